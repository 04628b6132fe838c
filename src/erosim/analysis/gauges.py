"""Point measurements in a particle fluid: pressure probes and water-level gauges.

Pressure at a probe point r is the Shepard-normalised SPH interpolant (SPEC SPH-1), with the
hydrostatic extrapolation of each particle's pressure to the probe that Adami, Hu & Adams (2012,
J. Comput. Phys. 231) use for the pressure a wall feels:

    p(r) = Σ_j V_j [p_j + ρ_j g·(r − r_j)] W(r − r_j, h) / Σ_j V_j W(r − r_j, h),   V_j = m_j/ρ_j,

with the poly6 kernel shape W ∝ (h² − |r|²)³ (Müller et al. 2003; its constant cancels in the
ratio). Inside the fluid the extrapolation terms cancel by symmetry; on a wall, where every
neighbour lies on one side, they carry the pressure from the neighbours' mean depth to the probe's
(a probe on a tank's floor reads ρ₀gH, not the pressure half a support above it); above the water
it never reads less than its neighbours (or 0). Without ``g`` it is the plain Shepard mean. A probe
with no particle within h is dry and reads 0 (gauge pressure of the air).

The water level at a gauge (a vertical line at a horizontal position) is read as a wave gauge reads
it, from the continuous water column at the line (:func:`water_level`): the SPH volume fraction

    φ(z) = Σ_j V_j W(r(z) − r_j, h)          (the kernel sum; 1 inside water, ½ at a flat free surface)

is sampled up the line from the floor, with the particles mirrored in the floor (so φ = 1 at a
wetted floor, not ½); the column starts where φ first reaches ½ within one support of the floor
(walls hold the lowest particles up to about a spacing, leaving a thin gap of low φ at the floor),
and the level is the first height above that where φ falls below ½, interpolated between samples.
Spray and jets detached from the column (φ < ½ between them and the water) are not water level.
The same profile gives a second reading, the wetted length of the line (``wire``): the total length
where φ ≥ ½, the column's gap at the floor counted wet as above, as a conductance or capacitance
wire gauge reads it (its signal is proportional to the immersed length of its wires, wherever along
them the water is). It equals the column's level on a single column and is larger where the line
passes through water above a hollow (a plunging jet over trapped air) or a jet crossing above it.
:func:`water_depth` keeps the older reading — the top of the highest particle within ``radius`` of
the line — which counts spray. A dry gauge reads 0. Vertical is the last axis (y in 2-D, z in 3-D).
Neighbours come from :class:`scipy.spatial.cKDTree` (a handful of points per output time).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from erosim.kernels.sph_kernels import kernel_w


def probe_pressure(
    positions: np.ndarray,
    pressure: np.ndarray,
    volume: np.ndarray,
    points: np.ndarray,
    h: float,
    *,
    density: np.ndarray | None = None,
    gravity: np.ndarray | None = None,
) -> np.ndarray:
    """Pressure at each of ``points`` (k, d) by the module docstring's interpolant (``gravity`` and
    ``density`` given: with the hydrostatic extrapolation); 0 where no particle is within h."""
    points = np.atleast_2d(np.asarray(points, dtype=np.float64))
    out = np.zeros(len(points))
    if len(positions) == 0 or len(points) == 0:
        return out
    tree = cKDTree(positions)
    vol = np.broadcast_to(np.asarray(volume, dtype=np.float64), (len(positions),))
    for k, idx in enumerate(tree.query_ball_point(points, r=h)):
        if not idx:
            continue
        idx = np.asarray(idx)
        offset = points[k] - positions[idx]
        w = vol[idx] * (h * h - np.sum(offset**2, axis=1)) ** 3
        s = w.sum()
        if s <= 0:
            continue
        value = pressure[idx]
        if gravity is not None:
            value = value + density[idx] * (offset @ np.asarray(gravity, dtype=np.float64))
        # above the water the extrapolation would read suction: no lower than the neighbours' (or 0)
        out[k] = max(float(np.dot(w, value) / s), min(0.0, float(pressure[idx].min())))
    return out


def water_depth(positions: np.ndarray, gauges: np.ndarray, radius: float, spacing: float, floor: float) -> np.ndarray:
    """Depth above ``floor`` of the water column at each gauge's horizontal position.

    ``gauges`` is (k, d−1): x in 2-D, (x, y) in 3-D. Depth = max z of particles within ``radius``
    horizontally + spacing/2 − floor; 0 if none.
    """
    gauges = np.asarray(gauges, dtype=np.float64).reshape(len(gauges), -1)
    out = np.zeros(len(gauges))
    if len(positions) == 0 or len(gauges) == 0:
        return out
    horiz = positions[:, :-1]
    z = positions[:, -1]
    tree = cKDTree(horiz)
    for k, idx in enumerate(tree.query_ball_point(gauges, r=radius)):
        if idx:
            out[k] = max(0.0, float(z[idx].max()) + 0.5 * spacing - floor)
    return out


def volume_fraction_profile(
    positions: np.ndarray,
    volume: np.ndarray,
    line: np.ndarray,
    h: float,
    dz: float,
    floor: float,
    kernel: str = "wendland",
    top: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(z, φ(z)) up the vertical line at the horizontal position ``line`` (d−1,): the kernel sum of the
    particles within h of it and of their mirror images in the floor, every ``dz`` from ``floor`` to
    ``top`` (default: h above the highest of those particles); empty arrays when none is within h."""
    dim = positions.shape[1]
    vol = np.broadcast_to(np.asarray(volume, dtype=np.float64), (len(positions),))
    # the particles within h of the line: one pass over the positions (a few gauges per sample; a tree
    # of every particle cost more than the gauges' sums)
    horiz2 = np.sum((positions[:, :-1] - np.asarray(line, dtype=np.float64)) ** 2, axis=1)
    idx = np.nonzero(horiz2 <= h * h)[0]
    if len(idx) == 0 and top is None:
        return np.zeros(0), np.zeros(0)
    near, v, horiz2 = positions[idx], vol[idx], horiz2[idx]
    if top is None:
        top = float(near[:, -1].max()) + h
    z = floor + dz * np.arange(int(np.ceil((top - floor) / dz)) + 1)
    phi = np.zeros(len(z))
    for image in (near[:, -1], 2.0 * floor - near[:, -1]):  # the particles and their mirror in the floor
        r = np.sqrt(horiz2[None, :] + (z[:, None] - image[None, :]) ** 2)
        phi += kernel_w(r, h, dim, kernel) @ v
    return z, phi


def profile_readings(z: np.ndarray, phi: np.ndarray, h: float, dz: float) -> tuple[float, float]:
    """The column's level and the wire's wetted length (module docstring) of a profile φ(z) sampled every
    ``dz`` from the floor (``z[0]``) up, crossings of φ = ½ interpolated linearly between samples."""
    excess = phi - 0.5
    level = 0.0
    wet = np.nonzero(excess[z <= z[0] + h] >= 0)[0]
    if len(wet):  # else no water within one support of the floor: no column
        excess[: wet[0]] = 0.5  # the gap under the column's first wet sample is the column's
        i = np.nonzero(excess < 0)[0][0]  # φ crosses ½ between samples i − 1 and i (the top one is dry)
        level = z[i - 1] + excess[i - 1] / (excess[i - 1] - excess[i]) * dz - z[0]
    a, b = excess[:-1], excess[1:]  # each interval's wet part, its crossing interpolated
    both = (a >= 0) & (b >= 0)
    one = (a >= 0) != (b >= 0)
    return float(level), float(dz * (both.sum() + np.sum(np.maximum(a, b)[one] / np.abs(a - b)[one])))


def water_level(
    positions: np.ndarray,
    volume: np.ndarray,
    gauges: np.ndarray,
    h: float,
    spacing: float,
    floor: float,
    kernel: str = "wendland",
) -> np.ndarray:
    """Height above ``floor`` of the continuous water column at each gauge line (module docstring)."""
    return gauge_readings(positions, volume, gauges, h, spacing, floor, kernel)[:, 0]


def gauge_readings(
    positions: np.ndarray,
    volume: np.ndarray,
    gauges: np.ndarray,
    h: float,
    spacing: float,
    floor: float,
    kernel: str = "wendland",
) -> np.ndarray:
    """(k, 2): the column's level and the wire's wetted length at each gauge line (module docstring).

    ``gauges`` is (k, d−1); ``volume`` the particles' V = m/ρ (scalar or per particle); ``h`` the
    kernel support and ``kernel`` the solver's; samples every ``spacing``/4 up the line, crossings of
    φ = ½ interpolated linearly between samples.
    """
    gauges = np.asarray(gauges, dtype=np.float64)
    out = np.zeros((len(gauges), 2))
    if len(gauges) == 0 or len(positions) == 0:
        return out
    gauges = gauges.reshape(-1, positions.shape[1] - 1)
    dz = 0.25 * spacing
    for k in range(len(gauges)):
        z, phi = volume_fraction_profile(positions, volume, gauges[k], h, dz, floor, kernel)
        if len(z):
            out[k] = profile_readings(z, phi, h, dz)
    return out
