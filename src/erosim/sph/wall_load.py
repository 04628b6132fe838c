"""The pressure a wall sensor reads: the load the fluid puts on a patch of boundary particles.

The force on the wall is minus the force its particles exert on the fluid (Newton's third law on
the pair terms of :mod:`erosim.sph.forces`): for the boundary particles b of a patch of the wall
and their fluid neighbours a,

    F = Σ_b Σ_a m_a m_b [P_ab f_ab r_ab − (c_r r_ab + c_v v_a)_ab],      r_ab = r_a − r_b,

with P_ab the solver's pressure term, f_ab = ∇W_ab/r_ab and (c_r, c_v) its viscous term; the mean
pressure is its component against the face's normal n (pointing into the fluid) over the wetted face's
area, p̄ = −F·n / A, A = (wetted boundary-particle columns in the patch) × (their cell on the face), and
the sensor reads it carried hydrostatically from the wetted face's centre r̄ to the sensor's point r_s
along the face (as Adami, Hu & Adams 2012 carry the fluid's pressure to a wall),

    p(r_s) = p̄ + ρ₀ g·(r_s − r̄)_face .

A column of the face is wetted when a fluid particle in front of it, within h, lies under ¾Δx from it
along the face (:func:`wetted`): dynamic boundary particles hold the fluid off by a gap that grows under
impacts to about half a support, and the face in that gap at the floor is dry in the model (docs/sph.md,
"At the foot of a wall").

Why not an interpolated pressure: dynamic boundary particles (Crespo et al. 2007) hold the fluid
off by their own pressure, far above the fluid's beside them (15–26 kPa against the 3 kPa measured
on the box of SPHERIC Test 2), while the fluid next to them reads a third of it; what the wall
feels is the momentum the pair forces exchange. Written in NumPy (a few sensors per output time,
each a few hundred pairs; a Numba kernel would buy nothing).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from erosim.kernels.sph_kernels import kernel_f, kernel_lap


def patch(boundary: np.ndarray, point, normal, half_width: float, depth: float, solid) -> np.ndarray:
    """Indices of the boundary particles of the wall ``solid`` = (lo, hi) behind the face at ``point``
    (within ``depth`` of it, along −``normal``) whose offset along the face is at most ``half_width``."""
    point, normal = np.asarray(point, dtype=np.float64), np.asarray(normal, dtype=np.float64)
    lo, hi = (np.asarray(x, dtype=np.float64) for x in solid)
    rel = boundary - point
    behind = rel @ normal
    along = rel - behind[:, None] * normal[None, :]
    inside = np.all((boundary >= lo - 1e-9) & (boundary <= hi + 1e-9), axis=1)
    near = (behind <= 1e-9) & (behind >= -depth) & np.all(np.abs(along) <= half_width + 1e-9, axis=1)
    return np.nonzero(inside & near)[0]


def wall_pressures(solver, walls, half_width: float) -> list[float]:
    """Normal load per area the fluid puts on each wall patch, ``walls`` = [(point, normal, solid)]
    with ``solid`` = (lo, hi) the wall's box (module docstring); 0 where no fluid touches the patch.

    Only the particles within reach of a patch are searched: those inside the box spanning every
    patch's point ± (half-width + 2h), so a sample costs a few passes over the positions and a
    tree of a few hundred fluid particles, not a tree of the whole fluid."""
    if not walls:
        return []
    st = solver.state
    nf = st.n_fluid
    pos = np.asarray(st.pos, dtype=np.float64)  # no copy in float64
    reach = half_width + 2.0 * solver.h
    points = np.asarray([w[0] for w in walls], dtype=np.float64)
    lo, hi = points.min(axis=0) - reach, points.max(axis=0) + reach
    near = np.all((pos >= lo) & (pos <= hi), axis=1)
    fluid = np.nonzero(near[:nf])[0]
    wall_idx = np.nonzero(near[nf:])[0]
    bpos = pos[nf:][wall_idx]
    tree = cKDTree(pos[fluid])
    out = []
    for point, normal, solid in walls:
        normal = np.asarray(normal, dtype=np.float64)
        idx_b = patch(bpos, point, normal, half_width, solver.h, solid)
        face, corner = at_the_face_end(bpos, idx_b, point, normal, half_width, solver.h, solver.lo, solver.hi,
                                       solver.params.spacing)  # fmt: skip
        wet = face[wetted(bpos[face], point, tree, normal, solver.h, solver.params.spacing)] if len(face) else face
        if len(wet):
            load = _load(solver, tree, fluid, bpos, wall_idx, np.concatenate([face, corner]), normal)
            mean = load / _face_area(bpos[wet], normal, solver.params.spacing)
            along = np.asarray(point, dtype=np.float64) - bpos[wet].mean(axis=0)  # from the wetted face's centre
            along -= (along @ normal) * normal  # along the face only
            out.append(max(0.0, mean + solver.params.rho0 * float(np.dot(solver.g, along))) if mean > 0.0 else mean)
        else:
            out.append(0.0)
    return out


def wetted(face: np.ndarray, point, tree, normal, h: float, spacing: float) -> np.ndarray:
    """Which of the wall particles ``face`` (behind the face through ``point``) the fluid wets: those whose
    column, projected on the face, has a fluid particle (``tree``) in front within h whose offset along the
    face is under ¾Δx on every tangential axis (the fluid's own layer over it; a regular lattice puts its
    layers level with the wall's).

    Dynamic boundary particles hold the fluid off by a gap that grows under the impacts to about half a
    support (at H/40 in a 2-D dam break the fluid's lowest layer sits 12 mm above the floor and 13 mm from
    the wall, against Δx/2 = 3.75 mm at the start): a face within that gap of the floor is dry in the model,
    and counting its area spreads the load of the water above it over face no water touches."""
    normal = np.asarray(normal, dtype=np.float64)
    tang = np.nonzero(normal == 0.0)[0]
    on_face = face - ((face - np.asarray(point, dtype=np.float64)) @ normal)[:, None] * normal[None, :]
    out = np.zeros(len(face), dtype=bool)
    for k, idx in enumerate(tree.query_ball_point(on_face, h)):
        if idx:
            rel = tree.data[np.asarray(idx)] - on_face[k]
            ahead = rel @ normal > 0.0
            out[k] = bool(np.any(ahead & np.all(np.abs(rel[:, tang]) < 0.75 * spacing, axis=1)))
    return out


def at_the_face_end(
    boundary: np.ndarray, idx_b: np.ndarray, point, normal, half_width: float, depth: float, lo, hi, spacing: float
) -> tuple[np.ndarray, np.ndarray]:
    """(face, corner): the patch ``idx_b`` split where the face ends at the fluid domain's edge (a side
    wall or a box meeting the floor). ``face`` is the patch's particles along the wetted face, inside the
    domain; they alone make the face area. ``corner`` is the boundary particles behind the face and past
    its end (within ``depth`` of both), of whichever wall, taken when the patch reaches the end (its first
    column, within ``spacing``): the fluid at the face's foot pushes on them too, along the normal, so
    their load is the face's. Without them a sensor a few millimetres above the floor counts the corner's
    area and misses its load: in a tank at rest at H/40 one 3 mm up read 0.64 ρ₀g(H − z)."""
    point, normal = np.asarray(point, dtype=np.float64), np.asarray(normal, dtype=np.float64)
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    tang = np.nonzero(normal == 0.0)[0]
    sub = boundary[idx_b]
    inside = np.all((sub[:, tang] >= lo[tang] - 1e-9) & (sub[:, tang] <= hi[tang] + 1e-9), axis=1)
    face = idx_b[inside]
    if not len(face):
        return face, face
    rel = boundary - point
    behind = rel @ normal
    cand = (behind <= 1e-9) & (behind >= -depth)
    corner = np.zeros(len(boundary), dtype=bool)
    for k in tang:
        others = [j for j in tang if j != k]
        window = np.all(np.abs(rel[:, others]) <= half_width + 1e-9, axis=1) if others else True
        if boundary[face, k].min() - lo[k] <= spacing:
            corner |= cand & window & (boundary[:, k] < lo[k] - 1e-9) & (boundary[:, k] >= lo[k] - depth)
        if hi[k] - boundary[face, k].max() <= spacing:
            corner |= cand & window & (boundary[:, k] > hi[k] + 1e-9) & (boundary[:, k] <= hi[k] + depth)
    return face, np.nonzero(corner)[0]


def wall_pressure(solver, point, normal, half_width: float, solid) -> float:
    """:func:`wall_pressures` of one patch."""
    return wall_pressures(solver, [(point, normal, solid)], half_width)[0]


def _face_area(wall: np.ndarray, normal: np.ndarray, spacing: float) -> float:
    """Face area of a patch of wall particles: its columns along the face times their cell. Walls are
    laid at extent/round(extent/Δx), not Δx, so each tangential axis's step is read off the particles
    (one column along an axis: Δx); the normal is along an axis (``probe_wall``)."""
    area, keys = 1.0, []
    for k in np.nonzero(np.asarray(normal) == 0.0)[0]:
        coords = np.unique(np.round(wall[:, k], 9))
        step = float(np.median(np.diff(coords))) if len(coords) > 1 else spacing
        area *= step
        keys.append(np.floor((wall[:, k] - coords[0]) / step + 0.25).astype(np.int64))
    columns = len(np.unique(np.stack(keys, axis=1), axis=0)) if keys else 1
    return columns * area


def _load(solver, tree, fluid, bpos: np.ndarray, wall_idx, idx_b: np.ndarray, normal: np.ndarray) -> float:
    """The fluid's normal load on the particles ``idx_b`` (N, or N/m in 2-D); ``tree`` holds the fluid
    particles ``fluid`` (indices), ``bpos`` the
    boundary particles ``wall_idx`` (indices among the boundary particles), ``idx_b`` the patch in ``bpos``."""
    st, prm = solver.state, solver.params
    nf, h, m, dim = st.n_fluid, solver.h, solver.m, solver.dim
    near = tree.query_ball_point(bpos[idx_b], h)
    counts = np.fromiter((len(x) for x in near), dtype=np.int64, count=len(near))
    if counts.sum() == 0:
        return 0.0
    local_a = np.concatenate([np.asarray(x, dtype=np.int64) for x in near if x])  # every (fluid a, wall b) pair
    local_b = np.repeat(idx_b, counts)
    rab = tree.data[local_a] - bpos[local_b]
    a, b = fluid[local_a], wall_idx[local_b]
    r2 = np.sum(rab**2, axis=1)
    r = np.sqrt(r2)
    f = kernel_f(r, h, dim, prm.kernel)
    rho_a, rho_b = st.rho[a].astype(np.float64), st.rho[nf + b].astype(np.float64)
    p_a, p_b = st.p[a].astype(np.float64), st.p[nf + b].astype(np.float64)
    if prm.pressure_form == "wcsph":
        pterm = p_a / rho_a**2 + p_b / rho_b**2
    else:
        pterm = (p_a + p_b) / (2.0 * rho_a * rho_b)
    vel = st.vel[a].astype(np.float64)
    if prm.viscosity == "artificial":
        vdotr = np.sum(vel * rab, axis=1)
        c_r = solver.kvb * np.minimum(vdotr, 0.0) * f / ((rho_a + rho_b) * (r2 + solver.eps2))
        c_v = np.zeros_like(r)
    else:
        c_r = np.zeros_like(r)
        c_v = -solver.kvb * kernel_lap(r, h, dim, prm.kernel) / (rho_a * rho_b)
    on_fluid = m * m * ((c_r - pterm * f)[:, None] * rab + c_v[:, None] * vel)  # the wall's force on the fluid
    return float(on_fluid.sum(axis=0) @ normal)
