"""The density diffusion's stable step (erosim.sph.diffusion_limit_molteni2009): a clump of particles
much closer than Δx on a voxel floor — what the overtopping run at 2 cm grew on the crest before it
failed (docs/voxel.md) — drives the δ-SPH term past the density update's bound K Δt ≤ 2/3 at the CFL
step; the solver's step limit keeps it below."""

import math

import numpy as np
import pytest

from erosim.core.errors import InstabilityError
from erosim.sph import diffusion_limit_molteni2009 as dl
from erosim.sph import integrators
from erosim.sph.boundaries.voxel_wall import VoxelWall
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver
from erosim.terrain.voxel import HalfSpace, VoxelTerrain

DX = 0.02


def clumped(n_clump: int, seed: int = 0, density_floor: str = "lone"):
    """One layer of water on a voxel floor (z = 0) and ``n_clump`` particles within 1 mm of a point 2 mm
    above it, every density 900 ± 1 kg/m³ (a thin overflow below ρ₀: pressure zero, nothing holds the
    particles apart)."""
    vt = VoxelTerrain.from_shapes([HalfSpace((0, 0, 0), (0, 0, 1))], (-0.1, -0.1, -0.1), (0.2, 0.2, 0.2), DX)
    rng = np.random.default_rng(seed)
    layer = np.array([[x, y, 0.5 * DX] for x in np.arange(0.01, 0.1, DX) for y in np.arange(0.01, 0.1, DX)])
    clump = np.array([0.05, 0.05, 0.002]) + rng.uniform(-1e-3, 1e-3, (n_clump, 3))
    wall = VoxelWall(vt)
    prm = SPHParams(dim=3, spacing=DX, walls="reflect", sound_speed=20.0, density_floor=density_floor)
    s = SPHSolver(prm, np.concatenate([layer, clump]), domain_lo=vt.lo, domain_hi=vt.hi, boundaries=[wall])
    st = s.state
    st.rho[: st.n_fluid] = 900.0 + rng.uniform(-1.0, 1.0, st.n_fluid)
    st.p[: st.n_fluid] = 0.0
    s._evaluate()  # the first step's rates from these densities
    return s, wall


def max_rate(s) -> float:
    st = s.state
    out = np.empty(st.n)
    return dl.max_rate(3, s.params.kernel, st.pos, st.rho, s.start, s.mid, s.nbr, st.n_fluid, s.m, s.h, s.kdiff,
                       s.eps2, out)  # fmt: skip


def test_rate_of_a_lone_close_pair_is_the_kernels_f0():
    """Two particles 0.1 mm apart, nothing else within h: K = m k_δ |f(r)| r²/((r² + η²) ρ) with Wendland
    C2's f(r) = −210/(πh⁵)(1 − r/h)³ — the closed form to rounding."""
    r = 1e-4
    fluid = np.array([[0.5, 0.5, 0.5], [0.5 + r, 0.5, 0.5]])
    s = SPHSolver(SPHParams(dim=3, spacing=DX, walls="reflect", sound_speed=20.0, gravity=(0.0, 0.0, 0.0)), fluid,
                  domain_lo=(0, 0, 0), domain_hi=(1, 1, 1))  # fmt: skip
    f = 210.0 / (math.pi * s.h**5) * (1.0 - r / s.h) ** 3
    want = s.m * s.kdiff * f * r * r / ((r * r + s.eps2) * s.params.rho0)
    assert max_rate(s) == pytest.approx(want, rel=1e-12)  # the standalone pass
    assert s.kmax == pytest.approx(want, rel=1e-12)  # the solver's fused pass


def test_a_clump_on_a_voxel_floor_stays_stable():
    """16 particles within 1 mm: K Δt = 0.77 at the CFL step (measured), past the predictor–corrector's bound
    2/3 (module docstring). With the CFL limits alone the clump's densities oscillate from step to step with a
    growing amplitude until the run fails at step 45 (measured); with the diffusion limit every step keeps
    K Δt ≤ 0.5 (to rounding; K of the last force pass), and after 300 steps every density is finite and
    within 10 % of the start (900 → 957–972 kg/m³ measured as the clump's pressure rises: a smooth change,
    no oscillation) and no particle is inside the solid. The first run has no density floor (docs/sph.md),
    which would otherwise stop the oscillation at m·W(0) and hide what the diffusion limit prevents."""
    s, _ = clumped(16, density_floor="off")
    s.dt_limit = lambda: integrators.step_limit(s.params.cfl, s.hs, s.c, s.vmax, s.amax, s.nu)  # CFL limits only
    assert max_rate(s) * s.dt_limit() > 2.0 / 3.0
    with pytest.raises(InstabilityError):
        for _ in range(300):
            s.step()

    s, wall = clumped(16)
    assert s.kmax == pytest.approx(max_rate(s), rel=1e-12)  # at the start both passes see the same state
    for _ in range(300):
        k = s.kmax  # the rates of the last force pass, which the step limits
        dt = s.step()
        assert k * dt <= dl.SAFETY * (1 + 1e-9)
        assert wall.inside(s) == 0
    rho = s.fluid_density()
    assert np.isfinite(rho).all()
    assert rho.min() > 0.9 * 900.0 and rho.max() < 1.1 * 900.0
