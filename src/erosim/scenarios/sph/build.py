"""The ``sph`` kind: an :class:`~erosim.scenarios.sph.schema.SPHScenario` → particles, solver, callbacks.

Fluid blocks are filled with a regular lattice of spacing Δx = ``sph.spacing``: along each axis
n = round(L/Δx) particles at lo + (i + ½)Δx, so a block of width a holds exactly a/Δx columns and
its particles represent the volume [lo, lo + nΔx]. Lattice points inside an obstacle or inside an
earlier block are dropped. The solver lays the boundary particles itself (``sph.walls``).

Consistent resolution (the thesis preset of ``dam-break``): with ``particles.count = N`` the schema
sets Δx = (V_fluid/N)^(1/d); then the kernel support h = h_factor·Δx, the mass m = ρ₀Δx^d and the
time step (adaptive, CFL/force/viscous limits of the solver) all follow from it, instead of the
thesis's mutually inconsistent h = 0.2 m, m = 30 kg (spacing (m/ρ₀)^(1/3) = 0.31 m > h), Δt = 0.1 s.
:func:`derivation` states those numbers for the report and ``erosim describe``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from erosim.core.errors import ConfigError
from erosim.core.schedules import TimeInterval
from erosim.scenarios.setup import Setup
from erosim.scenarios.sph.outputs import column_width, martin_moyce_figure, sph_report
from erosim.scenarios.sph.schema import SPHScenario
from erosim.simulation import callbacks as cb
from erosim.sph.boundaries.lifted_gate import LiftedGate
from erosim.sph.wall_load import wall_pressures

THESIS = {"h": 0.2, "mass": 30.0, "dt": 0.1}  # SC-1/SC-2 as printed in seed 000 (ch. 3)


def lattice(lo, hi, dx: float) -> np.ndarray:
    """Cell-centred lattice points of spacing ``dx`` filling the box [lo, hi] (n = round(L/dx) per axis)."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    counts = np.maximum(1, np.rint((hi - lo) / dx).astype(np.int64))
    axes = [lo[k] + (np.arange(counts[k]) + 0.5) * dx for k in range(len(lo))]
    grids = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=1)


def _inside(points: np.ndarray, lo, hi) -> np.ndarray:
    return np.all((points > np.asarray(lo)) & (points < np.asarray(hi)), axis=1)


def fluid_particles(cfg: SPHScenario) -> tuple[np.ndarray, np.ndarray]:
    """Initial fluid positions (n, d) and velocities (n, d) of every ``[[fluid]]`` block."""
    dx = cfg.sph.spacing
    pos_parts, vel_parts = [], []
    for i, block in enumerate(cfg.fluid):
        pts = lattice(block.lo, block.hi, dx)
        keep = np.ones(len(pts), dtype=bool)
        for ob in cfg.obstacles:
            keep &= ~_inside(pts, ob.lo, ob.hi)
        for prev in cfg.fluid[:i]:
            keep &= ~_inside(pts, prev.lo, prev.hi)
        pts = pts[keep]
        vel = np.zeros_like(pts)
        if block.velocity is not None:
            vel[:] = np.asarray(block.velocity, dtype=np.float64)
        pos_parts.append(pts)
        vel_parts.append(vel)
    pos = np.ascontiguousarray(np.concatenate(pos_parts))
    vel = np.ascontiguousarray(np.concatenate(vel_parts))
    if len(pos) == 0:
        raise ConfigError(
            "The fluid blocks hold no particles (all inside obstacles or thinner than sph.spacing); "
            "enlarge them or reduce sph.spacing."
        )
    return pos, vel


def derivation(cfg: SPHScenario, n_fluid: int) -> dict[str, Any]:
    """How the resolution was chosen: Δx, h, m and (when a preset asked for a count) the thesis values."""
    p = cfg.sph
    d = {
        "spacing": p.spacing,
        "support_h": p.support(),
        "particle_mass": p.rho0 * p.spacing**p.dim,
        "fluid_particles": int(n_fluid),
    }
    if cfg.particles.count is not None:
        d["requested_particles"] = int(cfg.particles.count)
        d["note"] = (
            f"spacing from particles.count: dx = (V/N)^(1/{p.dim}) = {p.spacing:.6g} m, "
            f"h = {p.h_factor:g}*dx = {p.support():.6g} m, m = rho0*dx^{p.dim} = {d['particle_mass']:.6g} kg, "
            "dt adaptive (CFL); the thesis's h = 0.2 m, m = 30 kg, dt = 0.1 s are mutually inconsistent "
            "(m = 30 kg means dx = 0.31 m > h) and are not used"
        )
    return d


@dataclass
class Built:
    solver: Any
    fluid_pos: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)


def build(cfg: SPHScenario) -> Built:
    """Particles and an :class:`erosim.sph.solver.SPHSolver` for the scenario (its CUDA subclass
    :class:`erosim.sph.solver_cuda.CudaSPHSolver` with ``run.device = "cuda"``)."""
    if cfg.run.device == "cuda":
        from erosim.sph.solver_cuda import CudaSPHSolver as SPHSolver
    else:
        from erosim.sph.solver import SPHSolver  # Numba import only when a run starts

    pos, vel = fluid_particles(cfg)
    boundaries = []
    if cfg.gate.speed > 0:
        if cfg.run.device == "cuda":
            raise ConfigError("A lifted gate runs on device 'cpu' only; run with --device cpu or set gate.speed = 0.")

        boundaries.append(
            LiftedGate(cfg.gate_face(), cfg.gate_side(), cfg.domain.lo, cfg.domain.hi, cfg.sph.spacing,
                       cfg.sph.layers(), cfg.gate.speed)
        )  # fmt: skip
    solver = SPHSolver(
        cfg.sph,
        pos,
        boundary_pos=None,
        domain_lo=np.asarray(cfg.domain.lo, dtype=np.float64),
        domain_hi=np.asarray(cfg.domain.hi, dtype=np.float64),
        obstacles=[(np.asarray(o.lo, float), np.asarray(o.hi, float)) for o in cfg.obstacles],
        fluid_vel=vel,
        seed=cfg.seed,
        boundaries=boundaries,
    )
    return Built(solver=solver, fluid_pos=pos, info=derivation(cfg, len(pos)))


def probe_wall(cfg: SPHScenario, point) -> tuple | None:
    """(normal into the fluid, the wall's solid box) when ``point`` lies on a face of an obstacle or,
    with boundary-particle walls, of the domain's floor or sides; None for a probe in the fluid."""
    if cfg.sph.walls != "particles":
        return None  # reflecting walls have no particles to feel the load
    q = np.asarray(point, dtype=np.float64)
    lo, hi = np.asarray(cfg.domain.lo, float), np.asarray(cfg.domain.hi, float)
    tol = 1e-6 * float(np.max(hi - lo))
    for ob in cfg.obstacles:
        olo, ohi = np.asarray(ob.lo, float), np.asarray(ob.hi, float)
        if np.any(q < olo - tol) or np.any(q > ohi + tol):
            continue
        for k in range(len(q)):
            for face, sign in ((olo[k], -1.0), (ohi[k], 1.0)):
                if abs(q[k] - face) <= tol and not (k == len(q) - 1 and sign < 0):
                    normal = np.zeros(len(q))
                    normal[k] = sign
                    return normal, (olo, ohi)
    reach = 10.0 * cfg.sph.support()  # the walls' particles lie within a support outside the domain
    for k in range(len(q)):
        for face, sign in ((lo[k], 1.0), (hi[k], -1.0)):
            top = k == len(q) - 1 and sign < 0  # no wall on top
            if abs(q[k] - face) <= tol and not top:
                normal = np.zeros(len(q))
                normal[k] = sign
                solid_lo, solid_hi = lo - reach, hi + reach
                (solid_hi if sign > 0 else solid_lo)[k] = face
                return normal, (solid_lo, solid_hi)
    return None


def setup(scenario, out) -> Setup:
    """The solver and the callbacks of an ``sph`` run (what a run leaves: ``docs/sph.md``).

    * ``particles/frame_NNNNN.vtp`` + ``particles.pvd`` every ``run.output_interval``;
    * ``gauges.csv`` (``t``, ``p_<probe>`` in Pa, ``depth_<gauge>`` and ``wire_<gauge>`` in m) and ``front.csv``
      (``t,x_front``: s, m from the column's back wall) every ``run.sample_interval``;
    * ``figures/snapshot_NNN.png`` (particles coloured by speed), ``figures/front.png`` (front vs
      Martin & Moyce 1952 when ``measure.compare = "martin-moyce"``);
    * ``report.json``: particle counts, resolution (Δx, h, m and how they were derived), steps, Δt,
      neighbours, throughput, particles outside the domain, the water budget (mass initial, added
      by each source, removed by each sink, in the fluid), the final front.
    """

    cfg: SPHScenario = scenario.config
    built = build(cfg)
    solver = built.solver
    r, p = cfg.run, cfg.sph
    callbacks: list = []
    if r.output_interval > 0:
        callbacks.append(cb.ParticleFrames(TimeInterval(r.output_interval), solver, out.path / "particles"))
    if cfg.probes or cfg.gauges:
        callbacks.append(
            cb.Probes(
                TimeInterval(r.sample_interval), solver, out.path / "gauges.csv",
                probes=[(q.name, q.position) for q in cfg.probes], gauges=[(g.name, g.position) for g in cfg.gauges],
                support=p.support(), spacing=p.spacing, mass=p.rho0 * p.spacing**p.dim, floor=cfg.domain.lo[-1],
                walls=[probe_wall(cfg, q.position) for q in cfg.probes], wall_pressures=wall_pressures,
            )
        )  # fmt: skip
    front = None
    if cfg.measure.front:
        origin = cfg.measure.front_origin if cfg.measure.front_origin is not None else min(b.lo[0] for b in cfg.fluid)
        compare = cfg.measure.compare == "martin-moyce"
        figure = None
        if compare:
            figure = martin_moyce_figure(
                out.path / "figures" / "front.png",
                column_width(cfg),
                abs(p.gravity_vector()[-1]),
                p.spacing,
                f"{scenario.name}: surge front",
            )
        front = cb.FrontTracker(TimeInterval(r.sample_interval), solver, out.path / "front.csv", spacing=p.spacing,
                                origin=origin, figure=figure)  # fmt: skip
        callbacks.append(front)
    if r.snapshots:
        callbacks.append(
            cb.Snapshots(
                TimeInterval(r.t_end / r.snapshots), solver, out.figures, lo=cfg.domain.lo, hi=cfg.domain.hi,
                spacing=p.spacing, title=scenario.name, g=abs(p.gravity_vector()[-1]),
            )
        )  # fmt: skip

    def report(sim) -> dict[str, Any]:
        return sph_report(cfg, solver, built.info, sim, front)

    def summary(sim, rep: dict) -> dict[str, Any]:
        return {
            "status": sim.status,
            "t": float(solver.t),
            "steps": int(solver.steps),
            "fluid_particles": solver.n_fluid,
            "boundary_particles": solver.n_boundary,
            **({"x_front": rep["x_front"]} if "x_front" in rep else {}),
            "wall_time_s": round(sim.wall_time, 2),
        }

    return Setup(
        models=[solver], callbacks=callbacks, stop_time=r.t_end, unit="s", report=report, summary=summary,
        checkpoint_wall_s=r.checkpoint_wall_s, seed=cfg.seed,
    )  # fmt: skip
