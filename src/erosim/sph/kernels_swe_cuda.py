"""CUDA kernels of the shallow-water SPH step (the device path of :mod:`erosim.sph.shallow_water_cuda`).

Why hand-written numba-cuda kernels: as for the 3-D step (:mod:`erosim.sph.kernels_cuda`, whose
prefix sum, scatter and per-cell sort these reuse), the only library primitives that would fit are a
sort and a scan, and a second GPU stack is not worth them. The physics is not rewritten: each kernel
calls the CPU path's own per-particle function of :mod:`erosim.sph.kernels_swe` (the pair search,
the depth and smoothing-length Newton solve, the pair forces, the bed's C¹ surface, the Manning kick,
the drift with its walls and open edges, the CFL scale and a map cell's hazard maxima), so both
devices solve the same equations over the same neighbour lists in the same order.

Neighbour lists are the CPU's: the same square grid (edge max_i s_i, origin min − edge), the same
stable counting sort by cell (atomic counts, prefix sum, scatter, each cell's particles sorted by
index), and CSR lists filled cell by cell in the CPU's scan order (count pass, prefix sum, fill pass).
Reductions are maxima and sums of integers (block reduction in shared memory, one atomic per block)
and each map cell's hazard maxima are one thread's gather over the particles binned as the CPU bins
them, so the device path does not depend on the launch order.
"""

from __future__ import annotations

import math
import types

import numpy as np
from numba import cuda

from erosim.sph import kernels_cuda
from erosim.sph import kernels_swe as K
from erosim.sph.kernels_cuda import SIMULATOR, TPB, _dev, _helper


def _here(fn):
    """A helper of :mod:`erosim.sph.kernels_cuda` that calls ``cuda``, for the kernels below. The
    simulator swaps its stand-in ``cuda`` only into the globals of the kernel it runs, so there the
    helper is rebound to this module's globals; on a device it is the helper itself."""
    if SIMULATOR:
        return types.FunctionType(fn.__code__, globals(), fn.__name__, fn.__defaults__, fn.__closure__)
    return fn


_block_max = _here(kernels_cuda._block_max)

_pairs = _dev(K.pairs_particle)
_depth_support = _dev(K.depth_support_particle)
_pair_forces = _dev(K.pair_forces_particle)
_bed = _helper(K.bed_c1.py_func)  # inlined here (the CPU calls it: see erosim.sph.kernels_swe)
_kick = _dev(K.kick_particle)
_drift = _dev(K.drift_particle)
_cfl = _dev(K.cfl_scale)
_surface = _dev(K.surface_particle)
_split_parent = _dev(K.split_parent)
_relax_support = _dev(K.relax_support)
if SIMULATOR:  # the Python source, calling its helpers' Python sources (they take the simulator's arrays)
    _cell_maxima = types.FunctionType(
        K.cell_maxima.py_func.__code__,
        {**vars(K), "wall_between": K.wall_between.py_func, "raise_cell": K.raise_cell.py_func},
        "cell_maxima",
    )
else:
    _cell_maxima = K.cell_maxima


# ---------------------------------------------------------------- neighbour lists


@cuda.jit
def cell_ids(pos, n, x0, y0, cell, ncx, ncy, pcell, counts):
    """pcell[i] = cy·ncx + cx, the cell of :func:`erosim.sph.kernels_swe.bin_particles`; counts[c] += 1."""
    i = cuda.grid(1)
    if i < n:
        cx = min(max(int((pos[i, 0] - x0) / cell), 0), ncx - 1)
        cy = min(max(int((pos[i, 1] - y0) / cell), 0), ncy - 1)
        c = cy * ncx + cx
        pcell[i] = c
        cuda.atomic.add(counts, c, 1)


@cuda.jit
def bin_search_max(pcell, search, n, out):
    """out[c] = max s_i over the particles of bin c (``out`` zeroed first): the CPU's ``bin_search_max``."""
    i = cuda.grid(1)
    if i < n:
        cuda.atomic.max(out, pcell[i], search[i])


@cuda.jit
def pairs(pos, search, n, x0, y0, cell, ncx, ncy, cell_start, order, bin_max, reach, count, start, nbr, fill):
    """The CPU's ``scan_pairs``: counts (``fill`` False) or the CSR lists (``fill`` True)."""
    i = cuda.grid(1)
    if i < n:
        k0 = start[i] if fill else 0
        k = _pairs(i, pos, search, x0, y0, cell, ncx, ncy, cell_start, order, bin_max, reach, k0, nbr, fill)
        if not fill:
            count[i] = k


@cuda.jit
def scaled_copy(src, dst, factor, n):
    """dst = factor · src (the lists' radii s_i = margin · H_i)."""
    i = cuda.grid(1)
    if i < n:
        dst[i] = src[i] * factor


@cuda.jit
def copy1(src, dst, n):
    i = cuda.grid(1)
    if i < n:
        dst[i] = src[i]


@cuda.jit
def raise_to(a, b, n):
    """a = max(b, a): the radii after a support outgrew the lists."""
    i = cuda.grid(1)
    if i < n:
        a[i] = max(b[i], a[i])


@cuda.jit
def max_moved(pos, at, n, out):
    """out[0] = max_i |x_i − x_i⁰| (out[0] starts at 0)."""
    sh = cuda.shared.array(TPB, np.float64)
    mx = 0.0
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        dx = pos[i, 0] - at[i, 0]
        dy = pos[i, 1] - at[i, 1]
        mx = max(mx, math.sqrt(dx * dx + dy * dy))
    m = _block_max(sh, mx)
    if cuda.threadIdx.x == 0:
        cuda.atomic.max(out, 0, m)


@cuda.jit
def max1(a, n, out):
    """out[0] = max_i a_i (out[0] starts at 0; a ≥ 0)."""
    sh = cuda.shared.array(TPB, np.float64)
    mx = 0.0
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        mx = max(mx, a[i])
    m = _block_max(sh, mx)
    if cuda.threadIdx.x == 0:
        cuda.atomic.max(out, 0, m)


@cuda.jit
def lists_broken(pos, at, hsup, search, n, moved_max, out):
    """out[0] += 1 for each i with H_i + |Δx_i| + max|Δx| > s_i (the CPU's ``_lists_hold`` test)."""
    i = cuda.grid(1)
    if i < n:
        dx = pos[i, 0] - at[i, 0]
        dy = pos[i, 1] - at[i, 1]
        if not hsup[i] + math.sqrt(dx * dx + dy * dy) + moved_max[0] <= search[i]:
            cuda.atomic.add(out, 0, 1)


# ---------------------------------------------------------------- the passes


@cuda.jit
def depth_and_support(pos, vol, hsup, n, start, nbr, k2, h_min, h_max, tol, max_iter, depth, omega):
    i = cuda.grid(1)
    if i < n:
        _depth_support(i, pos, vol, hsup, start, nbr, k2, h_min, h_max, tol, max_iter, depth, omega)


@cuda.jit
def accelerations(pos, vel, vol, hsup, depth, omega, n, start, nbr, bed, inv_cell, g, alpha, acc):
    i = cuda.grid(1)
    if i < n:
        ax, ay = _pair_forces(i, pos, vel, vol, hsup, depth, omega, start, nbr, g, alpha)
        _, gx, gy = _bed(bed, pos[i, 0] * inv_cell, pos[i, 1] * inv_cell)
        acc[i, 0] = ax - g * gx * inv_cell
        acc[i, 1] = ay - g * gy * inv_cell


@cuda.jit
def kick(vel, acc, depth, manning, inv_cell, pos, n, dt, g, d_floor):
    i = cuda.grid(1)
    if i < n:
        _kick(i, vel, acc, depth, manning, inv_cell, pos, dt, g, d_floor)


@cuda.jit
def drift(pos, vel, n, dt, inv_cell, wall, open_w, open_e, open_n, open_s, out, blocked, counts):
    """The CPU's drift; counts[0] += the particles that left by an open edge."""
    i = cuda.grid(1)
    if i < n:
        out[i] = False
        _drift(i, pos, vel, dt, inv_cell, wall, open_w, open_e, open_n, open_s, out, blocked)
        if out[i]:
            cuda.atomic.add(counts, 0, 1)


@cuda.jit
def hold_contacts(vel, n, blocked, counts):
    """Stop the particles that met a wall; counts[1] += the particles whose speed is not finite."""
    i = cuda.grid(1)
    if i < n:
        if blocked[i]:
            vel[i, 0] = 0.0
            vel[i, 1] = 0.0
        if not (math.isfinite(vel[i, 0]) and math.isfinite(vel[i, 1])):
            cuda.atomic.add(counts, 1, 1)


@cuda.jit
def cfl_limit(vel, depth, hsup, n, g, out):
    """out[0] = max_i −H_i/(√(g d_i) + |u_i|) (out[0] starts at −inf): minus the CFL scale."""
    sh = cuda.shared.array(TPB, np.float64)
    mx = -math.inf
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        mx = max(mx, -_cfl(i, vel, depth, hsup, g))
    m = _block_max(sh, mx)
    if cuda.threadIdx.x == 0:
        cuda.atomic.max(out, 0, m)


@cuda.jit
def relax_supports(k2, hsup, depth, vel, n, k2_home, relax, g, dt):
    """The CPU's ``relax_supports``: a split's daughters' support factors towards k²."""
    i = cuda.grid(1)
    if i < n:
        _relax_support(i, k2, hsup, depth, vel, k2_home, relax, g, dt)


@cuda.jit
def split_count(pos, vol, depth, vel, n, spacing_lim, vol_lim, speed2, depth_lim, radius, hexagon, inv_cell, wall,
                counts):  # fmt: skip
    """counts[0] += the particles the CPU's ``split_parents`` would split (the split itself is the host's)."""
    i = cuda.grid(1)
    if i < n:
        if _split_parent(i, pos, vol, depth, vel, spacing_lim, vol_lim, speed2, depth_lim, radius, hexagon,
                         inv_cell, wall):  # fmt: skip
            cuda.atomic.add(counts, 0, 1)


@cuda.jit
def surfaces(pos, depth, bed, n, inv_cell, eta):
    """The CPU's ``surfaces``: η_i = b(x_i) + d_i for the hazard maps."""
    i = cuda.grid(1)
    if i < n:
        eta[i] = _surface(i, pos, depth, bed, inv_cell)


@cuda.jit
def grid_maxima(
    pos, vel, vol, hsup, depth, eta, bed, cell_size, x0, y0, bcell, ncx, ncy, cell_start, order,
    r_lo, c_lo, nr, nc, t, wet, max_d, max_v, max_dv, arrival, wall, wall_dist, conveyance,
):  # fmt: skip
    """The CPU's ``grid_maxima``: one thread per cell of the nr × nc window from (r_lo, c_lo), each
    gathering its particles in the CPU's order (no atomics: a cell is one thread's)."""
    k = cuda.grid(1)
    if k < nr * nc:
        _cell_maxima(
            r_lo + k // nc, c_lo + k % nc, pos, vel, vol, hsup, depth, eta, bed, cell_size, x0, y0, bcell, ncx, ncy,
            cell_start, order, t, wet, max_d, max_v, max_dv, arrival, wall, wall_dist, conveyance,
        )  # fmt: skip
