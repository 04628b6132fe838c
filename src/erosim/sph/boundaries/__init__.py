"""Boundary handling: box walls and obstacles by reflection (``box``), fixed boundary particles (``particles``)."""
