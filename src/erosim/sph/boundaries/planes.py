"""Plane walls without particles: the sides of a tank or of a terrain's map, each a point r₀ and a
unit normal n pointing into the fluid; a particle's distance is l = (r − r₀)·n. They act through the
wall-weight curves (:mod:`erosim.sph.boundaries.wall_weight_harada2007`); a particle found behind a
plane is put back on it and loses the velocity component into it."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from erosim.sph.boundaries.distance_wall import DistanceWall
from erosim.sph.boundaries.wall_weight_harada2007 import wall_density, wall_rates


@njit(inline="always", cache=True)
def distance(pos, i, points, normals, k):
    """l = (r_i − r₀)·n of particle i to plane k."""
    l = 0.0
    for a in range(pos.shape[1]):
        l += (pos[i, a] - points[k, a]) * normals[k, a]
    return l


@njit(parallel=True, cache=True)
def plane_forces(pos, vel, rho, p, acc, drho, n_fluid, points, normals, table, dl, approach_only, rho1, c2, m,
                 rho0, gvec, wcsph, cvisc, summation):  # fmt: skip
    d = pos.shape[1]
    support = dl * (table.shape[1] - 1)
    for i in prange(n_fluid):
        for k in range(points.shape[0]):
            l = distance(pos, i, points, normals, k)
            if l >= support:
                continue
            n2 = normals[k, 2] if d == 3 else 0.0
            wall_rates(table, dl, approach_only, rho1, c2, i, l, normals[k, 0], normals[k, 1], n2, vel, rho, p, m,
                       rho0, gvec, wcsph, cvisc, summation, acc, drho)  # fmt: skip


@njit(parallel=True, cache=True)
def plane_density(pos, rho, n_fluid, points, normals, table, dl):
    for i in prange(n_fluid):
        for k in range(points.shape[0]):
            l = distance(pos, i, points, normals, k)
            rho[i] += wall_density(table, dl, l)


@njit(parallel=True, cache=True)
def plane_constrain(pos, vel, n_fluid, points, normals, gap):
    d = pos.shape[1]
    for i in prange(n_fluid):
        for k in range(points.shape[0]):
            l = distance(pos, i, points, normals, k)
            if l >= 0.0:
                continue
            vn = 0.0
            for a in range(d):
                pos[i, a] += (gap - l) * normals[k, a]
                vn += vel[i, a] * normals[k, a]
            if vn < 0.0:
                for a in range(d):
                    vel[i, a] -= vn * normals[k, a]


class PlaneWalls(DistanceWall):
    """Planes through ``points`` (k, dim) with unit inward ``normals`` (k, dim)."""

    name = "planes"

    def __init__(self, points, normals):
        self.points = np.ascontiguousarray(points, dtype=np.float64)
        normals = np.asarray(normals, dtype=np.float64)
        self.normals = np.ascontiguousarray(normals / np.linalg.norm(normals, axis=1, keepdims=True))
        self._density_pass = plane_density
        self._forces_pass = plane_forces
        self._constrain_pass = plane_constrain

    def _geometry(self):
        return self.points, self.normals

    def wall_distances(self, solver) -> list[tuple[np.ndarray, np.ndarray]]:
        x = solver.state.pos[: solver.state.n_fluid]
        return [((x - p) @ n, np.broadcast_to(n, x.shape)) for p, n in zip(self.points, self.normals, strict=True)]
