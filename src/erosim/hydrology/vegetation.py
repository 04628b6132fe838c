"""HY-5 vegetation: trees that hold the soil (SimpleHydrology 2020, ``World::grow``).

Once per cycle, with the seed's rules in physical units (ℓ = the seed's cell):

* trees die in lakes or the sea, in strong streams (> ``max_stream``, 0.2), or at random
  (``death``, seed 1/1000);
* each surviving tree seeds a cell within ``spread_radius``·ℓ (uniform in the square) with chance
  ``spread`` (seed 1/50); then ``spawn`` random seedlings per (256 ℓ)² of map area (Poisson);
* a candidate takes root only on a free cell of dry land (no lake, not below the sea), where
  stream < ``max_stream``, the surface is not steep (unit normal's z ≥ ``min_normal_z``, 0.8, from
  central differences) and a random draw exceeds the local root density. Candidates are tried one
  after another (trees in row-major order, then the seedlings), each against the trees and cover
  left by the previous ones, as the seed's loop does.

Root density ρ_r = min(1, strength · cover), cover = share of cells within ``root_radius``·ℓ that
hold a tree (one tree per cell at most, so a forest's density does not depend on the grid). The
droplets scale their erosion and deposition by max(0, 1 − ρ_r) (roots hold the soil). ``cover`` is
updated incrementally where trees are born or die.

Random numbers: the Poisson count of seedlings and a 64-bit key come from the caller's NumPy
generator (seeded per cycle); the kernel's draws are SplitMix64 from that key
(:mod:`erosim.hydrology.counter_rng`). The step is one Numba kernel, O(map) for the scan of the
tree map plus O(trees): done in NumPy it cost about 1.5 ms a cycle on a 256² map (mostly call
overheads), a sixth of the whole model's time with the seed's 250 droplets per cycle.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import njit

from erosim.hydrology.counter_rng import unit
from erosim.hydrology.params import VegetationParams
from erosim.hydrology.pools import HALO, OUTSIDE


@functools.lru_cache(maxsize=8)
def disc_offsets(radius_cells: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Offsets (dy, dx) (int64, read-only) of the cells within ``radius_cells`` and the weight
    1/count of each."""
    r = max(0.0, float(radius_cells))
    k = int(np.floor(r))
    yy, xx = np.mgrid[-k : k + 1, -k : k + 1]
    inside = (xx**2 + yy**2) <= r * r + 1e-9
    dy = yy[inside].ravel().astype(np.int64)
    dx = xx[inside].ravel().astype(np.int64)
    dy.flags.writeable = False
    dx.flags.writeable = False
    return dy, dx, 1.0 / int(inside.sum())


@njit(cache=True, inline="always")
def _wet_at(c, zf, lake_of, level, sea_level):
    """Under a lake or the sea, or outside the world (a nodata cell, a tile's halo): no tree there."""
    k = lake_of[c]
    return (k >= 0 and level[k] > zf[c]) or zf[c] < sea_level or k == OUTSIDE or k == HALO


@njit(cache=True, inline="always")
def _cover_add(cf, nx, ny, iy, ix, dy, dx, w):
    for k in range(dy.shape[0]):
        ty = iy + dy[k]
        tx = ix + dx[k]
        if ty >= 0 and ty < ny and tx >= 0 and tx < nx:
            cf[ty * nx + tx] += w


@njit(cache=True)
def _gap(p, st):
    """Failures before the next success of Bernoulli(p) trials: ⌊ln u / ln(1 − p)⌋ (geometric);
    a huge gap for p = 0, 0 for p = 1."""
    if p <= 0.0:
        return 1 << 62, st
    if p >= 1.0:
        return 0, st
    u, st = unit(st)
    g = math.floor(math.log(1.0 - u) / math.log1p(-p))
    return (int(g) if g < 4.0e18 else 1 << 62), st


@njit(cache=True)
def _grow(
    trees,
    cover,
    z,
    cell_size,
    lake_of,
    level,
    sea_level,
    stream,
    dy,
    dx,
    w,
    r,
    spread,
    death,
    max_stream,
    min_normal_z,
    strength,
    n_new,
    key,
    alive,
):
    """The vegetation step on flat views (see module docstring); ``alive`` is scratch (map size)."""
    ny, nx = trees.shape
    tf = trees.reshape(-1)
    cf = cover.reshape(-1)
    zf = z.reshape(-1)
    sf = stream.reshape(-1)
    st = key
    # Bernoulli(p) per tree drawn as geometric gaps between successes (the same distribution,
    # one draw per success instead of one per tree)
    gap_d, st = _gap(death, st)
    na = 0
    for c in range(nx * ny):
        if tf[c] == 0:
            continue
        dies = gap_d == 0
        gap_d -= 1
        if dies:
            gap_d, st = _gap(death, st)
        if dies or _wet_at(c, zf, lake_of, level, sea_level) or sf[c] > max_stream:
            tf[c] = 0
            _cover_add(cf, nx, ny, c // nx, c % nx, dy, dx, -w)
        else:
            alive[na] = c
            na += 1
    side = 2 * r + 1
    k, st = _gap(spread, st)  # index of the next surviving tree that seeds
    ns = 0
    while True:
        if k < na:
            c = alive[k]
            gap_s, st = _gap(spread, st)
            k += 1 + gap_s
            u, st = unit(st)
            ty = c // nx + int(u * side) - r
            u, st = unit(st)
            tx = c % nx + int(u * side) - r
            if ty < 0 or ty >= ny or tx < 0 or tx >= nx:
                continue
        elif ns < n_new:  # then the seedlings
            ns += 1
            u, st = unit(st)
            ty = min(int(u * ny), ny - 1)
            u, st = unit(st)
            tx = min(int(u * nx), nx - 1)
        else:
            break
        u, st = unit(st)
        t = ty * nx + tx
        if tf[t] != 0 or _wet_at(t, zf, lake_of, level, sea_level) or sf[t] >= max_stream:
            continue
        xa = max(tx - 1, 0)
        xb = min(tx + 1, nx - 1)
        ya = max(ty - 1, 0)
        yb = min(ty + 1, ny - 1)
        gx = (z[ty, xb] - z[ty, xa]) / (max(xb - xa, 1) * cell_size)
        gy = (z[yb, tx] - z[ya, tx]) / (max(yb - ya, 1) * cell_size)
        if 1.0 / math.sqrt(1.0 + gx * gx + gy * gy) < min_normal_z:
            continue
        if u <= min(1.0, strength * cf[t]):
            continue
        tf[t] = 1
        _cover_add(cf, nx, ny, ty, tx, dy, dx, w)


def step(
    trees: np.ndarray,
    cover: np.ndarray,
    z: np.ndarray,
    cell_size: float,
    ell: float,
    lake_of: np.ndarray,
    level: np.ndarray,
    sea_level: float,
    stream: np.ndarray,
    p: VegetationParams,
    rng: np.random.Generator,
    scratch: np.ndarray | None = None,
) -> None:
    """One vegetation cycle; updates ``trees`` (uint8) and ``cover`` (float64) in place.

    ``scratch``: an int64 work array of the map's size (allocated when not given)."""
    ny, nx = trees.shape
    dy, dx, w = disc_offsets(float(p.root_radius * ell / cell_size))
    r = max(1, int(round(p.spread_radius * ell / cell_size)))
    n_new = int(rng.poisson(p.spawn * ny * nx * cell_size**2 / (256.0 * ell) ** 2))
    key = np.uint64(rng.integers(0, 2**63))
    if scratch is None:
        scratch = np.empty(ny * nx, np.int64)
    _grow(
        trees,
        cover,
        z,
        float(cell_size),
        lake_of,
        level,
        float(sea_level),
        stream,
        dy,
        dx,
        float(w),
        r,
        float(p.spread),
        float(p.death),
        float(p.max_stream),
        float(p.min_normal_z),
        float(p.root_strength),
        n_new,
        key,
        scratch,
    )


def root_density(cover: np.ndarray, p: VegetationParams, water: np.ndarray | None = None) -> np.ndarray:
    """ρ_r = min(1, strength·cover), zero on water when ``water`` is given (the output map)."""
    rho = np.clip(p.root_strength * cover, 0.0, 1.0)
    if water is not None:
        rho[water] = 0.0
    return rho
