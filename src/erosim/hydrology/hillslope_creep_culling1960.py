"""Hillslope creep: linear diffusion of the dry terrain, ∂z/∂t = κ ∇²z (Culling 1960).

Soil creeps downhill at a rate proportional to the slope, q = −κ ∇z; with mass conservation
∂z/∂t = −∇·q = κ ∇²z. It is how every landscape-evolution model (CHILD, Landlab's LinearDiffuser)
shapes hillslopes between channels, and it damps a bump of wavenumber k at the rate κk²: at the
cell scale fast, at the scale of valleys and ridges hardly. Droplet erosion alone leaves cell-scale
pits and ridges on the slopes where droplets stop and deposit (the demo's hillslope roughness
doubled without it); one explicit step per hydrology cycle removes them.

Discretised in flux form over the four faces of each cell, so the terrain's volume is conserved to
rounding: a face carries c·w·(z_j − z_i) with c = κ/Δx² per cycle and w the smaller mobility of its
two cells — the cell's erodibility (1 − hardness: bedrock does not creep) on dry land, 0 on a nodata
cell and beyond the map's edge. A lake cell does not creep, but the soil of a higher dry neighbour
slumps onto its bed across their face (weight: the dry cell's erodibility), as creep carries a shore into
the water; the caller makes that gain through the lake bookkeeping
(:func:`erosim.hydrology.pools.settle_gains`: the water it displaces, a bed raised above the water
leaving the lake). Without it a lake cell on an aggrading plain kept its bed while the plain rose round
it, and the library scenario at 512² held 660 one-cell lakes, up to 28 m deep (issue 36). The explicit
step is stable for c ≤ ¼; larger c is split into sub-steps.
One Numba pass per sub-step, in place (two rows of the old heights kept aside), the mobility read
from the erodibility and lake maps as it goes: in NumPy the step made ~10 whole-map temporaries a
cycle, about 7 % of a 1024² run's time. The pass runs in parallel over bands of 32 rows.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

STABLE = 0.2  # largest c of one explicit sub-step (stability limit ¼)
BAND = 32  # rows per band of the parallel pass


@njit(cache=True, inline="always")
def _mob(erod, lake_of, c):
    """Mobility of cell c: its erodibility on dry land, 0 on a lake, nodata or halo cell."""
    return erod[c] if lake_of[c] == -1 else 0.0


@njit(cache=True, inline="always")
def _shore(erod, lake_of, lo, hi, zlo, zhi):
    """Weight of a face that dry land alone does not carry: a dry cell above a lake cell's bed sends its soil
    in, with its own erodibility; otherwise 0 (a lake to anything lower, nodata, halo, rock)."""
    if lake_of[hi] == -1 and lake_of[lo] >= 0 and zhi > zlo:
        return erod[hi]
    if lake_of[lo] == -1 and lake_of[hi] >= 0 and zlo > zhi:
        return erod[lo]
    return 0.0


@njit(cache=True, inline="always")
def _creep_rows(zf, erod, lake_of, c, r0, r1, nx, old):
    """One sub-step's fluxes of the x faces of rows r0 … r1 − 1 and of the y faces between them, in
    place; returns their Σ|flux|. Every flux comes from the heights before the sub-step: ``old`` (2 × nx)
    keeps rows j and j + 1 as they were, since row j is changed by its faces with row j + 1 before row
    j + 1's own faces."""
    moved = 0.0
    for i in range(nx):
        old[0, i] = zf[r0 * nx + i]
    for j in range(r0, r1):
        a = (j - r0) % 2  # old row j in old[a], old row j + 1 goes to old[1 − a]
        b = j * nx
        if j + 1 < r1:
            for i in range(nx):
                old[1 - a, i] = zf[b + nx + i]
        ml = _mob(erod, lake_of, b)
        for i in range(nx - 1):  # x faces: q = c·w·(z[i+1] − z[i])
            mr = _mob(erod, lake_of, b + i + 1)
            w = min(ml, mr)
            if w == 0.0:  # a lake, rock or nodata on one side: only a shore sends soil
                w = _shore(erod, lake_of, b + i, b + i + 1, old[a, i], old[a, i + 1])
            q = c * w * (old[a, i + 1] - old[a, i])
            zf[b + i] += q
            zf[b + i + 1] -= q
            moved += abs(q)
            ml = mr
        if j + 1 < r1:  # y faces with row j + 1
            moved += _y_faces(zf, erod, lake_of, c, b, nx, old[a], old[1 - a])
    return moved


@njit(cache=True, inline="always")
def _y_faces(zf, erod, lake_of, c, b, nx, above, below):
    """The fluxes of the y faces between the row starting at flat index b and the next, from their heights
    before the sub-step (``above``, ``below``), in place; returns Σ|flux|."""
    moved = 0.0
    for i in range(nx):
        w = min(_mob(erod, lake_of, b + i), _mob(erod, lake_of, b + nx + i))
        if w == 0.0:
            w = _shore(erod, lake_of, b + i, b + nx + i, above[i], below[i])
        q = c * w * (below[i] - above[i])
        zf[b + i] += q
        zf[b + nx + i] -= q
        moved += abs(q)
    return moved


@njit(cache=True, parallel=True)
def _creep(z, erod, lake_of, c, steps, band):
    """``steps`` explicit sub-steps of c each, in place; returns Σ|flux| (m). In parallel over bands of
    ``band`` rows (:func:`_creep_rows`); the y faces between two bands are made after them, from the two rows
    as they were before the sub-step (kept aside). The bands' size is fixed, not the thread count, so the
    result is the same for any thread count."""
    ny, nx = z.shape
    zf = z.reshape(-1)
    nb = (ny + band - 1) // band
    old = np.empty((nb, 2, nx))
    edge = np.empty((nb, 2, nx))  # rows r − 1 and r before the sub-step, r the first row of band b ≥ 1
    moved = np.zeros(nb)
    for _ in range(steps):
        for b in prange(1, nb):
            r = b * band
            for i in range(nx):
                edge[b, 0, i] = zf[(r - 1) * nx + i]
                edge[b, 1, i] = zf[r * nx + i]
        for b in prange(nb):
            moved[b] += _creep_rows(zf, erod, lake_of, c, b * band, min((b + 1) * band, ny), nx, old[b])
        for b in prange(1, nb):
            moved[b] += _y_faces(zf, erod, lake_of, c, (b * band - 1) * nx, nx, edge[b, 0], edge[b, 1])
    total = 0.0
    for b in range(nb):
        total += moved[b]
    return total


def creep_step(z: np.ndarray, mobility: np.ndarray, c: float, lake_of: np.ndarray | None = None) -> float:
    """Advance ``z`` (m, changed in place) by one cycle of creep with c = κ/Δx² (``mobility`` per
    cell in [0, 1], 0 = does not creep; with ``lake_of`` (flat, the lake of each cell, −1 dry) a
    cell that is not dry does not creep either, but a lake cell (≥ 0) receives from a higher dry
    neighbour: its bed rises, and the caller settles that gain in the lake).

    Returns the volume moved across faces per cell area (m), Σ|flux|, for the sediment report.
    """
    if c <= 0.0:
        return 0.0
    steps = max(1, math.ceil(c / STABLE))
    erod = np.ascontiguousarray(mobility, dtype=np.float64).reshape(-1)
    if lake_of is None:
        lake_of = np.full(erod.shape[0], -1, np.int64)
    return float(_creep(z, erod, lake_of, c / steps, steps, BAND))
