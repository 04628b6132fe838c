"""One driver for every run: models advanced together, callbacks on schedules, checkpoints, report.

A :class:`Simulation` holds

* **models** — objects with ``name``, ``time`` (their progress: simulated seconds, cycles,
  particles), ``advance()`` (one unit of work) and ``state_dict()`` / ``load_state_dict()``
  (everything the next ``advance`` reads, so a resume is bit-identical); all are advanced once per
  iteration, in order; the first one's ``time`` is the simulation's clock;
* **callbacks** (:mod:`erosim.simulation.callbacks`) with **schedules**
  (:mod:`erosim.core.schedules`) — frames, probes, couplers, checkpoints;
* a **stop rule** — ``stop_time`` on the clock, or a model whose ``finished`` is true;
* the **run folder** (:class:`~erosim.io.runfolder.RunFolder`) it checkpoints into and reports to.

It owns what every run needs: resume (models and callbacks restored from namespaced checkpoint
entries ``model.<name>.<key>`` / ``callback.<name>.<key>``, schedules continuing where they were),
the status (completed / unstable / interrupted / failed) written to ``report.json`` whatever
happens, and Ctrl-C: the first press is held until the current iteration and its callbacks are
complete (a checkpoint never sees half a step), then a checkpoint is written and
:class:`~erosim.core.errors.Interrupted` raised with the resume command; once the run has completed, the
first press is held until the final outputs are written, and the console says so; a second press
stops at once.
A sweep's worker, where no signal reaches the run's thread, asks the same of every run in its process
with :func:`request_stop`.
The pattern is Oceananigans' ``Simulation`` / ``Callback`` / ``Checkpointer``.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from erosim.core.callbacks import Callback
from erosim.core.errors import ConfigError, ErosimError, InputError, InstabilityError, Interrupted
from erosim.core.schedules import WallTimeInterval
from erosim.io import checkpoint as ckpt
from erosim.simulation.callbacks import Checkpointer
from erosim.simulation.progress import ProgressBar

MODEL = "model."
CALLBACK = "callback."

_STOP = threading.Event()


def request_stop() -> None:
    """Stop every run of this process as a Ctrl-C would: after the current iteration, with a checkpoint.

    For runs in threads that no signal reaches (a Dask worker's): ``erosim sweep`` calls it on each
    worker when the sweep is interrupted. :func:`clear_stop_request` re-arms the process.
    """
    _STOP.set()


def clear_stop_request() -> None:
    _STOP.clear()


def stop_requested() -> bool:
    return _STOP.is_set()


@contextlib.contextmanager
def held_interrupts(first: Callable[[], None] | None = None):
    """Hold the first Ctrl-C (SIGINT) until the caller looks at it; a second one raises at once.

    Yields a list that is non-empty once Ctrl-C was pressed; ``first()`` is called at the first press
    (to say what happens now). Outside the main thread (where signal handlers cannot be set) nothing is held.
    """
    pressed: list[int] = []

    def handler(signum, frame):
        if pressed:
            raise KeyboardInterrupt
        pressed.append(signum)
        if first is not None:
            first()

    try:
        old = signal.signal(signal.SIGINT, handler)
    except ValueError:  # not the main thread
        yield pressed
        return
    try:
        yield pressed
    finally:
        signal.signal(signal.SIGINT, old)


class Simulation:
    """Advance ``models`` until ``stop_time`` (see the module docstring)."""

    def __init__(
        self,
        models: list,
        *,
        out,
        stop_time: float,
        callbacks: list[Callback] = (),
        kind: str = "",
        label: str = "run",
        unit: str = "s",
        checkpoint_wall_s: float = 300.0,
        progress: bool = True,
    ):
        if not models:
            raise ValueError("a simulation needs at least one model")
        names = [m.name for m in models] + [c.name for c in callbacks]
        if len(set(names)) != len(names):
            raise ValueError(f"model and callback names must be unique, got {names}")
        self.models = list(models)
        self.out = out
        self.stop_time = float(stop_time)
        self.callbacks = list(callbacks)
        if not any(isinstance(c, Checkpointer) for c in self.callbacks):
            self.callbacks.append(Checkpointer(WallTimeInterval(checkpoint_wall_s)))
        self.kind = kind
        self.label = label
        self.unit = unit
        self.progress = progress
        self.iteration = 0
        self.iteration_start = 0  # iterations done before this session (resumed runs)
        self.resumed = False
        self.status = "built"
        self.error: str | None = None
        self.wall_time = 0.0  # running time of this session
        self._wall_before = 0.0  # running time of earlier sessions (resumed runs)
        self._loop_start: float | None = None

    # ------------------------------------------------------------------ clock
    @property
    def time(self) -> float:
        """The simulation's clock: the first model's ``time``."""
        return float(self.models[0].time)

    @property
    def wall_time_total(self) -> float:
        """Running time of every session of this run (s)."""
        running = time.perf_counter() - self._loop_start if self._loop_start is not None else 0.0
        return self._wall_before + (running if self.status == "running" else self.wall_time)

    def done(self) -> bool:
        if any(getattr(m, "finished", False) for m in self.models):
            return True
        return self.time >= self.stop_time - 1e-12 * max(1.0, abs(self.stop_time))

    # ------------------------------------------------------------------ checkpoints
    def checkpoint(self) -> None:
        """Write every model's and callback's state, the schedules' positions and the clock."""
        arrays: dict[str, Any] = {}
        meta: dict[str, Any] = {"kind": self.kind, "iteration": self.iteration, "time": self.time}
        for m in self.models:
            for k, v in m.state_dict().items():
                arrays[f"{MODEL}{m.name}.{k}"] = v
        cb_meta: dict[str, Any] = {}
        for c in self.callbacks:
            entry: dict[str, Any] = {"schedule": c.schedule.state()}
            for k, v in c.state_dict().items():
                if isinstance(v, np.ndarray):
                    arrays[f"{CALLBACK}{c.name}.{k}"] = v
                else:
                    entry.setdefault("state", {})[k] = v
            cb_meta[c.name] = entry
        meta["callbacks"] = cb_meta
        meta["wall_s"] = self.wall_time_total
        ckpt.save(self.out.checkpoint, arrays, meta)
        for c in self.callbacks:
            c.flush(self)

    def restore(self) -> None:
        """Continue from the run folder's checkpoint (models, callbacks, schedules, clock)."""
        arrays, meta = ckpt.load(self.out.path / "checkpoint")
        if meta.get("kind") not in (None, self.kind):
            raise InputError(
                f"The checkpoint in '{self.out.path}' was written by a '{meta.get('kind')}' run, not "
                f"'{self.kind}'; resume it with the scenario that wrote it."
            )
        for m in self.models:
            prefix = f"{MODEL}{m.name}."
            state = {
                k[len(prefix) :]: (v.item() if v.ndim == 0 else v) for k, v in arrays.items() if k.startswith(prefix)
            }
            if not state:
                raise InputError(
                    f"The checkpoint in '{self.out.path}' holds no state for '{m.name}'; it was written by "
                    "another version of erosim or another scenario — start the run again without --resume."
                )
            m.load_state_dict(state)
        self.iteration = int(meta.get("iteration", 0))
        saved = meta.get("callbacks", {})
        for c in self.callbacks:
            entry = saved.get(c.name)
            if entry is None:
                c.schedule.align(self)
                continue
            prefix = f"{CALLBACK}{c.name}."
            state = {k[len(prefix) :]: v for k, v in arrays.items() if k.startswith(prefix)}
            state.update(entry.get("state", {}))
            c.load_state_dict(state)
            c.schedule.load_state(entry.get("schedule", {}), self)
        self._wall_before = float(meta.get("wall_s", 0.0))
        self.resumed = True

    # ------------------------------------------------------------------ running
    def _fire(self) -> None:
        for c in self.callbacks:
            if c.schedule(self):
                c(self)

    def _step(self) -> None:
        for m in self.models:
            m.advance()
        self.iteration += 1

    def run(
        self,
        *,
        finish: Callable[[Simulation], dict] | None = None,
        report: Callable[[Simulation], dict] | None = None,
        seed: int | None = None,
    ) -> dict[str, Any]:
        """Advance until done; returns the report (also written to ``report.json``).

        ``finish(sim)`` writes the final outputs of a completed run and returns report entries;
        ``report(sim)`` returns the kind's report entries (called whatever the status). An
        :class:`InstabilityError` or :class:`Interrupted` is re-raised after the report is written.
        """
        self.status = "running"
        fresh = not self.resumed
        steps0 = self.iteration_start = self.iteration
        extra: dict[str, Any] = {}
        self._loop_start = time.perf_counter()
        with held_interrupts(self._pressed) as pressed:
            try:
                with ProgressBar(
                    self.stop_time, self.label, unit=self.unit, enabled=self.progress, start=self.time
                ) as bar:
                    if fresh:
                        self._fire()
                    while not self.done():
                        self._step()
                        self._fire()
                        bar.update(self.time, self.iteration - steps0)
                        if pressed or _STOP.is_set():
                            raise KeyboardInterrupt
                    bar.update(self.time, self.iteration - steps0)
                self.wall_time = time.perf_counter() - self._loop_start
                self.status = "completed"
                self.checkpoint()
                for c in self.callbacks:
                    extra.update(self._final_output(c.finalize, getattr(c, "name", type(c).__name__)))
                if finish is not None:
                    extra.update(self._final_output(finish, "finish"))
            except KeyboardInterrupt:
                self._stopped("interrupted")
                self.checkpoint()
                self.error = (
                    f"Interrupted at {self.time:.6g} {self.unit} after {self.iteration} iterations; a checkpoint "
                    f"was written — continue with `erosim run --resume {self.out.path}`."
                )
                raise Interrupted(self.error) from None
            except InstabilityError as exc:
                self._stopped("unstable", str(exc))
                raise
            except (ConfigError, InputError) as exc:
                self._stopped("failed", str(exc))
                raise
            except BaseException as exc:  # a bug: say so in the report, keep the traceback
                self._stopped("failed", f"{type(exc).__name__}: {exc}")
                raise
            finally:
                if self.status != "completed":
                    for c in self.callbacks:
                        c.flush(self)
                rep = self._report(steps0, extra, report)
                self.out.write_report(rep, seed=seed)
        return rep

    def _final_output(self, write: Callable, name: str) -> dict[str, Any]:
        """One final output of a completed run; one that fails (a picture of extreme values, a full
        figure library) becomes a warning in the report and on the console, so that it never loses the
        run's other maps and its report."""
        try:
            return write(self) or {}
        except (OSError, MemoryError, ErosimError):  # a full disk, bad input: the run's own outcome, as before
            raise
        except Exception as exc:
            note = (f"The final output '{name}' failed ({type(exc).__name__}: {exc}); the run completed and its "
                    "other outputs and this report are written.")  # fmt: skip
            self.out.warn(note)
            print(f"{self.label}: warning: {note}", file=sys.stderr, flush=True)
            return {}

    def _pressed(self) -> None:
        """The first Ctrl-C: during the steps it stops after the current one (said then); once the run
        has completed it is held until the final outputs are written, which is said now."""
        if self.status == "completed":
            print(
                f"{self.label}: the run has completed and is finishing its outputs (maps, figures); they take a "
                f"moment. Press Ctrl-C again to stop now (`erosim run --resume {self.out.path}` then writes them).",
                file=sys.stderr, flush=True,
            )  # fmt: skip

    def _stopped(self, status: str, error: str | None = None) -> None:
        if self._loop_start is not None and self.status == "running":
            self.wall_time = time.perf_counter() - self._loop_start
        self.status = status
        self.error = error

    def _report(self, steps0: int, extra: dict, report: Callable | None) -> dict[str, Any]:
        rep: dict[str, Any] = {
            "kind": self.kind,
            "status": self.status,
            "resumed": self.resumed,
            "iterations": self.iteration,
            "iterations_this_session": self.iteration - steps0,
            "progress": {"time": self.time, "stop_time": self.stop_time, "unit": self.unit},
            "simulation_wall_s": round(self.wall_time, 3),
            "simulation_wall_s_total": round(self._wall_before + self.wall_time, 3),
        }
        if self.error:
            rep["error"] = self.error
        rep.update(extra)  # the callbacks' entries; the kind's own report has the last word
        if report is not None:
            try:
                rep.update(report(self))
            except Exception as exc:  # the report must not hide the run's own outcome
                if self.status == "completed":
                    raise
                rep["report_error"] = f"{type(exc).__name__}: {exc}"
        return rep
