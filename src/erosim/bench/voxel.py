"""``erosim bench voxel``: the SPH fluid on a voxel terrain it erodes, against the same fluid in a box with
particle walls (issue 10; SPEC VX-10).

The benchmark's dam break (:mod:`erosim.bench.sph`: a cube of about ``particles`` fluid particles at one
end of a tank 3L × L × 1.5L, Δx = 0.01 m) is run three ways, each warmed up (compilation, first lists)
and then timed over the same ``steps``:

* **box**: the tank's floor and sides as boundary particles (the SPH benchmark itself);
* **voxel**: the tank as a voxel field (floor and four walls, 1 cm voxels, the wall-weight ramp) felt
  through :class:`~erosim.sph.boundaries.voxel_wall.VoxelWall` — no boundary particles;
* **voxel + erosion**: the same with Krištof et al.'s shear-stress erosion of the field applied every
  ``every`` steps (default 50) by the :class:`~erosim.coupling.coupler.Coupler` (τ_c = 0, so
  every moving particle erodes: the erosion's largest cost); with ``sediment = "suspended"`` the ground
  removed is carried by the particles and settles (:mod:`erosim.erosion.settling_voxel`, w_s = 0.02 m/s);
  with ``law = "excess_shear"`` the law is :mod:`erosim.erosion.excess_shear_partheniades1965` (τ_c = 0:
  every particle on the bed erodes).

Reported: ``particles``, ``steps``, ``particle_steps_per_s`` and ``pair_interactions_per_s`` (voxel +
erosion, coupling included; pairs: fluid neighbours within h at the end, as in ``bench sph``),
``boundary_fraction`` = (voxel step time) / (box step time) − 1 (what the wall weights cost over
particle walls; the issue's target ≤ 0.15), ``erosion_fraction`` = the couplings' time / the SPH
steps' time within the voxel + erosion run (what erosion every ``every`` steps adds; target ≤ 0.10),
``run_ratio_erosion`` = (voxel + erosion time) / (voxel time) − 1 (the two runs' flows part as the
tank erodes — at τ_c = 0 it deepens and the water spreads, so its steps get cheaper and this ratio is
no measure of the erosion's cost), the three rates, ``voxel_nodes``, ``boundary_particles`` of the box,
``eroded_m3``, ``sediment``, ``law``, ``threads`` and ``peak_rss_mb``.
"""

from __future__ import annotations

import resource

from erosim.bench import threading_layer
from erosim.bench.sph import box_reference, timed_steps
from erosim.core.schedules import IterationInterval
from erosim.coupling.coupler import Coupler
from erosim.coupling.terrains import VoxelFieldTerrain
from erosim.erosion.excess_shear_partheniades1965 import ExcessShearErosion, ExcessShearParams
from erosim.erosion.settling_voxel import SuspendedSediment
from erosim.erosion.shear_stress_kristof2009 import ShearStressErosion, ShearStressParams
from erosim.sph.boundaries.voxel_wall import VoxelWall
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver
from erosim.terrain.voxel import Box, VoxelTerrain


def tank_solver(fluid, lo, hi, dx: float):
    """The dam break's tank (``lo`` … ``hi``, open at the top) as a voxel field of Δ = ``dx`` with its
    wall-weight ramp, and an SPH solver of ``fluid`` felt through it: (solver, terrain)."""

    params = SPHParams(dim=3, spacing=dx, walls="reflect")
    band = 1.05 * (params.support() + 3**0.5 * dx)
    pad = band + 2 * dx
    lo_v = (lo[0] - pad, lo[1] - pad, lo[2] - pad)
    hi_v = (hi[0] + pad, hi[1] + pad, hi[2])
    air = Box(tuple(lo), (hi[0], hi[1], hi[2] + 1.0))  # the tank's inside, open at the top
    terrain = VoxelTerrain.from_sdf(lambda x, y, z: -air.sdf(x, y, z), lo_v, hi_v, dx, band=band)  # solid outside
    solver = SPHSolver(params, fluid, domain_lo=[a - 0.05 for a in lo_v], domain_hi=[b + 0.05 for b in hi_v],
                       boundaries=[VoxelWall(terrain)])  # fmt: skip
    return solver, terrain


def eroder_at_zero_threshold(terrain, solver, dx: float, law: str = "kristof2009", sediment: str = "carried_off"):
    """The benchmark's eroder: ``law`` at τ_c = 0 (every moving particle, or every particle on the bed,
    erodes), wrapped in the settling of :mod:`erosim.erosion.settling_voxel` for ``sediment = "suspended"``."""

    if law == "excess_shear":

        eroder = ExcessShearErosion(terrain, ExcessShearParams(erodibility=1.0, critical_stress=0.0),
                                    support=solver.h, spacing=dx)  # fmt: skip
    else:
        eroder = ShearStressErosion(terrain, ShearStressParams(k_eps=1.0, tau_c=0.0), support=solver.h)
    if sediment == "suspended":

        eroder = SuspendedSediment(eroder, solver, settling_velocity=0.02)
    return eroder


def run(particles: int = 50_000, steps: int | None = None, *, every: int = 50, warmup: int = 20,
        seconds: float = 8.0, sediment: str = "carried_off", law: str = "kristof2009") -> dict:  # fmt: skip
    """Benchmark one size; returns the JSON-able result (keys in the module docstring)."""
    import numba


    dx = 0.01
    fluid, lo, hi, box, steps, box_wall = box_reference(particles, dx, warmup=warmup, steps=steps,
                                                        seconds=seconds, step_bounds=(100, 500))  # fmt: skip
    results = {}
    for erode in (False, True):
        solver, terrain = tank_solver(fluid, lo, hi, dx)
        coupler = None
        if erode:
            eroder = eroder_at_zero_threshold(terrain, solver, dx, law, sediment)
            coupler = Coupler(IterationInterval(every), solver, eroder, VoxelFieldTerrain(terrain))
        timed_steps(solver.step, warmup, every, coupler)
        if coupler is not None:
            coupler()  # compiled and warm before the timing
            coupler.wall, coupler.calls = 0.0, 0
        wall_s = timed_steps(solver.step, steps, every, coupler)
        results[erode] = (wall_s, solver, terrain, coupler)
    v_wall, solver, terrain, _ = results[False]
    e_wall, esolver, _, coupler = results[True]
    nf = esolver.n_fluid
    return {
        "particles": int(nf),
        "steps": int(steps),
        "erosion_every": int(every),
        "sediment": sediment,
        "law": law,
        "particle_steps_per_s": nf * steps / e_wall,
        "pair_interactions_per_s": nf * esolver.neighbour_stats()["mean"] * steps / e_wall,
        "boundary_fraction": v_wall / box_wall - 1.0,
        "erosion_fraction": coupler.wall / (e_wall - coupler.wall),
        "run_ratio_erosion": e_wall / v_wall - 1.0,
        "box_particle_steps_per_s": box.n_fluid * steps / box_wall,
        "voxel_particle_steps_per_s": solver.n_fluid * steps / v_wall,
        "ms_per_step": {
            "box": 1000 * box_wall / steps,
            "voxel": 1000 * v_wall / steps,
            "voxel_erosion": 1000 * e_wall / steps,
        },  # fmt: skip
        "coupling_ms_per_call": 1000 * coupler.wall / max(coupler.calls, 1),
        "voxel_nodes": int(terrain.density.size),
        "boundary_particles": {"box": int(box.n_boundary), "voxel": int(solver.n_boundary)},
        "eroded_m3": coupler.totals["eroded"],
        "threads": int(numba.get_num_threads()),
        "threading_layer": threading_layer(),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1),
    }
