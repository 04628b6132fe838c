"""The ``sph-terrain`` kind end to end: the library scenarios, the command line on a user's DEM, closed
budgets, exact resume, the ground constraint under a violent inflow, and bad input."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from rasterio.crs import CRS

from erosim.cli import cli
from erosim.core.errors import Interrupted
from erosim.core.heightmap import Heightmap
from erosim.io import heightmaps as hio
from erosim.io.runfolder import RunFolder
from erosim.scenarios import loader, runner

# a few steps of every sph-terrain scenario of the library at a coarse spacing
CASES = {
    "rain-erosion": ["terrain.size=16", "terrain.cell_size=2.0", "sph.spacing=1.0", "run.t_end=0.3",
                     "run.map_frames=1", "rain.every=5"],
    "dam-break-erodible": ["sph.spacing=0.02", "profile.cell_size=0.04", "run.t_end=0.05", "run.map_frames=1"],
    "basin-at-rest": ["sph.spacing=0.1", "run.t_end=0.05", "run.map_frames=1"],
}  # fmt: skip


def _cli(*args):
    res = CliRunner().invoke(cli, ["--quiet", *args])
    return res.exit_code, res.output


def _sets(items):
    return [a for s in items for a in ("--set", s)]


def test_every_sph_terrain_scenario_has_a_case():
    names = {
        n for n in loader.library_names() if loader.read_toml(loader.LIBRARY / f"{n}.toml")["kind"] == "sph-terrain"
    }
    assert names == set(CASES)


@pytest.mark.parametrize("name", sorted(CASES))
def test_library_scenario_runs_and_reports(tmp_path, name):
    out = tmp_path / name
    code, text = _cli("run", name, "--out", str(out), *_sets(CASES[name]))
    assert code == 0, text
    rep = json.loads((out / "report.json").read_text())
    assert rep["status"] == "completed" and rep["steps"] >= 2
    wb = rep["water_budget"]
    for key in ("initial", "rained", "inflow", "left_edges", "in_fluid", "closure_rel"):
        assert key in wb
    assert wb["closure_rel"] < 1e-12  # counted particles: exact up to the float sums
    assert rep["particles_below_ground"] == 0
    if rep.get("sediment_budget"):
        sb = rep["sediment_budget"]
        assert {"eroded", "deposited", "suspended", "carried_off", "closure_rel"} <= sb.keys()
        assert sb["closure_rel"] < 1e-9
    assert (out / "figures" / "maps_final.png").is_file() and (out / "figures" / "evolution.gif").is_file()
    if rep["dim"] == 3:
        for m in ("height", "height_initial", "water_depth", "max_water_depth", "erosion", "deposition", "sediment"):
            assert (out / "maps" / f"{m}.tif").is_file()
        scenario = loader.load(name, CASES[name]).config
        if scenario.rain.rate > 0:  # the rain map: the intensity where the map is 1 at most, nothing below zero
            import rasterio

            with rasterio.open(out / "maps" / "rain.tif") as ds:
                rain = ds.read(1)
            assert rain.shape == tuple(rep["terrain"]["shape"]) and (out / "figures" / "rain.png").is_file()
            assert 0.0 <= rain.min() and rain.max() <= scenario.rain.rate * (1 + 1e-6) and rain.max() > 0
    else:
        assert (out / "profile.csv").read_text().startswith("x,height_initial,height,")


def _dem(tmp_path, ext=".tif", cell=2.0):
    """A 24 × 20 DEM of ``cell`` m cells in UTM 33N: a valley falling north with a basin in it."""
    ny, nx = 20, 24
    x = (np.arange(nx) + 0.5) * cell
    y = (np.arange(ny)[::-1] + 0.5) * cell
    X, Y = np.meshgrid(x, y)
    xc, yc = 12.0 * cell, 10.0 * cell
    z = 100.0 + 0.1 * np.abs(X - xc) + 0.04 * Y - 2.0 * np.exp(-((X - xc) ** 2 + (Y - yc) ** 2) / (15.0 * cell**2))
    crs = CRS.from_epsg(32633).to_wkt()
    top = 4100000.0 + ny * cell
    dem = Heightmap(z=z, cell_size=cell, crs=crs, transform=(cell, 0.0, 500000.0, 0.0, -cell, top))
    path = tmp_path / f"dem{ext}"
    hio.write(path, dem)
    return path, dem


def test_rain_erosion_on_a_users_dem_keeps_its_grid_and_crs(tmp_path):
    """The issue's interface: DEM and rain map files, a lake by level and seed (DEM coordinates),
    the spacing; the maps come back on the DEM's grid with its CRS."""
    dem_path, dem = _dem(tmp_path)
    rain = np.zeros(dem.shape)
    rain[:, 12:] = 1.0  # rain on the east half only
    hio.write(tmp_path / "rain.tif", rain, like=dem)
    out = tmp_path / "run"
    code, text = _cli(
        "run", "rain-erosion", "--out", str(out), "--set", f"terrain.file={dem_path}",
        "--set", f"rain.file={tmp_path / 'rain.tif'}", "--set", "run.t_end=0.3", "--set", "water.level=100.5",
        "--set", "water.seed=[500024.0, 4100020.0]", "--set", "sph.spacing=1.0", "--set", "rain.rate=3.6e5",
        "--set", "run.map_frames=0", "--set", "rain.every=5",
    )  # fmt: skip
    assert code == 0, text
    rep = json.loads((out / "report.json").read_text())
    assert rep["terrain"]["cell_size_m"] == 2.0 and "32633" in rep["terrain"]["crs"]
    wb = rep["water_budget"]
    assert wb["initial"] > 0 and wb["rained"] > 0 and wb["closure_rel"] < 1e-12
    assert wb["initial"] + wb["rained"] - wb["left_edges"] == pytest.approx(wb["in_fluid"], rel=1e-12)
    for name in ("height", "water_depth", "max_water_depth", "erosion", "sediment"):
        back = hio.read(out / "maps" / f"{name}.tif")
        assert back.shape == dem.shape and "32633" in back.crs
        assert back.transform == pytest.approx(dem.transform)
    depth = hio.read(out / "maps" / "max_water_depth.tif").z
    assert depth[8:13, 10:14].max() >= 0.75  # the lake around the seed: a layer or more of 1 m particles


@pytest.mark.parametrize("ext", [".asc", ".tif"])
def test_a_dem_gives_its_own_cell_size(tmp_path, ext):
    """3 m cells, not the library scenario's 2 m (which describe its generated terrain); the maps come
    back on the DEM's grid."""
    dem_path, dem = _dem(tmp_path, ext, cell=3.0)
    out = tmp_path / "run"
    code, text = _cli("run", "rain-erosion", "--out", str(out), "--set", f"terrain.file={dem_path}",
                      *_sets(["run.t_end=0.1", "rain.rate=0", "water.level=100.5", "sph.spacing=1.0",
                              "run.map_frames=0"]))  # fmt: skip
    assert code == 0, text
    assert json.loads((out / "report.json").read_text())["terrain"]["cell_size_m"] == 3.0
    assert hio.read(out / "maps" / "height.tif").transform == pytest.approx(dem.transform)


SMALL_RAIN = ["terrain.size=12", "terrain.cell_size=2.0", "sph.spacing=1.0", "rain.every=5", "run.map_frames=0",
              "rain.rate=4e5", "edges.outflow=[\"north\", \"east\"]", "terrain.relief=4.0"]  # fmt: skip


@pytest.mark.parametrize("transport", ["particles", "semi-lagrangian"])
def test_budgets_close_with_open_edges(tmp_path, transport):
    sc = loader.load("rain-erosion", SMALL_RAIN + ["run.t_end=1.5", f"erosion.transport={transport}"])
    summary, sim = runner.execute(sc, RunFolder(tmp_path / transport), progress=False)
    rep = json.loads((tmp_path / transport / "report.json").read_text())
    wb, sb = rep["water_budget"], rep["sediment_budget"]
    assert wb["left_edges"] > 0 and wb["closure_rel"] < 1e-12
    assert sb["eroded"] > 0 and sb["closure_rel"] < 1e-9
    if transport == "particles":
        assert sb["transport_error"] == 0.0 and sb["carried_off"] > 0  # sediment left with the water
    else:
        assert sb["transport_error"] != 0.0  # the backward step gains or loses sediment: reported


def test_resume_after_ctrl_c_is_bit_identical(tmp_path, monkeypatch):
    from erosim.sph.solver import SPHSolver

    sets = SMALL_RAIN + ["run.t_end=0.4", "water.level=3.0"]
    whole = RunFolder(tmp_path / "whole")
    runner.run(loader.load("rain-erosion", sets), whole, progress=False)
    real, calls = SPHSolver.step, {"n": 0}

    def interrupt(self):
        calls["n"] += 1
        if calls["n"] == 57:
            raise KeyboardInterrupt
        return real(self)

    monkeypatch.setattr(SPHSolver, "step", interrupt)
    cut = RunFolder(tmp_path / "cut")
    with pytest.raises(Interrupted):
        runner.run(loader.load("rain-erosion", sets), cut, progress=False)
    monkeypatch.setattr(SPHSolver, "step", real)
    runner.run(loader.load(cut.path / "scenario.toml"), RunFolder(cut.path, resume=True), resume=True,
               progress=False)  # fmt: skip
    for name in ("height", "water_depth", "sediment"):
        a = hio.read(whole.path / "maps" / f"{name}.tif").z
        b = hio.read(cut.path / "maps" / f"{name}.tif").z
        assert np.array_equal(a, b), name
    ra, rb = (json.loads((p / "report.json").read_text()) for p in (whole.path, cut.path))
    assert ra["water_budget"] == rb["water_budget"] and ra["steps"] == rb["steps"]


def test_violent_inflow_on_steep_nodata_bordered_ground_stays_above_it(tmp_path):
    """A cliff and a block of nodata (a wall) beside a jet of 2 m³/s: no particle ever below the ground."""
    ny, nx = 14, 14
    z = np.zeros((ny, nx))
    z[:, 9:] = 3.0  # a 3 m cliff over one 0.5 m cell
    nodata = np.zeros((ny, nx), bool)
    nodata[2:6, 2:5] = True
    z[nodata] = np.nan
    np.save(tmp_path / "dem.npy", z)
    for model in ("heightfield", "particles"):
        out = tmp_path / model
        code, text = _cli(
            "run", "rain-erosion", "--out", str(out), "--set", f"terrain.file={tmp_path / 'dem.npy'}",
            *_sets(["terrain.cell_size=0.5", "sph.spacing=0.25", "rain.rate=0", "run.t_end=0.4",
                    "inflows.jet.position=[3.5, 4.5]", "inflows.jet.discharge=2.0", "inflows.jet.radius=0.3",
                    "inflows.jet.height=1.5", f"ground.model={model}", "run.map_frames=0", "erosion.every=5"]),
        )  # fmt: skip
        assert code == 0, text
        rep = json.loads((out / "report.json").read_text())
        assert rep["water_budget"]["inflow"] > 0.5
        assert rep["particles_below_ground"] == 0, model
        assert rep["terrain"]["nodata_cells"] == 12


@pytest.mark.parametrize(
    "sets, words",
    [
        (["rain.file={rain3}"], "Rain map"),
        (["terrain.file={nan}"], "no valid height"),
        (["water.level=99.5", "water.seed=[1.0, 1.0]"], "outside the terrain"),
        (["water.level=99.5", "water.seed=[500002.0, 4100002.0]"], "not below water.level"),
        (["sph.spacing=5.0"], "cannot follow the ground"),
        (["sph.walls=particles"], "ground and the map edges are the walls"),
        (["rain.rate=1e9", "run.t_end=100"], "of memory, but only"),
    ],
)
def test_bad_input_is_one_sentence_and_leaves_no_folder(tmp_path, sets, words):
    dem_path, _ = _dem(tmp_path)
    np.save(tmp_path / "rain3.npy", np.ones((3, 3)))
    np.save(tmp_path / "nan.npy", np.full((8, 8), np.nan))
    files = {"rain3": tmp_path / "rain3.npy", "nan": tmp_path / "nan.npy"}
    extra = [s.format(**files) for s in sets]
    base = [f"terrain.file={dem_path}", "run.t_end=0.1", "sph.spacing=1.0", "rain.rate=100"]
    out = tmp_path / "bad"
    code, text = _cli("run", "rain-erosion", "--out", str(out), *_sets(base + extra))
    assert code == 2, text
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and words in lines[0] and "Traceback" not in text
    assert not out.exists()
