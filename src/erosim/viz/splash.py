"""Pictures of splash runs: surface wetness, wetness over time, a crater's profile (seed 003 figs. 6–9)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from erosim.viz.plots import map_figure, save_figure  # noqa: E402

WET = "YlGnBu"


def wetness_figure(path, wetness: np.ndarray, cell_size: float, title: str, extent=None):
    """Surface saturation θ (north-up array) on 0…1."""
    bar = {"cmap": WET, "vmin": 0.0, "vmax": 1.0, "label": "surface saturation θ"}
    return map_figure(path, np.asarray(wetness, np.float64), cell_size, title, colorbar=bar, extent=extent)


def puddles_figure(path, puddles: np.ndarray, cell_size: float, extent=None):
    """The standing water's depth (mm, north-up array; blank where none stands)."""
    depth = np.where(puddles > 0, puddles * 1e3, np.nan)
    top = float(np.nanmax(depth)) if np.isfinite(depth).any() else 1.0
    bar = {"cmap": "Blues", "vmin": 0.0, "vmax": top, "label": "standing water (mm)"}
    return map_figure(path, depth, cell_size, "Puddles at the end", colorbar=bar, extent=extent)


def wetness_frames_figure(path, frames: list[np.ndarray], times: list[float], columns: int = 4):
    """The wetness frames side by side (north up), each with its time."""
    k = len(frames)
    cols = min(columns, k)
    rows = int(np.ceil(k / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(2.4 * cols, 2.4 * rows + 0.3), squeeze=False)
    for n, ax in enumerate(axes.ravel()):
        ax.set_axis_off()
        if n < k:
            im = ax.imshow(frames[n], cmap=WET, vmin=0.0, vmax=1.0, interpolation="nearest")
            ax.set_title(f"t = {times[n]:.3g} s", fontsize=9)
    fig.colorbar(im, ax=axes.ravel().tolist(), shrink=0.8, label="surface saturation θ")
    return save_figure(fig, path)


def crater_profile_figure(path, geo, terrain: np.ndarray):
    """The crater's section through its deepest point (mm), before and after."""
    r = geo.raster
    j, i = np.unravel_index(int(np.argmax(geo.initial - terrain)), terrain.shape)
    x = (np.arange(r.nx) - i) * r.dx * 1e3
    fig, ax = plt.subplots(figsize=(6.4, 3.0))
    ax.plot(x, geo.initial[j] * 1e3, color="0.6", label="before")
    ax.fill_between(x, terrain[j] * 1e3, terrain[j].min() * 1e3 - 1, color="#a0522d", alpha=0.6)
    ax.plot(x, terrain[j] * 1e3, color="#6b3a1e", label="after")
    ax.set_xlabel("distance from the crater's centre (mm)")
    ax.set_ylabel("height (mm, true scale)")
    ax.set_aspect("equal")
    depth, rim = float((geo.initial - terrain).max()) * 1e3, float((terrain - geo.initial).max()) * 1e3
    ax.set_title(f"Crater section through its deepest point (y = {j * r.dy * 1e3:.1f} mm): depth {depth:.2f} mm, "
                 f"rim {rim:.2f} mm", fontsize=9)  # fmt: skip
    ax.legend(loc="lower right", fontsize=8)
    return save_figure(fig, path)


def craters_side_by_side(path, sections: list[tuple[str, np.ndarray, np.ndarray]], title: str):
    """Crater sections (label, x mm, height mm) in one row: dry / partly wet / saturated."""
    fig, axes = plt.subplots(1, len(sections), figsize=(3.2 * len(sections), 2.8), sharey=True)
    low = min(float(z.min()) for _, _, z in sections)
    for ax, (label, x, z) in zip(np.atleast_1d(axes), sections, strict=True):
        ax.fill_between(x, z, low - 0.5, color="#a0522d", alpha=0.7)
        ax.plot(x, z, color="#6b3a1e")
        ax.set_title(label, fontsize=9)
        ax.set_xlabel("mm")
        ax.set_aspect("equal")
    np.atleast_1d(axes)[0].set_ylabel("height (mm)")
    fig.suptitle(title, fontsize=10)
    return save_figure(fig, path)


def energy_scaling_figure(path, energy, diameter, beta: float, published: dict[str, float], title: str):
    """Crater diameter (mm) against kinetic energy (J), log–log, with the fitted and published slopes."""
    e, d = np.asarray(energy, np.float64), np.asarray(diameter, np.float64) * 1e3
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    ax.loglog(e, d, "o", color="#6b3a1e", label=f"erosim (fitted β = {beta:.3f})")
    mid_e, mid_d = float(np.exp(np.log(e).mean())), float(np.exp(np.log(d).mean()))
    ee = np.geomspace(e.min() / 1.3, e.max() * 1.3, 50)
    for (name, b), style in zip(sorted(published.items()), ("--", ":"), strict=False):
        ax.loglog(ee, mid_d * (ee / mid_e) ** b, style, color="0.3",
                  label=f"published slope, {name}: β = {b:g} (through the runs' mean)")  # fmt: skip
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    ticks = [t for t in (1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2) if ee[0] <= t <= ee[-1]]
    ax.set_xticks(ticks, [f"{t:.0e}" for t in ticks])
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.yaxis.set_major_formatter(ScalarFormatter())
    ax.yaxis.set_minor_formatter(ScalarFormatter())
    ax.set_xlabel("drop kinetic energy E_K (J)")
    ax.set_ylabel("crater diameter D_c (mm)")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)
