"""Puddles on a splash run's grid: particle volumes spread over their footprints and standing level in the
closed hollows (volume conserved), and the particles coarsened to fit a large DEM."""

import math

import numpy as np
import pytest

from erosim.coupling.puddles import footprint_volume, hollow_depth, pond
from erosim.coupling.raster import Raster
from erosim.scenarios.splash.build import coarsening


def test_a_footprint_spreads_a_particles_volume_over_the_cells_it_covers_and_keeps_it_all():
    r = Raster(0.0, 0.0, 1.0, 1.0, 11, 11)
    xy = np.array([[5.0, 5.0], [0.2, 0.3], [7.5, 2.5]])
    vol = footprint_volume(r, xy, np.array([8.0, 8.0, 8.0]), side=2.0)
    assert vol.sum() == pytest.approx(24.0, rel=1e-12)  # the one at the corner keeps its share inside
    # a 2 m square centred on a node covers that node's cell, half of its 4 edge neighbours', a quarter of
    # the 4 corner ones': 8 m³ / 4 m² = 2 m³ per whole cell
    assert vol[5, 5] == pytest.approx(2.0) and vol[5, 6] == pytest.approx(1.0) and vol[6, 6] == pytest.approx(0.5)


def test_water_in_a_hollow_stands_level_with_the_volume_it_was_given():
    n = 21
    x = np.arange(n) - 10.0
    z = 0.01 * (x[None, :] ** 2 + x[:, None] ** 2)  # a bowl; its rim (the map's edge) spills at 1 m
    r = Raster(0.0, 0.0, 1.0, 1.0, n, n)
    vol = footprint_volume(r, np.array([[10.2, 9.7], [12.0, 12.0]]), np.array([8.0, 8.0]), side=2.0)
    depth = pond(z, hollow_depth(z), vol, r.cell_area)
    wet = depth > 0
    assert depth.sum() * r.cell_area == pytest.approx(16.0, rel=1e-12)  # all of it, in the bowl
    assert np.ptp((z + depth)[wet]) < 1e-12  # one level surface
    # a paraboloid z = a r² holds V = π L²/(2a) below level L: L = √(2aV/π) (the grid's sum within a few %)
    level = math.sqrt(2 * 0.01 * 16.0 / math.pi)
    assert depth.max() == pytest.approx(level, rel=0.1) and depth.max() < 16.0 / 4  # not a particle in a cell


def test_water_beyond_a_hollows_capacity_spills():
    z = np.ones((5, 5))
    z[2, 2] = 0.5  # one cell 0.5 m deep: it holds 0.5 m³
    vol = np.zeros((5, 5))
    vol[2, 2] = 3.0
    depth = pond(z, hollow_depth(z), vol, 1.0)
    assert depth[2, 2] == pytest.approx(0.5) and depth.sum() == pytest.approx(0.5)


def test_the_particles_are_coarsened_together_until_the_ground_fits():
    r = Raster(0.0, 0.0, 1.0, 1.0, 300, 300)
    assert coarsening(r, 0.5, 0.25, 4, 0) == (0.5, 0.25)  # 0: never
    assert coarsening(r, 0.5, 0.25, 4, 10_000_000) == (0.5, 0.25)  # fits already
    dx, s = coarsening(r, 0.5, 0.25, 4, 200_000)
    assert dx / s == pytest.approx(2.0) and dx == pytest.approx(round(dx, 1))  # ratio kept, two digits
    cols = int(299 // s) ** 2
    assert cols * 4 <= 200_000 < int(299 // (s - 0.05)) ** 2 * 4  # the finest two-digit spacing that fits
