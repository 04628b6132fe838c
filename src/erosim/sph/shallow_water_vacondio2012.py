"""Shallow-water SPH (SWE-SPH) with variable smoothing length and particle splitting.

Method (Rodriguez-Paz & Bonet 2005, *Comput. Struct.* 83; Vacondio, Rogers, Stansby & Mignosa
2012, *J. Hydraul. Eng.* 138 and *Int. J. Numer. Meth. Fluids* 69; Vacondio et al. 2013, *Comput.
Methods Appl. Mech. Eng.* 256). Particles move on the plane and carry a volume of water V_i:

* depth      d_i = Σ_j V_j W(|x_i − x_j|, H_i),   H_i = k √(V_i/(d_i + δ_i))   (Newton per particle;
             δ_i = k²V_i/H_max² bounds H smoothly where the water thins)
* momentum   du_i/dt = −(g/2) Σ_j V_j [∇W_ij(H_i)/Ω_i + ∇W_ij(H_j)/Ω_j] − g ∇b(x_i) + Π-term + friction
             Ω_i = 1 + (H_i/(2(d_i + δ_i))) Σ_j V_j ∂W_ij/∂H
* friction   Manning, −g n² |u| u / d^{4/3}, applied semi-implicitly (never reverses a particle)
* time step  Δt = C min_i H_i/(√(g d_i) + |u_i|), kick–drift–kick leapfrog.

The momentum equation is the gradient of the discrete potential energy Σ_j V_j g (d_j/2 + b(x_j))
(variational SPH), so the scheme conserves energy when friction and viscosity are off and water
settles where the discrete energy is least: a lake on uneven ground comes to rest and stays there
exactly (forces balance particle by particle), without a separate bed-slope correction. The
choice, against Vacondio et al.'s bed-particle correction, is written here because that paper
interpolates the bed from bed particles; erosim has the DEM itself, and its Q4 surface gives ∇b
exactly where the potential is evaluated. Wet/dry fronts need no special case: the edge of the
particle cloud is the shoreline, and a particle never carries water where there is none.

Splitting (Vacondio et al. 2013), on by default: a moving particle (faster than ``split_speed``)
shallower than ``split_depth`` whose spacing √(V/d) has grown past ``split_spacing`` × the initial
spacing (the flow has thinned) becomes seven: one at its position with 0.178 V and six on a hexagon of
radius 0.4·√(V/d) with the rest in equal shares, all with the parent's velocity — mass, momentum and
the first moment of mass are kept exactly. A particle lighter than ``split_min_volume`` × the
reservoir particle is not split (0.03: one generation), which bounds the count. The split is gradual:
the daughters start with the parent's H (a support factor k_i² = k² V_parent/V_i, so that H = k_i
√(V_i/(d + δ_i)) and δ_i = k_i²V_i/H_max² are the parent's) and k_i relaxes to k over ``split_relax``
crossing times of their support (e-fold), where the abrupt √7 change of H gave them depths 13–22 %
off the water's and shrank the global step at once. Splits happen at the steps that rebuild the
neighbour lists anyway.

Walls are cells of the DEM (nodata, a dam line) and closed map edges: their bed is raised above the
water (:func:`raised_walls`), and a particle that would still enter one stays where it is and stops
(an inelastic, no-slip contact). Open map edges remove the particles that cross them;
their water is counted (``budget()``).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from scipy import ndimage

from erosim.core.config import Section, param
from erosim.core.errors import InputError, InstabilityError
from erosim.sph import kernels_swe as K

_SPLIT_CENTRE = 0.178  # Vacondio et al. 2013: the centre daughter's share of the parent's volume
_SPLIT_RADIUS = 0.4  # hexagon radius in units of the parent's spacing √(V/d)
_HEXAGON = np.stack([np.cos(np.arange(6) * (np.pi / 3.0)), np.sin(np.arange(6) * (np.pi / 3.0))], -1)
_EDGES = ("west", "east", "north", "south")


class ShallowWaterParams(Section):
    """Settings of :class:`ShallowWaterSPH`; see the module docstring."""

    g: float = param(9.81, gt=0, unit="m/s^2", doc="gravity")
    support: float = param(
        3.0, ge=2.0, le=4.0, unit="1", doc="kernel support H = support·√(V/d) (3.0: about 28 neighbours in 2-D)"
    )
    courant: float = param(
        0.15,
        gt=0,
        le=0.6,
        unit="1",
        doc="Courant number C of Δt = C·H/(√(g d) + |u|), on the support H (about 0.4 on the smoothing length "
        "H/2.6); at 0.3 Ritter's dam break is 7.7 % off (RMS of h₀), at 0.15 2.8 %",
    )
    viscosity: float = param(0.3, ge=0, le=2, unit="1", doc="artificial viscosity α (Monaghan 1992), for bores")
    split: bool = param(
        True,
        doc="split particles where the flow thins (Vacondio et al. 2013), gradually (split_relax): Ritter's map tip "
        "0.017 h₀ against 0.061 h₀ without; on either device (docs/flood.md)",
    )
    split_spacing: float = param(
        1.5, gt=1, unit="1", doc="split a particle when its spacing √(V/d) exceeds this × the initial spacing"
    )
    split_depth: float = param(
        1.0,
        gt=0,
        unit="m",
        doc="split only particles shallower than this (the thin water the hazard classes tell apart)",
    )
    split_speed: float = param(
        0.1, ge=0, unit="m/s", doc="split only particles moving faster than this (water at rest keeps its particles)"
    )
    split_relax: float = param(
        5.0,
        ge=0,
        unit="1",
        doc="a split's daughters start with their parent's H (k_i² = k² V_parent/V_i) and relax to their own H = "
        "k√(V/(d + δ)) over this many crossing times of their support, H/(√(g d) + |u|), e-fold (0: at once, the "
        "abrupt √7 change)",
    )
    split_min_volume: float = param(
        0.03, gt=0, le=1, unit="1", doc="never split particles lighter than this × the initial particle volume"
    )
    max_support: float = param(
        2.0,
        ge=1.2,
        unit="1",
        doc="H approaches this × the initial support as the water thins (H = k√(V/(d + δ)), δ = k²V/H_max²: a "
        "smooth bound, so a shore comes to rest); a lone particle's depth floor falls as 1/max_support². 2.0: "
        "the flood's margins thin to the grid model's shallow share and both dam breaks improve; 3.0 thins "
        "them further but its tip particles run ahead (docs/flood.md)",
    )
    bed_smoothing: float = param(
        1.0,
        ge=0,
        unit="1",
        doc="the bed the water feels is the DEM smoothed by a Gaussian of σ = this × the spacing (0: none)",
    )
    tolerance: float = param(1e-4, gt=0, lt=0.1, unit="1", doc="relative tolerance of the H–d Newton iteration")
    max_particles: int = param(5_000_000, ge=1, unit="1", doc="refuse to split beyond this many particles")
    margin_speed: Literal["shepard", "conveyance"] = param(
        "conveyance",
        doc="the hazard maps' speed where the water is thinner than the particles' columns (its edge): "
        "'conveyance' slows the speed along the edge by (depth/column depth)^(2/3), Manning's law at a shared "
        "friction slope, and keeps the speed across it, at which a front's tip and a shore move; 'shepard' keeps "
        "the particles' mean speed out to the edge in every direction (docs/flood.md)",
    )


class ShallowWaterSPH:
    """A :class:`~erosim.simulation.Simulation` model: shallow-water SPH over a DEM.

    ``bed`` is the DEM (rows north → south, float64), ``cell_size`` its cell in metres; positions
    are in the cell frame of :mod:`erosim.sph.kernels_swe` (x = column·Δ, y = row·Δ). ``wall`` marks
    cells water cannot enter, ``manning`` is n per cell, ``open_edges`` the edges water leaves by,
    ``surface`` the highest water surface at the start (walls are raised above it; default: the bed's top).
    """

    name = "swe"

    def __init__(
        self,
        bed: np.ndarray,
        cell_size: float,
        pos: np.ndarray,
        vol: np.ndarray,
        spacing: float,
        params: ShallowWaterParams | None = None,
        *,
        vel: np.ndarray | None = None,
        manning: np.ndarray | float = 0.0,
        wall: np.ndarray | None = None,
        open_edges: tuple[str, ...] = (),
        surface: float | None = None,
    ):
        self.params = params or ShallowWaterParams()
        self.cell = float(cell_size)
        self.inv_cell = 1.0 / self.cell
        bed = np.asarray(bed, dtype=np.float64)
        ny, nx = bed.shape
        self.manning = np.ascontiguousarray(np.broadcast_to(np.asarray(manning, np.float64), (ny, nx)))
        self.wall = np.zeros((ny, nx), np.bool_) if wall is None else np.ascontiguousarray(wall, dtype=np.bool_)
        bad = [e for e in open_edges if e not in _EDGES]
        if bad:
            raise InputError(f"Unknown map edge {bad[0]!r} in outflow.edges; use any of {', '.join(_EDGES)}.")
        self.open = tuple(e in open_edges for e in _EDGES)
        self.wall_dist = wall_distance(self.wall, self.cell)
        self.surface0 = float(surface) if surface is not None else float(bed.max())
        self.spacing = float(spacing)
        self.bed = self._felt_bed(bed)
        pos = np.ascontiguousarray(pos, dtype=np.float64).reshape(-1, 2)
        n = len(pos)
        if n == 0:
            raise InputError("The flood has no water: the reservoir holds no particle; raise its level or spacing.")
        self.v0 = float(np.max(vol))
        self.h0 = self.params.support * self.spacing
        self.h_cap = self.params.max_support * self.h0
        self.h_min = 0.05 * self.h0
        self.pos = pos.copy()
        self.vel = np.zeros((n, 2)) if vel is None else np.ascontiguousarray(vel, dtype=np.float64).copy()
        self.vol = np.ascontiguousarray(vol, dtype=np.float64).copy()
        # a first guess of H from the particle's own volume at the lattice depth V/Δx²
        self.hsup = np.full(n, self.h0)
        self.k2 = np.full(n, self.params.support**2)  # k_i² (a split's daughters relax to support²)
        self.depth = np.zeros(n)
        self.omega = np.ones(n)
        self.acc = np.zeros((n, 2))
        self.t = 0.0
        self.steps = 0
        self.splits = 0
        self.settle_steps = 0
        self.rebuilds = 0
        self._settling = False
        self._built_at: np.ndarray | None = None
        self.last_dt = 0.0
        self.volume_initial = float(self.vol.sum())
        self.volume_out = 0.0
        self._evaluate()

    # ------------------------------------------------------------------ the model protocol

    @property
    def n(self) -> int:
        return len(self.vol)

    @property
    def neighbour_pairs(self) -> int:
        """Ordered neighbour pairs (i, j) in the lists of the last evaluation."""
        return int(self._start[-1]) if self.n else 0

    @property
    def time(self) -> float:
        return self.t

    def advance(self) -> None:
        self.step()

    def step(self, dt: float | None = None) -> float:
        """One kick–drift–kick step (Δt from the CFL limit unless given); returns Δt."""
        prm = self.params
        if dt is None:
            dt = prm.courant * K.step_limit(self.vel, self.depth, self.hsup, self.n, prm.g)
        if not math.isfinite(dt) or dt <= 0:
            raise InstabilityError(
                f"The shallow-water step became {dt!r} s at t = {self.t:.3f} s; lower flood.courant."
            )
        self._kick(0.5 * dt)
        out = np.zeros(self.n, np.bool_)
        blocked = np.zeros(self.n, np.int64)
        K.drift(self.pos, self.vel, self.n, dt, self.inv_cell, self.wall, *self.open, out, blocked)
        if out.any():
            self.volume_out += float(self.vol[out].sum())
            self._keep(~out)
            blocked = blocked[~out]
        if prm.split and not self._settling:
            self._relax(dt)
            if not self._lists_hold():  # split when the lists are rebuilt anyway (a split rebuilds them)
                blocked = np.concatenate([blocked, np.zeros(self._split() * 6, np.int64)])
        if self.n:
            self._evaluate()
            self._kick(0.5 * dt)
            K.hold_contacts(self.vel, self.n, blocked)
        self.t += dt
        self.steps += 1
        self.last_dt = dt
        if self.n and not np.isfinite(self.vel).all():
            raise InstabilityError(f"Speeds became infinite at t = {self.t:.3f} s; lower flood.courant.")
        return dt

    def settle(self, max_steps: int = 600, speed: float = 0.05) -> int:
        """Let the water come to rest before the run starts, by FIRE (Bitzek et al. 2006, *Phys. Rev.
        Lett.* 97): ordinary steps whose velocities are turned towards the forces, v ← (1 − α)v +
        α|v|F̂, and zeroed whenever the power P = Σ V_i a_i·v_i turns negative (α back to 0.1, and
        decaying by 0.99 per step after 5 steps of positive power); it stops once the fastest particle
        is slower than ``speed`` (m/s) or after ``max_steps``. The clock stays at 0.

        A lattice of particles is not the discrete equilibrium (the SPH depth of an uneven
        arrangement is not exactly level): undamped, a reservoir would slosh at t = 0. Plain damping
        stalls on the shore's soft modes; FIRE reaches the energy minimum many times faster.
        Returns the steps taken.
        """
        alpha, since = 0.1, 0
        k = 0
        self._settling = True  # no splitting while the water comes to rest
        try:
            for k in range(1, max_steps + 1):  # noqa: B007 (the count is returned)
                self.step()
                w = self.vol[:, None]
                power = float((w * self.acc * self.vel).sum())
                if power <= 0.0:
                    self.vel[:] = 0.0
                    alpha, since = 0.1, 0
                else:
                    vn = math.sqrt(float((w * self.vel**2).sum()))
                    fn = math.sqrt(float((w * self.acc**2).sum()))
                    if fn > 0.0:
                        self.vel *= 1.0 - alpha
                        self.vel += alpha * vn / fn * self.acc
                    since += 1
                    if since > 5:
                        alpha *= 0.99
                # at rest: moving slower than `speed` after a step that did not stop everything
                if power > 0.0 and since > 5 and float(np.hypot(self.vel[:, 0], self.vel[:, 1]).max()) < speed:
                    break
        finally:
            self._settling = False
        self.settle_steps += k
        self.t, self.steps, self.last_dt = 0.0, 0, 0.0
        self.volume_out = 0.0
        self.volume_initial = float(self.vol.sum())
        self._evaluate()
        return k

    def set_terrain(self, bed: np.ndarray, wall: np.ndarray) -> None:
        """A new bed and walls (e.g. the breach opening after the reservoir has settled)."""
        self.wall = np.ascontiguousarray(wall, dtype=np.bool_)
        self.wall_dist = wall_distance(self.wall, self.cell)
        self.bed = self._felt_bed(np.asarray(bed, np.float64))
        self._evaluate()

    def _felt_bed(self, bed: np.ndarray) -> np.ndarray:
        return felt_bed(bed, self.wall, self.open, self.surface0, self.params.bed_smoothing * self.spacing / self.cell)

    # ------------------------------------------------------------------ passes

    def _kick(self, dt: float) -> None:
        K.kick(self.vel, self.acc, self.depth, self.manning, self.inv_cell, self.pos, self.n, dt, self.params.g, 1e-6)

    def _neighbours(self, margin: float) -> None:
        """CSR lists of the pairs closer than max(s_i, s_j), s = margin·H (a Verlet skin)."""
        self._build_lists(self.pos.copy(), self.hsup * margin)

    def _build_lists(self, at: np.ndarray, search: np.ndarray) -> None:
        """The lists of the pairs of positions ``at`` closer than max(search_i, search_j), found in bins
        of a third of the largest radius, each skipped where out of reach (:func:`K.pairs_particle`)."""
        n = len(at)
        cell = (float(search.max()) if n else self.h0) / K.LIST_BINS
        x0, y0 = at[:, 0].min() - cell, at[:, 1].min() - cell
        ncx = int((at[:, 0].max() - x0) / cell) + 2
        ncy = int((at[:, 1].max() - y0) / cell) + 2
        cell_start = np.empty(ncx * ncy + 1, np.int64)
        order = np.empty(n, np.int64)
        K.bin_particles(at, n, x0, y0, cell, ncx, ncy, cell_start, order)
        bin_max = np.empty(ncx * ncy)
        K.bin_search_max(at, search, n, x0, y0, cell, ncx, ncy, bin_max)
        count = np.empty(n, np.int64)
        grid = (x0, y0, cell, ncx, ncy, cell_start, order, bin_max, K.LIST_BINS)
        start = np.zeros(n + 1, np.int64)
        K.scan_pairs(at, search, n, *grid, count, start, np.empty(0, np.int64), False)
        np.cumsum(count, out=start[1:])
        nbr = np.empty(int(start[-1]), np.int64)
        K.scan_pairs(at, search, n, *grid, count, start, nbr, True)
        self._start, self._nbr, self._search, self._built_at = start, nbr, search, at
        self.rebuilds += 1

    def _lists_hold(self) -> bool:
        """Do the lists still hold every pair closer than max(H_i, H_j)?

        They were built with radius max(s_i, s_j) at positions x⁰; a pair now closer than
        max(H_i, H_j) was closer than that + |Δx_i| + |Δx_j| then, so H_i + |Δx_i| + max|Δx| ≤ s_i for
        every i suffices (the Verlet-list argument, with per-particle radii).
        """
        if self._built_at is None or len(self._built_at) != self.n:
            return False
        return K.lists_hold(self.pos, self._built_at, self.hsup, self._search, self.n)

    def _evaluate(self) -> None:
        """Depth and H (Newton), Ω and accelerations at the current positions; lists rebuilt when the
        particles have moved or grown past their skin."""
        prm = self.params
        margin = 1.5
        for _ in range(4):
            if not self._lists_hold():
                self._neighbours(margin)
            previous = self.hsup.copy()
            K.depth_and_support(
                self.pos, self.vol, self.hsup, self.n, self._start, self._nbr, self.k2,
                self.h_min, self.h_cap, prm.tolerance, 40, self.depth, self.omega,
            )  # fmt: skip
            if self._lists_hold():
                break
            # a support outgrew the lists: rebuild from the larger H and solve again
            self.hsup = np.maximum(previous, self.hsup)
            self._built_at = None
            margin *= 1.2
        K.accelerations(
            self.pos, self.vel, self.vol, self.hsup, self.depth, self.omega, self.n, self._start, self._nbr,
            self.bed, self.inv_cell, prm.g, prm.viscosity, self.acc,
        )  # fmt: skip

    def _keep(self, keep: np.ndarray) -> None:
        for k in ("pos", "vel", "vol", "hsup", "k2", "depth", "omega", "acc"):
            setattr(self, k, np.ascontiguousarray(getattr(self, k)[keep]))
        self._built_at = None

    def _split_args(self) -> tuple:
        """The thresholds of :func:`K.split_parent` (the module docstring's conditions)."""
        prm = self.params
        return (prm.split_spacing * self.spacing, 7 * prm.split_min_volume * self.v0, prm.split_speed**2,
                prm.split_depth, _SPLIT_RADIUS, _HEXAGON, self.inv_cell, self.wall)  # fmt: skip

    def _split(self) -> int:
        """Split the thinned particles (module docstring); returns how many were split."""
        prm = self.params
        parent = np.empty(self.n, np.bool_)
        K.split_parents(self.pos, self.vol, self.depth, self.vel, self.n, *self._split_args(), parent)
        m = int(parent.sum())
        if m == 0:
            return 0
        if self.n + 6 * m > prm.max_particles:
            return 0  # resolution stays where it is: the count is bounded by the user
        idx = np.flatnonzero(parent)
        v = self.vol[idx]
        rad = _SPLIT_RADIUS * np.sqrt(v / np.maximum(self.depth[idx], 1e-300))
        ring = (v - _SPLIT_CENTRE * v) / 6.0
        # a parent whose hexagon would reach into a wall or off the map is not split (split_parent: no
        # daughter may sit on another, coincident particles have no consistent smoothing length)
        new_pos = (self.pos[idx, None, :] + rad[:, None, None] * _HEXAGON).reshape(-1, 2)
        centre = v - 6.0 * ring  # the centre keeps exactly what the ring does not take
        self.vol[idx] = centre
        if prm.split_relax > 0:
            # the daughters keep the parent's H: k_i² = k_p² V_p/V_i holds k_i²V_i, so H = k_i√(V_i/(d + δ_i))
            # and δ_i = k_i²V_i/H_max² are the parent's at the parent's depth; they relax in _relax
            k2_ring = self.k2[idx] * v / ring
            self.k2[idx] = self.k2[idx] * v / centre
        else:
            k2_ring = np.full(m, prm.support**2)
            self.k2[idx] = prm.support**2
            self.hsup[idx] = self.hsup[idx] / math.sqrt(7.0)
        self.pos = np.concatenate([self.pos, new_pos])
        self.vel = np.concatenate([self.vel, np.repeat(self.vel[idx], 6, axis=0)])
        self.vol = np.concatenate([self.vol, np.repeat(ring, 6)])
        self.hsup = np.concatenate([self.hsup, np.repeat(self.hsup[idx], 6)])
        self.k2 = np.concatenate([self.k2, np.repeat(k2_ring, 6)])
        for k in ("depth", "omega"):
            setattr(self, k, np.concatenate([getattr(self, k), np.repeat(getattr(self, k)[idx], 6)]))
        self.acc = np.concatenate([self.acc, np.repeat(self.acc[idx], 6, axis=0)])
        self._built_at = None
        self.splits += m
        return m

    def _relax(self, dt: float) -> None:
        """The daughters' support factors towards k (:func:`K.relax_support`): k_i² ← k² + (k_i² − k²)
        exp(−Δt/τ_i), τ_i = ``split_relax`` · H_i/(√(g d_i) + |u_i|), so that their H shrinks from the
        parent's to their own over a few of their own crossing times rather than by √7 at once."""
        prm = self.params
        K.relax_supports(self.k2, self.hsup, self.depth, self.vel, self.n, prm.support**2, prm.split_relax, prm.g, dt)

    # ------------------------------------------------------------------ outputs

    def budget(self) -> dict:
        """Water volume: initial = in the flow + out through open edges (closure relative to initial)."""
        inside = float(self.vol.sum())
        closure = (self.volume_initial - self.volume_out - inside) / self.volume_initial
        return {
            "volume_initial_m3": self.volume_initial,
            "volume_out_m3": self.volume_out,
            "volume_in_flow_m3": inside,
            "closure_rel": closure,
        }

    def surface(self) -> np.ndarray:
        """Free-surface elevation b(x_i) + d_i of every particle."""
        b = np.empty(self.n)
        K.bed_at(self.bed, self.pos, self.n, self.inv_cell, b)
        return b + self.depth

    def depth_grid(self) -> np.ndarray:
        """The water's depth on the DEM's nodes now, as the hazard maps take it (:meth:`update_maxima`):
        min(Σ_j V_j W(|x − x_j|, H_j), η̄ − b), walls blinding the sum, 0 on wall cells and where dry."""
        out = np.zeros_like(self.bed)
        if self.n == 0:
            return out
        sums, r_lo, c_lo = self._map_sums()
        nr, nc = sums.shape[:2]
        d, s, se = sums[..., 0], sums[..., 2], sums[..., 3]
        bed = self.bed[r_lo : r_lo + nr, c_lo : c_lo + nc]
        cut = np.divide(se, s, out=np.zeros_like(se), where=s > 0) - bed
        out[r_lo : r_lo + nr, c_lo : c_lo + nc] = np.maximum(np.minimum(d, cut), 0.0)
        out[self.wall] = 0.0
        return out

    def _map_sums(self) -> tuple[np.ndarray, int, int]:
        """The sums Σ V_j W, Σ V_j W |u_j|, Σ V_j W/d_j, Σ V_j W η_j/d_j, Σ V_j W u_j, Σ V_j ∇W over the
        window of cells within reach of the particles (:func:`K.scatter_sums`), and the window's first
        row and column."""
        n = self.n
        (xmin, ymin), (xmax, ymax) = self.pos.min(axis=0), self.pos.max(axis=0)
        _, _, _, _, _, r_lo, c_lo, nr, nc = self._maxima_window(xmin, ymin, xmax, ymax, self.hsup.max())
        eta = np.empty(n)
        K.surfaces(self.pos, self.depth, self.bed, n, self.inv_cell, eta)
        # the sums particle by particle (each pair once, stripes of rows in parallel), then the cells in
        # parallel; the device gathers per cell (grid_maxima), the same sums in another order
        sums = np.zeros((nr, nc, K.MAP_SUMS))
        K.scatter_sums(
            self.pos, self.vel, self.vol, self.hsup, self.depth, eta, n, self.cell, r_lo, c_lo, self.wall,
            self.wall_dist, sums,
        )  # fmt: skip
        return sums, r_lo, c_lo

    def sample(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(surface elevation, depth, speed) at points in the cell frame (m).

        Depth by the SPH scatter sum Σ_j V_j W(r, H_j); speed the Shepard mean of |u_j| with the same
        weights; the surface is the bed's Q4 height plus the depth.
        """
        pts = np.asarray(points, np.float64).reshape(-1, 2)
        depth = np.zeros(len(pts))
        speed = np.zeros(len(pts))
        b = np.empty(len(pts))
        K.bed_at(self.bed, pts, len(pts), self.inv_cell, b)
        if self.n:
            sp = np.hypot(self.vel[:, 0], self.vel[:, 1])
            for k, p in enumerate(pts):
                r = np.hypot(self.pos[:, 0] - p[0], self.pos[:, 1] - p[1])
                s = np.clip(r / self.hsup, 0.0, 1.0)
                w = 7.0 / (np.pi * self.hsup**2) * (1 - s) ** 4 * (1 + 4 * s)
                dw = self.vol * w
                depth[k] = dw.sum()
                speed[k] = (dw * sp).sum() / depth[k] if depth[k] > 0 else 0.0
        return b + depth, depth, speed

    def update_maxima(self, maps, wet: float) -> None:
        """Raise the hazard maxima and arrival times of ``maps`` (arrays on the DEM grid) at time t from
        the SPH depth at the cell centres, d(x) = Σ_j V_j W(|x − x_j|, H_j), cut where the ground stands
        above the water, and the Shepard mean speed with the same weights (the formulas:
        :func:`erosim.sph.kernels_swe.grid_maxima`; here summed particle by particle,
        :func:`~erosim.sph.kernels_swe.scatter_sums`); the wall cells are never marked.

        The interpolant, not each particle's own depth d_i: d_i cannot fall below about
        V_i·7/(π H_max²) (one particle alone in its support), so cells under the particles' squares
        would never record water shallower than that, and a flood's edge would be a step of about a
        metre; the interpolant thins to zero over the supports at the water's edge, as the water does.
        """
        if self.n == 0:
            return
        sums, r_lo, c_lo = self._map_sums()
        K.raise_maxima(
            sums, r_lo, c_lo, self.bed, self.t, wet, maps.max_depth, maps.max_speed, maps.max_dv, maps.arrival,
            self.wall, K.MARGIN_SPEED[self.params.margin_speed],
        )  # fmt: skip

    def _maxima_window(self, xmin, ymin, xmax, ymax, hmax) -> tuple:
        """The bins of the map's gather (edge ≥ every support H, origin one edge below the particles'
        least corner, as the neighbour search's) and the window of cells within reach:
        (x0, y0, edge, ncx, ncy, first row, first column, rows, columns)."""
        ny, nx = self.bed.shape
        reach = max(float(hmax), 1e-9)
        x0, y0 = float(xmin) - reach, float(ymin) - reach
        ncx = int((float(xmax) - x0) / reach) + 2
        ncy = int((float(ymax) - y0) / reach) + 2
        c_lo, c_hi = max(int(x0 * self.inv_cell), 0), min(int((xmax + reach) * self.inv_cell) + 1, nx - 1)
        r_lo, r_hi = max(int(y0 * self.inv_cell), 0), min(int((ymax + reach) * self.inv_cell) + 1, ny - 1)
        return x0, y0, reach, ncx, ncy, r_lo, c_lo, max(r_hi - r_lo + 1, 0), max(c_hi - c_lo + 1, 0)

    def sync_maxima(self, maps) -> None:
        """Bring the hazard maxima to ``maps``' arrays before they are read (a device solver keeps them
        on the GPU); here they are already there."""

    def stats(self) -> dict:
        return {
            "particles": self.n,
            "steps": self.steps,
            "splits": self.splits,
            "settle_steps": self.settle_steps,
            "last_dt_s": self.last_dt,
        }

    # ------------------------------------------------------------------ checkpoints

    _ARRAYS = ("pos", "vel", "vol", "hsup", "k2", "depth", "omega", "acc")
    _SCALARS = ("t", "steps", "splits", "settle_steps", "rebuilds", "last_dt", "volume_initial", "volume_out")

    def state_dict(self) -> dict:
        """Everything the next step reads; the neighbour lists by the positions and radii they were
        built from (rebuilt identically on load, so a resumed run sums in the same order)."""
        out = {k: getattr(self, k).copy() for k in self._ARRAYS}
        out.update({k: np.asarray(getattr(self, k)) for k in self._SCALARS})
        if self._built_at is not None:
            out["lists_at"] = self._built_at.copy()
            out["lists_search"] = self._search.copy()
        return out

    def load_state_dict(self, state: dict) -> None:
        for k in self._ARRAYS:
            if k == "k2" and k not in state:  # a checkpoint from before the daughters' relaxation
                self.k2 = np.full(len(state["vol"]), self.params.support**2)
                continue
            setattr(self, k, np.array(state[k], order="C"))  # a copy: the state may be read again
        for k in ("t", "last_dt", "volume_initial", "volume_out"):
            setattr(self, k, float(np.asarray(state[k])))
        for k in ("steps", "splits", "settle_steps", "rebuilds"):
            setattr(self, k, int(np.asarray(state[k])))
        self._built_at = None
        if "lists_at" in state:
            rebuilds = self.rebuilds
            self._build_lists(np.ascontiguousarray(state["lists_at"]), np.ascontiguousarray(state["lists_search"]))
            self.rebuilds = rebuilds


def wall_distance(wall: np.ndarray, cell: float) -> np.ndarray:
    """Distance (m) from each cell's centre to the nearest wall cell's centre (inf without walls): the
    hazard maps look for walls between a cell and its particles only within reach of one."""
    if not wall.any():
        return np.full(wall.shape, np.inf)
    return np.ascontiguousarray(ndimage.distance_transform_edt(~wall) * cell)


def felt_bed(bed: np.ndarray, wall: np.ndarray, open_edges: tuple, surface: float, sigma_cells: float) -> np.ndarray:
    """The bed the water feels: the DEM smoothed by a Gaussian of ``sigma_cells`` cells (the particles'
    scale, ``bed_smoothing``), then its walls and closed edges raised (:func:`raised_walls`)."""
    smooth = ndimage.gaussian_filter(bed, sigma_cells, mode="nearest") if sigma_cells > 0 else bed
    return raised_walls(smooth, wall, open_edges, surface)


def raised_walls(
    bed: np.ndarray, wall: np.ndarray, open_edges: tuple[bool, bool, bool, bool], surface: float
) -> np.ndarray:
    """The bed the water feels: wall cells and the cells of closed map edges raised above the water.

    Past a wall the kernel misses neighbours, so the SPH depth falls towards it and −g∇d pushes water
    into it; the raised cell's bed slope −g∇b pushes back, so water meets a wall as it meets a shore
    and rests against it at a flat surface (the energy minimum), instead of piling up on the
    reflection. Walls stand 10 % of the water's height range (at least 1 m) above ``surface``, the
    highest water surface at the start: no water can rise above it without energy it does not have,
    and a low rise keeps the shore's slope gentle (a wall of the terrain's full relief over one cell
    would be a slope of 10 or more, a stiff spring that needs tiny steps).
    """
    out = np.array(bed, dtype=np.float64, copy=True)
    blocked = np.array(wall, dtype=bool, copy=True)
    west, east, north, south = open_edges
    if not west:
        blocked[:, 0] = True
    if not east:
        blocked[:, -1] = True
    if not north:
        blocked[0, :] = True
    if not south:
        blocked[-1, :] = True
    low = float(out[~blocked].min()) if (~blocked).any() else float(out.min())
    out[blocked] = np.maximum(out[blocked], surface + max(0.1 * (surface - low), 1.0))
    return np.ascontiguousarray(out)


def equal_volumes(points: np.ndarray, depth: np.ndarray, total: float) -> tuple[np.ndarray, np.ndarray]:
    """Particles of equal volume from lattice ``points`` with water columns ``depth``: the points kept
    with chance d/d_max by error diffusion along their order (row by row: a point is kept when the
    running sum of chances passes the next whole number), which thins a fine lattice to a number
    density ∝ depth without random clumps; the kept particles share ``total`` (m³) equally.

    Equal volumes, so that no arrangement of particles holds potential energy the water does not:
    with volumes ∝ depth the discrete system lowers its energy by sorting heavy particles into the
    deep water, and a lake never comes to rest.
    """
    depth = np.asarray(depth, np.float64)
    chance = depth / max(float(depth.max(initial=0.0)), 1e-300)
    running = np.cumsum(chance)
    kept = np.diff(np.floor(np.concatenate([[0.0], running])).astype(np.int64)) > 0
    count = int(kept.sum())
    if count == 0:
        return np.zeros((0, 2)), np.zeros(0)
    return np.ascontiguousarray(points[kept]), np.full(count, float(total) / count)


def lattice_volume(depth, spacing: float, support: float, max_support: float = 2.0) -> np.ndarray:
    """Volumes V = κ·d·s² that give SPH depth d on a square lattice of spacing s.

    κ = 1/(s² Σ_lattice W(r, H)) with H = k√(V/(d + δ)), δ = V/(max_support·s)² (the solver's smooth
    bound, with s the solver's spacing): the inverse of the lattice's own kernel sum (a few per cent
    from 1), found by fixed-point iteration on the unit lattice (scale-free: κ depends on the two
    factors only), so water laid on the lattice starts at its true depth.
    """
    reach = int(math.ceil(2 * support)) + 1
    g = np.arange(-reach, reach + 1, dtype=np.float64)
    r = np.hypot(*np.meshgrid(g, g)).ravel()
    kappa = 1.0
    for _ in range(200):
        h = support * math.sqrt(kappa / (1.0 + kappa / max_support**2))  # V = κ, d = 1 on the unit lattice
        s = np.clip(r / h, 0.0, 1.0)
        total = float((7.0 / (math.pi * h * h) * (1 - s) ** 4 * (1 + 4 * s)).sum())
        new = 1.0 / total
        if abs(new - kappa) < 1e-15:
            break
        kappa = new
    return np.asarray(depth, np.float64) * spacing * spacing * kappa
