"""Flood figures (SPEC FL-4): both are written, are not blank, and the legend says what FL-3 says."""

import numpy as np
from PIL import Image

from erosim.analysis.hazard import CLASSES, HAZARD_MEANING, HazardMaps
from erosim.core.heightmap import Heightmap
from erosim.viz.flood import HAZARD_LEGEND, plot_flood_maps, plot_hazard


def _flood():
    ny, nx = 40, 60
    y, x = np.mgrid[0:ny, 0:nx]
    z = 50.0 + 0.5 * np.abs(x - 30.0) + 0.2 * y
    nodata = np.zeros((ny, nx), bool)
    nodata[:3, :3] = True
    hm = Heightmap(z=z, cell_size=10.0, transform=(10.0, 0.0, 500000.0, 0.0, -10.0, 4000400.0), nodata=nodata)
    maps = HazardMaps(hm.shape)
    for t in range(5):
        depth = np.clip(56.0 - z, 0.0, None) * (1.0 + 0.2 * t)
        maps.update(float(t), depth, (0.2 + 0.1 * t) * (1.0 + 0.1 * np.abs(x - 30.0)), valid=hm.valid)
    return hm, maps


def _not_blank(path):
    a = np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)
    assert a.shape[0] > 300 and a.shape[1] > 600
    assert a.std() > 20.0  # a blank or single-colour picture has (near) zero spread
    return a


def test_flood_maps_and_hazard_figures_are_written(tmp_path):
    hm, maps = _flood()
    classes = maps.classes()
    assert len(np.unique(classes)) >= 4  # several classes drawn, so the legend colours show
    out = plot_flood_maps(tmp_path / "figures" / "flood_maps.png", hm, maps)
    _not_blank(out)
    hz = _not_blank(plot_hazard(tmp_path / "figures" / "hazard.png", hm, classes, maps.summary(100.0)))
    h5 = np.array([int(HAZARD_LEGEND[4][1][k : k + 2], 16) for k in (1, 3, 5)], dtype=np.float64)
    assert (np.abs(hz - h5).sum(axis=2) < 60).sum() > 100  # the H5 red is on the picture (map or table)
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == ["flood_maps.png", "hazard.png"]


def test_the_legend_is_the_fl3_table():
    assert tuple(name for name, _, _ in HAZARD_LEGEND) == CLASSES
    assert {name: meaning for name, _, meaning in HAZARD_LEGEND} == HAZARD_MEANING
    assert len({colour for _, colour, _ in HAZARD_LEGEND}) == 6


def _class_pixels(picture) -> np.ndarray:
    """Pixels of each hazard class's colour (H1…H6) in a picture."""
    colours = [np.array([int(c[k : k + 2], 16) for k in (1, 3, 5)], np.float64) for _, c, _ in HAZARD_LEGEND]
    return np.array([(np.abs(picture - c).sum(axis=2) < 60).sum() for c in colours])


def test_a_dry_run_still_draws_and_maps_no_hazard(tmp_path):
    hm, wet = _flood()
    dry = HazardMaps(hm.shape)
    _not_blank(plot_flood_maps(tmp_path / "m.png", hm, dry))
    dry_pixels = _class_pixels(_not_blank(plot_hazard(tmp_path / "h.png", hm, dry.classes(), dry.summary(100.0))))
    wet_pixels = _class_pixels(_not_blank(plot_hazard(tmp_path / "w.png", hm, wet.classes(), wet.summary(100.0))))
    # dry: the class colours appear only in the legend's six equal swatches (equal within 10 %), and the
    # wet run's map adds its H5/H6 cells on top of the same swatches (more than twice as many pixels)
    assert dry_pixels.max() <= 1.1 * dry_pixels.min()
    assert (wet_pixels[4:] > 2 * dry_pixels[4:]).all()
