"""Surge front of a collapsing column: the furthest wetted position along the flow axis.

    x_front(t) = max_{i ∈ water} x_i(t) + Δx/2 − x_wall

(the particle centre lies half a spacing inside the water it represents; x_wall is the column's
back wall), the quantity Martin & Moyce (1952) tabulate as z, non-dimensionalised as
Z = x_front/a against T = t √(2g/a) for a column of width a and height 2a (n² = 2).
Spray is not the wetted front: a particle with no other fluid particle within 2Δx is skipped.
"""

from __future__ import annotations

import numpy as np

ISOLATION = 2.0  # a particle with no neighbour within ISOLATION·Δx is spray


def front_position(positions: np.ndarray, spacing: float, origin: float, axis: int = 0) -> float:
    """Furthest x (along ``axis``) of non-isolated fluid particles + Δx/2, measured from ``origin`` (m)."""
    n = len(positions)
    if n == 0:
        return 0.0
    x = positions[:, axis]
    order = np.argsort(-x, kind="stable")
    xs = -x[order]  # ascending
    r = ISOLATION * spacing
    for k in range(min(n, 512)):
        i = order[k]
        lo = int(np.searchsorted(xs, -x[i] - r, side="left"))
        hi = int(np.searchsorted(xs, -x[i] + r, side="right"))
        cand = order[lo:hi]
        cand = cand[cand != i]
        if cand.size and np.any(np.sum((positions[cand] - positions[i]) ** 2, axis=1) <= r * r):
            return float(x[i] + 0.5 * spacing - origin)
    return float(x.max() + 0.5 * spacing - origin)


def nondimensional_front(t: np.ndarray, x_front: np.ndarray, a: float, g: float) -> tuple[np.ndarray, np.ndarray]:
    """(T, Z) = (t √(2g/a), x_front / a)."""
    return np.asarray(t) * np.sqrt(2.0 * g / a), np.asarray(x_front) / a
