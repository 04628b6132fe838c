"""The ``sph-terrain`` kind: SPH water on a heightmap that it erodes (seed 000; SPEC HM-1…HM-4, ER-1…ER-5).

The terrain (a DEM, a generated map, or a 2-D flume bed) lives in the SPH frame: x east and y north in
metres from its south-west node, z up; rows of the SPH-frame arrays run northward (the reverse of the
map order of files). Positions a scenario gives in the DEM's own coordinates are converted here.

A run: the fluid (a lake filled to ``water.level``, ``[[fluid]]`` boxes) on the ground
(``ground.model``: the particle-free heightfield wall or boundary particles), walls or open edges,
rain and point inflows adding water, and every ``erosion.every`` steps the coupler binning the fluid
onto the terrain's nodes and applying transport-capacity erosion. It leaves

* ``maps/`` (3-D, the DEM's grid, CRS and transform): height.tif, height_initial.tif,
  water_depth.tif (last binning), max_water_depth.tif, erosion.tif, deposition.tif (m, ≥ 0),
  sediment.tif (sediment held in the water, m³ per m² of bed), rain.tif (the rain's intensity, mm/h,
  when it rains); 2-D: ``profile.csv`` with the same columns along x;
* ``figures/maps_NNN.png`` (the thesis's three panels: height, water over the surface, difference
  from the initial terrain; 2-D: the bed profile), ``figures/evolution.gif``, hillshades before and
  after (3-D), rain.png (the rain map, the thesis's fig. 20);
* ``particles/`` frames when ``run.output_interval`` > 0; ``front.csv`` with ``measure.front``;
* ``report.json``: ``water_budget`` (m³ of water at rest: initial, rained, inflow, left_edges,
  in_fluid, closure_rel), ``sediment_budget`` (m³: eroded, deposited, suspended, carried_off,
  transport_error, closure_rel), ``particles_below_ground`` (the most seen at any check, every
  ``erosion.every`` steps and at the end: 0), the time spent coupling.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from erosim.core.errors import ConfigError
from erosim.core.schedules import IterationInterval, TimeInterval
from erosim.coupling.coupler import Coupler
from erosim.coupling.sampling import sample
from erosim.coupling.sources import EdgeOutflow, PointInflow, Rain, lake_particles
from erosim.coupling.terrains import HeightfieldTerrain
from erosim.erosion.transport_capacity_mei2007 import TransportCapacity
from erosim.scenarios import estimate
from erosim.scenarios.setup import Setup
from erosim.scenarios.sph.build import lattice
from erosim.scenarios.sph_terrain.geometry import Geometry, bedrock_map, edge_planes, geometry, rain_map
from erosim.scenarios.sph_terrain.outputs import BelowGround, TerrainOutputs, panel_function, terrain_report
from erosim.scenarios.sph_terrain.schema import SPHTerrainScenario
from erosim.simulation import callbacks as cb
from erosim.sph.boundaries.heightfield import GroundParticles, HeightfieldGround
from erosim.sph.boundaries.planes import PlaneWalls
from erosim.sph.solver import SPHSolver

#: more particles than this would not fit in the memory of a workstation (about 1 kB each)
MAX_PARTICLES = 20_000_000


def fluid_positions(cfg: SPHTerrainScenario, geo: Geometry) -> np.ndarray:
    """The initial water: the lake and the ``[[fluid]]`` boxes (lattice points above the ground)."""
    dx, d = cfg.sph.spacing, geo.dim
    parts = []
    if cfg.water.level is not None:
        seed = geo.to_local(cfg.water.seed, "water.seed") if cfg.water.seed is not None else None
        parts.append(lake_particles(geo.raster, geo.terrain, cfg.water.level, dx, d, seed))
    for i, b in enumerate(cfg.fluid):
        lo = np.concatenate([geo.to_local(b.lo[: d - 1], f"fluid block {i + 1} lo"), [b.lo[-1]]])
        hi = np.concatenate([geo.to_local(b.hi[: d - 1], f"fluid block {i + 1} hi"), [b.hi[-1]]])
        pts = lattice(np.minimum(lo, hi), np.maximum(lo, hi), dx)
        pts = pts[pts[:, -1] > sample(geo.raster, geo.terrain, pts) + 0.4 * dx]
        parts.append(pts)
    return np.concatenate(parts) if parts else np.zeros((0, d))


def build_solver(cfg: SPHTerrainScenario, geo: Geometry, fluid: np.ndarray):
    """The solver with its ground and edge walls; the sound speed from the highest fall the water can take."""

    p, r, d = cfg.sph, geo.raster, geo.dim
    dx = p.spacing
    if dx > MAX_SPACING_CELLS * min(r.dx, r.dy if d == 3 else r.dx):
        raise ConfigError(
            f"sph.spacing = {dx:g} m is more than {MAX_SPACING_CELLS:g} terrain cells ({r.dx:g} m): the particles "
            f"cannot follow the ground; use sph.spacing ≤ {MAX_SPACING_CELLS * r.dx:g} m or a coarser terrain."
        )
    ground_min = float(geo.terrain.min())
    tops = [float(fluid[:, -1].max()) + 0.5 * dx] if len(fluid) else []
    if cfg.rain.rate > 0:
        tops.append(float(geo.terrain.max()) + cfg.rain.height)
    tops += [float(geo.terrain.max()) + inf.height for inf in cfg.inflows.values()]
    if not tops:
        raise ConfigError("The scenario has no water: give water.level, a [[fluid]] block, rain.rate > 0 or an inflow.")
    fall = max(tops) - ground_min
    derived = {}
    if p.sound_speed <= 0:
        g = math.sqrt(sum(x * x for x in p.gravity_vector()))
        c = max(10.0 * math.sqrt(2.0 * g * max(fall, dx)), 1e-3)
        p = p.model_copy(update={"sound_speed": c})
        derived = {"sound_speed": c, "fall_height_m": fall, "rule": "c = 10·sqrt(2 g H), H from the lowest ground "
                   "to the highest water, drop or jet"}  # fmt: skip
    h = p.support()
    margin = 4.0 * h
    lo = [r.x0 - margin] + ([r.y0 - margin] if d == 3 else []) + [ground_min - margin]
    hi = [r.x0 + (r.nx - 1) * r.dx + margin] + ([r.y0 + (r.ny - 1) * r.dy + margin] if d == 3 else [])
    hi.append(max(tops + [float(geo.terrain.max())]) + max(10.0 * h, 0.5 * fall))
    if cfg.ground.model == "heightfield":
        ground = HeightfieldGround(r, geo.terrain)
    else:
        ground = GroundParticles(r, geo.terrain, dx, p.layers(), d)
    boundaries = [ground]
    planes = edge_planes(geo, cfg.edges.outflow)
    if planes is not None:
        boundaries.append(PlaneWalls(*planes))
    solver = SPHSolver(p, fluid, domain_lo=lo, domain_hi=hi, seed=cfg.seed, boundaries=boundaries)
    return solver, ground, derived


def _check_size(cfg: SPHTerrainScenario, geo: Geometry, fluid: np.ndarray, sources: list) -> None:
    """Refuse, before any step, a run whose sources would add more particles than memory holds."""
    vp = cfg.sph.spacing**geo.dim
    flow = sum(s.flow for s in sources if isinstance(s, Rain))
    flow += sum(inf.discharge for inf in cfg.inflows.values())
    expected = len(fluid) + flow * cfg.run.t_end / vp
    if expected > MAX_PARTICLES:
        raise ConfigError(
            f"The water of this run ({flow:.3g} m³/s of rain and inflow for {cfg.run.t_end:g} s, plus {len(fluid)} "
            f"particles) would need about {expected:.3g} particles of {cfg.sph.spacing:g} m, more than the "
            f"{MAX_PARTICLES:.0e} that fit in memory; lower rain.rate or the inflows, shorten run.t_end or raise "
            "sph.spacing."
        )


def setup(scenario, out) -> Setup:
    """The fluid, its ground, sources, sinks, coupler and outputs of an ``sph-terrain`` run."""

    cfg: SPHTerrainScenario = scenario.config
    geo = geometry(cfg)
    fluid = fluid_positions(cfg, geo)
    solver, ground, derived = build_solver(cfg, geo, fluid)
    r, e = geo.raster, cfg.erosion
    bedrock = bedrock_map(cfg, geo)
    eroder = None
    if e.enabled:  # the bed beyond an open edge: the initial terrain extrapolated (a free outflow, not a sink)
        eroder = TransportCapacity(e, r, solver, bedrock, outflow=cfg.edges.outflow, terrain=geo.terrain)
    heights = HeightfieldTerrain(r, geo.terrain, solver.dim, bedrock=bedrock, near_bed=2.0 * solver.h)
    coupler = Coupler(IterationInterval(e.every), solver, eroder, heights)
    callbacks: list = []
    if cfg.edges.outflow:
        callbacks.append(EdgeOutflow(IterationInterval(1), solver, r, cfg.edges.outflow))
    chance = None
    if cfg.rain.rate > 0:
        chance = rain_map(cfg, geo)
        callbacks.append(Rain(IterationInterval(cfg.rain.every), solver, r, geo.terrain, chance, cfg.rain.rate,
                              cfg.rain.height, cfg.seed, grid=heights.grid))  # fmt: skip
    for name, inf in cfg.inflows.items():
        xy = geo.to_local(inf.position, f"inflows.{name}.position")
        callbacks.append(PointInflow(IterationInterval(1), solver, r, geo.terrain, xy, inf.discharge,
                                     inf.radius, inf.height, name, cfg.seed))  # fmt: skip
    _check_size(cfg, geo, fluid, callbacks)
    callbacks.append(coupler)
    run = cfg.run
    if run.output_interval > 0:
        callbacks.append(cb.ParticleFrames(TimeInterval(run.output_interval), solver, out.path / "particles"))
    front = None
    if cfg.measure.front:
        origin = cfg.measure.front_origin if cfg.measure.front_origin is not None else 0.0
        front = cb.FrontTracker(TimeInterval(run.sample_interval), solver, out.path / "front.csv",
                                spacing=cfg.sph.spacing, origin=origin)  # fmt: skip
        callbacks.append(front)
    panel = panel_function(geo, coupler, scenario.name)
    if run.map_frames > 0:
        figures = out.path / "figures"  # maps_NNN.png on a schedule and evolution.gif of them at the end
        callbacks.append(
            cb.Animation(
                TimeInterval(run.t_end / run.map_frames),
                lambda sim: panel(),
                figures / "evolution.gif",
                fps=4.0,
                stills=str(figures / "maps_{:03d}.png"),
                thumbnail=2,
                name="map_frames",
            )
        )
    below = BelowGround(IterationInterval(e.every), solver, ground)
    rain = None if chance is None or geo.dim == 2 else chance * cfg.rain.rate
    callbacks += [below, TerrainOutputs(geo, coupler, eroder, panel, rain)]
    warnings = list(geo.dem.notes) if geo.dem is not None else []
    if geo.nodata is not None:
        warnings.append(f"{int(geo.nodata.sum())} nodata cells of the terrain stand as walls.")

    def report(sim) -> dict[str, Any]:
        return terrain_report(cfg, geo, solver, coupler, eroder, below, front, derived, sim)

    def summary(sim, rep: dict) -> dict[str, Any]:
        wb, sb = rep["water_budget"], rep.get("sediment_budget", {})
        return {
            "status": sim.status,
            "t": round(float(solver.t), 6),
            "steps": int(solver.steps),
            "fluid_particles": solver.n_fluid,
            "water_m3": wb["in_fluid"],
            "water_closure_rel": wb["closure_rel"],
            **({"eroded_m3": sb["eroded"], "sediment_closure_rel": sb["closure_rel"]} if sb else {}),
            "particles_below_ground": rep["particles_below_ground"],
            "wall_time_s": round(sim.wall_time, 2),
        }

    return Setup(
        models=[solver], callbacks=callbacks, stop_time=run.t_end, unit="s", report=report, summary=summary,
        checkpoint_wall_s=run.checkpoint_wall_s, seed=cfg.seed, warnings=warnings,
        estimate=run_estimate(cfg, geo, solver, callbacks),
    )  # fmt: skip


#: wall time per step of the ground's passes and the run's callbacks (2-D, 3-D), and per map cell at each
#: coupling: fitted to ``dam-break-erodible`` (2 815 steps of 3 500 particles in 37 s) and ``rain-erosion``
#: (1 345 steps, 64² cells, 42 s, 9 s of it coupling) with ``run.t_end`` shortened, 2 cores under a load of 4
TERRAIN_STEP_S, COUPLING_CELL_S = {2: 0.010, 3: 0.022}, 3.3e-5


def run_estimate(cfg: SPHTerrainScenario, geo: Geometry, solver, callbacks):
    """Memory and time of the run from its built solver (:func:`erosim.scenarios.estimate.from_solver`): the
    rain and inflows over ``run.t_end`` added, the coupler's maps and passes per step."""

    vp = cfg.sph.spacing**geo.dim
    flow = sum(s.flow for s in callbacks if isinstance(s, Rain)) + sum(i.discharge for i in cfg.inflows.values())
    cells = geo.raster.nx * (geo.raster.ny if geo.dim == 3 else 1)
    extra = TERRAIN_STEP_S[geo.dim] + COUPLING_CELL_S * cells / cfg.erosion.every
    what = f"{cells:,} map cells" if geo.dim == 3 else f"a 2-D flume of {cells:,} cells"
    return estimate.from_solver(
        what,
        solver,
        cfg.run.t_end,
        added=flow * cfg.run.t_end / vp,
        extra_bytes=estimate.GRID_CELL_BYTES * cells,
        step_extra_s=extra,
        fix="lower rain.rate or the inflows, shorten run.t_end or raise sph.spacing",
    )


#: a spacing wider than this many terrain cells cannot resolve the terrain the water runs on
MAX_SPACING_CELLS = 2.0
