"""The Malpasset dam break (2 December 1959) against the police survey's maximum water levels.

The terrain is the public TELEMAC-2D example mesh of the valley (`geo_malpasset-large.slf`, 53 081
nodes, bed "FOND" in metres, distributed with openTELEMAC under the GPL; not shipped with erosim):

    python benchmarks/malpasset.py --mesh geo_malpasset-large.slf --out runs/malpasset

1. The mesh's bed is interpolated linearly on its own triangles (matplotlib.tri) at the centres of
   `--cell` m cells over the mesh's extent; cells outside the mesh are nodata (walls), as the mesh's
   boundary is the valley's (the sea is inside the mesh, low ground at −20 m: the flood spreads into it).
2. `erosim run flood` with the reservoir at its 1959 level, 100 m, filled from a point in the lake,
   the dam's line as in the TELEMAC example (Hervouet & Petitjean 1999), (4701.18, 4143.41)–(4655.55,
   4392.10), drawn 100 m further at both ends to meet the valley's sides; no breach section, so the
   whole dam fails at t = 0, as the arch did; Manning n = 0.033 (the value of the cited models);
   2 000 s simulated (the front passes the last survey point, 12.3 km down the valley, at ~1 400 s).
3. The seventeen police survey points P1–P17 (coordinates and maximum levels as tabulated by
   George 2011, from Hervouet & Petitjean 1999) are the run's gauges; each one's `max_eta`
   (report.json's `gauges_summary`) is compared with the surveyed level: RMSE, bias, largest error.

Own Selafin reader, because the format is one page of big-endian Fortran records and no package
the project already depends on reads it (GDAL's Selafin driver is vector-only and not in rasterio's
wheels).

References: Hervouet, J.-M. & Petitjean, A. (1999) Malpasset dam-break revisited with
two-dimensional computations, J. Hydraul. Res. 37(6); George, D. L. (2011) Adaptive finite volume
methods with well-balanced Riemann solvers for modeling floods in rugged terrain, Int. J. Numer.
Meth. Fluids 66.
"""

from __future__ import annotations

import argparse
import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np

#: Police survey points: name, x, y (m, the TELEMAC mesh's frame), surveyed maximum level (m)
POLICE = [
    ("P1", 4913.1, 4244.0, 84.56), ("P2", 5159.7, 4369.6, 87.03), ("P3", 5790.6, 4177.7, 55.45),
    ("P4", 5886.5, 4503.9, 58.17), ("P5", 6763.0, 3429.6, 48.56), ("P6", 6929.9, 3591.8, 48.35),
    ("P7", 7326.0, 2948.7, 42.06), ("P8", 7451.0, 3232.1, 36.86), ("P9", 8735.9, 3264.6, 34.12),
    ("P10", 8628.6, 3604.6, 40.17), ("P11", 9761.1, 3480.3, 25.96), ("P12", 9832.9, 2414.7, 27.16),
    ("P13", 10957.2, 2651.9, 22.22), ("P14", 11115.7, 3800.7, 21.83), ("P15", 11689.0, 2592.3, 19.48),
    ("P16", 11626.0, 3406.8, 19.89), ("P17", 12333.7, 2269.7, 16.68),
]  # fmt: skip
DAM = ((4701.18, 4143.41), (4655.55, 4392.10))
RESERVOIR_SEED = (4500.0, 4270.0)  # in the lake, 150 m behind the dam (bed 46 m)
LEVEL = 100.0


def read_selafin(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(x, y, triangles, bed) of a 2-D Selafin file: the first variable of its first record."""
    buf = path.read_bytes()
    records, i = [], 0
    while i < len(buf):
        (n,) = struct.unpack(">i", buf[i : i + 4])
        records.append(buf[i + 4 : i + 4 + n])
        i += n + 8
    nbv1, nbv2 = struct.unpack(">2i", records[1])
    k = 2 + nbv1 + nbv2
    iparam = struct.unpack(">10i", records[k])
    k += 2 if iparam[9] == 1 else 1
    nelem, npoin, ndp, _ = struct.unpack(">4i", records[k])
    ikle = np.frombuffer(records[k + 1], ">i4").reshape(nelem, ndp).astype(np.int64) - 1
    real = ">f8" if len(records[k + 3]) == 8 * npoin else ">f4"
    x = np.frombuffer(records[k + 3], real).astype(np.float64) + iparam[2]
    y = np.frombuffer(records[k + 4], real).astype(np.float64) + iparam[3]
    bed = np.frombuffer(records[k + 6], real).astype(np.float64)  # k + 5 is the first record's time
    if ndp != 3 or len(bed) != npoin:
        raise SystemExit(f"{path} is not a 2-D triangle Selafin file with a bed variable first.")
    return x, y, ikle, bed


def rasterise(mesh: Path, cell: float, out: Path) -> Path:
    """The mesh's bed as a GeoTIFF of ``cell`` m (local frame, no CRS), nodata outside the mesh."""
    import matplotlib.tri as mtri
    import rasterio
    from rasterio.transform import from_origin

    x, y, tri, bed = read_selafin(mesh)
    x0, y1 = np.floor(x.min() / cell) * cell, np.ceil(y.max() / cell) * cell
    nx, ny = int(np.ceil((x.max() - x0) / cell)), int(np.ceil((y1 - y.min()) / cell))
    gx, gy = np.meshgrid(x0 + (np.arange(nx) + 0.5) * cell, y1 - (np.arange(ny) + 0.5) * cell)
    z = mtri.LinearTriInterpolator(mtri.Triangulation(x, y, tri), bed)(gx, gy)
    dem = np.where(np.ma.getmaskarray(z), -9999.0, np.ma.getdata(z)).astype(np.float32)
    path = out / f"malpasset_{cell:g}m.tif"
    profile = dict(driver="GTiff", width=nx, height=ny, count=1, dtype="float32", nodata=-9999.0,
                   transform=from_origin(x0, y1, cell, cell))  # fmt: skip
    with rasterio.open(path, "w", **profile) as ds:
        ds.write(dem, 1)
    return path


def dam_line(extend: float = 100.0) -> list[list[float]]:
    (ax, ay), (bx, by) = DAM
    ux, uy = bx - ax, by - ay
    n = float(np.hypot(ux, uy))
    ux, uy = ux / n, uy / n
    return [[ax - extend * ux, ay - extend * uy], [bx + extend * ux, by + extend * uy]]


def measure(run: Path) -> dict:
    """The run's maximum levels at the survey points against the survey."""
    gauges = json.loads((run / "report.json").read_text())["gauges_summary"]
    rows, errors = [], []
    for name, _, _, surveyed in POLICE:
        level = gauges[name]["max_eta"]
        err = None if level is None else level - surveyed
        rows.append({"point": name, "surveyed_m": surveyed, "model_m": level, "error_m": err})
        errors.append(np.nan if err is None else err)
    e = np.asarray(errors)
    dry = int(np.isnan(e).sum())
    e = e[np.isfinite(e)]
    return {
        "rmse_m": float(np.sqrt(np.mean(e**2))), "bias_m": float(e.mean()),
        "largest_m": float(e[np.argmax(np.abs(e))]), "points_dry": dry, "points": rows,
    }  # fmt: skip


def picture(results: list[dict], labels: list[str], png: Path) -> None:
    """Surveyed and computed maximum levels at P1–P17, one marker series per run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.6), constrained_layout=True)
    names = [p[0] for p in POLICE]
    ax.plot(names, [p[3] for p in POLICE], "ks", ms=7, mfc="none", label="police survey (Hervouet & Petitjean 1999)")
    for res, label, marker in zip(results, labels, "o^vDx", strict=False):
        levels = [r["model_m"] for r in res["points"]]
        ax.plot(names, levels, marker, ms=5, label=f"{label}: RMSE {res['rmse_m']:.2f} m")
    ax.set_xlabel("survey point, down the valley (P1 0.2 km below the dam, P17 7.9 km as the crow flies)")
    ax.set_ylabel("maximum water level (m)")
    ax.set_title("Malpasset dam break: maximum levels at the police survey points")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(png, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mesh", type=Path, help="TELEMAC's geo_malpasset-large.slf")
    ap.add_argument("--out", type=Path, required=True, help="folder for the DEM, gauges and run")
    ap.add_argument("--cell", type=float, default=20.0, help="DEM cell (m)")
    ap.add_argument("--spacing", type=float, default=20.0, help="flood.spacing (m)")
    ap.add_argument("--manning", type=float, default=0.033)
    ap.add_argument("--t-end", type=float, default=2000.0)
    ap.add_argument("--set", action="append", default=[], help="more erosim --set KEY=VALUE")
    ap.add_argument("--measure", type=Path, help="only measure this finished run folder")
    ap.add_argument("--json", type=Path, help="also write the figures here")
    ap.add_argument("--png", type=Path, help="draw the levels against the survey (with --also, more runs)")
    ap.add_argument("--also", type=Path, nargs="*", default=[], help="more finished run folders for --png")
    ap.add_argument("--labels", nargs="*", default=[], help="the runs' labels in the picture")
    a = ap.parse_args()
    run = a.measure
    if run is None:
        if a.mesh is None:
            ap.error("--mesh is needed to build the DEM (or --measure RUN to measure a finished run)")
        a.out.mkdir(parents=True, exist_ok=True)
        dem = rasterise(a.mesh, a.cell, a.out)
        gauges = a.out / "police.csv"
        gauges.write_text("name,x,y\n" + "".join(f"{n},{x},{y}\n" for n, x, y, _ in POLICE))
        run = a.out / "run"
        barrier = json.dumps(dam_line(), separators=(",", ":"))
        sets = [
            f"terrain.file={dem}", f"reservoir.level={LEVEL}",
            f"reservoir.seed=[{RESERVOIR_SEED[0]},{RESERVOIR_SEED[1]}]", f"reservoir.barrier={barrier}",
            f"flood.manning={a.manning}", f"flood.spacing={a.spacing}", f"run.t_end={a.t_end}",
            f"gauges.file={gauges}", *a.set,
        ]  # fmt: skip
        cmd = [sys.executable, "-m", "erosim", "run", "flood", "--out", str(run), "--overwrite"]
        for s in sets:
            cmd += ["--set", s]
        subprocess.run(cmd, check=True)
    result = {"run": str(run), **measure(run)}
    print(json.dumps(result, indent=1))
    if a.json:
        a.json.write_text(json.dumps(result, indent=1) + "\n")
    if a.png:
        runs = [run, *a.also]
        labels = a.labels + [str(r) for r in runs[len(a.labels) :]]
        picture([result, *(measure(r) for r in a.also)], labels, a.png)


if __name__ == "__main__":
    main()
