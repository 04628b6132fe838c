"""A sweep's plan: the base scenario, every member's settings, the threads a member runs with and
what the aggregation computes. It is saved as ``sweep.json`` beside ``base.toml`` (the resolved base
scenario) in the sweep folder; a resumed sweep reads both back, so it runs exactly the members the
first start planned, whatever the library or the command line says later.

The ``[sweep]`` table of a scenario file holds the same choices as the command line's options::

    [sweep]
    vary = { "hydrology.capacity" = "0.5:2:4", "hydrology.evaporation" = [0.002, 0.004] }
    design = "grid"          # or "lhs"
    seeds = 1
    quantiles = [0.1, 0.5, 0.9]
    exceed = ["erosion > 1", "lake_depth > 0"]
"""

from __future__ import annotations

import json
import math
import re
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

from erosim.api import overrides_list
from erosim.core.config import Section, param, validate_section
from erosim.core.errors import ConfigError, ErosimError
from erosim.scenarios import loader
from erosim.sweep import design

PLAN_FILE = "sweep.json"
BASE_FILE = "base.toml"
PLAN_VERSION = 1
# shown where a run wrote the map: P(lake), P(erosion > 1 m), P(max depth > 0.3 m), P(hazard ≥ H5)
DEFAULT_EXCEED = ("lake_depth > 0", "erosion > 1", "max_water_depth > 0.3", "hazard >= 5")


class SweepTable(Section):
    """The ``[sweep]`` table of a scenario file (the command line's options override it)."""

    vary: dict[str, Any] = param({}, doc="settings to vary: {key = 'v1,v2' | 'lo:hi:n' | 'lo:hi~n' | [values]}")
    design: Literal["grid", "lhs"] = param("grid", doc="every combination (grid) or a Latin hypercube (lhs)")
    seeds: int = param(1, ge=1, unit="1", doc="runs of every design point with seeds seed, seed+1, …")
    random_seed: int = param(0, ge=0, doc="seed of the lo:hi~n draws and of the Latin hypercube")
    quantiles: list[float] = param([0.1, 0.5, 0.9], doc="quantiles of every map over the members")
    exceed: list[str] = param([], doc="exceedance probabilities to map, 'map > value' or 'map >= value'")


@dataclass(frozen=True)
class Threshold:
    """An exceedance probability to map: P(``name`` ``op`` ``value``) over the members."""

    name: str
    op: str
    value: float

    @classmethod
    def parse(cls, text: str) -> Threshold:
        m = re.fullmatch(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*(>=|>)\s*([-+0-9.eE]+)\s*", text)
        try:
            value = float(m.group(3)) if m else math.nan
        except ValueError:
            value = math.nan
        if not m or not math.isfinite(value):
            raise ConfigError(
                f"Exceedance '{text}' is not 'map > value' or 'map >= value'; write e.g. --exceed 'erosion > 1'."
            )
        return cls(m.group(1), m.group(2), value)

    @property
    def variable(self) -> str:
        """The NetCDF variable name, e.g. ``p_erosion_gt_1`` or ``p_max_water_depth_gt_0p3``."""
        number = f"{self.value:g}".replace("-", "m").replace(".", "p").replace("+", "")
        return f"p_{self.name}_{'ge' if self.op == '>=' else 'gt'}_{number}"

    def label(self, units: str = "") -> str:
        """``P(erosion > 1 m)``; ``units`` "1" or "" shows none."""
        unit = f" {units}" if units not in ("", "1") else ""
        return f"P({self.name} {'≥' if self.op == '>=' else '>'} {self.value:g}{unit})"


@dataclass
class Plan:
    """Everything a sweep runs and aggregates (``sweep.json``)."""

    scenario: str  # the base scenario's name
    kind: str
    keys: list[str]  # the varied settings (and seed with --seeds)
    members: list[dict[str, Any]]  # each member's settings
    threads: int  # Numba threads of every member
    design: str = "grid"
    quantiles: list[float] = field(default_factory=lambda: [0.1, 0.5, 0.9])
    exceed: list[str] = field(default_factory=list)  # empty: DEFAULT_EXCEED where the maps exist
    version: int = PLAN_VERSION

    def member_name(self, i: int) -> str:
        return f"m{i:04d}"

    def overrides(self, i: int) -> list[str]:
        """Member ``i``'s settings as ``--set`` items on the base scenario."""
        return overrides_list(set=self.members[i])

    def thresholds(self) -> list[Threshold]:
        return [Threshold.parse(t) for t in (self.exceed or DEFAULT_EXCEED)]

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=1)

    @classmethod
    def read(cls, folder: Path) -> Plan:
        path = folder / PLAN_FILE
        if not path.is_file() or not (folder / BASE_FILE).is_file():
            raise ErosimError(f"'{folder}' holds no sweep (no {PLAN_FILE} and {BASE_FILE}); pass the --out of a sweep.")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            if data.get("version") != PLAN_VERSION:
                raise ValueError(f"version {data.get('version')!r}")
            return cls(**data)
        except (ValueError, TypeError) as exc:
            raise ErosimError(
                f"'{path}' is not a sweep plan this erosim reads ({exc}); start the sweep again."
            ) from None

    def same_members(self, other: Plan) -> bool:
        return (self.kind, self.keys, self.members) == (other.kind, other.keys, other.members)


def sweep_table(scenario_ref: str) -> SweepTable:
    """The scenario file's ``[sweep]`` table (defaults where it has none)."""
    data = loader.read_toml(loader.find(scenario_ref)).get("sweep", {})
    if not isinstance(data, dict):
        raise ConfigError("'sweep' in the scenario file must be a table: [sweep] vary = {...}.")
    return validate_section(SweepTable, data, "sweep")


def build(
    scenario_ref: str,
    overrides: list[str],
    preset: str | None,
    vary: list[str],
    *,
    design_name: str | None = None,
    seeds: int | None = None,
    random_seed: int | None = None,
    quantiles: list[float] | None = None,
    exceed: list[str] | None = None,
    threads: int,
) -> tuple[Plan, str]:
    """The plan and the base scenario's TOML; every member is validated here, before anything runs."""
    table = sweep_table(scenario_ref)
    specs = {key: design.parse_spec(key, spec) for key, spec in table.vary.items()}
    for item in vary:  # the command line's --vary replaces the file's for the same key
        v = design.parse_vary(item)
        specs[v.key] = v
    base = loader.load(scenario_ref, overrides, preset)
    chosen_seeds = seeds if seeds is not None else table.seeds
    settings = design.members(
        list(specs.values()),
        design=design_name or table.design,
        seeds=chosen_seeds,
        base_seed=int(getattr(base.config, "seed", 0)),
        random_seed=table.random_seed if random_seed is None else random_seed,
    )
    qs = table.quantiles if quantiles is None else quantiles
    if any(not 0.0 <= q <= 1.0 for q in qs):
        raise ConfigError(f"Quantiles {qs} must lie in [0, 1]; write e.g. --quantiles 0.1,0.5,0.9.")
    exceed = list(table.exceed if exceed is None else exceed)
    for text in exceed:
        Threshold.parse(text)
    keys = list(specs) + (["seed"] if chosen_seeds > 1 else [])
    plan = Plan(
        scenario=base.name, kind=base.kind, keys=keys, members=settings, threads=threads,
        design=design_name or table.design, quantiles=[float(q) for q in qs], exceed=exceed,
    )  # fmt: skip
    base_toml = base.to_toml()
    check_members(plan, base_toml)
    return plan, base_toml


def check_members(plan: Plan, base_toml: str) -> None:
    """Load every member's scenario as its run will; the first that does not validate is one sentence."""
    with tempfile.TemporaryDirectory() as tmp:
        base_path = Path(tmp) / BASE_FILE
        base_path.write_text(base_toml, encoding="utf-8")
        for i in range(len(plan.members)):
            try:
                loader.load(base_path, plan.overrides(i))
            except ErosimError as exc:
                what = ", ".join(f"{k}={v!r}" for k, v in plan.members[i].items())
                raise ConfigError(f"Sweep member {plan.member_name(i)} ({what}): {exc}") from None
