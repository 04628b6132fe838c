"""Neighbour search (SPEC SPH-8): identical to brute force; memory set by particles, not the domain."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from erosim.kernels import neighbours as nb


def _brute(pos, radius, n_fluid):
    tree = cKDTree(pos)
    out = []
    for i in range(len(pos)):
        cand = [j for j in tree.query_ball_point(pos[i], radius * 1.0001) if j != i]
        cand = [j for j in cand if np.sum((pos[i] - pos[j]) ** 2) < radius * radius]
        fl = sorted(j for j in cand if j < n_fluid)
        bd = sorted(j for j in cand if j >= n_fluid) if i < n_fluid else []
        out.append((fl, bd))
    return out


@pytest.mark.parametrize("dim", [2, 3])
def test_identical_to_brute_force_with_sparse_far_apart_clusters(dim):
    rng = np.random.default_rng(11)
    parts = [
        rng.random((300, dim)),  # a dense block
        rng.random((120, dim)) * 0.2 + 5000.0,  # a cluster 5 km away
        rng.random((40, dim)) * 0.05 - 3000.0,  # a small cluster on the other side
        np.array([[0.5] * dim, [0.5] * dim]),  # two particles at the same place
    ]
    pos = np.vstack(parts)
    n_fluid = 330  # the rest play boundary particles
    radius = 0.11
    start, mid, nbr = nb.find_neighbours(pos, radius, n_fluid)
    ref = _brute(pos, radius, n_fluid)
    for i, (fl, bd) in enumerate(ref):
        assert sorted(nbr[start[i] : mid[i]].tolist()) == fl, i
        assert sorted(nbr[mid[i] : start[i + 1]].tolist()) == bd, i


def test_points_on_cell_borders_and_exact_radius():
    """A lattice with spacing = radius/2: distances exactly equal to the radius are excluded (strict <)."""
    dx = 0.05
    ax = np.arange(8) * dx
    pos = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), axis=-1).reshape(-1, 3)
    radius = 2 * dx
    start, mid, nbr = nb.find_neighbours(pos, radius)
    ref = _brute(pos, radius, len(pos))
    for i, (fl, _) in enumerate(ref):
        assert sorted(nbr[start[i] : mid[i]].tolist()) == fl


def test_memory_grows_with_particles_not_domain():
    """Two particles 10 km apart at 0.1 m cells: the hash table is sized by the particle count."""
    pos = np.array([[0.0, 0.0, 0.0], [1.0e4, 1.0e4, 1.0e3]])
    grid = nb.Grid(3)
    ncell = nb.build_grid(grid, pos, 0.1)
    assert ncell == 2
    assert grid.table_key.size <= 16  # power of two ≥ 2n (min 16), not (10⁵)³ cells
    start, mid, nbr = nb.find_neighbours(pos, 0.1)
    assert nbr.size == 0
