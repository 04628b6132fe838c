"""Hardness maps (SPEC ST-1): files, strata by height band, noise, material classes, and checks."""

import numpy as np
import pytest
from PIL import Image

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap
from erosim.io import heightmaps as hio
from erosim.terrain import hardness
from erosim.terrain.hardness import MATERIALS, Strata


def test_geotiff_float_is_hardness_as_is(tmp_path):
    d = np.linspace(0.0, 1.0, 30).reshape(5, 6)
    hio.write(tmp_path / "h.tif", Heightmap(z=d, cell_size=2.0))
    back = hardness.load(tmp_path / "h.tif", (5, 6))
    np.testing.assert_array_equal(back, d.astype(np.float32))  # float32 file


def test_png_pixels_scale_by_their_bit_depth(tmp_path):
    q16 = np.array([[0, 65535], [32768, 13107]], dtype=np.uint16)
    Image.fromarray(q16).save(tmp_path / "a.png")
    np.testing.assert_allclose(hardness.load(tmp_path / "a.png"), q16 / 65535.0)
    q8 = np.array([[0, 255, 51]], dtype=np.uint8)
    Image.fromarray(q8).save(tmp_path / "b.png")
    np.testing.assert_allclose(hardness.load(tmp_path / "b.png"), q8 / 255.0)
    rgb = np.zeros((2, 2, 3), np.uint8)
    rgb[0, 0] = 255  # white
    Image.fromarray(rgb).save(tmp_path / "c.png")
    np.testing.assert_allclose(hardness.load(tmp_path / "c.png"), [[1.0, 0.0], [0.0, 0.0]])


def test_file_errors_are_clear(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        hardness.load(tmp_path / "none.tif")
    np.save(tmp_path / "big.npy", np.full((4, 4), 1.2))
    with pytest.raises(InputError, match=r"ranges 1.2..1.2 but hardness must lie in \[0, 1\]"):
        hardness.load(tmp_path / "big.npy")
    np.save(tmp_path / "ok.npy", np.zeros((4, 4)))
    with pytest.raises(InputError, match=r"shape \(4, 4\) but the heightmap has \(4, 5\)"):
        hardness.load(tmp_path / "ok.npy", (4, 5))
    (tmp_path / "junk.png").write_bytes(b"not a png")
    with pytest.raises(InputError, match="cannot be read"):
        hardness.load(tmp_path / "junk.png")


def test_strata_bands_by_height_repeat_and_tilt():
    spec = Strata(thickness=(2.0, 1.0, 3.0), hardness=(0.1, 0.9, 0.5), base=10.0)
    z = np.array([[10.0, 11.9, 12.0, 12.99, 13.0, 15.99, 16.0, 18.5, 9.5]])
    # bands from 10 m: [10, 12) → 0.1, [12, 13) → 0.9, [13, 16) → 0.5, repeating every 6 m
    np.testing.assert_array_equal(hardness.strata(z, 1.0, spec), [[0.1, 0.1, 0.9, 0.9, 0.5, 0.5, 0.1, 0.9, 0.5]])
    # tilt: layers rise 0.5 m per metre eastward relative to the surface → on flat ground at 10 m,
    # cells 2 m apart (cell 1 m) step through the bands
    tilted = Strata(thickness=(2.0, 1.0, 3.0), hardness=(0.1, 0.9, 0.5), base=10.0, tilt_x=0.5)
    flat = np.full((1, 8), 10.0)
    np.testing.assert_array_equal(hardness.strata(flat, 1.0, tilted), [[0.1] * 4 + [0.9] * 2 + [0.5] * 2])
    # northward tilt: rows run south, so a northward rise shows in the row direction reversed
    north = Strata(thickness=(2.0, 1.0, 3.0), hardness=(0.1, 0.9, 0.5), base=10.0, tilt_y=-0.5)
    np.testing.assert_array_equal(hardness.strata(flat.T, 1.0, north)[:, 0], [0.1] * 4 + [0.9] * 2 + [0.5] * 2)


def test_strata_bad_specs():
    with pytest.raises(InputError, match="one hardness per band"):
        hardness.strata(np.zeros((2, 2)), 1.0, Strata(thickness=(1.0, 2.0), hardness=(0.5,)))
    with pytest.raises(InputError, match="positive"):
        hardness.strata(np.zeros((2, 2)), 1.0, Strata(thickness=(1.0, 0.0), hardness=(0.5, 0.2)))
    with pytest.raises(InputError, match=r"\[0, 1\]"):
        hardness.strata(np.zeros((2, 2)), 1.0, Strata(thickness=(1.0,), hardness=(1.5,)))


def test_noise_is_smooth_in_range_and_seeded():
    a = hardness.noise((64, 80), seed=3, scale=6.0, low=0.2, high=0.7)
    assert a.shape == (64, 80) and a.min() == pytest.approx(0.2) and a.max() == pytest.approx(0.7)
    assert np.array_equal(a, hardness.noise((64, 80), seed=3, scale=6.0, low=0.2, high=0.7))
    assert not np.array_equal(a, hardness.noise((64, 80), seed=4, scale=6.0, low=0.2, high=0.7))
    # smooth: neighbours differ far less than the range (white noise would differ by ~0.2 here)
    assert np.abs(np.diff(a, axis=1)).mean() < 0.03
    with pytest.raises(InputError, match="within"):
        hardness.noise((4, 4), 0, low=0.8, high=0.2)


def test_class_map_with_materials_table():
    cm = np.array([[0, 1], [2, 1]], dtype=np.int16)
    d = hardness.classes(cm, {0: "sand", 1: "granite", 2: 0.33})
    np.testing.assert_array_equal(d, [[MATERIALS["sand"], MATERIALS["granite"]], [0.33, MATERIALS["granite"]]])
    with pytest.raises(InputError, match=r"values \[2\] have no material"):
        hardness.classes(cm, {0: "sand", 1: "granite"})
    with pytest.raises(InputError, match="Unknown material 'lava'"):
        hardness.classes(cm, {0: "lava", 1: "sand", 2: "sand"})
    with pytest.raises(InputError, match="integer classes"):
        hardness.classes(cm.astype(float), {0: "sand"})
