"""Closed hollows, their spill levels, capacities and outlet paths (`erosim.terrain.lake_outlets`) on a
tilted plane with two pits whose capacities follow by hand, and the library `mountain-lake` scene's lakes
spilling into one another (SPEC VX-9)."""

from __future__ import annotations

import numpy as np
import pytest

from erosim.scenarios import loader
from erosim.scenarios.voxel.build import build_terrain
from erosim.scenarios.voxel.outputs import top_surface
from erosim.terrain.lake_outlets import hollows

SLOPE, PIT, NOTCH = 0.05, 0.5, 0.01  # the plane falls 1 in 20 towards +x; pits 0.5 m deep; a 1 cm notch


def two_pits(cell: float = 1.0) -> np.ndarray:
    """A plane z = SLOPE (40 − x) over 40 × 21 cells, with 3 × 3 pits lowered by PIT at x = 4–6 (upper)
    and x = 20–22 (lower), rows 9–11, and the rim cell downhill of each pit's middle row 1 cm lower
    than its neighbours (a notch: the pour point)."""
    x = np.arange(40) * cell
    z = np.tile(SLOPE * (40 - x), (21, 1))
    z[9:12, 4:7] -= PIT
    z[9:12, 20:23] -= PIT
    z[10, 7] -= NOTCH
    z[10, 23] -= NOTCH
    return z


def test_a_pit_in_a_tilted_plane_fills_to_its_downhill_rim_and_spills_into_the_pit_below():
    upper, lower = hollows(two_pits(), 1.0, least_m3=0.1)
    # Filled to the notch's height, SLOPE (40 − 7) − NOTCH: the depth at x is PIT − SLOPE (7 − x) − NOTCH,
    # 0.34, 0.39, 0.44 m in the columns x = 4, 5, 6, three rows each; the lower pit the same.
    assert upper.spill_level_m == pytest.approx(SLOPE * (40 - 7) - NOTCH)
    assert upper.capacity_m3 == pytest.approx(3 * (0.34 + 0.39 + 0.44))
    assert lower.capacity_m3 == pytest.approx(3 * (0.34 + 0.39 + 0.44))
    assert upper.path[0] == (10, 7) and upper.spills_into == 1
    # straight down the plane along the middle row into the lower pit at x = 20
    assert upper.path == tuple((10, c) for c in range(7, 21))
    assert lower.path[0] == (10, 23) and lower.spills_into == -1 and lower.path[-1][1] == 39  # off the edge


def test_hollows_below_the_least_volume_are_left_out_and_paths_run_through_them():
    z = two_pits()
    z[10, 13] -= 0.2  # a dimple on the way down, 0.15 m deep below its lowest rim cell (x = 14): 0.15 m³
    assert len(hollows(z, 1.0, least_m3=0.1)) == 3
    upper, lower = hollows(z, 1.0, least_m3=0.5)
    assert upper.spills_into == 1
    assert (10, 13) in upper.path
    assert lower.capacity_m3 == pytest.approx(3 * (0.34 + 0.39 + 0.44))


def test_a_plane_without_pits_has_no_hollows():
    assert hollows(np.tile(SLOPE * (40 - np.arange(40.0)), (21, 1)), 1.0) == []


def test_the_mountain_lake_scene_has_lakes_that_spill_into_other_lakes():
    """What the scene's description claims of its terrain (terrain.seed = 387, 0.5 m voxels): several
    hollows deep enough for a lake of two particle layers (deeper than the kernel support h = 1 m), and at
    least one that spills into another."""
    cfg = loader.load("mountain-lake").config
    terrain = build_terrain(cfg)
    z = top_surface(terrain)
    found = hollows(z, terrain.cell_size)
    h = cfg.sph.support()
    deep = [k for k, hl in enumerate(found) if (hl.spill_level_m - z[hl.cells]).max() > h]
    assert len(deep) >= 3
    assert any(hl.spills_into >= 0 for hl in found)
