"""The weakly compressible SPH solver (SPEC SPH-1 … SPH-13): state, neighbour lists and the step.

Step order (SPH-13, with leapfrog's kicks around it): kick + drift + walls + EOS → neighbour lists
(rebuilt only when some particle moved more than half the Verlet skin; particles re-sorted by cell at
the rebuild) → [summation density] → one fused pressure/viscosity/continuity pass → kick.

With boundary models (:mod:`erosim.sph.boundaries`) the step is: kick + drift + EOS → each
boundary's ``constrain`` and ``predict`` → neighbour lists → boundaries' ``density`` → [summation
density] → the fused fluid pass → boundaries' ``forces`` → kick + corrector → boundaries' ``correct``.

Storage is :class:`~erosim.sph.state.ParticleState` (structure-of-arrays, one index space): fluid
particles ``0 … n_fluid−1`` (kept sorted by cell, so their internal order changes; ``ids`` labels
each particle, and outputs come in label order), then the fixed boundary particles. Particles can be
added and removed between steps (:meth:`SPHSolver.add_fluid`, :meth:`SPHSolver.remove_fluid`). The
variants of :class:`~erosim.sph.params.SPHParams` and the boundary models are resolved here, once,
into the functions the step calls (no flags in the hot loops).
"""

from __future__ import annotations

import math
from contextlib import contextmanager

import numba
import numpy as np

from erosim.core.errors import ConfigError, InstabilityError
from erosim.kernels import neighbours as nb
from erosim.kernels.sph_kernels import kernel_w, lattice_sum
from erosim.sph import diffusion_limit_molteni2009 as diffusion_limit
from erosim.sph import eos as eos_mod
from erosim.sph import forces, integrators
from erosim.sph.boundaries import particles as bparticles
from erosim.sph.boundaries.base import Boundary
from erosim.sph.boundaries.box import BoxWalls
from erosim.sph.boundaries.distance_wall import walls_follow
from erosim.sph.params import SPHParams
from erosim.sph.shifting_lind2012 import FickianShifting
from erosim.sph.state import ParticleState

_STATE_SCALARS = ("t", "steps", "c", "b", "gamma", "m", "rebuilds", "vmax", "amax", "kmax", "last_dt")
_FIELDS = ("pos", "vel", "rho", "p", "acc", "drho", "rho_old", "ids", "ref")


def _as_points(a, dim: int, what: str) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != dim:
        raise ConfigError(
            f"{what} must be an (n, {dim}) array of positions, got shape {a.shape}; check the scenario's dimension."
        )
    if not np.all(np.isfinite(a)):
        raise ConfigError(f"{what} contains NaN or infinite coordinates; check the scenario geometry.")
    return a


class SPHSolver:
    """Weakly compressible SPH in 2-D or 3-D; see :mod:`erosim.sph` for the interface.

    A model of :class:`~erosim.simulation.simulation.Simulation`: ``advance()`` is one step, ``time``
    the simulated time (s), ``state_dict()`` / ``load_state_dict()`` resume it bit for bit.
    """

    name = "fluid"

    def __init__(
        self,
        params: SPHParams,
        fluid_pos,
        *,
        boundary_pos=None,
        domain_lo,
        domain_hi,
        obstacles=(),
        fluid_vel=None,
        seed: int = 0,
        boundaries: list[Boundary] = (),
    ):
        self.params = prm = params
        self.dim = d = int(prm.dim)
        self.seed = int(seed)
        self.dtype = np.dtype(prm.precision)
        fluid = _as_points(fluid_pos, d, "fluid positions")
        if fluid.shape[0] == 0 and prm.sound_speed <= 0:
            raise ConfigError(
                "The scenario has no fluid particles; give the fluid block a positive size (a run that starts "
                "dry and fills from sources needs sph.sound_speed set)."
            )
        self.lo = np.asarray(domain_lo, np.float64).reshape(d)
        self.hi = np.asarray(domain_hi, np.float64).reshape(d)
        if np.any(self.hi <= self.lo):
            raise ConfigError(
                f"The domain box is empty (lo = {self.lo.tolist()}, hi = {self.hi.tolist()}); "
                "make every hi larger than lo."
            )
        obs = [(np.asarray(a, np.float64).reshape(d), np.asarray(b, np.float64).reshape(d)) for a, b in obstacles]
        self.olo = np.array([o[0] for o in obs], np.float64).reshape(len(obs), d)
        self.ohi = np.array([o[1] for o in obs], np.float64).reshape(len(obs), d)
        if np.any(self.ohi <= self.olo):
            raise ConfigError("An obstacle box is empty; give every obstacle hi > lo on each axis.")
        outside = np.any((fluid < self.lo) | (fluid > self.hi), axis=1)
        if outside.any():
            k = int(np.argmax(outside))
            raise ConfigError(
                f"{int(outside.sum())} fluid particles lie outside the domain box "
                f"{self.lo.tolist()}–{self.hi.tolist()} (first at {fluid[k].round(6).tolist()}); "
                "move the fluid block inside the domain or enlarge the domain."
            )
        for k in range(len(obs)):
            inside = np.all((fluid > self.olo[k]) & (fluid < self.ohi[k]), axis=1)
            if inside.any():
                raise ConfigError(
                    f"{int(inside.sum())} fluid particles lie inside obstacle {k} "
                    f"({self.olo[k].tolist()}–{self.ohi[k].tolist()}); "
                    "move the fluid block or the obstacle."
                )

        # ---- boundary models (chosen here, once) and the particles they lay
        self.boundaries = self._default_boundaries(boundary_pos) + list(boundaries)
        names = [bd.name for bd in self.boundaries]
        if len(set(names)) != len(names):
            raise ConfigError(f"Boundary models must have distinct names, got {names}.")
        parts = [x for x in (bd.particles() for bd in self.boundaries) if x is not None]
        bnd = np.concatenate([_as_points(x, d, "boundary positions") for x in parts]) if parts else np.zeros((0, d))
        nf = fluid.shape[0]

        # ---- constants
        g = np.asarray(prm.gravity_vector(), np.float64)
        self.g = g
        gnorm = float(np.linalg.norm(g))
        self.h = prm.support()
        self.hs = 0.5 * self.h
        self._w0 = float(kernel_w(np.zeros(1), self.h, d, prm.kernel)[0])  # W(0, h), for rho_min
        vel0 = np.zeros_like(fluid) if fluid_vel is None else _as_points(fluid_vel, d, "fluid velocities")
        if vel0.shape != fluid.shape:
            raise ConfigError(
                "fluid velocities must have one row per fluid particle; check the scenario's initial velocity."
            )
        v0max = float(np.sqrt((vel0**2).sum(axis=1)).max(initial=0.0))
        up = -g / gnorm if gnorm > 0 else np.eye(d)[-1]
        # the fastest a particle can fall: from the fluid's top to the domain's lowest point
        bottom = float(np.minimum(up * self.lo, up * self.hi).sum())
        self.fluid_height = float((fluid @ up).max(initial=bottom)) + 0.5 * prm.spacing - bottom
        c = prm.sound_speed_for(self.fluid_height, v0max)
        if c <= 0:
            raise ConfigError(
                "Cannot choose a sound speed without gravity or motion; set sph.sound_speed (m/s), "
                "e.g. 10× the fastest expected flow speed."
            )
        self.c = float(c)
        b, gam = eos_mod.eos_constants(prm.eos, prm.rho0, self.c, prm.gamma, prm.stiffness)
        self.b, self.gamma = float(b), float(gam)
        if prm.eos == "linear" and prm.stiffness > 0:
            self.c = math.sqrt(prm.stiffness)  # the law's own sound speed sets the step limit
        self.pmin = 0.0 if prm.floor_is_zero() else -math.inf
        self.nu = prm.mu / prm.rho0 if prm.viscosity == "laminar" else 0.0

        # ---- variants, chosen once
        self._pass = forces.fluid_driver(d, prm.kernel, prm.pressure_form, prm.viscosity)
        self._sumpass = forces.summation_driver(d, prm.kernel)
        self._leapfrog = prm.integrator == "leapfrog"
        self._summation = self.summation = prm.density == "summation"
        self.eps2 = 0.01 * self.hs**2
        self._coefficients()
        self.kmax = 0.0  # max K_i of the density diffusion at the last force pass (diffusion_limit_molteni2009)

        # ---- state (fluid first, then boundary)
        self.state = st = ParticleState(d, self.dtype, nf, bnd.shape[0])
        st.pos[:nf] = fluid
        st.pos[nf:] = bnd
        st.vel[:nf] = vel0
        st.rho[:] = prm.rho0
        st.ref[:] = st.pos[:nf]
        self.m = prm.rho0 * prm.spacing**d
        self.t = 0.0
        self.steps = 0
        self.rebuilds = 0
        self._disp2 = np.zeros(integrators.NCHUNK, np.float64)
        self._v2 = np.zeros(integrators.NCHUNK, np.float64)
        self._a2 = np.zeros(integrators.NCHUNK, np.float64)
        self._grid = nb.Grid(d)
        self.nbr = np.empty(0, np.int32)
        self._tmp = np.empty(64, np.int32)
        self.rc = self.h * (1.0 + prm.skin)
        self._workspace()

        self._rebuild(reorder=True)
        if self._summation:
            self._calibrate_mass()
        for bd in self.boundaries:
            bd.bind(self)
        self._hooks()
        self._shifting = FickianShifting(self) if self.params.shifting == "fickian" else None
        if prm.initial_pressure != "zero" and gnorm > 0:
            self._hydrostatic_start(up, gnorm)
        self._pressure_all()
        self._evaluate()
        self._norms()
        self.last_dt = 0.0
        if prm.dt > 0:
            lim = self.dt_limit()
            if prm.dt > lim:
                raise ConfigError(
                    f"Setting 'sph.dt' = {prm.dt:g} s is above the stable step limit {lim:.3g} s "
                    f"(CFL {prm.cfl}·h_s/(c + |v|max) with c = {self.c:.3g} m/s, force, viscous and "
                    "density-diffusion limits); "
                    f"use sph.dt ≤ {lim:.3g} or sph.dt = 0 for adaptive steps."
                )

    # ------------------------------------------------------------------ set-up helpers

    def _default_boundaries(self, boundary_pos) -> list[Boundary]:
        """Box reflection always; boundary particles for ``walls = "particles"`` and for given positions
        (given ones first, then the box walls, then the obstacles)."""
        prm, d = self.params, self.dim
        models: list[Boundary] = [BoxWalls(self.lo, self.hi, self.olo, self.ohi)]
        parts = []
        if boundary_pos is not None:
            parts.append(_as_points(boundary_pos, d, "boundary positions"))
        if prm.walls == "particles":
            parts.append(bparticles.box_walls(self.lo, self.hi, prm.spacing, prm.layers()))
            for k in range(self.olo.shape[0]):
                parts.append(bparticles.box_obstacle(self.olo[k], self.ohi[k], prm.spacing, prm.layers()))
        if parts:
            models.append(bparticles.BoundaryParticles(np.concatenate(parts)))
        return models

    def _hooks(self) -> None:
        """The boundary passes of every step, collected once (no per-step branching on models)."""
        bs = self.boundaries
        self._constrain = [b.constrain for b in bs if b.constrain is not None]
        self._predict = [b.predict for b in bs if b.predict is not None]
        self._density = [b.density for b in bs if b.density is not None]
        self._forces = [b.forces for b in bs if b.forces is not None]
        self._correct = [b.correct for b in bs if b.correct is not None]
        self._moved = [b.moved for b in bs if b.moved is not None]
        self._step_limits = [b.step_limit for b in bs if b.step_limit is not None]

    def _workspace(self) -> None:
        """Neighbour-list buffers sized for the current particle counts (after particles come or go)."""
        n, nf, nb_ = self.state.n, self.state.n_fluid, self.state.n_boundary
        self._count_f = np.empty(n, np.int64)
        self._count_b = np.empty(n, np.int64)
        self.start = np.empty(n + 1, np.int64)
        self.mid = np.empty(n, np.int64)
        self._cstart = np.empty(nf + 1, np.int64)
        self._tcount = np.empty(max(1, nb_), np.int64)
        self._have_counts = False
        self._krate = np.zeros(n, np.float64)  # K_i per particle, written by the fused pass

    def _coefficients(self) -> None:
        """The pair pass's coefficients from the parameters and the sound speed c: k_v (artificial: 2αh_s c;
        laminar: μ), its fluid–wall pairs' k_vb (k_v, or 0 for free-slip walls), the density diffusion's
        k_δ = 2δh_s c (0 with summation density) and k_h = ρ₀/c²."""
        prm = self.params
        self.kv = 2.0 * prm.alpha * self.hs * self.c if prm.viscosity == "artificial" else prm.mu
        self.kvb = self.kv if prm.wall_viscosity == "fluid" else 0.0
        self.kdiff = 0.0 if self._summation else 2.0 * prm.density_diffusion * self.hs * self.c
        self.kh = prm.rho0 / self.c**2

    def _calibrate_mass(self) -> None:
        """Summation density: m such that an interior lattice particle has ρ = ρ₀ (not ρ₀Δx^d·ΣW)."""

        self.m = self.params.rho0 / lattice_sum(self.params.spacing, self.h, self.dim, self.params.kernel)

    def _hydrostatic_start(self, up: np.ndarray, gnorm: float) -> None:
        """ρ from p = ρ₀|g|(H − z) below the fluid's top H (boundary particles: at least ρ₀)."""
        prm, st = self.params, self.state
        z = st.pos.astype(np.float64) @ up
        if st.n_fluid == 0:
            return
        top = float(z[: st.n_fluid].max()) + 0.5 * prm.spacing
        depth = np.clip(top - z, 0.0, None)
        rho = eos_mod.density_for_pressure(prm.rho0 * gnorm * depth, prm.rho0, self.b, self.gamma)
        if not self._summation:
            st.rho[:] = rho
            if prm.initial_pressure == "hydrostatic-consistent":
                deep = depth[: st.n_fluid] >= self.h
                st.rho[: st.n_fluid][deep] += self._kernel_shortfall()[deep]
        st.rho[st.n_fluid :] = np.maximum(st.rho[st.n_fluid :], prm.rho0)

    def _kernel_shortfall(self) -> np.ndarray:
        """S_i − S_ref per fluid particle: its kernel sum S_i = m(W(0) + Σ_j W_ij) over fluid and boundary
        neighbours plus the particle-free walls' share Z(l_i) (their ``add_density``), less the sum S_ref of a
        particle inside the lattice of spacing Δx.

        Continuity density carries ρ_i − S_i unchanged as particles move (dρ_i/dt = dS_i/dt for the fluid
        pairs and the wall term m(v·n)G = dZ/dt), so a start ρ_i = ρ^H(z_i) + S_i − S_ref arrives at the
        hydrostatic density where the particle's surroundings fill up to the lattice's — a lattice row that
        does not fit a curved wall or a concave edge settles into its gap without the gap becoming pressure.
        A wall with no density share of its own (the box's reflection alone) counts as missing neighbours.
        """

        st = self.state
        total = np.zeros(st.n)
        self._sumpass(st.pos, self.start, self.nbr, st.n_fluid, self.m, self.h, total)
        for bd in self.boundaries:
            add = getattr(bd, "add_density", None)
            if add is not None:
                add(self, total)
        ref = self.m * lattice_sum(self.params.spacing, self.h, self.dim, self.params.kernel)
        return total[: st.n_fluid] - ref

    @property
    def rho_min(self) -> float:
        """The density floor m·W(0, h) (``density_floor = "lone"``; −inf when "off"): the summation density
        of a particle with no neighbours, the least a particle's density can be. Continuity density has
        no such bound; in tearing spray one forward step can carry it through zero, where the 1/ρ of the
        viscous and pressure terms blow up (docs/sph.md, "A density floor")."""
        return self.m * self._w0 if self.params.density_floor == "lone" else -math.inf

    def eos_args(self) -> tuple[float, float, float, float]:
        """(ρ₀, B, γ, p_min) of :func:`erosim.sph.eos.tait`, for boundary passes."""
        return self.params.rho0, self.b, self.gamma, self.pmin

    def _pressure_all(self) -> None:
        st = self.state
        forces.pressure_pass(st.rho, self.params.rho0, self.b, self.gamma, self.pmin, 0, st.n, st.p)

    # ------------------------------------------------------------------ state views
    @property
    def n_fluid(self) -> int:
        return self.state.n_fluid

    @property
    def n_boundary(self) -> int:
        return self.state.n_boundary

    @property
    def n(self) -> int:
        return self.state.n

    pos = property(lambda self: self.state.pos, doc="(n, dim) positions, internal order (fluid, then boundary)")
    vel = property(lambda self: self.state.vel, doc="(n, dim) velocities, internal order")
    rho = property(lambda self: self.state.rho, doc="(n,) densities, internal order")
    p = property(lambda self: self.state.p, doc="(n,) pressures, internal order")
    acc = property(lambda self: self.state.acc, doc="(n_fluid, dim) accelerations, internal order")
    drho = property(lambda self: self.state.drho, doc="(n,) density rates, internal order")
    ids = property(lambda self: self.state.ids, doc="(n_fluid,) particle labels, internal order")

    # ------------------------------------------------------------------ neighbour lists

    def _rebuild(self, reorder: bool, source: np.ndarray | None = None) -> None:
        """Hash grid + Verlet lists from ``source`` positions (default: current), optional cell re-sort."""
        st, grid = self.state, self._grid
        nf, n = st.n_fluid, st.n
        src = st.pos if source is None else source
        if n == 0:  # nothing yet (a fluid that starts dry and fills from its sources)
            self.start[:] = 0
            self.active = np.zeros(0, np.int64)
            self.rebuilds += 1
            return
        try:
            nb.build_grid(grid, src, self.rc)
        except ValueError as exc:
            raise ConfigError(
                f"The particles spread too far for the neighbour grid ({exc}); "
                "enlarge sph.spacing or shrink the domain."
            ) from None
        if reorder:
            ci = grid.cell_index[:n]
            fl = ci < nf
            perm = ci[fl]
            if not np.array_equal(perm, np.arange(nf)):
                st.permute_fluid(perm, skip=("ref",))
                self._count_f[:nf] = self._count_f[:nf][perm]
                self._count_b[:nf] = self._count_b[:nf][perm]
                grid.particle_cell[:nf] = grid.particle_cell[:nf][perm]
                ci[fl] = np.arange(nf)
            src = st.pos
        r2 = self.rc * self.rc
        done = False
        if self._have_counts:
            # one pass into slots sized by the last counts, then compact (falls back when a slot overflows)
            cap_total = nb.capacities(self._count_f, self._count_b, nf, self._cstart)
            need = int(cap_total) + int(self._count_b[:nf].sum()) * 2 + 64
            if self.nbr.size < need:
                self.nbr = np.empty(int(need * 1.2), np.int32)
            over = nb.fill_capped(
                src, grid.spos, nf, grid.particle_cell, grid.cell_nbrs, grid.cell_start, grid.cell_index, r2,
                self._cstart, self.nbr, self._count_f, self._count_b,
            )  # fmt: skip
            if over == 0:
                bmax = int(self._count_b[:nf].max(initial=0))
                if self._tmp.size < bmax:
                    self._tmp = np.empty(bmax * 2 + 16, np.int32)
                nb.compact(self._cstart, self._count_f, self._count_b, nf, self.start, self.mid, self.nbr, self._tmp)
                total = int(self.start[nf]) + int(self._count_b[:nf].sum())
                done = total <= self.nbr.size
        if not done:
            nb.count_neighbours(
                src, grid.spos, nf, nf, grid.particle_cell, grid.cell_nbrs, grid.cell_start, grid.cell_index, r2,
                self._count_f, self._count_b,
            )  # fmt: skip
            total = nb.offsets(self._count_f, self._count_b, nf, self.start, self.mid)
            total += int(self._count_b[:nf].sum())  # room for the boundary particles' (transposed) lists
            if self.nbr.size < total:
                self.nbr = np.empty(int(total * 1.2) + 64, np.int32)
            nb.fill_neighbours(
                src, grid.spos, nf, nf, grid.particle_cell, grid.cell_nbrs, grid.cell_start, grid.cell_index, r2,
                self.start, self.mid, self.nbr,
            )  # fmt: skip
            self._have_counts = True
        self.active = nb.transpose_boundary(nf, n, self.start, self.mid, self.nbr, self._tcount)
        st.ref[:] = src[:nf]
        self.rebuilds += 1
        for bd in self.boundaries:
            bd.lists_built(self)

    def _maybe_rebuild(self) -> None:
        integrators.max_displacement(self.state.pos, self.state.ref, self.state.n_fluid, self._disp2)
        half = 0.5 * (self.rc - self.h)
        # a pair's distance changes by at most the two particles' displacements: each below half the skin
        moved = max((fn(self) for fn in self._moved), default=0.0)
        if float(self._disp2.max()) >= half * half or moved >= half:
            self._rebuild(reorder=(self.rebuilds % self.params.reorder_every) == 0)

    # ------------------------------------------------------------------ sources and sinks

    def add_fluid(self, pos, vel=None, *, source: str, **fields) -> int:
        """Add fluid particles (m, ρ₀, EOS pressure) between steps; returns how many were added.

        ``fields`` gives values of registered per-particle fields for them. Until the next force
        evaluation their acceleration is gravity alone and their density rate 0 (a new particle's
        first half kick; the pair forces act from the next step on).
        """
        st = self.state
        pos = _as_points(pos, self.dim, "new fluid positions")
        if vel is not None:
            vel = _as_points(vel, self.dim, "new fluid velocities")
        new = st.add_fluid(pos, vel, rho=self.params.rho0, source=source, **fields)
        st.p[new] = max(eos_mod.tait(self.params.rho0, self.params.rho0, self.b, self.gamma), self.pmin)
        st.acc[new] = self.g
        self._particles_changed()
        return new.stop - new.start

    def remove_fluid(self, mask, *, sink: str) -> int:
        """Remove the fluid particles where ``mask`` (n_fluid, internal order) is true; returns how many."""
        k = self.state.remove_fluid(mask, sink=sink)
        if k:
            self._particles_changed()
        return k

    @contextmanager
    def ground_moving(self, terrain, changed):
        """Around a change of the ground under the fluid (a coupler applying its increment): the distance
        walls' share of the densities is taken before, and after the body has written the new ground
        every boundary is refreshed with ``terrain`` (its ``changed`` nodes) and the walls follow
        (:func:`~erosim.sph.boundaries.distance_wall.walls_follow`)."""
        with walls_follow(self):
            yield
            for b in self.boundaries:
                b.refresh(self, terrain=terrain, changed=changed)

    def replace_boundary(self, positions) -> None:
        """New fixed boundary particles (a refreshed terrain); densities restart at ρ₀."""
        self.state.set_boundary(_as_points(positions, self.dim, "boundary positions"), rho=self.params.rho0)
        self._pressure_all()
        self._particles_changed()

    def _particles_changed(self) -> None:
        """Counts changed: new buffers, new lists (re-sorted), fresh speed maxima."""
        self._workspace()
        self._rebuild(reorder=True)
        self._norms()

    def budget(self) -> dict:
        """Fluid mass added and removed by source and sink (:meth:`ParticleState.budget`)."""
        return self.state.budget(self.m, self.params.rho0)

    # ------------------------------------------------------------------ physics

    def _evaluate(self) -> None:
        """Accelerations and density rates at the current state (one fused neighbour pass + boundary passes)."""
        st = self.state
        g = self.g
        gz = g[2] if self.dim == 3 else 0.0
        if self._summation:
            self._sumpass(st.pos, self.start, self.nbr, st.n_fluid, self.m, self.h, st.rho)
        for fn in self._density:
            fn(self)
        if self._summation:
            self._pressure_all()
        self._pass(
            st.pos, st.vel, st.rho, st.p, self.start, self.mid, self.nbr, st.n_fluid, self.m, self.h, self.kv,
            self.kvb, self.eps2, self.kdiff, self.eps2, self.kh, g[0], g[1], gz, st.acc, st.drho, self._krate,
        )  # fmt: skip
        self.kmax = float(self._krate[: st.n_fluid].max()) if self.kdiff > 0 and st.n_fluid else 0.0
        if self._summation:
            st.drho.fill(0)
        for fn in self._forces:
            fn(self)

    def _norms(self) -> None:
        integrators.max_norms(self.state.vel, self.state.acc, self.state.n_fluid, self._v2, self._a2)
        self.vmax = math.sqrt(float(self._v2.max()))
        self.amax = math.sqrt(float(self._a2.max()))

    def dt_limit(self) -> float:
        """Largest stable step now: min(C h_s/(c+|v|max), C sqrt(h_s/|a|max), 0.125 h_s²/ν, the density
        diffusion's 0.5/max K_i (:mod:`erosim.sph.diffusion_limit_molteni2009`), the boundary models' own
        limits)."""
        lim = integrators.step_limit(self.params.cfl, self.hs, self.c, self.vmax, self.amax, self.nu)
        lim = min(lim, self._diffusion_limit())
        for fn in self._step_limits:
            lim = min(lim, fn(self))
        return lim

    def _diffusion_limit(self) -> float:
        """The density diffusion's own bound, 0.5/max K_i (inf without diffusion), K_i from the last force
        pass; it binds only where particles clump (:mod:`erosim.sph.diffusion_limit_molteni2009`)."""
        return diffusion_limit.SAFETY / self.kmax if self.kmax > 0 else math.inf

    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return self.t

    def advance(self) -> None:
        """One step (the simulation's unit of work)."""
        self.step()

    def _advance_clock(self, dt: float) -> None:
        """Count the step and stop with one sentence when the fluid outran the sound speed or blew up."""
        prm = self.params
        self.t += dt
        self.steps += 1
        self.last_dt = dt
        if not (self.vmax <= prm.max_mach * self.c) or not math.isfinite(self.amax):
            what = (
                "NaN/infinite values"
                if not math.isfinite(self.vmax) or not math.isfinite(self.amax)
                else (f"a fluid speed of {self.vmax:.3g} m/s, above {prm.max_mach:g}× the sound speed {self.c:.3g} m/s")
            )
            raise InstabilityError(
                f"The SPH fluid went unstable at step {self.steps} (t = {self.t:.6g} s) with {what}; "
                "use an adaptive step (sph.dt = 0) or a smaller sph.dt/sph.cfl, or raise sph.sound_speed or sph.alpha."
            )

    def step(self) -> float:
        """Advance one step (fixed or adaptive Δt); returns the Δt used.

        Small systems run on one thread (``parallel_min_particles``); the result does not depend on
        the thread count (per-particle sums run in a fixed order; reductions are maxima).
        """
        if self.state.n_fluid >= self.params.parallel_min_particles:
            return self._step()
        prev = numba.get_num_threads()
        numba.set_num_threads(1)
        try:
            return self._step()
        finally:
            numba.set_num_threads(prev)

    def _step(self) -> float:
        prm, st = self.params, self.state
        dt = prm.dt if prm.dt > 0 else self.dt_limit()
        args = self.eos_args()
        k1, k2 = (0.5 * dt, 0.5 * dt) if self._leapfrog else (dt, 0.0)
        if self._shifting is not None:  # at the step's start, where the neighbour lists are valid
            self._shifting.apply(dt)
        integrators.kick_drift(
            st.pos, st.vel, st.acc, st.rho, st.rho_old, st.drho, st.p, st.n_fluid, k1, dt, *args, self.rho_min
        )
        for fn in self._constrain:
            fn(self)
        for fn in self._predict:
            fn(self, dt)
        self._maybe_rebuild()
        self._evaluate()
        if self._summation:
            np.copyto(st.rho_old, st.rho)
        rho = (st.rho, st.rho_old, st.drho, st.p)
        integrators.correct(st.vel, st.acc, *rho, st.n_fluid, k2, dt, *args, self.rho_min, self._v2, self._a2)
        for fn in self._correct:
            fn(self, dt)
        self.vmax = math.sqrt(float(self._v2.max()))
        self.amax = math.sqrt(float(self._a2.max()))
        self._advance_clock(dt)
        return dt

    # ------------------------------------------------------------------ outputs (label order)

    def _fluid(self, arr: np.ndarray) -> np.ndarray:
        """Fluid rows in label order (the order the fluid was given, then added particles by arrival)."""
        st = self.state
        nf = st.n_fluid
        out = np.empty((nf,) + arr.shape[1:], np.float64)
        if st.next_id == nf:  # labels are a permutation of 0 … n_fluid−1: scatter
            out[st.ids] = arr[:nf]
        else:
            out[:] = arr[:nf][np.argsort(st.ids, kind="stable")]
        return out

    def in_label_order(self, values: np.ndarray) -> np.ndarray:
        """A per-particle array of the fluid in internal order (a boundary's ``distances``, say; the state's
        rows) → label order, the order of :meth:`fluid_positions` and the other ``fluid_*`` getters."""
        return self._fluid(np.asarray(values))

    def fluid_positions(self) -> np.ndarray:
        """(n_fluid, dim) positions in label order (the order fluid_pos was given)."""
        return self._fluid(self.state.pos)

    def fluid_ids(self) -> np.ndarray:
        """(n_fluid,) the particles' labels in label order: each keeps its label for the whole run (rain and
        inflows add new ones), so frames can follow a particle from one to the next."""
        return self._fluid(self.state.ids).astype(np.int64)

    def fluid_velocities(self) -> np.ndarray:
        """(n_fluid, dim) velocities (full step) in label order."""
        return self._fluid(self.state.vel)

    def fluid_density(self) -> np.ndarray:
        """(n_fluid,) densities in label order."""
        return self._fluid(self.state.rho)

    def fluid_pressure(self) -> np.ndarray:
        """(n_fluid,) pressures in label order."""
        return self._fluid(self.state.p)

    def fluid_accelerations(self) -> np.ndarray:
        """(n_fluid, dim) accelerations of the last evaluation, in label order."""
        return self._fluid(self.state.acc)

    def fluid_field(self, name: str) -> np.ndarray:
        """A registered per-particle field (``state.register``) of the fluid, in label order."""
        return self._fluid(getattr(self.state, name))

    def boundary_positions(self) -> np.ndarray:
        """(n_boundary, dim) fixed boundary particle positions (given ones first, then walls, obstacles)."""
        return self.state.pos[self.state.n_fluid :].astype(np.float64)

    def boundary_pressure(self) -> np.ndarray:
        """(n_boundary,) boundary particle pressures."""
        return self.state.p[self.state.n_fluid :].astype(np.float64)

    def neighbour_stats(self) -> dict:
        """Mean/min/max number of neighbours within the support h per fluid particle, and list length."""
        nf = self.state.n_fluid
        cnt = _count_within(self.state.pos, self.start, self.nbr, nf, self.h * self.h)
        lens = np.diff(self.start[: nf + 1])
        if nf == 0:
            return {"mean": 0.0, "min": 0, "max": 0, "list_mean": 0.0, "rebuilds": int(self.rebuilds)}
        return {
            "mean": float(cnt.mean()),
            "min": int(cnt.min()),
            "max": int(cnt.max()),
            "list_mean": float(lens.mean()),
            "rebuilds": int(self.rebuilds),
        }

    # ------------------------------------------------------------------ checkpoints

    def state_dict(self) -> dict:
        """Everything the next step reads: the particle state (internal order), scalars, boundary models."""
        out = self.state.state_dict()
        out.update({k: getattr(self, k) for k in _STATE_SCALARS})
        for bd in self.boundaries:
            out.update({f"boundary.{bd.name}.{k}": v for k, v in bd.state_dict().items()})
        return out

    def load_state_dict(self, state: dict) -> None:
        """Restore :meth:`state_dict`; the next steps are bit-identical to the uninterrupted run."""
        pos = np.asarray(state.get("pos", np.zeros((0, 0))))
        if pos.ndim != 2 or pos.shape[1] != self.dim or int(np.asarray(state.get("initial", -1))) != self.state.initial:
            raise ConfigError(
                "The checkpoint was written for a different particle set; resume with the scenario that wrote it."
            )
        self.state.load_state_dict(state)
        for k in ("t", "c", "b", "gamma", "m", "vmax", "amax"):
            setattr(self, k, float(np.asarray(state[k])))
        for k in ("steps", "rebuilds"):
            setattr(self, k, int(np.asarray(state[k])))
        self.kmax = float(np.asarray(state.get("kmax", 0.0)))  # checkpoints before the diffusion's bound: 0
        self.last_dt = float(np.asarray(state.get("last_dt", 0.0)))  # reported only; older checkpoints: 0
        for bd in self.boundaries:
            prefix = f"boundary.{bd.name}."
            bd.load_state_dict({k[len(prefix) :]: v for k, v in state.items() if k.startswith(prefix)})
        self._coefficients()
        # lists exactly as built at the last rebuild (from the positions then), without re-sorting
        self._workspace()
        rebuilds = self.rebuilds
        src = self.state.pos.copy()
        src[: self.state.n_fluid] = self.state.ref
        for bd in self.boundaries:
            bd.listed_positions(self, src)
        self._rebuild(reorder=False, source=src)
        self.rebuilds = rebuilds
        self._disp2[:] = 0.0


@numba.njit(parallel=True, cache=True)
def _count_within(pos, start, nbr, n_fluid, h2):
    out = np.zeros(n_fluid, np.int64)
    d = pos.shape[1]
    for i in numba.prange(n_fluid):
        c = 0
        for s in range(start[i], start[i + 1]):
            j = nbr[s]
            r2 = 0.0
            for a in range(d):
                t = pos[i, a] - pos[j, a]
                r2 += t * t
            if r2 < h2:
                c += 1
        out[i] = c
    return out
