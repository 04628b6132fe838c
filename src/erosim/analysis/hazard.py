"""Flood hazard per cell from the maxima of depth, speed and depth × speed (SPEC FL-2 … FL-4).

Over a flood run every cell records the running maxima of depth D (m), speed V (m/s) and their
product D·V (m²/s, the maximum of the product at each step, not the product of the maxima), and the
first time it was wet (s). The hazard class follows the combined flood hazard curves of the Australian
Disaster Resilience Handbook 7, guideline 7-3 "Flood hazard" (AIDR 2017), as adopted by the NSW flood
risk management guideline FB03 "Flood hazard" (2022); the curves come from Smith, Davey & Cox (2014),
"Flood hazard", UNSW Water Research Laboratory technical report 2014/07. A cell gets the lowest class
whose three limits all hold (SPEC FL-3):

    class  V·D ≤ (m²/s)  D ≤ (m)  V ≤ (m/s)  meaning
    H1     0.3           0.3      2.0        generally safe for vehicles, people and buildings
    H2     0.6           0.5      2.0        unsafe for small vehicles
    H3     0.6           1.2      2.0        unsafe for vehicles, children and the elderly
    H4     1.0           2.0      2.0        unsafe for vehicles and people
    H5     4.0           4.0      4.0        unsafe for vehicles and people; all buildings vulnerable to
                                             structural damage
    H6     —             —        —          unsafe for vehicles and people; all buildings vulnerable to failure

and H6 when none does. A limit holds when the value is at most the limit (a value exactly on the line
takes the lower class). Cells shallower than ``wet_depth`` (default 0.01 m) are dry: class 0, and they
raise neither the speed nor the D·V maxima nor the arrival time. ``max_depth`` records wet depths only,
so it is 0 where the cell was never wet.

Reports (FL-4): the flooded area is the area of the cells of class 1–6, and each class's share is its
area over the flooded area (the shares sum to 1 when anything flooded; all are 0 when nothing did).
Cells outside ``valid`` (nodata, walls) are never flooded: class 0 whatever their maxima hold, so a
report and the hazard map written from :meth:`HazardMaps.classes` count the same cells. A dam break's
flooded area holds the reservoir itself; the area flooded *below the dam* leaves out the reservoir's
cells and every cell already wet at t = 0.
"""

from __future__ import annotations

import numpy as np

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap, xy_of

#: FL-3: (V·D ≤ m²/s, D ≤ m, V ≤ m/s) of H1 … H5; H6 is everything beyond H5
HAZARD_LIMITS: tuple[tuple[float, float, float], ...] = (
    (0.3, 0.3, 2.0),
    (0.6, 0.5, 2.0),
    (0.6, 1.2, 2.0),
    (1.0, 2.0, 2.0),
    (4.0, 4.0, 4.0),
)
#: FL-3: what each class means (the legend of hazard maps)
HAZARD_MEANING: dict[str, str] = {
    "H1": "generally safe for vehicles, people and buildings",
    "H2": "unsafe for small vehicles",
    "H3": "unsafe for vehicles, children and the elderly",
    "H4": "unsafe for vehicles and people",
    "H5": "unsafe for vehicles and people; all buildings vulnerable to structural damage",
    "H6": "unsafe for vehicles and people; all buildings vulnerable to failure",
}
CLASSES = tuple(HAZARD_MEANING)
WET_DEPTH = 0.01  # m: shallower water counts as dry (issue 9's flood.wet_depth default)
_KEYS = ("max_depth", "max_speed", "max_dv", "arrival")


def classify(max_depth, max_speed, max_dv, wet_depth: float = WET_DEPTH) -> np.ndarray:
    """Hazard class (uint8) per cell: 0 where ``max_depth`` < ``wet_depth`` (or NaN), else the lowest
    class 1 … 5 of :data:`HAZARD_LIMITS` whose three limits all hold, else 6."""
    d = np.asarray(max_depth, dtype=np.float64)
    v = np.asarray(max_speed, dtype=np.float64)
    dv = np.asarray(max_dv, dtype=np.float64)
    d, v, dv = np.broadcast_arrays(d, v, dv)
    out = np.full(d.shape, len(HAZARD_LIMITS) + 1, dtype=np.uint8)
    for k in range(len(HAZARD_LIMITS), 0, -1):  # highest first, so the lowest class that holds wins
        dv_max, d_max, v_max = HAZARD_LIMITS[k - 1]
        out[(dv <= dv_max) & (d <= d_max) & (v <= v_max)] = k
    out[~(d >= wet_depth)] = 0
    return out


class HazardMaps:
    """Running maxima of depth, speed and depth × speed, and the arrival time, per cell (FL-2).

    Arrays (float64, the grid's shape): ``max_depth`` (m, wet depths only), ``max_speed`` (m/s),
    ``max_dv`` (m²/s), ``arrival`` (s, ``inf`` where never wet). A dense grid of depth and speed is fed
    with :meth:`update` at every step (or every sampled step) of the run. ``valid`` (boolean, the grid's
    shape; default every cell) marks the cells water can stand on: the others (nodata, walls) are
    class 0 and count in no area.
    """

    def __init__(self, shape: tuple[int, int], wet_depth: float = WET_DEPTH, valid: np.ndarray | None = None) -> None:
        if not wet_depth > 0:
            raise InputError(f"The wet depth {wet_depth!r} m is not valid; set flood.wet_depth to a positive depth.")
        self.shape = tuple(int(n) for n in shape)
        self.wet_depth = float(wet_depth)
        if valid is not None:
            valid = np.asarray(valid, dtype=bool)
            if valid.shape != self.shape:
                raise ValueError(f"the valid mask's shape {valid.shape} must be the hazard grid's {self.shape}")
        self.valid = valid
        self.max_depth = np.zeros(self.shape)
        self.max_speed = np.zeros(self.shape)
        self.max_dv = np.zeros(self.shape)
        self.arrival = np.full(self.shape, np.inf)

    def update(self, t: float, depth: np.ndarray, speed: np.ndarray, valid: np.ndarray | None = None) -> None:
        """Take the depth (m) and speed (m/s) of every cell at time ``t`` (s); cells outside ``valid``
        (default: the maps' own ``valid``; e.g. nodata) and cells shallower than ``wet_depth`` are
        ignored. NaN counts as dry."""
        depth = np.asarray(depth, dtype=np.float64)
        speed = np.asarray(speed, dtype=np.float64)
        if depth.shape != self.shape or speed.shape != self.shape:
            raise ValueError(
                f"depth {depth.shape} and speed {speed.shape} must have the hazard grid's shape {self.shape}"
            )
        wet = depth >= self.wet_depth
        if valid is None:
            valid = self.valid
        if valid is not None:
            wet &= np.asarray(valid, dtype=bool)
        d = np.where(wet, depth, 0.0)
        v = np.where(wet, speed, 0.0)
        np.fmax(self.max_depth, d, out=self.max_depth)
        np.fmax(self.max_speed, v, out=self.max_speed)
        np.fmax(self.max_dv, d * v, out=self.max_dv)
        first = wet & np.isinf(self.arrival)
        self.arrival[first] = float(t)

    def classes(self) -> np.ndarray:
        """The hazard class of every cell (uint8, 0 = dry or not ``valid``) from the maxima so far
        (:func:`classify`)."""
        out = classify(self.max_depth, self.max_speed, self.max_dv, self.wet_depth)
        if self.valid is not None:
            out[~self.valid] = 0
        return out

    def state_dict(self) -> dict[str, np.ndarray]:
        """Copies of the four arrays (a checkpoint's content)."""
        return {k: getattr(self, k).copy() for k in _KEYS}

    def load_state_dict(self, state: dict) -> None:
        """Restore the arrays of :meth:`state_dict`."""
        for k in _KEYS:
            if k not in state:
                raise InputError(f"The checkpoint has no hazard map '{k}'; resume from a checkpoint of a flood run.")
            a = np.asarray(state[k], dtype=np.float64)
            if a.shape != self.shape:
                raise InputError(
                    f"The checkpoint's hazard map '{k}' has shape {a.shape} but the grid is {self.shape}; "
                    "resume with the terrain the run started from."
                )
            setattr(self, k, a.copy())

    def summary(
        self, cell_area_m2: float, inside: np.ndarray | None = None, reservoir: np.ndarray | None = None
    ) -> dict:
        """``flooded_area_m2``, ``hazard_area_m2`` and ``hazard_share`` (H1 … H6: fractions of the flooded
        area) over the valid cells; with ``inside`` (a boolean mask, e.g. :func:`polygon_mask`), the same
        three within it under ``"inside"``; with ``reservoir`` (a boolean mask of the reservoir's cells),
        the same three below the dam under ``"below_dam"``: the flooded cells outside the reservoir that
        were dry at t = 0 (arrival time > 0)."""
        classes = self.classes()
        out = _areas(classes, cell_area_m2)
        if inside is not None:
            out["inside"] = _areas(np.where(self._mask(inside), classes, 0), cell_area_m2)
        if reservoir is not None:
            below = ~self._mask(reservoir) & (self.arrival > 0.0)
            out["below_dam"] = _areas(np.where(below, classes, 0), cell_area_m2)
        return out

    def _mask(self, mask) -> np.ndarray:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != self.shape:
            raise ValueError(f"the mask's shape {mask.shape} must be the hazard grid's {self.shape}")
        return mask


def _areas(classes: np.ndarray, cell_area_m2: float) -> dict:
    counts = np.bincount(classes.ravel(), minlength=len(CLASSES) + 1)[1 : len(CLASSES) + 1]
    flooded = int(counts.sum())
    return {
        "flooded_area_m2": float(flooded * cell_area_m2),
        "hazard_area_m2": {name: float(n * cell_area_m2) for name, n in zip(CLASSES, counts, strict=True)},
        "hazard_share": {
            name: (float(n / flooded) if flooded else 0.0) for name, n in zip(CLASSES, counts, strict=True)
        },
    }


def polygon_mask(hm: Heightmap, polygon) -> np.ndarray:
    """Boolean mask of the cells whose centres lie inside ``polygon`` = [[x, y], ...] (map units, at
    least three points; closed automatically), by ``matplotlib.path.Path.contains_points``."""
    from matplotlib.path import Path

    try:
        pts = np.asarray(polygon, dtype=np.float64)
    except (TypeError, ValueError):
        pts = np.zeros((0, 0))
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3 or not np.isfinite(pts).all():
        raise InputError(
            f"The polygon {polygon!r} is not valid; give at least three points [[x0, y0], [x1, y1], [x2, y2], ...] "
            "as finite numbers in the map's coordinates."
        )
    ny, nx = hm.shape
    x, y = xy_of(hm, *np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij"))
    inside = Path(pts).contains_points(np.column_stack([x.ravel(), y.ravel()]))
    return inside.reshape(ny, nx)
