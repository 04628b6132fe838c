"""HY-1 droplets on an NVIDIA GPU (``--device cuda``, numba-cuda): one thread per droplet of a batch.

The device path of :class:`erosim.hydrology.model.HydrologyModel` for the parallel batches
(:mod:`erosim.hydrology.batch`). A batch runs in rounds as on the CPU; each round

1. on the device, every droplet that has a descent to do descends — one thread each, calling the
   CPU's own sub-step :func:`erosim.hydrology.droplet_step.step` compiled as a device function (in
   Numba's CUDA simulator: its Python source) — against the **live** terrain: each step's transfer
   is applied at once with atomic adds (``h −= dz`` on the footprint's dry cells), each visited
   footprint marked in ``track``; budget terms go to the droplet's own row;
2. on the host, the rows come back, the budget rows are added in droplet order, and each droplet
   that stopped floods (HY-2, :func:`erosim.hydrology.model.batch_floods`, the CPU's own pass, in
   droplet order); those that drained descend again in the next round.

So the model differs from the CPU batches in one point: droplets of a round see each other's
erosion as it happens (there is no private overlay per droplet — a map per thread does not fit a
GPU), the way GPU droplet eroders work; the lakes are the serial loop's.

Determinism on the device: the order in which threads read and atomically add to a cell is the
hardware's, and floating-point addition is not associative, so a GPU run is **not** repeatable
bit for bit and droplets that meet take slightly different paths from run to run. What is
guaranteed: every height change is applied exactly once to the cells it was computed for and
counted in the same droplet's budget row (the sediment and water budgets close to rounding, as on
the CPU); the budget rows are summed on the host in droplet order; spawn points are the CPU's
(counter-based, :mod:`erosim.hydrology.counter_rng`); the lakes are filled serially in droplet
order. The tests compare the device with the CPU batches statistically (within the CPU path's own
seed-to-seed scatter) and, for one droplet at a time, where no two threads meet, to float rounding.

State on the device: the terrain, the stream and root maps, the erodibility, the lake map and
levels, the visit map and the constants stay in device memory for the whole run. The lake pass
(HY-2) and the per-cycle passes (stream map, creep, vegetation) stay on the host, so the terrain
is copied back after each round's descents and up again after the floods, and the stream, root
and lake maps after each cycle: two map transfers a round (8 bytes a cell each way). That the lake
pass is not the bottleneck is an expectation, not yet a measurement (no GPU was available when this
was written; ``erosim bench hydrology --device cuda --json`` measures it where one is).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from erosim.core import devices
from erosim.core.errors import ConfigError
from erosim.hydrology import droplet_step
from erosim.hydrology.batch import NEW, NEXT, R_ROUNDS, R_S, R_STATUS, R_V, R_VX, R_VY, R_X, R_Y
from erosim.hydrology.counter_rng import spawn_base, spawn_point
from erosim.hydrology.model import batch_floods
from erosim.hydrology.params import P_FOOT, P_MAXSTEPS, P_SPILL, P_V0
from erosim.hydrology.pools import B_CARRIED, B_DEPOSITED, B_ERODED, B_EVAP, B_LEFT, B_RAINED, B_SIZE, B_STEPS
from erosim.kernels.device_source import SIMULATOR, rebind

devices.numpy_aliases()
from numba import cuda  # noqa: E402  (after the numpy alias: erosim.core.devices)

TPB = 32 if SIMULATOR else 128  # threads per block (the simulator runs a block's threads as Python threads)

_S = rebind(droplet_step)  # the CPU's sub-step and its helpers, from their source (erosim.kernels.device_source)
_step = _S.step
_constants = _S.constants
_origin = _S.origin
_box = _S.box
NO_LAKE = droplet_step.NO_LAKE
LEFT, STOP, ENDED = droplet_step.LEFT, droplet_step.STOP, droplet_step.ENDED


@cuda.jit
def descend_kernel(count, res, bd, z2, zf, stream, roots, erod, lake_of, level, track, P):
    """Droplet i < ``count`` whose row says NEW or NEXT descends (module docstring): the shared
    sub-step until it ends, leaves or stops; transfers by atomic adds; row and budget row written."""
    i = cuda.grid(1)
    if i >= count:
        return
    for k in range(bd.shape[1]):
        bd[i, k] = 0.0
    st0 = int(res[i, R_STATUS])
    if st0 != NEW and st0 != NEXT:
        return
    ny, nx = z2.shape
    K = _constants(P)
    m = int(P[P_FOOT])
    maxsteps = int(P[P_MAXSTEPS])
    x = res[i, R_X]
    y = res[i, R_Y]
    vx = 0.0
    vy = 0.0
    if st0 == NEW:
        V = P[P_V0]
        S = 0.0
    else:
        vx = res[i, R_VX]
        vy = res[i, R_VY]
        V = res[i, R_V]
        S = res[i, R_S]
    speed = math.sqrt(vx * vx + vy * vy)
    steps = 0
    evap = 0.0
    eroded = 0.0
    deposited = 0.0
    status = ENDED
    while True:
        j_lo, j_hi, i_lo, i_hi = _box(_origin(x, y, m), m, nx, ny)
        for j in range(j_lo, j_hi):
            for ii in range(i_lo, i_hi):
                track[j * nx + ii] = 1
        st, x, y, vx, vy, vn, S, speed, code, dz, moved = _step(
            x, y, vx, vy, V, S, speed, z2, zf, zf, False, stream, roots, erod, lake_of, level, K
        )
        steps += 1
        if st == LEFT:
            bd[i, B_LEFT] = V
            bd[i, B_CARRIED] = S
            V = 0.0
            S = 0.0
            status = LEFT
            break
        if st == STOP:
            status = STOP
            break
        if moved != 0.0:
            j_lo, j_hi, i_lo, i_hi = _box(code, m, nx, ny)
            for j in range(j_lo, j_hi):
                for ii in range(i_lo, i_hi):
                    if lake_of[j * nx + ii] == NO_LAKE:
                        cuda.atomic.add(zf, j * nx + ii, -dz)
            if moved > 0.0:
                eroded += moved
            else:
                deposited -= moved
        evap += V - vn
        V = vn
        if st == ENDED or steps >= maxsteps:
            status = ENDED
            break
    res[i, R_STATUS] = status
    res[i, R_X] = x
    res[i, R_Y] = y
    res[i, R_VX] = vx
    res[i, R_VY] = vy
    res[i, R_V] = V
    res[i, R_S] = S
    bd[i, B_STEPS] = steps
    bd[i, B_EVAP] = evap
    bd[i, B_ERODED] = eroded
    bd[i, B_DEPOSITED] = deposited


@njit(cache=True)
def spawn_rows(first, count, seed, rain_cdf, nx, ny, spill, res):
    """Rows of droplets ``first`` … ``first + count − 1``: NEW at the CPU's spawn points."""
    base = spawn_base(seed)
    for i in range(count):
        x, y = spawn_point(base, first + i, rain_cdf, nx, ny)
        res[i, R_STATUS] = NEW
        res[i, R_X] = x
        res[i, R_Y] = y
        res[i, R_VX] = 0.0
        res[i, R_VY] = 0.0
        res[i, R_ROUNDS] = spill


@njit(cache=True)
def add_rows(count, bd, B):
    """The droplets' budget rows added to the run's budget, in droplet order."""
    for i in range(count):
        for k in range(B_SIZE):
            B[k] += bd[i, k]


class DeviceDroplets:
    """The device copies of a :class:`~erosim.hydrology.model.HydrologyModel`'s maps and the batch
    loop that runs its droplets there (module docstring). ``sync_to_host`` / ``push`` move the maps
    the host passes read and write."""

    def __init__(self, model) -> None:
        devices.require("cuda")
        if model.batch <= 0:
            raise ConfigError(
                "hydrology.batch = 0 (the seed's one-after-another order) runs on device 'cpu' only; "
                "leave hydrology.batch unset or give a batch size for --device cuda."
            )
        self.model = model
        ny, nx = model.z.shape
        self.d_z = cuda.to_device(model.z)
        self.d_zf = self.d_z.reshape(nx * ny)
        self.d_erod = cuda.to_device(model.erod.reshape(-1))
        self.d_P = cuda.to_device(model.P)
        self.d_track = cuda.to_device(model.track)
        self.d_stream = cuda.to_device(model.stream.reshape(-1))
        self.d_cover = cuda.to_device(model.cover.reshape(-1))
        self.d_lake = cuda.to_device(model.lake_of)
        self.d_level = cuda.to_device(model.level)
        self.res = np.zeros((model.batch, 10))
        self.bd = np.zeros((model.batch, B_SIZE))
        self.d_res = cuda.to_device(self.res)
        self.d_bd = cuda.to_device(self.bd)

    def push(self) -> None:
        """Host → device: the maps the host passes change (terrain, lakes, streams, roots, visits)."""
        m = self.model
        self.d_z.copy_to_device(m.z)
        self.d_lake.copy_to_device(m.lake_of)
        self.d_level.copy_to_device(m.level)
        self.d_stream.copy_to_device(m.stream.reshape(-1))
        self.d_cover.copy_to_device(m.cover.reshape(-1))
        self.d_track.copy_to_device(m.track)

    def pull_track(self) -> None:
        """Device → host: the visit map (read by the stream update at the cycle's end)."""
        self.d_track.copy_to_host(self.model.track)

    def run_batch(self, first: int, nb: int) -> None:
        """Droplets first … first + nb − 1 in rounds: descents on the device, floods on the host."""

        m = self.model
        ny, nx = m.z.shape
        res, bd = self.res, self.bd
        spawn_rows(first, nb, m.seed, m.rain_cdf, nx, ny, int(m.P[P_SPILL]), res)
        m.budget[B_RAINED] += nb * m.P[P_V0]
        blocks = max(1, (nb + TPB - 1) // TPB)
        while True:
            self.d_res.copy_to_device(res)
            descend_kernel[blocks, TPB](
                nb, self.d_res, self.d_bd, self.d_z, self.d_zf, self.d_stream, self.d_cover, self.d_erod,
                self.d_lake, self.d_level, self.d_track, self.d_P,
            )  # fmt: skip
            self.d_res.copy_to_host(res)
            self.d_bd.copy_to_host(bd)
            self.d_z.copy_to_host(m.z)
            add_rows(nb, bd, m.budget)
            k = 0
            while True:
                k = batch_floods(
                    k, nb, res, m.z, m.lake_of, m.level, m.area, m.mroot, m.broot, m.hkey, m.hcell, m.hleft,
                    m.hright, m.hrank, m.hs, m.stack, m.walk, m.budget, m.P, m.margin, m.lake_cap,
                )  # fmt: skip
                if k >= nb:
                    break
                m._rebuild()  # heap pool or lake table full: compact, then go on
            self.d_z.copy_to_device(m.z)
            self.d_lake.copy_to_device(m.lake_of)
            self.d_level.copy_to_device(m.level)
            status = res[:nb, R_STATUS]
            if not np.any(status == NEXT):
                break


__all__ = ["DeviceDroplets", "descend_kernel"]
