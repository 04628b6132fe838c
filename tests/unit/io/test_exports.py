"""erosim export: meshes load back with trimesh on the heightmap, EXR/RAW32 round-trip exactly, splat
weights sum to one, tiles cover the map with their overlap, bad input is one sentence."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from erosim.cli import cli
from erosim.core.errors import InputError
from erosim.io import exports, heightmaps
from erosim.io.results import open_run
from erosim.view.export import export_run

trimesh = pytest.importorskip("trimesh")


@pytest.fixture
def run(tmp_path, make_run):
    z, maps = make_run(tmp_path / "run")
    return tmp_path / "run", z, maps


@pytest.mark.parametrize("fmt", ["glb", "gltf", "obj"])
def test_mesh_loads_back_on_the_heightmap(run, tmp_path, fmt):
    folder, z, _ = run
    export_run(folder, tmp_path / "out", [fmt])
    mesh = trimesh.load(tmp_path / "out" / f"terrain.{fmt}", force="mesh")
    ny, nx = z.shape
    assert len(mesh.vertices) == ny * nx and len(mesh.faces) == 2 * (ny - 1) * (nx - 1)
    assert mesh.visual.kind == "texture"
    v = np.asarray(mesh.vertices)
    col = np.rint(v[:, 0] / 2.5).astype(int)
    row = np.rint(v[:, 2] / 2.5).astype(int)
    # every vertex sits within half a cell of a grid node, at that node's height
    assert np.abs(v[:, 0] - col * 2.5).max() < 1.25 and np.abs(v[:, 2] - row * 2.5).max() < 1.25
    assert sorted(set(zip(row.tolist(), col.tolist(), strict=True))) == [(i, j) for i in range(ny) for j in range(nx)]
    np.testing.assert_allclose(v[:, 1], z[row, col], atol=1e-4)
    assert (mesh.face_normals[:, 1] > 0).all()  # faces look up


def test_exr_and_raw32_round_trip_exactly(run, tmp_path):
    folder, z, _ = run
    s = export_run(folder, tmp_path / "out", ["exr", "raw32", "png16"])
    back = exports.read_exr(tmp_path / "out" / "height.exr")
    assert back.dtype == np.float32 and np.array_equal(back, z.astype(np.float32))
    raw = exports.read_raw32(tmp_path / "out" / "height.raw32", tuple(s["shape"]))
    assert np.array_equal(raw, z.astype(np.float32))
    png = heightmaps.read(tmp_path / "out" / "height.png").z
    step = (z.max() - z.min()) / 65535
    assert np.abs(png - z).max() <= step / 2 + 1e-6


def test_exr_of_random_floats_is_exact(tmp_path):
    a = np.random.default_rng(3).normal(0, 1e4, (17, 9)).astype(np.float32)
    exports.write_exr(tmp_path / "a.exr", a)
    assert np.array_equal(exports.read_exr(tmp_path / "a.exr"), a)


def test_splat_weights_sum_to_one(run, tmp_path):
    folder, z, maps = run
    w = exports.splat_weights(
        z, 2.5, water=maps["lake_depth"], stream=maps["stream"], deposition=maps["deposition"],
        vegetation=maps["vegetation"],
    )  # fmt: skip
    assert w.shape == z.shape + (4,) and (w >= 0).all()
    np.testing.assert_allclose(w.sum(axis=-1), 1.0, atol=1e-12)
    assert (w[..., 3][maps["lake_depth"] >= exports.WATER_DEPTH_REF] == 1).all()  # deep lakes are all water
    export_run(folder, tmp_path / "out", ["splat"])
    from PIL import Image

    img = np.asarray(Image.open(tmp_path / "out" / "splat.png"))
    assert img.shape == z.shape + (4,)
    assert (img.astype(int).sum(axis=-1) == 255).all()
    assert np.abs(img / 255.0 - w).max() <= 1.5 / 255


def test_splat_bytes_largest_remainder():
    b = exports.splat_bytes(np.array([[[1 / 3, 1 / 3, 1 / 3, 0.0], [0, 0, 0, 0], [0.5, 0.5, 0, 0]]]))
    assert b.astype(int).sum(axis=-1).tolist() == [[255, 255, 255]]
    assert b[0, 1].tolist() == [0, 255, 0, 0]  # no weight at all: grass


@pytest.mark.parametrize("n, tile, overlap", [(31, 8, 1), (24, 8, 0), (24, 10, 3), (5, 8, 1), (100, 33, 1)])
def test_tiles_cover_the_map_with_the_overlap(n, tile, overlap):
    wins = exports.tile_windows(n, n, tile, overlap)
    rows = sorted({(w[2].start, w[2].stop) for w in wins})
    assert rows[0][0] == 0 and rows[-1][1] == n
    assert all(b - a <= tile for a, b in rows)
    for (_, b0), (a1, _) in zip(rows[:-1], rows[1:], strict=True):
        assert b0 - a1 == overlap  # neighbours share exactly `overlap` rows
    covered = np.zeros((n, n), int)
    for _, _, r, c in wins:
        covered[r, c] += 1
    assert (covered >= 1).all()


def test_tiled_export_joins(run, tmp_path):
    folder, z, _ = run
    s = export_run(folder, tmp_path / "out", ["exr", "glb", "png16", "raw16", "splat"], tile=10, overlap=1)
    assert len(s["tiles"]) == 3 * 4  # 24 rows: 0-10, 9-19, 18-24; 31 cols: 0-10, 9-19, 18-28, 27-31
    parts = np.full(z.shape, np.nan, np.float32)
    for t in s["tiles"]:
        sub = exports.read_exr(tmp_path / "out" / f"tile_r{t['row']:02d}_c{t['col']:02d}" / "height.exr")
        (r0, r1), (c0, c1) = t["rows"], t["cols"]
        prev = parts[r0:r1, c0:c1]
        assert np.array_equal(prev[~np.isnan(prev)], sub[~np.isnan(prev)])  # overlaps agree
        parts[r0:r1, c0:c1] = sub
    assert np.array_equal(parts, z.astype(np.float32))
    assert json.loads((tmp_path / "out" / "export.json").read_text())["overlap"] == 1
    # a tile's 16-bit map sits where the tile is: rows 9.., columns 18.. of the map
    t = heightmaps.read(tmp_path / "out" / "tile_r01_c02" / "height.png")
    assert t.transform[2] == pytest.approx(1000.0 + 18 * 2.5) and t.transform[5] == pytest.approx(5000.0 - 9 * 2.5)
    assert np.abs(t.z - z[9:19, 18:28]).max() <= (z.max() - z.min()) / 65535


def test_flood_run_opens_with_its_layers(tmp_path, make_run):
    hazard = np.zeros((24, 31), np.uint8)
    hazard[5:9, 3:20] = 4
    make_run(tmp_path / "flood", kind="flood", extra={"max_speed": np.full((24, 31), 2.0), "hazard": hazard})
    run = open_run(tmp_path / "flood")
    names = {layer.key: name for layer, name in run.layers()}
    assert run.kind == "flood" and names["hazard"] == "hazard" and names["speed"] == "max_speed"
    s = export_run(tmp_path / "flood", tmp_path / "out", ["splat"])
    assert s["kind"] == "flood"


@pytest.mark.parametrize(
    "args, words",
    [
        (["export", "{tmp}/nothing", "--to", "{tmp}/o"], "does not exist"),
        (["export", "{tmp}", "--to", "{tmp}/o"], "not a run folder"),
        (["export", "{tmp}/odd", "--to", "{tmp}/o"], "unknown kind 'weather'"),
        (["export", "{tmp}/sph", "--to", "{tmp}/o"], "holds no maps/height.tif"),
        (["export", "{tmp}/run", "--to", "{tmp}/o", "--tile", "4", "--overlap", "4"], "--overlap 4"),
        (["export", "{tmp}/run", "--to", "{tmp}/o", "--tile", "1"], "--tile 1 is too small"),
        (["export", "{tmp}/run", "--to", "{tmp}/o", "--tile", "0"], "--tile 0 is too small"),
    ],
)
def test_bad_input_is_one_sentence(tmp_path, make_run, args, words):
    make_run(tmp_path / "run")
    (tmp_path / "odd").mkdir()
    (tmp_path / "odd" / "report.json").write_text('{"kind": "weather"}')
    (tmp_path / "sph").mkdir()
    (tmp_path / "sph" / "report.json").write_text('{"kind": "sph"}')
    res = CliRunner().invoke(cli, [a.format(tmp=tmp_path) for a in args])
    assert res.exit_code != 0
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("erosim: error:") and words in lines[0], res.output
    assert "Traceback" not in res.output


def test_unknown_format_is_refused(tmp_path, make_run):
    make_run(tmp_path / "run")
    with pytest.raises(InputError, match="Unknown export format 'fbx'"):
        export_run(tmp_path / "run", tmp_path / "o", ["fbx"])
    for opt, word in (("--format", "fbx"), ("--texture", "marble")):
        res = CliRunner().invoke(cli, ["export", str(tmp_path / "run"), "--to", str(tmp_path / "o"), opt, word])
        lines = res.output.strip().splitlines()
        assert res.exit_code != 0 and len(lines) == 1 and "Unknown" in lines[0] and word in lines[0], res.output
    assert not (tmp_path / "o").exists()
