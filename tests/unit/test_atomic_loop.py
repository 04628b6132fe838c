"""Atomic writes, run folders, checkpoints and the generic loop."""

from __future__ import annotations

import numpy as np
import pytest

from erosim.core.errors import ConfigError, Interrupted
from erosim.io import atomic, checkpoint
from erosim.io.runfolder import RunFolder, default_out
from erosim.simulation.loop import Every, drive


def test_atomic_path_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "a.txt"
    with pytest.raises(RuntimeError):
        with atomic.atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_atomic_path_replaces_whole_file(tmp_path):
    target = tmp_path / "a.json"
    atomic.write_json(target, {"x": np.float32(1.5), "a": np.arange(3)})
    assert target.read_text().strip().startswith("{") and '"x": 1.5' in target.read_text()
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


def test_runfolder_refuses_non_empty_and_default_out_increments(tmp_path):
    out = RunFolder(tmp_path / "r")
    out.write_report({"steps": 3}, seed=7)
    with pytest.raises(ConfigError, match="already exists"):
        RunFolder(tmp_path / "r")
    with pytest.raises(ConfigError, match="no checkpoint"):
        RunFolder(tmp_path / "r", resume=True)
    assert default_out("r", root=tmp_path).name == "r-2"


def test_checkpoint_round_trip(tmp_path):
    state = {"pos": np.random.default_rng(0).random((5, 3)), "t": 0.25, "steps": 12}
    checkpoint.save(tmp_path, state, {"scenario": "x"})
    back, meta = checkpoint.load(tmp_path)
    assert np.array_equal(back["pos"], state["pos"]) and back["t"].item() == 0.25
    assert meta == {"scenario": "x"}


def test_drive_schedules_and_interrupt(tmp_path):
    clock = {"t": 0.0}
    fired, saved = [], []

    def advance():
        clock["t"] += 0.3
        if clock["t"] > 2.0:
            raise KeyboardInterrupt
        return clock["t"]

    with pytest.raises(Interrupted, match="checkpoint was written"):
        drive(
            advance,
            start=0.0,
            total=5.0,
            schedules=[Every(1.0, fired.append)],
            checkpoint=lambda: saved.append(clock["t"]),
            progress=False,
        )
    # frames at t = 0, then the first steps past 1.0 and 2.0 (0.3-s steps: 1.2, 2.1 is interrupted before)
    assert fired == pytest.approx([0.0, 1.2]) and len(saved) == 1


def test_drive_runs_to_total():
    clock = {"t": 0.0}

    def advance():
        clock["t"] += 0.25
        return clock["t"]

    done, steps = drive(advance, start=0.0, total=1.0, progress=False)
    assert done == pytest.approx(1.0) and steps == 4


def test_atomic_files_get_usual_permissions(tmp_path):
    import os

    umask = os.umask(0)
    os.umask(umask)
    path = atomic.write_text(tmp_path / "p.txt", "x")
    assert (path.stat().st_mode & 0o777) == (0o666 & ~umask)
