"""The pressure a wall sensor reads: the load the fluid puts on the wall's particles (erosim.sph.wall_load)."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from erosim.analysis.gauges import gauge_readings
from erosim.scenarios import loader
from erosim.scenarios.sph.build import build, lattice, probe_wall
from erosim.sph.wall_load import patch, wall_pressure, wall_pressures, wetted


def test_patch_takes_the_walls_own_particles_behind_the_face():
    """Two layers of a floor (z < 0) and a box standing on it: the patch around a point on the box's
    +x face holds only box particles within the depth behind that face and the half-width along it."""
    floor = lattice([0.0, 0.0, -0.2], [1.0, 1.0, 0.0], 0.1)
    box = lattice([0.4, 0.4, 0.0], [0.6, 0.6, 0.2], 0.1)
    wall = np.vstack([floor, box])
    got = patch(
        wall, [0.6, 0.5, 0.1], [1.0, 0.0, 0.0], half_width=0.1, depth=0.1, solid=([0.4, 0.4, 0.0], [0.6, 0.6, 0.2])
    )
    assert len(got) == 4 and np.all(got >= len(floor))  # x = 0.55, y = 0.45/0.55, z = 0.05/0.15
    np.testing.assert_allclose(wall[got][:, 0], 0.55)


@pytest.mark.parametrize("wall_model", ["dynamic", "extrapolated"])
def test_walls_of_a_tank_at_rest_feel_rho_g_depth(wall_model):
    """The hydrostatic tank (H/16) after 0.6 s: the side walls and the floor feel ρ₀g·depth within 1 %
    (measured 0.2–0.6 % at H/16 and 0.3–0.5 % at H/40 with the dynamic walls, 0.1–0.4 % at H/16 with the
    pressure extrapolated from the fluid), from the pair forces alone."""
    dx = 0.2 / 16
    cfg = loader.load("hydrostatic", [f"sph.spacing={dx!r}", f"sph.wall_pressure={wall_model}"]).config
    s = build(cfg).solver
    while s.t < 0.6:
        s.step()
    points = [[0.0, 0.05], [0.0, 0.1], [0.0, 0.15], [0.2, 0.1], [0.1, 0.0], [0.05, 0.0]]
    got = [wall_pressure(s, q, probe_wall(cfg, q)[0], s.h, probe_wall(cfg, q)[1]) for q in points]
    exact = 1000 * 9.81 * (0.2 - np.array(points)[:, 1])
    np.testing.assert_allclose(got, exact, rtol=0.01)


def test_probes_on_faces_get_their_walls():
    cfg = loader.load("spheric2").config
    walls = {q.name: probe_wall(cfg, q.position) for q in cfg.probes}
    for name in ("P1", "P2", "P3", "P4"):
        np.testing.assert_array_equal(walls[name][0], [1.0, 0.0, 0.0])  # the face towards the reservoir
    for name in ("P5", "P6", "P7", "P8"):
        np.testing.assert_array_equal(walls[name][0], [0.0, 0.0, 1.0])  # the top
    assert probe_wall(cfg, [1.5, 0.5, 0.2]) is None  # in the fluid
    tank = loader.load("dam-break").config
    floor = probe_wall(tank, [10.0, 3.5, 0.0])
    np.testing.assert_array_equal(floor[0], [0.0, 0.0, 1.0])
    assert probe_wall(loader.load("dam-break", ["sph.walls=reflect"]).config, [10.0, 3.5, 0.0]) is None


def test_face_area_uses_the_walls_own_step():
    """Walls are laid at extent/round(extent/Δx): a 3 × 3 patch of a face whose particles are 0.031 m
    apart in y and 0.0322 m in z covers 9 · 0.031 · 0.0322 m², not 9 Δx² (Δx = 0.03)."""
    from erosim.sph.wall_load import _face_area

    y, z = np.meshgrid(0.5 + 0.031 * np.arange(3), 0.0161 + 0.0322 * np.arange(3), indexing="ij")
    layers = [np.stack([np.full(y.size, x), y.ravel(), z.ravel()], axis=1) for x in (0.8, 0.77)]
    wall = np.vstack(layers)  # two layers behind the face: the same columns
    assert _face_area(wall, np.array([1.0, 0.0, 0.0]), 0.03) == pytest.approx(9 * 0.031 * 0.0322)


def test_a_sensor_at_the_foot_of_a_wall_feels_the_corner():
    """Sensors 3 and 15 mm above the floor on the tank's side walls (H/16, after 0.6 s at rest). Their patch
    reaches the floor: its area is the wetted face's alone, and the load includes the particles behind the face
    under the floor (the corner), which the fluid at the face's foot pushes on. The face's mean load, ρ₀g(H − z̄)
    with z̄ the wetted face's mean height, is carried hydrostatically to the sensor: each reads ρ₀g(H − z) at its
    own height within 1 % as the tank's other walls (measured 0.2 % here); before, counting the corner's area and
    not its load, the 3 mm sensor read 0.50 of ρ₀g(H − z̄) (0.66 at H/40), the 15 mm one 0.67, and without
    the carry the 3 mm one read 0.92 of ρ₀g(H − z)."""
    from erosim.sph.wall_load import at_the_face_end

    dx = 0.2 / 16
    cfg = loader.load("hydrostatic", [f"sph.spacing={dx!r}"]).config
    s = build(cfg).solver
    while s.t < 0.6:
        s.step()
    bpos = np.asarray(s.state.pos[s.state.n_fluid :], dtype=np.float64)
    for q in ([0.0, 0.003], [0.2, 0.003], [0.0, 0.015]):
        normal, solid = probe_wall(cfg, q)
        idx = patch(bpos, q, normal, s.h, s.h, solid)
        face, corner = at_the_face_end(bpos, idx, q, normal, s.h, s.h, s.lo, s.hi, dx)
        assert bpos[face, 1].min() > 0 and len(corner) and np.all(bpos[corner, 1] < 0)
        exact = 1000 * 9.81 * (0.2 - q[1])
        assert wall_pressure(s, q, normal, s.h, solid) == pytest.approx(exact, rel=0.01), q


def test_the_face_in_the_gap_under_a_held_off_fluid_is_dry():
    """Dynamic walls hold the fluid off by a gap that grows under impacts (docs/sph.md, "At the foot of a
    wall"). A wall at x = 0 (three layers behind it) and a fluid lattice in front of it whose lowest layer
    sits 12 mm above the floor (Δx = 7.5 mm, h = 22.5 mm): the wall particles level with the fluid's layers,
    or under ¾Δx from one, are wet; the column at 3.75 mm (8.25 mm below the fluid) is dry in every layer."""
    dx, h = 0.0075, 0.0225
    zb = 0.5 * dx + dx * np.arange(6)  # 3.75 … 41.25 mm
    wall = np.array([[0.5 * dx + k * dx, z] for k in range(3) for z in zb])
    fluid = np.array([[-(0.5 * dx + 2 * k * dx), 0.012 + j * dx] for k in range(3) for j in range(6)])
    wet = wetted(wall, [0.0, 0.003], cKDTree(fluid), np.array([-1.0, 0.0]), h, dx)
    assert not wet[np.isclose(wall[:, 1], 0.5 * dx)].any()  # 12 − 3.75 = 8.25 mm > ¾Δx = 5.6 mm
    assert wet[wall[:, 1] > dx].all()
    assert not wetted(wall, [0.0, 0.003], cKDTree(fluid + [0.0, 1.0]), np.array([-1.0, 0.0]), h, dx).any()


@pytest.mark.slow  # a 2-D dam break at H/20 for 20 √(H/g): about a minute
def test_sensors_near_the_floor_read_the_depth_at_the_wall_once_the_water_sloshes_as_a_long_wave():
    """Lobovsky et al.'s (2014) layout (H = 0.3 m, column 0.6 m, tank 1.61 m) at H/20, sensors on the far wall
    3, 15 and 30 mm up: over t√(g/H) = 10–20 the water sloshes as a long wave (3.2 m long over ~0.1 m), so the
    wall's pressure is hydrostatic on the depth at the wall, ρ₀g(h_w − z), h_w read one support from the wall
    (benchmarks/wall_sensors_near_floor.py). Each sensor's mean error is within 0.05 ρ₀gH, about twice the
    fluid probe's own offset from that depth here (0.023); measured +0.031, +0.019, +0.016, where the load
    spread over the dry face in the gap under the fluid read −0.153, −0.117, −0.077."""
    H, tank, sensors = 0.3, 1.61, (0.003, 0.015, 0.03)
    cfg = loader.load("dam-break-2d", [f"sph.spacing={H / 20!r}", f"domain.hi=[{tank}, {2 * H}]",
                                       f"fluid=[{{lo=[0.0, 0.0], hi=[0.6, {H}]}}]", "measure.front=false",
                                       'measure.compare="none"', "gauges=[]", "probes=[]"]).config  # fmt: skip
    s = build(cfg).solver
    g, scale = 9.81, 1000 * 9.81 * H
    walls = [([tank, z], *probe_wall(cfg, [tank, z])) for z in sensors]
    errors, t_next = [], 10.0 / np.sqrt(g / H)
    while s.t < 20.0 / np.sqrt(g / H):
        if s.t >= t_next:
            t_next += 0.005
            nf = s.state.n_fluid
            pos, rho = np.asarray(s.state.pos[:nf], dtype=np.float64), np.asarray(s.state.rho[:nf], dtype=np.float64)
            h_w = gauge_readings(pos, s.m / rho, np.array([[tank - s.h]]), s.h, s.params.spacing, 0.0)[0, 0]
            exact = 1000 * g * np.maximum(h_w - np.array(sensors), 0.0)
            errors.append((np.array(wall_pressures(s, walls, s.h)) - exact) / scale)
        s.step()
    mean = np.mean(errors, axis=0)
    assert np.all(np.abs(mean) <= 0.05), mean
