"""The page of ``erosim view``: what of a run is drawn, and the HTML around it.

:func:`payload` turns a run folder (:mod:`erosim.io.results`) into a small JSON description (grid,
layers with colour scales and ranges, particle frames, the report's key figures) plus flat arrays
(float32, uint8 for hazard classes): the terrain and every known map at up to ``max_side`` cells a
side (a larger map is read at a stride), and each particle frame thinned to ``max_particles``
(a random choice with a fixed seed, so a page is the same every time it is made). :func:`html` writes the page:
plotly.js — the copy the ``plotly`` Python package ships in its wheel, so nothing comes from the
network — draws, and ``view.js`` (beside this file) decides what: the terrain as a lit 3-D surface
(strided in the browser to the chosen detail), the layers draped over it, particles, the time
slider (a 2-D plan view while it moves), the values under the cursor and the legends. Before either
is read, ``first.js`` draws the terrain's coarse copy (:func:`_first`, inside the page) in 3-D with
plain WebGL, then runs them (both are kept in the page as text until then). The arrays are either
inside the page (``--html``: packed by :func:`pack`, map frames thinned to
:data:`INLINE_FRAME_BYTES`) or fetched from the local server (:mod:`erosim.view.server`).
"""

from __future__ import annotations

import base64
import html as htmllib
import json
from importlib import resources
from pathlib import Path

import numpy as np

from erosim.io import heightmaps
from erosim.io.results import LAYERS, Run, read_frame
from erosim.viz import maps
from erosim.viz.flood import HAZARD_LEGEND

MAX_SIDE = 1024
MAX_PARTICLES = 20_000
MAX_MAP_FRAMES = 60
DEFAULT_LAYERS = ("water", "stream", "hazard")

TERRAIN = [[0.0, "#2f5d34"], [0.25, "#6f9a52"], [0.5, "#c4b37c"], [0.75, "#9c8670"], [1.0, "#f4f4f4"]]
BLUES = [[0.0, "#9ecae1"], [1.0, "#08306b"]]
STREAMS = [[0.0, "#a6d8f5"], [1.0, "#1565c0"]]
RDBU = [[0.0, "#b2182b"], [0.5, "#f7f7f7"], [1.0, "#2166ac"]]
GREENS = [[0.0, "#c7e9c0"], [1.0, "#00441b"]]
VIRIDIS = [[0.0, "#440154"], [0.25, "#3b528b"], [0.5, "#21918c"], [0.75, "#5ec962"], [1.0, "#fde725"]]
HAZARD = [colour for _, colour, _ in HAZARD_LEGEND]  # classes 1..6, as in the flood's figures
FIELD_UNITS = {"speed": "m/s", "pressure": "Pa", "density": "kg/m³", "above ground": "m"}


def _pct(a: np.ndarray, q: float, positive: bool = True) -> float:
    v = a[np.isfinite(a)]
    if positive:
        v = v[v > 0]
    return float(np.percentile(v, q)) if v.size else 1.0


def _layer_spec(key: str, label: str, unit: str, a: np.ndarray) -> dict:
    """Colour scale, range and the value below which a cell is left bare, per kind of layer."""
    if key == "hazard":
        cs = [[0.0, HAZARD[0]]]
        for c in range(6):  # steps: class c+1 fills [c/6, (c+1)/6] of the scale over 0.5..6.5
            cs += [[c / 6, HAZARD[c]], [(c + 1) / 6, HAZARD[c]]]
        return {"colorscale": cs[1:], "cmin": 0.5, "cmax": 6.5, "hide_below": 0.5, "style": "drape",
                "classes": [[str(c + 1), HAZARD[c]] for c in range(6)]}  # fmt: skip
    if key == "water":
        return {"colorscale": BLUES, "cmin": 0.0, "cmax": _pct(a, 99), "hide_below": 1e-3, "style": "water"}
    if key == "stream":
        return {"colorscale": STREAMS, "cmin": 0.0, "cmax": max(_pct(a, 99), 1e-6), "hide_below": 0.02,
                "style": "drape"}  # fmt: skip
    if key == "vegetation":
        return {"colorscale": GREENS, "cmin": 0.0, "cmax": max(float(np.nanmax(a)), 1e-6), "hide_below": 0.01,
                "style": "drape"}  # fmt: skip
    if key == "wetness":
        return {"colorscale": BLUES, "cmin": float(np.nanmin(a)), "cmax": float(np.nanmax(a)),
                "hide_below": float(np.nanmin(a)), "style": "drape"}  # fmt: skip
    lo = float(np.nanmin(a)) if a.size else 0.0
    return {"colorscale": VIRIDIS, "cmin": lo, "cmax": max(_pct(a, 99, positive=False), lo + 1e-9),
            "hide_below": 0.0 if lo >= 0 else -np.inf, "style": "drape"}  # fmt: skip


class Payload:
    """``meta`` (JSON-ready) and ``arrays`` (name → contiguous NumPy array) of one run's page."""

    def __init__(self) -> None:
        self.meta: dict = {}
        self.arrays: dict[str, np.ndarray] = {}

    def add(self, name: str, a: np.ndarray) -> str:
        a = np.ascontiguousarray(a, dtype=np.uint8 if a.dtype == np.uint8 else np.float32)
        self.arrays[name] = a
        return name

    def array_bytes(self, name: str) -> bytes:
        return self.arrays[name].tobytes()


def _crs_name(crs: str | None) -> str | None:
    if not crs:
        return None
    try:
        from rasterio.crs import CRS

        c = CRS.from_user_input(crs)
        return c.to_string() if c.to_epsg() else (c.to_dict().get("proj") or "custom CRS")
    except Exception:
        return "custom CRS"


def payload(run: Run, max_side: int = MAX_SIDE, max_particles: int = MAX_PARTICLES) -> Payload:
    """What the page of ``run`` shows (module docstring)."""
    p = Payload()
    meta = p.meta
    meta["title"] = f"{run.name} — {run.kind}"
    meta["kind"] = run.kind
    meta["figures"] = run.key_figures()
    meta["layers"], meta["values"], meta["arrays"] = [], [], {}
    meta["default_layers"] = list(DEFAULT_LAYERS)
    meta["terrain_colorscale"] = TERRAIN
    meta["grid"] = None
    meta["map_frames"] = []
    ground = None
    if run.has_height():
        hm = run.height()
        ny0, nx0 = hm.z.shape
        step = max(1, int(np.ceil(max(ny0, nx0) / max_side)))
        z = np.asarray(hm.z[::step, ::step], dtype=np.float32)
        ground = (np.asarray(hm.z, dtype=np.float64), hm.cell_size)
        ny, nx = z.shape
        relief = float(np.nanmax(z) - np.nanmin(z))
        meta["grid"] = {
            "ny": ny, "nx": nx, "step": step, "cell": hm.cell_size * step, "y_top": (ny0 - 1) * hm.cell_size,
            "z_range": [float(np.nanmin(z)), float(np.nanmax(z))], "lift": max(relief * 2e-3, 1e-6),
            "transform": list(hm.transform) if hm.transform else None, "crs": _crs_name(hm.crs),
            "shape": [ny0, nx0], "cell_size": hm.cell_size,
        }  # fmt: skip
        meta["values"].append({"label": "height", "unit": "m", "array": p.add("height", z)})
        present = {}
        for layer, name in run.layers():
            a = run.read_map(name).z[::step, ::step]
            if layer.key == "hazard":
                a = np.clip(np.nan_to_num(a), 0, 255).astype(np.uint8)
            arr = p.add(f"map_{name}", a)
            present[layer.key] = (layer, arr, a)
            meta["values"].append(
                {"label": layer.label, "unit": layer.unit, "array": arr, "classes": layer.key == "hazard"}
            )
        for key, (layer, arr, a) in present.items():
            if key in ("erosion", "deposition"):
                continue
            spec = _layer_spec(key, layer.label, layer.unit, np.asarray(a, dtype=np.float64))
            meta["layers"].append({"key": key, "label": layer.label, "unit": layer.unit, "array": arr, **spec})
            if key == "stream":  # erosion and deposition, one diverging layer, right after the water
                _change_layer(meta, present)
        if "stream" not in present:
            _change_layer(meta, present)
        meta["preview"] = _preview(z, hm.cell_size * step, present)
        meta["first"] = _first(z, hm.cell_size * step)
        _map_frames(p, run, step, (ny0, nx0), present.get("water"))
    _frames(p, run, max_particles, ground)
    meta["arrays"] = {
        k: {"dtype": "u1" if a.dtype == np.uint8 else "f4", "n": int(a.size)} for k, a in p.arrays.items()
    }
    return p


FIRST_SIDE = 128


def _first(z: np.ndarray, cell: float) -> dict:
    """The terrain's coarse copy (≤ :data:`FIRST_SIDE` a side, float32 base64) that ``first.js`` draws
    in 3-D before plotly.js is read."""
    s = max(1, int(np.ceil(max(z.shape) / FIRST_SIDE)))
    zs = np.ascontiguousarray(np.nan_to_num(z[::s, ::s], nan=float(np.nanmin(z))), dtype=np.float32)
    return {"ny": zs.shape[0], "nx": zs.shape[1], "cell": cell * s, "colorscale": TERRAIN,
            "z_range": [float(np.nanmin(z)), float(np.nanmax(z))],
            "b64": base64.b64encode(zs.tobytes()).decode("ascii")}  # fmt: skip


def _preview(z: np.ndarray, cell: float, present: dict) -> str:
    """A plan-view picture (data URL, ≤ 512 px) shown until the 3-D surface is drawn."""
    import io

    from PIL import Image


    s = max(1, int(np.ceil(max(z.shape) / 512)))
    zs = np.asarray(z[::s, ::s], dtype=np.float64)
    pick = {k: np.asarray(v[2][::s, ::s], dtype=np.float64) for k, v in present.items()}
    if "water" in pick or "stream" in pick:
        zero = np.zeros_like(zs)
        rgb = maps.hydrology_map(zs, cell * s, pick.get("stream", zero), pick.get("water", zero),
                                 vegetation=pick.get("vegetation"))  # fmt: skip
    else:
        rgb = maps.shaded_relief(zs, cell * s)
    buf = io.BytesIO()
    Image.fromarray(np.clip(np.rint(rgb * 255), 0, 255).astype(np.uint8)).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _change_layer(meta: dict, present: dict) -> None:
    if not ({"erosion", "deposition"} & set(present)):
        return
    e = present.get("erosion", (None, None, 0.0))[2]
    d = present.get("deposition", (None, None, 0.0))[2]
    net = np.asarray(d, dtype=np.float64) - np.asarray(e, dtype=np.float64)
    m = _pct(np.abs(net), 99)
    meta["layers"].append(
        {
            "key": "change", "label": "Erosion (−) / deposition (+)", "unit": "m", "colorscale": RDBU,
            "cmin": -m, "cmax": m, "hide_below": 0.01 * m, "style": "drape",
            "erosion": present["erosion"][1] if "erosion" in present else None,
            "deposition": present["deposition"][1] if "deposition" in present else None,
        }
    )  # fmt: skip


def _map_frames(p: Payload, run: Run, step: int, shape: tuple[int, int], water) -> None:
    """Height and water of each map frame on the view's grid (frames of another shape are left out;
    the water of a frame is drawn where the run's final maps have a water layer)."""

    water_names = next(layer.files for layer in LAYERS if layer.key == "water")
    frames = run.map_frames
    if len(frames) > MAX_MAP_FRAMES:  # evenly spaced, first and last kept
        frames = [frames[int(round(i))] for i in np.linspace(0, len(frames) - 1, MAX_MAP_FRAMES)]
    for i, (t, files) in enumerate(frames):
        entry: dict = {"t": t, "arrays": {}}
        for key, names in (("height", ("height",)), ("water", water_names)):
            name = next((n for n in names if n in files), None)
            if name is None:
                continue
            a = heightmaps.read(files[name]).z
            if a.shape != shape:
                continue
            entry["arrays"][key] = p.add(f"mf{i}_{key}", a[::step, ::step])
        if entry["arrays"]:
            p.meta["map_frames"].append(entry)


def _frames(p: Payload, run: Run, max_particles: int, ground) -> None:

    meta = p.meta
    meta["frames"], meta["frame_fields"], meta["field_ranges"] = [], [], {}
    meta["field_units"] = FIELD_UNITS
    meta["time_unit"] = str(run.report.get("progress", {}).get("unit", "s"))
    dim = int(run.report.get("dim", 3) or 3)
    meta["particles_dim"] = 2 if dim == 2 and meta["grid"] is None else 3
    ranges: dict[str, list[float]] = {}
    for i, (t, path) in enumerate(run.frames):
        f = read_frame(path)
        pos = np.asarray(f["points"], dtype=np.float32).reshape(-1, 3)
        fields = {}
        if "velocity" in f["fields"]:
            vel = np.asarray(f["fields"]["velocity"], dtype=np.float64).reshape(-1, 3)
            fields["speed"] = np.linalg.norm(vel, axis=1)
        for k in ("pressure", "density"):
            if k in f["fields"]:
                fields[k] = np.asarray(f["fields"][k], dtype=np.float64)
        if ground is not None and dim == 3 and len(pos):
            z0, cs = ground
            col = np.clip(np.rint(pos[:, 0] / cs).astype(int), 0, z0.shape[1] - 1)
            row = np.clip(z0.shape[0] - 1 - np.rint(pos[:, 1] / cs).astype(int), 0, z0.shape[0] - 1)
            fields["above ground"] = pos[:, 2] - z0[row, col]
        n = len(pos)
        sel = np.arange(n)
        if n > max_particles:
            sel = np.sort(np.random.default_rng(0).choice(n, max_particles, replace=False))
        entry = {"t": float(f["time"] if f["time"] is not None else t), "n": int(sel.size), "arrays": {}}
        entry["arrays"]["pos"] = p.add(f"f{i}_pos", pos[sel])
        for k, v in fields.items():
            entry["arrays"][k] = p.add(f"f{i}_{k.replace(' ', '_')}", v[sel])
            lo, hi = (float(np.percentile(v, 1)), float(np.percentile(v, 99))) if v.size else (0.0, 1.0)
            r = ranges.setdefault(k, [lo, hi])
            r[0], r[1] = min(r[0], lo), max(r[1], hi)
        meta["frames"].append(entry)
        if not meta["frame_fields"]:
            meta["frame_fields"] = list(fields)
    meta["field_ranges"] = ranges
    if not meta["frame_fields"]:
        meta["frame_fields"] = ["speed"]


# ------------------------------------------------------------------------------------------ HTML
INLINE_FRAME_BYTES = 6_000_000  # the map frames a self-contained page keeps (base64, after packing)


def pack(a: np.ndarray) -> str:
    """An array for the self-contained page: its bytes shuffled into planes (every value's first
    byte, then every second byte, …: the high bytes of smooth float32 maps repeat, so they compress),
    deflated (zlib) and base64-encoded; the page undoes it with the browser's DecompressionStream."""
    import zlib

    b = np.ascontiguousarray(a)
    planes = b.view(np.uint8).reshape(-1, b.itemsize).T.tobytes()
    return base64.b64encode(zlib.compress(planes, 6)).decode("ascii")


def _fit_frames(p: Payload, packed: dict[str, str]) -> dict:
    """The meta of a self-contained page whose map frames fit :data:`INLINE_FRAME_BYTES`: evenly spaced
    frames (the first and last kept) are dropped from the page until they do; the rest say so."""
    frames = p.meta.get("map_frames", [])
    size = [sum(len(packed[n]) for n in f["arrays"].values()) for f in frames]
    if sum(size) <= INLINE_FRAME_BYTES:
        return p.meta
    keep = len(frames)
    while keep > 2:
        keep -= 1
        pick = sorted({int(round(i)) for i in np.linspace(0, len(frames) - 1, keep)})
        if sum(size[i] for i in pick) <= INLINE_FRAME_BYTES:
            break
    pick = sorted({int(round(i)) for i in np.linspace(0, len(frames) - 1, keep)})
    for i, f in enumerate(frames):
        if i not in pick:
            for n in f["arrays"].values():
                packed.pop(n, None)
    meta = dict(p.meta)
    meta["map_frames"] = [frames[i] for i in pick]
    meta["map_frames_note"] = (f"{len(pick)} of the run's {len(frames)} map frames in this file "
                               "(erosim view RUN serves them all)")  # fmt: skip
    meta["arrays"] = {k: v for k, v in p.meta["arrays"].items() if k in packed}
    return meta


def plotly_js() -> bytes:
    """plotly.min.js from the installed ``plotly`` package (it ships in the wheel)."""
    import plotly

    path = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"
    return path.read_bytes()


def first_js() -> str:
    return resources.files("erosim.view").joinpath("first.js").read_text(encoding="utf-8")


def view_js() -> str:
    return resources.files("erosim.view").joinpath("view.js").read_text(encoding="utf-8")


CSS = """
body{margin:0;font:13px system-ui,sans-serif;display:flex;height:100vh;color:#222;background:#fafafa}
#side{width:300px;padding:10px;overflow-y:auto;border-right:1px solid #ddd;background:#fff}
#main{flex:1;display:flex;flex-direction:column;min-width:0}
#plot{flex:1;min-height:0;height:calc(100vh - 40px)}
#preview{display:block;width:100%;height:100%;object-fit:contain}
#first3d{position:absolute;left:0;top:0}
#plot{position:relative}
#slide{position:absolute;left:0;top:0;width:100%;height:100%;object-fit:contain;background:#fafafa;z-index:10;
display:none;image-rendering:auto}
h1{font-size:15px;margin:0 0 8px} h2{font-size:13px;margin:12px 0 4px;color:#555}
#layers label{display:block;margin:2px 0} .legend{margin:6px 0} .bar{height:10px;border:1px solid #ccc}
.sw{display:inline-block;width:12px;height:12px;margin:0 2px 0 6px;vertical-align:middle;border:1px solid #999}
table{border-collapse:collapse;width:100%} td{padding:1px 4px;border-bottom:1px solid #eee;vertical-align:top}
#cursor{font-family:ui-monospace,monospace;font-size:12px;min-height:4em} #status{color:#888;font-size:11px}
#time{padding:6px 10px;border-top:1px solid #ddd;background:#fff} #frame{width:60%}
"""


def html(p: Payload, *, inline: bool) -> str:
    """The page; ``inline``: plotly.js and every array inside it (one file that works offline)."""
    preview = p.meta.get("preview")
    meta = p.meta
    if inline:
        plotly_tag = '<script type="text/plain" id="plotly-code">' + plotly_js().decode("utf-8") + "</script>"
        packed = {k: pack(a) for k, a in p.arrays.items()}
        meta = _fit_frames(p, packed)
        data = "".join(
            f'<script type="application/octet-stream" data-pack="shuffle-deflate" id="a-{k}">{text}</script>\n'
            for k, text in packed.items()
        )
    else:
        plotly_tag = ""  # first.js loads plotly.min.js from the server
        data = ""
    first = meta.get("first")
    meta = {k: v for k, v in meta.items() if k != "preview"}
    if first:
        meta["first"] = {k: v for k, v in first.items() if k != "b64"}
    meta = json.dumps(meta, allow_nan=False, default=float)
    meta = meta.replace("</", "<\\/")
    title = htmllib.escape(p.meta["title"])
    figures = "".join(
        f"<tr><td>{htmllib.escape(k)}</td><td>{htmllib.escape(v)}</td></tr>" for k, v in p.meta["figures"]
    )
    first_tag = f'<script type="application/octet-stream" id="first-height">{first["b64"]}</script>' if first else ""
    # first.js runs before the data are read: it draws the first picture, then (the page read) runs plotly.js
    # and view.js, kept as text till then
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>erosim view: {title}</title><style>{CSS}</style>
</head>
<body><div id="side"><h1>{title}</h1>
<h2>Layers</h2><div id="layers"></div><div id="legends"></div>
<div id="view-box"><h2>View</h2>detail <select id="detail"><option value="128">128</option>
<option value="256">256</option><option value="512">512</option><option value="full">full</option></select>
vertical <select id="exag-select"><option value="0">auto</option><option value="1">×1</option>
<option value="2">×2</option><option value="5">×5</option><option value="10">×10</option></select>
<span id="exag"></span></div>
<h2>Under the cursor</h2><div id="cursor">{"point at the terrain" if p.meta["grid"] else "point at a particle"}</div>
<h2>Report</h2><table id="figures">{figures}</table><div id="status"></div></div>
<div id="main"><div id="plot">{f'<img id="preview" alt="plan view" src="{preview}">' if preview else ""}</div>
<div id="time">frame <input type="range" id="frame" min="0" max="0" value="0"> <span id="frame-label"></span>
<span id="colour-box">colour <select id="colour"></select></span></div></div>
<script type="application/json" id="erosim-meta">{meta}</script>
{first_tag}<script>{first_js()}</script>
{data}{plotly_tag}<script type="text/plain" id="view-code">{view_js()}</script>
</body></html>
"""
