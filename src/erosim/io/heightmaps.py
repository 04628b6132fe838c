"""Heightmap files in and out: GeoTIFF, 16-bit PNG, RAW16, ESRI ASCII grid, NPY/NPZ.

The format follows the file's extension:

| extension       | format                                   | heights                         |
|-----------------|------------------------------------------|---------------------------------|
| ``.tif .tiff``  | GeoTIFF via rasterio, float32, deflate   | metres; CRS, transform, nodata  |
| ``.png``        | 16-bit grayscale PNG (Pillow)            | 0..65535 over a height range    |
| ``.raw .r16``   | headerless little-endian uint16 (games)  | 0..65535 over a height range    |
| ``.asc``        | ESRI ASCII grid (17 significant digits)  | metres, exact; corner + cellsize|
|                 |                                          | (``dx``/``dy`` if not square)   |
| ``.npy``        | NumPy array, float64                     | metres, exact                   |
| ``.npz``        | NumPy archive: z, cell_size, crs, transform | metres, exact, georeference  |

16-bit formats store q = round((z − lo)/(hi − lo)·65535); reading gives z = lo + q·(hi − lo)/65535,
so a round trip is within half a step (hi − lo)/65535. :func:`write` returns the range used
(``height_range``) so the run report can re-scale; erosim's PNGs also carry it in a text chunk
(``erosim:height_range``) and read it back. Without a range, 16-bit values are read as metres.

Georeference of PNG, RAW16, ASC and NPY lives in sidecar files beside the map (GDAL's and ESRI's
conventions, read back by :func:`read`): ``<stem>.prj`` holds the CRS as WKT, and a world file holds
the transform: ``<stem>.pgw`` for PNG, ``<stem>.wld`` for RAW16 and NPY (ASC keeps its corner and
cell size in its header). World-file lines are A, D, B, E, C, F with (C, F) the centre of the
upper-left pixel. A map without CRS or transform writes no sidecar.

``sample:jacksboro`` is the 3-arc-second DEM of the Jacksboro fault (Tennessee) shipped with
matplotlib. Its cells are 74.5 m (E–W) × 92.4 m (N–S); erosim uses the square cell of equal area,
83 m, and keeps the geographic CRS and transform. :func:`write_raster` writes a map of values that
are not heights (flood depths, hazard classes: float32 or integer) as a GeoTIFF on a DEM's grid with
a chosen nodata value. All writes are atomic (:func:`erosim.core.atomic.atomic_path`).
"""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np

from erosim.core.atomic import atomic_path, write_text
from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap, default_transform

Q16 = 65535
Q16_CHUNK = 1 << 22  # cells the 16-bit writers quantize at once (32 MB of float64)
FORMATS = {
    ".tif": "geotiff",
    ".tiff": "geotiff",
    ".png": "png16",
    ".raw": "raw16",
    ".r16": "raw16",
    ".asc": "asc",
    ".npy": "npy",
    ".npz": "npz",
}
SAMPLES = {"sample:jacksboro": "jacksboro_fault_dem.npz"}
JACKSBORO_CELL = 83.0  # m: sqrt(74.5 m × 92.4 m), the equal-area square of the 3" cell at 36.6° N
_NODATA = -9999.0
_PNG_RANGE_KEY = "erosim:height_range"
_PNG_CELL_KEY = "erosim:cell_size"
_SIDECAR_FORMATS = ("png16", "raw16", "asc", "npy")  # georeference beside the file, not in it


# ----------------------------------------------------------------------------------------- helpers
def _format(path: str | os.PathLike, verb: str) -> str:
    ext = Path(path).suffix.lower()
    if ext not in FORMATS:
        raise InputError(
            f"Cannot {verb} '{path}': unknown extension '{ext or '(none)'}'; use one of "
            + ", ".join(sorted(FORMATS))
            + "."
        )
    return FORMATS[ext]


def _check_cell_size(cell_size) -> float | None:
    if cell_size is None:
        return None
    try:
        cs = float(cell_size)
    except (TypeError, ValueError):
        cs = float("nan")
    if not math.isfinite(cs) or cs <= 0:
        raise InputError(f"Cell size {cell_size!r} m is not valid; it must be a positive number of metres.")
    return cs


def _check_range(height_range) -> tuple[float, float] | None:
    if height_range is None:
        return None
    try:
        lo, hi = (float(v) for v in height_range)
    except (TypeError, ValueError):
        raise InputError(
            f"Height range {height_range!r} is not valid; give two numbers [low, high] in metres."
        ) from None
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise InputError(f"Height range {height_range!r} is not valid; it needs low < high, both finite, in metres.")
    return lo, hi


def _row_blocks(a: np.ndarray):
    """Slices of ``Q16_CHUNK`` cells' worth of whole rows: what the 16-bit writers quantize at once."""
    rows = max(1, Q16_CHUNK // max(1, a[0].size)) if a.ndim and a.shape[0] else 1
    return [slice(r, r + rows) for r in range(0, a.shape[0] if a.ndim else 0, rows)]


def _q16(a: np.ndarray, lo: float, hi: float, nan: float | None = None) -> np.ndarray:
    """q = clip(rint((a − lo)·Q16/(hi − lo)), 0, Q16) as uint16 (NaN → ``nan`` first where given), a block of
    rows at a time: a 4096² map's float64 temporaries were three full-size copies (0.4 GB)."""
    a = np.asarray(a)
    q = np.empty(a.shape, np.uint16)
    scale = Q16 / (hi - lo)
    for rows in _row_blocks(a):
        b = np.array(a[rows], dtype=np.float64)
        if nan is not None:
            np.nan_to_num(b, copy=False, nan=nan)
        b -= lo
        b *= scale
        np.rint(b, out=b)
        q[rows] = np.clip(b, 0, Q16, out=b)
    return q


def _quantise(z: np.ndarray, height_range) -> tuple[np.ndarray, tuple[float, float]]:
    rng = _check_range(height_range)
    if rng is None:
        lo, hi = float(np.min(z)), float(np.max(z))
        if hi <= lo:
            hi = lo + 1.0
        rng = (lo, hi)
    return _q16(z, *rng), rng


def _dequantise(q: np.ndarray, height_range, full: int = Q16) -> np.ndarray:
    """z = lo + q·(hi − lo)/full; without a range the stored integers themselves."""
    if height_range is None:
        return q.astype(np.float64)
    lo, hi = height_range
    return lo + q.astype(np.float64) * ((hi - lo) / full)


def _as_heightmap(hm_or_array, like: Heightmap | None) -> Heightmap:
    if isinstance(hm_or_array, Heightmap):
        return hm_or_array
    z = np.asarray(hm_or_array)
    if like is not None:
        if z.shape != like.shape:
            raise InputError(f"Array shape {z.shape} does not match the reference map's {like.shape}.")
        # a map of the terrain keeps the terrain's georeference and its nodata cells
        nodata = like.nodata if like.nodata is not None and like.nodata.any() else None
        return Heightmap(z=z, cell_size=like.cell_size, crs=like.crs, transform=like.transform, nodata=nodata)
    return Heightmap(z=z, cell_size=1.0)


def _metres_per_degree(lat_deg: float) -> tuple[float, float]:
    """(m per degree of longitude, m per degree of latitude) on the WGS84 ellipsoid."""
    p = math.radians(lat_deg)
    lat = 111132.954 - 559.822 * math.cos(2 * p) + 1.175 * math.cos(4 * p)
    lon = 111412.84 * math.cos(p) - 93.5 * math.cos(3 * p) + 0.118 * math.cos(5 * p)
    return lon, lat


def _cell_from_transform(t: tuple, crs, ny: int) -> float:
    """Metres per cell of transform ``t`` (rasterio CRS or None): the square cell of equal area."""
    if crs is not None and crs.is_geographic:
        lat = t[5] + t[4] * ny / 2.0
        mlon, mlat = _metres_per_degree(lat)
        return math.sqrt(abs(t[0]) * mlon * abs(t[4]) * mlat)
    factor = 1.0
    if crs is not None:
        try:
            factor = float(crs.linear_units_factor[1])
        except Exception:  # CRS without linear units: take the numbers as metres
            factor = 1.0
    return math.sqrt(abs(t[0] * t[4] - t[1] * t[3])) * factor


def _world_path(p: Path) -> Path:
    """The world file of ``p``: ``<stem>.pgw`` for PNG, ``<stem>.wld`` for the others."""
    return p.with_suffix(".pgw" if p.suffix.lower() == ".png" else ".wld")


def _write_sidecars(p: Path, hm: Heightmap, transform_in_file: bool) -> list[str]:
    """Write ``<stem>.prj`` (CRS as WKT) and, unless the file holds it, the world file."""
    from rasterio.crs import CRS

    written = []
    if hm.crs:
        try:
            wkt = CRS.from_user_input(hm.crs).to_wkt()
        except Exception:
            raise InputError(f"The map's CRS {hm.crs[:60]!r} is not valid; give WKT text or 'EPSG:code'.") from None
        written.append(str(write_text(p.with_suffix(".prj"), wkt + "\n")))
    if hm.transform and not transform_in_file:
        a, b, c, d, e, f = (float(v) for v in hm.transform)
        lines = (a, d, b, e, c + 0.5 * (a + b), f + 0.5 * (d + e))  # C, F: centre of the upper-left pixel
        written.append(str(write_text(_world_path(p), "".join(f"{v!r}\n" for v in lines))))
    return written


def _read_sidecars(p: Path, world: bool = True):
    """(rasterio CRS or None, transform or None) from ``<stem>.prj`` and the world file of ``p``."""
    from rasterio.crs import CRS

    crs = transform = None
    prj = p.with_suffix(".prj")
    if prj.is_file():
        text = prj.read_text(encoding="utf-8", errors="replace").strip()
        for parse in (CRS.from_wkt, CRS.from_user_input):  # WKT (either dialect), else PROJ/EPSG strings
            try:
                crs = parse(text)
                break
            except Exception:
                continue
        else:  # an old ArcInfo or unknown .prj must not stop the heights from loading
            import warnings

            warnings.warn(f"'{prj}' holds no CRS erosim can read; the map is read without one.", stacklevel=3)
    wld = next((w for w in (_world_path(p), p.with_suffix(".wld")) if w.is_file()), None) if world else None
    if wld is not None:
        try:
            a, d, b, e, cx, cy = (float(v) for v in wld.read_text(encoding="ascii", errors="replace").split())
        except ValueError:
            raise InputError(f"World file '{wld}' does not hold six numbers; fix that file or delete it.") from None
        if not all(math.isfinite(v) for v in (a, d, b, e, cx, cy)) or a * e - b * d == 0:
            raise InputError(f"World file '{wld}' gives no valid pixel size; fix that file or delete it.")
        transform = (a, b, cx - 0.5 * (a + b), d, e, cy - 0.5 * (d + e))
    return crs, transform


def _georeferenced(p: Path, z: np.ndarray, cs: float | None, rng=None, notes: bool = False) -> Heightmap:
    """Heightmap of ``z`` read from ``p``, with the georeference (and cell size) of its sidecars."""
    crs, t = _read_sidecars(p)
    if cs is None and t is not None:
        cs = _cell_from_transform(t, crs, z.shape[0])
    hm = Heightmap(z=z, cell_size=cs or 1.0, crs=crs.to_wkt() if crs is not None else None, transform=t)
    if notes:
        hm.notes.extend(_assumptions(p, rng, cs))
    elif cs is None:
        hm.notes.append(_no_cell_size(p))
    return hm


# ------------------------------------------------------------------------------------------- read
def read(
    path: str | os.PathLike,
    *,
    cell_size: float | None = None,
    raw_shape: tuple[int, int] | None = None,
    height_range: tuple[float, float] | None = None,
) -> Heightmap:
    """Read a heightmap; ``cell_size`` (m) overrides the file's; ``height_range`` scales 16-bit
    data.

    ``raw_shape`` = (rows, cols) for RAW16 files that are not square.
    """
    cs = _check_cell_size(cell_size)
    rng = _check_range(height_range)
    key = str(path)
    if key.lower() in SAMPLES:
        return _read_sample(key.lower(), cs)
    if key.startswith("sample:"):
        raise InputError(f"Unknown sample DEM '{key}'; the one available is " + ", ".join(SAMPLES) + ".")
    fmt = _format(path, "read")
    p = Path(path)
    if not p.is_file():
        raise InputError(f"Heightmap file '{p}' does not exist; check the path.")
    try:
        if fmt == "geotiff":
            hm = _read_geotiff(p, cs)
        elif fmt == "png16":
            hm = _read_png(p, cs, rng)
        elif fmt == "raw16":
            hm = _read_raw(p, cs, rng, raw_shape)
        elif fmt == "asc":
            hm = _read_asc(p, cs)
        elif fmt == "npy":
            hm = _georeferenced(p, np.load(p, allow_pickle=False), cs)
        else:
            hm = _read_npz(p, cs)
    except InputError:
        raise
    except Exception as exc:  # library errors on a corrupt file: one sentence, not a traceback
        raise InputError(
            f"Cannot read heightmap '{p}' ({type(exc).__name__}: {exc}); is it a valid {fmt} file?"
        ) from exc
    _check_heights(hm, p)
    return hm


#: heights beyond this (m) are no terrain: Earth's surface spans about −11 km … +9 km
MAX_HEIGHT = 1.0e5


def _check_heights(hm: Heightmap, p: Path) -> None:
    """Refuse, in one sentence and before any run, heights no terrain has (an undeclared nodata value
    such as 1e30 or −3.4e38, or heights in another unit), which would otherwise break the physics and
    the pictures only after the run."""
    z = np.asarray(hm.z, dtype=np.float64)
    valid = np.isfinite(z)
    if hm.nodata is not None:
        valid &= ~np.asarray(hm.nodata, dtype=bool)
    if not valid.any():
        raise InputError(f"Heightmap '{p}' has no valid height (every cell is nodata or not a number); check the file.")
    worst = float(np.abs(z[valid]).max())
    if worst > MAX_HEIGHT:
        n = int((np.abs(z[valid]) > MAX_HEIGHT).sum())
        raise InputError(
            f"Heightmap '{p}' has {n:,} cell{'s' if n > 1 else ''} with heights up to {worst:.3g} m, beyond any "
            "terrain "
            f"(|z| <= {MAX_HEIGHT:.0e} m); if they are nodata, declare the file's nodata value (e.g. "
            f"gdal_edit.py -a_nodata VALUE '{p.name}'), else convert the heights to metres."
        )


def _read_sample(key: str, cs: float | None) -> Heightmap:
    from matplotlib import cbook

    with cbook.get_sample_data(SAMPLES[key]) as data:
        z = np.asarray(data["elevation"], dtype=np.float64)
        dx, dy = float(data["dx"]), float(data["dy"])
        x0 = float(data["xmin"])
        y_top = max(float(data["ymin"]), float(data["ymax"]))
    from rasterio.crs import CRS

    return Heightmap(
        z=z, cell_size=cs or JACKSBORO_CELL, crs=CRS.from_epsg(4326).to_wkt(), transform=(dx, 0.0, x0, 0.0, -dy, y_top)
    )


def _read_geotiff(p: Path, cs: float | None) -> Heightmap:
    import rasterio
    from rasterio.errors import NotGeoreferencedWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with rasterio.open(p) as ds:
            band = ds.read(1, masked=True)
            t = ds.transform
            crs = ds.crs
            tag = ds.tags().get("cell_size_m")
    if cs is None and tag:
        cs = _check_cell_size(tag)
    z = np.ma.getdata(band).astype(np.float64)
    mask = np.ma.getmaskarray(band) | ~np.isfinite(z)
    georef = not t.is_identity
    transform = tuple(t)[:6] if georef else None
    assumed = cs is None and not georef
    if cs is None:
        cs = _cell_from_transform(transform, crs, z.shape[0]) if georef else 1.0
    hm = Heightmap(
        z=z,
        cell_size=cs,
        crs=crs.to_wkt() if crs is not None else None,
        transform=transform,
        nodata=mask if mask.any() else None,
    )
    if assumed:
        hm.notes.append(_no_cell_size(p))
    return hm


def geotiff_header(path: str | os.PathLike, cell_size: float | None = None) -> dict:
    """What a GeoTIFF's header says, no heights read: ``shape`` (rows, cols), ``transform`` (a..f),
    ``crs`` (WKT or None), ``nodata`` and ``cell_size`` (m: ``cell_size`` if given, else the file's
    ``cell_size_m`` tag, else from the transform as :func:`read` takes it, else 1 m)."""
    import rasterio
    from rasterio.errors import NotGeoreferencedWarning

    p = Path(path)
    if _format(p, "read") != "geotiff":
        raise InputError(f"'{p}' is not a GeoTIFF (.tif); convert it with `erosim convert {p.name} DEM.tif`.")
    if not p.is_file():
        raise InputError(f"Heightmap file '{p}' does not exist; check the path.")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NotGeoreferencedWarning)
            with rasterio.open(p) as ds:
                t, crs, shape, nodata = ds.transform, ds.crs, (ds.height, ds.width), ds.nodata
                tag = ds.tags().get("cell_size_m")
    except Exception as exc:  # a corrupt file: one sentence
        raise InputError(
            f"Cannot read the GeoTIFF '{p}' ({type(exc).__name__}: {exc}); is it a valid GeoTIFF?"
        ) from exc
    cs = _check_cell_size(cell_size) or (_check_cell_size(tag) if tag else None)
    georef = not t.is_identity
    if cs is None:
        cs = _cell_from_transform(tuple(t)[:6], crs, shape[0]) if georef else 1.0
    return {
        "shape": shape,
        "transform": tuple(t)[:6] if georef else None,
        "crs": crs.to_wkt() if crs is not None else None,
        "nodata": nodata,
        "cell_size": cs,
    }


def _read_png(p: Path, cs: float | None, rng) -> Heightmap:
    from PIL import Image

    with Image.open(p) as img:
        info = dict(img.info)
        mode = img.mode
        a = np.asarray(img)
    if a.ndim == 3:  # RGB(A) picture: average the colour channels, drop alpha
        a = a[..., :3].mean(axis=2)
    full = 255 if mode in ("L", "P", "RGB", "RGBA", "LA", "1") else Q16  # 8-bit pictures
    if rng is None and _PNG_RANGE_KEY in info:
        rng = _check_range(str(info[_PNG_RANGE_KEY]).split())
    if cs is None and _PNG_CELL_KEY in info:
        cs = _check_cell_size(info[_PNG_CELL_KEY])
    return _georeferenced(p, _dequantise(np.asarray(a, dtype=np.float64), rng, full), cs, rng, notes=True)


#: words of the note a reader leaves when the file holds no cell size (runs show it as an assumption)
NO_CELL_SIZE = "stores no cell size"


def _no_cell_size(p: Path) -> str:
    return f"'{p.name}' {NO_CELL_SIZE}, so 1 m was assumed; set terrain.cell_size."


def _assumptions(p: Path, rng, cs) -> list[str]:
    """What a 16-bit file without erosim's metadata leaves to assumption, in words for the report."""
    notes = []
    if rng is None:
        notes.append(
            f"'{p.name}' stores no height range, so its integer values were read as metres; "
            "set terrain.height_range = [low, high] if they stand for another range."
        )
    if cs is None:
        notes.append(_no_cell_size(p))
    return notes


def _read_raw(p: Path, cs: float | None, rng, raw_shape) -> Heightmap:
    nbytes = p.stat().st_size
    if nbytes % 2:
        raise InputError(f"RAW16 file '{p}' has an odd size ({nbytes} bytes); it is not 16-bit data.")
    n = nbytes // 2
    if raw_shape is not None:
        ny, nx = (int(v) for v in raw_shape)
        if ny * nx != n:
            raise InputError(
                f"RAW16 file '{p}' holds {n} values but raw_shape {ny}x{nx} needs {ny * nx}; "
                "give the right raw_shape (rows, cols)."
            )
    else:
        side = math.isqrt(n)
        if side * side != n:
            raise InputError(f"RAW16 file '{p}' holds {n} values, not a square map; give raw_shape = [rows, cols].")
        ny = nx = side
    q = np.fromfile(p, dtype="<u2").reshape(ny, nx)
    return _georeferenced(p, _dequantise(q, rng), cs, rng, notes=True)


def _read_asc(p: Path, cs: float | None) -> Heightmap:
    header: dict[str, float] = {}
    with open(p, encoding="ascii", errors="replace") as fh:
        while True:
            pos = fh.tell()
            line = fh.readline()
            parts = line.split()
            if len(parts) == 2 and parts[0][:1].isalpha():
                header[parts[0].lower()] = float(parts[1])
            else:
                fh.seek(pos)
                break
        missing = [k for k in ("ncols", "nrows") if k not in header]
        if "cellsize" not in header and not ("dx" in header and "dy" in header):
            missing.append("cellsize")
        if missing:
            raise InputError(f"ASCII grid '{p}' lacks header line(s) {', '.join(missing)}; is it an ESRI .asc file?")
        ny, nx = int(header["nrows"]), int(header["ncols"])
        values = np.loadtxt(fh, dtype=np.float64, ndmin=1).ravel()
    if values.size != ny * nx:
        raise InputError(f"ASCII grid '{p}' has {values.size} values but its header says {ny}x{nx}.")
    z = values.reshape(ny, nx)
    dx, dy = header.get("dx", header.get("cellsize")), header.get("dy", header.get("cellsize"))
    x0 = header["xllcorner"] if "xllcorner" in header else header.get("xllcenter", 0.5 * dx) - 0.5 * dx
    y0 = header["yllcorner"] if "yllcorner" in header else header.get("yllcenter", 0.5 * dy) - 0.5 * dy
    transform = (dx, 0.0, x0, 0.0, -dy, y0 + ny * dy)
    crs, _ = _read_sidecars(p, world=False)
    mask = None
    if "nodata_value" in header:
        mask = z == header["nodata_value"]
    return Heightmap(
        z=z,
        cell_size=cs or _cell_from_transform(transform, crs, ny),
        crs=crs.to_wkt() if crs is not None else None,
        transform=transform,
        nodata=mask if mask is not None and mask.any() else None,
    )


def _read_npz(p: Path, cs: float | None) -> Heightmap:
    with np.load(p, allow_pickle=False) as data:
        keys = list(data.keys())
        zkey = next((k for k in ("z", "elevation", "height") if k in keys), None)
        if zkey is None:
            arrays = [k for k in keys if data[k].ndim == 2]
            if not arrays:
                raise InputError(f"NPZ file '{p}' holds no 2-D array; store the heights under the key 'z'.")
            zkey = arrays[0]
        z = data[zkey]
        file_cs = float(data["cell_size"]) if "cell_size" in keys else None
        crs = str(data["crs"]) if "crs" in keys and str(data["crs"]) else None
        transform = (
            tuple(float(v) for v in data["transform"]) if "transform" in keys and data["transform"].size == 6 else None
        )
        mask = data["nodata"].astype(bool) if "nodata" in keys and data["nodata"].shape == z.shape else None
    hm = Heightmap(z=z, cell_size=cs or file_cs or 1.0, crs=crs, transform=transform, nodata=mask)
    if not (cs or file_cs):
        hm.notes.append(_no_cell_size(p))
    return hm


# ------------------------------------------------------------------------------------------ write
def write(
    path: str | os.PathLike,
    hm_or_array: Heightmap | np.ndarray,
    *,
    like: Heightmap | None = None,
    height_range: tuple[float, float] | None = None,
) -> dict:
    """Write a heightmap (or a bare array georeferenced ``like`` another map) atomically.

    Returns ``{"path", "format", "shape", "cell_size", "georeference"}`` plus ``height_range``
    [lo, hi] (m) for the 16-bit formats, so a report can say how to re-scale them, ``sidecars``
    (the .prj and world files written) and ``not_kept`` (what the format cannot hold), where any.
    """
    fmt = _format(path, "write")
    hm = _as_heightmap(hm_or_array, like)
    p = Path(path)
    info = {"path": str(p), "format": fmt, "shape": list(hm.shape), "cell_size": hm.cell_size}
    asc_corner = True
    with atomic_path(p) as tmp:
        if fmt == "geotiff":
            _write_geotiff(tmp, hm)
        elif fmt == "png16":
            info["height_range"] = list(_write_png(tmp, hm, height_range))
        elif fmt == "raw16":
            q, rng = _quantise(hm.z, height_range)
            with open(tmp, "wb") as fh:
                fh.write(q.astype("<u2").tobytes())
            info["height_range"] = list(rng)
        elif fmt == "asc":
            asc_corner = _write_asc(tmp, hm)
        elif fmt == "npy":
            with open(tmp, "wb") as fh:
                np.save(fh, _with_nan(hm))
        else:
            with open(tmp, "wb") as fh:
                np.savez_compressed(
                    fh,
                    z=hm.z,
                    cell_size=np.float64(hm.cell_size),
                    crs=np.str_(hm.crs or ""),
                    transform=np.asarray(hm.transform if hm.transform else (), dtype=np.float64),
                    nodata=hm.nodata if hm.nodata is not None else np.zeros((0, 0), bool),
                )
    sidecars = []
    if fmt in _SIDECAR_FORMATS and (fmt != "asc" or asc_corner):
        sidecars = _write_sidecars(p, hm, transform_in_file=fmt == "asc")
        if sidecars:
            info["sidecars"] = sidecars
    info["georeference"] = _georeference_note(fmt, hm, sidecars, asc_corner)
    not_kept = _not_kept(fmt, hm, info.get("height_range"), asc_corner)
    if not_kept:
        info["not_kept"] = not_kept
    return info


def _georeference_note(fmt: str, hm: Heightmap, sidecars: list[str], asc_corner: bool) -> str:
    """Where the CRS and transform went, in words for ``convert``'s summary."""
    what = " and ".join(k for k, v in (("CRS", hm.crs), ("transform", hm.transform)) if v)
    if not what:
        return "none in the source"
    if fmt in ("geotiff", "npz"):
        return f"{what} in the file"
    names = " + ".join(Path(s).name for s in sidecars)
    if fmt == "asc" and hm.transform and asc_corner:
        return "transform in the header" + (f", CRS in {names}" if names else "")
    return f"{what} in {names}" if names else "not kept"


def _not_kept(fmt: str, hm: Heightmap, rng, asc_corner: bool) -> list[str]:
    """What the format loses of this map, one phrase each."""
    lost = []
    if rng is not None:
        lost.append(f"exact heights: 65 536 levels, step {(rng[1] - rng[0]) / Q16:.3g} m")
    if fmt == "geotiff":
        lost.append("exact heights: float32, relative rounding 6e-8")
    if fmt == "raw16":
        lost.append(f"height range: give --height-range {rng[0]!r} {rng[1]!r} when reading it")
    if fmt == "raw16" and hm.shape[0] != hm.shape[1]:
        lost.append(f"shape: give --raw-shape {hm.shape[0]} {hm.shape[1]} when reading it")
    if fmt in ("raw16", "npy") and not hm.transform:
        lost.append("cell size: give --cell-size when reading it")
    if fmt in ("png16", "raw16") and hm.nodata is not None:
        lost.append(f"nodata: {int(hm.nodata.sum())} cells hold the nearest valid height")
    if fmt == "asc" and not asc_corner and (hm.crs or hm.transform):
        lost.append("georeference: ASC holds no rotated or flipped grid")
    return lost


def _with_nan(hm: Heightmap) -> np.ndarray:
    if hm.nodata is None:
        return hm.z
    return np.where(hm.nodata, np.nan, hm.z)


def _write_geotiff(tmp: Path, hm: Heightmap) -> None:
    z = hm.z.astype(np.float32)
    if hm.nodata is not None:
        z = np.where(hm.nodata, np.float32(_NODATA), z)
    _geotiff(tmp, z, hm, _NODATA if hm.nodata is not None else None)


def _geotiff(tmp: Path, band: np.ndarray, like: Heightmap, nodata) -> None:
    """One band (float32 or an integer type) on ``like``'s grid, CRS and transform, deflate-compressed."""
    import rasterio
    from rasterio.transform import Affine

    ny, nx = like.shape
    t = like.transform or default_transform(ny, nx, like.cell_size)
    floating = np.issubdtype(band.dtype, np.floating)
    profile = dict(
        driver="GTiff",
        height=ny,
        width=nx,
        count=1,
        dtype=band.dtype.name,
        transform=Affine(*t),
        crs=like.crs,
        nodata=nodata,
        compress="deflate",
        predictor=3 if floating else 2,
        tiled=nx >= 256 and ny >= 256,
    )
    if profile["tiled"]:
        profile.update(blockxsize=256, blockysize=256)
    with rasterio.open(tmp, "w", **profile) as ds:
        ds.write(band, 1)
        ds.update_tags(cell_size_m=repr(like.cell_size))


def write_raster(
    path: str | os.PathLike, array: np.ndarray, like: Heightmap, *, nodata=None, mask: np.ndarray | None = None
) -> dict:
    """Write a map of values (not heights) as a GeoTIFF on ``like``'s grid, CRS and transform, atomically.

    Floating arrays are written as float32, integer and boolean ones keep an integer type (bool →
    uint8). Cells in ``mask``, nodata cells of ``like`` and non-finite values hold ``nodata`` (default
    −9999 for float32, the type's largest value for integers: 255 for uint8), which the file declares.
    Returns ``{"path", "format", "shape", "dtype", "nodata", "nodata_cells"}``.
    """
    p = Path(path)
    if _format(p, "write") != "geotiff":
        raise InputError(f"Cannot write the map '{p}' as {p.suffix}: maps of values are GeoTIFF; name it .tif.")
    a = np.asarray(array)
    if a.shape != like.shape:
        raise InputError(f"The map for '{p}' has shape {a.shape} but the DEM {like.shape}; they must match.")
    if a.dtype == bool:
        a = a.astype(np.uint8)
    if np.issubdtype(a.dtype, np.floating):
        band = a.astype(np.float32)
        value = _NODATA if nodata is None else float(nodata)
        out = ~np.isfinite(band)
    elif np.issubdtype(a.dtype, np.integer):
        band = a.copy()
        value = int(np.iinfo(a.dtype).max if nodata is None else nodata)
        if not np.iinfo(a.dtype).min <= value <= np.iinfo(a.dtype).max:
            raise InputError(
                f"The nodata value {value} does not fit the map's type {a.dtype} for '{p}'; choose one that does."
            )
        out = np.zeros(a.shape, bool)
    else:
        raise InputError(f"The map for '{p}' holds {a.dtype} values; give numbers (float or integer).")
    if like.nodata is not None:
        out |= like.nodata
    if mask is not None:
        out |= np.asarray(mask, dtype=bool)
    if np.any(band[~out] == band.dtype.type(value)):
        raise InputError(
            f"The map for '{p}' holds the nodata value {value!r} in cells with data; choose another nodata."
        )
    band[out] = value
    with atomic_path(p) as tmp:
        _geotiff(tmp, band, like, value)
    return {
        "path": str(p),
        "format": "geotiff",
        "shape": list(a.shape),
        "dtype": band.dtype.name,
        "nodata": value,
        "nodata_cells": int(out.sum()),
    }


def _write_png(tmp: Path, hm: Heightmap, height_range) -> tuple[float, float]:
    from PIL import Image, PngImagePlugin

    q, rng = _quantise(hm.z, height_range)
    meta = PngImagePlugin.PngInfo()
    meta.add_text(_PNG_RANGE_KEY, f"{rng[0]!r} {rng[1]!r}")
    meta.add_text(_PNG_CELL_KEY, repr(hm.cell_size))
    Image.fromarray(q).save(tmp, format="PNG", pnginfo=meta)
    return rng


def _write_asc(tmp: Path, hm: Heightmap) -> bool:
    """Write the grid; True when its corner and cell size come from the map's transform."""
    ny, nx = hm.shape
    t = hm.transform
    upright = t is not None and t[1] == 0 and t[3] == 0 and t[0] > 0 and t[4] < 0
    if upright:
        dx, dy, x0, y0 = float(t[0]), float(-t[4]), float(t[2]), float(t[5] + t[4] * ny)
    else:
        dx = dy = hm.cell_size
        x0 = y0 = 0.0
    square = abs(dx - dy) <= 1e-12 * dx
    cells = [f"cellsize {dx!r}"] if square else [f"dx {dx!r}", f"dy {dy!r}"]  # dx/dy: GDAL's extension
    lines = [f"ncols {nx}", f"nrows {ny}", f"xllcorner {x0!r}", f"yllcorner {y0!r}", *cells]
    lines.append(f"NODATA_value {_NODATA!r}")
    z = hm.z if hm.nodata is None else np.where(hm.nodata, _NODATA, hm.z)
    with open(tmp, "w", encoding="ascii") as fh:
        fh.write("\n".join(lines) + "\n")
        np.savetxt(fh, z, fmt="%.17g")
    return upright or t is None


def write_png16(path: str | os.PathLike, array: np.ndarray, height_range=None) -> dict:
    """16-bit PNG of a 2-D array over ``height_range`` (default its min..max); returns the range."""
    return write(path, np.asarray(array, dtype=np.float64), height_range=height_range)


def write_mask_png16(path: str | os.PathLike, array: np.ndarray, vmax: float | None = None) -> dict:
    """A texture mask: 0..``vmax`` → 0..65535 (clipped; ``vmax`` defaults to the array's maximum).

    Returns ``{"path", "format", "shape", "vmax"}``; pixel q stands for q·vmax/65535.
    """
    a = np.asarray(array)
    if vmax is None:  # the largest value, NaN read as 0 (a block at a time, as the quantizing)
        top = max((float(np.nan_to_num(a[rows], nan=0.0).max()) for rows in _row_blocks(a)), default=0.0)
        vmax = top if top > 0 else 1.0
    if not (math.isfinite(vmax) and vmax > 0):
        raise InputError(f"Mask scale vmax={vmax!r} is not valid; it must be a positive number.")
    from PIL import Image, PngImagePlugin

    q = _q16(a, 0.0, float(vmax), nan=0.0)
    meta = PngImagePlugin.PngInfo()
    meta.add_text(_PNG_RANGE_KEY, f"0.0 {float(vmax)!r}")
    with atomic_path(path) as tmp:
        Image.fromarray(q).save(tmp, format="PNG", pnginfo=meta)
    return {"path": str(path), "format": "png16", "shape": list(a.shape), "vmax": float(vmax)}


def convert(
    src: str | os.PathLike,
    dst: str | os.PathLike,
    cell_size: float | None = None,
    *,
    raw_shape: tuple[int, int] | None = None,
    height_range: tuple[float, float] | None = None,
) -> dict:
    """Read ``src`` and write ``dst`` (formats from the extensions); returns what was written.

    ``cell_size`` overrides the source's cell size; ``raw_shape``/``height_range`` help read
    RAW16/PNG16 sources. The result is :func:`write`'s (``georeference``: where the CRS and
    transform went; ``not_kept``: what ``dst`` cannot hold) plus ``src``, the heights' min/max,
    the nodata count and ``crs``, the source's coordinate system by name (or that it names none: a
    transform alone places the grid in map units of no known system).
    """
    _format(dst, "write")  # fail before reading a large file
    hm = read(src, cell_size=cell_size, raw_shape=raw_shape, height_range=height_range)
    info = write(dst, hm)
    info.update(
        src=str(src),
        dst=str(dst),
        z_min=float(hm.z.min()),
        z_max=float(hm.z.max()),
        nodata_cells=int(hm.nodata.sum()) if hm.nodata is not None else 0,
        crs=_crs_label(hm),
    )
    return info


def _crs_label(hm: Heightmap) -> str:
    """The source's coordinate system in words: ``EPSG:32633 (WGS 84 / UTM zone 33N)`` or why none."""
    if not hm.crs:
        return "none in the source" + (" (the transform is kept, in unnamed map units)" if hm.transform else "")
    name = hm.crs.split('"')[1] if '"' in hm.crs else ""
    try:
        from rasterio.crs import CRS

        code = CRS.from_wkt(hm.crs).to_epsg()
    except Exception:  # a WKT GDAL cannot parse is still carried over as written
        code = None
    return f"EPSG:{code} ({name})" if code else name or "custom (WKT)"
