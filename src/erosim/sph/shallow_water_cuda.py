"""The shallow-water SPH step on a CUDA device (``run.device = "cuda"`` of ``flood`` scenarios).

:class:`CudaShallowWaterSPH` is :class:`~erosim.sph.shallow_water_vacondio2012.ShallowWaterSPH` with
its steps on the GPU. It is built, and the reservoir settles, on the host exactly as on the CPU; at the
first step of the run the particles, the bed, the walls and the Manning map move to the device and
stay there. A step runs the CPU step's passes in its order (:mod:`erosim.sph.kernels_swe_cuda`): CFL
limit → half kick → drift → [particles that left by an open edge removed] → lists rebuilt when a
particle moved or grew past its skin → depth and H (Newton) → accelerations → half kick → contacts
held. Three numbers come back per step (the CFL scale, the count of particles that left, the count of
non-finite speeds) and one per list test; the hazard maxima are raised on the device every step
(the SPH depth at the cell centres gathered by one thread per cell, ``grid_maxima``: the CPU's sums
in another order, equal to rounding).
Fields come back only when an output, a gauge, a map or a checkpoint reads them; removing the
particles that left (a few steps of a run) is done on the host, which then sends the state back.

Both devices run the same per-particle functions over the same lists; they differ by rounding only
(the GPU contracts a·b + c into fused multiply-adds). Checkpoints are the CPU's: either device resumes
the other's. Particle splitting (``flood.split``): the daughters' supports relax on the device every
step; at the steps that rebuild the lists the device counts the particles the CPU's test would split
(``split_count``) and, when there are any, the host splits them on its copies of the fields and sends
the state back (a split is rare: one generation, each particle once).
"""

from __future__ import annotations

import math

import numpy as np

from erosim.core import devices
from erosim.core.errors import InstabilityError
from erosim.sph import kernels_cuda, kernels_swe_cuda
from erosim.sph import kernels_swe as K
from erosim.sph.shallow_water_vacondio2012 import _HEXAGON, ShallowWaterSPH

_FIELDS = ("pos", "vel", "hsup", "depth", "omega", "acc", "k2")  # what the device changes
_CONSTANT = ("vol",)  # per particle, changed only on the host (removal, splitting)
_MAXIMA = ("max_depth", "max_speed", "max_dv", "arrival")  # the hazard maps' arrays


class _OnTheHost:
    """A particle field of :class:`CudaShallowWaterSPH` as the host sees it: reading it first brings the
    device's copy back when the device is ahead; assigning it marks the device's copy out of date."""

    def __set_name__(self, owner, name):
        self.key = "_host_" + name

    def __get__(self, obj, objtype=None):
        if obj is None:
            return self
        obj._pull()
        return obj.__dict__[self.key]

    def __set__(self, obj, value):
        obj.__dict__[self.key] = value
        obj._device_stale = True


class CudaShallowWaterSPH(ShallowWaterSPH):
    """:class:`ShallowWaterSPH` whose run steps are on a CUDA GPU (see the module docstring)."""

    device = "cuda"
    pos = _OnTheHost()
    vel = _OnTheHost()
    hsup = _OnTheHost()
    depth = _OnTheHost()
    omega = _OnTheHost()
    acc = _OnTheHost()
    k2 = _OnTheHost()

    def __init__(self, *args, **kwargs):
        devices.require("cuda")
        self._on_host = True  # the host steps until the run starts (building, settling)
        self._device_stale = True  # the host's arrays are newer than the device's
        self._host_stale = False  # the device's arrays are newer than the host's
        self._maps: dict[int, tuple] = {}
        self._pairs = 0
        self._d_lists = False
        super().__init__(*args, **kwargs)
        self._on_host = False
        self._kc, self._ks = kernels_cuda, kernels_swe_cuda

    # ------------------------------------------------------------------ host ↔ device

    def _pull(self) -> None:
        """Bring the device's fields to the host arrays (when the device is ahead)."""
        if self._host_stale:
            self._host_stale = False
            for k in _FIELDS:
                self.__dict__["_host_" + k] = self._d[k].copy_to_host()

    def _push(self) -> None:
        """Send the host's state to the device (when the host is ahead), lists included."""
        if not self._device_stale:
            return
        from numba import cuda

        self._d = {k: cuda.to_device(np.ascontiguousarray(getattr(self, k))) for k in _FIELDS + _CONSTANT}
        n = self.n
        self._d["bed"] = cuda.to_device(self.bed)
        self._d["manning"] = cuda.to_device(self.manning)
        self._d["wall"] = cuda.to_device(self.wall)
        self._d["wall_dist"] = cuda.to_device(self.wall_dist)
        self._d["hexagon"] = cuda.to_device(_HEXAGON)
        self._d["out"] = cuda.device_array(n, np.bool_)
        self._d["blocked"] = cuda.device_array(n, np.int64)
        self._d["prev"] = cuda.device_array(n, np.float64)
        self._d["counts"] = cuda.to_device(np.zeros(2, np.int64))
        self._d["scalar"] = cuda.device_array(1, np.float64)
        self._d["pcell"] = cuda.device_array(n, np.int64)
        self._d["order"] = cuda.device_array(n, np.int64)
        self._d["count"] = cuda.device_array(n, np.int64)
        self._d["bounds"] = cuda.device_array((2, 2), np.float64)
        self._d["cells"] = cuda.device_array(0, np.int64)  # the grid's counts and starts, grown as needed
        self._d["cell_start"] = cuda.device_array(1, np.int64)
        self._d["bin_max"] = cuda.device_array(0, np.float64)  # each bin's largest search radius
        self._d["map_pcell"] = cuda.device_array(n, np.int64)  # the hazard maps' bins (update_maxima)
        self._d["map_order"] = cuda.device_array(n, np.int64)
        self._d["eta"] = cuda.device_array(n, np.float64)
        self._d["map_cells"] = cuda.device_array(0, np.int64)
        self._d["map_cell_start"] = cuda.device_array(1, np.int64)
        if self._built_at is not None and len(self._built_at) == n:
            self._d["at"] = cuda.to_device(self._built_at)
            self._d["search"] = cuda.to_device(self._search)
            self._d["start"] = cuda.to_device(self._start)
            self._d["nbr"] = cuda.to_device(self._nbr)
            self._d_lists = True
            self._pairs = int(self._start[-1])
        else:
            self._d["at"] = cuda.device_array((n, 2), np.float64)
            self._d["search"] = cuda.device_array(n, np.float64)
            self._d["start"] = cuda.device_array(n + 1, np.int64)
            self._d["nbr"] = cuda.device_array(max(1, 40 * n), np.int64)
            self._d_lists = False
        self._device_stale = False

    def _host_changed(self) -> None:
        """The host's arrays were changed (or replaced): the device copies are out of date."""
        self._device_stale = True
        self._host_stale = False

    # ------------------------------------------------------------------ the step

    def step(self, dt: float | None = None) -> float:
        if self._on_host:
            return super().step(dt)
        prm, ks = self.params, self._ks
        self._push()
        n = self.n
        d = self._d
        if dt is None:
            dt = prm.courant * self._cfl_scale()
        if not math.isfinite(dt) or dt <= 0:
            raise InstabilityError(
                f"The shallow-water step became {dt!r} s at t = {self.t:.3f} s; lower flood.courant."
            )
        bl = self._kc.blocks(n)
        ks.kick[bl, self._kc.TPB](d["vel"], d["acc"], d["depth"], d["manning"], self.inv_cell, d["pos"], n,
                                  0.5 * dt, prm.g, 1e-6)  # fmt: skip
        self._kc.zero[1, self._kc.TPB](d["counts"], 2)
        ks.drift[bl, self._kc.TPB](
            d["pos"], d["vel"], n, dt, self.inv_cell, d["wall"], *self.open, d["out"], d["blocked"], d["counts"]
        )  # fmt: skip
        self._host_stale = True
        if int(d["counts"][0:1].copy_to_host()[0]):
            self._remove_leavers()
            n = self.n
            d = self._d
            bl = self._kc.blocks(n)
        if prm.split and n:
            ks.relax_supports[bl, self._kc.TPB](d["k2"], d["hsup"], d["depth"], d["vel"], n, prm.support**2,
                                                prm.split_relax, prm.g, dt)  # fmt: skip
            if not self._lists_hold() and self._split_on_host():  # at the steps that rebuild the lists
                n = self.n
                d = self._d
                bl = self._kc.blocks(n)
        if n:
            self._evaluate()
            ks.kick[bl, self._kc.TPB](d["vel"], d["acc"], d["depth"], d["manning"], self.inv_cell, d["pos"], n,
                                      0.5 * dt, prm.g, 1e-6)  # fmt: skip
            ks.hold_contacts[bl, self._kc.TPB](d["vel"], n, d["blocked"], d["counts"])
        self.t += dt
        self.steps += 1
        self.last_dt = dt
        if n and int(d["counts"][1:2].copy_to_host()[0]):
            raise InstabilityError(f"Speeds became infinite at t = {self.t:.3f} s; lower flood.courant.")
        return dt

    def _cfl_scale(self) -> float:
        n, kc = self.n, self._kc
        if n == 0:
            return math.inf
        self._d["scalar"].copy_to_device(np.array([-math.inf]))
        self._ks.cfl_limit[kc.red_blocks(n), kc.TPB](
            self._d["vel"], self._d["depth"], self._d["hsup"], n, self.params.g, self._d["scalar"]
        )  # fmt: skip
        return -float(self._d["scalar"].copy_to_host()[0])

    def _remove_leavers(self) -> None:
        """Particles beyond an open edge leave (on the host: a few steps of a run); their water is counted."""
        self._pull()
        out = self._d["out"].copy_to_host()
        blocked = self._d["blocked"].copy_to_host()
        self.volume_out += float(self.vol[out].sum())
        self._keep(~out)
        self._push()
        self._d["blocked"].copy_to_device(np.ascontiguousarray(blocked[~out]))

    def _split_on_host(self) -> int:
        """The CPU's split of the thinned particles, on the host's copies, when the device counts any
        (:func:`kernels_swe_cuda.split_count`, the CPU's own test): the fields come back, the split
        appends the daughters, and the state goes out again with the daughters' contacts free."""
        n, kc, d = self.n, self._kc, self._d
        kc.zero[1, kc.TPB](d["counts"][0:1], 1)
        # the CPU's thresholds, with the device's own copies of the hexagon and the wall map
        spacing_lim, vol_lim, speed2, depth_lim, radius, _, inv_cell, _ = self._split_args()
        self._ks.split_count[kc.blocks(n), kc.TPB](
            d["pos"], d["vol"], d["depth"], d["vel"], n, spacing_lim, vol_lim, speed2, depth_lim, radius, d["hexagon"],
            inv_cell, d["wall"], d["counts"],
        )  # fmt: skip
        m = int(d["counts"][0:1].copy_to_host()[0])
        if m == 0 or n + 6 * m > self.params.max_particles:
            return 0
        blocked = d["blocked"].copy_to_host()
        split = self._split()
        if split:
            self._push()
            self._d["blocked"].copy_to_device(np.concatenate([blocked, np.zeros(6 * split, np.int64)]))
        return split

    def _lists_hold(self) -> bool:
        if self._on_host:
            return super()._lists_hold()
        if not self._d_lists:
            return False
        n, kc, ks, d = self.n, self._kc, self._ks, self._d
        d["scalar"].copy_to_device(np.zeros(1))
        ks.max_moved[kc.red_blocks(n), kc.TPB](d["pos"], d["at"], n, d["scalar"])
        kc.zero[1, kc.TPB](d["counts"][0:1], 1)
        ks.lists_broken[kc.blocks(n), kc.TPB](d["pos"], d["at"], d["hsup"], d["search"], n, d["scalar"], d["counts"])
        return int(d["counts"][0:1].copy_to_host()[0]) == 0

    def _neighbours(self, margin: float) -> None:
        if self._on_host:
            return super()._neighbours(margin)
        n, kc, ks, d = self.n, self._kc, self._ks, self._d
        bl, tpb = kc.blocks(n), kc.TPB
        ks.scaled_copy[bl, tpb](d["hsup"], d["search"], margin, n)
        kc.copy_rows[bl, tpb](d["pos"], d["at"], n)
        # the CPU's grid: edge max s_i / LIST_BINS, origin at the minimum corner less one edge
        from numba import cuda

        d["bounds"].copy_to_device(np.array([[np.inf, np.inf], [-np.inf, -np.inf]]))
        kc.bounds[kc.red_blocks(n), tpb](d["at"], n, d["bounds"][0], d["bounds"][1])
        d["scalar"].copy_to_device(np.zeros(1))
        ks.max1[kc.red_blocks(n), tpb](d["search"], n, d["scalar"])
        lo, hi = d["bounds"].copy_to_host()
        cell = float(d["scalar"].copy_to_host()[0]) / K.LIST_BINS
        x0, y0 = lo[0] - cell, lo[1] - cell
        ncx = int((hi[0] - x0) / cell) + 2
        ncy = int((hi[1] - y0) / cell) + 2
        ncell = ncx * ncy
        if d["cells"].size < ncell:  # kept between rebuilds, grown by a quarter when outgrown
            d["cells"] = cuda.device_array(ncell + ncell // 4, np.int64)
            d["cell_start"] = cuda.device_array(ncell + ncell // 4 + 1, np.int64)
            d["bin_max"] = cuda.device_array(ncell + ncell // 4, np.float64)
        counts, cell_start = d["cells"][:ncell], d["cell_start"][: ncell + 1]
        bin_max = d["bin_max"][:ncell]
        kc.zero[kc.blocks(ncell), tpb](counts, ncell)
        ks.cell_ids[bl, tpb](d["at"], n, x0, y0, cell, ncx, ncy, d["pcell"], counts)
        kc.exclusive_scan(counts, ncell, cell_start)
        kc.zero[kc.blocks(ncell), tpb](counts, ncell)
        kc.scatter[bl, tpb](d["pcell"], n, cell_start, counts, d["order"])
        kc.sort_ranges[kc.blocks(ncell), tpb](cell_start, ncell, d["order"])
        kc.zero[kc.blocks(ncell), tpb](bin_max, ncell)
        ks.bin_search_max[bl, tpb](d["pcell"], d["search"], n, bin_max)
        grid = (x0, y0, cell, ncx, ncy, cell_start, d["order"], bin_max, K.LIST_BINS)
        ks.pairs[bl, tpb](d["at"], d["search"], n, *grid, d["count"], d["start"], d["nbr"], False)
        kc.exclusive_scan(d["count"], n, d["start"])
        total = int(d["start"][n : n + 1].copy_to_host()[0])
        if d["nbr"].size < total:
            d["nbr"] = cuda.device_array(int(total * 1.2) + 64, np.int64)
        ks.pairs[bl, tpb](d["at"], d["search"], n, *grid, d["count"], d["start"], d["nbr"], True)
        self._d_lists = True
        self._pairs = total
        self.rebuilds += 1

    def _evaluate(self) -> None:
        if self._on_host:
            return super()._evaluate()
        prm, n, kc, ks, d = self.params, self.n, self._kc, self._ks, self._d
        bl, tpb = kc.blocks(n), kc.TPB
        margin = 1.5
        for _ in range(4):
            if not self._lists_hold():
                self._neighbours(margin)
            ks.copy1[bl, tpb](d["hsup"], d["prev"], n)
            ks.depth_and_support[bl, tpb](
                d["pos"], d["vol"], d["hsup"], n, d["start"], d["nbr"], d["k2"], self.h_min, self.h_cap,
                prm.tolerance, 40, d["depth"], d["omega"],
            )  # fmt: skip
            if self._lists_hold():
                break
            ks.raise_to[bl, tpb](d["hsup"], d["prev"], n)
            self._d_lists = False
            margin *= 1.2
        ks.accelerations[bl, tpb](
            d["pos"], d["vel"], d["vol"], d["hsup"], d["depth"], d["omega"], n, d["start"], d["nbr"], d["bed"],
            self.inv_cell, prm.g, prm.viscosity, d["acc"],
        )  # fmt: skip
        self._host_stale = True

    # ------------------------------------------------------------------ the hazard maxima, on the device

    def update_maxima(self, maps, wet: float) -> None:
        if self._on_host:
            return super().update_maxima(maps, wet)
        from numba import cuda

        self._push()
        host = [getattr(maps, k) for k in _MAXIMA]
        held = self._maps.get(id(maps))
        if held is None or any(a is not b for a, b in zip(held[0], host, strict=True)):  # new maps, or reloaded
            held = self._maps[id(maps)] = (host, [cuda.to_device(a) for a in host])
        n, kc, ks, d = self.n, self._kc, self._ks, self._d
        if not n:
            return
        bl, tpb = kc.blocks(n), kc.TPB
        d["bounds"].copy_to_device(np.array([[np.inf, np.inf], [-np.inf, -np.inf]]))
        kc.bounds[kc.red_blocks(n), tpb](d["pos"], n, d["bounds"][0], d["bounds"][1])
        d["scalar"].copy_to_device(np.zeros(1))
        ks.max1[kc.red_blocks(n), tpb](d["hsup"], n, d["scalar"])
        (xmin, ymin), (xmax, ymax) = d["bounds"].copy_to_host()
        x0, y0, reach, ncx, ncy, r_lo, c_lo, nr, nc = self._maxima_window(
            xmin, ymin, xmax, ymax, d["scalar"].copy_to_host()[0]
        )
        ncell = ncx * ncy
        if d["map_cells"].size < ncell:  # kept between calls, grown by a quarter when outgrown
            d["map_cells"] = cuda.device_array(ncell + ncell // 4, np.int64)
            d["map_cell_start"] = cuda.device_array(ncell + ncell // 4 + 1, np.int64)
        counts, cell_start = d["map_cells"][:ncell], d["map_cell_start"][: ncell + 1]
        kc.zero[kc.blocks(ncell), tpb](counts, ncell)
        ks.cell_ids[bl, tpb](d["pos"], n, x0, y0, reach, ncx, ncy, d["map_pcell"], counts)
        kc.exclusive_scan(counts, ncell, cell_start)
        kc.zero[kc.blocks(ncell), tpb](counts, ncell)
        kc.scatter[bl, tpb](d["map_pcell"], n, cell_start, counts, d["map_order"])
        kc.sort_ranges[kc.blocks(ncell), tpb](cell_start, ncell, d["map_order"])
        ks.surfaces[bl, tpb](d["pos"], d["depth"], d["bed"], n, self.inv_cell, d["eta"])
        if nr * nc:
            ks.grid_maxima[kc.blocks(nr * nc), tpb](
                d["pos"], d["vel"], d["vol"], d["hsup"], d["depth"], d["eta"], d["bed"], self.cell, x0, y0, reach,
                ncx, ncy, cell_start, d["map_order"], r_lo, c_lo, nr, nc, self.t, wet, *held[1], d["wall"],
                d["wall_dist"], K.MARGIN_SPEED[self.params.margin_speed],
            )  # fmt: skip

    def sync_maxima(self, maps) -> None:
        held = self._maps.get(id(maps))
        if held is not None:
            for host, dev in zip(*held, strict=True):
                dev.copy_to_host(host)

    # ------------------------------------------------------------------ host operations and checkpoints
    # (outputs need no override: reading pos, vel, depth, … brings the device's fields back)

    @property
    def neighbour_pairs(self) -> int:
        if self._on_host or not self.n:
            return super().neighbour_pairs
        return self._pairs

    def _on_the_host(self, method, *args):
        """Run a host operation of the CPU solver (settling, a new terrain) on the host's arrays."""
        self._pull()
        self._on_host = True
        try:
            return method(*args)
        finally:
            self._on_host = False
            self._host_changed()

    def settle(self, max_steps: int = 600, speed: float = 0.05) -> int:
        """The CPU's settling, on the host (FIRE reads every particle's speed and force each step)."""
        return self._on_the_host(super().settle, max_steps, speed)

    def set_terrain(self, bed, wall) -> None:
        self._on_the_host(super().set_terrain, bed, wall)

    def state_dict(self) -> dict:
        """The CPU's checkpoint, with the positions and radii the device's lists were built from."""
        out = super().state_dict()
        if not self._on_host and self._d_lists:  # the device's lists, rebuilt alike on resume
            out["lists_at"] = self._d["at"].copy_to_host()
            out["lists_search"] = self._d["search"].copy_to_host()
        return out

    def load_state_dict(self, state: dict) -> None:
        self._host_stale = False  # the state replaces whatever the device held
        super().load_state_dict(state)
        self._host_changed()
