"""Particle-stream erosion on an NVIDIA GPU (``--device cuda``, numba-cuda): one thread per pool slot.

The device path of :class:`erosim.erosion.particle_stream_warszawski.ParticleStream`. A round-robin
sweep of the CPU (every slot emits if idle, then acts once) is two launches here:

1. ``emit``: one thread per emitter walks its pool slots in slot order and gives each idle slot the
   emitter's next particle number (:func:`~erosim.erosion.particle_stream_warszawski._emit`) — the
   CPU's assignment exactly, since it depends only on the emitter's count;
2. ``act``: one thread per busy slot makes its impact with the CPU's own functions (the collision
   and move ``_act``, the graded bed's ``_graded_depth``, the disc's rows and columns and each cell's
   lowering ``_cut``; compiled from their source, :mod:`erosim.kernels.device_source`), the lowering
   applied with atomic adds (strata: a cell cut below its stratum's floor takes the band of the
   height its own atomic add left).

So the slots of a sweep act at once instead of one after another: each impact reads the terrain
as the other slots' concurrent cuts leave it. Determinism on the device: the order of atomic adds
is the hardware's and float addition is not associative, so a GPU run is not repeatable bit for bit,
and two impacts that read a cell while both cut it may each clip to the graded floor from the value
they read (the cut can then go below that floor by at most the other's lowering). What holds: the
particle numbers, spawn points and random draws are the CPU's (counter-based); every lowering is
applied once and counted in its slot's total (``removed`` equals the terrain's loss to rounding); the
slots' totals are summed on the host in slot order. The whole state (heights, hardness, strata
floors, slots) stays on the device between calls; ``sync()`` brings it to the host arrays.
"""

from __future__ import annotations

import math

import numpy as np

from erosim.core import devices
from erosim.erosion import particle_stream_warszawski as W
from erosim.kernels import raster
from erosim.kernels.device_source import SIMULATOR, rebind

devices.numpy_aliases()
from numba import cuda  # noqa: E402  (after the numpy alias: erosim.core.devices)

TPB = 32 if SIMULATOR else 128
_R = rebind(raster)
_K = rebind(W, {"bilinear": _R.bilinear})
_emit = _K._emit
_key = _K._key
_act = _K._act
_graded = _K._graded_depth
_rows = _K._rows
_cols = _K._cols
_cut = _K._cut
_band = _K._band
EDEPTH, ERADIUS, ESLOPEN, ESLOPE0, ESTEPS = W.EDEPTH, W.ERADIUS, W.ESLOPEN, W.ESLOPE0, W.ESTEPS


@cuda.jit
def emit_kernel(table, st, serial, age, emitted, total, seed, pool):
    """Thread e: emitter e's idle slots get its next particles, in slot order (the CPU's sweep)."""
    e = cuda.grid(1)
    if e >= table.shape[0]:
        return
    for s in range(e * pool, (e + 1) * pool):
        if serial[s] < 0 and emitted[e] < total[e]:
            serial[s] = emitted[e]
            emitted[e] += 1
            age[s] = 0
            _emit(table, e, serial[s], seed, st, s)


@cuda.jit
def act_kernel(h, d, table, st, serial, age, acc, impacts, seed, pool, strata, edges, values, floor, has_strata):
    """Thread s: slot s's impact (module docstring); its lowering added to ``acc[s]``."""
    s = cuda.grid(1)
    if s >= st.shape[0] or serial[s] < 0:
        return
    e = s // pool
    key = _key(seed, e, serial[s])
    m = st[s, 4]
    px, py, ok = _act(h, d, table, e, st, s, key, age[s])
    if ok:
        lam = table[e, ERADIUS] * m
        depth = table[e, EDEPTH] * m
        zmin = -math.inf
        if table[e, ESLOPEN] > 0.0:
            depth, zmin = _graded(h, d, px, py, st[s, 2], lam, depth, table[e, ESLOPE0], table[e, ESLOPEN])
        ny, nx = h.shape
        j0, j1 = _rows(py, lam, ny)
        lam2 = lam * lam
        inv = 1.0 / lam2
        got = 0.0
        for j in range(j0, j1 + 1):
            dy = j - py
            i0, i1 = _cols(px, dy, lam2, nx)
            for i in range(i0, i1 + 1):
                dx = i - px
                g = 1.0 - (dx * dx + dy * dy) * inv
                if g > 0.0:
                    dh = _cut(h[j, i], d[j, i], g, depth, zmin)
                    if dh > 0.0:
                        hn = cuda.atomic.add(h, (j, i), -dh) - dh
                        got += dh
                        if has_strata and hn < floor[j, i]:
                            d[j, i], floor[j, i] = _band(
                                hn, strata[0], strata[1], i, j, strata[2], edges, values, strata[3], strata[4]
                            )
        acc[s] += got
        impacts[s] += 1
        age[s] += 1
    if not ok or age[s] >= table[e, ESTEPS]:
        serial[s] = -1


class DeviceStream:
    """The device copies of a stream's state and its sweeps there (module docstring)."""

    def __init__(self, stream) -> None:
        devices.require("cuda")
        self.s = stream
        has = stream.strata is not None
        self.has_strata = has
        n = stream.st.shape[0]
        self.d_h = cuda.to_device(stream.h)
        self.d_d = cuda.to_device(stream.d)
        self.d_table = cuda.to_device(stream.table)
        self.d_st = cuda.to_device(stream.st)
        self.d_serial = cuda.to_device(stream.serial)
        self.d_age = cuda.to_device(stream.age)
        self.d_emitted = cuda.to_device(stream.emitted)
        self.d_total = cuda.to_device(stream.total)
        self.acc = np.zeros(n)
        self.imp = np.zeros(n, np.int64)
        self.d_acc = cuda.to_device(self.acc)
        self.d_imp = cuda.to_device(self.imp)
        one = np.zeros(1)
        self.d_strata = cuda.to_device(stream._sp if has else np.zeros(5))
        self.d_edges = cuda.to_device(stream._se if has else one)
        self.d_values = cuda.to_device(stream._sv if has else one)
        self.d_floor = cuda.to_device(stream.floor if has else np.zeros((1, 1)))
        self.base_acc = float(stream.acc[0])  # what earlier (CPU or restored) sweeps removed

    def push(self) -> None:
        """Host → device (after a checkpoint was loaded into the host arrays)."""
        s = self.s
        for dev, host in ((self.d_h, s.h), (self.d_d, s.d), (self.d_st, s.st), (self.d_serial, s.serial),
                          (self.d_age, s.age), (self.d_emitted, s.emitted), (self.d_total, s.total)):  # fmt: skip
            dev.copy_to_device(host)
        if self.has_strata:
            self.d_floor.copy_to_device(s.floor)
        self.acc[:] = 0.0
        self.d_acc.copy_to_device(self.acc)
        self.base_acc = float(s.acc[0])

    def _rounds_left(self) -> int:
        """An upper bound on the sweeps until the stream runs dry (from the host's copies of the
        counters): per emitter, its unemitted particles in pool-sized waves of ``steps`` impacts
        each, after those in flight; particles that leave the map early only make it shorter."""
        s = self.s
        steps = s.table[:, ESTEPS].astype(np.int64)
        waves = -(-(s.total - s.emitted) // s.pool)
        return int(np.max(waves * steps + steps)) if steps.size else 0

    def advance(self, rounds: int) -> tuple[int, bool]:
        """Up to ``rounds`` sweeps, launched in runs no longer than the stream can still last (the
        counters come back between runs); returns (impacts done, whether the stream has run dry)."""
        s = self.s
        nslot = s.st.shape[0]
        ne = s.table.shape[0]
        seed = np.uint64(s.seed)
        before = int(self.imp.sum())
        left = int(rounds)
        dry = False
        while left > 0 and not dry:
            n = min(left, max(1, self._rounds_left()))
            for _ in range(n):
                emit_kernel[max(1, -(-ne // TPB)), TPB](
                    self.d_table, self.d_st, self.d_serial, self.d_age, self.d_emitted, self.d_total, seed, s.pool
                )
                act_kernel[max(1, -(-nslot // TPB)), TPB](
                    self.d_h, self.d_d, self.d_table, self.d_st, self.d_serial, self.d_age, self.d_acc, self.d_imp,
                    seed, s.pool, self.d_strata, self.d_edges, self.d_values, self.d_floor, self.has_strata,
                )  # fmt: skip
            left -= n
            self.d_serial.copy_to_host(s.serial)
            self.d_emitted.copy_to_host(s.emitted)
            dry = bool(np.all(s.serial < 0) and np.all(s.emitted >= s.total))
        self.d_imp.copy_to_host(self.imp)
        return int(self.imp.sum()) - before, dry

    def sync(self) -> None:
        """Device → host: heights, hardness, strata floors, slots and the removed total."""
        s = self.s
        for dev, host in ((self.d_h, s.h), (self.d_d, s.d), (self.d_st, s.st), (self.d_serial, s.serial),
                          (self.d_age, s.age), (self.d_emitted, s.emitted)):  # fmt: skip
            dev.copy_to_host(host)
        if self.has_strata:
            self.d_floor.copy_to_host(s.floor)
        self.d_acc.copy_to_host(self.acc)
        total = self.base_acc
        for v in self.acc:  # in slot order
            total += v
        s.acc[0] = total


__all__ = ["DeviceStream", "act_kernel", "emit_kernel"]
