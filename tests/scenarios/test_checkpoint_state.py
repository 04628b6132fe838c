"""A checkpoint holds every piece of a run's state: a run stopped late (after several coupling
intervals) and a fresh build restored from its checkpoint agree attribute by attribute
(``state_audit.py``: the models, the callbacks, what they hold and their closures; caches that the next
step writes before reading and the sessions' clocks aside, each named there with why).

This finds what a resume would forget even where the outputs of a short run happen not to show it;
``test_interrupt_resume.py`` checks the outputs themselves.
"""

from __future__ import annotations

import pytest
from state_audit import audit
from test_interrupt_resume import KINDS

# a late iteration of each kind's small scene (of 1359, 6, 89, 166, 60, 1173 and 911 iterations): after several
# coupling intervals, sources' events and map frames
LATE = {"sph": 1000, "hydrology": 4, "particle-stream": 60, "sph-terrain": 125, "flood": 50, "splash": 900,
        "voxel": 700}  # fmt: skip
DEFAULT = ("hydrology", "particle-stream", "sph-terrain", "flood", "voxel")  # a second or two each; sph, splash: slow


@pytest.mark.parametrize(
    "kind", [k if k in DEFAULT else pytest.param(k, marks=pytest.mark.slow) for k in sorted(KINDS)]
)
def test_a_restored_run_holds_what_the_stopped_run_held(kind, tmp_path):
    name, *sets = KINDS[kind]
    differences = audit(name, sets, LATE[kind], tmp_path / "run")
    assert not differences, "\n".join(differences)
