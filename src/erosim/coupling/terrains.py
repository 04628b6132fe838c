"""The terrains a :class:`~erosim.coupling.coupler.Coupler` can change: a heightfield, a heightfield over a
porous ground, and a voxel field.

The coupler's steps are the same for both (ask the eroder, check the budget, apply once, refresh the
fluid's boundaries); what differs is held here, behind one small interface:

``terrain``
    what the eroder is given (the height array, or the :class:`~erosim.terrain.voxel.VoxelTerrain`);
``values``
    the array the increment changes and the boundaries are refreshed with (heights, or densities);
``unit_volume``
    the volume of one unit of ``values`` at one node (a cell's area; Δ³/(d_solid − d_air) for a field);
``provides`` and ``fluid(solver)``
    what the eroder sees of the fluid: the fluid binned on the raster
    (:class:`~erosim.coupling.binning.FluidGrid`, its :attr:`~FluidGrid.FIELDS`), or the solver's
    particles;
``refuse(inc, who)``, ``apply(dz, t)``
    checks of its own (the bedrock) and the write of Δ (with what the terrain records of its changes);
``write(fields)``
    the new values of its own fields an increment carries (a porous ground's moisture);
``budget(totals, eroder)``, ``state_dict()``, ``load_state_dict()``
    its report and checkpoint entries.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from erosim.core.errors import BudgetError, ConfigError
from erosim.coupling.binning import FluidGrid
from erosim.coupling.porous_ground import PorousGround
from erosim.coupling.raster import Raster
from erosim.sph.boundaries.heightfield import node_slopes


class HeightfieldTerrain:
    """Heights ``z`` (raster.shape, SPH frame; changed in place: the boundaries read it live) under a fluid
    of dimension ``dim``; never lowered below ``bedrock`` where one is given; water depth and speeds
    binned from ``near_bed`` (m) above the ground."""

    provides = FluidGrid.FIELDS
    report_key = "sediment_budget"

    def __init__(self, raster: Raster, z: np.ndarray, dim: int, *, bedrock=None, near_bed: float = np.inf):
        self.raster = raster
        self.z = np.ascontiguousarray(z, dtype=np.float64)
        if self.z.shape != raster.shape:
            raise ConfigError(f"The terrain has shape {self.z.shape}, its raster {raster.shape}; they must match.")
        self.bedrock = None if bedrock is None else np.asarray(bedrock, np.float64)
        self.grid = FluidGrid(raster, dim, ground=self.z, near=near_bed)
        self.z0 = self.z.copy()

    terrain = property(lambda self: self.z)
    values = property(lambda self: self.z)
    shape = property(lambda self: self.z.shape)
    unit_volume = property(lambda self: self.raster.cell_area)

    def fluid(self, solver) -> FluidGrid:
        """The fluid binned on the raster now (also without an eroder: the maps' running maxima)."""
        self.grid.bin(solver)
        return self.grid

    def refuse(self, inc, who: str) -> None:
        if self.bedrock is not None and np.any(self.z + inc.dz < self.bedrock - 1e-12):
            worst = float((self.bedrock - (self.z + inc.dz)).max())
            raise BudgetError(f"{who} cut {worst:.3g} m into the bedrock; it must not erode below the bedrock map.")

    def apply(self, dz: np.ndarray, t: float) -> None:
        self.z[...] = self.z + dz

    def budget(self, totals: dict[str, float], eroder) -> dict[str, Any]:
        """Volumes (m³): the terms, the terrain's change, closure = |eroded − deposited − suspended −
        carried off| / eroded."""
        eroded = totals["eroded"]
        closure = abs(eroded - totals["deposited"] - totals["suspended"] - totals["carried_off"])
        change = float((self.z - self.z0).sum() * self.raster.cell_area)
        return {"unit": "m3", **totals, "terrain_change": change,
                "closure_rel": closure / eroded if eroded > 0 else 0.0}  # fmt: skip

    def state_dict(self) -> dict[str, Any]:
        return {"terrain": self.z.copy(), **{f"grid_{k}": v for k, v in self.grid.state_dict().items()}}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.z[...] = np.asarray(state["terrain"])  # in place: the boundaries hold this array
        self.grid.load_state_dict({k[5:]: v for k, v in state.items() if k.startswith("grid_")})


class PorousHeightfieldTerrain:
    """Heights ``z`` (raster.shape, SPH frame; changed in place) over a
    :class:`~erosim.coupling.porous_ground.PorousGround` whose columns follow the surface when it changes
    (the splash kind, seed 003). The eroder is given this adapter (heights, their slopes, the ground and
    its moisture, the nodes ``outside`` the terrain) and sees the fluid's particles; the ground's pair
    weights for moisture diffusion (``diffusivity``, m²/s) are kept here and renewed where columns move."""

    provides = ("particles",)
    report_key = None  # the splash kind reports its own water and solid budgets

    def __init__(self, raster: Raster, z: np.ndarray, ground: PorousGround, diffusivity: float, *, outside=None):
        self.raster, self.z, self.ground = raster, z, ground
        self.outside = None if outside is None or not np.any(outside) else np.asarray(outside, bool)
        self.valid = None if self.outside is None else ~self.outside
        self.diffusivity = float(diffusivity)
        self.z0 = z.copy()
        self.sx, self.sy = node_slopes(z, raster.dx, raster.dy)
        self.weights = ground.weights(self.diffusivity)

    terrain = property(lambda self: self)
    values = property(lambda self: self.z)
    shape = property(lambda self: self.z.shape)
    unit_volume = property(lambda self: self.raster.cell_area)

    def fluid(self, solver):
        return solver

    def refuse(self, inc, who: str) -> None:
        """Nothing of its own: the eroder keeps every change off the nodes outside the terrain."""

    def write(self, fields: dict[str, np.ndarray]) -> None:
        self.ground.theta[...] = fields["theta"]

    def apply(self, dz: np.ndarray, t: float) -> None:
        """z += Δz, the slopes renewed, the ground's columns laid under the new surface."""
        self.z += dz
        self.sx[...], self.sy[...] = node_slopes(self.z, self.raster.dx, self.raster.dy)
        moved = self.ground.follow()
        if moved is None:
            self.weights = self.ground.weights(self.diffusivity)
        elif len(moved):
            self.weights[moved] = self.ground.weights(self.diffusivity, moved)

    def budget(self, totals: dict[str, float], eroder) -> dict[str, Any]:
        return dict(totals)

    def state_dict(self) -> dict[str, Any]:
        return {"terrain": self.z.copy(), **{f"ground_{k}": v for k, v in self.ground.state_dict().items()}}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.z[...] = np.asarray(state["terrain"])
        self.sx[...], self.sy[...] = node_slopes(self.z, self.raster.dx, self.raster.dy)
        self.ground.load_state_dict({k[7:]: v for k, v in state.items() if k.startswith("ground_")})
        self.weights = self.ground.weights(self.diffusivity)


def _node(terrain, flat: int) -> tuple[float, float, float]:
    """(x, y, z) of the field's node with C-order index ``flat``."""
    kz, ky, kx = np.unravel_index(flat, terrain.shape)
    ox, oy, oz = terrain.origin
    c = terrain.cell_size
    return ox + c * kx, oy + c * ky, oz + c * kz


class VoxelFieldTerrain:
    """A :class:`~erosim.terrain.voxel.VoxelTerrain`'s density field (SPEC VX-6), changed in place (the wall
    reads it live); the eroder sees the solver's particles.

    Two onsets are recorded. The *first transfer* (``first``: t, x, z; ``first_y``) is the time and place
    of the first transfer that lowers a solid node (density above the iso level; the node it lowers
    most): the ramp's nodes on the air side hold material too and are eroded by the same law, but their
    loss only steepens the ramp. One quantum (1/255 of a node) may come from a single particle's passing
    excess, which no observer would call the start of a breach. The *onset* (``onset``: t, x, y, z; the
    ``first_erosion`` of a run's report) is where the surface has first retreated past a grid point: the
    first coupling after which a node that was solid at the start is at or below the iso level — of
    several, the one that lost most. It is a local change of the surface by up to one cell, the least
    the field resolves as a moved surface at a place, and the counterpart of a laboratory's first
    visible scour; the overtopping validation judges it (:mod:`erosim.validation.overtopping`)."""

    provides = ("positions", "velocities")
    report_key = None  # the voxel kind reports the budget in its erosion entry

    def __init__(self, terrain):
        self.terrain = terrain
        self.initial = terrain.density.copy()
        self._solid0 = self.initial > terrain.iso
        self.first = np.full(3, np.nan)  # (t, x, z) of the first transfer
        self.first_y = np.nan
        self.onset = np.full(4, np.nan)  # (t, x, y, z) of the first solid node the surface passed

    values = property(lambda self: self.terrain.density)
    shape = property(lambda self: self.terrain.shape)
    unit_volume = property(lambda self: self.terrain.volume_per_unit)

    def fluid(self, solver):
        return solver

    def refuse(self, inc, who: str) -> None:
        """Nothing of its own: the eroders transfer whole quanta down to d_air at most."""

    def apply(self, dd: np.ndarray, t: float) -> None:
        """density += Δd (Δd is the exact float64 difference of float32 values, so the field takes exactly
        the eroder's new values), with the first transfer and the onset."""
        f = self.terrain
        if np.isnan(self.first[0]):
            lowered = np.where((dd < 0) & (f.density > f.iso), dd, 0.0)  # solid nodes (above the iso level) only
            if lowered.any():
                x, y, z = _node(f, int(np.argmin(lowered)))  # lowered most (first in C order)
                self.first[:] = (t, x, z)
                self.first_y = y
        f.density += dd  # float32 += exact float64 differences of float32 values
        if np.isnan(self.onset[0]):
            passed = self._solid0 & (f.density <= f.iso)
            if passed.any():
                loss = np.where(passed, self.initial - f.density, -np.inf)
                self.onset[:] = (t, *_node(f, int(np.argmax(loss))))  # lost most (first in C order)

    def budget(self, totals: dict[str, float], eroder) -> dict[str, Any]:
        """Volumes (m³): the terms, the eroder's pending and unmet erosion, the change of the field's solid
        volume, closure = |change + eroded − deposited| / eroded."""
        f = self.terrain
        change = float((f.density.astype(np.float64) - self.initial).sum() * f.volume_per_unit)
        eroded = totals["eroded"]
        closure = abs(change + eroded - totals["deposited"])
        return {
            "unit": "m3",
            **totals,
            "pending": eroder.pending_volume() if eroder is not None else 0.0,
            "unmet": eroder.unmet_total if eroder is not None else 0.0,
            "field_change": change,
            "closure_rel": closure / eroded if eroded > 0 else 0.0,
        }

    def state_dict(self) -> dict[str, Any]:
        return {"density": self.terrain.density.copy(), "first": np.append(self.first, self.first_y),
                "onset": self.onset.copy()}  # fmt: skip

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.terrain.density[...] = np.asarray(state["density"], np.float32)  # in place: the wall reads it
        first = np.asarray(state["first"], np.float64)
        self.first[:], self.first_y = first[:3], float(first[3])
        self.onset[:] = state["onset"] if "onset" in state else np.nan  # checkpoints before the onset was kept
