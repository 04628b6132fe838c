"""Particle state with sources and sinks: arrays stay consistent, reorders carry every field, the
mass budget closes, and a checkpoint with a changed particle count resumes exactly."""

import numpy as np
import pytest

from erosim.kernels.neighbours import find_neighbours
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver
from erosim.sph.state import ParticleState

DX = 0.01


def _solver(**kw):
    params = SPHParams(dim=2, spacing=DX, reorder_every=1, **kw)
    xs = (np.arange(10) + 0.5) * DX
    fluid = np.stack(np.meshgrid(xs, xs, indexing="ij"), axis=-1).reshape(-1, 2)
    return SPHSolver(params, fluid, domain_lo=[0.0, 0.0], domain_hi=[0.4, 0.3])


def _row(y, x0=0.02, k=6):
    return np.stack([x0 + DX * np.arange(k), np.full(k, y)], axis=1)


def _check_consistent(s: SPHSolver):
    st = s.state
    nf, n = st.n_fluid, st.n
    for name, (scope, _, _, _) in st.specs.items():
        assert getattr(st, name).shape[0] == (n if scope == "all" else nf), name
    assert len(np.unique(st.ids)) == nf
    # the registered field moved with its particle through every reorder, add and remove
    assert np.array_equal(st.tag, st.ids.astype(float))
    # neighbour lists hold every pair closer than h (against a fresh search)
    ref_start, ref_mid, ref_nbr = find_neighbours(st.pos.astype(np.float64), s.h, nf)
    for i in range(nf):
        got = set(s.nbr[s.start[i] : s.start[i + 1]].tolist())
        d2 = ((st.pos[list(got)] - st.pos[i]) ** 2).sum(axis=1) if got else np.zeros(0)
        within = {j for j, r2 in zip(got, d2, strict=True) if r2 < s.h * s.h}
        assert within == set(ref_nbr[ref_start[i] : ref_start[i + 1]].tolist()), i


def test_sources_and_sinks_keep_arrays_consistent_and_budget_closed():
    s = _solver()
    st = s.state
    st.register("tag")
    st.tag[:] = st.ids
    boundary0 = s.boundary_positions().copy()
    added = removed = 0
    for k in range(40):
        s.step()
        if k % 6 == 0:
            row = _row(0.15 + 0.002 * k)
            added += s.add_fluid(row, source="rain", tag=np.arange(st.next_id, st.next_id + len(row)))
        if k % 9 == 4:
            mask = st.pos[: st.n_fluid, 0] > 0.07  # a sink on the right
            removed += s.remove_fluid(mask, sink="outflow")
        _check_consistent(s)
    assert added > 0 and removed > 0
    assert np.array_equal(s.boundary_positions(), boundary0)  # the walls moved with the block, unchanged
    b = s.budget()
    m = s.m
    assert b["initial"] == 100 * m and b["added"]["rain"] == added * m and b["removed"]["outflow"] == removed * m
    assert b["in_fluid"] == (100 + added - removed) * m and b["closure_rel"] == 0.0
    # outputs come in label order: first the given particles, then the added ones by arrival
    order = np.argsort(st.ids)
    assert np.array_equal(s.fluid_positions(), st.pos[: st.n_fluid][order])


def test_checkpoint_with_more_particles_resumes_exactly():
    a = _solver()
    for k in range(10):
        a.step()
        if k == 3:
            a.add_fluid(_row(0.2), source="inflow")
    saved = {k: np.array(v, copy=True) for k, v in a.state_dict().items()}
    b = _solver()
    b.load_state_dict(saved)
    assert b.n_fluid == a.n_fluid == 106
    for _ in range(15):
        a.step()
        b.step()
    assert np.array_equal(a.fluid_positions(), b.fluid_positions())
    assert b.budget()["added"] == {"inflow": 6 * a.m}


def test_a_fluid_can_drain_away_and_fill_again():
    s = _solver()
    s.remove_fluid(np.ones(s.n_fluid, bool), sink="drain")
    assert s.n_fluid == 0 and s.fluid_positions().shape == (0, 2)
    s.step()  # an empty fluid steps (sources may add to it later)
    s.add_fluid(_row(0.1), source="rain")
    for _ in range(5):
        s.step()
    assert s.n_fluid == 6 and s.budget()["closure_rel"] == 0.0


def test_state_grows_and_keeps_the_boundary_block():
    st = ParticleState(2, np.float64, 3, 2)
    st.pos[:] = np.arange(10.0).reshape(5, 2)
    st.add_fluid(np.full((40, 2), -1.0), None, rho=1000.0, source="s")
    assert st.capacity >= 45 and st.n_fluid == 43
    assert np.array_equal(st.pos[43:], [[6.0, 7.0], [8.0, 9.0]])  # boundary rows moved up intact
    st.remove_fluid(np.arange(43) >= 3, sink="k")
    assert np.array_equal(st.pos, np.arange(10.0).reshape(5, 2))
    with pytest.raises(Exception, match="exists already"):
        st.register("pos")
