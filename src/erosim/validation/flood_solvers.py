"""Validation: the two flood solvers agree on where a small valley breach floods.

The library's ``flood`` scenario scaled down: a V valley 320 m square on 5 m cells (sides rising 20 m,
the floor falling 5 m northward), a dam line across it 225 m from its head holding 1 210 m³ (2 m deep
at the dam), a 10 m breach window to the valley floor, the north edge open, Manning's n = 0.035,
40 s. It runs once with the shallow-water SPH (``swe``) and once with the 3-D SPH on the heightfield
ground (``sph3d``, the thesis's method), both from the same set-up: the same reservoir volume, breach,
friction law and n, and the same rule for the maps (each particle marks the cell under it with the
depth of its water column). Compared: the flooded extents (cells whose maximum depth reached
``flood.wet_depth``) by intersection over union, threshold 0.8 (the issue's); the flooded areas, the
volumes each solver started with and the water that left are reported too. Resolutions: (swe, sph3d)
particle spacings of (2.5, 1.0) m coarse, (1.25, 0.5) m default (four 3-D particles through the dam's
2 m, about 9 700 of them), (1.25, 0.35) m fine.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from erosim.core import atomic
from erosim.core.errors import ConfigError
from erosim.io.runfolder import RunFolder, default_out
from erosim.scenarios import loader
from erosim.scenarios.runner import execute
from erosim.viz.plots import save_figure

THRESHOLD = 0.8
#: particle spacing (m) of (swe, sph3d)
RESOLUTIONS = {"coarse": (2.5, 1.0), "default": (1.25, 0.5), "fine": (1.25, 0.35)}
SETS = [
    "terrain.size=64", "terrain.cell_size=5.0", "terrain.relief=20.0",
    "reservoir.level=3.5", "reservoir.seed=[160.0, 150.0]",
    "reservoir.barrier=[[0.0, 225.0], [320.0, 225.0]]",
    "breach.bottom_width=10.0", "breach.floor=1.4", "breach.side_slope=1.0",
    "breach.line=[[160.0, 215.0], [160.0, 235.0]]",
    "run.t_end=40.0", "run.map_frames=0", "flood.settle_steps=200",
]  # fmt: skip


def _run(solver: str, spacing: float, folder: Path, progress: bool):

    scenario = loader.load("flood", [*SETS, f"flood.solver={solver}", f"flood.spacing={spacing!r}"])
    out = RunFolder(folder / solver)
    t0 = time.perf_counter()
    execute(scenario, out, progress=progress)
    wall = time.perf_counter() - t0
    import rasterio

    with rasterio.open(out.path / "maps" / "max_depth.tif") as ds:
        depth = ds.read(1, masked=True).filled(0.0)
    return depth, wall, out


def figure(path: Path, depth: dict, wet: dict, iou: float) -> None:
    """Both solvers' maximum depths and where each flooded (``depth``, ``wet``: map arrays by solver)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    union = wet["swe"] | wet["sph3d"]
    fig, axes = plt.subplots(1, 3, figsize=(12, 4.4))
    for ax, name in zip(axes[:2], ("swe", "sph3d"), strict=True):
        im = ax.imshow(np.where(wet[name], depth[name], np.nan), cmap="Blues", origin="upper")
        ax.set_title(f"{name}: maximum depth (m)", fontsize=10)
        fig.colorbar(im, ax=ax, shrink=0.8)
    both = np.zeros(union.shape + (3,))
    both[wet["swe"] & wet["sph3d"]] = (0.2, 0.4, 0.8)
    both[wet["swe"] & ~wet["sph3d"]] = (0.9, 0.6, 0.1)
    both[~wet["swe"] & wet["sph3d"]] = (0.8, 0.1, 0.1)
    both[~union] = 1.0
    axes[2].imshow(both, origin="upper")
    axes[2].set_title(f"flooded by both (blue), swe only (orange),\nsph3d only (red): IoU {iou:.2f}", fontsize=9)
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    fig.tight_layout()
    save_figure(fig, path)


def run(resolution: str = "default", out: Path | None = None, progress: bool = True) -> dict:
    """Both solvers on the small valley; writes ``validation.json`` and ``figures/flood_solvers.png``."""
    import json

    if resolution not in RESOLUTIONS:
        raise ConfigError(f"Unknown resolution '{resolution}'; use one of: {', '.join(RESOLUTIONS)}.")
    folder = RunFolder(out if out is not None else default_out(f"validate-flood-solvers-{resolution}"))
    s_swe, s_3d = RESOLUTIONS[resolution]
    runs = {}
    for name, spacing in (("swe", s_swe), ("sph3d", s_3d)):
        depth, wall, run_out = _run(name, spacing, folder.path, progress)
        rep = json.loads((run_out.path / "report.json").read_text())
        runs[name] = {"depth": depth, "wall": wall, "report": rep}
    wet = {k: v["depth"] >= runs[k]["report"]["wet_depth_m"] for k, v in runs.items()}
    union = wet["swe"] | wet["sph3d"]
    iou = float((wet["swe"] & wet["sph3d"]).sum() / max(union.sum(), 1))
    path = folder.figures / "flood_solvers.png"
    figure(path, {k: v["depth"] for k, v in runs.items()}, wet, iou)
    result = {
        "case": "flood-solvers",
        "metric": "intersection over union of the flooded extents of the shallow-water and the 3-D SPH floods",
        "value": iou,
        "iou": iou,
        "threshold": THRESHOLD,
        "passed": bool(iou >= THRESHOLD),
        "out": str(folder.path),
        "resolution": resolution,
        **{
            name: {
                "spacing_m": spacing,
                "particles": r["report"]["particles"],
                "steps": r["report"]["steps"],
                "flooded_area_m2": r["report"]["flooded_area_m2"],
                "volume_initial_m3": r["report"]["volume_initial_m3"],
                "volume_out_m3": r["report"]["volume_out_m3"],
                "max_depth_m": r["report"]["max_depth_m"],
                "wall_time_s": round(r["wall"], 2),
            }
            for (name, r), spacing in zip(runs.items(), (s_swe, s_3d), strict=True)
        },
        "figure": str(path.relative_to(folder.path)),
    }
    atomic.write_json(folder.path / "validation.json", result)
    return result
