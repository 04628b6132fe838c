"""The heightmap terrain of SPEC HM-1: a 2-D height matrix (DEM) with a cell size in metres.

``z[iy, ix]`` is float64, C-contiguous, shape ``(ny, nx)``, row 0 = north (the GeoTIFF order).
``transform`` is the affine geotransform in rasterio/``affine`` order ``(a, b, c, d, e, f)``:
x = a·col + b·row + c, y = d·col + e·row + f (pixel corners); ``crs`` is WKT text. Both are
``None`` for generated terrains. ``nodata`` is a boolean mask (True = no data) or ``None``; masked
cells hold a filled value (nearest valid height) so kernels never meet NaN.

Map coordinates ↔ cells (:func:`cell_of`, :func:`xy_of`) go through the transform, or for a map
without one through :func:`default_transform` (west edge x = 0, south edge y = 0): with
(x, y) = (a·col + b·row + c, d·col + e·row + f), the cell of a point is the floor of the inverse
affine map's (row, col), and a cell's centre is the forward map at (row + ½, col + ½).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import ndimage

from erosim.core.errors import InputError


def fill_nodata(z: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Copy of ``z`` with masked cells set to the height of the nearest valid cell (Euclidean).

    Nearest-neighbour fill (scipy.ndimage.distance_transform_edt) never invents heights outside the
    data's range and leaves no pit or peak the water could not leave; hydrology treats the masked
    area as outside the world anyway.
    """
    if not mask.any():
        return z.copy()
    _, (iy, ix) = ndimage.distance_transform_edt(mask, return_indices=True)
    return z[iy, ix]


def default_transform(ny: int, nx: int, cell_size: float) -> tuple:
    """Affine (a, b, c, d, e, f) of an ungeoreferenced map: west edge x = 0, south edge y = 0."""
    return (cell_size, 0.0, 0.0, 0.0, -cell_size, ny * cell_size)


def transform_of(hm: Heightmap) -> tuple:
    """The map's affine transform, or :func:`default_transform` for a map without one."""
    return tuple(hm.transform) if hm.transform is not None else default_transform(*hm.shape, hm.cell_size)


def fractional_cell(hm: Heightmap, x, y) -> tuple[np.ndarray, np.ndarray]:
    """(row, col) as real numbers of map point(s) (x, y): cell (i, j) spans [i, i+1) × [j, j+1)."""
    a, b, c, d, e, f = transform_of(hm)
    det = a * e - b * d
    dx = np.asarray(x, dtype=np.float64) - c
    dy = np.asarray(y, dtype=np.float64) - f
    return (a * dy - d * dx) / det, (e * dx - b * dy) / det


def cell_of(hm: Heightmap, x, y):
    """(row, col) of the cell holding map point (x, y) in the map's own units (arrays for arrays).

    The indices may lie off the grid (negative or ≥ the shape) for points off the map; check them
    with :func:`on_grid`. A point on a cell boundary belongs to the cell on its larger-index side.
    """
    r, c = fractional_cell(hm, x, y)
    r, c = np.floor(r).astype(np.int64), np.floor(c).astype(np.int64)
    if r.ndim == 0:
        return int(r), int(c)
    return r, c


def on_grid(hm: Heightmap, row, col):
    """True where (row, col) is a cell of the map."""
    ny, nx = hm.shape
    row, col = np.asarray(row), np.asarray(col)
    inside = (row >= 0) & (row < ny) & (col >= 0) & (col < nx)
    return bool(inside) if inside.ndim == 0 else inside


def xy_of(hm: Heightmap, row, col):
    """Map coordinates (x, y) of the centre of cell (row, col) (arrays for arrays)."""
    a, b, c, d, e, f = transform_of(hm)
    rr = np.asarray(row, dtype=np.float64) + 0.5
    cc = np.asarray(col, dtype=np.float64) + 0.5
    x, y = a * cc + b * rr + c, d * cc + e * rr + f
    if x.ndim == 0:
        return float(x), float(y)
    return x, y


@dataclasses.dataclass
class Heightmap:
    """A DEM: heights ``z`` (m), square cells of ``cell_size`` metres, optional georeference."""

    z: np.ndarray
    cell_size: float = 1.0
    crs: str | None = None
    transform: tuple | None = None
    nodata: np.ndarray | None = None
    # assumptions made while reading (no stored height range or cell size): runners copy them into
    # report.json's warnings so a user sees why heights or distances look off
    notes: list[str] = dataclasses.field(default_factory=list, compare=False)

    def __post_init__(self) -> None:
        try:
            cs = float(self.cell_size)
        except (TypeError, ValueError):
            raise InputError(
                f"Cell size {self.cell_size!r} is not a number; give the cell size in metres, e.g. 2.0."
            ) from None
        if not math.isfinite(cs) or cs <= 0:
            raise InputError(f"Cell size {self.cell_size!r} m is not valid; it must be a positive number of metres.")
        self.cell_size = cs
        z = np.asarray(self.z)
        if z.ndim != 2 or z.shape[0] < 2 or z.shape[1] < 2:
            raise InputError(
                f"A heightmap must be a 2-D array of at least 2x2 cells, got shape {z.shape}; check the input file."
            )
        if not np.issubdtype(z.dtype, np.number) or np.iscomplexobj(z):
            raise InputError(f"Heights must be real numbers, got dtype {z.dtype}; check the input file.")
        z = np.ascontiguousarray(z, dtype=np.float64)
        bad = ~np.isfinite(z)
        if self.nodata is not None and np.shape(self.nodata) != z.shape:
            raise InputError(
                f"The nodata mask has shape {np.shape(self.nodata)} but the heights have {z.shape}; they must match."
            )
        mask = bad if self.nodata is None else (np.asarray(self.nodata, dtype=bool) | bad)
        if mask.all():
            raise InputError(
                "The heightmap holds no valid height (all cells are NaN or nodata); "
                "check the file's nodata value or choose another file."
            )
        if mask.any():
            z = fill_nodata(np.where(mask, 0.0, z), mask)
            self.nodata = np.ascontiguousarray(mask)
        else:
            self.nodata = None
        self.z = np.ascontiguousarray(z, dtype=np.float64)
        if self.transform is not None:
            t = tuple(float(v) for v in tuple(self.transform)[:6])
            if len(t) != 6:
                raise InputError("A geotransform needs six numbers (a, b, c, d, e, f); check the input file.")
            self.transform = t

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx)."""
        return self.z.shape  # type: ignore[return-value]

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) in metres (map coordinates when georeferenced).

        Without a transform the map spans 0..nx·Δ in x and 0..ny·Δ in y.
        """
        ny, nx = self.shape
        if self.transform is None:
            return 0.0, nx * self.cell_size, 0.0, ny * self.cell_size
        a, b, c, d, e, f = self.transform
        xs = [c, c + a * nx, c + b * ny, c + a * nx + b * ny]
        ys = [f, f + d * nx, f + e * ny, f + d * nx + e * ny]
        return min(xs), max(xs), min(ys), max(ys)

    @property
    def valid(self) -> np.ndarray:
        """Boolean mask of cells with data (all True when there is no nodata)."""
        return np.ones(self.shape, bool) if self.nodata is None else ~self.nodata

    def copy(self, z: np.ndarray | None = None) -> Heightmap:
        """Deep copy; with ``z`` given, the same georeference around new heights."""
        return Heightmap(
            z=self.z.copy() if z is None else np.array(z, dtype=np.float64),
            cell_size=self.cell_size,
            crs=self.crs,
            transform=self.transform,
            nodata=None if self.nodata is None else self.nodata.copy(),
        )

    def __repr__(self) -> str:
        ny, nx = self.shape
        return (
            f"Heightmap({ny}x{nx}, cell {self.cell_size:g} m, z "
            f"{self.z.min():.3g}..{self.z.max():.3g} m"
            f"{', georeferenced' if self.crs else ''}"
            f"{', with nodata' if self.nodata is not None else ''})"
        )
