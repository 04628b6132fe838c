"""The overtopping flume's inflow: water laid at rest on the reservoir's surface, one particle at a time
(erosim.coupling.sources.FlumeInflow) — the discharge kept, no momentum added, no overlap, an even rise."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from erosim.core.errors import InstabilityError
from erosim.coupling.sources import FlumeInflow
from erosim.scenarios.voxel.schema import overflow_head

DX = 0.02


class Params:
    spacing = DX


class Reservoir:
    """A still reservoir: a lattice of particles (spacing Δx) 0.4 m × 0.12 m, 4 layers deep, jittered."""

    def __init__(self):
        g = np.meshgrid((np.arange(20) + 0.5) * DX, (np.arange(6) + 0.5) * DX, (np.arange(4) + 0.5) * DX,
                        indexing="ij")  # fmt: skip
        self.pos = np.stack([a.ravel() for a in g], axis=1)
        self.pos += np.random.default_rng(3).uniform(-0.05 * DX, 0.05 * DX, self.pos.shape)
        self.vel = np.zeros_like(self.pos)
        self.params = Params()
        self.t = 0.0

    def fluid_positions(self):
        return self.pos

    def add_fluid(self, pos, vel, *, source):
        assert source == "inflow"
        self.pos = np.concatenate([self.pos, pos])
        self.vel = np.concatenate([self.vel, vel])
        return len(pos)


def test_inflow_keeps_the_discharge_lays_particles_at_rest_apart_and_rises_evenly():
    res = Reservoir()
    n0 = len(res.pos)
    q = 1.5e-3  # m³/s: one particle every Δx³/Q = 5.3 ms
    inflow = FlumeInflow(res, 0.0, 0.4, 0.12, q, top=0.5)
    sites = len(inflow.sites)
    assert sites == 120 and len({tuple(s) for s in inflow.sites}) == sites  # every lattice site, once
    for k in range(1, 400):  # steps of 1 ms, 0.4 s
        res.t = k * 1e-3
        inflow(None)
        # the volume added is Q t, less the part of a particle not yet due
        assert (len(res.pos) - n0) * DX**3 == pytest.approx(q * res.t, abs=DX**3)
    new = res.pos[n0:]
    assert not res.vel[n0:].any()  # laid at rest: no momentum
    # no new particle closer than Δx to any other (1e-9 relative: the square root's rounding)
    d, _ = cKDTree(res.pos).query(new, k=2)
    assert d[:, 1].min() >= DX * (1 - 1e-9)
    # 74 particles (Q·0.399 s/Δx³ = 74.8) on 120 sites: each at a different site, each on the reservoir's
    # top layer (z ≈ 3.5 Δx + Δx, within the lattice's 5 % jitter): the level rises evenly, none stacked
    assert len(new) == 74 and len({(int(x // DX), int(y // DX)) for x, y in new[:, :2]}) == 74
    assert np.abs(new[:, 2] - 4.5 * DX).max() < 0.1 * DX


def test_inflow_state_resumes_and_the_overflowing_domain_is_refused():
    a, b = Reservoir(), Reservoir()
    ia, ib = FlumeInflow(a, 0.0, 0.4, 0.12, 1.5e-3, top=0.5), FlumeInflow(b, 0.0, 0.4, 0.12, 1.5e-3, top=0.5)
    for k in range(1, 50):
        a.t = k * 1e-3
        ia(None)
    b.pos, b.t = a.pos.copy(), a.t
    ib.load_state_dict(ia.state_dict())
    for k in range(50, 120):
        a.t = b.t = k * 1e-3
        ia(None)
        ib(None)
    assert np.array_equal(a.pos, b.pos)
    low = Reservoir()
    tight = FlumeInflow(low, 0.0, 0.4, 0.12, 1.5e-3, top=0.05)
    low.t = 0.01
    with pytest.raises(InstabilityError, match="top of the flume"):
        tight(None)


def test_overflow_head_is_three_halves_of_the_critical_depth():
    # q = 0.0125 m²/s: y_c = (q²/g)^(1/3) = 2.515 cm, H = 1.5 y_c
    assert overflow_head(1.5e-3, 0.12, g=9.81) == pytest.approx(1.5 * (0.0125**2 / 9.81) ** (1 / 3), rel=1e-12)
    assert overflow_head(1.5e-3, 0.12, g=9.81) == pytest.approx(0.0377, abs=1e-4)
