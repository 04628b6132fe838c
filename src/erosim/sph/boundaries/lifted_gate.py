"""A dam-break gate of boundary particles lifted vertically at a constant speed.

Laboratory dam breaks hold the water column behind a gate (a plate, a membrane) and remove it in a
finite time; the water escapes under the rising edge first, which delays the front against an
instantaneous release (Lauber & Hager 1998; Aleixo et al. 2013). The gate here is a plate of
``layers`` boundary-particle layers on the downstream side of the plane x = x_g, spanning the tank's
height (and its width in 3-D), whose particles move with the prescribed velocity

    v_gate = U e_z,   z(t) = z₀ + U·t   (t ≥ 0, until its lower edge reaches the domain's top).

They are dynamic boundary particles like the walls' (:mod:`erosim.sph.boundaries.particles`: the
same density and pressure passes). The plate moves in its own plane, so its velocity normal to the
face, the part that holds the water back, is zero; in the pair terms (continuity, viscosity) its
particles carry the velocity 0, which makes the gate free-slip. A no-slip plate (the pair terms with
v_i − U e_z) drags the water beside it upwards through the artificial viscosity, whose kinematic
viscosity ~αh c/8 is about 10⁻³ m²/s at Δx = a/10, a thousand times water's: a boundary layer of
several millimetres that a real gate's (√(ν t) ≈ 0.2 mm) is not. Measured on Martin & Moyce at a/10
with U = 3 m/s the dragged gate delays the front by 0.4 a more (error 13 % against 5.4 %).
The solver rebuilds the neighbour lists when the plate has moved half the Verlet skin
(:meth:`LiftedGate.moved`), so no pair with the moving plate is missed.
"""

from __future__ import annotations

import numpy as np

from erosim.core.errors import ConfigError
from erosim.sph.boundaries.base import Boundary


def gate_particles(x_face: float, side: int, lo, hi, spacing: float, layers: int) -> np.ndarray:
    """Lattice of the plate: ``layers`` columns at x_face + side·(k + ½)Δx, from the floor to the
    domain's top (and across its width in 3-D) at (m + ½)Δx."""
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    d = lo.size
    axes = [x_face + side * (np.arange(layers) + 0.5) * spacing]
    for a in range(1, d):
        n = max(1, int(round((hi[a] - lo[a]) / spacing)))
        axes.append(lo[a] + (np.arange(n) + 0.5) * (hi[a] - lo[a]) / n)
    grids = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=1)


class LiftedGate(Boundary):
    """A gate plate (see the module docstring) lifted at ``speed`` (m/s) from t = 0."""

    name = "gate"

    def __init__(self, x_face: float, side: int, lo, hi, spacing: float, layers: int, speed: float):
        if side not in (-1, 1):
            raise ValueError("side must be +1 (plate downstream at larger x) or -1")
        if speed <= 0:
            raise ConfigError(f"The gate's speed must be positive (got {speed:g} m/s); set gate.speed > 0.")
        self.base = np.ascontiguousarray(gate_particles(x_face, side, lo, hi, spacing, layers))
        self.speed = float(speed)
        self.lift_max = float(np.asarray(hi, float)[-1] - np.asarray(lo, float)[-1])
        self.lift = 0.0  # how far the plate has risen (m)
        self.lift_ref = 0.0  # the lift when the neighbour lists were last built
        self._restoring = False

    def particles(self) -> np.ndarray:
        return self.base

    def bind(self, solver) -> None:
        if solver.summation:
            raise ConfigError(
                "A lifted gate needs sph.density = 'continuity' (summation density keeps the boundary's own "
                "kernel sums fixed); leave sph.density at its default or drop the gate."
            )
        offset = 0
        for bd in solver.boundaries:
            if bd is self:
                break
            x = bd.particles()
            offset += 0 if x is None else x.shape[0]
        self.offset = offset  # first row of the plate within the boundary block

    def _rows(self, solver) -> slice:
        i0 = solver.state.n_fluid + self.offset
        return slice(i0, i0 + self.base.shape[0])

    def _place(self, solver, lift: float) -> None:
        """Plate rows at ``lift`` above their start; their pair-term velocity stays 0 (free slip)."""
        rows = self._rows(solver)
        solver.state.pos[rows] = self.base
        solver.state.pos[rows, -1] += lift

    def predict(self, solver, dt: float) -> None:
        """After the drift: the plate where it is at the step's end, t + Δt, with its velocity."""
        self.lift = min(self.speed * (solver.t + dt), self.lift_max)
        self._place(solver, self.lift)

    def moved(self, solver) -> float:
        """How far the plate has moved since the neighbour lists were last built (m)."""
        return self.lift - self.lift_ref

    def lists_built(self, solver) -> None:
        if self._restoring:
            self._restoring = False
        else:
            self.lift_ref = self.lift

    def listed_positions(self, solver, src: np.ndarray) -> None:
        """Write into ``src`` where the plate was when the lists were last built (resuming a run)."""
        rows = self._rows(solver)
        src[rows] = self.base
        src[rows, -1] += self.lift_ref
        self._restoring = True

    def state_dict(self) -> dict:
        return {"lift": np.float64(self.lift), "lift_ref": np.float64(self.lift_ref)}

    def load_state_dict(self, state) -> None:
        if "lift" in state:
            self.lift = float(np.asarray(state["lift"]))
            self.lift_ref = float(np.asarray(state["lift_ref"]))
