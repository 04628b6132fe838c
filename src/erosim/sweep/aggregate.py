"""A sweep's results in two files: ``sweep.csv`` (one row per member: its settings, status and the
scalar results of its report) and ``sweep.nc`` (xarray → NetCDF-4, CF-1.8 attributes, the DEM's CRS
kept): per-cell statistics of every map the completed members wrote (``maps/*.tif``) over the
members — mean, standard deviation (population, ddof = 0), quantiles — and exceedance probabilities
P(map > value), with the varied settings as coordinates of the ``member`` dimension. Probability
maps are drawn in ``figures/``.

A cell where any completed member has no data is NaN in every statistic. Members are read in plan
order, so the maps do not depend on which worker ran a member or when it finished (bit for bit). A
member that failed or went unstable counts in ``sweep.csv`` only; the statistics are over the
completed ones (``members_completed`` in the file's attributes).
"""

from __future__ import annotations

import csv
import io
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from erosim import __version__
from erosim.core.atomic import atomic_path, write_text
from erosim.io import heightmaps as hio
from erosim.io.heightmaps import default_transform
from erosim.sweep.member import read_report
from erosim.sweep.plan import Plan
from erosim.viz.maps import hillshade
from erosim.viz.plots import extent_of, probability_map

UNITS = {"stream": "1", "vegetation": "1", "hardness": "1", "hardness_initial": "1", "hazard": "1"}
SKIPPED_REPORT_KEYS = ("outputs", "progress", "warnings", "error")


def scalars(report: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """The report's numbers (and short texts) flattened to ``a.b.c`` keys, without outputs and lists."""
    out: dict[str, Any] = {}
    for key, value in report.items():
        if not prefix and key in SKIPPED_REPORT_KEYS:
            continue
        if isinstance(value, dict):
            out.update(scalars(value, f"{prefix}{key}."))
        elif isinstance(value, (bool, int, float)) or (isinstance(value, str) and len(value) <= 80):
            out[f"{prefix}{key}"] = value
    return out


def write_csv(path: Path, plan: Plan, records: list[dict[str, Any]], reports: list[dict | None]) -> Path:
    """``sweep.csv``: member, status, the varied settings, wall time, message, then the report's scalars."""
    rows, columns = [], ["member", "status", *plan.keys, "wall_s", "message"]
    for rec, rep, settings in zip(records, reports, plan.members, strict=True):
        row = {"member": rec["member"], "status": rec["status"], **settings, "wall_s": rec.get("wall_s"),
               "message": rec.get("message", "")}  # fmt: skip
        for key, value in scalars(rep or {}).items():
            if key in ("status", "kind"):
                continue
            if key not in columns:
                columns.append(key)
            row[key] = value
        rows.append(row)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return write_text(path, buf.getvalue())


def _read_map(path: Path):

    hm = hio.read(path)
    z = hm.z.astype(np.float32)
    if hm.nodata is not None:
        z[hm.nodata] = np.nan
    return z, hm


def _coordinates(hm, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, tuple]:
    """Cell-centre x and y of the map (the DEM's coordinates) and its extent for the figures."""

    ny, nx = shape
    transform = hm.transform or default_transform(ny, nx, hm.cell_size)
    a, _, c, _, e, f = transform
    return c + a * (np.arange(nx) + 0.5), f + e * (np.arange(ny) + 0.5), extent_of(transform, shape, hm.cell_size)


def _member_coordinate(values: list) -> np.ndarray:
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.asarray(values, dtype=float if any(isinstance(v, float) for v in values) else np.int64)
    return np.asarray([str(v) for v in values], dtype=object)


def statistics(stack: np.ndarray, quantiles: list[float]) -> dict[str, np.ndarray]:
    """Mean, standard deviation (ddof = 0) and quantiles (linear) over axis 0; NaN where any member has
    no data (``np.nanquantile`` would be exact there too, but is a Python loop over cells)."""
    return {
        "mean": stack.mean(axis=0, dtype=np.float64).astype(np.float32),
        "std": stack.std(axis=0, dtype=np.float64).astype(np.float32),
        "quantile": np.quantile(stack, quantiles, axis=0).astype(np.float32),
    }


def exceedance(stack: np.ndarray, op: str, value: float) -> np.ndarray:
    """P(stack ``op`` value) over axis 0: the fraction of members; NaN where any member has no data."""
    hit = stack >= value if op == ">=" else stack > value
    p = hit.mean(axis=0, dtype=np.float64).astype(np.float32)
    p[np.isnan(stack).any(axis=0)] = np.nan
    return p


def aggregate(folder: Path, plan: Plan, records: list[dict[str, Any]]) -> dict[str, Any]:
    """Write ``sweep.csv``, ``sweep.nc`` and the probability figures; returns what the summary shows."""
    import xarray as xr

    member_dirs = [folder / "members" / plan.member_name(i) for i in range(len(plan.members))]
    reports = [read_report(d) for d in member_dirs]
    write_csv(folder / "sweep.csv", plan, records, reports)
    ok = [i for i, r in enumerate(records) if r["status"] == "completed"]
    names = sorted(
        set.intersection(*[{p.stem for p in (member_dirs[i] / "maps").glob("*.tif")} for i in ok]) if ok else set()
    )
    coords: dict[str, Any] = {"member": [plan.member_name(i) for i in ok]}
    for key in plan.keys:
        coords[key] = ("member", _member_coordinate([plan.members[i].get(key) for i in ok]))
    data: dict[str, Any] = {}
    figures, skipped, geo = [], [], None
    thresholds = plan.thresholds()
    for name in names:
        maps = [_read_map(member_dirs[i] / "maps" / f"{name}.tif") for i in ok]
        shapes = {z.shape for z, _ in maps}
        if len(shapes) > 1:
            skipped.append(name)  # members of different sizes (e.g. terrain.size varied)
            continue
        stack = np.stack([z for z, _ in maps])
        if geo is None:
            geo = (maps[0][1], stack.shape[1:])
        units = UNITS.get(name, "m")
        stats = statistics(stack, plan.quantiles)
        for what in ("mean", "std"):
            data[f"{name}_{what}"] = (("y", "x"), stats[what], {"long_name": f"{what} of {name} over the members",
                                                               "units": units})  # fmt: skip
        data[f"{name}_quantile"] = (
            ("quantile", "y", "x"),
            stats["quantile"],
            {"long_name": f"quantiles of {name} over the members", "units": units},
        )
        for t in (t for t in thresholds if t.name == name):
            p = exceedance(stack, t.op, t.value)
            data[t.variable] = (("y", "x"), p, {"long_name": t.label(units), "units": "1", "threshold": t.value,
                                               "threshold_units": units, "comparison": t.op})  # fmt: skip
    ds = xr.Dataset(coords=coords)
    if data and geo is not None:
        hm, shape = geo
        x, y, extent = _coordinates(hm, shape)
        ds = ds.assign_coords(quantile=("quantile", np.asarray(plan.quantiles, dtype=float)), x=x, y=y)
        ds["x"].attrs = {"standard_name": "projection_x_coordinate", "long_name": "x of the cell centre", "units": "m"}
        ds["y"].attrs = {"standard_name": "projection_y_coordinate", "long_name": "y of the cell centre", "units": "m"}
        for key, (dims, arr, attrs) in data.items():
            ds[key] = (dims, arr, attrs)
        if hm.crs:
            ds["spatial_ref"] = (
                (),
                np.int32(0),
                {
                    "crs_wkt": hm.crs,
                    "spatial_ref": hm.crs,
                    "GeoTransform": " ".join(f"{v!r}" for v in hm.transform or ()),
                },
            )
            for key in data:
                ds[key].attrs["grid_mapping"] = "spatial_ref"
        figures = _figures(folder, ds, thresholds, extent, hm.cell_size)
    statuses = [r["status"] for r in records]
    ds.attrs = {
        "Conventions": "CF-1.8",
        "title": f"erosim sweep of {plan.scenario} ({plan.kind})",
        "source": f"erosim {__version__}",
        "history": f"{datetime.now(timezone.utc).isoformat(timespec='seconds')} erosim sweep",
        "design": plan.design,
        "varied": ", ".join(plan.keys) or "nothing",
        "members": len(records),
        "members_completed": len(ok),
        "members_failed": ", ".join(f"{r['member']} ({r['status']})" for r in records if r["status"] != "completed"),
        "threads_per_member": plan.threads,
        "std": "population standard deviation over the completed members (ddof = 0)",
    }
    with atomic_path(folder / "sweep.nc") as tmp:
        ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4")
    return {
        "members": len(records),
        "completed": statuses.count("completed"),
        "unstable": statuses.count("unstable"),
        "failed": len(records) - statuses.count("completed") - statuses.count("unstable"),
        "maps": [n for n in names if n not in skipped],
        "maps_skipped_sizes_differ": skipped,
        "probabilities": [t.variable for t in thresholds if t.variable in ds],
        "figures": figures,
    }


def _figures(folder: Path, ds, thresholds, extent: tuple, cell_size: float) -> list[str]:

    shade = None
    if "height_mean" in ds:
        z = ds["height_mean"].values.astype(np.float64)
        shade = hillshade(np.where(np.isfinite(z), z, np.nanmin(z) if np.isfinite(z).any() else 0.0), cell_size)
    written = []
    n = ds.sizes["member"]
    for t in thresholds:
        if t.variable not in ds:
            continue
        path = folder / "figures" / f"{t.variable}.png"
        path.parent.mkdir(parents=True, exist_ok=True)
        probability_map(
            path, ds[t.variable].values, extent, f"{ds[t.variable].attrs['long_name']} over {n} members", shade
        )
        written.append(str(path.relative_to(folder)))
    return written
