"""Before long work: a run's memory and a rough time from its sizes, and a refusal of what would not fit.

Read from the validated scenario alone (before a terrain is generated or a particle is laid), with
per-unit costs measured on the 2-core reference machine (peak RSS with ``/usr/bin/time -f %M``, wall
time from ``report.json``; ``docs/performance.md``):

* map cells (hydrology): 170 B and 3 µs of set-up and output per cell, 0.2 µs per cell per cycle
  (peak RSS of ``erosim run hydrology --set terrain.size=N --set run.cycles=C``: 2.88 GB at N = 4096,
  C = 8, int32 lake-heap indices and figures from strided maps; the seed's serial loop took 0.25 µs per
  cell-cycle on the idle machine and the parallel batches 0.77 of its wall time back to back at 1024²
  and 2048², docs/performance.md);
* map cells (particle stream): 180 B and 3 µs per cell; 0.45 µs per particle update (2.2·10⁶/s);
* SPH particles: 800 B each (fluid, walls and neighbour lists; ``erosim bench sph`` at 10⁵ and 10⁶),
  2.2·10⁶ particle-steps/s per core, 1.5 ms per step and 10 s of start (``spheric2`` at 0.05, 0.03 and
  0.025 m: 32, 137 and 230 s, estimated 39, 138 and 242 s); steps from the solver's limit C·h_s/(c + v),
  h_s = h/2, with the auto sound speed and v the free fall's speed (12 161 steps at 0.025 m, 11 694
  estimated); ``sph-terrain``, ``splash`` and ``voxel`` runs add their own passes (:func:`from_solver`,
  :func:`voxel`);
* floods: the reservoir filled from the scenario (a DEM read and a labelling, well under a second); shallow
  water: 250 B per particle, 80 B per map cell, 3.5·10⁵ particle-steps/s (``erosim bench flood``),
  Δt = 0.15·H/(3√(g d_max)); 3-D SPH: as SPH particles above, with the sound speed 10√(2g·fall);
* a base of 250 MB (Python, NumPy, Numba).

The time is a rough guide (within a factor of about three); the memory is checked against what the
machine has free: a run that would not fit is refused with one sentence before anything is built.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

from erosim.core.errors import ConfigError
from erosim.scenarios.flood.build import FloodSetUp
from erosim.scenarios.schema_common import build_terrain as heightmap
from erosim.scenarios.voxel.schema import at_dem_scale, band_for, overflow_head
from erosim.sph.kernels_swe import step_limit
from erosim.sph.params import SPHParams
from erosim.terrain.voxel import memory_bytes

BASE_BYTES = 250e6
HYDRO_CELL_BYTES, HYDRO_CELL_S, HYDRO_CELL_CYCLE_S = 170.0, 3e-6, 0.2e-6
STREAM_CELL_BYTES, STREAM_CELL_S, STREAM_UPDATE_S = 180.0, 3e-6, 0.45e-6
SPH_PARTICLE_BYTES, SPH_STEPS_PER_CORE_S = 800.0, 2.2e6
#: a run's start (imports, loading the compiled kernels, final outputs) and each SPH step's fixed cost
#: (Python, callbacks, neighbour-list bookkeeping): dam-break-2d, 2 576 particles, 9 586 steps in 42.5 s
START_S, SPH_STEP_S = 10.0, 1.5e-3
GRID_CELL_BYTES = 200.0  # the sph-terrain coupler's maps per cell


@dataclass(frozen=True)
class Estimate:
    what: str  # the sizes, in words
    memory: float  # bytes
    seconds: float | None  # rough wall time; None when the sizes do not tell
    fix: str  # what makes the run smaller
    steps: float | None = None  # SPH steps to the end, where the kind counts them
    setup_s: float | None = None  # the set-up's share of ``seconds``, where it is long enough to announce

    def line(self) -> str:
        time = f" and {duration(self.seconds)}" if self.seconds is not None else ""
        return f"{self.what}: about {_bytes(self.memory)} of memory{time} (rough estimate)"


def _bytes(n: float) -> str:
    for unit, size in (("GB", 1e9), ("MB", 1e6)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


def duration(s: float) -> str:
    if s < 60:
        return f"{max(s, 1):.0f} s"
    if s < 3600:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h"


def available_memory() -> float | None:
    """Bytes the machine can still give (``MemAvailable``), or None where it cannot be read."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def _cores() -> int:
    return max(1, min(int(os.environ.get("NUMBA_NUM_THREADS", os.cpu_count() or 1)), os.cpu_count() or 1))


GENERATED_CELL = 10.0  # m, a generated terrain's cell size when terrain.cell_size is not set


def map_size(terrain) -> tuple[int, float] | None:
    """(cells, cell size in m) of a ``[terrain]`` section: generated (size², ``cell_size`` or 10 m) or
    a file's header (its own cell size unless ``cell_size`` is set); None if unknown."""
    if terrain.file is None:
        return int(terrain.size) ** 2, float(terrain.cell_size or GENERATED_CELL)
    path = Path(str(terrain.file))
    try:
        if path.suffix.lower() == ".npy":
            import numpy as np

            return int(np.prod(np.load(path, mmap_mode="r").shape)), float(terrain.cell_size or 1.0)
        if path.suffix.lower() in (".r16", ".raw"):
            return path.stat().st_size // 2, float(terrain.cell_size or 1.0)
        import warnings

        import rasterio

        with warnings.catch_warnings():  # only the size is read: a PNG without a transform is fine here
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(path) as ds:
                return int(ds.width * ds.height), float(terrain.cell_size or abs(ds.res[0]) or 1.0)
    except Exception:  # an unreadable file is reported by the builder, in its own words
        return None


def map_cells(terrain) -> int | None:
    """Cells of a ``[terrain]`` section (:func:`map_size`)."""
    size = map_size(terrain)
    return None if size is None else size[0]


def sph_steps(t_end: float, c: float, v: float, cfl: float, support: float) -> float:
    """Steps to ``t_end`` at the solver's CFL limit Δt = C·h_s/(c + v), h_s = h/2 the smoothing length
    (``erosim.sph.integrators.step_limit``), v the fastest water expected."""
    return t_end * (c + v) / (cfl * 0.5 * support)


def sph_seconds(particles: float, steps: float, step_extra_s: float = 0.0, rate: float | None = None) -> float:
    """Wall time of ``steps`` SPH steps over ``particles`` (fluid and boundary, the mean over the run): the
    start (imports, compiled kernels, final outputs), a fixed cost per step and the particle-steps (``rate``
    per core and second; SPH_STEPS_PER_CORE_S by default)."""
    per_core = rate or SPH_STEPS_PER_CORE_S
    return START_S + steps * (SPH_STEP_S + step_extra_s + particles / (per_core * _cores()))


def _sph_steps(params, top: float, floor: float, t_end: float, speed: float) -> float | None:
    """Steps to ``t_end`` at the CFL limit with the solver's sound speed (``SPHParams.sound_speed_for``) and the
    fastest water expected (the initial speed or a free fall from ``top`` to ``floor``); None when nothing sets
    a speed (no gravity, fluid at rest, no sound speed)."""
    if params.dt:
        return t_end / params.dt
    fall = top - floor + 0.5 * params.spacing
    c = params.sound_speed_for(fall, speed)
    if c <= 0:
        return None
    g = math.sqrt(sum(x * x for x in params.gravity_vector()))
    return sph_steps(t_end, c, max(speed, math.sqrt(2.0 * g * fall)), params.cfl, params.support())


def from_solver(what: str, solver, t_end: float, *, added: float = 0.0, speed: float | None = None,
                extra_bytes: float = 0.0, step_extra_s: float = 0.0, fix: str = "",
                rate: float | None = None) -> Estimate:
    """The estimate of a run from its built solver: the particles it has and the ``added`` ones (rain,
    inflows, over the run: their mean counts for time, all of them for memory), steps from the solver's sound
    speed and ``speed`` (the fastest water expected; c/10 by default, the auto sound speed's rule), ``extra_bytes``
    and ``step_extra_s`` for the kind's own maps and passes."""
    p = solver.params
    v = solver.c / 10.0 if speed is None else speed
    steps = t_end / p.dt if p.dt > 0 else sph_steps(t_end, solver.c, v, p.cfl, solver.h)
    n0 = solver.n_fluid + solver.n_boundary
    seconds = sph_seconds(n0 + 0.5 * added, steps, step_extra_s, rate)
    text = f"{what}, {n0 + added:,.0f} particles at most, about {steps:,.0f} steps"
    return Estimate(text, BASE_BYTES + SPH_PARTICLE_BYTES * (n0 + added) + extra_bytes, seconds, fix, steps)


def hydrology(cfg) -> Estimate | None:
    cells = map_cells(cfg.terrain)
    if cells is None:
        return None
    n = math.isqrt(cells)
    seconds = cells * (HYDRO_CELL_S + HYDRO_CELL_CYCLE_S * cfg.run.cycles)
    what = f"{n:,}² cells, {cfg.run.cycles:,} cycles"
    return Estimate(what, BASE_BYTES + HYDRO_CELL_BYTES * cells, seconds, "make terrain.size smaller")


def stream(cfg) -> Estimate | None:
    cells = map_cells(cfg.terrain)
    if cells is None:
        return None
    updates = sum(e.particles * e.steps for e in cfg.emitters.values())
    seconds = cells * STREAM_CELL_S + updates * STREAM_UPDATE_S
    what = f"{math.isqrt(cells):,}² cells, {updates:,} particle updates"
    return Estimate(what, BASE_BYTES + STREAM_CELL_BYTES * cells, seconds, "make terrain.size smaller")


def sph(cfg) -> Estimate:
    p = cfg.sph
    dim = len(cfg.domain.lo)
    fluid = sum(math.prod(b - a for a, b in zip(f.lo, f.hi, strict=True)) for f in cfg.fluid) / p.spacing**dim
    walls = 0.0
    if p.walls == "particles":  # every face but the top, a few layers
        sides = [b - a for a, b in zip(cfg.domain.lo, cfg.domain.hi, strict=True)]
        area = sum(math.prod(sides[:k] + sides[k + 1 :]) * (2 if k < dim - 1 else 1) for k in range(dim))
        walls = area / p.spacing ** (dim - 1) * math.ceil(p.support() / p.spacing)
    n = fluid + walls
    top = max(f.hi[-1] for f in cfg.fluid)
    speed = max((math.sqrt(sum(v * v for v in f.velocity)) for f in cfg.fluid if f.velocity), default=0.0)
    steps = _sph_steps(p, top, cfg.domain.lo[-1], cfg.run.t_end, speed)
    seconds = sph_seconds(n, steps) if steps is not None else None
    what = f"{n:,.0f} particles" + (f", about {steps:,.0f} steps" if steps is not None else "")
    fix = "raise sph.spacing or make the fluid blocks smaller"
    return Estimate(what, BASE_BYTES + SPH_PARTICLE_BYTES * n, seconds, fix, steps)


def sph_terrain(cfg) -> Estimate | None:
    p = cfg.sph
    if cfg.profile is not None:
        return None  # a 2-D flume: small by construction
    size = map_size(cfg.terrain)
    if size is None:
        return None
    cells, cell = size
    extent = math.sqrt(cells) * cell
    rain = cfg.rain.rate * extent**2 / 3.6e6 if cfg.rain.rate > 0 else 0.0  # mm/h over the map → m³/s
    inflow = sum(i.discharge for i in cfg.inflows.values())
    n = (rain + inflow) * cfg.run.t_end / p.spacing**3  # the water the run adds (lakes come on top)
    memory = BASE_BYTES + SPH_PARTICLE_BYTES * n + GRID_CELL_BYTES * cells
    what = f"{math.isqrt(cells):,}² cells, about {n:,.0f} particles of rain and inflow"
    fix = "lower rain.rate or the inflows, shorten run.t_end, raise sph.spacing or make terrain.size smaller"
    return Estimate(what, memory, None, fix)


SWE_PARTICLE_BYTES, SWE_CELL_BYTES, SWE_STEPS_S = 250.0, 80.0, 3.5e5
SWE_STEP_S = 1.0e-3  # a shallow-water step's fixed cost (neighbour bookkeeping, Python)


def flood(cfg) -> Estimate | None:
    """Particles from the reservoir the scenario fills (:class:`FloodSetUp`), steps from the CFL limit."""

    site = FloodSetUp(cfg)  # bad input is refused here already, in the builder's own words
    hm = site.terrain
    cells = hm.z.size
    spacing = cfg.flood.spacing if cfg.flood.spacing is not None else 2.0 * hm.cell_size
    volume = float(site.depth0.sum()) * hm.cell_size**2
    d_max = max(float(site.depth0.max()), 1e-3)
    g = 9.81
    if cfg.flood.solver == "sph3d":

        n = volume / spacing**3
        p = SPHParams(dim=3, spacing=spacing)
        c = 10.0 * math.sqrt(2 * g * d_max)
        steps = sph_steps(cfg.run.t_end, c, c / 10.0, p.cfl, p.support())
        memory = BASE_BYTES + SPH_PARTICLE_BYTES * n + SWE_CELL_BYTES * cells
        seconds = sph_seconds(n, steps)
        fix = "raise flood.spacing or use flood.solver = 'swe'"
    else:
        n = float((site.depth0 > 0).sum()) * hm.cell_size**2 / spacing**2
        h = cfg.flood.support * spacing
        steps = cfg.run.t_end * 3.0 * math.sqrt(g * d_max) / (cfg.flood.courant * h)
        memory = BASE_BYTES + SWE_PARTICLE_BYTES * n * (7 if cfg.flood.split else 1) + SWE_CELL_BYTES * cells
        seconds = n * steps / SWE_STEPS_S
        fix = "raise flood.spacing"
    what = f"{volume:,.0f} m³ in about {n:,.0f} particles of {spacing:g} m ({cfg.flood.solver}), {steps:,.0f} steps"
    return Estimate(what, memory, seconds, fix)


def shallow_water(what: str, model, t_end: float, speed: float = 0.0) -> Estimate:
    """A shallow-water SPH run from its built model (validations that step a model themselves): Δt from the
    model's CFL limit C·min H/(√(g d) + |u|) at the start, its wave speed √(g d_max) raised by ``speed``, the
    fastest water expected (a dam break's front: 2√(g h₀)); particle-steps at SWE_STEPS_S."""

    p = model.params
    c = math.sqrt(p.g * max(float(model.depth.max()), 1e-9)) if model.n else 1.0
    dt = p.courant * step_limit(model.vel, model.depth, model.hsup, model.n, p.g) * c / (c + speed)
    steps = t_end / dt if math.isfinite(dt) and dt > 0 else 0.0
    seconds = START_S + steps * (SWE_STEP_S + model.n / SWE_STEPS_S)
    text = f"{what}, {model.n:,} particles, about {steps:,.0f} steps"
    return Estimate(text, BASE_BYTES + SWE_PARTICLE_BYTES * model.n, seconds, "", steps)


ESTIMATORS = {
    "hydrology": hydrology, "particle-stream": stream, "sph": sph, "sph-terrain": sph_terrain, "flood": flood,
    "voxel": lambda cfg: voxel(cfg),
}  # fmt: skip


def check(kind: str, cfg) -> Estimate | None:
    """The run's estimate; a :class:`ConfigError` when it would need more memory than is free."""
    fn = ESTIMATORS.get(kind)
    est = fn(cfg) if fn is not None else None
    if est is None:
        return None
    free = available_memory()
    if free is not None and est.memory > free:
        raise ConfigError(
            f"This run ({est.what}) needs about {_bytes(est.memory)} of memory, but only {_bytes(free)} is free; "
            f"{est.fix}, or use a machine with more memory."
        )
    return est


#: a voxel run's particle-steps per second per core (the wall-weight walls read the field at every particle)
#: and its fixed cost per step: fitted to ``mountain-lake`` (docs/voxel.md: 89 932 steps in 171 s on one
#: thread beside other runs, 1 300 particles on average) and ``overtopping --resolution coarse``
VOXEL_STEPS_PER_CORE_S, VOXEL_STEP_S = 1.0e6, 1.5e-3
#: the field's set-up per node (distances, wall weights, the DEM's columns): 2.0 s for the 2.1·10⁶ nodes of
#: ``mountain-lake`` on a 300² DEM of 1 m cells, compiled kernels cached
VOXEL_NODE_SETUP_S = 1.0e-6


def voxel(cfg) -> Estimate:
    """The field (nodes of ``voxels.cell_size`` over the terrain, as ``voxel.build.build_terrain`` lays
    them), the water (below ``water.level``, the rain and inflows over the run) and steps from the sound
    speed ``build_solver`` takes (10·√(2gH), H from the highest water to the field's bottom)."""

    cfg = at_dem_scale(cfg)
    f, v, p, run = cfg.terrain, cfg.voxels, cfg.sph, cfg.run
    c, dx, band = v.cell_size, p.spacing, band_for(cfg)
    water = 0.0  # m³ at the start
    added = sum(j.discharge for j in cfg.inflows.values()) * run.t_end
    if f.voxels_file:
        return None
    if f.shape == "heightmap":
        import numpy as np


        hm = heightmap(f, cfg.seed)
        z = np.asarray(hm.z, np.float64)
        zmax, zmin = float(np.nanmax(z)), float(np.nanmin(z))
        lift = max([cfg.rain.height] + [j.height for j in cfg.inflows.values()])
        top, bottom = zmax + lift + band + 2 * c, zmin - max(band + 2 * c, v.depth)
        ny, nx = z.shape
        extent = ((nx - 1) * hm.cell_size, (ny - 1) * hm.cell_size)
        if cfg.water.level is not None:
            water = float(np.nansum(np.maximum(cfg.water.level - z, 0.0))) * hm.cell_size**2
        added += cfg.rain.rate / 3.6e6 * extent[0] * extent[1] * run.t_end
        highest = max([cfg.water.level or -math.inf, zmax + lift])
        fall = highest - bottom
    else:
        e = cfg.embankment
        extent, bottom, top = (f.length + 4 * c, f.width + 4 * c), -(band + 2 * c), f.top
        if cfg.water.level is not None:
            water = (e.x_toe + 0.5 * e.height * e.upstream) * f.width * cfg.water.level
        added += cfg.inflow.discharge * run.t_end
        fall = max(cfg.water.level or 0.0, e.base + e.height + overflow_head(cfg.inflow.discharge, f.width))
    nodes = (extent[0] / c + 1) * (extent[1] / c + 1) * ((top - bottom) / c + 1)
    n0, n_add = water / dx**3, added / dx**3
    speed = p.sound_speed_for(max(fall, dx)) if p.sound_speed <= 0 else p.sound_speed
    steps = run.t_end / p.dt if p.dt > 0 else sph_steps(run.t_end, speed, speed / 10.0, p.cfl, p.support())
    per_step = VOXEL_STEP_S + (n0 + 0.5 * n_add) / (VOXEL_STEPS_PER_CORE_S * _cores())
    setup = nodes * VOXEL_NODE_SETUP_S
    seconds = START_S + setup + steps * per_step
    memory = BASE_BYTES + memory_bytes(int(nodes), erosion=cfg.erosion.enabled) * 3 + SPH_PARTICLE_BYTES * (n0 + n_add)
    what = (f"{nodes:,.0f} voxels of {c:g} m, {n0 + n_add:,.0f} particles of {dx:g} m at most, "
            f"about {steps:,.0f} steps")  # fmt: skip
    fix = "raise voxels.cell_size with sph.spacing, or shorten run.t_end"
    return Estimate(what, memory, seconds, fix, steps, setup_s=setup)
