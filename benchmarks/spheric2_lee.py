"""Where SPHERIC Test 2's water goes in the box's lee (issue 14, gauge H1): the `spheric2` scenario as
`erosim validate spheric2` sets it up, at a given spacing and device, with particle frames every
``--every`` seconds from ``--from`` on; per frame, the water behind the box (x < 0.6635 m, between the
box's sides, 0.2985 < y < 0.7015 m) and across the whole width behind it (x < 0.6635 m): volume at
rest (particles × Δx³), mean x-velocity, and the highest particle within 5 cm of H1's line. One CSV
row per frame; the frames are deleted.

    python benchmarks/spheric2_lee.py OUT --spacing 0.012 --device cuda
"""

from __future__ import annotations

import argparse
import csv
import shutil
import time
from pathlib import Path

import numpy as np

X_BOX, Y_LO, Y_HI, H1 = 0.6635, 0.2985, 0.7015, (0.496, 0.5)


def run_with_frames(out: Path, spacing: float, device: str, every: float, t_end: float):
    """The validation's case at ``spacing`` on ``device`` with particle frames every ``every`` s into
    ``out/spheric2-<spacing>``: (the run folder, the simulation, its seconds of wall time)."""
    from erosim.io.runfolder import RunFolder
    from erosim.scenarios import loader
    from erosim.scenarios.runner import execute

    sets = [f"sph.spacing={spacing!r}", f"run.t_end={t_end!r}", f"run.output_interval={every!r}",
            "run.snapshots=0", f"run.device={device}"]  # fmt: skip
    folder = RunFolder(out / f"spheric2-{spacing}", overwrite=True)
    t0 = time.perf_counter()
    _, sim = execute(loader.load("spheric2", sets), folder, progress=False)
    return folder, sim, time.perf_counter() - t0


def frames(folder):
    """Each particle frame of the run, in order, read back; the frames and the checkpoint are deleted after."""
    from erosim.io.particles import read_vtp

    for f in sorted((folder.path / "particles").glob("frame_*.vtp")):
        yield read_vtp(f)
    shutil.rmtree(folder.path / "particles", ignore_errors=True)
    shutil.rmtree(folder.path / "checkpoint", ignore_errors=True)


def run_arguments(doc: str, every: float) -> argparse.ArgumentParser:
    """The options of a run with frames (the SPHERIC benchmarks share them): OUT, spacing, device, frame
    interval (default ``every``) and end time."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--spacing", type=float, default=0.03)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--every", type=float, default=every)
    ap.add_argument("--t-end", type=float, default=1.6)
    return ap


def main() -> None:
    a = run_arguments(__doc__, 0.05).parse_args()
    t0 = time.perf_counter()
    folder, _, _ = run_with_frames(a.out, a.spacing, a.device, a.every, a.t_end)
    vol = a.spacing**3
    rows = []
    for d in frames(folder):
        x, u = np.asarray(d["points"]), np.asarray(d["fields"]["velocity"])
        behind = x[:, 0] < X_BOX
        lee = behind & (x[:, 1] > Y_LO) & (x[:, 1] < Y_HI)
        near = (np.abs(x[:, 0] - H1[0]) < 0.05) & (np.abs(x[:, 1] - H1[1]) < 0.05)
        rows.append({"t": round(float(d["time"]), 4), "lee_m3": lee.sum() * vol,
                     "lee_u": float(u[lee, 0].mean()) if lee.any() else 0.0, "behind_m3": behind.sum() * vol,
                     "behind_u": float(u[behind, 0].mean()) if behind.any() else 0.0,
                     "h1_top": float(x[near, 2].max()) if near.any() else 0.0})  # fmt: skip
    with open(a.out / f"lee_{a.spacing}.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"{len(rows)} frames, {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
