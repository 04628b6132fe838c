"""Ctrl-C at any moment, then ``--resume``, gives what an uninterrupted run gives, bit for bit.

For each kind a real ``erosim run`` subprocess is sent SIGINT (see ``interrupting_cli.py``) at a
random moment of a phase — during a step, while an output is written, during the final maps (two
presses: the first is held until the final outputs are complete, the second stops at once) — then
resumed with ``erosim run --resume``. Every file of the run folder must equal the uninterrupted
run's byte for byte; ``report.json`` and the checkpoint's metadata are compared without the entries
that describe the sessions (wall times, ``resumed``). The default run draws one moment per phase and
kind; ``-m slow`` draws three more.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

DRIVER = Path(__file__).with_name("interrupting_cli.py")

KINDS = {
    "sph": ["dam-break-2d", "run.t_end=0.06", "run.output_interval=0.02", "run.snapshots=2"],
    "hydrology": ["hydrology", "terrain.size=48", "terrain.cell_size=40.0", "run.cycles=6", "run.frames=3",
                  "hydrology.cycle_droplets=20000"],
    "particle-stream": ["particle-stream", "terrain.size=64", "emitters.main.particles=150", "emitters.main.steps=50"],
    "sph-terrain": ["rain-erosion", "terrain.size=12", "terrain.cell_size=2.0", "sph.spacing=1.0", "rain.every=5",
                    "rain.rate=4e5", "run.t_end=0.3", "run.map_frames=2"],
    "flood": ["flood", "run.t_end=40.0", "run.map_frames=2", "flood.settle_steps=40", "flood.spacing=40.0"],
}  # fmt: skip

# kinds interrupted only in the slow run (their uninterrupted references cost a minute or more in all)
SLOW_KINDS = {"splash": ["rain-splash", "run.t_end=0.35", "run.wetness_frames=2", "run.output_interval=0.15"]}


# report entries that describe a session, not the result: wall times, rates, this session's counts
def _session_key(key: str) -> bool:
    timing = ("resumed", "elapsed", "coupling_fraction")
    return "wall" in key or "this_session" in key or key.endswith("_per_s") or key in timing


def _erosim(args, *, interrupt=None):
    """Run erosim (``interrupt`` = (phase, n, presses): through the interrupting driver)."""
    env = {**os.environ, "PYTHONHASHSEED": "0"}
    cmd = [sys.executable, "-m", "erosim.cli"] if interrupt is None else [sys.executable, str(DRIVER)]
    if interrupt is not None:
        cmd += [str(x) for x in interrupt] + ["--"]
    return subprocess.run([*cmd, "--quiet", *args], capture_output=True, text=True, env=env, timeout=600)


def _run_args(kind, out):
    name, *sets = {**KINDS, **SLOW_KINDS}[kind]
    args = ["run", name, "--out", str(out)]
    for s in sets:
        args += ["--set", s]
    return args


def _strip(obj):
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if not _session_key(k)}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def _checkpoint(path):
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files if k != "__meta__"}
        meta = json.loads(bytes(data["__meta__"]).decode())
    return arrays, _strip(meta)


def _assert_same_folder(ref: Path, got: Path):
    files = sorted(p.relative_to(ref) for p in ref.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(got) for p in got.rglob("*") if p.is_file())
    for rel in files:
        a, b = ref / rel, got / rel
        if rel.name == "report.json":
            assert _strip(json.loads(a.read_text())) == _strip(json.loads(b.read_text())), rel
        elif rel.suffix == ".npz" and rel.parts[0] == "checkpoint":
            (xa, ma), (xb, mb) = _checkpoint(a), _checkpoint(b)
            assert ma == mb, rel
            assert xa.keys() == xb.keys(), rel
            for k in xa:
                np.testing.assert_array_equal(xa[k], xb[k], err_msg=f"{rel}: {k}")
        else:
            assert a.read_bytes() == b.read_bytes(), f"{rel} differs"


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    """Each kind's uninterrupted run, and how many steps / outputs / final outputs it made."""
    made = {}
    for kind in KINDS:
        out = tmp_path_factory.mktemp("ref") / kind
        res = _erosim(_run_args(kind, out))
        assert res.returncode == 0, res.stderr
        made[kind] = out
    return made


@pytest.fixture(scope="module")
def slow_references(tmp_path_factory):
    """The uninterrupted runs of the kinds interrupted only in the slow run."""
    made = {}
    for kind in SLOW_KINDS:
        out = tmp_path_factory.mktemp("ref") / kind
        res = _erosim(_run_args(kind, out))
        assert res.returncode == 0, res.stderr
        made[kind] = out
    return made


def _moment(kind: str, phase: str, draw: int, ref: Path) -> int:
    """A random N within the phase's range for this kind (seeded by kind, phase and draw)."""
    rep = json.loads((ref / "report.json").read_text())
    rng = np.random.default_rng([draw, len(kind), len(phase)])
    if phase == "step":
        return int(rng.integers(1, rep["iterations"] + 1))
    if phase == "output":
        return int(rng.integers(1, 3))  # the first or second output: every kind makes at least two
    return int(rng.integers(1, 3))  # the first or second final output


def _case(kind, phase, draw, references, tmp_path):
    ref = references[kind]
    n = _moment(kind, phase, draw, ref)
    out = tmp_path / "run"
    presses = 2 if phase == "final" else 1
    first = _erosim(_run_args(kind, out), interrupt=(phase, n, presses))
    assert first.returncode == 130, (phase, n, first.returncode, first.stderr)
    assert f"erosim run --resume {out}" in first.stderr
    assert json.loads((out / "report.json").read_text())["status"] == "interrupted"
    again = _erosim(["run", "--resume", str(out)])
    assert again.returncode == 0, again.stderr
    _assert_same_folder(ref, out)


PHASES = ["step", "output", "final"]


@pytest.mark.parametrize("phase", PHASES)
@pytest.mark.parametrize("kind", sorted(KINDS))
def test_resume_after_ctrl_c_equals_the_uninterrupted_run(kind, phase, references, tmp_path):
    _case(kind, phase, 0, references, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("draw", [1, 2, 3])
@pytest.mark.parametrize("phase", PHASES)
@pytest.mark.parametrize("kind", sorted(KINDS))
def test_resume_after_ctrl_c_at_more_moments(kind, phase, draw, references, tmp_path):
    _case(kind, phase, draw, references, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("phase", PHASES)
@pytest.mark.parametrize("kind", sorted(SLOW_KINDS))
def test_resume_after_ctrl_c_equals_the_uninterrupted_run_slow_kinds(kind, phase, slow_references, tmp_path):
    _case(kind, phase, 0, slow_references, tmp_path)


def test_one_press_during_the_final_outputs_lets_them_finish(references, tmp_path):
    """The first Ctrl-C is held while the final outputs are written: the run completes as it would."""
    out = tmp_path / "run"
    res = _erosim(_run_args("sph", out), interrupt=("final", 1, 1))
    assert res.returncode == 0, res.stderr
    _assert_same_folder(references["sph"], out)
