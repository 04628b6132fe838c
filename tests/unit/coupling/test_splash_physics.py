"""The crater law (SP-1), wetness-weakened strength (SP-2), mud mixing and diffusion (SP-4)."""

import math

import numpy as np
import pytest

from erosim.core.errors import ConfigError
from erosim.coupling.raster import Raster
from erosim.erosion.splash import crater_depth, crater_increment, crater_radius, crater_volume, imprint_depth
from erosim.erosion.wet_strength import WetStrengthParams, strength, weakening
from erosim.sph.mud import diffuse_concentration, mixture_acceleration, mixture_density, mixture_viscosity


def test_crater_depth_is_the_formula_and_proportional_to_speed():
    R, rho = 2e-3, 1000.0
    for sigma in (4e3, 2e4):
        for v in (1.0, 3.0, 7.5):
            assert crater_depth(R, v, rho, sigma) == pytest.approx(R * v * math.sqrt(2 * rho / (9 * sigma)), rel=1e-14)
        d = crater_depth(R, np.array([1.0, 2.0, 4.0]), rho, sigma)
        np.testing.assert_allclose(d / d[0], [1.0, 2.0, 4.0], rtol=1e-14)  # d ∝ v at fixed σ


def test_weaker_ground_gives_deeper_craters_and_chord_of_the_cap():
    R = 2e-3
    d_strong, d_weak = crater_depth(R, 4.0, 1000.0, 2e4), crater_depth(R, 4.0, 1000.0, 4e3)
    assert d_weak > d_strong
    assert d_weak / d_strong == pytest.approx(math.sqrt(5.0), rel=1e-12)  # d ∝ σ^(-1/2)
    for d in (0.1 * R, 0.5 * R, R):
        a = crater_radius(R, d)
        assert a == pytest.approx(math.sqrt(2 * R * d - d * d), rel=1e-14)
        # the opening lies on the sphere of radius R whose bottom is d deep: (R − d)² + a² = R²
        assert (R - d) ** 2 + a**2 == pytest.approx(R * R, rel=1e-12)
    assert crater_radius(R, 1.7 * R) == pytest.approx(R)  # deeper than R: the opening stays R


def test_crater_volume_matches_the_imprint_integral():
    R = 1.0
    for d in (0.3, 1.0, 1.5):
        r = np.linspace(0, R, 200001)
        integral = np.trapezoid(2 * np.pi * r * imprint_depth(r, R, d), r)
        # trapezoid error ~h^1.5 at the √(R²−r²) edge: 2e-6 here
        assert integral == pytest.approx(float(crater_volume(R, d)), rel=1e-5)


def test_crater_on_a_fine_heightmap_has_the_law_depth_and_volume():
    R, d = 2e-3, 1.2e-3
    cell = R / 20
    r = Raster(0.0, 0.0, cell, cell, 161, 161)
    dz = crater_increment(r, np.array([[80 * cell, 80 * cell]]), R, np.array([d]))
    assert -dz.min() == pytest.approx(d, rel=1e-12)  # the node under the impact
    # node sums converge to the cap volume (second order in the cell: ≈ 1 % at R/20)
    assert -dz.sum() * r.cell_area == pytest.approx(float(crater_volume(R, d)), rel=0.02)
    wet = np.argwhere(dz < 0)
    reach = np.hypot(*(wet - 80).T).max() * cell
    assert reach <= float(crater_radius(R, d)) + 1e-12


def test_a_crater_smaller_than_a_cell_keeps_its_volume():
    R, d = 1e-3, 5e-4
    r = Raster(0.0, 0.0, 0.01, 0.01, 5, 5)
    dz = crater_increment(r, np.array([[0.013, 0.027]]), R, np.array([d]))
    assert -dz.sum() * r.cell_area == pytest.approx(float(crater_volume(R, d)), rel=1e-12)
    # radially symmetric footprint (not the four-node bilinear square): within two cells, each node's share a
    # function of its distance alone, falling outward
    jj, ii = np.nonzero(dz)
    dist = np.hypot(ii * 0.01 - 0.013, jj * 0.01 - 0.027)
    assert dist.max() < 2 * 0.01 and len(dist) > 4
    order = np.argsort(dist)
    assert np.all(np.diff(-dz[jj, ii][order]) <= 1e-18)


def test_strength_end_values_and_monotone():
    s0, s1 = 2e4, 4e3
    assert strength(0.0, s0, s1) == pytest.approx(s0, rel=1e-14)
    assert strength(1.0, s0, s1) == pytest.approx(s1, rel=1e-14)
    th = np.linspace(0, 1, 1001)
    s = strength(th, s0, s1)
    assert np.all(np.diff(s) < 0)
    assert weakening(0.5) == pytest.approx((math.exp(0.25) - 1) / (math.e - 1), rel=1e-14)


def test_wet_stronger_than_dry_is_refused():
    with pytest.raises(ConfigError, match="sigma_wet = 30000 Pa is above ground.sigma_dry = 20000 Pa"):
        WetStrengthParams(sigma_dry=2e4, sigma_wet=3e4)


def test_mixture_density_and_viscosity():
    assert mixture_density(0.0, 1000, 2650) == pytest.approx(1000)
    assert mixture_density(0.3, 1000, 2650) == pytest.approx(0.3 * 2650 + 0.7 * 1000)
    assert mixture_viscosity(1.0, 1e-3, 2.0) == pytest.approx(2.0)


def test_a_blob_of_mud_spreads_and_keeps_its_solid():
    dx = 0.01
    ax = np.arange(12) * dx
    pos = np.stack([g.ravel() for g in np.meshgrid(ax, ax, ax, indexing="ij")], axis=1)
    c = np.where(np.linalg.norm(pos - 5.5 * dx, axis=1) < 2.2 * dx, 0.4, 0.0)
    vol = dx**3
    total0 = c.sum() * vol
    var0 = (c * ((pos - pos.mean(0)) ** 2).sum(1)).sum() / c.sum()
    steps = diffuse_concentration(pos, c, vol, 2.0 * dx, 1e-4, 0.2)
    assert steps >= 1
    assert abs(c.sum() * vol - total0) / total0 < 1e-12  # pairwise exchange: rounding only
    assert c.min() >= 0.0 and c.max() <= 0.4  # no overshoot (sub-steps keep the maximum principle)
    var1 = (c * ((pos - pos.mean(0)) ** 2).sum(1)).sum() / c.sum()
    assert var1 > var0 * 1.2  # it spread


def test_mud_sinks_through_still_water_and_falls_freely_in_air():
    g = np.array([0.0, 0.0, -9.81])
    c = np.array([0.0, 0.3, 0.5])
    rho = mixture_density(c, 1000.0, 2650.0)
    # in still water the pair forces hold the water up (a_water = 0): mud sinks at g(ρ − ρ_f)/ρ (buoyancy)
    still = mixture_acceleration(np.zeros((3, 3)), g, c, 1000.0, 2650.0)
    np.testing.assert_allclose(still[:, 2], -9.81 * (rho - 1000.0) / rho, rtol=1e-14)
    # a free-falling particle (no forces: a_water = g) falls at g whatever it carries
    np.testing.assert_allclose(mixture_acceleration(np.tile(g, (3, 1)), g, c, 1000.0, 2650.0), np.tile(g, (3, 1)))


def test_puddles_are_the_water_standing_in_closed_hollows():
    from types import SimpleNamespace

    from erosim.coupling.puddles import hollow_depth, standing_water

    r = Raster(0.0, 0.0, 0.1, 0.1, 9, 9)
    x, y = np.meshgrid(np.arange(9) * 0.1, np.arange(9) * 0.1)
    z = 0.5 * x.copy()  # a plane sloping towards x = 0 (open: water runs off) ...
    z[3:6, 5:8] -= 0.2  # ... with a closed hollow dug into it
    hollows = hollow_depth(z)
    assert hollows[4, 6] > 0 and hollows[4, 1] == 0
    pos = np.array([[0.6, 0.4, 0.0], [0.6, 0.4, 0.01], [0.1, 0.4, 0.05]])  # two in the hollow, one on the slope
    water = np.array([1.0, 0.25, 1.0])  # the second has given three quarters of its water to the ground
    state = SimpleNamespace(n_fluid=3, pos=pos, water=water)
    solver = SimpleNamespace(state=state, params=SimpleNamespace(spacing=0.05))  # footprints inside one cell
    wet = SimpleNamespace(solver=solver, vp=1e-6, terrain=z)
    puddles = standing_water(wet, r, hollows)
    # the water held in the hollow (1.25e-6 m³), none of the slope's, stands level in it
    assert puddles.sum() * r.cell_area == pytest.approx(1.25e-6, rel=1e-12)
    assert (puddles[hollows <= 0] == 0).all()
    wetted = puddles > 0
    level = (z + puddles)[wetted]
    assert wetted.any() and np.ptp(level) < 1e-12


def _ground_on(z, outside=None, spacing=0.5, layers=3):
    from erosim.coupling.porous_ground import PorousGround

    r = Raster(0.0, 0.0, 1.0, 1.0, z.shape[1], z.shape[0])
    return r, PorousGround(r, z, spacing, layers, 0.4, 0.2, 2650.0, outside=outside)


def test_no_ground_column_stands_over_nodata_and_points_there_find_the_nearest_one():
    z = np.zeros((12, 12))
    hole = np.zeros_like(z, bool)
    hole[4:7, 5:8] = True
    r, g = _ground_on(z, hole)
    ix = np.floor(g.xy[:, 0] / r.dx + 0.5).astype(int)
    iy = np.floor(g.xy[:, 1] / r.dy + 0.5).astype(int)
    assert not hole[iy, ix].any() and g.ncol == 22 * 22 - 6 * 6  # the 6 × 6 sites nearest the hole's nodes
    assert g.n == 3 * g.ncol and np.array_equal(g.column[: g.ncol], np.arange(g.ncol))
    cols = g.column_of(np.array([[6.0, 5.0], [0.3, 0.3]]))  # the hole's centre, and a corner
    assert cols.min() >= 0 and np.hypot(*(g.xy[cols[0]] - [6.0, 5.0])) <= 1.8  # nearest kept: beside the hole
    assert np.array_equal(g.xy[cols[1]], [0.25, 0.25])


def test_moving_some_columns_remeasures_their_pairs_exactly_as_a_full_laying():
    x = np.arange(10.0)
    z = 0.2 * x[None, :] + 0.1 * np.sin(x[:, None])
    r, g = _ground_on(z)
    w0 = g.weights(1e-3)
    z[3:5, 2:4] -= 0.07  # a crater
    moved = g.follow()
    w = w0.copy()
    w[moved] = g.weights(1e-3, moved)
    r_part = g._r.copy()
    assert 0 < len(moved) < len(w0)
    g.follow(full=True)
    assert np.array_equal(g._r, r_part) and np.array_equal(g.weights(1e-3), w)  # bit for bit
    assert not np.array_equal(w, w0)
    assert len(g.follow()) == 0  # nothing moved since


def test_mud_settles_only_on_the_terrain_and_keeps_its_volume():
    from erosim.coupling.splash_coupler import _scatter

    r = Raster(0.0, 0.0, 1.0, 1.0, 6, 6)
    valid = np.ones(r.shape, bool)
    valid[2, 3] = False
    xy = np.array([[2.6, 2.2], [0.5, 0.5]])
    vol = np.array([0.3, 0.1])
    dz = _scatter(r, xy, vol, valid)
    assert dz[2, 3] == 0.0 and dz.sum() * r.cell_area == pytest.approx(vol.sum(), rel=1e-14)
    assert np.array_equal(_scatter(r, xy[1:], vol[1:], valid), _scatter(r, xy[1:], vol[1:]))


def test_water_over_nodata_leaves_and_is_counted():
    from erosim.core.schedules import IterationInterval
    from erosim.coupling.sources import OutsideOutflow
    from erosim.sph.params import SPHParams
    from erosim.sph.solver import SPHSolver

    r = Raster(0.0, 0.0, 1.0, 1.0, 8, 8)
    hole = np.zeros(r.shape, bool)
    hole[3, 4] = True  # the node at x = 4, y = 3
    pos = np.array([[4.2, 3.3, 1.0], [4.6, 3.0, 1.0], [1.0, 1.0, 1.0]])  # over the hole (nearest node), beside, away
    p = SPHParams(dim=3, spacing=0.5, sound_speed=10.0)
    solver = SPHSolver(p, pos, domain_lo=[-2, -2, -2], domain_hi=[10, 10, 5])
    solver.state.register("water", fill=1.0)
    solver.state.water[:] = np.where(solver.state.ids[:3] == 0, 0.25, 1.0)  # internal order; label 0 over the hole
    out = OutsideOutflow(IterationInterval(1), solver, r, hole)
    out()
    assert solver.n_fluid == 2 and solver.state.removed == {"outside": 1}
    assert out.left["water"] == 0.25 and solver.state.removed_sums["water"] == 0.25
