"""A finished run folder opened for reading: its kind, report, known maps and particle frames.

``erosim view`` and ``erosim export`` look at a run through this one reader, so both refuse the
same bad input in one sentence (a path that is not a folder, a folder without ``report.json``, a
report of an unknown kind) and both know the same maps. The maps are the GeoTIFFs the kinds write
under ``maps/`` (:data:`LAYERS` lists those shown as layers, flood runs' included); any other
``maps/*.tif`` is listed too but not interpreted. Particle frames are the ``particles.pvd``
collection of SPH runs (:mod:`erosim.io.particles`). Map frames — the terrain and its water over
time — are ``maps/frames/<map>_<number>.tif`` (e.g. ``height_00003.tif``, ``water_depth_00003.tif``),
at the times listed in ``maps/frames/frames.json`` (``{"times": [...]}``), else numbered 0, 1, 2 ….
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap
from erosim.io import heightmaps
from erosim.io.particles import read_pvd, read_vtp

# kinds whose run folders erosim knows (flood: the flood-hazard kind's maps and report keys)
KNOWN_KINDS = ("hydrology", "sph", "sph-terrain", "particle-stream", "flood", "splash")


@dataclasses.dataclass(frozen=True)
class Layer:
    """A map shown as a layer: the files that hold it (first found wins), its label and unit."""

    key: str
    files: tuple[str, ...]
    label: str
    unit: str


# the layers of the view and of the splat map, in the order they are listed
LAYERS = (
    Layer("water", ("lake_depth", "water_depth", "max_depth", "max_water_depth"), "Water depth / lakes", "m"),
    Layer("stream", ("stream",), "Streams", "0–1"),
    Layer("erosion", ("erosion",), "Erosion", "m"),
    Layer("deposition", ("deposition",), "Deposition", "m"),
    Layer("vegetation", ("vegetation",), "Vegetation (tree density)", "0–1"),
    Layer("hazard", ("hazard",), "Hazard class", "class 1–6"),
    Layer("wetness", ("wetness",), "Wetness", "0–1"),
    Layer("puddles", ("puddles",), "Puddles (standing water)", "m"),
    Layer("speed", ("max_speed",), "Largest speed", "m/s"),
    Layer("dv", ("max_dv",), "Largest depth × speed", "m²/s"),
    Layer("arrival", ("arrival_time",), "Arrival time", "s"),
    Layer("sediment", ("sediment",), "Suspended sediment", "m"),
    Layer("hardness", ("hardness",), "Hardness", "0–1"),
)

# report entries shown beside the view: (label, path of keys, unit)
KEY_FIGURES = (
    ("status", ("status",), ""),
    ("kind", ("kind",), ""),
    ("scenario", ("scenario",), ""),
    ("progress", ("progress", "time"), ""),
    ("wall time", ("wall_time_s",), "s"),
    ("flooded area", ("flooded_area_m2",), "m²"),
    ("hazard shares", ("hazard_share",), ""),
    ("water rained", ("water_budget", "rained"), ""),
    ("water in lakes", ("water_budget", "in_lakes"), ""),
    ("water left edges", ("water_budget", "left_edges"), ""),
    ("water closure", ("water_budget", "closure_rel"), ""),
    ("eroded", ("sediment_budget", "eroded"), ""),
    ("deposited", ("sediment_budget", "deposited"), ""),
    ("sediment closure", ("sediment_budget", "closure_rel"), ""),
    ("water absorbed", ("water_budget", "absorbed"), "m³"),
    ("solid eroded", ("solid_budget", "eroded"), "m³"),
    ("solid closure", ("solid_budget", "closure_rel"), ""),
    ("crater depth", ("crater_depth_m",), "m"),
    ("lake share", ("statistics", "lake_fraction"), ""),
    ("largest lake depth", ("statistics", "max_lake_depth_m"), "m"),
    ("fluid particles", ("fluid_particles",), ""),
    ("front position", ("x_front",), "m"),
)


@dataclasses.dataclass
class Run:
    """What a run folder holds: ``maps`` maps a name (``height``, ``stream``, …) to its GeoTIFF."""

    path: Path
    kind: str
    report: dict[str, Any]
    maps: dict[str, Path]
    frames: list[tuple[float, Path]]
    map_frames: list[tuple[float, dict[str, Path]]] = dataclasses.field(default_factory=list)

    @property
    def name(self) -> str:
        return self.path.name

    def has_height(self) -> bool:
        return "height" in self.maps

    def height(self) -> Heightmap:
        """The final terrain (``maps/height.tif``); one sentence when the run wrote none."""
        if "height" not in self.maps:
            raise InputError(
                f"Run '{self.path}' (kind {self.kind}) holds no maps/height.tif; "
                "only runs on a heightmap (hydrology, sph-terrain, particle-stream, flood, splash) have a terrain "
                "to export."
            )
        return self.read_map("height")

    def read_map(self, name: str) -> Heightmap:

        return heightmaps.read(self.maps[name])

    def layers(self) -> list[tuple[Layer, str]]:
        """The known layers this run has, each with the map name that holds it."""
        found = []
        for layer in LAYERS:
            for f in layer.files:
                if f in self.maps:
                    found.append((layer, f))
                    break
        return found

    def key_figures(self) -> list[tuple[str, str]]:
        """(label, value with unit) of the report entries in :data:`KEY_FIGURES` this run has."""
        out = []
        for label, keys, unit in KEY_FIGURES:
            v: Any = self.report
            for k in keys:
                v = v.get(k) if isinstance(v, dict) else None
            if v is None:
                continue
            if label == "progress":
                unit = str(self.report.get("progress", {}).get("unit", ""))
            if label in ("water rained", "water in lakes", "water left edges", "eroded", "deposited"):
                unit = str(self.report.get(keys[0], {}).get("unit", ""))
            out.append((label, _fmt(v) + (f" {unit}" if unit else "")))
        return out


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, dict):
        return ", ".join(f"{k}: {_fmt(x)}" for k, x in v.items())
    if isinstance(v, list):
        return ", ".join(_fmt(x) for x in v)
    return str(v)


def open_run(path: str | os.PathLike) -> Run:
    """Open a run folder written by ``erosim run``; one sentence when it is not one."""
    p = Path(path)
    if not p.exists():
        raise InputError(f"Run folder '{p}' does not exist; pass the folder an `erosim run` wrote, e.g. runs/demo.")
    if not p.is_dir():
        raise InputError(f"'{p}' is a file, not a run folder; pass the folder an `erosim run` wrote, e.g. runs/demo.")
    rep = p / "report.json"
    if not rep.is_file():
        raise InputError(
            f"'{p}' is not a run folder: it holds no report.json (a run writes it when it ends); "
            "pass the folder an `erosim run` wrote."
        )
    try:
        report = json.loads(rep.read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        raise InputError(f"'{rep}' is not readable JSON; the run folder is damaged, run the scenario again.") from None
    kind = report.get("kind") if isinstance(report, dict) else None
    if kind not in KNOWN_KINDS:
        raise InputError(
            f"Run '{p}' is of an unknown kind '{kind}'; erosim shows runs of the kinds " + ", ".join(KNOWN_KINDS) + "."
        )
    maps = {f.stem: f for f in sorted((p / "maps").glob("*.tif"))} if (p / "maps").is_dir() else {}
    frames: list[tuple[float, Path]] = []
    pvd = p / "particles" / "particles.pvd"
    if pvd.is_file():

        try:
            # only names inside particles/: a collection cannot point the reader elsewhere
            rows = [(float(t), f) for t, f in read_pvd(pvd) if f and Path(f).name == f]
            frames = [(t, pvd.parent / f) for t, f in rows if (pvd.parent / f).is_file()]
        except Exception:  # a damaged collection: the frames on disk in name order, times unknown
            frames = []
    if not frames and (p / "particles").is_dir():
        frames = [(float(i), f) for i, f in enumerate(sorted((p / "particles").glob("frame_*.vtp")))]
    map_frames = _map_frames(p / "maps" / "frames")
    return Run(path=p, kind=kind, report=report, maps=maps, frames=frames, map_frames=map_frames)


def _map_frames(folder: Path) -> list[tuple[float, dict[str, Path]]]:
    """``maps/frames/<map>_<number>.tif`` grouped by number, in order, with their times."""
    if not folder.is_dir():
        return []
    groups: dict[int, dict[str, Path]] = {}
    for f in folder.glob("*.tif"):
        m = re.fullmatch(r"(.+)_(\d+)", f.stem)
        if m:
            groups.setdefault(int(m.group(2)), {})[m.group(1)] = f
    times: list = []
    try:
        times = list(json.loads((folder / "frames.json").read_text(encoding="utf-8")).get("times", []))
    except (OSError, ValueError, AttributeError):
        times = []
    out = []
    for k, number in enumerate(sorted(groups)):
        t = times[k] if k < len(times) and isinstance(times[k], (int, float)) else float(number)
        out.append((float(t), groups[number]))
    return out


def read_frame(path: Path) -> dict[str, np.ndarray]:
    """Positions (n, 3) and point fields of one particle frame."""

    return read_vtp(path)
