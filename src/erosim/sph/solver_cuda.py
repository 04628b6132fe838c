"""The weakly compressible SPH step on a CUDA device (``device = "cuda"``), the same solver as the CPU's.

:class:`CudaSPHSolver` is :class:`~erosim.sph.solver.SPHSolver` with its step moved to the GPU: it is
built, checked and started on the host exactly like the CPU solver (the first neighbour lists and
force evaluation included), then its particle state is copied to the device, where it stays between
steps. Each step runs the CPU step's passes in the CPU's order (SPEC SPH-13): kick + drift + EOS →
box reflection → boundary particles' predictor → neighbour lists rebuilt (cell sort, particle
re-sort, Verlet lists; :mod:`erosim.sph.kernels_cuda`) when a particle moved half the skin →
boundary particles' continuity rate (or, with ``wall_pressure = "extrapolated"``, their pressure from
the fluid's, and no predictor or corrector) → the fused fluid pass → kick + corrector → boundary corrector.
Per step only four numbers come back to the host (the largest displacement, speed, acceleration
and density-diffusion rate K_i, for the rebuild test and the adaptive Δt, which keeps K_iΔt ≤ 0.5 as
on the CPU: :mod:`erosim.sph.diffusion_limit_molteni2009`; K_i comes out of the fused pass and its
maximum is reduced there, on the device); the particle fields are copied back only when an output,
a probe or a checkpoint reads them.

The kernels call the CPU's own per-particle functions, so the two devices solve the same equations
in the same order and differ by rounding only (the GPU contracts a·b + c into fused multiply-adds
where the CPU's compiler may not). Checkpoints are the CPU's (:meth:`state_dict`): a run checkpointed
on one device resumes on the other.

What the device path covers: ``kind = "sph"`` scenarios (box domains, box obstacles, reflecting and
boundary-particle walls with either wall pressure, 2-D and 3-D, every kernel, EOS, pressure form,
viscosity and integrator) with continuity density. Summation density, particle sources and sinks and
the terrain boundary models stay on the CPU; asking for them on the device is a one-sentence error.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from erosim.core import devices
from erosim.core.errors import ConfigError
from erosim.kernels import neighbours as nb
from erosim.sph import kernels_cuda as kc
from erosim.sph.boundaries.box import BoxWalls
from erosim.sph.boundaries.particles import BoundaryParticles
from erosim.sph.solver import SPHSolver

# small systems (the 2-D validations) fill few blocks; the step is still right, only the GPU idles
warnings.filterwarnings("ignore", message=r"Grid size \d+ will likely result in GPU under-utilization")
_PERMUTED = ("pos", "vel", "acc", "rho", "p", "drho", "rho_old", "ids", "pcell")  # re-sorted with the fluid
_MAX_CELLS_PER_PARTICLE = 64  # the dense device grid may have this many cells per particle (+ 2^20)


def _unsupported(what: str) -> ConfigError:
    return ConfigError(f"{what} is not available on device 'cuda'; run this scenario with --device cpu.")


class CudaSPHSolver(SPHSolver):
    """:class:`~erosim.sph.solver.SPHSolver` whose steps run on a CUDA GPU (see the module docstring)."""

    device = "cuda"

    def __init__(self, params, fluid_pos, **kwargs):
        if params.shifting != "off":
            raise _unsupported("Particle shifting (sph.shifting)")
        devices.require("cuda")
        if params.density == "summation":
            raise _unsupported("Summation density (sph.density = 'summation')")
        if kwargs.get("boundaries"):
            raise _unsupported("A terrain boundary model")
        super().__init__(params, fluid_pos, **kwargs)
        for bd in self.boundaries:
            if type(bd) not in (BoxWalls, BoundaryParticles):
                raise _unsupported(f"The boundary model '{bd.name}'")

        self._kc = kc
        prm = self.params
        self._fused = kc.fluid_pass(self.dim, prm.kernel, prm.pressure_form, prm.viscosity)
        self._brate = kc.boundary_density_rate(self.dim, prm.kernel)
        self._extrapolated = prm.wall_pressure == "extrapolated"
        self._bextrapolate = kc.boundary_extrapolate(self.dim, prm.kernel) if self._extrapolated else None
        self._upload()

    # ------------------------------------------------------------------ host ↔ device

    def _upload(self) -> None:
        """Copy the particle state to the device and build the device's lists from the positions of
        the last (host) rebuild, without re-sorting: the lists the host has now."""
        from numba import cuda

        st = self.state
        n, nf, d, f = st.n, st.n_fluid, self.dim, self.dtype
        self.d = {
            name: cuda.to_device(np.ascontiguousarray(getattr(st, name)))
            for name in ("pos", "vel", "rho", "p", "drho", "rho_old", "acc", "ref", "ids")
        }
        self.d["pcell"] = cuda.device_array(n, np.int64)  # cell of each particle at the last rebuild
        box = next(bd for bd in self.boundaries if isinstance(bd, BoxWalls))
        self._box = tuple(cuda.to_device(np.ascontiguousarray(a)) for a in (box._lo, box._hi, box._olo, box._ohi))
        self._spare = {name: cuda.device_array_like(self.d[name]) for name in _PERMUTED}
        self._have_boundary_particles = any(isinstance(bd, BoundaryParticles) for bd in self.boundaries)
        self._d_g = cuda.to_device(np.asarray(self.g, np.float64))
        self._d_disp2 = cuda.device_array(1, np.float64)
        self._d_maxima = cuda.device_array(3, np.float64)  # max |v|², |a|², K_i of a step
        self._d_start = cuda.device_array(n + 1, np.int64)
        self._d_mid = cuda.device_array(n, np.int64)
        self._d_nbr = cuda.device_array(max(1, self.nbr.size), np.int32)
        self._d_cell_index = cuda.device_array(n, np.int64)
        self._d_spos = cuda.device_array((n, d), f)
        self._d_count_f = cuda.device_array(n, np.int64)
        self._d_count_t = cuda.device_array(n, np.int64)
        self._dirty = False
        src = np.ascontiguousarray(st.pos.copy())
        src[:nf] = st.ref
        self._device_rebuild(reorder=False, source=cuda.to_device(src))

    def _sync(self) -> None:
        """Copy the device's particle fields into the host state (only after device steps)."""
        if not self._dirty:
            return
        st = self.state
        for name, arr in self.d.items():
            if name != "pcell":
                getattr(st, name)[...] = arr.copy_to_host()
        self._dirty = False

    # ------------------------------------------------------------------ neighbour lists on the device

    def _device_rebuild(self, reorder: bool, source=None) -> None:
        """Cell sort, optional fluid re-sort and Verlet lists from ``source`` (default: the positions)."""
        from numba import cuda

        kc, st = self._kc, self.state
        n, nf, d = st.n, st.n_fluid, self.dim
        src = self.d["pos"] if source is None else source
        if n == 0:
            return
        # ---- grid over the particles' bounding box (the CPU's origin and cell edge)
        lo = cuda.to_device(np.full(d, np.inf))
        hi = cuda.to_device(np.full(d, -np.inf))
        kc.bounds[kc.red_blocks(n), kc.TPB](src, n, lo, hi)
        mins = lo.copy_to_host().astype(self.dtype).reshape(1, d)
        maxs = hi.copy_to_host()
        origin = nb.grid_origin(mins, self.rc).astype(np.float64)
        inv_cell = 1.0 / self.rc
        top = np.floor((maxs - origin) * inv_cell).astype(np.int64) + 1
        dims = top + 2
        ncell = int(np.prod(dims))
        if ncell > _MAX_CELLS_PER_PARTICLE * n + (1 << 20):
            raise ConfigError(
                f"The particles spread over {ncell} neighbour-grid cells, too many for the device's dense grid "
                f"({n} particles); run this scenario with --device cpu or shrink the domain."
            )
        d_origin = cuda.to_device(origin)
        d_dims = cuda.to_device(dims.astype(np.int64))
        counts = cuda.device_array(ncell, np.int64)
        kc.zero[kc.blocks(ncell), kc.TPB](counts, ncell)
        kc.cell_ids[kc.blocks(n), kc.TPB](src, n, d_origin, inv_cell, d_dims, self.d["pcell"], counts)
        cell_start = cuda.device_array(ncell + 1, np.int64)
        kc.exclusive_scan(counts, ncell, cell_start)
        fill = counts  # the counts are spent: reuse them as the scatter's fill counters
        kc.zero[kc.blocks(ncell), kc.TPB](fill, ncell)
        kc.scatter[kc.blocks(n), kc.TPB](self.d["pcell"], n, cell_start, fill, self._d_cell_index)
        kc.sort_ranges[kc.blocks(ncell), kc.TPB](cell_start, ncell, self._d_cell_index)
        # ---- fluid re-sorted by cell (memory locality), as the CPU does at a rebuild
        if reorder and nf > 0:
            flags = cuda.device_array(n, np.int64)
            newidx = cuda.device_array(n + 1, np.int64)
            perm = cuda.device_array(nf, np.int64)
            kc.fluid_flags[kc.blocks(n), kc.TPB](self._d_cell_index, n, nf, flags)
            kc.exclusive_scan(flags, n, newidx)
            kc.fluid_permutation[kc.blocks(n), kc.TPB](self._d_cell_index, n, nf, newidx, perm)
            self._permute(perm)
            src = self.d["pos"]
        kc.gather_sorted[kc.blocks(n), kc.TPB](src, self._d_cell_index, n, self._d_spos)
        # ---- Verlet lists: fluid particles (fluid + boundary neighbours), then boundary particles
        r2 = self.rc * self.rc
        args = (self.d["pcell"], d_dims, cell_start, self._d_cell_index, r2)
        kc.count_lists[kc.blocks(nf), kc.TPB](src, self._d_spos, nf, 0, nf, *args, self._d_count_f, self._d_count_t)
        kc.exclusive_scan(self._d_count_t, nf, self._d_start)
        kc.fluid_offsets[kc.blocks(nf), kc.TPB](self._d_count_f, self._d_start, nf, self._d_mid)
        nbnd = n - nf
        bscan = cuda.device_array(nbnd + 1, np.int64)
        if nbnd > 0:
            kc.count_lists[kc.blocks(nbnd), kc.TPB](
                src, self._d_spos, nf, nf, n, *args, self._d_count_f, self._d_count_t
            )
            kc.exclusive_scan(self._d_count_f, nbnd, bscan)
            kc.boundary_offsets[kc.blocks(nbnd), kc.TPB](bscan, nf, n, self._d_start, self._d_mid)
        total = int(self._d_start[n : n + 1].copy_to_host()[0])
        if self._d_nbr.size < total:
            self._d_nbr = cuda.device_array(int(total * 1.2) + 64, np.int32)
        kc.fill_lists[kc.blocks(nf), kc.TPB](
            src, self._d_spos, nf, 0, nf, *args, self._d_start, self._d_mid, self._d_nbr
        )
        if nbnd > 0:
            kc.fill_lists[kc.blocks(nbnd), kc.TPB](
                src, self._d_spos, nf, nf, n, *args, self._d_start, self._d_mid, self._d_nbr
            )  # fmt: skip
            kc.sort_boundary_lists[kc.blocks(nbnd), kc.TPB](self._d_start, nf, n, self._d_nbr)
        kc.copy_rows[kc.blocks(nf), kc.TPB](src, self.d["ref"], nf)

    def _permute(self, perm) -> None:
        """Fluid rows of every field but ``ref`` in the new order (row k ← row perm[k]); each field is
        gathered into its spare buffer, which then becomes the field (the old one the spare)."""
        kc, st = self._kc, self.state
        for name, spare in self._spare.items():
            arr = self.d[name]
            rows = arr.shape[0]
            fn = kc.gather_rows if arr.ndim == 2 else kc.gather
            fn[kc.blocks(rows), kc.TPB](arr, spare, perm, st.n_fluid, rows)
            self.d[name], self._spare[name] = spare, arr

    # ------------------------------------------------------------------ the step

    def _step(self) -> float:
        prm, st, kc = self.params, self.state, self._kc
        nf, n = st.n_fluid, st.n
        dv = self.d
        dt = prm.dt if prm.dt > 0 else self.dt_limit()
        rho0, b, gamma, pmin = self.eos_args()
        k1, k2 = (0.5 * dt, 0.5 * dt) if self._leapfrog else (dt, 0.0)
        bf, bb = kc.blocks(nf), kc.blocks(n - nf)
        kc.kick_drift[bf, kc.TPB](
            dv["pos"], dv["vel"], dv["acc"], dv["rho"], dv["rho_old"], dv["drho"], dv["p"], nf, k1, dt, rho0, b, gamma,
            pmin, self.rho_min,
        )  # fmt: skip
        self._dirty = True
        lo, hi, olo, ohi = self._box
        kc.reflect[bf, kc.TPB](dv["pos"], dv["vel"], nf, lo, hi, olo, ohi)
        bnd = self._have_boundary_particles and n > nf
        dyn = bnd and not self._extrapolated  # dynamic boundary particles step their own density
        if dyn:
            kc.boundary_update_density[bb, kc.TPB](
                dv["rho"], dv["rho_old"], dv["drho"], dv["p"], self._d_start, nf, n, dt, rho0, b, gamma, pmin, True
            )  # fmt: skip
        # rebuild test: the largest displacement since the lists were built
        kc.zero[1, kc.TPB](self._d_disp2, 1)
        kc.max_displacement[kc.red_blocks(nf), kc.TPB](dv["pos"], dv["ref"], nf, self._d_disp2)
        disp2 = float(self._d_disp2.copy_to_host()[0])
        half = 0.5 * (self.rc - self.h)
        if disp2 >= half * half:
            self._device_rebuild(reorder=(self.rebuilds % prm.reorder_every) == 0)
            self.rebuilds += 1
        # evaluate: boundary continuity rate (or extrapolated pressure), then the fused fluid pass
        start, mid, nbr = self._d_start, self._d_mid, self._d_nbr
        if dyn:
            self._brate[bb, kc.TPB](dv["pos"], dv["vel"], start, mid, nbr, nf, n, self.m, self.h, dv["drho"])
        elif bnd:
            self._bextrapolate[bb, kc.TPB](
                dv["pos"], dv["rho"], dv["p"], start, mid, nbr, nf, n, self.h, self._d_g, rho0, b, gamma, pmin
            )  # fmt: skip
        g = self.g
        gz = g[2] if self.dim == 3 else 0.0
        kc.zero[1, kc.TPB](self._d_maxima, 3)
        self._fused[bf, kc.TPB](
            dv["pos"], dv["vel"], dv["rho"], dv["p"], start, mid, nbr, nf, self.m, self.h, self.kv, self.kvb,
            self.eps2, self.kdiff, self.eps2, self.kh, g[0], g[1], gz, dv["acc"], dv["drho"], self._d_maxima, 2,
        )  # fmt: skip
        kc.correct[kc.red_blocks(nf), kc.TPB](
            dv["vel"], dv["acc"], dv["rho"], dv["rho_old"], dv["drho"], dv["p"], nf, k2, dt, rho0, b, gamma, pmin,
            self.rho_min, self._d_maxima,
        )  # fmt: skip
        if dyn:
            kc.boundary_update_density[bb, kc.TPB](
                dv["rho"], dv["rho_old"], dv["drho"], dv["p"], start, nf, n, dt, rho0, b, gamma, pmin, False
            )  # fmt: skip
        v2, a2, kmax = self._d_maxima.copy_to_host()
        self.vmax = math.sqrt(float(v2))
        self.amax = math.sqrt(float(a2))
        self.kmax = float(kmax)  # the density diffusion's step bound reads it (SPHSolver._diffusion_limit)
        self._advance_clock(dt)
        return dt

    def step(self) -> float:
        """Advance one step on the device; returns the Δt used."""
        return self._step()

    # ------------------------------------------------------------------ outputs and checkpoints

    def _fluid(self, arr: np.ndarray) -> np.ndarray:
        self._sync()
        return super()._fluid(arr)

    def fluid_positions(self) -> np.ndarray:
        self._sync()
        return self._fluid(self.state.pos)

    def fluid_velocities(self) -> np.ndarray:
        self._sync()
        return self._fluid(self.state.vel)

    def fluid_density(self) -> np.ndarray:
        self._sync()
        return self._fluid(self.state.rho)

    def fluid_pressure(self) -> np.ndarray:
        self._sync()
        return self._fluid(self.state.p)

    def fluid_accelerations(self) -> np.ndarray:
        self._sync()
        return self._fluid(self.state.acc)

    def boundary_pressure(self) -> np.ndarray:
        self._sync()
        return super().boundary_pressure()

    def device_lists(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(start, mid, nbr) of the device's neighbour lists, copied to the host (the CPU's layout)."""
        n = self.state.n
        start = self._d_start.copy_to_host()
        return start, self._d_mid.copy_to_host(), self._d_nbr[: int(start[n])].copy_to_host()

    def neighbour_stats(self) -> dict:
        self._sync()
        self.start, self.mid, self.nbr = self.device_lists()
        return super().neighbour_stats()

    def state_dict(self) -> dict:
        self._sync()
        return super().state_dict()

    def load_state_dict(self, state: dict) -> None:
        """Restore a checkpoint of either device; the device's lists are those of the checkpointed run."""
        super().load_state_dict(state)
        self._upload()

    # ------------------------------------------------------------------ host-only operations

    def add_fluid(self, pos, vel=None, *, source: str, **fields) -> int:
        raise _unsupported("Adding fluid particles (a source)")

    def remove_fluid(self, mask, *, sink: str) -> int:
        raise _unsupported("Removing fluid particles (a sink)")

    def replace_boundary(self, positions) -> None:
        raise _unsupported("Replacing the boundary particles (a changing terrain)")
