"""The pictures of docs/view.md: run folders in `erosim view`, and a glTF export opened back.

    PYTHONPATH=src python benchmarks/view_images.py --out docs/images \\
        --view hydrology=RUN1#frame=5 --view flood=RUN2 --view sph=RUN3#frame=12 --gltf RUN1

Each ``--view NAME=RUN[#FRAGMENT]`` serves RUN with ``erosim view``'s own server, opens it in headless
Chromium (software WebGL, a 1400 × 900 window; FRAGMENT as in the page's address: ``frame=``,
``layers=``, ``probe=row,col``), waits until everything is drawn and saves ``view_NAME.jpg``.
``--gltf RUN`` writes ``erosim export RUN --format gltf``, loads the ``.gltf`` back with trimesh
(vertices, triangles, the texture turned into vertex colours by trimesh), draws that mesh as a
plotly ``mesh3d`` in the same headless Chromium and saves ``export_gltf.jpg``. Chromium is driven as
in ``benchmarks/view_first_paint.py`` (DevTools protocol on a pipe).
"""

from __future__ import annotations

import argparse
import base64
import io
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from view_first_paint import Chromium  # noqa: E402


def screenshot(url: str, jpg: Path, wait_attr: str = "data-ready-ms", timeout: float = 300.0) -> None:
    from PIL import Image

    prof = Path(tempfile.mkdtemp(prefix="erosim-shot-"))
    ch = Chromium(prof)
    try:
        ch.page("Page.enable")
        ch.page("Emulation.setDeviceMetricsOverride", width=1400, height=900, deviceScaleFactor=1, mobile=False)
        ch.page("Page.navigate", url=url)
        t_end = time.time() + timeout
        while time.time() < t_end and not ch.eval(f"!!document.body && document.body.hasAttribute('{wait_attr}')"):
            time.sleep(0.2)
        time.sleep(1.0)  # let the last frame reach the screen
        png = base64.b64decode(ch.page("Page.captureScreenshot", format="png")["data"])
    finally:
        ch.close()
        shutil.rmtree(prof, ignore_errors=True)
    Image.open(io.BytesIO(png)).convert("RGB").save(jpg, quality=82, optimize=True)
    print(f"{jpg}: {jpg.stat().st_size / 1e3:.0f} kB")


def view_shot(run: str, fragment: str, jpg: Path) -> None:
    from erosim.view import app

    srv, url = app.start(run, 0)
    try:
        screenshot(url + ("#" + fragment if fragment else ""), jpg)
    finally:
        srv.shutdown()
        srv.server_close()


def gltf_shot(run: str, jpg: Path, max_faces: int = 300_000) -> None:
    import trimesh

    from erosim.view import export, page

    tmp = Path(tempfile.mkdtemp(prefix="erosim-gltf-"))
    try:
        export.export_run(run, tmp, formats=("gltf",))
        path = tmp / "terrain.gltf"
        scene = trimesh.load(path)
        mesh = scene.to_geometry() if hasattr(scene, "to_geometry") else scene.dump(concatenate=True)
        colours = np.asarray(mesh.visual.to_color().vertex_colors)[:, :3]
        v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
        print(f"{path.name}: {len(v)} vertices, {len(f)} triangles, loaded back with trimesh {trimesh.__version__}")
        if len(f) > max_faces:  # plotly draws every triangle in software WebGL: keep the picture's cost bounded
            f = f[:: int(np.ceil(len(f) / max_faces))]
        hexes = [f"#{r:02x}{g:02x}{b:02x}" for r, g, b in colours.tolist()]
        # glTF axes: x east, y up, z south -> plotted as east, north (−z), up
        trace = {
            "type": "mesh3d", "x": v[:, 0].tolist(), "y": (-v[:, 2]).tolist(), "z": v[:, 1].tolist(),
            "i": f[:, 0].tolist(), "j": f[:, 1].tolist(), "k": f[:, 2].tolist(), "vertexcolor": hexes,
            "flatshading": False, "lighting": {"ambient": 0.55, "diffuse": 0.7},
            "lightposition": {"x": -1e5, "y": 1e5, "z": 2e5},
        }  # fmt: skip
        relief = float(np.ptp(v[:, 1])) or 1.0
        span = float(max(np.ptp(v[:, 0]), np.ptp(v[:, 2])))
        layout = {
            "margin": {"l": 0, "r": 0, "t": 40, "b": 0}, "width": 1400, "height": 900,
            "title": {"text": f"{path.name} loaded back with trimesh: {len(v)} vertices, texture as vertex colours"},
            "scene": {"aspectmode": "manual", "aspectratio": {"x": 1, "y": 1, "z": max(0.25, 3 * relief / span)},
                      "camera": {"eye": {"x": -0.9, "y": -1.5, "z": 1.1}}},
        }  # fmt: skip
        html = tmp / "gltf.html"
        html.write_text(
            "<!DOCTYPE html><html><body style='margin:0'><div id='p'></div><script>"
            + page.plotly_js().decode("utf-8")
            + "</script><script>Plotly.newPlot('p',["
            + json.dumps(trace)
            + "],"
            + json.dumps(layout)
            + ",{plotGlPixelRatio:1}).then(()=>document.body.setAttribute('data-ready-ms','1'));"
            + "</script></body></html>",
            encoding="utf-8",
        )
        screenshot("file://" + str(html), jpg)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("docs/images"))
    ap.add_argument("--view", action="append", default=[], help="NAME=RUN[#FRAGMENT]")
    ap.add_argument("--gltf", help="a run folder with a terrain: export it as glTF and show it loaded back")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for spec in args.view:
        name, rest = spec.split("=", 1)
        run, _, fragment = rest.partition("#")
        view_shot(run, fragment, args.out / f"view_{name}.jpg")
    if args.gltf:
        gltf_shot(args.gltf, args.out / "export_gltf.jpg")


if __name__ == "__main__":
    main()
