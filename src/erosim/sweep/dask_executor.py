"""Sweep members as Dask tasks (``dask.distributed``): a ``LocalCluster`` of worker processes by
default, any scheduler's address otherwise.

* Every member is one task (:func:`erosim.sweep.member.run_member`); a worker runs one at a time
  with the plan's Numba threads, so workers × threads = the cores a local sweep uses.
* A worker that dies while running a member (killed, out of memory) has that member retried once by
  the scheduler (``distributed.scheduler.allowed-failures = 1`` on a local cluster; a remote
  scheduler applies its own setting); the retry resumes from the member's checkpoint. A second death
  is recorded as the member's failure and the sweep goes on.
* Ctrl-C asks every worker's runs to stop as Ctrl-C stops a run (after the step, with a checkpoint:
  :func:`erosim.simulation.simulation.request_stop`), waits for them, and re-raises.
* A remote cluster's workers must see the sweep folder at the same path (a shared file system).
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import time
from collections.abc import Callable, Iterator
from typing import Any

from erosim.core.errors import ErosimError
from erosim.simulation.simulation import clear_stop_request, request_stop
from erosim.sweep.member import MemberTask, run_member

STOP_WAIT_S = 120.0  # how long an interrupted sweep waits for its members' checkpoints
# a retry after a worker's death; no statistical profiler (it takes the GIL from a member every 10 ms)
# and a slower system monitor: on a small machine every cycle the workers' housekeeping takes is a
# cycle a member does not get
LOCAL_CONFIG = {
    "distributed.scheduler.allowed-failures": 1,
    "distributed.worker.profile.enabled": False,
    "distributed.admin.system-monitor.interval": "2s",
}


def local_cores() -> int:
    """The cores this process may use (the affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


@contextlib.contextmanager
def connect(scheduler: str | None, workers: int, timeout_s: float = 10.0) -> Iterator[Any]:
    """A ``distributed.Client``: to ``scheduler`` (an address), or to a new local cluster of ``workers``."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=f"{timeout_s}s", set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ErosimError(
                f"No Dask scheduler answered at '{scheduler}' within {timeout_s:g} s ({type(exc).__name__}); "
                "check the address that `dask scheduler` printed, or leave out --scheduler to use local workers."
            ) from None
        with client:
            yield client
        return
    # the workers ignore Ctrl-C (a terminal sends it to the whole process group): the sweep stops them
    # in order instead, each member writing its checkpoint; a spawned Python keeps an ignored SIGINT
    ignored = _ignore_sigint()
    try:
        with dask.config.set(LOCAL_CONFIG):
            cluster = LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                memory_limit=0, silence_logs=logging.ERROR,
            )  # fmt: skip
    finally:
        if ignored is not None:
            signal.signal(signal.SIGINT, ignored)
    with cluster, Client(cluster, set_as_default=False) as client:
        yield client


def _ignore_sigint():
    """Ignore SIGINT (the main thread only); returns the handler to restore, or None."""
    try:
        return signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: nothing to restore
        return None


def _failure(task: MemberTask, exc: BaseException) -> dict[str, Any]:
    name = type(exc).__name__
    why = "its worker died twice while running it" if name == "KilledWorker" else f"{name}: {exc}"
    return {"index": task.index, "member": task.name, "status": "failed", "message": why, "action": "ran",
            "wall_s": None}  # fmt: skip


def run_tasks(
    client: Any,
    tasks: list[MemberTask],
    *,
    on_done: Callable[[dict[str, Any]], None],
    member_function: Callable[[MemberTask], dict[str, Any]] = run_member,
) -> list[dict[str, Any]]:
    """Run ``tasks`` on ``client``'s workers; ``on_done(record)`` as each finishes; the records in task order."""
    from distributed import as_completed

    client.run(clear_stop_request)  # a worker of an earlier, interrupted sweep runs members again
    futures = {
        client.submit(member_function, t, key=f"erosim-member-{t.name}-{time.time_ns()}", pure=False): t for t in tasks
    }
    records: dict[int, dict[str, Any]] = {}
    try:
        for future in as_completed(futures, loop=client.loop):
            task = futures[future]
            try:
                record = future.result()
            except Exception as exc:  # the task itself catches a member's errors: this is the worker
                record = _failure(task, exc)
            records[task.index] = record
            on_done(record)
    except KeyboardInterrupt:
        # running members stop after their step with a checkpoint, as a run does on Ctrl-C; queued ones
        # return without starting
        with contextlib.suppress(Exception):
            client.run(request_stop)
        deadline = time.monotonic() + STOP_WAIT_S
        for future in futures:
            with contextlib.suppress(Exception):
                future.result(timeout=max(0.0, deadline - time.monotonic()))
        raise
    return [records[t.index] for t in sorted(tasks, key=lambda t: t.index)]
