"""What a `splash` run writes and reports: particle and wetness frames, the final maps (terrain, change,
wetness, standing water, water depth) on the DEM's grid, the crater's measures and the report.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from erosim.core.atomic import write_text
from erosim.core.schedules import Schedule
from erosim.coupling.binning import FluidGrid
from erosim.coupling.puddles import hollow_depth, standing_water, water_depth
from erosim.coupling.splash_coupler import WetGround
from erosim.erosion import splash as sp
from erosim.erosion.wet_strength import strength
from erosim.io import heightmaps as hio
from erosim.io.particles import FrameSeries
from erosim.scenarios.splash.schema import SplashScenario
from erosim.simulation import callbacks as cb
from erosim.viz import splash as vs
from erosim.viz.plots import change_figure, extent_of
from erosim.viz.splash import wetness_frames_figure


class SplashFrames(cb.ParticleFrames):
    """Fluid frames with each particle's water share, mud concentration and mixture density, and the
    ground particles' saturation (``particles/ground.pvd``)."""

    def __init__(self, schedule, solver, wet: WetGround, folder: Path):
        super().__init__(schedule, solver, folder)

        self.wet = wet
        self.ground_series = FrameSeries(self.folder / "ground", name="ground")

    def __call__(self, sim) -> None:
        s, w = self.fluid, self.wet
        fields = {
            "velocity": s.fluid_velocities().astype(np.float32),
            "water": s.fluid_field("water").astype(np.float32),
            "mud": s.fluid_field("mud").astype(np.float32),
            "mixture_density": s._fluid(w.mud_density()).astype(np.float32),
        }
        self.series.write(float(s.t), s.fluid_positions().astype(np.float32), fields)
        g = w.ground
        fields = {"saturation": g.theta.astype(np.float32), "porosity": g.porosity.astype(np.float32),
                  "strength": g.strength(w.sigma_dry, w.sigma_wet).astype(np.float32)}  # fmt: skip
        self.ground_series.write(float(s.t), g.pos.astype(np.float32), fields)

    def state_dict(self) -> dict[str, Any]:
        return {**super().state_dict(), "ground_frames": [list(f) for f in self.ground_series.frames]}

    def load_state_dict(self, state: dict[str, Any]) -> None:

        super().load_state_dict(state)
        self.ground_series = FrameSeries(self.folder / "ground", name="ground", frames=state.get("ground_frames", []))


class WetnessFrames(cb.Callback):
    """``maps/frames/wetness_N.tif`` and ``height_N.tif`` (the DEM's grid) with ``frames.json``; small
    copies of the wetness for the frames figure travel in the checkpoint."""

    def __init__(self, schedule, geo, wet: WetGround, folder: Path):
        super().__init__(schedule, name="wetness_frames")
        self.geo, self.wet, self.folder = geo, wet, Path(folder)
        self.times: list[float] = []
        self.thumbs: list[np.ndarray] = []

    def __call__(self, sim) -> None:

        k = len(self.times)
        wet = self.wet.wetness()[::-1]
        hio.write_raster(self.folder / f"wetness_{k:05d}.tif", wet.astype(np.float32), self.geo.dem)
        hio.write(self.folder / f"height_{k:05d}.tif", np.ascontiguousarray(self.wet.terrain[::-1]), like=self.geo.dem)
        self.times.append(float(self.wet.solver.t))
        write_text(self.folder / "frames.json", json.dumps({"times": self.times}))
        step = max(1, max(wet.shape) // 96)
        self.thumbs.append(np.ascontiguousarray(wet[::step, ::step], dtype=np.float32))

    def state_dict(self) -> dict[str, Any]:
        return {"times": np.array(self.times), "thumbs": np.array(self.thumbs, np.float32)}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.times = np.asarray(state.get("times", [])).tolist()
        self.thumbs = list(np.asarray(state.get("thumbs", np.zeros((0, 1, 1), np.float32))))

    def finalize(self, sim) -> dict[str, Any]:
        if not self.thumbs:
            return {}

        path = sim.out.figures / "wetness_frames.png"
        with sim.out.picture(path):
            wetness_frames_figure(path, self.thumbs, self.times)
        figure = "figures/wetness_frames.png"
        return {"wetness_frames": {"count": len(self.times), "folder": "maps/frames", "figure": figure}}


class SplashOutputs(cb.Callback):
    """The final maps (the DEM's grid) and figures."""

    def __init__(self, geo, wet: WetGround, grid: FluidGrid, drop: bool):
        super().__init__(Schedule(), name="outputs")
        self.geo, self.wet, self.grid, self.drop = geo, wet, grid, drop

    def finalize(self, sim) -> dict[str, Any]:

        out, g, w = sim.out, self.geo, self.wet
        z = w.terrain
        puddles = standing_water(w, g.raster, hollow_depth(z))
        if g.nodata is not None:
            puddles[g.nodata] = 0.0  # outside the terrain (the map keeps it as nodata)
        fields = {
            "height": z,
            "height_initial": g.initial,
            "erosion": np.maximum(g.initial - z, 0.0),
            "deposition": np.maximum(z - g.initial, 0.0),
            "wetness": w.wetness(),
            "puddles": puddles,
            "water_depth": water_depth(w, g.raster),
        }
        written = {}
        for name, arr in fields.items():
            mapped = np.ascontiguousarray(arr[::-1])
            if name.startswith("height"):
                hio.write(out.maps / f"{name}.tif", mapped, like=g.dem)
            else:
                hio.write_raster(out.maps / f"{name}.tif", mapped.astype(np.float32), g.dem)
            written[name] = {"path": f"maps/{name}.tif", "min": float(mapped.min()), "max": float(mapped.max())}
        info = hio.write(out.maps / "wetness.png", np.ascontiguousarray(fields["wetness"][::-1]), like=g.dem,
                         height_range=(0.0, 1.0))  # fmt: skip
        written["wetness_png16"] = {"path": "maps/wetness.png", "range": info.get("height_range", [0.0, 1.0])}
        cell = g.raster.dx

        box = None if self.drop else extent_of(g.dem.transform, g.initial.shape, cell)

        draw = {
            "wetness.png": lambda p: vs.wetness_figure(p, fields["wetness"][::-1], cell, "Surface wetness θ", box),
            "erosion_deposition.png": lambda p: change_figure(p, (z - g.initial)[::-1], cell,
                                                              "Erosion and deposition", box),
            **({"crater.png": lambda p: vs.crater_profile_figure(p, g, z)} if self.drop
               else {"puddles.png": lambda p: vs.puddles_figure(p, puddles[::-1], cell, box)}),
        }  # fmt: skip
        figs = []
        for name, picture in draw.items():
            with out.picture(out.figures / name):
                picture(out.figures / name)
                figs.append(f"figures/{name}")
        standing = {
            "volume_m3": float(puddles.sum() * g.raster.cell_area),
            "area_m2": float((puddles > 0).sum() * g.raster.cell_area),
            "max_depth_m": float(puddles.max()),
        }
        return {"outputs": {"maps": written, "figures": figs}, "puddles": standing}


def crater_measure(geo, terrain: np.ndarray) -> dict[str, float]:
    """Depth (m) of the deepest point below the initial ground, and the radius (m) of the circle of the
    pit's area (nodes lowered by more than 1 % of that depth): the crater's a_p as measured."""
    change = geo.initial - terrain
    depth = float(change.max())
    if depth <= 0:
        return {"depth": 0.0, "radius": 0.0}
    area = float((change > 0.01 * depth).sum()) * geo.raster.cell_area
    return {"depth": depth, "radius": math.sqrt(area / math.pi)}


def surface_wetness(wet: WetGround, geo) -> dict[str, float]:
    """Mean and largest surface saturation over the terrain's nodes (nodata left out)."""
    theta = wet.wetness()
    if geo.nodata is not None:
        theta = theta[~geo.nodata]
    return {"mean": float(theta.mean()), "max": float(theta.max())}


def splash_report(cfg: SplashScenario, geo, dx: float, solver, wet: WetGround, sim) -> dict[str, Any]:
    """The ``splash`` kind's entries of ``report.json``."""
    imp = np.array(wet.impacts, np.float64).reshape(-1, 8)
    rep: dict[str, Any] = {
        "t": float(solver.t),
        "t_end": cfg.run.t_end,
        "steps": int(solver.steps),
        "fluid_particles": solver.n_fluid,
        "terrain": {
            "shape": list(geo.terrain.shape),
            "cell_size_m": geo.raster.dx,
            "crs": geo.dem.crs if geo.dem is not None else None,
        },  # fmt: skip
        "resolution": {
            "fluid_spacing_m": dx,
            "particle_radius_m": wet.radius,
            "ground_spacing_m": wet.ground.s,
            "ground_particles": wet.ground.n,
            "support_h_m": solver.h,
            "sound_speed_m_s": solver.c,
        },  # fmt: skip
        "water_budget": wet.water_budget(),
        "solid_budget": wet.solid_budget(),
        "impacts": {
            "count": wet.n_impacts,
            "mean_speed_m_s": float(imp[:, 3].mean()) if len(imp) else None,
            "mean_depth_m": float(imp[:, 6].mean()) if len(imp) else None,
            "first": dict(
                zip(("t", "x", "y", "speed", "theta", "sigma", "depth", "radius"), imp[0].tolist(), strict=True)
            )
            if len(imp)
            else None,  # fmt: skip
        },
        "surface_wetness": surface_wetness(wet, geo),
        "wall_cost": wet.costs(sim),
        "couplings": wet.calls,
        "removed": {k: v for k, v in solver.state.removed.items()},
    }
    if cfg.drop is not None:
        d = cfg.drop
        m = crater_measure(geo, wet.terrain)
        theta = cfg.ground.saturation
        sigma = float(strength(theta, cfg.ground.sigma_dry, cfg.ground.sigma_wet))
        v_hit = float(imp[0, 3]) if len(imp) else d.speed
        law_d = float(sp.crater_depth(d.radius, v_hit, solver.params.rho0, sigma))
        rep["crater_depth_m"] = m["depth"]
        rep["crater_width_m"] = m["radius"]
        rep["crater_diameter_m"] = 2.0 * m["radius"]
        rep["crater_law"] = {
            "radius_m": d.radius,
            "impact_speed_m_s": v_hit,
            "saturation": theta,
            "sigma_pa": sigma,
            "depth_m": law_d,
            "width_m": float(sp.crater_radius(d.radius, law_d)),
            "note": "d_p = R v √(2ρ_f/(9σ_s)), a_p = √(2R d_p − d_p²) for the first drop; the measured crater "
            "sums every drop's",
        }
    return rep
