"""Manning's bed friction, the one law both flood solvers and the device path apply.

The shallow-water equations carry the bed's shear stress τ_b = ρ g n² |u| u / d^{1/3} as the
deceleration −g n² |u| u / d^{4/3} of the depth-averaged velocity u (Manning's law, e.g. Chow 1959,
*Open-Channel Hydraulics*, ch. 5). Taken semi-implicitly over a step Δt,

    u ← u* / D,   D = 1 + Δt g n² |u*| / d^{4/3},

with u* the velocity before friction: D ≥ 1 only divides, so friction can stop water but never
reverse it, however thin. :func:`manning_divisor` is D for one particle or column; the
shallow-water SPH kick (:func:`erosim.sph.kernels_swe.kick_particle`, also inlined into the GPU
kernels) and the 3-D solver's columns (:class:`erosim.sph.manning_columns.ManningColumns`) both call
it, the columns its Python source on NumPy arrays (``manning_divisor.py_func``: one expression for
every column at once, evaluated as before this function was shared, so their results are unchanged
bit for bit; NumPy's vectorised pow and the compiled one differ in the last bit for some depths).
"""

from __future__ import annotations

from numba import njit


@njit(inline="always")
def manning_divisor(n, speed, depth, dt, g):
    """D = 1 + Δt g n² |u| / d^{4/3} (module docstring); ``depth`` must be > 0 (floor it first).
    Scalars when compiled; its ``py_func`` takes NumPy arrays as well."""
    return 1.0 + dt * g * n * n * speed / depth ** (4.0 / 3.0)
