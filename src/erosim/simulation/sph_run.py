"""Runner of ``kind = "sph"`` scenarios: build the solver, step it to ``run.t_end``, write the run folder.

What a run leaves (DESIGN.md, "Run folder"; every file written atomically):

* ``scenario.toml`` — the resolved scenario; ``report.json`` — status (completed / unstable /
  interrupted), particle counts, resolution (Δx, h, m and how they were derived), steps, timing,
  final front, ``column_width`` when the front is measured;
* ``particles/frame_NNNNN.vtp`` + ``particles/particles.pvd`` every ``run.output_interval``
  (fields velocity, pressure, density; float32);
* ``gauges.csv`` (columns ``t``, ``p_<probe>`` in Pa, ``depth_<gauge>`` in m) and ``front.csv``
  (``t,x_front``: seconds, metres from the column's back wall) every ``run.sample_interval``;
* ``figures/snapshot_NNN.png`` (particles coloured by speed) and ``figures/front.png`` (front vs
  Martin & Moyce 1952 when ``measure.compare = "martin-moyce"``);
* ``checkpoint/state.npz`` every ``run.checkpoint_wall_s`` of wall time, at the end and on Ctrl-C.
  It holds the solver's complete state and the recorders' rows, so ``erosim run --resume DIR``
  continues bit for bit (``--set run.t_end=…`` extends a finished run).

An :class:`~erosim.core.errors.InstabilityError` from the solver stops the run: the files written so
far stay, ``report.json`` gets ``status = "unstable"`` and the error's message, and it is re-raised.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from erosim.analysis.front import front_position, nondimensional_front
from erosim.analysis.gauges import probe_pressure, water_depth
from erosim.core.errors import InputError, InstabilityError, Interrupted
from erosim.io import atomic, checkpoint
from erosim.io.particles import FrameSeries
from erosim.io.runfolder import RunFolder
from erosim.scenarios.builders_sph import build
from erosim.scenarios.loader import Scenario, write_resolved
from erosim.scenarios.schema_sph import SPHScenario
from erosim.simulation.loop import Every, drive

_SOLVER = "solver__"


def _csv_text(header: list[str], rows: list[list[float]]) -> str:
    lines = [",".join(header)]
    lines += [",".join(repr(float(v)) for v in r) for r in rows]
    return "\n".join(lines) + "\n"


class Recorder:
    """Samples gauges, probes and the surge front; writes frames and snapshots; keeps its rows."""

    def __init__(self, cfg: SPHScenario, out: RunFolder, solver, name: str):
        self.cfg = cfg
        self.out = out
        self.solver = solver
        self.name = name
        p = cfg.sph
        self.dx = p.spacing
        self.h = p.support()
        self.mass = p.rho0 * p.spacing**p.dim
        self.gauge_rows: list[list[float]] = []
        self.front_rows: list[list[float]] = []
        self.n_snap = 0
        self.frames = FrameSeries(out.path / "particles") if cfg.run.output_interval > 0 else None
        self.front_origin = (
            cfg.measure.front_origin if cfg.measure.front_origin is not None else min(b.lo[0] for b in cfg.fluid)
        )
        self.header = ["t"] + [f"p_{q.name}" for q in cfg.probes] + [f"depth_{g.name}" for g in cfg.gauges]

    # sampling ---------------------------------------------------------------------------------
    def sample(self, _t: float) -> None:
        s, cfg = self.solver, self.cfg
        pos = s.fluid_positions()
        t = float(s.t)
        if cfg.probes or cfg.gauges:
            row = [t]
            if cfg.probes:
                vol = self.mass / s.fluid_density()
                pts = np.array([q.position for q in cfg.probes], dtype=np.float64)
                row += probe_pressure(pos, s.fluid_pressure(), vol, pts, self.h).tolist()
            if cfg.gauges:
                g = np.array([q.position for q in cfg.gauges], dtype=np.float64)
                row += water_depth(pos, g, self.dx, self.dx, cfg.domain.lo[-1]).tolist()
            self.gauge_rows.append(row)
        if cfg.measure.front:
            self.front_rows.append([t, front_position(pos, self.dx, self.front_origin, axis=0)])

    def frame(self, _t: float) -> None:
        s = self.solver
        fields = {
            "velocity": s.fluid_velocities().astype(np.float32),
            "pressure": s.fluid_pressure().astype(np.float32),
            "density": s.fluid_density().astype(np.float32),
        }
        self.frames.write(float(s.t), s.fluid_positions().astype(np.float32), fields)

    def snapshot(self, _t: float) -> None:
        from erosim.viz.plots import snapshot

        s = self.solver
        snapshot(
            self.out.figures / f"snapshot_{self.n_snap:03d}.png",
            s.fluid_positions(),
            s.fluid_velocities(),
            t=float(s.t),
            lo=self.cfg.domain.lo,
            hi=self.cfg.domain.hi,
            spacing=self.dx,
            title=self.name,
        )
        self.n_snap += 1

    # files ------------------------------------------------------------------------------------
    def flush(self) -> None:
        if self.cfg.probes or self.cfg.gauges:
            self.out.write_text("gauges.csv", _csv_text(self.header, self.gauge_rows))
        if self.cfg.measure.front:
            self.out.write_text("front.csv", _csv_text(["t", "x_front"], self.front_rows))

    def front_figure(self) -> str | None:
        """Front vs Martin & Moyce (1952) when asked for; returns the figure path or None."""
        if not (self.cfg.measure.front and self.cfg.measure.compare == "martin-moyce" and self.front_rows):
            return None
        from erosim.validation.martin_moyce import SURGE_FILE
        from erosim.validation.reference import read_csv
        from erosim.viz.plots import front_vs_experiment

        try:
            ref = read_csv(SURGE_FILE)
        except InputError as exc:
            self.out.warn(f"front figure without experiment: {exc}")
            ref = {"T": np.zeros(0), "Z": np.zeros(0)}
        rows = np.asarray(self.front_rows)
        a = column_width(self.cfg)
        g = abs(self.cfg.sph.gravity_vector()[-1])
        T, Z = nondimensional_front(rows[:, 0], rows[:, 1], a, g)
        path = front_vs_experiment(
            self.out.figures / "front.png",
            T,
            Z,
            ref["T"],
            ref["Z"],
            label=f"erosim (dx = a/{a / self.dx:.0f})",
            title=f"{self.name}: surge front",
        )
        return str(path.relative_to(self.out.path))

    # checkpoint -------------------------------------------------------------------------------
    def state(self) -> dict[str, np.ndarray]:
        ncol = len(self.header)
        return {
            "rec__gauges": np.asarray(self.gauge_rows, dtype=np.float64).reshape(-1, ncol),
            "rec__front": np.asarray(self.front_rows, dtype=np.float64).reshape(-1, 2),
        }

    def meta(self) -> dict[str, Any]:
        return {"frames": self.frames.frames if self.frames else [], "n_snap": self.n_snap}

    def restore(self, state: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
        self.gauge_rows = state["rec__gauges"].tolist()
        self.front_rows = state["rec__front"].tolist()
        self.n_snap = int(meta.get("n_snap", 0))
        if self.frames is not None:
            self.frames = FrameSeries(self.out.path / "particles", frames=meta.get("frames", []))


def column_width(cfg: SPHScenario) -> float:
    """Width a of the first fluid block along x (the collapsing column)."""
    return float(cfg.fluid[0].hi[0] - cfg.fluid[0].lo[0])


def _schedule(interval: float, action, t_now: float, saved: dict | None, key: str) -> Every:
    ev = Every(interval, action)
    if saved is not None:
        prev = saved.get(key)
        if prev and abs(prev[0] - interval) <= 1e-15 * max(1.0, interval):
            ev.next_at = float(prev[1])
        elif interval > 0:
            ev.next_at = (int(t_now / interval + 1e-9) + 1) * interval
    return ev


def run(scenario: Scenario, out: RunFolder, *, resume: bool = False, progress: bool = True) -> dict:
    """Run an SPH scenario into ``out``; returns a short summary (see the module docstring)."""
    return execute(scenario, out, resume=resume, progress=progress)[0]


def execute(scenario: Scenario, out: RunFolder, *, resume: bool = False, progress: bool = True):
    """:func:`run`, also returning the solver in its final state (for validation cases)."""
    cfg: SPHScenario = scenario.config
    built = build(cfg)
    solver = built.solver
    write_resolved(scenario, out)
    rec = Recorder(cfg, out, solver, scenario.name)

    saved_sched = None
    if resume:
        state, meta = checkpoint.load(out.checkpoint)
        solver.load_state_dict(
            {k[len(_SOLVER) :]: (v.item() if v.ndim == 0 else v) for k, v in state.items() if k.startswith(_SOLVER)}
        )
        rec.restore(state, meta)
        saved_sched = meta.get("schedules", {})

    t0 = float(solver.t)
    r = cfg.run
    snap_interval = r.t_end / r.snapshots if r.snapshots else 0.0
    schedules = {
        "sample": _schedule(r.sample_interval, rec.sample, t0, saved_sched, "sample"),
        "frame": _schedule(r.output_interval, rec.frame, t0, saved_sched, "frame") if rec.frames else None,
        "snapshot": _schedule(snap_interval, rec.snapshot, t0, saved_sched, "snapshot") if snap_interval else None,
    }
    schedules = {k: v for k, v in schedules.items() if v is not None}

    def advance() -> float:
        solver.step()
        return float(solver.t)

    def save_checkpoint() -> None:
        state = {_SOLVER + k: v for k, v in solver.state_dict().items()}
        state.update(rec.state())
        meta = rec.meta()
        meta["schedules"] = {k: [v.interval, v.next_at] for k, v in schedules.items()}
        meta["t"] = float(solver.t)
        meta["steps"] = int(solver.steps)
        checkpoint.save(out.checkpoint, state, meta)
        rec.flush()

    steps0 = int(solver.steps)
    wall0 = time.perf_counter()
    status, error = "completed", None
    try:
        drive(
            advance,
            start=t0,
            total=r.t_end,
            schedules=list(schedules.values()),
            checkpoint=save_checkpoint,
            checkpoint_wall_s=r.checkpoint_wall_s,
            label=scenario.name,
            unit="s",
            progress=progress,
            steps_done=steps0,
        )
    except InstabilityError as exc:
        status, error = "unstable", str(exc)
        raise
    except Interrupted as exc:
        status, error = "interrupted", str(exc)
        raise
    except BaseException as exc:  # a bug or a stray Ctrl-C outside the loop: say so in the report
        status, error = "failed", f"{type(exc).__name__}: {exc}"
        raise
    finally:
        wall = time.perf_counter() - wall0
        rec.flush()
        report = _report(scenario, cfg, solver, built.info, rec, status, error, wall, steps0, resume)
        if status == "completed":
            fig = rec.front_figure()
            if fig:
                report["figures"].append(fig)
        report["figures"] += (
            sorted(str(p.relative_to(out.path)) for p in (out.path / "figures").glob("snapshot_*.png"))
            if (out.path / "figures").is_dir()
            else []
        )
        out.write_report(report, seed=cfg.seed)
    summary = {
        "status": status,
        "t": float(solver.t),
        "steps": int(solver.steps),
        "fluid_particles": solver.n_fluid,
        "boundary_particles": solver.n_boundary,
        **({"x_front": report["x_front"]} if "x_front" in report else {}),
        "wall_time_s": round(wall, 2),
    }
    return summary, solver


def _report(scenario, cfg, solver, info, rec, status, error, wall, steps0, resumed) -> dict:
    steps = int(solver.steps) - steps0
    n = solver.n_fluid + solver.n_boundary
    pos = solver.fluid_positions()
    lo, hi = np.asarray(cfg.domain.lo), np.asarray(cfg.domain.hi)
    outside = int(np.count_nonzero(np.any((pos < lo) | (pos > hi), axis=1)))
    rep: dict[str, Any] = {
        "scenario": scenario.name,
        "preset": scenario.preset,
        "status": status,
        "dim": cfg.dim,
        "t": float(solver.t),
        "t_end": cfg.run.t_end,
        "steps": int(solver.steps),
        "steps_this_session": steps,
        "resumed": bool(resumed),
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
        "files": {
            "frames": len(rec.frames.frames) if rec.frames else 0,
            "gauges_csv": bool(cfg.probes or cfg.gauges),
            "front_csv": bool(cfg.measure.front),
        },
        "figures": [],
    }
    if error:
        rep["error"] = error
    if cfg.measure.front:
        rep["column_width"] = column_width(cfg)
        rep["front_origin"] = rec.front_origin
        if rec.front_rows:
            rep["x_front"] = rec.front_rows[-1][1]
    return rep


def _safe(fn):
    try:
        return fn()
    except Exception:  # diagnostics only; never mask the run's own outcome
        return None


def write_csv(path, header: list[str], rows) -> None:
    """Write a small CSV atomically (used by validation cases)."""
    atomic.write_text(path, _csv_text(header, [list(r) for r in rows]))
