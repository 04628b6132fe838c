"""Validation of the shallow-water SPH's wet/dry fronts: Thacker's planar oscillation in a paraboloid.

Thacker (1981, *J. Fluid Mech.* 107): over the bed b(r) = −h₀(1 − r²/a²) without friction, a cap of
water h = h₀[1 − |x − c(t)|²/a²] (where positive) keeps its shape while its centre orbits,
c(t) = σ(cos ωt, sin ωt), with the uniform velocity u = σω(−sin ωt, cos ωt), ω = √(2gh₀)/a. The
shoreline moves over dry ground all the time, so the case tests wet/dry fronts with no special
treatment (SWASHES, Delestre et al. 2013: a = 1 m, h₀ = 0.1 m, σ = 0.5 m).

Measured over ``periods`` periods, 16 times a period: the SPH depth on the DEM's nodes against the
analytic cap, RMS over the nodes wet in either, relative to h₀ (threshold 10 %), and the wet area's
intersection over union with the analytic disc (shoreline position). Reported besides: the water's
centroid against c(t) — by momentum conservation the centroid of any SPH solution on a paraboloid is
an exact harmonic oscillator, so it checks the bed force and the step, not the fronts.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

from erosim.core import atomic
from erosim.core.errors import ConfigError
from erosim.io.runfolder import RunFolder, default_out
from erosim.scenarios import estimate
from erosim.sph.kernels_swe import step_limit
from erosim.sph.shallow_water_vacondio2012 import ShallowWaterParams, ShallowWaterSPH, equal_volumes
from erosim.viz.plots import save_figure

G = 9.81
A, H0, SIGMA, L = 1.0, 0.1, 0.5, 4.0
THRESHOLD = 0.10
WET = 0.01  # × h₀: nodes shallower than this are dry
RESOLUTIONS = {"coarse": 0.05, "default": 0.025, "fine": 0.0125}  # particle spacing (m)


def omega() -> float:
    return math.sqrt(2 * G * H0) / A


def exact_centre(t) -> np.ndarray:
    w = omega()
    t = np.asarray(t, np.float64)
    return np.stack([SIGMA * np.cos(w * t), SIGMA * np.sin(w * t)], axis=-1)


def bowl(spacing: float, params: ShallowWaterParams | None = None) -> ShallowWaterSPH:
    """The solver over the paraboloid (DEM cells of half the spacing), with the cap at t = 0."""
    cs = spacing / 2
    n = int(round(L / cs)) + 1
    g = np.arange(n) * cs - L / 2
    X, Y = np.meshgrid(g, g)
    bed = -H0 * (1 - (X**2 + Y**2) / A**2)
    fine = spacing / math.sqrt(2.0)  # the cap's mean depth is h₀/2: `spacing` there, finer in the middle
    xs = np.arange(-A + SIGMA, A + SIGMA, fine) + 0.5 * fine
    ys = np.arange(-A, A, fine) + 0.5 * fine
    x, y = (a.ravel() for a in np.meshgrid(xs, ys))
    h = H0 * (1 - ((x - SIGMA) ** 2 + y**2) / A**2)
    wet = h > 0
    p = params or ShallowWaterParams(viscosity=0.0)
    pos, vol = equal_volumes(np.column_stack([x[wet] + L / 2, y[wet] + L / 2]), h[wet], 0.5 * math.pi * A**2 * H0)
    vel = np.zeros_like(pos)
    vel[:, 1] = SIGMA * omega()
    return ShallowWaterSPH(bed, cs, pos, vol, spacing, p, vel=vel, manning=0.0, surface=H0)


def run_case(resolution: str = "default", periods: float = 2.0, params: ShallowWaterParams | None = None,
             progress: bool = False) -> dict:
    if resolution not in RESOLUTIONS:
        raise ConfigError(f"Unknown resolution '{resolution}'; use one of: {', '.join(RESOLUTIONS)}.")
    spacing = RESOLUTIONS[resolution]
    m = bowl(spacing, params)
    period = 2 * math.pi / omega()
    t_end = periods * period
    samples = np.linspace(0.0, t_end, int(periods * 16) + 1)
    guess = estimate.shallow_water(f"a bowl of {spacing:g} m particles", m, t_end, speed=SIGMA * omega())  # u ≤ σω
    if progress:
        print(f"thacker: {guess.line()}", file=sys.stderr, flush=True)
    n = m.bed.shape[0]
    g = np.arange(n) * m.cell - L / 2
    X, Y = np.meshgrid(g, g)
    track, errors, ious = [], [], []
    wall0 = time.perf_counter()

    for ts in samples:
        while m.t < ts - 1e-12:
            m.step(min(m.params.courant * step_limit(m.vel, m.depth, m.hsup, m.n, m.params.g), ts - m.t))
        track.append((m.vol[:, None] * m.pos).sum(0) / m.vol.sum() - L / 2)
        cx, cy = exact_centre(ts)
        exact = np.maximum(H0 * (1 - ((X - cx) ** 2 + (Y - cy) ** 2) / A**2), 0.0)
        sph = m.depth_grid()
        wet_e, wet_s = exact > WET * H0, sph > WET * H0
        both = wet_e | wet_s
        errors.append(float(np.sqrt(np.mean((sph[both] - exact[both]) ** 2)) / H0))
        ious.append(float((wet_e & wet_s).sum() / both.sum()))
    wall = time.perf_counter() - wall0
    track = np.asarray(track)
    centre = exact_centre(samples)
    err = np.hypot(*(track - centre).T) / SIGMA
    return {
        "rms_rel": float(np.sqrt(np.mean(np.square(errors)))),
        "rms_rel_final": errors[-1],
        "wet_iou_min": float(min(ious)),
        "centroid_error_rel_max": float(err.max()),
        "period_s": period,
        "t_end": float(m.t),
        "particles": m.n,
        "steps": m.steps,
        "steps_estimated": round(guess.steps),
        "spacing_m": spacing,
        "wall_time_s": round(wall, 2),
        "budget_closure_rel": m.budget()["closure_rel"],
        "track": (samples, np.asarray(errors), np.asarray(ious), m.depth_grid(), X, Y),
    }


def run(resolution: str = "default", out: Path | None = None, progress: bool = True) -> dict:
    """Thacker's oscillation; writes ``validation.json`` and ``figures/thacker.png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    folder = RunFolder(out if out is not None else default_out(f"validate-thacker-{resolution}"))
    r = run_case(resolution, progress=progress)
    t, errors, ious, depth, X, Y = r.pop("track")
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 4.2))
    im = ax0.pcolormesh(X, Y, np.where(depth > WET * H0, depth, np.nan), cmap="Blues", shading="auto")
    cx, cy = exact_centre(r["t_end"])
    ang = np.linspace(0, 2 * np.pi, 200)
    ax0.plot(cx + A * np.cos(ang), cy + A * np.sin(ang), "k--", lw=1, label="analytic shoreline")
    ax0.set_aspect("equal")
    ax0.set_xlim(-L / 2, L / 2)
    ax0.set_ylim(-L / 2, L / 2)
    ax0.set_xlabel("x (m)")
    ax0.set_ylabel("y (m)")
    ax0.legend(fontsize=8, loc="upper right")
    fig.colorbar(im, ax=ax0, label="SPH depth (m)")
    ax0.set_title(f"t = {r['t_end']:.2f} s ({r['t_end'] / r['period_s']:.0f} periods)", fontsize=10)
    ax1.plot(t, 100 * errors, "C0.-", label="depth RMS (% of h₀)")
    ax1.plot(t, 100 * (1 - ious), "C1.-", label="1 − wet-area IoU (%)")
    ax1.set_xlabel("t (s)")
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3)
    ax1.set_title(f"Δx = {r['spacing_m']:g} m: depth RMS {100 * r['rms_rel']:.1f} % of h₀", fontsize=10)
    fig.tight_layout()
    path = folder.figures / "thacker.png"
    save_figure(fig, path)
    result = {
        "case": "thacker",
        "metric": "RMS depth error against Thacker's cap over two periods (nodes wet in either), relative to h0",
        "value": r["rms_rel"],
        "threshold": THRESHOLD,
        "passed": bool(r["rms_rel"] < THRESHOLD and abs(r["budget_closure_rel"]) < 1e-12),
        "out": str(folder.path),
        "resolution": resolution,
        **r,
        "figure": str(path.relative_to(folder.path)),
    }
    atomic.write_json(folder.path / "validation.json", result)
    return result
