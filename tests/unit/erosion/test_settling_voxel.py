"""Suspended sediment over a voxel terrain (erosion.sediment = "suspended"): the pickup shares, the settling
law on a particle at rest, and the budget it returns."""

import math

import numpy as np
import pytest

from erosim.core.increments import check_budget
from erosim.erosion.settling_voxel import SuspendedSediment, share_pickup

COARSE = ["sph.spacing=0.04", "voxels.cell_size=0.04", "erosion.tau_c=0.5", "erosion.k_eps=2.0",
          "erosion.k_eps_units=fraction", "erosion.morfac=1"]  # fmt: skip


def test_each_nodes_volume_is_shared_equally_among_the_particles_within_reach():
    """Two nodes give 0.3 and 0.1 m³; three particles within R = 1 of the first (two of them also of the
    second) and one out of reach of both: shares 0.1 each from the first, 0.05 each from the second; a
    particle with less room takes what fits and the rest returns to its node."""
    count = np.zeros((3, 3, 3), np.int64)
    volume = np.zeros(27)
    volume[(1 * 3 + 1) * 3 + 1] = 0.3  # node (1, 1, 1) at (1, 1, 1) m
    volume[(1 * 3 + 1) * 3 + 2] = 0.1  # node (2, 1, 1) at (2, 1, 1) m
    pos = np.array([[1.0, 1.0, 0.2], [1.5, 1.0, 1.0], [1.5, 1.2, 1.2], [0.0, 0.0, 2.9]])
    sed = np.zeros(4)
    returned = np.zeros(27)
    room = np.full(4, 1.0)
    given = share_pickup(volume, 0.0, 0.0, 0.0, 1.0, pos, 4, 1.0, room, count, sed, returned)
    assert given == pytest.approx(0.4, rel=1e-12) and not returned.any()
    np.testing.assert_allclose(sed, [0.1, 0.15, 0.15, 0.0], rtol=1e-12)
    # the second particle can hold 0.12 m³ more: it takes 0.1 from the first node, then 0.02 of the
    # second's 0.05; the other 0.03 goes back to that node
    sed[:] = 0.0
    room = np.array([1.0, 0.12, 1.0, 1.0])
    given = share_pickup(volume, 0.0, 0.0, 0.0, 1.0, pos, 4, 1.0, room, count, sed, returned)
    np.testing.assert_allclose(sed, [0.1, 0.12, 0.15, 0.0], rtol=1e-12)
    assert returned[(1 * 3 + 1) * 3 + 2] == pytest.approx(0.03) and returned.sum() == pytest.approx(0.03)
    assert given + returned.sum() == pytest.approx(0.4, rel=1e-12)


@pytest.fixture(scope="module")
def flume():
    from erosim.erosion.shear_stress_kristof2009 import ShearStressErosion
    from erosim.scenarios import loader
    from erosim.scenarios.voxel.build import build_solver, build_terrain

    cfg = loader.load("overtopping", COARSE, preset="full").config
    terrain = build_terrain(cfg)
    solver, _, _ = build_solver(cfg, terrain)
    return terrain, solver, ShearStressErosion(terrain, cfg.erosion, support=solver.h)


def test_a_load_at_rest_settles_at_ws_over_its_height_onto_the_ground_under_it(flume):
    """Water at rest erodes nothing; one particle near the floor holding s₀ keeps s₀ e^{−w_s Δt/max(l, l_min)}
    after a coupling of Δt, the rest goes to the field (and the accumulator's float32 rounding) under it,
    and the increment closes the budget with nothing carried off; a particle higher than h keeps its load."""
    terrain, solver, eroder = flume
    sus = SuspendedSediment(eroder, solver, settling_velocity=0.02)
    st = solver.state
    n = st.n_fluid
    pos = np.ascontiguousarray(st.pos[:n], np.float64)
    l, _ = eroder.wall_distances(pos)
    low = int(np.argmin(np.where(l > 0, l, np.inf)))
    high = int(np.argmax(l))
    assert l[high] > solver.h
    st.sediment[:n] = 0.0
    st.sediment[low] = st.sediment[high] = 1e-6
    sus.suspended_last = sus.held()  # as if picked up by an earlier coupling
    before = terrain.density.astype(np.float64).copy()
    dt = 0.5
    st.vel[:n] = 0.0
    loads = st.sediment[:n].copy()
    inc = sus.increments(terrain, solver, dt)
    np.testing.assert_array_equal(st.sediment[:n], loads)  # the caller writes the particles' new loads
    new = inc.particles["sediment"]
    kept = 1e-6 * math.exp(-0.02 * dt / max(l[low], sus.l_min))
    assert new[low] == pytest.approx(kept, rel=1e-12) and new[high] == 1e-6
    vpu = terrain.volume_per_unit
    gained = float(np.sum(inc.dz) * vpu) + float(sus.bound.sum() * vpu)
    assert gained == pytest.approx(1e-6 - kept, rel=1e-9)
    assert np.count_nonzero(np.asarray(inc.dz) + sus.bound) == 1  # one node, under the particle
    terms = check_budget(inc, terrain.shape, vpu, "suspended sediment")
    assert terms["carried_off"] == 0.0 and terms["eroded"] == 0.0
    held = float(new.sum()) + float(sus.bound.sum() * vpu)
    assert held == pytest.approx(2e-6 - float(np.sum(inc.dz) * vpu), rel=1e-12)
    np.testing.assert_array_equal(terrain.density, before.astype(np.float32))  # the caller applies the increment


def test_a_suspended_run_that_moved_no_ground_says_why(flume):
    """The wrapper gives the warning its eroder's own words: no quantum moved at τ_c = 0.5 (the preset's
    K = 1, n = ½ and l_min = 0.4 h = 3.2 cm: 0.032 · 0.5² = 0.008 m/s) names that speed (a suspended run
    once failed here, the wrapper lacking the eroder's threshold)."""
    from erosim.scenarios.voxel.outputs import no_erosion_warning

    terrain, solver, eroder = flume
    sus = SuspendedSediment(eroder, solver, settling_velocity=0.02)
    assert sus.removed_total == 0 and sus.pending_volume() == 0
    note = no_erosion_warning(sus)
    assert "faster than 0.008 m/s" in note and "erosion.tau_c" in note


def test_settling_slows_with_height_as_ws_dt_over_l():
    """The settling law itself (settle): a load s at height l above the ground keeps s e^{−w_s Δt / max(l, l_min)};
    particles at 0.5, 2 and 3 l_min (the first clamped to l_min) keep different shares, the rest bound under them."""
    from erosim.erosion.settling_voxel import settle

    nz, ny, nx = 8, 4, 6
    dens = np.zeros((nz, ny, nx))  # air everywhere: room for what settles
    bound = np.zeros_like(dens)
    l_min, rate_dt, inv = 0.1, 0.05, 10.0  # w_s Δt = 0.05 m, 0.1 m cells
    heights = np.array([0.05, 0.2, 0.3])
    feet = np.array([[0.15, 0.15, 0.1], [0.35, 0.15, 0.1], [0.55, 0.25, 0.1]])  # over three different nodes
    pos = feet + np.outer(heights, [0.0, 0.0, 1.0])
    wall_n = np.tile([0.0, 0.0, 1.0], (3, 1))
    sed = np.full(3, 1e-3)
    put = settle(dens, 0.0, 0.0, 0.0, inv, 1.0, 1e-3, pos, heights.copy(), wall_n, 3, 1.0, l_min, rate_dt, sed, bound)
    kept = 1e-3 * np.exp(-rate_dt / np.maximum(heights, l_min))
    np.testing.assert_allclose(sed, kept, rtol=1e-12)
    assert put == pytest.approx(float(np.sum(1e-3 - kept)), rel=1e-12)
    assert bound.sum() * 1e-3 == pytest.approx(put, rel=1e-12)
