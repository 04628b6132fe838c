"""HY-1 descend: the seed-case kernel (footprint one cell, whole steps) against the general one."""

import numpy as np
import pytest

from erosim.core.heightmap import Heightmap
from erosim.hydrology import droplets
from erosim.hydrology.model import HydrologyModel
from erosim.hydrology.params import P_MAXSTEPS, P_V0, HydrologyParams, VegetationParams
from erosim.hydrology.pools import B_SIZE, B_STEPS


def _terrain(n=64, seed=2):
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:n, 0:n]
    base = 60.0 * np.hypot(xx - n / 2, yy - n / 2) / n
    return base + ndimage.gaussian_filter(rng.random((n, n)), 2.0) * 40.0


def _seed_case(z, seed=1, pit_flood=False):
    p = HydrologyParams(length_scale=0.0, max_step=0.0, pit_flood=pit_flood, cycle_droplets=8000)
    return HydrologyModel(Heightmap(z=z, cell_size=20.0), p, VegetationParams(spawn=50.0), seed)


def test_variant_is_chosen_from_the_parameters():
    z = _terrain(16)
    assert _seed_case(z)._descend is droplets.descend_cell
    general = HydrologyModel(Heightmap(z=z, cell_size=20.0), HydrologyParams(length_scale=40.0))
    assert general._descend is droplets.descend


@pytest.mark.parametrize("pit_flood", [False, True])
def test_seed_case_kernel_agrees_with_the_general_one_to_rounding(pit_flood):
    m = _seed_case(_terrain(), pit_flood=pit_flood)
    m.run(3)  # streams, trees and some erosion in place
    rng = np.random.default_rng(0)
    n = m.z.shape[0]
    worst = 0.0
    for _ in range(200):
        x, y = rng.random(2) * (n - 1)
        out = []
        for fn in (droplets.descend, droplets.descend_cell):
            P = m.P.copy()
            P[P_MAXSTEPS] = 10
            z = m.z.copy()
            B = np.zeros(B_SIZE)
            r = fn(x, y, 0.0, 0.0, P[P_V0], 0.0, z, z.reshape(-1), m.stream.reshape(-1),
                   m.cover.reshape(-1), m.erod.reshape(-1), m.lake_of, m.level,
                   m.track.copy(), B, P)  # fmt: skip
            out.append((r[0], np.array(r[1:]), z, B[B_STEPS]))
        (sa, a, za, na), (sb, b, zb, nb) = out
        assert sa == sb and na == nb
        worst = max(worst, np.max(np.abs(a - b) / (np.abs(a) + 1.0)), np.max(np.abs(za - zb)))
    # the two kernels order their floating-point operations differently; over 10 steps the
    # rounding (1e-16) grows by the path's sensitivity (measured: ~1e-13); 1e-9 leaves room and
    # still catches any change of the model
    assert worst < 1e-9


def test_seed_case_budgets_close_and_runs_repeat():
    z = _terrain(48, seed=3)
    a, b = _seed_case(z, seed=5), _seed_case(z, seed=5)
    a.run(6)
    b.run(6)
    wb, sb = a.water_budget(), a.sediment_budget()
    assert wb["rained"] > 0 and sb["eroded"] > 0 and sb["deposited"] > 0
    # float64 sums of ~1e5 terms: rounding ~1e-16 each; 1e-9 is the project's stated bar
    assert wb["closure_rel"] < 1e-9 and sb["closure_rel"] < 1e-9
    assert sb["terrain_change_rel_error"] < 1e-9
    assert wb["in_lakes_tracked"] == pytest.approx(wb["in_lakes"], rel=1e-9, abs=1e-6)
    assert np.array_equal(a.z, b.z) and np.array_equal(a.budget, b.budget)
    assert np.array_equal(a.trees, b.trees) and np.array_equal(a.lake_depth(), b.lake_depth())


def _roll_over_a_pit(depth, pit_flood=True):
    """One droplet of the library's model (ℓ = 40 m on 20 m cells) released at rest 15 cells up a plane of
    0.3 m/m, its path crossing one cell lowered by ``depth`` (m); returns (status, x, y)."""
    n = 40
    z = 6.0 * np.mgrid[0:n, 0:n][1].astype(float)  # 6 m a cell, falling toward x = 0
    z[20, 15] -= depth
    m = HydrologyModel(
        Heightmap(z=z, cell_size=20.0), HydrologyParams(length_scale=40.0, pit_flood=pit_flood),
        VegetationParams(enabled=False), seed=1,
    )  # fmt: skip
    P, zz, B = m.P, m.z.copy(), np.zeros(B_SIZE)
    r = droplets.descend(
        30.0, 20.0, 0.0, 0.0, P[P_V0], 0.0, zz, zz.reshape(-1), m.stream.reshape(-1), m.cover.reshape(-1),
        m.erod.reshape(-1), m.lake_of, m.level, m.track.copy(), B, P,
    )  # fmt: skip
    return r[0], r[1], r[2]


def test_a_droplet_floods_a_pit_only_when_it_cannot_climb_out():
    """``pit_flood``: a droplet floods at the bottom of a pit when its kinetic energy cannot lift it over
    the rim, ½|v|² < g·(rim − h) (droplet_step.trapped). Rolling down 0.3 m/m for 300 m it carries
    ½|v|² of a few hundred m²/s² (g = ℓ/s² = 40 m/s² per unit slope at full volume): a cell 8 m deep on
    the plane (its rim, the cell below it, 2 m above its floor) does not hold it, and it leaves at the
    plane's foot; one 60 m deep (rim 54 m up) does, and it floods at that cell. Without the rule
    (the seed) it slides to and fro in the deep pit until its water is gone."""
    from erosim.hydrology.droplet_step import ENDED, LEFT, STOP

    status, x, _ = _roll_over_a_pit(8.0)
    assert status == LEFT and x < 0.5
    assert _roll_over_a_pit(60.0) == (STOP, 15.0, 20.0)
    assert _roll_over_a_pit(60.0, pit_flood=False)[0] == ENDED
