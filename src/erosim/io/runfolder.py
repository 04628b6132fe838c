"""The run folder every run leaves behind (DESIGN.md, "Run folder").

::

    <out>/scenario.toml   resolved configuration (re-runnable as is)
    <out>/report.json     erosim version, seed, wall time, steps, metrics, warnings
    <out>/maps/ particles/ figures/ checkpoint/   gauges.csv  front.csv ...

All writes go through :mod:`erosim.core.atomic`, so no partial file is ever left.
"""

from __future__ import annotations

import contextlib
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from erosim import __version__
from erosim.core import atomic
from erosim.core.errors import ConfigError


def default_out(name: str, root: str | os.PathLike = "runs") -> Path:
    """``runs/<name>``, or ``runs/<name>-2``, ``-3`` … when that exists: earlier runs are never overwritten."""
    base = Path(root) / name
    if not base.exists():
        return base
    i = 2
    while (Path(root) / f"{name}-{i}").exists():
        i += 1
    return Path(root) / f"{name}-{i}"


class RunFolder:
    """A run's output folder; ``resume=True`` opens an existing one to continue it.

    An enclosing session (:func:`erosim.validation.session.validating`) may set ``reopens`` (whether a
    non-empty folder is opened as it is), ``on_open`` (called with each folder opened) and ``continues``
    (whether the runner continues a folder from its checkpoint); the hooks keep this layer free of what
    sits above it."""

    reopens: Callable[[Path], bool] | None = None
    on_open: Callable[[Path], None] | None = None
    continues: Callable[[Path], bool] | None = None

    def __init__(self, path: str | os.PathLike, *, resume: bool = False, overwrite: bool = False):
        self.path = Path(path)
        if self.path.exists() and not self.path.is_dir():
            raise ConfigError(f"'{self.path}' is a file, not a folder; name a folder for the run (--out DIR).")
        if resume:
            if not (self.path / "checkpoint").is_dir():
                raise ConfigError(
                    f"Cannot resume '{self.path}': it holds no checkpoint/ folder; "
                    "pass the folder of a run that was interrupted or wrote checkpoints."
                )
        elif (
            self.path.exists()
            and any(self.path.iterdir())
            and not overwrite
            and not (RunFolder.reopens is not None and RunFolder.reopens(self.path))
        ):  # (a folder of a validation being resumed is opened as it is)
            raise ConfigError(
                f"Output folder '{self.path}' already exists and is not empty; "
                "choose another --out, add --overwrite, or continue it with --resume."
            )
        self.path.mkdir(parents=True, exist_ok=True)
        if RunFolder.on_open is not None:
            RunFolder.on_open(self.path)
        self.started = time.perf_counter()
        self.warnings: list[str] = []

    # paths ------------------------------------------------------------------------------------
    def sub(self, name: str) -> Path:
        """A sub-folder (``maps``, ``particles``, ``figures``, ``checkpoint``), created on demand."""
        p = self.path / name
        p.mkdir(parents=True, exist_ok=True)
        return p

    @property
    def maps(self) -> Path:
        return self.sub("maps")

    @property
    def figures(self) -> Path:
        return self.sub("figures")

    @property
    def particles(self) -> Path:
        return self.sub("particles")

    @property
    def checkpoint(self) -> Path:
        return self.sub("checkpoint")

    # writes -----------------------------------------------------------------------------------
    def write_text(self, rel: str, text: str) -> Path:
        return atomic.write_text(self.path / rel, text)

    def write_json(self, rel: str, obj: Any) -> Path:
        return atomic.write_json(self.path / rel, obj)

    def atomic(self, rel: str):
        """Context manager yielding a temporary path that becomes ``<out>/rel`` on success."""
        return atomic.atomic_path(self.path / rel)

    def warn(self, message: str) -> None:
        """Record a warning for ``report.json``."""
        self.warnings.append(message)

    @contextlib.contextmanager
    def picture(self, path: str | os.PathLike):
        """``with out.picture(path): draw…``: a picture that cannot be drawn (e.g. heights of extreme
        magnitude) becomes a warning in ``report.json`` instead of losing the run's other outputs."""
        try:
            yield
        except Exception as exc:
            rel = os.path.relpath(path, self.path)
            self.warn(f"The picture '{rel}' could not be written ({type(exc).__name__}: {exc}); the run's maps "
                      "and report are complete.")  # fmt: skip

    def write_report(self, report: dict[str, Any], *, seed: int | None = None) -> Path:
        """Write ``report.json`` with the common header (version, seed, wall time, warnings) first."""
        head = {
            "erosim_version": __version__,
            "python": platform.python_version(),
            "seed": seed,
            "wall_time_s": round(time.perf_counter() - self.started, 3),
            "warnings": list(self.warnings),
        }
        return self.write_json("report.json", {**head, **report})
