"""Measures of an eroded terrain that a terrain artist judges by eye, as numbers (issue 12's demo
targets; ``benchmarks/demo_metrics.py`` prints them for a run folder).

* **Hillslope roughness**: the standard deviation of the discrete Laplacian ∇²z (m⁻¹; 5-point
  stencil, ``scipy.ndimage.laplace`` / Δx²) over hillslope cells — where the stream map is below 0.05
  and there is no lake. Cell-scale artefacts (pits, diagonal ridges) raise it; smooth slopes do not.
  Compared before and after a run, the ratio says whether the model roughened the hills.
* **River network**: river cells are those with stream ≥ 0.2, grouped 8-connected
  (``scipy.ndimage.label``). The longest river's span is the larger side of its bounding box as a
  fraction of the map's width; a river *reaches an outlet* when it touches (8-adjacent) a lake cell
  or the map's edge. Short streaks that end on a hillside do neither. A one-cell puddle counts as a
  lake there, so the share is also given for outlets that are the edge or a lake of at least
  ``LAKE_CELLS`` cells (issue 36's measure of rivers that end somewhere).
* **Lakes**: lake cells (depth > 0) grouped 8-connected; how many, how many are one cell (the
  depositional plains' micro-pits), how many have at least ``LAKE_CELLS`` cells.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

RIVER_STREAM = 0.2
HILLSLOPE_STREAM = 0.05
LAKE_CELLS = 10  # a lake of this many cells or more counts as a river's outlet in the stricter share
EIGHT = np.ones((3, 3), bool)


def laplacian_roughness(z: np.ndarray, cell_size: float, where: np.ndarray) -> float:
    """std of ∇²z (m⁻¹) over the cells in ``where``, the map's border row and column left out."""
    lap = ndimage.laplace(np.asarray(z, dtype=np.float64), mode="nearest") / cell_size**2
    inner = np.zeros_like(where, dtype=bool)
    inner[1:-1, 1:-1] = True
    values = lap[where & inner]
    return float(values.std()) if values.size else float("nan")


def _lakes(lake_depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lakes (depth > 0) labelled 8-connected, and each label's cell count (index 0, dry land: 0)."""
    labels, _ = ndimage.label(lake_depth > 0, structure=EIGHT)
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    return labels, sizes


def hillslopes(stream: np.ndarray, lake_depth: np.ndarray) -> np.ndarray:
    return (stream < HILLSLOPE_STREAM) & (lake_depth <= 0)


def river_network(stream: np.ndarray, lake_depth: np.ndarray) -> dict:
    """The longest river's span (fraction of the width) and the share of river cells whose river
    reaches a lake or the edge."""
    rivers = stream >= RIVER_STREAM
    labels, count = ndimage.label(rivers, structure=EIGHT)
    if count == 0:
        return {
            "rivers": 0, "river_cells": 0, "longest_span_fraction": 0.0, "reaching_outlet_fraction": 0.0,
            "reaching_edge_or_lake_fraction": 0.0,
        }  # fmt: skip
    ny, nx = stream.shape
    spans = np.zeros(count)
    for k, sl in enumerate(ndimage.find_objects(labels)):
        spans[k] = max(sl[0].stop - sl[0].start, sl[1].stop - sl[1].start)
    sizes = ndimage.sum_labels(rivers, labels, index=np.arange(1, count + 1))
    lakes, lake_sizes = _lakes(lake_depth)

    def reached(lake_cells: np.ndarray) -> float:
        outlet = ndimage.binary_dilation(lake_cells, structure=EIGHT)
        outlet[0, :] = outlet[-1, :] = outlet[:, 0] = outlet[:, -1] = True
        reaching = np.unique(labels[outlet & rivers])
        return float(sizes[reaching[reaching > 0] - 1].sum() / rivers.sum())

    return {
        "rivers": int(count),
        "river_cells": int(rivers.sum()),
        "longest_span_fraction": float(spans.max() / nx),
        "reaching_outlet_fraction": reached(lakes > 0),
        "reaching_edge_or_lake_fraction": reached(lake_sizes[lakes] >= LAKE_CELLS),
    }


def lake_counts(lake_depth: np.ndarray) -> dict:
    """Lakes (depth > 0, 8-connected): how many, how many one cell, how many ≥ ``LAKE_CELLS``."""
    sizes = _lakes(lake_depth)[1][1:]
    return {
        "lakes": int(sizes.size),
        "one_cell_lakes": int((sizes == 1).sum()),
        "large_lakes": int((sizes >= LAKE_CELLS).sum()),
    }
