"""HY-5 vegetation: trees that hold the soil (SimpleHydrology 2020, ``World::grow``).

Once per cycle, with the seed's rules in physical units (ℓ = the seed's cell):

* seedlings appear at random cells (``spawn`` per (256 ℓ)² of map area per cycle);
* each tree seeds a cell within ``spread_radius``·ℓ with chance ``spread`` (seed 1/50);
* a tree takes root only on dry land (no lake, not below the sea), where stream < ``max_stream``
  (0.2), the surface is not steep (unit normal's z ≥ 0.8) and a random draw exceeds the local
  root density;
* trees die in lakes, in strong streams (> 0.2), or at random (``death``, seed 1/1000).

Root density ρ_r = min(1, strength · cover), cover = share of cells within ``root_radius``·ℓ that
hold a tree (one tree per cell at most, so a forest's density does not depend on the grid). The
droplets scale their erosion and deposition by max(0, 1 − ρ_r) (roots hold the soil). ``cover`` is
updated incrementally where trees are born or die, so a cycle costs O(trees), not O(map).
"""

from __future__ import annotations

import numpy as np

from erosim.hydrology.params import VegetationParams


def disc_offsets(radius_cells: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Offsets (dy, dx) of the cells within ``radius_cells`` and the weight 1/count of each."""
    r = max(0.0, float(radius_cells))
    k = int(np.floor(r))
    yy, xx = np.mgrid[-k : k + 1, -k : k + 1]
    inside = (xx**2 + yy**2) <= r * r + 1e-9
    return yy[inside].ravel(), xx[inside].ravel(), 1.0 / int(inside.sum())


def _normal_z(z: np.ndarray, iy: np.ndarray, ix: np.ndarray, cell_size: float) -> np.ndarray:
    ny, nx = z.shape
    xa, xb = np.maximum(ix - 1, 0), np.minimum(ix + 1, nx - 1)
    ya, yb = np.maximum(iy - 1, 0), np.minimum(iy + 1, ny - 1)
    gx = (z[iy, xb] - z[iy, xa]) / (np.maximum(xb - xa, 1) * cell_size)
    gy = (z[yb, ix] - z[ya, ix]) / (np.maximum(yb - ya, 1) * cell_size)
    return 1.0 / np.sqrt(1.0 + gx * gx + gy * gy)


def _wet(iy, ix, z, lake_of, level, sea_level):
    lk = lake_of.reshape(z.shape)[iy, ix]
    wet = np.zeros(iy.shape, bool)
    m = lk >= 0
    wet[m] = level[lk[m]] > z[iy[m], ix[m]]
    return wet | (z[iy, ix] < sea_level)


def _add_cover(cover, iy, ix, offsets, sign):
    dy, dx, w = offsets
    ny, nx = cover.shape
    for oy, ox in zip(dy, dx, strict=True):
        ty, tx = iy + oy, ix + ox
        ok = (ty >= 0) & (ty < ny) & (tx >= 0) & (tx < nx)
        np.add.at(cover, (ty[ok], tx[ok]), sign * w)


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
) -> None:
    """One vegetation cycle; updates ``trees`` (uint8) and ``cover`` (float64) in place."""
    ny, nx = trees.shape
    offsets = disc_offsets(p.root_radius * ell / cell_size)
    flat = np.flatnonzero(trees)
    iy, ix = np.divmod(flat, nx)
    # death: in water, in a strong stream, or at random
    dead = (
        _wet(iy, ix, z, lake_of, level, sea_level)
        | (stream[iy, ix] > p.max_stream)
        | (rng.random(flat.size) < p.death)
    )
    if dead.any():
        trees[iy[dead], ix[dead]] = 0
        _add_cover(cover, iy[dead], ix[dead], offsets, -1.0)
    iy, ix = iy[~dead], ix[~dead]
    # candidates: neighbours seeded by living trees, and random seedlings
    go = rng.random(iy.size) < p.spread
    r = max(1, int(round(p.spread_radius * ell / cell_size)))
    ng = int(go.sum())
    ty = iy[go] + rng.integers(-r, r + 1, size=ng)
    tx = ix[go] + rng.integers(-r, r + 1, size=ng)
    n_new = rng.poisson(p.spawn * ny * nx * cell_size**2 / (256.0 * ell) ** 2)
    ty = np.concatenate([ty, rng.integers(0, ny, size=n_new)])
    tx = np.concatenate([tx, rng.integers(0, nx, size=n_new)])
    draw = rng.random(ty.size)
    inside = (ty >= 0) & (ty < ny) & (tx >= 0) & (tx < nx)
    ty, tx, draw = ty[inside], tx[inside], draw[inside]
    ok = (
        (trees[ty, tx] == 0)
        & ~_wet(ty, tx, z, lake_of, level, sea_level)
        & (stream[ty, tx] < p.max_stream)
        & (_normal_z(z, ty, tx, cell_size) >= p.min_normal_z)
        & (draw > np.minimum(1.0, p.root_strength * cover[ty, tx]))
    )
    ty, tx = ty[ok], tx[ok]
    if ty.size:
        # one tree per cell even when two candidates land on the same one
        cells = np.unique(ty * nx + tx)
        ty, tx = np.divmod(cells, nx)
        trees[ty, tx] = 1
        _add_cover(cover, ty, tx, offsets, 1.0)


def root_density(
    cover: np.ndarray, p: VegetationParams, water: np.ndarray | None = None
) -> np.ndarray:
    """ρ_r = min(1, strength·cover), zero on water when ``water`` is given (the output map)."""
    rho = np.clip(p.root_strength * cover, 0.0, 1.0)
    if water is not None:
        rho[water] = 0.0
    return rho
