"""Time integration (SPEC SPH-10): leapfrog kick-drift-kick and symplectic Euler, plus the step limits.

With a = a(r, v, ρ) and the density rate D = dρ/dt from one fused force pass per step:

* leapfrog (kick-drift-kick; the seeds' form v_{n+½} = v_{n−½} + a_n Δt, r_{n+1} = r_n + v_{n+½}Δt,
  started with the half step, written as two half kicks):
  v_{n+½} = v_n + ½Δt a_n,  ρ_{n+½} = ρ_n + ½Δt D_n,  r_{n+1} = r_n + Δt v_{n+½};
  evaluate a_{n+1}, D_{n+1} at (r_{n+1}, v_{n+½}, ρ_{n+½});
  v_{n+1} = v_{n+½} + ½Δt a_{n+1},  ρ_{n+1} = ρ_{n+½} + ½Δt D_{n+1}.
* symplectic Euler (seed 001): v_{n+1} = v_n + Δt a_n, ρ_{n+1} = ρ_n + Δt D_n, r_{n+1} = r_n + Δt v_{n+1}.

Density is a configuration variable advanced with the velocity of the same step,
ρ_{n+1} = ρ_n + Δt D(r_{n+1}, v_{n+½}) (leapfrog) or D(r_{n+1}, v_{n+1}) (symplectic Euler). As that D
comes from the same single force pass that needs ρ_{n+1} for the pressure, the pass uses the
predictor ρ* = ρ_n + Δt D_n and the corrector ρ_{n+1} = ρ_n + Δt D_{n+1} follows it. (Advancing ρ
with the previous step's D alone is forward Euler for the acoustic (ρ, v) pair and grows sound-wave
noise at CFL 0.2; the corrector removes that.)

:func:`kick_drift` (first kick, drift, predictor, EOS) and :func:`correct` (second kick,
corrector, EOS) serve both integrators with different weights: leapfrog kicks ½Δt in each,
symplectic Euler Δt in the first and 0 in the second. Between the drift and the neighbour-list check
the boundary models keep particles out of walls (:mod:`erosim.sph.boundaries`), then
:func:`max_displacement` measures how far particles moved since the lists were built.

Step limits (Monaghan 1992; Morris et al. 1997), h_s the smoothing length:
Δt ≤ C h_s/(c + |v|max),  Δt ≤ C sqrt(h_s/|a|max),  Δt ≤ 0.125 h_s²/ν (laminar viscosity, ν = μ/ρ₀).
"""

from __future__ import annotations

import math

from numba import njit, prange

from erosim.sph.eos import tait

NCHUNK = 64  # fixed chunk count of the max-reductions (deterministic for any thread count)


@njit(inline="always", cache=True)
def _chunk(n, c):
    cs = (n + NCHUNK - 1) // NCHUNK
    return c * cs, min(n, (c + 1) * cs)


@njit(inline="always", cache=True)
def kick_drift_particle(pos, vel, acc, rho, rho_old, drho, p, i, dt_kick, dt, rho0, b, gamma, pmin, rho_min):
    """Fluid particle i: v += dt_kick·a; r += dt·v; predictor ρ* = max(ρ + dt·D, ρ_min) (ρ kept in rho_old);
    p = EOS(ρ*). The CPU loop and the device kernel (:mod:`erosim.sph.kernels_cuda`) both call it."""
    for a in range(pos.shape[1]):
        vel[i, a] += dt_kick * acc[i, a]
        pos[i, a] += dt * vel[i, a]
    rho_old[i] = rho[i]
    rho[i] = max(rho[i] + dt * drho[i], rho_min)
    p[i] = max(tait(rho[i], rho0, b, gamma), pmin)


@njit(inline="always", cache=True)
def correct_particle(vel, acc, rho, rho_old, drho, p, i, dt_kick, dt, rho0, b, gamma, pmin, rho_min):
    """Fluid particle i after the force pass: v += dt_kick·a (leapfrog's second half kick); corrector
    ρ = max(ρ_old + dt·D_new, ρ_min); p = EOS(ρ). Returns (|v|², |a|²). The CPU loop and the device
    kernel both call it."""
    sv = 0.0
    sa = 0.0
    for a in range(vel.shape[1]):
        vel[i, a] += dt_kick * acc[i, a]
        sv += vel[i, a] * vel[i, a]
        sa += acc[i, a] * acc[i, a]
    rho[i] = max(rho_old[i] + dt * drho[i], rho_min)
    p[i] = max(tait(rho[i], rho0, b, gamma), pmin)
    return sv, sa


@njit(parallel=True, cache=True)
def kick_drift(pos, vel, acc, rho, rho_old, drho, p, n_fluid, dt_kick, dt, rho0, b, gamma, pmin, rho_min):
    """Fluid: :func:`kick_drift_particle` for every particle."""
    for i in prange(n_fluid):
        kick_drift_particle(pos, vel, acc, rho, rho_old, drho, p, i, dt_kick, dt, rho0, b, gamma, pmin, rho_min)


@njit(parallel=True, cache=True)
def max_displacement(pos, ref, n_fluid, out_disp2):
    """out_disp2[c] = max |r − ref|² over the fluid particles of chunk c (after the boundaries' constraints)."""
    d = pos.shape[1]
    for c in prange(NCHUNK):
        mx = 0.0
        i0, i1 = _chunk(n_fluid, c)
        for i in range(i0, i1):
            s = 0.0
            for a in range(d):
                t = pos[i, a] - ref[i, a]
                s += t * t
            mx = max(mx, s)
        out_disp2[c] = mx


@njit(parallel=True, cache=True)
def correct(vel, acc, rho, rho_old, drho, p, n_fluid, dt_kick, dt, rho0, b, gamma, pmin, rho_min, out_v2, out_a2):
    """After the force pass: v += dt_kick·a (leapfrog's second half kick; 0 for symplectic Euler);
    corrector ρ = max(ρ_old + dt·D_new, ρ_min); p = EOS(ρ). out_v2[c], out_a2[c]: chunk maxima of |v|², |a|²
    (+inf if any is NaN). Each particle is :func:`correct_particle`.
    """
    for c in prange(NCHUNK):
        mv = 0.0
        ma = 0.0
        i0, i1 = _chunk(n_fluid, c)
        for i in range(i0, i1):
            sv, sa = correct_particle(vel, acc, rho, rho_old, drho, p, i, dt_kick, dt, rho0, b, gamma, pmin, rho_min)
            if sv != sv or sa != sa:
                mv = math.inf
                ma = math.inf
            mv = max(mv, sv)
            ma = max(ma, sa)
        out_v2[c] = mv
        out_a2[c] = ma


@njit(parallel=True, cache=True)
def max_norms(vel, acc, n_fluid, out_v2, out_a2):
    """Chunk maxima of |v|² and |a|² over fluid particles (NaN anywhere gives +inf)."""
    d = vel.shape[1]
    for c in prange(NCHUNK):
        mv = 0.0
        ma = 0.0
        i0, i1 = _chunk(n_fluid, c)
        for i in range(i0, i1):
            sv = 0.0
            sa = 0.0
            for a in range(d):
                sv += vel[i, a] * vel[i, a]
                sa += acc[i, a] * acc[i, a]
            if sv != sv or sa != sa:
                mv = math.inf
                ma = math.inf
            mv = max(mv, sv)
            ma = max(ma, sa)
        out_v2[c] = mv
        out_a2[c] = ma


def step_limit(cfl: float, hs: float, c: float, vmax: float, amax: float, nu: float) -> float:
    """min(C h_s/(c + v_max), C sqrt(h_s/a_max), 0.125 h_s²/ν) (ν = 0 for no viscous limit)."""
    lim = cfl * hs / (c + vmax)
    if amax > 0:
        lim = min(lim, cfl * math.sqrt(hs / amax))
    if nu > 0:
        lim = min(lim, 0.125 * hs * hs / nu)
    return lim
