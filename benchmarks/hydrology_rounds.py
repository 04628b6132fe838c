"""The droplet descents alone (phase 1 of a batch round), replayed on captured rounds: time per sub-step.

    .venv/bin/python benchmarks/hydrology_rounds.py --size 1024 [--warm 4] [--rounds 6] [--repeat 3] [--json]
    NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/hydrology_rounds.py --size 1024

Builds the library scenario at ``--size``, runs ``--warm`` cycles, then captures the arguments of the next
cycle's first ``--rounds`` calls of :func:`erosim.hydrology.batch.descend_batch`. Phase 1 does not change the
terrain (its results go to the rows, logs and budget rows), so each captured round can be replayed on copies of
its arrays as often as needed: the same droplets, the same sub-steps, on every replay. Prints the best of
``--repeat`` replays per round, summed, as milliseconds, nanoseconds per sub-step per thread and sub-steps per
second, and the sub-steps counted. Use it to compare two versions of the descent on the same work (their
sub-step counts must agree where the change keeps the results); ``benchmarks/hydrology_phases.py`` times whole
cycles with their lakes, logs and creep.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def _copies(args):
    return [a.copy() if isinstance(a, np.ndarray) else a for a in args]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--warm", type=int, default=4, help="cycles run before the captured one")
    ap.add_argument("--rounds", type=int, default=6, help="rounds of the captured cycle replayed")
    ap.add_argument("--repeat", type=int, default=3, help="replays of each round; the best is kept")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)

    import numba

    import erosim.hydrology.model as M
    from erosim.hydrology.batch import descend_batch
    from erosim.hydrology.pools import B_STEPS
    from erosim.scenarios import loader
    from erosim.scenarios.hydrology.build import build_model

    sc = loader.load("hydrology", [f"terrain.size={args.size}"])
    _terrain, model = build_model(sc.config)
    for _ in range(args.warm):
        model.cycle()
    captured = []

    def capture(*a):
        if len(captured) < args.rounds:
            captured.append(_copies(a))
        return descend_batch(*a)

    M.descend_batch = capture
    try:
        model.cycle()
    finally:
        M.descend_batch = descend_batch
    total, steps = 0.0, 0
    for a in captured:
        descend_batch(*_copies(a))  # compiled and warm
        best = float("inf")
        for _ in range(args.repeat):
            b = _copies(a)
            t = time.perf_counter()
            descend_batch(*b)
            best = min(best, time.perf_counter() - t)
        total += best
        steps += int(b[13][:, B_STEPS].sum())
    threads = numba.get_num_threads()
    out = {
        "size": args.size,
        "threads": threads,
        "rounds": len(captured),
        "droplets_per_round": int(captured[0][0]) if captured else 0,
        "sub_steps": steps,
        "ms": round(total * 1e3, 2),
        "ns_per_sub_step_per_thread": round(total * threads / max(steps, 1) * 1e9, 1),
        "sub_steps_per_s": round(steps / total) if total > 0 else None,
    }
    print(json.dumps(out, indent=1) if args.json else "  ".join(f"{k} {v}" for k, v in out.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
