"""The tile plan of a tiled build (erosim.tiles.plan): cores partition the map, halos reach only the
neighbours, the feathered weights sum to one everywhere, bad sizes are one sentence."""

import numpy as np
import pytest

from erosim.core.errors import ConfigError
from erosim.tiles.plan import borders, bounds, covering, cycles_per_round, plan, ramp, weights

SHAPES = [(96, 96), (100, 37), (1000, 1000), (48, 200), (17, 17)]


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("size, overlap", [(48, 12), (16, 8), (64, 0), (100, 50)])
def test_cores_partition_the_map_and_windows_add_the_halo(shape, size, overlap):
    tiles = plan(shape, size, overlap)
    count = np.zeros(shape, int)
    for t in tiles:
        r0, r1, c0, c1 = t.core
        assert 0 < r1 - r0 <= size and 0 < c1 - c0 <= size
        count[r0:r1, c0:c1] += 1
        w0, w1, v0, v1 = t.window
        assert (w0, w1, v0, v1) == (max(0, r0 - overlap), min(shape[0], r1 + overlap),
                                    max(0, c0 - overlap), min(shape[1], c1 + overlap))  # fmt: skip
    assert (count == 1).all()  # every cell in exactly one core


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("size, overlap", [(48, 12), (16, 8), (64, 0), (100, 50), (30, 15)])
def test_weights_sum_to_one_and_vanish_at_halo_edges(shape, size, overlap):
    tiles = plan(shape, size, overlap)
    total = np.zeros(shape)
    for t in tiles:
        w = weights(t, overlap)
        assert w.shape == t.shape and (w > 0).all() and (w <= 1).all()
        r0, r1, c0, c1 = t.window
        total[r0:r1, c0:c1] += w
        cr0, cr1, cc0, cc1 = t.core
        if overlap and cr0 > r0:  # a halo on the north: rows at d = ½, 3/2 cells from its edge weigh 1 : 3
            np.testing.assert_allclose(w[0] / w[1], 1 / 3)
    if all(min(t.core[1] - t.core[0], t.core[3] - t.core[2]) >= 2 * overlap for t in tiles):
        np.testing.assert_allclose(total, 1.0, rtol=0, atol=1e-12)
    else:  # cores narrower than 2K: the ramps of one tile meet, the blend divides by the sum
        assert total.min() > 0


def test_a_halo_reaches_only_the_neighbouring_cores():
    tiles = plan((1000, 1000), 100, 50)
    for t in tiles:
        for u, _ in covering(tiles, t.window):
            assert abs(u.row - t.row) <= 1 and abs(u.col - t.col) <= 1


def test_bounds_are_even_and_end_at_the_length():
    assert bounds(96, 48) == [0, 48, 96]
    assert bounds(100, 48) == [0, 33, 67, 100]  # ⌈100/48⌉ = 3 cores of 33–34 cells, not 48 + 48 + 4
    assert bounds(10, 48) == [0, 10]
    b = bounds(16384, 1000)
    assert len(b) == 18 and b[-1] == 16384 and max(np.diff(b)) <= 1000 and min(np.diff(b)) >= 500


def test_ramp_is_linear_from_the_halo_edge():
    np.testing.assert_allclose(ramp(8, 2, 0, 2), [0.125, 0.375, 0.625, 0.875, 1, 1, 1, 1])
    np.testing.assert_allclose(ramp(8, 0, 2, 2), [1, 1, 1, 1, 0.875, 0.625, 0.375, 0.125])
    np.testing.assert_allclose(ramp(5, 0, 0, 3), 1.0)


def test_borders_are_the_interior_core_boundaries():
    tiles = plan((96, 100), 48, 12)
    assert borders(tiles) == ([48], [33, 67])
    assert borders(plan((40, 40), 48, 12)) == ([], [])


@pytest.mark.parametrize("size, overlap", [(8, 2), (48, 25), (48, -1)])
def test_bad_sizes_are_one_sentence(size, overlap):
    with pytest.raises(ConfigError, match="overlap between 0 and half the size"):
        plan((96, 96), size, overlap)


def test_cycles_split_over_rounds():
    assert cycles_per_round(10, 3) == [4, 3, 3]
    assert sum(cycles_per_round(640, 7)) == 640
    with pytest.raises(ConfigError):
        cycles_per_round(2, 3)


def test_each_tile_and_round_gets_its_own_seed():
    """tiles.build.member_seed: a function of (build seed, round, tile) alone, distinct over a 16384² build's
    256 tiles in 16 rounds and over two build seeds."""
    from erosim.tiles.build import member_seed

    keys = [(s, k, i) for s in (1, 2) for k in range(1, 17) for i in range(256)]
    seeds = [member_seed(*key) for key in keys]
    assert len(set(seeds)) == len(seeds)
    assert seeds == [member_seed(*key) for key in keys]
    assert all(isinstance(v, int) and v >= 0 for v in seeds)


def test_unset_rounds_are_eight_but_at_most_one_a_cycle_and_set_rounds_are_checked():
    """tiles.rounds unset: 8, or one a cycle for a build of fewer cycles (a short build needs no setting); set,
    it is kept, and more rounds than cycles is refused in one sentence."""
    from erosim.scenarios import loader

    tiled = ["terrain.file=big.tif", "tiles.size=64", "tiles.overlap=8"]
    for cycles, rounds in ((640, 8), (8, 8), (5, 5), (1, 1)):
        cfg = loader.load("hydrology", [*tiled, f"run.cycles={cycles}"]).config
        assert cfg.tiles.rounds_for(cycles) == rounds
    cfg = loader.load("hydrology", [*tiled, "run.cycles=640", "tiles.rounds=3"]).config
    assert cfg.tiles.rounds_for(640) == 3
    with pytest.raises(ConfigError, match="tiles.rounds = 6 exceeds run.cycles = 4"):
        loader.load("hydrology", [*tiled, "run.cycles=4", "tiles.rounds=6"])
