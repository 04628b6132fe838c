"""Scenario kinds: which schema validates a scenario file and which builder turns it into a run.

A kind is a schema (a :class:`~erosim.core.config.Section`) and a builder
``setup(scenario, out) -> Setup`` (models, callbacks, stop time, report); every kind runs through
:func:`erosim.scenarios.runner.run`.

Import strings keep ``erosim list`` and ``--help`` fast (no Numba import until a run starts).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from erosim.core.errors import ConfigError


@dataclass(frozen=True)
class Kind:
    schema: str  # "module:Class", a Section subclass
    builder: str  # "module:function", setup(scenario, out) -> erosim.scenarios.setup.Setup


KINDS: dict[str, Kind] = {
    "sph": Kind("erosim.scenarios.schema_sph:SPHScenario", "erosim.scenarios.builders_sph:setup"),
    "hydrology": Kind(
        "erosim.scenarios.schema_hydrology:HydrologyScenario", "erosim.scenarios.builders_hydrology:setup"
    ),
    "particle-stream": Kind("erosim.scenarios.schema_stream:StreamScenario", "erosim.scenarios.builders_stream:setup"),
    "sph-terrain": Kind(
        "erosim.scenarios.schema_sph_terrain:SPHTerrainScenario", "erosim.scenarios.builders_sph_terrain:setup"
    ),
    "flood": Kind("erosim.scenarios.schema_flood:FloodScenario", "erosim.scenarios.builders_flood:setup"),
    "splash": Kind("erosim.scenarios.schema_splash:SplashScenario", "erosim.scenarios.builders_splash:setup"),
    "voxel": Kind("erosim.scenarios.schema_voxel:VoxelScenario", "erosim.scenarios.builders_voxel:setup"),
}


def resolve(target: str) -> Any:
    """Import ``"package.module:attribute"`` and return the attribute."""
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def get(kind: str) -> Kind:
    if kind not in KINDS:
        raise ConfigError(f"Unknown scenario kind '{kind}'; use one of: {', '.join(sorted(KINDS))}.")
    return KINDS[kind]
