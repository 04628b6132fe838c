"""Manning's bed friction for a 3-D SPH fluid over terrain, applied to its water columns.

The shallow-water equations carry the bed's shear stress τ_b = ρ g n² |ū| ū / D^{1/3} as the
deceleration −g n² |ū| ū / D^{4/3} of the depth-averaged velocity ū (Manning's law, e.g. Chow 1959).
A 3-D SPH particle of Δx = 0.1–1 m cannot resolve the boundary layer that makes this stress (a
no-slip wall with SPH's artificial viscosity, ν ≈ αhc/8 of order 1 m²/s, drags the flow instead in a
way set by the sound speed and the spacing), so the ground is free-slip and this pass (in the
solver's list of boundaries, though not a wall) gives every particle the friction of its column
(:func:`erosim.sph.depth_columns.column_fields`, D and ū),
semi-implicitly after each step:

    u_i,h ← u_i,h − (1 − f_i) ū_i,     f_i = 1 / (1 + Δt g n² |ū_i| / D_i^{4/3}),

so each column's mean horizontal momentum is multiplied by f: the friction can stop a column, never
reverse it, however thin the water, and particles keep their deviation from their column's mean.
The same function as the shallow-water solver's kick (f = 1/D,
:func:`erosim.kernels.friction_manning.manning_divisor`), so the two flood solvers feel the same bed. Horizontal
components only (the shallow-water solver's, too); ``manning`` is n everywhere or a map on the
columns' raster nodes (nearest node).
"""

from __future__ import annotations

import numpy as np

from erosim.kernels.friction_manning import manning_divisor
from erosim.sph.boundaries.base import Boundary
from erosim.sph.depth_columns import column_fields

#: m: depths are floored here only to avoid 0/0 (a particle's own column is never empty)
D_FLOOR = 1e-6


class ManningColumns(Boundary):
    """Manning friction on the columns of a 3-D fluid (module docstring); x, y from (0, 0)."""

    name = "manning"

    def __init__(self, manning, spacing: float, shape: tuple[int, int], cell: float, g: float = 9.81):
        self.manning = manning if np.isscalar(manning) else np.ascontiguousarray(manning, np.float64)
        self.spacing, self.shape, self.cell, self.g = float(spacing), tuple(shape), float(cell), float(g)

    def _n(self, pos: np.ndarray) -> np.ndarray | float:
        if np.isscalar(self.manning):
            return float(self.manning)
        ny, nx = self.manning.shape
        col = np.clip(np.floor(pos[:, 0] / self.cell + 0.5).astype(np.int64), 0, nx - 1)
        row = np.clip(np.floor(pos[:, 1] / self.cell + 0.5).astype(np.int64), 0, ny - 1)
        return self.manning[row, col]

    def correct(self, solver, dt: float) -> None:
        st = solver.state
        n = st.n_fluid
        if n == 0:
            return
        pos, vel = st.pos[:n], st.vel[:n]
        d, u, _, _ = column_fields(pos, vel, solver.m / st.rho[:n], self.spacing, self.shape)
        nn = self._n(pos)
        speed = np.hypot(u[:, 0], u[:, 1])
        f = 1.0 / manning_divisor.py_func(nn, speed, np.maximum(d, D_FLOOR), dt, self.g)  # all columns at once
        vel[:, 0] -= (1.0 - f) * u[:, 0]
        vel[:, 1] -= (1.0 - f) * u[:, 1]
