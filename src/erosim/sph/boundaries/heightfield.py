"""Heightfield ground without particles (SPEC HM-2, HM-4): the terrain under the fluid is known by the
Q4 interpolation of its node heights, and acts through the wall-weight curves of
:mod:`erosim.sph.boundaries.wall_weight_harada2007`.

For a particle at (x, y, z) (2-D: (x, z)) over a terrain z_g(x, y) on a
:class:`~erosim.coupling.raster.Raster`, with the Q4 height and slope (SPEC HM-2, in cell units,
:mod:`erosim.kernels.raster`),

    n = (−∂z_g/∂x, −∂z_g/∂y, 1)/√(1 + |∇z_g|²),      l = (z − z_g(x, y))·n_z,

the distance to the tangent plane of the ground below the particle (exact on a plane, within
O(κ l²) on ground of curvature κ). Memory is that of the terrain raster: nothing grows with the
area the water may reach. The terrain array is read live each step, so an erosion model that
changes it (through the coupler) is felt at once; ``refresh`` has nothing to rebuild. A particle
found below the ground is lifted onto it (z = z_g + 10⁻³Δx) and loses the velocity component into
the ground. Nodata cells should be given a wall height by the caller (:func:`wall_heights`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from erosim.kernels.raster import bilinear, gradient
from erosim.sph.boundaries.distance_wall import DistanceWall
from erosim.sph.boundaries.wall_weight_harada2007 import wall_density, wall_rates


@njit(inline="always", cache=True)
def ground(z, x0, y0, inv_dx, inv_dy, pos, i):
    """(height, n_x, n_y, n_z) of the ground under particle i (n_y = 0 and n = (n_x, n_z) in 2-D)."""
    d = pos.shape[1]
    x = (pos[i, 0] - x0) * inv_dx
    y = (pos[i, 1] - y0) * inv_dy if d == 3 else 0.0
    hgt = bilinear(z, x, y)
    gx, gy = gradient(z, x, y)
    gx *= inv_dx
    gy *= inv_dy
    if d == 2:
        gy = 0.0
    inv = 1.0 / math.sqrt(1.0 + gx * gx + gy * gy)
    return hgt, -gx * inv, -gy * inv, inv


@njit(parallel=True, cache=True)
def heightfield_forces(pos, vel, rho, p, acc, drho, n_fluid, z, x0, y0, inv_dx, inv_dy, table, dl, approach_only,
                       m, rho0, gvec, cpress, cvisc, summation):  # fmt: skip
    d = pos.shape[1]
    support = dl * (table.shape[1] - 1)
    for i in prange(n_fluid):
        hgt, nx, ny, nz = ground(z, x0, y0, inv_dx, inv_dy, pos, i)
        l = (pos[i, d - 1] - hgt) * nz
        if l >= support:
            continue
        if d == 3:
            n0, n1, n2 = nx, ny, nz
        else:
            n0, n1, n2 = nx, nz, 0.0
        wall_rates(table, dl, approach_only, i, l, n0, n1, n2, vel, rho, p, m, rho0, gvec, cpress, cvisc,
                   summation, acc, drho)  # fmt: skip


@njit(parallel=True, cache=True)
def heightfield_density(pos, rho, n_fluid, z, x0, y0, inv_dx, inv_dy, table, dl):
    d = pos.shape[1]
    for i in prange(n_fluid):
        hgt, _, _, nz = ground(z, x0, y0, inv_dx, inv_dy, pos, i)
        rho[i] += wall_density(table, dl, (pos[i, d - 1] - hgt) * nz)


@njit(parallel=True, cache=True)
def heightfield_constrain(pos, vel, n_fluid, z, x0, y0, inv_dx, inv_dy, gap):
    d = pos.shape[1]
    for i in prange(n_fluid):
        hgt, nx, ny, nz = ground(z, x0, y0, inv_dx, inv_dy, pos, i)
        if pos[i, d - 1] >= hgt:
            continue
        pos[i, d - 1] = hgt + gap
        vn = vel[i, 0] * nx + vel[i, d - 1] * nz
        if d == 3:
            vn += vel[i, 1] * ny
        if vn < 0.0:
            vel[i, 0] -= vn * nx
            vel[i, d - 1] -= vn * nz
            if d == 3:
                vel[i, 1] -= vn * ny


@njit(parallel=True, cache=True)
def below_ground(pos, n_fluid, z, x0, y0, inv_dx, inv_dy, tol):
    """Number of fluid particles more than ``tol`` below the ground."""
    d = pos.shape[1]
    count = 0
    for i in prange(n_fluid):
        hgt, _, _, _ = ground(z, x0, y0, inv_dx, inv_dy, pos, i)
        if pos[i, d - 1] < hgt - tol:
            count += 1
    return count


def wall_heights(z: np.ndarray, nodata: np.ndarray | None, top: float) -> np.ndarray:
    """Heights with nodata cells raised to ``top``: a DEM's holes become walls the water cannot enter."""
    if nodata is None or not nodata.any():
        return z
    out = z.copy()
    out[nodata] = top
    return out


class HeightfieldGround(DistanceWall):
    """The ground ``terrain`` (``raster.shape``, SPH frame, read live) as a particle-free wall."""

    name = "ground"

    def __init__(self, raster, terrain: np.ndarray):
        if terrain.shape != raster.shape:
            raise ValueError(f"terrain shape {terrain.shape} does not match the raster {raster.shape}")
        self.raster = raster
        self.terrain = terrain
        self._density_pass = heightfield_density
        self._forces_pass = heightfield_forces
        self._constrain_pass = heightfield_constrain

    def _geometry(self):
        r = self.raster
        return self.terrain, r.x0, r.y0, 1.0 / r.dx, 1.0 / r.dy

    def below(self, solver, tol: float = 0.0) -> int:
        """Fluid particles more than ``tol`` below the ground (0 after every step)."""
        st = solver.state
        return int(below_ground(st.pos, st.n_fluid, *self._geometry(), tol))
