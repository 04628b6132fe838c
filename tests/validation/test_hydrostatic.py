"""Tank at rest: pressure against ρ₀g(H − z), density variation and containment (issue 2, item 5)."""

import json

import numpy as np
import pytest

from erosim.validation import hydrostatic as hs


def test_errors_of_the_exact_state():
    z = np.linspace(0.0025, 0.1975, 40)
    pos = np.stack([np.full_like(z, 0.1), z], axis=1)
    p = 1000 * 9.81 * (0.2 - z)
    e = hs.errors(pos, p, np.full_like(z, 1000.0), rho0=1000.0, g=9.81, H=0.2, lo=[0, 0], hi=[0.2, 0.3])
    assert e == {"pressure_rms_rel": 0.0, "density_variation": 0.0, "outside": 0}
    e = hs.errors(
        pos + [0, 0.5], p * 1.05, np.full_like(z, 1005.0), rho0=1000.0, g=9.81, H=0.2, lo=[0, 0], hi=[0.2, 0.3]
    )
    assert e["density_variation"] == pytest.approx(0.005)
    assert e["outside"] == len(z)


def _check(result, out):
    assert result["case"] == "hydrostatic"
    for key in ("metric", "value", "threshold", "passed", "out", "density_variation", "particles_outside"):
        assert key in result
    assert json.loads((out / "validation.json").read_text())["passed"] == result["passed"]
    assert (out / "figures" / "pressure_profile.png").is_file()


#: measured pressure RMS of the coarse tank (2026-11-23) and its scatter: the metric swings between
#: 0.56 % and 0.82 % over t = 0.5…0.7 s as the tank's last sloshing dies out
COARSE_MEASURED, COARSE_SCATTER = 0.0074, 0.0026


def test_coarse_tank_at_rest(tmp_path):
    """H/16 (256 particles), 0.6 s of settling, held to the issue's own bounds (2 % pressure RMS,
    1 % density; measured 0.74 % and 0.48 %; H/40: 0.59 % and 0.49 %) and, as a regression bound, to
    the measured value plus its scatter: without the density corrector, say, the tank still passes
    the issue's bound (1.5 %) but not this one."""
    result = hs.run("coarse", tmp_path / "hs", progress=False)
    _check(result, tmp_path / "hs")
    assert result["particles_outside"] == 0
    assert result["density_variation"] < 0.01, result
    assert result["value"] < 0.02, result
    assert result["value"] <= COARSE_MEASURED + COARSE_SCATTER, result


@pytest.mark.slow
def test_default_tank_at_rest(tmp_path):
    """H/40, 1 s of settling: the issue's pass criterion."""
    result = hs.run("default", tmp_path / "hs", progress=False)
    _check(result, tmp_path / "hs")
    assert result["passed"], result
