"""Shear-stress erosion of a voxel terrain (VX-6, Krištof et al. 2009) on scripted particles."""

import math

import numpy as np
import pytest

from erosim.core.increments import check_budget
from erosim.erosion.shear_stress_kristof2009 import ShearStressErosion, ShearStressParams
from erosim.terrain.voxel import Box, HalfSpace, VoxelTerrain

H_SUPPORT = 0.02  # kernel support h (m) of the scripted fluid


def _block(value=0.8, n=(9, 9, 9), cell=0.01):
    """A field of uniform density ``value`` on n nodes (z, y, x) of ``cell`` metres from the origin."""
    return VoxelTerrain(np.full(n, value, np.float32), cell)


def _one(terrain, params, pos, vel, wall_l):
    e = ShearStressErosion(terrain, params, support=H_SUPPORT)
    return e, e.rates(np.array([pos], float), np.array([vel], float), np.array([wall_l], float))


def test_theta_power_law_at_one_grid_point():
    """One particle 1.5 cm from the node at the grid's centre, moving across r̂ (all of its speed is
    shear) with l = 0.3 cm from the wall: θ = |v|/(r − min(l, 0.4h)) and the rate K θⁿ − τ_c exactly;
    doubling the speed multiplies θⁿ by 2ⁿ; a particle moving along r̂ shears nothing."""
    vt = _block()
    node = np.array([0.04, 0.04, 0.04])
    pos = node + [0.0, 0.0, 0.015]
    p = ShearStressParams(tau_c=0.0, radius=0.02)
    for speed in (0.5, 1.0, 2.0):
        e, r = _one(vt, p, pos, [speed, 0.0, 0.0], 0.003)
        theta = speed / (0.015 - 0.003)
        assert r[4, 4, 4] == pytest.approx(theta**0.5, rel=1e-12)
    e, r2 = _one(vt, p, pos, [0.0, 0.0, 2.0], 0.003)
    assert r2[4, 4, 4] == 0.0
    # the correction is capped at 0.4 h and θ's distance floored at l_min = 0.4 h
    e, r3 = _one(vt, p, node + [0.0, 0.0, 0.01], [1.0, 0.0, 0.0], 0.05)
    assert r3[4, 4, 4] == pytest.approx((1.0 / max(0.01 - 0.4 * H_SUPPORT, 0.4 * H_SUPPORT)) ** 0.5)
    # n = 1: linear in θ
    e, r4 = _one(vt, ShearStressParams(tau_c=0.0, n=1.0, radius=0.02), pos, [1.0, 0.0, 0.0], 0.003)
    assert r4[4, 4, 4] == pytest.approx(1.0 / 0.012)


def test_nothing_below_the_critical_stress():
    """A particle at 1 m/s across the nodes half a cell (5 mm) below it: their distance is floored at
    l_min = 0.4h = 8 mm, θⁿ = √(1/0.008) = 11.18 s^-½ at most: τ_c = 11.2 erodes nothing, τ_c = 11.1 erodes."""
    vt = _block()
    pos = np.array([[0.04, 0.04, 0.055]])
    vel = np.array([[1.0, 0.0, 0.0]])
    none = ShearStressErosion(vt, ShearStressParams(tau_c=11.2, radius=0.02), support=H_SUPPORT)
    assert not none.rates(pos, vel, np.array([0.003])).any()
    inc = none.transfer(pos, vel, 10.0, np.array([0.003]))
    assert not inc.dz.any() and inc.carried_off == 0.0 and not none.pending.any()
    some = ShearStressErosion(vt, ShearStressParams(tau_c=11.1, radius=0.02), support=H_SUPPORT)
    assert some.rates(pos, vel, np.array([0.003])).max() == pytest.approx(math.sqrt(1 / 0.008) - 11.1)
    still = ShearStressErosion(vt, ShearStressParams(tau_c=0.0), support=H_SUPPORT)
    assert not still.rates(pos, np.zeros((1, 3)), np.array([0.003])).any()  # water at rest


def test_quantised_transfer_keeps_the_total():
    """Many calls each eroding less than one quantum: nothing moves at first, then whole quanta; after
    every call Σ accumulated = removed + pending (+ unmet, 0 here) to float64 rounding (1e-12 relative),
    each node's change is a whole number of quanta but for float32 rounding (6e-8 on a quantum of 3.9e-3:
    1.5e-5 of a quantum; asserted 1e-4), and the increments close the eroder contract's budget."""
    vt = _block(value=0.9)
    rng = np.random.default_rng(5)
    pos = np.column_stack([rng.uniform(0.01, 0.07, 40), rng.uniform(0.01, 0.07, 40), rng.uniform(0.01, 0.07, 40)])
    vel = rng.normal(size=(40, 3))
    wl = rng.uniform(0.0, 0.01, 40)
    p = ShearStressParams(k_eps=0.02, tau_c=1.0)
    e = ShearStressErosion(vt, p, support=H_SUPPORT)
    per_call = e.rates(pos, vel, wl) * p.k_eps * 1e-3  # solid fraction per call of dt = 1 ms
    assert 0 < per_call.max() < p.quantum  # less than a quantum a call
    asked = 0.0
    first = None
    for call in range(400):
        # the rates of this call (the eroded field's gradient turns the wall normals, so they change)
        asked += e.rates(pos, vel, wl).sum() * p.k_eps * 1e-3 * vt.cell_size**3
        inc = e.transfer(pos, vel, 1e-3, wl)
        check_budget(inc, vt.shape, vt.volume_per_unit, "shear stress")
        vt.density[...] = vt.density + inc.dz  # the caller's step (float64 sum, exact back in float32)
        if first is None and inc.carried_off > 0:
            first = call
        steps = -inc.dz / e.quantum
        assert np.abs(steps - np.round(steps)).max() < 1e-4
        assert e.removed_total + e.pending_volume() + e.unmet_total == pytest.approx(asked, rel=1e-12)
    assert first is not None and first > 0
    assert e.unmet_total == 0.0
    assert 0.9 * vt.cell_size**3 * vt.density.size - vt.solid_volume() == pytest.approx(e.removed_total, rel=1e-6)


def test_non_erodible_base_and_empty_nodes():
    """Nodes below ``non_erodible_below`` keep their density; an eroded node stops at d_air and the
    erosion it could not take is counted as unmet. (A ramp half-width of 5 mm, under the cell: the plinth's
    floor density, that of the half-space z < 0.035 m, is then d_air at every node above it.)"""
    vt = VoxelTerrain(np.full((9, 9, 9), 0.05, np.float32), 0.01, band=0.005)
    pos = np.array([[0.04, 0.04, 0.04]])
    vel = np.array([[3.0, 0.0, 0.0]])
    p = ShearStressParams(k_eps=100.0, tau_c=0.0, radius=0.03, non_erodible_below=0.035)
    e = ShearStressErosion(vt, p, support=H_SUPPORT)
    inc = e.transfer(pos, vel, 1.0, np.array([0.0]))
    z = vt.axes()[2]
    below = z < 0.035
    assert not inc.dz[below].any() and inc.dz[~below].min() < 0
    new = vt.density + inc.dz
    assert new.min() >= 0.0 and np.isclose(new[~below].min(), 0.0)
    assert e.unmet_total > 0 and e.pending_volume() == 0.0
    assert e.removed_total == pytest.approx(-inc.dz.sum() * vt.volume_per_unit)


def test_state_dict_resumes_identically():
    vt1, vt2 = _block(), _block()
    rng = np.random.default_rng(7)
    pos = rng.uniform(0.01, 0.07, (30, 3))
    vel = rng.normal(size=(30, 3))
    p = ShearStressParams(k_eps=0.05, tau_c=2.0)
    a = ShearStressErosion(vt1, p, support=H_SUPPORT)
    for _ in range(3):
        vt1.density += a.transfer(pos, vel, 0.01).dz.astype(np.float32)
    b = ShearStressErosion(vt2, p, support=H_SUPPORT)
    vt2.density[...] = vt1.density
    b.load_state_dict(a.state_dict())
    assert np.array_equal(a.transfer(pos, vel, 0.01).dz, b.transfer(pos, vel, 0.01).dz)


def test_water_scours_a_voxel_floor_through_the_wall_and_the_contract():
    """A sheet of water sliding at 1 m/s over a voxel floor (1 cm voxels, Δx = 1 cm): eroded every 50
    steps, the increments close the budget, the field loses exactly the removed volume, nothing below
    the non-erodible level changes, and after each refresh no particle is inside the solid."""
    from erosim.sph.boundaries.voxel_wall import VoxelWall
    from erosim.sph.params import SPHParams
    from erosim.sph.solver import SPHSolver
    from erosim.terrain.voxel import HalfSpace

    dx = 0.01
    vt = VoxelTerrain.from_shapes(HalfSpace((0, 0, 0.05), (0, 0, 1)), (0, 0, 0), (0.3, 0.1, 0.12), dx)
    g = np.meshgrid((np.arange(20) + 0.5) * dx, (np.arange(10) + 0.5) * dx, 0.05 + (np.arange(3) + 0.5) * dx,
                    indexing="ij")  # fmt: skip
    fluid = np.stack([a.ravel() for a in g], axis=1)
    wall = VoxelWall(vt)
    s = SPHSolver(SPHParams(dim=3, spacing=dx, walls="reflect"), fluid, fluid_vel=np.tile([1.0, 0, 0], (len(fluid), 1)),
                  domain_lo=vt.lo, domain_hi=vt.hi, boundaries=[wall])  # fmt: skip
    e = ShearStressErosion(vt, ShearStressParams(k_eps=0.05, tau_c=2.0, non_erodible_below=0.03), support=s.h)
    v0 = vt.solid_volume()
    base = vt.density[vt.axes()[2] < 0.03].copy()
    t_last = 0.0
    while s.t < 0.1:
        s.step()
        if s.steps % e.params.every == 0:
            inc = e.increments(e.terrain, s, s.t - t_last)
            t_last = s.t
            check_budget(inc, vt.shape, vt.volume_per_unit, "shear stress")
            vt.density[...] = vt.density + inc.dz
            wall.refresh(s, terrain=vt.density)
            assert wall.inside(s) == 0
    assert e.removed_total > 0
    assert v0 - vt.solid_volume() == pytest.approx(e.removed_total, rel=1e-9)  # float64 sums of 4e4 nodes
    assert np.array_equal(vt.density[vt.axes()[2] < 0.03], base)


def test_parallel_speed_is_taken_along_the_wall_normal_from_the_field():
    """A particle 5 mm above a floor tilted 2:1 (a voxel ramp, 1 cm voxels), moving at 1 m/s down the
    slope and 0.5 m/s into it: v_p is its speed along the plane, 1 m/s, for every grid point it reaches
    (the field's normal is exact on a plane — trilinear interpolation of a linear ramp — but for the
    float32 field's rounding, 6e-8 relative, grown tenfold by the differences of the gradient: 1e-6);
    the seed's |v| − |v·r̂| varies from point to point (less where r̂ leans along v, more across it)."""
    from erosim.terrain.voxel import HalfSpace

    slope = np.array([1.0, 0.0, 2.0]) / math.sqrt(5.0)  # normal of the 2:1 plane z = −x/2 + c, into the fluid
    down = np.array([2.0, 0.0, -1.0]) / math.sqrt(5.0)
    vt = VoxelTerrain.from_shapes(HalfSpace((0.1, 0.05, 0.05), tuple(slope)), (0, 0, 0), (0.2, 0.1, 0.1), 0.01,
                                  band=0.05)  # fmt: skip
    foot = np.array([0.1, 0.05, 0.05])
    pos = foot + 0.005 * slope
    vel = 1.0 * down - 0.5 * slope
    p = ShearStressParams(tau_c=0.0, n=1.0, radius=0.02, parallel="wall")
    e = ShearStressErosion(vt, p, support=H_SUPPORT)
    l, nrm = e.wall_distances(pos[None])
    assert l[0] == pytest.approx(0.005, abs=1e-8) and nrm[0] == pytest.approx(slope, abs=1e-6)
    rates = e.rates(pos[None], vel[None])
    x_ax, y_ax, z_ax = vt.axes()
    zz, yy, xx = np.meshgrid(z_ax, y_ax, x_ax, indexing="ij")
    r = np.sqrt((xx - pos[0]) ** 2 + (yy - pos[1]) ** 2 + (zz - pos[2]) ** 2) - 0.005  # r' (l < l_min)
    reached = (r <= p.radius) & (vt.density > vt.value_range[0])
    # n = 1, K = 1: the rate is θ = v_p/max(r', l_min) with v_p = 1 at every point reached
    expect = np.where(reached, 1.0 / np.maximum(r, 0.4 * H_SUPPORT), 0.0)
    assert rates == pytest.approx(expect, rel=1e-6, abs=1e-9)
    seed = ShearStressErosion(vt, ShearStressParams(tau_c=0.0, n=1.0, radius=0.02, parallel="seed"),
                              support=H_SUPPORT).rates(pos[None], vel[None])  # fmt: skip
    ratio = seed[reached] / rates[reached]  # the seed's v_p per point: |v| − |v·r̂| ∈ [0, |v| = 1.118]
    assert ratio.min() < 0.7 and ratio.max() > 1.05


def _surface_heights(vt) -> np.ndarray:
    """Per node column, the lowest z where the field's linear interpolation along the column falls to the
    iso level (the trilinear surface on a node line)."""
    d, z, c = vt.density.astype(np.float64), vt.axes()[2], vt.cell_size
    out = np.full(d.shape[1:], np.nan)
    for (j, i), _ in np.ndenumerate(out):
        col = d[:, j, i]
        k = int(np.argmax(col <= vt.iso)) if (col <= vt.iso).any() else len(col) - 1
        out[j, i] = z[0] if k == 0 else z[k - 1] + c * (col[k - 1] - vt.iso) / (col[k - 1] - col[k])
    return out


def test_the_plinth_is_never_lowered():
    """Known answer: the overtopping case's layers in 4 cm voxels (a floor at z = 0, a plinth to
    ``non_erodible_below`` = z_p = 0.02 m, a body on it to 0.2 m), scoured by fast water (τ_c = 0) until
    nothing above the plinth is left: the nodes below z_p keep their density, and the node at 0.04 m ends at
    the plinth's own ramp density d_p = 0.4375 (the half-space z < 0.02 m, ramp half-width 0.16 m), so with
    the node at z = 0 at 0.5625 the surface lies at 0.04·(0.5625 − ½)/(0.5625 − 0.4375) = 0.02 m = z_p in
    every column (1e-6 m: the float32 field's rounding). Without the floor the node at 0.04 m empties and the
    surface sinks to 0.04·0.0625/0.5625 = 0.0044 m, the 0.007–0.018 m of the overtopping run before."""
    c, z_p = 0.04, 0.02
    shapes = [HalfSpace((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), Box((-1.0, -1.0, -1.0), (2.0, 2.0, z_p)),
              Box((-1.0, -1.0, z_p), (2.0, 2.0, 0.2))]  # fmt: skip
    vt = VoxelTerrain.from_shapes(shapes, (0.0, 0.0, -0.16), (0.4, 0.2, 0.4), c)
    start = vt.density.copy()
    g = np.arange(0.02, 0.4, 0.04)
    pos = np.array([[x, y, zz] for x in g for y in g[:5] for zz in np.arange(0.03, 0.3, 0.04)])
    vel = np.tile([3.0, 0.0, 0.0], (len(pos), 1))
    e = ShearStressErosion(vt, ShearStressParams(k_eps=50.0, tau_c=0.0, non_erodible_below=z_p), support=0.08)
    for _ in range(40):
        inc = e.transfer(pos, vel, 1.0, np.zeros(len(pos)))
        vt.density += inc.dz.astype(np.float32)
    heights = _surface_heights(vt)[1:-1, 1:-1]  # columns under the water
    assert np.allclose(heights, z_p, atol=1e-6, rtol=0)
    below = vt.axes()[2] < z_p
    assert np.array_equal(vt.density[below], start[below])
    assert e.unmet_total > 0  # the erosion the floor refused is counted


def test_flush_erodes_what_is_pending():
    """At the end of a run the pending rest (below a quantum at every node) is applied: after ``flush``
    nothing is pending, the field has lost exactly the removed volume, and that is what was computed but for
    the float32 field's rounding (half an ulp at 0.9, 3e-8, per node touched; the difference is counted as
    unmet); the flush's increment closes the contract's budget."""
    vt = _block(value=0.9)
    start = vt.solid_volume()
    rng = np.random.default_rng(5)
    pos = rng.uniform(0.01, 0.07, (40, 3))
    vel = rng.normal(size=(40, 3))
    wl = rng.uniform(0.0, 0.01, 40)
    e = ShearStressErosion(vt, ShearStressParams(k_eps=0.02, tau_c=1.0), support=H_SUPPORT)
    asked = e.rates(pos, vel, wl).sum() * 0.02 * 1e-3 * vt.cell_size**3
    inc = e.transfer(pos, vel, 1e-3, wl)
    assert inc.carried_off == 0.0 and e.pending_volume() == pytest.approx(asked, rel=1e-12)
    touched = int((e.pending > 0).sum())
    inc = e.flush(vt)
    check_budget(inc, vt.shape, vt.volume_per_unit, "shear stress")
    vt.density[...] = vt.density + inc.dz
    assert e.pending_volume() == 0.0
    assert start - vt.solid_volume() == pytest.approx(e.removed_total, rel=1e-9)
    assert e.removed_total + e.unmet_total == pytest.approx(asked, rel=1e-12)
    ulp = float(np.spacing(np.float32(0.9)))
    assert abs(e.removed_total - asked) <= 0.5 * ulp * touched * vt.volume_per_unit
    assert e.removed_total > 0.9 * asked


def test_byte_units_and_morfac_scale_the_accumulated_erosion():
    """K_ε in the seed's bytes accumulates 1/255 of what the same K_ε as a solid fraction does, and a
    morphological factor f multiplies it by f (both exact but for float64 rounding, 1e-12 relative)."""
    rng = np.random.default_rng(3)
    pos = rng.uniform(0.01, 0.07, (30, 3))
    vel = rng.normal(size=(30, 3))
    wl = rng.uniform(0.0, 0.01, 30)
    held = []
    for kw in ({}, {"k_eps_units": "byte"}, {"k_eps_units": "byte", "morfac": 10.0}):
        e = ShearStressErosion(_block(), ShearStressParams(k_eps=0.05, tau_c=1.0, **kw), support=H_SUPPORT)
        e.transfer(pos, vel, 1e-4, wl)
        held.append(e.pending.sum() + e.removed_total / e.terrain.volume_per_unit)
    assert held[0] > 0
    assert held[1] == pytest.approx(held[0] / 255.0, rel=1e-12)
    assert held[2] == pytest.approx(10.0 * held[1], rel=1e-12)
