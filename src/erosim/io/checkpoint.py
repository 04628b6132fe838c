"""Checkpoints: a run's complete state as one ``.npz`` written atomically.

``save`` stores arrays and scalars (plus a small JSON header) to ``<out>/checkpoint/state.npz``;
``load`` returns the same dict. Resuming from it must reproduce the uninterrupted run bit for bit,
so a model's checkpoint holds *everything* that its next step reads (RNG state included).
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from erosim.core.atomic import save_npz, to_json
from erosim.core.errors import InputError

FILE = "state.npz"


def save(folder: str | os.PathLike, state: dict[str, Any], meta: dict[str, Any] | None = None) -> Path:
    """Write ``state`` (name → array or scalar) and ``meta`` (JSON-able) to ``folder/state.npz``."""
    arrays = {k: np.asarray(v) for k, v in state.items()}
    arrays["__meta__"] = np.frombuffer(to_json(meta or {}).encode(), dtype=np.uint8)
    return save_npz(Path(folder) / FILE, **arrays)


def load(folder: str | os.PathLike) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Read what :func:`save` wrote; 0-d arrays come back as NumPy scalars' arrays (use ``.item()``)."""
    path = Path(folder) / FILE
    if not path.is_file():
        raise InputError(f"No checkpoint at '{path}'; resume a run folder that has checkpoint/{FILE}.")
    try:
        with np.load(path, allow_pickle=False) as data:
            state = {k: data[k] for k in data.files if k != "__meta__"}
            meta = json.loads(bytes(data["__meta__"]).decode()) if "__meta__" in data.files else {}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as exc:  # truncated or corrupt
        raise InputError(
            f"Checkpoint '{path}' is damaged ({type(exc).__name__}: {exc}), so the run cannot be resumed; "
            "start it again into a new folder (erosim run SCENARIO --out NEW), or delete this one."
        ) from None
    return state, meta
