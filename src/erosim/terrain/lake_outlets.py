"""Where a terrain's lakes stand and where each one spills: its closed hollows, their spill levels and
capacities, and the path from each hollow's pour point down to the next hollow or the map's edge.

* **Hollows**: the depth of water each cell would hold with every closed basin filled to its spill level,
  by Priority-Flood (Barnes, Lehman & Mulla 2014; :func:`~erosim.terrain.priority_flood_barnes2014.
  closed_basin_depth`), grouped 8-connected (``scipy.ndimage.label``). A hollow's capacity is
  Σ depth · Δx², its spill level the filled surface's height over it.
* **Pour point**: the lowest cell on the hollow's rim (8-adjacent, outside every basin); Priority-Flood
  fills a basin exactly to that cell's height.
* **Outlet path**: steepest descent over the 8 neighbours (O'Callaghan & Mark 1984's D8) from the pour
  point over the surface filled with a slope of 10⁻⁵ (so that the flats of smaller filled hollows still
  drain), until it enters another of the hollows kept or reaches the map's edge. A lake that has filled
  passes its inflow on along this path: into the next lake (the lakes join) or off the map.

Used to describe the ``mountain-lake`` scene's lakes and to measure a run's outlets being cut (a lake
whose outlet is carved loses spill level and capacity; ``benchmarks/mountain_lake_lowering.py``). The
path walk is plain Python: it visits a few cells per hollow.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from erosim.terrain.priority_flood_barnes2014 import closed_basin_depth, fill_basins

EIGHT = np.ones((3, 3), bool)
ROUTING_SLOPE = 1e-5  # m/m: the filled flats' fall towards their spill points, for the D8 walk only


@dataclass(frozen=True)
class Hollow:
    """A closed hollow: its cells, the water it holds when full, its spill level and its outlet's path
    ((row, column) cells from the pour point); ``spills_into`` is the index of the hollow that path
    enters in the list :func:`hollows` returns, or -1 for the map's edge."""

    cells: np.ndarray
    capacity_m3: float
    spill_level_m: float
    path: tuple[tuple[int, int], ...]
    spills_into: int

    def centre(self, cell_size: float) -> tuple[float, float]:
        """(x, y) of the hollow's cells' centroid, in metres from node (0, 0)."""
        iy, ix = np.nonzero(self.cells)
        return float(ix.mean() * cell_size), float(iy.mean() * cell_size)


def steepest_neighbour(z: np.ndarray, i: int, j: int) -> tuple[int, int] | None:
    """The 8-neighbour of (i, j) of steepest descent (drop over distance), or None where none is lower."""
    ny, nx = z.shape
    best, to = 0.0, None
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            a, c = i + di, j + dj
            if (di or dj) and 0 <= a < ny and 0 <= c < nx:
                s = (z[i, j] - z[a, c]) / (1.4142135623730951 if di and dj else 1.0)
                if s > best:
                    best, to = s, (a, c)
    return to


def hollows(z: np.ndarray, cell_size: float, least_m3: float = 1.0) -> list[Hollow]:
    """The closed hollows of the heightmap ``z`` (rows along y) that hold more than ``least_m3`` m³ when
    full, ordered by their first cell, each with its spill level and outlet path (module docstring)."""
    z = np.asarray(z, dtype=np.float64)
    depth = closed_basin_depth(z)
    routed = fill_basins(z, cell_size, ROUTING_SLOPE)
    labels, n = ndimage.label(depth > 0, structure=EIGHT)
    volume = ndimage.sum(depth, labels, index=np.arange(1, n + 1)) * cell_size**2
    kept = [k + 1 for k in range(n) if volume[k] > least_m3]
    index = {k: i for i, k in enumerate(kept)}
    found = []
    for k in kept:
        cells = labels == k
        rim = ndimage.binary_dilation(cells, structure=EIGHT) & ~cells & (depth <= 0)
        ri, rj = np.nonzero(rim)
        pour = int(np.argmin(z[ri, rj]))
        path = [(int(ri[pour]), int(rj[pour]))]
        while (nxt := steepest_neighbour(routed, *path[-1])) is not None and labels[nxt] not in index:
            path.append(nxt)
        if nxt is not None:
            path.append(nxt)
        end = labels[path[-1]]
        spill = float((z + depth)[cells].max())
        found.append(Hollow(cells=cells, capacity_m3=float(volume[k - 1]), spill_level_m=spill, path=tuple(path),
                            spills_into=index[end] if end in index else -1))  # fmt: skip
    return found
