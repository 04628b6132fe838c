"""The ``splash`` kind: SPH water on porous ground that it wets, weakens, splashes and scours (seed 003;
SPEC SP-1…SP-6).

The terrain (a DEM, a generated map, or — with ``[drop]`` — a flat patch scaled to the drop) lives in
the SPH frame of :mod:`erosim.scenarios.sph_terrain.build` (x east, y north, z up, rows
northward). The fluid feels the ground as the heightmap's particle-free wall; porous ground particles
(:class:`~erosim.coupling.porous_ground.PorousGround`) lie in layers under it; every ``run.every``
steps the coupler of :class:`~erosim.coupling.splash_coupler.WetGround` digs the craters of the particles that
strike the ground, scours, lets water seep in and spread, and mixes mud.

A DEM's nodata cells are outside the terrain: no ground particle stands there, no rain falls there,
no crater or deposit changes them, and water that reaches one (the node nearest it) leaves the run,
counted in ``water_budget.left_nodata`` (part of ``left_edges``) as at an open edge. The fluid meets
their filled heights (the nearest valid ones) until it leaves: a nodata hole is neither a wall nor a pit.

A ``[drop]`` run: each drop is one fluid particle of the drop's volume, so the crater law's R is the
drop's radius; the fluid spacing is R·(4π/3)^{1/3}; the patch's cells are R/``cells_per_radius``;
the drops start one kernel support above the ground, at ``drop.speed`` downward.

It leaves ``maps/`` (the DEM's grid): height.tif, height_initial.tif, erosion.tif, deposition.tif,
wetness.tif (surface saturation θ, 0…1), puddles.tif (depth of the water standing in closed hollows at the end),
water_depth.tif, and wetness.png (16-bit: 0…65535 for θ = 0…1); ``maps/frames/`` wetness and height
over time (``run.wetness_frames``); ``figures/`` (wetness, erosion and deposition, the wetness frames,
a crater's profile for drop runs); particle frames with each particle's water share, mud
concentration and mixture density, and the ground particles' saturation; ``report.json`` with
``water_budget`` and ``solid_budget`` (each with ``closure_rel``), the impacts, the cost of the
passes, and for drop runs ``crater_depth_m``, ``crater_width_m`` (a_p: the opening's radius) and the
crater law's values beside them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from erosim.core.errors import ConfigError
from erosim.core.heightmap import Heightmap, default_transform
from erosim.core.schedules import IterationInterval, TimeInterval
from erosim.coupling.binning import FluidGrid
from erosim.coupling.porous_ground import PorousGround
from erosim.coupling.raster import Raster
from erosim.coupling.sources import EdgeOutflow, OutsideOutflow, PointInflow, Rain
from erosim.coupling.splash_coupler import WetGround
from erosim.scenarios.estimate import BASE_BYTES, SPH_PARTICLE_BYTES, START_S, Estimate
from erosim.scenarios.schema_common import terrain_facts
from erosim.scenarios.setup import Setup
from erosim.scenarios.sph_terrain import geometry as terrain_geometry
from erosim.scenarios.splash.outputs import SplashFrames, SplashOutputs, WetnessFrames, splash_report
from erosim.scenarios.splash.schema import SplashScenario, ground_spacing
from erosim.sph.boundaries.heightfield import HeightfieldGround
from erosim.sph.boundaries.planes import PlaneWalls
from erosim.sph.mud import MudMixture
from erosim.sph.solver import SPHSolver

#: the most porous ground particles a run lays (each holds about 1 kB with its diffusion pairs)
MAX_GROUND = 2_000_000
#: a drop's fluid spacing per drop radius: the cube of the drop's volume
DROP_SPACING = (4.0 * math.pi / 3.0) ** (1.0 / 3.0)


def geometry(cfg: SplashScenario) -> tuple[terrain_geometry.Geometry, float]:
    """The terrain in the SPH frame and the fluid spacing. A DEM's nodata cells keep the nearest valid
    heights (:func:`erosim.core.heightmap.fill_nodata`) and are marked in ``Geometry.nodata``."""
    if cfg.drop is not None:
        d = cfg.drop
        cell = d.radius / d.cells_per_radius
        n = 2 * int(math.ceil(0.5 * d.patch * d.cells_per_radius)) + 1  # odd: a node under the patch's centre
        z = np.zeros((n, n))
        raster = Raster(0.0, 0.0, cell, cell, n, n)
        dem = Heightmap(z.copy(), cell, transform=default_transform(n, n, cell))
        return terrain_geometry.Geometry(raster, z.copy(), z.copy(), None, dem, 3), d.radius * DROP_SPACING
    geo = terrain_geometry.dem_geometry(cfg.terrain, cfg.seed, nodata_wall=None)  # nodata: outside, not walls
    dx = cfg.scale.spacing_cells * geo.raster.dx if cfg.scale.spacing_cells else cfg.sph.spacing
    return geo, dx


def froude_scaled(cfg: SplashScenario, cell: float) -> tuple[SplashScenario, float]:
    """The scenario scaled from ``scale.reference_cell`` to a terrain of ``cell`` metres by Froude similarity,
    λ = cell/reference: lengths × λ, times and speeds × √λ, so that a storm on a DEM of any scale does what it
    does on the reference terrain in as many steps (a λ times larger particle falls √λ times longer):

    run.t_end, run.rain_until × √λ;  rain.height × λ, rain.rate (a speed) × √λ;  inflow discharge × λ^{5/2},
    radius and height × λ;  ground.spacing × λ;  permeabilities × √λ (K is a speed);  moisture and mud
    diffusivities × λ^{3/2};
    evaporation × √λ;  yield strengths × λ (d_p/R ∝ v/√σ stays);  splash.min_speed × √λ;  scour k_s × √λ,
    τ_c × λ^{−n/2} (the shear rate v/l scales as 1/√λ);  a set sph.sound_speed × √λ, sph.dt × √λ.
    Returns the scaled scenario and λ (1: unchanged)."""
    ref = cfg.scale.reference_cell
    if ref is None or cfg.drop is not None or abs(cell / ref - 1.0) < 1e-12:
        return cfg, 1.0
    lam = cell / ref
    r = math.sqrt(lam)
    run = cfg.run.model_copy(
        update={
            "t_end": cfg.run.t_end * r,
            "rain_until": None if cfg.run.rain_until is None else cfg.run.rain_until * r,
        }
    )
    rain = cfg.rain.model_copy(update={"height": cfg.rain.height * lam, "rate": cfg.rain.rate * r})
    inflows = {
        k: v.model_copy(
            update={"discharge": v.discharge * lam**2.5, "radius": v.radius * lam, "height": v.height * lam}
        )
        for k, v in cfg.inflows.items()
    }
    g = cfg.ground
    ground = g.model_copy(
        update={
            "permeability": g.permeability * r,
            "subsoil_permeability": g.subsoil_permeability * r,
            "spacing": g.spacing * lam,
            "diffusivity": g.diffusivity * lam**1.5,
            "evaporation": g.evaporation * r,
            "sigma_dry": g.sigma_dry * lam,
            "sigma_wet": g.sigma_wet * lam,
        }
    )
    splash = cfg.splash.model_copy(update={"min_speed": cfg.splash.min_speed * r})
    sc = cfg.scour
    scour = sc.model_copy(update={"k_s": sc.k_s * r, "tau_c": sc.tau_c * lam ** (-sc.n / 2)})
    mud = cfg.mud.model_copy(update={"diffusivity": cfg.mud.diffusivity * lam**1.5})
    sph = cfg.sph.model_copy(update={"sound_speed": cfg.sph.sound_speed * r, "dt": cfg.sph.dt * r})
    out = cfg.model_copy(update={"run": run, "rain": rain, "inflows": inflows, "ground": ground, "splash": splash,
                                 "scour": scour, "mud": mud, "sph": sph})  # fmt: skip
    return out, lam


def coarsening(raster, fluid_spacing: float, ground_spacing: float, layers: int, most: int) -> tuple[float, float]:
    """The fluid and ground spacings, grown together (their ratio kept) so that the porous ground's columns
    (whole ground spacings across the map) times ``layers`` stay within ``most`` particles: unchanged when they
    fit or ``most`` is 0, else the fluid spacing rounded up to two significant digits."""
    w, h = (raster.nx - 1) * raster.dx, (raster.ny - 1) * raster.dy
    ratio = fluid_spacing / ground_spacing

    def count(s: float) -> int:
        return int(w // s) * int(h // s) * layers

    if most <= 0 or count(ground_spacing) <= most:
        return fluid_spacing, ground_spacing
    dx = fluid_spacing * math.sqrt(count(ground_spacing) / most)
    step = 10.0 ** (math.floor(math.log10(dx)) - 1)
    dx = math.ceil(dx / step - 1e-9) * step
    while count(dx / ratio) > most:
        dx += step
    return dx, dx / ratio


def drop_column(cfg: SplashScenario, geo, dx: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Positions and velocities of the drops: a column over the patch's centre, the first one support h
    (plus half a spacing) above the ground."""
    d = cfg.drop
    r = geo.raster
    cx, cy = r.x0 + (r.nx // 2) * r.dx, r.y0 + (r.ny // 2) * r.dy
    z = h + 0.5 * dx + np.arange(d.count) * max(d.gap * 2.0 * d.radius, 1.01 * dx)
    pos = np.column_stack([np.full(d.count, cx), np.full(d.count, cy), z])
    vel = np.zeros_like(pos)
    vel[:, 2] = -d.speed
    return pos, vel


def build_solver(cfg: SplashScenario, geo, dx: float):
    """The solver on the heightmap's wall, with closed edges as planes; the sound speed
    ``scale.sound_factor`` times the fastest water expected."""

    p, r = cfg.sph.model_copy(update={"spacing": dx}), geo.raster
    h = p.support()
    g = math.sqrt(sum(x * x for x in p.gravity_vector()))
    ground_min, ground_max = float(geo.terrain.min()), float(geo.terrain.max())
    fluid, vel = np.zeros((0, 3)), None
    tops, speeds = [], []
    if cfg.drop is not None:
        fluid, vel = drop_column(cfg, geo, dx, h)
        tops.append(float(fluid[:, 2].max()))
        speeds.append(math.sqrt(cfg.drop.speed**2 + 2 * g * (tops[-1] - ground_min)))
    if cfg.rain.rate > 0:
        tops.append(ground_max + cfg.rain.height)
    for inf in cfg.inflows.values():
        tops.append(ground_max + inf.height)
        speeds.append(inf.discharge / max(math.pi * max(inf.radius, 0.5 * dx) ** 2, dx * dx))
    fall = max(tops) - ground_min
    speeds.append(math.sqrt(2 * g * max(fall, dx)))
    if p.sound_speed <= 0:
        p = p.model_copy(update={"sound_speed": max(cfg.scale.sound_factor * max(speeds), 1e-3)})
    margin = 4.0 * h
    lo = [r.x0 - margin, r.y0 - margin, ground_min - margin]
    hi = [r.x0 + (r.nx - 1) * r.dx + margin, r.y0 + (r.ny - 1) * r.dy + margin, max(tops) + max(10 * h, 0.5 * fall)]
    ground = HeightfieldGround(r, geo.terrain)
    boundaries = [ground]
    planes = terrain_geometry.edge_planes(geo, cfg.edges.outflow)
    if planes is not None:
        boundaries.append(PlaneWalls(*planes))
    boundaries.append(MudMixture(cfg.mud.solid_density, cfg.mud.solid_viscosity))  # mud's mass and viscosity
    solver = SPHSolver(p, fluid, fluid_vel=vel, domain_lo=lo, domain_hi=hi, seed=cfg.seed, boundaries=boundaries)
    return solver


def setup(scenario, out) -> Setup:
    """The fluid, the porous ground, the sources and sinks and the outputs of a ``splash`` run."""
    cfg: SplashScenario = scenario.config
    geo, dx = geometry(cfg)
    cfg, lam = froude_scaled(cfg, geo.raster.dx)
    s_ground = ground_spacing(dx, cfg.ground)
    r = geo.raster
    coarsened = None
    if cfg.drop is None:
        fitted = coarsening(r, dx, s_ground, cfg.ground.layers, cfg.scale.max_ground)
        if fitted != (dx, s_ground):
            coarsened, (dx, s_ground) = (dx, s_ground), fitted
    span = min((r.nx - 1) * r.dx, (r.ny - 1) * r.dy)
    if span < 2 * s_ground:
        raise ConfigError(
            f"The terrain is {span:g} m across, less than two ground spacings ({s_ground:g} m); use a larger terrain "
            "or a smaller sph.spacing."
        )
    solver = build_solver(cfg, geo, dx)
    gs = cfg.ground
    columns = columns_for(r, s_ground)
    if columns * gs.layers > MAX_GROUND:
        raise ConfigError(
            f"The ground would need {columns * gs.layers:.3g} particles of {s_ground:g} m, more than the "
            f"{MAX_GROUND:.0e} that fit in a laptop's memory (about 1 kB each with their pairs); leave "
            "scale.max_ground at its default (the particles are then coarsened to fit), or give a coarser "
            "ground.spacing (0: the fluid's) or fewer ground.layers."
        )
    perm = None
    if gs.topsoil_layers > 0:
        perm = [gs.permeability] * gs.topsoil_layers + [gs.subsoil_permeability] * (gs.layers - gs.topsoil_layers)
    ground = PorousGround(r, geo.terrain, s_ground, gs.layers, gs.porosity, gs.saturation, gs.density, perm,
                          outside=geo.nodata)  # fmt: skip
    wet = WetGround(IterationInterval(cfg.run.every), solver, r, geo.terrain, ground, splash=cfg.splash,
                    sigma_dry=gs.sigma_dry, sigma_wet=gs.sigma_wet, permeability=gs.permeability,
                    diffusivity=gs.diffusivity, evaporation_mm_h=gs.evaporation, mud=cfg.mud,
                    scour=cfg.scour, outside=geo.nodata)  # fmt: skip
    callbacks: list = []
    outside = None
    if geo.nodata is not None:  # water over nodata leaves first, so that no pass sees it there
        outside = OutsideOutflow(IterationInterval(1), solver, r, geo.nodata)
        callbacks.append(outside)
    if cfg.edges.outflow:
        callbacks.append(EdgeOutflow(IterationInterval(1), solver, r, cfg.edges.outflow))
    grid = FluidGrid(r, 3, ground=geo.terrain, near=2.0 * solver.h)
    warnings = list(geo.dem.notes) if geo.dem is not None and cfg.drop is None else []
    if cfg.drop is not None:  # by the model's design (seed 003), said so that no one reads a resolved drop
        warnings.append(f"Each drop is one SPH particle of the drop's volume ({dx:.3g} m spacing for drop.radius = "
                        f"{cfg.drop.radius:g} m): its shape and spreading on impact are not resolved, and the crater "
                        "follows the projectile law for a drop of that size.")  # fmt: skip
    assumed: list[str] = []
    facts = None
    if cfg.drop is None:
        facts, assumed = terrain_facts(geo.dem, cfg.terrain)
        if facts["nodata_cells"]:
            warnings.append(f"{facts['nodata_cells']} cells of the terrain are nodata: outside the terrain (no ground "
                            "particles or rain there; water reaching them leaves and counts in "
                            "water_budget.left_nodata); the maps keep them as nodata.")  # fmt: skip
        if lam != 1.0:
            assumed.append(scaling_line(scenario.config, cfg, lam, r.dx))
        if coarsened is not None:
            assumed.append(f"particles: the fluid's {coarsened[0]:.3g} m and the ground's {coarsened[1]:.3g} m would "
                           f"need {columns_for(r, coarsened[1]) * gs.layers:,} ground particles on this "
                           f"{(r.nx - 1) * r.dx:g} m × {(r.ny - 1) * r.dy:g} m terrain; both are coarsened to "
                           f"{dx:.3g} m and {s_ground:.3g} m ({ground.n:,} ground particles; scale.max_ground = "
                           f"{cfg.scale.max_ground:,}: raise it for finer particles, 0 never to coarsen)")  # fmt: skip
    cost = run_cost(cfg, solver, ground)
    if cfg.rain.rate > 0:
        chance = terrain_geometry.rain_map(cfg, geo)
        if geo.nodata is not None:
            chance = np.where(geo.nodata, 0.0, chance)  # no rain falls outside the terrain
        height = cfg.rain.height
        if height < 2.0 * solver.h:  # drops born inside the ground's reach would never strike it
            height = 2.0 * solver.h
            warnings.append(f"rain.height = {cfg.rain.height:g} m is within two kernel supports of the ground; the "
                            f"drops start {height:.3g} m above it so that they strike it.")  # fmt: skip
        # drops start one support inside the map: a drop born within a closed edge's wall would be pushed
        # off it alone, its density (continuity) falling by the wall's share, towards zero at the wall
        callbacks.append(Rain(IterationInterval(cfg.rain.every), solver, r, geo.terrain, chance, cfg.rain.rate,
                              height, cfg.seed, grid=grid, until=cfg.run.rain_until,
                              inset=solver.h))  # fmt: skip
    for name, inf in cfg.inflows.items():
        xy = geo.to_local(inf.position, f"inflows.{name}.position")
        callbacks.append(PointInflow(IterationInterval(1), solver, r, geo.terrain, xy, inf.discharge,
                                     inf.radius, inf.height, name, cfg.seed))  # fmt: skip
    callbacks.extend(wet.callbacks)  # the coupler, then the moisture pass
    run = cfg.run
    if run.output_interval > 0:
        callbacks.append(SplashFrames(TimeInterval(run.output_interval), solver, wet, out.path / "particles"))
    if run.wetness_frames > 0:
        callbacks.append(WetnessFrames(TimeInterval(run.t_end / run.wetness_frames), geo, wet, out.maps / "frames"))
    callbacks.append(SplashOutputs(geo, wet, grid, cfg.drop is not None))

    def report(sim) -> dict[str, Any]:
        rep = splash_report(cfg, geo, dx, solver, wet, sim)
        rep["froude_scale"] = lam
        if facts is not None:
            rep["terrain"] = {**facts, **rep["terrain"]}
            rep["assumed"] = assumed
        rep["cost_estimate"] = {k: v for k, v in cost.items() if k != "estimate"}
        left = outside.left if outside is not None else {"water": 0.0, "mud": 0.0}
        rep["water_budget"]["left_nodata"] = left["water"] * wet.vp  # part of left_edges
        rep["solid_budget"]["mud_left_nodata"] = left["mud"] * wet.vp  # part of mud_left_edges
        return rep

    def summary(sim, rep: dict) -> dict[str, Any]:
        out = {
            "status": sim.status,
            "t": round(float(solver.t), 6),
            "steps": int(solver.steps),
            "fluid_particles": solver.n_fluid,
            "impacts": rep["impacts"]["count"],
            "water_closure_rel": rep["water_budget"]["closure_rel"],
            "solid_closure_rel": rep["solid_budget"]["closure_rel"],
        }
        if "crater_depth_m" in rep:
            out.update(crater_depth_m=rep["crater_depth_m"], crater_width_m=rep["crater_width_m"])
        out["wall_time_s"] = round(sim.wall_time, 2)
        return out

    return Setup(
        models=[solver], callbacks=callbacks, stop_time=run.t_end, unit="s", report=report, summary=summary,
        checkpoint_wall_s=run.checkpoint_wall_s, seed=cfg.seed, warnings=warnings, assumed=assumed,
        estimate=cost["estimate"],
    )  # fmt: skip


def columns_for(raster, spacing: float) -> int:
    """Columns of porous ground of ``spacing`` m on the map (whole spacings across it)."""
    return int(((raster.nx - 1) * raster.dx) // spacing) * int(((raster.ny - 1) * raster.dy) // spacing)


def scaling_line(given: SplashScenario, scaled: SplashScenario, lam: float, cell: float) -> str:
    """One line that says how :func:`froude_scaled` changed the values one reads most (times, rain)."""
    pairs = [("run.t_end", given.run.t_end, scaled.run.t_end, "s")]
    if given.run.rain_until is not None:
        pairs.append(("run.rain_until", given.run.rain_until, scaled.run.rain_until, "s"))
    if given.rain.rate > 0:
        pairs += [("rain.rate", given.rain.rate, scaled.rain.rate, "mm/h"),
                  ("rain.height", given.rain.height, scaled.rain.height, "m")]  # fmt: skip
    changes = ", ".join(f"{k} {a:.4g} → {b:.4g} {u}" for k, a, b, u in pairs)
    return (f"scaled: the scenario's values are for {given.scale.reference_cell:g} m cells; on these {cell:g} m cells "
            f"every dimensional value (--set ones too) is scaled by Froude similarity, λ = {lam:.4g} (lengths × λ, "
            f"times and speeds × √λ = {math.sqrt(lam):.4g}): {changes}")  # fmt: skip


#: CPU seconds of a splash run on one core, per fluid step, per fluid particle-step and per ground diffusion
#: pair at each coupling: fitted to the 80 × 80 DEM of docs/splash.md (490 s: 26 s of SPH steps, 442 s of
#: seepage passes over 5.6·10⁶ pairs) and checked on an 18 × 18 one (estimate 3.6 s, measured 3.1 s)
STEP_S, PARTICLE_STEP_S, PAIR_COUPLING_S = 2.0e-3, 3.0e-6, 4.5e-8
#: bytes per ground particle (its state and cell lists) and per diffusion pair (two indices and a weight)
GROUND_BYTES, PAIR_BYTES = 400.0, 24.0


def run_cost(cfg: SplashScenario, solver, ground: PorousGround) -> dict[str, Any]:
    """The run's sizes and a rough time (within a factor of about three), said before it starts: steps from
    the first step's limit (sound speed and spacing; the fluid's speed shortens the steps later: 13 % more of
    them on the DEM of docs/splash.md), the fluid expected (rain over the run), the ground's particles and pairs."""
    dt = solver.dt_limit() if cfg.sph.dt <= 0 else cfg.sph.dt
    steps = int(math.ceil(cfg.run.t_end / dt))
    fluid = solver.n_fluid
    if cfg.rain.rate > 0:
        rained = cfg.rain.rate / 3.6e6 * (cfg.run.rain_until or cfg.run.t_end) * ground.ncol * ground.area
        fluid += int(rained / solver.params.spacing**3)
    pairs = len(ground.i)
    seconds = steps * (STEP_S + PARTICLE_STEP_S * 0.5 * fluid + PAIR_COUPLING_S * pairs / cfg.run.every)

    seconds += START_S
    dx = solver.params.spacing
    what = (f"about {steps:,} steps of {dt:.3g} s, up to {fluid:,} fluid particles of {dx:.3g} m, "
            f"{ground.n:,} ground particles of {ground.s:.3g} m ({ground.ncol:,} columns × {ground.layers} layers, "
            f"{pairs:,} diffusion pairs)")  # fmt: skip
    memory = BASE_BYTES + SPH_PARTICLE_BYTES * fluid + GROUND_BYTES * ground.n + PAIR_BYTES * pairs
    fix = "coarsen ground.spacing, lower ground.layers or shorten run.t_end"
    est = Estimate(what, memory, seconds, fix)
    return {"steps": steps, "dt_s": dt, "fluid_particles": fluid, "ground_particles": ground.n,
            "ground_pairs": pairs, "seconds": seconds, "memory_bytes": memory, "estimate": est}  # fmt: skip
