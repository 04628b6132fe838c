"""Mud: fluid particles that carry solid at a volume concentration C (seed 003 eqs. 10, 11, 16; SPEC SP-4).

A mud particle's density and viscosity mix the water's and the solid's by C:

    ρ = C ρ_s + (1 − C) ρ_f,        μ = C μ_s + (1 − C) μ_f,

and C spreads between neighbouring particles by the SPH diffusion of seed eq. (16),

    dC_i/dt = Σ_j (m_j/ρ_j) D (C_j − C_i) L(r_ij),

in the conservative pairwise form of :mod:`erosim.kernels.sph_diffusion` (all particles have the
volume V_p = m/ρ₀, so Σ C_i V_p — the solid carried — is conserved to rounding).

Modelling choices. The weakly compressible solver's particles share one mass m = ρ_f V_p and one rest
density, so the mixture acts on the flow through the particle's inertia (:class:`MudInertia`, a pass
after the pair forces): a mud particle's mass is ρ V_p, so the forces of its neighbours and walls
accelerate it ρ_f/ρ times as much as they would water,

    a_i = g + (ρ_f/ρ_i)(a_i^water − g),

which makes mud sink through still water at g(ρ − ρ_f)/ρ (buoyancy). Its neighbours still feel it
with the water's mass (the pair forces are computed once, with equal masses), so momentum is not
exchanged exactly symmetrically when C > 0 — the price of not rewriting the fused pair pass. The
mixture viscosity μ is computed (particle frames) but not used by the pair pass. C is the solid's
volume per particle volume, capped at ``splash.mud_max`` when solid is taken up.
"""

from __future__ import annotations

import numpy as np

from erosim.core.config import Section, param
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


class MudInertia(Boundary):
    """The pass of :func:`mixture_acceleration` after the pair forces (a per-particle pass through the
    boundary hooks; it lays no particles). Registers the ``mud`` field (C) if nobody has."""

    name = "mud_inertia"

    def __init__(self, rho_solid: float):
        self.rho_solid = float(rho_solid)

    def bind(self, solver) -> None:
        if "mud" not in solver.state.specs:
            solver.state.register("mud", fill=0.0)

    def forces(self, solver) -> None:
        st = solver.state
        nf = st.n_fluid
        c = st.mud[:nf]
        if nf == 0 or not c.any():
            return
        k = np.flatnonzero(c)
        g = np.asarray(solver.g, dtype=np.float64)[: solver.dim]
        st.acc[k] = mixture_acceleration(st.acc[k].astype(np.float64), g, c[k], solver.params.rho0, self.rho_solid)
