"""Mud: fluid particles that carry solid at a volume concentration C (seed 003 eqs. 10, 11, 16; SPEC SP-4).

A mud particle's density and viscosity mix the water's and the solid's by C:

    ρ = C ρ_s + (1 − C) ρ_f,        μ = C μ_s + (1 − C) μ_f,

and C spreads between neighbouring particles by the SPH diffusion of seed eq. (16),

    dC_i/dt = Σ_j (m_j/ρ_j) D (C_j − C_i) L(r_ij),

in the conservative pairwise form of :mod:`erosim.kernels.sph_diffusion` (all particles have the
volume V_p = m/ρ₀, so Σ C_i V_p — the solid carried — is conserved to rounding).

Modelling choices. The weakly compressible solver's particles share one mass m and one rest density,
so its fused pair pass computes the forces between particles of equal volume V_i = m/ρ_i (ρ_i its
number-density estimate). Those volume forces are what a mixture of particles of equal volume but
different masses needs, so the mixture acts through two things added after the pair pass
(:class:`MudMixture`, a per-particle pass through the boundary hooks):

* **viscosity**: the extra pairwise force of the Morris et al. (1997) form, with the pair's viscosity
  the harmonic mean of the two particles' (Cleary 1998, so that a pair of very different viscosities
  acts like two layers in series),

      F_i = Σ_j V_i V_j (μ̄_ij − μ_f) L(r_ij) (v_j − v_i),   μ̄_ij = 2μ_iμ_j/(μ_i + μ_j),

  over the pairs where either particle carries solid (μ_f, the water's, is what the pair pass already
  stands for: its laminar term, or its artificial viscosity); a fixed boundary particle takes the
  fluid particle's μ. F_ij = −F_ji exactly (the coefficient is symmetric in floating point and the
  velocity difference antisymmetric), so momentum is exchanged, not made;
* **mass**: particle i carries M_i = m ρ_i^mix/ρ_f (water and solid), and the forces on it — the pair
  pass's m(a_i^water − g) and F_i — accelerate that mass:

      a_i = g + (ρ_f/ρ_i^mix)(a_i^water − g + F_i/m),

  which makes mud sink through still water at g(ρ − ρ_f)/ρ (buoyancy). Since every pair force is
  equal and opposite, Σ_i M_i v_i changes only by gravity and the walls (to rounding).

The viscous term is explicit: the step obeys Δt ≤ 0.125 h_s² ρ^mix/μ^mix of the most viscous mud
particle (Morris et al. 1997), through the boundary protocol's ``step_limit`` hook. C is the solid's
volume per particle volume, capped at ``splash.mud_max`` when solid is taken up.

The pair loop is a hand-written Numba kernel over the solver's neighbour lists (no library offers an
SPH pair force on another code's lists); one cached driver per kernel family.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from erosim.core.config import Section, param
from erosim.kernels import sph_kernels as K
from erosim.kernels.sph_diffusion import diffuse, pair_weights, pairs_within
from erosim.sph.boundaries.base import Boundary


class MudParams(Section):
    solid_density: float = param(2650.0, gt=0, unit="kg/m3", doc="density ρ_s of the solid grains")
    solid_viscosity: float = param(1.0, gt=0, unit="Pa s", doc="viscosity μ_s the solid lends the mixture")
    diffusivity: float = param(1.0e-4, ge=0, unit="m2/s", doc="diffusivity D of the concentration between particles")


def mixture_density(c, rho_fluid: float, rho_solid: float):
    """ρ = C ρ_s + (1 − C) ρ_f."""
    c = np.asarray(c, dtype=np.float64)
    return c * rho_solid + (1.0 - c) * rho_fluid


def mixture_viscosity(c, mu_fluid: float, mu_solid: float):
    """μ = C μ_s + (1 − C) μ_f."""
    c = np.asarray(c, dtype=np.float64)
    return c * mu_solid + (1.0 - c) * mu_fluid


def diffuse_concentration(pos: np.ndarray, c: np.ndarray, volume: float, h: float, diffusivity: float,
                          dt: float) -> int:  # fmt: skip
    """Advance C (in place) by Δt of eq. (16) among particles at ``pos`` (support h); returns sub-steps.

    Only pairs where some particle carries solid matter; the others exchange nothing.
    """
    if diffusivity <= 0 or dt <= 0 or not np.any(c > 0):
        return 0
    i, j, r = pairs_within(pos, h)
    dim = pos.shape[1]
    w = pair_weights(r, h, dim, volume, volume, diffusivity)
    cap = np.full(len(c), volume)
    return diffuse(c, cap, i, j, w, dt)


def mixture_acceleration(acc: np.ndarray, g: np.ndarray, c: np.ndarray, rho_fluid: float, rho_solid: float):
    """a = g + (ρ_f/ρ)(a_water − g) for accelerations ``acc`` (n, d) of particles of concentration ``c``."""
    ratio = rho_fluid / mixture_density(c, rho_fluid, rho_solid)
    return g + ratio[:, None] * (acc - g)


@njit(inline="always")
def _pair_viscous_force(lap, i, pos, vel, vol, mu, c, start, mid, nbr, h, mu_f, out):
    """F_i of the module docstring (over i's neighbour list: fluid j first, then fixed boundary j)."""
    d = pos.shape[1]
    h2 = h * h
    mui = mu[i]
    ci = c[i]
    for s in range(start[i], start[i + 1]):
        j = nbr[s]
        fluid_j = s < mid[i]
        if ci == 0.0 and (not fluid_j or c[j] == 0.0):
            continue
        r2 = 0.0
        for a in range(d):
            t = pos[i, a] - pos[j, a]
            r2 += t * t
        if r2 >= h2:
            continue
        muj = mu[j] if fluid_j else mui
        mbar = 2.0 * (mui * muj) / (mui + muj) - mu_f
        k = (vol[i] * vol[j]) * mbar * lap(math.sqrt(r2), h)
        for a in range(d):
            vj = vel[j, a] if fluid_j else 0.0
            out[i, a] += k * (vj - vel[i, a])


@njit(parallel=True, cache=True)
def mud_viscous_force_wendland(pos, vel, vol, mu, c, start, mid, nbr, n_fluid, h, mu_f, out):
    """F_i (Wendland C2's Brookshaw Laplacian weight) for fluid particles 0 … n_fluid − 1."""
    three = pos.shape[1] == 3
    for i in prange(n_fluid):
        if three:
            _pair_viscous_force(K.wendland_lap_3d, i, pos, vel, vol, mu, c, start, mid, nbr, h, mu_f, out)
        else:
            _pair_viscous_force(K.wendland_lap_2d, i, pos, vel, vol, mu, c, start, mid, nbr, h, mu_f, out)


@njit(parallel=True, cache=True)
def mud_viscous_force_muller(pos, vel, vol, mu, c, start, mid, nbr, n_fluid, h, mu_f, out):
    """F_i (Müller's viscosity-kernel Laplacian) for fluid particles 0 … n_fluid − 1."""
    three = pos.shape[1] == 3
    for i in prange(n_fluid):
        if three:
            _pair_viscous_force(K.muller_lap_3d, i, pos, vel, vol, mu, c, start, mid, nbr, h, mu_f, out)
        else:
            _pair_viscous_force(K.muller_lap_2d, i, pos, vel, vol, mu, c, start, mid, nbr, h, mu_f, out)


_VISCOUS = {"wendland": mud_viscous_force_wendland, "muller": mud_viscous_force_muller}


def particle_masses(solver, rho_solid: float) -> np.ndarray:
    """M_i = m ρ_i^mix/ρ_f of the fluid particles (water and the solid they carry), kg."""
    st = solver.state
    c = st.mud[: st.n_fluid] if "mud" in st.specs else np.zeros(st.n_fluid)
    rho_f = solver.params.rho0
    return solver.m * mixture_density(c, rho_f, rho_solid) / rho_f


class MudMixture(Boundary):
    """The pass of the module docstring after the pair forces (a per-particle pass through the boundary
    hooks; it lays no particles): the mixture's extra viscous pair force and its mass, and the viscous
    step limit. Registers the ``mud`` field (C) if nobody has."""

    name = "mud_mixture"

    def __init__(self, rho_solid: float, mu_solid: float):
        self.rho_solid = float(rho_solid)
        self.mu_solid = float(mu_solid)

    def bind(self, solver) -> None:
        if "mud" not in solver.state.specs:
            solver.state.register("mud", fill=0.0)
        self._viscous = _VISCOUS[solver.params.kernel]

    def _mixture(self, solver, c):
        rho_f, mu_f = solver.params.rho0, solver.params.mu
        return mixture_density(c, rho_f, self.rho_solid), mixture_viscosity(c, mu_f, self.mu_solid)

    def forces(self, solver) -> None:
        st = solver.state
        nf = st.n_fluid
        c = st.mud[:nf]
        if nf == 0 or not c.any():
            return
        rho_mix, mu = self._mixture(solver, c)
        vol = solver.m / st.rho.astype(np.float64)  # V_i = m/ρ_i of every particle (fluid and boundary)
        force = np.zeros((nf, solver.dim))
        self._viscous(
            st.pos, st.vel, vol, mu, c, solver.start, solver.mid, solver.nbr, nf, solver.h, solver.params.mu, force
        )  # fmt: skip
        k = np.flatnonzero((c > 0) | force.any(axis=1))
        g = np.asarray(solver.g, dtype=np.float64)[: solver.dim]
        ratio = (solver.params.rho0 / rho_mix[k])[:, None]
        st.acc[k] = g + ratio * (st.acc[k].astype(np.float64) - g + force[k] / solver.m)

    def step_limit(self, solver) -> float:
        """0.125 h_s² min(ρ^mix/μ^mix) over the mud particles (∞ without mud)."""
        st = solver.state
        c = st.mud[: st.n_fluid]
        if not c.any():
            return math.inf
        rho_mix, mu = self._mixture(solver, c)
        return 0.125 * solver.hs**2 * float(np.min(rho_mix / mu))
