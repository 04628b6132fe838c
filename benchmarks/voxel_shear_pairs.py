"""Why the seed's shear sums cost twice as much with `erosion.sediment = "suspended"` (docs/voxel.md, `erosim
bench voxel`): after the benchmark's dam break in the voxel tank (Δx = 1 cm, τ_c = 0, a coupling every 50
steps) with each sediment option, count the (particle, node) pairs `shear_sums` visits, those on nodes with
material (density above d_air, where it computes the distance) and those within the erosion radius
(where it evaluates the stress). One thread.

    NUMBA_NUM_THREADS=1 python benchmarks/voxel_shear_pairs.py carried_off|suspended [PARTICLES]
"""

import math
import sys

import numpy as np
from numba import njit

from erosim.kernels.voxel import node_span


@njit(cache=True)
def count_pairs(dens, ox, oy, oz, inv, d_air, pos, vel, wall_l, n, radius, l_min):
    nz, ny, nx = dens.shape
    cell = 1.0 / inv
    visited = 0
    material = 0
    within = 0
    for j in range(n):
        if vel[j, 0] == 0.0 and vel[j, 1] == 0.0 and vel[j, 2] == 0.0:
            continue
        px, py, pz = pos[j, 0], pos[j, 1], pos[j, 2]
        lj = min(max(wall_l[j], 0.0), l_min)
        reach = radius + lj
        i0, i1 = node_span(px, reach, ox, inv, nx)
        j0, j1 = node_span(py, reach, oy, inv, ny)
        k0, k1 = node_span(pz, reach, oz, inv, nz)
        for kk in range(k0, k1 + 1):
            for jj in range(j0, j1 + 1):
                for ii in range(i0, i1 + 1):
                    visited += 1
                    if dens[kk, jj, ii] <= d_air:
                        continue
                    material += 1
                    rx = ox + ii * cell - px
                    ry = oy + jj * cell - py
                    rz = oz + kk * cell - pz
                    if math.sqrt(rx * rx + ry * ry + rz * rz) - lj <= radius:
                        within += 1
    return visited, material, within


def main(sediment, particles=20000, steps=500, every=50):
    from erosim.bench.sph import dam_break_geometry
    from erosim.coupling.voxel_coupler import VoxelCoupler
    from erosim.erosion.shear_stress_kristof2009 import ShearStressErosion, ShearStressParams
    from erosim.simulation.schedules import IterationInterval
    from erosim.sph.boundaries.voxel_wall import VoxelWall
    from erosim.sph.params import SPHParams
    from erosim.sph.solver import SPHSolver
    from erosim.terrain.voxel import Box, VoxelTerrain

    dx = 0.01
    fluid, lo, hi = dam_break_geometry(particles, 3, dx)
    params = SPHParams(dim=3, spacing=dx, walls="reflect")
    h = params.support()
    cell = dx
    band = 1.05 * (h + 3**0.5 * cell)
    pad = band + 2 * cell
    lo_v = (lo[0] - pad, lo[1] - pad, lo[2] - pad)
    hi_v = (hi[0] + pad, hi[1] + pad, hi[2])
    air = Box(tuple(lo), (hi[0], hi[1], hi[2] + 1.0))
    terrain = VoxelTerrain.from_sdf(lambda x, y, z: -air.sdf(x, y, z), lo_v, hi_v, cell, band=band)
    solver = SPHSolver(
        params,
        fluid,
        domain_lo=[a - 0.05 for a in lo_v],
        domain_hi=[b + 0.05 for b in hi_v],
        boundaries=[VoxelWall(terrain)],
    )
    base = ShearStressErosion(terrain, ShearStressParams(k_eps=1.0, tau_c=0.0), support=solver.h)
    eroder = base
    if sediment == "suspended":
        from erosim.erosion.settling_voxel import SuspendedSediment

        eroder = SuspendedSediment(base, solver, settling_velocity=0.02)
    coupler = VoxelCoupler(IterationInterval(every), solver, eroder, terrain)
    for k in range(steps):
        solver.step()
        if (k + 1) % every == 0:
            coupler()
    pos, vel = solver.fluid_positions(), solver.fluid_velocities()
    l, _ = base.wall_distances(pos)
    d_air = terrain.value_range[0]
    res = count_pairs(
        terrain.density,
        *terrain.origin,
        1.0 / terrain.cell_size,
        d_air,
        np.ascontiguousarray(pos),
        np.ascontiguousarray(vel),
        l,
        len(pos),
        base.radius,
        base.l_min,
    )
    nodes = int((terrain.density > d_air).sum())
    print(
        f"{sediment}: {len(pos)} particles, {nodes} nodes with material; pairs visited {res[0]}, on nodes with "
        f"material {res[1]}, within R {res[2]}"
    )


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 20000)
