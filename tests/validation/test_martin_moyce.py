"""Martin & Moyce (1952) column collapse, n² = 2: surge front against the experiment (issue 2, item 5)."""

import json

import numpy as np
import pytest

from erosim.data import MARTIN_MOYCE_SURGE, reference_csv
from erosim.validation import martin_moyce as mm

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


#: measured error of the coarse collapse with the lifted gate (2026-11-25; 3.12 % released at once)
#: and the data's own scatter: the two digitisations of the experiment shipped (the table, and
#: PySPH's of fig. 3) differ by 1.36 % on average at the tabulated T ≤ 3
COARSE_MEASURED, DATA_SCATTER = 0.119, 0.0136


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


def test_coarse_column_collapse(tmp_path):
    """a/10 (200 particles, seconds) with the gate lifted at √(g a): the front lags the experiment
    (the coarse run's numerical dissipation; released at once its lag and the missing gate's delay
    cancelled to 3.1 %). Held, as a regression bound, to the measured value within the data's
    scatter on either side (a change that speeds the front, e.g. less dissipation, shows as a smaller
    error here); the issue's 10 % pass criterion is for the default resolution (below)."""
    result = mm.run("coarse", tmp_path / "mm", progress=False)
    _check(result, tmp_path / "mm")
    assert result["gate_speed_m_s"] == pytest.approx(np.sqrt(G * mm.A))
    assert abs(result["value"] - COARSE_MEASURED) <= DATA_SCATTER, result


@pytest.mark.slow
def test_gate_makes_the_error_shrink_from_coarse_to_default(tmp_path):
    """With the gate the error falls from a/10 to a/25 (measured 11.9 % → 5.2 %; released at once it
    grew, 3.1 % → 7.8 %). It does not keep falling (a/50 8.4 %, a/100 12.6 %, docs/sph.md), so only
    this step is asserted, by more than the data's scatter."""
    coarse = mm.run("coarse", tmp_path / "c", progress=False)["value"]
    default = mm.run("default", tmp_path / "d", progress=False)["value"]
    assert default < coarse - DATA_SCATTER, (coarse, default)


@pytest.mark.slow
def test_default_column_collapse(tmp_path):
    """a/25: the issue's pass criterion, mean relative error of Z at T <= 3 at most 10 %."""
    result = mm.run("default", tmp_path / "mm", progress=False)
    _check(result, tmp_path / "mm")
    assert result["passed"] and result["value"] <= 0.10, result


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
