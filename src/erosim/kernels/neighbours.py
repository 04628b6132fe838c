"""Neighbour search (SPEC SPH-8): a hashed uniform grid of occupied cells plus Verlet neighbour lists.

Why hand-written Numba: SciPy's ``cKDTree`` is O(n log n), single-threaded for building and returns
Python-level pair sets; the solver needs an O(n) search whose memory grows with the number of
particles, not with the domain's volume, and whose output (CSR lists split into fluid and boundary
neighbours) feeds the force loop directly.

Method
------
1. Cell of a particle: (i, j, k) = ⌊(x − origin)/c⌋ + 1 with cell edge c ≥ search radius; the three
   integers are packed into one 64-bit key (21 bits per axis in 3-D, 31 in 2-D).
2. Occupied cells are numbered through an open-addressing hash table (linear probing, Fibonacci
   hashing, size a power of two ≥ 2n) — memory O(n) whatever the domain size (the role of the seed's
   XOR hash, Teschner et al. 2003, but exact: keys are compared, so no false candidates).
3. Cells are ordered by key and particles counting-sorted by cell (Green 2010's sorted grid), which
   also gives the permutation the solver uses to reorder particles for memory locality.
4. For every cell the ids of its 3^d neighbour cells are looked up once; each fluid particle then
   scans them and keeps the particles closer than the radius — two passes (count, fill) into CSR
   lists. Boundary particles' lists (their fluid neighbours) are the transpose of the fluid
   particles' boundary parts (:func:`transpose_boundary`), so the many boundary particles far from
   any fluid cost nothing.

List layout: for query particle i, ``nbr[start[i]:mid[i]]`` are fluid neighbours (index < n_fluid)
and ``nbr[mid[i]:start[i+1]]`` boundary neighbours; particles ≥ ``n_fluid`` (boundary) get fluid
neighbours only (boundary–boundary pairs never interact). A particle is never its own neighbour.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def key_bits(dim: int) -> int:
    """Bits per axis in a packed cell key."""
    return 21 if dim == 3 else 31


@njit(parallel=True, cache=True)
def cell_keys(pos, origin, inv_cell, bits, keys):
    """keys[i] = packed (⌊(x − origin)/c⌋ + 1) of particle i, 2-D or 3-D."""
    n, d = pos.shape
    for i in prange(n):
        k = np.int64(0)
        for a in range(d):
            c = np.int64(np.floor((pos[i, a] - origin[a]) * inv_cell)) + 1
            k |= c << (bits * a)
        keys[i] = k


@njit(inline="always", cache=True)
def _slot(key, shift):
    return np.int64((np.uint64(key) * np.uint64(0x9E3779B97F4A7C15)) >> np.uint64(shift))


@njit(cache=True)
def hash_cells(keys, table_key, table_cell, shift, particle_cell, cell_key):
    """Number the occupied cells (first appearance order); returns the number of cells.

    ``table_key`` must be filled with −1; its length is a power of two 2^(64−shift) > len(keys).
    """
    mask = table_key.size - 1
    ncell = 0
    for i in range(keys.size):
        k = keys[i]
        s = _slot(k, shift)
        while True:
            tk = table_key[s]
            if tk == k:
                particle_cell[i] = table_cell[s]
                break
            if tk == -1:
                table_key[s] = k
                table_cell[s] = ncell
                cell_key[ncell] = k
                particle_cell[i] = ncell
                ncell += 1
                break
            s = (s + 1) & mask
    return ncell


@njit(cache=True)
def lookup(key, table_key, table_cell, shift):
    """Cell id of ``key`` or −1 if no particle is in that cell."""
    mask = table_key.size - 1
    s = _slot(key, shift)
    while True:
        tk = table_key[s]
        if tk == key:
            return table_cell[s]
        if tk == -1:
            return -1
        s = (s + 1) & mask


@njit(cache=True)
def renumber_cells(particle_cell, rank):
    """Replace every particle's cell id by ``rank[id]`` (cells reordered by key)."""
    for i in range(particle_cell.size):
        particle_cell[i] = rank[particle_cell[i]]


@njit(cache=True)
def counting_sort(particle_cell, ncell, cell_start, cell_index):
    """cell_start[c]:cell_start[c+1] lists (in cell_index) the particles of cell c, in index order."""
    cell_start[: ncell + 1] = 0
    for i in range(particle_cell.size):
        cell_start[particle_cell[i] + 1] += 1
    for c in range(ncell):
        cell_start[c + 1] += cell_start[c]
    fill = cell_start[:ncell].copy()
    for i in range(particle_cell.size):
        c = particle_cell[i]
        cell_index[fill[c]] = i
        fill[c] += 1


@njit(parallel=True, cache=True)
def gather_sorted(pos, cell_index, spos):
    """spos[s] = pos[cell_index[s]] (positions in cell order)."""
    n, d = pos.shape
    for s in prange(n):
        j = cell_index[s]
        for a in range(d):
            spos[s, a] = pos[j, a]


@njit(parallel=True, cache=True)
def neighbour_cells(cell_key, ncell, table_key, table_cell, shift, bits, dim, out):
    """out[c, :] = ids of the 3^dim cells around cell c (−1 where empty)."""
    for c in prange(ncell):
        k0 = cell_key[c]
        m = 0
        if dim == 3:
            for dz in range(-1, 2):
                for dy in range(-1, 2):
                    for dx in range(-1, 2):
                        k = k0 + dx + (np.int64(dy) << bits) + (np.int64(dz) << (2 * bits))
                        out[c, m] = lookup(k, table_key, table_cell, shift)
                        m += 1
        else:
            for dy in range(-1, 2):
                for dx in range(-1, 2):
                    k = k0 + dx + (np.int64(dy) << bits)
                    out[c, m] = lookup(k, table_key, table_cell, shift)
                    m += 1


@njit(parallel=True, cache=True)
def count_neighbours(
    pos, spos, n_fluid, n_query, particle_cell, cell_nbrs, cell_start, cell_index, r2max, count_f, count_b
):
    """Pass 1: number of fluid and boundary neighbours within sqrt(r2max) of particles 0 … n_query−1.

    ``spos`` holds the positions in cell order (spos[s] = pos[cell_index[s]]): a contiguous scan.
    """
    d = pos.shape[1]
    kn = cell_nbrs.shape[1]
    for i in prange(n_query):
        x0 = pos[i, 0]
        x1 = pos[i, 1]
        x2 = pos[i, d - 1]
        c = particle_cell[i]
        cf = 0
        cb = 0
        for k in range(kn):
            cc = cell_nbrs[c, k]
            if cc < 0:
                continue
            for s in range(cell_start[cc], cell_start[cc + 1]):
                t = x0 - spos[s, 0]
                r2 = t * t
                t = x1 - spos[s, 1]
                r2 += t * t
                if d == 3:
                    t = x2 - spos[s, 2]
                    r2 += t * t
                if r2 < r2max:
                    j = cell_index[s]
                    if j < n_fluid:
                        if j != i:
                            cf += 1
                    else:
                        cb += 1
        count_f[i] = cf
        count_b[i] = cb


@njit(cache=True)
def offsets(count_f, count_b, n_query, start, mid):
    """CSR offsets of particles 0 … n_query−1: start[i] .. mid[i] fluid neighbours, mid[i] .. start[i+1] boundary."""
    start[0] = 0
    for i in range(n_query):
        mid[i] = start[i] + count_f[i]
        start[i + 1] = mid[i] + count_b[i]
    return start[n_query]


@njit(parallel=True, cache=True)
def fill_neighbours(
    pos, spos, n_fluid, n_query, particle_cell, cell_nbrs, cell_start, cell_index, r2max, start, mid, nbr
):
    """Pass 2: write the neighbour indices counted by :func:`count_neighbours`."""
    d = pos.shape[1]
    kn = cell_nbrs.shape[1]
    for i in prange(n_query):
        x0 = pos[i, 0]
        x1 = pos[i, 1]
        x2 = pos[i, d - 1]
        c = particle_cell[i]
        pf = start[i]
        pb = mid[i]
        for k in range(kn):
            cc = cell_nbrs[c, k]
            if cc < 0:
                continue
            for s in range(cell_start[cc], cell_start[cc + 1]):
                t = x0 - spos[s, 0]
                r2 = t * t
                t = x1 - spos[s, 1]
                r2 += t * t
                if d == 3:
                    t = x2 - spos[s, 2]
                    r2 += t * t
                if r2 < r2max:
                    j = cell_index[s]
                    if j < n_fluid:
                        if j != i:
                            nbr[pf] = j
                            pf += 1
                    else:
                        nbr[pb] = j
                        pb += 1


@njit(cache=True)
def capacities(count_f, count_b, n_query, cstart):
    """Slots per particle for a one-pass rebuild: last counts + 25 % + 2; returns the total."""
    cstart[0] = 0
    for i in range(n_query):
        c = count_f[i] + count_b[i]
        cstart[i + 1] = cstart[i] + c + 2 + c // 4
    return cstart[n_query]


@njit(parallel=True, cache=True)
def fill_capped(
    pos, spos, n_fluid, particle_cell, cell_nbrs, cell_start, cell_index, r2max, cstart, nbr, count_f, count_b
):
    """One-pass list build into per-particle slots [cstart[i], cstart[i+1]): fluid neighbours from the
    front, boundary ones from the back. Returns the number of particles whose slots overflowed
    (then the caller falls back to count + fill); the counts are exact either way."""
    d = pos.shape[1]
    kn = cell_nbrs.shape[1]
    over = 0
    for i in prange(n_fluid):
        x0 = pos[i, 0]
        x1 = pos[i, 1]
        x2 = pos[i, d - 1]
        c = particle_cell[i]
        pf = cstart[i]
        pb = cstart[i + 1]
        cf = 0
        cb = 0
        for k in range(kn):
            cc = cell_nbrs[c, k]
            if cc < 0:
                continue
            for s in range(cell_start[cc], cell_start[cc + 1]):
                t = x0 - spos[s, 0]
                r2 = t * t
                t = x1 - spos[s, 1]
                r2 += t * t
                if d == 3:
                    t = x2 - spos[s, 2]
                    r2 += t * t
                if r2 < r2max:
                    j = cell_index[s]
                    if j < n_fluid:
                        if j != i:
                            if pf < pb:
                                nbr[pf] = j
                            pf += 1
                            cf += 1
                    else:
                        pb -= 1
                        if pb >= pf:
                            nbr[pb] = j
                        cb += 1
        count_f[i] = cf
        count_b[i] = cb
        if cf + cb > cstart[i + 1] - cstart[i]:
            over += 1
    return over


@njit(cache=True)
def compact(cstart, count_f, count_b, n_fluid, start, mid, nbr, tmp):
    """Squeeze the slots of :func:`fill_capped` into CSR lists (fluid part, then boundary part in
    scan order — the same lists :func:`count_neighbours` + :func:`fill_neighbours` make)."""
    w = 0
    for i in range(n_fluid):
        s0 = cstart[i]
        s1 = cstart[i + 1]
        cb = count_b[i]
        for k in range(cb):
            tmp[k] = nbr[s1 - 1 - k]
        start[i] = w
        for k in range(count_f[i]):
            nbr[w] = nbr[s0 + k]
            w += 1
        mid[i] = w
        for k in range(cb):
            nbr[w] = tmp[k]
            w += 1
    start[n_fluid] = w
    return w


@njit(cache=True)
def transpose_boundary(n_fluid, n_total, start, mid, nbr, count):
    """Lists of the boundary particles (their fluid neighbours) from the fluid particles' lists.

    Appends them after the fluid lists in ``nbr`` (which must have room), sets start/mid of particles
    n_fluid … n_total−1 (mid = end: no boundary neighbours) and returns the active boundary particles
    (those with at least one fluid neighbour), in index order. Fluid neighbours appear in index order.
    """
    nb = n_total - n_fluid
    count[:nb] = 0
    for i in range(n_fluid):
        for s in range(mid[i], start[i + 1]):
            count[nbr[s] - n_fluid] += 1
    base = start[n_fluid]
    n_active = 0
    for k in range(nb):
        i = n_fluid + k
        mid[i] = base + count[k]
        start[i + 1] = mid[i]
        if count[k] > 0:
            n_active += 1
        count[k] = base
        base = mid[i]
    for i in range(n_fluid):
        for s in range(mid[i], start[i + 1]):
            k = nbr[s] - n_fluid
            nbr[count[k]] = i
            count[k] += 1
    active = np.empty(n_active, np.int64)
    a = 0
    for k in range(nb):
        i = n_fluid + k
        if start[i + 1] > start[i]:
            active[a] = i
            a += 1
    return active


class Grid:
    """Buffers of one hashed grid (reused between builds, grown only when needed)."""

    def __init__(self, dim: int):
        self.dim = dim
        self.bits = key_bits(dim)
        self.n = -1

    def ensure(self, n: int) -> None:
        if n == self.n:
            return
        self.n = n
        tsize = 1 << max(4, int(np.ceil(np.log2(2 * n + 2))))
        self.shift = 64 - int(np.log2(tsize))
        self.table_key = np.empty(tsize, np.int64)
        self.table_cell = np.empty(tsize, np.int64)
        self.keys = np.empty(n, np.int64)
        self.particle_cell = np.empty(n, np.int64)
        self.cell_key = np.empty(n, np.int64)
        self.cell_start = np.empty(n + 1, np.int64)
        self.cell_index = np.empty(n, np.int64)
        self.spos = None
        self.cell_nbrs = np.empty((0, 3**self.dim), np.int32)

    def ensure_cells(self, ncell: int) -> None:
        if self.cell_nbrs.shape[0] < ncell:
            self.cell_nbrs = np.empty((int(ncell * 1.25) + 16, 3**self.dim), np.int32)


def grid_origin(pos: np.ndarray, cell: float) -> np.ndarray:
    """Grid origin one cell below the particles' minimum corner (so packed coordinates stay ≥ 1)."""
    return pos.min(axis=0) - cell


def build_grid(grid: Grid, pos: np.ndarray, cell: float) -> int:
    """Hash, order (by key) and counting-sort ``pos`` into ``grid``; returns the number of cells.

    Raises ``ValueError`` when the particles span more cells than a packed key can hold.
    """
    n, d = pos.shape
    grid.ensure(n)
    origin = grid_origin(pos, cell)
    span = (pos.max(axis=0) - origin) / cell + 2
    if np.any(span >= (1 << grid.bits) - 2):
        raise ValueError(
            f"particles span {int(span.max())} cells along one axis, more than the {(1 << grid.bits) - 3} a key holds"
        )
    cell_keys(pos, origin.astype(np.float64), 1.0 / cell, grid.bits, grid.keys)
    grid.table_key.fill(-1)
    ncell = hash_cells(grid.keys, grid.table_key, grid.table_cell, grid.shift, grid.particle_cell, grid.cell_key)
    # order cells by key (row-major in space) for locality; renumber table and particles
    order = np.argsort(grid.cell_key[:ncell], kind="stable")
    rank = np.empty(ncell, np.int64)
    rank[order] = np.arange(ncell)
    grid.cell_key[:ncell] = grid.cell_key[:ncell][order]
    _renumber_table(grid.table_key, grid.table_cell, rank)
    renumber_cells(grid.particle_cell, rank)
    counting_sort(grid.particle_cell, ncell, grid.cell_start, grid.cell_index)
    grid.ensure_cells(ncell)
    if grid.spos is None or grid.spos.shape != pos.shape or grid.spos.dtype != pos.dtype:
        grid.spos = np.empty_like(pos)
    gather_sorted(pos, grid.cell_index, grid.spos)
    neighbour_cells(grid.cell_key, ncell, grid.table_key, grid.table_cell, grid.shift, grid.bits, d, grid.cell_nbrs)
    return ncell


@njit(cache=True)
def _renumber_table(table_key, table_cell, rank):
    for s in range(table_key.size):
        if table_key[s] != -1:
            table_cell[s] = rank[table_cell[s]]


def find_neighbours(pos, radius: float, n_fluid: int | None = None):
    """All neighbours closer than ``radius`` (strictly) of every particle, as CSR lists.

    Returns ``(start, mid, nbr)``: fluid neighbours of i are ``nbr[start[i]:mid[i]]`` and boundary
    neighbours (indices ≥ ``n_fluid``) ``nbr[mid[i]:start[i+1]]``; particles ≥ ``n_fluid`` list
    only fluid neighbours. ``n_fluid`` defaults to all particles. Allocates; for tests and probes.
    """
    pos = np.ascontiguousarray(pos, dtype=np.float64)
    n, d = pos.shape
    nf = n if n_fluid is None else int(n_fluid)
    grid = Grid(d)
    build_grid(grid, pos, float(radius))
    cf = np.empty(n, np.int64)
    cb = np.empty(n, np.int64)
    count_neighbours(
        pos, grid.spos, nf, nf, grid.particle_cell, grid.cell_nbrs, grid.cell_start, grid.cell_index, radius**2, cf, cb
    )
    start = np.empty(n + 1, np.int64)
    mid = np.empty(n, np.int64)
    total = offsets(cf, cb, nf, start, mid)
    nbr = np.empty(total + int(cb[:nf].sum()), np.int64)
    fill_neighbours(
        pos,
        grid.spos,
        nf,
        nf,
        grid.particle_cell,
        grid.cell_nbrs,
        grid.cell_start,
        grid.cell_index,
        radius**2,
        start,
        mid,
        nbr,
    )
    transpose_boundary(nf, n, start, mid, nbr, np.empty(max(n - nf, 1), np.int64))
    return start, mid, nbr
