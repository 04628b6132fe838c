"""Pass criteria of a validation, each stated in one line (``erosim validate``).

A criterion is a dict: ``name`` (short label), ``criterion`` (what is held), ``value``, ``limit``,
``passed`` (True, False, or None where the run cannot evaluate it, with ``note`` saying why) and
``line`` (one sentence: the name, the measured value, the limit). :func:`verdict` folds a list of
them into the run's ``passed`` and one line naming every criterion that failed.
"""

from __future__ import annotations

from collections.abc import Callable


def percent(x: float) -> str:
    return f"{100 * x:.1f} %"


def at_most(
    name: str, criterion: str, value: float, limit: float, fmt: Callable[[float], str] = percent, **extra
) -> dict:
    """The criterion value ≤ limit."""
    passed = bool(value <= limit)
    line = f"{name}: {criterion}: {fmt(value)} {'<=' if passed else '>'} {fmt(limit)}"
    return {"name": name, "criterion": criterion, "value": float(value), "limit": float(limit),
            "passed": passed, "line": line, **extra}  # fmt: skip


def not_evaluated(name: str, criterion: str, why: str) -> dict:
    """A criterion this run cannot evaluate; ``why`` says which run does."""
    return {"name": name, "criterion": criterion, "value": None, "limit": None, "passed": None, "note": why,
            "line": f"{name}: {criterion}: not evaluated ({why})"}  # fmt: skip


def verdict(criteria: list[dict], note: str = "") -> tuple[bool, str]:
    """(passed, one line): passed when every evaluated criterion holds (at least one must be evaluated);
    the line names each failed criterion with its value and limit, then ``note`` if given."""
    evaluated = [c for c in criteria if c["passed"] is not None]
    if not evaluated:
        raise ValueError("no criterion was evaluated")
    failed = [c for c in evaluated if not c["passed"]]
    if failed:
        line = "failed " + "; ".join(c["line"] for c in failed)
    else:
        line = "passed " + "; ".join(c["name"] for c in evaluated)
        skipped = [c["name"] for c in criteria if c["passed"] is None]
        if skipped:
            line += f" ({', '.join(skipped)} not evaluated by this run)"
    return not failed, line + (f"; {note}" if note else "")
