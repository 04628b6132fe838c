"""Schema of ``kind = "particle-stream"`` scenarios (Warszawski particle-stream erosion, SPEC ST).

::

    seed = 1
    [terrain]                 # erosim.scenarios.schema_common.TerrainSection (generated or a DEM)
    [hardness]                # where D comes from: file | strata | noise | classes | uniform
    source = "auto"           # auto: file when hardness.file is set, else strata
    thickness = [...]         # strata: band thicknesses (m), bottom to top, repeating
    values = [...]            # strata: band hardness in [0, 1]
    [stream]                  # pool, length unit, batch
    [emitters.main]           # one table per emitter (erosion.particle_stream_warszawski.Emitter)
    [emitters.side] ...

``--set hardness.file=PATH`` alone switches to a hardness map from a file; ``--set
emitters.main.particles=50000`` changes one emitter; ``--set emitters.extra.y=0.2`` adds one.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError
from erosim.erosion.particle_stream_warszawski import Emitter
from erosim.scenarios.schema_common import TerrainSection
from erosim.terrain.hardness import MATERIALS


class HardnessSection(Section):
    """The hardness map D (ST-1): 1 = unerodible, 0 = fully erodible."""

    source: Literal["auto", "file", "strata", "noise", "classes", "uniform"] = param(
        "auto", doc="auto (file when `file` is set, else strata) | file | strata | noise | classes | uniform"
    )
    file: str | None = param(None, doc="hardness raster (GeoTIFF, PNG 8/16-bit, .npy), same size as the terrain")
    thickness: list[float] = param([30.0, 12.0, 20.0, 8.0], unit="m", doc="strata: band thicknesses, bottom up")
    values: list[float] = param([0.25, 0.85, 0.45, 0.7], unit="1", doc="strata: hardness of each band")
    base: float = param(0.0, unit="m", doc="strata: height where the first band starts")
    tilt_x: float = param(0.0, unit="m/m", doc="strata: dip of the layers, metres per metre eastward")
    tilt_y: float = param(0.0, unit="m/m", doc="strata: dip of the layers, metres per metre northward")
    follow_cut: bool = param(True, doc="strata: a lowered cell takes the hardness of the band it is cut down to")
    noise_scale: float = param(16.0, gt=0, unit="cells", doc="noise: feature size (Gaussian sigma)")
    low: float = param(0.1, ge=0, le=1, unit="1", doc="noise: softest value")
    high: float = param(0.9, ge=0, le=1, unit="1", doc="noise: hardest value")
    class_file: str | None = param(None, doc="classes: integer class raster (GeoTIFF, PNG, .npy)")
    materials: dict[str, str | float] = param(
        {}, doc="classes: class number -> material name (" + ", ".join(MATERIALS) + ") or hardness"
    )
    value: float = param(0.5, ge=0, le=1, unit="1", doc="uniform: the hardness everywhere")

    @property
    def kind(self) -> str:
        if self.source == "auto":
            return "file" if self.file else "strata"
        return self.source

    @model_validator(mode="after")
    def _check(self) -> HardnessSection:
        if self.kind == "file" and not self.file:
            raise ConfigError("hardness.source is 'file' but hardness.file is not set; give --set hardness.file=PATH.")
        if self.kind == "strata":
            if not self.thickness or len(self.thickness) != len(self.values):
                raise ConfigError(
                    f"hardness.thickness has {len(self.thickness)} bands but hardness.values has "
                    f"{len(self.values)}; give one hardness per band."
                )
            if min(self.thickness) <= 0:
                raise ConfigError("Every hardness.thickness must be positive (metres); fix the list.")
            if min(self.values) < 0 or max(self.values) > 1:
                raise ConfigError(
                    f"hardness.values {self.values} must lie in [0, 1] (0 = fully erodible, 1 = unerodible)."
                )
        if self.kind == "noise" and self.low > self.high:
            raise ConfigError(f"hardness.low = {self.low:g} is above hardness.high = {self.high:g}; swap them.")
        if self.kind == "classes":
            if not self.class_file:
                raise ConfigError("hardness.source is 'classes' but hardness.class_file is not set; give its path.")
            for key, mat in self.materials.items():
                try:
                    int(key)
                except ValueError:
                    raise ConfigError(
                        f'hardness.materials key \'{key}\' is not a class number; use e.g. "3" = "shale".'
                    ) from None
                if isinstance(mat, str) and mat not in MATERIALS:
                    raise ConfigError(
                        f"hardness.materials: unknown material '{mat}'; use one of {', '.join(MATERIALS)}."
                    )
                if not isinstance(mat, str) and not 0 <= mat <= 1:
                    raise ConfigError(f"hardness.materials: class {key} hardness {mat} is outside [0, 1].")
        return self


class StreamSection(Section):
    """How the stream is run."""

    pool: int = param(64, ge=1, le=65536, unit="particles", doc="particles in flight per emitter (pool size)")
    length_unit: Literal["cells", "m"] = param(
        "cells",
        doc="unit of the emitters' width, length, speed, max_speed, radius_per_mass, pivot_offset, depth_per_mass",
    )
    impacts_per_batch: int = param(
        200_000, ge=1, unit="impacts", doc="work between progress updates and checkpoint checks"
    )
    checkpoint_wall_s: float = param(300.0, gt=0, unit="s", doc="wall time between checkpoints")


class StreamScenario(Section):
    """A particle-stream erosion run: terrain, hardness, one or several emitters."""

    seed: int = param(1, doc="random seed (same seed, inputs and settings give the same result)")
    terrain: TerrainSection = Field(default_factory=lambda: TerrainSection(preset="plateau"))
    hardness: HardnessSection = Field(default_factory=HardnessSection)
    stream: StreamSection = Field(default_factory=StreamSection)
    emitters: dict[str, Emitter] = Field(default_factory=lambda: {"main": Emitter()})

    @model_validator(mode="after")
    def _check(self) -> StreamScenario:
        if not self.emitters:
            raise ConfigError("The scenario has no emitter; add an [emitters.main] table.")
        return self
