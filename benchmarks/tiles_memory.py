"""Peak memory and wall time of a tiled hydrology build against an untiled run of the same DEM.

    PYTHONPATH=src python benchmarks/tiles_memory.py --size 2048 --tile 512 --overlap 32 --cycles 64 \
        --workers 2 --out /tmp/tiles-bench

Generates a ``mountains`` DEM of SIZE² cells (20 m, UTM 33N) as a GeoTIFF, then runs

    erosim --quiet run hydrology --set terrain.file=DEM --set run.cycles=C --set run.frames=0 --out U
    erosim --quiet run hydrology --set terrain.file=DEM ... --tile N --overlap K --workers W --out T

each under ``/usr/bin/time -f '%M kB %e s'`` (``%M``: the largest resident set of any one process of
the command's tree, i.e. the main process or one Dask worker) while sampling the summed resident
set of the whole process tree (main + nanny + workers) every 0.2 s with psutil. Prints one JSON
object: both runs' peak RSS (largest process, whole tree) and wall time, and the tiled build's seam
figures next to the same figures measured on the untiled run at the same lines (what an untiled
run shows there by itself).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path


def _tree_rss(pid: int) -> int:
    import psutil

    try:
        p = psutil.Process(pid)
        procs = [p, *p.children(recursive=True)]
    except psutil.Error:
        return 0
    total = 0
    for q in procs:
        try:
            total += q.memory_info().rss
        except psutil.Error:
            pass
    return total


def measured(cmd: list[str]) -> dict:
    """Run ``cmd`` under /usr/bin/time; its largest process's and its whole tree's peak RSS, wall time."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        ["/usr/bin/time", "-f", "TIME %M kB %e s", *cmd], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
    )
    peak = [0]

    def sample():
        while proc.poll() is None:
            peak[0] = max(peak[0], _tree_rss(proc.pid))
            time.sleep(0.2)

    th = threading.Thread(target=sample, daemon=True)
    th.start()
    _, err = proc.communicate()
    th.join()
    wall = time.perf_counter() - t0
    line = [ln for ln in err.splitlines() if ln.startswith("TIME ")]
    if proc.returncode != 0 or not line:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{err[-3000:]}")
    kb = int(line[-1].split()[1])
    return {"peak_rss_largest_process_mb": kb / 1024, "peak_rss_tree_mb": peak[0] / 2**20, "wall_s": wall}


def mountains_dem(out: Path, size: int) -> Path:
    """The benchmarks' test DEM (generated mountains, 20 m cells, UTM 33N) at ``out/dem<size>.tif``, made once."""
    from rasterio.crs import CRS

    from erosim.io.heightmaps import write
    from erosim.terrain.generate import generate

    dem = out / f"dem{size}.tif"
    if not dem.exists():
        hm = generate("mountains", size, 20.0, 7)
        hm.crs = CRS.from_epsg(32633).to_wkt()
        hm.transform = (20.0, 0.0, 500000.0, 0.0, -20.0, 4000000.0)
        write(dem, hm)
    return dem


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=2048)
    ap.add_argument("--tile", type=int, default=512)
    ap.add_argument("--overlap", type=int, default=32)
    ap.add_argument("--cycles", type=int, default=64)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--out", default="/tmp/tiles-bench")
    ap.add_argument("--skip-untiled", action="store_true")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    dem = mountains_dem(out, args.size)
    erosim = [sys.executable, "-m", "erosim", "--quiet", "run", "hydrology"]
    common = ["--set", f"terrain.file={dem}", "--set", f"run.cycles={args.cycles}", "--set", "run.frames=0"]
    result: dict = {"size": args.size, "tile": args.tile, "overlap": args.overlap, "cycles": args.cycles,
                    "workers": args.workers, "rounds": args.rounds, "cores": os.cpu_count()}  # fmt: skip
    tiled_out = out / f"tiled{args.size}"
    cmd = [*erosim, *common, "--tile", str(args.tile), "--overlap", str(args.overlap),
           "--set", f"tiles.rounds={args.rounds}", "--workers", str(args.workers), "--out", str(tiled_out),
           "--overwrite"]  # fmt: skip
    result["tiled"] = measured(cmd)
    report = json.loads((tiled_out / "report.json").read_text())
    result["tiled"]["tiles"] = len(report["plan"]["tiles"])
    result["tiled"]["seams"] = report["seams"]
    if not args.skip_untiled:
        untiled_out = out / f"untiled{args.size}"
        result["untiled"] = measured([*erosim, *common, "--out", str(untiled_out), "--overwrite"])
        from erosim.tiles import seams
        from erosim.tiles.plan import plan

        tiles = plan((args.size, args.size), args.tile, args.overlap)
        maps = untiled_out / "maps"
        result["untiled"]["seams_at_the_same_lines"] = seams.figures(
            maps / "height.tif", maps / "stream.tif", tiles, (args.size, args.size)
        )
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
