"""Gauge points of a flood run from a CSV file (issue 9, item 5): columns ``name,x,y``.

x and y are in the DEM's own coordinates (its transform; a map without one spans x 0..nx·Δ, y 0..ny·Δ
with Δ the cell size). Every gauge must lie on a cell of the DEM that has data. Column names are matched
without regard to case or surrounding spaces; other columns are ignored; a UTF-8 byte-order mark is
allowed; blank lines are skipped. Any problem is one :class:`~erosim.core.errors.InputError` sentence
naming the file, the row (its line number in the file) and the fix.
"""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap, cell_of, on_grid

COLUMNS = ("name", "x", "y")


def _fmt(v: float) -> str:
    return f"{v:.10g}"


def read_gauge_points(path: str | os.PathLike, hm: Heightmap) -> list[tuple[str, float, float]]:
    """The gauges ``[(name, x, y), ...]`` of the CSV at ``path``, in file order, checked against ``hm``."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"The gauges file '{p}' does not exist; check gauges.file.")
    try:
        with open(p, newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.reader(fh))
    except UnicodeDecodeError:
        raise InputError(
            f"The gauges file '{p}' is not UTF-8 text; save it as a CSV file with columns name,x,y."
        ) from None
    numbered = [(k, row) for k, row in enumerate(rows, start=1) if any(cell.strip() for cell in row)]
    if not numbered:
        raise InputError(f"The gauges file '{p}' is empty; give a header line name,x,y and one line per gauge.")
    header = [cell.strip().lower() for cell in numbered[0][1]]
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise InputError(
            f"The gauges file '{p}' lacks the column{'s' if len(missing) > 1 else ''} {', '.join(missing)}; "
            "its first line must name the columns name,x,y."
        )
    col = {c: header.index(c) for c in COLUMNS}
    gauges: list[tuple[str, float, float]] = []
    seen: dict[str, int] = {}
    for line, row in numbered[1:]:
        cells = [row[col[c]].strip() if col[c] < len(row) else "" for c in COLUMNS]
        name = cells[0]
        if not name:
            raise InputError(f"Row {line} of the gauges file '{p}' has no name; give every gauge a name.")
        xy = []
        for key, text in zip(("x", "y"), cells[1:], strict=True):
            try:
                value = float(text)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise InputError(
                    f"Row {line} of the gauges file '{p}' has {key} = {text!r}, not a number; "
                    "give x and y as numbers in the DEM's coordinates."
                )
            xy.append(value)
        if name in seen:
            raise InputError(
                f"The gauge name {name!r} appears twice in '{p}' (rows {seen[name]} and {line}); "
                "give each gauge its own name."
            )
        seen[name] = line
        x, y = xy
        r, c = cell_of(hm, x, y)
        at = f"[{_fmt(x)}, {_fmt(y)}]"
        if not on_grid(hm, r, c):
            x0, x1, y0, y1 = hm.extent
            raise InputError(
                f"Gauge {name!r} at {at} (row {line} of '{p}') lies outside the DEM "
                f"(x {_fmt(x0)}..{_fmt(x1)}, y {_fmt(y0)}..{_fmt(y1)}); move it onto the map or remove it."
            )
        if not hm.valid[r, c]:
            raise InputError(
                f"Gauge {name!r} at {at} (row {line} of '{p}') lies on a nodata cell of the DEM; "
                "move it to a cell with data or remove it."
            )
        gauges.append((name, x, y))
    if not gauges:
        raise InputError(f"The gauges file '{p}' holds no gauge; add one line name,x,y per gauge below the header.")
    return gauges
