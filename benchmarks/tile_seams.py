"""Seams of a tiled hydrology build against untiled runs of the same DEM (issue 38, item 3).

    PYTHONPATH=src python benchmarks/tile_seams.py --size 1024 --tile 256 --overlap 8 --rounds 8 \
        --cycles 640 --workers 2 --out /tmp/tile-seams

Generates a ``mountains`` DEM of SIZE² cells (20 m, UTM 33N, seed 7, as benchmarks/tiles_memory.py),
then runs (each under ``/usr/bin/time``, :func:`tiles_memory.measured`)

    erosim --quiet run hydrology --set terrain.file=DEM --set run.cycles=C --set run.frames=0 \
        --tile N --overlap K --set tiles.rounds=R --workers W --out T        # the tiled build
    erosim --quiet run hydrology --set terrain.file=DEM --set run.cycles=C --set run.frames=0 --out U1
    ... the same with --set seed=2 --out U2      # the seed-to-seed scatter of an untiled run

and prints one JSON object with

* ``seams``: the tiled build's seam figures (:mod:`erosim.tiles.seams`: the largest height jump across
  a tile border against the 99.9th percentile of neighbour differences inside the tiles; river
  continuity: the share of river cells (stream ≥ 0.2) in the last row/column before a border with a
  river cell among the three facing it across), and the same figures of the untiled run at the same
  lines;
* ``against_untiled``: the tiled build against the untiled run of the same seed — river mask IoU
  (stream ≥ 0.2) and the IoU of the main rivers (the top 2 % of stream values of each map), heights
  (|Δz| median, 95th and 99th percentiles, and of the change z − z₀) on the cells at least ``--away``
  cells from every tile border; ``seed_scatter``: the same figures for the untiled run of seed 2
  against seed 1, the scale a tiled build's difference is to be read against (droplets are random: two
  seeds do not give the same rivers cell for cell).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from tiles_memory import measured, mountains_dem  # noqa: E402

RIVER = 0.2  # erosim.analysis.terrain_metrics.RIVER_STREAM


def _read(path: Path) -> np.ndarray:
    import rasterio

    with rasterio.open(path) as ds:
        return ds.read(1).astype(np.float64)


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    union = np.count_nonzero(a | b)
    return float(np.count_nonzero(a & b) / union) if union else float("nan")


def compare(run: Path, ref: Path, away: np.ndarray) -> dict:
    """``run``'s maps against ``ref``'s: river IoU, main-river IoU, heights on the ``away`` cells."""
    s, s0 = _read(run / "maps" / "stream.tif"), _read(ref / "maps" / "stream.tif")
    z, z0 = _read(run / "maps" / "height.tif"), _read(ref / "maps" / "height.tif")
    zi = _read(ref / "maps" / "height_initial.tif")
    top, top0 = s >= np.quantile(s, 0.98), s0 >= np.quantile(s0, 0.98)
    dz = np.abs(z - z0)[away]
    change, change0 = (z - zi)[away], (z0 - zi)[away]
    return {
        "river_iou": _iou(s >= RIVER, s0 >= RIVER),
        "main_river_iou_top2pct": _iou(top, top0),
        "river_cells": [int((s >= RIVER).sum()), int((s0 >= RIVER).sum())],
        "height_absdiff_away_median_m": float(np.median(dz)),
        "height_absdiff_away_p95_m": float(np.quantile(dz, 0.95)),
        "height_absdiff_away_p99_m": float(np.quantile(dz, 0.99)),
        "change_rms_away_m": [float(np.sqrt(np.mean(change**2))), float(np.sqrt(np.mean(change0**2)))],
        "cells_away": int(away.sum()),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--tile", type=int, default=256)
    ap.add_argument("--overlap", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=8, help="tiles.rounds (8, the scenario's default)")
    ap.add_argument("--cycles", type=int, default=640)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--away", type=int, default=16, help="cells from every tile border for the height figures")
    ap.add_argument("--out", default="/tmp/tile-seams")
    ap.add_argument("--skip-untiled", action="store_true", help="reuse the untiled runs already in --out")
    ap.add_argument("--build", default=None,
                    help="measure this finished tiled build folder (e.g. one made by another version of erosim with "
                    "the same settings) instead of running one")  # fmt: skip
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    dem = mountains_dem(out, args.size)  # the same DEM as benchmarks/tiles_memory.py's
    erosim = [sys.executable, "-m", "erosim", "--quiet", "run", "hydrology"]
    common = ["--set", f"terrain.file={dem}", "--set", f"run.cycles={args.cycles}", "--set", "run.frames=0"]
    result: dict = {"size": args.size, "tile": args.tile, "overlap": args.overlap, "rounds": args.rounds,
                    "cycles": args.cycles, "workers": args.workers, "cores": os.cpu_count()}  # fmt: skip
    tiled = Path(args.build) if args.build else out / f"tiled{args.size}_r{args.rounds}"
    if args.build is None:
        cmd = [*erosim, *common, "--tile", str(args.tile), "--overlap", str(args.overlap),
               "--set", f"tiles.rounds={args.rounds}", "--workers", str(args.workers), "--out", str(tiled),
               "--overwrite"]  # fmt: skip
        result["tiled_run"] = measured(cmd)
    result["build"] = str(tiled)
    report = json.loads((tiled / "report.json").read_text())
    result["tiles"] = len(report["plan"]["tiles"])
    result["exchange_per_round"] = [r.get("entered") for r in report["rounds"]]
    runs = {seed: out / f"untiled{args.size}_s{seed}" for seed in (1, 2)}
    for seed, folder in runs.items():
        if not (args.skip_untiled and (folder / "maps" / "height.tif").is_file()):
            result[f"untiled_run_seed{seed}"] = measured([*erosim, *common, "--set", f"seed={seed}", "--out",
                                                          str(folder), "--overwrite"])  # fmt: skip
    from erosim.tiles import seams
    from erosim.tiles.plan import borders, plan

    shape = (args.size, args.size)
    tiles = plan(shape, args.tile, args.overlap)
    maps = runs[1] / "maps"
    hmaps = tiled / "maps"
    result["seams"] = {"tiled": seams.figures(hmaps / "height.tif", hmaps / "stream.tif", tiles, shape),
                       "untiled_at_the_same_lines": seams.figures(maps / "height.tif", maps / "stream.tif", tiles,
                                                                  shape)}  # fmt: skip
    rows, cols = borders(tiles)
    dist = np.full(shape, 10**9)
    idx = np.arange(args.size)
    for b in rows:
        dist = np.minimum(dist, np.abs(idx[:, None] - (b - 0.5)).astype(int) + 0 * idx[None, :])
    for b in cols:
        dist = np.minimum(dist, np.abs(idx[None, :] - (b - 0.5)).astype(int) + 0 * idx[:, None])
    away = dist >= args.away
    result["against_untiled"] = compare(tiled, runs[1], away)
    result["seed_scatter"] = compare(runs[2], runs[1], away)
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
