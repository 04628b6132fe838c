"""Procedural terrain generation: determinism, presets, physical units, bad input."""

import numpy as np
import pytest

from erosim.core.errors import ConfigError
from erosim.terrain.generate import PRESETS, generate, resolve


def test_same_seed_same_terrain_other_seed_differs():
    a = generate("mountains", 64, 10.0, seed=3)
    b = generate("mountains", 64, 10.0, seed=3)
    c = generate("mountains", 64, 10.0, seed=4)
    assert np.array_equal(a.z, b.z)
    assert not np.allclose(a.z, c.z)


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_presets_make_finite_terrain_in_their_relief(preset):
    hm = generate(preset, (48, 80), 10.0, seed=1)
    assert hm.shape == (48, 80)
    assert hm.cell_size == 10.0
    assert np.isfinite(hm.z).all()
    relief = resolve(preset).relief
    # u is scaled so its 1st..99th percentile spans 0..1 (module docs): allow 40 % overshoot.
    assert hm.z.min() >= -0.01 and hm.z.max() <= 1.4 * relief
    assert hm.z.std() > 0


def test_presets_differ():
    maps = {p: generate(p, 64, 10.0, seed=2).z for p in PRESETS}
    names = sorted(maps)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            za, zb = maps[a], maps[b]
            corr = np.corrcoef(za.ravel(), zb.ravel())[0, 1]
            assert not np.allclose(za, zb) and corr < 0.95, (a, b, corr)


def test_resolution_independent_at_large_scale():
    # Same physical extent (512 x 10 m = 256 x 20 m): the fine map, block-averaged 2x2, must match
    # the coarse one at large scale. Differences are only the octaves finer than 40 m (a few % of
    # the variance), so 0.98 is a conservative floor.
    coarse = generate("mountains", 256, 20.0, seed=11).z
    fine = generate("mountains", 512, 10.0, seed=11).z
    down = fine.reshape(256, 2, 256, 2).mean(axis=(1, 3))
    corr = np.corrcoef(coarse.ravel(), down.ravel())[0, 1]
    assert corr > 0.98, corr


def test_fixed_octaves_give_identical_values_at_shared_points():
    # With a fixed octave count the noise is a pure function of the physical position: a map with
    # an offset origin reproduces the overlapping part of a larger map exactly.
    big = generate("hills", 64, 5.0, seed=9, octaves=6)
    part = generate("hills", 32, 5.0, seed=9, octaves=6, offset_x=80.0, offset_y=40.0)
    np.testing.assert_allclose(part.z, big.z[8:40, 16:48], rtol=0, atol=1e-9)


def test_bad_inputs_give_clear_errors():
    with pytest.raises(ConfigError, match="Unknown terrain preset 'mountain'.*mountains"):
        generate("mountain", 32, 1.0, 0)
    with pytest.raises(ConfigError, match="positive number of metres"):
        generate("hills", 32, -1.0, 0)
    with pytest.raises(ConfigError, match="at least 2 cells"):
        generate("hills", 1, 1.0, 0)
    with pytest.raises(ConfigError, match="wavelength"):
        generate("hills", 32, 1.0, 0, wavelength=-5)
    with pytest.raises(ConfigError, match="did you mean 'relief'"):
        generate("hills", 32, 1.0, 0, releif=10)


def test_terrain_section_generates_or_reads(tmp_path):
    from erosim.core.config import validate_section
    from erosim.io.heightmaps import write
    from erosim.scenarios.schema_common import TerrainSection, build_terrain

    sec = validate_section(TerrainSection, {"preset": "hills", "size": 32, "cell_size": 4.0, "relief": 50.0}, "terrain")
    hm = build_terrain(sec, seed=5)
    assert np.array_equal(hm.z, generate("hills", 32, 4.0, 5, relief=50.0).z)
    write(tmp_path / "dem.npy", hm)
    # Setting only terrain.file switches the source (what `--set terrain.file=PATH` does).
    sec = validate_section(
        TerrainSection, {"preset": "hills", "file": str(tmp_path / "dem.npy"), "cell_size": 4.0}, "terrain"
    )
    assert sec.uses_file
    assert np.array_equal(build_terrain(sec, seed=0).z, hm.z)


def test_terrain_section_errors_name_the_key():
    from erosim.core.config import validate_section
    from erosim.scenarios.schema_common import TerrainSection

    with pytest.raises(ConfigError, match="Unknown terrain preset 'peaks'"):
        validate_section(TerrainSection, {"preset": "peaks"}, "terrain")
    with pytest.raises(ConfigError, match="terrain.cell_size"):
        validate_section(TerrainSection, {"cell_size": -2.0}, "terrain")
    with pytest.raises(ConfigError, match="terrain.file is not set"):
        validate_section(TerrainSection, {"source": "file"}, "terrain")


def test_large_maps_are_built_in_blocks_without_seams(monkeypatch):
    import erosim.terrain.generate as gen

    whole = generate("plateau", (40, 30), 25.0, seed=4)
    monkeypatch.setattr(gen, "_CHUNK", 7 * 30)  # 7 rows per block: the last block is partial
    blocks = generate("plateau", (40, 30), 25.0, seed=4)
    assert np.array_equal(whole.z, blocks.z)


def test_the_canyon_shape_has_cliffs_a_flat_floor_and_plateaus_that_drain_over_the_rims():
    """`canyon` on a 24 m map of 1 m cells, relief 6 m: the floor 6 m wide and level across (it falls
    only northward, relief/4 over the map); each wall rises the full relief between two neighbouring
    cells (a cliff, 80° at 1 m cells); every plateau cell is higher than its neighbour towards the rim,
    so steepest descent on a plateau leads over the edge."""
    from erosim.terrain.shapes import shape

    z = shape("canyon", 24, 1.0, relief=6.0).z  # row 0 north
    row = z[12]
    floor = np.abs((np.arange(24) + 0.5) - 12.0) < 3.0
    assert floor.sum() == 6 and np.ptp(row[floor]) < 1e-12
    assert np.all(np.diff(z[:, 12]) > 0)  # the floor rises southward (rows run north to south)
    assert np.ptp(z[:, 12]) == pytest.approx(6.0 / 4 * 23 / 24)
    west, east = row[8] - row[9], row[15] - row[14]
    assert west == pytest.approx(6.0, abs=0.1) and east == pytest.approx(6.0, abs=0.1)
    assert np.all(np.diff(row[:9]) < 0) and np.all(np.diff(row[15:]) > 0)  # plateaus fall towards the rims
