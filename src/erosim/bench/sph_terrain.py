"""``erosim bench sph-terrain``: the SPH fluid on a heightmap that it erodes, against the same fluid in a
box (issue 8).

The benchmark's dam break (:mod:`erosim.bench.sph`: a cube of about ``particles`` fluid particles at
one end of a tank 3L × L × 1.5L, Δx = 0.01 m) is run twice:

* **box**: the tank's floor and sides as boundary particles (the SPH benchmark itself);
* **terrain**: the floor a flat heightmap of 2Δx cells under the particle-free heightfield ground,
  the sides plane walls, and transport-capacity erosion coupled every ``every`` steps (the coupler:
  binning the fluid onto the terrain's nodes, the erosion law, applying the increments, refreshing
  the ground).

Both are warmed up (compilation, first lists), then ``steps`` steps are timed. Reported:

* ``particles``, ``steps``, ``particle_steps_per_s`` (terrain case, coupling included) and
  ``pair_interactions_per_s``;
* ``coupling_fraction``: the share of the terrain case's wall time spent outside the SPH step
  (binning, erosion, refresh);
* ``box_particle_steps_per_s`` and ``heightfield_overhead`` = (terrain step time without the
  coupling) / (box step time) − 1: what the heightfield ground costs over box walls;
* ``boundary_particles`` of each case, ``peak_rss_mb``, ``threads``.
"""

from __future__ import annotations

import resource
import time

import numpy as np

from erosim.bench import threading_layer
from erosim.bench.sph import box_reference
from erosim.core.schedules import IterationInterval
from erosim.coupling.coupler import Coupler
from erosim.coupling.raster import Raster
from erosim.coupling.terrains import HeightfieldTerrain
from erosim.erosion.transport_capacity_mei2007 import TransportCapacity, TransportCapacityParams
from erosim.sph.boundaries.heightfield import HeightfieldGround
from erosim.sph.boundaries.planes import PlaneWalls
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver


def run(particles: int = 100_000, steps: int | None = None, *, every: int = 20, warmup: int = 20,
        seconds: float = 8.0) -> dict:  # fmt: skip
    """Benchmark one size; returns the JSON-able result (keys in the module docstring)."""
    import numba


    dx = 0.01
    # --- box: boundary particles on the floor and the sides
    fluid, lo, hi, box, steps, box_wall = box_reference(particles, dx, warmup=warmup, steps=steps,
                                                        seconds=seconds, step_bounds=(60, 400))  # fmt: skip

    # --- terrain: flat heightmap floor, plane sides, erosion every `every` steps
    cell = 2.0 * dx
    nx, ny = int(round(hi[0] / cell)) + 1, int(round(hi[1] / cell)) + 1
    raster = Raster(0.0, 0.0, cell, cell, nx, ny)
    terrain = np.zeros(raster.shape)
    xe, ye = (nx - 1) * cell, (ny - 1) * cell
    planes = PlaneWalls([[0, 0, 0], [xe, 0, 0], [0, 0, 0], [0, ye, 0]],
                        [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]])  # fmt: skip
    params = SPHParams(dim=3, spacing=dx, walls="reflect")
    solver = SPHSolver(params, fluid, domain_lo=lo - 0.1, domain_hi=hi, boundaries=[HeightfieldGround(raster, terrain),
                       planes])  # fmt: skip
    eroder = TransportCapacity(TransportCapacityParams(), raster, solver)
    coupler = Coupler(IterationInterval(every), solver, eroder,
                      HeightfieldTerrain(raster, terrain, solver.dim, near_bed=2.0 * solver.h))
    for k in range(warmup):
        solver.step()
        if k % every == 0:
            coupler()
    coupler.wall = 0.0
    r0 = solver.rebuilds
    t0 = time.perf_counter()
    for k in range(steps):
        solver.step()
        if k % every == 0:
            coupler()
    wall = time.perf_counter() - t0
    stats = solver.neighbour_stats()
    nf = solver.n_fluid
    step_only = wall - coupler.wall
    return {
        "particles": int(nf),
        "steps": int(steps),
        "erosion_every": int(every),
        "particle_steps_per_s": nf * steps / wall,
        "pair_interactions_per_s": nf * stats["mean"] * steps / wall,
        "neighbours_mean": round(stats["mean"], 2),
        "coupling_fraction": coupler.wall / wall,
        "ms_per_step": 1000.0 * wall / steps,
        "box_particle_steps_per_s": box.n_fluid * steps / box_wall,
        "box_ms_per_step": 1000.0 * box_wall / steps,
        "heightfield_overhead": step_only / box_wall - 1.0,
        "boundary_particles": {"terrain": int(solver.n_boundary), "box": int(box.n_boundary)},
        "terrain_nodes": int(raster.nx * raster.ny),
        "eroded_m3": coupler.budget()["eroded"],
        "rebuilds": int(solver.rebuilds - r0),
        "threads": int(numba.get_num_threads()),
        "threading_layer": threading_layer(),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1),
    }
