"""Callbacks: small objects a :class:`~erosim.simulation.simulation.Simulation` calls on a schedule.

Each callback has a ``schedule`` (:mod:`erosim.core.schedules`) and is called with the
simulation when it is due. It may keep state that belongs in checkpoints (``state_dict`` /
``load_state_dict``: arrays go into the checkpoint's arrays, other values into its JSON header), write
what it gathered at checkpoints and at the end (``flush``), and add to the report when the run
completes (``finalize``). The fluid callbacks read a particle model through its public interface
(``fluid_positions()``, ``fluid_velocities()``, ``fluid_pressure()``, ``fluid_density()``, ``t``).

* :class:`Checkpointer` — writes the simulation's checkpoint;
* :class:`ParticleFrames` — VTK PolyData frames + ``particles.pvd`` (ParaView);
* :class:`Snapshots` — PNG pictures of the particles coloured by speed;
* :class:`Probes` — pressure probes and water-level gauges → ``gauges.csv``;
* :class:`FrontTracker` — the surge front → ``front.csv`` (and its figure against an experiment);
* :class:`Animation` — pictures of a map over time → an animated GIF;
* :class:`MapFrames` — maps (height, water) over time → ``maps/frames/`` (``erosim view``'s slider);
* :class:`BudgetCheck` — a terrain changed in place must change by what its model says it moved;
* :class:`~erosim.core.callbacks.Callback` — the base (:mod:`erosim.core.callbacks`), any function of the simulation.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from erosim.analysis.front import front_position
from erosim.analysis.gauges import gauge_readings, probe_pressure
from erosim.core.atomic import write_text
from erosim.core.callbacks import Callback
from erosim.core.increments import Increment, IncrementView, check_budget
from erosim.core.schedules import Schedule
from erosim.io import map_frames
from erosim.io.particles import FrameSeries
from erosim.viz.animate import save_animation
from erosim.viz.maps import save_png
from erosim.viz.plots import snapshot


def csv_text(header: list[str], rows) -> str:
    """CSV with a header line; numbers written with ``repr`` (round-trip exact)."""
    lines = [",".join(header)]
    lines += [",".join(repr(float(v)) for v in r) for r in rows]
    return "\n".join(lines) + "\n"


class Checkpointer(Callback):
    """Writes the simulation's checkpoint (default: every 5 minutes of wall time)."""

    def __init__(self, schedule: Schedule):
        super().__init__(schedule, name="checkpointer")

    def __call__(self, sim) -> None:
        sim.checkpoint()


class ParticleFrames(Callback):
    """``particles/frame_NNNNN.vtp`` (velocity, pressure, density as float32; ``id``, each particle's label
    for the whole run, as int64) and ``particles.pvd``."""

    def __init__(self, schedule: Schedule, fluid, folder: Path):
        super().__init__(schedule, name="frames")

        self.fluid = fluid
        self.folder = Path(folder)
        self.series = FrameSeries(self.folder)

    def __call__(self, sim) -> None:
        s = self.fluid
        fields = {
            "velocity": s.fluid_velocities().astype(np.float32),
            "pressure": s.fluid_pressure().astype(np.float32),
            "density": s.fluid_density().astype(np.float32),
            "id": s.fluid_ids(),
        }
        self.series.write(float(s.t), s.fluid_positions().astype(np.float32), fields)

    def state_dict(self) -> dict[str, Any]:
        return {"frames": [list(f) for f in self.series.frames]}

    def load_state_dict(self, state: dict[str, Any]) -> None:

        self.series = FrameSeries(self.folder, frames=state.get("frames", []))


class Snapshots(Callback):
    """``figures/snapshot_NNN.png``: the particles coloured by speed, on one scale for every frame:
    0 to 2√(|g|Δz), Δz the domain's height (Ritter's dam-break front speed 2√(gH) for the deepest
    water the domain holds, above the free-fall speed √(2gΔz)); without gravity each frame's own."""

    def __init__(self, schedule: Schedule, fluid, folder: Path, *, lo, hi, spacing: float, title: str, g: float):
        super().__init__(schedule, name="snapshots")
        self.fluid = fluid
        self.folder = Path(folder)
        self.lo, self.hi, self.spacing, self.title = lo, hi, spacing, title
        self.speed_max = 2.0 * float(np.sqrt(abs(g) * (hi[-1] - lo[-1]))) or None
        self.count = 0

    def __call__(self, sim) -> None:

        s = self.fluid
        snapshot(
            self.folder / f"snapshot_{self.count:03d}.png", s.fluid_positions(), s.fluid_velocities(),
            t=float(s.t), lo=self.lo, hi=self.hi, spacing=self.spacing, title=self.title, speed_max=self.speed_max,
        )  # fmt: skip
        self.count += 1

    def state_dict(self) -> dict[str, Any]:
        return {"count": self.count}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.count = int(state.get("count", 0))


class Probes(Callback):
    """Pressure probes and water-level gauges (:mod:`erosim.analysis.gauges`) sampled into ``gauges.csv``.

    Columns: ``t`` (s), ``p_<probe>`` (Pa), ``depth_<gauge>`` (m above ``floor``: the continuous water
    column at the gauge line, :func:`~erosim.analysis.gauges.water_level`), ``wire_<gauge>`` (m: the
    line's wetted length, as a wire gauge reads it, :func:`~erosim.analysis.gauges.gauge_readings`). A probe with a wall
    (``walls[k]`` = (normal, solid box)) reads the load the fluid puts on that wall's particles with
    ``wall_pressures(fluid, [(point, normal, box), …], support)`` (the builder passes
    :func:`erosim.sph.wall_load.wall_pressures`: over a patch one support wide each way); the others
    the fluid's pressure interpolated at their point.
    """

    def __init__(
        self, schedule: Schedule, fluid, path: Path, *, probes, gauges, support: float, spacing: float,
        mass: float, floor: float, walls=None, wall_pressures: Callable | None = None,
    ):  # fmt: skip
        super().__init__(schedule, name="probes")
        self.fluid = fluid
        self.path = Path(path)
        self.probe_points = np.array([p for _, p in probes], dtype=np.float64)
        self.gauge_points = np.array([g for _, g in gauges], dtype=np.float64)
        self.h, self.dx, self.mass, self.floor = support, spacing, mass, floor
        self.walls = list(walls) if walls is not None else [None] * len(probes)
        if wall_pressures is None and any(w is not None for w in self.walls):
            raise ValueError("probes on walls need the wall_pressures function that reads them")
        self.wall_pressures = wall_pressures
        self.header = (["t"] + [f"p_{n}" for n, _ in probes] + [f"depth_{n}" for n, _ in gauges]
                       + [f"wire_{n}" for n, _ in gauges])  # fmt: skip
        self.rows: list[list[float]] = []

    def __call__(self, sim) -> None:

        s = self.fluid
        pos = s.fluid_positions()
        row = [float(s.t)]
        vol = self.mass / s.fluid_density()
        if len(self.probe_points):
            values = np.zeros(len(self.probe_points))
            inside = [k for k, wall in enumerate(self.walls) if wall is None]
            on_walls = [k for k, wall in enumerate(self.walls) if wall is not None]
            if inside:
                values[inside] = probe_pressure(
                    pos, s.fluid_pressure(), vol, self.probe_points[inside], self.h,
                    density=s.fluid_density(), gravity=s.params.gravity_vector(),
                )  # fmt: skip
            if on_walls:
                values[on_walls] = self.wall_pressures(s, [(self.probe_points[k], *self.walls[k]) for k in on_walls],
                                                       self.h)  # fmt: skip
            row += values.tolist()
        if len(self.gauge_points):
            kernel = s.params.kernel
            readings = gauge_readings(pos, vol, self.gauge_points, self.h, self.dx, self.floor, kernel)
            row += readings[:, 0].tolist() + readings[:, 1].tolist()
        self.rows.append(row)

    def state_dict(self) -> dict[str, Any]:
        return {"rows": np.asarray(self.rows, dtype=np.float64).reshape(-1, len(self.header))}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if "rows" in state:
            self.rows = np.asarray(state["rows"]).tolist()

    def flush(self, sim) -> None:

        write_text(self.path, csv_text(self.header, self.rows))


class FrontTracker(Callback):
    """The surge front (:func:`erosim.analysis.front.front_position`) into ``front.csv`` (``t,x_front``);
    at the end ``figure(rows)`` (given by the builder: the front against an experiment) draws it."""

    def __init__(self, schedule: Schedule, fluid, path: Path, *, spacing: float, origin: float,
                 figure: Callable | None = None):  # fmt: skip
        super().__init__(schedule, name="front")
        self.fluid = fluid
        self.path = Path(path)
        self.spacing, self.origin = spacing, origin
        self.figure = figure
        self.rows: list[list[float]] = []

    def __call__(self, sim) -> None:

        s = self.fluid
        self.rows.append([float(s.t), front_position(s.fluid_positions(), self.spacing, self.origin, axis=0)])

    def state_dict(self) -> dict[str, Any]:
        return {"rows": np.asarray(self.rows, dtype=np.float64).reshape(-1, 2)}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if "rows" in state:
            self.rows = np.asarray(state["rows"]).tolist()

    def flush(self, sim) -> None:

        write_text(self.path, csv_text(["t", "x_front"], self.rows))

    def finalize(self, sim) -> dict[str, Any]:
        if self.figure is not None and self.rows:
            self.figure(np.asarray(self.rows))
        return {}


class Animation(Callback):
    """Pictures (``picture(sim)`` → RGB array) gathered over the run and saved as a GIF at the end.

    With ``stills`` (a file name pattern such as ``figures/maps_{:03d}.png``) every picture is also saved
    whole as a PNG, numbered on, and the GIF is made of its thumbnails (every ``thumbnail``-th pixel).
    The pictures gathered so far travel in the checkpoint (thumbnails: a few MB), so a resumed run's
    animation is the uninterrupted run's.
    """

    def __init__(self, schedule: Schedule, picture: Callable, path: Path, *, fps: float = 8.0,
                 stills: str | None = None, thumbnail: int = 1, name: str = "animation"):  # fmt: skip
        super().__init__(schedule, name=name)
        self.picture = picture
        self.path = Path(path)
        self.fps = fps
        self.stills, self.thumbnail, self.count = stills, int(thumbnail), 0
        self.frames: list[np.ndarray] = []

    def _take(self, sim) -> np.ndarray:
        pic = self.picture(sim)
        if self.stills is not None:

            save_png(Path(self.stills.format(self.count)), pic)
            self.count += 1
        return pic[:: self.thumbnail, :: self.thumbnail]

    def __call__(self, sim) -> None:
        self.frames.append(self._take(sim))

    def state_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"frames": np.stack(self.frames)} if self.frames else {}
        if self.stills is not None:
            out["count"] = self.count
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.frames = list(state["frames"]) if "frames" in state else []
        self.count = int(state.get("count", 0))

    def finalize(self, sim) -> dict[str, Any]:
        if not self.frames:
            return {}

        save_animation(self.path, [*self.frames, self._take(sim)], fps=self.fps)  # the state stays as it was
        return {"animation": str(self.path.relative_to(sim.out.path))}


class MapFrames(Callback):
    """Maps of the run's state (``maps(sim)`` → name → array on ``like``'s grid) written as a frame
    each time the schedule fires and once more at the end (:mod:`erosim.io.map_frames`).

    Only the frames' times travel in the checkpoint: a resumed run writes the frames after it again,
    numbered on from there, so its folder holds the uninterrupted run's frames.
    """

    def __init__(self, schedule: Schedule, maps: Callable, like, unit: str):
        super().__init__(schedule, name="map_frames")
        self.maps, self.like, self.unit = maps, like, unit
        self.times: list[float] = []

    def _write(self, sim) -> None:

        map_frames.write_frame(sim.out.path, len(self.times), self.maps(sim), self.like)
        self.times.append(float(sim.time))
        map_frames.write_times(sim.out.path, self.times, self.unit)

    def __call__(self, sim) -> None:
        self._write(sim)

    def state_dict(self) -> dict[str, Any]:
        return {"times": list(self.times)}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.times = [float(t) for t in state.get("times", [])]

    def finalize(self, sim) -> dict[str, Any]:
        if not self.times or float(sim.time) > self.times[-1]:
            self._write(sim)
        return {"map_frames": len(self.times)}


class BudgetCheck(Callback):
    """Checks the sediment budget of a model that changes its terrain ``z`` in place.

    ``moved()`` returns the model's running totals (ΔS held in the water, C carried off), m³. Each
    time the check fires, Δz since the last check (an :class:`~erosim.core.increments.IncrementView`)
    with the totals' change must pass :func:`~erosim.core.increments.check_budget`; a model whose
    terrain change and bookkeeping disagree stops with a :class:`~erosim.core.errors.BudgetError`.
    The report gets the number of checks and the largest relative imbalance seen.
    """

    def __init__(self, schedule: Schedule, z: np.ndarray, moved: Callable[[], tuple[float, float]], cell_area: float,
                 who: str):  # fmt: skip
        super().__init__(schedule, name="budget_check")
        self.z, self.moved, self.cell_area, self.who = z, moved, cell_area, who
        self._sync()
        self.checks = 0
        self.worst = 0.0

    def _sync(self) -> None:
        self.view = IncrementView(self.z)
        self.last = self.moved()

    def __call__(self, sim) -> None:
        s, c = self.moved()
        inc = Increment(self.view.take(), s - self.last[0], c - self.last[1])
        self.last = (s, c)
        t = check_budget(inc, self.z.shape, self.cell_area, self.who)
        scale = max(t["eroded"], t["deposited"], abs(t["suspended"]), abs(t["carried_off"]))
        if scale > 0:
            self.worst = max(self.worst, abs(t["imbalance"]) / scale)
        self.checks += 1

    def state_dict(self) -> dict[str, Any]:
        # the reference of the next check travels too, so checks fall as in an uninterrupted run
        return {"checks": self.checks, "worst": self.worst, "mark": self.view.mark, "last": np.array(self.last)}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self._sync()  # the model was restored first; an older checkpoint without a reference uses it
        if "mark" in state:
            self.view.mark[...] = state["mark"]
            self.last = tuple(float(x) for x in state["last"])
        self.checks = int(state.get("checks", 0))
        self.worst = float(state.get("worst", 0.0))

    def finalize(self, sim) -> dict[str, Any]:
        return {"budget_check": {"checks": self.checks, "max_imbalance_rel": self.worst}}
