"""Estimates before long work: a run that would not fit in memory is refused in one sentence before
anything is built; the memory estimate is within a factor of two of a real run's peak."""

import json
import subprocess
import sys

import pytest
from click.testing import CliRunner

from erosim.cli import cli
from erosim.scenarios import estimate, loader


def test_a_run_too_large_for_memory_is_refused_before_anything_is_built(tmp_path, monkeypatch):
    monkeypatch.setattr(estimate, "available_memory", lambda: 2e9)
    out = tmp_path / "big"
    result = CliRunner().invoke(cli, ["--quiet", "run", "hydrology", "--set", "terrain.size=4096", "--out", str(out)])
    assert result.exit_code == 2
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "needs about 5.53 GB of memory, but only 2 GB is free" in lines[0], result.output
    assert "terrain.size" in lines[0]
    assert not out.exists()


@pytest.mark.parametrize(
    "name, sets",
    [
        ("hydrology", ["terrain.size=1024", "run.cycles=2", "run.frames=0"]),
        ("particle-stream", ["terrain.size=1024", "emitters.main.particles=1000"]),
    ],
)
def test_memory_estimate_is_within_a_factor_of_two_of_the_peak(tmp_path, name, sets):
    """Peak RSS of a real run (this child alone: it is the only child waited for in a fresh process)."""
    guess = estimate.check(loader.load(name, sets).kind, loader.load(name, sets).config)
    args = ["run", name, "--out", str(tmp_path / "r")] + [x for s in sets for x in ("--set", s)]
    probe = (
        "import resource, subprocess, sys\n"
        f"cmd = [sys.executable, '-m', 'erosim.cli', '--quiet', *{args!r}]\n"
        "subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)\n"
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024)\n"
    )
    peak = float(subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout)
    assert peak / 2 < guess.memory < 2 * peak, (guess.memory, peak)
    assert json.loads((tmp_path / "r" / "report.json").read_text())["status"] == "completed"
