"""The ground of an SPH run on a heightmap, shared by the `sph-terrain` and `splash` kinds: the terrain
as a :class:`Geometry` (raster, heights, bedrock, nodata), maps read on its grid (rain, bedrock), and
the plane walls of its closed edges.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from erosim.core.errors import ConfigError, InputError
from erosim.core.heightmap import Heightmap
from erosim.coupling.raster import Raster
from erosim.io.heightmaps import default_transform, read
from erosim.scenarios.schema_common import build_terrain
from erosim.scenarios.sph_terrain.schema import SPHTerrainScenario
from erosim.sph.boundaries.heightfield import wall_heights


@dataclass
class Geometry:
    """The terrain in the SPH frame and the conversion from the DEM's coordinates."""

    raster: Raster
    terrain: np.ndarray  # live: the ground the fluid feels and the erosion changes (nodata raised to walls)
    initial: np.ndarray
    nodata: np.ndarray | None
    dem: Heightmap | None  # the map-order DEM (outputs keep its grid and georeference)
    dim: int

    def to_local(self, xy, what: str) -> np.ndarray:
        """DEM coordinates (x[, y]) → SPH-frame metres; refuses a point off the map."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1)
        r = self.raster
        if self.dim == 2:
            local = xy[:1]
        else:
            a, _, c, _, e, f = self.dem.transform
            col = (xy[0] - c) / a - 0.5
            row = (xy[1] - f) / e - 0.5
            local = np.array([col * r.dx, (r.ny - 1 - row) * r.dy])
        span = np.array([(r.nx - 1) * r.dx, (r.ny - 1) * r.dy])[: self.dim - 1]
        if np.any(local < -1e-9) or np.any(local > span + 1e-9):
            raise ConfigError(
                f"{what} {xy.tolist()} lies outside the terrain; give a point on the map (its own coordinates)."
            )
        return local


def geometry(cfg: SPHTerrainScenario) -> Geometry:
    """The scenario's terrain as a :class:`Geometry` (nodata cells raised into walls)."""
    if cfg.profile is not None:
        p = cfg.profile
        nx = int(round(p.length / p.cell_size)) + 1
        x = np.arange(nx) * p.cell_size
        z = (p.height + p.slope * x)[None, :]
        raster = Raster(0.0, 0.0, p.cell_size, 1.0, nx, 1)
        return Geometry(raster, z.copy(), z.copy(), None, None, 2)
    return dem_geometry(cfg.terrain, cfg.seed, cfg.ground.nodata_wall)


def dem_geometry(terrain, seed: int, nodata_wall: float | None) -> Geometry:
    """A scenario's ``[terrain]`` in the SPH frame (rows northward). Nodata cells keep the nearest valid
    heights (as every kind reads a DEM) and are marked in ``Geometry.nodata``; with ``nodata_wall`` they
    are raised into walls that many metres above the DEM's top."""

    hm = build_terrain(terrain, seed)
    if hm.transform is None:
        hm = hm.copy()
        hm.transform = default_transform(*hm.shape, hm.cell_size)
    ny, nx = hm.shape
    raster = Raster(0.0, 0.0, hm.cell_size, hm.cell_size, nx, ny)
    z = np.ascontiguousarray(hm.z[::-1], dtype=np.float64)
    nodata = None if hm.nodata is None or not hm.nodata.any() else np.ascontiguousarray(hm.nodata[::-1])
    if nodata is not None and nodata_wall is not None:
        z = wall_heights(z, nodata, float(z[~nodata].max()) + nodata_wall)
    return Geometry(raster, z.copy(), z.copy(), nodata, hm, 3)


def map_like_terrain(path: str, what: str, geo: Geometry) -> np.ndarray:
    """A raster of the terrain's size (bedrock, rain map) in the SPH frame (rows northward)."""

    m = read(path).z
    if m.shape != geo.terrain.shape:
        raise InputError(
            f"{what} '{path}' has shape {m.shape} but the terrain {geo.terrain.shape}; give one of the terrain's size."
        )
    return np.ascontiguousarray(m[::-1], dtype=np.float64)


def bedrock_map(cfg: SPHTerrainScenario, geo: Geometry) -> np.ndarray | None:
    g = cfg.ground
    if g.bedrock_file:
        return map_like_terrain(g.bedrock_file, "Bedrock map", geo)
    if g.bedrock_depth is not None:
        return geo.initial - g.bedrock_depth
    return None


def rain_map(cfg: SPHTerrainScenario, geo: Geometry) -> np.ndarray:
    r = cfg.rain
    if r.file:
        m = map_like_terrain(r.file, "Rain map", geo)
        top = float(np.nanmax(m)) if np.isfinite(m).any() else 0.0
        return m / top if top > 1.0 else m  # an image (0…255, 0…65535): its brightest cell is chance 1
    if r.pattern == "uniform":
        return np.ones(geo.terrain.shape)
    from scipy import ndimage

    noise = np.random.default_rng([cfg.seed, 0x5A17]).random(geo.terrain.shape)
    blobs = ndimage.gaussian_filter(noise, r.noise_scale, mode="wrap")
    blobs = (blobs - blobs.min()) / max(float(np.ptp(blobs)), 1e-12)
    return np.clip(1.6 * blobs - 0.3, 0.0, 1.0)


def edge_planes(geo: Geometry, open_edges) -> tuple[np.ndarray, np.ndarray] | None:
    r, d = geo.raster, geo.dim
    xe, ye = (r.nx - 1) * r.dx, (r.ny - 1) * r.dy
    walls = {"west": ([0.0, 0.0], [1.0, 0.0]), "east": ([xe, 0.0], [-1.0, 0.0])}
    if d == 3:
        walls.update({"south": ([0.0, 0.0], [0.0, 1.0]), "north": ([0.0, ye], [0.0, -1.0])})
    pts, nrm = [], []
    for name, (p0, n) in walls.items():
        if name in open_edges:
            continue
        pts.append(p0[: d - 1] + [0.0])
        nrm.append(n[: d - 1] + [0.0])
    return (np.array(pts), np.array(nrm)) if pts else None
