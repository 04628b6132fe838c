"""Excess-shear erosion with the log-law bed shear stress (erosion.excess_shear_partheniades1965) on scripted
particles over tilted voxel planes."""

import math

import numpy as np
import pytest

from erosim.core.increments import check_budget
from erosim.erosion.excess_shear_partheniades1965 import KAPPA, ExcessShearErosion, ExcessShearParams
from erosim.terrain.voxel import HalfSpace, VoxelTerrain

K_S = 0.001  # bed roughness (m)
U_STAR = 0.08  # friction velocity of the scripted flow (m/s): τ_b = ρ u*² = 6.4 Pa


def _bed(angle_deg: float, cell: float):
    """A voxel half-space whose surface passes (0.5, 0.5, 0.3) tilted ``angle_deg`` about y; its unit normal
    into the fluid and the unit vector down the slope's line in the x-z plane."""
    a = math.radians(angle_deg)
    normal = np.array([-math.sin(a), 0.0, math.cos(a)])
    along = np.array([math.cos(a), 0.0, math.sin(a)])
    terrain = VoxelTerrain.from_shapes([HalfSpace((0.5, 0.5, 0.3), tuple(normal))], (0, 0, 0), (1, 1, 1), cell)
    return terrain, normal, along


def _log_layers(normal, along, dx, layers=3, half=0.2, centre=(0.5, 0.5, 0.3)):
    """A lattice of ``layers`` layers of particles (spacing ``dx``) over a (2·half)² patch of the bed, each
    moving along it at the rough-wall log law's speed for its height, u(z) = u*/κ ln(30 z/k_s)."""
    s = np.arange(-half + dx / 2, half, dx)
    patch = np.array(centre) + s[:, None, None] * along + s[None, :, None] * np.array([0, 1.0, 0])
    pos, vel = [], []
    for k in range(layers):
        z = (k + 0.5) * dx
        pos.append(patch.reshape(-1, 3) + z * normal)
        vel.append(np.tile(U_STAR / KAPPA * math.log(30 * z / K_S) * along, (s.size**2, 1)))
    return np.vstack(pos), np.vstack(vel), (s.size * dx) ** 2


@pytest.mark.parametrize("angle", [0.0, 30.0, 63.4])
@pytest.mark.parametrize(("dx", "cell"), [(0.02, 0.02), (0.01, 0.01), (0.01, 0.02)])
def test_the_bed_retreats_at_k_d_times_the_excess_stress_at_any_spacing_and_tilt(angle, dx, cell):
    """Over a log-law flow the first layer reads τ_b = ρ u*² whatever its height (so the same at 1 and 2 cm
    particles), the layers above count no bed, and the ground lost per second and square metre is
    k_d (τ_b − τ_c) on a level bed, a 30° slope and the overtopping case's 2:1 slope, with voxels of either
    size: 1e-6 relative (the lattice is exact; the distances come from the float32 field, to about 1e-7 of Δx
    on a tilted plane)."""
    terrain, normal, along = _bed(angle, cell)
    pos, vel, area = _log_layers(normal, along, dx)
    p = ExcessShearParams(erodibility=1e-4, critical_stress=2.0, roughness=K_S)
    e = ExcessShearErosion(terrain, p, support=2 * dx, spacing=dx)
    tau = e.bed_shear_stress(pos, vel)
    first = slice(0, len(pos) // 3)
    assert tau[first] == pytest.approx(1000.0 * U_STAR**2, rel=1e-6)
    assert np.isnan(tau[len(pos) // 3 :]).all()
    assert e.rates(pos, vel).sum() / area == pytest.approx(1e-4 * (1000.0 * U_STAR**2 - 2.0), rel=1e-6)


def test_a_particle_pressed_to_the_bed_reads_the_stress_at_half_a_spacing():
    """A first-layer particle stands for the water from the bed to Δx, so the log law is read at least Δx/2
    up: at l = Δx/4 (pressed down by an impact) it reads what it would at Δx/2, ρ (κ v/ln(15 Δx/k_s))²,
    not the larger stress of the log law at Δx/4; at 0.75 Δx its own height (1e-9 relative)."""
    terrain, normal, along = _bed(0.0, 0.02)
    e = ExcessShearErosion(terrain, ExcessShearParams(roughness=K_S), support=0.04, spacing=0.02)
    pos = np.array([0.5, 0.5, 0.3]) + np.outer([0.005, 0.01, 0.015], normal)
    tau = e.bed_shear_stress(pos, np.tile(along, (3, 1)))
    at = [1000.0 * (KAPPA / math.log(30 * z / K_S)) ** 2 for z in (0.01, 0.01, 0.015)]
    assert tau == pytest.approx(at, rel=1e-9)


def test_nothing_below_the_critical_stress_and_nothing_from_still_water():
    """τ_c just above the flow's τ_b erodes nothing, just below it erodes; water at rest erodes nothing;
    the threshold speed at half a spacing up is the first layer's speed at τ_b = τ_c."""
    terrain, normal, along = _bed(0.0, 0.02)
    pos, vel, _ = _log_layers(normal, along, 0.02)
    tau_b = 1000.0 * U_STAR**2
    above = ExcessShearErosion(terrain, ExcessShearParams(critical_stress=tau_b * 1.001, roughness=K_S),
                               support=0.04, spacing=0.02)  # fmt: skip
    assert not above.rates(pos, vel).any()
    below = ExcessShearErosion(terrain, ExcessShearParams(critical_stress=tau_b * 0.999, roughness=K_S),
                               support=0.04, spacing=0.02)  # fmt: skip
    assert below.rates(pos, vel).sum() > 0
    assert not below.rates(pos, np.zeros_like(vel)).any()
    assert above.threshold_speed() == pytest.approx(np.linalg.norm(vel[0]) * math.sqrt(1.001), rel=1e-12)


def test_the_non_erodible_base_and_the_budget():
    """Ground below ``non_erodible_below`` is never taken (a bed at 0.3 m with the base at 0.31 m loses
    nothing); above it, the quantised increments close the eroder contract's budget and the removed and
    pending volumes add up to k_d (τ_b − τ_c) A Δt over the calls (the field left as it was: 1e-9 relative)."""
    terrain, normal, along = _bed(0.0, 0.02)
    pos, vel, area = _log_layers(normal, along, 0.02)
    p = ExcessShearParams(erodibility=1e-4, critical_stress=2.0, roughness=K_S, non_erodible_below=0.31)
    guarded = ExcessShearErosion(terrain, p, support=0.04, spacing=0.02)
    assert not guarded.rates(pos, vel).any()
    e = ExcessShearErosion(terrain, ExcessShearParams(erodibility=1e-4, critical_stress=2.0, roughness=K_S),
                           support=0.04, spacing=0.02)  # fmt: skip
    total = 0.0
    for _ in range(20):
        inc = e.transfer(pos, vel, 0.5)
        check_budget(inc, terrain.shape, terrain.volume_per_unit, "excess shear")
        total += inc.carried_off
    assert total > 0
    want = 1e-4 * (1000.0 * U_STAR**2 - 2.0) * area * 10.0
    assert total + e.pending_volume() + e.unmet_total == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize(("angle", "cell", "dx"), [(0.0, 0.02, 0.02), (30.0, 0.01, 0.02), (0.0, 0.02, 0.01)])
def test_the_surface_retreats_at_the_erosion_rate(angle, cell, dx):
    """The log-law flow kept on the bed as it goes, 50 s of transfers applied to the field: the iso-surface
    read back by the wall distance has retreated along its normal by ε t = k_d (τ_b − τ_c) t = 22 mm, two
    ramp cells at 2 cm, on average over 60 points of the patch's middle. Within 10 %: up to a quantum per
    node is still pending (the ramp's 8 nodes per column hold up to 8Δ/255 = 0.6 mm at Δ = 2 cm, 3 %) and
    the footprints at the patch's edge spread outwards (measured 2–7 % short); the points scatter by 3–8 %."""
    terrain, normal, along = _bed(angle, cell)
    e = ExcessShearErosion(terrain, ExcessShearParams(erodibility=1e-4, critical_stress=2.0, roughness=K_S),
                           support=2 * dx, spacing=dx)  # fmt: skip
    slope = math.tan(math.radians(angle))
    rng = np.random.default_rng(1)
    xy = np.column_stack([rng.uniform(0.42, 0.58, 60), rng.uniform(0.42, 0.58, 60)])
    bed0 = 0.3 + (xy[:, 0] - 0.5) * slope
    retreat = np.zeros(len(xy))
    for _ in range(100):
        below = retreat.mean() / math.cos(math.radians(angle))  # the bed's vertical drop so far
        pos, vel, _ = _log_layers(normal, along, dx, half=0.1, centre=(0.5, 0.5, 0.3 - below))
        terrain.density += e.transfer(pos, vel, 0.5).dz.astype(np.float32)
        z = bed0 - below + 0.005
        l, n = terrain.distance(np.column_stack([xy, z]))
        retreat = (bed0 - (z - l / n[:, 2])) * math.cos(math.radians(angle))
    eps_t = 1e-4 * (1000.0 * U_STAR**2 - 2.0) * 50.0
    assert retreat.mean() == pytest.approx(eps_t, rel=0.10)
