"""Schema of ``kind = "voxel"`` scenarios: SPH water scouring a voxel terrain (seed 001, SPEC VX-1…VX-10).

::

    seed = 1
    [terrain]      shape = "flume": a flat flume floor at z = 0, side walls at y = 0 and y = width, an
                   upstream wall at x = 0, open downstream at x = length; or "heightmap": the rest of
                   [terrain] (a generated terrain or a DEM: schema_common.TerrainSection) as voxels, open edges;
                   voxels_file: start from a saved field instead
    [caves]        noise caves carved into the heightmap (wavelength, threshold, below)
    [rain]         rain on the heightmap as drops of 5 particles (rate mm/h)
    [embankment]   a trapezoid across the flume (erosim.terrain.voxel.Embankment): toe, height, crest, slopes
    [voxels]       cell size and the density ramp's half-width (0: the narrowest the wall allows)
    [sph]          solver parameters (erosim.sph.params.SPHParams); the walls are the field and the planes
    [water]        the reservoir at rest upstream of the embankment: its level
    [inflow]       the reservoir's filling: discharge (m³/s) laid at rest on its surface over x0…x1
    [inflows.NAME] on a heightmap, a river's source: a vertical jet of ``discharge`` m³/s at ``position``
                   (the terrain's frame), ``height`` m above the ground (erosim.coupling.sources.PointInflow)
    [erosion]      shear-stress erosion every ``every`` steps: the seed's law (law = "kristof2009",
                   erosion.shear_stress_kristof2009) or the excess bed shear stress in pascals (law =
                   "excess_shear", erosion.excess_shear_partheniades1965); what it removes carried off
                   at once, or with sediment = "suspended" carried by the particles and settling back
                   (erosion.settling_voxel: settling_velocity, max_concentration)
    [run]          t_end, output interval (meshes, field, particle frames), profile interval and formats

Positions are metres in the flume's frame: x along the flume from its upstream wall, y across, z up
from the floor.
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, field_validator, model_validator

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError
from erosim.erosion.excess_shear_partheniades1965 import ExcessShearParams
from erosim.scenarios.schema_common import TerrainSection, with_sph_defaults
from erosim.scenarios.schema_common import build_terrain as heightmap
from erosim.scenarios.sph_terrain.schema import InflowSection as JetSection
from erosim.sph.params import SPHParams


class VoxelTerrainSection(TerrainSection):
    """The terrain: a flume, or a heightmap (the fields of schema_common.TerrainSection: a generated
    terrain or ``file``, any DEM the project reads) as voxels."""

    shape: Literal["flume", "heightmap"] = param(
        "flume", doc="the terrain: 'flume' (a floor, side walls, an embankment) or 'heightmap' ([heightmap] as voxels)"
    )
    voxels_file: str | None = param(None, doc="start from this saved density field (.npz of a run's fields/), e.g. "
                                    "the end of an earlier run")  # fmt: skip
    length: float = param(1.6, gt=0, unit="m", doc="flume length (x); the downstream end is open")
    width: float = param(0.12, gt=0, unit="m", doc="flume width (y) between its side walls")
    top: float = param(0.5, gt=0, unit="m", doc="height of the voxel grid above the floor")


class EmbankmentSection(Section):
    x_toe: float = param(0.4, ge=0, unit="m", doc="x of the upstream toe")
    height: float = param(0.2, gt=0, unit="m", doc="height of the crest above the base")
    crest_width: float = param(0.1, ge=0, unit="m", doc="crest width along the flume")
    upstream: float = param(2.0, gt=0, unit="m/m", doc="upstream slope, horizontal:vertical")
    downstream: float = param(2.0, gt=0, unit="m/m", doc="downstream slope, horizontal:vertical")
    base: float = param(0.0, ge=0, unit="m", doc="height of the embankment's base above the floor (a plinth)")


class VoxelsSection(Section):
    cell_size: float = param(0.02, gt=0, unit="m", doc="voxel size Δ (no larger than the kernel support h)")
    band: float = param(0.0, ge=0, unit="m", doc="density ramp half-width; 0 = h + √3Δ plus 5 % (the least the "
                        "wall-weight distance needs)")  # fmt: skip
    depth: float = param(0.0, ge=0, unit="m", doc="a heightmap's field reaches at least this far below its lowest "
                         "ground (room for caves); 0: the ramp and two cells")  # fmt: skip
    iso: float = param(0.5, unit="1", doc="iso level of the surface in the density range (0 air, 1 solid)")
    max_bytes: int = param(4 << 30, gt=0, unit="B", doc="refuse a field larger than this in memory")
    attraction: float | str = param(
        "none", unit="kg/m^3", doc="the wall's attraction (SPEC VX-5): below this density ρ₁ a particle's wall "
        "pressure blends towards the attractive curve, so water is drawn into scoured hollows; 'seed' = ρ₀ plus one "
        "particle's own density contribution (the seed's choice), 'none' = repulsion only",
    )  # fmt: skip

    @field_validator("attraction", mode="before")
    @classmethod
    def _attraction(cls, v):
        if isinstance(v, str) and v in ("seed", "none"):
            return v
        if isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0:
            return float(v)
        raise ValueError("give ρ₁ as a positive density in kg/m³, or 'seed' or 'none'")
    scale: Literal["set", "dem"] = param(
        "set", doc="'dem': voxels and particles at the heightmap's own cell size (voxels.cell_size and sph.spacing "
        "follow it); what --set terrain.file=… gives a library scene unless either is set too",
    )  # fmt: skip


class CavesSection(Section):
    wavelength: float = param(0.0, ge=0, unit="m", doc="size of the noise caves carved into a heightmap (0: none)")
    threshold: float = param(0.3, unit="1", doc="caves where the 3-D noise exceeds this (higher: fewer caves)")
    below: float | None = param(None, unit="m", doc="caves only under this height (none: anywhere)")
    octaves: int = param(3, ge=1, le=8, unit="1", doc="noise octaves")


class RainSection(Section):
    rate: float = param(0.0, ge=0, unit="mm/h", doc="rain intensity over the whole map (0: none)")
    height: float = param(1.0, ge=0, unit="m", doc="drops appear this high above the highest ground")
    every: int = param(20, ge=1, unit="steps", doc="SPH steps between two showers (the rain due is added then)")


class WaterSection(Section):
    level: float | None = param(None, unit="m", doc="initial water level: the flume's reservoir, or every hollow "
                                "of a heightmap below it (none: no water at the start)")  # fmt: skip


class InflowSection(Section):
    discharge: float = param(0.0, ge=0, unit="m3/s", doc="water added to the reservoir per second, laid at rest on "
                             "its surface (0: none)")  # fmt: skip
    x0: float = param(0.0, ge=0, unit="m", doc="upstream end of the area it is laid on")
    x1: float = param(0.2, gt=0, unit="m", doc="downstream end of that area")


class VoxelJetSection(JetSection):
    position: list[float] = param(..., unit="m", doc="[x, y] in the terrain's frame: metres from its south-west node")


class VoxelErosion(ExcessShearParams):
    enabled: bool = param(True, doc="shear-stress erosion on (false: the fluid only)")
    law: Literal["kristof2009", "excess_shear"] = param(
        "kristof2009", doc="the erosion law: the seed's shear rate of Krištof et al. (k_eps, tau_c, k, n, radius, "
        "l_min, parallel; SPEC VX-6), or the excess bed shear stress ε = k_d (τ_b − τ_c) with τ_b from a "
        "rough-wall log law (erodibility, critical_stress in Pa, roughness; docs/voxel.md)")  # fmt: skip
    start: float = param(1.0, ge=0, unit="s", doc="no erosion before this time: the fluid laid on a lattice settles")
    sediment: Literal["carried_off", "suspended"] = param(
        "carried_off", doc="what the water does with the ground it removes: 'carried_off' at once (the seed's), or "
        "'suspended' on the particles, settling back (erosion.settling_voxel)")  # fmt: skip
    settling_velocity: float = param(0.02, gt=0, unit="m/s", doc="w_s of the suspended load (erosion.sediment = "
                                     "'suspended'); 0.02 m/s: quartz sand of about 0.2 mm")  # fmt: skip
    max_concentration: float = param(0.2, gt=0, le=1, unit="1", doc="the most ground a particle carries, as a "
                                     "fraction of its volume (erosion.sediment = 'suspended'; 0.2: the start of "
                                     "hyperconcentrated flow); what full water cannot take is not eroded")  # fmt: skip


class VoxelRun(Section):
    t_end: float = param(60.0, gt=0, unit="s", doc="simulated time to reach")
    output_interval: float = param(10.0, ge=0, unit="s", doc="meshes, density field and particle frames every "
                                   "this long (0: at the start and the end only)")  # fmt: skip
    profile_interval: float = param(1.0, gt=0, unit="s", doc="centre-line profiles (profiles.csv) every this long")
    figure_interval: float = param(20.0, gt=0, unit="s", doc="profiles drawn in figures/profiles.png every this long "
                                   "(morphological time: flow time × erosion.morfac)")  # fmt: skip
    meshes: list[Literal["obj", "ply", "glb"]] = param(["glb"], doc="surface mesh formats written per output time")
    field_format: Literal["npz", "vti"] = param("npz", doc="density field format per output time")
    particle_frames: bool = param(True, doc="particle frames (.vtp) per output time")
    sections: bool = param(False, doc="a cross-section figure per output time (figures/section_NNNN.png), the "
                           "surface at the start of the run dashed")  # fmt: skip
    surface_figure: bool = param(False, doc="figures/surface.png at the end: the surface at the start and at the "
                                 "end (coloured by its lowering), the water as dots")  # fmt: skip
    section_axis: Literal["x", "y"] = param("y", doc="the section's plane is across this axis")
    section_at: float | None = param(None, unit="m", doc="where along that axis (none: the middle)")
    checkpoint_wall_s: float = param(300.0, gt=0, unit="s", doc="wall-clock time between checkpoints")


class VoxelScenario(Section):
    seed: int = param(1, ge=0, doc="random seed")
    terrain: VoxelTerrainSection = Field(
        default_factory=lambda: VoxelTerrainSection(preset="mountains", size=32, cell_size=1.0)
    )
    embankment: EmbankmentSection = Field(default_factory=EmbankmentSection)
    heightmap: TerrainSection = Field(
        default_factory=lambda: TerrainSection(preset="mountains", size=32, cell_size=1.0)
    )
    caves: CavesSection = Field(default_factory=CavesSection)
    rain: RainSection = Field(default_factory=RainSection)
    voxels: VoxelsSection = Field(default_factory=VoxelsSection)
    sph: SPHParams = Field(default_factory=lambda: SPHParams(dim=3, walls="reflect", spacing=0.02))
    water: WaterSection = Field(default_factory=WaterSection)
    inflow: InflowSection = Field(default_factory=InflowSection)
    inflows: dict[str, VoxelJetSection] = Field(default_factory=dict)
    erosion: VoxelErosion = Field(default_factory=VoxelErosion)
    run: VoxelRun = Field(default_factory=VoxelRun)

    @model_validator(mode="before")
    @classmethod
    def _derive(cls, data):
        return with_sph_defaults(data, dim=3, spacing=0.02, walls="reflect")

    @model_validator(mode="after")
    def _check(self) -> VoxelScenario:
        if self.sph.dim != 3:
            raise ConfigError("A voxel terrain is a 3-D wall; leave sph.dim out (or set it to 3).")
        if self.sph.walls != "reflect":
            raise ConfigError(
                "In voxel scenarios the terrain and the flume's planes are the walls; leave sph.walls out."
            )
        f, e = self.terrain, self.embankment
        if f.shape == "heightmap":
            if self.inflow.discharge > 0:
                raise ConfigError(
                    "[inflow] enters a flume's upstream wall; on a heightmap use [rain], [inflows.NAME] or water.level."
                )
            return self
        if self.inflows:
            raise ConfigError("[inflows.NAME] jets stand on a heightmap; a flume is fed by [inflow].")
        if self.voxels.scale == "dem":
            raise ConfigError("voxels.scale = 'dem' takes a heightmap's cell size; a flume has none: leave it 'set'.")
        heel = e.x_toe + e.height * (e.upstream + e.downstream) + e.crest_width
        if heel >= f.length:
            raise ConfigError(
                f"The embankment reaches x = {heel:g} m, beyond the flume's end at {f.length:g} m; lengthen "
                "terrain.length or move embankment.x_toe upstream."
            )
        if e.base + e.height >= f.top:
            raise ConfigError(
                f"The embankment's crest ({e.base + e.height:g} m) is above terrain.top; raise terrain.top."
            )
        i = self.inflow
        if i.discharge > 0 and not (i.x0 < i.x1 <= e.x_toe):
            raise ConfigError(
                "The inflow's area must lie upstream of the embankment: give inflow.x0 < inflow.x1 ≤ embankment.x_toe."
            )
        if self.sph.spacing > f.width / 2:
            raise ConfigError(
                f"sph.spacing = {self.sph.spacing:g} m leaves fewer than two particles across the {f.width:g} m "
                "flume; use a smaller spacing or a wider flume."
            )
        return self


# ------------------------------------------------------------------ quantities derived from the settings
#: the wall-weight distance must be right out to h; the ramp gets this margin over h + √3Δ
BAND_MARGIN = 1.05


def band_for(cfg: VoxelScenario) -> float:
    """The density ramp's half-width: ``voxels.band``, or the least the wall allows (h + √3Δ) plus 5 %."""
    if cfg.voxels.band > 0:
        return cfg.voxels.band
    return BAND_MARGIN * (cfg.sph.support() + math.sqrt(3.0) * cfg.voxels.cell_size)


def at_dem_scale(cfg: VoxelScenario) -> VoxelScenario:
    """``cfg`` with ``voxels.scale = "dem"`` resolved: voxels and particles at the heightmap's own cell size
    (``voxels.cell_size`` = ``sph.spacing`` = the DEM's cells; h = 2 cells, so the voxels fit the kernel
    support). A library scene's sizes describe its generated terrain; on a user's DEM they would give
    millions of nodes per cell of a 30 m map or a handful on a 0.5 m one. Unchanged for ``"set"``."""
    if cfg.voxels.scale != "dem" or cfg.terrain.voxels_file:
        return cfg

    cell = float(heightmap(cfg.terrain, cfg.seed).cell_size)
    return cfg.model_copy(update={
        "voxels": cfg.voxels.model_copy(update={"cell_size": cell, "scale": "set"}),
        "sph": cfg.sph.model_copy(update={"spacing": cell}),
    })  # fmt: skip


def overflow_head(discharge: float, width: float, g: float = 9.81) -> float:
    """The water's height over a broad crest passing ``discharge`` across ``width``: 3/2 of the critical
    depth, H = 1.5 (q²/g)^(1/3), q = Q/width (m)."""
    q = discharge / width
    return 1.5 * (q * q / g) ** (1.0 / 3.0)
