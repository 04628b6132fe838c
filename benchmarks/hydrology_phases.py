"""Where a hydrology cycle's time goes: the library scenario at one size, per phase.

    .venv/bin/python benchmarks/hydrology_phases.py --size 512 --cycles 24 [--set hydrology.batch=0]
    NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/hydrology_phases.py --size 512

Runs one untimed cycle (compilation), then ``--cycles`` cycles with timers around the batch phases
(parallel descents, the one-thread descents of a round's last few droplets, logs applied, lakes filled) and
around the cycle's other passes (creep, the stream map, vegetation, lake rebuilds, creep into lakes)
and prints milliseconds per cycle of wall and CPU time, the phases' shares and the descend steps per
droplet. With ``hydrology.batch=0`` (the seed's order) the phases are not split.
"""

from __future__ import annotations

import argparse
import json
import time


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--cycles", type=int, default=24)
    ap.add_argument("--set", dest="sets", action="append", default=[], help="a scenario setting, as erosim run")
    args = ap.parse_args(argv)

    import numba

    import erosim.hydrology.model as M
    from erosim.hydrology.pools import B_STEPS
    from erosim.scenarios import loader
    from erosim.scenarios.hydrology.build import build_model

    sc = loader.load("hydrology", [f"terrain.size={args.size}", *args.sets])
    _terrain, model = build_model(sc.config)
    model.cycle()
    spent = {"parallel descents": 0.0, "one-thread descents": 0.0, "logs applied": 0.0, "lakes filled": 0.0}

    def timed(name, fn):
        def call(*a):
            t = time.perf_counter()
            out = fn(*a)
            spent[name] += time.perf_counter() - t
            return out

        return call

    M.descend_batch = timed("parallel descents", M.descend_batch)
    M.descend_batch_serial = timed("one-thread descents", M.descend_batch_serial)
    M.apply_logs = timed("logs applied", M.apply_logs)
    M.batch_floods = timed("lakes filled", M.batch_floods)
    for name, owner, attr in (
        ("creep", M, "creep_step"),
        ("stream map", M.streams, "update"),
        ("vegetation", M.vegetation, "step"),
        ("lake rebuilds", model, "_rebuild"),
        ("creep into lakes", model, "_slump_into_lakes"),
    ):
        spent[name] = 0.0
        setattr(owner, attr, timed(name, getattr(owner, attr)))
    d0, s0 = model.droplets, model.budget[B_STEPS]
    t0, c0 = time.perf_counter(), time.process_time()
    model.run(args.cycles)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    n = args.cycles
    out = {
        "size": args.size,
        "batch": int(model.batch),
        "threads": numba.get_num_threads() if model.batch else 1,
        "wall_ms_per_cycle": round(1e3 * wall / n, 1),
        "cpu_ms_per_cycle": round(1e3 * cpu / n, 1),
        "phases_ms_per_cycle": {k: round(1e3 * v / n, 1) for k, v in spent.items()},
        "steps_per_droplet": round(float(model.budget[B_STEPS] - s0) / (model.droplets - d0), 1),
    }
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
