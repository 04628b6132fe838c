"""Conservative SPH diffusion between particles (Brookshaw 1985; Cleary & Monaghan 1999), pairwise.

For a quantity u carried with a capacity c_i (amount q_i = c_i u_i: a pore volume times a saturation,
a particle volume times a solid concentration) the SPH Laplacian gives

    dq_i/dt = Σ_j w_ij (u_j − u_i),        w_ij = D · V_i V_j · L(r_ij),

with V the particles' volumes, D the diffusivity (m²/s) and L the Brookshaw Laplacian weight of the
kernel (:func:`erosim.kernels.sph_kernels.kernel_lap`; for c_i = V_i this is dC_i/dt = Σ_j V_j D
(C_j − C_i) L_ij, seed 003 eq. 16). Each pair's exchange is computed once and added to i and
subtracted from j, so Σ q is conserved to rounding whatever the step; explicit steps are sub-cycled
so that Δt·Σ_j w_ij/c_i ≤ ½ for every particle, which keeps every u between its neighbours' values
(no overshoot, so a saturation stays in [0, 1]).

Pairs come from SciPy's k-d tree (``cKDTree.query_pairs``), sorted, so a run is deterministic. The
pair loop is a small Numba kernel (a scatter in pair order: deterministic): NumPy's gather + two
``bincount``s per sub-step cost ten times more for the ground's 10⁵ pairs every coupling, and no
library offers an SPH pair exchange on a fixed pair list.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from erosim.kernels.sph_kernels import kernel_lap


def pairs_within(pos: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs (i < j) of points closer than ``radius``, sorted by (i, j), and their distances."""
    pos = np.ascontiguousarray(pos, dtype=np.float64)
    if len(pos) < 2:
        z = np.zeros(0, np.int64)
        return z, z.copy(), np.zeros(0)
    pairs = cKDTree(pos).query_pairs(radius, output_type="ndarray").astype(np.int64)
    if len(pairs) == 0:
        z = np.zeros(0, np.int64)
        return z, z.copy(), np.zeros(0)
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    i, j = pairs[:, 0], pairs[:, 1]
    r = np.sqrt(((pos[i] - pos[j]) ** 2).sum(axis=1))
    return i, j, r


def pair_weights(r: np.ndarray, h: float, dim: int, vol_i, vol_j, diffusivity: float) -> np.ndarray:
    """w_ij = D V_i V_j L(r_ij) (m³·m³/s per m² … i.e. capacity units per second)."""
    return diffusivity * np.asarray(vol_i) * np.asarray(vol_j) * kernel_lap(r, h, dim)


@njit(cache=True)
def _rates(w, i, j, capacity, out):
    out[:] = 0.0
    for p in range(w.size):
        out[i[p]] += w[p]
        out[j[p]] += w[p]
    top = 0.0
    for k in range(out.size):
        r = out[k] / max(capacity[k], 1e-300)
        top = max(top, r)
    return top


@njit(cache=True)
def _exchange(u, capacity, i, j, w, h, steps, dq):
    for _ in range(steps):
        dq[:] = 0.0
        for p in range(w.size):
            if w[p] == 0.0:
                continue
            a, b = i[p], j[p]
            flux = w[p] * (u[b] - u[a]) * h
            dq[a] += flux
            dq[b] -= flux
        for k in range(u.size):
            u[k] += dq[k] / capacity[k]


def substeps(w: np.ndarray, i: np.ndarray, j: np.ndarray, capacity: np.ndarray, dt: float) -> int:
    """Sub-steps for Δt: ⌈Δt·max_i Σ_j w_ij / c_i / ½⌉ (at least 1)."""
    if len(w) == 0 or dt <= 0:
        return 1
    top = _rates(w, i, j, np.ascontiguousarray(capacity, np.float64), np.empty(len(capacity)))
    return max(1, int(math.ceil(dt * top / 0.5)))


def diffuse(u: np.ndarray, capacity: np.ndarray, i: np.ndarray, j: np.ndarray, w: np.ndarray, dt: float) -> int:
    """Advance u (in place) by Δt of dq_i/dt = Σ_j w_ij (u_j − u_i), q = c·u; returns the sub-steps used."""
    if len(w) == 0 or dt <= 0:
        return 0
    k = substeps(w, i, j, capacity, dt)
    _exchange(u, np.ascontiguousarray(capacity, np.float64), i, j, w, dt / k, k, np.empty(len(u)))
    return k
