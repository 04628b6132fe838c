"""Suspended sediment over a voxel terrain: the ground an eroder removes rides on the fluid particles and
settles back (erosion.sediment = "suspended"; the stretch of issue 10, SPEC VX-6's removed material).

Krištof et al. (2009) let the water that erodes carry what it took and drop it where it slows; the
shear-stress eroder alone (:mod:`erosim.erosion.shear_stress_kristof2009`) carries everything off at
once. With this wrapper:

* **pickup** — a node's volume V_i transferred in a coupling is shared equally among the fluid particles
  within the erosion radius R of it (the ones its erosion summed over), as a registered per-particle
  field ``sediment`` (m³ of ground). A node none is near any more keeps its volume carried off. A
  particle holds at most c_max of its own volume (``max_concentration``, default 0.2, where clear-water
  flow turns hyperconcentrated, Costa 1988, and beyond which the fluid's clear-water dynamics would not
  hold): the share a full particle cannot take goes back to its node, so that erosion is limited by what
  the water can carry.
* **settling** — the deposition flux of suspended load at the bed is w_s·c (Garcia & Parker 1991: the
  settling velocity w_s times the concentration c at the bed). A particle within one support h of the
  ground holding s_j settles it through its height over the bed, l_j ≥ l_min (0.4 h, the eroder's):

      ds_j/dt = −w_s s_j / max(l_j, l_min)   →   s_j ← s_j e^{−w_s Δt / max(l_j, l_min)}  over a coupling,

  the exact relaxation, so the result does not depend on how often the coupler runs. What settles is
  bound for the air-side node nearest the particle's foot on the surface, r_j − (l_j − Δ/2) n_j (n the
  field's normal into the fluid), as much as fits below d_solid (the rest stays in the water); it is
  added to a per-node accumulator and moved into the float32 field as exact float32 differences, the
  rounding left in the accumulator (the eroder's way with its quantum). Particles farther than h from
  the ground keep their load.
* **bookkeeping** — particles leaving over open edges take their load (the solver's ``removed_sums``);
  the suspended volume is the particles' load plus the accumulator's; each coupling returns
  ``Increment(dz = erosion + deposition, suspended = its change, carried_off = unpicked + what left)``,
  which closes the budget exactly.

The clear-water fluid's dynamics do not change with its load (no density or viscosity of the mixture),
which the cap keeps within the clear-water range; the largest s_j over the particle's volume is
reported. The scatter loops are Numba kernels written here: the pairing of particles with voxel nodes
is this coupling's own.

References: P. Krištof, B. Beneš, J. Křivánek, O. Šťava, Computer Graphics Forum 28(2), 2009;
M. H. Garcia, G. Parker, J. Hydraul. Eng. 117(4), 1991 (entrainment and deposition of suspended sediment).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from erosim.core.increments import Increment
from erosim.kernels.voxel import node_span


@njit(cache=True)
def share_pickup(volume, ox, oy, oz, inv, pos, n, radius, room, count, sediment, returned):
    """Add each node's ``volume`` (m³, flat over the field's (nz, ny, nx) ``count`` array) to the sediment of
    the first ``n`` particles within ``radius`` of it, in equal shares, each particle taking at most its
    ``room`` (m³); what a full particle cannot take goes to ``returned`` (flat, m³) of its node. Returns the
    volume given out."""
    nz, ny, nx = count.shape
    cell = 1.0 / inv
    r2 = radius * radius
    count[...] = 0
    for sweep in range(2):  # count the particles at each node, then hand out the shares
        given = 0.0
        for j in range(n):
            px, py, pz = pos[j, 0], pos[j, 1], pos[j, 2]
            i0, i1 = node_span(px, radius, ox, inv, nx)
            j0, j1 = node_span(py, radius, oy, inv, ny)
            k0, k1 = node_span(pz, radius, oz, inv, nz)
            for kk in range(k0, k1 + 1):
                rz = oz + kk * cell - pz
                for jj in range(j0, j1 + 1):
                    ry = oy + jj * cell - py
                    for ii in range(i0, i1 + 1):
                        flat = (kk * ny + jj) * nx + ii
                        if volume[flat] <= 0.0:
                            continue
                        rx = ox + ii * cell - px
                        if rx * rx + ry * ry + rz * rz > r2:
                            continue
                        if sweep == 0:
                            count[kk, jj, ii] += 1
                        else:
                            share = volume[flat] / count[kk, jj, ii]
                            take = min(share, max(room[j], 0.0))
                            room[j] -= take
                            sediment[j] += take
                            returned[flat] += share - take
                            given += take
    return given


@njit(cache=True)
def settle(dens, ox, oy, oz, inv, hi, vpu, pos, wall_l, wall_n, n, reach, l_min, rate_dt, sediment, bound):
    """Move from each of the first ``n`` particles within ``reach`` of the ground the part of its sediment
    that settles in a coupling, 1 − e^{−rate_dt / max(l, l_min)}, to ``bound`` (density units) of the
    air-side node nearest its foot, as much as fits below ``hi`` with what is bound there already;
    returns the volume moved (m³)."""
    nz, ny, nx = dens.shape
    put = 0.0
    for j in range(n):
        s = sediment[j]
        lj = wall_l[j]
        if s <= 0.0 or lj > reach:
            continue
        back = max(lj, 0.0) - 0.5 / inv  # from the particle to half a cell above its foot
        ii = min(max(int(round((pos[j, 0] - back * wall_n[j, 0] - ox) * inv)), 0), nx - 1)
        jj = min(max(int(round((pos[j, 1] - back * wall_n[j, 1] - oy) * inv)), 0), ny - 1)
        kk = min(max(int(round((pos[j, 2] - back * wall_n[j, 2] - oz) * inv)), 0), nz - 1)
        want = s * (1.0 - math.exp(-rate_dt / max(lj, l_min)))
        room = (hi - dens[kk, jj, ii] - bound[kk, jj, ii]) * vpu
        dep = min(want, max(room, 0.0))
        if dep <= 0.0:
            continue
        sediment[j] = s - dep
        bound[kk, jj, ii] += dep / vpu
        put += dep
    return put


class SuspendedSediment:
    """``eroder`` (a :class:`~erosim.erosion.shear_stress_kristof2009.ShearStressErosion`) with its removed
    ground carried by the particles of ``solver`` and settling at ``settling_velocity`` (m/s); the
    coupler calls :meth:`increments` as it would the eroder's (module docstring)."""

    def __init__(self, eroder, solver, settling_velocity: float, max_concentration: float = 0.2):
        self.eroder = eroder
        self.solver = solver
        self.w_s = float(settling_velocity)
        self.c_max = float(max_concentration)
        self.returned_total = 0.0
        self.name = f"{eroder.name}+suspended"
        if "sediment" not in solver.state.specs:
            solver.state.register("sediment")
        self.count = np.zeros(eroder.terrain.shape, np.int64)
        self.bound = np.zeros(eroder.terrain.shape)  # settled sediment bound for each node (density units)
        self.suspended_last = 0.0
        self.left_last = 0.0
        self.picked_total = 0.0
        self.deposited_total = 0.0

    # the eroder's own figures, for the coupler and the report
    needs = property(lambda self: self.eroder.needs)
    params = property(lambda self: self.eroder.params)
    l_min = property(lambda self: self.eroder.l_min)
    strength = property(lambda self: self.eroder.strength)
    threshold_note = property(lambda self: self.eroder.threshold_note)
    terrain = property(lambda self: self.eroder.terrain)
    removed_total = property(lambda self: self.eroder.removed_total)
    unmet_total = property(lambda self: self.eroder.unmet_total)

    def pending_volume(self) -> float:
        return self.eroder.pending_volume()

    def held(self) -> float:
        """Sediment on the particles now (m³; with what is bound for the nodes, the suspended volume)."""
        st = self.solver.state
        return float(st.sediment[: st.n_fluid].sum())

    def left(self) -> float:
        """Sediment that left with water over open edges so far (m³)."""
        return float(self.solver.state.removed_sums.get("sediment", 0.0))

    def max_concentration(self) -> float:
        """The largest s_j / V_j (volume of ground per volume of water) of a particle now."""
        st, s = self.solver.state, self.solver
        if st.n_fluid == 0:
            return 0.0
        vol = s.m / np.asarray(st.rho[: st.n_fluid], np.float64)
        return float(np.max(st.sediment[: st.n_fluid] / vol))

    def increments(self, terrain, fluid, dt: float) -> Increment:
        """The eroder's transfer, picked up by the particles of ``fluid`` (the solver given at construction),
        and what settles in ``dt`` seconds; the particles are read in the state's own order, as
        ``sediment`` is kept, and their new loads travel in the increment."""
        if fluid is not self.solver or terrain is not self.terrain:
            raise ValueError("this eroder was built for another solver or terrain")
        t, st, solver = self.terrain, fluid.state, fluid
        n = st.n_fluid
        sediment = st.sediment[:n].copy()  # the particles' loads, written back by the coupler
        here = np.ascontiguousarray(st.pos[:n], np.float64)
        wl, wn = self.eroder.wall_distances(here)  # once, for the erosion and the settling
        inc = self.eroder.transfer(here, np.asarray(st.vel[:n], np.float64), dt, wl, wn)
        vpu = t.volume_per_unit
        dd = np.asarray(inc.dz, np.float64)
        ox, oy, oz = t.origin
        inv = 1.0 / t.cell_size
        volume = np.where(dd < 0, -dd * vpu, 0.0).reshape(-1)
        room = self.c_max * solver.m / np.asarray(st.rho[:n], np.float64) - sediment
        returned = np.zeros(t.shape)
        picked = share_pickup(volume, ox, oy, oz, inv, here, n, self.eroder.radius, room, self.count, sediment,
                              returned.reshape(-1))  # fmt: skip
        self.bound += returned / vpu  # what full water cannot take stays where it was
        self.returned_total += float(returned.sum())
        eroded = t.density + dd  # float32 values, exactly (the eroder's differences are)
        lo, hi = t.value_range
        settle(eroded, ox, oy, oz, inv, hi, vpu, here, wl, wn, n, solver.h, self.l_min, self.w_s * float(dt),
               sediment, self.bound)  # fmt: skip
        new = np.clip(eroded + self.bound, lo, hi).astype(np.float32).astype(np.float64)
        moved = np.where(self.bound > 0, new - eroded, 0.0)  # a rounding left below zero waits for more
        self.bound -= moved
        left = self.left()
        suspended = float(sediment.sum()) + float(self.bound.sum() * vpu)
        self.picked_total += picked
        self.deposited_total += float(moved.sum() * vpu)
        off = inc.carried_off - picked - float(returned.sum()) + left - self.left_last
        out = Increment(dz=dd + moved, suspended=suspended - self.suspended_last, carried_off=off,
                        particles={"sediment": sediment})
        self.suspended_last, self.left_last = suspended, left
        return out

    def state_dict(self) -> dict[str, Any]:
        out = dict(self.eroder.state_dict())
        out["suspended_bound"] = self.bound.copy()
        out["suspended_totals"] = np.array([self.suspended_last, self.left_last, self.picked_total,
                                            self.deposited_total, self.returned_total])  # fmt: skip
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.eroder.load_state_dict(state)
        if "suspended_totals" in state:
            self.bound[...] = np.asarray(state["suspended_bound"])
            (self.suspended_last, self.left_last, self.picked_total, self.deposited_total,
             self.returned_total) = (float(v) for v in np.asarray(state["suspended_totals"]))  # fmt: skip
