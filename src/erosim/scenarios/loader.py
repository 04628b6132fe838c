"""Scenario files: read TOML, apply a preset and ``--set`` overrides, validate, write back resolved.

Layout of a scenario file (``docs/architecture.md``)::

    schema_version = 1
    kind = "sph"            # selects the schema and the runner (erosim.scenarios.kinds)
    name = "dam-break"
    description = "..."
    preset = "thesis"       # optional: apply [presets.thesis] before --set overrides
    [presets.thesis] ...    # named partial overrides
    [sweep] ...             # optional: what `erosim sweep` varies (erosim.sweep.plan)
    ...                     # everything else: the kind's schema (a Section)

Order of precedence: file < preset < ``--set``. The resolved scenario (all defaults filled in, the
preset applied and dropped) is what :meth:`Scenario.to_toml` writes into every run folder; running that
file again reproduces the run.
"""

from __future__ import annotations

import copy
import difflib
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

import tomli_w

from erosim.core.config import describe_section, validate_section
from erosim.core.errors import ConfigError
from erosim.scenarios import kinds

SCHEMA_VERSION = 1
LIBRARY = Path(__file__).with_name("library")
META_KEYS = ("schema_version", "kind", "name", "description", "preset", "presets", "sweep")


@dataclass
class Scenario:
    name: str
    kind: str
    description: str
    config: Any  # the kind's validated Section
    preset: str | None = None
    presets: dict[str, dict] = field(default_factory=dict)
    source: Path | None = None

    def resolved(self) -> dict[str, Any]:
        """The complete configuration as plain data. A preset's values are already applied: it stays
        by name only, as an empty preset, so a run of this file (or its ``--resume``) reports it."""
        head = {"schema_version": SCHEMA_VERSION, "kind": self.kind, "name": self.name}
        if self.description:
            head["description"] = self.description
        if self.preset:
            head["preset"] = self.preset
        tail = {"presets": {self.preset: {}}} if self.preset else {}
        return {**head, **self.config.model_dump(mode="json", exclude_none=True), **tail}

    def to_toml(self) -> str:
        note = "# Resolved scenario written by erosim; `erosim run <this file>` repeats the run.\n"
        if self.preset:
            note += f"# Preset '{self.preset}' was applied.\n"
        return note + tomli_w.dumps(self.resolved(), multiline_strings=True)

    def describe(self) -> list[tuple[str, str, str, str]]:
        """Rows (key, value, unit, meaning) of every setting, for ``erosim describe``."""
        values = _flatten(self.config.model_dump(mode="json"))
        schema = type(self.config)
        rows = []
        for key, _default, unit, doc in describe_section(schema):
            rows.append((key, _short(values.get(key, "")), unit, doc))
        return rows


def _short(value: Any) -> str:
    text = repr(value) if not isinstance(value, str) else value
    return text if len(text) <= 40 else text[:37] + "..."


def _flatten(d: dict, prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def library_names() -> list[str]:
    """Names of the scenarios shipped with erosim."""
    return sorted(p.stem for p in LIBRARY.glob("*.toml"))


def find(name_or_path: str | os.PathLike) -> Path:
    """The file of a library scenario name or a path; a clear error (with a suggestion) otherwise."""
    p = Path(name_or_path)
    bare = isinstance(name_or_path, str) and p.suffix == "" and os.sep not in name_or_path and "/" not in name_or_path
    if bare and p.exists() and (LIBRARY / f"{name_or_path}.toml").is_file():
        raise ConfigError(
            f"'{name_or_path}' names both a library scenario and the path '{p}' in this folder; write "
            f"'.{os.sep}{name_or_path}' for the path, or run from another folder for the library's."
        )
    if p.suffix == ".toml" or p.exists():
        if p.is_dir() and (p / "scenario.toml").is_file():
            return p / "scenario.toml"
        if not p.is_file():
            raise ConfigError(f"Scenario file '{p}' does not exist; check the path or run `erosim list`.")
        return p
    lib = LIBRARY / f"{name_or_path}.toml"
    if lib.is_file():
        return lib
    names = library_names()
    near = difflib.get_close_matches(str(name_or_path), names, n=1, cutoff=0.4)
    hint = f"did you mean '{near[0]}'?" if near else "run `erosim list` to see them."
    raise ConfigError(f"No scenario named '{name_or_path}'; {hint}")


def read_toml(path: Path) -> dict[str, Any]:
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"Scenario file '{path}' is not valid TOML ({exc}); fix the syntax there.") from None
    except UnicodeDecodeError:
        raise ConfigError(f"Scenario file '{path}' is not UTF-8 text; save it as UTF-8 TOML.") from None


#: a bare word in an array, ``[east, north]``: what the shell leaves of ``["east", "north"]``
_BARE_WORD = re.compile(r"(?<=[\[,])(\s*)([A-Za-z_][\w.\-/]*)(\s*)(?=[,\]])")
_TOML_WORDS = {"true", "false", "inf", "nan"}


def parse_override(item: str) -> tuple[list[str], Any]:
    """``"a.b=c"`` → (["a", "b"], value); the value is read as TOML (numbers, booleans, arrays,
    strings), falling back to a bare string (``terrain.file=dem.tif``). An array of bare words,
    ``[east, north]`` (the shell strips the quotes of ``["east", "north"]``), is read as strings."""
    key, sep, raw = item.partition("=")
    key = key.strip()
    if not sep or not key or any(not part for part in key.split(".")):
        raise ConfigError(f"Override '{item}' is not of the form key.sub=value; write e.g. --set run.t_end=2.0.")
    raw = raw.strip()
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
        if raw.startswith("[") and raw.endswith("]"):
            quoted = _BARE_WORD.sub(
                lambda m: m.group(0) if m.group(2) in _TOML_WORDS else f'{m.group(1)}"{m.group(2)}"{m.group(3)}', raw
            )
            try:
                value = tomllib.loads(f"v = {quoted}")["v"]
            except tomllib.TOMLDecodeError:
                pass
    return key.split("."), value


def _set(data: dict, path: list[str], value: Any, item: str) -> None:
    node = data
    for part in path[:-1]:
        nxt = node.setdefault(part, {})
        if isinstance(nxt, list):
            raise ConfigError(
                f"Override '{item}': '{part}' is a list of tables; replace it whole, "
                f"e.g. --set '{part}=[{{...}}]', or edit the scenario file."
            )
        if not isinstance(nxt, dict):
            raise ConfigError(f"Override '{item}': '{part}' is a value, not a table; set it directly.")
        node = nxt
    node[path[-1]] = value


def _merge(base: dict, extra: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in extra.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


#: settings a library scenario sets for its own generated terrain; ``--set terrain.file=DEM`` drops
#: those the command line does not set again (cell size; a flood's dam line, breach, hazard polygon and
#: open edges, which are positions and edges of the generated valley)
TERRAIN_BOUND = (
    ("terrain", "cell_size"), ("reservoir", "barrier"), ("breach",), ("hazard", "inside"), ("outflow", "edges"),
    ("inflows",),
)  # fmt: skip


def _drop(body: dict, keys: tuple) -> None:
    """Remove ``keys`` (a table or a value in one) from a scenario's body, if present."""
    table = body
    for k in keys[:-1]:
        table = table.get(k)
        if not isinstance(table, dict):
            return
    table.pop(keys[-1], None)


def load(
    name_or_path: str | os.PathLike, overrides: list[str] | tuple[str, ...] = (), preset: str | None = None
) -> Scenario:
    """Read, merge and validate a scenario; every problem is one :class:`ConfigError` sentence."""
    path = find(name_or_path)
    data = read_toml(path)
    version = data.get("schema_version", SCHEMA_VERSION)
    if version != SCHEMA_VERSION:
        raise ConfigError(
            f"Scenario '{path}' has schema_version {version!r}, this erosim reads {SCHEMA_VERSION}; "
            "update the file or erosim."
        )
    # --set may choose the preset too
    sets = [parse_override(item) + (item,) for item in overrides]
    for keys, value, _item in sets:
        if keys == ["preset"]:
            preset = str(value)
    preset = preset or data.get("preset")
    presets = data.get("presets", {}) or {}
    body = {k: v for k, v in data.items() if k not in META_KEYS}
    if preset:
        if preset not in presets:
            names = ", ".join(sorted(presets)) or "none"
            raise ConfigError(f"Scenario '{path.stem}' has no preset '{preset}'; its presets: {names}.")
        body = _merge(body, presets[preset])
    set_keys = {tuple(keys) for keys, _value, _item in sets}
    if ("terrain", "file") in set_keys:
        # the scenario's cell size and positions described its generated terrain: the user's DEM keeps
        # its own cell size, and nothing is placed on it that the command line does not place
        for bound in TERRAIN_BOUND:
            if not any(k[: len(bound)] == bound for k in set_keys):
                _drop(body, bound)
        if data.get("kind") == "voxel" and not set_keys & {("voxels", "cell_size"), ("sph", "spacing")}:
            body.setdefault("voxels", {})["scale"] = "dem"  # voxels and particles at the DEM's own cell size
    for keys, value, item in sets:
        if keys[0] in META_KEYS:
            if keys != ["preset"]:
                raise ConfigError(f"Override '{item}' cannot change '{keys[0]}'; edit the scenario file instead.")
            continue
        _set(body, keys, value, item)
    kind_name = data.get("kind")
    if not kind_name:
        raise ConfigError(f'Scenario \'{path}\' has no \'kind\'; add kind = "sph", "hydrology" or "particle-stream".')
    kind = kinds.get(kind_name)
    schema = kinds.resolve(kind.schema)
    config = validate_section(schema, body)
    return Scenario(
        name=str(data.get("name", path.stem)),
        kind=kind_name,
        description=str(data.get("description", "")).strip(),
        config=config,
        preset=preset,
        presets=presets,
        source=path,
    )


def write_resolved(scenario: Scenario, out) -> Path:
    """Write ``scenario.toml`` (resolved) into a :class:`~erosim.io.runfolder.RunFolder`."""
    return out.write_text("scenario.toml", scenario.to_toml())
