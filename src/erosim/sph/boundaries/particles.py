"""Fixed boundary particles for tank walls and box obstacles (dynamic boundary particles).

Dynamic boundary particles (Crespo, Gómez-Gesteira & Dalrymple 2007; the fixed particles of seed
001, SPEC SPH-12): lattice particles that never move but carry density (from the continuity
equation, or summation) and pressure (from the EOS), so fluid approaching a wall compresses them and
is pushed back. Layers sit at half-spacing offsets outside the fluid region, so the first layer is
Δx/2 behind the wall face, like the fluid's first layer is Δx/2 in front of it.
"""

from __future__ import annotations

import numpy as np


def _lattice(lo, hi, dx):
    """Points (k + ½)Δx from ``lo`` that lie inside [lo, hi] (at least one per axis)."""
    axes = []
    for a in range(len(lo)):
        n = max(1, int(round((hi[a] - lo[a]) / dx)))
        axes.append(lo[a] + (np.arange(n) + 0.5) * (hi[a] - lo[a]) / n)
    grids = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=1)


def box_walls(lo, hi, spacing: float, layers: int, open_top: bool = True) -> np.ndarray:
    """Particles in a shell ``layers``·Δx thick around the box [lo, hi], open at the top (last axis max).

    The shell covers the box's sides and floor and its corners; with ``open_top`` the top face has none.
    """
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    d = lo.size
    t = layers * spacing
    outer_lo = lo - t
    outer_hi = hi + t
    if open_top:
        outer_hi[-1] = hi[-1]
    # lattice aligned with the box: cell counts from the inner box extent keep spacing ~Δx
    n_in = np.maximum(1, np.round((hi - lo) / spacing)).astype(int)
    dxs = (hi - lo) / n_in
    axes = []
    for a in range(d):
        inner = lo[a] + (np.arange(n_in[a]) + 0.5) * dxs[a]
        below = lo[a] - (np.arange(layers) + 0.5) * dxs[a]
        above = hi[a] + (np.arange(layers) + 0.5) * dxs[a]
        if open_top and a == d - 1:
            above = above[:0]
        axes.append(np.concatenate([below[::-1], inner, above]))
    grids = np.meshgrid(*axes, indexing="ij")
    pts = np.stack([g.ravel() for g in grids], axis=1)
    inside = np.all((pts > lo) & (pts < hi), axis=1)
    keep = ~inside & np.all((pts >= outer_lo) & (pts <= outer_hi), axis=1)
    return pts[keep]


def box_obstacle(lo, hi, spacing: float, layers: int) -> np.ndarray:
    """Particles filling the outer ``layers``·Δx of the solid box [lo, hi] (hollow inside)."""
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    pts = _lattice(lo, hi, spacing)
    t = layers * spacing
    deep = np.all((pts > lo + t) & (pts < hi - t), axis=1)
    return pts[~deep]
