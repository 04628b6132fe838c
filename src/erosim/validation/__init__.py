"""erosim.validation: runs compared with experiments and analytic answers (``erosim validate``)."""

from __future__ import annotations

from typing import Any


def run_facts(solver, summary: dict, wall: float) -> dict[str, Any]:
    """What every SPH validation reports about its run: particles, steps, wall time, status."""
    return {
        "fluid_particles": int(solver.n_fluid),
        "boundary_particles": int(solver.n_boundary),
        "steps": int(solver.steps),
        "wall_time_s": round(wall, 2),
        "run_status": summary["status"],
    }
