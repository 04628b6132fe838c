"""The tiles of a tiled build: cores that partition the map, windows with a halo, blending weights.

Pure functions of the map's shape (no file is read). Along each axis a map of ``L`` cells is cut into
``n = ⌈L / size⌉`` cores as even as whole cells allow (boundaries ``round(i·L/n)``), so every core
holds between ``size/2`` and ``size`` cells; a tile's window is its core grown by ``overlap`` cells
on every side that is not the map's edge. With ``overlap ≤ size/2`` a halo reaches only into the
neighbouring cores, so every cell is covered by at most two tiles per axis.

Blending (:func:`weights`; the first version's mosaics, kept for :func:`erosim.tiles.rasters.blend` —
the build now takes each tile's core): along an axis, a tile's weight rises linearly from 0 at the outer edge of
its halo to 1 at ``2·overlap`` cells inside it, w(d) = min(1, d / (2K)) with d the distance of a
cell's centre from the halo's outer edge; on a side at the map's edge it is 1. Across a border at
``b`` the two tiles' windows overlap on [b − K, b + K) and their weights w_A = (b + K − x)/(2K),
w_B = (x − b + K)/(2K) sum to 1 at every cell centre x: a feathered (linear) blend. The 2-D weight is
the product of the two axes' weights, so at a corner the four tiles' weights sum to 1 as well.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from erosim.core.errors import ConfigError


@dataclass(frozen=True)
class Tile:
    """Tile (``row``, ``col``) of the plan: its ``core`` and its ``window`` (core + halo), each as
    half-open cell ranges (row0, row1, col0, col1) of the whole map."""

    row: int
    col: int
    core: tuple[int, int, int, int]
    window: tuple[int, int, int, int]

    @property
    def name(self) -> str:
        return f"r{self.row}_c{self.col}"

    @property
    def shape(self) -> tuple[int, int]:
        r0, r1, c0, c1 = self.window
        return r1 - r0, c1 - c0

    def as_dict(self) -> dict:
        return {"name": self.name, **asdict(self)}


def check(shape: tuple[int, int], size: int, overlap: int) -> None:
    """One sentence when ``size`` and ``overlap`` cannot tile a map of ``shape``."""
    if size < 16 or overlap < 0 or 2 * overlap > size:
        raise ConfigError(
            f"Tiles of {size} cells with an overlap of {overlap} are not valid; give a size of at least 16 cells "
            "and an overlap between 0 and half the size."
        )
    if min(shape) < 2:
        raise ConfigError(f"A map of {shape[0]} × {shape[1]} cells cannot be tiled; it needs at least 2 cells a side.")


def bounds(length: int, size: int) -> list[int]:
    """Core boundaries along an axis of ``length`` cells: ``n + 1`` numbers from 0 to ``length``,
    ``n = ⌈length / size⌉``, the cores as even as whole cells allow."""
    n = max(1, math.ceil(length / size))
    return [round(i * length / n) for i in range(n + 1)]


def plan(shape: tuple[int, int], size: int, overlap: int) -> list[Tile]:
    """The tiles of a map of ``shape`` (rows, cols), row by row from the north-west corner."""
    check(shape, size, overlap)
    ny, nx = shape
    rb, cb = bounds(ny, size), bounds(nx, size)
    tiles = []
    for i in range(len(rb) - 1):
        for j in range(len(cb) - 1):
            core = (rb[i], rb[i + 1], cb[j], cb[j + 1])
            window = (max(0, rb[i] - overlap), min(ny, rb[i + 1] + overlap),
                      max(0, cb[j] - overlap), min(nx, cb[j + 1] + overlap))  # fmt: skip
            tiles.append(Tile(i, j, core, window))
    return tiles


def ramp(n: int, low_halo: int, high_halo: int, overlap: int) -> np.ndarray:
    """One axis's blending weights over a window of ``n`` cells with halos of ``low_halo`` and
    ``high_halo`` cells (0 on a side at the map's edge): min(1, d / (2K)) from each side with a halo."""
    w = np.ones(n)
    if overlap == 0:
        return w
    d = np.arange(n) + 0.5
    if low_halo:
        w = np.minimum(w, d / (2 * overlap))
    if high_halo:
        w = np.minimum(w, d[::-1] / (2 * overlap))
    return w


def weights(tile: Tile, overlap: int) -> np.ndarray:
    """The tile's blending weights over its window (rows, cols): the product of the axes' ramps."""
    r0, r1, c0, c1 = tile.window
    cr0, cr1, cc0, cc1 = tile.core
    wy = ramp(r1 - r0, cr0 - r0, r1 - cr1, overlap)
    wx = ramp(c1 - c0, cc0 - c0, c1 - cc1, overlap)
    return np.outer(wy, wx)


def intersect(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> tuple[int, int, int, int] | None:
    """The intersection of two cell rectangles (row0, row1, col0, col1), or None."""
    r0, r1, c0, c1 = max(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), min(a[3], b[3])
    return (r0, r1, c0, c1) if r0 < r1 and c0 < c1 else None


def covering(tiles: list[Tile], rect: tuple[int, int, int, int]) -> list[tuple[Tile, tuple[int, int, int, int]]]:
    """The tiles whose window meets ``rect``, each with the part of ``rect`` it covers."""
    out = []
    for t in tiles:
        part = intersect(t.window, rect)
        if part is not None:
            out.append((t, part))
    return out


def borders(tiles: list[Tile]) -> tuple[list[int], list[int]]:
    """The interior core boundaries: (rows where a row of tiles meets the next, columns likewise)."""
    rows = sorted({t.core[0] for t in tiles} - {0})
    cols = sorted({t.core[2] for t in tiles} - {0})
    return rows, cols


def cycles_per_round(cycles: int, rounds: int) -> list[int]:
    """``cycles`` split over ``rounds`` passes as evenly as whole cycles allow (the first ones longer)."""
    if rounds < 1 or rounds > cycles:
        raise ConfigError(f"{rounds} rounds cannot split {cycles} cycles; give between 1 and {cycles} rounds.")
    return [cycles // rounds + (1 if k < cycles % rounds else 0) for k in range(rounds)]
