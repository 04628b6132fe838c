"""Parts of the SPH-on-terrain kind: rain by a rain map, the lake fill, the transport-capacity law,
the ground constraint on steep and nodata-bordered terrain, memory that grows with the fluid only."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from erosim.core.errors import ConfigError
from erosim.coupling.binning import FluidGrid
from erosim.coupling.raster import Raster
from erosim.coupling.sources import Rain, lake_particles
from erosim.erosion.transport_capacity_mei2007 import TransportCapacity, TransportCapacityParams
from erosim.sph.params import SPHParams


class _Recorder:
    """Stands in for the solver: records the particles a source adds."""

    def __init__(self, dim=3, spacing=1.0):
        self.dim, self.t = dim, 0.0
        self.params = SimpleNamespace(spacing=spacing)
        self.added = []

    def add_fluid(self, pos, vel, *, source):
        self.added.append(np.array(pos))
        return len(pos)


def test_rain_falls_with_the_maps_probabilities():
    """χ² of the drops per cell against N·p_k/Σp (p-value above 10⁻³), none where the map is 0, and
    the number of drops the rate asks for (the fraction carried to the next shower)."""
    r = Raster(0.0, 0.0, 2.0, 2.0, 8, 6)
    rng = np.random.default_rng(7)
    chance = rng.random(r.shape)
    chance[0, :3] = 0.0
    solver = _Recorder()
    rain = Rain(None, solver, r, np.zeros(r.shape), chance, rate_mm_h=3.6e6, height=1.0, seed=3)
    # 1 m/s of rain over Σp·A m²: the drops due in 10 s, with 1 m³ particles
    solver.t = 10.0
    rain()
    drops = np.concatenate(solver.added)
    expected = 10.0 * chance.sum() * r.cell_area
    assert len(drops) == int(expected) and rain.carry == pytest.approx(expected - int(expected))
    ix = np.clip(np.floor(drops[:, 0] / r.dx + 0.5).astype(int), 0, r.nx - 1)
    iy = np.clip(np.floor(drops[:, 1] / r.dy + 0.5).astype(int), 0, r.ny - 1)
    counts = np.zeros(r.shape)
    np.add.at(counts, (iy, ix), 1)
    assert counts[0, :3].sum() == 0
    # a drop lands in its node's cell (clipped onto the map at its edges), so each node gets ∝ p_k
    ok = chance > 0
    exp = len(drops) * chance[ok] / chance[ok].sum()
    chi2 = (((counts[ok] - exp) ** 2) / exp).sum()
    assert stats.chi2.sf(chi2, ok.sum() - 1) > 1e-3
    assert np.all(drops[:, 2] == 1.0)  # `height` above the ground (0 here)


def test_rain_map_of_another_size_is_refused():
    r = Raster(0.0, 0.0, 1.0, 1.0, 5, 4)
    with pytest.raises(ConfigError, match="rain map .* terrain's size"):
        Rain(None, _Recorder(), r, np.zeros(r.shape), np.ones((3, 3)), 10.0, 1.0, 0)


def test_lake_fills_the_connected_basin_below_its_level():
    r = Raster(0.0, 0.0, 1.0, 1.0, 12, 8)
    ground = np.full(r.shape, 2.0)
    ground[2:6, 1:5] = 0.0  # basin A
    ground[2:6, 7:11] = 0.0  # basin B, separated by a ridge of height 2
    pts = lake_particles(r, ground, 1.0, 0.25, 3, seed_xy=(2.0, 3.0))
    assert pts[:, 0].max() < 5.0  # only basin A
    assert pts[:, 2].max() == pytest.approx(1.0 - 0.125) and pts[:, 2].min() > 0.25 * 0.4
    both = lake_particles(r, ground, 1.0, 0.25, 3)
    assert both[:, 0].max() > 7.0  # without a seed every basin fills
    with pytest.raises(ConfigError, match="outside the terrain"):
        lake_particles(r, ground, 1.0, 0.25, 3, seed_xy=(40.0, 3.0))
    with pytest.raises(ConfigError, match="not below water.level"):
        lake_particles(r, ground, 1.0, 0.25, 3, seed_xy=(6.0, 3.0))


def _grid(r, depth, vel):
    g = FluidGrid(r, vel.shape[-1])
    g.depth[...] = depth
    g.bed_velocity[...] = vel
    g.velocity[...] = vel
    g.count[...] = (depth > 0) * 4
    return g


def _eroder(r, terrain, transport="semi-lagrangian", bedrock=None, **kw):
    solver = SimpleNamespace(state=SimpleNamespace(specs={}), dim=3)
    return TransportCapacity(TransportCapacityParams(transport=transport, **kw), r, solver, bedrock)


def test_no_erosion_under_water_at_rest_even_on_flat_ground():
    """C = K_c sin α |⟨u⟩_t|: still water carries nothing, so nothing is dissolved (the slope clamp
    only matters once the water moves)."""
    r = Raster(0.0, 0.0, 1.0, 1.0, 6, 5)
    terrain = np.zeros(r.shape)
    e = _eroder(r, terrain)
    inc = e.increments(terrain, _grid(r, np.full(r.shape, 0.5), np.zeros(r.shape + (3,))), dt=0.5)
    assert np.all(inc.dz == 0.0) and inc.suspended == 0.0


def test_erosion_grows_with_speed_and_follows_the_law():
    """One node, flat bed (the clamp α_min sets sin α), no sediment yet: the bed loses
    (1 − e^{−K_s Δt})·K_c sin α_min |u|; faster water erodes more; vertical velocity does not count."""
    r = Raster(0.0, 0.0, 1.0, 1.0, 3, 3)
    eroded = []
    for u in (0.5, 1.0, 2.0):
        terrain = np.zeros(r.shape)
        vel = np.zeros(r.shape + (3,))
        vel[..., 0] = u
        vel[..., 2] = -3.0  # falling: not along the ground
        e = _eroder(r, terrain, min_slope_deg=5.0)
        inc = e.increments(terrain, _grid(r, np.full(r.shape, 0.3), vel), dt=0.2)
        eroded.append(-inc.dz[1, 1])
        law = (1 - np.exp(-0.25 * 0.2)) * 0.16 * np.sin(np.radians(5.0)) * u
        assert -inc.dz[1, 1] == pytest.approx(law, rel=1e-12)
        assert inc.suspended == pytest.approx(-inc.dz.sum() * r.cell_area, rel=1e-12)
    assert eroded[0] < eroded[1] < eroded[2]


def test_erosion_stops_at_bedrock():
    r = Raster(0.0, 0.0, 1.0, 1.0, 3, 3)
    terrain = np.zeros(r.shape)
    bedrock = terrain - 0.002
    vel = np.zeros(r.shape + (3,))
    vel[..., 0] = 5.0
    e = _eroder(r, terrain, bedrock=bedrock, capacity=10.0, dissolve=50.0, deposit=0.0)
    for _ in range(20):
        inc = e.increments(terrain, _grid(r, np.full(r.shape, 0.3), vel), dt=0.5)
        terrain += inc.dz
    assert np.all(terrain >= bedrock - 1e-15)
    assert terrain.min() == pytest.approx(-0.002, abs=1e-15)  # cut down to the bedrock and no further


def test_semi_lagrangian_transport_reports_its_mass_error():
    r = Raster(0.0, 0.0, 1.0, 1.0, 10, 1)
    terrain = np.zeros(r.shape)
    vel = np.zeros(r.shape + (2,))
    vel[0, :, 0] = np.linspace(0.2, 1.5, r.nx)  # accelerating flow: the backward step is not conservative
    e = _eroder(r, terrain, min_slope_deg=10.0)
    e.solver.dim = 2
    for _ in range(5):
        terrain += e.increments(terrain, _grid(r, np.full(r.shape, 0.3), vel), dt=0.4).dz
    assert abs(e.transport_error) > 1e-6
    held = e.held_total()
    eroded = -terrain.sum() * r.cell_area
    assert held == pytest.approx(eroded + e.transport_error, rel=1e-12)


def test_a_particle_ground_needs_no_memory_per_area():
    """The heightfield ground lays no particles: the fluid's arrays do not grow with the terrain."""
    from erosim.sph.boundaries.heightfield import HeightfieldGround
    from erosim.sph.solver import SPHSolver

    fluid = np.stack(np.meshgrid(*[np.arange(6) * 0.1 + 0.05] * 2, [0.05, 0.15], indexing="ij"), -1).reshape(-1, 3)
    sizes = {}
    for n in (20, 400):
        r = Raster(0.0, 0.0, 0.1, 0.1, n, n)
        s = SPHSolver(SPHParams(dim=3, spacing=0.1, walls="reflect"), fluid, domain_lo=[-1, -1, -1],
                      domain_hi=[50, 50, 5], boundaries=[HeightfieldGround(r, np.zeros(r.shape))])  # fmt: skip
        assert s.n_boundary == 0
        sizes[n] = sum(a.nbytes for a in s.state._store.values()) + s.nbr.nbytes + s.start.nbytes
    assert sizes[20] == sizes[400]


def test_a_deposit_is_taken_from_each_particle_in_proportion_to_its_load():
    """Particle transport (ER-3): a node that deposits a fraction q of the sediment its water holds
    takes q of each particle's own load (a particle carrying nothing gives nothing, none goes
    negative); a pick-up is shared equally. Sums close to rounding (1e-15)."""
    from erosim.erosion.transport_capacity_mei2007 import exchange_with_particles, held_per_node

    # a one-row raster of three 1 m nodes at x = 0, 1, 2 (the kernels take its numbers: x0, y0, 1/dx, 1/dy, nx, ny)
    pos = np.array([[0.1, 0.0], [0.2, 0.0], [-0.3, 0.0], [1.1, 0.0], [0.9, 0.0]])
    sed = np.array([4.0, 0.0, 1.0, 2.0, 2.0])  # node 0 holds 5 m³ (4, 0, 1), node 1 holds 4 m³
    held = np.zeros(3)
    held_per_node(pos, sed, 5, 0.0, 0.0, 1.0, 1.0, 3, 1, held)
    assert held.tolist() == [5.0, 4.0, 0.0]
    exchange = np.array([-2.0, 0.6, 0.0])  # node 0 deposits 2 of its 5; node 1 picks up 0.6
    count = np.array([3, 2, 0])
    exchange_with_particles(pos, sed, 5, 0.0, 0.0, 1.0, 1.0, 3, 1, exchange, count, held)
    np.testing.assert_allclose(sed, [4.0 * 0.6, 0.0, 1.0 * 0.6, 2.3, 2.3], rtol=1e-15)
    assert sed.min() >= 0.0


def test_the_ground_constraint_lifts_a_particle_below_it_and_stops_it_going_in():
    """A particle found under the heightfield (after a step that crossed it, or a deposit that buried
    it) is put on the Q4 surface, 10⁻³Δx above it, and loses the velocity component into the ground
    (the component along it is kept)."""
    from erosim.sph.boundaries.heightfield import HeightfieldGround
    from erosim.sph.solver import SPHSolver

    r = Raster(0.0, 0.0, 0.1, 0.1, 11, 11)
    terrain = np.fromfunction(lambda j, i: 0.2 * i * 0.1, r.shape)  # a plane rising eastward, slope 0.2
    ground = HeightfieldGround(r, terrain)
    s = SPHSolver(SPHParams(dim=3, spacing=0.05, walls="reflect"), [[0.5, 0.5, 0.4]], domain_lo=[-1, -1, -1],
                  domain_hi=[2, 2, 2], boundaries=[ground])  # fmt: skip
    st = s.state
    st.pos[0] = [0.5, 0.5, 0.02]  # the ground is at 0.1 here: 8 cm under it
    st.vel[0] = [1.0, 0.5, -2.0]
    ground.constrain(s)
    assert st.pos[0, 2] == pytest.approx(0.1 + 1e-3 * 0.05, abs=1e-12)
    n = np.array([-0.2, 0.0, 1.0]) / np.sqrt(1.04)
    assert st.vel[0] @ n == pytest.approx(0.0, abs=1e-12)  # nothing left into the ground
    tangent = np.array([1.0, 0.5, -2.0]) - (np.array([1.0, 0.5, -2.0]) @ n) * n
    np.testing.assert_allclose(st.vel[0], tangent, rtol=1e-12)
    assert ground.below(s, tol=0.0) == 0
    # a deposit that buries it: the refresh lifts it at once
    terrain += 0.3
    ground.refresh(s, terrain=terrain, changed=np.ones(r.shape, bool))
    assert st.pos[0, 2] >= 0.4 and ground.below(s, tol=0.0) == 0


def test_suspended_load_settles_in_still_water_at_the_laws_rate():
    """ER-2 with C = 0 (water at rest): ds/dt = −K_d s, so after n coupling steps of Δt the load is
    s₀ e^{−K_d n Δt} and the bed has risen by what left the water (Mei et al. 2007; seed 000 eq. 1.33).
    The relaxation is exact per step, so the only tolerance is float rounding (1e-12 relative)."""
    r = Raster(0.0, 0.0, 1.0, 1.0, 6, 5)
    terrain = np.zeros(r.shape)
    kd, dt, n, s0 = 0.5, 0.1, 20, 0.01
    e = _eroder(r, terrain, deposit=kd)
    e.s_area[...] = s0
    still = _grid(r, np.full(r.shape, 0.5), np.zeros(r.shape + (3,)))
    for _ in range(n):
        terrain += e.increments(terrain, still, dt).dz
    s = s0 * np.exp(-kd * n * dt)
    assert np.allclose(e.s_area, s, rtol=1e-12, atol=0.0)
    # settled, not lost: the bed rises by what left the water over each node's wet part (an edge node's
    # cell is half wet, a corner's a quarter: e.wet), so the volume closes with the raster's cell area
    assert np.allclose(terrain, e.wet * (s0 - s), rtol=1e-12, atol=0.0)
    assert e.wet[2, 2] == 1.0 and e.wet[0, 2] == 0.5 and e.wet[0, 0] == 0.25
