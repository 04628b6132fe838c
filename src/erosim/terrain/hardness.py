"""Hardness maps (SPEC ST-1): per-cell resistance to erosion, ``D ∈ [0, 1]`` (1 = unerodible).

Three ways to get one, as the seed (Warszawski, §4) describes — imported from data or generated per
geological material:

* :func:`load` — from a GeoTIFF (band 1), a greyscale/colour image (PNG, 8 or 16 bit) or ``.npy``.
  Floating-point rasters are taken as hardness directly; integer ones are scaled by their type's
  maximum (``uint8``/255, ``uint16``/65535), so a white pixel is unerodible rock.
* :func:`strata` — layered rock by height band: bands of thickness ``t_b`` and hardness ``D_b``
stacked
  from ``z₀`` and repeating with period ``T = Σ t_b``, on planes tilted by ``(t_x, t_y)`` m/m::

      q = (h + t_x X + t_y Y − z₀) mod T,     D = D_b  for  e_b ≤ q < e_{b+1},  e_b = Σ_{k<b} t_k

  (``X`` east, ``Y`` north, metres; the same rule as the erosion kernel uses when strata follow the
  cut).
* :func:`noise` — a smooth random field (Gaussian-filtered white noise,
:func:`scipy.ndimage.gaussian_filter`)
  rescaled to ``[low, high]``.
* :func:`classes` — a class map (integers) and a table of materials → hardness per class.

The material hardness values in :data:`MATERIALS` are relative, art-directable figures (ordered like
rock erodibility), not measured properties.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from erosim.core.errors import InputError


@dataclass(frozen=True)
class Strata:
    """Layered hardness: bands of ``thickness`` (m) and ``hardness`` from ``base`` (m), repeating,
    tilted by ``tilt_x`` (m per m eastward) and ``tilt_y`` (m per m northward)."""

    thickness: tuple[float, ...]
    hardness: tuple[float, ...]
    base: float = 0.0
    tilt_x: float = 0.0
    tilt_y: float = 0.0


def check_hardness(d: np.ndarray, shape: tuple[int, int] | None = None, what: str = "hardness map") -> np.ndarray:
    """``d`` as C-contiguous float64, or an :class:`InputError` (NaN, outside [0, 1], bad shape)."""
    d = np.asarray(d)
    if d.ndim != 2:
        raise InputError(f"The {what} must be a 2-D array, got shape {d.shape}; give one value per cell.")
    if shape is not None and d.shape != tuple(shape):
        raise InputError(
            f"The {what} has shape {d.shape} but the heightmap has {tuple(shape)}; "
            "give a hardness map of the same size (or resample it)."
        )
    d = np.ascontiguousarray(d, dtype=np.float64)
    if not np.isfinite(d).all():
        raise InputError(f"The {what} holds NaN or infinite values; fill them with a hardness in [0, 1].")
    lo, hi = float(d.min()), float(d.max())
    if lo < 0.0 or hi > 1.0:
        raise InputError(
            f"The {what} ranges {lo:g}..{hi:g} but hardness must lie in [0, 1] "
            "(0 = fully erodible, 1 = unerodible); rescale it."
        )
    return d


MATERIALS: dict[str, float] = {
    "sand": 0.05,
    "soil": 0.1,
    "gravel": 0.2,
    "clay": 0.3,
    "shale": 0.4,
    "sandstone": 0.55,
    "limestone": 0.7,
    "basalt": 0.85,
    "granite": 0.95,
    "bedrock": 1.0,
}


def load(path: str | os.PathLike, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Read a hardness map; ``shape`` (ny, nx), when given, must match (else an InputError)."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"Hardness file '{p}' does not exist; check the path (hardness.file).")
    ext = p.suffix.lower()
    try:
        if ext in (".tif", ".tiff"):
            import rasterio

            with rasterio.open(p) as src:
                raw = src.read(1, masked=True)
                a = np.asarray(raw.filled(np.nan) if np.ma.isMaskedArray(raw) and raw.mask.any() else raw.data)
        elif ext == ".npy":
            a = np.load(p, allow_pickle=False)
        else:
            from PIL import Image

            with Image.open(p) as img:
                a = np.asarray(img)
            if a.ndim == 3:  # colour: mean of the colour channels (alpha ignored)
                kind = a.dtype
                a = a[..., :3].mean(axis=2) if a.shape[2] >= 3 else a[..., 0]
                a = a.astype(np.float64) / np.iinfo(kind).max if np.issubdtype(kind, np.integer) else a
    except (OSError, ValueError) as exc:
        raise InputError(f"Hardness file '{p}' cannot be read ({exc}); give a GeoTIFF, PNG or .npy file.") from None
    if np.issubdtype(a.dtype, np.integer):
        if a.dtype.itemsize > 2 or np.issubdtype(a.dtype, np.signedinteger):
            raise InputError(
                f"Hardness file '{p}' holds {a.dtype} integers; use floats in [0, 1] or 8/16-bit unsigned pixels."
            )
        a = a.astype(np.float64) / np.iinfo(a.dtype).max
    return check_hardness(a, shape, what=f"hardness map '{p.name}'")


def strata(z: np.ndarray, cell_size: float, spec: Strata) -> np.ndarray:
    """Hardness of the stratum each cell's height lies in (tilted, repeating bands; module doc)."""
    z = np.asarray(z, dtype=np.float64)
    ny, nx = z.shape
    i = np.arange(nx, dtype=np.float64)[None, :]
    j = np.arange(ny, dtype=np.float64)[:, None]
    return np.ascontiguousarray(strata_at(z, i, j, cell_size, spec))


def strata_at(z, i, j, cell_size: float, spec: Strata) -> np.ndarray:
    """Hardness of the stratum at height ``z`` above grid position (column ``i``, row ``j``);
    arrays broadcast (e.g. a cross-section: heights × rows at one column)."""
    th = np.asarray(spec.thickness, dtype=np.float64)
    vals = np.asarray(spec.hardness, dtype=np.float64)
    if th.size == 0 or th.size != vals.size:
        raise InputError(
            f"Strata need as many thicknesses as hardness values, got {th.size} and {vals.size}; "
            "list one hardness per band."
        )
    if (th <= 0).any():
        raise InputError("Every stratum thickness must be positive (metres); fix hardness.thickness.")
    check_hardness(vals[None, :], what="strata hardness list")
    edges = np.concatenate([[0.0], np.cumsum(th)[:-1]])
    period = float(th.sum())
    # same arithmetic, in the same order, as the kernel's _band (so both agree to the bit)
    tx, ty = spec.tilt_x * cell_size, -spec.tilt_y * cell_size
    q = np.asarray(z, dtype=np.float64) + tx * i + ty * j - spec.base
    q = q - period * np.floor(q * (1.0 / period))
    band = np.searchsorted(edges, q, side="right") - 1
    return vals[np.clip(band, 0, vals.size - 1)]


def noise(shape: tuple[int, int], seed: int, scale: float = 16.0, low: float = 0.0, high: float = 1.0) -> np.ndarray:
    """Smooth random hardness in ``[low, high]``: white noise blurred with σ = ``scale`` cells."""
    if not 0.0 <= low <= high <= 1.0:
        raise InputError(f"Noise hardness range {low:g}..{high:g} is not within [0, 1]; use 0 <= low <= high <= 1.")
    if scale <= 0:
        raise InputError(f"Noise scale {scale:g} cells must be positive; give the feature size in cells.")
    rng = np.random.default_rng(seed)
    f = ndimage.gaussian_filter(rng.standard_normal(shape), sigma=scale, mode="wrap")
    span = f.max() - f.min()
    f = (f - f.min()) / span if span > 0 else np.zeros(shape)
    return np.ascontiguousarray(low + (high - low) * f)


def classes(class_map: np.ndarray, materials: dict[int, str | float]) -> np.ndarray:
    """Hardness from an integer class map and a table class → material name or hardness value.

    Material names are those of :data:`MATERIALS`."""
    cm = np.asarray(class_map)
    if not np.issubdtype(cm.dtype, np.integer):
        raise InputError(f"A class map must hold integer classes, got {cm.dtype}; save it as an integer raster.")
    out = np.full(cm.shape, np.nan)
    for cls, mat in materials.items():
        if isinstance(mat, str):
            if mat not in MATERIALS:
                raise InputError(f"Unknown material '{mat}' for class {cls}; use one of: {', '.join(MATERIALS)}.")
            val = MATERIALS[mat]
        else:
            val = float(mat)
        out[cm == int(cls)] = val
    missing = np.unique(cm[np.isnan(out)])
    if missing.size:
        raise InputError(f"Class map values {missing[:5].tolist()} have no material; add them to the materials table.")
    return check_hardness(out, what="class-map hardness")
