"""Settings of the weakly compressible SPH solver (SPEC SPH-1 … SPH-13), one :class:`SPHParams`.

Every variant is chosen by name (``kernel = "wendland"``, ``eos = "tait"``, …); the solver picks the
matching Numba functions once, when it is built. Defaults are physically valid for water on the
metre scale and below (they pass the Martin & Moyce and hydrostatic validations); the seeds'
variants stay selectable:

* ``kernel``: ``"wendland"`` (Wendland C2 for everything, Dehnen & Aly 2012) or ``"muller"``
  (Müller et al. 2003: poly6 for density, spiky gradient for pressure, viscosity Laplacian, SPH-2).
* ``density``: ``"continuity"`` (dρ/dt = Σ m_j v_ij·∇W, with δ-SPH density diffusion, Molteni &
  Colagrossi 2009, and the hydrostatic correction of Fourtakas et al. 2019) or ``"summation"``
  (ρ = Σ m_j W, SPH-3, the seeds' way).
* ``eos``: ``"tait"`` p = B((ρ/ρ₀)^γ − 1), B = ρ₀c²/γ (SPH-4b) or ``"linear"`` p = k(ρ − ρ₀) (SPH-4a).
* ``pressure_form``: ``"wcsph"`` −Σ m_j (p_i/ρ_i² + p_j/ρ_j²)∇W (SPH-5b) or ``"symmetric"``
  −Σ m_j (p_i + p_j)/(2ρ_iρ_j) ∇W (SPH-5a).
* ``viscosity``: ``"artificial"`` Monaghan Π_ij (SPH-6b) or ``"laminar"`` μ Σ m_j v_ji/(ρ_iρ_j) ∇²W (SPH-6a).
* ``integrator``: ``"leapfrog"`` (kick-drift-kick, SPH-10) or ``"symplectic-euler"`` (seed 001).

Lengths: ``spacing`` is the initial particle spacing Δx; the kernel's support radius (the distance
beyond which it is zero, the seeds' h) is ``h_factor · spacing``. Particle mass is ρ₀Δx^d.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import model_validator

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError


class SPHParams(Section):
    """Every setting of :class:`erosim.sph.solver.SPHSolver`; see the module docstring."""

    dim: Literal[2, 3] = param(3, unit="1", doc="space dimension: 2 or 3")
    spacing: float = param(0.01, gt=0, unit="m", doc="initial particle spacing Δx (mass = ρ₀Δx^dim)")
    h_factor: float = param(
        2.0,
        ge=1.2,
        le=4.0,
        unit="1",
        doc="kernel support radius h = h_factor·spacing; default 2.0 in 3-D (about 30 neighbours; thesis h = 2Δx), "
        "3.0 in 2-D (about 28). On a lattice Wendland's gradient is consistent to 1.8 % at 2.0 (3-D; 0.2 % at 2.1) "
        "and 0.3 % at 3.0 (2-D; 2.6 % at 2.6): that error shows as hydrostatic pressure error (3-D 1.4 % at 2.0, "
        "0.65 % at 2.1)",
    )
    rho0: float = param(1000.0, gt=0, unit="kg/m^3", doc="rest density ρ₀")
    kernel: Literal["wendland", "muller"] = param(
        "wendland", doc="'wendland' (C2, all terms) or 'muller' (poly6/spiky/viscosity, SPH-2)"
    )
    density: Literal["continuity", "summation"] = param(
        "continuity", doc="'continuity' (dρ/dt, with δ-SPH diffusion) or 'summation' (ρ = Σ m W, SPH-3)"
    )
    density_diffusion: float = param(
        0.1,
        ge=0,
        le=1,
        unit="1",
        doc="δ of the δ-SPH density diffusion (Molteni & Colagrossi 2009) in 'continuity' mode; 0 = off",
    )
    eos: Literal["tait", "linear"] = param("tait", doc="equation of state: 'tait' (SPH-4b) or 'linear' (SPH-4a)")
    sound_speed: float = param(
        0.0,
        ge=0,
        unit="m/s",
        doc="numerical sound speed c; 0 = auto: 10·sqrt(2·|g|·H), H from the domain's floor to the fluid's top "
        "(the fastest fall; c ≥ 10·u_max keeps density within 1 %), or 10× the initial speed if larger",
    )
    gamma: float = param(7.0, ge=1, le=10, unit="1", doc="Tait exponent γ")
    stiffness: float = param(
        0.0, ge=0, unit="m^2/s^2", doc="k of the linear EOS p = k(ρ−ρ₀); 0 = c² (same sound speed as Tait)"
    )
    pressure_form: Literal["wcsph", "symmetric"] = param(
        "wcsph", doc="'wcsph' (SPH-5b, momentum conserving) or 'symmetric' ((p_i+p_j)/2, SPH-5a)"
    )
    pressure_floor: Literal["zero", "none"] = param(
        "zero",
        doc="'zero' clamps negative pressure to 0 (stable free surfaces); "
        "'none' keeps tension (unstable at free surfaces)",
    )
    density_floor: Literal["lone", "off"] = param(
        "lone", doc="'lone': each fluid density ≥ m·W(0), a lone particle's summation density (docs/sph.md); 'off'",
    )  # fmt: skip
    shifting: Literal["off", "fickian"] = param(
        "off", doc="particle shifting: 'off' or 'fickian' (Lind et al. 2012; keeps thin sheets and spray from clumping)"
    )
    shifting_coefficient: float = param(
        2.0, gt=0, le=6, unit="1", doc="A of the shifting's D_i = A h_s |v_i| Δt (Skillen et al. 2013: 1–6)"
    )
    viscosity: Literal["artificial", "laminar"] = param(
        "artificial", doc="'artificial' (Monaghan Π, SPH-6b) or 'laminar' (μ∇²v, SPH-6a)"
    )
    alpha: float = param(0.1, ge=0, le=1, unit="1", doc="artificial viscosity coefficient α (SPH-6b)")
    wall_viscosity: Literal["fluid", "none"] = param(
        "fluid",
        doc="fluid–wall viscous term: 'fluid' (no-slip with the fluid's viscosity) or 'none' (free-slip; docs/sph.md)",
    )
    wall_pressure: Literal["dynamic", "extrapolated"] = param(
        "dynamic",
        doc="boundary particles' pressure: 'dynamic' (their own density by continuity, Crespo et al. 2007) or "
        "'extrapolated' (from the fluid, hydrostatically, Adami et al. 2012; docs/sph.md)",
    )
    mu: float = param(1.0e-3, ge=0, unit="Pa*s", doc="dynamic viscosity μ for 'laminar' (water: 1e-3)")
    gravity: tuple[float, ...] | None = param(
        None, unit="m/s^2", doc="gravity vector; default (0, −9.81) in 2-D, (0, 0, −9.81) in 3-D (last axis up)"
    )
    integrator: Literal["leapfrog", "symplectic-euler"] = param(
        "leapfrog", doc="'leapfrog' (kick-drift-kick, SPH-10) or 'symplectic-euler' (seed 001)"
    )
    dt: float = param(
        0.0, ge=0, unit="s", doc="fixed time step; 0 = adaptive (CFL, force, viscous and density diffusion limits)"
    )
    cfl: float = param(
        0.2, gt=0, le=1, unit="1", doc="Courant number of the adaptive step (and of the fixed-step check)"
    )
    precision: Literal["float32", "float64"] = param("float64", doc="floating point type of the particle fields")
    initial_pressure: Literal["hydrostatic", "hydrostatic-consistent", "zero"] = param(
        "hydrostatic",
        doc="start-up density: 'hydrostatic' (ρ from ρ₀|g|(H − z)), 'hydrostatic-consistent' (also corrected "
        "by each deep particle's kernel-sum shortfall at walls; docs/voxel.md) or 'zero' (ρ₀)",
    )
    walls: Literal["particles", "reflect"] = param(
        "particles",
        doc="domain walls: 'particles' lays fixed boundary particles on every face but the top "
        "(and on obstacles) plus reflection; 'reflect' only reflects velocity (SPH-11)",
    )
    wall_layers: int = param(
        0,
        ge=0,
        le=6,
        unit="1",
        doc="layers of boundary particles laid by walls='particles'; 0 = auto: ceil(h_factor − ½), the "
        "fewest that fill the support of a fluid particle at the wall (2 at h = 2Δx, 3 at 3Δx)",
    )
    skin: float = param(
        0.15,
        ge=0,
        le=1,
        unit="1",
        doc="Verlet skin of the neighbour list as a fraction of h (lists rebuilt when a particle moved skin/2)",
    )
    reorder_every: int = param(
        1, ge=1, unit="1", doc="re-sort particles by cell every this many neighbour-list rebuilds (memory locality)"
    )
    parallel_min_particles: int = param(
        5000,
        ge=0,
        unit="1",
        doc="below this many fluid particles the solver runs on one thread (waking threads costs more than it saves)",
    )
    max_mach: float = param(1.0, gt=0, unit="1", doc="stop as unstable when a fluid particle is faster than max_mach·c")

    @model_validator(mode="before")
    @classmethod
    def _default_h_factor(cls, data):
        """2-D default support 3Δx: Σ_j V_j x_j ∂W/∂x = −1 within 0.3 % on a lattice (2.6 % at 2.6Δx)."""
        if isinstance(data, dict) and "h_factor" not in data and data.get("dim", 3) in (2, "2"):
            data = {**data, "h_factor": 3.0}
        return data

    @model_validator(mode="after")
    def _check_gravity(self) -> SPHParams:
        if self.gravity is not None and len(self.gravity) != self.dim:

            raise ConfigError(
                f"Setting 'gravity' has {len(self.gravity)} components but dim = {self.dim}; "
                f"give {self.dim} numbers, e.g. gravity = {[0.0] * (self.dim - 1) + [-9.81]}."
            )
        return self

    def sound_speed_for(self, height: float, speed: float = 0.0) -> float:
        """The numerical sound speed c: ``sound_speed`` when set, else the larger of 10·√(2|g|H), H the
        height the fluid can fall, and 10× the fastest initial ``speed`` (c ≥ 10·u_max keeps density
        within 1 %); 0 when neither gravity nor motion sets one."""
        if self.sound_speed > 0:
            return float(self.sound_speed)
        gnorm = float(np.linalg.norm(np.asarray(self.gravity_vector(), np.float64)))
        return max(10.0 * math.sqrt(2.0 * gnorm * height), 10.0 * speed)

    def gravity_vector(self) -> tuple[float, ...]:
        """Gravity as a ``dim``-tuple (the default points down the last axis)."""
        if self.gravity is not None:
            return tuple(float(g) for g in self.gravity)
        return tuple([0.0] * (self.dim - 1) + [-9.81])

    def layers(self) -> int:
        """Wall layers (resolves ``wall_layers = 0``): layer k lies (k − ½)Δx behind the wall, so it
        is needed while (k − ½)Δx < h."""
        if self.wall_layers > 0:
            return int(self.wall_layers)
        return max(1, math.ceil(self.h_factor - 0.5))

    def support(self) -> float:
        """Kernel support radius h = h_factor · spacing (m)."""
        return self.h_factor * self.spacing

    def floor_is_zero(self) -> bool:
        """Whether negative pressure is clamped to zero ."""
        return self.pressure_floor == "zero"
