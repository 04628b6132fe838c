"""The one runner of every scenario kind: its builder's :class:`~erosim.scenarios.setup.Setup` →
a :class:`~erosim.simulation.simulation.Simulation` → the run folder.

``erosim run`` calls :func:`run`; validation cases call :func:`execute` to get the simulation (and so
the models) back in their final state; ``erosim demo`` is :func:`demo`. ``--resume`` of a run that
has completed (and whose end the command line does not move) changes nothing: the summary is the one
line :data:`COMPLETE` says.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

from erosim.io.runfolder import RunFolder
from erosim.scenarios import estimate, kinds, loader
from erosim.scenarios.hydrology.build import clear_demo_folder
from erosim.scenarios.loader import Scenario, write_resolved
from erosim.simulation.simulation import Simulation

#: the summary's one key when ``--resume`` finds the run complete (its value: the line to print)
COMPLETE = "complete"


def _complete(out: RunFolder, time_now: float, stop: float, unit: str) -> dict[str, str]:
    line = (
        f"The run in '{out.path}' is complete (t = {time_now:.6g} of {stop:.6g} {unit}); nothing was run or "
        "changed. To run it further, resume it with a later end (--set run.t_end=… or the kind's own)."
    )
    return {COMPLETE: line}


def _completed_report(out: RunFolder) -> dict | None:
    """The folder's report when it says the run completed, else None."""
    try:
        rep = json.loads((out.path / "report.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return rep if isinstance(rep, dict) and rep.get("status") == "completed" else None


def execute(scenario: Scenario, out: RunFolder, *, resume: bool = False, progress: bool = True):
    """Build and run ``scenario`` into ``out``; returns (summary for the command line, simulation)."""

    # a resumed validation's interrupted run (the hook its session sets on RunFolder)
    resume = resume or (RunFolder.continues is not None and RunFolder.continues(out.path))
    done = _completed_report(out) if resume else None
    if done is not None:  # the same scenario (no --set moved its end): nothing to build
        try:
            same = (out.path / "scenario.toml").read_text(encoding="utf-8") == scenario.to_toml()
        except OSError:
            same = False
        progress_of = done.get("progress", {})
        if same and {"time", "stop_time", "unit"} <= set(progress_of):
            return _complete(out, progress_of["time"], progress_of["stop_time"], progress_of["unit"]), None
    guess = estimate.check(scenario.kind, scenario.config)  # refuses a run that would not fit in memory
    if guess is not None and guess.seconds is not None and progress:  # to read while a large terrain is generated
        print(f"{scenario.name}: {guess.line()}", file=sys.stderr, flush=True)
    builder = kinds.resolve(kinds.get(scenario.kind).builder)
    announce = progress and not resume and guess is not None and guess.setup_s is not None
    if announce:  # a set-up long enough to wait for (a voxel field): said before it starts and when it ends
        print(f"{scenario.name}: setting up (about {estimate.duration(guess.setup_s)}; the first run after an "
              "install or an update also compiles the kernels, a minute or two)…", file=sys.stderr, flush=True)
    t_setup = time.perf_counter()
    setup = builder(scenario, out)
    if announce:
        print(f"{scenario.name}: set up in {time.perf_counter() - t_setup:.1f} s", file=sys.stderr, flush=True)
    if setup.estimate is not None and progress and not resume:  # time known once the models are built
        print(f"{scenario.name}: {setup.estimate.line()}", file=sys.stderr, flush=True)
    for note in setup.warnings:
        out.warn(note)
    if progress and not resume:
        for line in [*(f"assumed: {a}" for a in setup.assumed), *(f"warning: {w}" for w in setup.warnings)]:
            print(f"{scenario.name}: {line}", file=sys.stderr, flush=True)
    sim = Simulation(
        setup.models, out=out, stop_time=setup.stop_time, callbacks=setup.callbacks, kind=scenario.kind,
        label=scenario.name, unit=setup.unit, checkpoint_wall_s=setup.checkpoint_wall_s, progress=progress,
    )  # fmt: skip
    if resume:
        sim.restore()
        if done is not None and sim.done():  # completed, and the command line did not move its end
            return _complete(out, sim.time, sim.stop_time, sim.unit), sim
    write_resolved(scenario, out)

    def report(s: Simulation) -> dict[str, Any]:
        return {"scenario": scenario.name, "preset": scenario.preset, **setup.report(s)}

    rep = sim.run(report=report, seed=setup.seed)
    return setup.summary(sim, rep), sim


def run(scenario: Scenario, out: RunFolder, *, resume: bool = False, progress: bool = True) -> dict:
    """Run ``scenario`` into ``out`` (``--resume``: continue from its checkpoint); the summary."""
    return execute(scenario, out, resume=resume, progress=progress)[0]


def demo(out: Path, progress: bool = True) -> dict:
    """``erosim demo``: the library ``hydrology`` scenario (512² mountains) into ``out``."""

    out = Path(out)
    clear_demo_folder(out)
    scenario = loader.load("hydrology")
    folder = RunFolder(out, overwrite=True)
    t0 = time.perf_counter()
    summary = run(scenario, folder, progress=progress)
    summary["total_s"] = round(time.perf_counter() - t0, 1)
    summary["open_first"] = str(out / "figures" / "hydrology.png")
    summary["then"] = (
        f"{out}/figures/hillshade_before.png vs hillshade_after.png, "
        f"{out}/figures/evolution.gif; engine exports in {out}/maps/ "
        "(height.png/.r16 + mask_*.png); budgets in report.json"
    )
    return summary
