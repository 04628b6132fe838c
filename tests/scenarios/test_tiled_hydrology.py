"""A tiled hydrology build (erosim.tiles) against an untiled run of the same DEM: the mosaic's grid,
heights away from borders, seam figures, droplets passed between tiles in rounds, resume per tile and
round, bad input. One local Dask cluster serves every build of the module; the builds form the
``multiprocess`` tier (``make test-multiprocess``, which CI runs after the default run), the resume
tests (more builds) are also marked slow; bad input stays in the default run."""

import itertools
import json
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

import erosim
from erosim.cli import cli
from erosim.core.errors import Interrupted
from erosim.io import heightmaps as hio
from erosim.sweep import dask_executor
from erosim.terrain.generate import generate
from erosim.tiles.build import run_tiled

sys.path.insert(0, str(Path(__file__).parent))
import tile_members  # noqa: E402

N, TILE, OVERLAP, ROUNDS = 96, 48, 12, 2
# 40 cycles of 18 droplets on 96² cells at 40 m (≈ 1 s a run): rivers (stream ≥ 0.2) form, heights move
# by tens of metres; a faster stream map (0.1) so that 40 cycles draw the rivers
RUN = {"run.cycles": 40, "run.frames": 0, "hydrology.cycle_droplets": 500, "hydrology.stream_rate": 0.1}
UTM = 32633


def _sets(dem) -> list[str]:
    return [f"terrain.file={json.dumps(str(dem))}"] + [f"{k}={v}" for k, v in RUN.items()]


def _tiled_sets(dem) -> list[str]:
    return _sets(dem) + [f"tiles.size={TILE}", f"tiles.overlap={OVERLAP}", f"tiles.rounds={ROUNDS}"]


def _read(path) -> np.ndarray:
    with rasterio.open(path) as ds:
        return ds.read(1).astype(np.float64)


@pytest.fixture(scope="module")
def dem(tmp_path_factory):
    from rasterio.crs import CRS

    hm = generate("mountains", N, 40.0, 3)
    hm.crs = CRS.from_epsg(UTM).to_wkt()
    hm.transform = (40.0, 0.0, 500000.0, 0.0, -40.0, 4000000.0)
    path = tmp_path_factory.mktemp("dem") / "dem.tif"
    hio.write(path, hm)
    return path


@pytest.fixture(scope="module")
def client():
    with dask_executor.connect(None, 2) as c:
        yield c


@pytest.fixture(scope="module")
def tiled(dem, client, tmp_path_factory):
    out = tmp_path_factory.mktemp("tiled") / "build"
    folder, summary = run_tiled("hydrology", _tiled_sets(dem), out=str(out), progress=False, client=client)
    return folder, summary


@pytest.fixture(scope="module")
def untiled(dem, tmp_path_factory):
    base = tmp_path_factory.mktemp("untiled")
    sets = {"terrain.file": str(dem), **RUN}
    return {s: _read(erosim.run("hydrology", base / f"s{s}", set={**sets, "seed": s}).path / "maps" / "height.tif")
            for s in (1, 2)}  # fmt: skip


@pytest.mark.multiprocess
def test_mosaic_is_one_cog_per_map_on_the_dems_grid(tiled, dem):
    folder, summary = tiled
    assert summary["tiles"] == 4 and summary["ran_now"] == 4 * ROUNDS
    with rasterio.open(dem) as ds:
        grid = (ds.shape, ds.crs, ds.transform)
    names = {p.stem for p in (folder / "maps").glob("*.tif")}
    assert {"height", "height_initial", "erosion", "deposition", "stream", "lake_depth", "vegetation"} <= names
    for name in names:
        with rasterio.open(folder / "maps" / f"{name}.tif") as ds:
            assert (ds.shape, ds.crs, ds.transform) == grid, name
            assert ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG", name
    # every tile's input is its window + halo of the DEM, CRS and transform kept
    with rasterio.open(dem) as src:
        for t in json.loads((folder / "tiles.json").read_text())["tiles"]:
            r0, r1, c0, c1 = t["window"]
            with rasterio.open(folder / "tiles" / t["name"] / "input.tif") as ds:
                assert ds.crs == src.crs and ds.shape == (r1 - r0, c1 - c0)
                assert ds.transform == src.transform @ src.transform.translation(c0, r0)
                np.testing.assert_array_equal(ds.read(1), src.read(1)[r0:r1, c0:c1])
    # the mosaic of the tiles' cores of round 1's initial heights is the DEM (float32)
    np.testing.assert_allclose(_read(folder / "maps" / "height_initial.tif"), _read(dem), rtol=1e-6)


@pytest.mark.multiprocess
def test_heights_match_the_untiled_run_away_from_borders(tiled, untiled, dem):
    folder, _ = tiled
    z0, zt = _read(dem), _read(folder / "maps" / "height.tif")
    # away from borders: farther than 2·overlap from the border at 48 (beyond the blend zone and the
    # halo's own edge effects)
    away = np.ones((N, N), bool)
    away[TILE - 2 * OVERLAP : TILE + 2 * OVERLAP, :] = False
    away[:, TILE - 2 * OVERLAP : TILE + 2 * OVERLAP] = False

    def rms(d):
        return float(np.sqrt(np.mean(d[away] ** 2)))

    # Droplets are random: a tiled build is another draw of the same erosion, so the yardstick is the
    # seed-to-seed scatter. Measured on this DEM and run: the rms height difference of two untiled seeds
    # away from borders is 4.86 ± 0.27 m over 15 seed pairs (largest/smallest 1.23); 1.5× one pair's
    # rms covers that scatter. A tiled build that blended wrongly (a shifted or missing tile) differs by
    # the terrain's own relief, tens of metres.
    scatter = rms(untiled[2] - untiled[1])
    assert rms(zt - untiled[1]) <= 1.5 * scatter
    # and it eroded as much as the untiled run did (not a copy of the DEM): rms change within 1.5×
    moved, moved_untiled = rms(zt - z0), rms(untiled[1] - z0)
    assert moved_untiled / 1.5 <= moved <= 1.5 * moved_untiled


@pytest.mark.multiprocess
def test_seam_figures_are_reported_and_measured_right(tiled):
    folder, _ = tiled
    seams = json.loads((folder / "report.json").read_text())["seams"]
    z, s = _read(folder / "maps" / "height.tif"), _read(folder / "maps" / "stream.tif")
    jumps = np.concatenate([np.abs(z[:, TILE] - z[:, TILE - 1]), np.abs(z[TILE] - z[TILE - 1])])
    assert seams["border_pairs"] == 2 * N
    assert seams["border_jump_max_m"] == pytest.approx(jumps.max(), rel=1e-6)
    cores = [(r0, r1, c0, c1) for r0, r1 in ((0, TILE), (TILE, N)) for c0, c1 in ((0, TILE), (TILE, N))]
    inside = np.concatenate(
        [np.abs(np.diff(z[r0:r1, c0:c1], axis=a)).ravel() for r0, r1, c0, c1 in cores for a in (0, 1)]
    )
    assert seams["inside_p999_m"] == pytest.approx(np.quantile(inside, 0.999), rel=1e-6)
    river = s >= 0.2
    touching = int(river[:, TILE - 1].sum() + river[:, TILE].sum() + river[TILE - 1].sum() + river[TILE].sum())
    assert seams["river_cells_at_borders"] == touching
    # the seam target on this build: no jump across a border larger than the 99.9th percentile
    # of the jumps inside tiles (the droplets crossing a border erode both sides of it)
    assert seams["border_jump_max_m"] <= seams["inside_p999_m"]


@pytest.mark.multiprocess
@pytest.mark.slow  # a second build of four tiles in two rounds (~10 s warm, more on a loaded machine)
@pytest.mark.parametrize("stop", ["stop_after_first", "stop_in_round_2"])
def test_a_stopped_tiled_build_resumes_the_rest(stop, tiled, dem, client, tmp_path):
    out = tmp_path / "build"
    with pytest.raises(Interrupted, match="erosim run --resume"):
        run_tiled("hydrology", _tiled_sets(dem), out=str(out), progress=False, client=client,
                  member_function=getattr(tile_members, stop))  # fmt: skip
    rdir = out / "tiles" if stop == "stop_after_first" else out / "tiles" / "round2"
    first = rdir / "r0_c0" / "report.json"
    assert json.loads(first.read_text())["status"] == "completed"
    assert json.loads((out / "report.json").read_text())["status"] == "interrupted"
    assert not (out / "maps").exists()
    stamp = first.stat().st_mtime_ns
    folder, summary = run_tiled(None, resume=str(out), progress=False, client=client)
    assert summary["ran_now"] == (3 + 4 if stop == "stop_after_first" else 3) and first.stat().st_mtime_ns == stamp
    k = 0 if stop == "stop_after_first" else 1
    actions = {r["member"]: r["action"] for r in json.loads((out / "report.json").read_text())["rounds"][k]["tiles"]}
    assert actions == {"r0_c0": "kept", "r0_c1": "ran", "r1_c0": "ran", "r1_c1": "ran"}
    # the same build as the one that ran in one go (tiles are seeded runs, inflows in a fixed order)
    np.testing.assert_array_equal(_read(out / "maps" / "height.tif"), _read(tiled[0] / "maps" / "height.tif"))
    np.testing.assert_array_equal(_read(out / "maps" / "stream.tif"), _read(tiled[0] / "maps" / "stream.tif"))


@pytest.mark.parametrize(
    "args, words",
    [
        (["--tile", "48"], "give it with --set terrain.file"),
        (["--tile", "48", "--overlap", "30", "FILE"], "overlap of at most half the size"),
        (["--workers", "2"], "apply to tiled builds"),
        (["--tile", "48", "SPH"], 'apply to kind = "hydrology" scenarios'),
        (["--tile", "48", "--overlap", "12", "NPY"], "is not a GeoTIFF"),
        (["--tile", "48", "--overlap", "12", "FILE", "--set", "run.device=cuda"], "on the CPU only"),
        (["--tile", "48", "--overlap", "12", "FILE", "--set", "hydrology.batch=0"], "batch path only"),
    ],
)
def test_bad_input_is_one_sentence_and_leaves_nothing(args, words, dem, tmp_path):
    npy = tmp_path / "dem.npy"
    np.save(npy, _read(dem))
    extra = {"FILE": ["--set", f"terrain.file={dem}"], "NPY": ["--set", f"terrain.file={npy}"]}
    argv = list(itertools.chain.from_iterable(extra.get(a, [a]) for a in args))
    out = tmp_path / "out"
    scenario = "dam-break-2d" if "SPH" in args else "hydrology"
    argv = [a for a in argv if a != "SPH"]
    result = CliRunner().invoke(cli, ["--quiet", "run", scenario, *argv, "--out", str(out)])
    assert result.exit_code == 2, result.output
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and words in lines[0], result.output
    assert not out.exists()


@pytest.mark.multiprocess
def test_the_second_round_starts_from_the_first_and_gets_every_droplet_that_crossed(tiled, dem):
    folder, _ = tiled
    report = json.loads((folder / "report.json").read_text())
    assert [r["cycles"] for r in report["rounds"]] == [20, 20]  # run.cycles split over the rounds
    start, stream = (_read(folder / "tiles" / "round2" / f"start_{m}.tif") for m in ("height", "stream"))
    exits, inflow = [], []
    for t in report["plan"]["tiles"]:
        r0, r1, c0, c1 = t["window"]
        one, two = folder / "tiles" / t["name"], folder / "tiles" / "round2" / t["name"]
        np.testing.assert_array_equal(_read(two / "input.tif"), start[r0:r1, c0:c1])
        np.testing.assert_array_equal(_read(two / "stream_in.tif"), stream[r0:r1, c0:c1])
        # round 1's heights mosaicked: the tile's core of its own result (a tile never changes its halo)
        q0, q1, p0, p1 = t["core"]
        z1 = _read(one / "maps" / "height.tif")
        np.testing.assert_array_equal(start[q0:q1, p0:p1], z1[q0 - r0 : q1 - r0, p0 - c0 : p1 - c0])
        halo = z1 - _read(one / "maps" / "height_initial.tif")
        halo[q0 - r0 : q1 - r0, p0 - c0 : p1 - c0] = 0.0
        assert (halo == 0.0).all()
        assert json.loads((two / "report.json").read_text())["statistics"]["cycles"] == 20
        e, i = np.load(one / "exits.npy"), np.load(two / "inflow.npy")
        exits.append(e)
        inflow.append(i)
        # every droplet a tile takes in starts in its core (window coordinates)
        row, col = np.floor(i[:, 2] + 0.5) + r0, np.floor(i[:, 1] + 0.5) + c0
        assert ((row >= q0) & (row < q1) & (col >= p0) & (col < p1)).all()
    exits, inflow = np.concatenate(exits), np.concatenate(inflow)
    # every droplet that left a tile into its halo enters a neighbour, with its water and sediment
    assert exits.shape[0] > 0 and inflow.shape[0] == exits.shape[0]
    assert inflow[:, 5].sum() == pytest.approx(exits[:, 5].sum(), rel=1e-12)
    assert inflow[:, 6].sum() == pytest.approx(exits[:, 6].sum(), rel=1e-12)
    assert report["rounds"][1]["entered"]["droplets"] == inflow.shape[0]
    # the initial height is the DEM's, the erosion is measured from it over both rounds
    z0, z = _read(dem), _read(folder / "maps" / "height.tif")
    np.testing.assert_allclose(_read(folder / "maps" / "height_initial.tif"), z0, rtol=1e-6)
    np.testing.assert_allclose(_read(folder / "maps" / "erosion.tif"), np.maximum(z0 - z, 0), atol=1e-4)


@pytest.mark.multiprocess
def test_every_tile_and_round_draws_its_own_droplets(tiled):
    """Each tile's run in each round has its own seed (tiles.build.member_seed): a tile's run numbers its droplets
    from 0, so with the build's seed everywhere every round rained on the first round's points and every tile on
    the same points of its window."""
    from erosim.scenarios import loader
    from erosim.tiles.build import member_seed

    folder, _ = tiled
    report = json.loads((folder / "report.json").read_text())
    seed = loader.load("hydrology", []).config.seed
    seeds = {}
    for k in range(1, ROUNDS + 1):
        for i, t in enumerate(report["plan"]["tiles"]):
            tdir = folder / "tiles" / (f"round{k}" if k > 1 else "") / t["name"]
            seeds[(k, i)] = json.loads((tdir / "report.json").read_text())["seed"]
    assert seeds == {key: member_seed(seed, *key) for key in seeds}
    assert len(set(seeds.values())) == len(seeds) == ROUNDS * len(report["plan"]["tiles"])


def test_the_python_api_refuses_a_tiled_scenario_instead_of_running_it_whole(dem, tmp_path):
    from erosim.core.errors import ConfigError

    with pytest.raises(ConfigError, match="tiled build"):
        erosim.run(
            "hydrology",
            tmp_path / "whole",
            set={"terrain.file": str(dem), "tiles.size": TILE, "tiles.overlap": OVERLAP},
        )
    assert not (tmp_path / "whole").exists()


@pytest.mark.multiprocess
@pytest.mark.slow  # a cluster of its own (~10 s) and a build
def test_a_scheduler_address_runs_the_same_build(tiled, dem, tmp_path):
    from distributed import LocalCluster

    sets = _tiled_sets(dem)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        folder, summary = run_tiled(
            "hydrology", sets, out=str(tmp_path / "remote"), progress=False, scheduler=cluster.scheduler_address
        )
    assert summary["workers"] == "remote" and summary["ran_now"] == 4 * ROUNDS
    np.testing.assert_array_equal(_read(folder / "maps" / "height.tif"), _read(tiled[0] / "maps" / "height.tif"))
