"""How closely the CUDA device path follows the CPU solver on a real GPU (a check, not a benchmark).

Builds the benchmark's 3-D dam break (``erosim.bench.sph``) at ``--particles`` on both devices, checks
that the device's first neighbour lists are the CPU's entry for entry, runs ``--steps`` steps on each
and prints one JSON object: per field, the largest difference relative to the field's largest value,
after 1 step and after all steps, and both devices' step counts, Δt and rebuilds.

On the GPU the two paths sum the same terms in the same order; they differ where the GPU's compiler
fuses a·b + c into one rounding and the CPU's does not, about 1e-16 relative per operation. The
collapsing column is not chaotic over a few hundred steps, so the differences should stay near 1e-12
after 100 steps; ``--tolerance`` (default 1e-9 after all steps) makes the exit status say so.

    python benchmarks/gpu_agreement.py --particles 20000 --steps 100
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

FIELDS = ("positions", "velocities", "density", "pressure")


def rel_diff(a, b) -> dict[str, float]:
    out = {}
    for f in FIELDS:
        x, y = getattr(a, "fluid_" + f)(), getattr(b, "fluid_" + f)()
        out[f] = float(np.max(np.abs(x - y)) / max(float(np.max(np.abs(x))), 1e-300))
    return out


def agreement(particles: int = 20_000, steps: int = 100, dim: int = 3, tolerance: float = 1e-9) -> dict:
    """The check's JSON object (see the module docstring); ``passed`` says whether it held."""
    from erosim.bench.sph import dam_break_geometry
    from erosim.sph.params import SPHParams
    from erosim.sph.solver import SPHSolver
    from erosim.sph.solver_cuda import CudaSPHSolver

    fluid, lo, hi = dam_break_geometry(particles, dim, 0.01)
    prm = SPHParams(dim=dim, spacing=0.01)
    cpu = SPHSolver(prm, fluid, domain_lo=lo, domain_hi=hi)
    gpu = CudaSPHSolver(prm, fluid, domain_lo=lo, domain_hi=hi)
    s, m, nbr = gpu.device_lists()
    lists_equal = bool(
        np.array_equal(s, cpu.start) and np.array_equal(m, cpu.mid) and np.array_equal(nbr, cpu.nbr[: s[-1]])
    )
    cpu.step()
    gpu.step()
    first = rel_diff(cpu, gpu)
    for _ in range(steps - 1):
        cpu.step()
        gpu.step()
    last = rel_diff(cpu, gpu)
    out = {
        "particles": cpu.n_fluid,
        "boundary_particles": cpu.n_boundary,
        "steps": [cpu.steps, gpu.steps],
        "t": [cpu.t, gpu.t],
        "rebuilds": [cpu.rebuilds, gpu.rebuilds],
        "lists_equal_at_start": lists_equal,
        "rel_diff_after_1_step": first,
        f"rel_diff_after_{steps}_steps": last,
        "tolerance": tolerance,
        "passed": lists_equal and max(last.values()) <= tolerance,
    }
    return out


def flood_agreement(spacing: float = 10.0, steps: int = 200, tolerance: float = 1e-9) -> dict:
    """The same check for the shallow-water SPH: the benchmark valley's dam break (``erosim bench
    flood``) built and settled once per device (on the host, alike), then ``steps`` steps with the
    hazard maxima raised on each; differences relative to each field's largest value."""
    from erosim.analysis.hazard import HazardMaps
    from erosim.bench.flood import setup

    settle = ["flood.settle_steps=100"]  # on the host, alike on both; fewer steps only to save time
    site, cpu, cfg, _ = setup(1e9, spacing, device="cpu", overrides=settle)
    _, gpu, _, _ = setup(1e9, spacing, device="cuda", overrides=settle)
    maps = [HazardMaps(site.terrain.shape, cfg.flood.wet_depth) for _ in range(2)]
    for _ in range(steps):
        for solver, m in zip((cpu, gpu), maps, strict=True):
            solver.step()
            solver.update_maxima(m, m.wet_depth)
    gpu.sync_maxima(maps[1])

    def rel(a, b):
        a, b = np.nan_to_num(a, posinf=0.0), np.nan_to_num(b, posinf=0.0)
        return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(a))), 1e-300))

    same_n = cpu.n == gpu.n
    fields = {k: rel(getattr(cpu, k), getattr(gpu, k)) for k in ("pos", "vel", "depth", "hsup")} if same_n else {}
    maxima = {k: rel(getattr(maps[0], k), getattr(maps[1], k)) for k in ("max_depth", "max_speed", "arrival")}
    return {
        "particles": [cpu.n, gpu.n],
        "steps": [cpu.steps, gpu.steps],
        "t": [cpu.t, gpu.t],
        "rebuilds": [cpu.rebuilds, gpu.rebuilds],
        "volume_out_m3": [cpu.volume_out, gpu.volume_out],
        f"rel_diff_after_{steps}_steps": fields,
        "hazard_maxima_rel_diff": maxima,
        "tolerance": tolerance,
        "passed": same_n and max([*fields.values(), *maxima.values()]) <= tolerance,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--particles", type=int, default=20_000)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--dim", type=int, choices=(2, 3), default=3)
    ap.add_argument("--tolerance", type=float, default=1e-9)
    args = ap.parse_args(argv)
    out = agreement(args.particles, args.steps, args.dim, args.tolerance)
    print(json.dumps(out))
    return 0 if out["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
