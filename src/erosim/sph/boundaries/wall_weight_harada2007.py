"""Wall weight functions (Harada, Koshizuka & Kawaguchi 2007; SPEC VX-4): a wall known only by the
distance l of a particle to it and the wall's normal n, with no boundary particles and no neighbour
loop.

What a wall does to fluid particle i is what a flat, semi-infinite layer of fixed wall particles
(the lattice of the fluid's spacing Δx, first layer Δx/2 behind the wall, like
:mod:`erosim.sph.boundaries.particles`) would do to a particle at distance l; those sums depend on l
only, so they are computed once ("baked", :func:`bake`) as curves of l ∈ [0, h] and looked up at
run time. With n the unit normal pointing into the fluid, g⊥ = −g·n and g_t = g + g⊥ n the
gravity's normal and tangential parts, m the particle mass and the wall particles at rest density
(ρ_w = ρ₀, like boundary particles, which never fall below it) with the hydrostatically extrapolated
pressure p_w = p_i − ρ₀ g·(r_i − r_w) (Adami et al. 2012), the curves and what they give are

* Z(l)  = m Σ_w W(r_iw)                       summation density:  ρ_i += Z(l)
* G(l)  = Σ_w f(r_iw) (l − l_w)                continuity:  dρ_i/dt += m (v_i·n) G(l)
* H(l)  = Σ_w f(r_iw) (l − l_w)²,  T(l) = Σ_w f(r_iw) x_iw²  (x along the wall)
                                               pressure, SPH-5b ("wcsph"):
                  a_i −= m [p_i (1/ρ_i² + 1/ρ₀²) G n + (g⊥ H n − T g_t)/ρ₀]
                                               SPH-5a ("symmetric", (p_i + p_w)/(2ρ_iρ_w)):
                  a_i −= m [p_i G n/(ρ_i ρ₀) + (g⊥ H n − T g_t)/(2ρ̄)],  ρ̄ = max(ρ_i, ρ₀)
                  (the T term holds the water up along a steep wall; ρ̄ keeps a spray particle, whose
                  density has fallen, from being held more than a particle at rest density)
* viscosity, artificial (SPH-6b, ν from k_v = 2αh_s c):
  A(l) = Σ_w f (l − l_w)²/(r² + ε²),  B(l) = Σ_{ahead} f x_iw²/(r² + ε²),  C(l) = Σ_{ahead} f x_iw (l − l_w)/(r² + ε²)
  (for a tangential velocity along x, "ahead" = the wall particles it moves towards):
  a_i += m k_v/(ρ_i + ρ₀) [min(v_n, 0) A n + B v_t + C |v_t| n];
  laminar (SPH-6a): A = B = Σ_w L(r_iw), C = 0, a_i += −μ m/(ρ̄ ρ₀) (A v_n n + B v_t).

* attraction (SPEC VX-5, seed 001 §4.3): a second pressure curve that keeps only the attractive part,
  the force a lone probe particle feels from the wall when its density is its own share plus the
  wall's, ρ_c(l) = m W(0) + Z(l), and its pressure the linearised law p_c = c²(ρ_c − ρ₀):
  F(l) = −m min(0, ρ_c − ρ₀)(1/ρ_c² + 1/ρ₀²) G(l) ≤ 0 (per c², towards the wall; from the averaged
  Z and G). For a particle below ρ₁ the pressure's normal part blends the two,
  a_n = (ρ_i/ρ₁) a_repul + (1 − ρ_i/ρ₁) c² F(l), and is a_repul from ρ₁ up; the hydrostatic wall
  pressure (H, T) and the viscous terms are not blended. ρ₁ is a tunable of the wall
  (``attraction``: off by default; ``"seed"`` is the seed's ρ₀ + m W(0), one particle's own share
  above rest density); the seed measured its curves on a pressure law that allows tension, so the
  lone-probe curve is defined here on the linearised law at the solver's own c, for any EOS.

with ∇_i W_iw = f(r) r_iw (f < 0, so G, H < 0 and the pressure pushes out of the wall). The sums
are averaged over the particle's position across one lattice cell of the wall, which makes the
curves smooth and the tangential sums exact halves of the full ones.

The curves depend on the wall only through l, so any distance source uses them: the heightfield
ground (l and n in closed form), plane walls, an analytic shape, or a voxel density field
(:mod:`erosim.sph.boundaries.voxel_wall`, l = (ISO − d)/|∇d|). Baking takes about a second in 3-D;
:func:`bake_cached` keeps the curves on disk, ``~/.cache/erosim/wall_weights/<key>.npz``
(``$XDG_CACHE_HOME`` honoured), keyed by the kernel, dimension, spacing, support, ρ₀, viscosity
form, the table's resolution and a hash of the sources that compute them (this module and
:mod:`erosim.kernels.sph_kernels`), so a changed kernel is baked again; a cache that cannot be read
or written is ignored (the curves are baked).

Why not SPlisHSPlasH's volume/density maps: those sample a signed-distance field of a mesh on a
3-D grid; a heightfield or a voxel density field already is such a field (the heightfield gives l
and n in closed form), so the flat-wall curves are all that is needed here.
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit, prange

from erosim.core.atomic import save_npz
from erosim.kernels import sph_kernels
from erosim.kernels.sph_kernels import kernel_f, kernel_lap, kernel_w

# rows of WallCurves.table
Z, G, H, T, VN, VT, VTN, ATT = range(8)
ROWS = 8


@dataclass(frozen=True)
class WallCurves:
    """Baked wall sums on l = k·dl, k = 0 … n−1 (dl = h/(n−1)); ``table`` rows Z, G, H, T, A, B, C, F
    (F the attraction curve per c²)."""

    table: np.ndarray
    dl: float
    support: float
    approach_only: bool  # artificial viscosity acts only on approach (SPH-6b); laminar always

    def at(self, l: float) -> np.ndarray:
        """The eight curves at distance ``l`` (linear interpolation; 0 beyond the support)."""
        return np.array(lookup(self.table, self.dl, float(l)))


def _wall_lattice(spacing: float, support: float, dim: int) -> np.ndarray:
    """Wall particles (lateral coordinates, depth below the wall) near the origin: the fluid lattice
    continued below the wall, first layer Δx/2 behind it."""
    k = int(math.ceil(support / spacing)) + 2
    lat = np.arange(-k, k + 1) * spacing
    depth = -(np.arange(k + 1) + 0.5) * spacing
    axes = [lat] * (dim - 1) + [depth]
    return np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)


def bake(kernel: str, dim: int, spacing: float, support: float, rho0: float, viscosity: str,
         *, n: int = 256, lateral: int = 4) -> WallCurves:  # fmt: skip
    """The curves of the module docstring for this kernel, dimension, spacing Δx and support h."""
    wall = _wall_lattice(spacing, support, dim)
    m = rho0 * spacing**dim
    eps2 = 0.01 * (0.5 * support) ** 2
    ls = np.linspace(0.0, support, n)
    offs = (np.arange(lateral) + 0.5) / lateral * spacing
    lateral_pts = np.stack([g.ravel() for g in np.meshgrid(*([offs] * (dim - 1)), indexing="ij")], axis=1)
    table = np.zeros((ROWS, n))
    for k, l in enumerate(ls):
        acc = np.zeros(ROWS)
        for off in lateral_pts:
            probe = np.concatenate([off, [l]])
            r = probe - wall  # r_iw
            dist = np.sqrt((r * r).sum(axis=1))
            near = dist < support
            r, dist = r[near], dist[near]
            fr = kernel_f(dist, support, dim, kernel)
            nz = r[:, -1]  # l − l_w > 0
            x = r[:, 0]  # along the tangential direction
            ahead = x < 0
            den = dist * dist + eps2
            acc[Z] += m * kernel_w(dist, support, dim, kernel).sum()
            acc[G] += (fr * nz).sum()
            acc[H] += (fr * nz * nz).sum()
            acc[T] += (fr * x * x).sum()
            if viscosity == "laminar":
                lsum = kernel_lap(dist, support, dim, kernel).sum()
                acc[VN] += lsum
                acc[VT] += lsum
            else:
                acc[VN] += (fr * nz * nz / den).sum()
                acc[VT] += (fr * x * x / den)[ahead].sum()
                acc[VTN] += (fr * x * nz / den)[ahead].sum()
        table[:, k] = acc / len(lateral_pts)
    table[ATT] = attraction_curve(table[Z], table[G], m * float(kernel_w(np.zeros(1), support, dim, kernel)[0]),
                                  m, rho0)  # fmt: skip
    return WallCurves(table=table, dl=ls[1] - ls[0], support=support, approach_only=viscosity != "laminar")


def attraction_curve(z, g, self_density, m, rho0):
    """F(l) = −m min(0, ρ_c − ρ₀)(1/ρ_c² + 1/ρ₀²) G(l), ρ_c = m W(0) + Z(l): the attraction a lone probe
    feels from the wall per c² of the linearised pressure law (module docstring; ≤ 0, towards the wall)."""
    rho_c = self_density + np.asarray(z, np.float64)
    return -m * np.minimum(0.0, rho_c - rho0) * (1.0 / rho_c**2 + 1.0 / rho0**2) * np.asarray(g, np.float64)


def seed_rho1(kernel: str, dim: int, spacing: float, support: float, rho0: float) -> float:
    """The seed's ρ₁ = ρ₀ + m W(0): rest density plus one particle's own share."""
    return rho0 + rho0 * spacing**dim * float(kernel_w(np.zeros(1), support, dim, kernel)[0])


def _sources_hash() -> str:
    digest = hashlib.sha256()
    for mod in (__file__, sph_kernels.__file__):
        digest.update(Path(mod).read_bytes())
    return digest.hexdigest()[:16]


def cache_dir() -> Path:
    """Where :func:`bake_cached` keeps curves: ``$XDG_CACHE_HOME/erosim/wall_weights`` (default ``~/.cache``)."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "erosim" / "wall_weights"


def cache_key(kernel: str, dim: int, spacing: float, support: float, rho0: float, viscosity: str, n: int = 256,
              lateral: int = 4) -> str:  # fmt: skip
    """The file stem of these curves in the cache (readable parameters, then a hash of them and the sources)."""
    spec = f"{kernel}|{dim}|{float(spacing)!r}|{float(support)!r}|{float(rho0)!r}|{viscosity}|{n}|{lateral}|rows{ROWS}"
    digest = hashlib.sha256((spec + "|" + _sources_hash()).encode()).hexdigest()[:20]
    return f"{kernel}-{dim}d-{viscosity}-{digest}"


def bake_cached(kernel: str, dim: int, spacing: float, support: float, rho0: float, viscosity: str, *,
                n: int = 256, lateral: int = 4, folder: str | os.PathLike | None = None) -> WallCurves:  # fmt: skip
    """:func:`bake`'s curves, read from the cache ``folder`` (default :func:`cache_dir`) when baked before
    with the same key (:func:`cache_key`), else baked and stored there; identical to :func:`bake`."""
    key = cache_key(kernel, dim, spacing, support, rho0, viscosity, n, lateral)
    path = Path(folder or cache_dir()) / f"{key}.npz"
    try:
        with np.load(path) as f:
            return WallCurves(table=f["table"].copy(), dl=float(f["dl"]), support=float(f["support"]),
                              approach_only=bool(f["approach_only"]))  # fmt: skip
    except (OSError, KeyError, ValueError):
        pass
    curves = bake(kernel, dim, spacing, support, rho0, viscosity, n=n, lateral=lateral)
    try:
        save_npz(path, table=curves.table, dl=curves.dl, support=curves.support, approach_only=curves.approach_only)
    except OSError:  # a read-only or full disk: the curves are baked each time
        pass
    return curves


@njit(inline="always", cache=True)
def lookup(table, dl, l):
    """The eight curves at distance l (clamped to 0 below the wall, zero beyond the table), as a tuple."""
    if l < 0.0:
        l = 0.0
    x = l / dl
    k = int(x)
    if k >= table.shape[1] - 1:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    t = x - k
    u = 1.0 - t
    return (
        u * table[0, k] + t * table[0, k + 1],
        u * table[1, k] + t * table[1, k + 1],
        u * table[2, k] + t * table[2, k + 1],
        u * table[3, k] + t * table[3, k + 1],
        u * table[4, k] + t * table[4, k + 1],
        u * table[5, k] + t * table[5, k + 1],
        u * table[6, k] + t * table[6, k + 1],
        u * table[7, k] + t * table[7, k + 1],
    )


@njit(inline="always", cache=True)
def wall_rates(table, dl, approach_only, rho1, c2, i, l, n0, n1, n2, vel, rho, p, m, rho0, gvec, wcsph, cvisc,
               summation, acc, drho):  # fmt: skip
    """Add the wall's contribution to particle i's acceleration and (continuity) density rate.

    Below ``rho1`` (0: never) the pressure's normal part blends towards ``c2`` times the attraction
    curve F(l) (VX-5, module docstring); ``c2`` is the squared sound speed of the solver.

    (n0, n1[, n2]) is the unit normal into the fluid (2-D: (n0, n1)), ``l`` the distance, ``gvec``
    gravity, ``wcsph`` the pressure form (else symmetric), ``cvisc`` the viscous coefficient (k_v m for
    artificial, −μ m for laminar; divided here by ρ_i + ρ₀ or ρ̄ρ₀); with ``summation`` the density is
    not touched here (see :func:`wall_density`).
    """
    _, cg, ch, ctt, cvn, cvt, cvtn, catt = lookup(table, dl, l)
    d = vel.shape[1]
    rhoi = rho[i]
    rbar = max(rhoi, rho0)
    g0 = gvec[0]
    g1 = gvec[1]
    g2 = gvec[2] if d == 3 else 0.0
    gn = g0 * n0 + g1 * n1 + g2 * n2  # = −g⊥
    v0 = vel[i, 0]
    v1 = vel[i, 1]
    v2 = vel[i, 2] if d == 3 else 0.0
    vn = v0 * n0 + v1 * n1 + v2 * n2
    t0 = v0 - vn * n0
    t1 = v1 - vn * n1
    t2 = v2 - vn * n2
    if wcsph:
        cp = p[i] * (1.0 / (rhoi * rhoi) + 1.0 / (rho0 * rho0))
        chyd = 1.0 / rho0
    else:
        cp = p[i] / (rhoi * rho0)
        chyd = 0.5 / rbar
    # a = −m [cp G n + chyd (g⊥ H n − T g_t)], g⊥ = −gn, g_t = g − gn n
    arep = -m * cp * cg
    if rhoi < rho1:  # VX-5: (ρ/ρ₁) F_repul + (1 − ρ/ρ₁) F_attract
        w = rhoi / rho1
        arep = w * arep + (1.0 - w) * c2 * catt
    an = arep + m * chyd * gn * ch
    cgt = m * chyd * ctt
    if approach_only:
        cv = cvisc / (rhoi + rho0)
        an += cv * (min(vn, 0.0) * cvn + math.sqrt(t0 * t0 + t1 * t1 + t2 * t2) * cvtn)
    else:
        cv = cvisc / (rbar * rho0)
        an += cv * vn * cvn
    ct = cv * cvt
    acc[i, 0] += an * n0 + ct * t0 + cgt * (g0 - gn * n0)
    acc[i, 1] += an * n1 + ct * t1 + cgt * (g1 - gn * n1)
    if d == 3:
        acc[i, 2] += an * n2 + ct * t2 + cgt * (g2 - gn * n2)
    if not summation:
        drho[i] += m * vn * cg


@njit(parallel=True, cache=True)
def shifting_sums(table, dl, l, n, vol, rho0, gc, gct, divr, conc):
    """A wall's share of particle shifting's sums (:mod:`erosim.sph.shifting_lind2012`) at distances ``l``
    with unit normals ``n`` into the fluid: ∇C and ∇C̃ += vol G(l) n, ∇·r −= vol (H(l) + (d − 1) T(l)),
    C += Z(l)/ρ₀ (``vol`` = m/ρ₀; zero beyond the support)."""
    d = n.shape[1]
    support = dl * (table.shape[1] - 1)
    for i in prange(l.shape[0]):
        if l[i] >= support:  # also keeps a far particle's huge l out of the table's index
            continue
        z, g, hh, t, _, _, _, _ = lookup(table, dl, l[i])
        for a in range(d):
            gc[i, a] += vol * g * n[i, a]
            gct[i, a] += vol * g * n[i, a]
        divr[i] -= vol * (hh + (d - 1) * t)
        conc[i] += z / rho0


@njit(inline="always", cache=True)
def wall_density(table, dl, l):
    """Z(l): the wall's share of a summation density."""
    return lookup(table, dl, l)[0]
