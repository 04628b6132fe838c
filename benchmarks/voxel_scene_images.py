"""The pictures of docs/voxel.md's `mountain-lake` and `canyon-caves` runs, from their run folders.

    python benchmarks/voxel_scene_images.py mountain-lake RUN OUT.png
    python benchmarks/voxel_scene_images.py canyon RUN1 RUN2 OUT.png [--at Y]
    python benchmarks/voxel_scene_images.py caves RUN

`mountain-lake`: the surface (marching cubes of fields/density_0000.npz and of the last field) as the run's
figures/surface.png draws it (erosim.scenarios.voxel.outputs.surface_figure): before tinted by height,
after coloured by the lowering of the top surface (m), the last particle frame's water as blue dots.
`canyon`: the cross-sections across the canyon after the first run (its start dashed) and after the
second (its start, the first's end, dashed), side by side, at y = Y (default: the node row the two runs
lowered most), over plan views of the top surface's lowering in each run (the section's row dashed).
It prints what it measures: the solid volume (the closed mesh's) before and after, and the top
surface's largest lowering.
`caves`: per particle frame of a `canyon-caves` run, the water in the caves: the particles more than
half a metre below the heightmap the caves were carved from (the scenario as the run folder's
scenario.toml gives it, its caves and any `terrain.voxels_file` left out).
"""

from __future__ import annotations

import argparse
import glob
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from erosim.io.particles import read_vtp
from erosim.scenarios.voxel.outputs import surface_figure, top_surface
from erosim.terrain.voxel import VoxelTerrain


def fields(run: str) -> list[str]:
    return sorted(glob.glob(f"{run}/fields/density_*.npz"))


def small_png(path: str | Path, image: Image.Image) -> None:
    """Save as a 256-colour PNG (the pictures stay well under 300 kB)."""
    image.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)


def mountain_lake(run: str, out: str) -> None:
    fs = fields(run)
    t0, t1 = VoxelTerrain.load(fs[0]), VoxelTerrain.load(fs[-1])
    dz = top_surface(t1) - top_surface(t0)
    last = read_vtp(sorted(glob.glob(f"{run}/particles/frame_*.vtp"))[-1])
    v0, v1 = t0.surface_mesh().volume, t1.surface_mesh().volume
    print(
        f"solid volume (closed mesh) {v0:.1f} -> {v1:.1f} m3 (removed {v0 - v1:.1f}); "
        f"top surface lowered at most {-dz.min():.3f} m; {len(last['points'])} particles at t = {last['time']:.3g} s"
    )
    with tempfile.TemporaryDirectory() as tmp:
        png = Path(tmp) / "ml.png"
        surface_figure(png, t0, t1, last["points"], float(last["time"]), "mountain-lake")
        small_png(out, Image.open(png))


def lowering_maps(path: Path, t: VoxelTerrain, maps: list[tuple[str, np.ndarray]], at: float) -> None:
    """Plan views of the top surface's lowering (m) in each run, the section's row dashed; the colours
    saturate at 0.5 m (a few single columns, thin lips losing their top, drop further)."""
    from erosim.viz.plots import plt, save_figure

    x, y, _ = t.axes()
    top = 0.5
    fig, axes = plt.subplots(1, len(maps), figsize=(4.2 * len(maps), 3.4))
    for ax, (name, m) in zip(np.atleast_1d(axes), maps, strict=True):
        im = ax.imshow(np.maximum(m, 0.0), origin="lower", extent=(x[0], x[-1], y[0], y[-1]), cmap="magma_r",
                       vmin=0.0, vmax=top)  # fmt: skip
        ax.axhline(at, color="tab:blue", ls="--", lw=1.0)
        ax.set_title(f"lowering of the top surface in {name} (m)", fontsize=9)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        fig.colorbar(im, ax=ax, shrink=0.85, extend="max")
    fig.tight_layout()
    save_figure(fig, path)


def canyon(run1: str, run2: str, out: str, at: float | None) -> None:
    f1, f2 = fields(run1), fields(run2)
    t0, t1 = VoxelTerrain.load(f1[0]), VoxelTerrain.load(f1[-1])
    s2, t2 = VoxelTerrain.load(f2[0]), VoxelTerrain.load(f2[-1])
    if not np.array_equal(s2.density, t1.density):
        raise SystemExit(f"{run2} did not start from {f1[-1]}.")
    z0, z1, z2 = top_surface(t0), top_surface(t1), top_surface(t2)
    y = t0.axes()[1]
    if at is None:
        at = float(y[np.argmin((z2 - z0).sum(axis=1))])
    v = [t.surface_mesh().volume for t in (t0, t1, t2)]
    print(
        f"solid volume (closed mesh) {v[0]:.1f} -> {v[1]:.1f} -> {v[2]:.1f} m3 (removed {v[0] - v[1]:.1f} in run 1, "
        f"{v[1] - v[2]:.1f} in run 2); top surface lowered at most {-(z1 - z0).min():.3f} m (run 1), "
        f"{-(z2 - z1).min():.3f} m (run 2); section at y = {at:g} m"
    )
    with tempfile.TemporaryDirectory() as tmp:
        p1, p2 = Path(tmp) / "a.png", Path(tmp) / "b.png"
        t1.cross_section(p1, "y", at, title=f"after run 1 (start dashed), y = {at:g} m", reference=t0)
        t2.cross_section(p2, "y", at, title=f"after run 2 (run 2's start dashed), y = {at:g} m", reference=s2)
        p3 = Path(tmp) / "c.png"
        lowering_maps(p3, t0, [("run 1", z0 - z1), ("run 2", z1 - z2)], at)
        a, b = Image.open(p1).convert("RGB"), Image.open(p2).convert("RGB")
        c = Image.open(p3).convert("RGB")
        c = c.resize((a.width + b.width, c.height * (a.width + b.width) // c.width), Image.Resampling.LANCZOS)
        both = Image.new("RGB", (a.width + b.width, max(a.height, b.height) + c.height), "white")
        both.paste(a, (0, 0))
        both.paste(b, (a.width, 0))
        both.paste(c, (0, max(a.height, b.height)))
        both = both.resize((both.width * 3 // 4, both.height * 3 // 4), Image.Resampling.LANCZOS)
        small_png(out, both)


def caves(run: str) -> None:
    from erosim.scenarios import loader
    from erosim.scenarios.voxel.build import build_terrain

    cfg = loader.load(Path(run) / "scenario.toml", ["caves.wavelength=0"]).config  # a second run: its generator's
    uncut = build_terrain(cfg.model_copy(update={"terrain": cfg.terrain.model_copy(update={"voxels_file": None})}))
    z = top_surface(uncut)  # [iy, ix] on the voxels' node columns
    c, (x0, y0) = uncut.cell_size, uncut.lo[:2]
    for frame in sorted(glob.glob(f"{run}/particles/frame_*.vtp")):
        pos = np.asarray(read_vtp(frame)["points"])
        if len(pos) == 0:
            continue
        ix = np.clip(np.round((pos[:, 0] - x0) / c).astype(int), 0, z.shape[1] - 1)
        iy = np.clip(np.round((pos[:, 1] - y0) / c).astype(int), 0, z.shape[0] - 1)
        print(f"{Path(frame).name}: {len(pos)} particles, {int((pos[:, 2] < z[iy, ix] - 0.5).sum())} in the caves")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    m = sub.add_parser("mountain-lake")
    m.add_argument("run")
    m.add_argument("out")
    c = sub.add_parser("canyon")
    c.add_argument("run1")
    c.add_argument("run2")
    c.add_argument("out")
    c.add_argument("--at", type=float, default=None)
    sub.add_parser("caves").add_argument("run")
    a = ap.parse_args()
    if a.what == "mountain-lake":
        mountain_lake(a.run, a.out)
    elif a.what == "caves":
        caves(a.run)
    else:
        canyon(a.run1, a.run2, a.out, a.at)


if __name__ == "__main__":
    main()
