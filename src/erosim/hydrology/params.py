"""Parameters of the procedural hydrology model (SPEC HY-1…HY-5) in physical units.

The seed (SimpleHydrology 2020) works in cells and frames. erosim states every parameter in metres
and seconds through one **reference length ℓ** (``length_scale``): the seed's cell. A seed quantity
maps to physical units as

* position, footprint of a droplet (track, erosion) and of a tree's roots: 1 seed cell → ℓ;
* time: 1 seed time unit → 1 s, so ``dt`` = 1.2 s, ``friction``, ``evaporation`` in 1/s;
* acceleration a = ℓ/s² · n_h/(V/V₀ · ρ) (n_h: horizontal part of the unit surface normal);
* droplet volume V₀ = ℓ³/volume_factor (m³): one seed volume unit fills one cell by 1/volume_factor;
* capacity c_eq = capacity · ℓ · V/V₀ · |v| · Δh  (m³ of sediment; Δh the drop over one ``dt``);
* stream map update every ``cycle_droplets`` droplets per (256 ℓ)² of map area (the seed's world).

Defaults differ from the seed where its values made droplets slow and long-lived on steep
physical terrain (friction 0.5 /s, evaporation 0.003 /s, sub-steps of at most one cell, and
``pit_flood``: a droplet in a pit that its kinetic energy cannot carry it out of floods there at
once instead of oscillating until it evaporates; trees: 10 seedlings per cycle, spread 0.03;
hillslope creep, which the seed does not have: without it droplets leave cell-scale pits on the
slopes). The ``simplehydrology-2020`` preset restores the seed's. The defaults are the library
``hydrology`` scenario's: ``HydrologyParams()`` is what a scenario that leaves ``[hydrology]`` out
runs with (tests/unit/api/test_api.py checks it).

By default (``length_scale`` unset) ℓ is two cells of the terrain: 40 m on the library's 20 m
generated terrain, 2 m on a 1 m lidar tile, 166 m on an 83 m DEM, so every DEM runs at its own scale
with no tuning (droplets per cycle follow the map's area in ℓ², footprints and steps the cell). With
ℓ set in metres the same terrain at 256² or 512² cells (same extent) runs the same physics;
``length_scale = 0`` takes ℓ = one cell, the seed's own convention (used by the
``simplehydrology-2020`` preset and the benchmark, resolution dependent by design).
"""

from __future__ import annotations

import math

import numpy as np

from erosim.core.config import Section, param


class HydrologyParams(Section):
    """Droplet, lake and stream parameters (HY-1…HY-4); defaults give the demo's look."""

    length_scale: float | None = param(
        None, ge=0, unit="m",
        doc="reference length ℓ (the seed's cell): footprints, volume, acceleration; none = 2 cells; 0 = one cell",
    )  # fmt: skip
    dt: float = param(1.2, gt=0, unit="s", doc="droplet time step (seed 1.2)")
    density: float = param(1.0, gt=0, unit="1", doc="droplet density relative to the seed's (seed 1.0)")
    friction: float = param(0.5, ge=0, unit="1/s", doc="speed damping, × (1 − 0.5·stream) (seed 0.1)")
    evaporation: float = param(0.003, ge=0, unit="1/s", doc="volume loss rate, × (1 − 0.2·stream) (seed 0.001)")
    deposition: float = param(0.08, ge=0, le=1, unit="1", doc="mass-transfer fraction per dt (seed 0.08)")
    capacity: float = param(1.0, ge=0, unit="1", doc="sediment capacity factor (seed 1.0)")
    min_volume: float = param(0.01, gt=0, lt=1, unit="1", doc="droplet ends below this share of V₀ (seed 0.01)")
    volume_factor: float = param(100.0, gt=0, unit="1", doc="V₀ = ℓ³/volume_factor (seed 100)")
    drainage: float = param(0.001, ge=0, le=1, unit="1", doc="lake level step toward a drain (seed 0.001)")
    spill: int = param(5, ge=1, le=100, unit="1", doc="descend/flood rounds per droplet (seed 5)")
    stream_rate: float = param(0.01, gt=0, le=1, unit="1", doc="stream map adaptation rate r (seed 0.01)")
    cycle_droplets: int = param(
        250, ge=1, unit="1", doc="droplets per stream/vegetation update, per (256 ℓ)² of map area (seed 250)"
    )
    max_step: float = param(1.0, ge=0, unit="cells", doc="largest move per sub-step; 0 = none (the seed)")
    lakes: bool = param(True, doc="flood droplets into lakes (HY-2); off: a stopped droplet ends")
    sea_level: float | None = param(
        None, unit="m", doc="water below this height leaves the world; none = open map edges only"
    )
    pit_flood: bool = param(
        True,
        doc="a droplet in a pit (a cell below its 8 neighbours) that cannot climb its rim, ½v² < g·(rim − h), or has "
        "stopped there floods there; seed: off",
    )
    max_steps: int = param(20_000, ge=10, unit="1", doc="safety cap on sub-steps per descent")
    batch: int | None = param(
        None,
        ge=0,
        le=65536,
        unit="droplets",
        doc="droplets descending in parallel, each round (hydrology/batch.py); none = an eighth of a cycle's; "
        "0 = one after another (the seed's order)",
    )
    creep: float = param(
        0.001, ge=0, unit="ℓ²/cycle",
        doc="hillslope creep κ/ℓ² per cycle (∂z/∂t = κ∇²z, Culling 1960): smooths cell-scale pits; 0 = off (the seed)",
    )  # fmt: skip
    rebuild_every: int = param(
        16, ge=1, unit="cycles", doc="rebuild the lake heaps (fresh keys after erosion) every N cycles"
    )


class VegetationParams(Section):
    """Trees (HY-5): they hold the soil, spread to their neighbours and die in water."""

    enabled: bool = param(True, doc="grow trees")
    spawn: float = param(10.0, ge=0, unit="1", doc="random seedlings per cycle per (256 ℓ)² (seed 1)")
    spread: float = param(0.03, ge=0, le=1, unit="1", doc="chance per tree and cycle to seed a neighbour (seed 1/50)")
    spread_radius: float = param(4.0, ge=0, unit="ℓ", doc="how far a tree seeds (seed 4 cells)")
    death: float = param(0.001, ge=0, le=1, unit="1", doc="random death chance per cycle (seed 1/1000)")
    max_stream: float = param(0.2, ge=0, le=1, unit="1", doc="trees die / cannot grow where stream > this (seed 0.2)")
    min_normal_z: float = param(0.8, ge=0, le=1, unit="1", doc="trees grow where the normal's z ≥ this (seed 0.8)")
    root_radius: float = param(1.0, gt=0, unit="ℓ", doc="radius of the root-density footprint")
    root_strength: float = param(
        1.0, ge=0, unit="1", doc="root density of full tree cover; erosion × max(0, 1 − density)"
    )


# indices of the kernel constant vector -------------------------------------------------------
(
    P_DT,
    P_FRIC,
    P_EVAP,
    P_KD,
    P_CAP,
    P_ACC,
    P_AMIN,
    P_DENS,
    P_V0,
    P_VMIN,
    P_DX,
    P_CA,
    P_MAXSTEP,
    P_FOOT,
    P_SEA,
    P_EDGE,
    P_DRAIN,
    P_MAXSTEPS,
    P_SPILL,
    P_LAKES,
    P_PIT,
    P_ROOT,
) = range(22)
P_SIZE = 22


def reference_length(p: HydrologyParams, cell_size: float) -> float:
    """ℓ in metres: ``length_scale``; two cells when it is unset, one cell when it is 0."""
    if p.length_scale is None:
        return 2.0 * float(cell_size)
    return float(p.length_scale) if p.length_scale > 0 else float(cell_size)


def droplets_per_cycle(p: HydrologyParams, shape: tuple[int, int], cell_size: float) -> int:
    """Droplets between stream updates: ``cycle_droplets`` per (256 ℓ)² of map area."""
    ell = reference_length(p, cell_size)
    area = shape[0] * shape[1] * cell_size**2
    return max(1, int(round(p.cycle_droplets * area / (256.0 * ell) ** 2)))


BATCHES_PER_CYCLE = 8  # the default batch: an eighth of a cycle's droplets (hydrology/batch.py)


def batch_size(p: HydrologyParams, per_cycle: int) -> int:
    """Droplets descending in parallel each round (the batch's slots): ``batch``; unset, ⌈droplets per cycle / 8⌉;
    0 = serial.

    A fixed share of the cycle keeps the droplets that do not see each other's erosion at the same
    density on every map size (the cycle's droplets scale with the map's area): measured on the
    library terrain at 512², batches of an eighth of a cycle match the serial order's erosion and
    step counts within the seed-to-seed scatter, whole-cycle batches erode ~5 % less."""
    if p.batch is None:
        return max(1, -(-per_cycle // BATCHES_PER_CYCLE))
    return int(p.batch)


def kernel_constants(p: HydrologyParams, cell_size: float) -> np.ndarray:
    """The float64 vector the Numba kernels read (indices ``P_*``), all in m, s, m³."""
    ell = reference_length(p, cell_size)
    v0 = ell**3 / p.volume_factor
    sea = -math.inf if p.sea_level is None else float(p.sea_level)
    c = np.zeros(P_SIZE)
    c[P_DT] = p.dt
    c[P_FRIC] = p.friction
    c[P_EVAP] = p.evaporation
    c[P_KD] = p.deposition
    c[P_CAP] = p.capacity * ell  # × 1 s: c_eq = cap·(V/V₀)·|v|·Δh in m³
    c[P_ACC] = ell  # ℓ/s²
    c[P_AMIN] = 0.01 * ell  # the seed's |a| < 0.01 (cells/time²)
    c[P_DENS] = p.density
    c[P_V0] = v0
    c[P_VMIN] = p.min_volume * v0
    c[P_DX] = cell_size
    c[P_CA] = cell_size**2
    c[P_MAXSTEP] = p.max_step
    c[P_FOOT] = max(1, int(round(ell / cell_size)))
    c[P_SEA] = sea
    c[P_EDGE] = sea  # off-map entries: the sea level, −∞ (open edges) without a sea
    c[P_DRAIN] = p.drainage
    c[P_MAXSTEPS] = p.max_steps
    c[P_SPILL] = p.spill
    c[P_LAKES] = 1.0 if p.lakes else 0.0
    c[P_PIT] = 1.0 if p.pit_flood else -1.0  # > 0: a droplet trapped in a pit floods there
    return c
