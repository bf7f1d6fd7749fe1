/* topojax viewer: decoding the page's data (MIT licence, part of topojax).
 *
 * Arrays arrive as {t: type, n: count, z: base64 of zlib-compressed little-endian bytes};
 * graphs as flat arrays of vertices and edges whose paths are pixel steps on the map's
 * grid (or world polylines).  prepareGraph turns a graph into the arrays the drawing and
 * the routing share: every path point's world (x, y) and map-view (u, v) position. */
"use strict";
var TJ = (window.TJ = window.TJ || {});

(function () {
  var ALPHABET = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  var LOOKUP = new Uint8Array(256);
  for (var i = 0; i < ALPHABET.length; i++) LOOKUP[ALPHABET.charCodeAt(i)] = i;

  /* base64 text -> bytes */
  TJ.base64 = function (text) {
    var n = text.length;
    var pad = n > 0 && text[n - 1] === "=" ? (text[n - 2] === "=" ? 2 : 1) : 0;
    var out = new Uint8Array(((n * 3) >> 2) - pad);
    var j = 0;
    for (var k = 0; k < n; k += 4) {
      var a = LOOKUP[text.charCodeAt(k)], b = LOOKUP[text.charCodeAt(k + 1)];
      var c = LOOKUP[text.charCodeAt(k + 2)], d = LOOKUP[text.charCodeAt(k + 3)];
      var triple = (a << 18) | (b << 12) | (c << 6) | d;
      if (j < out.length) out[j++] = (triple >> 16) & 255;
      if (j < out.length) out[j++] = (triple >> 8) & 255;
      if (j < out.length) out[j++] = triple & 255;
    }
    return out;
  };

  TJ.inflate = function (bytes) {
    if (typeof DecompressionStream === "undefined") {
      return Promise.reject(
        new Error(
          "this browser cannot decompress the view's data (it lacks DecompressionStream); " +
            "open the file in a current Chrome, Edge, Firefox or Safari"
        )
      );
    }
    var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("deflate"));
    return new Response(stream).arrayBuffer();
  };

  var TYPES = {
    i1: Int8Array, u1: Uint8Array, i2: Int16Array, i4: Int32Array,
    u4: Uint32Array, f4: Float32Array, f8: Float64Array,
  };

  /* one packed array -> its typed array */
  TJ.unpack = function (packed) {
    if (packed === null || packed === undefined) return Promise.resolve(null);
    var Type = TYPES[packed.t];
    if (!Type) return Promise.reject(new Error("unknown array type " + packed.t));
    if (packed.n === 0) return Promise.resolve(new Type(0));
    return TJ.inflate(TJ.base64(packed.z)).then(function (buffer) {
      var out = new Type(buffer);
      if (out.length !== packed.n) {
        throw new Error("corrupt data: expected " + packed.n + " values, found " + out.length);
      }
      return out;
    });
  };

  /* {name: packed} -> Promise of {name: typed array} */
  TJ.unpackAll = function (obj, names) {
    return Promise.all(names.map(function (k) { return TJ.unpack(obj[k]); })).then(function (arrays) {
      var out = {};
      names.forEach(function (k, i) { out[k] = arrays[i]; });
      return out;
    });
  };

  /* The map frame: world <-> map view (u, v): u = column + 0.5 at pixel centres, v = row
   * + 0.5, the image's own axes; the same formulas as OccupancyMap. */
  TJ.Frame = function (f) {
    this.height = f.height;
    this.width = f.width;
    this.res = f.res;
    this.ox = f.origin[0];
    this.oy = f.origin[1];
    this.yaw = f.origin[2];
    this.cos = Math.cos(this.yaw);
    this.sin = Math.sin(this.yaw);
  };
  TJ.Frame.prototype.pixelToWorld = function (r, c) {
    var xm = (c + 0.5) * this.res;
    var ym = (this.height - r - 0.5) * this.res;
    return [this.ox + this.cos * xm - this.sin * ym, this.oy + this.sin * xm + this.cos * ym];
  };
  /* continuous pixel [row, col] of a world point, the formula of
   * OccupancyMap.world_to_pixel (same operations, same rounding) */
  TJ.Frame.prototype.worldToPixel = function (x, y) {
    var dx = x - this.ox, dy = y - this.oy;
    var xm = this.cos * dx + this.sin * dy;
    var ym = -this.sin * dx + this.cos * dy;
    return [this.height - 0.5 - ym / this.res, xm / this.res - 0.5];
  };
  TJ.Frame.prototype.worldToView = function (x, y) {
    var dx = x - this.ox, dy = y - this.oy;
    var xm = this.cos * dx + this.sin * dy;
    var ym = -this.sin * dx + this.cos * dy;
    return [xm / this.res, this.height - ym / this.res];
  };
  TJ.Frame.prototype.viewToWorld = function (u, v) {
    var xm = u * this.res, ym = (this.height - v) * this.res;
    return [this.ox + this.cos * xm - this.sin * ym, this.oy + this.sin * xm + this.cos * ym];
  };

  /* A graph of the payload -> Promise of its arrays:
   *   n, vx, vy (world), vu, vv (view), kind, clear, ids, degree;
   *   ne, u, v, len, cmin, cmean, sizes, starts (per edge);
   *   px, py (world), pu, pv (view) of every path point, edges one after another;
   *   rows, cols (pixels) when the paths are on the grid; box (per edge view bbox);
   *   entry (a route graph shown with its map): {reach, h, w, bits, occupied, frame}, the
   *   robot's feasible pixels and the map's occupied ones (bits, big-endian within each
   *   byte) for joining it in sight and refusing points on obstacles. */
  TJ.prepareGraph = function (g, frame) {
    var e = g.edges;
    return Promise.all([
      TJ.unpackAll(g, ["vx", "vy", "kind", "clear"]),
      TJ.unpackAll(e, ["u", "v", "len", "cmin", "cmean", "sizes", "rc", "xy"]),
      g.entry ? TJ.unpackAll(g.entry, ["feasible", "occupied"]) : Promise.resolve(null),
    ]).then(function (parts) {
      var V = parts[0], E = parts[1], F = parts[2];
      var G = {
        name: g.name, label: g.label, routable: g.routable, whyNot: g.why_not_routable,
        resolution: g.resolution_m || frame.res,
        ids: g.ids, kinds: g.kinds, n: g.n_vertices, ne: g.n_edges,
        vx: V.vx, vy: V.vy, kind: V.kind, clear: V.clear,
        u: E.u, v: E.v, len: E.len, cmin: E.cmin, cmean: E.cmean, sizes: E.sizes,
      };
      var ne = G.ne, total = 0;
      G.starts = new Int32Array(ne);
      for (var k = 0; k < ne; k++) { G.starts[k] = total; total += G.sizes[k]; }
      G.np = total;
      G.px = new Float64Array(total); G.py = new Float64Array(total);
      G.pu = new Float32Array(total); G.pv = new Float32Array(total);
      if (E.rc) {
        G.rows = new Int32Array(total); G.cols = new Int32Array(total);
        var r = 0, c = 0;
        for (var i = 0; i < total; i++) {
          r += E.rc[2 * i]; c += E.rc[2 * i + 1];
          G.rows[i] = r; G.cols[i] = c;
        }
      }
      for (var p = 0; p < total; p++) {
        var w;
        if (E.xy) w = [E.xy[2 * p], E.xy[2 * p + 1]];
        else w = frame.pixelToWorld(G.rows[p], G.cols[p]);
        G.px[p] = w[0]; G.py[p] = w[1];
        var uv = frame.worldToView(w[0], w[1]);
        G.pu[p] = uv[0]; G.pv[p] = uv[1];
      }
      G.vu = new Float32Array(G.n); G.vv = new Float32Array(G.n);
      G.degree = new Int32Array(G.n);
      for (var q = 0; q < G.n; q++) {
        var vw = frame.worldToView(G.vx[q], G.vy[q]);
        G.vu[q] = vw[0]; G.vv[q] = vw[1];
      }
      for (var m = 0; m < ne; m++) { G.degree[G.u[m]]++; G.degree[G.v[m]]++; }
      G.box = TJ.edgeBoxes(G.pu, G.pv, G.starts, G.sizes);
      G.entry = F && G.rows ? {
        reach: g.entry.reach_m, h: frame.height, w: frame.width, bits: F.feasible,
        occupied: F.occupied, frame: frame,
      } : null;
      return G;
    });
  };

  /* per polyline: [umin, vmin, umax, vmax] in a Float32Array of 4 per polyline */
  TJ.edgeBoxes = function (pu, pv, starts, sizes) {
    var n = sizes.length, box = new Float32Array(4 * n);
    for (var k = 0; k < n; k++) {
      var a = Infinity, b = Infinity, c = -Infinity, d = -Infinity;
      for (var i = starts[k], end = starts[k] + sizes[k]; i < end; i++) {
        if (pu[i] < a) a = pu[i];
        if (pv[i] < b) b = pv[i];
        if (pu[i] > c) c = pu[i];
        if (pv[i] > d) d = pv[i];
      }
      box[4 * k] = a; box[4 * k + 1] = b; box[4 * k + 2] = c; box[4 * k + 3] = d;
    }
    return box;
  };

  /* A uniform grid over points (x[i], y[i]) for nearest-point queries. */
  TJ.Grid = function (x, y, cell) {
    var n = x.length;
    this.x = x; this.y = y; this.n = n;
    var x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    for (var i = 0; i < n; i++) {
      if (x[i] < x0) x0 = x[i];
      if (y[i] < y0) y0 = y[i];
      if (x[i] > x1) x1 = x[i];
      if (y[i] > y1) y1 = y[i];
    }
    if (n === 0) { x0 = y0 = 0; x1 = y1 = 1; }
    // no more cells than about twice the points
    var area = Math.max((x1 - x0) * (y1 - y0), 1e-12);
    cell = Math.max(cell, Math.sqrt(area / Math.max(2 * n, 1)));
    this.cell = cell; this.x0 = x0; this.y0 = y0;
    this.nx = Math.floor((x1 - x0) / cell) + 1;
    this.ny = Math.floor((y1 - y0) / cell) + 1;
    var counts = new Int32Array(this.nx * this.ny + 1);
    var cellOf = new Int32Array(n);
    for (var j = 0; j < n; j++) {
      var cx = Math.floor((x[j] - x0) / cell), cy = Math.floor((y[j] - y0) / cell);
      cellOf[j] = cy * this.nx + cx;
      counts[cellOf[j] + 1]++;
    }
    for (var k = 1; k < counts.length; k++) counts[k] += counts[k - 1];
    this.offsets = counts;
    this.items = new Int32Array(n);
    var fill = counts.slice(0, counts.length - 1);
    for (var m = 0; m < n; m++) this.items[fill[cellOf[m]]++] = m;
  };
  /* nearest point to (qx, qy) within maxDist (Infinity: any): {index, dist} or null;
   * among equally near points the lowest index. */
  TJ.Grid.prototype.nearest = function (qx, qy, maxDist) {
    if (this.n === 0) return null;
    var cell = this.cell, nx = this.nx, ny = this.ny;
    var cx = Math.floor((qx - this.x0) / cell), cy = Math.floor((qy - this.y0) / cell);
    var best = -1, bestD2 = maxDist === undefined || maxDist === Infinity ? Infinity : maxDist * maxDist;
    // distance from the query to the grid's box, in cells: rings closer than that are empty
    var outX = Math.max(0, -cx, cx - (nx - 1)), outY = Math.max(0, -cy, cy - (ny - 1));
    var ringMax = Math.max(nx, ny) + Math.max(outX, outY) + 1;
    for (var ring = Math.max(outX, outY); ring <= ringMax; ring++) {
      // every point in ring `ring` or beyond is at least (ring - 1) * cell away
      var near = (ring - 1) * cell;
      if (ring > 0 && near > 0 && near * near > bestD2) break;
      for (var gy = cy - ring; gy <= cy + ring; gy++) {
        if (gy < 0 || gy >= ny) continue;
        var edgeRow = gy === cy - ring || gy === cy + ring;
        for (var gx = cx - ring; gx <= cx + ring; gx += edgeRow ? 1 : 2 * ring) {
          if (gx >= 0 && gx < nx) {
            var c = gy * nx + gx;
            for (var t = this.offsets[c], end = this.offsets[c + 1]; t < end; t++) {
              var i = this.items[t];
              var dx = this.x[i] - qx, dy = this.y[i] - qy, d2 = dx * dx + dy * dy;
              if (d2 < bestD2 || (d2 === bestD2 && i < best)) { bestD2 = d2; best = i; }
            }
          }
          if (ring === 0) break;
        }
      }
    }
    return best < 0 ? null : { index: best, dist: Math.sqrt(bestD2) };
  };
  /* every point within r of (qx, qy), by index */
  TJ.Grid.prototype.within = function (qx, qy, r) {
    var out = [];
    if (this.n === 0) return out;
    var cell = this.cell, r2 = r * r;
    var gx0 = Math.max(0, Math.floor((qx - r - this.x0) / cell));
    var gx1 = Math.min(this.nx - 1, Math.floor((qx + r - this.x0) / cell));
    var gy0 = Math.max(0, Math.floor((qy - r - this.y0) / cell));
    var gy1 = Math.min(this.ny - 1, Math.floor((qy + r - this.y0) / cell));
    for (var gy = gy0; gy <= gy1; gy++) {
      for (var gx = gx0; gx <= gx1; gx++) {
        var c = gy * this.nx + gx;
        for (var t = this.offsets[c], end = this.offsets[c + 1]; t < end; t++) {
          var i = this.items[t], dx = this.x[i] - qx, dy = this.y[i] - qy;
          if (dx * dx + dy * dy <= r2) out.push(i);
        }
      }
    }
    return out.sort(function (a, b) { return a - b; });
  };
})();
