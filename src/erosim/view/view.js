// erosim view: the page's own script (plotly.js draws; this file decides what to draw).
// META (JSON in #erosim-meta) describes the run; arrays come base64-encoded in <script id="a-NAME">
// tags (the self-contained page) or as raw bytes from data/NAME (the local server).
(function () {
  "use strict";
  const META = JSON.parse(document.getElementById("erosim-meta").textContent);
  const G = META.grid; // null for runs without a terrain
  const cache = {};
  const traceCache = {};
  const t0 = performance.now();

  function b64(s) {
    const bin = atob(s);
    const u = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) u[i] = bin.charCodeAt(i);
    return u.buffer;
  }
  // arrays inside the page are deflated byte planes (erosim.view.page.pack): inflate, then interleave
  async function unpack(buf, size) {
    if (typeof DecompressionStream === "undefined")
      throw new Error("this browser cannot unpack the page's data (no DecompressionStream: Chrome 80, Firefox " +
                      "113, Safari 16.4 or later have it); serve the run with erosim view RUN instead");
    const z = new Blob([buf]).stream().pipeThrough(new DecompressionStream("deflate"));
    const planes = new Uint8Array(await new Response(z).arrayBuffer());
    if (size === 1) return planes.buffer;
    const n = planes.length / size, out = new Uint8Array(planes.length);
    for (let b = 0; b < size; b++) for (let i = 0, o = b; i < n; i++, o += size) out[o] = planes[b * n + i];
    return out.buffer;
  }
  function arr(name) {
    if (!cache[name]) {
      const spec = META.arrays[name];
      const tag = document.getElementById("a-" + name);
      const buf = tag
        ? unpack(b64(tag.textContent.trim()), spec.dtype === "u1" ? 1 : 4)
        : fetch("data/" + encodeURIComponent(name)).then((r) => {
            if (!r.ok) throw new Error("cannot load " + name + ": HTTP " + r.status);
            return r.arrayBuffer();
          });
      cache[name] = buf.then((b) => (spec.dtype === "u1" ? new Uint8Array(b) : new Float32Array(b)));
    }
    return cache[name];
  }

  // ---------------------------------------------------------------------------------- state
  const state = { layers: new Set(META.default_layers), detail: 256, frame: 0, colour: META.frame_fields[0], exag: 0 };
  const hash = new URLSearchParams(location.hash.slice(1));
  if (hash.has("layers")) state.layers = new Set(hash.get("layers").split(",").filter(Boolean));
  if (hash.has("detail")) state.detail = hash.get("detail") === "full" ? 1e9 : +hash.get("detail");
  if (hash.has("frame")) state.frame = +hash.get("frame");

  // the slider runs over the particle frames, else over the map frames; with both, each particle frame
  // shows the last map frame at or before its time
  const SLIDES = META.frames.length ? META.frames : META.map_frames;
  function mapFrame() {
    const M = META.map_frames;
    if (!M.length) return null;
    if (!META.frames.length) return M[Math.min(state.frame, M.length - 1)];
    const t = META.frames[state.frame].t;
    let best = M[0];
    for (const m of M) if (m.t <= t * (1 + 1e-9)) best = m;
    return best;
  }
  function heightName() {
    const m = mapFrame();
    return (m && m.arrays.height) || "height";
  }
  function valuesName(L) {
    const m = mapFrame();
    return (L.key === "water" && m && m.arrays.water) || L.array;
  }

  function stride() {
    return G ? Math.max(1, Math.ceil(Math.max(G.ny, G.nx) / state.detail)) : 1;
  }
  function exaggeration() {
    if (state.exag > 0) return state.exag;
    const w = Math.max(G.nx, G.ny) * G.cell, relief = Math.max(G.z_range[1] - G.z_range[0], 1e-9);
    return Math.max(1, Math.round((0.25 * w) / relief));
  }

  // strided 2-D rows of a flat array; fn(value, flatIndex) may turn a cell into NaN (a hole)
  function rows(a, s, fn) {
    const out = [];
    for (let i = 0; i < G.ny; i += s) {
      const r = [];
      for (let j = 0; j < G.nx; j += s) {
        const k = i * G.nx + j;
        r.push(fn ? fn(a[k], k) : a[k]);
      }
      out.push(r);
    }
    return out;
  }
  function axes(s) {
    const x = [], y = [];
    for (let j = 0; j < G.nx; j += s) x.push(j * G.cell);
    for (let i = 0; i < G.ny; i += s) y.push(G.y_top - i * G.cell);
    return { x, y };
  }

  const LIGHT = { ambient: 0.45, diffuse: 0.8, roughness: 0.9, specular: 0.05, fresnel: 0.1 };
  const LIGHTPOS = { x: -1e5, y: 1e5, z: 2e5 };

  async function terrainTrace(s) {
    const hn = heightName();
    const key = "terrain:" + s + ":" + hn;
    if (!traceCache[key]) {
      const z = await arr(hn);
      const { x, y } = axes(s);
      traceCache[key] = {
        type: "surface", name: "terrain", x, y, z: rows(z, s), surfacecolor: rows(z, s),
        colorscale: META.terrain_colorscale, cmin: G.z_range[0], cmax: G.z_range[1], showscale: false,
        lighting: LIGHT, lightposition: LIGHTPOS, hovertemplate: "height %{z:.2f} m<extra></extra>",
      };
    }
    return traceCache[key];
  }

  async function layerValues(L) {
    if (L.key === "change") {
      const [e, d] = await Promise.all([L.erosion ? arr(L.erosion) : null, L.deposition ? arr(L.deposition) : null]);
      const n = G.nx * G.ny, out = new Float32Array(n);
      for (let k = 0; k < n; k++) out[k] = (d ? d[k] : 0) - (e ? e[k] : 0);
      return out;
    }
    return arr(valuesName(L));
  }

  async function layerTrace(L, s) {
    const key = L.key + ":" + s + ":" + heightName() + ":" + valuesName(L);
    if (!traceCache[key]) {
      const [z, v] = await Promise.all([arr(heightName()), layerValues(L)]);
      const lift = G.lift;
      const shown = (val) => (L.key === "change" ? Math.abs(val) > L.hide_below : val > L.hide_below);
      const zz = rows(v, s, (val, k) => (shown(val) ? z[k] + (L.style === "water" ? val : lift) : NaN));
      const { x, y } = axes(s);
      traceCache[key] = {
        type: "surface", name: L.label, x, y, z: zz, surfacecolor: rows(v, s),
        colorscale: L.colorscale, cmin: L.cmin, cmax: L.cmax, showscale: false,
        lighting: LIGHT, lightposition: LIGHTPOS,
        hovertemplate: L.label + " %{surfacecolor:.3g} " + L.unit + "<extra></extra>",
      };
    }
    return traceCache[key];
  }

  function magnitude(v) {
    const n = v.length / 3, out = new Float32Array(n);
    for (let i = 0; i < n; i++) out[i] = Math.hypot(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
    return out;
  }

  async function particleTrace() {
    const F = META.frames[state.frame];
    if (!F) return null;
    const key = "frame:" + state.frame + ":" + state.colour;
    if (!traceCache[key]) {
      const pos = await arr(F.arrays.pos);
      const c = await arr(F.arrays[state.colour]);
      const n = pos.length / 3, x = new Float32Array(n), y = new Float32Array(n), z = new Float32Array(n);
      for (let i = 0; i < n; i++) { x[i] = pos[3 * i]; y[i] = pos[3 * i + 1]; z[i] = pos[3 * i + 2]; }
      const unit = META.field_units[state.colour] || "";
      const marker = {
        color: c, colorscale: "Viridis", size: META.particles_dim === 2 ? 4 : 2.5, showscale: true,
        cmin: META.field_ranges[state.colour][0], cmax: META.field_ranges[state.colour][1],
        colorbar: { title: { text: state.colour + (unit ? " (" + unit + ")" : "") }, len: 0.6 },
      };
      traceCache[key] = META.particles_dim === 2
        ? { type: "scattergl", mode: "markers", name: "particles", x, y, marker,
            hovertemplate: "x %{x:.3f} m, y %{y:.3f} m<br>" + state.colour + " %{marker.color:.3g} " + unit + "<extra></extra>" }
        : { type: "scatter3d", mode: "markers", name: "particles", x, y, z, marker,
            hovertemplate: state.colour + " %{marker.color:.3g} " + unit + "<extra></extra>" };
    }
    return traceCache[key];
  }

  function layout(first) {
    const box = { height: gd.clientHeight || 600, width: gd.clientWidth || 800 };
    const L = Object.assign(baseLayout(), box);
    if (first && L.scene) {
      // the first picture goes without tick labels and axis titles: plotly.js turns every label into
      // triangles (drawing it on a canvas and reading the pixels back), which costs most of a second
      // with software WebGL; they come with the layers, one draw later
      for (const a of ["xaxis", "yaxis", "zaxis"])
        L.scene[a] = Object.assign({}, L.scene[a] || {}, { tickvals: [], ticktext: [], title: { text: "" } });
    }
    return L;
  }
  function baseLayout() {
    if (!G) {
      if (META.particles_dim === 2)
        return { margin: { l: 50, r: 10, t: 10, b: 40 }, uirevision: "keep", showlegend: false,
                 xaxis: { title: { text: "x (m)" } }, yaxis: { title: { text: "y (m)" }, scaleanchor: "x" } };
      return { margin: { l: 0, r: 0, t: 0, b: 0 }, uirevision: "keep", showlegend: false, scene: { aspectmode: "data" } };
    }
    const w = G.nx * G.cell, h = G.ny * G.cell, m = Math.max(w, h);
    const zr = ((G.z_range[1] - G.z_range[0]) * exaggeration()) / m;
    return {
      margin: { l: 0, r: 0, t: 0, b: 0 }, uirevision: "keep", showlegend: false,
      scene: {
        aspectmode: "manual", aspectratio: { x: w / m, y: h / m, z: Math.max(zr, 0.01) },
        xaxis: { title: { text: "east (m)" } }, yaxis: { title: { text: "north (m)" } },
        zaxis: { title: { text: "height (m)" } },
        camera: { eye: { x: -0.9, y: -1.5, z: 1.1 } },
      },
    };
  }

  const gd = document.getElementById("plot");
  // plotly draws its WebGL scenes at twice the screen's pixels by default; software WebGL (a machine
  // without a GPU) pays for every pixel, so draw at the screen's own density
  const CONFIG = { responsive: true, displaylogo: false,
                   plotGlPixelRatio: Math.min(2, Math.max(1, window.devicePixelRatio || 1)) };
  let drawing = Promise.resolve();
  const times = (window.erosimTimes = { script: t0 });
  // first: the terrain alone at a coarse stride (the first picture comes fast), then what is chosen
  async function draw(first) {
    const s = first ? Math.max(stride(), Math.ceil(Math.max(G.ny, G.nx) / 128)) : stride();
    const data = [];
    if (G) {
      data.push(await terrainTrace(s));
      if (!first) for (const L of META.layers) if (state.layers.has(L.key)) data.push(await layerTrace(L, s));
    }
    const p = await particleTrace();
    if (p) data.push(p);
    times.traces = times.traces || performance.now();
    await Plotly.react(gd, data, layout(first), CONFIG);
    const preview = document.getElementById("preview");
    if (preview) preview.remove(); // the plan-view picture shown while plotly.js loaded
    const firstPicture = document.getElementById("first3d");
    if (firstPicture) firstPicture.remove(); // and first.js's 3-D picture
    times.plot = times.plot || performance.now();
    document.body.dataset.draws = (+(document.body.dataset.draws || 0) + 1).toString();
    legends();
    document.getElementById("exag").textContent = G ? "×" + exaggeration() : "";
  }
  // requests made while a draw waits merge into it (it reads the state when it starts), so sliding
  // through frames faster than they draw shows the latest frame instead of a backlog
  let queued = false;
  function redraw(first) {
    if (!first && queued) return drawing;
    if (!first) queued = true;
    drawing = drawing
      .then(() => { if (!first) queued = false; return draw(first); })
      .catch((e) => { document.getElementById("status").textContent = String(e); });
    return drawing;
  }


  // ------------------------------------------------------------------- the view while sliding
  // Redrawing the 3-D scene costs a second or more in software WebGL, so while the slider moves the
  // frame shows on a plan view drawn into a 2-D canvas (shaded relief coloured by height, the water
  // and the particles), and the 3-D scene is drawn again when the slider is let go.
  function hexRGB(h) { return [1, 3, 5].map((i) => parseInt(h.slice(i, i + 2), 16)); }
  function lut(cs) { // 256 colours along a plotly colour scale
    const out = new Uint8ClampedArray(256 * 3);
    for (let i = 0; i < 256; i++) {
      const t = i / 255;
      let k = 0;
      while (k < cs.length - 2 && t > cs[k + 1][0]) k++;
      const [t0, c0] = cs[k], [t1, c1] = cs[k + 1], a = hexRGB(c0), b = hexRGB(c1);
      const f = t1 > t0 ? Math.min(1, Math.max(0, (t - t0) / (t1 - t0))) : 0;
      for (let c = 0; c < 3; c++) out[3 * i + c] = a[c] + f * (b[c] - a[c]);
    }
    return out;
  }
  const VIRIDIS = [[0, "#440154"], [0.25, "#3b528b"], [0.5, "#21918c"], [0.75, "#5ec962"], [1, "#fde725"]];
  let slideBox = null; // particle bounds of runs without a terrain, grown as frames are seen
  let slideN = 0;
  async function slide2d() {
    const n = ++slideN;
    let cv = document.getElementById("slide");
    if (!cv) {
      cv = document.createElement("canvas");
      cv.id = "slide";
      gd.appendChild(cv);
    }
    const W = gd.clientWidth || 800, H = gd.clientHeight || 600;
    const F = META.frames[state.frame];
    const pos = F ? await arr(F.arrays.pos) : null;
    const col = F ? await arr(F.arrays[state.colour]) : null;
    let s = 1, nx, ny, img = null, toPix;
    if (G) {
      s = Math.max(1, Math.ceil(Math.max(G.ny, G.nx) / 512));
      nx = Math.ceil(G.nx / s); ny = Math.ceil(G.ny / s);
      const z = await arr(heightName());
      const wL = META.layers.find((L) => L.key === "water");
      const w = wL && state.layers.has("water") ? await arr(valuesName(wL)) : null;
      if (n !== slideN) return; // a newer frame is on its way
      img = new ImageData(nx, ny);
      const T = lut(META.terrain_colorscale), B = wL ? lut(wL.colorscale) : null;
      const z0 = G.z_range[0], dz = Math.max(G.z_range[1] - z0, 1e-9), d = 2 * G.cell * s, ex = exaggeration();
      for (let i = 0; i < ny; i++) {
        const r = i * s, up = Math.max(r - s, 0) * G.nx, dn = Math.min(r + s, G.ny - 1) * G.nx;
        for (let j = 0; j < nx; j++) {
          const c = j * s, k = r * G.nx + c, o = 4 * (i * nx + j);
          const gx = (z[r * G.nx + Math.min(c + s, G.nx - 1)] - z[r * G.nx + Math.max(c - s, 0)]) * ex / d;
          const gy = (z[up + c] - z[dn + c]) * ex / d; // north minus south
          // light from the north-west, 45° up (Lambert): n·l with n ∝ (−gx, −gy, 1)
          const shade = Math.max(0.25, (gx * -0.5 + gy * 0.5 + 0.7071) / Math.sqrt(1 + gx * gx + gy * gy) * 1.2);
          let q = Math.max(0, Math.min(255, ((z[k] - z0) / dz) * 255)) | 0;
          let rgb = [T[3 * q], T[3 * q + 1], T[3 * q + 2]];
          if (w && w[k] > wL.hide_below) {
            q = Math.max(0, Math.min(255, (w[k] / Math.max(wL.cmax, 1e-9)) * 255)) | 0;
            rgb = [B[3 * q], B[3 * q + 1], B[3 * q + 2]];
          }
          img.data[o] = rgb[0] * shade; img.data[o + 1] = rgb[1] * shade; img.data[o + 2] = rgb[2] * shade;
          img.data[o + 3] = 255;
        }
      }
      toPix = (x, y) => [x / (G.cell * s), (G.y_top - y) / (G.cell * s)];
    } else {
      if (!pos) return;
      let [x0, x1, y0, y1] = slideBox || [Infinity, -Infinity, Infinity, -Infinity];
      for (let i = 0; i < pos.length; i += 3) {
        x0 = Math.min(x0, pos[i]); x1 = Math.max(x1, pos[i]); y0 = Math.min(y0, pos[i + 1]); y1 = Math.max(y1, pos[i + 1]);
      }
      slideBox = [x0, x1, y0, y1];
      const span = Math.max(x1 - x0, y1 - y0, 1e-9);
      nx = Math.max(2, Math.round((512 * (x1 - x0)) / span)); ny = Math.max(2, Math.round((512 * (y1 - y0)) / span));
      toPix = (x, y) => [((x - x0) / span) * 511, ((y1 - y) / span) * 511];
    }
    if (n !== slideN) return;
    if (!img) { img = new ImageData(nx, ny); img.data.fill(255); }
    if (pos) { // particles as small squares written into the picture (one putImageData for all)
      const V = lut(VIRIDIS), [lo, hi] = META.field_ranges[state.colour] || [0, 1], D = img.data;
      const r = Math.max(1, Math.round(Math.max(nx, ny) / 400)), span = Math.max(hi - lo, 1e-30);
      for (let i = 0; i < pos.length / 3; i++) {
        const q = (Math.max(0, Math.min(255, ((col[i] - lo) / span) * 255)) | 0) * 3;
        const [px, py] = toPix(pos[3 * i], pos[3 * i + 1]);
        const x0 = Math.max(0, Math.round(px - r / 2)), y0 = Math.max(0, Math.round(py - r / 2));
        for (let y = y0; y < Math.min(ny, y0 + r); y++) {
          for (let x = x0; x < Math.min(nx, x0 + r); x++) {
            const o = 4 * (y * nx + x);
            D[o] = V[q]; D[o + 1] = V[q + 1]; D[o + 2] = V[q + 2]; D[o + 3] = 255;
          }
        }
      }
    }
    cv.width = nx; cv.height = ny;
    cv.getContext("2d").putImageData(img, 0, 0);
    cv.style.display = "block";
    document.body.dataset.slides = (+(document.body.dataset.slides || 0) + 1).toString();
  }
  function hideSlide() {
    const cv = document.getElementById("slide");
    if (cv) cv.style.display = "none";
  }

  // ------------------------------------------------------------------------------- controls
  function gradient(cs) {
    return "linear-gradient(to right," + cs.map((c) => c[1] + " " + c[0] * 100 + "%").join(",") + ")";
  }
  function legends() {
    const el = document.getElementById("legends");
    el.innerHTML = "";
    for (const L of META.layers) {
      if (!state.layers.has(L.key)) continue;
      const d = document.createElement("div");
      d.className = "legend";
      if (L.classes) {
        d.innerHTML = "<b>" + L.label + "</b> " + L.classes.map((c) =>
          '<span class="sw" style="background:' + c[1] + '"></span>' + c[0]).join(" ");
      } else {
        d.innerHTML = "<b>" + L.label + "</b> (" + L.unit + ")<div class='bar' style='background:" +
          gradient(L.colorscale) + "'></div><span>" + L.cmin.toPrecision(3) + "</span><span style='float:right'>" +
          L.cmax.toPrecision(3) + "</span>";
      }
      el.appendChild(d);
    }
  }

  function controls() {
    const box = document.getElementById("layers");
    for (const L of META.layers) {
      const id = "layer-" + L.key;
      const lab = document.createElement("label");
      lab.innerHTML = '<input type="checkbox" id="' + id + '"> ' + L.label;
      box.appendChild(lab);
      const cb = lab.querySelector("input");
      cb.checked = state.layers.has(L.key);
      cb.addEventListener("change", () => {
        if (cb.checked) state.layers.add(L.key); else state.layers.delete(L.key);
        redraw();
      });
    }
    if (!G) document.getElementById("view-box").style.display = "none";
    if (!META.layers.length) box.textContent = G ? "this run wrote no maps besides its height" : "no terrain in this run";
    const det = document.getElementById("detail");
    det.value = state.detail >= 1e9 ? "full" : String(state.detail);
    det.addEventListener("change", () => { state.detail = det.value === "full" ? 1e9 : +det.value; redraw(); });
    const ex = document.getElementById("exag-select");
    ex.addEventListener("change", () => { state.exag = +ex.value; redraw(); });
    const sl = document.getElementById("frame"), lab = document.getElementById("frame-label");
    if (SLIDES.length) {
      state.frame = Math.max(0, Math.min(state.frame, SLIDES.length - 1));
      sl.max = SLIDES.length - 1;
      sl.value = state.frame;
      const show = () => {
        const F = SLIDES[state.frame];
        lab.textContent = "t = " + F.t.toPrecision(4) + " " + META.time_unit + "  (" + (state.frame + 1) + "/" +
          SLIDES.length + (F.n !== undefined ? ", " + F.n + " particles shown" : ", " + Object.keys(F.arrays).join(" and ")) + ")" +
          (!META.frames.length && META.map_frames_note ? " — " + META.map_frames_note : "");
      };
      show();
      // while sliding: the plan view of the frame (fast); let go (or a key step): the 3-D scene again
      sl.addEventListener("input", () => { state.frame = +sl.value; show(); slide2d(); });
      sl.addEventListener("change", () => { state.frame = +sl.value; show(); redraw().then(() => { if (!queued) hideSlide(); }); });
      const col = document.getElementById("colour");
      if (META.frames.length) {
        for (const f of META.frame_fields) col.add(new Option(f, f));
        col.addEventListener("change", () => { state.colour = col.value; redraw(); });
      } else {
        document.getElementById("colour-box").style.display = "none";
      }
    } else {
      document.getElementById("time").innerHTML = "<i>No frames saved: the final state.</i>";
    }
  }

  // values under the cursor: read every map at the cell under the pointer
  async function hover(ev) {
    const pt = ev.points && ev.points[0];
    if (!pt) return;
    const out = document.getElementById("cursor");
    if (!G || pt.data.name === "particles") {
      const mc = pt["marker.color"] !== undefined ? pt["marker.color"] : undefined;
      out.innerHTML = "x " + (+pt.x).toFixed(3) + " m, y " + (+pt.y).toFixed(3) + " m" +
        (pt.z !== undefined ? ", z " + (+pt.z).toFixed(3) + " m" : "") +
        (mc !== undefined ? "<br>" + state.colour + " " + (+mc).toPrecision(4) : "");
      return;
    }
    const j = Math.round(pt.x / G.cell), i = Math.round((G.y_top - pt.y) / G.cell);
    if (i < 0 || j < 0 || i >= G.ny || j >= G.nx) return;
    const k = i * G.nx + j, col = j * G.step, row = i * G.step, t = G.transform;
    let html = "";
    if (t) {
      const X = t[0] * (col + 0.5) + t[1] * (row + 0.5) + t[2], Y = t[3] * (col + 0.5) + t[4] * (row + 0.5) + t[5];
      html += "<b>" + X.toFixed(2) + ", " + Y.toFixed(2) + "</b> " + (G.crs || "(no CRS)") + "<br>";
    }
    html += "row " + row + ", column " + col + "<br>";
    const water = META.layers.find((L) => L.key === "water");
    for (const v of META.values) {
      const name = v.array === "height" ? heightName() : water && v.array === water.array ? valuesName(water) : v.array;
      const a = await arr(name);
      const val = a[k];
      const txt = v.classes ? (val ? "class " + val : "dry") : (+val).toPrecision(4) + " " + v.unit;
      html += v.label + ": " + txt + "<br>";
    }
    out.innerHTML = html;
  }

  controls();
  // times since the page was requested (navigation start): data-first-paint-ms is the first picture
  // (first.js's, or this file's first plotly draw), data-plot-ms the first interactive plotly scene
  const painted = () => {
    const ms = performance.now().toFixed(0);
    if (!document.body.hasAttribute("data-plot-ms")) document.body.setAttribute("data-plot-ms", ms);
    if (!document.body.hasAttribute("data-first-paint-ms")) document.body.setAttribute("data-first-paint-ms", ms);
  };
  // with first.js's picture on the screen, plotly sets up one scene (terrain, layers, axes) instead of a
  // coarse one first: everything is drawn about a second and a half sooner
  if (G && !document.getElementById("first3d")) redraw(true).then(painted);
  redraw().then(() => {
    painted();
    const ms = performance.now();
    document.body.setAttribute("data-ready-ms", ms.toFixed(0));
    const at = (a) => (+document.body.getAttribute(a) / 1000).toFixed(2);
    document.getElementById("status").textContent = "first picture " + at("data-first-paint-ms") +
      " s, interactive " + at("data-plot-ms") + " s, all drawn " + (ms / 1000).toFixed(2) + " s after opening";
    gd.on("plotly_hover", hover);
    window.addEventListener("resize", () => redraw());
    if (hash.has("slide") && SLIDES.length) { // #slide=k: the plan view shown while sliding, at frame k
      state.frame = Math.max(0, Math.min(+hash.get("slide"), SLIDES.length - 1));
      slide2d();
    }
    if (hash.has("probe") && G) {  // #probe=row,col: show the values of that cell (for tests and links)
      const [i, j] = hash.get("probe").split(",").map(Number);
      hover({ points: [{ x: j * G.cell, y: G.y_top - i * G.cell, data: { name: "terrain" } }] }).then(() =>
        document.body.setAttribute("data-probe", "done"));
    }
  });
})();
