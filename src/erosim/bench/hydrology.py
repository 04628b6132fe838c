"""``erosim bench hydrology``: droplets per second of the hydrology model, lakes on.

``preset = "simplehydrology-2020"`` (default): the library scenario ``hydrology`` with the seed's
constants (ℓ = one cell) on a generated mountain terrain of ``size``² cells and the extent of the
seed's world at 256² (10.24 km); its droplets run one after another (the seed's order, one
thread) unless ``batch`` is given. The model first spins up for ``spinup`` droplets (2 per cell,
untimed: Numba compilation, and the first lakes and streams form — the reference C++ was also
timed on running simulations), then runs whole cycles until ``droplets`` more have fallen
(default: 4 per cell).

``preset = "library"``: the library scenario itself (``erosim run hydrology --set
terrain.size=N``: 20 m cells, ℓ = two cells, parallel batches of an eighth of a cycle's droplets,
:mod:`erosim.hydrology.batch`); spin-up 16 cycles, then 32 timed cycles by default.

Reported:

* ``droplets_per_s`` — droplets of the timed cycles / wall time (stream, creep and vegetation
  updates and the lake rebuilds included);
* ``steps_per_s`` — descend sub-steps per second;
* ``flood_fraction`` — share of that wall time spent in HY-2 flood (lake filling / draining),
  measured with a monotonic clock around each flood call (a separate Numba build of the serial
  loop; ``None`` in batch mode, whose floods are not timed);
* ``droplets_per_cpu_s`` — the same per second of this process's CPU time: on a shared, loaded
  machine it shows what the loop does when it has a core to itself (summed over threads);
* ``device`` (``cpu`` or ``cuda``), ``threads`` (Numba's thread count in batch mode, 1 for the
  serial order; on ``cuda`` the host's, which runs the lake, stream, creep and vegetation passes),
  ``batch`` (droplets per parallel batch, 0 = serial; on ``cuda`` the GPU threads of a launch),
  and on ``cuda`` ``gpu`` (the device in words).

``device = "cuda"`` (:mod:`erosim.hydrology.droplets_cuda`): the batches descend on the GPU; the
seed preset's serial order cannot, so there its batches are an eighth of a cycle unless ``batch``
is given.
"""

from __future__ import annotations

import os
import time
import warnings

from erosim.bench import threading_layer
from erosim.core import devices
from erosim.hydrology.pools import B_FLOOD_NS, B_STEPS
from erosim.scenarios import loader
from erosim.scenarios.hydrology.build import build_model


def run(
    size: int = 256,
    droplets: int | None = None,
    spinup: int | None = None,
    seed: int = 1,
    batch: int | None = None,
    preset: str = "simplehydrology-2020",
    device: str = "cpu",
) -> dict:
    """Benchmark one map size; returns the JSON-able result."""
    import numba
    from numba import NumbaWarning


    size = int(size)
    seed_case = preset != "library"
    over = [f"terrain.size={size}", f"seed={seed}"] + ([] if batch is None else [f"hydrology.batch={int(batch)}"])
    if seed_case:
        over.append(f"terrain.cell_size={10240.0 / size}")
    sc = loader.load("hydrology", over, preset="simplehydrology-2020" if seed_case else None)
    cfg = sc.config
    if device == "cuda":
        hy = cfg.hydrology.model_copy(update={"batch": None}) if batch is None else cfg.hydrology
        cfg = cfg.model_copy(update={"hydrology": hy, "run": cfg.run.model_copy(update={"device": "cuda"})})
    cell = float(cfg.terrain.cell_size)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NumbaWarning)  # the timed build cannot be cached
        _terrain, model = build_model(cfg, timing=True)
        n_cells = size * size
        if seed_case:
            spin = 2 * n_cells if spinup is None else int(spinup)
            want = 4 * n_cells if droplets is None else int(droplets)
        else:
            spin = 16 * model.per_cycle if spinup is None else int(spinup)
            want = 32 * model.per_cycle if droplets is None else int(droplets)
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
    nb = int(model.batch)
    return {
        "benchmark": "hydrology",
        "preset": "simplehydrology-2020" if seed_case else "library",
        "size": size,
        "cell_size_m": cell,
        "droplets": int(done),
        "spinup_droplets": int(d0),
        "wall_s": round(wall, 3),
        "droplets_per_s": round(done / wall, 1),
        "droplets_per_cpu_s": round(done / cpu, 1) if cpu > 0 else None,
        "steps_per_s": round(steps / wall, 1),
        "steps_per_droplet": round(steps / done, 1),
        "flood_fraction": None if nb else round(flood_s / wall, 4),
        "lake_fraction": round(model.stats()["lake_fraction"], 4),
        "mode": f"batch {nb}" if nb else "serial",
        "batch": nb,
        "device": device,
        "threads": numba.get_num_threads() if nb and device == "cpu" else 1,
        "threading_layer": threading_layer(),
        "cpu_count": os.cpu_count(),
        **({"gpu": devices.cuda_status()[1]} if device == "cuda" else {}),
    }
