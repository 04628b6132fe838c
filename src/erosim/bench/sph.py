"""``erosim bench sph``: throughput of the SPH solver on a dam break (issue 2, item 9).

A fluid block of about ``particles`` particles (3-D: a cube of side L, the thesis's SC-1; 2-D: a
column L × 2L) is released at one end of a tank 3L long (3-D: L wide, 1.5L high; 2-D: 2.5L high),
with the solver's default settings (Wendland C2, Tait, δ-SPH, artificial viscosity, leapfrog,
boundary-particle walls, float64, support 2Δx in 3-D: about 30 neighbours). The solver is built
and run for ``warmup`` steps untimed (Numba compilation and the first neighbour lists), then
``steps`` steps (default: 100 to 400, enough for about ``seconds`` of timing) are timed,
neighbour-list rebuilds and particle re-sorting included. The timed steps are the start of the
collapse (few rebuilds); ``benchmarks/sph_scaling.py --flowing`` times a developed flow.
(float32 storage measured no faster: the pair loop is bound by arithmetic, not memory.)
Reported:

* ``particle_steps_per_s`` = fluid particles × timed steps / wall time;
* ``pair_interactions_per_s`` = Σ over fluid particles of neighbours within h (fluid and boundary) ×
  steps / wall time;
* ``neighbours_mean``, ``ms_per_step``, ``threads`` (Numba threads), ``peak_rss_mb`` (peak resident
  memory of the process), ``cpu_s`` (process CPU time of the timed steps: on a shared machine, wall
  time also counts the other jobs' load), ``boundary_particles``, ``rebuilds`` (during the timed steps);
* ``device`` (``cpu`` or ``cuda``: ``--device cuda`` times :class:`~erosim.sph.solver_cuda.CudaSPHSolver`,
  whose steps include the per-step copies of three numbers back to the host) and, on the GPU,
  ``gpu`` (its name). The GPU's timed steps end with the step's last host copy, so all kernels of
  them have finished.
"""

from __future__ import annotations

import resource
import time

import numpy as np

from erosim.bench import threading_layer
from erosim.core.devices import cuda_status, require
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver


def dam_break_geometry(particles: int, dim: int, spacing: float):
    """(fluid positions, domain lo, domain hi) of the benchmark's dam break."""
    if dim == 3:
        n = max(2, int(round(particles ** (1.0 / 3.0))))
        counts = (n, n, n)
        L = n * spacing
        hi = (3.0 * L, L, 1.5 * L)
    else:
        n = max(2, int(round((particles / 2.0) ** 0.5)))
        counts = (n, 2 * n)
        L = n * spacing
        hi = (3.0 * L, 2.5 * L)
    axes = [(np.arange(c) + 0.5) * spacing for c in counts]
    grids = np.meshgrid(*axes, indexing="ij")
    fluid = np.stack([g.ravel() for g in grids], axis=1)
    return fluid, np.zeros(dim), np.array(hi)


def box_reference(particles: int, spacing: float, *, warmup: int, steps: int | None, seconds: float,
                  step_bounds: tuple[int, int]):  # fmt: skip
    """The 3-D dam break in a box of boundary particles that the terrain benchmarks compare with.

    Returns (fluid, lo, hi, solver, steps, wall_s): ``steps`` (when None) is what fits in ``seconds``
    at the speed of five probe steps, within ``step_bounds``; ``wall_s`` is the time of that many steps
    after ``warmup`` untimed ones.
    """

    fluid, lo, hi = dam_break_geometry(int(particles), 3, spacing)
    box = SPHSolver(SPHParams(dim=3, spacing=spacing), fluid, domain_lo=lo, domain_hi=hi)
    for _ in range(warmup):
        box.step()
    if steps is None:
        per = timed_steps(box.step, 5) / 5
        steps = int(max(step_bounds[0], min(step_bounds[1], seconds / max(per, 1e-6))))
    return fluid, lo, hi, box, steps, timed_steps(box.step, steps)


def timed_steps(step, steps: int, every: int = 0, coupler=None) -> float:
    """Wall seconds of ``steps`` calls of ``step``, calling ``coupler`` after every ``every``-th."""
    t0 = time.perf_counter()
    for k in range(steps):
        step()
        if coupler is not None and (k + 1) % every == 0:
            coupler()
    return time.perf_counter() - t0


def run(
    particles: int = 100_000,
    steps: int | None = None,
    dim: int = 3,
    *,
    warmup: int = 20,
    precision: str = "float64",
    walls: str = "particles",
    seconds: float = 8.0,
    device: str = "cpu",
) -> dict:
    """Benchmark one size; returns the JSON-able result (keys in the module docstring)."""
    import numba


    require(device)
    if device == "cuda":
        from erosim.sph.solver_cuda import CudaSPHSolver as SPHSolver
    else:
        from erosim.sph.solver import SPHSolver

    spacing = 0.01
    fluid, lo, hi = dam_break_geometry(int(particles), int(dim), spacing)
    params = SPHParams(dim=int(dim), spacing=spacing, precision=precision, walls=walls)
    t0 = time.perf_counter()
    solver = SPHSolver(params, fluid, domain_lo=lo, domain_hi=hi)
    build_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    for _ in range(warmup):
        solver.step()
    warm_s = time.perf_counter() - t0
    if steps is None:
        # the same stage of the collapse at every size (time per step comparable across N), at least
        # ~`seconds` of timing at small N
        per = warm_s / max(warmup, 1)
        steps = int(max(100, min(400, seconds / max(per, 1e-6))))
    r0 = solver.rebuilds
    c0 = time.process_time()
    t0 = time.perf_counter()
    for _ in range(int(steps)):
        solver.step()
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    stats = solver.neighbour_stats()
    nf = solver.n_fluid
    return {
        "particles": int(nf),
        "boundary_particles": int(solver.n_boundary),
        "dim": int(dim),
        "steps": int(steps),
        "neighbours_mean": round(stats["mean"], 2),
        "particle_steps_per_s": nf * steps / wall,
        "pair_interactions_per_s": nf * stats["mean"] * steps / wall,
        "ms_per_step": 1000.0 * wall / steps,
        "threads": int(numba.get_num_threads()),
        "threading_layer": threading_layer(),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1),
        "wall_s": round(wall, 3),
        "cpu_s": round(cpu, 3),
        "rebuilds": int(solver.rebuilds - r0),
        "simulated_s": float(solver.t),
        "build_s": round(build_s, 2),
        "precision": precision,
        "walls": walls,
        "device": device,
        **({"gpu": devices_gpu()} if device == "cuda" else {}),
    }


def devices_gpu() -> str:
    """The GPU (or the simulator) that ran the benchmark, in words."""

    return cuda_status()[1]
