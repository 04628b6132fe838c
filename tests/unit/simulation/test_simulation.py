"""The Simulation: schedules fire and resume aligned, checkpoints are namespaced, status and Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import time

import numpy as np
import pytest

from erosim.core.callbacks import Callback
from erosim.core.errors import InstabilityError, Interrupted
from erosim.core.schedules import IterationInterval, Schedule, TimeInterval, WallTimeInterval
from erosim.io import checkpoint
from erosim.io.runfolder import RunFolder
from erosim.simulation.simulation import Simulation


class Ticker:
    """A model whose time grows by ``dt`` each advance and which records a running sum."""

    def __init__(self, name="ticker", dt=0.3, fail_at=None, interrupt_at=None):
        self.name, self.dt = name, dt
        self.t, self.n, self.total = 0.0, 0, np.zeros(3)
        self.fail_at, self.interrupt_at = fail_at, interrupt_at

    @property
    def time(self):
        return self.t

    def advance(self):
        if self.n == self.fail_at:
            raise InstabilityError("blew up; lower the step")
        if self.n == self.interrupt_at:
            raise KeyboardInterrupt
        self.n += 1
        self.t += self.dt
        self.total += np.arange(3) * self.t

    def state_dict(self):
        return {"t": self.t, "n": self.n, "total": self.total.copy()}

    def load_state_dict(self, st):
        self.t, self.n, self.total = float(st["t"]), int(st["n"]), np.array(st["total"])


class Recorder(Callback):
    def __init__(self, schedule, name):
        super().__init__(schedule, name=name)
        self.seen: list[tuple[float, int]] = []

    def __call__(self, sim):
        self.seen.append((sim.time, sim.iteration))

    def state_dict(self):
        return {"seen": np.asarray(self.seen, dtype=float).reshape(-1, 2), "calls": len(self.seen)}

    def load_state_dict(self, state):
        self.seen = [(float(a), int(b)) for a, b in np.asarray(state.get("seen", np.zeros((0, 2))))]


class Clock:
    def __init__(self, time=0.0, iteration=0):
        self.time, self.iteration = time, iteration


def _sim(tmp_path, name, stop=3.0, model=None, resume=False, **kw):
    out = RunFolder(tmp_path / name, resume=resume)
    cbs = [Recorder(TimeInterval(1.0), "by_time"), Recorder(IterationInterval(4), "by_iter")]
    return Simulation([model or Ticker(**kw)], out=out, stop_time=stop, callbacks=cbs, kind="test", progress=False)


def test_time_interval_fires_at_multiples_and_once_per_crossing():
    s = TimeInterval(1.0)
    fired = [t for t in (0.0, 0.3, 0.99, 1.0, 1.2, 3.7, 3.8, 4.0) if s(Clock(t))]
    assert fired == [0.0, 1.0, 3.7, 4.0]  # 2 and 3 were both crossed by one step: fired once at 3.7


def test_iteration_interval_and_offset():
    assert [i for i in range(10) if IterationInterval(3)(Clock(iteration=i))] == [0, 3, 6, 9]
    assert [i for i in range(10) if IterationInterval(4, offset=1)(Clock(iteration=i))] == [1, 5, 9]
    with pytest.raises(ValueError):
        IterationInterval(0)


def test_wall_time_interval_keeps_the_time_it_had_across_a_resume():
    s = WallTimeInterval(0.2)
    assert not s(Clock())
    time.sleep(0.12)
    saved = s.state()
    assert 0.1 <= saved["elapsed"] < 0.2
    again = WallTimeInterval(0.2)
    again.load_state(saved, Clock())
    assert not again(Clock())
    time.sleep(0.1)  # 0.12 before the resume + 0.1 after > 0.2
    assert again(Clock()) and not again(Clock())


def test_time_interval_realigns_when_its_interval_changed():
    s = TimeInterval(0.5)
    s.load_state({"interval": 1.0, "next_at": 3.0}, Clock(2.2))
    assert s.next_at == pytest.approx(2.5)


def test_run_fires_schedules_and_writes_report(tmp_path):
    sim = _sim(tmp_path, "a")
    rep = sim.run()
    by_time, by_iter = sim.callbacks[0], sim.callbacks[1]
    # steps of 0.3: first times at or past 0, 1, 2, 3 (the last step ends at 3.0 within rounding)
    assert [round(t, 6) for t, _ in by_time.seen] == [0.0, 1.2, 2.1, 3.0]
    assert [i for _, i in by_iter.seen] == [0, 4, 8]
    assert rep["status"] == "completed" and rep["iterations"] == 10
    on_disk = json.loads((tmp_path / "a" / "report.json").read_text())
    assert on_disk["status"] == "completed" and on_disk["kind"] == "test"
    state, meta = checkpoint.load(tmp_path / "a" / "checkpoint")
    assert {"model.ticker.t", "model.ticker.total", "callback.by_time.seen"} <= state.keys()
    assert meta["callbacks"]["by_time"]["schedule"]["next_at"] == pytest.approx(4.0)


def test_interrupt_then_resume_is_the_uninterrupted_run(tmp_path):
    whole = _sim(tmp_path, "whole", stop=6.0)
    whole.run()
    cut = _sim(tmp_path, "cut", stop=6.0, interrupt_at=7)
    with pytest.raises(Interrupted, match="--resume"):
        cut.run()
    assert json.loads((tmp_path / "cut" / "report.json").read_text())["status"] == "interrupted"
    again = _sim(tmp_path, "cut", stop=6.0, resume=True)
    again.restore()
    assert again.iteration == 7 and again.models[0].n == 7
    again.run()
    assert again.models[0].total.tolist() == whole.models[0].total.tolist()
    for a, b in zip(whole.callbacks[:2], again.callbacks[:2], strict=True):
        assert a.seen == b.seen  # every firing of the uninterrupted run, none twice


def test_sigint_is_held_until_the_iteration_is_complete(tmp_path):
    class Slow(Ticker):
        def advance(self):
            if self.n == 3:
                os.kill(os.getpid(), signal.SIGINT)  # arrives in the middle of an iteration
            super().advance()
            self.total += 1.0  # the iteration's second half: must not be skipped

    sim = _sim(tmp_path, "s", stop=10.0, model=Slow())
    with pytest.raises(Interrupted):
        sim.run()
    state, meta = checkpoint.load(tmp_path / "s" / "checkpoint")
    assert int(state["model.ticker.n"]) == 4 and meta["iteration"] == 4
    # the checkpoint holds whole iterations only: total = Σ_k (arange(3)·t_k + 1) over 4 steps
    ts = 0.3 * np.arange(1, 5)
    assert np.allclose(state["model.ticker.total"], np.arange(3) * ts.sum() + 4)


def test_instability_is_reported_and_reraised(tmp_path):
    sim = _sim(tmp_path, "u", fail_at=2)
    with pytest.raises(InstabilityError):
        sim.run()
    rep = json.loads((tmp_path / "u" / "report.json").read_text())
    assert rep["status"] == "unstable" and "lower the step" in rep["error"]


def test_finished_model_stops_the_run(tmp_path):
    class Finite(Ticker):
        @property
        def finished(self):
            return self.n >= 2

    sim = _sim(tmp_path, "f", stop=100.0, model=Finite())
    assert sim.run()["iterations"] == 2


def test_resume_checks_the_kind_and_the_model_names(tmp_path):
    _sim(tmp_path, "k").run()
    other = Simulation([Ticker()], out=RunFolder(tmp_path / "k", resume=True), stop_time=3, kind="sph", progress=False)
    with pytest.raises(Exception, match="written by a 'test' run"):
        other.restore()
    renamed = _sim(tmp_path, "k", model=Ticker(name="other"), resume=True)
    with pytest.raises(Exception, match="no state for 'other'"):
        renamed.restore()


def test_a_callback_added_on_resume_starts_aligned(tmp_path):
    _sim(tmp_path, "c", stop=2.0).run()
    out = RunFolder(tmp_path / "c", resume=True)
    late = Recorder(TimeInterval(0.5), "late")
    sim = Simulation([Ticker()], out=out, stop_time=4.0, callbacks=[late], kind="test", progress=False)
    sim.restore()
    sim.run()
    assert [round(t, 6) for t, _ in late.seen] == [2.7, 3.0, 3.6, 4.2]  # first times past 2.5, 3.0, 3.5, 4.0


def test_schedule_base_never_fires():
    assert not Schedule()(Clock(1e9, 10**9))
