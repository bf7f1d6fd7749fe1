"""Coverage and directness of a route graph: waypoints where feasible space lies farther
than the snap distance from the graph, and straight shortcut edges where the graph's route
between two nearby vertices is materially longer than the straight line (a greedy
spanner)."""

from __future__ import annotations

import heapq
import math

import cv2
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree
from skimage.graph import MCP_Geometric

from ._work import WorkGraph, line_pixels


def graph_raster(work: WorkGraph, shape: tuple[int, int]) -> np.ndarray:
    """Pixels (bool (H, W)) of the graph's live vertices and edge paths."""
    mask = np.zeros(shape, bool)
    for _, _, path in work.edges.values():
        mask[path[:, 0], path[:, 1]] = True
    for v, members in enumerate(work.members):
        if v not in work.dead:
            mask[members[:, 0], members[:, 1]] = True
    return mask


def covered(raster: np.ndarray, feasible: np.ndarray, snap_px: float) -> np.ndarray:
    """Feasible pixels within ``snap_px`` of the graph through the feasible space (a
    geodesic dilation of the graph's pixels in steps of a small disc, cut to the Euclidean
    ball of radius ``snap_px`` around the graph)."""
    step = int(max(1, min(3, round(snap_px / 4))))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * step + 1, 2 * step + 1))
    out = (raster & feasible).view(np.uint8)
    feas = feasible.view(np.uint8)
    n_steps = int(snap_px // step)
    for _ in range(n_steps):
        out = cv2.dilate(out, kernel) & feas
    rest = int(math.ceil(snap_px - n_steps * step))
    if rest >= 1:
        last = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * rest + 1, 2 * rest + 1))
        out = cv2.dilate(out, last) & feas
    # Chained digital discs reach a little past their radii; no pixel farther than snap_px
    # in a straight line can be within snap_px through the feasible space.
    far = (~raster).view(np.uint8)
    within = cv2.distanceTransform(far, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) <= snap_px
    return out.view(bool) & within


def segment_ok(a, b, feasible: np.ndarray) -> np.ndarray | None:
    """The straight pixel line from ``a`` to ``b`` if all its pixels are feasible."""
    path = line_pixels(a, b)
    return path if feasible[path[:, 0], path[:, 1]].all() else None


def attach_points(work: WorkGraph, pixels: list, shape: tuple[int, int]) -> list[int]:
    """Vertices at the graph pixels ``pixels`` (each on a vertex or an edge): an edge is
    split at every requested interior pixel.  Returns one vertex id per pixel (-1 for a
    pixel that is on neither)."""
    width = shape[1]
    want = {int(r) * width + int(c): [] for r, c in pixels}
    for k, (r, c) in enumerate(pixels):
        want[int(r) * width + int(c)].append(k)
    out = [-1] * len(pixels)
    for v, members in enumerate(work.members):
        if v in work.dead:
            continue
        for key in (members[:, 0].astype(np.int64) * width + members[:, 1]).tolist():
            for k in want.pop(key, ()):
                out[k] = v
    splits: dict[int, dict[int, list]] = {}
    if want:
        keys = np.fromiter(want, np.int64)
        for e, (_, _, path) in list(work.edges.items()):
            flat = path[1:-1, 0].astype(np.int64) * width + path[1:-1, 1]
            hit = np.flatnonzero(np.isin(flat, keys))
            for i in hit.tolist():
                ks = want.pop(int(flat[i]), None)
                if ks:
                    splits.setdefault(e, {})[i + 1] = ks
            if not want:
                break
            keys = np.fromiter(want, np.int64)
    for e, at in splits.items():
        u, v, path = work.edges[e]
        work.remove_edge(e)
        prev, prev_i = u, 0
        for i in sorted(at):
            w = work.add_vertex(path[i])
            work.add_edge(prev, w, path[prev_i : i + 1])
            for k in at[i]:
                out[k] = w
            prev, prev_i = w, i
        work.add_edge(prev, v, path[prev_i:])
    return out


def _waypoint_candidates(uncovered: np.ndarray, spacing_px: float) -> np.ndarray:
    """Uncovered pixels on a square grid of ``spacing_px``, plus one pixel of each
    uncovered component that holds no grid point."""
    h, w = uncovered.shape
    s = max(1.0, spacing_px)
    rows = np.arange(s / 2, h, s).astype(np.int64)
    cols = np.arange(s / 2, w, s).astype(np.int64)
    rr, cc = np.meshgrid(rows, cols, indexing="ij")
    on = uncovered[rr, cc]
    pts = [np.stack([rr[on], cc[on]], axis=1)]
    n, labels = cv2.connectedComponents(uncovered.view(np.uint8), connectivity=8)
    hit = np.zeros(n, bool)
    hit[labels[rr[on], cc[on]]] = True
    missing = np.flatnonzero(~hit[1:]) + 1
    if len(missing):
        ys, xs = np.nonzero(np.isin(labels, missing))
        order = np.argsort(labels[ys, xs], kind="stable")
        ys, xs = ys[order], xs[order]
        _, first, counts = np.unique(labels[ys, xs], return_index=True, return_counts=True)
        mid = first + counts // 2  # the middle pixel (raster order) of each component
        pts.append(np.stack([ys[mid], xs[mid]], axis=1))
    return np.concatenate(pts).astype(np.int64)


def _geodesic_path(start, targets: np.ndarray, feasible: np.ndarray) -> np.ndarray | None:
    """Shortest 8-connected feasible pixel path from ``start`` to the nearest pixel of
    ``targets`` (bool mask), or None; searched in windows around ``start`` that double
    in size until one holds a reachable target."""
    h, w = feasible.shape
    half = 64
    while True:
        r0, r1 = max(0, start[0] - half), min(h, start[0] + half + 1)
        c0, c1 = max(0, start[1] - half), min(w, start[1] + half + 1)
        sub = targets[r0:r1, c0:c1]
        if sub.any():
            cost = np.where(feasible[r0:r1, c0:c1], 1.0, np.inf)
            mcp = MCP_Geometric(cost, fully_connected=True)
            costs, _ = mcp.find_costs([(start[0] - r0, start[1] - c0)])
            reached = np.isfinite(costs) & sub
            if reached.any():
                cand = np.argwhere(reached)
                end = cand[np.argmin(costs[reached])]
                path = np.asarray(mcp.traceback(tuple(end)), np.int32)
                return path + np.array([r0, c0], np.int32)
        if r0 == 0 and c0 == 0 and r1 == h and c1 == w:
            return None
        half *= 2


def add_coverage(
    work: WorkGraph, feasible: np.ndarray, snap_px: float, rounds: int = 6
) -> np.ndarray:
    """Add waypoints joined by straight feasible edges (a shortest spanning tree, or a
    feasible shortest path where no straight edge reaches) until every feasible pixel
    lies within ``snap_px`` of the graph, or ``rounds`` rounds are spent.  Returns the
    feasible pixels still uncovered (bool (H, W))."""
    shape = feasible.shape
    spacing = 1.3 * snap_px
    for k in range(rounds + 1):
        raster = graph_raster(work, shape)
        uncovered = feasible & ~covered(raster, feasible, snap_px)
        if k == rounds or not uncovered.any():
            break
        pts = _waypoint_candidates(uncovered, spacing)
        _connect_waypoints(work, pts, raster, feasible, spacing)
        spacing *= 0.7  # leftovers lie between earlier waypoints
    return uncovered


def _connect_waypoints(
    work: WorkGraph, pts: np.ndarray, raster: np.ndarray, feasible: np.ndarray, spacing: float
) -> None:
    """Join the waypoints ``pts`` (n, 2) to the graph ``raster`` and to each other by the
    shortest straight feasible edges that connect them all (Kruskal, the graph being one
    node), then by feasible shortest paths for the groups left apart."""
    n = len(pts)
    if n == 0:
        return
    shape = feasible.shape
    graph_px = np.argwhere(raster)
    _, nearest = cKDTree(graph_px).query(pts)
    cands = []
    for i, p in enumerate(pts):
        g = graph_px[nearest[i]]
        seg = segment_ok(p, g, feasible)
        if seg is not None:
            cands.append((len(seg), i, n, seg))
    tree = cKDTree(pts)
    for i, j in tree.query_pairs(2.0 * spacing, output_type="ndarray"):
        seg = segment_ok(pts[i], pts[j], feasible)
        if seg is not None:
            cands.append((len(seg), int(i), int(j), seg))
    cands.sort(key=lambda t: t[0])
    parent = list(range(n + 1))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    chosen = []
    for _, i, j, seg in cands:
        a, b = find(i), find(j)
        if a != b:
            parent[a] = b
            chosen.append((i, j, seg))
    # groups that reach no graph pixel in a straight line: a feasible shortest path
    roots = {find(i) for i in range(n)} - {find(n)}
    extra = []
    for root in roots:
        i = next(k for k in range(n) if find(k) == root)
        path = _geodesic_path(pts[i], raster, feasible)
        if path is not None:
            extra.append((i, path))
            parent[root] = find(n)
    graph_ends = [tuple(seg[-1]) for i, j, seg in chosen if j == n]
    graph_ends += [tuple(path[-1]) for _, path in extra]
    ids = attach_points(work, graph_ends, shape)
    wid = [work.add_vertex(p) if find(i) == find(n) else -1 for i, p in enumerate(pts)]
    k = 0
    for i, j, seg in chosen:
        if j == n:
            if ids[k] >= 0:
                work.add_edge(wid[i], ids[k], seg)
            k += 1
        elif wid[i] >= 0 and wid[j] >= 0:
            work.add_edge(wid[i], wid[j], seg)
    for i, path in extra:
        if ids[k] >= 0:
            work.add_edge(wid[i], ids[k], path)
        k += 1
    for v in wid:
        if v >= 0 and not work.adj[v]:
            work.dead.add(v)


def _bounded_distance(nbr: dict, src: int, dst: int, cutoff: float) -> float:
    """Graph distance from ``src`` to ``dst`` if at most ``cutoff``, else ``inf``."""
    dist = {src: 0.0}
    heap = [(0.0, src)]
    while heap:
        d, u = heapq.heappop(heap)
        if u == dst:
            return d
        if d > dist.get(u, math.inf):
            continue
        for v, w in nbr.get(u, ()):
            nd = d + w
            if nd <= cutoff and nd < dist.get(v, math.inf):
                dist[v] = nd
                heapq.heappush(heap, (nd, v))
    return math.inf


def add_shortcuts(
    work: WorkGraph,
    feasible: np.ndarray,
    radius_px: float,
    stretch: float,
    gain_px: float,
    from_dead_ends: bool = True,
    end_px: float = 2.0,
    min_loop_px: float = 0.0,
) -> int:
    """Greedy spanner: for vertex pairs at most ``radius_px`` apart, shortest first, add a
    straight feasible edge when the graph route between them is longer than ``stretch``
    times the straight line and than the straight line plus ``gain_px``, and the edge
    touches no other edge farther than ``end_px`` from its ends (no crossing) and closes
    no loop shorter than ``min_loop_px`` (graph route plus straight line); with
    ``from_dead_ends`` False, only between vertices of two or more edges.  Returns the
    number of edges added."""
    min_deg = 1 if from_dead_ends else 2
    alive = [v for v in range(len(work.pixel)) if v not in work.dead and work.adj[v]]
    if len(alive) < 2 or radius_px <= 0:
        return 0
    pos = np.array([work.pixel[v] for v in alive], np.float64)
    pairs = cKDTree(pos).query_pairs(radius_px, output_type="ndarray")
    deg = np.array([len(work.adj[v]) for v in alive])
    if len(pairs):
        pairs = pairs[(deg[pairs[:, 0]] >= min_deg) & (deg[pairs[:, 1]] >= min_deg)]
    if len(pairs) == 0:
        return 0
    index = {v: k for k, v in enumerate(alive)}
    rows, cols, vals = [], [], []
    for e, (u, v, _) in work.edges.items():
        if u != v:
            rows.append(index[u])
            cols.append(index[v])
            vals.append(work.length[e])
    m = len(alive)
    # parallel edges: keep the shortest (sum_duplicates would add them)
    best: dict[tuple[int, int], float] = {}
    for a, b, w in zip(rows, cols, vals, strict=True):
        key = (min(a, b), max(a, b))
        if w < best.get(key, math.inf):
            best[key] = w
    ka = np.array([k[0] for k in best], np.int64)
    kb = np.array([k[1] for k in best], np.int64)
    kw = np.array(list(best.values()))
    mat = coo_matrix((kw, (ka, kb)), shape=(m, m)).tocsr()
    straight = np.hypot(*(pos[pairs[:, 0]] - pos[pairs[:, 1]]).T)
    sources = np.unique(pairs[:, 0])
    graph_d = np.empty(len(pairs))
    limit = stretch * radius_px
    chunk = max(1, 4_000_000 // m)
    for s in range(0, len(sources), chunk):
        src = sources[s : s + chunk]
        d = dijkstra(mat, directed=False, indices=src, limit=limit)
        row_of = np.full(m, -1, np.int64)
        row_of[src] = np.arange(len(src))
        sel = np.isin(pairs[:, 0], src)
        graph_d[sel] = d[row_of[pairs[sel, 0]], pairs[sel, 1]]
    need = np.maximum(stretch * straight, straight + gain_px)
    cand = np.flatnonzero((graph_d > need) & (graph_d + straight >= min_loop_px))
    cand = cand[np.argsort(straight[cand], kind="stable")]
    nbr = work.neighbours()
    # shortcuts cross no edge: a crossing without a vertex would let a query point snap
    # onto a long edge that leads away from its goal (and doubles the edges in open rooms)
    occupied = _grow(graph_raster(work, feasible.shape))
    # A route from u shorter than ``need`` that uses a new edge reaches one of its ends
    # within ``need`` in a straight line: without such an end nearby, the distance
    # computed above still holds and the check on the grown graph is skipped.
    cell = float(max(1.0, need.max(initial=1.0)))
    near: dict[tuple[int, int], list] = {}
    added = 0
    for k in cand:
        u, v = alive[pairs[k, 0]], alive[pairs[k, 1]]
        if _end_within(near, cell, pos[pairs[k, 0]], need[k]) and (
            _bounded_distance(nbr, u, v, need[k]) < math.inf
        ):
            continue
        short = min_loop_px - straight[k]
        if short > 0 and _bounded_distance(nbr, u, v, short) < math.inf:
            continue  # the loop it would close, through earlier shortcuts, is too short
        seg = segment_ok(work.pixel[u], work.pixel[v], feasible)
        if seg is None:
            continue
        inner = _away_from_ends(seg, work.members[u], work.members[v], end_px)
        if occupied[inner[:, 0], inner[:, 1]].any():
            continue
        _mark(occupied, seg)
        e = work.add_edge(u, v, seg)
        w = work.length[e]
        nbr.setdefault(u, []).append((v, w))
        nbr.setdefault(v, []).append((u, w))
        for p in (pos[pairs[k, 0]], pos[pairs[k, 1]]):
            near.setdefault((int(p[0] // cell), int(p[1] // cell)), []).append(p)
        added += 1
    return added


def _end_within(near: dict, cell: float, p: np.ndarray, dist: float) -> bool:
    """Is a point of the grid buckets ``near`` (cells of side ``cell`` >= ``dist``)
    within ``dist`` of ``p``?"""
    ci, cj = int(p[0] // cell), int(p[1] // cell)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            for q in near.get((ci + di, cj + dj), ()):
                if (q[0] - p[0]) ** 2 + (q[1] - p[1]) ** 2 <= dist * dist:
                    return True
    return False


def _grow(mask: np.ndarray) -> np.ndarray:
    """``mask`` (bool (H, W)) dilated by one pixel (3 x 3)."""
    return cv2.dilate(mask.view(np.uint8), np.ones((3, 3), np.uint8)).view(bool)


def _mark(mask: np.ndarray, seg: np.ndarray) -> None:
    """Set the pixels of ``seg`` (K, 2) and their 8 neighbours in ``mask``."""
    h, w = mask.shape
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            mask[np.clip(seg[:, 0] + dr, 0, h - 1), np.clip(seg[:, 1] + dc, 0, w - 1)] = True


def _away_from_ends(seg: np.ndarray, mu: np.ndarray, mv: np.ndarray, end_px: float):
    """Pixels of ``seg`` more than ``end_px`` (Chebyshev) from its ends and from the
    pixels ``mu``, ``mv`` (M, 2) of its end vertices: where it must not touch another
    edge."""
    ends = np.concatenate([mu, mv, seg[:1], seg[-1:]]).astype(np.int64)
    d = np.abs(seg[:, None, :].astype(np.int64) - ends[None, :, :]).max(axis=2).min(axis=1)
    return seg[d > end_px]
