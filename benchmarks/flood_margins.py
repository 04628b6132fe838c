"""The flood's margins before and after a change: two run folders of `erosim run flood`, their figures
and a picture of both hazard maps cropped to the flood.

    git worktree add ../before REV     # the code before the change
    PYTHONPATH=../before/src .venv/bin/erosim run flood --set flood.spacing=5 --out runs/flood-before
    .venv/bin/erosim run flood --set flood.spacing=5 --out runs/flood-after
    .venv/bin/python benchmarks/flood_margins.py runs/flood-before runs/flood-after \
        --png docs/images/before_after/flood_margins.png

Printed per folder (JSON): the shallowest wet cell of maps/max_depth.tif, the shares of the flooded
cells (hazard 1–6) shallower than 1 m and 0.5 m, the flooded cells, report.json's hazard_share
(and below the dam) and water-budget closure; and the two extents' intersection over union.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def _read(folder: Path):
    import rasterio

    with rasterio.open(folder / "maps" / "max_depth.tif") as f:
        depth = f.read(1).astype(np.float64)
    with rasterio.open(folder / "maps" / "hazard.tif") as f:
        hazard = f.read(1)
    report = json.loads((folder / "report.json").read_text())
    return depth, hazard, report


def facts(folder: Path) -> tuple[dict, np.ndarray]:
    depth, hazard, rep = _read(folder)
    wet = (hazard >= 1) & (hazard <= 6)
    d = depth[wet]
    return {
        "shallowest_wet_m": float(d.min()),
        "share_below_1m": float((d < 1.0).mean()),
        "share_below_0.5m": float((d < 0.5).mean()),
        "flooded_cells": int(wet.sum()),
        "flooded_area_m2": rep["flooded_area_m2"],
        "hazard_share": {k: round(v, 4) for k, v in rep["hazard_share"].items()},
        "hazard_share_below_dam": {k: round(v, 4) for k, v in rep["hazard_share_below_dam"].items()},
        "closure_rel": rep["water_budget"]["closure_rel"],
        "steps": rep["steps"],
    }, wet


BEFORE_AFTER = ("before: each cell the depth\nof the particles over it", "after: the SPH depth\nat the cell centre")


def picture(before: Path, after: Path, png: Path, titles: tuple[str, str] = BEFORE_AFTER, suptitle: str = "") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    from erosim.analysis.hazard import CLASSES

    maps = [_read(before)[1], _read(after)[1]]
    wet = (maps[0] >= 1) & (maps[0] <= 6) | (maps[1] >= 1) & (maps[1] <= 6)
    rows, cols = np.flatnonzero(wet.any(axis=1)), np.flatnonzero(wet.any(axis=0))
    r0, r1 = max(rows.min() - 3, 0), rows.max() + 4
    c0, c1 = max(cols.min() - 3, 0), cols.max() + 4
    colours = ["#ffffff", "#1a9641", "#a6d96a", "#ffffbf", "#fdae61", "#d7191c", "#7b3294"]
    cmap = ListedColormap(colours)
    norm = BoundaryNorm(np.arange(-0.5, 7.5), cmap.N)
    fig, axes = plt.subplots(1, 2, figsize=(5.4, 6.4), sharey=True)
    for ax, m, title in zip(axes, maps, titles, strict=True):
        shown = np.where(m == 255, 0, m)[r0:r1, c0:c1]
        ax.imshow(shown, cmap=cmap, norm=norm, interpolation="nearest")
        flooded = (shown >= 1).sum()
        shallow = ((shown >= 1) & (shown <= 4)).sum()
        ax.set_title(f"{title}\nH1–H4 {100 * shallow / max(flooded, 1):.1f} % of {flooded} cells", fontsize=8)
        ax.set_xticks([])
        ax.set_yticks([])
    handles = [Patch(color=colours[k], label=name) for k, name in enumerate(CLASSES, start=1)]
    fig.legend(handles=handles, loc="lower center", ncol=6, fontsize=7, frameon=False)
    default = "erosim run flood --set flood.spacing=5:\nmaps/hazard.tif, cropped to the flood"
    fig.suptitle(suptitle or default, fontsize=9)
    fig.tight_layout(rect=(0, 0.06, 1, 0.95))
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--png", type=Path, default=None)
    ap.add_argument("--titles", nargs=2, default=None, help="the two panels' titles (\\n for a new line)")
    ap.add_argument("--suptitle", default="", help="the figure's title (\\n for a new line)")
    args = ap.parse_args(argv)
    a, wa = facts(args.before)
    b, wb = facts(args.after)
    out = {
        "before": a,
        "after": b,
        "iou": float((wa & wb).sum() / (wa | wb).sum()),
        "extent_change": float(wb.sum() / wa.sum() - 1.0),
    }
    print(json.dumps(out, indent=1))
    if args.png is not None:
        titles = tuple(t.replace("\\n", "\n") for t in args.titles) if args.titles else BEFORE_AFTER
        picture(args.before, args.after, args.png, titles, args.suptitle.replace("\\n", "\n"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
