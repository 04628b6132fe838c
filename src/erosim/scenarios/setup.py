"""What a scenario kind's builder returns: the models and callbacks of one run, and its report."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any


@dataclass
class Setup:
    """A run ready to go: a :class:`~erosim.simulation.simulation.Simulation` is made from it.

    ``report(sim)`` gives the kind's entries of ``report.json`` (whatever the run's status);
    ``summary(sim, report)`` the few lines the command line prints. ``warnings`` go into the report
    and onto the console; ``assumed`` (what the run takes its inputs to be: cell size and where it came
    from, heights, nodata, CRS, parameters scaled to the terrain) onto the console before the run, as is
    ``estimate`` (:class:`erosim.scenarios.estimate.Estimate`: memory and time from the built models) where the
    scenario alone did not tell them.
    """

    models: list
    callbacks: list
    stop_time: float
    unit: str
    report: Callable[[Any], dict]
    summary: Callable[[Any, dict], dict]
    checkpoint_wall_s: float = 300.0
    seed: int | None = None
    warnings: list[str] = field(default_factory=list)
    assumed: list[str] = field(default_factory=list)
    estimate: Any = None
