"""Reservoir set-up of the dam-break flood (SPEC FL-1): coordinates ↔ cells, the barrier's rasterisation,
the breach window's geometry and the reservoir fill against a plain breadth-first search."""

from collections import deque

import numpy as np
import pytest
from scipy import ndimage

from erosim.core.config import validate_section
from erosim.core.errors import ConfigError, InputError
from erosim.core.heightmap import Heightmap
from erosim.terrain.reservoir import Breach, barrier_mask, cell_of, cut_breach, fill_reservoir, xy_of

UTM = (10.0, 0.0, 440000.0, 0.0, -10.0, 5100000.0)  # 10 m cells, north-west corner at (440000, 5100000)


def _bfs_fill(z, valid, blocked, level, seed):
    """Reference: the 4-connected cells below ``level`` reachable from ``seed``, by a queue."""
    ny, nx = z.shape
    ok = (z < level) & valid & ~blocked
    seen = np.zeros_like(ok)
    todo = deque([seed])
    seen[seed] = True
    while todo:
        r, c = todo.popleft()
        for rr, cc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
            if 0 <= rr < ny and 0 <= cc < nx and ok[rr, cc] and not seen[rr, cc]:
                seen[rr, cc] = True
                todo.append((rr, cc))
    return np.where(seen, level - z, 0.0)


# ----------------------------------------------------------------------------------------- coordinates
def test_cell_of_and_xy_of_follow_the_transform():
    hm = Heightmap(z=np.zeros((6, 8)), cell_size=10.0, transform=UTM)
    assert cell_of(hm, 440000.1, 5099999.9) == (0, 0)  # just inside the north-west corner
    assert cell_of(hm, 440035.0, 5099975.0) == (2, 3)
    assert xy_of(hm, 2, 3) == (440035.0, 5099975.0)
    rows, cols = np.meshgrid(np.arange(6), np.arange(8), indexing="ij")
    x, y = xy_of(hm, rows, cols)
    back = cell_of(hm, x, y)
    assert np.array_equal(back[0], rows) and np.array_equal(back[1], cols)
    assert cell_of(hm, 439999.0, 5099995.0)[1] == -1  # west of the map: off the grid, not clipped


def test_cell_of_without_transform_uses_the_default_one():
    hm = Heightmap(z=np.zeros((4, 5)), cell_size=2.0)  # spans x 0..10, y 0..8, row 0 = north
    assert cell_of(hm, 0.5, 7.5) == (0, 0)
    assert cell_of(hm, 9.5, 0.5) == (3, 4)
    assert xy_of(hm, 3, 4) == (9.0, 1.0)


def test_cell_of_inverts_a_rotated_transform():
    t = (8.0, 6.0, 100.0, 6.0, -8.0, 500.0)  # 10 m cells rotated by about 37°
    hm = Heightmap(z=np.zeros((5, 7)), cell_size=10.0, transform=t)
    rows, cols = np.meshgrid(np.arange(5), np.arange(7), indexing="ij")
    assert all(np.array_equal(a, b) for a, b in zip(cell_of(hm, *xy_of(hm, rows, cols)), (rows, cols), strict=True))


# --------------------------------------------------------------------------------------------- barrier
@pytest.mark.parametrize("seed", range(12))
def test_barrier_is_4_connected_and_covers_the_segment(seed):
    rng = np.random.default_rng(seed)
    hm = Heightmap(z=np.zeros((40, 50)), cell_size=10.0, transform=UTM)
    p = np.column_stack([rng.uniform(440000, 440500, 2), rng.uniform(5099600, 5100000, 2)])
    if seed == 0:  # exactly through cell corners: the diagonal of square cells
        p = np.array([[440000.0, 5100000.0], [440300.0, 5099700.0]])
    mask = barrier_mask(hm, p.tolist())
    _, n = ndimage.label(mask)  # 4-connected components
    assert n == 1
    t = np.linspace(0.0, 1.0, 20001)[:, None]
    pts = p[0] + t * (p[1] - p[0])
    r, c = cell_of(hm, pts[:, 0], pts[:, 1])
    assert mask[r, c].all()
    # thin: every barrier cell's centre is within half a cell diagonal (√2/2 cell, + 1e-9) of the line
    rr, cc = np.nonzero(mask)
    x, y = xy_of(hm, rr, cc)
    d = p[1] - p[0]
    dist = np.abs((x - p[0, 0]) * d[1] - (y - p[0, 1]) * d[0]) / np.hypot(*d) / 10.0
    assert dist.max() <= np.sqrt(0.5) + 1e-9


def test_a_diagonal_barrier_through_corners_gets_both_side_cells():
    hm = Heightmap(z=np.zeros((4, 4)), cell_size=1.0)
    mask = barrier_mask(hm, [[0.0, 4.0], [4.0, 0.0]])  # the map's diagonal, through every inner corner
    assert mask.sum() == 4 + 2 * 3
    assert np.array_equal(mask, np.abs(np.subtract.outer(np.arange(4), np.arange(4))) <= 1)


def test_a_valley_closed_by_a_polyline_fills_one_side_only():
    ny, nx = 30, 40
    x = np.arange(nx)
    z = np.tile(np.abs(x - 20.0) * 2.0, (ny, 1)) + np.linspace(10.0, 0.0, ny)[:, None]  # valley draining south
    hm = Heightmap(z=z, cell_size=1.0)
    dam = [[5.0, 17.3], [20.0, 14.1], [36.0, 16.9]]  # a bent dam across the valley, y up = north
    barrier = barrier_mask(hm, dam)
    depth = fill_reservoir(hm, 12.0, (20.5, 25.0), barrier=barrier, open_edges=["south", "east", "west"])
    wet = depth > 0
    assert wet[0].any()  # it reaches the closed north edge, which holds it
    rows, cols = np.nonzero(wet)
    xs, ys = xy_of(hm, rows, cols)
    dam = np.array(dam)
    assert np.all(ys > np.interp(xs, dam[:, 0], dam[:, 1]))  # every wet cell's centre north of the dam
    assert not (wet & barrier).any()
    assert wet.sum() > 50
    # without the barrier the same level reaches the open south edge
    with pytest.raises(InputError, match="reaches the south edge of the map"):
        fill_reservoir(hm, 12.0, (20.5, 25.0), open_edges=["south"])


def test_a_diagonal_barrier_does_not_leak():
    hm = Heightmap(z=np.zeros((25, 25)), cell_size=1.0)
    line = [[0.0, 25.0], [25.0, 0.0]]  # corner to corner
    depth = fill_reservoir(hm, 1.0, (2.0, 2.0), barrier=barrier_mask(hm, line))
    rows, cols = np.nonzero(depth > 0)
    assert rows.size > 0 and np.all(rows - cols > 0)  # strictly south-west of the diagonal


# ---------------------------------------------------------------------------------------------- breach
def _dam(ny=40, nx=60, cell=2.0):
    z = np.full((ny, nx), 100.0)
    return Heightmap(z=z, cell_size=cell)


@pytest.mark.parametrize("slope", [0.0, 0.5, 2.0])
def test_breach_geometry(slope):
    hm = _dam()  # 120 m × 80 m, flat at 100 m
    b = Breach(bottom_width=20.0, floor=90.0, side_slope=slope, line=((60.0, 10.0), (60.0, 70.0)))  # north-south
    cut = cut_breach(hm, b).z
    x, y = xy_of(hm, *np.meshgrid(np.arange(40), np.arange(60), indexing="ij"))
    s = np.abs(x - 60.0)
    within = (y >= 10.0) & (y <= 70.0)
    expected_floor = within & (s <= 10.0)
    assert np.array_equal(cut == 90.0, expected_floor)  # the floor: 20 m wide, within the segment only
    assert np.array_equal(cut[~within], hm.z[~within])
    assert (cut <= hm.z).all()
    if slope == 0.0:
        assert np.array_equal(cut < 100.0, expected_floor)  # vertical walls
    else:
        side = within & (s > 10.0)
        assert np.allclose(cut[side], np.minimum(100.0, 90.0 + (s[side] - 10.0) / slope), rtol=0, atol=1e-12)
        row = cut[20]  # one row across the window: the width at the top is b + 2·m·(100 − 90)
        assert np.sum(row < 100.0) * hm.cell_size == pytest.approx(20.0 + 2 * slope * 10.0, abs=2 * hm.cell_size)


def test_breach_never_raises_and_skips_nodata():
    rng = np.random.default_rng(3)
    z = rng.uniform(80.0, 120.0, (30, 30))
    nodata = np.zeros(z.shape, bool)
    nodata[10:13, 10:13] = True
    hm = Heightmap(z=z, cell_size=1.0, nodata=nodata)
    cut = cut_breach(hm, Breach(bottom_width=6.0, floor=95.0, side_slope=1.0, line=((0.0, 0.0), (30.0, 30.0))))
    assert (cut.z <= hm.z).all()
    assert (cut.z < hm.z).any()
    assert np.array_equal(cut.nodata, hm.nodata)  # nodata stays nodata (walls); its filler heights follow
    # the nearest data cell, as in every Heightmap


def test_breach_diagonal_line_measures_perpendicular_distance():
    hm = _dam(40, 40, 1.0)
    b = Breach(bottom_width=4.0, floor=95.0, line=((5.0, 5.0), (35.0, 35.0)))
    cut = cut_breach(hm, b).z
    x, y = xy_of(hm, *np.meshgrid(np.arange(40), np.arange(40), indexing="ij"))
    s = np.abs(x - y) / np.sqrt(2.0)
    along = (x + y - 10.0) / np.sqrt(2.0)
    inside = (s <= 2.0) & (along >= 0) & (along <= 30.0 * np.sqrt(2.0))
    assert np.array_equal(cut == 95.0, inside)


@pytest.mark.parametrize(
    "data, words",
    [
        ({"bottom_width": 0.0, "floor": 1.0, "line": [[0, 0], [1, 1]]}, "breach.bottom_width"),
        ({"bottom_width": 5.0, "floor": 1.0, "side_slope": -1, "line": [[0, 0], [1, 1]]}, "breach.side_slope"),
        ({"bottom_width": 5.0, "floor": 1.0, "line": [[0, 0], [0, 0]]}, "'breach.line' .* two ends must differ"),
        ({"bottom_width": 5.0, "floor": float("inf"), "line": [[0, 0], [1, 1]]}, "'breach.floor' .* finite number"),
        ({"bottom_width": 5.0, "floor": 1.0, "line": [[0, 0]]}, "breach.line"),
    ],
)
def test_bad_breach_is_one_sentence(data, words):
    with pytest.raises(ConfigError, match=words):
        validate_section(Breach, data, "breach")


# --------------------------------------------------------------------------------------------- reservoir
@pytest.mark.parametrize("seed", range(20))
def test_fill_matches_a_breadth_first_search(seed):
    rng = np.random.default_rng(100 + seed)
    ny, nx = rng.integers(8, 40, 2)
    z = ndimage.gaussian_filter(rng.normal(0.0, 5.0, (ny, nx)), 1.5)
    nodata = rng.random((ny, nx)) < 0.05
    blocked = rng.random((ny, nx)) < 0.08
    hm = Heightmap(z=z, cell_size=5.0, transform=UTM[:1] + (0.0, 440000.0, 0.0, -5.0, 5100000.0), nodata=nodata)
    cand = np.argwhere(hm.valid & ~blocked)
    r, c = cand[rng.integers(len(cand))]
    level = hm.z[r, c] + rng.uniform(0.01, 3.0)
    depth = fill_reservoir(hm, level, xy_of(hm, r, c), barrier=blocked)
    ref = _bfs_fill(hm.z, hm.valid, blocked, level, (r, c))
    assert depth.dtype == np.float64
    assert np.array_equal(depth, ref)  # the same cells, the same (exact) depths


def test_the_fill_may_touch_a_closed_edge_but_not_an_open_one():
    z = np.tile(np.linspace(0.0, 10.0, 20), (10, 1))  # rises eastward; lowest along the west edge
    hm = Heightmap(z=z, cell_size=1.0)
    depth = fill_reservoir(hm, 3.0, (1.5, 5.0))  # no open edge: the walls hold it
    assert (depth[:, 0] > 0).all()
    with pytest.raises(InputError) as err:
        fill_reservoir(hm, 3.0, (1.5, 5.0), open_edges=["west"])
    assert str(err.value) == (
        "The reservoir at level 3 m reaches the west edge of the map: the barrier does not close the valley; "
        "draw reservoir.barrier across the valley or lower reservoir.level."
    )
    fill_reservoir(hm, 3.0, (1.5, 5.0), open_edges=["east"])  # the east edge is not reached


def _bowl():
    y, x = np.mgrid[0:20, 0:20]
    z = np.hypot(x - 9.5, y - 9.5)
    nodata = np.zeros(z.shape, bool)
    nodata[2, 2] = True
    return Heightmap(z=z, cell_size=1.0, nodata=nodata)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"level": 3.0, "seed_xy": (25.0, 5.0)}, "The reservoir seed [25, 5] lies outside the DEM (x 0..20, y 0..20); "
         "set reservoir.seed to a point in the reservoir, in the DEM's coordinates."),
        ({"level": 3.0, "seed_xy": (2.5, 17.5)}, "The reservoir seed [2.5, 17.5] lies on a nodata cell of the DEM; "
         "set reservoir.seed to a point in the reservoir where the DEM has data."),
        ({"level": 0.5, "seed_xy": (14.5, 14.5)}, "The reservoir level 0.5 m is at or below the ground "
         "(6.363961031 m) at the seed [14.5, 14.5]; raise reservoir.level or move reservoir.seed to lower ground."),
        ({"level": float("nan"), "seed_xy": (10.0, 10.0)}, "The reservoir level nan is not a finite number; "
         "set reservoir.level in metres."),
        ({"level": 3.0, "seed_xy": (10.0,)}, "The reservoir seed (10.0,) is not a point; "
         "set reservoir.seed = [x, y] in the DEM's coordinates."),
        ({"level": 3.0, "seed_xy": (10.0, 10.0), "open_edges": ["up"]}, "Unknown map edge 'up' in outflow.edges; "
         "use north, south, east or west."),
    ],
)  # fmt: skip
def test_bad_reservoir_input_is_one_sentence(kwargs, message):
    with pytest.raises(InputError) as err:
        fill_reservoir(_bowl(), **kwargs)
    assert str(err.value) == message


def test_seed_on_the_barrier_is_refused():
    hm = _bowl()
    barrier = barrier_mask(hm, [[0.0, 10.2], [20.0, 10.2]])
    with pytest.raises(InputError, match=r"lies on the barrier; move reservoir.seed into the reservoir"):
        fill_reservoir(hm, 5.0, (10.0, 10.2), barrier=barrier)


def test_bad_barrier_polyline_is_one_sentence():
    with pytest.raises(InputError, match=r"The barrier polyline \[\[1.0, 2.0\]\] is not valid; give at least 2"):
        barrier_mask(_bowl(), [[1.0, 2.0]])
