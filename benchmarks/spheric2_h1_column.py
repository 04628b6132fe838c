"""What stands on SPHERIC Test 2's gauge line H1 (issue 14): the `spheric2` scenario as `erosim validate
spheric2` sets it up, at a given spacing and device, with particle frames every ``--every`` seconds; per
frame, the SPH volume fraction φ(z) up the vertical line at H1 and at 24 lines around it (±4 cm in x
and y, 2 cm apart), read exactly as the gauge reads it (:func:`erosim.analysis.gauges.water_level`'s
sum, the particles mirrored in the floor). Per line it keeps the gauge's level (top of the first φ ≥ ½
column from the floor), the water the line passes through (the length where φ ≥ ½, as a wire gauge
wetted along its length would read) and the highest φ ≥ ½ point; and from ``--slab-from`` on, the
particles within 3 cm of the centre plane y = 0.5 m behind the box (x < 0.70 m) for a side view.
Everything goes to ``OUT/h1_column_<spacing>.npz``; the frames are deleted.

    python benchmarks/spheric2_h1_column.py OUT --spacing 0.012 --device cuda
"""

from __future__ import annotations

import argparse
import shutil
import time
from pathlib import Path

import numpy as np

H1 = (0.496, 0.5)
OFFSETS = np.array([(dx, dy) for dx in (-0.04, -0.02, 0.0, 0.02, 0.04) for dy in (-0.04, -0.02, 0.0, 0.02, 0.04)])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--spacing", type=float, default=0.03)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--every", type=float, default=0.025)
    ap.add_argument("--t-end", type=float, default=1.6)
    ap.add_argument("--slab-from", type=float, default=1.1)
    a = ap.parse_args()
    from erosim.analysis.gauges import volume_fraction_profile, water_level
    from erosim.io.particles import read_vtp
    from erosim.io.runfolder import RunFolder
    from erosim.scenarios import loader
    from erosim.scenarios.runner import execute
    from erosim.simulation.callbacks import Probes

    sets = [f"sph.spacing={a.spacing!r}", f"run.t_end={a.t_end!r}", f"run.output_interval={a.every!r}",
            "run.snapshots=0", f"run.device={a.device}"]  # fmt: skip
    folder = RunFolder(a.out / f"spheric2-{a.spacing}", overwrite=True)
    t0 = time.perf_counter()
    _, sim = execute(loader.load("spheric2", sets), folder, progress=False)
    run_s = time.perf_counter() - t0
    probes = next(c for c in sim.callbacks if isinstance(c, Probes))
    kernel = sim.models[0].params.kernel
    h, dx, mass, floor = probes.h, probes.dx, probes.mass, probes.floor
    dz = 0.25 * dx
    lines = np.asarray(H1) + OFFSETS
    times, level, wetted, highest, gauge, profiles, slabs = [], [], [], [], [], [], {}
    for f in sorted((folder.path / "particles").glob("frame_*.vtp")):
        d = read_vtp(f)
        t = float(d["time"])
        pos = np.asarray(d["points"], dtype=np.float64)
        vol = mass / np.asarray(d["fields"]["density"], dtype=np.float64)
        times.append(t)
        gauge.append(water_level(pos, vol, np.asarray([H1]), h, dx, floor, kernel)[0])
        lv, wt, hi, pr = [], [], [], []
        for line in lines:
            z, phi = volume_fraction_profile(pos, vol, line, h, dz, floor, kernel, top=1.0)
            wet = phi >= 0.5
            lv.append(water_level(pos, vol, line[None, :], h, dx, floor, kernel)[0])
            wt.append(wet.sum() * dz)
            hi.append(z[wet].max() - floor if wet.any() else 0.0)
            pr.append(phi.astype(np.float32))
        level.append(lv)
        wetted.append(wt)
        highest.append(hi)
        profiles.append(np.stack(pr))
        if t >= a.slab_from - 1e-9:
            keep = (np.abs(pos[:, 1] - 0.5) < 0.03) & (pos[:, 0] < 0.70)
            u = np.asarray(d["fields"]["velocity"], dtype=np.float32)
            slabs[f"slab_{t:.3f}"] = np.hstack([pos[keep].astype(np.float32), u[keep]])
    shutil.rmtree(folder.path / "particles", ignore_errors=True)
    shutil.rmtree(folder.path / "checkpoint", ignore_errors=True)
    n = max(len(p[0]) for p in profiles)
    prof = np.zeros((len(profiles), len(lines), n), dtype=np.float32)
    for k, p in enumerate(profiles):
        prof[k, :, : p.shape[1]] = p
    np.savez_compressed(
        a.out / f"h1_column_{a.spacing}.npz", t=np.asarray(times), lines=lines, gauge=np.asarray(gauge),
        level=np.asarray(level), wetted=np.asarray(wetted), highest=np.asarray(highest), phi=prof,
        dz=dz, h=h, spacing=dx, floor=floor, run_s=run_s, **slabs,
    )  # fmt: skip
    print(f"{len(times)} frames, run {run_s:.0f} s, all {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
