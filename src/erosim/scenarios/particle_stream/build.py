"""The ``particle-stream`` kind (Warszawski particle-stream erosion, SPEC ST): terrain + hardness + emitters.

What a run leaves (every file written atomically):

* ``scenario.toml`` (resolved), ``report.json`` with ``removed_volume`` (m³, Σ(h₀ − h)·Δ²), the
  kernel's own running count of it, particles, impacts, throughput, deepest cut and eroded area;
* ``maps/height_initial.tif``, ``maps/height.tif`` (GeoTIFF, float32, georeference kept from a DEM),
  ``maps/height.png`` (PNG16) and ``maps/height.r16`` (RAW16; its height range is in the report),
  ``maps/hardness_initial.tif`` and ``maps/hardness.tif`` (final: strata that follow the cut change
  it), ``maps/erosion.tif`` (h₀ − h, m) and ``maps/erosion_mask.png`` (PNG16 texture mask, 0…max);
* ``figures/hillshade_before.png``, ``figures/hillshade_after.png``, ``figures/strata_after.png``
  (shaded relief tinted by hardness), ``figures/erosion.png`` and ``figures/canyon.png`` (that map
  beside a cross-section through the deepest cut, rock coloured by hardness);
* ``checkpoint/state.npz`` every ``stream.checkpoint_wall_s``, at the end and on Ctrl-C;
  ``erosim run --resume DIR`` continues exactly (counter-based random numbers need no RNG state).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from erosim.core.errors import InputError
from erosim.core.heightmap import Heightmap
from erosim.core.schedules import IterationInterval
from erosim.erosion.particle_stream_warszawski import Emitter, ParticleStream
from erosim.scenarios.particle_stream.outputs import StreamOutputs
from erosim.scenarios.particle_stream.schema import HardnessSection, StreamScenario
from erosim.scenarios.schema_common import build_terrain, terrain_facts
from erosim.scenarios.setup import Setup
from erosim.simulation.callbacks import BudgetCheck
from erosim.terrain import hardness as hardness_mod
from erosim.terrain.hardness import Strata

#: Emitter fields that are lengths, scaled by the cell size when length_unit = "cells": the horizontal
#: ones and the depth of a cut, so that a canyon keeps its shape in cells on any DEM (10 cells wide and
#: 7 deep on the library's 10 m cells is 10 m wide and 7 m deep on a 1 m lidar tile, not a 70 m slot).
LENGTH_FIELDS = ("width", "length", "speed", "max_speed", "radius_per_mass", "pivot_offset", "depth_per_mass")


def build_hardness(section: HardnessSection, hm: Heightmap, seed: int) -> tuple[np.ndarray, Strata | None]:
    """The initial hardness map for ``hm`` and, for strata that follow the cut, their Strata."""
    kind = section.kind
    if kind == "file":
        return hardness_mod.load(section.file, hm.shape), None
    if kind == "uniform":
        return np.full(hm.shape, float(section.value)), None
    if kind == "noise":
        return hardness_mod.noise(hm.shape, seed + 7919, section.noise_scale, section.low, section.high), None
    if kind == "classes":
        cm = _read_classes(section.class_file, hm.shape)
        return hardness_mod.classes(cm, {int(k): v for k, v in section.materials.items()}), None
    spec = Strata(tuple(section.thickness), tuple(section.values), section.base, section.tilt_x, section.tilt_y)
    return hardness_mod.strata(hm.z, hm.cell_size, spec), (spec if section.follow_cut else None)


def _read_classes(path: str, shape: tuple[int, int]) -> np.ndarray:
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise InputError(f"Class map '{p}' does not exist; check hardness.class_file.")
    if p.suffix.lower() == ".npy":
        cm = np.load(p, allow_pickle=False)
    elif p.suffix.lower() in (".tif", ".tiff"):
        import rasterio

        with rasterio.open(p) as src:
            cm = src.read(1)
    else:
        from PIL import Image

        with Image.open(p) as img:
            cm = np.asarray(img)
    if cm.shape != tuple(shape):
        raise InputError(f"Class map '{p}' has shape {cm.shape} but the terrain has {tuple(shape)}; they must match.")
    return cm


def emitters_in_metres(cfg: StreamScenario, cell_size: float) -> dict[str, Emitter]:
    """The scenario's emitters (by name) with horizontal lengths in metres (the physics' unit)."""
    out = {}
    for name, em in cfg.emitters.items():
        if cfg.stream.length_unit == "cells":
            em = em.model_copy(update={k: getattr(em, k) * cell_size for k in LENGTH_FIELDS})
        out[name] = em
    return out


def build(cfg: StreamScenario) -> tuple[Heightmap, np.ndarray, ParticleStream]:
    """(initial heightmap, initial hardness, stream ready to run) for a validated scenario.

    One ``advance()`` of the stream is about ``stream.impacts_per_batch`` impacts (whole sweeps of
    the pool): the unit between progress updates and checkpoint checks.
    """
    hm = build_terrain(cfg.terrain, cfg.seed)
    d0, strata = build_hardness(cfg.hardness, hm, cfg.seed)
    emitters = emitters_in_metres(cfg, hm.cell_size)
    rounds = max(1, cfg.stream.impacts_per_batch // max(1, len(emitters) * cfg.stream.pool))
    stream = ParticleStream(
        hm.z, d0, hm.cell_size, emitters, cfg.seed, strata, pool=cfg.stream.pool, rounds=rounds, outside=hm.nodata
    )
    return hm, d0, stream


def setup(scenario, out) -> Setup:
    """The stream and its outputs for a ``particle-stream`` run (see the module docstring)."""
    cfg: StreamScenario = scenario.config
    hm, d0, stream = build(cfg)
    facts, assumed = terrain_facts(hm, cfg.terrain)
    warnings = list(hm.notes)
    if facts["nodata_cells"]:
        warnings.append(
            f"{facts['nodata_cells']} cells of the terrain are nodata: outside the map, like its edge (a "
            "particle reaching one leaves, none is cut); the maps keep them as nodata."
        )
    if cfg.stream.length_unit == "cells":
        assumed.append(f"scaled: emitter lengths and depths in cells of {hm.cell_size:g} m (stream.length_unit)")
    stream.advance(0)  # compile (or load the cached kernel) outside the timed stream
    # the removed material leaves the map (the method does not deposit): Σ Δz·A = −removed volume
    budget = BudgetCheck(
        IterationInterval(1), stream.h, lambda: (0.0, stream.removed_volume()), hm.cell_size**2, "The particle stream"
    )

    def report(sim) -> dict[str, Any]:
        erosion = hm.z - stream.h
        area = hm.cell_size**2
        wall = sim.wall_time_total
        return {
            "method": "particle stream over a hardness map (Warszawski, seed 004)",
            "removed_volume": float(erosion.sum() * area),
            "removed_volume_unit": "m3",
            "removed_volume_kernel": stream.removed_volume(),
            "max_depth": float(erosion.max()),
            "eroded_area_m2": float((erosion > 0).sum() * area),
            "particles": stream.particles_emitted,
            "impacts": stream.impacts,
            "emitters": list(cfg.emitters),
            "hardness_source": cfg.hardness.kind,
            "strata_follow_cut": stream.strata is not None,
            "terrain": facts,
            "stream_wall_s": wall,
            "impacts_per_s": stream.impacts / wall if wall > 0 else None,
        }

    def summary(sim, rep: dict) -> dict[str, Any]:
        return {
            "removed_volume_m3": rep["removed_volume"],
            "max_depth_m": rep["max_depth"],
            "particles": rep["particles"],
            "impacts": rep["impacts"],
            "impacts_per_s": rep["impacts_per_s"],
        }

    return Setup(
        models=[stream], callbacks=[budget, StreamOutputs(hm, d0, stream)], stop_time=float(stream.particles_total),
        unit="particles", report=report, summary=summary, checkpoint_wall_s=cfg.stream.checkpoint_wall_s,
        seed=cfg.seed, warnings=warnings, assumed=assumed,
    )  # fmt: skip
