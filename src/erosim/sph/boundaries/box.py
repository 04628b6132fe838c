"""Box walls and box obstacles by velocity reflection (SPEC SPH-11, seed 000).

After every drift a particle found outside the domain box [lo, hi] is mirrored back inside across
the wall it crossed (then clamped onto the box, so it can never be outside) and the velocity
component normal to that wall is reversed if it points outwards. A particle found inside an
axis-aligned obstacle box is moved onto the obstacle's nearest face and its normal velocity
component reversed likewise. This is the last line of defence: with ``walls = "particles"`` the
boundary particles' pressure normally keeps fluid away from walls before it reaches them.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from erosim.sph.boundaries.base import Boundary


@njit(inline="always", cache=True)
def enforce(pos, vel, i, lo, hi, olo, ohi):
    """Keep particle ``i`` inside [lo, hi] and outside every obstacle box (olo[k], ohi[k])."""
    d = pos.shape[1]
    for a in range(d):
        x = pos[i, a]
        if x < lo[a]:
            x = min(2.0 * lo[a] - x, hi[a])
            if vel[i, a] < 0.0:
                vel[i, a] = -vel[i, a]
        elif x > hi[a]:
            x = max(2.0 * hi[a] - x, lo[a])
            if vel[i, a] > 0.0:
                vel[i, a] = -vel[i, a]
        pos[i, a] = x
    for k in range(olo.shape[0]):
        inside = True
        for a in range(d):
            if pos[i, a] <= olo[k, a] or pos[i, a] >= ohi[k, a]:
                inside = False
                break
        if not inside:
            continue
        best = 1e300
        ba = 0
        side = 0
        for a in range(d):
            dl = pos[i, a] - olo[k, a]
            dh = ohi[k, a] - pos[i, a]
            if dl < best:
                best = dl
                ba = a
                side = -1
            if dh < best:
                best = dh
                ba = a
                side = 1
        if side < 0:
            pos[i, ba] = olo[k, ba]
            if vel[i, ba] > 0.0:
                vel[i, ba] = -vel[i, ba]
        else:
            pos[i, ba] = ohi[k, ba]
            if vel[i, ba] < 0.0:
                vel[i, ba] = -vel[i, ba]


@njit(parallel=True, cache=True)
def reflect(pos, vel, n_fluid, lo, hi, olo, ohi):
    """:func:`enforce` for every fluid particle."""
    for i in prange(n_fluid):
        enforce(pos, vel, i, lo, hi, olo, ohi)


class BoxWalls(Boundary):
    """The domain box [lo, hi] and axis-aligned obstacle boxes, kept by reflection after each drift."""

    name = "box"

    def __init__(self, lo, hi, obstacles_lo=None, obstacles_hi=None):
        self.lo = np.asarray(lo, np.float64)
        d = self.lo.size
        self.hi = np.asarray(hi, np.float64).reshape(d)
        self.olo = np.asarray(obstacles_lo if obstacles_lo is not None else np.zeros((0, d)), np.float64).reshape(-1, d)
        self.ohi = np.asarray(obstacles_hi if obstacles_hi is not None else np.zeros((0, d)), np.float64).reshape(-1, d)

    def bind(self, solver) -> None:
        dt = solver.dtype
        self._lo, self._hi = self.lo.astype(dt), self.hi.astype(dt)
        self._olo, self._ohi = self.olo.astype(dt), self.ohi.astype(dt)

    def constrain(self, solver) -> None:
        st = solver.state
        reflect(st.pos, st.vel, st.n_fluid, self._lo, self._hi, self._olo, self._ohi)
