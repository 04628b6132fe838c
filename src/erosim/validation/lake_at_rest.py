"""Validation: a lake on rough real terrain stays at rest (the shallow-water SPH's balance of the depth
gradient against the bed slope).

A basin of the Jacksboro DEM (``sample:jacksboro``: 83 m cells, heights in whole metres) is filled to
325 m, 4 m below its spill level: about 19 Mm³ up to 19 m deep, with shores over stepped ground. The
flood set-up lays equal-volume particles and lets them settle (FIRE, to 1e-3 m/s); then the lake runs
free, with Manning friction and nothing else, for ``t_end``. Passed when 99 % of the particles stay
slower than 1e-3 m/s throughout (the bound the issue sets) and no water leaves; the fastest particle,
the surface's spread and the settling steps are reported.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from erosim.core import atomic
from erosim.core.errors import ConfigError
from erosim.io.runfolder import RunFolder, default_out
from erosim.scenarios import estimate
from erosim.scenarios.flood.build import build
from erosim.scenarios.loader import load
from erosim.viz.plots import save_figure

SPEED = 1e-3  # m/s
LEVEL, SEED = 325.0, (-84.2133, 36.5925)
RESOLUTIONS = {"coarse": 166.0, "default": 83.0, "fine": 41.5}  # particle spacing (m)
T_END = {"coarse": 300.0, "default": 600.0, "fine": 600.0}

SCENARIO = """schema_version = 1
kind = "flood"
name = "lake-at-rest"
description = "A lake at rest in a basin of the Jacksboro DEM."
[terrain]
file = "sample:jacksboro"
[reservoir]
level = {level!r}
seed = [{x!r}, {y!r}]
[flood]
spacing = {spacing!r}
settle_steps = 8000
settle_speed = {speed!r}
[run]
t_end = {t_end!r}
map_frames = 0
"""


def run(resolution: str = "default", out: Path | None = None, progress: bool = True) -> dict:
    """Settle the lake, run it free; writes ``validation.json`` and ``figures/lake_speeds.png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    if resolution not in RESOLUTIONS:
        raise ConfigError(f"Unknown resolution '{resolution}'; use one of: {', '.join(RESOLUTIONS)}.")
    folder = RunFolder(out if out is not None else default_out(f"validate-lake-at-rest-{resolution}"))
    t_end = T_END[resolution]
    text = SCENARIO.format(level=LEVEL, x=SEED[0], y=SEED[1], spacing=RESOLUTIONS[resolution], speed=SPEED,
                           t_end=t_end)  # fmt: skip
    scenario_path = folder.path / "scenario.toml"
    atomic.write_text(scenario_path, text)
    wall0 = time.perf_counter()
    _, m = build(load(str(scenario_path)).config)
    settle_wall = time.perf_counter() - wall0
    if progress:  # a lake at rest: the wave speed alone sets the step
        guess = estimate.shallow_water("a settled lake", m, t_end - m.t)
        print(f"lake-at-rest: {guess.line()}", file=sys.stderr, flush=True)
    times, p99, fastest, median = [], [], [], []
    while m.t < t_end:
        m.step()
        s = np.hypot(m.vel[:, 0], m.vel[:, 1])
        times.append(m.t)
        p99.append(float(np.percentile(s, 99)))
        fastest.append(float(s.max()))
        median.append(float(np.median(s)))
    wall = time.perf_counter() - wall0
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.semilogy(times, fastest, label="fastest particle")
    ax.semilogy(times, p99, label="99th percentile")
    ax.semilogy(times, median, label="median")
    ax.axhline(SPEED, color="k", ls="--", lw=1, label="1 mm/s")
    ax.set_xlabel("t after settling (s)")
    ax.set_ylabel("speed (m/s)")
    ax.set_title(f"A lake at rest on the Jacksboro DEM: {m.n} particles of {RESOLUTIONS[resolution]:g} m", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    path = folder.figures / "lake_speeds.png"
    save_figure(fig, path)
    worst_p99 = max(p99)
    budget = m.budget()
    result = {
        "case": "lake-at-rest",
        "metric": "99th percentile of particle speeds over the free run after settling (m/s)",
        "value": worst_p99,
        "threshold": SPEED,
        "passed": bool(worst_p99 < SPEED and budget["volume_out_m3"] == 0.0),
        "out": str(folder.path),
        "resolution": resolution,
        "fastest_m_s": max(fastest),
        "median_m_s_end": median[-1],
        "surface_std_m": float(np.std(m.surface())),
        "volume_m3": budget["volume_initial_m3"],
        "particles": m.n,
        "settle_steps": m.settle_steps,
        "steps": m.steps,
        "t_end": m.t,
        "settle_wall_s": round(settle_wall, 2),
        "wall_time_s": round(wall, 2),
        "figure": str(path.relative_to(folder.path)),
    }
    atomic.write_json(folder.path / "validation.json", result)
    return result
