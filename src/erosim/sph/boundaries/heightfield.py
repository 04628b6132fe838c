"""Heightfield ground without particles (SPEC HM-2, HM-4): the terrain under the fluid is known by the
Q4 interpolation of its node heights, and acts through the wall-weight curves of
:mod:`erosim.sph.boundaries.wall_weight_harada2007`.

For a particle at (x, y, z) (2-D: (x, z)) over a terrain z_g(x, y) on a
:class:`~erosim.coupling.raster.Raster`, with the Q4 height (SPEC HM-2, :mod:`erosim.kernels.raster`)
and the slope s = ∇z_g interpolated the same way from the nodes' central differences,

    n = (−s_x, −s_y, 1)/√(1 + |s|²),      l = (z − z_g(x, y))·n_z,

the distance to the tangent plane of the ground below the particle (exact on a plane, within
O(κ l²) on ground of curvature κ). The slope of the Q4 surface itself jumps across cell edges; the
interpolated nodal slope does not, so a particle resting where four cells meet is not pushed to and
fro by a normal that flips. Memory is that of the terrain raster: nothing grows with the
area the water may reach. The terrain array is read live each step, so an erosion model that
changes it (through the coupler) is felt at once; ``refresh`` has nothing to rebuild. A particle
found below the ground is lifted onto it (z = z_g + 10⁻³Δx) and loses the velocity component into
the ground. Nodata cells should be given a wall height by the caller (:func:`wall_heights`).

:class:`GroundParticles` is the seed's way (SPEC HM-4): fixed boundary particles laid under the same
Q4 surface (:func:`ground_particles`), re-laid when the terrain changes; memory grows with the area.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from erosim.kernels.raster import bilinear, bilinear_points
from erosim.sph.boundaries import particles as bparticles
from erosim.sph.boundaries.distance_wall import DistanceWall
from erosim.sph.boundaries.wall_weight_harada2007 import VT, VTN, wall_density, wall_rates


@njit(inline="always", cache=True)
def ground(z, sx, sy, x0, y0, inv_dx, inv_dy, pos, i):
    """(height, n_x, n_y, n_z) of the ground under particle i (n_y = 0 and n = (n_x, n_z) in 2-D);
    ``sx``, ``sy`` the nodes' slopes (m/m)."""
    d = pos.shape[1]
    x = (pos[i, 0] - x0) * inv_dx
    y = (pos[i, 1] - y0) * inv_dy if d == 3 else 0.0
    hgt = bilinear(z, x, y)
    gx = bilinear(sx, x, y)
    gy = bilinear(sy, x, y) if d == 3 else 0.0
    inv = 1.0 / math.sqrt(1.0 + gx * gx + gy * gy)
    return hgt, -gx * inv, -gy * inv, inv


def node_slopes(z: np.ndarray, dx: float, dy: float) -> tuple[np.ndarray, np.ndarray]:
    """(∂z/∂x, ∂z/∂y) at the nodes (m/m): central differences, one-sided at the edges (0 on a one-node axis)."""
    ny, nx = z.shape
    sx = np.gradient(z, dx, axis=1) if nx > 1 else np.zeros_like(z)
    sy = np.gradient(z, dy, axis=0) if ny > 1 else np.zeros_like(z)
    return np.ascontiguousarray(sx), np.ascontiguousarray(sy)


@njit(parallel=True, cache=True)
def heightfield_forces(pos, vel, rho, p, acc, drho, n_fluid, z, sx, sy, x0, y0, inv_dx, inv_dy, table, dl,
                       approach_only, rho1, c2, m, rho0, gvec, wcsph, cvisc, summation):  # fmt: skip
    d = pos.shape[1]
    support = dl * (table.shape[1] - 1)
    for i in prange(n_fluid):
        hgt, nx, ny, nz = ground(z, sx, sy, x0, y0, inv_dx, inv_dy, pos, i)
        l = (pos[i, d - 1] - hgt) * nz
        if l >= support:
            continue
        if d == 3:
            n0, n1, n2 = nx, ny, nz
        else:
            n0, n1, n2 = nx, nz, 0.0
        wall_rates(table, dl, approach_only, rho1, c2, i, l, n0, n1, n2, vel, rho, p, m, rho0, gvec, wcsph,
                   cvisc, summation, acc, drho)  # fmt: skip


@njit(parallel=True, cache=True)
def heightfield_distance(pos, n_fluid, z, sx, sy, x0, y0, inv_dx, inv_dy, out_l, out_n):
    """l and n of the fluid particles (the ground's normal distance and unit normal, up)."""
    d = pos.shape[1]
    for i in prange(n_fluid):
        hgt, nx, ny, nz = ground(z, sx, sy, x0, y0, inv_dx, inv_dy, pos, i)
        out_l[i] = (pos[i, d - 1] - hgt) * nz
        out_n[i, 0] = nx
        if d == 3:
            out_n[i, 1] = ny
            out_n[i, 2] = nz
        else:
            out_n[i, 1] = nz


@njit(parallel=True, cache=True)
def heightfield_density(pos, rho, n_fluid, z, sx, sy, x0, y0, inv_dx, inv_dy, table, dl):
    d = pos.shape[1]
    for i in prange(n_fluid):
        hgt, _, _, nz = ground(z, sx, sy, x0, y0, inv_dx, inv_dy, pos, i)
        rho[i] += wall_density(table, dl, (pos[i, d - 1] - hgt) * nz)


@njit(parallel=True, cache=True)
def heightfield_constrain(pos, vel, n_fluid, z, sx, sy, x0, y0, inv_dx, inv_dy, gap):
    d = pos.shape[1]
    for i in prange(n_fluid):
        x = (pos[i, 0] - x0) * inv_dx
        y = (pos[i, 1] - y0) * inv_dy if d == 3 else 0.0
        if pos[i, d - 1] >= bilinear(z, x, y):  # the common case: the height alone decides
            continue
        hgt, nx, ny, nz = ground(z, sx, sy, x0, y0, inv_dx, inv_dy, pos, i)
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
def below_ground(pos, n_fluid, z, sx, sy, x0, y0, inv_dx, inv_dy, tol):
    """Number of fluid particles more than ``tol`` below the ground."""
    d = pos.shape[1]
    count = 0
    for i in prange(n_fluid):
        hgt, _, _, _ = ground(z, sx, sy, x0, y0, inv_dx, inv_dy, pos, i)
        if pos[i, d - 1] < hgt - tol:
            count += 1
    return count


def count_below(solver, raster, terrain: np.ndarray, tol: float) -> int:
    """Fluid particles of ``solver`` more than ``tol`` below the Q4 surface of ``terrain``."""
    st = solver.state
    sx, sy = node_slopes(terrain, raster.dx, raster.dy)
    return int(below_ground(st.pos, st.n_fluid, terrain, sx, sy, raster.x0, raster.y0, 1.0 / raster.dx,
                            1.0 / raster.dy, tol))  # fmt: skip


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

    def __init__(self, raster, terrain: np.ndarray, *, slip: bool = False):
        if terrain.shape != raster.shape:
            raise ValueError(f"terrain shape {terrain.shape} does not match the raster {raster.shape}")
        self.raster = raster
        self.terrain = terrain
        self.sx, self.sy = node_slopes(terrain, raster.dx, raster.dy)
        self._density_pass = heightfield_density
        self._forces_pass = heightfield_forces
        self._constrain_pass = heightfield_constrain
        self.slip = bool(slip)

    def bind(self, solver) -> None:
        """As every distance wall; with ``slip`` the tangential viscous curves (B, C) are zero: a
        free-slip ground, whose shear a friction law gives instead (the 3-D flood's Manning columns)."""
        super().bind(solver)
        if self.slip:
            from dataclasses import replace


            table = self.curves.table.copy()
            table[[VT, VTN]] = 0.0
            self.curves = replace(self.curves, table=table)

    def _geometry(self):
        r = self.raster
        return self.terrain, self.sx, self.sy, r.x0, r.y0, 1.0 / r.dx, 1.0 / r.dy

    def wall_distances(self, solver) -> list[tuple[np.ndarray, np.ndarray]]:
        st = solver.state
        l, n = np.empty(st.n_fluid), np.empty((st.n_fluid, solver.dim))
        heightfield_distance(st.pos, st.n_fluid, *self._geometry(), l, n)
        return [(l, n)]

    def refresh(self, solver, *, terrain=None, **changed) -> None:
        """The terrain changed (it is read live): recompute the nodes' slopes and lift the particles a
        deposit has buried onto the new ground (no particle ends below it, not even until the next step)."""
        if terrain is not None:
            self.sx[...], self.sy[...] = node_slopes(self.terrain, self.raster.dx, self.raster.dy)
            self.constrain(solver)

    def state_dict(self) -> dict:
        """The nodes' slopes (the terrain itself is its owner's, restored by it — maybe after this)."""
        return {"sx": self.sx.copy(), "sy": self.sy.copy()}

    def load_state_dict(self, state: dict) -> None:
        self.sx[...] = state["sx"]
        self.sy[...] = state["sy"]

    def below(self, solver, tol: float = 0.0) -> int:
        """Fluid particles more than ``tol`` below the ground (0 after every step)."""
        st = solver.state
        return int(below_ground(st.pos, st.n_fluid, *self._geometry(), tol))


def ground_particles(raster, terrain: np.ndarray, spacing: float, layers: int, dim: int) -> np.ndarray:
    """Fixed particles under the Q4 surface of ``terrain`` (SPEC HM-4): columns on the fluid's lattice
    over the map and ``layers`` columns beyond its edges, each holding ``layers`` particles at
    (k + ½)Δx below the surface, more where a neighbouring column's ground is lower (steep slopes keep
    no gap); the map's edge heights continue beyond it."""

    def sample(pts):
        x = (pts[:, 0] - raster.x0) / raster.dx
        y = (pts[:, 1] - raster.y0) / raster.dy if dim == 3 else np.zeros(len(pts))
        return bilinear_points(np.ascontiguousarray(terrain, np.float64), x, y)

    def axis(lo, n, d):
        span = (n - 1) * d
        k = int(np.ceil(span / spacing))
        return lo + (np.arange(-layers, k + layers) + 0.5) * spacing

    xs = axis(raster.x0, raster.nx, raster.dx)
    if dim == 3:
        ys = axis(raster.y0, raster.ny, raster.dy)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        pts = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])
        g = sample(pts).reshape(gx.shape)
        pad = np.pad(g, 1, mode="edge")
        low = np.minimum.reduce([pad[1 + a : pad.shape[0] - 1 + a, 1 + b : pad.shape[1] - 1 + b]
                                 for a in (-1, 0, 1) for b in (-1, 0, 1)])  # fmt: skip
        cols = np.column_stack([gx.ravel(), gy.ravel()])
    else:
        pts = np.column_stack([xs, np.zeros(xs.size)])
        g = sample(pts)
        pad = np.pad(g, 1, mode="edge")
        low = np.minimum.reduce([pad[:-2], pad[1:-1], pad[2:]])
        cols = xs[:, None]
    g, low = g.ravel(), low.ravel()
    depth = layers + np.ceil(np.maximum(g - low, 0.0) / spacing).astype(int)
    k = np.concatenate([np.arange(n) for n in depth])
    col = np.repeat(np.arange(len(g)), depth)
    z = g[col] - (k + 0.5) * spacing
    return np.column_stack([cols[col], z])


class GroundParticles(bparticles.BoundaryParticles):
    """The ground ``terrain`` as fixed boundary particles (SPEC HM-4, the seed's way), re-laid when it changes."""

    name = "ground_particles"

    def __init__(self, raster, terrain: np.ndarray, spacing: float, layers: int, dim: int):
        self.raster, self.terrain, self.spacing, self.layers, self.dim = raster, terrain, spacing, layers, dim
        super().__init__(ground_particles(raster, terrain, spacing, layers, dim))

    def refresh(self, solver, *, terrain=None, **changed) -> None:
        """The terrain changed: lay the particles on it again (the solver rebuilds its lists)."""
        if terrain is None:
            return
        super().refresh(solver, positions=ground_particles(self.raster, terrain, self.spacing, self.layers, self.dim))

    def below(self, solver, tol: float = 0.0) -> int:
        """Fluid particles more than ``tol`` below the ground (0 after every step)."""
        return count_below(solver, self.raster, self.terrain, tol)
