"""The stable time step of the δ-SPH density diffusion (Molteni & Colagrossi 2009) in this solver's
density update, per particle.

The diffusion term of :mod:`erosim.sph.forces` relaxes particle i's density towards its neighbours'
at the rate

    K_i = m k_δ Σ_j (−f_ij) r_ij²/((r_ij² + η²) ρ_j),    k_δ = 2δ h_s c,  η² = 0.01 h_s²

(fluid neighbours j, ∇W_ij = f_ij r_ij), so for a density deviation x alone dx/dt = −K_i x. The solver
advances densities as ρ* = ρⁿ + Δt D*ⁿ⁻¹ (the rate of the previous evaluation), then
ρⁿ⁺¹ = ρⁿ + Δt D(ρ*) (:func:`erosim.sph.integrators.kick_drift` and ``correct``). On dx/dt = −Kx with
a = KΔt that is x*ₙ₊₁ = xₙ − a x*ₙ, xₙ₊₁ = xₙ − a x*ₙ₊₁, whose amplification factors solve
λ² − (1 − 2a)λ − a = 0: |λ| ≤ 1 only for a ≤ 2/3; beyond it an odd–even oscillation of the density
grows from step to step (λ < −1) until a density goes negative.

In a fluid at its rest spacing K_i Δt is about 0.06 at the CFL step (CFL 0.2), far from the bound.
But the rate of a pair does not fall as two particles close in (f(0) is finite: Wendland C2 in 3-D
gives |f(0)| = 210/(π h⁵)), so a clump of particles much closer than Δx — particles in a thin
overflow at pressure zero, several put back on a wall at nearly the same place — adds up to
m k_δ |f(0)|/ρ per close neighbour (450 s⁻¹ at Δx = 2 cm, c = 21.6 m/s) and crosses the bound while
the CFL step is unchanged. The solver's fused pair pass (:mod:`erosim.sph.forces`) returns K_i of
every particle at no extra neighbour loop, and adaptive steps keep Δt ≤ :data:`SAFETY`/max_i K_i
(a ≤ 0.5, |λ| ≤ 0.71) with the rates of the last force pass (``SPHSolver.kmax``, checkpointed).

:func:`rates` and :func:`max_rate` are the same sum as a standalone pass over the solver's neighbour
lists (for checks and diagnostics; the step does not call them). Hand-written Numba like the fused
pass it mirrors: it walks the solver's own lists (``start``/``mid``/``nbr``), which no library exposes.
"""

from __future__ import annotations

import math

from numba import njit, prange

from erosim.kernels import sph_kernels as K

#: K_i Δt kept at or below this (the density update is stable up to 2/3)
SAFETY = 0.5


@njit(inline="always", cache=True)
def _rate(gradf, i, pos, rho, start, mid, nbr, h, eta2):
    h2 = h * h
    d = pos.shape[1]
    s_ = 0.0
    for s in range(start[i], mid[i]):
        j = nbr[s]
        r2 = 0.0
        for a in range(d):
            t = pos[i, a] - pos[j, a]
            r2 += t * t
        if r2 >= h2:
            continue
        s_ += -gradf(math.sqrt(r2), h) * r2 / ((r2 + eta2) * rho[j])
    return s_


@njit(parallel=True, cache=True)
def _rates_3d_wendland(pos, rho, start, mid, nbr, n_fluid, h, eta2, out):
    for i in prange(n_fluid):
        out[i] = _rate(K.wendland_f_3d, i, pos, rho, start, mid, nbr, h, eta2)


@njit(parallel=True, cache=True)
def _rates_2d_wendland(pos, rho, start, mid, nbr, n_fluid, h, eta2, out):
    for i in prange(n_fluid):
        out[i] = _rate(K.wendland_f_2d, i, pos, rho, start, mid, nbr, h, eta2)


@njit(parallel=True, cache=True)
def _rates_3d_muller(pos, rho, start, mid, nbr, n_fluid, h, eta2, out):
    for i in prange(n_fluid):
        out[i] = _rate(K.muller_f_3d, i, pos, rho, start, mid, nbr, h, eta2)


@njit(parallel=True, cache=True)
def _rates_2d_muller(pos, rho, start, mid, nbr, n_fluid, h, eta2, out):
    for i in prange(n_fluid):
        out[i] = _rate(K.muller_f_2d, i, pos, rho, start, mid, nbr, h, eta2)


_DRIVERS = {
    (3, "wendland"): _rates_3d_wendland,
    (2, "wendland"): _rates_2d_wendland,
    (3, "muller"): _rates_3d_muller,
    (2, "muller"): _rates_2d_muller,
}


def rates(dim, kernel, pos, rho, start, mid, nbr, n_fluid, m, h, kdiff, eta2, out):
    """K_i (s⁻¹) of the first ``n_fluid`` particles into ``out`` (see the module docstring)."""
    _DRIVERS[(int(dim), kernel)](pos, rho, start, mid, nbr, n_fluid, h, eta2, out[:n_fluid])
    out[:n_fluid] *= m * kdiff


def max_rate(dim, kernel, pos, rho, start, mid, nbr, n_fluid, m, h, kdiff, eta2, out) -> float:
    """max_i K_i (s⁻¹; 0 without fluid or without diffusion)."""
    if n_fluid == 0 or kdiff <= 0:
        return 0.0
    rates(dim, kernel, pos, rho, start, mid, nbr, n_fluid, m, h, kdiff, eta2, out)
    return float(out[:n_fluid].max())
