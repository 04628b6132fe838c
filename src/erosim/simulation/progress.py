"""Progress bar for long work: simulated time (or cycles), steps per second and ETA.

Built on ``rich.progress``; silent when disabled (``--quiet``) or when output is not a terminal
(rich then renders nothing live, so logs in CI stay clean).
"""

from __future__ import annotations

import time

from rich.progress import BarColumn, Progress, ProgressColumn, Task, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.text import Text


class _Rate(ProgressColumn):
    """Steps per second while simulated time advances; otherwise the unit itself per second."""

    def render(self, task: Task) -> Text:
        elapsed = task.elapsed or 0.0
        what = task.fields["rate_unit"]
        done = task.fields["steps"] if what == "steps" else task.completed - task.fields["origin"]
        rate = done / elapsed if elapsed > 0 else 0.0
        return Text(f"{rate:,.0f} {what}/s", style="cyan")


class ProgressBar:
    """``with ProgressBar(total, "dam-break", unit="s") as bar: bar.update(done, steps)``."""

    def __init__(self, total: float, label: str, unit: str = "s", enabled: bool = True, start: float = 0.0):
        self.total = float(total)
        self.unit = unit
        self.enabled = enabled
        self._progress: Progress | None = None
        self._task = None
        self._start = start
        self._last = 0.0
        self.label = label

    def __enter__(self) -> ProgressBar:
        if self.enabled:
            # simulated seconds to three digits; counts (cycles, particles) whole, with thousands separators
            number = ".3g" if self.unit == "s" else ",.0f"
            fmt = f"{{task.completed:{number}}}/{{task.total:{number}}} {self.unit}"
            self._progress = Progress(
                TextColumn("[bold]{task.description}"),
                BarColumn(),
                TextColumn(fmt),
                _Rate(),
                TimeElapsedColumn(),
                TextColumn("ETA"),
                TimeRemainingColumn(),
                transient=False,
            )
            self._progress.__enter__()
            # simulated time advances in steps; other units (cycles, droplets) count themselves
            rate_unit = "steps" if self.unit == "s" else self.unit
            self._task = self._progress.add_task(
                self.label, total=self.total, completed=self._start, steps=0, rate_unit=rate_unit, origin=self._start
            )
        return self

    def update(self, done: float, steps: int) -> None:
        """Report progress; refreshes at most ~10 times a second (cheap to call every step)."""
        if self._progress is None:
            return
        now = time.perf_counter()
        if now - self._last < 0.1 and done < self.total:
            return
        self._last = now
        self._progress.update(self._task, completed=min(done, self.total), steps=steps)

    def __exit__(self, *exc) -> None:
        if self._progress is not None:
            self._progress.__exit__(*exc)
