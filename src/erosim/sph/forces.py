"""SPH pair forces and density rates (SPEC SPH-3, SPH-5, SPH-6, SPH-7), fused into one neighbour pass.

Per fluid particle i, over its neighbour list (fluid j first, then fixed boundary j), one loop computes

* pressure (SPH-5):  a_i −= Σ m_j P_ij ∇W_ij with P_ij = p_i/ρ_i² + p_j/ρ_j² ("wcsph", SPH-5b) or
  (p_i + p_j)/(2ρ_iρ_j) ("symmetric", seed 000 eq. 2.5 divided by ρ_i, SPH-5a);
* viscosity (SPH-6):  artificial (Monaghan 1992 as in Becker & Teschner 2007)
  a_i −= Σ m_j Π_ij ∇W_ij, Π_ij = −ν v_ij·r_ij/(r² + εh_s²), ν = 2αh_s c/(ρ_i + ρ_j), only if v_ij·r_ij < 0;
  or laminar (seed 000 eq. 2.6 divided by ρ_i) a_i += μ Σ m_j (v_j − v_i)/(ρ_iρ_j) ∇²W;
* continuity: dρ_i/dt = Σ m_j v_ij·∇W_ij (Monaghan 1992) plus, between fluid particles, δ-SPH density
  diffusion (Molteni & Colagrossi 2009) with the hydrostatic correction of Fourtakas et al. (2019):
  + δ h_s c Σ (m_j/ρ_j) 2 [(ρ_j − ρ_i) − (ρ_j^H − ρ_i^H)] (−f_ij r²)/(r² + η²),
  ρ_j^H − ρ_i^H = −ρ₀ g·r_ij / c²  (r_ij = r_i − r_j, ∇W_ij = f_ij r_ij, η² = 0.01 h_s²);
* gravity (SPH-7) added once;
* the density diffusion's rate K_i = m k_δ Σ_j (−f_ij) r²/((r² + η²)ρ_j) (``krate``, k_δ = ``kdiff``), from
  which the solver keeps its step stable (:mod:`erosim.sph.diffusion_limit_molteni2009`).

Boundary particles (fixed, "dynamic boundary particles" of Crespo et al. 2007) are neighbours like
any other (v_j = 0, no density diffusion) except that their viscous term has its own coefficient
``kvb``: ``kv`` by default (``wall_viscosity = "fluid"``: a no-slip wall with the fluid's viscosity),
0 with ``"none"`` (free-slip walls, which also lose the damping of the fluid's approach). Water's
boundary layer, √(νt) ≈ 1 mm after a second, is far thinner than a spacing; the artificial
viscosity's ν = αh_s c/(4(d + 2)) (5·10⁻³ m²/s at Δx = 3 cm and c = 33 m/s) makes it about 7 cm
after a second (docs/sph.md, "Walls: no-slip or free-slip", measures both on SPHERIC Test 2).
Their own density passes belong to their boundary model (:mod:`erosim.sph.boundaries.particles`).
h is the kernel support radius, h_s = h/2 the smoothing length used in ν, δ and ε.

The variants are scalar Numba functions passed to the per-particle bodies; the parallel loop drivers
below are one small cached function per combination (Numba cannot cache a driver that takes functions
as arguments, so each combination is spelled out; :func:`fluid_driver` picks one by name):
``gradf(r, h)``, ``lap(r, h)`` (from :mod:`erosim.kernels.sph_kernels`),
``pterm(p_i, p_j, ρ_i, ρ_j)`` and ``visc(v·r, r², f, L, ρ_i, ρ_j, k_visc, ε²) -> (c_r, c_v)`` where
the viscous acceleration is m_j (c_r r_ij + c_v v_ij).

Neighbour indices are read as unsigned integers (``np.uint64``): with a signed index Numba adds a
negative-index wraparound to every array access, about 15 % of the pass's time (docs/performance.md).
The arithmetic, and so every result, is the same.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from erosim.kernels import sph_kernels as K

# ---------------------------------------------------------------- pair terms


@njit(inline="always", cache=True)
def pterm_wcsph(pi, pj, rhoi, rhoj):
    """SPH-5b: p_i/ρ_i² + p_j/ρ_j²."""
    return pi / (rhoi * rhoi) + pj / (rhoj * rhoj)


@njit(inline="always", cache=True)
def pterm_symmetric(pi, pj, rhoi, rhoj):
    """SPH-5a: (p_i + p_j)/(2ρ_iρ_j)."""
    return (pi + pj) / (2.0 * rhoi * rhoj)


@njit(inline="always", cache=True)
def visc_artificial(vdotr, r2, f, lapw, rhoi, rhoj, kv, eps2):
    """Monaghan Π (SPH-6b), kv = 2αh_s c: returns (c_r, c_v) = (−Π f, 0)."""
    return kv * min(vdotr, 0.0) * f / ((rhoi + rhoj) * (r2 + eps2)), 0.0  # branch-free: 0 when separating


@njit(inline="always", cache=True)
def visc_laminar(vdotr, r2, f, lapw, rhoi, rhoj, kv, eps2):
    """Laminar (SPH-6a), kv = μ: returns (0, −μ L/(ρ_iρ_j))."""
    return 0.0, -kv * lapw / (rhoi * rhoj)


@njit(inline="always", cache=True)
def no_lap(r, h):
    """Stand-in Laplacian for the artificial viscosity (which does not use it)."""
    return 0.0


# ---------------------------------------------------------------- fused drivers


@njit(inline="always")
def fluid_particle_3d(
    gradf,
    lap,
    pterm,
    visc,
    i,
    pos,
    vel,
    rho,
    p,
    start,
    mid,
    nbr,
    m,
    h,
    kv,
    kvb,
    eps2,
    kdiff,
    eta2,
    kh,
    gx,
    gy,
    gz,
    acc,
    drho,
):
    """3-D: acceleration and dρ/dt of fluid particle i (see the module docstring); returns the density
    diffusion's rate K_i (:mod:`erosim.sph.diffusion_limit_molteni2009`)."""
    h2 = h * h
    xi = pos[i, 0]
    yi = pos[i, 1]
    zi = pos[i, 2]
    ui = vel[i, 0]
    vi = vel[i, 1]
    wi = vel[i, 2]
    rhoi = rho[i]
    pi = p[i]
    ax = 0.0
    ay = 0.0
    az = 0.0
    dr = 0.0
    dd = 0.0
    kd = 0.0
    for s in range(np.uint64(start[i]), np.uint64(mid[i])):
        j = np.uint64(nbr[s])
        dx = xi - pos[j, 0]
        dy = yi - pos[j, 1]
        dz = zi - pos[j, 2]
        r2 = dx * dx + dy * dy + dz * dz
        if r2 >= h2:
            continue
        r = math.sqrt(r2)
        f = gradf(r, h)
        rhoj = rho[j]
        du = ui - vel[j, 0]
        dv = vi - vel[j, 1]
        dw = wi - vel[j, 2]
        vdotr = du * dx + dv * dy + dw * dz
        cr, cv = visc(vdotr, r2, f, lap(r, h), rhoi, rhoj, kv, eps2)
        c = cr - pterm(pi, p[j], rhoi, rhoj) * f
        ax += c * dx + cv * du
        ay += c * dy + cv * dv
        az += c * dz + cv * dw
        dr += vdotr * f
        wd = (-f) * r2 / ((r2 + eta2) * rhoj)
        dd += ((rhoj - rhoi) + kh * (gx * dx + gy * dy + gz * dz)) * wd
        kd += wd
    for s in range(np.uint64(mid[i]), np.uint64(start[i + 1])):
        j = np.uint64(nbr[s])
        dx = xi - pos[j, 0]
        dy = yi - pos[j, 1]
        dz = zi - pos[j, 2]
        r2 = dx * dx + dy * dy + dz * dz
        if r2 >= h2:
            continue
        r = math.sqrt(r2)
        f = gradf(r, h)
        rhoj = rho[j]
        vdotr = ui * dx + vi * dy + wi * dz
        cr, cv = visc(vdotr, r2, f, lap(r, h), rhoi, rhoj, kvb, eps2)
        c = cr - pterm(pi, p[j], rhoi, rhoj) * f
        ax += c * dx + cv * ui
        ay += c * dy + cv * vi
        az += c * dz + cv * wi
        dr += vdotr * f
    acc[i, 0] = m * ax + gx
    acc[i, 1] = m * ay + gy
    acc[i, 2] = m * az + gz
    drho[i] = m * (dr + kdiff * dd)
    return m * kdiff * kd


@njit(inline="always")
def fluid_particle_2d(
    gradf,
    lap,
    pterm,
    visc,
    i,
    pos,
    vel,
    rho,
    p,
    start,
    mid,
    nbr,
    m,
    h,
    kv,
    kvb,
    eps2,
    kdiff,
    eta2,
    kh,
    gx,
    gy,
    gz,
    acc,
    drho,
):
    """2-D: acceleration and dρ/dt of fluid particle i (``gz`` unused); returns K_i like the 3-D body."""
    h2 = h * h
    xi = pos[i, 0]
    yi = pos[i, 1]
    ui = vel[i, 0]
    vi = vel[i, 1]
    rhoi = rho[i]
    pi = p[i]
    ax = 0.0
    ay = 0.0
    dr = 0.0
    dd = 0.0
    kd = 0.0
    for s in range(np.uint64(start[i]), np.uint64(mid[i])):
        j = np.uint64(nbr[s])
        dx = xi - pos[j, 0]
        dy = yi - pos[j, 1]
        r2 = dx * dx + dy * dy
        if r2 >= h2:
            continue
        r = math.sqrt(r2)
        f = gradf(r, h)
        rhoj = rho[j]
        du = ui - vel[j, 0]
        dv = vi - vel[j, 1]
        vdotr = du * dx + dv * dy
        cr, cv = visc(vdotr, r2, f, lap(r, h), rhoi, rhoj, kv, eps2)
        c = cr - pterm(pi, p[j], rhoi, rhoj) * f
        ax += c * dx + cv * du
        ay += c * dy + cv * dv
        dr += vdotr * f
        wd = (-f) * r2 / ((r2 + eta2) * rhoj)
        dd += ((rhoj - rhoi) + kh * (gx * dx + gy * dy)) * wd
        kd += wd
    for s in range(np.uint64(mid[i]), np.uint64(start[i + 1])):
        j = np.uint64(nbr[s])
        dx = xi - pos[j, 0]
        dy = yi - pos[j, 1]
        r2 = dx * dx + dy * dy
        if r2 >= h2:
            continue
        r = math.sqrt(r2)
        f = gradf(r, h)
        rhoj = rho[j]
        vdotr = ui * dx + vi * dy
        cr, cv = visc(vdotr, r2, f, lap(r, h), rhoi, rhoj, kvb, eps2)
        c = cr - pterm(pi, p[j], rhoi, rhoj) * f
        ax += c * dx + cv * ui
        ay += c * dy + cv * vi
        dr += vdotr * f
    acc[i, 0] = m * ax + gx
    acc[i, 1] = m * ay + gy
    drho[i] = m * (dr + kdiff * dd)
    return m * kdiff * kd


@njit(inline="always")
def kernel_sum(w, i, pos, start, nbr, h):
    """Σ_j W(r_ij) over the neighbour list of particle i (i itself not included)."""
    h2 = h * h
    d = pos.shape[1]
    acc = 0.0
    for s in range(start[i], start[i + 1]):
        j = nbr[s]
        r2 = 0.0
        for a in range(d):
            t = pos[i, a] - pos[j, a]
            r2 += t * t
        if r2 < h2:
            acc += w(math.sqrt(r2), h)
    return acc


@njit(inline="always")
def summation_particle(w, i, pos, start, nbr, m, h, rho):
    """SPH-3: ρ_i = m (W(0) + Σ_j W(r_ij)) of fluid particle i (fluid and boundary neighbours)."""
    rho[i] = m * (w(0.0, h) + kernel_sum(w, i, pos, start, nbr, h))


# ---------------------------------------------------------------- drivers, one per variant
# (listed out so Numba can cache each; the body above is shared)

# reciprocal approximations and fused multiply-add only: NaN/inf semantics stay IEEE (NaN detection)
_FAST = {"arcp", "contract"}


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_2d_wendland_wcsph_artificial(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_2d(
            K.wendland_f_2d, no_lap, pterm_wcsph, visc_artificial,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_2d_wendland_wcsph_laminar(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_2d(
            K.wendland_f_2d, K.wendland_lap_2d, pterm_wcsph, visc_laminar,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_2d_wendland_symmetric_artificial(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_2d(
            K.wendland_f_2d, no_lap, pterm_symmetric, visc_artificial,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_2d_wendland_symmetric_laminar(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_2d(
            K.wendland_f_2d, K.wendland_lap_2d, pterm_symmetric, visc_laminar,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_2d_muller_wcsph_artificial(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_2d(
            K.muller_f_2d, no_lap, pterm_wcsph, visc_artificial,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_2d_muller_wcsph_laminar(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_2d(
            K.muller_f_2d, K.muller_lap_2d, pterm_wcsph, visc_laminar,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_2d_muller_symmetric_artificial(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_2d(
            K.muller_f_2d, no_lap, pterm_symmetric, visc_artificial,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_2d_muller_symmetric_laminar(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_2d(
            K.muller_f_2d, K.muller_lap_2d, pterm_symmetric, visc_laminar,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_3d_wendland_wcsph_artificial(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_3d(
            K.wendland_f_3d, no_lap, pterm_wcsph, visc_artificial,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_3d_wendland_wcsph_laminar(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_3d(
            K.wendland_f_3d, K.wendland_lap_3d, pterm_wcsph, visc_laminar,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_3d_wendland_symmetric_artificial(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_3d(
            K.wendland_f_3d, no_lap, pterm_symmetric, visc_artificial,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_3d_wendland_symmetric_laminar(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_3d(
            K.wendland_f_3d, K.wendland_lap_3d, pterm_symmetric, visc_laminar,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_3d_muller_wcsph_artificial(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_3d(
            K.muller_f_3d, no_lap, pterm_wcsph, visc_artificial,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_3d_muller_wcsph_laminar(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_3d(
            K.muller_f_3d, K.muller_lap_3d, pterm_wcsph, visc_laminar,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_3d_muller_symmetric_artificial(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_3d(
            K.muller_f_3d, no_lap, pterm_symmetric, visc_artificial,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True, fastmath=_FAST)
def fluid_pass_3d_muller_symmetric_laminar(
    pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho, krate
):
    for i in prange(n_fluid):
        krate[i] = fluid_particle_3d(
            K.muller_f_3d, K.muller_lap_3d, pterm_symmetric, visc_laminar,
            i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
        )  # fmt: skip


@njit(parallel=True, cache=True)
def summation_density_2d_wendland(pos, start, nbr, n_fluid, m, h, rho):
    for i in prange(n_fluid):
        summation_particle(K.wendland_w_2d, i, pos, start, nbr, m, h, rho)


@njit(parallel=True, cache=True)
def summation_density_2d_muller(pos, start, nbr, n_fluid, m, h, rho):
    for i in prange(n_fluid):
        summation_particle(K.muller_w_2d, i, pos, start, nbr, m, h, rho)


@njit(parallel=True, cache=True)
def summation_density_3d_wendland(pos, start, nbr, n_fluid, m, h, rho):
    for i in prange(n_fluid):
        summation_particle(K.wendland_w_3d, i, pos, start, nbr, m, h, rho)


@njit(parallel=True, cache=True)
def summation_density_3d_muller(pos, start, nbr, n_fluid, m, h, rho):
    for i in prange(n_fluid):
        summation_particle(K.muller_w_3d, i, pos, start, nbr, m, h, rho)


_FLUID = {
    (2, "wendland", "wcsph", "artificial"): fluid_pass_2d_wendland_wcsph_artificial,
    (2, "wendland", "wcsph", "laminar"): fluid_pass_2d_wendland_wcsph_laminar,
    (2, "wendland", "symmetric", "artificial"): fluid_pass_2d_wendland_symmetric_artificial,
    (2, "wendland", "symmetric", "laminar"): fluid_pass_2d_wendland_symmetric_laminar,
    (2, "muller", "wcsph", "artificial"): fluid_pass_2d_muller_wcsph_artificial,
    (2, "muller", "wcsph", "laminar"): fluid_pass_2d_muller_wcsph_laminar,
    (2, "muller", "symmetric", "artificial"): fluid_pass_2d_muller_symmetric_artificial,
    (2, "muller", "symmetric", "laminar"): fluid_pass_2d_muller_symmetric_laminar,
    (3, "wendland", "wcsph", "artificial"): fluid_pass_3d_wendland_wcsph_artificial,
    (3, "wendland", "wcsph", "laminar"): fluid_pass_3d_wendland_wcsph_laminar,
    (3, "wendland", "symmetric", "artificial"): fluid_pass_3d_wendland_symmetric_artificial,
    (3, "wendland", "symmetric", "laminar"): fluid_pass_3d_wendland_symmetric_laminar,
    (3, "muller", "wcsph", "artificial"): fluid_pass_3d_muller_wcsph_artificial,
    (3, "muller", "wcsph", "laminar"): fluid_pass_3d_muller_wcsph_laminar,
    (3, "muller", "symmetric", "artificial"): fluid_pass_3d_muller_symmetric_artificial,
    (3, "muller", "symmetric", "laminar"): fluid_pass_3d_muller_symmetric_laminar,
}


def fluid_driver(dim: int, kernel: str, pressure_form: str, viscosity: str):
    """The fused fluid pass for this combination of variants."""
    return _FLUID[(dim, kernel, pressure_form, viscosity)]


def summation_driver(dim: int, kernel: str):
    """Summation density (SPH-3) with this kernel."""
    return globals()[f"summation_density_{dim}d_{kernel}"]


@njit(parallel=True, cache=True)
def pressure_pass(rho, rho0, b, gamma, pmin, i0, i1, p):
    """p_i = max(B((ρ_i/ρ₀)^γ − 1), pmin) for i in [i0, i1) (the linear law is γ = 1, B = kρ₀)."""
    for i in prange(i0, i1):
        p[i] = max(b * ((rho[i] / rho0) ** gamma - 1.0), pmin)
