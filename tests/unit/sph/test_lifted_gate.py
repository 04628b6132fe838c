"""The lifted dam-break gate (sph/boundaries/lifted_gate.py): where the plate is, what it holds back,
list rebuilds while it moves, exact resume, and the scenario's refusals."""

import numpy as np
import pytest

from erosim.core.errors import ConfigError
from erosim.scenarios import loader
from erosim.sph.boundaries.lifted_gate import LiftedGate, gate_particles
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver

DX = 0.01
LO, HI = [0.0, 0.0], [0.4, 0.25]
COLUMN = 0.1  # 10 × 20 particles of water at 0 ≤ x ≤ 0.1, 0 ≤ y ≤ 0.2


def _column():
    ax = (np.arange(10) + 0.5) * DX
    ay = (np.arange(20) + 0.5) * DX
    g = np.meshgrid(ax, ay, indexing="ij")
    return np.stack([a.ravel() for a in g], axis=1)


def _solver(speed):
    prm = SPHParams(dim=2, spacing=DX, reorder_every=2)
    gates = [LiftedGate(COLUMN, 1, LO, HI, DX, prm.layers(), speed)] if speed > 0 else []
    return SPHSolver(prm, _column(), domain_lo=LO, domain_hi=HI, boundaries=gates)


def _front(s):
    return float(s.fluid_positions()[:, 0].max())


def test_plate_lattice_spans_the_tank_height_behind_the_face():
    pts = gate_particles(0.1, 1, LO, HI, DX, 3)
    assert pts.shape == (3 * 25, 2)
    np.testing.assert_allclose(np.unique(pts[:, 0]), [0.105, 0.115, 0.125])
    assert pts[:, 1].min() == pytest.approx(0.005) and pts[:, 1].max() == pytest.approx(0.245)
    left = gate_particles(0.3, -1, LO, HI, DX, 2)  # water at larger x: the plate lies at smaller x
    np.testing.assert_allclose(np.unique(left[:, 0]), [0.285, 0.295])


def test_plate_rises_at_its_speed_and_the_water_leaves_under_its_edge():
    """The plate's rows sit at z₀ + U t (to rounding); every particle past the gate's face came
    under the plate's lower edge: none is higher than the edge plus one kernel support."""
    u = 0.5
    s = _solver(u)
    gate = s.boundaries[-1]
    base = gate.base
    while s.t < 0.1:
        s.step()
        past = s.fluid_positions()
        past = past[past[:, 0] > COLUMN + 0.5 * DX]
        if past.size:
            assert past[:, 1].max() <= u * s.t + s.h, (s.t, past[:, 1].max())
    rows = s.state.pos[s.n_fluid + gate.offset : s.n_fluid + gate.offset + base.shape[0]]
    np.testing.assert_allclose(rows[:, 0], base[:, 0])
    np.testing.assert_allclose(rows[:, 1], base[:, 1] + u * s.t, rtol=0, atol=1e-12)
    assert _front(s) > COLUMN + DX  # water did get out


def test_gate_delays_the_front_and_a_faster_gate_less():
    """At the same time the instantly released column is furthest, then the fast gate, then the slow."""
    fronts = []
    for u in (0.0, 2.0, 0.5):
        s = _solver(u)
        while s.t < 0.08:
            s.step()
        fronts.append(_front(s))
    assert fronts[0] > fronts[1] > fronts[2], fronts


def test_lists_are_rebuilt_while_the_plate_moves():
    """Every pair closer than the support, the moving plate's included, is in the lists (brute force)."""
    from scipy.spatial import cKDTree

    s = _solver(1.0)
    for k in range(300):
        s.step()
        if k % 50:
            continue
        x = s.state.pos.astype(np.float64)
        for i, j in cKDTree(x).query_pairs(s.h * (1 - 1e-9)):
            for a, b in ((i, j), (j, i)):
                if a < s.n_fluid:
                    assert b in s.nbr[s.start[a] : s.start[a + 1]], (k, a, b)


def test_resume_with_a_moving_gate_is_bit_identical():
    a = _solver(1.0)
    for _ in range(120):
        a.step()
    state = {k: np.array(v, copy=True) for k, v in a.state_dict().items()}
    for _ in range(80):
        a.step()
    b = _solver(1.0)
    b.load_state_dict(state)
    for _ in range(80):
        b.step()
    np.testing.assert_array_equal(a.fluid_positions(), b.fluid_positions())
    np.testing.assert_array_equal(a.fluid_velocities(), b.fluid_velocities())
    np.testing.assert_array_equal(a.state.pos, b.state.pos)
    assert a.t == b.t and a.rebuilds == b.rebuilds


def test_scenario_lays_the_gate_at_the_columns_face():
    cfg = loader.load("dam-break-2d", ["gate.speed=0.75"]).config
    assert cfg.gate_face() == pytest.approx(0.05715) and cfg.gate_side() == 1
    assert loader.load("dam-break-2d").config.gate.speed == 0.0  # off unless asked for


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        (["gate.speed=1", "gate.x=0.03"], "cuts through a fluid block"),
        (["gate.speed=1", "gate.x=0.9"], "outside the domain"),
        (["gate.speed=1", "sph.walls=reflect"], "boundary particles"),
    ],
)
def test_bad_gate_is_refused_with_the_fix(overrides, match):
    with pytest.raises(ConfigError, match=match):
        loader.load("dam-break-2d", overrides)


def test_gate_with_summation_density_is_refused():
    prm = SPHParams(dim=2, spacing=DX, density="summation")
    with pytest.raises(ConfigError, match="continuity"):
        SPHSolver(prm, _column(), domain_lo=LO, domain_hi=HI, boundaries=[LiftedGate(COLUMN, 1, LO, HI, DX, 2, 1.0)])
