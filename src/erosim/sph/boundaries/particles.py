"""Fixed boundary particles for tank walls and box obstacles (dynamic boundary particles).

Dynamic boundary particles (Crespo, Gómez-Gesteira & Dalrymple 2007; the fixed particles of seed
001, SPEC SPH-12): lattice particles that never move but carry density and pressure (from the same
EOS as the fluid), so fluid approaching a wall compresses them and is pushed back. Layers sit at
half-spacing offsets outside the fluid region, so the first layer is Δx/2 behind the wall face, like
the fluid's first layer is Δx/2 in front of it.

As a boundary model (:class:`BoundaryParticles`) they join the solver's index space after the fluid,
where the fused fluid pass sums over them (pressure, viscosity, continuity with v_j = 0); their own
passes are

* density: continuity dρ_b/dt = Σ_fluid m_j (0 − v_j)·∇W_bj over the *active* particles (those with
  a fluid neighbour), or with summation density ρ_b = max(ρ₀, m(W(0) + Σ_boundary W) + m Σ_fluid W_bj)
  (the first, constant part computed once);
* predictor / corrector: ρ_b* = max(ρ₀, ρ_b + Δt dρ_b/dt), then ρ_b = max(ρ₀, ρ_b^old + Δt dρ_b/dt)
  with the new rate (kept ≥ ρ₀: a wall never pulls; Crespo et al. 2007), p_b from the EOS;
* refresh: new particle positions (a terrain that changed) replace the old ones.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from erosim.kernels import sph_kernels as K
from erosim.kernels.neighbours import find_neighbours
from erosim.kernels.sph_kernels import kernel_w
from erosim.sph.boundaries.base import Boundary
from erosim.sph.boundaries.pressure_extrapolation_adami2012 import extrapolate_driver
from erosim.sph.eos import tait
from erosim.sph.forces import kernel_sum, pressure_pass


def _lattice(lo, hi, dx):
    """Points (k + ½)Δx from ``lo`` that lie inside [lo, hi] (at least one per axis)."""
    axes = []
    for a in range(len(lo)):
        n = max(1, int(round((hi[a] - lo[a]) / dx)))
        axes.append(lo[a] + (np.arange(n) + 0.5) * (hi[a] - lo[a]) / n)
    grids = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=1)


def box_walls(lo, hi, spacing: float, layers: int, open_top: bool = True) -> np.ndarray:
    """Particles in a shell ``layers``·Δx thick around the box [lo, hi], open at the top (last axis max).

    The shell covers the box's sides and floor and its corners; with ``open_top`` the top face has none.
    """
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    d = lo.size
    t = layers * spacing
    outer_lo = lo - t
    outer_hi = hi + t
    if open_top:
        outer_hi[-1] = hi[-1]
    # lattice aligned with the box: cell counts from the inner box extent keep spacing ~Δx
    n_in = np.maximum(1, np.round((hi - lo) / spacing)).astype(int)
    dxs = (hi - lo) / n_in
    axes = []
    for a in range(d):
        inner = lo[a] + (np.arange(n_in[a]) + 0.5) * dxs[a]
        below = lo[a] - (np.arange(layers) + 0.5) * dxs[a]
        above = hi[a] + (np.arange(layers) + 0.5) * dxs[a]
        if open_top and a == d - 1:
            above = above[:0]
        axes.append(np.concatenate([below[::-1], inner, above]))
    grids = np.meshgrid(*axes, indexing="ij")
    pts = np.stack([g.ravel() for g in grids], axis=1)
    inside = np.all((pts > lo) & (pts < hi), axis=1)
    keep = ~inside & np.all((pts >= outer_lo) & (pts <= outer_hi), axis=1)
    return pts[keep]


def box_obstacle(lo, hi, spacing: float, layers: int) -> np.ndarray:
    """Particles filling the outer ``layers``·Δx of the solid box [lo, hi] (hollow inside)."""
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    pts = _lattice(lo, hi, spacing)
    t = layers * spacing
    deep = np.all((pts > lo + t) & (pts < hi - t), axis=1)
    return pts[~deep]


# ---------------------------------------------------------------- per-particle passes


@njit(inline="always")
def density_rate_particle(gradf, i, pos, vel, start, mid, nbr, m, h, drho):
    """dρ/dt of fixed boundary particle i: Σ_fluid m_j (0 − v_j)·∇W_ij."""
    h2 = h * h
    d = pos.shape[1]
    dr = 0.0
    for s in range(start[i], mid[i]):
        j = nbr[s]
        r2 = 0.0
        vdotr = 0.0
        for a in range(d):
            t = pos[i, a] - pos[j, a]
            r2 += t * t
            vdotr -= vel[j, a] * t
        if r2 >= h2:
            continue
        dr += vdotr * gradf(math.sqrt(r2), h)
    drho[i] = m * dr


@njit(inline="always")
def summation_particle(w, i, pos, start, nbr, m, h, rho_base, rho0, rho):
    """ρ_i = max(ρ₀, ρ_base,i + m Σ_fluid W(r_ij)); ``rho_base`` = m (W(0) + Σ_boundary W), constant."""
    rho[i] = max(rho0, rho_base[i] + m * kernel_sum(w, i, pos, start, nbr, h))


@njit(parallel=True, cache=True)
def update_density(rho, rho_old, drho, p, active, dt, rho0, b, gamma, pmin, predictor):
    """Active boundary particles: ρ = max(ρ₀, ρ_old + dt·dρ/dt), p = EOS(ρ); the predictor first keeps
    ρ in ρ_old (so it steps from the current ρ), the corrector steps from the kept one. A particle listed
    for the first time at a rebuild between the two has ρ_old = 0 and so steps from ρ₀: the density of a
    wall no water reached yet (its hydrostatic start counts depth below the fluid's top, water above it
    or not; tests/unit/sph/test_sph_boundaries.py, first-reached test)."""
    for k in prange(active.size):
        update_density_particle(rho, rho_old, drho, p, active[k], dt, rho0, b, gamma, pmin, predictor)


@njit(inline="always", cache=True)
def update_density_particle(rho, rho_old, drho, p, i, dt, rho0, b, gamma, pmin, predictor):
    """Boundary particle i of :func:`update_density` (the CPU loop and the device kernel both call it)."""
    if predictor:
        rho_old[i] = rho[i]
    rho[i] = max(rho0, rho_old[i] + dt * drho[i])
    p[i] = max(tait(rho[i], rho0, b, gamma), pmin)


# drivers, one per kernel and dimension (spelled out so Numba can cache each)
@njit(parallel=True, cache=True)
def density_rate_2d_wendland(pos, vel, start, mid, nbr, active, m, h, drho):
    for k in prange(active.size):
        density_rate_particle(K.wendland_f_2d, active[k], pos, vel, start, mid, nbr, m, h, drho)


@njit(parallel=True, cache=True)
def density_rate_2d_muller(pos, vel, start, mid, nbr, active, m, h, drho):
    for k in prange(active.size):
        density_rate_particle(K.muller_f_2d, active[k], pos, vel, start, mid, nbr, m, h, drho)


@njit(parallel=True, cache=True)
def density_rate_3d_wendland(pos, vel, start, mid, nbr, active, m, h, drho):
    for k in prange(active.size):
        density_rate_particle(K.wendland_f_3d, active[k], pos, vel, start, mid, nbr, m, h, drho)


@njit(parallel=True, cache=True)
def density_rate_3d_muller(pos, vel, start, mid, nbr, active, m, h, drho):
    for k in prange(active.size):
        density_rate_particle(K.muller_f_3d, active[k], pos, vel, start, mid, nbr, m, h, drho)


@njit(parallel=True, cache=True)
def summation_2d_wendland(pos, start, nbr, i0, i1, m, h, rho_base, rho0, rho):
    for i in prange(i0, i1):
        summation_particle(K.wendland_w_2d, i, pos, start, nbr, m, h, rho_base, rho0, rho)


@njit(parallel=True, cache=True)
def summation_2d_muller(pos, start, nbr, i0, i1, m, h, rho_base, rho0, rho):
    for i in prange(i0, i1):
        summation_particle(K.muller_w_2d, i, pos, start, nbr, m, h, rho_base, rho0, rho)


@njit(parallel=True, cache=True)
def summation_3d_wendland(pos, start, nbr, i0, i1, m, h, rho_base, rho0, rho):
    for i in prange(i0, i1):
        summation_particle(K.wendland_w_3d, i, pos, start, nbr, m, h, rho_base, rho0, rho)


@njit(parallel=True, cache=True)
def summation_3d_muller(pos, start, nbr, i0, i1, m, h, rho_base, rho0, rho):
    for i in prange(i0, i1):
        summation_particle(K.muller_w_3d, i, pos, start, nbr, m, h, rho_base, rho0, rho)


class BoundaryParticles(Boundary):
    """Fixed boundary particles at ``positions`` (m, dim): tank walls, obstacles, terrain (see module)."""

    name = "boundary_particles"

    def __init__(self, positions):
        self.positions = np.ascontiguousarray(positions, dtype=np.float64)

    def particles(self) -> np.ndarray:
        return self.positions

    def bind(self, solver) -> None:
        prm = solver.params
        if prm.wall_pressure == "extrapolated":
            self._extrapolate = extrapolate_driver(solver.dim, prm.kernel)
            self._g = np.asarray(solver.g, np.float64)
            self.density = self._extrapolated
            self.predict = self.correct = None
        elif solver.summation:
            self._sum = globals()[f"summation_{solver.dim}d_{prm.kernel}"]
            self.density = self._summation_density
            self._base(solver)
        else:
            self._rate = globals()[f"density_rate_{solver.dim}d_{prm.kernel}"]
            self.density = self._continuity_rate

    def _base(self, solver) -> None:
        """Summation density: the constant part m (W(0) + Σ_boundary W) of each boundary particle."""

        st, h, d, kernel = solver.state, solver.h, solver.dim, solver.params.kernel
        self.rho_base = np.zeros(st.n, np.float64)
        if st.n_boundary == 0:
            return
        bpos = st.pos[st.n_fluid :].astype(np.float64)
        starts, _, lst = find_neighbours(bpos, h)
        w0 = float(kernel_w(np.zeros(1), h, d, kernel)[0])
        i_idx = np.repeat(np.arange(bpos.shape[0]), np.diff(starts))
        rr = np.sqrt(((bpos[i_idx] - bpos[lst]) ** 2).sum(axis=1))
        sums = np.bincount(i_idx, weights=kernel_w(rr, h, d, kernel), minlength=bpos.shape[0])
        self.rho_base[st.n_fluid :] = solver.m * (w0 + sums)

    def _summation_density(self, solver) -> None:
        st = solver.state
        self._sum(st.pos, solver.start, solver.nbr, st.n_fluid, st.n, solver.m, solver.h, self.rho_base,
                  solver.params.rho0, st.rho)  # fmt: skip

    def _extrapolated(self, solver) -> None:
        """p and ρ of the active boundary particles from the fluid's (Adami et al. 2012)."""
        st = solver.state
        if solver.summation:  # the fluid's summation density is new: its pressure first
            pressure_pass(st.rho, *solver.eos_args(), 0, st.n_fluid, st.p)
        self._extrapolate(st.pos, st.rho, st.p, solver.start, solver.mid, solver.nbr, solver.active, solver.h,
                          self._g, *solver.eos_args())  # fmt: skip

    def _continuity_rate(self, solver) -> None:
        st = solver.state
        self._rate(st.pos, st.vel, solver.start, solver.mid, solver.nbr, solver.active, solver.m, solver.h, st.drho)

    def predict(self, solver, dt: float) -> None:
        st = solver.state
        update_density(st.rho, st.rho_old, st.drho, st.p, solver.active, dt, *solver.eos_args(), True)

    def correct(self, solver, dt: float) -> None:
        st = solver.state
        update_density(st.rho, st.rho_old, st.drho, st.p, solver.active, dt, *solver.eos_args(), False)

    def refresh(self, solver, *, positions=None, **changed) -> None:
        """Lay the particles at new ``positions`` (a changed terrain); the solver rebuilds its lists."""
        if positions is None:
            return
        self.positions = np.ascontiguousarray(positions, dtype=np.float64)
        solver.replace_boundary(self.positions)
        if solver.summation:
            self._base(solver)
