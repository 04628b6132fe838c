"""Analytic terrains for tests, validation and laboratory-like set-ups: flat, tilted, bowl, valley, canyon.

Cell centres at x = (ix + ½)Δ, y from the south edge (row 0 of the array is north, the map order);
W is the map's width (x) and D its depth (y), ``relief`` and ``base`` in metres:

* ``flat``:   z = base
* ``tilted``: z = base + relief·x/W                        (rises eastward)
* ``bowl``:   z = base + relief·(ρ/R)², ρ the distance to the centre, R = min(W, D)/2 (a paraboloid)
* ``valley``: z = base + relief·|x − W/2|/(W/2) + relief·(1 − y/D)/4   (a V valley falling northward)
* ``canyon``: z = base + relief·[clip((r − a)/b, 0, 1) + (r − a − b)⁺/(5W)] + relief·(1 − y/D)/4,
  r = |x − W/2|, a = W/8, b = W/48: a flat floor W/4 wide between cliffs b across (steeper than 80°
  for a relief of 6 m on a 24 m map) under plateaus sloping at relief/(5W) towards the rim, so that what runs off
  them falls over it; the floor falls northward as the valley's
"""

from __future__ import annotations

import numpy as np

from erosim.core.heightmap import Heightmap

SHAPES = ("flat", "tilted", "bowl", "valley", "canyon")


def shape(name: str, size, cell_size: float, relief: float = 1.0, base: float = 0.0) -> Heightmap:
    """The named analytic terrain of ``size`` cells (int or (ny, nx))."""
    ny, nx = (size, size) if np.isscalar(size) else tuple(size)
    ny, nx = int(ny), int(nx)
    w, d = nx * cell_size, ny * cell_size
    x = (np.arange(nx) + 0.5) * cell_size
    y = (np.arange(ny)[::-1] + 0.5) * cell_size  # row 0 at the north edge
    X, Y = np.meshgrid(x, y)
    if name == "flat":
        z = np.zeros_like(X)
    elif name == "tilted":
        z = X / w
    elif name == "bowl":
        z = ((X - w / 2) ** 2 + (Y - d / 2) ** 2) / (min(w, d) / 2) ** 2
    elif name == "valley":
        z = np.abs(X - w / 2) / (w / 2) + 0.25 * (1.0 - Y / d)
    elif name == "canyon":
        r = np.abs(X - w / 2)
        a, b = w / 8, w / 48
        z = np.clip((r - a) / b, 0.0, 1.0) + np.maximum(r - a - b, 0.0) / (5 * w) + 0.25 * (1.0 - Y / d)
    else:
        raise ValueError(f"unknown shape {name!r}; use one of {', '.join(SHAPES)}")
    return Heightmap(z=base + relief * z, cell_size=float(cell_size))
