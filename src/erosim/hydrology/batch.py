"""Batch-synchronous parallel descent (HY-1 on all cores): the droplets of a batch run at once.

In the seed every droplet sees the terrain the previous one left. With ``hydrology.batch`` > 0 (unset:
an eighth of a cycle's droplets, :func:`erosim.hydrology.params.batch_size`, the library scenario's
default; 0 = the seed's order, which the ``simplehydrology-2020`` preset keeps) the droplets of a cycle
run in batches, in **rounds**:

1. in parallel (Numba ``prange``), every droplet of the batch that has a descent to do descends
   against the terrain, streams and lakes **as they were at the round's start**, plus its own
   changes: it writes them into a private overlay (one map per thread, cleared after each
   droplet) and logs them — for each step its footprint and the height each dry footprint cell
   loses (negative: gains) — with its budget terms in its own row;
2. serially and in droplet order the logs are applied to the terrain (and the visited
   footprints marked, HY-4), the budget rows added, and then each droplet that stopped floods
   (HY-2, :mod:`erosim.hydrology.pools`) exactly as in the serial loop: it ends in a lake, or
   drains, walks off the drain and needs another descent, which the next round does.

Rounds repeat until every droplet of the batch has ended, left or used its ``spill`` floods. So
the model differs from the seed's order only in that droplets of one round do not see each
other's erosion (each sees its own, as in the seed); the lakes are the serial loop's, filled and
drained one droplet after another. This is how droplet erosion is usually made parallel on GPUs.

Determinism: a droplet's descent depends only on the round-start state, its index and its own
changes (the overlay starts at zero for every droplet), and everything is applied in droplet order,
so the result is the same for any thread count (for a given seed, input and batch size). Budgets
close as in the serial loop: every logged change is applied exactly once, to the cells it was
computed for (the lakes do not change between a round's two phases), and counted in the same
droplet's budget row. A droplet whose log fills up (``LOG`` steps) pauses and goes on descending
in the next round. A round with fewer than ``SERIAL_BELOW`` droplets to descend runs them on the
calling thread (:func:`descend_batch_serial`): the same results without the threads' round trip.

The kernel is :func:`erosim.hydrology.droplets.descend`'s model (any footprint, sub-steps); with a
one-cell footprint and whole steps it agrees with :func:`~erosim.hydrology.droplets.descend_cell`
to rounding.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange

from erosim.hydrology.counter_rng import spawn_base, spawn_point
from erosim.hydrology.droplets import ENDED, LEFT, STOP, footprint_start
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
    P_MAXSTEPS,
    P_PIT,
    P_ROOT,
    P_SEA,
    P_V0,
    P_VMIN,
)
from erosim.hydrology.pools import B_CARRIED, B_DEPOSITED, B_ERODED, B_EVAP, B_LEFT, B_SIZE, B_STEPS, NO_LAKE, OUTSIDE

PAUSED = 3  # the droplet's log is full: it goes on descending in the next round
NEW = 4  # spawns and descends in the next round
NEXT = 5  # drained a lake: descends again in the next round
DONE = 6  # ended, left, or settled: nothing more to do
LOG = 2048  # logged steps per droplet and round
SERIAL_BELOW = 4  # a round with fewer droplets to descend runs on the calling thread

# columns of the per-droplet rows
R_STATUS, R_X, R_Y, R_VX, R_VY, R_V, R_S, R_NLOG, R_ROUNDS, R_USED = range(10)
R_SIZE = 10


@njit(cache=True, inline="always")
def _sample_ov(z, ov, x, y):
    """:func:`erosim.hydrology.droplets.sample` of the terrain plus the droplet's overlay: the
    height and gradient (per cell) of the Q4 interpolant at (x, y), clamped to the map."""
    ny, nx = z.shape
    xc = min(max(x, 0.0), nx - 1.0)
    yc = min(max(y, 0.0), ny - 1.0)
    i0 = min(int(xc), nx - 2)
    j0 = min(int(yc), ny - 2)
    fx = xc - i0
    fy = yc - j0
    c = j0 * nx + i0
    z1 = z[j0, i0] + ov[c]
    z2 = z[j0, i0 + 1] + ov[c + 1]
    z3 = z[j0 + 1, i0 + 1] + ov[c + nx + 1]
    z4 = z[j0 + 1, i0] + ov[c + nx]
    top = z1 + fx * (z2 - z1)
    bot = z4 + fx * (z3 - z4)
    gx = (1.0 - fy) * (z2 - z1) + fy * (z3 - z4)
    gy = (1.0 - fx) * (z4 - z1) + fx * (z3 - z2)
    return top + fy * (bot - top), gx, gy


@njit(cache=True, inline="always")
def _surface_ov(c, zf, ov, lake_of, level, sea_level):
    """:func:`erosim.hydrology.pools.surface` of the terrain plus the droplet's overlay."""
    j = lake_of[c]
    if j >= 0:
        return level[j]
    h = zf[c] + ov[c]
    return sea_level if h < sea_level else h


@njit(cache=True)
def walk_down_ov(c, max_walk, zf, ov, lake_of, level, sea_level, nx, ny):
    """:func:`erosim.hydrology.pools.walk_down` over the terrain plus the droplet's overlay (the
    pit test sees the droplet's own deposits, as in the serial loop): (cell, at a minimum)."""
    for _ in range(max_walk):
        iy = c // nx
        ix = c - iy * nx
        best = c
        hb = _surface_ov(c, zf, ov, lake_of, level, sea_level)
        for j in range(max(iy - 1, 0), min(iy + 2, ny)):
            for i in range(max(ix - 1, 0), min(ix + 2, nx)):
                n = j * nx + i
                if lake_of[n] == OUTSIDE:
                    continue
                h = _surface_ov(n, zf, ov, lake_of, level, sea_level)
                if h < hb:
                    hb = h
                    best = n
        if best == c:
            return c, True
        c = best
    return c, False


@njit(cache=True, inline="always")
def _origin(x, y, m, nx):
    """Log code of the footprint at (x, y): its cell (m = 1), else its first cell offset by m."""
    if m == 1:
        return int(y + 0.5) * nx + int(x + 0.5)
    return (footprint_start(y, m) + m) * (nx + 2 * m) + footprint_start(x, m) + m


@njit(cache=True, inline="always")
def _box(code, m, nx, ny):
    """Cells (j range, i range) of a logged footprint, clipped to the map."""
    if m == 1:
        j = code // nx
        i = code - j * nx
        return j, j + 1, i, i + 1
    w = nx + 2 * m
    j0 = code // w - m
    i0 = code - (j0 + m) * w - m
    return max(j0, 0), min(j0 + m, ny), max(i0, 0), min(i0 + m, nx)


@njit(cache=True, error_model="numpy")
def descend_logged(x, y, vx, vy, V, S, used, z2, zf, ov, stream, roots, erod, lake_of, level, lc, ldz, bd, P):
    """:func:`erosim.hydrology.droplets.descend` against the round-start terrain plus the
    droplet's own changes (overlay ``ov``, flat, all zero on entry and on return): step k logs
    its footprint ``lc[k]`` (:func:`_origin`) and the height each dry footprint cell loses,
    ``ldz[k]``; budget terms go to the droplet's row ``bd``. ``used``: steps already taken in
    this descent (earlier rounds). Returns (status, x, y, vx, vy, V, S, steps logged)."""
    ny, nx = z2.shape
    dt = P[P_DT]
    dx = P[P_DX]
    ca = P[P_CA]
    m = int(P[P_FOOT])
    maxstep = P[P_MAXSTEP]
    vmin = P[P_VMIN]
    sea = P[P_SEA]
    fric = P[P_FRIC]
    evp = P[P_EVAP]
    cap = P[P_CAP]
    root = P[P_ROOT]
    pit = P[P_PIT]
    kd = P[P_KD]
    maxsteps = int(P[P_MAXSTEPS]) - used
    inv_dx = 1.0 / dx
    inv_v0 = 1.0 / P[P_V0]
    acc_num = P[P_ACC] / P[P_DENS]
    amin2 = P[P_AMIN] * P[P_AMIN]
    xmax = nx - 0.5
    ymax = ny - 0.5
    cap_log = lc.shape[0]
    steps = 0
    evap = 0.0
    eroded = 0.0
    deposited = 0.0
    status = PAUSED
    speed = math.sqrt(vx * vx + vy * vy)
    while steps < cap_log:
        c = int(y + 0.5) * nx + int(x + 0.5)
        code = _origin(x, y, m, nx)
        h0, gx, gy = _sample_ov(z2, ov, x, y)
        gx *= inv_dx
        gy *= inv_dx
        vrel = V * inv_v0
        scale = acc_num / (vrel * math.sqrt(1.0 + gx * gx + gy * gy))
        s = stream[c]
        fe = fric * (1.0 - 0.5 * s)
        ee = evp * (1.0 - 0.2 * s)
        ax = -gx * scale
        ay = -gy * scale
        a2 = ax * ax + ay * ay
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
        lc[steps] = code
        ldz[steps] = 0.0
        steps += 1
        if x < -0.5 or y < -0.5 or x >= xmax or y >= ymax:
            bd[B_LEFT] += V
            bd[B_CARRIED] += S
            x, y, V, S = x0, y0, 0.0, 0.0
            status = LEFT
            break
        cn = int(y + 0.5) * nx + int(x + 0.5)
        if zf[cn] + ov[cn] < sea or lake_of[cn] == OUTSIDE:
            bd[B_LEFT] += V
            bd[B_CARRIED] += S
            V, S = 0.0, 0.0
            status = LEFT
            break
        if (stream[cn] > 0.5 and a2 < amin2) or lake_of[cn] >= 0:
            status = STOP
            break
        speed = math.sqrt(vx * vx + vy * vy)
        if speed * h < pit:
            wc, at_min = walk_down_ov(cn, 2 * m + 1, zf, ov, lake_of, level, sea, nx, ny)
            if at_min:
                x = float(wc % nx)
                y = float(wc // nx)
                status = STOP
                break
        # mass transfer at the old position (its footprint's dry cells)
        h1, _, _ = _sample_ov(z2, ov, x, y)
        drop = (h0 - h1) * nsub
        ceq = cap * vrel * speed * drop if drop > 0.0 else 0.0
        hold = 1.0 - root * roots[c]
        if hold < 0.0:
            hold = 0.0
        diff = ceq - S
        amt = (kd if nsub == 1 else kd / nsub) * hold * diff
        if diff > 0.0:
            amt *= erod[c]
        if amt != 0.0:
            j_lo, j_hi, i_lo, i_hi = _box(code, m, nx, ny)
            cnt = 0
            for j in range(j_lo, j_hi):
                for i in range(i_lo, i_hi):
                    if lake_of[j * nx + i] == NO_LAKE:
                        cnt += 1
            if cnt > 0:
                dz = amt / (cnt * ca)
                for j in range(j_lo, j_hi):
                    for i in range(i_lo, i_hi):
                        if lake_of[j * nx + i] == NO_LAKE:
                            ov[j * nx + i] -= dz
                ldz[steps - 1] = dz
                if amt > 0.0:
                    eroded += amt
                else:
                    deposited -= amt
                S += amt
        vn = V * (1.0 - h * ee)
        evap += V - vn
        V = vn
        if V < vmin or steps >= maxsteps:
            status = ENDED
            break
    for k in range(steps):  # leave the overlay at zero for the thread's next droplet
        if ldz[k] != 0.0:
            j_lo, j_hi, i_lo, i_hi = _box(lc[k], m, nx, ny)
            for j in range(j_lo, j_hi):
                for i in range(i_lo, i_hi):
                    ov[j * nx + i] = 0.0
    bd[B_STEPS] += steps
    bd[B_EVAP] += evap
    bd[B_ERODED] += eroded
    bd[B_DEPOSITED] += deposited
    return status, x, y, vx, vy, V, S, steps


@njit(cache=True, inline="always")
def _descend_one(i, t, first, base, z2, zf, sf, rf, ef, lake_of, level, rain_cdf, P, res, lc, ldz, bd, ov):
    """Droplet ``i``'s descent of this round (if its row says it has one) on overlay row ``t``."""
    ny, nx = z2.shape
    for k in range(B_SIZE):
        bd[i, k] = 0.0
    st0 = int(res[i, R_STATUS])
    res[i, R_NLOG] = 0.0
    if st0 != NEW and st0 != PAUSED and st0 != NEXT:
        return
    if st0 == NEW:
        x, y = spawn_point(base, first + i, rain_cdf, nx, ny)
        vx, vy, V, S, used = 0.0, 0.0, P[P_V0], 0.0, 0
    else:
        x, y, vx, vy = res[i, R_X], res[i, R_Y], res[i, R_VX], res[i, R_VY]
        V, S, used = res[i, R_V], res[i, R_S], int(res[i, R_USED]) if st0 == PAUSED else 0
    st, x, y, vx, vy, V, S, n = descend_logged(
        x, y, vx, vy, V, S, used, z2, zf, ov[t], sf, rf, ef, lake_of, level, lc[i], ldz[i], bd[i], P
    )
    res[i, R_STATUS] = st
    res[i, R_X] = x
    res[i, R_Y] = y
    res[i, R_VX] = vx
    res[i, R_VY] = vy
    res[i, R_V] = V
    res[i, R_S] = S
    res[i, R_NLOG] = n
    res[i, R_USED] = used + n


@njit(cache=True, parallel=True)
def descend_batch(first, count, seed, z2, stream, roots, erod, lake_of, level, rain_cdf, P, res,
                  lc, ldz, bd, ov):  # fmt: skip
    """Phase 1 of a round: droplets ``first`` … ``first + count − 1`` whose row says NEW (spawn
    first), PAUSED or NEXT descend in parallel (:func:`descend_logged`); results back in
    ``res[i]``, logs in ``lc[i]``, ``ldz[i]``, budget terms in ``bd[i]`` (all rows cleared here).
    ``ov``: one zeroed overlay row (map size) per Numba thread."""
    zf = z2.reshape(-1)
    sf = stream.reshape(-1)
    rf = roots.reshape(-1)
    ef = erod.reshape(-1)
    base = spawn_base(seed)
    for i in prange(count):
        _descend_one(i, numba.get_thread_id(), first, base, z2, zf, sf, rf, ef, lake_of, level, rain_cdf, P, res,
                     lc, ldz, bd, ov)  # fmt: skip


@njit(cache=True)
def descend_batch_serial(first, count, seed, z2, stream, roots, erod, lake_of, level, rain_cdf, P, res,
                         lc, ldz, bd, ov):  # fmt: skip
    """:func:`descend_batch` on the calling thread (overlay row 0), for a round with only a few
    droplets left to descend: the same results, without waking the other threads and waiting for
    the slowest at the round's end (on a loaded machine that wait cost more than the work)."""
    zf = z2.reshape(-1)
    sf = stream.reshape(-1)
    rf = roots.reshape(-1)
    ef = erod.reshape(-1)
    base = spawn_base(seed)
    for i in range(count):
        _descend_one(i, 0, first, base, z2, zf, sf, rf, ef, lake_of, level, rain_cdf, P, res, lc, ldz, bd, ov)


@njit(cache=True)
def apply_logs(count, nx, ny, m, zf, lake_of, track, res, lc, ldz, bd, B):
    """Phase 2a, serial in droplet order: apply the logged height changes to the dry cells of each
    logged footprint, mark the footprints visited (HY-4) and add each droplet's budget row."""
    for i in range(count):
        for k in range(int(res[i, R_NLOG])):
            j_lo, j_hi, i_lo, i_hi = _box(lc[i, k], m, nx, ny)
            dz = ldz[i, k]
            for j in range(j_lo, j_hi):
                for ii in range(i_lo, i_hi):
                    c = j * nx + ii
                    track[c] = 1
                    if dz != 0.0 and lake_of[c] == NO_LAKE:
                        zf[c] -= dz
        for k in range(B_SIZE):
            B[k] += bd[i, k]


def work_arrays(batch: int, cells: int, log: int = LOG) -> tuple[np.ndarray, ...]:
    """(res, lc, ldz, bd, ov) for batches of ``batch`` droplets logging up to ``log`` steps each
    on a map of ``cells`` cells (one overlay row per Numba thread)."""
    return (
        np.zeros((batch, R_SIZE)),
        np.zeros((batch, log), np.int64),
        np.zeros((batch, log)),
        np.zeros((batch, B_SIZE)),
        np.zeros((numba.config.NUMBA_NUM_THREADS, cells)),
    )


__all__ = [
    "DONE", "LOG", "NEW", "NEXT", "PAUSED", "SERIAL_BELOW", "apply_logs", "descend_batch",
    "descend_batch_serial", "work_arrays",
]  # fmt: skip
