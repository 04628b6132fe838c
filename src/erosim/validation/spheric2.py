"""Validation: SPHERIC benchmark Test 2, a 3-D dam break against a box (Kleefsman et al. 2005).

The ``spheric2`` scenario runs for ``t_end``; its gauges and probes (``gauges.csv``) are compared
with the MARIN measurements (``erosim/data/reference/spheric2_kleefsman2005_marin.csv``):

* water level at H1–H4: RMS of (run − experiment) over 0 ≤ t ≤ 1.5 s, the experiment interpolated
  at the run's samples; target ≤ 10 % of the initial column height H = 0.55 m (55 mm) at each gauge;
* pressure at P1–P4 on the box's front face after the impact: the ±10 ms means of run and experiment
  every 20 ms over 0.5 ≤ t ≤ 1.5 s, RMS of their difference relative to ρ₀gH (5.4 kPa); target
  ≤ 25 % at P1 and P3 (issue 14).

The experiment's time origin is the gate's release (the measurements start at t = 0). Each gauge's
level is read two ways (:func:`erosim.analysis.gauges.water_level`): the wetted length of the gauge's
line, as a wire gauge reads it (its signal is the immersed length of its wires), and the continuous
water column from the floor. The targets are scored on the wetted length (``wire_level_rms_m``); the
column (``level_rms_m``) is reported beside it. Behind the box a plunging jet closes an air pocket
over the floor that this single-phase model leaves empty, and the column reading stops under it
while the water over it still wets a wire (docs/sph.md, "SPHERIC Test 2"). The targets are set for
the default resolution and finer; the coarse run reports which it misses. Pressures are read as the
load the fluid puts on the box's particles around the sensor (:mod:`erosim.sph.wall_load`), as the
sensors feel it.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from erosim.core import atomic
from erosim.core.errors import ConfigError
from erosim.data import SPHERIC2, reference_csv
from erosim.io.runfolder import RunFolder, default_out
from erosim.scenarios import loader
from erosim.scenarios.runner import execute
from erosim.validation import run_facts
from erosim.validation.criteria import at_most, verdict
from erosim.viz.plots import series_vs_experiment

H = 0.55  # initial column height (m)
LEVEL_WINDOW = (0.0, 1.5)
LEVEL_THRESHOLD = 0.10  # of H
PRESSURE_WINDOW = (0.5, 1.5)
PRESSURE_THRESHOLD = 0.25  # of rho0 g H, at P1 and P3
GAUGES = ("H1", "H2", "H3", "H4")
PROBES = ("P1", "P2", "P3", "P4")
RESOLUTIONS = {"coarse": 0.05, "default": 0.025, "fine": 0.02}  # spacing (m)
TARGETS_FROM = "default"  # the coarsest resolution the targets are set for


def _csv(path: Path) -> dict[str, np.ndarray]:
    head, *rows = path.read_text().splitlines()
    data = np.array([[float(x) for x in r.split(",")] for r in rows if r.strip()], dtype=np.float64)
    return {name: data[:, j] for j, name in enumerate(head.split(","))}


def _window_means(t: np.ndarray, v: np.ndarray, centres: np.ndarray, half: float = 0.01) -> np.ndarray:
    return np.array([v[(t >= c - half) & (t <= c + half)].mean() for c in centres])


def errors(run: dict[str, np.ndarray], exp: dict[str, np.ndarray], rho0: float, g: float) -> dict:
    """Level RMS (m and /H) per gauge, read as the column and as the wetted length, and pressure RMS (/ρ₀gH)
    per probe, as the module docstring says."""
    out: dict = {"level_rms_m": {}, "level_rms_rel": {}, "wire_level_rms_m": {}, "wire_level_rms_rel": {},
                 "pressure_rms_rel": {}}  # fmt: skip
    t = run["t"]
    sel = (t >= LEVEL_WINDOW[0]) & (t <= LEVEL_WINDOW[1])
    for g_ in GAUGES:
        lab = np.interp(t[sel], exp["t_s"], exp[f"{g_}_m"])
        rms = float(np.sqrt(np.mean((run[f"depth_{g_}"][sel] - lab) ** 2)))
        out["level_rms_m"][g_] = rms
        out["level_rms_rel"][g_] = rms / H
        if f"wire_{g_}" in run:  # runs before the wetted length was recorded have only the column
            out["wire_level_rms_m"][g_] = float(np.sqrt(np.mean((run[f"wire_{g_}"][sel] - lab) ** 2)))
            out["wire_level_rms_rel"][g_] = out["wire_level_rms_m"][g_] / H
    centres = np.arange(PRESSURE_WINDOW[0], PRESSURE_WINDOW[1] + 1e-9, 0.02)
    for p in PROBES:
        sim = _window_means(t, run[f"p_{p}"], centres)
        ref = _window_means(exp["t_s"], exp[f"{p}_Pa"], centres)
        out["pressure_rms_rel"][p] = float(np.sqrt(np.mean((sim - ref) ** 2)) / (rho0 * g * H))
    return out


def _mm(x: float) -> str:
    return f"{1000 * x:.1f} mm"


def criteria(e: dict, resolution: str) -> tuple[list[dict], str]:
    """The pass criteria on the errors ``e`` (:func:`errors`): each gauge's wetted-length RMS ≤ 10 % of H,
    P1's and P3's pressure RMS ≤ 25 % of ρ₀gH; and a note for a resolution the targets are not set for."""
    if set(e["wire_level_rms_m"]) != set(GAUGES):
        raise ConfigError("The run's gauges.csv has no wetted length (wire_H1 …); rerun it with this erosim.")
    out = [
        at_most(f"{g_} level", f"wetted-length RMS over 0-1.5 s (column {_mm(e['level_rms_m'][g_])})",
                e["wire_level_rms_m"][g_], LEVEL_THRESHOLD * H, fmt=_mm)
        for g_ in GAUGES
    ] + [
        at_most(f"{p} pressure", "post-impact pressure RMS over 0.5-1.5 s, of rho0*g*H", e["pressure_rms_rel"][p],
                PRESSURE_THRESHOLD)
        for p in ("P1", "P3")
    ]  # fmt: skip
    order = list(RESOLUTIONS)
    note = ""
    if order.index(resolution) < order.index(TARGETS_FROM):
        note = (
            f"{resolution} (dx = {RESOLUTIONS[resolution]:g} m) is not expected to meet the targets, which are set "
            f"for {TARGETS_FROM} (dx = {RESOLUTIONS[TARGETS_FROM]:g} m) and finer"
        )
    return out, note


def run(
    resolution: str = "default",
    out: Path | None = None,
    progress: bool = True,
    overrides: tuple[str, ...] | list[str] = (),
) -> dict:
    """Run the case; writes ``validation.json`` and ``figures/spheric2_vs_experiment.png``. ``overrides`` are
    scenario settings (``section.key=value``) applied after the case's own, for studies (docs/sph.md)."""

    if resolution not in RESOLUTIONS:
        raise ConfigError(f"Unknown resolution '{resolution}'; use one of: {', '.join(RESOLUTIONS)}.")
    dx = RESOLUTIONS[resolution]
    scenario = loader.load(
        "spheric2",
        [f"sph.spacing={dx!r}", "run.t_end=1.6", "run.output_interval=0.1", "run.checkpoint_wall_s=600.0", *overrides],
    )
    cfg = scenario.config
    g = abs(cfg.sph.gravity_vector()[-1])
    folder = RunFolder(out if out is not None else default_out(f"validate-spheric2-{resolution}"))
    wall0 = time.perf_counter()
    summary, sim = execute(scenario, folder, progress=progress)
    wall = time.perf_counter() - wall0
    solver = sim.models[0]
    series = _csv(folder.path / "gauges.csv")
    exp = reference_csv(SPHERIC2)
    e = errors(series, exp, cfg.sph.rho0, g)

    keep = exp["t_s"] <= 1.6
    panels = [
        {"title": f"{g_}: water level, RMS {1000 * e['wire_level_rms_m'][g_]:.0f} mm (wetted length)", "unit": "m",
         "t": series["t"], "value": series[f"wire_{g_}"], "t_exp": exp["t_s"][keep], "exp": exp[f"{g_}_m"][keep],
         "window": LEVEL_WINDOW, "also": (f"column from the floor, RMS {1000 * e['level_rms_m'][g_]:.0f} mm",
                                          series[f"depth_{g_}"])}
        for g_ in GAUGES
    ] + [
        {"title": f"{p}: pressure, RMS {100 * e['pressure_rms_rel'][p]:.0f} % of ρ₀gH", "unit": "Pa",
         "t": series["t"], "value": series[f"p_{p}"], "t_exp": exp["t_s"][keep], "exp": exp[f"{p}_Pa"][keep],
         "window": PRESSURE_WINDOW}
        for p in PROBES
    ]  # fmt: skip
    fig = series_vs_experiment(
        folder.figures / "spheric2_vs_experiment.png", panels,
        title=f"SPHERIC Test 2, Δx = {dx:g} m ({solver.n_fluid:,} fluid particles)",
    )  # fmt: skip
    crit, note = criteria(e, resolution)
    passed, line = verdict(crit, note)
    result = {
        "case": "spheric2",
        "metric": "water level read as the wetted length (wire gauge): RMS over 0-1.5 s relative to H = 0.55 m, "
        "worst of H1-H4",
        "value": max(e["wire_level_rms_rel"].values()),
        "threshold": LEVEL_THRESHOLD,
        "passed": passed,
        "verdict": line,
        "criteria": crit,
        "out": str(folder.path),
        "wire_level_rms_m": e["wire_level_rms_m"],
        "wire_level_rms_rel": e["wire_level_rms_rel"],
        "level_rms_m": e["level_rms_m"],
        "level_rms_rel": e["level_rms_rel"],
        "level_readings": "wire_*: the wetted length of the gauge's line (scored); level_*: the continuous column "
        "from the floor, which stops under the air pocket a plunging jet leaves empty behind the box (docs/sph.md)",
        "pressure_rms_rel": e["pressure_rms_rel"],
        "pressure_metric": "RMS of ±10 ms means every 20 ms over 0.5-1.5 s, relative to rho0*g*H; target P1, P3",
        "pressure_threshold": PRESSURE_THRESHOLD,
        "resolution": resolution,
        "spacing": dx,
        "overrides": list(overrides),
        **run_facts(solver, summary, wall),
        "figure": str(fig.relative_to(folder.path)),
    }
    atomic.write_json(folder.path / "validation.json", result)
    return result
