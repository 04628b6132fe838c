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
    assert len(lines) == 1 and "needs about 3.1 GB of memory, but only 2 GB is free" in lines[0], result.output
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


def test_a_run_without_gravity_gets_no_time_but_no_crash():
    cfg = loader.load("dam-break-2d", ["sph.gravity=[0.0, 0.0]"]).config
    guess = estimate.check("sph", cfg)
    assert guess.seconds is None and guess.memory > estimate.BASE_BYTES
    assert "steps" not in guess.what


def test_a_generated_terrains_default_cell_size_counts_in_the_rain_estimate():
    """A generated map with no terrain.cell_size has 10 m cells; rain over 10 m cells is 25× the water
    of 2 m cells on the same grid."""
    from erosim.scenarios.schema_common import TerrainSection

    assert estimate.map_size(TerrainSection(size=64)) == (64 * 64, estimate.GENERATED_CELL)
    sets = ["rain.rate=1e5", "run.t_end=10"]
    small, large = (
        estimate.sph_terrain(loader.load("rain-erosion", [*sets, f"terrain.cell_size={c}"]).config) for c in (2.0, 10.0)
    )
    water = (large.memory - small.memory) / estimate.SPH_PARTICLE_BYTES  # particles added by the larger map
    assert water == pytest.approx(24 * (small.memory - estimate.BASE_BYTES - 200.0 * 64 * 64) / 800.0, rel=1e-6)


@pytest.mark.parametrize("name, t_end", [("dam-break-2d", 0.02), ("mountain-lake", 0.2)])
def test_the_step_estimate_is_within_a_quarter_of_a_short_runs_steps(tmp_path, name, t_end):
    """The estimate takes the solver's limit Δt = C·h_s/(c + v) with v the free fall's speed throughout; a
    run's water starts slower (v from 0 up, c + v between c and 1.1 c) and the force limit rarely binds, so
    its steps lie within a quarter of the estimate (they were half of it when h_s was taken as h)."""
    sets = [f"run.t_end={t_end}"]
    guess = estimate.check(loader.load(name, sets).kind, loader.load(name, sets).config)
    args = ["--quiet", "run", name, "--out", str(tmp_path / "r"), "--set", sets[0]]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    steps = json.loads((tmp_path / "r" / "report.json").read_text())["steps"]
    assert 0.75 * guess.steps < steps < 1.25 * guess.steps, (guess.steps, steps)
    assert guess.seconds is not None and guess.memory > estimate.BASE_BYTES


def test_shallow_water_validations_estimate_their_steps_within_a_factor_of_two():
    """The validations that step a shallow-water model themselves (Ritter and Stoker, Thacker's bowl)
    print an estimate from the built model: Δt from its CFL limit at the start, the wave speed raised by the
    fastest water expected. The flow's speeds change over the run, so the bound is the issue's factor of two."""
    from erosim.validation import swe_dam_break, thacker

    runs = [swe_dam_break.run_case(h1, "coarse") for h1 in (0.0, 0.1 * swe_dam_break.H0)]
    runs.append(thacker.run_case("coarse", periods=0.5))
    for r in runs:
        assert 0.5 * r["steps_estimated"] <= r["steps"] <= 2.0 * r["steps_estimated"], r
