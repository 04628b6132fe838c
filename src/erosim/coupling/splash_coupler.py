"""Water and porous ground, every N fluid steps: splash craters, scour, Darcy seepage, moisture, mud
(seed 003; SPEC SP-1…SP-5).

One callback, :class:`WetGround`, runs the seed's three stages on the fluid of an
:class:`~erosim.sph.solver.SPHSolver` over a heightmap (read live by the solver's ground) and the
:class:`~erosim.coupling.porous_ground.PorousGround` under it. Each call, with Δt the simulated time
since the last one:

1. **contact**: a fluid particle touches the ground when its centre is closer than
   ``splash.contact``·h to the Q4 surface (h the kernel support: where the ground's wall acts on
   it); its speed towards the ground is measured along the surface normal. A particle that comes
   into contact strikes the ground at the larger of its speed now and at the last check while it
   was farther than h from the ground (before the wall's push began to slow it) — unless water
   already lies on the ground there (another particle touching the same ground column): then the
   water cushions it and it strikes at the speed it has now;
2. **splash** (SP-1, SP-2): each strike faster than ``splash.min_speed`` digs the crater of
   :mod:`erosim.erosion.splash` with the strength σ_s(θ) (:mod:`erosim.erosion.wet_strength`) of the
   surface particle under it; the share ``splash.rim`` of the crater's solid lands around it as its
   rim (:func:`~erosim.erosion.splash.rim_increment`), the particle takes the rest up as mud
   (concentration C, up to ``splash.mud_max``) and what it cannot take is thrown clear (counted,
   ``splashed_away``). The strike's normal
   velocity is spent on the crater (the energy balance of the law): the particle keeps only its
   motion along the ground and does not rebound;
3. **scour** (SP-5): particles touching the ground wear it by Krištof et al.'s shear-stress law,
   shared with the voxel eroder (:func:`erosim.erosion.shear_stress_kristof2009.excess_stress`):
   volume k_s·max(0, K θⁿ − τ_c)·Δx²·Δt per particle, θ = v_∥/max(l, l_min), v_∥ the speed along the
   ground and l the distance to it; τ_c scales with σ_s(θ)/σ₀ (wet ground scours more easily —
   the seed's erosion "considering wetness", a modelling choice); the solid joins the particle's mud;
4. **seepage** (SP-3, :mod:`erosim.hydrology.seepage_darcy`): touching particles give water to the
   surface particles of their footprint (within h, Wendland shares; each covering one ground column's
   area in the same shares) at the Darcy rate; a particle
   whose water is spent is removed (sink ``seepage``) and its solid settles on the ground where it was;
5. the terrain change of 2–4 is one :class:`~erosim.core.increments.Increment` (craters, scour,
   settled mud; ΔS the mud taken up minus settled; C what was thrown clear), checked by
   :func:`~erosim.core.increments.check_budget` and applied once; the solver's boundaries are
   refreshed and the ground's columns follow their surface;
6. in a layered ground water drains down the columns (Darcy, the layers' harmonic-mean K; the surface
   then takes water at the top layer's K, not ``permeability``), moisture diffuses through the ground,
   surface particles evaporate, and the mud concentration
   diffuses among the fluid particles (SP-4, :mod:`erosim.sph.mud`).

Per fluid particle the registered fields are ``water`` (the share of its volume V_p still water,
1 → 0 as it seeps), ``mud`` (C, solid volume per V_p), ``touching`` and ``approach`` (the contact
state of step 1). The water budget (fluid + ground + evaporated + left through the edges) and the
solid budget (ground lost = mud in the water + mud gone through the edges + thrown clear) close to
rounding and are reported with their ``closure_rel``.

Why not the house :class:`~erosim.coupling.coupler.Coupler`. Both make the terrain change an
:class:`~erosim.core.increments.Increment`, check it with ``check_budget`` and apply it once, then
refresh the solver's boundaries; but the Coupler's eroder contract is ``increments(terrain, grid,
dt)`` over the binned :class:`~erosim.coupling.binning.FluidGrid` (its ``needs`` checked against
``FluidGrid.FIELDS``), and this exchange is per particle, not per cell: (a) a strike's speed is the
particle's approach speed remembered between calls (the registered ``approach``/``touching``
fields), and several strikes may land in one cell; (b) it writes particle fields (``mud``,
``water``) and removes spent particles through the solver's sinks; (c) after the terrain changes,
the ground particles' columns follow their surface and only then does moisture diffuse among them,
a step after the apply that the Coupler has no hook for; (d) the Coupler bins the whole fluid on
every call, which this exchange does not use. Routing it through the Coupler would mean an eroder
that holds the solver (defeating ``needs``), the porous ground made a boundary model so that its
``refresh`` moves the columns, the solid budget mapped onto the Coupler's four terms (suspended =
mud, carried off = thrown clear + mud gone through the edges) and a new checkpoint layout — more than
a small change, so the exchange keeps its own callback and shares the Increment/``check_budget``
contract instead.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from erosim.core.callbacks import Callback
from erosim.core.config import Section, param
from erosim.core.increments import Increment, check_budget
from erosim.coupling.porous_ground import PorousGround
from erosim.coupling.raster import Raster
from erosim.coupling.sampling import sample
from erosim.erosion import splash as sp
from erosim.erosion.shear_stress_kristof2009 import excess_stresses
from erosim.erosion.wet_strength import strength
from erosim.hydrology.seepage_darcy import absorb_spread, conductivity, drain, evaporate, footprint_weights, harmonic
from erosim.kernels.sph_diffusion import diffuse
from erosim.sph.boundaries.heightfield import node_slopes
from erosim.sph.mud import MudParams, diffuse_concentration, mixture_density

SPENT = 1e-9  # a particle with less than this share of its water left is spent


class ScourParams(Section):
    enabled: bool = param(True, doc="shear-stress scour by water moving along the ground (SP-5)")
    k_s: float = param(1.0e-4, ge=0, unit="m/s", doc="scour rate per unit of excess stress (volume per particle "
                       "footprint Δx² and second)")  # fmt: skip
    tau_c: float = param(6.0, ge=0, unit="s^-n", doc="critical stress τ_c of dry ground, in the units of K θⁿ")
    k: float = param(1.0, gt=0, unit="1", doc="K of τ = K θⁿ (Krištof et al.: 1)")
    n: float = param(0.5, gt=0, le=2, unit="1", doc="n of τ = K θⁿ (Krištof et al.: 0.5)")
    l_min: float = param(0.4, gt=0, le=1, unit="spacing", doc="smallest distance l in the shear rate, in spacings")


def _scatter(raster: Raster, xy: np.ndarray, volume: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
    """Δz (raster.shape) that puts ``volume`` (m³, signed) at points ``xy`` with bilinear weights; with
    ``valid`` (raster.shape) only on those nodes, the weights of the others given to them in proportion
    (each point needs a valid node among its four: the one nearest it, where the fluid still is)."""
    dz = np.zeros(raster.shape)
    if len(volume) == 0:
        return dz
    fx = np.clip((xy[:, 0] - raster.x0) / raster.dx, 0.0, raster.nx - 1.0)
    fy = np.clip((xy[:, 1] - raster.y0) / raster.dy, 0.0, raster.ny - 1.0)
    i = np.minimum(np.floor(fx).astype(np.int64), max(raster.nx - 2, 0))
    j = np.minimum(np.floor(fy).astype(np.int64), max(raster.ny - 2, 0))
    tx, ty = fx - i, fy - j
    h = volume / raster.cell_area
    corners = []
    for di, dj, w in ((0, 0, (1 - tx) * (1 - ty)), (1, 0, tx * (1 - ty)), (0, 1, (1 - tx) * ty), (1, 1, tx * ty)):
        node = (np.minimum(j + dj, raster.ny - 1), np.minimum(i + di, raster.nx - 1))
        corners.append((node, w if valid is None else w * valid[node]))
    total = sum(w for _, w in corners) if valid is not None else None
    for node, w in corners:
        np.add.at(dz, node, w * h if total is None else w / total * h)
    return dz


class WetGround(Callback):
    """The callback of the module docstring (``schedule``: every N fluid steps)."""

    def __init__(self, schedule, solver, raster: Raster, terrain: np.ndarray, ground: PorousGround, *,
                 splash: sp.SplashParams, sigma_dry: float, sigma_wet: float, permeability: float,
                 diffusivity: float, evaporation_mm_h: float, mud: MudParams, scour: ScourParams,
                 outside: np.ndarray | None = None, name: str = "wet_ground"):  # fmt: skip
        """``outside``: None or the nodes outside the terrain (a DEM's nodata; raster.shape), which no
        crater, scour or settling mud changes."""
        super().__init__(schedule, name=name)
        self.solver, self.raster, self.terrain, self.ground = solver, raster, terrain, ground
        self.splash, self.mud, self.scour = splash, mud, scour
        self.outside = None if outside is None or not np.any(outside) else np.asarray(outside, bool)
        self.valid = None if self.outside is None else ~self.outside
        self.sigma_dry, self.sigma_wet = float(sigma_dry), float(sigma_wet)
        g = float(np.linalg.norm(solver.g))
        self.k = conductivity(permeability, gravity=g if g > 0 else 9.81)
        self.diffusivity = float(diffusivity)
        kg = conductivity(ground.permeability, gravity=g if g > 0 else 9.81)
        self.k_between = harmonic(kg[ground.upper], kg[ground.lower]) if ground.layered else None
        if ground.layered:  # the surface takes water at the top soil's conductivity
            self.k = float(kg[0])
        self.evaporation = evaporation_mm_h / 3.6e6  # m/s
        dx = solver.params.spacing
        self.vp = dx**3
        self.radius = (3.0 * self.vp / (4.0 * np.pi)) ** (1.0 / 3.0)  # the particle's equivalent sphere
        self.contact = splash.contact * solver.h
        st = solver.state
        for field, fill in (("water", 1.0), ("mud", 0.0), ("touching", 0.0), ("approach", 0.0)):
            if field not in st.specs:
                st.register(field, fill=fill)
        self.terrain0 = terrain.copy()
        self.sx, self.sy = node_slopes(terrain, raster.dx, raster.dy)
        self._w = ground.weights(self.diffusivity)
        self.ground_water0 = ground.water()
        self.totals = dict.fromkeys(("eroded", "deposited", "suspended", "splashed_away", "evaporated", "dug",
                                     "scoured"), 0.0)  # fmt: skip
        self.impacts: list[list[float]] = []  # per strike: t, x, y, speed, θ, σ, depth, opening radius
        self.n_impacts = 0
        self.last_t = float(solver.t)
        self.calls = 0
        self.wall = {"splash": 0.0, "seepage": 0.0, "mud": 0.0, "between": 0.0}
        self.cpu = dict(self.wall)  # process CPU time: steadier than wall time on a loaded machine
        self._end = None

    # ------------------------------------------------------------------ one coupling
    def __call__(self, sim=None) -> None:
        t0, c0 = time.perf_counter(), time.process_time()
        if self._end is not None:
            self.wall["between"] += t0 - self._end[0]
            self.cpu["between"] += c0 - self._end[1]
        s, st = self.solver, self.solver.state
        dt = float(s.t) - self.last_t
        nf = st.n_fluid
        r = self.raster
        pos, vel = st.pos[:nf].astype(np.float64), st.vel[:nf].astype(np.float64)
        zg = sample(r, self.terrain, pos)
        sx, sy = sample(r, self.sx, pos), sample(r, self.sy, pos)
        norm = np.sqrt(1.0 + sx * sx + sy * sy)
        gap = (pos[:, 2] - zg) / norm  # distance to the (locally planar) ground
        vn = -(-sx * vel[:, 0] - sy * vel[:, 1] + vel[:, 2]) / norm  # speed towards the ground
        touch = gap < self.contact
        cols = self.ground.column_of(pos[:, :2])
        theta_here = self.ground.theta[cols]

        # ---- 1–2 splash
        new = touch & (st.touching[:nf] == 0)
        # water already lying on the ground cushions a newcomer: it strikes at the speed it has now
        lying = np.bincount(cols[touch & ~new], minlength=self.ground.n) > 0
        speed = np.where(lying[cols], np.maximum(vn, 0.0), np.maximum(vn, st.approach[:nf]))
        strike = np.flatnonzero(new & (speed >= self.splash.min_speed))
        dz = np.zeros(r.shape)
        taken_up, thrown = 0.0, 0.0
        for i in strike:
            sigma = float(strength(theta_here[i], self.sigma_dry, self.sigma_wet))
            d = float(sp.crater_depth(self.radius, speed[i], s.params.rho0, sigma))
            dzi = sp.crater_increment(r, pos[i : i + 1, :2], self.radius, np.array([d]))
            if self.outside is not None:
                dzi[self.outside] = 0.0  # outside the terrain nothing is dug
            dug = float(-dzi.sum() * r.cell_area)
            rim = sp.rim_increment(r, pos[i, 0], pos[i, 1], float(sp.crater_radius(self.radius, d)),
                                   self.splash.rim * dug, self.splash.rim_extent)  # fmt: skip
            if self.outside is not None and rim[self.outside].any():  # the rim lands on the terrain only
                kept = rim.sum()
                rim[self.outside] = 0.0
                rim *= kept / rim.sum() if rim.sum() > 0 else 0.0
            vol = dug - float(rim.sum() * r.cell_area)  # what leaves the ground: mud, or thrown clear
            take = min(vol, max(self.splash.mud_max - st.mud[i], 0.0) * self.vp)
            st.mud[i] += take / self.vp
            taken_up += take
            thrown += vol - take
            dz += dzi + rim
            self.totals["dug"] += dug
            self.n_impacts += 1
            if len(self.impacts) < 1000:
                a = float(sp.crater_radius(self.radius, d))
                self.impacts.append([float(s.t), pos[i, 0], pos[i, 1], float(speed[i]), float(theta_here[i]), sigma,
                                     d, a])  # fmt: skip
        if len(strike):
            # the energy balance: the strike's normal kinetic energy is spent digging; the particle keeps
            # only its motion along the ground (no rebound)
            nrm = np.column_stack([-sx[strike], -sy[strike], np.ones(len(strike))]) / norm[strike, None]
            keep = np.maximum(vn[strike], 0.0)[:, None] * nrm
            st.vel[strike] = (vel[strike] + keep).astype(st.vel.dtype)
        st.touching[:nf] = touch
        # the speed of approach is the one measured before the ground's wall began to push
        free = gap >= max(s.h, self.contact)
        st.approach[:nf] = np.where(touch, 0.0, np.where(free, np.maximum(vn, 0.0), st.approach[:nf]))

        # ---- 3 scour
        sc = self.scour
        if sc.enabled and sc.k_s > 0 and dt > 0 and touch.any():
            idx = np.flatnonzero(touch)
            vpar = np.sqrt(np.maximum((vel[idx] ** 2).sum(axis=1) - vn[idx] ** 2, 0.0))
            sig = strength(theta_here[idx], self.sigma_dry, self.sigma_wet)
            tau_c = sc.tau_c * sig / self.sigma_dry
            exc = np.empty(len(idx))
            dx = s.params.spacing
            excess_stresses(vpar, np.maximum(gap[idx], 0.0), sc.l_min * dx, sc.k, sc.n, tau_c, exc)
            vol = sc.k_s * exc * dx * dx * dt
            room = np.maximum(self.splash.mud_max - st.mud[idx], 0.0) * self.vp
            vol = np.minimum(vol, room)
            if vol.any():
                dz -= _scatter(r, pos[idx, :2], vol, self.valid)
                st.mud[idx] += vol / self.vp
                taken_up += float(vol.sum())
                self.totals["scoured"] += float(vol.sum())
        t1, c1 = time.perf_counter(), time.process_time()

        # ---- 4 seepage: Darcy absorption, spent particles settle their mud
        idx = np.flatnonzero(touch)
        pt, pc, pr = self.ground.columns_near(pos[idx, :2], s.h)  # each particle's footprint (radius h)
        w = footprint_weights(pr, s.h)
        w /= np.bincount(pt, w, len(idx))[pt]
        taken = np.zeros(nf)
        taken[idx], gained = absorb_spread(st.water[idx] * self.vp, pt, pc, w, self.ground.theta, self.ground.pore,
                                           self.ground.area, self.k, dt, cover=self.ground.area)  # fmt: skip
        st.water[:nf] -= taken / self.vp
        spent = touch & (st.water[:nf] <= SPENT)
        settled = 0.0
        if spent.any():
            k = np.flatnonzero(spent)
            gained += np.bincount(cols[k], st.water[k] * self.vp, self.ground.n)
            mud_vol = st.mud[k] * self.vp
            # on a round footprint of the particle's size (at least two cells): not a four-node square
            dz += sp.settle(r, pos[k, :2], mud_vol, max(sp.SUBCELL * min(r.dx, r.dy), s.params.spacing), self.valid)
            settled = float(mud_vol.sum())
            st.water[k] = 0.0
            st.mud[k] = 0.0
        self.ground.theta += gained / self.ground.pore

        # ---- 5 one increment, checked and applied
        inc = Increment(dz=dz, suspended=taken_up - settled, carried_off=thrown)
        terms = check_budget(inc, r.shape, r.cell_area, "Splash erosion")
        self.totals["eroded"] += terms["eroded"]
        self.totals["deposited"] += terms["deposited"]
        self.totals["suspended"] += terms["suspended"]
        self.totals["splashed_away"] += terms["carried_off"]
        if spent.any():
            s.remove_fluid(spent, sink="seepage")
        changed = dz != 0
        if changed.any():
            with s.ground_moving(self.terrain, changed):
                self.terrain += dz
                self.sx[...], self.sy[...] = node_slopes(self.terrain, r.dx, r.dy)
            moved = self.ground.follow()
            if moved is None:
                self._w = self.ground.weights(self.diffusivity)
            elif len(moved):
                self._w[moved] = self.ground.weights(self.diffusivity, moved)

        # ---- 6 moisture, evaporation
        g = self.ground
        if self.k_between is not None:
            drain(g.theta, g.pore, g.upper, g.lower, self.k_between, g.area, dt)
        diffuse(g.theta, g.pore, g.i, g.j, self._w, dt)
        self.totals["evaporated"] += evaporate(g.theta, g.pore, g.surface, g.area, self.evaporation, dt)
        t2, c2 = time.perf_counter(), time.process_time()
        # ---- mud diffusion among the fluid
        nf = st.n_fluid
        diffuse_concentration(st.pos[:nf].astype(np.float64), st.mud[:nf], self.vp, s.h, self.mud.diffusivity, dt)
        t3, c3 = time.perf_counter(), time.process_time()
        for store, (a, b, c, d) in ((self.wall, (t0, t1, t2, t3)), (self.cpu, (c0, c1, c2, c3))):
            store["splash"] += b - a
            store["seepage"] += c - b
            store["mud"] += d - c
        self.last_t = float(s.t)
        self.calls += 1
        self._end = (time.perf_counter(), time.process_time())

    # ------------------------------------------------------------------ budgets and maps
    def water_budget(self) -> dict[str, Any]:
        """m³ of water: supplied (the fluid's initial and added particles, the ground's initial water) and
        where it is (fluid, ground, evaporated, left through the edges)."""
        st = self.solver.state
        vp = self.vp
        fluid0 = st.initial * vp
        added = sum(st.added.values()) * vp
        fluid = float(st.water[: st.n_fluid].sum()) * vp
        left = st.removed_sums.get("water", 0.0) * vp
        ground = self.ground.water()
        supplied = fluid0 + added + self.ground_water0
        now = fluid + ground + self.totals["evaporated"] + left
        return {
            "unit": "m3",
            "fluid_initial": fluid0,
            "added": {k: v * vp for k, v in st.added.items()},
            "ground_initial": self.ground_water0,
            "in_fluid": fluid,
            "in_ground": ground,
            "absorbed": ground - self.ground_water0 + self.totals["evaporated"],
            "evaporated": self.totals["evaporated"],
            "left_edges": left,
            "closure_rel": abs(supplied - now) / supplied if supplied > 0 else 0.0,
        }

    def solid_budget(self) -> dict[str, Any]:
        """m³ of solid: what the ground lost (eroded − settled back), where it is, and what dug it (the craters'
        volume ``by_splash`` and the scour's ``by_scour``)."""
        st = self.solver.state
        mud = float(st.mud[: st.n_fluid].sum()) * self.vp
        left = st.removed_sums.get("mud", 0.0) * self.vp
        t = self.totals
        lost = t["eroded"] - t["deposited"]
        change = float((self.terrain - self.terrain0).sum() * self.raster.cell_area)
        return {
            "unit": "m3",
            "eroded": t["eroded"],
            "settled": t["deposited"],
            "in_mud": mud,
            "mud_left_edges": left,
            "splashed_away": t["splashed_away"],
            "by_splash": t["dug"],
            "by_scour": t["scoured"],
            "terrain_change": change,
            "closure_rel": abs(lost - mud - left - t["splashed_away"]) / t["eroded"] if t["eroded"] > 0 else 0.0,
        }

    def wetness(self) -> np.ndarray:
        """Surface saturation θ at the terrain's nodes (SPH frame)."""
        return self.ground.surface_map()

    def mud_density(self) -> np.ndarray:
        """Mixture density ρ = Cρ_s + (1 − C)ρ_f of every fluid particle (internal order)."""
        st = self.solver.state
        return mixture_density(st.mud[: st.n_fluid], self.solver.params.rho0, self.mud.solid_density)

    def costs(self, sim) -> dict[str, Any]:
        """Wall and process CPU time of the passes and of the fluid's steps between two couplings (this
        session), and each pass per second of those steps."""
        out: dict[str, Any] = {}
        for label, w in (("wall", self.wall), ("cpu", self.cpu)):
            between = w["between"]
            out[f"sph_steps_{label}_s"] = round(between, 4)
            for k in ("splash", "seepage", "mud"):
                out[f"{k}_{label}_s"] = round(w[k], 4)
                out[f"{k}_per_sph_{label}"] = w[k] / between if between > 0 else None
        out["note"] = "this session's time of each pass, and per second of the fluid's steps between couplings"
        return out

    # ------------------------------------------------------------------ callback protocol
    def state_dict(self) -> dict[str, Any]:
        imp = np.array(self.impacts, np.float64).reshape(-1, 8)
        return {
            "terrain": self.terrain.copy(),
            "totals": np.array([self.totals[k] for k in self.totals]),
            "impacts": imp,
            "n_impacts": self.n_impacts,
            "last_t": self.last_t,
            "calls": self.calls,
            **{f"ground_{k}": v for k, v in self.ground.state_dict().items()},
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.terrain[...] = np.asarray(state["terrain"])
        self.totals = dict(zip(self.totals, np.asarray(state["totals"]).tolist(), strict=True))
        self.impacts = np.asarray(state["impacts"]).reshape(-1, 8).tolist()
        self.n_impacts = int(state["n_impacts"])
        self.last_t = float(state["last_t"])
        self.calls = int(state["calls"])
        self.sx[...], self.sy[...] = node_slopes(self.terrain, self.raster.dx, self.raster.dy)
        self.ground.load_state_dict({k[7:]: v for k, v in state.items() if k.startswith("ground_")})
        self._w = self.ground.weights(self.diffusivity)
