"""Heightmap files: every format round-trips; bad inputs give one clear sentence."""

import numpy as np
import pytest

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap
from erosim.io import heightmaps as io

UTM33 = 'PROJCS["WGS 84 / UTM zone 33N",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],PARAMETER["latitude_of_origin",0],PARAMETER["central_meridian",15],PARAMETER["scale_factor",0.9996],PARAMETER["false_easting",500000],PARAMETER["false_northing",0],UNIT["metre",1],AUTHORITY["EPSG","32633"]]'  # noqa: E501


@pytest.fixture
def hm():
    rng = np.random.default_rng(0)
    z = 120.0 + 80.0 * rng.random((23, 31))
    return Heightmap(z=z, cell_size=5.0)


@pytest.fixture
def geo_hm(hm):
    return Heightmap(z=hm.z, cell_size=5.0, crs=UTM33, transform=(5.0, 0.0, 440000.0, 0.0, -5.0, 5100000.0))


def test_geotiff_keeps_crs_transform_and_float32_heights(tmp_path, geo_hm):
    info = io.write(tmp_path / "a.tif", geo_hm)
    assert info["format"] == "geotiff"
    back = io.read(tmp_path / "a.tif")
    assert back.transform == geo_hm.transform
    from rasterio.crs import CRS

    assert CRS.from_wkt(back.crs) == CRS.from_epsg(32633)
    assert back.cell_size == 5.0
    # Stored as float32: relative rounding 2^-24 of heights ~200 m.
    np.testing.assert_allclose(back.z, geo_hm.z, rtol=2**-23, atol=0)


def test_geotiff_nodata_becomes_mask_and_is_filled(tmp_path, geo_hm):
    z = geo_hm.z.copy()
    z[:3, :4] = np.nan
    io.write(tmp_path / "n.tif", Heightmap(z=z, cell_size=5.0, crs=UTM33, transform=geo_hm.transform))
    back = io.read(tmp_path / "n.tif")
    assert back.nodata is not None and back.nodata.sum() == 12 and back.nodata[:3, :4].all()
    assert np.isfinite(back.z).all()
    # Filled with nearest valid heights: inside the valid data's range.
    valid = geo_hm.z[~back.nodata]
    assert valid.min() - 1e-3 <= back.z[:3, :4].min() and back.z[:3, :4].max() <= valid.max() + 1e-3


def test_plain_geotiff_round_trips_cell_size(tmp_path, hm):
    io.write(tmp_path / "p.tiff", hm)
    back = io.read(tmp_path / "p.tiff")
    assert back.cell_size == hm.cell_size and back.crs is None
    np.testing.assert_allclose(back.z, hm.z, rtol=2**-23)


@pytest.mark.parametrize("ext", [".png", ".raw", ".r16"])
def test_16bit_formats_within_one_quantisation_step(tmp_path, hm, ext):
    info = io.write(tmp_path / f"h{ext}", hm)
    lo, hi = info["height_range"]
    assert lo == hm.z.min() and hi == hm.z.max()
    back = io.read(tmp_path / f"h{ext}", height_range=(lo, hi), raw_shape=hm.shape if ext != ".png" else None)
    step = (hi - lo) / 65535
    assert np.abs(back.z - hm.z).max() <= 0.5 * step + 1e-12  # rounding to the nearest level


def test_png16_carries_its_height_range_and_cell_size(tmp_path, hm):
    io.write(tmp_path / "h.png", hm, height_range=(100.0, 300.0))
    back = io.read(tmp_path / "h.png")
    assert back.cell_size == 5.0
    assert np.abs(back.z - hm.z).max() <= 0.5 * 200.0 / 65535 + 1e-12


def test_raw16_square_size_is_inferred(tmp_path):
    z = np.linspace(0, 1000, 64 * 64).reshape(64, 64)
    io.write(tmp_path / "s.raw", z, height_range=(0, 1000))
    assert (tmp_path / "s.raw").stat().st_size == 64 * 64 * 2
    back = io.read(tmp_path / "s.raw", height_range=(0, 1000), cell_size=2.0)
    assert back.shape == (64, 64) and back.cell_size == 2.0
    assert np.abs(back.z - z).max() <= 0.5 * 1000 / 65535 + 1e-12
    # Little-endian uint16, row-major, no header: first and last samples.
    raw = np.fromfile(tmp_path / "s.raw", dtype="<u2")
    assert raw[0] == 0 and raw[-1] == 65535


@pytest.mark.parametrize("ext", [".asc", ".npy", ".npz"])
def test_exact_formats(tmp_path, hm, ext):
    io.write(tmp_path / f"e{ext}", hm)
    back = io.read(tmp_path / f"e{ext}", cell_size=None if ext != ".npy" else 5.0)
    assert np.array_equal(back.z, hm.z)
    assert back.cell_size == 5.0


def test_asc_keeps_corner_and_nodata(tmp_path, geo_hm):
    z = geo_hm.z.copy()
    z[5, 5] = np.nan
    io.write(tmp_path / "g.asc", Heightmap(z=z, cell_size=5.0, transform=geo_hm.transform))
    back = io.read(tmp_path / "g.asc")
    assert back.transform == geo_hm.transform
    assert back.nodata is not None and back.nodata.sum() == 1 and back.nodata[5, 5]
    assert np.array_equal(back.z[~back.nodata], geo_hm.z[~back.nodata])


def test_npz_keeps_georeference(tmp_path, geo_hm):
    io.write(tmp_path / "g.npz", geo_hm)
    back = io.read(tmp_path / "g.npz")
    assert back.crs == geo_hm.crs and back.transform == geo_hm.transform


def test_convert_between_formats(tmp_path, geo_hm):
    io.write(tmp_path / "src.tif", geo_hm)
    info = io.convert(tmp_path / "src.tif", tmp_path / "dst.asc", cell_size=None)
    assert info["crs"].startswith("EPSG:") and info["shape"] == [23, 31]
    back = io.read(tmp_path / "dst.asc")
    np.testing.assert_allclose(back.z, geo_hm.z, rtol=2**-23)
    info = io.convert(tmp_path / "dst.asc", tmp_path / "dst.png")
    assert info["height_range"] == [pytest.approx(back.z.min()), pytest.approx(back.z.max())]


def test_sample_jacksboro():
    hm = io.read("sample:jacksboro")
    assert hm.shape == (344, 403)
    assert hm.cell_size == io.JACKSBORO_CELL
    assert 200 < hm.z.min() < hm.z.max() < 1200  # metres above sea level in the Tennessee valley
    assert hm.crs is not None


def test_mask_png16(tmp_path):
    a = np.array([[0.0, 0.5], [1.0, 2.0]])
    info = io.write_mask_png16(tmp_path / "m.png", a, vmax=1.0)
    assert info["vmax"] == 1.0
    back = io.read(tmp_path / "m.png")  # range 0..vmax comes from the text chunk
    np.testing.assert_allclose(back.z, [[0, 0.5], [1, 1]], atol=0.5 / 65535 + 1e-12)


def test_bad_inputs(tmp_path, hm):
    with pytest.raises(InputError, match="does not exist"):
        io.read(tmp_path / "missing.tif")
    with pytest.raises(InputError, match="unknown extension '.xyz'"):
        io.read(tmp_path / "a.xyz")
    with pytest.raises(InputError, match="unknown extension"):
        io.write(tmp_path / "a.jpg", hm)
    (tmp_path / "bad.raw").write_bytes(b"\0" * (2 * 30))
    with pytest.raises(InputError, match="not a square map; give raw_shape"):
        io.read(tmp_path / "bad.raw")
    with pytest.raises(InputError, match="raw_shape 4x4 needs 16"):
        io.read(tmp_path / "bad.raw", raw_shape=(4, 4))
    with pytest.raises(InputError, match="positive number of metres"):
        io.read(tmp_path / "bad.raw", raw_shape=(5, 6), cell_size=-2)
    np.save(tmp_path / "nan.npy", np.full((4, 4), np.nan))
    with pytest.raises(InputError, match="no valid height"):
        io.read(tmp_path / "nan.npy")
    (tmp_path / "corrupt.tif").write_bytes(b"not a tiff")
    with pytest.raises(InputError, match="Cannot read heightmap"):
        io.read(tmp_path / "corrupt.tif")
    with pytest.raises(InputError, match="Unknown sample DEM"):
        io.read("sample:nowhere")
    with pytest.raises(InputError, match="low < high"):
        io.read(tmp_path / "bad.raw", raw_shape=(5, 6), height_range=(5, 1))


def test_writes_leave_no_temporary_files(tmp_path, hm):
    for ext in io.FORMATS:
        io.write(tmp_path / f"x{ext}", hm)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"x{ext}" for ext in io.FORMATS)


def test_heightmap_validation_and_helpers():
    with pytest.raises(InputError, match="positive number of metres"):
        Heightmap(z=np.zeros((3, 3)), cell_size=-1.0)
    with pytest.raises(InputError, match="positive number of metres"):
        Heightmap(z=np.zeros((3, 3)), cell_size=float("nan"))
    with pytest.raises(InputError, match="2-D array of at least 2x2"):
        Heightmap(z=np.zeros(5), cell_size=1.0)
    with pytest.raises(InputError, match="no valid height"):
        Heightmap(z=np.full((3, 3), np.nan), cell_size=1.0)
    with pytest.raises(InputError, match="nodata mask has shape"):
        Heightmap(z=np.zeros((3, 3)), nodata=np.zeros((2, 2), bool))
    z = np.arange(16.0).reshape(4, 4)
    z[0, 0] = np.nan
    hm = Heightmap(z=z, cell_size=2.0)
    assert hm.nodata[0, 0] and hm.nodata.sum() == 1 and hm.z[0, 0] in (1.0, 4.0)  # nearest cell
    assert hm.z.dtype == np.float64 and hm.z.flags.c_contiguous
    assert hm.extent == (0.0, 8.0, 0.0, 8.0) and hm.shape == (4, 4)
    c = hm.copy()
    c.z[1, 1] = -1.0
    assert hm.z[1, 1] == 5.0  # copies do not share memory


def test_eight_bit_png_is_scaled_by_its_own_range(tmp_path):
    from PIL import Image

    Image.fromarray(np.array([[0, 255], [51, 102]], dtype=np.uint8)).save(tmp_path / "g.png")
    back = io.read(tmp_path / "g.png", height_range=(0.0, 100.0))
    np.testing.assert_allclose(back.z, [[0.0, 100.0], [20.0, 40.0]], atol=1e-12)


def test_foreign_geographic_geotiff_gets_a_metric_cell_size(tmp_path):
    # A GeoTIFF written by another tool: lon/lat grid of 3 arc-seconds at 36.6° N, NaN as nodata.
    import rasterio
    from rasterio.transform import Affine

    z = np.full((20, 30), 500.0, dtype=np.float32)
    z[0, :5] = np.nan
    step = 3.0 / 3600.0
    profile = dict(
        driver="GTiff", height=20, width=30, count=1, dtype="float32", crs="EPSG:4326",
        transform=Affine(step, 0, -84.4, 0, -step, 36.6 + 10 * step), nodata=float("nan"),
    )  # fmt: skip
    with rasterio.open(tmp_path / "geo.tif", "w", **profile) as ds:
        ds.write(z, 1)
    hm = io.read(tmp_path / "geo.tif")
    # 3" is 74.5 m E-W and 92.5 m N-S there; the equal-area square cell is ~83 m (±0.5 %).
    assert hm.cell_size == pytest.approx(83.0, rel=0.005)
    assert hm.nodata is not None and hm.nodata.sum() == 5
    assert np.all(hm.z == 500.0)
