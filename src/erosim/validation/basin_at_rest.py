"""Validation: a lake at rest in a heightmap bowl, with both ground models (issue 8).

The ``basin-at-rest`` scenario (a paraboloid bowl holding water to the level L) settles for
``t_end``; then, for the particle-free heightfield ground and for boundary particles under the same
surface, over every fluid particle:

* hydrostatic pressure  sqrt(mean (p_i − ρ₀g(L_p − z_i))²) / (ρ₀gH) < 3 %   (H the lake's depth),
  with L_p = median of p_i/(ρ₀g) + z_i, the surface the pressure field stands for;
* a flat free surface   max − min of the top of the water over the lake's inner cells ≤ Δx;
* the pressure's surface where the water's is:  |L_p − L_s| ≤ Δx, L_s the median top;
* particles below the ground = 0.

The top of the water in a cell is its highest particle + Δx/2; inner cells are those whose ground is
at least 2Δx below L (the thinning rim is left out). L_s sits a little below L: the initial lattice
leaves gaps against the curved ground that the water fills as it settles (``level_settled``).
The heightfield ground dissipates little, so the initial slump sloshes for a few seconds: the
settling time is 3 s.
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

P_THRESHOLD = 0.03
# spacing (m), settling time (s)
RESOLUTIONS = {"coarse": (0.06, 3.0), "default": (0.05, 3.0), "fine": (0.0375, 3.0)}
MODELS = ("heightfield", "particles")


def errors(pos: np.ndarray, p: np.ndarray, *, rho0: float, g: float, level: float, depth: float, raster,
           ground: np.ndarray, spacing: float) -> dict:  # fmt: skip
    """The measures of the module docstring (positions in the SPH frame)."""
    ix = np.clip(np.floor((pos[:, 0] - raster.x0) / raster.dx + 0.5).astype(int), 0, raster.nx - 1)
    iy = np.clip(np.floor((pos[:, 1] - raster.y0) / raster.dy + 0.5).astype(int), 0, raster.ny - 1)
    top = np.full(raster.shape, -np.inf)
    np.maximum.at(top, (iy, ix), pos[:, -1] + 0.5 * spacing)
    inner = (ground < level - 2 * spacing) & np.isfinite(top)
    if not inner.any():
        return {"pressure_rms_rel": float("inf"), "surface_range_m": float("inf"), "inner_cells": 0,
                "surface_mismatch_m": float("inf")}  # fmt: skip
    settled = float(np.median(top[inner]))
    head = p / (rho0 * g) + pos[:, -1]
    level_p = float(np.median(head))
    return {
        "pressure_rms_rel": float(np.sqrt(np.mean((head - level_p) ** 2)) / depth),
        "surface_range_m": float(np.ptp(top[inner])),
        "surface_mismatch_m": abs(level_p - settled),
        "level_initial": level,
        "level_settled": settled,
        "level_pressure": level_p,
        "inner_cells": int(inner.sum()),
    }


def run(resolution: str = "default", out: Path | None = None, progress: bool = True) -> dict:
    """Run the case with both ground models; writes ``validation.json`` and the pressure figures."""

    if resolution not in RESOLUTIONS:
        raise ConfigError(f"Unknown resolution '{resolution}'; use one of: {', '.join(RESOLUTIONS)}.")
    spacing, t_end = RESOLUTIONS[resolution]
    root = Path(out) if out is not None else default_out(f"validate-basin-at-rest-{resolution}")
    results, figures = {}, []
    wall0 = time.perf_counter()
    for model in MODELS:
        scenario = loader.load(
            "basin-at-rest",
            [f"sph.spacing={spacing!r}", f"run.t_end={t_end!r}", f"ground.model={model}", "run.map_frames=1"],
        )
        cfg = scenario.config
        folder = RunFolder(root / model)
        t0 = time.perf_counter()
        summary, sim = execute(scenario, folder, progress=progress)
        solver = sim.models[0]
        coupler = next(c for c in sim.callbacks if c.name == "coupler")
        level = cfg.water.level
        g = abs(cfg.sph.gravity_vector()[-1])
        depth = level - float(coupler.terrain.z.min())
        pos, p = solver.fluid_positions(), solver.fluid_pressure()
        e = errors(pos, p, rho0=cfg.sph.rho0, g=g, level=level, depth=depth, raster=coupler.terrain.raster,
                   ground=coupler.terrain.z, spacing=spacing)  # fmt: skip
        below = sim.out.path / "report.json"
        import json

        rep = json.loads(below.read_text())
        e["particles_below_ground"] = rep["particles_below_ground"]
        fig = pressure_profile(
            root / f"pressure_{model}.png", pos[:, -1] - (level - depth), p, rho0=cfg.sph.rho0, g=g, H=depth,
            title=f"basin at rest, {model} ground, dx = {spacing:g} m: RMS {100 * e['pressure_rms_rel']:.2f} %",
        )  # fmt: skip
        figures.append(str(Path(fig).relative_to(root)))
        e["passed"] = bool(
            e["pressure_rms_rel"] < P_THRESHOLD
            and e["surface_range_m"] <= spacing
            and e["surface_mismatch_m"] <= spacing
            and e["particles_below_ground"] == 0
        )
        e.update(run_facts(solver, summary, time.perf_counter() - t0))
        results[model] = e
    passed = all(r["passed"] for r in results.values())
    result = {
        "case": "basin-at-rest",
        "metric": "RMS of p - rho0*g*(L_p - z), relative to rho0*g*H, after settling (worst ground model)",
        "value": max(r["pressure_rms_rel"] for r in results.values()),
        "threshold": P_THRESHOLD,
        "passed": passed,
        "out": str(root),
        "resolution": resolution,
        "spacing": spacing,
        "settling_time_s": t_end,
        "ground_models": results,
        "surface_threshold_m": spacing,
        "figures": figures,
        "wall_time_s": round(time.perf_counter() - wall0, 2),
    }
    atomic.write_json(root / "validation.json", result)
    return result
