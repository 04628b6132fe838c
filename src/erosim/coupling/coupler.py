"""The coupler: the fluid → an erosion model's increments → the terrain, every N steps (DESIGN.md "Contracts").

One coupler for both kinds of terrain, seen through an adapter of :mod:`erosim.coupling.terrains` (a
heightfield, or a voxel field's densities). Each time its schedule fires (every N fluid steps, an
``IterationInterval``), with ``dt`` the simulated time since the last call, the coupler

1. hands the eroder what it sees of the fluid (``terrain.fluid(solver)``: the fluid binned on the
   raster, :class:`~erosim.coupling.binning.FluidGrid` — binned on every call, also without an eroder,
   for the maps' running maxima — or the solver's particles);
2. asks the eroder for increments: ``eroder.increments(terrain, fluid, dt) -> Increment`` — the change Δ
   of every node and, in :attr:`~erosim.core.increments.Increment.particles`, the new values of
   particle fields (the sediment each particle carries); the eroder writes neither;
3. checks the increment's budget (:func:`~erosim.core.increments.check_budget` with the terrain's
   volume per unit: Σ Δ·A + ΔS + C = 0) and the terrain's own limits (the bedrock), refusing it with
   one clear sentence otherwise;
4. applies it once: the particle fields, the terrain's own fields, the particles it removes (through the
   solver's sinks), then Δ inside the solver's
   :meth:`~erosim.sph.solver.SPHSolver.ground_moving` (the walls' share kept, every boundary
   refreshed with the new ground), and adds the terms to the run's budget.

An eroder is any object with ``name``, ``needs`` (a tuple of what it reads of the fluid, checked
against the terrain's ``provides`` when the coupler is built: fastscapelib's ``FlowKernelEroder``
declares its inputs the same way), ``increments(terrain, fluid, dt)``, and optionally ``state_dict`` /
``load_state_dict`` (its suspended sediment, its accumulator). Before ``start`` (s) the coupler only
looks: a fluid laid on a lattice settles in its first moments, at speeds no still reservoir has, and
that motion would otherwise scour a voxel field.

An eroder that keeps erosion back below a transfer step (the voxel eroders' quantum) may have
``flush(terrain) -> Increment``: at the end of a completed run the coupler applies what it still holds,
so that all the erosion computed is eroded by the end.

The coupler is a callback of :class:`~erosim.simulation.simulation.Simulation` (``schedule``,
``__call__(sim)``; checkpoint state: the terrain's, the budget's terms, the eroder's).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from erosim.core.callbacks import Callback
from erosim.core.errors import ConfigError
from erosim.core.increments import check_budget

_TERMS = ("eroded", "deposited", "suspended", "carried_off")


class Coupler(Callback):
    """Couple ``solver`` to ``terrain`` (an adapter of :mod:`erosim.coupling.terrains`) through ``eroder``
    (None: only look) on ``schedule``, from ``start`` (s) on."""

    def __init__(self, schedule, solver, eroder, terrain, *, start: float = -np.inf, name: str = "coupler"):
        super().__init__(schedule, name=name)
        self.solver = solver
        self.eroder = eroder
        self.terrain = terrain
        missing = [f for f in getattr(eroder, "needs", ()) if f not in terrain.provides]
        if missing:
            raise ConfigError(
                f"Erosion model '{eroder.name}' needs {', '.join(missing)}, which this terrain's coupling does not "
                f"provide (it gives {', '.join(terrain.provides)}); choose another model."
            )
        self.start = float(start)
        self.wall = 0.0  # wall time spent here (s)
        self.totals = dict.fromkeys(_TERMS, 0.0)
        self.calls = 0
        self.last_t = float(solver.t)

    def __call__(self, sim=None) -> None:
        t0 = time.perf_counter()
        try:
            self._couple()
        finally:
            self.wall += time.perf_counter() - t0

    def _couple(self) -> None:
        s, g = self.solver, self.terrain
        now = float(s.t)
        dt = now - self.last_t
        fluid = g.fluid(s)
        self.last_t = now
        if self.eroder is None or now <= self.start:
            return
        self._apply(self.eroder.increments(g.terrain, fluid, dt), now)

    def _apply(self, inc, now: float) -> None:
        """Check the increment ``inc`` and apply it at time ``now`` (steps 3 and 4 of the module docstring)."""
        s, g = self.solver, self.terrain
        who = f"Erosion model '{self.eroder.name}'"
        terms = check_budget(inc, g.shape, g.unit_volume, who)
        g.refuse(inc, who)
        for field, values in inc.particles.items():
            getattr(s.state, field)[: len(values)] = values
        if inc.terrain_fields:
            g.write(inc.terrain_fields)
        if inc.removed is not None:
            s.remove_fluid(inc.removed, sink=inc.sink)
        changed = inc.dz != 0
        if changed.any():
            with s.ground_moving(g.values, changed):
                g.apply(inc.dz, now)
        for k in _TERMS:
            self.totals[k] += terms[k]
        self.calls += 1

    def budget(self) -> dict[str, Any]:
        """Volumes (m³) since the start: eroded, deposited, suspended (held in the water), carried off, what
        the terrain adds (its change, the eroder's pending erosion) and the closure; the couplings."""
        return {**self.terrain.budget(self.totals, self.eroder), "couplings": self.calls}

    # ---------------------------------------------------------------- callback protocol
    def state_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = dict(self.terrain.state_dict())
        out["totals"] = np.array([self.totals[k] for k in _TERMS])
        out.update({f"eroder_{k}": v for k, v in getattr(self.eroder, "state_dict", dict)().items()})
        out["calls"] = self.calls
        out["last_t"] = self.last_t
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.terrain.load_state_dict(state)
        self.totals = dict(zip(_TERMS, np.asarray(state["totals"]).tolist(), strict=True))
        if hasattr(self.eroder, "load_state_dict"):
            self.eroder.load_state_dict({k[7:]: v for k, v in state.items() if k.startswith("eroder_")})
        self.calls = int(state["calls"])
        self.last_t = float(state["last_t"])
        # no refresh: a boundary that stands for the terrain restores its own state with the solver

    def finalize(self, sim) -> dict[str, Any]:
        flush = getattr(self.eroder, "flush", None)
        if flush is not None and self.calls:
            self._apply(flush(self.terrain.terrain), float(self.solver.t))
        key = self.terrain.report_key
        return {key: self.budget()} if key and self.eroder is not None else {}
