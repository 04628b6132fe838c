"""The voxel coupler on scripted particles: budget, first erosion, non-erodible base, the wall refreshed,
the settling time; the crest-life measure of the overtopping validation."""

from __future__ import annotations

import numpy as np
import pytest

from erosim.core.schedules import IterationInterval
from erosim.coupling.coupler import Coupler
from erosim.coupling.terrains import VoxelFieldTerrain
from erosim.erosion.shear_stress_kristof2009 import ShearStressErosion, ShearStressParams
from erosim.sph.solver import SPHSolver
from erosim.terrain.voxel import HalfSpace, VoxelTerrain
from erosim.validation.overtopping import crest_life

CELL = 0.02
H = 0.04  # kernel support


class Wall:
    def __init__(self):
        self.calls = []

    def refresh(self, solver, *, terrain=None, changed=None):
        self.calls.append((terrain, int(changed.sum())))


class Fluid:
    """Particles sliding along a floor at z = 0 at 1 m/s, 1 cm above it."""

    ground_moving = SPHSolver.ground_moving  # the solver's: walls follow, boundaries refreshed

    def __init__(self, x):
        self.t = 0.0
        self.pos = np.column_stack([x, np.full(len(x), 0.06), np.full(len(x), 0.01)])
        self.vel = np.zeros_like(self.pos)
        self.vel[:, 0] = 1.0
        self.boundaries = [Wall()]

    def fluid_positions(self):
        return self.pos

    def fluid_velocities(self):
        return self.vel


def _floor():
    return VoxelTerrain.from_shapes([HalfSpace((0, 0, 0), (0, 0, 1))], (0, 0, -0.12), (0.4, 0.12, 0.1), CELL,
                                    band=0.08)  # fmt: skip


def _coupler(terrain, fluid, **kw):
    params = ShearStressParams(k_eps=5.0, tau_c=1.0, **kw)
    return Coupler(IterationInterval(1), fluid, ShearStressErosion(terrain, params, support=H),
                   VoxelFieldTerrain(terrain), start=0.05)  # fmt: skip


def test_coupler_applies_the_increments_closes_the_budget_and_refreshes_the_wall():
    terrain = _floor()
    before = terrain.density.copy()
    fluid = Fluid(np.array([0.1, 0.3]))
    c = _coupler(terrain, fluid)
    fluid.t = 0.04
    c()  # before the settling time: nothing
    assert c.calls == 0 and np.array_equal(terrain.density, before)
    fluid.t = 0.2
    rates = c.eroder.rates(fluid.pos, fluid.vel)  # Σ max(0, K θⁿ − τ_c) per node on the field as it is
    c()
    b = c.budget()
    # known answer: the eroder was asked for K_ε Δt (d_s − d_a) Σ rates over the 0.16 s since the last look
    # (the call before the settling time counts as a look), and every bit of it was moved, is pending
    # below a quantum, or was asked of nodes with nothing left; float64 sums of a few hundred terms
    lo, hi = terrain.value_range
    asked = c.eroder.params.k_eps * (0.2 - 0.04) * (hi - lo) * rates.sum() * terrain.volume_per_unit
    assert b["eroded"] > 0  # (most is asked of the ramp's air-side nodes, which hold little: unmet)
    assert b["eroded"] + b["pending"] + b["unmet"] == pytest.approx(asked, rel=1e-12)
    # the field lost exactly what the eroder says it removed (float32 values, differences summed in float64)
    assert b["field_change"] == pytest.approx(-b["carried_off"], rel=1e-12)
    assert b["closure_rel"] < 1e-12
    assert fluid.boundaries[0].calls and fluid.boundaries[0].calls[0][0] is terrain.density
    # the first erosion is a node under one of the two particles (within the erosion radius h + l_min)
    t, x, z = c.terrain.first
    assert t == 0.2
    assert min(abs(x - 0.1), abs(x - 0.3)) <= H + 0.4 * H + 1e-12
    assert -H <= z <= 0.01


def test_onset_is_the_first_solid_node_the_surface_passes():
    terrain = _floor()
    # one particle passing over x = 0.1 once; a stream sliding over x = 0.3 at every coupling
    fluid = Fluid(np.array([0.1, 0.3]))
    c = _coupler(terrain, fluid)
    fluid.t = 0.05
    c()  # the settling time ends
    fluid.t = 0.0502
    c()
    solid0 = c.terrain.initial > terrain.iso
    # one short coupling moved quanta (the first transfer) but left every solid node solid: no onset yet
    assert not np.isnan(c.terrain.first[0]) and c.budget()["eroded"] > 0
    assert not (solid0 & (terrain.density <= terrain.iso)).any()
    assert np.isnan(c.terrain.onset[0])
    fluid.pos = fluid.pos[1:]
    fluid.vel = fluid.vel[1:]
    k = 0
    while np.isnan(c.terrain.onset[0]):
        k += 1
        fluid.t = 0.0502 + 0.01 * k
        c()
        assert k < 10_000  # the stream keeps eroding, so the surface retreats past a node
    # it came at the first coupling that left a node solid at the start at or below the iso level ...
    t, x, y, z = c.terrain.onset
    assert t == fluid.t
    ix, iy, iz = (np.round((np.array([x, y, z]) - terrain.origin) / CELL)).astype(int)
    assert solid0[iz, iy, ix] and terrain.density[iz, iy, ix] <= terrain.iso
    # ... under the stream (within the erosion radius h + l_min of it), not under the lone particle
    assert abs(x - 0.3) <= H + 0.4 * H + 1e-12
    # and it is kept in the checkpoint
    fresh = _coupler(_floor(), Fluid(np.array([0.3])))
    fresh.load_state_dict(c.state_dict())
    assert np.array_equal(fresh.terrain.onset, c.terrain.onset)


def test_non_erodible_below_keeps_those_nodes():
    """A base 3 cm under the floor's surface (z_p = −0.03 m): the 3 cm above it erode, the nodes below it keep
    their density, and every node keeps at least the base's own ramp density (the surface stays above z_p)."""
    terrain = _floor()
    before = terrain.density.copy()
    fluid = Fluid(np.array([0.1, 0.2, 0.3]))
    c = _coupler(terrain, fluid, non_erodible_below=-0.03)
    for k in range(1, 20):
        fluid.t = 0.05 + 0.05 * k
        c()
    z = terrain.axes()[2]
    assert c.budget()["eroded"] > 0
    assert np.array_equal(terrain.density[z < -0.03], before[z < -0.03])
    assert (terrain.density >= np.minimum(before, c.eroder.floor)).all()


def test_state_round_trip_restores_field_and_accumulator():
    terrain = _floor()
    fluid = Fluid(np.array([0.2]))
    c = _coupler(terrain, fluid)
    fluid.t = 0.1
    c()
    state = {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in c.state_dict().items()}
    fluid.t = 0.3
    c()
    after = terrain.density.copy()
    c.load_state_dict(state)
    c()
    assert np.array_equal(terrain.density, after)


def test_crest_life_is_the_first_profile_lowered_by_the_fraction():
    x = np.linspace(0, 1, 11)
    rows = []
    for t, top in [(0.0, 0.2), (20.0, 0.19), (40.0, 0.14), (60.0, 0.05)]:
        rows.append(np.column_stack([np.full(11, t), x, np.minimum(top, 0.2 * (1 - abs(x - 0.5)))]))
    prof = np.concatenate(rows)
    assert crest_life(prof, 0.25, 0.2, 60.0) == (40.0, True)  # 0.14 < 0.2 − 0.05
    assert crest_life(prof, 0.9, 0.2, 60.0) == (60.0, False)  # never below 0.02: lasted the run


def _judge(tmp_path, preset, first, tops):
    """``assess`` on a scripted run folder: the onset ``first`` (x, z from the toe) and the crest's height
    at 0, 20, 40, 60 s."""
    import json

    from erosim.scenarios import loader
    from erosim.validation.overtopping import assess

    cfg = loader.load("overtopping", ["sph.spacing=0.02", "voxels.cell_size=0.02", "erosion.morfac=1"],
                      preset=preset).config  # the scripted times are the flow's: f = 1
    x = np.linspace(0.0, 1.0, 51)
    prof = np.concatenate([np.column_stack([np.full(51, t), x, np.minimum(top, 0.4 * x)])
                           for t, top in zip((0.0, 20.0, 40.0, 60.0), tops, strict=True)])  # fmt: skip
    np.savetxt(tmp_path / "profiles.csv", prof, delimiter=",", header="t,x,z", comments="")
    rep = {"status": "completed", "t": 60.0, "eroded_volume_m3": 1e-3, "particles_inside_solid": 0,
           "first_erosion": {"t": 2.6, "x": first[0], "z": first[1]}, "timings": {"wall_time_s": 1.0}}  # fmt: skip
    (tmp_path / "report.json").write_text(json.dumps(rep))
    return assess(preset, cfg, tmp_path, 60.0)


@pytest.mark.parametrize(
    "preset, first, ok",
    [
        # partial: the lower half of the 2:1 downstream slope (0.5 … 0.9 m from the toe) begins at 0.7 m; one
        # voxel (2 cm) of tolerance, so the node at 0.68 m (computed as 1.08 − 0.4) passes and 0.66 m does not
        ("partial", (1.08 - 0.4, 0.10), True),
        ("partial", (0.66, 0.12), False),
        ("partial", (0.93, 0.0), False),
        # full: the crest, 0.4 … 0.5 m, ± one voxel, and no lower than 2 voxels under its 0.22 m top
        ("full", (0.78 - 0.4, 0.2016), True),
        ("full", (0.06, 0.04), False),
        ("full", (0.45, 0.17), False),
    ],
)
def test_assess_judges_where_erosion_began(tmp_path, preset, first, ok):
    res = _judge(tmp_path, preset, first, (0.2, 0.2, 0.2, 0.2))
    assert res["first_erosion_ok"] is ok
    assert res["crest_life_s"] == 60.0 and not res["crest_lowered"]


def test_bench_voxel_reports_its_keys():
    from erosim.bench.voxel import run

    res = run(particles=1000, steps=60, every=20, warmup=2)
    assert res["particles"] > 900 and res["steps"] == 60
    for key in ("particle_steps_per_s", "boundary_fraction", "erosion_fraction"):
        assert np.isfinite(res[key])
    assert res["particle_steps_per_s"] > 0
    assert res["boundary_particles"]["voxel"] == 0 and res["boundary_particles"]["box"] > 0
    assert res["eroded_m3"] > 0  # τ_c = 0: the sloshing water erodes the tank


def test_finalize_applies_the_pending_rest():
    """At the end of a completed run the coupler applies what the eroder still holds below a quantum: nothing
    is pending after ``finalize``, the field's change is the eroded volume (closure to float64 rounding) and
    the eroded volume has grown by what was pending (less float32 rounding counted as unmet)."""
    terrain = _floor()
    fluid = Fluid(np.array([0.2]))
    c = _coupler(terrain, fluid)
    for k in range(1, 6):
        fluid.t = 0.05 + 0.05 * k
        c()
    pending, eroded = c.eroder.pending_volume(), c.budget()["eroded"]
    assert pending > 0
    out = c.finalize(None)
    b = out[c.terrain.report_key] if c.terrain.report_key else c.budget()
    assert b["pending"] == 0.0 and b["closure_rel"] < 1e-12
    assert b["eroded"] - eroded == pytest.approx(pending, rel=1e-3)
