"""Exports artists import into game engines and DCC tools: meshes, 32-bit heightmaps, splat maps, tiles.

Why these and with what:

| format   | library            | what is in it                                                          |
|----------|--------------------|------------------------------------------------------------------------|
| GLB/glTF | trimesh            | the terrain as a triangle mesh, Y up, metres, texture inside (one file) |
| OBJ      | trimesh            | the same mesh (``.obj`` + ``.mtl`` + texture PNG)                       |
| EXR      | OpenEXR (ASWF)     | heights as one 32-bit float channel ``Y`` (ZIP, lossless: exact)        |
| RAW32    | NumPy              | heights as headerless little-endian float32, rows north to south       |
| PNG16    | :mod:`.heightmaps` | 16-bit greyscale over the height range (in ``export.json``)             |
| RAW16    | :mod:`.heightmaps` | headerless little-endian uint16 over the height range                  |
| splat    | Pillow             | RGBA 8-bit weights R rock, G grass, B sediment, A water (sum 255)      |

Mesh axes (glTF's convention, which OBJ importers share): x east, y up, z south, in metres, the
origin at the centre of the north-west cell; vertex (row i, column j) is (j·Δ, z[i, j], i·Δ) and its
texture coordinate is (j/(nx−1), 1 − i/(ny−1)), so the texture's top row is the map's north row.

Splat weights (:func:`splat_weights`) split each cell in a fixed order, so the four weights sum to 1
(to rounding): water takes w = max(min(1, depth/0.5 m), min(1, stream/0.5)); sediment takes
s = min(1, deposition/d95) of the rest (d95: the 95th percentile of positive deposition); rock takes
r = smoothstep of the slope from 25° to 45°, less where trees grow (× (1 − vegetation)), of what is
left; grass gets the remainder. The PNG stores them rounded so that every pixel's four bytes sum to
255 (largest remainder).

Tiles (:func:`tile_windows`): windows of ``tile`` cells a side stepping by ``tile − overlap``, so
neighbours share ``overlap`` rows or columns (1: the shared edge vertices of seamless meshes); the
last row and column of tiles are cut at the map's edge. Every file is written through
:mod:`erosim.core.atomic`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from erosim.core.atomic import atomic_path, write_bytes
from erosim.core.errors import InputError

WATER_DEPTH_REF = 0.5  # m of water that make a cell all water in the splat map
STREAM_REF = 0.5  # stream value that makes a cell all water
ROCK_SLOPE = (25.0, 45.0)  # degrees: rock starts, rock is full


# ------------------------------------------------------------------------------------------- meshes
def terrain_mesh(z: np.ndarray, cell_size: float, texture: np.ndarray | None = None):
    """A ``trimesh.Trimesh`` of the heightmap (axes in the module docstring); ``texture`` RGB in [0, 1]."""
    import trimesh

    z = np.asarray(z, dtype=np.float64)
    ny, nx = z.shape
    jj, ii = np.meshgrid(np.arange(nx), np.arange(ny))
    vertices = np.column_stack([jj.ravel() * cell_size, z.ravel(), ii.ravel() * cell_size])
    idx = np.arange(ny * nx).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    # counter-clockwise seen from above (+y): normals point up
    faces = np.concatenate([np.column_stack([a, c, b]), np.column_stack([b, c, d])])
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    if texture is not None:
        from PIL import Image

        uv = np.column_stack([jj.ravel() / max(nx - 1, 1), 1.0 - ii.ravel() / max(ny - 1, 1)])
        img = Image.fromarray(_rgb8(texture))
        material = trimesh.visual.material.SimpleMaterial(image=img)
        mesh.visual = trimesh.visual.TextureVisuals(uv=uv, image=img, material=material)
    return mesh


def _rgb8(rgb: np.ndarray) -> np.ndarray:
    a = np.asarray(rgb)
    if a.dtype != np.uint8:
        a = np.clip(np.rint(np.nan_to_num(a.astype(np.float64)) * 255.0), 0, 255).astype(np.uint8)
    return a


def write_mesh(path: str | os.PathLike, mesh, fmt: str) -> list[Path]:
    """Write ``mesh`` as ``glb``, ``gltf`` (with its buffer and texture files) or ``obj`` (+ .mtl, texture)."""
    p = Path(path)
    if fmt == "glb":
        return [write_bytes(p, mesh.export(file_type="glb"))]
    if fmt == "gltf":  # one JSON file, its buffers and texture embedded as data URIs
        from trimesh.exchange.gltf import export_gltf

        files = export_gltf(mesh.scene(), embed_buffers=True)
        return [write_bytes(p, files["model.gltf"])]
    if fmt == "obj":
        from trimesh.exchange.obj import export_obj

        mtl = p.with_suffix(".mtl").name
        text, extra = export_obj(mesh, include_normals=False, return_texture=True, mtl_name=mtl)
        written = [write_bytes(p.parent / name, data) for name, data in extra.items()]
        written.append(write_bytes(p, text.encode("utf-8")))
        return written
    raise InputError(f"Unknown mesh format '{fmt}'; use glb, gltf or obj.")


# -------------------------------------------------------------------------------------- heightmaps
def write_exr(path: str | os.PathLike, z: np.ndarray) -> Path:
    """Heights as a one-channel (``Y``) 32-bit float OpenEXR image, ZIP-compressed (lossless)."""
    import OpenEXR

    a = np.ascontiguousarray(np.asarray(z, dtype=np.float32))
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with atomic_path(path) as tmp:
        with OpenEXR.File(header, {"Y": a}) as f:
            f.write(str(tmp))
    return Path(path)


def read_exr(path: str | os.PathLike) -> np.ndarray:
    """The ``Y`` channel of an EXR written by :func:`write_exr` (float32)."""
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        channels = f.channels()
        if "Y" not in channels:
            raise InputError(f"'{path}' has no Y channel; read an EXR heightmap written by erosim export.")
        return np.array(channels["Y"].pixels, dtype=np.float32)


def write_raw32(path: str | os.PathLike, z: np.ndarray) -> Path:
    """Heights as headerless little-endian float32, rows north to south (shape in ``export.json``)."""
    return write_bytes(path, np.ascontiguousarray(np.asarray(z, dtype="<f4")).tobytes())


def read_raw32(path: str | os.PathLike, shape: tuple[int, int]) -> np.ndarray:
    return np.fromfile(path, dtype="<f4").reshape(shape)


# ---------------------------------------------------------------------------------------- splat map
def _smoothstep(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    t = np.clip((x - lo) / (hi - lo), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _unit(a: np.ndarray | None, ref: float, shape) -> np.ndarray:
    if a is None:
        return np.zeros(shape)
    return np.clip(np.nan_to_num(np.asarray(a, dtype=np.float64)) / ref, 0.0, 1.0)


def splat_weights(
    z: np.ndarray,
    cell_size: float,
    *,
    water: np.ndarray | None = None,
    stream: np.ndarray | None = None,
    deposition: np.ndarray | None = None,
    vegetation: np.ndarray | None = None,
) -> np.ndarray:
    """(ny, nx, 4) float weights rock, grass, sediment, water that sum to 1 (rules in the module docstring)."""
    z = np.asarray(z, dtype=np.float64)
    shape = z.shape
    w = np.maximum(_unit(water, WATER_DEPTH_REF, shape), _unit(stream, STREAM_REF, shape))
    if deposition is not None:
        dep = np.nan_to_num(np.asarray(deposition, dtype=np.float64))
        pos = dep[dep > 0]
        ref = float(np.percentile(pos, 95)) if pos.size else 1.0
        s = _unit(dep, ref if ref > 0 else 1.0, shape)
    else:
        s = np.zeros(shape)
    d_row, d_col = np.gradient(z, cell_size)
    slope = np.degrees(np.arctan(np.hypot(d_row, d_col)))
    r = _smoothstep(slope, *ROCK_SLOPE) * (1.0 - _unit(vegetation, 1.0, shape))
    water_w = w
    sediment_w = (1.0 - w) * s
    rock_w = (1.0 - w) * (1.0 - s) * r
    grass_w = (1.0 - w) * (1.0 - s) * (1.0 - r)
    return np.stack([rock_w, grass_w, sediment_w, water_w], axis=-1)


def splat_bytes(weights: np.ndarray) -> np.ndarray:
    """uint8 RGBA of float weights, each pixel's four bytes summing to 255 (largest remainder)."""
    x = np.clip(np.asarray(weights, dtype=np.float64), 0.0, None)
    total = x.sum(axis=-1, keepdims=True)
    x = np.where(total > 0, x / np.where(total > 0, total, 1.0), np.array([0.0, 1.0, 0.0, 0.0]))
    scaled = x * 255.0
    base = np.floor(scaled)
    short = (255 - base.sum(axis=-1)).astype(np.int64)  # 0..3 units to hand out
    order = np.argsort(-(scaled - base), axis=-1, kind="stable")
    ranks = np.argsort(order, axis=-1, kind="stable")  # rank of each channel's remainder
    base += ranks < short[..., None]
    return base.astype(np.uint8)


def write_splat(path: str | os.PathLike, weights: np.ndarray) -> Path:
    """The splat map as an RGBA PNG (R rock, G grass, B sediment, A water)."""
    from PIL import Image

    with atomic_path(path) as tmp:
        Image.fromarray(splat_bytes(weights), mode="RGBA").save(tmp, format="PNG")
    return Path(path)


# -------------------------------------------------------------------------------------------- tiles
def tile_windows(ny: int, nx: int, tile: int, overlap: int) -> list[tuple[int, int, slice, slice]]:
    """``(row, col, rows, cols)`` windows of ``tile`` cells stepping by ``tile − overlap`` over the map."""
    if tile < 2:
        raise InputError(f"--tile {tile} is too small; give a tile size of at least 2 cells.")
    if not 0 <= overlap < tile:
        raise InputError(f"--overlap {overlap} must be at least 0 and less than the tile size {tile}.")

    def starts(n: int) -> list[int]:
        step = tile - overlap
        out = [0]
        while out[-1] + tile < n:
            out.append(out[-1] + step)
        return out

    return [
        (i, j, slice(r0, min(r0 + tile, ny)), slice(c0, min(c0 + tile, nx)))
        for i, r0 in enumerate(starts(ny))
        for j, c0 in enumerate(starts(nx))
    ]
