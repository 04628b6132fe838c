"""Tiled builds: a DEM too large for one run eroded tile by tile on Dask and mosaicked (docs/tiles.md)."""
