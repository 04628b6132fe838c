"""Particle frames (.vtp) and the ParaView collection (.pvd) are well-formed XML and read back exactly."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from erosim.io.particles import FrameSeries, read_pvd, read_vtp, write_vtp


@pytest.mark.parametrize("dim", [2, 3])
def test_frame_round_trip(tmp_path, dim):
    rng = np.random.default_rng(0)
    pos = rng.random((57, dim)).astype(np.float32)
    vel = rng.normal(size=(57, dim)).astype(np.float32)
    p = rng.normal(size=57).astype(np.float32)
    rho = (1000 + rng.normal(size=57)).astype(np.float64)
    write_vtp(tmp_path / "f.vtp", pos, {"velocity": vel, "pressure": p, "density": rho}, time=0.125)

    ET.parse(tmp_path / "f.vtp")  # well-formed XML
    back = read_vtp(tmp_path / "f.vtp")
    assert back["n_points"] == 57
    assert back["time"] == 0.125
    assert back["points"].shape == (57, 3)
    np.testing.assert_array_equal(back["points"][:, :dim], pos)
    np.testing.assert_array_equal(back["points"][:, dim:], 0.0)  # 2-D padded with z = 0
    np.testing.assert_array_equal(back["fields"]["velocity"][:, :dim], vel)
    np.testing.assert_array_equal(back["fields"]["pressure"], p)
    np.testing.assert_array_equal(back["fields"]["density"], rho)
    np.testing.assert_array_equal(back["verts"], np.arange(57))  # one vertex cell per point


def test_vtp_header_declares_polydata(tmp_path):
    write_vtp(tmp_path / "f.vtp", np.zeros((3, 3)), {"pressure": np.ones(3)})
    root = ET.parse(tmp_path / "f.vtp").getroot()
    assert root.get("type") == "PolyData"
    piece = root.find("PolyData/Piece")
    assert piece.get("NumberOfPoints") == "3" and piece.get("NumberOfVerts") == "3"
    names = {d.get("Name") for d in piece.findall("PointData/DataArray")}
    assert names == {"pressure"}


def test_series_collection_lists_frames_in_order(tmp_path):
    s = FrameSeries(tmp_path / "particles")
    for k in range(3):
        s.write(0.1 * k, np.full((4, 2), k, float), {"pressure": np.zeros(4)})
    rows = read_pvd(tmp_path / "particles" / "particles.pvd")
    assert [f for _, f in rows] == ["frame_00000.vtp", "frame_00001.vtp", "frame_00002.vtp"]
    assert [t for t, _ in rows] == pytest.approx([0.0, 0.1, 0.2])
    for _, f in rows:
        assert read_vtp(tmp_path / "particles" / f)["n_points"] == 4
    # no temporary file left behind
    assert not [p for p in (tmp_path / "particles").iterdir() if p.name.startswith(".")]
