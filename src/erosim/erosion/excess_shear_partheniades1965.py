"""Excess-shear erosion of a voxel terrain, the bed shear stress from a rough-wall log law at each particle
(Partheniades 1965's erosion law; the wall function of Nikuradse 1933 and Keulegan 1938).

Why a second law beside the seed's (:mod:`erosim.erosion.shear_stress_kristof2009`, the default): the
seed's shear *rate* v_p/max(l, l_min), l_min = 0.4 h, summed over every particle within R of a grid point,
has no resolution-free threshold or rate. The speed at which τ_c is passed, l_min (τ_c/K)^(1/n), grows
with the particle size (0.58 m/s at 2 cm particles, 49 m/s at a DEM's 27 m), and a node's rate grows with
the number of particles it reaches; the overtopping case's `partial` onset climbs the slope as the spacing
is refined (docs/voxel.md). Here both the threshold and the rate are stated per unit area of the bed in
physical units, as engineers measure them on soils (jet-erosion tests, Hanson & Cook 2004):

    ε = k_d (τ_b − τ_c)⁺                          (m/s of bed retreat, normal to the surface),
    τ_b = ρ₀ u*²,   u* = κ v_p / ln(30 z / k_s),   z = max(l, Δx/2),   κ = 0.41,

with v_p the particle's speed along the wall (the normal from the density field), l its wall distance,
k_s the bed's equivalent sand roughness (Nikuradse's fully rough log law u/u* = ln(30 z/k_s)/κ; the
logarithm is held at 1 or more, z ≥ e k_s/30) and z no less than Δx/2, the height of the centre of a
first-layer particle that stands for the water from the bed to Δx. Over a resolved log-law profile u*
is the same at every height, so τ_b does not depend on where the particle sits; in a sheet one particle
deep it is the depth-averaged law's, within its logarithm.

Each particle of the first layer (l < Δx: on a lattice one layer of particles, centres Δx/2 up, stands on
each bed area Δx²) removes ε Δx² Δt of ground under itself. The field is a linear ramp of the signed
distance across the surface (:mod:`erosim.terrain.voxel`), so the volume is shared equally among the
ramp's nodes along the normal through the particle's foot point r_j − l_j n_j (:func:`bed_retreat`):
an equal decrement of a ramp's nodes moves its iso-surface along the normal by the volume over the area
and keeps its slope, so the wall distance read from any cell of the ramp follows the retreating
bed (taking it from the foot's cell alone would hollow the node at the surface while the cells above,
from which the particles read their distance, still showed the old bed). A grid point below
``non_erodible_below`` gives none, and a particle whose foot point lies below it removes nothing.
The volume enters the seed's per-node accumulator (density units, V/volume_per_unit) and reaches the
field in whole quanta (:func:`~erosim.erosion.shear_stress_kristof2009.quantised_transfer`, the same
budget and checkpoint state), so everything but the law is
:class:`~erosim.erosion.shear_stress_kristof2009.ShearStressErosion`'s.

Parameters: ``erodibility`` k_d (m³/(N·s) = m/(Pa·s)), ``critical_stress`` τ_c (Pa), ``roughness`` k_s
(m). Hanson & Simon (2001) measured k_d of 10⁻⁹–4·10⁻⁶ m³/(N·s) and τ_c of 0–400 Pa on stream beds;
Hanson & Cook's classes run from very resistant (k_d < 10⁻⁸) to very erodible (k_d > 10⁻⁴). A run of
seconds standing for hours needs k_d raised by the ratio of the two times; the threshold stays physical.

References: E. Partheniades, "Erosion and deposition of cohesive soils", J. Hydraulics Div. ASCE 91(1),
1965; G. J. Hanson, K. R. Cook, "Apparatus, test procedures, and analytical methods to measure soil
erodibility in situ", Applied Engineering in Agriculture 20(4), 2004; G. J. Hanson, A. Simon, "Erodibility
of cohesive streambeds in the loess area of the midwestern USA", Hydrological Processes 15, 2001;
G. H. Keulegan, "Laws of turbulent flow in open channels", J. Res. NBS 21, 1938.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from erosim.core.config import param
from erosim.erosion.shear_stress_kristof2009 import ShearStressErosion, ShearStressParams
from erosim.kernels.voxel import cell_of, node_span
from erosim.terrain.voxel import BAND_CELLS

#: von Kármán's constant
KAPPA = 0.41


class ExcessShearParams(ShearStressParams):
    """:class:`~erosim.erosion.shear_stress_kristof2009.ShearStressParams` (the transfer, the base and the
    schedule are shared) and the parameters of :class:`ExcessShearErosion` (module docstring)."""

    erodibility: float = param(1.0e-5, ge=0, unit="m3/(N s)", doc="k_d of ε = k_d (τ_b − τ_c) (law = "
                               "'excess_shear'): 1e-5 is a moderately erodible soil; raise it by the ratio of "
                               "the times where a short run stands for a long one")  # fmt: skip
    critical_stress: float = param(1.0, ge=0, unit="Pa", doc="τ_c of the bed in pascals (law = 'excess_shear')")
    roughness: float = param(0.001, gt=0, unit="m", doc="the bed's equivalent sand roughness k_s of the log law "
                             "(law = 'excess_shear'; 1 mm: sand)")  # fmt: skip


@njit(cache=True, inline="always")
def bed_shear(v_par, z, rho, roughness):
    """τ_b = ρ (κ v_par / ln(30 z/k_s))², the logarithm held at 1 or more (Pa)."""
    u_star = KAPPA * max(v_par, 0.0) / max(math.log(30.0 * z / roughness), 1.0)
    return rho * u_star * u_star


@njit(cache=True)
def bed_shears(pos, vel, wall_l, wall_n, n, spacing, rho, roughness, out):
    """τ_b of each of the first ``n`` particles on the bed (l < Δx), NaN for the others (Pa)."""
    for j in range(n):
        if not wall_l[j] < spacing:
            out[j] = np.nan
            continue
        v2 = vel[j, 0] ** 2 + vel[j, 1] ** 2 + vel[j, 2] ** 2
        vn = vel[j, 0] * wall_n[j, 0] + vel[j, 1] * wall_n[j, 1] + vel[j, 2] * wall_n[j, 2]
        out[j] = bed_shear(math.sqrt(max(v2 - vn * vn, 0.0)), max(wall_l[j], 0.5 * spacing), rho, roughness)


@njit(cache=True, inline="always")
def _ramp_weights(dens, ox, oy, oz, inv, d_air, fx, fy, fz, nx_, ny_, nz_, half, foot, z_floor, scale, out):
    """Σ of the weights of the nodes with material (d > d_air, none below ``z_floor``) whose depth below the
    surface along the normal, t = (f − r_node)·n, lies in (−half, half], each weighted by a tent 1 − ρ/a of
    its distance ρ from the normal line through the foot point f, a = ``foot``; with ``scale`` ≠ 0 the
    weights times ``scale`` are added to ``out``."""
    nz, ny, nx = dens.shape
    cell = 1.0 / inv
    total = 0.0
    i0, i1 = node_span(fx, half * abs(nx_) + foot, ox, inv, nx)
    j0, j1 = node_span(fy, half * abs(ny_) + foot, oy, inv, ny)
    k0, k1 = node_span(fz, half * abs(nz_) + foot, oz, inv, nz)
    for k in range(k0, k1 + 1):
        rz = fz - (oz + k * cell)
        if oz + k * cell < z_floor:
            continue
        for jj in range(j0, j1 + 1):
            ry = fy - (oy + jj * cell)
            for i in range(i0, i1 + 1):
                if dens[k, jj, i] <= d_air:
                    continue
                rx = fx - (ox + i * cell)
                t = rx * nx_ + ry * ny_ + rz * nz_
                if not (-half < t <= half):
                    continue
                rho2 = rx * rx + ry * ry + rz * rz - t * t
                wt = 1.0 - math.sqrt(max(rho2, 0.0)) / foot
                if wt <= 0.0:
                    continue
                total += wt
                if scale != 0.0:
                    out[k, jj, i] += scale * wt
    return total


@njit(cache=True)
def bed_retreat(dens, ox, oy, oz, inv, d_air, pos, tau_b, wall_l, wall_n, n, tau_c, half, foot, z_floor, scale,
                out):  # fmt: skip
    """out[node] += scale (τ_b − τ_c)⁺ for each particle on the bed (``tau_b`` not NaN), shared among the nodes
    of the density ramp under it (:func:`_ramp_weights`: within ``half`` of the surface along the normal
    through its foot point r − l n, and within ``foot`` of that line, the larger of the cell and the
    particle spacing, so that a lattice of particles covers every node column). Shifting a linear ramp of
    half-width b by δ along its normal lowers every node with depth t ∈ (−b, b] by the same amount (the node
    at t = b leaves the ramp's solid end), so an equal share per node moves the iso-surface by the volume
    over the area and keeps the ramp's slope: the wall distance read from any cell of the ramp follows the
    bed. Where no such node is left, the solid corners of the foot's cell share it by trilinear weight
    times material. A particle whose foot lies below ``z_floor`` stands on the non-erodible base and takes
    nothing; nodes below it are never changed."""
    cell = 1.0 / inv
    for j in range(n):
        if not tau_b[j] > tau_c:  # NaN off the bed
            continue
        lj = max(wall_l[j], 0.0)
        nx_, ny_, nz_ = wall_n[j, 0], wall_n[j, 1], wall_n[j, 2]
        fx, fy, fz = pos[j, 0] - lj * nx_, pos[j, 1] - lj * ny_, pos[j, 2] - lj * nz_
        if fz < z_floor:  # the bed under it is the non-erodible base
            continue
        amount = scale * (tau_b[j] - tau_c)
        total = _ramp_weights(dens, ox, oy, oz, inv, d_air, fx, fy, fz, nx_, ny_, nz_, half, foot, z_floor, 0.0, out)
        if total > 0.0:
            _ramp_weights(dens, ox, oy, oz, inv, d_air, fx, fy, fz, nx_, ny_, nz_, half, foot, z_floor,
                          amount / total, out)  # fmt: skip
            continue
        i, jj, k, u, v, w = cell_of(dens, ox, oy, oz, inv, fx, fy, fz)
        for sweep in range(2):
            for c in range(8):
                a, b, e = c & 1, (c >> 1) & 1, c >> 2
                if oz + (k + e) * cell < z_floor:
                    continue
                wt = (u if a else 1.0 - u) * (v if b else 1.0 - v) * (w if e else 1.0 - w)
                wt *= max(dens[k + e, jj + b, i + a] - d_air, 0.0)
                if sweep == 0:
                    total += wt
                elif total > 0.0:
                    out[k + e, jj + b, i + a] += amount * wt / total


class ExcessShearErosion(ShearStressErosion):
    """Excess-shear erosion of ``terrain`` by fluid particles of spacing ``spacing`` (m) and rest density
    ``rho0``; ``support`` is the kernel's h, kept for the suspended load's reach. Module docstring."""

    name = "excess_shear"
    strength = "erodibility"

    def __init__(self, terrain, params: ExcessShearParams | None = None, *, support: float, spacing: float,
                 rho0: float = 1000.0):  # fmt: skip
        super().__init__(terrain, params if params is not None else ExcessShearParams(), support=support)
        self.spacing = float(spacing)
        self.rho0 = float(rho0)

    def bed_shear_stress(self, pos, vel, wall_l=None, normals=None) -> np.ndarray:
        """τ_b (Pa) of every particle on the bed (l < Δx), NaN for the others."""
        pos, vel, wall_l, nrm = self._wall(pos, vel, wall_l, normals)
        out = np.empty(len(pos))
        bed_shears(pos, vel, wall_l, nrm, len(pos), self.spacing, self.rho0, self.params.roughness, out)
        return out

    def _retreat(self, pos, vel, wall_l, normals, scale, out) -> None:
        pos, vel, wall_l, nrm = self._wall(pos, vel, wall_l, normals)
        tau_b = np.empty(len(pos))
        p, t = self.params, self.terrain
        bed_shears(pos, vel, wall_l, nrm, len(pos), self.spacing, self.rho0, p.roughness, tau_b)
        half = t.band if t.band is not None else BAND_CELLS * t.cell_size
        bed_retreat(t.density, *t.origin, 1.0 / t.cell_size, t.value_range[0], pos, tau_b, wall_l, nrm, len(pos),
                    p.critical_stress, half, max(t.cell_size, self.spacing), self.z_floor, scale, out)  # fmt: skip

    def _accumulate(self, pos, vel, dt: float, wall_l, normals) -> None:
        """Add k_d (τ_b − τ_c)⁺ Δx² Δt of ground per particle on the bed to the accumulator (density units)."""
        scale = self.params.erodibility * self.spacing**2 * dt * self.params.morfac / self.terrain.volume_per_unit
        self._retreat(pos, vel, wall_l, normals, scale, self.pending)

    def rates(self, pos, vel, wall_l=None) -> np.ndarray:
        """The volume each grid point loses per second (m³/s)."""
        out = np.zeros(self.terrain.shape)
        self._retreat(pos, vel, wall_l, None, self.params.erodibility * self.spacing**2, out)
        return out

    def threshold_speed(self) -> float:
        """The speed along the bed of a first-layer particle (z = Δx/2) at which τ_b reaches τ_c (m/s)."""
        lg = max(math.log(30.0 * 0.5 * self.spacing / self.params.roughness), 1.0)
        return math.sqrt(self.params.critical_stress / self.rho0) * lg / KAPPA

    def threshold_note(self) -> str:
        """Why no water has eroded: the least speed that would, and what to change (a clause of a warning)."""
        p = self.params
        return (
            f"the bed shear stress reaches erosion.critical_stress = {p.critical_stress:g} Pa only where water runs "
            f"faster than {self.threshold_speed():.3g} m/s along the bed (the log law at half a spacing up, roughness "
            f"{p.roughness:g} m), and none has; run longer, or lower erosion.critical_stress if such flow should erode"
        )
