"""Porous ground particles laid on a heightmap in layers (seed 003 fig. 2; SPEC SP-1…SP-3).

Solid particles sampled on the terrain surface: columns on a square lattice of spacing s over the
map (x = x0 + (i + ½)s, y = y0 + (j + ½)s), ``layers`` particles deep under the Q4 surface at
z = ground(x, y) − (l + ½)s. Each has a porosity φ, a saturation θ ∈ [0, 1] (the share of its pores
holding water), a grain density ρ_s and — through θ — a yield strength (:mod:`erosim.erosion.wet_strength`).
It holds φs³θ m³ of water; the top layer (l = 0) is the surface that water touches and that
evaporates. Each layer may have its own permeability (a top soil over a subsoil): the pairs'
diffusion then scales with their harmonic-mean conductivity, and water drains down the columns by
Darcy's law (:func:`erosim.hydrology.seepage_darcy.drain`).

A DEM's nodata cells are outside the terrain: no column stands where the node nearest the column's
centre is nodata (``outside``), and a point over such a place belongs to the nearest column kept.

The particles are the soil's moisture carriers: when the heightmap changes (a crater, a deposit) every
column follows its ground (:meth:`PorousGround.follow`), keeping its water; the solid volume the
terrain gains or loses is the heightmap's (Σ Δz·A), counted by the eroder contract. The fluid feels
the ground through the heightmap's particle-free wall (:class:`~erosim.sph.boundaries.heightfield.HeightfieldGround`);
water passes into the particles by Darcy seepage (:mod:`erosim.hydrology.seepage_darcy`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from erosim.core.errors import ConfigError
from erosim.coupling.raster import Raster
from erosim.coupling.sampling import sample
from erosim.erosion.wet_strength import strength
from erosim.hydrology.seepage_darcy import harmonic
from erosim.kernels.sph_diffusion import pair_weights, pairs_within


@njit(cache=True)
def _distances(pos, i, j, out):
    for p in range(i.size):
        a, b = i[p], j[p]
        out[p] = math.sqrt((pos[a, 0] - pos[b, 0]) ** 2 + (pos[a, 1] - pos[b, 1]) ** 2 + (pos[a, 2] - pos[b, 2]) ** 2)
    return out


#: the diffusion support in ground spacings (Wendland C2: about 50 neighbours in 3-D)
SUPPORT = 2.0


class PorousGround:
    """Layers of porous particles under ``terrain`` (raster.shape, SPH frame, read live)."""

    def __init__(self, raster: Raster, terrain: np.ndarray, spacing: float, layers: int, porosity: float,
                 saturation: float, density: float, permeability=None, outside: np.ndarray | None = None):  # fmt: skip
        """``permeability``: None (uniform ground) or one k_p (m²) per layer, top first; ``outside``: None
        or a mask (raster.shape) of the nodes outside the terrain (a DEM's nodata), where no column stands."""
        self.raster, self.terrain = raster, terrain
        self.s = s = float(spacing)
        self.layers = int(layers)
        xe, ye = (raster.nx - 1) * raster.dx, (raster.ny - 1) * raster.dy
        self.ncx, self.ncy = max(1, int(math.floor(xe / s + 1e-9))), max(1, int(math.floor(ye / s + 1e-9)))
        xs = raster.x0 + (np.arange(self.ncx) + 0.5) * s
        ys = raster.y0 + (np.arange(self.ncy) + 0.5) * s
        gx, gy = np.meshgrid(xs, ys)  # (ncy, ncx): lattice site k = j·ncx + i
        sites = np.column_stack([gx.ravel(), gy.ravel()])
        keep = np.ones(len(sites), bool)
        if outside is not None and np.any(outside):
            ix = np.clip(np.floor((sites[:, 0] - raster.x0) / raster.dx + 0.5).astype(np.int64), 0, raster.nx - 1)
            iy = np.clip(np.floor((sites[:, 1] - raster.y0) / raster.dy + 0.5).astype(np.int64), 0, raster.ny - 1)
            keep = ~np.asarray(outside, bool)[iy, ix]
            if not keep.any():

                raise ConfigError("Every ground column would stand over the DEM's nodata cells; give a DEM with more "
                                  "valid cells or a smaller ground spacing.")  # fmt: skip
        self.xy = sites[keep]
        self.ncol = len(self.xy)
        # each lattice site → its column, or the nearest kept column's where none stands there
        index = np.full(len(sites), -1, np.int64)
        index[keep] = np.arange(self.ncol)
        if not keep.all():
            from scipy import ndimage

            _, (jj, ii) = ndimage.distance_transform_edt(~keep.reshape(self.ncy, self.ncx), return_indices=True)
            index = index.reshape(self.ncy, self.ncx)[jj, ii].ravel()
        self.site_column = index
        n = self.ncol * self.layers
        self.pos = np.zeros((n, 3))
        self.pos[:, :2] = np.tile(self.xy, (self.layers, 1))
        self.depth = np.repeat((np.arange(self.layers) + 0.5) * s, self.ncol)
        self.volume = s**3
        self.area = s * s
        self.porosity = np.full(n, float(porosity))
        self.pore = self.porosity * self.volume
        self.theta = np.full(n, float(saturation))
        self.density = np.full(n, float(density))  # grain density of each particle (kg/m³)
        self.layered = permeability is not None
        perm = np.ones(self.layers) if permeability is None else np.asarray(permeability, float)
        if perm.shape != (self.layers,):
            raise ValueError(f"permeability has {perm.size} values for {self.layers} layers; give one per layer.")
        self.permeability = np.repeat(perm, self.ncol)  # k_p of each particle (m²)
        self.upper = np.arange(self.ncol * (self.layers - 1))  # each particle over another, and that one
        self.lower = self.upper + self.ncol
        self.surface = np.zeros(n, bool)
        self.surface[: self.ncol] = True
        self.column = np.tile(np.arange(self.ncol), self.layers)  # the column of each particle
        self.follow()

    @property
    def n(self) -> int:
        return len(self.theta)

    def follow(self, full: bool = False) -> np.ndarray | None:
        """Lay every column under the current ground (after the terrain changed); the pairs' distances
        follow. The pairs themselves are those within 1.1 h of the first laying (columns only move
        vertically, by a crater's or a deposit's depth, so a pair leaves the support, where its weight is
        0, long before a new one could enter). Only the pairs with a column that moved are measured
        again (the others' distances are unchanged, bit for bit); returns their indices, or None when
        every pair was (the first laying, ``full``)."""
        top = sample(self.raster, self.terrain, np.column_stack([self.xy, np.zeros(self.ncol)]))
        self.h = SUPPORT * self.s
        first = not hasattr(self, "i")
        if first:
            self.pos[:, 2] = np.tile(top, self.layers) - self.depth
            i, j, _ = pairs_within(self.pos, 1.1 * self.h)
            self.i, self.j = i.astype(np.int32), j.astype(np.int32)
            self._ci, self._cj = self.column[self.i], self.column[self.j]
        if first or full:
            self.pos[:, 2] = np.tile(top, self.layers) - self.depth
            self._top = top
            self._r = _distances(self.pos, self.i, self.j, np.empty(len(self.i)))
            return None
        moved = top != self._top
        if not moved.any():
            return np.zeros(0, np.int64)
        self._top = top
        self.pos[:, 2] = np.tile(top, self.layers) - self.depth
        pairs = np.flatnonzero(moved[self._ci] | moved[self._cj])
        self._r[pairs] = _distances(self.pos, self.i[pairs], self.j[pairs], np.empty(len(pairs)))
        return pairs

    def water(self) -> float:
        """m³ of water held in the pores."""
        return float((self.theta * self.pore).sum())

    def weights(self, diffusivity: float, pairs: np.ndarray | None = None) -> np.ndarray:
        """Pair weights D φ̄ V² L(r) of the moisture diffusion (seepage_darcy's docstring); in a layered
        ground D = ``diffusivity``·K̄_ij/K_top, K̄ the pair's harmonic-mean conductivity. ``pairs``: only
        those pairs' weights (in that order), else every pair's."""
        i, j = (self.i, self.j) if pairs is None else (self.i[pairs], self.j[pairs])
        r = self._r if pairs is None else self._r[pairs]
        phi = 0.5 * (self.porosity[i] + self.porosity[j])
        if self.layered and self.permeability[0] > 0:

            phi = phi * harmonic(self.permeability[i], self.permeability[j]) / self.permeability[0]
        return phi * pair_weights(r, self.h, 3, self.volume, self.volume, diffusivity)

    def column_of(self, xy: np.ndarray) -> np.ndarray:
        """Index of the column (= its surface particle) under horizontal points ``xy`` (k, 2)."""
        r = self.raster
        i = np.clip(np.floor((xy[:, 0] - r.x0) / self.s).astype(np.int64), 0, self.ncx - 1)
        j = np.clip(np.floor((xy[:, 1] - r.y0) / self.s).astype(np.int64), 0, self.ncy - 1)
        return self.site_column[j * self.ncx + i]

    def columns_near(self, xy: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The lattice's columns whose centres lie within ``radius`` of each point ``xy`` (k, 2): (point
        index, column index, horizontal distance) per pair; a site without a column (nodata) counts as the
        nearest kept column's, sites beyond the map are left out (every point keeps its own column)."""
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        r, s, m = self.raster, self.s, int(math.ceil(radius / self.s)) + 1
        fi = (xy[:, 0] - r.x0) / s - 0.5
        fj = (xy[:, 1] - r.y0) / s - 0.5
        off = np.arange(-m, m + 1)
        di, dj = (a.ravel() for a in np.meshgrid(off, off))
        i = np.rint(fi).astype(np.int64)[:, None] + di[None, :]
        j = np.rint(fj).astype(np.int64)[:, None] + dj[None, :]
        d = np.hypot((i - fi[:, None]) * s, (j - fj[:, None]) * s)
        ok = (d < radius) & (i >= 0) & (i < self.ncx) & (j >= 0) & (j < self.ncy)
        own = self.column_of(xy)
        pt = np.broadcast_to(np.arange(len(xy))[:, None], d.shape)[ok]
        col = self.site_column[(j * self.ncx + i)[ok]]
        dist = d[ok]
        lone = np.bincount(pt, minlength=len(xy)) == 0  # a point farther than radius from every centre
        if lone.any():
            k = np.flatnonzero(lone)
            pt, col = np.concatenate([pt, k]), np.concatenate([col, own[k]])
            dist = np.concatenate([dist, np.zeros(len(k))])
        return pt, col, dist

    def surface_map(self, values: np.ndarray | None = None) -> np.ndarray:
        """A surface particles' value (default θ) at every node of the raster (the column over the node)."""
        v = self.theta if values is None else values
        xs, ys = self.raster.nodes()
        gx, gy = np.meshgrid(xs, ys)
        cols = self.column_of(np.column_stack([gx.ravel(), gy.ravel()]))
        return v[cols].reshape(self.raster.shape)

    def strength(self, sigma_dry: float, sigma_wet: float) -> np.ndarray:
        """Each particle's yield strength σ_s(θ) (Pa; :mod:`erosim.erosion.wet_strength`)."""

        return strength(self.theta, sigma_dry, sigma_wet)

    def state_dict(self) -> dict:
        return {"theta": self.theta.copy(), "z": self.pos[:, 2].copy()}

    def load_state_dict(self, state: dict) -> None:
        self.theta[...] = state["theta"]
        self.follow(full=True)  # the terrain is restored first (by its owner); the columns lie under it
