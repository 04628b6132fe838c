"""Raster → particles: Q4 values of a node raster at the fluid particles (SPEC HM-2).

``value(x, y) = Σ_j F_j N_j(ξ, η)`` over the four nodes of the cell holding (x, y), with the shape
functions of :func:`erosim.kernels.raster.q4_shape`; positions beyond the raster are clamped to its
edge. Used to give particles a terrain quantity (ground height under a particle, hardness, a
sediment concentration) from the grid the coupler keeps.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from erosim.coupling.raster import Raster
from erosim.kernels.raster import bilinear


@njit(parallel=True, cache=True)
def sample_q4(values, pos, n, x0, y0, inv_dx, inv_dy, out):
    """out[i] = Q4 interpolant of ``values`` (ny, nx) at particle i's horizontal position, i < n."""
    d = pos.shape[1]
    for i in prange(n):
        x = (pos[i, 0] - x0) * inv_dx
        y = (pos[i, 1] - y0) * inv_dy if d == 3 else 0.0
        out[i] = bilinear(values, x, y)


def sample(raster: Raster, values: np.ndarray, positions: np.ndarray, n: int | None = None) -> np.ndarray:
    """Q4 values of ``values`` (raster.shape) at the first ``n`` (default all) of ``positions`` (n, dim)."""
    values = np.ascontiguousarray(values, dtype=np.float64)
    if values.shape != raster.shape:
        raise ValueError(f"values have shape {values.shape}, the raster {raster.shape}")
    n = positions.shape[0] if n is None else int(n)
    out = np.empty(n, np.float64)
    sample_q4(values, positions, n, raster.x0, raster.y0, 1.0 / raster.dx, 1.0 / raster.dy, out)
    return out
