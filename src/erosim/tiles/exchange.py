"""Droplets that cross a tile border: recorded where they leave one tile, injected into its neighbour.

In a tiled build (:mod:`erosim.tiles.build`) every tile is a hydrology run over its window (core +
halo) in which the halo is outside the world: rain falls on the core only, and a droplet that steps
into a halo cell leaves the tile there (HY-1's "left the map", :mod:`erosim.hydrology.droplets`). The
tile records it — the cycle, its position (the halo cell it stepped into, in map coordinates), its
velocity, water volume V and sediment S (its ``B_LEFT`` and ``B_CARRIED`` terms, the volumes it took
out of the tile's budget) — in ``exits.npy``. Before the next round, the build hands every recorded
droplet to the tile whose core holds its cell (:func:`route`); that tile injects it, in the same cycle
of its round, as a droplet that goes on descending from that position with that velocity, water and
sediment (:meth:`erosim.hydrology.model.HydrologyModel.attach_exchange`). The halo's heights are the
neighbour's (the last round's mosaic), so a droplet's gradient at the border is the map's.

Budgets per tile: rained + entered = in lakes + evaporated + left (left includes what passed to the
neighbours); eroded + entered sediment = deposited + carried off. What a tile passes on in round k
enters the neighbour in round k + 1: water crossing B borders needs B + 1 rounds to reach its last
tile (docs/tiles.md). Water that a lake drains into the halo (:func:`erosim.hydrology.pools.flood`
draining at an outside cell) is passed on too, from the lowest halo cell next to the lake, with no
velocity and 10 % of the droplet's sediment (:meth:`TileExchange.record_floods`,
:func:`erosim.hydrology.model.batch_floods`).

What the droplet step exposes (and must keep exposing): after a batch's parallel descent, for each
droplet i, ``res[i, R_STATUS] == LEFT`` when it left; then ``res[i, R_X], res[i, R_Y]`` is the cell it
stepped into (an outside cell: the halo) or, where it left over the window's edge, its last position
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
    cycle). ``flow``: water and sediment entered, water and sediment passed on (m³)."""

    def __init__(self, core, origin, inflow: np.ndarray | None = None):
        self.core = tuple(int(v) for v in core)
        self.origin = (int(origin[0]), int(origin[1]))
        self.inflow = np.zeros((0, len(COLUMNS))) if inflow is None else np.asarray(inflow, np.float64)
        self._exits: list[np.ndarray] = []
        self.flow = np.zeros(4)
        self._ring = self._outlet = self._outlet_z = np.zeros(0, np.int64)
        self._nx = 1

    def incoming(self, cycle: int) -> np.ndarray:
        """The droplets that enter in ``cycle`` (of this run), in their recorded order."""
        c = self.inflow[:, 0]
        a, b = np.searchsorted(c, cycle, "left"), np.searchsorted(c, cycle, "right")
        return self.inflow[a:b]

    def entered(self, rows: np.ndarray) -> None:
        self.flow[0] += rows[:, 5].sum()
        self.flow[1] += rows[:, 6].sum()

    def prepare(self, z: np.ndarray) -> None:
        """The core's ring (its cells with a halo cell among their 8 neighbours) and, for each, its lowest
        halo neighbour: where a lake on the ring drains into the halo (:meth:`record_floods`)."""
        ny, nx = z.shape
        r0, r1, c0, c1 = self.core
        inside = np.zeros((ny, nx), bool)
        inside[r0:r1, c0:c1] = True
        best = np.full((ny, nx), np.inf)
        where = np.full((ny, nx), -1, np.int64)
        idx = np.arange(ny * nx).reshape(ny, nx)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                if dy == 0 and dx == 0:
                    continue
                # neighbour (j + dy, i + dx) of cell (j, i), both within the window
                js, jd = slice(max(dy, 0), ny + min(dy, 0)), slice(max(-dy, 0), ny - max(dy, 0))
                is_, id_ = slice(max(dx, 0), nx + min(dx, 0)), slice(max(-dx, 0), nx - max(dx, 0))
                zn, out_n, cell_n = z[js, is_], ~inside[js, is_], idx[js, is_]
                take = out_n & (zn < best[jd, id_])
                best[jd, id_] = np.where(take, zn, best[jd, id_])
                where[jd, id_] = np.where(take, cell_n, where[jd, id_])
        ring = inside & (where >= 0)
        self._ring = idx[ring]
        self._outlet = where[ring]
        self._outlet_z = best[ring]
        self._nx = nx

    def record_floods(self, cycle: int, res: np.ndarray, nb: int, lake_of: np.ndarray, marked: int, done: int) -> None:
        """Droplets whose lake drained them into the halo (rows marked ``marked`` by
        :func:`erosim.hydrology.model.batch_floods`, R_X/R_Y the cell where they flooded): each leaves
        at the lowest halo neighbour of its lake's ring cells (of the ring cell nearest to it where the
        lake's label is not found on the ring), with no velocity; the rows become ``done``."""
        sel = np.flatnonzero(res[:nb, R_STATUS] == marked)
        if sel.size == 0:
            return
        res[sel, R_STATUS] = done
        if self._ring.size == 0:
            return
        nx = self._nx
        rows = []
        for i in sel:
            c = int(res[i, R_Y]) * nx + int(res[i, R_X])
            on = np.flatnonzero(lake_of[self._ring] == lake_of[c]) if lake_of[c] >= 0 else np.zeros(0, np.int64)
            if on.size:
                j = on[np.argmin(self._outlet_z[on])]
            else:
                ry, rx = self._ring // nx, self._ring % nx
                j = int(np.argmin((ry - c // nx) ** 2 + (rx - c % nx) ** 2))
            o = int(self._outlet[j])
            rows.append((float(cycle), float(o % nx), float(o // nx), 0.0, 0.0, res[i, R_V], res[i, R_S]))
        rows = np.asarray(rows)
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


def route(tiles, index: int, exits_of, cycles: int) -> np.ndarray:
    """The inflow of tile ``index``: the exits (``exits_of(tile)``, map coordinates) of the tiles whose
    windows meet its core that fall in its core, in its window's coordinates, ordered by cycle (then by
    source tile and record order: deterministic); cycles beyond this round's ``cycles`` enter in its
    last."""
    from erosim.tiles.plan import covering

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
