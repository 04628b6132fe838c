"""The ``voxel`` kind: SPH water scouring a voxel terrain (seed 001; SPEC VX-1…VX-10).

The terrain is a :class:`~erosim.terrain.voxel.VoxelTerrain` (a flume's floor, an optional plinth and a
trapezoidal embankment, :mod:`erosim.terrain.voxel`) felt by the fluid through the wall-weight
boundary :class:`~erosim.sph.boundaries.voxel_wall.VoxelWall`; the flume's side walls and upstream
end are analytic planes; the reservoir fills by layers laid at rest on its surface (``[inflow]``); water leaving past
the downstream end is removed and counted. Every
``erosion.every`` steps the :class:`~erosim.coupling.coupler.Coupler` applies the
shear-stress erosion of :mod:`erosim.erosion.shear_stress_kristof2009` to the field.

A run leaves

* ``figures/section_NNNN.png`` (``run.sections``): cross-sections, the run's starting surface dashed;
* ``figures/surface.png`` (``run.surface_figure``), at the end: the surface at the start and at the end,
  the latter coloured by its lowering, the water as dots (:mod:`erosim.viz.surface_render`);
* ``meshes/surface_NNNN.{obj,ply,glb}`` (``run.meshes``) and ``fields/density_NNNN.{npz,vti}``
  (``run.field_format``) per output time (every ``run.output_interval``, and at the start and end),
  ``particles/`` frames at the same times (``run.particle_frames``);
* ``profiles.csv`` (``t,x,z``): the surface height z along the flume's centre line, x from the
  embankment's upstream toe (a heightmap: along the middle row, x in the terrain's frame), every
  ``run.profile_interval``; ``figures/profiles.png`` with the profiles every ``run.figure_interval``
  (and the last);
* ``maps/`` (a heightmap's voxels): height.tif, height_initial.tif, erosion.tif, deposition.tif and
  water_depth.tif on the DEM's grid with its CRS (:class:`VoxelMaps`);
* ``report.json``: ``eroded_volume_m3``, ``first_erosion`` {t (flow time), t_morphological (t ×
  ``erosion.morfac``), x (from the upstream toe), z, y}: the first node, solid at the start, that the
  eroded surface has passed (density at or below the iso level), ``first_transfer`` the same for the
  first quantum moved (:mod:`erosim.coupling.terrains`), the ``budget`` (m³: eroded = carried off;
  pending, unmet, the field's change, closure), ``particles_inside_solid`` (the most seen after any
  coupling; 0) and the timings.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from erosim.core.errors import ConfigError, InputError
from erosim.core.schedules import IterationInterval, TimeInterval
from erosim.coupling.coupler import Coupler
from erosim.coupling.raster import Raster
from erosim.coupling.sampling import sample
from erosim.coupling.sources import EDGES, EdgeOutflow, FlumeInflow, PointInflow, RainDrops
from erosim.coupling.terrains import VoxelFieldTerrain
from erosim.erosion.excess_shear_partheniades1965 import ExcessShearErosion
from erosim.erosion.settling_voxel import SuspendedSediment
from erosim.erosion.shear_stress_kristof2009 import ShearStressErosion
from erosim.scenarios.schema_common import build_terrain as heightmap
from erosim.scenarios.schema_common import terrain_facts
from erosim.scenarios.setup import Setup
from erosim.scenarios.voxel.outputs import (
    EROSION_NOTES,
    Inside,
    Profiles,
    VoxelMaps,
    VoxelOutputs,
    profile_figure,
    reporter,
    top_surface,
)
from erosim.scenarios.voxel.schema import VoxelScenario, at_dem_scale, band_for, overflow_head
from erosim.sph.boundaries.planes import PlaneWalls
from erosim.sph.boundaries.voxel_wall import VoxelWall
from erosim.sph.solver import SPHSolver
from erosim.terrain.voxel import Box, Embankment, HalfSpace, VoxelTerrain


def build_terrain(cfg: VoxelScenario):
    """The scenario's voxel field: a saved field (``terrain.voxels_file``), a heightmap with its caves, or
    the flume's floor (z < 0), the plinth (z < ``embankment.base``) and the embankment; ``voxels.scale =
    "dem"`` resolved first (:func:`at_dem_scale`)."""

    cfg = at_dem_scale(cfg)
    f, e, v = cfg.terrain, cfg.embankment, cfg.voxels
    h = cfg.sph.support()
    if f.voxels_file:
        t = VoxelTerrain.load(f.voxels_file)
        if t.cell_size > h:
            raise ConfigError(
                f"The saved field's voxels of {t.cell_size:g} m are too coarse for the particle spacing "
                f"{cfg.sph.spacing:g} m (kernel support h = {h:g} m); use sph.spacing ≥ "
                f"{t.cell_size / cfg.sph.h_factor:g} m."
            )
        return t
    if v.cell_size > h:
        raise ConfigError(
            f"Voxels of {v.cell_size:g} m are too coarse for the particle spacing {cfg.sph.spacing:g} m: the wall "
            f"distance needs cells no larger than the kernel support h = {h:g} m; set voxels.cell_size ≤ {h:g}."
        )
    band = band_for(cfg)
    if f.shape == "heightmap":

        hm = heightmap(cfg.terrain, cfg.seed)
        lift = max([cfg.rain.height] + [j.height for j in cfg.inflows.values()])  # rain and the jets' mouths
        top = float(np.nanmax(hm.z)) + lift + band + 2 * v.cell_size
        bottom = float(np.nanmin(hm.z)) - max(band + 2 * v.cell_size, v.depth)
        try:
            t = VoxelTerrain.from_heightmap(hm, v.cell_size, bottom=bottom, top=top, band=band, iso=v.iso,
                                            max_bytes=v.max_bytes)  # fmt: skip
        except InputError as exc:  # the voxels' size that fits: the particles must come with them
            raise InputError(
                f"{str(exc).rstrip('.')}, setting sph.spacing with voxels.cell_size (voxels may be no larger "
                "than the kernel support, twice the spacing)."
            ) from None
        c = cfg.caves
        if c.wavelength > 0:
            t = t.carve_caves(wavelength=c.wavelength, threshold=c.threshold, seed=cfg.seed, octaves=c.octaves,
                              below=c.below)  # fmt: skip
        return t
    c = v.cell_size
    shapes = [HalfSpace((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
              Embankment(e.x_toe, e.height, e.crest_width, e.upstream, e.downstream, base=e.base)]  # fmt: skip
    if e.base > 0:
        shapes.append(Box((-1.0 - band, -1.0 - band, -1.0 - band), (f.length + 1.0 + band, f.width + 1.0 + band,
                                                                     e.base)))  # fmt: skip
    lo = (-2.0 * c, -2.0 * c, -(band + 2.0 * c))
    hi = (f.length + 2.0 * c, f.width + 2.0 * c, f.top)
    return VoxelTerrain.from_shapes(shapes, lo, hi, c, band=band, iso=v.iso, max_bytes=v.max_bytes)


def jet_mouths(cfg: VoxelScenario, terrain) -> tuple[list[float], Raster | None, np.ndarray | None]:
    """The ``[inflows.NAME]`` jets on a heightmap's voxels: the height of each mouth's centre (``height`` above
    the top surface, :func:`top_surface`, at ``position`` in the terrain's frame), the raster of the field's
    node columns and that surface (None without jets); a point off the map is refused."""
    if not cfg.inflows:
        return [], None, None
    c = terrain.cell_size
    _, ny, nx = terrain.shape
    nodes = Raster(float(terrain.lo[0]), float(terrain.lo[1]), c, c, nx, ny)
    ground = top_surface(terrain)
    lo, hi = np.asarray(terrain.lo[:2]), np.asarray(terrain.hi[:2])
    tops = []
    for name, jet in cfg.inflows.items():
        xy = np.asarray(jet.position, np.float64).reshape(-1)
        if xy.size != 2 or np.any(xy < lo) or np.any(xy > hi):
            raise ConfigError(
                f"inflows.{name}.position {xy.tolist()} lies outside the terrain; give [x, y] between "
                f"{lo.round(3).tolist()} and {hi.round(3).tolist()} m (the terrain's frame)."
            )
        tops.append(float(sample(nodes, ground, xy[None])[0]) + jet.height)
    return tops, nodes, ground


def jets(cfg: VoxelScenario, terrain, solver) -> list[PointInflow]:
    """The ``[inflows.NAME]`` sources (:class:`~erosim.coupling.sources.PointInflow`, a vertical jet each) on
    a heightmap's voxels, at :func:`jet_mouths`."""
    _, nodes, ground = jet_mouths(cfg, terrain)
    return [PointInflow(IterationInterval(1), solver, nodes, ground, jet.position, jet.discharge, jet.radius,
                        jet.height, name, cfg.seed) for name, jet in cfg.inflows.items()]  # fmt: skip


def rain_height(cfg: VoxelScenario, terrain) -> float:
    """z at which rain drops appear: ``rain.height`` above the highest solid node of the field."""
    solid = (terrain.density > terrain.iso).any(axis=(1, 2))
    z_top = terrain.axes()[2][np.nonzero(solid)[0].max()] if solid.any() else terrain.lo[2]
    return float(min(z_top + cfg.rain.height, terrain.hi[2]))


def build_solver(cfg: VoxelScenario, terrain):
    """The fluid (a reservoir or lakes at rest), its voxel wall and, in a flume, the planes of its side and
    upstream walls; the sound speed from the highest fall the water can take."""

    p, f, e = cfg.sph, cfg.terrain, cfg.embankment
    dx = p.spacing
    flume = f.shape == "flume"
    level = cfg.water.level
    fluid = np.zeros((0, 3))
    if level is not None:
        if flume:
            fluid = terrain.fluid_points(dx, lo=(0.0, 0.0, 0.0), hi=(e.x_toe + e.height * e.upstream, f.width, f.top),
                                         below=level)  # fmt: skip
        else:
            fluid = terrain.fluid_points(dx, below=level)
    if flume:
        if len(fluid) == 0 and cfg.inflow.discharge <= 0:
            raise ConfigError("The scenario has no water: give water.level above the floor or inflow.discharge > 0.")
        top, floor = max(level or 0.0, e.base + e.height + overflow_head(cfg.inflow.discharge, f.width)), 0.0
        what = "the water level or the crest and the overflow's head above the floor"
    else:
        if len(fluid) == 0 and cfg.rain.rate <= 0 and not cfg.inflows:
            raise ConfigError(
                "The scenario has no water: give water.level above some ground, rain.rate > 0 or an [inflows.NAME] jet."
            )
        top = max([float(fluid[:, 2].max()) if len(fluid) else -np.inf]
                  + ([rain_height(cfg, terrain)] if cfg.rain.rate > 0 else [])
                  + jet_mouths(cfg, terrain)[0])  # fmt: skip
        floor = float(terrain.lo[2])
        what = "the highest water, rain drop or jet's mouth above the field's bottom"
    derived = {}
    if p.sound_speed <= 0:
        g = math.sqrt(sum(x * x for x in p.gravity_vector()))
        c = 10.0 * math.sqrt(2.0 * g * max(top - floor, dx))
        p = p.model_copy(update={"sound_speed": c})
        derived = {"sound_speed": c, "rule": f"c = 10·sqrt(2 g H), H from {what}"}
    h = p.support()
    if flume:
        lo = [-4.0 * h, -4.0 * h, terrain.lo[2]]
        hi = [f.length + 4.0 * h, f.width + 4.0 * h, f.top + max(top, 0.5 * f.top)]
        planes = [PlaneWalls([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, f.width, 0.0]],
                             [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])]  # fmt: skip
    else:
        lo = [terrain.lo[0] - 4.0 * h, terrain.lo[1] - 4.0 * h, terrain.lo[2]]
        hi = [terrain.hi[0] + 4.0 * h, terrain.hi[1] + 4.0 * h, max(terrain.hi[2], top) + 10.0 * h]
        planes = []
    wall = VoxelWall(terrain, attraction=None if cfg.voxels.attraction == "none" else cfg.voxels.attraction)
    solver = SPHSolver(p, fluid, domain_lo=lo, domain_hi=hi, seed=cfg.seed, boundaries=[wall, *planes])
    return solver, wall, derived


def make_eroder(e, terrain, solver):
    """The eroder of ``erosion.law`` for ``terrain`` and the fluid of ``solver``."""
    if e.law == "excess_shear":

        return ExcessShearErosion(terrain, e, support=solver.h, spacing=solver.params.spacing,
                                  rho0=solver.params.rho0)  # fmt: skip

    return ShearStressErosion(terrain, e, support=solver.h)


def setup(scenario, out) -> Setup:
    """The flume, its fluid, inflow and outflow, the erosion coupler and the outputs of a ``voxel`` run."""
    cfg: VoxelScenario = at_dem_scale(scenario.config)
    terrain = build_terrain(cfg)
    solver, wall, derived = build_solver(cfg, terrain)
    e, run = cfg.erosion, cfg.run
    eroder = make_eroder(e, terrain, solver) if e.enabled else None
    if eroder is not None and e.sediment == "suspended":

        eroder = SuspendedSediment(eroder, solver, e.settling_velocity, e.max_concentration)
    coupler = Coupler(IterationInterval(e.every), solver, eroder, VoxelFieldTerrain(terrain), start=e.start)
    callbacks: list = []
    if cfg.inflow.discharge > 0:
        i = cfg.inflow
        callbacks.append(FlumeInflow(solver, i.x0, i.x1, cfg.terrain.width, i.discharge, cfg.terrain.top))
    flume = cfg.terrain.shape == "flume"
    if flume:
        # the open downstream end: a raster whose east edge is the flume's end
        ends = Raster(0.0, 0.0, cfg.terrain.length, cfg.terrain.width, 2, 2)
        callbacks.append(EdgeOutflow(IterationInterval(1), solver, ends, ["east"]))
    else:
        (x0, y0), (x1, y1) = terrain.lo[:2], terrain.hi[:2]
        box = Raster(float(x0), float(y0), float(x1 - x0), float(y1 - y0), 2, 2)
        callbacks.append(EdgeOutflow(IterationInterval(1), solver, box, EDGES))
        if cfg.rain.rate > 0:
            callbacks.append(RainDrops(IterationInterval(cfg.rain.every), solver, terrain.lo[:2], terrain.hi[:2],
                                       rain_height(cfg, terrain), cfg.rain.rate, cfg.seed))  # fmt: skip
        callbacks += jets(cfg, terrain, solver)
    callbacks.append(coupler)
    inside = Inside(IterationInterval(e.every), solver, wall)
    x0 = cfg.embankment.x_toe if flume else 0.0
    y_mid = 0.5 * cfg.terrain.width if flume else 0.5 * (terrain.lo[1] + terrain.hi[1])
    profiles = Profiles(TimeInterval(run.profile_interval), terrain, solver, y_mid, x0,
                        out.path / "profiles.csv", time_factor=e.morfac)  # fmt: skip
    outputs = VoxelOutputs(TimeInterval(run.output_interval if run.output_interval > 0 else run.t_end), terrain,
                           solver, out, cfg)  # fmt: skip
    profiles.figure = lambda p: profile_figure(cfg, p, out)
    outputs.cfg_name = scenario.name
    callbacks += [inside, profiles, outputs]
    report_fn = reporter(cfg, terrain, solver, coupler, eroder, inside, profiles, derived, x0, flume, out)

    def summary(sim, rep: dict) -> dict[str, Any]:
        return {
            "status": sim.status,
            "t": round(float(solver.t), 6),
            "steps": int(solver.steps),
            "fluid_particles": solver.n_fluid,
            "eroded_volume_m3": rep["eroded_volume_m3"],
            "first_erosion": rep["first_erosion"],
            "particles_inside_solid": rep["particles_inside_solid"],
            "wall_time_s": round(sim.wall_time, 2),
            **{"warning": w for w in out.warnings if w.startswith(EROSION_NOTES)},  # noqa: B035 (one at most)
        }

    assumed: list[str] = []
    if cfg.terrain.shape == "heightmap" and not cfg.terrain.voxels_file:

        dem = heightmap(cfg.terrain, cfg.seed)
        callbacks.append(VoxelMaps(terrain, solver, dem, out))
    if cfg.terrain.shape == "heightmap" and cfg.terrain.uses_file and not cfg.terrain.voxels_file:
        assumed = terrain_facts(dem, cfg.terrain)[1]
        assumed.append(f"voxels: {terrain.shape[2]} × {terrain.shape[1]} × {terrain.shape[0]} nodes of "
                       f"{terrain.cell_size:g} m, particles of {cfg.sph.spacing:g} m (voxels.scale = "
                       f"'{scenario.config.voxels.scale}')")  # fmt: skip
    return Setup(
        models=[solver], callbacks=callbacks, stop_time=run.t_end, unit="s", report=report_fn, summary=summary,
        checkpoint_wall_s=run.checkpoint_wall_s, seed=cfg.seed, assumed=assumed,
    )  # fmt: skip
