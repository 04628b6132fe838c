"""A reservoir on a real DEM, the dam that holds it and the breach window cut into the dam (SPEC FL-1).

The dam-break flood (issue 9) starts from water at rest behind a dam. Its set-up is independent of the
solver that moves the water, so the shallow-water and the 3-D SPH floods share it:

* **Reservoir** (:func:`fill_reservoir`): the water surface is flat at ``level``; the reservoir is the
  4-connected set R of cells with z < level reachable from the seed cell without passing a nodata cell
  (nodata cells are walls) or a barrier cell, and its depth is

      D = level − z   in R,     D = 0 elsewhere.

  Connected components come from ``scipy.ndimage.label`` (the cross-shaped structure: 4-connected).
  R may touch a *closed* map edge (one not listed in ``open_edges``: a wall), but not an open one:
  water there would leave the map at once, which means the barrier does not close the valley.
* **Barrier** (:func:`barrier_mask`): the dam's line when the DEM has no dam in it; a polyline in map
  coordinates rasterised to every cell any of its segments passes through, plus, where a segment
  passes exactly through a cell corner, both cells beside that corner, so the barrier is
  4-connected and no water crosses it diagonally.
* **Breach** (:func:`cut_breach`): a trapezoidal window across the dam (40 m wide in the thesis). For a
  cell centre at perpendicular distance s (m) from the window's centre-line segment, within the
  segment's length,

      z ← min(z, floor + max(0, s − b/2) / m)

  with b the bottom width (m) and m the side slope (horizontal:vertical; m = 0 gives vertical walls:
  z ← min(z, floor) for s ≤ b/2 only). Cells are never raised and cells beyond the segment's ends are
  untouched; nodata cells stay nodata (their filler heights follow their nearest data cell, as in
  every :class:`~erosim.core.heightmap.Heightmap`).

Coordinates are the DEM's own (its transform; a generated map without one uses
:func:`erosim.core.heightmap.default_transform`). Distances are measured in cells times the map's cell
size (m), so they are metres on a projected DEM and the equal-area approximation on a geographic one.
Map edges are named by the heightmap's storage order: row 0 is the north edge, the last row the south
edge, column 0 the west edge and the last column the east edge.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import field_validator
from scipy import ndimage

from erosim.core.config import Section, param
from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap, cell_of, fractional_cell, on_grid, xy_of

__all__ = ["EDGES", "Breach", "barrier_mask", "cell_of", "cut_breach", "fill_reservoir", "xy_of"]

EDGES = ("north", "south", "east", "west")


def _fmt(v: float) -> str:
    return f"{v:.10g}"


def _points(polyline, what: str, at_least: int) -> np.ndarray:
    """``polyline`` as an (n, 2) float array of finite map coordinates, or one InputError sentence."""
    try:
        pts = np.asarray(polyline, dtype=np.float64)
    except (TypeError, ValueError):
        pts = np.zeros((0, 0))
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < at_least or not np.isfinite(pts).all():
        raise InputError(
            f"{what} {polyline!r} is not valid; give at least {at_least} points [[x0, y0], [x1, y1], ...] "
            "as finite numbers in the map's coordinates."
        )
    return pts


# -------------------------------------------------------------------------------------------- barrier
def _segment_cells(p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) of the cells a segment between fractional (row, col) points passes through,
    4-connected: where it passes exactly through a corner, both cells beside the corner are added."""
    d = p1 - p0
    ts = [np.array([0.0, 1.0])]
    for k in range(2):  # parameters where the segment crosses the grid's row (k=0) and column lines
        if d[k] != 0.0:
            lo, hi = sorted((p0[k], p1[k]))
            lines = np.arange(math.ceil(lo), math.floor(hi) + 1, dtype=np.float64)
            ts.append((lines - p0[k]) / d[k])
    t = np.unique(np.clip(np.concatenate(ts), 0.0, 1.0))
    mid = np.concatenate([[0.0], 0.5 * (t[1:] + t[:-1]), [1.0]]) if len(t) > 1 else t
    pts = p0[None, :] + mid[:, None] * d[None, :]
    cells = np.floor(pts).astype(np.int64)
    keep = np.ones(len(cells), bool)
    keep[1:] = np.any(cells[1:] != cells[:-1], axis=1)
    cells = cells[keep]
    diag = np.all(cells[1:] != cells[:-1], axis=1)  # a step through a corner: add both side cells
    a, b = cells[:-1][diag], cells[1:][diag]
    extra = np.concatenate([np.stack([a[:, 0], b[:, 1]], axis=1), np.stack([b[:, 0], a[:, 1]], axis=1)])
    cells = np.concatenate([cells, extra])
    return cells[:, 0], cells[:, 1]


def barrier_mask(hm: Heightmap, polyline) -> np.ndarray:
    """Boolean (ny, nx) mask of the cells the polyline ``[[x, y], ...]`` (map units) passes through,
    4-connected (see the module docstring); parts off the map are dropped."""
    pts = _points(polyline, "The barrier polyline", 2)
    rows, cols = fractional_cell(hm, pts[:, 0], pts[:, 1])
    frac = np.stack([rows, cols], axis=1)
    mask = np.zeros(hm.shape, bool)
    for p0, p1 in zip(frac[:-1], frac[1:], strict=True):
        r, c = _segment_cells(p0, p1)
        inside = on_grid(hm, r, c)
        mask[r[inside], c[inside]] = True
    return mask


# --------------------------------------------------------------------------------------------- breach
class Breach(Section):
    """A trapezoidal breach window across a dam (SPEC FL-1; the module docstring gives the shape)."""

    bottom_width: float = param(..., gt=0, unit="m", doc="width of the window's floor")
    floor: float = param(..., unit="m", doc="elevation of the window's floor")
    side_slope: float = param(
        0.0, ge=0, unit="1", doc="side slope of the window, horizontal:vertical (0 = vertical walls)"
    )
    line: tuple[tuple[float, float], tuple[float, float]] = param(
        ..., unit="map units", doc="the window's centre line across the dam, [[x0, y0], [x1, y1]]"
    )

    @field_validator("bottom_width", "floor", "side_slope")
    @classmethod
    def _finite(cls, v: float) -> float:
        if not math.isfinite(v):
            raise ValueError("it must be a finite number")
        return v

    @field_validator("line")
    @classmethod
    def _two_ends(cls, v: tuple) -> tuple:
        if not all(math.isfinite(c) for p in v for c in p):
            raise ValueError("the centre line's ends must be finite numbers")
        if v[0] == v[1]:
            raise ValueError("the centre line's two ends must differ")
        return v


def cut_breach(hm: Heightmap, breach: Breach) -> Heightmap:
    """A copy of ``hm`` with the breach window cut in: z ← min(z, floor + max(0, s − b/2)/m) for cells
    whose centre lies within the centre-line segment's length at perpendicular distance s (m)."""
    (x0, y0), (x1, y1) = breach.line
    r, c = fractional_cell(hm, np.array([x0, x1]), np.array([y0, y1]))
    cs = hm.cell_size
    a = np.array([r[0], c[0]]) * cs  # the segment in metres (row, col axes)
    u = np.array([r[1] - r[0], c[1] - c[0]]) * cs
    length = float(np.hypot(*u))
    u /= length
    ny, nx = hm.shape
    pr = (np.arange(ny) + 0.5)[:, None] * cs - a[0]
    pc = (np.arange(nx) + 0.5)[None, :] * cs - a[1]
    along = pr * u[0] + pc * u[1]
    s = np.abs(pr * u[1] - pc * u[0])
    excess = np.maximum(0.0, s - 0.5 * breach.bottom_width)
    if breach.side_slope > 0:
        target = breach.floor + excess / breach.side_slope
    else:
        target = np.where(excess > 0, np.inf, breach.floor)
    within = (along >= 0.0) & (along <= length) & hm.valid
    z = np.where(within, np.minimum(hm.z, target), hm.z)
    return hm.copy(z=z)


# ------------------------------------------------------------------------------------------ reservoir
def _edge_cells(region: np.ndarray) -> dict[str, bool]:
    return {
        "north": bool(region[0].any()),
        "south": bool(region[-1].any()),
        "east": bool(region[:, -1].any()),
        "west": bool(region[:, 0].any()),
    }


def fill_reservoir(
    hm: Heightmap, level: float, seed_xy, barrier: np.ndarray | None = None, open_edges=()
) -> np.ndarray:
    """Depth (m, float64, 0 outside) of a reservoir filled to ``level`` from ``seed_xy`` = (x, y).

    The reservoir is the 4-connected set of cells with z < level reachable from the seed's cell, not
    through nodata cells nor ``barrier`` cells (a boolean mask, e.g. from :func:`barrier_mask`); depth
    = level − z there. It may touch a closed map edge (a wall); touching an edge named in
    ``open_edges`` ("north", "south", "east", "west") is refused, since the water would leave the map
    at once: the barrier does not close the valley. Bad input raises one-sentence :class:`InputError`.
    """
    edges = [str(e).lower() for e in open_edges]
    for e in edges:
        if e not in EDGES:
            raise InputError(f"Unknown map edge {e!r} in outflow.edges; use north, south, east or west.")
    try:
        level = float(level)
    except (TypeError, ValueError):
        level = math.nan
    if not math.isfinite(level):
        raise InputError(f"The reservoir level {level!r} is not a finite number; set reservoir.level in metres.")
    try:
        seed = np.asarray(seed_xy, dtype=np.float64)
    except (TypeError, ValueError):
        seed = np.zeros(0)
    if seed.shape != (2,) or not np.isfinite(seed).all():
        raise InputError(
            f"The reservoir seed {seed_xy!r} is not a point; set reservoir.seed = [x, y] in the DEM's coordinates."
        )
    x, y = (float(v) for v in seed)
    row, col = cell_of(hm, x, y)
    at = f"[{_fmt(x)}, {_fmt(y)}]"
    if not on_grid(hm, row, col):
        x0, x1, y0, y1 = hm.extent
        raise InputError(
            f"The reservoir seed {at} lies outside the DEM (x {_fmt(x0)}..{_fmt(x1)}, y {_fmt(y0)}..{_fmt(y1)}); "
            "set reservoir.seed to a point in the reservoir, in the DEM's coordinates."
        )
    if not hm.valid[row, col]:
        raise InputError(
            f"The reservoir seed {at} lies on a nodata cell of the DEM; set reservoir.seed to a point in the "
            "reservoir where the DEM has data."
        )
    if barrier is not None:
        barrier = np.asarray(barrier, dtype=bool)
        if barrier.shape != hm.shape:
            raise InputError(f"The barrier mask has shape {barrier.shape} but the DEM {hm.shape}; they must match.")
        if barrier[row, col]:
            raise InputError(
                f"The reservoir seed {at} lies on the barrier; move reservoir.seed into the reservoir, "
                "off reservoir.barrier's line."
            )
    ground = float(hm.z[row, col])
    if level <= ground:
        raise InputError(
            f"The reservoir level {_fmt(level)} m is at or below the ground ({_fmt(ground)} m) at the seed {at}; "
            "raise reservoir.level or move reservoir.seed to lower ground."
        )
    water = (hm.z < level) & hm.valid
    if barrier is not None:
        water &= ~barrier
    labels, _ = ndimage.label(water)  # default structure: 4-connected
    region = labels == labels[row, col]
    for edge, touched in _edge_cells(region).items():
        if touched and edge in edges:
            raise InputError(
                f"The reservoir at level {_fmt(level)} m reaches the {edge} edge of the map: the barrier does not "
                "close the valley; draw reservoir.barrier across the valley or lower reservoir.level."
            )
    return np.where(region, level - hm.z, 0.0)
