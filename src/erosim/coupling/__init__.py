"""Fluid ↔ terrain coupling: particles → raster fields, raster → particles, and the eroder contract.

* :mod:`~erosim.coupling.raster` — the node raster shared by fluid and terrain (SPH frame);
* :mod:`~erosim.coupling.binning` — :class:`FluidGrid`: per-node count, depth, mean velocity, speed
  and their running maxima, binned from the solver's internal arrays;
* :mod:`~erosim.coupling.sampling` — Q4 (SPEC HM-2) values of a raster at particle positions;
* :mod:`~erosim.core.increments` — :class:`Increment` (what an erosion model returns), the budget
  check, and :class:`IncrementView` for models that change their terrain in place;
* :mod:`~erosim.coupling.coupler` — :class:`Coupler`: every N steps bins the fluid, asks the eroder
  for increments, applies them once, checks the budget and refreshes the boundaries.
"""
