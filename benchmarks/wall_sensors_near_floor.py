"""Wall pressure sensors near the floor (issue 40, item 3): a 2-D dam break in the layout of Lobovsky et
al. (2014) (column 0.6 m long and H = 0.3 m high at one end of a 1.61 m tank) at Δx = H/N, the far wall's
sensors at z = 3, 15, 30 and 80 mm read every 5 ms as ``erosim.sph.wall_load`` reads them (the load on
the wall's particles), beside the fluid's own pressure at the same points (the Shepard interpolant with
the hydrostatic carry, ``erosim.analysis.gauges.probe_pressure``). Prints each sensor's mean over the
post-impact plateau t√(g/H) = 3–6 in units of ρ₀gH; ``--csv`` keeps the series. No measurements are
shipped for this layout: this compares readings, it does not score them.

    python benchmarks/wall_sensors_near_floor.py --n 40 [--csv OUT.csv] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse

import numpy as np

from erosim.analysis.gauges import probe_pressure
from erosim.scenarios import loader
from erosim.scenarios.sph.build import build, probe_wall
from erosim.sph.wall_load import wall_pressures

H, LENGTH, TANK = 0.3, 0.6, 1.61
SENSORS = (0.003, 0.015, 0.03, 0.08)
PLATEAU = (3.0, 6.0)  # t√(g/H)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40, help="particles across H")
    ap.add_argument("--csv", default=None)
    ap.add_argument("--set", dest="overrides", action="append", default=[])
    args = ap.parse_args()
    dx = H / args.n
    cfg = loader.load(
        "dam-break-2d",
        [f"sph.spacing={dx!r}", f"domain.hi=[{TANK}, {2 * H}]", f"fluid=[{{lo=[0.0, 0.0], hi=[{LENGTH}, {H}]}}]",
         "measure.front=false", 'measure.compare="none"', "gauges=[]", "probes=[]", *args.overrides],
    ).config  # fmt: skip
    s = build(cfg).solver
    g = abs(cfg.sph.gravity_vector()[-1])
    walls = [([TANK, z], *probe_wall(cfg, [TANK, z])) for z in SENSORS]
    points = np.array([[TANK, z] for z in SENSORS])
    rows, t_next, t_end = [], 0.0, 8.0 / np.sqrt(g / H)
    while s.t < t_end:
        if s.t >= t_next:
            t_next += 0.005
            st = s.state
            nf = st.n_fluid
            rho = np.asarray(st.rho[:nf], dtype=np.float64)
            fluid = probe_pressure(np.asarray(st.pos[:nf], dtype=np.float64), np.asarray(st.p[:nf], dtype=np.float64),
                                   s.m / rho, points, s.h, density=rho, gravity=np.array([0.0, -g]))  # fmt: skip
            rows.append([s.t, *wall_pressures(s, walls, s.h), *fluid])
        s.step()
    r = np.array(rows)
    if args.csv:
        head = (
            "t,"
            + ",".join(f"wall_{1000 * z:g}mm" for z in SENSORS)
            + ","
            + ",".join(f"fluid_{1000 * z:g}mm" for z in SENSORS)
        )
        np.savetxt(args.csv, r, delimiter=",", header=head, comments="")
    tt = r[:, 0] * np.sqrt(g / H)
    sel = (tt >= PLATEAU[0]) & (tt <= PLATEAU[1])
    scale = cfg.sph.rho0 * g * H
    print(f"dx = H/{args.n}, {s.steps} steps; plateau mean over t*(g/H)^0.5 = 3-6, in rho0 g H:")
    for k, z in enumerate(SENSORS):
        wall, fl = r[sel, 1 + k].mean() / scale, r[sel, 1 + len(SENSORS) + k].mean() / scale
        print(f"  z = {1000 * z:4.0f} mm: wall load {wall:.3f}, fluid at the point {fl:.3f}")


if __name__ == "__main__":
    main()
