"""HY-4 stream map: time-averaged droplet presence, old values fade.

After each cycle of droplets, stream ← (1 − r)·stream + r·visited with r = ``stream_rate``
(seed 0.01) and visited = 1 where any droplet of the cycle passed (its footprint), else 0.
The map lies in [0, 1]; droplets read it for their effective friction and evaporation (HY-1).
The update is one fused Numba pass (stream and track read and written once): in NumPy it took
three passes over the map every cycle, a few per cent of the seed preset's run time.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _update(sf, track, keep, rate):
    for c in range(sf.shape[0]):
        sf[c] = sf[c] * keep + rate * track[c]
        track[c] = 0


def update(stream: np.ndarray, track: np.ndarray, rate: float) -> None:
    """In place: stream ← (1 − r)·stream + r·track; then clears ``track``."""
    _update(stream.reshape(-1), track.reshape(-1), 1.0 - float(rate), float(rate))


def ease_out(stream: np.ndarray, threshold: float = 0.0) -> np.ndarray:
    """HY-9 display curve of the stream map: 1 − (1 − s)⁴, values below ``threshold`` dropped."""
    s = np.clip(stream, 0.0, 1.0)
    out = 1.0 - (1.0 - s) ** 4
    if threshold > 0:
        out[s < threshold] = 0.0
    return out
