"""Shear-stress erosion of a voxel terrain by SPH water (Krištof, Beneš, Křivánek & Šťava 2009, as applied
to voxel grid points in seed 001 §4.1, listing 9; SPEC VX-6).

Krištof et al.'s erosion rate is ε = K_ε (τ − τ_c) with the shear stress of a pseudo-plastic fluid
τ = K θⁿ (K = 1, n = 0.5) and the shear rate θ = v_p/l, v_p the particle's velocity parallel to the
surface and l its distance to it. On a voxel grid (seed eq. 4.1) every grid point i with material
sums over the fluid particles j within the erosion radius R:

    dM_i/dt = −K_ε Σ_j max(0, K θ_ijⁿ − τ_c),
    θ_ij    = v_p,j / max(r'_ij, l_min),     r'_ij = |r_i − r_j| − min(l_j, l_min),
    v_p,j   = |v_j| − |v_j · r̂_ij|             (``parallel = "seed"``, listing 9, the default)
            = |v_j − (v_j·n_j) n_j|            (``parallel = "wall"``),

r_ij = r_i − r_j, l_j the particle's wall distance and n_j the unit wall normal at the particle, both
from the density field (:mod:`erosim.kernels.voxel`; l clamped at 0), and l_min = 0.4 h (h the
kernel support): the seed's "rectified" distance, which measures from the particle's own distance to
the wall and keeps θ finite for a particle touching it. A particle counts where r'_ij ≤ R (default
R = h).

v_p is the velocity component parallel to the surface (Krištof et al.'s θ = v_p/l). The seed's
listing approximates it with the direction r̂_ij from the particle to the grid point, which is the
wall normal only for a point straight below the particle: for a point up- or downstream of it,
r̂_ij leans along the flow and |v| − |v·r̂| falls below the speed along the wall (to 0 for r̂ ∥ v),
while across the flow it exceeds it (|v| for r̂ ⊥ v, even for a particle moving straight into the
wall). With ``parallel = "wall"`` the normal from the field's gradient is the surface's own, so a
particle's shear is the same for every grid point it reaches and zero for motion normal to the wall;
it is an option, not the default, because SPEC VX-6 fixes the seed's form, and on the overtopping
case at 2 cm it puts the first erosion higher on the downstream slope (docs/voxel.md).

M is the node's solid fraction, so its density changes by (d_solid − d_air)·dM; the area factor L_b²
of Krištof's dM_b/dt = −Σ L_b² ε is constant on a voxel
grid and folded into K_ε (units: solid fraction per second per unit of excess stress and particle).
Grid points below ``non_erodible_below`` = z_p (m) are never eroded (the non-erodible base of the
overtopping case), and neither are nodes already at d_air. The surface itself never drops below z_p: every
node keeps at least the density of the solid half-space z < z_p on the terrain's ramp,
d_p(z) = d_air + (d_solid − d_air)·clamp(½ + (z_p − z)/(2b), 0, 1) (:func:`erosim.terrain.voxel.ramp`), or
its density at the start if lower; the field then stays ≥ that half-space's field at every node, and
trilinear interpolation being monotone in the node values, its iso-surface stays at or above z = z_p
(a node just above the plinth can otherwise be emptied and pull the interpolated surface below it).
Erosion asked beyond that floor is counted as *unmet*.

Units of K_ε (``k_eps_units``): ``"fraction"`` — solid fraction per second per unit of excess stress and
particle; ``"byte"`` — the seed's density units, one 255th of the range per second (seed 001 stores the
field as bytes 0–255 and states M_b, and so K_ε, in them: its presets τ_c = 6, K_ε = 2 and τ_c = 1.2,
K_ε = 0.05 erode 255 times more slowly than the same numbers read as fractions, which is why the seed
needed its sub-byte "resolution per time step" accumulator at all).

Morphological acceleration (``morfac`` = f, Roelvink 2006): every evaluation's erosion is multiplied by f,
so t seconds of flow stand for f·t seconds of bed change (the *morphological* or physical time the run
reports); valid while the bed changes little over one flow time scale (f·K_ε small against the flow's
adjustment), the standard method of coastal morphodynamics (J.A. Roelvink, "Coastal morphodynamic
evolution techniques", Coastal Engineering 53, 2006).

Quantised transfer (the seed's "resolution per time step" fix): the erosion of each call,
K_ε Σ(…)·Δt, is added to a per-node accumulator P (density units, float64); whole steps of the
quantum q (default (d_solid − d_air)/255, the seed's byte) move to the field,

    Δd_i = −⌊P_i/q⌋·q  (at most d_i − d_air),      P_i ← P_i + Δd_i,

so small rates are not lost to rounding and no call changes the field by less than a quantum; at the
end of a run :meth:`ShearStressErosion.flush` applies what is still pending (the coupler calls it), so
what was computed is eroded by the end; the
total is kept: Σ accumulated = Σ transferred + Σ pending + Σ unmet, where *unmet* is the erosion
asked of a node that ran out of material (its pending part is dropped, and counted). The float32
field's rounding is absorbed: Δd is the exact difference of the new and old float32 values.

The model follows the eroder contract (:mod:`erosim.core.increments`): it never writes the terrain;
:meth:`ShearStressErosion.increments` returns ``Increment(dz=Δd, suspended=0, carried_off=V)`` with
Δd the density change per node and V the removed volume (m³), which close
``check_budget(inc, terrain.shape, terrain.volume_per_unit, …)`` (Σ Δd·Δ³/(d_solid − d_air) + V = 0):
the caller applies ``terrain.density += Δd`` and refreshes the wall (``VoxelWall.refresh``). The
accumulator is the model's checkpoint state. The particle loop is serial — a scatter onto nodes,
deterministic, run every ``every`` SPH steps (default 50; VX-6) — over the ≤ (2(R + l_min)/Δ + 1)³
nodes around each particle.

References: P. Krištof, B. Beneš, J. Křivánek, O. Šťava, "Hydraulic erosion using smoothed particle
hydrodynamics", Computer Graphics Forum 28(2), 2009; seed 001 (Ōtsubo & Kusama) §4, listing 9.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numba import njit

from erosim.core.config import Section, param
from erosim.core.increments import Increment
from erosim.kernels.voxel import node_span, wall_distance
from erosim.terrain.voxel import BAND_CELLS, ramp


class ShearStressParams(Section):
    """Parameters of :class:`ShearStressErosion` (see the module docstring)."""

    k_eps: float = param(1.0, ge=0, unit="1/s", doc="erosion strength K_ε: solid fraction per second per unit of "
                         "excess stress and particle (seed presets: partial 2, full 0.05)")  # fmt: skip
    tau_c: float = param(1.0, ge=0, unit="s^-n", doc="critical shear stress τ_c, in the units of K θⁿ (seed: 6 | 1.2)")
    k: float = param(1.0, gt=0, unit="1", doc="K of τ = K θⁿ (Krištof et al.: 1)")
    n: float = param(0.5, gt=0, le=2, unit="1", doc="exponent n of τ = K θⁿ (pseudo-plastic: 0.5)")
    radius: float = param(0.0, ge=0, unit="m", doc="erosion radius R around a grid point; 0 = the kernel support h")
    l_min: float = param(0.4, gt=0, le=1, unit="1", doc="l_min, and the cap of the distance correction, as a "
                         "fraction of h (seed: 0.4)")  # fmt: skip
    parallel: Literal["seed", "wall"] = param("seed", doc="v_p: the seed's |v| − |v·r̂| ('seed', SPEC VX-6), or the "
                                              "speed along the wall normal at the particle ('wall')")  # fmt: skip
    quantum: float = param(1.0 / 255.0, gt=0, le=1, unit="1", doc="transfer step as a fraction of the density range "
                           "(seed: one byte, 1/255)")  # fmt: skip
    non_erodible_below: float | None = param(None, unit="m", doc="grid points below this elevation are not eroded, "
                                             "and the surface is never lowered below it")  # fmt: skip
    k_eps_units: Literal["fraction", "byte"] = param("fraction", doc="what K_ε's density change is counted in: "
                                                     "solid fraction ('fraction') or the seed's bytes, 1/255 of the "
                                                     "range ('byte', seed 001's own units)")  # fmt: skip
    morfac: float = param(1.0, ge=1, unit="1", doc="morphological acceleration factor f (Roelvink 2006): each "
                          "evaluation's erosion times f; t seconds of flow stand for f·t of bed change")  # fmt: skip
    every: int = param(50, ge=1, unit="1", doc="SPH steps between erosion evaluations (VX-6: 50)")


@njit(cache=True, inline="always")
def excess_stress(v_par, dist, l_min, k, expo, tau_c):
    """The law of one particle: max(0, K θⁿ − τ_c) with the shear rate θ = v_par / max(dist, l_min)."""
    theta = max(v_par, 0.0) / max(dist, l_min)
    tau = k * theta**expo
    return tau - tau_c if tau > tau_c else 0.0


@njit(cache=True)
def excess_stresses(v_par, dist, l_min, k, expo, tau_c, out):
    """:func:`excess_stress` of every particle (arrays ``v_par``, ``dist``, ``tau_c``; the heightmap's scour
    in :mod:`erosim.coupling.splash_coupler` uses it with a τ_c per particle)."""
    for i in range(v_par.size):
        out[i] = excess_stress(v_par[i], dist[i], l_min, k, expo, tau_c[i])


@njit(cache=True)
def shear_sums(dens, ox, oy, oz, inv, d_air, pos, vel, wall_l, wall_n, seed_vp, n, radius, l_min, k, expo, tau_c,
               z_floor, scale, out):  # fmt: skip
    """out[node] += scale · Σ_j max(0, K θⁿ − τ_c) over the first ``n`` particles (module docstring); v_p is
    the speed along the wall (normal ``wall_n[j]``), or with ``seed_vp`` the seed's |v| − |v·r̂_ij|."""
    nz, ny, nx = dens.shape
    cell = 1.0 / inv
    for j in range(n):
        vx, vy, vz = vel[j, 0], vel[j, 1], vel[j, 2]
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        if speed == 0.0:
            continue
        vn = vx * wall_n[j, 0] + vy * wall_n[j, 1] + vz * wall_n[j, 2]
        v_wall = math.sqrt(max(speed * speed - vn * vn, 0.0))
        px, py, pz = pos[j, 0], pos[j, 1], pos[j, 2]
        lj = min(max(wall_l[j], 0.0), l_min)
        reach = radius + lj
        i0, i1 = node_span(px, reach, ox, inv, nx)
        j0, j1 = node_span(py, reach, oy, inv, ny)
        k0, k1 = node_span(pz, reach, oz, inv, nz)
        for kk in range(k0, k1 + 1):
            rz = oz + kk * cell - pz
            if oz + kk * cell < z_floor:
                continue
            for jj in range(j0, j1 + 1):
                ry = oy + jj * cell - py
                for ii in range(i0, i1 + 1):
                    if dens[kk, jj, ii] <= d_air:
                        continue
                    rx = ox + ii * cell - px
                    r = math.sqrt(rx * rx + ry * ry + rz * rz)
                    rc = r - lj
                    if rc > radius:
                        continue
                    if seed_vp:
                        vr = abs(vx * rx + vy * ry + vz * rz) / r if r > 0.0 else 0.0
                        vp = speed - vr
                    else:
                        vp = v_wall
                    e = excess_stress(vp, rc, l_min, k, expo, tau_c)
                    if e > 0.0:
                        out[kk, jj, ii] += scale * e


@njit(cache=True)
def quantised_transfer(dens, pending, quantum, d_air, dd):
    """Whole quanta of ``pending`` onto ``dd`` (flat views), at most down to d_air; returns the unmet
    erosion (density units) of nodes that ran out of material."""
    unmet = 0.0
    for i in range(dens.size):
        a = pending[i]
        if a < quantum:
            continue
        old = dens[i]
        q = math.floor(a / quantum) * quantum
        avail = old - d_air
        if q >= avail:
            new = np.float32(d_air)
            actual = np.float64(new) - np.float64(old)
            unmet += a + actual
            pending[i] = 0.0
        else:
            new = np.float32(old - q)
            actual = np.float64(new) - np.float64(old)
            pending[i] = a + actual
        dd[i] = actual
    return unmet


class ShearStressErosion:
    """Shear-stress erosion of ``terrain`` (a :class:`~erosim.terrain.voxel.VoxelTerrain`, read live) by fluid
    particles; ``support`` is the SPH kernel's support h (m). See the module docstring."""

    name = "shear_stress"
    needs = ("positions", "velocities")
    #: the field of the parameters that scales the erosion rate (named by the run's warnings)
    strength = "k_eps"

    def __init__(self, terrain, params: ShearStressParams | None = None, *, support: float):
        self.terrain = terrain
        self.params = p = params if params is not None else ShearStressParams()
        self.h = float(support)
        self.radius = p.radius if p.radius > 0 else self.h
        self.l_min = p.l_min * self.h
        lo, hi = terrain.value_range
        self.quantum = p.quantum * (hi - lo)
        self.z_floor = -math.inf if p.non_erodible_below is None else float(p.non_erodible_below)
        self.pending = np.zeros(terrain.shape, np.float64)
        self.floor = None if p.non_erodible_below is None else self.plinth_floor(terrain, self.z_floor)
        self.removed_total = 0.0  # m³ moved out of the field so far
        self.unmet_total = 0.0  # m³ of erosion asked of nodes with nothing left

    @staticmethod
    def plinth_floor(terrain, z_p: float) -> np.ndarray:
        """d_p per node (float32, the field's shape): the density of the solid half-space z < ``z_p`` on the
        terrain's ramp (module docstring), the least a node may be eroded to."""
        band = terrain.band if terrain.band is not None else BAND_CELLS * terrain.cell_size
        z = terrain.axes()[2]
        col = ramp(z_p - z, band, terrain.value_range)
        return np.ascontiguousarray(np.broadcast_to(col[:, None, None], terrain.shape))

    @property
    def rate_scale(self) -> float:
        """Density units per unit of K_ε·Σ(…)·Δt: the range, or a 255th of it (``k_eps_units = 'byte'``),
        times ``morfac``."""
        lo, hi = self.terrain.value_range
        per = (hi - lo) / 255.0 if self.params.k_eps_units == "byte" else hi - lo
        return per * self.params.morfac

    def _args(self):
        t = self.terrain
        ox, oy, oz = t.origin
        return t.density, ox, oy, oz, 1.0 / t.cell_size, t.value_range[0]

    def wall_distances(self, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(l, n) of every particle: the distance (m, positive in the fluid) and the unit normal into the
        fluid, from the terrain's density field (:mod:`erosim.kernels.voxel`)."""
        t = self.terrain
        pos = np.ascontiguousarray(pos, np.float64)
        l, nrm = np.empty(len(pos)), np.empty((len(pos), 3))
        wall_distance(t.density, *t.origin, 1.0 / t.cell_size, t.iso, pos, len(pos), l, nrm)
        return l, nrm

    def _wall(self, pos, vel, wall_l, normals):
        """(pos, vel, l, n) as contiguous float64 arrays, checked; l and n from the field unless the caller
        found them (once, for the positions given)."""
        pos = np.ascontiguousarray(pos, np.float64)
        vel = np.ascontiguousarray(vel, np.float64)
        if pos.shape != vel.shape or pos.ndim != 2 or pos.shape[1] != 3:
            raise ValueError("positions and velocities must be (n, 3)")
        if normals is None:
            field_l, nrm = self.wall_distances(pos)
            wall_l = field_l if wall_l is None else wall_l
        else:
            nrm = np.ascontiguousarray(normals, np.float64)
        wall_l = np.ascontiguousarray(wall_l, np.float64)
        if wall_l.shape != (len(pos),):
            raise ValueError("wall distances must be (n,)")
        return pos, vel, wall_l, nrm

    def _sums(self, pos, vel, wall_l, scale, out, normals=None):
        p = self.params
        pos, vel, wall_l, nrm = self._wall(pos, vel, wall_l, normals)
        shear_sums(*self._args(), pos, vel, wall_l, nrm, p.parallel == "seed", len(pos), self.radius, self.l_min,
                   p.k, p.n, p.tau_c, self.z_floor, scale, out)  # fmt: skip

    def _accumulate(self, pos, vel, dt: float, wall_l, normals) -> None:
        """Add the erosion of ``dt`` seconds to the accumulator (density units): K_ε Δt (d_solid − d_air) Σ(…)."""
        self._sums(pos, vel, wall_l, self.params.k_eps * dt * self.rate_scale, self.pending, normals)

    def threshold_speed(self) -> float:
        """The speed along the wall below which no particle erodes: l_min (τ_c/K)^(1/n) (m/s)."""
        p = self.params
        return self.l_min * (p.tau_c / p.k) ** (1.0 / p.n)

    def threshold_note(self) -> str:
        """Why no water has eroded: the least speed that would, and what to change (a clause of a warning)."""
        return (
            f"K θⁿ reaches erosion.tau_c = {self.params.tau_c:g} only where water runs faster than "
            f"{self.threshold_speed():.3g} m/s along the surface (θ = v/l, l at least l_min = {self.l_min:.3g} m at "
            "this spacing), and none has; run longer, or lower erosion.tau_c or sph.spacing if such flow should erode"
        )

    def rates(self, pos, vel, wall_l=None) -> np.ndarray:
        """Σ_j max(0, K θⁿ − τ_c) per grid point (the erosion rate is K_ε times it, in solid fraction per second)."""
        out = np.zeros(self.terrain.shape)
        self._sums(pos, vel, wall_l, 1.0, out)
        return out

    def transfer(self, pos, vel, dt: float, wall_l=None, normals=None) -> Increment:
        """Accumulate the erosion of ``dt`` seconds by particles at ``pos`` with ``vel`` (and wall distances
        ``wall_l``, with their ``normals`` or else from the field) and return the quantised transfer as
        an :class:`Increment` (density change per node, removed volume in ``carried_off``); the terrain is
        not changed."""
        lo = self.terrain.value_range[0]
        self._accumulate(pos, vel, float(dt), wall_l, normals)
        dd = np.zeros(self.terrain.shape)
        unmet = quantised_transfer(self.terrain.density.reshape(-1), self.pending.reshape(-1), self.quantum, lo,
                                   dd.reshape(-1))  # fmt: skip
        if self.floor is not None:
            unmet += self._keep_floor(dd)
        vpu = self.terrain.volume_per_unit
        removed = float(-dd.sum() * vpu)
        self.removed_total += removed
        self.unmet_total += float(unmet * vpu)
        return Increment(dz=dd, suspended=0.0, carried_off=removed)

    def _keep_floor(self, dd: np.ndarray) -> float:
        """Cut the changes ``dd`` (in place) that would take a node below min(d, d_p) (the plinth's floor);
        the erosion so refused, and the node's pending rest, become unmet (returned, density units)."""
        old = self.terrain.density
        keep = np.minimum(old, self.floor)
        new = old.astype(np.float64) + dd
        cut = new < keep
        if not cut.any():
            return 0.0
        actual = keep[cut].astype(np.float64) - old[cut].astype(np.float64)
        refused = float((actual - dd[cut] + self.pending[cut]).sum())
        self.pending[cut] = 0.0
        dd[cut] = actual
        return refused

    def flush(self, terrain) -> Increment:
        """The erosion still pending below a quantum, applied whole (at the end of a run, by the coupler), at
        most down to d_air and the plinth's floor (the rest becomes unmet); the accumulator is left empty."""
        if terrain is not self.terrain:
            raise ValueError("this eroder was built for another voxel terrain")
        old = self.terrain.density
        keep = np.full(old.shape, self.terrain.value_range[0], np.float64)
        if self.floor is not None:
            keep = np.maximum(keep, np.minimum(old, self.floor))
        take = np.clip(np.minimum(self.pending, old - keep), 0.0, None)
        dd = (old - take).astype(np.float32).astype(np.float64) - old
        dd[take == 0.0] = 0.0
        vpu = self.terrain.volume_per_unit
        self.unmet_total += float((self.pending + dd).sum() * vpu)
        self.pending[...] = 0.0
        removed = float(-dd.sum() * vpu)
        self.removed_total += removed
        return Increment(dz=dd, suspended=0.0, carried_off=removed)

    def increments(self, terrain, fluid, dt: float) -> Increment:
        """The coupler's contract (:mod:`erosim.coupling.coupler`): :meth:`transfer` for the fluid particles
        of ``fluid``, an :class:`~erosim.sph.solver.SPHSolver` (3-D), over ``terrain`` (the field this
        eroder was built for)."""
        if terrain is not self.terrain:
            raise ValueError("this eroder was built for another voxel terrain")
        return self.transfer(fluid.fluid_positions(), fluid.fluid_velocities(), dt)

    def pending_volume(self) -> float:
        """Erosion accumulated but not yet transferred (m³)."""
        return float(self.pending.sum() * self.terrain.volume_per_unit)

    def state_dict(self) -> dict:
        return {"pending": self.pending.copy(), "removed_total": self.removed_total, "unmet_total": self.unmet_total}

    def load_state_dict(self, state: dict) -> None:
        self.pending[...] = state["pending"]
        self.removed_total = float(state["removed_total"])
        self.unmet_total = float(state["unmet_total"])
