"""Member functions whose worker process dies, for the sweep's retry tests (imported by Dask workers)."""

import os
from pathlib import Path

from erosim.sweep.member import MemberTask, run_member


def die_once(task: MemberTask):
    """Kill the worker the first time member ``task`` is tried; run it normally on the retry."""
    marker = Path(task.folder).parent / f"{task.name}.died"
    if task.index == 0 and not marker.exists():
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.write_text("died once\n")
        os._exit(1)
    return run_member(task)


def die_always_on_first_member(task: MemberTask):
    """Member 0 kills its worker every time; the others run normally."""
    if task.index == 0:
        os._exit(1)
    return run_member(task)
