"""Batch-synchronous descent (HY-1 on several threads), an opt-in alternative to the seed's order.

In the seed every droplet sees the terrain the previous one left. With ``hydrology.batch = N``
the droplets of a cycle run in batches of N: within a batch every droplet descends (in parallel,
Numba ``prange``) against the terrain, streams and lakes **as they were at the batch start** and
logs its changes — for each step the cell and the height it removes (negative: adds), and its
budget terms — instead of writing them; then, serially and in droplet order, the logs are
applied and each droplet that stopped floods (HY-2) and goes on as in the serial loop (drains,
further descents, settling). This is how droplet erosion is usually made parallel on GPUs; it
changes the model only in that droplets of one batch do not see each other's erosion, nor their
own (a droplet samples the batch-start terrain on its whole first descent).

Determinism: a droplet's first descent depends only on the batch-start state and its index, and
everything is applied in droplet order, so the result is the same for any thread count (and for
a given seed, input and batch size). Budgets close as in the serial loop: every logged change is
applied exactly once and counted in the same droplet's budget row. A droplet whose log fills up
(``LOG`` steps) is paused and finishes its descent in the serial phase.

Only the seed's case (footprint one cell, whole time steps) has a logged kernel; other settings
are refused by :func:`check`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from erosim.core.errors import ConfigError
from erosim.hydrology.counter_rng import spawn_base, spawn_point
from erosim.hydrology.droplets import ENDED, LEFT, STOP, _corners
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
    P_MAXSTEPS,
    P_PIT,
    P_ROOT,
    P_SEA,
    P_V0,
    P_VMIN,
)
from erosim.hydrology.pools import (
    B_CARRIED,
    B_DEPOSITED,
    B_ERODED,
    B_EVAP,
    B_LEFT,
    B_SIZE,
    B_STEPS,
    NO_LAKE,
    OUTSIDE,
    walk_down,
)

PAUSED = 3  # the droplet's log is full: it goes on descending in the serial phase
LOG = 2048  # logged steps per droplet and first descent

# columns of the per-droplet result rows
R_STATUS, R_X, R_Y, R_VX, R_VY, R_V, R_S, R_NLOG = range(8)
R_SIZE = 8


def check(params, foot: int) -> None:
    """Refuse batch mode where no logged kernel exists (footprint > 1 cell or sub-steps)."""
    if params.batch > 0 and (foot != 1 or params.max_step > 0):
        raise ConfigError(
            "hydrology.batch works with a one-cell droplet footprint and whole time steps only; "
            "set hydrology.length_scale = 0 (or equal to the cell size) and hydrology.max_step = "
            "0, or set hydrology.batch = 0."
        )


@njit(cache=True, error_model="numpy")
def descend_logged(x, y, vx, vy, V, S, z2, zf, stream, roots, erod, lake_of, level, lc, ldz, bd, P):
    """:func:`erosim.hydrology.droplets.descend_cell` against a frozen terrain: instead of
    writing, step k logs its cell ``lc[k]`` and the height it removes ``ldz[k]``; budget terms go
    to the droplet's row ``bd``. Returns (status, x, y, vx, vy, V, S, steps logged)."""
    ny, nx = z2.shape
    dt = P[P_DT]
    vmin = P[P_VMIN]
    sea = P[P_SEA]
    cap = P[P_CAP]
    root = P[P_ROOT]
    pit = P[P_PIT]
    kd = P[P_KD]
    nwalk = 2 * int(P[P_FOOT]) + 1
    maxsteps = int(P[P_MAXSTEPS])
    inv_dx = 1.0 / P[P_DX]
    inv_ca = 1.0 / P[P_CA]
    inv_v0 = 1.0 / P[P_V0]
    dtx = dt * inv_dx
    acc_k = dt * P[P_ACC] / P[P_DENS]
    amin2 = (P[P_AMIN] * dt) ** 2
    fric_dt = dt * P[P_FRIC]
    evap_dt = dt * P[P_EVAP]
    cap_log = lc.shape[0]
    steps = 0
    evap = 0.0
    eroded = 0.0
    deposited = 0.0
    status = PAUSED
    i0, j0, fx, fy, z1, zz2, z3, z4 = _corners(z2, x, y)
    top = z1 + fx * (zz2 - z1)
    h = top + fy * (z4 + fx * (z3 - z4) - top)
    gx = ((1.0 - fy) * inv_dx) * (zz2 - z1) + (fy * inv_dx) * (z3 - z4)
    gy = ((1.0 - fx) * inv_dx) * (z4 - z1) + (fx * inv_dx) * (z3 - zz2)
    while steps < cap_log:
        c = int(y + 0.5) * nx + int(x + 0.5)
        s = stream[c]
        vrel = V * inv_v0
        kv = acc_k / vrel
        f = kv / math.sqrt(1.0 + gx * gx + gy * gy)
        dvx = -gx * f
        dvy = -gy * f
        vx += dvx
        vy += dvy
        x0 = x
        y0 = y
        x += dtx * vx
        y += dtx * vy
        damp = 1.0 - fric_dt * (1.0 - 0.5 * s)
        vx *= damp
        vy *= damp
        lc[steps] = c
        ldz[steps] = 0.0
        steps += 1
        if x < -0.5 or y < -0.5 or x >= nx - 0.5 or y >= ny - 0.5:
            bd[B_LEFT] += V
            bd[B_CARRIED] += S
            x, y, V, S = x0, y0, 0.0, 0.0
            status = LEFT
            break
        cn = int(y + 0.5) * nx + int(x + 0.5)
        if zf[cn] < sea or lake_of[cn] == OUTSIDE:
            bd[B_LEFT] += V
            bd[B_CARRIED] += S
            V, S = 0.0, 0.0
            status = LEFT
            break
        if (stream[cn] > 0.5 and dvx * dvx + dvy * dvy < amin2) or lake_of[cn] >= 0:
            status = STOP
            break
        speed = math.sqrt(vx * vx + vy * vy)
        if speed * dt < pit:
            wc, at_min = walk_down(cn, nwalk, zf, lake_of, level, sea, nx, ny)
            if at_min:
                x = float(wc % nx)
                y = float(wc // nx)
                status = STOP
                break
        i0, j0, fx, fy, z1, zz2, z3, z4 = _corners(z2, x, y)
        top = z1 + fx * (zz2 - z1)
        h1 = top + fy * (z4 + fx * (z3 - z4) - top)
        gx = ((1.0 - fy) * inv_dx) * (zz2 - z1) + (fy * inv_dx) * (z3 - z4)
        gy = ((1.0 - fx) * inv_dx) * (z4 - z1) + (fx * inv_dx) * (z3 - zz2)
        kh = kd * max(1.0 - root * roots[c], 0.0)
        khe = kh * erod[c]
        ceq = (cap * vrel * speed) * max(h - h1, 0.0)
        diff = ceq - S
        amt = (khe if diff > 0.0 else kh) * diff
        if lake_of[c] == NO_LAKE:  # lake cells are never eroded or filled by descent
            ldz[steps - 1] = amt * inv_ca
            eroded += max(amt, 0.0)
            deposited += max(-amt, 0.0)
            S += amt
        h = h1
        vn = V * (1.0 - evap_dt * (1.0 - 0.2 * s))
        evap += V - vn
        V = vn
        if V < vmin or steps >= maxsteps:
            status = ENDED
            break
    bd[B_STEPS] += steps
    bd[B_EVAP] += evap
    bd[B_ERODED] += eroded
    bd[B_DEPOSITED] += deposited
    return status, x, y, vx, vy, V, S, steps


@njit(cache=True, parallel=True)
def descend_batch(first, count, seed, z2, stream, roots, erod, lake_of, level, rain_cdf, P, res,
                  lc, ldz, bd):  # fmt: skip
    """Phase 1: droplets ``first`` … ``first + count − 1`` spawn and descend in parallel against
    the current (frozen) state; results in ``res[i]``, logs in ``lc[i]``, ``ldz[i]``, budget
    terms in ``bd[i]`` (all rows cleared here)."""
    ny, nx = z2.shape
    zf = z2.reshape(-1)
    sf = stream.reshape(-1)
    rf = roots.reshape(-1)
    ef = erod.reshape(-1)
    base = spawn_base(seed)
    for i in prange(count):
        for k in range(B_SIZE):
            bd[i, k] = 0.0
        x, y = spawn_point(base, first + i, rain_cdf, nx, ny)
        st, x, y, vx, vy, V, S, n = descend_logged(
            x, y, 0.0, 0.0, P[P_V0], 0.0, z2, zf, sf, rf, ef, lake_of, level, lc[i], ldz[i], bd[i], P
        )
        res[i, R_STATUS] = st
        res[i, R_X] = x
        res[i, R_Y] = y
        res[i, R_VX] = vx
        res[i, R_VY] = vy
        res[i, R_V] = V
        res[i, R_S] = S
        res[i, R_NLOG] = n


@njit(cache=True)
def apply_logs(count, zf, track, res, lc, ldz, bd, B):
    """Phase 2a, serial in droplet order: apply the logged height changes, mark the visited
    cells (HY-4) and add each droplet's budget row."""
    for i in range(count):
        for k in range(int(res[i, R_NLOG])):
            c = lc[i, k]
            zf[c] -= ldz[i, k]
            track[c] = 1
        for k in range(B_SIZE):
            B[k] += bd[i, k]


def work_arrays(batch: int, log: int = LOG) -> tuple[np.ndarray, ...]:
    """(res, lc, ldz, bd) for batches of ``batch`` droplets logging up to ``log`` steps each."""
    return (
        np.zeros((batch, R_SIZE)),
        np.zeros((batch, log), np.int64),
        np.zeros((batch, log)),
        np.zeros((batch, B_SIZE)),
    )


__all__ = ["LOG", "PAUSED", "apply_logs", "check", "descend_batch", "work_arrays"]
