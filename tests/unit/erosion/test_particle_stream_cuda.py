"""Particle-stream erosion on the CUDA device path (erosim.erosion.particle_stream_cuda), under Numba's
CUDA simulator, against the CPU stream.

The simulator runs in a subprocess (as for the other device tests) on a 32² ``hills`` map with the
benchmark's strata hardness and eight emitters, discs of two cells per unit mass:

* one slot per emitter: the device's slots of a sweep act at once, the CPU's one after another; the
  particles, draws and cuts are the same and only the order in which overlapping cuts add differs,
  so heights agree to rounding and the strata hardness exactly;
* four slots per emitter: slots of one emitter cut the same ground at once, so the two agree only
  statistically — the removed volume within twice the CPU stream's own seed-to-seed scatter (sample
  standard deviation over 6 seeds); the removed total equals the terrain's loss to rounding;
* ``bench stream`` runs on the device and reports its keys (on a 32² map with two slots per emitter:
  its 512² map is beyond the simulator's speed).
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
from erosim.bench.stream import _emitters, STRATA, CELL
from erosim.erosion.particle_stream_cuda import DeviceStream
from erosim.erosion.particle_stream_warszawski import ParticleStream
from erosim.terrain import hardness
from erosim.terrain.generate import generate

hm = generate("hills", 32, CELL, 0, relief=40.0)
d0 = hardness.strata(hm.z, CELL, STRATA)
ems = [e.model_copy(update={"radius_per_mass": 2 * CELL}) for e in _emitters(32, 6)]

def run(device, pool, seed=3):
    gpu = DeviceStream if device == "cuda" else None
    return ParticleStream(hm.z, d0, CELL, ems, seed, STRATA, pool=pool, gpu=gpu).run(batch=50)

out = {}
cpu, dev = run("cpu", 1), run("cuda", 1)
out["one"] = {"dh_rel": float(np.abs(cpu.h - dev.h).max() / np.abs(cpu.h - hm.z).max()),
              "d_equal": bool(np.array_equal(cpu.d, dev.d)), "impacts": [cpu.impacts, dev.impacts],
              "done": [cpu.done, dev.done]}
dev = run("cuda", 4)
cpu = [run("cpu", 4, seed=s) for s in (3, 4, 5, 6, 7, 8)]
loss = float((hm.z - dev.h).sum())
out["pool"] = {"dev": dev.removed, "cpu": cpu[0].removed, "scatter": float(np.std([c.removed for c in cpu], ddof=1)),
               "closure": abs(dev.removed - loss) / loss, "impacts": [cpu[0].impacts, dev.impacts]}
import erosim.bench.stream as B
B.SIZE, B.POOL, B.MIN_TIME = 32, 2, 0.0
out["bench"] = B.run([16], 2, device="cuda")
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def simulated():
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)}
    # the counter-based random numbers wrap uint64 on purpose: NumPy warns about it in Python
    cmd = [sys.executable, "-W", "ignore::RuntimeWarning", "-c", SCRIPT]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


# Relative to the deepest cut: the same float64 cuts added in another order where discs overlap
# (~1e-16 of a ~40 m height per addition, a few hundred additions a cell).
ROUNDING = 1e-12


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_device_stream_with_one_slot_per_emitter_is_the_cpus_to_rounding(simulated):
    one = simulated["one"]
    assert one["impacts"][0] == one["impacts"][1] > 100
    assert one["done"] == [True, True]
    assert one["dh_rel"] <= ROUNDING
    assert one["d_equal"]


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_device_stream_pools_remove_as_the_cpu_within_its_scatter_and_count_it(simulated):
    p = simulated["pool"]
    assert p["dev"] > 0 and p["scatter"] > 0
    assert abs(p["dev"] - p["cpu"]) <= 2.0 * p["scatter"]
    assert p["closure"] <= ROUNDING  # the removed total is the terrain's loss
    # the same particles act; a particle leaves the map earlier or later only by the terrain it met
    assert abs(p["impacts"][0] - p["impacts"][1]) <= 0.05 * p["impacts"][0]


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_bench_stream_runs_on_the_device(simulated):
    r = simulated["bench"]
    assert r["device"] == "cuda" and r["threads"] == 1 and "simulator" in r["gpu"]
    assert r["updates_per_s"] > 0 and r["runs"][0]["particles"] == 16


def test_stream_bench_device_refused_in_one_sentence_without_a_gpu(cli_runner):
    from erosim.cli import cli
    from erosim.core.devices import cuda_status

    if cuda_status()[0]:
        pytest.skip("a CUDA device (or the simulator) is usable here")
    res = cli_runner.invoke(cli, ["bench", "stream", "--device", "cuda", "--json"])
    assert res.exit_code == 2
    assert "Device 'cuda' is not usable" in res.output and res.output.count("\n") == 1
