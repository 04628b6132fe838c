"""The node raster that a fluid and a terrain share, in the SPH frame.

Nodes sit at x_i = x0 + i·Δx (i = 0 … nx−1) and, in 3-D, y_j = y0 + j·Δy (j = 0 … ny−1); the
horizontal axes are the first ``dim − 1`` axes of the particles (vertical is the last). A 2-D fluid
(x, z) uses a raster of one row (ny = 1). Arrays are ``(ny, nx)`` with row j at y_j, so rows grow
**northward** (+y), the reverse of a DEM's north-up row order: ``z_sph = dem.z[::-1]``.

Each node owns the cell [x_i − Δx/2, x_i + Δx/2) × [y_j − Δy/2, y_j + Δy/2) (half-open: a particle
exactly on a cell edge belongs to the node above it); values between nodes follow the Q4
interpolation of SPEC HM-2 (:mod:`erosim.kernels.raster`), positions in cell units being
((x − x0)/Δx, (y − y0)/Δy).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Raster:
    """Nodes ``(x0 + i·dx, y0 + j·dy)``, ``nx × ny`` of them (``ny = 1`` for a 2-D fluid)."""

    x0: float
    y0: float
    dx: float
    dy: float
    nx: int
    ny: int = 1

    def __post_init__(self):
        if not (self.dx > 0 and self.dy > 0 and self.nx >= 1 and self.ny >= 1):
            raise ValueError(f"a raster needs positive cell sizes and node counts, got {self}")

    @property
    def shape(self) -> tuple[int, int]:
        return (self.ny, self.nx)

    @property
    def cell_area(self) -> float:
        """Area a node stands for (m²); for a one-row raster of a 2-D fluid, Δx × 1 m (per unit width)."""
        return self.dx * (self.dy if self.ny > 1 else 1.0)

    def nodes(self) -> tuple[np.ndarray, np.ndarray]:
        """Node coordinates (x of each column, y of each row)."""
        return self.x0 + self.dx * np.arange(self.nx), self.y0 + self.dy * np.arange(self.ny)
