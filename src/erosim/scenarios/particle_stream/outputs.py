"""What a `particle-stream` run writes: the maps, the canyon figure (plan view, strata, the long profile
along the stream) and the report's canyon measures.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from erosim.core.atomic import atomic_path
from erosim.core.callbacks import Callback
from erosim.core.heightmap import Heightmap
from erosim.core.schedules import Schedule
from erosim.erosion.particle_stream_warszawski import EDIR, EX, EY, ParticleStream
from erosim.io import heightmaps as hio
from erosim.terrain.hardness import Strata, strata_at
from erosim.viz.maps import colormap, hillshade
from erosim.viz.plots import extent_of, hillshade_figure, map_figure, scale_bar


def _strata_picture(z: np.ndarray, d: np.ndarray, cell_size: float) -> np.ndarray:

    tint = colormap(d, "copper_r", vmin=0.0, vmax=1.0)
    shade = 0.25 + 0.75 * hillshade(z, cell_size)
    return np.clip(tint * shade[..., None], 0.0, 1.0)


def long_profile(h0: np.ndarray, h: np.ndarray, x0: float, y0: float, heading: float):
    """The canyon's floor along the stream: distance (cells) along ``heading`` (grid radians) from
    the emitter at (x0, y0) (column, row), and for each cell-long bin of the cut cells the lowest
    height after and the height there before (NaN where nothing was cut)."""
    erosion = h0 - h
    cut = erosion > 0.02 * max(float(erosion.max()), 1e-12)
    jj, ii = np.nonzero(cut)
    if ii.size == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    along = np.rint((ii - x0) * np.cos(heading) + (jj - y0) * np.sin(heading)).astype(int)
    lo = along.min()
    n = along.max() - lo + 1
    k = along - lo
    order = np.lexsort((h[jj, ii], k))  # by bin, lowest first
    bins, first = np.unique(k[order], return_index=True)
    lowest = order[first]
    after = np.full(n, np.nan)
    before = np.full(n, np.nan)
    after[bins], before[bins] = h[jj[lowest], ii[lowest]], h0[jj[lowest], ii[lowest]]
    return np.arange(lo, lo + n, dtype=float), after, before


def canyon_figure(
    path, h0: np.ndarray, h: np.ndarray, d: np.ndarray, cell: float, spec: Strata | None, emitter: tuple | None = None
) -> None:
    """Map (relief tinted by hardness, axes in metres, scale bar), a north–south cross-section
    through the deepest cut in the middle of the map (30–70 % of its width), and the canyon's long
    profile along the first emitter's heading (``emitter`` = (column, row, heading in grid radians)).

    The section's rock is coloured by its hardness — the strata themselves when they are known
    (``spec``), else the surface hardness of each cell — under the final surface; the dashed line is
    the surface before erosion, so the white space between the two is the carved canyon.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure


    erosion = h0 - h
    ny, nx = h.shape
    lo, hi = int(0.3 * nx), max(int(0.7 * nx), int(0.3 * nx) + 1)  # away from the emitter's head
    deepest = erosion[:, lo:hi].max(axis=0)
    col = lo + int(np.argmax(deepest)) if deepest.max() > 0 else nx // 2
    centre = int(np.argmax(erosion[:, col])) if erosion[:, col].max() > 0 else ny // 2
    cut = np.nonzero(erosion[:, col] > 0.02 * max(erosion[:, col].max(), 1e-12))[0]
    half = max(15, int(1.2 * (cut.max() - cut.min() + 1)) if cut.size else 15)
    r0, r1 = max(0, centre - half), min(ny, centre + half + 1)
    rows = np.arange(r0, r1)
    top, bottom = float(h0[rows, col].max()), float(h[rows, col].min())
    pad = 0.15 * max(top - bottom, 1.0)
    zs = np.linspace(top + pad, bottom - pad, 400)[:, None]
    if spec is not None:

        rock = strata_at(zs, float(col), rows[None, :].astype(float), cell, spec)
    else:
        rock = np.broadcast_to(d[rows, col][None, :], (zs.size, rows.size)).copy()
    rock = np.where(zs <= h[rows, col][None, :], rock, np.nan)
    dist = (rows - r0) * cell

    fig = Figure(figsize=(15, 4.6), dpi=100)
    FigureCanvasAgg(fig)
    ax0 = fig.add_axes([0.045, 0.12, 0.25, 0.78])
    ax1 = fig.add_axes([0.36, 0.12, 0.28, 0.78])
    ax2 = fig.add_axes([0.73, 0.12, 0.26, 0.78])
    km = nx * cell > 5000.0
    f = 1e-3 if km else 1.0
    unit = "km" if km else "m"
    extent = (0.0, nx * cell * f, 0.0, ny * cell * f)  # x east from the west edge, y north from the south edge

    def to_y(r):
        return (ny - 0.5 - r) * cell * f

    ax0.imshow(_strata_picture(h, d, cell), interpolation="nearest", extent=extent)
    ax0.plot([(col + 0.5) * cell * f] * 2, [to_y(r0), to_y(r1 - 1)], color="cyan", lw=1.5)
    if emitter is not None:
        ax0.plot((emitter[0] + 0.5) * cell * f, to_y(emitter[1]), "o", mec="white", mfc="none", ms=8, mew=1.5)
    scale_bar(ax0, extent, km)
    ax0.set_xlabel(f"x ({unit})")
    ax0.set_ylabel(f"y ({unit})")
    ax0.set_title("after: relief tinted by hardness (o: emitter)", fontsize=10)
    im = ax1.imshow(
        rock,
        extent=[dist[0], dist[-1], zs[-1, 0], zs[0, 0]],
        aspect="auto",
        cmap="copper_r",
        vmin=0.0,
        vmax=1.0,
        interpolation="nearest",
    )
    ax1.plot(dist, h0[rows, col], "k--", lw=1.0, label="before")
    ax1.plot(dist, h[rows, col], "k-", lw=1.2, label="after")
    ax1.set_xlabel("distance along the section, north → south (m)")
    ax1.set_ylabel("height (m)")
    ax1.set_title(f"cross-section at x = {col * cell:.0f} m (cyan line)", fontsize=10)
    ax1.legend(loc="lower left", fontsize=8)
    fig.colorbar(im, ax=ax1, label="hardness (1 = unerodible)", fraction=0.05, pad=0.02)
    if emitter is not None:
        along, after, before = long_profile(h0, h, emitter[0], emitter[1], emitter[2])
        ax2.plot(along * cell, before, "k--", lw=1.0, label="ground before, where the floor is")
        ax2.plot(along * cell, after, "-", color="tab:blue", lw=1.4, label="canyon floor after")
        ax2.legend(loc="best", fontsize=8)
    ax2.set_xlabel("distance downstream from the emitter (m)")
    ax2.set_ylabel("height (m)")
    ax2.set_title("long profile along the stream", fontsize=10)
    ax2.grid(alpha=0.3)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")


def write_outputs(out, hm: Heightmap, d0: np.ndarray, stream: ParticleStream) -> dict[str, Any]:
    """Maps and figures of a finished (or interrupted) stream; returns what the report needs."""

    maps, figs = out.maps, out.figures
    final = hm.copy(stream.h)
    erosion = hm.z - stream.h
    hio.write(maps / "height_initial.tif", hm)
    hio.write(maps / "height.tif", final)
    png = hio.write(maps / "height.png", final)
    raw = hio.write(maps / "height.r16", final)
    hio.write(maps / "hardness_initial.tif", d0, like=hm)
    hio.write(maps / "hardness.tif", stream.d, like=hm)
    hio.write(maps / "erosion.tif", erosion, like=hm)
    mask = hio.write_mask_png16(maps / "erosion_mask.png", erosion)
    cs, box = hm.cell_size, extent_of(hm.transform, hm.shape, hm.cell_size)
    hard = {"cmap": "copper_r", "vmin": 0.0, "vmax": 1.0, "label": "hardness (0 soft … 1 unerodible)"}
    depth = {"cmap": "magma", "vmin": 0.0, "vmax": max(float(erosion.max()), 1e-9), "label": "erosion depth (m)"}
    first = stream.table[0]
    draw = {
        "hillshade_before.png": lambda p: hillshade_figure(p, hm.z, cs, "Terrain before", box),
        "hillshade_after.png": lambda p: hillshade_figure(p, stream.h, cs, "Terrain after", box),
        "strata_after.png": lambda p: map_figure(p, _strata_picture(stream.h, stream.d, cs), cs,
                                                 "Rock at the surface after", colorbar=hard, extent=box),
        "erosion.png": lambda p: map_figure(p, erosion, cs, "Erosion", colorbar=depth, extent=box),
        "canyon.png": lambda p: canyon_figure(p, hm.z, stream.h, stream.d, cs, stream.strata,
                                              (first[EX], first[EY], first[EDIR])),
    }  # fmt: skip
    for name, picture in draw.items():
        with out.picture(figs / name):
            picture(figs / name)
    return {
        "height_png_range": png.get("height_range"),
        "height_raw_range": raw.get("height_range"),
        "height_raw_shape": list(hm.shape),
        "erosion_mask_vmax": mask["vmax"],
    }


class StreamOutputs(Callback):
    """Lets the last particles act, then writes the maps and figures of a completed run."""

    def __init__(self, hm: Heightmap, d0: np.ndarray, stream: ParticleStream):
        super().__init__(Schedule(), name="outputs")
        self.hm, self.d0, self.stream = hm, d0, stream

    def finalize(self, sim) -> dict[str, Any]:
        # the loop stops when every particle was emitted *and* has acted; one more sweep marks it done
        while not self.stream.done:
            self.stream.advance()
        return write_outputs(sim.out, self.hm, self.d0, self.stream)
