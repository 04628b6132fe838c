"""CPU kernels' own source compiled for the GPU (numba-cuda) or run in Numba's CUDA simulator.

The device paths call the CPU's per-particle functions instead of copies of them. Those functions are
Numba ``njit`` dispatchers, some cached (``cache=True``), which numba-cuda would try to cache for a
GPU, and under the simulator (``NUMBA_ENABLE_CUDASIM=1``) kernels run as Python and cannot pass their
arrays to compiled functions. :func:`rebind` therefore remakes a module's jitted functions from their
Python source over one shared set of globals in which every such function is the remade one: plain
Python in the simulator, ``njit(inline="always")`` (uncached, inlined into the kernel) on a device —
the same source either way.
"""

from __future__ import annotations

import types

from numba import config, njit

SIMULATOR = bool(config.ENABLE_CUDASIM)


def rebind(module, extra: dict | None = None) -> types.SimpleNamespace:
    """``module``'s jitted functions remade from their source (module docstring), calling each other
    and the functions in ``extra`` (name → function, e.g. another module's remade helper)."""
    g = dict(vars(module))
    g.update(extra or {})
    made = {}
    for name, obj in vars(module).items():
        py = getattr(obj, "py_func", None)
        if py is not None and getattr(py, "__module__", None) == module.__name__:
            f = types.FunctionType(py.__code__, g, py.__name__, py.__defaults__, py.__closure__)
            made[name] = f if SIMULATOR else njit(inline="always")(f)
    g.update(made)
    return types.SimpleNamespace(**g)
