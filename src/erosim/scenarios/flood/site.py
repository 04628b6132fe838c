"""The flood's site, shared by every flood solver: the DEM with its nodata walls, the breach cut, the
barrier, and the reservoir filled from its seed to its level (SPEC FL-1).
"""

from __future__ import annotations

import math

import numpy as np

from erosim.core.errors import InputError
from erosim.core.heightmap import cell_of, default_transform, fractional_cell
from erosim.io.gauge_points import read_gauge_points
from erosim.scenarios.flood.schema import FloodScenario
from erosim.scenarios.schema_common import build_terrain
from erosim.sph.kernels_swe import bed_at
from erosim.sph.shallow_water_vacondio2012 import equal_volumes
from erosim.terrain.reservoir import barrier_mask, cut_breach, fill_reservoir


def format_point(p) -> str:
    return "[" + ", ".join(f"{float(v):.10g}" for v in p) + "]"


class FloodSetUp:
    """The DEM with the breach cut in, the walls, and the reservoir's water (map order, row 0 north)."""

    def __init__(self, cfg: FloodScenario):
        hm = build_terrain(cfg.terrain, cfg.seed)
        if hm.transform is None:
            hm = hm.copy()
            hm.transform = default_transform(*hm.shape, hm.cell_size)
        self.dem = hm
        res = cfg.reservoir
        barrier = barrier_mask(hm, res.barrier) if res.barrier is not None else None
        if barrier is not None and not barrier.any():
            x0, x1, y0, y1 = hm.extent
            raise InputError(
                f"reservoir.barrier [{', '.join(format_point(p) for p in res.barrier)}] has no segment over the DEM "
                f"(x {x0:.10g}..{x1:.10g}, y {y0:.10g}..{y1:.10g}); draw the dam's line across the valley in the "
                "DEM's coordinates."
            )
        self.depth0 = fill_reservoir(hm, res.level, res.seed, barrier=barrier, open_edges=cfg.outflow.edges)
        self.terrain = cut_breach(hm, cfg.breach) if cfg.breach is not None else hm
        nodata = hm.nodata if hm.nodata is not None else np.zeros(hm.shape, bool)
        wall = nodata.copy()
        if barrier is not None and cfg.breach is not None:
            # the window: where the breach, cut into ground higher than anything, lies below the level
            probe = cut_breach(hm.copy(z=np.full(hm.shape, res.level + 1e6)), cfg.breach).z < res.level
            wall |= barrier & ~probe
        self.wall = wall
        self.barrier = barrier
        self.level = float(res.level)
        self.closed_hollow = self._closed_hollow(res.seed, cfg)
        self.gauges = None  # (name, x, y) of each gauge: a bad file is refused here, before anything settles
        if cfg.gauges.file:

            self.gauges = read_gauge_points(cfg.gauges.file, self.terrain)

    def _closed_hollow(self, seed, cfg: FloodScenario) -> str | None:
        """The warning sentence when no open edge, barrier or breach lets the reservoir's water out: the
        connected water below the level on the breached DEM (its walls kept) is the reservoir itself."""
        from scipy import ndimage


        hm = self.terrain
        below = (hm.z < self.level) & ~self.wall & hm.valid
        labels, _ = ndimage.label(below)  # 4-connected, as the fill
        row, col = cell_of(self.dem, float(seed[0]), float(seed[1]))
        reach = labels == labels[row, col]
        if reach.sum() > (self.depth0 > 0).sum():
            return None
        area = (self.depth0 > 0).sum() * hm.cell_size**2
        if self.barrier is None:
            why = "it has no reservoir.barrier"
        elif not (ndimage.binary_dilation(self.depth0 > 0) & self.barrier).any():
            why = "reservoir.barrier does not touch it"
        elif cfg.breach is None:
            why = "the ground under reservoir.barrier is above the level where it holds the water"
        else:
            why = "the breach does not open reservoir.barrier below the level where it holds the water"
        return (
            f"The reservoir at level {self.level:.10g} m fills a closed hollow of {area:,.0f} m² from the seed "
            f"{format_point(seed)} and {why}, so no water leaves it and the maps show a lake; draw reservoir.barrier "
            "across the valley where the water is held (and a breach through it), or raise reservoir.level."
        )

    def particles(self, spacing: float, bed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Particles of equal volume over the reservoir (solver's cell frame) and their volumes.

        Equal volumes, so that no arrangement of particles holds potential energy the water does not
        (with volumes ∝ depth the discrete system lowers its energy by sorting heavy particles into
        the deep water, and a lake never comes to rest). Their number density follows the depth: the
        points of a fine lattice (spacing s·√(d̄/d_max)) are kept with chance d/d_max
        (:func:`~erosim.sph.shallow_water_vacondio2012.equal_volumes`), so the spacing is ``spacing``
        where the depth is the mean depth d̄. The column d is the level minus ``bed`` (the C¹ surface
        the solver feels, walls raised); the particles share the reservoir's volume on the DEM,
        Σ (level − z)·Δ², exactly.
        """

        cs = self.dem.cell_size
        ny, nx = self.dem.shape
        d_mean = float(self.depth0[self.depth0 > 0].mean())
        d_max = float(self.depth0.max())
        fine = spacing * max(math.sqrt(d_mean / d_max), 0.25)
        xs = np.arange(-0.5 * cs + 0.5 * fine, (nx - 0.5) * cs, fine)
        ys = np.arange(-0.5 * cs + 0.5 * fine, (ny - 0.5) * cs, fine)
        x, y = (a.ravel() for a in np.meshgrid(xs, ys))
        col = np.clip(np.floor(x / cs + 0.5).astype(np.int64), 0, nx - 1)
        row = np.clip(np.floor(y / cs + 0.5).astype(np.int64), 0, ny - 1)
        keep = (self.depth0[row, col] > 0) & ~self.wall[row, col]
        pts = np.ascontiguousarray(np.column_stack([x[keep], y[keep]]))
        b = np.empty(len(pts))
        bed_at(np.ascontiguousarray(bed), pts, len(pts), 1.0 / cs, b)
        d = np.maximum(self.level - b, 0.0)
        volume = float(self.depth0.sum()) * cs * cs  # the reservoir's own volume on the DEM
        return equal_volumes(pts, d, volume)

    def to_frame(self, xy) -> np.ndarray:
        """Map coordinates → the solver's cell frame (x = col·Δ, y = row·Δ, cell centres on nodes)."""
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        r, c = fractional_cell(self.dem, xy[:, 0], xy[:, 1])
        cs = self.dem.cell_size
        return np.column_stack([(np.asarray(c) - 0.5) * cs, (np.asarray(r) - 0.5) * cs])
