"""Distance and normal to the iso-surface of a voxel density field (SPEC VX-3), per particle.

Conventions (every caller relies on them):

* ``dens[iz, iy, ix]`` — float32, C-contiguous; node ``(ix, iy, iz)`` sits at
  ``(x, y, z) = origin + (ix, iy, iz)·Δ`` (z up, the SPH frame);
* the solid is where the density exceeds the iso level ``iso``; the fluid where it is below;
* points outside the grid are clamped onto it: the edge values continue outwards.

At a point r inside the cell with lower node (i, j, k) and local coordinates (u, v, w) ∈ [0, 1]³,
trilinear interpolation of the 8 surrounding values d_abc (a, b, c ∈ {0, 1}) gives

    d(r) = Σ d_abc · ((1−a)(1−u) + a u) ((1−b)(1−v) + b v) ((1−c)(1−w) + c w),
    ∇d   = the analytic derivative of that polynomial (divided by Δ), p,

and, with the sign chosen **positive in the fluid**,

    l = (ISO − d)/|∇d|,        n = −∇d/|∇d|   (the unit normal pointing into the fluid).

l is the first-order (Newton) distance to the surface d = ISO. It is exact where d is linear in
space (a plane at any tilt inside a linear density ramp: trilinear interpolation reproduces
linear functions exactly). On a surface of curvature κ built from a ramp of the signed distance,
the interpolated d is in error by at most Δ²/8·|∂²d| per axis, so l by O(Δ²κ) and n by O(Δκ) rad.
Where |∇d| vanishes (outside the ramp, far from any surface) l is ±:data:`FAR` (+ in the fluid)
and n = (0, 0, 1).

*Concave edges: the gradient where the polynomial's goes flat.* At a concave edge — two walls meeting,
the density a max-combination of their ramps — the signed distance −min(x, z) has a kink along the
bisector. Where the bisector passes through a node, three of the four nodes of a cell's face next to
it read the same value and the polynomial is flat near that node: |p| → 0, l → ∞, no wall, in a pocket
a fraction of a cell from both walls (Δx/3 when the walls lie 2/3 of a cell off the nodes). Particles
are drawn into it (the wall's repulsion vanishes there): water at rest in a voxel tank so placed
(`erosim validate voxel-at-rest`, fine) read 14.6 % RMS pressure error against 1–2 % on the same tank
aligned with the nodes (docs/voxel.md). There the nodes' central differences q, (d[+1] − d[−1])/2Δ
per axis, interpolated trilinearly, straddle the kink and stay at the mean of the two walls' gradients.
So ∇d = p + b (q − p), b = 0 while |p| ≥ 0.75|q| (everywhere off such a kink: planes and smooth
surfaces keep the polynomial's exact gradient), rising linearly to 1 at |p| = 0.25|q|. Using q
everywhere was measured and rejected: its normals are not the gradient of l away from the kinks, and
the tank at rest kept circulating (coarse 4.3 %, default 5.2 % RMS against 2.8 % and 1.3 %).

Why hand-written Numba rather than ``scipy.ndimage.map_coordinates``: the SPH boundary passes and
the erosion model call :func:`sample` one particle at a time from inside their own parallel loops,
with the gradient from the same stencil, where a Python-level library call is impossible; and
:func:`wall_distance` computes every particle's l and n in one parallel pass (VX-10: no extra
neighbour loop). :func:`distance_normal` is compiled once as a function of its own (with :func:`sample`
inlined into it), not inlined into each of its callers' call sites: three inlined copies of the stencil
made the wall constraint's first compilation take 30 s instead of 6 s on the 2-core machine
(``benchmarks/voxel_compile_time.py``), for a voxel benchmark within its scatter either way.
"""

from __future__ import annotations

import math

from numba import njit, prange

#: the distance reported where the field is flat (far from any surface)
FAR = 1.0e30
#: |∇d| (density units per metre) below which the field counts as flat
FLAT = 1.0e-12
#: the polynomial's |∇d| over the nodes' below which ∇d blends towards the nodes' (fully at BLEND_LO)
BLEND_HI, BLEND_LO = 0.75, 0.25


@njit(inline="always", cache=True)
def cell_of(dens, ox, oy, oz, inv, x, y, z):
    """Lower node (i, j, k) of the cell holding (x, y, z), clamped onto the grid, and (u, v, w) in it."""
    nz, ny, nx = dens.shape
    fx = min(max((x - ox) * inv, 0.0), nx - 1.0)
    fy = min(max((y - oy) * inv, 0.0), ny - 1.0)
    fz = min(max((z - oz) * inv, 0.0), nz - 1.0)
    i = min(int(fx), nx - 2)
    j = min(int(fy), ny - 2)
    k = min(int(fz), nz - 2)
    return i, j, k, fx - i, fy - j, fz - k


@njit(inline="always", cache=True)
def node_span(p, reach, o, inv, n):
    """The first and last node index (clamped to 0 … n − 1) within ``reach`` of the coordinate ``p`` along
    an axis whose node 0 lies at ``o``, ``inv`` = 1/Δ (an empty span when first > last)."""
    return max(0, int(math.ceil((p - reach - o) * inv))), min(n - 1, int(math.floor((p + reach - o) * inv)))


@njit(inline="always", cache=True)
def _trilinear(d000, d100, d010, d110, d001, d101, d011, d111, u, v, w):
    c00 = d000 + u * (d100 - d000)
    c10 = d010 + u * (d110 - d010)
    c01 = d001 + u * (d101 - d001)
    c11 = d011 + u * (d111 - d011)
    c0 = c00 + v * (c10 - c00)
    c1 = c01 + v * (c11 - c01)
    return c0 + w * (c1 - c0)


@njit(inline="always", cache=True)
def _dif(a, b):
    """a − b in the field's precision, as a float64 (as :func:`_central` forms it)."""
    return float(a - b)


@njit(inline="always", cache=True)
def _central(dens, i, j, k):
    """The node's central differences (d[+1] − d[−1])/(index span) per axis, one-sided at the grid's edges
    (density per cell; the caller divides by Δ)."""
    nz, ny, nx = dens.shape
    i0, i1 = max(i - 1, 0), min(i + 1, nx - 1)
    j0, j1 = max(j - 1, 0), min(j + 1, ny - 1)
    k0, k1 = max(k - 1, 0), min(k + 1, nz - 1)
    return ((dens[k, j, i1] - dens[k, j, i0]) / (i1 - i0), (dens[k, j1, i] - dens[k, j0, i]) / (j1 - j0),
            (dens[k1, j, i] - dens[k0, j, i]) / (k1 - k0))  # fmt: skip


@njit(inline="always", cache=True)
def sample(dens, ox, oy, oz, inv, x, y, z):
    """(d, ∂d/∂x, ∂d/∂y, ∂d/∂z) at (x, y, z): d trilinear in the 8 nodes around it, ∇d the derivative of that
    polynomial, blended towards the trilinear interpolation of the nodes' central differences where the
    polynomial's is the smaller (module docstring); ``inv`` = 1/Δ."""
    i, j, k, u, v, w = cell_of(dens, ox, oy, oz, inv, x, y, z)
    d000 = dens[k, j, i]
    d100 = dens[k, j, i + 1]
    d010 = dens[k, j + 1, i]
    d110 = dens[k, j + 1, i + 1]
    d001 = dens[k + 1, j, i]
    d101 = dens[k + 1, j, i + 1]
    d011 = dens[k + 1, j + 1, i]
    d111 = dens[k + 1, j + 1, i + 1]
    c00 = d000 + u * (d100 - d000)
    c10 = d010 + u * (d110 - d010)
    c01 = d001 + u * (d101 - d001)
    c11 = d011 + u * (d111 - d011)
    c0 = c00 + v * (c10 - c00)
    c1 = c01 + v * (c11 - c01)
    d = c0 + w * (c1 - c0)
    ex0 = (d100 - d000) + v * ((d110 - d010) - (d100 - d000))
    ex1 = (d101 - d001) + v * ((d111 - d011) - (d101 - d001))
    px = ex0 + w * (ex1 - ex0)
    py = (c10 - c00) + w * ((c11 - c01) - (c10 - c00))
    pz = c1 - c0
    nz, ny, nx = dens.shape
    if 1 <= i and i + 2 < nx and 1 <= j and j + 2 < ny and 1 <= k and k + 2 < nz:  # inside: no clamping
        qx = 0.5 * _trilinear(
            _dif(dens[k, j, i + 1], dens[k, j, i - 1]),
            _dif(dens[k, j, i + 2], d000),
            _dif(dens[k, j + 1, i + 1], dens[k, j + 1, i - 1]),
            _dif(dens[k, j + 1, i + 2], d010),
            _dif(dens[k + 1, j, i + 1], dens[k + 1, j, i - 1]),
            _dif(dens[k + 1, j, i + 2], d001),
            _dif(dens[k + 1, j + 1, i + 1], dens[k + 1, j + 1, i - 1]),
            _dif(dens[k + 1, j + 1, i + 2], d011),
            u,
            v,
            w,
        )
        qy = 0.5 * _trilinear(
            _dif(dens[k, j + 1, i], dens[k, j - 1, i]),
            _dif(dens[k, j + 1, i + 1], dens[k, j - 1, i + 1]),
            _dif(dens[k, j + 2, i], d000),
            _dif(dens[k, j + 2, i + 1], d100),
            _dif(dens[k + 1, j + 1, i], dens[k + 1, j - 1, i]),
            _dif(dens[k + 1, j + 1, i + 1], dens[k + 1, j - 1, i + 1]),
            _dif(dens[k + 1, j + 2, i], d001),
            _dif(dens[k + 1, j + 2, i + 1], d101),
            u,
            v,
            w,
        )
        qz = 0.5 * _trilinear(
            _dif(dens[k + 1, j, i], dens[k - 1, j, i]),
            _dif(dens[k + 1, j, i + 1], dens[k - 1, j, i + 1]),
            _dif(dens[k + 1, j + 1, i], dens[k - 1, j + 1, i]),
            _dif(dens[k + 1, j + 1, i + 1], dens[k - 1, j + 1, i + 1]),
            _dif(dens[k + 2, j, i], d000),
            _dif(dens[k + 2, j, i + 1], d100),
            _dif(dens[k + 2, j + 1, i], d010),
            _dif(dens[k + 2, j + 1, i + 1], d110),
            u,
            v,
            w,
        )
    else:
        a000 = _central(dens, i, j, k)
        a100 = _central(dens, i + 1, j, k)
        a010 = _central(dens, i, j + 1, k)
        a110 = _central(dens, i + 1, j + 1, k)
        a001 = _central(dens, i, j, k + 1)
        a101 = _central(dens, i + 1, j, k + 1)
        a011 = _central(dens, i, j + 1, k + 1)
        a111 = _central(dens, i + 1, j + 1, k + 1)
        qx = _trilinear(a000[0], a100[0], a010[0], a110[0], a001[0], a101[0], a011[0], a111[0], u, v, w)
        qy = _trilinear(a000[1], a100[1], a010[1], a110[1], a001[1], a101[1], a011[1], a111[1], u, v, w)
        qz = _trilinear(a000[2], a100[2], a010[2], a110[2], a001[2], a101[2], a011[2], a111[2], u, v, w)
    p2 = px * px + py * py + pz * pz
    q2 = qx * qx + qy * qy + qz * qz
    b = 0.0
    if p2 < BLEND_HI * BLEND_HI * q2:  # the polynomial's slope has fallen well below the nodes'
        r = math.sqrt(p2 / q2)
        b = min(1.0, (BLEND_HI - r) / (BLEND_HI - BLEND_LO))
    return d, (px + b * (qx - px)) * inv, (py + b * (qy - py)) * inv, (pz + b * (qz - pz)) * inv


@njit(cache=True)
def distance_normal(dens, ox, oy, oz, inv, iso, x, y, z):
    """(l, n_x, n_y, n_z, d) at (x, y, z): the signed distance (positive in the fluid), the unit
    normal into the fluid and the interpolated density; see the module docstring."""
    d, gx, gy, gz = sample(dens, ox, oy, oz, inv, x, y, z)
    g = math.sqrt(gx * gx + gy * gy + gz * gz)
    if g < FLAT:
        return (FAR if d < iso else -FAR), 0.0, 0.0, 1.0, d
    return (iso - d) / g, -gx / g, -gy / g, -gz / g, d


@njit(parallel=True, cache=True)
def wall_distance(dens, ox, oy, oz, inv, iso, pos, n, out_l, out_n):
    """l and n (``out_l[:n]``, ``out_n[:n]``) of the first ``n`` points of ``pos`` (m, 3), one parallel pass."""
    for i in prange(n):
        l, n0, n1, n2, _ = distance_normal(dens, ox, oy, oz, inv, iso, pos[i, 0], pos[i, 1], pos[i, 2])
        out_l[i] = l
        out_n[i, 0] = n0
        out_n[i, 1] = n1
        out_n[i, 2] = n2
