"""``loop_kernel``: Numba's ``njit`` for the droplet loops, without reference counting per sub-step.

Numba's IR inlining (``inline="always"``, used for the helpers the GPU also compiles) binds each
array argument of the inlined function to a new variable, and a function it calls binds its own;
each binding is a reference-count increment and a decrement. Numba's pruning pass removes such
pairs only when no loop lies between them, so in the loops over the shared sub-step
(:func:`erosim.hydrology.droplet_step.step`, whose pit walk and footprint are loops) every sub-step
made some twenty atomic updates: 37 % of the time on the library terrain (``perf`` on the 2-core
machine). The parallel pipeline's copy propagation removes those bindings. The kernels compiled
with it hold no ``prange``: they run on the calling thread, and Numba's note that nothing ran in
parallel is silenced for them.
"""

from __future__ import annotations

import warnings

from numba import njit
from numba.core.errors import NumbaPerformanceWarning

warnings.filterwarnings(
    "ignore",
    message=r"(?s)\s*The keyword argument 'parallel=True'.*erosim.hydrology.\w+\.py",
    category=NumbaPerformanceWarning,
)


def loop_kernel(fn):
    """``njit(cache=True, error_model="numpy", parallel=True)``: a serial loop without per-iteration
    reference counting (module docstring)."""
    return njit(cache=True, error_model="numpy", parallel=True)(fn)
