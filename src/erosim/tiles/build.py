"""A tiled hydrology build (``erosim run hydrology --set terrain.file=big.tif --tile N --overlap K``):
a DEM too large for one run eroded tile by tile on Dask, then mosaicked.

The build folder::

    <out>/scenario.toml          the resolved scenario, [tiles] included (``--resume`` reads it)
    <out>/tiles.json             the plan: the DEM's grid, every tile's core and window
    <out>/tiles/rR_cC/           round 1: input.tif (the tile's window = core + halo of the DEM, CRS and
                                 transform kept), inflow.npy (empty in round 1), exchange.json, and an
                                 ordinary hydrology run folder around them, exits.npy included
    <out>/tiles/roundK/          rounds K ≥ 2: start_height.tif and start_stream.tif (round K−1's
                                 mosaics) and rR_cC/ as above, cut from them, inflow.npy = the droplets
                                 that left the neighbours into this tile's core in round K−1
    <out>/maps/NAME.tif          one Cloud-Optimized GeoTIFF per map on the DEM's grid, CRS, transform
    <out>/report.json            plan, per round the exchange and every tile's status and wall time,
                                 seam figures

Only the DEM's header is read whole; tiles are cut with windowed reads and the mosaics are written
core by core (:mod:`erosim.tiles.rasters`), so the build's own memory is bounded by a tile; each Dask
worker holds one tile's run. Tiles are sweep members (:mod:`erosim.sweep.member`): a finished tile is
kept and an interrupted one resumed from its checkpoint when the build is run again with
``erosim run --resume <out>``, round by round.

Each round runs ``run.cycles / rounds`` cycles in every tile. A tile's halo is not its own: rain falls
on its core, a droplet that steps into the halo leaves the tile there and is recorded with its water,
sediment and velocity, and the next round injects it into the neighbour whose core holds that cell, in
the same cycle (:mod:`erosim.hydrology.tile_exchange`, :mod:`erosim.tiles.exchange`); a lake at the
border fills to the halo's height before it spills into it; creep moves soil across the border. The
halo's heights are the neighbours' (the last round's mosaic), so gradients at a border are the map's.
The mosaics take every tile's core (a tile never changes its halo). Each tile's run in each round has its
own seed (:func:`member_seed`), so that no two draw the same droplets.
"""

from __future__ import annotations

import json
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from erosim.core.atomic import write_json, write_text
from erosim.core.errors import ConfigError, ErosimError, Interrupted
from erosim.io.heightmaps import geotiff_header
from erosim.io.runfolder import default_out
from erosim.scenarios import loader
from erosim.sweep import dask_executor
from erosim.sweep.member import FINISHED, MemberTask, read_report, record, run_member
from erosim.sweep.runner import MemberProgress, plan_threads
from erosim.tiles import exchange as xch
from erosim.tiles import rasters, seams
from erosim.tiles.plan import Tile, cycles_per_round, plan
from erosim.tiles.rasters import read_window

PLAN_FILE = "tiles.json"
OUTPUTS = ("tiles", "maps", "report.json", PLAN_FILE, "scenario.toml")


def tiled(scenario) -> bool:
    """Whether a loaded scenario asks for a tiled build."""
    return scenario.kind == "hydrology" and scenario.config.tiles.size > 0


def _load(scenario_ref, overrides, preset, resume):
    if resume:
        if scenario_ref is not None:
            raise ErosimError("Give either a scenario or --resume DIR, not both; --resume reads DIR/scenario.toml.")
        folder = Path(resume)
        if not (folder / PLAN_FILE).is_file():
            raise ErosimError(f"Cannot resume '{folder}' as a tiled build: it has no {PLAN_FILE}.")
        return loader.load(folder / "scenario.toml", list(overrides)), folder
    if scenario_ref is None:
        raise ErosimError("Name a scenario (see `erosim list`) or a TOML file, or pass --resume DIR.")
    return loader.load(scenario_ref, list(overrides), preset), None


def _open_folder(scenario, out, overwrite: bool) -> tuple[Path, bool]:
    folder = Path(out) if out else default_out(scenario.name)
    if folder.exists() and not folder.is_dir():
        raise ConfigError(f"'{folder}' is a file, not a folder; name a folder for the build (--out DIR).")
    created = not folder.exists()
    if folder.exists() and any(folder.iterdir()):
        if not overwrite:
            raise ConfigError(
                f"Output folder '{folder}' already exists and is not empty; choose another --out, add --overwrite, "
                f"or continue a tiled build with `erosim run --resume {folder}`."
            )
        for name in OUTPUTS:
            target = folder / name
            if target.is_dir():
                shutil.rmtree(target)
            elif target.exists():
                target.unlink()
    folder.mkdir(parents=True, exist_ok=True)
    return folder, created


def member_seed(seed: int, round_: int, tile: int) -> int:
    """The seed of tile ``tile``'s run in round ``round_`` (from 1) of a build with ``seed``: its own, so that
    every tile and round draws its own droplets. A tile's run numbers its droplets from 0, and the spawn points
    and the trees' draws are keyed by (seed, droplet or cycle number): with the build's seed in every run, each
    round rained on the same points as the first and every tile on the same points of its window (one tile
    in 16 rounds of 40 cycles ended 59 m from the untiled run at the 99th percentile, where a second untiled
    seed is 36 m from it; docs/tiles.md)."""
    return int(np.random.SeedSequence([int(seed), int(round_), int(tile)]).generate_state(1)[0])


def _round_dir(folder: Path, k: int) -> Path:
    return folder / "tiles" if k == 1 else folder / "tiles" / f"round{k}"


def run_tiled(
    scenario_ref: str | None,
    overrides: list[str] = (),  # type: ignore[assignment]
    preset: str | None = None,
    out: str | None = None,
    resume: str | None = None,
    overwrite: bool = False,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
    client: Any = None,
    member_function=run_member,
    timeout_s: float = 10.0,
) -> tuple[Path, dict[str, Any]]:
    """Run a tiled build (see the module docstring); returns (folder, summary). ``client``: a
    ``distributed.Client`` to use instead of connecting (tests share one)."""
    t0 = time.perf_counter()
    scenario, folder = _load(scenario_ref, overrides, preset, resume)
    if not tiled(scenario):
        raise ConfigError("This scenario does not ask for tiles; set tiles.size (or --tile N) for a tiled build.")
    cfg = scenario.config
    tiles_cfg = cfg.tiles.model_copy(update={"rounds": cfg.tiles.rounds_for(cfg.run.cycles)})
    cfg = scenario.config = cfg.model_copy(update={"tiles": tiles_cfg})  # the rounds resolved, and so saved
    dem = Path(cfg.terrain.file).resolve()
    header = geotiff_header(dem, cfg.terrain.cell_size)  # bad input: one sentence, nothing written yet
    shape = tuple(header["shape"])
    tiles = plan(shape, cfg.tiles.size, cfg.tiles.overlap)
    shares = cycles_per_round(cfg.run.cycles, cfg.tiles.rounds)
    n_workers, threads = plan_threads(scheduler, workers, None, len(tiles))
    if client is not None:
        n_workers = len(client.scheduler_info().get("workers", {})) or n_workers
    doc = {
        "dem": str(dem), "shape": list(shape), "cell_size_m": header["cell_size"], "crs": header["crs"],
        "transform": header["transform"], "size": cfg.tiles.size, "overlap": cfg.tiles.overlap,
        "rounds": cfg.tiles.rounds, "cycles_per_round": shares, "tiles": [t.as_dict() for t in tiles],
    }  # fmt: skip
    created = False
    if folder is None:
        folder, created = _open_folder(scenario, out, overwrite)
        terrain = cfg.terrain.model_copy(update={"file": str(dem)})
        scenario.config = cfg.model_copy(update={"terrain": terrain})
        write_text(folder / "scenario.toml", scenario.to_toml())
        write_json(folder / PLAN_FILE, doc)
    elif json.loads((folder / PLAN_FILE).read_text(encoding="utf-8"))["tiles"] != json.loads(json.dumps(doc["tiles"])):
        raise ConfigError(f"'{folder}' holds another tiled build (another plan); start it afresh with --overwrite.")
    if progress:
        print(
            f"tiled build: {shape[0]} × {shape[1]} cells in {len(tiles)} tiles of ≤ {cfg.tiles.size} cells + "
            f"{cfg.tiles.overlap} halo, {cfg.tiles.rounds} round(s), "
            f"{'scheduler ' + scheduler if scheduler else f'{n_workers} local workers'} → {folder}",
            file=sys.stderr, flush=True,
        )  # fmt: skip
    base = str((folder / "scenario.toml").resolve())
    bar = MemberProgress("tiles", len(tiles) * len(shares), 0, max(1, n_workers), progress)
    rounds: list[dict[str, Any]] = []
    try:
        context = dask_executor.connect(scheduler, n_workers, timeout_s) if client is None else _given(client)
        with context as cl:
            for k, cycles in enumerate(shares, start=1):
                rdir = _round_dir(folder, k)
                source, stream_src, prev = dem, None, None
                if k > 1:
                    prev = _round_dir(folder, k - 1)
                    source, stream_src = rdir / "start_height.tif", rdir / "start_stream.tif"
                    for name, path in (("height", source), ("stream", stream_src)):
                        if not path.is_file():
                            f = _map(prev, name)
                            rasters.write_by_cores(tiles, rasters.grid_profile(dem), path,
                                                   lambda t, f=f: _core(f, t), cog=False)  # fmt: skip
                tasks, records = [], {}
                exchange = {"droplets": 0, "water_m3": 0.0, "sediment_m3": 0.0}
                bar.set_note(f"round {k}/{len(shares)}")
                for i, t in enumerate(tiles):
                    tdir = (rdir / t.name).resolve()
                    member = tdir / xch.MEMBER
                    if not member.is_file():  # its inputs: the window's heights (and stream), the inflow
                        rasters.cut(source, t, tdir / "input.tif", header["cell_size"])
                        inflow = np.zeros((0, len(xch.COLUMNS)))
                        if k > 1:
                            rasters.cut(stream_src, t, tdir / "stream_in.tif", header["cell_size"])
                            inflow = xch.route(tiles, i, lambda s, prev=prev: _exits(prev, s), cycles)
                        xch.write_member(tdir, t, inflow, "stream_in.tif" if k > 1 else None)
                    inflow = np.load(tdir / xch.INFLOW, mmap_mode="r")
                    exchange["droplets"] += int(inflow.shape[0])
                    exchange["water_m3"] += float(inflow[:, 5].sum())
                    exchange["sediment_m3"] += float(inflow[:, 6].sum())
                    report = read_report(tdir)
                    if report is not None and report.get("status") in FINISHED and (tdir / xch.EXITS).is_file():
                        records[i] = record(i, t.name, report, "kept")
                        bar.member_done(records[i])
                        continue
                    sets = (f"terrain.file={json.dumps(str(tdir / 'input.tif'))}",
                            f"terrain.cell_size={header['cell_size']!r}", "tiles.size=0", f"run.cycles={cycles}",
                            "run.frames=0", f"tiles.member={json.dumps(str(member))}",
                            f"seed={member_seed(cfg.seed, k, i)}")  # fmt: skip
                    tasks.append(MemberTask(i, t.name, str(tdir), base, sets, threads))
                if tasks:
                    done = dask_executor.run_tasks(cl, tasks, on_done=bar.member_done, member_function=member_function)
                    for rec in done:
                        records[rec["index"]] = rec
                ordered = [records[i] for i in range(len(tiles))]
                rounds.append({"round": k, "cycles": cycles, "entered": exchange, "tiles": ordered})
                unfinished = [r for r in ordered if r["status"] not in ("completed",)]
                if unfinished:
                    break
    except KeyboardInterrupt:
        raise Interrupted(
            f"Tiled build interrupted; finished tiles are kept and running ones wrote checkpoints — continue with "
            f"`erosim run --resume {folder}`."
        ) from None
    except BaseException:
        if created and not any((folder / "tiles").glob("**/report.json")):
            shutil.rmtree(folder, ignore_errors=True)  # stopped before any tile ran: nothing to keep
        raise
    finally:
        bar.close()
    summary: dict[str, Any] = {
        "tiles": len(tiles), "rounds": len(shares), "workers": n_workers or "remote", "threads_per_tile": threads,
    }  # fmt: skip
    report: dict[str, Any] = {"plan": doc, "rounds": rounds}
    if unfinished:
        interrupted = all(r["status"] == "interrupted" for r in unfinished)
        report.update(status="interrupted" if interrupted else "failed", wall_time_s=time.perf_counter() - t0)
        write_json(folder / "report.json", report)
        names = ", ".join(f"{r['member']} ({r['status']}{': ' + r['message'] if r['message'] else ''})"
                          for r in unfinished[:4])  # fmt: skip
        cls = Interrupted if interrupted else ErosimError
        raise cls(f"Tiles not finished: {names}; the others are kept — continue with `erosim run --resume {folder}`.")
    last = _round_dir(folder, len(shares))
    outputs = _mosaic(folder, dem, tiles, cfg.tiles.overlap, last)
    figures = seams.figures(folder / "maps" / "height.tif", folder / "maps" / "stream.tif", tiles, shape)
    report.update(status="completed", outputs=outputs, seams=figures, wall_time_s=round(time.perf_counter() - t0, 2))
    write_json(folder / "report.json", report)
    ran = sum(r["action"] != "kept" for rd in rounds for r in rd["tiles"])
    summary.update(
        ran_now=ran, seam_jump_max_m=figures["border_jump_max_m"], inside_p999_m=figures["inside_p999_m"],
        river_continuity=figures["river_continuity"], wall_s=report["wall_time_s"],
    )  # fmt: skip
    return folder, summary


class _given:
    """A context manager that yields an existing client and leaves it open."""

    def __init__(self, client):
        self.client = client

    def __enter__(self):
        return self.client

    def __exit__(self, *exc):
        return False


def _map(rdir: Path, name: str):
    return lambda t: rdir / t.name / "maps" / f"{name}.tif"


def _core(path_of, t: Tile) -> np.ndarray:
    """Tile ``t``'s core of the map ``path_of(t)`` (a tile's halo is outside its run: only its core is its)."""
    wr0, _, wc0, _ = t.window
    r0, r1, c0, c1 = t.core
    return read_window(path_of(t), (r0 - wr0, r1 - wr0, c0 - wc0, c1 - wc0))


def _exits(rdir: Path, t: Tile) -> np.ndarray:
    return np.load(rdir / t.name / xch.EXITS)


def _mosaic(folder: Path, dem: Path, tiles: list[Tile], overlap: int, last: Path) -> list[str]:
    """One COG per map of the tiles' runs in ``<out>/maps/``: each tile's core from the last round, the
    initial height from round 1, erosion and deposition from those two (max(z₀ − z, 0), max(z − z₀, 0))."""
    grid = rasters.grid_profile(dem)
    names = sorted(p.stem for p in (last / tiles[0].name / "maps").glob("*.tif"))
    maps = folder / "maps"
    derived = {"erosion", "deposition"} & set(names)
    for name in names:
        if name in derived:
            continue
        rdir = _round_dir(folder, 1) if name == "height_initial" else last
        path_of = _map(rdir, name)
        rasters.write_by_cores(tiles, grid, maps / f"{name}.tif", lambda t, f=path_of: _core(f, t))
    for name in sorted(derived):
        sign = 1.0 if name == "erosion" else -1.0

        def change(t, sign=sign):
            z0 = rasters.read_window(maps / "height_initial.tif", t.core)
            z = rasters.read_window(maps / "height.tif", t.core)
            return np.maximum(sign * (z0 - z), 0.0)

        rasters.write_by_cores(tiles, grid, maps / f"{name}.tif", change)
    return [f"maps/{n}.tif" for n in names]
