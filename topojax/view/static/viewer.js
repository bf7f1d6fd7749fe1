/* topojax viewer: the page (MIT licence, part of topojax).
 *
 * Pan by dragging, zoom with the wheel or two fingers; hover a vertex, an edge or a room for its
 * attributes; click a start and a goal for a route (TJ.Router, as topojax.plan_route);
 * replay a timeline.  window.topojaxView is the page's interface for scripts and tests. */
"use strict";
var TJ = (window.TJ = window.TJ || {});
TJ.frameNo = 0;

(function () {
  function $(id) { return document.getElementById(id); }
  /* a value as an error message shows what it received: text quoted */
  TJ.shown = function (v) { return typeof v === "string" ? JSON.stringify(v) : String(v); };
  function fmt(x, digits) { return Number.isFinite(x) ? x.toFixed(digits) : "n/a"; }
  function el(tag, attrs, text) {
    var e = document.createElement(tag);
    for (var k in attrs) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    return e;
  }

  function Viewer(data) {
    this.data = data;
    this.frame = data ? new TJ.Frame(data.frame) : null;
    this.state = "loading";
    this.canvas = $("tj-canvas");
    this.ctx = this.canvas.getContext("2d");
    this.view = { z: 1, tx: 0, ty: 0, dpr: 1, w: 0, h: 0, u0: 0, v0: 0, u1: 0, v1: 0 };
    this.layers = new Map();
    this.rasters = [];
    this.graphs = [];
    this.routers = new Map();
    this.edgeGrids = new Map();
    this.frameGrid = null;  // the edge grid of the last timeline frame hovered
    this.routePoints = [];
    this.route = null;
    this.routeError = null;
    this.timeline = null;
    this.frameIndex = 0;
    this.nFrames = 0;
    this.pending = false;
    this.stats = { first_draw_ms: null, draw_ms: [] };
    this.hover = null;
    this.pointer = null;  // the mouse over the canvas, [sx, sy], while it is not dragging
  }

  Viewer.prototype.fail = function (err) {
    this.state = "error";
    this.error = String(err && err.message ? err.message : err);
    var box = $("tj-error");
    box.textContent = "This view cannot be shown: " + this.error;
    box.hidden = false;
    $("tj-loading").hidden = true;
    if (window.console) console.error(err);
  };

  Viewer.prototype.start = function () {
    var self = this, d = this.data;
    if (d.version !== 1) throw new Error("the page's data has version " + d.version + "; this viewer reads version 1");
    $("tj-title").textContent = d.title;
    document.title = d.title;
    var redraw = function () { self.requestDraw(); };
    var failed = function (e) { self.fail(e); };
    d.rasters.forEach(function (spec) { self.rasters.push(new TJ.Raster(spec, redraw, failed)); });
    this.rasters.forEach(function (r) { r.prefetch(); });
    var graphs = Promise.all(d.graphs.map(function (g) { return TJ.prepareGraph(g, self.frame); }));
    var timeline = d.timeline ? this.prepareTimeline(d.timeline) : Promise.resolve(null);
    var path = d.timeline ? TJ.unpackAll(d.timeline.path, ["scan", "x", "y"]) : Promise.resolve(null);
    return Promise.all([graphs, timeline, path]).then(function (parts) {
      self.graphs = parts[0];
      self.graphs.forEach(function (g, i) {
        g.colour = TJ.GRAPH_COLOURS[i % TJ.GRAPH_COLOURS.length];
        var spec = d.graphs[i].raster;
        if (spec) {
          g.raster = new TJ.Raster(Object.assign({ name: g.name, label: g.label, kind: "mask", on: true,
            colour: TJ.rgb(g.colour), boost: 2 }, spec), redraw, failed);
          g.raster.prefetch();
        }
      });
      self.timeline = parts[1];
      self.robot = parts[2] ? self.viewPath(parts[2]) : null;
      self.buildLayers();
      self.buildPanel();
      self.bindEvents();
      self.resize();
      self.fit();
      return self.whenTilesReady();
    }).then(function () {
      var t0 = performance.now();
      self.draw();
      self.stats.first_draw_ms = performance.now() - TJ.t0;
      self.stats.first_frame_ms = performance.now() - t0;
      $("tj-loading").hidden = true;
      if (self.state !== "error") self.state = "ready";
    });
  };

  /* resolves once every raster's coarsest level is decoded (they stand in for the rest) */
  Viewer.prototype.whenTilesReady = function () {
    var self = this;
    return new Promise(function (resolve) {
      (function poll() {
        var all = self.rasters.concat(self.graphs.filter(function (g) { return g.raster; })
          .map(function (g) { return g.raster; }));
        if (self.state === "error" || all.every(function (r) { return r.ready(); })) resolve();
        else setTimeout(poll, 20);
      })();
    });
  };

  Viewer.prototype.viewPath = function (p) {
    var n = p.x.length, pu = new Float32Array(n), pv = new Float32Array(n);
    for (var i = 0; i < n; i++) {
      var uv = this.frame.worldToView(p.x[i], p.y[i]);
      pu[i] = uv[0]; pv[i] = uv[1];
    }
    return { scan: p.scan, x: p.x, y: p.y, pu: pu, pv: pv };
  };

  Viewer.prototype.prepareTimeline = function (t) {
    var self = this, frame = this.frame;
    var pool = TJ.unpackAll(t.pool, ["sizes", "xy", "len", "cmin", "cmean"]).then(function (P) {
      var n = P.sizes.length, starts = new Int32Array(n), total = 0;
      for (var k = 0; k < n; k++) { starts[k] = total; total += P.sizes[k]; }
      P.starts = starts;
      P.pu = new Float32Array(total); P.pv = new Float32Array(total);
      for (var i = 0; i < total; i++) {
        var uv = frame.worldToView(P.xy[2 * i], P.xy[2 * i + 1]);
        P.pu[i] = uv[0]; P.pv[i] = uv[1];
      }
      P.box = TJ.edgeBoxes(P.pu, P.pv, starts, P.sizes);
      return P;
    });
    var frames = Promise.all(t.frames.map(function (f) {
      return TJ.unpackAll(f, ["ids", "x", "y", "kind", "clear", "edges", "added", "removed"]).then(function (F) {
        F.scan = f.scan; F.rooms = f.rooms >= 0 ? t.rooms[f.rooms] : null;
        F.n = F.x.length; F.vu = new Float32Array(F.n); F.vv = new Float32Array(F.n);
        for (var i = 0; i < F.n; i++) {
          var uv = frame.worldToView(F.x[i], F.y[i]);
          F.vu[i] = uv[0]; F.vv[i] = uv[1];
        }
        if (f.map) {
          var spec = { name: "map", label: "map at this update", kind: "grey", on: true, tile: 512,
            width: f.map.level.width * f.map.level.step, height: f.map.level.height * f.map.level.step,
            levels: [f.map.level], box: f.map.box };
          F.picture = new TJ.Raster(spec, function () { self.requestDraw(); }, function (e) { self.fail(e); });
        }
        return F;
      });
    }));
    return Promise.all([pool, frames]).then(function (parts) {
      self.nFrames = parts[1].length;
      self.frameIndex = self.nFrames; // the final graph
      return { pool: parts[0], frames: parts[1], kinds: t.kinds };
    });
  };

  /* ------------------------------------------------------------------ layers */
  Viewer.prototype.addLayer = function (name, label, on, swatch) {
    this.layers.set(name, { name: name, label: label, on: on, swatch: swatch });
  };
  Viewer.prototype.buildLayers = function () {
    var self = this, d = this.data;
    this.rasters.forEach(function (r) {
      var sw = { map: "#9e9e9e", distance: "#b73779", ridges: "#ffb000", skeleton: "#285aff" }[r.name];
      self.addLayer(r.name, r.label, r.on, sw);
    });
    this.graphs.forEach(function (g) {
      self.addLayer(g.name, g.label + " (" + g.n + " vertices, " + g.ne + " edges)", true, g.colour);
    });
    if (this.graphs.length) this.addLayer("vertices", "vertices (by kind)", true);
    if (d.rooms) {
      this.addLayer("rooms", "rooms (" + d.rooms.rooms.length + ")", true, "hsla(137,70%,52%,0.6)");
      this.addLayer("doors", "doors (" + d.rooms.doors.length + ")", true, "#ff00aa");
    } else if (this.timeline && this.timeline.frames.some(function (f) { return f.rooms; })) {
      this.addLayer("rooms", "rooms", true, "hsla(137,70%,52%,0.6)");
    }
    if (this.graphs.some(function (g) { return g.routable; }) || d.route) this.addLayer("route", "route", true, "#0091ea");
    if (this.robot && this.robot.x.length) this.addLayer("path", "robot path", true, "#e377c2");
    if (this.timeline) this.addLayer("changes", "changes at the update", true, "#1b9e3e");
    if (d.route) {
      this.route = { length_m: d.route.length_m, xy: d.route.xy, start_snap_m: d.route.start_snap_m,
        goal_snap_m: d.route.goal_snap_m, given: true };
    }
  };

  Viewer.prototype.setLayer = function (name, on) {
    var layer = this.layers.get(name);
    if (!layer) {
      throw new Error("setLayer: expected a layer name (" + Array.from(this.layers.keys()).join(", ") +
        "), received " + TJ.shown(name));
    }
    if (typeof on !== "boolean") {
      throw new Error("setLayer: expected on = true or false, received " + TJ.shown(on));
    }
    layer.on = on;
    var box = $("tj-layer-" + name);
    if (box) box.checked = layer.on;
    this.requestDraw();
  };
  Viewer.prototype.isOn = function (name) {
    var layer = this.layers.get(name);
    return !!(layer && layer.on);
  };

  Viewer.prototype.buildPanel = function () {
    var self = this, d = this.data, f = this.frame;
    var summary = [f.height + " × " + f.width + " px, " + f.res + " m/px"];
    $("tj-summary").textContent = summary.join(" · ");
    var list = $("tj-layers");
    this.layers.forEach(function (layer) {
      var label = el("label", {});
      var box = el("input", { type: "checkbox", id: "tj-layer-" + layer.name, "data-layer": layer.name });
      box.checked = layer.on;
      box.addEventListener("change", function () { self.setLayer(layer.name, box.checked); });
      label.appendChild(box);
      if (layer.swatch) {
        var sw = el("span", { class: "tj-swatch" }); sw.style.background = layer.swatch; label.appendChild(sw);
      }
      label.appendChild(document.createTextNode(layer.label));
      list.appendChild(label);
    });
    var legend = $("tj-legend");
    if (this.graphs.length) {
      ["junction", "end", "ring", "isolated", "other"].forEach(function (k, i) {
        var s = el("span", {}), sw = el("span", { class: "tj-swatch" });
        sw.style.background = TJ.KIND_COLOURS[i]; s.appendChild(sw); s.appendChild(document.createTextNode(k));
        legend.appendChild(s);
      });
    }
    var routable = this.graphs.filter(function (g) { return g.routable; });
    var select = $("tj-route-on");
    routable.forEach(function (g) { select.appendChild(el("option", { value: g.name }, g.label)); });
    $("tj-route-on-label").hidden = routable.length < 2;
    select.addEventListener("change", function () { self.clearRoute(); });
    if (!routable.length) {
      var why = this.graphs.length ? this.graphs[0].whyNot : "there is no graph";
      $("tj-route").textContent = "Routes need a graph with edge paths: " + why + ".";
    }
    $("tj-route-clear").addEventListener("click", function () { self.clearRoute(); });
    $("tj-fit").addEventListener("click", function () { self.fit(); });
    if (this.route) this.showRoute();
    if (d.notes && d.notes.length) {
      $("tj-notes-box").hidden = false;
      d.notes.forEach(function (n) { $("tj-notes").appendChild(el("li", {}, n)); });
    }
    if (this.timeline) {
      $("tj-timeline").hidden = false;
      var slider = $("tj-slider");
      slider.max = String(this.nFrames);
      slider.value = String(this.nFrames);
      slider.addEventListener("input", function () { self.stop(); self.setFrame(+slider.value); });
      $("tj-play").addEventListener("click", function () { self.playing ? self.stop() : self.play(); });
      this.showFrame();
    }
  };

  /* ------------------------------------------------------------------ view */
  Viewer.prototype.resize = function () {
    var rect = this.canvas.getBoundingClientRect(), v = this.view;
    var dpr = window.devicePixelRatio || 1;
    var cw = v.w, ch = v.h;
    v.w = Math.max(1, rect.width); v.h = Math.max(1, rect.height); v.dpr = dpr;
    this.canvas.width = Math.round(v.w * dpr);
    this.canvas.height = Math.round(v.h * dpr);
    if (!this.moved && this.fitZ !== undefined) { this.fit(); return; } // e.g. shown after a hidden start
    if (cw) { v.tx += (v.w - cw) / 2; v.ty += (v.h - ch) / 2; }
    this.requestDraw();
  };
  Viewer.prototype.fit = function () {
    var v = this.view, f = this.frame;
    var z = 0.95 * Math.min(v.w / f.width, v.h / f.height);
    v.z = z;
    v.tx = (v.w - f.width * z) / 2;
    v.ty = (v.h - f.height * z) / 2;
    this.fitZ = z;
    this.moved = false;
    this.requestDraw();
  };
  Viewer.prototype.zoomAt = function (factor, sx, sy) {
    var v = this.view;
    // up to 64 screen px per map px, or 16 x the fit of a map of a few pixels
    var z = Math.min(Math.max(64, 16 * this.fitZ), Math.max(this.fitZ / 16, v.z * factor));
    var k = z / v.z;
    v.tx = sx - (sx - v.tx) * k;
    v.ty = sy - (sy - v.ty) * k;
    v.z = z;
    this.moved = true;
    this.requestDraw();
  };
  Viewer.prototype.panBy = function (dx, dy) {
    this.view.tx += dx; this.view.ty += dy;
    this.moved = true;
    this.requestDraw();
  };
  Viewer.prototype.worldToScreen = function (x, y) {
    var uv = this.frame.worldToView(x, y), v = this.view;
    return [uv[0] * v.z + v.tx, uv[1] * v.z + v.ty];
  };
  Viewer.prototype.screenToWorld = function (sx, sy) {
    var v = this.view;
    return this.frame.viewToWorld((sx - v.tx) / v.z, (sy - v.ty) / v.z);
  };

  Viewer.prototype.requestDraw = function () {
    if (this.pending) return;
    this.pending = true;
    var self = this;
    requestAnimationFrame(function () { self.pending = false; self.draw(); });
  };

  /* ------------------------------------------------------------------ drawing */
  Viewer.prototype.draw = function () {
    var t0 = performance.now();
    TJ.frameNo++;
    var ctx = this.ctx, v = this.view;
    v.u0 = -v.tx / v.z; v.v0 = -v.ty / v.z;
    v.u1 = (v.w - v.tx) / v.z; v.v1 = (v.h - v.ty) / v.z;
    ctx.setTransform(v.dpr, 0, 0, v.dpr, 0, 0);
    ctx.fillStyle = "#eceff1";
    ctx.fillRect(0, 0, v.w, v.h);
    var f = this.currentFrame();
    for (var i = 0; i < this.rasters.length; i++) {
      var r = this.rasters[i];
      if (!this.isOn(r.name)) continue;
      if (r.name === "map" && f && f.picture) this.drawPicture(ctx, f.picture);
      else r.draw(ctx, v, [0, 0, 1]);
    }
    if (!this.rasters.length) {
      ctx.fillStyle = "#fff";
      ctx.fillRect(v.tx, v.ty, this.frame.width * v.z, this.frame.height * v.z);
    }
    this.drawRooms(ctx, f);
    this.drawGraphs(ctx, f);
    if (f && this.isOn("changes")) this.drawChanges(ctx, f);
    if (this.isOn("path") && this.robot) this.drawRobot(ctx, f);
    if (this.isOn("route")) this.drawRoute(ctx);
    if (this.isOn("vertices")) this.drawAllVertices(ctx, f);
    this.drawScale();
    var ms = performance.now() - t0;
    this.stats.draw_ms.push(ms);
    if (this.stats.draw_ms.length > 600) this.stats.draw_ms.shift();
    // a zoom, a step of the timeline or a layer switched changes what is under a still
    // mouse: the tooltip says what is there now
    if (this.pointer) this.showHover(this.pointer[0], this.pointer[1]);
  };

  Viewer.prototype.drawPicture = function (ctx, pic) {
    var b = pic.box, frame = this.frame;
    var uv = frame.worldToView(b[0], b[3]);
    var k = (b[2] - b[0]) / pic.width / frame.res;
    pic.draw(ctx, this.view, [uv[0], uv[1], k]);
  };

  Viewer.prototype.currentFrame = function () {
    if (!this.timeline || this.frameIndex >= this.nFrames) return null;
    return this.timeline.frames[this.frameIndex];
  };

  Viewer.prototype.drawRooms = function (ctx, f) {
    var rooms = f ? f.rooms : this.data.rooms ? this.data.rooms.rooms : null;
    if (rooms && this.isOn("rooms")) TJ.drawRooms(ctx, this.view, this.frame, rooms);
    if (!f && this.data.rooms && this.isOn("doors")) TJ.drawDoors(ctx, this.view, this.frame, this.data.rooms.doors);
  };

  /* Graphs as polylines; zoomed out, a graph's mask tiles instead (when it has them). */
  Viewer.prototype.drawGraphs = function (ctx, f) {
    var wide = this.view.z > 2 ? 2.5 : 1.5, perPixel = this.view.z * this.view.dpr;
    for (var i = 0; i < this.graphs.length; i++) {
      var g = this.graphs[i];
      if (!this.isOn(g.name)) continue;
      if (g.raster && perPixel < 1 && !(f && i === 0)) {
        g.raster.draw(ctx, this.view, [0, 0, 1]);
        continue;
      }
      if (f && i === 0) {
        TJ.tracePolylines(ctx, this.view, this.timeline.pool, f.edges);
      } else {
        TJ.tracePolylines(ctx, this.view, { pu: g.pu, pv: g.pv, starts: g.starts, sizes: g.sizes, box: g.box });
      }
      ctx.lineWidth = wide; ctx.strokeStyle = g.colour; ctx.lineJoin = "round";
      ctx.stroke();
    }
  };

  Viewer.prototype.drawAllVertices = function (ctx, f) {
    for (var i = this.graphs.length - 1; i >= 0; i--) {
      var g = this.graphs[i];
      if (!this.isOn(g.name)) continue;
      if (f && i === 0) TJ.drawVertices(ctx, this.view, f.vu, f.vv, f.kind, f.n);
      else TJ.drawVertices(ctx, this.view, g.vu, g.vv, g.kind, g.n);
    }
  };

  Viewer.prototype.drawChanges = function (ctx, f) {
    var pool = this.timeline.pool;
    TJ.tracePolylines(ctx, this.view, pool, f.removed);
    ctx.setLineDash([6, 4]); ctx.lineWidth = 3; ctx.strokeStyle = "#d50032"; ctx.stroke();
    ctx.setLineDash([]);
    TJ.tracePolylines(ctx, this.view, pool, f.added);
    ctx.lineWidth = 3.5; ctx.strokeStyle = "#1b9e3e"; ctx.stroke();
  };

  Viewer.prototype.drawRobot = function (ctx, f) {
    var p = this.robot, v = this.view, n = p.x.length;
    if (f) { n = 0; while (n < p.x.length && p.scan[n] <= f.scan) n++; }
    if (n === 0) return;
    ctx.beginPath();
    for (var i = 0; i < n; i++) {
      var x = p.pu[i] * v.z + v.tx, y = p.pv[i] * v.z + v.ty;
      if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    }
    ctx.lineWidth = 2; ctx.strokeStyle = "#e377c2"; ctx.stroke();
    TJ.drawMarker(ctx, v, this.frame, p.x[n - 1], p.y[n - 1], "#c2185b", "");
  };

  Viewer.prototype.drawRoute = function (ctx) {
    var v = this.view, frame = this.frame;
    if (this.route && this.route.xy.length >= 2) {
      TJ.traceWorld(ctx, v, frame, this.route.xy, false);
      ctx.lineJoin = "round"; ctx.lineCap = "round";
      ctx.lineWidth = 7; ctx.strokeStyle = "rgba(255,255,255,0.9)"; ctx.stroke();
      ctx.lineWidth = 4; ctx.strokeStyle = "#0091ea"; ctx.stroke();
      ctx.lineCap = "butt";
    }
    var names = ["A", "B"];
    for (var i = 0; i < this.routePoints.length; i++) {
      var p = this.routePoints[i];
      TJ.drawMarker(ctx, v, frame, p[0], p[1], i === 0 ? "#2e7d32" : "#c62828", names[i]);
    }
  };

  Viewer.prototype.drawScale = function () {
    var metresPerPx = this.frame.res / this.view.z;
    var len = TJ.niceLength(metresPerPx, 110);
    var px = len / metresPerPx;
    $("tj-scale-bar").style.width = px.toFixed(1) + "px";
    // len is 1, 2 or 5 times a power of ten: one significant digit names it exactly
    var text = len >= 1000 ? len / 1000 + " km" : +len.toPrecision(1) + " m";
    $("tj-scale-label").textContent = text;
    this.scale = { metres: len, pixels: px };
  };

  /* ------------------------------------------------------------------ hover */
  Viewer.prototype.edgeGrid = function (key, L) {
    var grid = this.edgeGrids.get(key);
    if (!grid) {
      grid = new TJ.Grid(L.pu, L.pv, 8);
      grid.edgeOf = new Int32Array(L.pu.length);
      for (var k = 0; k < L.starts.length; k++) grid.edgeOf.fill(k, L.starts[k], L.starts[k] + L.sizes[k]);
      this.edgeGrids.set(key, grid);
    }
    return grid;
  };
  /* the grid of the edges of timeline frame `index` (the pool keeps removed edges too);
     only the last frame's is kept, so hovering through a long replay holds one grid */
  Viewer.prototype.frameEdgeGrid = function (index, f) {
    var grid = this.frameGrid && this.frameGrid.index === index ? this.frameGrid : null;
    if (!grid) {
      var P = this.timeline.pool, n = 0, k, e;
      for (k = 0; k < f.edges.length; k++) n += P.sizes[f.edges[k]];
      var pu = new Float32Array(n), pv = new Float32Array(n), edgeOf = new Int32Array(n), at = 0;
      for (k = 0; k < f.edges.length; k++) {
        e = f.edges[k];
        pu.set(P.pu.subarray(P.starts[e], P.starts[e] + P.sizes[e]), at);
        pv.set(P.pv.subarray(P.starts[e], P.starts[e] + P.sizes[e]), at);
        edgeOf.fill(e, at, at + P.sizes[e]);
        at += P.sizes[e];
      }
      grid = new TJ.Grid(pu, pv, 8);
      grid.edgeOf = edgeOf;
      grid.index = index;
      this.frameGrid = grid;
    }
    return grid;
  };

  /* what is under screen point (sx, sy): {kind, lines} or null */
  Viewer.prototype.hoverAt = function (sx, sy) {
    var v = this.view, f = this.currentFrame(), self = this;
    var u = (sx - v.tx) / v.z, w = (sy - v.ty) / v.z;
    var world = this.screenToWorld(sx, sy);
    var where = "x " + fmt(world[0], 3) + " m, y " + fmt(world[1], 3) + " m";
    // vertices are drawn over every graph's edges: a vertex under the point first
    for (var i = 0; i < this.graphs.length && this.isOn("vertices"); i++) {
      var g = this.graphs[i];
      if (!this.isOn(g.name)) continue;
      var V = f && i === 0 ? { n: f.n, vu: f.vu, vv: f.vv, kind: f.kind, clear: f.clear, x: f.x, y: f.y, ids: f.ids } :
        { n: g.n, vu: g.vu, vv: g.vv, kind: g.kind, clear: g.clear, x: g.vx, y: g.vy, ids: g.ids };
      var best = -1, bestD = 8 / v.z;
      for (var k = 0; k < V.n; k++) {
        var d = Math.max(Math.abs(V.vu[k] - u), Math.abs(V.vv[k] - w));
        if (d <= bestD) { bestD = d; best = k; }
      }
      if (best >= 0) {
        return { kind: "vertex", id: V.ids[best], clearance_m: V.clear[best], lines: [
          g.label + " vertex " + V.ids[best] + " · " + (TJ.KINDS[V.kind[best]] || "other"),
          "clearance " + fmt(V.clear[best], 3) + " m",
          "x " + fmt(V.x[best], 3) + " m, y " + fmt(V.y[best], 3) + " m",
        ] };
      }
    }
    for (i = 0; i < this.graphs.length; i++) {
      g = this.graphs[i];
      if (!this.isOn(g.name)) continue;
      var L = f && i === 0 ? this.timeline.pool : g;
      var grid = f && i === 0 ? this.frameEdgeGrid(this.frameIndex, f) : this.edgeGrid(g.name, L);
      var hit = grid.nearest(u, w, 6 / v.z);
      if (hit) {
        var e = grid.edgeOf[hit.index];
        var ends = f && i === 0 ? "" : " " + g.ids[g.u[e]] + "–" + g.ids[g.v[e]];
        return { kind: "edge", length_m: L.len[e], lines: [
          g.label + " edge" + ends,
          "length " + fmt(L.len[e], 3) + " m",
          "clearance min " + fmt(L.cmin[e], 3) + " m, mean " + fmt(L.cmean[e], 3) + " m",
        ] };
      }
    }
    var rooms = f ? f.rooms : this.data.rooms ? this.data.rooms.rooms : null;
    if (rooms && this.isOn("rooms")) {
      // a room holds the point inside its outline and outside its holes; of rooms
      // holding it (rooms given without their holes: a room round a courtyard holds the
      // rooms inside it), the smallest room's
      var best = -1;
      for (var r = 0; r < rooms.length; r++) {
        if ((best < 0 || rooms[r].area_m2 < rooms[best].area_m2) &&
            TJ.inRoom(rooms[r], world[0], world[1])) best = r;
      }
      if (best >= 0) {
        return { kind: "room", id: rooms[best].id, lines: [
          "room " + rooms[best].id, "area " + fmt(rooms[best].area_m2, 2) + " m²", where,
        ] };
      }
    }
    return null;
  };

  TJ.KINDS = ["junction", "end", "ring", "isolated", "other"];
  TJ.inRoom = function (room, x, y) {
    if (!TJ.inside(room.polygon, x, y)) return false;
    var holes = room.holes || [];
    for (var k = 0; k < holes.length; k++) if (TJ.inside(holes[k], x, y)) return false;
    return true;
  };
  TJ.inside = function (poly, x, y) {
    var inside = false, n = poly.length / 2;
    for (var i = 0, j = n - 1; i < n; j = i++) {
      var xi = poly[2 * i], yi = poly[2 * i + 1], xj = poly[2 * j], yj = poly[2 * j + 1];
      if (yi > y !== yj > y && x < ((xj - xi) * (y - yi)) / (yj - yi) + xi) inside = !inside;
    }
    return inside;
  };

  Viewer.prototype.showHover = function (sx, sy) {
    var world = this.screenToWorld(sx, sy);
    $("tj-coords").textContent = "x " + fmt(world[0], 3) + " m   y " + fmt(world[1], 3) + " m";
    var info = this.hoverAt(sx, sy), tip = $("tj-tooltip");
    this.hover = info;
    if (!info) { tip.hidden = true; return; }
    tip.textContent = info.lines.join("\n");
    tip.hidden = false;
    var x = sx + 14, y = sy + 14;
    if (x + tip.offsetWidth > this.view.w) x = sx - tip.offsetWidth - 10;
    if (y + tip.offsetHeight > this.view.h) y = sy - tip.offsetHeight - 10;
    tip.style.left = x + "px"; tip.style.top = y + "px";
  };

  /* ------------------------------------------------------------------ routes */
  Viewer.prototype.router = function (name) {
    var g = null;
    for (var i = 0; i < this.graphs.length; i++) if (this.graphs[i].name === name) g = this.graphs[i];
    if (!g) {
      throw new Error("route: expected graph, a graph layer's name (" +
        this.graphs.map(function (x) { return x.name; }).join(", ") + "), received " + TJ.shown(name));
    }
    if (!this.routers.has(name)) this.routers.set(name, new TJ.Router(g));
    return this.routers.get(name);
  };
  Viewer.prototype.routeGraphName = function () {
    var select = $("tj-route-on");
    return select.value || (this.graphs[0] && this.graphs[0].name);
  };
  Viewer.prototype.planRoute = function (x0, y0, x1, y1, name) {
    return this.router(name || this.routeGraphName()).route(x0, y0, x1, y1, this.data.max_snap_m);
  };
  Viewer.prototype.clickAt = function (sx, sy) {
    var world = this.screenToWorld(sx, sy);
    // a first click starts a new route: the last one (or the route given) goes
    if (this.routePoints.length >= 2 || this.route) this.clearRoute();
    this.routePoints.push(world);
    if (this.routePoints.length === 2) {
      var a = this.routePoints[0], b = this.routePoints[1];
      try {
        this.route = this.planRoute(a[0], a[1], b[0], b[1]);
        this.routeError = null;
      } catch (err) {
        this.route = null; this.routeError = err.message;
      }
    }
    this.showRoute();
    this.requestDraw();
  };
  Viewer.prototype.clearRoute = function () {
    this.routePoints = []; this.route = null; this.routeError = null;
    this.showRoute(); this.requestDraw();
  };
  Viewer.prototype.showRoute = function () {
    var box = $("tj-route");
    box.textContent = "";
    if (this.routeError) {
      box.appendChild(el("div", { class: "tj-bad" }, this.routeError));
    } else if (this.route) {
      var len = el("div", { class: "tj-length", id: "tj-route-length", "data-length-m": String(this.route.length_m) },
        fmt(this.route.length_m, 3) + " m");
      box.appendChild(len);
      box.appendChild(el("div", {}, "snapped " + fmt(this.route.start_snap_m, 2) + " m / " +
        fmt(this.route.goal_snap_m, 2) + " m" + (this.route.given ? " (given)" : "")));
    } else if (this.routePoints.length === 1) {
      box.textContent = "Start set; click the goal.";
    } else {
      box.textContent = "Click a start and a goal on the map.";
    }
  };

  /* ------------------------------------------------------------------ timeline */
  Viewer.prototype.setFrame = function (i) {
    if (!this.timeline) throw new Error("this view has no timeline");
    if (typeof i !== "number" || !isFinite(i)) {
      throw new Error("setFrame: expected a frame index from 0 to " + this.nFrames + ", received " +
        TJ.shown(i));
    }
    this.frameIndex = Math.max(0, Math.min(this.nFrames, Math.round(i)));
    $("tj-slider").value = String(this.frameIndex);
    this.showFrame();
    this.requestDraw();
  };
  Viewer.prototype.frameInfo = function () {
    var f = this.currentFrame();
    if (!f) return { index: this.frameIndex, final: true };
    return { index: this.frameIndex, final: false, scan: f.scan, vertices: f.n, edges: f.edges.length,
      added: f.added.length, removed: f.removed.length };
  };
  Viewer.prototype.showFrame = function () {
    var box = $("tj-frame"), f = this.currentFrame(), g = this.graphs[0];
    box.textContent = "";
    if (!f) {
      box.textContent = "final graph: " + (g ? g.n + " vertices, " + g.ne + " edges" : "none");
      return;
    }
    box.appendChild(document.createTextNode("update " + (this.frameIndex + 1) + " of " + this.nFrames +
      ", scan " + (f.scan + 1) + ": " + f.n + " vertices, " + f.edges.length + " edges; "));
    box.appendChild(el("span", { class: "tj-added" }, "+" + f.added.length));
    box.appendChild(document.createTextNode(" / "));
    box.appendChild(el("span", { class: "tj-removed" }, "−" + f.removed.length));
    box.appendChild(document.createTextNode(" edges"));
  };
  Viewer.prototype.play = function () {
    var self = this;
    if (this.frameIndex >= this.nFrames) this.setFrame(0);
    this.playing = setInterval(function () {
      if (self.frameIndex >= self.nFrames) { self.stop(); return; }
      self.setFrame(self.frameIndex + 1);
    }, 450);
    $("tj-play").textContent = "pause";
  };
  Viewer.prototype.stop = function () {
    if (this.playing) clearInterval(this.playing);
    this.playing = null;
    $("tj-play").textContent = "play";
  };

  /* ------------------------------------------------------------------ events */
  Viewer.prototype.bindEvents = function () {
    var self = this, canvas = this.canvas, stage = $("tj-stage"), down = null;
    function local(e) {
      var r = canvas.getBoundingClientRect();
      return [e.clientX - r.left, e.clientY - r.top];
    }
    canvas.addEventListener("wheel", function (e) {
      e.preventDefault();
      var p = local(e), dy = e.deltaY * (e.deltaMode === 1 ? 33 : e.deltaMode === 2 ? 400 : 1);
      self.zoomAt(Math.pow(2, -dy / 300), p[0], p[1]);
    }, { passive: false });
    // the pointers down on the canvas, at most two: one drags, two fingers pinch (the map
    // follows their midpoint and zooms with their distance)
    var pts = new Map(), pinch = null;
    function spread() {
      var ab = Array.from(pts.values()), a = ab[0], b = ab[1];
      return { x: (a[0] + b[0]) / 2, y: (a[1] + b[1]) / 2, d: Math.hypot(b[0] - a[0], b[1] - a[1]) };
    }
    function hideTip() { self.pointer = null; $("tj-tooltip").hidden = true; }
    /* pointer `id` is up or gone; whether that ends a click */
    function end(id) {
      pts.delete(id);
      if (pinch) { // the finger left drags on from where it is: no jump, and no click
        pinch = null;
        var rest = pts.keys().next().value, q = pts.get(rest);
        down = { id: rest, x: q[0], y: q[1], moved: true };
        return false;
      }
      var click = !!down && !down.moved;
      down = null;
      stage.classList.remove("tj-dragging");
      return click;
    }
    canvas.addEventListener("pointerdown", function (e) {
      if (e.button !== 0 || pts.has(e.pointerId) || pts.size >= 2) return;
      var p = local(e);
      pts.set(e.pointerId, p);
      try { canvas.setPointerCapture(e.pointerId); } catch (err) { /* the pointer is already gone */ }
      if (pts.size === 1) { down = { id: e.pointerId, x: p[0], y: p[1], moved: false }; return; }
      pinch = spread();
      down.moved = true;
      stage.classList.add("tj-dragging");
      hideTip();
    });
    canvas.addEventListener("pointermove", function (e) {
      var p = local(e);
      if (pts.has(e.pointerId)) pts.set(e.pointerId, p);
      else if (pts.size) return; // another pointer while one drags
      if (pinch) {
        var now = spread();
        self.panBy(now.x - pinch.x, now.y - pinch.y);
        if (pinch.d > 0 && now.d > 0) self.zoomAt(now.d / pinch.d, now.x, now.y);
        pinch = now;
        return;
      }
      if (down) {
        var dx = p[0] - down.x, dy = p[1] - down.y;
        if (down.moved || Math.abs(dx) + Math.abs(dy) > 4) {
          down.moved = true;
          stage.classList.add("tj-dragging");
          self.panBy(dx, dy);
          down.x = p[0]; down.y = p[1];
          hideTip();
          return;
        }
      }
      self.pointer = p;
      self.showHover(p[0], p[1]);
    });
    canvas.addEventListener("pointerup", function (e) {
      if (!pts.has(e.pointerId)) return;
      var p = local(e);
      if (end(e.pointerId) && self.graphs.some(function (g) { return g.routable; })) self.clickAt(p[0], p[1]);
    });
    // a pointer the browser cancels (or whose capture is lost) ends with no pointerup
    function cancel(e) { if (pts.has(e.pointerId)) end(e.pointerId); }
    canvas.addEventListener("pointercancel", cancel);
    canvas.addEventListener("lostpointercapture", cancel);
    canvas.addEventListener("pointerleave", hideTip);
    if (typeof ResizeObserver === "function") {
      new ResizeObserver(function () { self.resize(); }).observe(stage);
    } else {
      window.addEventListener("resize", function () { self.resize(); });
    }
  };

  /* ------------------------------------------------------------------ the interface */
  /* refuse, naming it, an argument of `fn` that is no finite number: a string or NaN
     would leave the view at no place */
  function numbers(fn, names, args) {
    for (var i = 0; i < names.length; i++) {
      var v = args[i];
      if (typeof v !== "number" || !isFinite(v)) {
        throw new Error(fn + ": expected " + names.join(", ") + " as finite numbers, received " +
          names[i] + " = " + TJ.shown(v));
      }
    }
  }
  function api(viewer, ready) {
    return {
      get state() { return viewer.state; },
      get error() { return viewer.error || null; },
      ready: ready,
      stats: viewer.stats,
      layers: function () {
        return Array.from(viewer.layers.values()).map(function (l) { return { name: l.name, label: l.label, on: l.on }; });
      },
      setLayer: function (name, on) { viewer.setLayer(name, on); viewer.draw(); },
      route: function (x0, y0, x1, y1, graph) {
        try {
          numbers("route", ["x0", "y0", "x1", "y1"], arguments);
          var r = viewer.planRoute(x0, y0, x1, y1, graph);
          return { length_m: r.length_m, start_snap_m: r.start_snap_m, goal_snap_m: r.goal_snap_m,
            n_points: r.xy.length / 2, vertices: r.vertices };
        } catch (err) { return { error: err.message }; }
      },
      lastRoute: function () {
        if (viewer.routeError) return { error: viewer.routeError };
        return viewer.route ? { length_m: viewer.route.length_m, given: !!viewer.route.given } : null;
      },
      clearRoute: function () { viewer.clearRoute(); },
      routePoints: function () { return viewer.routePoints.map(function (p) { return [p[0], p[1]]; }); },
      worldToScreen: function (x, y) {
        numbers("worldToScreen", ["x", "y"], arguments);
        return viewer.worldToScreen(x, y);
      },
      screenToWorld: function (sx, sy) {
        numbers("screenToWorld", ["sx", "sy"], arguments);
        return viewer.screenToWorld(sx, sy);
      },
      hoverAt: function (sx, sy) {
        numbers("hoverAt", ["sx", "sy"], arguments);
        return viewer.hoverAt(sx, sy) || null;
      },
      fit: function () { viewer.fit(); viewer.draw(); },
      zoomAt: function (f, sx, sy) {
        numbers("zoomAt", ["f", "sx", "sy"], arguments);
        if (f <= 0) throw new Error("zoomAt: expected a zoom factor f > 0, received f = " + f);
        viewer.zoomAt(f, sx, sy); viewer.draw();
      },
      panBy: function (dx, dy) {
        numbers("panBy", ["dx", "dy"], arguments);
        viewer.panBy(dx, dy); viewer.draw();
      },
      view: function () { var v = viewer.view; return { z: v.z, tx: v.tx, ty: v.ty, w: v.w, h: v.h, scale: viewer.scale }; },
      nFrames: function () { return viewer.nFrames; },
      setFrame: function (i) { viewer.setFrame(i); viewer.draw(); return viewer.frameInfo(); },
      frameInfo: function () { return viewer.frameInfo(); },
      draw: function () { viewer.draw(); return viewer.stats.draw_ms[viewer.stats.draw_ms.length - 1]; },
      /* pan `frames` animation frames of `dx` CSS px; resolves with the time between
       * frames and the drawing time of each, milliseconds */
      benchmarkPan: function (frames, dx) {
        numbers("benchmarkPan", ["frames", "dx"], arguments); // NaN frames: it never ends
        return new Promise(function (resolve) {
          var gaps = [], draws = [], last = null, i = 0;
          function step(t) {
            if (last !== null) gaps.push(t - last);
            last = t;
            if (i++ >= frames) { resolve({ frame_ms: gaps, draw_ms: draws }); return; }
            viewer.view.tx += (i % 40 < 20 ? 1 : -1) * dx;
            var t0 = performance.now(); viewer.draw(); draws.push(performance.now() - t0);
            requestAnimationFrame(step);
          }
          requestAnimationFrame(step);
        });
      },
    };
  }

  TJ.boot = function () {
    var viewer = new Viewer(null);
    var ready;
    try {
      viewer.data = JSON.parse($("tj-data").textContent);
      viewer.frame = new TJ.Frame(viewer.data.frame);
      ready = viewer.start().catch(function (err) { viewer.fail(err); });
    } catch (err) {
      viewer.fail(err);
      ready = Promise.resolve();
    }
    window.topojaxView = api(viewer, ready);
  };

  TJ.t0 = performance.now();
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", TJ.boot);
  else TJ.boot();
})();
