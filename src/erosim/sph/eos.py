"""Equations of state (SPEC SPH-4): pressure from density, chosen by name when the solver is built.

* Tait / WCSPH (Becker & Teschner 2007): p = B((ρ/ρ₀)^γ − 1), B = ρ₀c²/γ.
* Linear (seed 000 eq. 2.4): p = k(ρ − ρ₀).

The linear law is Tait's form with γ = 1 and B = kρ₀ (B((ρ/ρ₀) − 1) = k(ρ − ρ₀)), so the loops use
one formula, :func:`tait`, with the constants of :func:`eos_constants`. The speed of sound
of either law at ρ₀ is c = sqrt(dp/dρ) = sqrt(Bγ/ρ₀) (Tait) = sqrt(k) (linear).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(inline="always", cache=True)
def tait(rho, rho0, b, gamma):
    """Tait: p = B((ρ/ρ₀)^γ − 1) (γ = 7 and 1 by multiplication, which is several times faster than pow)."""
    x = rho / rho0
    if gamma == 7.0:
        x2 = x * x
        return b * (x2 * x2 * x2 * x - 1.0)
    if gamma == 1.0:
        return b * (x - 1.0)
    return b * (x**gamma - 1.0)


@njit(inline="always", cache=True)
def linear(rho, rho0, b, gamma):
    """Linear: p = k(ρ − ρ₀) (``b`` is k)."""
    return b * (rho - rho0)


def tait_b(rho0: float, sound_speed: float, gamma: float) -> float:
    """B = ρ₀c²/γ."""
    return rho0 * sound_speed**2 / gamma


def eos_constants(name: str, rho0: float, sound_speed: float, gamma: float, stiffness: float) -> tuple[float, float]:
    """(B, γ) for :func:`tait`: Tait B = ρ₀c²/γ; linear B = kρ₀, γ = 1 (k = ``stiffness``, 0 means c²)."""
    if name == "tait":
        return tait_b(rho0, sound_speed, gamma), float(gamma)
    if name == "linear":
        return (stiffness if stiffness > 0 else sound_speed**2) * rho0, 1.0
    raise ValueError(f"unknown equation of state {name!r}; use 'tait' or 'linear'")


def pressure(name: str, rho, rho0: float, b: float, gamma: float = 7.0) -> np.ndarray:
    """Vectorised EOS for arrays (tests, probes)."""
    rho = np.asarray(rho, dtype=np.float64)
    if name == "tait":
        return b * ((rho / rho0) ** gamma - 1.0)
    if name == "linear":
        return b * (rho - rho0)
    raise ValueError(f"unknown equation of state {name!r}; use 'tait' or 'linear'")


def density_for_pressure(p, rho0: float, b: float, gamma: float) -> np.ndarray:
    """Inverse of :func:`tait` with constants (B, γ): ρ = ρ₀(1 + p/B)^(1/γ) (for hydrostatic start-up)."""
    p = np.asarray(p, dtype=np.float64)
    return rho0 * (1.0 + p / b) ** (1.0 / gamma)
