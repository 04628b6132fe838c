"""Fluid ↔ grid coupling: binning against NumPy, Q4 sampling, the eroder contract and the coupler."""

import json
from types import SimpleNamespace

import numpy as np
import pytest

from erosim.core.errors import BudgetError, ConfigError, Interrupted
from erosim.core.increments import Increment, check_budget
from erosim.core.schedules import IterationInterval
from erosim.coupling.binning import FluidGrid
from erosim.coupling.coupler import Coupler
from erosim.coupling.raster import Raster
from erosim.coupling.sampling import sample
from erosim.coupling.terrains import HeightfieldTerrain
from erosim.io.runfolder import RunFolder
from erosim.simulation.callbacks import BudgetCheck
from erosim.simulation.simulation import Simulation
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver


def _fake_solver(pos, vel, rho, m):
    st = SimpleNamespace(pos=pos, vel=vel, rho=rho, n_fluid=len(pos))
    return SimpleNamespace(state=st, m=m, dim=pos.shape[1])


def _numpy_bin(r: Raster, pos, vel, rho, m):
    """The definition of the binned fields, written plainly."""
    d = pos.shape[1]
    ix = np.floor((pos[:, 0] - r.x0) * (1.0 / r.dx) + 0.5).astype(int)
    iy = np.floor((pos[:, 1] - r.y0) * (1.0 / r.dy) + 0.5).astype(int) if d == 3 else np.zeros(len(pos), int)
    ok = (ix >= 0) & (ix < r.nx) & (iy >= 0) & (iy < r.ny)
    count = np.zeros(r.shape, int)
    vol = np.zeros(r.shape)
    vsum = np.zeros(r.shape + (d,))
    np.add.at(count, (iy[ok], ix[ok]), 1)
    np.add.at(vol, (iy[ok], ix[ok]), m / rho[ok])
    for a in range(d):
        np.add.at(vsum[..., a], (iy[ok], ix[ok]), vel[ok, a])
    mean = np.where(count[..., None] > 0, vsum / np.maximum(count, 1)[..., None], 0.0)
    return count, vol / r.cell_area, mean, np.sqrt((mean**2).sum(-1)), int((~ok).sum())


@pytest.mark.parametrize("dim", [2, 3])
def test_binning_matches_numpy_with_edges_outside_and_maxima(dim):
    rng = np.random.default_rng(4)
    r = Raster(x0=1.0, y0=-2.0, dx=0.5, dy=0.25, nx=9, ny=7 if dim == 3 else 1)
    n = 4000
    pos = np.empty((n, dim))
    pos[:, 0] = rng.uniform(r.x0 - 1.0, r.x0 + r.nx * r.dx + 0.5, n)  # some fall outside on both sides
    if dim == 3:
        pos[:, 1] = rng.uniform(r.y0 - 0.5, r.y0 + r.ny * r.dy + 0.3, n)
    pos[:, -1] = rng.uniform(0, 1, n)
    # particles exactly on cell edges (half-open cells: they belong to the node above) and the outer edges
    pos[:20, 0] = r.x0 + (np.arange(20) % r.nx + 0.5) * r.dx
    pos[20, 0] = r.x0 - 0.5 * r.dx  # lower outer edge: inside (node 0)
    pos[21, 0] = r.x0 + (r.nx - 0.5) * r.dx  # upper outer edge: outside
    vel = rng.normal(size=(n, dim))
    rho = rng.uniform(990, 1010, n)
    grid = FluidGrid(r, dim)
    solver = _fake_solver(pos, vel, rho, m=0.3)
    grid.bin(solver)
    count, depth, mean, speed, outside = _numpy_bin(r, pos, vel, rho, 0.3)
    assert np.array_equal(grid.count, count) and grid.outside == outside > 0
    np.testing.assert_allclose(grid.depth, depth, rtol=1e-13)
    np.testing.assert_allclose(grid.velocity, mean, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(grid.speed, speed, rtol=1e-12, atol=1e-15)
    assert grid.count.sum() + grid.outside == n
    # running maxima: a second binning with the water halved keeps the first one's maxima
    first_depth, first_speed = grid.depth.copy(), grid.speed.copy()
    solver.state.rho = rho * 2.0
    solver.state.vel = vel * 0.5
    grid.bin(solver)
    np.testing.assert_allclose(grid.depth, first_depth / 2, rtol=1e-12)
    assert np.array_equal(grid.max_depth, first_depth) and np.array_equal(grid.max_speed, first_speed)


def test_q4_sampling_is_exact_for_bilinear_fields_and_clamps():
    r = Raster(x0=10.0, y0=5.0, dx=2.0, dy=3.0, nx=6, ny=5)
    xs, ys = r.nodes()
    X, Y = np.meshgrid(xs, ys)
    f = 1.5 + 0.2 * X - 0.7 * Y + 0.05 * X * Y  # in the span of the Q4 shape functions

    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(xs[0], xs[-1], 300), rng.uniform(ys[0], ys[-1], 300), np.zeros(300)])
    got = sample(r, f, pts)
    want = 1.5 + 0.2 * pts[:, 0] - 0.7 * pts[:, 1] + 0.05 * pts[:, 0] * pts[:, 1]
    np.testing.assert_allclose(got, want, rtol=1e-12)
    outside = np.array([[xs[0] - 5.0, ys[-1] + 9.0, 0.0]])
    assert sample(r, f, outside)[0] == pytest.approx(f[-1, 0])  # clamped to the corner node


def test_budget_check_accepts_a_closed_increment_and_names_a_broken_one():
    dz = np.zeros((3, 4))
    dz[1, 1] = -0.2
    dz[2, 3] = 0.05
    terms = check_budget(Increment(dz, suspended=0.15 * 2.0, carried_off=0.0), dz.shape, 2.0, "model X")
    assert terms["eroded"] == pytest.approx(0.4) and terms["deposited"] == pytest.approx(0.1)
    with pytest.raises(BudgetError, match="model X breaks the sediment budget"):
        check_budget(Increment(dz), dz.shape, 2.0, "model X")
    with pytest.raises(BudgetError, match="shape"):
        check_budget(Increment(dz[:2]), dz.shape, 2.0, "model X")
    with pytest.raises(BudgetError, match="NaN"):
        check_budget(Increment(dz * np.nan), dz.shape, 2.0, "model X")


class DepthEroder:
    """A toy eroder: lowers wet nodes by k·depth·dt into suspension (it declares what it moves)."""

    name = "toy"
    needs = ("depth",)

    def __init__(self, k=0.05, honest=True):
        self.k, self.honest, self.held = k, honest, 0.0

    def increments(self, terrain, grid, dt):
        dz = -self.k * grid.depth * dt
        moved = float(-dz.sum() * grid.raster.cell_area)
        self.held += moved
        return Increment(dz, suspended=moved if self.honest else 0.0)

    def state_dict(self):
        return {"held": np.array(self.held)}

    def load_state_dict(self, state):
        self.held = float(state["held"])


def _flume(tmp_path, name, eroder, resume=False, stop=0.03, interrupt_at=None):
    dx = 0.01
    xs = (np.arange(12) + 0.5) * dx
    fluid = np.stack(np.meshgrid(xs, (np.arange(12) + 0.5) * dx, indexing="ij"), -1).reshape(-1, 2)
    solver = SPHSolver(SPHParams(dim=2, spacing=dx), fluid, domain_lo=[0, 0], domain_hi=[0.5, 0.3])
    if interrupt_at is not None:
        real = solver.step

        def step():
            if solver.steps == interrupt_at:
                raise KeyboardInterrupt
            return real()

        solver.step = step
    raster = Raster(x0=0.5 * dx, y0=0.0, dx=dx, dy=1.0, nx=50)
    coupler = Coupler(IterationInterval(10), solver, eroder, HeightfieldTerrain(raster, np.zeros(raster.shape), 2))
    sim = Simulation([solver], out=RunFolder(tmp_path / name, resume=resume), stop_time=stop, callbacks=[coupler],
                     kind="test", progress=False)  # fmt: skip
    return sim, coupler


def test_coupler_applies_increments_once_every_n_steps_and_budget_closes(tmp_path):
    sim, coupler = _flume(tmp_path, "a", DepthEroder())
    seen = []
    real = coupler.eroder.increments

    def spy(terrain, grid, dt):
        inc = real(terrain, grid, dt)
        seen.append((sim.iteration, terrain.copy(), inc.dz.copy()))
        return inc

    coupler.eroder.increments = spy
    sim.run()
    assert [it for it, _, _ in seen] == list(range(0, sim.iteration + 1, 10)) and len(seen) > 5
    # each call saw the terrain with every earlier increment applied exactly once
    for (_, before, dz), (_, after, _) in zip(seen, seen[1:], strict=False):
        assert np.array_equal(after, before + dz)
    z = coupler.terrain.z
    assert np.array_equal(z, seen[-1][1] + seen[-1][2]) and z.min() < 0
    b = coupler.budget()
    assert b["eroded"] > 0 and b["closure_rel"] < 1e-12
    assert b["terrain_change"] == pytest.approx(-b["suspended"], rel=1e-12)
    assert b["suspended"] == pytest.approx(coupler.eroder.held, rel=1e-12)
    rep = json.loads((tmp_path / "a" / "report.json").read_text())
    assert rep["sediment_budget"]["couplings"] == len(seen)


def test_coupler_refuses_a_broken_budget_missing_fields_and_bedrock(tmp_path):
    sim, _ = _flume(tmp_path, "b", DepthEroder(honest=False))
    with pytest.raises(BudgetError, match="Erosion model 'toy' breaks the sediment budget"):
        sim.run()
    assert json.loads((tmp_path / "b" / "report.json").read_text())["status"] == "failed"

    class NeedsHardness(DepthEroder):
        needs = ("depth", "hardness")

    solver = SPHSolver(SPHParams(dim=2, spacing=0.01), [[0.05, 0.05]], domain_lo=[0, 0], domain_hi=[0.2, 0.2])
    r = Raster(0.0, 0.0, 0.01, 1.0, 20)
    with pytest.raises(ConfigError, match="needs hardness"):
        Coupler(IterationInterval(1), solver, NeedsHardness(), HeightfieldTerrain(r, np.zeros(r.shape), 2))
    rock = HeightfieldTerrain(r, np.zeros(r.shape), 2, bedrock=np.zeros(r.shape))
    c = Coupler(IterationInterval(1), solver, DepthEroder(k=1e9), rock)
    with pytest.raises(BudgetError, match="bedrock"):
        solver.step()
        c()


def test_coupled_run_resumes_bit_identical(tmp_path):
    whole, cw = _flume(tmp_path, "whole", DepthEroder())
    whole.run()
    cut, _ = _flume(tmp_path, "cut", DepthEroder(), interrupt_at=37)
    with pytest.raises(Interrupted):
        cut.run()
    again, ca = _flume(tmp_path, "cut", DepthEroder(), resume=True)
    again.restore()
    again.run()
    assert np.array_equal(ca.terrain.z, cw.terrain.z) and ca.eroder.held == cw.eroder.held
    assert np.array_equal(again.models[0].fluid_positions(), whole.models[0].fluid_positions())
    assert np.array_equal(ca.terrain.grid.max_depth, cw.terrain.grid.max_depth)


class LoadingEroder(DepthEroder):
    """The toy, with what it lowers carried by the particles: the new loads travel in the increment."""

    def increments(self, terrain, grid, dt):
        inc = super().increments(terrain, grid, dt)
        st = self.solver.state
        loads = st.sediment[: st.n_fluid] + inc.suspended / st.n_fluid  # an equal share each
        return Increment(inc.dz, suspended=inc.suspended, particles={"sediment": loads})


def test_coupler_writes_the_particle_loads_an_increment_carries(tmp_path):
    """Known answer: the particles hold exactly what the terrain lost (Σ s_j = −Σ Δz A), and a refused
    increment writes neither the terrain nor the particles."""
    eroder = LoadingEroder()
    sim, coupler = _flume(tmp_path, "loads", eroder)
    eroder.solver = coupler.solver
    coupler.solver.state.register("sediment")
    sim.run()
    st = coupler.solver.state
    lost = -float(coupler.terrain.z.sum() * coupler.terrain.raster.cell_area)
    assert lost > 0 and float(st.sediment[: st.n_fluid].sum()) == pytest.approx(lost, rel=1e-12)

    class Broken(LoadingEroder):
        def increments(self, terrain, grid, dt):
            inc = super().increments(terrain, grid, dt)
            return Increment(inc.dz, suspended=0.0, particles=inc.particles)

    bad = Broken()
    sim, coupler = _flume(tmp_path, "broken", bad)
    bad.solver = coupler.solver
    coupler.solver.state.register("sediment")
    with pytest.raises(BudgetError):
        sim.run()
    assert not coupler.solver.state.sediment.any() and not coupler.terrain.z.any()


def test_budget_check_stops_a_model_whose_bookkeeping_is_wrong(tmp_path):
    z = np.zeros((4, 4))
    said = {"carried": 0.0}

    def moved():
        return 0.0, said["carried"]

    check = BudgetCheck(IterationInterval(1), z, moved, 1.0, "The test model")
    z[0, 0] -= 0.5
    said["carried"] += 0.5
    check(None)
    assert check.checks == 1 and check.worst < 1e-15
    z[1, 1] -= 0.5  # eroded, but never said where it went
    with pytest.raises(BudgetError, match="The test model breaks the sediment budget"):
        check(None)
