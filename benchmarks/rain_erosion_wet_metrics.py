"""Wet-area metrics of sph-terrain runs from each run's checkpoint (its last binning, 2 m cells).

    python benchmarks/rain_erosion_wet_metrics.py RUN_DIR [RUN_DIR ...]

wet: share of the map deeper than 0.1 m; largest_wet_region: the largest 4-connected wet patch as a
share of the map (one lake or sheet over everything → near the wet share); still / moving: wet cells
slower than 0.25 m/s / at least 0.5 m/s; top10pct_q_share: share of the summed unit discharge
(depth × speed) carried by the tenth of the wet cells that carry most (a uniform sheet → 0.1).
"""

import json
import sys

import numpy as np
from scipy import ndimage


def metrics(d: str) -> dict:
    z = np.load(d + "/checkpoint/state.npz", allow_pickle=True)
    dep = z["callback.coupler.grid_depth"]
    vel = z["callback.coupler.grid_velocity"][..., :2]
    sp = np.hypot(vel[..., 0], vel[..., 1])
    q = dep * sp
    wet = dep > 0.1
    lab, n = ndimage.label(wet)
    largest = np.bincount(lab.ravel())[1:].max() if n else 0
    still = wet & (sp < 0.25)
    moving = wet & (sp >= 0.5)
    qw = np.sort(q[wet])[::-1]
    k = max(1, int(round(0.1 * qw.size)))
    with open(d + "/report.json") as f:
        water = json.load(f)["water_budget"]
    return {
        "t_s": round(float(z["model.fluid.t"]), 2),
        "wet": round(float(wet.mean()), 3),
        "largest_wet_region": round(largest / wet.size, 3),
        "still_share_of_map": round(float(still.mean()), 3),
        "moving_share_of_wet": round(moving.sum() / max(wet.sum(), 1), 3),
        "top10pct_q_share": round(float(qw[:k].sum() / max(qw.sum(), 1e-12)), 3),
        "water_m3": water,
    }


if __name__ == "__main__":
    for run in sys.argv[1:]:
        print(run, json.dumps(metrics(run)))
