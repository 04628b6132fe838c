"""Raster kernels on heightmaps: Q4 bilinear interpolation, its gradient, scatter, normals, slope.

Conventions (every caller relies on them):

* ``z[iy, ix]`` — row index ``iy`` is the y axis (row 0 = north, y grows southward), column ``ix``
  the x axis; arrays are C-contiguous float64.
* Positions ``x, y`` are in **cell units**: node ``(ix, iy)`` sits at ``x = ix, y = iy``; the map
  spans ``0 <= x <= nx-1``, ``0 <= y <= ny-1``. Positions outside are **clamped** to the map.
* Gradients returned by :func:`gradient` are per cell unit; divide by the cell size for m/m.

The interpolation is the four-node quadrilateral (Q4) of SPEC HM-2 on the reference square
ξ, η ∈ [−1, 1] of the cell holding the point (ξ = 2(x − i₀) − 1, η = 2(y − j₀) − 1):

    N₁ = ¼(1−ξ)(1−η)  at node (i₀,   j₀)
    N₂ = ¼(1+ξ)(1−η)  at node (i₀+1, j₀)
    N₃ = ¼(1+ξ)(1+η)  at node (i₀+1, j₀+1)
    N₄ = ¼(1−ξ)(1+η)  at node (i₀,   j₀+1)

    F(ξ, η) = Σ F_j N_j,   Σ N_j = 1,   N_i(node j) = δ_ij.

Scatter (HM-3) is the transpose: a quantity F at (ξ₀, η₀) adds F·N_j(ξ₀, η₀) to node j, so the
total added is exactly F.

These are hand-written Numba kernels (not scipy.ndimage.map_coordinates) because the particle
models (hydrology droplets, particle stream, SPH coupling) call them one point at a time from
inside their own jitted loops, where a Python-level library call is impossible.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


@njit(cache=True, inline="always")
def q4_shape(xi, eta):
    """Q4 shape functions (N₁, N₂, N₃, N₄) at (ξ, η) ∈ [−1, 1]² (SPEC HM-2)."""
    return (
        0.25 * (1.0 - xi) * (1.0 - eta),
        0.25 * (1.0 + xi) * (1.0 - eta),
        0.25 * (1.0 + xi) * (1.0 + eta),
        0.25 * (1.0 - xi) * (1.0 + eta),
    )


@njit(cache=True, inline="always")
def locate(n, x):
    """Clamp ``x`` to [0, n−1]; return (i₀, ξ) with i₀ the cell's lower node and ξ ∈ [−1, 1].

    For a one-node axis (n == 1) returns i₀ = 0 and ξ = −1 (all weight on node 0).
    """
    if n < 2:
        return 0, -1.0
    top = n - 1.0
    if x < 0.0:
        x = 0.0
    elif x > top:
        x = top
    i0 = int(math.floor(x))
    if i0 > n - 2:
        i0 = n - 2
    return i0, 2.0 * (x - i0) - 1.0


@njit(cache=True, inline="always")
def upper_nodes(nx, ny, i0, j0):
    """Indices of the cell's upper nodes (collapsed onto the lower ones on 1-node axes)."""
    i1 = i0 + 1 if nx > 1 else i0
    j1 = j0 + 1 if ny > 1 else j0
    return i1, j1


@njit(cache=True)
def bilinear(z, x, y):
    """Height at (x, y) in cell units: F = Σ z_j N_j(ξ, η) (Q4, SPEC HM-2), clamped to the map."""
    ny, nx = z.shape
    i0, xi = locate(nx, x)
    j0, eta = locate(ny, y)
    i1, j1 = upper_nodes(nx, ny, i0, j0)
    n1, n2, n3, n4 = q4_shape(xi, eta)
    return n1 * z[j0, i0] + n2 * z[j0, i1] + n3 * z[j1, i1] + n4 * z[j1, i0]


@njit(cache=True)
def gradient(z, x, y):
    """(∂F/∂x, ∂F/∂y) per cell unit of the Q4 interpolant at (x, y), clamped to the map.

    ∂F/∂x = 2 Σ z_j ∂N_j/∂ξ with ∂N₁/∂ξ = −¼(1−η), ∂N₂/∂ξ = ¼(1−η), ∂N₃/∂ξ = ¼(1+η),
    ∂N₄/∂ξ = −¼(1+η) (the factor 2 is dξ/dx); ∂F/∂y likewise with ξ ↔ η.
    On cell edges the derivative of the cell with the lower index is used (the upper one at the
    last row/column). Divide by the cell size for a slope in m/m.
    """
    ny, nx = z.shape
    i0, xi = locate(nx, x)
    j0, eta = locate(ny, y)
    i1, j1 = upper_nodes(nx, ny, i0, j0)
    z1 = z[j0, i0]
    z2 = z[j0, i1]
    z3 = z[j1, i1]
    z4 = z[j1, i0]
    gx = 0.5 * ((1.0 - eta) * (z2 - z1) + (1.0 + eta) * (z3 - z4)) if nx > 1 else 0.0
    gy = 0.5 * ((1.0 - xi) * (z4 - z1) + (1.0 + xi) * (z3 - z2)) if ny > 1 else 0.0
    return gx, gy


@njit(cache=True)
def scatter_bilinear(field, x, y, value):
    """Add ``value`` at (x, y) to the four nodes as value·N_j(ξ, η) (SPEC HM-3); clamped to the map.

    The four weights sum to one, so the field's total grows by exactly ``value`` (up to rounding).
    """
    ny, nx = field.shape
    i0, xi = locate(nx, x)
    j0, eta = locate(ny, y)
    i1, j1 = upper_nodes(nx, ny, i0, j0)
    n1, n2, n3, n4 = q4_shape(xi, eta)
    field[j0, i0] += value * n1
    field[j0, i1] += value * n2
    field[j1, i1] += value * n3
    field[j1, i0] += value * n4


@njit(cache=True)
def _central(z, cell_size, ix, iy):
    """(∂z/∂x, ∂z/∂y) in m/m at node (ix, iy) by central differences, one-sided at the edges."""
    ny, nx = z.shape
    dzdx = 0.0
    dzdy = 0.0
    if nx > 1:
        xa = max(ix - 1, 0)
        xb = min(ix + 1, nx - 1)
        dzdx = (z[iy, xb] - z[iy, xa]) / ((xb - xa) * cell_size)
    if ny > 1:
        ya = max(iy - 1, 0)
        yb = min(iy + 1, ny - 1)
        dzdy = (z[yb, ix] - z[ya, ix]) / ((yb - ya) * cell_size)
    return dzdx, dzdy


@njit(cache=True)
def normal(z, cell_size, ix, iy):
    """Unit surface normal (n_x, n_y, n_z) at node (ix, iy): (−∂z/∂x, −∂z/∂y, 1)/‖·‖.

    Derivatives by central differences (z[iy, ix+1] − z[iy, ix−1])/(2Δ) (one-sided at the edges),
    Δ = ``cell_size`` in metres; x along columns, y along rows (southward), z up.
    """
    dzdx, dzdy = _central(z, cell_size, ix, iy)
    inv = 1.0 / math.sqrt(dzdx * dzdx + dzdy * dzdy + 1.0)
    return -dzdx * inv, -dzdy * inv, inv


@njit(cache=True, parallel=True)
def slope(z, cell_size):
    """Slope angle α = atan(‖∇z‖) in radians at every node, ∇z by central differences (m/m)."""
    ny, nx = z.shape
    out = np.empty((ny, nx), dtype=np.float64)
    for iy in prange(ny):
        for ix in range(nx):
            dzdx, dzdy = _central(z, cell_size, ix, iy)
            out[iy, ix] = math.atan(math.sqrt(dzdx * dzdx + dzdy * dzdy))
    return out


@njit(cache=True, parallel=True)
def bilinear_points(z, xs, ys):
    """:func:`bilinear` at many points (cell units); returns an array shaped like ``xs``."""
    out = np.empty(xs.shape[0], dtype=np.float64)
    for k in prange(xs.shape[0]):
        out[k] = bilinear(z, xs[k], ys[k])
    return out


@njit(cache=True, inline="always")
def nearest_node(pos, i, x0, y0, inv_dx, inv_dy, nx, ny):
    """Flat index iy·nx + ix of the raster node nearest particle i (a raster with origin (x0, y0) in the
    particles' frame, 1/Δx and 1/Δy given; a 2-D particle's raster is one row), or −1 outside it: the
    node whose cell [x − Δx/2, x + Δx/2) holds the particle, as the fluid is binned and its sediment held."""
    ix = int(math.floor((pos[i, 0] - x0) * inv_dx + 0.5))
    iy = int(math.floor((pos[i, 1] - y0) * inv_dy + 0.5)) if pos.shape[1] == 3 else 0
    if ix < 0 or ix >= nx or iy < 0 or iy >= ny:
        return -1
    return iy * nx + ix

