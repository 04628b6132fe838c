"""HY-1 one droplet sub-step, written once: the serial loop, the parallel batches and the GPU call it.

:func:`step` advances a droplet by one sub-step of the model of :mod:`erosim.hydrology.droplets`
(its docstring has the equations: SimpleHydrology 2020's descent with sub-steps of at most
``max_step`` cells and an ℓ×ℓ footprint)::

    a = (ℓ/s²)·n_h/(V/V₀·ρ);  v += h·a;  x += h·v;  v *= 1 − h·f_eff
    c_eq = cap·(V/V₀)·|v|·max(0, Δz·dt/h);  ΔS = (h/dt)·k_d·max(0, 1 − ρ_r)·(c_eq − S) (× erodibility if > 0)
    V *= 1 − h·e_eff

against the terrain ``z`` plus, where ``has_ov``, an overlay ``ov`` (the batches' private map of a
droplet's own changes, :mod:`erosim.hydrology.batch`). It does not write the terrain: it returns
the footprint (:func:`origin`, cells by :func:`box`) and the height ``dz`` each of its dry cells
loses, and each caller applies that its own way — the serial loop and the batches with
:func:`lower` (into the terrain, into the overlay), the GPU kernel with atomic adds
(:mod:`erosim.hydrology.droplets_cuda`). The step tests the exits (map edge, sea, nodata or a
tile's halo: ``LEFT``; a lake, or a slow droplet in a strong stream or in a pit: ``STOP``; volume
below the minimum: ``ENDED``), otherwise returns ``MOVED``.

The functions here take plain scalars, arrays and a tuple of constants (:func:`constants`) and
are inlined where they are called; they are not cached on their own, so that numba-cuda can
compile the same source as a device function (as the shallow-water kernels do with
:mod:`erosim.sph.kernels_swe`). The seed preset's serial loop keeps its latency-tuned form of the
same model for whole steps and a one-cell footprint
(:func:`erosim.hydrology.droplets.descend_cell`, which agrees with this step to rounding, tested).
"""

from __future__ import annotations

import math

from numba import njit

from erosim.hydrology.params import (
    P_ACC,
    P_AMIN,
    P_CA,
    P_CAP,
    P_DENS,
    P_DT,
    P_DX,
    P_EVAP,
    P_FOOT,
    P_FRIC,
    P_KD,
    P_MAXSTEP,
    P_PIT,
    P_ROOT,
    P_SEA,
    P_V0,
    P_VMIN,
)
from erosim.hydrology.pools import HALO, NO_LAKE, OUTSIDE

MOVED = -1  # the sub-step is done and the droplet goes on
ENDED = 0  # volume below the minimum (or step cap): the caller settles what is left
LEFT = 1  # left the map or entered the sea: water and sediment accounted as gone
STOP = 2  # stopped at a cell for HY-2 flood


@njit(inline="always")
def constants(P):
    """The step's constants from the kernel vector ``P`` (:func:`erosim.hydrology.params.kernel_constants`):
    (dt, 1/Δx, Δx², footprint m, max_step, V_min, sea, friction, evaporation, cap, root, pit, k_d,
    1/V₀, ℓ/(s²ρ), |a|²_min)."""
    return (
        P[P_DT], 1.0 / P[P_DX], P[P_CA], P[P_FOOT], P[P_MAXSTEP], P[P_VMIN], P[P_SEA], P[P_FRIC], P[P_EVAP],
        P[P_CAP], P[P_ROOT], P[P_PIT], P[P_KD], 1.0 / P[P_V0], P[P_ACC] / P[P_DENS], P[P_AMIN] * P[P_AMIN],
    )  # fmt: skip


@njit(inline="always")
def sample(z, ov, has_ov, x, y):
    """Height and gradient (per cell) of the Q4 interpolant of z (+ ov where ``has_ov``) at (x, y),
    clamped to the map: the four corners loaded once for all three."""
    ny, nx = z.shape
    xc = min(max(x, 0.0), nx - 1.0)
    yc = min(max(y, 0.0), ny - 1.0)
    i0 = min(int(xc), nx - 2)
    j0 = min(int(yc), ny - 2)
    fx = xc - i0
    fy = yc - j0
    z1 = z[j0, i0]
    z2 = z[j0, i0 + 1]
    z3 = z[j0 + 1, i0 + 1]
    z4 = z[j0 + 1, i0]
    if has_ov:
        c = j0 * nx + i0
        z1 = z1 + ov[c]
        z2 = z2 + ov[c + 1]
        z3 = z3 + ov[c + nx + 1]
        z4 = z4 + ov[c + nx]
    top = z1 + fx * (z2 - z1)
    bot = z4 + fx * (z3 - z4)
    gx = (1.0 - fy) * (z2 - z1) + fy * (z3 - z4)
    gy = (1.0 - fx) * (z4 - z1) + fx * (z3 - z2)
    return top + fy * (bot - top), gx, gy


@njit(inline="always")
def surface(c, zf, ov, has_ov, lake_of, level, sea_level):
    """:func:`erosim.hydrology.pools.surface` of the terrain (+ overlay): lake level, sea, or height."""
    j = lake_of[c]
    if j >= 0:
        return level[j]
    h = zf[c] + ov[c] if has_ov else zf[c]
    return sea_level if h < sea_level else h


@njit(inline="always")
def _walk_height(n, zf, ov, has_ov, lake_of, level, sea_level):
    """:func:`surface` of a neighbour in the walk, +∞ on a nodata cell (never the lowest), written
    with selects instead of branches: which neighbour is lowest is data-dependent, so branches on
    it mispredict (the walk was half of a step's time)."""
    lk = lake_of[n]
    h = zf[n] + ov[n] if has_ov else zf[n]
    h = sea_level if h < sea_level else h
    lv = level[lk if lk >= 0 else 0]
    h = lv if lk >= 0 else h
    return math.inf if lk == OUTSIDE else h


STALL = 0.01  # cells per time step: a droplet at a pit's bottom moving slower than this has stopped there


@njit(inline="always")
def trapped(speed, g, h, rim, v_stall):
    """A droplet of speed |v| at height h (m) in a pit whose rim is at ``rim`` cannot leave it: its kinetic
    energy cannot lift it over the rim, ½|v|² < g·(rim − h), with g = ℓ/(s²·ρ·V/V₀) the acceleration
    per unit slope of :func:`step` (so ½|v|² + g·z only falls along a path: friction); or it has stopped,
    |v| < ``v_stall`` (on a pit's flat floor the rim is level with it, and friction slows it forever
    without reaching 0)."""
    return 0.5 * speed * speed < g * (rim - h) or speed < v_stall


@njit(inline="always")
def pit_trap(c, x, y, max_walk, speed, g, h, v_stall, zf, ov, has_ov, lake_of, level, sea_level, nx, ny):
    """(trapped, cell): whether a droplet at (x, y) over cell c, of speed |v| at height h, is trapped
    (:func:`trapped`) in the pit that a steepest-descent D8 walk of the surface (:func:`surface`, +∞ on
    nodata; neighbours in row order, the first of equal heights kept) from c ends in within
    ``max_walk`` moves, with that pit's rim its lowest neighbour; and that pit's cell. A walk that
    steps into a tile's halo (``HALO``) ends there untrapped: the pit the droplet may be in lies beyond
    the tile, so it goes on descending and leaves there. The surface includes the overlay where
    ``has_ov``: the test sees the droplet's own deposits.

    Read only as far as a trap is possible (the walk at every step was a quarter of a sub-step's
    time). A pit's rim is at most the surface of the cell the walk entered it from; every cell on the
    walk is lower than the one before. So the rim of any pit the walk can still reach is at most the
    surface of the cell it just left, and a droplet that could climb that high (and is not stalled)
    is not trapped: the walk stops there. Before the first scan the bound is max(surface(c), the
    lowest of the other corners of the cell square around (x, y)): those corners are neighbours of c,
    so they bound the rim of a pit at c. Told from those four cells in seven sub-steps in ten of a
    round at 1024²."""
    hc = surface(c, zf, ov, has_ov, lake_of, level, sea_level)
    i0 = min(int(min(max(x, 0.0), nx - 1.0)), nx - 2)
    j0 = min(int(min(max(y, 0.0), ny - 1.0)), ny - 2)
    k0 = j0 * nx + i0
    up = math.inf
    for n in (k0, k0 + 1, k0 + nx, k0 + nx + 1):
        hn = _walk_height(n, zf, ov, has_ov, lake_of, level, sea_level)
        up = hn if (n != c and hn < up) else up
    if not trapped(speed, g, h, max(up, hc), v_stall):
        return False, c
    prev = math.inf  # surface of the cell the walk came from: any pit further on has its rim at most that
    iy = c // nx
    ix = c - iy * nx
    hcur = hc
    for _ in range(max_walk):
        if not trapped(speed, g, h, prev, v_stall) or lake_of[c] == HALO:
            return False, c
        best = c
        hb = hcur
        bi = ix
        bj = iy
        rim = math.inf
        for j in range(max(iy - 1, 0), min(iy + 2, ny)):
            for i in range(max(ix - 1, 0), min(ix + 2, nx)):
                n = j * nx + i
                hn = _walk_height(n, zf, ov, has_ov, lake_of, level, sea_level)
                lower_here = hn < hb
                hb = hn if lower_here else hb
                best = n if lower_here else best
                bi = i if lower_here else bi
                bj = j if lower_here else bj
                rim = hn if (n != c and hn < rim) else rim
        if best == c:
            return trapped(speed, g, h, rim, v_stall), c
        prev = hcur
        c = best
        hcur = hb
        ix = bi
        iy = bj
    return False, c


CODE_SHIFT = 32  # a footprint's code holds its first row in the high 32 bits and its first column in the low ones
CODE_MASK = (1 << CODE_SHIFT) - 1


@njit(inline="always")
def origin(x, y, m):
    """Code of the m×m footprint centred at (x, y): its first cell (i, j) = (floor(x − (m−1)/2 + ½), the
    same in y; for m = 1 the cell holding (x, y)), as (j + m)·2³² + (i + m). A shift and a mask decode it
    (:func:`box`): a flat index decoded by integer division cost two divisions a sub-step."""
    i0 = int(math.floor(x - 0.5 * (m - 1) + 0.5))
    j0 = int(math.floor(y - 0.5 * (m - 1) + 0.5))
    return ((j0 + m) << CODE_SHIFT) + i0 + m


@njit(inline="always")
def box(code, m, nx, ny):
    """Cells (j range, i range) of the footprint ``code`` (:func:`origin`), clipped to the map."""
    j0 = (code >> CODE_SHIFT) - m
    i0 = (code & CODE_MASK) - m
    return max(j0, 0), min(j0 + m, ny), max(i0, 0), min(i0 + m, nx)


@njit(inline="always")
def lower(dst, lake_of, code, m, nx, ny, dz):
    """dst −= dz on the dry (non-lake) cells of footprint ``code``: a step's transfer applied."""
    j_lo, j_hi, i_lo, i_hi = box(code, m, nx, ny)
    for j in range(j_lo, j_hi):
        for i in range(i_lo, i_hi):
            if lake_of[j * nx + i] == NO_LAKE:
                dst[j * nx + i] -= dz


@njit(inline="always")
def step(x, y, vx, vy, V, S, speed, z2, zf, ov, has_ov, stream, roots, erod, lake_of, level, K):
    """One sub-step of a droplet at (x, y) (cells) with velocity (vx, vy) (m/s), speed |v|, volume
    V and sediment S (m³) over the terrain ``z2`` (``zf`` its flat view) + ``ov`` where ``has_ov``.

    Returns (status, x, y, vx, vy, V, S, speed, code, dz, moved): ``code`` the footprint of the
    old position (:func:`origin`), ``dz`` the height each of its dry cells loses (0 when nothing
    moves; the caller applies it), ``moved`` the sediment taken up (m³, negative: deposited). On
    ``LEFT`` (x, y) is the last position on the map and V, S are the water and sediment leaving; a
    step into a tile's halo (``HALO``) is a whole step, its transfer made on the old footprint's dry
    cells (the halo's are not the tile's: never changed) as in the map beyond, then ``LEFT`` at the halo
    cell; every other exit moves nothing (``dz`` = ``moved`` = 0).
    ``K``: :func:`constants`."""
    ny, nx = z2.shape
    dt, inv_dx, ca, mf, maxstep, vmin, sea, fric, evp, cap, root, pit, kd, inv_v0, acc_num, amin2 = K
    m = int(mf)
    c = int(y + 0.5) * nx + int(x + 0.5)
    code = origin(x, y, m)
    h0, gx, gy = sample(z2, ov, has_ov, x, y)
    gx *= inv_dx
    gy *= inv_dx
    vrel = V * inv_v0
    scale = acc_num / (vrel * math.sqrt(1.0 + gx * gx + gy * gy))
    s = stream[c]
    fe = fric * (1.0 - 0.5 * s)
    ee = evp * (1.0 - 0.2 * s)
    ax = -gx * scale
    ay = -gy * scale
    a2 = ax * ax + ay * ay  # |a|², compared with squares: no square root on the hot path
    nsub = 1
    h = dt
    if maxstep > 0.0:
        dist = (speed + dt * math.sqrt(a2)) * dt * inv_dx
        if dist > maxstep:
            nsub = min(int(math.ceil(dist / maxstep)), 1024)
            if nsub > 1:
                h = dt / nsub
    vx += h * ax
    vy += h * ay
    x0 = x
    y0 = y
    x += h * vx * inv_dx
    y += h * vy * inv_dx
    damp = 1.0 - h * fe
    vx *= damp
    vy *= damp
    if x < -0.5 or y < -0.5 or x >= nx - 0.5 or y >= ny - 0.5:
        return LEFT, x0, y0, vx, vy, V, S, speed, code, 0.0, 0.0
    cn = int(y + 0.5) * nx + int(x + 0.5)
    zn = zf[cn] + ov[cn] if has_ov else zf[cn]
    if zn < sea or lake_of[cn] == OUTSIDE:
        return LEFT, x, y, vx, vy, V, S, speed, code, 0.0, 0.0
    out = lake_of[cn] == HALO  # into a tile's halo: this step's transfer is made, then the droplet leaves
    if not out and ((stream[cn] > 0.5 and a2 < amin2) or lake_of[cn] >= 0):
        return STOP, x, y, vx, vy, V, S, speed, code, 0.0, 0.0
    speed = math.sqrt(vx * vx + vy * vy)
    h1, _, _ = sample(z2, ov, has_ov, x, y)
    if not out and pit > 0.0:
        held, wc = pit_trap(cn, x, y, 2 * m + 1, speed, acc_num / vrel, h1, STALL / (dt * inv_dx), zf, ov, has_ov,
                            lake_of, level, sea, nx, ny)  # fmt: skip
        if held:
            return STOP, float(wc % nx), float(wc // nx), vx, vy, V, S, speed, code, 0.0, 0.0
    # mass transfer at the old position (its footprint's dry cells)
    drop = (h0 - h1) * nsub
    ceq = cap * vrel * speed * drop if drop > 0.0 else 0.0
    hold = 1.0 - root * roots[c]
    if hold < 0.0:
        hold = 0.0
    diff = ceq - S
    amt = (kd if nsub == 1 else kd / nsub) * hold * diff
    if diff > 0.0:
        amt *= erod[c]
    dz = 0.0
    moved = 0.0
    if amt != 0.0:
        j_lo, j_hi, i_lo, i_hi = box(code, m, nx, ny)
        cnt = 0
        for j in range(j_lo, j_hi):
            for i in range(i_lo, i_hi):
                if lake_of[j * nx + i] == NO_LAKE:
                    cnt += 1
        if cnt > 0:  # lake cells are never eroded or filled by descent
            dz = amt / (cnt * ca)
            moved = amt
            S += amt
    V = V * (1.0 - h * ee)
    if out:
        return LEFT, x, y, vx, vy, V, S, speed, code, dz, moved
    return (ENDED if V < vmin else MOVED), x, y, vx, vy, V, S, speed, code, dz, moved
