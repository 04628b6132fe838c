"""Schema of ``kind = "sph-terrain"`` scenarios: an SPH fluid on a heightmap that it erodes (seed 000,
SPEC HM-1…HM-4, ER-1…ER-5).

::

    seed = 1
    [terrain]          the DEM (erosim.scenarios.schema_common.TerrainSection): generated or a file
    [profile]          2-D instead: a flume's bed along x (length, cell size, height, slope)
    [sph]              solver parameters (erosim.sph.params.SPHParams); walls are the ground and edges
    [ground]           heightfield (particle-free, default) | particles; bedrock; nodata wall height
    [edges]            outflow = ["east", ...]: open edges (water leaving is removed and counted)
    [water]            level (m) and seed = [x, y]: a lake filling the basin around the seed
    [[fluid]]          boxes of water (lo, hi in the DEM's coordinates and metres of height)
    [inflows.NAME]     point inflows: position [x, y], discharge (m³/s), radius, height
    [rain]             rate (mm/h), file (rain map: per-cell chance 0…1) or a generated pattern
    [erosion]          transport-capacity erosion (erosion.transport_capacity_mei2007), every N steps
    [run]              t_end, particle frames, map frames, checkpoints
    [measure]          surge front (2-D dam breaks)

Every horizontal position (water.seed, fluid boxes, inflows) is in the DEM's own coordinates (its
CRS units; for a generated terrain, metres from its south-west corner); heights are metres.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError
from erosim.erosion.transport_capacity_mei2007 import TransportCapacityParams
from erosim.scenarios.schema_common import TerrainSection, with_sph_defaults
from erosim.scenarios.sph.schema import FluidBlock, Measure
from erosim.sph.params import SPHParams


class ProfileSection(Section):
    """A 2-D fluid's bed: heights along x (a flume); used instead of [terrain] when given."""

    length: float = param(..., gt=0, unit="m", doc="length of the bed")
    cell_size: float = param(..., gt=0, unit="m", doc="spacing of the bed's height nodes")
    height: float = param(0.0, unit="m", doc="bed height at x = 0")
    slope: float = param(0.0, unit="m/m", doc="bed slope (height gained per metre along x)")


class GroundSection(Section):
    """How the terrain acts on the fluid."""

    model: Literal["heightfield", "particles"] = param(
        "heightfield",
        doc="'heightfield': particle-free wall from the Q4 surface (memory ∝ fluid); 'particles': fixed "
        "boundary particles laid under the surface (SPEC HM-4)",
    )
    bedrock_depth: float | None = param(None, gt=0, unit="m", doc="erodible depth below the initial ground")
    bedrock_file: str | None = param(None, doc="raster of bedrock heights (m), the terrain's size")
    nodata_wall: float = param(50.0, gt=0, unit="m", doc="nodata cells stand this high above the highest ground")


class EdgesSection(Section):
    outflow: list[Literal["west", "east", "south", "north"]] = param(
        [], doc="open map edges: water crossing them leaves (counted); the other edges are walls"
    )


class WaterSection(Section):
    level: float | None = param(None, unit="m", doc="initial lake surface height (none: no lake)")
    seed: list[float] | None = param(
        None, unit="m", doc="a point in the lake, [x, y] in the DEM's coordinates (2-D: [x]); none: every basin"
    )


class InflowSection(Section):
    position: list[float] = param(..., unit="m", doc="[x, y] in the DEM's coordinates (2-D: [x])")
    discharge: float = param(..., gt=0, unit="m3/s", doc="water added per second (2-D: m²/s per unit width)")
    radius: float = param(0.0, ge=0, unit="m", doc="radius of the jet's disc (0: one particle spacing)")
    height: float = param(1.0, ge=0, unit="m", doc="height of the jet's mouth above the ground")


class RainSection(Section):
    rate: float = param(0.0, ge=0, unit="mm/h", doc="rain intensity where the rain map is 1 (0: no rain)")
    file: str | None = param(
        None, doc="rain map raster: per cell the chance 0…1 that a drop falls there (ER-4); an image is scaled to 0…1"
    )
    pattern: Literal["uniform", "noise"] = param("noise", doc="rain map when no file: uniform, or noise blobs")
    noise_scale: float = param(8.0, gt=0, unit="cells", doc="size of the generated rain map's blobs")
    height: float = param(2.0, ge=0, unit="m", doc="drops appear this high above the ground or the water")
    every: int = param(10, ge=1, unit="steps", doc="SPH steps between two showers (the rain due is added then)")


class ErosionSection(TransportCapacityParams):
    enabled: bool = param(True, doc="transport-capacity erosion on (false: the fluid only)")
    every: int = param(20, ge=1, unit="steps", doc="SPH steps between two erosion updates (the coupler)")


class TerrainRun(Section):
    t_end: float = param(10.0, gt=0, unit="s", doc="simulated time to reach")
    output_interval: float = param(0.0, ge=0, unit="s", doc="particle frames (.vtp) every this long; 0: none")
    map_frames: int = param(8, ge=0, le=200, unit="1", doc="three-panel map frames over the run (figures, GIF)")
    sample_interval: float = param(0.01, gt=0, unit="s", doc="surge front sampled every this long (2-D)")
    checkpoint_wall_s: float = param(300.0, gt=0, unit="s", doc="wall-clock time between checkpoints")


class SPHTerrainScenario(Section):
    seed: int = param(1, ge=0, doc="random seed (terrain, rain)")
    terrain: TerrainSection = Field(default_factory=lambda: TerrainSection(preset="hills", size=64, cell_size=2.0))
    profile: ProfileSection | None = None
    sph: SPHParams = Field(default_factory=lambda: SPHParams(dim=3, walls="reflect", spacing=1.0))
    ground: GroundSection = Field(default_factory=GroundSection)
    edges: EdgesSection = Field(default_factory=EdgesSection)
    water: WaterSection = Field(default_factory=WaterSection)
    fluid: list[FluidBlock] = []
    inflows: dict[str, InflowSection] = {}
    rain: RainSection = Field(default_factory=RainSection)
    erosion: ErosionSection = Field(default_factory=ErosionSection)
    run: TerrainRun = Field(default_factory=TerrainRun)
    measure: Measure = Field(default_factory=Measure)

    @property
    def dim(self) -> int:
        return 2 if self.profile is not None else 3

    @model_validator(mode="before")
    @classmethod
    def _derive(cls, data):
        """``sph.dim`` from the geometry (2 with a [profile]); boundary walls are the ground's business."""
        if not isinstance(data, dict):
            return data
        if data.get("profile"):
            return with_sph_defaults(data, dim=2, walls="reflect")
        # metre-sized particles on a terrain (a flume keeps SPH's 1 cm)
        return with_sph_defaults(data, dim=3, spacing=1.0, walls="reflect")

    @model_validator(mode="after")
    def _check(self) -> SPHTerrainScenario:
        d = self.dim
        if self.sph.dim != d:
            raise ConfigError(
                f"sph.dim = {self.sph.dim} but the scenario is {d}-D ({'a [profile]' if d == 2 else 'a [terrain]'}); "
                "leave sph.dim out."
            )
        if self.sph.walls != "reflect":
            raise ConfigError(
                "In sph-terrain scenarios the ground and the map edges are the walls; set ground.model "
                "('heightfield' or 'particles') and edges.outflow instead of sph.walls."
            )
        if d == 2 and self.rain.rate > 0:
            raise ConfigError("Rain needs a 3-D terrain; use [terrain] instead of [profile], or set rain.rate = 0.")
        if self.water.seed is not None and len(self.water.seed) != d - 1:
            raise ConfigError(f"water.seed has {len(self.water.seed)} coordinates; give {d - 1} (horizontal).")
        if self.water.seed is not None and self.water.level is None:
            raise ConfigError("water.seed is set but water.level is not; give the lake's surface height.")
        for name, inf in self.inflows.items():
            if len(inf.position) != d - 1:
                raise ConfigError(f"inflows.{name}.position has {len(inf.position)} coordinates; give {d - 1}.")
        for i, b in enumerate(self.fluid):
            if len(b.lo) != d or len(b.hi) != d or any(h <= lo for lo, h in zip(b.lo, b.hi, strict=True)):
                raise ConfigError(f"fluid block {i + 1} needs lo < hi with {d} coordinates each.")
        if d == 2 and any(e in ("south", "north") for e in self.edges.outflow):
            raise ConfigError("A 2-D profile has only west and east edges; edges.outflow can name those.")
        self.erosion.check()
        return self
