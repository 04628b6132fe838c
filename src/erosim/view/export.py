"""``erosim export RUN --to DIR``: a run's final terrain in the formats game engines and DCC tools import.

Reads the run with :func:`erosim.io.results.open_run`, draws the mesh texture with
:mod:`erosim.viz.maps` (shaded relief, or the hydrology picture where the run has water) and writes
with :mod:`erosim.io.exports` (formats, axes and splat channels documented there). ``export.json``
in DIR lists every file, the shape, cell size, height range (what 0 and 65535 of the 16-bit files
stand for), the axes and the splat channels, and for a tiled export each tile's window.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from erosim.core.atomic import write_json
from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap
from erosim.io import exports, heightmaps
from erosim.io.results import open_run
from erosim.viz import maps

FORMATS = ("glb", "gltf", "obj", "exr", "raw32", "png16", "raw16", "splat")
DEFAULT_FORMATS = ("glb", "obj", "exr", "raw32", "png16", "raw16", "splat")
TEXTURES = ("relief", "hillshade", "none")
MAX_TEXTURE = 4096  # px a side: larger maps are textured at a stride


def _texture(kind: str, z: np.ndarray, cell_size: float, layers: dict[str, np.ndarray]) -> np.ndarray | None:

    if kind == "none":
        return None
    step = max(1, int(np.ceil(max(z.shape) / MAX_TEXTURE)))
    zs = z[::step, ::step]
    if kind == "hillshade":
        shade = maps.hillshade(zs, cell_size * step)
        return np.repeat(shade[..., None], 3, axis=2)
    if "stream" in layers or "water" in layers:
        zero = np.zeros_like(zs)
        pick = {k: v[::step, ::step] for k, v in layers.items()}
        return maps.hydrology_map(
            zs, cell_size * step, pick.get("stream", zero), pick.get("water", zero), vegetation=pick.get("vegetation")
        )
    return maps.shaded_relief(zs, cell_size * step)


def _window(hm: Heightmap, z: np.ndarray, rows: slice, cols: slice) -> Heightmap:
    """The heightmap of one tile: its heights, the map's CRS, the transform moved to the tile's corner."""
    t = hm.transform
    if t:
        a, b, c, d, e, f = t[:6]
        t = (a, b, c + a * cols.start + b * rows.start, d, e, f + d * cols.start + e * rows.start)
    return Heightmap(z=z, cell_size=hm.cell_size, crs=hm.crs, transform=t)


def export_run(
    run: str | os.PathLike,
    to: str | os.PathLike,
    formats: tuple[str, ...] | list[str] = DEFAULT_FORMATS,
    *,
    tile: int | None = None,
    overlap: int = 1,
    texture: str = "relief",
) -> dict:
    """Export ``run``'s final terrain into folder ``to``; returns the summary written to ``export.json``."""
    bad = [f for f in formats if f not in FORMATS]
    if bad:
        raise InputError(f"Unknown export format '{bad[0]}'; use one of {', '.join(FORMATS)}.")
    if texture not in TEXTURES:
        raise InputError(f"Unknown texture '{texture}'; use one of {', '.join(TEXTURES)}.")
    r = open_run(run)
    hm = r.height()
    out = Path(to)
    if out.exists() and not out.is_dir():
        raise InputError(f"'{out}' is a file; name a folder for the export with --to DIR.")
    z = np.asarray(hm.z, dtype=np.float64)
    layers = {layer.key: r.read_map(name).z for layer, name in r.layers()}
    ny, nx = z.shape
    windows = exports.tile_windows(ny, nx, tile, overlap) if tile is not None else [(0, 0, slice(0, ny), slice(0, nx))]
    lo, hi = float(np.nanmin(z)), float(np.nanmax(z))
    summary: dict = {
        "run": str(r.path),
        "kind": r.kind,
        "shape": [ny, nx],
        "cell_size_m": hm.cell_size,
        "crs": hm.crs,
        "transform": list(hm.transform) if hm.transform else None,
        "height_range_m": [lo, hi],
        "axes": "mesh: x east, y up, z south (m), origin at the north-west cell centre; rasters: rows north to south",
        "splat_channels": {"R": "rock", "G": "grass", "B": "sediment", "A": "water"},
        "formats": list(formats),
        "tiles": [],
    }
    for i, j, rows, cols in windows:
        folder = out / f"tile_r{i:02d}_c{j:02d}" if tile is not None else out
        zt = z[rows, cols]
        lt = {k: v[rows, cols] for k, v in layers.items()}
        files: list[Path] = []
        if {"glb", "gltf", "obj"} & set(formats):
            mesh = exports.terrain_mesh(zt, hm.cell_size, _texture(texture, zt, hm.cell_size, lt))
            for f in ("glb", "gltf", "obj"):
                if f in formats:
                    files += exports.write_mesh(folder / f"terrain.{f}", mesh, f)
        if "exr" in formats:
            files.append(exports.write_exr(folder / "height.exr", zt))
        if "raw32" in formats:
            files.append(exports.write_raw32(folder / "height.raw32", zt))
        # the 16-bit files of every tile share the whole map's range, so tiles join without steps
        for f, ext in (("png16", "png"), ("raw16", "r16")):
            if f in formats:
                info = heightmaps.write(folder / f"height.{ext}", _window(hm, zt, rows, cols), height_range=(lo, hi))
                files += [folder / f"height.{ext}"] + [Path(s) for s in info.get("sidecars", [])]
        if "splat" in formats:
            w = exports.splat_weights(
                zt, hm.cell_size, water=lt.get("water"), stream=lt.get("stream"),
                deposition=lt.get("deposition"), vegetation=lt.get("vegetation"),
            )  # fmt: skip
            files.append(exports.write_splat(folder / "splat.png", w))
        summary["tiles"].append(
            {
                "row": i, "col": j, "rows": [rows.start, rows.stop], "cols": [cols.start, cols.stop],
                "files": sorted(str(p.relative_to(out)) for p in files),
            }
        )  # fmt: skip
    if tile is None:
        summary["files"] = summary.pop("tiles")[0]["files"]
    else:
        summary["tile"], summary["overlap"] = tile, overlap
    write_json(out / "export.json", summary)
    return summary
