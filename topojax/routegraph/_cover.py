"""Coverage and directness of a route graph: lanes, meshes and waypoints where feasible
space lies farther than the snap distance from the graph, and straight shortcut edges where the graph's route
between two nearby vertices is materially longer than the straight line (a greedy
spanner)."""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy.spatial import cKDTree

from ..fields.clearance import distance_transform_px
from ..graph.work import WorkGraph, line_pixels, lines_pixels
from ._corners import bent_candidates, reflex_corners
from ._joins import (
    GraphPixels,
    attach_points,
    feasible_segments,
    geodesic_path,
    grow,
    mask_pixels,
    pieces_by_area,
)
from ._lanes import LANE_MIN_AREA, add_lanes
from ._mesh import MESH_MIN_AREA, MESH_SPACING, add_mesh
from ._spanner import anchor_pieces, clear_lines, greedy_shortcuts, see_named, see_within

#: Coverage waypoints lie on a square grid of this many snap distances (a disc of the snap
#: distance around each grid point covers its cell up to sqrt 2 / 2 of the spacing).
COVER_SPACING = 1.3
#: Two points along edges (anchors) get a shortcut, a *rung*, only where the graph route
#: between them is longer than this many times their distance ...
RUNG_STRETCH = 3.0
#: ... and than their distance plus this many metres: lanes joined to the rest far away
#: (along both walls of a corridor 2.5-4 m wide) get a rung every few metres.
RUNG_GAIN_M = 6.0
# The 5 x 5 labelled distance transform names a graph pixel at most this factor (plus a
# pixel) farther than the nearest one.
_LABEL_SLACK = 1.05
# The labelled transform (its cost goes with the window's pixels) names each tested pixel's
# graph pixel when the row-by-row search (:func:`see_within`, 2 x snap + 1 rows per tested
# pixel) would read more than this many rows per pixel of the window.
_ROWS_PER_PIXEL = 4


def graph_raster(work: WorkGraph, shape: tuple[int, int]) -> np.ndarray:
    """Pixels (bool (H, W)) of the graph's live vertices and edge paths."""
    mask = np.zeros(shape, bool)
    parts = [path for _, _, path in work.edges.values()]
    parts += [m for v, m in enumerate(work.members) if v not in work.dead]
    if parts:
        every = np.concatenate(parts)
        mask[every[:, 0], every[:, 1]] = True
    return mask


def _grown_raster(work: WorkGraph, shape: tuple[int, int], seen: tuple[int, int]):
    """``(pixels, seen)``: the pixels (bool (H, W)) of the live vertices and edges of
    ``work`` made since it had ``seen`` = ``(vertices, next edge id)``, and that pair now.
    Where the graph only grows (edges split into pieces over the same pixels, vertices
    and edges removed only when made since), the graph's raster is the previous one with
    these pixels."""
    n_vertices, first_edge = seen
    mask = np.zeros(shape, bool)
    parts = []
    for e in reversed(work.edges):  # edge ids grow in the order the edges were made
        if e < first_edge:
            break
        parts.append(work.edges[e][2])
    dead = work.dead
    parts += [work.members[v] for v in range(n_vertices, len(work.members)) if v not in dead]
    if parts:
        every = np.concatenate(parts)
        mask[every[:, 0], every[:, 1]] = True
    return mask, (len(work.members), work.next_edge_id)


def covered(
    raster: np.ndarray,
    feasible: np.ndarray,
    snap_px: float,
    wall: np.ndarray | None = None,
    among: np.ndarray | None = None,
) -> np.ndarray:
    """Feasible pixels that see a pixel of the graph (``raster``) within ``snap_px`` along
    a straight segment over feasible pixels (a robot snaps along a straight line; such a
    pixel is within ``snap_px`` of the graph through the feasible space too).

    ``wall``: each pixel's distance to the nearest pixel that is not feasible (float32
    (H, W), :func:`wall_distance`), computed when not given.  ``among``: only these
    pixels (bool (H, W)) are tested, the others are returned False."""
    if wall is None:
        wall = wall_distance(feasible)
    test = feasible if among is None else among & feasible
    if not raster.any() or not test.any():
        return np.zeros(feasible.shape, bool)
    rows_read = np.count_nonzero(test) * (2 * math.floor(snap_px) + 1)
    if rows_read > _ROWS_PER_PIXEL * test.size:
        # the labelled transform names a graph pixel near each pixel, at most
        # _LABEL_SLACK times (plus a pixel) farther than the nearest one; where the named
        # pixel is hidden or out of reach, another within reach may still be seen
        free = (~raster).view(np.uint8)
        _, label = cv2.distanceTransformWithLabels(
            free, cv2.DIST_L2, cv2.DIST_MASK_5, labelType=cv2.DIST_LABEL_PIXEL
        )
        out, rr, cc = see_named(
            test,
            label,
            mask_pixels(raster),
            wall,
            feasible,
            float(snap_px),
            _LABEL_SLACK * snap_px + 1.0,
        )
    else:
        out = np.zeros(feasible.shape, bool)
        pts = mask_pixels(test)
        # contiguous, as see_named's are: one compiled variant of see_within
        rr, cc = np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1])
    out[rr, cc] = see_within(rr, cc, raster, wall, feasible, float(snap_px))
    return out


def wall_distance(feasible: np.ndarray) -> np.ndarray:
    """Distance (pixels, float32 (H, W)) of each pixel to the nearest pixel that is not
    feasible (exact Euclidean)."""
    return distance_transform_px(feasible)


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
        lookup = np.zeros(n, bool)
        lookup[missing] = True
        ys, xs = mask_pixels(lookup[labels]).T
        order = np.argsort(labels[ys, xs], kind="stable")
        ys, xs = ys[order], xs[order]
        _, first, counts = np.unique(labels[ys, xs], return_index=True, return_counts=True)
        mid = first + counts // 2  # the middle pixel (raster order) of each component
        pts.append(np.stack([ys[mid], xs[mid]], axis=1))
    return np.concatenate(pts).astype(np.int64)


def add_coverage(
    work: WorkGraph,
    feasible: np.ndarray,
    snap_px: float,
    rounds: int = 6,
    min_loop_px: float = 0.0,
    wall: np.ndarray | None = None,
    among: np.ndarray | None = None,
) -> np.ndarray:
    """Add lanes along the walls (:func:`add_lanes`), then a triangulated mesh through the
    large open pieces left (:func:`add_mesh`) and lanes along the skeleton of the smaller
    ones, then waypoints joined by straight feasible edges (a shortest spanning tree, or a feasible shortest path where no straight edge
    reaches), until every feasible pixel is covered (:func:`covered`) or ``rounds``
    waypoint rounds are spent.  Returns the feasible pixels still uncovered (bool
    (H, W)).  The mesh closes no loop shorter than ``min_loop_px``.  ``wall``:
    :func:`wall_distance` of ``feasible``, computed when not given.  ``among``: only
    these pixels (bool (H, W)) need covering, the others count as covered."""
    shape = feasible.shape
    spacing = COVER_SPACING * snap_px
    lane_round, grid_round = 0, 0  # lane rounds: along the walls, then mesh and skeleton
    if wall is None:
        wall = wall_distance(feasible)
    uncovered = feasible if among is None else feasible & among
    raster, seen = None, (0, 0)
    while True:
        # the graph only grows: what was covered stays covered, and a pixel still
        # uncovered can only see a graph pixel added since the last test
        added, seen = _grown_raster(work, shape, seen)
        if raster is not None:
            added &= ~raster
            raster = raster | added  # a new array: the rounds' joins hold the old one
        else:
            raster = added.copy()
        uncovered = uncovered & ~covered(added, feasible, snap_px, wall, among=uncovered)
        if grid_round == rounds or not uncovered.any():
            break
        if lane_round == 0:
            lane_round = 1
            if add_lanes(work, uncovered, raster, feasible, wall, snap_px, min_loop_px, True):
                continue
        if lane_round == 1:
            lane_round = 2
            # the large pieces get a mesh, the smaller ones lanes along their skeleton
            rest, open_ = pieces_by_area(
                uncovered, LANE_MIN_AREA * snap_px**2, MESH_MIN_AREA * snap_px**2
            )
            pixels = GraphPixels(raster)  # both join to the same graph pixels
            meshed = add_mesh(work, open_, raster, feasible, snap_px, min_loop_px, pixels=pixels)
            laned = add_lanes(
                work,
                rest,
                raster,
                feasible,
                wall,
                snap_px,
                min_loop_px,
                False,
                sized=True,
                pixels=pixels,
            )
            del pixels
            if meshed or laned:
                continue
        # pieces too small for lanes: waypoints from now on
        pts = _waypoint_candidates(uncovered, spacing)
        _connect_waypoints(work, pts, raster, feasible, spacing)
        spacing *= 0.7  # leftovers lie between earlier waypoints
        grid_round += 1
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
    graph_px = mask_pixels(raster)
    _, nearest = cKDTree(graph_px).query(pts)
    pairs = cKDTree(pts).query_pairs(2.0 * spacing, output_type="ndarray").astype(np.int64)
    # candidates: each waypoint to its nearest graph pixel, then pairs of waypoints
    ends_i = np.concatenate([np.arange(n, dtype=np.int64), pairs[:, 0]])
    ends_j = np.concatenate([np.full(n, n, np.int64), pairs[:, 1]])
    a = pts[ends_i].astype(np.int64)
    b = np.concatenate([graph_px[nearest], pts[pairs[:, 1]]]).astype(np.int64)
    ok = np.flatnonzero(feasible_segments(a, b, feasible, False))
    size = np.abs(a[ok] - b[ok]).max(axis=1) + 1
    cands = list(
        zip(size.tolist(), ends_i[ok].tolist(), ends_j[ok].tolist(), ok.tolist(), strict=True)
    )
    cands.sort(key=lambda t: t[0])
    parent = list(range(n + 1))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    chosen = []
    for _, i, j, k in cands:
        ri, rj = find(i), find(j)
        if ri != rj:
            parent[ri] = rj
            chosen.append((i, j, line_pixels(a[k], b[k])))
    # groups that reach no graph pixel in a straight line: a feasible shortest path
    first: dict[int, int] = {}  # the first waypoint of each group
    for k in range(n):
        first.setdefault(find(k), k)
    roots = set(first) - {find(n)}
    extra = []
    for root in roots:
        i = first[root]
        path = geodesic_path(pts[i], raster, feasible)
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


def _anchor_graph(work: WorkGraph, alive: list[int], spacing_px: float, keep_px: float):
    """The live graph with extra nodes (*anchors*) along its edges, about ``spacing_px``
    apart and at least ``keep_px`` of path from either end, so that shortcuts may start
    part-way along an edge.

    Returns ``(pos int64 (N, 2), degree (N,), on_edge (N, 3), u, v (int64 (P,)), w
    float64 (P,))``: nodes ``0..len(alive) - 1`` are the vertices ``alive``, the rest
    anchors; ``on_edge`` holds, for an anchor, the nodes at the two ends of its edge and
    the edge's first anchor (-1 for a vertex); ``u``-``v`` the pieces between consecutive
    nodes along each edge (no self-loops, the shortest of parallel pieces) and ``w`` their
    lengths in pixels."""
    index = {v: k for k, v in enumerate(alive)}
    n0 = len(alive)
    vpos = np.array([work.pixel[v] for v in alive], np.int64).reshape(-1, 2)
    vdeg = np.array([len(work.adj[v]) for v in alive], np.int64)
    ends = np.array([(index[a], index[b]) for a, b, _ in work.edges.values()], np.int64)
    ends = ends.reshape(-1, 2)
    paths = [path for _, _, path in work.edges.values()]
    sizes = np.array([len(p) for p in paths], np.int64)
    lengths = np.array([work.length[e] for e in work.edges], np.float64)
    # a one-pixel edge has no anchor: one piece of its recorded length
    single = (sizes < 2) & (ends[:, 0] != ends[:, 1])
    long = sizes >= 2
    every = (
        np.concatenate([p for p, ok in zip(paths, long, strict=True) if ok]).astype(np.int64)
        if long.any()
        else np.zeros((0, 2), np.int64)
    )
    starts = np.r_[0, np.cumsum(sizes[long])[:-1]].astype(np.int64)
    at, first, owner, pu, pv, pw = anchor_pieces(
        every, starts, sizes[long], ends[long, 0], ends[long, 1], n0, spacing_px, keep_px
    )
    on = np.full((n0 + at.size, 3), -1, np.int64)
    on[n0:, 0] = ends[long, 0][owner]
    on[n0:, 1] = ends[long, 1][owner]
    on[n0:, 2] = first
    pos = np.concatenate([vpos, every[at]])
    deg = np.concatenate([vdeg, np.full(at.size, 2, np.int64)])
    u = np.r_[ends[single, 0], pu].astype(np.int64)
    v = np.r_[ends[single, 1], pv].astype(np.int64)
    w = np.r_[lengths[single], pw].astype(np.float64)
    lo, hi = np.minimum(u, v), np.maximum(u, v)
    order = np.lexsort((w, hi, lo))
    lo, hi, w = lo[order], hi[order], w[order]
    keep = np.r_[True, (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])] if lo.size else lo.astype(bool)
    return pos, deg, on, lo[keep], hi[keep], w[keep]


def _same_edge(a, b, on, vert_key, m, neighbours: bool = True) -> np.ndarray:
    """Pairs of nodes (vertex or anchor ids ``a``, ``b``) that are no shortcut pair: two
    anchors of one edge, an anchor and its edge's end vertices (or, with ``neighbours``,
    their neighbours), two anchors of edges with a common end.  ``vert_key``: ``u * m +
    v`` for the two ends of every edge, both ways round, sorted."""
    same = np.zeros(len(a), bool)
    for x, y in ((a, b), (b, a)):
        anchor = on[x, 2] >= 0
        for end in (on[x, 0], on[x, 1]):
            same |= anchor & (end == y)
            if (on[y, 2] >= 0).any():
                same |= anchor & (on[y, 2] >= 0) & ((end == on[y, 0]) | (end == on[y, 1]))
            if neighbours:
                sel = np.flatnonzero(anchor & (on[y, 2] < 0))
                same[sel] |= _in_sorted(end[sel] * m + y[sel], vert_key)
    return same


def _in_sorted(keys: np.ndarray, sorted_keys: np.ndarray) -> np.ndarray:
    """Whether each of ``keys`` is in ``sorted_keys`` (ascending): ``np.isin``, for a
    set sorted once."""
    if sorted_keys.size == 0:
        return np.zeros(keys.shape, bool)
    at = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return sorted_keys[at] == keys


#: Up to this many node pairs within the shortcut radius are listed at once (about 100
#: bytes each on their way through the filters) ...
PAIRS_AT_ONCE = 2_000_000
#: ... more are listed a block of nodes at a time, about this many pairs a block, and
#: only those with a clear line kept: the memory of a dense graph's candidates is then
#: that of its few clear ones (a small ``snap_m`` on a large map lists tens of millions).
PAIRS_PER_BLOCK = 1_000_000


def _straight_candidates(pos, radius_px, n_vertices, usable, on, vert_key, rungs, clear):
    """The straight shortcut candidates: node pairs (``pos`` float64 (M, 2); the first
    ``n_vertices`` vertices, the rest anchors) at most ``radius_px`` apart, both ends
    ``usable`` (bool (M,)), whose straight line is ``clear`` (a function of int64 (P, 2)
    pairs giving bool (P,)).  Returns ``(pairs, rung_pairs)``, int64 (P, 2) and (R, 2),
    ``i < j`` in each row: pairs with a vertex end that are not of one edge
    (:func:`_same_edge`), and pairs of two anchors (none unless ``rungs``); each sorted
    by ``(i, j)``, whether listed at once or in blocks (over :data:`PAIRS_AT_ONCE`
    pairs), and whatever order the k-d tree gives them in."""
    m = len(pos)
    tree = cKDTree(pos)
    n_pairs = (int(tree.count_neighbors(tree, radius_px)) - m) // 2
    if n_pairs > MAX_SHORTCUT_PAIRS:
        raise ValueError(
            f"shortcut_radius_m: {n_pairs:,} pairs of the graph's {m:,} vertices and anchors "
            f"lie within it, expected at most {MAX_SHORTCUT_PAIRS:,} (each takes a line "
            "test); use a smaller shortcut_radius_m, or a larger snap_m or "
            "shortcut_spacing_m (fewer vertices and anchors)"
        )
    if n_pairs <= PAIRS_AT_ONCE:
        blocks = [tree.query_pairs(radius_px, output_type="ndarray").reshape(-1, 2)]
    else:
        blocks = _pair_blocks(tree, pos, radius_px)
    plain, rung = [], []
    for pairs in blocks:
        a, b = pairs[:, 0], pairs[:, 1]
        vertex_end = (a < n_vertices) | (b < n_vertices)
        ok = usable[a] & usable[b]
        keep = ok & (vertex_end | rungs)
        pairs, vertex_end = pairs[keep], vertex_end[keep]
        # no shortcut along one edge or round one vertex (it would cut a bend or a
        # corner into a thin loop around nothing); at least one end a vertex: a shortcut
        # between two anchors splits two edges, and between neighbouring lanes of an open
        # room such rungs would make a mesh; but two anchors whose route is very long get
        # a rung (whose loop is long too, so it may join two anchors of one edge)
        along = np.zeros(len(pairs), bool)
        along[vertex_end] = _same_edge(*pairs[vertex_end].T, on, vert_key, m)
        pairs, vertex_end = pairs[~along], vertex_end[~along]
        # a line not clear now is never clear: those go before the greedy pass
        clear_now = clear(pairs)
        plain.append(pairs[clear_now & vertex_end])
        rung.append(pairs[clear_now & ~vertex_end])
    plain, rung = np.concatenate(plain), np.concatenate(rung)
    # the greedy pass takes candidates of equal length in this order
    plain = plain[np.lexsort((plain[:, 1], plain[:, 0]))]
    rung = rung[np.lexsort((rung[:, 1], rung[:, 0]))]
    return plain.astype(np.int64), rung.astype(np.int64)


def _pair_blocks(tree, pos, radius_px):
    """Node pairs ``(i, j)``, ``i < j``, at most ``radius_px`` apart (``tree`` the
    k-d tree of ``pos``), as int64 (P, 2) arrays of about :data:`PAIRS_PER_BLOCK` rows,
    block by block of consecutive ``i``."""
    counts = tree.query_ball_point(pos, radius_px, return_length=True)
    ends = np.cumsum(counts)
    lo = 0
    while lo < len(pos):
        base = ends[lo - 1] if lo else 0
        hi = max(lo + 1, int(np.searchsorted(ends, base + PAIRS_PER_BLOCK, side="right")))
        near = cKDTree(pos[lo:hi]).sparse_distance_matrix(tree, radius_px, output_type="ndarray")
        i, j = near["i"].astype(np.int64) + lo, near["j"].astype(np.int64)
        del near
        yield np.stack([i, j], axis=1)[j > i]
        lo = hi


#: The most shortcut candidate pairs (node pairs within the shortcut radius) a graph may
#: have: their memory is bounded (:data:`PAIRS_PER_BLOCK`), but each takes a line test,
#: about a minute for this many.
MAX_SHORTCUT_PAIRS = 300_000_000


#: The estimate of the pairs (:func:`estimated_pairs`) counts the nodes of the *open*
#: feasible pixels: those farther than this many coverage reaches from the pixels that
#: are not feasible (the lanes along the walls cover up to 1 + ``LANE_INSET`` reaches).
OPEN_DEPTH = 2.0
#: ... at this share of the density of the open middle of a hall: a graph's own count
#: lies within about a quarter of the full density's in open halls, and above it where
#: the space is cluttered, so the estimate stays under the count.
ESTIMATE_SHARE = 0.75
#: The node density of an open hall is at most this many times that of the coverage
#: mesh's lattice plus anchors along edges of two pixels a reach (:func:`pairs_bound`).
DENSITY_BOUND_FACTOR = 3.0


def open_pixels(feasible: np.ndarray, clearance: np.ndarray, radius: float, reach: float):
    """The open feasible pixels (bool (H, W)): ``feasible`` ones whose clearance
    (float (H, W)) exceeds the robot's ``radius`` by at least :data:`OPEN_DEPTH` coverage
    reaches (``reach``); the three lengths in one unit."""
    return feasible & (clearance >= radius + OPEN_DEPTH * reach)


def pairs_bound(n_open: int, reach_px: float, radius_px: float, anchor_px: float) -> float:
    """An upper bound of :func:`estimated_pairs` for ``n_open`` open pixels, without their
    layout: nodes at :data:`DENSITY_BOUND_FACTOR` times the density of the coverage mesh's
    lattice (sites ``MESH_SPACING`` reaches apart, ``reach_px`` pixels) plus that of
    anchors ``anchor_px`` apart (0: none) along two pixels of edge per reach and pixel,
    each with all open pixels within the shortcut radius (``radius_px``)."""
    density = 2.0 / (math.sqrt(3.0) * (MESH_SPACING * reach_px) ** 2)
    if anchor_px > 0:
        density += 2.0 / (reach_px * anchor_px)
    side = math.sqrt(math.pi) * radius_px + 1.0
    box = side * side  # inf for a radius beyond any map, where ``** 2`` raises OverflowError
    return ESTIMATE_SHARE * 0.5 * (DENSITY_BOUND_FACTOR * density) ** 2 * n_open * min(n_open, box)


def estimated_pairs(open_: np.ndarray, density: float, radius_px: float) -> float:
    """The node pairs within ``radius_px`` (pixels) of a graph whose nodes lie on the open
    pixels ``open_`` (bool (H, W), :func:`open_pixels`) at ``density`` nodes a pixel, times
    :data:`ESTIMATE_SHARE`: half the sum, over the open pixels, of the density squared
    times the open pixels in a square of the area of the radius's disc round each."""
    # a square of 2 max(H, W) - 1 pixels a side holds the whole map round every pixel: a
    # larger one counts no more, and OpenCV's buffers grow with its side (1e7: 2.7 GB)
    side = max(1, round(min(math.sqrt(math.pi) * radius_px, 2 * max(open_.shape) - 1)))
    near = cv2.boxFilter(
        open_.view(np.uint8),
        cv2.CV_32F,
        (side, side),
        normalize=False,
        borderType=cv2.BORDER_CONSTANT,
    )
    total = float(np.sum(near, where=open_, dtype=np.float64))
    return ESTIMATE_SHARE * 0.5 * density**2 * total


def shortcut_nodes(work: WorkGraph, anchor_px: float, end_px: float):
    """``(alive, anchor graph)``: the live vertices with an edge, and
    :func:`_anchor_graph` of them (anchors about ``anchor_px`` apart, 0: none, at least
    ``end_px`` and a pixel from either end of their edge), the nodes of the shortcuts;
    None for the anchor graph of fewer than two vertices."""
    alive = [v for v in range(len(work.pixel)) if v not in work.dead and work.adj[v]]
    if len(alive) < 2:
        return alive, None
    spacing = anchor_px if anchor_px > 0 else math.inf
    return alive, _anchor_graph(work, alive, spacing, max(end_px, 1.0))


def add_shortcuts(
    work: WorkGraph,
    feasible: np.ndarray,
    radius_px: float,
    stretch: float,
    gain_px: float,
    from_dead_ends: bool = True,
    end_px: float = 2.0,
    min_loop_px: float = 0.0,
    anchor_px: float = 0.0,
    corner_tolerance_px: float = 0.0,
    rung_gain_px: float = 0.0,
) -> int:
    """Greedy spanner: for node pairs at most ``radius_px`` apart, shortest first, add a
    straight feasible edge when the graph route between them is longer than ``stretch``
    times the straight line and than the straight line plus ``gain_px``, and the edge
    touches no other edge farther than ``end_px`` from its ends (no crossing) and closes
    no loop shorter than ``min_loop_px`` (graph route plus straight line).  The nodes are
    the vertices (with ``from_dead_ends`` False, only those of two or more edges) and,
    with ``anchor_px`` > 0, points about that far apart along the edges (an edge is split
    where a shortcut starts).  With ``corner_tolerance_px`` > 0, candidates also bend
    once, at a reflex corner of the feasible space's outline simplified to that
    tolerance (:mod:`._corners`): two straight lines through
    the corner joining two nodes that do not see each other, by the same rules except
    that both ends may be anchors, that a vertex may pair with an anchor of an edge next
    to it, and that the two lines may cross other edges (no vertex is made there); neither line may close a loop shorter than ``min_loop_px``
    through a corner already in the graph.  Two anchors pair only with ``rung_gain_px`` >
    0, where the route is longer than ``RUNG_STRETCH`` times the line and than the line
    plus ``rung_gain_px``.  Returns the number of shortcuts added."""
    min_deg = 1 if from_dead_ends else 2
    if radius_px <= 0:
        return 0
    alive, anchored = shortcut_nodes(work, anchor_px, end_px)
    if anchored is None:
        return 0
    pos_i, deg, on, ka, kb, kw = anchored
    pos = pos_i.astype(np.float64)
    m = len(pos)
    index = {v: k for k, v in enumerate(alive)}
    ends = np.array([(index[u], index[v]) for u, v, _ in work.edges.values()], np.int64)
    vert_key = np.sort(np.r_[ends[:, 0] * m + ends[:, 1], ends[:, 1] * m + ends[:, 0]])
    # shortcuts cross no edge: a crossing without a vertex would let a query point snap
    # onto a long edge that leads away from its goal (and doubles the edges in open rooms)
    occupied = grow(graph_raster(work, feasible.shape))
    members = [work.members[v] for v in alive] + [p[None] for p in pos_i[len(alive) :]]
    mem = np.concatenate(members).astype(np.int64)
    mem_start = np.r_[0, np.cumsum([len(x) for x in members])].astype(np.int64)
    del members

    def clear(pairs: np.ndarray) -> np.ndarray:
        return clear_lines(
            *(np.ascontiguousarray(x) for x in pairs.T),
            pos_i, mem, mem_start, feasible, occupied, float(end_px),
        )  # fmt: skip

    pairs, rungs = _straight_candidates(
        pos, radius_px, len(alive), deg >= min_deg, on, vert_key, rung_gain_px > 0, clear
    )
    n_plain = len(pairs)
    pairs = np.concatenate([pairs, rungs])
    corners = (
        reflex_corners(feasible, corner_tolerance_px)
        if corner_tolerance_px > 0
        else np.zeros((0, 2), np.int64)
    )
    bent = bent_candidates(corners, pos_i, deg >= min_deg, feasible, radius_px, end_px)
    # a bent shortcut may join a vertex to an anchor next to it (a room's vertex to the
    # corridor past its door, round the door's frame)
    bent = bent[~_same_edge(bent[:, 0], bent[:, 1], on, vert_key, m, neighbours=False)]
    via = pos[bent[:, 0]] - corners[bent[:, 2]], corners[bent[:, 2]] - pos[bent[:, 1]]
    length = np.r_[
        np.hypot(*(pos[pairs[:, 0]] - pos[pairs[:, 1]]).T),
        np.hypot(*via[0].T) + np.hypot(*via[1].T),
    ]
    cand_a = np.r_[pairs[:, 0], bent[:, 0]].astype(np.int64)
    cand_b = np.r_[pairs[:, 1], bent[:, 1]].astype(np.int64)
    cand_c = np.r_[np.full(len(pairs), -1), m + bent[:, 2]].astype(np.int64)
    if cand_a.size == 0:
        return 0
    need = np.maximum(stretch * length, length + gain_px)
    rung = slice(n_plain, len(pairs))
    need[rung] = np.maximum(RUNG_STRETCH * length[rung], length[rung] + rung_gain_px)
    # every candidate goes to the greedy pass, which draws its lines before it searches
    # the graph for a route: a route search per candidate with a clear line costs less
    # than the routes of all candidates up front
    cand = np.argsort(length, kind="stable")
    nodes = np.concatenate([pos_i, corners]).astype(np.int64)
    corner_mem = nodes[len(pos_i) :]
    mem = np.concatenate([mem, corner_mem])
    mem_start = np.r_[mem_start, mem_start[-1] + 1 + np.arange(len(corner_mem))]
    taken, _ = greedy_shortcuts(
        nodes,
        mem,
        mem_start,
        ka,
        kb,
        kw,
        cand_a[cand],
        cand_b[cand],
        cand_c[cand],
        need[cand],
        min_loop_px - length[cand],
        feasible,
        occupied,
        float(end_px),
        float(min_loop_px),
    )
    chosen = np.stack([cand_a[cand[taken]], cand_b[cand[taken]], cand_c[cand[taken]]], axis=1)
    _add_chosen(work, chosen, nodes, alive, m, feasible.shape)
    return int(chosen.shape[0])


def _add_chosen(work: WorkGraph, chosen, nodes, alive, m, shape) -> None:
    """Add the accepted shortcuts ``chosen`` ((a, b, c) node ids, c -1 or a corner) to
    ``work``: anchors become vertices (their edges split), used corners new vertices."""
    node = np.full(len(nodes), -1, np.int64)
    node[: len(alive)] = alive
    ends = chosen[:, :2].ravel()
    anchors = np.unique(ends[ends >= len(alive)])
    if anchors.size:
        node[anchors] = attach_points(work, [tuple(p) for p in nodes[anchors]], shape)
    for c in np.unique(chosen[chosen[:, 2] >= m, 2]).tolist():
        node[c] = work.add_vertex(nodes[c])
    legs: set[tuple[int, int]] = set()  # shortcuts bent at one corner share their legs
    made = []  # the edges, in order: their lines are drawn all at once
    for a, b, c in chosen.tolist():
        u, v = int(node[a]), int(node[b])
        if u < 0 or v < 0:
            continue
        if c < 0:
            made.append((u, v))
            continue
        w = int(node[c])
        for x, y in ((u, w), (w, v)):
            if (min(x, y), max(x, y)) not in legs:
                legs.add((min(x, y), max(x, y)))
                made.append((x, y))
    if not made:
        return
    ends = np.array([(*work.pixel[x], *work.pixel[y]) for x, y in made], np.int64)
    pixels, starts, lengths = lines_pixels(ends)
    lo, hi = starts[:-1].tolist(), starts[1:].tolist()
    for (x, y), i, j, length in zip(made, lo, hi, lengths.tolist(), strict=True):
        work.add_edge(x, y, pixels[i:j], length)
