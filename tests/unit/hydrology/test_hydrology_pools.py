"""HY-2 lakes: exact fill-to-spill, flat levels, merging, draining at the map edge (HY-8)."""

import numpy as np
import pytest
from skimage.morphology import reconstruction

from erosim.core.heightmap import Heightmap
from erosim.hydrology import pools
from erosim.hydrology.model import HydrologyModel
from erosim.hydrology.params import HydrologyParams, VegetationParams


def _model(z, cell=1.0, **kw):
    p = HydrologyParams(length_scale=0.0, **kw)
    m = HydrologyModel(Heightmap(z=np.asarray(z, float), cell_size=cell), p, VegetationParams(enabled=False), seed=3)
    m._rebuild()
    return m


def _flood(m, iy, ix, V, S=0.0, spread=0):
    ny, nx = m.z.shape
    P = m.P
    return pools.flood(
        iy * nx + ix,
        V,
        S,
        nx,
        ny,
        m.z.reshape(-1),
        m.lake_of,
        m.level,
        m.area,
        m.mroot,
        m.broot,
        m.budget,
        P[14],
        P[15],
        P[11],
        P[16],
        m.hkey,
        m.hcell,
        m.hleft,
        m.hright,
        m.hrank,
        m.hs,
        m.stack,
        m.walk,
        spread,
    )


def _filled(z):
    """Depression-filled surface (morphological reconstruction by erosion), open map edges."""
    seed = z.copy()
    seed[1:-1, 1:-1] = z.max()
    return reconstruction(seed, z, method="erosion")


def _two_basins():
    """Two square pits (floors 0 m and 2 m) in a 10 m plateau, joined by a 5 m saddle."""
    z = np.full((20, 30), 10.0)
    z[5:15, 3:13] = 2.0  # west basin, 100 cells
    z[5:15, 17:27] = 0.0  # east basin, 100 cells
    z[9:11, 13:17] = 5.0  # saddle
    return z


def test_volume_goes_into_lake_exactly():
    z = _two_basins()
    m = _model(z)
    res, _c, V, _S = _flood(m, 8, 20, 300.0)  # east basin: 300 m³ over 100 m² -> 3 m deep
    assert res == pools.SPENT and V == 0.0
    d = m.lake_depth()
    # exact to rounding: the level solves A·(L − z)·Δx² = V
    assert d[8, 20] == pytest.approx(3.0, rel=1e-12)
    assert d.sum() == pytest.approx(300.0, rel=1e-12)
    # flat: one level over every wet cell
    wet = d > 0
    assert np.ptp((z + d)[wet]) < 1e-12


def test_fill_to_spill_then_overflow_into_the_next_basin():
    z = _two_basins()
    m = _model(z)
    # west basin holds 100 m² × 3 m = 300 m³ up to the saddle (5 m): 350 m³ overflows 50 m³
    res, cell, V, _S = _flood(m, 8, 8, 350.0)
    assert res == pools.DRAIN
    iy, ix = divmod(cell, z.shape[1])
    assert ix == 17 and 8 <= iy <= 11  # the drain: first east-basin cell past the flat saddle
    d = m.lake_depth()
    level = (z + d)[8, 8]
    assert level == pytest.approx(5.0 - 0.001 * (5.0 - z[iy, ix]), abs=1e-9)  # seed's slow drainage
    released = 300.0 - d.sum()
    assert V == pytest.approx(50.0 + released, rel=1e-12)  # what overflowed is what the drop carries
    # never above the spill level given by a morphological fill of the terrain
    assert np.all(z + d <= _filled(z) + 1e-9)


def test_lakes_merge_when_the_levels_meet():
    z = _two_basins()
    m = _model(z)
    _flood(m, 8, 20, 500.0)  # east basin up to the saddle height 5 m (100 m² × 5 m)
    _flood(m, 8, 8, 300.0)  # west basin up to 5 m
    res, _c, V, _S = _flood(m, 8, 8, 208.0)  # both + the 8 saddle cells: 208 m² × 1 m
    assert res == pools.SPENT
    d = m.lake_depth()
    wet = d > 0
    assert np.ptp((z + d)[wet]) < 1e-9  # one flat lake
    assert (z + d)[8, 8] == pytest.approx(6.0, rel=1e-9)
    assert len(np.unique(m.lake_of[m.lake_of >= 0])) == 1


def test_lake_touching_the_open_edge_drains_off_the_map():
    """HY-8: no wall at the map edge; a lake that reaches it spills off the world."""
    z = np.full((10, 10), 10.0)
    z[3:7, 0:6] = 1.0  # a pit open to the west edge at 1 m
    z[3:7, 0] = 4.0  # its rim on the edge column is 4 m
    m = _model(z)
    res, _c, V, _S = _flood(m, 5, 3, 1000.0)
    assert res == pools.LEFT
    d = m.lake_depth()
    assert (z + d)[5, 3] == pytest.approx(4.0, abs=1e-9)  # filled to the edge cell, no higher
    assert m.budget[pools.B_LEFT] == pytest.approx(1000.0 - d.sum(), rel=1e-12)


def test_sea_level_takes_the_water():
    z = np.full((12, 12), 10.0)
    z[4:8, 4:8] = 2.0
    z[5, 8:] = 3.0  # a channel from the pit to the east edge, 3 m
    z[5, 11] = -5.0  # below the sea
    m = _model(z, sea_level=0.0)
    res, _c, _V, _S = _flood(m, 5, 5, 1000.0)
    assert res == pools.LEFT
    # full at the channel height 3 m, then one drainage step toward the sea (seed: r = 0.001)
    assert (z + m.lake_depth())[5, 5] == pytest.approx(3.0 - 0.001 * 3.0, abs=1e-9)


@pytest.mark.parametrize("seed", [1, 2])
def test_random_floods_never_exceed_the_filled_surface(seed):
    rng = np.random.default_rng(seed)
    from scipy import ndimage

    z = ndimage.gaussian_filter(rng.random((40, 40)) * 20.0, 2.0)
    m = _model(z)
    for _ in range(300):
        iy, ix = rng.integers(1, 39, size=2)
        if m.lake_of[iy * 40 + ix] < 0:
            ix = int(ix)
        res, cell, V, S = _flood(m, int(iy), int(ix), float(rng.random() * 5.0))
    d = m.lake_depth()
    surf = m.z + d
    # tolerance: the seed's drainage step may leave a lake up to 0.1 % of (level − drain) lower,
    # never higher; rounding of the exact solve is ~1e-12 m
    assert np.all(surf <= _filled(m.z) + 1e-9)
    # flat lakes: within each lake one level
    for k in np.unique(m.lake_of[m.lake_of >= 0]):
        cells = (m.lake_of == k).reshape(z.shape) & (d > 0)
        if cells.any():
            assert np.ptp(surf[cells]) < 1e-9
    # water exchanged equals water stored
    assert m.budget[pools.B_TO_LAKES] == pytest.approx(d.sum(), rel=1e-10)


def test_heaps_meld_in_order():
    n = 200
    hkey = np.zeros(n)
    hcell = np.zeros(n, np.int64)
    hleft = np.zeros(n, np.int64)
    hright = np.zeros(n, np.int64)
    hrank = np.zeros(n, np.int64)
    hs = np.array([0, -1, 0, 0], np.int64)
    stack = np.zeros(128, np.int64)
    rng = np.random.default_rng(0)
    keys = rng.random(150)
    a = b = -1
    for i, k in enumerate(keys):
        if i % 2:
            a = pools.push(a, k, i, hkey, hcell, hleft, hright, hrank, hs, stack)
        else:
            b = pools.push(b, k, i, hkey, hcell, hleft, hright, hrank, hs, stack)
    r = pools.merge(a, b, hkey, hleft, hright, hrank, stack)
    out = []
    while r >= 0:
        out.append(hkey[r])
        r = pools.pop(r, hkey, hleft, hright, hrank, hs, stack)
    assert out == sorted(keys)


@pytest.mark.parametrize("side", [10, 120])
def test_adding_water_to_a_lake_does_no_per_cell_work(side):
    """The seed floods the whole lake for every droplet; here a droplet that only raises a lake's
    level touches no heap at all, whatever the lake's area (cost O(1), not O(area))."""
    z = np.full((side + 4, side + 4), 100.0)
    z[2:-2, 2:-2] = 0.0
    m = _model(z)
    _flood(m, side // 2, side // 2, float(side * side) * 10.0)  # 10 m deep, far below the rim
    used = (m.hs[pools.HS_BUMP], m.hs[pools.HS_FREE])
    for _ in range(100):
        res, _c, _V, _S = _flood(m, side // 2, side // 2, 1.0)
        assert res == pools.SPENT
    assert (m.hs[pools.HS_BUMP], m.hs[pools.HS_FREE]) == used
    assert m.lake_depth()[side // 2, side // 2] == pytest.approx(10.0 + 100.0 / side**2, rel=1e-12)


def _halo_pit(code):
    """A 1 m pit (4 × 6 cells) whose east side is a tile's border: the halo (columns 8–13, ``code``)
    holds the neighbour's 4 m rim beside the pit and falls to 0 m beyond it."""
    z = np.full((10, 14), 10.0)
    z[3:7, 2:8] = 1.0
    z[3:7, 8] = 4.0
    z[:, 9:] = 0.0
    m = _model(z)
    m.lake_of.reshape(z.shape)[:, 8:] = code
    return z, m


def test_lake_cut_by_a_tile_border_fills_to_the_halo_before_it_spills():
    """A tile's halo is a boundary at its own height, not an open edge: the pit fills to the 4 m rim
    it shares with the neighbour, then spills there (the halo cell returned for the exchange), keeping
    10 % of the sediment; a nodata side (OUTSIDE) drains the same pit at once."""
    z, m = _halo_pit(pools.HALO)
    res, cell, _V, _S = _flood(m, 5, 3, 100.0)
    assert res == pools.LEFT
    iy, ix = divmod(cell, z.shape[1])
    assert ix == 8 and 3 <= iy <= 6  # the halo cell of the rim it spilled over
    d = m.lake_depth()
    assert (m.z + d)[5, 3] == pytest.approx(4.0, abs=1e-9)  # full to the rim (the drain's target is the level)
    assert (d[:, 8:] == 0).all()  # the halo never joins the lake
    assert d.sum() == pytest.approx(72.0, rel=1e-12)  # 24 cells × 3 m
    assert m.budget[pools.B_LEFT] == pytest.approx(28.0, rel=1e-12)
    # a droplet with sediment reaching the full lake: 90 % settles in it (the water it displaces goes
    # on), 10 % leaves with the water into the halo
    res, cell, _V, _S = _flood(m, 5, 3, 10.0, S=1.0)
    assert res == pools.LEFT and cell % z.shape[1] == 8
    assert m.budget[pools.B_CARRIED] == pytest.approx(0.1, rel=1e-12)
    assert m.budget[pools.B_LEFT] == pytest.approx(28.0 + 10.0 + 0.9, rel=1e-12)
    _z, open_side = _halo_pit(pools.OUTSIDE)
    res, _c, _V, _S = _flood(open_side, 5, 3, 100.0)
    assert res == pools.LEFT and open_side.lake_depth().sum() < 1.0  # drained at once


@pytest.mark.parametrize("spread", [0, 1])
def test_a_lakes_sediment_settles_over_the_droplets_reach(spread):
    """Sediment S brought into a lake at cell c settles in equal shares on the lake's cells within
    ``spread`` cells of c (issue 36; spread 0 = the entry cell alone, the seed's one-cell droplets),
    displacing its own volume of water while it stays under the surface; cells outside the square or
    outside the lake are untouched, and the sediment's volume is kept exactly (to rounding)."""
    z = np.full((12, 12), 10.0)
    z[3:9, 3:9] = 0.0  # a 6 × 6 pit, 10 m deep
    m = _model(z)
    res, _, _, _ = _flood(m, 5, 5, 200.0)  # a lake 200 / 36 ≈ 5.6 m deep over the pit
    assert res == pools.SPENT
    k = m.lake_of[5 * 12 + 5]
    before = m.z.copy()
    S = 4.0  # m³: 4 m over one cell (under the 5.6 m of water), 1 m over four
    displaced = pools.settle_in_lake(
        k, 3 * 12 + 3, S, m.z.reshape(-1), m.lake_of, m.level, m.area, m.mroot, m.broot, 1.0, m.hkey, m.hcell,
        m.hleft, m.hright, m.hrank, m.hs, m.stack, 12, spread,
    )  # fmt: skip
    rise = m.z - before
    # the entry is the pit's corner: its square holds (spread + 1)² lake cells
    cells = (spread + 1) ** 2
    assert np.count_nonzero(rise) == cells
    assert np.allclose(rise[3 : 4 + spread, 3 : 4 + spread], S / cells, rtol=1e-12)
    assert abs(rise.sum() - S) < 1e-12 * S
    assert abs(displaced - S) < 1e-12 * S


def test_a_load_larger_than_a_puddle_fills_it_to_the_surface_and_spreads_the_rest():
    """A one-cell lake 1 m deep (full to its 10 m rim) takes a load of 10 m³ on 1 m² cells, ``spread`` 1:
    its share is capped at its water depth, so the cell is filled to the surface (1 m³, displacing its
    whole 1 m³ column) and leaves the lake, and the other 9 m³ settle on the 3 × 3 square as on dry
    ground, 1 m each. The cell ends level with the square (11 m), where the uncapped share built a
    tower 10 m tall on it (issue 36: up to 150 m on the library's 20 m cells); the volume is kept."""
    z = np.full((9, 9), 10.0)
    z[4, 4] = 9.0
    m = _model(z)
    res, _, _, _ = _flood(m, 4, 4, 1.0)  # exactly the pit's room: a one-cell lake at its rim
    assert res == pools.SPENT
    k = m.lake_of[4 * 9 + 4]
    assert k >= 0 and m.area[k] == 1 and m.level[k] == pytest.approx(10.0, abs=1e-12)
    before = m.z.copy()
    displaced = pools.settle_in_lake(
        k, 4 * 9 + 4, 10.0, m.z.reshape(-1), m.lake_of, m.level, m.area, m.mroot, m.broot, 1.0, m.hkey, m.hcell,
        m.hleft, m.hright, m.hrank, m.hs, m.stack, 9, 1,
    )  # fmt: skip
    np.testing.assert_allclose(m.z[3:6, 3:6], 11.0, rtol=1e-12)
    assert np.count_nonzero(m.z - before) == 9
    assert abs((m.z - before).sum() - 10.0) < 1e-12 * 10.0
    assert displaced == pytest.approx(1.0, rel=1e-12)
    assert m.lake_of[4 * 9 + 4] == pools.NO_LAKE and m.area[k] == 0


def test_a_droplet_whose_load_fills_the_lake_it_enters_goes_on():
    """A droplet with 0.5 m³ of water and 20 m³ of sediment floods into a one-cell lake 1 m deep (``spread``
    1): 90 % of its load settles, the lake takes 1 m³ up to its surface and is gone, no lake is within 2, 4
    or 8 cells to take more, and the other 17 m³ settle on the reach as on dry ground (17/9 m each). The
    flood returns FILLED at the entry with the droplet's water plus the lake's displaced 1 m³ and the kept
    10 % of the load, for the droplet to go on."""
    z = np.full((21, 21), 10.0)
    z[10, 10] = 9.0
    m = _model(z)
    assert _flood(m, 10, 10, 1.0)[0] == pools.SPENT  # the one-cell lake, full to its rim
    before = m.z.copy()
    res, cell, V, S = _flood(m, 10, 10, 0.5, 20.0, spread=1)
    assert res == pools.FILLED and cell == 10 * 21 + 10
    assert V == pytest.approx(1.5, rel=1e-12) and S == pytest.approx(2.0, rel=1e-12)
    np.testing.assert_allclose(m.z[9:12, 9:12], 10.0 + 17.0 / 9.0, rtol=1e-12)
    assert np.count_nonzero(m.z - before) == 9 and not (m.lake_depth() > 0).any()
    assert m.budget[pools.B_DEPOSITED] == pytest.approx(18.0, rel=1e-12)


def test_shares_are_capped_cell_by_cell_and_the_deeper_cells_take_the_rest():
    """Two lake cells in the reach, 0.5 m and 3 m under a level of 10 m: a 2 m³ load (1 m³ each in equal
    shares) fills the shallow one to the surface (0.5 m³; it leaves the lake) and puts the other 1.5 m³
    on the deep one, which stays wet. Nothing rises above the water; the volume is kept."""
    z = np.full((9, 9), 12.0)
    z[4, 3:7] = [9.5, 7.0, 7.0, 7.0]  # a trough; the flood below fills it to 10 m
    m = _model(z)
    res, _, _, _ = _flood(m, 4, 5, 0.5 + 3 * 3.0)
    assert res == pools.SPENT
    k = m.lake_of[4 * 9 + 4]
    assert m.area[k] == 4 and m.level[k] == pytest.approx(10.0, abs=1e-12)
    before = m.z.copy()
    displaced = pools.settle_in_lake(
        k, 3 * 9 + 3, 2.0, m.z.reshape(-1), m.lake_of, m.level, m.area, m.mroot, m.broot, 1.0, m.hkey, m.hcell,
        m.hleft, m.hright, m.hrank, m.hs, m.stack, 9, 1,
    )  # fmt: skip
    rise = m.z - before
    assert rise[4, 3] == pytest.approx(0.5, rel=1e-12) and m.lake_of[4 * 9 + 3] == pools.NO_LAKE
    assert rise[4, 4] == pytest.approx(1.5, rel=1e-12) and m.lake_of[4 * 9 + 4] == k
    assert np.count_nonzero(rise) == 2
    assert displaced == pytest.approx(2.0, rel=1e-12)


def test_soil_creeping_into_a_lake_displaces_its_water_or_fills_the_cell():
    """settle_gains: a lake cell's bed gain from the shore is made through the bookkeeping. In the east basin
    filled 3 m deep (100 m², 300 m³), a 0.5 m gain on one cell displaces 0.5 m³ and the cell stays wet; a 4 m
    gain on another raises its bed above the water: the cell leaves the lake, displacing its whole 3 m column;
    a dry cell keeps its gain. Cells of 1 m."""
    m = _model(_two_basins())
    _flood(m, 8, 20, 300.0)
    nx = m.z.shape[1]
    zf = m.z.reshape(-1)
    a, b, dry = 8 * nx + 20, 10 * nx + 22, 2 * nx + 2
    k = m.lake_of[a]
    assert k >= 0 and m.lake_of[b] == k and m.lake_of[dry] == pools.NO_LAKE
    cells = np.array([a, b, dry])
    zf[cells] += np.array([0.5, 4.0, 0.7])  # what creep added
    displaced = pools.settle_gains(
        cells, np.array([0.5, 4.0, 0.7]), zf, m.lake_of, m.level, m.area, m.mroot, m.broot, 1.0, m.hkey, m.hcell,
        m.hleft, m.hright, m.hrank, m.hs, m.stack,
    )  # fmt: skip
    assert displaced == pytest.approx(0.5 + 3.0, abs=1e-12)
    np.testing.assert_allclose(zf[cells], [0.5, 4.0, 10.7], atol=1e-12)
    assert m.lake_of[a] == k and m.lake_of[b] == pools.NO_LAKE and m.area[k] == 99
    assert m.level[k] == pytest.approx(3.0, abs=1e-12)


def _settle_dry(m, c, amount, spread):
    nx = m.z.shape[1]
    pools.settle_dry(c, amount, m.z.reshape(-1), m.lake_of, m.level, -np.inf, nx, 1.0, spread)


def test_a_dry_load_fills_its_pit_then_spreads_as_a_layer_over_the_reach():
    """A load S settling at a dry one-cell pit 0.5 m below its lowest neighbour (issue 38) first
    fills the pit to that rim (0.5 m³ on 1 m² cells), then the rest spreads in equal heights over the
    dry cells within ``spread`` = 2 cells (a 5 × 5 square): the pit ends level with its rim plus the
    layer, not above it. A lake cell in the square gets none, cells beyond it none, and the volume is
    kept to rounding."""
    z = np.full((11, 11), 10.0)
    z[5, 5] = 9.5  # the pit; its rim is 10 m
    z[5, 8] = 9.0  # a dry cell beyond the reach, lower, must not change
    m = _model(z)
    m.lake_of[4 * 11 + 6] = 0  # one cell of the square marked a lake's (level 10 m, at the rim): it takes no share
    m.level[0] = 10.0
    before = m.z.copy()
    S = 24.5  # m³: 0.5 into the pit, 24 over the 24 dry cells of the square
    _settle_dry(m, 5 * 11 + 5, S, 2)
    rise = m.z - before
    assert rise[5, 5] == pytest.approx(1.5, rel=1e-12)  # 0.5 to the rim, then the 1 m layer
    assert m.z[5, 5] == pytest.approx(m.z[5, 4], rel=1e-12)  # level with its rim: no mound
    square = rise[3:8, 3:8].copy()
    square[2, 2] -= 0.5
    square[1, 3] += 1.0  # the lake cell's missing share
    np.testing.assert_allclose(square, 1.0, rtol=1e-12)
    assert rise[4, 6] == 0.0
    assert np.count_nonzero(rise) == 24
    assert abs(rise.sum() - S) < 1e-12 * S


def test_a_small_load_only_fills_part_of_its_pit_and_the_seeds_droplets_keep_one_cell():
    """A load smaller than the pit's room stays in the pit (the rest of the map untouched); with
    ``spread`` 0 (the seed's one-cell droplets) the whole load lands on the cell, pit or not."""
    z = np.full((7, 7), 10.0)
    z[3, 3] = 9.0
    m = _model(z)
    before = m.z.copy()
    _settle_dry(m, 3 * 7 + 3, 0.25, 2)
    assert m.z[3, 3] - before[3, 3] == pytest.approx(0.25, rel=1e-12)
    assert np.count_nonzero(m.z - before) == 1
    _settle_dry(m, 3 * 7 + 3, 3.0, 0)
    assert m.z[3, 3] - before[3, 3] == pytest.approx(3.25, rel=1e-12)
    assert np.count_nonzero(m.z - before) == 1


def test_a_droplet_stopping_in_a_dry_pit_fills_it_and_leaves_no_spike():
    """A droplet with sediment S that floods at a dry one-cell pit of room 0.2 m³ settles 0.9·S there
    (the seed keeps 10 % when it drains on): the pit is filled to its rim and the rest laid over its
    reach, so the cell ends one layer above its rim, not 0.9·S/Δx² above its floor (issue 38); the
    sediment budget counts the deposit."""
    z = np.full((9, 9), 10.0)
    z[4, 4] = 9.8
    z[:, 0] = 0.0  # an open side: water can leave
    m = _model(z)
    before = m.z.copy()
    S = 20.0
    _, _, _, S_kept = _flood(m, 4, 4, 1.0, S, spread=2)
    rise = m.z - before
    dep = 0.9 * S
    assert S_kept == pytest.approx(0.1 * S, rel=1e-12)
    assert abs(rise.sum() - dep) < 1e-12 * dep
    layer = (dep - 0.2) / 25.0  # the rest over the 5 × 5 square, all dry
    assert m.z[4, 4] == pytest.approx(10.0 + layer, rel=1e-12)
    np.testing.assert_allclose(rise[2:7, 2:7][rise[2:7, 2:7] != rise[4, 4]], layer, rtol=1e-12)
    assert m.budget[pools.B_DEPOSITED] == pytest.approx(dep, rel=1e-12)
