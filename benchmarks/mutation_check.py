"""Mutation check: break one piece of physics at a time and see whether the tests notice.

For every mutation below (a file of the package, exact text, its broken replacement, and the test
modules that own that code) the package's sources are copied to a temporary folder, the mutation is
applied there, and pytest runs those test modules against the copy (``PYTHONPATH``; ``-x``: the first
failure is enough): the tests of the default run first, then, for a mutation they let through, the
modules' slow tests (``TIERS``; the result names the tier that caught it). Numba compiles the copy
afresh (its cache folder is named by a hash of the sources, see ``erosim/__init__.py``), so no compiled
kernel of the unbroken code can hide a mutation.

A mutation is *caught* when a test fails, *survives* when every test passes, and is *stale* when its
text no longer occurs exactly once in today's sources (reported in the table; the rest still run;
``tests/unit/package/test_mutation_table.py`` keeps the table in step with the code). Every mutation must be
caught; the list grows with the physics (erosion laws, boundaries, budgets).

    .venv/bin/python benchmarks/mutation_check.py                 # all, a table on stdout
    .venv/bin/python benchmarks/mutation_check.py --only box-no-reversal artificial-viscosity-off
    .venv/bin/python benchmarks/mutation_check.py --tests-rev df2ca55 --json before.json
        # the tests as they were at an older commit (the mutations still apply to today's sources)

Runs take a few minutes each (compilation); the whole list about an hour on two cores.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutation:
    name: str
    file: str  # relative to src/erosim
    edits: tuple[tuple[str, str], ...]  # (exact text, replacement); each text occurs exactly once
    tests: tuple[str, ...]  # test modules that own the code
    what: str


SPH_CORE = ("tests/unit/sph/test_sph_solver.py", "tests/verification/test_sph_viscosity.py",
            "tests/validation/test_hydrostatic.py", "tests/validation/test_martin_moyce.py")  # fmt: skip

# the general descend's exit into a nodata cell (the demo's ℓ = 2 cells runs that kernel)
NODATA_LEAVES = "    if zn < sea or lake_of[cn] == OUTSIDE:\n        return LEFT, x, y"

MUTATIONS = (
    Mutation(
        "artificial-viscosity-off",
        "sph/forces.py",
        (("return kv * min(vdotr, 0.0) * f / ((rhoi + rhoj) * (r2 + eps2)), 0.0", "return 0.0 * kv, 0.0"),),
        SPH_CORE,
        "Monaghan's Π (SPH-6b, the default) contributes nothing",
    ),
    Mutation(
        "laminar-viscosity-off",
        "sph/forces.py",
        (("return 0.0, -kv * lapw / (rhoi * rhoj)", "return 0.0, 0.0 * kv"),),
        SPH_CORE,
        "μ∇²v (SPH-6a, the thesis presets) contributes nothing",
    ),
    Mutation(
        "density-corrector-removed",
        "sph/integrators.py",
        (("rho[i] = max(rho_old[i] + dt * drho[i], rho_min)", "rho[i] = max(rho[i] + 0.0 * drho[i], rho_min)"),),
        SPH_CORE,
        "the continuity corrector keeps the predicted density",
    ),
    Mutation(
        "delta-sph-off",
        "sph/forces.py",
        (
            (
                'drho[i] = m * (dr + kdiff * dd)\n    return m * kdiff * kd\n\n\n'
                '@njit(inline="always")\ndef fluid_particle_2d',
                'drho[i] = m * dr\n    return m * kdiff * kd\n\n\n@njit(inline="always")\ndef fluid_particle_2d',
            ),
            (
                '    drho[i] = m * (dr + kdiff * dd)\n    return m * kdiff * kd\n\n\n'
                '@njit(inline="always")\ndef kernel_sum',
                '    drho[i] = m * dr\n    return m * kdiff * kd\n\n\n@njit(inline="always")\ndef kernel_sum',
            ),
        ),
        SPH_CORE,
        "no δ-SPH density diffusion",
    ),  # fmt: skip
    Mutation(
        "pressure-sign",
        "sph/forces.py",
        (("return pi / (rhoi * rhoi) + pj / (rhoj * rhoj)", "return pi / (rhoi * rhoi) - pj / (rhoj * rhoj)"),),
        SPH_CORE,
        "SPH-5b pressure term with a wrong sign",
    ),
    Mutation(
        "box-no-reversal",
        "sph/boundaries/box.py",
        (
            (
                "x = min(2.0 * lo[a] - x, hi[a])\n            if vel[i, a] < 0.0:\n"
                "                vel[i, a] = -vel[i, a]",
                "x = min(2.0 * lo[a] - x, hi[a])\n            if vel[i, a] < 0.0:\n"
                "                vel[i, a] = vel[i, a]",
            ),
        ),
        ("tests/unit/sph/test_sph_boundaries.py", "tests/unit/sph/test_sph_solver.py"),
        "a particle crossing a lower box wall keeps its outward velocity",
    ),  # fmt: skip
    Mutation(
        "boundary-particles-static-density",
        "sph/boundaries/particles.py",
        (("    drho[i] = m * dr\n", "    drho[i] = 0.0 * m * dr\n"),),
        ("tests/unit/sph/test_sph_boundaries.py", "tests/validation/test_hydrostatic.py"),
        "boundary particles never compress",
    ),
    Mutation(
        "verlet-rebuild-late",
        "sph/solver.py",
        (("half = 0.5 * (self.rc - self.h)", "half = 5.0 * (self.rc - self.h)"),),
        ("tests/unit/sph/test_sph_solver.py", "tests/unit/sph/test_sph_state.py"),
        "neighbour lists rebuilt only after particles moved ten times the safe distance",
    ),
    Mutation(
        "wall-hydrostatic-term-off",
        "sph/boundaries/wall_weight_harada2007.py",
        (("an = arep + m * chyd * gn * ch", "an = arep + 0.0 * m * chyd * gn * ch"),),
        ("tests/unit/sph/test_wall_weights.py", "tests/validation/test_basin_at_rest.py"),
        "particle-free walls without the hydrostatic pressure of their wall particles",
    ),
    Mutation(
        "wall-tangential-support-off",
        "sph/boundaries/wall_weight_harada2007.py",
        (("cgt = m * chyd * ctt", "cgt = 0.0 * m * chyd * ctt"),),
        ("tests/unit/sph/test_wall_weights.py", "tests/validation/test_basin_at_rest.py"),
        "steep walls do not hold water up (no tangential hydrostatic term)",
    ),
    Mutation(
        "heightfield-constraint-off",
        "sph/boundaries/heightfield.py",
        (("if pos[i, d - 1] >= bilinear(z, x, y):", "if pos[i, d - 1] >= bilinear(z, x, y) - 1e9:"),),
        ("tests/unit/sph/test_sph_terrain_parts.py", "tests/scenarios/test_sph_terrain_scenarios.py"),
        "no particle is ever lifted back above the ground",
    ),
    Mutation(
        "binning-mean-not-divided",
        "coupling/binning.py",
        (("u = velocity[iy, ix, a] / c", "u = velocity[iy, ix, a] / 1.0"),),
        ("tests/unit/coupling/test_coupling.py",),
        "a node's mean velocity is the sum of its particles'",
    ),
    Mutation(
        "coupler-applies-twice",
        "coupling/terrains.py",
        (("self.z[...] = self.z + dz", "self.z[...] = self.z + 2.0 * dz"),),
        ("tests/unit/coupling/test_coupling.py",),
        "the coupler applies each increment twice",
    ),
    Mutation(
        "voxel-coupler-applies-twice",
        "coupling/terrains.py",
        (("f.density += dd  #", "f.density += 2.0 * dd  #"),),
        ("tests/unit/coupling/test_voxel_coupler.py",),
        "the coupler applies each density increment of a voxel field twice",
    ),
    Mutation(
        "coupler-drops-particle-loads",
        "coupling/coupler.py",
        (("getattr(s.state, field)[: len(values)] = values", "pass"),),
        ("tests/unit/coupling/test_coupling.py", "tests/scenarios/test_sph_terrain_scenarios.py"),
        "the particles' new sediment loads in an increment are never written: picked-up sediment vanishes",
    ),
    Mutation(
        "capacity-slope-clamp-off",
        "erosion/transport_capacity_mei2007.py",
        (("np.maximum(np.sin(np.arctan(np.hypot(sx, sy))), self.sin_min)", "np.sin(np.arctan(np.hypot(sx, sy)))"),),
        ("tests/unit/sph/test_sph_terrain_parts.py",),
        "flat ground never erodes (ER-1's clamp lost)",
    ),
    Mutation(
        "bed-shear-at-the-wall-distance",
        "erosion/excess_shear_partheniades1965.py",
        (("max(wall_l[j], 0.5 * spacing), rho, roughness)", "max(wall_l[j], 0.01 * spacing), rho, roughness)"),),
        ("tests/unit/erosion/test_excess_shear.py",),
        "the log law read at the particle's distance alone, not at least half a spacing up",
    ),
    Mutation(
        "bed-retreat-per-particle-not-per-area",
        "erosion/excess_shear_partheniades1965.py",
        (
            (
                "scale = self.params.erodibility * self.spacing**2 * dt",
                "scale = self.params.erodibility * self.spacing * dt",
            ),
        ),
        ("tests/unit/erosion/test_excess_shear.py",),
        "each particle on the bed removes k_d (τ_b − τ_c) Δx instead of over its area Δx²",
    ),
    Mutation(
        "bed-retreat-from-the-foot-cell-only",
        "erosion/excess_shear_partheniades1965.py",
        (
            (
                "        if total > 0.0:\n            _ramp_weights(",
                "        if total < 0.0:\n            _ramp_weights(",
            ),
        ),
        ("tests/unit/erosion/test_excess_shear.py",),
        "the ground taken from the foot's cell only, not along the ramp: the surface the wall reads lags",
    ),
    Mutation(
        "sediment-deposit-share-wrong",
        "erosion/transport_capacity_mei2007.py",
        (("sed[i] += sed[i] * (e / held[k])", "sed[i] += e / count[k]"),),
        ("tests/unit/sph/test_sph_terrain_parts.py", "tests/scenarios/test_sph_terrain_scenarios.py"),
        "deposits taken equally from every particle, not in proportion to its load",
    ),
    Mutation(
        "rain-ignores-its-map",
        "coupling/sources.py",
        (
            (
                'node = np.searchsorted(self.cdf, rng.random(k), side="right").clip(0, self.cdf.size - 1)',
                "node = (rng.random(k) * self.cdf.size).astype(np.int64)",
            ),
        ),
        ("tests/unit/sph/test_sph_terrain_parts.py",),
        "rain falls uniformly whatever the rain map",
    ),  # fmt: skip
    Mutation(
        "sink-not-counted",
        "sph/state.py",
        (("self.removed[sink] = self.removed.get(sink, 0) + k", "self.removed[sink] = self.removed.get(sink, 0) + 0"),),
        ("tests/unit/sph/test_sph_state.py", "tests/scenarios/test_sph_terrain_scenarios.py"),
        "water leaving through a sink is not counted",
    ),
    Mutation(
        "seed-kernel-ignores-erodibility",
        "hydrology/droplets.py",
        (("khe = kh * erod[c]", "khe = kh"),),
        ("tests/unit/hydrology/test_hydrology_bite.py", "tests/unit/hydrology/test_hydrology_descend.py"),
        "the seed-case droplet kernel erodes hard rock like soft soil",
    ),
    Mutation(
        "roots-ignored",
        "hydrology/droplets.py",
        (("kh = kd * max(1.0 - root * roots[c], 0.0)", "kh = kd * max(1.0 - 0.0 * root * roots[c], 0.0)"),),
        ("tests/unit/hydrology/test_hydrology_bite.py", "tests/unit/hydrology/test_hydrology_descend.py"),
        "roots hold no soil in the seed preset's descend loop (HY-5)",
    ),
    Mutation(
        "batch-ignores-erodibility-and-roots",
        "hydrology/droplet_step.py",
        (
            ("hold = 1.0 - root * roots[c]", "hold = 1.0 - 0.0 * root * roots[c]"),
            ("        amt *= erod[c]", "        amt *= 1.0"),
        ),
        ("tests/unit/hydrology/test_hydrology_bite.py", "tests/unit/hydrology/test_hydrology_batch.py"),
        "the shared droplet step (the batches' descents and the general serial loop) ignores erodibility and roots",
    ),  # fmt: skip
    Mutation(
        "fixed-hardness-ignored",
        "erosion/particle_stream_warszawski.py",
        (
            (
                "                dh = _cut(h[j, i], d[j, i], g, depth, zmin)\n                h[j, i] -= dh\n"
                "                total += dh\n    return total\n",
                "                dh = _cut(h[j, i], 0.0, g, depth, zmin)\n                h[j, i] -= dh\n"
                "                total += dh\n    return total\n",
            ),
        ),
        ("tests/unit/erosion/test_stream_bite.py", "tests/unit/erosion/test_particle_stream.py"),
        "a fixed hardness map does not slow the stream",
    ),  # fmt: skip
    Mutation(
        "heap-rebuild-loses-south-edge",
        "hydrology/pools.py",
        (("edge = ix == 0 or iy == 0 or ix == nx - 1 or iy == ny - 1", "edge = ix == 0 or iy == 0 or ix == nx - 1"),),
        ("tests/unit/hydrology/test_hydrology_bite.py", "tests/unit/hydrology/test_hydrology_pools.py"),
        "a rebuilt lake heap forgets the off-map exit of south-edge cells",
    ),
    Mutation(
        "strata-ignore-hardness",
        "erosion/particle_stream_warszawski.py",
        (
            (
                "                dh = _cut(h[j, i], d[j, i], g, depth, zmin)\n                h[j, i] -= dh\n"
                "                total += dh\n                if h[j, i] < floor[j, i]:",
                "                dh = _cut(h[j, i], 0.0, g, depth, zmin)\n                h[j, i] -= dh\n"
                "                total += dh\n                if h[j, i] < floor[j, i]:",
            ),
        ),
        ("tests/unit/erosion/test_stream_bite.py", "tests/unit/erosion/test_particle_stream.py"),
        "strata of any hardness erode like soft rock (the stream scenario's default path)",
    ),  # fmt: skip
    Mutation(
        "schedule-fires-every-call",
        "core/schedules.py",
        (
            (
                "if self.interval <= 0 or t < self.next_at - 1e-12 * max(1.0, abs(self.next_at)):",
                "if self.interval <= 0:",
            ),
        ),
        ("tests/unit/simulation/test_simulation.py",),
        "a time interval fires after every iteration",
    ),  # fmt: skip
    Mutation(
        "ctrl-c-not-held",
        "simulation/simulation.py",
        (("        pressed.append(signum)\n", "        raise KeyboardInterrupt\n"),),
        ("tests/unit/simulation/test_simulation.py",),
        "Ctrl-C interrupts a step half-way (a checkpoint of half a step)",
    ),
    Mutation(
        "probe-without-wall-extrapolation",
        "analysis/gauges.py",
        (("        if gravity is not None:\n", "        if gravity is None:\n"),),
        ("tests/unit/analysis/test_gauges_front.py",),
        "a probe on a wall reads the plain Shepard mean of its one-sided neighbours",
    ),
    Mutation(
        "level-gauge-without-floor-mirror",
        "analysis/gauges.py",
        (("for image in (near[:, -1], 2.0 * floor - near[:, -1]):", "for image in (near[:, -1],):"),),
        ("tests/unit/analysis/test_gauges_front.py",),
        "the water-level gauge forgets the floor (φ = ½ on a wetted floor)",
    ),
    Mutation(
        "wall-load-without-wall-pressure",
        "sph/wall_load.py",
        (("pterm = p_a / rho_a**2 + p_b / rho_b**2\n", "pterm = p_a / rho_a**2 + 0.0 * p_b\n"),),
        ("tests/unit/sph/test_wall_load.py",),
        "a wall sensor forgets the wall particles' own pressure in the pair force",
    ),
    Mutation(
        "animation-not-checkpointed",
        "simulation/callbacks.py",
        (
            (
                'out: dict[str, Any] = {"frames": np.stack(self.frames)} if self.frames else {}',
                "out: dict[str, Any] = {}",
            ),
        ),
        ("tests/scenarios/test_interrupt_resume.py",),
        "a resumed run's animation starts at the resume",
    ),
    Mutation(
        "hillslope-creep-off",
        "hydrology/hillslope_creep_culling1960.py",
        (
            (
                "            q = c * w * (old[a, i + 1] - old[a, i])",
                "            q = 0.0 * c * w * (old[a, i + 1] - old[a, i])",
            ),
            ("        q = c * w * (below[i] - above[i])", "        q = 0.0"),
        ),
        ("tests/unit/hydrology/test_hillslope_creep.py",),
        "hillslope creep (Culling 1960) moves no soil",
    ),
    Mutation(
        "creep-into-bedrock",
        "hydrology/hillslope_creep_culling1960.py",
        (
            ("            w = min(ml, mr)\n", "            w = max(ml, mr)\n"),
            (
                "        w = min(_mob(erod, lake_of, b + i), _mob(erod, lake_of, b + nx + i))",
                "        w = max(_mob(erod, lake_of, b + i), _mob(erod, lake_of, b + nx + i))",
            ),
        ),
        ("tests/unit/hydrology/test_hillslope_creep.py",),
        "creep crosses into lakes and bedrock (face weight the larger mobility)",
    ),
    Mutation(
        "creep-stops-at-the-shore",
        "hydrology/hillslope_creep_culling1960.py",
        (("    if lake_of[hi] == -1 and lake_of[lo] >= 0 and zhi > zlo:\n        return erod[hi]\n", ""),),
        ("tests/unit/hydrology/test_hillslope_creep.py",),
        "a shore's soil no longer creeps onto a lake bed on one side of it (the lake beside a lower-index cell)",
    ),
    Mutation(
        "batch-log-merge-drops-steps",
        "hydrology/batch.py",
        (("            ldz[n - 1] += dz\n", "            ldz[n - 1] = dz\n"),),
        ("tests/unit/hydrology/test_hydrology_batch.py",),
        "a batch droplet's log keeps only the last of the steps it merged on one footprint (their erosion lost)",
    ),
    Mutation(
        "creep-bands-not-joined",
        "hydrology/hillslope_creep_culling1960.py",
        (
            (
                "            moved[b] += _y_faces(zf, erod, lake_of, c, (b * band - 1) * nx, nx, "
                "edge[b, 0], edge[b, 1])",
                "            moved[b] += 0.0",
            ),
        ),
        ("tests/unit/hydrology/test_hillslope_creep.py",),
        "the parallel creep skips the faces between its bands of rows (no soil crosses every 32nd row)",
    ),
    Mutation(
        "lake-load-above-the-water",
        "hydrology/pools.py",
        (
            (
                "                if lake_of[n] == k and (L - zf[n]) * cell_area <= share:\n",
                "                if lake_of[n] == k and (L - zf[n]) * cell_area < 0.0:\n",
            ),
        ),
        ("tests/unit/hydrology/test_hydrology_pools.py",),
        "a lake's sediment shares are not capped at the water depth (a one-cell lake's load builds a tower)",
    ),
    Mutation(
        "filled-pool-costs-a-round",
        "hydrology/model.py",
        (("            rounds -= 1.0 if res_f == DRAIN else FILL_ROUND\n", "            rounds -= 1.0\n"),),
        ("tests/scenarios/test_users_dems.py",),
        "a droplet whose load filled the pool it entered loses a whole spill round, as if it had spilled over a rim",
    ),
    Mutation(
        "pit-flood-ignores-momentum",
        "hydrology/droplet_step.py",
        (
            (
                "    return 0.5 * speed * speed < g * (rim - h) or speed < v_stall\n",
                "    return True\n",
            ),
        ),
        ("tests/unit/hydrology/test_hydrology_descend.py",),
        "every droplet reaching a pit floods there, however fast (the rivers end in the plains' hollows)",
    ),
    Mutation(
        "dry-load-on-one-cell",
        "hydrology/pools.py",
        (
            (
                "            settle_dry(c, dep, zf, lake_of, level, sea_level, nx, cell_area, spread)\n",
                "            zf[c] += dep / cell_area\n",
            ),
        ),
        ("tests/unit/hydrology/test_hydrology_pools.py",),
        "a droplet flooding at a dry cell drops its load on that one cell again (a spike S/Δx² tall)",
    ),
    Mutation(
        "dry-load-as-a-pyramid",
        "hydrology/pools.py",
        (
            (
                "    dry = count_in(lake_of, box, nx, NO_LAKE)\n",
                "    dry = 0\n    for j in range(j_lo, j_hi):\n        for i in range(i_lo, i_hi):\n"
                "            if lake_of[j * nx + i] == NO_LAKE:\n"
                "                dry += spread + 1 - max(abs(j - c // nx), abs(i - c % nx))\n",
            ),
            (
                "                zf[j * nx + i] += dz\n",
                "                zf[j * nx + i] += dz * (spread + 1 - max(abs(j - c // nx), abs(i - c % nx)))\n",
            ),
        ),
        ("tests/unit/hydrology/test_hydrology_pools.py", "tests/scenarios/test_users_dems.py"),
        "a dry load's remainder spreads as a pyramid, leaving the filled pit a mound, instead of as a layer",
    ),
    Mutation(
        "nodata-does-not-drain",
        "hydrology/droplet_step.py",
        ((NODATA_LEAVES, NODATA_LEAVES.replace(" or lake_of[cn] == OUTSIDE", "")),),
        ("tests/scenarios/test_users_dems.py",),
        "a droplet reaching a nodata cell goes on over its filled height instead of leaving",
    ),
    Mutation(
        "fill-no-slope",
        "terrain/priority_flood_barnes2014.py",
        (("    rise = slope * float(cell_size)\n", "    rise = 0.0 * slope * float(cell_size)\n"),),
        ("tests/unit/terrain/test_priority_flood.py",),
        "closed basins filled flat (no ε slope toward the spill point)",
    ),
    Mutation(
        "fill-diagonal-as-straight",
        "terrain/priority_flood_barnes2014.py",
        (("    kernel(out.reshape(-1), nx, ny, rise, SQRT2 * rise)",
          "    kernel(out.reshape(-1), nx, ny, rise, rise)"),),  # fmt: skip
        ("tests/unit/terrain/test_priority_flood.py",),
        "the fill's rise over a diagonal step is Δx·s instead of √2·Δx·s",
    ),
    Mutation(
        "fill-eikonal-one-neighbour",
        "terrain/priority_flood_barnes2014.py",
        (("    if b - a < rise:  # false when b is infinite or rise is 0\n", "    if False:\n"),),
        ("tests/unit/terrain/test_priority_flood.py",),
        "the eikonal update reduced to the one lower neighbour's height + s·Δx (an octagonal plain)",
    ),
    Mutation(
        "mei-deposition-off",
        "erosion/transport_capacity_mei2007.py",
        (("                e = -fd * (s - c)\n", "                e = 0.0 * fd * (s - c)\n"),),
        ("tests/unit/sph/test_sph_terrain_parts.py",),
        "suspended sediment never settles (ER-2's deposition term zeroed)",
    ),
    Mutation(
        "darcy-drainage-reversed",
        "hydrology/seepage_darcy.py",
        (
            (
                "    theta[upper] -= flow / pore[upper]\n    theta[lower] += flow / pore[lower]",
                "    theta[upper] += flow / pore[upper]\n    theta[lower] -= flow / pore[lower]",
            ),
        ),
        ("tests/verification/test_seepage_darcy.py",),
        "water climbs from the lower layer into the upper one (Darcy drainage between layers reversed)",
    ),
    Mutation(
        "heightfield-density-ignores-distance",
        "sph/boundaries/heightfield.py",
        (("rho[i] += wall_density(table, dl, (pos[i, d - 1] - hgt) * nz)", "rho[i] += wall_density(table, dl, 0.0)"),),
        ("tests/unit/sph/test_wall_weights.py",),
        "the heightfield's share of the summation density is the same at any distance from the ground",
    ),
    Mutation(
        "swe-manning-n-not-squared",
        "kernels/friction_manning.py",
        (("    return 1.0 + dt * g * n * n * speed / depth ** (4.0 / 3.0)",
          "    return 1.0 + dt * g * n * speed / depth ** (4.0 / 3.0)"),),  # fmt: skip
        ("tests/unit/sph/test_kernels_swe.py", "tests/unit/sph/test_depth_columns.py"),
        "the floods' Manning friction (both solvers) grows with n, not n² (g n u|u| / d^{4/3})",
    ),
    Mutation(
        "hazard-highest-class-wins",
        "analysis/hazard.py",
        (
            (
                "for k in range(len(HAZARD_LIMITS), 0, -1):  # highest first, so the lowest class that holds wins",
                "for k in range(1, len(HAZARD_LIMITS) + 1):",
            ),
        ),
        ("tests/unit/analysis/test_hazard.py",),
        "a cell gets the highest hazard class whose limits hold, not the lowest",
    ),
    Mutation(
        "kristof-tau-c-not-subtracted",
        "erosion/shear_stress_kristof2009.py",
        (("    return tau - tau_c if tau > tau_c else 0.0\n", "    return tau if tau > tau_c else 0.0\n"),),
        ("tests/unit/erosion/test_voxel_erosion.py",),
        "the shear-stress law erodes at K θⁿ above τ_c instead of K θⁿ − τ_c",
    ),
    Mutation(
        "voxel-wall-distance-halved",
        "kernels/voxel.py",
        (("    return (iso - d) / g, -gx / g, -gy / g, -gz / g, d\n",
          "    return (iso - d) / (2.0 * g), -gx / g, -gy / g, -gz / g, d\n"),),  # fmt: skip
        ("tests/unit/terrain/test_voxel_distance.py",),
        "the voxel wall reads half the distance to the iso-surface",
    ),
    Mutation(
        "splash-crater-depth-factor",
        "erosion/splash.py",
        (("np.sqrt(2.0 * rho_fluid / (9.0 * np.asarray(sigma)))", "np.sqrt(rho_fluid / np.asarray(sigma))"),),
        ("tests/unit/coupling/test_splash_physics.py",),
        "the crater depth law loses its factor √(2/9)",
    ),
    Mutation(
        "wet-strength-ignores-moisture",
        "erosion/wet_strength.py",
        (("    return sigma_wet + (sigma_dry - sigma_wet) * weakening(theta)",
          "    return sigma_wet + (sigma_dry - sigma_wet) * weakening(0.0 * theta)"),),  # fmt: skip
        ("tests/unit/coupling/test_splash_physics.py",),
        "wet ground is as strong as dry ground",
    ),
    Mutation(
        "mud-density-of-water",
        "sph/mud.py",
        (("    return c * rho_solid + (1.0 - c) * rho_fluid\n", "    return 0.0 * c * rho_solid + rho_fluid\n"),),
        ("tests/verification/test_mud_mixture.py",),
        "mud weighs as much as clear water (the solid fraction's density lost)",
    ),
    Mutation(
        "settling-ignores-height",
        "erosion/settling_voxel.py",
        (("want = s * (1.0 - math.exp(-rate_dt / max(lj, l_min)))", "want = s * (1.0 - math.exp(-rate_dt / l_min))"),),
        ("tests/unit/erosion/test_settling_voxel.py",),
        "sediment settles at the same rate whatever the particle's height above the ground",
    ),
    Mutation(
        "checkpoint-rounds-to-float32",
        "io/checkpoint.py",
        (
            (
                "    arrays = {k: np.asarray(v) for k, v in state.items()}\n",
                "    arrays = {k: np.asarray(v, dtype=np.float32) if np.asarray(v).dtype == np.float64\n"
                "              else np.asarray(v) for k, v in state.items()}\n",
            ),
        ),
        ("tests/unit/core/test_atomic_loop.py", "tests/unit/simulation/test_simulation.py"),
        "a checkpoint keeps the state arrays in single precision (a resume is no longer exact)",
    ),
    Mutation(
        "flood-arrival-is-the-step",
        "sph/shallow_water_vacondio2012.py",
        (("sums, r_lo, c_lo, self.bed, self.t, wet,", "sums, r_lo, c_lo, self.bed, self.last_dt, wet,"),),
        ("tests/validation/test_flood_solvers.py",),
        "the flood's arrival map records the step length instead of the time",
    ),
    Mutation(
        "flood-map-particle-depth",
        "sph/kernels_swe.py",
        (
            (
                "                        sums[rr, cc, 0] += w\n",
                "                        sums[rr, cc, 0] = max(sums[rr, cc, 0], depth[j])\n",
            ),
        ),
        ("tests/unit/sph/test_kernels_swe.py",),
        "the flood's maps take the deepest particle's own depth in reach, not the SPH depth at the cell centre",
    ),
    Mutation(
        "work-queue-skips-items",
        "kernels/work_queue.py",
        (("context.get_constant(types.int64, 1)", "context.get_constant(types.int64, 2)"),),
        ("tests/unit/kernels/test_work_queue.py", "tests/unit/hydrology/test_hydrology_batch.py"),
        "the lanes' shared counter steps by two: every other droplet of a batch round is never descended",
    ),
    Mutation(
        "flood-map-stripes-overlap",
        "sph/kernels_swe.py",
        (
            ("            r0 = max(rows[j, 0], s0)\n", "            r0 = rows[j, 0]\n"),
            ("            r1 = min(rows[j, 1], s1)\n", "            r1 = rows[j, 1]\n"),
        ),
        ("tests/unit/sph/test_kernels_swe.py",),
        "each stripe of the maps' sums adds its particles to every row they reach, not only its own rows",
    ),
    Mutation(
        "flood-map-no-surface-cut",
        "sph/kernels_swe.py",
        (("    d = min(d, se / s - bed[r, c])\n", "    d = min(d, se / s - bed[r, c] + 1e9)\n"),),
        ("tests/unit/sph/test_kernels_swe.py",),
        "the flood's maps are wet up banks above the water surface, wherever the kernel reaches",
    ),
    Mutation(
        "flood-margin-speed-direction-blind",
        "sph/kernels_swe.py",
        (("cos2 = min((ux * gx + uy * gy) ** 2 / a, 1.0)", "cos2 = 0.0 * a"),),
        ("tests/verification/test_swe_thin_water.py",),
        "the maps slow a front's thin tip as they slow the water along the flood's edge",
    ),
    Mutation(
        "flood-margin-speed-unslowed",
        "sph/kernels_swe.py",
        (("phi = (d / columns) ** conveyance", "phi = 1.0 + 0.0 * columns"),),
        ("tests/verification/test_swe_thin_water.py",),
        "the maps give the flood's thin edge the speed of the columns beside it",
    ),
    Mutation(
        "flood-map-through-walls",
        "sph/kernels_swe.py",
        (("if wall_dist[r, c] <= h + cell_size and wall_between(", "if False and wall_between("),),
        ("tests/unit/sph/test_kernels_swe.py",),
        "the flood's maps see water through walls (a dam's downstream cells wet at t = 0)",
    ),
    Mutation(
        "stream-bed-not-graded",
        "erosion/particle_stream_warszawski.py",
        (("    return depth * (fall / (lam * s0)) ** n, hp - fall", "    return depth, -math.inf"),),
        ("tests/unit/erosion/test_particle_stream_graded.py",),
        "the particle stream's gradation ignores the fall ahead and cuts below it (a closed trough)",
    ),
    Mutation(
        "jet-layers-unturned",
        "coupling/sources.py",
        (("s.add_fluid(self.turned(self.events), self.vel, source=self.name)",
          "s.add_fluid(self.layer, self.vel, source=self.name)"),),  # fmt: skip
        ("tests/unit/coupling/test_splash_isotropy.py",),
        "a 3-D jet's lattice disc (a '+' at radius ~Δx) falls unturned: wet patch and crater '+'-shaped",
    ),
    Mutation(
        "jet-layers-helical",
        "coupling/sources.py",
        (("a = 0.5 * np.pi * np.random.default_rng([self.seed & 0xFFFFFFFF, event, 0x7E7]).random()",
          "a = event * 2.399963229728653  # the golden angle"),),  # fmt: skip
        ("tests/unit/coupling/test_splash_isotropy.py",),
        "a 3-D jet's layers are turned by a fixed angle each: a helix, whose sheet spreads as a four-armed spiral",
    ),
    Mutation(
        "ground-moisture-axis-neighbours-only",
        "coupling/porous_ground.py",
        (("i, j, _ = pairs_within(self.pos, 1.1 * self.h)", "i, j, _ = pairs_within(self.pos, 1.01 * self.s)"),),
        ("tests/unit/coupling/test_splash_isotropy.py",),
        "moisture diffuses only between axis neighbours (a 5-point stencil in plan) instead of the kernel's support",
    ),
    Mutation(
        "seepage-one-column",
        "coupling/porous_ground.py",
        (("        ok = (d < radius) & (i >= 0)", "        ok = (d < 0.0) & (i >= 0)"),),
        ("tests/unit/coupling/test_splash_isotropy.py",),
        "a touching particle gives water only to the column under its centre: the jet's rays wet a star",
    ),
    Mutation(
        "subcell-crater-one-node",
        "erosion/splash.py",
        (("SUBCELL = 2.0", "SUBCELL = 0.75"),),
        ("tests/unit/coupling/test_splash_physics.py",),
        "a crater narrower than a cell is laid on its nearest node(s), not a radial footprint: a jet digs a square",
    ),
    Mutation(
        "crater-without-rim",
        "coupling/splash_coupler.py",
        (("self.splash.rim * dug, self.splash.rim_extent", "0.0 * dug, self.splash.rim_extent"),),
        ("tests/scenarios/test_splash_scenarios.py",),
        "a crater's solid all goes into the water: no rim around a drop's crater",
    ),
    Mutation(
        "outflow-edge-digs",
        "erosion/transport_capacity_mei2007.py",
        (("sx, sy = node_gradient(terrain, r.dx, r.dy, self.ghost)", "sx, sy = node_gradient(terrain, r.dx, r.dy, {})"),
         ("wet_area = area * self.wet", "wet_area = area * np.ones_like(self.wet)"),
         ("self.dz *= self.wet  #", "self.dz *= 1.0  #")),  # fmt: skip
        ("tests/unit/coupling/test_outflow_edge_erosion.py", "tests/unit/sph/test_sph_terrain_parts.py"),
        "the open edge's slope one-sided and its sediment over the whole (half dry) cell: the edge row digs",
    ),
)


def stale_edits(m: Mutation, src_root: Path = REPO / "src") -> list[str]:
    """The edits of ``m`` whose text does not occur exactly once in the sources (empty: it applies)."""
    path = src_root / "erosim" / m.file
    if not path.is_file():
        return [f"{m.file} does not exist"]
    text = path.read_text(encoding="utf-8")
    return [f"{old[:60]!r}… occurs {text.count(old)} times in {m.file}" for old, _ in m.edits if text.count(old) != 1]


def _apply(src_root: Path, m: Mutation) -> None:
    path = src_root / "erosim" / m.file
    text = path.read_text(encoding="utf-8")
    for old, new in m.edits:
        text = text.replace(old, new)
    path.write_text(text, encoding="utf-8")


def _tests_folder(rev: str | None, work: Path) -> Path:
    if rev is None:
        return REPO
    out = work / "tests-rev"
    out.mkdir()
    archive = subprocess.run(["git", "-C", str(REPO), "archive", rev, "tests", "pyproject.toml"], capture_output=True,
                             check=True).stdout  # fmt: skip
    subprocess.run(["tar", "-x", "-C", str(out)], input=archive, check=True)
    return out


#: pytest's marker selections, run in turn: the default run's tests, then the slow tier's
TIERS = ("not slow and not cuda and not browser and not regression", "slow and not cuda and not browser")


def run_one(m: Mutation, tests_root: Path, work: Path) -> dict:
    stale = stale_edits(m)
    if stale:  # the source moved on: reported in the table, the other mutations still run
        return {"name": m.name, "status": "stale", "seconds": 0.0, "first_failure": "; ".join(stale), "what": m.what}
    src = work / f"src-{m.name}"
    shutil.copytree(REPO / "src", src, ignore=shutil.ignore_patterns("__pycache__"))
    _apply(src, m)
    tests = [t for t in m.tests if (tests_root / t).is_file()]
    if not tests:
        return {"name": m.name, "status": "no tests", "seconds": 0.0, "first_failure": None, "what": m.what}
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(src)
    env["XDG_CACHE_HOME"] = str(work / "cache")  # a fresh compile of the mutated sources
    t0 = time.perf_counter()
    for tier in TIERS:  # the default tests first; the slow ones only for a mutation they let through
        res = subprocess.run(
            [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", "-m", tier, *tests],
            cwd=tests_root, env=env, capture_output=True, text=True,
        )  # fmt: skip
        if res.returncode != 0 and res.returncode != 5:  # 5: the tier has no test in these modules
            break
    seconds = time.perf_counter() - t0
    failed = [ln.split(" ")[1] for ln in res.stdout.splitlines() if ln.startswith("FAILED ")]
    status = {0: "survived", 5: "survived", 1: "caught"}.get(res.returncode, f"error (pytest exit {res.returncode})")
    shutil.rmtree(src, ignore_errors=True)
    return {"name": m.name, "status": status, "seconds": round(seconds, 1), "tier": tier,
            "first_failure": failed[0] if failed else None, "what": m.what, "tests": tests}  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="*", help="names of the mutations to run (default: all)")
    ap.add_argument("--list", action="store_true", help="list the mutations and exit")
    ap.add_argument("--tests-rev", help="run the tests of this git revision (default: the working tree's)")
    ap.add_argument("--json", help="also write the results to this file")
    args = ap.parse_args(argv)
    chosen = [m for m in MUTATIONS if not args.only or m.name in args.only]
    if args.list:
        for m in chosen:
            print(f"{m.name:36s} {m.file:42s} {m.what}")
        return 0
    results = []
    with tempfile.TemporaryDirectory(prefix="erosim-mutation-") as tmp:
        work = Path(tmp)
        tests_root = _tests_folder(args.tests_rev, work)
        for m in chosen:
            r = run_one(m, tests_root, work)
            results.append(r)
            print(f"{r['name']:36s} {r['status']:10s} {r['seconds']:7.1f} s  {r['first_failure'] or ''}", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    survived = [r["name"] for r in results if r["status"] != "caught"]
    print(
        f"{len(results) - len(survived)} of {len(results)} caught" + (f"; not caught: {survived}" if survived else "")
    )
    return 1 if survived else 0


if __name__ == "__main__":
    raise SystemExit(main())
