"""HY-1 descend: a water droplet runs downhill, erodes and deposits (SimpleHydrology 2020).

One step of duration dt (the seed's, split into n sub-steps of h = dt/n so that a droplet never
moves more than ``max_step`` cells — at a finer grid it then sees every cell it crosses):

    n_h  = −∇z / √(1 + |∇z|²)                        horizontal part of the unit normal
    a    = (ℓ/s²) · n_h / (V/V₀ · ρ)                  (seed: acc = n.xz / (volume·density))
    v   += h·a ;  x += h·v ;  v *= 1 − h·f_eff,       f_eff = friction·(1 − 0.5·stream)
    c_eq = cap·ℓ·(V/V₀)·|v|·max(0, Δz·dt/h)           capacity; Δz the drop over the sub-step
    ΔS   = (h/dt)·k_d·max(0, 1 − ρ_r)·(c_eq − S)          × erodibility where ΔS > 0 (erosion)
    z   −= ΔS spread over the ℓ×ℓ footprint of the old position; S += ΔS
    V   *= 1 − h·e_eff,                               e_eff = evaporation·(1 − 0.2·stream)

The droplet ends when V < V_min, or leaves the world (map edge, sea, a nodata cell of the DEM: its
water and sediment leave),
or stops for HY-2 flood: it enters a lake, or it is in a strong stream (> 0.5) with |a| below
0.01 ℓ/s², or (``pit_flood``, an erosim addition) a steepest-descent walk of at most 2·ℓ/Δx + 1
cells from its cell reaches a local minimum whose rim its kinetic energy cannot lift it over,
½|v|² < g·(rim − h) with g = ℓ/(s²·ρ·V/V₀) (:func:`erosim.hydrology.droplet_step.trapped`): it
floods at that minimum (instead of oscillating in the depression until it evaporates). A droplet
fast enough to cross a pit crosses it: stopping every droplet that reached a local minimum (the
rule before, a move of less than ℓ/2 a sub-step, held for nearly every sub-step) ended rivers in
the plains' shallow hollows (issue 36; docs/hydrology.md, "Pits that a droplet can cross").
Every visited cell's footprint is marked in ``track`` (HY-4). Lake cells are never
eroded or filled by descent (their water level bookkeeping stays exact, see ``pools``).

Sediment is kept as an amount (m³) — the seed's ``sediment /= (1 − dt·evap)`` rescaling is left
out so that the sediment budget closes. Written as a Numba kernel because the droplet loop is
sequential and per-point (no library does it). Two serial loops, chosen in Python
(:func:`descend_variant`): :func:`descend` (any footprint, sub-steps) repeats the one sub-step
that the parallel batches and the GPU also call (:func:`erosim.hydrology.droplet_step.step`);
:func:`descend_cell` (the seed's case: one-cell footprint, whole steps — the
``simplehydrology-2020`` preset) is the same model written for the short step-to-step dependency
chain that bounds this loop's speed (~60 ns a step on the 2-core machine against ~80 ns for the
general loop in the same case) and agrees with it to rounding (tested); it is the one place the
step is written a second time, kept so that the preset's results and speed stay as they were.
"""

from __future__ import annotations

import math

from numba import njit

from erosim.hydrology.droplet_step import ENDED, LEFT, STALL, STOP, box, constants, lower, origin, pit_trap, step
from erosim.hydrology.loop_kernel import loop_kernel
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
from erosim.hydrology.pools import B_CARRIED, B_DEPOSITED, B_ERODED, B_EVAP, B_LEFT, B_STEPS, NO_LAKE, OUTSIDE


@njit(cache=True, inline="always")
def _settle_budget(B, steps, evap, eroded, deposited):
    """Add a finished descent's totals to the budget array (steps, evaporation, sediment moved)."""
    B[B_STEPS] += steps
    B[B_EVAP] += evap
    B[B_ERODED] += eroded
    B[B_DEPOSITED] += deposited


@njit(inline="always")
def mark(track, nx, ny, x, y, m):
    """track = 1 on the m×m footprint at (x, y) (HY-4: the cells a droplet visited)."""
    j_lo, j_hi, i_lo, i_hi = box(origin(x, y, m), m, nx, ny)
    for j in range(j_lo, j_hi):
        for i in range(i_lo, i_hi):
            track[j * nx + i] = 1


@loop_kernel
def descend(x, y, vx, vy, V, S, z2, zf, stream, roots, erod, lake_of, level, track, B, P):
    """Run one droplet until it ends, leaves or stops (see module docstring): the shared sub-step
    (:func:`erosim.hydrology.droplet_step.step`) against the live terrain, its transfers applied
    at once, each visited footprint marked in ``track``.

    Returns (status, x, y, vx, vy, V, S) with positions in cell units and V, S in m³.
    """
    ny, nx = z2.shape
    K = constants(P)
    m = int(P[P_FOOT])
    maxsteps = int(P[P_MAXSTEPS])
    no_ov = zf[:1]  # the serial loop writes the terrain itself: no overlay
    steps = 0
    evap = 0.0  # evaporated volume, added to the budget on exit
    eroded = 0.0
    deposited = 0.0
    speed = math.sqrt(vx * vx + vy * vy)
    while True:
        mark(track, nx, ny, x, y, m)
        st, x, y, vx, vy, vn, S, speed, code, dz, moved = step(
            x, y, vx, vy, V, S, speed, z2, zf, no_ov, False, stream, roots, erod, lake_of, level, K
        )
        steps += 1
        if st == LEFT:
            B[B_LEFT] += V
            B[B_CARRIED] += S
            _settle_budget(B, steps, evap, eroded, deposited)
            return LEFT, x, y, vx, vy, 0.0, 0.0
        if st == STOP:
            _settle_budget(B, steps, evap, eroded, deposited)
            return STOP, x, y, vx, vy, V, S
        if moved != 0.0:
            lower(zf, lake_of, code, m, nx, ny, dz)
            if moved > 0.0:
                eroded += moved
            else:
                deposited -= moved
        evap += V - vn
        V = vn
        if st == ENDED or steps >= maxsteps:
            _settle_budget(B, steps, evap, eroded, deposited)
            return ENDED, x, y, vx, vy, V, S


@njit(cache=True, inline="always")
def _corners(z, x, y):
    """Cell of the Q4 interpolant at (x, y) (clamped to the map): (i0, j0, fx, fy) and its four
    corner heights z1 = z[j0, i0], z2 = z[j0, i0+1], z3 = z[j0+1, i0+1], z4 = z[j0+1, i0]."""
    ny, nx = z.shape
    xc = min(max(x, 0.0), nx - 1.0)
    yc = min(max(y, 0.0), ny - 1.0)
    i0 = min(int(xc), nx - 2)
    j0 = min(int(yc), ny - 2)
    return i0, j0, xc - i0, yc - j0, z[j0, i0], z[j0, i0 + 1], z[j0 + 1, i0 + 1], z[j0 + 1, i0]


@njit(cache=True, error_model="numpy")
def descend_cell(x, y, vx, vy, V, S, z2, zf, stream, roots, erod, lake_of, level, track, B, P):
    """:func:`descend` for the seed's case — footprint one cell (ℓ = Δx) and whole time steps
    (``max_step`` 0) — chosen in Python by :func:`descend_variant`: the seed preset's hot loop.

    The same model written for a short dependency chain from one step to the next (the loop is
    latency bound): the terrain at the new position is sampled once, before the mass transfer,
    and the transfer's change of one corner is added to that sample's height and gradient (the
    Q4 interpolant is linear in its corner values) instead of sampling again after the store;
    erosion and deposition are selected without branches; no division besides the acceleration's.
    Results agree with :func:`descend` to rounding (the order of floating-point operations
    differs), deterministically.
    """
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
    dtx = dt * inv_dx  # s/m: cell units per (m/s) over one step
    acc_k = dt * P[P_ACC] / P[P_DENS]  # Δv = −∇z · acc_k / (V/V₀ · √(1+|∇z|²)), ∇z in m/m
    amin2 = (P[P_AMIN] * dt) ** 2  # the stop test on |Δv|² = dt²·|a|²
    fric_dt = dt * P[P_FRIC]
    evap_dt = dt * P[P_EVAP]
    steps = 0
    evap = 0.0  # evaporated volume, added to the budget on exit
    eroded = 0.0
    deposited = 0.0
    i0, j0, fx, fy, z1, zz2, z3, z4 = _corners(z2, x, y)
    top = z1 + fx * (zz2 - z1)
    h = top + fy * (z4 + fx * (z3 - z4) - top)
    gx = ((1.0 - fy) * inv_dx) * (zz2 - z1) + (fy * inv_dx) * (z3 - z4)  # slope (m/m)
    gy = ((1.0 - fx) * inv_dx) * (z4 - z1) + (fx * inv_dx) * (z3 - zz2)
    while True:
        ix = int(x + 0.5)
        iy = int(y + 0.5)
        c = iy * nx + ix
        track[c] = 1
        s = stream[c]
        vrel = V * inv_v0
        kv = acc_k / vrel  # off the step-to-step chain (V is known early)
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
        steps += 1
        if x < -0.5 or y < -0.5 or x >= nx - 0.5 or y >= ny - 0.5:
            B[B_LEFT] += V
            B[B_CARRIED] += S
            _settle_budget(B, steps, evap, eroded, deposited)
            return LEFT, x0, y0, vx, vy, 0.0, 0.0
        cn = int(y + 0.5) * nx + int(x + 0.5)
        if zf[cn] < sea or lake_of[cn] == OUTSIDE:
            B[B_LEFT] += V
            B[B_CARRIED] += S
            _settle_budget(B, steps, evap, eroded, deposited)
            return LEFT, x, y, vx, vy, 0.0, 0.0
        if (stream[cn] > 0.5 and dvx * dvx + dvy * dvy < amin2) or lake_of[cn] >= 0:
            _settle_budget(B, steps, evap, eroded, deposited)
            return STOP, x, y, vx, vy, V, S
        speed = math.sqrt(vx * vx + vy * vy)
        # the terrain at the new position, before the transfer
        i0, j0, fx, fy, z1, zz2, z3, z4 = _corners(z2, x, y)
        top = z1 + fx * (zz2 - z1)
        h1 = top + fy * (z4 + fx * (z3 - z4) - top)
        if pit > 0.0:
            held, wc = pit_trap(cn, x, y, nwalk, speed, kv / dt, h1, STALL / dtx, zf, zf[:1], False, lake_of, level,
                                sea, nx, ny)  # fmt: skip
            if held:
                _settle_budget(B, steps, evap, eroded, deposited)
                return STOP, float(wc % nx), float(wc // nx), vx, vy, V, S
        wy0 = (1.0 - fy) * inv_dx
        wy1 = fy * inv_dx
        wx0 = (1.0 - fx) * inv_dx
        wx1 = fx * inv_dx
        gx = wy0 * (zz2 - z1) + wy1 * (z3 - z4)
        gy = wx0 * (z4 - z1) + wx1 * (z3 - zz2)
        # mass transfer at the old cell; erosion (diff > 0) is scaled by the erodibility
        kh = kd * max(1.0 - root * roots[c], 0.0)
        khe = kh * erod[c]
        ceq = (cap * vrel * speed) * max(h - h1, 0.0)
        diff = ceq - S
        amt = (khe if diff > 0.0 else kh) * diff
        if lake_of[c] == NO_LAKE:  # lake cells are never eroded or filled by descent
            dz = amt * inv_ca
            zf[c] -= dz
            eroded += max(amt, 0.0)
            deposited += max(-amt, 0.0)
            S += amt
            # the new sample moves with the changed corner (Q4 weights of that corner)
            di = ix - i0
            dj = iy - j0
            if di >= 0 and di <= 1 and dj >= 0 and dj <= 1:
                wx = fx if di == 1 else 1.0 - fx
                wy = fy if dj == 1 else 1.0 - fy
                h1 -= dz * (wx * wy)
                wys = wy1 if dj == 1 else wy0  # the same weights over Δx: slope change
                wxs = wx1 if di == 1 else wx0
                gx -= dz * (wys if di == 1 else -wys)
                gy -= dz * (wxs if dj == 1 else -wxs)
        h = h1
        vn = V * (1.0 - evap_dt * (1.0 - 0.2 * s))
        evap += V - vn
        V = vn
        if V < vmin or steps >= maxsteps:
            _settle_budget(B, steps, evap, eroded, deposited)
            return ENDED, x, y, vx, vy, V, S


def descend_variant(P):
    """The descend kernel for the constants ``P``: :func:`descend_cell` in the seed's case
    (footprint one cell, no sub-steps), else the general :func:`descend`."""
    if int(P[P_FOOT]) == 1 and P[P_MAXSTEP] <= 0.0:
        return descend_cell
    return descend
