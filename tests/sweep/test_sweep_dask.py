"""``erosim sweep`` on real Dask clusters: results independent of workers and of the path (local cluster,
explicit scheduler address, interrupted and resumed), failures recorded, dead workers retried once.

The tests that start a cluster form the ``multiprocess`` tier (``make test-multiprocess``, which CI runs
after the default run); the bad-input tests stay in the default run."""

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from erosim.core.errors import ConfigError, ErosimError
from erosim.sweep.runner import run_sweep

sys.path.insert(0, str(Path(__file__).parent))
import dying_member  # noqa: E402

TINY = ["terrain.size=48", "terrain.cell_size=40", "run.cycles=60", "run.frames=0"]
VARY = ["hydrology.capacity=0.5,2"]
# members of about a second each (single thread), long enough to be stopped in the middle
LONGER = ["terrain.size=128", "terrain.cell_size=20", "run.cycles=900", "run.frames=0"]


def _maps(folder) -> dict:
    with xr.open_dataset(Path(folder) / "sweep.nc") as ds:
        return {k: ds[k].values for k in ds.data_vars}


def _assert_same_maps(a: dict, b: dict):
    assert a.keys() == b.keys() and "p_erosion_gt_1" in a
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)  # bit for bit


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "reference"
    summary = run_sweep("hydrology", TINY, None, VARY, seeds=2, workers=2, threads=1, out=str(out), progress=False)
    return out, summary


@pytest.mark.multiprocess
def test_sweep_runs_members_as_ordinary_runs(reference):
    out, summary = reference
    assert (summary["members"], summary["completed"], summary["workers"]) == (4, 4, 2)
    for i in range(4):
        report = json.loads((out / "members" / f"m{i:04d}" / "report.json").read_text())
        assert report["status"] == "completed" and report["terrain"]["shape"] == [48, 48]
    scenario = (out / "members" / "m0003" / "scenario.toml").read_text()
    assert "capacity = 2" in scenario and "seed = 2" in scenario
    rows = (out / "sweep.csv").read_text().splitlines()
    assert rows[0].startswith("member,status,hydrology.capacity,seed,wall_s,message") and len(rows) == 5
    assert (out / "figures" / "p_erosion_gt_1.png").is_file()
    report = json.loads((out / "report.json").read_text())
    assert report["threads_per_member"] == 1 and report["failed_members"] == {}


@pytest.mark.multiprocess
def test_one_worker_and_a_second_run_give_the_same_maps(reference, tmp_path):
    out, _ = reference
    summary = run_sweep("hydrology", TINY, None, VARY, seeds=2, workers=1, out=str(tmp_path / "one"), progress=False)
    assert summary["threads_per_member"] >= 1
    _assert_same_maps(_maps(out), _maps(tmp_path / "one"))
    again = run_sweep("hydrology", TINY, None, VARY, seeds=2, workers=1, out=str(tmp_path / "one"), progress=False)
    assert again["ran_now"] == 0  # the same sweep into the same folder: every member kept


@pytest.mark.multiprocess
def test_explicit_scheduler_address(reference, tmp_path):
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        summary = run_sweep(
            "hydrology", TINY, None, VARY, seeds=2, scheduler=cluster.scheduler_address, out=str(tmp_path / "remote"),
            progress=False,
        )  # fmt: skip
    assert summary["workers"] == "remote" and summary["completed"] == 4
    _assert_same_maps(_maps(reference[0]), _maps(tmp_path / "remote"))


def _sweep_command(out):
    return [
        sys.executable,
        "-m",
        "erosim.cli",
        "--quiet",
        "sweep",
        "hydrology",
        *[f"--set={s}" for s in LONGER],
        "--vary",
        VARY[0],
        "--seeds",
        "2",
        "--workers",
        "1",
        "--threads-per-member",
        "1",
        "--out",
        str(out),
    ]


@pytest.mark.multiprocess
@pytest.mark.slow  # an uninterrupted sweep, a stopped one and its resume: about 40 s each
@pytest.mark.parametrize("how", [signal.SIGINT, signal.SIGKILL], ids=["ctrl-c", "killed"])
def test_resume_after_stopping_mid_way(tmp_path, how):
    """Stop a sweep while its second member runs; the resumed sweep keeps the first, resumes (Ctrl-C) or
    reruns (killed) the second, and its maps equal an uninterrupted sweep's."""
    ref = tmp_path / "uninterrupted"
    run_sweep("hydrology", LONGER, None, VARY, seeds=2, workers=2, threads=1, out=str(ref), progress=False)
    out = tmp_path / "stopped"
    # SIG_DFL in the child: a shell's background job (`make test &`, nohup) ignores SIGINT, and a Python
    # started with it ignored keeps ignoring it, so the Ctrl-C below would be lost
    proc = subprocess.Popen(_sweep_command(out), start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # fmt: skip
    first = out / "members" / "m0000" / "report.json"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and '"completed"' not in (first.read_text() if first.is_file() else ""):
        time.sleep(0.05)
    time.sleep(0.3)  # the second member is under way
    os.killpg(proc.pid, how)
    _, err = proc.communicate(timeout=180)
    if how == signal.SIGINT:
        assert proc.returncode == 130 and "erosim sweep --resume" in err
        second = json.loads((out / "members" / "m0001" / "report.json").read_text())
        assert second["status"] == "interrupted" and second["progress"]["time"] < 900
    summary = run_sweep(None, resume=str(out), workers=1, progress=False)
    assert summary["completed"] == 4 and 1 <= summary["ran_now"] <= 3
    if how == signal.SIGINT:
        assert json.loads((out / "members" / "m0001" / "report.json").read_text())["resumed"] is True
    _assert_same_maps(_maps(ref), _maps(out))


@pytest.mark.multiprocess
def test_a_failing_member_is_recorded_and_the_sweep_goes_on(tmp_path):
    from erosim.io import heightmaps as hio
    from erosim.terrain.generate import generate

    dem = tmp_path / "dem.tif"
    hio.write(dem, generate("hills", 40, 30.0, seed=3))
    vary = [f"terrain.file={dem},{tmp_path / 'missing.tif'}"]
    summary = run_sweep("hydrology", ["run.cycles=20", "run.frames=0"], None, vary, workers=2,
                        out=str(tmp_path / "s"), progress=False)  # fmt: skip
    assert (summary["completed"], summary["failed"]) == (1, 1)
    assert "does not exist" in summary["failed_members"]["m0001"]
    with xr.open_dataset(tmp_path / "s" / "sweep.nc") as ds:
        assert list(ds.member.values) == ["m0000"] and ds.attrs["members_failed"] == "m0001 (failed)"


@pytest.mark.multiprocess
@pytest.mark.slow  # a worker killed mid-run and a new one started, about 17 s
def test_a_worker_that_dies_is_retried_once(tmp_path):
    summary = run_sweep("hydrology", TINY, None, VARY, workers=2, out=str(tmp_path / "once"), progress=False,
                        member_function=dying_member.die_once)  # fmt: skip
    assert (tmp_path / "once" / "members" / "m0000.died").is_file()  # it did die
    assert summary["completed"] == 2 and summary["failed_members"] == {}
    summary = run_sweep("hydrology", TINY, None, VARY, workers=2, out=str(tmp_path / "always"), progress=False,
                        member_function=dying_member.die_always_on_first_member)  # fmt: skip
    assert summary["completed"] == 1
    assert summary["failed_members"] == {"m0000": "its worker died twice while running it"}


def test_a_scheduler_that_does_not_answer_is_one_sentence(tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # free, and nothing listens once closed
    t0 = time.monotonic()
    with pytest.raises(ErosimError, match="No Dask scheduler answered at 'tcp://127.0.0.1"):
        run_sweep("hydrology", TINY, None, VARY, scheduler=f"tcp://127.0.0.1:{port}", timeout_s=1.0,
                  out=str(tmp_path / "x"), progress=False)  # fmt: skip
    assert time.monotonic() - t0 < 15


@pytest.mark.multiprocess
def test_another_sweep_in_the_same_folder_is_refused(reference):
    with pytest.raises(ConfigError, match="holds another sweep"):
        run_sweep("hydrology", TINY, None, ["hydrology.capacity=1,3"], out=str(reference[0]), progress=False)


@pytest.mark.parametrize(
    "args, words",
    [
        (["hydrology", "--vary", "hydrology.no_such=1,2"], "no_such"),
        (["hydrology", "--vary", "hydrology.capacity=1:2:0"], "at least 1"),
        (["hydrology", "--vary", "hydrology.capacity=1,2", "--exceed", "erosion ~ 1"], "map > value"),
        (["--vary", "hydrology.capacity=1,2"], "Name a scenario"),
        (["hydrology", "--vary", "hydrology.capacity=1,2", "--workers", "0"], "--workers 0"),
    ],
)
def test_bad_input_on_the_command_line(cli_runner, tmp_path, args, words):
    from erosim.cli import cli

    result = cli_runner.invoke(cli, ["sweep", *args, "--out", str(tmp_path / "s")])
    assert result.exit_code == 2
    assert words in result.output and result.output.count("\n") == 1
    assert not (tmp_path / "s").exists()  # nothing is left behind
