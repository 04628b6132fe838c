"""Atomic file writes: write to a temporary name in the same folder, then rename.

An interrupted run therefore never leaves a truncated or corrupt file behind: a reader sees either
the old file or the complete new one (``os.replace`` is atomic on POSIX and Windows).
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

_UMASK = os.umask(0)
os.umask(_UMASK)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it to ``path``, on error delete it.

    Use it with libraries that write files themselves (rasterio, matplotlib, imageio)::

        with atomic_path(out / "height.tif") as tmp:
            write_geotiff(tmp, ...)
    """
    final = Path(path)
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(prefix=f".{final.stem}.", suffix=final.suffix + ".part", dir=final.parent)
    except OSError as exc:
        raise _naming(exc, final) from None
    os.close(fd)
    tmp = Path(tmp_name)
    os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; give the file the usual permissions
    try:
        yield tmp
        os.replace(tmp, final)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        if isinstance(exc, OSError) and exc.errno is not None:
            raise _naming(exc, final) from None
        raise


def _naming(exc: OSError, final: Path) -> OSError:
    """The same error, naming the file the user asked for rather than its temporary name."""
    named = type(exc)(exc.errno, exc.strerror, str(final))
    return named if exc.filename in (None, str(final)) or ".part" in str(exc.filename) else exc


def write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text(path: str | os.PathLike, text: str) -> Path:
    return write_bytes(path, text.encode("utf-8"))


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot write {type(obj).__name__} to JSON")


def to_json(obj: Any, ensure_ascii: bool = True) -> str:
    """JSON text of ``obj``; NumPy scalars and arrays become plain numbers and lists (``ensure_ascii=False``:
    characters such as ≥ as they are, for a terminal, not ``\\u2265``)."""
    return json.dumps(obj, indent=2, default=_json_default, allow_nan=True, ensure_ascii=ensure_ascii)


def write_json(path: str | os.PathLike, obj: Any) -> Path:
    return write_text(path, to_json(obj) + "\n")


def save_npz(path: str | os.PathLike, **arrays: Any) -> Path:
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
    return Path(path)


def save_npy(path: str | os.PathLike, array: np.ndarray) -> Path:
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.save(fh, array)
    return Path(path)
