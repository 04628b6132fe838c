"""HY-5 vegetation: trees that hold the soil (SimpleHydrology 2020, ``World::grow``).

Once per cycle, with the seed's rules in physical units (ℓ = the seed's cell):

* seedlings appear at random cells (``spawn`` per (256 ℓ)² of map area);
* each tree seeds a neighbour within ``spread_radius``·ℓ with chance ``spread`` (seed 1/50);
* a tree takes root only on dry land (no lake, not below the sea), where stream < ``max_stream``
  (0.2), the surface is not steep (unit normal's z ≥ 0.8) and a random draw exceeds the local
  root density;
* trees die in lakes, in strong streams (> 0.2), or at random (``death``, seed 1/1000).

Root density ρ_r = min(1, strength · (tree cover within ``root_radius``·ℓ)), zero on water; the
droplets scale their erosion and deposition by max(0, 1 − ρ_r) (roots hold the soil). Trees are
one per cell; the cover is the share of cells with a tree in the disc, so a forest's density does
not depend on the grid. Vectorised NumPy/SciPy (no per-tree Python loop).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from erosim.hydrology.params import VegetationParams


def disc(radius_cells: float) -> np.ndarray:
    """Normalised disc kernel of the given radius in cells (at least the centre cell)."""
    r = max(0.0, float(radius_cells))
    k = int(np.floor(r))
    yy, xx = np.mgrid[-k : k + 1, -k : k + 1]
    w = ((xx**2 + yy**2) <= r * r + 1e-9).astype(float)
    return w / w.sum()


def allowed(z: np.ndarray, cell_size: float, depth: np.ndarray, stream: np.ndarray,
            sea: np.ndarray, p: VegetationParams) -> np.ndarray:
    """Where a tree may stand: dry, not in a strong stream, not steep."""
    gy, gx = np.gradient(z, cell_size)
    nz = 1.0 / np.sqrt(1.0 + gx * gx + gy * gy)
    return (depth <= 0.0) & ~sea & (stream < p.max_stream) & (nz >= p.min_normal_z)


def step(trees: np.ndarray, roots: np.ndarray, z: np.ndarray, cell_size: float, ell: float,
         depth: np.ndarray, stream: np.ndarray, sea: np.ndarray, p: VegetationParams,
         rng: np.random.Generator) -> None:
    """One vegetation cycle; updates ``trees`` (uint8) and ``roots`` (float64) in place."""
    ny, nx = trees.shape
    ok = allowed(z, cell_size, depth, stream, sea, p)
    water = (depth > 0.0) | sea
    # death: in water, in a strong stream, or at random
    alive = trees.astype(bool)
    dead = alive & (water | (stream > p.max_stream) | (rng.random(trees.shape) < p.death))
    alive &= ~dead
    # spreading to a neighbour
    iy, ix = np.nonzero(alive)
    go = rng.random(iy.size) < p.spread
    r = max(1, int(round(p.spread_radius * ell / cell_size)))
    ty = iy[go] + rng.integers(-r, r + 1, size=int(go.sum()))
    tx = ix[go] + rng.integers(-r, r + 1, size=int(go.sum()))
    # random seedlings
    area_units = ny * nx * cell_size**2 / (256.0 * ell) ** 2
    n_new = rng.poisson(p.spawn * area_units)
    sy = rng.integers(0, ny, size=n_new)
    sx = rng.integers(0, nx, size=n_new)
    ty = np.concatenate([ty, sy])
    tx = np.concatenate([tx, sx])
    inside = (ty >= 0) & (ty < ny) & (tx >= 0) & (tx < nx)
    ty, tx = ty[inside], tx[inside]
    draw = rng.random(ty.size)
    take = ok[ty, tx] & (draw > roots[ty, tx])
    alive[ty[take], tx[take]] = True
    trees[...] = alive
    cover = ndimage.convolve(alive.astype(float), disc(p.root_radius * ell / cell_size), mode="constant")
    np.minimum(p.root_strength * cover, 1.0, out=roots)
    roots[water] = 0.0
