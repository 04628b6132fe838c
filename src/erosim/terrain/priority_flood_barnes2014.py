"""Closed basins filled to their spill level with a gentle down-valley slope (Priority-Flood+ε).

Barnes, Lehman & Mulla (2014), "Priority-Flood: An optimal depression-filling and watershed-labeling
algorithm for digital elevation models", Computers & Geosciences 62, 117–127, Algorithm 3: the map's
edge cells seed a priority queue keyed by height; the lowest cell is taken out and each unvisited
8-neighbour q of it, c, is raised to at least z_c + ε and queued. Here ε is a physical slope s (m/m)
times a distance, so that a filled basin becomes a plain that falls toward its spill point at s,
whatever the cell size. Two raises (``metric``):

* ``"euclidean"`` (default): the plain F solves the eikonal equation |∇F| = s over the basin, F = z on
  the ground that stands above it. The queue is Dijkstra's, as in the fast marching method (Sethian
  1996, PNAS 93, 1591–1595; Tsitsiklis 1995), and a cell's raise is fast marching's upwind update from
  its accepted 4-neighbours: with a ≤ b the lower accepted neighbour along x and along y and r = s·Δx,

      F_q = ½(a + b + √(2r² − (b − a)²))   if b − a < r,   else a + r,

  or F_d + √2·r from an accepted diagonal neighbour d where that is lower (water still crosses a
  diagonal gap in the ground); F_q ← max(z_q, F_q). The plain's contours are circles about its spill
  point: slope lines in every direction, and |∇F| = s to first order in Δx/distance.
* ``"d8"``: Algorithm 3 as published, z_q ← max(z_q, z_c + s·|q − c|) with |q − c| = Δx or √2·Δx. The
  plain is a cone over the 8-neighbour path length: octagonal facets whose slope lines keep to
  22.5° modulo 45°, which on a large plain lines the droplets' rivers up along rows, columns and diagonals
  (docs/hydrology.md, "The fill's plains fall over the Euclidean distance").

Every raised cell has a 4- or 8-neighbour lower by at least s·Δx/√2 (the eikonal update) or s·Δx (d8),
so every cell has a strictly descending path to the map's edge (s > 0); cells outside the closed
basins are left exactly as they were. Generated noise terrains have many closed basins (the library
``mountains`` of 10 km: 39 % of the area, 91 m deep on average) which a real landscape's rivers
have long since filled with sediment or cut through; filling them is the sediment half of that
history (``terrain.fill_slope``, off by default).

Written as Numba kernels sharing one indexed binary heap (ties broken by cell index, so the result is
deterministic): scikit-image's morphological reconstruction fills basins flat (s = 0), which leaves
droplets nowhere to go; scikit-fmm computes distances from a front but not a fill that yields to the
ground above it; no maintained library installed here fills with a slope in metres.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

SQRT2 = math.sqrt(2.0)
METRICS = ("euclidean", "d8")


@njit(cache=True, inline="always")
def _less(hk, hc, a, b):
    return hk[a] < hk[b] or (hk[a] == hk[b] and hc[a] < hc[b])


@njit(cache=True)
def _sift_up(hk, hc, pos, i):
    while i > 0:
        p = (i - 1) >> 1
        if not _less(hk, hc, i, p):
            break
        hk[p], hk[i] = hk[i], hk[p]
        hc[p], hc[i] = hc[i], hc[p]
        pos[hc[i]] = i
        pos[hc[p]] = p
        i = p


@njit(cache=True)
def _sift_down(hk, hc, pos, i, n):
    while True:
        left = 2 * i + 1
        right = left + 1
        s = i
        if left < n and _less(hk, hc, left, s):
            s = left
        if right < n and _less(hk, hc, right, s):
            s = right
        if s == i:
            return
        hk[s], hk[i] = hk[i], hk[s]
        hc[s], hc[i] = hc[i], hc[s]
        pos[hc[i]] = i
        pos[hc[s]] = s
        i = s


@njit(cache=True)
def _offer(hk, hc, pos, n, key, cell):
    """Queue ``cell`` at ``key``, or lower its key if it is queued higher; returns the heap's size."""
    i = pos[cell]
    if i < 0:
        i = n
        n += 1
        hc[i] = cell
        pos[cell] = i
    elif key >= hk[i]:
        return n
    hk[i] = key
    _sift_up(hk, hc, pos, i)
    return n


@njit(cache=True)
def _take(hk, hc, pos, n):
    cell = hc[0]
    pos[cell] = -2  # accepted: never queued again
    n -= 1
    if n > 0:
        hk[0] = hk[n]
        hc[0] = hc[n]
        pos[hc[0]] = 0
        _sift_down(hk, hc, pos, 0, n)
    return cell, n


@njit(cache=True)
def _queue_edges(zf, nx, ny):
    """The queue (keys, cells, slots, size) seeded with the map's edge cells at their own heights; a cell's
    slot is -1 while not queued, -2 once taken out (its height final), else its place in the heap."""
    n = nx * ny
    hk = np.empty(n)
    hc = np.empty(n, np.int64)
    pos = np.full(n, -1, np.int64)
    m = 0
    for c in range(n):
        iy = c // nx
        ix = c - iy * nx
        if ix == 0 or iy == 0 or ix == nx - 1 or iy == ny - 1:
            m = _offer(hk, hc, pos, m, zf[c], c)
    return hk, hc, pos, m


@njit(cache=True)
def _fill(zf, nx, ny, rise, rise_diag):
    """Algorithm 3's raise (``metric="d8"``): each cell is queued once, from the first neighbour taken out."""
    hk, hc, pos, m = _queue_edges(zf, nx, ny)
    while m > 0:
        c, m = _take(hk, hc, pos, m)
        iy = c // nx
        ix = c - iy * nx
        for jy in range(max(iy - 1, 0), min(iy + 2, ny)):
            for jx in range(max(ix - 1, 0), min(ix + 2, nx)):
                q = jy * nx + jx
                if pos[q] != -1:
                    continue
                floor = zf[c] + (rise_diag if jx != ix and jy != iy else rise)
                if zf[q] < floor:
                    zf[q] = floor
                m = _offer(hk, hc, pos, m, zf[q], q)


@njit(cache=True, inline="always")
def _accepted(zf, pos, q):
    return zf[q] if pos[q] == -2 else np.inf


@njit(cache=True)
def _arrival(zf, pos, q, nx, ny, rise, rise_diag):
    """The eikonal update at cell q from its accepted neighbours (module docstring)."""
    iy = q // nx
    ix = q - iy * nx
    a = np.inf
    b = np.inf
    d = np.inf
    if ix > 0:
        a = min(a, _accepted(zf, pos, q - 1))
    if ix < nx - 1:
        a = min(a, _accepted(zf, pos, q + 1))
    if iy > 0:
        b = min(b, _accepted(zf, pos, q - nx))
        if ix > 0:
            d = min(d, _accepted(zf, pos, q - nx - 1))
        if ix < nx - 1:
            d = min(d, _accepted(zf, pos, q - nx + 1))
    if iy < ny - 1:
        b = min(b, _accepted(zf, pos, q + nx))
        if ix > 0:
            d = min(d, _accepted(zf, pos, q + nx - 1))
        if ix < nx - 1:
            d = min(d, _accepted(zf, pos, q + nx + 1))
    if b < a:
        a, b = b, a
    if b - a < rise:  # false when b is infinite or rise is 0
        t = 0.5 * (a + b + math.sqrt(2.0 * rise * rise - (b - a) * (b - a)))
    else:
        t = a + rise
    return min(t, d + rise_diag)


@njit(cache=True)
def _fill_eikonal(zf, nx, ny, rise, rise_diag):
    hk, hc, pos, m = _queue_edges(zf, nx, ny)
    while m > 0:
        key = hk[0]
        c, m = _take(hk, hc, pos, m)
        zf[c] = key
        iy = c // nx
        ix = c - iy * nx
        for jy in range(max(iy - 1, 0), min(iy + 2, ny)):
            for jx in range(max(ix - 1, 0), min(ix + 2, nx)):
                q = jy * nx + jx
                if pos[q] == -2:
                    continue
                t = _arrival(zf, pos, q, nx, ny, rise, rise_diag)
                m = _offer(hk, hc, pos, m, max(zf[q], t), q)


def fill_basins(z: np.ndarray, cell_size: float, slope: float, metric: str = "euclidean") -> np.ndarray:
    """A copy of ``z`` with every closed basin filled to a plain falling at ``slope`` (m/m) toward
    its spill point; the map's edge is the outlet. ``metric`` ``"euclidean"`` (default) or ``"d8"``: the
    distance the plain falls over (module docstring)."""
    if not (math.isfinite(slope) and slope >= 0.0):
        raise ValueError(f"fill slope {slope!r} must be a finite number >= 0")
    if metric not in METRICS:
        raise ValueError(f"fill metric {metric!r} must be one of {', '.join(METRICS)}")
    out = np.array(z, dtype=np.float64, copy=True)
    ny, nx = out.shape
    rise = slope * float(cell_size)
    kernel = _fill_eikonal if metric == "euclidean" else _fill
    kernel(out.reshape(-1), nx, ny, rise, SQRT2 * rise)
    return out


def closed_basin_depth(z: np.ndarray) -> np.ndarray:
    """Depth (m) of water that would stand in each cell if every closed basin filled to its spill
    level (``fill_basins`` with slope 0 minus ``z``): 0 outside closed basins."""
    return fill_basins(z, 1.0, 0.0) - np.asarray(z, dtype=np.float64)
