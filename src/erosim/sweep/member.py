"""One sweep member, as a Dask worker runs it: an ordinary run into its own folder (scenario.toml,
report.json, checkpoints), started afresh, resumed from its checkpoint, or kept as it is when it
already finished.

Finished means completed or unstable (an unstable run fails the same way again); a failed one (say
a disk that was full) and an interrupted one run again, from their checkpoint where they have one.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from erosim.api import execute
from erosim.core.errors import ErosimError, Interrupted
from erosim.simulation.simulation import stop_requested

FINISHED = ("completed", "unstable")


@dataclass(frozen=True)
class MemberTask:
    """What a worker needs to run member ``name``: absolute paths, its ``--set`` items, its threads."""

    index: int
    name: str
    folder: str
    base: str  # the sweep's base.toml
    overrides: tuple[str, ...]
    threads: int


def read_report(folder: Path) -> dict[str, Any] | None:
    """The member's report.json, or None where it has none (not started, or cut off while writing)."""
    try:
        return json.loads((folder / "report.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def record(index: int, name: str, report: dict[str, Any], action: str) -> dict[str, Any]:
    """A member's line in the sweep: index, name, status, message, action (ran, resumed, kept), wall_s."""
    return {
        "index": index,
        "member": name,
        "status": report.get("status", "failed"),
        "message": report.get("error", ""),
        "action": action,
        "wall_s": report.get("wall_time_s"),
    }


def has_checkpoint(folder: Path) -> bool:
    return (folder / "checkpoint").is_dir() and any((folder / "checkpoint").iterdir())


def run_member(task: MemberTask) -> dict[str, Any]:
    """Run, resume or keep member ``task``; its record (index, name, status, message, action, wall_s).

    Not started when the sweep asked this worker to stop (:func:`~erosim.simulation.simulation.request_stop`)."""
    import numba

    numba.set_num_threads(min(task.threads, numba.config.NUMBA_NUM_THREADS))
    folder = Path(task.folder)
    report = read_report(folder)
    if report is not None and report.get("status") in FINISHED:
        action = "kept"
    elif stop_requested():  # the sweep was interrupted before this member started
        action, report = "not started", {"status": "interrupted", "error": "the sweep was interrupted first"}
    else:
        action = "resumed" if has_checkpoint(folder) and (folder / "scenario.toml").is_file() else "ran"
        message = None
        try:
            if action == "resumed":
                execute(None, [], None, None, str(folder), False, progress=False)
            else:
                execute(task.base, list(task.overrides), None, str(folder), None, True, progress=False)
        except Interrupted:
            pass  # the report says interrupted; the next start resumes it
        except ErosimError as exc:
            message = str(exc)
        except Exception as exc:  # a bug in a member must not stop the sweep: record it
            message = f"{type(exc).__name__}: {exc}"
        report = read_report(folder) or {"status": "failed", "error": message}
        if message and not report.get("error"):
            report = {**report, "status": "failed", "error": message}
    return record(task.index, task.name, report, action)
