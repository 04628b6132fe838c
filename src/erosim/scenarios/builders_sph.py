"""Turn an :class:`~erosim.scenarios.schema_sph.SPHScenario` into particles and an SPH solver.

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
from erosim.scenarios.schema_sph import SPHScenario

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
    """Particles and an :class:`erosim.sph.solver.SPHSolver` for the scenario."""
    from erosim.sph.solver import SPHSolver  # Numba import only when a run starts

    pos, vel = fluid_particles(cfg)
    solver = SPHSolver(
        cfg.sph,
        pos,
        boundary_pos=None,
        domain_lo=np.asarray(cfg.domain.lo, dtype=np.float64),
        domain_hi=np.asarray(cfg.domain.hi, dtype=np.float64),
        obstacles=[(np.asarray(o.lo, float), np.asarray(o.hi, float)) for o in cfg.obstacles],
        fluid_vel=vel,
        seed=cfg.seed,
    )
    return Built(solver=solver, fluid_pos=pos, info=derivation(cfg, len(pos)))
