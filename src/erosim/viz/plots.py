"""Figures of SPH runs (PNG, written atomically): particle snapshots coloured by speed, the surge
front against an experiment, and a pressure profile against the hydrostatic line.

matplotlib with the non-interactive Agg backend; each function draws one figure and returns its path.
"""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from erosim.core.atomic import atomic_path  # noqa: E402
from erosim.viz.maps import hillshade


def save_figure(fig, path: str | os.PathLike) -> Path:
    """Write ``fig`` as a PNG at 110 dpi through an atomic path, and close it."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return Path(path)


def snapshot(
    path,
    positions: np.ndarray,
    velocities: np.ndarray,
    *,
    t: float,
    lo,
    hi,
    spacing: float | None = None,
    boundary: np.ndarray | None = None,
    title: str = "",
    speed_max: float | None = None,
) -> Path:
    """Particles coloured by speed |u|; 3-D runs are shown as a side view (x–z).

    With ``spacing`` the dots are drawn about one particle spacing wide; ``speed_max`` fixes the top of
    the colour scale (the same on every frame of a run), else it is the frame's own maximum."""
    pos = np.asarray(positions)
    speed = np.linalg.norm(velocities, axis=1) if len(pos) else np.zeros(0)
    ix, iz = 0, pos.shape[1] - 1 if pos.ndim == 2 else 1
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    w, hgt = hi[ix] - lo[ix], hi[iz] - lo[iz]
    aspect = hgt / max(w, 1e-12)
    fig, ax = plt.subplots(figsize=(9.0 if aspect < 1 else 2.0 + 6.0 / aspect, 1.3 + min(7.0, 7.0 * aspect)))
    if boundary is not None and len(boundary):
        ax.scatter(boundary[:, ix], boundary[:, iz], s=1, c="0.6", lw=0)
    order = np.argsort(pos[:, 1]) if pos.shape[1] == 3 else slice(None)  # far particles first
    size = 2.0
    if spacing:
        pts = fig.get_figwidth() * 0.75 * 72.0 * spacing / max(w, 1e-12)  # one spacing in points
        size = float(np.clip((0.9 * pts) ** 2, 0.5, 60.0))
    sc = ax.scatter(
        pos[order, ix], pos[order, iz], s=size, c=speed[order], cmap="viridis", lw=0, vmin=0.0, vmax=speed_max
    )
    fig.colorbar(sc, ax=ax, label="speed (m/s)", fraction=0.025, pad=0.02)
    ax.set_xlim(lo[ix], hi[ix])
    ax.set_ylim(lo[iz], hi[iz])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)" if pos.shape[1] == 3 else "y (m)")
    ax.set_title(f"{title} t = {t:.4g} s".strip())
    fig.tight_layout()
    return save_figure(fig, path)


def front_vs_experiment(
    path,
    T: np.ndarray,
    Z: np.ndarray,
    ref_T: np.ndarray,
    ref_Z: np.ndarray,
    *,
    label: str = "erosim",
    ref_label: str = "Martin & Moyce (1952)",
    title: str = "",
    computed: tuple[np.ndarray, np.ndarray, str] | None = None,
) -> Path:
    """Non-dimensional surge front Z = x/a against T = t√(2g/a), simulation line vs measured points;
    ``computed`` = (T, Z, label) adds another computation's front as a dashed line."""
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(T, Z, "-", label=label)
    ax.plot(ref_T, ref_Z, "o", mfc="none", label=ref_label)
    if computed is not None:
        ax.plot(computed[0], computed[1], "--", color="0.4", label=computed[2])
    ax.set_xlabel("T = t √(2g/a)")
    ax.set_ylabel("Z = x_front / a")
    ax.grid(alpha=0.3)
    ax.legend()
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return save_figure(fig, path)


def series_vs_experiment(path, panels: list[dict], title: str = "") -> Path:
    """Time series of a run against an experiment, one panel each: ``title``, ``unit``, ``t``, ``value``
    (the run) and ``t_exp``, ``exp`` (the measurement), and optionally the ``window`` (t0, t1) scored
    and ``also`` = (label, values at ``t``), a second reading of the run drawn dashed."""
    cols = 2
    rows = (len(panels) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(11, 2.4 * rows), sharex=True, squeeze=False)
    for ax, pan in zip(axes.ravel(), panels, strict=False):
        ax.plot(pan["t_exp"], pan["exp"], color="0.45", lw=0.8, label="experiment")
        ax.plot(pan["t"], pan["value"], color="tab:blue", lw=1.1, label="erosim")
        if "also" in pan:
            ax.plot(pan["t"], pan["also"][1], color="tab:green", lw=0.9, ls="--", label=pan["also"][0])
            ax.legend(fontsize=7)
        if "window" in pan:
            ax.axvspan(*pan["window"], color="tab:orange", alpha=0.08, lw=0)
        ax.set_title(pan["title"], fontsize=9)
        ax.set_ylabel(pan["unit"])
    for ax in axes.ravel()[len(panels) :]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def pressure_profile(
    path, z: np.ndarray, p: np.ndarray, *, rho0: float, g: float, H: float, floor: float = 0.0, title: str = ""
) -> Path:
    """Particle pressure against height with the hydrostatic line p = ρ₀ g (H − z)."""
    fig, ax = plt.subplots(figsize=(5, 5))
    ax.plot(p, z, ".", ms=2, alpha=0.5, label="particles")
    zz = np.linspace(floor, floor + H, 50)
    ax.plot(rho0 * g * (floor + H - zz), zz, "k-", label="ρ₀ g (H − z)")
    ax.set_xlabel("pressure (Pa)")
    ax.set_ylabel("height (m)")
    ax.grid(alpha=0.3)
    ax.legend()
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return save_figure(fig, path)


def _canvas_rgb(fig) -> np.ndarray:
    """The figure as an RGB uint8 array (Agg canvas)."""
    fig.canvas.draw()
    rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    plt.close(fig)
    return rgb


def terrain_panels(height: np.ndarray, water: np.ndarray, change: np.ndarray, cell_size: float,
                   title: str = "", change_range: float | None = None) -> np.ndarray:  # fmt: skip
    """Seed 000's three panels (figs. 21–24): height map, water depth over the surface, change of height
    since the start (erosion blue-white-red: lowered red, raised blue), each with its colour bar in
    metres; arrays in map order (row 0 = north). ``change_range`` fixes the change panel's scale at
    ±that (m; beyond it the colours saturate, the bar's ends say so), so that the frames of a run compare;
    by default the frame's own largest change. Returns the picture as an RGB array."""

    ny, nx = height.shape
    extent = [0, nx * cell_size, 0, ny * cell_size]
    fig, axes = plt.subplots(1, 3, figsize=(13.5, 4.4))
    shade = hillshade(height, cell_size)
    ax = axes[0]
    im = ax.imshow(height, cmap="gist_earth", extent=extent)
    ax.imshow(shade, cmap="gray", alpha=0.35, extent=extent)
    fig.colorbar(im, ax=ax, fraction=0.046, label="height (m)")
    ax.set_title("height map")
    ax = axes[1]
    ax.imshow(shade, cmap="gray", extent=extent, vmin=0, vmax=1)
    wet = np.ma.masked_less_equal(water, 0.0)
    im = ax.imshow(wet, cmap="Blues", extent=extent, vmin=0.0, vmax=max(float(water.max()), 1e-6))
    fig.colorbar(im, ax=ax, fraction=0.046, label="water depth (m)")
    ax.set_title("water over the surface")
    ax = axes[2]
    lim = change_range if change_range is not None else max(float(np.abs(change).max()), 1e-9)
    im = ax.imshow(change, cmap="RdBu", vmin=-lim, vmax=lim, extent=extent)
    ends = "neither" if change_range is None else "both"
    fig.colorbar(im, ax=ax, fraction=0.046, label="height change (m)", extend=ends)
    ax.set_title("difference from the initial terrain")
    for ax in axes:
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return _canvas_rgb(fig)


def profile_panel(x: np.ndarray, bed0: np.ndarray, bed: np.ndarray, water: np.ndarray, title: str = "") -> np.ndarray:
    """A 2-D flume: initial and current bed, the water column over it (m); returns an RGB array."""
    fig, ax = plt.subplots(figsize=(10, 3.6))
    ax.fill_between(x, bed, bed + water, color="tab:blue", alpha=0.5, lw=0, label="water")
    ax.plot(x, bed0, "k--", lw=1.0, label="initial bed")
    ax.plot(x, bed, color="saddlebrown", lw=1.6, label="bed")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("height (m)")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return _canvas_rgb(fig)


def probability_map(path, p: np.ndarray, extent: tuple, title: str, shade: np.ndarray | None = None) -> Path:
    """A probability map (0–1, NaN = no data) over an optional hillshade; ``extent`` = (x0, x1, y0, y1) in m."""
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    if shade is not None:
        ax.imshow(shade, cmap="gray", extent=extent, vmin=0, vmax=1, interpolation="nearest")
    shown = np.ma.masked_where(~np.isfinite(p) | (p <= 0), p)  # P = 0 shows the terrain beneath
    im = ax.imshow(shown, cmap="magma_r", vmin=0.0, vmax=1.0, alpha=0.8, extent=extent, interpolation="nearest")
    fig.colorbar(im, ax=ax, label="probability over the members")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    fig.tight_layout()
    return save_figure(fig, path)


def _nice_length(span: float) -> float:
    """A round length (1, 2 or 5 × 10ᵏ m) near a fifth of ``span``."""
    target = span / 5.0
    k = 10.0 ** np.floor(np.log10(target))
    return float(min((1.0, 2.0, 5.0, 10.0), key=lambda f: abs(f * k - target)) * k)


def scale_bar(ax, extent: tuple, km: bool, per_metre: float = 1.0) -> None:
    """A black-and-white bar of a round length in metres; ``per_metre`` map units per metre (1 for a
    projected map, about 1e-5 for degrees), so a geographic map's bar is still in metres."""
    x0, x1, y0, y1 = extent
    if per_metre != 1.0:
        metres = _nice_length((x1 - x0) / per_metre)
        length = metres * per_metre
        label = f"{metres / 1000:g} km" if metres >= 1000 else f"{metres:g} m"
    else:
        length = _nice_length(x1 - x0)
        label = f"{length:g} km" if km else (f"{length / 1000:g} km" if length >= 1000 else f"{length:g} m")
    px, py = x0 + 0.05 * (x1 - x0), y0 + 0.05 * (y1 - y0)
    height = 0.012 * (y1 - y0)
    ax.add_patch(plt.Rectangle((px, py), length, height, color="black", zorder=5))
    ax.add_patch(plt.Rectangle((px + length / 2, py), length / 2, height, color="white", ec="black", lw=0.5, zorder=6))
    ax.text(px + length / 2, py + 2.5 * height, label, ha="center", va="bottom", fontsize=9, zorder=6,
            bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "none", "alpha": 0.8})  # fmt: skip


def map_units(extent: tuple, nx: int, cell_size: float) -> tuple[float, bool]:
    """(map units per metre, geographic?) of a map ``nx`` cells of ``cell_size`` m wide over ``extent``:
    a DEM in degrees spans about 1e-5 units per metre; its axes are then longitude and latitude."""
    per_metre = (extent[1] - extent[0]) / (nx * cell_size)
    geographic = not 0.5 < per_metre < 2.0
    return (per_metre if geographic else 1.0), geographic


def axis_labels(ax, geographic: bool, km: bool) -> None:
    if geographic:
        ax.set_xlabel("longitude (°)")
        ax.set_ylabel("latitude (°)")
    else:
        unit = "km" if km else "m"
        ax.set_xlabel(f"x ({unit})")
        ax.set_ylabel(f"y ({unit})")


def extent_of(transform: tuple | None, shape: tuple[int, int], cell_size: float) -> tuple:
    """(x0, x1, y0, y1) of a map: from its affine transform (a, b, c, d, e, f), or 0 at the south-west corner."""
    ny, nx = shape
    if transform is None:
        return (0.0, nx * cell_size, 0.0, ny * cell_size)
    a, _, c, _, e, f = transform[:6]
    xs, ys = sorted((c, c + a * nx)), sorted((f, f + e * ny))
    return (xs[0], xs[1], ys[0], ys[1])


def map_figure(
    path,
    picture: np.ndarray,
    cell_size: float,
    title: str,
    *,
    legend: list[tuple[str, np.ndarray]] | None = None,
    colorbar: dict | None = None,
    extent: tuple | None = None,
) -> Path:
    """A map picture (RGB, or one band with ``colorbar`` = {cmap, vmin, vmax, label}) with axes in
    metres (km for maps over 5 km), a scale bar, and a ``legend`` of (label, colour) swatches.
    ``extent`` = (x0, x1, y0, y1) in the DEM's coordinates (default: 0 at the south-west corner)."""
    from matplotlib.patches import Patch

    ny, nx = picture.shape[:2]
    x0, x1, y0, y1 = extent or extent_of(None, (ny, nx), cell_size)
    per_metre, geographic = map_units((x0, x1, y0, y1), nx, cell_size)
    km = (x1 - x0) > 5000.0 and not geographic
    f = 1e-3 if km else 1.0
    fig, ax = plt.subplots(figsize=(7.2, 6.4 * ny / nx + 0.6 if nx >= ny else 7.2))
    shown = (x0 * f, x1 * f, y0 * f, y1 * f)
    if picture.ndim == 2:  # one band through the colour bar's map
        im = ax.imshow(picture, extent=shown, cmap=colorbar["cmap"], vmin=colorbar.get("vmin"),
                       vmax=colorbar.get("vmax"), interpolation="antialiased")  # fmt: skip
        fig.colorbar(im, ax=ax, label=colorbar["label"], shrink=0.85)
    else:
        ax.imshow(picture, extent=shown, interpolation="antialiased")
        if colorbar is not None:  # a picture tinted by a colour map (shaded): its scale
            norm = matplotlib.colors.Normalize(colorbar.get("vmin", 0.0), colorbar.get("vmax", 1.0))
            sm = matplotlib.cm.ScalarMappable(norm=norm, cmap=colorbar["cmap"])
            fig.colorbar(sm, ax=ax, label=colorbar["label"], shrink=0.85)
    scale_bar(ax, shown, km, per_metre)
    if legend:
        handles = [Patch(facecolor=tuple(np.clip(c, 0, 1)), edgecolor="black", lw=0.5, label=t) for t, c in legend]
        ax.legend(handles=handles, loc="upper right", fontsize=9, framealpha=0.85)
    axis_labels(ax, geographic, km)
    ax.set_title(title)
    fig.tight_layout()
    return save_figure(fig, path)


def hillshade_figure(path, z: np.ndarray, cell_size: float, title: str, extent: tuple | None = None) -> Path:
    """The terrain's hillshade (sun from the north-west, 45°) with axes and a scale bar."""

    shade = hillshade(np.asarray(z, dtype=np.float64), cell_size)
    return map_figure(path, np.repeat(shade[..., None], 3, axis=2), cell_size, title, extent=extent)


def change_figure(path, change: np.ndarray, cell_size: float, title: str, extent: tuple | None = None) -> Path:
    """Deposition (+, blue) and erosion (−, red) in metres on a diverging scale centred on zero (the
    99th percentile of |change| at its ends, so a few deep cuts do not wash the rest out)."""
    finite = np.abs(change[np.isfinite(change)])
    top = float(np.percentile(finite, 99)) if finite.size and finite.max() > 0 else 1.0
    bar = {"cmap": "RdBu", "vmin": -top, "vmax": top, "label": "deposition (+) / erosion (−) (m)"}
    return map_figure(path, np.asarray(change, dtype=np.float64), cell_size, title, colorbar=bar, extent=extent)


def voxel_section(path, field: np.ndarray, extent, iso: float, *, labels=("x (m)", "z (m)"), title: str = "",
                  reference: np.ndarray | None = None, value_range=(0.0, 1.0), where: str = "") -> Path:  # fmt: skip
    """A cross-section of a voxel density field: ``field`` (rows along the vertical axis, from ``extent``'s
    v0 to v1) shaded from air to solid with its colour bar, its iso-line solid, ``reference``'s (an earlier
    field) dashed, both in the legend; ``where`` (e.g. "y = 0.06 m") names the plane of the cut."""
    from matplotlib.lines import Line2D

    h0, h1, v0, v1 = (float(e) for e in extent)
    fig, ax = plt.subplots(figsize=(8.8, max(2.8, 8.0 * (v1 - v0) / max(h1 - h0, 1e-12) + 1.3)))
    im = ax.imshow(field, origin="lower", extent=(h0, h1, v0, v1), cmap="copper_r", vmin=value_range[0],
                   vmax=value_range[1], interpolation="bilinear", aspect="equal")  # fmt: skip
    fig.colorbar(im, ax=ax, shrink=0.8, pad=0.02, label=f"density (air {value_range[0]:g} … solid {value_range[1]:g})")
    hs = np.linspace(h0, h1, field.shape[1])
    vs = np.linspace(v0, v1, field.shape[0])
    handles = []
    if field.min() < iso < field.max():
        ax.contour(hs, vs, field, levels=[iso], colors="k", linewidths=1.2)
        handles.append(Line2D([], [], color="k", lw=1.2, label=f"surface now (density {iso:g})"))
    if reference is not None and reference.min() < iso < reference.max():
        ax.contour(hs, vs, reference, levels=[iso], colors="tab:blue", linewidths=1.0, linestyles="--")
        handles.append(Line2D([], [], color="tab:blue", lw=1.0, ls="--", label="surface at the start"))
    if handles:
        ax.legend(handles=handles, fontsize=8, loc="upper right")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    head = title or "voxel terrain section"
    ax.set_title(f"{head} — section at {where}" if where else head, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


LEGEND_CURVES = 8  # profiles_figure: more lines than this get a colour bar of time, not a legend


def profiles_figure(path, curves: list[tuple[float, np.ndarray, np.ndarray]], title: str = "",
                    xlabel: str = "x from the upstream toe (m)") -> Path:  # fmt: skip
    """Surface profiles along a flume or a terrain's middle row: ``curves`` of (t, x, z), one line per time,
    coloured by time (viridis: dark for early, yellow for late); up to ``LEGEND_CURVES`` lines get a legend,
    more a colour bar of t (a legend of 30 times took the figure over); ``xlabel`` says where x is measured
    from."""
    fig, ax = plt.subplots(figsize=(9, 3.6))
    cmap = plt.get_cmap("viridis")
    t0, t1 = curves[0][0], curves[-1][0]
    span = t1 - t0 if t1 > t0 else 1.0
    for i, (t, x, z) in enumerate(curves):
        ax.plot(x, z, color=cmap((t - t0) / span), lw=1.8 if i in (0, len(curves) - 1) else 1.2, label=f"t = {t:.4g} s")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("surface height z (m)")
    ax.grid(alpha=0.3)
    if len(curves) <= LEGEND_CURVES:
        ax.legend(fontsize=8, loc="upper right")
    else:
        bar = plt.cm.ScalarMappable(norm=matplotlib.colors.Normalize(t0, t0 + span), cmap=cmap)
        fig.colorbar(bar, ax=ax, pad=0.01, label="t (s)")
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return save_figure(fig, path)
