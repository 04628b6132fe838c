"""Run an SPH scenario on the device to a time, then step its checkpoint on the CPU and on the device side by side.

A check that the two paths agree on one particular state, not only on the dam-break check of
``gpu_agreement.py``: after each step it records both clocks, both largest speeds and the largest
position and velocity differences, and stops when either side stops (unstable, ``max_mach``) or after
``--steps``. Written for SPHERIC Test 2 at 0.015 m, which went unstable on the device at 0.893 s and not
on the CPU (docs/sph.md); it works for any ``kind = "sph"`` scenario.

    python benchmarks/gpu_lockstep.py OUT --scenario spheric2 --set sph.spacing=0.015 --t-check 0.86 --steps 600
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np


def _simulation(name: str, settings: list[str], folder: Path, device: str, t_end: float, resume: bool):
    from erosim.io.runfolder import RunFolder
    from erosim.scenarios import kinds, loader
    from erosim.simulation.simulation import Simulation

    scenario = loader.load(name, [*settings, f"run.device={device}", f"run.t_end={t_end!r}"])
    out = RunFolder(folder, resume=resume)
    setup = kinds.resolve(kinds.get(scenario.kind).builder)(scenario, out)
    sim = Simulation(
        setup.models, out=out, stop_time=setup.stop_time, callbacks=setup.callbacks, kind=scenario.kind,
        label=scenario.name, unit=setup.unit, checkpoint_wall_s=1e9, progress=False,
    )  # fmt: skip
    if resume:
        sim.restore()
    return sim


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--scenario", default="spheric2")
    ap.add_argument("--set", dest="settings", action="append", default=[])
    ap.add_argument("--t-check", type=float, required=True, help="time of the checkpoint both sides start from")
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--cpu-first", action="store_true", help="write the checkpoint on the CPU instead of the device")
    ap.add_argument("--side", action="append", default=[],
                    help="DEVICE[:KEY=VALUE,...], a side to step from the checkpoint (default: cpu and cuda); "
                    "the first two are compared")  # fmt: skip
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    runs = args.out / "runs"
    first = "cpu" if args.cpu_first else "cuda"
    record: dict = {"scenario": args.scenario, "settings": args.settings, "t_check": args.t_check, "first": first}

    def save():
        (args.out / "lockstep.json").write_text(json.dumps(record, indent=1))

    t0 = time.perf_counter()
    sim = _simulation(args.scenario, args.settings + ["run.output_interval=0", "run.snapshots=0"],
                      runs / "first", first, args.t_check, resume=False)  # fmt: skip
    sim.run(seed=1)
    record["first_run"] = {"status": sim.status, "t": sim.time, "steps": sim.iteration,
                           "wall_s": round(time.perf_counter() - t0, 1)}  # fmt: skip
    save()
    print(json.dumps(record["first_run"]), flush=True)
    if sim.status != "completed":
        return 1
    sides = {}
    for k, spec in enumerate(args.side or ["cpu", "cuda"]):
        device, _, extra = spec.partition(":")
        folder = runs / f"side{k}"
        shutil.copytree(runs / "first", folder)
        more = [e for e in extra.split(",") if e]
        sides[f"{k}_{spec}"] = _simulation(args.scenario, args.settings + more, folder, device, 10.0, True).models[0]
    rows = []
    record["rows"] = rows
    stopped: dict = {}
    for k in range(args.steps):
        row = {"step": k + 1}
        for name, m in sides.items():
            if f"{name}_stopped" in stopped:
                continue
            try:
                m.advance()
            except Exception as exc:  # noqa: BLE001 - the stop is the finding
                row[f"{name}_stopped"] = stopped[f"{name}_stopped"] = f"{type(exc).__name__}: {exc}"
            row[f"{name}_t"] = float(m.time)
            row[f"{name}_dt"] = float(m.last_dt)
            vel, acc = m.fluid_velocities(), m.fluid_accelerations()
            row[f"{name}_vmax"] = float(np.sqrt((vel**2).sum(axis=1)).max())
            i = int(np.argmax((acc**2).sum(axis=1)))  # the particle with the largest acceleration (label)
            row[f"{name}_amax"] = {"label": i, "acc": float(np.sqrt((acc[i] ** 2).sum())),
                                   "pos": m.fluid_positions()[i].round(5).tolist(), "vel": vel[i].round(4).tolist(),
                                   "rho": float(m.fluid_density()[i]), "p": float(m.fluid_pressure()[i])}  # fmt: skip
        if len(stopped) == len(sides):
            rows.append(row)
            break
        if len(sides) < 2:
            rows.append(row)
            continue
        a, b = list(sides.values())[:2]
        row["dx_max"] = float(np.abs(a.fluid_positions() - b.fluid_positions()).max())
        row["dv_max"] = float(np.abs(a.fluid_velocities() - b.fluid_velocities()).max())
        row["drho_rel_max"] = float(np.abs(a.fluid_density() / b.fluid_density() - 1.0).max())
        rows.append(row)
        if k % 25 == 0 or any(key.endswith("_stopped") for key in row):
            print(json.dumps(row), flush=True)
            save()
    record["wall_s"] = round(time.perf_counter() - t0, 1)
    save()
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "src"))
    raise SystemExit(main())
