"""Parameter sections: frozen pydantic models with units and valid ranges.

Every model's parameters (an SPH solver, an erosion law, a hydrology cycle) are declared once as a
:class:`Section`; the same class validates the scenario file's table and is what the physics code
receives. Use :func:`param` to declare a field with a unit and range, e.g.::

    class Droplet(Section):
        friction: float = param(0.1, ge=0, le=1, unit="1", doc="velocity damping per step")

A bad value raises :class:`~erosim.core.errors.ConfigError` naming the key, the value and the range;
an unknown key raises one that suggests the nearest valid key.
"""

from __future__ import annotations

import difflib
import typing
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from erosim.core.errors import ConfigError


class Section(BaseModel):
    """Base of every parameter table: unknown keys are errors, values are immutable."""

    # allow_inf_nan=False: a float setting of inf or nan (`--set run.t_end=inf`) is refused in one sentence
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)


def param(default: Any = ..., *, unit: str = "", doc: str = "", **limits: Any) -> Any:
    """A field with a unit and a description; ``limits`` are pydantic's ``ge``, ``gt``, ``le``, ``lt``."""
    return Field(default, description=doc, json_schema_extra={"unit": unit}, **limits)


def _fields_at(model: type[BaseModel], loc: tuple) -> list[str]:
    """Valid key names of the sub-table at ``loc`` (best effort, for suggestions)."""
    cls: Any = model
    for part in _skip_table_keys(model, loc):
        fields = getattr(cls, "model_fields", None)
        if not fields or part not in fields:
            break
        ann = _table_value(fields[part].annotation)
        cls = ann if isinstance(ann, type) and issubclass(ann, BaseModel) else None
        if cls is None:
            return []
    return list(getattr(cls, "model_fields", {}) or [])


def _table_value(ann: Any) -> Any:
    """``dict[str, Sub]`` (a table of named sub-tables, e.g. ``[emitters.NAME]``) → ``Sub``."""
    return typing.get_args(ann)[1] if typing.get_origin(ann) is dict else ann


def _skip_table_keys(model: type[BaseModel], loc: tuple) -> tuple:
    """``loc`` minus names in ``dict[str, Sub]`` tables (``emitters.main.x`` → ``emitters.x``)."""
    out, cls = [], model
    it = iter(loc)
    for part in it:
        out.append(part)
        fields = getattr(cls, "model_fields", None)
        if not fields or part not in fields:
            out.extend(it)
            break
        ann = fields[part].annotation
        if typing.get_origin(ann) is dict:
            next(it, None)
        cls = _table_value(ann)
    return tuple(out)


def _limits_text(model: type[BaseModel], loc: tuple) -> str:
    cls: Any = model
    info = None
    for part in _skip_table_keys(model, loc):
        fields = getattr(cls, "model_fields", None)
        if not fields or part not in fields:
            return ""
        info = fields[part]
        cls = _table_value(info.annotation)
    if info is None:
        return ""
    words = {"ge": ">=", "gt": ">", "le": "<=", "lt": "<"}
    found = []
    for meta in info.metadata:
        for attr, sym in words.items():
            val = getattr(meta, attr, None)
            if val is not None:
                found.append(f"{sym} {val}")
    unit = (info.json_schema_extra or {}).get("unit", "") if isinstance(info.json_schema_extra, dict) else ""
    if not found:
        return ""
    return " (valid: " + " and ".join(found) + (f" {unit}" if unit and unit != "1" else "") + ")"


def validate_section(model: type[BaseModel], data: dict, where: str = "") -> Any:
    """Build ``model`` from ``data`` or raise a one-sentence :class:`ConfigError`.

    ``where`` prefixes key paths (e.g. ``"sph"``) so the message names the key as the user wrote it.
    """
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = tuple(str(p) for p in err["loc"])
        key = ".".join(((where,) if where else ()) + loc)
        if err["type"] == "extra_forbidden":
            valid = _fields_at(model, loc[:-1])
            near = difflib.get_close_matches(loc[-1], valid, n=1, cutoff=0.5)
            hint = f"did you mean '{near[0]}'?" if near else "valid keys here: " + ", ".join(valid)
            raise ConfigError(f"Unknown setting '{key}': {hint}") from None
        if err["type"] == "missing":
            raise ConfigError(f"Missing setting '{key}': add it to the scenario or pass --set {key}=VALUE.") from None
        value = err.get("input")
        limits = _limits_text(model, loc)
        msg = err["msg"].rstrip(".")
        how = f"--set {key}=VALUE"
        if isinstance(value, str) and value.lstrip().startswith("["):  # an array the shell took apart
            how = f"""--set '{key}=["a", "b"]' (quoted whole, so that the shell keeps the quotes)"""
        raise ConfigError(
            f"Setting '{key}' = {value!r} is not valid: {msg}{limits}; change it in the scenario or with {how}."
        ) from None


def describe_section(model: type[BaseModel], prefix: str = "") -> list[tuple[str, str, str, str]]:
    """Rows (key, default, unit, description) of a section and its sub-sections, for ``erosim describe``."""
    rows = []
    for name, info in model.model_fields.items():
        key = f"{prefix}{name}"
        ann = info.annotation
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            rows.extend(describe_section(ann, key + "."))
            continue
        sub = _table_value(ann)
        if sub is not ann and isinstance(sub, type) and issubclass(sub, BaseModel):
            rows.extend(describe_section(sub, key + ".<name>."))  # [key.NAME] tables
            continue
        extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
        default = "" if info.is_required() else repr(info.get_default(call_default_factory=True))
        rows.append((key, default, str(extra.get("unit", "")), info.description or ""))
    return rows
