"""The 3-D SPH flood (``flood.solver = "sph3d"``): the thesis's own method (seed 000 §3.3, SPEC FL-1)
on the flood set-up shared with the shallow-water solver.

The weakly compressible SPH fluid (:class:`erosim.sph.solver.SPHSolver`) runs over the breached DEM
as the particle-free heightfield ground (Harada 2007 wall weights), in the SPH frame (x east, y
north from the south-west node, z up); walls (nodata cells, the barrier outside its window) are the
ground raised above the reservoir; closed map edges are plane walls; open ones remove the water that
crosses them. The reservoir is a lattice of spacing Δx over the set-up's reservoir cells from the
ground up to the level (so the dam holds it and nothing else connects it).

:class:`SPHFlood` presents the solver to the flood kind as :class:`ShallowWaterSPH` does: the hazard
maxima come from the shallow-water solver's reconstruction at the cell centres every ``every`` steps
(:meth:`SPHFlood.update_maxima`: the particles' 2-D SPH sum seen from above, cut at their columns'
surface), gauges read the particles binned into columns (the depth of a column is Σ m/ρ over its
cell, its speed the column's mean; :mod:`erosim.sph.depth_columns`), and the water budget is the
solver's mass budget in m³.

The ``thesis`` preset reproduces the thesis's particle (m = 125 kg, so Δx = 0.5 m) with a time step
from the CFL and viscous limits instead of its Δt = 0.1 s, which no stable SPH step reaches at that
spacing; `erosim describe flood` and the estimate before the run state what that costs.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from erosim.core.errors import ConfigError
from erosim.coupling.raster import Raster
from erosim.coupling.sampling import sample
from erosim.coupling.sources import EdgeOutflow
from erosim.sph import kernels_swe as K
from erosim.sph.boundaries.heightfield import HeightfieldGround
from erosim.sph.boundaries.planes import PlaneWalls
from erosim.sph.depth_columns import column_fields
from erosim.sph.manning_columns import ManningColumns
from erosim.sph.params import SPHParams
from erosim.sph.shallow_water_vacondio2012 import ShallowWaterParams, wall_distance
from erosim.sph.solver import SPHSolver


class SPHFlood:
    """A 3-D SPH fluid over the flood's DEM, with the interface of the shallow-water model."""

    name = "sph3d"

    def __init__(
        self, site, spacing: float, open_edges, *, manning=0.0, every: int = 5, seed: int = 1,
        margin_speed: str = "conveyance",
    ):  # fmt: skip

        hm = site.terrain
        ny, nx = hm.shape
        cs = hm.cell_size
        if spacing > 2.0 * cs:
            raise ConfigError(
                f"flood.spacing = {spacing:g} m is more than two DEM cells ({cs:g} m): the 3-D particles cannot "
                f"follow the ground; use flood.spacing ≤ {2 * cs:g} m or the shallow-water solver."
            )
        self.site, self.spacing, self.every, self.cell = site, float(spacing), int(every), cs
        self.conveyance = K.MARGIN_SPEED[margin_speed]  # the maps' speed at the water's edge (kernels_swe)
        self.raster = Raster(0.0, 0.0, cs, cs, nx, ny)
        top = site.level + max(2.0, 0.1 * float(site.depth0.max()))
        ground = np.ascontiguousarray(hm.z[::-1], dtype=np.float64)
        ground[site.wall[::-1]] = np.maximum(ground[site.wall[::-1]], top)
        self.ground = ground
        fluid = self._reservoir(ground)
        if len(fluid) == 0:
            raise ConfigError(f"No particle fits the reservoir at flood.spacing = {spacing:g} m; give a smaller one.")
        fall = site.level - float(ground.min())
        g = 9.81
        params = SPHParams(dim=3, spacing=spacing, walls="reflect", sound_speed=10.0 * math.sqrt(2 * g * fall))
        h = params.support()
        lo = [-4 * h, -4 * h, float(ground.min()) - 4 * h]
        hi = [(nx - 1) * cs + 4 * h, (ny - 1) * cs + 4 * h, top + max(10 * h, 0.5 * fall)]
        walls = {"west": ([0, 0, 0], [1, 0, 0]), "east": ([(nx - 1) * cs, 0, 0], [-1, 0, 0]),
                 "south": ([0, 0, 0], [0, 1, 0]), "north": ([0, (ny - 1) * cs, 0], [0, -1, 0])}  # fmt: skip
        closed = [w for name, w in walls.items() if name not in open_edges]
        self._col_shape = (int(math.ceil((ny - 1) * cs / spacing)), int(math.ceil((nx - 1) * cs / spacing)))
        n_map = manning if np.isscalar(manning) else np.asarray(manning, np.float64)[::-1]
        boundaries = [HeightfieldGround(self.raster, ground, slip=True),
                      ManningColumns(n_map, spacing, self._col_shape, cs, g)]  # fmt: skip
        if closed:
            boundaries.append(PlaneWalls([p for p, _ in closed], [n for _, n in closed]))
        self.solver = SPHSolver(params, fluid, domain_lo=lo, domain_hi=hi, seed=seed, boundaries=boundaries)
        self.open_edges = tuple(open_edges)

        self._outflow = EdgeOutflow(None, self.solver, self.raster, self.open_edges)
        self.volume_initial = self.budget()["volume_initial_m3"]
        self.settle_steps = 0
        self._map_fixed = None  # (walls, their distance, ground, H) of the hazard maps, made at first use

    def _reservoir(self, ground: np.ndarray) -> np.ndarray:
        """Columns of particles over the reservoir, stacked from the ground up, holding its volume.

        A square lattice of spacing Δx over the reservoir's cells gives the columns; column c of depth
        D_c = level − z(x_c) gets n_c particles at z(x_c) + (k + ½)Δx, k < n_c (each particle the cube
        of water Δx³ it stands for, the lowest resting on the ground as the wall weights hold it).
        The counts follow D_c/Δx by error diffusion along the columns, scaled so that Σ n_c Δx³ is the
        set-up's reservoir volume Σ (level − z)·Δ² to within one particle — the same water the
        shallow-water solver starts with. (A lattice of fixed levels kept only the points more than
        0.4 Δx above the ground: it lost 0.4 Δx of every column, half the water of a shallow reservoir.)
        """

        s, cs = self.spacing, self.cell
        ny, nx = ground.shape
        x = np.arange(0.5 * s, (nx - 1) * cs, s)
        y = np.arange(0.5 * s, (ny - 1) * cs, s)
        X, Y = (a.ravel() for a in np.meshgrid(x, y))
        col = np.clip(np.floor(X / cs + 0.5).astype(np.int64), 0, nx - 1)
        row = np.clip(np.floor(Y / cs + 0.5).astype(np.int64), 0, ny - 1)
        inside = self.site.depth0[::-1][row, col] > 0
        X, Y = X[inside], Y[inside]
        z0 = sample(self.raster, ground, np.column_stack([X, Y, np.zeros_like(X)]))
        depth = np.maximum(self.site.level - z0, 0.0)
        volume = float(self.site.depth0.sum()) * cs * cs
        if depth.sum() <= 0.0:
            return np.zeros((0, 3))
        cum = np.cumsum(depth) * (volume / (float(depth.sum()) * s**3))
        counts = np.diff(np.concatenate([[0], np.floor(cum + 0.5).astype(np.int64)]))
        k = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
        Xr, Yr, Zr = (np.repeat(a, counts) for a in (X, Y, z0))
        return np.column_stack([Xr, Yr, Zr + (k + 0.5) * s])

    # ------------------------------------------------------------------ the model protocol

    @property
    def t(self) -> float:
        return self.solver.t

    @property
    def time(self) -> float:
        return self.solver.t

    @property
    def n(self) -> int:
        return self.solver.n_fluid

    @property
    def steps(self) -> int:
        return self.solver.steps

    def advance(self) -> None:
        self.solver.step()
        self._outflow()  # water past an open edge leaves (counted by the solver's mass budget)

    def state_dict(self) -> dict:
        return self.solver.state_dict()

    def load_state_dict(self, state: dict) -> None:
        self.solver.load_state_dict(state)

    # ------------------------------------------------------------------ what the flood kind reads

    def _columns(self):
        """The water column under every particle (:func:`erosim.sph.depth_columns.column_fields`)."""

        st = self.solver.state
        n = st.n_fluid
        return column_fields(st.pos[:n], st.vel[:n], self.solver.m / st.rho[:n], self.spacing, self._col_shape)

    def sync_maxima(self, maps) -> None:
        """The maxima are raised in ``maps``' own arrays (nothing to bring back)."""

    def update_maxima(self, maps, wet: float) -> None:
        """The hazard maxima from the shallow-water solver's map reconstruction
        (:meth:`ShallowWaterSPH.update_maxima <erosim.sph.shallow_water_vacondio2012.ShallowWaterSPH.update_maxima>`):
        at each cell centre the depth d(x) = Σ_j V_j W(|x − x_j|, H) of the particles seen from above
        (x_j their plan positions, V_j = m/ρ_j), cut at the Shepard mean of their columns' surfaces
        less the ground, with the Shepard mean of their columns' speeds; walls blind the sum. The 2-D
        kernel's support is H = ``flood.support`` (3) × the spacing: the particles' columns stand a
        spacing apart, so H spans the neighbouring columns as the shallow-water solver's spans its
        neighbours, and water spread thinner than one layer of particles maps as thin as it is.
        Every ``every`` steps."""
        if self.solver.steps % self.every:
            return

        n = self.solver.n_fluid
        if n == 0:
            return
        d_i, u_i, _, _ = self._columns()
        st = self.solver.state
        ny, nx = self.site.terrain.shape
        if self._map_fixed is None:
            wall = np.ascontiguousarray(self.site.wall, dtype=np.bool_)
            bed = np.ascontiguousarray(self.site.terrain.z, dtype=np.float64)
            self._map_fixed = (wall, wall_distance(wall, self.cell), bed, ShallowWaterParams().support * self.spacing)
        wall, wall_dist, bed, h = self._map_fixed
        # the SPH frame (y north from the south-west node) → the cell frame (y = row·Δ, row 0 north)
        pos = np.ascontiguousarray(np.column_stack([st.pos[:n, 0], (ny - 1) * self.cell - st.pos[:n, 1]]))
        vel = np.ascontiguousarray(np.column_stack([u_i[:, 0], -u_i[:, 1]]))
        vol = np.ascontiguousarray(self.solver.m / st.rho[:n])
        depth = np.ascontiguousarray(d_i)
        hsup = np.full(n, h)
        inv = 1.0 / self.cell
        eta = np.empty(n)
        K.surfaces(pos, depth, bed, n, inv, eta)
        (xmin, ymin), (xmax, ymax) = pos.min(axis=0), pos.max(axis=0)
        c_lo, c_hi = max(int((xmin - h) * inv), 0), min(int((xmax + h) * inv) + 1, nx - 1)
        r_lo, r_hi = max(int((ymin - h) * inv), 0), min(int((ymax + h) * inv) + 1, ny - 1)
        sums = np.zeros((max(r_hi - r_lo + 1, 0), max(c_hi - c_lo + 1, 0), K.MAP_SUMS))
        K.scatter_sums(pos, vel, vol, hsup, depth, eta, n, self.cell, r_lo, c_lo, wall, wall_dist, sums)
        K.raise_maxima(
            sums, r_lo, c_lo, bed, self.solver.t, wet, maps.max_depth, maps.max_speed, maps.max_dv, maps.arrival,
            wall, self.conveyance,
        )  # fmt: skip

    def _at_nodes(self) -> tuple[np.ndarray, np.ndarray]:
        """(depth, speed) of the smoothed columns at the DEM's nodes, map order (row 0 north)."""
        _, _, (depth, ux, uy), _ = self._columns()
        ny, nx = self.site.terrain.shape
        s = self.spacing
        col = np.clip(np.floor(np.arange(nx) * self.cell / s).astype(np.int64), 0, depth.shape[1] - 1)
        row = np.clip(np.floor(np.arange(ny) * self.cell / s).astype(np.int64), 0, depth.shape[0] - 1)
        d = depth[np.ix_(row, col)]
        v = np.hypot(ux, uy)[np.ix_(row, col)]
        return d[::-1].copy(), v[::-1].copy()

    def depth_grid(self) -> np.ndarray:
        return self._at_nodes()[0]

    def sample(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(surface, depth, speed) of the smoothed column at each point (points in the SWE cell frame)."""
        _, _, (depth, ux, uy), _ = self._columns()
        pts = np.asarray(points, np.float64).reshape(-1, 2)
        ny = self.site.terrain.shape[0]
        x, y = pts[:, 0], (ny - 1) * self.cell - pts[:, 1]
        ix = np.clip(np.floor(x / self.spacing).astype(np.int64), 0, depth.shape[1] - 1)
        iy = np.clip(np.floor(y / self.spacing).astype(np.int64), 0, depth.shape[0] - 1)
        d = depth[iy, ix]
        col = np.clip(np.floor(pts[:, 0] / self.cell + 0.5).astype(np.int64), 0, self.site.terrain.shape[1] - 1)
        row = np.clip(np.floor(pts[:, 1] / self.cell + 0.5).astype(np.int64), 0, ny - 1)
        return self.site.terrain.z[row, col] + d, d, np.hypot(ux, uy)[iy, ix]

    def budget(self) -> dict:
        """Water at rest (m³, mass/ρ₀): initial = in the flow + out through open edges (particle counts,
        so the closure is exact)."""
        b = self.solver.budget()
        rho0 = self.solver.params.rho0
        out = sum(b["removed"].values()) / rho0
        return {
            "volume_initial_m3": b["initial"] / rho0,
            "volume_out_m3": out,
            "volume_in_flow_m3": b["in_fluid"] / rho0,
            "closure_rel": b["closure_rel"],
        }

    @property
    def volume_out(self) -> float:
        return self.budget()["volume_out_m3"]

    def stats(self) -> dict[str, Any]:
        return {"particles": self.n, "steps": self.steps, "splits": 0, "settle_steps": 0,
                "last_dt_s": float(self.solver.last_dt)}  # fmt: skip
