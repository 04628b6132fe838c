"""The generic run loop: advance a model until done, with writers, checkpoints and Ctrl-C safety.

Every runner (SPH, hydrology, particle stream) drives its model with :func:`drive`:

* ``advance()`` does one unit of work (an SPH step, a batch of droplets) and returns the new
  progress value (simulated seconds, droplets done, ...);
* each :class:`Every` schedule calls its action when progress crosses its next multiple
  (frame writers, gauges);
* ``checkpoint()`` is called every ``checkpoint_wall_s`` seconds of wall time, at the end, and when
  the user presses Ctrl-C — after which :class:`~erosim.core.errors.Interrupted` is raised so the CLI
  exits cleanly with a resume hint;
* an :class:`~erosim.core.errors.InstabilityError` from ``advance`` propagates unchanged: the runner
  records it in ``report.json`` and re-raises; files already written stay.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from erosim.core.errors import Interrupted
from erosim.simulation.progress import ProgressBar


@dataclass
class Every:
    """Call ``action(progress)`` each time progress reaches the next multiple of ``interval``."""

    interval: float
    action: Callable[[float], None]
    next_at: float = 0.0

    def due(self, progress: float) -> bool:
        return self.interval > 0 and progress >= self.next_at - 1e-12 * max(1.0, abs(self.next_at))

    def fire(self, progress: float) -> None:
        self.action(progress)
        # skip multiples already passed (a large step may cross several)
        k = int(progress / self.interval + 1e-9) + 1
        self.next_at = k * self.interval


def drive(
    advance: Callable[[], float],
    *,
    start: float,
    total: float,
    schedules: list[Every] = (),
    checkpoint: Callable[[], None] | None = None,
    checkpoint_wall_s: float = 300.0,
    label: str = "run",
    unit: str = "s",
    progress: bool = True,
    steps_done: int = 0,
) -> tuple[float, int]:
    """Run ``advance`` from ``start`` until ``total``; returns (final progress, steps taken in total).

    Schedules whose ``next_at`` is ``start`` fire before the first step (e.g. frame 0), unless the
    caller set ``next_at`` past it (on resume).
    """
    done = start
    steps = steps_done
    last_ckpt = time.perf_counter()
    try:
        with ProgressBar(total, label, unit=unit, enabled=progress, start=start) as bar:
            for s in schedules:
                if s.due(done):
                    s.fire(done)
            while done < total - 1e-12 * max(1.0, abs(total)):
                done = advance()
                steps += 1
                for s in schedules:
                    if s.due(done):
                        s.fire(done)
                if checkpoint is not None and time.perf_counter() - last_ckpt >= checkpoint_wall_s:
                    checkpoint()
                    last_ckpt = time.perf_counter()
                bar.update(done, steps)
            bar.update(done, steps)
    except KeyboardInterrupt:
        if checkpoint is not None:
            checkpoint()
            raise Interrupted(
                f"Interrupted at {done:.6g} {unit} after {steps} steps; a checkpoint was written — "
                "continue with `erosim run --resume <run folder>`."
            ) from None
        raise Interrupted(f"Interrupted at {done:.6g} {unit} after {steps} steps.") from None
    if checkpoint is not None:
        checkpoint()
    return done, steps
