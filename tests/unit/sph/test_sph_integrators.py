"""Time integration (SPEC SPH-10) on a simple oscillator, through the solver's own update loops."""

import numba
import numpy as np
import pytest

from erosim.sph import integrators

OMEGA = 2.0 * np.pi  # 1 Hz


@pytest.fixture(autouse=True)
def _one_thread():
    """Three particles: thread start-up would dominate (the solver does the same below 5000 particles)."""
    prev = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(prev)


def _oscillate(scheme: str, dt: float, steps: int):
    """x'' = −ω²x for 3 independent particles, run by kick_drift/correct exactly as the solver does."""
    x0 = np.array([[1.0, 0.0], [0.0, 0.5], [0.3, -0.2]])
    pos = x0.copy()
    vel = np.zeros_like(pos)
    acc = -(OMEGA**2) * pos
    n = len(pos)
    rho = np.full(n, 1000.0)
    rho_old = rho.copy()
    drho = np.zeros(n)
    p = np.zeros(n)
    v2, a2 = np.zeros(integrators.NCHUNK), np.zeros(integrators.NCHUNK)
    k1, k2 = (0.5 * dt, 0.5 * dt) if scheme == "leapfrog" else (dt, 0.0)
    energy = []
    for _ in range(steps):
        integrators.kick_drift(pos, vel, acc, rho, rho_old, drho, p, n, k1, dt, 1000.0, 1.0, 7.0, 0.0, -np.inf)
        acc[:] = -(OMEGA**2) * pos  # the "force pass"
        integrators.correct(vel, acc, rho, rho_old, drho, p, n, k2, dt, 1000.0, 1.0, 7.0, 0.0, -np.inf, v2, a2)
        energy.append(0.5 * (vel**2).sum() + 0.5 * OMEGA**2 * (pos**2).sum())
    return np.array(energy), 0.5 * OMEGA**2 * (x0**2).sum()


def test_leapfrog_energy_is_bounded_without_drift():
    """Velocity Verlet: energy error O((ωΔt)²), oscillating, no secular drift over 200 periods."""
    dt = 0.01
    e, e0 = _oscillate("leapfrog", dt, 20000)
    rel = np.abs(e - e0) / e0
    assert rel.max() < (OMEGA * dt) ** 2 / 4  # bound of the modified energy for velocity Verlet
    first, last = rel[:2000].max(), rel[-2000:].max()
    assert last < 1.05 * first  # no growth from the first 20 periods to the last 20


def test_leapfrog_is_second_order():
    """Halving Δt cuts the energy error by about 4."""
    e1, e0 = _oscillate("leapfrog", 0.02, 500)
    e2, _ = _oscillate("leapfrog", 0.01, 1000)
    ratio = np.abs(e1 - e0).max() / np.abs(e2 - e0).max()
    assert 3.5 < ratio < 4.5


def test_symplectic_euler_energy_is_bounded():
    """Symplectic Euler: first-order energy error, but bounded (no drift) over 200 periods."""
    dt = 0.005
    e, e0 = _oscillate("symplectic-euler", dt, 40000)
    rel = np.abs(e - e0) / e0
    assert rel.max() < OMEGA * dt  # O(ωΔt) bound of its modified energy
    assert rel[-4000:].max() < 1.05 * rel[:4000].max()


def test_step_limit():
    lim = integrators.step_limit(0.2, 0.01, 20.0, 1.0, 100.0, 0.0)
    assert lim == pytest.approx(min(0.2 * 0.01 / 21.0, 0.2 * np.sqrt(0.01 / 100.0)))
    assert integrators.step_limit(0.2, 0.01, 20.0, 0.0, 0.0, 1.0) == pytest.approx(0.125 * 1e-4)


def test_density_floor_holds_in_predictor_and_corrector():
    """ρ = max(ρ + Δt D, ρ_min) in both updates: a particle whose neighbours fly apart (D < 0) stops at
    ρ_min with zero pressure, and the floor never lifts a density above it; -inf leaves the update alone."""
    n, dt, rho0, b, gamma = 2, 1e-3, 1000.0, 1.0e5, 7.0
    for rho_min in (rho0, -np.inf):
        pos, vel, acc = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        rho = np.array([1000.5, 1200.0])
        rho_old = rho.copy()
        drho = np.array([-2.0e4, -2.0e4])  # 20 kg/m³ per step down
        p = np.zeros(n)
        v2, a2 = np.zeros(integrators.NCHUNK), np.zeros(integrators.NCHUNK)
        integrators.kick_drift(pos, vel, acc, rho, rho_old, drho, p, n, 0.5 * dt, dt, rho0, b, gamma, 0.0, rho_min)
        assert rho_old.tolist() == [1000.5, 1200.0]
        integrators.correct(vel, acc, rho, rho_old, drho, p, n, 0.5 * dt, dt, rho0, b, gamma, 0.0, rho_min, v2, a2)
        if rho_min == rho0:
            assert rho.tolist() == [rho0, 1180.0]
            assert p[0] == 0.0 and p[1] > 0.0
        else:
            assert rho.tolist() == [980.5, 1180.0]
