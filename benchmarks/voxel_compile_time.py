"""First compilation of the voxel wall's passes, with Numba's cache off: how long a voxel run's first
step waits for `voxel_constrain` and `wall_distance` (kernels/voxel.py's docstring quotes the figures).

    NUMBA_DISABLE_CACHE=1 PYTHONPATH=src .venv/bin/python benchmarks/voxel_compile_time.py
"""

from __future__ import annotations

import time

import numpy as np

from erosim.kernels import voxel as kv
from erosim.sph.boundaries import voxel_wall as vw


def main() -> None:
    rng = np.random.default_rng(0)
    dens = rng.random((12, 12, 12))  # any field: only the compilation is timed
    pos = rng.random((50, 3)) * 5 + 3
    vel = np.zeros((50, 3))
    t0 = time.perf_counter()
    vw.voxel_constrain(pos, vel, 50, dens, 0.0, 0.0, 0.0, 1.0, 0.5, 0.01)
    t1 = time.perf_counter()
    kv.wall_distance(dens, 0.0, 0.0, 0.0, 1.0, 0.5, pos, 50, np.zeros(50), np.zeros((50, 3)))
    t2 = time.perf_counter()
    print(f"voxel_constrain {t1 - t0:.1f} s, wall_distance {t2 - t1:.1f} s (first call: compilation)")


if __name__ == "__main__":
    main()
