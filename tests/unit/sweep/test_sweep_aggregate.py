"""Aggregation of member maps into sweep.nc / sweep.csv, against NumPy on synthetic members."""

import csv
import json

import numpy as np
import pytest
import xarray as xr

from erosim.core.heightmap import Heightmap
from erosim.io import heightmaps as hio
from erosim.sweep.aggregate import aggregate, scalars
from erosim.sweep.plan import Plan

WKT_UTM33 = 'PROJCS["WGS 84 / UTM zone 33N",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],PARAMETER["latitude_of_origin",0],PARAMETER["central_meridian",15],PARAMETER["scale_factor",0.9996],PARAMETER["false_easting",500000],PARAMETER["false_northing",0],UNIT["metre",1],AUTHORITY["EPSG","32633"]]'  # noqa: E501


def _members(tmp_path, n=5, shape=(12, 9), status=None):
    """Member folders with random erosion/height maps (one nodata cell), a georeference and reports."""
    rng = np.random.default_rng(0)
    transform = (5.0, 0.0, 400000.0, 0.0, -5.0, 5100000.0)
    nodata = np.zeros(shape, bool)
    nodata[3, 4] = True
    stacks = {"erosion": [], "height": []}
    status = status or ["completed"] * n
    for i in range(n):
        folder = tmp_path / "members" / f"m{i:04d}"
        (folder / "maps").mkdir(parents=True)
        for name in stacks:
            z = rng.gamma(2.0, 0.6, shape) if name == "erosion" else 100 + rng.normal(0, 3, shape)
            z = z.astype(np.float32).astype(np.float64)
            hio.write(folder / "maps" / f"{name}.tif", Heightmap(z, 5.0, WKT_UTM33, transform, nodata))
            if status[i] == "completed":
                stacks[name].append(np.where(nodata, np.nan, z))
        report = {"status": status[i], "wall_time_s": 1.5 + i, "sediment_budget": {"eroded": 10.0 * i},
                  "outputs": {"maps": {}}, "statistics": {"lake_cells": i}}  # fmt: skip
        (folder / "report.json").write_text(json.dumps(report), encoding="utf-8")
    plan = Plan(scenario="synthetic", kind="hydrology", keys=["hydrology.capacity"],
                members=[{"hydrology.capacity": 0.5 * (i + 1)} for i in range(n)], threads=1,
                quantiles=[0.1, 0.5, 0.9], exceed=["erosion > 1", "erosion >= 2"])  # fmt: skip
    records = [{"index": i, "member": f"m{i:04d}", "status": status[i], "message": "" if status[i] == "completed"
                else "went unstable", "action": "ran", "wall_s": 1.5 + i} for i in range(n)]  # fmt: skip
    return plan, records, {k: np.stack(v) for k, v in stacks.items()}, nodata


def test_statistics_and_probabilities_match_numpy(tmp_path):
    plan, records, stacks, nodata = _members(tmp_path)
    summary = aggregate(tmp_path, plan, records)
    assert summary["completed"] == 5 and summary["maps"] == ["erosion", "height"]
    with xr.open_dataset(tmp_path / "sweep.nc") as ds:
        e = stacks["erosion"]
        # float32 results of float64 sums: compared to float32 rounding (relative 1e-6)
        np.testing.assert_allclose(ds["erosion_mean"].values, e.mean(axis=0), rtol=1e-6)
        np.testing.assert_allclose(ds["erosion_std"].values, e.std(axis=0), rtol=1e-5)
        np.testing.assert_allclose(ds["height_quantile"].sel(quantile=0.9).values,
                                   np.percentile(stacks["height"], 90, axis=0), rtol=1e-6)  # fmt: skip
        for var, hit in (("p_erosion_gt_1", e > 1), ("p_erosion_ge_2", e >= 2)):
            expected = np.where(nodata, np.nan, hit.mean(axis=0)).astype(np.float32)
            np.testing.assert_array_equal(ds[var].values, expected)
        assert np.isnan(ds["p_erosion_gt_1"].values[nodata]).all() and np.isnan(ds["erosion_mean"].values[3, 4])
        assert ds["p_erosion_gt_1"].attrs["long_name"] == "P(erosion > 1 m)"
        # the varied setting is a coordinate of the members; the grid keeps the DEM's place and CRS
        np.testing.assert_array_equal(ds["hydrology.capacity"].values, [0.5, 1.0, 1.5, 2.0, 2.5])
        assert ds.x.values[0] == pytest.approx(400002.5) and ds.y.values[0] == pytest.approx(5099997.5)
        assert "UTM zone 33N" in ds["spatial_ref"].attrs["crs_wkt"]
        assert ds["erosion_mean"].attrs["grid_mapping"] == "spatial_ref" and ds.attrs["Conventions"] == "CF-1.8"
    assert (tmp_path / "figures" / "p_erosion_gt_1.png").stat().st_size > 1000


def test_failed_members_are_listed_but_not_counted(tmp_path):
    status = ["completed", "unstable", "completed", "completed"]
    plan, records, stacks, _ = _members(tmp_path, n=4, status=status)
    summary = aggregate(tmp_path, plan, records)
    assert (summary["completed"], summary["unstable"], summary["failed"]) == (3, 1, 0)
    with xr.open_dataset(tmp_path / "sweep.nc") as ds:
        assert list(ds.member.values) == ["m0000", "m0002", "m0003"]
        np.testing.assert_allclose(ds["erosion_mean"].values, stacks["erosion"].mean(axis=0), rtol=1e-6)
        assert "m0001 (unstable)" in ds.attrs["members_failed"]
    rows = list(csv.DictReader(open(tmp_path / "sweep.csv", encoding="utf-8")))
    assert [r["status"] for r in rows] == status
    assert rows[1]["message"] == "went unstable" and rows[3]["sediment_budget.eroded"] == "30.0"
    assert rows[2]["hydrology.capacity"] == "1.5" and "outputs.maps" not in rows[0]


def test_members_of_different_sizes_skip_that_map(tmp_path):
    plan, records, _, _ = _members(tmp_path, n=2)
    z = np.zeros((4, 4))
    hio.write(tmp_path / "members" / "m0001" / "maps" / "height.tif", Heightmap(z, 5.0))
    summary = aggregate(tmp_path, plan, records)
    assert summary["maps"] == ["erosion"] and summary["maps_skipped_sizes_differ"] == ["height"]


def test_report_scalars_flatten_numbers_and_skip_outputs():
    rep = {"status": "completed", "outputs": {"maps": {"a": {"min": 1}}}, "water_budget": {"rained": 2.0},
           "warnings": ["x"], "terrain": {"shape": [3, 3], "cell_size_m": 5.0}}  # fmt: skip
    assert scalars(rep) == {"status": "completed", "water_budget.rained": 2.0, "terrain.cell_size_m": 5.0}
