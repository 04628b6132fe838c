"""What an `sph` run reports: the surge front against Martin & Moyce's measurements (figure) and the run's
report (particles, steps, energy, probes).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from erosim.analysis.front import nondimensional_front
from erosim.data import MARTIN_MOYCE_SURGE, reference_csv
from erosim.scenarios.sph.schema import SPHScenario
from erosim.viz.plots import front_vs_experiment


def column_width(cfg: SPHScenario) -> float:
    """Width a of the first fluid block along x (the collapsing column)."""
    return float(cfg.fluid[0].hi[0] - cfg.fluid[0].lo[0])


def martin_moyce_figure(path, width: float, g: float, spacing: float, title: str):
    """The end-of-run figure of a front: the front against Martin & Moyce (1952), n² = 2, non-dimensional
    (Z = x/a, T = t√(2g/a), a = ``width``), as ``figure(rows)`` for
    :class:`~erosim.simulation.callbacks.FrontTracker`."""

    def figure(rows: np.ndarray) -> None:

        ref = reference_csv(MARTIN_MOYCE_SURGE)
        T, Z = nondimensional_front(rows[:, 0], rows[:, 1], width, g)
        front_vs_experiment(path, T, Z, ref["T"], ref["Z"], label=f"erosim (dx = a/{width / spacing:.0f})", title=title)

    return figure


def sph_report(cfg: SPHScenario, solver, info: dict, sim, front) -> dict[str, Any]:
    """The ``sph`` kind's entries of ``report.json``."""
    steps = int(sim.iteration - sim.iteration_start)
    wall = sim.wall_time
    n = solver.n_fluid + solver.n_boundary
    pos = solver.fluid_positions()
    lo, hi = np.asarray(cfg.domain.lo), np.asarray(cfg.domain.hi)
    outside = int(np.count_nonzero(np.any((pos < lo) | (pos > hi), axis=1)))
    figures = sorted(p.name for p in sim.out.path.glob("figures/*.png"))
    rep: dict[str, Any] = {
        "dim": cfg.dim,
        "t": float(solver.t),
        "t_end": cfg.run.t_end,
        "steps": int(solver.steps),
        "steps_this_session": steps,
        "fluid_particles": solver.n_fluid,
        "boundary_particles": solver.n_boundary,
        "resolution": info,
        "dt_mean": (float(solver.t) / solver.steps) if solver.steps else None,
        "dt_limit": _safe(solver.dt_limit),
        "neighbours": _safe(solver.neighbour_stats),
        # fluid particle-steps per second (the benchmark's measure), and counting boundary particles
        "particle_steps_per_s": (solver.n_fluid * steps / wall) if wall > 0 and steps else None,
        "all_particle_steps_per_s": (n * steps / wall) if wall > 0 and steps else None,
        "outside_domain": outside,
        "water_budget": solver.budget(),
        "files": {
            "frames": sum(1 for _ in sim.out.path.glob("particles/frame_*.vtp")),
            "gauges_csv": bool(cfg.probes or cfg.gauges),
            "front_csv": bool(cfg.measure.front),
        },
        "figures": [f"figures/{f}" for f in figures if f == "front.png"]
        + [f"figures/{f}" for f in figures if f.startswith("snapshot_")],
    }
    if front is not None:
        rep["column_width"] = column_width(cfg)
        rep["front_origin"] = front.origin
        if front.rows:
            rep["x_front"] = front.rows[-1][1]
    return rep


def _safe(fn):
    try:
        return fn()
    except Exception:  # diagnostics only; never mask the run's own outcome
        return None
