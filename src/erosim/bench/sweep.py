"""Benchmark of ``erosim sweep`` on Dask (``erosim bench sweep``): speed-up and the scheduler's overhead.

The same sweep — ``members`` hydrology runs of one generated 256² terrain (20 m cells) that differ by
seed, each on one Numba thread — runs twice: on one local worker (serially) and on ``workers``
workers. Both go through the whole machinery (cluster start, tasks, aggregation into sweep.nc), so
``speedup`` = serial wall time / parallel wall time is what a user gains. The overhead per member is
(parallel wall time − the members' own wall time / workers) / members: cluster start, task dispatch,
worker imports and the aggregation, shared out. A warm-up run fills Numba's on-disk cache first, so
no worker compiles. ``identical_maps`` checks that the two sweeps' aggregated maps agree bit for bit.
"""

from __future__ import annotations

import csv
import tempfile
import time
from pathlib import Path

import numpy as np

from erosim.api import run as run_scenario
from erosim.sweep.runner import run_sweep

SIZE = 256
CELL = 20.0


def _settings(cycles: int) -> list[str]:
    return [f"terrain.size={SIZE}", f"terrain.cell_size={CELL}", f"run.cycles={cycles}", "run.frames=0"]


def _maps(folder: Path) -> dict[str, np.ndarray]:
    import xarray as xr

    with xr.open_dataset(folder / "sweep.nc") as ds:
        return {k: ds[k].values for k in ds.data_vars}


def _member_seconds(folder: Path) -> list[float]:
    with open(folder / "sweep.csv", newline="", encoding="utf-8") as f:
        return [float(row["wall_s"]) for row in csv.DictReader(f)]


def run(members: int = 8, workers: int = 2, cycles: int = 200) -> dict:
    with tempfile.TemporaryDirectory(prefix="erosim-bench-sweep-") as tmp:
        root = Path(tmp)
        sets = {k: v for k, v in (s.split("=") for s in _settings(2))}
        run_scenario("hydrology", root / "warm-up", set=sets)  # Numba's cache, shared with the workers
        common = dict(seeds=members, threads=1, progress=False)
        t0 = time.perf_counter()
        run_sweep("hydrology", _settings(cycles), None, [], workers=1, out=str(root / "serial"), **common)
        serial = time.perf_counter() - t0
        t0 = time.perf_counter()
        run_sweep("hydrology", _settings(cycles), None, [], workers=workers, out=str(root / "parallel"), **common)
        parallel = time.perf_counter() - t0
        member_s, member_serial_s = _member_seconds(root / "parallel"), _member_seconds(root / "serial")
        a, b = _maps(root / "serial"), _maps(root / "parallel")
        identical = a.keys() == b.keys() and all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)
    return {
        "benchmark": "sweep",
        "scenario": f"hydrology {SIZE}² × {cycles} cycles, members differ by seed",
        "members": members,
        "workers": workers,
        "threads_per_member": 1,
        "member_s_mean_serial": round(float(np.mean(member_serial_s)), 2),
        "member_s_mean_parallel": round(float(np.mean(member_s)), 2),
        "serial_s": round(serial, 2),
        "parallel_s": round(parallel, 2),
        "speedup": round(serial / parallel, 2),
        "overhead_per_member_s": round((parallel - sum(member_s) / workers) / members, 3),
        "identical_maps": bool(identical),
    }
