"""erosim: particle-based terrain erosion and flood simulation."""

import os

# Numba's OpenMP layer spin-waits between parallel loops; on a machine shared with other work (CI,
# a laptop with a browser open) that cost ~1 ms per loop, against ~3 µs for the workqueue layer,
# and halved SPH throughput at 10⁴–10⁵ particles (docs/performance.md). Workqueue splits loops into
# fixed chunks, so results stay deterministic for a given thread count. Set
# NUMBA_THREADING_LAYER=omp (or tbb) before running erosim to choose another layer.
os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

__version__ = "0.1.0"
