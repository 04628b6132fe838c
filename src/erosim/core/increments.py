"""What an erosion model hands back, and the check that it conserves sediment.

An erosion model does not change the terrain itself: it returns an :class:`Increment` — the height
change Δz of every node and where the moved material went — and its caller applies it once
(DESIGN.md "Contracts"; the pattern of fastscape's processes returning increments that one process
applies). The budget every increment must close, in m³:

    Σ_k Δz_k A  +  ΔS  +  C  =  0

with A the node's area, ΔS the change of the sediment held in the water (suspended, or carried by
particles) and C the sediment that left the domain. :func:`check_budget` refuses an increment that
breaks it by more than ``rtol`` of the volume moved (default 1e-9: float64 sums over millions of
nodes stay orders of magnitude below it).

Models that change their terrain in place (the droplet hydrology, the particle stream) are seen
through an :class:`IncrementView`: Δz since the last look.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from erosim.core.errors import BudgetError


@dataclass
class Increment:
    """Δz (m) per node, the change of sediment held in the water ΔS (m³), sediment carried off C (m³), and
    ``particles``: the new values of per-particle fields of the fluid (name → the first n fluid
    particles' values, in the state's order; the sediment each carries), which the caller writes with Δz;
    ``terrain_fields``: the new values of the terrain's own fields (a porous ground's moisture), which
    the terrain writes; ``removed``: the fluid particles to remove (a mask over the first n), counted
    under ``sink`` (water spent into the ground)."""

    dz: np.ndarray
    suspended: float = 0.0
    carried_off: float = 0.0
    particles: dict[str, np.ndarray] = field(default_factory=dict)
    terrain_fields: dict[str, np.ndarray] = field(default_factory=dict)
    removed: np.ndarray | None = None
    sink: str = "removed"


def check_budget(inc: Increment, shape: tuple[int, ...], cell_area: float, who: str, rtol: float = 1e-9) -> dict:
    """Refuse (one clear sentence) an increment of the wrong shape, with NaN, or breaking the budget.

    Returns the increment's terms: eroded and deposited volumes (m³, ≥ 0), ΔS, C and the imbalance.
    """
    dz = np.asarray(inc.dz)
    if dz.shape != tuple(shape):
        raise BudgetError(f"{who} returned a height change of shape {dz.shape} for a terrain of shape {tuple(shape)}.")
    if not np.all(np.isfinite(dz)) or not (np.isfinite(inc.suspended) and np.isfinite(inc.carried_off)):
        raise BudgetError(f"{who} returned NaN or infinite increments; its inputs or parameters are out of range.")
    eroded = float(-dz[dz < 0].sum() * cell_area)
    deposited = float(dz[dz > 0].sum() * cell_area)
    imbalance = deposited - eroded + float(inc.suspended) + float(inc.carried_off)
    scale = max(eroded, deposited, abs(inc.suspended), abs(inc.carried_off))
    if abs(imbalance) > rtol * scale + 1e-300:
        raise BudgetError(
            f"{who} breaks the sediment budget: the terrain changes by {deposited - eroded:.6g} m³, the water "
            f"takes {inc.suspended:.6g} m³ and {inc.carried_off:.6g} m³ leaves, an imbalance of {imbalance:.3g} m³ "
            f"({abs(imbalance) / max(scale, 1e-300):.2g} of the volume moved; at most {rtol:g}); its increments "
            "must account for every volume they move."
        )
    return {
        "eroded": eroded,
        "deposited": deposited,
        "suspended": float(inc.suspended),
        "carried_off": float(inc.carried_off),
        "imbalance": imbalance,
    }


class IncrementView:
    """Δz of a terrain array ``z`` that its model changes in place: the change since the last :meth:`take`."""

    def __init__(self, z: np.ndarray):
        self.z = z
        self.mark = np.array(z, dtype=np.float64, copy=True)

    def take(self) -> np.ndarray:
        dz = self.z - self.mark
        self.mark[...] = self.z
        return dz
