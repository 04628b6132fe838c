"""Runner of ``kind = "hydrology"`` scenarios and ``erosim demo``.

A run: build the terrain (``[terrain]``), optional rain / hardness maps, then
:class:`erosim.hydrology.model.HydrologyModel` cycles driven by :func:`erosim.simulation.loop.drive`
(progress bar, wall-clock checkpoints between cycles, Ctrl-C → checkpoint). At the end it writes:

* ``maps/``: height_initial.tif, height.tif, lake_depth.tif, stream.tif, erosion.tif,
  deposition.tif, vegetation.tif (GeoTIFF float32, the input's CRS kept); height.png (PNG16) and
  height.r16 (RAW16 little-endian) with their height range in report.json; 16-bit PNG masks
  mask_stream.png, mask_lake_depth.png, mask_erosion.png, mask_deposition.png,
  mask_vegetation.png (value = q·vmax/65535, vmax in report.json);
* ``figures/``: hillshade_before.png, hillshade_after.png, hydrology.png (HY-9: light blue streams,
  dark blue lakes, green forest), evolution.gif;
* ``report.json``: water_budget, sediment_budget, statistics, output list and ranges.
"""

from __future__ import annotations

import contextlib
import shutil
import signal
import time
from pathlib import Path

import numpy as np

from erosim.core.errors import ConfigError
from erosim.io import checkpoint as ckpt
from erosim.io.runfolder import RunFolder
from erosim.simulation.loop import Every, drive

MAPS = ("height_initial", "height", "lake_depth", "stream", "erosion", "deposition", "vegetation")


@contextlib.contextmanager
def _cycle_is_atomic():
    """Hold Ctrl-C until the current cycle is complete, so a checkpoint never sees half a cycle."""
    pressed = []

    def handler(signum, frame):
        pressed.append(signum)

    try:
        old = signal.signal(signal.SIGINT, handler)
    except ValueError:  # not the main thread: nothing to defer
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
    if pressed:
        raise KeyboardInterrupt


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
    """The terrain and a fresh :class:`HydrologyModel` for a validated ``HydrologyScenario``."""
    from erosim.hydrology.model import HydrologyModel
    from erosim.scenarios.schema_common import build_terrain

    terrain = build_terrain(cfg.terrain, cfg.seed)
    rain, erod = _inputs(cfg, terrain.shape)
    model = HydrologyModel(terrain, cfg.hydrology, cfg.vegetation, cfg.seed, rain=rain, erodibility=erod, timing=timing)
    return terrain, model


def _picture(model):
    from erosim.viz.maps import hydrology_map

    return hydrology_map(model.z, model.cell_size, model.stream, model.lake_depth(), vegetation=model.vegetation())


def write_outputs(model, terrain, out: RunFolder) -> dict:
    """Maps, engine exports and pictures of the model's current state; returns their ranges."""
    from erosim.io import heightmaps as hio
    from erosim.viz.maps import hillshade, save_png

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
        hio.write(out.maps / f"{name}.tif", np.ascontiguousarray(arr), like=terrain)
        info["maps"][name] = {"path": f"maps/{name}.tif", "min": float(arr.min()), "max": float(arr.max())}
    png = hio.write(out.maps / "height.png", model.z, like=terrain)
    raw = hio.write(out.maps / "height.r16", model.z, like=terrain)
    info["heightmap_16bit"] = {
        "png": "maps/height.png",
        "raw16": "maps/height.r16",
        "raw16_shape": list(model.z.shape),
        "height_range": png["height_range"],
        "raw16_height_range": raw["height_range"],
        "rescale": "z = lo + q·(hi − lo)/65535",
    }
    for name in ("stream", "lake_depth", "erosion", "deposition", "vegetation"):
        vmax = 1.0 if name in ("stream", "vegetation") else None
        m = hio.write_mask_png16(out.maps / f"mask_{name}.png", maps[name], vmax=vmax)
        info["masks"][name] = {"path": f"maps/mask_{name}.png", "vmax": m["vmax"]}
    save_png(out.figures / "hillshade_before.png", hillshade(model.z0, model.cell_size))
    save_png(out.figures / "hillshade_after.png", hillshade(model.z, model.cell_size))
    save_png(out.figures / "hydrology.png", _picture(model))
    return info


def _frame(model, size: int = 256):
    pic = _picture(model)
    step = max(1, pic.shape[0] // size, pic.shape[1] // size)
    return pic[::step, ::step]


def run(scenario, out: RunFolder, *, resume: bool = False, progress: bool = True) -> dict:
    """Run a hydrology scenario into ``out`` (see module docstring); returns a short summary."""
    from erosim.scenarios.loader import write_resolved

    cfg = scenario.config
    terrain, model = build_model(cfg)
    for note in terrain.notes:
        out.warn(note)
    if resume:
        state, _meta = ckpt.load(out.path / "checkpoint")
        model.load_state(state)
    write_resolved(scenario, out)
    ratio = model.ell / model.cell_size
    if ratio > 8:
        out.warn(
            f"hydrology.length_scale ({model.ell:g} m) spans {ratio:.0f} cells of "
            f"{model.cell_size:g} m: "
            "droplet footprints are large and the run is slow; set terrain.cell_size to the DEM's "
            "real cell size or lower hydrology.length_scale."
        )
    frames: list = []
    schedules = []
    if cfg.run.frames > 0:
        interval = max(1, cfg.run.cycles // cfg.run.frames)
        ev = Every(interval, lambda _p: frames.append(_frame(model)))
        ev.next_at = model.cycles if not resume else (model.cycles // interval + 1) * interval
        schedules.append(ev)

    def advance() -> float:
        with _cycle_is_atomic():
            model.cycle()
        return float(model.cycles)

    def save_ckpt() -> None:
        ckpt.save(out.checkpoint, model.state(), {"kind": "hydrology", "cycles": model.cycles})

    t0 = time.perf_counter()
    drive(
        advance,
        start=float(model.cycles),
        total=float(cfg.run.cycles),
        schedules=schedules,
        checkpoint=save_ckpt,
        checkpoint_wall_s=cfg.run.checkpoint_interval,
        label=scenario.name,
        unit="cycles",
        progress=progress,
        steps_done=model.cycles,
    )
    wall = time.perf_counter() - t0
    info = write_outputs(model, terrain, out)
    if frames:
        frames.append(_frame(model))
        from erosim.viz.animate import save_animation

        save_animation(out.figures / "evolution.gif", frames, fps=8)
        info["animation"] = "figures/evolution.gif"
    wb, sb = model.water_budget(), model.sediment_budget()
    stats = model.stats()
    stats["droplets_per_s"] = (model.per_cycle * cfg.run.cycles) / wall if wall > 0 and not resume else None
    report = {
        "kind": "hydrology",
        "scenario": scenario.name,
        "preset": scenario.preset,
        "terrain": {
            "shape": list(terrain.shape),
            "cell_size_m": terrain.cell_size,
            "crs": terrain.crs,
            "z_min": float(model.z0.min()),
            "z_max": float(model.z0.max()),
        },
        "water_budget": wb,
        "sediment_budget": sb,
        "statistics": stats,
        "outputs": info,
        "simulation_wall_s": round(wall, 3),
    }
    out.write_report(report, seed=cfg.seed)
    return {
        "droplets": stats["droplets"],
        "cycles": stats["cycles"],
        "lake_fraction": round(stats["lake_fraction"], 4),
        "tree_fraction": round(stats["tree_fraction"], 4),
        "water_closure_rel": wb["closure_rel"],
        "sediment_closure_rel": sb["closure_rel"],
        "wall_s": round(wall, 2),
    }


def _clear_demo_folder(out: Path) -> None:
    """Empty ``out`` for a new demo — only if it is empty or a folder erosim wrote."""
    if not out.exists():
        return
    if not out.is_dir():
        raise ConfigError(f"Demo output '{out}' is a file; pass another --out folder.")
    entries = list(out.iterdir())
    if entries and not ((out / "report.json").exists() or (out / "scenario.toml").exists()):
        raise ConfigError(f"Demo output '{out}' holds files erosim did not write; pass an empty or new --out folder.")
    shutil.rmtree(out)


def demo(out: Path, progress: bool = True) -> dict:
    """``erosim demo``: the library ``hydrology`` scenario (512² mountains) into ``out``."""
    from erosim.scenarios import loader

    out = Path(out)
    _clear_demo_folder(out)
    scenario = loader.load("hydrology")
    folder = RunFolder(out, overwrite=True)
    t0 = time.perf_counter()
    summary = run(scenario, folder, progress=progress)
    summary["total_s"] = round(time.perf_counter() - t0, 1)
    summary["open_first"] = str(out / "figures" / "hydrology.png")
    summary["then"] = (
        f"{out}/figures/hillshade_before.png vs hillshade_after.png, "
        f"{out}/figures/evolution.gif; engine exports in {out}/maps/ "
        "(height.png/.r16 + mask_*.png); budgets in report.json"
    )
    return summary
