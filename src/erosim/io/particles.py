"""Particle frames as VTK XML PolyData (``.vtp``) plus a ParaView collection (``.pvd``).

Why a small writer of our own: the ``vtk`` wheel is ~100 MB and meshio writes unstructured grids
(``.vtu``) but not PolyData; the PolyData XML format for a point cloud is short and fully specified
(VTK file formats, "XML File Formats" / PolyData). Each frame holds the points, one vertex cell per
point (so ParaView draws them without a glyph filter) and point arrays (velocity, pressure,
density, ...). Arrays are stored inline as ``format="binary"``: base64 of a UInt64 byte-count header
followed by the raw little-endian bytes. 2-D positions/vectors are padded with z = 0.

:func:`read_vtp` parses such a file back (tests use it to check frames are well-formed and exact).
All files are written through :mod:`erosim.core.atomic`, so an interrupted run never leaves a
truncated frame or collection.
"""

from __future__ import annotations

import base64
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from erosim.core.atomic import write_bytes, write_text
from erosim.core.errors import InputError

_VTK_TYPES = {
    np.dtype("<f4"): "Float32",
    np.dtype("<f8"): "Float64",
    np.dtype("<i4"): "Int32",
    np.dtype("<i8"): "Int64",
    np.dtype("<u1"): "UInt8",
}
_NP_TYPES = {v: k for k, v in _VTK_TYPES.items()}


def _as3(a: np.ndarray) -> np.ndarray:
    """(n, d) with d ≤ 3 → (n, 3), zero-padded."""
    a = np.asarray(a)
    if a.ndim == 2 and a.shape[1] < 3:
        a = np.concatenate([a, np.zeros((a.shape[0], 3 - a.shape[1]), a.dtype)], axis=1)
    return a


def _encode(a: np.ndarray) -> str:
    a = np.ascontiguousarray(a)
    if a.dtype not in _VTK_TYPES:
        a = a.astype("<f8" if a.dtype.kind == "f" else "<i8")
    raw = a.astype(a.dtype.newbyteorder("<"), copy=False).tobytes()
    return base64.b64encode(np.uint64(len(raw)).tobytes() + raw).decode("ascii")


def _data_array(name: str, a: np.ndarray, ncomp: int) -> str:
    a = np.asarray(a)
    if a.dtype not in _VTK_TYPES:
        a = a.astype("<f8" if a.dtype.kind == "f" else "<i8")
    return (
        f'<DataArray type="{_VTK_TYPES[a.dtype]}" Name="{name}" NumberOfComponents="{ncomp}" '
        f'format="binary">{_encode(a)}</DataArray>'
    )


def vtp_bytes(positions: np.ndarray, fields: dict[str, np.ndarray], time: float | None = None) -> bytes:
    """The XML text of one PolyData frame (points + vertex cells + point data)."""
    pts = _as3(np.asarray(positions))
    n = pts.shape[0]
    parts = [
        '<?xml version="1.0"?>',
        '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
        "<PolyData>",
    ]
    if time is not None:
        parts.append(
            '<FieldData><DataArray type="Float64" Name="TimeValue" NumberOfTuples="1" '
            f'format="ascii">{float(time)!r}</DataArray></FieldData>'
        )
    parts.append(
        f'<Piece NumberOfPoints="{n}" NumberOfVerts="{n}" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="0">'
    )
    parts.append("<PointData>")
    for name, arr in fields.items():
        a = np.asarray(arr)
        if a.ndim == 2:
            a = _as3(a)
            parts.append(_data_array(name, a, a.shape[1]))
        else:
            parts.append(_data_array(name, a, 1))
    parts.append("</PointData>")
    parts.append("<Points>" + _data_array("Points", pts, 3) + "</Points>")
    idx = np.arange(n, dtype="<i8")
    parts.append("<Verts>" + _data_array("connectivity", idx, 1) + _data_array("offsets", idx + 1, 1) + "</Verts>")
    parts += ["</Piece>", "</PolyData>", "</VTKFile>", ""]
    return "\n".join(parts).encode("ascii")


def write_vtp(
    path: str | os.PathLike, positions: np.ndarray, fields: dict[str, np.ndarray], time: float | None = None
) -> Path:
    """Write one frame atomically."""
    return write_bytes(path, vtp_bytes(positions, fields, time))


def _decode(elem: ET.Element) -> np.ndarray:
    dtype = _NP_TYPES[elem.get("type")]
    ncomp = int(elem.get("NumberOfComponents", "1"))
    if elem.get("format") == "ascii":
        arr = np.array((elem.text or "").split(), dtype=dtype)
    else:
        raw = base64.b64decode((elem.text or "").strip())
        nbytes = int(np.frombuffer(raw[:8], "<u8")[0])
        arr = np.frombuffer(raw[8 : 8 + nbytes], dtype=dtype)
    return arr.reshape(-1, ncomp) if ncomp > 1 else arr


def read_vtp(path: str | os.PathLike) -> dict[str, Any]:
    """Parse a frame written by :func:`write_vtp`: ``{"points", "verts", "fields", "time"}``."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise InputError(f"Particle frame '{path}' cannot be read ({exc}); write it again.") from None
    piece = root.find("PolyData/Piece")
    if root.get("type") != "PolyData" or piece is None:
        raise InputError(f"'{path}' is not a VTK PolyData file; pass a .vtp frame.")
    out: dict[str, Any] = {"time": None, "fields": {}}
    tv = root.find("PolyData/FieldData/DataArray[@Name='TimeValue']")
    if tv is not None:
        out["time"] = float(_decode(tv)[0])
    out["points"] = _decode(piece.find("Points/DataArray"))
    out["verts"] = _decode(piece.find("Verts/DataArray[@Name='connectivity']"))
    out["n_points"] = int(piece.get("NumberOfPoints"))
    for da in piece.findall("PointData/DataArray"):
        out["fields"][da.get("Name")] = _decode(da)
    return out


def pvd_text(frames: list[tuple[float, str]]) -> str:
    """A ParaView collection listing ``(time, relative file)`` frames."""
    rows = "\n".join(f'    <DataSet timestep="{t!r}" group="" part="0" file="{f}"/>' for t, f in frames)
    return (
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
        f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n"
    )


def read_pvd(path: str | os.PathLike) -> list[tuple[float, str]]:
    """``(time, file)`` rows of a collection written by :class:`FrameSeries`."""
    root = ET.parse(path).getroot()
    return [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]


class FrameSeries:
    """Numbered frames ``<folder>/frame_00000.vtp`` … and ``<folder>/<name>.pvd`` kept up to date.

    ``frames`` (time, file name) is part of a run's checkpoint, so a resumed run rewrites the
    collection with exactly the frames of the uninterrupted run.
    """

    def __init__(
        self, folder: str | os.PathLike, name: str = "particles", frames: list[tuple[float, str]] | None = None
    ):
        self.folder = Path(folder)
        self.name = name
        self.frames: list[tuple[float, str]] = [(float(t), str(f)) for t, f in (frames or [])]

    def write(self, t: float, positions: np.ndarray, fields: dict[str, np.ndarray]) -> Path:
        fname = f"frame_{len(self.frames):05d}.vtp"
        path = write_vtp(self.folder / fname, positions, fields, time=t)
        self.frames.append((float(t), fname))
        write_text(self.folder / f"{self.name}.pvd", pvd_text(self.frames))
        return path
