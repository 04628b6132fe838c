"""Particle-stream erosion over a hardness map (K. Warszawski, seed 004; SPEC ST-1…ST-6).

A fast, non-physical, art-directable way to carve channels, gullies and canyons: particles leave an
emitter's window, travel over the map in 2-D, and every impact lowers the terrain around it, less
where the hardness map says the rock resists. The seed's equations (1)–(7) were images that did not
survive; the formulas below are the ones chosen here, each fixing what SPEC ST-2…ST-5 states.

Coordinates follow :mod:`erosim.kernels.raster`: ``x`` = column, ``y`` = row (row 0 = north), in
cell units; cell ``(i, j)`` sits at ``x = i, y = j``. Angles are in radians in these grid axes
(``α = 0`` → +x = east, ``α = −π/2`` → −y = north); the schema converts compass-style degrees.

ST-1 terrain: heights ``H`` (m) and hardness ``D ∈ [0, 1]`` (1 = unerodible, 0 = fully erodible),
both ``(ny, nx)``.

ST-2 emission. An emitter has a window centred at ``E`` with unit direction ``u = (cos α_e, sin
α_e)`` and its normal ``n = (−sin α_e, cos α_e)``; width ``w`` (across) and length ``ℓ`` (along),
cells::

    C₀ = E + (ξ₁ − ½) w n + (ξ₂ − ½) ℓ u,      α₀ = α_e + (2ξ₃ − 1) σ
    v  = v̄ (1 + (2ξ₄ − 1) j_v),               m  = m̄ (1 + (2ξ₅ − 1) j_m),     β₀ = β̄

with ξ_k ~ U(0, 1), spread σ, jitters j_v, j_m. A particle acts ``K`` times (impacts) and then
returns to the emitter's pool, from which the emitter re-emits it (a pool of ``P`` slots per
emitter, stepped round-robin, so ``P`` particles are in flight at once); it also returns early when
it leaves the map.

ST-3 motion (next position on a circle of radius ``v`` around the current one, at the direction
angle ``α_k``, which deviates from the particle's heading ``α`` by at most the admissible angle)::

    δ_max   = α_max · max(0, 1 − v / v_max),        α_k = α + (2ξ_k − 1) δ_max
    C_{k+1} = C_k + v (cos α_k, sin α_k)

so a slow particle may deviate up to ``α_max`` from its heading and one at ``v_max`` keeps its
course. The deviation does not accumulate (the heading itself only changes in collisions, ST-4), so
a stream wiggles but keeps its direction. Optional rotational motion: the particle turns around a
pivot shifted by ``ρ`` from its track, with rotational speed ``r`` (rad per step) and rotation angle
``β``::

    P_k = C_k + ρ (cos β_k, sin β_k),              β_{k+1} = β_k + r

(``ρ = 0`` gives the linear motion ``P_k = C_k``). Impacts happen at ``P_k``.

ST-4 collision (the direction turns toward the softest terrain within ±γ). ``2J + 1`` probe
directions ``θ_j = α + γ j / J`` (``j = −J…J``) are read one step ahead, ``Q_j = P_k + v (cos θ_j,
sin θ_j)``, with ``D(Q_j)`` bilinear (a probe off the map counts as harder than any rock, 2)::

    θ* = argmin_j D(Q_j)   (ties, within 10⁻⁹, → smallest |j|: a uniform map keeps the course),
    α  ← α + s (θ* − α),   steering s ∈ [0, 1].

ST-5 deformation. Radius of influence ``λ = κ m`` (cells); gradation at distance ``r`` from the
impact point ``P_k``::

    Δh(r) = e m (1 − r² / λ²)

largest (``e m``, metres) at the impact, falling with distance and negative beyond ``λ``; cells
where ``Δh ≤ 0`` are untouched. Each touched cell is lowered by the gradation scaled by its
erodibility::

    h ← h − Δh (1 − d)

so ``d = 1`` never changes and the terrain only goes down. The kernels add up the lowerings (m,
in ``acc[0]``); times the cell area that is the removed volume.

Graded bed (a choice made here, ``slope_exponent`` n > 0, the default; n = 0 is the seed's rule
above exactly). With the same gradation at every impact a stream cuts deepest where most particles
pass — at the emitter — and its floor climbs downstream over the original relief: a closed trough
that water could not have carved. So, as in a stream-power law, the gradation scales with the
ground's fall ahead, and no cell is cut below the ground at the footprint's edge ahead::

    F = h(P_k) − h(P_k + λ u_α),   Δh(r) = e m (F / (λ S₀))ⁿ (1 − r²/λ²),
    h ← max(h − Δh (1 − d), h(P_k) − F)

(``u_α`` the heading; ``F ≤ 0`` cuts nothing). Open outlet: where ``P_k + λ u_α`` is off the map or
nodata, the fall continues from behind, ``F = h(P_k − λ u_α) − h(P_k)`` with the floor bound
``h(P_k) − F`` as above; but where the impact stands on a lip above the floor behind
(``h(P_k) > h(B)``, ``B = P_k − λ u_α``), the lip is the fall, ``F = h(P_k) − h(B)``, and it is cut
down to ``h(B)``. Without that, a lip at the edge (the edge cells are reached by fewer impacts
than those upstream), once the channel upstream was cut below it, turned the fall negative and was
never cut: a closed outlet. The point read lies outside the footprint, so an impact shrinks the
fall it reads: sills are cut from their crests down, pits cannot form, and the floor grades to the
outlet (monotone on uniform rock; a hard band holds a knickpoint). A stream aimed up a slope, or
over level ground, has no fall and carves nothing.

Order of one step of a particle (it moves on the heightmap, so every step touches the surface and
is both a collision and an impact): impact point ``P_k`` (off the map → back to the pool),
collision turn of the heading (ST-4), deformation around ``P_k`` (ST-5), move to ``C_{k+1}``
(ST-3).

Strata that follow the cut (:func:`advance` with strata): with hardness given by layered strata
(:mod:`erosim.terrain.hardness`), a cell's hardness is that of the band its *current* height lies
in, ``d = D_b`` with ``b`` the band of ``q = (h + t_x i + t_y j − z₀) mod T`` (bands of thicknesses
``t_b`` from ``z₀`` repeating with period ``T = Σ t_b``, tilt ``t_x, t_y`` in metres per cell), and
it is re-read whenever a lowering takes a cell below its stratum's floor, so a canyon meets hard
and soft layers as it deepens.

ST-6 cost: per impact a fixed ``2J + 1`` probes and ``≈ π λ²`` cells, so the work is O(n) in the
number of particles.

Why hand-written Numba: the stream is inherently sequential — each impact reads the terrain the
earlier ones cut (strata hardness too) — and is made of tiny per-particle operations that no array
library expresses; a jitted loop runs millions of impacts per second. It runs on one thread on
purpose: the result then depends only on the seed, never on the thread count. Random numbers are
counter-based (SplitMix64 of seed, emitter, particle serial and draw number), so a checkpoint needs
no generator state and a resumed run reproduces the uninterrupted one exactly. ``gpu =``
:class:`erosim.erosion.particle_stream_cuda.DeviceStream` (given by the caller: that module builds on
this one) runs the sweeps on a GPU with these same per-impact functions, the slots of a sweep at once
(not repeatable bit for bit there).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError, InputError
from erosim.kernels.raster import bilinear
from erosim.terrain.hardness import Strata, check_hardness

# Columns of the emitter table (float64, one row per emitter; all lengths in cells, angles in rad).
EX, EY, EDIR, EWIDTH, ELENGTH, ESPREAD = 0, 1, 2, 3, 4, 5
ESPEED, EVJIT, EVMAX, EAMAX, EGAMMA, EPROBES, ESTEER = 6, 7, 8, 9, 10, 11, 12
EMASS, EMJIT, EDEPTH, ERADIUS, ERHO, EROT, EBETA, ESTEPS = 13, 14, 15, 16, 17, 18, 19, 20
ECOSD, ESIND = 21, 22  # cos and sin of the probe spacing Δ = γ/J
ESLOPE0, ESLOPEN = 23, 24  # stream-power slope: reference fall per cell S₀ (m) and exponent n
NCOL = 25

# hardness a probe off the map reads: harder than any rock, so streams keep to the map
OFF_MAP = 2.0
# probes softer by less than this are ties (bilinear round-off must not steer a uniform map)
TIE = 1e-9


# ------------------------------------------------------------------------------------ random
@njit(cache=True, inline="always")
def _mix(z):
    """SplitMix64 finaliser (Steele, Lea, Flood 2014) on a uint64."""
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@njit(cache=True, inline="always")
def _key(seed, emitter, serial):
    """Per-particle key from (seed, emitter, serial)."""
    z = _mix(np.uint64(seed) + np.uint64(0x9E3779B97F4A7C15))
    z = _mix(z ^ (np.uint64(emitter) * np.uint64(0xD1B54A32D192ED03)))
    return _mix(z ^ (np.uint64(serial) + np.uint64(0x632BE59BD9B4E019)))


@njit(cache=True, inline="always")
def _u01(key, draw):
    """Uniform in [0, 1) for draw number ``draw`` of a particle."""
    z = _mix(key + np.uint64(draw) * np.uint64(0x9E3779B97F4A7C15))
    return np.float64(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


# ----------------------------------------------------------------------------------- pieces
@njit(cache=True, inline="always")
def _emit(table, e, serial, seed, st, s):
    """ST-2: place slot ``s`` of emitter ``e`` as particle number ``serial`` (row ``st[s]``)."""
    key = _key(seed, e, serial)
    a = table[e, EDIR]
    ux = math.cos(a)
    uy = math.sin(a)
    across = (_u01(key, 0) - 0.5) * table[e, EWIDTH]
    along = (_u01(key, 1) - 0.5) * table[e, ELENGTH]
    st[s, 0] = table[e, EX] - uy * across + ux * along  # C_x
    st[s, 1] = table[e, EY] + ux * across + uy * along  # C_y
    st[s, 2] = a + (2.0 * _u01(key, 2) - 1.0) * table[e, ESPREAD]  # α
    st[s, 3] = table[e, ESPEED] * (1.0 + (2.0 * _u01(key, 3) - 1.0) * table[e, EVJIT])  # v
    st[s, 4] = table[e, EMASS] * (1.0 + (2.0 * _u01(key, 4) - 1.0) * table[e, EMJIT])  # m
    st[s, 5] = table[e, EBETA]  # β


@njit(cache=True, inline="always")
def _probe(d, x, y):
    """Hardness at (x, y) (bilinear), or OFF_MAP outside the map."""
    ny, nx = d.shape
    if x < 0.0 or y < 0.0 or x > nx - 1.0 or y > ny - 1.0:
        return OFF_MAP
    return bilinear(d, x, y)


@njit(cache=True, inline="always")
def _steer(d, px, py, alpha, v, cos_step, sin_step, nprobe, step, steer):
    """ST-4: turn α toward the softest of 2J+1 probes within ±γ (ties → the smallest turn).

    Probe directions α ± jΔ (Δ = γ/J = ``step``) are generated by rotating (cos α, sin α) by Δ
    (``cos_step``, ``sin_step``), so a collision costs two trigonometric calls, not 4J + 2.
    """
    c0 = math.cos(alpha)
    s0 = math.sin(alpha)
    best = _probe(d, px + v * c0, py + v * s0)
    best_t = 0.0
    cp, sp, cm, sm = c0, s0, c0, s0
    for j in range(1, nprobe + 1):
        cp, sp = cp * cos_step - sp * sin_step, sp * cos_step + cp * sin_step
        cm, sm = cm * cos_step + sm * sin_step, sm * cos_step - cm * sin_step
        dp = _probe(d, px + v * cp, py + v * sp)
        if dp < best - TIE:
            best = dp
            best_t = j * step
        dm = _probe(d, px + v * cm, py + v * sm)
        if dm < best - TIE:
            best = dm
            best_t = -j * step
    return alpha + steer * best_t


@njit(cache=True, inline="always")
def _rows(y0, lam, ny):
    """Rows j0 … j1 of the disc of radius λ around y0, clipped to the map."""
    return max(int(math.ceil(y0 - lam)), 0), min(int(math.floor(y0 + lam)), ny - 1)


@njit(cache=True, inline="always")
def _cols(x0, dy, lam2, nx):
    """Columns i0 … i1 of the disc's row at offset dy (half-chord √(λ² − dy²)), clipped to the map."""
    w = math.sqrt(max(lam2 - dy * dy, 0.0))
    return max(int(math.ceil(x0 - w)), 0), min(int(math.floor(x0 + w)), nx - 1)


@njit(cache=True, inline="always")
def _cut(hv, dv, g, depth, zmin):
    """ST-5 lowering of one cell of height ``hv``, hardness ``dv`` at gradation weight g = 1 − r²/λ² > 0:
    e·m·g·(1 − d), never below ``zmin`` (graded bed: nothing cut below the ground ahead)."""
    dh = depth * g * max(0.0, 1.0 - dv)  # nodata cells (OFF_MAP) are not cut
    return min(dh, max(0.0, hv - zmin))


@njit(cache=True, inline="always")
def _stamp(h, d, x0, y0, lam, depth, zmin):
    """ST-5: h ← h − e·m·(1 − r²/λ²)·(1 − d) where positive; returns the summed lowering (m)."""
    ny, nx = h.shape
    j0, j1 = _rows(y0, lam, ny)
    lam2 = lam * lam
    inv = 1.0 / lam2
    total = 0.0
    for j in range(j0, j1 + 1):
        dy = j - y0
        i0, i1 = _cols(x0, dy, lam2, nx)
        for i in range(i0, i1 + 1):
            dx = i - x0
            g = 1.0 - (dx * dx + dy * dy) * inv
            if g > 0.0:
                dh = _cut(h[j, i], d[j, i], g, depth, zmin)
                h[j, i] -= dh
                total += dh
    return total


@njit(cache=True, inline="always")
def _band(z, tx, ty, i, j, z0, edges, values, period, inv_period):
    """(hardness, floor) of the stratum holding height ``z`` at cell (i, j) (tilted, repeating
    bands); the cell stays in that stratum while its height is at least ``floor``."""
    q = z + tx * i + ty * j - z0
    q = q - period * math.floor(q * inv_period)
    b = 0
    for k in range(1, edges.size):
        if q >= edges[k]:
            b = k
    return values[b], z - (q - edges[b])


@njit(cache=True)
def strata_init(h, strata, edges, values, d, floor):
    """Fill ``d`` (hardness) and ``floor`` (height where a cell leaves its stratum) from ``h``."""
    ny, nx = h.shape
    for j in range(ny):
        for i in range(nx):
            d[j, i], floor[j, i] = _band(
                h[j, i], strata[0], strata[1], i, j, strata[2], edges, values, strata[3], strata[4]
            )


@njit(cache=True, inline="always")
def _stamp_strata(h, d, floor, x0, y0, lam, depth, zmin, strata, edges, values):
    """:func:`_stamp`, then each lowered cell takes the hardness of the band its new height is in
    (looked up only when the cell is cut below its stratum's ``floor``)."""
    ny, nx = h.shape
    j0, j1 = _rows(y0, lam, ny)
    lam2 = lam * lam
    inv = 1.0 / lam2
    tx, ty, z0, period, inv_period = strata[0], strata[1], strata[2], strata[3], strata[4]
    total = 0.0
    for j in range(j0, j1 + 1):
        dy = j - y0
        i0, i1 = _cols(x0, dy, lam2, nx)
        for i in range(i0, i1 + 1):
            dx = i - x0
            g = 1.0 - (dx * dx + dy * dy) * inv
            if g > 0.0:
                dh = _cut(h[j, i], d[j, i], g, depth, zmin)
                h[j, i] -= dh
                total += dh
                if h[j, i] < floor[j, i]:
                    d[j, i], floor[j, i] = _band(h[j, i], tx, ty, i, j, z0, edges, values, period, inv_period)
    return total


@njit(cache=True, inline="always")
def _act(h, d, table, e, st, s, key, age):
    """One impact of slot ``s``: position (rotation), bounds, collision, deviation, move.

    Returns the impact position and whether the particle is still on the map (x, y, ok).
    """
    cx, cy, alpha, v, beta = st[s, 0], st[s, 1], st[s, 2], st[s, 3], st[s, 5]
    rho = table[e, ERHO]
    px, py = cx, cy
    if rho > 0.0:
        px += rho * math.cos(beta)
        py += rho * math.sin(beta)
    ny, nx = h.shape
    if px < 0.0 or py < 0.0 or px > nx - 1.0 or py > ny - 1.0:
        return px, py, False
    if d[int(py + 0.5), int(px + 0.5)] >= OFF_MAP:  # a nodata cell: outside the map, the particle leaves
        return px, py, False
    nprobe = int(table[e, EPROBES])
    step = table[e, EGAMMA] / nprobe
    alpha = _steer(d, px, py, alpha, v, table[e, ECOSD], table[e, ESIND], nprobe, step, table[e, ESTEER])
    dmax = table[e, EAMAX] * max(0.0, 1.0 - v / table[e, EVMAX])
    ak = alpha + (2.0 * _u01(key, 8 + age) - 1.0) * dmax
    st[s, 0] = cx + v * math.cos(ak)
    st[s, 1] = cy + v * math.sin(ak)
    st[s, 2] = alpha
    st[s, 5] = beta + table[e, EROT]
    return px, py, True


@njit(cache=True, inline="always")
def _off(d, x, y):
    """Whether (x, y) is off the map or on a nodata cell (hardness OFF_MAP)."""
    ny, nx = d.shape
    if x < 0.0 or y < 0.0 or x > nx - 1.0 or y > ny - 1.0:
        return True
    return d[int(y + 0.5), int(x + 0.5)] >= OFF_MAP


@njit(cache=True, inline="always")
def _graded_depth(h, d, px, py, alpha, lam, depth, s0, n):
    """Graded bed: the gradation ``e m (S / S₀)ⁿ`` at the impact, with ``F`` the ground's fall
    from the impact point to the edge of its footprint straight ahead (distance λ; where that is off
    the map or nodata, the open outlet, see the module's docstring) and ``S = F / λ``;
    0 where the ground ahead is not lower. The point λ ahead lies outside the cut, so each impact
    shrinks the fall it reads and the bed grades towards its outlet. Returns (gradation e m (S/S₀)ⁿ,
    the lowest height a cell may be cut to, h(P) − F, or h(P − λu) on a lip at the outlet)."""
    ux = lam * math.cos(alpha)
    uy = lam * math.sin(alpha)
    qx, qy = px + ux, py + uy
    if _off(d, qx, qy):
        # open outlet: the fall continues from λ behind, F = h(B) − h(P), the floor running on
        # at that slope through the edge; but where the impact stands on a lip above the floor
        # behind (h(P) > h(B)), the lip is the fall and is cut down to h(B). Reading only
        # h(B) − h(P) let a lip at the edge, once the channel upstream was cut below it, turn the
        # fall negative and never be cut: a closed outlet.
        bx, by = px - ux, py - uy
        if _off(d, bx, by):
            return 0.0, 0.0
        hp = bilinear(h, px, py)
        hb = bilinear(h, bx, by)
        if hp > hb:
            return depth * ((hp - hb) / (lam * s0)) ** n, hb
        fall = hb - hp
    else:
        hp = bilinear(h, px, py)
        fall = hp - bilinear(h, qx, qy)
    if not fall > 0.0:  # no fall (or a NaN height): nothing to cut
        return 0.0, hp
    return depth * (fall / (lam * s0)) ** n, hp - fall


# ----------------------------------------------------------------------------------- drivers
#: :func:`advance`'s strata arguments (params, edges, hardness, floor) for a stream without strata
NO_STRATA = (np.zeros(5), np.zeros(1), np.zeros(1), np.zeros((0, 0)))


@njit(cache=True)
def advance(h, d, table, st, serial, age, emitted, total, acc, seed, rounds, strata, edges, values, floor):
    """Run ``rounds`` round-robin sweeps over all pool slots.

    ``st`` (slots, 6) holds C_x, C_y, α, v, m, β; ``serial[s]`` is the slot's particle number
    (−1 = idle), ``age[s]`` its impacts so far; ``emitted``/``total`` count per emitter.
    ``acc[0]`` accumulates the summed lowering (m) impact by impact, so the total does not depend on
    how the run is cut into calls. Returns (impacts done, rounds done before the stream ran dry).

    Hardness: a fixed map when ``floor`` is empty (size 0); else strata re-read from each lowered
    cell's new height, ``strata`` = (t_x, t_y, z₀, T, 1/T), ``edges`` the bands' lower bounds within a
    period (edges[0] = 0), ``values`` their hardness, ``floor`` each cell's stratum floor
    (:func:`strata_init`). Both cases take arrays of the same types, so Numba compiles this loop once
    (:data:`NO_STRATA` stands for "no strata").
    """
    nslot = st.shape[0]
    pool = nslot // table.shape[0]
    impacts = 0
    for r in range(rounds):
        busy = False
        for s in range(nslot):
            e = s // pool
            if serial[s] < 0:
                if emitted[e] >= total[e]:
                    continue
                serial[s] = emitted[e]
                emitted[e] += 1
                age[s] = 0
                _emit(table, e, serial[s], seed, st, s)
            busy = True
            key = _key(seed, e, serial[s])
            m = st[s, 4]
            px, py, ok = _act(h, d, table, e, st, s, key, age[s])
            if ok:
                lam, depth = table[e, ERADIUS] * m, table[e, EDEPTH] * m
                zmin = -math.inf
                if table[e, ESLOPEN] > 0.0:
                    depth, zmin = _graded_depth(
                        h, d, px, py, st[s, 2], lam, depth, table[e, ESLOPE0], table[e, ESLOPEN]
                    )
                if floor.size == 0:
                    acc[0] += _stamp(h, d, px, py, lam, depth, zmin)
                else:
                    acc[0] += _stamp_strata(h, d, floor, px, py, lam, depth, zmin, strata, edges, values)
                impacts += 1
                age[s] += 1
            if not ok or age[s] >= table[e, ESTEPS]:
                serial[s] = -1
        if not busy:
            return impacts, r
    return impacts, rounds


# ------------------------------------------------------------------------------------ Python side
class Emitter(Section):
    """One emitter (the scenario's ``[emitters.NAME]`` table); lengths in metres, angles in degrees.

    The scenario may give the horizontal lengths in cells instead (``stream.length_unit``); the
    runner converts them to metres before the physics sees them.

    ``x``, ``y`` place the window centre as fractions of the map width (from the west edge) and
    height (from the north edge); ``direction_deg`` is the heading, counter-clockwise from east (90
    = north).
    """

    x: float = param(0.05, unit="1", doc="window centre, fraction of the map width from the west edge")
    y: float = param(0.5, unit="1", doc="window centre, fraction of the map height from the north edge")
    direction_deg: float = param(0.0, unit="deg", doc="stream heading, counter-clockwise from east")
    width: float = param(20.0, ge=0, unit="m|cell", doc="window width across the stream (stream width)")
    length: float = param(0.0, ge=0, unit="m|cell", doc="window length along the stream")
    spread_deg: float = param(5.0, ge=0, le=180, unit="deg", doc="initial heading jitter ±")
    particles: int = param(10_000, ge=0, unit="1", doc="particles this emitter emits in total")
    steps: int = param(40, ge=1, unit="1", doc="impacts per particle before it returns to the pool")
    speed: float = param(2.0, gt=0, unit="m|cell per step", doc="mean speed v (radius of the motion circle)")
    speed_jitter: float = param(0.2, ge=0, lt=1, unit="1", doc="relative speed jitter ±")
    max_speed: float = param(4.0, gt=0, unit="m|cell per step", doc="v_max: at this speed the course never deviates")
    max_angle_deg: float = param(
        20.0, ge=0, le=180, unit="deg", doc="alpha_max: largest deviation from the heading (at v = 0)"
    )
    gamma_deg: float = param(30.0, ge=0, le=180, unit="deg", doc="gamma: collision looks for soft rock within ±gamma")
    probes: int = param(2, ge=1, le=32, unit="1", doc="probe directions each side of the heading (2J+1 in all)")
    steer: float = param(0.5, ge=0, le=1, unit="1", doc="share of the turn toward the softest probe per impact")
    mass: float = param(1.0, gt=0, unit="1", doc="mean particle mass (erosive strength)")
    mass_jitter: float = param(0.2, ge=0, lt=1, unit="1", doc="relative mass jitter ±")
    depth_per_mass: float = param(0.02, ge=0, unit="m", doc="e: lowering at the impact point per unit mass")
    radius_per_mass: float = param(4.0, gt=0, unit="m|cell", doc="kappa: radius of influence per unit mass")
    slope_exponent: float = param(
        1.0,
        ge=0,
        unit="1",
        doc="n: the lowering scales as (S / reference_slope)^n with S the ground's fall ahead, so a stream grades "
        "its bed to its outlet and digs no pits (0 = the seed's plain lowering)",
    )
    reference_slope: float = param(
        0.05, gt=0, unit="1", doc="S_0: the fall per unit length at which the lowering is e m"
    )
    pivot_offset: float = param(0.0, ge=0, unit="m|cell", doc="rho: rotational motion, pivot shift from the track")
    rotation_speed_deg: float = param(0.0, unit="deg/step", doc="r: rotational speed")
    rotation_angle_deg: float = param(0.0, unit="deg", doc="beta_0: initial rotation angle")


def emitter_table(emitters: list[Emitter] | dict[str, Emitter], shape: tuple[int, int], cell_size: float) -> np.ndarray:
    """The (E, NCOL) float64 table the kernels read; lengths converted to cells, angles to radians.

    Raises :class:`ConfigError` for an empty emission window (zero width or entirely off the map).
    """
    if not emitters:
        raise ConfigError("No emitter is defined; add an [emitters.NAME] table to the scenario.")
    ny, nx = shape
    t = np.zeros((len(emitters), NCOL))
    named = emitters if isinstance(emitters, dict) else {str(k): em for k, em in enumerate(emitters)}
    for k, (name, em) in enumerate(named.items()):
        if em.width <= 0:
            raise ConfigError(
                f"Emitter '{name}' has an empty emission window (width = 0); give it a width > 0 (the stream's width)."
            )
        if em.speed <= 0 or em.max_speed <= 0 or em.mass <= 0 or em.radius_per_mass <= 0:
            raise ConfigError(
                f"Emitter '{name}': speed, max_speed, mass and radius_per_mass must be positive; fix them."
            )
        cx, cy = em.x * (nx - 1), em.y * (ny - 1)
        a = -math.radians(em.direction_deg)  # compass-style (CCW from east, north up) → grid (y down)
        half = 0.5 * max(em.width, em.length) / cell_size + 0.5
        if cx + half < 0 or cy + half < 0 or cx - half > nx - 1 or cy - half > ny - 1:
            raise ConfigError(
                f"Emitter '{name}' has its window at x={em.x:g}, y={em.y:g} (map fractions), "
                "entirely off the map, so it would emit nothing; put x and y between 0 and 1."
            )
        t[k] = 0.0
        t[k, EX], t[k, EY], t[k, EDIR] = cx, cy, a
        t[k, EWIDTH], t[k, ELENGTH] = em.width / cell_size, em.length / cell_size
        t[k, ESPREAD] = math.radians(em.spread_deg)
        t[k, ESPEED], t[k, EVJIT], t[k, EVMAX] = (em.speed / cell_size, em.speed_jitter, em.max_speed / cell_size)
        t[k, EAMAX], t[k, EGAMMA] = math.radians(em.max_angle_deg), math.radians(em.gamma_deg)
        t[k, EPROBES], t[k, ESTEER] = max(int(em.probes), 1), em.steer
        t[k, EMASS], t[k, EMJIT] = em.mass, em.mass_jitter
        t[k, EDEPTH], t[k, ERADIUS] = em.depth_per_mass, em.radius_per_mass / cell_size
        t[k, ERHO], t[k, EROT] = em.pivot_offset / cell_size, -math.radians(em.rotation_speed_deg)
        t[k, EBETA] = -math.radians(em.rotation_angle_deg)
        t[k, ESTEPS] = em.steps
        t[k, ESLOPE0], t[k, ESLOPEN] = em.reference_slope * cell_size, em.slope_exponent
        t[k, ECOSD] = math.cos(t[k, EGAMMA] / t[k, EPROBES])
        t[k, ESIND] = math.sin(t[k, EGAMMA] / t[k, EPROBES])
    return t


def strata_arrays(strata: Strata, cell_size: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(params (t_x, t_y per cell, z₀, T, 1/T), band lower edges, band hardness) for
    :func:`advance` with strata."""
    th = np.asarray(strata.thickness, dtype=np.float64)
    edges = np.concatenate([[0.0], np.cumsum(th)[:-1]])
    period = float(th.sum())
    params = np.array([strata.tilt_x * cell_size, -strata.tilt_y * cell_size, strata.base, period, 1.0 / period])
    return params, edges, np.asarray(strata.hardness, dtype=np.float64)


class ParticleStream:
    """A stream (one or several emitters) eroding ``h`` in place over hardness ``d``.

    ``advance(rounds)`` runs that many round-robin sweeps (``rounds`` given at construction when
    omitted); ``done`` tells when every emitter has emitted all its particles and the last one has
    acted. As a model of :class:`~erosim.simulation.simulation.Simulation`, its ``time`` is the number
    of particles that have finished acting; ``state_dict()`` / ``load_state_dict()`` give and take
    everything needed to resume exactly. ``outside`` marks a DEM's nodata cells: outside the map, so
    a particle reaching one leaves, probes see them as the map's edge, and no cut lowers them.
    """

    name = "stream"

    def __init__(
        self,
        h: np.ndarray,
        d: np.ndarray,
        cell_size: float,
        emitters: list[Emitter] | dict[str, Emitter],
        seed: int,
        strata: Strata | None = None,
        pool: int = 64,
        rounds: int = 1,
        outside: np.ndarray | None = None,
        gpu=None,
    ):
        h = np.asarray(h)
        if h.ndim != 2:
            raise InputError(f"The heightmap must be 2-D, got shape {h.shape}.")
        self.h = np.ascontiguousarray(h, dtype=np.float64).copy()
        self.d = check_hardness(d, self.h.shape).copy()
        self.cell_size = float(cell_size)
        self.table = emitter_table(emitters, self.h.shape, self.cell_size)
        emitters = list(emitters.values()) if isinstance(emitters, dict) else list(emitters)
        if int(pool) < 1:
            raise ConfigError(f"The particle pool holds {pool} particles; set pool >= 1.")
        self.pool = int(pool)
        n = len(emitters) * self.pool
        self.st = np.zeros((n, 6))
        self.serial = np.full(n, -1, dtype=np.int64)
        self.age = np.zeros(n, dtype=np.int64)
        self.emitted = np.zeros(len(emitters), dtype=np.int64)
        self.total = np.array([int(em.particles) for em in emitters], dtype=np.int64)
        self.seed = int(seed) & 0xFFFFFFFFFFFFFFFF
        self.acc = np.zeros(1)  # acc[0]: summed lowering, m
        self.impacts = 0
        self.strata = strata
        if strata is not None:
            self._sp, self._se, self._sv = strata_arrays(strata, self.cell_size)
            # strata hardness is a function of height: recompute it here (same arithmetic as the
            # cuts use) together with each cell's stratum floor
            self.floor = np.empty_like(self.h)
            strata_init(self.h, self._sp, self._se, self._sv, self.d, self.floor)
        if outside is not None:  # nodata cells of the DEM: outside the map, probed and left as its edge
            self.d[np.asarray(outside, dtype=bool)] = OFF_MAP
        self.finished = False
        self.rounds = max(1, int(rounds))
        self.device = "cpu" if gpu is None else "cuda"
        self._gpu = None if gpu is None else gpu(self)  # sweeps on the GPU, state kept there

    @property
    def particles_total(self) -> int:
        return int(self.total.sum())

    @property
    def particles_emitted(self) -> int:
        return int(self.emitted.sum())

    @property
    def done(self) -> bool:
        return self.finished

    @property
    def time(self) -> float:
        """Particles that have finished acting (emitted and no longer in flight)."""
        if self.finished:
            return float(self.particles_total)
        return float(self.particles_emitted - int((self.serial >= 0).sum()))

    def advance(self, rounds: int | None = None) -> int:
        """Run ``rounds`` sweeps (each slot acts once per sweep); returns the impacts done."""
        rounds = self.rounds if rounds is None else rounds
        if self._gpu is not None:
            impacts, dry = self._gpu.advance(rounds)
            self._gpu.sync()  # the host arrays (maps, checkpoints, callbacks) stay current
            self.impacts += impacts
            self.finished = dry
            return impacts
        args = (
            self.h,
            self.d,
            self.table,
            self.st,
            self.serial,
            self.age,
            self.emitted,
            self.total,
            self.acc,
            np.uint64(self.seed),
            int(rounds),
        )
        if self.strata is None:
            impacts, did = advance(*args, *NO_STRATA)
        else:
            impacts, did = advance(*args, self._sp, self._se, self._sv, self.floor)
        self.impacts += impacts
        if did < rounds:
            self.finished = True
        return impacts

    def run(self, batch: int = 1000) -> ParticleStream:
        """Advance until done."""
        while not self.finished:
            self.advance(batch)
        return self

    @property
    def removed(self) -> float:
        """Summed lowering over all cells (m)."""
        return float(self.acc[0])

    def removed_volume(self) -> float:
        """Removed volume (m³) counted by the kernel: summed lowering × cell area."""
        return self.removed * self.cell_size**2

    def state_dict(self) -> dict[str, np.ndarray]:
        """Everything the next sweep reads (for checkpoints)."""
        out = {
            "h": self.h,
            "d": self.d,
            "st": self.st,
            "serial": self.serial,
            "age": self.age,
            "emitted": self.emitted,
            "acc": self.acc,
            "impacts": np.int64(self.impacts),
            "finished": np.bool_(self.finished),
        }
        if self.strata is not None:
            out["floor"] = self.floor
        return out

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore what :meth:`state_dict` gave (same emitters, map size and seed)."""
        names = ("h", "d", "st", "serial", "age", "emitted", "acc")
        if self.strata is not None:
            names += ("floor",)
        for name in names:
            if name not in state:
                raise InputError(f"The checkpoint lacks '{name}'; resume with the scenario the run was started with.")
            cur = getattr(self, name)
            new = np.ascontiguousarray(state[name], dtype=cur.dtype)
            if new.shape != cur.shape:
                raise InputError(
                    f"Checkpoint array '{name}' has shape {new.shape}, expected {cur.shape}; "
                    "resume with the scenario the run was started with."
                )
            cur[...] = new  # in place: callbacks hold these arrays
        self.impacts = int(state["impacts"])
        # a resumed run may ask for more particles (--set emitters.NAME.particles=...): it is only
        # finished if every emitter has emitted its (possibly new) total
        self.finished = bool(state["finished"]) and self.particles_emitted >= self.particles_total
        if self._gpu is not None:
            self._gpu.push()


def erode(
    h: np.ndarray,
    d: np.ndarray,
    cell_size: float,
    emitters: list[Emitter],
    seed: int = 0,
    strata: Strata | None = None,
    pool: int = 64,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Run a stream to the end; returns (new heights, final hardness, removed volume m³).

    The inputs are not changed."""
    s = ParticleStream(h, d, cell_size, emitters, seed, strata, pool).run()
    return s.h, s.d, s.removed_volume()
