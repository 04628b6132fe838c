"""``erosim sweep``: plan the members, run them on Dask, aggregate; resume where a sweep stopped.

The sweep folder::

    <out>/sweep.json      the plan: varied settings, every member's settings, threads per member
    <out>/base.toml       the resolved base scenario every member starts from
    <out>/members/m0000/  ordinary run folders (scenario.toml, report.json, maps/, checkpoint/)
    <out>/sweep.csv       one row per member: settings, status, message, the report's numbers
    <out>/sweep.nc        statistics and exceedance probabilities per cell (erosim.sweep.aggregate)
    <out>/figures/        probability maps
    <out>/report.json     the sweep's own report: members by status, workers, wall time

Running the same sweep into the same folder again, or ``erosim sweep --resume <out>``, keeps the
finished members, resumes interrupted ones from their checkpoints and runs the rest.
"""

from __future__ import annotations

import shutil
import sys
import time
from pathlib import Path
from typing import Any

from erosim.core.atomic import write_json, write_text
from erosim.core.errors import ConfigError, ErosimError, Interrupted
from erosim.io.runfolder import default_out
from erosim.sweep import aggregate, dask_executor
from erosim.sweep.member import FINISHED, MemberTask, read_report, record, run_member
from erosim.sweep.plan import BASE_FILE, PLAN_FILE, Plan, build

OUTPUTS = ("members", "sweep.csv", "sweep.nc", "figures", "report.json", PLAN_FILE, BASE_FILE)


class MemberProgress:
    """``<label> 3/8 · <note> · running 2 · failed 0 · ETA 40 s`` on the console (rich; silent when disabled):
    the members of a sweep, the tiles of a tiled build. ``done`` members were finished before it started; the
    ETA counts the members run since (a kept one costs nothing)."""

    def __init__(self, label: str, total: int, done: int, slots: int, enabled: bool, note: str = ""):
        self.total, self.done, self.failed, self.slots, self.note = total, done, 0, slots, note
        self.started, self.ran = time.perf_counter(), 0
        self._progress = None
        if enabled:
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

            self._progress = Progress(
                TextColumn(f"[bold]{label}"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.fields[state]}")
            )
            self._task = self._progress.add_task(label, total=total, completed=done, state=self.state())
            self._progress.start()

    def state(self) -> str:
        running = min(self.slots, self.total - self.done)
        text = f"running {running} · failed {self.failed}"
        if self.note:
            text = f"{self.note} · {text}"
        if 0 < self.ran and self.done < self.total:
            text += f" · ETA {(time.perf_counter() - self.started) / self.ran * (self.total - self.done):,.0f} s"
        return text

    def set_note(self, note: str) -> None:
        self.note = note
        self._show()

    def member_done(self, record: dict[str, Any]) -> None:
        self.done += 1
        self.ran += record.get("action") != "kept"
        self.failed += record["status"] != "completed"
        self._show()

    def _show(self) -> None:
        if self._progress is not None:
            self._progress.update(self._task, completed=self.done, state=self.state())

    def close(self) -> None:
        if self._progress is not None:
            self._progress.stop()
            self._progress = None


def _folder_for(plan: Plan, base_toml: str, out: str | None, overwrite: bool) -> tuple[Path, Plan]:
    """The sweep folder and its plan: new, or the one holding this very sweep (continued with the plan
    it started with, threads included); refused otherwise."""
    folder = Path(out) if out else default_out(f"{plan.scenario}-sweep")
    if folder.exists() and not folder.is_dir():
        raise ConfigError(f"'{folder}' is a file, not a folder; name a folder for the sweep (--out DIR).")
    if overwrite:
        for name in OUTPUTS:
            target = folder / name
            if target.is_dir():
                shutil.rmtree(target)
            elif target.exists():
                target.unlink()
    elif (folder / PLAN_FILE).is_file():
        earlier = Plan.read(folder)
        if not earlier.same_members(plan):
            raise ConfigError(
                f"'{folder}' holds another sweep (other members); choose another --out, add --overwrite to "
                f"replace it, or continue it with `erosim sweep --resume {folder}`."
            )
        return folder, earlier
    elif folder.exists() and any(folder.iterdir()):
        raise ConfigError(
            f"Output folder '{folder}' already exists and is not empty; choose another --out or add --overwrite."
        )
    folder.mkdir(parents=True, exist_ok=True)
    write_text(folder / BASE_FILE, base_toml)
    write_text(folder / PLAN_FILE, plan.to_json())
    return folder, plan


def plan_threads(scheduler: str | None, workers: int | None, threads: int | None, members: int) -> tuple[int, int]:
    """(workers, Numba threads per member): by default workers × threads = the local cores."""
    for name, value in (("--workers", workers), ("--threads-per-member", threads)):
        if value is not None and value < 1:
            raise ConfigError(f"{name} {value} is not valid; give a whole number of at least 1.")
    cores = dask_executor.local_cores()
    if scheduler is not None:
        return workers or 0, threads or 1  # the remote cluster's workers are its own
    n_workers = workers or max(1, min(cores, members))
    return n_workers, threads or max(1, cores // n_workers)


def run_sweep(
    scenario_ref: str | None,
    overrides: list[str] = (),  # type: ignore[assignment]
    preset: str | None = None,
    vary: list[str] = (),  # type: ignore[assignment]
    *,
    design: str | None = None,
    seeds: int | None = None,
    random_seed: int | None = None,
    quantiles: list[float] | None = None,
    exceed: list[str] | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    threads: int | None = None,
    out: str | None = None,
    resume: str | None = None,
    overwrite: bool = False,
    progress: bool = True,
    timeout_s: float = 10.0,
    member_function=run_member,
) -> dict[str, Any]:
    """Run a sweep (see the module docstring); returns its summary (also ``report.json``)."""
    t0 = time.perf_counter()
    if resume:
        if scenario_ref is not None or vary:
            raise ErosimError(
                "Give either a scenario and --vary, or --resume DIR, not both; --resume reads DIR/sweep.json."
            )
        folder = Path(resume)
        plan = Plan.read(folder)
        n_workers, _ = plan_threads(scheduler, workers, plan.threads, len(plan.members))
    else:
        if scenario_ref is None:
            raise ErosimError("Name a scenario to sweep (see `erosim list`), or pass --resume DIR.")
        plan, base_toml = build(
            scenario_ref, list(overrides), preset, list(vary), design_name=design, seeds=seeds,
            random_seed=random_seed, quantiles=quantiles, exceed=exceed, threads=1,
        )  # fmt: skip
        n_workers, plan.threads = plan_threads(scheduler, workers, threads, len(plan.members))
        folder, plan = _folder_for(plan, base_toml, out, overwrite)
    base = (folder / BASE_FILE).resolve()
    tasks, records = [], {}
    for i in range(len(plan.members)):
        name = plan.member_name(i)
        member_dir = (folder / "members" / name).resolve()
        report = read_report(member_dir)
        if report is not None and report.get("status") in FINISHED:
            records[i] = record(i, name, report, "kept")
        else:
            tasks.append(MemberTask(i, name, str(member_dir), str(base), tuple(plan.overrides(i)), plan.threads))
    if progress:
        print(
            f"sweep {plan.scenario}: {len(plan.members)} members ({len(records)} finished earlier), "
            f"{'scheduler ' + scheduler if scheduler else f'{n_workers} local workers'} × {plan.threads} "
            f"thread(s) each → {folder}",
            file=sys.stderr, flush=True,
        )  # fmt: skip
    bar = MemberProgress("sweep", len(plan.members), len(records), max(1, n_workers), progress, note="members")
    try:
        if tasks:
            with dask_executor.connect(scheduler, n_workers, timeout_s) as client:
                for rec in dask_executor.run_tasks(
                    client, tasks, on_done=bar.member_done, member_function=member_function
                ):
                    records[rec["index"]] = rec
        bar.close()
        ordered = [records[i] for i in range(len(plan.members))]
        summary = aggregate.aggregate(folder, plan, ordered)
    except KeyboardInterrupt:
        raise Interrupted(
            f"Sweep interrupted; finished members are kept and running ones wrote checkpoints — continue with "
            f"`erosim sweep --resume {folder}`."
        ) from None
    finally:
        bar.close()
    summary = {
        "sweep": plan.scenario, "kind": plan.kind, "design": plan.design, "varied": plan.keys, **summary,
        "ran_now": sum(r["action"] != "kept" for r in ordered), "workers": n_workers or "remote",
        "threads_per_member": plan.threads, "wall_s": round(time.perf_counter() - t0, 2),
        "failed_members": {r["member"]: r["message"] for r in ordered if r["status"] != "completed"},
        "outputs": ["sweep.nc", "sweep.csv", "members/"],
    }  # fmt: skip
    write_json(folder / "report.json", summary)
    summary["folder"] = str(folder)
    return summary
