"""Flood hazard (SPEC FL-2 … FL-4): classes on the FL-3 table's boundary values, running maxima and
arrival times from a scripted sequence of states, checkpoint round trip, areas and shares, polygons."""

import numpy as np
import pytest

from erosim.analysis.hazard import CLASSES, HAZARD_LIMITS, HAZARD_MEANING, HazardMaps, classify, polygon_mask
from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap, xy_of

UP = 1e-7  # a step just over a limit (values on the limit take the lower class)


@pytest.mark.parametrize(
    "d, v, dv, expect",
    [
        (0.3, 1.0, 0.3, 1),  # D and V·D exactly on H1's limits
        (0.3 + UP, 1.0, 0.3, 2),
        (0.1, 1.0, 0.3 + UP, 2),
        (0.5, 1.0, 0.5, 2),
        (0.5 + UP, 1.0, 0.5, 3),
        (0.3, 2.0, 0.6, 2),
        (0.3, 2.0, 0.6 + UP, 4),  # V·D over 0.6 skips H3 (same V·D limit as H2)
        (1.2, 0.5, 0.6, 3),
        (1.2 + UP, 0.5, 0.6, 4),
        (0.5, 2.0, 1.0, 4),
        (0.5, 2.0, 1.0 + UP, 5),
        (2.0, 0.5, 1.0, 4),
        (2.0 + UP, 0.5, 1.0, 5),
        (0.1, 2.0, 0.2, 1),  # V = 2.0 keeps the lowest class the depth allows
        (0.1, 2.01, 0.201, 5),  # V over 2 m/s: H5 at once
        (1.0, 4.0, 4.0, 5),
        (1.0, 4.0, 4.01, 6),
        (4.0, 1.0, 4.0, 5),
        (4.01, 0.5, 2.0, 6),
        (0.1, 4.01, 0.401, 6),
        (0.01, 0.0, 0.0, 1),  # exactly the wet depth: wet
        (0.00999, 50.0, 0.4995, 0),  # shallower: dry, whatever the speed
        (float("nan"), 1.0, 1.0, 0),
    ],
)
def test_class_on_the_table_boundaries(d, v, dv, expect):
    got = classify(np.array([d]), np.array([v]), np.array([dv]))
    assert got.dtype == np.uint8
    assert int(got[0]) == expect


def test_classify_agrees_with_a_cell_by_cell_reading_of_the_table():
    rng = np.random.default_rng(7)
    d = rng.uniform(0.0, 5.0, 5000) * (rng.random(5000) < 0.9)
    v = rng.uniform(0.0, 5.0, 5000)
    dv = d * v * rng.uniform(0.5, 1.0, 5000)
    got = classify(d, v, dv, wet_depth=0.05)
    for k in range(len(d)):
        if d[k] < 0.05:
            ref = 0
        else:
            ref = next(
                (i + 1 for i, (a, b, c) in enumerate(HAZARD_LIMITS) if dv[k] <= a and d[k] <= b and v[k] <= c), 6
            )
        assert got[k] == ref


def test_the_table_has_six_classes_with_meanings():
    assert CLASSES == ("H1", "H2", "H3", "H4", "H5", "H6")
    assert len(HAZARD_LIMITS) == 5 and all(HAZARD_MEANING[c] for c in CLASSES)
    assert [lim[1] for lim in HAZARD_LIMITS] == sorted(lim[1] for lim in HAZARD_LIMITS)  # depth limits rise


def test_maxima_and_arrival_from_a_scripted_sequence():
    maps = HazardMaps((1, 4), wet_depth=0.01)
    valid = np.array([[True, True, True, False]])  # the last cell is nodata
    steps = [  # t, depth, speed of the cells (0, 0..3)
        (0.0, [0.0, 0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0]),
        (1.0, [0.5, 0.005, 0.0, 3.0], [1.0, 10.0, 0.0, 1.0]),
        (2.0, [0.2, 0.02, 0.0, 3.0], [3.0, 0.5, 0.0, 1.0]),
        (3.0, [1.0, 0.0, float("nan"), 3.0], [0.1, 0.0, 9.0, 1.0]),
    ]
    for t, d, v in steps:
        maps.update(t, np.array([d]), np.array([v]), valid=valid)
    assert maps.max_depth.tolist() == [[1.0, 0.02, 0.0, 0.0]]  # wet depths only; nodata never recorded
    assert maps.max_speed.tolist() == [[3.0, 0.5, 0.0, 0.0]]  # the 10 m/s of a dry cell does not count
    assert np.allclose(maps.max_dv, [[0.6, 0.01, 0.0, 0.0]], rtol=0, atol=1e-15)  # 0.2·3, not 1.0·3
    assert maps.arrival.tolist() == [[1.0, 2.0, np.inf, np.inf]]
    assert maps.classes().tolist() == [[5, 1, 0, 0]]  # V = 3 m/s: H5


def test_update_refuses_a_grid_of_another_shape():
    with pytest.raises(ValueError, match=r"must have the hazard grid's shape \(3, 3\)"):
        HazardMaps((3, 3)).update(0.0, np.zeros((3, 4)), np.zeros((3, 4)))


def _random_steps(maps, rng, n, t0):
    for k in range(n):
        d = np.maximum(0.0, rng.normal(0.2, 0.5, maps.shape))
        maps.update(t0 + k, d, rng.uniform(0.0, 5.0, maps.shape))


def test_state_round_trip_continues_exactly():
    rng = np.random.default_rng(1)
    a = HazardMaps((20, 30))
    _random_steps(a, rng, 5, 0.0)
    state = a.state_dict()
    state["max_depth"][:] = -1.0  # a copy: changing it leaves the maps alone
    assert (a.max_depth >= 0).all()
    b = HazardMaps((20, 30))
    b.load_state_dict(a.state_dict())
    for m in (a, b):
        _random_steps(m, np.random.default_rng(2), 5, 5.0)
    for k, v in a.state_dict().items():
        assert np.array_equal(v, b.state_dict()[k])
    with pytest.raises(InputError, match="has shape \\(20, 30\\) but the grid is \\(2, 2\\)"):
        HazardMaps((2, 2)).load_state_dict(a.state_dict())


def test_summary_areas_and_shares():
    rng = np.random.default_rng(4)
    maps = HazardMaps((40, 50))
    _random_steps(maps, rng, 3, 0.0)
    cls = maps.classes()
    inside = np.zeros((40, 50), bool)
    inside[5:25, 10:30] = True
    s = maps.summary(25.0, inside=inside)
    assert s["flooded_area_m2"] == 25.0 * np.count_nonzero(cls)
    assert sum(s["hazard_share"].values()) == pytest.approx(1.0, abs=1e-12)
    for k, name in enumerate(CLASSES, start=1):
        assert s["hazard_area_m2"][name] == 25.0 * np.count_nonzero(cls == k)
        assert s["inside"]["hazard_area_m2"][name] == 25.0 * np.count_nonzero((cls == k) & inside)
    assert s["inside"]["flooded_area_m2"] == 25.0 * np.count_nonzero(cls[inside])
    assert sum(s["inside"]["hazard_share"].values()) == pytest.approx(1.0, abs=1e-12)
    assert len({v for v in s["hazard_share"].values()}) > 3  # several classes present, so the test means something


def test_summary_of_a_dry_run_is_zero():
    s = HazardMaps((3, 3)).summary(1.0)
    assert s["flooded_area_m2"] == 0.0 and set(s["hazard_share"].values()) == {0.0}


def test_polygon_mask_takes_cells_whose_centres_are_inside():
    hm = Heightmap(z=np.zeros((10, 12)), cell_size=5.0, transform=(5.0, 0.0, 1000.0, 0.0, -5.0, 2050.0))
    poly = [[1012.0, 2012.0], [1041.0, 2012.0], [1041.0, 2033.0], [1012.0, 2033.0]]
    mask = polygon_mask(hm, poly)
    x, y = xy_of(hm, *np.meshgrid(np.arange(10), np.arange(12), indexing="ij"))
    assert np.array_equal(mask, (x > 1012) & (x < 1041) & (y > 2012) & (y < 2033))
    assert mask.sum() == 6 * 5  # x centres 1012.5 … 1037.5, y centres 2012.5 … 2032.5
    with pytest.raises(InputError, match=r"The polygon \[\[0, 0\], \[1, 1\]\] is not valid; give at least three"):
        polygon_mask(hm, [[0, 0], [1, 1]])


def test_invalid_cells_are_never_flooded_and_the_reservoir_is_left_out_below_the_dam():
    """Cells outside ``valid`` (nodata, walls) are class 0 and in no area whatever their maxima; the
    area below the dam leaves out the reservoir's cells and the cells wet at t = 0."""
    valid = np.ones((1, 6), bool)
    valid[0, 5] = False
    maps = HazardMaps((1, 6), wet_depth=0.01, valid=valid)
    maps.max_depth[:] = 0.2  # H1 everywhere, speed 0
    maps.arrival[:] = [0.0, 0.0, 0.0, 5.0, 7.0, 9.0]  # cells 0-2 wet at t = 0
    reservoir = np.array([[True, True, False, False, False, False]])
    assert maps.classes().tolist() == [[1, 1, 1, 1, 1, 0]]
    s = maps.summary(2.0, reservoir=reservoir)
    assert s["flooded_area_m2"] == 10.0 and s["hazard_area_m2"]["H1"] == 10.0
    assert s["below_dam"]["flooded_area_m2"] == 4.0  # cells 3 and 4: not 2 (wet at t = 0), not 5 (invalid)
    assert s["below_dam"]["hazard_share"]["H1"] == 1.0
    with pytest.raises(ValueError, match="shape"):
        HazardMaps((2, 2), valid=np.ones((3, 3), bool))
