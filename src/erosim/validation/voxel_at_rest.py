"""Validation: water at rest in a voxel tank, every wall particle-free (issue 10; SPEC VX-3 … VX-5).

The tank is one :class:`~erosim.terrain.voxel.VoxelTerrain` (the union of half-spaces, less a ball):
vertical walls at x = 0, y = 0 and y = W, the floor z = 0, a 45° wall rising from x = X45 and a
spherical bowl of radius R sunk into the floor; all act on the fluid through
:class:`~erosim.sph.boundaries.voxel_wall.VoxelWall` (Harada et al. 2007 wall weights at the field's
distance). The water, filled to depth D on the lattice of spacing Δx and started hydrostatically
(``initial_pressure = "hydrostatic-consistent"``: each particle deeper than h also starts short by its
kernel sum's shortfall against the lattice's, fluid neighbours plus the wall's share, so that the lattice
rows that do not fit the bowl, the slope and the concave edges settle into their gaps without turning the
gaps into over-pressure; :meth:`erosim.sph.solver.SPHSolver._kernel_shortfall`), settles for ``t_end``;
over the last ``window`` seconds the piezometric head of each particle, p_i/(ρ₀g) + z_i, is averaged
(the pressure rings acoustically about its mean), and

* hydrostatic pressure  sqrt(mean (p̄_i − ρ₀g(L_p − z̄_i))²) / (ρ₀gH) < 3 %, L_p the median head
  (the level the pressure field stands for) and H = L_p − the bowl's bottom, the deepest water;
* density next to the walls  max |ρ_i − ρ₀|/ρ₀ < 1 % over the particles within the support h of a
  wall (where a missing wall contribution would leave about half of ρ₀);
* particles inside the solid = 0 after every step.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from erosim.core import atomic
from erosim.core.errors import ConfigError
from erosim.io.runfolder import default_out
from erosim.scenarios import estimate
from erosim.simulation.progress import ProgressBar
from erosim.sph.boundaries.voxel_wall import VoxelWall
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver
from erosim.terrain.voxel import HalfSpace, Sphere, VoxelTerrain
from erosim.viz.plots import pressure_profile

P_THRESHOLD = 0.03
RHO_THRESHOLD = 0.01
# tank (m): length, width, 45° wall's foot, water depth, bowl radius and centre x, bowl depth
L, W, X45, DEPTH, R, XB, SINK = 0.36, 0.12, 0.24, 0.16, 0.1, 0.11, 0.04
# spacing (m), settling time (s), averaging window (s)
RESOLUTIONS = {"coarse": (0.02, 1.5, 0.3), "default": (0.01, 2.0, 0.25), "fine": (0.0075, 2.0, 0.25)}


def tank(cell: float, pad: float = 0.08):
    """The solid of the module docstring on voxels of ``cell`` (m), the grid starting ``pad`` (m) outside the
    walls (at 8 cm the fine grid's nodes lie 2/3 of a cell off them, the others' on them)."""

    walls = [HalfSpace((0, 0, 0), (0, 0, 1)), HalfSpace((0, 0, 0), (1, 0, 0)), HalfSpace((0, 0, 0), (0, 1, 0)),
             HalfSpace((0, W, 0), (0, -1, 0)), HalfSpace((X45, 0, 0), (-1, 0, 1))]  # fmt: skip
    solid = VoxelTerrain.from_shapes(walls, (-pad, -pad, -pad), (L + pad, W + pad, DEPTH + 0.1), cell)
    return solid.difference(Sphere((XB, 0.5 * W, R - SINK), R))


def errors(head: np.ndarray, z: np.ndarray, rho: np.ndarray, l: np.ndarray, *, rho0: float, h: float,
           bottom: float) -> dict:  # fmt: skip
    """The measures of the module docstring from the averaged heads and heights, the densities and wall distances."""
    level = float(np.median(head))
    depth = level - bottom
    near = l < h
    return {
        "pressure_rms_rel": float(np.sqrt(np.mean((head - level) ** 2)) / depth),
        "near_wall_density_dev": float(np.max(np.abs(rho[near] / rho0 - 1.0))) if near.any() else float("inf"),
        "near_wall_particles": int(near.sum()),
        "level_pressure": level,
        "depth": depth,
    }


def run(resolution: str = "default", out: Path | None = None, progress: bool = True,
        start: str = "hydrostatic-consistent") -> dict:  # fmt: skip
    """Run the case; writes ``validation.json`` and ``pressure.png`` (pressure against height, with the
    hydrostatic line) into ``out``. ``start`` is the solver's ``initial_pressure`` (the lattice's start made
    consistent with the walls by default; ``"hydrostatic"`` for the plain hydrostatic start)."""

    if resolution not in RESOLUTIONS:
        raise ConfigError(f"Unknown resolution '{resolution}'; use one of: {', '.join(RESOLUTIONS)}.")
    dx, t_end, window = RESOLUTIONS[resolution]
    root = Path(out) if out is not None else default_out(f"validate-voxel-at-rest-{resolution}")
    wall0 = time.perf_counter()
    vt = tank(dx)
    fluid = vt.fluid_points(dx, below=DEPTH)
    wall = VoxelWall(vt)
    prm = SPHParams(dim=3, spacing=dx, walls="reflect", initial_pressure=start)
    s = SPHSolver(prm, fluid, domain_lo=vt.lo, domain_hi=vt.hi, boundaries=[wall])
    rho0, g = s.params.rho0, 9.81
    inside_max = 0
    heads, zs = [], []
    if progress:

        guess = estimate.from_solver(f"a tank of {vt.shape[2]} × {vt.shape[1]} × {vt.shape[0]} voxels", s, t_end,
                                     speed=0.0, rate=estimate.VOXEL_STEPS_PER_CORE_S,
                                     step_extra_s=estimate.VOXEL_STEP_S - estimate.SPH_STEP_S)  # fmt: skip
        print(f"voxel-at-rest: {guess.line()}", file=sys.stderr, flush=True)

    with ProgressBar(t_end, "voxel-at-rest", unit="s", enabled=progress) as bar:
        while s.t < t_end:
            s.step()
            inside_max = max(inside_max, wall.inside(s))
            if s.t > t_end - window and s.steps % 10 == 0:
                z = s.fluid_positions()[:, 2]
                heads.append(s.fluid_pressure() / (rho0 * g) + z)
                zs.append(z)
            bar.update(float(s.t), int(s.steps))
    head, z = np.mean(heads, axis=0), np.mean(zs, axis=0)  # the same particle in every sample
    l = s.in_label_order(wall.distances(s)[0])  # the getters' order, as the densities
    e = errors(head, z, s.fluid_density(), l, rho0=rho0, h=s.h, bottom=-SINK)
    e["particles_inside_max"] = int(inside_max)
    passed = bool(e["pressure_rms_rel"] < P_THRESHOLD and e["near_wall_density_dev"] < RHO_THRESHOLD
                  and inside_max == 0)  # fmt: skip
    root.mkdir(parents=True, exist_ok=True)
    p_mean = rho0 * g * (head - z)
    fig = pressure_profile(
        root / "pressure.png", z + SINK, p_mean, rho0=rho0, g=g, H=e["depth"],
        title=f"voxel tank at rest, dx = {dx:g} m: RMS {100 * e['pressure_rms_rel']:.2f} % of ρ₀gH",
    )  # fmt: skip
    result = {
        "case": "voxel-at-rest",
        "metric": "RMS of p - rho0*g*(L_p - z), time-averaged, relative to rho0*g*H (H to the bowl's bottom)",
        "value": e["pressure_rms_rel"],
        "threshold": P_THRESHOLD,
        "density_threshold": RHO_THRESHOLD,
        "passed": passed,
        "out": str(root),
        "resolution": resolution,
        "spacing": dx,
        "settling_time_s": t_end,
        "initial_pressure": start,
        "averaging_window_s": window,
        **e,
        "fluid_particles": int(s.n_fluid),
        "boundary_particles": int(s.n_boundary),
        "steps": int(s.steps),
        "figures": [str(Path(fig).relative_to(root))],
        "wall_time_s": round(time.perf_counter() - wall0, 2),
    }
    atomic.write_json(root / "validation.json", result)
    return result
