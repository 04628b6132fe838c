"""Scenario kinds: which schema validates a scenario file and which builder turns it into a run.

A kind is a folder ``scenarios/<kind>/``: a schema (``schema.py``, a :class:`~erosim.core.config.Section`),
a builder that only wires (``build.py``, ``setup(scenario, out) -> Setup``: models, callbacks, stop time,
report) and what the run writes (``outputs.py``); every kind runs through
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


def _kind(folder: str, schema_class: str) -> Kind:
    """A kind laid out as ``scenarios/<folder>/{schema, build, outputs}.py``."""
    return Kind(f"erosim.scenarios.{folder}.schema:{schema_class}", f"erosim.scenarios.{folder}.build:setup")


KINDS: dict[str, Kind] = {
    "sph": _kind("sph", "SPHScenario"),
    "hydrology": _kind("hydrology", "HydrologyScenario"),
    "particle-stream": _kind("particle_stream", "StreamScenario"),
    "sph-terrain": _kind("sph_terrain", "SPHTerrainScenario"),
    "flood": _kind("flood", "FloodScenario"),
    "splash": _kind("splash", "SplashScenario"),
    "voxel": _kind("voxel", "VoxelScenario"),
}


def resolve(target: str) -> Any:
    """Import ``"package.module:attribute"`` and return the attribute."""
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def get(kind: str) -> Kind:
    if kind not in KINDS:
        raise ConfigError(f"Unknown scenario kind '{kind}'; use one of: {', '.join(sorted(KINDS))}.")
    return KINDS[kind]
