"""Figures of a dam-break flood (SPEC FL-4, thesis figs. 17–19): the maximum depth, speed and depth ×
speed over the terrain, and the hazard classes H1–H6 with their areas.

Maps follow the conventions of :func:`erosim.viz.plots.map_figure`: axes in the DEM's own coordinates
(km when the map is wider than 5 km), a scale bar, colour bars with units, the terrain's hillshade
(sun from the north-west, 45°) beneath the water; dry cells show the terrain, nodata cells are white.
Colour scales of the three maxima end at the 99th percentile of the wet cells' values (the colour bar
says so with a pointed end when larger values exist), so a few fast cells at the breach do not wash
out the valley.

Hazard classes (FL-3; AIDR 2017 guideline 7-3, NSW FB03 2022) are drawn in six colours from green
(H1, generally safe) through yellow and orange to red and purple (H6), in :data:`HAZARD_LEGEND` with
each class's meaning. matplotlib (Agg); files are written atomically.
"""

from __future__ import annotations

import os
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from erosim.core.heightmap import Heightmap  # noqa: E402
from erosim.viz.maps import hillshade
from erosim.viz.plots import axis_labels, extent_of, map_units, save_figure, scale_bar  # noqa: E402

#: (class, colour, meaning) of FL-3, H1 … H6 (the meanings are erosim.analysis.hazard.HAZARD_MEANING's)
HAZARD_LEGEND: tuple[tuple[str, str, str], ...] = (
    ("H1", "#1a9850", "generally safe for vehicles, people and buildings"),
    ("H2", "#a6d96a", "unsafe for small vehicles"),
    ("H3", "#fee08b", "unsafe for vehicles, children and the elderly"),
    ("H4", "#fdae61", "unsafe for vehicles and people"),
    ("H5", "#d73027", "unsafe for vehicles and people; all buildings vulnerable to structural damage"),
    ("H6", "#762a83", "unsafe for vehicles and people; all buildings vulnerable to failure"),
)


def _frame(hm: Heightmap) -> tuple[tuple, tuple, np.ndarray]:
    """(extent shown, (km?, geographic?, map units per metre), hillshade RGBA with nodata white) of the DEM."""

    x0, x1, y0, y1 = extent_of(hm.transform, hm.shape, hm.cell_size)
    per_metre, geographic = map_units((x0, x1, y0, y1), hm.shape[1], hm.cell_size)
    km = (x1 - x0) > 5000.0 and not geographic
    f = 1e-3 if km else 1.0
    shade = 0.35 + 0.65 * hillshade(hm.z, hm.cell_size)
    rgba = np.dstack([shade, shade, shade, np.ones_like(shade)])
    if hm.nodata is not None:
        rgba[hm.nodata] = 1.0
    return (x0 * f, x1 * f, y0 * f, y1 * f), (km, geographic, per_metre), rgba


def _axes_labels(ax, shown: tuple, units: tuple, title: str) -> None:
    from matplotlib.ticker import MaxNLocator

    km, geographic, per_metre = units
    scale_bar(ax, shown, km, per_metre)
    ax.ticklabel_format(useOffset=False, style="plain")  # whole map coordinates, not an offset
    ax.xaxis.set_major_locator(MaxNLocator(4))
    ax.yaxis.set_major_locator(MaxNLocator(5))
    axis_labels(ax, geographic, km)
    ax.set_title(title)


def plot_flood_maps(out_png: str | os.PathLike, hm: Heightmap, hazard_maps, title: str = "") -> Path:
    """Three panels over the hillshade: maximum depth D (m), maximum speed V (m/s) and maximum D·V
    (m²/s) of ``hazard_maps`` (an :class:`erosim.analysis.hazard.HazardMaps` or any object with the
    arrays ``max_depth``, ``max_speed``, ``max_dv`` on the DEM's grid); never-wet cells show the terrain."""
    from matplotlib.ticker import MaxNLocator

    shown, units, base = _frame(hm)
    wet = np.asarray(hazard_maps.max_depth) > 0
    if hm.nodata is not None:
        wet &= ~hm.nodata
    panels = [
        (hazard_maps.max_depth, "Blues", "maximum depth D (m)", "Maximum water depth"),
        (hazard_maps.max_speed, "viridis", "maximum speed V (m/s)", "Maximum speed"),
        (hazard_maps.max_dv, "magma_r", "maximum D·V (m²/s)", "Maximum depth × speed"),
    ]
    ny, nx = hm.shape
    fig, axes = plt.subplots(1, 3, figsize=(17.0, 1.2 + 4.6 * min(1.5, max(0.5, ny / nx))))
    for ax, (values, cmap, label, name) in zip(axes, panels, strict=True):
        v = np.asarray(values, dtype=np.float64)
        ax.imshow(base, extent=shown, interpolation="nearest")
        top = float(np.percentile(v[wet], 99)) if wet.any() else 1.0
        top = top if top > 0 else (float(v[wet].max()) if wet.any() and v[wet].max() > 0 else 1.0)
        shown_v = np.ma.masked_where(~wet, v)
        im = ax.imshow(shown_v, extent=shown, cmap=cmap, vmin=0.0, vmax=top, alpha=0.9, interpolation="nearest")
        more = wet.any() and float(v[wet].max()) > top
        fig.colorbar(im, ax=ax, label=label, shrink=0.8, pad=0.07, extend="max" if more else "neither")
        _axes_labels(ax, shown, units, name)
        ax.xaxis.set_major_locator(MaxNLocator(3))  # three panels side by side: room for long coordinates
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, out_png)


def plot_hazard(out_png: str | os.PathLike, hm: Heightmap, classes: np.ndarray, summary: dict, title: str = "") -> Path:
    """The hazard class of every cell (0 dry: the terrain shows; 1–6 in the six colours of
    :data:`HAZARD_LEGEND`) with the legend and a table of each class's area (m²) and share of the
    flooded area; ``summary`` is :meth:`erosim.analysis.hazard.HazardMaps.summary`'s dict."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    shown, units, base = _frame(hm)
    c = np.asarray(classes)
    cmap = ListedColormap([colour for _, colour, _ in HAZARD_LEGEND])
    ny, nx = hm.shape
    map_h = 6.0 * min(1.6, max(0.6, ny / nx))
    fig = plt.figure(figsize=(13.0, max(5.8, map_h + 0.8)))
    grid = fig.add_gridspec(1, 2, width_ratios=[1.25, 1.0])
    ax = fig.add_subplot(grid[0])
    ax.imshow(base, extent=shown, interpolation="nearest")
    ax.imshow(np.ma.masked_where(c == 0, c), extent=shown, cmap=cmap, vmin=0.5, vmax=6.5, alpha=0.9,
              interpolation="nearest")  # fmt: skip
    _axes_labels(ax, shown, units, title or "Flood hazard (AIDR 2017 / FB03)")
    side = fig.add_subplot(grid[1])
    side.axis("off")
    handles = [
        Patch(facecolor=colour, edgecolor="black", lw=0.5, label=f"{name}  " + textwrap.fill(meaning, 46).replace(
            "\n", "\n        "))
        for name, colour, meaning in HAZARD_LEGEND
    ]  # fmt: skip
    side.legend(handles=handles, loc="upper left", fontsize=9, frameon=False, title="hazard class",
                title_fontsize=10, alignment="left", borderaxespad=0.0)  # fmt: skip
    areas, shares = summary["hazard_area_m2"], summary["hazard_share"]
    rows = [[name, f"{areas[name]:,.0f}", f"{100.0 * shares[name]:.1f} %"] for name, _, _ in HAZARD_LEGEND]
    rows.append(["flooded", f"{summary['flooded_area_m2']:,.0f}", "100 %" if summary["flooded_area_m2"] else "–"])
    table = side.table(cellText=rows, colLabels=["class", "area (m²)", "share"], loc="lower left",
                       colLoc="right", cellLoc="right", bbox=[0.0, 0.1, 0.9, 0.42])  # fmt: skip
    table.auto_set_font_size(False)
    table.set_fontsize(9)
    for k, (_, colour, _) in enumerate(HAZARD_LEGEND, start=1):
        table[k, 0].set_facecolor(colour)
    for j in range(3):
        table[0, j].set_text_props(fontweight="bold")
    fig.tight_layout()
    return save_figure(fig, out_png)
