"""Map frames: the terrain and its water at the run's output times, for ``erosim view``'s time slider.

A frame is one GeoTIFF per map, ``maps/frames/<map>_<number>.tif`` (float32, deflate, on the run's
grid, CRS and transform: :func:`erosim.io.heightmaps.write_raster`), and ``maps/frames/frames.json``
lists the frames' times (``{"times": [...], "unit": ...}``) in number order. The reader is
:func:`erosim.io.results.open_run` (``Run.map_frames``). Every file is written atomically, so a run
stopped while writing a frame leaves the frames before it whole.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from erosim.core.atomic import write_json
from erosim.core.heightmap import Heightmap
from erosim.io.heightmaps import write_raster

FOLDER = Path("maps") / "frames"


def frame_path(run: str | os.PathLike, name: str, number: int) -> Path:
    return Path(run) / FOLDER / f"{name}_{number:05d}.tif"


def write_frame(run: str | os.PathLike, number: int, maps: dict[str, np.ndarray], like: Heightmap) -> list[Path]:
    """Write frame ``number``: each map (name → array of ``like``'s shape) as a float32 GeoTIFF."""

    (Path(run) / FOLDER).mkdir(parents=True, exist_ok=True)
    out = []
    for name, a in maps.items():
        p = frame_path(run, name, number)
        write_raster(p, np.asarray(a, dtype=np.float32), like, nodata=np.nan)
        out.append(p)
    return out


def write_times(run: str | os.PathLike, times: list[float], unit: str) -> Path:
    """``maps/frames/frames.json``: the time of every frame written so far, in number order."""
    (Path(run) / FOLDER).mkdir(parents=True, exist_ok=True)
    return write_json(Path(run) / FOLDER / "frames.json", {"times": [float(t) for t in times], "unit": unit})
