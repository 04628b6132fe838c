"""Schema of ``kind = "sph"`` scenario files (validated by :func:`erosim.core.config.validate_section`).

::

    seed = 1
    [sph]            solver parameters (erosim.sph.params.SPHParams)
    [domain]         lo, hi: the box (m); vertical is the last axis (y in 2-D, z in 3-D)
    [particles]      optional target fluid particle count: derives sph.spacing (then h and m)
    [[fluid]]        blocks of fluid: lo, hi, optional initial velocity
    [[obstacles]]    solid axis-aligned boxes: lo, hi
    [run]            t_end, frame / sample / checkpoint intervals, device ("cpu" or "cuda")
    [[probes]]       pressure probes: name, position
    [[gauges]]       water-level gauges: name, horizontal position
    [measure]        surge front on/off and its origin (the column's back wall)
    [gate]           optional dam-break gate lifted at a constant speed (speed, x)

Geometry is checked here (a fluid block outside the domain, mixed dimensions, …): each problem is
one :class:`~erosim.core.errors.ConfigError` sentence naming the block and the fix.
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import model_validator

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError
from erosim.sph.params import SPHParams


class Box(Section):
    lo: list[float] = param(..., unit="m", doc="lower corner (x, y[, z])")
    hi: list[float] = param(..., unit="m", doc="upper corner (x, y[, z])")


class Domain(Box):
    """The tank: particles never leave it."""


class FluidBlock(Box):
    velocity: list[float] | None = param(None, unit="m/s", doc="initial velocity of the block (default at rest)")


class Obstacle(Box):
    """A solid box inside the domain."""


class Particles(Section):
    count: int | None = param(
        None,
        ge=1,
        unit="1",
        doc="target number of fluid particles; when set, sph.spacing = (fluid volume / count)^(1/dim) "
        "(so h = h_factor·Δx and m = ρ₀Δx^dim follow from it)",
    )


class Run(Section):
    t_end: float = param(1.0, gt=0, unit="s", doc="simulated time to reach")
    output_interval: float = param(0.05, ge=0, unit="s", doc="particle frames (.vtp) every this long; 0: none")
    sample_interval: float = param(0.01, gt=0, unit="s", doc="gauges, probes and front sampled every this long")
    snapshots: int = param(4, ge=0, le=100, unit="1", doc="PNG snapshots (coloured by speed) over the run")
    checkpoint_wall_s: float = param(300.0, gt=0, unit="s", doc="wall-clock time between checkpoints")
    device: Literal["cpu", "cuda"] = param(
        "cpu",
        doc="where the SPH steps run: 'cpu' (Numba threads) or 'cuda' (an NVIDIA GPU, needs `pip install "
        "'erosim[cuda]'`; docs/gpu.md); a checkpoint of either resumes on the other",
    )


class Probe(Section):
    name: str = param(..., doc="column name in gauges.csv")
    position: list[float] = param(..., unit="m", doc="point where the pressure is measured")


class Gauge(Section):
    name: str = param(..., doc="column name in gauges.csv")
    position: list[float] = param(..., unit="m", doc="horizontal position of the vertical gauge line (x[, y])")


class Gate(Section):
    speed: float = param(
        0.0,
        ge=0,
        unit="m/s",
        doc="lift the dam-break gate at this speed from t = 0 (a plate of boundary particles at gate.x; "
        "0: no gate, the column is released at once)",
    )
    x: float | None = param(
        None, unit="m", doc="the gate's face towards the water (default: the fluid's face towards the longer tank part)"
    )


class Measure(Section):
    front: bool = param(False, doc="record the surge front (furthest wetted x) to front.csv")
    front_origin: float | None = param(
        None, unit="m", doc="x of the column's back wall (default: smallest x of the fluid blocks)"
    )
    compare: Literal["none", "martin-moyce"] = param(
        "none", doc="plot the front against an experiment: 'martin-moyce' (column of height 2a, n² = 2)"
    )


def derived_spacing(volume: float, count: int, dim: int) -> float:
    """Δx = (V/N)^(1/dim), rounded to 12 significant digits so 7 m / 70 gives exactly 0.1 m."""
    return float(f"{(volume / count) ** (1.0 / dim):.12g}")


def _check_box(name: str, box: Box, dim: int) -> None:
    if len(box.lo) != dim or len(box.hi) != dim:
        raise ConfigError(
            f"{name} has lo/hi of lengths {len(box.lo)}/{len(box.hi)} but the domain is {dim}-D; "
            f"give {dim} coordinates to each."
        )
    if any(h <= l for l, h in zip(box.lo, box.hi, strict=True)):
        raise ConfigError(f"{name} has hi {box.hi} not above lo {box.lo} on every axis; swap or fix the corners.")


class SPHScenario(Section):
    seed: int = param(0, ge=0, doc="random seed (recorded in the run folder)")
    sph: SPHParams = SPHParams()
    domain: Domain
    particles: Particles = Particles()
    fluid: list[FluidBlock]
    obstacles: list[Obstacle] = []
    run: Run = Run()
    probes: list[Probe] = []
    gauges: list[Gauge] = []
    measure: Measure = Measure()
    gate: Gate = Gate()

    @property
    def dim(self) -> int:
        return len(self.domain.lo)

    @model_validator(mode="before")
    @classmethod
    def _derive(cls, data):
        """Fill ``sph.dim`` from the domain and ``sph.spacing`` from ``particles.count``."""
        if not isinstance(data, dict):
            return data
        data = dict(data)
        sph = dict(data.get("sph") or {})
        lo = (data.get("domain") or {}).get("lo") if isinstance(data.get("domain"), dict) else None
        if "dim" not in sph and isinstance(lo, list) and len(lo) in (2, 3):
            sph["dim"] = len(lo)
        count = (data.get("particles") or {}).get("count") if isinstance(data.get("particles"), dict) else None
        if isinstance(count, int) and count >= 1 and isinstance(data.get("fluid"), list):
            vol = 0.0
            try:
                for b in data["fluid"]:
                    vol += math.prod(float(h) - float(l) for l, h in zip(b["lo"], b["hi"], strict=True))
            except (KeyError, TypeError, ValueError):
                vol = 0.0  # malformed blocks: the field validation reports them
            if vol > 0 and isinstance(lo, list) and len(lo) in (2, 3):
                sph["spacing"] = derived_spacing(vol, count, len(lo))
        data["sph"] = sph
        return data

    @model_validator(mode="after")
    def _geometry(self) -> SPHScenario:
        dim = len(self.domain.lo)
        if dim not in (2, 3):
            raise ConfigError(f"domain.lo has {dim} coordinates; give 2 (x, y) or 3 (x, y, z).")
        _check_box("domain", self.domain, dim)
        if not self.fluid:
            raise ConfigError("The scenario has no [[fluid]] block; add one with lo and hi corners.")
        if self.sph.dim != dim:
            raise ConfigError(
                f"sph.dim = {self.sph.dim} but the domain has {dim} coordinates; set sph.dim = {dim} "
                "or give the domain corners in the other dimension."
            )
        lo, hi = self.domain.lo, self.domain.hi

        def inside(name: str, b: Box) -> None:
            if any(bl < dl - 1e-12 or bh > dh + 1e-12 for bl, bh, dl, dh in zip(b.lo, b.hi, lo, hi, strict=True)):
                raise ConfigError(
                    f"{name} (lo {b.lo}, hi {b.hi}) lies outside the domain (lo {lo}, hi {hi}); "
                    "move it inside or enlarge [domain]."
                )

        for i, b in enumerate(self.fluid):
            name = f"fluid block {i + 1}"
            _check_box(name, b, dim)
            inside(name, b)
            if b.velocity is not None and len(b.velocity) != dim:
                raise ConfigError(f"{name} velocity has {len(b.velocity)} components; give {dim}.")
        for i, o in enumerate(self.obstacles):
            _check_box(f"obstacle {i + 1}", o, dim)
            inside(f"obstacle {i + 1}", o)
        for p in self.probes:
            if len(p.position) != dim:
                raise ConfigError(f"probe '{p.name}' position has {len(p.position)} coordinates; give {dim}.")
        if self.gate.speed > 0:
            self.gate_side()
            if self.sph.walls != "particles":
                raise ConfigError(
                    "A lifted gate is made of boundary particles; set sph.walls = 'particles' or gate.speed = 0."
                )
        for g in self.gauges:
            if len(g.position) != dim - 1:
                raise ConfigError(
                    f"gauge '{g.name}' position has {len(g.position)} coordinates; give the {dim - 1} "
                    "horizontal one(s) of its vertical line."
                )
        return self

    def gate_face(self) -> float:
        """x of the gate's face: ``gate.x`` or the fluid's face towards the longer part of the tank."""
        if self.gate.x is not None:
            return float(self.gate.x)
        lo_f = min(b.lo[0] for b in self.fluid)
        hi_f = max(b.hi[0] for b in self.fluid)
        return hi_f if self.domain.hi[0] - hi_f >= lo_f - self.domain.lo[0] else lo_f

    def gate_side(self) -> int:
        """+1 when the water stands at smaller x than the gate (the plate lies at larger x), else −1."""
        x = self.gate_face()
        if not self.domain.lo[0] < x < self.domain.hi[0]:
            raise ConfigError(
                f"gate.x = {x:g} m lies outside the domain's x range {self.domain.lo[0]:g}–{self.domain.hi[0]:g} m; "
                "put the gate inside the tank."
            )
        if all(b.hi[0] <= x + 1e-12 for b in self.fluid):
            return 1
        if all(b.lo[0] >= x - 1e-12 for b in self.fluid):
            return -1
        raise ConfigError(
            f"The gate at x = {x:g} m cuts through a fluid block; put gate.x at the column's face so all the "
            "water starts on one side."
        )
