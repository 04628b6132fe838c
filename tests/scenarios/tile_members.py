"""Tile functions for the tiled build's resume test (imported by Dask workers)."""

from erosim.sweep.member import MemberTask, record, run_member


def stop_after_first(task: MemberTask):
    """Run tile 0; report every other tile as interrupted before it started, as a stopped build does."""
    if task.index == 0:
        return run_member(task)
    return record(task.index, task.name, {"status": "interrupted", "error": "stopped by the test"}, "not started")


def stop_in_round_2(task: MemberTask):
    """Run every tile of round 1 and tile 0 of round 2; report the others of round 2 as interrupted."""
    if "round2" not in task.folder or task.index == 0:
        return run_member(task)
    return record(task.index, task.name, {"status": "interrupted", "error": "stopped by the test"}, "not started")
