/* topojax viewer: routes along a graph, the algorithm of topojax.RoutePlanner (MIT
 * licence, part of topojax).
 *
 * A query point snaps to the nearest corridor point: a pixel of an edge path (a vertex
 * without edges, which leads nowhere, only in a graph with no edge at all); where edges
 * cross, that point lies on each and the route may leave along any of them.  The route runs along the snapped edge to one of its ends, through the
 * graph (Dijkstra on length_m, parallel edges by their shortest, self-loops never), and
 * along the goal's edge to the snapped goal; start and goal on one edge also try the
 * direct way along it.  Lengths along an edge are its straight and diagonal pixel steps
 * scaled to the edge's length_m, as RoutePlanner counts them.  A route graph shown with
 * its map carries the robot's feasible pixels: each end then joins the graph at the
 * nearest point of any edge it sees within reach, whichever gives the shortest route
 * (where it sees none, of any edge it sees off the obstacles; where none is, an error), as
 * RoutePlanner(graph, occupancy=map) does. */
"use strict";
var TJ = (window.TJ = window.TJ || {});

(function () {
  /* Binary heap of [distance, tie, vertex, via, edge], smallest (distance, tie) first. */
  function Heap() { this.a = []; }
  function less(p, q) { return p[0] < q[0] || (p[0] === q[0] && p[1] < q[1]); }
  Heap.prototype.push = function (item) {
    var a = this.a; a.push(item);
    var i = a.length - 1;
    while (i > 0) {
      var parent = (i - 1) >> 1;
      if (!less(a[i], a[parent])) break;
      var t = a[i]; a[i] = a[parent]; a[parent] = t; i = parent;
    }
  };
  Heap.prototype.pop = function () {
    var a = this.a, top = a[0], last = a.pop();
    if (a.length > 0) {
      a[0] = last;
      var i = 0, n = a.length;
      for (;;) {
        var l = 2 * i + 1, r = l + 1, m = i;
        if (l < n && less(a[l], a[m])) m = l;
        if (r < n && less(a[r], a[m])) m = r;
        if (m === i) break;
        var t = a[i]; a[i] = a[m]; a[m] = t; i = m;
      }
    }
    return top;
  };
  Heap.prototype.size = function () { return this.a.length; };

  /* The routing structures of one prepared graph (TJ.prepareGraph). */
  TJ.Router = function (G) {
    if (!G.routable) throw new Error("this graph cannot be routed on: " + G.whyNot);
    this.G = G;
    var ne = G.ne, np = G.np;
    // cumulative length along each path from its first pixel, scaled to length_m
    var cum = new Float64Array(np);
    for (var k = 0; k < ne; k++) {
      var s = G.starts[k], n = G.sizes[k], straight = 0, diagonal = 0;
      cum[s] = 0;
      for (var i = s + 1; i < s + n; i++) {
        var dr = G.rows[i] - G.rows[i - 1], dc = G.cols[i] - G.cols[i - 1];
        if (dr !== 0 && dc !== 0) diagonal++; else straight++;
        cum[i] = (straight + diagonal * Math.SQRT2) * G.resolution;  // metres, as Python
      }
      var steps = cum[s + n - 1];
      var scale = steps > 0 ? G.len[k] / steps : 1;
      for (var j = s; j < s + n; j++) cum[j] *= scale;
      cum[s + n - 1] = G.len[k];
    }
    this.cum = cum;
    // adjacency: vertex -> Map(neighbour -> [length, edge]), the shortest parallel edge
    this.adj = [];
    for (var v = 0; v < G.n; v++) this.adj.push(new Map());
    for (var e = 0; e < ne; e++) {
      var a = G.u[e], b = G.v[e];
      if (a === b) continue;
      var pairs = [[a, b], [b, a]];
      for (var p = 0; p < 2; p++) {
        var x = pairs[p][0], y = pairs[p][1], best = this.adj[x].get(y);
        if (best === undefined || G.len[e] < best[0]) this.adj[x].set(y, [G.len[e], e]);
      }
    }
    // snap targets: every path point; the vertices without edges only where there is no
    // edge at all (they lead nowhere)
    this.lonely = [];
    if (ne === 0) for (var q = 0; q < G.n; q++) if (G.degree[q] === 0) this.lonely.push(q);
    var m = np + this.lonely.length;
    var sx = new Float64Array(m), sy = new Float64Array(m);
    sx.set(G.px); sy.set(G.py);
    for (var t = 0; t < this.lonely.length; t++) {
      sx[np + t] = G.vx[this.lonely[t]]; sy[np + t] = G.vy[this.lonely[t]];
    }
    // the edge (or -1) and position on it of every point
    this.pointEdge = new Int32Array(np);
    for (var f = 0; f < ne; f++) this.pointEdge.fill(f, G.starts[f], G.starts[f] + G.sizes[f]);
    var cell = 8 * (G.resolution || 0.05);
    this.grid = new TJ.Grid(sx, sy, cell);
    this.entry = G.entry;
    if (this.entry) {
      // the pixels off the obstacles: those a leg from a point the robot does not fit at
      // may cross (the bits past the last pixel are never read)
      var occ = this.entry.occupied, clear = new Uint8Array(occ.length);
      for (var b = 0; b < occ.length; b++) clear[b] = ~occ[b] & 255;
      this.clear = { h: this.entry.h, w: this.entry.w, bits: clear };
    }
  };

  /* Whether the straight line from pixel (q0, q1) to pixel (c0, c1) passes through
   * feasible pixels only: the pixels its ends round to (halves up) and those a piece of it
   * runs inside (or along a border of, the one it rounds to), walked row by row with the
   * arithmetic of RoutePlanner's (topojax/_sight.py), so both find the same pixels. */
  function sees(F, q0, q1, c0, c1) {
    var a0 = q0 + 0.5, a1 = q1 + 0.5, b0 = c0 + 0.5, b1 = c1 + 0.5, t;
    if (b0 < a0) { t = a0; a0 = b0; b0 = t; t = a1; a1 = b1; b1 = t; }
    var d0 = b0 - a0 > 0 ? b0 - a0 : 1, d1 = b1 - a1;
    var rLo = Math.floor(a0), n = Math.floor(b0) - rLo, x = a1;
    for (var j = 0; j <= n; j++) {
      // row rLo + j runs from column x to column y
      var y = j === n ? b1 : a1 + ((rLo + j + 1 - a0) * d1) / d0, r = rLo + j;
      var lx = Math.min(x, y), hx = Math.max(x, y);
      var lo = Math.floor(lx), hi = hx > lx ? Math.ceil(hx) - 1 : Math.floor(hx);
      if (j === 0) { lo = Math.min(lo, Math.floor(a1)); hi = Math.max(hi, Math.floor(a1)); }
      if (j === n) { lo = Math.min(lo, Math.floor(b1)); hi = Math.max(hi, Math.floor(b1)); }
      if (r < 0 || r >= F.h || lo < 0 || hi >= F.w) return false;
      for (var c = lo; c <= hi; c++) {
        var i = r * F.w + c;
        if (((F.bits[i >> 3] >> (7 - (i & 7))) & 1) === 0) return false;
      }
      x = y;
    }
    return true;
  }
  TJ.sees = sees;

  /* Where a route from (x, y) may join the graph, {dist: the nearest point's distance,
   * at: [{edge, index, vertex, dist}, ...]}: with the feasible pixels, each edge's nearest
   * point in sight over them within reach and maxSnap, else (a point the robot does not
   * fit at, or beyond reach) in sight over the pixels off the obstacles up to reach
   * farther than the nearest point and within maxSnap, else an Error, as RoutePlanner;
   * without them the nearest corridor points (one, or one per edge through it where edges
   * cross; points at most TIE metres farther count as near). */
  var TIE = 1e-9;
  TJ.Router.prototype.snap = function (x, y, maxSnap, name) {
    var hit = this.grid.nearest(x, y, Infinity);
    if (hit === null) throw new Error("the graph has no vertices or edges to route on");
    var near = this.grid.within(x, y, hit.dist + TIE), at = [];
    if (near.indexOf(hit.index) < 0) {
      near.push(hit.index);
      near.sort(function (a, b) { return a - b; });
    }
    var cap = maxSnap === null || maxSnap === undefined ? Infinity : maxSnap;
    if (this.entry && hit.dist <= cap) {
      // the points in sight over feasible pixels, else over those off the obstacles
      // a join exactly the reach away within it, and the nearest point itself within
      // the second reach, whatever the rounding (as RoutePlanner)
      var near = Math.min(this.entry.reach, cap) * (1 + 1e-12) + TIE;
      var wide = Math.min((hit.dist + this.entry.reach) * (1 + 1e-12) + TIE, cap);
      this.entries(x, y, near, this.entry, at);
      if (at.length === 0) this.entries(x, y, wide, this.clear, at);
      if (at.length === 0) {
        throw new Error(
          (name ? name + ": " : "") + "the nearest point of the graph, " +
            hit.dist.toPrecision(6) + " m away, is behind an obstacle or off the map, as " +
            "is every other within " + wide.toPrecision(6) + " m"
        );
      }
      return { dist: hit.dist, at: at };
    }
    for (var k = 0; k < near.length; k++) at.push(this.point(near[k], hit.dist));
    return { dist: hit.dist, at: at };
  };

  /* the join point of snap target i at `dist` metres */
  TJ.Router.prototype.point = function (i, dist) {
    var np = this.G.np;
    if (i >= np) return { edge: -1, index: 0, vertex: this.lonely[i - np], dist: dist };
    var e = this.pointEdge[i];
    return { edge: e, index: i - this.G.starts[e], vertex: -1, dist: dist };
  };

  /* append to `at` each edge's (or edgeless vertex's) nearest points within `reach`
   * metres that (x, y) sees over the set pixels of `mask` (every one at most TIE metres
   * farther than the edge's nearest, as without them), nearest first */
  TJ.Router.prototype.entries = function (x, y, reach, mask, at) {
    var F = this.entry, G = this.G, np = G.np, grid = this.grid;
    var q = F.frame.worldToPixel(x, y);
    var r0 = Math.floor(q[0] + 0.5), c0 = Math.floor(q[1] + 0.5);
    if (!(r0 >= 0 && r0 < mask.h && c0 >= 0 && c0 < mask.w)) return; // off the map
    var i0 = r0 * mask.w + c0;
    if (((mask.bits[i0 >> 3] >> (7 - (i0 & 7))) & 1) === 0) return; // a pixel it may not cross
    var cand = grid.within(x, y, reach).map(function (i) {
      var dx = grid.x[i] - x, dy = grid.y[i] - y;
      return [Math.sqrt(dx * dx + dy * dy), i];
    });
    cand.sort(function (a, b) { return a[0] - b[0] || a[1] - b[1]; });
    var joined = new Map(); // key -> the distance it is joined at
    for (var k = 0; k < cand.length; k++) {
      var d = cand[k][0], i = cand[k][1];
      var key = i >= np ? G.ne + this.lonely[i - np] : this.pointEdge[i];
      if (joined.has(key) && d > joined.get(key) + TIE) continue;
      var c = i >= np ? F.frame.worldToPixel(grid.x[i], grid.y[i]) : [G.rows[i], G.cols[i]];
      if (!sees(mask, q[0], q[1], c[0], c[1])) continue;
      if (!joined.has(key)) joined.set(key, d);
      at.push(this.point(i, d));
    }
  };

  /* vertex -> [cost, length along the snapped edge to it, the point of `snap.at` it is
   * left from], the cheapest over the snap's points; the cost is that length plus how much
   * longer the leg to the point is than the nearest one's (0 without the map) */
  TJ.Router.prototype.ends = function (snap) {
    var out = new Map(), G = this.G;
    function offer(n, d, p) {
      var cost = (p.dist - snap.dist) + d, old = out.get(n);
      if (old === undefined || cost < old[0]) out.set(n, [cost, d, p]);
    }
    for (var k = 0; k < snap.at.length; k++) {
      var p = snap.at[k];
      if (p.edge < 0) { offer(p.vertex, 0, p); continue; }
      var toStart = this.cum[G.starts[p.edge] + p.index];
      offer(G.u[p.edge], toStart, p);
      offer(G.v[p.edge], G.len[p.edge] - toStart, p);
    }
    return out;
  };

  TJ.Router.prototype.where = function (snap) {
    var G = this.G;
    snap = snap.at[0];
    if (snap.edge < 0) return "vertex " + G.ids[snap.vertex];
    return "edge " + G.ids[G.u[snap.edge]] + "-" + G.ids[G.v[snap.edge]];
  };

  /* The shortest route from (x0, y0) to (x1, y1), world metres:
   * {length_m, xy: [x, y, x, y, ...], vertices: [...], start_snap_m, goal_snap_m}.
   * Throws an Error (as plan_route raises) for a point beyond maxSnap metres or when no
   * corridor joins the two. */
  /* With the map, a point on an occupied pixel is an error, as RoutePlanner's. */
  TJ.Router.prototype.offObstacles = function (name, x, y) {
    var F = this.entry;
    if (!F || !F.occupied) return;
    var q = F.frame.worldToPixel(x, y);
    var r = Math.floor(q[0] + 0.5), c = Math.floor(q[1] + 0.5);
    if (r < 0 || r >= F.h || c < 0 || c >= F.w) return;
    var i = r * F.w + c;
    if ((F.occupied[i >> 3] >> (7 - (i & 7))) & 1) {
      throw new Error(name + ": a point on an obstacle of the map (pixel " + r + ", " + c + ")");
    }
  };

  TJ.Router.prototype.route = function (x0, y0, x1, y1, maxSnap) {
    this.offObstacles("start", x0, y0);
    this.offObstacles("goal", x1, y1);
    var s = this.snap(x0, y0, maxSnap, "start"), g = this.snap(x1, y1, maxSnap, "goal");
    var named = [["start", s], ["goal", g]];
    for (var i = 0; i < 2; i++) {
      if (maxSnap !== null && maxSnap !== undefined && named[i][1].dist > maxSnap) {
        throw new Error(
          named[i][0] + ": the nearest point of the graph is " + named[i][1].dist.toPrecision(6) +
            " m away, more than the " + maxSnap + " m a route may snap"
        );
      }
    }
    var G = this.G, cum = this.cum;
    // costs count the legs beyond the nearest ones (as RoutePlanner); `length` is along
    // the graph
    var best = Infinity, length = 0, plan = null, ps = null, pg = null;
    for (var a = 0; a < s.at.length; a++) {
      for (var b = 0; b < g.at.length; b++) {
        var sa = s.at[a], gb = g.at[b], legs = (sa.dist - s.dist) + (gb.dist - g.dist);
        if (sa.edge >= 0 && sa.edge === gb.edge) {
          var direct = Math.abs(cum[G.starts[gb.edge] + gb.index] - cum[G.starts[sa.edge] + sa.index]);
          if (legs + direct < best) {
            best = legs + direct; length = direct; plan = "direct"; ps = sa; pg = gb;
          }
        } else if (sa.edge < 0 && gb.edge < 0 && sa.vertex === gb.vertex && legs < best) {
          best = legs; length = 0; plan = "vertex"; ps = sa; pg = gb;
        }
      }
    }
    var sources = this.ends(s), targets = this.ends(g);
    var parent = new Map(), heap = new Heap(), tie = 0, reached = -1;
    sources.forEach(function (d, n) { heap.push([d[0], tie++, n, -1, -1, d[1]]); });
    while (heap.size() > 0) {
      var item = heap.pop(), d = item[0], n = item[2], along = item[5];
      if (parent.has(n)) continue;
      if (d >= best) break;
      parent.set(n, [item[3], item[4]]);
      if (targets.has(n) && d + targets.get(n)[0] < best) {
        best = d + targets.get(n)[0]; length = along + targets.get(n)[1];
        reached = n; plan = "graph";
      }
      for (var entry of this.adj[n]) {
        var m = entry[0], we = entry[1];
        if (!parent.has(m) && d + we[0] < best) {
          heap.push([d + we[0], tie++, m, n, we[1], along + we[0]]);
        }
      }
    }
    if (plan === null) {
      throw new Error(
        "no route from the start (snapped to " + this.where(s) + ") to the goal (snapped to " +
          this.where(g) + "): they lie in different components of the graph"
      );
    }
    var pieces = [], chain = [];
    if (plan === "direct") {
      pieces.push([ps.edge, ps.index, pg.index]);
    } else if (plan === "graph") {
      chain = [reached];
      var hops = [];
      while (parent.get(chain[chain.length - 1])[0] !== -1) {
        var step = parent.get(chain[chain.length - 1]);
        hops.push(step[1]); chain.push(step[0]);
      }
      chain.reverse(); hops.reverse();
      var from = sources.get(chain[0]), to = targets.get(chain[chain.length - 1]);
      ps = from[2]; pg = to[2];
      if (ps.edge >= 0) pieces.push(this.partial(ps.edge, ps.index, chain[0], from[1]));
      for (var h = 0; h < hops.length; h++) {
        var e = hops[h];
        pieces.push(G.u[e] === chain[h] ? [e, 0, G.sizes[e] - 1] : [e, G.sizes[e] - 1, 0]);
      }
      if (pg.edge >= 0) {
        var last = this.partial(pg.edge, pg.index, chain[chain.length - 1], to[1]);
        pieces.push([last[0], last[2], last[1]]);
      }
    }
    var xy = this.polyline(pieces, ps);
    return {
      length_m: length, xy: xy, start_snap_m: ps.dist, goal_snap_m: pg.dist,
      vertices: chain.map(function (v) { return G.ids[v]; }),
    };
  };

  /* [edge, from index, to index]: the piece of edge e from `index` to its end at
   * `vertex` (the end `along` metres away when both ends are that vertex) */
  TJ.Router.prototype.partial = function (e, index, vertex, along) {
    var G = this.G, toStart = this.cum[G.starts[e] + index];
    if (G.u[e] === vertex && (G.v[e] !== vertex || toStart === along)) return [e, index, 0];
    return [e, index, G.sizes[e] - 1];
  };

  TJ.Router.prototype.polyline = function (pieces, s) {
    var G = this.G, xy = [];
    for (var k = 0; k < pieces.length; k++) {
      var e = pieces[k][0], i = pieces[k][1], j = pieces[k][2], base = G.starts[e];
      var dir = j >= i ? 1 : -1;
      for (var p = i; ; p += dir) {
        var x = G.px[base + p], y = G.py[base + p], n = xy.length;
        if (!(n >= 2 && xy[n - 2] === x && xy[n - 1] === y)) xy.push(x, y);
        if (p === j) break;
      }
    }
    if (xy.length === 0 && s.edge < 0) xy.push(G.vx[s.vertex], G.vy[s.vertex]);
    return xy;
  };
})();
