"""``erosim bench flood``: a dam-break flood down a 10 km valley with the shallow-water SPH (issue 9).

The valley (generated, :func:`valley_dem`): 10 km long and 4 km wide on 20 m cells, a flat floor
``floor_width`` wide falling 0.5 % northward between side slopes of 10 %, with gentle noise. A dam
line crosses it 4 km from its upstream (south) end; the reservoir behind it is filled to 21 m above
the floor at the dam (about 50 Mm³) and the whole dam fails at t = 0; the water leaves by the
north edge. The run is the ``flood`` kind's own set-up and solver (settling included), with the
hazard maxima raised every step, for ``t_end`` simulated seconds (4000 in the issue's target).

Reported: ``particles`` (at the start and the most at any time), ``steps``, ``settle_steps``,
``particle_steps_per_s`` (particles × steps over the wall time of the run, settling excluded),
``pair_interactions_per_s``, ``simulated_s_per_wall_s``, ``wall_s`` (run) and ``setup_s`` (set-up
and settling), ``volume_released_m3``, ``flooded_area_m2``, ``peak_rss_mb``, ``threads`` and
``device`` (with ``--device cuda`` the steps and the hazard maxima run on the GPU; the set-up and
the settling run on the host either way).
"""

from __future__ import annotations

import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from erosim.analysis.hazard import HazardMaps
from erosim.bench import threading_layer
from erosim.core.heightmap import Heightmap, default_transform
from erosim.io.heightmaps import write
from erosim.scenarios import loader
from erosim.scenarios.flood.build import build

LENGTH, WIDTH, CELL = 10_000.0, 4_000.0, 20.0
FLOOR_SLOPE, SIDE_SLOPE = 0.005, 0.10
DAM_Y = 4_000.0  # m from the upstream (south) end
DEPTH_AT_DAM = 21.0


def valley_dem(floor_width: float = 1000.0, seed: int = 7):
    """The benchmark's valley as a Heightmap (row 0 north; x east, y north from the south-west corner)."""

    ny, nx = int(LENGTH / CELL), int(WIDTH / CELL)
    x = (np.arange(nx) + 0.5) * CELL
    y = (np.arange(ny)[::-1] + 0.5) * CELL
    X, Y = np.meshgrid(x, y)
    side = np.maximum(np.abs(X - WIDTH / 2) - floor_width / 2, 0.0) * SIDE_SLOPE
    z = FLOOR_SLOPE * (LENGTH - Y) + side
    rng = np.random.default_rng(seed)
    from scipy import ndimage

    z = z + ndimage.gaussian_filter(rng.normal(0.0, 1.0, z.shape), 3.0) * 2.0  # metre-scale undulation
    return Heightmap(z=z, cell_size=CELL, transform=default_transform(ny, nx, CELL))


def setup(
    t_end: float = 4000.0, spacing: float = 20.0, *, split: bool | None = None, device: str = "cpu", overrides=()
):
    """(site, solver, cfg, setup seconds): the benchmark's flood built and settled, ready to run
    (``split``: None keeps the scenario's default; ``overrides``: more ``key=value`` settings of the scenario)."""

    hm = valley_dem()
    level = FLOOR_SLOPE * (LENGTH - DAM_Y) + DEPTH_AT_DAM
    with tempfile.TemporaryDirectory() as tmp:
        dem = Path(tmp) / "valley.tif"
        write(dem, hm)
        scenario = loader.load(
            "flood",
            [
                f"terrain.file={dem}",
                f"reservoir.level={level!r}",
                f"reservoir.seed=[{WIDTH / 2!r}, {DAM_Y / 2!r}]",
                f"reservoir.barrier=[[0.0, {DAM_Y!r}], [{WIDTH!r}, {DAM_Y!r}]]",
                "outflow.edges=['north']",
                f"flood.spacing={spacing!r}",
                *([] if split is None else [f"flood.split={'true' if split else 'false'}"]),
                f"run.t_end={t_end!r}",
                f"run.device={device}",
                *overrides,
            ],
        )
        cfg = scenario.config.model_copy(update={"breach": None})
        t0 = time.perf_counter()
        site, solver = build(cfg)
        setup_s = time.perf_counter() - t0
    return site, solver, cfg, setup_s


def run(
    t_end: float = 4000.0, spacing: float = 20.0, *, split: bool | None = None, device: str = "cpu", overrides=()
) -> dict:
    """Run the benchmark flood; returns the JSON-able result (keys in the module docstring)."""
    import numba


    site, solver, cfg, setup_s = setup(t_end, spacing, split=split, device=device, overrides=overrides)
    maps = HazardMaps(site.terrain.shape, cfg.flood.wet_depth)
    n0 = solver.n
    most = n0
    particle_steps = 0
    pairs = 0
    t1 = time.perf_counter()
    while solver.t < t_end - 1e-9:
        solver.step()
        solver.update_maxima(maps, maps.wet_depth)
        particle_steps += solver.n
        pairs += solver.neighbour_pairs
        most = max(most, solver.n)
        if solver.n == 0:
            break
    wall = time.perf_counter() - t1
    solver.sync_maxima(maps)
    summary = maps.summary(CELL * CELL)
    return {
        "case": "10 km valley dam break (shallow-water SPH)",
        "particles": n0,
        "particles_max": most,
        "spacing_m": spacing,
        "steps": solver.steps,
        "settle_steps": solver.settle_steps,
        "simulated_s": solver.t,
        "particle_steps_per_s": particle_steps / wall if wall > 0 else None,
        "pair_interactions_per_s": pairs / wall if wall > 0 else None,
        "simulated_s_per_wall_s": solver.t / wall if wall > 0 else None,
        "wall_s": round(wall, 2),
        "setup_s": round(setup_s, 2),
        "volume_released_m3": solver.volume_initial,
        "volume_out_m3": solver.volume_out,
        "flooded_area_m2": summary["flooded_area_m2"],
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "threads": numba.get_num_threads(),
        "threading_layer": threading_layer(),
        "device": device,
    }
