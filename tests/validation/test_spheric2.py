"""SPHERIC Test 2 (3-D dam break against a box, Kleefsman et al. 2005): the shipped measurements,
the error measures on known series, and the coarse case against the experiment (issue 14)."""

import json

import numpy as np
import pytest

from erosim.data import SPHERIC2, reference_csv
from erosim.validation import spheric2 as sp
from erosim.validation.criteria import verdict

EXP = reference_csv(SPHERIC2)


def test_measurements_are_labelled_by_gauge_position():
    """The source swaps H1 and H3; shipped under their gauges, H3 (1.488 m, 0.50 m from the gate) wets
    before H2 (0.992 m), and H2 before H1 (0.496 m, behind the box); H4 starts at the column's 0.55 m."""

    def wetted(name):
        return EXP["t_s"][np.argmax(EXP[name] > 0.02)]

    assert wetted("H3_m") < wetted("H2_m") < wetted("H1_m")
    assert EXP["H4_m"][0] == pytest.approx(0.55, abs=0.01)
    assert len(EXP["t_s"]) == 7395 and EXP["t_s"][-1] > 7.0


def test_no_gauge_wets_faster_than_a_dam_break_front_can_reach_it():
    """Ritter's front on a dry bed, 2√(gH) = 4.65 m/s, is the fastest a dam break spreads (friction and
    a real gate only slow it). Each gauge's first 2 mm comes no sooner than that front from the gate at
    x = 1.992 m reaches it; under the source's labels its "H1" (0.186 s) would sit 1.50 m from the gate,
    8 m/s. The file's H3 wets at 2.7 m/s on average from rest, H2 at 2.8 m/s."""
    ritter = 2.0 * np.sqrt(9.81 * sp.H)
    x = {"H1_m": 0.496, "H2_m": 0.992, "H3_m": 1.488}
    first = {g: EXP["t_s"][np.argmax(EXP[g] > 0.002)] for g in x}
    for g, xg in x.items():
        assert (1.992 - xg) / first[g] < ritter, (g, first[g])
    assert (1.992 - x["H1_m"]) / first["H3_m"] > ritter  # the source's labelling breaks the bound


def test_error_measures_on_known_series():
    t = np.arange(0.0, 1.6, 0.002)
    run = {"t": t}
    for g in sp.GAUGES:
        run[f"depth_{g}"] = np.interp(t, EXP["t_s"], EXP[f"{g}_m"])
    for p in sp.PROBES:
        run[f"p_{p}"] = np.interp(t, EXP["t_s"], EXP[f"{p}_Pa"])
    e = sp.errors(run, EXP, 1000.0, 9.81)
    assert max(e["level_rms_m"].values()) < 1e-12
    assert max(e["pressure_rms_rel"].values()) < 0.02  # ±10 ms means of the 1 ms record vs of its 2 ms resampling
    run["wire_H1"] = run["depth_H1"] - 0.02  # the wire's reading is scored apart from the column's
    run["depth_H2"] = run["depth_H2"] + 0.055  # 10 % of H too high everywhere
    run["p_P3"] = run["p_P3"] - 0.2 * 1000 * 9.81 * sp.H
    e = sp.errors(run, EXP, 1000.0, 9.81)
    assert e["level_rms_rel"]["H2"] == pytest.approx(0.10, rel=1e-9)
    assert e["wire_level_rms_m"] == {"H1": pytest.approx(0.02, rel=1e-9)} and e["level_rms_m"]["H1"] < 1e-12
    assert e["pressure_rms_rel"]["P3"] == pytest.approx(0.20, abs=0.02)


def _e(wire=0.03, column=None, p1=0.13, p3=0.13, **per_gauge):
    """Errors as :func:`sp.errors` gives them: every gauge's wetted length ``wire`` (m) unless given per
    gauge (``H1=0.06``), the column as ``column`` (default: the wetted length)."""
    w = {g: per_gauge.get(g, wire) for g in sp.GAUGES}
    c = {g: column if column is not None else w[g] for g in sp.GAUGES}
    return {"wire_level_rms_m": w, "level_rms_m": c, "pressure_rms_rel": {"P1": p1, "P2": 0.5, "P3": p3, "P4": 0.5}}


def test_criteria_score_the_wetted_length_and_p1_p3():
    """Pass: each gauge's wetted-length RMS ≤ 55 mm and P1, P3 ≤ 25 % of ρ₀gH; the column is reported in
    each gauge's line but not scored, nor P2 and P4; a miss names the gauge, its value and the limit."""
    crit, note = sp.criteria(_e(column=0.070), "default")
    assert [c["name"] for c in crit] == ["H1 level", "H2 level", "H3 level", "H4 level", "P1 pressure", "P3 pressure"]
    assert all(c["passed"] for c in crit) and note == "" and verdict(crit)[0]
    assert crit[0]["limit"] == pytest.approx(0.055) and "column 70.0 mm" in crit[0]["line"]
    passed, line = verdict(*sp.criteria(_e(H1=0.0551), "fine"))
    assert not passed and line == "failed H1 level: wetted-length RMS over 0-1.5 s (column 55.1 mm): 55.1 mm > 55.0 mm"
    passed, line = verdict(*sp.criteria(_e(p3=0.26), "default"))
    assert not passed and "P3 pressure" in line and "26.0 % > 25.0 %" in line and "H1" not in line
    with pytest.raises(Exception, match="wetted length"):
        sp.criteria({**_e(), "wire_level_rms_m": {}}, "default")


def test_coarse_says_it_is_not_expected_to_meet_the_targets():
    """The targets are set for the default resolution and finer: a coarse miss says so in its one line."""
    passed, line = verdict(*sp.criteria(_e(H1=0.063, p1=0.29), "coarse"))
    assert not passed and line.count("\n") == 0
    assert "H1 level" in line and "63.0 mm > 55.0 mm" in line and "P1 pressure" in line and "29.0 % > 25.0 %" in line
    assert line.endswith("coarse (dx = 0.05 m) is not expected to meet the targets, which are set for default "
                         "(dx = 0.025 m) and finer")  # fmt: skip
    assert verdict(*sp.criteria(_e(), "coarse"))[0]  # were coarse to meet them, it would pass


def _level_errors(tmp_path, spacing):
    from erosim.io.runfolder import RunFolder
    from erosim.scenarios import loader
    from erosim.scenarios.runner import execute

    sets = [f"sph.spacing={spacing!r}", "run.t_end=1.6", "run.output_interval=0", "run.snapshots=0"]
    folder = RunFolder(tmp_path / f"dx{spacing}")
    execute(loader.load("spheric2", sets), folder, progress=False)
    return sp.errors(sp._csv(folder.path / "gauges.csv"), EXP, 1000.0, 9.81)


#: coarse (Δx = 0.05 m) errors measured 2026-11-24, and their scatter: the spread of each metric when
#: the time step is changed by ±5 % (sph.cfl 0.19 / 0.21), which reorders the flow's small splashes; the
#: pressures re-measured 2026-11-28 when the box's sensors came to read the wetted face with the
#: hydrostatic carry (P1 0.2852 -> 0.2641, P3 0.2488 -> 0.2557; the flow is unchanged)
COARSE_LEVEL = {"H1": (0.1168, 0.020), "H2": (0.0588, 0.003), "H3": (0.0713, 0.005), "H4": (0.0635, 0.005)}
COARSE_PRESSURE = {"P1": (0.2641, 0.010), "P3": (0.2557, 0.015)}


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    out = tmp_path_factory.mktemp("spheric2") / "v"
    return sp.run("coarse", out, progress=False), out


@pytest.mark.slow  # a coarse run of the experiment, about 70 s
def test_coarse_case_against_the_experiment(coarse):
    """Δx = 0.05 m (5 500 particles, about 35 s): the validation's outputs, and each gauge's level RMS
    and P1/P3's pressure RMS held at the measured value plus its scatter (regression bounds; the
    issue's targets, 10 % and 25 %, apply at the default resolution)."""
    result, out = coarse
    assert result["case"] == "spheric2" and result["fluid_particles"] == 5500
    assert (out / "figures" / "spheric2_vs_experiment.png").is_file()
    assert json.loads((out / "validation.json").read_text())["value"] == result["value"]
    for g, (measured, scatter) in COARSE_LEVEL.items():
        assert result["level_rms_rel"][g] <= measured + scatter, (g, result["level_rms_rel"])
    for p, (measured, scatter) in COARSE_PRESSURE.items():
        assert result["pressure_rms_rel"][p] <= measured + scatter, (p, result["pressure_rms_rel"])
    assert result["value"] == max(result["wire_level_rms_rel"].values())
    # coarse misses H1's wetted length (measured 63 mm), P1 and P3 (26 %): it fails and says it is not expected to
    assert not result["passed"] and "H1 level" in result["verdict"] and "not expected" in result["verdict"]
    # the wetted length equals the column wherever no hollow or jet is on the line; jets crossing it put
    # it at most 3 mm further from the lab than the column at any spacing run (H3 at 0.02 m), and the
    # coarse run measured it 0-1.5 mm closer: 5 mm allows that and the run-to-run scatter of the splashes
    assert set(result["wire_level_rms_m"]) == set(sp.GAUGES)
    for g in sp.GAUGES:
        assert result["wire_level_rms_m"][g] <= result["level_rms_m"][g] + 0.005, result["wire_level_rms_m"]


@pytest.mark.slow  # the coarse run and a finer one
def test_water_level_error_shrinks_with_resolution(tmp_path, coarse):
    """Mean level RMS over H1–H4: Δx = 0.07 m → 0.05 m measured 10.0 % → 7.8 % of H (0.03 m: 5.8 %,
    0.02 m: 5.4 %); the finer run must be better by more than the scatter of the coarser (±1 %)."""
    coarser = _level_errors(tmp_path, 0.07)["level_rms_rel"]
    finer = coarse[0]["level_rms_rel"]
    assert np.mean(list(finer.values())) < np.mean(list(coarser.values())) - 0.01


@pytest.mark.slow
def test_default_resolution_meets_the_targets(tmp_path):
    """Δx = 0.025 m (43 120 particles, about 4 min on two threads): every gauge's wetted length within the
    issue's 10 % of H (measured 49 / 13 / 30 / 21 mm) and the box's P1 and P3 within 25 % of ρ₀gH
    (measured 12 %, 17 %; 13 %, 18 % before the sensors read the wetted face with the hydrostatic carry). H1's
    column reading stays above (64 mm): it stops under the air pocket."""
    result = sp.run("default", tmp_path / "v", progress=False)
    assert result["passed"] and result["spacing"] == 0.025, result["verdict"]
    for g in sp.GAUGES:
        assert result["wire_level_rms_rel"][g] <= sp.LEVEL_THRESHOLD, result["wire_level_rms_m"]
    for p in ("P1", "P3"):
        assert result["pressure_rms_rel"][p] <= sp.PRESSURE_THRESHOLD, result["pressure_rms_rel"]
