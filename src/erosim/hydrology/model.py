"""HY-3 the hydrological cycle and its water and sediment budgets.

A cycle: ``droplets_per_cycle`` droplets, each spawned uniformly (or by the rain map), then
descend (HY-1) and flood (HY-2) alternately — at most ``spill`` floods — until its volume is
spent; then the hillslope creep, the stream map update (HY-4) and one vegetation step (HY-5).
By default the droplets run in parallel batches (an eighth of a cycle's droplets, ``hydrology.batch``
unset; :mod:`erosim.hydrology.batch`, :func:`batch_floods`): each round they descend at once
against the round-start state plus their own changes, then serially in droplet order their logs
are applied and their lakes filled — independent of the thread count, not of the batch size.
``hydrology.batch = 0`` (the ``simplehydrology-2020`` preset) runs them one after another in a
single-threaded Numba loop (:func:`run_droplets`): each droplet sees the terrain and lakes the
previous one left, the seed's semantics.
With ``gpu =`` :class:`erosim.hydrology.droplets_cuda.DeviceDroplets` (``run.device = "cuda"``; the
caller gives the class: that module builds on this one) the batches' descents run on a GPU, the lakes
and the per-cycle passes on the host.

Random numbers: droplet i's spawn point comes from SplitMix64 hashing of (seed, i), vegetation's
from NumPy's PCG64 seeded with (seed, cycle) (the seedling count and the key of the vegetation
kernel's SplitMix64 stream): a run resumed from a checkpoint taken between cycles repeats the
uninterrupted run bit for bit.

In the serial order HY-1 runs in one of two kernels chosen once from the parameters
(:func:`erosim.hydrology.droplets.descend_variant`): the seed's case (footprint one cell, whole
time steps — the ``simplehydrology-2020`` preset) has its own short loop, everything else the
general one; batches use :func:`erosim.hydrology.batch.descend_logged` for every case.

Budgets (float64 accumulators, m³):

* water — rained = Σ V₀ over droplets; in_lakes = Σ lake depth·Δx² (measured on the final maps);
  evaporated = evaporation along the paths + the volume left in droplets that ended (below the
  minimum volume, at the spill limit, or at the step cap: the seed deletes them); left_edges =
  water that left over a map edge or into the sea (droplets and lakes draining there).
  closure_rel = |rained − in_lakes − evaporated − left_edges| / rained. Evaporated also holds the water
  that soil creeping into a lake displaces (``displaced_from_lakes_by_creep``): at the spill level it would
  run over; the model lets it go, as it lets go the water of droplets that end.
* sediment — eroded = volume taken from the terrain; deposited = volume put back (along paths,
  on lake beds, where droplets end); carried_off = sediment leaving over an edge or into the sea.
  closure_rel = |eroded − deposited − carried_off| / eroded. Independently,
  Σ(z − z₀)·Δx² = deposited − eroded is checked (``terrain_change``).
"""

from __future__ import annotations

import ctypes
import ctypes.util

import numpy as np
from numba import njit

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap
from erosim.hydrology import pools, streams, vegetation
from erosim.hydrology.batch import (
    DONE,
    NEW,
    NEXT,
    PAUSED,
    R_INDEX,
    R_ROUNDS,
    R_S,
    R_STATUS,
    R_V,
    R_VX,
    R_VY,
    R_X,
    R_Y,
    SERIAL_BELOW,
    apply_logs,
    descend_batch,
    descend_batch_serial,
    work_arrays,
)
from erosim.hydrology.counter_rng import spawn_base, spawn_point, splitmix64
from erosim.hydrology.droplets import ENDED, LEFT, descend, descend_cell, descend_variant
from erosim.hydrology.hillslope_creep_culling1960 import creep_step
from erosim.hydrology.params import (
    P_CA,
    P_DRAIN,
    P_EDGE,
    P_FOOT,
    P_LAKES,
    P_ROOT,
    P_SEA,
    P_SPILL,
    P_V0,
    HydrologyParams,
    VegetationParams,
    batch_size,
    droplets_per_cycle,
    kernel_constants,
    reference_length,
)
from erosim.hydrology.pools import (
    B_CARRIED,
    B_DEPOSITED,
    B_ERODED,
    B_EVAP,
    B_FLOOD_NS,
    B_FLOODS,
    B_LEFT,
    B_RAINED,
    B_RESID,
    B_SIZE,
    B_STEPS,
    B_TO_LAKES,
    DRAIN,
    FILL_ROUND,
    FILLED,
    HS_BUMP,
    HS_NLAKES,
    flood,
    settle_dry,
    settle_in_lake,
    walk_down,
)

_libc = ctypes.CDLL(ctypes.util.find_library("c"))
_clock_gettime = _libc.clock_gettime
_clock_gettime.argtypes = [ctypes.c_int, ctypes.c_void_p]
_clock_gettime.restype = ctypes.c_int
_CLOCK_MONOTONIC = 1


@njit
def _now_real(ts):
    """Monotonic clock in ns (libc clock_gettime through ctypes: ~30 ns a call)."""
    _clock_gettime(_CLOCK_MONOTONIC, ts.ctypes.data)
    return ts[0] * 1_000_000_000 + ts[1]


@njit(cache=True)
def _now_none(ts):
    return 0


@njit(inline="always")
def _lake_spread(P):
    """Cells around its entry over which a droplet's sediment settles in a lake: half the droplet's
    footprint (:func:`erosim.hydrology.pools.settle_in_lake`; 0 for the seed's one-cell droplets)."""
    return int(P[P_FOOT]) // 2


@njit(cache=True)
def _settle(c, V, S, zf, lake_of, level, area, mroot, broot, B, P, hkey, hcell, hleft, hright, hrank, hs, stack, nx):
    """A droplet ends at cell c (a map ``nx`` cells wide): its volume counts as evaporated, its sediment
    settles over the droplet's reach there, in the lake c is in (:func:`erosim.hydrology.pools.settle_in_lake`)
    or on the dry cells (:func:`erosim.hydrology.pools.settle_dry`)."""
    B[B_RESID] += V
    if S <= 0.0:
        return
    k = lake_of[c]
    if k >= 0:
        extra = settle_in_lake(
            k, c, S, zf, lake_of, level, area, mroot, broot, P[P_CA], hkey, hcell, hleft, hright, hrank, hs, stack,
            nx, _lake_spread(P), P[P_SEA],
        )  # fmt: skip
        B[B_TO_LAKES] -= extra
        B[B_RESID] += extra
        B[B_DEPOSITED] += S
    elif zf[c] < P[P_SEA]:
        B[B_CARRIED] += S
    else:
        settle_dry(c, S, zf, lake_of, level, P[P_SEA], nx, P[P_CA], _lake_spread(P))
        B[B_DEPOSITED] += S


@njit(inline="always")
def run_droplets(
    first,
    count,
    seed,
    z2,
    stream,
    roots,
    erod,
    lake_of,
    track,
    level,
    area,
    mroot,
    broot,
    hkey,
    hcell,
    hleft,
    hright,
    hrank,
    hs,
    stack,
    walk,
    rain_cdf,
    B,
    P,
    now,
    margin,
    lake_cap,
    descend,
):
    """Droplets ``first`` … ``first + count − 1``; returns how many ran (fewer when the heap pool
    or the lake table needs a rebuild first — the caller rebuilds and continues).

    ``now`` is the flood timer: :func:`_now_none` normally (cached build), :func:`_now_real` in
    the benchmark (a separate, uncached build that measures the time spent in HY-2); ``descend``
    the HY-1 kernel (:func:`erosim.hydrology.droplets.descend_variant`)."""
    ny, nx = z2.shape
    zf = z2.reshape(-1)
    sf = stream.reshape(-1)
    rf = roots.reshape(-1)
    ef = erod.reshape(-1)
    ts = np.zeros(2, np.int64)
    spill = int(P[P_SPILL])
    lakes_on = P[P_LAKES] > 0.0
    ca = P[P_CA]
    sea = P[P_SEA]
    edge = P[P_EDGE]
    drainage = P[P_DRAIN]
    spread = _lake_spread(P)
    nwalk = 2 * int(P[P_FOOT]) + 1
    base = spawn_base(seed)
    for i in range(count):
        if hkey.shape[0] - hs[HS_BUMP] < margin or hs[HS_NLAKES] + spill + 2 >= lake_cap:
            return i
        x, y = spawn_point(base, first + i, rain_cdf, nx, ny)
        V = P[P_V0]
        S = 0.0
        vx = 0.0
        vy = 0.0
        B[B_RAINED] += P[P_V0]
        rounds = float(spill)
        at_min = False
        while True:
            if at_min:  # spilled into a depression: it floods there without descending
                status = 2
            else:
                status, x, y, vx, vy, V, S = descend(
                    x, y, vx, vy, V, S, z2, zf, sf, rf, ef, lake_of, level, track, B, P
                )
            if status == LEFT:
                break
            c = int(y + 0.5) * nx + int(x + 0.5)
            if status == ENDED or not lakes_on:
                _settle(
                    c, V, S, zf, lake_of, level, area, mroot, broot, B, P, hkey, hcell, hleft, hright, hrank, hs, stack,
                    nx,
                )  # fmt: skip
                break
            t0 = now(ts)
            res, cell, V, S = flood(
                c,
                V,
                S,
                nx,
                ny,
                zf,
                lake_of,
                level,
                area,
                mroot,
                broot,
                B,
                sea,
                edge,
                ca,
                drainage,
                hkey,
                hcell,
                hleft,
                hright,
                hrank,
                hs,
                stack,
                walk,
                spread,
            )
            B[B_FLOOD_NS] += now(ts) - t0
            B[B_FLOODS] += 1
            if res != DRAIN and res != FILLED:
                break
            # step off the drain down the water/terrain surface, away from the lake it left
            cell, at_min = walk_down(cell, nwalk, zf, lake_of, level, sea, nx, ny)
            x = float(cell % nx)
            y = float(cell // nx)
            vx = 0.0
            vy = 0.0
            rounds -= 1.0 if res == DRAIN else FILL_ROUND
            if rounds <= 0:
                _settle(
                    cell,
                    V,
                    S,
                    zf,
                    lake_of,
                    level,
                    area,
                    mroot,
                    broot,
                    B,
                    P,
                    hkey,
                    hcell,
                    hleft,
                    hright,
                    hrank,
                    hs,
                    stack,
                    nx,
                )
                break
    return count


# Cached drivers, one per descend variant. ``run_droplets`` takes the clock and the descend kernel
# as arguments, and Numba's cache cannot hold an overload whose signature names other jitted
# functions (re-pickling its index then fails with "ReferenceError: underlying object has
# vanished", numba/numba#9348), so each variant gets its own cached function into which
# ``run_droplets`` is inlined (Numba IR inlining binds the kernels statically; passing them as
# values would make them uncacheable "dynamic globals"). The benchmark's timed build calls
# ``run_droplets`` itself (uncached).
@njit(cache=True)
def run_droplets_cell(
    first, count, seed, z2, stream, roots, erod, lake_of, track, level, area, mroot, broot, hkey,
    hcell, hleft, hright, hrank, hs, stack, walk, rain_cdf, B, P, margin, lake_cap,
):  # fmt: skip
    """:func:`run_droplets` with the seed-case descend kernel (:func:`descend_cell`), untimed."""
    return run_droplets(
        first, count, seed, z2, stream, roots, erod, lake_of, track, level, area, mroot, broot, hkey,
        hcell, hleft, hright, hrank, hs, stack, walk, rain_cdf, B, P, _now_none, margin, lake_cap,
        descend_cell,
    )  # fmt: skip


@njit(cache=True)
def run_droplets_general(
    first, count, seed, z2, stream, roots, erod, lake_of, track, level, area, mroot, broot, hkey,
    hcell, hleft, hright, hrank, hs, stack, walk, rain_cdf, B, P, margin, lake_cap,
):  # fmt: skip
    """:func:`run_droplets` with the general descend kernel (:func:`descend`), untimed."""
    return run_droplets(
        first, count, seed, z2, stream, roots, erod, lake_of, track, level, area, mroot, broot, hkey,
        hcell, hleft, hright, hrank, hs, stack, walk, rain_cdf, B, P, _now_none, margin, lake_cap,
        descend,
    )  # fmt: skip


FLOOD_LEFT = 8  # batch_floods: the droplet's lake drained it into a tile's halo, or its walk off a drain went there


@njit(cache=True)
def batch_floods(
    start, count, res, z2, lake_of, level, area, mroot, broot, hkey, hcell, hleft, hright, hrank, hs,
    stack, walk, B, P, margin, lake_cap,
):  # fmt: skip
    """Phase 2b of a batch round (:mod:`erosim.hydrology.batch`), serial in droplet order from
    ``start``: each droplet that stopped floods (HY-2) as in :func:`run_droplets` — it ends in a
    lake, or drains, walks off the drain (floods again at once where that walk ends in a
    depression) and is marked ``NEXT`` for another descent; one that ended settles. Returns the
    index reached: below ``count`` when the heap pool or the lake table needs a rebuild first (the
    caller rebuilds and calls again from there). In a tile of a tiled build a droplet whose lake
    drains it into the tile's halo (:func:`erosim.hydrology.pools.flood`, over the halo cell's own
    height), or whose walk off a drain steps into the halo, is marked ``FLOOD_LEFT`` with that halo
    cell (R_X, R_Y) and the water and sediment it took there (R_V, R_S), for
    :meth:`erosim.hydrology.tile_exchange.TileExchange.record_floods`."""
    ny, nx = z2.shape
    zf = z2.reshape(-1)
    spill = int(P[P_SPILL])
    lakes_on = P[P_LAKES] > 0.0
    nwalk = 2 * int(P[P_FOOT]) + 1
    for i in range(start, count):
        status = int(res[i, R_STATUS])
        if status == DONE:
            continue
        if status == PAUSED:
            continue
        if hkey.shape[0] - hs[HS_BUMP] < margin or hs[HS_NLAKES] + spill + 2 >= lake_cap:
            return i
        x = res[i, R_X]
        y = res[i, R_Y]
        V = res[i, R_V]
        S = res[i, R_S]
        rounds = res[i, R_ROUNDS]
        while True:
            if status == LEFT:
                break
            c = int(y + 0.5) * nx + int(x + 0.5)
            if status == ENDED or not lakes_on:
                _settle(
                    c, V, S, zf, lake_of, level, area, mroot, broot, B, P, hkey, hcell, hleft, hright, hrank, hs, stack,
                    nx,
                )  # fmt: skip
                break
            left0 = B[B_LEFT]
            carried0 = B[B_CARRIED]
            res_f, cell, V, S = flood(
                c, V, S, nx, ny, zf, lake_of, level, area, mroot, broot, B, P[P_SEA], P[P_EDGE], P[P_CA],
                P[P_DRAIN], hkey, hcell, hleft, hright, hrank, hs, stack, walk, _lake_spread(P),
            )  # fmt: skip
            B[B_FLOODS] += 1
            if res_f == pools.LEFT and lake_of[cell] == pools.HALO:  # into a tile's halo: passed on
                status = FLOOD_LEFT
                x = float(cell % nx)
                y = float(cell // nx)
                V = B[B_LEFT] - left0
                S = B[B_CARRIED] - carried0
                break
            if res_f != DRAIN and res_f != FILLED:
                break
            cell, at_min = walk_down(cell, nwalk, zf, lake_of, level, P[P_SEA], nx, ny)
            x = float(cell % nx)
            y = float(cell // nx)
            if lake_of[cell] == pools.HALO:  # the walk off the drain left the tile: passed on from there
                B[B_LEFT] += V
                B[B_CARRIED] += S
                status = FLOOD_LEFT
                break
            rounds -= 1.0 if res_f == DRAIN else FILL_ROUND
            if rounds <= 0:
                _settle(
                    cell, V, S, zf, lake_of, level, area, mroot, broot, B, P, hkey, hcell, hleft, hright, hrank, hs,
                    stack, nx,
                )  # fmt: skip
                break
            if at_min:  # spilled into a depression: it floods there without descending
                status = 2
                continue
            status = NEXT
            break
        if status == FLOOD_LEFT:
            res[i, R_STATUS] = FLOOD_LEFT
            res[i, R_X] = x
            res[i, R_Y] = y
            res[i, R_V] = V
            res[i, R_S] = S
        elif status == NEXT:
            res[i, R_STATUS] = NEXT
            res[i, R_X] = x
            res[i, R_Y] = y
            res[i, R_VX] = 0.0
            res[i, R_VY] = 0.0
            res[i, R_V] = V
            res[i, R_S] = S
            res[i, R_ROUNDS] = rounds
        else:
            res[i, R_STATUS] = DONE
    return count


def _index_dtype(count: int):
    """int32 for indices below ``count`` where they fit (the lake heaps' node pool is 3 map sizes:
    28 instead of 48 bytes a node, 60 bytes a cell), else int64."""
    return np.int32 if count < 2**31 - 1 else np.int64


def _check_map(name: str, arr, shape) -> np.ndarray:
    a = np.asarray(arr, dtype=np.float64)
    if a.shape != tuple(shape):
        raise InputError(
            f"The {name} map has shape {a.shape} but the terrain has {tuple(shape)}; "
            "give a map of the same size as the terrain."
        )
    if not np.isfinite(a).all() or (a < 0).any():
        raise InputError(f"The {name} map holds negative or non-finite values; use finite values >= 0.")
    return np.ascontiguousarray(a)


class HydrologyModel:
    """Heightmap + stream, lakes and trees, advanced one cycle at a time (HY-3).

    A model of :class:`~erosim.simulation.simulation.Simulation`: ``advance()`` runs one cycle,
    ``time`` counts the cycles, ``state_dict()`` / ``load_state_dict()`` resume it exactly.
    """

    name = "hydrology"

    STATE_KEYS = (
        "z",
        "z0",
        "stream",
        "cover",
        "trees",
        "lake_of",
        "level",
        "budget",
        "droplets",
        "cycles",
        "area",
        "mroot",
        "broot",
        "hs",
        "hkey",
        "hcell",
        "hleft",
        "hright",
        "hrank",
    )

    def __init__(
        self,
        terrain: Heightmap,
        params: HydrologyParams | None = None,
        veg: VegetationParams | None = None,
        seed: int = 0,
        rain: np.ndarray | None = None,
        erodibility: np.ndarray | None = None,
        timing: bool = False,
        gpu=None,
    ):
        self.p = params or HydrologyParams()
        self.veg = veg or VegetationParams()
        self.seed = int(seed)
        self.terrain = terrain
        self.cell_size = float(terrain.cell_size)
        self.ell = reference_length(self.p, self.cell_size)
        self.P = kernel_constants(self.p, self.cell_size)
        self.P[P_ROOT] = self.veg.root_strength if self.veg.enabled else 0.0
        self._creep = self.p.creep * (self.ell / self.cell_size) ** 2  # κ/Δx² per cycle
        self._descend = descend_variant(self.P)
        self._driver = run_droplets_cell if self._descend is descend_cell else run_droplets_general
        self.z = np.ascontiguousarray(terrain.z, dtype=np.float64).copy()
        self.z0 = self.z.copy()
        ny, nx = self.z.shape
        n = nx * ny
        self.n = n
        self.stream = np.zeros((ny, nx))
        self.cover = np.zeros((ny, nx))  # tree cover within the root radius (HY-5)
        self.trees = np.zeros((ny, nx), np.uint8)
        self.track = np.zeros(n, np.uint8)
        self.erod = np.ones((ny, nx)) if erodibility is None else _check_map("erodibility", erodibility, (ny, nx))
        outside = terrain.nodata.ravel() if terrain.nodata is not None else None
        if rain is None and outside is None:
            self.rain_cdf = np.zeros(0)
        else:
            r = np.ones(n) if rain is None else _check_map("rain", rain, (ny, nx)).ravel().astype(np.float64)
            if outside is not None:
                r = np.where(outside, 0.0, r)  # no rain falls outside the terrain (nodata)
            if r.sum() <= 0:
                raise InputError("The rain map is zero everywhere; give positive values where rain falls.")
            self.rain_cdf = np.cumsum(r)
        self.per_cycle = droplets_per_cycle(self.p, (ny, nx), self.cell_size)
        self.lake_cap = n + self.p.spill * self.per_cycle + 16
        idx = _index_dtype(self.lake_cap + n)  # cell, lake and heap-node indices: 4 bytes where they fit
        self.lake_of = np.full(n, pools.NO_LAKE, idx)
        if outside is not None:
            self.lake_of[outside] = pools.OUTSIDE  # water that reaches a nodata cell leaves, as at the edge
        self.level = np.zeros(self.lake_cap)
        self.budget = np.zeros(B_SIZE)
        self.droplets = 0
        self.cycles = 0
        self.timing = bool(timing)
        # work arrays (rebuilt lake structures live only within a cycle)
        self.area = np.zeros(self.lake_cap, idx)
        self.mroot = np.full(self.lake_cap, -1, idx)
        self.broot = np.full(self.lake_cap, -1, idx)
        self.stack = np.zeros(256, np.int64)
        self.stamp = np.zeros(n, idx)
        self.order = np.zeros(n, idx)
        self.start = np.zeros(n + 2, idx)
        self.hs = np.zeros(4, np.int64)
        self.margin = max(n, 65536)
        self._alloc_pool(3 * self.margin)
        self._built = False
        self.batch = batch_size(self.p, self.per_cycle)
        self.device = "cpu" if gpu is None else "cuda"
        self._gpu = None if gpu is None else gpu(self)  # the batches' descents on the GPU
        self._work = work_arrays(self.batch, n) if self.batch > 0 and self._gpu is None else None
        self.exchange = None  # a tile of a tiled build: its droplet exchange (attach_exchange)

    # ----------------------------------------------------------------------------- internals
    def _alloc_pool(self, size: int) -> None:
        self.hkey = np.zeros(size)
        idx = _index_dtype(size)
        self.hcell = np.zeros(size, idx)
        self.hleft = np.zeros(size, idx)
        self.hright = np.zeros(size, idx)
        self.hrank = np.zeros(size, idx)
        self.walk = np.zeros(size, idx)

    def _rebuild(self) -> None:
        ny, nx = self.z.shape
        zf = self.z.reshape(-1)
        while True:
            old = self.level[: max(int(self.hs[HS_NLAKES]), 1)].copy()
            lake_before = self.lake_of.copy()
            k = pools.rebuild(
                nx,
                ny,
                zf,
                self.lake_of,
                old,
                self.P[P_SEA],
                self.P[P_EDGE],
                self.level,
                self.area,
                self.mroot,
                self.broot,
                self.hkey,
                self.hcell,
                self.hleft,
                self.hright,
                self.hrank,
                self.hs,
                self.stack,
                self.stamp,
                self.order,
                self.start,
            )
            if self.hkey.shape[0] - self.hs[HS_BUMP] >= 2 * self.margin:
                self.n_lakes = k
                self._built = True
                return
            # pool too small for the lakes present: grow it and rebuild from the same maps
            self.lake_of[:] = lake_before
            self.level[: old.size] = old
            self.hs[HS_NLAKES] = old.size
            self._alloc_pool(2 * self.hkey.shape[0] + 2 * self.margin)

    def _run(self, first: int, count: int) -> None:
        """Droplets first … first + count − 1 one after another (the seed's order), rebuilding the
        lake heaps whenever the pool or the lake table fills."""
        k = 0
        while k < count:
            head = (
                first + k, count - k, self.seed, self.z, self.stream, self.cover, self.erod, self.lake_of,
                self.track, self.level, self.area, self.mroot, self.broot, self.hkey, self.hcell,
                self.hleft, self.hright, self.hrank, self.hs, self.stack, self.walk, self.rain_cdf,
                self.budget, self.P,
            )  # fmt: skip
            if self.timing:  # the benchmark's build with a real clock around the lake filling
                done = run_droplets(*head, _now_real, self.margin, self.lake_cap, self._descend)
            else:
                done = self._driver(*head, self.margin, self.lake_cap)
            self.droplets += done
            k += done
            if k < count:
                self._rebuild()  # heap pool or lake table full: compact, then go on

    def _run_batch(self, first: int, total: int, inject: np.ndarray | None = None) -> None:
        """Droplets first … first + total − 1 in batch rounds over ``batch`` slots (:mod:`erosim.hydrology.batch`):
        parallel descents, then serially, slot by slot, their logs applied and their floods; a slot whose
        droplet is done takes the next droplet for the next round. ``inject``: instead of spawning, the
        ``total`` droplets that enter from a neighbouring tile, rows (cycle, x, y, vx, vy, V, S)
        (:mod:`erosim.hydrology.tile_exchange`): they start as droplets that go on descending (NEXT)."""
        ny, nx = self.z.shape
        zf = self.z.reshape(-1)
        res, lc, ldz, bd, ov = self._work
        slots = min(self.batch, total)
        res[:slots, R_STATUS] = DONE
        entered = 0
        foot = int(self.P[P_FOOT])
        while True:
            entered = self._enter(res[:slots], first, entered, total, inject)
            status = res[:slots, R_STATUS]
            left = np.count_nonzero((status == NEW) | (status == NEXT) | (status == PAUSED))
            if left == 0:
                return
            descend = descend_batch_serial if left < SERIAL_BELOW else descend_batch
            descend(slots, self.seed, self.z, self.stream, self.cover, self.erod, self.lake_of, self.level,
                    self.rain_cdf, self.P, res, lc, ldz, bd, ov)  # fmt: skip
            if self.exchange is not None:  # droplets that left into the halo go to the neighbour
                self.exchange.record(self.cycles, res, bd, slots)
            apply_logs(slots, nx, ny, foot, zf, self.lake_of, self.track, res, lc, ldz, bd, self.budget, ov.shape[0])
            k = 0
            while True:
                k = batch_floods(
                    k, slots, res, self.z, self.lake_of, self.level, self.area, self.mroot, self.broot,
                    self.hkey, self.hcell, self.hleft, self.hright, self.hrank, self.hs, self.stack, self.walk,
                    self.budget, self.P, self.margin, self.lake_cap,
                )  # fmt: skip
                if k >= slots:
                    break
                self._rebuild()  # heap pool or lake table full: compact, then go on
            if self.exchange is not None:  # lakes that drained droplets into the halo
                self.exchange.record_floods(self.cycles, res, slots, FLOOD_LEFT, DONE)

    def _enter(self, res: np.ndarray, first: int, entered: int, total: int, inject: np.ndarray | None) -> int:
        """The next droplets into the free (DONE) slots of ``res``, in slot order: droplet first + entered, …
        spawns (NEW), or the next ``inject`` rows go on descending (NEXT). Returns how many have entered."""
        free = np.flatnonzero(res[:, R_STATUS] == DONE)[: total - entered]
        k = free.size
        if k == 0:
            return entered
        res[free, R_ROUNDS] = self.p.spill
        if inject is None:
            res[free, R_STATUS] = NEW
            res[free, R_INDEX] = first + entered + np.arange(k)
            self.budget[B_RAINED] += k * self.P[P_V0]
        else:
            res[free, R_STATUS] = NEXT
            rows = inject[entered : entered + k]
            for col, c in ((R_X, 1), (R_Y, 2), (R_VX, 3), (R_VY, 4), (R_V, 5), (R_S, 6)):
                res[free, col] = rows[:, c]
        return entered + k

    def _slump_into_lakes(self, wet: np.ndarray, gains: np.ndarray) -> None:
        """What creep carried from the shores onto the beds of the lake cells ``wet`` (``gains``, m), settled
        through the lake bookkeeping (:func:`erosim.hydrology.pools.settle_gains`); first, room in the heap pool
        for one node per cell."""
        if not np.any(gains > 0.0):
            return
        if self.hkey.shape[0] - self.hs[HS_BUMP] < wet.size + 2 * self.margin:
            self._rebuild()
            if self.hkey.shape[0] - self.hs[HS_BUMP] < wet.size + 2 * self.margin:
                self._alloc_pool(self.hkey.shape[0] + wet.size + 2 * self.margin)
                self._rebuild()
        displaced = pools.settle_gains(
            wet, gains, self.z.reshape(-1), self.lake_of, self.level, self.area, self.mroot, self.broot,
            self.cell_size**2, self.hkey, self.hcell, self.hleft, self.hright, self.hrank, self.hs, self.stack,
        )  # fmt: skip
        self.budget[B_TO_LAKES] -= displaced
        self.budget[pools.B_DISPLACED] += displaced

    def attach_exchange(self, exchange) -> None:
        """Make this model a tile of a tiled build (:class:`erosim.hydrology.tile_exchange.TileExchange`): the
        cells outside the tile's core (its halo) become ``lake_of`` = HALO (no rain, no erosion; droplets
        reaching them leave, and are recorded to enter the neighbour; a lake drains into them over their
        own height, :func:`erosim.hydrology.pools.flood`), rain falls on the core
        only, as many droplets per cycle as on the core's area, and the droplets entering from the
        neighbours run every cycle. Needs the batch path (``hydrology.batch`` unset or > 0)."""
        if self.batch <= 0:
            raise InputError(
                "A tiled build passes droplets between tiles on the batch path only; leave hydrology.batch "
                "unset (or > 0) for a tiled build."
            )
        if self._gpu is not None:
            raise InputError(
                "A tiled build passes droplets between tiles on the CPU only; leave run.device = 'cpu' for a "
                "tiled build."
            )
        ny, nx = self.z.shape
        r0, r1, c0, c1 = exchange.core
        halo = np.ones((ny, nx), bool)
        halo[r0:r1, c0:c1] = False
        flat = halo.ravel()
        self.lake_of[flat & (self.lake_of != pools.OUTSIDE)] = pools.HALO
        r = np.ones(self.n) if self.rain_cdf.size == 0 else np.diff(self.rain_cdf, prepend=0.0)
        r = np.where(flat | (self.lake_of == pools.OUTSIDE), 0.0, r)
        self.rain_cdf = np.cumsum(r)
        self.per_cycle = droplets_per_cycle(self.p, (r1 - r0, c1 - c0), self.cell_size)
        self.batch = batch_size(self.p, self.per_cycle)  # > 0: a set batch was checked above, unset gives ≥ 1
        self._work = work_arrays(self.batch, self.n)
        self._halo = np.flatnonzero(self.lake_of == pools.HALO)
        self.exchange = exchange

    def _creep_tile(self) -> None:
        """Creep in a tile of a tiled build: its halo creeps as dry land, so that soil crosses the tile's
        border as it would untiled (a step at a border is smoothed from both sides), but only the core's
        change is kept — the halo's heights are put back (the neighbour creeps its own core; faces inside
        the halo are its). What the core gained across the border is counted in the exchange
        (``flow[4]``, m³) and closes the tile's terrain budget."""
        halo = self._halo
        before = self.z.reshape(-1)[halo]
        lake = np.where(self.lake_of == pools.HALO, pools.NO_LAKE, self.lake_of)
        moved = creep_step(self.z, self.erod, self._creep, lake)
        self.budget[pools.B_CREPT] += moved * self.cell_size**2
        zf = self.z.reshape(-1)
        self.exchange.flow[4] += float(np.sum(before - zf[halo])) * self.cell_size**2
        zf[halo] = before

    # ----------------------------------------------------------------------------- public API
    def cycle(self) -> None:
        """One cycle: droplets, then the stream map and the vegetation."""
        if not self._built or self.cycles % self.p.rebuild_every == 0:
            self._rebuild()
        batch = self.batch
        if batch <= 0:
            self._run(self.droplets, self.per_cycle)
        else:
            gpu = self._gpu
            if gpu is not None:
                gpu.push()  # the host passes of the last cycle (and any lake rebuild) changed the maps
            if gpu is None:
                self._run_batch(self.droplets, self.per_cycle)
                self.droplets += self.per_cycle
            else:
                todo = self.per_cycle
                while todo > 0:
                    nb = min(batch, todo)
                    gpu.run_batch(self.droplets, nb)
                    self.droplets += nb
                    todo -= nb
                gpu.pull_track()
        if self.exchange is not None:  # droplets entering from the neighbouring tiles this cycle
            incoming = self.exchange.incoming(self.cycles)
            if incoming.shape[0]:
                self._run_batch(self.droplets, incoming.shape[0], inject=incoming)
            self.exchange.entered(incoming)
        streams.update(self.stream, self.track, self.p.stream_rate)
        if self._creep > 0.0:
            wet = np.flatnonzero(self.lake_of >= 0)
            bed = self.z.reshape(-1)[wet]
            if self.exchange is not None:
                self._creep_tile()
            else:
                moved = creep_step(self.z, self.erod, self._creep, self.lake_of)  # dry land, and into lakes
                self.budget[pools.B_CREPT] += moved * self.cell_size**2
            self._slump_into_lakes(wet, self.z.reshape(-1)[wet] - bed)
        if self.veg.enabled:
            rng = np.random.default_rng([self.seed & 0xFFFFFFFF, self.cycles, 0x5EED])
            vegetation.step(
                self.trees,
                self.cover,
                self.z,
                self.cell_size,
                self.ell,
                self.lake_of,
                self.level,
                self.P[P_SEA],
                self.stream,
                self.veg,
                rng,
                self.order,  # scratch: the rebuild's order array is free between cycles
            )
        self.cycles += 1

    def advance(self) -> None:
        """One cycle (the simulation's unit of work)."""
        self.cycle()

    @property
    def time(self) -> float:
        """Progress in cycles."""
        return float(self.cycles)

    def run(self, cycles: int) -> None:
        for _ in range(cycles):
            self.cycle()

    def sea_mask(self) -> np.ndarray:
        return self.z < self.P[P_SEA]

    def lake_depth(self) -> np.ndarray:
        """Depth of standing water (m) per cell (the pool map)."""
        return pools.depth_map(self.lake_of, self.level, self.z)

    def erosion(self) -> np.ndarray:
        """Net lowering of the terrain (m, ≥ 0)."""
        d = np.subtract(self.z0, self.z)
        return np.maximum(d, 0.0, out=d)

    def deposition(self) -> np.ndarray:
        """Net raising of the terrain (m, ≥ 0)."""
        d = np.subtract(self.z, self.z0)
        return np.maximum(d, 0.0, out=d)

    def vegetation(self) -> np.ndarray:
        """Root density ρ_r in [0, 1] (zero on lakes and sea): what holds the soil (HY-5)."""
        return vegetation.root_density(self.cover, self.veg, (self.lake_depth() > 0) | self.sea_mask())

    def water_budget(self) -> dict:
        B = self.budget
        ca = self.cell_size**2
        rained = float(B[B_RAINED])
        in_lakes = float(self.lake_depth().sum() * ca)
        displaced = float(B[pools.B_DISPLACED])
        evaporated = float(B[B_EVAP] + B[B_RESID]) + displaced
        left = float(B[B_LEFT])
        entered = float(self.exchange.flow[0]) if self.exchange is not None else 0.0
        supplied = rained + entered
        closure = abs(supplied - in_lakes - evaporated - left) / supplied if supplied > 0 else 0.0
        out = {
            "unit": "m3",
            "rained": rained,
            "in_lakes": in_lakes,
            "evaporated": evaporated,
            "left_edges": left,
            "closure_rel": closure,
            "evaporated_in_flight": float(B[B_EVAP]),
            "ended_in_droplets": float(B[B_RESID]),
            "displaced_from_lakes_by_creep": displaced,
            "in_lakes_tracked": float(B[B_TO_LAKES]),
        }
        if self.exchange is not None:  # a tile: closure = |rained + entered − in lakes − evaporated − left|
            out.update(entered_from_tiles=entered, passed_to_tiles=float(self.exchange.flow[2]))
        return out

    def sediment_budget(self) -> dict:
        B = self.budget
        ca = self.cell_size**2
        eroded = float(B[B_ERODED])
        deposited = float(B[B_DEPOSITED])
        carried = float(B[B_CARRIED])
        entered = float(self.exchange.flow[1]) if self.exchange is not None else 0.0
        closure = abs(eroded + entered - deposited - carried) / eroded if eroded > 0 else 0.0
        change = float(np.sum(self.z - self.z0) * ca)
        crept_in = float(self.exchange.flow[4]) if self.exchange is not None else 0.0  # a tile: creep across its border
        out = {
            "unit": "m3",
            "eroded": eroded,
            "deposited": deposited,
            "carried_off": carried,
            "closure_rel": closure,
            "terrain_change": change,
            "terrain_change_rel_error": abs(change - (deposited - eroded + crept_in)) / eroded if eroded > 0 else 0.0,
            "moved_by_creep": float(B[pools.B_CREPT]),
        }
        if self.exchange is not None:  # a tile: closure = |eroded + entered − deposited − carried off|
            out.update(entered_from_tiles=entered, passed_to_tiles=float(self.exchange.flow[3]), crept_in=crept_in)
        return out

    def sediment_in_transit(self) -> tuple[float, float]:
        """(sediment held in the water, sediment carried off the map) so far, m³. Droplets are not kept
        between cycles, so after a whole cycle nothing is held: the terrain's change is −carried off
        (in a tile of a tiled build: the sediment that entered from its neighbours, and the soil that crept
        in across its border, less that)."""
        if self.exchange is None:
            return 0.0, float(self.budget[B_CARRIED])
        return 0.0, float(self.budget[B_CARRIED]) - float(self.exchange.flow[1]) - float(self.exchange.flow[4])

    def stats(self) -> dict:
        B = self.budget
        depth = self.lake_depth()
        return {
            "droplets": int(self.droplets),
            "cycles": int(self.cycles),
            "droplets_per_cycle": int(self.per_cycle),
            "batch": int(self.batch),
            "descend_steps": int(B[B_STEPS]),
            "floods": int(B[B_FLOODS]),
            "lake_cells": int((depth > 0).sum()),
            "lake_fraction": float((depth > 0).mean()),
            "max_lake_depth_m": float(depth.max()),
            "tree_fraction": float(self.trees.mean()),
            "stream_max": float(self.stream.max()),
            "reference_length_m": self.ell,
        }

    # ----------------------------------------------------------------------------- checkpoint
    def state_dict(self) -> dict:
        """Everything the next cycle reads, lake heaps included (so a resume is bit-identical)."""
        k = max(int(self.hs[HS_NLAKES]), 1)
        used = int(self.hs[HS_BUMP])
        return {
            "z": self.z,
            "z0": self.z0,
            "stream": self.stream,
            "cover": self.cover,
            "trees": self.trees,
            "lake_of": self.lake_of,
            "level": self.level[:k].copy(),
            "budget": self.budget,
            "droplets": np.int64(self.droplets),
            "cycles": np.int64(self.cycles),
            "area": self.area[:k].copy(),
            "mroot": self.mroot[:k].copy(),
            "broot": self.broot[:k].copy(),
            "hs": self.hs.copy(),
            "hkey": self.hkey[:used].copy(),
            "hcell": self.hcell[:used].copy(),
            "hleft": self.hleft[:used].copy(),
            "hright": self.hright[:used].copy(),
            "hrank": self.hrank[:used].copy(),
            "built": np.int64(self._built),
            **(self.exchange.state_dict() if self.exchange is not None else {}),
        }

    def load_state_dict(self, st: dict) -> None:
        missing = [k for k in self.STATE_KEYS if k not in st]
        if missing or np.shape(st["z"]) != self.z.shape:
            raise InputError(
                "The checkpoint does not match this hydrology run (missing or differently "
                "sized maps); "
                "start the run again without --resume."
            )
        for name in ("z", "z0", "stream", "cover", "trees", "lake_of"):
            getattr(self, name)[...] = st[name]
        b = np.asarray(st["budget"])  # a checkpoint from before the creep into lakes has one term fewer
        self.budget[:] = 0.0
        self.budget[: b.size] = b
        k = np.asarray(st["level"]).size
        for name in ("level", "area", "mroot", "broot"):
            getattr(self, name)[:k] = st[name]
        self.hs[...] = st["hs"]
        used = int(self.hs[HS_BUMP])
        if used > self.hkey.shape[0] - 2 * self.margin:
            self._alloc_pool(used + 3 * self.margin)
        for name in ("hkey", "hcell", "hleft", "hright", "hrank"):
            getattr(self, name)[:used] = st[name]
        self.droplets = int(st["droplets"])
        self.cycles = int(st["cycles"])
        self._built = bool(int(st.get("built", 1)))
        if self.exchange is not None:
            self.exchange.load_state_dict(st)

    def flood_seconds(self) -> float:
        return float(self.budget[B_FLOOD_NS]) * 1e-9


__all__ = ["HydrologyModel", "run_droplets", "run_droplets_cell", "run_droplets_general", "splitmix64"]
