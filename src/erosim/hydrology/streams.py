"""HY-4 stream map: time-averaged droplet presence, old values fade.

After each cycle of droplets, stream ← (1 − r)·stream + r·visited with r = ``stream_rate``
(seed 0.01) and visited = 1 where any droplet of the cycle passed (its footprint), else 0.
The map lies in [0, 1]; droplets read it for their effective friction and evaporation (HY-1).
"""

from __future__ import annotations

import numpy as np


def update(stream: np.ndarray, track: np.ndarray, rate: float) -> None:
    """In place: stream ← (1 − r)·stream + r·track; then clears ``track``."""
    stream *= 1.0 - rate
    stream += rate * track.reshape(stream.shape)
    track[...] = 0


def ease_out(stream: np.ndarray, threshold: float = 0.0) -> np.ndarray:
    """HY-9 display curve of the stream map: 1 − (1 − s)⁴, values below ``threshold`` dropped."""
    s = np.clip(stream, 0.0, 1.0)
    out = 1.0 - (1.0 - s) ** 4
    if threshold > 0:
        out[s < threshold] = 0.0
    return out
