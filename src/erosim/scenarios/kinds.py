"""Scenario kinds: which schema validates a scenario file and which runner runs it.

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
    runner: str  # "module:function", run(scenario, out, *, resume, progress) -> dict


KINDS: dict[str, Kind] = {
    "sph": Kind("erosim.scenarios.schema_sph:SPHScenario", "erosim.simulation.sph_run:run"),
    "hydrology": Kind("erosim.scenarios.schema_hydrology:HydrologyScenario", "erosim.simulation.hydrology_run:run"),
    "particle-stream": Kind("erosim.scenarios.schema_stream:StreamScenario", "erosim.simulation.stream_run:run"),
}


def resolve(target: str) -> Any:
    """Import ``"package.module:attribute"`` and return the attribute."""
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def get(kind: str) -> Kind:
    if kind not in KINDS:
        raise ConfigError(f"Unknown scenario kind '{kind}'; use one of: {', '.join(sorted(KINDS))}.")
    return KINDS[kind]
