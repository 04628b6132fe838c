// erosim view: the first picture of the terrain in 3-D, drawn before plotly.js is read.
// Why by hand: plotly.js is 4.6 MB of JavaScript; reading it and setting up its WebGL scene takes one
// to three seconds on a machine without a GPU (software WebGL), most of it before anything shows. This
// file draws the terrain's coarse copy (META.first: at most 128 cells a side, inside the page) as a lit
// mesh with plain WebGL — one shader pair, vertex colours — from plotly's starting camera, then loads
// plotly.js and view.js, which draw the interactive scene over it. Without WebGL the plan-view picture
// stays instead.
(function () {
  "use strict";
  const META = JSON.parse(document.getElementById("erosim-meta").textContent);
  const F = META.first;

  function load() { // plotly.js, then view.js: inside the page (text blocks) or from the local server
    // this script runs before the page's data blocks are read (a self-contained page is tens of MB):
    // plotly.js and view.js come after them, so wait for the whole page
    if (document.readyState === "loading") return document.addEventListener("DOMContentLoaded", load);
    const add = (code, src, then) => {
      const s = document.createElement("script");
      if (src) { s.src = src; s.onload = then; } else { s.textContent = code; }
      document.body.appendChild(s);
      if (!src && then) then();
    };
    const view = () => add(document.getElementById("view-code").textContent);
    const inline = document.getElementById("plotly-code");
    if (inline) add(inline.textContent, null, view); else add(null, "plotly.min.js", view);
  }
  // plotly.js is read two frames after the picture is drawn, so the picture is on the screen first
  // (and at the latest after 250 ms: a page opened in a background tab gets no animation frames)
  let loaded = false;
  const go = () => { if (!loaded) { loaded = true; load(); } };
  const later = (drawn) => {
    if (!drawn) return setTimeout(go, 0);
    requestAnimationFrame(() => requestAnimationFrame(() => setTimeout(go, 0)));
    setTimeout(go, 250);
  };

  function draw() {
    const box = document.getElementById("plot");
    const W = box.clientWidth || 800, H = box.clientHeight || 600;
    const cv = document.createElement("canvas");
    cv.id = "first3d";
    cv.width = W; cv.height = H;
    const gl = cv.getContext("webgl", { antialias: true, preserveDrawingBuffer: true });
    if (!gl) return false;
    const bin = atob(document.getElementById("first-height").textContent.trim());
    const u8 = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
    const z = new Float32Array(u8.buffer), ny = F.ny, nx = F.nx, n = ny * nx;
    // plotly's box: x and y spans in proportion, z scaled by the vertical exaggeration; the eye where
    // view.js puts plotly's camera (eye −0.9, −1.5, 1.1 of the box, looking at its centre)
    const w = (nx - 1) * F.cell, h = (ny - 1) * F.cell, m = Math.max(w, h);
    const z0 = F.z_range[0], relief = Math.max(F.z_range[1] - z0, 1e-9);
    const ex = Math.max(1, Math.round((0.25 * Math.max(nx, ny) * F.cell) / relief));
    const az = Math.max((relief * ex) / m, 0.01), ax = w / m, ay = h / m;
    const pos = new Float32Array(3 * n), col = new Float32Array(3 * n);
    const lut = F.colorscale.map(([t, c]) => [t, [1, 3, 5].map((k) => parseInt(c.slice(k, k + 2), 16) / 255)]);
    const colour = (t) => {
      let k = 0;
      while (k < lut.length - 2 && t > lut[k + 1][0]) k++;
      const [t0, a] = lut[k], [t1, b] = lut[k + 1], f = Math.min(1, Math.max(0, (t - t0) / (t1 - t0 || 1)));
      return [0, 1, 2].map((c) => a[c] + f * (b[c] - a[c]));
    };
    const L = [-0.408, 0.408, 0.816]; // toward plotly's light (view.js LIGHTPOS), normalised
    const dx = F.cell, zs = az / relief; // metres of height → box units
    for (let i = 0; i < ny; i++) {
      for (let j = 0; j < nx; j++) {
        const k = i * nx + j, v = z[k];
        pos[3 * k] = (j / Math.max(nx - 1, 1) - 0.5) * ax;
        pos[3 * k + 1] = (0.5 - i / Math.max(ny - 1, 1)) * ay; // row 0 is the north edge
        pos[3 * k + 2] = ((v - z0) / relief - 0.5) * az;
        // normal of the exaggerated surface: (−∂z/∂x, −∂z/∂y, 1), central differences
        const e = z[i * nx + Math.min(j + 1, nx - 1)], wv = z[i * nx + Math.max(j - 1, 0)];
        const no = z[Math.max(i - 1, 0) * nx + j], so = z[Math.min(i + 1, ny - 1) * nx + j];
        const gx = ((e - wv) * ex) / (2 * dx), gy = ((no - so) * ex) / (2 * dx);
        const len = Math.hypot(gx, gy, 1);
        const lam = Math.max(0, (-gx * L[0] - gy * L[1] + L[2]) / len);
        const c = colour((v - z0) / relief), s = Math.min(1.1, 0.45 + 0.8 * lam);
        col[3 * k] = c[0] * s; col[3 * k + 1] = c[1] * s; col[3 * k + 2] = c[2] * s;
      }
    }
    const idx = new Uint16Array(6 * (ny - 1) * (nx - 1));
    let q = 0;
    for (let i = 0; i < ny - 1; i++) {
      for (let j = 0; j < nx - 1; j++) {
        const a = i * nx + j;
        idx.set([a, a + 1, a + nx, a + 1, a + nx + 1, a + nx], q);
        q += 6;
      }
    }
    // camera: plotly's eye (−0.9, −1.5, 1.1) about the box centre, z up, 45° field of view
    const eye = [-0.9, -1.5, 1.1], f = normal(eye.map((c) => -c)), up = [0, 0, 1];
    const s = normal(cross(f, up)), u = cross(s, f);
    const view = [s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
      -dot(s, eye), -dot(u, eye), dot(f, eye), 1];
    const t = 1 / Math.tan(Math.PI / 8), near = 0.01, far = 100;
    const proj = [t / (W / H), 0, 0, 0, 0, t, 0, 0, 0, 0, (far + near) / (near - far), -1, 0, 0,
      (2 * far * near) / (near - far), 0];
    const vs = "attribute vec3 p; attribute vec3 c; uniform mat4 V, P; varying vec3 vc;" +
      "void main(){ vc = c; gl_Position = P * V * vec4(p, 1.0); }";
    const fs = "precision mediump float; varying vec3 vc; void main(){ gl_FragColor = vec4(vc, 1.0); }";
    const prog = gl.createProgram();
    for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
      const sh = gl.createShader(type);
      gl.shaderSource(sh, src);
      gl.compileShader(sh);
      gl.attachShader(prog, sh);
    }
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) return false;
    gl.useProgram(prog);
    for (const [name, data] of [["p", pos], ["c", col]]) {
      const b = gl.createBuffer(), loc = gl.getAttribLocation(prog, name);
      gl.bindBuffer(gl.ARRAY_BUFFER, b);
      gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
      gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, 3, gl.FLOAT, false, 0, 0);
    }
    const ib = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, idx, gl.STATIC_DRAW);
    gl.uniformMatrix4fv(gl.getUniformLocation(prog, "V"), false, view);
    gl.uniformMatrix4fv(gl.getUniformLocation(prog, "P"), false, proj);
    gl.viewport(0, 0, W, H);
    gl.clearColor(1, 1, 1, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.drawElements(gl.TRIANGLES, idx.length, gl.UNSIGNED_SHORT, 0);
    const img = document.getElementById("preview");
    if (img) img.style.display = "none";
    box.appendChild(cv);
    return true;
  }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function normal(a) { const l = Math.hypot(a[0], a[1], a[2]); return a.map((c) => c / l); }

  let drawn = false;
  try { drawn = !!F && draw(); } catch (e) { drawn = false; }
  if (drawn) document.body.setAttribute("data-first-paint-ms", performance.now().toFixed(0));
  document.body.setAttribute("data-first-picture", drawn ? "3-D" : "plan view");
  later(drawn);
})();
