"""The threading layer: workqueue for the library (fork-safe), OpenMP with passive waits for the `erosim`
command, the user's NUMBA_THREADING_LAYER respected by both (erosim/__init__.py)."""

import os
import subprocess
import sys

import pytest

PROBE = """
import os, sys
import erosim
if sys.argv[1] == "command":
    erosim.command_threading_layer()
import numba
print(os.environ["NUMBA_THREADING_LAYER"], " ".join(numba.config.THREADING_LAYER_PRIORITY),
      os.environ.get("OMP_WAIT_POLICY", "-"), numba.config.THREADING_LAYER)
"""


def _probe(mode, **env):
    clean = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_THREADING", "OMP_WAIT"))}
    out = subprocess.run([sys.executable, "-c", PROBE, mode], env={**clean, **env}, capture_output=True, text=True,
                         check=True, timeout=120)  # fmt: skip
    return out.stdout.split()


def test_the_library_asks_for_workqueue_which_survives_a_fork():
    layer, *_rest, config = _probe("library")
    assert layer == "workqueue" and config == "workqueue"


def test_the_command_asks_for_openmp_with_passive_waits_then_workqueue():
    layer, *priority, wait, config = _probe("command")
    assert layer == "default" and config == "default"
    assert priority[:2] == ["omp", "workqueue"] and wait == "passive"


@pytest.mark.parametrize("mode", ["library", "command"])
def test_a_layer_the_user_set_is_kept(mode):
    layer, *_rest, config = _probe(mode, NUMBA_THREADING_LAYER="tbb")
    assert layer == "tbb" and config == "tbb"
