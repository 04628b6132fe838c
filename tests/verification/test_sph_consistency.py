"""SPH discretisation checks against exact answers: lattice consistency of the default kernels and a
3-D tank at rest against the hydrostatic pressure."""

import numpy as np
import pytest

from erosim.kernels.sph_kernels import kernel_grad, kernel_w
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver


@pytest.mark.parametrize("dim", [2, 3])
def test_default_support_reproduces_constant_and_linear_fields(dim):
    """On a lattice of spacing 1: Σ_j W_ij ≈ 1 and Σ_j x_j ∂W_ij/∂x_i = −1 (∇x = 1).

    Σ W is 1.034 in 3-D at 2.0Δx (density = "summation" calibrates the particle mass to it; the
    default continuity density does not use it).

    The gradient identity fails by 2.6 % in 2-D at h = 2.6Δx, which a hydrostatic tank then shows
    as 2 % pressure error; the 2-D default 3Δx keeps it within 0.3 %. In 3-D the default 2.0Δx (the
    thesis's h) is consistent to 1.8 % (tolerance below), 2.1Δx to 0.2 %.
    """
    h = SPHParams(dim=dim).h_factor
    ax = np.arange(-5.0, 6.0)
    g = np.stack(np.meshgrid(*([ax] * dim), indexing="ij"), axis=-1).reshape(-1, dim)
    w_sum = kernel_w(np.linalg.norm(g, axis=1), h, dim, "wendland").sum()
    grad_x = (g[:, 0] * kernel_grad(g, h, "wendland")[:, 0]).sum()
    assert w_sum == pytest.approx(1.0, abs=0.04)
    assert -grad_x == pytest.approx(1.0, abs=0.003 if dim == 2 else 0.02)


@pytest.mark.slow  # a 3-D tank settling, about 11 s; the 2-D tank (validation/test_hydrostatic.py) runs by default
def test_tank_at_rest_3d_matches_hydrostatic_pressure():
    """12³ particles in a 0.1 m tank settle 0.4 s: RMS of p − ρ₀g(H − z) below 2 % of ρ₀gH (issue 2's
    criterion; measured 1.4 %, most of it the 1.8 % gradient inconsistency of h = 2Δx), density
    within 1 % of ρ₀, fluid at rest (|v| < 1 % of √(gH)), none outside."""
    H, n = 0.1, 12
    dx = H / n
    ax = (np.arange(n) + 0.5) * dx
    fluid = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), axis=-1).reshape(-1, 3)
    lo, hi = np.zeros(3), np.array([H, H, 1.5 * H])
    s = SPHSolver(SPHParams(dim=3, spacing=dx), fluid, domain_lo=lo, domain_hi=hi)
    while s.t < 0.4:
        s.step()
    x, p, rho = s.fluid_positions(), s.fluid_pressure(), s.fluid_density()
    rms = np.sqrt(np.mean((p - 1000.0 * 9.81 * (H - x[:, 2])) ** 2)) / (1000.0 * 9.81 * H)
    assert rms < 0.02
    assert np.abs(rho / 1000.0 - 1.0).max() < 0.01
    assert s.vmax < 0.01 * np.sqrt(9.81 * H)
    assert np.all((x >= lo) & (x <= hi))
