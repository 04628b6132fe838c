"""The ``hydrology`` scenario end to end: outputs, report, resume, DEM input, clear errors."""

import json

import numpy as np
import pytest

from erosim.cli import cli
from erosim.core.errors import ConfigError, InputError
from erosim.core.heightmap import Heightmap
from erosim.io import heightmaps as hio
from erosim.io.runfolder import RunFolder
from erosim.scenarios import loader, runner
from erosim.scenarios.hydrology import build as hydrology_build
from erosim.scenarios.hydrology import outputs as hydrology_outputs

SMALL = ["terrain.size=48", "terrain.cell_size=40.0", "run.cycles=6", "run.frames=3", "hydrology.cycle_droplets=20000"]


def _run(tmp_path, overrides=(), name="run", preset=None):
    sc = loader.load("hydrology", list(SMALL) + list(overrides), preset=preset)
    out = RunFolder(tmp_path / name)
    summary = runner.run(sc, out, progress=False)
    return out.path, summary


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    path, _ = _run(tmp_path_factory.mktemp("hy"))
    return path


def test_run_folder_holds_every_output(folder):
    for name in hydrology_outputs.MAPS:
        assert (folder / "maps" / f"{name}.tif").is_file()
    for name in (
        "height.png",
        "height.r16",
        "mask_stream.png",
        "mask_lake_depth.png",
        "mask_erosion.png",
        "mask_deposition.png",
        "mask_vegetation.png",
    ):
        assert (folder / "maps" / name).is_file()
    for name in ("hillshade_before.png", "hillshade_after.png", "hydrology.png", "evolution.gif"):
        assert (folder / "figures" / name).is_file()
    assert (folder / "scenario.toml").is_file() and (folder / "checkpoint" / "state.npz").is_file()
    # the 16-bit exports hold the final heights: q → lo + q·(hi − lo)/65535 within half a step of height.tif
    from PIL import Image

    rep = json.loads((folder / "report.json").read_text())["outputs"]["heightmap_16bit"]
    z = np.asarray(hio.read(folder / "maps" / "height.tif").z, np.float64)
    lo, hi = rep["height_range"]
    q = np.asarray(Image.open(folder / "maps" / "height.png"), np.float64)
    assert q.shape == z.shape and np.abs(lo + q * (hi - lo) / 65535 - z).max() <= 0.5 * (hi - lo) / 65535 + 1e-4
    r16 = np.fromfile(folder / "maps" / "height.r16", "<u2").reshape(rep["raw16_shape"]).astype(np.float64)
    lo, hi = rep["raw16_height_range"]
    assert np.abs(lo + r16 * (hi - lo) / 65535 - z).max() <= 0.5 * (hi - lo) / 65535 + 1e-4
    # a stream mask pixel is the stream map's value on 0…1
    stream = np.asarray(hio.read(folder / "maps" / "stream.tif").z, np.float64)
    mask = np.asarray(Image.open(folder / "maps" / "mask_stream.png"), np.float64) / 65535
    assert np.abs(mask - np.clip(stream, 0, 1)).max() <= 0.5 / 65535 + 1e-6


def test_map_frames_follow_the_run(folder):
    """run.frames=3 over 6 cycles: frames at cycles 0, 2, 4 and the end; the last is the final state."""
    from erosim.io.results import open_run

    frames = open_run(folder).map_frames
    assert [t for t, _ in frames] == [0.0, 2.0, 4.0, 6.0]
    assert all(sorted(files) == ["height", "lake_depth"] for _, files in frames)
    final = hio.read(folder / "maps" / "height.tif").z
    assert np.array_equal(hio.read(frames[-1][1]["height"]).z, final)  # both float32 of the same state
    assert np.array_equal(hio.read(frames[-1][1]["lake_depth"]).z, hio.read(folder / "maps" / "lake_depth.tif").z)
    first = hio.read(frames[0][1]["height"]).z
    assert np.array_equal(first, hio.read(folder / "maps" / "height_initial.tif").z)  # before any droplet
    assert not np.array_equal(first, final)  # the terrain changed between the first and the last frame


def test_report_budgets_and_ranges(folder):
    rep = json.loads((folder / "report.json").read_text())
    wb, sb = rep["water_budget"], rep["sediment_budget"]
    for key in ("rained", "in_lakes", "evaporated", "left_edges", "closure_rel"):
        assert key in wb
    for key in ("eroded", "deposited", "carried_off", "closure_rel"):
        assert key in sb
    # the four terms close by themselves (float64 accumulators): 1e-9 is the stated bar
    assert abs(wb["rained"] - wb["in_lakes"] - wb["evaporated"] - wb["left_edges"]) <= 1e-9 * wb["rained"]
    assert abs(sb["eroded"] - sb["deposited"] - sb["carried_off"]) <= 1e-9 * sb["eroded"]
    lo, hi = rep["outputs"]["heightmap_16bit"]["height_range"]
    # the 16-bit heightmap re-scales to the final heights within half a quantisation step
    z = hio.read(folder / "maps" / "height.tif").z
    back = hio.read(folder / "maps" / "height.png", height_range=(lo, hi)).z
    assert np.max(np.abs(back - z)) <= 0.5 * (hi - lo) / 65535 + 1e-3  # + float32 GeoTIFF rounding


def test_resume_repeats_the_uninterrupted_run(tmp_path):
    full, _ = _run(tmp_path, ["run.cycles=6", "run.frames=0"], name="full")
    half, _ = _run(tmp_path, ["run.cycles=3", "run.frames=0"], name="half")
    # continue the 3-cycle run to 6 cycles from its checkpoint
    sc = loader.load(half / "scenario.toml", ["run.cycles=6"])
    runner.run(sc, RunFolder(half, resume=True), resume=True, progress=False)
    a = hio.read(full / "maps" / "height.tif").z
    b = hio.read(half / "maps" / "height.tif").z
    assert np.array_equal(a, b)
    ra = json.loads((full / "report.json").read_text())["water_budget"]
    rb = json.loads((half / "report.json").read_text())["water_budget"]
    assert ra["rained"] == rb["rained"] and ra["in_lakes"] == rb["in_lakes"]


def test_dem_file_input_keeps_its_crs(tmp_path):
    from scipy import ndimage

    rng = np.random.default_rng(3)
    z = 300.0 + 200.0 * ndimage.gaussian_filter(rng.random((40, 40)), 4.0)
    from rasterio.crs import CRS

    crs = CRS.from_epsg(32633).to_wkt()
    dem = Heightmap(z=z, cell_size=30.0, crs=crs, transform=(30.0, 0.0, 400000.0, 0.0, -30.0, 5000000.0))
    hio.write(tmp_path / "dem.tif", dem)
    path, _ = _run(tmp_path, [f"terrain.file={tmp_path / 'dem.tif'}"], name="dem")
    out = hio.read(path / "maps" / "lake_depth.tif")
    assert out.crs and "32633" in out.crs
    assert out.transform == pytest.approx(dem.transform)
    assert out.shape == (40, 40)


def test_seed_preset_runs(tmp_path):
    path, summary = _run(
        tmp_path, ["terrain.size=48", "terrain.cell_size=40.0"], name="seed", preset="simplehydrology-2020"
    )
    text = (path / "scenario.toml").read_text()
    assert "length_scale = 0.0" in text and "pit_flood = false" in text
    assert summary["water_closure_rel"] < 1e-9


def test_nan_only_dem_is_a_clear_error(tmp_path):
    np.save(tmp_path / "nan.npy", np.full((20, 20), np.nan))
    with pytest.raises(InputError, match="no valid height"):
        _run(tmp_path, [f"terrain.file={tmp_path / 'nan.npy'}"], name="nan")


def test_wrong_raw_size_is_a_clear_error(tmp_path):
    (tmp_path / "bad.r16").write_bytes(b"\x00\x01" * 1001)
    with pytest.raises(InputError, match="(?i)raw"):
        _run(tmp_path, [f"terrain.file={tmp_path / 'bad.r16'}"], name="raw")


def test_negative_cell_size_is_a_clear_error():
    with pytest.raises(ConfigError, match="terrain.cell_size"):
        loader.load("hydrology", ["terrain.cell_size=-5"])


def test_unknown_presets_are_clear_errors():
    with pytest.raises(ConfigError, match="no preset 'simplehydrology'"):
        loader.load("hydrology", preset="simplehydrology")
    with pytest.raises(ConfigError, match="Unknown terrain preset"):
        loader.load("hydrology", ["terrain.preset=volcano"])
    with pytest.raises(ConfigError, match="hydrology.frction"):
        loader.load("hydrology", ["hydrology.frction=0.2"])


def test_cli_run_with_set(tmp_path, cli_runner):
    res = cli_runner.invoke(
        cli,
        [
            "--quiet",
            "run",
            "hydrology",
            *sum((["--set", s] for s in SMALL), []),
            "--set",
            "run.cycles=2",
            "--out",
            str(tmp_path / "cli"),
        ],
    )
    assert res.exit_code == 0, res.output
    # the command line runs what the Python API runs, bit for bit
    ref, _ = _run(tmp_path, ["run.cycles=2"], name="api")
    for name in ("height", "stream", "lake_depth"):
        cli_map, api_map = (hio.read(f / "maps" / f"{name}.tif").z for f in (tmp_path / "cli", ref))
        assert np.array_equal(cli_map, api_map), name


def test_demo_folder_guard(tmp_path):
    keep = tmp_path / "mine"
    keep.mkdir()
    (keep / "notes.txt").write_text("precious")
    with pytest.raises(ConfigError, match="did not write"):
        hydrology_build.clear_demo_folder(keep)
    assert (keep / "notes.txt").is_file()


def test_rain_and_hardness_map_files(tmp_path):
    rain = np.zeros((48, 48))
    rain[:, :12] = 1.0
    hard = np.ones((48, 48))  # unerodible rock everywhere
    np.save(tmp_path / "rain.npy", rain)
    np.save(tmp_path / "hard.npy", hard)
    path, _ = _run(
        tmp_path,
        [
            f"inputs.rain_map={tmp_path / 'rain.npy'}",
            f"inputs.hardness_map={tmp_path / 'hard.npy'}",
            "vegetation.enabled=false",
        ],
        name="maps",
    )
    rep = json.loads((path / "report.json").read_text())
    assert rep["sediment_budget"]["eroded"] == 0.0  # rock does not erode
    stream = hio.read(path / "maps" / "stream.tif").z
    assert stream[:, :10].mean() > stream[:, 30:].mean()
    np.save(tmp_path / "small.npy", np.ones((5, 5)))
    with pytest.raises(InputError, match="same size"):
        _run(tmp_path, [f"inputs.hardness_map={tmp_path / 'small.npy'}"], name="bad")
