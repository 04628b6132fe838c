"""ST-5 with strata (ST-1): an impact lowers a cell by Δh·(1 − d), d the hardness of its band."""

import numpy as np
import pytest

from erosim.erosion.particle_stream_warszawski import Emitter as GradedEmitter
from erosim.erosion.particle_stream_warszawski import ParticleStream
from erosim.terrain.hardness import Strata, strata

N = 49  # odd: the window centre 0.5·(N − 1) = 24 is a cell, where Δh = e·m exactly
H0 = 10.0
# Tolerances: the lowerings are read as H0 − h, and heights near 10 m are spaced 1.8e-15 m apart
# (one ulp), so each carries up to ~2e-15 m of rounding: ATOL = 1e-14 m. RTOL = 1e-12: soft and
# hard lowerings are the same product e·m·g·(1 − d) up to one more rounded multiplication. A
# broken law shows up at the scale of d·e·m ≈ 0.1 m, 1e13 times larger.
RTOL, ATOL = 1e-12, 1e-14


class Emitter(GradedEmitter):
    """An emitter with the seed's plain lowering (slope_exponent = 0): these tests check ST-2…ST-5
    as the seed states them; the graded bed has its own tests (test_particle_stream_graded.py)."""

    slope_exponent: float = 0.0


def _impact(d, strata_spec=None, **kw):
    """One particle, one impact at the map centre (no jitter, a 1e-9 m window) on flat terrain
    at H0 = 10 m, cell 1 m; returns (lowering map, hardness the kernel held after the impact)."""
    em = Emitter(
        particles=1, steps=1, width=1e-9, spread_deg=0, speed_jitter=0, mass_jitter=0, max_angle_deg=0,
        x=0.5, y=0.5, mass=1.5, radius_per_mass=4.0, depth_per_mass=0.1, **kw,
    )  # fmt: skip
    h0 = np.full((N, N), H0)
    s = ParticleStream(h0, d, 1.0, [em], seed=3, strata=strata_spec).run()
    assert s.impacts == 1
    return h0 - s.h, s.d


def _soft():
    """The lowering on soft rock (d = 0): Δh = e·m·(1 − r²/λ²) inside λ = κ·m = 6 cells."""
    drop, _ = _impact(np.zeros((N, N)))
    assert drop.max() == pytest.approx(0.15, rel=1e-9)  # e·m at the impact point
    assert (drop > 0).sum() > 100  # a disc of radius 6 cells: ~113 cells
    return drop


# bands from base 5 m of 4 m (d 0.1), 3 m (d 0.6), 5 m (d 0.3): the flat terrain at 10 m lies at
# q = 5 m, in the 0.6 band [4, 7) m
FLAT = Strata(thickness=(4.0, 3.0, 5.0), hardness=(0.1, 0.6, 0.3), base=5.0)
# thin bands tilted eastward by 0.4 m per cell: the 6-cell impact disc spans all three bands
TILTED = Strata(thickness=(0.5, 0.7, 0.4), hardness=(0.2, 0.9, 0.5), base=0.3, tilt_x=0.4)


def test_strata_band_impact_lowers_by_one_minus_band_hardness_times_soft_lowering():
    """ST-5 on the strata path (hardness follows the cut): h ← h − Δh·(1 − d) with d the hardness
    of the band the cell's height lies in, here 0.6 at the impact: the lowering is 0.4 times the
    soft-rock lowering in every cell of the disc (tolerances: RTOL, ATOL above)."""
    soft = _soft()
    drop, d_after = _impact(np.zeros((N, N)), FLAT)  # the map given is replaced by the strata's
    hit = soft > 0
    np.testing.assert_allclose(drop, (1.0 - 0.6) * soft, rtol=RTOL, atol=ATOL)
    assert np.all(drop[~hit] == 0.0)
    # the cut (≤ 0.06 m) stays inside the 0.6 band: the hardness the kernel holds is still 0.6
    assert np.all(d_after == 0.6)


def test_tilted_strata_scale_each_cell_by_its_own_band():
    """The same law cell by cell when the disc crosses several tilted bands: each cell keeps
    (1 − d_b) of the soft lowering, d_b its band's hardness at the height it had before the
    impact (the band is re-read only after the cut). Tolerances: RTOL, ATOL above."""
    soft = _soft()
    d_before = strata(np.full((N, N), H0), 1.0, TILTED)
    hit = soft > 0
    assert len(np.unique(d_before[hit])) == 3  # the disc does cross all three bands
    drop, _ = _impact(np.zeros((N, N)), TILTED)
    np.testing.assert_allclose(drop, (1.0 - d_before) * soft, rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("d", [0.0, 0.35, 0.6, 1.0])
def test_fixed_hardness_map_scales_the_lowering_the_same_way(d):
    """The fixed-hardness path (no strata) with a uniform map d: lowering = (1 − d) × soft, and
    nothing at all for unerodible rock (d = 1). Tolerances: RTOL, ATOL above."""
    soft = _soft()
    drop, d_after = _impact(np.full((N, N), d))
    np.testing.assert_allclose(drop, (1.0 - d) * soft, rtol=RTOL, atol=ATOL)
    assert np.all(d_after == d)  # a fixed map is never rewritten
