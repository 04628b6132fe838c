"""Where a `mountain-lake` run lowered its ground, and whether along the flow paths: from finished run
folders (fields at the start and at the end), per run

* the eroded volume and the largest and mean lowering of the top surface;
* Spearman's ρ between the lowering and log D8 flow accumulation on the starting surface, outside its
  closed hollows (the hollows filled first, so that the accumulation follows their spill paths), and
  the mean lowering on the top 10 % of the accumulation against the rest: a channel cut along the flow
  paths raises both;
* the lowering along the spill path north of the largest hollow (x 11–13 m, y ≥ 19.5 m on the library's
  terrain.seed = 11 mountain);

and a figure of the lowering maps side by side.

    python benchmarks/mountain_lake_lowering.py FIGURE.png RUN [RUN ...]
"""

from __future__ import annotations

import glob
import json
import sys
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

from erosim.scenarios.builders_voxel import top_surface
from erosim.terrain.priority_flood_barnes2014 import closed_basin_depth
from erosim.terrain.voxel import VoxelTerrain


def d8_accumulation(z: np.ndarray) -> np.ndarray:
    """Cells draining through each cell (itself included), steepest descent over the 8 neighbours."""
    ny, nx = z.shape
    acc = np.ones(z.size)
    for k in np.argsort(z.ravel())[::-1]:
        i, j = divmod(int(k), nx)
        best, to = 0.0, -1
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                a, c = i + di, j + dj
                if (di or dj) and 0 <= a < ny and 0 <= c < nx:
                    s = (z[i, j] - z[a, c]) / np.hypot(di, dj)
                    if s > best:
                        best, to = s, a * nx + c
        if to >= 0:
            acc[to] += acc[k]
    return acc.reshape(ny, nx)


def lowering(run: Path):
    fields = sorted(glob.glob(str(run / "fields" / "density_*.npz")))
    first = VoxelTerrain.load(fields[0])
    start, end = top_surface(first), top_surface(VoxelTerrain.load(fields[-1]))
    return start, start - end, first.cell_size


def measures(run: Path) -> dict:
    start, low, cell = lowering(run)
    hollows = closed_basin_depth(start)
    acc = d8_accumulation(start + hollows)
    out = hollows <= 0
    top = acc[out] > np.percentile(acc[out], 90)
    x = np.arange(start.shape[1]) * cell
    y = np.arange(start.shape[0]) * cell
    spill = (np.abs(x[None, :] - 12.0) <= 1.0) & (y[:, None] >= 19.5)
    rep = json.loads((run / "report.json").read_text())
    return {
        "cell_m": cell,
        "eroded_volume_m3": rep["eroded_volume_m3"],
        "t": rep["t"],
        "max_lowering_m": float(low.max()),
        "mean_lowering_m": float(low.mean()),
        "spearman_lowering_vs_log_accumulation": float(spearmanr(low[out], np.log(acc[out]))[0]),
        "mean_lowering_top10pct_accumulation_m": float(low[out][top].mean()),
        "mean_lowering_rest_m": float(low[out][~top].mean()),
        "spill_path_max_m": float(low[spill].max()),
        "spill_path_mean_m": float(low[spill].mean()),
    }


def figure(runs: list[Path], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(runs), figsize=(5.2 * len(runs), 4.8), constrained_layout=True, squeeze=False)
    for ax, run in zip(axes[0], runs, strict=True):
        start, low, cell = lowering(run)
        x = np.arange(start.shape[1]) * cell
        y = np.arange(start.shape[0]) * cell
        im = ax.imshow(low, origin="lower", extent=(0, x[-1], 0, y[-1]), cmap="magma_r", vmin=0, vmax=0.3)
        ax.contour(x, y, start, levels=15, colors="k", linewidths=0.3)
        ax.set_title(f"{run.name}: {cell:g} m voxels", fontsize=10)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    fig.colorbar(im, ax=axes[0], label="ground lowered (m)")
    fig.suptitle("mountain-lake: the ground lowered by the end; contours: the ground at the start", fontsize=10)
    fig.savefig(path, dpi=80)


if __name__ == "__main__":
    runs = [Path(a) for a in sys.argv[2:]]
    print(json.dumps({str(r): measures(r) for r in runs}, indent=1))
    figure(runs, sys.argv[1])
