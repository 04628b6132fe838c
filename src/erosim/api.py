"""The Python API: ``erosim.run`` runs a scenario exactly as ``erosim run`` does (``docs/api.md``).

::

    import erosim

    result = erosim.run("dam-break-2d", "runs/dam", run__t_end=0.05)   # ≡ --set run.t_end=0.05
    result.path, result.summary, result.report["steps"]

Overrides are keyword arguments with ``__`` for the dots of ``--set`` (``run__t_end=0.05`` is
``--set run.t_end=0.05``), or a ``set={"run.t_end": 0.05}`` dict; values are Python numbers,
strings, booleans, lists and dicts. :func:`execute` is the body of ``erosim run`` (the command line
calls it too), so the same scenario and overrides give the same run folder. Errors are
:class:`~erosim.core.errors.ErosimError` sentences, as on the command line.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import tomli_w

from erosim.core.errors import ConfigError, ErosimError, Interrupted, os_error_message

if TYPE_CHECKING:
    from erosim.scenarios.loader import Scenario


@dataclass(frozen=True)
class RunResult:
    """What a run left: its folder, the summary ``erosim run`` prints and ``report.json``."""

    path: Path
    summary: dict[str, Any]
    report: dict[str, Any] = field(repr=False)


def _toml(value: Any, key: str) -> str:
    """``value`` as a one-line TOML value (what ``--set KEY=VALUE`` reads)."""
    if hasattr(value, "tolist"):  # NumPy scalars and arrays
        value = value.tolist()
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v, key) for v in value) + "]"
    if isinstance(value, dict):
        names = {k: str(k) if re.fullmatch(r"[A-Za-z0-9_-]+", str(k)) else _toml(str(k), key) for k in value}
        return "{" + ", ".join(f"{names[k]} = {_toml(v, key)}" for k, v in value.items()) + "}"
    try:
        return tomli_w.dumps({"v": value})[len("v = ") :].rstrip("\n")
    except TypeError:
        raise ConfigError(
            f"Override '{key}' = {value!r} is not a TOML value; give a number, string, boolean, list or dict."
        ) from None


def overrides_list(set: dict[str, Any] | None = None, **overrides: Any) -> list[str]:
    """``--set`` items: ``set`` first, then ``overrides`` with ``__`` read as ``.`` (``run__t_end``)."""
    items = {**(set or {}), **{k.replace("__", "."): v for k, v in overrides.items()}}
    return [f"{key}={_toml(value, key)}" for key, value in items.items()]


def load_scenario(
    scenario: str | os.PathLike, *, preset: str | None = None, set: dict[str, Any] | None = None, **overrides: Any
) -> Scenario:
    """The validated scenario (a library name or a TOML path) with ``preset`` and overrides applied."""
    from erosim.scenarios import loader

    return loader.load(scenario, overrides_list(set, **overrides), preset)


def execute(scenario_ref, overrides, preset, out, resume, overwrite, *, progress: bool = True):
    """``erosim run``: load, open the run folder (``resume``: the folder to continue), run; returns
    (:class:`~erosim.io.runfolder.RunFolder`, summary)."""
    from erosim.io.runfolder import RunFolder, default_out
    from erosim.scenarios import loader

    if resume:
        folder = Path(resume)
        if scenario_ref is not None:
            raise ErosimError("Give either a scenario or --resume DIR, not both; --resume reads DIR/scenario.toml.")
        if not (folder / "scenario.toml").is_file():
            raise ErosimError(f"Cannot resume '{folder}': no scenario.toml there; pass a run folder erosim wrote.")
        scenario = loader.load(folder / "scenario.toml", overrides)
        run_folder = RunFolder(folder, resume=True)
    else:
        if scenario_ref is None:
            raise ErosimError("Name a scenario (see `erosim list`) or a TOML file, or pass --resume DIR.")
        scenario = loader.load(scenario_ref, overrides, preset)
        target = Path(out) if out else default_out(scenario.name)
        created = not target.exists()
        run_folder = RunFolder(target, overwrite=overwrite)
    from erosim.scenarios.runner import run as run_scenario

    try:
        summary = run_scenario(scenario, run_folder, resume=bool(resume), progress=progress)
    except BaseException as exc:
        resumable = (run_folder.path / "checkpoint").is_dir()
        started = (run_folder.path / "report.json").is_file()  # a started run reports whatever happens
        if not resume and created and not started and not resumable:
            # failed or stopped before the run started (bad input found while building it, Ctrl-C while
            # compiling, a disk too full for even the report or a checkpoint): nothing to keep, so it goes
            shutil.rmtree(run_folder.path, ignore_errors=True)
            if isinstance(exc, KeyboardInterrupt):
                msg = "Interrupted before the first step; nothing was kept, run the command again."
                raise Interrupted(msg) from None
        elif isinstance(exc, OSError) and resumable:
            hint = f" The run can then be continued with `erosim run --resume {run_folder.path}`."
            raise ErosimError(os_error_message(exc) + hint) from exc
        raise
    return run_folder, summary


def run(
    scenario: str | os.PathLike | None,
    out: str | os.PathLike | None = None,
    *,
    preset: str | None = None,
    resume: bool = False,
    progress: bool = False,
    overwrite: bool = False,
    set: dict[str, Any] | None = None,
    **overrides: Any,
) -> RunResult:
    """Run ``scenario`` (a library name or a TOML path) into ``out`` (default ``runs/<name>``), as
    ``erosim run`` does; ``resume=True`` continues the interrupted run in ``out`` (scenario None)."""
    if resume and (out is None or scenario is not None):
        raise ErosimError("resume=True continues the run in `out`; call run(None, out, resume=True).")
    try:
        folder, summary = execute(
            scenario, overrides_list(set, **overrides), preset, None if resume else out, out if resume else None,
            overwrite, progress=progress,
        )  # fmt: skip
    except OSError as exc:
        raise ErosimError(os_error_message(exc)) from exc
    report = json.loads((folder.path / "report.json").read_text(encoding="utf-8"))
    return RunResult(path=folder.path, summary=summary, report=report)
