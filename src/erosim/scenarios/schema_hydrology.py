"""Schema of ``kind = "hydrology"`` scenario files (SPEC HY-1…HY-9).

::

    seed = 1
    [terrain]      generated or loaded heightmap (erosim.scenarios.schema_common.TerrainSection)
    [hydrology]    droplets, lakes, streams (erosim.hydrology.params.HydrologyParams), SI units
    [vegetation]   trees and roots (erosim.hydrology.params.VegetationParams)
    [inputs]       optional rain map (relative weights) and hardness map (0 = soft … 1 = rock)
    [run]          cycles, animation frames, checkpoint interval
"""

from __future__ import annotations

from erosim.core.config import Section, param
from erosim.hydrology.params import HydrologyParams, VegetationParams
from erosim.scenarios.schema_common import TerrainSection


class Inputs(Section):
    rain_map: str | None = param(
        None, doc="raster of relative rain (a heightmap format, terrain-sized); none = uniform"
    )
    hardness_map: str | None = param(
        None, doc="hardness raster in [0, 1] (GeoTIFF, PNG, .npy); erosion × (1 − hardness)"
    )


class HydrologyRun(Section):
    cycles: int = param(640, ge=1, unit="1", doc="hydrology cycles (droplet batches) to run")
    frames: int = param(24, ge=0, unit="1", doc="frames of figures/evolution.gif and maps/frames/ (0 = none)")
    checkpoint_interval: float = param(300.0, gt=0, unit="s", doc="wall time between checkpoints")


class HydrologyScenario(Section):
    seed: int = param(1, doc="random seed (terrain, droplets, vegetation)")
    terrain: TerrainSection = param(TerrainSection(preset="mountains", size=512, cell_size=20.0), doc="the heightmap")
    hydrology: HydrologyParams = param(HydrologyParams(), doc="droplets, lakes, streams")
    vegetation: VegetationParams = param(VegetationParams(), doc="trees")
    inputs: Inputs = param(Inputs(), doc="rain and hardness maps")
    run: HydrologyRun = param(HydrologyRun(), doc="run length and outputs")
