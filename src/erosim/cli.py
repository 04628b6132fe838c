"""Command line: ``erosim run | sweep | demo | list | describe | validate | bench | convert | view | export | info``.

Thin by design: parse, load the scenario, call a runner / benchmark / validation, print. Errors meant
for the user (:class:`~erosim.core.errors.ErosimError`) are printed as one sentence with a non-zero
exit; ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import click

from erosim import __version__
from erosim.core.errors import ErosimError, Interrupted, os_error_message


class _Context:
    debug = False
    quiet = False


STATE = _Context()


def _fail(exc: BaseException) -> None:
    if STATE.debug:
        raise exc
    code = getattr(exc, "exit_code", 2) if isinstance(exc, ErosimError) else 1
    click.echo(f"erosim: error: {exc}", err=True)
    sys.exit(code)


def _guard(fn, *args, **kwargs):
    try:
        return fn(*args, **kwargs)
    except ErosimError as exc:
        _fail(exc)
    except OSError as exc:  # permission denied, read-only or full disk, a file where a folder should be
        _fail(ErosimError(os_error_message(exc)))
    except KeyboardInterrupt:
        _fail(Interrupted("Interrupted before any result was kept; run the command again."))


def _print_result(result: dict, as_json: bool) -> None:
    if as_json:
        from erosim.core.atomic import to_json

        click.echo(to_json(result, ensure_ascii=False))
        return
    from rich.console import Console

    Console().print(_summary_table(result))


def _cell(value):
    """One value of a summary, for a table cell: numbers to 6 significant digits, a table of key/value
    pairs as a nested table, a list of tables as a table with a column per key, other lists joined."""
    from rich.markup import escape
    from rich.table import Table

    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, float):
        return f"{value:,.6g}"
    if isinstance(value, int):
        return f"{value}"
    if isinstance(value, dict):
        return _summary_table(value, bold=False) if value else "(none)"
    if isinstance(value, (list, tuple)):
        if value and all(isinstance(v, dict) for v in value):
            columns = list(dict.fromkeys(k for v in value for k in v))
            table = Table(*columns, box=None, header_style="italic", pad_edge=False)
            for v in value:
                table.add_row(*(_cell(v.get(c, "")) for c in columns))
            return table
        if any(isinstance(v, (dict, list, tuple)) for v in value):
            return escape(json.dumps(value, default=str, ensure_ascii=False))
        return ", ".join(str(_cell(v)) for v in value) if value else "(none)"
    return escape(str(value))


def _summary_table(result: dict, bold: bool = True):
    """A summary as a two-column table (key, value); nested tables for nested values, never raw JSON."""
    from rich.markup import escape
    from rich.table import Table

    table = Table(show_header=False, box=None, pad_edge=False)
    for key, value in result.items():
        name = escape(str(key))
        table.add_row(f"[bold]{name}[/bold]" if bold else name, _cell(value))
    return table


DEVICE_CASES = ("martin-moyce", "hydrostatic")  # validations that run on --device cuda
OVERRIDE_CASES = ("martin-moyce", "spheric2")  # validations that take --set


def _device_option(help_text: str):
    return click.option(
        "--device", type=click.Choice(["cpu", "cuda"]), default=None, help=help_text + " (default: cpu)."
    )


def _require_device(device: str | None) -> None:
    """One sentence and a non-zero exit when ``device`` cannot run here (before anything is written)."""
    if device is not None:
        from erosim.core.devices import require

        _guard(require, device)


def _check_device_kind(scenario, resume, preset) -> None:
    """--device is a setting of kind = "sph", "flood" and "hydrology" scenarios only: one sentence for the others."""
    from erosim.scenarios import loader

    try:
        sc = loader.load(Path(resume) / "scenario.toml", []) if resume else loader.load(scenario, [], preset)
    except ErosimError:
        return  # the run itself reports what is wrong with the scenario
    if sc.kind not in ("sph", "flood", "hydrology"):
        _fail(
            ErosimError(
                f'--device applies to kind = "sph", "flood" and "hydrology" scenarios, not \'{sc.name}\' '
                f"(kind '{sc.kind}'); leave it out."
            )
        )


def _set_threads(threads: int | None) -> None:
    if threads is None:
        return
    if threads < 1:
        _fail(ErosimError(f"--threads {threads} is not valid; give a whole number of at least 1."))
    os.environ["NUMBA_NUM_THREADS"] = str(threads)
    import numba

    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="erosim")
@click.option("--threads", type=int, default=None, help="CPU threads for Numba kernels (default: all cores).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option("--debug", is_flag=True, help="Show tracebacks instead of one-line errors.")
def cli(threads: int | None, quiet: bool, debug: bool) -> None:
    """erosim: particle-based terrain erosion and flood simulation.

    \b
    Quick start:
      erosim demo                          rivers, lakes and vegetation on a generated terrain
      erosim list                          the scenario library
      erosim run dam-break-2d              run a scenario (results in runs/<name>/)
      erosim run flood-jacksboro           a dam-break flood on a real DEM, with hazard maps
      erosim sweep hydrology --seeds 8     an ensemble on Dask: probability maps (sweep.nc)
      erosim validate martin-moyce         compare with the Martin & Moyce (1952) experiment
      erosim view runs/demo                see a run in the browser (offline; --html FILE for one file)
      erosim export runs/demo --to out/    the terrain as GLB/OBJ mesh, EXR/RAW32 heights, a splat map
    """
    STATE.debug = debug
    STATE.quiet = quiet
    _set_threads(threads)


# --------------------------------------------------------------------------------------------- run


@cli.command()
@click.argument("scenario", required=False)
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="KEY=VALUE",
    help="Override a setting, e.g. --set run.t_end=1.5 (repeatable).",
)
@click.option("--preset", default=None, help="Apply a named preset of the scenario (see `erosim describe`).")
@click.option(
    "--out", type=click.Path(file_okay=False), default=None, help="Run folder (default runs/<name>, never overwriting)."
)
@click.option(
    "--resume", type=click.Path(file_okay=False), default=None, help="Continue an interrupted run from its folder."
)
@click.option("--overwrite", is_flag=True, help="Allow writing into an existing, non-empty --out folder.")
@_device_option(
    'Where the SPH steps (kind = "sph", "flood") or the droplet batches (kind = "hydrology") run: cpu or cuda; '
    "sets run.device"
)
@click.option(
    "--tile", type=int, default=None, metavar="N",
    help="Hydrology on a large GeoTIFF (terrain.file): erode it in tiles of at most N cells a side (tiles.size).",
)  # fmt: skip
@click.option(
    "--overlap", type=int, default=None, metavar="K", help="Tiled build: halo cells per tile (tiles.overlap)."
)
@click.option(
    "--scheduler", default=None, metavar="ADDRESS",
    help="Tiled build: a dask.distributed scheduler (default: local workers).",
)  # fmt: skip
@click.option("--workers", type=int, default=None, help="Tiled build: local worker processes (default: one per core).")
def run(scenario, overrides, preset, out, resume, overwrite, device, tile, overlap, scheduler, workers):
    """Run SCENARIO (a library name or a TOML file) and write a run folder.

    \b
    A tiled build erodes a DEM too large for one run tile by tile on Dask (docs/tiles.md):
      erosim run hydrology --set terrain.file=big.tif --tile 1024 --overlap 64 [--workers 2]
    writes one Cloud-Optimized GeoTIFF per map in OUT/maps/ on the DEM's grid, CRS and transform,
    and the seam figures in OUT/report.json; --resume OUT continues it, keeping finished tiles.
    """
    from erosim.api import execute

    if (tile is not None or overlap is not None) and scenario is not None:
        from erosim.scenarios import loader

        kind = _guard(loader.load, scenario, list(overrides), preset).kind
        if kind != "hydrology":
            _fail(ErosimError(f'--tile and --overlap apply to kind = "hydrology" scenarios, not kind \'{kind}\'; '
                              "leave them out."))  # fmt: skip
    if tile is not None:
        overrides = (*overrides, f"tiles.size={tile}")
    if overlap is not None:
        overrides = (*overrides, f"tiles.overlap={overlap}")
    if _is_tiled(scenario, overrides, preset, resume):
        if device is not None:
            _fail(ErosimError("--device does not apply to a tiled hydrology build; leave it out."))
        from erosim.tiles.build import run_tiled

        folder, summary = _guard(
            run_tiled, scenario, list(overrides) if resume is None else [], preset, out, resume, overwrite,
            scheduler=scheduler, workers=workers, progress=not STATE.quiet,
        )  # fmt: skip
        _print_result(summary, as_json=False)
        click.echo(f"Results in {folder}/: {_contents(folder)}")
        return
    if scheduler is not None or workers is not None:
        _fail(ErosimError("--scheduler and --workers apply to tiled builds (--tile N) only; leave them out."))

    if resume is not None and scenario is None and not overrides and device is None:
        from erosim.validation import session

        if session.find(resume) is not None:  # a validation's folder: continued as the validation, with its verdict
            click.get_current_context().invoke(validate, resume=resume)
            return
    _require_device(device)
    if device is not None:
        _check_device_kind(scenario, resume, preset)
        overrides = (*overrides, f"run.device={device}")
    run_folder, summary = _guard(
        execute, scenario, list(overrides), preset, out, resume, overwrite, progress=not STATE.quiet
    )
    from erosim.scenarios.runner import COMPLETE

    if summary and COMPLETE in summary:  # --resume of a completed run: one line, nothing written
        click.echo(summary[COMPLETE])
        return
    if summary:
        _print_result(summary, as_json=False)
    click.echo(f"Results in {run_folder.path}/: {_contents(run_folder.path)}")


@cli.command()
@click.argument("scenario", required=False)
@click.option(
    "--vary", multiple=True, metavar="KEY=SPEC",
    help="A setting to vary: v1,v2,… | lo:hi:n (evenly spaced) | lo:hi~n (random, seeded); repeatable.",
)  # fmt: skip
@click.option("--seeds", type=int, default=None, help="Run every design point with K seeds (seed, seed+1, …).")
@click.option(
    "--design", type=click.Choice(["grid", "lhs"]), default=None, help="Every combination, or a Latin hypercube."
)
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help="Override a setting of every member.")
@click.option("--preset", default=None, help="Apply a named preset of the scenario to every member.")
@click.option(
    "--exceed", multiple=True, metavar="'MAP > VALUE'",
    help="An exceedance probability to map, e.g. 'erosion > 1' (repeatable; default: lake, erosion, depth).",
)  # fmt: skip
@click.option("--quantiles", default=None, metavar="Q1,Q2,…", help="Quantiles of every map (default 0.1,0.5,0.9).")
@click.option("--random-seed", type=int, default=None, help="Seed of lo:hi~n draws and of the Latin hypercube.")
@click.option(
    "--scheduler", default=None, metavar="ADDRESS", help="A dask.distributed scheduler (default: local workers)."
)
@click.option("--workers", type=int, default=None, help="Local worker processes (default: one per core).")
@click.option("--threads-per-member", "threads", type=int, default=None, help="Numba threads of each member.")
@click.option("--out", type=click.Path(file_okay=False), default=None, help="Sweep folder (default runs/<name>-sweep).")
@click.option("--resume", type=click.Path(file_okay=False), default=None, help="Continue a sweep from its folder.")
@click.option("--overwrite", is_flag=True, help="Replace the sweep in --out.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as one JSON object.")
def sweep(scenario, vary, seeds, design, overrides, preset, exceed, quantiles, random_seed, scheduler, workers, threads,
          out, resume, overwrite, as_json):  # fmt: skip
    """Run SCENARIO many times on Dask and map how likely each outcome is (sweep.nc, sweep.csv).

    \b
    erosim sweep hydrology --set terrain.size=128 --vary hydrology.capacity=0.5:2:4 --seeds 3
    erosim sweep rain-erosion --vary erosion.capacity=0.25,0.5,1 --scheduler tcp://10.0.0.5:8786
    """
    from erosim.sweep.runner import run_sweep

    qs = None
    if quantiles is not None:
        try:
            qs = [float(q) for q in quantiles.split(",")]
        except ValueError:
            _fail(ErosimError(f"--quantiles {quantiles} is not a list of numbers; write e.g. --quantiles 0.1,0.5,0.9."))
    summary = _guard(
        run_sweep, scenario, list(overrides), preset, list(vary), design=design, seeds=seeds, random_seed=random_seed,
        quantiles=qs, exceed=list(exceed) or None, scheduler=scheduler, workers=workers, threads=threads, out=out,
        resume=resume, overwrite=overwrite, progress=not STATE.quiet and not as_json,
    )  # fmt: skip
    _print_result(summary, as_json=as_json)


def _is_tiled(scenario, overrides, preset, resume) -> bool:
    """Whether this run is a tiled build: its scenario (or the resumed folder) sets tiles.size."""
    if resume is not None:
        return (Path(resume) / "tiles.json").is_file()
    if scenario is None:
        return False
    from erosim.scenarios import loader
    from erosim.tiles.build import tiled

    sc = _guard(loader.load, scenario, list(overrides), preset)
    return tiled(sc)


def _contents(folder: Path) -> str:
    """What a run folder holds, report first: ``report.json, figures/, maps/, gauges.csv``."""
    entries = sorted(folder.iterdir(), key=lambda p: (p.name != "report.json", p.is_file(), p.name))
    return ", ".join(p.name + ("/" if p.is_dir() else "") for p in entries if not p.name.startswith("."))


# -------------------------------------------------------------------------------------------- demo
@cli.command()
@click.option(
    "--out",
    type=click.Path(file_okay=False),
    default="runs/demo",
    show_default=True,
    help="Where to write (replaced on each demo run).",
)
def demo(out):
    """The main job: rivers, lakes and vegetation carved into a generated 512² mountain terrain."""
    from erosim.scenarios.kinds import resolve

    fn = _guard(resolve, "erosim.scenarios.runner:demo")
    summary = _guard(fn, Path(out), not STATE.quiet)
    if summary:
        _print_result(summary, as_json=False)


# ------------------------------------------------------------------------------- list / describe
def _first_sentence(text: str) -> str:
    """The description's first sentence (its summary line), for one-line listings."""
    line = " ".join(text.split())
    end = line.find(". ")
    return line if end < 0 else line[: end + 1]


@cli.command(name="list")
def list_():
    """List the scenario library."""
    import shutil

    from erosim.scenarios import loader

    # one line per scenario at any width: names, kinds and presets whole, the description cut to fit
    rows = [("scenario", "kind", "presets", "what it is (erosim describe NAME)")]
    for name in loader.library_names():
        data = loader.read_toml(loader.LIBRARY / f"{name}.toml")
        presets = ", ".join(sorted(data.get("presets", {}) or {}))
        rows.append((name, str(data.get("kind", "?")), presets, _first_sentence(str(data.get("description", "")))))
    widths = [max(len(r[k]) for r in rows) for k in range(3)]
    room = shutil.get_terminal_size((120, 24)).columns - sum(widths) - 6
    for r in rows:
        text = r[3] if len(r[3]) <= room else r[3][: max(room - 1, 0)] + "…"
        line = "  ".join(c.ljust(w) for c, w in zip(r[:3], widths, strict=True))
        click.echo((line + "  " + text if room >= 10 else line).rstrip())


@cli.command()
@click.argument("scenario")
@click.option(
    "--set", "overrides", multiple=True, metavar="KEY=VALUE", help="Show the scenario with overrides applied."
)
@click.option("--preset", default=None, help="Show the scenario with a preset applied.")
def describe(scenario, overrides, preset):
    """Explain SCENARIO: what it models, its presets and every setting with its unit."""
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    from erosim.scenarios import loader

    sc = _guard(loader.load, scenario, list(overrides), preset)
    console = Console()
    if not console.is_terminal:  # piped or redirected: rich's 80 columns would fold every row
        console = Console(width=120)
    console.print(f"[bold]{sc.name}[/bold]  (kind: {sc.kind}{', preset: ' + sc.preset if sc.preset else ''})")
    if sc.description:
        console.print(escape(sc.description))
    if sc.presets:
        console.print("Presets: " + ", ".join(sorted(sc.presets)) + "  (use --preset NAME)")
    table = Table(box=None, header_style="bold", pad_edge=False)
    table.add_column("setting", no_wrap=True)  # names are never cut
    table.add_column("value", max_width=28, overflow="fold")
    table.add_column("unit", no_wrap=True)
    table.add_column("meaning", ratio=1)
    for row in sc.describe():
        table.add_row(*(escape(cell) for cell in row))
    console.print(table)


# --------------------------------------------------------------------------------------- validate
VALIDATION_CASES = {
    "martin-moyce": "erosim.validation.martin_moyce:run",
    "hydrostatic": "erosim.validation.hydrostatic:run",
    "basin-at-rest": "erosim.validation.basin_at_rest:run",
    "spheric2": "erosim.validation.spheric2:run",
    "swe-dam-break": "erosim.validation.swe_dam_break:run",
    "thacker": "erosim.validation.thacker:run",
    "lake-at-rest": "erosim.validation.lake_at_rest:run",
    "flood-solvers": "erosim.validation.flood_solvers:run",
    "splash-wetness": "erosim.validation.splash_wetness:run",
    "voxel-at-rest": "erosim.validation.voxel_at_rest:run",
    "overtopping": "erosim.validation.overtopping:run",
}


@cli.command()
@click.argument("case", type=click.Choice(sorted(VALIDATION_CASES)), required=False)
@click.option(
    "--resolution",
    type=click.Choice(["coarse", "default", "fine"]),
    default="default",
    show_default=True,
    help="martin-moyce: coarse (a/10) and default (a/25) check the front against the experiment, criterion (a); "
    "fine runs a/50, a/10 and a/25 and checks (a) at a/25, (b) the error against the converged MPS solution "
    "falling to 3 % at a/50 and (c) the column height at a/50. spheric2: Δx 0.05, 0.025, 0.02 m; its targets "
    "are set for default and fine.",
)
@click.option(
    "--out", type=click.Path(file_okay=False), default=None, help="Run folder (default runs/validate-<case>)."
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option(
    "--ground",
    type=click.Choice(["box", "heightfield"]),
    default=None,
    help="martin-moyce only: the tank floor as boundary particles (box, default) or a flat heightmap.",
)
@click.option(
    "--gate-speed",
    type=click.FloatRange(min=0.0),
    default=None,
    help="martin-moyce only: lift a gate at the column's face at this speed (m/s, box ground on the cpu); "
    "default 0: the column is released at once.",
)
@click.option(
    "--start",
    type=click.Choice(["hydrostatic-consistent", "hydrostatic"]),
    default=None,
    help="voxel-at-rest only: the fluid's start, hydrostatic and consistent with the walls (default) or the "
    "plain hydrostatic start.",
)
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="KEY=VALUE",
    help="martin-moyce and spheric2 only: override a setting of the case's scenario (a study of a method, e.g. "
    "sph.wall_pressure=extrapolated); validation.json records them.",
)
@_device_option("martin-moyce and hydrostatic: where the SPH steps run")
@click.option(
    "--resume", type=click.Path(file_okay=False), default=None,
    help="Continue an interrupted validation from its folder and give its verdict (the case and its options are "
    "the folder's).",
)  # fmt: skip
def validate(case, resolution, out, as_json, ground, gate_speed, start, overrides, device, resume):
    """Run a validation CASE against published experimental or analytic data.

    Exit status 0 when the case's criteria hold, 1 otherwise, the failed criteria then named in one line
    (martin-moyce and spheric2: docs/sph.md)."""
    from erosim.scenarios.kinds import resolve
    from erosim.validation import session

    if resume is not None:  # the case and its options from the folder (validation_run.json)
        if case is not None or out is not None:
            _fail(ErosimError("Give either a CASE or --resume DIR, not both; --resume reads the case from DIR."))
        out, rec = _validation_record(Path(resume))
        case, resolution, opts = rec["case"], rec.get("resolution", "default"), dict(rec.get("options") or {})
        ground, gate_speed, start, device = (opts.get(k) for k in ("ground", "gate_speed", "start", "device"))
        overrides = tuple(opts.get("overrides") or ())
    elif case is None:
        _fail(ErosimError(f"Name a validation case ({', '.join(sorted(VALIDATION_CASES))}) or pass --resume DIR."))
    if ground is not None and case != "martin-moyce":
        _fail(ErosimError(f"--ground applies to martin-moyce only, not '{case}'; leave it out."))
    if gate_speed is not None and case != "martin-moyce":
        _fail(ErosimError(f"--gate-speed applies to martin-moyce only, not '{case}'; leave it out."))
    if start is not None and case != "voxel-at-rest":
        _fail(ErosimError(f"--start applies to voxel-at-rest only, not '{case}'; leave it out."))
    if overrides and case not in OVERRIDE_CASES:
        _fail(ErosimError(f"--set applies to {' and '.join(OVERRIDE_CASES)} only, not '{case}'; leave it out."))
    if device is not None and case not in DEVICE_CASES:
        _fail(ErosimError(f"--device applies to {' and '.join(DEVICE_CASES)} only, not '{case}'; leave it out."))
    _require_device(device)
    fn = _guard(resolve, VALIDATION_CASES[case])
    extra = {"ground": ground} if ground else {}
    if device is not None:
        extra["device"] = device
    if gate_speed is not None:
        extra["gate_speed"] = gate_speed
    if start is not None:
        extra["start"] = start
    if overrides:
        extra["overrides"] = list(overrides)
    with session.validating(case, resolution, extra, resume=Path(out) if resume is not None else None):
        try:
            result = _guard(fn, resolution, Path(out) if out else None, not (STATE.quiet or as_json), **extra)
        except SystemExit as stop:  # interrupted with the case's folder kept: how to continue it
            root = session.root()
            if stop.code == Interrupted.exit_code and root is not None and (root / session.MARK).is_file():
                click.echo(f"erosim: continue the validation, with its verdict: `erosim validate --resume {root}`.",
                           err=True)  # fmt: skip
            raise
    criteria = result.get("criteria")
    if as_json or not criteria:
        _print_result(result, as_json)
    else:  # the criteria one line each under the table, not as a JSON dump in it
        _print_result({k: v for k, v in result.items() if k != "criteria"}, False)
        for c in criteria:
            click.echo(("  pass  " if c["passed"] else "  n/a   " if c["passed"] is None else "  FAIL  ") + c["line"])
    if not result.get("passed", False):
        if "verdict" in result:  # the failed criteria, named in one line (on stderr: --json keeps stdout one object)
            click.echo(f"erosim: validation {result['verdict']}", err=True)
        sys.exit(1)


def _validation_record(folder: Path) -> tuple[Path, dict]:
    """(root, record) of the validation in ``folder`` (or one of its two parents), else one sentence."""
    from erosim.validation import session

    found = session.find(folder)
    if found is None or found[1].get("case") not in VALIDATION_CASES:
        _fail(ErosimError(f"'{folder}' is not the folder of a validation (no readable {session.MARK}); pass the "
                          "folder that `erosim validate` named when it was interrupted."))  # fmt: skip
    return found


# ------------------------------------------------------------------------------------------ bench
@cli.group()
def bench():
    """Throughput benchmarks (see `make bench`)."""


@bench.command(name="sph")
@click.option(
    "--particles", type=click.IntRange(min=100), default=100_000, show_default=True, help="Fluid particles (about)."
)
@click.option(
    "--steps", type=click.IntRange(min=1), default=None, help="Timed steps (default: enough for a few seconds)."
)
@click.option("--dim", type=click.Choice(["2", "3"]), default="3", show_default=True)
@_device_option("Where the SPH steps run: cpu or cuda")
@click.option("--json", "as_json", is_flag=True)
def bench_sph(particles, steps, dim, device, as_json):
    """SPH solver on a 3-D dam break: particle-steps/s and neighbour-pair interactions/s."""
    from erosim.scenarios.kinds import resolve

    _require_device(device)
    fn = _guard(resolve, "erosim.bench.sph:run")
    _print_result(_guard(fn, particles, steps, int(dim), device=device or "cpu"), as_json)


@bench.command(name="sph-terrain")
@click.option(
    "--particles", type=click.IntRange(min=1000), default=100_000, show_default=True, help="Fluid particles (about)."
)
@click.option("--steps", type=click.IntRange(min=1), default=None, help="Timed steps (default: a few seconds' worth).")
@click.option(
    "--every", type=click.IntRange(min=1), default=20, show_default=True, help="SPH steps between erosion updates."
)
@click.option("--json", "as_json", is_flag=True)
def bench_sph_terrain(particles, steps, every, as_json):
    """SPH on an eroding heightmap (heightfield ground, coupling) against the same fluid in a box."""
    from erosim.scenarios.kinds import resolve

    fn = _guard(resolve, "erosim.bench.sph_terrain:run")
    _print_result(_guard(fn, particles, steps, every=every), as_json)


@bench.command(name="voxel")
@click.option(
    "--particles", type=click.IntRange(min=1000), default=50_000, show_default=True, help="Fluid particles (about)."
)
@click.option("--steps", type=click.IntRange(min=1), default=None, help="Timed steps (default: a few seconds' worth).")
@click.option(
    "--every", type=click.IntRange(min=1), default=50, show_default=True, help="SPH steps between erosion updates."
)
@click.option(
    "--sediment",
    type=click.Choice(["carried_off", "suspended"]),
    default="carried_off",
    show_default=True,
    help="What the erosion does with the ground it removes (erosion.sediment).",
)
@click.option(
    "--law",
    type=click.Choice(["kristof2009", "excess_shear"]),
    default="kristof2009",
    show_default=True,
    help="The erosion law (erosion.law).",
)
@click.option("--json", "as_json", is_flag=True)
def bench_voxel(particles, steps, every, sediment, law, as_json):
    """SPH on an eroding voxel terrain (wall weights, erosion) against the same fluid in a box."""
    from erosim.scenarios.kinds import resolve

    fn = _guard(resolve, "erosim.bench.voxel:run")
    _print_result(_guard(fn, particles, steps, every=every, sediment=sediment, law=law), as_json)


@bench.command(name="flood")
@click.option("--t-end", type=click.FloatRange(min=1), default=4000.0, show_default=True, help="Simulated seconds.")
@click.option("--spacing", type=click.FloatRange(min=5), default=20.0, show_default=True, help="Particle spacing (m).")
@click.option(
    "--split/--no-split", default=None, help="Particle splitting where the flow thins (default: the scenario's, on)."
)
@_device_option("Where the shallow-water SPH steps run: cpu or cuda")
@click.option("--json", "as_json", is_flag=True)
def bench_flood(t_end, spacing, split, device, as_json):
    """A dam break down a 10 km valley (shallow-water SPH, hazard maxima every step)."""
    from erosim.scenarios.kinds import resolve

    _require_device(device)
    fn = _guard(resolve, "erosim.bench.flood:run")
    _print_result(_guard(fn, t_end, spacing, split=split, device=device or "cpu"), as_json)


@bench.command(name="hydrology")
@click.option("--size", type=click.IntRange(min=16), default=256, show_default=True, help="Map size in cells (square).")
@click.option(
    "--droplets", type=click.IntRange(min=1), default=None, help="Droplets to time (default: enough for a few seconds)."
)
@click.option(
    "--batch",
    type=click.IntRange(min=0, max=65536),
    default=None,
    help="Droplets per parallel batch (hydrology.batch); 0 = the seed's one-after-another order "
    "(default: the preset's: 0 for simplehydrology-2020, an eighth of a cycle for library).",
)
@click.option(
    "--preset",
    type=click.Choice(["simplehydrology-2020", "library"]),
    default="simplehydrology-2020",
    show_default=True,
    help="The seed's constants on the seed's 10.24 km world, or the library scenario as "
    "`erosim run hydrology` runs it.",
)
@_device_option("Where the droplet batches descend: cpu or cuda")
@click.option("--json", "as_json", is_flag=True)
def bench_hydrology(size, droplets, batch, preset, device, as_json):
    """Hydrology (lakes on): droplets/s, device, threads and the share spent filling lakes."""
    from erosim.scenarios.kinds import resolve

    _require_device(device)
    fn = _guard(resolve, "erosim.bench.hydrology:run")
    _print_result(_guard(fn, size, droplets, batch=batch, preset=preset, device=device or "cpu"), as_json)


@bench.command(name="sweep")
@click.option("--members", type=click.IntRange(min=1), default=8, show_default=True, help="Members of the sweep.")
@click.option(
    "--workers", type=click.IntRange(min=1), default=2, show_default=True, help="Workers of the parallel run."
)
@click.option(
    "--cycles", type=click.IntRange(min=1), default=200, show_default=True, help="Hydrology cycles a member runs."
)
@click.option("--json", "as_json", is_flag=True)
def bench_sweep(members, workers, cycles, as_json):
    """A sweep on one worker, then on several: speed-up and overhead per member."""
    from erosim.scenarios.kinds import resolve

    fn = _guard(resolve, "erosim.bench.sweep:run")
    _print_result(_guard(fn, members=members, workers=workers, cycles=cycles), as_json)


@bench.command(name="stream")
@click.option(
    "--particles",
    type=click.IntRange(min=1),
    multiple=True,
    help="Particle counts (repeatable; default 1e4, 1e5, 1e6).",
)
@click.option(
    "--impacts-per-particle",
    type=click.IntRange(min=1),
    default=32,
    show_default=True,
    help="Updates (move, collide, deform) a particle makes before it returns to the pool; 1 = the seed's reading.",
)
@_device_option("Where the stream's sweeps run: cpu or cuda")
@click.option("--json", "as_json", is_flag=True)
def bench_stream(particles, impacts_per_particle, device, as_json):
    """Particle-stream erosion: particles and particle updates per second at several counts (shows O(n))."""
    from erosim.scenarios.kinds import resolve

    _require_device(device)
    fn = _guard(resolve, "erosim.bench.stream:run")
    counts = list(particles) or [10_000, 100_000, 1_000_000]
    _print_result(_guard(fn, counts, impacts_per_particle, device=device or "cpu"), as_json)


# ---------------------------------------------------------------------------------------- convert
@cli.command()
@click.argument("src", type=click.Path())
@click.argument("dst", type=click.Path())
@click.option("--cell-size", type=float, default=None, help="Cell size in metres (for formats that do not store it).")
@click.option(
    "--raw-shape", type=(int, int), default=None, metavar="ROWS COLS", help="Shape of a RAW16 input that is not square."
)
@click.option(
    "--height-range",
    type=(float, float),
    default=None,
    metavar="MIN MAX",
    help="Heights (m) that 0 and 65535 stand for in a 16-bit input without a stored range.",
)
def convert(src, dst, cell_size, raw_shape, height_range):
    """Convert a heightmap between GeoTIFF, 16-bit PNG, RAW16, ESRI ASCII grid and NPY."""
    from erosim.scenarios.kinds import resolve

    fn = _guard(resolve, "erosim.io.heightmaps:convert")
    info = _guard(fn, src, dst, cell_size=cell_size, raw_shape=raw_shape, height_range=height_range)
    if info:
        _print_result(info, as_json=False)
    click.echo(f"Wrote {dst}")


# ----------------------------------------------------------------------------------- view, export
@cli.command()
@click.argument("run", type=click.Path())
@click.option("--to", "to", type=click.Path(), required=True, help="Folder for the exported files.")
@click.option(
    "--format",
    "formats",
    multiple=True,
    metavar="gltf|glb|obj|exr|raw32|png16|raw16|splat",
    help="Format (repeatable; default all but gltf): mesh glb/gltf/obj, heightmap exr/raw32/png16/raw16, splat map.",
)
@click.option("--tile", type=int, default=None, metavar="N", help="Tiles of N cells a side (default: one piece).")
@click.option("--overlap", type=int, default=1, show_default=True, metavar="K", help="Cells neighbouring tiles share.")
@click.option(
    "--texture", metavar="relief|hillshade|none", default="relief", show_default=True,
    help="Mesh texture: shaded relief (with water where the run has it), grey hillshade, or none.",
)  # fmt: skip
def export(run, to, formats, tile, overlap, texture):
    """Export RUN's terrain: glTF/GLB and OBJ meshes, EXR/RAW32/PNG16/RAW16 heightmaps, an RGBA splat map."""
    from erosim.view.export import DEFAULT_FORMATS, export_run

    fmts = tuple(formats) or DEFAULT_FORMATS
    summary = _guard(export_run, run, to, fmts, tile=tile, overlap=overlap, texture=texture)
    n = sum(len(t["files"]) for t in summary.get("tiles", [])) or len(summary.get("files", []))
    click.echo(f"Wrote {n} files and export.json to {to}")


@cli.command()
@click.argument("run", type=click.Path())
@click.option("--port", type=int, default=0, metavar="P", help="Port on 127.0.0.1 (default: a free one).")
@click.option("--no-browser", is_flag=True, help="Do not open a browser; print the address only.")
@click.option("--html", "html_out", type=click.Path(), default=None, help="Write one self-contained HTML file instead.")
@click.option(
    "--max-side", type=click.IntRange(min=16), default=1024, show_default=True,
    help="Cells a side the view reads at most; larger maps are read at a stride (the 'full' detail).",
)  # fmt: skip
def view(run, port, no_browser, html_out, max_side):
    """Show RUN in the browser: the terrain in 3-D, its layers, particles over time, values under the cursor."""
    from erosim.view import app

    if html_out:
        info = _guard(app.write_html, run, html_out, max_side=max_side)
        click.echo(f"Wrote {info['path']} ({info['bytes'] / 1e6:.1f} MB; opens offline in any browser)")
        return
    _guard(app.serve, run, port, browser=not no_browser, echo=click.echo, max_side=max_side)


# ------------------------------------------------------------------------------------------- info
@cli.command()
def info():
    """Versions, threads, usable devices and where things are."""
    import numba
    import numpy

    from erosim.bench import threading_layer
    from erosim.core.devices import available
    from erosim.scenarios import loader

    _print_result(
        {
            "erosim": __version__,
            "python": sys.version.split()[0],
            "numpy": numpy.__version__,
            "numba": numba.__version__,
            "threads": numba.get_num_threads(),
            "threading_layer": threading_layer(),
            "cpu_cores": os.cpu_count(),
            **{f"device {name}": what for name, what in available().items()},
            "scenarios": ", ".join(loader.library_names()),
        },
        as_json=False,
    )


def main() -> None:
    from erosim import command_threading_layer

    command_threading_layer()
    cli(prog_name="erosim")


if __name__ == "__main__":
    main()
