"""Droplet hydrology on the CUDA device path (erosim.hydrology.droplets_cuda), under Numba's CUDA
simulator, against the CPU's parallel batches.

As for the SPH device tests, the simulator runs in a subprocess and one script does every comparison,
on a 16×16 bowl with noise (20 m cells, ℓ = 40 m: 2×2 footprints and sub-steps):

* one droplet per batch: no two droplets are ever in flight together, so the device (live terrain,
  atomic adds) and the CPU (round-start terrain plus the droplet's own overlay) solve the same
  sequence; they differ only in the order of float additions (the CPU reads z + Σ own changes, the
  device (z − dz₁) − dz₂ …), so heights agree to rounding (as amplified by the model itself: measured
  by the CPU on heights changed by a few ulps) and the lakes exactly;
* 32 droplets per batch: on the device they see each other's erosion as it happens, on the CPU not,
  so the two agree only statistically: the volume eroded within twice the CPU path's own
  seed-to-seed scatter (sample standard deviation over 6 seeds);
* on both, the water and sediment budgets close (the project's 1e-9 bar), and ``bench hydrology``
  runs on the device and reports its keys.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[3] / "src"
needs_simulator = pytest.mark.skipif(
    __import__("importlib.util").util.find_spec("numba.cuda") is None,
    reason="numba.cuda (the CUDA simulator) is not installed",
)

SCRIPT = r"""
import json
import numpy as np
from erosim.core.heightmap import Heightmap
from erosim.hydrology.droplets_cuda import DeviceDroplets
from erosim.hydrology.model import HydrologyModel
from erosim.hydrology.params import HydrologyParams, VegetationParams

n = 16
yy, xx = np.mgrid[0:n, 0:n]
z = 30.0 * np.hypot(xx - n / 2, yy - n / 2) / n + np.random.default_rng(1).random((n, n)) * 3.0

def run(device, batch, seed=3, cycle_droplets=20000, cycles=3, z=z):
    p = HydrologyParams(length_scale=40.0, cycle_droplets=cycle_droplets, batch=batch)
    gpu = DeviceDroplets if device == "cuda" else None
    m = HydrologyModel(Heightmap(z=z, cell_size=20.0), p, VegetationParams(spawn=5.0), seed, gpu=gpu)
    m.run(cycles)
    return m

def budgets(m):
    w, s = m.water_budget(), m.sediment_budget()
    return {"water": w["closure_rel"], "sediment": s["closure_rel"], "terrain": s["terrain_change_rel_error"],
            "lakes_tracked": abs(w["in_lakes"] - w["in_lakes_tracked"]) / w["rained"], "eroded": s["eroded"],
            "in_lakes": w["in_lakes"], "droplets": m.droplets}

out = {}
cpu, dev = run("cpu", 1), run("cuda", 1)
# the model's own sensitivity to rounding: the CPU again on heights changed by a few ulps (1e-15 relative)
nudged = run("cpu", 1, z=z * (1.0 + 1e-15 * np.random.default_rng(7).standard_normal(z.shape)))
out["one"] = {
    "dz_rel": float(np.abs(cpu.z - dev.z).max() / np.abs(cpu.z - cpu.z0).max()),
    "nudged_rel": float(np.abs((cpu.z - cpu.z0) - (nudged.z - nudged.z0)).max() / np.abs(cpu.z - cpu.z0).max()),
    "lakes_equal": bool(np.array_equal(cpu.lake_of, dev.lake_of)),
    "steps": [cpu.stats()["descend_steps"], dev.stats()["descend_steps"]],
    "cpu": budgets(cpu), "dev": budgets(dev),
}
kw = dict(batch=32, cycle_droplets=100000)
dev = run("cuda", **kw)
cpu = [run("cpu", seed=s, **kw) for s in (3, 4, 5, 6, 7, 8)]
eroded = [m.sediment_budget()["eroded"] for m in cpu]
out["batch"] = {"dev": budgets(dev), "cpu": budgets(cpu[0]), "scatter": float(np.std(eroded, ddof=1)),
                "per_cycle": dev.per_cycle}
from erosim.bench.hydrology import run as bench
out["bench"] = bench(size=16, droplets=4, spinup=4, device="cuda")
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def simulated():
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)}
    proc = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


# Relative to the largest height change: the two paths add the same per-cell changes in a different
# order (float64, ~1e-16 of a ~30 m height per addition, a few hundred additions). A droplet that
# crosses a near-flat pit floor turns such differences into larger ones (its transfer follows the
# small drop h0 − h1): the CPU itself, on heights changed by a few ulps, ends up to ~2e-8 of the
# largest change apart. The device may differ by as much as that measured sensitivity, or by 1e-12
# where it is smaller; both are far below any difference in the model (a changed step moves
# centimetres, ~1e-2 of the largest change here).
ROUNDING = 1e-12
MODEL_CHANGE = 1e-4  # a tenth of a millimetre in the ~0.4 m largest change: any changed step is more
CLOSURE = 1e-9  # the project's bar for float64 budget sums (tests/unit/hydrology/test_hydrology_batch.py)


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_device_droplets_one_at_a_time_are_the_cpus_to_rounding(simulated):
    one = simulated["one"]
    assert one["cpu"]["eroded"] > 0 and one["cpu"]["in_lakes"] > 0  # erosion and lakes: not a trivial case
    assert one["steps"][0] == one["steps"][1]
    assert one["nudged_rel"] < MODEL_CHANGE  # the sensitivity is rounding's, not a changed step's
    assert one["dz_rel"] <= max(ROUNDING, one["nudged_rel"])
    assert one["lakes_equal"]


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_device_batches_close_the_budgets_and_erode_as_the_cpu_within_its_scatter(simulated):
    b = simulated["batch"]
    assert b["per_cycle"] > 32  # more than one batch a cycle: droplets of a batch are in flight together
    for side in ("dev", "cpu"):
        for key in ("water", "sediment", "terrain", "lakes_tracked"):
            assert b[side][key] < CLOSURE, (side, key)
    assert b["dev"]["droplets"] == b["cpu"]["droplets"]
    assert abs(b["dev"]["eroded"] - b["cpu"]["eroded"]) <= 2.0 * b["scatter"]


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_bench_hydrology_runs_on_the_device(simulated):
    r = simulated["bench"]
    assert r["device"] == "cuda" and r["threads"] == 1 and r["batch"] >= 1
    assert r["droplets"] >= 4 and r["droplets_per_s"] > 0 and "simulator" in r["gpu"]


def test_hydrology_device_refused_in_one_sentence_without_a_gpu(cli_runner, tmp_path):
    """--device cuda where no GPU is usable: one sentence, exit 2, no run folder, never the CPU instead."""
    from erosim.cli import cli
    from erosim.core.devices import cuda_status

    if cuda_status()[0]:
        pytest.skip("a CUDA device (or the simulator) is usable here")
    out = tmp_path / "run"
    for args in (
        ["run", "hydrology", "--device", "cuda", "--out", str(out)],
        ["run", "hydrology", "--set", "run.device=cuda", "--out", str(out)],
        ["bench", "hydrology", "--device", "cuda", "--json"],
    ):
        res = cli_runner.invoke(cli, ["--quiet", *args])
        assert res.exit_code == 2, args
        assert "Device 'cuda' is not usable" in res.output and res.output.count("\n") == 1, args
        assert not out.exists()
