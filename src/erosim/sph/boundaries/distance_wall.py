"""Walls known by a distance function and its normal: the common part of the heightfield ground and
the plane walls, acting through the baked wall-weight curves of
:mod:`erosim.sph.boundaries.wall_weight_harada2007` (no boundary particles, no neighbour loop).

A subclass gives three Numba passes over the fluid particles — ``_density_pass`` (summation
density: ρ += Z(l)), ``_forces_pass`` (pressure, viscosity and continuity terms) and
``_constrain_pass`` (a particle found inside the solid is put back on its surface and loses the
velocity that points into it) — and the arguments that locate its wall (``_geometry()``). This
class bakes the curves for the solver's kernel, spacing and viscosity when it is bound (or reads
them from the on-disk cache, :func:`~erosim.sph.boundaries.wall_weight_harada2007.bake_cached`), and
wires the passes to the solver's hooks.
"""

from __future__ import annotations

import numpy as np

from erosim.sph.boundaries.base import Boundary
from erosim.sph.boundaries.wall_weight_harada2007 import bake_cached

#: a particle put back on a wall sits this fraction of Δx above it
GAP = 1e-3


class DistanceWall(Boundary):
    """Base of walls given by a distance function (see the module docstring)."""

    name = "distance_wall"

    def bind(self, solver) -> None:
        prm = solver.params
        self.curves = bake_cached(prm.kernel, solver.dim, prm.spacing, solver.h, prm.rho0, prm.viscosity)
        self.m = solver.m
        self.gvec = np.asarray(solver.g, np.float64)
        self.wcsph = prm.pressure_form == "wcsph"
        self.cvisc = solver.kv * solver.m if prm.viscosity == "artificial" else -prm.mu * solver.m
        self.gap = GAP * prm.spacing
        if solver.summation:
            self.density = self._density
        self._summation = solver.summation

    def _curve_args(self):
        c = self.curves
        return c.table, c.dl, c.approach_only

    def _density(self, solver) -> None:
        st = solver.state
        self._density_pass(st.pos, st.rho, st.n_fluid, *self._geometry(), self.curves.table, self.curves.dl)

    def forces(self, solver) -> None:
        st = solver.state
        self._forces_pass(
            st.pos, st.vel, st.rho, st.p, st.acc, st.drho, st.n_fluid, *self._geometry(), *self._curve_args(),
            self.m, solver.params.rho0, self.gvec, self.wcsph, self.cvisc, self._summation,
        )  # fmt: skip

    def constrain(self, solver) -> None:
        st = solver.state
        self._constrain_pass(st.pos, st.vel, st.n_fluid, *self._geometry(), self.gap)
