"""Validation: a tank of water at rest against the hydrostatic pressure p = ρ₀ g (H − z).

The ``hydrostatic`` scenario (2-D tank, water depth H) settles for ``t_end``; then, over all fluid
particles at the final state,

* RMS pressure error  sqrt(mean (p_i − ρ₀g(H − z_i))²) / (ρ₀gH)   < 2 %,
* density variation   max |ρ_i − ρ₀| / ρ₀                           < 1 %,
* particles outside the tank                                         = 0

(issue 2). z is measured from the tank floor; H is the initial water depth.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from erosim.core import atomic
from erosim.core.errors import ConfigError
from erosim.io.runfolder import RunFolder, default_out
from erosim.scenarios import loader
from erosim.scenarios.runner import execute
from erosim.validation import run_facts
from erosim.viz.plots import pressure_profile

P_THRESHOLD = 0.02
RHO_THRESHOLD = 0.01
# particles across the depth H, settling time (s)
RESOLUTIONS = {"coarse": (16, 0.6), "default": (40, 1.0), "fine": (80, 1.0)}


def errors(pos: np.ndarray, p: np.ndarray, rho: np.ndarray, *, rho0: float, g: float, H: float, lo, hi) -> dict:
    """The three measures of the module docstring."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    z = pos[:, -1] - lo[-1]
    p_exact = rho0 * g * (H - z)
    scale = rho0 * g * H
    return {
        "pressure_rms_rel": float(np.sqrt(np.mean((p - p_exact) ** 2)) / scale),
        "density_variation": float(np.max(np.abs(rho - rho0)) / rho0),
        "outside": int(np.count_nonzero(np.any((pos < lo) | (pos > hi), axis=1))),
    }


def run(resolution: str = "default", out: Path | None = None, progress: bool = True, device: str = "cpu") -> dict:
    """Run the case; writes ``validation.json`` and ``figures/pressure_profile.png`` (``device = "cuda"``:
    the SPH steps on the GPU)."""

    if resolution not in RESOLUTIONS:
        raise ConfigError(f"Unknown resolution '{resolution}'; use one of: {', '.join(RESOLUTIONS)}.")
    base = loader.load("hydrostatic")
    block = base.config.fluid[0]
    H = block.hi[-1] - block.lo[-1]
    n_h, t_end = RESOLUTIONS[resolution]
    scenario = loader.load(
        "hydrostatic",
        [
            f"sph.spacing={H / n_h!r}",
            f"run.t_end={t_end!r}",
            "run.output_interval=0.1",
            "run.snapshots=1",
            "run.checkpoint_wall_s=600.0",
            f"run.device={device}",
        ],
    )
    cfg = scenario.config
    g = abs(cfg.sph.gravity_vector()[-1])
    name = f"validate-hydrostatic-{resolution}" + ("-cuda" if device == "cuda" else "")
    folder = RunFolder(out if out is not None else default_out(name))
    wall0 = time.perf_counter()
    summary, sim = execute(scenario, folder, progress=progress)
    solver = sim.models[0]
    wall = time.perf_counter() - wall0

    pos, p, rho = solver.fluid_positions(), solver.fluid_pressure(), solver.fluid_density()
    e = errors(pos, p, rho, rho0=cfg.sph.rho0, g=g, H=H, lo=cfg.domain.lo, hi=cfg.domain.hi)
    fig = pressure_profile(
        folder.figures / "pressure_profile.png",
        pos[:, -1] - cfg.domain.lo[-1],
        p,
        rho0=cfg.sph.rho0,
        g=g,
        H=H,
        title=f"hydrostatic, dx = H/{n_h}, t = {solver.t:.3g} s: RMS {100 * e['pressure_rms_rel']:.2f} %",
    )
    passed = e["pressure_rms_rel"] < P_THRESHOLD and e["density_variation"] < RHO_THRESHOLD and e["outside"] == 0
    result = {
        "case": "hydrostatic",
        "metric": "RMS pressure error vs rho0*g*(H-z), relative to rho0*g*H, after settling",
        "value": e["pressure_rms_rel"],
        "threshold": P_THRESHOLD,
        "passed": bool(passed),
        "out": str(folder.path),
        "density_variation": e["density_variation"],
        "density_threshold": RHO_THRESHOLD,
        "particles_outside": e["outside"],
        "resolution": resolution,
        "device": device,
        "spacing": H / n_h,
        "particles_across_depth": n_h,
        "settling_time_s": float(solver.t),
        **run_facts(solver, summary, wall),
        "figure": str(fig.relative_to(folder.path)),
    }
    atomic.write_json(folder.path / "validation.json", result)
    return result
