"""The members of a sweep: ``--vary`` specifications combined as a full grid or a Latin hypercube.

A specification (``--vary KEY=SPEC`` or ``vary = {KEY = SPEC}`` in a scenario's ``[sweep]`` table) is

* ``v1,v2,…`` (or a TOML list): the listed values, read as TOML (numbers, strings, booleans);
* ``lo:hi:n``: ``n`` evenly spaced values from ``lo`` to ``hi``, both included (whole numbers when
  ``lo`` and ``hi`` are whole and the spacing is);
* ``lo:hi~n``: ``n`` values drawn uniformly from [lo, hi) with the sweep's random seed (each key
  its own stream, so adding a key does not change another's draws).

Designs: ``grid`` runs every combination (first key slowest); ``lhs`` is a Latin hypercube (McKay,
Beckman & Conover 1979, via :class:`scipy.stats.qmc.LatinHypercube`): ``n`` members for keys that all
give the same ``n``; each listed or evenly spaced value is used exactly once, and a ``~`` range is cut
into ``n`` equal strata with one member drawn in each. ``seeds = K`` runs every design point with the
scenario's seed, seed + 1, …, seed + K − 1.
"""

from __future__ import annotations

import itertools
import zlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from erosim.core.errors import ConfigError

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

DESIGNS = ("grid", "lhs")


@dataclass(frozen=True)
class Vary:
    """One varied setting: listed values, or a range ``low``–``high`` with ``n`` points (``random``: drawn)."""

    key: str
    n: int
    values: tuple | None = None
    low: float | None = None
    high: float | None = None
    random: bool = False


def _toml_value(text: str) -> Any:
    text = text.strip()
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text  # a bare word: a string (e.g. a file name)


def _number(text: str, key: str, spec: str) -> int | float:
    value = _toml_value(text)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"--vary {key}={spec}: '{text}' is not a number; write a range as lo:hi:n, e.g. 0.5:2:4.")
    return value


def parse_spec(key: str, spec: Any) -> Vary:
    """The :class:`Vary` of ``key`` from its specification (a string, or a list from a TOML file)."""
    if not key or any(not part for part in key.split(".")):
        raise ConfigError(
            f"--vary '{key}={spec}' names no setting; write --vary key.sub=SPEC, e.g. hydrology.dt=0.5,1."
        )
    if isinstance(spec, (list, tuple)):
        if not spec:
            raise ConfigError(f"--vary {key}: the list of values is empty; give at least one value.")
        return Vary(key, len(spec), values=tuple(spec))
    if not isinstance(spec, str):
        return Vary(key, 1, values=(spec,))
    text = spec.strip()
    if "~" in text or text.count(":") == 2:
        head, sep, count = text.rpartition("~") if "~" in text else text.rpartition(":")
        bounds = head.split(":")
        if len(bounds) != 2:
            raise ConfigError(f"--vary {key}={spec}: a range is lo:hi:n (evenly spaced) or lo:hi~n (random).")
        low, high = (_number(b, key, spec) for b in bounds)
        n = _number(count, key, spec)
        if not isinstance(n, int) or n < 1:
            raise ConfigError(f"--vary {key}={spec}: n = {count.strip()} is not a whole number of at least 1.")
        if high < low:
            raise ConfigError(f"--vary {key}={spec}: the range runs backwards; write the lower bound first.")
        return Vary(key, n, low=low, high=high, random=sep == "~")
    values = tuple(_toml_value(v) for v in text.split(","))
    if any(v == "" for v in values):
        raise ConfigError(f"--vary {key}={spec}: an empty value between commas; list values as v1,v2,v3.")
    return Vary(key, len(values), values=values)


def parse_vary(item: str) -> Vary:
    """``"key=SPEC"`` (the command line's ``--vary``) → :class:`Vary`."""
    key, sep, spec = item.partition("=")
    if not sep:
        raise ConfigError(f"--vary '{item}' is not KEY=SPEC; write e.g. --vary hydrology.dt=0.5,1,2.")
    return parse_spec(key.strip(), spec)


def _levels(v: Vary, random_seed: int) -> list:
    """The values of ``v`` in a grid (listed, evenly spaced or drawn)."""
    if v.values is not None:
        return list(v.values)
    if v.random:
        rng = np.random.default_rng([random_seed, zlib.crc32(v.key.encode())])
        return rng.uniform(v.low, v.high, v.n).tolist()
    if v.n == 1:
        return [v.low]
    points = np.linspace(v.low, v.high, v.n)
    step = (v.high - v.low) / (v.n - 1)
    if isinstance(v.low, int) and isinstance(v.high, int) and float(step).is_integer():
        return [int(round(p)) for p in points]
    return points.tolist()


def _latin_hypercube(varies: list[Vary], random_seed: int) -> list[dict[str, Any]]:
    from scipy.stats import qmc

    sizes = {v.key: v.n for v in varies}
    n = varies[0].n
    if len(set(sizes.values())) > 1:
        listed = ", ".join(f"{k}: {m}" for k, m in sizes.items())
        raise ConfigError(f"A Latin hypercube needs the same n for every varied key ({listed}); make them equal.")
    u = qmc.LatinHypercube(d=len(varies), rng=np.random.default_rng(random_seed)).random(n)
    columns = []
    for j, v in enumerate(varies):
        if v.random:
            columns.append((v.low + u[:, j] * (v.high - v.low)).tolist())
        else:  # each level once: the stratum a member falls in picks the level
            levels = _levels(v, random_seed)
            columns.append([levels[int(k)] for k in np.minimum((u[:, j] * n).astype(int), n - 1)])
    return [{v.key: columns[j][i] for j, v in enumerate(varies)} for i in range(n)]


def members(
    varies: list[Vary], *, design: str = "grid", seeds: int = 1, base_seed: int = 0, random_seed: int = 0
) -> list[dict[str, Any]]:
    """The settings of every member, in order: ``{key: value}`` (``seed`` added when ``seeds`` > 1)."""
    if design not in DESIGNS:
        raise ConfigError(f"Unknown sweep design '{design}'; use grid or lhs.")
    if seeds < 1:
        raise ConfigError(f"seeds = {seeds} is not valid; give a whole number of at least 1.")
    keys = [v.key for v in varies]
    repeated = sorted({k for k in keys if keys.count(k) > 1})
    if repeated:
        raise ConfigError(f"'{repeated[0]}' is varied twice; give each key one --vary.")
    if seeds > 1 and "seed" in keys:
        raise ConfigError("The seed is both varied and repeated with --seeds; use one of the two.")
    if not varies:
        points: list[dict[str, Any]] = [{}]
    elif design == "grid":
        grids = [_levels(v, random_seed) for v in varies]
        points = [dict(zip(keys, combo, strict=True)) for combo in itertools.product(*grids)]
    else:
        points = _latin_hypercube(varies, random_seed)
    if seeds == 1:
        return points
    return [{**p, "seed": base_seed + k} for p in points for k in range(seeds)]
