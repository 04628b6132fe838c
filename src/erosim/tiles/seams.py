"""Seam figures of a mosaic, read strip by strip (memory: a strip the map's length by two cells, and
a sample of a tile's differences).

* **Height jump across borders**: |z(b) − z(b − 1)| for every pair of cells on the two sides of an
  interior tile border b (rows and columns), its maximum and 99.9th percentile, against the 99.9th
  percentile of the same neighbour differences inside the tiles' cores (pairs that cross no border;
  up to :data:`SAMPLE` pairs per tile, drawn with a fixed seed).
* **River continuity**: river cells are stream ≥ :data:`erosim.analysis.terrain_metrics.RIVER_STREAM`
  (0.2, the river threshold of the hydrology metrics); of the river cells in the last row/column
  before a border (either side), the share with a river cell among the three cells facing it across;
  and the same share of those river cells whose steepest way down (the lowest of their 8 neighbours, on
  the mosaic's heights, if lower than the cell) is one of the three cells across: rivers that flow
  across the border, not along it or away from it (a river that runs beside a border, or rises at
  it, has no river across it in an untiled run either).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from erosim.analysis.terrain_metrics import RIVER_STREAM
from erosim.tiles.plan import Tile, borders
from erosim.tiles.rasters import read_window

SAMPLE = 200_000


def _strips(path: Path, tiles: list[Tile], shape: tuple[int, int]):
    """(a, b): the cells on the two sides of every interior border, as pairs of 1-D arrays."""
    ny, nx = shape
    rows, cols = borders(tiles)
    for b in cols:
        s = read_window(path, (0, ny, b - 1, b + 1))
        yield s[:, 0], s[:, 1]
    for b in rows:
        s = read_window(path, (b - 1, b + 1, 0, nx))
        yield s[0], s[1]


def _continuing(a: np.ndarray, b: np.ndarray) -> tuple[int, int]:
    """(river cells of ``a`` and ``b``, those with a river cell among the three facing it across)."""
    ra, rb = a >= RIVER_STREAM, b >= RIVER_STREAM

    def facing(x):
        y = x.copy()
        y[1:] |= x[:-1]
        y[:-1] |= x[1:]
        return y

    return int(ra.sum() + rb.sum()), int((ra & facing(rb)).sum() + (rb & facing(ra)).sum())


def _wide_strips(path: Path, tiles: list[Tile], shape: tuple[int, int]):
    """Four cells across every interior border (b − 2 … b + 1), as (length, 4) arrays, columns first."""
    ny, nx = shape
    rows, cols = borders(tiles)
    for b in cols:
        yield _pad(read_window(path, (0, ny, max(b - 2, 0), min(b + 2, nx))), b - 2, nx)
    for b in rows:
        yield _pad(read_window(path, (max(b - 2, 0), min(b + 2, ny), 0, nx)).T, b - 2, ny)


def _pad(a: np.ndarray, start: int, length: int) -> np.ndarray:
    """``a`` (length, ≤ 4) as (length, 4), NaN where the strip runs off the map."""
    out = np.full((a.shape[0], 4), np.nan)
    lo = max(-start, 0)
    out[:, lo : lo + a.shape[1]] = a
    return out


def _crossing(z: np.ndarray, s: np.ndarray) -> tuple[int, int]:
    """(river cells next to the border whose steepest way down (of their 8 neighbours) crosses it, those
    with a river cell among the three facing them across). ``z``, ``s``: (length, 4) strips, the border
    between columns 1 and 2."""
    river = s >= RIVER_STREAM
    n = z.shape[0]
    total = kept = 0
    for side, other in ((1, 2), (2, 1)):
        own = 2 * side - 1  # the column behind the cell, on its own side: 0 or 3
        best = np.full(n, np.inf)
        across = np.zeros(n, bool)
        for col, is_across in ((own, False), (side, False), (other, True)):
            for d in (-1, 0, 1):
                if col == side and d == 0:
                    continue
                nb = np.full(n, np.nan)
                lo, hi = max(d, 0), n + min(d, 0)
                nb[lo - d : hi - d] = z[lo:hi, col]
                lower = np.nan_to_num(nb, nan=np.inf) < best
                best = np.where(lower, nb, best)
                across = np.where(lower, is_across, across)
        crossing = river[:, side] & across & (best < z[:, side])
        facing = river[:, other].copy()
        facing[1:] |= river[:-1, other]
        facing[:-1] |= river[1:, other]
        total += int(crossing.sum())
        kept += int((crossing & facing).sum())
    return total, kept


def figures(height: Path, stream: Path, tiles: list[Tile], shape: tuple[int, int]) -> dict:
    """The seam figures of a mosaic (see the module docstring)."""
    jumps = [np.abs(a - b) for a, b in _strips(height, tiles, shape)]
    jumps = np.concatenate(jumps) if jumps else np.empty(0)
    jumps = jumps[np.isfinite(jumps)]
    rng = np.random.default_rng(0)
    inside = []
    for t in tiles:
        z = read_window(height, t.core)
        d = np.concatenate([np.abs(np.diff(z, axis=0)).ravel(), np.abs(np.diff(z, axis=1)).ravel()])
        d = d[np.isfinite(d)]
        inside.append(d if d.size <= SAMPLE else rng.choice(d, SAMPLE, replace=False))
    inside = np.concatenate(inside)
    touching = continuing = 0
    for a, b in _strips(stream, tiles, shape):
        n, k = _continuing(np.nan_to_num(a), np.nan_to_num(b))
        touching, continuing = touching + n, continuing + k
    crossing = crossing_kept = 0
    for z, st in zip(_wide_strips(height, tiles, shape), _wide_strips(stream, tiles, shape), strict=True):
        n, k = _crossing(z, np.nan_to_num(st))
        crossing, crossing_kept = crossing + n, crossing_kept + k
    p999_in = float(np.quantile(inside, 0.999)) if inside.size else None
    return {
        "border_pairs": int(jumps.size),
        "border_jump_max_m": float(jumps.max()) if jumps.size else None,
        "border_jump_p999_m": float(np.quantile(jumps, 0.999)) if jumps.size else None,
        "inside_p999_m": p999_in,
        "inside_max_m": float(inside.max()) if inside.size else None,
        "border_jump_max_over_inside_p999": (float(jumps.max()) / p999_in if jumps.size and p999_in else None),
        "river_threshold": RIVER_STREAM,
        "river_cells_at_borders": touching,
        "river_cells_continuing": continuing,
        "river_continuity": continuing / touching if touching else None,
        "river_cells_flowing_across": crossing,
        "river_cells_flowing_across_continuing": crossing_kept,
        "river_continuity_flowing_across": crossing_kept / crossing if crossing else None,
    }
