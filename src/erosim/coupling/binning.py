"""Fluid → raster: the per-node fields a terrain model reads from an SPH fluid (SPEC ER-1, FL-2).

For node k of a :class:`~erosim.coupling.raster.Raster` and the fluid particles j in its cell:

    count_k = #j,   volume_k = Σ_j m/ρ_j,   depth_k = volume_k / A   (A: the node's cell area),
    ⟨u⟩_k = (1/count_k) Σ_j u_j   (every component),   speed_k = |⟨u⟩_k|,

(⟨u⟩ is the plain mean velocity of the particles in the cell, seed 000 eq. 2.14; 0 where the cell is
dry), and running maxima max_depth_k, max_speed_k over every binning since the start (the flood
hazard's D and V, FL-2). ``depth`` is the water column the particles' volume fills over the cell: it
assumes the water stands on the cell (the terrain below is the caller's).

Given the ground (its node heights) and a thickness δ, the same pass also gives the flow near the
bed: ``bed_count``, ``bed_velocity`` and ``bed_speed`` over the particles less than δ above the
node's ground — the velocity an erosion law should see, not that of spray or of drops still falling.
Without a ground every particle counts as near the bed.

Why a Numba kernel of our own: the sums run over the solver's internal arrays every few steps without
copies, in particle order (deterministic for any thread count); NumPy's ``add.at`` would need
several temporary arrays per field.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from erosim.coupling.raster import Raster
from erosim.kernels.raster import nearest_node


@njit(cache=True)
def bin_particles(pos, vel, rho, n_fluid, m, x0, y0, inv_dx, inv_dy, nx, ny, inv_area, ground, near, count, depth,
                  velocity, speed, max_depth, max_speed, bed_count, bed_velocity, bed_speed):  # fmt: skip
    """Fill count, depth, velocity, speed (ny, nx[, d]) and the near-bed fields from fluid particles
    0 … n_fluid−1; update the maxima. Returns the number of particles outside the raster."""
    d = pos.shape[1]
    count[:] = 0
    depth[:] = 0.0
    velocity[:] = 0.0
    bed_count[:] = 0
    bed_velocity[:] = 0.0
    outside = 0
    for i in range(n_fluid):
        k = nearest_node(pos, i, x0, y0, inv_dx, inv_dy, nx, ny)
        if k < 0:
            outside += 1
            continue
        iy, ix = k // nx, k % nx
        count[iy, ix] += 1
        depth[iy, ix] += m / rho[i]
        for a in range(d):
            velocity[iy, ix, a] += vel[i, a]
        if pos[i, d - 1] - ground[iy, ix] < near:
            bed_count[iy, ix] += 1
            for a in range(d):
                bed_velocity[iy, ix, a] += vel[i, a]
    for iy in range(ny):
        for ix in range(nx):
            depth[iy, ix] *= inv_area
            s = _mean_speed(velocity, count[iy, ix], iy, ix, d)
            speed[iy, ix] = s
            bed_speed[iy, ix] = _mean_speed(bed_velocity, bed_count[iy, ix], iy, ix, d)
            max_depth[iy, ix] = max(max_depth[iy, ix], depth[iy, ix])
            max_speed[iy, ix] = max(max_speed[iy, ix], s)
    return outside


@njit(inline="always", cache=True)
def _mean_speed(velocity, c, iy, ix, d):
    """Turn the velocity sum of a node into the mean (in place); returns its magnitude (0 when dry)."""
    s = 0.0
    if c > 0:
        for a in range(d):
            u = velocity[iy, ix, a] / c
            velocity[iy, ix, a] = u
            s += u * u
    return math.sqrt(s)


class FluidGrid:
    """The per-node fields of a fluid on ``raster`` (module docstring), refreshed by :meth:`bin`."""

    FIELDS = ("count", "depth", "velocity", "speed", "max_depth", "max_speed", "bed_count", "bed_velocity",
              "bed_speed")  # fmt: skip

    def __init__(self, raster: Raster, dim: int, ground: np.ndarray | None = None, near: float = np.inf):
        self.raster = raster
        self.dim = int(dim)
        shape = raster.shape
        self.ground = np.zeros(shape) if ground is None else ground
        self.near = float(near) if ground is not None else np.inf
        self.count = np.zeros(shape, np.int64)
        self.depth = np.zeros(shape)
        self.velocity = np.zeros(shape + (self.dim,))
        self.speed = np.zeros(shape)
        self.max_depth = np.zeros(shape)
        self.max_speed = np.zeros(shape)
        self.bed_count = np.zeros(shape, np.int64)
        self.bed_velocity = np.zeros(shape + (self.dim,))
        self.bed_speed = np.zeros(shape)
        self.outside = 0

    def bin(self, solver) -> None:
        """Bin the solver's fluid particles (its internal arrays, no copies)."""
        st, r = solver.state, self.raster
        self.outside = bin_particles(
            st.pos, st.vel, st.rho, st.n_fluid, solver.m, r.x0, r.y0, 1.0 / r.dx, 1.0 / r.dy, r.nx, r.ny,
            1.0 / r.cell_area, self.ground, self.near, self.count, self.depth, self.velocity, self.speed,
            self.max_depth, self.max_speed, self.bed_count, self.bed_velocity, self.bed_speed,
        )  # fmt: skip

    def state_dict(self) -> dict[str, Any]:
        """Every field as the last binning left it, the running maxima included: what is read between
        binnings (rain landing on the water, the pictures) is then the same after a resume."""
        out: dict[str, Any] = {k: getattr(self, k).copy() for k in self.FIELDS}
        out["outside"] = int(self.outside)
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state_dict`; a checkpoint of an older erosim (maxima only) leaves the rest zero."""
        for k in self.FIELDS:
            if k in state:
                getattr(self, k)[...] = state[k]
        self.outside = int(np.asarray(state.get("outside", 0)))
