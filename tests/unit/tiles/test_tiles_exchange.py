"""Droplets crossing tile borders (erosim.tiles.exchange): recorded where they leave one tile's core,
routed to the neighbour, injected there with their water and sediment; budgets close, runs repeat and
resume exactly. Two tiles of a small tilted map, run by hand (no Dask)."""

import numpy as np
import pytest

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap
from erosim.hydrology.model import HydrologyModel
from erosim.hydrology.params import HydrologyParams, VegetationParams
from erosim.tiles.exchange import COLUMNS, TileExchange, route
from erosim.tiles.plan import plan

NY, NX, K = 32, 64, 4
TILES = plan((NY, NX), 32, K)  # r0_c0: core cols 0–32, window 0–36; r0_c1: core 32–64, window 28–64
A, B = TILES[0], TILES[1]


def _terrain(seed=3):
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:NY, 0:NX]
    valley = 8.0 * np.abs(yy - NY / 2) / NY  # a valley along the rows, falling to the east
    return 200.0 - 1.5 * xx + valley + ndimage.gaussian_filter(rng.random((NY, NX)), 2.0) * 6.0


def _model(tile, inflow=None, seed=5, z=None):
    z = _terrain() if z is None else z
    r0, r1, c0, c1 = tile.window
    p = HydrologyParams(length_scale=40.0, max_step=1.0, cycle_droplets=20000)
    m = HydrologyModel(Heightmap(z=z[r0:r1, c0:c1].copy(), cell_size=20.0), p, VegetationParams(spawn=50.0), seed)
    cr0, cr1, cc0, cc1 = tile.core
    ex = TileExchange((cr0 - r0, cr1 - r0, cc0 - c0, cc1 - c0), (r0, c0), inflow)
    m.attach_exchange(ex)
    return m


def _budgets_close(m):
    w, s = m.water_budget(), m.sediment_budget()
    # float64 sums of ~10⁴ droplet terms: rounding ~1e-13 relative
    assert w["closure_rel"] < 1e-9 and s["closure_rel"] < 1e-9 and s["terrain_change_rel_error"] < 1e-9


@pytest.fixture(scope="module")
def upstream():
    m = _model(A)
    m.run(4)
    return m


def test_rain_falls_on_the_core_and_droplets_leave_into_the_halo(upstream):
    m = upstream
    # A's halo (the 4 columns of B's core) is B's: nothing A's droplets do changes it (a 2×2 footprint
    # (ℓ = 2 cells) reaching over the border moves its transfer on its core cells only)
    assert (m.z[:, 32:] == m.z0[:, 32:]).all()
    # no droplet walked there: only the 2×2 footprints (ℓ = 2 cells) of droplets on the core's last
    # column mark the halo's first column
    assert (m.stream[:, 33:] == 0).all() and (m.stream[:, 32] > 0).any()
    assert m.per_cycle == HydrologyModel(Heightmap(z=np.zeros((NY, 32)), cell_size=20.0), m.p).per_cycle
    e = m.exchange.exits()
    assert e.shape[0] > 0 and e.shape[1] == len(COLUMNS)
    col = np.floor(e[:, 1] + 0.5)
    assert (col >= 32).all() and (col < 36).all()  # map coordinates of A's halo cells
    assert set(np.unique(e[:, 0])) <= {0.0, 1.0, 2.0, 3.0} and (e[:, 5] > 0).all()
    # what left into the halo is what the water budget counts as passed on
    w = m.water_budget()
    assert w["passed_to_tiles"] == pytest.approx(e[:, 5].sum(), rel=1e-12)
    assert w["passed_to_tiles"] > 0.2 * w["rained"]  # on a slope falling east most water reaches B
    _budgets_close(m)


def test_route_hands_each_exit_to_the_tile_whose_core_holds_it(upstream):
    exits = upstream.exchange.exits()
    got = route(TILES, 1, lambda t: exits if t == A else np.zeros((0, len(COLUMNS))), cycles=3)
    assert got.shape[0] == exits.shape[0]
    np.testing.assert_array_equal(np.sort(got[:, 1]), np.sort(exits[:, 1] - B.window[2]))  # B's window coordinates
    np.testing.assert_array_equal(np.sort(got[:, 5]), np.sort(exits[:, 5]))  # water kept
    assert (np.diff(got[:, 0]) >= 0).all() and got[:, 0].max() == 2  # by cycle; cycle 3 enters in the last (2)
    assert route(TILES, 0, lambda t: exits if t == A else np.zeros((0, 7)), cycles=3).shape[0] == 0  # not back


def test_injected_droplets_carry_water_and_sediment_into_the_neighbour(upstream):
    inflow = route(TILES, 1, lambda t: upstream.exchange.exits() if t == A else np.zeros((0, 7)), cycles=4)
    fed, alone = _model(B, inflow), _model(B)
    fed.run(4)
    alone.run(4)
    w, s = fed.water_budget(), fed.sediment_budget()
    assert w["entered_from_tiles"] == pytest.approx(inflow[:, 5].sum(), rel=1e-12)
    assert s["entered_from_tiles"] == pytest.approx(inflow[:, 6].sum(), rel=1e-12)
    _budgets_close(fed)
    # the water entering at B's west border walks there: B's first core columns are visited far more
    first = np.s_[:, K : K + 4]
    assert fed.stream[first].sum() > 2 * alone.stream[first].sum()
    again = _model(B, inflow)
    again.run(4)
    assert np.array_equal(again.z, fed.z) and np.array_equal(again.exchange.exits(), fed.exchange.exits())


def test_a_tile_resumes_bit_identically_with_its_exchange(upstream):
    inflow = route(TILES, 1, lambda t: upstream.exchange.exits() if t == A else np.zeros((0, 7)), cycles=4)
    full = _model(B, inflow)
    full.run(4)
    part = _model(B, inflow)
    part.run(2)
    again = _model(B, inflow)
    again.load_state_dict({k: np.array(v, copy=True) for k, v in part.state_dict().items()})
    again.run(2)
    assert np.array_equal(full.z, again.z) and np.array_equal(full.budget, again.budget)
    assert np.array_equal(full.exchange.exits(), again.exchange.exits())
    assert np.array_equal(full.exchange.flow, again.exchange.flow)


def test_the_serial_order_is_refused_for_a_tile():
    p = HydrologyParams(batch=0)
    m = HydrologyModel(Heightmap(z=_terrain()[:, :36].copy(), cell_size=20.0), p, VegetationParams(), 1)
    with pytest.raises(InputError, match="hydrology.batch"):
        m.attach_exchange(TileExchange((0, NY, 0, 32), (0, 0)))


def test_creep_crosses_the_border_and_leaves_the_halo_to_the_neighbour():
    """A 40 m step at the border (A's core low, its halo high): creep moves soil down it into the core's
    last column as an untiled run would (flux c·Δz a face), the halo keeps its heights (B creeps its own
    core), and the volume that crossed closes the tile's terrain budget."""
    z = np.full((NY, NX), 100.0)
    z[:, 32:] = 140.0
    m = _model(A, z=z)
    before = m.z.copy()
    m._creep_tile()
    c = m._creep  # κ/Δx² per cycle
    gained = m.z[:, 31] - before[:, 31]
    # one explicit step: the last core column gains c·40 m from its face with the halo (its other faces
    # are flat); rows 0 and NY−1 have the same single face across
    np.testing.assert_allclose(gained, c * 40.0, rtol=1e-12)
    assert (m.z[:, 32:] == before[:, 32:]).all() and (m.z[:, :31] == before[:, :31]).all()
    assert m.exchange.flow[4] == pytest.approx(gained.sum() * 20.0**2, rel=1e-12)
    m.run(2)
    _budgets_close(m)
