"""The particle stream's graded bed (slope_exponent > 0): the lowering follows the ground's fall
ahead of each impact and never cuts below it, so a canyon's floor descends to its outlet."""

import numpy as np

from erosim.erosion.particle_stream_warszawski import Emitter, ParticleStream

NY, NX = 48, 120
D = 0.3  # uniform erodibility 1 − D
E, M = 0.1, 1.0  # depth_per_mass (cells of 1 m) and mean mass
# Floor tolerance: one impact's lowering at its centre, e m (1 − d) (mass jitter ±20 %), the
# method's own vertical resolution; a closed trough is tens of metres deep (the seed's variant
# below reads 31 m on this plane).
TOL = E * M * 1.2 * (1.0 - D)


def _run(h0, slope_exponent=1.0):
    em = Emitter(x=0.02, y=0.5, width=6.0, length=0.0, particles=600, steps=100, speed=1.5, max_speed=3.0,
                 max_angle_deg=12, gamma_deg=15, steer=0.05, spread_deg=1.0, mass=M, mass_jitter=0.2,
                 depth_per_mass=E, radius_per_mass=3.0, slope_exponent=slope_exponent)  # fmt: skip
    return ParticleStream(h0, np.full(h0.shape, D), 1.0, [em], seed=5).run()


def _floor(h0, h):
    """Lowest cut height in each column (NaN where nothing was cut)."""
    cut = h0 - h > 1e-9
    return np.array([h[cut[:, i], i].min() if cut[:, i].any() else np.nan for i in range(h.shape[1])])


def test_a_stream_down_a_plane_grades_its_floor_to_the_outlet():
    jj, ii = np.indices((NY, NX))
    h0 = 20.0 - 0.05 * ii  # falling 5 cm per cell towards the east edge, the stream's way
    s = _run(h0)
    floor = _floor(h0, s.h)
    assert np.isfinite(floor[5:]).all()  # a channel from the emitter to the east edge
    rise = floor[1:] - np.fmin.accumulate(floor)[:-1]  # above the lowest floor upstream
    assert np.nanmax(rise) <= TOL  # descending all the way: no trough, no pit at the emitter
    # the outlet stays open: the channel reaches the edge at or below the floor anywhere upstream
    assert floor[-1] <= np.nanmin(floor) + TOL
    # and the seed's plain lowering, on the same plane, digs the closed trough this guards against
    seed = _floor(h0, _run(h0, slope_exponent=0.0).h)
    assert np.nanmax(seed[1:] - np.fmin.accumulate(seed)[:-1]) > 10.0


def test_on_level_ground_a_graded_stream_has_no_fall_and_cuts_nothing():
    h0 = np.full((NY, NX), 10.0)
    s = _run(h0)
    # bilinear reads of level ground differ by round-off (~1e-15 m), the only "fall" there is
    assert np.abs(s.h - h0).max() < 1e-9


def test_nothing_is_cut_below_the_ground_ahead_of_the_last_impact():
    # a step down half-way: the graded bed may lower the upper reach towards the lower one, never
    # below it (the lower reach's ground is the base level the upper one grades to)
    jj, ii = np.indices((NY, NX))
    h0 = np.where(ii < NX // 2, 12.0, 10.0)
    s = _run(h0)
    assert s.h.min() >= 10.0 - TOL
    assert (s.h[:, : NX // 2] < 12.0).any()  # the step was worked on


def test_a_lip_at_the_outlet_is_cut_open():
    # a plane falling east to a 3 m sill along the east edge's last three columns: a closed outlet
    # before the fix (the fall read from behind the sill is negative there, so it was never cut;
    # the library canyon ended in an 8 m lip). The sill must be cut down to the floor upstream.
    jj, ii = np.indices((NY, NX))
    h0 = 20.0 - 0.05 * ii + np.where(ii >= NX - 3, 3.0, 0.0)
    s = _run(h0)
    floor = _floor(h0, s.h)
    assert np.isfinite(floor[-3:]).all()  # the sill was worked on
    # the floor at the edge no higher than the floor anywhere upstream, within one impact's lowering
    assert floor[-1] <= np.nanmin(floor[5:-3]) + TOL
    rise = floor[1:] - np.fmin.accumulate(floor)[:-1]
    assert np.nanmax(rise) <= TOL  # descending (or level within TOL) from the emitter to the edge
