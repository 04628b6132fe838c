"""CUDA kernels of the weakly compressible SPH step (the device path of :mod:`erosim.sph.solver_cuda`).

Why hand-written numba-cuda kernels: the step's sort and scan are the only places a library
primitive would fit (CuPy's ``argsort``/``cumsum``), and CuPy is a second GPU stack that erosim would
then need besides Numba. The sort here is a counting sort by cell, which needs only a prefix sum;
writing both in numba-cuda keeps one GPU dependency (``numba-cuda``, an optional extra) and keeps the
exact order the CPU path sums in. The physics is *not* rewritten: the kernels below call the CPU
path's own per-particle functions (:func:`erosim.sph.forces.fluid_particle_3d`,
:func:`erosim.sph.boundaries.particles.density_rate_particle`, :func:`erosim.sph.boundaries.box.enforce`,
:func:`erosim.sph.eos.tait`, the kernels of :mod:`erosim.kernels.sph_kernels`, the integrator's
:func:`~erosim.sph.integrators.kick_drift_particle` and :func:`~erosim.sph.integrators.correct_particle`),
which numba-cuda compiles for the device.

Neighbour search (the CPU's method, :mod:`erosim.kernels.neighbours`, on a dense grid)
------------------------------------------------------------------------------------
1. Cell of a particle: c_a = ⌊(x_a − origin_a)/r_c⌋ + 1 with the CPU's origin (minimum corner − r_c)
   and cell edge r_c (the list radius); cell id = c_0 + N_0(c_1 + N_1 c_2) over the particles'
   bounding box (N_a = max c_a + 2), so ids increase in the CPU's key order (z, then y, then x).
2. Counting sort by cell: per-cell counts (atomic adds), an exclusive prefix sum (each thread sums a
   run of entries, a block scans its runs' totals after Hillis & Steele 1986, blocks are combined
   recursively), a scatter, then each cell's few particles sorted by index — the CPU's stable
   order, whatever order the scatter's atomics gave. (The CPU numbers occupied cells through a hash
   table; a dense grid over the bounding box needs no hashing and suits box domains.)
3. Verlet lists in the CPU's CSR layout: for fluid particle i, fluid neighbours
   ``nbr[start[i]:mid[i]]`` then boundary ones ``nbr[mid[i]:start[i+1]]``, each in the scan order of
   the 3^d cells around it (count pass, prefix sum, fill pass); a boundary particle's list holds its
   fluid neighbours in index order (the CPU's transpose gives that order).

Helpers shared by several kernels are inlined ``njit`` functions (numba-cuda compiles them into each
kernel that calls them; plain Python in the simulator) rather than ``cuda.jit(device=True)`` ones, so
every kernel also compiles to PTX on a machine without a GPU (``benchmarks/cuda_compile_check.py``).

Reductions (largest |r − r_ref|², |v|², |a|² and the density diffusion's rate K_i) are maxima
(block reduction in shared memory, then one atomic max per block), so they do not depend on the
launch order: the device path is deterministic.
Under Numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``) the same kernels run as Python on the CPU
(for tests); there the CPU functions that take arrays are called through their Python source.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import config, cuda, int64, njit

from erosim.kernels import sph_kernels as K
from erosim.sph import forces, integrators
from erosim.sph.boundaries import box as _box
from erosim.sph.boundaries import particles as _bparticles
from erosim.sph.boundaries import pressure_extrapolation_adami2012 as _adami

SIMULATOR = bool(config.ENABLE_CUDASIM)
# threads per block of every kernel (a power of two: the block reductions halve it); the simulator
# runs each thread of a block as a Python thread, so it gets small blocks
TPB = 32 if SIMULATOR else 256
# reductions: at most this many blocks, each thread striding over the particles (one shared-memory
# reduction per block); prefix sums: each thread sums this many consecutive entries
RED_BLOCKS = 1 if SIMULATOR else 1024
SCAN_ITEMS = 64 if SIMULATOR else 8


def _dev(fn):
    """A CPU per-particle function for use in a kernel: itself on a device, its Python source in the
    simulator (which runs kernels as Python and cannot pass its arrays to compiled functions)."""
    return fn.py_func if SIMULATOR else fn


_enforce = _dev(_box.enforce)
_density_rate_particle = _dev(_bparticles.density_rate_particle)
_extrapolate_particle = _dev(_adami.extrapolate_particle)
_kick_drift_particle = _dev(integrators.kick_drift_particle)
_correct_particle = _dev(integrators.correct_particle)
_update_density_particle = _dev(_bparticles.update_density_particle)


def _helper(fn):
    """A helper called from kernels: inlined into them on a device, plain Python in the simulator."""
    return fn if SIMULATOR else njit(inline="always")(fn)


def blocks(n: int) -> int:
    """Blocks of :data:`TPB` threads covering ``n`` items (at least one)."""
    return max(1, (int(n) + TPB - 1) // TPB)


def red_blocks(n: int) -> int:
    """Blocks of a striding reduction over ``n`` items."""
    return min(blocks(n), RED_BLOCKS)


# ---------------------------------------------------------------- block reductions


@_helper
def _block_max(sh, v):
    """Maximum of ``v`` over the block (every thread gets it); ``sh`` is a TPB-long shared array."""
    t = cuda.threadIdx.x
    sh[t] = v
    cuda.syncthreads()
    s = TPB // 2
    while s > 0:
        if t < s:
            sh[t] = max(sh[t], sh[t + s])
        cuda.syncthreads()
        s //= 2
    out = sh[0]
    cuda.syncthreads()
    return out


@cuda.jit
def bounds(pos, n, out_lo, out_hi):
    """out_lo[a] = min over particles of pos[:, a], out_hi[a] = max (out_* start at ±inf)."""
    sh = cuda.shared.array(TPB, np.float64)
    i0 = cuda.grid(1)
    step = cuda.gridsize(1)
    d = pos.shape[1]
    for a in range(d):
        lo = math.inf
        hi = -math.inf
        for i in range(i0, n, step):
            lo = min(lo, pos[i, a])
            hi = max(hi, pos[i, a])
        lo = -_block_max(sh, -lo)
        hi = _block_max(sh, hi)
        if cuda.threadIdx.x == 0:
            cuda.atomic.min(out_lo, a, lo)
            cuda.atomic.max(out_hi, a, hi)


@cuda.jit
def max_displacement(pos, ref, n_fluid, out):
    """out[0] = max |r − ref|² over the fluid (out[0] starts at 0); the CPU's ``max_displacement``."""
    sh = cuda.shared.array(TPB, np.float64)
    d = pos.shape[1]
    mx = 0.0
    for i in range(cuda.grid(1), n_fluid, cuda.gridsize(1)):
        s = 0.0
        for a in range(d):
            t = pos[i, a] - ref[i, a]
            s += t * t
        mx = max(mx, s)
    m = _block_max(sh, mx)
    if cuda.threadIdx.x == 0:
        cuda.atomic.max(out, 0, m)


# ---------------------------------------------------------------- prefix sum (int64)


@cuda.jit
def _scan_blocks(src, m, dst, sums):
    """Inclusive prefix sums within each block's SCAN_ITEMS·TPB entries into dst[k+1]; sums[b] = block
    total. Each thread sums its run of entries, the runs' totals are scanned (Hillis–Steele), then
    each thread writes its run's sums."""
    sh = cuda.shared.array(TPB, int64)
    t = cuda.threadIdx.x
    b = cuda.blockIdx.x
    base = (b * TPB + t) * SCAN_ITEMS
    own = int64(0)
    for k in range(base, min(base + SCAN_ITEMS, m)):
        own += src[k]
    sh[t] = own
    cuda.syncthreads()
    off = 1
    while off < TPB:
        add = int64(0)
        if t >= off:
            add = sh[t - off]
        cuda.syncthreads()
        sh[t] += add
        cuda.syncthreads()
        off *= 2
    run = sh[t] - own
    for k in range(base, min(base + SCAN_ITEMS, m)):
        run += src[k]
        dst[k + 1] = run
    if t == TPB - 1:
        sums[b] = sh[t]


@cuda.jit
def _add_block_offsets(dst, m, offs):
    k = cuda.grid(1)
    if k < m:
        dst[k + 1] += offs[k // (TPB * SCAN_ITEMS)]


@cuda.jit
def zero(arr, m):
    """arr[:m] = 0 (on the device: no host array of the grid's size is made or copied)."""
    k = cuda.grid(1)
    if k < m:
        arr[k] = 0


@cuda.jit
def _set_first_zero(dst):
    if cuda.grid(1) == 0:
        dst[0] = 0


def exclusive_scan(src, m: int, dst) -> None:
    """dst[0] = 0, dst[k+1] = src[0] + … + src[k] for k < m (int64 device arrays; dst has m + 1 rows)."""
    nb = max(1, (int(m) + TPB * SCAN_ITEMS - 1) // (TPB * SCAN_ITEMS))
    sums = cuda.device_array(nb, np.int64)
    _scan_blocks[nb, TPB](src, m, dst, sums)
    if nb > 1:
        offs = cuda.device_array(nb + 1, np.int64)
        exclusive_scan(sums, nb, offs)
        _add_block_offsets[blocks(m), TPB](dst, m, offs)
    _set_first_zero[1, 1](dst)


# ---------------------------------------------------------------- cells and the counting sort


@_helper
def _cell_coord(x, origin, inv_cell):
    return int64(math.floor((x - origin) * inv_cell)) + 1


@cuda.jit
def cell_ids(pos, n, origin, inv_cell, dims, pcell, counts):
    """pcell[i] = cell id of particle i (see the module docstring); counts[cell] += 1."""
    i = cuda.grid(1)
    if i >= n:
        return
    d = pos.shape[1]
    c = _cell_coord(pos[i, d - 1], origin[d - 1], inv_cell)
    for a in range(d - 2, -1, -1):
        c = c * dims[a] + _cell_coord(pos[i, a], origin[a], inv_cell)
    pcell[i] = c
    cuda.atomic.add(counts, c, 1)


@cuda.jit
def scatter(pcell, n, cell_start, fill, cell_index):
    """Particles into their cells' ranges (any order within a cell; :func:`sort_cells` fixes it)."""
    i = cuda.grid(1)
    if i < n:
        c = pcell[i]
        cell_index[cell_start[c] + cuda.atomic.add(fill, c, 1)] = i


@cuda.jit
def sort_ranges(start, m, idx):
    """Sort idx[start[c]:start[c+1]] ascending for each c < m (insertion sort: a few entries each)."""
    c = cuda.grid(1)
    if c >= m:
        return
    s0 = start[c]
    s1 = start[c + 1]
    for s in range(s0 + 1, s1):
        v = idx[s]
        t = s - 1
        while t >= s0 and idx[t] > v:
            idx[t + 1] = idx[t]
            t -= 1
        idx[t + 1] = v


@cuda.jit
def fluid_flags(cell_index, n, n_fluid, flags):
    s = cuda.grid(1)
    if s < n:
        flags[s] = 1 if cell_index[s] < n_fluid else 0


@cuda.jit
def fluid_permutation(cell_index, n, n_fluid, newidx, perm):
    """Fluid in cell order: perm[new] = old (new = rank among the fluid slots); cell_index gets the new ids."""
    s = cuda.grid(1)
    if s < n:
        j = cell_index[s]
        if j < n_fluid:
            k = newidx[s]
            perm[k] = j
            cell_index[s] = k


@cuda.jit
def gather_rows(src, dst, perm, n_fluid, n):
    """dst[k] = src[perm[k]] for k < n_fluid, dst[k] = src[k] for n_fluid ≤ k < n (2-D arrays)."""
    k = cuda.grid(1)
    if k < n:
        j = perm[k] if k < n_fluid else k
        for a in range(src.shape[1]):
            dst[k, a] = src[j, a]


@cuda.jit
def gather(src, dst, perm, n_fluid, n):
    """:func:`gather_rows` for 1-D arrays."""
    k = cuda.grid(1)
    if k < n:
        j = perm[k] if k < n_fluid else k
        dst[k] = src[j]


@cuda.jit
def gather_sorted(pos, cell_index, n, spos):
    """spos[s] = pos[cell_index[s]] (positions in cell order, for contiguous scans)."""
    s = cuda.grid(1)
    if s < n:
        j = cell_index[s]
        for a in range(pos.shape[1]):
            spos[s, a] = pos[j, a]


@cuda.jit
def copy_rows(src, dst, n):
    k = cuda.grid(1)
    if k < n:
        for a in range(src.shape[1]):
            dst[k, a] = src[k, a]


# ---------------------------------------------------------------- Verlet lists


@_helper
def _neighbour_cell(c, m, dims, dim):
    """Id of the m-th of the 3^dim cells around cell c, in the CPU's order (dz, dy, dx; dx fastest)."""
    dx = m % 3 - 1
    dy = (m // 3) % 3 - 1
    if dim == 3:
        dz = m // 9 - 1
        return c + dx + dims[0] * (dy + dims[1] * dz)
    return c + dx + dims[0] * dy


@_helper
def _dist2(spos, s, x0, x1, x2, d):
    t = x0 - spos[s, 0]
    r2 = t * t
    t = x1 - spos[s, 1]
    r2 += t * t
    if d == 3:
        t = x2 - spos[s, 2]
        r2 += t * t
    return r2


@cuda.jit
def count_lists(pos, spos, n_fluid, i0, i1, pcell, dims, cell_start, cell_index, r2max, count_f, count_t):
    """Particles i0 … i1−1: fluid neighbours (j ≠ i) and all neighbours closer than sqrt(r2max), in rows
    ``count_f[i − i0]``, ``count_t[i − i0]``. Boundary particles (i ≥ n_fluid) count fluid neighbours only."""
    i = cuda.grid(1) + i0
    if i >= i1:
        return
    d = pos.shape[1]
    x0 = pos[i, 0]
    x1 = pos[i, 1]
    x2 = pos[i, d - 1]
    c = pcell[i]
    kn = 27 if d == 3 else 9
    cf = 0
    cb = 0
    for m in range(kn):
        cc = _neighbour_cell(c, m, dims, d)
        for s in range(cell_start[cc], cell_start[cc + 1]):
            if _dist2(spos, s, x0, x1, x2, d) < r2max:
                j = cell_index[s]
                if j < n_fluid:
                    if j != i:
                        cf += 1
                elif i < n_fluid:
                    cb += 1
    count_f[i - i0] = cf
    count_t[i - i0] = cf + cb


@cuda.jit
def fluid_offsets(count_f, start, n_fluid, mid):
    """mid[i] = start[i] + count_f[i] (start: the scan of the fluid particles' total counts)."""
    i = cuda.grid(1)
    if i < n_fluid:
        mid[i] = start[i] + count_f[i]


@cuda.jit
def boundary_offsets(bscan, n_fluid, n, start, mid):
    """Boundary particles' lists after the fluid's: start/mid of rows n_fluid+1 … n (mid = end)."""
    k = cuda.grid(1)
    if k < n - n_fluid:
        e = start[n_fluid] + bscan[k + 1]
        start[n_fluid + k + 1] = e
        mid[n_fluid + k] = e


@cuda.jit
def fill_lists(pos, spos, n_fluid, i0, i1, pcell, dims, cell_start, cell_index, r2max, start, mid, nbr):
    """Write the lists counted by :func:`count_lists` (fluid part from start[i], boundary from mid[i])."""
    i = cuda.grid(1) + i0
    if i >= i1:
        return
    d = pos.shape[1]
    x0 = pos[i, 0]
    x1 = pos[i, 1]
    x2 = pos[i, d - 1]
    c = pcell[i]
    kn = 27 if d == 3 else 9
    pf = start[i]
    pb = mid[i]
    for m in range(kn):
        cc = _neighbour_cell(c, m, dims, d)
        for s in range(cell_start[cc], cell_start[cc + 1]):
            if _dist2(spos, s, x0, x1, x2, d) < r2max:
                j = cell_index[s]
                if j < n_fluid:
                    if j != i:
                        nbr[pf] = j
                        pf += 1
                elif i < n_fluid:
                    nbr[pb] = j
                    pb += 1


@cuda.jit
def sort_boundary_lists(start, n_fluid, n, nbr):
    """A boundary particle's fluid neighbours in index order (the CPU's transposed lists)."""
    k = cuda.grid(1)
    i = n_fluid + k
    if i >= n:
        return
    for s in range(start[i] + 1, start[i + 1]):
        v = nbr[s]
        t = s - 1
        while t >= start[i] and nbr[t] > v:
            nbr[t + 1] = nbr[t]
            t -= 1
        nbr[t + 1] = v


# ---------------------------------------------------------------- integration (erosim.sph.integrators)


@cuda.jit
def kick_drift(pos, vel, acc, rho, rho_old, drho, p, n_fluid, dt_kick, dt, rho0, b, gamma, pmin, rho_min):
    """Fluid: :func:`erosim.sph.integrators.kick_drift_particle`, one thread per particle."""
    i = cuda.grid(1)
    if i < n_fluid:
        _kick_drift_particle(pos, vel, acc, rho, rho_old, drho, p, i, dt_kick, dt, rho0, b, gamma, pmin, rho_min)


@cuda.jit
def correct(vel, acc, rho, rho_old, drho, p, n_fluid, dt_kick, dt, rho0, b, gamma, pmin, rho_min, out):
    """Second kick, corrector ρ = max(ρ_old + dt·D, ρ_min), p = EOS(ρ); out[0], out[1] = max |v|², |a|² (inf on NaN).
    Threads stride over the particles (launch with :func:`red_blocks`)."""
    sh = cuda.shared.array(TPB, np.float64)
    mv = 0.0
    ma = 0.0
    for i in range(cuda.grid(1), n_fluid, cuda.gridsize(1)):
        sv, sa = _correct_particle(vel, acc, rho, rho_old, drho, p, i, dt_kick, dt, rho0, b, gamma, pmin, rho_min)
        if sv != sv or sa != sa:
            mv = math.inf
            ma = math.inf
        mv = max(mv, sv)
        ma = max(ma, sa)
    mv = _block_max(sh, mv)
    ma = _block_max(sh, ma)
    if cuda.threadIdx.x == 0:
        cuda.atomic.max(out, 0, mv)
        cuda.atomic.max(out, 1, ma)


# ---------------------------------------------------------------- boundaries


@cuda.jit
def reflect(pos, vel, n_fluid, lo, hi, olo, ohi):
    """Box walls and obstacles by reflection (:func:`erosim.sph.boundaries.box.enforce`)."""
    i = cuda.grid(1)
    if i < n_fluid:
        _enforce(pos, vel, i, lo, hi, olo, ohi)


@cuda.jit
def boundary_update_density(rho, rho_old, drho, p, start, n_fluid, n, dt, rho0, b, gamma, pmin, predictor):
    """Active boundary particles (a non-empty list): ρ = max(ρ₀, ρ_old + dt·dρ/dt), p = EOS(ρ)
    (:func:`erosim.sph.boundaries.particles.update_density`)."""
    i = cuda.grid(1) + n_fluid
    if i < n and start[i + 1] != start[i]:
        _update_density_particle(rho, rho_old, drho, p, i, dt, rho0, b, gamma, pmin, predictor)


@functools.cache
def boundary_density_rate(dim: int, kernel: str):
    """Continuity rate of the active boundary particles with this kernel (a kernel per variant)."""
    gradf = K.kernel_functions(kernel, dim)[1]

    @cuda.jit
    def rate(pos, vel, start, mid, nbr, n_fluid, n, m, h, drho):
        i = cuda.grid(1) + n_fluid
        if i < n and start[i + 1] > start[i]:
            _density_rate_particle(gradf, i, pos, vel, start, mid, nbr, m, h, drho)

    return rate


@functools.cache
def boundary_extrapolate(dim: int, kernel: str):
    """Pressure and density of the active boundary particles from the fluid's (Adami et al. 2012,
    :func:`erosim.sph.boundaries.pressure_extrapolation_adami2012.extrapolate_particle`)."""
    w = K.kernel_functions(kernel, dim)[0]

    @cuda.jit
    def extrapolate(pos, rho, p, start, mid, nbr, n_fluid, n, h, g, rho0, b, gamma, pmin):
        i = cuda.grid(1) + n_fluid
        if i < n and start[i + 1] > start[i]:
            _extrapolate_particle(w, i, pos, rho, p, start, mid, nbr, h, g, rho0, b, gamma, pmin)

    return extrapolate


# ---------------------------------------------------------------- the fused fluid pass


@functools.cache
def fluid_pass(dim: int, kernel: str, pressure_form: str, viscosity: str):
    """The fused pressure/viscosity/continuity pass (:mod:`erosim.sph.forces`) for this combination of
    variants, one thread per fluid particle; ``kmax[slot]`` (0 before the launch) gets max_i K_i, the
    density diffusion's rate that bounds the step (:mod:`erosim.sph.diffusion_limit_molteni2009`), by a
    block reduction and one atomic max per block (no second neighbour loop)."""
    _, gradf, lapf = K.kernel_functions(kernel, dim)
    lap = lapf if viscosity == "laminar" else forces.no_lap
    pterm = forces.pterm_wcsph if pressure_form == "wcsph" else forces.pterm_symmetric
    visc = forces.visc_laminar if viscosity == "laminar" else forces.visc_artificial
    body = _dev(forces.fluid_particle_3d if dim == 3 else forces.fluid_particle_2d)

    @cuda.jit
    def fused(pos, vel, rho, p, start, mid, nbr, n_fluid, m, h, kv, kvb, eps2, kdiff, eta2, kh, gx, gy, gz, acc, drho,
              kmax, slot):  # fmt: skip
        sh = cuda.shared.array(TPB, np.float64)
        i = cuda.grid(1)
        k = 0.0
        if i < n_fluid:
            k = body(gradf, lap, pterm, visc, i, pos, vel, rho, p, start, mid, nbr, m, h, kv, kvb, eps2, kdiff, eta2,
                     kh, gx, gy, gz, acc, drho)  # fmt: skip
        # the density diffusion's largest rate K_i (the body's return), reduced in the same pass
        k = _block_max(sh, k)
        if cuda.threadIdx.x == 0:
            cuda.atomic.max(kmax, slot, k)

    return fused
