"""Where a `mountain-lake` run lowered its ground, and whether along the flow paths: from finished run
folders (fields at the start and at the end), per run

* the eroded volume and the largest and mean lowering of the top surface;
* Spearman's ρ between the lowering and log D8 flow accumulation on the starting surface, outside its
  closed hollows (the hollows filled first, so that the accumulation follows their spill paths), and
  the mean lowering on the top 10 % of the accumulation against the rest: a channel cut along the flow
  paths raises both;
* on the mountain of terrain.seed = 11 only, the lowering in a window over the spill path north of its
  largest hollow (x 11–13 m, y ≥ 19.5 m: docs/voxel.md's 60 s table; the outlets below measure any
  mountain's paths themselves);
* per closed hollow of the starting surface holding more than 1 m³, at every saved field: its spill
  level and its capacity (the water it would hold filled to that level), and the lowering along its
  outlet's path (from the pour point, steepest descent over the filled starting surface to the map's
  edge or the next hollow): a lake carving its outlet lowers its spill level, loses capacity, and cuts a
  channel along that path (`channel_m`: the longest unbroken stretch of it lowered by more than
  `CHANNEL_DEPTH`);

and a figure of the lowering maps side by side. With ``--seeds FIRST LAST``, the scan that chose the
scene's mountain: the seeds whose mountain has a hollow spilling into another, most lakes first.

    python benchmarks/mountain_lake_lowering.py FIGURE.png RUN [RUN ...]
    python benchmarks/mountain_lake_lowering.py --seeds 0 400
"""

from __future__ import annotations

import functools
import glob
import json
import sys
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

from erosim.scenarios.loader import read_toml
from erosim.scenarios.voxel.outputs import top_surface
from erosim.terrain.lake_outlets import hollows as lake_hollows
from erosim.terrain.priority_flood_barnes2014 import closed_basin_depth
from erosim.terrain.voxel import VoxelTerrain


def d8_accumulation(z: np.ndarray) -> np.ndarray:
    """Cells draining through each cell (itself included), steepest descent over the 8 neighbours."""
    ny, nx = z.shape
    acc = np.ones(z.size)
    for k in np.argsort(z.ravel())[::-1]:
        i, j = divmod(int(k), nx)
        best, to = 0.0, -1
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                a, c = i + di, j + dj
                if (di or dj) and 0 <= a < ny and 0 <= c < nx:
                    s = (z[i, j] - z[a, c]) / np.hypot(di, dj)
                    if s > best:
                        best, to = s, a * nx + c
        if to >= 0:
            acc[to] += acc[k]
    return acc.reshape(ny, nx)


CHANNEL_DEPTH = 0.1  # m: a cut deeper than this (about the 0.1 m of a rill) counts towards a channel


def describe(h, cell: float) -> dict:
    """A hollow as numbers: its centre, capacity, spill level, outlet path's length and where it spills."""
    return {"centre_m": [round(c, 2) for c in h.centre(cell)], "capacity_m3": round(h.capacity_m3, 2),
            "spill_level_m": round(h.spill_level_m, 3), "path_m": round(len(h.path) * cell, 2),
            "spills_into": h.spills_into}  # fmt: skip


@functools.cache
def outlet_history(run: Path) -> list[dict]:
    """Spill level, capacity and the cut along the outlet's path of each hollow at every saved field."""
    fields = sorted(glob.glob(str(run / "fields" / "density_*.npz")))
    first = VoxelTerrain.load(fields[0])
    start, cell = top_surface(first), first.cell_size
    hollows = lake_hollows(start, cell)
    every = read_toml(run / "scenario.toml")["run"]["output_interval"]
    times = [round(int(Path(f).stem.split("_")[1]) * every, 6) for f in fields]
    history = [describe(h, cell) | {"at": []} for h in hollows]
    for f, t in zip(fields, times, strict=True):
        now = top_surface(VoxelTerrain.load(f))
        depth = closed_basin_depth(now)
        low, spill = start - now, now + depth
        for h, rec in zip(hollows, history, strict=True):
            cut = np.array([low[p] for p in h.path])
            longest = length = 0
            for deep in cut > CHANNEL_DEPTH:
                length = length + 1 if deep else 0
                longest = max(longest, length)
            rec["at"].append(
                {
                    "field": Path(f).name,
                    "t": t,
                    "spill_level_m": round(float(spill[h.cells & (depth > 0)].max()), 3)
                    if (h.cells & (depth > 0)).any() else None,
                    "capacity_m3": round(float(depth[h.cells].sum() * cell * cell), 3),
                    "outlet_cut_max_m": round(float(cut.max()), 3),
                    "outlet_cut_mean_m": round(float(cut.mean()), 3),
                    "channel_m": round(longest * cell, 2),
                }
            )
    return history


def lake_history(run: Path) -> list[dict]:
    """Per hollow (as :func:`erosim.terrain.lake_outlets.hollows`) and particle frame: the water standing
    in it (particles over its cells below its spill level + one voxel, times the particle's volume), the
    particles on its outlet's path moving down it (faster than 0.1 m/s along the path's direction), and,
    where the frames carry the particles' labels (`id`), ``from_lakes_above``: how many particles
    standing in it had been held, in an earlier frame, in a lake that spills into it (over its cells, at
    or below its spill level: water that leaves only over the pour point, or splashed), and
    ``arrived_from_lakes_above``: how many such particles it has held so far. A lake that has filled
    passes its inflow on over its outlet, into the next lake (the lakes join) or off the map."""
    from erosim.io.particles import read_pvd, read_vtp

    first = VoxelTerrain.load(sorted(glob.glob(str(run / "fields" / "density_*.npz")))[0])
    start, cell = top_surface(first), first.cell_size
    spacing = read_toml(run / "scenario.toml")["sph"]["spacing"]
    hollows = lake_hollows(start, cell)
    frames = read_pvd(run / "particles" / "particles.pvd")
    history = [describe(h, cell) | {"t": [], "water_m3": [], "leaving": [], "from_lakes_above": [],
                                    "arrived_from_lakes_above": []} for h in hollows]  # fmt: skip
    stood = [np.zeros(0, np.int64) for _ in hollows]  # labels of the particles that have stood in each lake
    arrived = [np.zeros(0, np.int64) for _ in hollows]  # … and of those that came to it from a lake above
    feeders = [[k for k, u in enumerate(hollows) if u.spills_into == j] for j in range(len(hollows))]
    paths, downhill = [], []  # each outlet path as a mask, and its direction over its first cells
    for h in hollows:
        mask = np.zeros_like(h.cells)
        mask[tuple(np.array(h.path).T)] = True
        (a0, b0), (a1, b1) = h.path[0], h.path[min(len(h.path) - 1, 2)]
        along = np.array([b1 - b0, a1 - a0], dtype=float)
        paths.append(mask)
        downhill.append(along / max(np.hypot(*along), 1e-12))
    ny, nx = start.shape
    for t, name in frames:
        frame = read_vtp(run / "particles" / name)
        pos, vel = np.asarray(frame["points"]), np.asarray(frame["fields"]["velocity"])
        ids = frame["fields"].get("id")
        ix = np.clip(np.rint(pos[:, 0] / cell).astype(int), 0, nx - 1)
        iy = np.clip(np.rint(pos[:, 1] / cell).astype(int), 0, ny - 1)
        near_ground = pos[:, 2] <= start[iy, ix] + 2 * spacing
        for j, (h, rec) in enumerate(zip(hollows, history, strict=True)):
            standing = h.cells[iy, ix] & (pos[:, 2] <= h.spill_level_m + cell)
            moving = paths[j][iy, ix] & near_ground & (vel[:, :2] @ downhill[j] > 0.1)
            rec["t"].append(round(float(t), 3))
            rec["water_m3"].append(round(float(standing.sum() * spacing**3), 3))
            rec["leaving"].append(int(moving.sum()))
            if ids is not None:
                above = [stood[k] for k in feeders[j]]
                came = ids[standing][np.isin(ids[standing], np.concatenate(above))] if above else ids[:0]
                rec["from_lakes_above"].append(int(came.size))
                arrived[j] = np.union1d(arrived[j], came)
                rec["arrived_from_lakes_above"].append(int(arrived[j].size))
        if ids is not None:
            for k, h in enumerate(hollows):  # held: at or below the spill level
                held = h.cells[iy, ix] & (pos[:, 2] <= h.spill_level_m)
                stood[k] = np.union1d(stood[k], ids[held])
    return history


@functools.cache
def lowering(run: Path):
    fields = sorted(glob.glob(str(run / "fields" / "density_*.npz")))
    first = VoxelTerrain.load(fields[0])
    start, end = top_surface(first), top_surface(VoxelTerrain.load(fields[-1]))
    return start, start - end, first.cell_size


def measures(run: Path) -> dict:
    start, low, cell = lowering(run)
    hollows = closed_basin_depth(start)
    acc = d8_accumulation(start + hollows)
    out = hollows <= 0
    top = acc[out] > np.percentile(acc[out], 90)
    rep = json.loads((run / "report.json").read_text())
    found = {
        "cell_m": cell,
        "eroded_volume_m3": rep["eroded_volume_m3"],
        "t": rep["t"],
        "max_lowering_m": float(low.max()),
        "mean_lowering_m": float(low.mean()),
        "spearman_lowering_vs_log_accumulation": float(spearmanr(low[out], np.log(acc[out]))[0]),
        "mean_lowering_top10pct_accumulation_m": float(low[out][top].mean()),
        "mean_lowering_rest_m": float(low[out][~top].mean()),
    }
    if read_toml(run / "scenario.toml")["terrain"].get("seed") == 11:  # the window docs/voxel.md's 60 s table read
        x = np.arange(start.shape[1]) * cell
        y = np.arange(start.shape[0]) * cell
        spill = (np.abs(x[None, :] - 12.0) <= 1.0) & (y[:, None] >= 19.5)
        found |= {"spill_path_max_m": float(low[spill].max()), "spill_path_mean_m": float(low[spill].mean())}
    return found


def figure(runs: list[Path], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(runs) + 1, figsize=(5.2 * (len(runs) + 1), 4.8), constrained_layout=True,
                             squeeze=False)  # fmt: skip
    top = max(0.3, max(np.ceil(np.percentile(lowering(run)[1], 99) * 10) / 10 for run in runs))  # colour scale's end
    for ax, run in zip(axes[0, :-1], runs, strict=True):
        start, low, cell = lowering(run)
        x = np.arange(start.shape[1]) * cell
        y = np.arange(start.shape[0]) * cell
        im = ax.imshow(low, origin="lower", extent=(0, x[-1], 0, y[-1]), cmap="magma_r", vmin=0, vmax=top)
        ax.contour(x, y, start, levels=15, colors="k", linewidths=0.3)
        for h in lake_hollows(start, cell):
            ax.contour(x, y, h.cells.astype(float), levels=[0.5], colors="tab:blue", linewidths=1.0)
            iy, ix = np.array(h.path).T
            ax.plot(ix * cell, iy * cell, color="tab:cyan", lw=1.2)
            ax.plot(ix[0] * cell, iy[0] * cell, "o", color="tab:cyan", ms=3)
        ax.set_title(f"{run.name}: {cell:g} m voxels", fontsize=10)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    fig.colorbar(im, ax=axes[0, :-1], label="ground lowered (m)")
    ax = axes[0, -1]
    for run, style in zip(runs, ("-", "--", ":", "-."), strict=False):
        for k, h in enumerate(outlet_history(run)):
            if h["capacity_m3"] < 5.0:
                continue
            t = [a["t"] for a in h["at"]]
            drop = [h["spill_level_m"] - (a["spill_level_m"] if a["spill_level_m"] is not None else np.nan)
                    for a in h["at"]]  # fmt: skip
            ax.plot(t, drop, style, color=f"C{k}", label=f"{run.name}: ({h['centre_m'][0]:g}, {h['centre_m'][1]:g}) "
                    f"{h['capacity_m3']:.0f} m³")  # fmt: skip
    ax.set_xlabel("t (s)")
    ax.set_ylabel("spill level lowered (m)")
    ax.set_title("lakes of more than 5 m³: their outlets cut", fontsize=10)
    ax.legend(fontsize=7)
    fig.suptitle("mountain-lake: the ground lowered by the end; black: the ground at the start; blue: its closed "
                 "hollows over 1 m³; cyan: their outlets' paths from the pour point (dot)", fontsize=9)
    fig.savefig(path, dpi=80)


def seed_scan(first: int, last: int) -> list[dict]:
    """The library scene's mountain for each ``terrain.seed`` in [first, last), as its voxels: the hollows
    of more than 1 m³, how many are deeper than the kernel support h and how many spill into another."""
    from erosim.scenarios import loader
    from erosim.scenarios.voxel.build import build_terrain

    rows = []
    for seed in range(first, last):
        cfg = loader.load("mountain-lake", [f"terrain.seed={seed}"]).config
        terrain = build_terrain(cfg)
        z = top_surface(terrain)
        found = lake_hollows(z, terrain.cell_size)
        deep = sum(bool((h.spill_level_m - z[h.cells]).max() > cfg.sph.support()) for h in found)
        rows.append({"seed": seed, "hollows": len(found), "deeper_than_h": deep,
                     "spilling_into_another": sum(h.spills_into >= 0 for h in found)})  # fmt: skip
    return rows


if __name__ == "__main__":
    if sys.argv[1] == "--seeds":
        rows = [r for r in seed_scan(int(sys.argv[2]), int(sys.argv[3])) if r["spilling_into_another"]]
        rows.sort(key=lambda r: (-r["deeper_than_h"], r["seed"]))
        print(f"{len(rows)} seeds with a hollow spilling into another; most hollows deeper than h first:")
        for r in rows[:10]:
            print(r)
        sys.exit(0)
    runs = [Path(a) for a in sys.argv[2:]]
    print(json.dumps({str(r): measures(r) | {"hollows": outlet_history(r), "lakes": lake_history(r)} for r in runs}))
    figure(runs, sys.argv[1])
