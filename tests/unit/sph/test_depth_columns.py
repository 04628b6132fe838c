"""The water columns of a 3-D SPH fluid and Manning's friction on them (the 3-D flood, issue 9)."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from erosim.sph.depth_columns import column_fields
from erosim.sph.manning_columns import ManningColumns

DX = 0.5


def _sheet(nx=20, ny=20, layers=4, every=1, u=(1.0, -0.5)):
    """Particles stacked ``layers`` high on every ``every``-th column of an nx × ny lattice of DX."""
    xs = (np.arange(0, nx, every) + 0.5) * DX
    ys = (np.arange(0, ny, every) + 0.5) * DX
    X, Y, Z = np.meshgrid(xs, ys, (np.arange(layers) + 0.5) * DX, indexing="ij")
    pos = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    vel = np.zeros_like(pos)
    vel[:, :2] = u
    return pos, vel, np.full(len(pos), DX**3)


def test_a_uniform_sheet_has_its_depth_and_velocity():
    pos, vel, vol = _sheet()
    d, u, (D, Ux, Uy), (iy, ix) = column_fields(pos, vel, vol, DX, (40, 40))
    inner = (ix >= 5) & (ix < 15) & (iy >= 5) & (iy < 15)  # ≥ 4σ from the sheet's edge
    # the discrete Gaussian sums to one: a uniform sheet keeps its depth to round-off
    assert np.allclose(d[inner], 4 * DX, rtol=1e-12)
    assert np.allclose(u[inner], [1.0, -0.5], rtol=1e-12)
    # wherever it is wet, the velocity is the one velocity of all the water
    wet = D > 1e-9
    assert np.allclose(Ux[wet], 1.0) and np.allclose(Uy[wet], -0.5)


def test_a_sparse_film_keeps_its_volume_and_gets_its_mean_depth():
    """One particle on every third column: the film is DX/9 deep on average, not one particle high."""
    pos, vel, vol = _sheet(nx=30, ny=30, layers=1, every=3)
    d, _, (D, _, _), (iy, ix) = column_fields(pos, vel, vol, DX, (60, 60))
    assert D.sum() * DX * DX == pytest.approx(vol.sum(), rel=1e-12)  # the smoothing moves water, never adds any
    # at its particles the film reads 2.3× its mean depth (σ = 0.79 Δx is fixed, one particle per
    # 9 columns peaks at 9/(2π·0.79²)), not a column of one particle, DX = 0.5 m
    inner = (ix >= 9) & (ix < 21) & (iy >= 9) & (iy < 21)
    assert np.allclose(d[inner], 9 / (2 * np.pi * 0.79**2) * DX / 9, rtol=0.05)


def _solver(pos, vel, vol):
    st = SimpleNamespace(pos=pos, vel=vel, rho=np.full(len(vol), 1000.0), n_fluid=len(vol))
    return SimpleNamespace(state=st, m=1000.0 * DX**3)


def test_manning_columns_slow_a_sheet_as_the_shallow_water_law():
    """A 2 m sheet at 1.1 m/s: every column's velocity becomes u/(1 + Δt g n²|u|/D^{4/3}), the
    shallow-water solver's semi-implicit Manning step (erosim.sph.kernels_swe.kick)."""
    pos, vel, vol = _sheet(u=(1.0, -0.5))
    solver = _solver(pos, vel, vol)
    n, dt, g = 0.035, 0.01, 9.81
    ManningColumns(n, DX, (40, 40), 5.0, g).correct(solver, dt)
    ix, iy = (pos[:, 0] / DX).astype(int), (pos[:, 1] / DX).astype(int)
    inner = (ix >= 5) & (ix < 15) & (iy >= 5) & (iy < 15)
    speed, depth = math.hypot(1.0, 0.5), 4 * DX
    f = 1.0 / (1.0 + dt * g * n * n * speed / depth ** (4 / 3))
    assert np.allclose(vel[inner, :2], np.array([1.0, -0.5]) * f, rtol=1e-12)
    assert np.all(vel[:, 2] == 0.0)  # horizontal only


def test_manning_columns_stop_water_but_never_reverse_it():
    pos, vel, vol = _sheet(layers=1, every=3, u=(2.0, 0.0))
    vel[::2, 0] = 3.0  # particles keep their deviation from the column's mean
    solver = _solver(pos, vel, vol)
    ManningColumns(0.1, DX, (40, 40), 5.0).correct(solver, 1e6)  # an absurd step: the columns stop
    momentum = (vol * vel[:, 0]).sum()
    # what is left is the particles' deviation from their smoothed column mean, not the flow
    assert abs(momentum) < 1e-4 * (vol * 2.5).sum()
    assert np.all(np.abs(vel[:, 0]) <= 0.5 + 1e-9)


def test_a_manning_map_is_read_at_the_nearest_node():
    pos, vel, vol = _sheet()
    solver = _solver(pos, vel.copy(), vol)
    ManningColumns(np.zeros((4, 4)), DX, (40, 40), 5.0).correct(solver, 0.1)
    assert np.array_equal(solver.state.vel, vel)  # n = 0 everywhere: no friction
