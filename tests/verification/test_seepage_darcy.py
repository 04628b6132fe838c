"""Darcy seepage and moisture diffusion in porous ground particles against their analytic answers (SP-3)."""

import math

import numpy as np
import pytest
from scipy.special import erfc

from erosim.coupling.porous_ground import PorousGround
from erosim.coupling.raster import Raster
from erosim.hydrology.seepage_darcy import absorb, conductivity, evaporate
from erosim.kernels.sph_diffusion import diffuse


def _flat(n_cells, spacing, layers, porosity=0.4, saturation=0.0):
    r = Raster(0.0, 0.0, spacing, spacing, n_cells + 1, n_cells + 1)
    return PorousGround(r, np.zeros(r.shape), spacing, layers, porosity, saturation, 2650.0)


def test_conductivity_of_a_sand():
    assert conductivity(1e-11) == pytest.approx(1e-11 * 1000 * 9.81 / 1e-3)


def test_puddle_on_a_dry_bed_drains_at_the_darcy_rate():
    """A puddle over a bed whose surface stays dry (deep, fast-draining) sinks at K: volume V0 − K A t."""
    g = _flat(6, 0.01, 1)
    k = 1e-3
    n_f = 3 * g.ncol
    water = np.full(n_f, 1e-6)  # three fluid particles of 1 cm³ over each column
    contact = np.tile(np.arange(g.ncol), 3)
    v0 = water.sum()
    dt, t = 1e-3, 0.0
    for _ in range(50):
        taken, gained = absorb(water, contact, g.theta, g.pore, g.area, k, dt)
        water -= taken
        g.theta[:] = 0.0  # the bed drains everything at once: the surface stays dry
        t += dt
    # exact to rounding: the Darcy flux K(1 − θ) with θ = 0 over the puddle's whole bed area
    assert v0 - water.sum() == pytest.approx(k * g.ncol * g.area * t, rel=1e-12)


def test_closed_surface_layer_fills_as_the_darcy_law_says():
    """One layer, no diffusion: θ(t) = 1 − (1 − θ0) exp(−K A t/(φV)); explicit steps of KAΔt/(φV) = 0.01
    agree to O(Δt) (0.5 % of the rise)."""
    g = _flat(4, 0.01, 1, saturation=0.1)
    k, dt, n = 4e-4, 1e-2, 200
    water = np.full(g.ncol, 1.0)  # plenty on every column
    contact = np.arange(g.ncol)
    total0 = water.sum() + g.water()
    for _ in range(n):
        taken, gained = absorb(water, contact, g.theta, g.pore, g.area, k, dt)
        water -= taken
        g.theta += gained / g.pore
    tau = g.pore[0] / (k * g.area)
    exact = 1 - 0.9 * math.exp(-n * dt / tau)
    assert g.theta[0] == pytest.approx(exact, abs=0.005 * (exact - 0.1))
    assert abs(water.sum() + g.water() - total0) / total0 < 1e-12  # water budget: rounding only


def test_fluid_runs_out_before_the_ground_does():
    g = _flat(2, 0.01, 1)
    water = np.array([1e-9, 2e-9, 0.0])
    contact = np.array([0, 0, 1])
    taken, gained = absorb(water, contact, g.theta, g.pore, g.area, 10.0, 1.0)
    np.testing.assert_allclose(taken, water, rtol=1e-15)  # all of it: the demand is far larger
    assert gained.sum() == pytest.approx(water.sum(), rel=1e-15)


def _front(z, theta, level):
    """Depth where θ first falls below ``level`` (linear between particles)."""
    k = int(np.argmax(theta < level))
    return z[k - 1] + (theta[k - 1] - level) / (theta[k - 1] - theta[k]) * (z[k] - z[k - 1])


def test_moisture_front_moves_as_diffusion_root_t():
    """Wet ground over dry: θ follows ½ erfc(z/(2√(Dt))), so the θ = 0.2 front moves ∝ √t."""
    s, D = 0.01, 1e-4
    g = _flat(14, s, 40, saturation=0.0)
    mid = 20 * s
    g.theta[g.depth < mid] = 1.0
    w = g.weights(D)
    total0 = g.water()
    centre = g.column_of(np.array([[7 * s, 7 * s]]))[0]
    col = centre + g.ncol * np.arange(g.layers)
    z = g.depth[col] - mid
    fronts, t, dt = [], 0.0, 0.25
    for target in (4.0, 16.0):
        while t < target - 1e-9:
            diffuse(g.theta, g.pore, g.i, g.j, w, dt)
            t += dt
        prof = g.theta[col]
        # the SPH Laplacian on a lattice (support 2 spacings) is off the continuum by 0.006 here; 0.015 allowed
        np.testing.assert_allclose(prof, 0.5 * erfc(z / (2 * math.sqrt(D * t))), atol=0.015)
        fronts.append(_front(z, prof, 0.2))
    # √(16/4); measured 1.988 (the front interpolated linearly between particles)
    assert fronts[1] / fronts[0] == pytest.approx(2.0, rel=0.02)
    assert abs(g.water() - total0) / total0 < 1e-12
    assert g.theta.min() >= 0.0 and g.theta.max() <= 1.0


def test_evaporation_takes_from_the_surface_only():
    g = _flat(3, 0.01, 2, saturation=0.5)
    before = g.water()
    gone = evaporate(g.theta, g.pore, g.surface, g.area, 1e-5, 10.0)
    assert gone == pytest.approx(g.ncol * 1e-5 * g.area * 10.0)
    assert g.water() == pytest.approx(before - gone, rel=1e-14)
    assert np.all(g.theta[~g.surface] == 0.5)


def test_seepage_stops_when_the_ground_below_is_saturated():
    """A puddle over ground whose lower layers are saturated (a perched water table over the closed
    bottom of the ground, like a less permeable layer below): the surface takes K(1 − θ)AΔt while it
    has room; diffusion spreads the deficit through the column (the saturated layers give moisture up
    to the drier surface), so the rate falls as the column's pore space fills, and seepage stops when
    it is full: never more than the free pore volume goes in, and the rest of the puddle stands."""
    g = _flat(4, 0.01, 4, saturation=1.0)
    g.theta[g.surface] = 0.2  # only the surface layer has room: 0.8 φV per column
    room = float(((1.0 - g.theta) * g.pore).sum())
    w = g.weights(1e-4)
    water = np.full(g.ncol, 2e-6)  # 2 cm³ over each column, more than its room (0.8·0.4·1 cm³)
    contact = np.arange(g.ncol)
    total0 = water.sum() + g.water()
    rates = []
    for _ in range(600):
        taken, gained = absorb(water, contact, g.theta, g.pore, g.area, 1e-2, 1e-2)
        water -= taken
        g.theta += gained / g.pore
        diffuse(g.theta, g.pore, g.i, g.j, w, 1e-2)
        rates.append(taken.sum())
    assert rates[0] == pytest.approx(1e-2 * 0.8 * g.area * 1e-2 * g.ncol, rel=1e-12)  # K(1 − θ)AΔt at first
    assert np.all(np.diff(rates) <= 1e-12 * rates[0])  # it only slows down as the pores fill
    assert rates[-1] < 1e-2 * rates[0]  # 4·10⁻³ after 6 s: nearly stopped
    absorbed = g.ncol * 2e-6 - water.sum()
    # 93 % of the room after 6 s (the last of it goes in ever more slowly); never more than the room
    assert 0.9 * room < absorbed <= room * (1 + 1e-12)
    assert g.theta.max() <= 1.0
    assert abs(water.sum() + g.water() - total0) / total0 < 1e-12
