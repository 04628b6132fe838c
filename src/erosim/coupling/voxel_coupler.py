"""The coupler of a voxel terrain: the fluid's particles → an eroder's density increments → the field,
every N steps (SPEC VX-6; the house coupler's contract, :mod:`erosim.coupling.coupler`, on a 3-D field).

Each time its schedule fires (an ``IterationInterval`` of ``erosion.every`` steps) the coupler

1. hands the eroder the solver and the simulated time Δt since the last call:
   ``eroder.step(solver, dt) -> Increment`` (Δd per node of the density field; what it removed is
   carried off or, with the load on the particles, suspended; the eroder never writes the field);
2. checks the increment's budget (:func:`~erosim.core.increments.check_budget` with the volume of one
   density unit of one node, Δ³/(d_solid − d_air), in place of a cell's area): Σ Δd·Δ³/(d_s − d_a) + C = 0;
3. applies it once, ``density += Δd`` (Δd is the exact float64 difference of float32 values, so the
   field takes exactly the eroder's new values);
4. refreshes every boundary of the solver (``refresh(solver, terrain=density)``: the wall's distance is
   read from the changed field and particles left inside the solid are pushed out), and adds the
   terms to the run's budget.

Two onsets are recorded. The *first transfer* is the time and place of the first transfer that lowers
a solid node (density above the iso level; the node it lowers most): the ramp's nodes on the air side
hold material too and are eroded by the same law, but their loss only steepens the ramp. One quantum
(1/255 of a node) may come from a single particle's passing excess, which no observer would call the
start of a breach. The *onset* (``first_erosion`` of a run's report) is where the surface has first
retreated past a grid point: the first coupling after which a node that was solid at the start (above
the iso level) is at or below it — of several, the one that lost most. It is a local change of the
surface by up to one cell, the least the field resolves as a moved surface at a place, and the
counterpart of a laboratory's first visible scour; the overtopping validation judges it
(:mod:`erosim.validation.overtopping`).

Before ``start`` (s) the coupler does nothing: a fluid laid on a lattice settles in its first moments
(particles slide into the corners of the terrain at speeds no still reservoir has), and that motion
would otherwise scour the field.

Its checkpoint state is the density field itself (float32, bit for bit), the eroder's accumulator,
the budget and the first erosion, so a resumed run continues exactly.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from erosim.core.increments import check_budget
from erosim.sph.boundaries.distance_wall import walls_follow

_TERMS = ("eroded", "deposited", "suspended", "carried_off")


def _node(terrain, flat: int) -> tuple[float, float, float]:
    """(x, y, z) of the field's node with C-order index ``flat``."""
    kz, ky, kx = np.unravel_index(flat, terrain.shape)
    ox, oy, oz = terrain.origin
    c = terrain.cell_size
    return ox + c * kx, oy + c * ky, oz + c * kz


class VoxelCoupler:
    """Couple ``solver`` to ``terrain`` (a :class:`~erosim.terrain.voxel.VoxelTerrain`) through ``eroder``."""

    def __init__(self, schedule, solver, eroder, terrain, *, start: float = 0.0, name: str = "coupler"):
        self.schedule = schedule
        self.name = name
        self.solver = solver
        self.eroder = eroder
        self.terrain = terrain
        self.initial = terrain.density.copy()
        self.totals = dict.fromkeys(_TERMS, 0.0)
        self.calls = 0
        self.last_t = float(solver.t)
        self.first = np.full(3, np.nan)  # (t, x, z) of the first transfer
        self.first_y = np.nan
        self.onset = np.full(4, np.nan)  # (t, x, y, z) of the first solid node the surface passed
        self._solid0 = self.initial > terrain.iso
        self.wall = 0.0
        self.start = float(start)  # no erosion before this time (s): the fluid settles first

    def __call__(self, sim=None) -> None:
        t0 = time.perf_counter()
        try:
            self._couple()
        finally:
            self.wall += time.perf_counter() - t0

    def _couple(self) -> None:
        s, t = self.solver, self.terrain
        dt = float(s.t) - self.last_t
        self.last_t = float(s.t)
        if self.eroder is None or dt <= 0 or float(s.t) <= self.start:
            return
        inc = self.eroder.step(s, dt)
        terms = check_budget(inc, t.shape, t.volume_per_unit, f"Erosion model '{self.eroder.name}'")
        for k in _TERMS:
            self.totals[k] += terms[k]
        self.calls += 1
        dd = np.asarray(inc.dz)
        changed = dd != 0
        if not changed.any():
            return
        if np.isnan(self.first[0]):
            lowered = np.where((dd < 0) & (t.density > t.iso), dd, 0.0)  # solid nodes (above the iso level) only
            if lowered.any():
                x, y, z = _node(t, int(np.argmin(lowered)))  # lowered most (first in C order)
                self.first[:] = (float(s.t), x, z)
                self.first_y = y
        with walls_follow(s):
            t.density += dd  # float32 += exact float64 differences of float32 values
            for b in s.boundaries:
                b.refresh(s, terrain=t.density, changed=changed)
        if np.isnan(self.onset[0]):
            passed = self._solid0 & (t.density <= t.iso)
            if passed.any():
                loss = np.where(passed, self.initial - t.density, -np.inf)
                self.onset[:] = (float(s.t), *_node(t, int(np.argmax(loss))))  # lost most (first in C order)

    def budget(self) -> dict[str, Any]:
        """Volumes (m³) since the start: eroded, deposited, carried off (removed from the field), the
        eroder's pending and unmet erosion, and the change of the field's solid volume."""
        t = self.terrain
        change = float((t.density.astype(np.float64) - self.initial).sum() * t.volume_per_unit)
        eroded = self.totals["eroded"]
        closure = abs(change + eroded - self.totals["deposited"])
        return {
            "unit": "m3",
            **self.totals,
            "pending": self.eroder.pending_volume() if self.eroder is not None else 0.0,
            "unmet": self.eroder.unmet_total if self.eroder is not None else 0.0,
            "field_change": change,
            "closure_rel": closure / eroded if eroded > 0 else 0.0,
            "couplings": self.calls,
        }

    # ---------------------------------------------------------------- callback protocol
    def state_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "density": self.terrain.density.copy(),
            "totals": np.array([self.totals[k] for k in _TERMS]),
            "first": np.append(self.first, self.first_y),
            "onset": self.onset.copy(),
            "calls": self.calls,
            "last_t": self.last_t,
        }
        if self.eroder is not None:
            out.update({f"eroder_{k}": v for k, v in self.eroder.state_dict().items()})
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.terrain.density[...] = np.asarray(state["density"], np.float32)  # in place: the wall reads it
        self.totals = dict(zip(_TERMS, np.asarray(state["totals"]).tolist(), strict=True))
        first = np.asarray(state["first"], np.float64)
        self.first[:], self.first_y = first[:3], float(first[3])
        self.onset[:] = state["onset"] if "onset" in state else np.nan  # checkpoints before the onset was kept
        self.calls = int(state["calls"])
        self.last_t = float(state["last_t"])
        if self.eroder is not None:
            self.eroder.load_state_dict({k[7:]: v for k, v in state.items() if k.startswith("eroder_")})

    def flush(self, sim) -> None:
        """Nothing to write between checkpoints (the field is in the checkpoint)."""

    def finalize(self, sim) -> dict[str, Any]:
        return {}
