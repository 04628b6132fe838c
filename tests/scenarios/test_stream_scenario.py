"""The `particle-stream` scenario end to end: library run, own DEM and hardness, resume, errors."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from erosim.cli import cli
from erosim.core.heightmap import Heightmap
from erosim.io import heightmaps as hio
from erosim.io.runfolder import RunFolder
from erosim.scenarios import loader, runner
from erosim.scenarios.particle_stream import build as particle_stream_build

SMALL = ["--set", "terrain.size=64", "--set", "emitters.main.particles=150", "--set", "emitters.main.steps=50"]


def run_cli(*args):
    return CliRunner().invoke(cli, ["--quiet", "run", *args])


def test_library_scenario_writes_the_run_folder(tmp_path):
    out = tmp_path / "run"
    res = run_cli("particle-stream", "--out", str(out), *SMALL)
    assert res.exit_code == 0, res.output
    for name in (
        "height_initial.tif",
        "height.tif",
        "hardness.tif",
        "hardness_initial.tif",
        "erosion.tif",
        "height.png",
        "height.r16",
        "erosion_mask.png",
    ):
        assert (out / "maps" / name).is_file(), name
    for name in ("hillshade_before.png", "hillshade_after.png", "strata_after.png", "erosion.png", "canyon.png"):
        assert (out / "figures" / name).is_file(), name
    assert (out / "scenario.toml").is_file() and (out / "checkpoint" / "state.npz").is_file()
    rep = json.loads((out / "report.json").read_text())
    h0 = hio.read(out / "maps" / "height_initial.tif")
    h = hio.read(out / "maps" / "height.tif").z
    ero = hio.read(out / "maps" / "erosion.tif").z
    assert rep["seed"] == 1 and rep["particles"] == 150 and rep["removed_volume"] > 0
    # float32 GeoTIFFs: heights ~10² m carry ~10⁻⁵ m round-off per cell, so compare to 1e-4 relative
    area = h0.cell_size**2
    assert rep["removed_volume"] == pytest.approx(float(ero.astype(np.float64).sum()) * area, rel=1e-4)
    assert rep["removed_volume"] == pytest.approx(rep["removed_volume_kernel"], rel=1e-9)
    assert (h <= h0.z + 1e-3).all()  # only goes down (float32 round-off aside)
    # the 16-bit PNG re-reads within one quantisation step of the float map
    lo, hi = rep["height_png_range"]
    png = hio.read(out / "maps" / "height.png", height_range=(lo, hi)).z
    np.testing.assert_allclose(png, h, atol=(hi - lo) / 65535 + 1e-3)


def test_own_dem_and_hardness_files(tmp_path):
    ny, nx = 48, 60
    jj, ii = np.indices((ny, nx))
    z = 100.0 - 0.2 * ii + 3.0 * np.sin(jj / 7.0)  # falling eastward, the stream's way
    dem = tmp_path / "dem.tif"
    hio.write(dem, Heightmap(z=z, cell_size=5.0))
    d = np.full((ny, nx), 0.3)
    d[:, 30:34] = 1.0  # an unerodible dyke across the stream
    hard = tmp_path / "hard.tif"
    hio.write(hard, Heightmap(z=d, cell_size=5.0))
    out = tmp_path / "run"
    res = run_cli(
        "particle-stream",
        "--out",
        str(out),
        "--set",
        f"terrain.file={dem}",
        "--set",
        f"hardness.file={hard}",
        "--set",
        "emitters.main.particles=100",
        "--set",
        "emitters.main.steps=60",
        "--set",
        "emitters.main.x=0.05",
    )
    assert res.exit_code == 0, res.output
    rep = json.loads((out / "report.json").read_text())
    assert rep["hardness_source"] == "file" and rep["terrain"]["cell_size_m"] == 5.0
    np.testing.assert_array_equal(hio.read(out / "maps" / "hardness.tif").z, d.astype(np.float32))  # float32 file
    h0 = hio.read(out / "maps" / "height_initial.tif").z
    h = hio.read(out / "maps" / "height.tif").z
    assert np.array_equal(h[:, 30:34], h0[:, 30:34])
    assert (h[:, :30] < h0[:, :30]).any() and rep["removed_volume"] > 0


def test_same_seed_same_maps(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        assert run_cli("particle-stream", "--out", str(out), *SMALL, "--preset", "two-streams").exit_code == 0
    for name in ("height.tif", "hardness.tif", "erosion.tif"):
        assert np.array_equal(hio.read(a / "maps" / name).z, hio.read(b / "maps" / name).z)
    ra, rb = (json.loads((p / "report.json").read_text()) for p in (a, b))
    assert ra["removed_volume"] == rb["removed_volume"] and ra["emitters"] == ["main", "north"]


def test_resume_continues_exactly(tmp_path, monkeypatch):
    from erosim.core.errors import Interrupted
    from erosim.erosion.particle_stream_warszawski import ParticleStream

    sets = ["terrain.size=64", "emitters.main.particles=120", "emitters.main.steps=40", "stream.pool=8",
            "stream.impacts_per_batch=200"]  # fmt: skip
    sc = loader.load("particle-stream", sets)
    whole = RunFolder(tmp_path / "whole")
    runner.run(sc, whole, progress=False)
    # Ctrl-C during the stream: the checkpoint holds the state after the last whole advance
    real, calls = ParticleStream.advance, {"n": 0}

    def interrupt_later(self, rounds=None):
        calls["n"] += 1
        if calls["n"] == 5:  # the first call is the builder's compile-only advance(0)
            raise KeyboardInterrupt
        return real(self, rounds)

    monkeypatch.setattr(ParticleStream, "advance", interrupt_later)
    part = RunFolder(tmp_path / "part")
    with pytest.raises(Interrupted, match="--resume"):
        runner.run(sc, part, progress=False)
    monkeypatch.setattr(ParticleStream, "advance", real)
    assert json.loads((part.path / "report.json").read_text())["status"] == "interrupted"
    resumed = loader.load(tmp_path / "part" / "scenario.toml")
    runner.run(resumed, RunFolder(tmp_path / "part", resume=True), resume=True, progress=False)
    for name in ("height.tif", "hardness.tif"):
        assert np.array_equal(hio.read(whole.path / "maps" / name).z, hio.read(part.path / "maps" / name).z)


@pytest.mark.parametrize(
    "extra, words",
    [
        (["--set", "emitters.main.width=0"], "empty emission window"),
        (["--set", "emitters.main.x=4"], "off the map"),
        (["--set", "hardness.values=[0.2, 1.5, 0.3, 0.4]"], "[0, 1]"),
        (["--set", "hardness.source=file"], "hardness.file"),
        (["--set", "emitters.main.wdith=3"], "did you mean 'width'"),
    ],
)
def test_bad_settings_are_one_sentence(tmp_path, extra, words):
    res = run_cli("particle-stream", "--out", str(tmp_path / "x"), *SMALL, *extra)
    assert res.exit_code != 0
    assert words in res.output and "Traceback" not in res.output


def test_bad_hardness_files_are_one_sentence(tmp_path):
    np.save(tmp_path / "small.npy", np.zeros((10, 10)))
    np.save(tmp_path / "big.npy", np.full((64, 64), 2.0))
    res = run_cli(
        "particle-stream", "--out", str(tmp_path / "a"), *SMALL, "--set", f"hardness.file={tmp_path / 'small.npy'}"
    )
    assert res.exit_code != 0 and "shape (10, 10)" in res.output and "Traceback" not in res.output
    res = run_cli(
        "particle-stream", "--out", str(tmp_path / "b"), *SMALL, "--set", f"hardness.file={tmp_path / 'big.npy'}"
    )
    assert res.exit_code != 0 and "must lie in [0, 1]" in res.output and "Traceback" not in res.output


def test_every_hardness_source_builds(tmp_path):
    cm = np.zeros((64, 64), np.uint8)
    cm[:, 32:] = 3
    np.save(tmp_path / "classes.npy", cm)
    cases = {
        "uniform": (["hardness.source=uniform", "hardness.value=0.4"], lambda d: np.all(d == 0.4)),
        "noise": (
            ["hardness.source=noise", "hardness.low=0.2", "hardness.high=0.6"],
            lambda d: d.min() == pytest.approx(0.2) and d.max() == pytest.approx(0.6),
        ),
        "classes": (
            [
                f"hardness.class_file={tmp_path / 'classes.npy'}",
                "hardness.source=classes",
                'hardness.materials={"0" = "sand", "3" = 0.9}',
            ],
            lambda d: np.all(d[:, :32] == 0.05) and np.all(d[:, 32:] == 0.9),
        ),
        "strata": ([], lambda d: set(np.unique(d)) <= {0.25, 0.85, 0.45, 0.7}),
    }
    for name, (sets, ok) in cases.items():
        sc = loader.load("particle-stream", ["terrain.size=64", *sets])
        hm, d0, stream = particle_stream_build.build(sc.config)
        assert ok(d0), name
        assert (stream.strata is not None) == (name == "strata"), name


def test_bench_stream_prints_one_json_object(monkeypatch):
    from erosim.bench import stream as bench

    monkeypatch.setattr(bench, "SIZE", 96)  # the contract, not the timing: a small map, one repeat
    monkeypatch.setattr(bench, "MIN_TIME", 0.0)
    res = CliRunner().invoke(cli, ["bench", "stream", "--particles", "100", "--particles", "300", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert [r["particles"] for r in out["runs"]] == [100, 300]
    for r in out["runs"]:
        assert r["impacts"] == r["particles"] * bench.STEPS  # fixed work per particle
        assert r["particles_per_s"] > 0 and r["us_per_particle"] > 0
