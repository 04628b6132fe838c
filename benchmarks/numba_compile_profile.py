"""A pytest plugin that times Numba's compilations per function (Numba's ``numba:compile`` events), to
find what the default test run spends compiling. Each process (each xdist worker) writes
``/tmp/compile_times/<pid>.tsv``: seconds (including the functions compiled inside it), count, name.

    XDG_CACHE_HOME=$(mktemp -d) PYTHONPATH=src:benchmarks .venv/bin/python -m pytest -q -n 2 \\
        --dist loadfile -p numba_compile_profile
"""

from __future__ import annotations

import atexit
import collections
import os
import time

from numba.core import event

SECONDS: collections.defaultdict[str, float] = collections.defaultdict(float)
COUNT: collections.Counter[str] = collections.Counter()
_started: list[float] = []


class _Compiles(event.Listener):
    def on_start(self, ev) -> None:
        _started.append(time.perf_counter())

    def on_end(self, ev) -> None:
        t0 = _started.pop() if _started else time.perf_counter()
        func = getattr(ev.data.get("dispatcher"), "py_func", None)
        name = f"{getattr(func, '__module__', '')}.{getattr(func, '__qualname__', '?')}"
        SECONDS[name] += time.perf_counter() - t0
        COUNT[name] += 1


event.register("numba:compile", _Compiles())


@atexit.register
def _write() -> None:
    os.makedirs("/tmp/compile_times", exist_ok=True)
    with open(f"/tmp/compile_times/{os.getpid()}.tsv", "w") as f:
        for name, s in sorted(SECONDS.items(), key=lambda kv: -kv[1]):
            f.write(f"{s:.3f}\t{COUNT[name]}\t{name}\n")
