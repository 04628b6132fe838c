"""Surge front of a collapsing column: the furthest wetted position along the flow axis.

    x_front(t) = max_i x_i(t) + Δx/2 − x_wall

(the particle centre lies half a spacing inside the water it represents; x_wall is the column's
back wall), the quantity Martin & Moyce (1952) tabulate as z, non-dimensionalised as
Z = x_front/a against T = t √(2g/a) for a column of width a and height 2a (n² = 2).
Residual column height at the back wall: H = h/(2a) against τ = t √(g/a).
"""

from __future__ import annotations

import numpy as np


def front_position(positions: np.ndarray, spacing: float, origin: float, axis: int = 0) -> float:
    """Furthest wetted coordinate along ``axis``, measured from ``origin`` (metres)."""
    if len(positions) == 0:
        return 0.0
    return float(positions[:, axis].max() + 0.5 * spacing - origin)


def nondimensional_front(t: np.ndarray, x_front: np.ndarray, a: float, g: float) -> tuple[np.ndarray, np.ndarray]:
    """(T, Z) = (t √(2g/a), x_front / a)."""
    return np.asarray(t) * np.sqrt(2.0 * g / a), np.asarray(x_front) / a
