"""First paint of `erosim view`'s 3-D terrain and the time per step of its frame slider, in headless Chromium.

    PYTHONPATH=src python benchmarks/view_first_paint.py [--side 1024] [--frames 50] [--repeats 5]
        [--steps 20] [--mode server|html] [--keep DIR] [--particles N] [--shots DIR] [--no-release]

What it does: writes a synthetic run folder (a hydrology run as ``erosim run`` leaves it: height, lake
depth, streams, erosion, deposition, vegetation, and ``--frames`` map frames of height and lake depth
under ``maps/frames/``; with ``--particles N`` instead an sph-terrain run: the same terrain and
``--frames`` particle frames of N particles over it), serves it with ``erosim view``'s own server
(``--mode server``, what ``erosim view RUN`` does) or writes the self-contained page (``--mode html``), and opens it
``--repeats`` times in a fresh headless Chromium (software WebGL: SwiftShader, as on a machine
without a GPU), each with a new, empty profile (nothing cached).

How first paint is detected: the page sets ``data-first-paint-ms`` on ``<body>`` when plotly.js has
finished drawing the first 3-D terrain surface (``Plotly.react`` resolved). A script installed
before the page loads (``Page.addScriptToEvaluateOnNewDocument``) watches that attribute and then
waits for two animation frames — the frame holding the WebGL draw has been produced — and notes
``performance.now()``, which counts from the navigation start (so the time includes fetching the
page, reading plotly.js, fetching the height and building the surface). That number is "first paint".

How a slider step is timed: in the page, the slider is set to the next frame and its ``input``
event dispatched (as a person dragging it does); the step ends when the page has shown the frame
(``data-draws`` or ``data-slides`` on ``<body>`` goes up: the 3-D scene or the plan view drawn while
sliding) and two animation frames have passed. ``--steps`` steps from frame 1 on, one after
another; the median is printed. "Release" is the same for the ``change`` event (the slider let
go): the time until the 3-D scene shows the frame. Chromium is driven over its DevTools
protocol on a pipe (``--remote-debugging-pipe``), with the Python standard library only.

Times depend on the machine's load: report them with the load average this script prints, and
compare only runs measured in the same conditions.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

WATCH = """
(() => {
  const rafs = () => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)));
  const obs = new MutationObserver(() => {
    if (document.body && document.body.hasAttribute('data-first-paint-ms') && window.__fp === undefined) {
      window.__fp = null;
      rafs().then(() => { window.__fp = performance.now(); });
      obs.disconnect();
    }
  });
  obs.observe(document, { attributes: true, childList: true, subtree: true });
})();
"""

STEP = """
(async (k, release) => {
  const rafs = () => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)));
  const sl = document.getElementById('frame');
  const count = () => +(document.body.dataset.draws || 0) + +(document.body.dataset.slides || 0);
  const before = count();
  const t0 = performance.now();
  sl.value = k;
  sl.dispatchEvent(new Event(release ? 'change' : 'input'));
  while (count() === before) {
    if (performance.now() - t0 > 30000) return null; // nothing drawn (a page whose slider ignores the event)
    await new Promise((r) => setTimeout(r, 2));
  }
  await rafs();
  return performance.now() - t0;
})
"""


def browser() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    sys.exit("no Chromium found: install Debian's chromium package (apt-get install chromium)")


class Chromium:
    """Headless Chromium driven over the DevTools protocol on fds 3 (commands in) and 4 (replies out)."""

    def __init__(self, profile: Path):
        to_r, self._to_w = os.pipe()
        self._from_r, from_w = os.pipe()

        def fds():
            a, b = os.dup(to_r), os.dup(from_w)
            os.dup2(a, 3)
            os.dup2(b, 4)

        cmd = [
            browser(), "--headless", "--no-sandbox", "--disable-dev-shm-usage", "--enable-unsafe-swiftshader",
            "--use-angle=swiftshader", "--hide-scrollbars", "--window-size=1400,900", "--no-first-run",
            f"--user-data-dir={profile}", "--remote-debugging-pipe", "about:blank",
        ]  # fmt: skip
        self.proc = subprocess.Popen(
            cmd, preexec_fn=fds, close_fds=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            env={**os.environ, "HOME": str(profile)},
        )  # fmt: skip
        os.close(to_r)
        os.close(from_w)
        self._buf = b""
        self._id = 0
        targets = self.call("Target.getTargets")["targetInfos"]
        page = next(t for t in targets if t["type"] == "page")
        self.session = self.call("Target.attachToTarget", targetId=page["targetId"], flatten=True)["sessionId"]

    def _read(self) -> dict:
        while b"\0" not in self._buf:
            chunk = os.read(self._from_r, 1 << 20)
            if not chunk:
                raise RuntimeError("Chromium closed its pipe")
            self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def call(self, method: str, session: str | None = None, **params):
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params}
        if session:
            msg["sessionId"] = session
        os.write(self._to_w, json.dumps(msg).encode() + b"\0")
        while True:
            r = self._read()
            if r.get("id") == self._id:
                if "error" in r:
                    raise RuntimeError(f"{method}: {r['error']}")
                return r["result"]

    def page(self, method: str, **params):
        return self.call(method, self.session, **params)

    def eval(self, expr: str):
        r = self.page("Runtime.evaluate", expression=expr, awaitPromise=True, returnByValue=True)
        if "exceptionDetails" in r:
            raise RuntimeError(str(r["exceptionDetails"])[:500])
        return r["result"].get("value")

    def close(self) -> None:
        try:
            self.call("Browser.close")
        except Exception:
            pass
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def make_run(folder: Path, side: int, frames: int) -> None:
    """A hydrology run folder: a ridged terrain, lakes in its hollows, streams, and map frames of a
    terrain slowly lowering and lakes slowly filling."""
    from erosim.io import heightmaps

    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[0:side, 0:side] / side
    z = 300 + 120 * np.sin(6 * xx) * np.cos(5 * yy) + 60 * np.sin(17 * xx + 3 * yy) + 5 * rng.random((side, side))
    cell = 10.0
    hm = heightmaps.Heightmap(z=z, cell_size=cell, transform=(cell, 0.0, 500000.0, 0.0, -cell, 4800000.0))
    (folder / "maps" / "frames").mkdir(parents=True)
    heightmaps.write(folder / "maps" / "height.tif", hm)
    level = np.percentile(z, 15)
    maps = {
        "lake_depth": np.where(z < level, level - z, 0.0),
        "stream": np.clip(np.abs(np.sin(40 * xx + 10 * np.sin(8 * yy))) - 0.9, 0, 1) * 10,
        "erosion": rng.random(z.shape) * 0.2,
        "deposition": rng.random(z.shape) * 0.3,
        "vegetation": (rng.random(z.shape) > 0.6) * 0.6,
    }
    for name, a in maps.items():
        heightmaps.write_raster(folder / "maps" / f"{name}.tif", a, like=hm)
    for k in range(frames):
        f = k / max(frames - 1, 1)
        zk = z + 4 * (1 - f) * np.sin(9 * xx + k)
        lvl = np.percentile(z, 15 * f)
        heightmaps.write(folder / "maps" / "frames" / f"height_{k:05d}.tif", zk, like=hm)
        heightmaps.write_raster(folder / "maps" / "frames" / f"lake_depth_{k:05d}.tif",
                                np.where(z < lvl, lvl - z, 0.0), like=hm)  # fmt: skip
    (folder / "maps" / "frames" / "frames.json").write_text(json.dumps({"times": [float(k) for k in range(frames)]}))
    (folder / "report.json").write_text(json.dumps({"kind": "hydrology", "status": "completed"}))


def shoot(ch: Chromium, path: Path) -> None:
    import base64

    path.write_bytes(base64.b64decode(ch.page("Page.captureScreenshot", format="png")["data"]))


def make_particle_run(folder: Path, side: int, frames: int, n: int) -> None:
    """An sph-terrain run folder: the terrain of :func:`make_run` (no map frames) and ``frames`` particle
    frames of ``n`` particles a sheet of water sliding over it (velocity, pressure, density)."""
    from erosim.io.particles import pvd_text, write_vtp

    make_run(folder, side, 0)
    from erosim.io import heightmaps

    hm = heightmaps.read(folder / "maps" / "height.tif")
    z, cell = hm.z, hm.cell_size
    (folder / "particles").mkdir()
    rng = np.random.default_rng(1)
    col, row = rng.random(n) * 0.3 * (side - 1), rng.random(n) * (side - 1)
    rows = []
    for k in range(frames):
        c = np.clip(col + k * 0.012 * side, 0, side - 1)
        i = np.clip(np.rint(row).astype(int), 0, side - 1)
        x, y = c * cell, (side - 1 - row) * cell
        ground = z[i, np.rint(c).astype(int)]
        pos = np.column_stack([x, y, ground + 1.0 + rng.random(n)])
        vel = np.column_stack([np.full(n, 0.012 * side * cell), rng.normal(size=n), rng.normal(size=n) * 0.1])
        name = f"frame_{k:05d}.vtp"
        write_vtp(folder / "particles" / name, pos, {"velocity": vel, "pressure": rng.random(n) * 1e4,
                                                     "density": 1000 + rng.random(n)}, time=float(k))  # fmt: skip
        rows.append((float(k), name))
    (folder / "particles" / "particles.pvd").write_text(pvd_text(rows))
    (folder / "report.json").write_text(json.dumps({"kind": "sph-terrain", "status": "completed", "dim": 3}))


def open_once(
    url: str, steps: int, n_frames: int, timeout: float = 120.0, shots: Path | None = None, release: bool = True
) -> dict:
    prof = Path(tempfile.mkdtemp(prefix="erosim-bench-chromium-"))
    ch = Chromium(prof)
    try:
        ch.page("Page.enable")
        ch.page("Page.addScriptToEvaluateOnNewDocument", source=WATCH)
        ch.page("Page.navigate", url=url)
        t_end = time.time() + timeout
        fp = None
        while time.time() < t_end:
            fp = ch.eval("window.__fp === undefined ? null : window.__fp")
            if fp:
                break
            time.sleep(0.05)
        if not fp:
            raise RuntimeError("the 3-D terrain was not drawn within the timeout")
        if shots:
            shoot(ch, shots / "first_paint.png")
        out = {"first_paint_s": fp / 1000.0}
        out["marks"] = ch.eval(
            "JSON.stringify(Object.assign({}, window.erosimTimes || {}, {"
            "html: performance.getEntriesByType('navigation')[0].responseEnd,"
            "dom: performance.getEntriesByType('navigation')[0].domInteractive,"
            "js: (performance.getEntriesByType('resource').find((e) => e.name.includes('plotly')) || {}).responseEnd}))"
        )
        # wait for the page to finish its first full drawing before sliding
        while time.time() < t_end and not ch.eval("document.body.hasAttribute('data-ready-ms')"):
            time.sleep(0.05)
        out["ready_s"] = float(ch.eval("+document.body.getAttribute('data-ready-ms')")) / 1000.0
        plot = ch.eval("document.body.getAttribute('data-plot-ms')")
        out["plot_s"] = float(plot) / 1000.0 if plot else out["first_paint_s"]  # before first.js: the same
        if shots:
            shoot(ch, shots / "ready.png")
        step_ms = []
        for k in range(1, min(steps, n_frames - 1) + 1):
            step_ms.append(ch.eval(f"({STEP})({k}, false)"))
            if shots and k == 1:
                shoot(ch, shots / "sliding.png")
        out["steps_ms"] = step_ms
        out["release_ms"] = ch.eval(f"({STEP})({len(step_ms)}, true)") if step_ms and release else None
        out["release_ms"] = float("nan") if out["release_ms"] is None else out["release_ms"]
        return out
    finally:
        ch.close()
        shutil.rmtree(prof, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--side", type=int, default=1024)
    ap.add_argument("--frames", type=int, default=50)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--steps", type=int, default=20, help="slider steps timed per repeat")
    ap.add_argument("--mode", choices=("server", "html"), default="server")
    ap.add_argument("--keep", type=Path, help="keep the run folder here (made once, reused)")
    ap.add_argument(
        "--particles",
        type=int,
        default=0,
        help="instead of map frames: --frames particle frames of this many particles (sph-terrain)",
    )
    ap.add_argument("--no-release", action="store_true", help="skip timing the release (pages without one)")
    ap.add_argument("--shots", type=Path, help="save screenshots (first paint, all drawn, sliding) here")
    args = ap.parse_args()

    from erosim.view import app

    tmp = Path(tempfile.mkdtemp(prefix="erosim-bench-view-"))
    run = args.keep or tmp / "run"
    if not (run / "report.json").exists():
        t = time.perf_counter()
        if args.particles:
            make_particle_run(run, args.side, args.frames, args.particles)
        else:
            make_run(run, args.side, args.frames)
        what = f"{args.particles} particles" if args.particles else "map"
        print(
            f"run folder {run} ({args.side}², {args.frames} {what} frames) written in {time.perf_counter() - t:.1f} s"
        )
    srv = None
    if args.mode == "server":
        t = time.perf_counter()
        srv, url = app.start(run, 0)
        print(f"server ready in {time.perf_counter() - t:.2f} s")
    else:
        info = app.write_html(run, tmp / "view.html")
        url = "file://" + info["path"]
        print(f"self-contained page: {info['bytes'] / 1e6:.1f} MB")
    try:
        fps, plots, readies, steps, releases = [], [], [], [], []
        for r in range(args.repeats):
            load = os.getloadavg()[0]
            res = open_once(url, args.steps, args.frames, shots=args.shots, release=not args.no_release)
            fps.append(res["first_paint_s"])
            readies.append(res["ready_s"])
            plots.append(res["plot_s"])
            steps += res["steps_ms"]
            releases.append(res["release_ms"])
            sm = statistics.median(res["steps_ms"]) if res["steps_ms"] else float("nan")
            print(
                f"repeat {r + 1}: first paint {res['first_paint_s']:.2f} s, plotly scene {res['plot_s']:.2f} s, "
                f"all drawn {res['ready_s']:.2f} s, "
                f"slider step median {sm:.0f} ms, release {res['release_ms']:.0f} ms (load average {load:.1f})"
            )
            print(f"  marks (ms): {res['marks']}")  # fmt: skip
        print(f"first paint of the 3-D terrain ({args.side}², {args.mode}): median {statistics.median(fps):.2f} s "
              f"over {len(fps)} repeats (min {min(fps):.2f}, max {max(fps):.2f})")  # fmt: skip
        print(f"interactive (plotly) 3-D scene: median {statistics.median(plots):.2f} s; "
              f"all drawn: median {statistics.median(readies):.2f} s")  # fmt: skip
        releases = [r for r in releases if r == r] or [float("nan")]  # NaN: not timed
        if steps:
            print(f"slider step: median {statistics.median(steps):.0f} ms over {len(steps)} steps "
                  f"(min {min(steps):.0f}, max {max(steps):.0f}); release (3-D redrawn): median "
                  f"{statistics.median(releases):.0f} ms over {len(releases)}")  # fmt: skip
        print(f"load average now {os.getloadavg()}")
    finally:
        if srv is not None:
            srv.shutdown()
            srv.server_close()
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
