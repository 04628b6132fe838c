"""The ``hydrology`` kind (SPEC HY-1…HY-9): terrain, rain and hardness maps → a hydrology model.

A run cycles :class:`erosim.hydrology.model.HydrologyModel` ``run.cycles`` times and, when done, writes

* ``maps/``: height_initial.tif, height.tif, lake_depth.tif, stream.tif, erosion.tif, deposition.tif,
  vegetation.tif (GeoTIFF float32, the input's CRS kept); height.png (PNG16) and height.r16 (RAW16
  little-endian) with their height range in report.json; 16-bit PNG masks mask_stream.png,
  mask_lake_depth.png, mask_erosion.png, mask_deposition.png, mask_vegetation.png
  (value = q·vmax/65535, vmax in report.json);
* ``figures/``: hillshade_before.png, hillshade_after.png, hydrology.png (HY-9: light blue streams,
  dark blue lakes, green forest; legend), erosion_deposition.png (diverging scale in metres), each
  with axes in the DEM's coordinates and a scale bar; evolution.gif (``run.frames`` pictures);
* ``maps/frames/``: height_NNNNN.tif and lake_depth_NNNNN.tif at the same times and the end
  (:mod:`erosim.io.map_frames`; ``erosim view``'s time slider);
* ``report.json``: water_budget, sediment_budget, statistics, output list and ranges.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

from erosim.core.errors import ConfigError
from erosim.core.schedules import IterationInterval, TimeInterval
from erosim.hydrology.model import HydrologyModel
from erosim.hydrology.tile_exchange import load_member, read_stream
from erosim.io.heightmaps import read
from erosim.scenarios.hydrology.outputs import HydrologyOutputs, TileExits, frame_maps, thumbnail
from erosim.scenarios.schema_common import build_terrain, terrain_facts
from erosim.scenarios.setup import Setup
from erosim.simulation.callbacks import Animation, BudgetCheck, MapFrames
from erosim.terrain import hardness


def _inputs(cfg, shape):
    rain = erod = None
    if cfg.inputs.rain_map:

        rain = read(cfg.inputs.rain_map).z
    if cfg.inputs.hardness_map:

        erod = 1.0 - hardness.load(cfg.inputs.hardness_map, shape)
    return rain, erod


def build_model(cfg, *, timing: bool = False):
    """The terrain and a fresh :class:`HydrologyModel` for a validated ``HydrologyScenario`` (on
    ``run.device``: the droplet batches on the GPU with ``cuda``)."""

    terrain = build_terrain(cfg.terrain, cfg.seed)
    rain, erod = _inputs(cfg, terrain.shape)
    gpu = None
    if cfg.run.device == "cuda":
        from erosim.hydrology.droplets_cuda import DeviceDroplets as gpu
    model = HydrologyModel(
        terrain, cfg.hydrology, cfg.vegetation, cfg.seed, rain=rain, erodibility=erod, timing=timing, gpu=gpu,
    )  # fmt: skip
    return terrain, model


def tile_member(model, member: str) -> TileExits:
    """Attach a tile's exchange (:mod:`erosim.hydrology.tile_exchange`) and its starting stream map."""
    exchange, stream = load_member(member)
    model.attach_exchange(exchange)
    if stream is not None:  # rounds ≥ 2 go on from the last round's stream map
        model.stream[...] = read_stream(stream)
    return TileExits(exchange)


def setup(scenario, out) -> Setup:
    """The model and callbacks of a ``hydrology`` run (see the module docstring)."""
    cfg = scenario.config
    if cfg.tiles.size:  # a tiled build runs its tiles as runs of tiles.size = 0 (erosim.tiles.build)
        raise ConfigError(
            "This scenario asks for a tiled build (tiles.size > 0), which `erosim run` makes (docs/tiles.md); "
            "from Python call erosim.tiles.build.run_tiled, or set tiles.size=0 for one run."
        )
    terrain, model = build_model(cfg)
    callbacks: list = []
    if cfg.tiles.member:  # one tile of a tiled build: droplets pass to and from its neighbours
        callbacks.append(tile_member(model, cfg.tiles.member))
    warnings = list(terrain.notes)
    facts, assumed = terrain_facts(terrain, cfg.terrain)
    if facts["nodata_cells"]:
        warnings.append(
            f"{facts['nodata_cells']} cells of the terrain are nodata: outside the world, like the map's edge "
            "(water reaching them leaves and counts in water_budget.left_edges); the maps keep them as nodata."
        )
    how = "hydrology.length_scale" if cfg.hydrology.length_scale else "one cell"  # set in m, or 0
    if cfg.hydrology.length_scale is None:
        how = "two cells, hydrology.length_scale unset"
    order = f"in parallel batches of {model.batch}" if model.batch else "one after another (the seed's order)"
    assumed.append(f"scaled: ℓ = {model.ell:g} m ({how}), {model.per_cycle} droplets per cycle "
                   f"({cfg.hydrology.cycle_droplets} per (256 ℓ)² of map), {order}")  # fmt: skip
    ratio = model.ell / model.cell_size
    if ratio > 8:
        warnings.append(
            f"hydrology.length_scale ({model.ell:g} m) spans {ratio:.0f} cells of {model.cell_size:g} m: "
            "droplet footprints are large and the run is slow; set terrain.cell_size to the DEM's "
            "real cell size or lower hydrology.length_scale."
        )
    if cfg.run.frames > 0:
        interval = max(1, cfg.run.cycles // cfg.run.frames)
        callbacks.append(
            Animation(TimeInterval(interval), lambda sim: thumbnail(model), out.path / "figures" / "evolution.gif")
        )
        callbacks.append(MapFrames(TimeInterval(interval), lambda sim: frame_maps(model), terrain, "cycles"))
    callbacks.append(
        BudgetCheck(
            IterationInterval(16), model.z, model.sediment_in_transit, model.cell_size**2, "The hydrology model"
        )
    )
    callbacks.append(HydrologyOutputs(model, terrain))

    def report(sim) -> dict[str, Any]:
        stats = model.stats()
        done = sim.iteration - sim.iteration_start
        stats["droplets_per_s"] = (
            model.per_cycle * done / sim.wall_time if sim.wall_time > 0 and done and not sim.resumed else None
        )
        return {
            "terrain": facts,
            "scaled": {"length_scale_m": model.ell, "droplets_per_cycle": model.per_cycle},
            "water_budget": model.water_budget(),
            "sediment_budget": model.sediment_budget(),
            "statistics": stats,
        }

    def summary(sim, rep: dict) -> dict[str, Any]:
        stats = rep["statistics"]
        return {
            "droplets": stats["droplets"],
            "cycles": stats["cycles"],
            "lake_fraction": round(stats["lake_fraction"], 4),
            "tree_fraction": round(stats["tree_fraction"], 4),
            "water_closure_rel": rep["water_budget"]["closure_rel"],
            "sediment_closure_rel": rep["sediment_budget"]["closure_rel"],
            "wall_s": round(sim.wall_time, 2),
        }

    return Setup(
        models=[model], callbacks=callbacks, stop_time=float(cfg.run.cycles), unit="cycles", report=report,
        summary=summary, checkpoint_wall_s=cfg.run.checkpoint_interval, seed=cfg.seed, warnings=warnings,
        assumed=assumed,
    )  # fmt: skip


def clear_demo_folder(out: Path) -> None:
    """Empty ``out`` for a new demo — only if it is empty or a folder erosim wrote."""
    if not out.exists():
        return
    if not out.is_dir():
        raise ConfigError(f"Demo output '{out}' is a file; pass another --out folder.")
    entries = list(out.iterdir())
    if entries and not ((out / "report.json").exists() or (out / "scenario.toml").exists()):
        raise ConfigError(f"Demo output '{out}' holds files erosim did not write; pass an empty or new --out folder.")
    shutil.rmtree(out)
