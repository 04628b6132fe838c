"""Voxel terrain as a particle-free wall (SPEC VX-3, VX-4): the ground, walls, overhangs and caves of a
:class:`~erosim.terrain.voxel.VoxelTerrain` act on the fluid through the wall-weight curves of
Harada, Koshizuka & Kawaguchi (2007) (:mod:`erosim.sph.boundaries.wall_weight_harada2007`), with
the distance and normal from the density field (:mod:`erosim.kernels.voxel`):

    l = (ISO − d(r))/|∇d(r)|  (positive in the fluid),     n = −∇d/|∇d|  (into the fluid),

d and ∇d by trilinear interpolation of the 8 nodes around the particle. Per step and particle this
costs one interpolation in each of the boundary's three passes and no neighbour loop (VX-10):

* ``density`` (summation density): ρ_i += Z(l);
* ``forces``: pressure (repulsion with the hydrostatic wall pressure), viscous friction and the
  continuity term of the curves, as for :class:`~erosim.sph.boundaries.heightfield.HeightfieldGround`
  (the :class:`~erosim.sph.boundaries.distance_wall.DistanceWall` pattern); with ``attraction`` = ρ₁
  (kg/m³ or ``"seed"``) the pressure of a particle below ρ₁ blends towards the wall's attraction
  curve (VX-5), so water follows the wall into scoured hollows;
* ``constrain`` after the drift: a particle found in the solid (l < 0) is moved along n by −l plus a
  gap of 10⁻³Δx, up to four Newton steps (l is first-order away from the ramp's linear part), and
  loses the velocity component into the wall; a particle so deep that the field is flat there (no
  normal) is lifted up its column to the first air node. No particle ends a step inside the solid.

The field is read live: an erosion model's increments are felt at the next step; ``refresh`` after
they are applied pushes out the particles the change left inside (deposits). The curves need l
correct out to the kernel's support h, so the terrain's density ramp must be at least h + √3Δ
wide (:mod:`erosim.terrain.voxel`) and the voxels no coarser than h; both are checked when bound.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from erosim.core.errors import ConfigError
from erosim.kernels.voxel import FAR, distance_normal, wall_distance
from erosim.sph.boundaries.distance_wall import DistanceWall
from erosim.sph.boundaries.wall_weight_harada2007 import wall_density, wall_rates


@njit(parallel=True, cache=True)
def voxel_forces(pos, vel, rho, p, acc, drho, n_fluid, dens, ox, oy, oz, inv, iso, table, dl, approach_only, rho1,
                 c2, m, rho0, gvec, wcsph, cvisc, summation):  # fmt: skip
    support = dl * (table.shape[1] - 1)
    for i in prange(n_fluid):
        l, n0, n1, n2, _ = distance_normal(dens, ox, oy, oz, inv, iso, pos[i, 0], pos[i, 1], pos[i, 2])
        if l >= support:
            continue
        wall_rates(table, dl, approach_only, rho1, c2, i, l, n0, n1, n2, vel, rho, p, m, rho0, gvec, wcsph,
                   cvisc, summation, acc, drho)  # fmt: skip


@njit(parallel=True, cache=True)
def voxel_density(pos, rho, n_fluid, dens, ox, oy, oz, inv, iso, table, dl):
    support = dl * (table.shape[1] - 1)
    for i in prange(n_fluid):
        l, _, _, _, _ = distance_normal(dens, ox, oy, oz, inv, iso, pos[i, 0], pos[i, 1], pos[i, 2])
        if l < support:
            rho[i] += wall_density(table, dl, l)


@njit(parallel=True, cache=True)
def voxel_constrain(pos, vel, n_fluid, dens, ox, oy, oz, inv, iso, gap):
    nz = dens.shape[0]
    for i in prange(n_fluid):
        l, n0, n1, n2, d = distance_normal(dens, ox, oy, oz, inv, iso, pos[i, 0], pos[i, 1], pos[i, 2])
        if l >= 0.0:
            continue
        for _ in range(4):
            if l <= -0.5 * FAR:  # deep in a flat solid: up the column to the first air node
                z0 = pos[i, 2]
                for k in range(nz):
                    z = oz + k / inv
                    if z <= z0:
                        continue
                    l, n0, n1, n2, d = distance_normal(dens, ox, oy, oz, inv, iso, pos[i, 0], pos[i, 1], z)
                    if d < iso:
                        pos[i, 2] = z
                        break
            else:
                pos[i, 0] += (gap - l) * n0
                pos[i, 1] += (gap - l) * n1
                pos[i, 2] += (gap - l) * n2
            l, n0, n1, n2, d = distance_normal(dens, ox, oy, oz, inv, iso, pos[i, 0], pos[i, 1], pos[i, 2])
            if l >= 0.0:
                break
        vn = vel[i, 0] * n0 + vel[i, 1] * n1 + vel[i, 2] * n2
        if vn < 0.0:
            vel[i, 0] -= vn * n0
            vel[i, 1] -= vn * n1
            vel[i, 2] -= vn * n2


@njit(parallel=True, cache=True)
def count_inside(pos, n_fluid, dens, ox, oy, oz, inv, iso, tol):
    """Fluid particles more than ``tol`` inside the solid (l < −tol)."""
    count = 0
    for i in prange(n_fluid):
        l, _, _, _, _ = distance_normal(dens, ox, oy, oz, inv, iso, pos[i, 0], pos[i, 1], pos[i, 2])
        if l < -tol:
            count += 1
    return count


class VoxelWall(DistanceWall):
    """The solid of ``terrain`` (a :class:`~erosim.terrain.voxel.VoxelTerrain`, read live) as a particle-free
    wall of a 3-D fluid; see the module docstring."""

    name = "voxel"

    def __init__(self, terrain, *, attraction: float | str | None = None):
        self.terrain = terrain
        self.attraction = attraction  # ρ₁ of VX-5 (DistanceWall); None: repulsion only
        self._density_pass = voxel_density
        self._forces_pass = voxel_forces
        self._constrain_pass = voxel_constrain

    def bind(self, solver) -> None:
        t = self.terrain
        if solver.dim != 3:
            raise ConfigError("A voxel terrain is a 3-D wall; run the fluid with sph.dim = 3.")
        if t.cell_size > solver.h:
            raise ConfigError(
                f"Voxels of {t.cell_size:g} m are too coarse for the particle spacing {solver.params.spacing:g} m: "
                f"the wall distance needs cells no larger than the kernel support h = {solver.h:g} m; "
                "use smaller voxels or a larger spacing."
            )
        need = solver.h + math.sqrt(3.0) * t.cell_size
        if t.band is not None and t.band < need * (1.0 - 1e-9):
            raise ConfigError(
                f"The voxel terrain's density ramp ({t.band:g} m) is narrower than the kernel support plus a cell "
                f"diagonal ({need:.3g} m), so wall distances near h would be wrong; build it with band ≥ {need:.3g} m."
            )
        super().bind(solver)

    def _geometry(self):
        t = self.terrain
        ox, oy, oz = t.origin
        return t.density, ox, oy, oz, 1.0 / t.cell_size, t.iso

    def refresh(self, solver, *, terrain=None, **changed) -> None:
        """The field changed (in place, or ``terrain`` is a new :class:`VoxelTerrain` or density array of
        the same grid): push out the particles it left inside the solid."""
        if terrain is not None:
            if hasattr(terrain, "density"):
                self.terrain = terrain
            elif terrain is not self.terrain.density:
                arr = np.asarray(terrain)
                if arr.shape != self.terrain.shape:
                    raise ValueError(f"density shape {arr.shape} does not match the voxel grid {self.terrain.shape}")
                self.terrain.density[...] = arr
        self.constrain(solver)

    def inside(self, solver, tol: float = 0.0) -> int:
        """Fluid particles more than ``tol`` inside the solid (0 after every step)."""
        st = solver.state
        return int(count_inside(st.pos, st.n_fluid, *self._geometry(), tol))

    def wall_distances(self, solver) -> list[tuple[np.ndarray, np.ndarray]]:
        return [self.distances(solver)]

    def distances(self, solver) -> tuple[np.ndarray, np.ndarray]:
        """(l, n) of the fluid particles in the state's (internal) order: wall distance (m, positive in the
        fluid) and unit normal; ``solver.in_label_order`` puts them in the order of ``solver.fluid_positions()``."""

        st = solver.state
        nf = st.n_fluid
        l, n = np.empty(nf), np.empty((nf, 3))
        wall_distance(*self._geometry(), st.pos, nf, l, n)
        return l, n
