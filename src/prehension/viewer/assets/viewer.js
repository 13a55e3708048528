/* prehension grasp viewer: a small Canvas2D renderer for one scene (no WebGL, no network).
 *
 * The scene (JSON in #scene-data) holds layers of triangle meshes, polylines, points and
 * arrows in the palm frame [mm].  Every frame the triangles of the visible layers are
 * projected orthographically, flat-shaded (Lambert, a light fixed to the camera) and drawn
 * back to front (painter's algorithm); "on top" layers (contacts, frames) are drawn last.
 * The camera turns about the scene's centre like matplotlib's (elev, azim), z up.
 */
(function () {
  "use strict";

  var scene = JSON.parse(document.getElementById("scene-data").textContent);
  var BACKGROUND = scene.lighting.background;
  var LIGHT_VIEW = normalize(scene.lighting.lightInCamera); // towards the light: right, up, towards the viewer
  var AMBIENT = scene.lighting.ambient;
  var SHADE_LEVELS = 48;
  var SEAM_PX = 0.8; // opaque triangles are outlined this wide in their own colour: no hairline seams
  var canvas = document.getElementById("view");
  var ctx = canvas.getContext("2d");
  if (!ctx) { throw new Error("this browser gives no 2-D canvas"); }

  // ---- small vector helpers -----------------------------------------------------------
  function normalize(v) {
    var n = Math.hypot(v[0], v[1], v[2]) || 1;
    return [v[0] / n, v[1] / n, v[2] / n];
  }
  function parseColor(hex) {
    var n = parseInt(hex.slice(1), 16);
    return [(n >> 16) & 255, (n >> 8) & 255, n & 255];
  }

  // ---- geometry, prepared once ----------------------------------------------------------
  var geo = buildGeometry(scene.layers);

  function buildGeometry(layers) {
    var nv = 0, nf = 0;
    layers.forEach(function (layer) {
      layer.meshes.forEach(function (m) { nv += m.v.length / 3; nf += m.f.length / 3; });
    });
    var g = {
      pos: new Float64Array(3 * nv), tri: new Uint32Array(3 * nf), normal: new Float64Array(3 * nf),
      triMesh: new Uint32Array(nf), meshes: [], screen: new Float64Array(3 * nv),
      order: new Uint32Array(nf), depth: new Float64Array(nf), shade: new Uint8Array(nf)
    };
    var v0 = 0, f0 = 0;
    layers.forEach(function (layer) {
      layer.meshes.forEach(function (m) {
        g.pos.set(m.v, 3 * v0);
        for (var k = 0; k < m.f.length; k++) { g.tri[3 * f0 + k] = m.f[k] + v0; }
        var id = g.meshes.length;
        g.meshes.push({ layer: layer, rgb: parseColor(m.color), opacity: m.opacity, closed: m.closed, styles: [] });
        for (var t = 0; t < m.f.length / 3; t++) { g.triMesh[f0 + t] = id; }
        v0 += m.v.length / 3;
        f0 += m.f.length / 3;
      });
    });
    computeNormals(g, nf);
    return g;
  }

  function computeNormals(g, nf) {
    var P = g.pos, T = g.tri;
    for (var t = 0; t < nf; t++) {
      var a = 3 * T[3 * t], b = 3 * T[3 * t + 1], c = 3 * T[3 * t + 2];
      var ux = P[b] - P[a], uy = P[b + 1] - P[a + 1], uz = P[b + 2] - P[a + 2];
      var vx = P[c] - P[a], vy = P[c + 1] - P[a + 1], vz = P[c + 2] - P[a + 2];
      var n = normalize([uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx]);
      g.normal[3 * t] = n[0]; g.normal[3 * t + 1] = n[1]; g.normal[3 * t + 2] = n[2];
    }
  }

  // ---- camera -----------------------------------------------------------------------------
  var lo = scene.bounds.lo, hi = scene.bounds.hi;
  var center = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
  var cam = {};

  function resetCamera() {
    cam.elev = scene.view.elev;
    cam.azim = scene.view.azim;
    cam.panX = 0;
    cam.panY = 0;
    cam.scale = fitScale();
  }

  function basis() { // screen right, screen up, towards the viewer (world coordinates)
    var e = cam.elev * Math.PI / 180, a = cam.azim * Math.PI / 180;
    return {
      x: [-Math.sin(a), Math.cos(a), 0],
      y: [-Math.sin(e) * Math.cos(a), -Math.sin(e) * Math.sin(a), Math.cos(e)],
      z: [Math.cos(e) * Math.cos(a), Math.cos(e) * Math.sin(a), Math.sin(e)]
    };
  }

  function viewport() {
    var panel = document.getElementById("panel");
    var left = (window.innerWidth > 760 && panel && !panel.classList.contains("collapsed")) ? panel.offsetWidth + 20 : 0;
    return { left: left, width: Math.max(50, window.innerWidth - left), height: Math.max(50, window.innerHeight) };
  }

  function fitScale() { // px per mm that fits the bounding box in the free part of the window
    var B = basis(), vp = viewport(), w = 0, h = 0;
    for (var i = 0; i < 8; i++) {
      var p = [i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1], i & 4 ? hi[2] : lo[2]];
      var d = [p[0] - center[0], p[1] - center[1], p[2] - center[2]];
      w = Math.max(w, Math.abs(dot(d, B.x)));
      h = Math.max(h, Math.abs(dot(d, B.y)));
    }
    return 0.88 * Math.min(vp.width / (2 * w || 1), vp.height / (2 * h || 1));
  }

  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

  function origin() { // screen position of the scene centre
    var vp = viewport();
    return [vp.left + vp.width / 2 + cam.panX, vp.height / 2 + cam.panY];
  }

  function project(p, B, o) { // world point -> [x px, y px, depth mm (larger: nearer)]
    var d = [p[0] - center[0], p[1] - center[1], p[2] - center[2]];
    return [o[0] + cam.scale * dot(d, B.x), o[1] - cam.scale * dot(d, B.y), dot(d, B.z)];
  }

  // ---- drawing ------------------------------------------------------------------------------
  function projectVertices(B, o) {
    var P = geo.pos, S = geo.screen, s = cam.scale;
    for (var i = 0; i < P.length; i += 3) {
      var dx = P[i] - center[0], dy = P[i + 1] - center[1], dz = P[i + 2] - center[2];
      S[i] = o[0] + s * (dx * B.x[0] + dy * B.x[1] + dz * B.x[2]);
      S[i + 1] = o[1] - s * (dx * B.y[0] + dy * B.y[1] + dz * B.y[2]);
      S[i + 2] = dx * B.z[0] + dy * B.z[1] + dz * B.z[2];
    }
  }

  function collectTriangles(B) { // visible, front-facing triangles with their shade; returns count
    var L = [LIGHT_VIEW[0] * B.x[0] + LIGHT_VIEW[1] * B.y[0] + LIGHT_VIEW[2] * B.z[0],
             LIGHT_VIEW[0] * B.x[1] + LIGHT_VIEW[1] * B.y[1] + LIGHT_VIEW[2] * B.z[1],
             LIGHT_VIEW[0] * B.x[2] + LIGHT_VIEW[1] * B.y[2] + LIGHT_VIEW[2] * B.z[2]];
    var N = geo.normal, T = geo.tri, S = geo.screen, count = 0;
    for (var t = 0; t < geo.triMesh.length; t++) {
      var mesh = geo.meshes[geo.triMesh[t]];
      if (!mesh.layer.visible) { continue; }
      var nz = N[3 * t] * B.z[0] + N[3 * t + 1] * B.z[1] + N[3 * t + 2] * B.z[2];
      if (mesh.closed && nz < 0) { continue; }
      var sign = nz < 0 ? -1 : 1; // two-sided lighting for open surfaces
      var lambert = Math.max(0, sign * (N[3 * t] * L[0] + N[3 * t + 1] * L[1] + N[3 * t + 2] * L[2]));
      geo.shade[t] = Math.round((SHADE_LEVELS - 1) * (AMBIENT + (1 - AMBIENT) * lambert));
      geo.depth[t] = S[3 * T[3 * t] + 2] + S[3 * T[3 * t + 1] + 2] + S[3 * T[3 * t + 2] + 2];
      geo.order[count++] = t;
    }
    return count;
  }

  function style(mesh, level) {
    if (!mesh.styles[level]) {
      var k = level / (SHADE_LEVELS - 1), c = mesh.rgb;
      mesh.styles[level] = "rgba(" + Math.round(c[0] * k) + "," + Math.round(c[1] * k) + "," +
        Math.round(c[2] * k) + "," + mesh.opacity + ")";
    }
    return mesh.styles[level];
  }

  function drawTriangles(order, n) { // consecutive triangles of one colour share a path
    var S = geo.screen, T = geo.tri, current = null, outline = false;
    ctx.lineWidth = SEAM_PX;
    ctx.lineJoin = "round";
    for (var i = 0; i < n; i++) {
      var t = order[i], mesh = geo.meshes[geo.triMesh[t]], color = style(mesh, geo.shade[t]);
      if (color !== current) {
        flush(current, outline);
        current = color;
        outline = mesh.opacity >= 1 && !quick; // outlines hide hairline seams; skipped while dragging
        ctx.beginPath();
      }
      var a = 3 * T[3 * t], b = 3 * T[3 * t + 1], c = 3 * T[3 * t + 2];
      ctx.moveTo(S[a], S[a + 1]);
      ctx.lineTo(S[b], S[b + 1]);
      ctx.lineTo(S[c], S[c + 1]);
      ctx.closePath();
    }
    flush(current, outline);
  }

  function flush(color, outline) {
    if (color === null) { return; }
    ctx.fillStyle = color;
    ctx.fill();
    if (outline) { ctx.strokeStyle = color; ctx.stroke(); }
  }

  function drawLine(line, B, o) {
    var p = line.p, first = true;
    ctx.strokeStyle = line.color;
    ctx.lineWidth = line.width;
    ctx.setLineDash(line.dashed ? [6, 4] : []);
    ctx.beginPath();
    for (var i = 0; i < p.length; i += 3) {
      var q = project([p[i], p[i + 1], p[i + 2]], B, o);
      if (first) { ctx.moveTo(q[0], q[1]); first = false; } else { ctx.lineTo(q[0], q[1]); }
    }
    ctx.stroke();
    ctx.setLineDash([]);
  }

  function drawArrows(set, B, o) {
    for (var i = 0; i < set.o.length; i += 3) {
      var a = project([set.o[i], set.o[i + 1], set.o[i + 2]], B, o);
      var b = project([set.o[i] + set.d[i], set.o[i + 1] + set.d[i + 1], set.o[i + 2] + set.d[i + 2]], B, o);
      arrow2d(a, b, set.color);
    }
  }

  function arrow2d(a, b, color) {
    var dx = b[0] - a[0], dy = b[1] - a[1], n = Math.hypot(dx, dy);
    ctx.strokeStyle = color;
    ctx.fillStyle = color;
    ctx.lineWidth = 2.5;
    ctx.beginPath();
    ctx.moveTo(a[0], a[1]);
    ctx.lineTo(b[0], b[1]);
    ctx.stroke();
    if (n < 1) { return; }
    var ux = dx / n, uy = dy / n, head = Math.min(12, 0.45 * n);
    ctx.beginPath();
    ctx.moveTo(b[0] + 2 * ux, b[1] + 2 * uy);
    ctx.lineTo(b[0] - head * ux - 0.45 * head * uy, b[1] - head * uy + 0.45 * head * ux);
    ctx.lineTo(b[0] - head * ux + 0.45 * head * uy, b[1] - head * uy - 0.45 * head * ux);
    ctx.closePath();
    ctx.fill();
  }

  function drawPoints(set, B, o) {
    ctx.fillStyle = set.color;
    ctx.strokeStyle = "#ffffff";
    ctx.lineWidth = 1.5;
    for (var i = 0; i < set.p.length; i += 3) {
      var q = project([set.p[i], set.p[i + 1], set.p[i + 2]], B, o);
      ctx.beginPath();
      ctx.arc(q[0], q[1], set.size / 2, 0, 2 * Math.PI);
      ctx.fill();
      ctx.stroke();
    }
  }

  function drawMarkers(layer, B, o) {
    layer.lines.forEach(function (l) { drawLine(l, B, o); });
    layer.arrows.forEach(function (a) { drawArrows(a, B, o); });
    layer.points.forEach(function (p) { drawPoints(p, B, o); });
  }

  function drawScene() {
    var t0 = performance.now(), B = basis(), o = origin();
    var w = window.innerWidth, h = window.innerHeight;
    ctx.fillStyle = BACKGROUND;
    ctx.fillRect(0, 0, w, h);
    projectVertices(B, o);
    var n = collectTriangles(B);
    var order = geo.order.subarray(0, n), depth = geo.depth;
    order.sort(function (a, b) { return depth[a] - depth[b]; }); // far (small depth) first
    drawTriangles(order, n);
    scene.layers.forEach(function (l) { if (l.visible && !l.onTop) { drawMarkers(l, B, o); } });
    scene.layers.forEach(function (l) { if (l.visible && l.onTop) { drawMarkers(l, B, o); } });
    drawAxesGizmo(B, w, h);
    drawScaleBar(w, h);
    reportDrawn(n, performance.now() - t0);
  }

  // ---- overlays: orientation axes and a scale bar -------------------------------------
  function drawAxesGizmo(B, w, h) {
    var c = [w - 70, h - 110], names = ["x", "y", "z"], colors = ["#d62728", "#2ca02c", "#1f77b4"];
    var axes = [0, 1, 2].map(function (k) {
      var e = [0, 0, 0];
      e[k] = 1;
      return { k: k, sx: dot(e, B.x), sy: dot(e, B.y), depth: dot(e, B.z) };
    }).sort(function (a, b) { return a.depth - b.depth; });
    ctx.font = "bold 12px system-ui, sans-serif";
    ctx.textAlign = "center";
    ctx.textBaseline = "middle";
    axes.forEach(function (ax) {
      var tip = [c[0] + 38 * ax.sx, c[1] - 38 * ax.sy];
      arrow2d(c, tip, colors[ax.k]);
      ctx.fillText(names[ax.k], c[0] + 50 * ax.sx, c[1] - 50 * ax.sy);
    });
  }

  function niceLength(mm) { // largest 1, 2 or 5 x 10^k not above mm
    var p = Math.pow(10, Math.floor(Math.log10(mm))), best = p;
    [2, 5, 10].forEach(function (m) { if (m * p <= mm) { best = m * p; } });
    return best;
  }

  function drawScaleBar(w, h) {
    var mm = niceLength(130 / cam.scale), px = mm * cam.scale, x1 = w - 24, x0 = x1 - px, y = h - 26;
    ctx.strokeStyle = "#1d2630";
    ctx.fillStyle = "#1d2630";
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.moveTo(x0, y - 5); ctx.lineTo(x0, y); ctx.lineTo(x1, y); ctx.lineTo(x1, y - 5);
    ctx.stroke();
    ctx.font = "12px system-ui, sans-serif";
    ctx.textAlign = "center";
    ctx.textBaseline = "bottom";
    ctx.fillText(mm + " mm", (x0 + x1) / 2, y - 4);
  }

  // ---- status for people and tests ------------------------------------------------------
  function reportDrawn(n, ms) {
    var el = document.getElementById("viewer-status");
    if (!el || window.prehensionViewerErrors.length) { return; }
    el.setAttribute("data-status", "ok");
    el.setAttribute("data-triangles", String(n));
    el.textContent = n + " triangles drawn in " + Math.round(ms) + " ms";
  }

  // ---- page: panel, layers, legend ------------------------------------------------------
  function buildPanel() {
    document.getElementById("title").textContent = scene.title;
    var caption = document.getElementById("caption");
    scene.caption.forEach(function (line) {
      var p = document.createElement("p");
      p.textContent = line;
      caption.appendChild(p);
    });
    buildStages();
    var box = document.getElementById("layers");
    scene.layers.forEach(function (layer) {
      if (!layer.meshes.length && !layer.lines.length && !layer.points.length && !layer.arrows.length) { return; }
      if (layer.stage) { return; } // shown with its stage (the stage selector), not on its own
      var label = document.createElement("label"), input = document.createElement("input");
      input.type = "checkbox";
      input.checked = layer.visible;
      input.setAttribute("data-layer", layer.key);
      input.addEventListener("change", function () { layer.visible = input.checked; requestDraw(); });
      label.appendChild(input);
      label.appendChild(document.createTextNode(" " + layer.label));
      box.appendChild(label);
    });
    var legend = document.getElementById("legend");
    scene.legend.forEach(function (entry) {
      var li = document.createElement("li"), sw = document.createElement("span");
      sw.className = "swatch";
      sw.style.background = entry.color;
      li.appendChild(sw);
      li.appendChild(document.createTextNode(entry.label));
      legend.appendChild(li);
    });
    document.getElementById("toggle-panel").addEventListener("click", function () {
      var panel = document.getElementById("panel");
      panel.classList.toggle("collapsed");
      this.innerHTML = panel.classList.contains("collapsed") ? "&#9776;" : "&#8211;";
    });
  }

  // Pre-grasp, grasp, squeeze: one stage at a time; a layer with a stage is visible with it only.
  function showStage(key) {
    scene.stage = key;
    scene.layers.forEach(function (l) { if (l.stage) { l.visible = l.stage === key; } });
    document.getElementById("stages").setAttribute("data-stage", key);
    requestDraw();
  }

  function buildStages() {
    var box = document.getElementById("stages");
    if (!scene.stages || !scene.stages.length) { box.style.display = "none"; return; }
    scene.stages.forEach(function (stage) {
      var label = document.createElement("label"), input = document.createElement("input");
      input.type = "radio";
      input.name = "stage";
      input.checked = stage.key === scene.stage;
      input.setAttribute("data-stage", stage.key);
      input.addEventListener("change", function () { if (input.checked) { showStage(stage.key); } });
      label.appendChild(input);
      label.appendChild(document.createTextNode(" " + stage.label));
      box.appendChild(label);
    });
    box.setAttribute("data-stage", scene.stage);
  }

  // ---- interaction --------------------------------------------------------------------------
  var pending = false, quick = false;
  function requestDraw() {
    if (pending) { return; }
    pending = true;
    window.requestAnimationFrame(function () { pending = false; drawScene(); });
  }

  function resize() {
    var dpr = window.devicePixelRatio || 1;
    canvas.width = Math.round(window.innerWidth * dpr);
    canvas.height = Math.round(window.innerHeight * dpr);
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  }

  function installControls() {
    var drag = null;
    canvas.addEventListener("pointerdown", function (e) {
      drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button !== 0 };
      canvas.setPointerCapture(e.pointerId);
      canvas.classList.add("dragging");
    });
    canvas.addEventListener("pointermove", function (e) {
      if (!drag) { return; }
      var dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      drag.x = e.clientX;
      drag.y = e.clientY;
      quick = true;
      if (drag.pan) { cam.panX += dx; cam.panY += dy; } else {
        cam.azim -= 0.4 * dx;
        cam.elev = Math.max(-90, Math.min(90, cam.elev + 0.4 * dy));
      }
      requestDraw();
    });
    function stop() { drag = null; canvas.classList.remove("dragging"); quick = false; requestDraw(); }
    canvas.addEventListener("pointerup", stop);
    canvas.addEventListener("pointercancel", stop);
    canvas.addEventListener("contextmenu", function (e) { e.preventDefault(); });
    canvas.addEventListener("wheel", zoom, { passive: false });
    canvas.addEventListener("dblclick", function () { resetCamera(); requestDraw(); });
    window.addEventListener("keydown", function (e) {
      if (e.key === "r" || e.key === "R") { resetCamera(); requestDraw(); }
    });
    window.addEventListener("resize", function () { resize(); requestDraw(); });
  }

  function zoom(e) { // about the point under the cursor
    e.preventDefault();
    var k = Math.exp(-0.0015 * e.deltaY), o = origin();
    cam.panX += (e.clientX - o[0]) * (1 - k);
    cam.panY += (e.clientY - o[1]) * (1 - k);
    cam.scale *= k;
    requestDraw();
  }

  window.prehensionViewer = { draw: drawScene, camera: cam, reset: resetCamera, stage: showStage }; // for scripting and tests
  buildPanel();
  resize();
  resetCamera();
  installControls();
  drawScene();
})();
