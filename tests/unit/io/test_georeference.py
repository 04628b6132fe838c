"""Georeference survives every format: .prj + world-file sidecars beside PNG, RAW16, NPY and ASC."""

import numpy as np
import pytest
from rasterio.crs import CRS

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap
from erosim.io import heightmaps as io

UTM33 = CRS.from_epsg(32633)
CELL = 10.0
TRANSFORM = (CELL, 0.0, 440123.0, 0.0, -CELL, 5100456.0)  # origin off the 10 m grid
SIDECARS = {  # format -> the sidecars it writes besides the map itself
    ".png": ["m.pgw", "m.prj"],
    ".r16": ["m.prj", "m.wld"],
    ".npy": ["m.prj", "m.wld"],
    ".asc": ["m.prj"],  # the corner and cell size are in the grid's header
}


@pytest.fixture
def geo_hm():
    z = 300.0 + np.arange(48.0).reshape(6, 8) * 2.5  # 8 x 6 cells, 300..417.5 m
    return Heightmap(z=z, cell_size=CELL, crs=UTM33.to_wkt(), transform=TRANSFORM)


def _read(path, hm):
    raw_shape = hm.shape if path.suffix == ".r16" else None
    return io.read(path, raw_shape=raw_shape, height_range=(hm.z.min(), hm.z.max()))


@pytest.mark.parametrize("ext", list(SIDECARS))
def test_crs_and_transform_round_trip(tmp_path, geo_hm, ext):
    info = io.write(tmp_path / f"m{ext}", geo_hm)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([f"m{ext}", *SIDECARS[ext]])
    assert sorted(info["sidecars"]) == sorted(str(tmp_path / n) for n in SIDECARS[ext])
    back = _read(tmp_path / f"m{ext}", geo_hm)
    assert back.crs is not None and CRS.from_wkt(back.crs) == UTM33
    assert back.transform == pytest.approx(TRANSFORM, abs=1e-9)
    assert back.cell_size == pytest.approx(CELL, rel=1e-12)  # RAW16 and NPY get it from the world file
    assert back.shape == geo_hm.shape


@pytest.mark.parametrize("ext", list(SIDECARS))
def test_ungeoreferenced_map_writes_no_sidecar(tmp_path, geo_hm, ext):
    info = io.write(tmp_path / f"m{ext}", Heightmap(z=geo_hm.z, cell_size=CELL))
    assert [p.name for p in tmp_path.iterdir()] == [f"m{ext}"]
    assert "sidecars" not in info and info["georeference"] == "none in the source"
    back = _read(tmp_path / f"m{ext}", geo_hm)
    assert back.crs is None


def test_world_file_holds_the_centre_of_the_upper_left_pixel(tmp_path, geo_hm):
    io.write(tmp_path / "m.png", geo_hm)
    io.write(tmp_path / "m.r16", geo_hm)
    for name in ("m.pgw", "m.wld"):
        a, d, b, e, c, f = (float(v) for v in (tmp_path / name).read_text().split())
        assert (a, d, b, e) == (CELL, 0.0, 0.0, -CELL)
        assert c == TRANSFORM[2] + 0.5 * CELL  # 440128: half a cell east of the west edge
        assert f == TRANSFORM[5] - 0.5 * CELL  # 5100451: half a cell south of the north edge


def test_prj_holds_the_crs_as_wkt(tmp_path, geo_hm):
    info = io.write(tmp_path / "m.asc", geo_hm)
    text = (tmp_path / "m.prj").read_text()
    assert text.startswith("PROJCS[") and CRS.from_wkt(text) == UTM33
    assert info["georeference"] == "transform in the header, CRS in m.prj"
    header = (tmp_path / "m.asc").read_text().splitlines()[:5]
    assert header[2:] == ["xllcorner 440123.0", "yllcorner 5100396.0", "cellsize 10.0"]  # 5100456 - 6 x 10


def test_convert_tif_png_tif_keeps_crs_and_transform(tmp_path, geo_hm):
    io.write(tmp_path / "dem.tif", geo_hm)
    info = io.convert(tmp_path / "dem.tif", tmp_path / "x.png")
    assert info["crs"].startswith("EPSG:")
    assert info["georeference"] == "CRS and transform in x.prj + x.pgw"
    assert any("65 536 levels" in s for s in info["not_kept"])
    info = io.convert(tmp_path / "x.png", tmp_path / "y.tif")
    assert info["georeference"] == "CRS and transform in the file"
    back = io.read(tmp_path / "y.tif")
    assert CRS.from_wkt(back.crs) == UTM33
    assert back.transform == pytest.approx(TRANSFORM, abs=1e-9)
    assert back.cell_size == CELL


def test_convert_says_what_raw16_cannot_hold(tmp_path, geo_hm):
    z = geo_hm.z.copy()
    z[0, 0] = np.nan
    io.write(tmp_path / "dem.npz", Heightmap(z=z, cell_size=CELL, crs=geo_hm.crs, transform=TRANSFORM))
    info = io.convert(tmp_path / "dem.npz", tmp_path / "x.r16")
    assert info["georeference"] == "CRS and transform in x.prj + x.wld"
    lost = " | ".join(info["not_kept"])
    assert "height range: give --height-range 302.5 417.5" in lost  # nodata cell filled from z[0, 1]
    assert "--raw-shape 6 8" in lost and "nodata: 1 cells" in lost
    assert "cell size" not in lost  # the world file keeps it


def test_asc_with_rectangular_cells_keeps_dx_dy(tmp_path, geo_hm):
    t = (0.001, 0.0, -84.4, 0.0, -0.00075, 36.6)
    io.write(tmp_path / "g.asc", Heightmap(z=geo_hm.z, cell_size=83.0, crs=CRS.from_epsg(4326).to_wkt(), transform=t))
    back = io.read(tmp_path / "g.asc")
    assert back.transform == pytest.approx(t, abs=1e-12)
    assert CRS.from_wkt(back.crs) == CRS.from_epsg(4326)
    # metres, not degrees: 0.001° E-W is 89.5 m and 0.00075° N-S 83.2 m at 36.6° N; equal-area square
    assert back.cell_size == pytest.approx(86.3, rel=0.002)


def test_unreadable_world_file_is_one_sentence_and_an_unreadable_prj_is_skipped(tmp_path, geo_hm):
    io.write(tmp_path / "m.png", geo_hm)
    (tmp_path / "m.pgw").write_text("10\n0\n0\n")
    with pytest.raises(InputError, match="^World file .* does not hold six numbers"):
        io.read(tmp_path / "m.png")
    (tmp_path / "m.pgw").unlink()
    (tmp_path / "m.prj").write_text("Projection UTM\nZone 33\nDatum WGS84\nUnits METERS")  # old ArcInfo style
    with pytest.warns(UserWarning, match="holds no CRS erosim can read"):
        back = io.read(tmp_path / "m.png")  # the heights still load, without a CRS
    assert back.crs is None
    np.testing.assert_allclose(back.z, geo_hm.z, atol=(geo_hm.z.max() - geo_hm.z.min()) / 65535)
