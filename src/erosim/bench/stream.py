"""Benchmark of particle-stream erosion (``erosim bench stream``): throughput and O(n) in particles.

Fixed work per particle, whatever the count, so that time per particle measures the method's cost
alone: a fixed 512² generated terrain (``hills``, 10 m cells) with strata hardness that follows the
cut (the library scenario's mode, the heavier kernel), eight emitters on the west edge heading east,
each particle making exactly ``STEPS`` impacts (speed 1.5 cells, so it never leaves the map) with a
radius of influence of 4 cells per unit mass (≈ 50 cells per impact). The stream runs on one thread
by design (see :mod:`erosim.erosion.particle_stream_warszawski`). Each count is timed after a
warm-up (JIT compile excluded), repeated until at least ``MIN_TIME`` s have been measured; the
median repeat counts. Wall time gives the throughput (``particles_per_s``, ``updates_per_s``); the
process's CPU time (one thread) gives the linearity check, because on a shared machine wall time
also counts other jobs' load (``us_per_particle_cpu_spread`` ≤ 0.2 ⇒ ``linear_within_20pct``).
"""

from __future__ import annotations

import time

import numpy as np

from erosim.core.devices import cuda_status
from erosim.core.errors import ConfigError
from erosim.erosion.particle_stream_warszawski import Emitter, ParticleStream
from erosim.terrain import hardness
from erosim.terrain.generate import generate
from erosim.terrain.hardness import Strata

SIZE = 512
CELL = 10.0
STEPS = 32
EMITTERS = 8
POOL = 64
MIN_TIME = 1.0
STRATA = Strata(thickness=(12.0, 5.0, 9.0, 4.0), hardness=(0.25, 0.85, 0.45, 0.7), tilt_x=0.01)


def _emitters(particles: int, steps: int = STEPS) -> list[Emitter]:
    counts = [particles // EMITTERS + (1 if k < particles % EMITTERS else 0) for k in range(EMITTERS)]
    return [
        Emitter(
            x=0.02,
            y=(k + 0.5) / EMITTERS,
            width=8 * CELL,
            particles=counts[k],
            steps=steps,
            speed=1.5 * CELL,
            max_speed=3 * CELL,
            max_angle_deg=12.0,
            gamma_deg=15.0,
            steer=0.05,
            spread_deg=1.0,
            depth_per_mass=0.01,
            radius_per_mass=4 * CELL,
        )
        for k in range(EMITTERS)
    ]


def _spread(values: list) -> float | None:
    """max/min − 1 of the per-particle times (0 = perfectly linear in n)."""
    v = [x for x in values if x]
    return max(v) / min(v) - 1.0 if v else None


def run(particles: list[int], impacts_per_particle: int = STEPS, device: str = "cpu") -> dict:
    """Time streams of each particle count; returns ``{"runs": [...], ...}`` (one JSON object).

    ``impacts_per_particle`` is how many times a particle acts (moves, collides, deforms) before it
    returns to the pool: 32 by default, like the library scenario's streams; 1 is the seed's
    reading (ST-2: after one deformation the particle goes back to the pool), where
    ``particles_per_s`` equals ``updates_per_s``. ``device = "cuda"``: the sweeps run on the GPU
    (:mod:`erosim.erosion.particle_stream_cuda`, the same pool: 512 slots act at once), ``threads``
    then counts the host's one thread and ``gpu`` names the device.
    """
    if impacts_per_particle < 1:

        raise ConfigError(f"--impacts-per-particle {impacts_per_particle} is not valid; give 1 or more.")
    counts = [int(n) for n in particles]
    hm = generate("hills", SIZE, CELL, 0, relief=40.0)
    d0 = hardness.strata(hm.z, CELL, STRATA)
    gpu = None
    if device == "cuda":
        from erosim.erosion.particle_stream_cuda import DeviceStream as gpu
    ParticleStream(hm.z, d0, CELL, _emitters(64), 0, STRATA, pool=POOL, gpu=gpu).run()  # JIT warm-up
    runs = []
    for n in counts:
        walls, cpus, impacts = [], [], 0
        while not walls or (sum(walls) < MIN_TIME and len(walls) < 20):
            s = ParticleStream(hm.z, d0, CELL, _emitters(n, impacts_per_particle), 0, STRATA, pool=POOL, gpu=gpu)
            t0, c0 = time.perf_counter(), time.process_time()
            s.run(batch=4096)
            walls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
            impacts = s.impacts
        dt, cpu = float(np.median(walls)), float(np.median(cpus))
        runs.append(
            {
                "particles": n,
                "impacts": impacts,
                "seconds": dt,
                "cpu_seconds": cpu,
                "particles_per_s": n / dt if dt > 0 else None,
                "updates_per_s": impacts / dt if dt > 0 else None,
                "us_per_particle": 1e6 * dt / n if n else None,
                "us_per_particle_cpu": 1e6 * cpu / n if n else None,
                "us_per_update": 1e6 * dt / impacts if impacts else None,
                "repeats": len(walls),
            }
        )
    spread = _spread([r["us_per_particle"] for r in runs])
    spread_cpu = _spread([r["us_per_particle_cpu"] for r in runs])
    return {
        "benchmark": "particle-stream (Warszawski)",
        "map": f"{SIZE}x{SIZE} cells of {CELL:g} m, strata hardness following the cut",
        "steps_per_particle": impacts_per_particle,
        "emitters": EMITTERS,
        "pool_per_emitter": POOL,
        "threads": 1,
        "device": device,
        **({"gpu": cuda_status()[1]} if device == "cuda" else {}),
        "runs": runs,
        "updates_per_s": runs[-1]["updates_per_s"] if runs else None,  # the largest particle count's
        "us_per_particle_spread": spread,
        "us_per_particle_cpu_spread": spread_cpu,
        # needs two counts or more to say anything
        "linear_within_20pct": (spread_cpu <= 0.20) if spread_cpu is not None and len(runs) > 1 else None,
        "min_updates_per_s": min(r["updates_per_s"] for r in runs) if runs else None,
        "target_updates_per_s": 1e6,
    }
