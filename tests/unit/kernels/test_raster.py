"""Raster kernels: Q4 interpolation (HM-2), scatter (HM-3), gradient, normals, slope."""

import math

import numpy as np
import pytest

from erosim.kernels import raster

# Rounding tolerance: every quantity here is a handful of float64 operations on O(100) values.
EPS = 1e-12


def _plane(ny=7, nx=9, a=0.7, b=-1.3, c=5.0):
    iy, ix = np.mgrid[0:ny, 0:nx].astype(np.float64)
    return np.ascontiguousarray(a * ix + b * iy + c), a, b, c


def test_shape_functions_partition_of_unity_and_kronecker():
    rng = np.random.default_rng(1)
    for xi, eta in rng.uniform(-1, 1, size=(50, 2)):
        assert sum(raster.q4_shape(xi, eta)) == pytest.approx(1.0, abs=EPS)
    corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    for i, (xi, eta) in enumerate(corners):
        n = raster.q4_shape(float(xi), float(eta))
        assert n[i] == 1.0
        assert sum(abs(v) for j, v in enumerate(n) if j != i) == 0.0


def test_bilinear_reproduces_nodes():
    z = np.random.default_rng(2).normal(size=(6, 8))
    for iy in range(6):
        for ix in range(8):
            assert raster.bilinear(z, float(ix), float(iy)) == pytest.approx(z[iy, ix], abs=EPS)


def test_bilinear_exact_on_linear_and_bilinear_functions():
    z, a, b, c = _plane()
    rng = np.random.default_rng(3)
    for x, y in rng.uniform(0, 6, size=(100, 2)):
        assert raster.bilinear(z, x, y) == pytest.approx(a * x + b * y + c, abs=1e-11)
        gx, gy = raster.gradient(z, x, y)
        assert gx == pytest.approx(a, abs=1e-11)
        assert gy == pytest.approx(b, abs=1e-11)
    # The Q4 space also holds x·y exactly.
    iy, ix = np.mgrid[0:5, 0:5].astype(np.float64)
    zxy = np.ascontiguousarray(ix * iy)
    assert raster.bilinear(zxy, 1.3, 2.6) == pytest.approx(1.3 * 2.6, abs=EPS)


def test_gradient_matches_finite_difference_inside_a_cell():
    z = np.random.default_rng(4).normal(size=(5, 5))
    x, y, h = 1.4, 2.7, 1e-6
    gx, gy = raster.gradient(z, x, y)
    fx = (raster.bilinear(z, x + h, y) - raster.bilinear(z, x - h, y)) / (2 * h)
    fy = (raster.bilinear(z, x, y + h) - raster.bilinear(z, x, y - h)) / (2 * h)
    assert gx == pytest.approx(fx, abs=1e-8)  # finite-difference truncation ~h
    assert gy == pytest.approx(fy, abs=1e-8)


def test_bilinear_clamps_outside_the_map():
    z, a, b, c = _plane()
    assert raster.bilinear(z, -5.0, -3.0) == pytest.approx(z[0, 0], abs=EPS)
    assert raster.bilinear(z, 100.0, 100.0) == pytest.approx(z[-1, -1], abs=EPS)
    assert raster.bilinear(z, 8.0, 6.0) == pytest.approx(z[6, 8], abs=EPS)


def test_scatter_conserves_total_and_stays_on_map():
    field = np.zeros((10, 12))
    rng = np.random.default_rng(5)
    total = 0.0
    for x, y, v in zip(rng.uniform(-3, 15, 500), rng.uniform(-3, 13, 500), rng.normal(size=500), strict=True):
        raster.scatter_bilinear(field, x, y, v)
        total += v
    assert field.sum() == pytest.approx(total, abs=1e-10)


def test_scatter_is_transpose_of_interpolation():
    # <scatter(v at p), z> = v * bilinear(z, p): the adjoint property of HM-3 w.r.t. HM-2.
    z = np.random.default_rng(6).normal(size=(4, 5))
    field = np.zeros_like(z)
    raster.scatter_bilinear(field, 2.3, 1.6, 2.0)
    assert (field * z).sum() == pytest.approx(2.0 * raster.bilinear(z, 2.3, 1.6), abs=EPS)


def test_normal_and_slope_on_a_plane():
    z, a, b, c = _plane(a=0.5, b=0.25)
    cs = 2.0
    nx_, ny_, nz_ = raster.normal(z, cs, 3, 3)
    norm = math.sqrt((a / cs) ** 2 + (b / cs) ** 2 + 1)
    assert (nx_, ny_, nz_) == pytest.approx((-a / cs / norm, -b / cs / norm, 1 / norm), abs=EPS)
    s = raster.slope(z, cs)
    assert s.shape == z.shape
    np.testing.assert_allclose(s, math.atan(math.hypot(a / cs, b / cs)), atol=EPS)


def test_bilinear_points_matches_scalar():
    z = np.random.default_rng(7).normal(size=(6, 6))
    xs = np.array([0.0, 1.5, 4.9, 5.0])
    ys = np.array([0.2, 3.3, 0.0, 5.0])
    got = raster.bilinear_points(z, xs, ys)
    want = [raster.bilinear(z, x, y) for x, y in zip(xs, ys, strict=True)]
    np.testing.assert_allclose(got, want, atol=EPS)
