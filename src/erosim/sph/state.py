"""Particle state: structure-of-arrays fields with room to grow, particle sources and sinks, the budget.

One index space holds the fluid particles ``0 … n_fluid−1`` followed by the fixed boundary particles
``n_fluid … n−1`` (SPEC SPH-12). Every field lives in a store with spare rows (the capacity), and the
solver works on views of the active rows, so particles can be added (rain, inflow) and removed
(outflow, absorption) between steps without reallocating each time: adding moves the boundary block
up to make room, removing compacts the fluid rows in their order and moves the boundary block down.

Fields
------
* scope ``"all"`` (one row per particle): ``pos`` (n, d), ``vel`` (n, d), ``rho``, ``p``, ``drho``,
  ``rho_old`` (n,);
* scope ``"fluid"`` (one row per fluid particle): ``acc`` (n_f, d), ``ref`` (n_f, d: positions at the
  last neighbour-list build), ``ids`` (n_f,: a label that follows a particle through every reorder);
* extra fields that models register with :meth:`ParticleState.register` (sediment load, saturation,
  concentration), of either scope, reordered, added and removed with the rest.

Budget: every particle has the mass m, so the fluid's mass is m·n_f at all times and
initial + added − removed = m·n_f holds exactly; added and removed particles are counted by the name of
the source or sink (:meth:`ParticleState.budget`). The pattern is PySPH's named particle arrays.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from erosim.core.errors import ConfigError

ALL = "all"
FLUID = "fluid"


class ParticleState:
    """Fluid and boundary particles' fields (see the module docstring)."""

    def __init__(self, dim: int, dtype, n_fluid: int, n_boundary: int, *, capacity: int | None = None):
        self.dim = int(dim)
        self.dtype = np.dtype(dtype)
        self.n_fluid = int(n_fluid)
        self.n_boundary = int(n_boundary)
        n = self.n
        self.capacity = max(n, int(capacity) if capacity is not None else n)
        self.fluid_capacity = max(self.n_fluid, self.capacity - self.n_boundary)
        self.specs: dict[str, tuple[str, tuple[int, ...], np.dtype, float]] = {}
        self._store: dict[str, np.ndarray] = {}
        d, f = self.dim, self.dtype
        for name, shape in (("pos", (d,)), ("vel", (d,)), ("rho", ()), ("p", ()), ("drho", ()), ("rho_old", ())):
            self._add_field(name, ALL, shape, f, 0.0)
        self._add_field("acc", FLUID, (d,), f, 0.0)
        self._add_field("ref", FLUID, (d,), f, 0.0)
        self._add_field("ids", FLUID, (), np.dtype(np.int64), 0)
        self._own = tuple(self.specs)
        self.ids[:] = np.arange(self.n_fluid)
        self.next_id = self.n_fluid
        self.initial = self.n_fluid
        self.added: dict[str, int] = {}
        self.removed: dict[str, int] = {}
        self.removed_sums: dict[str, float] = {}  # registered float fields summed over removed particles

    # ------------------------------------------------------------------ fields
    @property
    def n(self) -> int:
        return self.n_fluid + self.n_boundary

    def _rows(self, scope: str) -> int:
        return self.n if scope == ALL else self.n_fluid

    def _cap(self, scope: str) -> int:
        return self.capacity if scope == ALL else self.fluid_capacity

    def _add_field(self, name: str, scope: str, shape: tuple[int, ...], dtype, fill) -> None:
        self.specs[name] = (scope, tuple(shape), np.dtype(dtype), fill)
        self._store[name] = np.full((self._cap(scope),) + tuple(shape), fill, dtype=dtype)
        setattr(self, name, self._store[name][: self._rows(scope)])

    def register(self, name: str, *, scope: str = FLUID, shape: tuple[int, ...] = (), dtype=np.float64, fill=0.0):
        """Add a per-particle field (for a coupled model: sediment, saturation, ...); returns its view."""
        if scope not in (ALL, FLUID):
            raise ValueError(f"scope must be '{ALL}' or '{FLUID}', got {scope!r}")
        if name in self.specs or hasattr(type(self), name):
            raise ConfigError(f"A particle field named '{name}' exists already; register each field once.")
        self._add_field(name, scope, shape, dtype, fill)
        return getattr(self, name)

    @property
    def extras(self) -> list[str]:
        """Names of the registered fields beyond the solver's own."""
        return [name for name in self.specs if name not in self._own]

    def _views(self) -> None:
        for name, (scope, _, _, _) in self.specs.items():
            setattr(self, name, self._store[name][: self._rows(scope)])

    def _grow(self, n_fluid: int, n_boundary: int) -> None:
        """Make room for ``n_fluid`` + ``n_boundary`` rows (stores ×1.5 when they must grow)."""
        need_f = n_fluid
        need_all = n_fluid + n_boundary
        if need_f <= self.fluid_capacity and need_all <= self.capacity:
            return
        new_all = max(need_all, int(1.5 * self.capacity) + 16)
        new_f = max(need_f, new_all - n_boundary)
        for name, (scope, shape, dtype, fill) in self.specs.items():
            old = self._store[name]
            store = np.full(((new_all if scope == ALL else new_f),) + shape, fill, dtype=dtype)
            k = self._rows(scope)
            store[:k] = old[:k]
            self._store[name] = store
        self.capacity, self.fluid_capacity = new_all, new_f

    def _move_boundary(self, new_n_fluid: int) -> None:
        """Shift the boundary rows of every all-particle field so they start at ``new_n_fluid``."""
        nf, nb = self.n_fluid, self.n_boundary
        if new_n_fluid == nf or nb == 0:
            return
        for name, (scope, _, _, _) in self.specs.items():
            if scope == ALL:
                s = self._store[name]
                s[new_n_fluid : new_n_fluid + nb] = s[nf : nf + nb].copy()

    # ------------------------------------------------------------------ sources and sinks
    def add_fluid(self, pos, vel, *, rho: float, source: str, **fields) -> slice:
        """Append fluid particles (rows ``n_fluid … n_fluid + k − 1`` afterwards); returns their slice.

        ``rho`` is their density; other fields start at their fill value unless given in ``fields``
        (arrays of k rows). The caller sets what depends on the physics (pressure, acceleration).
        """
        pos = np.asarray(pos, dtype=np.float64).reshape(-1, self.dim)
        k = pos.shape[0]
        vel = np.zeros_like(pos) if vel is None else np.asarray(vel, dtype=np.float64).reshape(k, self.dim)
        nf = self.n_fluid
        if k == 0:
            return slice(nf, nf)
        self._grow(nf + k, self.n_boundary)
        self._move_boundary(nf + k)
        new = slice(nf, nf + k)
        for name, (_, _, _, fill) in self.specs.items():
            self._store[name][new] = fill
        self.n_fluid = nf + k
        self._views()
        self.pos[new] = pos
        self.vel[new] = vel
        self.ref[new] = pos
        self.rho[new] = rho
        self.rho_old[new] = rho
        self.ids[new] = np.arange(self.next_id, self.next_id + k)
        self.next_id += k
        for name, values in fields.items():
            if name not in self.specs:
                raise ConfigError(f"No particle field named '{name}'; register it before adding particles with it.")
            getattr(self, name)[new] = values
        self.added[source] = self.added.get(source, 0) + k
        return new

    def remove_fluid(self, mask, *, sink: str) -> int:
        """Remove the fluid particles where ``mask`` (n_fluid,) is true; the others keep their order."""
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != (self.n_fluid,):
            raise ValueError(f"mask must have one entry per fluid particle ({self.n_fluid}), got {mask.shape}")
        k = int(mask.sum())
        if k == 0:
            return 0
        keep = np.flatnonzero(~mask)
        nf_new = keep.size
        for name in self.extras:
            if self.specs[name][2].kind == "f":
                self.removed_sums[name] = self.removed_sums.get(name, 0.0) + float(getattr(self, name)[mask].sum())
        for name in self.specs:
            s = self._store[name]
            s[:nf_new] = s[keep]
        self._move_boundary(nf_new)
        self.n_fluid = nf_new
        self._views()
        self.removed[sink] = self.removed.get(sink, 0) + k
        return k

    def set_boundary(self, pos, *, rho: float) -> None:
        """Replace the boundary particles by ``pos`` (their velocity 0, density ``rho``)."""
        pos = np.asarray(pos, dtype=np.float64).reshape(-1, self.dim)
        nb = pos.shape[0]
        self._grow(self.n_fluid, nb)
        self.n_boundary = nb
        self._views()
        b = slice(self.n_fluid, self.n)
        for name, (scope, _, _, fill) in self.specs.items():
            if scope == ALL:
                self._store[name][b] = fill
        self.pos[b] = pos
        self.rho[b] = rho
        self.rho_old[b] = rho

    def permute_fluid(self, perm: np.ndarray, skip: tuple[str, ...] = ()) -> None:
        """Reorder the fluid rows of every field (but ``skip``): new row k is old row ``perm[k]``."""
        nf = self.n_fluid
        for name in self.specs:
            if name in skip:
                continue
            arr = getattr(self, name)
            arr[:nf] = arr[:nf][perm]

    # ------------------------------------------------------------------ budget and checkpoints
    def budget(self, mass: float, rho0: float) -> dict[str, Any]:
        """Fluid mass (kg) and volume at rest (m³: mass/ρ₀): initial, added and removed by name, now."""
        added, removed = sum(self.added.values()), sum(self.removed.values())
        closure = self.initial + added - removed - self.n_fluid  # exact integers: 0 unless a count is lost
        return {
            "unit": "kg",
            "particle_mass": mass,
            "initial": self.initial * mass,
            "added": {k: v * mass for k, v in self.added.items()},
            "removed": {k: v * mass for k, v in self.removed.items()},
            "in_fluid": self.n_fluid * mass,
            "volume_m3": {"initial": self.initial * mass / rho0, "in_fluid": self.n_fluid * mass / rho0},
            "closure_rel": abs(closure) / max(self.initial + added, 1),
        }

    def state_dict(self) -> dict[str, Any]:
        """The active rows of every field and the counters (sources and sinks by name)."""
        out: dict[str, Any] = {name: getattr(self, name).copy() for name in self.specs}
        out["n_fluid"] = self.n_fluid
        out["n_boundary"] = self.n_boundary
        out["next_id"] = self.next_id
        out["initial"] = self.initial
        out["removed_sum_names"] = np.array(sorted(self.removed_sums), dtype="U64")
        out["removed_sum_values"] = np.array([self.removed_sums[k] for k in sorted(self.removed_sums)])
        for kind in ("added", "removed"):
            counts = getattr(self, kind)
            out[f"{kind}_names"] = np.array(sorted(counts), dtype="U64")
            out[f"{kind}_counts"] = np.array([counts[k] for k in sorted(counts)], dtype=np.int64)
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state_dict` (the particle counts may differ from this state's)."""
        nf, nb = int(np.asarray(state["n_fluid"])), int(np.asarray(state["n_boundary"]))
        self._grow(nf, nb)
        self.n_fluid, self.n_boundary = nf, nb
        self._views()
        for name in self.specs:
            if name in state:
                getattr(self, name)[...] = np.asarray(state[name])
        self.next_id = int(np.asarray(state["next_id"]))
        self.initial = int(np.asarray(state["initial"]))
        for kind in ("added", "removed"):
            names = [str(x) for x in np.asarray(state.get(f"{kind}_names", np.zeros(0, "U1")))]
            counts = np.asarray(state.get(f"{kind}_counts", np.zeros(0, np.int64))).tolist()
            setattr(self, kind, dict(zip(names, (int(c) for c in counts), strict=True)))
        names = [str(x) for x in np.asarray(state.get("removed_sum_names", np.zeros(0, "U1")))]
        values = np.asarray(state.get("removed_sum_values", np.zeros(0))).tolist()
        self.removed_sums = dict(zip(names, (float(v) for v in values), strict=True))
