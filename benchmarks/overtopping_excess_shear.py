"""The overtopping case under the excess-shear law (``erosion.law = "excess_shear"``) at two resolutions,
the same physical parameters at each: a resistant embankment (τ_c = 5 Pa, the `partial` preset's
geometry) and a weak one on its plinth (τ_c = 0.2 Pa, `full`'s), k_d = 0.02 m/(Pa·s), k_s = 1 mm, 8 s
each; then where each began to erode (the first node passed, and the first profile points lowered by
5 mm, 1 cm, 2 cm, from profiles.csv every 1 s) and a figure of the four runs' profiles.

    python benchmarks/overtopping_excess_shear.py OUT_DIR [--spacings 0.02 0.015] [--draw-only]
    python benchmarks/overtopping_excess_shear.py OUT_DIR --law kristof2009   # the seed's presets, the same way
    python benchmarks/overtopping_excess_shear.py --stress RUN SPACING        # τ_b along the slope in RUN's frames

The summary also gives, per run, the crest's top and the eroded centre-line section at 4, 6 and 8 s, and
per preset the RMS difference of the profiles between the first two spacings. ``--stress`` reads a run
with particle frames (``… --set erosion.erodibility=0 --set run.output_interval=0.5``) and prints the 90th
percentile of the first layer's τ_b (k_s = 1 mm) in 5 cm bins along the flume at each frame from 1 s.

Each run is ``erosim run overtopping --preset P --set erosion.law=excess_shear --set
erosion.critical_stress=TC --set erosion.erodibility=0.02 --set sph.spacing=S --set voxels.cell_size=S
--set run.t_end=8``, one thread (the 2 cm runs take about 6 minutes, the 1.5 cm runs about 12 on the
2-core machine, two at a time).
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

#: preset → the bed's critical shear stress (Pa): a resistant soil, whose threshold the overflow passes
#: only low on the downstream slope (τ_b there 5–8 Pa, 2–4 Pa above mid-slope, at 2 and 1.5 cm), and a
#: weak one that the water passes wherever it flows (τ_b on the crest 0.3–1 Pa)
CASES = {"partial": 5.0, "full": 0.2}
ERODIBILITY = 0.02  # m/(Pa·s): 2 cm/s of retreat per Pa of excess, the seconds of this model for hours
TIMES = [0, 2, 3, 4, 5, 6, 8]
DROPS = (0.005, 0.01, 0.02)


def sets(preset: str, spacing: float, law: str = "excess_shear") -> list[str]:
    common = [f"sph.spacing={spacing!r}", f"voxels.cell_size={spacing!r}", "run.t_end=8.0", "run.output_interval=2.0",
              "run.particle_frames=false"]  # fmt: skip
    if law != "excess_shear":
        return common  # the preset's own erosion (the seed's law)
    return ["erosion.law=excess_shear", f"erosion.critical_stress={CASES[preset]!r}",
            f"erosion.erodibility={ERODIBILITY!r}", *common]  # fmt: skip


def one(args) -> str:
    preset, spacing, folder, law = args
    from numba import set_num_threads

    from erosim.io.runfolder import RunFolder
    from erosim.scenarios import loader, runner

    set_num_threads(1)
    runner.run(loader.load("overtopping", sets(preset, spacing, law), preset=preset),
               RunFolder(Path(folder), overwrite=True), progress=False)  # fmt: skip
    return folder


def first_lowered(tab: np.ndarray, drop: float) -> tuple[float | None, list[float]]:
    """The first profile time at which a point of the centre line lies ``drop`` below its start, and where."""
    times = np.unique(tab[:, 0])
    start = tab[tab[:, 0] == times[0], 2]
    for t in times[1:]:
        low = tab[tab[:, 0] == t]
        hit = start - low[:, 2] >= drop
        if hit.any():
            return float(t), [round(float(x), 3) for x in low[hit, 1]]
    return None, []


def profile(tab: np.ndarray, t: float, xs: np.ndarray) -> np.ndarray:
    """The centre-line surface of the profile nearest ``t``, at ``xs``."""
    times = np.unique(tab[:, 0])
    row = tab[tab[:, 0] == times[np.argmin(abs(times - t))]]
    return np.interp(xs, row[:, 1], row[:, 2])


XS = np.linspace(0.0, 0.9, 181)  # the embankment's extent from the toe (m)
LATER = (4.0, 6.0, 8.0)


def summary(folder: Path) -> dict:
    rep = json.loads((folder / "report.json").read_text())
    tab = np.loadtxt(folder / "profiles.csv", delimiter=",", skiprows=1)
    out = {"first_erosion": rep["first_erosion"] and {k: rep["first_erosion"][k] for k in ("t", "x", "z")},
           "eroded_volume_m3": rep["eroded_volume_m3"], "steps": rep["steps"],
           "wall_time_s": rep["timings"]["wall_time_s"]}  # fmt: skip
    for d in DROPS:
        t, xs = first_lowered(tab, d)
        out[f"lowered_{d * 1000:g}mm"] = {"t": t, "x_from": min(xs, default=None), "x_to": max(xs, default=None)}
    start = profile(tab, 0.0, XS)
    out["crest_top_m"] = {f"{t:g} s": round(float(profile(tab, t, XS).max()), 3) for t in LATER}
    out["eroded_section_cm2"] = {f"{t:g} s": round(1e4 * float(np.trapezoid(start - profile(tab, t, XS), XS)))
                                 for t in LATER}  # fmt: skip
    return out


def profile_rms_mm(a: Path, b: Path) -> dict:
    """RMS difference (mm) of two runs' centre-line profiles over the embankment at the later times."""
    ta, tb = (np.loadtxt(f / "profiles.csv", delimiter=",", skiprows=1) for f in (a, b))
    return {f"{t:g} s": round(1000 * float(np.sqrt(np.mean((profile(ta, t, XS) - profile(tb, t, XS)) ** 2))), 1)
            for t in LATER}  # fmt: skip


def stress(run: Path, spacing: float) -> None:
    """Print the 90th percentile of τ_b of the first layer in 5 cm bins along the flume, per frame (module doc)."""
    from erosim.erosion.excess_shear_partheniades1965 import ExcessShearErosion, ExcessShearParams
    from erosim.io.particles import read_pvd, read_vtp
    from erosim.scenarios import loader
    from erosim.terrain.voxel import VoxelTerrain

    x0 = loader.load(run / "scenario.toml").config.embankment.x_toe
    edges = np.arange(0.0, 1.0001, 0.05)
    print("x from toe (m):", " ".join(f"{e:5.2f}" for e in edges[:-1]))
    for k, (t, name) in enumerate(read_pvd(run / "particles" / "particles.pvd")):
        if t < 1.0:
            continue
        frame = read_vtp(run / "particles" / Path(name).name)
        terrain = VoxelTerrain.load(run / "fields" / f"density_{k:04d}.npz")
        eroder = ExcessShearErosion(terrain, ExcessShearParams(), support=2 * spacing, spacing=spacing)
        tau = eroder.bed_shear_stress(frame["points"], frame["fields"]["velocity"])
        x = frame["points"][:, 0] - x0
        cells = []
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            on = (x >= a) & (x < b) & np.isfinite(tau)
            cells.append(f"{np.percentile(tau[on], 90):5.1f}" if on.sum() >= 3 else "    -")
        print(f"t = {t:4.1f} s, τ_b p90 (Pa):", " ".join(cells))


def figure(folders: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = sorted(folders, key=lambda k: (k[0] != "partial", -k[1]))
    fig, axes = plt.subplots(2, len(keys) // 2, figsize=(6 * len(keys) // 2, 6.4), sharex=True, squeeze=False)
    for ax, key in zip(axes.T.ravel(), keys, strict=True):
        tab = np.loadtxt(folders[key] / "profiles.csv", delimiter=",", skiprows=1)
        times = np.unique(tab[:, 0])
        colours = plt.cm.viridis(np.linspace(0, 1, len(TIMES)))
        for c, t in zip(colours, TIMES, strict=True):
            near = times[np.argmin(abs(times - t))]
            row = tab[tab[:, 0] == near]
            ax.plot(row[:, 1], row[:, 2], color=c, lw=1.5 if t else 2.5, label=f"{near:.0f} s")
        fe = summary(folders[key])["first_erosion"]
        onset = f"first node passed at {fe['t']:.2f} s, x = {fe['x']:.2f} m" if fe else "no erosion"
        ax.set_title(f"{key[0]}: τ_c = {CASES[key[0]]:g} Pa, Δx = {key[1] * 100:g} cm\n{onset}", fontsize=9)
        ax.set_xlim(-0.1, 1.1)
        ax.grid(alpha=0.3)
        ax.set_ylabel("z (m)")
    axes[-1, 0].set_xlabel("x from the upstream toe (m)")
    axes[-1, -1].set_xlabel("x from the upstream toe (m)")
    axes[0, 0].legend(fontsize=7, ncol=2)
    fig.suptitle("overtopping under the excess-shear law (k_d = 0.02 m/(Pa·s), k_s = 1 mm): centre-line profiles")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out", nargs="?")
    ap.add_argument("--spacings", type=float, nargs="+", default=[0.02, 0.015])
    ap.add_argument("--law", choices=["excess_shear", "kristof2009"], default="excess_shear")
    ap.add_argument("--draw-only", action="store_true", help="only read the runs already in OUT_DIR")
    ap.add_argument("--stress", nargs=2, metavar=("RUN", "SPACING"), help="τ_b along the slope in RUN's frames")
    a = ap.parse_args()
    if a.stress:
        stress(Path(a.stress[0]), float(a.stress[1]))
        return
    out = Path(a.out)
    folders = {(p, s): out / f"{p}_{s:g}" for p in CASES for s in a.spacings}
    if not a.draw_only:
        with ProcessPoolExecutor(2) as pool:
            list(pool.map(one, [(p, s, str(f), a.law) for (p, s), f in folders.items()]))
    res = {f"{p} {s:g} m": summary(f) for (p, s), f in folders.items()}
    for p in CASES:
        first, second = (folders[(p, s)] for s in a.spacings[:2])
        res[f"{p}: profiles' RMS difference, {a.spacings[0]:g} against {a.spacings[1]:g} m (mm)"] = profile_rms_mm(
            first, second)  # fmt: skip
    (out / "summary.json").write_text(json.dumps(res, indent=1))
    print(json.dumps(res, indent=1))
    if a.law == "excess_shear":
        figure(folders, out / "overtopping_excess_shear.png")


if __name__ == "__main__":
    main()
