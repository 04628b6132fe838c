"""The particle-stream canyon's floor along the map, from a run folder's maps (issue 36, seed 004).

    python benchmarks/particle_stream_profile.py RUN_DIR

Per column (the library stream runs west to east), the canyon floor is the lowest height among the
cells cut by more than 1 m. Prints the deepest cut, the depth at the emitter's column, the floor at
the first and last columns and its largest rise above the lowest floor upstream (0 for a floor that
never rises downstream; the closed trough of the seed's plain lowering read 55 m).
"""

import json
import sys

import numpy as np
import rasterio


def profile(run: str, emitter_x: float = 0.06) -> dict:
    with rasterio.open(run + "/maps/height_initial.tif") as src:
        h0 = src.read(1).astype(float)
    with rasterio.open(run + "/maps/height.tif") as src:
        h = src.read(1).astype(float)
    cut = h0 - h
    cols = [i for i in range(h.shape[1]) if (cut[:, i] > 1.0).any()]
    floor = np.array([h[:, i][cut[:, i] > 1.0].min() for i in cols])
    rise = floor - np.minimum.accumulate(floor)
    i0 = int(emitter_x * (h.shape[1] - 1))
    return {
        "max_depth_m": round(float(cut.max()), 2),
        "depth_at_emitter_m": round(float(cut[:, i0].max()), 2),
        "floor_first_m": round(float(floor[0]), 2),
        "floor_last_m": round(float(floor[-1]), 2),
        "floor_min_m": round(float(floor.min()), 2),
        "max_rise_m": round(float(rise.max()), 2),
        "max_rise_column": int(cols[int(rise.argmax())]),
    }


if __name__ == "__main__":
    print(json.dumps(profile(sys.argv[1])))
