"""The ``voxel`` kind: SPH water scouring a voxel terrain (seed 001; SPEC VX-1…VX-10).

The terrain is a :class:`~erosim.terrain.voxel.VoxelTerrain` (a flume's floor, an optional plinth and a
trapezoidal embankment, :mod:`erosim.terrain.voxel`) felt by the fluid through the wall-weight
boundary :class:`~erosim.sph.boundaries.voxel_wall.VoxelWall`; the flume's side walls and upstream
end are analytic planes; the reservoir fills by layers laid at rest on its surface (``[inflow]``); water leaving past
the downstream end is removed and counted. Every
``erosion.every`` steps the :class:`~erosim.coupling.coupler.Coupler` applies the
shear-stress erosion of :mod:`erosim.erosion.shear_stress_kristof2009` to the field.

A run leaves

* ``figures/section_NNNN.png`` (``run.sections``): cross-sections, the run's starting surface dashed;
* ``figures/surface.png`` (``run.surface_figure``), at the end: the surface at the start and at the end,
  the latter coloured by its lowering, the water as dots (:mod:`erosim.viz.surface_render`);
* ``meshes/surface_NNNN.{obj,ply,glb}`` (``run.meshes``) and ``fields/density_NNNN.{npz,vti}``
  (``run.field_format``) per output time (every ``run.output_interval``, and at the start and end),
  ``particles/`` frames at the same times (``run.particle_frames``);
* ``profiles.csv`` (``t,x,z``): the surface height z along the flume's centre line, x from the
  embankment's upstream toe (a heightmap: along the middle row, x in the terrain's frame), every
  ``run.profile_interval``; ``figures/profiles.png`` with the profiles every ``run.figure_interval``
  (and the last);
* ``maps/`` (a heightmap's voxels): height.tif, height_initial.tif, erosion.tif, deposition.tif and
  water_depth.tif on the DEM's grid with its CRS (:class:`VoxelMaps`);
* ``report.json``: ``eroded_volume_m3``, ``first_erosion`` {t, x (from the upstream toe), z, y}: the first
  node, solid at the start, that the eroded surface has passed (density at or below the iso level),
  ``first_transfer`` the same for the first quantum moved (:mod:`erosim.coupling.terrains`), the
  ``budget`` (m³: eroded = carried off;
  pending, unmet, the field's change, closure), ``particles_inside_solid`` (the most seen after any
  coupling; 0) and the timings.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from erosim.core.errors import ConfigError, InputError, InstabilityError
from erosim.core.schedules import IterationInterval, Schedule, TimeInterval
from erosim.coupling.coupler import Coupler
from erosim.coupling.raster import Raster
from erosim.coupling.sampling import sample
from erosim.coupling.sources import EDGES, EdgeOutflow, PointInflow
from erosim.coupling.terrains import VoxelFieldTerrain
from erosim.scenarios.setup import Setup
from erosim.scenarios.voxel.schema import VoxelScenario, at_dem_scale, band_for, overflow_head
from erosim.simulation import callbacks as cb


def build_terrain(cfg: VoxelScenario):
    """The scenario's voxel field: a saved field (``terrain.voxels_file``), a heightmap with its caves, or
    the flume's floor (z < 0), the plinth (z < ``embankment.base``) and the embankment; ``voxels.scale =
    "dem"`` resolved first (:func:`at_dem_scale`)."""
    from erosim.terrain.voxel import Box, Embankment, HalfSpace, VoxelTerrain

    cfg = at_dem_scale(cfg)
    f, e, v = cfg.terrain, cfg.embankment, cfg.voxels
    h = cfg.sph.support()
    if f.voxels_file:
        t = VoxelTerrain.load(f.voxels_file)
        if t.cell_size > h:
            raise ConfigError(
                f"The saved field's voxels of {t.cell_size:g} m are too coarse for the particle spacing "
                f"{cfg.sph.spacing:g} m (kernel support h = {h:g} m); use sph.spacing ≥ "
                f"{t.cell_size / cfg.sph.h_factor:g} m."
            )
        return t
    if v.cell_size > h:
        raise ConfigError(
            f"Voxels of {v.cell_size:g} m are too coarse for the particle spacing {cfg.sph.spacing:g} m: the wall "
            f"distance needs cells no larger than the kernel support h = {h:g} m; set voxels.cell_size ≤ {h:g}."
        )
    band = band_for(cfg)
    if f.shape == "heightmap":
        from erosim.scenarios.schema_common import build_terrain as heightmap

        hm = heightmap(cfg.terrain, cfg.seed)
        lift = max([cfg.rain.height] + [j.height for j in cfg.inflows.values()])  # rain and the jets' mouths
        top = float(np.nanmax(hm.z)) + lift + band + 2 * v.cell_size
        bottom = float(np.nanmin(hm.z)) - max(band + 2 * v.cell_size, v.depth)
        try:
            t = VoxelTerrain.from_heightmap(hm, v.cell_size, bottom=bottom, top=top, band=band, iso=v.iso,
                                            max_bytes=v.max_bytes)  # fmt: skip
        except InputError as exc:  # the voxels' size that fits: the particles must come with them
            raise InputError(
                f"{str(exc).rstrip('.')}, setting sph.spacing with voxels.cell_size (voxels may be no larger "
                "than the kernel support, twice the spacing)."
            ) from None
        c = cfg.caves
        if c.wavelength > 0:
            t = t.carve_caves(wavelength=c.wavelength, threshold=c.threshold, seed=cfg.seed, octaves=c.octaves,
                              below=c.below)  # fmt: skip
        return t
    c = v.cell_size
    shapes = [HalfSpace((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
              Embankment(e.x_toe, e.height, e.crest_width, e.upstream, e.downstream, base=e.base)]  # fmt: skip
    if e.base > 0:
        shapes.append(Box((-1.0 - band, -1.0 - band, -1.0 - band), (f.length + 1.0 + band, f.width + 1.0 + band,
                                                                     e.base)))  # fmt: skip
    lo = (-2.0 * c, -2.0 * c, -(band + 2.0 * c))
    hi = (f.length + 2.0 * c, f.width + 2.0 * c, f.top)
    return VoxelTerrain.from_shapes(shapes, lo, hi, c, band=band, iso=v.iso, max_bytes=v.max_bytes)


def surface_profile(terrain, y: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, z) of the terrain's top surface along the node row nearest ``y`` (:func:`top_surface`)."""
    x_ax, y_ax, _ = terrain.axes()
    j = int(np.clip(round((y - y_ax[0]) / terrain.cell_size), 0, len(y_ax) - 1))
    return x_ax, _iso_top(terrain, terrain.density[:, j, :])


def top_surface(terrain) -> np.ndarray:
    """z[iy, ix]: the terrain's top surface, the highest crossing of the iso level in every node column."""
    return _iso_top(terrain, terrain.density)


def _iso_top(terrain, slab: np.ndarray) -> np.ndarray:
    """The highest crossing of the iso level in every node column of ``slab`` (the field's nodes, z first):
    linear between the topmost solid node and the air node above it; the field's top where that node is
    solid, its bottom where the column has none."""
    col = slab.astype(np.float64)
    z_ax = terrain.axes()[2]
    solid = col > terrain.iso
    nz = col.shape[0]
    k = nz - 1 - np.argmax(solid[::-1], axis=0)  # topmost solid node (nz − 1 where none: masked below)
    k1 = np.minimum(k + 1, nz - 1)
    d0 = np.take_along_axis(col, k[None], axis=0)[0]
    d1 = np.take_along_axis(col, k1[None], axis=0)[0]
    inner = k < nz - 1
    z = np.where(inner, z_ax[k] + terrain.cell_size * (d0 - terrain.iso) / np.where(inner, d0 - d1, 1.0), z_ax[-1])
    return np.where(solid.any(axis=0), z, z_ax[0])


class RainDrops(cb.Callback):
    """Rain as drops of 5 particles (a centre and its four horizontal neighbours at Δx; SPEC VX-8) at
    random places over the map at ``z``, falling at rest; the drops due at ``rate`` (mm/h) are added every
    ``every`` steps. Places come from a generator keyed by (seed, shower), so a resumed run rains the same."""

    SHAPE = np.array([[0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], np.float64)

    def __init__(self, schedule, solver, lo, hi, z: float, rate_mm_h: float, seed: int):
        super().__init__(schedule, name="rain")
        dx = solver.params.spacing
        self.solver, self.lo, self.hi, self.z, self.seed = solver, np.asarray(lo), np.asarray(hi), z, seed
        area = float(np.prod(self.hi - self.lo))
        self.per_s = rate_mm_h / 3.6e6 * area / (5 * dx**3)  # drops per second
        self.carry, self.last_t, self.events, self.drops = 0.0, float(solver.t), 0, 0

    def __call__(self, sim) -> None:
        s = self.solver
        due = self.carry + (float(s.t) - self.last_t) * self.per_s
        self.last_t = float(s.t)
        n = int(due)
        self.carry = due - n
        if n == 0:
            return
        dx = s.params.spacing
        rng = np.random.default_rng([self.seed, 0xD409, self.events])
        self.events += 1
        centres = np.column_stack([rng.uniform(self.lo[0] + dx, self.hi[0] - dx, n),
                                   rng.uniform(self.lo[1] + dx, self.hi[1] - dx, n), np.full(n, self.z)])  # fmt: skip
        pts = (centres[:, None, :] + dx * self.SHAPE[None]).reshape(-1, 3)
        s.add_fluid(pts, np.zeros_like(pts), source="rain")
        self.drops += n

    def state_dict(self) -> dict[str, Any]:
        return {"carry": self.carry, "last_t": self.last_t, "events": self.events, "drops": self.drops}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.carry, self.last_t = float(state["carry"]), float(state["last_t"])
        self.events, self.drops = int(state["events"]), int(state["drops"])


class Inflow(cb.Callback):
    """A reservoir filled as in a laboratory flume, its level rising gently: water enters at ``discharge``
    Q (m³/s) one particle at a time (one every Δx³/Q seconds), each laid **at rest** on the water's
    surface at its site (:meth:`rest_height`); the sites are the Δx lattice of the
    rectangle ``x0…x1`` × the flume's width, taken in a fixed scattered order (a stride coprime with
    their number), so the surface rises evenly.

    A particle so laid adds potential energy of about Δx/2 and no momentum, and no wave larger than one
    particle: the reservoir stays still while it fills and the overflow is driven by the level alone,
    as in Fujisawa et al.'s (2011) flume fed from upstream. Water poured from a height instead hits the
    surface at √(2gΔz), and whole layers dropped at once start surges: both stir the reservoir into
    currents of several cm/s that scour its upstream face before any water reaches the crest
    (docs/voxel.md). A new particle is at least Δx from every other."""

    def __init__(self, solver, x0: float, x1: float, width: float, discharge: float, top: float):
        super().__init__(IterationInterval(1), name="inflow")
        dx = solver.params.spacing
        xs = (np.arange(math.ceil(x0 / dx - 0.5), math.floor(x1 / dx - 0.5) + 1) + 0.5) * dx
        ys = (np.arange(0, math.floor(width / dx - 0.5) + 1) + 0.5) * dx
        gx, gy = np.meshgrid(xs[(xs > x0) & (xs < x1)], ys[ys < width], indexing="ij")
        sites = np.column_stack([gx.ravel(), gy.ravel()])
        n = len(sites)
        stride = next(k for k in range(max(1, int(0.618 * n)), 2 * n + 2) if math.gcd(k, n) == 1)
        self.sites = sites[(np.arange(n) * stride) % n]
        self.dx, self.top = dx, top
        self.period = dx**3 / discharge
        self.solver = solver
        self.carry, self.last_t, self.events = 0.0, float(solver.t), 0

    def rest_height(self, pos, xy) -> float:
        """The lowest z at ``xy`` at least Δx from every fluid particle below it: max over the particles k
        within Δx horizontally (ρ_k < Δx) of z_k + √(Δx² − ρ_k²) (a ball laid on the surface); Δx/2 (on
        the floor) when there are none."""
        z = self._ball_top(pos, xy)
        return z if z > -math.inf else 0.5 * self.dx

    def _ball_top(self, pos, xy) -> float:
        """max of z_k + √(Δx² − ρ_k²) over the particles within Δx horizontally; −∞ when there are none."""
        r2 = (pos[:, 0] - xy[0]) ** 2 + (pos[:, 1] - xy[1]) ** 2
        near = r2 < self.dx * self.dx
        return float((pos[near, 2] + np.sqrt(self.dx * self.dx - r2[near])).max()) if near.any() else -math.inf

    def __call__(self, sim) -> None:
        s = self.solver
        due = self.carry + (float(s.t) - self.last_t) / self.period
        self.last_t = float(s.t)
        count = int(due)
        self.carry = due - count
        if count == 0:
            return
        pos = s.fluid_positions()
        pts = np.empty((count, 3))
        for k in range(count):
            xy = self.sites[(self.events + k) % len(self.sites)]
            pts[k] = xy[0], xy[1], max(self.rest_height(pos, xy), self._ball_top(pts[:k], xy))  # and this step's
        if pts[:, 2].max() > self.top:
            raise InstabilityError(
                f"The inflow's water reached the top of the flume's domain ({self.top:g} m) at t = {float(s.t):.3g} s; "
                "lower inflow.discharge or raise terrain.top."
            )
        self.events += count
        s.add_fluid(pts, np.zeros_like(pts), source="inflow")

    def state_dict(self) -> dict[str, Any]:
        return {"carry": self.carry, "last_t": self.last_t, "events": self.events}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.carry, self.last_t, self.events = float(state["carry"]), float(state["last_t"]), int(state["events"])


class Profiles(cb.Callback):
    """The centre-line surface profile every ``interval`` (rows t, x from the toe, z) → ``profiles.csv``."""

    def __init__(self, schedule, terrain, solver, y: float, x_toe: float, path: Path):
        super().__init__(schedule, name="profiles")
        self.terrain, self.solver, self.y, self.x_toe, self.path = terrain, solver, y, x_toe, Path(path)
        self.rows: list[np.ndarray] = []
        self.figure = None  # figure(self) at the end of a completed run

    def __call__(self, sim) -> None:
        x, z = surface_profile(self.terrain, self.y)
        t = float(self.solver.t)
        if self.rows and self.rows[-1][0, 0] == t:
            return
        self.rows.append(np.column_stack([np.full(len(x), t), x - self.x_toe, z]))

    def table(self) -> np.ndarray:
        return np.concatenate(self.rows) if self.rows else np.zeros((0, 3))

    def state_dict(self) -> dict[str, Any]:
        return {"rows": self.table()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        tab = np.asarray(state["rows"], np.float64).reshape(-1, 3)
        self.rows = [tab[tab[:, 0] == t] for t in np.unique(tab[:, 0])]

    def flush(self, sim) -> None:
        from erosim.core.atomic import write_text

        write_text(self.path, cb.csv_text(["t", "x", "z"], self.table()))

    def finalize(self, sim) -> dict[str, Any]:
        self(sim)  # the final profile
        self.flush(sim)
        if self.figure is not None:
            self.figure(self)
        return {}


class VoxelOutputs(cb.Callback):
    """Per output time: the surface mesh(es), the density field, particle frames (count NNNN)."""

    def __init__(self, schedule, terrain, solver, out, cfg: VoxelScenario):
        super().__init__(schedule, name="voxel_outputs")
        self.terrain, self.solver, self.out, self.cfg = terrain, solver, out, cfg
        self.count = 0
        self.last_t = -math.inf
        self.initial = terrain.density.copy()  # the surface at the start, dashed in the sections
        self.cfg_name = "voxel terrain"
        self.frames = cb.ParticleFrames(Schedule(), solver, out.path / "particles") if cfg.run.particle_frames else None

    def __call__(self, sim) -> None:
        t = float(self.solver.t)
        if t == self.last_t:
            return
        self.last_t = t
        run, root = self.cfg.run, self.out.path
        tag = f"{self.count:04d}"
        if run.meshes:
            mesh = self.terrain.surface_mesh()
            for kind in run.meshes:
                self.terrain.export_mesh(root / "meshes" / f"surface_{tag}.{kind}", mesh=mesh)
        if run.field_format == "npz":
            self.terrain.save(root / "fields" / f"density_{tag}.npz")
        else:
            self.terrain.write_vti(root / "fields" / f"density_{tag}.vti")
        if self.frames is not None:
            self.frames(sim)
        if run.sections:
            ref, path = self.terrain.like(self.initial), root / "figures" / f"section_{tag}.png"
            with self.out.picture(path):
                self.terrain.cross_section(path, axis=run.section_axis, at=run.section_at,
                                           title=f"{self.cfg_name}  t = {t:.3g} s", reference=ref)  # fmt: skip
        self.count += 1

    def state_dict(self) -> dict[str, Any]:
        st = {"count": self.count, "last_t": self.last_t}
        if self.frames is not None:
            st["frames"] = self.frames.state_dict()["frames"]
        return st

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.count = int(state.get("count", 0))
        self.last_t = float(state.get("last_t", -math.inf))
        if self.frames is not None:
            self.frames.load_state_dict({"frames": state.get("frames", [])})

    def finalize(self, sim) -> dict[str, Any]:
        self(sim)
        out = {"outputs": {"times": self.count, "meshes": [f"meshes/surface_NNNN.{k}" for k in self.cfg.run.meshes],
                           "field": f"fields/density_NNNN.{self.cfg.run.field_format}"}}  # fmt: skip
        if self.cfg.run.surface_figure:
            with self.out.picture(self.out.figures / "surface.png"):
                surface_figure(self.out.figures / "surface.png", self.terrain.like(self.initial), self.terrain,
                               self.solver.fluid_positions(), float(self.solver.t), self.cfg_name)  # fmt: skip
                out["outputs"]["surface_figure"] = "figures/surface.png"
        return out


class VoxelMaps(cb.Callback):
    """``maps/`` of a heightmap's voxels at the end, on the DEM's grid with its CRS (the field's node columns:
    the DEM's nodes at ``voxels.scale = "dem"``, else a grid of the voxels' size from the DEM's first node):
    height.tif and height_initial.tif (the top surface, :func:`top_surface`), erosion.tif and
    deposition.tif (its lowering and raising, m) and water_depth.tif (the fluid's volume over each column:
    each particle's Δx³ spread over its footprint, :func:`erosim.scenarios.splash.build.footprint_volume`)."""

    def __init__(self, terrain, solver, dem, out):
        super().__init__(Schedule(), name="maps")
        from erosim.core.heightmap import Heightmap, transform_of

        self.terrain, self.solver, self.out = terrain, solver, out
        self.initial = top_surface(terrain)
        ny, nx = self.initial.shape
        c = terrain.cell_size
        a, b, x0, d, e, y0 = transform_of(dem)
        south = y0 + e * (dem.z.shape[0] - 0.5)  # the DEM's southern nodes' y (e < 0)
        transform = (c, 0.0, x0 + 0.5 * a - 0.5 * c, 0.0, -c, south + (ny - 1) * c + 0.5 * c)
        self.like = Heightmap(np.zeros((ny, nx)), c, crs=dem.crs, transform=transform)

    def finalize(self, sim) -> dict[str, Any]:
        from erosim.coupling.raster import Raster
        from erosim.io import heightmaps as hio
        from erosim.scenarios.splash.build import footprint_volume

        now = top_surface(self.terrain)
        ny, nx = now.shape
        c = self.terrain.cell_size
        x0, y0 = float(self.terrain.lo[0]), float(self.terrain.lo[1])
        pos = self.solver.fluid_positions()
        dx = self.solver.params.spacing
        volume = footprint_volume(Raster(x0, y0, c, c, nx, ny), pos[:, :2], np.full(len(pos), dx**3), dx)
        fields = {"height": now, "height_initial": self.initial, "erosion": np.maximum(self.initial - now, 0.0),
                  "deposition": np.maximum(now - self.initial, 0.0), "water_depth": volume / (c * c)}  # fmt: skip
        written = {}
        for name, arr in fields.items():
            north_up = np.ascontiguousarray(arr[::-1])
            if name.startswith("height"):
                hio.write(self.out.maps / f"{name}.tif", north_up, like=self.like)
            else:
                hio.write_raster(self.out.maps / f"{name}.tif", north_up.astype(np.float32), self.like)
            written[name] = {"path": f"maps/{name}.tif", "min": float(arr.min()), "max": float(arr.max())}
        return {"maps": written}


def surface_figure(path, start, end, water: np.ndarray, t: float, name: str) -> Path:
    """``figures/surface.png``: the surface at the start tinted by height, and at ``t`` coloured by the lowering
    of the top surface (per node column, on faces facing up) with the ``water`` particles as dots."""
    from erosim.viz.surface_render import surface_panels

    a, b = start.surface_mesh(), end.surface_mesh()
    dz = top_surface(end) - top_surface(start)
    x, y, _ = end.axes()
    c = b.vertices[b.faces].mean(axis=1)
    ix = np.clip(np.rint((c[:, 0] - x[0]) / end.cell_size).astype(int), 0, len(x) - 1)
    iy = np.clip(np.rint((c[:, 1] - y[0]) / end.cell_size).astype(int), 0, len(y) - 1)
    lowering = np.where(b.face_normals[:, 2] > 0.3, -dz[iy, ix], 0.0)
    top = max(0.05, float(np.percentile(-dz, 99.5)))
    return surface_panels(path, [
        {"vertices": a.vertices, "faces": a.faces, "title": "start, tinted by height"},
        {"vertices": b.vertices, "faces": b.faces, "points": water, "face_values": lowering,
         "value_range": (0.0, top), "value_cmap": "magma_r", "value_label": "lowering of the surface (m)",
         "title": f"t = {t:.3g} s, water as dots"},
    ], size=(11.0, 4.6), title=name)  # fmt: skip


class Inside(cb.Callback):
    """Counts the fluid particles inside the solid after each coupling; keeps the most seen."""

    def __init__(self, schedule, solver, wall):
        super().__init__(schedule, name="inside")
        self.solver, self.wall, self.most = solver, wall, 0

    def __call__(self, sim) -> None:
        self.most = max(self.most, self.wall.inside(self.solver))

    def state_dict(self) -> dict[str, Any]:
        return {"most": self.most}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.most = int(state.get("most", 0))


def jet_mouths(cfg: VoxelScenario, terrain) -> tuple[list[float], Raster | None, np.ndarray | None]:
    """The ``[inflows.NAME]`` jets on a heightmap's voxels: the height of each mouth's centre (``height`` above
    the top surface, :func:`top_surface`, at ``position`` in the terrain's frame), the raster of the field's
    node columns and that surface (None without jets); a point off the map is refused."""
    if not cfg.inflows:
        return [], None, None
    c = terrain.cell_size
    _, ny, nx = terrain.shape
    nodes = Raster(float(terrain.lo[0]), float(terrain.lo[1]), c, c, nx, ny)
    ground = top_surface(terrain)
    lo, hi = np.asarray(terrain.lo[:2]), np.asarray(terrain.hi[:2])
    tops = []
    for name, jet in cfg.inflows.items():
        xy = np.asarray(jet.position, np.float64).reshape(-1)
        if xy.size != 2 or np.any(xy < lo) or np.any(xy > hi):
            raise ConfigError(
                f"inflows.{name}.position {xy.tolist()} lies outside the terrain; give [x, y] between "
                f"{lo.round(3).tolist()} and {hi.round(3).tolist()} m (the terrain's frame)."
            )
        tops.append(float(sample(nodes, ground, xy[None])[0]) + jet.height)
    return tops, nodes, ground


def jets(cfg: VoxelScenario, terrain, solver) -> list[PointInflow]:
    """The ``[inflows.NAME]`` sources (:class:`~erosim.coupling.sources.PointInflow`, a vertical jet each) on
    a heightmap's voxels, at :func:`jet_mouths`."""
    _, nodes, ground = jet_mouths(cfg, terrain)
    return [PointInflow(IterationInterval(1), solver, nodes, ground, jet.position, jet.discharge, jet.radius,
                        jet.height, name) for name, jet in cfg.inflows.items()]  # fmt: skip


def rain_height(cfg: VoxelScenario, terrain) -> float:
    """z at which rain drops appear: ``rain.height`` above the highest solid node of the field."""
    solid = (terrain.density > terrain.iso).any(axis=(1, 2))
    z_top = terrain.axes()[2][np.nonzero(solid)[0].max()] if solid.any() else terrain.lo[2]
    return float(min(z_top + cfg.rain.height, terrain.hi[2]))


def build_solver(cfg: VoxelScenario, terrain):
    """The fluid (a reservoir or lakes at rest), its voxel wall and, in a flume, the planes of its side and
    upstream walls; the sound speed from the highest fall the water can take."""
    from erosim.sph.boundaries.planes import PlaneWalls
    from erosim.sph.boundaries.voxel_wall import VoxelWall
    from erosim.sph.solver import SPHSolver

    p, f, e = cfg.sph, cfg.terrain, cfg.embankment
    dx = p.spacing
    flume = f.shape == "flume"
    level = cfg.water.level
    fluid = np.zeros((0, 3))
    if level is not None:
        if flume:
            fluid = terrain.fluid_points(dx, lo=(0.0, 0.0, 0.0), hi=(e.x_toe + e.height * e.upstream, f.width, f.top),
                                         below=level)  # fmt: skip
        else:
            fluid = terrain.fluid_points(dx, below=level)
    if flume:
        if len(fluid) == 0 and cfg.inflow.discharge <= 0:
            raise ConfigError("The scenario has no water: give water.level above the floor or inflow.discharge > 0.")
        top, floor = max(level or 0.0, e.base + e.height + overflow_head(cfg.inflow.discharge, f.width)), 0.0
        what = "the water level or the crest and the overflow's head above the floor"
    else:
        if len(fluid) == 0 and cfg.rain.rate <= 0 and not cfg.inflows:
            raise ConfigError(
                "The scenario has no water: give water.level above some ground, rain.rate > 0 or an [inflows.NAME] jet."
            )
        top = max([float(fluid[:, 2].max()) if len(fluid) else -np.inf]
                  + ([rain_height(cfg, terrain)] if cfg.rain.rate > 0 else [])
                  + jet_mouths(cfg, terrain)[0])  # fmt: skip
        floor = float(terrain.lo[2])
        what = "the highest water, rain drop or jet's mouth above the field's bottom"
    derived = {}
    if p.sound_speed <= 0:
        g = math.sqrt(sum(x * x for x in p.gravity_vector()))
        c = 10.0 * math.sqrt(2.0 * g * max(top - floor, dx))
        p = p.model_copy(update={"sound_speed": c})
        derived = {"sound_speed": c, "rule": f"c = 10·sqrt(2 g H), H from {what}"}
    h = p.support()
    if flume:
        lo = [-4.0 * h, -4.0 * h, terrain.lo[2]]
        hi = [f.length + 4.0 * h, f.width + 4.0 * h, f.top + max(top, 0.5 * f.top)]
        planes = [PlaneWalls([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, f.width, 0.0]],
                             [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])]  # fmt: skip
    else:
        lo = [terrain.lo[0] - 4.0 * h, terrain.lo[1] - 4.0 * h, terrain.lo[2]]
        hi = [terrain.hi[0] + 4.0 * h, terrain.hi[1] + 4.0 * h, max(terrain.hi[2], top) + 10.0 * h]
        planes = []
    wall = VoxelWall(terrain, attraction=None if cfg.voxels.attraction == "none" else cfg.voxels.attraction)
    solver = SPHSolver(p, fluid, domain_lo=lo, domain_hi=hi, seed=cfg.seed, boundaries=[wall, *planes])
    return solver, wall, derived


def make_eroder(e, terrain, solver):
    """The eroder of ``erosion.law`` for ``terrain`` and the fluid of ``solver``."""
    if e.law == "excess_shear":
        from erosim.erosion.excess_shear_partheniades1965 import ExcessShearErosion

        return ExcessShearErosion(terrain, e, support=solver.h, spacing=solver.params.spacing,
                                  rho0=solver.params.rho0)  # fmt: skip
    from erosim.erosion.shear_stress_kristof2009 import ShearStressErosion

    return ShearStressErosion(terrain, e, support=solver.h)


def setup(scenario, out) -> Setup:
    """The flume, its fluid, inflow and outflow, the erosion coupler and the outputs of a ``voxel`` run."""
    cfg: VoxelScenario = at_dem_scale(scenario.config)
    terrain = build_terrain(cfg)
    solver, wall, derived = build_solver(cfg, terrain)
    e, run = cfg.erosion, cfg.run
    eroder = make_eroder(e, terrain, solver) if e.enabled else None
    if eroder is not None and e.sediment == "suspended":
        from erosim.erosion.settling_voxel import SuspendedSediment

        eroder = SuspendedSediment(eroder, solver, e.settling_velocity, e.max_concentration)
    coupler = Coupler(IterationInterval(e.every), solver, eroder, VoxelFieldTerrain(terrain), start=e.start)
    callbacks: list = []
    if cfg.inflow.discharge > 0:
        i = cfg.inflow
        callbacks.append(Inflow(solver, i.x0, i.x1, cfg.terrain.width, i.discharge, cfg.terrain.top))
    flume = cfg.terrain.shape == "flume"
    if flume:
        # the open downstream end: a raster whose east edge is the flume's end
        ends = Raster(0.0, 0.0, cfg.terrain.length, cfg.terrain.width, 2, 2)
        callbacks.append(EdgeOutflow(IterationInterval(1), solver, ends, ["east"]))
    else:
        (x0, y0), (x1, y1) = terrain.lo[:2], terrain.hi[:2]
        box = Raster(float(x0), float(y0), float(x1 - x0), float(y1 - y0), 2, 2)
        callbacks.append(EdgeOutflow(IterationInterval(1), solver, box, EDGES))
        if cfg.rain.rate > 0:
            callbacks.append(RainDrops(IterationInterval(cfg.rain.every), solver, terrain.lo[:2], terrain.hi[:2],
                                       rain_height(cfg, terrain), cfg.rain.rate, cfg.seed))  # fmt: skip
        callbacks += jets(cfg, terrain, solver)
    callbacks.append(coupler)
    inside = Inside(IterationInterval(e.every), solver, wall)
    x0 = cfg.embankment.x_toe if flume else 0.0
    y_mid = 0.5 * cfg.terrain.width if flume else 0.5 * (terrain.lo[1] + terrain.hi[1])
    profiles = Profiles(TimeInterval(run.profile_interval), terrain, solver, y_mid, x0,
                        out.path / "profiles.csv")  # fmt: skip
    outputs = VoxelOutputs(TimeInterval(run.output_interval if run.output_interval > 0 else run.t_end), terrain,
                           solver, out, cfg)  # fmt: skip
    profiles.figure = lambda p: _profile_figure(cfg, p, out)
    outputs.cfg_name = scenario.name
    callbacks += [inside, profiles, outputs]
    report_fn = _reporter(cfg, terrain, solver, coupler, eroder, inside, profiles, derived, x0, flume, out)

    def summary(sim, rep: dict) -> dict[str, Any]:
        return {
            "status": sim.status,
            "t": round(float(solver.t), 6),
            "steps": int(solver.steps),
            "fluid_particles": solver.n_fluid,
            "eroded_volume_m3": rep["eroded_volume_m3"],
            "first_erosion": rep["first_erosion"],
            "particles_inside_solid": rep["particles_inside_solid"],
            "wall_time_s": round(sim.wall_time, 2),
            **{"warning": w for w in out.warnings if w.startswith(EROSION_NOTES)},  # noqa: B035 (one at most)
        }

    assumed: list[str] = []
    if cfg.terrain.shape == "heightmap" and not cfg.terrain.voxels_file:
        from erosim.scenarios.schema_common import build_terrain as heightmap
        from erosim.scenarios.schema_common import terrain_facts

        dem = heightmap(cfg.terrain, cfg.seed)
        callbacks.append(VoxelMaps(terrain, solver, dem, out))
    if cfg.terrain.shape == "heightmap" and cfg.terrain.uses_file and not cfg.terrain.voxels_file:
        assumed = terrain_facts(dem, cfg.terrain)[1]
        assumed.append(f"voxels: {terrain.shape[2]} × {terrain.shape[1]} × {terrain.shape[0]} nodes of "
                       f"{terrain.cell_size:g} m, particles of {cfg.sph.spacing:g} m (voxels.scale = "
                       f"'{scenario.config.voxels.scale}')")  # fmt: skip
    return Setup(
        models=[solver], callbacks=callbacks, stop_time=run.t_end, unit="s", report=report_fn, summary=summary,
        checkpoint_wall_s=run.checkpoint_wall_s, seed=cfg.seed, assumed=assumed,
    )  # fmt: skip


#: clear water holds while the ground it has removed stays below this fraction of its volume (the start
#: of hyperconcentrated flow, Costa 1988); the fluid here carries no sediment, so a run beyond it is warned
CLEAR_WATER_LIMIT = 0.2
#: the openings of the run's erosion warnings (:func:`sediment_warning`, :func:`no_erosion_warning`; one at most)
EROSION_NOTES = ("The ground removed", "No ground was eroded")


def sediment_warning(eroded_m3: float, water_m3: float, strength: str = "erosion.k_eps") -> str | None:
    """One sentence when the eroded volume exceeds :data:`CLEAR_WATER_LIMIT` of the water's volume, else None;
    ``strength`` names the law's rate setting."""
    if water_m3 <= 0 or eroded_m3 <= CLEAR_WATER_LIMIT * water_m3:
        return None
    return (
        f"The ground removed ({eroded_m3:.3g} m³) is {eroded_m3 / water_m3:.2f} of the water's volume "
        f"({water_m3:.3g} m³), above the {CLEAR_WATER_LIMIT * 100:g} % up to which clear-water flow holds "
        f"(Costa 1988): the erosion is too strong for this terrain's scale; lower {strength} (docs/voxel.md)."
    )


def no_erosion_warning(eroder) -> str | None:
    """One sentence when the erosion was evaluated but no quantum has moved: either some is pending, below
    a quantum at every node, or none at all, when the slowest water along the surface that reaches τ_c
    (the eroder's ``threshold_note``) was never reached. Under the seed's law that speed is
    l_min (τ_c/K)^(1/n) (θ ≤ v/l_min) and grows with the spacing, so a scene's τ_c set for small particles
    erodes nothing on a coarse DEM. A law whose rate is set to 0 asks for no erosion and is not warned."""
    if eroder is None or eroder.removed_total > 0 or getattr(eroder.params, eroder.strength) == 0:
        return None
    pending = eroder.pending_volume()
    if pending > 0:
        return (
            f"No ground was eroded yet: {pending:.3g} m³ of erosion is pending, less than one quantum "
            f"(erosion.quantum = {eroder.params.quantum:.3g} of a voxel's density range) at every node; run longer "
            f"or raise erosion.{eroder.strength} (docs/voxel.md)."
        )
    return f"No ground was eroded yet: {eroder.threshold_note()} (docs/voxel.md)."


def _warn(out, note: str | None, opening: str) -> None:
    """Keep ``out.warnings`` holding ``note`` (or none) among the warnings that start with ``opening``."""
    kept = [w for w in out.warnings if not w.startswith(opening)]
    out.warnings[:] = kept + ([note] if note is not None else [])


def _reporter(cfg, terrain, solver, coupler, eroder, inside, profiles, derived, x0, flume, out):
    suspended = eroder is not None and cfg.erosion.sediment == "suspended"

    def report(sim) -> dict[str, Any]:
        from erosim.terrain.voxel import memory_bytes

        first, onset = coupler.terrain.first, coupler.terrain.onset
        frame = "from the embankment's upstream toe" if flume else "the terrain's frame (m from its south-west node)"
        steps = sim.iteration - sim.iteration_start
        st = solver.state
        water_m3 = (st.initial + sum(st.added.values())) * solver.m / solver.params.rho0  # all the water, at rest
        # with the load on the particles their cap (erosion.max_concentration) keeps the water clear instead
        strength = f"erosion.{eroder.strength}" if eroder is not None else "erosion.k_eps"
        clear = None if suspended else sediment_warning(coupler.totals["eroded"], water_m3, strength)
        _warn(out, clear, EROSION_NOTES[0])
        _warn(out, no_erosion_warning(eroder) if coupler.calls else None, EROSION_NOTES[1])
        return {
            "t": float(solver.t),
            "t_end": cfg.run.t_end,
            "steps": int(solver.steps),
            "fluid_particles": st.n_fluid,
            "water": {"initial_particles": st.initial, "added": dict(st.added), "removed": dict(st.removed)},
            "voxels": {"shape_zyx": list(terrain.shape), "cell_size_m": terrain.cell_size, "band_m": terrain.band,
                       "memory_bytes": memory_bytes(int(np.prod(terrain.shape)), erosion=eroder is not None)},
            "resolution": {"spacing": cfg.sph.spacing, "support_h": solver.h, **derived},
            "eroded_volume_m3": coupler.totals["eroded"],
            "eroded_to_water_volume": coupler.totals["eroded"] / water_m3 if water_m3 > 0 else None,
            "first_erosion": None if math.isnan(onset[0]) else {
                "t": float(onset[0]), "x": float(onset[1]) - x0, "z": float(onset[3]), "y": float(onset[2]),
                "x_frame": frame,
                "definition": "the first node, solid at the start, that the eroded surface passed (density at or "
                              "below the iso level)"},
            "first_transfer": None if math.isnan(first[0]) else {
                "t": float(first[0]), "x": float(first[1]) - x0, "z": float(first[2]),
                "y": float(coupler.terrain.first_y), "x_frame": frame,
                "definition": "the first quantum moved off a solid node (the node it lowered most)"},
            "budget": coupler.budget(),
            **({"sediment": {"on_particles_m3": eroder.held(), "picked_up_m3": eroder.picked_total,
                             "settled_m3": eroder.deposited_total - eroder.returned_total,
                             "not_taken_m3": eroder.returned_total, "max_concentration": eroder.max_concentration(),
                             "definition": "ground eroded and carried by the water (erosion.sediment = 'suspended'); "
                                           "not_taken: erosion left in place because the water near it was full "
                                           "(erosion.max_concentration); max_concentration: the largest load of a "
                                           "particle over its volume now"}}
               if suspended else {}),
            "particles_inside_solid": max(inside.most, solver.n_fluid and wall_inside(solver)),
            "timings": {
                "wall_time_s": round(sim.wall_time, 3),
                "coupling_wall_s": round(coupler.wall, 3),
                "coupling_fraction": coupler.wall / sim.wall_time if sim.wall_time > 0 else None,
                "particle_steps_per_s": st.n_fluid * steps / sim.wall_time if sim.wall_time > 0 and steps else None,
            },
        }  # fmt: skip

    def wall_inside(s) -> int:
        return inside.wall.inside(s)

    return report


def _profile_figure(cfg: VoxelScenario, profiles: Profiles, out) -> None:
    """``figures/profiles.png``: the centre-line profiles every ``run.figure_interval`` and the last."""
    from erosim.viz.plots import profiles_figure

    tab = profiles.table()
    if not len(tab):
        return
    times = np.unique(tab[:, 0])
    every = cfg.run.figure_interval
    keep = [t for t in times if abs(t / every - round(t / every)) * every < 0.5 * cfg.run.profile_interval]
    if times[-1] not in keep:
        keep.append(times[-1])
    curves = [(t, tab[tab[:, 0] == t, 1], tab[tab[:, 0] == t, 2]) for t in keep]
    flume = cfg.terrain.shape == "flume"
    along = "x from the upstream toe (m)" if flume else "x in the terrain's frame (m from its south-west node)"
    where = "Centre-line profiles" if flume else "Profiles along the middle row"
    profiles_figure(out.figures / "profiles.png", curves, title=f"{where}, every {every:g} s", xlabel=along)
