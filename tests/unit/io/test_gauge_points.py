"""Gauge points from a CSV (issue 9, item 5): what is read, and one sentence for each bad file."""

import numpy as np
import pytest

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap
from erosim.io.gauge_points import read_gauge_points

T = (10.0, 0.0, 500000.0, 0.0, -10.0, 4000100.0)  # 10 m cells: x 500000..500080, y 4000000..4000100


@pytest.fixture
def hm():
    nodata = np.zeros((10, 8), bool)
    nodata[0, 0] = True  # the north-west cell: x 500000..500010, y 4000090..4000100
    return Heightmap(z=np.arange(80.0).reshape(10, 8), cell_size=10.0, transform=T, nodata=nodata)


def _csv(tmp_path, text, name="gauges.csv"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_reads_names_and_coordinates_in_file_order(tmp_path, hm):
    p = _csv(tmp_path, "\ufeffName , X, y,comment\nG2,500015.5,4000050,first\n\nG1, 500079.9 ,4000000.1,\n")
    assert read_gauge_points(p, hm) == [("G2", 500015.5, 4000050.0), ("G1", 500079.9, 4000000.1)]


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "The gauges file '{p}' is empty; give a header line name,x,y and one line per gauge."),
        ("name,x\nA,500010\n", "The gauges file '{p}' lacks the column y; its first line must name the columns "
         "name,x,y."),
        ("id,east,north\nA,1,2\n", "The gauges file '{p}' lacks the columns name, x, y; its first line must name the "
         "columns name,x,y."),
        ("name,x,y\n", "The gauges file '{p}' holds no gauge; add one line name,x,y per gauge below the header."),
        ("name,x,y\nA,500010,4000050\nB,5000x0,4000050\n", "Row 3 of the gauges file '{p}' has x = '5000x0', not a "
         "number; give x and y as numbers in the DEM's coordinates."),
        ("name,x,y\nA,500010,nan\n", "Row 2 of the gauges file '{p}' has y = 'nan', not a number; give x and y as "
         "numbers in the DEM's coordinates."),
        ("name,x,y\nA,500010,4000050\nB,500020,4000050\nA,500030,4000050\n", "The gauge name 'A' appears twice in "
         "'{p}' (rows 2 and 4); give each gauge its own name."),
        ("name,x,y\n,500010,4000050\n", "Row 2 of the gauges file '{p}' has no name; give every gauge a name."),
        ("name,x,y\nA,500085,4000050\n", "Gauge 'A' at [500085, 4000050] (row 2 of '{p}') lies outside the DEM "
         "(x 500000..500080, y 4000000..4000100); move it onto the map or remove it."),
        ("name,x,y\nA,500005,4000095\n", "Gauge 'A' at [500005, 4000095] (row 2 of '{p}') lies on a nodata cell of "
         "the DEM; move it to a cell with data or remove it."),
    ],
)  # fmt: skip
def test_bad_gauge_files_are_one_sentence(tmp_path, hm, text, message):
    p = _csv(tmp_path, text)
    with pytest.raises(InputError) as err:
        read_gauge_points(p, hm)
    assert str(err.value) == message.format(p=p)


def test_missing_file(tmp_path, hm):
    with pytest.raises(InputError) as err:
        read_gauge_points(tmp_path / "none.csv", hm)
    assert str(err.value) == f"The gauges file '{tmp_path / 'none.csv'}' does not exist; check gauges.file."


def test_generated_map_uses_its_default_coordinates(tmp_path):
    hm = Heightmap(z=np.zeros((4, 6)), cell_size=2.0)  # x 0..12, y 0..8
    p = _csv(tmp_path, "name,x,y\nin,11.9,0.1\nout,12.1,4\n")
    with pytest.raises(InputError, match=r"Gauge 'out' at \[12.1, 4\] .* \(x 0..12, y 0..8\)"):
        read_gauge_points(p, hm)
