"""The Python API (``erosim.run``, ``docs/api.md``): the documented scripts run, a run equals the
command line's bit for bit, overrides and errors behave as ``--set`` does, and the parameter classes'
defaults are the scenarios' (one source of truth)."""

from __future__ import annotations

import dataclasses
import inspect
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import erosim
from erosim.api import overrides_list
from erosim.cli import cli
from erosim.core.config import validate_section
from erosim.core.errors import ConfigError, ErosimError
from erosim.erosion.particle_stream_warszawski import Emitter, ParticleStream
from erosim.erosion.transport_capacity_mei2007 import TransportCapacityParams
from erosim.hydrology.params import HydrologyParams, VegetationParams
from erosim.io import checkpoint
from erosim.scenarios import kinds, loader
from erosim.sph.params import SPHParams
from erosim.terrain.hardness import Strata

DOC = Path(__file__).resolve().parents[3] / "docs" / "api.md"
BLOCKS = re.findall(r"^```python\n(.*?)^```", DOC.read_text(encoding="utf-8"), re.S | re.M)

# small, fast versions of a library scenario of each kind
SMALL = {
    "dam-break-2d": {"run.t_end": 0.02, "sph.spacing": 0.005715, "run.snapshots": 0, "run.output_interval": 0},
    "hydrology": {"terrain.size": 48, "terrain.cell_size": 80.0, "run.cycles": 4, "run.frames": 0},
    "particle-stream": {"terrain.size": 48, "emitters.main.particles": 100, "emitters.main.steps": 20},
    "rain-erosion": {"terrain.size": 12, "run.t_end": 0.2, "run.map_frames": 0},
}


# ------------------------------------------------------------------------------- package surface
def test_import_is_cheap_and_every_export_resolves():
    code = "import sys, erosim; print(sorted(m for m in ('numba', 'pydantic', 'erosim.api') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
    for name in erosim.__all__:
        assert getattr(erosim, name) is not None and name in dir(erosim)
    assert erosim.run is erosim.api.run and erosim.HydrologyParams is HydrologyParams
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        erosim.nope  # noqa: B018


def test_overrides_read_as_set_items():
    assert overrides_list({"terrain.file": "my dem.tif"}, run__t_end=0.5, water__seed=(1.0, 2.0)) == [
        'terrain.file="my dem.tif"',
        "run.t_end=0.5",
        "water.seed=[1.0, 2.0]",
    ]
    assert overrides_list(fluid=[{"lo": [0, 0], "hi": [1, 2]}], x=np.float64(0.25), flag=True) == [
        "fluid=[{lo = [0, 0], hi = [1, 2]}]",
        "x=0.25",
        "flag=true",
    ]
    for item in overrides_list(a__b=1e-7, c=float("inf"), d={"odd key": "x"}, e=Path("dem.tif")):
        loader.parse_override(item)  # valid --set syntax
    assert loader.parse_override(overrides_list(a=1e-7)[0])[1] == 1e-7
    with pytest.raises(ConfigError, match="not a TOML value"):
        overrides_list(a=object())
    sc = erosim.load_scenario("dam-break-2d", set={"run.t_end": 0.3}, sph__alpha=0.05)
    assert sc.config.run.t_end == 0.3 and sc.config.sph.alpha == 0.05


# ----------------------------------------------------------------------------------- docs/api.md
# a script that runs an ensemble starts a Dask cluster of worker processes: the multiprocess tier
@pytest.mark.parametrize(
    "code",
    [pytest.param(b, marks=[pytest.mark.multiprocess] if "run_sweep" in b else []) for b in BLOCKS],
    ids=[f"block{i + 1}" for i in range(len(BLOCKS))],
)
def test_docs_script_runs(code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, str(DOC), "exec"), {"__name__": "__main__"})


def test_docs_have_a_script_per_kind():
    text = "\n".join(BLOCKS)
    for name in ("dam-break-2d", "hydrology", "particle-stream", "rain-erosion"):
        assert f'"{name}"' in text, name


# ------------------------------------------------------------------------------- same as the CLI
def _same_files(a: Path, b: Path) -> None:
    sa, _ = checkpoint.load(a / "checkpoint")
    sb, _ = checkpoint.load(b / "checkpoint")
    assert sa.keys() == sb.keys()
    for key in sa:
        x, y = np.asarray(sa[key]), np.asarray(sb[key])
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), key
    assert (a / "scenario.toml").read_bytes() == (b / "scenario.toml").read_bytes()
    csvs = sorted(p.name for p in a.glob("*.csv"))
    assert csvs == sorted(p.name for p in b.glob("*.csv"))
    for name in csvs:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.mark.parametrize("name", sorted(SMALL))
def test_run_equals_the_command_line_bit_for_bit(name, tmp_path):
    sets = SMALL[name]
    cli_out, api_out = tmp_path / "cli", tmp_path / "api"
    args = [a for key, value in sets.items() for a in ("--set", f"{key}={value}")]
    res = CliRunner().invoke(cli, ["--quiet", "run", name, "--out", str(cli_out), *args])
    assert res.exit_code == 0, res.output
    if name in ("hydrology", "rain-erosion"):  # both spellings of an override
        result = erosim.run(name, api_out, **{k.replace(".", "__"): v for k, v in sets.items()})
    else:
        result = erosim.run(name, api_out, set=sets)
    assert result.path == api_out and result.report["status"] == "completed"
    assert result.report["scenario"] == loader.load(name).name
    _same_files(api_out, cli_out)


def test_default_folder_resume_and_overwrite(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    sets = SMALL["dam-break-2d"]
    first = erosim.run("dam-break-2d", set=sets)
    assert first.path == Path("runs/dam-break-2d") and first.report["t"] >= 0.02 * (1 - 1e-9)
    assert erosim.run("dam-break-2d", set=sets).path == Path("runs/dam-break-2d-2")  # never overwrites
    with pytest.raises(ConfigError, match="already exists and is not empty"):
        erosim.run("dam-break-2d", first.path, set=sets)
    again = erosim.run("dam-break-2d", first.path, overwrite=True, set=sets)
    _same_files(again.path, Path("runs/dam-break-2d-2"))
    more = erosim.run(None, first.path, resume=True, run__t_end=0.04)
    assert more.report["resumed"] and more.report["t"] >= 0.04 * (1 - 1e-9)


def test_errors_are_one_sentence_erosim_errors(tmp_path):
    with pytest.raises(ConfigError, match="did you mean 'dam-break-2d'"):
        erosim.run("dam-brake-2d", tmp_path / "a")
    with pytest.raises(ConfigError, match="Unknown setting 'run.t_ned'"):
        erosim.run("dam-break-2d", tmp_path / "b", run__t_ned=1.0)
    with pytest.raises(ErosimError, match="resume=True"):
        erosim.run("dam-break-2d", tmp_path / "c", resume=True)
    with pytest.raises(ErosimError, match="resume=True"):
        erosim.run(None, resume=True)
    out = tmp_path / "d"
    with pytest.raises(ErosimError):  # found while building: no folder is left behind
        erosim.run("hydrology", out, terrain__file=str(tmp_path / "missing.tif"))
    assert not out.exists()
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


# ---------------------------------------------------------------- one source of truth for defaults
def _minimal(kind: str, data: dict):
    return validate_section(kinds.resolve(kinds.get(kind).schema), data)


_BOX3 = {"domain": {"lo": [0, 0, 0], "hi": [1, 1, 1]}, "fluid": [{"lo": [0, 0, 0], "hi": [0.5, 0.5, 0.5]}]}
_BOX2 = {"domain": {"lo": [0, 0], "hi": [1, 1]}, "fluid": [{"lo": [0, 0], "hi": [0.5, 0.5]}]}
_PROFILE = {"profile": {"length": 1.0, "cell_size": 0.1}}

# (kind, scenario with no key of the section set, section, the class with its defaults); the only
# differences a kind sets are written here: sph.dim from the geometry (h_factor 3.0 in 2-D follows),
# sph-terrain's walls = "reflect" (the ground and the map edges are its walls) and, on a terrain,
# metre-sized particles (spacing 1 m; a 2-D flume keeps SPH's 1 cm)
DEFAULTS = [
    ("sph", _BOX3, "sph", SPHParams(dim=3)),
    ("sph", _BOX2, "sph", SPHParams(dim=2)),
    ("hydrology", {}, "hydrology", HydrologyParams()),
    ("hydrology", {}, "vegetation", VegetationParams()),
    ("sph-terrain", {}, "sph", SPHParams(dim=3, walls="reflect", spacing=1.0)),
    ("sph-terrain", _PROFILE, "sph", SPHParams(dim=2, walls="reflect")),
    ("sph-terrain", {}, "erosion", TransportCapacityParams()),
    ("particle-stream", {}, "emitters.main", Emitter()),
    ("particle-stream", {"emitters": {"main": {"x": 0.1}}}, "emitters.main", Emitter(x=0.1)),
]


@pytest.mark.parametrize(
    "kind, data, section, reference", DEFAULTS, ids=[f"{k}-{s}-{i}" for i, (k, _d, s, _r) in enumerate(DEFAULTS)]
)
def test_parameter_class_defaults_are_the_schema_defaults(kind, data, section, reference):
    node = _minimal(kind, data)
    for part in section.split("."):
        node = node[part] if isinstance(node, dict) else getattr(node, part)
    drift = {
        f: (getattr(node, f), getattr(reference, f))
        for f in type(reference).model_fields
        if getattr(node, f) != getattr(reference, f)
    }
    assert not drift, f"{kind} [{section}] (schema, class): {drift}"


def test_model_arguments_default_to_the_schema():
    stream = _minimal("particle-stream", {})
    assert inspect.signature(ParticleStream).parameters["pool"].default == stream.stream.pool
    strata = {f.name: f.default for f in dataclasses.fields(Strata) if f.default is not dataclasses.MISSING}
    assert strata == {k: getattr(stream.hardness, k) for k in strata}


def test_library_hydrology_runs_the_class_defaults():
    """`erosim run hydrology` and HydrologyModel(terrain) in Python use the same parameters (the
    library scenario once ran 250 droplets per cycle where HydrologyParams() ran 1000)."""
    cfg = loader.load("hydrology").config
    assert cfg.hydrology == HydrologyParams() and cfg.vegetation == VegetationParams()
