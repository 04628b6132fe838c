"""The golden cases: one short run of every kind, summarised into a few numbers that are stored in
``tests/regression/golden/<case>.json`` and compared by ``test_golden.py``.

A summary is every number of the run's ``report.json`` (nested keys joined by dots) but the ones that
measure the machine (wall and CPU times, throughputs, memory) or name files, and for every map
(``maps/*.tif``) and voxel field (the last ``fields/density_*.npz``) its sum, sum of squares, least
and largest value. The runs are deterministic for a given thread count (fixed-chunk reductions,
counter-based random numbers), so on one machine they repeat to the last bit; the comparison's
tolerance (``RTOL``) allows only the last-bit differences another CPU or maths library may give.

After a change that is meant to change results, rewrite the stored values with
``.venv/bin/python tests/regression/update_golden.py [case ...]`` and say in the commit why they moved.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
STORE = HERE / "golden"

#: relative tolerance: float64 results of a few hundred steps whose only difference is the rounding of
#: a transcendental function (exp, pow, sqrt are correctly rounded or within 1 ulp in glibc and in
#: LLVM's intrinsics) stay within ~1e-12 relative; 1e-9 leaves room for their growth over the run
#: and is still six orders of magnitude below any change of physics the cases would show.
RTOL = 1e-9
#: absolute floor for values that are zero or cancel to round-off (m, m³, Pa of a few-metre scene)
ATOL = 1e-12

# name → (scenario, --set overrides, preset): each a few seconds on one core (the flood: the flood-solvers
# validation's small valley, 10 s after the breach)
CASES: dict[str, tuple[str, dict, str | None]] = {
    "sph-dam-break-2d": ("dam-break-2d", {"run.t_end": 0.05, "run.output_interval": 0.0, "run.snapshots": 0}, None),
    "sph-terrain-rain": ("rain-erosion", {
        "terrain.size": 12, "terrain.cell_size": 2.0, "sph.spacing": 1.0, "rain.every": 5, "run.map_frames": 0,
        "rain.rate": 4e5, "edges.outflow": ["north", "east"], "terrain.relief": 4.0, "run.t_end": 0.6,
        "run.output_interval": 0.0}, None),
    "hydrology": ("hydrology", {"terrain.size": 48, "terrain.cell_size": 40.0, "run.cycles": 6, "run.frames": 0,
                                "hydrology.cycle_droplets": 20000}, None),
    "particle-stream": ("particle-stream", {"terrain.size": 64, "emitters.main.particles": 150,
                                            "emitters.main.steps": 50}, None),
    "voxel-overtopping": ("overtopping", {
        "sph.spacing": 0.04, "voxels.cell_size": 0.04, "run.t_end": 0.3, "run.output_interval": 0.15,
        "run.profile_interval": 0.05, "erosion.tau_c": 0.5, "erosion.k_eps": 2.0, "erosion.start": 0.05,
        "erosion.every": 10, "erosion.k_eps_units": "fraction", "erosion.morfac": 1.0}, "full"),
    "splash-drop": ("splash-drop", {"run.t_end": 0.003}, None),
    "flood": ("flood", {
        "terrain.size": 64, "terrain.cell_size": 5.0, "terrain.relief": 20.0, "reservoir.level": 3.5,
        "reservoir.seed": [160.0, 150.0], "reservoir.barrier": [[0.0, 225.0], [320.0, 225.0]],
        "breach.bottom_width": 10.0, "breach.floor": 1.4, "breach.side_slope": 1.0,
        "breach.line": [[160.0, 215.0], [160.0, 235.0]], "flood.spacing": 2.5, "run.t_end": 10.0, "run.map_frames": 0,
        "flood.settle_steps": 200}, None),
}  # fmt: skip

_MACHINE = re.compile(r"wall|cpu|time_s|_s$|per_s|throughput|fraction|memory|rss|threads|version|python|path|"
                      r"outputs|seconds|estimate|progress|timings|costs")  # fmt: skip


def _numbers(value, key: str, out: dict[str, float]) -> None:
    if _MACHINE.search(key.rsplit(".", 1)[-1]) or (key and _MACHINE.search(key.split(".", 1)[0])):
        return
    if isinstance(value, (bool, int, float)):
        out[key] = float(value)
    elif isinstance(value, dict):
        for k, v in value.items():
            _numbers(v, f"{key}.{k}" if key else str(k), out)
    elif isinstance(value, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        for i, v in enumerate(value):
            out[f"{key}[{i}]"] = float(v)


def _array_stats(a: np.ndarray, name: str, out: dict[str, float]) -> None:
    a = np.asarray(a, np.float64)
    a = a[np.isfinite(a)]
    out[f"{name}.sum"] = float(a.sum())
    out[f"{name}.sum_sq"] = float((a * a).sum())
    out[f"{name}.min"] = float(a.min()) if a.size else 0.0
    out[f"{name}.max"] = float(a.max()) if a.size else 0.0


def summarise(folder: Path) -> dict[str, float]:
    """The numbers of a run folder that the regression tier compares (module docstring)."""
    import rasterio

    out: dict[str, float] = {}
    _numbers(json.loads((folder / "report.json").read_text()), "", out)
    for tif in sorted((folder / "maps").glob("*.tif")):
        with rasterio.open(tif) as src:
            band = src.read(1, masked=True)
        _array_stats(band.astype(np.float64).filled(np.nan), f"maps.{tif.stem}", out)
    fields = sorted((folder / "fields").glob("density_*.npz"))
    if fields:
        with np.load(fields[-1]) as f:
            _array_stats(f["density"], "fields.density", out)
    return out


def run_case(name: str, root: Path) -> dict[str, float]:
    """Run golden case ``name`` into ``root/name`` and summarise it."""
    import erosim

    scenario, sets, preset = CASES[name]
    res = erosim.run(scenario, root / name, set=sets, preset=preset, progress=False)
    return summarise(res.path)


def stored(name: str) -> dict[str, float]:
    return json.loads((STORE / f"{name}.json").read_text())


def differences(now: dict[str, float], then: dict[str, float]) -> list[str]:
    """One line per number that is new, gone, or outside RTOL/ATOL."""
    lines = [f"{k}: new ({now[k]!r})" for k in sorted(set(now) - set(then))]
    lines += [f"{k}: gone (was {then[k]!r})" for k in sorted(set(then) - set(now))]
    for k in sorted(set(now) & set(then)):
        a, b = now[k], then[k]
        if not (abs(a - b) <= ATOL + RTOL * abs(b) or (np.isnan(a) and np.isnan(b))):
            lines.append(f"{k}: {a!r}, stored {b!r} (relative difference {abs(a - b) / max(abs(b), 1e-300):.2g})")
    return lines
