/* topojax viewer: drawing (MIT licence, part of topojax).
 *
 * Everything is drawn on one canvas in map-view units (u, v) = (column, row) + 0.5,
 * mapped to the screen as (u * z + tx, v * z + ty) CSS pixels.  Rasters are pyramids of
 * PNG tiles: only the tiles in sight, at the level nearest one tile pixel per device
 * pixel, are decoded (a coarser level stands in until they are).  Polylines skip points
 * closer than a fraction of a screen pixel to the last one drawn, and edges outside the
 * view are not visited. */
"use strict";
var TJ = (window.TJ = window.TJ || {});

(function () {
  TJ.KIND_COLOURS = ["#d62728", "#1f77b4", "#9467bd", "#7f7f7f", "#8c564b"];
  TJ.GRAPH_COLOURS = ["#e6550d", "#2ca02c", "#17becf", "#bcbd22", "#e377c2"];
  var MASK_COLOURS = { ridges: [255, 176, 0], skeleton: [40, 90, 255] };
  // distance map: a dark-to-light scale through purple and orange (magma-like stops)
  var SCALE_STOPS = [
    [0, 0, 0, 4], [64, 80, 18, 123], [128, 183, 55, 121], [192, 252, 137, 97], [255, 252, 253, 191],
  ];

  /* 256 RGBA entries for a layer kind */
  TJ.lut = function (kind, name, colour) {
    var lut = new Uint8ClampedArray(1024);
    for (var v = 0; v < 256; v++) {
      var o = 4 * v;
      if (kind === "grey") {
        lut[o] = lut[o + 1] = lut[o + 2] = v; lut[o + 3] = 255;
      } else if (kind === "scale") {
        for (var s = 1; s < SCALE_STOPS.length; s++) {
          var a = SCALE_STOPS[s - 1], b = SCALE_STOPS[s];
          if (v <= b[0]) {
            var t = (v - a[0]) / (b[0] - a[0]);
            for (var ch = 0; ch < 3; ch++) lut[o + ch] = a[ch + 1] + t * (b[ch + 1] - a[ch + 1]);
            break;
          }
        }
        lut[o + 3] = 215;
      } else {
        var c = colour || MASK_COLOURS[name] || [255, 0, 255];
        lut[o] = c[0]; lut[o + 1] = c[1]; lut[o + 2] = c[2]; lut[o + 3] = v > 0 ? 255 : 0;
      }
    }
    return lut;
  };

  /* At most `limit` tile decodes at a time. */
  var queue = [], running = 0, LIMIT = 4;
  function pump() {
    while (running < LIMIT && queue.length > 0) {
      var job = queue.shift();
      running++;
      job().then(function () { running--; pump(); }, function () { running--; pump(); });
    }
  }
  TJ.decodeTile = function (b64, lut) {
    var img = new Image();
    img.src = "data:image/png;base64," + b64;
    return img.decode().then(function () {
      var canvas = document.createElement("canvas");
      canvas.width = img.naturalWidth; canvas.height = img.naturalHeight;
      var ctx = canvas.getContext("2d", { willReadFrequently: true });
      ctx.drawImage(img, 0, 0);
      var data = ctx.getImageData(0, 0, canvas.width, canvas.height);
      var px = data.data;
      for (var i = 0; i < px.length; i += 4) {
        var o = 4 * px[i];
        px[i] = lut[o]; px[i + 1] = lut[o + 1]; px[i + 2] = lut[o + 2]; px[i + 3] = lut[o + 3];
      }
      ctx.putImageData(data, 0, 0);
      return typeof createImageBitmap === "function" ? createImageBitmap(canvas) : canvas;
    });
  };

  /* One raster: a pyramid of tiles (see topojax/view/_encode.py). */
  TJ.Raster = function (spec, onTile, onError) {
    this.name = spec.name; this.label = spec.label; this.kind = spec.kind;
    this.on = spec.on; this.T = spec.tile;
    this.width = spec.width; this.height = spec.height;
    this.box = spec.box || null; // world box [x0, y0, x1, y1] of a timeline picture
    this.levels = spec.levels.map(function (l) {
      var tiles = new Map();
      l.tiles.forEach(function (t) { tiles.set(t[0] + "," + t[1], t[2]); });
      return { step: l.step, width: l.width, height: l.height, tiles: tiles };
    });
    this.lut = TJ.lut(spec.kind, spec.name, spec.colour);
    // a level pixel may cover up to this many device pixels (thin lines stay visible)
    this.boost = spec.boost || 1;
    this.cache = new Map();
    this.onTile = onTile; this.onError = onError;
    this.smooth = spec.kind === "scale";
  };
  /* the decoded tile, null while it decodes, undefined where the level has none */
  TJ.Raster.prototype.tile = function (li, tr, tc) {
    var key = li + "/" + tr + "," + tc;
    var hit = this.cache.get(key);
    if (hit !== undefined) { hit.used = TJ.frameNo; return hit.bmp; }
    var b64 = this.levels[li].tiles.get(tr + "," + tc);
    if (b64 === undefined) return undefined;
    var entry = { bmp: null, used: TJ.frameNo };
    this.cache.set(key, entry);
    var self = this;
    queue.push(function () {
      return TJ.decodeTile(b64, self.lut).then(function (bmp) {
        entry.bmp = bmp; self.onTile();
      }, function (err) {
        self.onError(new Error("a tile of the " + self.label + " layer cannot be decoded: " + err.message));
      });
    });
    pump();
    this.evict();
    return null;
  };
  TJ.Raster.prototype.evict = function () {
    if (this.cache.size <= 320) return;
    var old = [];
    this.cache.forEach(function (e, k) { if (e.bmp && e.used < TJ.frameNo - 2) old.push([e.used, k]); });
    old.sort(function (a, b) { return a[0] - b[0]; });
    for (var i = 0; i < old.length && this.cache.size > 256; i++) {
      var e = this.cache.get(old[i][1]);
      if (e.bmp && e.bmp.close) e.bmp.close();
      this.cache.delete(old[i][1]);
    }
  };
  /* decode the coarsest level first: it stands in for everything else */
  TJ.Raster.prototype.prefetch = function () {
    var li = this.levels.length - 1, self = this;
    this.levels[li].tiles.forEach(function (_, key) {
      var rc = key.split(",");
      self.tile(li, +rc[0], +rc[1]);
    });
  };
  TJ.Raster.prototype.ready = function () {
    var li = this.levels.length - 1, self = this, all = true;
    this.levels[li].tiles.forEach(function (_, key) {
      var hit = self.cache.get(li + "/" + key);
      if (!hit || !hit.bmp) all = false;
    });
    return all;
  };

  /* Draw the raster; `place` maps its pixel (col, row) box to view units:
   * [u0, v0, du per pixel] (the map itself: [0, 0, 1]). */
  TJ.Raster.prototype.draw = function (ctx, view, place) {
    var u0 = place[0], v0 = place[1], k = place[2];
    var perPixel = view.z * view.dpr * k; // device pixels per raster pixel
    var li = 0;
    // the coarsest level whose pixels are at most a device pixel (else the finest)
    for (var i = 0; i < this.levels.length; i++) if (this.levels[i].step * perPixel <= this.boost) li = i;
    var L = this.levels[li], T = this.T, span = T * L.step;
    // visible raster pixels
    var c0 = ((view.u0 - u0) / k), c1 = ((view.u1 - u0) / k);
    var r0 = ((view.v0 - v0) / k), r1 = ((view.v1 - v0) / k);
    var tc0 = Math.max(0, Math.floor(c0 / span)), tc1 = Math.min(Math.ceil(L.width / T) - 1, Math.floor(c1 / span));
    var tr0 = Math.max(0, Math.floor(r0 / span)), tr1 = Math.min(Math.ceil(L.height / T) - 1, Math.floor(r1 / span));
    ctx.imageSmoothingEnabled = this.smooth || perPixel * L.step < 1;
    for (var tr = tr0; tr <= tr1; tr++) {
      for (var tc = tc0; tc <= tc1; tc++) this.drawTile(ctx, view, place, li, tr, tc);
    }
  };
  TJ.Raster.prototype.drawTile = function (ctx, view, place, li, tr, tc) {
    var T = this.T;
    for (var lj = li; lj < this.levels.length; lj++) {
      var d = lj - li, tr2 = tr >> d, tc2 = tc >> d;
      var bmp = this.tile(lj, tr2, tc2);
      if (bmp === undefined) return; // nothing there at this level: nothing to draw
      if (bmp === null) continue; // still decoding: try a coarser level
      var Li = this.levels[li], Lj = this.levels[lj];
      // the fine tile's pixels, in the coarse tile's pixels
      var w = Math.min(T, Li.width - tc * T), h = Math.min(T, Li.height - tr * T);
      var f = Li.step / Lj.step;
      var sx = tc * T * f - tc2 * T, sy = tr * T * f - tr2 * T, sw = w * f, sh = h * f;
      var k = place[2] * Li.step;
      var du = place[0] + tc * T * k, dv = place[1] + tr * T * k;
      var x = du * view.z + view.tx, y = dv * view.z + view.ty;
      ctx.drawImage(bmp, sx, sy, sw, sh, x, y, w * k * view.z, h * k * view.z);
      return;
    }
  };

  /* Polylines (pu, pv per point; starts, sizes per line; box per line) as one path. */
  TJ.tracePolylines = function (ctx, view, L, which) {
    var z = view.z, tx = view.tx, ty = view.ty, lod = 0.6;
    var pad = 2 / z;
    ctx.beginPath();
    var n = which ? which.length : L.starts.length;
    for (var q = 0; q < n; q++) {
      var k = which ? which[q] : q, b = 4 * k;
      if (L.box[b] > view.u1 + pad || L.box[b + 2] < view.u0 - pad ||
          L.box[b + 1] > view.v1 + pad || L.box[b + 3] < view.v0 - pad) continue;
      var s = L.starts[k], e = s + L.sizes[k] - 1;
      var lx = L.pu[s] * z + tx, ly = L.pv[s] * z + ty;
      ctx.moveTo(lx, ly);
      if (s === e) { ctx.lineTo(lx + 0.01, ly); continue; }
      for (var i = s + 1; i <= e; i++) {
        var x = L.pu[i] * z + tx, y = L.pv[i] * z + ty;
        if (i === e || Math.abs(x - lx) > lod || Math.abs(y - ly) > lod) {
          ctx.lineTo(x, y); lx = x; ly = y;
        }
      }
    }
  };

  /* Vertices as squares coloured by kind.  At most one per square of the screen (the
   * first kind wins: junctions over ends over the rest); once there are many in sight
   * they lose their outline and sit on whole pixels, which draws much faster. */
  TJ.drawVertices = function (ctx, view, vu, vv, kind, n) {
    var z = view.z, tx = view.tx, ty = view.ty;
    var size = z > 1 ? 6 : z > 0.25 ? 5 : 4, half = size / 2;
    var cols = Math.ceil(view.w / size) + 2, rows = Math.ceil(view.h / size) + 2;
    var taken = new Uint8Array(cols * rows), shown = [];
    for (var c = 0; c < TJ.KIND_COLOURS.length; c++) shown.push([]);
    var count = 0;
    for (var c2 = 0; c2 < TJ.KIND_COLOURS.length; c2++) {
      for (var i = 0; i < n; i++) {
        if (kind[i] !== c2) continue;
        var u = vu[i], v = vv[i];
        if (u < view.u0 || u > view.u1 || v < view.v0 || v > view.v1) continue;
        var x = u * z + tx, y = v * z + ty;
        var cell = (Math.floor(y / size) + 1) * cols + Math.floor(x / size) + 1;
        if (taken[cell]) continue;
        taken[cell] = 1;
        shown[c2].push(x, y);
        count++;
      }
    }
    var dense = count > 1500;
    for (var k = 0; k < shown.length; k++) {
      var xy = shown[k];
      if (!xy.length) continue;
      ctx.fillStyle = TJ.KIND_COLOURS[k];
      if (dense) {
        var s = size - 1;
        for (var j = 0; j < xy.length; j += 2) ctx.fillRect(Math.round(xy[j] - s / 2), Math.round(xy[j + 1] - s / 2), s, s);
        continue;
      }
      ctx.beginPath();
      for (var q = 0; q < xy.length; q += 2) ctx.rect(xy[q] - half, xy[q + 1] - half, size, size);
      ctx.fill();
      ctx.lineWidth = 1; ctx.strokeStyle = "rgba(255,255,255,0.85)"; ctx.stroke();
    }
  };

  TJ.rgb = function (hex) {
    var v = parseInt(hex.slice(1), 16);
    return [(v >> 16) & 255, (v >> 8) & 255, v & 255];
  };

  TJ.roomColour = function (id, alpha) {
    return "hsla(" + ((id * 137.508) % 360).toFixed(1) + ",70%,52%," + alpha + ")";
  };

  /* world polyline [x, y, x, y, ...] -> screen path (added to the current path when
     `more` is set) */
  TJ.traceWorld = function (ctx, view, frame, xy, closed, more) {
    if (!more) ctx.beginPath();
    for (var i = 0; i < xy.length; i += 2) {
      var uv = frame.worldToView(xy[i], xy[i + 1]);
      var x = uv[0] * view.z + view.tx, y = uv[1] * view.z + view.ty;
      if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    }
    if (closed) ctx.closePath();
  };

  TJ.drawRooms = function (ctx, view, frame, rooms) {
    for (var i = 0; i < rooms.length; i++) {
      var r = rooms[i];
      if (r.polygon.length < 6) continue;
      TJ.traceWorld(ctx, view, frame, r.polygon, true);
      // holes (the rooms a corridor loop runs round) are left out of the fill
      var holes = r.holes || [];
      for (var k = 0; k < holes.length; k++) TJ.traceWorld(ctx, view, frame, holes[k], true, true);
      ctx.fillStyle = TJ.roomColour(r.id, 0.28); ctx.fill("evenodd");
      ctx.lineWidth = 1.5; ctx.strokeStyle = TJ.roomColour(r.id, 0.9); ctx.stroke();
    }
    // the ids over every fill, each at its room's label point (inside the room, where the
    // centroid of a ring or an L may not be); a timeline saved before had centroids only
    ctx.font = "bold 11px sans-serif"; ctx.textAlign = "center"; ctx.textBaseline = "middle";
    for (var j = 0; j < rooms.length; j++) {
      var at = rooms[j].label || rooms[j].centroid;
      if (!at) continue;
      var uv = frame.worldToView(at[0], at[1]);
      var sx = uv[0] * view.z + view.tx, sy = uv[1] * view.z + view.ty;
      var text = String(rooms[j].id), w = ctx.measureText(text).width + 6;
      ctx.fillStyle = "rgba(255,255,255,0.8)"; ctx.fillRect(sx - w / 2, sy - 8, w, 16);
      ctx.fillStyle = "#111111"; ctx.fillText(text, sx, sy + 0.5);
    }
  };

  TJ.drawDoors = function (ctx, view, frame, doors) {
    ctx.lineWidth = 4; ctx.strokeStyle = "#ff00aa"; ctx.lineCap = "round";
    for (var i = 0; i < doors.length; i++) {
      TJ.traceWorld(ctx, view, frame, doors[i].ends, false);
      ctx.stroke();
    }
    ctx.lineCap = "butt";
  };

  TJ.drawMarker = function (ctx, view, frame, x, y, colour, text) {
    var uv = frame.worldToView(x, y);
    var sx = uv[0] * view.z + view.tx, sy = uv[1] * view.z + view.ty;
    ctx.beginPath(); ctx.arc(sx, sy, 7, 0, 2 * Math.PI);
    ctx.fillStyle = colour; ctx.fill();
    ctx.lineWidth = 2; ctx.strokeStyle = "#fff"; ctx.stroke();
    if (text) {
      ctx.fillStyle = "#fff"; ctx.font = "bold 10px sans-serif";
      ctx.textAlign = "center"; ctx.textBaseline = "middle";
      ctx.fillText(text, sx, sy + 0.5);
    }
  };

  /* a length for a scale bar of about `target` CSS pixels: 1, 2 or 5 times a power of 10 */
  TJ.niceLength = function (metresPerPixel, target) {
    var raw = metresPerPixel * target;
    var p = Math.pow(10, Math.floor(Math.log10(raw)));
    var best = p;
    [1, 2, 5, 10].forEach(function (m) { if (m * p <= raw) best = m * p; });
    return best;
  };
})();
