"""Splash erosion: the crater a falling water particle digs in the ground (projectile on a plate; seed 003
§2.1 eqs. 13–14; SPEC SP-1).

A fluid particle of radius R and density ρ_f that strikes ground of yield strength σ_s at speed v
(normal to the ground) leaves a crater of depth d_p and opening radius a_p:

    d_p = R·v·√(2ρ_f / (9σ_s)),        a_p = √(2R·d_p − d_p²)  (d_p ≤ R),  a_p = R  (d_p > R)

The seed's eqs. (13)–(14) are garbled in the only copy; d_p is SPEC SP-1's reconstruction from the
energy balance the seed names (the particle's kinetic energy spent against σ_s), a_p the radius of
the opening of a spherical cap of the projectile's radius R and depth d_p. SPEC calls a_p the
crater's "width"; runs report it as ``crater_width_m`` and the opening's diameter 2a_p beside it.

Modelling choices (the seed leaves them open):

* **Shape**: the crater is the imprint of the projectile, a sphere of radius R pressed d_p deep:
  depth(r) = max(0, d_p − R + √(R² − r²)) for r ≤ R. A crater deeper than R keeps the opening R (a
  vertical wall below the sphere's equator): the chord formula's second branch above.
* **Speed** is the normal component of the particle's velocity towards the ground; the tangential
  part is scour's (SP-5). Impacts slower than a threshold (``splash.min_speed``) dig nothing.
* **On the heightmap** (:func:`crater_increment`): nodes inside the opening are lowered by the
  imprint's depth at their position; a crater narrower than a cell cannot be drawn node by node, so
  its volume π d_p²(3R − d_p)/3 is taken from the nodes within two cells of the impact in the shares
  of a radial Wendland C2 bump (:func:`spread`): the same footprint in every direction wherever the
  impact falls between the nodes (the four-node bilinear share it replaces is a square, and a jet that
  strikes one place again and again dug a square, "+"-shaped pit). The volume removed is always
  Σ Δz·A of the nodes — what the heightmap loses is what is counted.
* **Rim** (:func:`rim_increment`): the share ``splash.rim`` of a crater's solid is thrown out of it and
  lands around it as an ejecta blanket whose thickness falls as (r/a_p)⁻³ from the opening's edge a_p
  to ``splash.rim_extent``·a_p, at least two cells beyond a_p (the grid draws no thinner ring)
  (McGetchin, Settle & Head 1973, *Earth Planet. Sci. Lett.* 20: 226–236: t ∝ (r/R)⁻³ around simple
  craters); the rest is taken up by
  the water as mud. A blanket narrower than the grid is spread like a sub-cell crater. Modelling
  choice: the seed throws the solid into the water as mud and names no rim; granular drop-impact
  craters have one (Zhao et al. 2015, *PNAS* 112: 342–347).
"""

from __future__ import annotations

import math

import numpy as np

from erosim.core.config import Section, param


class SplashParams(Section):
    """When and how an impact digs a crater."""

    min_speed: float = param(0.5, ge=0, unit="m/s", doc="normal impact speeds below this dig no crater")
    contact: float = param(1.0, gt=0, le=1.5, unit="h", doc="a particle touches the ground when its centre is closer "
                           "than this many kernel supports h to it (1: where the ground's wall acts)")  # fmt: skip
    rim: float = param(0.5, ge=0, le=1, unit="1", doc="share of a crater's solid that lands around it as its rim "
                       "(an ejecta blanket ∝ (r/a_p)⁻³); the rest is taken up by the water as mud")  # fmt: skip
    rim_extent: float = param(2.5, gt=1, le=10, unit="a_p", doc="outer radius of the rim's ejecta blanket, in "
                              "crater opening radii a_p")  # fmt: skip
    mud_max: float = param(0.5, ge=0, lt=1, unit="1", doc="most solid a particle takes up (volume fraction C); the "
                           "rest of a crater's solid is thrown clear (counted as splashed away)")  # fmt: skip


def crater_depth(radius, speed, rho_fluid: float, sigma):
    """d_p = R v √(2ρ_f/(9σ_s)) (m); arrays broadcast."""
    return np.asarray(radius) * np.asarray(speed) * np.sqrt(2.0 * rho_fluid / (9.0 * np.asarray(sigma)))


def crater_radius(radius, depth):
    """a_p = √(2R d_p − d_p²) for d_p ≤ R, R beyond (m): the radius of the crater's opening."""
    r = np.asarray(radius, dtype=np.float64)
    d = np.minimum(np.asarray(depth, dtype=np.float64), r)
    return np.sqrt(np.maximum(2.0 * r * d - d * d, 0.0))


def crater_volume(radius, depth):
    """Volume (m³) of the imprint: a cap π d²(3R − d)/3 up to d = R, plus a cylinder πR²(d − R) below."""
    r = np.asarray(radius, dtype=np.float64)
    d = np.asarray(depth, dtype=np.float64)
    cap = np.minimum(d, r)
    return math.pi * cap * cap * (3.0 * r - cap) / 3.0 + math.pi * r * r * np.maximum(d - r, 0.0)


def imprint_depth(r, radius: float, depth: float):
    """Depth (m) of the imprint at distance ``r`` from the impact: max(0, d − R + √(R² − r²)), 0 beyond R."""
    r = np.asarray(r, dtype=np.float64)
    inside = r < radius
    out = np.zeros_like(r)
    out[inside] = np.maximum(depth - radius + np.sqrt(radius * radius - r[inside] ** 2), 0.0)
    return out


def crater_increment(raster, xy: np.ndarray, radius: float, depths: np.ndarray) -> np.ndarray:
    """Δz (raster.shape, ≤ 0) of craters of ``depths`` at horizontal points ``xy`` (k, 2), one at a time.

    Overlapping craters add up (a second impact in a crater deepens it). See the module docstring for
    the sub-cell case.
    """
    dz = np.zeros(raster.shape)
    nx, ny = raster.nx, raster.ny
    cell = min(raster.dx, raster.dy if ny > 1 else raster.dx)
    for (x, y), d in zip(np.asarray(xy, np.float64).reshape(-1, 2), np.asarray(depths, np.float64).ravel(),
                         strict=True):  # fmt: skip
        if not d > 0:
            continue
        a = float(crater_radius(radius, d))
        fx, fy = (x - raster.x0) / raster.dx, (y - raster.y0) / raster.dy if ny > 1 else 0.0
        if a >= cell:
            i0, i1 = max(0, int(math.floor(fx - a / raster.dx))), min(nx - 1, int(math.ceil(fx + a / raster.dx)))
            j0 = max(0, int(math.floor(fy - a / raster.dy))) if ny > 1 else 0
            j1 = min(ny - 1, int(math.ceil(fy + a / raster.dy))) if ny > 1 else 0
            xs = raster.x0 + raster.dx * np.arange(i0, i1 + 1)
            ys = raster.y0 + raster.dy * np.arange(j0, j1 + 1) if ny > 1 else np.array([y])
            rr = np.hypot(xs[None, :] - x, ys[:, None] - y)
            dz[j0 : j1 + 1, i0 : i1 + 1] -= imprint_depth(rr, radius, d)
            continue
        dz -= spread(raster, x, y, float(crater_volume(radius, d)), SUBCELL * cell)
    return dz


#: the support (in cells) of the footprint of a crater or rim narrower than a cell
SUBCELL = 2.0


def spread(raster, x: float, y: float, volume: float, support: float) -> np.ndarray:
    """Δz (raster.shape, ≥ 0 for volume ≥ 0) that lays ``volume`` (m³) on the nodes within ``support`` of
    (x, y) in the shares of the Wendland C2 bump (1 − q)⁴(1 + 4q), q = r/support: radially symmetric,
    Σ Δz·A = volume (the nearest node takes it all where none is within reach)."""
    dz = np.zeros(raster.shape)
    nx, ny = raster.nx, raster.ny
    fx, fy = (x - raster.x0) / raster.dx, (y - raster.y0) / raster.dy if ny > 1 else 0.0
    mx, my = int(math.ceil(support / raster.dx)), int(math.ceil(support / raster.dy)) if ny > 1 else 0
    i0, i1 = max(0, int(math.floor(fx)) - mx), min(nx - 1, int(math.ceil(fx)) + mx)
    j0, j1 = max(0, int(math.floor(fy)) - my), min(ny - 1, int(math.ceil(fy)) + my)
    if i0 > i1 or j0 > j1:
        return dz
    xs = raster.x0 + raster.dx * np.arange(i0, i1 + 1)
    ys = raster.y0 + raster.dy * np.arange(j0, j1 + 1) if ny > 1 else np.array([y])
    q = np.clip(np.hypot(xs[None, :] - x, ys[:, None] - y) / support, 0.0, 1.0)
    w = (1.0 - q) ** 4 * (1.0 + 4.0 * q)
    if w.sum() <= 0:
        i = min(max(int(round(fx)), 0), nx - 1)
        j = min(max(int(round(fy)), 0), ny - 1)
        dz[j, i] = volume / raster.cell_area
        return dz
    dz[j0 : j1 + 1, i0 : i1 + 1] = w / w.sum() * volume / raster.cell_area
    return dz


def settle(raster, xy: np.ndarray, volumes: np.ndarray, support: float, valid: np.ndarray | None = None) -> np.ndarray:
    """Δz (raster.shape) that lays each of ``volumes`` (m³) at points ``xy`` (k, 2) on the radial footprint of
    :func:`spread` (``support`` m): mud settling where its water soaked away, round wherever it falls between
    the nodes. With ``valid`` (raster.shape) only on those nodes, each footprint's share on the others given
    to them in proportion (a settling particle stands over the terrain, so its nearest node is valid and
    within reach of a support of two cells or more). Σ Δz·A = Σ ``volumes``."""
    dz = np.zeros(raster.shape)
    for (x, y), v in zip(np.asarray(xy, np.float64).reshape(-1, 2), np.asarray(volumes, np.float64).ravel(),
                         strict=True):  # fmt: skip
        if not v > 0:
            continue
        one = spread(raster, x, y, v, support)
        if valid is not None:
            kept = np.where(valid, one, 0.0)
            if kept.sum() > 0:
                one = kept * (one.sum() / kept.sum())
        dz += one
    return dz


def rim_increment(raster, x: float, y: float, opening: float, volume: float, extent: float) -> np.ndarray:
    """Δz (raster.shape, ≥ 0) of a rim of ``volume`` m³ around a crater of opening radius ``opening`` at
    (x, y): thickness ∝ (r/a)⁻³ for a ≤ r ≤ ``extent``·a (McGetchin et al. 1973), on the nodes in that ring;
    a ring narrower than two cells reaches two cells beyond the opening instead (the grid cannot draw it
    thinner), one with fewer than 8 nodes is spread like a sub-cell crater. Σ Δz·A = volume."""
    if not volume > 0:
        return np.zeros(raster.shape)
    nx, ny = raster.nx, raster.ny
    cell = min(raster.dx, raster.dy if ny > 1 else raster.dx)
    outer = max(extent * opening, opening + SUBCELL * cell)
    fx, fy = (x - raster.x0) / raster.dx, (y - raster.y0) / raster.dy if ny > 1 else 0.0
    i0, i1 = max(0, int(math.floor(fx - outer / raster.dx))), min(nx - 1, int(math.ceil(fx + outer / raster.dx)))
    j0 = max(0, int(math.floor(fy - outer / raster.dy))) if ny > 1 else 0
    j1 = min(ny - 1, int(math.ceil(fy + outer / raster.dy))) if ny > 1 else 0
    xs = raster.x0 + raster.dx * np.arange(i0, i1 + 1)
    ys = raster.y0 + raster.dy * np.arange(j0, j1 + 1) if ny > 1 else np.array([y])
    rr = np.hypot(xs[None, :] - x, ys[:, None] - y)
    ring = (rr >= opening) & (rr <= outer)
    if ring.sum() < 8:  # fewer nodes than a ring needs to be round: a sub-cell blanket
        return spread(raster, x, y, volume, max(SUBCELL * cell, outer))
    w = np.where(ring, (np.maximum(rr, opening) / opening) ** -3.0, 0.0)
    dz = np.zeros(raster.shape)
    dz[j0 : j1 + 1, i0 : i1 + 1] = w / w.sum() * volume / raster.cell_area
    return dz
