"""What a `flood` run writes and reports: the hazard maxima tracked over the run, the release check (a
reservoir that releases under 1 % of its volume is named), the gauges, the maps (`max_depth`,
`max_speed`, `max_dv`, `arrival_time`, `hazard`) on the DEM's grid and the depth picture.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from erosim.analysis.hazard import HazardMaps
from erosim.core.atomic import write_text
from erosim.core.schedules import IterationInterval, Schedule, TimeInterval
from erosim.io.heightmaps import write_raster
from erosim.io.runfolder import RunFolder
from erosim.scenarios.flood.site import FloodSetUp
from erosim.simulation import callbacks as cb
from erosim.sph.shallow_water_vacondio2012 import ShallowWaterSPH
from erosim.viz.flood import plot_flood_maps, plot_hazard
from erosim.viz.maps import colormap, hillshade

#: a reservoir that releases less than this share of its volume in the first tenth of the run is warned of
SLOW_RELEASE = 0.01


class HazardTracker(cb.Callback):
    """Raises the hazard maxima and arrival times every step (their arrays travel in the checkpoint)."""

    def __init__(self, solver: ShallowWaterSPH, maps: HazardMaps):
        super().__init__(IterationInterval(1), name="hazard")
        self.solver, self.maps = solver, maps
        solver.update_maxima(maps, maps.wet_depth)  # the reservoir itself at t = 0

    def __call__(self, sim) -> None:
        self.solver.update_maxima(self.maps, self.maps.wet_depth)

    def state_dict(self) -> dict[str, Any]:
        self.solver.sync_maxima(self.maps)
        return self.maps.state_dict()

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if state:
            self.maps.load_state_dict(state)


class ReleaseCheck(cb.Callback):
    """Warns when the reservoir has released less than :data:`SLOW_RELEASE` of its volume by a tenth of
    the run: the water beyond the reservoir's cells widened by a particle spacing (at least two cells,
    so that a shore's particles moving as the water settles do not count) and through the open edges,
    less what was there at t = 0, over the initial volume."""

    def __init__(self, solver, site: FloodSetUp, t_end: float, out):
        from scipy import ndimage

        super().__init__(TimeInterval(0.1 * t_end), name="release")
        self.solver, self.site, self.out = solver, site, out
        widen = max(2, math.ceil(solver.spacing / site.dem.cell_size))
        self.held = ndimage.binary_dilation(site.depth0 > 0, iterations=widen)
        self.outside0: float | None = None
        self.released: float | None = None
        self.at = 0.0  # the time it was measured

    def _outside(self) -> float:
        pos, vol = _particles_on_grid(self.solver)
        cs = self.site.dem.cell_size
        ny, nx = self.held.shape
        col = np.clip(np.floor(pos[:, 0] / cs + 0.5).astype(np.int64), 0, nx - 1)
        row = np.clip(np.floor(pos[:, 1] / cs + 0.5).astype(np.int64), 0, ny - 1)
        return float(vol[~self.held[row, col]].sum()) + float(self.solver.budget()["volume_out_m3"])

    def __call__(self, sim) -> None:
        if self.outside0 is None:
            self.outside0 = self._outside()
        elif self.released is None:
            self.released = (self._outside() - self.outside0) / self.solver.volume_initial
            self.at = float(sim.time)
            warning = self.warning()
            if warning is not None:
                self.out.warn(warning)
                if sim.progress:
                    print(f"{sim.label}: warning: {warning}", file=sys.stderr, flush=True)

    def warning(self) -> str | None:
        if self.released is None or self.released >= SLOW_RELEASE:
            return None
        t = self.at
        return (
            f"The reservoir released only {100 * max(self.released, 0.0):.2g} % of its "
            f"{self.solver.volume_initial:,.0f} m³ in the first {t:.4g} s (a tenth of the run): the dam opens "
            "little below reservoir.level or the ground beyond is high; check breach.line, breach.bottom_width "
            "and breach.floor (or reservoir.barrier) if a dam break was meant."
        )

    def state_dict(self) -> dict[str, Any]:
        state = {}
        if self.outside0 is not None:
            state["outside0"] = np.asarray(self.outside0)
        if self.released is not None:
            state["released"] = np.asarray([self.released, self.at])
        return state

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if "outside0" in state:
            self.outside0 = float(state["outside0"])
        if "released" in state:
            self.released, self.at = (float(v) for v in np.asarray(state["released"]))
            warning = self.warning()
            if warning is not None:  # the resumed run's report keeps it
                self.out.warn(warning)


def _particles_on_grid(solver) -> tuple[np.ndarray, np.ndarray]:
    """(positions in the cell frame, volumes) of a flood solver's water particles."""
    if hasattr(solver, "pos"):  # the shallow-water solvers
        return np.asarray(solver.pos), np.asarray(solver.vol)
    inner = solver.solver  # the 3-D SPH flood: the SPH frame (y north from the south-west node)
    st, n = inner.state, inner.n_fluid
    ny = solver.site.terrain.shape[0]
    pos = np.column_stack([st.pos[:n, 0], (ny - 1) * solver.cell - st.pos[:n, 1]])
    return pos, inner.m / st.rho[:n]


class FloodGauges(cb.Callback):
    """Free-surface elevation, depth and speed at the gauges every ``run.sample_interval``."""

    def __init__(self, schedule, solver: ShallowWaterSPH, names: list[str], points: np.ndarray, path: Path):
        super().__init__(schedule, name="gauges")
        self.solver, self.names, self.points, self.path = solver, names, points, path
        self.rows: list[list[float]] = []

    def __call__(self, sim) -> None:
        eta, depth, speed = self.solver.sample(self.points)
        self.rows.append([self.solver.t, *eta, *depth, *speed])

    def state_dict(self) -> dict[str, Any]:
        return {"rows": np.asarray(self.rows, np.float64)} if self.rows else {}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.rows = [list(r) for r in state["rows"]] if "rows" in state else []

    def flush(self, sim) -> None:

        header = ["t", *(f"eta_{n}" for n in self.names), *(f"depth_{n}" for n in self.names)]
        header += [f"speed_{n}" for n in self.names]
        write_text(self.path, cb.csv_text(header, self.rows))

    def summary(self, wet: float) -> dict[str, Any]:
        rows = np.asarray(self.rows, np.float64).reshape(-1, 1 + 3 * len(self.names))
        out = {}
        k = len(self.names)
        for i, name in enumerate(self.names):
            eta, depth = rows[:, 1 + i], rows[:, 1 + k + i]
            wet_at = np.flatnonzero(depth >= wet)
            out[name] = {
                "max_eta": float(eta.max()) if len(rows) else None,
                "max_depth": float(depth.max()) if len(rows) else None,
                "arrival_s": float(rows[wet_at[0], 0]) if len(wet_at) else None,
            }
        return out


class FloodOutputs(cb.Callback):
    """Maps and figures of the run on the DEM's grid (at the end)."""

    def __init__(self, site: FloodSetUp, solver: ShallowWaterSPH, maps: HazardMaps, inside):
        super().__init__(Schedule(), name="outputs")
        self.site, self.solver, self.maps, self.inside = site, solver, maps, inside

    def finalize(self, sim) -> dict[str, Any]:
        self.solver.sync_maxima(self.maps)
        write_flood_maps(sim.out, self.site, self.solver, self.maps, self.inside)
        return {}


def write_flood_maps(out: RunFolder, site: FloodSetUp, solver: ShallowWaterSPH, maps: HazardMaps, inside) -> None:
    """The hazard maps as GeoTIFFs on the DEM's grid, and their figures (each picture guarded: one that
    cannot be drawn is a warning, never the loss of the maps)."""

    hm = site.terrain
    nodata = hm.nodata if hm.nodata is not None else np.zeros(hm.shape, bool)
    wet = maps.max_depth >= maps.wet_depth
    folder = out.maps
    for name, arr in (("max_depth", maps.max_depth), ("max_speed", maps.max_speed), ("max_dv", maps.max_dv)):
        write_raster(folder / f"{name}.tif", np.where(nodata, np.nan, arr).astype(np.float32), hm, nodata=np.nan)
    arrival = np.where(wet & ~nodata & np.isfinite(maps.arrival), maps.arrival, np.nan)
    write_raster(folder / "arrival_time.tif", arrival.astype(np.float32), hm, nodata=np.nan)
    classes = np.where(nodata, 255, maps.classes()).astype(np.uint8)
    write_raster(folder / "hazard.tif", classes, hm, nodata=255)
    depth = solver.depth_grid()
    write_raster(folder / "depth_final.tif", np.where(nodata, np.nan, depth).astype(np.float32), hm, nodata=np.nan)
    write_raster(folder / "height.tif", np.where(nodata, np.nan, hm.z).astype(np.float32), hm, nodata=np.nan)

    shares = maps.summary(hm.cell_size**2, inside)
    draw = {
        "flood_maps.png": lambda p: plot_flood_maps(p, hm, maps),
        "hazard.png": lambda p: plot_hazard(p, hm, maps.classes(), shares),
    }
    for name, picture in draw.items():
        with out.picture(out.figures / name):
            picture(out.figures / name)


def depth_picture(site: FloodSetUp, solver: ShallowWaterSPH):

    hm = site.terrain
    shade = hillshade(hm.z, hm.cell_size)
    vmax = max(float(site.depth0.max()), 1e-3)
    step = max(1, int(math.ceil(max(hm.shape) / 400)))  # thumbnails of at most ~400 px

    def picture(sim) -> np.ndarray:
        d = solver.depth_grid()[::step, ::step]
        rgb = colormap(np.minimum(d, vmax), "Blues", vmin=0.0, vmax=vmax).astype(np.float64)
        base = np.repeat(shade[::step, ::step, None], 3, axis=2).astype(np.float64)
        if base.max() <= 1.0:
            base = base * 255.0
        a = np.clip(d / (0.2 * vmax), 0.0, 1.0)[..., None] * (d >= 0.01)[..., None]
        return (base * (1 - a) + rgb[..., :3] * a).astype(np.uint8)

    return picture
