"""`erosim convert IN OUT [--cell-size M]` through the real command line."""

import numpy as np
from click.testing import CliRunner

from erosim.cli import cli
from erosim.core.heightmap import Heightmap
from erosim.io import heightmaps as io


def test_convert_npy_to_geotiff_with_cell_size(tmp_path):
    z = np.linspace(10.0, 90.0, 12 * 15).reshape(12, 15)
    np.save(tmp_path / "in.npy", z)
    result = CliRunner().invoke(
        cli, ["convert", str(tmp_path / "in.npy"), str(tmp_path / "out.tif"), "--cell-size", "2.5"]
    )
    assert result.exit_code == 0, result.output
    assert "out.tif" in result.output
    back = io.read(tmp_path / "out.tif")
    assert back.cell_size == 2.5
    np.testing.assert_allclose(back.z, z, rtol=2**-23)  # float32 storage


def test_convert_geotiff_to_png16_reports_height_range(tmp_path):
    hm = Heightmap(z=np.arange(20.0).reshape(4, 5) * 3.0 + 100.0, cell_size=4.0)
    io.write(tmp_path / "in.tif", hm)
    result = CliRunner().invoke(cli, ["convert", str(tmp_path / "in.tif"), str(tmp_path / "out.png")])
    assert result.exit_code == 0, result.output
    assert "height_range" in result.output and "157" in result.output  # 100 + 19·3
    back = io.read(tmp_path / "out.png")
    np.testing.assert_allclose(back.z, hm.z, atol=0.5 * 57.0 / 65535 + 1e-12)


def test_convert_bad_input_is_one_sentence(tmp_path):
    runner = CliRunner()
    result = runner.invoke(cli, ["convert", str(tmp_path / "nope.tif"), str(tmp_path / "x.png")])
    assert result.exit_code != 0
    assert "does not exist" in result.output and "Traceback" not in result.output
    np.save(tmp_path / "in.npy", np.zeros((3, 3)))
    result = runner.invoke(cli, ["convert", str(tmp_path / "in.npy"), str(tmp_path / "x.bmp")])
    assert result.exit_code != 0 and "unknown extension '.bmp'" in result.output
    result = runner.invoke(cli, ["convert", str(tmp_path / "in.npy"), str(tmp_path / "x.tif"), "--cell-size", "-1"])
    assert result.exit_code != 0 and "positive number of metres" in result.output
