"""When callbacks fire: by simulated time, by iteration count, or by wall-clock time.

A schedule is asked once after every iteration of a :class:`~erosim.simulation.simulation.Simulation`
(and once before the first iteration of a fresh run) whether its callback is due; answering *yes*
moves it on to its next firing. Its position is part of every checkpoint, so a resumed run fires at
exactly the moments the uninterrupted run would have (the pattern of Oceananigans' ``TimeInterval``,
``IterationInterval`` and ``WallTimeInterval``).

* :class:`TimeInterval` — every ``interval`` of the simulation's time (simulated seconds for a fluid,
  cycles for hydrology, particles for a stream): fires at t₀ = 0, Δ, 2Δ, …; a step that crosses
  several multiples fires once.
* :class:`IterationInterval` — every ``n`` iterations (an SPH step, a hydrology cycle): fires when
  iteration ≡ offset (mod n), iteration 0 included.
* :class:`WallTimeInterval` — every ``seconds`` of wall time spent running; the time since the last
  firing is kept across a resume, so a checkpointer fires ``seconds`` of running apart, not sooner.
"""

from __future__ import annotations

import time
from typing import Any, Protocol


class Clock(Protocol):
    """What a schedule reads: the simulation's time and iteration count."""

    time: float
    iteration: int


class Schedule:
    """Base class: never due; subclasses override :meth:`__call__` and, when they have any, the state."""

    def __call__(self, clock: Clock) -> bool:
        return False

    def state(self) -> dict[str, Any]:
        """JSON-able position of the schedule (written into checkpoints)."""
        return {}

    def load_state(self, state: dict[str, Any], clock: Clock) -> None:
        """Continue from :meth:`state` (on resume)."""

    def align(self, clock: Clock) -> None:
        """Resume without a saved position (a callback added on resume, or a changed interval): the
        next firing is the first one after ``clock``, as if the schedule had run all along."""


class TimeInterval(Schedule):
    """Fires each time the simulation's time reaches the next multiple of ``interval``."""

    def __init__(self, interval: float):
        self.interval = float(interval)
        self.next_at = 0.0

    def __call__(self, clock: Clock) -> bool:
        t = float(clock.time)
        if self.interval <= 0 or t < self.next_at - 1e-12 * max(1.0, abs(self.next_at)):
            return False
        # skip multiples already passed (a large step may cross several)
        self.next_at = (int(t / self.interval + 1e-9) + 1) * self.interval
        return True

    def state(self) -> dict[str, Any]:
        return {"interval": self.interval, "next_at": self.next_at}

    def load_state(self, state: dict[str, Any], clock: Clock) -> None:
        same = abs(float(state.get("interval", -1.0)) - self.interval) <= 1e-15 * max(1.0, self.interval)
        if same and "next_at" in state:
            self.next_at = float(state["next_at"])
        else:
            self.align(clock)

    def align(self, clock: Clock) -> None:
        if self.interval > 0:
            self.next_at = (int(float(clock.time) / self.interval + 1e-9) + 1) * self.interval


class IterationInterval(Schedule):
    """Fires when the iteration count is ``offset`` modulo ``n`` (iteration 0 included when offset = 0)."""

    def __init__(self, n: int, offset: int = 0):
        if int(n) < 1:
            raise ValueError(f"an iteration interval must be at least 1, got {n}")
        self.n = int(n)
        self.offset = int(offset) % self.n

    def __call__(self, clock: Clock) -> bool:
        return int(clock.iteration) % self.n == self.offset

    def state(self) -> dict[str, Any]:
        return {"n": self.n, "offset": self.offset}


class WallTimeInterval(Schedule):
    """Fires when ``seconds`` of wall time have passed while running since it last fired."""

    def __init__(self, seconds: float):
        self.seconds = float(seconds)
        self._banked = 0.0  # running time before the current session's reference point
        self._since: float | None = None  # the clock starts at the first question, not at construction

    def elapsed(self) -> float:
        if self._since is None:
            self._since = time.perf_counter()
        return self._banked + time.perf_counter() - self._since

    def __call__(self, clock: Clock) -> bool:
        if self.elapsed() < self.seconds:
            return False
        self._banked = 0.0
        self._since = time.perf_counter()
        return True

    def state(self) -> dict[str, Any]:
        return {"seconds": self.seconds, "elapsed": self.elapsed()}

    def load_state(self, state: dict[str, Any], clock: Clock) -> None:
        self._banked = float(state.get("elapsed", 0.0))
        self._since = time.perf_counter()

    def align(self, clock: Clock) -> None:
        self._banked = 0.0
        self._since = time.perf_counter()
