"""The mutation check's table stays in step with the sources: every mutation's edit text occurs
exactly once in today's package, so `make mutation` breaks what it says it breaks."""

import importlib.util
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]


def _module():
    spec = importlib.util.spec_from_file_location("mutation_check", REPO / "benchmarks" / "mutation_check.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("mutation_check", mod)  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def test_every_mutation_applies_to_todays_sources():
    mc = _module()
    stale = {m.name: mc.stale_edits(m) for m in mc.MUTATIONS}
    assert {k: v for k, v in stale.items() if v} == {}


def test_mutation_names_are_unique_and_each_edit_changes_the_text():
    mc = _module()
    names = [m.name for m in mc.MUTATIONS]
    assert len(names) == len(set(names))
    assert all(old != new for m in mc.MUTATIONS for old, new in m.edits)
    assert all(m.tests for m in mc.MUTATIONS)
    assert all((REPO / t).is_file() for m in mc.MUTATIONS for t in m.tests)
