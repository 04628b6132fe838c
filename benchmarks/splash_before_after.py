"""Before/after pictures of the splash scenes (issue 36, seed 003): the water-jet's wet patch and crater,
and splash-drop's crater section and wetness, from two run folders each (the earlier code's and this one's).

    erosim run water-jet --out BEFORE_JET        # in a worktree of the earlier code
    erosim run water-jet --out AFTER_JET
    erosim run splash-drop --out BEFORE_DROP     # earlier code (10 ms)
    erosim run splash-drop --out AFTER_DROP
    python benchmarks/splash_before_after.py BEFORE_JET AFTER_JET BEFORE_DROP AFTER_DROP docs/images/before_after

Reads each run's checkpoint (ground saturation on the ground lattice, terrain) and report.json, and prints
the figures docs/splash.md quotes: the wet front's radius over 16 directions (θ = 0.05, from the centre of
wetness) and its spread (max − min)/mean, the crater's edge (10 % of its depth, from the strikes' centre),
the highest deposit (rim or settled mud), the largest surface saturation and water depth.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import TwoSlopeNorm  # noqa: E402


def load(run: Path):
    d = np.load(run / "checkpoint" / "state.npz", allow_pickle=True)
    rep = json.loads((run / "report.json").read_text())
    s, cell = rep["resolution"]["ground_spacing_m"], rep["terrain"]["cell_size_m"]
    z = d["callback.wet_ground.terrain"]
    ny, nx = z.shape
    ncx, ncy = int(np.floor((nx - 1) * cell / s + 1e-9)), int(np.floor((ny - 1) * cell / s + 1e-9))
    theta = d["callback.wet_ground.ground_theta"][: ncx * ncy].reshape(ncy, ncx)
    return theta, z, s, cell, rep


BEARINGS = np.radians(np.arange(0.0, 360.0, 22.5))


def radii(field, ic, jc, inside, reach):
    """Per bearing, the outermost distance (grid units) along the ray where ``inside`` holds."""
    from scipy.ndimage import map_coordinates

    steps = np.linspace(0.0, reach, 2001)
    out = []
    for a in BEARINGS:
        v = map_coordinates(field, [jc + steps * np.sin(a), ic + steps * np.cos(a)], order=1)
        hit = np.flatnonzero(inside(v))
        out.append(steps[hit.max()] if len(hit) else 0.0)
    return np.array(out)


def measure(run: Path) -> dict:
    theta, z, s, cell, rep = load(run)
    d = np.load(run / "checkpoint" / "state.npz")
    jj, ii = np.indices(theta.shape)
    w = theta / theta.sum()
    wet = radii(theta, (w * ii).sum(), (w * jj).sum(), lambda v: v >= 0.05, min(theta.shape) / 2 - 1) * s
    imp = d["callback.wet_ground.eroder_impacts"]
    depth = float(-z.min())
    edge = radii(z, imp[:, 1].mean() / cell, imp[:, 2].mean() / cell, lambda v: v < -0.1 * depth,
                 min(0.12 / cell, min(z.shape) / 2 - 1)) * cell  # fmt: skip
    spread = lambda r: float((r.max() - r.min()) / r.mean()) if r.mean() > 0 else float("nan")  # noqa: E731
    maps = rep["outputs"]["maps"]
    return {"wet_front_m": float(wet.mean()), "wet_front_spread": spread(wet), "crater_depth_m": depth,
            "crater_edge_m": float(edge.mean()), "crater_edge_spread": spread(edge),
            "deposit_max_m": maps["deposition"]["max"], "wetness_max": rep["surface_wetness"]["max"],
            "water_depth_max_m": maps["water_depth"]["max"]}  # fmt: skip


def scalebar(ax, length, label):
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    xs = x0 + 0.05 * (x1 - x0)
    ys = y0 + 0.06 * (y1 - y0)
    ax.plot([xs, xs + length], [ys, ys], color="k", lw=3)
    ax.text(xs + length / 2, ys + 0.02 * (y1 - y0), label, ha="center", fontsize=8)


def jet(before: Path, after: Path, out: Path):
    fig, axes = plt.subplots(2, 2, figsize=(11, 10))
    for row, (run, tag) in enumerate(((before, "before"), (after, "after"))):
        theta, z, s, cell, rep = load(run)
        ax = axes[row, 0]
        im = ax.imshow(theta, origin="lower", cmap="YlGnBu", vmin=0, vmax=1,
                       extent=[0, theta.shape[1] * s, 0, theta.shape[0] * s])  # fmt: skip
        ax.set_title(f"water-jet {tag}: surface saturation θ at {rep['t']:.2f} s\n(ground particles of {s * 100:g} cm)",
                     fontsize=10)  # fmt: skip
        fig.colorbar(im, ax=ax, shrink=0.8, label="surface saturation θ (1)")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        scalebar(ax, 0.2, "0.2 m")
        ax = axes[row, 1]
        c = (z - 0.0) * 1e3
        ny, nx = z.shape
        zoom = 0.15
        j, i = np.unravel_index(int(np.argmin(c)), c.shape)
        norm = TwoSlopeNorm(vmin=-12.0, vcenter=0.0, vmax=0.5)  # the crater's depth and the rim's height
        im = ax.imshow(c, origin="lower", cmap="BrBG", norm=norm,
                       extent=[-cell / 2, (nx - 0.5) * cell, -cell / 2, (ny - 0.5) * cell])  # fmt: skip
        ax.set_xlim(i * cell - zoom, i * cell + zoom)
        ax.set_ylim(j * cell - zoom, j * cell + zoom)
        ax.set_title(f"water-jet {tag}: height change at {rep['t']:.2f} s\n"
                     f"(cells of {cell * 100:g} cm; colours −12 mm … 0 … +0.5 mm)", fontsize=10)  # fmt: skip
        fig.colorbar(im, ax=ax, shrink=0.8, label="height change (mm): crater < 0 < rim",
                     ticks=[-12, -8, -4, 0, 0.25, 0.5])
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        scalebar(ax, 0.05, "5 cm")
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)


def drop(before: Path, after: Path, out: Path):
    fig, axes = plt.subplots(2, 2, figsize=(11, 8))
    for row, (run, tag) in enumerate(((before, "before"), (after, "after"))):
        theta, z, s, cell, rep = load(run)
        ax = axes[row, 0]
        j, i = np.unravel_index(int(np.argmin(z)), z.shape)
        x = (np.arange(z.shape[1]) - i) * cell * 1e3
        ax.fill_between(x, z[j] * 1e3, -2, color="#a0522d", alpha=0.6)
        ax.plot(x, z[j] * 1e3, color="#6b3a1e", label="after the strike")
        ax.axhline(0, color="0.5", lw=0.8, label="ground before")
        ax.set_ylim(-1.2, 0.5)
        ax.set_xlabel("distance from the crater's centre (mm)")
        ax.set_ylabel("height (mm, ×4 vertical exaggeration)")
        ax.set_aspect(4.0)
        rim = rep["outputs"]["maps"]["deposition"]["max"] * 1e3
        ax.set_title(f"splash-drop {tag}: crater section (R = 2 mm at 4 m/s, dry)\n"
                     f"depth {rep['crater_depth_m'] * 1e3:.2f} mm, rim {rim:.3f} mm", fontsize=10)  # fmt: skip
        ax.legend(fontsize=8, loc="lower right")
        ax = axes[row, 1]
        im = ax.imshow(theta, origin="lower", cmap="YlGnBu", vmin=0, vmax=0.12,
                       extent=[0, theta.shape[1] * s * 1e3, 0, theta.shape[0] * s * 1e3])  # fmt: skip
        wmax = rep["surface_wetness"]["max"]
        ax.set_title(f"splash-drop {tag}: surface saturation at {rep['t'] * 1e3:.0f} ms (max {wmax:.2g})\n"
                     f"water depth map max {rep['outputs']['maps']['water_depth']['max'] * 1e3:.3g} mm",
                     fontsize=10)  # fmt: skip
        fig.colorbar(im, ax=ax, shrink=0.8, label="surface saturation θ (1)")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        scalebar(ax, 5.0, "5 mm")
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)


if __name__ == "__main__":
    bj, aj, bd, ad, folder = (Path(a) for a in sys.argv[1:6])
    folder.mkdir(parents=True, exist_ok=True)
    jet(bj, aj, folder / "splash_water_jet.png")
    drop(bd, ad, folder / "splash_drop.png")
    for name, run in (("water-jet before", bj), ("water-jet after", aj), ("splash-drop before", bd),
                      ("splash-drop after", ad)):  # fmt: skip
        print(name, json.dumps({k: float(f"{v:.4g}") for k, v in measure(run).items()}))
