"""All the GPU figures of docs/gpu.md in one Python process, within a time budget.

A lent GPU machine is short-lived and every process on it compiles the CPU's and the GPU's kernels
afresh, so this script runs the measurements in one process (each kernel compiled once), in order of
importance, skipping any part whose rough cost no longer fits in ``--budget`` seconds:

1. ``env``          the GPU, the driver, Numba's and numpy's versions, ``erosim info``'s devices;
2. ``agreement``    the CPU/GPU agreement check of ``benchmarks/gpu_agreement.py`` (3-D, 20 000 particles);
3. ``bench_cuda_1e6`` / ``bench_cpu_1e6``  ``erosim bench sph`` at 10⁶ fluid particles on each device
                    (same machine, same process: the ratio);
4. ``profile_1e6``  the device step split by kernel (each launch synchronised and timed; the split
                    adds the synchronisations, so its total exceeds the benchmark's step);
5. ``martin_moyce_cuda`` / ``hydrostatic_cuda``  the validations with ``device = "cuda"`` (and
                    ``martin_moyce_cpu`` for the same errors on the CPU);
6. ``bench_cuda_1e7`` / ``bench_cpu_1e7``  the same at 10⁷; then ``bench_cuda_float32_1e7``;
7. the shallow-water SPH: ``flood_agreement`` (the benchmark valley at 10 m, 200 steps on each device),
   ``bench_flood_cuda`` / ``bench_flood_cpu`` (``erosim bench flood`` at 5 m spacing) and
   ``flood_run_cuda`` (``erosim run flood --device cuda``, its report and files).

Every result goes into one JSON file (``OUT/gpu_session.json``, rewritten after each part, so an
interrupted session keeps what it measured) and a log (``OUT/gpu_session.log``)::

    python benchmarks/gpu_session.py OUT [--budget 480] [--scale 1.0]

``--scale`` multiplies every particle count (a quick check under the CUDA simulator uses 1e-4).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


class KernelTimer:
    """Stands in for :mod:`erosim.sph.kernels_cuda` on a solver: every kernel launch through it is
    synchronised and timed, by kernel name (``totals``: seconds, ``calls``)."""

    def __init__(self, module, totals: dict):
        self._module, self._totals = module, totals

    def wrap(self, name: str, kernel):
        """A kernel whose launches ``kernel[config](*args)`` are timed."""
        timer = self

        class Launch:
            def __getitem__(self, config):
                return timer.timed_call(name, kernel[config])

        return Launch()

    def timed_call(self, name: str, fn):
        """``fn`` (a launch, or a host function that launches kernels itself: the prefix sum) timed as a
        whole, synchronised before and after."""
        from numba import cuda

        def timed(*args):
            cuda.synchronize()
            t0 = time.perf_counter()
            fn(*args)
            cuda.synchronize()
            entry = self._totals.setdefault(name, [0.0, 0])
            entry[0] += time.perf_counter() - t0
            entry[1] += 1

        return timed

    def __getattr__(self, name):
        attr = getattr(self._module, name)
        if name == "exclusive_scan":
            return self.timed_call(name, attr)
        return self.wrap(name, attr) if hasattr(attr, "__getitem__") and callable(attr) else attr


def profile(particles: int, steps: int) -> dict:
    """Seconds per step of each device kernel (synchronised launches) at ``particles`` (3-D dam break)."""
    from erosim.bench.sph import dam_break_geometry
    from erosim.sph.params import SPHParams
    from erosim.sph.solver_cuda import CudaSPHSolver

    fluid, lo, hi = dam_break_geometry(particles, 3, 0.01)
    solver = CudaSPHSolver(SPHParams(dim=3, spacing=0.01), fluid, domain_lo=lo, domain_hi=hi)
    for _ in range(20):
        solver.step()
    totals: dict = {}
    timer = KernelTimer(solver._kc, totals)
    solver._kc = timer
    solver._fused = timer.wrap("fluid_pass", solver._fused)
    solver._brate = timer.wrap("boundary_density_rate", solver._brate)
    r0 = solver.rebuilds
    t0 = time.perf_counter()
    for _ in range(steps):
        solver.step()
    wall = time.perf_counter() - t0
    per = {
        k: {"ms_per_step": 1e3 * v[0] / steps, "calls": v[1]}
        for k, v in sorted(totals.items(), key=lambda kv: -kv[1][0])
    }
    kernels = sum(v[0] for v in totals.values())
    return {
        "particles": solver.n_fluid,
        "steps": steps,
        "rebuilds": solver.rebuilds - r0,
        "ms_per_step_synchronised": 1e3 * wall / steps,
        "ms_per_step_in_kernels": 1e3 * kernels / steps,
        "kernels": per,
    }


def gpu_memory() -> dict:
    from numba import cuda

    free, total = cuda.current_context().get_memory_info()
    return {"gpu_memory_used_gb": round((total - free) / 2**30, 2), "gpu_memory_total_gb": round(total / 2**30, 2)}


def bench(particles: int, device: str, **kw) -> dict:
    from erosim.bench.sph import run

    out = run(particles=particles, device=device, **kw)
    if device == "cuda":
        out.update(gpu_memory())
    return out


def flood_bench(device: str, t_end: float) -> dict:
    """``erosim bench flood --spacing 5`` for ``t_end`` simulated seconds (the reservoir settled for at
    most 100 steps: the settling runs on the host on either device)."""
    from erosim.bench.flood import run

    return run(t_end, 5.0, device=device, overrides=["flood.settle_steps=100"])


def flood_run(runs: Path) -> dict:
    """``erosim run flood --device cuda`` for 120 s: the run folder's report and the maps it wrote."""
    from erosim.cli import cli

    out = runs / "flood-cuda"
    try:
        args = ["--quiet", "run", "flood", "--device", "cuda", "--set", "run.t_end=120", "--out", str(out)]
        cli.main([*args, "--overwrite"], standalone_mode=False)
    except SystemExit as exc:
        if exc.code:
            raise
    report = json.loads((out / "report.json").read_text())
    return {"report": report, "files": sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file())[:60]}


def spheric2(spacing: float, runs: Path, t_end: float = 1.6) -> dict:
    """SPHERIC Test 2 (the `spheric2` scenario, as `erosim validate spheric2` sets it up) on the device
    at ``spacing``, scored by the validation's own errors (water-level RMS per gauge, pressure RMS)."""
    from erosim.data import SPHERIC2, reference_csv
    from erosim.io.runfolder import RunFolder
    from erosim.scenarios import loader
    from erosim.scenarios.runner import execute
    from erosim.validation import spheric2 as s2

    settings = [f"sph.spacing={spacing!r}", f"run.t_end={t_end!r}", "run.output_interval=0", "run.snapshots=0",
                "run.device=cuda"]  # fmt: skip
    scenario = loader.load("spheric2", settings)
    folder = RunFolder(runs / f"spheric2-{spacing}")
    t0 = time.perf_counter()
    _, sim = execute(scenario, folder, progress=False)
    wall = time.perf_counter() - t0
    e = s2.errors(s2._csv(folder.path / "gauges.csv"), reference_csv(SPHERIC2), scenario.config.sph.rho0, 9.81)
    solver = sim.models[0]
    return {"spacing_m": spacing, "fluid_particles": solver.n_fluid, "boundary_particles": solver.n_boundary,
            "steps": solver.steps, "wall_s": round(wall, 1), "level_rms_mm": {k: round(1000 * v, 1) for k, v in
            e["level_rms_m"].items()}, "wire_rms_mm": {k: round(1000 * v, 1) for k, v in
            e["wire_level_rms_m"].items()}, "pressure_rms_pct": {k: round(100 * v, 1) for k, v in
            e["pressure_rms_rel"].items()}}  # fmt: skip


def env() -> dict:
    import numba
    import numpy

    from erosim.core.devices import available

    try:
        smi = subprocess.run(
            ["nvidia-smi", "--query-gpu=name,memory.total,driver_version,clocks.max.sm", "--format=csv,noheader"],
            capture_output=True, text=True, check=False,
        )  # fmt: skip
        gpu = smi.stdout.strip() or smi.stderr.strip()
    except OSError as exc:
        gpu = f"nvidia-smi: {exc}"
    try:
        import numba.cuda

        cuda_impl = getattr(numba.cuda, "implementation", "built-in")
    except Exception as exc:  # noqa: BLE001 - reported, not raised
        cuda_impl = repr(exc)
    return {
        "nvidia_smi": gpu,
        "numba_cuda": cuda_impl,
        "numba": numba.__version__,
        "numpy": numpy.__version__,
        "numba_threads": numba.get_num_threads(),
        "python": sys.version.split()[0],
        "devices": available(),
    }


def validation(name: str, device: str, runs: Path) -> dict:
    import importlib

    mod = importlib.import_module(f"erosim.validation.{name.replace('-', '_')}")
    return mod.run("default", out=runs / f"{name}-{device}", progress=False, device=device)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--budget", type=float, default=480.0, help="seconds; parts that no longer fit are skipped")
    ap.add_argument("--scale", type=float, default=1.0, help="multiplies every particle count")
    ap.add_argument("--skip", default="", help="comma-separated parts not to run")
    ap.add_argument("--flood-t-end", type=float, default=60.0, help="simulated seconds of the flood benchmark")
    ap.add_argument("--runs", type=Path, default=Path("/tmp/erosim-gpu-runs"))
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    args.runs.mkdir(parents=True, exist_ok=True)
    from gpu_agreement import agreement, flood_agreement

    n = lambda x: max(200, int(x * args.scale))  # noqa: E731
    # (name, rough seconds on an H100 machine with a fresh compile cache, what to run)
    parts = [
        ("env", 5, env),
        ("agreement", 60, lambda: agreement(n(20_000), 100)),
        ("bench_cuda_1e6", 60, lambda: bench(n(1_000_000), "cuda")),
        ("bench_cpu_1e6", 40, lambda: bench(n(1_000_000), "cpu", steps=40)),
        ("profile_1e6", 20, lambda: profile(n(1_000_000), 50)),
        ("martin_moyce_cuda", 60, lambda: validation("martin-moyce", "cuda", args.runs)),
        ("martin_moyce_cpu", 20, lambda: validation("martin-moyce", "cpu", args.runs)),
        ("hydrostatic_cuda", 40, lambda: validation("hydrostatic", "cuda", args.runs)),
        ("bench_cuda_1e7", 60, lambda: bench(n(10_000_000), "cuda", steps=100)),
        ("bench_cpu_1e7", 60, lambda: bench(n(10_000_000), "cpu", steps=10)),
        ("bench_cuda_float32_1e7", 40, lambda: bench(n(10_000_000), "cuda", steps=100, precision="float32")),
        # the shallow-water SPH (flood): agreement, then `erosim bench flood` at 5 m (about 3·10⁵ particles)
        ("flood_agreement", 90, lambda: flood_agreement(10.0, 200)),
        ("bench_flood_cuda", 90, lambda: flood_bench("cuda", args.flood_t_end)),
        ("bench_flood_cpu", 90, lambda: flood_bench("cpu", args.flood_t_end)),
        ("flood_run_cuda", 60, lambda: flood_run(args.runs)),
        # SPHERIC Test 2 finer than the CPU's validation reaches (its fine is 0.02 m)
        ("spheric2_cuda_0.015", 60, lambda: spheric2(0.015, args.runs)),
        ("spheric2_cuda_0.01", 150, lambda: spheric2(0.01, args.runs)),
    ]
    results: dict = {"budget_s": args.budget, "scale": args.scale, "parts": {}}
    log = open(args.out / "gpu_session.log", "a", buffering=1)
    t_start = time.perf_counter()

    def save():
        tmp = args.out / "gpu_session.json.tmp"
        tmp.write_text(json.dumps(results, indent=1, default=str))
        tmp.replace(args.out / "gpu_session.json")

    failed = 0
    skip = set(filter(None, args.skip.split(",")))
    for name, cost, fn in parts:
        if name in skip:
            continue
        elapsed = time.perf_counter() - t_start
        if elapsed + cost > args.budget:
            results["parts"][name] = {"skipped": f"{elapsed:.0f} s spent, about {cost} s more would pass the budget"}
            print(f"== {name}: skipped at {elapsed:.0f} s", file=log)
            save()
            continue
        print(f"== {name} at {elapsed:.0f} s", file=log)
        t0 = time.perf_counter()
        try:
            res = fn()
            res = {k: v for k, v in res.items() if k not in ("T", "Z", "t", "depth")} if isinstance(res, dict) else res
            results["parts"][name] = {"wall_s": round(time.perf_counter() - t0, 1), "result": res}
            print(json.dumps(res, default=str)[:3000], file=log)
        except BaseException as exc:  # a part's failure must not lose the others' figures
            failed += 1
            results["parts"][name] = {"wall_s": round(time.perf_counter() - t0, 1), "error": repr(exc)}
            print(traceback.format_exc(), file=log)
            if isinstance(exc, KeyboardInterrupt):
                save()
                raise
        print(f"   {time.perf_counter() - t0:.1f} s", file=log)
        save()
    results["total_s"] = round(time.perf_counter() - t_start, 1)
    save()
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
