"""A triangle surface (a voxel terrain's marching-cubes mesh) drawn as a flat-shaded 3-D picture (PNG).

Each triangle gets a Lambert shade from its unit normal n and a light L = (sin A·cos h, cos A·cos h,
sin h) for azimuth A (clockwise from north, +y) and altitude h, the same light as
:func:`erosim.viz.maps.hillshade`:

    colour = tint(z̄) · (ambient + (1 − ambient) · max(0, n·L)),

tint a colour map of the triangle's mean height z̄ over the heights shown, or of a value per
triangle (``face_values``, e.g. the surface's lowering) with a colour bar. Points (water particles)
are drawn as dots after the surface (so nearer ground never hides them). matplotlib's ``mplot3d``
(Agg) draws the triangles in painter's order, which is right for a terrain seen from above; the
picture is ``size`` inches at 110 dpi.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from erosim.viz.plots import plt, save_figure


def lambert(normals: np.ndarray, azimuth: float = 315.0, altitude: float = 45.0, ambient: float = 0.35) -> np.ndarray:
    """ambient + (1 − ambient)·max(0, n·L) for unit ``normals`` (N, 3), the light from ``azimuth``/``altitude``
    (degrees); the triangles' brightness in [ambient, 1]."""
    a, h = np.radians(azimuth), np.radians(altitude)
    light = np.array([np.sin(a) * np.cos(h), np.cos(a) * np.cos(h), np.sin(h)])
    return ambient + (1.0 - ambient) * np.clip(np.asarray(normals, np.float64) @ light, 0.0, 1.0)


def surface_panels(path: str | os.PathLike, panels: list[dict], *, elev: float = 38.0, azim: float = -60.0,
                   size: tuple[float, float] | None = None, zlim: tuple[float, float] | None = None,
                   cmap: str = "gist_earth", title: str = "") -> Path:  # fmt: skip
    """Side by side, one 3-D view per panel: ``panels`` of dicts with ``vertices`` (V, 3), ``faces`` (F, 3)
    (e.g. a ``trimesh.Trimesh``'s), optional ``points`` (P, 3) drawn as blue dots, ``title``, and
    optional ``face_values`` (F,) coloured by ``value_cmap`` over ``value_range`` with ``value_label``
    on a colour bar (instead of the height tint). The
    same view (``elev``, ``azim``, degrees), axes and colour scale in every panel, so they compare;
    ``zlim`` (m) the heights shown (default: all panels' range)."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    if not panels:
        raise ValueError("surface_panels needs at least one panel.")
    verts = [np.asarray(p["vertices"], np.float64) for p in panels]
    lo = np.min([v.min(axis=0) for v in verts], axis=0)
    hi = np.max([v.max(axis=0) for v in verts], axis=0)
    z0, z1 = zlim if zlim is not None else (lo[2], hi[2])
    n = len(panels)
    fig = plt.figure(figsize=size or (5.0 * n, 4.6))
    colours = plt.get_cmap(cmap)
    for k, (p, v) in enumerate(zip(panels, verts, strict=True)):
        ax = fig.add_subplot(1, n, k + 1, projection="3d")
        ax.computed_zorder = False  # draw in the order added: the surface, then the points over it
        tri = v[np.asarray(p["faces"], np.int64)]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
        zbar = tri[:, :, 2].mean(axis=1)
        values = p.get("face_values")
        if values is None:
            tint = colours(0.25 + 0.7 * np.clip((zbar - z0) / max(z1 - z0, 1e-12), 0.0, 1.0))[:, :3]
        else:
            v0, v1 = p.get("value_range", (float(np.min(values)), float(np.max(values))))
            norm = plt.Normalize(v0, v1)
            vmap = plt.get_cmap(p.get("value_cmap", "viridis"))
            tint = vmap(norm(np.asarray(values, np.float64)))[:, :3]
        rgb = tint * lambert(normal)[:, None]
        ax.add_collection3d(Poly3DCollection(tri, facecolors=rgb, edgecolors="none", linewidths=0.0, zorder=1))
        pts = p.get("points")
        if pts is not None and len(pts):
            pts = np.asarray(pts, np.float64)
            ax.scatter(pts[:, 0], pts[:, 1], pts[:, 2], s=4, c="tab:blue", depthshade=False, alpha=0.8, linewidths=0,
                       zorder=2)  # fmt: skip
        if values is not None:
            bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=vmap), ax=ax, shrink=0.5, pad=0.14)
            bar.set_label(p.get("value_label", ""), fontsize=8)
            bar.ax.tick_params(labelsize=7)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(z0, z1)
        ax.set_box_aspect((hi[0] - lo[0], hi[1] - lo[1], max(z1 - z0, 1e-6)))
        ax.view_init(elev=elev, azim=azim)
        ax.set_xlabel("x (m)", fontsize=8)
        ax.set_ylabel("y (m)", fontsize=8)
        ax.set_zlabel("z (m)", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_title(p.get("title", ""), fontsize=10)
    if title:
        fig.suptitle(title, fontsize=11)
    fig.subplots_adjust(left=0.0, right=0.97, bottom=0.02, top=0.92, wspace=0.02)
    return save_figure(fig, path)
