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

Pairs come from SciPy's k-d tree (``cKDTree.query_pairs``), sorted, so a run is deterministic; the
sums are NumPy ``bincount``s. No Numba kernel here: the passes run every coupling, not every step,
and the library calls are fast enough (docs/splash.md gives their cost).
"""

from __future__ import annotations

import math

import numpy as np
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


def substeps(w: np.ndarray, i: np.ndarray, j: np.ndarray, capacity: np.ndarray, dt: float) -> int:
    """Sub-steps for Δt: ⌈Δt·max_i Σ_j w_ij / c_i / ½⌉ (at least 1)."""
    n = len(capacity)
    if len(w) == 0 or dt <= 0:
        return 1
    rate = (np.bincount(i, w, n) + np.bincount(j, w, n)) / np.maximum(capacity, 1e-300)
    return max(1, int(math.ceil(dt * float(rate.max()) / 0.5)))


def diffuse(u: np.ndarray, capacity: np.ndarray, i: np.ndarray, j: np.ndarray, w: np.ndarray, dt: float) -> int:
    """Advance u (in place) by Δt of dq_i/dt = Σ_j w_ij (u_j − u_i), q = c·u; returns the sub-steps used."""
    n = len(u)
    if len(w) == 0 or dt <= 0:
        return 0
    k = substeps(w, i, j, capacity, dt)
    h = dt / k
    for _ in range(k):
        flux = w * (u[j] - u[i]) * h  # amount moving j → i
        u += (np.bincount(i, flux, n) - np.bincount(j, flux, n)) / capacity
    return k
