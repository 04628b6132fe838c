"""Where water enters and leaves an SPH fluid on terrain: a lake filled to a level, rain by a rain map,
point inflows with a discharge, and open map edges (SPEC ER-4, FL-1).

Every new particle carries the volume V_p = Δx^d of water at rest (mass m = ρ₀V_p); every source and
sink is counted by name in the fluid's :class:`~erosim.sph.state.ParticleState`, so a run's water
budget closes exactly: initial + rained + inflow − left through edges = in the fluid.

They live in the coupling layer because they place water relative to the terrain. They are callbacks
of a :class:`~erosim.simulation.simulation.Simulation` (subclasses of
:class:`~erosim.core.callbacks.Callback`: ``schedule``, ``name``, ``__call__(sim)``, checkpoint state),
acting between steps.

* :func:`lake_particles` — a lattice of particles filling the cells connected to a seed point (or all
  cells) below a water level, top layer half a spacing under the level;
* :class:`Rain` — every ``every`` steps, rain of R mm/h falls where a rain map says (per node a
  chance in [0, 1], ER-4): the expected number of drops N = Σ_k R p_k A Δt/(3.6·10⁶ V_p) (the
  fraction carried over), each dropped in a node chosen with probability ∝ p_k, at a random point of
  its cell, ``height`` above the ground (or the water already there), until ``until`` if given;
* :class:`PointInflow` — a vertical jet of discharge Q (m³/s) from a disc of radius r at a height
  above the ground: a lattice layer of the disc every Δx/u seconds at u = Q/(area of the layer), each
  layer turned about the jet's axis (in 3-D) so that the stream has no preferred direction (a lattice
  disc of radius ~Δx is a "+" of five particles; stacked unturned it lands as four axis-aligned streams
  and wets and digs a "+"). Each layer is turned by its own random angle in [0, π/2) (the disc looks
  the same after a quarter turn), drawn from a generator keyed by (seed, layer): the stream has no
  preferred direction and no sense of rotation. A fixed turn per layer stacks the layers as a helix:
  by the golden angle (137.5° ≡ 47.5° of a quarter turn) two layers advance 5°, and the water's sheet
  on flat ground spread as a four-armed spiral (on the `water-jet` scene without seepage or craters,
  eight-fold harmonic of the sheet's bearings 0.11; random turns: 0.03–0.075 over three seeds);
* :class:`RainDrops` — rain on a voxel terrain as drops of five particles (SPEC VX-8) at random places;
* :class:`FlumeInflow` — a laboratory flume's reservoir filled at a discharge, each particle laid at rest
  on the water's surface (the voxel overtopping scenes);
* :class:`EdgeOutflow` — particles beyond an open map edge are removed and counted;
* :class:`OutsideOutflow` — particles over a DEM's nodata (the node nearest them outside the
  terrain) are removed and counted, as at an open edge.

Random draws use NumPy generators keyed by (seed, event number), so a resumed run draws the same rain.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import ndimage

from erosim.core.callbacks import Callback
from erosim.core.errors import ConfigError, InstabilityError
from erosim.core.schedules import IterationInterval
from erosim.coupling.raster import Raster
from erosim.coupling.sampling import sample

EDGES = ("west", "east", "south", "north")


def lake_particles(raster: Raster, ground: np.ndarray, level: float, spacing: float, dim: int,
                   seed_xy=None) -> np.ndarray:  # fmt: skip
    """Positions filling, below ``level``, the cells connected to ``seed_xy`` (all cells if None)
    whose ground is below the level; lattice columns of spacing Δx, top layer at level − Δx/2,
    nothing closer than 0.4Δx to the ground."""
    wet = ground < level
    if seed_xy is not None:
        ix = int(round((seed_xy[0] - raster.x0) / raster.dx))
        iy = int(round((seed_xy[1] - raster.y0) / raster.dy)) if dim == 3 else 0
        if not (0 <= ix < raster.nx and 0 <= iy < raster.ny):
            raise ConfigError(
                f"water.seed {list(seed_xy)} lies outside the terrain; give a point inside the map "
                "(its own coordinates)."
            )
        if not wet[iy, ix]:
            raise ConfigError(
                f"The ground at water.seed is {ground[iy, ix]:.4g} m, not below water.level = {level:.4g} m; "
                "raise the level or move the seed into the basin."
            )
        labels, _ = ndimage.label(wet, structure=np.ones((3, 3)) if dim == 3 else None)
        wet = labels == labels[iy, ix]
    x = np.arange(raster.x0, raster.x0 + (raster.nx - 1) * raster.dx + 1e-9, spacing) + 0.5 * spacing
    x = x[x < raster.x0 + (raster.nx - 1) * raster.dx]
    if dim == 3:
        y = np.arange(raster.y0, raster.y0 + (raster.ny - 1) * raster.dy + 1e-9, spacing) + 0.5 * spacing
        y = y[y < raster.y0 + (raster.ny - 1) * raster.dy]
        cols = np.stack([g.ravel() for g in np.meshgrid(x, y, indexing="ij")], axis=1)
    else:
        cols = x[:, None]
    pts3 = np.zeros((len(cols), dim))
    pts3[:, : dim - 1] = cols
    g = sample(raster, ground, pts3)
    ix = np.clip(np.rint((cols[:, 0] - raster.x0) / raster.dx).astype(int), 0, raster.nx - 1)
    iy = np.clip(np.rint((cols[:, 1] - raster.y0) / raster.dy).astype(int), 0, raster.ny - 1) if dim == 3 else 0
    keep = wet[iy, ix] & (g < level - 0.9 * spacing)
    cols, g = cols[keep], g[keep]
    out = []
    top = level - 0.5 * spacing
    for k in range(int(np.ceil((level - g.min()) / spacing)) + 1 if len(g) else 0):
        zk = top - k * spacing
        sel = zk > g + 0.4 * spacing
        if not sel.any():
            continue
        out.append(np.column_stack([cols[sel], np.full(sel.sum(), zk)]))
    if not out:
        raise ConfigError(
            f"water.level = {level:.4g} m leaves no water deeper than one particle spacing ({spacing:g} m); "
            "raise the level or lower sph.spacing."
        )
    return np.concatenate(out)


class _Source(Callback):
    """Common checkpoint state: the fraction of a particle carried to the next event, the event count."""

    def __init__(self, schedule, name: str):
        super().__init__(schedule, name=name)
        self.carry = 0.0
        self.events = 0
        self.last_t = 0.0

    def state_dict(self) -> dict[str, Any]:
        return {"carry": self.carry, "events": self.events, "last_t": self.last_t}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.carry = float(state.get("carry", 0.0))
        self.events = int(state.get("events", 0))
        self.last_t = float(state.get("last_t", 0.0))


class Rain(_Source):
    """Rain of ``rate`` mm/h by the per-node chance map ``chance`` (raster.shape, SPH frame)."""

    def __init__(self, schedule, solver, raster: Raster, ground: np.ndarray, chance: np.ndarray, rate_mm_h: float,
                 height: float, seed: int, grid=None, inset: float = 0.0, until: float | None = None):  # fmt: skip
        """``inset`` (m): drops start at least this far inside the map's edges (e.g. one kernel support,
        out of the reach of closed edges' walls): the map's extent is drawn in by it on every side.
        ``until`` (s of simulated time): the rain stops then (None: it never stops)."""
        super().__init__(schedule, "rain")
        if chance.shape != raster.shape:
            raise ConfigError(
                f"The rain map has shape {chance.shape[::-1] if chance.ndim == 2 else chance.shape} but the terrain "
                f"{raster.shape}; give a rain map of the terrain's size."
            )
        if not np.all(np.isfinite(chance)) or chance.min() < 0:
            raise ConfigError("The rain map has negative or NaN values; give chances between 0 and 1.")
        self.solver, self.raster, self.ground, self.grid = solver, raster, ground, grid
        self.chance = np.clip(chance, 0.0, 1.0)
        self.rate = float(rate_mm_h)
        self.height = float(height)
        self.seed = int(seed)
        self.until = until
        self.inset = min(float(inset), 0.5 * (raster.nx - 1) * raster.dx, 0.5 * (raster.ny - 1) * raster.dy)
        cdf = np.cumsum(self.chance.ravel())
        self.cdf = cdf / cdf[-1] if cdf[-1] > 0 else cdf
        # m³ of rain per second over the map: R (m/s) × Σ p_k A
        self.flow = self.rate / 3.6e6 * float(self.chance.sum()) * raster.cell_area

    def expected(self, dt: float) -> float:
        """Drops due over ``dt`` seconds (before the carried fraction)."""
        return self.flow * dt / self.solver.params.spacing**self.solver.dim

    def __call__(self, sim=None) -> None:
        s = self.solver
        t = float(s.t)
        if self.until is not None and t > self.until:
            self.last_t = t
            return
        due = self.carry + self.expected(t - self.last_t)
        self.last_t = t
        k = int(due)
        self.carry = due - k
        self.events += 1
        if k == 0 or self.flow <= 0:
            return
        rng = np.random.default_rng([self.seed & 0xFFFFFFFF, self.events, 0x2A1])
        r = self.raster
        node = np.searchsorted(self.cdf, rng.random(k), side="right").clip(0, self.cdf.size - 1)
        iy, ix = np.divmod(node, r.nx)
        x = r.x0 + (ix + rng.random(k) - 0.5) * r.dx
        y = r.y0 + (iy + rng.random(k) - 0.5) * r.dy
        xe, ye = (r.nx - 1) * r.dx, (r.ny - 1) * r.dy
        x = np.clip(x, r.x0, r.x0 + xe)
        y = np.clip(y, r.y0, r.y0 + ye)
        if self.inset > 0:  # the map drawn in by the inset on every side (not clipped: drops stay apart)
            x = r.x0 + self.inset + (x - r.x0) * ((xe - 2 * self.inset) / xe)
            y = r.y0 + self.inset + (y - r.y0) * ((ye - 2 * self.inset) / ye)
        pts = np.column_stack([x, y, np.zeros(k)])
        z = sample(r, self.ground, pts) + self.height
        if self.grid is not None:
            z += sample(r, self.grid.depth, pts)
        pts[:, 2] = z
        s.add_fluid(pts, None, source="rain")


class PointInflow(_Source):
    """A vertical jet of ``discharge`` m³/s from a disc of ``radius`` m at (x, y), ``height`` m above ground."""

    def __init__(self, schedule, solver, raster: Raster, ground: np.ndarray, position, discharge: float,
                 radius: float, height: float, name: str, seed: int = 0):  # fmt: skip
        super().__init__(schedule, f"inflow:{name}")
        self.seed = int(seed)
        d = solver.dim
        dx = solver.params.spacing
        self.solver = solver
        k = max(0, int(radius / dx))
        offs = np.arange(-k, k + 1) * dx
        if d == 3:
            disc = np.stack([g.ravel() for g in np.meshgrid(offs, offs, indexing="ij")], axis=1)
            disc = disc[(disc**2).sum(axis=1) <= max(radius, 0.5 * dx) ** 2 + 1e-12]
        else:
            disc = offs[:, None]
        centre = np.asarray(position, np.float64)[: d - 1]
        cols = centre + disc
        pts = np.zeros((len(cols), d))
        pts[:, : d - 1] = cols
        top = float(sample(raster, ground, pts).max()) + height
        pts[:, d - 1] = top
        self.layer = pts
        self.centre = centre
        area = len(cols) * dx ** (d - 1)
        self.speed = float(discharge) / area  # m/s through the layer
        if self.speed <= 0:
            raise ConfigError(f"Inflow '{name}' has discharge {discharge}; give a positive discharge in m³/s.")
        self.period = dx / self.speed  # one layer each time the jet has moved one spacing
        self.vel = np.zeros_like(pts)
        self.vel[:, d - 1] = -self.speed
        self.last_t = float(solver.t)

    def __call__(self, sim=None) -> None:
        s = self.solver
        t = float(s.t)
        due = self.carry + (t - self.last_t) / self.period
        self.last_t = t
        layers = int(due)
        self.carry = due - layers
        for _ in range(layers):
            self.events += 1
            s.add_fluid(self.turned(self.events), self.vel, source=self.name)

    def turned(self, event: int) -> np.ndarray:
        """The layer of ``event``, turned about the jet's axis by a random angle in [0, π/2) keyed by
        (seed, ``event``) (3-D): a rigid turn (the particles' spacings are kept) within the disc's
        quarter-turn symmetry, with no sense of rotation from one layer to the next (module docstring)."""
        if self.solver.dim != 3:
            return self.layer
        a = 0.5 * np.pi * np.random.default_rng([self.seed & 0xFFFFFFFF, event, 0x7E7]).random()
        c, s = np.cos(a), np.sin(a)
        out = self.layer.copy()
        rel = self.layer[:, :2] - self.centre
        out[:, 0] = self.centre[0] + c * rel[:, 0] - s * rel[:, 1]
        out[:, 1] = self.centre[1] + s * rel[:, 0] + c * rel[:, 1]
        return out


class EdgeOutflow(Callback):
    """Removes fluid particles that crossed an open edge of the map (``edges`` ⊆ west, east, south, north)."""

    def __init__(self, schedule, solver, raster: Raster, edges):
        super().__init__(schedule, name="outflow")
        self.solver = solver
        self.edges = tuple(edges)
        unknown = set(self.edges) - set(EDGES)
        if unknown:
            raise ConfigError(f"Unknown edge(s) {sorted(unknown)} in edges.outflow; use {', '.join(EDGES)}.")
        self.bounds = {
            "west": (0, raster.x0, -1.0),
            "east": (0, raster.x0 + (raster.nx - 1) * raster.dx, 1.0),
            "south": (1, raster.y0, -1.0),
            "north": (1, raster.y0 + (raster.ny - 1) * raster.dy, 1.0),
        }

    def __call__(self, sim=None) -> None:
        st = self.solver.state
        pos = st.pos[: st.n_fluid]
        for e in self.edges:
            axis, at, sign = self.bounds[e]
            if axis >= self.solver.dim - 1:
                continue
            out = sign * (pos[:, axis] - at) > 0
            if out.any():
                self.solver.remove_fluid(out, sink=f"edge:{e}")
                pos = st.pos[: st.n_fluid]


class OutsideOutflow(Callback):
    """Removes fluid particles over the nodes ``outside`` the terrain (raster.shape: a DEM's nodata),
    those whose nearest node is outside, as an open edge would (sink ``outside``); adds up the water and
    the mud they carried (registered fields ``water`` and ``mud`` where the solver has them, in V_p)."""

    def __init__(self, schedule, solver, raster: Raster, outside: np.ndarray):
        if np.shape(outside) != raster.shape:
            raise ValueError(f"outside mask {np.shape(outside)} does not match the raster {raster.shape}")
        super().__init__(schedule, name="outside")
        self.solver, self.raster = solver, raster
        self.outside = np.asarray(outside, bool)
        self.left = {"water": 0.0, "mud": 0.0}

    def __call__(self, sim=None) -> None:
        st, r = self.solver.state, self.raster
        pos = st.pos[: st.n_fluid]
        ix = np.clip(np.floor((pos[:, 0] - r.x0) / r.dx + 0.5).astype(np.int64), 0, r.nx - 1)
        iy = np.clip(np.floor((pos[:, 1] - r.y0) / r.dy + 0.5).astype(np.int64), 0, r.ny - 1) if r.ny > 1 else 0
        out = self.outside[iy, ix]
        if out.any():
            for k in self.left:
                if hasattr(st, k):
                    self.left[k] += float(getattr(st, k)[: st.n_fluid][out].sum())
            self.solver.remove_fluid(out, sink="outside")

    def state_dict(self) -> dict[str, Any]:
        return {"left_water": self.left["water"], "left_mud": self.left["mud"]}

    def load_state_dict(self, state) -> None:
        self.left = {"water": float(state.get("left_water", 0.0)), "mud": float(state.get("left_mud", 0.0))}


class RainDrops(Callback):
    """Rain as drops of 5 particles (a centre and its four horizontal neighbours at Δx; SPEC VX-8) at
    random places over the map at ``z``, falling at rest; the drops due at ``rate`` (mm/h) are added every
    ``every`` steps. Places come from a generator keyed by (seed, shower), so a resumed run rains the same."""

    SHAPE = np.array([[0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], np.float64)

    def __init__(self, schedule, solver, lo, hi, z: float, rate_mm_h: float, seed: int):
        super().__init__(schedule, name="rain")
        dx = solver.params.spacing
        self.solver, self.lo, self.hi, self.z, self.seed = solver, np.asarray(lo), np.asarray(hi), z, seed
        area = float(np.prod(self.hi - self.lo))
        self.per_s = rate_mm_h / 3.6e6 * area / (5 * dx**3)  # drops per second
        self.carry, self.last_t, self.events, self.drops = 0.0, float(solver.t), 0, 0

    def __call__(self, sim) -> None:
        s = self.solver
        due = self.carry + (float(s.t) - self.last_t) * self.per_s
        self.last_t = float(s.t)
        n = int(due)
        self.carry = due - n
        if n == 0:
            return
        dx = s.params.spacing
        rng = np.random.default_rng([self.seed, 0xD409, self.events])
        self.events += 1
        centres = np.column_stack([rng.uniform(self.lo[0] + dx, self.hi[0] - dx, n),
                                   rng.uniform(self.lo[1] + dx, self.hi[1] - dx, n), np.full(n, self.z)])  # fmt: skip
        pts = (centres[:, None, :] + dx * self.SHAPE[None]).reshape(-1, 3)
        s.add_fluid(pts, np.zeros_like(pts), source="rain")
        self.drops += n

    def state_dict(self) -> dict[str, Any]:
        return {"carry": self.carry, "last_t": self.last_t, "events": self.events, "drops": self.drops}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.carry, self.last_t = float(state["carry"]), float(state["last_t"])
        self.events, self.drops = int(state["events"]), int(state["drops"])


class FlumeInflow(Callback):
    """A reservoir filled as in a laboratory flume, its level rising gently: water enters at ``discharge``
    Q (m³/s) one particle at a time (one every Δx³/Q seconds), each laid **at rest** on the water's
    surface at its site (:meth:`rest_height`); the sites are the Δx lattice of the
    rectangle ``x0…x1`` × the flume's width, taken in a fixed scattered order (a stride coprime with
    their number), so the surface rises evenly.

    A particle so laid adds potential energy of about Δx/2 and no momentum, and no wave larger than one
    particle: the reservoir stays still while it fills and the overflow is driven by the level alone,
    as in Fujisawa et al.'s (2011) flume fed from upstream. Water poured from a height instead hits the
    surface at √(2gΔz), and whole layers dropped at once start surges: both stir the reservoir into
    currents of several cm/s that scour its upstream face before any water reaches the crest
    (docs/voxel.md). A new particle is at least Δx from every other."""

    def __init__(self, solver, x0: float, x1: float, width: float, discharge: float, top: float):
        super().__init__(IterationInterval(1), name="inflow")
        dx = solver.params.spacing
        xs = (np.arange(math.ceil(x0 / dx - 0.5), math.floor(x1 / dx - 0.5) + 1) + 0.5) * dx
        ys = (np.arange(0, math.floor(width / dx - 0.5) + 1) + 0.5) * dx
        gx, gy = np.meshgrid(xs[(xs > x0) & (xs < x1)], ys[ys < width], indexing="ij")
        sites = np.column_stack([gx.ravel(), gy.ravel()])
        n = len(sites)
        stride = next(k for k in range(max(1, int(0.618 * n)), 2 * n + 2) if math.gcd(k, n) == 1)
        self.sites = sites[(np.arange(n) * stride) % n]
        self.dx, self.top = dx, top
        self.period = dx**3 / discharge
        self.solver = solver
        self.carry, self.last_t, self.events = 0.0, float(solver.t), 0

    def rest_height(self, pos, xy) -> float:
        """The lowest z at ``xy`` at least Δx from every fluid particle below it: max over the particles k
        within Δx horizontally (ρ_k < Δx) of z_k + √(Δx² − ρ_k²) (a ball laid on the surface); Δx/2 (on
        the floor) when there are none."""
        z = self._ball_top(pos, xy)
        return z if z > -math.inf else 0.5 * self.dx

    def _ball_top(self, pos, xy) -> float:
        """max of z_k + √(Δx² − ρ_k²) over the particles within Δx horizontally; −∞ when there are none."""
        r2 = (pos[:, 0] - xy[0]) ** 2 + (pos[:, 1] - xy[1]) ** 2
        near = r2 < self.dx * self.dx
        return float((pos[near, 2] + np.sqrt(self.dx * self.dx - r2[near])).max()) if near.any() else -math.inf

    def __call__(self, sim) -> None:
        s = self.solver
        due = self.carry + (float(s.t) - self.last_t) / self.period
        self.last_t = float(s.t)
        count = int(due)
        self.carry = due - count
        if count == 0:
            return
        pos = s.fluid_positions()
        pts = np.empty((count, 3))
        for k in range(count):
            xy = self.sites[(self.events + k) % len(self.sites)]
            pts[k] = xy[0], xy[1], max(self.rest_height(pos, xy), self._ball_top(pts[:k], xy))  # and this step's
        if pts[:, 2].max() > self.top:
            raise InstabilityError(
                f"The inflow's water reached the top of the flume's domain ({self.top:g} m) at t = {float(s.t):.3g} s; "
                "lower inflow.discharge or raise terrain.top."
            )
        self.events += count
        s.add_fluid(pts, np.zeros_like(pts), source="inflow")

    def state_dict(self) -> dict[str, Any]:
        return {"carry": self.carry, "last_t": self.last_t, "events": self.events}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.carry, self.last_t, self.events = float(state["carry"]), float(state["last_t"]), int(state["events"])
