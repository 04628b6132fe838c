"""write_raster: maps of values on a DEM's grid (flood outputs, issue 9 item 6) round-trip through GeoTIFF
with their values, type, CRS, transform and nodata."""

import numpy as np
import pytest
import rasterio
from rasterio.crs import CRS

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap
from erosim.io import heightmaps as hio

UTM = CRS.from_epsg(32633)
T = (5.0, 0.0, 440123.0, 0.0, -5.0, 5100456.0)


@pytest.fixture
def dem():
    nodata = np.zeros((7, 9), bool)
    nodata[0, :2] = True
    return Heightmap(z=np.arange(63.0).reshape(7, 9), cell_size=5.0, crs=UTM.to_wkt(), transform=T, nodata=nodata)


def _open(path):
    with rasterio.open(path) as ds:
        return ds.read(1), ds.dtypes[0], ds.crs, tuple(ds.transform)[:6], ds.nodata


def test_float_map_round_trip(tmp_path, dem):
    rng = np.random.default_rng(0)
    depth = rng.uniform(0.0, 3.0, dem.shape)
    depth[3, 3] = np.inf  # never wet (an arrival time)
    never = np.zeros(dem.shape, bool)
    never[6, 8] = True
    info = hio.write_raster(tmp_path / "maps" / "max_depth.tif", depth, dem, mask=never)
    band, dtype, crs, transform, nodata = _open(tmp_path / "maps" / "max_depth.tif")
    assert (dtype, nodata, info["nodata"], info["nodata_cells"]) == ("float32", -9999.0, -9999.0, 4)
    assert crs == UTM and transform == T
    out = dem.nodata | never
    out[3, 3] = True
    assert np.array_equal(band == -9999.0, out)
    assert np.array_equal(band[~out], depth[~out].astype(np.float32))  # exact to float32
    back = hio.read(tmp_path / "maps" / "max_depth.tif")
    assert back.cell_size == dem.cell_size and back.transform == T
    assert np.array_equal(back.nodata, out)


def test_uint8_map_round_trip(tmp_path, dem):
    classes = (np.arange(63).reshape(7, 9) % 7).astype(np.uint8)  # 0 dry, 1..6
    hio.write_raster(tmp_path / "hazard.tif", classes, dem)
    band, dtype, crs, transform, nodata = _open(tmp_path / "hazard.tif")
    assert (dtype, nodata) == ("uint8", 255.0)
    assert crs == UTM and transform == T
    assert np.array_equal(band[dem.nodata], [255, 255])
    assert np.array_equal(band[~dem.nodata], classes[~dem.nodata])


def test_map_of_a_generated_terrain_gets_the_default_transform(tmp_path):
    hm = Heightmap(z=np.zeros((4, 6)), cell_size=2.0)
    hio.write_raster(tmp_path / "a.tif", np.ones((4, 6)), hm, nodata=-1.0)
    band, _, crs, transform, nodata = _open(tmp_path / "a.tif")
    assert crs is None and transform == (2.0, 0.0, 0.0, 0.0, -2.0, 8.0) and nodata == -1.0
    assert (band == 1.0).all()


@pytest.mark.parametrize(
    "name, array, kwargs, words",
    [
        ("a.png", np.zeros((7, 9)), {}, "maps of values are GeoTIFF; name it .tif"),
        ("a.tif", np.zeros((3, 3)), {}, r"has shape \(3, 3\) but the DEM \(7, 9\); they must match"),
        ("a.tif", np.full((7, 9), 255, np.uint8), {}, "holds the nodata value 255 in cells with data"),
        ("a.tif", np.zeros((7, 9), np.uint8), {"nodata": 300}, "does not fit the map's type uint8"),
        ("a.tif", np.full((7, 9), "x"), {}, "give numbers"),
    ],
)
def test_bad_maps_are_one_sentence(tmp_path, dem, name, array, kwargs, words):
    with pytest.raises(InputError, match=words):
        hio.write_raster(tmp_path / name, array, dem, **kwargs)
    assert list(tmp_path.iterdir()) == []  # nothing half-written
