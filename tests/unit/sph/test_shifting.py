"""Fickian particle shifting (Lind et al. 2012; erosim.sph.shifting_lind2012) on scripted particle sets."""

import numpy as np
import pytest

from erosim.core.errors import ConfigError
from erosim.coupling.raster import Raster
from erosim.sph.boundaries.heightfield import HeightfieldGround
from erosim.sph.boundaries.planes import PlaneWalls
from erosim.sph.params import SPHParams
from erosim.sph.shifting_lind2012 import SURFACE
from erosim.sph.solver import SPHSolver

DX = 0.025
LAYERS = 8


def _block(dim, shifting="fickian", move=None):
    """A lattice block LAYERS deep in a particle-free tank (heightfield floor, plane side walls) at rest."""
    L = 0.2
    xs = (np.arange(round(L / DX)) + 0.5) * DX
    zs = (np.arange(LAYERS) + 0.5) * DX
    fluid = np.stack([g.ravel() for g in np.meshgrid(*([xs] * (dim - 1) + [zs]), indexing="ij")], axis=1)
    if move is not None:
        move(fluid)
    raster = Raster(0.0, 0.0, 0.02, 0.02 if dim == 3 else 1.0, 12, 12 if dim == 3 else 1)
    ground = HeightfieldGround(raster, np.zeros(raster.shape))
    if dim == 2:
        planes = PlaneWalls([[0, 0], [L, 0]], [[1, 0], [-1, 0]])
    else:
        points = [[0, 0, 0], [L, 0, 0], [0, 0, 0], [0, L, 0]]
        planes = PlaneWalls(points, [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]])
    lo, hi = [-0.05] * (dim - 1) + [0.0], [L + 0.05] * (dim - 1) + [0.5]
    prm = SPHParams(dim=dim, spacing=DX, walls="reflect", shifting=shifting)
    return SPHSolver(prm, fluid, domain_lo=lo, domain_hi=hi, boundaries=[ground, planes])


@pytest.mark.parametrize("dim", [2, 3])
def test_walls_complete_the_support_and_only_the_top_layer_is_a_free_surface(dim):
    """On a regular lattice a wall's share (its baked curves) fills the support like the missing
    particles: ∇·r within 3 % of d and |∇C| below 3 % of the top layer's at the particles more than a
    support h below the surface, next to the floor or a side wall included (the curves average the
    wall lattice across a cell, so not exactly; measured 0.6 % and 2 %). The top layer is the free
    surface (∇·r below 1.5 in 2-D, 2.75 in 3-D, and C below a full lattice's), beside the side
    walls too (∇·r 1.49 and 2.61 there). Particles within h of two walls are left out: the two flat-wall
    shares overlap in the corner (∇·r 2.24 in 2-D, 3.09 in 3-D), as the wall weights' density does."""
    s = _block(dim)
    gc, _, divr, conc = s._shifting.gradients()
    order = np.argsort(s.ids)  # internal order -> label order
    gc, divr, conc = gc[order], divr[order], conc[order]
    x = s.fluid_positions()
    z, L, h = x[:, -1], 0.2, s.h
    top = z > (LAYERS - 1) * DX
    walls = (z < h).astype(int)
    for a in range(dim - 1):
        walls += (x[:, a] < h) | (x[:, a] > L - h)
    bulk = (z < (LAYERS - 0.5) * DX - h) & (walls <= 1)
    assert bulk.sum() > 0 and (bulk & (walls == 1)).sum() > 0
    top_grad = np.linalg.norm(gc[top], axis=1).min()
    assert np.all(divr[top] < SURFACE[dim]) and np.all(conc[top] < s._shifting.full)
    assert divr[bulk].min() > SURFACE[dim]
    assert np.abs(divr[bulk] - dim).max() < 0.03 * dim
    assert np.linalg.norm(gc[bulk], axis=1).max() < 0.03 * top_grad


def _pair_move(fluid):
    """Two interior neighbours pushed to a quarter spacing apart (a clump)."""
    k = np.argmin(np.linalg.norm(fluid - fluid.mean(axis=0), axis=1))
    j = np.argmin(np.where(np.arange(len(fluid)) == k, np.inf, np.linalg.norm(fluid - fluid[k], axis=1)))
    mid = 0.5 * (fluid[k] + fluid[j])
    u = (fluid[j] - fluid[k]) / np.linalg.norm(fluid[j] - fluid[k])
    fluid[k], fluid[j] = mid - 0.125 * DX * u, mid + 0.125 * DX * u
    _pair_move.ids = (k, j)


def test_a_clump_is_pushed_apart_and_no_shift_exceeds_a_tenth_of_a_spacing():
    """A clump lowers its particles' ∇·r below the surface threshold (2.67 here, as they leave their
    lattice sites) but raises their C above a full lattice's (1.26 against 1.03): it is shifted whole,
    not only across a false surface normal along the pair, and comes apart."""
    s = _block(3, move=_pair_move)
    k, j = _pair_move.ids
    before = s.fluid_positions()
    s.state.vel[: s.n_fluid, 0] = 1.0  # m/s, a flow along x: the shift per step is A h_s |v| Δt |∇C̃|
    s._shifting.apply(1e-3)
    after = s.fluid_positions()
    assert np.linalg.norm(after[j] - after[k]) > np.linalg.norm(before[j] - before[k]) + 0.01 * DX
    assert np.linalg.norm(after - before, axis=1).max() <= 0.1 * DX * (1 + 1e-12)


def test_the_free_surface_is_not_diffused_away():
    """Surface particles move only along the surface: no shift along their ∇C."""

    def ripple(fluid):
        top = fluid[:, -1] > (LAYERS - 1) * DX
        fluid[top, 0] += 0.2 * DX * np.sin(fluid[top, 0] * 40.0)  # an uneven top layer: lateral gradients

    s = _block(3, move=ripple)
    gc, _, divr, conc = s._shifting.gradients()
    before = s.pos[: s.n_fluid].copy()
    s.state.vel[: s.n_fluid, 0] = 1.0
    s._shifting.apply(1e-3)
    moved = s.pos[: s.n_fluid] - before
    surf = (divr < SURFACE[3]) & (conc < s._shifting.full)
    assert surf.sum() > 0 and np.abs(moved[surf]).max() > 0.0  # they do slide along it
    normal = np.einsum("ij,ij->i", moved[surf], gc[surf]) / np.linalg.norm(gc[surf], axis=1)
    assert np.abs(normal).max() < 1e-12


def test_a_block_at_rest_stays_at_rest_with_shifting():
    """Shifting scales with each particle's speed: a block settling at rest is not stirred by it (its
    largest speed after 1 s within 1 mm/s of the run without shifting, its pressure's RMS error against
    hydrostatic within 0.5 % of ρ₀gH of it, positions within a hundredth of a spacing)."""
    speeds, drift, rms = {}, {}, {}
    for mode in ("off", "fickian"):
        s = _block(2, shifting=mode)
        x0 = s.fluid_positions()
        while s.t < 1.0:
            s.step()
        speeds[mode] = s.vmax
        x = s.fluid_positions()
        drift[mode] = np.abs(x - x0).max()
        rho_g_h = 1000.0 * 9.81 * LAYERS * DX
        rms[mode] = np.sqrt(np.mean((s.fluid_pressure() - 1000.0 * 9.81 * (LAYERS * DX - x[:, -1])) ** 2)) / rho_g_h
    assert speeds["fickian"] < speeds["off"] + 1e-3
    assert rms["fickian"] < rms["off"] + 0.005
    assert drift["fickian"] < drift["off"] + 0.01 * DX


def test_shifting_is_refused_on_the_gpu_solver():
    pytest.importorskip("numba.cuda")
    from erosim.sph.solver_cuda import CudaSPHSolver

    with pytest.raises(ConfigError, match="shifting"):
        CudaSPHSolver(SPHParams(dim=3, spacing=DX, shifting="fickian"), np.zeros((1, 3)) + 0.1,
                      domain_lo=[0, 0, 0], domain_hi=[0.2, 0.2, 0.2])  # fmt: skip


def test_a_voxel_floor_gives_the_same_share_as_a_heightfield_floor():
    """The voxel wall's share (distance and normal from the density field) on a flat floor: a lattice
    resting on it has ∇·r within 3 % of 3 and |∇C| below 3 % of the surface's in its lower layers
    (more than h below the surface), as on the heightfield floor; a sign error in l or n would show
    as a gradient of the free surface's size there."""
    from erosim.sph.boundaries.voxel_wall import VoxelWall
    from erosim.terrain.voxel import HalfSpace, VoxelTerrain

    L = 0.2
    vt = VoxelTerrain.from_shapes([HalfSpace((0, 0, 0), (0, 0, 1))], (-0.05, -0.05, -0.08), (L + 0.05, L + 0.05, 0.3),
                                  DX)  # fmt: skip
    xs = (np.arange(round(L / DX)) + 0.5) * DX
    zs = (np.arange(LAYERS) + 0.5) * DX
    fluid = np.stack([g.ravel() for g in np.meshgrid(xs, xs, zs, indexing="ij")], axis=1)
    s = SPHSolver(SPHParams(dim=3, spacing=DX, walls="reflect", shifting="fickian"), fluid, domain_lo=vt.lo,
                  domain_hi=vt.hi, boundaries=[VoxelWall(vt)])  # fmt: skip
    gc, _, divr, _ = s._shifting.gradients()
    order = np.argsort(s.ids)
    gc, divr = gc[order], divr[order]
    x = s.fluid_positions()
    inner = np.all((x[:, :2] > s.h) & (x[:, :2] < L - s.h), axis=1)  # away from the block's open sides
    low = inner & (x[:, 2] < (LAYERS - 0.5) * DX - s.h)
    top = inner & (x[:, 2] > (LAYERS - 1) * DX)
    assert low.sum() > 0 and (low & (x[:, 2] < s.h)).sum() > 0
    assert np.abs(divr[low] - 3.0).max() < 0.09
    assert np.linalg.norm(gc[low], axis=1).max() < 0.03 * np.linalg.norm(gc[top], axis=1).min()
