"""Point measurements in a particle fluid: pressure probes and water-level gauges.

Pressure at a probe point r is the Shepard-normalised SPH interpolant (SPEC SPH-1)

    p(r) = Σ_j V_j p_j W(r − r_j, h) / Σ_j V_j W(r − r_j, h),   V_j = m_j/ρ_j,

with the poly6 kernel shape W ∝ (h² − |r|²)³ (Müller et al. 2003; its constant cancels in the
ratio). A probe with no particle within h is dry and reads 0 (gauge pressure of the air).

The water level at a gauge (a vertical line at a horizontal position) is the top of the highest
particle whose horizontal distance to the line is below ``radius``: z_max + Δx/2, given as depth
above ``floor``; a dry gauge reads 0. Vertical is the last axis (y in 2-D, z in 3-D).
Neighbours come from :class:`scipy.spatial.cKDTree` (a handful of points per output time).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def probe_pressure(
    positions: np.ndarray, pressure: np.ndarray, volume: np.ndarray, points: np.ndarray, h: float
) -> np.ndarray:
    """Shepard-interpolated pressure at each of ``points`` (k, d); 0 where no particle is within h."""
    points = np.atleast_2d(np.asarray(points, dtype=np.float64))
    out = np.zeros(len(points))
    if len(positions) == 0 or len(points) == 0:
        return out
    tree = cKDTree(positions)
    vol = np.broadcast_to(np.asarray(volume, dtype=np.float64), (len(positions),))
    for k, idx in enumerate(tree.query_ball_point(points, r=h)):
        if not idx:
            continue
        idx = np.asarray(idx)
        r2 = np.sum((positions[idx] - points[k]) ** 2, axis=1)
        w = vol[idx] * (h * h - r2) ** 3
        s = w.sum()
        if s > 0:
            out[k] = float(np.dot(w, pressure[idx]) / s)
    return out


def water_depth(positions: np.ndarray, gauges: np.ndarray, radius: float, spacing: float, floor: float) -> np.ndarray:
    """Depth above ``floor`` of the water column at each gauge's horizontal position.

    ``gauges`` is (k, d−1): x in 2-D, (x, y) in 3-D. Depth = max z of particles within ``radius``
    horizontally + spacing/2 − floor; 0 if none.
    """
    gauges = np.asarray(gauges, dtype=np.float64).reshape(len(gauges), -1)
    out = np.zeros(len(gauges))
    if len(positions) == 0 or len(gauges) == 0:
        return out
    horiz = positions[:, :-1]
    z = positions[:, -1]
    tree = cKDTree(horiz)
    for k, idx in enumerate(tree.query_ball_point(gauges, r=radius)):
        if idx:
            out[k] = max(0.0, float(z[idx].max()) + 0.5 * spacing - floor)
    return out
