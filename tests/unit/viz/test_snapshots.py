"""Snapshots of one run share one colour scale: 0 to Ritter's front speed 2√(gΔz) for the domain's height."""

import numpy as np
import pytest

from erosim.core.schedules import IterationInterval
from erosim.simulation import callbacks
from erosim.viz import plots


class _Fluid:
    def __init__(self, speed):
        self.t = 0.0
        self.pos = np.array([[0.2, 0.2], [0.6, 0.4]])
        self.vel = np.array([[0.0, 0.0], [speed, 0.0]])

    def fluid_positions(self):
        return self.pos

    def fluid_velocities(self):
        return self.vel


def test_every_frame_has_the_same_colour_scale(tmp_path, monkeypatch):
    seen = []
    real = plots.snapshot

    def spy(*args, **kwargs):
        seen.append(kwargs["speed_max"])
        return real(*args, **kwargs)

    monkeypatch.setattr(callbacks, "snapshot", spy)  # the name the callback calls
    for speed in (0.1, 3.0):  # frames whose own maxima differ 30-fold
        cb = callbacks.Snapshots(
            IterationInterval(1), _Fluid(speed), tmp_path, lo=[0, 0], hi=[1.0, 0.5], spacing=0.05, title="t", g=9.81
        )
        cb(None)
    assert seen[0] == seen[1] == pytest.approx(2 * np.sqrt(9.81 * 0.5))
