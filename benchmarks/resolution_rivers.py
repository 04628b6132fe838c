"""Resolution independence of the droplet hydrology (issue 38, item 4): the same landscape at two
resolutions, its main rivers in the same places.

    PYTHONPATH=src python benchmarks/resolution_rivers.py --coarse 256 --factor 4 --extent 10240 \
        --length-scale 40 --cycles 640 --out /tmp/resolution-rivers

Runs the library ``hydrology`` scenario twice on the same generated terrain (``mountains``, seed 1,
``extent`` metres a side; the generator works in metres, :func:`erosim.terrain.generate.generate`):
COARSE² cells and (FACTOR·COARSE)² cells, each as

    erosim --quiet run hydrology --set terrain.size=N --set terrain.cell_size=EXTENT/N \
        --set hydrology.length_scale=L --set run.cycles=C --set run.frames=0 --out DIR

with the reference length ℓ = L metres on both (SPEC HY: every droplet parameter follows from ℓ in
metres and seconds: droplets per cycle per area, volume, footprint, acceleration, creep; sub-steps of
at most one cell make the finer run integrate the same paths more finely). ``--length-scale 0`` runs
both with the scenario's default ℓ = two cells instead (resolution dependent by design: the contrast).

Main rivers: the top 2 % of flow accumulation. Flow accumulation is the D8 drainage area (m²) over
the final surface (terrain + lake depth, closed basins filled with a 10⁻⁵ slope so that flats drain,
Barnes et al. 2014); the finer run's is brought to the coarse grid by the block maximum (a channel
crossing a block carries its largest area). Prints one JSON object: IoU of the main-river masks of
the two runs (``main_rivers_iou_top2pct``; issue target ≥ 0.6), the same for the initial terrains
(the rivers the landscape has before any erosion: the baseline), with the finer run's surface
block-averaged to the coarse grid before D8 (``surface_on_coarse_grid``: its rivers drawn at the
coarse cell, free of the finer grid's D8 paths), for the runs' stream maps (top 2 %,
stream brought to the coarse grid by the block mean), with a one-cell tolerance (a coarse cell counts
as matched when a main-river cell of the other run lies among its 8 neighbours), and the runs' wall
times. Every run is on terrain seed SEED. ``--seed-pair`` runs the coarse size once more with droplet
seed SEED + 1 on the same terrain and gives the same measures between the two coarse runs
(``seed_pair``): how far the model's own scatter lets two runs of one landscape agree, the yardstick for
the two resolutions' figures. ``--set KEY=VALUE`` passes a setting to every run; ``--figure PNG`` draws
each pair's main rivers over one another in a 5 km window.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit

TOP = 0.02  # the main rivers: the top 2 % of flow accumulation (issue 38)
FILL_SLOPE = 1e-5  # m/m: flats drain, depressions are passed at their spill level


def _read(path: Path) -> np.ndarray:
    import rasterio

    with rasterio.open(path) as ds:
        return ds.read(1).astype(np.float64)


@njit(cache=True)
def _d8_area(z, cell_area):
    """D8 drainage area (m²): every cell drains to its steepest lower neighbour (drop / distance),
    cells visited from the highest down; a cell with no lower neighbour keeps its area (map edge)."""
    ny, nx = z.shape
    zf = z.ravel()
    order = np.argsort(-zf)
    acc = np.full(ny * nx, cell_area)
    for c in order:
        iy, ix = c // nx, c % nx
        best, to = 0.0, -1
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                jy, jx = iy + dy, ix + dx
                if (dy == 0 and dx == 0) or jy < 0 or jy >= ny or jx < 0 or jx >= nx:
                    continue
                n = jy * nx + jx
                s = (zf[c] - zf[n]) / (1.4142135623730951 if dy != 0 and dx != 0 else 1.0)
                if s > best:
                    best, to = s, n
        if to >= 0:
            acc[to] += acc[c]
    return acc.reshape(ny, nx)


def flow_area(z: np.ndarray, cell: float) -> np.ndarray:
    from erosim.terrain.priority_flood_barnes2014 import fill_basins

    return _d8_area(fill_basins(z, cell, FILL_SLOPE), cell * cell)


def _blocks(a: np.ndarray, f: int, how) -> np.ndarray:
    n = a.shape[0] // f
    return how(a[: n * f, : n * f].reshape(n, f, n, f), axis=(1, 3))


def _top(a: np.ndarray) -> np.ndarray:
    return a >= np.quantile(a, 1.0 - TOP)


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.count_nonzero(a & b) / np.count_nonzero(a | b))


def _near(a: np.ndarray) -> np.ndarray:
    from scipy import ndimage

    return ndimage.binary_dilation(a, np.ones((3, 3), bool))


def _tolerant_iou(a: np.ndarray, b: np.ndarray) -> float:
    """IoU where a cell of either mask counts as matched when the other has a cell within one cell."""
    hit = np.count_nonzero(a & _near(b)) + np.count_nonzero(b & _near(a))
    return float(hit / (np.count_nonzero(a) + np.count_nonzero(b)))


def _surface(run: Path, when: str) -> np.ndarray:
    """The run's initial heights, or its final surface (heights + lake depth)."""
    if when == "initial":
        return _read(run / "maps" / "height_initial.tif")
    return _read(run / "maps" / "height.tif") + np.nan_to_num(_read(run / "maps" / "lake_depth.tif"))


def _main(z: np.ndarray, f: int, cell: float) -> np.ndarray:
    """Main rivers of surface ``z`` (cells of ``cell`` m) on a grid ``f`` times coarser: top 2 % of D8 area,
    block maximum."""
    return _top(_blocks(flow_area(z, cell), f, np.max))


def _agreement(a: np.ndarray, b: np.ndarray) -> dict:
    return {"main_rivers_iou_top2pct": _iou(a, b), "within_one_cell": _tolerant_iou(a, b),
            "cells": [int(a.sum()), int(b.sum())]}  # fmt: skip


def compare(coarse: Path, fine: Path, f: int, cell_c: float, cell_f: float, masks: dict | None = None) -> dict:
    """The measures of the module docstring for two runs; ``masks`` (a dict) receives the final main-river
    masks of both on the coarse grid (``coarse``, ``fine``)."""
    out = {}
    for when in ("initial", "final"):
        z_f = _surface(fine, when)
        m_c, m_f = _main(_surface(coarse, when), 1, cell_c), _main(z_f, f, cell_f)
        if masks is not None and when == "final":
            masks.update(coarse=m_c, fine=m_f)
        m_s = _top(flow_area(_blocks(z_f, f, np.mean), cell_c))  # the finer surface seen on the coarse grid
        out[when] = _agreement(m_c, m_f) | {"surface_on_coarse_grid_iou": _iou(m_c, m_s),
                                            "surface_on_coarse_grid_within_one_cell": _tolerant_iou(m_c, m_s)}
    out["stream_top2pct"] = _stream_measures(coarse, fine, f)
    return out


def _stream_measures(a: Path, b: Path, f: int) -> dict:
    """IoU of the two runs' stream maps' top 2 %, run b's brought to a's grid by the block mean."""
    s_a = _top(_read(a / "maps" / "stream.tif"))
    s_b = _top(_blocks(_read(b / "maps" / "stream.tif"), f, np.mean))
    return {"iou": _iou(s_a, s_b), "within_one_cell": _tolerant_iou(s_a, s_b)}


def figure(path: Path, pairs: list[tuple[str, np.ndarray, np.ndarray, str, str]], cell_c: float, window: float) -> None:
    """Each pair's main rivers over one another in a ``window``-metre square at the map's centre: black
    where both have one, red the first only, blue the second only."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    n = pairs[0][1].shape[0]
    w = min(n, int(window / cell_c))
    lo = (n - w) // 2
    ext = [lo * cell_c / 1e3, (lo + w) * cell_c / 1e3, (lo + w) * cell_c / 1e3, lo * cell_c / 1e3]
    cmap = ListedColormap(["white", "tab:red", "tab:blue", "black"])
    fig, axs = plt.subplots(1, len(pairs), figsize=(6.2 * len(pairs), 7.0), squeeze=False)
    for ax, (title, a, b, la, lb) in zip(axs[0], pairs, strict=True):
        code = a.astype(int) + 2 * b.astype(int)
        ax.imshow(code[lo : lo + w, lo : lo + w], cmap=cmap, vmin=0, vmax=3, extent=ext, interpolation="nearest")
        ax.set_title(f"{title}\nIoU {_iou(a, b):.3f}, within one cell {_tolerant_iou(a, b):.2f}\n"
                     f"red: {la} only, blue: {lb} only, black: both", fontsize=9)  # fmt: skip
        ax.set_xlabel("x (km)")
        ax.set_ylabel("y (km)")
    fig.suptitle("main rivers (top 2 % of D8 area over the final surface, on the coarse grid)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    fig.savefig(path, dpi=90)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--coarse", type=int, default=256)
    ap.add_argument("--factor", type=int, default=4)
    ap.add_argument("--extent", type=float, default=10240.0, help="metres a side (the library terrain's)")
    ap.add_argument("--length-scale", type=float, default=40.0, help="ℓ in metres on both runs; 0 = two cells each")
    ap.add_argument("--cycles", type=int, default=640)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", default="/tmp/resolution-rivers")
    ap.add_argument("--skip-runs", action="store_true", help="measure the runs already in --out")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a setting for every run")
    ap.add_argument("--seed-pair", action="store_true", help="also the coarse size with seed + 1 on the same terrain")
    ap.add_argument("--figure", help="PNG: each pair's main rivers in a 5 km window at the map's centre")
    args = ap.parse_args()
    out = Path(args.out)
    sizes = (args.coarse, args.coarse * args.factor)
    cells = tuple(args.extent / n for n in sizes)
    tag = f"l{args.length_scale:g}" if args.length_scale > 0 else "l2cells"
    result: dict = {"sizes": sizes, "cell_size_m": cells, "extent_m": args.extent, "cycles": args.cycles,
                    "length_scale_m": args.length_scale or "two cells", "seed": args.seed, "settings": args.set,
                    "runs": {}}  # fmt: skip
    runs = [(n, cell, args.seed, out / f"n{n}_{tag}") for n, cell in zip(sizes, cells, strict=True)]
    if args.seed_pair:  # the coarse run again with other droplets on the same terrain: the model's own scatter
        runs.append((sizes[0], cells[0], args.seed + 1, out / f"n{sizes[0]}_{tag}_seed{args.seed + 1}"))
    for n, cell, seed, folder in runs:
        cmd = [sys.executable, "-m", "erosim", "--quiet", "run", "hydrology", "--set", f"terrain.size={n}",
               "--set", f"terrain.cell_size={cell!r}", "--set", f"terrain.seed={args.seed}", "--set", f"seed={seed}",
               "--set", f"run.cycles={args.cycles}", "--set", "run.frames=0",
               "--out", str(folder), "--overwrite"]  # fmt: skip
        if args.length_scale > 0:
            cmd[-3:-3] = ["--set", f"hydrology.length_scale={args.length_scale!r}"]
        for setting in args.set:
            cmd[-3:-3] = ["--set", setting]
        key = str(n) if seed == args.seed else f"{n}_seed{seed}"
        if not args.skip_runs:
            import subprocess

            t0 = time.perf_counter()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)  # its summary table: not this JSON
            result["runs"][key] = {"wall_s": round(time.perf_counter() - t0, 1), "command": " ".join(cmd[1:])}
        report = json.loads((folder / "report.json").read_text())
        result["runs"].setdefault(key, {})["droplets"] = report.get("statistics", {}).get("droplets")
    masks: dict = {}
    result.update(compare(runs[0][3], runs[1][3], args.factor, cells[0], cells[1], masks))
    pairs = [(f"{sizes[0]}² against {sizes[1]}², seed {args.seed}", masks["coarse"], masks["fine"],
              f"{sizes[0]}²", f"{sizes[1]}²")]  # fmt: skip
    if args.seed_pair:
        other = _main(_surface(runs[2][3], "final"), 1, cells[0])
        mc = masks["coarse"]
        result["seed_pair"] = {"final": _agreement(mc, other),
                               "stream_top2pct": _stream_measures(runs[0][3], runs[2][3], 1)}
        pairs.append((f"{sizes[0]}²: seed {args.seed} against seed {args.seed + 1}", mc, other,
                      f"seed {args.seed}", f"seed {args.seed + 1}"))  # fmt: skip
    if args.figure:
        figure(Path(args.figure), pairs, cells[0], 5000.0)
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
