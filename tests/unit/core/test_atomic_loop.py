"""Atomic writes, run folders and checkpoints."""

from __future__ import annotations

import numpy as np
import pytest

from erosim.core import atomic
from erosim.core.errors import ConfigError
from erosim.io import checkpoint
from erosim.io.runfolder import RunFolder, default_out


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


def test_atomic_files_get_usual_permissions(tmp_path):
    import os

    umask = os.umask(0)
    os.umask(umask)
    path = atomic.write_text(tmp_path / "p.txt", "x")
    assert (path.stat().st_mode & 0o777) == (0o666 & ~umask)


@pytest.mark.parametrize("keep", [0, 10, 200, -20])
def test_a_truncated_checkpoint_is_one_sentence(tmp_path, keep):
    """A checkpoint cut short (a full disk, a copy stopped half-way) is named as damaged, with what
    to do, instead of a zip library traceback (BadZipFile, EOFError)."""
    from erosim.core.errors import InputError

    path = checkpoint.save(tmp_path, {"pos": np.arange(3000.0), "t": np.float64(1.5)}, {"scenario": "x"})
    data = path.read_bytes()
    path.write_bytes(data[:keep] if keep >= 0 else data[:keep])
    with pytest.raises(InputError, match="is damaged .* cannot be resumed; start it again"):
        checkpoint.load(tmp_path)
