"""Transport-capacity erosion under an SPH flow (Mei, Decaudin & Hu 2007; seed 000 eq. 1.30–1.36,
SPEC ER-1…ER-3), as an eroder of :class:`~erosim.coupling.coupler.Coupler`.

Per terrain node k with water deeper than ``min_depth`` (node fields from the fluid grid: the mean
velocity ⟨u⟩ of the particles near the bed and its part along the ground, |⟨u⟩_t| = |⟨u⟩ − (⟨u⟩·n)n|
with n the ground's normal; the water depth), terrain height b, sediment s held in the water over
the node (m³ per m² of bed) and slope angle α (central differences of b):

    C = K_c · sin(max(α, α_min)) · |⟨u⟩_t|                                  (ER-1, α_min the slope clamp)
    C > s:  b −= E,  s += E,   E = (1 − e^{−K_s Δt}) (C − s), at most b − bedrock     (ER-2, dissolve)
    C ≤ s:  b += D,  s −= D,   D = (1 − e^{−K_d Δt}) (s − C)                        (ER-2, deposit)

The seed applies K_s(C − s) once per step of its fixed Δt; here K_s and K_d are rates (1/s) and the
exchange is the exact relaxation of ds/dt = K (C − s) over the coupling interval Δt, so the result
does not depend on how often the coupler runs and stays stable for any Δt. The seed takes |⟨u⟩| of
every particle in the cell; the flow along the bed is what drags sediment, and drops still falling
onto the ground (rain) would otherwise erode where they land (that is splash erosion, another
method). The defaults are the
thesis's table 6 (K_c = 0.16, K_s = 0.025, K_d = 0.05 per step) with its Δt = 0.1 s: K_c = 0.16 s,
K_s = 0.25 s⁻¹, K_d = 0.5 s⁻¹. Flat terrain would never erode without the clamp (seed 000 §1.4);
water at rest (⟨u⟩ = 0) never erodes whatever the clamp.

Map edges. The water stands only on the inner half of an edge node's cell (a quarter at a corner):
walls lie on the edge nodes, and water that crosses an open edge's nodes is removed. The sediment per
m² there is s = held / (f A), f the wet fraction (½ on an edge, ¼ at a corner), and the node's cell,
half of it dry beyond the map, changes by f·(the wet half's change): Δz = −f E, so Σ Δz A + ΔS = 0
still holds with the raster's cell area A. Slopes are central differences on the map padded by one
ghost row: beyond a wall the bed is extrapolated linearly from the two edge rows (the one-sided
difference), beyond an open (outflow) edge it is the initial bed extrapolated linearly and held, the
land the water runs off to. The outflow edge is then an interior node for the law: its own height
does not enter its slope, so lowering it cannot raise its capacity (with the one-sided difference it
did: a self-feeding cut of rate ≈ K_s K_c |u| / Δx that dug the edge row metres deep), and
particles leaving carry their sediment out.

Transport of the sediment (ER-3), two options:

* ``"particles"`` (default, mass-conserving): the sediment rides on the fluid particles (a
  registered per-particle field ``sediment``, m³). A node's s is the sediment of its particles over
  the node's area; dissolved sediment is shared equally among them, deposited sediment is taken from
  each in proportion to what it carries (the particles' new loads travel in the increment, which the
  coupler applies). The particles' motion is the advection; a particle leaving
  through an open edge takes its sediment with it (counted as carried off). Terrain + suspended +
  carried off is constant to rounding.
* ``"semi-lagrangian"`` (the seed's): s on the grid, advected by s(x) ← s(x − ⟨u⟩Δt) with Q4
  interpolation after each exchange. It is not conservative; its gain or loss of sediment per step is
  summed and reported as ``transport_error`` (m³).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError
from erosim.core.increments import Increment
from erosim.kernels.raster import bilinear, nearest_node


class TransportCapacityParams(Section):
    """Parameters of transport-capacity erosion (SPEC ER-1…ER-3); SI units."""

    capacity: float = param(0.16, ge=0, unit="s", doc="K_c: transport capacity per unit of sin α |⟨u⟩| (ER-1)")
    dissolve: float = param(0.25, ge=0, unit="1/s", doc="K_s: rate at which the flow picks up sediment (ER-2)")
    deposit: float = param(0.5, ge=0, unit="1/s", doc="K_d: rate at which sediment settles (ER-2)")
    min_slope_deg: float = param(
        3.0, ge=0, le=89, unit="deg", doc="slope clamp α_min: flat ground still erodes under moving water"
    )
    min_depth: float = param(0.0, ge=0, unit="m", doc="erosion acts only where the water is deeper than this")
    transport: str = param(
        "particles", doc="how suspended sediment moves: 'particles' (conserving) or 'semi-lagrangian' (seed's ER-3)"
    )

    def check(self) -> None:
        """Refuse (one sentence) a transport that is not one of the two."""
        if self.transport not in ("particles", "semi-lagrangian"):
            raise ConfigError(
                f"erosion.transport = '{self.transport}' is not known; use 'particles' or 'semi-lagrangian'."
            )


@njit(cache=True)
def held_per_node(pos, sed, n_fluid, x0, y0, inv_dx, inv_dy, nx, ny, out):
    """out[k] = sediment (m³) carried by the fluid particles in node k's cell."""
    out[:] = 0.0
    for i in range(n_fluid):
        k = nearest_node(pos, i, x0, y0, inv_dx, inv_dy, nx, ny)
        if k >= 0:
            out[k] += sed[i]


@njit(cache=True)
def exchange_with_particles(pos, sed, n_fluid, x0, y0, inv_dx, inv_dy, nx, ny, exchange, count, held):
    """Give each particle its share of node k's exchange (m³; > 0 taken up by the water): an equal
    share of a pick-up, a fraction exchange/held of its own load for a deposit."""
    for i in range(n_fluid):
        k = nearest_node(pos, i, x0, y0, inv_dx, inv_dy, nx, ny)
        if k < 0:
            continue
        e = exchange[k]
        if e > 0.0:
            sed[i] += e / count[k]
        elif e < 0.0:
            sed[i] += sed[i] * (e / held[k])


@njit(cache=True)
def capacity_exchange(b, s_area, depth, speed, sin_alpha, floor, kc, fs, fd, min_depth, dz, e_area):
    """ER-1/ER-2 on every node: dz (m, terrain change) and e_area (m, sediment taken up per m²)."""
    ny, nx = b.shape
    for iy in range(ny):
        for ix in range(nx):
            dz[iy, ix] = 0.0
            e_area[iy, ix] = 0.0
            if depth[iy, ix] <= min_depth or depth[iy, ix] <= 0.0:
                continue
            c = kc * sin_alpha[iy, ix] * speed[iy, ix]
            s = s_area[iy, ix]
            if c > s:
                e = fs * (c - s)
                room = b[iy, ix] - floor[iy, ix]
                if e > room:
                    e = max(room, 0.0)
            else:
                e = -fd * (s - c)
            dz[iy, ix] = -e
            e_area[iy, ix] = e


@njit(cache=True)
def advect_semi_lagrangian(s, vel, dt, inv_dx, inv_dy, out):
    """ER-3: out(x) = s(x − ⟨u⟩Δt) (Q4, clamped to the map), per node."""
    ny, nx = s.shape
    d = vel.shape[2]
    for iy in range(ny):
        for ix in range(nx):
            x = ix - vel[iy, ix, 0] * dt * inv_dx
            y = iy - vel[iy, ix, 1] * dt * inv_dy if d == 3 else 0.0
            out[iy, ix] = bilinear(s, x, y)


EDGE_SIDES = {"west": (1, 0), "east": (1, -1), "south": (0, 0), "north": (0, -1)}  # (axis, end) of (ny, nx)


def wet_fraction(shape: tuple[int, int]) -> np.ndarray:
    """Fraction of each node's cell inside the map (½ on an edge, ¼ at a corner; a one-node axis counts whole)."""
    f = np.ones(shape)
    for axis, n in enumerate(shape):
        if n > 1:
            idx = [slice(None), slice(None)]
            for end in (0, -1):
                idx[axis] = end
                f[tuple(idx)] *= 0.5
    return f


def ghost_padded(terrain: np.ndarray, fixed: dict[str, np.ndarray]) -> np.ndarray:
    """The terrain with one ghost row/column on each side of an axis of more than one node: the linear
    extrapolation 2 z_edge − z_inner, or the held row ``fixed[side]`` for an open edge."""
    ny, nx = terrain.shape
    py, px = int(ny > 1), int(nx > 1)
    p = np.empty((ny + 2 * py, nx + 2 * px))
    p[py : py + ny, px : px + nx] = terrain
    if px:
        p[py : py + ny, 0] = fixed.get("west", 2.0 * terrain[:, 0] - terrain[:, 1])
        p[py : py + ny, -1] = fixed.get("east", 2.0 * terrain[:, -1] - terrain[:, -2])
    if py:
        p[0, px : px + nx] = fixed.get("south", 2.0 * terrain[0] - terrain[1])
        p[-1, px : px + nx] = fixed.get("north", 2.0 * terrain[-1] - terrain[-2])
    return p


def node_gradient(terrain: np.ndarray, dx: float, dy: float, fixed: dict[str, np.ndarray]) -> tuple:
    """(∂z/∂x, ∂z/∂y) at the nodes (m/m): central differences on :func:`ghost_padded` (0 on a one-node axis)."""
    ny, nx = terrain.shape
    p = ghost_padded(terrain, fixed)
    py, px = int(ny > 1), int(nx > 1)
    sx = (p[py : py + ny, 2:] - p[py : py + ny, :-2]) / (2.0 * dx) if px else np.zeros_like(terrain)
    sy = (p[2:, px : px + nx] - p[:-2, px : px + nx]) / (2.0 * dy) if py else np.zeros_like(terrain)
    return sx, sy


def _along_ground(vel: np.ndarray, sx: np.ndarray, sy: np.ndarray) -> np.ndarray:
    """|u − (u·n)n| per node, n the ground's unit normal (−s_x, −s_y, 1)/‖·‖ from the nodes' slopes."""
    if vel.shape[-1] == 3:
        n = np.stack([-sx, -sy, np.ones_like(sx)], axis=-1)
    else:
        n = np.stack([-sx, np.ones_like(sx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    ut = vel - (vel * n).sum(axis=-1, keepdims=True) * n
    return np.sqrt((ut * ut).sum(axis=-1))


class TransportCapacity:
    """The eroder (see the module docstring); ``solver`` gives the particles for ``transport = "particles"``."""

    name = "transport-capacity"
    needs = ("count", "depth", "bed_velocity")

    def __init__(self, params: TransportCapacityParams, raster, solver, bedrock: np.ndarray | None = None, *,
                 outflow=(), terrain: np.ndarray | None = None):  # fmt: skip
        """``outflow``: the open edges (west, east, south, north); beyond them the bed is ``terrain`` (the
        initial one) extrapolated linearly and held."""
        params.check()
        self.p = params
        self.raster = raster
        self.solver = solver
        shape = raster.shape
        self.floor = np.full(shape, -np.inf) if bedrock is None else np.ascontiguousarray(bedrock, np.float64)
        self.sin_min = math.sin(math.radians(params.min_slope_deg))
        self.wet = wet_fraction(shape)
        unknown = set(outflow) - set(EDGE_SIDES)
        if unknown:
            raise ConfigError(f"Unknown edge(s) {sorted(unknown)} in the outflow edges; use {', '.join(EDGE_SIDES)}.")
        if outflow and terrain is None:
            raise ValueError("open edges need the initial terrain (terrain=...) to extrapolate the bed beyond them")
        self.ghost: dict[str, np.ndarray] = {}
        for side in outflow:
            axis, end = EDGE_SIDES[side]
            if shape[axis] < 2:
                continue  # a one-node axis (2-D fluid's y) has no such edge
            z0 = np.asarray(terrain, np.float64)
            edge, inner = (z0.take(end, axis), z0.take(1 if end == 0 else -2, axis))
            self.ghost[side] = 2.0 * edge - inner
        self.dz = np.zeros(shape)
        self.e_area = np.zeros(shape)
        self.s_area = np.zeros(shape)  # sediment per m² of bed held by the water (grid transport's state)
        self.held = np.zeros(shape)
        self.transport_error = 0.0
        if params.transport == "particles":
            if "sediment" not in solver.state.specs:
                solver.state.register("sediment")

    # ---------------------------------------------------------------- the contract
    def increments(self, terrain: np.ndarray, grid, dt: float) -> Increment:
        p, r = self.p, self.raster
        area = r.cell_area
        # in 2-D the one-row raster has no y slope; ghost rows beyond walls and open edges (module docstring)
        sx, sy = node_gradient(terrain, r.dx, r.dy, self.ghost)
        sin_alpha = np.maximum(np.sin(np.arctan(np.hypot(sx, sy))), self.sin_min)
        wet_area = area * self.wet
        fs = 1.0 - math.exp(-p.dissolve * dt)
        fd = 1.0 - math.exp(-p.deposit * dt)
        if p.transport == "particles":
            st = self.solver.state
            held_per_node(st.pos, st.sediment, st.n_fluid, r.x0, r.y0, 1.0 / r.dx, 1.0 / r.dy, r.nx, r.ny,
                          self.held.reshape(-1))  # fmt: skip
            np.divide(self.held, wet_area, out=self.s_area)
        speed = _along_ground(grid.bed_velocity, sx, sy)
        capacity_exchange(terrain, self.s_area, grid.depth, speed, sin_alpha, self.floor, p.capacity, fs, fd,
                          p.min_depth, self.dz, self.e_area)  # fmt: skip
        exchange = self.e_area * wet_area  # m³ per node: the wet part of the cell
        self.dz *= self.wet  # the cell's mean change (its dry part beyond the map keeps its height)
        carried = {}
        if p.transport == "particles":
            carried["sediment"] = sed = st.sediment[: st.n_fluid].copy()  # the coupler writes it back
            exchange_with_particles(st.pos, sed, st.n_fluid, r.x0, r.y0, 1.0 / r.dx, 1.0 / r.dy, r.nx, r.ny,
                                    exchange.reshape(-1), grid.count.reshape(-1), self.held.reshape(-1))  # fmt: skip
        else:
            s1 = self.s_area + self.e_area
            out = np.empty_like(s1)
            advect_semi_lagrangian(s1, grid.velocity, dt, 1.0 / r.dx, 1.0 / r.dy, out)
            self.transport_error += float(((out - s1) * self.wet).sum() * area)
            self.s_area[...] = out
        return Increment(self.dz.copy(), suspended=float(exchange.sum()), particles=carried)

    # ---------------------------------------------------------------- reporting and checkpoints
    def held_total(self) -> float:
        """Sediment held in the water now (m³)."""
        if self.p.transport == "particles":
            st = self.solver.state
            return float(st.sediment[: st.n_fluid].sum())
        return float((self.s_area * self.wet).sum() * self.raster.cell_area)

    def carried_off(self) -> float:
        """Sediment that left with water through open edges (m³; particle transport)."""
        return float(self.solver.state.removed_sums.get("sediment", 0.0))

    def held_map(self) -> np.ndarray:
        """Sediment held in the water over each node, m³ per m² of wet bed."""
        if self.p.transport == "particles":
            st, r = self.solver.state, self.raster
            held_per_node(st.pos, st.sediment, st.n_fluid, r.x0, r.y0, 1.0 / r.dx, 1.0 / r.dy, r.nx, r.ny,
                          self.held.reshape(-1))  # fmt: skip
            return self.held / (r.cell_area * self.wet)
        return self.s_area.copy()

    def state_dict(self) -> dict[str, Any]:
        return {"s_area": self.s_area.copy(), "transport_error": np.float64(self.transport_error)}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.s_area[...] = np.asarray(state["s_area"])
        self.transport_error = float(np.asarray(state["transport_error"]))
