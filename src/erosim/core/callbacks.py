"""The callback protocol: what a :class:`~erosim.simulation.simulation.Simulation` calls on a schedule.

A callback has a ``schedule`` (:mod:`erosim.core.schedules`) and a ``name`` (its checkpoint
namespace), and is called with the simulation when the schedule is due. It may keep state that
belongs in checkpoints (``state_dict`` / ``load_state_dict``: arrays go into the checkpoint's arrays,
other values into its JSON header), write what it gathered at checkpoints and at the end (``flush``),
and add to the report when the run completes (``finalize``). The base class does nothing of these;
outputs (:mod:`erosim.simulation.callbacks`), sources and sinks of water and the couplers
(:mod:`erosim.coupling`) subclass it and override what they need.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from erosim.core.schedules import Schedule


class Callback:
    """A function ``func(sim)`` called when ``schedule`` is due; the base of every callback."""

    def __init__(self, schedule: Schedule, func: Callable | None = None, name: str | None = None):
        self.schedule = schedule
        self.func = func
        self.name = name or getattr(func, "__name__", type(self).__name__.lower())

    def __call__(self, sim) -> None:
        if self.func is not None:
            self.func(sim)

    def state_dict(self) -> dict[str, Any]:
        return {}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state_dict` (missing keys mean a callback added on resume: keep defaults)."""

    def flush(self, sim) -> None:
        """Write what was gathered so far (called at every checkpoint and at the end)."""

    def finalize(self, sim) -> dict[str, Any]:
        """When the run has completed: final files; returns entries for ``report.json``."""
        return {}
