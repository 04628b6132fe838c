"""SPH kernels (SPEC SPH-2 and Wendland C2): normalisation, gradient, Laplacian weight."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from erosim.kernels.sph_kernels import kernel_grad, kernel_lap, kernel_w

KERNELS = ["muller", "wendland"]
H = 0.37  # any support radius; all checks are scale-free


def _radial_integral(fn, dim):
    shell = (lambda r: 2 * math.pi * r) if dim == 2 else (lambda r: 4 * math.pi * r * r)
    return quad(lambda r: shell(r) * fn(r), 0.0, H, limit=200)[0]


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("dim", [2, 3])
def test_kernel_is_normalised(kernel, dim):
    total = _radial_integral(lambda r: kernel_w(np.array([r]), H, dim, kernel)[0], dim)
    assert total == pytest.approx(1.0, abs=1e-9)  # quadrature of a polynomial: exact to round-off


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("dim", [2, 3])
def test_kernel_is_compact_and_non_negative(kernel, dim):
    r = np.linspace(0, 2 * H, 401)
    w = kernel_w(r, H, dim, kernel)
    assert np.all(w >= 0)
    assert np.all(w[r >= H] == 0)
    assert w[0] > 0


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("dim", [2, 3])
def test_gradient_is_antisymmetric_and_points_inward(kernel, dim):
    rng = np.random.default_rng(3)
    rvec = rng.uniform(-H, H, (500, dim))
    g = kernel_grad(rvec, H, kernel)
    np.testing.assert_array_equal(kernel_grad(-rvec, H, kernel), -g)
    r = np.linalg.norm(rvec, axis=1)
    inside = r < H
    assert np.all((g * rvec).sum(axis=1)[inside] <= 0)  # W decreases outwards
    assert np.all(g[~inside] == 0)


@pytest.mark.parametrize("dim", [2, 3])
def test_wendland_gradient_is_the_derivative_of_w(dim):
    r = np.linspace(0.01, 0.99, 50) * H
    eps = 1e-6 * H
    dwdr = (kernel_w(r + eps, H, dim, "wendland") - kernel_w(r - eps, H, dim, "wendland")) / (2 * eps)
    rvec = np.zeros((r.size, dim))
    rvec[:, 0] = r
    g = kernel_grad(rvec, H, "wendland")[:, 0]
    np.testing.assert_allclose(g, dwdr, rtol=1e-6, atol=1e-9 * np.abs(dwdr).max())  # central difference O(eps²)


def test_muller_constants_match_spec_sph2():
    """The seed's 3-D formulas (SPEC SPH-2) at one radius, and the 2-D constants (normalised)."""
    r, h = 0.3, 0.5
    assert kernel_w(np.array([r]), h, 3, "muller")[0] == pytest.approx(
        315 / (64 * math.pi * h**9) * (h * h - r * r) ** 3
    )
    assert kernel_w(np.array([r]), h, 2, "muller")[0] == pytest.approx(4 / (math.pi * h**8) * (h * h - r * r) ** 3)
    g3 = kernel_grad(np.array([[r, 0, 0]]), h, "muller")[0, 0]
    assert g3 == pytest.approx(-45 / (math.pi * h**6) * (h - r) ** 2)
    g2 = kernel_grad(np.array([[r, 0]]), h, "muller")[0, 0]
    assert g2 == pytest.approx(-30 / (math.pi * h**5) * (h - r) ** 2)
    assert kernel_lap(np.array([r]), h, 3, "muller")[0] == pytest.approx(45 / (math.pi * h**6) * (h - r))
    # the spiky gradient at r = 0 is undefined; it is set to zero (deterministic, antisymmetric)
    assert np.all(kernel_grad(np.zeros((1, 3)), h, "muller") == 0)


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("dim", [2, 3])
def test_laplacian_weight_is_exact_for_quadratic_fields(kernel, dim):
    """Σ V_j (A_j − A_i) L(r) → ∫ A L dV = ∇²A = 2 for A = x²: ∫ r² L dV / dim = 2.

    Müller's viscosity Laplacian satisfies it exactly; Brookshaw's Wendland weight within 2.5 %
    (its η² = 0.01 h_s² regularisation removes that much near r = 0).
    """
    moment = _radial_integral(lambda r: r * r * kernel_lap(np.array([r]), H, dim, kernel)[0], dim) / dim
    tol = 1e-9 if kernel == "muller" else 0.025
    assert moment == pytest.approx(2.0, rel=tol)
