"""SPH solver scaling: time per step at about 10⁴, 10⁵ and 10⁶ fluid particles (3-D dam break).

Runs :func:`erosim.bench.sph.run` at each size and prints one JSON object per size plus the time per
particle-step, which is flat when the cost is linear in N. ``--flowing`` first runs the dam break
untimed until the front is moving (``warmup`` steps), so the timed steps include the neighbour-list
rebuilds of a developed flow (about one every 8–10 steps) instead of the nearly still start.

    .venv/bin/python benchmarks/sph_scaling.py [--sizes 10000 100000 1000000] [--flowing]

On a shared machine compare ``cpu_s`` as well as wall time: wall time also counts the others' load.
"""

from __future__ import annotations

import argparse
import json

from erosim.bench.sph import run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--steps", type=int, default=None)
    ap.add_argument("--flowing", action="store_true", help="time a developed flow (warm-up of 1500 steps)")
    args = ap.parse_args()
    for n in args.sizes:
        warm = 1500 if args.flowing else 20
        steps = args.steps if args.steps is not None else (10 if n >= 500_000 else None)
        r = run(n, steps, 3, warmup=warm)
        r["us_per_particle_step"] = 1e6 / r["particle_steps_per_s"]
        r["warmup_steps"] = warm
        print(json.dumps(r), flush=True)


if __name__ == "__main__":
    main()
