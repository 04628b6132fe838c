"""Why the seed's shear sums cost twice as much with `erosion.sediment = "suspended"` (docs/voxel.md, `erosim
bench voxel`): after the benchmark's dam break in its voxel tank (`erosim.bench.voxel.tank_solver`, Δx = 1 cm,
τ_c = 0, a coupling every 50 steps) with each sediment option, the nodes with material, the (particle, node)
pairs within the erosion radius on them, where `shear_sums` evaluates the stress (counted by the kernel
itself, with n = 0 so that each such pair adds exactly 1), and the time of one evaluation of the sums
(`ShearStressErosion.rates`, the best of five). One thread.

    NUMBA_NUM_THREADS=1 python benchmarks/voxel_shear_pairs.py carried_off|suspended [PARTICLES]
"""

import sys
import time

import numpy as np

from erosim.bench.sph import dam_break_geometry, timed_steps
from erosim.bench.voxel import eroder_at_zero_threshold, tank_solver
from erosim.core.schedules import IterationInterval
from erosim.coupling.coupler import Coupler
from erosim.coupling.terrains import VoxelFieldTerrain
from erosim.erosion.shear_stress_kristof2009 import shear_sums


def main(sediment: str, particles: int = 20000, steps: int = 500, every: int = 50) -> None:
    dx = 0.01
    fluid, lo, hi = dam_break_geometry(particles, 3, dx)
    solver, terrain = tank_solver(fluid, lo, hi, dx)
    eroder = eroder_at_zero_threshold(terrain, solver, dx, sediment=sediment)
    timed_steps(solver.step, steps, every, Coupler(IterationInterval(every), solver, eroder,
                                                             VoxelFieldTerrain(terrain)))
    law = getattr(eroder, "eroder", eroder)  # the shear-stress law under the settling wrapper
    pos = np.ascontiguousarray(solver.fluid_positions())
    vel = np.ascontiguousarray(solver.fluid_velocities())
    wall_l, normals = law.wall_distances(pos)
    d_air = terrain.value_range[0]
    pairs = np.zeros(terrain.shape)
    shear_sums(terrain.density, *terrain.origin, 1.0 / terrain.cell_size, d_air, pos, vel, wall_l, normals,
               law.params.parallel == "seed",
               len(pos), law.radius, law.l_min, 1.0, 0.0, 0.0, law.z_floor, 1.0, pairs)  # fmt: skip
    seconds = []
    for _ in range(5):
        t0 = time.perf_counter()
        law.rates(pos, vel, wall_l)
        seconds.append(time.perf_counter() - t0)
    print(f"{sediment}: {len(pos)} particles, {int((terrain.density > d_air).sum())} nodes with material, "
          f"{int(pairs.sum())} pairs within R on them, the sums {1000 * min(seconds):.1f} ms")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 20000)
