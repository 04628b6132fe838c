"""The voxel surface picture (erosim.viz.surface_render): Lambert shading and the PNG it writes."""

import numpy as np
from PIL import Image

from erosim.terrain.voxel import Sphere, VoxelTerrain
from erosim.viz.surface_render import lambert, surface_panels


def test_lambert_is_one_facing_the_light_and_ambient_facing_away():
    # light from the north-west (azimuth 315°) at 45°: L = (−½, ½, 1/√2)
    light = np.array([-0.5, 0.5, np.sqrt(0.5)])
    n = np.array([light, -light, [0.0, 0.0, 1.0]])
    got = lambert(n, azimuth=315.0, altitude=45.0, ambient=0.35)
    # n·L = 1, −1 (clipped to 0) and sin 45° for a level face; exact up to rounding
    assert np.allclose(got, [1.0, 0.35, 0.35 + 0.65 * np.sqrt(0.5)], atol=1e-12)


def test_surface_panels_writes_a_png_of_the_requested_size(tmp_path):
    t = VoxelTerrain.from_shapes([Sphere((0.0, 0.0, 0.0), 1.0)], (-1.5, -1.5, -1.5), (1.5, 1.5, 1.5), 0.25)
    mesh = t.surface_mesh()
    values = mesh.vertices[mesh.faces][:, :, 2].mean(axis=1)
    pts = np.array([[0.0, 0.0, 1.2], [0.5, 0.0, 1.1]])
    out = surface_panels(tmp_path / "s.png", [
        {"vertices": mesh.vertices, "faces": mesh.faces, "title": "height tint"},
        {"vertices": mesh.vertices, "faces": mesh.faces, "points": pts, "face_values": values,
         "value_label": "z (m)", "title": "values"},
    ], size=(6.0, 3.0))  # fmt: skip
    with Image.open(out) as im:
        assert im.format == "PNG"
        assert im.size == (660, 330)  # 6 × 3 inches at save_figure's 110 dpi
        px = np.asarray(im.convert("RGB"), dtype=np.float64)
    # the surface was drawn: a good share of the pixels is neither white background nor one flat colour
    assert (px.sum(axis=2) < 3 * 250).mean() > 0.05
    assert px.reshape(-1, 3).std(axis=0).min() > 5.0
