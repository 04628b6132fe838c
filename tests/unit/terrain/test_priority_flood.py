"""Closed basins filled to their spill level (Priority-Flood+ε, Barnes et al. 2014), the plain falling
over the Euclidean distance (the eikonal update, default) or the 8-neighbour path (``metric="d8"``)."""

from __future__ import annotations

import numpy as np
import pytest
from skimage.morphology import reconstruction

from erosim.terrain.generate import generate
from erosim.terrain.priority_flood_barnes2014 import closed_basin_depth, fill_basins


def _flat_fill_reference(z: np.ndarray) -> np.ndarray:
    """Depression filling by morphological reconstruction by erosion (Soille 2004), seeded at the
    map's edge: an independent implementation of the slope-0 fill."""
    seed = np.full_like(z, z.max())
    seed[0, :], seed[-1, :], seed[:, 0], seed[:, -1] = z[0, :], z[-1, :], z[:, 0], z[:, -1]
    return reconstruction(seed, z, method="erosion")


def _descends_to_edge(z: np.ndarray, cell: float, slope: float) -> bool:
    """Every inner cell has an 8-neighbour lower by at least slope·distance (less rounding)."""
    ny, nx = z.shape
    pad = np.pad(z, 1, constant_values=np.inf)
    drop = np.full((ny, nx), -np.inf)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dx == dy == 0:
                continue
            dist = cell * np.hypot(dx, dy)
            nb = pad[1 + dy : 1 + dy + ny, 1 + dx : 1 + dx + nx]
            drop = np.maximum(drop, (z - nb) / dist)
    inner = drop[1:-1, 1:-1]
    return bool((inner >= slope * (1 - 1e-9) - 1e-9).all())


@pytest.fixture(scope="module")
def mountains():
    return generate("mountains", size=96, cell_size=20.0, seed=3).z


@pytest.mark.parametrize("metric", ["euclidean", "d8"])
def test_slope_zero_equals_morphological_reconstruction(mountains, metric):
    # two independent algorithms for the same fill: equal to rounding of float64 maxima (exact)
    filled = fill_basins(mountains, 20.0, 0.0, metric=metric)
    np.testing.assert_array_equal(filled, _flat_fill_reference(mountains))
    assert (closed_basin_depth(mountains) > 0).mean() > 0.05  # the noise terrain has closed basins


# the steepest fall to a neighbour a raised cell is guaranteed: s for the d8 raise, s/√2 for the
# eikonal update (two accepted 4-neighbours at equal height, the front arriving diagonally)
@pytest.mark.parametrize("metric, least", [("euclidean", 1 / np.sqrt(2)), ("d8", 1.0)])
def test_slope_gives_a_descending_path_and_leaves_open_ground(mountains, metric, least):
    s = 0.005
    filled = fill_basins(mountains, 20.0, s, metric=metric)
    assert _descends_to_edge(filled, 20.0, least * s)
    assert not _descends_to_edge(mountains, 20.0, 0.0)  # the raw terrain has pits
    flat = _flat_fill_reference(mountains)
    assert (filled >= flat).all()  # never below the spill level
    open_ground = flat == mountains
    # outside closed basins only the ε ramp can raise a cell: at most s × the map's diagonal path
    lift = filled[open_ground] - mountains[open_ground]
    assert (lift == 0).mean() > 0.9
    # a filled basin's plain rises above its spill level by at most s times the longest D8 path in it
    assert (filled - flat).max() <= s * 20.0 * 96 * np.sqrt(2)


@pytest.mark.parametrize("metric", ["euclidean", "d8"])
def test_a_bowl_fills_to_its_rim_as_a_cone(metric):
    # a paraboloid bowl on a 41² grid of 1 m spills at the edge's lowest cells, the midpoints
    # (r = 20 m → 0.04·400 = 16 m); with slope s the plain rises from there at s per metre
    n, cell, s = 41, 1.0, 0.01
    y, x = np.mgrid[0:n, 0:n] - 20.0
    z = 0.04 * (x**2 + y**2)
    filled = fill_basins(z, cell, s, metric=metric)
    flat = fill_basins(z, cell, 0.0, metric=metric)
    np.testing.assert_array_equal(flat, np.maximum(z, 16.0))  # the disc r < 20 m stands at the spill level
    # the centre is 20 m from the nearest edge midpoint along a grid axis: exactly 20 steps for d8; the
    # eikonal front, fed also by the midpoints' slightly higher neighbours, within its first-order 3 %
    rise = 20 * s
    assert filled[20, 20] == pytest.approx(16.0 + rise, abs=1e-9 if metric == "d8" else 0.03 * rise)
    assert _descends_to_edge(filled, cell, s / np.sqrt(2))


def _notched_basin(n=201, s=0.01):
    """A walled square basin of 1 m cells, its floor 100 m below a notch at the middle of one edge: the
    plain must stand at the notch's height plus s times the Euclidean distance from it."""
    z = np.full((n, n), -300.0)
    z[0, :] = z[-1, :] = z[:, 0] = z[:, -1] = 10.0
    z[0, n // 2] = -200.0
    y, x = np.mgrid[0:n, 0:n]
    r = np.hypot(y, x - n // 2)
    radial = np.arctan2(y, x - n // 2)  # direction away from the notch
    inner = (y > 1) & (y < n - 2) & (x > 1) & (x < n - 2)  # away from the walls, for the gradient
    return z, r, radial, inner


def test_the_plain_falls_over_the_euclidean_distance_in_every_direction():
    """Known answer: a basin spilling through one notch fills to a circular cone about the notch.

    Tolerances are the first-order fast-marching scheme's: its error about a point source decays like
    (log r)/r, measured here as 2.5 % of the distance at 20 cells and 0.5 % at 190; the gradient's
    direction is within 1.4° RMS of the radius. The 8-neighbour raise (``d8``) misses by a fixed 8.2 %
    (1/cos 22.5° = 1.0824, at 22.5° off the axes) and points every gradient at 22.5° modulo 45°.
    """
    s = 0.01
    z, r, radial, inner = _notched_basin(s=s)
    far = inner & (r >= 20)
    for metric in ("euclidean", "d8"):
        f = fill_basins(z, 1.0, s, metric=metric)
        ratio = (f[far] + 200.0) / (s * r[far])
        gy, gx = np.gradient(f)
        off = np.degrees(np.arctan2(gy, gx) - radial)[far]
        off = (off + 180.0) % 360.0 - 180.0
        rms = float(np.sqrt(np.mean(off**2)))
        if metric == "euclidean":
            assert ratio.min() >= 1.0 - 1e-12  # never below the exact cone (a plain that drains)
            assert ratio.max() <= 1.03
            assert ratio[r[far] >= 100].max() <= 1.01
            assert rms <= 2.0
            assert np.hypot(gx, gy)[far].mean() == pytest.approx(s, rel=0.01)  # |∇F| = s
        else:
            assert ratio.max() == pytest.approx(1.0824, abs=1e-3)
            assert rms > 10.0


def test_generate_applies_fill_slope():
    raw = generate("mountains", size=64, cell_size=20.0, seed=5)
    drained = generate("mountains", size=64, cell_size=20.0, seed=5, fill_slope=0.005)
    np.testing.assert_array_equal(drained.z, fill_basins(raw.z, 20.0, 0.005))
    with pytest.raises(ValueError):
        fill_basins(raw.z, 20.0, -1.0)


def test_the_demo_terrain_drains_and_the_seed_preset_keeps_its_basins():
    """The library hydrology scenario (the demo) fills its closed basins; the seed's preset does not."""
    from erosim.scenarios import loader
    from erosim.scenarios.schema_common import build_terrain

    demo = loader.load("hydrology", ["terrain.size=96"]).config
    assert closed_basin_depth(build_terrain(demo.terrain, demo.seed).z).max() == 0.0
    seed = loader.load("hydrology", ["terrain.size=96"], preset="simplehydrology-2020").config
    assert (closed_basin_depth(build_terrain(seed.terrain, seed.seed).z) > 0).mean() > 0.05
