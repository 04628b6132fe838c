"""The demo's terrain measures (erosim.analysis.terrain_metrics) on terrains whose answer is known."""

import numpy as np

from erosim.analysis.terrain_metrics import hillslopes, lake_counts, laplacian_roughness, river_network


def _slope(n=64, cell=20.0):
    y, x = np.mgrid[0:n, 0:n] * cell
    return 0.3 * x + 0.1 * y + 50 * np.sin(x / 400.0)  # smooth: curvature far below a cell's scale


def test_a_washboard_scores_above_the_roughness_bound():
    """Cell-scale ridges (the demo's "scale" artefact) of 1 m on 20 m cells raise the roughness far
    past the 1.1 × bound; the smooth slope itself is nearly flat in ∇²z."""
    z = _slope()
    every = np.ones(z.shape, bool)
    board = z + 1.0 * ((np.add.outer(np.arange(64), np.arange(64)) % 2) - 0.5)  # diagonal ridges
    before, after = laplacian_roughness(z, 20.0, every), laplacian_roughness(board, 20.0, every)
    assert after > 10 * before and after > 1.1 * before
    # a checkerboard of ±a has ∇²z = ∓8a/Δx² at every cell: its std is 8 · 0.5 / 20² = 0.01 m⁻¹
    assert abs(after - 8 * 0.5 / 20.0**2) < 0.02 * after


def test_hillslopes_leave_out_rivers_and_lakes():
    stream = np.zeros((4, 4))
    stream[1, :] = 0.5
    lake = np.zeros((4, 4))
    lake[3, 3] = 1.0
    assert hillslopes(stream, lake).sum() == 16 - 4 - 1


def test_river_network_spans_and_outlets():
    stream, lake = np.zeros((50, 100)), np.zeros((50, 100))
    stream[25, 0:60] = 0.5  # from the west edge, 60 % of the width
    stream[10, 40:50] = 0.3  # a streak on a hillside: no lake, no edge
    stream[40, 70:80] = 0.3  # ends in a lake
    lake[40:45, 80:85] = 2.0
    net = river_network(stream, lake)
    assert net["rivers"] == 3 and net["river_cells"] == 80
    assert net["longest_span_fraction"] == 0.6
    assert net["reaching_outlet_fraction"] == (60 + 10) / 80
    assert net["reaching_edge_or_lake_fraction"] == (60 + 10) / 80  # the lake has 25 cells
    assert river_network(np.zeros((5, 5)), np.zeros((5, 5)))["rivers"] == 0


def test_a_puddle_is_an_outlet_only_in_the_loose_share():
    """A river ending at a one-cell puddle reaches an outlet, but not the edge or a lake of ≥ 10 cells."""
    stream, lake = np.zeros((50, 100)), np.zeros((50, 100))
    stream[25, 0:60] = 0.5  # from the west edge
    stream[10, 40:60] = 0.3  # ends beside a one-cell puddle
    lake[10, 60] = 0.2
    lake[30:33, 80:84] = 1.0  # a lake of 12 cells, away from every river
    net = river_network(stream, lake)
    assert net["reaching_outlet_fraction"] == 1.0
    assert net["reaching_edge_or_lake_fraction"] == 60 / 80
    assert lake_counts(lake) == {"lakes": 2, "one_cell_lakes": 1, "large_lakes": 1}
