"""The overtopping profile figures of docs/voxel.md from two finished run folders (``erosim run
overtopping --preset partial|full …``): each preset's centre-line profiles at the times given, drawn by
:func:`erosim.viz.plots.profiles_figure`, and the onset of each printed.

    python benchmarks/overtopping_figures.py PARTIAL_RUN FULL_RUN OUT_DIR
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from erosim.viz.plots import profiles_figure

#: the seed draws every 20 s; at this scale both embankments are gone within seconds (partial 4–6 s,
#: full 1–3 s; the profiles are every 1 s)
TIMES = {"partial": [0, 2, 3, 4, 5, 6, 60], "full": [0, 1, 2, 3, 60]}


def main(partial: str, full: str, out: str) -> None:
    for preset, folder in (("partial", Path(partial)), ("full", Path(full))):
        tab = np.loadtxt(folder / "profiles.csv", delimiter=",", skiprows=1)
        times = np.unique(tab[:, 0])
        curves = []
        for t in TIMES[preset]:
            near = times[np.argmin(abs(times - t))]
            if abs(near - t) < 0.5:
                curves.append((round(float(near), 2), tab[tab[:, 0] == near, 1], tab[tab[:, 0] == near, 2]))
        rep = json.loads((folder / "report.json").read_text())
        fe = rep["first_erosion"]
        title = (f"overtopping, {preset}: first erosion at {fe['t']:.2f} s, x = {fe['x']:.2f} m, z = {fe['z']:.2f} m"
                 if fe else f"overtopping, {preset}: no erosion")  # fmt: skip
        path = profiles_figure(Path(out) / f"overtopping_{preset}_profiles.png", curves, title=title)
        print(preset, path, fe, rep["eroded_volume_m3"])


if __name__ == "__main__":
    main(*sys.argv[1:4])
