"""The boundary protocol: what a wall adds to an SPH step, as its own per-particle passes.

A boundary model may

* lay **fixed particles** that join the solver's index space after the fluid (:meth:`Boundary.particles`);
  the fused fluid pass sums over them like over any neighbour (they are particles, with density and
  pressure); everything else a boundary does is its own pass;
* **bind** to the solver once its arrays exist (constants, calibration);
* per step, in the order of SPEC SPH-13 with leapfrog's kicks around it (``solver`` is the
  :class:`~erosim.sph.solver.SPHSolver`, its fields in ``solver.state``):

  1. ``constrain(solver)`` after the drift: keep fluid particles out of the solid (a particle that
     crossed is put back and its normal velocity reversed) — the last line of defence;
  2. ``predict(solver, dt)`` after the drift: the predictor of the boundary's own state;
  3. ``density(solver)`` before the pair pass: its contribution to summation density, or the
     density rate of its own particles;
  4. ``forces(solver)`` after the pair pass: what it adds to the fluid's acceleration and density
     rate (a wall known by a distance function and its normal, e.g. a heightfield or a voxel
     wall-weight boundary, acts here);
  5. ``correct(solver, dt)`` after the pair pass: the corrector of its own state;

* if its particles **move** (a lifted gate), say how far since the neighbour lists were last built
  (``moved(solver)``, so the solver rebuilds them in time), hear when they are built
  (``lists_built(solver)``) and, on resuming, put where they were then into the rebuild's positions
  (``listed_positions(solver, src)``);
* bound the **time step** (``step_limit(solver) -> float``, s): the adaptive step is the smallest of
  the solver's limits and these (e.g. the viscous limit of a more viscous mixture);
* **refresh** itself when the terrain it represents changes (``refresh(solver, **changed)``);
* keep **checkpoint state** (``state_dict`` / ``load_state_dict``).

A hook a model does not need stays ``None``: the solver collects the defined ones when it is built,
so the step loop has no branches on boundary types. The pattern is SPlisHSPlasH's per-particle
boundary passes, chosen when the simulation is built.
"""

from __future__ import annotations

from typing import Any

import numpy as np


class Boundary:
    """Base class: a boundary that does nothing; models override the hooks they need."""

    name = "boundary"
    constrain = None
    predict = None
    density = None
    forces = None
    correct = None
    moved = None
    step_limit = None

    def particles(self) -> np.ndarray | None:
        """Fixed particles (m, dim) to add after the fluid, or None."""
        return None

    def bind(self, solver) -> None:
        """Called once the solver's arrays exist (before the first evaluation)."""

    def lists_built(self, solver) -> None:
        """The solver has just built its neighbour lists (moving boundaries note where they were)."""

    def listed_positions(self, solver, src: np.ndarray) -> None:
        """Resuming: write this boundary's particles into ``src`` as they were at the last list build."""

    def refresh(self, solver, **changed) -> None:
        """The terrain this boundary stands for has changed (``changed`` says how)."""

    def state_dict(self) -> dict[str, Any]:
        return {}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state_dict`."""
