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

The exchange runs through the house :class:`~erosim.coupling.coupler.Coupler`: :class:`WetExchange`
is its eroder (steps 1–4 above: ``increments(terrain, solver, dt)``; the particle fields it changes —
``mud``, ``water``, ``touching``, ``approach`` and the velocity of a strike —, the ground's moisture and
the spent particles travel in the :class:`~erosim.core.increments.Increment`), the terrain is a
:class:`~erosim.coupling.terrains.PorousHeightfieldTerrain` (heights with the porous ground under them,
whose columns follow the surface when the coupler applies Δz: step 5), and :class:`Moisture` is the
callback on the same schedule that runs step 6 after it. :class:`WetGround` builds the three and
gives the run's budgets and maps.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from erosim.core.callbacks import Callback
from erosim.core.config import Section, param
from erosim.core.increments import Increment
from erosim.coupling.coupler import Coupler
from erosim.coupling.porous_ground import PorousGround
from erosim.coupling.raster import Raster
from erosim.coupling.sampling import sample
from erosim.coupling.terrains import PorousHeightfieldTerrain
from erosim.erosion import splash as sp
from erosim.erosion.shear_stress_kristof2009 import excess_stresses
from erosim.erosion.wet_strength import strength
from erosim.hydrology.seepage_darcy import absorb_spread, conductivity, drain, evaporate, footprint_weights, harmonic
from erosim.kernels.sph_diffusion import diffuse
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


class PassClock:
    """Wall and process CPU time of the passes of one coupling (this session), and of the fluid's steps
    between two couplings (from the end of :class:`Moisture` to the start of the next exchange)."""

    PASSES = ("splash", "seepage", "mud", "between")

    def __init__(self):
        self.wall = dict.fromkeys(self.PASSES, 0.0)
        self.cpu = dict.fromkeys(self.PASSES, 0.0)
        self.end: tuple[float, float] | None = None

    @staticmethod
    def now() -> tuple[float, float]:
        return time.perf_counter(), time.process_time()

    def add(self, name: str, start: tuple[float, float], stop: tuple[float, float]) -> None:
        self.wall[name] += stop[0] - start[0]
        self.cpu[name] += stop[1] - start[1]


class WetExchange:
    """The eroder of the module docstring's steps 1–4 (contact, splash, scour, seepage), per particle."""

    name = "splash"
    needs = ("particles",)

    def __init__(self, solver, *, splash: sp.SplashParams, sigma_dry: float, sigma_wet: float, permeability: float,
                 scour: ScourParams, layered_k: float | None = None, clock: PassClock | None = None):  # fmt: skip
        self.solver, self.splash, self.scour = solver, splash, scour
        self.clock = clock or PassClock()
        self.sigma_dry, self.sigma_wet = float(sigma_dry), float(sigma_wet)
        g = float(np.linalg.norm(solver.g))
        # the surface takes water at the top soil's conductivity in a layered ground
        self.k = conductivity(permeability, gravity=g if g > 0 else 9.81) if layered_k is None else layered_k
        dx = solver.params.spacing
        self.vp = dx**3
        self.radius = (3.0 * self.vp / (4.0 * np.pi)) ** (1.0 / 3.0)  # the particle's equivalent sphere
        self.contact = splash.contact * solver.h
        st = solver.state
        for field, fill in (("water", 1.0), ("mud", 0.0), ("touching", 0.0), ("approach", 0.0)):
            if field not in st.specs:
                st.register(field, fill=fill)
        self.dug = 0.0
        self.scoured = 0.0
        self.impacts: list[list[float]] = []  # per strike: t, x, y, speed, θ, σ, depth, opening radius
        self.n_impacts = 0

    def increments(self, terrain, solver, dt: float) -> Increment:
        """Steps 1–4 on ``terrain`` (a :class:`~erosim.coupling.terrains.PorousHeightfieldTerrain`)."""
        clock = self.clock
        start = clock.now()
        if clock.end is not None:
            clock.add("between", clock.end, start)
        s, st = solver, solver.state
        nf = st.n_fluid
        r = terrain.raster
        ground = terrain.ground
        outside, valid = terrain.outside, terrain.valid
        pos, vel = st.pos[:nf].astype(np.float64), st.vel[:nf].astype(np.float64)
        new_vel = st.vel[:nf].copy()
        mud, water = st.mud[:nf].copy(), st.water[:nf].copy()
        zg = sample(r, terrain.z, pos)
        sx, sy = sample(r, terrain.sx, pos), sample(r, terrain.sy, pos)
        norm = np.sqrt(1.0 + sx * sx + sy * sy)
        gap = (pos[:, 2] - zg) / norm  # distance to the (locally planar) ground
        vn = -(-sx * vel[:, 0] - sy * vel[:, 1] + vel[:, 2]) / norm  # speed towards the ground
        touch = gap < self.contact
        cols = ground.column_of(pos[:, :2])
        theta_here = ground.theta[cols]

        # ---- 1–2 splash
        new = touch & (st.touching[:nf] == 0)
        # water already lying on the ground cushions a newcomer: it strikes at the speed it has now
        lying = np.bincount(cols[touch & ~new], minlength=ground.n) > 0
        speed = np.where(lying[cols], np.maximum(vn, 0.0), np.maximum(vn, st.approach[:nf]))
        strike = np.flatnonzero(new & (speed >= self.splash.min_speed))
        dz = np.zeros(r.shape)
        taken_up, thrown = 0.0, 0.0
        for i in strike:
            sigma = float(strength(theta_here[i], self.sigma_dry, self.sigma_wet))
            d = float(sp.crater_depth(self.radius, speed[i], s.params.rho0, sigma))
            dzi = sp.crater_increment(r, pos[i : i + 1, :2], self.radius, np.array([d]))
            if outside is not None:
                dzi[outside] = 0.0  # outside the terrain nothing is dug
            dug = float(-dzi.sum() * r.cell_area)
            rim = sp.rim_increment(r, pos[i, 0], pos[i, 1], float(sp.crater_radius(self.radius, d)),
                                   self.splash.rim * dug, self.splash.rim_extent)  # fmt: skip
            if outside is not None and rim[outside].any():  # the rim lands on the terrain only
                kept = rim.sum()
                rim[outside] = 0.0
                rim *= kept / rim.sum() if rim.sum() > 0 else 0.0
            vol = dug - float(rim.sum() * r.cell_area)  # what leaves the ground: mud, or thrown clear
            take = min(vol, max(self.splash.mud_max - mud[i], 0.0) * self.vp)
            mud[i] += take / self.vp
            taken_up += take
            thrown += vol - take
            dz += dzi + rim
            self.dug += dug
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
            new_vel[strike] = (vel[strike] + keep).astype(new_vel.dtype)
        touching = touch.astype(st.touching.dtype)
        # the speed of approach is the one measured before the ground's wall began to push
        free = gap >= max(s.h, self.contact)
        approach = np.where(touch, 0.0, np.where(free, np.maximum(vn, 0.0), st.approach[:nf]))

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
            room = np.maximum(self.splash.mud_max - mud[idx], 0.0) * self.vp
            vol = np.minimum(vol, room)
            if vol.any():
                dz -= _scatter(r, pos[idx, :2], vol, valid)
                mud[idx] += vol / self.vp
                taken_up += float(vol.sum())
                self.scoured += float(vol.sum())
        splashed = clock.now()
        clock.add("splash", start, splashed)

        # ---- 4 seepage: Darcy absorption, spent particles settle their mud
        idx = np.flatnonzero(touch)
        pt, pc, pr = ground.columns_near(pos[idx, :2], s.h)  # each particle's footprint (radius h)
        w = footprint_weights(pr, s.h)
        w /= np.bincount(pt, w, len(idx))[pt]
        taken = np.zeros(nf)
        taken[idx], gained = absorb_spread(water[idx] * self.vp, pt, pc, w, ground.theta, ground.pore,
                                           ground.area, self.k, dt, cover=ground.area)  # fmt: skip
        water -= taken / self.vp
        spent = touch & (water <= SPENT)
        settled = 0.0
        if spent.any():
            k = np.flatnonzero(spent)
            gained += np.bincount(cols[k], water[k] * self.vp, ground.n)
            mud_vol = mud[k] * self.vp
            # on a round footprint of the particle's size (at least two cells): not a four-node square
            dz += sp.settle(r, pos[k, :2], mud_vol, max(sp.SUBCELL * min(r.dx, r.dy), s.params.spacing), valid)
            settled = float(mud_vol.sum())
            water[k] = 0.0
            mud[k] = 0.0
        clock.add("seepage", splashed, clock.now())
        return Increment(
            dz=dz, suspended=taken_up - settled, carried_off=thrown,
            particles={"vel": new_vel, "mud": mud, "water": water, "touching": touching, "approach": approach},
            terrain_fields={"theta": ground.theta + gained / ground.pore},
            removed=spent if spent.any() else None, sink="seepage",
        )  # fmt: skip

    def state_dict(self) -> dict[str, Any]:
        return {"impacts": np.array(self.impacts, np.float64).reshape(-1, 8), "n_impacts": self.n_impacts,
                "dug": self.dug, "scoured": self.scoured}  # fmt: skip

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.impacts = np.asarray(state["impacts"]).reshape(-1, 8).tolist()
        self.n_impacts = int(state["n_impacts"])
        self.dug, self.scoured = float(state["dug"]), float(state["scoured"])


class Moisture(Callback):
    """Step 6 of the module docstring, after the coupler on the same schedule: water drains down a layered
    ground's columns, moisture diffuses through the ground, the surface evaporates, and the mud
    concentration diffuses among the fluid particles."""

    def __init__(self, schedule, solver, terrain, *, evaporation_mm_h: float, mud: MudParams,
                 clock: PassClock | None = None, name: str = "moisture"):  # fmt: skip
        super().__init__(schedule, name=name)
        self.clock = clock or PassClock()
        self.solver, self.terrain, self.mud = solver, terrain, mud
        ground = terrain.ground
        g = float(np.linalg.norm(solver.g))
        kg = conductivity(ground.permeability, gravity=g if g > 0 else 9.81)
        self.k_between = harmonic(kg[ground.upper], kg[ground.lower]) if ground.layered else None
        self.evaporation = evaporation_mm_h / 3.6e6  # m/s
        self.vp = solver.params.spacing**3
        self.evaporated = 0.0
        self.last_t = float(solver.t)

    def __call__(self, sim=None) -> None:
        clock = self.clock
        start = clock.now()
        s, st = self.solver, self.solver.state
        dt = float(s.t) - self.last_t
        g = self.terrain.ground
        if self.k_between is not None:
            drain(g.theta, g.pore, g.upper, g.lower, self.k_between, g.area, dt)
        diffuse(g.theta, g.pore, g.i, g.j, self.terrain.weights, dt)
        self.evaporated += evaporate(g.theta, g.pore, g.surface, g.area, self.evaporation, dt)
        moist = clock.now()
        clock.add("seepage", start, moist)  # moisture counts with the seepage pass
        nf = st.n_fluid
        diffuse_concentration(st.pos[:nf].astype(np.float64), st.mud[:nf], self.vp, s.h, self.mud.diffusivity, dt)
        clock.end = clock.now()
        clock.add("mud", moist, clock.end)
        self.last_t = float(s.t)

    def state_dict(self) -> dict[str, Any]:
        return {"evaporated": self.evaporated, "last_t": self.last_t}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.evaporated, self.last_t = float(state["evaporated"]), float(state["last_t"])


class WetGround:
    """The splash kind's coupling of water and porous ground: the coupler with :class:`WetExchange` over a
    :class:`~erosim.coupling.terrains.PorousHeightfieldTerrain`, and :class:`Moisture`, on ``schedule``
    (every N fluid steps); ``callbacks`` are the two to run, in that order. Gives the run's budgets and
    maps."""

    def __init__(self, schedule, solver, raster: Raster, terrain: np.ndarray, ground: PorousGround, *,
                 splash: sp.SplashParams, sigma_dry: float, sigma_wet: float, permeability: float,
                 diffusivity: float, evaporation_mm_h: float, mud: MudParams, scour: ScourParams,
                 outside: np.ndarray | None = None, name: str = "wet_ground"):  # fmt: skip
        """``outside``: None or the nodes outside the terrain (a DEM's nodata; raster.shape), which no
        crater, scour or settling mud changes."""
        self.solver, self.raster, self.ground, self.mud = solver, raster, ground, mud
        self.adapter = PorousHeightfieldTerrain(raster, terrain, ground, diffusivity, outside=outside)
        g = float(np.linalg.norm(solver.g))
        top_k = None
        if ground.layered:  # the surface takes water at the top soil's conductivity
            top_k = float(conductivity(ground.permeability, gravity=g if g > 0 else 9.81)[0])
        self.clock = PassClock()
        self.exchange = WetExchange(solver, splash=splash, sigma_dry=sigma_dry, sigma_wet=sigma_wet,
                                    permeability=permeability, scour=scour, layered_k=top_k,
                                    clock=self.clock)  # fmt: skip
        self.coupler = Coupler(schedule, solver, self.exchange, self.adapter, name=name)
        self.moisture = Moisture(schedule, solver, self.adapter, evaporation_mm_h=evaporation_mm_h, mud=mud,
                                 clock=self.clock)  # fmt: skip
        self.sigma_dry, self.sigma_wet = self.exchange.sigma_dry, self.exchange.sigma_wet
        self.vp, self.radius = self.exchange.vp, self.exchange.radius
        self.ground_water0 = ground.water()

    callbacks = property(lambda self: [self.coupler, self.moisture])
    terrain = property(lambda self: self.adapter.z)  # the heights, changed in place
    impacts = property(lambda self: self.exchange.impacts)
    n_impacts = property(lambda self: self.exchange.n_impacts)
    calls = property(lambda self: self.coupler.calls)

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
        evaporated = self.moisture.evaporated
        supplied = fluid0 + added + self.ground_water0
        now = fluid + ground + evaporated + left
        return {
            "unit": "m3",
            "fluid_initial": fluid0,
            "added": {k: v * vp for k, v in st.added.items()},
            "ground_initial": self.ground_water0,
            "in_fluid": fluid,
            "in_ground": ground,
            "absorbed": ground - self.ground_water0 + evaporated,
            "evaporated": evaporated,
            "left_edges": left,
            "closure_rel": abs(supplied - now) / supplied if supplied > 0 else 0.0,
        }

    def solid_budget(self) -> dict[str, Any]:
        """m³ of solid: what the ground lost (eroded − settled back), where it is, and what dug it (the craters'
        volume ``by_splash`` and the scour's ``by_scour``)."""
        st = self.solver.state
        mud = float(st.mud[: st.n_fluid].sum()) * self.vp
        left = st.removed_sums.get("mud", 0.0) * self.vp
        t = self.coupler.totals
        lost = t["eroded"] - t["deposited"]
        change = float((self.adapter.z - self.adapter.z0).sum() * self.raster.cell_area)
        return {
            "unit": "m3",
            "eroded": t["eroded"],
            "settled": t["deposited"],
            "in_mud": mud,
            "mud_left_edges": left,
            "splashed_away": t["carried_off"],
            "by_splash": self.exchange.dug,
            "by_scour": self.exchange.scoured,
            "terrain_change": change,
            "closure_rel": abs(lost - mud - left - t["carried_off"]) / t["eroded"] if t["eroded"] > 0 else 0.0,
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
        for label, w in (("wall", self.clock.wall), ("cpu", self.clock.cpu)):
            between = w["between"]
            out[f"sph_steps_{label}_s"] = round(between, 4)
            for k in ("splash", "seepage", "mud"):
                out[f"{k}_{label}_s"] = round(w[k], 4)
                out[f"{k}_per_sph_{label}"] = w[k] / between if between > 0 else None
        out["note"] = "this session's time of each pass, and per second of the fluid's steps between couplings"
        return out
