"""A validation that resumes as a validation.

``erosim validate CASE`` runs inside :func:`validating`: the first run folder the case opens is its
root, where ``validation_run.json`` records the case, its resolution and options. After a Ctrl-C,
``erosim validate --resume ROOT`` (or ``erosim run --resume`` of the root or of a run folder under it)
calls the case again inside :func:`validating` with ``resume=ROOT``: the case's folders under ROOT are
opened as they are, the run that was interrupted continues from its checkpoint (the others run
again), and the case then evaluates its criteria and writes ``validation.json`` as a fresh one does.
The cases themselves are unchanged: the hooks are :class:`~erosim.io.runfolder.RunFolder`'s ``reopens``
and ``on_open`` (set here) and :func:`erosim.scenarios.runner.execute`.
"""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Any

from erosim.core.atomic import write_json
from erosim.io.runfolder import RunFolder

MARK = "validation_run.json"


class _Session:
    case: str | None = None
    resolution: str = "default"
    options: dict[str, Any] = {}
    root: Path | None = None
    resume: Path | None = None


_S = _Session()


@contextlib.contextmanager
def validating(case: str, resolution: str, options: dict[str, Any], resume: Path | None = None):
    """Run a validation case inside: its root folder is marked, and with ``resume`` its folders reopened."""

    _S.case, _S.resolution, _S.options = case, resolution, dict(options)
    _S.root, _S.resume = (Path(resume) if resume else None), (Path(resume).resolve() if resume else None)
    RunFolder.reopens, RunFolder.on_open, RunFolder.continues = reopens, opened, continues
    try:
        yield _S
    finally:
        _S.case, _S.root, _S.resume = None, None, None
        RunFolder.reopens = RunFolder.on_open = RunFolder.continues = None


def root() -> Path | None:
    """The running validation's root folder (None before its first folder, or outside a validation)."""
    return _S.root


def reopens(path: Path) -> bool:
    """True when ``path`` is a folder of a validation being resumed (its contents kept, not refused)."""
    return _S.resume is not None and Path(path).resolve().is_relative_to(_S.resume)


def opened(path: Path) -> None:
    """Called by each new run folder: the first one of a validation is its root, marked with the case."""
    if _S.case is None or _S.root is not None:
        return
    _S.root = Path(path)

    write_json(Path(path) / MARK, {"case": _S.case, "resolution": _S.resolution, "options": _S.options})


def continues(path: Path) -> bool:
    """True when ``path`` is a run of a resumed validation that stopped before completing (checkpoint,
    report not "completed"): the runner then continues it from its checkpoint instead of starting it."""
    if _S.resume is None or not Path(path).resolve().is_relative_to(_S.resume):
        return False
    if not (Path(path) / "checkpoint").is_dir():
        return False
    try:
        status = json.loads((Path(path) / "report.json").read_text(encoding="utf-8")).get("status")
    except (OSError, ValueError, AttributeError):
        return False
    return status != "completed"


def find(folder: str | Path) -> tuple[Path, dict] | None:
    """The validation whose root is ``folder`` or one of its two parents: (root, its record)."""
    p = Path(folder)
    for cand in (p, p.parent, p.parent.parent):
        mark = cand / MARK
        if mark.is_file():
            try:
                rec = json.loads(mark.read_text(encoding="utf-8"))
            except (OSError, ValueError):
                return None
            if isinstance(rec, dict) and "case" in rec:
                return cand, rec
    return None
