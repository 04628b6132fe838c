"""Procedural terrains: fractal Brownian motion, ridged multifractal and domain-warped noise.

Every parameter is in physical units (metres): noise is evaluated at the **physical position** of
each cell centre, x = x₀ + (ix + ½)·Δ, y = y₀ + (iy + ½)·Δ, so the same seed gives the same
landscape at any resolution — 256² cells of 2 m and 512² cells of 1 m sample one and the same
surface (SPEC HY-6; the hydrology resolution-independence test relies on it).

Base noise: OpenSimplex2 gradient noise from FastNoise Lite (``pyfastnoiselite``, a maintained
Cython wrapper), one octave per call. The octave sums are done here in NumPy so that their
normalisation does not depend on the octave count (FastNoise Lite's own fractal mode divides by the
finite sum Σ gᵏ, which would rescale the large features when finer octaves are added):

* fBm (Musgrave 2003): n(p) = (1 − g) Σ_{k<K} gᵏ N_k(λᵏ p / L), with gain g, lacunarity λ,
  wavelength L; |n| ≲ 1. Height fraction u = ½ + ½·n/σ with σ = 0.65 (the 99th percentile
  of |n|, so u spans ≈ 0..1).
* ridged multifractal (Musgrave 2003): s_k = (1 − |N_k|)²·w_k, w₀ = 1, w_{k+1} = clamp(2 s_k, 0, 1);
  r = (1 − g) Σ gᵏ s_k; u = r/0.75 (its 99th percentile) — sharp crests, smooth valleys;
  ``ridge_mix`` m < 1 blends u ← m·u + (1 − m)·u_fBm with an independent fBm (massifs and crests).
* domain warp (Quílez 2002): p' = p + A·(n_a(p/L_w), n_b(p/L_w)) with two independent fBm fields
  and amplitude A in metres, then the base noise at p'.

Shaping of u ∈ ~[0, 1] into heights: u ← max(u, 0)^exponent (flatter valleys for exponent > 1);
optional mesa shaping for plateaus, u ← (1−d)·S(u) + d·u with S a logistic step of the given
sharpness at ``plateau_level`` rescaled to [0, 1]; z = base + relief·u.

Closed basins: ``fill_slope`` s > 0 fills every closed basin to its spill level as a plain falling at
s toward the spill point (:mod:`erosim.terrain.priority_flood_barnes2014`), so that all water can
reach the map's edge, as in a landscape whose rivers have had time to fill their basins.

Octaves: ``octaves = 0`` (auto) adds octaves until the finest wavelength L/λ^{K−1} reaches two
cells; a fixed count makes two resolutions bit-identical at every common point.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import model_validator
from pyfastnoiselite.pyfastnoiselite import FastNoiseLite, FractalType, NoiseType

from erosim.core.config import Section, param, validate_section
from erosim.core.errors import ConfigError
from erosim.core.heightmap import Heightmap
from erosim.terrain.priority_flood_barnes2014 import fill_basins

KINDS = ("fbm", "ridged", "warped")

#: Named presets: partial parameter sets on top of :class:`NoiseParams`' defaults.
PRESETS: dict[str, dict] = {
    "hills": dict(kind="fbm", wavelength=2000.0, relief=150.0, gain=0.42, exponent=1.4),
    "mountains": dict(
        kind="ridged",
        wavelength=3000.0,
        relief=900.0,
        gain=0.5,
        exponent=1.1,
        ridge_mix=0.5,
        warp_strength=250.0,
        warp_wavelength=2500.0,
    ),
    "plateau": dict(
        kind="warped",
        wavelength=2500.0,
        relief=300.0,
        gain=0.45,
        exponent=1.0,
        warp_strength=300.0,
        warp_wavelength=2000.0,
        plateau_level=0.5,
        plateau_sharpness=14.0,
        plateau_detail=0.12,
    ),
}

#: 99th percentile of |n| of the normalised sums (measured over 64 x 64 wavelengths, 10 octaves),
#: so that u spans about 0..1 over a large map.
_SPREAD_FBM = 0.65
_SPREAD_RIDGED = 0.75
_CHUNK = 1 << 20  # points per evaluation block: bounds memory for very large maps


class NoiseParams(Section):
    """Parameters of a generated terrain (all lengths in metres)."""

    kind: Literal["fbm", "ridged", "warped"] = param("fbm", doc="noise kind: fbm | ridged | warped")
    wavelength: float = param(2000.0, gt=0, unit="m", doc="wavelength of the largest features")
    relief: float = param(200.0, ge=0, unit="m", doc="height scale: heights span about base..base+relief")
    base: float = param(0.0, unit="m", doc="height of the lowest ground")
    octaves: int = param(0, ge=0, le=24, unit="1", doc="octaves; 0 = until the finest wavelength is 2 cells")
    lacunarity: float = param(2.0, gt=1, le=4, unit="1", doc="wavelength ratio between octaves")
    gain: float = param(0.5, gt=0, lt=1, unit="1", doc="amplitude ratio between octaves")
    exponent: float = param(1.0, gt=0, le=8, unit="1", doc="height redistribution u**exponent")
    ridge_mix: float = param(
        1.0, ge=0, le=1, unit="1", doc="ridged kind: share of ridged noise, the rest independent fBm"
    )
    warp_strength: float = param(0.0, ge=0, unit="m", doc="domain-warp displacement amplitude")
    warp_wavelength: float = param(2000.0, gt=0, unit="m", doc="wavelength of the warp field")
    plateau_level: float = param(0.0, ge=0, le=1, unit="1", doc="mesa step height fraction (0 = off)")
    plateau_sharpness: float = param(12.0, gt=0, le=100, unit="1", doc="steepness of the mesa escarpments")
    plateau_detail: float = param(0.1, ge=0, le=1, unit="1", doc="share of the raw noise kept on mesas")
    offset_x: float = param(0.0, unit="m", doc="x of the map's west edge in the noise world")
    offset_y: float = param(0.0, unit="m", doc="y of the map's north edge in the noise world")
    fill_slope: float = param(
        0.0, ge=0, le=0.1, unit="m/m",
        doc="fill closed basins to their spill level, falling at this slope toward it (Barnes 2014); 0 = off",
    )  # fmt: skip

    @model_validator(mode="after")
    def _warped_needs_warp(self) -> NoiseParams:
        if self.kind == "warped" and self.warp_strength == 0.0:
            object.__setattr__(self, "warp_strength", 0.2 * self.wavelength)
        return self


NOISE_KEYS = tuple(NoiseParams.model_fields)


def _seeds(seed: int, n: int) -> list[int]:
    """``n`` independent non-negative int32 seeds derived from ``seed`` (NumPy SeedSequence)."""
    state = np.random.SeedSequence(int(seed) & 0xFFFFFFFFFFFFFFFF).generate_state(n)
    return [int(s) & 0x3FFFFFFF for s in state]


def _octave(seed: int, px: np.ndarray, py: np.ndarray, freq: float) -> np.ndarray:
    """One octave of OpenSimplex2 noise in [−1, 1] at points (px, py)·freq (dimensionless)."""
    f = FastNoiseLite(seed)
    f.noise_type = NoiseType.NoiseType_OpenSimplex2
    f.fractal_type = FractalType.FractalType_None
    f.frequency = 1.0
    coords = np.empty((2, px.size), dtype=np.float32)
    coords[0] = px * freq
    coords[1] = py * freq
    return np.asarray(f.gen_from_coords(coords), dtype=np.float64)


def _fbm(seed: int, px, py, octaves: int, lac: float, gain: float) -> np.ndarray:
    out = np.zeros(px.size)
    amp, freq = 1.0, 1.0
    for k in range(octaves):
        out += amp * _octave(seed + k, px, py, freq)
        amp *= gain
        freq *= lac
    return (1.0 - gain) * out


def _ridged(seed: int, px, py, octaves: int, lac: float, gain: float) -> np.ndarray:
    out = np.zeros(px.size)
    weight = np.ones(px.size)
    amp, freq = 1.0, 1.0
    for k in range(octaves):
        s = (1.0 - np.abs(_octave(seed + k, px, py, freq))) ** 2 * weight
        out += amp * s
        np.clip(2.0 * s, 0.0, 1.0, out=weight)
        amp *= gain
        freq *= lac
    return (1.0 - gain) * out


def auto_octaves(p: NoiseParams, cell_size: float) -> int:
    """Octave count K with the finest wavelength L/λ^{K−1} ≥ 2 cells (at least 1, at most 16)."""
    if p.octaves:
        return p.octaves
    ratio = p.wavelength / (2.0 * cell_size)
    if ratio <= 1.0:
        return 1
    return int(min(16, 1 + math.floor(math.log(ratio) / math.log(p.lacunarity))))


def height_fraction(p: NoiseParams, seed: int, x: np.ndarray, y: np.ndarray, octaves: int) -> np.ndarray:
    """Shaped height fraction u (≈ 0..1) at physical points x, y (m), before scaling by relief."""
    s_base, s_wx, s_wy = _seeds(seed, 3)
    if p.warp_strength > 0:
        wk = max(1, min(octaves, 4))
        wx = _fbm(s_wx, x / p.warp_wavelength, y / p.warp_wavelength, wk, p.lacunarity, p.gain)
        wy = _fbm(s_wy, x / p.warp_wavelength, y / p.warp_wavelength, wk, p.lacunarity, p.gain)
        x = x + p.warp_strength * wx / _SPREAD_FBM
        y = y + p.warp_strength * wy / _SPREAD_FBM
    px, py = x / p.wavelength, y / p.wavelength
    if p.kind == "ridged":
        u = _ridged(s_base, px, py, octaves, p.lacunarity, p.gain) / _SPREAD_RIDGED
        if p.ridge_mix < 1.0:  # blend with an independent fBm: massifs as well as crests
            fb = _fbm(s_base + 1000, px, py, octaves, p.lacunarity, p.gain) / _SPREAD_FBM
            u = p.ridge_mix * u + (1.0 - p.ridge_mix) * (0.5 + 0.5 * fb)
    else:
        u = 0.5 + 0.5 * _fbm(s_base, px, py, octaves, p.lacunarity, p.gain) / _SPREAD_FBM
    u = np.maximum(u, 0.0) ** p.exponent
    if p.plateau_level > 0:
        k, c = p.plateau_sharpness, p.plateau_level
        lo, hi = 1.0 / (1.0 + math.exp(k * c)), 1.0 / (1.0 + math.exp(-k * (1.0 - c)))
        step = (1.0 / (1.0 + np.exp(-k * (u - c))) - lo) / (hi - lo)
        u = (1.0 - p.plateau_detail) * step + p.plateau_detail * u
    return u


def resolve(preset_or_kind: str, overrides: dict | None = None, where: str = "terrain") -> NoiseParams:
    """Validated parameters: a preset (or bare kind) with ``overrides`` on top."""
    name = str(preset_or_kind).strip().lower()
    if name in PRESETS:
        data = dict(PRESETS[name])
    elif name in KINDS:
        data = {"kind": name}
    else:
        import difflib

        choices = sorted(PRESETS) + list(KINDS)
        near = difflib.get_close_matches(name, choices, n=1)
        hint = f"did you mean '{near[0]}'? " if near else ""
        raise ConfigError(f"Unknown terrain preset '{preset_or_kind}': {hint}choose one of {', '.join(choices)}.")
    data.update({k: v for k, v in (overrides or {}).items() if v is not None})
    return validate_section(NoiseParams, data, where)


def generate(
    preset_or_kind: str = "hills", size: int | tuple[int, int] = 256, cell_size: float = 2.0, seed: int = 0, **overrides
) -> Heightmap:
    """A generated :class:`Heightmap` of ``size`` cells (int or (ny, nx)) of ``cell_size`` metres.

    ``preset_or_kind`` is a preset (``hills``, ``mountains``, ``plateau``) or a noise kind
    (``fbm``, ``ridged``, ``warped``); ``overrides`` are :class:`NoiseParams` fields.
    """
    ny, nx = (size, size) if np.isscalar(size) else tuple(size)
    if int(ny) < 2 or int(nx) < 2 or int(ny) != ny or int(nx) != nx:
        raise ConfigError(f"Terrain size {size!r} is not valid; give at least 2 cells per side, e.g. 256.")
    ny, nx = int(ny), int(nx)
    if not (isinstance(cell_size, (int, float)) and math.isfinite(cell_size) and cell_size > 0):
        raise ConfigError(f"Cell size {cell_size!r} m is not valid; it must be a positive number of metres.")
    p = resolve(preset_or_kind, overrides)
    octaves = auto_octaves(p, float(cell_size))
    xs = p.offset_x + (np.arange(nx) + 0.5) * cell_size
    z = np.empty((ny, nx))
    rows = max(1, _CHUNK // nx)
    for r0 in range(0, ny, rows):
        r1 = min(ny, r0 + rows)
        ys = p.offset_y + (np.arange(r0, r1) + 0.5) * cell_size
        X, Y = np.meshgrid(xs, ys)
        u = height_fraction(p, seed, X.ravel(), Y.ravel(), octaves)
        z[r0:r1] = (p.base + p.relief * u).reshape(r1 - r0, nx)
    if p.fill_slope > 0:

        z = fill_basins(z, float(cell_size), p.fill_slope)
    return Heightmap(z=z, cell_size=float(cell_size))
