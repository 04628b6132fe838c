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

import numpy as np

from erosim.core.callbacks import Callback
from erosim.core.errors import ConfigError
from erosim.core.schedules import IterationInterval, Schedule, TimeInterval
from erosim.scenarios.schema_common import build_terrain, terrain_facts
from erosim.scenarios.setup import Setup
from erosim.simulation.callbacks import Animation, BudgetCheck, MapFrames

MAPS = ("height_initial", "height", "lake_depth", "stream", "erosion", "deposition", "vegetation")


def _inputs(cfg, shape):
    rain = erod = None
    if cfg.inputs.rain_map:
        from erosim.io.heightmaps import read

        rain = read(cfg.inputs.rain_map).z
    if cfg.inputs.hardness_map:
        from erosim.terrain import hardness

        erod = 1.0 - hardness.load(cfg.inputs.hardness_map, shape)
    return rain, erod


def build_model(cfg, *, timing: bool = False):
    """The terrain and a fresh :class:`HydrologyModel` for a validated ``HydrologyScenario`` (on
    ``run.device``: the droplet batches on the GPU with ``cuda``)."""
    from erosim.hydrology.model import HydrologyModel

    terrain = build_terrain(cfg.terrain, cfg.seed)
    rain, erod = _inputs(cfg, terrain.shape)
    gpu = None
    if cfg.run.device == "cuda":
        from erosim.hydrology.droplets_cuda import DeviceDroplets as gpu
    model = HydrologyModel(
        terrain, cfg.hydrology, cfg.vegetation, cfg.seed, rain=rain, erodibility=erod, timing=timing, gpu=gpu,
    )  # fmt: skip
    return terrain, model


FIGURE_CELLS = 1024  # the figures are ~800 px across: drawn from maps of at most this many cells a side


def figure_step(shape) -> int:
    """Stride that brings a map to at most ``FIGURE_CELLS`` cells a side for a figure (1 when smaller): a
    4096² run's pictures then cost what a 1024² run's do instead of 16 times that in memory."""
    return max(1, -(-max(shape) // FIGURE_CELLS))


def picture(model, step: int = 1):
    """The combined hydrology map (HY-9) of the model's current state, every ``step``-th cell."""
    from erosim.hydrology import pools, vegetation
    from erosim.hydrology.params import P_SEA
    from erosim.viz.maps import hydrology_map

    s = slice(None, None, step)
    z = model.z[s, s]
    depth = pools.depth_map(model.lake_of.reshape(model.z.shape)[s, s], model.level, z)
    veg = vegetation.root_density(model.cover[s, s], model.veg, (depth > 0) | (z < model.P[P_SEA]))
    return hydrology_map(z, model.cell_size * step, model.stream[s, s], depth, vegetation=veg)


def _thumbnail(model, size: int = 256):
    return picture(model, max(1, model.z.shape[0] // size, model.z.shape[1] // size))


def _frame_maps(model) -> dict:
    """What a map frame holds (``maps/frames/``, the view's time slider): the height and the lakes."""
    return {"height": model.z, "lake_depth": model.lake_depth()}


def write_outputs(model, terrain, folder) -> dict:
    """Maps, engine exports and pictures of the model's current state into a run folder; their ranges."""
    from erosim.io import heightmaps as hio

    maps = {
        "height_initial": model.z0,
        "height": model.z,
        "lake_depth": model.lake_depth(),
        "stream": model.stream,
        "erosion": model.erosion(),
        "deposition": model.deposition(),
        "vegetation": model.vegetation(),
    }
    info: dict = {"maps": {}, "masks": {}}
    for name, arr in maps.items():
        hio.write(folder.maps / f"{name}.tif", np.ascontiguousarray(arr), like=terrain)
        info["maps"][name] = {"path": f"maps/{name}.tif", "min": float(arr.min()), "max": float(arr.max())}
    # the 16-bit exports and pictures: one that fails is a warning, never the loss of the maps above
    with folder.picture(folder.maps / "height.png"):
        png = hio.write(folder.maps / "height.png", model.z, like=terrain)
        raw = hio.write(folder.maps / "height.r16", model.z, like=terrain)
        info["heightmap_16bit"] = {
            "png": "maps/height.png",
            "raw16": "maps/height.r16",
            "raw16_shape": list(model.z.shape),
            "height_range": png["height_range"],
            "raw16_height_range": raw["height_range"],
            "rescale": "z = lo + q·(hi − lo)/65535",
        }
    with folder.picture(folder.maps / "mask_*.png"):
        for name in ("stream", "lake_depth", "erosion", "deposition", "vegetation"):
            vmax = 1.0 if name in ("stream", "vegetation") else None
            m = hio.write_mask_png16(folder.maps / f"mask_{name}.png", maps[name], vmax=vmax)
            info["masks"][name] = {"path": f"maps/mask_{name}.png", "vmax": m["vmax"]}
    with folder.picture(folder.figures):
        from erosim.viz.maps import DARK_BLUE, FOREST, GROUND, LIGHT_BLUE
        from erosim.viz.plots import change_figure, extent_of, hillshade_figure, map_figure

        box = extent_of(terrain.transform, model.z.shape, model.cell_size)
        k = figure_step(model.z.shape)
        s, cs = slice(None, None, k), model.cell_size * k
        hillshade_figure(folder.figures / "hillshade_before.png", model.z0[s, s], cs, "Terrain before", box)
        hillshade_figure(folder.figures / "hillshade_after.png", model.z[s, s], cs, "Terrain after", box)
        legend = [("stream", LIGHT_BLUE), ("lake", DARK_BLUE), ("forest", FOREST), ("bare ground", GROUND)]
        map_figure(folder.figures / "hydrology.png", picture(model, k), cs, "Rivers, lakes and forest", legend=legend,
                   extent=box)  # fmt: skip
        change_figure(folder.figures / "erosion_deposition.png", maps["deposition"][s, s] - maps["erosion"][s, s], cs,
                      "Erosion and deposition", box)  # fmt: skip
    return info


class HydrologyOutputs(Callback):
    """The final maps, masks and pictures of a completed run (:func:`write_outputs`)."""

    def __init__(self, model, terrain):
        super().__init__(Schedule(), name="outputs")
        self.model, self.terrain = model, terrain

    def finalize(self, sim) -> dict[str, Any]:
        return {"outputs": write_outputs(self.model, self.terrain, sim.out)}


class TileExits(Callback):
    """A tile of a tiled build: writes the droplets that left it (``exits.npy``) when it completes."""

    def __init__(self, exchange):
        super().__init__(Schedule(), name="tile_exits")
        self.exchange = exchange

    def finalize(self, sim) -> dict[str, Any]:
        from erosim.hydrology.tile_exchange import EXITS, write_exits

        write_exits(sim.out.path, self.exchange)
        return {"tile_exchange": {"exits": EXITS, "flow_m3": [float(v) for v in self.exchange.flow]}}


def _tile_member(model, member: str) -> TileExits:
    """Attach a tile's exchange (:mod:`erosim.hydrology.tile_exchange`) and its starting stream map."""
    from erosim.hydrology.tile_exchange import load_member, read_stream

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
        callbacks.append(_tile_member(model, cfg.tiles.member))
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
            Animation(TimeInterval(interval), lambda sim: _thumbnail(model), out.path / "figures" / "evolution.gif")
        )
        callbacks.append(MapFrames(TimeInterval(interval), lambda sim: _frame_maps(model), terrain, "cycles"))
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
