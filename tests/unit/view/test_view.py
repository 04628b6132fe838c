"""erosim view: what the page holds, the self-contained HTML (no network), the server (127.0.0.1 only,
no path traversal), runs without frames or terrain, bad input in one sentence — and the page as a
person sees it, in headless Chromium (skipped with a message where no browser is installed)."""

import http.client
import json
import os
import re
import shutil
import subprocess

import numpy as np
import pytest
from click.testing import CliRunner

from erosim.cli import cli
from erosim.io.particles import pvd_text, write_vtp
from erosim.io.results import open_run
from erosim.view import app, page


def make_sph_run(folder, frames=4, n=300, dim=2):
    folder.mkdir(parents=True)
    (folder / "particles").mkdir()
    rng = np.random.default_rng(1)
    rows = []
    for i in range(frames):
        pos = rng.random((n, dim))
        write_vtp(
            folder / "particles" / f"frame_{i:05d}.vtp", pos,
            {"velocity": rng.normal(size=(n, dim)), "pressure": rng.random(n) * 1e3, "density": 1000 + rng.random(n)},
            time=0.1 * i,
        )  # fmt: skip
        rows.append((0.1 * i, f"frame_{i:05d}.vtp"))
    (folder / "particles" / "particles.pvd").write_text(pvd_text(rows))
    (folder / "report.json").write_text(json.dumps({"kind": "sph", "dim": dim, "progress": {"unit": "s"}}))


def flood_extra(ny=24, nx=31):
    hazard = np.zeros((ny, nx), np.uint8)
    hazard[4:14, 2:25] = np.arange(1, 7).repeat(4)[:23]
    return {"max_depth": np.where(hazard > 0, 1.5, 0.0), "max_speed": hazard * 0.4, "hazard": hazard}


def test_payload_of_a_hydrology_run(tmp_path, make_run):
    z, _ = make_run(tmp_path / "run")
    p = page.payload(open_run(tmp_path / "run"))
    keys = [layer["key"] for layer in p.meta["layers"]]
    assert keys == ["water", "stream", "change", "vegetation"]
    assert np.array_equal(p.arrays["height"].reshape(z.shape), z.astype(np.float32))
    assert p.meta["frames"] == [] and p.meta["grid"]["transform"][2] == 1000.0
    assert {v["label"] for v in p.meta["values"]} >= {"height", "Erosion", "Deposition", "Water depth / lakes"}


def test_payload_of_a_flood_run_has_hazard_classes(tmp_path, make_run):
    make_run(tmp_path / "flood", kind="flood", extra=flood_extra())
    p = page.payload(open_run(tmp_path / "flood"))
    hz = next(layer for layer in p.meta["layers"] if layer["key"] == "hazard")
    assert hz["cmin"] == 0.5 and hz["cmax"] == 6.5 and len(hz["classes"]) == 6
    assert p.arrays[hz["array"]].dtype == np.uint8 and p.arrays[hz["array"]].max() == 6
    assert "speed" in [layer["key"] for layer in p.meta["layers"]]


def test_large_maps_are_read_at_a_stride(tmp_path, make_run):
    make_run(tmp_path / "run", ny=70, nx=50)
    p = page.payload(open_run(tmp_path / "run"), max_side=32)
    g = p.meta["grid"]
    assert g["step"] == 3 and (g["ny"], g["nx"]) == (24, 17) and g["cell"] == 7.5


def test_particles_are_thinned(tmp_path):
    make_sph_run(tmp_path / "sph", frames=3, n=500)
    p = page.payload(open_run(tmp_path / "sph"), max_particles=100)
    assert [f["n"] for f in p.meta["frames"]] == [100, 100, 100]
    assert p.meta["particles_dim"] == 2 and p.meta["grid"] is None
    assert p.meta["frame_fields"] == ["speed", "pressure", "density"]
    assert [f["t"] for f in p.meta["frames"]] == pytest.approx([0.0, 0.1, 0.2])


def test_html_is_self_contained(tmp_path, make_run):
    make_run(tmp_path / "run")
    info = app.write_html(tmp_path / "run", tmp_path / "v.html")
    text = (tmp_path / "v.html").read_text(encoding="utf-8")
    assert info["bytes"] > 3e6  # plotly.js is inside
    assert not re.search(r"<script[^>]+src=", text)  # no script from anywhere else
    # plotly.js (kept as text until the first picture is drawn) mentions CDNs it never uses here; the rest
    # of the page names none
    assert "cdn." not in re.sub(r'<script type="text/plain" id="plotly-code">.*?</script>', "", text, flags=re.S)
    meta = json.loads(re.search(r'id="erosim-meta">(.*?)</script>', text, re.S).group(1))
    for name in meta["arrays"]:
        assert f'id="a-{name}"' in text


@pytest.fixture
def served(tmp_path, make_run):
    make_run(tmp_path / "run")
    srv, url = app.start(tmp_path / "run", 0)
    yield srv, url
    srv.shutdown()
    srv.server_close()


def _get(srv, path):
    c = http.client.HTTPConnection(*srv.server_address[:2], timeout=10)
    c.putrequest("GET", path, skip_host=False, skip_accept_encoding=True)  # the path exactly as given
    c.endheaders()
    r = c.getresponse()
    body = r.read()
    c.close()
    return r.status, body


def test_server_binds_loopback_only(served):
    srv, url = served
    assert srv.server_address[0] == "127.0.0.1" and url.startswith("http://127.0.0.1:")
    assert _get(srv, "/")[0] == 200
    status, js = _get(srv, "/plotly.min.js")
    assert status == 200 and len(js) > 1e6
    status, body = _get(srv, "/data/height")
    assert status == 200 and len(body) == 24 * 31 * 4
    # from another address of this machine the port is closed
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.connect(("192.0.2.1", 9))  # no packet is sent: this only picks the outgoing interface
            own = s.getsockname()[0]
        except OSError:
            own = None
    if own and not own.startswith("127."):
        with pytest.raises(OSError):
            socket.create_connection((own, srv.server_address[1]), timeout=2).close()


@pytest.mark.parametrize(
    "path", ["/../etc/passwd", "/data/../../etc/passwd", "/%2e%2e/etc/passwd", "/data/%252e%252e/x", "/..%2fx"]
)
def test_server_refuses_path_traversal(served, path):
    srv, _ = served
    status, body = _get(srv, path)
    assert status == 403 and b"Refused" in body and b"root:" not in body


def test_server_serves_nothing_else(served):
    srv, _ = served
    assert _get(srv, "/etc/passwd")[0] == 404
    assert _get(srv, "/data/nothing")[0] == 404


def test_run_without_frames_or_terrain_opens(tmp_path, make_run):
    make_run(tmp_path / "hyd")
    assert page.payload(open_run(tmp_path / "hyd")).meta["frames"] == []
    make_sph_run(tmp_path / "sph", frames=0)
    p = page.payload(open_run(tmp_path / "sph"))
    assert p.meta["frames"] == [] and p.meta["grid"] is None
    res = CliRunner().invoke(cli, ["view", str(tmp_path / "sph"), "--html", str(tmp_path / "v.html")])
    assert res.exit_code == 0, res.output


@pytest.mark.parametrize(
    "target, words", [("nothing", "does not exist"), ("empty", "not a run folder"), ("odd", "unknown kind 'weather'")]
)
def test_bad_input_is_one_sentence(tmp_path, target, words):
    (tmp_path / "empty").mkdir()
    (tmp_path / "odd").mkdir()
    (tmp_path / "odd" / "report.json").write_text('{"kind": "weather"}')
    for args in (["view", str(tmp_path / target), "--html", str(tmp_path / "v.html")],
                 ["view", str(tmp_path / target), "--no-browser"]):  # fmt: skip
        res = CliRunner().invoke(cli, args)
        lines = res.output.strip().splitlines()
        assert res.exit_code != 0 and len(lines) == 1 and words in lines[0], res.output
    assert not (tmp_path / "v.html").exists()


def test_bad_port_is_one_sentence(tmp_path, make_run):
    make_run(tmp_path / "run")
    res = CliRunner().invoke(cli, ["view", str(tmp_path / "run"), "--no-browser", "--port", "70000"])
    lines = res.output.strip().splitlines()
    assert res.exit_code != 0 and len(lines) == 1 and "--port 70000 is not a port" in lines[0], res.output


def test_html_into_a_folder_is_refused(tmp_path, make_run):
    make_run(tmp_path / "run")
    res = CliRunner().invoke(cli, ["view", str(tmp_path / "run"), "--html", str(tmp_path)])
    assert res.exit_code != 0 and "is a folder" in res.output


# ------------------------------------------------------------------------------ in a real browser
def _browser():
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


def _shoot(browser, html, png, fragment="", tmp=None):
    cmd = [
        browser, "--headless", "--no-sandbox", "--disable-dev-shm-usage", "--enable-unsafe-swiftshader",
        "--use-angle=swiftshader", "--hide-scrollbars", "--window-size=1200,800", "--virtual-time-budget=20000",
        f"--user-data-dir={tmp}", f"--screenshot={png}", f"file://{html}#{fragment}",
    ]  # fmt: skip
    subprocess.run(cmd, capture_output=True, timeout=120, env={**os.environ, "HOME": str(tmp)})
    from PIL import Image

    return np.asarray(Image.open(png).convert("RGB")).astype(int)


def _waterish(img):
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return int(((b > r + 40) & (b > g + 10)).sum())


@pytest.mark.browser  # a headless Chromium (`make test-browser`)
def test_page_in_headless_chromium(tmp_path, make_run):
    browser = _browser()
    if browser is None:
        pytest.skip("no Chromium here: install Debian's chromium package (apt-get install chromium) to run this test")
    make_run(tmp_path / "flood", kind="flood", extra=flood_extra(60, 80), ny=60, nx=80)
    html = tmp_path / "v.html"
    app.write_html(tmp_path / "flood", html)
    off = _shoot(browser, html, tmp_path / "off.png", "layers=", tmp_path)
    on = _shoot(browser, html, tmp_path / "on.png", "layers=water,hazard", tmp_path)
    plot = (slice(50, 750), slice(320, 1150))  # the 3-D view, right of the side panel
    for img in (off, on):
        assert img.shape[:2] == (800, 1200)
        assert img[plot].std() > 10, "the view is blank"
        assert len(np.unique(img[plot].reshape(-1, 3) // 16, axis=0)) > 30, "the view has hardly any colours"
    # switching the layers on changes the picture, and the water is blue
    diff = np.abs(on[plot] - off[plot]).sum(axis=-1) > 30
    assert diff.mean() > 0.01, "the layers did not toggle"
    assert _waterish(on[plot]) > _waterish(off[plot]) + 500


@pytest.mark.browser  # a headless Chromium (`make test-browser`)
def test_values_under_the_cursor_in_headless_chromium(tmp_path, make_run):
    browser = _browser()
    if browser is None:
        pytest.skip("no Chromium here: install Debian's chromium package (apt-get install chromium) to run this test")
    extra = flood_extra()
    z, _ = make_run(tmp_path / "flood", kind="flood", extra=extra)
    html = tmp_path / "v.html"
    app.write_html(tmp_path / "flood", html)
    cmd = [
        browser, "--headless", "--no-sandbox", "--disable-dev-shm-usage", "--enable-unsafe-swiftshader",
        "--use-angle=swiftshader", "--window-size=1200,800", "--virtual-time-budget=20000",
        f"--user-data-dir={tmp_path}", "--dump-dom", f"file://{html}#probe=5,3",
    ]  # fmt: skip
    dom = subprocess.run(cmd, capture_output=True, timeout=120, text=True, env={**os.environ, "HOME": str(tmp_path)})
    assert 'data-probe="done"' in dom.stdout, dom.stderr[-2000:]
    cursor = re.search(r'<div id="cursor">(.*?)</div>', dom.stdout, re.S).group(1)
    assert "1008.75, 4986.25" in cursor  # the cell centre in the DEM's coordinates
    assert f"height: {float(np.float32(z[5, 3])):.4g} m" in cursor
    assert f"Hazard class: class {extra['hazard'][5, 3]}<" in cursor
    assert f"Largest speed: {extra['max_speed'][5, 3]:.4f} m/s" in cursor


def test_html_of_a_512_run_is_under_20_mb(tmp_path, make_run):
    make_run(tmp_path / "run", ny=512, nx=512, cell=20.0)
    info = app.write_html(tmp_path / "run", tmp_path / "v.html")
    assert info["bytes"] < 20e6, f"{info['bytes'] / 1e6:.1f} MB"


def test_erosim_view_serves_until_ctrl_c(tmp_path, make_run):
    import signal
    import sys
    import time
    import urllib.request

    make_run(tmp_path / "run")
    cmd = [sys.executable, "-m", "erosim.cli", "view", str(tmp_path / "run"), "--no-browser"]
    p = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # a background shell ignores it
    )  # fmt: skip
    try:
        line = p.stdout.readline()
        url = re.search(r"http://127\.0\.0\.1:\d+/", line).group(0)
        deadline = time.time() + 30
        while True:
            try:
                with urllib.request.urlopen(url, timeout=5) as r:
                    assert r.status == 200 and b"erosim view" in r.read()
                break
            except OSError:
                assert time.time() < deadline
                time.sleep(0.2)
        p.send_signal(signal.SIGINT)
        out, _ = p.communicate(timeout=30)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 0 and "stopped" in out


@pytest.mark.browser  # a headless Chromium (`make test-browser`)
def test_particles_and_the_time_slider_in_headless_chromium(tmp_path):
    browser = _browser()
    if browser is None:
        pytest.skip("no Chromium here: install Debian's chromium package (apt-get install chromium) to run this test")
    make_sph_run(tmp_path / "sph", frames=4, n=400)
    html = tmp_path / "v.html"
    app.write_html(tmp_path / "sph", html)
    first = _shoot(browser, html, tmp_path / "f0.png", "frame=0", tmp_path)
    last = _shoot(browser, html, tmp_path / "f3.png", "frame=3", tmp_path)
    plot = (slice(50, 750), slice(320, 1150))
    for img in (first, last):
        assert img[plot].std() > 10, "the particle view is blank"
    assert (np.abs(first[plot] - last[plot]).sum(axis=-1) > 30).mean() > 0.005, "the frames look the same"


def add_map_frames(folder, z, n=3, times=None):
    """maps/frames/height_0000k.tif and lake_depth_0000k.tif: the terrain sinking, a lake rising."""
    from erosim.io import heightmaps

    like = heightmaps.read(folder / "maps" / "height.tif")
    (folder / "maps" / "frames").mkdir()
    for k in range(n):
        heightmaps.write(folder / "maps" / "frames" / f"height_{k:05d}.tif", z - 5.0 * k, like=like)
        lake = np.where(z < 45 + 5 * k, 2.0, 0)
        heightmaps.write(folder / "maps" / "frames" / f"lake_depth_{k:05d}.tif", lake, like=like)
    if times is not None:
        (folder / "maps" / "frames" / "frames.json").write_text(json.dumps({"times": times}))


def test_map_frames_drive_the_slider(tmp_path, make_run):
    z, _ = make_run(tmp_path / "run")
    add_map_frames(tmp_path / "run", z, times=[0.0, 10.0, 20.0])
    run = open_run(tmp_path / "run")
    assert [t for t, _ in run.map_frames] == [0.0, 10.0, 20.0]
    assert sorted(run.map_frames[1][1]) == ["height", "lake_depth"]
    p = page.payload(run)
    mf = p.meta["map_frames"]
    assert [f["t"] for f in mf] == [0.0, 10.0, 20.0] and p.meta["frames"] == []
    np.testing.assert_allclose(p.arrays[mf[2]["arrays"]["height"]].reshape(z.shape), z - 10.0, atol=1e-4)
    assert set(mf[0]["arrays"]) == {"height", "water"}


@pytest.mark.browser  # a headless Chromium (`make test-browser`)
def test_map_frames_in_headless_chromium(tmp_path, make_run):
    browser = _browser()
    if browser is None:
        pytest.skip("no Chromium here: install Debian's chromium package (apt-get install chromium) to run this test")
    z, _ = make_run(tmp_path / "run", ny=60, nx=80)
    add_map_frames(tmp_path / "run", z)
    html = tmp_path / "v.html"
    app.write_html(tmp_path / "run", html)
    a = _shoot(browser, html, tmp_path / "a.png", "frame=0&layers=water", tmp_path)
    b = _shoot(browser, html, tmp_path / "b.png", "frame=2&layers=water", tmp_path)
    plot = (slice(50, 750), slice(320, 1150))
    assert _waterish(b[plot]) > _waterish(a[plot]) + 500  # the lake has grown
    cmd = [
        browser, "--headless", "--no-sandbox", "--disable-dev-shm-usage", "--enable-unsafe-swiftshader",
        "--use-angle=swiftshader", "--window-size=1200,800", "--virtual-time-budget=20000",
        f"--user-data-dir={tmp_path}", "--dump-dom", f"file://{html}#frame=2&probe=5,3",
    ]  # fmt: skip
    dom = subprocess.run(cmd, capture_output=True, timeout=120, text=True, env={**os.environ, "HOME": str(tmp_path)})
    cursor = re.search(r'<div id="cursor">(.*?)</div>', dom.stdout, re.S).group(1)
    assert f"height: {float(np.float32(z[5, 3] - 10.0)):.4g} m" in cursor  # the frame's height, not the final


@pytest.mark.browser  # a headless Chromium (`make test-browser`)
@pytest.mark.slow  # two more browser runs (about 25 s on the shared 2-core machine)
def test_plan_view_while_sliding_in_headless_chromium(tmp_path, make_run):
    """The plan view drawn while the slider moves (#slide=k draws it as an input event does): the lake
    grows there as in the 3-D scene."""
    browser = _browser()
    if browser is None:
        pytest.skip("no Chromium here: install Debian's chromium package (apt-get install chromium) to run this test")
    z, _ = make_run(tmp_path / "run", ny=60, nx=80)
    add_map_frames(tmp_path / "run", z)
    html = tmp_path / "v.html"
    app.write_html(tmp_path / "run", html)
    plot = (slice(50, 750), slice(320, 1150))
    a = _shoot(browser, html, tmp_path / "sa.png", "slide=0&layers=water", tmp_path)
    b = _shoot(browser, html, tmp_path / "sb.png", "slide=2&layers=water", tmp_path)
    assert a[plot].std() > 10 and _waterish(b[plot]) > _waterish(a[plot]) + 500


@pytest.mark.browser  # a headless Chromium (`make test-browser`)
def test_first_picture_is_3d_before_plotly(tmp_path, make_run):
    """first.js draws the terrain in 3-D before plotly.js is read; the page says which picture came first."""
    browser = _browser()
    if browser is None:
        pytest.skip("no Chromium here: install Debian's chromium package (apt-get install chromium) to run this test")
    make_run(tmp_path / "run", ny=60, nx=80)
    html = tmp_path / "v.html"
    app.write_html(tmp_path / "run", html)
    cmd = [
        browser, "--headless", "--no-sandbox", "--disable-dev-shm-usage", "--enable-unsafe-swiftshader",
        "--use-angle=swiftshader", "--window-size=1200,800", "--virtual-time-budget=20000",
        f"--user-data-dir={tmp_path}", "--dump-dom", f"file://{html}",
    ]  # fmt: skip
    dom = subprocess.run(cmd, capture_output=True, timeout=120, text=True, env={**os.environ, "HOME": str(tmp_path)})
    body = re.search(r"<body([^>]*)>", dom.stdout).group(1)
    assert 'data-first-picture="3-D"' in body, body
    first, plot = (int(re.search(rf'{a}="(\d+)"', body).group(1)) for a in ("data-first-paint-ms", "data-plot-ms"))
    assert first <= plot  # the picture came before plotly's scene (virtual time: the order, not the speed)


def test_self_contained_page_thins_map_frames_to_its_budget(tmp_path, make_run, monkeypatch):
    z, _ = make_run(tmp_path / "run", ny=60, nx=80)
    add_map_frames(tmp_path / "run", z, n=7)
    p = page.payload(open_run(tmp_path / "run"))
    packed = {k: page.pack(a) for k, a in p.arrays.items()}
    per_frame = sum(len(packed[n]) for n in p.meta["map_frames"][0]["arrays"].values())
    monkeypatch.setattr(page, "INLINE_FRAME_BYTES", int(3.5 * per_frame))  # room for three frames, not four
    meta = page._fit_frames(p, packed)
    kept = [f["t"] for f in meta["map_frames"]]
    assert kept == [0.0, 3.0, 6.0] and "3 of the run's 7 map frames" in meta["map_frames_note"]
    assert "mf1_height" not in packed and "mf1_height" not in meta["arrays"] and "mf3_height" in packed
    assert len(p.meta["map_frames"]) == 7  # the payload itself (the server's) keeps them all
