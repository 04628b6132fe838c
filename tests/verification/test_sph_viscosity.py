"""Viscosity and density diffusion against the analytic decay rates of a shear wave and a density wave.

A shear wave u_x = U sin(k y) in a fluid at rest density (no gravity, so no pressure gradient) decays
as ∂u_x/∂t = ν ∇²u_x = −ν k² U sin(k y). The solver's first force evaluation gives ∂u/∂t at every
particle; in the interior of a lattice block it must be ν_eff ∇²u_x with the viscosity the method
stands for on that lattice (the continuum value times a lattice moment that is computed here
independently, from the kernel alone):

* laminar (SPH-6a, Brookshaw's Laplacian L = −2 f r²/(r² + η²)): ν_eff = (μ/ρ₀) · ½ Σ_j V_j L(r_j) y_j²,
  which is μ/ρ₀ in the continuum (½∫L y² dV = 1);
* artificial (SPH-6b, Monaghan's Π with k_v = 2αh_s c, acting on approaching pairs only):
  ν_eff = −(k_v/8) Σ_j V_j x_j² y_j² f(r_j)/(r_j² + ε²), which is α h_s c/(4(d + 2)) in the continuum
  (the Π of every pair gives αh_s c/(2(d + 2)), Monaghan 2005; the approach switch keeps half of it).

Taylor terms beyond the second order are (kh)²/30 ≈ 4·10⁻⁴ of the rate here; the tolerance is 1 %.
"""

import numpy as np
import pytest

from erosim.kernels.sph_kernels import kernel_f, kernel_lap
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver

DX = 0.01


def _lattice_moments(dim: int, h: float):
    k = int(np.ceil(h / DX)) + 1
    ax = np.arange(-k, k + 1) * DX
    g = np.stack([a.ravel() for a in np.meshgrid(*([ax] * dim), indexing="ij")], axis=1)
    r2 = (g * g).sum(axis=1)
    g, r2 = g[(r2 > 0) & (r2 < h * h)], r2[(r2 > 0) & (r2 < h * h)]
    r = np.sqrt(r2)
    v = DX**dim
    lam = 0.5 * (v * kernel_lap(r, h, dim) * g[:, 1] ** 2).sum()
    art = (v * g[:, 0] ** 2 * g[:, 1] ** 2 * kernel_f(r, h, dim) / (r2 + 0.01 * (0.5 * h) ** 2)).sum()
    return lam, art


def _shear_rate(dim: int, viscosity: str, **extra):
    """(acceleration along x, ∇²u_x, solver) on the interior particles of a block with a shear wave."""
    nx, ny = 16, 120
    axes = [(np.arange(nx) + 0.5) * DX, (np.arange(ny) + 0.5) * DX] + ([(np.arange(nx) + 0.5) * DX] if dim == 3 else [])
    pos = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
    k, U = 2 * np.pi / (ny * DX), 0.1
    vel = np.zeros_like(pos)
    vel[:, 0] = U * np.sin(k * pos[:, 1])
    p = SPHParams(dim=dim, spacing=DX, gravity=(0.0,) * dim, sound_speed=10.0, walls="reflect", viscosity=viscosity,
                  initial_pressure="zero", **extra)  # fmt: skip
    s = SPHSolver(p, pos, fluid_vel=vel, domain_lo=[-1.0] * dim, domain_hi=[3.0] * dim)
    hi = np.array([nx * DX, ny * DX] + ([nx * DX] if dim == 3 else []))
    inner = np.all((pos > 1.01 * s.h) & (pos < hi - 1.01 * s.h), axis=1) & (np.abs(np.sin(k * pos[:, 1])) > 0.3)
    lap = -k * k * U * np.sin(k * pos[:, 1])
    return s.fluid_accelerations()[inner, 0], lap[inner], s


@pytest.mark.parametrize("dim", [2, 3])
def test_laminar_viscosity_decays_a_shear_wave_at_the_analytic_rate(dim):
    acc, lap, s = _shear_rate(dim, "laminar", mu=1.0)
    lam, _ = _lattice_moments(dim, s.h)
    nu = 1.0 / 1000.0
    assert 0.95 < lam <= 1.0  # the lattice moment is the continuum's 1 within the kernel's consistency
    np.testing.assert_allclose(acc, nu * lam * lap, rtol=0.01)


@pytest.mark.parametrize("dim", [2, 3])
def test_artificial_viscosity_decays_a_shear_wave_at_the_analytic_rate(dim):
    alpha = 0.1
    acc, lap, s = _shear_rate(dim, "artificial", alpha=alpha)
    _, art = _lattice_moments(dim, s.h)
    kv = 2.0 * alpha * (0.5 * s.h) * s.c
    nu = -kv / 8.0 * art
    continuum = alpha * 0.5 * s.h * s.c / (4 * (dim + 2))
    assert 0.5 * continuum < nu <= continuum  # the lattice moment falls short of the continuum's by 12 % / 41 %
    np.testing.assert_allclose(acc, nu * lap, rtol=0.01)


@pytest.mark.parametrize("dim", [2, 3])
def test_density_diffusion_smooths_a_density_wave_at_the_analytic_rate(dim):
    """δ-SPH (Molteni & Colagrossi 2009): with the fluid at rest and no gravity (so no hydrostatic
    part), dρ/dt = δ h_s c Σ_j V_j L(r_j) (ρ_j − ρ_i) = δ h_s c λ ∇²ρ, with L Brookshaw's weight and
    λ = ½ Σ V L y² the lattice moment of the laminar test above; for ρ = ρ₀(1 + ε sin ky) the rate
    is −δ h_s c λ k² ρ₀ ε sin ky (1 %: Taylor terms (kh)²/30, and V_j = m/ρ_j differs from Δx^d by ε)."""
    nx, ny = 16, 120
    axes = [(np.arange(nx) + 0.5) * DX, (np.arange(ny) + 0.5) * DX] + ([(np.arange(nx) + 0.5) * DX] if dim == 3 else [])
    pos = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
    k, eps, delta = 2 * np.pi / (ny * DX), 1e-3, 0.1
    p = SPHParams(dim=dim, spacing=DX, gravity=(0.0,) * dim, sound_speed=10.0, walls="reflect", initial_pressure="zero",
                  density_diffusion=delta, dt=1e-8)  # fmt: skip
    s = SPHSolver(p, pos, domain_lo=[-1.0] * dim, domain_hi=[3.0] * dim)
    st = s.state
    y = st.pos[: st.n_fluid, 1].copy()
    st.rho[: st.n_fluid] = 1000.0 * (1.0 + eps * np.sin(k * y))
    s.step()  # one evaluation at the wave (the particles move by ~1e-13 m)
    hi = np.array([nx * DX, ny * DX] + ([nx * DX] if dim == 3 else []))
    x = st.pos[: st.n_fluid]
    inner = np.all((x > 1.01 * s.h) & (x < hi - 1.01 * s.h), axis=1) & (np.abs(np.sin(k * y)) > 0.3)
    lam, _ = _lattice_moments(dim, s.h)
    expected = -delta * (0.5 * s.h) * s.c * lam * k * k * 1000.0 * eps * np.sin(k * y[inner])
    np.testing.assert_allclose(st.drho[: st.n_fluid][inner], expected, rtol=0.01)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("viscosity", ["artificial", "laminar"])
def test_walls_are_free_slip_unless_they_take_the_fluids_viscosity(dim, viscosity):
    """A layer sliding at U along a floor of boundary particles (no gravity, ρ = ρ₀, so no pressure and
    no fluid–fluid shear): with ``wall_viscosity = "none"`` nothing acts along the floor; with
    ``"fluid"`` the floor drags each particle within a support of it by the fluid's own pair term with
    v_wall = 0, summed here from the formulas of :mod:`erosim.sph.forces` over the floor's particles
    (artificial: m Σ_b k_v min(U x_ib, 0) f x_ib/(2ρ₀(r² + ε²)); laminar: −m Σ_b μ L U/ρ₀²)."""
    nx, nz = 24, 4
    axes = [(np.arange(nx) + 0.5) * DX] * (dim - 1) + [(np.arange(nz) + 0.5) * DX]
    pos = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
    faxes = [(np.arange(-6, nx + 6) + 0.5) * DX] * (dim - 1) + [-(np.arange(3) + 0.5) * DX]
    floor = np.stack([g.ravel() for g in np.meshgrid(*faxes, indexing="ij")], axis=1)
    U = 0.2
    vel = np.zeros_like(pos)
    vel[:, 0] = U
    got = {}
    for wall in ("none", "fluid"):
        p = SPHParams(dim=dim, spacing=DX, gravity=(0.0,) * dim, sound_speed=10.0, walls="reflect", mu=1.0,
                      viscosity=viscosity, initial_pressure="zero", wall_viscosity=wall)  # fmt: skip
        s = SPHSolver(p, pos, fluid_vel=vel, boundary_pos=floor, domain_lo=[-1.0] * dim, domain_hi=[3.0] * dim)
        got[wall] = s.fluid_accelerations()[:, 0]
    inner = np.all((pos[:, :-1] > 1.01 * s.h) & (pos[:, :-1] < nx * DX - 1.01 * s.h), axis=1)
    np.testing.assert_array_equal(got["none"][inner], 0.0)  # exactly: every pair term vanishes
    expected = np.zeros(len(pos))
    for i in np.nonzero(inner)[0]:
        off = pos[i] - floor
        r2 = (off**2).sum(axis=1)
        near = r2 < s.h**2
        off, r2 = off[near], r2[near]
        r = np.sqrt(r2)
        if viscosity == "artificial":
            c_r = s.kv * np.minimum(U * off[:, 0], 0.0) * kernel_f(r, s.h, dim) / (2000.0 * (r2 + s.eps2))
            expected[i] = s.m * (c_r * off[:, 0]).sum()
        else:
            expected[i] = -s.m * (1.0 * kernel_lap(r, s.h, dim) * U / 1000.0**2).sum()
    touching = inner & (pos[:, -1] + 0.5 * DX < (1 - 1e-9) * s.h)  # within a support of the first floor layer
    assert np.all(expected[touching] < 0)  # a drag, against the motion
    np.testing.assert_allclose(got["fluid"][inner], expected[inner], rtol=1e-9, atol=1e-12)
