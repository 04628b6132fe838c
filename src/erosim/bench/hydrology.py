"""``erosim bench hydrology``: droplets per second of the hydrology model, lakes on.

The library scenario ``hydrology`` with the ``simplehydrology-2020`` preset (the reference
implementation's constants, ℓ = one cell) on a generated mountain terrain of ``size``² cells and
the extent of the seed's world at 256² (10.24 km). The model first spins up for ``spinup``
droplets (2 per cell, untimed: Numba compilation, and the first lakes and streams form — the
reference C++ was also timed on running simulations), then runs whole cycles until ``droplets``
more have fallen (default: 4 per cell) and reports

* ``droplets_per_s`` — droplets of the timed cycles / wall time (stream and vegetation updates
  and the per-cycle lake rebuild included);
* ``steps_per_s`` — descend sub-steps per second;
* ``flood_fraction`` — share of that wall time spent in HY-2 flood (lake filling / draining),
  measured with a monotonic clock around each flood call (a separate Numba build of the loop);
* ``droplets_per_cpu_s`` — the same per second of this process's CPU time: on a shared, loaded
  machine it shows what the loop does when it has a core to itself.

The droplets run one after another (the seed's order, one thread: ``threads`` 1). ``batch = N``
(Python API only) times the opt-in batch-synchronous mode instead (``hydrology.batch = N``:
first descents of N droplets at a time on Numba's threads, see :mod:`erosim.hydrology.batch`);
``threads`` then reports Numba's thread count.
"""

from __future__ import annotations

import os
import time
import warnings


def run(size: int = 256, droplets: int | None = None, spinup: int | None = None, seed: int = 1, batch: int = 0) -> dict:
    """Benchmark one map size; returns the JSON-able result."""
    import numba
    from numba import NumbaWarning

    from erosim.hydrology.pools import B_FLOOD_NS, B_STEPS
    from erosim.scenarios import loader
    from erosim.scenarios.builders_hydrology import build_model

    size = int(size)
    cell = 10240.0 / size
    sc = loader.load(
        "hydrology",
        [f"terrain.size={size}", f"terrain.cell_size={cell}", f"seed={seed}"]
        + ([f"hydrology.batch={int(batch)}"] if batch else []),
        preset="simplehydrology-2020",
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NumbaWarning)  # the timed build cannot be cached
        _terrain, model = build_model(sc.config, timing=True)
        n_cells = size * size
        spin = 2 * n_cells if spinup is None else int(spinup)
        want = 4 * n_cells if droplets is None else int(droplets)
        while model.droplets < spin:
            model.cycle()
        d0, s0, f0 = model.droplets, model.budget[B_STEPS], model.budget[B_FLOOD_NS]
        t0, c0 = time.perf_counter(), time.process_time()
        while model.droplets - d0 < want:
            model.cycle()
        wall = time.perf_counter() - t0
        cpu = time.process_time() - c0
    done = model.droplets - d0
    steps = float(model.budget[B_STEPS] - s0)
    flood_s = float(model.budget[B_FLOOD_NS] - f0) * 1e-9
    return {
        "benchmark": "hydrology",
        "preset": "simplehydrology-2020",
        "size": size,
        "cell_size_m": cell,
        "droplets": int(done),
        "spinup_droplets": int(d0),
        "wall_s": round(wall, 3),
        "droplets_per_s": round(done / wall, 1),
        "droplets_per_cpu_s": round(done / cpu, 1) if cpu > 0 else None,
        "steps_per_s": round(steps / wall, 1),
        "steps_per_droplet": round(steps / done, 1),
        "flood_fraction": round(flood_s / wall, 4),
        "lake_fraction": round(model.stats()["lake_fraction"], 4),
        "mode": f"batch {int(batch)}" if batch else "serial",
        "threads": numba.get_num_threads() if batch else 1,
        "cpu_count": os.cpu_count(),
    }
