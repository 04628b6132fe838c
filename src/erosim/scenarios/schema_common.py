"""Scenario tables shared by several kinds: ``[terrain]`` (generated or loaded heightmap).

::

    [terrain]
    source = "auto"          # auto | generate | file   (auto: file when `file` is set)
    preset = "mountains"     # hills | mountains | plateau | fbm | ridged | warped
    size = 256               # cells per side (generate)
    cell_size = 10.0         # m; for files it overrides the file's own cell size
    file = "dem.tif"         # GeoTIFF, PNG16, RAW16, ASC, NPY/NPZ, or "sample:jacksboro"
    raw_shape = [rows, cols] # RAW16 files that are not square
    height_range = [lo, hi]  # m, to scale 16-bit files
    wavelength = 3000.0      # any erosim.terrain.generate.NoiseParams field overrides the preset

``--set terrain.file=PATH`` alone switches a scenario to that DEM.
"""

from __future__ import annotations

from typing import Literal

from pydantic import model_validator

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError
from erosim.core.heightmap import Heightmap
from erosim.io.heightmaps import NO_CELL_SIZE, read
from erosim.terrain.generate import NOISE_KEYS, generate, resolve
from erosim.terrain.shapes import SHAPES, shape

#: Cell size of generated terrains when the scenario gives none (m): 512 cells span 5.12 km.
DEFAULT_CELL_SIZE = 10.0


def with_sph_defaults(data, **defaults):
    """A scenario's raw table with ``[sph]`` keys it leaves out filled from ``defaults`` (a
    ``mode="before"`` validator's body; anything not a table passes through for pydantic to refuse)."""
    if not isinstance(data, dict):
        return data
    data = dict(data)
    sph = dict(data.get("sph") or {})
    for key, value in defaults.items():
        sph.setdefault(key, value)
    data["sph"] = sph
    return data


class TerrainSection(Section):
    """Where the heightmap comes from: generated noise or a DEM file."""

    source: Literal["auto", "generate", "file"] = param(
        "auto", doc="auto (file when `file` is set, else generate) | generate | file"
    )
    preset: str = param(
        "mountains",
        doc="generated terrain: hills | mountains | plateau | fbm | ridged | warped, or a shape: flat | tilted | "
        "bowl | valley | canyon (relief and base apply)",
    )
    size: int = param(256, ge=2, le=16384, unit="cells", doc="generated terrain: cells per side")
    cell_size: float | None = param(
        None,
        gt=0,
        unit="m",
        doc=f"cell size; generated default {DEFAULT_CELL_SIZE:g} m; a DEM given with --set terrain.file keeps its "
        "own unless terrain.cell_size is set too (a scenario's value describes its generated terrain)",
    )
    seed: int | None = param(
        None, ge=0, doc="generated terrain: its own seed (none = the scenario's), e.g. to sweep seeds on one terrain"
    )
    file: str | None = param(None, doc='DEM file (.tif .png .raw .r16 .asc .npy .npz) or "sample:jacksboro"')
    raw_shape: list[int] | None = param(None, doc="[rows, cols] of a RAW16 file that is not square")
    height_range: list[float] | None = param(None, unit="m", doc="[low, high] heights of a 16-bit file's 0 and 65535")
    # Noise overrides (None: the preset's value); ranges are checked against NoiseParams.
    wavelength: float | None = param(None, unit="m", doc="wavelength of the largest features")
    relief: float | None = param(None, unit="m", doc="height scale")
    base: float | None = param(None, unit="m", doc="height of the lowest ground")
    octaves: int | None = param(None, unit="1", doc="noise octaves (0: down to two cells)")
    lacunarity: float | None = param(None, unit="1", doc="wavelength ratio between octaves")
    gain: float | None = param(None, unit="1", doc="amplitude ratio between octaves")
    exponent: float | None = param(None, unit="1", doc="height redistribution exponent")
    ridge_mix: float | None = param(None, unit="1", doc="ridged kind: share of ridged noise")
    warp_strength: float | None = param(None, unit="m", doc="domain-warp displacement")
    warp_wavelength: float | None = param(None, unit="m", doc="domain-warp wavelength")
    plateau_level: float | None = param(None, unit="1", doc="mesa step level (0 = off)")
    plateau_sharpness: float | None = param(None, unit="1", doc="mesa escarpment steepness")
    plateau_detail: float | None = param(None, unit="1", doc="raw noise kept on mesas")
    offset_x: float | None = param(None, unit="m", doc="map's west edge in the noise world")
    offset_y: float | None = param(None, unit="m", doc="map's north edge in the noise world")
    fill_slope: float | None = param(None, unit="m/m", doc="fill closed basins, falling at this slope (0 = off)")

    @property
    def uses_file(self) -> bool:
        return self.source == "file" or (self.source == "auto" and self.file is not None)

    def noise_overrides(self) -> dict:

        return {k: getattr(self, k) for k in NOISE_KEYS if k != "kind" and getattr(self, k) is not None}

    @model_validator(mode="after")
    def _check(self) -> TerrainSection:
        if self.source == "file" and not self.file:
            raise ConfigError("terrain.source is 'file' but terrain.file is not set; give --set terrain.file=PATH.")
        if self.raw_shape is not None and (len(self.raw_shape) != 2 or min(self.raw_shape) < 2):
            raise ConfigError(f"terrain.raw_shape = {self.raw_shape} is not valid; give [rows, cols], each at least 2.")
        if self.height_range is not None and (
            len(self.height_range) != 2 or not self.height_range[0] < self.height_range[1]
        ):
            raise ConfigError(
                f"terrain.height_range = {self.height_range} is not valid; give [low, high] with low < high."
            )
        if not self.uses_file and self.preset not in SHAPES:

            resolve(self.preset, self.noise_overrides(), where="terrain")  # unknown preset / bad value
        return self


def build_terrain(section: TerrainSection, seed: int) -> Heightmap:
    """The scenario's heightmap: read ``section.file`` or generate ``section.preset``."""
    if section.uses_file:

        return read(
            section.file,
            cell_size=section.cell_size,
            raw_shape=tuple(section.raw_shape) if section.raw_shape else None,
            height_range=tuple(section.height_range) if section.height_range else None,
        )
    if section.preset in SHAPES:

        return shape(
            section.preset, section.size, section.cell_size or DEFAULT_CELL_SIZE,
            relief=section.relief if section.relief is not None else 1.0,
            base=section.base if section.base is not None else 0.0,
        )  # fmt: skip

    own = section.seed if section.seed is not None else seed
    return generate(
        section.preset, section.size, section.cell_size or DEFAULT_CELL_SIZE, own, **section.noise_overrides()
    )


def _crs_name(hm: Heightmap) -> str:
    wkt = hm.crs
    if not wkt and hm.transform is None:
        return "none (positions in metres from the map's south-west corner)"
    if not wkt:
        x0, x1, y0, y1 = hm.extent
        return f"none (positions in the file's map units, from its geotransform: x {x0:g}..{x1:g}, y {y0:g}..{y1:g})"
    try:
        from rasterio.crs import CRS

        crs = CRS.from_wkt(wkt)
        code = crs.to_epsg()
        name = wkt.split('"')[1] if '"' in wkt else ""
        return f"EPSG:{code} ({name})" if code else name or "custom"
    except Exception:  # a CRS GDAL cannot parse still runs; say what it is called
        return wkt.split('"')[1] if '"' in wkt else "unreadable WKT"


def terrain_facts(hm: Heightmap, section: TerrainSection) -> tuple[dict, list[str]]:
    """What a run takes its terrain to be: report.json's ``terrain`` entries and the console's
    "assumed" lines (cell size and where it came from, height range, nodata cells, CRS)."""

    ny, nx = hm.shape
    valid = hm.z if hm.nodata is None else hm.z[~hm.nodata]
    nodata = int(hm.nodata.sum()) if hm.nodata is not None else 0
    if not section.uses_file:
        came = "generated"
    elif section.cell_size is not None:
        came = "terrain.cell_size"
    elif any(NO_CELL_SIZE in note for note in hm.notes):
        came = "assumed: the file stores none, set terrain.cell_size"
    else:
        came = "the file"
    facts = {
        "shape": [ny, nx],
        "cell_size_m": hm.cell_size,
        "cell_size_from": came,
        "crs": hm.crs,
        "nodata_cells": nodata,
        "z_min": float(valid.min()),
        "z_max": float(valid.max()),
    }
    lines = [
        f"terrain: {ny} × {nx} cells of {hm.cell_size:g} m ({came}), {nx * hm.cell_size:,.0f} m × "
        f"{ny * hm.cell_size:,.0f} m",
        f"heights: {facts['z_min']:.6g} … {facts['z_max']:.6g} m",
        f"nodata: {nodata} cells ({100 * nodata / (nx * ny):.2g} %) are outside the terrain"
        if nodata
        else "nodata: none",
        f"CRS: {_crs_name(hm)}",
    ]
    return facts, lines
