"""Windowed GeoTIFF reads and writes of a tiled build: a tile's input cut from the DEM, the blended
mosaic of one map written core by core, Cloud-Optimized GeoTIFFs. Every step holds at most a
tile's window (and GDAL's block cache, capped at :data:`GDAL_CACHE_MB`) in memory."""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from erosim.core.atomic import atomic_path
from erosim.tiles.plan import Tile, covering, weights

NODATA = -9999.0  # what the mosaics write where no tile has data (the value erosim's maps use)
GDAL_CACHE_MB = 256
BLOCK = 256


@contextlib.contextmanager
def gdal_env() -> Iterator[None]:
    """rasterio's environment with GDAL's block cache capped (GDAL's default is 5 % of the RAM)."""
    import rasterio
    from rasterio.errors import NotGeoreferencedWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with rasterio.Env(GDAL_CACHEMAX=GDAL_CACHE_MB):
            yield


def _window(rect: tuple[int, int, int, int]):
    from rasterio.windows import Window

    r0, r1, c0, c1 = rect
    return Window(c0, r0, c1 - c0, r1 - r0)


def read_window(path: Path, rect: tuple[int, int, int, int]) -> np.ndarray:
    """Band 1 of ``path`` over ``rect`` (row0, row1, col0, col1) as float64, NaN where nodata."""
    import rasterio

    with gdal_env(), rasterio.open(path) as ds:
        band = ds.read(1, window=_window(rect), masked=True)
    z = np.ma.getdata(band).astype(np.float64)
    z[np.ma.getmaskarray(band)] = np.nan
    return z


def cut(source: Path, tile: Tile, dst: Path, cell_size: float) -> None:
    """Write ``tile``'s window of ``source`` as its own GeoTIFF (the window's transform, the CRS and
    nodata kept, ``cell_size_m`` tagged so every tile has the DEM's cell size), atomically."""
    import rasterio
    from rasterio.windows import transform as window_transform

    with gdal_env(), rasterio.open(source) as ds:
        win = _window(tile.window)
        band = ds.read(1, window=win).astype(np.float32)
        profile = dict(
            driver="GTiff", height=band.shape[0], width=band.shape[1], count=1, dtype="float32", crs=ds.crs,
            transform=window_transform(win, ds.transform), nodata=ds.nodata, compress="deflate", predictor=3,
        )  # fmt: skip
        with atomic_path(dst) as tmp, rasterio.open(tmp, "w", **profile) as out:
            out.write(band, 1)
            out.update_tags(cell_size_m=repr(float(cell_size)))


def grid_profile(source: Path) -> dict:
    """The grid, CRS and transform of ``source``, as a float32 profile for the mosaics."""
    import rasterio

    with gdal_env(), rasterio.open(source) as ds:
        return dict(height=ds.height, width=ds.width, crs=ds.crs, transform=ds.transform)


def _scratch_profile(grid: dict) -> dict:
    """An uncompressed tiled GeoTIFF: windows written in any order do not grow the file."""
    tiled = grid["width"] >= BLOCK and grid["height"] >= BLOCK
    extra = dict(blockxsize=BLOCK, blockysize=BLOCK) if tiled else {}
    return dict(driver="GTiff", count=1, dtype="float32", nodata=NODATA, tiled=tiled, **extra, **grid)


def to_cog(scratch: Path, dst: Path) -> None:
    """``scratch`` copied into a Cloud-Optimized GeoTIFF ``dst`` (deflate, overviews), atomically;
    GDAL's COG driver reads the source block by block."""
    from rasterio.shutil import copy

    with gdal_env(), atomic_path(dst) as tmp:
        copy(scratch, tmp, driver="COG", compress="DEFLATE", predictor="YES", blocksize=BLOCK)


def write_by_cores(
    tiles: list[Tile], grid: dict, dst: Path, compute: Callable[[Tile], np.ndarray], cog: bool = True
) -> None:
    """Write ``dst`` on ``grid`` core by core: ``compute(tile)`` gives the values over ``tile.core``
    (NaN = nodata); a COG when ``cog``, else a tiled GeoTIFF."""
    import rasterio

    dst.parent.mkdir(parents=True, exist_ok=True)
    scratch = dst.with_name(f".{dst.stem}.scratch.tif")
    try:
        with gdal_env(), rasterio.open(scratch, "w", **_scratch_profile(grid)) as out:
            for t in tiles:
                v = compute(t).astype(np.float32)
                v[~np.isfinite(v)] = NODATA
                out.write(v, 1, window=_window(t.core))
        if cog:
            to_cog(scratch, dst)
        else:
            with atomic_path(dst) as tmp:
                os.replace(scratch, tmp)
    finally:
        scratch.unlink(missing_ok=True)


def blend(tiles: list[Tile], overlap: int, path_of: Callable[[Tile], Path], core: Tile) -> np.ndarray:
    """(Not used by the build since tiles pass droplets across borders: the mosaics take each tile's core.)
    The feathered blend (:func:`erosim.tiles.plan.weights`) over ``core``'s core of the map that
    ``path_of(tile)`` holds for every tile: Σ wᵢ·vᵢ / Σ wᵢ over the tiles with data, NaN where none."""
    r0, r1, c0, c1 = core.core
    num = np.zeros((r1 - r0, c1 - c0))
    den = np.zeros_like(num)
    for t, part in covering(tiles, core.core):
        wr0, _, wc0, _ = t.window
        local = (part[0] - wr0, part[1] - wr0, part[2] - wc0, part[3] - wc0)
        v = read_window(path_of(t), local)
        w = weights(t, overlap)[local[0] : local[1], local[2] : local[3]]
        w = np.where(np.isfinite(v), w, 0.0)
        sl = (slice(part[0] - r0, part[1] - r0), slice(part[2] - c0, part[3] - c0))
        num[sl] += w * np.nan_to_num(v)
        den[sl] += w
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, np.nan)
