"""benchmarks/mutation_check.py stays in step with the sources: every mutation's text occurs exactly
once in today's file, so `make mutation` breaks the physics it names (a moved source is caught here,
not an hour into the check)."""

import importlib.util
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("mutation_check", REPO / "benchmarks" / "mutation_check.py")
mutation_check = importlib.util.module_from_spec(_spec)
sys.modules["mutation_check"] = mutation_check  # its dataclasses look their module up
_spec.loader.exec_module(mutation_check)


@pytest.mark.parametrize("m", mutation_check.MUTATIONS, ids=lambda m: m.name)
def test_every_mutation_applies_to_todays_source(m):
    assert mutation_check.stale_edits(m) == [], m.name


@pytest.mark.parametrize("m", mutation_check.MUTATIONS, ids=lambda m: m.name)
def test_every_mutation_changes_its_file_and_names_tests_that_exist(m):
    assert all(old != new for old, new in m.edits)
    assert m.tests and all((REPO / t).is_file() for t in m.tests), m.tests


def test_mutation_names_are_unique():
    names = [m.name for m in mutation_check.MUTATIONS]
    assert len(names) == len(set(names))


def test_a_stale_mutation_is_reported_not_fatal(tmp_path):
    m = mutation_check.Mutation("gone", "sph/forces.py", (("no such text in the file", "x"),), ("tests",), "-")
    r = mutation_check.run_one(m, REPO, tmp_path)
    assert r["status"] == "stale" and "occurs 0 times" in r["first_failure"]
