"""Voxel terrain (SPEC VX-1, VX-2, VX-8): a 3-D density field whose iso-surface is the ground, able to
hold what a heightmap cannot — overhangs, caves, undercut banks.

The field
---------
``density[iz, iy, ix]`` (float32, C-contiguous) at the nodes ``(x, y, z) = origin + (ix, iy, iz)·Δ``
(Δ the cell size in metres, z up, y the SPH frame's second axis — northward for a map). The field
takes values in a nominal range ``[d_air, d_solid]`` — ``(0, 1)`` by default, ``(0, 255)`` for the
seed's byte fields (a ``uint8`` array gets that range and ISO = 127.5 unless told otherwise) — and
**the solid is where d > ISO**. The solid volume a node stands for is ``(d − d_air)/(d_solid − d_air)·Δ³``
(:meth:`VoxelTerrain.solid_volume`), the measure the erosion budget conserves.

Every constructor here writes a **linear ramp of a signed distance** s (positive in the solid):

    d = d_air + (d_solid − d_air) · clamp(½ + s/(2b), 0, 1),

with b the ramp's half-width (``band``, default 4 cells). Inside the ramp d is linear in the
distance to the surface, so the distance l = (ISO − d)/|∇d| of SPEC VX-3
(:mod:`erosim.kernels.voxel`) is exact on planes and accurate to O(Δ²κ) on curved surfaces, out to
b − √3Δ from the surface on either side (the 8 nodes around the point must lie in the ramp): that
must cover the SPH kernel's support h for the wall weights, b ≥ h + √3Δ (the default 4Δ does for
voxels no coarser than the particle spacing at h = 2Δx).

* from a **heightmap** (:meth:`VoxelTerrain.from_heightmap`, any :class:`~erosim.core.heightmap.Heightmap`):
  s = (z_g(x, y) − z)·n_z, the distance to the tangent plane of the bilinearly resampled ground
  (n_z = 1/√(1 + |∇z_g|²)), smooth across the surface;
* from **primitive shapes** (:class:`Box`, :class:`Sphere`, :class:`HalfSpace`, :class:`Embankment`,
  a trapezoid across a flume) by their signed distance functions (Quílez's box and sphere SDFs; the
  embankment and half-spaces as intersections of planes), combined on a common grid by
  **max / min**: union d = max(d₁, d₂), intersection d = min(d₁, d₂), difference
  d = min(d₁, d_air + d_solid − d₂) (:meth:`VoxelTerrain.union`, ``intersection``, ``difference``);
* from **3-D noise** for caves (VX-8; :meth:`VoxelTerrain.from_noise`, :meth:`VoxelTerrain.carve_caves`):
  fBm of OpenSimplex2 noise from FastNoise Lite (as :mod:`erosim.terrain.generate`) at the nodes'
  physical positions, n(p) = (1 − g) Σ_k gᵏ N_k(2ᵏ p/L); solid where n > t, with s ≈ (n − t)·L/(2π)
  (the distance for a unit sine of wavelength L near its zero).

Memory: the field is 4 bytes a node, **4 MB per 10⁶ cells** (:func:`memory_bytes`); the shear-stress
erosion adds its float64 accumulator (8 MB per 10⁶) and a float64 increment while it runs (8 MB).
A heightmap that would need more than ``max_bytes`` at the requested voxel size is refused with one
sentence before anything is allocated.

Outputs
-------
* the **surface mesh** by marching cubes (Lorensen & Cline 1987, the 256-case table; scikit-image's
  ``measure.marching_cubes``, Lewiner et al. 2003), closed at the grid's faces by padding with air
  so that a solid gives a watertight mesh, outward normals; written as OBJ, PLY or glTF binary
  (``.glb``) by trimesh (:meth:`VoxelTerrain.export_mesh`);
* **cross-sections** as figures (:meth:`VoxelTerrain.cross_section`);
* the field as ``.npz`` (:meth:`VoxelTerrain.save`, :meth:`VoxelTerrain.load`) and as VTK image
  data ``.vti`` that ParaView opens (:meth:`VoxelTerrain.write_vti`, :mod:`erosim.io.volumes`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from erosim.core.atomic import save_npz, write_bytes
from erosim.core.errors import ConfigError, InputError
from erosim.core.heightmap import Heightmap
from erosim.io.volumes import write_vti
from erosim.kernels.raster import bilinear_points
from erosim.kernels.voxel import wall_distance
from erosim.viz.plots import voxel_section

#: bytes per node of the density field (float32)
BYTES_PER_NODE = 4
#: default half-width of the density ramp, in cells
BAND_CELLS = 4.0
#: default largest field a heightmap may be turned into (bytes)
MAX_BYTES = 4 * 2**30
_SLAB = 1 << 21  # nodes per evaluation block of a constructor


def memory_bytes(n_cells: int, erosion: bool = False) -> int:
    """Bytes of a field of ``n_cells`` nodes (4 each), plus the erosion's accumulator and increment (16 each)."""
    return int(n_cells) * (BYTES_PER_NODE + (16 if erosion else 0))


def ramp(s: np.ndarray, band: float, value_range: tuple[float, float]) -> np.ndarray:
    """Density (float32) of a signed distance ``s`` (m, positive in the solid): the module docstring's ramp."""
    lo, hi = value_range
    t = np.clip(0.5 + np.asarray(s, np.float64) / (2.0 * band), 0.0, 1.0)
    return (lo + (hi - lo) * t).astype(np.float32)


# --------------------------------------------------------------------------------------------- shapes


@dataclass(frozen=True)
class Box:
    """The axis-aligned box ``lo``–``hi`` (m)."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]

    def sdf(self, x, y, z):
        """Signed distance (m), negative inside (exact)."""
        c = [(a + b) / 2 for a, b in zip(self.lo, self.hi, strict=True)]
        e = [(b - a) / 2 for a, b in zip(self.lo, self.hi, strict=True)]
        q = [np.abs(p - ci) - ei for p, ci, ei in zip((x, y, z), c, e, strict=True)]
        out = np.sqrt(sum(np.maximum(qi, 0.0) ** 2 for qi in q))
        return out + np.minimum(np.maximum(np.maximum(q[0], q[1]), q[2]), 0.0)


@dataclass(frozen=True)
class Sphere:
    """The ball of ``radius`` (m) around ``centre``."""

    centre: tuple[float, float, float]
    radius: float

    def sdf(self, x, y, z):
        """Signed distance (m), negative inside (exact)."""
        cx, cy, cz = self.centre
        return np.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) - self.radius


@dataclass(frozen=True)
class HalfSpace:
    """The solid behind the plane through ``point`` with unit ``normal`` pointing out of the solid
    (into the fluid): a floor has normal (0, 0, 1), a 45° wall e.g. (−1, 0, 1)/√2."""

    point: tuple[float, float, float]
    normal: tuple[float, float, float]

    def sdf(self, x, y, z):
        """Signed distance (m), negative inside (exact)."""
        n = np.asarray(self.normal, np.float64)
        n = n / np.linalg.norm(n)
        px, py, pz = self.point
        return (x - px) * n[0] + (y - py) * n[1] + (z - pz) * n[2]


@dataclass(frozen=True)
class Embankment:
    """A trapezoidal embankment across a flume along x: its upstream toe at ``x_toe``, ``height`` above
    ``base``, a crest ``crest_width`` wide, slopes ``upstream`` and ``downstream`` as horizontal:vertical
    ratios (2.0 = 2 m across for 1 m up), across y from ``y_lo`` to ``y_hi`` (infinite by default)."""

    x_toe: float
    height: float
    crest_width: float
    upstream: float
    downstream: float
    base: float = 0.0
    y_lo: float = -math.inf
    y_hi: float = math.inf

    @property
    def x_heel(self) -> float:
        """x of the downstream toe."""
        return self.x_toe + self.height * (self.upstream + self.downstream) + self.crest_width

    def sdf(self, x, y, z):
        """Signed distance (m), negative inside: the intersection of its planes (exact near the faces,
        a lower bound outside near the edges)."""
        top = self.base + self.height
        x1 = self.x_toe + self.height * self.upstream  # upstream crest edge
        x2 = x1 + self.crest_width
        su = math.hypot(1.0, self.upstream)
        sd = math.hypot(1.0, self.downstream)
        d = np.maximum(self.base - z, z - top)
        d = np.maximum(d, ((self.x_toe - x) + self.upstream * (z - self.base)) / su)  # upstream face
        d = np.maximum(d, ((x - x2) - self.downstream * (top - z)) / sd)  # downstream face
        if math.isfinite(self.y_lo):
            d = np.maximum(d, self.y_lo - y)
        if math.isfinite(self.y_hi):
            d = np.maximum(d, y - self.y_hi)
        return d


# --------------------------------------------------------------------------------------------- noise


def fbm3(seed: int, x, y, z, wavelength: float, octaves: int = 3, gain: float = 0.5) -> np.ndarray:
    """3-D fBm n = (1 − g) Σ_k gᵏ N_k(2ᵏ p/L) of OpenSimplex2 noise at physical points (|n| ≲ 1)."""
    from pyfastnoiselite.pyfastnoiselite import FastNoiseLite, FractalType, NoiseType

    pts = np.stack([np.ravel(x), np.ravel(y), np.ravel(z)]).astype(np.float64)
    out = np.zeros(pts.shape[1])
    amp, freq = 1.0, 1.0 / wavelength
    states = np.random.SeedSequence(int(seed) & 0xFFFFFFFFFFFFFFFF).generate_state(octaves)
    for k in range(octaves):
        f = FastNoiseLite(int(states[k]) & 0x3FFFFFFF)
        f.noise_type = NoiseType.NoiseType_OpenSimplex2
        f.fractal_type = FractalType.FractalType_None
        f.frequency = 1.0
        out += amp * np.asarray(f.gen_from_coords((pts * freq).astype(np.float32)), np.float64)
        amp *= gain
        freq *= 2.0
    return ((1.0 - gain) * out).reshape(np.shape(x))


# --------------------------------------------------------------------------------------------- terrain


def _ranges(density: np.ndarray, iso, value_range):
    if value_range is None:
        value_range = (0.0, 255.0) if density.dtype == np.uint8 else (0.0, 1.0)
    lo, hi = (float(v) for v in value_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise ConfigError(f"The density range ({lo:g}, {hi:g}) is empty; give (air, solid) with solid > air.")
    iso = 0.5 * (lo + hi) if iso is None else float(iso)
    if not (lo < iso < hi):
        raise ConfigError(
            f"The iso level {iso:g} lies outside the density field's range ({lo:g}, {hi:g}); "
            f"choose a level between them, e.g. {0.5 * (lo + hi):g}."
        )
    return iso, (lo, hi)


class VoxelTerrain:
    """A voxel density field (see the module docstring): ``density[iz, iy, ix]`` float32, ``cell_size``
    Δ (m), ``origin`` the (x, y, z) of node (0, 0, 0), ``iso`` the level (solid above it),
    ``value_range`` (d_air, d_solid), ``band`` the ramp's half-width (m; None when unknown)."""

    def __init__(self, density, cell_size: float, origin=(0.0, 0.0, 0.0), iso: float | None = None,
                 value_range: tuple[float, float] | None = None, band: float | None = None):  # fmt: skip
        density = np.asarray(density)
        if density.ndim != 3 or min(density.shape) < 2:
            raise InputError(
                f"A voxel density field must be a 3-D array of at least 2 nodes per axis, got shape {density.shape}."
            )
        if not np.issubdtype(density.dtype, np.number):
            raise InputError(f"A voxel density field must hold numbers, got {density.dtype}.")
        self.iso, self.value_range = _ranges(density, iso, value_range)
        try:
            cs = float(cell_size)
        except (TypeError, ValueError):
            cs = float("nan")
        if not (math.isfinite(cs) and cs > 0):
            raise ConfigError(f"Voxel cell size {cell_size!r} is not valid; give a positive number of metres.")
        self.cell_size = cs
        self.origin = tuple(float(v) for v in np.asarray(origin, np.float64).reshape(3))
        self.density = np.ascontiguousarray(density, dtype=np.float32)
        if not np.all(np.isfinite(self.density)):
            raise InputError("The voxel density field holds NaN or infinite values; fill them before use.")
        lo, hi = self.value_range
        dmin, dmax = float(self.density.min()), float(self.density.max())
        if dmin < lo or dmax > hi:
            raise InputError(
                f"Voxel densities span {dmin:g}–{dmax:g}, outside the field's range ({lo:g}, {hi:g}); "
                "rescale them or give the matching value_range."
            )
        self.band = None if band is None else float(band)

    # ---------------------------------------------------------------- geometry

    @property
    def shape(self) -> tuple[int, int, int]:
        """(nz, ny, nx) nodes."""
        return self.density.shape

    @property
    def lo(self) -> np.ndarray:
        """(x, y, z) of the first node."""
        return np.array(self.origin)

    @property
    def hi(self) -> np.ndarray:
        """(x, y, z) of the last node."""
        nz, ny, nx = self.shape
        return self.lo + self.cell_size * np.array([nx - 1, ny - 1, nz - 1])

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Node coordinates (x, y, z) along each axis (m)."""
        nz, ny, nx = self.shape
        ox, oy, oz = self.origin
        d = self.cell_size
        return ox + d * np.arange(nx), oy + d * np.arange(ny), oz + d * np.arange(nz)

    @property
    def volume_per_unit(self) -> float:
        """Solid volume (m³) one density unit of one node stands for: Δ³/(d_solid − d_air)."""
        lo, hi = self.value_range
        return self.cell_size**3 / (hi - lo)

    def solid_volume(self) -> float:
        """Σ (d − d_air)/(d_solid − d_air)·Δ³ over the nodes (m³): the volume erosion budgets conserve."""
        return float((self.density.astype(np.float64) - self.value_range[0]).sum() * self.volume_per_unit)

    @property
    def nbytes(self) -> int:
        return int(self.density.nbytes)

    def like(self, density) -> VoxelTerrain:
        """A terrain on this grid (origin, cell size, iso, range, band) with another field."""
        return VoxelTerrain(density, self.cell_size, self.origin, self.iso, self.value_range, self.band)

    def distance(self, points) -> tuple[np.ndarray, np.ndarray]:
        """(l, n) at ``points`` (m, 3): the distance to the surface (m, positive outside the solid) and the
        unit normal pointing out of it (SPEC VX-3, :mod:`erosim.kernels.voxel`)."""

        pts = np.ascontiguousarray(np.asarray(points, np.float64).reshape(-1, 3))
        l, n = np.empty(len(pts)), np.empty((len(pts), 3))
        ox, oy, oz = self.origin
        wall_distance(self.density, ox, oy, oz, 1.0 / self.cell_size, self.iso, pts, len(pts), l, n)
        return l, n

    def fluid_points(self, spacing: float, lo=None, hi=None, *, below: float | None = None,
                     clearance: float = 0.5) -> np.ndarray:  # fmt: skip
        """Lattice points ((k + ½)·Δx on each axis) in the box ``lo``–``hi`` (default: the grid), under the
        height ``below`` if given, at least ``clearance``·Δx outside the solid: a fluid filling the terrain's
        hollows, as the SPH solver's initial positions.

        A point is kept when its wall distance l is at least ``clearance``·Δx, or when the field is below the
        iso level on the whole sphere of that radius around it (:func:`clear_of_solid`, 64 directions): at a
        concave edge — the crease of a max-combination, where two walls meet — trilinear interpolation of the
        kinked field reads l = Δx/(2√2) for a point Δx/2 from both walls (:mod:`erosim.kernels.voxel`), and the
        distance test alone would leave every lattice row along the floor's edges and the tank's corners
        empty (the water then settles into them).
        """
        dx = float(spacing)
        lo = self.lo if lo is None else np.asarray(lo, np.float64)
        hi = self.hi if hi is None else np.asarray(hi, np.float64)
        axes = [(np.arange(math.ceil(a / dx - 0.5), math.floor(b / dx - 0.5) + 1) + 0.5) * dx
                for a, b in zip(lo, hi, strict=True)]  # fmt: skip
        pts = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
        if below is not None:
            pts = pts[pts[:, 2] < below]
        l, _ = self.distance(pts)
        keep = l >= clearance * dx
        edge = ~keep & (l > 0)  # fluid points the distance test refuses: a concave edge, or really too close
        if edge.any():
            keep[np.flatnonzero(edge)] = self.clear_of_solid(pts[edge], clearance * dx)
        return np.ascontiguousarray(pts[keep])

    def clear_of_solid(self, points, radius: float, directions: int = 64) -> np.ndarray:
        """Whether the field is below the iso level at each point and at ``directions`` points (a Fibonacci
        sphere) ``radius``·(1 − 10⁻³) from it: no solid within ``radius``, to the directions' angular spacing
        (a plane at 0.97·radius between two directions is missed)."""
        pts = np.asarray(points, np.float64).reshape(-1, 3)
        k = np.arange(directions) + 0.5
        polar = np.arccos(1.0 - 2.0 * k / directions)
        azimuth = math.pi * (1.0 + math.sqrt(5.0)) * k
        u = np.stack([np.cos(azimuth) * np.sin(polar), np.sin(azimuth) * np.sin(polar), np.cos(polar)], axis=1)
        probes = pts[:, None, :] + (1.0 - 1e-3) * float(radius) * u[None, :, :]
        l, _ = self.distance(np.concatenate([pts, probes.reshape(-1, 3)]))
        return (l[: len(pts)] > 0) & np.all(l[len(pts) :].reshape(len(pts), directions) > 0, axis=1)

    # ---------------------------------------------------------------- constructors

    @classmethod
    def from_sdf(cls, sdf, lo, hi, cell_size: float, *, band: float | None = None, iso: float | None = None,
                 value_range: tuple[float, float] = (0.0, 1.0),
                 max_bytes: int = MAX_BYTES) -> VoxelTerrain:  # fmt: skip
        """The ramp of ``sdf(x, y, z)`` (signed distance in m, **negative inside** the solid; a shape's
        ``.sdf`` or any function on broadcast arrays) on the nodes from ``lo`` to ``hi`` (m); refused when
        the field would need more than ``max_bytes``."""
        cs = float(cell_size)
        if not (math.isfinite(cs) and cs > 0):
            raise ConfigError(f"Voxel cell size {cell_size!r} is not valid; give a positive number of metres.")
        lo = np.asarray(lo, np.float64).reshape(3)
        hi = np.asarray(hi, np.float64).reshape(3)
        n = np.floor((hi - lo) / cs + 1e-9).astype(int) + 1
        if np.any(n < 2):
            raise ConfigError(f"The voxel box {lo.tolist()}–{hi.tolist()} holds fewer than 2 nodes per axis at "
                              f"{cs:g} m cells; enlarge it or use smaller cells.")  # fmt: skip
        need = memory_bytes(int(np.prod(n)))
        if need > max_bytes:
            fit = cs * (need / max_bytes) ** (1 / 3)
            raise ConfigError(
                f"A voxel box of {n[0]}x{n[1]}x{n[2]} nodes at {cs:g} m needs {need / 2**30:.3g} GiB, more than the "
                f"{max_bytes / 2**30:.3g} GiB allowed; use voxels of at least {fit:.3g} m "
                "or a smaller box."
            )
        band = BAND_CELLS * cs if band is None else float(band)
        vr = (float(value_range[0]), float(value_range[1]))
        _ranges(np.zeros(1), iso, vr)
        x = lo[0] + cs * np.arange(n[0])
        y = lo[1] + cs * np.arange(n[1])
        z = lo[2] + cs * np.arange(n[2])
        dens = np.empty((n[2], n[1], n[0]), np.float32)
        step = max(1, _SLAB // (n[0] * n[1]))
        for k0 in range(0, n[2], step):
            zz = z[k0 : k0 + step, None, None]
            dens[k0 : k0 + step] = ramp(-np.broadcast_to(sdf(x[None, None, :], y[None, :, None], zz),
                                                         (len(zz), n[1], n[0])), band, vr)  # fmt: skip
        return cls(dens, cs, lo, iso, vr, band)

    @classmethod
    def from_shapes(cls, shapes, lo, hi, cell_size: float, **kw) -> VoxelTerrain:
        """The union of ``shapes`` (one or a list of :class:`Box`, :class:`Sphere`, :class:`HalfSpace`,
        :class:`Embankment`): the ramp of the minimum of their signed distances."""
        shapes = list(shapes) if isinstance(shapes, (list, tuple)) else [shapes]
        if not shapes:
            raise ConfigError("No shapes given for the voxel terrain; give at least one.")

        def sdf(x, y, z):
            out = shapes[0].sdf(x, y, z)
            for s in shapes[1:]:
                out = np.minimum(out, s.sdf(x, y, z))
            return out

        return cls.from_sdf(sdf, lo, hi, cell_size, **kw)

    @classmethod
    def from_heightmap(cls, hm: Heightmap, cell_size: float | None = None, *, bottom: float | None = None,
                       top: float | None = None, band: float | None = None, iso: float | None = None,
                       value_range: tuple[float, float] = (0.0, 1.0),
                       max_bytes: int = MAX_BYTES) -> VoxelTerrain:  # fmt: skip
        """The ground of a DEM as voxels: nodes over the DEM's cell centres, x east and y north from the
        south-west cell's centre at (0, 0) (the SPH frame of the sph-terrain kind's raster), from ``bottom``
        (default: the lowest ground − b − 2Δ) to ``top`` (default: the highest ground + b + 2Δ); the
        signed distance to the tangent plane of the bilinearly resampled ground (module docstring).
        Refused (one sentence) when the field would need more than ``max_bytes``."""
        cs = float(hm.cell_size if cell_size is None else cell_size)
        if not (math.isfinite(cs) and cs > 0):
            raise ConfigError(f"Voxel cell size {cell_size!r} is not valid; give a positive number of metres.")
        z = np.asarray(hm.z, np.float64)[::-1]  # row 0 = south, y grows northward
        ny_h, nx_h = z.shape
        band = BAND_CELLS * cs if band is None else float(band)
        zmin, zmax = float(z.min()), float(z.max())
        bottom = zmin - band - 2 * cs if bottom is None else float(bottom)
        top = zmax + band + 2 * cs if top is None else float(top)
        if top <= bottom:
            raise ConfigError(f"The voxel column's top {top:g} m is not above its bottom {bottom:g} m; raise the top.")
        w, d = (nx_h - 1) * hm.cell_size, (ny_h - 1) * hm.cell_size
        nx, ny = int(math.floor(w / cs + 1e-9)) + 1, int(math.floor(d / cs + 1e-9)) + 1
        nz = int(math.floor((top - bottom) / cs + 1e-9)) + 1
        need = memory_bytes(nx * ny * nz)
        if need > max_bytes:
            # the voxel size at which the field fits: n ∝ 1/Δ³
            fit = cs * (need / max_bytes) ** (1.0 / 3.0)
            raise InputError(
                f"A DEM of {nx_h}x{ny_h} cells ({w:g} m x {d:g} m, {top - bottom:g} m of relief and margin) as "
                f"{cs:g} m voxels needs {nx}x{ny}x{nz} nodes, {need / 2**30:.3g} GiB, more than the "
                f"{max_bytes / 2**30:.3g} GiB allowed; use voxels of at least {fit:.3g} m or crop the DEM."
            )
        xs = np.arange(nx) * cs
        ys = np.arange(ny) * cs
        gx, gy = np.meshgrid(xs / hm.cell_size, ys / hm.cell_size)
        zg = bilinear_points(np.ascontiguousarray(z), gx.ravel(), gy.ravel()).reshape(ny, nx)
        sx = np.gradient(zg, cs, axis=1) if nx > 1 else np.zeros_like(zg)
        sy = np.gradient(zg, cs, axis=0) if ny > 1 else np.zeros_like(zg)
        nzc = 1.0 / np.sqrt(1.0 + sx * sx + sy * sy)
        zs = bottom + cs * np.arange(nz)
        vr = (float(value_range[0]), float(value_range[1]))
        _ranges(np.zeros(1), iso, vr)
        dens = np.empty((nz, ny, nx), np.float32)
        for k, zk in enumerate(zs):
            dens[k] = ramp((zg - zk) * nzc, band, vr)
        return cls(dens, cs, (0.0, 0.0, bottom), iso, vr, band)

    @classmethod
    def from_noise(cls, lo, hi, cell_size: float, *, wavelength: float, threshold: float = 0.0, seed: int = 0,
                   octaves: int = 3, band: float | None = None, **kw) -> VoxelTerrain:  # fmt: skip
        """Solid where the 3-D fBm n (module docstring) exceeds ``threshold``: blobs of size ~``wavelength`` (m)."""
        if not (wavelength > 0):
            raise ConfigError(f"Noise wavelength {wavelength!r} m is not valid; give a positive length.")
        scale = wavelength / (2.0 * math.pi)

        def sdf(x, y, z):
            x, y, z = np.broadcast_arrays(x, y, z)
            return -(fbm3(seed, x, y, z, wavelength, octaves) - threshold) * scale

        return cls.from_sdf(sdf, lo, hi, cell_size, band=band, **kw)

    def carve_caves(self, *, wavelength: float, threshold: float = 0.3, seed: int = 0, octaves: int = 3,
                    below: float | None = None) -> VoxelTerrain:  # fmt: skip
        """This terrain less the caves of 3-D noise (where n > ``threshold``), only under the height
        ``below`` (m) if given (caves may reach the surface where they rise to it)."""
        lo_v, hi_v = self.value_range
        caves = VoxelTerrain.from_noise(self.lo, self.hi, self.cell_size, wavelength=wavelength, threshold=threshold,
                                        seed=seed, octaves=octaves, band=self.band, iso=self.iso,
                                        value_range=self.value_range)  # fmt: skip
        if below is not None:
            caves = caves.intersection(HalfSpace((0.0, 0.0, float(below)), (0.0, 0.0, 1.0)))
        return self.difference(caves)

    # ---------------------------------------------------------------- combination (max / min)

    def _other(self, other) -> np.ndarray:
        if isinstance(other, VoxelTerrain):
            if other.shape != self.shape or other.cell_size != self.cell_size or other.origin != self.origin:
                raise ConfigError("Voxel terrains combined must share their grid (shape, cell size and origin).")
            if other.value_range != self.value_range:
                raise ConfigError("Voxel terrains combined must share their density range.")
            return other.density
        band = BAND_CELLS * self.cell_size if self.band is None else self.band
        return VoxelTerrain.from_sdf(other.sdf, self.lo, self.hi, self.cell_size, band=band, iso=self.iso,
                                     value_range=self.value_range).density  # fmt: skip

    def union(self, other) -> VoxelTerrain:
        """Solid where either is: d = max(d₁, d₂) (``other`` a terrain on this grid or a shape)."""
        return self.like(np.maximum(self.density, self._other(other)))

    def intersection(self, other) -> VoxelTerrain:
        """Solid where both are: d = min(d₁, d₂)."""
        return self.like(np.minimum(self.density, self._other(other)))

    def difference(self, other) -> VoxelTerrain:
        """Solid where this is and ``other`` is not: d = min(d₁, d_air + d_solid − d₂)."""
        lo, hi = self.value_range
        return self.like(np.minimum(self.density, np.float32(lo + hi) - self._other(other)))

    # ---------------------------------------------------------------- mesh and figures

    def surface_mesh(self, closed: bool = True):
        """The iso-surface as a :class:`trimesh.Trimesh` (marching cubes, outward normals); ``closed`` pads
        the field with air so the solid's cut at the grid's faces is closed too (watertight)."""
        import trimesh
        from skimage.measure import marching_cubes

        dens = self.density
        shift = np.zeros(3)
        if closed:
            dens = np.pad(dens, 1, mode="constant", constant_values=np.float32(self.value_range[0]))
            shift[:] = -self.cell_size
        if not (dens.min() < self.iso < dens.max()):
            raise InputError("The voxel field has no surface at its iso level (all solid or all air); nothing to mesh.")
        verts, faces, _, _ = marching_cubes(dens, level=self.iso, spacing=(self.cell_size,) * 3,
                                            gradient_direction="descent", allow_degenerate=False)  # fmt: skip
        # skimage's faces, read in (z, y, x), wind inward for a solid above the level; (z, y, x) → (x, y, z)
        # mirrors the axes' handedness and turns them outward
        verts = verts[:, ::-1] + self.lo + shift
        return trimesh.Trimesh(vertices=verts, faces=faces, process=True)

    def export_mesh(self, path: str | os.PathLike, mesh=None) -> Path:
        """Write the surface mesh as ``.obj``, ``.ply`` or ``.glb`` (by the suffix), atomically."""
        path = Path(path)
        kind = path.suffix.lower().lstrip(".")
        if kind not in ("obj", "ply", "glb"):
            raise ConfigError(f"Cannot write a mesh as '{path.suffix}'; use .obj, .ply or .glb.")
        mesh = self.surface_mesh() if mesh is None else mesh
        data = mesh.export(file_type=kind)
        return write_bytes(path, data.encode("utf-8") if isinstance(data, str) else bytes(data))

    def section(self, axis: str = "y", at: float | None = None) -> tuple[np.ndarray, tuple, tuple[str, str]]:
        """The field on the node plane nearest ``at`` (m) across ``axis`` ('x', 'y' or 'z'; default the
        middle): (2-D array with rows along the vertical of the figure, extent (h0, h1, v0, v1), labels)."""
        ax = self.axes()
        i = self.plane(axis, at)[0]
        if axis == "y":
            return self.density[:, i, :], (ax[0][0], ax[0][-1], ax[2][0], ax[2][-1]), ("x (m)", "z (m)")
        if axis == "x":
            return self.density[:, :, i], (ax[1][0], ax[1][-1], ax[2][0], ax[2][-1]), ("y (m)", "z (m)")
        return self.density[i], (ax[0][0], ax[0][-1], ax[1][0], ax[1][-1]), ("x (m)", "y (m)")

    def plane(self, axis: str, at: float | None = None) -> tuple[int, float]:
        """(index, coordinate in m) of the node plane across ``axis`` nearest ``at`` (default the middle)."""
        k = "xyz".find(axis)
        if k < 0 or len(axis) != 1:
            raise ConfigError(f"Unknown section axis {axis!r}; use 'x', 'y' or 'z'.")
        c = self.axes()[k]
        i = len(c) // 2 if at is None else int(np.clip(round((float(at) - c[0]) / self.cell_size), 0, len(c) - 1))
        return i, float(c[i])

    def cross_section(self, path: str | os.PathLike, axis: str = "y", at: float | None = None,
                      title: str = "", reference: VoxelTerrain | None = None) -> Path:  # fmt: skip
        """A PNG of the section (:meth:`section`): density shaded, the surface as a line, and the surface
        of ``reference`` (e.g. the terrain before erosion) dashed."""

        field, extent, labels = self.section(axis, at)
        ref = None if reference is None else reference.section(axis, at)[0]
        plane = self.plane(axis, at)[1]
        return voxel_section(path, field, extent, self.iso, labels=labels, title=title, reference=ref,
                             value_range=self.value_range, where=f"{axis} = {plane:.4g} m")  # fmt: skip

    # ---------------------------------------------------------------- files

    def save(self, path: str | os.PathLike) -> Path:
        """The field and its grid as ``.npz`` (atomically)."""
        return save_npz(path, density=self.density, cell_size=self.cell_size, origin=np.array(self.origin),
                        iso=self.iso, value_range=np.array(self.value_range),
                        band=np.nan if self.band is None else self.band)  # fmt: skip

    @classmethod
    def load(cls, path: str | os.PathLike) -> VoxelTerrain:
        """Read :meth:`save`'s file back."""
        try:
            with np.load(path) as f:
                band = float(f["band"])
                return cls(f["density"], float(f["cell_size"]), f["origin"], float(f["iso"]),
                           tuple(f["value_range"].tolist()), None if math.isnan(band) else band)  # fmt: skip
        except FileNotFoundError:
            raise InputError(f"Voxel file not found: '{path}'; check the path.") from None
        except (KeyError, ValueError, OSError) as exc:
            raise InputError(f"'{path}' is not a voxel terrain written by erosim ({exc}); write it with "
                             "VoxelTerrain.save.") from None  # fmt: skip

    def write_vti(self, path: str | os.PathLike, fields: dict[str, np.ndarray] | None = None) -> Path:
        """The field (and any other node ``fields`` of the same shape) as VTK image data ParaView opens."""

        arrays = {"density": self.density, **(fields or {})}
        return write_vti(path, arrays, self.origin, self.cell_size)
