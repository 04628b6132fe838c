"""The one runner of every scenario kind: its builder's :class:`~erosim.scenarios.setup.Setup` →
a :class:`~erosim.simulation.simulation.Simulation` → the run folder.

``erosim run`` calls :func:`run`; validation cases call :func:`execute` to get the simulation (and so
the models) back in their final state; ``erosim demo`` is :func:`demo`.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

from erosim.io.runfolder import RunFolder
from erosim.scenarios import kinds
from erosim.scenarios.loader import Scenario, write_resolved
from erosim.simulation.simulation import Simulation


def execute(scenario: Scenario, out: RunFolder, *, resume: bool = False, progress: bool = True):
    """Build and run ``scenario`` into ``out``; returns (summary for the command line, simulation)."""
    from erosim.scenarios import estimate

    guess = estimate.check(scenario.kind, scenario.config)  # refuses a run that would not fit in memory
    if guess is not None and guess.seconds is not None and progress:  # to read while a large terrain is generated
        print(f"{scenario.name}: {guess.line()}", file=sys.stderr, flush=True)
    builder = kinds.resolve(kinds.get(scenario.kind).builder)
    setup = builder(scenario, out)
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
    from erosim.scenarios import loader
    from erosim.scenarios.builders_hydrology import clear_demo_folder

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
