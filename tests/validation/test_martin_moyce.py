"""Martin & Moyce (1952) column collapse, n² = 2: surge front against the experiment (issue 2, item 5)."""

import json

import numpy as np
import pytest

from erosim.data import MARTIN_MOYCE_SURGE, reference_csv
from erosim.validation import martin_moyce as mm
from erosim.validation.criteria import verdict

G = 9.81


def test_metric_is_zero_for_the_experiment_and_scales_with_a_bias():
    ref = reference_csv(MARTIN_MOYCE_SURGE)
    t = ref["T"] / np.sqrt(2 * G / mm.A)
    x = ref["Z"] * mm.A
    err, T_k, _ = mm.front_error(t, x, mm.A, G, ref["T"], ref["Z"])
    assert err == pytest.approx(0.0, abs=1e-12)
    assert T_k.max() <= 3.0 and len(T_k) == 13  # the table points with T <= 3
    err, _, _ = mm.front_error(t, 1.1 * x, mm.A, G, ref["T"], ref["Z"])
    assert err == pytest.approx(0.10, rel=1e-9)


def test_metric_refuses_a_run_that_stops_early():
    ref = reference_csv(MARTIN_MOYCE_SURGE)
    with pytest.raises(Exception, match="run.t_end"):
        mm.front_error(np.array([0.0, 0.05]), np.array([mm.A, mm.A]), mm.A, G, ref["T"], ref["Z"])


def _check(result, out):
    assert result["case"] == "martin-moyce"
    assert (out / "report.json").is_file()
    for key in ("metric", "value", "threshold", "passed", "out", "resolution", "fluid_particles", "wall_time_s"):
        assert key in result
    saved = json.loads((out / "validation.json").read_text())
    assert saved["value"] == result["value"]
    assert (out / "figures" / "front_vs_experiment.png").is_file()
    assert (out / "front.csv").read_text().startswith("t,x_front\n")
    if result.get("ground", "box") == "box":
        assert json.loads((out / "report.json").read_text())["column_width"] == pytest.approx(mm.A)


#: measured errors of the coarse collapse released at once (2026-11-25): against the experiment
#: 3.12 %, against Koshizuka & Oka's MPS computation 9.0 %; and the data's own scatter: the two
#: digitisations of the experiment shipped (the table, and PySPH's of fig. 3) differ by 1.36 % on
#: average at the tabulated T ≤ 3, the scale of a hand-read figure's error (the MPS curve is one too)
COARSE_MEASURED, COARSE_MPS_MEASURED, DATA_SCATTER = 0.031, 0.090, 0.0136
#: measured error of the coarse run's residual column height against the experiment's table (5.2 %)
COARSE_COLUMN_MEASURED = 0.052


def test_data_scatter_is_what_the_regression_bound_says():
    """The scatter used below, recomputed from the two digitisations."""
    from erosim.data import MARTIN_MOYCE_FIG3

    a, b = reference_csv(MARTIN_MOYCE_SURGE), reference_csv(MARTIN_MOYCE_FIG3)
    sel = b["case"] == "a=2.25in"
    order = np.argsort(b["T"][sel])
    tb, zb = b["T"][sel][order], b["Z"][sel][order]
    m = (a["T"] <= 3.0) & (a["T"] >= tb.min())
    rel = np.abs(np.interp(a["T"][m], tb, zb) - a["Z"][m]) / a["Z"][m]
    assert rel.mean() == pytest.approx(DATA_SCATTER, abs=5e-5)


def test_reference_computation_metric_and_its_lead_over_the_experiment():
    """The MPS metric is 0 on the computation's own points and 10 % for a 10 % bias; the computation
    (incompressible, released at once) leads the experiment at every table point from T = 0.8 to its
    end by more than the digitisation scatter, 13 % on average: the lead a converged solver inherits."""
    T_k, Z_k = mm.reference_computation()
    assert len(T_k) == 17 and T_k.min() > 0 and T_k.max() <= 3.0
    assert mm.reference_computation_error(T_k, Z_k) == pytest.approx(0.0, abs=1e-12)
    assert mm.reference_computation_error(T_k, 1.1 * Z_k) == pytest.approx(0.10, rel=1e-9)
    ref = reference_csv(MARTIN_MOYCE_SURGE)
    sel = (ref["T"] >= 0.8) & (ref["T"] <= T_k.max())
    lead = np.interp(ref["T"][sel], T_k, Z_k) / ref["Z"][sel] - 1.0
    assert len(lead) == 11 and np.all(lead > DATA_SCATTER), lead
    assert mm.computation_against_experiment(ref["T"], ref["Z"]) == pytest.approx(0.132, abs=0.001)


def test_column_height_metric():
    """Zero on the table itself (τ = t√(g/a), H = h/(2a)), 10 % for a 10 % bias; only the points the
    run spans count."""
    from erosim.data import MARTIN_MOYCE_COLUMN

    ref = reference_csv(MARTIN_MOYCE_COLUMN)
    t = ref["tau"] / np.sqrt(G / mm.A)
    h = 2 * mm.A * ref["H"]
    assert mm.column_height_error(t, h, mm.A, G) == (pytest.approx(0.0, abs=1e-12), len(t))
    err, n = mm.column_height_error(t[:10], 1.1 * h[:10], mm.A, G)
    assert err == pytest.approx(0.10, rel=1e-9) and n == 10


def _runs(front=None, mps=None, column=None):
    """Per-resolution metrics as :func:`mm.criteria` takes them, from {n_a: value} dicts."""
    ns = set(front or {}) | set(mps or {}) | set(column or {})
    return {n: {"front": (front or {}).get(n, 0.05), "mps": (mps or {}).get(n, 0.05),
                "column": (column or {}).get(n)} for n in ns}  # fmt: skip


def test_criteria_of_a_single_run_are_the_front_against_the_experiment():
    """coarse and default evaluate (a) on their own run, against the 10 % bound; (b) and (c) need the
    refinement sequence and are reported as not evaluated, and say which run evaluates them."""
    crit = mm.criteria("default", _runs(front={25: 0.078}, mps={25: 0.043}, column={25: 0.063}))
    assert [c["passed"] for c in crit] == [True, None, None]
    assert crit[0]["value"] == 0.078 and crit[0]["limit"] == 0.10 and "a/25" in crit[0]["criterion"]
    assert all("--resolution fine" in c["note"] for c in crit[1:])
    passed, line = verdict(crit)
    assert passed and "not evaluated" in line
    crit = mm.criteria("default", _runs(front={25: 0.1001}))
    passed, line = verdict(crit)
    assert not passed and line.startswith("failed (a) front vs experiment") and "10.0 % > 10.0 %" in line
    crit = mm.criteria("coarse", _runs(front={10: 0.031}))
    assert crit[0]["passed"] and "a/10" in crit[0]["criterion"] and "set at the default a/25" in crit[0]["criterion"]


FINE = {"front": {10: 0.031, 25: 0.078, 50: 0.107}, "mps": {10: 0.090, 25: 0.043, 50: 0.020},
        "column": {10: 0.052, 25: 0.063, 50: 0.032}}  # fmt: skip


def test_criteria_of_the_refinement_sequence():
    """fine: (a) on the a/25 run (not a/50's 10.7 %), (b) the MPS error falling at each step and ≤ 3 % at
    a/50, (c) the column at a/50 ≤ 5 %; each fails on its own and is named in the one line."""
    crit = mm.criteria("fine", _runs(**FINE))
    assert [c["passed"] for c in crit] == [True, True, True]
    assert crit[0]["value"] == 0.078 and crit[1]["sequence"] == {"a/10": 0.09, "a/25": 0.043, "a/50": 0.02}
    assert crit[2]["value"] == 0.032 and crit[2]["limit"] == 0.05
    assert verdict(crit)[0]

    def failed(**change):
        crit = mm.criteria("fine", _runs(**{k: {**v, **change.get(k, {})} for k, v in FINE.items()}))
        passed, line = verdict(crit)
        assert not passed
        return [c["name"][:3] for c in crit if c["passed"] is False], line

    names, line = failed(mps={25: 0.019})  # ≤ 3 % at a/50 but rose from a/25 to a/50
    assert names == ["(b)"] and "does not fall" in line and "9.0 % -> 1.9 % -> 2.0 %" in line
    names, line = failed(mps={50: 0.031})  # falls, but above 3 % at a/50
    assert names == ["(b)"] and "3.1 % > 3.0 %" in line
    names, line = failed(column={50: 0.051})
    assert names == ["(c)"] and "5.1 % > 5.0 %" in line
    names, line = failed(front={25: 0.11}, column={50: 0.06})
    assert names == ["(a)", "(c)"] and line.count(" > ") == 2
    no_gauge = mm.criteria("fine", _runs(**{**FINE, "column": {}}))
    assert no_gauge[2]["passed"] is None and "no column gauge" in no_gauge[2]["note"]
    with pytest.raises(ValueError):
        verdict([no_gauge[2]])


def test_a_failed_criterion_is_one_line_on_the_console_and_exit_status_1(cli_runner, monkeypatch):
    """The CLI: exit 0 when the criteria hold; 1 otherwise, with the verdict naming the failed criterion
    in one line on stderr (stdout stays one JSON object with --json)."""
    from erosim.cli import cli

    crit = mm.criteria("fine", _runs(**{**FINE, "column": {50: 0.07}}))
    passed, line = verdict(crit)
    fake = {"case": "martin-moyce", "metric": "m", "value": 0.107, "threshold": None, "passed": passed,
            "verdict": line, "criteria": crit, "out": "x"}  # fmt: skip
    monkeypatch.setattr(mm, "run", lambda *a, **k: fake)
    res = cli_runner.invoke(cli, ["--quiet", "validate", "martin-moyce", "--resolution", "fine", "--json"])
    assert res.exit_code == 1 and json.loads(res.stdout)["passed"] is False
    assert res.stderr.strip().splitlines() == [f"erosim: validation {line}"] and "(c) column height" in line
    res = cli_runner.invoke(cli, ["--quiet", "validate", "martin-moyce", "--resolution", "fine"])
    assert res.exit_code == 1 and "FAIL  (c) column height" in res.stdout and "pass  (a) front" in res.stdout
    fake.update(passed=True, criteria=mm.criteria("fine", _runs(**FINE)))
    res = cli_runner.invoke(cli, ["--quiet", "validate", "martin-moyce", "--resolution", "fine"])
    assert res.exit_code == 0 and res.stderr == "" and res.stdout.count("  pass  ") == 3


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    out = tmp_path_factory.mktemp("mm") / "coarse"
    return mm.run("coarse", out, progress=False), out


def test_coarse_column_collapse(coarse):
    """a/10 (200 particles, seconds), released at once: its numerical dissipation holds the front back
    to within 3.1 % of the experiment and 9 % behind the MPS computation. Held, as a regression bound,
    to the measured values within the data's scatter on either side (a change that speeds the front,
    e.g. less dissipation, shows here); the 10 % pass criterion is for the default resolution."""
    result, out = coarse
    _check(result, out)
    assert result["gate_speed_m_s"] == 0.0 and result["overrides"] == []
    assert abs(result["value"] - COARSE_MEASURED) <= DATA_SCATTER, result
    assert abs(result["reference_computation"]["value"] - COARSE_MPS_MEASURED) <= DATA_SCATTER, result
    column = result["column_height"]
    assert column["points"] == 10 and abs(column["value"] - COARSE_COLUMN_MEASURED) <= DATA_SCATTER, result
    # a single run evaluates (a) on itself; (b) and (c) are left to the refinement sequence (fine)
    assert result["passed"] and [c["passed"] for c in result["criteria"]] == [True, None, None], result
    assert result["threshold"] == mm.FRONT_LIMIT and result["criteria"][0]["value"] == result["value"]
    assert "13.2 %" in result["why_reference"] and "refinement" not in result


@pytest.fixture(scope="module")
def default(tmp_path_factory):
    return mm.run("default", tmp_path_factory.mktemp("mm") / "default", progress=False)


def test_error_against_the_mps_computation_falls_from_coarse_to_default(coarse, default):
    """Convergence (issue 14): refined from a/10 to a/25 the front moves towards the independent MPS
    computation of the same collapse (measured 9.0 % → 4.3 %), and its error against the experiment
    grows towards that computation's own (3.1 % → 7.8 %, the limit 13.2 %), each by more than the
    data's scatter."""
    c, d = coarse[0], default
    assert d["reference_computation"]["value"] < c["reference_computation"]["value"] - DATA_SCATTER, (c, d)
    assert c["value"] + DATA_SCATTER < d["value"] < d["reference_computation"]["its_error_against_the_experiment"]


def test_less_dissipation_moves_the_coarse_front_towards_the_mps_computation(coarse, tmp_path):
    """The coarse front's lag is the artificial viscosity's (ν ≈ αhc/8, 100× water's at a/10): with
    water's own viscosity instead (laminar, μ = 10⁻³ Pa s, no-slip walls) the same run is closer to
    the MPS computation (measured 5.4 % against 9.0 %) and further ahead of the experiment (6.7 %
    against 3.1 %), each by more than the data's scatter."""
    c = coarse[0]
    lam = mm.run("coarse", tmp_path / "lam", progress=False, overrides=["sph.viscosity=laminar", "sph.mu=0.001"])
    assert lam["overrides"] == ["sph.viscosity=laminar", "sph.mu=0.001"]
    assert lam["reference_computation"]["value"] < c["reference_computation"]["value"] - DATA_SCATTER, (c, lam)
    assert lam["value"] > c["value"] + DATA_SCATTER, (c, lam)


def test_extrapolated_free_slip_walls_reach_the_mps_computation_sooner(default, tmp_path):
    """Walls that push with the fluid's own pressure (Adami et al. 2012) and drag nothing
    (``sph.wall_pressure=extrapolated``, ``sph.wall_viscosity=none``): at a/25 the front is within 2.5 %
    of the MPS computation (the dynamic no-slip walls: 4.3 %; this pair gives 6.9, 2.5, 0.6 % at a/10,
    a/25, a/50, docs/sph.md) and the column height within 1.5 % of the experiment (6.3 %), each better by
    more than the data's scatter; its error against the experiment is then 10.3 %, near the
    computation's own 13.2 %: a solver closer to the converged solution is further from the front."""
    ov = ["sph.wall_pressure=extrapolated", "sph.wall_viscosity=none"]
    d = mm.run("default", tmp_path / "d", progress=False, overrides=ov)
    assert d["reference_computation"]["value"] < default["reference_computation"]["value"] - DATA_SCATTER, d
    assert d["column_height"]["value"] < default["column_height"]["value"] - DATA_SCATTER, d
    assert d["value"] > default["value"] + DATA_SCATTER, d  # further ahead of the experiment


@pytest.mark.slow
def test_fine_runs_the_refinement_sequence_and_meets_the_three_criteria(tmp_path):
    """fine: a/50 in the run folder, a/10 and a/25 under refinement/ (about a minute in all). The three
    criteria hold (measured: (a) 7.8 % at a/25; (b) 9.0 -> 4.3 -> 2.0 %; (c) 3.2 % at a/50), and the a/50 front's own
    error against the experiment (10.7 %) lies below the MPS computation's (13.2 %), its limit."""
    result = mm.run("fine", tmp_path / "mm", progress=False)
    _check(result, tmp_path / "mm")
    assert result["passed"] and [c["passed"] for c in result["criteria"]] == [True, True, True], result["verdict"]
    assert [r["resolution"] for r in result["refinement"]] == ["a/10", "a/25", "a/50"]
    for n in (10, 25):
        assert (tmp_path / "mm" / "refinement" / f"a{n}" / "front.csv").is_file()
    assert result["threshold"] is None and result["particles_across_column"] == 50
    mps = result["reference_computation"]
    assert 0.10 - DATA_SCATTER < result["value"] < mps["its_error_against_the_experiment"], result


@pytest.mark.slow
def test_gate_makes_the_error_shrink_from_coarse_to_default(tmp_path):
    """With the gate lifted at √(g a) the error falls from a/10 to a/25 (measured 11.9 % → 5.2 %). It
    does not keep falling (a/50 8.4 %, a/100 12.6 %, docs/sph.md), so only this step is asserted, by
    more than the data's scatter."""
    u = mm.gate_speed_default(G)
    coarse = mm.run("coarse", tmp_path / "c", progress=False, gate_speed=u)
    default = mm.run("default", tmp_path / "d", progress=False, gate_speed=u)
    assert coarse["gate_speed_m_s"] == pytest.approx(np.sqrt(G * mm.A))
    assert default["value"] < coarse["value"] - DATA_SCATTER, (coarse["value"], default["value"])


@pytest.mark.slow
def test_default_column_collapse(tmp_path):
    """a/25: the issue's pass criterion, mean relative error of Z at T <= 3 at most 10 %."""
    result = mm.run("default", tmp_path / "mm", progress=False)
    _check(result, tmp_path / "mm")
    assert result["passed"] and result["value"] <= 0.10, result
    assert [c["passed"] for c in result["criteria"]] == [True, None, None]


def test_coarse_column_collapse_on_a_heightmap_floor(tmp_path):
    """The same collapse with the floor a flat heightmap under the particle-free heightfield ground and
    plane walls at the tank's ends (issue 8): held to the same 10 % bound as the box version."""
    result = mm.run("coarse", tmp_path / "hf", progress=False, ground="heightfield")
    _check(result, tmp_path / "hf")
    assert result["ground"] == "heightfield" and result["boundary_particles"] == 0
    assert result["value"] <= 0.10, result


@pytest.mark.slow
def test_default_column_collapse_on_a_heightmap_floor(tmp_path):
    result = mm.run("default", tmp_path / "hf", progress=False, ground="heightfield")
    _check(result, tmp_path / "hf")
    assert result["passed"] and result["value"] <= 0.10, result
