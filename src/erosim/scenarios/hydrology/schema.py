"""Schema of ``kind = "hydrology"`` scenario files (SPEC HY-1…HY-9).

::

    seed = 1
    [terrain]      generated or loaded heightmap (erosim.scenarios.schema_common.TerrainSection)
    [hydrology]    droplets, lakes, streams (erosim.hydrology.params.HydrologyParams), SI units
    [vegetation]   trees and roots (erosim.hydrology.params.VegetationParams)
    [inputs]       optional rain map (relative weights) and hardness map (0 = soft … 1 = rock)
    [run]          cycles, animation frames, checkpoint interval, device ("cpu" or "cuda")
    [tiles]        tiled builds of a large GeoTIFF (size 0 = one piece; docs/tiles.md)
"""

from __future__ import annotations

from typing import Literal

from pydantic import model_validator

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError
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
    device: Literal["cpu", "cuda"] = param(
        "cpu",
        doc="where the droplet batches descend: 'cpu' (Numba threads) or 'cuda' (an NVIDIA GPU, needs `pip install "
        "'erosim[cuda]'`; docs/hydrology.md); lakes, streams, creep and vegetation stay on the CPU",
    )


class Tiles(Section):
    size: int = param(
        0, ge=0, unit="cells", doc="tiled build: largest tile core, cells a side (0 = the whole map in one run)"
    )
    overlap: int = param(32, ge=0, unit="cells", doc="tiled build: halo cells around each tile (at most size/2)")
    rounds: int = param(
        8, ge=1, unit="1",
        doc="tiled build: passes over all tiles, each on the last one's heights and stream map and with the "
        "droplets that left its neighbours in the last (run.cycles split; water crossing B borders needs B + 1; "
        "8 or more give seams near an untiled run's; unset: 8, but at most one a cycle)",
    )  # fmt: skip
    member: str = param(
        "", doc="set by a tiled build for each of its tiles: the tile's exchange file (docs/tiles.md); leave empty"
    )

    def rounds_for(self, cycles: int) -> int:
        """The rounds of a build of ``cycles`` cycles: ``rounds`` where it is set, else its default but at most one
        a cycle (a short build needs no setting)."""
        return self.rounds if "rounds" in self.model_fields_set else max(1, min(self.rounds, cycles))


class HydrologyScenario(Section):
    seed: int = param(1, doc="random seed (terrain, droplets, vegetation)")
    terrain: TerrainSection = param(TerrainSection(preset="mountains", size=512, cell_size=20.0), doc="the heightmap")
    hydrology: HydrologyParams = param(HydrologyParams(), doc="droplets, lakes, streams")
    vegetation: VegetationParams = param(VegetationParams(), doc="trees")
    inputs: Inputs = param(Inputs(), doc="rain and hardness maps")
    run: HydrologyRun = param(HydrologyRun(), doc="run length and outputs")
    tiles: Tiles = param(Tiles(), doc="tiled builds of a DEM too large for one run (erosim.tiles)")

    @model_validator(mode="after")
    def _check_tiles(self) -> HydrologyScenario:
        t = self.tiles
        if t.size == 0:
            return self
        if not self.terrain.uses_file:
            raise ConfigError(
                "A tiled build (tiles.size, --tile) erodes a DEM file; give it with --set terrain.file=DEM.tif."
            )
        if t.size < 16 or 2 * t.overlap > t.size:
            raise ConfigError(
                f"tiles.size = {t.size} with tiles.overlap = {t.overlap} is not valid; give a size of at least 16 "
                "cells and an overlap of at most half the size."
            )
        if t.overlap < 2:
            raise ConfigError(
                f"tiles.overlap = {t.overlap} is too small for a tiled build; give at least 2 cells, the halo "
                "a droplet crossing a border steps into before it is passed to the neighbouring tile."
            )
        if self.hydrology.batch == 0:
            raise ConfigError(
                "A tiled build passes droplets between tiles on the batch path only; leave hydrology.batch unset "
                "(or > 0) instead of 0 (the simplehydrology-2020 preset's serial order)."
            )
        if self.run.device != "cpu":
            raise ConfigError(
                f"A tiled build passes droplets between tiles on the CPU only; leave run.device = 'cpu' instead of "
                f"'{self.run.device}' for a tiled build."
            )
        if self.inputs.rain_map or self.inputs.hardness_map:
            raise ConfigError(
                "A tiled build does not cut inputs.rain_map or inputs.hardness_map into tiles yet; leave them out "
                "or run without tiles."
            )
        if t.rounds_for(self.run.cycles) > self.run.cycles:
            raise ConfigError(
                f"tiles.rounds = {t.rounds} exceeds run.cycles = {self.run.cycles}; each round runs a share of the "
                "cycles, so give fewer rounds or more cycles."
            )
        return self
