"""SPHERIC Test 2 with wall-weight walls instead of boundary particles: the tank and the box as one voxel
field (Δ = Δx, the wall's ramp) felt through :class:`erosim.sph.boundaries.voxel_wall.VoxelWall`, the
fluid, kernel, sound speed and gauges as ``erosim validate spheric2`` has them; the levels at H1–H4
scored as the validation scores them (column and wetted length, mm). Pressures are not read: the box
has no particles to feel the load. An experiment on the boundary treatment (issue 14, docs/sph.md).

    python benchmarks/spheric2_wall_weights.py SPACING [T_END]
"""

import sys
import time

import numpy as np

from erosim.analysis.gauges import gauge_readings
from erosim.data import SPHERIC2, reference_csv
from erosim.scenarios import loader
from erosim.sph.boundaries.voxel_wall import VoxelWall
from erosim.sph.solver import SPHSolver
from erosim.terrain.voxel import Box, VoxelTerrain
from erosim.validation.spheric2 import GAUGES, LEVEL_WINDOW


def main(dx: float, t_end: float = 1.6) -> dict:
    cfg = loader.load("spheric2", [f"sph.spacing={dx!r}"]).config
    p = cfg.sph.model_copy(update={"walls": "reflect"})  # no particle walls: the field is the wall
    h = p.support()
    band = 1.05 * (h + 3**0.5 * dx)  # the wall's ramp: a support and a cell's diagonal (as bench voxel's)
    pad = band + 2 * dx
    (x0, y0, z0), (x1, y1, _) = cfg.domain.lo, cfg.domain.hi
    tank = Box((x0, y0, z0), (x1, y1, 2.0 * cfg.domain.hi[2]))  # open at the top
    boxes = [Box(tuple(o.lo), tuple(o.hi)) for o in cfg.obstacles]

    def solid(x, y, z):  # signed distance, negative in the solid: outside the tank, or in a box
        d = -tank.sdf(x, y, z)
        for b in boxes:
            d = np.minimum(d, b.sdf(x, y, z))
        return d

    terrain = VoxelTerrain.from_sdf(solid, (x0 - pad, y0 - pad, z0 - pad), (x1 + pad, y1 + pad, cfg.domain.hi[2] + pad),
                                    dx, band=band)  # fmt: skip
    f = cfg.fluid[0]
    n = [max(1, int(round((b - a) / dx))) for a, b in zip(f.lo, f.hi, strict=True)]
    axes = [a + (np.arange(k) + 0.5) * (b - a) / k for a, b, k in zip(f.lo, f.hi, n, strict=True)]
    fluid = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], 1)
    solver = SPHSolver(p, fluid, domain_lo=[x0 - pad - 0.05, y0 - pad - 0.05, z0 - pad - 0.05],
                       domain_hi=[x1 + pad + 0.05, y1 + pad + 0.05, 2.0 * cfg.domain.hi[2]], seed=cfg.seed,
                       boundaries=[VoxelWall(terrain)])  # fmt: skip
    mass = p.rho0 * dx**3
    points = np.array([g.position for g in cfg.gauges])
    rows, next_t, t0 = [], 0.0, time.perf_counter()
    while solver.t <= t_end:
        if solver.t >= next_t - 1e-12:
            r = gauge_readings(solver.fluid_positions(), mass / solver.fluid_density(), points, h, dx, z0, p.kernel)
            rows.append([float(solver.t), *r[:, 0], *r[:, 1]])
            next_t += cfg.run.sample_interval
        solver.step()
    tab = np.array(rows)
    t = tab[:, 0]
    exp = reference_csv(SPHERIC2)
    sel = (t >= LEVEL_WINDOW[0]) & (t <= LEVEL_WINDOW[1])
    names = [g.name for g in cfg.gauges]
    out = {"spacing": dx, "fluid_particles": solver.n_fluid, "steps": solver.steps,
           "wall_s": round(time.perf_counter() - t0, 1), "level_rms_mm": {}, "wire_level_rms_mm": {}}  # fmt: skip
    for k, name in enumerate(names):
        if name not in GAUGES:
            continue
        lab = np.interp(t[sel], exp["t_s"], exp[f"{name}_m"])
        out["level_rms_mm"][name] = round(1000 * float(np.sqrt(np.mean((tab[sel, 1 + k] - lab) ** 2))), 1)
        wire = tab[sel, 1 + len(names) + k]
        out["wire_level_rms_mm"][name] = round(1000 * float(np.sqrt(np.mean((wire - lab) ** 2))), 1)
    k1 = names.index("H1")
    out["H1_column_m"] = {
        f"{c:.1f}": round(float(np.interp(c, t, tab[:, 1 + k1])), 3) for c in (1.0, 1.1, 1.2, 1.3, 1.4, 1.5)
    }
    return out


if __name__ == "__main__":
    print(main(float(sys.argv[1]), *(float(a) for a in sys.argv[2:3])))
