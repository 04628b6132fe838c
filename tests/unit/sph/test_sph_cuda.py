"""The SPH step on the CUDA device path, checked under Numba's CUDA simulator against the CPU solver.

The simulator runs the device kernels as Python threads, so it is switched on in a subprocess
(``NUMBA_ENABLE_CUDASIM=1``): the CPU tests of this process keep their compiled Numba. One
subprocess runs every comparison (its start-up and the simulator's slowness dominate) and prints
one JSON line; the tests below assert on it.

Tolerance: the device path calls the CPU's own per-particle functions over the same neighbour
lists in the same order, so the two differ only where one contracts a·b + c into a fused
multiply-add and the other does not (the CPU kernels are compiled with ``contract``; the simulator
evaluates in Python, without). Each such step changes a result by at most half an ulp (1.1e-16
relative); over a few hundred operations per particle and three steps that stays below 1e-13 of a
field's scale. We allow 1e-11 of the field's largest value: 100× that bound, and 10⁶× below any
physical difference (one Δt changes a position by |v|Δt/L ≈ 1e-4 of the tank).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[3] / "src"


def _numba_cuda_missing() -> bool:
    """numba.cuda (built into Numba up to now, else the numba-cuda package) holds the simulator."""
    import importlib.util

    return importlib.util.find_spec("numba.cuda") is None


needs_simulator = pytest.mark.skipif(_numba_cuda_missing(), reason="numba.cuda (the CUDA simulator) is not installed")

SCRIPT = r"""
import json
import numpy as np
from erosim.bench.sph import dam_break_geometry
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver
from erosim.sph.solver_cuda import CudaSPHSolver

# 2-D dam break with boundary-particle walls, ~50 fluid particles; skin 0 rebuilds the lists (and
# re-sorts the fluid by cell) every step, so every kernel of the device path runs each step
fluid, lo, hi = dam_break_geometry(50, 2, 0.01)
prm = SPHParams(dim=2, spacing=0.01, skin=0.0)
kw = dict(domain_lo=lo, domain_hi=hi)
cpu = SPHSolver(prm, fluid, **kw)
dev = CudaSPHSolver(prm, fluid, **kw)
out = {"n_fluid": cpu.n_fluid, "n_boundary": cpu.n_boundary}
s, m, nbr = dev.device_lists()
out["lists_equal_at_start"] = bool(
    np.array_equal(s, cpu.start) and np.array_equal(m, cpu.mid) and np.array_equal(nbr, cpu.nbr[: s[-1]])
)

FIELDS = ("positions", "velocities", "density", "pressure", "accelerations")


def rel_diff(a, b):
    res = {f: float(np.max(np.abs(getattr(a, "fluid_" + f)() - getattr(b, "fluid_" + f)()))
                    / max(float(np.max(np.abs(getattr(a, "fluid_" + f)()))), 1e-300)) for f in FIELDS}
    res["boundary_pressure"] = float(np.max(np.abs(a.boundary_pressure() - b.boundary_pressure()))
                                     / max(float(np.max(np.abs(a.boundary_pressure()))), 1e-300))
    return res


out["bound"] = []  # per step: Δt, and the density diffusion's bound 0.5/max K_i it was chosen under
for _ in range(2):
    lims = [s_._diffusion_limit() for s_ in (cpu, dev)]
    out["bound"].append([cpu.step(), dev.step()] + lims)
out["kmax"] = [cpu.kmax, dev.kmax]
out["steps"] = [cpu.steps, dev.steps]
out["rebuilds"] = [cpu.rebuilds, dev.rebuilds]
out["dt"] = [cpu.last_dt, dev.last_dt]
out["ids_equal"] = bool(np.array_equal(cpu.state.ids, (dev._sync(), dev.state.ids)[1]))
out["moved"] = float(np.max(np.abs(cpu.fluid_positions() - fluid)))
s, m, nbr = dev.device_lists()
out["lists_equal_after_steps"] = bool(
    np.array_equal(s, cpu.start) and np.array_equal(m, cpu.mid) and np.array_equal(nbr, cpu.nbr[: s[-1]])
)
out["after_steps"] = rel_diff(cpu, dev)

# checkpoints across devices: the CPU's state resumes on the device and the device's on the CPU
ck_cpu, ck_dev = cpu.state_dict(), dev.state_dict()
dev_from_cpu = CudaSPHSolver(prm, fluid, **kw)
dev_from_cpu.load_state_dict(ck_cpu)
cpu_from_dev = SPHSolver(prm, fluid, **kw)
cpu_from_dev.load_state_dict(ck_dev)
for s_ in (cpu, dev, dev_from_cpu, cpu_from_dev):
    s_.step()
out["resumed_steps"] = [dev_from_cpu.steps, cpu_from_dev.steps]
out["checkpoint_kmax"] = [float(ck_cpu["kmax"]), float(ck_dev["kmax"])]
out["cpu_checkpoint_on_device"] = rel_diff(cpu, dev_from_cpu)
out["device_checkpoint_on_cpu"] = rel_diff(dev, cpu_from_dev)
# the device resumed from its own checkpoint: the step is bit for bit the uninterrupted one
dev_again = CudaSPHSolver(prm, fluid, **kw)
dev_again.load_state_dict(ck_dev)
dev_again.step()
out["device_resume_bitwise"] = all(
    np.array_equal(getattr(dev, "fluid_" + f)(), getattr(dev_again, "fluid_" + f)()) for f in FIELDS
)
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def simulated():
    if _numba_cuda_missing():
        pytest.skip("numba.cuda (the CUDA simulator) is not installed")
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)}
    proc = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


TOL = 1e-11  # relative to each field's largest value; see the module docstring


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
def test_device_lists_are_the_cpu_lists(simulated):
    assert simulated["lists_equal_at_start"]
    assert simulated["lists_equal_after_steps"]
    assert simulated["rebuilds"][0] == simulated["rebuilds"][1] >= 3  # a rebuild with re-sorting each step
    assert simulated["ids_equal"]  # the fluid re-sorted into the same order


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
def test_device_steps_agree_with_cpu_to_rounding(simulated):
    assert simulated["steps"] == [2, 2]
    assert simulated["dt"][0] == pytest.approx(simulated["dt"][1], rel=TOL)
    assert simulated["moved"] > 0  # the fluid moved: the comparison is not of a state at rest
    for field, diff in simulated["after_steps"].items():
        assert diff <= TOL, field


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
def test_diffusion_bound_agrees_where_it_does_not_bind(simulated):
    """The dam break's particles sit near Δx apart: the density diffusion's bound 0.5/max K_i is far
    above the CFL step (K_iΔt ≈ 0.06 at CFL 0.2, diffusion_limit_molteni2009), and both devices compute
    the same K_i (tolerance TOL: the same sum over the same lists, module docstring)."""
    for dt_cpu, dt_dev, lim_cpu, lim_dev in simulated["bound"]:
        assert math.isfinite(lim_dev) and lim_dev == pytest.approx(lim_cpu, rel=TOL)
        assert dt_cpu < 0.5 * lim_cpu and dt_dev < 0.5 * lim_dev  # not binding, by a margin of 2 at least
    assert simulated["kmax"][0] > 0 and simulated["kmax"][1] == pytest.approx(simulated["kmax"][0], rel=TOL)
    assert simulated["checkpoint_kmax"][1] == pytest.approx(simulated["checkpoint_kmax"][0], rel=TOL)


CLUMP_SCRIPT = r"""
import json
import numpy as np
from erosim.sph import integrators
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver
from erosim.sph.solver_cuda import CudaSPHSolver

# the clump of tests/unit/sph/test_diffusion_limit.py in a reflecting box (the device has no voxel wall):
# a 3 × 3 layer on the floor and 16 particles within 1 mm of a point 2 mm above it, densities 900 ± 1
DX = 0.02
rng = np.random.default_rng(0)
layer = np.array([[x, y, 0.5 * DX] for x in 0.01 + DX * np.arange(3) for y in 0.01 + DX * np.arange(3)])
clump = np.array([0.03, 0.03, 0.002]) + rng.uniform(-1e-3, 1e-3, (16, 3))
fluid = np.concatenate([layer, clump])
prm = SPHParams(dim=3, spacing=DX, walls="reflect", sound_speed=20.0)
kw = dict(domain_lo=(0.0, 0.0, 0.0), domain_hi=(3 * DX, 3 * DX, 0.1))
cpu = SPHSolver(prm, fluid, **kw)
st = cpu.state
st.rho[: st.n_fluid] = 900.0 + rng.uniform(-1.0, 1.0, st.n_fluid)
st.p[: st.n_fluid] = 0.0
cpu._evaluate()
dev = CudaSPHSolver(prm, fluid, **kw)
dev.load_state_dict(cpu.state_dict())  # the same start on the device, through the CPU's checkpoint
out = {}
for name, s in (("cpu", cpu), ("dev", dev)):
    rows = []
    for k in range(6):
        if k == 3:
            ck = s.state_dict()
        kmax = s.kmax
        cfl = integrators.step_limit(prm.cfl, s.hs, s.c, s.vmax, s.amax, s.nu)
        rows.append([s.step(), kmax, cfl])
    out[name] = rows
again = CudaSPHSolver(prm, fluid, **kw)
again.load_state_dict(ck)  # the device's checkpoint after 3 steps (its kmax included)
out["dev_resumed"] = [again.step() for _ in range(3)]
print(json.dumps(out))
"""


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@needs_simulator
def test_diffusion_bound_binds_alike_on_both_devices():
    """A clump of 16 particles within 1 mm starts at K_iΔt = 0.77 at the CFL step, past the density
    update's bound 2/3. On both devices every step is the diffusion's 0.5/max K_i (K_i of the last
    force pass), well below the CFL step, and the step sequences agree to TOL (the same K_i summed
    over the same lists; module docstring); the device resumed from its own checkpoint takes the same
    steps bit for bit (its max K_i is checkpointed). About 9 s of wall time under load."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)}
    proc = subprocess.run([sys.executable, "-c", CLUMP_SCRIPT], env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["cpu"][0][1] * out["cpu"][0][2] > 2.0 / 3.0  # unstable at the CFL step alone
    for (dt_c, k_c, cfl_c), (dt_d, k_d, _) in zip(out["cpu"], out["dev"], strict=True):
        assert dt_c == pytest.approx(0.5 / k_c, rel=1e-12)  # the bound binds (not the CFL step) ...
        assert dt_c < 0.8 * cfl_c
        assert dt_d == pytest.approx(0.5 / k_d, rel=1e-12)  # ... on the device too
        assert dt_d == pytest.approx(dt_c, rel=TOL) and k_d == pytest.approx(k_c, rel=TOL)
    assert out["dev_resumed"] == [row[0] for row in out["dev"][3:]]


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
def test_checkpoints_resume_across_devices(simulated):
    assert simulated["resumed_steps"] == [3, 3]
    assert simulated["device_resume_bitwise"]
    for case in ("cpu_checkpoint_on_device", "device_checkpoint_on_cpu"):
        for field, diff in simulated[case].items():
            assert diff <= TOL, (case, field)


def test_device_cuda_without_cuda_is_one_sentence(cli_runner, tmp_path):
    from erosim.cli import cli
    from erosim.core.devices import cuda_status

    if cuda_status()[0]:
        pytest.skip("this machine has a usable CUDA device")
    out = tmp_path / "run"
    for args in (
        ["run", "hydrostatic", "--device", "cuda", "--out", str(out)],
        ["bench", "sph", "--device", "cuda", "--particles", "1000"],
        ["validate", "hydrostatic", "--device", "cuda", "--out", str(out)],
    ):
        res = cli_runner.invoke(cli, args)
        assert res.exit_code == 2, (args, res.output)
        lines = [ln for ln in res.output.splitlines() if ln.strip()]
        assert len(lines) == 1 and "Device 'cuda' is not usable" in lines[0] and "--device cpu" in lines[0]
        assert not out.exists()


def test_run_device_setting_refused_in_toml_without_cuda(cli_runner, tmp_path):
    from erosim.cli import cli
    from erosim.core.devices import cuda_status

    if cuda_status()[0]:
        pytest.skip("this machine has a usable CUDA device")
    toml = tmp_path / "t.toml"
    toml.write_text(
        'schema_version = 1\nkind = "sph"\nname = "t"\n[sph]\nspacing = 0.02\n[domain]\nlo = [0.0, 0.0]\n'
        'hi = [0.2, 0.3]\n[[fluid]]\nlo = [0.0, 0.0]\nhi = [0.1, 0.1]\n[run]\nt_end = 0.001\ndevice = "cuda"\n'
    )
    out = tmp_path / "run"
    res = cli_runner.invoke(cli, ["--quiet", "run", str(toml), "--out", str(out)])
    assert res.exit_code == 2
    assert "Device 'cuda' is not usable" in res.output
    assert not out.exists()  # no half-written run folder


def test_info_lists_devices(cli_runner):
    from erosim.cli import cli

    res = cli_runner.invoke(cli, ["info"])
    assert res.exit_code == 0
    assert "device cpu" in res.output and "device cuda" in res.output
    assert "threading_layer" in res.output  # the layer the parallel loops run on (docs/performance.md)


TOML = """schema_version = 1
kind = "sph"
name = "t"
[sph]
spacing = 0.02
[domain]
lo = [0.0, 0.0]
hi = [0.2, 0.3]
[[fluid]]
lo = [0.0, 0.0]
hi = [0.1, 0.1]
[run]
t_end = {t_end}
output_interval = 0.0
snapshots = 0
"""


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@pytest.mark.slow
@needs_simulator
def test_cli_run_resumes_a_cpu_run_on_the_device(tmp_path):
    """`erosim run --resume DIR --device cuda` continues a CPU run folder on the device (simulator);
    the state at the end matches the uninterrupted CPU run to rounding (tolerance: module docstring)."""
    import numpy as np

    from erosim.io import checkpoint

    def erosim(*args, sim=False):
        env = {**os.environ, "PYTHONPATH": str(SRC), "NUMBA_ENABLE_CUDASIM": "1" if sim else "0"}
        code = "import sys; from erosim.cli import main; sys.argv[0] = 'erosim'; main()"
        proc = subprocess.run([sys.executable, "-c", code, "--quiet", *args], env=env, capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr[-2000:]

    short, full = tmp_path / "short.toml", tmp_path / "full.toml"
    short.write_text(TOML.format(t_end=0.0005))
    full.write_text(TOML.format(t_end=0.001))
    erosim("run", str(full), "--out", str(tmp_path / "cpu"))
    erosim("run", str(short), "--out", str(tmp_path / "mixed"))
    erosim("run", "--resume", str(tmp_path / "mixed"), "--set", "run.t_end=0.001", "--device", "cuda", sim=True)
    a, _ = checkpoint.load(tmp_path / "cpu" / "checkpoint")
    b, _ = checkpoint.load(tmp_path / "mixed" / "checkpoint")
    assert int(a["model.fluid.steps"]) == int(b["model.fluid.steps"]) >= 3
    assert np.array_equal(a["model.fluid.ids"], b["model.fluid.ids"])
    for name in ("pos", "vel", "rho", "p"):
        x, y = a[f"model.fluid.{name}"], b[f"model.fluid.{name}"]
        assert float(np.max(np.abs(x - y))) <= TOL * float(np.max(np.abs(x))), name


VARIANTS_SCRIPT = r"""
import itertools, json
import numpy as np
from erosim.bench.sph import dam_break_geometry
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver
from erosim.sph.solver_cuda import CudaSPHSolver

cases = [dict(kernel=k, pressure_form=f, viscosity=v)
         for k, f, v in itertools.product(("wendland", "muller"), ("wcsph", "symmetric"), ("artificial", "laminar"))]
cases += [dict(integrator="symplectic-euler"), dict(eos="linear"), dict(precision="float32"),
          dict(walls="reflect"), dict(dim=3), dict(wall_pressure="extrapolated"),
          dict(dim=3, wall_pressure="extrapolated")]
out = {}
for case in cases:
    dim = case.get("dim", 2)
    fluid, lo, hi = dam_break_geometry(40 if dim == 2 else 27, dim, 0.01)
    prm = SPHParams(**{"dim": dim, "spacing": 0.01, "skin": 0.0, **case})
    cpu = SPHSolver(prm, fluid, domain_lo=lo, domain_hi=hi)
    dev = CudaSPHSolver(prm, fluid, domain_lo=lo, domain_hi=hi)
    cpu.step(); dev.step()
    key = ",".join(f"{k}={v}" for k, v in case.items())
    out[key] = max(float(np.max(np.abs(getattr(cpu, "fluid_" + f)() - getattr(dev, "fluid_" + f)()))
                         / max(float(np.max(np.abs(getattr(cpu, "fluid_" + f)()))), 1e-300))
                   for f in ("positions", "velocities", "density", "pressure", "accelerations"))
print(json.dumps(out))
"""


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@pytest.mark.slow
@needs_simulator
def test_every_variant_agrees_with_cpu():
    """Each kernel × pressure form × viscosity, symplectic Euler, the linear EOS, float32, reflecting
    walls only, 3-D, and the wall pressure extrapolated from the fluid in 2-D and 3-D: one step (with a
    list rebuild) on the device matches the CPU. float64 to TOL; float32 to 2e-6, about 30 float32 ulps
    (6e-8 each): the simulator rounds its float64 arithmetic to float32 only where it stores, the CPU's
    compiled code also in between."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)}
    proc = subprocess.run([sys.executable, "-c", VARIANTS_SCRIPT], env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    diffs = json.loads(proc.stdout.strip().splitlines()[-1])
    assert len(diffs) == 15
    for case, diff in diffs.items():
        assert diff <= (2e-6 if "float32" in case else TOL), case


@pytest.mark.cuda  # the device path under Numba's CUDA simulator (`make test-cuda`)
@pytest.mark.slow
@needs_simulator
def test_bench_on_the_device_has_the_cpu_keys_plus_device():
    """`erosim bench sph --device cuda` reports what the CPU benchmark reports, plus the device."""
    code = (
        "import json; from erosim.bench.sph import run; "
        "print(json.dumps([run(100, 1, 2, warmup=1, device=d) for d in ('cpu', 'cuda')]))"
    )
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)}
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    cpu, dev = json.loads(proc.stdout.strip().splitlines()[-1])
    assert cpu["device"] == "cpu" and dev["device"] == "cuda"
    assert set(cpu) <= set(dev) and set(dev) - set(cpu) == {"gpu"}
    assert dev["particles"] == cpu["particles"] and dev["particle_steps_per_s"] > 0
    assert dev["neighbours_mean"] == cpu["neighbours_mean"]  # the same lists after the same steps


def test_device_on_a_kind_without_one_is_one_sentence(cli_runner, tmp_path, monkeypatch):
    """With a usable device (the simulator's switch stands in for a GPU: nothing runs), --device on a
    scenario of another kind names the kind and stops before writing anything."""
    from erosim.cli import cli

    monkeypatch.setenv("NUMBA_ENABLE_CUDASIM", "1")
    out = tmp_path / "run"
    res = cli_runner.invoke(cli, ["run", "particle-stream", "--device", "cuda", "--out", str(out)])
    assert res.exit_code == 2
    assert "\"hydrology\" scenarios, not 'particle-stream' (kind 'particle-stream')" in res.output
    assert not out.exists()


def test_numpy_alias_restored_for_numba_cuda(monkeypatch):
    """numpy 2.5 dropped np.row_stack, which numba-cuda releases of its time overload at their first
    compile (an AttributeError on a real GPU image): the device check puts the alias back, as vstack."""
    import numpy as np

    from erosim.core import devices

    monkeypatch.delattr(np, "row_stack", raising=False)
    assert "row_stack" not in vars(np)
    devices.cuda_status()
    assert np.row_stack is np.vstack
