"""The tiles' side of the droplet exchange (:mod:`erosim.hydrology.tile_exchange`, which a tile's run
uses and which holds the exchange itself): :func:`route` hands the droplets that left the tiles in one
round to the tiles whose cores they entered, for the next."""

from __future__ import annotations

import numpy as np

from erosim.hydrology.tile_exchange import (  # noqa: F401  (the build's names for the exchange's files)
    COLUMNS,
    EXITS,
    INFLOW,
    MEMBER,
    TileExchange,
    load_member,
    write_exits,
    write_member,
)
from erosim.tiles.plan import covering


def route(tiles, index: int, exits_of, cycles: int) -> np.ndarray:
    """The inflow of tile ``index``: the exits (``exits_of(tile)``, map coordinates) of the tiles whose
    windows meet its core that fall in its core, in its window's coordinates, ordered by cycle (then by
    source tile and record order: deterministic); cycles beyond this round's ``cycles`` enter in its
    last."""
    t = tiles[index]
    r0, r1, c0, c1 = t.core
    parts = []
    for s, _ in covering(tiles, t.core):
        if s == t:
            continue
        e = exits_of(s)
        if e.shape[0] == 0:
            continue
        row, col = np.floor(e[:, 2] + 0.5), np.floor(e[:, 1] + 0.5)
        e = e[(row >= r0) & (row < r1) & (col >= c0) & (col < c1)].copy()
        e[:, 1] -= t.window[2]
        e[:, 2] -= t.window[0]
        parts.append(e)
    rows = np.concatenate(parts) if parts else np.zeros((0, len(COLUMNS)))
    rows[:, 0] = np.minimum(rows[:, 0], cycles - 1)
    return rows[np.argsort(rows[:, 0], kind="stable")]
