"""Droplets that cross a tile border: recorded where they leave one tile, injected into its neighbour.

In a tiled build (:mod:`erosim.tiles.build`) every tile is a hydrology run over its window (core +
halo) in which the halo is not the tile's (``lake_of`` = :data:`erosim.hydrology.pools.HALO`): rain
falls on the core only, nothing erodes in the halo, and a droplet that steps into a halo cell leaves the
tile there (HY-1's "left the map", :mod:`erosim.hydrology.droplet_step`). The tile records it — the
cycle, its position (the halo cell it stepped into, in map coordinates), its velocity, water volume V
and sediment S (its ``B_LEFT`` and ``B_CARRIED`` terms, the volumes it took out of the tile's budget) —
in ``exits.npy``. Before the next round, the build hands every recorded droplet to the tile whose core
holds its cell (:func:`erosim.tiles.exchange.route`); that tile injects it, in the same cycle of its
round, as a droplet that goes on descending from that position with that velocity, water and sediment
(:meth:`erosim.hydrology.model.HydrologyModel.attach_exchange`). The halo's heights are the neighbour's
(the last round's mosaic), so a droplet's gradient at the border is the map's.

Lakes at a border (HY-2, :func:`erosim.hydrology.pools.flood`): a halo cell is a boundary entry of the
lake beside it keyed by its own height, as any dry cell beyond a lake is, not a drain at −∞ as the map's
edge is, so a lake cut by a border fills to the height of its lowest halo neighbour before it spills
there; the water it spills, with the 10 % of the sediment a draining droplet keeps, is passed on from
that halo cell with no velocity (:meth:`TileExchange.record_floods`,
:func:`erosim.hydrology.model.batch_floods`), as is a droplet whose walk off a drain (or down a pit)
steps into the halo.

Budgets per tile: rained + entered = in lakes + evaporated + left (left includes what passed to the
neighbours); eroded + entered sediment = deposited + carried off. What a tile passes on in round k
enters the neighbour in round k + 1: water crossing B borders needs B + 1 rounds to reach its last
tile (docs/tiles.md).

What the droplet step exposes (and must keep exposing): after a batch's parallel descent, for each
droplet i, ``res[i, R_STATUS] == LEFT`` when it left; then ``res[i, R_X], res[i, R_Y]`` is the cell it
stepped (or walked) into (a halo cell) or, where it left over the window's edge, its last position
inside; ``res[i, R_VX], res[i, R_VY]`` its velocity; ``bd[i, B_LEFT]`` and ``bd[i, B_CARRIED]`` the
water and sediment it took out. A droplet resumes descending from a row with ``R_STATUS = NEXT`` and
its x, y, vx, vy, V, S.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from erosim.core.atomic import atomic_path
from erosim.hydrology.batch import R_S, R_STATUS, R_V, R_VX, R_VY, R_X, R_Y
from erosim.hydrology.droplets import LEFT
from erosim.hydrology.pools import B_CARRIED, B_LEFT

COLUMNS = ("cycle", "x", "y", "vx", "vy", "V", "S")  # an exit / inflow row; x, y in cells (column, row)
EXITS = "exits.npy"
INFLOW = "inflow.npy"
MEMBER = "exchange.json"


class TileExchange:
    """A tile's droplet exchange: ``core`` (row0, row1, col0, col1) within its window, the window's
    ``origin`` (row, col) in the map, ``inflow`` rows (:data:`COLUMNS`, window coordinates, sorted by
    cycle). ``flow``: water and sediment entered, water and sediment passed on, and the soil that crept
    into the core across its border (m³; :meth:`erosim.hydrology.model.HydrologyModel._creep_tile`)."""

    def __init__(self, core, origin, inflow: np.ndarray | None = None):
        self.core = tuple(int(v) for v in core)
        self.origin = (int(origin[0]), int(origin[1]))
        self.inflow = np.zeros((0, len(COLUMNS))) if inflow is None else np.asarray(inflow, np.float64)
        self._exits: list[np.ndarray] = []
        self.flow = np.zeros(5)

    def incoming(self, cycle: int) -> np.ndarray:
        """The droplets that enter in ``cycle`` (of this run), in their recorded order."""
        c = self.inflow[:, 0]
        a, b = np.searchsorted(c, cycle, "left"), np.searchsorted(c, cycle, "right")
        return self.inflow[a:b]

    def entered(self, rows: np.ndarray) -> None:
        self.flow[0] += rows[:, 5].sum()
        self.flow[1] += rows[:, 6].sum()

    def record_floods(self, cycle: int, res: np.ndarray, nb: int, marked: int, done: int) -> None:
        """Droplets that a lake drained into the halo, or whose walk off a drain stepped into it (rows
        marked ``marked`` by :func:`erosim.hydrology.model.batch_floods`: R_X/R_Y the halo cell, R_V/R_S
        the water and sediment taken there): each leaves from that cell with no velocity; the rows
        become ``done``."""
        sel = np.flatnonzero(res[:nb, R_STATUS] == marked)
        if sel.size == 0:
            return
        res[sel, R_STATUS] = done
        rows = np.column_stack([np.full(sel.size, float(cycle)), res[sel, R_X], res[sel, R_Y], np.zeros(sel.size),
                                np.zeros(sel.size), res[sel, R_V], res[sel, R_S]])  # fmt: skip
        self.flow[2] += rows[:, 5].sum()
        self.flow[3] += rows[:, 6].sum()
        self._exits.append(rows)

    def record(self, cycle: int, res: np.ndarray, bd: np.ndarray, nb: int) -> None:
        """The droplets of a batch's descent that left into the halo (see the module docstring)."""
        sel = np.flatnonzero(res[:nb, R_STATUS] == LEFT)
        if sel.size == 0:
            return
        x, y = res[sel, R_X], res[sel, R_Y]
        col, row = np.floor(x + 0.5), np.floor(y + 0.5)
        r0, r1, c0, c1 = self.core
        out = (row < r0) | (row >= r1) | (col < c0) | (col >= c1)  # in the halo, not over the map's edge
        sel, x, y = sel[out], x[out], y[out]
        if sel.size == 0:
            return
        rows = np.column_stack([np.full(sel.size, float(cycle)), x, y, res[sel, R_VX], res[sel, R_VY],
                                bd[sel, B_LEFT], bd[sel, B_CARRIED]])  # fmt: skip
        self.flow[2] += rows[:, 5].sum()
        self.flow[3] += rows[:, 6].sum()
        self._exits.append(rows)

    def exits(self) -> np.ndarray:
        """Every recorded exit, in map coordinates."""
        rows = np.concatenate(self._exits) if self._exits else np.zeros((0, len(COLUMNS)))
        rows = rows.copy()
        rows[:, 1] += self.origin[1]
        rows[:, 2] += self.origin[0]
        return rows

    def state_dict(self) -> dict:
        rows = np.concatenate(self._exits) if self._exits else np.zeros((0, len(COLUMNS)))
        return {"tile_exits": rows, "tile_flow": self.flow.copy()}

    def load_state_dict(self, st: dict) -> None:
        self._exits = [np.asarray(st["tile_exits"], np.float64).reshape(-1, len(COLUMNS))]
        self.flow[...] = st["tile_flow"]


def write_member(tdir: Path, tile, inflow: np.ndarray, stream: str | None) -> Path:
    """A tile's exchange file (``exchange.json``, written last and atomically: a tile folder with one
    has all its inputs) and its inflow (``inflow.npy``, window coordinates)."""
    with atomic_path(tdir / INFLOW) as tmp, open(tmp, "wb") as f:
        np.save(f, inflow)
    wr0, _, wc0, _ = tile.window
    r0, r1, c0, c1 = tile.core
    doc = {"core": [r0 - wr0, r1 - wr0, c0 - wc0, c1 - wc0], "origin": [wr0, wc0], "inflow": INFLOW,
           "stream": stream}  # fmt: skip
    path = tdir / MEMBER
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(doc), encoding="utf-8")
    return path


def read_stream(path: Path) -> np.ndarray:
    """The stream map a tile starts from (``stream_in.tif``, its whole window), nodata as 0, in [0, 1]."""
    import rasterio

    with rasterio.open(path) as ds:
        band = ds.read(1, masked=True)
    s = np.ma.getdata(band).astype(np.float64)
    s[np.ma.getmaskarray(band)] = 0.0
    return np.clip(np.nan_to_num(s), 0.0, 1.0)


def load_member(path: str | Path) -> tuple[TileExchange, Path | None]:
    """The exchange of a tile run (``tiles.member``) and the stream map it starts from (or None)."""
    path = Path(path)
    doc = json.loads(path.read_text(encoding="utf-8"))
    inflow = np.load(path.parent / doc["inflow"])
    stream = path.parent / doc["stream"] if doc.get("stream") else None
    return TileExchange(doc["core"], doc["origin"], inflow), stream


def write_exits(folder: Path, exchange: TileExchange) -> None:
    with atomic_path(folder / EXITS) as tmp, open(tmp, "wb") as f:
        np.save(f, exchange.exits())
