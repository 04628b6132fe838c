"""Closed basins filled to their spill level (Priority-Flood+ε, Barnes et al. 2014)."""

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


def test_slope_zero_equals_morphological_reconstruction(mountains):
    # two independent algorithms for the same fill: equal to rounding of float64 maxima (exact)
    filled = fill_basins(mountains, 20.0, 0.0)
    np.testing.assert_array_equal(filled, _flat_fill_reference(mountains))
    assert (closed_basin_depth(mountains) > 0).mean() > 0.05  # the noise terrain has closed basins


def test_slope_gives_a_descending_path_and_leaves_open_ground(mountains):
    s = 0.005
    filled = fill_basins(mountains, 20.0, s)
    assert _descends_to_edge(filled, 20.0, s)
    assert not _descends_to_edge(mountains, 20.0, 0.0)  # the raw terrain has pits
    flat = _flat_fill_reference(mountains)
    assert (filled >= flat).all()  # never below the spill level
    open_ground = flat == mountains
    # outside closed basins only the ε ramp can raise a cell: at most s × the map's diagonal path
    lift = filled[open_ground] - mountains[open_ground]
    assert (lift == 0).mean() > 0.9
    # a filled basin's plain rises above its spill level by at most s times the longest D8 path in it
    assert (filled - flat).max() <= s * 20.0 * 96 * np.sqrt(2)


def test_a_bowl_fills_to_its_rim_as_a_cone():
    # a paraboloid bowl on a 41² grid of 1 m spills at the edge's lowest cells, the midpoints
    # (r = 20 m → 0.04·400 = 16 m); with slope s the plain rises from there at s per metre of D8 path
    n, cell, s = 41, 1.0, 0.01
    y, x = np.mgrid[0:n, 0:n] - 20.0
    z = 0.04 * (x**2 + y**2)
    filled = fill_basins(z, cell, s)
    flat = fill_basins(z, cell, 0.0)
    np.testing.assert_array_equal(flat, np.maximum(z, 16.0))  # the disc r < 20 m stands at the spill level
    # the centre is 20 D8 steps from the nearest edge midpoint: 16 + 20·s
    assert filled[20, 20] == pytest.approx(16.0 + 20 * s, abs=1e-9)
    assert _descends_to_edge(filled, cell, s)


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
