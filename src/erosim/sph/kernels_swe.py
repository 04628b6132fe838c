"""Numba kernels of the shallow-water SPH solver (erosim.sph.shallow_water_vacondio2012).

The per-particle functions (``*_particle``, ``cfl_scale``) are inlined into the
loops here and into the GPU kernels of :mod:`erosim.sph.kernels_swe_cuda`, which call them too; they
and ``bed_c1`` are not cached on their own (numba-cuda would look for a GPU to key the cache).
``bed_c1`` is called, not inlined: inlined into a parallel loop, its tuples of weights trip Numba's
array analysis.

Why hand-written: the variable-smoothing-length depth (a Newton iteration per particle), the
variational momentum equation with its Ω correction terms, the per-cell wall reflections and the
particle splitting have no library implementation; each pass is one parallel loop over particles
gathering from their neighbours, so the result does not depend on the thread count.

Conventions: positions are metres in the DEM's *cell frame* — x = column·Δ, y = row·Δ (rows grow
southward, a mirror image of the map that the equations do not notice), so node (row, col) of the
DEM sits at (col·Δ, row·Δ). The kernel is Wendland C2 in 2-D with support radius H (zero for
r ≥ H); ∇_i W_ij = f(r, H)·(x_i − x_j). For W = H⁻² g(r/H), ∂W/∂H = −(2W + f r²)/H.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from erosim.kernels.friction_manning import manning_divisor
from erosim.kernels.sph_kernels import wendland_f_2d, wendland_w_2d


@njit(inline="always")
def dw_dh(r, h):
    """∂W/∂H of the 2-D Wendland C2 kernel: −(2W + f r²)/H."""
    return -(2.0 * wendland_w_2d(r, h) + wendland_f_2d(r, h) * r * r) / h


# ---------------------------------------------------------------- the bed, C¹


@njit(inline="always")
def _cr_weights(t):
    """Catmull-Rom weights of nodes −1, 0, 1, 2 at t ∈ [0, 1] and their derivatives."""
    t2 = t * t
    t3 = t2 * t
    w = (0.5 * (-t3 + 2 * t2 - t), 0.5 * (3 * t3 - 5 * t2 + 2), 0.5 * (-3 * t3 + 4 * t2 + t), 0.5 * (t3 - t2))
    dw = (0.5 * (-3 * t2 + 4 * t - 1), 0.5 * (9 * t2 - 10 * t), 0.5 * (-9 * t2 + 8 * t + 1), 0.5 * (3 * t2 - 2 * t))
    return w, dw


@njit
def bed_c1(z, x, y):
    """(b, ∂b/∂x, ∂b/∂y) at (x, y) in cell units: Catmull-Rom bicubic interpolation of the DEM's nodes.

    The water comes to rest where the bed force −g∇b balances the depth gradient; with the Q4
    surface ∇b jumps at every cell edge, so a particle resting on an edge chatters across it and a
    lake never settles below a speed of about g·Δslope·Δt. The Catmull-Rom surface passes through
    the nodes like Q4 and reproduces planes, but its gradient is continuous (C¹). Positions are
    clamped to the map; nodes beyond an edge repeat the edge's.
    """
    ny, nx = z.shape
    x = min(max(x, 0.0), nx - 1.0)
    y = min(max(y, 0.0), ny - 1.0)
    i = min(int(math.floor(x)), max(nx - 2, 0))
    j = min(int(math.floor(y)), max(ny - 2, 0))
    wx, dwx = _cr_weights(x - i)
    wy, dwy = _cr_weights(y - j)
    b = 0.0
    gx = 0.0
    gy = 0.0
    for a in range(4):
        jj = min(max(j - 1 + a, 0), ny - 1)
        rowv = 0.0
        rowd = 0.0
        for c in range(4):
            ii = min(max(i - 1 + c, 0), nx - 1)
            v = z[jj, ii]
            rowv += wx[c] * v
            rowd += dwx[c] * v
        b += wy[a] * rowv
        gx += wy[a] * rowd
        gy += dwy[a] * rowv
    return b, gx, gy


# ---------------------------------------------------------------- neighbour search


@njit(cache=True)
def bin_particles(pos, n, x0, y0, cell, ncx, ncy, cell_start, order):
    """Counting sort of particles 0…n−1 into a dense ncy×ncx grid of square cells of edge ``cell``.

    ``cell_start`` (ncx·ncy + 1) gets each cell's first index into ``order`` (stable: particles of a
    cell keep their index order, so every later sum runs in the same order on any thread count).
    """
    counts = np.zeros(ncx * ncy + 1, np.int64)
    cid = np.empty(n, np.int64)
    for i in range(n):
        cx = min(max(int((pos[i, 0] - x0) / cell), 0), ncx - 1)
        cy = min(max(int((pos[i, 1] - y0) / cell), 0), ncy - 1)
        c = cy * ncx + cx
        cid[i] = c
        counts[c + 1] += 1
    for c in range(ncx * ncy):
        counts[c + 1] += counts[c]
    cell_start[: ncx * ncy + 1] = counts
    fill = counts[: ncx * ncy].copy()
    for i in range(n):
        c = cid[i]
        order[fill[c]] = i
        fill[c] += 1


#: bins of the neighbour search per largest search radius: a particle scans ±LIST_BINS bins and skips
#: those farther than its own radius and the bin's largest (:func:`pairs_particle`)
LIST_BINS = 3


@njit(cache=True)
def bin_search_max(pos, search, n, x0, y0, cell, ncx, ncy, out):
    """out[c] = the largest search radius s_j of the particles in bin c (0 where empty); bins as in
    :func:`bin_particles`."""
    out[:] = 0.0
    for i in range(n):
        cx = min(max(int((pos[i, 0] - x0) / cell), 0), ncx - 1)
        cy = min(max(int((pos[i, 1] - y0) / cell), 0), ncy - 1)
        c = cy * ncx + cx
        if search[i] > out[c]:
            out[c] = search[i]


@njit(inline="always")
def pairs_particle(i, pos, hsup, x0, y0, cell, ncx, ncy, cell_start, order, bin_max, reach, k, nbr, fill):
    """Particle i's pairs j ≠ i with r_ij < max(s_i, s_j) (s = ``hsup``, the search radii), in bin
    order: written to nbr[k…] when ``fill``; returns k plus their number.

    Bins of edge ``cell`` with ``reach`` · cell ≥ max s_j: i scans the bins within ``reach`` of its own
    and skips a bin whose nearest point is at least max(s_i, ``bin_max``[bin]) away, as no particle
    in it can pair with i. Where the radii differ (thin water's supports grow towards
    ``flood.max_support`` × a deep particle's), bins sized by the largest radius would make every
    particle scan an area of (3 max s)², most of it empty of partners.
    """
    ui = (pos[i, 0] - x0) / cell
    vi = (pos[i, 1] - y0) / cell
    cx = min(max(int(ui), 0), ncx - 1)
    cy = min(max(int(vi), 0), ncy - 1)
    si = hsup[i]
    for gy in range(max(cy - reach, 0), min(cy + reach + 1, ncy)):
        ey = max(gy - vi, vi - (gy + 1.0), 0.0) * cell
        for gx in range(max(cx - reach, 0), min(cx + reach + 1, ncx)):
            c = gy * ncx + gx
            ex = max(gx - ui, ui - (gx + 1.0), 0.0) * cell
            lim = max(si, bin_max[c]) * (1.0 + 1e-9)  # a hair wide: rounding never drops a pair
            if ex * ex + ey * ey >= lim * lim:
                continue
            for q in range(cell_start[c], cell_start[c + 1]):
                j = order[q]
                if j == i:
                    continue
                dx = pos[i, 0] - pos[j, 0]
                dy = pos[i, 1] - pos[j, 1]
                hm = max(si, hsup[j])
                if dx * dx + dy * dy < hm * hm:
                    if fill:
                        nbr[k] = j
                    k += 1
    return k


@njit(parallel=True, cache=True)
def scan_pairs(pos, hsup, n, x0, y0, cell, ncx, ncy, cell_start, order, bin_max, reach, count, start, nbr, fill):
    """The pairs j ≠ i with r_ij < max(s_i, s_j) (:func:`pairs_particle`): their number in ``count[i]``
    (``fill`` False), or, with the offsets ``start`` from those counts, the CSR lists
    nbr[start[i]:start[i+1]] in bin order (``fill`` True)."""
    for i in prange(n):
        k0 = start[i] if fill else 0
        k = pairs_particle(
            i, pos, hsup, x0, y0, cell, ncx, ncy, cell_start, order, bin_max, reach, k0, nbr, fill
        )
        if not fill:
            count[i] = k


# ---------------------------------------------------------------- depth and smoothing length


@njit(parallel=True, cache=True)
def depth_and_support(pos, vol, hsup, n, start, nbr, k2, h_min, h_max, tol, max_iter, depth, omega):
    """Depth d_i = Σ_j V_j W(r_ij, H_i) (self included) with H_i = k_i·√(V_i/(d_i + δ_i)), by Newton.

    ``k2`` holds k_i² per particle (the support factor squared: ``flood.support``² for every particle but
    a split's daughters, whose k_i starts where their H equals the parent's and relaxes back).
    δ_i = k_i²V_i/h_max² bounds H smoothly by h_max as the water thins (a particle alone on dry ground
    gets H → h_max) and leaves deep water untouched; a hard clamp would make H(d) kink where it binds,
    and particles on a lake's shore chatter across the kink for ever. Residual
    R(H) = Σ_j V_j W(r_ij, H) + δ_i − k²V_i/H², R'(H) = Σ_j V_j ∂W/∂H + 2k²V_i/H³ (Vacondio et al.
    2012, Rodriguez-Paz & Bonet 2005). Ω_i = 1 + (H_i/(2(d_i + δ_i))) Σ_j V_j ∂W_ij/∂H (from
    dH/dd = −H/(2(d + δ))); [h_min, h_max] only guard the iteration. Returns the largest number of
    iterations any particle needed. ``hsup`` holds the previous H on entry (the first guess) and the
    new one on exit.
    """
    iters = np.zeros(n, np.int64)
    for i in prange(n):
        iters[i] = depth_support_particle(i, pos, vol, hsup, start, nbr, k2, h_min, h_max, tol, max_iter, depth, omega)
    return iters.max()


@njit(inline="always")
def depth_support_particle(i, pos, vol, hsup, start, nbr, k2, h_min, h_max, tol, max_iter, depth, omega):
    """Particle i's Newton solve of :func:`depth_and_support`; returns its iterations."""
    h = min(max(hsup[i], h_min), h_max)
    vi = vol[i]
    k2i = k2[i]
    delta = k2i * vi / (h_max * h_max)
    s = 0.0
    ds = 0.0
    it = 0
    for it in range(max_iter):  # noqa: B007 (the count is kept)
        s = vi * wendland_w_2d(0.0, h)
        ds = vi * dw_dh(0.0, h)
        h2 = h * h
        for q in range(start[i], start[i + 1]):
            j = nbr[q]
            dx = pos[i, 0] - pos[j, 0]
            dy = pos[i, 1] - pos[j, 1]
            r2 = dx * dx + dy * dy
            if r2 < h2:  # the lists reach past H (their skin): no root for those
                r = math.sqrt(r2)
                s += vol[j] * wendland_w_2d(r, h)
                ds += vol[j] * dw_dh(r, h)
        res = s + delta - k2i * vi / (h * h)
        der = ds + 2.0 * k2i * vi / (h * h * h)
        if der <= 0.0:
            hn = h * 1.2 if res < 0.0 else h * 0.8
        else:
            hn = h - res / der
        hn = min(max(hn, 0.8 * h), 1.25 * h)  # damped Newton: at most 25 % a step
        hn = min(max(hn, h_min), h_max)
        if abs(hn - h) <= tol * h:
            break  # converged: keep H and the sums evaluated at it
        h = hn
    hsup[i] = h
    depth[i] = s
    om = 1.0 + h / (2.0 * (s + delta)) * ds
    omega[i] = min(max(om, 0.25), 4.0)
    return it + 1


# ---------------------------------------------------------------- accelerations


@njit(parallel=True, cache=True)
def accelerations(pos, vel, vol, hsup, depth, omega, n, start, nbr, bed, inv_cell, g, alpha, acc):
    """a_i = −(g/2) Σ_j V_j [∇W_ij(H_i)/Ω_i + ∇W_ij(H_j)/Ω_j] − g ∇b(x_i) − Σ_j V_j Π_ij ∇W̄_ij.

    The first two terms are the variational shallow-water momentum equation (Rodriguez-Paz & Bonet
    2005; Vacondio et al. 2012): the gradient of the potential energy Σ V_j g(d_j/2 + b_j), so the
    scheme conserves energy and water comes to rest where that discrete energy is least. ∇b is the
    exact gradient of the bed's C¹ surface (:func:`bed_c1`), so the bed term is conservative too.
    Π_ij = −α c̄ μ_ij / d̄_ij for approaching pairs, μ_ij = h̄ v_ij·r_ij/(r² + 0.01h̄²), c = √(g d),
    h̄ = H̄/2 (Monaghan 1992 in depth form) captures bores.
    """
    for i in prange(n):
        ax, ay = pair_forces_particle(i, pos, vel, vol, hsup, depth, omega, start, nbr, g, alpha)
        _, gx, gy = bed_c1(bed, pos[i, 0] * inv_cell, pos[i, 1] * inv_cell)
        acc[i, 0] = ax - g * gx * inv_cell
        acc[i, 1] = ay - g * gy * inv_cell


@njit(inline="always")
def pair_forces_particle(i, pos, vel, vol, hsup, depth, omega, start, nbr, g, alpha):
    """Particle i's pressure and artificial-viscosity sum of :func:`accelerations` (the bed apart)."""
    xi = pos[i, 0]
    yi = pos[i, 1]
    hi = hsup[i]
    ci = math.sqrt(g * depth[i])
    ax = 0.0
    ay = 0.0
    for q in range(start[i], start[i + 1]):
        j = nbr[q]
        dx = xi - pos[j, 0]
        dy = yi - pos[j, 1]
        r2 = dx * dx + dy * dy
        hj = hsup[j]
        if r2 >= hi * hi and r2 >= hj * hj:
            continue  # beyond both supports (the lists' skin): no force
        r = math.sqrt(r2)
        fi = wendland_f_2d(r, hi)
        fj = wendland_f_2d(r, hj)
        fp = 0.5 * g * vol[j] * (fi / omega[i] + fj / omega[j])
        ax -= fp * dx
        ay -= fp * dy
        vdr = (vel[i, 0] - vel[j, 0]) * dx + (vel[i, 1] - vel[j, 1]) * dy
        if alpha > 0.0 and vdr < 0.0:
            hb = 0.25 * (hi + hj)
            mu = hb * vdr / (r2 + 0.01 * hb * hb)
            cb = 0.5 * (ci + math.sqrt(g * depth[j]))
            db = 0.5 * (depth[i] + depth[j])
            pi_ij = -alpha * cb * mu / db
            fv = vol[j] * pi_ij * 0.5 * (fi + fj)
            ax -= fv * dx
            ay -= fv * dy
    return ax, ay


@njit(parallel=True, cache=True)
def kick(vel, acc, depth, manning, inv_cell, pos, n, dt, g, d_floor):
    """u ← (u + Δt a) / (1 + Δt g n² |u + Δt a| / d^{4/3}) — Manning friction, semi-implicit
    (:func:`erosim.kernels.friction_manning.manning_divisor`, the 3-D flood solver's law too).

    The friction factor only divides, so it can stop a particle but never reverse it, however thin
    the water (d is floored at ``d_floor`` only to avoid 0/0). ``manning`` is a map of n on the DEM
    grid (nearest cell).
    """
    for i in prange(n):
        kick_particle(i, vel, acc, depth, manning, inv_cell, pos, dt, g, d_floor)


@njit(inline="always")
def kick_particle(i, vel, acc, depth, manning, inv_cell, pos, dt, g, d_floor):
    """Particle i's semi-implicit Manning kick of :func:`kick`."""
    ny, nx = manning.shape
    ux = vel[i, 0] + dt * acc[i, 0]
    uy = vel[i, 1] + dt * acc[i, 1]
    col = min(max(int(pos[i, 0] * inv_cell + 0.5), 0), nx - 1)
    row = min(max(int(pos[i, 1] * inv_cell + 0.5), 0), ny - 1)
    nn = manning[row, col]
    d = max(depth[i], d_floor)
    speed = math.sqrt(ux * ux + uy * uy)
    den = manning_divisor(nn, speed, d, dt, g)
    vel[i, 0] = ux / den
    vel[i, 1] = uy / den


@njit(parallel=True, cache=True)
def drift(pos, vel, n, dt, inv_cell, wall, open_w, open_e, open_n, open_s, out, blocked):
    """x ← x + Δt u, with walls and open edges on the DEM's cells.

    A particle whose new cell is a wall (nodata, a dam line) or beyond a closed map edge stays where
    it was and stops (an inelastic, no-slip contact); ``blocked[i]`` is set and :func:`hold_contacts`
    stops it again after the closing half-kick, so water pressed against a wall rests there instead
    of bouncing or sliding to and fro along it (a free-slip contact let particles pinned in a row
    against a dam slide at a metre a second for ever). One beyond an open edge is
    flagged in ``out`` (removed by the caller, its water counted). Edges: west x < −Δ/2,
    east x > (nx−½)Δ, north y < −Δ/2 (row 0), south y > (ny−½)Δ.
    """
    for i in prange(n):
        drift_particle(i, pos, vel, dt, inv_cell, wall, open_w, open_e, open_n, open_s, out, blocked)


@njit(inline="always")
def drift_particle(i, pos, vel, dt, inv_cell, wall, open_w, open_e, open_n, open_s, out, blocked):
    """Particle i's drift of :func:`drift`."""
    ny, nx = wall.shape
    blocked[i] = 0
    ox = pos[i, 0]
    oy = pos[i, 1]
    x = ox + dt * vel[i, 0]
    y = oy + dt * vel[i, 1]
    c0 = int(math.floor(ox * inv_cell + 0.5))
    r0 = int(math.floor(oy * inv_cell + 0.5))
    c1 = int(math.floor(x * inv_cell + 0.5))
    r1 = int(math.floor(y * inv_cell + 0.5))
    leaving = (c1 < 0 and open_w) or (c1 >= nx and open_e) or (r1 < 0 and open_n) or (r1 >= ny and open_s)
    if leaving:
        pos[i, 0] = x
        pos[i, 1] = y
        out[i] = True
        return
    blocked_x = c1 < 0 or c1 >= nx or wall[min(max(r0, 0), ny - 1), c1]
    blocked_y = r1 < 0 or r1 >= ny or wall[r1, min(max(c0, 0), nx - 1)]
    if not (blocked_x or blocked_y or wall[min(max(r1, 0), ny - 1), min(max(c1, 0), nx - 1)]):
        pos[i, 0] = x
        pos[i, 1] = y
        return
    vel[i, 0] = 0.0
    vel[i, 1] = 0.0
    blocked[i] = 1


@njit(parallel=True, cache=True)
def hold_contacts(vel, n, blocked):
    """Stop the particles that met a wall in this step's drift (after the closing half-kick)."""
    for i in prange(n):
        if blocked[i]:
            vel[i, 0] = 0.0
            vel[i, 1] = 0.0


# ---------------------------------------------------------------- splitting (Vacondio et al. 2013)


@njit(parallel=True, cache=True)
def split_parents(pos, vol, depth, vel, n, spacing_lim, vol_lim, speed2, depth_lim, radius, hexagon, inv_cell, wall,
                  out):  # fmt: skip
    """out[i] = does particle i split (:func:`split_parent`)."""
    for i in prange(n):
        out[i] = split_parent(i, pos, vol, depth, vel, spacing_lim, vol_lim, speed2, depth_lim, radius, hexagon,
                              inv_cell, wall)  # fmt: skip


@njit(inline="always")
def split_parent(i, pos, vol, depth, vel, spacing_lim, vol_lim, speed2, depth_lim, radius, hexagon, inv_cell, wall):
    """Particle i splits when its spacing s_i = √(V_i/d_i) exceeds ``spacing_lim``, V_i ≥ ``vol_lim``,
    |u_i|² > ``speed2``, d_i < ``depth_lim``, and its daughters' hexagon x_i + ``radius``·s_i·(cos, sin)
    (``hexagon``: the six unit vectors) lies on the map and on no wall cell (a daughter on a wall would
    sit on another particle once held there)."""
    d = depth[i]
    s = math.sqrt(vol[i] / max(d, 1e-300))
    if not (s > spacing_lim and vol[i] >= vol_lim and d < depth_lim):
        return False
    if not vel[i, 0] ** 2 + vel[i, 1] ** 2 > speed2:
        return False
    rad = radius * s
    ny, nx = wall.shape
    for k in range(6):
        col = int(math.floor((pos[i, 0] + rad * hexagon[k, 0]) * inv_cell + 0.5))
        row = int(math.floor((pos[i, 1] + rad * hexagon[k, 1]) * inv_cell + 0.5))
        if col < 0 or col >= nx or row < 0 or row >= ny:
            return False
        if wall[row, col]:
            return False
    return True


@njit(cache=True)
def lists_hold(pos, built_at, hsup, search, n):
    """The Verlet-list test of ``ShallowWaterSPH._lists_hold``: H_i + |Δx_i| + max_j |Δx_j| ≤ s_i for
    every i, Δx the moves since the lists were built at ``built_at`` with radii ``search``; in two
    passes without temporaries (it runs several times a step)."""
    most = 0.0
    for i in range(n):
        most = max(most, math.sqrt((pos[i, 0] - built_at[i, 0]) ** 2 + (pos[i, 1] - built_at[i, 1]) ** 2))
    for i in range(n):
        moved = math.sqrt((pos[i, 0] - built_at[i, 0]) ** 2 + (pos[i, 1] - built_at[i, 1]) ** 2)
        if not hsup[i] + moved + most <= search[i]:
            return False
    return True


@njit(parallel=True, cache=True)
def relax_supports(k2, hsup, depth, vel, n, k2_home, relax, g, dt):
    """A split's daughters' support factors towards k² (:func:`relax_support`), every particle."""
    for i in prange(n):
        relax_support(i, k2, hsup, depth, vel, k2_home, relax, g, dt)


@njit(inline="always")
def relax_support(i, k2, hsup, depth, vel, k2_home, relax, g, dt):
    """k_i² ← k² + (k_i² − k²) exp(−Δt/τ_i), τ_i = ``relax`` · H_i/(√(g d_i) + |u_i|): a daughter's H
    shrinks from its parent's to its own over a few of its own crossing times; within 0.1 % of k² (0.05 %
    of H) it is home. Particles already at k² are left alone."""
    if k2[i] != k2_home:
        u = math.hypot(vel[i, 0], vel[i, 1])
        tau = relax * hsup[i] / (math.sqrt(g * depth[i]) + u + 1e-300)
        new = k2_home + (k2[i] - k2_home) * (math.exp(-dt / tau) if tau > 0.0 else 0.0)
        if new - k2_home < 1e-3 * k2_home:
            new = k2_home
        k2[i] = new


@njit(parallel=True, cache=True)
def step_limit(vel, depth, hsup, n, g):
    """min_i H_i / (√(g d_i) + |u_i|) — the CFL time-step scale (times the Courant number)."""
    best = np.full(n, np.inf)
    for i in prange(n):
        best[i] = cfl_scale(i, vel, depth, hsup, g)
    return best.min() if n > 0 else np.inf


@njit(inline="always")
def cfl_scale(i, vel, depth, hsup, g):
    """H_i / (√(g d_i) + |u_i|), or inf for a particle at rest in no water."""
    c = math.sqrt(g * depth[i]) + math.sqrt(vel[i, 0] ** 2 + vel[i, 1] ** 2)
    return hsup[i] / c if c > 0.0 else np.inf


@njit(cache=True)
def bed_at(bed, pos, n, inv_cell, out):
    """Bed elevation b(x_i) from the C¹ surface the water feels (:func:`bed_c1`)."""
    for i in range(n):
        out[i] = bed_c1(bed, pos[i, 0] * inv_cell, pos[i, 1] * inv_cell)[0]


# ---------------------------------------------------------------- hazard maxima on the DEM grid


@njit(cache=True)
def splat_depth(pos, vol, hsup, n, inv_cell, cell_size, out):
    """SPH depth on the DEM's nodes: d(x) = Σ_j V_j W(|x − x_j|, H_j) (the scatter form)."""
    ny, nx = out.shape
    for j in range(n):
        h = hsup[j]
        cx = pos[j, 0] * inv_cell
        cy = pos[j, 1] * inv_cell
        rad = h * inv_cell
        for r in range(max(int(math.ceil(cy - rad)), 0), min(int(math.floor(cy + rad)), ny - 1) + 1):
            for c in range(max(int(math.ceil(cx - rad)), 0), min(int(math.floor(cx + rad)), nx - 1) + 1):
                dx = c * cell_size - pos[j, 0]
                dy = r * cell_size - pos[j, 1]
                rr = math.sqrt(dx * dx + dy * dy)
                if rr < h:
                    out[r, c] += vol[j] * wendland_w_2d(rr, h)


@njit(cache=True)
def grid_maxima(
    pos, vel, vol, hsup, depth, eta, bed, cell_size, x0, y0, bcell, ncx, ncy, cell_start, order,
    r_lo, r_hi, c_lo, c_hi, t, wet, max_d, max_v, max_dv, arrival, wall, wall_dist, conveyance,
):  # fmt: skip
    """Running maxima of the water's depth, speed and depth·speed at the DEM's cell centres, and first
    wetting times.

    At each cell centre x (node (row, col) at (col·Δ, row·Δ)) the depth is the SPH interpolant
    d(x) = Σ_j V_j W(|x − x_j|, H_j) (the scatter form, which integrates to the water's volume), cut
    where the ground stands above the water: d_map = min(d(x), η̄(x) − b(x)), with η̄ the Shepard
    mean of the particles' surfaces η_j = b(x_j) + d_j (weights V_j W/d_j; ``eta`` from
    :func:`surfaces`) and b the bed the water feels, at the node. The interpolant alone reaches a
    support H beyond the outermost particles uphill too, onto banks above the water; the cut keeps
    the shoreline where the water surface meets the ground and leaves the interpolant wherever the
    ground is level with or below the surface (on a flat bed d(x) = S(x)·(η̄ − b), S = Σ V_j W/d_j,
    and S < 1 past the water's edge). A particle behind a ``wall`` cell (nodata, a dam) is not seen
    (:func:`wall_between`, looked for only within reach of a wall, ``wall_dist`` in m). The speed is
    the Shepard mean ū(x) = Σ_j V_j W |u_j| / d(x) (Monaghan 1992, *Annu. Rev. Astron. Astrophys.*
    30). Where the map's depth is below the depth of the particles' columns there, d̄ = d(x)/S(x) (the
    V_j W-weighted harmonic mean of the d_j) — the water's edge, thinner than a particle — the speed
    along the edge is slowed by φ = (d_map/d̄)^p and the speed across it is not (:func:`raise_cell`),
    the edge's direction being the depth's gradient ∇d = Σ_j V_j ∇W. With ``conveyance`` p = 2/3: the
    water beside a stream shares its friction slope, so Manning's law gives its speed from its depth,
    u ∝ d^(2/3)/n (the conveyance assumption of one-dimensional channel models, Chow 1959,
    *Open-Channel Hydraulics* §6-3); a front's thin tip moves with the front behind it (Whitham 1955,
    *Proc. R. Soc. A* 227), and a shore is a material line, so across the edge the water keeps the
    particles' speed. p = 0 keeps the particles' own speed out to the edge in every direction. Cells
    where d_map < ``wet`` are dry and raise nothing; wall cells are never marked.

    This is the gather form, cell by cell over the rows ``r_lo``…``r_hi`` and columns of the
    particles' reach, each cell summing the particles of its neighbouring bins (:func:`bin_particles`,
    bins of edge ``bcell`` ≥ max H_j): the device runs :func:`cell_maxima` one thread per cell. The
    CPU solver sums the same terms particle by particle (:func:`scatter_sums`, :func:`raise_maxima`),
    which visits each pair once; this serial loop is its reference in the tests.
    """
    for r in range(r_lo, r_hi + 1):
        for c in range(c_lo, c_hi + 1):
            cell_maxima(
                r, c, pos, vel, vol, hsup, depth, eta, bed, cell_size, x0, y0, bcell, ncx, ncy, cell_start, order,
                t, wet, max_d, max_v, max_dv, arrival, wall, wall_dist, conveyance,
            )  # fmt: skip


@njit(inline="always")
def cell_maxima(
    r, c, pos, vel, vol, hsup, depth, eta, bed, cell_size, x0, y0, bcell, ncx, ncy, cell_start, order,
    t, wet, max_d, max_v, max_dv, arrival, wall, wall_dist, conveyance,
):  # fmt: skip
    """Cell (r, c)'s update of :func:`grid_maxima`."""
    if wall[r, c]:
        return
    x = c * cell_size
    y = r * cell_size
    inv_cell = 1.0 / cell_size
    near = wall_dist[r, c] <= bcell + cell_size  # a wall within reach: look for walls between
    bx = min(max(int((x - x0) / bcell), 0), ncx - 1)
    by = min(max(int((y - y0) / bcell), 0), ncy - 1)
    d = 0.0
    du = 0.0
    s = 0.0
    se = 0.0
    ux = 0.0
    uy = 0.0
    grad_x = 0.0
    grad_y = 0.0
    for gy in range(max(by - 1, 0), min(by + 2, ncy)):
        for gx in range(max(bx - 1, 0), min(bx + 2, ncx)):
            b = gy * ncx + gx
            for q in range(cell_start[b], cell_start[b + 1]):
                j = order[q]
                dx = x - pos[j, 0]
                dy = y - pos[j, 1]
                h = hsup[j]
                rr2 = dx * dx + dy * dy
                if rr2 < h * h:
                    if near and wall_between(x, y, pos[j, 0], pos[j, 1], inv_cell, wall):
                        continue
                    rj = math.sqrt(rr2)
                    w = vol[j] * wendland_w_2d(rj, h)
                    d += w
                    du += w * math.sqrt(vel[j, 0] ** 2 + vel[j, 1] ** 2)
                    ux += w * vel[j, 0]
                    uy += w * vel[j, 1]
                    f = vol[j] * wendland_f_2d(rj, h)
                    grad_x += f * dx
                    grad_y += f * dy
                    w /= depth[j]
                    s += w
                    se += w * eta[j]
    raise_cell(r, c, d, du, s, se, ux, uy, grad_x, grad_y, bed, t, wet, max_d, max_v, max_dv, arrival, conveyance)


MARGIN_SPEED = {"conveyance": 2.0 / 3.0, "shepard": 0.0}  # ShallowWaterParams.margin_speed → p of raise_cell
MAP_SUMS = 8  # the sums a cell's maxima take (scatter_sums, raise_cell)


@njit(inline="always")
def raise_cell(r, c, d, du, s, se, ux, uy, gx, gy, bed, t, wet, max_d, max_v, max_dv, arrival, conveyance):
    """Cell (r, c)'s maxima from its sums d = Σ V_j W, du = Σ V_j W |u_j|, s = Σ V_j W/d_j,
    se = Σ V_j W η_j/d_j, (ux, uy) = Σ V_j W u_j and (gx, gy) = ∇d = Σ V_j ∇W (:func:`grid_maxima`).

    The speed is ū = du/d, and where the map's depth is below the columns' d̄ = d/s it is
    ū·√(cos²θ + φ² sin²θ), φ = (d_map/d̄)^``conveyance`` (``MARGIN_SPEED``), θ the angle between the
    water's mean velocity (ux, uy) and the depth's gradient: the speed across the edge (θ = 0 or π, a
    front or a receding shore) is the particles', the speed along it is slowed by φ. Where either
    vector is zero, the whole speed is slowed by φ."""
    if d < wet:
        return
    u = du / d
    columns = d / s
    d = min(d, se / s - bed[r, c])
    if d < wet:
        return
    if d < columns and conveyance > 0.0:
        phi = (d / columns) ** conveyance
        a = (ux * ux + uy * uy) * (gx * gx + gy * gy)
        if a > 0.0:
            cos2 = min((ux * gx + uy * gy) ** 2 / a, 1.0)
            u *= math.sqrt(cos2 + phi * phi * (1.0 - cos2))
        else:
            u *= phi
    if d > max_d[r, c]:
        max_d[r, c] = d
    if u > max_v[r, c]:
        max_v[r, c] = u
    if d * u > max_dv[r, c]:
        max_dv[r, c] = d * u
    if t < arrival[r, c]:
        arrival[r, c] = t


MAP_STRIPE = 16  # rows of the window each thread of scatter_sums fills at a time


@njit(parallel=True, cache=True)
def scatter_sums(pos, vel, vol, hsup, depth, eta, n, cell_size, r_lo, c_lo, wall, wall_dist, sums):
    """The sums of :func:`grid_maxima` at the cells of the window from (r_lo, c_lo) (``sums``, shape
    (rows, columns, ``MAP_SUMS``), zero on entry, in :func:`raise_cell`'s order), particle by particle
    over the cells within its support: each pair once, where the gather visits every particle of the
    neighbouring bins (bins as wide as the largest support), so about six times fewer pairs where the
    supports differ. The window's rows are cut into stripes of ``MAP_STRIPE`` filled in parallel, each
    stripe by one thread over all particles in their order, so every cell adds its particles in
    ascending order whatever the thread count: the sums are those of a serial loop, bit for bit.
    ``wall_dist`` as in :func:`grid_maxima`."""
    ny, nx = wall.shape
    nr, nc = sums.shape[0], sums.shape[1]
    inv_cell = 1.0 / cell_size
    rows = np.empty((n, 2), np.int64)  # each particle's first and last row within reach
    for j in prange(n):
        rad = hsup[j] * inv_cell
        rows[j, 0] = max(int(math.ceil(pos[j, 1] * inv_cell - rad)), r_lo, 0)
        rows[j, 1] = min(int(math.floor(pos[j, 1] * inv_cell + rad)), r_lo + nr - 1, ny - 1)
    for k in prange((nr + MAP_STRIPE - 1) // MAP_STRIPE):
        s0 = r_lo + k * MAP_STRIPE
        s1 = min(s0 + MAP_STRIPE, r_lo + nr) - 1
        for j in range(n):
            r0 = max(rows[j, 0], s0)
            r1 = min(rows[j, 1], s1)
            if r0 > r1:
                continue
            h = hsup[j]
            px = pos[j, 0]
            py = pos[j, 1]
            rad = h * inv_cell
            c0 = max(int(math.ceil(px * inv_cell - rad)), c_lo, 0)
            c1 = min(int(math.floor(px * inv_cell + rad)), c_lo + nc - 1, nx - 1)
            vx = vel[j, 0]
            vy = vel[j, 1]
            uj = math.sqrt(vx**2 + vy**2)
            inv_h = 1.0 / h
            # Wendland C2 (wendland_w_2d, wendland_f_2d) times V_j, its constants once per particle
            cw = vol[j] * 7.0 / (math.pi * h * h)
            cf = vol[j] * -140.0 / (math.pi * h * h * h * h)
            h2 = h * h
            inv_d = 1.0 / depth[j]
            eta_j = eta[j]
            for r in range(r0, r1 + 1):
                y = r * cell_size
                dy = y - py
                chord = math.sqrt(max(h2 - dy * dy, 0.0))  # the support's half-width on this row
                first = max(int(math.ceil((px - chord) * inv_cell)), c0)
                last = min(int(math.floor((px + chord) * inv_cell)), c1)
                for c in range(first, last + 1):
                    if wall[r, c]:
                        continue
                    x = c * cell_size
                    dx = x - px
                    rr2 = dx * dx + dy * dy
                    if rr2 < h2:
                        if wall_dist[r, c] <= h + cell_size and wall_between(x, y, px, py, inv_cell, wall):
                            continue
                        q = math.sqrt(rr2) * inv_h
                        e = 1.0 - q
                        e3 = e * e * e
                        w = cw * e3 * e * (1.0 + 4.0 * q)
                        f = cf * e3
                        rr = r - r_lo
                        cc = c - c_lo
                        sums[rr, cc, 0] += w
                        sums[rr, cc, 1] += w * uj
                        sums[rr, cc, 4] += w * vx
                        sums[rr, cc, 5] += w * vy
                        sums[rr, cc, 6] += f * dx
                        sums[rr, cc, 7] += f * dy
                        w *= inv_d
                        sums[rr, cc, 2] += w
                        sums[rr, cc, 3] += w * eta_j


@njit(parallel=True, cache=True)
def raise_maxima(sums, r_lo, c_lo, bed, t, wet, max_d, max_v, max_dv, arrival, wall, conveyance):
    """The maxima of the window's cells from :func:`scatter_sums` (:func:`raise_cell`); wall cells
    are never marked."""
    nr, nc = sums.shape[0], sums.shape[1]
    for rr in prange(nr):
        for cc in range(nc):
            r = r_lo + rr
            c = c_lo + cc
            if not wall[r, c]:
                raise_cell(
                    r, c, sums[rr, cc, 0], sums[rr, cc, 1], sums[rr, cc, 2], sums[rr, cc, 3], sums[rr, cc, 4],
                    sums[rr, cc, 5], sums[rr, cc, 6], sums[rr, cc, 7], bed, t, wet, max_d, max_v, max_dv, arrival,
                    conveyance,
                )  # fmt: skip


@njit(inline="always")
def wall_between(xa, ya, xb, yb, inv_cell, wall):
    """Does the segment from (xa, ya) to (xb, yb) (cell frame, m) cross a ``wall`` cell? Every cell it
    passes through is visited in order (Amanatides & Woo 1987, *Eurographics* 87), the first and the
    last excepted; cells off the map are not walls."""
    ny, nx = wall.shape
    ua = xa * inv_cell + 0.5
    va = ya * inv_cell + 0.5
    du = xb * inv_cell + 0.5 - ua
    dv = yb * inv_cell + 0.5 - va
    c = int(math.floor(ua))
    r = int(math.floor(va))
    steps = abs(int(math.floor(ua + du)) - c) + abs(int(math.floor(va + dv)) - r)
    step_c = 1 if du > 0.0 else -1
    step_r = 1 if dv > 0.0 else -1
    if du != 0.0:
        next_c = ((c + 1.0 if du > 0.0 else c * 1.0) - ua) / du
        delta_c = abs(1.0 / du)
    else:
        next_c = math.inf
        delta_c = math.inf
    if dv != 0.0:
        next_r = ((r + 1.0 if dv > 0.0 else r * 1.0) - va) / dv
        delta_r = abs(1.0 / dv)
    else:
        next_r = math.inf
        delta_r = math.inf
    for _ in range(steps - 1):
        if next_c < next_r:
            c += step_c
            next_c += delta_c
        else:
            r += step_r
            next_r += delta_r
        if 0 <= r < ny and 0 <= c < nx and wall[r, c]:
            return True
    return False


@njit(inline="always")
def surface_particle(i, pos, depth, bed, inv_cell):
    """Particle i's water surface for the hazard maps, η_i = b(x_i) + d_i, with b the bilinear (Q4)
    interpolant of the bed's nodes: it never overshoots them, where the C¹ surface the water feels
    (:func:`bed_c1`) dips below a wall's foot by a fraction of the wall's rise (Catmull-Rom's negative
    weights), which would put a shore under water that stands level beside it."""
    ny, nx = bed.shape
    x = min(max(pos[i, 0] * inv_cell, 0.0), nx - 1.0)
    y = min(max(pos[i, 1] * inv_cell, 0.0), ny - 1.0)
    c = min(int(x), max(nx - 2, 0))
    r = min(int(y), max(ny - 2, 0))
    fx = x - c
    fy = y - r
    c1 = min(c + 1, nx - 1)
    r1 = min(r + 1, ny - 1)
    b = (1.0 - fy) * ((1.0 - fx) * bed[r, c] + fx * bed[r, c1]) + fy * ((1.0 - fx) * bed[r1, c] + fx * bed[r1, c1])
    return b + depth[i]


@njit(parallel=True, cache=True)
def surfaces(pos, depth, bed, n, inv_cell, eta):
    """η_i of every particle (:func:`surface_particle`)."""
    for i in prange(n):
        eta[i] = surface_particle(i, pos, depth, bed, inv_cell)
