"""Depth-averaged fields of a 3-D SPH fluid: the water column under every particle.

The particles' volumes V_j = m/ρ_j and horizontal momenta V_j u_j are summed on square columns of the
particle spacing Δx and smoothed by a Gaussian G of σ = 0.79 Δx:

    D(x) = Σ_j V_j G(x − x_j),     ū(x) = Σ_j V_j u_j G(x − x_j) / D(x),

σ being the second moment of the 2-D Wendland C2 kernel at a support of three spacings, the
shallow-water SPH's own depth summation (Rodriguez-Paz & Bonet 2005; ``flood.support`` = 3). So D is
the depth the shallow-water solver gives the same water: a film one particle thick and sparse gets
its mean depth, not one particle's height. The 3-D flood reads these columns for its hazard maps and
for Manning's bed friction (:mod:`erosim.sph.manning_columns`).

Frame: x, y horizontal from the grid's corner (0, 0); columns of ``spacing`` (row = ⌊y/Δx⌋,
col = ⌊x/Δx⌋, particles outside are clamped onto the edge columns). Only the box around the
particles is smoothed (a run's water covers a small part of its DEM); at the grid's edges the
smoothing reflects, as a wall does, so no water is lost there.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter

#: σ/Δx: the Gaussian with the second moment of a 2-D Wendland C2 kernel of support 3Δx
SIGMA = 0.79
_PAD = 4  # columns of margin around the particles (4 ≥ 4σ/Δx: the filter's truncation)


def column_fields(pos: np.ndarray, vel: np.ndarray, vol: np.ndarray, spacing: float, shape: tuple[int, int]):
    """(d_i, ū_i (n, 2), (D, ūx, ūy) on the (ny, nx) column grid, (row_i, col_i)) for particles
    ``pos`` (n, ≥2) with velocities ``vel`` and volumes ``vol`` (module docstring)."""
    n = len(vol)
    ny, nx = shape
    ix = np.clip(np.floor(pos[:, 0] / spacing).astype(np.int64), 0, nx - 1)
    iy = np.clip(np.floor(pos[:, 1] / spacing).astype(np.int64), 0, ny - 1)
    grids = tuple(np.zeros(shape) for _ in range(3))
    if n == 0:
        return np.zeros(0), np.zeros((0, 2)), grids, (iy, ix)
    lo_y, hi_y = max(int(iy.min()) - _PAD, 0), min(int(iy.max()) + _PAD + 1, ny)
    lo_x, hi_x = max(int(ix.min()) - _PAD, 0), min(int(ix.max()) + _PAD + 1, nx)
    sub = (hi_y - lo_y, hi_x - lo_x)
    flat = (iy - lo_y) * sub[1] + (ix - lo_x)
    area = spacing * spacing
    fields = [
        gaussian_filter(np.bincount(flat, weights=w, minlength=sub[0] * sub[1]).reshape(sub), SIGMA,
                        mode="reflect", truncate=4.0) / area
        for w in (vol, vol * vel[:, 0], vol * vel[:, 1])
    ]  # fmt: skip
    depth = fields[0]
    safe = np.where(depth > 0, depth, 1.0)
    grids[0][lo_y:hi_y, lo_x:hi_x] = depth
    grids[1][lo_y:hi_y, lo_x:hi_x] = fields[1] / safe
    grids[2][lo_y:hi_y, lo_x:hi_x] = fields[2] / safe
    d_i = grids[0][iy, ix]
    u_i = np.column_stack([grids[1][iy, ix], grids[2][iy, ix]])
    return d_i, u_i, grids, (iy, ix)
