"""Counter-based random numbers for the hydrology kernels: SplitMix64 (Steele, Lea & Flood 2014).

x ← x + 0x9E3779B97F4A7C15, then the finaliser z ← (z ⊕ z≫30)·0xBF58476D1CE4E5B9,
z ← (z ⊕ z≫27)·0x94D049BB133111EB, z ⊕ z≫31. A stream is a 64-bit key; each draw hashes the
previous state, so a droplet's or a cycle's numbers depend only on (seed, index) and never on the
order in which others ran. Numba functions because the droplet and vegetation loops draw inside
their jitted loops (NumPy's generators cannot be called there one number at a time).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def splitmix64(x):
    """SplitMix64 finaliser of x + golden gamma: a well-mixed 64-bit hash of x."""
    x = (x + np.uint64(0x9E3779B97F4A7C15)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    x = ((x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    x = ((x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    return x ^ (x >> np.uint64(31))


@njit(cache=True)
def unit(state):
    """Next uniform in [0, 1) (53 bits) and the new state."""
    state = splitmix64(state)
    return (state >> np.uint64(11)) * (1.0 / 9007199254740992.0), state


@njit(cache=True)
def spawn_base(seed):
    """The key of the droplets' spawn stream for a run seed."""
    return splitmix64(np.uint64(seed) * np.uint64(0x2545F4914F6CDD1D))


@njit(cache=True)
def spawn_point(base, i, rain_cdf, nx, ny):
    """Droplet i's spawn point (cell units): uniform over the map, or, with a rain map (its
    cumulative weights ``rain_cdf``; empty = none), a cell drawn by weight and a uniform point
    in it."""
    st = splitmix64(base ^ np.uint64(i))
    u1, st = unit(st)
    u2, st = unit(st)
    if rain_cdf.shape[0] > 0:
        u3, st = unit(st)
        cell = np.searchsorted(rain_cdf, u3 * rain_cdf[-1], side="right")
        if cell >= nx * ny:
            cell = nx * ny - 1
        return (cell % nx) + u1 - 0.5, (cell // nx) + u2 - 0.5
    return u1 * nx - 0.5, u2 * ny - 0.5
