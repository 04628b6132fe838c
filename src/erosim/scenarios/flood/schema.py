"""Schema of ``kind = "flood"`` scenarios: a dam-break flood over a DEM with hazard maps (seed 000 §3.3,
SPEC FL-1…FL-4).

::

    seed = 1
    [terrain]      the DEM (erosim.scenarios.schema_common.TerrainSection); nodata cells are walls
    [reservoir]    level (m), seed = [x, y], barrier = [[x, y], …] (the dam's line when the DEM has none)
    [breach]       bottom_width, floor, side_slope, line = [[x0, y0], [x1, y1]] (optional window)
    [outflow]      edges = ["east", …]: open map edges (water leaving is removed and counted)
    [flood]        solver ("swe"), spacing, manning (or manning_file), wet_depth, the solver's settings
    [hazard]       inside = [[x, y], …]: a polygon whose flooded area and class shares are reported too
    [gauges]       file = "gauges.csv" (columns name,x,y)
    [run]          t_end, sample_interval, map_frames, checkpoint_wall_s, device ("cpu" or "cuda")

Every horizontal position is in the DEM's own coordinates (its CRS units; a generated terrain's are
metres from its north-west corner, as :func:`erosim.core.heightmap.default_transform` lays it out).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError
from erosim.scenarios.schema_common import TerrainSection
from erosim.sph.shallow_water_vacondio2012 import ShallowWaterParams
from erosim.terrain.reservoir import Breach


class ReservoirSection(Section):
    level: float = param(..., unit="m", doc="the reservoir's water surface elevation")
    seed: list[float] = param(..., unit="map units", doc="[x, y]: a point in the reservoir, in the DEM's coordinates")
    barrier: list[list[float]] | None = param(
        None,
        unit="map units",
        doc="the dam's line [[x0, y0], [x1, y1], …] when the DEM has no dam: a wall, open only where the breach is",
    )


class OutflowSection(Section):
    edges: list[Literal["west", "east", "north", "south"]] = param(
        [], doc="open map edges: water crossing them leaves the run (counted); the others are walls"
    )


class FloodSection(ShallowWaterParams):
    solver: Literal["swe", "sph3d"] = param(
        "swe",
        doc="'swe': shallow-water SPH (Vacondio et al. 2012), for valleys; 'sph3d': the thesis's 3-D SPH on the "
        "heightfield ground, for local detail (particles ∝ volume/spacing³)",
    )
    spacing: float | None = param(
        None,
        gt=0,
        unit="m",
        doc="particle spacing where the reservoir has its mean depth (equal volumes: denser where deeper); "
        "default two DEM cells",
    )
    settle_steps: int = param(
        600, ge=0, unit="1", doc="the reservoir settles (damped, dam closed) for at most this many steps before t = 0"
    )
    settle_speed: float = param(0.05, gt=0, unit="m/s", doc="settling stops once no particle is faster than this")
    manning: float = param(
        0.035, ge=0, le=1, unit="s/m^(1/3)", doc="Manning's n everywhere, for both solvers (see manning_file)"
    )
    manning_file: str | None = param(None, doc="a raster of Manning's n on the DEM's grid (replaces manning)")
    wet_depth: float = param(0.01, gt=0, unit="m", doc="cells shallower than this count as dry in the hazard maps")


class HazardSection(Section):
    inside: list[list[float]] | None = param(
        None, unit="map units", doc="a polygon [[x, y], …] (e.g. downstream of the dam): its own area and shares"
    )


class GaugesSection(Section):
    file: str | None = param(None, doc="CSV with columns name,x,y (the DEM's coordinates)")


class FloodRun(Section):
    t_end: float = param(600.0, gt=0, unit="s", doc="simulated time to reach")
    sample_interval: float = param(5.0, gt=0, unit="s", doc="gauges sampled every this long")
    map_frames: int = param(12, ge=0, le=200, unit="1", doc="depth frames over the run (figures, GIF; maps/frames/)")
    output_interval: float = param(0.0, ge=0, unit="s", doc="particle frames (.vtp) every this long; 0: none")
    checkpoint_wall_s: float = param(300.0, gt=0, unit="s", doc="wall-clock time between checkpoints")
    device: Literal["cpu", "cuda"] = param(
        "cpu", doc="where the shallow-water SPH steps run: 'cpu' or 'cuda' (an NVIDIA GPU; docs/gpu.md)"
    )


class FloodScenario(Section):
    seed: int = param(1, ge=0, doc="random seed (a generated terrain)")
    terrain: TerrainSection = Field(default_factory=TerrainSection)
    reservoir: ReservoirSection
    breach: Breach | None = None
    outflow: OutflowSection = Field(default_factory=OutflowSection)
    flood: FloodSection = Field(default_factory=FloodSection)
    hazard: HazardSection = Field(default_factory=HazardSection)
    gauges: GaugesSection = Field(default_factory=GaugesSection)
    run: FloodRun = Field(default_factory=FloodRun)

    @model_validator(mode="after")
    def _check(self) -> FloodScenario:
        if len(self.reservoir.seed) != 2:
            raise ConfigError(f"reservoir.seed has {len(self.reservoir.seed)} coordinates; give [x, y].")
        if self.reservoir.barrier is not None and (
            len(self.reservoir.barrier) < 2 or any(len(p) != 2 for p in self.reservoir.barrier)
        ):
            raise ConfigError("reservoir.barrier needs at least two points [x, y]; e.g. [[x0, y0], [x1, y1]].")
        if self.hazard.inside is not None and (
            len(self.hazard.inside) < 3 or any(len(p) != 2 for p in self.hazard.inside)
        ):
            raise ConfigError("hazard.inside needs at least three points [x, y] (a polygon).")
        return self
