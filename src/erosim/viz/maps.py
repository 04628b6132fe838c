"""Map pictures: hillshade, shaded relief, the combined hydrology map (SPEC HY-9), colour maps.

Arrays follow the heightmap convention (``z[iy, ix]``, row 0 = north). Pictures are float RGB in
[0, 1] with shape (ny, nx, 3) until :func:`save_png` writes them as 8-bit PNG (atomically).

Hillshade (the ESRI/Horn formula with the light as a unit vector): with x east, y north, z up,
n = (−∂z/∂x, −∂z/∂y, 1)/‖·‖ from central differences (``numpy.gradient``), the light
L = (sin A·cos h, cos A·cos h, sin h) for azimuth A (clockwise from north) and altitude h, and
shade = max(0, n·L). It is absolute (not contrast-stretched), so before/after pictures compare.
"""

from __future__ import annotations

import os

import numpy as np

from erosim.core.atomic import atomic_path

LIGHT_BLUE = np.array([0.55, 0.80, 1.00])
DARK_BLUE = np.array([0.05, 0.20, 0.55])
FOREST = np.array([0.13, 0.36, 0.15])
GROUND = np.array([0.78, 0.72, 0.60])


def hillshade(z: np.ndarray, cell_size: float, azimuth: float = 315.0, altitude: float = 45.0) -> np.ndarray:
    """Illumination in [0, 1] of the surface ``z`` (m) lit from ``azimuth``/``altitude`` (deg)."""
    z = np.asarray(z, dtype=np.float64)
    if min(z.shape) < 2:
        return np.full(z.shape, np.sin(np.radians(altitude)))
    d_row, d_col = np.gradient(z, cell_size)
    dzdx, dzdy = d_col, -d_row  # rows run southward: ∂z/∂north = −∂z/∂row
    a, h = np.radians(azimuth), np.radians(altitude)
    lx, ly, lz = np.sin(a) * np.cos(h), np.cos(a) * np.cos(h), np.sin(h)
    shade = (-dzdx * lx - dzdy * ly + lz) / np.sqrt(dzdx * dzdx + dzdy * dzdy + 1.0)
    return np.clip(shade, 0.0, 1.0)


def _to_uint8(img: np.ndarray) -> np.ndarray:
    a = np.asarray(img)
    if a.dtype == np.uint8:
        return a
    a = np.nan_to_num(a.astype(np.float64), nan=0.0)
    return np.clip(np.rint(a * 255.0), 0, 255).astype(np.uint8)


def save_png(path: str | os.PathLike, rgb_or_gray: np.ndarray) -> str:
    """Write a float picture in [0, 1] (or uint8), gray (ny, nx) or RGB(A) (ny, nx, 3|4), as PNG."""
    from PIL import Image

    a = _to_uint8(rgb_or_gray)
    if a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[2] not in (3, 4)):
        raise ValueError(f"save_png needs a (ny, nx) or (ny, nx, 3|4) array, got shape {a.shape}")
    with atomic_path(path) as tmp:
        Image.fromarray(a).save(tmp, format="PNG", optimize=False)
    return str(path)


def shaded_relief(
    z: np.ndarray, cell_size: float, cmap: str = "gist_earth", vmin=None, vmax=None, ambient: float = 0.35
) -> np.ndarray:
    """Hypsometric tint (``cmap`` from 0.3 to 0.95 over vmin..vmax) times a softened hillshade."""
    import matplotlib

    z = np.asarray(z, dtype=np.float64)
    lo = float(np.min(z)) if vmin is None else vmin
    hi = float(np.max(z)) if vmax is None else vmax
    t = (z - lo) / (hi - lo) if hi > lo else np.zeros_like(z)
    tint = matplotlib.colormaps[cmap](np.clip(0.3 + 0.65 * t, 0, 1))[..., :3]
    shade = ambient + (1.0 - ambient) * hillshade(z, cell_size)
    return np.clip(tint * shade[..., None], 0.0, 1.0)


def ease_out(x: np.ndarray, power: float = 2.0) -> np.ndarray:
    """1 − (1 − x)^power on x clipped to [0, 1]: faint flows stay visible, strong ones saturate."""
    return 1.0 - (1.0 - np.clip(x, 0.0, 1.0)) ** power


def hydrology_map(
    z: np.ndarray,
    cell_size: float,
    stream: np.ndarray,
    lake_depth: np.ndarray,
    *,
    vegetation: np.ndarray | None = None,
    stream_gain: float = 1.0,
    stream_threshold: float | None = None,
    lake_depth_ref: float | None = None,
) -> np.ndarray:
    """Combined hydrology picture (HY-9): hillshaded ground, streams light blue, lakes dark blue.

    The relief is shaded on the water surface z + lake_depth, so lakes show flat.

    Streams: α_s = ease_out(gain·stream) (set to 0 below ``stream_threshold`` when given); lakes:
    α_l = 0.55 + 0.45·min(1, depth/depth_ref) where depth > 0 (depth_ref defaults to the 95th
    percentile of lake depth); ``vegetation`` density in [0, 1] tints the ground forest green.
    """
    z = np.asarray(z, dtype=np.float64)
    d = np.clip(np.nan_to_num(np.asarray(lake_depth, dtype=np.float64), nan=0.0), 0.0, None)
    shade = 0.3 + 0.7 * hillshade(z + d, cell_size)  # the water layer: lakes are shaded flat
    ground = np.broadcast_to(GROUND, z.shape + (3,)).copy()
    if vegetation is not None:
        v = np.clip(np.asarray(vegetation, dtype=np.float64), 0.0, 1.0)[..., None]
        ground = (1.0 - 0.8 * v) * ground + 0.8 * v * FOREST
    rgb = ground * shade[..., None]
    s = np.clip(stream_gain * np.asarray(stream, dtype=np.float64), 0.0, 1.0)
    if stream_threshold is not None:
        s = np.where(s >= stream_threshold, s, 0.0)
    a_s = ease_out(s)[..., None]
    rgb = (1.0 - a_s) * rgb + a_s * LIGHT_BLUE * (0.6 + 0.4 * shade[..., None])
    wet = d > 0
    if wet.any():
        ref = lake_depth_ref or float(np.percentile(d[wet], 95)) or 1.0
        a_l = np.where(wet, 0.55 + 0.45 * np.minimum(1.0, d / ref), 0.0)[..., None]
        rgb = (1.0 - a_l) * rgb + a_l * DARK_BLUE * (0.75 + 0.25 * shade[..., None])
    return np.clip(rgb, 0.0, 1.0)


def colormap(array: np.ndarray, cmap: str = "viridis", vmin=None, vmax=None, symmetric: bool = False) -> np.ndarray:
    """RGB picture of ``array`` through a matplotlib colour map (NaN drawn gray).

    ``symmetric`` centres the scale on zero (for erosion − deposition differences).
    """
    import matplotlib

    a = np.asarray(array, dtype=np.float64)
    finite = a[np.isfinite(a)]
    if symmetric:
        m = float(np.max(np.abs(finite))) if finite.size else 1.0
        vmin, vmax = (-m, m) if vmin is None and vmax is None else (vmin, vmax)
    lo = (float(finite.min()) if finite.size else 0.0) if vmin is None else vmin
    hi = (float(finite.max()) if finite.size else 1.0) if vmax is None else vmax
    t = (a - lo) / (hi - lo) if hi > lo else np.zeros_like(a)
    rgb = matplotlib.colormaps[cmap](np.clip(np.nan_to_num(t, nan=0.0), 0, 1))[..., :3]
    rgb[~np.isfinite(a)] = 0.5
    return rgb


def colormap_png(path: str | os.PathLike, array: np.ndarray, cmap: str = "viridis", **kwargs) -> str:
    """Write ``array`` through a matplotlib colour map as PNG (see :func:`colormap` for options)."""
    return save_png(path, colormap(array, cmap, **kwargs))
