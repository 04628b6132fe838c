"""Node fields on a regular 3-D grid as VTK XML image data (``.vti``), the format ParaView opens as a
volume (VTK file formats, "XML File Formats" / ImageData).

Why a writer of our own: as for the particle frames (:mod:`erosim.io.particles`), the ``vtk`` wheel is
large and meshio does not write ImageData; the format is short. The grid is given by its origin and a
spacing; ``WholeExtent`` counts nodes from 0, x varying fastest — the C order of an array indexed
``[iz, iy, ix]``, written as is. Arrays are inline ``format="binary"`` (base64 of a UInt64 byte count
then the little-endian bytes), every file through :mod:`erosim.core.atomic`. :func:`read_vti` parses
such a file back.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from erosim.core.atomic import write_bytes
from erosim.core.errors import InputError
from erosim.io.particles import _data_array, _decode


def vti_bytes(fields: dict[str, np.ndarray], origin, spacing: float) -> bytes:
    """The XML text of an ImageData file holding node ``fields`` (each shaped (nz, ny, nx))."""
    if not fields:
        raise ValueError("vti_bytes needs at least one field")
    shapes = {np.shape(a) for a in fields.values()}
    if len(shapes) != 1 or len(next(iter(shapes))) != 3:
        raise ValueError(f"every field must be one 3-D (nz, ny, nx) shape, got {sorted(shapes)}")
    nz, ny, nx = next(iter(shapes))
    ox, oy, oz = (float(v) for v in origin)
    s = float(spacing)
    ext = f"0 {nx - 1} 0 {ny - 1} 0 {nz - 1}"
    parts = [
        '<?xml version="1.0"?>',
        '<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
        f'<ImageData WholeExtent="{ext}" Origin="{ox!r} {oy!r} {oz!r}" Spacing="{s!r} {s!r} {s!r}">',
        f'<Piece Extent="{ext}">',
        f'<PointData Scalars="{next(iter(fields))}">',
    ]
    parts += [_data_array(name, np.ascontiguousarray(a).ravel(), 1) for name, a in fields.items()]
    parts += ["</PointData>", "<CellData/>", "</Piece>", "</ImageData>", "</VTKFile>", ""]
    return "\n".join(parts).encode("ascii")


def write_vti(path: str | os.PathLike, fields: dict[str, np.ndarray], origin, spacing: float) -> Path:
    """Write :func:`vti_bytes` atomically."""
    return write_bytes(path, vti_bytes(fields, origin, spacing))


def read_vti(path: str | os.PathLike) -> dict[str, Any]:
    """Parse a file written by :func:`write_vti`: ``{"origin", "spacing", "fields"}``, fields shaped (nz, ny, nx)."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise InputError(f"Image data '{path}' cannot be read ({exc}); write it again.") from None
    img = root.find("ImageData")
    if root.get("type") != "ImageData" or img is None:
        raise InputError(f"'{path}' is not a VTK ImageData file; pass a .vti file.")
    x0, x1, y0, y1, z0, z1 = (int(v) for v in img.get("WholeExtent").split())
    shape = (z1 - z0 + 1, y1 - y0 + 1, x1 - x0 + 1)
    fields = {da.get("Name"): _decode(da).reshape(shape) for da in img.findall("Piece/PointData/DataArray")}
    return {
        "origin": tuple(float(v) for v in img.get("Origin").split()),
        "spacing": tuple(float(v) for v in img.get("Spacing").split()),
        "fields": fields,
    }
