"""The shallow-water SPH step on the CUDA device path, under Numba's CUDA simulator, against the CPU.

As for the 3-D step (tests/unit/sph/test_sph_cuda.py), the simulator runs in a subprocess and one script
does every comparison. The case: a sheet of water thrown east at 1.5 m/s over a sloping, wavy bed
with a block of wall cells and Manning friction, out through the open east edge — so every device
kernel runs: the lists are rebuilt, particles leave (removed on the host, their water counted), the
hazard maxima are raised on the device. Under the simulator the device kernels evaluate the CPU's
own per-particle functions in Python, without the fused multiply-adds a GPU would contract, so the
two paths agree exactly; on a GPU they agree to rounding (benchmarks/gpu_session.py checks that).
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
from erosim.analysis.hazard import HazardMaps
from erosim.sph.shallow_water_vacondio2012 import ShallowWaterParams, ShallowWaterSPH, lattice_volume
from erosim.sph.shallow_water_cuda import CudaShallowWaterSPH

ny, nx = 12, 16
yy, xx = np.mgrid[0:ny, 0:nx]
bed = 0.02 * (nx - xx) + 0.01 * np.sin(yy)
wall = np.zeros((ny, nx), bool)
wall[5:7, 4] = True
x, y = (a.ravel() for a in np.meshgrid(np.arange(11.0, 15.0, 0.5), np.arange(1.0, 10.5, 0.5)))
p = ShallowWaterParams(split=False)  # the split's own comparison: test_device_splits_as_the_cpu_does
args = (bed, 1.0, np.column_stack([x, y]), lattice_volume(np.full(x.size, 0.6), 0.5, p.support), 0.5, p)
kw = dict(vel=np.tile([1.5, 0.2], (x.size, 1)), manning=0.03, wall=wall, open_edges=("east",), surface=1.5)
cpu, dev = ShallowWaterSPH(*args, **kw), CudaShallowWaterSPH(*args, **kw)
maps = [HazardMaps(bed.shape, 0.01), HazardMaps(bed.shape, 0.01)]
out = {"n0": cpu.n}
for k in range(14):
    cpu.step()
    dev.step()
    cpu.update_maxima(maps[0], 0.01)
    dev.update_maxima(maps[1], 0.01)
    if k == 6:
        ck_dev = dev.state_dict()
        ck_cpu = cpu.state_dict()
dev.sync_maxima(maps[1])
out["n"] = [cpu.n, dev.n]
out["rebuilds"] = [cpu.rebuilds, dev.rebuilds]
out["t"] = [cpu.t, dev.t]
out["pairs"] = [cpu.neighbour_pairs, dev.neighbour_pairs]
out["volume_out"] = [cpu.budget()["volume_out_m3"], dev.budget()["volume_out_m3"]]
out["closure"] = dev.budget()["closure_rel"]
out["moved"] = float(np.abs(cpu.pos[:, 0] - 13.0).max())
def rel(a, b):
    a, b = np.nan_to_num(a, posinf=0.0), np.nan_to_num(b, posinf=0.0)
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(a)), 1e-300))
out["fields"] = {k: rel(getattr(cpu, k), getattr(dev, k)) for k in ("pos", "vel", "depth", "hsup", "acc")}
out["maxima"] = {k: rel(getattr(maps[0], k), getattr(maps[1], k)) for k in ("max_depth", "max_speed", "arrival")}
out["wetted_cells"] = int((maps[1].max_depth > 0).sum())
# checkpoints across devices: the device's resumed on the CPU, the CPU's on the device, and the device's
# own resumed on the device (bit for bit)
runs = {"cpu_from_device": (ShallowWaterSPH, ck_dev), "device_from_cpu": (CudaShallowWaterSPH, ck_cpu),
        "device_from_device": (CudaShallowWaterSPH, ck_dev)}
for name, (cls, ck) in runs.items():
    m = cls(*args, **kw)
    m.load_state_dict(ck)
    for _ in range(7):
        m.step()
    ref = cpu if cls is ShallowWaterSPH else dev
    out[name] = max(rel(ref.pos, m.pos), rel(ref.vel, m.vel))
    if name == "device_from_device":
        out["device_resume_bitwise"] = bool(np.array_equal(dev.pos, m.pos) and np.array_equal(dev.vel, m.vel))
print(json.dumps(out))
"""


def _simulate(script: str) -> dict:
    """Run ``script`` under Numba's CUDA simulator in a fresh interpreter; its last line of JSON."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)}
    proc = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def simulated():
    return _simulate(SCRIPT)


TOL = 1e-11  # relative to each field's largest value, the 3-D device test's bound (its docstring)


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_device_flood_steps_agree_with_the_cpu(simulated):
    assert simulated["t"][0] == pytest.approx(simulated["t"][1], rel=TOL)
    assert simulated["moved"] > 0.5  # the water moved a metre or so: not a comparison at rest
    assert simulated["rebuilds"][0] == simulated["rebuilds"][1] >= 3
    assert simulated["pairs"][0] == simulated["pairs"][1]
    for field, diff in simulated["fields"].items():
        assert diff <= TOL, field


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_device_flood_removes_leaving_water_and_keeps_the_budget(simulated):
    assert simulated["n"][0] == simulated["n"][1] < simulated["n0"]  # water left by the east edge
    assert simulated["volume_out"][1] == pytest.approx(simulated["volume_out"][0], rel=TOL)
    assert abs(simulated["closure"]) < 1e-12


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_device_hazard_maxima_are_the_cpus(simulated):
    assert simulated["wetted_cells"] > 20
    for name, diff in simulated["maxima"].items():
        assert diff <= TOL, name


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_device_flood_checkpoints_resume_on_either_device(simulated):
    for name in ("cpu_from_device", "device_from_cpu", "device_from_device"):
        assert simulated[name] <= TOL, name
    assert simulated["device_resume_bitwise"]


SPLIT_SCRIPT = r"""
import json
import numpy as np
from erosim.sph.shallow_water_vacondio2012 import ShallowWaterParams, ShallowWaterSPH, lattice_volume
from erosim.sph.shallow_water_cuda import CudaShallowWaterSPH

# a dam break 0.4 m deep on a flat channel 6 m wide, open to the east: its tip thins past 1.5 × the
# spacing within a dozen steps and splits (the defaults: gradual, one generation, below 1 m)
ny, nx = 6, 24
bed = np.zeros((ny, nx))
x, y = (a.ravel() for a in np.meshgrid(np.arange(1.0, 5.0, 0.25), np.arange(1.0, 4.1, 0.25)))
p = ShallowWaterParams()
args = (bed, 1.0, np.column_stack([x, y]), lattice_volume(np.full(x.size, 0.4), 0.25, p.support), 0.25, p)
kw = dict(manning=0.02, open_edges=("east",), surface=1.0)
cpu, dev = ShallowWaterSPH(*args, **kw), CudaShallowWaterSPH(*args, **kw)
out = {"n0": cpu.n, "volume0": float(cpu.vol.sum())}
for k in range(18):
    cpu.step()
    dev.step()
out["n"] = [cpu.n, dev.n]
out["splits"] = [cpu.splits, dev.splits]
out["volume"] = [float(cpu.vol.sum()), float(dev.vol.sum())]
out["relaxing"] = [int((cpu.k2 != p.support**2).sum()), int((dev.k2 != p.support**2).sum())]
out["t"] = [cpu.t, dev.t]
def rel(a, b):
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(a)), 1e-300))
out["fields"] = {k: rel(getattr(cpu, k), getattr(dev, k)) for k in ("pos", "vel", "depth", "hsup", "k2", "vol")}
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def simulated_split():
    return _simulate(SPLIT_SCRIPT)


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_device_splits_as_the_cpu_does(simulated_split):
    """A dam break's thinning tip splits on the device path (the count on the device, the split on the
    host's copies) exactly where the CPU splits it: the same particles, the same volume to round-off,
    and the fields within the device tests' bound (the simulator runs the CPU's per-particle functions;
    on a GPU the fused multiply-adds leave rounding differences that a split's threshold may amplify)."""
    s = simulated_split
    assert s["splits"][0] == s["splits"][1] >= 3  # the tip did split, on both
    assert s["n"][0] == s["n"][1] == s["n0"] + 6 * s["splits"][0]
    assert s["relaxing"][0] == s["relaxing"][1] >= 7 * s["splits"][0] - 7  # the daughters' H still relaxing
    # mass: the split and the removal keep the water to round-off of a sum of a few hundred terms
    for v in s["volume"]:
        assert v == pytest.approx(s["volume0"], rel=1e-13)
    assert s["t"][0] == pytest.approx(s["t"][1], rel=TOL)
    for field, diff in s["fields"].items():
        assert diff <= TOL, field


def test_flood_device_setting_refused_without_cuda_and_for_the_3d_solver(cli_runner, tmp_path):
    """`[run] device = "cuda"` in a flood scenario: one sentence and no run folder where no GPU is
    usable, and one naming the 3-D solver, which stays on the CPU."""
    from erosim.cli import cli
    from erosim.core.devices import cuda_status

    out = tmp_path / "run"
    if not cuda_status()[0]:
        res = cli_runner.invoke(cli, ["--quiet", "run", "flood", "--set", "run.device=cuda", "--out", str(out)])
        assert res.exit_code == 2
        assert "Device 'cuda' is not usable" in res.output
        assert not out.exists()
    args = ["--quiet", "run", "flood", "--set", "run.device=cuda", "--set", "flood.solver=sph3d", "--out", str(out)]
    res = cli_runner.invoke(cli, args)
    assert res.exit_code != 0
    assert "flood.solver = 'sph3d' runs on device 'cpu' only" in res.output
    assert not out.exists()
