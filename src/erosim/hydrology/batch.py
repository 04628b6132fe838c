"""Batch-synchronous parallel descent (HY-1 on all cores): the droplets of a batch run at once.

In the seed every droplet sees the terrain the previous one left. With ``hydrology.batch`` > 0 (unset:
an eighth of a cycle's droplets, :func:`erosim.hydrology.params.batch_size`, the library scenario's
default; 0 = the seed's order, which the ``simplehydrology-2020`` preset keeps) the droplets of a cycle
run through ``batch`` **slots**, in **rounds**:

1. in parallel (Numba ``prange``), every slot's droplet that has a descent to do descends
   against the terrain, streams and lakes **as they were at the round's start**, plus its own
   changes: it writes them into a private overlay (one map per thread, cleared after each
   droplet) and logs them — for each step its footprint and the height each dry footprint cell
   loses (negative: gains) — with its budget terms in its own row;
2. in slot order the logs are applied to the terrain (and the visited footprints marked, HY-4:
   in parallel over bands of rows, each band in slot order, :func:`apply_logs`), the budget rows
   added, and then, serially, each droplet that stopped floods
   (HY-2, :mod:`erosim.hydrology.pools`) exactly as in the serial loop: it ends in a lake, or
   drains, walks off the drain and needs another descent, which the next round does.

After each round a slot whose droplet has ended, left or used its ``spill`` floods takes the
cycle's next droplet (:meth:`erosim.hydrology.model.HydrologyModel._run_batch`), so every round but
the cycle's last few descends ``batch`` droplets. When each eighth of a cycle ran to its end before
the next began, its last rounds held a few stragglers each and left threads idle: at 1024² the
rounds of fewer than 32 droplets took 19 % of the descents' time, now 4 % (docs/performance.md,
"Slots"). So the model differs
from the seed's order only in that droplets of one round do not see each other's erosion (each
sees its own, as in the seed); the lakes are the serial loop's, filled and drained one droplet
after another. This is how droplet erosion is usually made parallel on GPUs.

Determinism: a droplet's descent depends only on the round-start state, its index and its own
changes (the overlay starts at zero for every droplet), everything is applied in slot order, and
which droplet enters which slot depends only on which slots the last round freed, so the result is
the same for any thread count (for a given seed, input and batch size). Budgets
close as in the serial loop: every logged change is applied exactly once, to the cells it was
computed for (the lakes do not change between a round's two phases), and counted in the same
droplet's budget row. A droplet whose log fills up (``LOG`` footprints) pauses and goes on descending
in the next round. A round with fewer than ``SERIAL_BELOW`` droplets to descend runs them on the
calling thread (:func:`descend_batch_serial`): the same results without the threads' round trip.

Each step is the sub-step the serial loop and the GPU also run
(:func:`erosim.hydrology.droplet_step.step`, any footprint, sub-steps), here against the terrain
plus the overlay; with a one-cell footprint and whole steps it agrees with
:func:`~erosim.hydrology.droplets.descend_cell` to rounding.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange

from erosim.hydrology.counter_rng import spawn_base, spawn_point
from erosim.hydrology.droplet_step import ENDED, LEFT, STOP, box, constants, lower, step
from erosim.hydrology.loop_kernel import loop_kernel
from erosim.hydrology.params import P_FOOT, P_MAXSTEPS, P_V0
from erosim.hydrology.pools import B_CARRIED, B_DEPOSITED, B_ERODED, B_EVAP, B_LEFT, B_SIZE, B_STEPS, NO_LAKE
from erosim.kernels.work_queue import take

PAUSED = 3  # the droplet's log is full: it goes on descending in the next round
NEW = 4  # spawns and descends in the next round
NEXT = 5  # drained a lake: descends again in the next round
DONE = 6  # ended, left, or settled: nothing more to do
LOG = 2048  # log entries (footprints) per droplet and round
SERIAL_BELOW = 4  # a round with fewer droplets to descend runs on the calling thread

# columns of the per-droplet rows
R_STATUS, R_X, R_Y, R_VX, R_VY, R_V, R_S, R_NLOG, R_ROUNDS, R_USED, R_INDEX = range(11)
R_SIZE = 11


@loop_kernel
def descend_logged(x, y, vx, vy, V, S, used, z2, zf, ov, stream, roots, erod, lake_of, level, lc, ldz, bd, P):
    """The droplet's descent (:func:`erosim.hydrology.droplet_step.step`) against the round-start
    terrain plus its own changes (overlay ``ov``, flat, all zero on entry and on return): each step
    logs its footprint (:func:`~erosim.hydrology.droplet_step.origin`) and the height each dry footprint
    cell loses; a step on the same footprint as the one before adds its height to that entry (about
    two steps in three at 1024²: sub-steps are short), so entry k is ``lc[k]``, ``ldz[k]``. Budget
    terms go to the droplet's row ``bd``. ``used``: steps already taken in this descent (earlier
    rounds). Returns (status, x, y, vx, vy, V, S, log entries, steps)."""
    ny, nx = z2.shape
    K = constants(P)
    m = int(P[P_FOOT])
    maxsteps = int(P[P_MAXSTEPS]) - used
    cap_log = lc.shape[0]
    steps = 0
    n = 0  # log entries
    evap = 0.0
    eroded = 0.0
    deposited = 0.0
    status = PAUSED
    speed = math.sqrt(vx * vx + vy * vy)
    while n < cap_log:
        st, x, y, vx, vy, vn, S, speed, code, dz, moved = step(
            x, y, vx, vy, V, S, speed, z2, zf, ov, True, stream, roots, erod, lake_of, level, K
        )
        if n > 0 and lc[n - 1] == code:
            ldz[n - 1] += dz
        else:
            lc[n] = code
            ldz[n] = dz
            n += 1
        steps += 1
        if st == LEFT:
            if moved > 0.0:  # a step into a tile's halo makes its transfer (droplet_step.step)
                eroded += moved
            elif moved < 0.0:
                deposited -= moved
            evap += V - vn  # 0 for every other exit: V is returned unchanged
            V = vn
            bd[B_LEFT] += V
            bd[B_CARRIED] += S
            V, S = 0.0, 0.0
            status = LEFT
            break
        if st == STOP:
            status = STOP
            break
        if moved != 0.0:
            lower(ov, lake_of, code, m, nx, ny, dz)
            if moved > 0.0:
                eroded += moved
            else:
                deposited -= moved
        evap += V - vn
        V = vn
        if st == ENDED or steps >= maxsteps:
            status = ENDED
            break
    for k in range(n):  # leave the overlay at zero for the thread's next droplet: every entry, since
        # steps that changed the overlay can sum to an entry of 0 (a step into a halo does not lower it)
        j_lo, j_hi, i_lo, i_hi = box(lc[k], m, nx, ny)
        for j in range(j_lo, j_hi):
            for i in range(i_lo, i_hi):
                ov[j * nx + i] = 0.0
    bd[B_STEPS] += steps
    bd[B_EVAP] += evap
    bd[B_ERODED] += eroded
    bd[B_DEPOSITED] += deposited
    return status, x, y, vx, vy, V, S, n, steps


@njit(cache=True, inline="always")
def _descend_one(i, t, base, z2, zf, sf, rf, ef, lake_of, level, rain_cdf, P, res, lc, ldz, bd, ov):
    """Slot ``i``'s descent of this round (if its row says it has one) on overlay row ``t``; a NEW
    droplet spawns at the point of its index in the run (``R_INDEX``)."""
    ny, nx = z2.shape
    for k in range(B_SIZE):
        bd[i, k] = 0.0
    st0 = int(res[i, R_STATUS])
    res[i, R_NLOG] = 0.0
    if st0 != NEW and st0 != PAUSED and st0 != NEXT:
        return
    if st0 == NEW:
        x, y = spawn_point(base, int(res[i, R_INDEX]), rain_cdf, nx, ny)
        vx, vy, V, S, used = 0.0, 0.0, P[P_V0], 0.0, 0
    else:
        x, y, vx, vy = res[i, R_X], res[i, R_Y], res[i, R_VX], res[i, R_VY]
        V, S, used = res[i, R_V], res[i, R_S], int(res[i, R_USED]) if st0 == PAUSED else 0
    st, x, y, vx, vy, V, S, n, steps = descend_logged(
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
    res[i, R_USED] = used + steps


@njit(cache=True, parallel=True)
def descend_batch(count, seed, z2, stream, roots, erod, lake_of, level, rain_cdf, P, res, lc, ldz, bd, ov):
    """Phase 1 of a round: the droplets of slots 0 … ``count − 1`` whose row says NEW (spawn
    first), PAUSED or NEXT descend in parallel (:func:`descend_logged`); results back in
    ``res[i]``, logs in ``lc[i]``, ``ldz[i]``, budget terms in ``bd[i]`` (all rows cleared here).
    ``ov``: one zeroed overlay row (map size) per Numba thread. The slots are taken one at a time by
    as many lanes as threads (:func:`erosim.kernels.work_queue.take`): droplets differ in length, and a
    fixed share per thread left one waiting for the other; a droplet's result does not depend on its
    lane (the lane's overlay row is zero on entry and on return)."""
    zf = z2.reshape(-1)
    sf = stream.reshape(-1)
    rf = roots.reshape(-1)
    ef = erod.reshape(-1)
    base = spawn_base(seed)
    lanes = max(min(ov.shape[0], count), 1)  # one per overlay row, that is per thread
    counter = np.zeros(1, np.int64)
    for t in prange(lanes):  # each lane takes the next slot until none is left (dynamic, any layer)
        while True:
            i = take(counter)
            if i >= count:
                break
            _descend_one(i, t, base, z2, zf, sf, rf, ef, lake_of, level, rain_cdf, P, res, lc, ldz, bd, ov)


@njit(cache=True)
def descend_batch_serial(count, seed, z2, stream, roots, erod, lake_of, level, rain_cdf, P, res, lc, ldz, bd, ov):
    """:func:`descend_batch` on the calling thread (overlay row 0), for a round with only a few
    droplets left to descend: the same results, without waking the other threads and waiting for
    the slowest at the round's end (on a loaded machine that wait cost more than the work)."""
    zf = z2.reshape(-1)
    sf = stream.reshape(-1)
    rf = roots.reshape(-1)
    ef = erod.reshape(-1)
    base = spawn_base(seed)
    for i in range(count):
        _descend_one(i, 0, base, z2, zf, sf, rf, ef, lake_of, level, rain_cdf, P, res, lc, ldz, bd, ov)


@njit(cache=True, inline="always")
def _apply_rows(r0, r1, count, nx, ny, m, zf, lake_of, track, res, lc, ldz):
    """The logged changes of droplets 0 … count − 1, in droplet and step order, to the rows r0 … r1 − 1:
    each logged footprint's cells there are marked visited (HY-4) and, where dry, lowered by its dz."""
    for i in range(count):
        for k in range(int(res[i, R_NLOG])):
            j_lo, j_hi, i_lo, i_hi = box(lc[i, k], m, nx, ny)
            j_lo = max(j_lo, r0)
            j_hi = min(j_hi, r1)
            dz = ldz[i, k]
            for j in range(j_lo, j_hi):
                for ii in range(i_lo, i_hi):
                    c = j * nx + ii
                    track[c] = 1
                    if dz != 0.0 and lake_of[c] == NO_LAKE:
                        zf[c] -= dz


@njit(cache=True, parallel=True)
def apply_logs(count, nx, ny, m, zf, lake_of, track, res, lc, ldz, bd, B, bands):
    """Phase 2a: apply the logged height changes to the dry cells of each logged footprint, mark the
    footprints visited (HY-4) and add each droplet's budget rows. In parallel over ``bands`` bands of rows
    (one per thread; :func:`_apply_rows`): each band applies its cells' changes in droplet and step order, so every cell
    gets the same sequence of subtractions as in one serial pass and the heights are the same for any thread
    count (bit for bit)."""
    bands = max(min(bands, ny), 1)
    for b in prange(bands):
        _apply_rows(b * ny // bands, (b + 1) * ny // bands, count, nx, ny, m, zf, lake_of, track, res, lc, ldz)
    for i in range(count):
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
