"""Hydrology and the particle stream on the DEMs users bring: the file's own scale with no setting,
nodata kept in the outputs and counted, assumptions stated (issue 12)."""

import json
import re

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.transform import Affine

from erosim.api import run
from erosim.cli import cli
from erosim.io import heightmaps as hio
from erosim.terrain.generate import generate

NODATA = -9999.0


def _dem(path, cell, size=64, relief=115.0, hole=False, seed=4):
    """A georeferenced GeoTIFF (UTM 33N) of ``size``² cells of ``cell`` m; ``hole``: a nodata square
    and a NaN band."""
    z = generate("hills", size, cell, seed=seed, relief=relief).z.astype(np.float32)
    if hole:
        z[20:30, 20:30] = NODATA
        z[:, -4:] = np.nan
    profile = dict(driver="GTiff", height=size, width=size, count=1, dtype="float32", crs="EPSG:32633",
                   transform=Affine(cell, 0, 500000, 0, -cell, 5000000), nodata=NODATA)  # fmt: skip
    with rasterio.open(path, "w", **profile) as ds:
        ds.write(z, 1)
    return path


@pytest.mark.parametrize("cell", [1.0, 20.0, 83.0])
def test_hydrology_runs_at_the_dem_scale_with_no_setting(tmp_path, cell):
    dem = _dem(tmp_path / "dem.tif", cell)
    rep = run("hydrology", tmp_path / "run", set={"terrain.file": str(dem), "run.cycles": 4, "run.frames": 0}).report
    t = rep["terrain"]
    assert t["cell_size_m"] == pytest.approx(cell) and t["cell_size_from"] == "the file"
    assert t["nodata_cells"] == 0 and "UTM zone 33N" in t["crs"]
    # ℓ follows the cell (two cells) and the droplets the map's area in ℓ²: the same on every scale
    assert rep["scaled"]["length_scale_m"] == pytest.approx(2 * cell)
    from erosim.hydrology.params import HydrologyParams

    expected = round(HydrologyParams().cycle_droplets * 64 * 64 / (256 * 2) ** 2)
    assert rep["scaled"]["droplets_per_cycle"] == expected
    assert not any("length_scale" in w for w in rep["warnings"])


def test_nodata_cells_are_counted_and_stay_nodata_in_every_map(tmp_path):
    dem = _dem(tmp_path / "dem.tif", 2.0, hole=True)
    result = run("hydrology", tmp_path / "run", set={"terrain.file": str(dem), "run.cycles": 4, "run.frames": 0})
    hole = np.zeros((64, 64), bool)
    hole[20:30, 20:30] = True
    hole[:, -4:] = True
    assert result.report["terrain"]["nodata_cells"] == int(hole.sum())
    assert any(f"{int(hole.sum())} cells of the terrain are nodata" in w for w in result.report["warnings"])
    for name in ("height", "erosion", "lake_depth", "stream"):
        with rasterio.open(result.path / "maps" / f"{name}.tif") as ds:
            band = ds.read(1, masked=True)
        np.testing.assert_array_equal(np.ma.getmaskarray(band), hole, err_msg=name)
    assert result.report["terrain"]["z_min"] > 0  # the nodata value is not a height


def test_a_png_without_a_cell_size_is_an_assumption_said_aloud(tmp_path):
    from PIL import Image

    png = tmp_path / "dem.png"  # a 16-bit PNG from another tool: heights, no cell size, no world file
    z = generate("hills", 48, 5.0, seed=1).z
    Image.fromarray((1000 * (z - z.min()) / np.ptp(z)).astype(np.uint16)).save(png)
    done = CliRunner().invoke(
        cli, ["run", "hydrology", "--set", f"terrain.file={png}", "--set", "run.cycles=2", "--set", "run.frames=0",
              "--out", str(tmp_path / "run")], prog_name="erosim",
    )  # fmt: skip
    assert done.exit_code == 0, done.stderr
    err = done.stderr
    assert re.search(r"assumed: terrain: 48 × 48 cells of 1 m \(assumed: the file stores none", err)
    assert "warning: 'dem.png' stores no cell size, so 1 m was assumed" in err
    rep = json.loads((tmp_path / "run" / "report.json").read_text())
    assert rep["terrain"]["cell_size_from"].startswith("assumed")


def test_the_stream_cuts_a_canyon_to_the_dem_scale(tmp_path):
    """On a 1 m lidar-like tile of 31 m relief the library stream cut a 72 m slot (its depth was in
    metres while its widths were in cells); in cells throughout it cuts a canyon shaped as on 10 m cells."""
    dem = _dem(tmp_path / "dem.tif", 1.0, size=256)
    with rasterio.open(dem) as ds:
        relief = float(ds.read(1).max() - ds.read(1).min())
    rep = run("particle-stream", tmp_path / "run", set={"terrain.file": str(dem)}).report
    assert rep["terrain"]["cell_size_m"] == 1.0
    assert 0.5 < rep["max_depth"] < relief  # a canyon, not a scratch and not a slot below the terrain


def test_nodata_cells_drain_water_like_the_map_edge():
    """A bowl holds its rain as a lake; with its centre nodata the same rain leaves there instead."""
    from erosim.core.heightmap import Heightmap
    from erosim.hydrology.model import HydrologyModel
    from erosim.hydrology.params import HydrologyParams, VegetationParams
    from erosim.hydrology.pools import OUTSIDE

    y, x = np.mgrid[0:64, 0:64]
    r = np.hypot(x - 31.5, y - 31.5)
    results = {}
    for hole in (False, True):
        hm = Heightmap(z=0.05 * r**2, cell_size=5.0, nodata=r < 4 if hole else None)
        model = HydrologyModel(hm, HydrologyParams(cycle_droplets=2000), VegetationParams(), seed=1)
        for _ in range(30):
            model.advance()
        results[hole] = model.water_budget(), model.lake_depth()
        if hole:  # outside the world: never eroded, filled or made a lake, whatever reached it
            np.testing.assert_array_equal(model.z[r < 4], model.z0[r < 4])
            assert (model.lake_of.reshape(r.shape)[r < 4] == OUTSIDE).all()
    closed, drained = results[False][0], results[True][0]
    assert closed["left_edges"] == 0 and closed["in_lakes"] > 0.9 * closed["rained"]
    # most of the rain reaches the hole and leaves (the rest evaporates on the way or fills pits)
    assert drained["left_edges"] > 0.8 * drained["rained"] and abs(drained["closure_rel"]) < 1e-12
    assert not (results[True][1][r < 4] > 0).any()  # no lake stands in the hole


def test_scaled_copies_of_a_terrain_erode_alike_at_1_20_and_83_m():
    """The same terrain scaled to 1 m, 20 m and 83 m cells (heights scaled too) runs the same hydrology
    in cell units: ℓ, the droplets' volume, speed and capacity all follow the cell. Not bit for bit —
    rounding differs with the scale and single droplets diverge — so compared by correlation; measured
    0.98 for erosion and stream, 0.96 for lakes, on this 96² map."""
    from erosim.core.heightmap import Heightmap
    from erosim.hydrology.model import HydrologyModel
    from erosim.hydrology.params import HydrologyParams, VegetationParams

    base = generate("mountains", 96, 20.0, seed=3)
    out = {}
    for cell in (1.0, 20.0, 83.0):
        model = HydrologyModel(Heightmap(z=base.z * cell / 20.0, cell_size=cell), HydrologyParams(),
                               VegetationParams(), seed=1)  # fmt: skip
        for _ in range(60):
            model.advance()
        out[cell] = model.erosion() / cell, model.stream.copy()
    for cell in (1.0, 83.0):
        for k in (0, 1):
            assert np.corrcoef(out[cell][k].ravel(), out[20.0][k].ravel())[0, 1] > 0.9


def test_the_stream_cuts_the_same_canyon_in_cells_on_any_scale(tmp_path):
    """In cells throughout (stream.length_unit), a scaled copy of a terrain on uniform rock is cut
    alike: erosion / cell size agrees to 1e-4 of the deepest cut. The graded bed bounds each cut at
    h(P) − F, a difference of two interpolated heights, so float64 rounding that differs between the
    scales moves clamped cells by an ulp of the relief per impact and the offsets add up over ~3·10⁵
    impacts (measured: 1.8e-5 cells, 1.3e-5 relative); a canyon that scaled wrongly would differ in
    whole cells."""
    from erosim.core.heightmap import Heightmap

    base = generate("hills", 96, 10.0, seed=3, relief=115.0)
    out = {}
    for cell in (1.0, 10.0, 83.0):
        dem = tmp_path / f"dem{cell:g}.tif"
        hio.write(dem, Heightmap(z=base.z * cell / 10.0, cell_size=cell))
        result = run("particle-stream", tmp_path / f"run{cell:g}",
                     set={"terrain.file": str(dem), "hardness.source": "uniform"})  # fmt: skip
        out[cell] = hio.read(result.path / "maps" / "erosion.tif").z / cell
    assert out[10.0].max() > 0.5  # a canyon was cut
    for cell in (1.0, 83.0):
        np.testing.assert_allclose(out[cell], out[10.0], rtol=0, atol=1e-4 * out[10.0].max())


def test_the_stream_leaves_at_nodata_and_never_cuts_it(tmp_path):
    """A nodata band across the stream's path: no cell of it is cut, and the canyon stops at it."""
    dem = tmp_path / "dem.tif"
    z = generate("hills", 128, 10.0, seed=4, relief=115.0).z.astype(np.float32)
    z[:, 60:70] = NODATA  # a north-south band of no data in the stream's way (it runs east)
    profile = dict(driver="GTiff", height=128, width=128, count=1, dtype="float32", crs="EPSG:32633",
                   transform=Affine(10.0, 0, 500000, 0, -10.0, 5000000), nodata=NODATA)  # fmt: skip
    with rasterio.open(dem, "w", **profile) as ds:
        ds.write(z, 1)
    result = run("particle-stream", tmp_path / "run", set={"terrain.file": str(dem)})
    with rasterio.open(result.path / "maps" / "erosion.tif") as ds:
        erosion = ds.read(1, masked=True)
    assert np.ma.getmaskarray(erosion)[:, 60:70].all() and result.report["terrain"]["nodata_cells"] == 128 * 10
    cut = np.ma.filled(erosion, 0.0)
    assert cut[:, :60].max() > 1.0  # the canyon west of the band
    assert cut[:, 70:].max() < 0.05 * cut[:, :60].max()  # particles left at the band: nothing beyond it
    with rasterio.open(result.path / "maps" / "height.tif") as ds:
        assert np.ma.getmaskarray(ds.read(1, masked=True))[:, 60:70].all()


def test_stream_cells_outside_the_map_keep_their_height():
    from erosim.erosion.particle_stream_warszawski import Emitter, ParticleStream

    h = generate("hills", 64, 10.0, seed=1).z
    outside = np.zeros(h.shape, bool)
    outside[:, 30:34] = True
    em = [Emitter(x=0.05, y=0.5, width=60.0, particles=300, steps=60, speed=10.0, max_speed=20.0,
                  radius_per_mass=30.0, depth_per_mass=0.05, slope_exponent=0.0)]  # fmt: skip
    stream = ParticleStream(h, np.full(h.shape, 0.3), 10.0, em, seed=2, outside=outside)
    while not stream.done:
        stream.advance()
    np.testing.assert_array_equal(stream.h[outside], h[outside])
    assert (h - stream.h)[:, :30].max() > 0.1


def test_a_dem_with_a_geotransform_and_no_crs_says_its_positions_are_the_files():
    """A mesh rasterised to local coordinates has a geotransform and no CRS: seeds and barriers are in
    those coordinates, and the "assumed" line must not say they count from the south-west corner."""
    from erosim.core.heightmap import Heightmap
    from erosim.scenarios.schema_common import TerrainSection, terrain_facts

    z = np.zeros((4, 5))
    local = Heightmap(z=z, cell_size=20.0, transform=(20.0, 0.0, 530.0, 0.0, -20.0, 6842.0))
    _, lines = terrain_facts(local, TerrainSection(file="mesh.tif"))
    assert "CRS: none (positions in the file's map units, from its geotransform: x 530..630, y 6762..6842)" in lines
    _, lines = terrain_facts(Heightmap(z=z, cell_size=20.0), TerrainSection())
    assert "CRS: none (positions in metres from the map's south-west corner)" in lines
