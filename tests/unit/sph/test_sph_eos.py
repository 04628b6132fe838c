"""Equations of state (SPEC SPH-4)."""

import numpy as np
import pytest

from erosim.sph import eos


def test_tait_values():
    rho0, c, gamma = 1000.0, 20.0, 7.0
    b, g = eos.eos_constants("tait", rho0, c, gamma, 0.0)
    assert b == pytest.approx(rho0 * c * c / gamma) and g == gamma
    assert eos.tait(rho0, rho0, b, g) == 0.0
    assert eos.tait(1010.0, rho0, b, g) == pytest.approx(b * (1.01**7 - 1.0))
    # seed 001's c_s = 140 m/s gives B ≈ 2795 kPa (SPEC SPH-4b)
    assert eos.tait_b(1000.0, 140.0, 7.0) == pytest.approx(2.8e6, rel=1e-9)
    # speed of sound dp/dρ at ρ₀ equals c²
    d = 1e-3
    assert (eos.tait(rho0 + d, rho0, b, g) - eos.tait(rho0 - d, rho0, b, g)) / (2 * d) == pytest.approx(c * c, rel=1e-6)


def test_linear_values_and_its_tait_form():
    rho0, k = 1000.0, 300.0
    assert eos.linear(1003.0, rho0, k, 7.0) == pytest.approx(900.0)
    b, g = eos.eos_constants("linear", rho0, 99.0, 7.0, k)
    assert eos.tait(1003.0, rho0, b, g) == pytest.approx(900.0)  # same law through the loops' formula
    b0, _ = eos.eos_constants("linear", rho0, 20.0, 7.0, 0.0)  # k = 0 means c²
    assert eos.tait(1001.0, rho0, b0, 1.0) == pytest.approx(400.0)


@pytest.mark.parametrize("name", ["tait", "linear"])
def test_inverse(name):
    b, g = eos.eos_constants(name, 1000.0, 15.0, 7.0, 0.0)
    p = np.array([0.0, 10.0, 1e3, 2e4])
    rho = eos.density_for_pressure(p, 1000.0, b, g)
    np.testing.assert_allclose(eos.pressure("tait", rho, 1000.0, b, g), p, atol=1e-6)


def test_unknown_law_is_refused():
    with pytest.raises(ValueError, match="tait"):
        eos.eos_constants("ideal-gas", 1000.0, 10.0, 7.0, 0.0)
