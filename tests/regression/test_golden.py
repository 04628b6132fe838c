"""The regression tier: each golden case (``golden.py``) runs and its numbers equal the stored ones
within the stated tolerance; a change of results fails here with the numbers that moved."""

from __future__ import annotations

import golden
import pytest

pytestmark = pytest.mark.regression


@pytest.mark.parametrize("name", sorted(golden.CASES))
def test_golden_case_repeats_its_stored_results(name, tmp_path):
    now = golden.run_case(name, tmp_path)
    then = golden.stored(name)
    assert len(then) > 10  # a summary that names a few numbers only would compare nothing
    moved = golden.differences(now, then)
    assert not moved, f"{name}: {len(moved)} numbers moved (rtol {golden.RTOL:g}):\n" + "\n".join(moved[:40])
