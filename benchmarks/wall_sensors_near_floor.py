"""Wall pressure sensors near the floor (issue 40, item 3): a 2-D dam break in the layout of Lobovsky et
al. (2014) (column 0.6 m long and H = 0.3 m high at one end of a 1.61 m tank) at Δx = H/N, the far wall's
sensors at z = 3, 15, 30 and 80 mm (and 50, 120 mm) read every 5 ms as ``erosim.sph.wall_load`` reads
them (the load on the wall's particles), beside the fluid's own pressure at the same points (the
Shepard interpolant with the hydrostatic carry, ``erosim.analysis.gauges.probe_pressure``) and the
water depth at the wall h_w(t) (the column reading of a gauge line one support h from the wall,
``erosim.analysis.gauges.gauge_readings``).

Lobovsky et al.'s measurements are not shipped (no public copy was found), so the readings are scored
against a known answer from the same run: where the flow at the wall is quasi-static the pressure at
height z is hydrostatic on the water depth there,

    p(z, t) = ρ₀ g (h_w(t) − z)⁺,

which holds once the violent phase is over and the water sloshes as a long wave (t√(g/H) = 10–20: a
wave 2 × 1.61 m long over ~0.1 m of water; its vertical acceleration is (depth/length)² of g). Printed
per sensor, in units of ρ₀gH: the RMS and mean of (reading − ρ₀g(h_w − z)) over t√(g/H) = 10–20, and,
for comparison with the impact plateau the experiment reports, the mean over t√(g/H) = 3–6 (not scored:
the runup is not quasi-static there; the column at the wall stands at ~H while the floor reads ~0.6 ρ₀gH).

    python benchmarks/wall_sensors_near_floor.py --n 40 [--t-end 20] [--csv OUT.csv] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse

import numpy as np

from erosim.analysis.gauges import gauge_readings, probe_pressure
from erosim.scenarios import loader
from erosim.scenarios.sph.build import build, probe_wall
from erosim.sph.wall_load import wall_pressures

H, LENGTH, TANK = 0.3, 0.6, 1.61
SENSORS = (0.003, 0.015, 0.03, 0.05, 0.08, 0.12)
PLATEAU = (3.0, 6.0)  # t√(g/H): the impact plateau (reported, not scored)
QUASI_STATIC = (10.0, 20.0)  # t√(g/H): the long-wave phase, scored against ρ₀g(h_w − z)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40, help="particles across H")
    ap.add_argument("--t-end", type=float, default=QUASI_STATIC[1], help="end time in units of sqrt(H/g)")
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
    line = np.array([[TANK - s.h]])  # the depth at the wall: one support in, where φ has a full support
    rows, t_next, t_end = [], 0.0, args.t_end / np.sqrt(g / H)
    while s.t < t_end:
        if s.t >= t_next:
            t_next += 0.005
            st = s.state
            nf = st.n_fluid
            rho = np.asarray(st.rho[:nf], dtype=np.float64)
            pos = np.asarray(st.pos[:nf], dtype=np.float64)
            fluid = probe_pressure(pos, np.asarray(st.p[:nf], dtype=np.float64), s.m / rho, points, s.h,
                                   density=rho, gravity=np.array([0.0, -g]))  # fmt: skip
            depth = gauge_readings(pos, s.m / rho, line, s.h, s.params.spacing, 0.0, s.params.kernel)[0, 0]
            rows.append([s.t, *wall_pressures(s, walls, s.h), *fluid, depth])
        s.step()
    r = np.array(rows)
    ns = len(SENSORS)
    if args.csv:
        head = ("t," + ",".join(f"wall_{1000 * z:g}mm" for z in SENSORS) + ","
                + ",".join(f"fluid_{1000 * z:g}mm" for z in SENSORS) + ",depth_at_wall")  # fmt: skip
        np.savetxt(args.csv, r, delimiter=",", header=head, comments="")
    tt = r[:, 0] * np.sqrt(g / H)
    scale = cfg.sph.rho0 * g * H
    plateau = (tt >= PLATEAU[0]) & (tt <= PLATEAU[1])
    qs = (tt >= QUASI_STATIC[0]) & (tt <= QUASI_STATIC[1])
    print(f"dx = H/{args.n}, {s.steps} steps, t*(g/H)^0.5 = {tt[-1]:.1f}; in rho0 g H:")
    if qs.any():
        print(f"  mean depth at the wall over t*(g/H)^0.5 = {QUASI_STATIC[0]:g}-{QUASI_STATIC[1]:g}: "
              f"{r[qs, -1].mean() / H:.3f} H")  # fmt: skip
    print(
        "  z (mm) | impact plateau mean (3-6): wall, fluid | quasi-static (10-20) vs rho0 g (h_w - z): "
        "wall RMS, mean; fluid RMS, mean"
    )
    for k, z in enumerate(SENSORS):
        wall, fl = r[:, 1 + k], r[:, 1 + ns + k]
        line_ = f"  {1000 * z:6.0f} | {wall[plateau].mean() / scale:6.3f} {fl[plateau].mean() / scale:6.3f} |"
        if qs.any():
            exact = cfg.sph.rho0 * g * np.maximum(r[qs, -1] - z, 0.0)
            for v in (wall, fl):
                d = (v[qs] - exact) / scale
                line_ += f" {np.sqrt(np.mean(d**2)):6.3f} {d.mean():+6.3f}"
        print(line_)


if __name__ == "__main__":
    main()
