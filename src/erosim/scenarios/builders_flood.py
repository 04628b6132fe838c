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

import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from erosim.analysis.hazard import HazardMaps, polygon_mask
from erosim.core.errors import ConfigError, InputError
from erosim.core.heightmap import default_transform, fractional_cell
from erosim.core.schedules import IterationInterval, Schedule, TimeInterval
from erosim.scenarios.schema_common import build_terrain, terrain_facts
from erosim.scenarios.schema_flood import FloodScenario
from erosim.scenarios.setup import Setup
from erosim.simulation import callbacks as cb
from erosim.sph.shallow_water_vacondio2012 import ShallowWaterParams, ShallowWaterSPH, equal_volumes, felt_bed
from erosim.terrain.reservoir import barrier_mask, cut_breach, fill_reservoir

if TYPE_CHECKING:
    from erosim.io.runfolder import RunFolder

#: particles beyond this many would not fit a workstation (about 200 B each, times the splitting)
MAX_PARTICLES = 20_000_000
#: a reservoir that releases less than this share of its volume in the first tenth of the run is warned of
SLOW_RELEASE = 0.01


def _fmt_point(p) -> str:
    return "[" + ", ".join(f"{float(v):.10g}" for v in p) + "]"


class FloodSetUp:
    """The DEM with the breach cut in, the walls, and the reservoir's water (map order, row 0 north)."""

    def __init__(self, cfg: FloodScenario):
        hm = build_terrain(cfg.terrain, cfg.seed)
        if hm.transform is None:
            hm = hm.copy()
            hm.transform = default_transform(*hm.shape, hm.cell_size)
        self.dem = hm
        res = cfg.reservoir
        barrier = barrier_mask(hm, res.barrier) if res.barrier is not None else None
        if barrier is not None and not barrier.any():
            x0, x1, y0, y1 = hm.extent
            raise InputError(
                f"reservoir.barrier [{', '.join(_fmt_point(p) for p in res.barrier)}] has no segment over the DEM "
                f"(x {x0:.10g}..{x1:.10g}, y {y0:.10g}..{y1:.10g}); draw the dam's line across the valley in the "
                "DEM's coordinates."
            )
        self.depth0 = fill_reservoir(hm, res.level, res.seed, barrier=barrier, open_edges=cfg.outflow.edges)
        self.terrain = cut_breach(hm, cfg.breach) if cfg.breach is not None else hm
        nodata = hm.nodata if hm.nodata is not None else np.zeros(hm.shape, bool)
        wall = nodata.copy()
        if barrier is not None and cfg.breach is not None:
            # the window: where the breach, cut into ground higher than anything, lies below the level
            probe = cut_breach(hm.copy(z=np.full(hm.shape, res.level + 1e6)), cfg.breach).z < res.level
            wall |= barrier & ~probe
        self.wall = wall
        self.barrier = barrier
        self.level = float(res.level)
        self.closed_hollow = self._closed_hollow(res.seed, cfg)
        self.gauges = None  # (name, x, y) of each gauge: a bad file is refused here, before anything settles
        if cfg.gauges.file:
            from erosim.io.gauge_points import read_gauge_points

            self.gauges = read_gauge_points(cfg.gauges.file, self.terrain)

    def _closed_hollow(self, seed, cfg: FloodScenario) -> str | None:
        """The warning sentence when no open edge, barrier or breach lets the reservoir's water out: the
        connected water below the level on the breached DEM (its walls kept) is the reservoir itself."""
        from scipy import ndimage

        from erosim.core.heightmap import cell_of

        hm = self.terrain
        below = (hm.z < self.level) & ~self.wall & hm.valid
        labels, _ = ndimage.label(below)  # 4-connected, as the fill
        row, col = cell_of(self.dem, float(seed[0]), float(seed[1]))
        reach = labels == labels[row, col]
        if reach.sum() > (self.depth0 > 0).sum():
            return None
        area = (self.depth0 > 0).sum() * hm.cell_size**2
        if self.barrier is None:
            why = "it has no reservoir.barrier"
        elif not (ndimage.binary_dilation(self.depth0 > 0) & self.barrier).any():
            why = "reservoir.barrier does not touch it"
        elif cfg.breach is None:
            why = "the ground under reservoir.barrier is above the level where it holds the water"
        else:
            why = "the breach does not open reservoir.barrier below the level where it holds the water"
        return (
            f"The reservoir at level {self.level:.10g} m fills a closed hollow of {area:,.0f} m² from the seed "
            f"{_fmt_point(seed)} and {why}, so no water leaves it and the maps show a lake; draw reservoir.barrier "
            "across the valley where the water is held (and a breach through it), or raise reservoir.level."
        )

    def particles(self, spacing: float, bed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Particles of equal volume over the reservoir (solver's cell frame) and their volumes.

        Equal volumes, so that no arrangement of particles holds potential energy the water does not
        (with volumes ∝ depth the discrete system lowers its energy by sorting heavy particles into
        the deep water, and a lake never comes to rest). Their number density follows the depth: the
        points of a fine lattice (spacing s·√(d̄/d_max)) are kept with chance d/d_max
        (:func:`~erosim.sph.shallow_water_vacondio2012.equal_volumes`), so the spacing is ``spacing``
        where the depth is the mean depth d̄. The column d is the level minus ``bed`` (the C¹ surface
        the solver feels, walls raised); the particles share the reservoir's volume on the DEM,
        Σ (level − z)·Δ², exactly.
        """
        from erosim.kernels.swe_sph import bed_at

        cs = self.dem.cell_size
        ny, nx = self.dem.shape
        d_mean = float(self.depth0[self.depth0 > 0].mean())
        d_max = float(self.depth0.max())
        fine = spacing * max(math.sqrt(d_mean / d_max), 0.25)
        xs = np.arange(-0.5 * cs + 0.5 * fine, (nx - 0.5) * cs, fine)
        ys = np.arange(-0.5 * cs + 0.5 * fine, (ny - 0.5) * cs, fine)
        x, y = (a.ravel() for a in np.meshgrid(xs, ys))
        col = np.clip(np.floor(x / cs + 0.5).astype(np.int64), 0, nx - 1)
        row = np.clip(np.floor(y / cs + 0.5).astype(np.int64), 0, ny - 1)
        keep = (self.depth0[row, col] > 0) & ~self.wall[row, col]
        pts = np.ascontiguousarray(np.column_stack([x[keep], y[keep]]))
        b = np.empty(len(pts))
        bed_at(np.ascontiguousarray(bed), pts, len(pts), 1.0 / cs, b)
        d = np.maximum(self.level - b, 0.0)
        volume = float(self.depth0.sum()) * cs * cs  # the reservoir's own volume on the DEM
        return equal_volumes(pts, d, volume)

    def to_frame(self, xy) -> np.ndarray:
        """Map coordinates → the solver's cell frame (x = col·Δ, y = row·Δ, cell centres on nodes)."""
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        r, c = fractional_cell(self.dem, xy[:, 0], xy[:, 1])
        cs = self.dem.cell_size
        return np.column_stack([(np.asarray(c) - 0.5) * cs, (np.asarray(r) - 0.5) * cs])


def build(cfg: FloodScenario) -> tuple[FloodSetUp, ShallowWaterSPH]:
    """The set-up and the solver of a flood scenario (no files written)."""
    site = FloodSetUp(cfg)
    hm = site.terrain
    fl = cfg.flood
    spacing = fl.spacing if fl.spacing is not None else 2.0 * hm.cell_size
    manning: np.ndarray | float = fl.manning
    if fl.manning_file:
        from erosim.io.heightmaps import read

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
        from erosim.scenarios.flood_sph3d import SPHFlood

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
        return site, SPHFlood(site, spacing, tuple(cfg.outflow.edges), manning=manning, seed=cfg.seed)
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
    if cfg.run.device == "cuda" and "split" not in fl.model_fields_set:
        params["split"] = False  # splitting runs on the CPU: a device run splits only when asked (and refuses)
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


class HazardTracker(cb.Callback):
    """Raises the hazard maxima and arrival times every step (their arrays travel in the checkpoint)."""

    def __init__(self, solver: ShallowWaterSPH, maps: HazardMaps):
        super().__init__(IterationInterval(1), name="hazard")
        self.solver, self.maps = solver, maps
        solver.update_maxima(maps, maps.wet_depth)  # the reservoir itself at t = 0

    def __call__(self, sim) -> None:
        self.solver.update_maxima(self.maps, self.maps.wet_depth)

    def state_dict(self) -> dict[str, Any]:
        self.solver.sync_maxima(self.maps)
        return self.maps.state_dict()

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if state:
            self.maps.load_state_dict(state)


class ReleaseCheck(cb.Callback):
    """Warns when the reservoir has released less than :data:`SLOW_RELEASE` of its volume by a tenth of
    the run: the water beyond the reservoir's cells widened by a particle spacing (at least two cells,
    so that a shore's particles moving as the water settles do not count) and through the open edges,
    less what was there at t = 0, over the initial volume."""

    def __init__(self, solver, site: FloodSetUp, t_end: float, out):
        from scipy import ndimage

        super().__init__(TimeInterval(0.1 * t_end), name="release")
        self.solver, self.site, self.out = solver, site, out
        widen = max(2, math.ceil(solver.spacing / site.dem.cell_size))
        self.held = ndimage.binary_dilation(site.depth0 > 0, iterations=widen)
        self.outside0: float | None = None
        self.released: float | None = None
        self.at = 0.0  # the time it was measured

    def _outside(self) -> float:
        pos, vol = _particles_on_grid(self.solver)
        cs = self.site.dem.cell_size
        ny, nx = self.held.shape
        col = np.clip(np.floor(pos[:, 0] / cs + 0.5).astype(np.int64), 0, nx - 1)
        row = np.clip(np.floor(pos[:, 1] / cs + 0.5).astype(np.int64), 0, ny - 1)
        return float(vol[~self.held[row, col]].sum()) + float(self.solver.budget()["volume_out_m3"])

    def __call__(self, sim) -> None:
        if self.outside0 is None:
            self.outside0 = self._outside()
        elif self.released is None:
            self.released = (self._outside() - self.outside0) / self.solver.volume_initial
            self.at = float(sim.time)
            warning = self.warning()
            if warning is not None:
                self.out.warn(warning)
                if sim.progress:
                    print(f"{sim.label}: warning: {warning}", file=sys.stderr, flush=True)

    def warning(self) -> str | None:
        if self.released is None or self.released >= SLOW_RELEASE:
            return None
        t = self.at
        return (
            f"The reservoir released only {100 * max(self.released, 0.0):.2g} % of its "
            f"{self.solver.volume_initial:,.0f} m³ in the first {t:.4g} s (a tenth of the run): the dam opens "
            "little below reservoir.level or the ground beyond is high; check breach.line, breach.bottom_width "
            "and breach.floor (or reservoir.barrier) if a dam break was meant."
        )

    def state_dict(self) -> dict[str, Any]:
        state = {}
        if self.outside0 is not None:
            state["outside0"] = np.asarray(self.outside0)
        if self.released is not None:
            state["released"] = np.asarray([self.released, self.at])
        return state

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if "outside0" in state:
            self.outside0 = float(state["outside0"])
        if "released" in state:
            self.released, self.at = (float(v) for v in np.asarray(state["released"]))
            warning = self.warning()
            if warning is not None:  # the resumed run's report keeps it
                self.out.warn(warning)


def _particles_on_grid(solver) -> tuple[np.ndarray, np.ndarray]:
    """(positions in the cell frame, volumes) of a flood solver's water particles."""
    if hasattr(solver, "pos"):  # the shallow-water solvers
        return np.asarray(solver.pos), np.asarray(solver.vol)
    inner = solver.solver  # the 3-D SPH flood: the SPH frame (y north from the south-west node)
    st, n = inner.state, inner.n_fluid
    ny = solver.site.terrain.shape[0]
    pos = np.column_stack([st.pos[:n, 0], (ny - 1) * solver.cell - st.pos[:n, 1]])
    return pos, inner.m / st.rho[:n]


class FloodGauges(cb.Callback):
    """Free-surface elevation, depth and speed at the gauges every ``run.sample_interval``."""

    def __init__(self, schedule, solver: ShallowWaterSPH, names: list[str], points: np.ndarray, path: Path):
        super().__init__(schedule, name="gauges")
        self.solver, self.names, self.points, self.path = solver, names, points, path
        self.rows: list[list[float]] = []

    def __call__(self, sim) -> None:
        eta, depth, speed = self.solver.sample(self.points)
        self.rows.append([self.solver.t, *eta, *depth, *speed])

    def state_dict(self) -> dict[str, Any]:
        return {"rows": np.asarray(self.rows, np.float64)} if self.rows else {}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.rows = [list(r) for r in state["rows"]] if "rows" in state else []

    def flush(self, sim) -> None:
        from erosim.core.atomic import write_text

        header = ["t", *(f"eta_{n}" for n in self.names), *(f"depth_{n}" for n in self.names)]
        header += [f"speed_{n}" for n in self.names]
        write_text(self.path, cb.csv_text(header, self.rows))

    def summary(self, wet: float) -> dict[str, Any]:
        rows = np.asarray(self.rows, np.float64).reshape(-1, 1 + 3 * len(self.names))
        out = {}
        k = len(self.names)
        for i, name in enumerate(self.names):
            eta, depth = rows[:, 1 + i], rows[:, 1 + k + i]
            wet_at = np.flatnonzero(depth >= wet)
            out[name] = {
                "max_eta": float(eta.max()) if len(rows) else None,
                "max_depth": float(depth.max()) if len(rows) else None,
                "arrival_s": float(rows[wet_at[0], 0]) if len(wet_at) else None,
            }
        return out


class FloodOutputs(cb.Callback):
    """Maps and figures of the run on the DEM's grid (at the end)."""

    def __init__(self, site: FloodSetUp, solver: ShallowWaterSPH, maps: HazardMaps, inside):
        super().__init__(Schedule(), name="outputs")
        self.site, self.solver, self.maps, self.inside = site, solver, maps, inside

    def finalize(self, sim) -> dict[str, Any]:
        self.solver.sync_maxima(self.maps)
        write_flood_maps(sim.out, self.site, self.solver, self.maps, self.inside)
        return {}


def write_flood_maps(out: RunFolder, site: FloodSetUp, solver: ShallowWaterSPH, maps: HazardMaps, inside) -> None:
    """The hazard maps as GeoTIFFs on the DEM's grid, and their figures (each picture guarded: one that
    cannot be drawn is a warning, never the loss of the maps)."""
    from erosim.io.heightmaps import write_raster

    hm = site.terrain
    nodata = hm.nodata if hm.nodata is not None else np.zeros(hm.shape, bool)
    wet = maps.max_depth >= maps.wet_depth
    folder = out.maps
    for name, arr in (("max_depth", maps.max_depth), ("max_speed", maps.max_speed), ("max_dv", maps.max_dv)):
        write_raster(folder / f"{name}.tif", np.where(nodata, np.nan, arr).astype(np.float32), hm, nodata=np.nan)
    arrival = np.where(wet & ~nodata & np.isfinite(maps.arrival), maps.arrival, np.nan)
    write_raster(folder / "arrival_time.tif", arrival.astype(np.float32), hm, nodata=np.nan)
    classes = np.where(nodata, 255, maps.classes()).astype(np.uint8)
    write_raster(folder / "hazard.tif", classes, hm, nodata=255)
    depth = solver.depth_grid()
    write_raster(folder / "depth_final.tif", np.where(nodata, np.nan, depth).astype(np.float32), hm, nodata=np.nan)
    write_raster(folder / "height.tif", np.where(nodata, np.nan, hm.z).astype(np.float32), hm, nodata=np.nan)
    from erosim.viz.flood import plot_flood_maps, plot_hazard

    shares = maps.summary(hm.cell_size**2, inside)
    draw = {
        "flood_maps.png": lambda p: plot_flood_maps(p, hm, maps),
        "hazard.png": lambda p: plot_hazard(p, hm, maps.classes(), shares),
    }
    for name, picture in draw.items():
        with out.picture(out.figures / name):
            picture(out.figures / name)


def _depth_picture(site: FloodSetUp, solver: ShallowWaterSPH):
    from erosim.viz.maps import colormap, hillshade

    hm = site.terrain
    shade = hillshade(hm.z, hm.cell_size)
    vmax = max(float(site.depth0.max()), 1e-3)
    step = max(1, int(math.ceil(max(hm.shape) / 400)))  # thumbnails of at most ~400 px

    def picture(sim) -> np.ndarray:
        d = solver.depth_grid()[::step, ::step]
        rgb = colormap(np.minimum(d, vmax), "Blues", vmin=0.0, vmax=vmax).astype(np.float64)
        base = np.repeat(shade[::step, ::step, None], 3, axis=2).astype(np.float64)
        if base.max() <= 1.0:
            base = base * 255.0
        a = np.clip(d / (0.2 * vmax), 0.0, 1.0)[..., None] * (d >= 0.01)[..., None]
        return (base * (1 - a) + rgb[..., :3] * a).astype(np.uint8)

    return picture


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
            cb.Animation(TimeInterval(cfg.run.t_end / cfg.run.map_frames), _depth_picture(site, solver),
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
