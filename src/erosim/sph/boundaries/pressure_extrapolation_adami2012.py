"""Boundary particles' pressure extrapolated from the fluid (Adami, Hu & Adams 2012, eq. 27).

A fixed boundary particle w takes the Shepard-weighted pressure of its fluid neighbours f, each
carried hydrostatically from f to w:

    p_w = Σ_f (p_f + ρ_f (g − a_w)·(r_w − r_f)) W_wf / Σ_f W_wf,    ρ_w = ρ₀ (1 + p_w/B)^(1/γ)

(the Tait law inverted; a_w = 0 for fixed walls, and for a gate lifted at constant speed). A wall
with no fluid within its support keeps p = 0, ρ = ρ₀. The fluid's pressure is already clamped at
p_min (0 by default), so p_w ≥ p_min too: the wall never pulls.

Why: a dynamic boundary particle (Crespo et al. 2007, :mod:`erosim.sph.boundaries.particles`) pushes
back with the pressure of its own density, integrated from the fluid's approach since it was first
listed (from ρ₀), so a wall's answer lags the fluid's pressure wherever water arrives suddenly (an
impact, a front on a dry floor). With the extrapolated pressure the wall answers at once with the
fluid's own pressure carried to it, and holds no history. At rest the two agree (a tank at rest reads
ρ₀g·depth at its walls with either, tests/unit/sph/test_sph_boundaries.py). The fused pair pass is
unchanged: it reads the boundary particles' p and ρ as before (v_w = 0 in the continuity and viscous
terms). What it gives on Martin & Moyce and SPHERIC Test 2: docs/sph.md.

Written as a Numba pass here because the solver's boundary particles, neighbour lists and kernels are
its own; no SPH library exposes this step separately.
"""

from __future__ import annotations

import math

from numba import njit, prange

from erosim.kernels import sph_kernels as K


@njit(inline="always")
def extrapolate_particle(w, i, pos, rho, p, start, mid, nbr, h, g, rho0, b, gamma, pmin):
    """p_i, ρ_i of boundary particle i from its fluid neighbours (module equation)."""
    h2 = h * h
    d = pos.shape[1]
    sw = 0.0
    sp = 0.0
    for s in range(start[i], mid[i]):
        j = nbr[s]
        r2 = 0.0
        gr = 0.0
        for a in range(d):
            t = pos[i, a] - pos[j, a]
            r2 += t * t
            gr += g[a] * t
        if r2 >= h2:
            continue
        wij = w(math.sqrt(r2), h)
        sw += wij
        sp += (p[j] + rho[j] * gr) * wij
    pi = max(sp / sw, pmin) if sw > 0.0 else 0.0
    p[i] = pi
    rho[i] = rho0 * max(1.0 + pi / b, 1e-6) ** (1.0 / gamma)  # the guard binds only under tension (p_min = −∞)


@njit(parallel=True, cache=True)
def extrapolate_2d_wendland(pos, rho, p, start, mid, nbr, active, h, g, rho0, b, gamma, pmin):
    for k in prange(active.size):
        extrapolate_particle(K.wendland_w_2d, active[k], pos, rho, p, start, mid, nbr, h, g, rho0, b, gamma, pmin)


@njit(parallel=True, cache=True)
def extrapolate_2d_muller(pos, rho, p, start, mid, nbr, active, h, g, rho0, b, gamma, pmin):
    for k in prange(active.size):
        extrapolate_particle(K.muller_w_2d, active[k], pos, rho, p, start, mid, nbr, h, g, rho0, b, gamma, pmin)


@njit(parallel=True, cache=True)
def extrapolate_3d_wendland(pos, rho, p, start, mid, nbr, active, h, g, rho0, b, gamma, pmin):
    for k in prange(active.size):
        extrapolate_particle(K.wendland_w_3d, active[k], pos, rho, p, start, mid, nbr, h, g, rho0, b, gamma, pmin)


@njit(parallel=True, cache=True)
def extrapolate_3d_muller(pos, rho, p, start, mid, nbr, active, h, g, rho0, b, gamma, pmin):
    for k in prange(active.size):
        extrapolate_particle(K.muller_w_3d, active[k], pos, rho, p, start, mid, nbr, h, g, rho0, b, gamma, pmin)


def extrapolate_driver(dim: int, kernel: str):
    """The compiled pass for this dimension and kernel."""
    return globals()[f"extrapolate_{dim}d_{kernel}"]
