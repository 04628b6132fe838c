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
from dataclasses import dataclass
from typing import Any

import numpy as np

from erosim.core.errors import ConfigError, InputError
from erosim.core.heightmap import Heightmap
from erosim.core.schedules import IterationInterval, Schedule, TimeInterval
from erosim.coupling.coupler import Coupler
from erosim.coupling.raster import Raster
from erosim.coupling.sampling import sample
from erosim.coupling.sources import EdgeOutflow, PointInflow, Rain, lake_particles
from erosim.coupling.terrains import HeightfieldTerrain
from erosim.scenarios.schema_common import build_terrain
from erosim.scenarios.setup import Setup
from erosim.scenarios.sph.build import lattice
from erosim.scenarios.sph_terrain.schema import SPHTerrainScenario
from erosim.simulation import callbacks as cb

#: a spacing wider than this many terrain cells cannot resolve the terrain the water runs on
MAX_SPACING_CELLS = 2.0
#: more particles than this would not fit in the memory of a workstation (about 1 kB each)
MAX_PARTICLES = 20_000_000


@dataclass
class Geometry:
    """The terrain in the SPH frame and the conversion from the DEM's coordinates."""

    raster: Raster
    terrain: np.ndarray  # live: the ground the fluid feels and the erosion changes (nodata raised to walls)
    initial: np.ndarray
    nodata: np.ndarray | None
    dem: Heightmap | None  # the map-order DEM (outputs keep its grid and georeference)
    dim: int

    def to_local(self, xy, what: str) -> np.ndarray:
        """DEM coordinates (x[, y]) → SPH-frame metres; refuses a point off the map."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1)
        r = self.raster
        if self.dim == 2:
            local = xy[:1]
        else:
            a, _, c, _, e, f = self.dem.transform
            col = (xy[0] - c) / a - 0.5
            row = (xy[1] - f) / e - 0.5
            local = np.array([col * r.dx, (r.ny - 1 - row) * r.dy])
        span = np.array([(r.nx - 1) * r.dx, (r.ny - 1) * r.dy])[: self.dim - 1]
        if np.any(local < -1e-9) or np.any(local > span + 1e-9):
            raise ConfigError(
                f"{what} {xy.tolist()} lies outside the terrain; give a point on the map (its own coordinates)."
            )
        return local


def geometry(cfg: SPHTerrainScenario) -> Geometry:
    """The scenario's terrain as a :class:`Geometry` (nodata cells raised into walls)."""
    if cfg.profile is not None:
        p = cfg.profile
        nx = int(round(p.length / p.cell_size)) + 1
        x = np.arange(nx) * p.cell_size
        z = (p.height + p.slope * x)[None, :]
        raster = Raster(0.0, 0.0, p.cell_size, 1.0, nx, 1)
        return Geometry(raster, z.copy(), z.copy(), None, None, 2)
    return dem_geometry(cfg.terrain, cfg.seed, cfg.ground.nodata_wall)


def dem_geometry(terrain, seed: int, nodata_wall: float | None) -> Geometry:
    """A scenario's ``[terrain]`` in the SPH frame (rows northward). Nodata cells keep the nearest valid
    heights (as every kind reads a DEM) and are marked in ``Geometry.nodata``; with ``nodata_wall`` they
    are raised into walls that many metres above the DEM's top."""
    from erosim.io.heightmaps import default_transform
    from erosim.sph.boundaries.heightfield import wall_heights

    hm = build_terrain(terrain, seed)
    if hm.transform is None:
        hm = hm.copy()
        hm.transform = default_transform(*hm.shape, hm.cell_size)
    ny, nx = hm.shape
    raster = Raster(0.0, 0.0, hm.cell_size, hm.cell_size, nx, ny)
    z = np.ascontiguousarray(hm.z[::-1], dtype=np.float64)
    nodata = None if hm.nodata is None or not hm.nodata.any() else np.ascontiguousarray(hm.nodata[::-1])
    if nodata is not None and nodata_wall is not None:
        z = wall_heights(z, nodata, float(z[~nodata].max()) + nodata_wall)
    return Geometry(raster, z.copy(), z.copy(), nodata, hm, 3)


def _map_like_terrain(path: str, what: str, geo: Geometry) -> np.ndarray:
    """A raster of the terrain's size (bedrock, rain map) in the SPH frame (rows northward)."""
    from erosim.io.heightmaps import read

    m = read(path).z
    if m.shape != geo.terrain.shape:
        raise InputError(
            f"{what} '{path}' has shape {m.shape} but the terrain {geo.terrain.shape}; give one of the terrain's size."
        )
    return np.ascontiguousarray(m[::-1], dtype=np.float64)


def _bedrock(cfg: SPHTerrainScenario, geo: Geometry) -> np.ndarray | None:
    g = cfg.ground
    if g.bedrock_file:
        return _map_like_terrain(g.bedrock_file, "Bedrock map", geo)
    if g.bedrock_depth is not None:
        return geo.initial - g.bedrock_depth
    return None


def _rain_map(cfg: SPHTerrainScenario, geo: Geometry) -> np.ndarray:
    r = cfg.rain
    if r.file:
        m = _map_like_terrain(r.file, "Rain map", geo)
        top = float(np.nanmax(m)) if np.isfinite(m).any() else 0.0
        return m / top if top > 1.0 else m  # an image (0…255, 0…65535): its brightest cell is chance 1
    if r.pattern == "uniform":
        return np.ones(geo.terrain.shape)
    from scipy import ndimage

    noise = np.random.default_rng([cfg.seed, 0x5A17]).random(geo.terrain.shape)
    blobs = ndimage.gaussian_filter(noise, r.noise_scale, mode="wrap")
    blobs = (blobs - blobs.min()) / max(float(np.ptp(blobs)), 1e-12)
    return np.clip(1.6 * blobs - 0.3, 0.0, 1.0)


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


def _edge_planes(geo: Geometry, open_edges) -> tuple[np.ndarray, np.ndarray] | None:
    r, d = geo.raster, geo.dim
    xe, ye = (r.nx - 1) * r.dx, (r.ny - 1) * r.dy
    walls = {"west": ([0.0, 0.0], [1.0, 0.0]), "east": ([xe, 0.0], [-1.0, 0.0])}
    if d == 3:
        walls.update({"south": ([0.0, 0.0], [0.0, 1.0]), "north": ([0.0, ye], [0.0, -1.0])})
    pts, nrm = [], []
    for name, (p0, n) in walls.items():
        if name in open_edges:
            continue
        pts.append(p0[: d - 1] + [0.0])
        nrm.append(n[: d - 1] + [0.0])
    return (np.array(pts), np.array(nrm)) if pts else None


def build_solver(cfg: SPHTerrainScenario, geo: Geometry, fluid: np.ndarray):
    """The solver with its ground and edge walls; the sound speed from the highest fall the water can take."""
    from erosim.sph.boundaries.heightfield import GroundParticles, HeightfieldGround
    from erosim.sph.boundaries.planes import PlaneWalls
    from erosim.sph.solver import SPHSolver

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
    planes = _edge_planes(geo, cfg.edges.outflow)
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


class BelowGround(cb.Callback):
    """Counts fluid particles below the ground (1 mm below the Q4 surface), keeps the most seen."""

    def __init__(self, schedule, solver, ground):
        super().__init__(schedule, name="below_ground")
        self.solver, self.ground = solver, ground
        self.most = 0

    def __call__(self, sim) -> None:
        self.most = max(self.most, self.now())

    def now(self) -> int:
        return self.ground.below(self.solver, tol=1e-3)

    def state_dict(self) -> dict[str, Any]:
        return {"most": self.most}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.most = int(state.get("most", 0))


class TerrainOutputs(cb.Callback):
    """The final maps (DEM grid), profile and pictures of a completed run."""

    def __init__(self, geo: Geometry, coupler: Coupler, eroder, panel, rain: np.ndarray | None = None):
        super().__init__(Schedule(), name="outputs")
        self.geo, self.coupler, self.eroder, self.panel = geo, coupler, eroder, panel
        self.rain = rain  # the rain's intensity per cell (mm/h, SPH frame), or None without rain

    def fields(self) -> dict[str, np.ndarray]:
        """Output fields in the SPH frame (rows northward)."""
        g, c = self.geo, self.coupler
        sediment = self.eroder.held_map() if self.eroder is not None else np.zeros_like(g.terrain)
        return {
            "height_initial": g.initial,
            "height": c.terrain.z,
            "water_depth": c.terrain.grid.depth,
            "max_water_depth": c.terrain.grid.max_depth,
            "erosion": np.maximum(g.initial - c.terrain.z, 0.0),
            "deposition": np.maximum(c.terrain.z - g.initial, 0.0),
            "sediment": sediment,
        }

    def finalize(self, sim) -> dict[str, Any]:
        out, g = sim.out, self.geo
        self.coupler.terrain.grid.bin(self.coupler.solver)  # the water as it is at the end
        fields = self.fields()
        from erosim.viz.maps import save_png

        with out.picture(out.figures / "maps_final.png"):
            save_png(out.figures / "maps_final.png", self.panel())
        if g.dim == 2:
            x = np.arange(g.raster.nx) * g.raster.dx
            cols = ["x"] + list(fields)
            rows = np.column_stack([x] + [f[0] for f in fields.values()])
            out.write_text("profile.csv", cb.csv_text(cols, rows))
            return {"outputs": {"profile": "profile.csv", "figure": "figures/maps_final.png"}}
        from erosim.io import heightmaps as hio

        written = {}
        for name, arr in fields.items():
            mapped = np.ascontiguousarray(arr[::-1])
            hio.write(out.maps / f"{name}.tif", mapped, like=g.dem)
            written[name] = {"path": f"maps/{name}.tif", "min": float(mapped.min()), "max": float(mapped.max())}
        if self.rain is not None:  # the rain map (seed 000's fig. 20): where the drops fall, and how hard
            rain = np.ascontiguousarray(self.rain[::-1])
            hio.write_raster(out.maps / "rain.tif", rain.astype(np.float32), g.dem)
            written["rain"] = {"path": "maps/rain.tif", "min": float(rain.min()), "max": float(rain.max()),
                               "unit": "mm/h"}  # fmt: skip
        from erosim.viz.plots import change_figure, extent_of, hillshade_figure, map_figure

        north_up = g.initial[::-1]
        box = extent_of(g.dem.transform if g.dem is not None else None, north_up.shape, g.raster.dx)
        after = self.coupler.terrain.z[::-1]
        with out.picture(out.figures / "hillshade_before.png"):
            hillshade_figure(out.figures / "hillshade_before.png", north_up, g.raster.dx, "Terrain before", box)
        with out.picture(out.figures / "hillshade_after.png"):
            hillshade_figure(out.figures / "hillshade_after.png", after, g.raster.dx, "Terrain after", box)
        with out.picture(out.figures / "erosion_deposition.png"):
            change_figure(out.figures / "erosion_deposition.png", after - north_up, g.raster.dx,
                          "Erosion and deposition", box)  # fmt: skip
        if self.rain is not None:
            bar = {"cmap": "Blues", "vmin": 0.0, "vmax": max(float(self.rain.max()), 1e-9), "label": "rain (mm/h)"}
            with out.picture(out.figures / "rain.png"):
                map_figure(out.figures / "rain.png", self.rain[::-1], g.raster.dx, "Rain map", colorbar=bar,
                           extent=box)  # fmt: skip
        return {"outputs": {"maps": written, "figure": "figures/maps_final.png"}}


#: the change panel's fixed scale, ± this share of the terrain's relief
CHANGE_RANGE_OF_RELIEF = 0.1
#: the water panel leaves out films thinner than this (m)
WATER_SHOWN_M = 1e-3


def _panel_function(geo: Geometry, coupler: Coupler, title: str):
    """The picture of the terrain and water now (three panels; 2-D: the bed profile) as an RGB array."""
    from erosim.viz.plots import profile_panel, terrain_panels

    # one scale for every frame's change panel: a tenth of the terrain's relief (at least a centimetre)
    relief = float(np.nanmax(geo.initial) - np.nanmin(geo.initial))
    change_range = max(CHANGE_RANGE_OF_RELIEF * relief, 0.01)
    # the water as the particles spread it: each particle's volume binned to its cell, then smoothed over a
    # particle's size (σ = Δx/2, at least a cell), so that scattered particles show as the sheet they are a part
    # of, not a cell-by-cell speckle (the picture only; maps/water_depth.tif keeps the binned depth)
    sigma = max(0.5 * coupler.solver.params.spacing / geo.raster.dx, 1.0)

    def panel() -> np.ndarray:
        c = coupler
        c.terrain.grid.bin(c.solver)
        t = f"{title}  t = {c.solver.t:.3g} s"
        if geo.dim == 2:
            x = np.arange(geo.raster.nx) * geo.raster.dx
            return profile_panel(x, geo.initial[0], c.terrain.z[0], c.terrain.grid.depth[0], title=t)
        from scipy.ndimage import gaussian_filter

        water = gaussian_filter(c.terrain.grid.depth, sigma, mode="constant")
        return terrain_panels(c.terrain.z[::-1], np.where(water >= WATER_SHOWN_M, water, 0.0)[::-1],
                              (c.terrain.z - geo.initial)[::-1], geo.raster.dx, title=t,
                              change_range=change_range)  # fmt: skip

    return panel


def setup(scenario, out) -> Setup:
    """The fluid, its ground, sources, sinks, coupler and outputs of an ``sph-terrain`` run."""
    from erosim.erosion.transport_capacity_mei2007 import TransportCapacity

    cfg: SPHTerrainScenario = scenario.config
    geo = geometry(cfg)
    fluid = fluid_positions(cfg, geo)
    solver, ground, derived = build_solver(cfg, geo, fluid)
    r, e = geo.raster, cfg.erosion
    bedrock = _bedrock(cfg, geo)
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
        chance = _rain_map(cfg, geo)
        callbacks.append(Rain(IterationInterval(cfg.rain.every), solver, r, geo.terrain, chance, cfg.rain.rate,
                              cfg.rain.height, cfg.seed, grid=heights.grid))  # fmt: skip
    for name, inf in cfg.inflows.items():
        xy = geo.to_local(inf.position, f"inflows.{name}.position")
        callbacks.append(PointInflow(IterationInterval(1), solver, r, geo.terrain, xy, inf.discharge,
                                     inf.radius, inf.height, name))  # fmt: skip
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
    panel = _panel_function(geo, coupler, scenario.name)
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
    from erosim.scenarios import estimate

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


def terrain_report(cfg, geo: Geometry, solver, coupler: Coupler, eroder, below: BelowGround, front, derived, sim):
    """The ``sph-terrain`` kind's entries of ``report.json``."""
    st = solver.state
    vp = cfg.sph.spacing**geo.dim  # m³ of water at rest per particle (per unit width in 2-D: m²)
    added, removed = st.added, st.removed
    rained = added.get("rain", 0) * vp
    inflow = sum(v for k, v in added.items() if k.startswith("inflow:")) * vp
    left = sum(v for k, v in removed.items() if k.startswith("edge:")) * vp
    initial, now = st.initial * vp, st.n_fluid * vp
    supplied = initial + rained + inflow
    steps = sim.iteration - sim.iteration_start
    rep: dict[str, Any] = {
        "dim": geo.dim,
        "t": float(solver.t),
        "t_end": cfg.run.t_end,
        "steps": int(solver.steps),
        "fluid_particles": st.n_fluid,
        "ground": cfg.ground.model,
        "terrain": {
            "shape": list(geo.terrain.shape[::-1] if geo.dim == 2 else geo.terrain.shape),
            "cell_size_m": geo.raster.dx,
            "crs": geo.dem.crs if geo.dem is not None else None,
            "nodata_cells": int(geo.nodata.sum()) if geo.nodata is not None else 0,
            "z_min": float(geo.initial.min()),
            "z_max": float(geo.initial.max()),
        },
        "resolution": {"spacing": cfg.sph.spacing, "support_h": solver.h, "particle_volume_m3": vp, **derived},
        "water_budget": {
            "unit": "m3" if geo.dim == 3 else "m2 (per metre of width)",
            "initial": initial,
            "rained": rained,
            "inflow": inflow,
            "left_edges": left,
            "in_fluid": now,
            "closure_rel": abs(supplied - left - now) / supplied if supplied > 0 else 0.0,
        },
        "particles_below_ground": max(below.most, below.now()),  # the most seen at any check (0 expected)
        "particles_below_ground_now": below.now(),
        "dt_mean": float(solver.t) / solver.steps if solver.steps else None,
        "particle_steps_per_s": st.n_fluid * steps / sim.wall_time if sim.wall_time > 0 and steps else None,
        "coupling_wall_s": round(coupler.wall, 3),
        "coupling_fraction": coupler.wall / sim.wall_time if sim.wall_time > 0 else None,
    }
    if eroder is not None:
        sb = coupler.budget()
        held, carried, err = eroder.held_total(), eroder.carried_off(), eroder.transport_error
        eroded = sb["eroded"]
        rep["sediment_budget"] = {
            "unit": "m3" if geo.dim == 3 else "m2 (per metre of width)",
            "eroded": eroded,
            "deposited": sb["deposited"],
            "suspended": held,
            "carried_off": carried,
            "transport_error": err,
            "transport": cfg.erosion.transport,
            "couplings": sb["couplings"],
            "closure_rel": abs(eroded - sb["deposited"] - held - carried + err) / eroded if eroded > 0 else 0.0,
        }
    if front is not None and front.rows:
        rep["x_front"] = front.rows[-1][1]
    return rep
