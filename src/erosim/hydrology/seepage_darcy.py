"""Seepage into porous ground by Darcy's law, moisture spreading inside it, and evaporation (seed 003
§2, SPEC SP-3).

**Absorption.** Water standing on a surface ground particle k enters it at the Darcy flux

    q_k = K (1 − θ_k),        K = k_p ρ_w g / μ_w        (m/s),

K the hydraulic conductivity of a ground of permeability k_p (m²), over the particle's top area A_k,
so in Δt the particle takes at most K(1 − θ_k)A_k Δt — and never more than its free pore volume
(1 − θ_k)φ_k V_k, nor more than the water of the fluid particles touching it (each gives in
proportion to what it holds). Modelling choice: the seed says only that absorption follows Darcy's
law; the hydraulic gradient across the wetting surface is taken as one (gravity drainage) and the
saturation deficit (1 − θ) stands for the suction that draws water into dry ground and vanishes at
saturation — a saturated surface takes water again only as moisture drains away from it. A puddle
on a bed that keeps its surface dry therefore sinks at K; one on a closed surface layer of pore
volume φV fills it as θ(t) = 1 − (1 − θ₀) e^{−KAt/(φV)}.

**Footprint.** A fluid particle's water meets the ground over its footprint, not at the one column
under its centre: it offers its water to the surface particles within the kernel support h of it
(horizontal distance r) in the shares w_pc = W(r_pc/h)/Σ_c W(r_pc/h), W(q) = (1 − q)⁴(1 + 4q) the
Wendland C2 bump (Wendland 1995), the same wherever it lies on the ground lattice and alike in every
direction (a particle sliding over the ground wets a band, not a line of single columns, and a point
source a disk, not the lattice's star). A particle's water covers the area a_p of one ground column,
spread in the same shares: the surface particle c is covered over A_c' = min(A_c, Σ_p w_pc a_p) and
takes at most K(1 − θ_c)A_c'Δt, so a lone particle soaks in at K·a_p, as when it met the one column
under its centre, now over a round patch, and ground under overlapping footprints takes K(1 − θ) over
its whole area. Modelling choice: the seed names no footprint; h is where the ground's wall acts on
the particle. (Covering its own cross-section Δx² instead would soak water in (Δx/s)² times faster
where the ground particles are finer than the fluid's: 4 times in rain-splash, whose puddles then
mostly soak away — measured 0.026 l standing instead of 0.27 l.)

**Moisture diffusion.** Between ground particles, driven by saturation differences:
d(φ_iV_iθ_i)/dt = Σ_j D_θ φ̄_ij V_i V_j L(r_ij)(θ_j − θ_i) (the conservative SPH diffusion of
:mod:`erosim.kernels.sph_diffusion`; φ̄ the mean porosity of the pair), so a step of wet over dry
ground spreads as erfc(z/(2√(D_θ t))) and a moisture front moves ∝ √t.

**Layered ground: Darcy drainage between layers.** Where the top soil and the subsoil differ in
permeability, the gravity part of Richards' equation, q = K(θ), is added to the diffusion above (its
capillary part, −D_θ ∂θ/∂z). Between a particle u and the one under it, l, in the same column,

    q_ul = K̄_ul θ_u (1 − θ_l),        K̄_ul = 2 K_u K_l / (K_u + K_l),

K̄ the conductivity between the two layers: the harmonic mean, the series conductance of the half
particle of each over the distance s between their centres (s / (s/2K_u + s/2K_l)). The upper's
saturation stands for the share of its pores that conduct, the lower's deficit for its suction (as
in the absorption); a saturated top layer over a dry subsoil drains at K̄A. In Δt the pair moves at
most the upper's water θ_uφ_uV_u and the lower's free pore (1 − θ_l)φ_lV_l, so θ stays in [0, 1].
Since D_θ = K(θ) dψ/dθ (Richards), the diffusivity of a pair is D_θ K̄_ij/K_top: D_θ is the top
soil's. A top soil faster than its subsoil fills once the subsoil cannot take the water away, and
the water then stands on it (saturation-excess ponding, Dunne 1983). Modelling choice: a uniform
ground keeps the diffusion-only exchange.

**Evaporation** (optional): surface particles lose E·A_k·Δt of water (E in m/s), while they have it.

Every transfer is subtracted from one store and added to another in the same floating-point
amounts, so water in the fluid + in the ground + evaporated is constant to rounding (SP-3's
conservation; runs report the closure).
"""

from __future__ import annotations

import numpy as np

WATER_DENSITY = 1000.0  # kg/m³
WATER_VISCOSITY = 1.0e-3  # Pa·s (20 °C)


def conductivity(permeability: float, gravity: float = 9.81, rho: float = WATER_DENSITY,
                 mu: float = WATER_VISCOSITY) -> float:  # fmt: skip
    """Hydraulic conductivity K = k_p ρ g / μ (m/s) of a ground of permeability ``permeability`` (m²)."""
    return permeability * rho * gravity / mu


def absorb(water: np.ndarray, contact: np.ndarray, theta: np.ndarray, pore: np.ndarray, area: float, k: float,
           dt: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """One Darcy absorption step.

    ``water`` (n_f,) m³ of water each fluid particle holds; ``contact`` (n_f,) the ground particle it
    touches (−1: none); ``theta``, ``pore`` (n_g,) the ground's saturations and pore volumes (m³);
    ``area`` the top area of a surface particle (m²), ``k`` the conductivity K (m/s).
    Returns (taken (n_f,) m³ each fluid particle loses, gained (n_g,) m³ each ground particle gains);
    Σ taken = Σ gained to rounding (gained is the bincount of taken).
    """
    n_g = len(theta)
    touching = contact >= 0
    taken = np.zeros(len(water))
    if not touching.any() or dt <= 0:
        return taken, np.zeros(n_g)
    c = contact[touching]
    supply = np.bincount(c, water[touching], n_g)
    deficit = np.clip(1.0 - theta, 0.0, 1.0)
    demand = np.minimum(k * deficit * area * dt, deficit * pore)
    take = np.minimum(demand, supply)
    share = np.divide(take, supply, out=np.zeros(n_g), where=supply > 0)
    taken[touching] = water[touching] * share[c]
    gained = np.bincount(contact[touching], taken[touching], n_g)
    return taken, gained


def footprint_weights(r: np.ndarray, radius: float) -> np.ndarray:
    """The Wendland C2 bump W = (1 − q)⁴(1 + 4q), q = r/``radius`` (0 beyond): un-normalised footprint weights."""
    q = np.clip(np.asarray(r, dtype=np.float64) / radius, 0.0, 1.0)
    return (1.0 - q) ** 4 * (1.0 + 4.0 * q)


def absorb_spread(water: np.ndarray, p: np.ndarray, c: np.ndarray, w: np.ndarray, theta: np.ndarray,
                  pore: np.ndarray, area: float, k: float, dt: float,
                  cover: float | None = None) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """One Darcy absorption step over footprints: fluid particle ``p[m]`` offers the share ``w[m]`` of its
    ``water`` (m³) to ground particle ``c[m]`` (each particle's shares sum to 1) and covers ``cover`` m² of
    ground in the same shares (None: every footprint column wholly). Each ground particle takes at most
    the Darcy demand min(K(1 − θ)A'Δt, (1 − θ)φV) of :func:`absorb` over its covered area
    A' = min(A, Σ w·cover), every offer to it in the same proportion. Returns (taken (n_f,), gained
    (n_g,)) m³: the bincounts of the same pair amounts, so Σ taken = Σ gained to rounding."""
    n_g = len(theta)
    taken = np.zeros(len(water))
    if len(p) == 0 or dt <= 0:
        return taken, np.zeros(n_g)
    offer = w * water[p]
    supply = np.bincount(c, offer, n_g)
    covered = area if cover is None else np.minimum(area, np.bincount(c, w * cover, n_g))
    deficit = np.clip(1.0 - theta, 0.0, 1.0)
    take = np.minimum(np.minimum(k * deficit * covered * dt, deficit * pore), supply)
    share = np.divide(take, supply, out=np.zeros(n_g), where=supply > 0)
    amount = offer * share[c]
    taken += np.bincount(p, amount, len(water))
    return taken, np.bincount(c, amount, n_g)


def evaporate(theta: np.ndarray, pore: np.ndarray, surface: np.ndarray, area: float, rate: float,
              dt: float) -> float:  # fmt: skip
    """Take E·A·Δt (at most what they hold) from the ``surface`` particles' water (θ in place); returns m³ taken."""
    if rate <= 0 or dt <= 0:
        return 0.0
    held = theta[surface] * pore[surface]
    loss = np.minimum(held, rate * area * dt)
    theta[surface] = (held - loss) / pore[surface]
    return float(loss.sum())


def harmonic(k_a: np.ndarray, k_b: np.ndarray) -> np.ndarray:
    """Conductivity between two layers in series, K̄ = 2K_aK_b/(K_a + K_b) (0 where either is 0)."""
    total = k_a + k_b
    return np.divide(2.0 * k_a * k_b, total, out=np.zeros(np.broadcast(k_a, k_b).shape), where=total > 0)


def drain(theta: np.ndarray, pore: np.ndarray, upper: np.ndarray, lower: np.ndarray, k_between: np.ndarray,
          area: float, dt: float) -> float:  # fmt: skip
    """One step of Darcy drainage q = K̄ θ_u (1 − θ_l) from each ``upper`` particle to its ``lower`` one.

    ``k_between`` (m/s) the harmonic-mean conductivity of each pair, ``area`` the top area (m²);
    θ in place, every pair's amount taken from one and given to the other; returns the m³ moved.
    """
    if dt <= 0 or len(upper) == 0:
        return 0.0
    tu, tl = theta[upper], theta[lower]
    flow = k_between * tu * np.clip(1.0 - tl, 0.0, 1.0) * area * dt
    flow = np.minimum(flow, np.minimum(tu * pore[upper], np.clip(1.0 - tl, 0.0, 1.0) * pore[lower]))
    theta[upper] -= flow / pore[upper]
    theta[lower] += flow / pore[lower]
    return float(flow.sum())
