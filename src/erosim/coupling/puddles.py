"""Water standing on wet ground after a splash run, measured on the DEM's grid: each fluid particle's water
spread over its footprint (a square of the fluid spacing, volume conserved), gathered by closed hollow
and levelled in it (the hollow filled to its spill level: morphological reconstruction).
"""

from __future__ import annotations

import math

import numpy as np

from erosim.coupling.sampling import sample
from erosim.coupling.splash_coupler import WetGround


def hollow_depth(z: np.ndarray) -> np.ndarray:
    """Depth (m) of the closed hollows of ``z``: the surface filled to its spill level minus z."""
    from skimage.morphology import reconstruction

    seed = z.copy()
    seed[1:-1, 1:-1] = z.max()
    return reconstruction(seed, z, method="erosion") - z


def footprint_volume(raster, xy: np.ndarray, volume: np.ndarray, side: float) -> np.ndarray:
    """Volumes (m³, one per node's cell) of water spread from points ``xy`` over the square footprints of
    ``side`` metres centred on them, each cell taking the share of a footprint that it covers (the cells are
    the nodes' squares); a footprint's share beyond the map goes to the cells it covers inside, so the
    volume is conserved: Σ = Σ ``volume``."""
    nx, ny, dx, dy = raster.nx, raster.ny, raster.dx, raster.dy
    out = np.zeros(ny * nx)
    if len(xy) == 0:
        return out.reshape(ny, nx)
    a = max(float(side), 1e-12)

    def weights(c, x0, d, n):
        """Per axis: node indices (m, k) and the footprint's share of each (rows sum to 1 inside the map)."""
        lo = (c - 0.5 * a - x0) / d
        first = np.floor(lo + 0.5).astype(np.int64)
        m = int(math.ceil(a / d)) + 1
        idx = first[:, None] + np.arange(m)[None, :]
        cell_lo = x0 + (idx - 0.5) * d
        w = np.clip(np.minimum(c[:, None] + 0.5 * a, cell_lo + d) - np.maximum(c[:, None] - 0.5 * a, cell_lo), 0.0,
                    None)  # fmt: skip
        w = np.where((idx >= 0) & (idx < n), w, 0.0)
        total = w.sum(axis=1, keepdims=True)
        return np.clip(idx, 0, n - 1), w / np.where(total > 0, total, 1.0), total[:, 0] > 0

    ix, wx, okx = weights(np.asarray(xy[:, 0], np.float64), raster.x0, dx, nx)
    iy, wy, oky = weights(np.asarray(xy[:, 1], np.float64), raster.y0, dy, ny)
    vol = np.where(okx & oky, np.asarray(volume, np.float64), 0.0)
    for j in range(iy.shape[1]):
        for i in range(ix.shape[1]):
            out += np.bincount(iy[:, j] * nx + ix[:, i], vol * wy[:, j] * wx[:, i], ny * nx)
    return out.reshape(ny, nx)


def pond(z: np.ndarray, hollows: np.ndarray, volume: np.ndarray, cell_area: float) -> np.ndarray:
    """Depth (m) of the water ``volume`` (m³ per cell) that lies in each closed hollow (``hollows`` > 0, its
    depth below the spill level; 8-connected cells form one hollow) standing level in it: the level L with
    Σ max(L − z, 0)·A = the hollow's water, at most its spill level (water beyond spills and is not
    counted). Depths are those of a physical volume on the grid, however large the particles."""
    from scipy import ndimage

    depth = np.zeros_like(z, dtype=np.float64)
    labels, n = ndimage.label(hollows > 0, structure=np.ones((3, 3)))
    if n == 0:
        return depth
    held = ndimage.sum_labels(volume, labels, np.arange(1, n + 1))
    for k in np.nonzero(held > 0)[0]:
        cells = labels == k + 1
        zc = z[cells]
        spill = float((zc + hollows[cells]).max())
        order = np.sort(zc)
        # volume to fill up to each cell's bottom: A·Σ_{j<i} (z_i − z_j)
        below = cell_area * (np.arange(len(order)) * order - np.concatenate([[0.0], np.cumsum(order)[:-1]]))
        i = int(np.searchsorted(below, held[k], side="right")) - 1
        level = order[i] + (held[k] - below[i]) / (cell_area * (i + 1))
        depth[cells] = np.maximum(min(level, spill) - zc, 0.0)
    return depth


def standing_water(wet: WetGround, raster, hollows: np.ndarray) -> np.ndarray:
    """Puddles (m): the water the fluid particles still hold (V_p times their ``water`` share), spread over
    each particle's footprint (a square of the fluid spacing: :func:`footprint_volume`), gathered by closed
    hollow (``hollows`` > 0) and standing level in it (:func:`pond`) — water that stands because it cannot
    run off; water elsewhere is on its way down the slope and not counted."""
    st = wet.solver.state
    nf = st.n_fluid
    if nf == 0:
        return np.zeros(hollows.shape)
    pos = st.pos[:nf].astype(np.float64)
    volume = footprint_volume(raster, pos[:, :2], st.water[:nf] * wet.vp, wet.solver.params.spacing)
    return pond(wet.terrain, hollows, volume, raster.cell_area)


def water_depth(wet: WetGround, raster) -> np.ndarray:
    """Depth (m) of the water on the ground: the water the fluid particles within two kernel supports of
    the ground hold (V_p times their ``water`` share; those higher up are still falling), each spread over
    its footprint, a square of the fluid spacing (:func:`footprint_volume`): Σ depth·A is that water, and
    one particle on a fine grid is not one cell's column of its whole volume."""

    st = wet.solver.state
    nf = st.n_fluid
    if nf == 0:
        return np.zeros(raster.shape)
    pos = st.pos[:nf].astype(np.float64)
    near = pos[:, 2] - sample(raster, wet.terrain, pos) < 2.0 * wet.solver.h
    vol = footprint_volume(raster, pos[near, :2], st.water[:nf][near] * wet.vp, wet.solver.params.spacing)
    return vol / raster.cell_area
