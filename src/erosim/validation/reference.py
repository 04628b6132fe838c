"""Where the published reference data live (``shared/reference`` beside the checkout).

Search order: ``$EROSIM_REFERENCE``; ``<repo>/../shared/reference``; ``<repo>/shared/reference``.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np

from erosim.core.errors import InputError

_REPO = Path(__file__).resolve().parents[3]


def reference_dir() -> Path:
    env = os.environ.get("EROSIM_REFERENCE")
    candidates = [Path(env)] if env else []
    candidates += [_REPO.parent / "shared" / "reference", _REPO / "shared" / "reference"]
    for c in candidates:
        if c.is_dir():
            return c
    raise InputError(
        "Reference data not found (looked in "
        + ", ".join(str(c) for c in candidates)
        + "); set EROSIM_REFERENCE to the folder holding the reference CSV files."
    )


def read_csv(name: str) -> dict[str, np.ndarray]:
    """Columns of a reference CSV (``#`` comment lines skipped) by header name."""
    path = reference_dir() / name
    if not path.is_file():
        raise InputError(f"Reference file '{path}' is missing; restore it or set EROSIM_REFERENCE.")
    lines = [ln for ln in path.read_text(encoding="utf-8").splitlines() if ln.strip() and not ln.startswith("#")]
    rows = list(csv.reader(lines))
    cols: dict[str, np.ndarray] = {}
    for j, name in enumerate(rows[0]):
        values = [r[j].strip() for r in rows[1:]]
        try:
            cols[name.strip()] = np.array(values, dtype=np.float64)
        except ValueError:
            cols[name.strip()] = np.array(values)
    return cols
