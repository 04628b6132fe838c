"""What stands on SPHERIC Test 2's gauge line H1 (issue 14): the `spheric2` scenario as `erosim validate
spheric2` sets it up, at a given spacing and device, with particle frames every ``--every`` seconds; per
frame, the SPH volume fraction φ(z) up the vertical line at H1 and at 24 lines around it (±4 cm in x
and y, 2 cm apart), up to 1 m, summed and read as the gauges do (:mod:`erosim.analysis.gauges`:
``volume_fraction_profile``, ``profile_readings``). Per line it keeps the column's level (top of the
first φ ≥ ½ column from the floor), the wire's wetted length (the length where φ ≥ ½) and the highest
φ ≥ ½ point; and from ``--slab-from`` on, the
particles within 3 cm of the centre plane y = 0.5 m behind the box (x < 0.70 m) for a side view.
Everything goes to ``OUT/h1_column_<spacing>.npz``; the frames are deleted.

    python benchmarks/spheric2_h1_column.py OUT --spacing 0.012 --device cuda
"""

from __future__ import annotations

import time

import numpy as np

H1 = (0.496, 0.5)
OFFSETS = np.array([(dx, dy) for dx in (-0.04, -0.02, 0.0, 0.02, 0.04) for dy in (-0.04, -0.02, 0.0, 0.02, 0.04)])


def main() -> None:
    from spheric2_lee import frames, run_arguments, run_with_frames

    ap = run_arguments(__doc__, 0.025)
    ap.add_argument("--slab-from", type=float, default=1.1)
    a = ap.parse_args()

    from erosim.analysis.gauges import profile_readings, volume_fraction_profile
    from erosim.simulation.callbacks import Probes

    t0 = time.perf_counter()
    folder, sim, run_s = run_with_frames(a.out, a.spacing, a.device, a.every, a.t_end)
    probes = next(c for c in sim.callbacks if isinstance(c, Probes))
    kernel = sim.models[0].params.kernel
    h, dx, mass, floor = probes.h, probes.dx, probes.mass, probes.floor
    dz = 0.25 * dx
    lines = np.asarray(H1) + OFFSETS
    times, level, wetted, highest, profiles, slabs = [], [], [], [], [], {}
    for d in frames(folder):
        t = float(d["time"])
        pos = np.asarray(d["points"], dtype=np.float64)
        vol = mass / np.asarray(d["fields"]["density"], dtype=np.float64)
        times.append(t)
        profile = [volume_fraction_profile(pos, vol, line, h, dz, floor, kernel, top=1.0) for line in lines]
        readings = np.array([profile_readings(z, phi, h, dz) for z, phi in profile])
        level.append(readings[:, 0])
        wetted.append(readings[:, 1])
        highest.append([z[phi >= 0.5].max() - floor if (phi >= 0.5).any() else 0.0 for z, phi in profile])
        profiles.append(np.stack([phi.astype(np.float32) for _, phi in profile]))
        if t >= a.slab_from - 1e-9:
            keep = (np.abs(pos[:, 1] - 0.5) < 0.03) & (pos[:, 0] < 0.70)
            u = np.asarray(d["fields"]["velocity"], dtype=np.float32)
            slabs[f"slab_{t:.3f}"] = np.hstack([pos[keep].astype(np.float32), u[keep]])
    np.savez_compressed(
        a.out / f"h1_column_{a.spacing}.npz", t=np.asarray(times), lines=lines, level=np.asarray(level),
        wetted=np.asarray(wetted), highest=np.asarray(highest), phi=np.stack(profiles), dz=dz, h=h, spacing=dx,
        floor=floor, run_s=run_s, **slabs,
    )  # fmt: skip
    print(f"{len(times)} frames, run {run_s:.0f} s, all {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
