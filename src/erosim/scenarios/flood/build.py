"""The ``flood`` kind: a dam-break flood over a DEM, mapped as hazard (seed 000 §3.3; SPEC FL-1…FL-4).

Set-up (shared by every flood solver, :mod:`erosim.terrain.reservoir`): the reservoir is filled to
``reservoir.level`` from ``reservoir.seed`` on the DEM as it stands (with ``reservoir.barrier`` as the
dam's line when the DEM has none); the breach window is then cut into the DEM and the barrier opens
where the window is below the reservoir level (without a breach the whole barrier goes at t = 0: a
total failure). Nodata cells, and the barrier outside its window, are walls; ``outflow.edges`` are
open. Water is laid on a square lattice of ``flood.spacing`` over the reservoir, each particle holding
the water column it stands on.

The solver is shallow-water SPH (:mod:`erosim.sph.shallow_water_vacondio2012`). Every step raises the
hazard maxima (:mod:`erosim.analysis.hazard`) on the DEM's grid from the SPH depth at the cell centres
(``update_maxima``; docs/flood.md, "The maps' depth"). A run leaves

* ``maps/``: max_depth.tif, max_speed.tif, max_dv.tif, arrival_time.tif (s; nodata where never
  wet), hazard.tif (uint8: 0 dry, 1–6, 255 on nodata), depth_final.tif, height.tif (the DEM with the breach)
  — the DEM's grid, CRS and transform;
* ``figures/``: flood_maps.png (the three maxima), hazard.png (six-colour legend and area table),
  depth_NNN frames in flood.gif;
* ``maps/frames/water_depth_NNNNN.tif`` at the same ``run.map_frames`` times and the end
  (:mod:`erosim.io.map_frames`; ``erosim view``'s time slider);
* ``gauges.csv`` (t, eta_<name>, depth_<name>, speed_<name>) when ``gauges.file`` is given;
* ``report.json``: flooded_area_m2, hazard_share (H1…H6, fractions of the flooded area),
  hazard_area_m2 (all three over the cells that are neither nodata nor wall, the reservoir included),
  flooded_area_below_dam_m2, hazard_share_below_dam, hazard_area_below_dam_m2 (the same without the
  reservoir's cells and every cell wet at t = 0), volume_initial_m3, volume_out_m3, water_budget
  (closure_rel), gauges_summary.

Inputs that would silently do nothing are named: a barrier with no segment over the DEM is refused; a
reservoir in a closed hollow (no open edge, barrier or breach lets its water out: the connected water
below the level on the breached DEM is the reservoir itself) and a reservoir that releases less than
1 % of its volume in the first tenth of the run are warned of (report.json ``warnings`` and the console).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from erosim.analysis.hazard import HazardMaps, polygon_mask
from erosim.core.errors import ConfigError, InputError
from erosim.core.schedules import TimeInterval
from erosim.coupling.flood_sph3d import SPHFlood
from erosim.io.heightmaps import read
from erosim.scenarios.flood.outputs import FloodGauges, FloodOutputs, HazardTracker, ReleaseCheck, depth_picture
from erosim.scenarios.flood.schema import FloodScenario
from erosim.scenarios.flood.site import FloodSetUp
from erosim.scenarios.schema_common import terrain_facts
from erosim.scenarios.setup import Setup
from erosim.simulation import callbacks as cb
from erosim.sph.shallow_water_vacondio2012 import ShallowWaterParams, ShallowWaterSPH, felt_bed


def build(cfg: FloodScenario) -> tuple[FloodSetUp, ShallowWaterSPH]:
    """The set-up and the solver of a flood scenario (no files written)."""
    site = FloodSetUp(cfg)
    hm = site.terrain
    fl = cfg.flood
    spacing = fl.spacing if fl.spacing is not None else 2.0 * hm.cell_size
    manning: np.ndarray | float = fl.manning
    if fl.manning_file:

        m = read(fl.manning_file).z
        if m.shape != hm.shape:
            raise InputError(
                f"flood.manning_file '{fl.manning_file}' has shape {m.shape} but the DEM {hm.shape}; "
                "give a map on the DEM's grid."
            )
        if not np.all(np.isfinite(m)) or m.min() < 0:
            raise InputError(f"flood.manning_file '{fl.manning_file}' holds negative or missing values; fix the map.")
        manning = m
    if fl.solver == "sph3d":

        if cfg.run.device == "cuda":
            raise ConfigError(
                "flood.solver = 'sph3d' runs on device 'cpu' only; run with --device cpu or flood.solver = 'swe'."
            )

        estimate = float(site.depth0.sum()) * hm.cell_size**2 / spacing**3
        if estimate > MAX_PARTICLES:
            raise InputError(
                f"The reservoir would need about {estimate:,.0f} particles of {spacing:g} m in 3-D; give a larger "
                "flood.spacing or use flood.solver = 'swe'."
            )
        return site, SPHFlood(
            site, spacing, tuple(cfg.outflow.edges), manning=manning, seed=cfg.seed,
            margin_speed=cfg.flood.margin_speed,
        )  # fmt: skip
    if spacing > 4.0 * hm.cell_size or spacing < 0.25 * hm.cell_size:
        raise InputError(
            f"flood.spacing = {spacing:g} m against {hm.cell_size:g} m DEM cells: give a spacing between a quarter "
            "of a cell and four cells, or resample the DEM."
        )
    estimate = float((site.depth0 > 0).sum()) * hm.cell_size**2 / spacing**2
    if estimate > MAX_PARTICLES:
        raise InputError(
            f"The reservoir would need about {estimate:,.0f} particles at flood.spacing = {spacing:g} m; "
            "give a larger flood.spacing."
        )
    params = fl.model_dump(include=set(ShallowWaterParams.model_fields))
    # the reservoir settles on the DEM as it stands, the dam whole (the barrier all wall), then the
    # breach opens at t = 0
    closed = site.wall | (site.barrier if site.barrier is not None else False)
    open_edges = tuple(e in cfg.outflow.edges for e in ("west", "east", "north", "south"))
    bed = felt_bed(site.dem.z, closed, open_edges, site.level, fl.bed_smoothing * spacing / hm.cell_size)
    pos, vol = site.particles(spacing, bed)
    if len(pos) == 0:
        raise InputError(
            f"No particle fits the reservoir at flood.spacing = {spacing:g} m; give a smaller spacing or raise "
            "reservoir.level."
        )
    solver_class = ShallowWaterSPH
    if cfg.run.device == "cuda":
        from erosim.sph.shallow_water_cuda import CudaShallowWaterSPH as solver_class
    solver = solver_class(
        site.dem.z, hm.cell_size, pos, vol, spacing, ShallowWaterParams(**params), manning=manning, wall=closed,
        open_edges=tuple(cfg.outflow.edges), surface=site.level,
    )  # fmt: skip
    if fl.settle_steps > 0:
        solver.settle(fl.settle_steps, fl.settle_speed)
    solver.set_terrain(hm.z, site.wall)
    return site, solver


def setup(scenario, out) -> Setup:
    """The solver, the hazard maxima, gauges and outputs of a ``flood`` run (module docstring)."""
    cfg: FloodScenario = scenario.config
    site, solver = build(cfg)
    hm = site.terrain
    facts, assumed = terrain_facts(site.dem, cfg.terrain)
    warnings = list(site.dem.notes)
    if facts["nodata_cells"]:
        warnings.append(f"{facts['nodata_cells']} cells of the DEM are nodata: walls the water cannot enter.")
    if site.closed_hollow is not None:
        warnings.append(site.closed_hollow)
    spacing = solver.spacing
    assumed.append(
        f"reservoir: {solver.volume_initial:,.0f} m³ over {(site.depth0 > 0).sum() * hm.cell_size**2:,.0f} m² at "
        f"level {site.level:g} m; {solver.n:,} particles at {spacing:g} m spacing"
    )
    assumed.append(f"open edges: {', '.join(cfg.outflow.edges) or 'none (every map edge is a wall)'}")
    maps = HazardMaps(hm.shape, cfg.flood.wet_depth, valid=~site.wall)  # nodata and the dam: never flooded
    inside = polygon_mask(hm, cfg.hazard.inside) if cfg.hazard.inside is not None else None
    reservoir = site.depth0 > 0
    callbacks: list = [HazardTracker(solver, maps)]
    if site.closed_hollow is None:  # one sentence per problem: a closed hollow releases nothing anyway
        callbacks.append(ReleaseCheck(solver, site, cfg.run.t_end, out))
    gauges = None
    if site.gauges is not None:
        pts = site.gauges
        names = [p[0] for p in pts]
        gauges = FloodGauges(
            TimeInterval(cfg.run.sample_interval), solver, names, site.to_frame([p[1:] for p in pts]),
            out.path / "gauges.csv",
        )  # fmt: skip
        callbacks.append(gauges)
    if cfg.run.map_frames > 0:
        callbacks.append(
            cb.Animation(TimeInterval(cfg.run.t_end / cfg.run.map_frames), depth_picture(site, solver),
                         out.figures / "flood.gif")
        )  # fmt: skip
        callbacks.append(cb.MapFrames(TimeInterval(cfg.run.t_end / cfg.run.map_frames),
                                      lambda sim: {"water_depth": solver.depth_grid()}, hm, "s"))  # fmt: skip
    callbacks.append(FloodOutputs(site, solver, maps, inside))

    def report(sim) -> dict[str, Any]:
        solver.sync_maxima(maps)
        summary = maps.summary(hm.cell_size**2, inside, reservoir)
        below = summary["below_dam"]
        budget = solver.budget()
        rep = {
            "method": "shallow-water SPH (Vacondio et al. 2012) over the DEM; hazard classes of FL-3",
            "solver": cfg.flood.solver,
            "flooded_area_m2": summary["flooded_area_m2"],
            "hazard_share": summary["hazard_share"],
            "hazard_area_m2": summary["hazard_area_m2"],
            "flooded_area_below_dam_m2": below["flooded_area_m2"],
            "hazard_share_below_dam": below["hazard_share"],
            "hazard_area_below_dam_m2": below["hazard_area_m2"],
            "volume_initial_m3": budget["volume_initial_m3"],
            "volume_out_m3": budget["volume_out_m3"],
            "water_budget": budget,
            "max_depth_m": float(maps.max_depth.max()),
            "max_speed_m_s": float(maps.max_speed.max()),
            "wet_depth_m": maps.wet_depth,
            "spacing_m": spacing,
            "terrain": facts,
            **solver.stats(),
        }
        if "inside" in summary:
            rep["inside"] = summary["inside"]
        if gauges is not None:
            rep["gauges_summary"] = gauges.summary(maps.wet_depth)
        wall = sim.wall_time_total
        if wall > 0:
            rep["simulated_s_per_wall_s"] = solver.t / wall
        return rep

    def summary(sim, rep: dict) -> dict[str, Any]:
        return {
            "flooded_area_m2": rep["flooded_area_m2"],
            "hazard_share": {k: round(v, 3) for k, v in rep["hazard_share"].items()},
            "flooded_area_below_dam_m2": rep["flooded_area_below_dam_m2"],
            "volume_out_m3": rep["volume_out_m3"],
            "particles": rep["particles"],
            "steps": rep["steps"],
        }

    return Setup(
        models=[solver], callbacks=callbacks, stop_time=cfg.run.t_end, unit="s", report=report, summary=summary,
        checkpoint_wall_s=cfg.run.checkpoint_wall_s, seed=cfg.seed, warnings=warnings, assumed=assumed,
    )  # fmt: skip


#: particles beyond this many would not fit a workstation (about 200 B each, times the splitting)
MAX_PARTICLES = 20_000_000
