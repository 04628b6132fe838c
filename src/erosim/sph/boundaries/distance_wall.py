"""Walls known by a distance function and its normal: the common part of the heightfield ground and
the plane walls, acting through the baked wall-weight curves of
:mod:`erosim.sph.boundaries.wall_weight_harada2007` (no boundary particles, no neighbour loop).

A subclass gives three Numba passes over the fluid particles — ``_density_pass`` (summation
density: ρ += Z(l)), ``_forces_pass`` (pressure, viscosity and continuity terms) and
``_constrain_pass`` (a particle found inside the solid is put back on its surface and loses the
velocity that points into it) — and the arguments that locate its wall (``_geometry()``). This
class bakes the curves for the solver's kernel, spacing and viscosity when it is bound (or reads
them from the on-disk cache, :func:`~erosim.sph.boundaries.wall_weight_harada2007.bake_cached`), and
wires the passes to the solver's hooks. The attribute ``attraction`` (ρ₁ of SPEC VX-5 in kg/m³,
``"seed"`` for the seed's ρ₀ + m W(0), or None for no attraction, the default) sets the density below
which the wall's pressure blends towards the attraction curve.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from erosim.core.errors import ConfigError
from erosim.sph.boundaries.base import Boundary
from erosim.sph.boundaries.wall_weight_harada2007 import bake_cached, seed_rho1, shifting_sums

#: a particle put back on a wall sits this fraction of Δx above it
GAP = 1e-3


class DistanceWall(Boundary):
    """Base of walls given by a distance function (see the module docstring)."""

    name = "distance_wall"
    #: ρ₁ of the wall attraction (VX-5): kg/m³, "seed", or None (off)
    attraction: float | str | None = None

    def bind(self, solver) -> None:
        prm = solver.params
        self.curves = bake_cached(prm.kernel, solver.dim, prm.spacing, solver.h, prm.rho0, prm.viscosity)
        self.m = solver.m
        self.gvec = np.asarray(solver.g, np.float64)
        self.wcsph = prm.pressure_form == "wcsph"
        self.cvisc = solver.kv * solver.m if prm.viscosity == "artificial" else -prm.mu * solver.m
        self.gap = GAP * prm.spacing
        self.rho1 = self._rho1(prm.kernel, solver.dim, prm.spacing, solver.h, prm.rho0)
        self.c2 = float(solver.c) ** 2
        if solver.summation:
            self.density = self._density
        self._summation = solver.summation

    def _rho1(self, kernel, dim, spacing, support, rho0) -> float:
        a = self.attraction
        if a is None:
            return 0.0
        if isinstance(a, str):
            if a != "seed":
                raise ConfigError(f"Unknown wall attraction {a!r}; give ρ₁ in kg/m³, 'seed' or none.")
            return seed_rho1(kernel, dim, spacing, support, rho0)
        if not a > 0:
            raise ConfigError(f"The wall attraction's ρ₁ must be a positive density in kg/m³, not {a!r}.")
        return float(a)

    def _curve_args(self):
        c = self.curves
        return c.table, c.dl, c.approach_only, self.rho1, self.c2

    def _density(self, solver) -> None:
        self.add_density(solver, solver.state.rho)

    def add_density(self, solver, rho) -> None:
        """rho_i += Z(l_i), the wall's share of a summation density, for the fluid particles."""
        st = solver.state
        self._density_pass(st.pos, rho, st.n_fluid, *self._geometry(), self.curves.table, self.curves.dl)

    def share(self, solver) -> np.ndarray:
        """Z(l_i) of the fluid particles: the wall's share of their density (kg/m³)."""
        z = np.zeros(solver.state.n_fluid)
        self.add_density(solver, z)
        return z

    def follow(self, solver, share_before: np.ndarray) -> None:
        """The wall moved under the fluid (its terrain changed, then :meth:`refresh` put particles back
        out): a continuity density takes the change of the wall's share, ρ_i += Z(l_i, after) − Z(l_i,
        before), as the continuity term of a moving wall would; summation density reads Z afresh."""
        if self._summation:
            return
        st = solver.state
        nf = st.n_fluid
        st.rho[:nf] = np.maximum(st.rho[:nf] + (self.share(solver) - share_before), solver.rho_min)

    def forces(self, solver) -> None:
        st = solver.state
        self._forces_pass(
            st.pos, st.vel, st.rho, st.p, st.acc, st.drho, st.n_fluid, *self._geometry(), *self._curve_args(),
            self.m, solver.params.rho0, self.gvec, self.wcsph, self.cvisc, self._summation,
        )  # fmt: skip

    def wall_distances(self, solver) -> list[tuple[np.ndarray, np.ndarray]]:
        """(l, n) of the fluid particles to each of this boundary's walls: distance (m, positive in the
        fluid) and unit normal into the fluid, (n_fluid,) and (n_fluid, dim)."""
        raise NotImplementedError

    def shifting_share(self, solver, gc, gct, divr, conc) -> None:
        """The wall's share of particle shifting's sums (:mod:`erosim.sph.shifting_lind2012`): a flat
        layer of wall particles at ρ₀, ∇C += (m/ρ₀) G(l) n, ∇·r −= (m/ρ₀)(H(l) + (d − 1) T(l)), C += Z(l)/ρ₀."""
        rho0 = solver.params.rho0
        for l, n in self.wall_distances(solver):
            shifting_sums(self.curves.table, self.curves.dl, l, np.ascontiguousarray(n), self.m / rho0, rho0, gc, gct,
                          divr, conc)  # fmt: skip

    def constrain(self, solver) -> None:
        st = solver.state
        self._constrain_pass(st.pos, st.vel, st.n_fluid, *self._geometry(), self.gap)


@contextmanager
def walls_follow(solver):
    """Around a change of the terrain under ``solver``'s distance walls (the couplers': apply the
    increments, refresh the boundaries): every :class:`DistanceWall`'s share of the fluid's densities
    before, then :meth:`DistanceWall.follow` after. Without it a particle resting on ground that is
    eroded under it follows the ground down, and the continuity term of that motion, m(v·n)G(l),
    raises its density at every transfer while its distance to the wall stays the same (docs/voxel.md)."""
    walls = [b for b in getattr(solver, "boundaries", ()) if isinstance(b, DistanceWall)]
    before = [b.share(solver) for b in walls]
    yield
    for b, z in zip(walls, before, strict=True):
        b.follow(solver, z)
