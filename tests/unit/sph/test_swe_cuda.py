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
p = ShallowWaterParams(split=False)  # splitting stays on the CPU (the device refuses it)
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


@pytest.fixture(scope="module")
def simulated():
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)}
    proc = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


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


def test_splitting_is_refused_on_the_device_in_one_sentence(monkeypatch):
    import numpy as np

    from erosim.core import devices
    from erosim.core.errors import ConfigError
    from erosim.sph.shallow_water_cuda import CudaShallowWaterSPH
    from erosim.sph.shallow_water_vacondio2012 import ShallowWaterParams

    monkeypatch.setattr(devices, "require", lambda device: None)  # as if a GPU were there
    pos = np.column_stack([np.arange(2.0, 6.0, 0.5), np.full(8, 3.0)])
    with pytest.raises(ConfigError, match="flood.split"):
        CudaShallowWaterSPH(np.zeros((8, 8)), 1.0, pos, np.full(8, 0.25), 0.5, ShallowWaterParams(split=True))


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
