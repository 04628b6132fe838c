"""Wall-weight curves against explicit wall particles, and particle-free walls holding water at rest."""

import numpy as np
import pytest

from erosim.coupling.raster import Raster
from erosim.kernels.sph_kernels import kernel_f, kernel_w
from erosim.sph.boundaries.heightfield import HeightfieldGround
from erosim.sph.boundaries.planes import PlaneWalls
from erosim.sph.boundaries.wall_weight_harada2007 import G, H, T, Z, bake
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver


@pytest.mark.parametrize("dim, kernel, hf", [(2, "wendland", 3.0), (3, "wendland", 2.0), (3, "muller", 2.0)])
def test_curves_are_the_averaged_sums_over_a_wall_lattice(dim, kernel, hf):
    """The curves equal the sums over an explicit wall of particles, averaged over random probe positions
    across the lattice (200 draws; the bake's 4-point-per-axis average and the random one agree to 2 %
    of each curve's peak)."""
    dx, rho0 = 0.01, 1000.0
    h = hf * dx
    c = bake(kernel, dim, dx, h, rho0, "artificial")
    k = 8
    lat = np.arange(-k, k + 1) * dx
    axes = [lat] * (dim - 1) + [-(np.arange(k) + 0.5) * dx]
    wall = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
    m = rho0 * dx**dim
    peak = np.abs(c.table).max(axis=1)
    rng = np.random.default_rng(1)
    for l in (0.1 * dx, 0.5 * dx, 1.2 * dx):
        sums = np.zeros(4)
        draws = 200
        for _ in range(draws):
            probe = np.append(rng.random(dim - 1) * dx, l)
            r = probe - wall
            dist = np.sqrt((r * r).sum(axis=1))
            f = kernel_f(dist, h, dim, kernel)
            sums += [m * kernel_w(dist, h, dim, kernel).sum(), (f * r[:, -1]).sum(), (f * r[:, -1] ** 2).sum(),
                     (f * r[:, 0] ** 2).sum()]  # fmt: skip
        got = c.at(l)
        for row, value in zip((Z, G, H, T), sums / draws, strict=True):
            assert got[row] == pytest.approx(value, abs=0.02 * peak[row]), (l, row)
    assert np.all(c.at(h) == 0.0)  # nothing beyond the support
    # half the kernel's mass lies below a wall through the particle: Z(0) ≈ ρ₀/2 (lattice sum, 1 %)
    assert c.at(0.0)[Z] == pytest.approx(rho0 / 2, rel=0.01)


def _tank(dim, walls_kind, t_end=1.0):
    H, L = 0.4, 0.4
    dx = H / 16
    xs = (np.arange(round(L / dx)) + 0.5) * dx
    zs = (np.arange(16) + 0.5) * dx
    grids = [xs] * (dim - 1) + [zs]
    fluid = np.stack([g.ravel() for g in np.meshgrid(*grids, indexing="ij")], axis=1)
    if walls_kind == "box":
        lo, hi = [0.0] * dim, [L] * (dim - 1) + [0.8]
        s = SPHSolver(SPHParams(dim=dim, spacing=dx), fluid, domain_lo=lo, domain_hi=hi)
    else:
        raster = Raster(0.0, 0.0, 0.02, 0.02 if dim == 3 else 1.0, 21, 21 if dim == 3 else 1)
        ground = HeightfieldGround(raster, np.zeros(raster.shape))
        if dim == 2:
            planes = PlaneWalls([[0, 0], [L, 0]], [[1, 0], [-1, 0]])
        else:
            planes = PlaneWalls([[0, 0, 0], [L, 0, 0], [0, 0, 0], [0, L, 0]],
                                [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]])  # fmt: skip
        lo, hi = [-0.05] * (dim - 1) + [0.0], [L + 0.05] * (dim - 1) + [0.8]
        s = SPHSolver(SPHParams(dim=dim, spacing=dx, walls="reflect"), fluid, domain_lo=lo, domain_hi=hi,
                      boundaries=[ground, planes])  # fmt: skip
    while s.t < t_end:
        s.step()
    pos, p = s.fluid_positions(), s.fluid_pressure()
    rms = np.sqrt(np.mean((p - 1000.0 * 9.81 * (H - pos[:, -1])) ** 2)) / (1000.0 * 9.81 * H)
    return s, rms


def test_particle_free_walls_hold_a_2d_tank_at_rest():
    """A heightfield floor and plane side walls: hydrostatic within the 2 % of the box tank's validation
    (1.5 % after 1 s, still settling: 1.1 % after 2 s; the box tank 0.6 %), and still — the steep side
    walls hold the water up (without the tangential hydrostatic term of the wall pressure, the columns
    at the side walls slid down at 0.14 m/s)."""
    s, rms = _tank(2, "distance")
    assert s.n_boundary == 0
    assert rms < 0.02
    assert s.vmax < 0.01  # m/s after 1 s; at rest (the box tank: 0.7 mm/s)
    assert s.fluid_positions()[:, 1].min() > 0.0
