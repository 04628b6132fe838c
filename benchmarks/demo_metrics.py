"""The demo's targets (issue 12) measured on a hydrology run folder (default: runs/demo, `make demo`).

    .venv/bin/python benchmarks/demo_metrics.py [RUN_FOLDER] [--json]

Prints hillslope roughness before and after (std of the Laplacian where stream < 0.05 and no lake;
target: after ≤ 1.1 × before), the longest river's span (stream ≥ 0.2, 8-connected; target ≥ 40 % of
the width), the share of river cells in rivers that reach a lake or the edge (target ≥ 80 %; also
with only lakes of ≥ 10 cells counted), the lakes (all, one-cell, ≥ 10 cells), the deepest cut and
the sediment moved per unit of rain (erosim.analysis.terrain_metrics): gross (every volume the
droplets picked up, counted again each time it is picked up anew) and net (the sediment carried off
the map).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from erosim.analysis.terrain_metrics import hillslopes, lake_counts, laplacian_roughness, river_network
from erosim.io import heightmaps as hio
from erosim.terrain.priority_flood_barnes2014 import closed_basin_depth


def _closed_basins(hm) -> float | None:
    """Share of the map in closed basins (water there cannot reach the edge until they fill)."""
    if (hm.nodata is not None and hm.nodata.any()) or not np.isfinite(hm.z).all():
        return None  # nodata holes drain too: the map's edge alone does not define the outlets
    return float((closed_basin_depth(hm.z) > 0).mean())


def measure(folder: Path) -> dict:
    report = json.loads((folder / "report.json").read_text(encoding="utf-8"))
    maps = {name: hio.read(folder / "maps" / f"{name}.tif") for name in
            ("height_initial", "height", "stream", "lake_depth", "erosion")}  # fmt: skip
    cell = maps["height"].cell_size
    slopes = hillslopes(maps["stream"].z, maps["lake_depth"].z)
    before = laplacian_roughness(maps["height_initial"].z, cell, slopes)
    after = laplacian_roughness(maps["height"].z, cell, slopes)
    rivers = river_network(maps["stream"].z, maps["lake_depth"].z)
    rain = report["water_budget"]["rained"]
    eroded = report["sediment_budget"]["eroded"]
    carried = report["sediment_budget"]["carried_off"]
    return {
        "run": str(folder),
        "shape": list(maps["height"].shape),
        "cell_size_m": cell,
        "hillslope_roughness_before_per_m": before,
        "hillslope_roughness_after_per_m": after,
        "roughness_ratio": after / before,
        "roughness_target_met": bool(after <= 1.1 * before),
        **rivers,
        "longest_span_target_met": rivers["longest_span_fraction"] >= 0.4,
        "reaching_target_met": rivers["reaching_outlet_fraction"] >= 0.8,
        **lake_counts(maps["lake_depth"].z),
        "deepest_cut_m": float(np.max(maps["erosion"].z)),
        "sediment_eroded_m3": eroded,
        "rain_m3": rain,
        "sediment_per_rain": eroded / rain if rain else None,
        "sediment_carried_off_m3": carried,
        "carried_off_per_rain": carried / rain if rain else None,
        "closed_basin_fraction_before": _closed_basins(maps["height_initial"]),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", default="runs/demo")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    folder = Path(args.folder)
    if not (folder / "report.json").is_file():
        print(f"demo_metrics: '{folder}' is not a hydrology run folder; run `make demo` first.", file=sys.stderr)
        return 2
    result = measure(folder)
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        for key, value in result.items():
            print(f"{key:36s} {value:.4g}" if isinstance(value, float) else f"{key:36s} {value}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
