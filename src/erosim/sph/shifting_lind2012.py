"""Fickian particle shifting (Lind, Xu, Stansby & Rogers 2012), with Skillen et al.'s (2013) coefficient
and a free surface found by the divergence of position (Lee et al. 2008); ``sph.shifting = "fickian"``.

Why: with the pressure clamped at zero (``pressure_floor = "zero"``) nothing pushes apart two particles
whose density has fallen below ρ₀ — a thin overflow sheet, spray — so they can drift onto each other
and clump (pairs closer than a quarter spacing), and a clump's density diffusion then bounds the step
(:mod:`erosim.sph.diffusion_limit_molteni2009`). Shifting moves each particle a little down its
concentration gradient every step, which keeps the distribution regular. Per fluid particle i, over its
neighbours j (fluid and boundary particles, V_j = m/ρ_j) and the wall-weight walls' share:

    ∇C_i  = Σ_j V_j ∇W_ij,                                     (the concentration gradient)
    ∇C̃_i = Σ_j V_j (1 + R (W_ij/W(Δx))⁴) ∇W_ij,  R = 0.2      (Lind's anti-pairing weight)
    ∇·r_i = −Σ_j V_j r_ij·∇W_ij                                (d in the bulk, less at a free surface)
    C_i   = Σ_j V_j W_ij  (j = i included)                     (C_full inside a full lattice)
    δr_i  = −D_i ∇C̃_i,   D_i = A h_s |v_i| Δt                  (A = ``shifting_coefficient``, default 2)

and near a free surface (∇·r_i below 1.5 in 2-D, 2.75 in 3-D: DualSPHysics' thresholds, which also
catch a surface particle beside a wall, whose wall share fills part of its support) and C_i < C_full
(a clump in the bulk also lowers ∇·r, as its particles leave their lattice sites, but its C exceeds
C_full, so it is shifted whole and comes apart) only the part of δr_i tangent to it
is kept, the surface's normal being n_i = −∇C_i/|∇C_i| (Lind et al. 2012): the surface is not
diffused away, but particles slide apart along it. D_i scales with the particle's own speed (Skillen
et al.), so a shift is a small fraction of the particle's own advection and water at rest is left
alone (with the flow's largest speed instead, as Sun et al. 2017 scale it, the layers under a still
reservoir's surface would be pushed up into it every step while an overflow runs fast elsewhere); a
shift is at most a tenth of a spacing per step (a safeguard: A h_s |v_i| Δt |∇C̃| is rarely above
|v_i| Δt). Velocities and densities are not corrected for the shift (the Taylor term δr·∇φ of
some schemes is left out: a shift is a small fraction of the particle's own displacement).

Walls of wall-weight curves (:mod:`erosim.sph.boundaries.wall_weight_harada2007`) add what their
flat layer of wall particles at ρ₀ would add, from the baked curves at the particle's distance l:
∇C += (m/ρ₀) G(l) n, ∇·r −= (m/ρ₀)(H(l) + (d − 1) T(l)), C += Z(l)/ρ₀
(``DistanceWall.shifting_share``: heightfield, plane and voxel walls); the anti-pairing weight is not
applied to them. Where two such walls meet in a concave corner their shares overlap (as their
density shares do), so a particle in the corner is shifted slightly out of it. Boundary particles
are neighbours like fluid ones. A boundary that gives no share (the box's reflecting walls,
``walls = "reflect"``) looks like a free surface to the particles next to it, which then only
slide along it.

The pass is one more loop over the neighbour lists per step, at the start of the step (the lists are
valid there), before the drift; the boundaries' constraint after the drift still keeps every particle
out of the solids. Written here because the SPH libraries the project uses do not expose a shifting
step for these lists.

References: S.J. Lind, R. Xu, P.K. Stansby, B.D. Rogers, J. Comput. Phys. 231 (2012) 1499–1523;
A. Skillen, S. Lind, P.K. Stansby, B.D. Rogers, Comput. Methods Appl. Mech. Engrg. 265 (2013) 163–173;
E.-S. Lee et al., J. Comput. Phys. 227 (2008) 8417–8436; P.N. Sun et al., Comput. Phys. Commun. 215
(2017) 102–118.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from erosim.kernels import sph_kernels as K

#: Lind et al.'s anti-pairing weight R (W/W(Δx))^4
PAIRING = 0.2
#: ∇·r below which a particle is at a free surface (DualSPHysics' defaults), by dimension
SURFACE = {2: 1.5, 3: 2.75}
#: a shift is at most this fraction of the spacing per step
MAX_SHIFT = 0.1


@njit(inline="always", cache=True)
def _gradients(w, gradf, i, pos, rho, start, nbr, m, h, inv_wdx, gc, gct, divr, conc):
    d = pos.shape[1]
    cs = m / rho[i] * w(0.0, h)
    g0 = g1 = g2 = 0.0
    t0 = t1 = t2 = 0.0
    dv = 0.0
    h2 = h * h
    for s in range(np.uint64(start[i]), np.uint64(start[i + 1])):  # unsigned: no wraparound checks (forces.py)
        j = np.uint64(nbr[s])
        dx = pos[i, 0] - pos[j, 0]
        dy = pos[i, 1] - pos[j, 1]
        dz = pos[i, 2] - pos[j, 2] if d == 3 else 0.0
        r2 = dx * dx + dy * dy + dz * dz
        if r2 >= h2 or r2 == 0.0:
            continue
        r = math.sqrt(r2)
        vj = m / rho[j]
        vf = vj * gradf(r, h)
        wij = w(r, h)
        cs += vj * wij
        q = wij * inv_wdx
        vt = vf * (1.0 + PAIRING * q * q * q * q)
        g0 += vf * dx
        g1 += vf * dy
        g2 += vf * dz
        t0 += vt * dx
        t1 += vt * dy
        t2 += vt * dz
        dv -= vf * r2
    gc[i, 0] = g0
    gc[i, 1] = g1
    gct[i, 0] = t0
    gct[i, 1] = t1
    if d == 3:
        gc[i, 2] = g2
        gct[i, 2] = t2
    divr[i] = dv
    conc[i] = cs


# one small cached driver per kernel and dimension: Numba cannot cache a driver that takes functions as
# arguments (the same pattern as the force pass's drivers, erosim.sph.forces)
@njit(parallel=True, cache=True)
def gradients_wendland_3d(pos, rho, start, nbr, n_fluid, m, h, inv_wdx, gc, gct, divr, conc):
    for i in prange(n_fluid):
        _gradients(K.wendland_w_3d, K.wendland_f_3d, i, pos, rho, start, nbr, m, h, inv_wdx, gc, gct, divr, conc)


@njit(parallel=True, cache=True)
def gradients_wendland_2d(pos, rho, start, nbr, n_fluid, m, h, inv_wdx, gc, gct, divr, conc):
    for i in prange(n_fluid):
        _gradients(K.wendland_w_2d, K.wendland_f_2d, i, pos, rho, start, nbr, m, h, inv_wdx, gc, gct, divr, conc)


@njit(parallel=True, cache=True)
def gradients_muller_3d(pos, rho, start, nbr, n_fluid, m, h, inv_wdx, gc, gct, divr, conc):
    for i in prange(n_fluid):
        _gradients(K.muller_w_3d, K.muller_f_3d, i, pos, rho, start, nbr, m, h, inv_wdx, gc, gct, divr, conc)


@njit(parallel=True, cache=True)
def gradients_muller_2d(pos, rho, start, nbr, n_fluid, m, h, inv_wdx, gc, gct, divr, conc):
    for i in prange(n_fluid):
        _gradients(K.muller_w_2d, K.muller_f_2d, i, pos, rho, start, nbr, m, h, inv_wdx, gc, gct, divr, conc)


GRADIENTS = {
    ("wendland", 3): gradients_wendland_3d,
    ("wendland", 2): gradients_wendland_2d,
    ("muller", 3): gradients_muller_3d,
    ("muller", 2): gradients_muller_2d,
}


@njit(parallel=True, cache=True)
def shift(pos, vel, n_fluid, gc, gct, divr, conc, coeff, surface, full, max_shift):
    """r_i += δr_i = −coeff |v_i| ∇C̃_i, tangential only where ∇·r_i < ``surface`` and C_i < ``full``,
    |δr_i| ≤ ``max_shift``."""
    d = pos.shape[1]
    for i in prange(n_fluid):
        v2 = 0.0
        for a in range(d):
            v2 += vel[i, a] * vel[i, a]
        ci = coeff * math.sqrt(v2)
        s0 = -ci * gct[i, 0]
        s1 = -ci * gct[i, 1]
        s2 = -ci * gct[i, 2] if d == 3 else 0.0
        if divr[i] < surface and conc[i] < full:
            n0 = gc[i, 0]
            n1 = gc[i, 1]
            n2 = gc[i, 2] if d == 3 else 0.0
            nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            if nn > 0.0:
                sn = (s0 * n0 + s1 * n1 + s2 * n2) / (nn * nn)
                s0 -= sn * n0
                s1 -= sn * n1
                s2 -= sn * n2
        mag = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        if mag > max_shift:
            k = max_shift / mag
            s0 *= k
            s1 *= k
            s2 *= k
        pos[i, 0] += s0
        pos[i, 1] += s1
        if d == 3:
            pos[i, 2] += s2


class FickianShifting:
    """The shifting step of a solver (see the module docstring); ``apply(dt)`` before each drift."""

    def __init__(self, solver):
        prm = solver.params
        self.solver = solver
        self.coefficient = prm.shifting_coefficient
        self._pass = GRADIENTS[(prm.kernel, solver.dim)]
        wdx = float(K.kernel_w(np.array([prm.spacing]), solver.h, solver.dim, prm.kernel)[0])
        self.inv_wdx = 1.0 / wdx if wdx > 0 else 0.0
        self.surface = SURFACE[solver.dim]
        # C of a particle inside a full lattice: 1.00 in 2-D, 1.03 in 3-D at h = 2Δx
        self.full = prm.spacing**solver.dim * K.lattice_sum(prm.spacing, solver.h, solver.dim, prm.kernel)
        self.max_shift = MAX_SHIFT * prm.spacing
        self._shares = [b.shifting_share for b in solver.boundaries if getattr(b, "shifting_share", None)]
        self._buf = (np.empty((0, solver.dim)), np.empty((0, solver.dim)), np.empty(0), np.empty(0))

    def gradients(self):
        """(∇C, ∇C̃, ∇·r, C) of the fluid particles, walls' shares included."""
        s = self.solver
        st = s.state
        nf = st.n_fluid
        if len(self._buf[2]) < nf:  # grown with the fluid, not allocated each step; the pass writes every row
            self._buf = (np.empty((2 * nf, s.dim)), np.empty((2 * nf, s.dim)), np.empty(2 * nf), np.empty(2 * nf))
        gc, gct, divr, conc = (a[:nf] for a in self._buf)
        self._pass(st.pos, st.rho, s.start, s.nbr, nf, s.m, s.h, self.inv_wdx, gc, gct, divr, conc)
        for share in self._shares:
            share(s, gc, gct, divr, conc)
        return gc, gct, divr, conc

    def apply(self, dt: float) -> None:
        s = self.solver
        if s.state.n_fluid == 0:
            return
        gc, gct, divr, conc = self.gradients()
        coeff = self.coefficient * 0.5 * s.h * dt
        st = s.state
        shift(st.pos, st.vel, st.n_fluid, gc, gct, divr, conc, coeff, self.surface, self.full, self.max_shift)
