"""What a `hydrology` run writes: the maps (GeoTIFF, 16-bit PNG), the overview picture and its
thumbnail, the frames of the animation, and the budget of water and sediment in the report.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from erosim.core.callbacks import Callback
from erosim.core.schedules import Schedule
from erosim.hydrology import pools, vegetation
from erosim.hydrology.params import P_SEA
from erosim.hydrology.tile_exchange import EXITS, write_exits
from erosim.io import heightmaps as hio
from erosim.viz.maps import DARK_BLUE, FOREST, GROUND, LIGHT_BLUE, hydrology_map
from erosim.viz.plots import change_figure, extent_of, hillshade_figure, map_figure

MAPS = ("height_initial", "height", "lake_depth", "stream", "erosion", "deposition", "vegetation")


FIGURE_CELLS = 1024  # the figures are ~800 px across: drawn from maps of at most this many cells a side


def figure_step(shape) -> int:
    """Stride that brings a map to at most ``FIGURE_CELLS`` cells a side for a figure (1 when smaller): a
    4096² run's pictures then cost what a 1024² run's do instead of 16 times that in memory."""
    return max(1, -(-max(shape) // FIGURE_CELLS))


def picture(model, step: int = 1):
    """The combined hydrology map (HY-9) of the model's current state, every ``step``-th cell."""

    s = slice(None, None, step)
    z = model.z[s, s]
    depth = pools.depth_map(model.lake_of.reshape(model.z.shape)[s, s], model.level, z)
    veg = vegetation.root_density(model.cover[s, s], model.veg, (depth > 0) | (z < model.P[P_SEA]))
    return hydrology_map(z, model.cell_size * step, model.stream[s, s], depth, vegetation=veg)


def thumbnail(model, size: int = 256):
    return picture(model, max(1, model.z.shape[0] // size, model.z.shape[1] // size))


def frame_maps(model) -> dict:
    """What a map frame holds (``maps/frames/``, the view's time slider): the height and the lakes."""
    return {"height": model.z, "lake_depth": model.lake_depth()}


MASKS = ("stream", "lake_depth", "erosion", "deposition", "vegetation")  # the 16-bit masks (mask_NAME.png)


def write_outputs(model, terrain, folder) -> dict:
    """Maps, engine exports and pictures of the model's current state into a run folder; their ranges.

    Each map is made, written with its mask and let go before the next is made, so that the output phase
    holds one full-size map at a time beside the model (at 4096² the seven held at once were 0.9 GB)."""

    sources = {
        "height_initial": lambda: model.z0,
        "height": lambda: model.z,
        "lake_depth": model.lake_depth,
        "stream": lambda: model.stream,
        "erosion": model.erosion,
        "deposition": model.deposition,
        "vegetation": model.vegetation,
    }
    k = figure_step(model.z.shape)
    s, cs = slice(None, None, k), model.cell_size * k
    change = np.zeros(model.z[s, s].shape)  # deposition − erosion at the figures' stride
    info: dict = {"maps": {}, "masks": {}}
    for name in MAPS:
        arr = sources[name]()
        hio.write(folder.maps / f"{name}.tif", np.ascontiguousarray(arr), like=terrain)
        info["maps"][name] = {"path": f"maps/{name}.tif", "min": float(arr.min()), "max": float(arr.max())}
        # the 16-bit exports and pictures: one that fails is a warning, never the loss of the maps
        if name in MASKS:
            with folder.picture(folder.maps / f"mask_{name}.png"):
                vmax = 1.0 if name in ("stream", "vegetation") else None
                m = hio.write_mask_png16(folder.maps / f"mask_{name}.png", arr, vmax=vmax)
                info["masks"][name] = {"path": f"maps/mask_{name}.png", "vmax": m["vmax"]}
        if name in ("erosion", "deposition"):
            change += arr[s, s] if name == "deposition" else -arr[s, s]
        del arr
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
    with folder.picture(folder.figures):
        box = extent_of(terrain.transform, model.z.shape, model.cell_size)
        hillshade_figure(folder.figures / "hillshade_before.png", model.z0[s, s], cs, "Terrain before", box)
        hillshade_figure(folder.figures / "hillshade_after.png", model.z[s, s], cs, "Terrain after", box)
        legend = [("stream", LIGHT_BLUE), ("lake", DARK_BLUE), ("forest", FOREST), ("bare ground", GROUND)]
        map_figure(folder.figures / "hydrology.png", picture(model, k), cs, "Rivers, lakes and forest", legend=legend,
                   extent=box)  # fmt: skip
        change_figure(folder.figures / "erosion_deposition.png", change, cs, "Erosion and deposition", box)
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
        write_exits(sim.out.path, self.exchange)
        return {"tile_exchange": {"exits": EXITS, "flow_m3": [float(v) for v in self.exchange.flow]}}
