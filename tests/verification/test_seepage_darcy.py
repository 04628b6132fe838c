"""Darcy seepage and moisture diffusion in porous ground particles against their analytic answers (SP-3)."""

import math

import numpy as np
import pytest
from scipy.special import erfc

from erosim.coupling.porous_ground import PorousGround
from erosim.coupling.raster import Raster
from erosim.hydrology.seepage_darcy import absorb, conductivity, drain, evaporate, harmonic
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


def test_two_layer_column_passes_the_harmonic_mean_darcy_rate_and_the_top_soil_fills_first():
    """A top soil of K_t over a subsoil of K_s: a saturated top over a dry subsoil drains at
    K̄A = 2K_tK_s/(K_t + K_s)·A (the series conductance of the two half-layers, s/(s/2K_t + s/2K_s));
    under a puddle the top soil then saturates while the subsoil is still dry, and the puddle sinks
    no faster than the interface lets water through (saturation-excess ponding)."""
    kp_t, kp_s = 2e-8, 5e-11
    r = Raster(0.0, 0.0, 0.01, 0.01, 5, 5)
    g = PorousGround(r, np.zeros(r.shape), 0.01, 2, 0.4, 0.0, 2650.0, permeability=[kp_t, kp_s])
    k_t, k_s = conductivity(kp_t), conductivity(kp_s)
    k_bar = harmonic(k_t * np.ones(g.ncol), k_s * np.ones(g.ncol))
    s = g.s
    assert k_bar[0] == pytest.approx(s / (s / (2 * k_t) + s / (2 * k_s)), rel=1e-14)
    g.theta[g.surface] = 1.0
    dt = 1e-3
    moved = drain(g.theta, g.pore, g.upper, g.lower, k_bar, g.area, dt)
    # exact to rounding: θ_u(1 − θ_l) = 1 at the first step, K̄AΔt per column (well under the pore volume)
    assert moved == pytest.approx(g.ncol * k_bar[0] * g.area * dt, rel=1e-12)
    # and downward: the top loses exactly that, the subsoil gains it (never the reverse)
    step = k_bar[0] * g.area * dt
    assert np.allclose(g.theta[g.surface], 1.0 - step / g.pore[g.surface], rtol=0, atol=1e-15)
    assert np.allclose(g.theta[~g.surface], step / g.pore[~g.surface], rtol=0, atol=1e-15)

    g.theta[:] = 0.0
    water = np.full(g.ncol, 1.0)  # an endless puddle on every column
    contact = np.arange(g.ncol)
    total0 = water.sum() + g.water()
    tau_top = g.pore[0] / (k_t * g.area)  # the top soil fills in about this time at K_t (0.02 s)
    steps, soaked = 400, []
    for _ in range(steps):
        taken, gained = absorb(water, contact, g.theta, g.pore, g.area, k_t, dt)
        water -= taken
        g.theta += gained / g.pore
        drain(g.theta, g.pore, g.upper, g.lower, k_bar, g.area, dt)
        soaked.append(taken.sum())
    top, sub = g.theta[g.surface].mean(), g.theta[~g.surface].mean()
    assert steps * dt > 10 * tau_top
    # the top soil is saturated (within the one step it needs to refill, K_t A Δt/(φV) = 5 %) and the
    # subsoil has taken at most K̄ t A of water (θ ≤ K̄ t/(φ s) = 0.1)
    assert top > 0.95 and sub <= k_bar[0] * steps * dt / (0.4 * s) + 1e-12
    # once the top is full the ground takes no more than the interface passes: K̄A per column at most
    assert soaked[-1] <= g.ncol * k_bar[0] * g.area * dt * (1 + 1e-9)
    assert soaked[0] == pytest.approx(g.ncol * k_t * g.area * dt, rel=1e-12)  # a dry top takes K_t at first
    assert abs(water.sum() + g.water() - total0) / total0 < 1e-12  # water budget: rounding only


def test_wet_over_dry_column_drains_down_and_its_front_moves_down():
    """Darcy drainage q = K̄ θ_u (1 − θ_l) between the layers of a column whose top layer is saturated
    and the rest dry: the first step moves exactly K̄AΔt from the top into the layer below (nothing
    else moves), and afterwards the wetting front (the deepest layer holding water above 1 %) only
    goes down while the water's mean depth only increases and the total stays constant to rounding."""
    r = Raster(0.0, 0.0, 0.01, 0.01, 3, 3)
    g = PorousGround(r, np.zeros(r.shape), 0.01, 6, 0.4, 0.0, 2650.0, permeability=[4e-9] * 6)
    k_bar = harmonic(conductivity(4e-9) * np.ones(len(g.upper)), conductivity(4e-9) * np.ones(len(g.upper)))
    g.theta[g.surface] = 1.0
    dt = 2e-3
    step = k_bar[0] * g.area * dt / g.pore[0]  # 0.0196 of the pore volume per step
    drain(g.theta, g.pore, g.upper, g.lower, k_bar, g.area, dt)
    layer = (g.depth / g.s - 0.5).round().astype(int)
    assert np.allclose(g.theta[layer == 0], 1.0 - step, rtol=0, atol=1e-15)
    assert np.allclose(g.theta[layer == 1], step, rtol=0, atol=1e-15)
    assert np.all(g.theta[layer >= 2] == 0.0)
    total0 = g.water()
    fronts, depths = [], []
    for _ in range(300):
        drain(g.theta, g.pore, g.upper, g.lower, k_bar, g.area, dt)
        held = g.theta * g.pore
        fronts.append(layer[g.theta > 0.01].max())
        depths.append((held * g.depth).sum() / held.sum())
    assert np.all(np.diff(fronts) >= 0) and fronts[0] == 1 and fronts[-1] == g.layers - 1
    assert np.all(np.diff(depths) > 0)
    assert g.theta[layer == 0].max() < 0.5  # the top has drained more than half of its water
    assert abs(g.water() - total0) / total0 < 1e-12
