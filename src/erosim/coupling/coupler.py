"""The coupler: a fluid's grid fields → an erosion model's increments → the terrain, every N steps.

Each time its schedule fires (every N fluid steps, an ``IterationInterval``), the coupler

1. bins the fluid onto the terrain's raster (:class:`~erosim.coupling.binning.FluidGrid`);
2. asks the eroder for increments: ``eroder.increments(terrain, grid, dt)`` with ``dt`` the simulated
   time since the last coupling; the eroder reads what it declared in ``eroder.needs`` and returns an
   :class:`~erosim.core.increments.Increment` — it never writes the terrain;
3. checks the increment's budget (:func:`~erosim.core.increments.check_budget`: shape, finite,
   Σ Δz·A + ΔS + C = 0) and refuses it with a clear error otherwise;
4. applies it once — z += Δz, never below ``bedrock`` where one is given (an eroder that cuts into it
   is refused: it must honour the bedrock itself);
5. refreshes every boundary model of the solver with the new terrain (``refresh(solver, terrain=z,
   changed=mask)``), and adds the terms to the run's sediment budget.

Without an eroder the coupler only bins (water depth, speeds and their running maxima for the maps).
An eroder is any object with ``name``, ``needs`` (a tuple of :attr:`FluidGrid.FIELDS`) and
``increments(terrain, grid, dt) -> Increment``, optionally ``state_dict`` / ``load_state_dict``
(its suspended sediment, for instance). One that needs a field the grid does not provide is refused
when the coupler is built (fastscapelib's ``FlowKernelEroder`` declares its inputs the same way).

The coupler is a callback of :class:`~erosim.simulation.simulation.Simulation` (``schedule``,
``__call__(sim)``, checkpoint state: the terrain, the running maxima, the budget, the eroder's state).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from erosim.core.errors import BudgetError, ConfigError
from erosim.core.increments import check_budget
from erosim.coupling.binning import FluidGrid
from erosim.coupling.raster import Raster
from erosim.sph.boundaries.distance_wall import walls_follow

_TERMS = ("eroded", "deposited", "suspended", "carried_off")


class Coupler:
    """Couple ``solver`` to ``terrain`` (raster.shape, SPH frame) through ``eroder`` on ``schedule``."""

    def __init__(self, schedule, solver, eroder, raster: Raster, terrain: np.ndarray, *, bedrock=None,
                 near_bed: float = np.inf, name: str = "coupler"):  # fmt: skip
        self.schedule = schedule
        self.name = name
        self.solver = solver
        self.eroder = eroder
        self.raster = raster
        missing = [f for f in getattr(eroder, "needs", ()) if f not in FluidGrid.FIELDS]
        if missing:
            raise ConfigError(
                f"Erosion model '{eroder.name}' needs {', '.join(missing)}, which the fluid grid does not provide "
                f"(it gives {', '.join(FluidGrid.FIELDS)}); choose another model or extend the grid."
            )
        self.terrain = np.ascontiguousarray(terrain, dtype=np.float64)  # shared: boundaries read it live
        if self.terrain.shape != raster.shape:
            raise ConfigError(
                f"The terrain has shape {self.terrain.shape}, its raster {raster.shape}; they must match."
            )
        self.bedrock = None if bedrock is None else np.asarray(bedrock, np.float64)
        self.grid = FluidGrid(raster, solver.dim, ground=self.terrain, near=near_bed)
        self.wall = 0.0  # wall time spent here (s)
        self.terrain0 = self.terrain.copy()
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
        s = self.solver
        dt = float(s.t) - self.last_t
        self.grid.bin(s)
        if self.eroder is None:
            self.last_t = float(s.t)
            return
        inc = self.eroder.increments(self.terrain, self.grid, dt)
        terms = check_budget(inc, self.terrain.shape, self.raster.cell_area, f"Erosion model '{self.eroder.name}'")
        new = self.terrain + inc.dz
        if self.bedrock is not None and np.any(new < self.bedrock - 1e-12):
            worst = float((self.bedrock - new).max())
            raise BudgetError(
                f"Erosion model '{self.eroder.name}' cut {worst:.3g} m into the bedrock; it must not erode below "
                "the bedrock map."
            )
        changed = inc.dz != 0
        if changed.any():
            with walls_follow(s):
                self.terrain[...] = new
                for b in s.boundaries:
                    b.refresh(s, terrain=self.terrain, changed=changed)
        for k in _TERMS:
            self.totals[k] += terms[k]
        self.calls += 1
        self.last_t = float(s.t)

    def sediment_budget(self) -> dict[str, Any]:
        """Volumes (m³) since the start: eroded, deposited, suspended (held in the water), carried off,
        and closure = |eroded − deposited − suspended − carried off| / eroded, with the terrain's change."""
        t = self.totals
        eroded = t["eroded"]
        closure = abs(eroded - t["deposited"] - t["suspended"] - t["carried_off"])
        change = float((self.terrain - self.terrain0).sum() * self.raster.cell_area)
        return {
            "unit": "m3",
            **t,
            "terrain_change": change,
            "closure_rel": closure / eroded if eroded > 0 else 0.0,
            "couplings": self.calls,
        }

    # ---------------------------------------------------------------- callback protocol
    def state_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"terrain": self.terrain.copy(), "totals": np.array([self.totals[k] for k in _TERMS])}
        out.update({f"grid_{k}": v for k, v in self.grid.state_dict().items()})
        out.update({f"eroder_{k}": v for k, v in getattr(self.eroder, "state_dict", dict)().items()})
        out["calls"] = self.calls
        out["last_t"] = self.last_t
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.terrain[...] = np.asarray(state["terrain"])  # in place: the boundaries hold this array
        self.totals = dict(zip(_TERMS, np.asarray(state["totals"]).tolist(), strict=True))
        self.grid.load_state_dict({k[5:]: v for k, v in state.items() if k.startswith("grid_")})
        if hasattr(self.eroder, "load_state_dict"):
            self.eroder.load_state_dict({k[7:]: v for k, v in state.items() if k.startswith("eroder_")})
        self.calls = int(state["calls"])
        self.last_t = float(state["last_t"])
        # no refresh: a boundary that stands for the terrain restores its own state with the solver

    def flush(self, sim) -> None:
        """Nothing to write between checkpoints (the terrain is in the checkpoint)."""

    def finalize(self, sim) -> dict[str, Any]:
        return {"sediment_budget": self.sediment_budget()} if self.eroder is not None else {}
