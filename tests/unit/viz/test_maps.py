"""Map pictures: hillshade physics, the hydrology map's colours, PNG and GIF files."""

import math

import numpy as np
import pytest
from PIL import Image

from erosim.core.errors import InputError
from erosim.terrain.generate import generate
from erosim.viz import maps
from erosim.viz.animate import save_animation


def test_hillshade_in_range_and_flat_ground_is_sin_altitude():
    hm = generate("mountains", 64, 10.0, seed=1)
    hs = maps.hillshade(hm.z, hm.cell_size)
    assert hs.shape == hm.shape and hs.min() >= 0.0 and hs.max() <= 1.0 and hs.std() > 0
    flat = maps.hillshade(np.zeros((8, 8)), 1.0, altitude=30.0)
    np.testing.assert_allclose(flat, math.sin(math.radians(30.0)), atol=1e-12)


def test_hillshade_lights_the_slope_facing_the_sun():
    # A plane rising to the east (z = x): its normal leans west, so light from the west (270°)
    # is brighter than light from the east (90°); n·L = (sin h + cos h)/√2 for a 45° slope.
    iy, ix = np.mgrid[0:8, 0:8].astype(float)
    z = ix * 1.0
    west = maps.hillshade(z, 1.0, azimuth=270.0, altitude=45.0)
    east = maps.hillshade(z, 1.0, azimuth=90.0, altitude=45.0)
    h = math.radians(45.0)
    np.testing.assert_allclose(west, (math.sin(h) + math.cos(h)) / math.sqrt(2), atol=1e-12)
    np.testing.assert_allclose(east, (math.sin(h) - math.cos(h)) / math.sqrt(2), atol=1e-12)
    # Rows run southward: z rising with the row index faces north, lit from the north (0°).
    north = maps.hillshade(iy * 1.0, 1.0, azimuth=0.0, altitude=45.0)
    assert north.mean() > maps.hillshade(iy * 1.0, 1.0, azimuth=180.0, altitude=45.0).mean()


def test_hydrology_map_colours_streams_and_lakes():
    z = np.zeros((40, 40))
    stream = np.zeros_like(z)
    stream[5:8, :] = 1.0
    lake = np.zeros_like(z)
    lake[20:30, 20:30] = 2.0
    rgb = maps.hydrology_map(z, 1.0, stream, lake)
    assert rgb.shape == (40, 40, 3) and rgb.min() >= 0 and rgb.max() <= 1
    ground, river, pool = rgb[35, 5], rgb[6, 5], rgb[25, 25]
    assert river[2] > river[0] and river[2] > ground[2]  # light blue: blue dominates, brighter
    assert pool[2] > pool[0] and pool.sum() < river.sum()  # dark blue: darker than the streams


def test_ease_out_keeps_order_and_range():
    x = np.linspace(-0.5, 1.5, 41)
    y = maps.ease_out(x)
    assert y.min() == 0 and y.max() == 1 and np.all(np.diff(y) >= 0)
    assert maps.ease_out(np.array([0.25]))[0] > 0.25  # weak flows are lifted


def test_png_and_colormap_files(tmp_path):
    hm = generate("hills", 32, 10.0, seed=2)
    maps.save_png(tmp_path / "hs.png", maps.hillshade(hm.z, hm.cell_size))
    maps.colormap_png(tmp_path / "c.png", hm.z - hm.z.mean(), "RdBu", symmetric=True)
    maps.save_png(tmp_path / "r.png", maps.shaded_relief(hm.z, hm.cell_size))
    for name, mode in [("hs.png", "L"), ("c.png", "RGB"), ("r.png", "RGB")]:
        with Image.open(tmp_path / name) as img:
            assert img.size == (32, 32) and img.mode == mode


def test_gif_animation(tmp_path):
    frames = [np.full((16, 20), v) for v in (0.0, 0.5, 1.0)]
    save_animation(tmp_path / "a.gif", frames, fps=5)
    with Image.open(tmp_path / "a.gif") as img:
        assert img.n_frames == 3 and img.size == (20, 16)
    with pytest.raises(InputError, match="no frames"):
        save_animation(tmp_path / "b.gif", [], fps=5)
    with pytest.raises(InputError, match=".gif or .mp4"):
        save_animation(tmp_path / "b.avi", frames, fps=5)


def test_lakes_are_shaded_flat_on_their_water_surface():
    # Bed rising eastward, lake up to level 10: the water surface z + d is flat, so every lake
    # pixel away from the shore gets the same colour.
    iy, ix = np.mgrid[0:20, 0:30].astype(float)
    z = ix.copy()
    depth = np.clip(10.0 - z, 0.0, None)
    rgb = maps.hydrology_map(z, 1.0, np.zeros_like(z), depth, lake_depth_ref=1.0)
    inner = rgb[2:-2, 2:8]  # depth >= 2 there: full lake opacity, no shore pixels
    assert np.ptp(inner.reshape(-1, 3), axis=0).max() < 1e-12


def test_map_figures_carry_axes_scale_and_legend(tmp_path):
    """A map figure is a figure, not the raw raster: axes in the DEM's coordinates, and the pixels of
    the legend's swatch colours and of the scale bar's black and white are there."""
    from PIL import Image

    from erosim.viz.maps import DARK_BLUE
    from erosim.viz.plots import change_figure, extent_of, map_figure

    assert extent_of(None, (10, 20), 5.0) == (0.0, 100.0, 0.0, 50.0)
    assert extent_of((5.0, 0.0, 400000.0, 0.0, -5.0, 5100000.0), (10, 20), 5.0) == (400000.0, 400100.0, 5099950.0,
                                                                                   5100000.0)  # fmt: skip
    rgb = np.full((64, 96, 3), 0.8)
    path = map_figure(tmp_path / "m.png", rgb, 20.0, "test", legend=[("lake", DARK_BLUE)])
    img = np.asarray(Image.open(path).convert("RGB"))
    assert img.shape[:2] != (64, 96)
    blue = np.round(DARK_BLUE * 255).astype(int)
    assert (np.abs(img.astype(int) - blue).sum(axis=2) < 12).sum() > 20  # the legend's swatch
    assert (img.sum(axis=2) == 0).sum() > 20  # the scale bar's black half
    change = np.linspace(-3, 5, 64 * 96).reshape(64, 96)
    assert change_figure(tmp_path / "c.png", change, 20.0, "change").stat().st_size > 5000


def test_profiles_over_many_times_carry_a_colour_bar_of_time_and_few_a_legend(monkeypatch, tmp_path):
    """A run's profiles every 20 s over 600 s are 31 lines: a legend of 31 times took the figure over, so they
    get a colour bar of t spanning the run; a handful keep their legend."""
    from erosim.viz import plots

    figs = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: figs.append(fig) or path)
    x = np.linspace(0.0, 1.0, 11)
    many = [(float(t), x, 0.2 - 1e-4 * t * x) for t in range(0, 620, 20)]
    plots.profiles_figure(tmp_path / "many.png", many, title="many")
    plots.profiles_figure(tmp_path / "few.png", many[:3], title="few")
    fig_many, fig_few = figs
    ax, bar = fig_many.axes
    assert ax.get_legend() is None and bar.get_ylabel() == "t (s)"
    assert bar.get_ylim() == pytest.approx((0.0, 600.0))
    assert len(fig_few.axes) == 1 and len(fig_few.axes[0].get_legend().get_texts()) == 3
