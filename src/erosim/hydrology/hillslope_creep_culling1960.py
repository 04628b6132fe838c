"""Hillslope creep: linear diffusion of the dry terrain, ∂z/∂t = κ ∇²z (Culling 1960).

Soil creeps downhill at a rate proportional to the slope, q = −κ ∇z; with mass conservation
∂z/∂t = −∇·q = κ ∇²z. It is how every landscape-evolution model (CHILD, Landlab's LinearDiffuser)
shapes hillslopes between channels, and it damps a bump of wavenumber k at the rate κk²: at the
cell scale fast, at the scale of valleys and ridges hardly. Droplet erosion alone leaves cell-scale
pits and ridges on the slopes where droplets stop and deposit (the demo's hillslope roughness
doubled without it); one explicit step per hydrology cycle removes them.

Discretised in flux form over the four faces of each cell, so the terrain's volume is conserved to
rounding: a face carries c·w·(z_j − z_i) with c = κ/Δx² per cycle and w the smaller mobility of its
two cells — the cell's erodibility (1 − hardness: bedrock does not creep) on dry land, 0 on a lake
cell (lakes keep their bed, whose volume their level accounts for), a nodata cell, and beyond the
map's edge. The explicit step is stable for c ≤ ¼; larger c is split into sub-steps.
Written with NumPy: four slice operations per sub-step on the whole map.
"""

from __future__ import annotations

import math

import numpy as np

STABLE = 0.2  # largest c of one explicit sub-step (stability limit ¼)


def creep_step(z: np.ndarray, mobility: np.ndarray, c: float) -> float:
    """Advance ``z`` (m, changed in place) by one cycle of creep with c = κ/Δx² (``mobility`` per
    cell in [0, 1], 0 = does not creep).

    Returns the volume moved across faces per cell area (m), Σ|flux|, for the sediment report.
    """
    if c <= 0.0:
        return 0.0
    steps = max(1, math.ceil(c / STABLE))
    ci = c / steps
    wx = ci * np.minimum(mobility[:, 1:], mobility[:, :-1])
    wy = ci * np.minimum(mobility[1:, :], mobility[:-1, :])
    moved = 0.0
    for _ in range(steps):
        qx = wx * (z[:, 1:] - z[:, :-1])
        qy = wy * (z[1:, :] - z[:-1, :])
        z[:, :-1] += qx
        z[:, 1:] -= qx
        z[:-1, :] += qy
        z[1:, :] -= qy
        moved += float(np.abs(qx).sum() + np.abs(qy).sum())
    return moved
