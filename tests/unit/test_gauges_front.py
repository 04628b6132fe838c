"""Pressure probes, water-level gauges and the surge front on states whose answers are known."""

import numpy as np
import pytest

from erosim.analysis.front import front_position, nondimensional_front
from erosim.analysis.gauges import probe_pressure, water_depth
from erosim.scenarios.builders_sph import lattice

DX = 0.01


def _tank(dim):
    hi = [0.3, 0.2] if dim == 2 else [0.2, 0.2, 0.2]
    return lattice([0.0] * dim, hi, DX)


@pytest.mark.parametrize("dim", [2, 3])
def test_probe_reproduces_a_linear_pressure_field(dim):
    """Shepard interpolation is exact for a linear field on a symmetric lattice neighbourhood
    (up to round-off): p = ρ₀g(H − z) at interior points."""
    pos = _tank(dim)
    p = 1000 * 9.81 * (0.2 - pos[:, -1])
    pts = np.array([[0.1] * (dim - 1) + [z] for z in (0.05, 0.1, 0.15)])
    got = probe_pressure(pos, p, DX**dim, pts, h=2 * DX)
    np.testing.assert_allclose(got, 1000 * 9.81 * (0.2 - pts[:, -1]), rtol=1e-9)


def test_dry_probe_reads_zero():
    pos = _tank(2)
    got = probe_pressure(pos, np.ones(len(pos)), DX**2, np.array([[0.1, 0.5]]), h=2 * DX)
    assert got[0] == 0.0


def test_gauge_depth_is_the_water_top_and_zero_when_dry():
    pos = _tank(2)  # water to y = 0.2
    got = water_depth(pos, np.array([[0.1], [0.29], [0.6]]), radius=DX, spacing=DX, floor=0.0)
    np.testing.assert_allclose(got, [0.2, 0.2, 0.0], atol=1e-12)


def test_front_skips_isolated_spray():
    pos = _tank(2)  # column occupies x in [0, 0.3]
    assert front_position(pos, DX, origin=0.0) == pytest.approx(0.3)
    spray = np.vstack([pos, [[0.5, 0.1]]])  # a lone droplet ahead is not the wetted front
    assert front_position(spray, DX, origin=0.0) == pytest.approx(0.3)
    film = np.vstack([pos, [[0.305, 0.005], [0.315, 0.005]]])  # a connected film is
    assert front_position(film, DX, origin=0.0) == pytest.approx(0.32)


def test_nondimensional_front():
    T, Z = nondimensional_front(np.array([0.0, 1.0]), np.array([0.05715, 0.1143]), 0.05715, 9.81)
    np.testing.assert_allclose(T, [0.0, np.sqrt(2 * 9.81 / 0.05715)])
    np.testing.assert_allclose(Z, [1.0, 2.0])
