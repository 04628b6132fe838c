"""What a `voxel` run writes and reports: the centre-line profiles, the surface maps and sections, the
VTK/mesh outputs, the check that the water stays inside the domain, the warnings on sediment and on
ground that did not erode, and the report.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from erosim.core.atomic import write_text
from erosim.core.heightmap import Heightmap, transform_of
from erosim.core.schedules import Schedule
from erosim.coupling.puddles import footprint_volume
from erosim.coupling.raster import Raster
from erosim.io import heightmaps as hio
from erosim.scenarios.voxel.schema import VoxelScenario
from erosim.simulation import callbacks as cb
from erosim.terrain.voxel import memory_bytes
from erosim.viz.plots import profiles_figure
from erosim.viz.surface_render import surface_panels


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


class Profiles(cb.Callback):
    """The centre-line surface profile every ``interval`` (rows t, x from the toe, z) → ``profiles.csv``; t is
    the morphological time, the flow's time times ``time_factor`` (``erosion.morfac``)."""

    def __init__(self, schedule, terrain, solver, y: float, x_toe: float, path: Path, time_factor: float = 1.0):
        super().__init__(schedule, name="profiles")
        self.terrain, self.solver, self.y, self.x_toe, self.path = terrain, solver, y, x_toe, Path(path)
        self.time_factor = float(time_factor)
        self.rows: list[np.ndarray] = []
        self.figure = None  # figure(self) at the end of a completed run

    def __call__(self, sim) -> None:
        x, z = surface_profile(self.terrain, self.y)
        t = float(self.solver.t) * self.time_factor
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

        write_text(self.path, cb.csv_text(["t", "x", "z"], self.table()))

    def finalize(self, sim) -> dict[str, Any]:
        self(sim)  # the final profile
        self.flush(sim)
        if self.figure is not None:
            self.figure(self)
        return {}


def moment(t: float, morfac: float = 1.0) -> str:
    """A figure's time: flow time t, and with ``erosion.morfac`` f ≠ 1 the bed change it stands for, f·t."""
    return f"t = {t:.3g} s" if morfac == 1.0 else f"t = {t:.3g} s ({morfac * t:.3g} s of bed change, morfac {morfac:g})"


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
                                           title=f"{self.cfg_name}  {moment(t, self.cfg.erosion.morfac)}",
                                           reference=ref)  # fmt: skip
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
                               self.solver.fluid_positions(), float(self.solver.t), self.cfg_name,
                               self.cfg.erosion.morfac)  # fmt: skip
                out["outputs"]["surface_figure"] = "figures/surface.png"
        return out


class VoxelMaps(cb.Callback):
    """``maps/`` of a heightmap's voxels at the end, on the DEM's grid with its CRS (the field's node columns:
    the DEM's nodes at ``voxels.scale = "dem"``, else a grid of the voxels' size from the DEM's first node):
    height.tif and height_initial.tif (the top surface, :func:`top_surface`), erosion.tif and
    deposition.tif (its lowering and raising, m) and water_depth.tif (the fluid's volume over each column:
    each particle's Δx³ spread over its footprint, :func:`erosim.coupling.puddles.footprint_volume`)."""

    def __init__(self, terrain, solver, dem, out):
        super().__init__(Schedule(), name="maps")

        self.terrain, self.solver, self.out = terrain, solver, out
        self.initial = top_surface(terrain)
        ny, nx = self.initial.shape
        c = terrain.cell_size
        a, b, x0, d, e, y0 = transform_of(dem)
        south = y0 + e * (dem.z.shape[0] - 0.5)  # the DEM's southern nodes' y (e < 0)
        transform = (c, 0.0, x0 + 0.5 * a - 0.5 * c, 0.0, -c, south + (ny - 1) * c + 0.5 * c)
        self.like = Heightmap(np.zeros((ny, nx)), c, crs=dem.crs, transform=transform)

    def finalize(self, sim) -> dict[str, Any]:

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


def surface_figure(path, start, end, water: np.ndarray, t: float, name: str, morfac: float = 1.0) -> Path:
    """``figures/surface.png``: the surface at the start tinted by height, and at ``t`` coloured by the lowering
    of the top surface (per node column, on faces facing up) with the ``water`` particles as dots; ``morfac``
    (``erosion.morfac``) names the bed change that t stands for (:func:`moment`)."""

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
         "title": f"{moment(t, morfac)}, water as dots"},
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


#: clear water holds while the ground it has removed stays below this fraction of its volume (the start
#: of hyperconcentrated flow, Costa 1988); the fluid here carries no sediment, so a run beyond it is warned
CLEAR_WATER_LIMIT = 0.2


#: the openings of the run's erosion warnings (:func:`sediment_warning`, :func:`no_erosion_warning`; one at most)
EROSION_NOTES = ("The ground removed", "No ground was eroded")


def sediment_warning(
    eroded_m3: float, water_m3: float, strength: str = "erosion.k_eps", morfac: float = 1.0
) -> str | None:  # fmt: skip
    """One sentence when the ground the water removed in its own (flow) time exceeds
    :data:`CLEAR_WATER_LIMIT` of its volume, else None; ``strength`` names the law's rate setting. With a
    morphological factor f (``erosion.morfac``) the bed moves f times the flow's erosion, but the water
    carries what it eroded in flow time: the eroded volume / f is compared (Roelvink 2006)."""
    carried = eroded_m3 / morfac
    if water_m3 <= 0 or carried <= CLEAR_WATER_LIMIT * water_m3:
        return None
    per_flow = "" if morfac == 1.0 else f", {carried:.3g} m³ in flow time at erosion.morfac = {morfac:g}"
    return (
        f"The ground removed ({eroded_m3:.3g} m³{per_flow}) is {carried / water_m3:.2f} of the water's volume "
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


def reporter(cfg, terrain, solver, coupler, eroder, inside, profiles, derived, x0, flume, out):
    suspended = eroder is not None and cfg.erosion.sediment == "suspended"

    def report(sim) -> dict[str, Any]:

        first, onset = coupler.terrain.first, coupler.terrain.onset
        frame = "from the embankment's upstream toe" if flume else "the terrain's frame (m from its south-west node)"
        steps = sim.iteration - sim.iteration_start
        st = solver.state
        water_m3 = (st.initial + sum(st.added.values())) * solver.m / solver.params.rho0  # all the water, at rest
        # with the load on the particles their cap (erosion.max_concentration) keeps the water clear instead
        strength = f"erosion.{eroder.strength}" if eroder is not None else "erosion.k_eps"
        morfac = cfg.erosion.morfac
        clear = None if suspended else sediment_warning(coupler.totals["eroded"], water_m3, strength, morfac)
        _warn(out, clear, EROSION_NOTES[0])
        _warn(out, no_erosion_warning(eroder) if coupler.calls else None, EROSION_NOTES[1])
        return {
            "t": float(solver.t),
            "t_end": cfg.run.t_end,
            "morfac": cfg.erosion.morfac,
            "t_morphological": float(solver.t) * cfg.erosion.morfac,
            "steps": int(solver.steps),
            "fluid_particles": st.n_fluid,
            "water": {"initial_particles": st.initial, "added": dict(st.added), "removed": dict(st.removed)},
            "voxels": {"shape_zyx": list(terrain.shape), "cell_size_m": terrain.cell_size, "band_m": terrain.band,
                       "memory_bytes": memory_bytes(int(np.prod(terrain.shape)), erosion=eroder is not None)},
            "resolution": {"spacing": cfg.sph.spacing, "support_h": solver.h, **derived},
            "eroded_volume_m3": coupler.totals["eroded"],
            "eroded_to_water_volume": coupler.totals["eroded"] / water_m3 if water_m3 > 0 else None,
            "first_erosion": None if math.isnan(onset[0]) else {
                "t": float(onset[0]), "t_morphological": float(onset[0]) * cfg.erosion.morfac,
                "x": float(onset[1]) - x0, "z": float(onset[3]), "y": float(onset[2]), "x_frame": frame,
                "definition": "the first node, solid at the start, that the eroded surface passed (density at or "
                              "below the iso level)"},
            "first_transfer": None if math.isnan(first[0]) else {
                "t": float(first[0]), "t_morphological": float(first[0]) * cfg.erosion.morfac,
                "x": float(first[1]) - x0, "z": float(first[2]),
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


def profile_figure(cfg: VoxelScenario, profiles: Profiles, out) -> None:
    """``figures/profiles.png``: the centre-line profiles every ``run.figure_interval`` and the last."""

    tab = profiles.table()
    if not len(tab):
        return
    times = np.unique(tab[:, 0])
    every = cfg.run.figure_interval
    f = cfg.erosion.morfac  # the table's times are morphological: flow time × f
    keep = [t for t in times if abs(t / every - round(t / every)) * every < 0.5 * cfg.run.profile_interval * f]
    if times[-1] not in keep:
        keep.append(times[-1])
    curves = [(t, tab[tab[:, 0] == t, 1], tab[tab[:, 0] == t, 2]) for t in keep]
    flume = cfg.terrain.shape == "flume"
    along = "x from the upstream toe (m)" if flume else "x in the terrain's frame (m from its south-west node)"
    where = "Centre-line profiles" if flume else "Profiles along the middle row"
    when = f"every {every:g} s" if f == 1 else f"every {every:g} s of morphological time (erosion.morfac = {f:g})"
    profiles_figure(out.figures / "profiles.png", curves, title=f"{where}, {when}", xlabel=along)
