"""Particle-stream erosion (Warszawski, SPEC ST-2…ST-5) on small synthetic maps."""

import math

import numpy as np
import pytest

from erosim.core.errors import ConfigError, InputError
from erosim.erosion.particle_stream_warszawski import Emitter as GradedEmitter
from erosim.erosion.particle_stream_warszawski import ParticleStream, _steer, erode
from erosim.terrain.hardness import Strata, strata

N = 96


class Emitter(GradedEmitter):
    """An emitter with the seed's plain lowering (slope_exponent = 0): these tests check ST-2…ST-5
    as the seed states them; the graded bed has its own tests (test_particle_stream_graded.py)."""

    slope_exponent: float = 0.0


def flat(n=N, value=10.0):
    return np.full((n, n), value)


def single(**kw):
    """One particle, one impact, no jitter: it strikes exactly at the window centre."""
    base = dict(
        particles=1, steps=1, width=1e-9, spread_deg=0, speed_jitter=0, mass_jitter=0, max_angle_deg=0, x=0.5, y=0.5
    )
    return Emitter(**{**base, **kw})


def test_single_impact_stays_inside_radius_of_influence():
    h0 = flat()
    em = single(mass=1.5, radius_per_mass=4.0, depth_per_mass=0.1)
    h, _, _ = erode(h0, np.zeros_like(h0), 1.0, [em], seed=3)
    lam = 1.5 * 4.0
    cx = cy = 0.5 * (N - 1)
    jj, ii = np.indices(h0.shape)
    r = np.hypot(ii - cx, jj - cy)
    changed = h != h0
    assert not changed[r >= lam].any()  # ST-5: Δh <= 0 beyond λ leaves the terrain untouched
    assert changed[r < lam - 1e-6].all()
    # largest at the impact point, e·m there (erodibility 1): Δh(r) = e m (1 - r²/λ²)
    # (tolerance: the 1e-9-wide window shifts the impact by < 1e-9 cells, a 1e-9 relative change)
    drop = h0 - h
    np.testing.assert_allclose(drop, np.clip(0.15 * (1 - r**2 / lam**2), 0, None), rtol=0, atol=1e-9)


def test_heavier_particle_erodes_wider_area():
    h0 = flat()
    areas = []
    for mass in (1.0, 2.0):
        h, _, _ = erode(h0, np.zeros_like(h0), 1.0, [single(mass=mass, radius_per_mass=5.0)], seed=1)
        areas.append(int((h < h0).sum()))
    assert areas[1] > areas[0]
    # λ ∝ m, so the disc's area ∝ m²: ratio 4 up to the lattice count of discs of radius 5 and 10
    # cells (boundary cells ~ 2πλ, i.e. a few percent here)
    assert 3.5 < areas[1] / areas[0] < 4.5
    assert areas[1] == pytest.approx(math.pi * 10.0**2, rel=0.05)


def test_hard_cells_never_change_and_hardness_scales_lowering():
    rng = np.random.default_rng(0)
    h0 = 50.0 + rng.random((N, N))
    d = np.full_like(h0, 0.5)
    d[30:60, 40:50] = 1.0  # an unerodible dyke across the stream
    em = Emitter(particles=400, steps=40, x=0.02, y=0.45, width=30.0, speed=1.5)
    h, _, vol = erode(h0, d, 1.0, [em], seed=7)
    assert np.array_equal(h[d == 1.0], h0[d == 1.0])
    assert (h[d == 0.5] < h0[d == 0.5]).any()
    # a single impact on erodibility 0.25 lowers exactly a quarter of what it lowers on 0
    a, _, _ = erode(flat(), np.zeros((N, N)), 1.0, [single()], seed=1)
    b, _, _ = erode(flat(), np.full((N, N), 0.75), 1.0, [single()], seed=1)
    np.testing.assert_allclose(flat() - b, 0.25 * (flat() - a), rtol=1e-12, atol=1e-15)


def test_terrain_only_goes_down_and_removed_volume_is_reported():
    rng = np.random.default_rng(1)
    h0 = 20.0 + 3.0 * rng.random((N, N))
    d = rng.random((N, N))
    cell = 2.5
    em = [Emitter(particles=300, x=0.05, y=0.3), Emitter(particles=300, x=0.5, y=0.95, direction_deg=90)]
    h, _, vol = erode(h0, d, cell, em, seed=11)
    assert (h <= h0).all()
    assert vol > 0
    # the kernel's running sum and the map difference agree to round-off (different summation order)
    assert vol == pytest.approx(float((h0 - h).sum()) * cell**2, rel=1e-9)


def test_same_seed_same_result_other_seed_differs():
    rng = np.random.default_rng(2)
    h0 = 5.0 * rng.random((N, N))
    d = 0.5 * rng.random((N, N))
    em = [Emitter(particles=200, max_angle_deg=40, speed=1.0)]
    a, da, va = erode(h0, d, 1.0, em, seed=5)
    b, db, vb = erode(h0, d, 1.0, em, seed=5)
    c, _, _ = erode(h0, d, 1.0, em, seed=6)
    assert np.array_equal(a, b) and np.array_equal(da, db) and va == vb
    assert not np.array_equal(a, c)


def test_resume_from_state_reproduces_uninterrupted_run():
    h0 = flat(64)
    d = np.full_like(h0, 0.2)
    em = [Emitter(particles=150, steps=20, max_angle_deg=30, speed=1.0)]
    whole = ParticleStream(h0, d, 1.0, em, seed=9, pool=8).run(batch=7)
    first = ParticleStream(h0, d, 1.0, em, seed=9, pool=8)
    first.advance(50)
    saved = {k: np.array(v) for k, v in first.state_dict().items()}
    second = ParticleStream(h0, d, 1.0, em, seed=9, pool=8)
    second.load_state_dict(saved)
    second.run(batch=7)
    assert np.array_equal(second.h, whole.h)
    assert second.removed == whole.removed and second.impacts == whole.impacts


def steer(d, alpha, gamma, probes, share):
    """The collision rule for a particle at (10, 20) with speed 2 cells."""
    step = gamma / probes
    return _steer(d, 10.0, 20.0, alpha, 2.0, math.cos(step), math.sin(step), probes, step, share)


def test_collision_turns_toward_the_softer_side():
    d = np.full((40, 40), 0.8)
    d[:20, :] = 0.1  # soft band north (small row index) of a particle at row 20 heading east
    gamma = math.radians(30)
    alpha = steer(d, 0.0, gamma, 3, 1.0)
    assert alpha < 0  # turned north (toward −y)
    assert alpha >= -gamma - 1e-12
    # a uniform map keeps the course (ties go to the smallest turn)
    assert steer(np.full((40, 40), 0.3), 0.4, gamma, 3, 1.0) == 0.4
    # half steering turns half as far
    assert steer(d, 0.0, gamma, 3, 0.5) == pytest.approx(0.5 * alpha)
    # the mirror image (soft band south, from row 21) turns the other way
    south = np.full((40, 40), 0.8)
    south[21:, :] = 0.1
    assert steer(south, 0.0, gamma, 3, 1.0) == pytest.approx(-alpha, abs=1e-12)


def test_stream_bends_into_a_soft_band_beside_it():
    n = 128
    h0 = flat(n)
    d = np.full((n, n), 0.9)
    d[:60, :] = 0.05  # soft rock beside (north of) the stream, whose window spans rows 60..68
    em = [
        Emitter(
            particles=300,
            steps=60,
            x=0.0,
            y=64 / (n - 1),
            width=8.0,
            speed=2.0,
            max_speed=4.0,
            spread_deg=0,
            max_angle_deg=5,
            gamma_deg=45,
            steer=0.5,
        )
    ]
    soft, _, _ = erode(h0, d, 1.0, em, seed=4)
    ctrl, _, _ = erode(h0, np.full((n, n), 0.9), 1.0, em, seed=4)

    def downstream(h):
        w = (h0 - h)[:, 40:]
        return float((w.sum(axis=1) * np.arange(n)).sum() / w.sum()), float(w[:56].sum() / w.sum())

    row_c, north_c = downstream(ctrl)
    row_s, north_s = downstream(soft)
    # control: the stream runs straight along row 64 (±5° jitter that does not accumulate)
    assert abs(row_c - 64) < 3 and north_c < 0.01
    # with the band: the cut moved into the soft rock (seeds 0–3: centroids 37–40, shares 0.6–0.7)
    assert row_s < 50 and north_s > 0.4


def test_fast_particles_keep_course_slow_ones_wander():
    def spread(speed):
        em = [
            Emitter(
                particles=50,
                steps=40,
                x=0.0,
                y=0.5,
                width=1e-9,
                spread_deg=0,
                speed=speed,
                max_speed=2.0,
                max_angle_deg=60,
                speed_jitter=0,
                mass_jitter=0,
                radius_per_mass=1.5,
            )
        ]
        h, _, _ = erode(flat(128), np.zeros((128, 128)), 1.0, em, seed=2)
        rows = np.nonzero((flat(128) - h).sum(axis=1))[0]
        return rows.max() - rows.min()

    # at v = v_max the admissible deviation α_max (1 − v/v_max) is zero: the track stays on its row
    # (width of the disc, 2λ = 3 cells); at v = v_max/4 each step may deviate up to 45°, a lateral
    # random walk of ~0.2 cells per step: over 40 steps and 50 particles it spans 7–10 rows
    # (seeds 0–4)
    assert spread(2.0) <= 3
    assert spread(0.5) > 5


def test_rotational_motion_strikes_around_the_pivot():
    em = single(steps=4, speed=1e-6, pivot_offset=6.0, rotation_speed_deg=90.0, radius_per_mass=1.2)
    h, _, _ = erode(flat(), np.zeros((N, N)), 1.0, [em], seed=0)
    c = 0.5 * (N - 1)
    hits = {
        (round(c + 6 * math.cos(math.radians(a))), round(c - 6 * math.sin(math.radians(a)))) for a in (0, 90, 180, 270)
    }
    for i, j in hits:
        assert h[j, i] < 10.0
    assert h[round(c), round(c)] == 10.0  # the pivot itself is not struck (λ = 1.2 < ρ = 6)


def test_strata_hardness_follows_the_cut():
    n = 64
    jj, ii = np.indices((n, n))
    h0 = 30.0 + 0.05 * ii
    spec = Strata(thickness=(1.0, 0.5, 2.0), hardness=(0.2, 0.9, 0.5), base=0.3, tilt_x=0.02)
    d0 = strata(h0, 1.0, spec)
    em = [Emitter(particles=400, steps=30, x=0.0, y=0.5, width=10.0, depth_per_mass=0.1)]
    h, d, _ = erode(h0, d0, 1.0, em, seed=1, strata=spec)
    assert (h < h0 - 0.5).any()  # cut through at least one band
    assert not np.array_equal(d, d0)
    np.testing.assert_array_equal(d, strata(h, 1.0, spec))


def test_bad_inputs_give_clear_errors():
    h0 = flat(32)
    with pytest.raises(InputError, match=r"\[0, 1\]"):
        ParticleStream(h0, np.full((32, 32), 1.5), 1.0, [Emitter()], seed=0)
    with pytest.raises(InputError, match="shape"):
        ParticleStream(h0, np.zeros((32, 31)), 1.0, [Emitter()], seed=0)
    with pytest.raises(InputError, match="NaN"):
        ParticleStream(h0, np.full((32, 32), np.nan), 1.0, [Emitter()], seed=0)
    with pytest.raises(ConfigError, match="empty emission window"):
        ParticleStream(h0, np.zeros((32, 32)), 1.0, [Emitter(width=0, length=5.0)], seed=0)
    with pytest.raises(ConfigError, match="off the map"):
        ParticleStream(h0, np.zeros((32, 32)), 1.0, [Emitter(x=3.0, y=0.5)], seed=0)
    with pytest.raises(ConfigError, match="No emitter"):
        ParticleStream(h0, np.zeros((32, 32)), 1.0, [], seed=0)
    with pytest.raises(ConfigError, match="width"):
        from erosim.core.config import validate_section

        validate_section(Emitter, {"width": -1.0}, "emitters.main")


@pytest.mark.parametrize("direction, drow, dcol", [(0, 0, 1), (90, -1, 0), (180, 0, -1), (-90, 1, 0)])
def test_direction_is_compass_style_and_the_window_bounds_the_entry(direction, drow, dcol):
    n = 96
    c = 0.5 * (n - 1)
    # first impacts only: they lie in the window, a segment of width 10 across the heading
    em = single(particles=200, width=10.0, direction_deg=direction, radius_per_mass=1.0)
    h, _, _ = erode(flat(n), np.zeros((n, n)), 1.0, [em], seed=3)
    rows, cols = np.nonzero(h < 10.0)
    along = (rows - c) * drow + (cols - c) * dcol
    across = (rows - c) * dcol - (cols - c) * drow
    assert np.abs(along).max() < 1.0  # within λ = 1 of the window's line
    assert np.abs(across).max() < 5.0 + 1.0 and np.abs(across).max() > 4.0  # ±w/2 (+λ)
    # travelling: the cut extends along the heading (east = +column, north = −row)
    em = single(particles=20, steps=30, speed=1.0, max_speed=1.0, direction_deg=direction)
    h, _, _ = erode(flat(n), np.zeros((n, n)), 1.0, [em], seed=3)
    rows, cols = np.nonzero(h < 10.0)
    assert ((rows - c) * drow + (cols - c) * dcol).max() > 25
