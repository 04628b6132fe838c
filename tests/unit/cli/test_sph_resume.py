"""Checkpoint/resume reproduces the uninterrupted run bit for bit; Ctrl-C and instability end cleanly."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from erosim.cli import cli
from erosim.core.errors import InstabilityError, Interrupted
from erosim.io import checkpoint
from erosim.io.runfolder import RunFolder
from erosim.scenarios import loader, runner

BASE = ["sph.spacing=0.007", "run.output_interval=0.002", "run.sample_interval=0.001", "run.snapshots=0"]


def _cli(*args):
    res = CliRunner().invoke(cli, ["--quiet", *args])
    return res.exit_code, res.output


def _sets(items):
    out = []
    for s in items:
        out += ["--set", s]
    return out


def _solver_state(folder):
    state, meta = checkpoint.load(folder / "checkpoint")
    return {k: v for k, v in state.items() if k.startswith("model.fluid.")}, state, meta


def _assert_same(a, b):
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def test_resume_extends_a_finished_run_exactly(tmp_path):
    full, part = tmp_path / "full", tmp_path / "part"
    code, out = _cli("run", "dam-break-2d", "--out", str(full), *_sets(BASE + ["run.t_end=0.006"]))
    assert code == 0, out
    code, out = _cli("run", "dam-break-2d", "--out", str(part), *_sets(BASE + ["run.t_end=0.003"]))
    assert code == 0, out
    code, out = _cli("run", "--resume", str(part), "--set", "run.t_end=0.006")
    assert code == 0, out

    sa, fa, _ = _solver_state(full)
    sb, fb, _ = _solver_state(part)
    _assert_same(sa, sb)  # positions, velocities, densities, time, step count, ...
    rows = ("callback.front.rows", "callback.probes.rows")
    _assert_same({k: fa[k] for k in rows}, {k: fb[k] for k in rows})
    assert (full / "front.csv").read_text() == (part / "front.csv").read_text()
    assert (full / "gauges.csv").read_text() == (part / "gauges.csv").read_text()
    assert (full / "particles" / "particles.pvd").read_text() == (part / "particles" / "particles.pvd").read_text()
    rep = json.loads((part / "report.json").read_text())
    assert rep["resumed"] and rep["status"] == "completed"


def test_ctrl_c_writes_checkpoint_and_resume_matches(tmp_path, monkeypatch):
    from erosim.sph import solver as solver_mod

    sets = BASE + ["run.t_end=0.006"]
    full = RunFolder(tmp_path / "full")
    runner.run(loader.load("dam-break-2d", sets), full, progress=False)

    real_step = solver_mod.SPHSolver.step
    calls = {"n": 0}

    def step_then_interrupt(self):
        calls["n"] += 1
        if calls["n"] == 7:
            raise KeyboardInterrupt
        return real_step(self)

    monkeypatch.setattr(solver_mod.SPHSolver, "step", step_then_interrupt)
    cut = RunFolder(tmp_path / "cut")
    with pytest.raises(Interrupted, match="checkpoint was written"):
        runner.run(loader.load("dam-break-2d", sets), cut, progress=False)
    monkeypatch.setattr(solver_mod.SPHSolver, "step", real_step)

    rep = json.loads((cut.path / "report.json").read_text())
    assert rep["status"] == "interrupted" and rep["steps"] == 6
    assert not [p for p in cut.path.rglob(".*.part")]  # no partial file

    runner.run(loader.load(cut.path / "scenario.toml"), RunFolder(cut.path, resume=True), resume=True, progress=False)
    _assert_same(_solver_state(full.path)[0], _solver_state(cut.path)[0])
    assert (full.path / "front.csv").read_text() == (cut.path / "front.csv").read_text()


def test_unstable_run_stops_with_clear_message_and_keeps_files(tmp_path):
    """max_mach tiny: the first motion counts as 'exploding speed', which must stop the run cleanly."""
    out = tmp_path / "u"
    code, text = _cli(
        "run", "dam-break-2d", "--out", str(out), *_sets(BASE + ["run.t_end=0.01", "sph.max_mach=0.0001"])
    )
    assert code == InstabilityError.exit_code
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "step" in lines[0] and "Traceback" not in text
    rep = json.loads((out / "report.json").read_text())
    assert rep["status"] == "unstable" and "step" in rep["error"]
    assert (out / "scenario.toml").is_file()
    assert (out / "particles" / "frame_00000.vtp").is_file()  # what was written stays
    assert (out / "front.csv").read_text().startswith("t,x_front\n")
