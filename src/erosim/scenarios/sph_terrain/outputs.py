"""What an `sph-terrain` run writes and reports: the terrain maps and the three-panel frames (terrain, water,
change on colour ranges fixed for the run), the check that no particle sinks below the ground, and the
report (water and sediment budgets, erosion and deposition).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from erosim.core.schedules import Schedule
from erosim.coupling.coupler import Coupler
from erosim.io import heightmaps as hio
from erosim.scenarios.sph_terrain.geometry import Geometry
from erosim.simulation import callbacks as cb
from erosim.viz.maps import save_png
from erosim.viz.plots import change_figure, extent_of, hillshade_figure, map_figure, profile_panel, terrain_panels


class BelowGround(cb.Callback):
    """Counts fluid particles below the ground (1 mm below the Q4 surface), keeps the most seen."""

    def __init__(self, schedule, solver, ground):
        super().__init__(schedule, name="below_ground")
        self.solver, self.ground = solver, ground
        self.most = 0

    def __call__(self, sim) -> None:
        self.most = max(self.most, self.now())

    def now(self) -> int:
        return self.ground.below(self.solver, tol=1e-3)

    def state_dict(self) -> dict[str, Any]:
        return {"most": self.most}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.most = int(state.get("most", 0))


class TerrainOutputs(cb.Callback):
    """The final maps (DEM grid), profile and pictures of a completed run."""

    def __init__(self, geo: Geometry, coupler: Coupler, eroder, panel, rain: np.ndarray | None = None):
        super().__init__(Schedule(), name="outputs")
        self.geo, self.coupler, self.eroder, self.panel = geo, coupler, eroder, panel
        self.rain = rain  # the rain's intensity per cell (mm/h, SPH frame), or None without rain

    def fields(self) -> dict[str, np.ndarray]:
        """Output fields in the SPH frame (rows northward)."""
        g, c = self.geo, self.coupler
        sediment = self.eroder.held_map() if self.eroder is not None else np.zeros_like(g.terrain)
        return {
            "height_initial": g.initial,
            "height": c.terrain.z,
            "water_depth": c.terrain.grid.depth,
            "max_water_depth": c.terrain.grid.max_depth,
            "erosion": np.maximum(g.initial - c.terrain.z, 0.0),
            "deposition": np.maximum(c.terrain.z - g.initial, 0.0),
            "sediment": sediment,
        }

    def finalize(self, sim) -> dict[str, Any]:
        out, g = sim.out, self.geo
        self.coupler.terrain.grid.bin(self.coupler.solver)  # the water as it is at the end
        fields = self.fields()

        with out.picture(out.figures / "maps_final.png"):
            save_png(out.figures / "maps_final.png", self.panel())
        if g.dim == 2:
            x = np.arange(g.raster.nx) * g.raster.dx
            cols = ["x"] + list(fields)
            rows = np.column_stack([x] + [f[0] for f in fields.values()])
            out.write_text("profile.csv", cb.csv_text(cols, rows))
            return {"outputs": {"profile": "profile.csv", "figure": "figures/maps_final.png"}}

        written = {}
        for name, arr in fields.items():
            mapped = np.ascontiguousarray(arr[::-1])
            hio.write(out.maps / f"{name}.tif", mapped, like=g.dem)
            written[name] = {"path": f"maps/{name}.tif", "min": float(mapped.min()), "max": float(mapped.max())}
        if self.rain is not None:  # the rain map (seed 000's fig. 20): where the drops fall, and how hard
            rain = np.ascontiguousarray(self.rain[::-1])
            hio.write_raster(out.maps / "rain.tif", rain.astype(np.float32), g.dem)
            written["rain"] = {"path": "maps/rain.tif", "min": float(rain.min()), "max": float(rain.max()),
                               "unit": "mm/h"}  # fmt: skip

        north_up = g.initial[::-1]
        box = extent_of(g.dem.transform if g.dem is not None else None, north_up.shape, g.raster.dx)
        after = self.coupler.terrain.z[::-1]
        with out.picture(out.figures / "hillshade_before.png"):
            hillshade_figure(out.figures / "hillshade_before.png", north_up, g.raster.dx, "Terrain before", box)
        with out.picture(out.figures / "hillshade_after.png"):
            hillshade_figure(out.figures / "hillshade_after.png", after, g.raster.dx, "Terrain after", box)
        with out.picture(out.figures / "erosion_deposition.png"):
            change_figure(out.figures / "erosion_deposition.png", after - north_up, g.raster.dx,
                          "Erosion and deposition", box)  # fmt: skip
        if self.rain is not None:
            bar = {"cmap": "Blues", "vmin": 0.0, "vmax": max(float(self.rain.max()), 1e-9), "label": "rain (mm/h)"}
            with out.picture(out.figures / "rain.png"):
                map_figure(out.figures / "rain.png", self.rain[::-1], g.raster.dx, "Rain map", colorbar=bar,
                           extent=box)  # fmt: skip
        return {"outputs": {"maps": written, "figure": "figures/maps_final.png"}}


#: the change panel's fixed scale, ± this share of the terrain's relief
CHANGE_RANGE_OF_RELIEF = 0.1


#: the water panel leaves out films thinner than this (m)
WATER_SHOWN_M = 1e-3


def panel_function(geo: Geometry, coupler: Coupler, title: str):
    """The picture of the terrain and water now (three panels; 2-D: the bed profile) as an RGB array."""

    # one scale for every frame's change panel: a tenth of the terrain's relief (at least a centimetre)
    relief = float(np.nanmax(geo.initial) - np.nanmin(geo.initial))
    change_range = max(CHANGE_RANGE_OF_RELIEF * relief, 0.01)
    # the water as the particles spread it: each particle's volume binned to its cell, then smoothed over a
    # particle's size (σ = Δx/2, at least a cell), so that scattered particles show as the sheet they are a part
    # of, not a cell-by-cell speckle (the picture only; maps/water_depth.tif keeps the binned depth)
    sigma = max(0.5 * coupler.solver.params.spacing / geo.raster.dx, 1.0)

    def panel() -> np.ndarray:
        c = coupler
        c.terrain.grid.bin(c.solver)
        t = f"{title}  t = {c.solver.t:.3g} s"
        if geo.dim == 2:
            x = np.arange(geo.raster.nx) * geo.raster.dx
            return profile_panel(x, geo.initial[0], c.terrain.z[0], c.terrain.grid.depth[0], title=t)
        from scipy.ndimage import gaussian_filter

        water = gaussian_filter(c.terrain.grid.depth, sigma, mode="constant")
        return terrain_panels(c.terrain.z[::-1], np.where(water >= WATER_SHOWN_M, water, 0.0)[::-1],
                              (c.terrain.z - geo.initial)[::-1], geo.raster.dx, title=t,
                              change_range=change_range)  # fmt: skip

    return panel


def terrain_report(cfg, geo: Geometry, solver, coupler: Coupler, eroder, below: BelowGround, front, derived, sim):
    """The ``sph-terrain`` kind's entries of ``report.json``."""
    st = solver.state
    vp = cfg.sph.spacing**geo.dim  # m³ of water at rest per particle (per unit width in 2-D: m²)
    added, removed = st.added, st.removed
    rained = added.get("rain", 0) * vp
    inflow = sum(v for k, v in added.items() if k.startswith("inflow:")) * vp
    left = sum(v for k, v in removed.items() if k.startswith("edge:")) * vp
    initial, now = st.initial * vp, st.n_fluid * vp
    supplied = initial + rained + inflow
    steps = sim.iteration - sim.iteration_start
    rep: dict[str, Any] = {
        "dim": geo.dim,
        "t": float(solver.t),
        "t_end": cfg.run.t_end,
        "steps": int(solver.steps),
        "fluid_particles": st.n_fluid,
        "ground": cfg.ground.model,
        "terrain": {
            "shape": list(geo.terrain.shape[::-1] if geo.dim == 2 else geo.terrain.shape),
            "cell_size_m": geo.raster.dx,
            "crs": geo.dem.crs if geo.dem is not None else None,
            "nodata_cells": int(geo.nodata.sum()) if geo.nodata is not None else 0,
            "z_min": float(geo.initial.min()),
            "z_max": float(geo.initial.max()),
        },
        "resolution": {"spacing": cfg.sph.spacing, "support_h": solver.h, "particle_volume_m3": vp, **derived},
        "water_budget": {
            "unit": "m3" if geo.dim == 3 else "m2 (per metre of width)",
            "initial": initial,
            "rained": rained,
            "inflow": inflow,
            "left_edges": left,
            "in_fluid": now,
            "closure_rel": abs(supplied - left - now) / supplied if supplied > 0 else 0.0,
        },
        "particles_below_ground": max(below.most, below.now()),  # the most seen at any check (0 expected)
        "particles_below_ground_now": below.now(),
        "dt_mean": float(solver.t) / solver.steps if solver.steps else None,
        "particle_steps_per_s": st.n_fluid * steps / sim.wall_time if sim.wall_time > 0 and steps else None,
        "coupling_wall_s": round(coupler.wall, 3),
        "coupling_fraction": coupler.wall / sim.wall_time if sim.wall_time > 0 else None,
    }
    if eroder is not None:
        sb = coupler.budget()
        held, carried, err = eroder.held_total(), eroder.carried_off(), eroder.transport_error
        eroded = sb["eroded"]
        rep["sediment_budget"] = {
            "unit": "m3" if geo.dim == 3 else "m2 (per metre of width)",
            "eroded": eroded,
            "deposited": sb["deposited"],
            "suspended": held,
            "carried_off": carried,
            "transport_error": err,
            "transport": cfg.erosion.transport,
            "couplings": sb["couplings"],
            "closure_rel": abs(eroded - sb["deposited"] - held - carried + err) / eroded if eroded > 0 else 0.0,
        }
    if front is not None and front.rows:
        rep["x_front"] = front.rows[-1][1]
    return rep
