"""SPH smoothing kernels as scalar Numba functions of the distance r and the support radius h.

Every kernel is zero for r ≥ h (h is the *support radius*, the seeds' h). For each kernel family and
dimension there are three scalar functions, all ``@njit(inline="always", cache=True)``:

* ``w(r, h)``   the kernel value W(r, h);
* ``f(r, h)``   the gradient factor: ∇W(r⃗, h) = f(|r⃗|, h) · r⃗ (so ∇_i W_ij = f · (r_i − r_j));
* ``lap(r, h)`` the viscosity Laplacian weight L ≥ 0 used as ∇²A_i ≈ Σ_j V_j (A_j − A_i) L(r_ij).

Families
--------
Müller et al. (2003), SPEC SPH-2 (seed 000 eq. 1.16–1.20):
  W_poly6 = 315/(64π h⁹)(h² − r²)³       [2-D: 4/(π h⁸)]                 — density (``w``)
  ∇W_spiky = −45/(π h⁶)(h − r)² r⃗/r       [2-D: −30/(π h⁵)]               — gradient (``f``)
  ∇²W_visc = 45/(π h⁶)(h − r)             [2-D: 40/(π h⁵)]                — Laplacian (``lap``)
  The 2-D poly6 and spiky constants of SPEC SPH-2 were checked against ∫W dA = 1 and are correct.
  The seed gives no 2-D viscosity Laplacian; its constant here, 40/(π h⁵), is the one for which
  Σ V_j (A_j − A_i) L reproduces ∇²A exactly for quadratic A — the same property that gives
  Müller's 45/(π h⁶) in 3-D. At r = 0 the spiky gradient direction is undefined: f is set to 0
  there (deterministic and antisymmetric, SPEC SPH-2 allows it).
Wendland C2 (Wendland 1995; Dehnen & Aly 2012), s = r/h:
  W = σ (1 − s)⁴ (1 + 4s),  σ = 7/(π h²) in 2-D, 21/(2π h³) in 3-D;  f = −20σ/h² (1 − s)³.
  lap is Brookshaw's (1985) estimate L = −2 f r²/(r² + 0.01 (h/2)²) (Morris et al. 1997).

``kernel_w`` / ``kernel_grad`` / ``kernel_lap`` are plain NumPy-callable helpers over arrays (for
probes and tests); the solver picks the scalar functions by name with :func:`kernel_functions`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_ETA2 = 0.0025  # (0.05 h)²/h² = 0.01 (h/2)² / h²: keeps Brookshaw's weight finite at r → 0

# ---------------------------------------------------------------- Müller et al. 2003, 3-D


@njit(inline="always", cache=True)
def muller_w_3d(r, h):
    """W_poly6 (3-D) = 315/(64π h⁹) (h² − r²)³."""
    if r >= h:
        return 0.0
    d = h * h - r * r
    return 315.0 / (64.0 * math.pi * h**9) * d * d * d


@njit(inline="always", cache=True)
def muller_f_3d(r, h):
    """∇W_spiky (3-D) = f r⃗ with f = −45/(π h⁶) (h − r)²/r (0 at r = 0)."""
    if r >= h or r <= 1e-12 * h:
        return 0.0
    d = h - r
    return -45.0 / (math.pi * h**6) * d * d / r


@njit(inline="always", cache=True)
def muller_lap_3d(r, h):
    """∇²W_visc (3-D) = 45/(π h⁶)(h − r)."""
    if r >= h:
        return 0.0
    return 45.0 / (math.pi * h**6) * (h - r)


# ---------------------------------------------------------------- Müller et al. 2003, 2-D


@njit(inline="always", cache=True)
def muller_w_2d(r, h):
    """W_poly6 (2-D) = 4/(π h⁸) (h² − r²)³."""
    if r >= h:
        return 0.0
    d = h * h - r * r
    return 4.0 / (math.pi * h**8) * d * d * d


@njit(inline="always", cache=True)
def muller_f_2d(r, h):
    """∇W_spiky (2-D) = f r⃗ with f = −30/(π h⁵) (h − r)²/r (0 at r = 0)."""
    if r >= h or r <= 1e-12 * h:
        return 0.0
    d = h - r
    return -30.0 / (math.pi * h**5) * d * d / r


@njit(inline="always", cache=True)
def muller_lap_2d(r, h):
    """Viscosity Laplacian (2-D) = 40/(π h⁵)(h − r) (exact for quadratic fields)."""
    if r >= h:
        return 0.0
    return 40.0 / (math.pi * h**5) * (h - r)


# ---------------------------------------------------------------- Wendland C2


@njit(inline="always", cache=True)
def wendland_w_3d(r, h):
    """Wendland C2 (3-D): 21/(2π h³) (1 − s)⁴ (1 + 4s), s = r/h."""
    if r >= h:
        return 0.0
    s = r / h
    d = 1.0 - s
    return 21.0 / (2.0 * math.pi * h**3) * d * d * d * d * (1.0 + 4.0 * s)


@njit(inline="always", cache=True)
def wendland_f_3d(r, h):
    """Wendland C2 (3-D) gradient factor: −20·21/(2π h⁵) (1 − s)³."""
    if r >= h:
        return 0.0
    d = 1.0 - r / h
    return -210.0 / (math.pi * h**5) * d * d * d


@njit(inline="always", cache=True)
def wendland_lap_3d(r, h):
    """Brookshaw Laplacian weight of Wendland C2 (3-D): −2 f r²/(r² + η²)."""
    if r >= h:
        return 0.0
    r2 = r * r
    return -2.0 * wendland_f_3d(r, h) * r2 / (r2 + _ETA2 * h * h)


@njit(inline="always", cache=True)
def wendland_w_2d(r, h):
    """Wendland C2 (2-D): 7/(π h²) (1 − s)⁴ (1 + 4s), s = r/h."""
    if r >= h:
        return 0.0
    s = r / h
    d = 1.0 - s
    return 7.0 / (math.pi * h**2) * d * d * d * d * (1.0 + 4.0 * s)


@njit(inline="always", cache=True)
def wendland_f_2d(r, h):
    """Wendland C2 (2-D) gradient factor: −20·7/(π h⁴) (1 − s)³."""
    if r >= h:
        return 0.0
    d = 1.0 - r / h
    return -140.0 / (math.pi * h**4) * d * d * d


@njit(inline="always", cache=True)
def wendland_lap_2d(r, h):
    """Brookshaw Laplacian weight of Wendland C2 (2-D): −2 f r²/(r² + η²)."""
    if r >= h:
        return 0.0
    r2 = r * r
    return -2.0 * wendland_f_2d(r, h) * r2 / (r2 + _ETA2 * h * h)


_TABLE = {
    ("muller", 2): (muller_w_2d, muller_f_2d, muller_lap_2d),
    ("muller", 3): (muller_w_3d, muller_f_3d, muller_lap_3d),
    ("wendland", 2): (wendland_w_2d, wendland_f_2d, wendland_lap_2d),
    ("wendland", 3): (wendland_w_3d, wendland_f_3d, wendland_lap_3d),
}


def kernel_functions(kernel: str, dim: int):
    """``(w, f, lap)`` scalar Numba functions of the named kernel (``"muller"``/``"wendland"``) in ``dim``-D."""
    try:
        return _TABLE[(kernel, int(dim))]
    except KeyError:
        raise ValueError(f"unknown kernel {kernel!r} in {dim}-D; use 'muller' or 'wendland' with dim 2 or 3") from None


# ---------------------------------------------------------------- NumPy-callable helpers


@njit  # not cached: Numba cannot cache functions that take functions as arguments
def _apply_scalar(fn, r, h, out):
    for i in range(r.size):
        out[i] = fn(r[i], h)


def _values(which: int, r, h: float, dim: int, kernel: str) -> np.ndarray:
    fn = kernel_functions(kernel, dim)[which]
    r = np.ascontiguousarray(r, dtype=np.float64)
    out = np.empty(r.size)
    _apply_scalar(fn, r.ravel(), float(h), out)
    return out.reshape(r.shape)


def kernel_w(r, h: float, dim: int, kernel: str = "wendland") -> np.ndarray:
    """W(|r|, h) for an array of distances ``r`` (any shape)."""
    return _values(0, r, h, dim, kernel)


def kernel_f(r, h: float, dim: int, kernel: str = "wendland") -> np.ndarray:
    """Gradient factor f(|r|, h) (∇W = f r⃗) for an array of distances ``r``."""
    return _values(1, r, h, dim, kernel)


def kernel_lap(r, h: float, dim: int, kernel: str = "wendland") -> np.ndarray:
    """Viscosity Laplacian weight L(|r|, h) for an array of distances ``r``."""
    return _values(2, r, h, dim, kernel)


def lattice_sum(spacing: float, h: float, dim: int, kernel: str = "wendland") -> float:
    """Σ_j W(|r_ij|, h) of a particle inside a full lattice of this spacing, itself included."""
    k = int(np.ceil(h / spacing))
    axis = np.arange(-k, k + 1) * spacing
    pts = np.stack([g.ravel() for g in np.meshgrid(*([axis] * dim), indexing="ij")], axis=1)
    r = np.sqrt((pts * pts).sum(axis=1))
    return float(kernel_w(r[r < h], h, dim, kernel).sum())


def kernel_grad(rvec, h: float, kernel: str = "wendland") -> np.ndarray:
    """∇W(r⃗, h) for an ``(n, dim)`` array of separation vectors r⃗ = r_i − r_j; returns ``(n, dim)``."""
    rvec = np.ascontiguousarray(np.atleast_2d(rvec), dtype=np.float64)
    _, f, _ = kernel_functions(kernel, rvec.shape[1])
    r = np.sqrt((rvec * rvec).sum(axis=1))
    fac = np.empty(r.size)
    _apply_scalar(f, r, float(h), fac)
    return fac[:, None] * rvec
