"""Where the water is in sph-terrain runs, drawn from each run's checkpoint (its last binning, 2 m cells).

    python benchmarks/rain_erosion_water.py OUT.png RUN_DIR=label [RUN_DIR=label ...]

One row per run: the initial terrain, the water depth (blank below 0.1 m) and the unit discharge
depth × speed (blank below 0.05 m²/s), all with axes in metres, colour bars and a 50 m scale bar.
"""

import sys

import matplotlib
import numpy as np
import rasterio

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(out: str, runs: list[str]) -> None:
    fig, axs = plt.subplots(len(runs), 3, figsize=(15, 4.6 * len(runs)), squeeze=False)
    for row, spec in zip(axs, runs, strict=True):
        d, label = spec.split("=", 1)
        z = np.load(d + "/checkpoint/state.npz", allow_pickle=True)
        dep = z["callback.coupler.grid_depth"]
        v = z["callback.coupler.grid_velocity"][..., :2]
        q = dep * np.hypot(v[..., 0], v[..., 1])
        with rasterio.open(d + "/maps/height_initial.tif") as src:
            b = src.bounds
            hi = src.read(1)
        ext = [b.left, b.right, b.bottom, b.top]
        t = float(z["model.fluid.t"])
        a = row[0].imshow(hi, extent=ext, cmap="gist_earth")  # map order: row 0 = north
        fig.colorbar(a, ax=row[0], label="height (m)")
        row[0].set_title(f"{label}: initial terrain")
        # the coupler's grids run northward (row 0 = south)
        a = row[1].imshow(np.ma.masked_less(dep, 0.1), origin="lower", extent=ext, cmap="Blues", vmin=0, vmax=2.0)
        fig.colorbar(a, ax=row[1], label="water depth (m), dry < 0.1 m blank", extend="max")
        row[1].set_title(f"{label}: water depth at t = {t:.0f} s")
        a = row[2].imshow(np.ma.masked_less(q, 0.05), origin="lower", extent=ext, cmap="magma_r", vmin=0, vmax=4.0)
        fig.colorbar(a, ax=row[2], label="unit discharge depth × speed (m²/s)", extend="max")
        row[2].set_title(f"{label}: where the water flows")
        for ax in row:
            ax.set_xlabel("x (m)")
            ax.set_ylabel("y (m)")
            ax.plot([ext[0] + 8, ext[0] + 58], [ext[2] + 6] * 2, "k-", lw=3)
            ax.text(ext[0] + 33, ext[2] + 9, "50 m", ha="center")
    fig.tight_layout()
    fig.savefig(out, dpi=90)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
