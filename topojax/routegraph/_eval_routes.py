"""Routes between sampled feasible points: pair sampling, geodesics, snapping, and
shortest paths along a graph that may start and end part-way along an edge."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from .._cpus import usable_cpus
from .._sight import sees
from ..graph.geodesic import geodesic_from
from ._eval_geometry import GraphGeometry

__all__ = [
    "PairSet",
    "RouteNetwork",
    "entries",
    "geodesic_lengths_px",
    "route_lengths_px",
    "sample_pairs",
    "snap",
]

# Targets drawn per source pixel: one geodesic search serves all of them.
PAIRS_PER_SOURCE = 10
#: Geodesic searches run at once at most (each holds a float64 distance and a uint8 copy
#: of its region's bounding box).
GEODESIC_THREADS = 4
# Candidate snap points checked for a collision-free segment per batch (nearest first).
_SNAP_BATCH = 64
# Dijkstra rows computed per call (bounds the memory of the distance block).
_DIJKSTRA_CELLS = 8_000_000
#: Sources whose pairs are routed at once: the joins of their ends are held together.
SOURCES_AT_ONCE = 100
#: (start join, goal join) combinations of pairs scored at once (about 200 bytes each on
#: their way through): with ``entry="best"`` every pair has one per pair of runs its two
#: ends see, thousands where a dense graph lies within a large ``snap_m``.
COMBOS_AT_ONCE = 250_000


@dataclass(frozen=True, eq=False)
class PairSet:
    """Sampled pairs, grouped by source: ``source[i]`` (row, col) and its targets
    ``target[start[i]:start[i + 1]]``, all in region ``region[i]``."""

    source: np.ndarray
    region: np.ndarray
    start: np.ndarray
    target: np.ndarray

    @property
    def n_pairs(self) -> int:
        return int(self.target.shape[0])

    def pair_source(self) -> np.ndarray:
        """Index of the source of each pair."""
        return np.repeat(np.arange(self.source.shape[0]), np.diff(self.start))


def sample_pairs(fs, regions: np.ndarray, n_pairs: int, seed: int) -> PairSet:
    """``n_pairs`` pairs of distinct feasible pixels in one region each.

    Sources are drawn region by area (among ``regions``, those with at least two pixels),
    then uniformly in it; each source gets up to :data:`PAIRS_PER_SOURCE` targets drawn
    uniformly among the other pixels of its region.
    """
    rng = np.random.default_rng(seed)
    slices = ndimage.find_objects(fs.labels)
    res2 = fs.resolution_m**2
    # two pixels or more: half a pixel of slack, whatever the resolution (down to 1e-6 m
    # per pixel, the finest map)
    regions = np.array([r for r in regions if fs.area_m2[r] >= 1.5 * res2], np.int64)
    empty = np.empty((0, 2), np.int64)
    if regions.size == 0:
        return PairSet(empty, np.empty(0, np.int64), np.zeros(1, np.int64), empty)
    n_src = -(-n_pairs // PAIRS_PER_SOURCE)
    weights = fs.area_m2[regions] / fs.area_m2[regions].sum()
    src_region = np.sort(rng.choice(regions, size=n_src, p=weights))
    counts = np.full(n_src, PAIRS_PER_SOURCE, np.int64)
    counts[-1] = n_pairs - PAIRS_PER_SOURCE * (n_src - 1)
    sources, targets = [], []
    cache: dict[int, np.ndarray] = {}
    for rid, k in zip(src_region.tolist(), counts.tolist(), strict=True):
        sl = slices[rid - 1]
        if rid not in cache:
            cache[rid] = np.cumsum(np.count_nonzero(fs.labels[sl] == rid, axis=1))
        cum = cache[rid]
        n_px = int(cum[-1])
        i = int(rng.integers(n_px))
        j = rng.integers(n_px - 1, size=k)
        j = j + (j >= i)
        px = _nth_pixels(fs.labels, sl, rid, cum, np.r_[i, j])
        sources.append(px[0])
        targets.append(px[1:])
    return PairSet(
        source=np.array(sources, np.int64).reshape(-1, 2),
        region=src_region,
        start=np.r_[0, np.cumsum(counts)].astype(np.int64),
        target=np.concatenate(targets).astype(np.int64),
    )


def _nth_pixels(labels, sl, rid: int, cum: np.ndarray, nth: np.ndarray) -> np.ndarray:
    """Pixels (row, col) int64 (K, 2) numbered ``nth`` (int64 (K,)) among those of region
    ``rid`` in raster order, given its bounding box ``sl`` and the running count ``cum``
    of its pixels by row of the box: one row of the box read per pixel, no list of the
    region's pixels (16 bytes each) held."""
    rows = np.searchsorted(cum, nth, side="right")
    before = np.where(rows > 0, cum[rows - 1], 0)
    out = np.empty((nth.size, 2), np.int64)
    for m, (r, k) in enumerate(zip(rows.tolist(), (nth - before).tolist(), strict=True)):
        row = sl[0].start + r
        out[m] = row, sl[1].start + np.flatnonzero(labels[row, sl[1]] == rid)[k]
    return out


def geodesic_lengths_px(fs, pairs: PairSet) -> np.ndarray:
    """Length (pixels) of the shortest 8-connected path inside the feasible region from
    each pair's source to its target (moves of 1 and sqrt 2): one search per source on the
    bounding box of its region, stopped when all its targets are reached; the searches
    run in up to :data:`GEODESIC_THREADS` threads (they release the GIL)."""
    out = np.full(pairs.n_pairs, np.inf)
    slices = ndimage.find_objects(fs.labels)
    masks = {rid: fs.labels[slices[rid - 1]] == rid for rid in set(pairs.region.tolist())}

    def search(i: int) -> None:
        rid = int(pairs.region[i])
        sl = slices[rid - 1]
        off = np.array([sl[0].start, sl[1].start])
        a, b = pairs.start[i], pairs.start[i + 1]
        out[a:b] = geodesic_from(masks[rid], pairs.source[i] - off, pairs.target[a:b] - off)

    n = pairs.source.shape[0]
    threads = min(GEODESIC_THREADS, usable_cpus(), n)
    if threads > 1:
        with ThreadPoolExecutor(threads, thread_name_prefix="geodesic") as pool:
            list(pool.map(search, range(n)))
    else:
        for i in range(n):
            search(i)
    return out


@dataclass(frozen=True, eq=False)
class RouteNetwork:
    """A graph cut into *runs* (stretches of one edge between two network nodes) with the
    snap points that lie on them.

    Attributes
    ----------
    n_nodes : int
    run_a, run_b : int64 (R,)
        Network nodes at the two ends of each run.
    run_len : float64 (R,)
        Length of each run (pixels).
    pt_rc : float64 (P, 2)
        Points a pair may snap to.
    pt_run : int64 (P,)
        Run of each point.
    pt_t : float64 (P,)
        Arc length of each point from its run's ``run_a`` end.
    tree : cKDTree
        On ``pt_rc``.
    matrix : scipy.sparse.csr_matrix
        Network node adjacency, the shortest run between two nodes as the weight.
    """

    n_nodes: int
    run_a: np.ndarray
    run_b: np.ndarray
    run_len: np.ndarray
    pt_rc: np.ndarray
    pt_run: np.ndarray
    pt_t: np.ndarray
    tree: cKDTree
    matrix: object


def route_network(geo: GraphGeometry, piece_ok: np.ndarray, point_ok: np.ndarray) -> RouteNetwork:
    """The network of the pieces ``piece_ok`` (between densified points ``g`` and ``g + 1``
    of one edge; length N - 1) and the points ``point_ok`` (length N) of ``geo``.

    Each maximal run of usable pieces along an edge becomes one run between network nodes
    (the graph's vertices, and the densified points where a run starts or stops inside an
    edge); a usable point on no usable piece becomes a run of length 0.
    """
    n = geo.pt_edge.size
    same = geo.pt_edge[1:] == geo.pt_edge[:-1]
    pok = same & piece_ok
    prev = np.r_[False, pok[:-1]]
    nxt = np.r_[pok[1:], False]
    run_first = np.flatnonzero(pok & ~prev)
    run_last = np.flatnonzero(pok & ~nxt) + 1
    run_of_piece = np.cumsum(pok & ~prev) - 1
    pt_run = np.full(n, -1, np.int64)
    pieces = np.flatnonzero(pok)
    pt_run[pieces + 1] = run_of_piece[pieces]
    pt_run[pieces] = run_of_piece[pieces]
    lone = np.flatnonzero(point_ok & (pt_run < 0))
    pt_run[lone] = run_first.size + np.arange(lone.size)
    run_first = np.r_[run_first, lone].astype(np.int64)
    run_last = np.r_[run_last, lone].astype(np.int64)
    key = np.where(geo.pt_vertex >= 0, geo.pt_vertex, geo.n_vertices + np.arange(n))
    used, inverse = np.unique(np.r_[key[run_first], key[run_last]], return_inverse=True)
    run_a, run_b = inverse[: run_first.size], inverse[run_first.size :]
    run_len = geo.pt_s[run_last] - geo.pt_s[run_first]
    keep = np.flatnonzero(pt_run >= 0)
    matrix = _adjacency(used.size, run_a, run_b, run_len)
    pt_rc = geo.pt_rc[keep]
    return RouteNetwork(
        n_nodes=int(used.size),
        run_a=run_a.astype(np.int64),
        run_b=run_b.astype(np.int64),
        run_len=run_len,
        pt_rc=pt_rc,
        pt_run=pt_run[keep],
        pt_t=geo.pt_s[keep] - geo.pt_s[run_first[pt_run[keep]]],
        tree=cKDTree(pt_rc) if pt_rc.size else None,
        matrix=matrix,
    )


def _adjacency(n_nodes: int, a: np.ndarray, b: np.ndarray, w: np.ndarray):
    """Symmetric CSR adjacency keeping the shortest of parallel runs (zero lengths as a
    tiny positive weight, since a sparse matrix cannot hold an explicit zero edge)."""
    ok = a != b
    lo, hi, w = np.minimum(a, b)[ok], np.maximum(a, b)[ok], np.maximum(w[ok], 1e-9)
    order = np.lexsort((w, hi, lo))
    lo, hi, w = lo[order], hi[order], w[order]
    first = np.ones(lo.size, bool)
    first[1:] = (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])
    lo, hi, w = lo[first], hi[first], w[first]
    m = coo_matrix((np.r_[w, w], (np.r_[lo, hi], np.r_[hi, lo])), shape=(n_nodes, n_nodes))
    return m.tocsr()


def _in_reach(net: RouteNetwork, q_all: np.ndarray, snap_px: float):
    """Per query (float64 (Q, 2)) with network points within ``snap_px``: ``(query index,
    point indices int64, their distances px)``."""
    for i, cands in enumerate(net.tree.query_ball_point(q_all, snap_px * (1 + 1e-12))):
        if cands:
            cands = np.asarray(cands, np.int64)
            yield i, cands, np.hypot(*(net.pt_rc[cands] - q_all[i]).T)


def snap(net: RouteNetwork, queries: np.ndarray, snap_px: float, feasible: np.ndarray):
    """Nearest network point within ``snap_px`` of each query pixel whose segment to it is
    collision-free.  Returns ``(point index or -1 (Q,), distance px (Q,))``."""
    idx = np.full(queries.shape[0], -1, np.int64)
    dist = np.full(queries.shape[0], np.inf)
    if net.tree is None or queries.shape[0] == 0:
        return idx, dist
    q_all = queries.astype(np.float64)
    for i, cands, d in _in_reach(net, q_all, snap_px):
        order = np.lexsort((cands, d))
        for b in range(0, order.size, _SNAP_BATCH):
            sel = order[b : b + _SNAP_BATCH]
            ok = sees(feasible, q_all[i], net.pt_rc[cands[sel]])
            if ok.any():
                j = sel[int(np.argmax(ok))]
                idx[i], dist[i] = cands[j], d[j]
                break
    return idx, dist


def entries(net: RouteNetwork, queries: np.ndarray, snap_px: float, feasible: np.ndarray):
    """Every run's nearest network point within ``snap_px`` of each query pixel whose
    segment to it is collision-free: the points a route may join the network at when it
    takes the best entry.  Returns ``(query (K,), point (K,), distance px (K,))``, by
    query."""
    q_of, pts, dists = [], [], []
    if net.tree is None or queries.shape[0] == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    q_all = queries.astype(np.float64)
    for i, cands, d in _in_reach(net, q_all, snap_px):
        ok = sees(feasible, q_all[i], net.pt_rc[cands])
        cands, d = cands[ok], d[ok]
        run = net.pt_run[cands]
        order = np.lexsort((cands, d, run))
        first = np.r_[True, run[order][1:] != run[order][:-1]] if order.size else order
        keep = order[first.astype(bool)]
        q_of.append(np.full(keep.size, i, np.int64))
        pts.append(cands[keep])
        dists.append(d[keep])
    if not q_of:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(q_of), np.concatenate(pts), np.concatenate(dists)


def _joins(net, queries, snap_px, feasible, best_entry: bool):
    """``(query, point, distance)`` arrays of the points each query may join at (one per
    query with a snap, or one per run with ``best_entry``), by query."""
    if best_entry:
        return entries(net, queries, snap_px, feasible)
    idx, dist = snap(net, queries, snap_px, feasible)
    have = np.flatnonzero(idx >= 0)
    return have, idx[have], dist[have]


@dataclass(frozen=True, eq=False)
class _JoinTable:
    """Where each source's and each pair's joins lie among those :func:`_joins` gives
    (``s_start`` (S + 1,), ``t_start`` (P + 1,)), each pair's source (``pair_src``
    (P,)), and where its (start join, goal join) combinations start among all of them,
    taken pair after pair (``first`` (P,), ``count`` (P,))."""

    s_start: np.ndarray
    t_start: np.ndarray
    pair_src: np.ndarray
    first: np.ndarray
    count: np.ndarray

    @classmethod
    def of(cls, pairs: PairSet, s_q: np.ndarray, t_q: np.ndarray) -> _JoinTable:
        """The table of ``pairs`` whose sources join at queries ``s_q`` and targets at
        ``t_q`` (ascending, as :func:`_joins` gives them)."""
        pair_src = pairs.pair_source()
        s_start = np.searchsorted(s_q, np.arange(pairs.source.shape[0] + 1))
        t_start = np.searchsorted(t_q, np.arange(pairs.n_pairs + 1))
        count = np.diff(s_start)[pair_src] * np.diff(t_start)
        return cls(s_start, t_start, pair_src, np.cumsum(count) - count, count)

    @property
    def total(self) -> int:
        """Number of all combinations."""
        return int(self.count.sum())

    def combos(self, lo: int, hi: int):
        """Combinations ``lo`` to ``hi``: ``(pair, start join, goal join)``, int64 each."""
        combo = np.arange(lo, hi, dtype=np.int64)
        pair = np.searchsorted(self.first + self.count, combo, side="right")
        k = combo - self.first[pair]
        ct = np.maximum(np.diff(self.t_start)[pair], 1)
        return pair, self.s_start[self.pair_src[pair]] + k // ct, self.t_start[pair] + k % ct


def route_lengths_px(
    net: RouteNetwork,
    pairs: PairSet,
    snap_px: float,
    feasible: np.ndarray,
    best_entry: bool = False,
) -> np.ndarray:
    """Route length (pixels) of each pair: snap segment + shortest path along the network
    + snap segment; ``inf`` where a snap is missing or the snap points are not connected.
    Each end snaps to its nearest collision-free network point, or with ``best_entry``
    to whichever point of :func:`entries` gives the shortest route.  The pairs of
    :data:`SOURCES_AT_ONCE` sources are joined at a time, and their combinations of joins
    scored :data:`COMBOS_AT_ONCE` at a time: the memory is bounded whatever the number of
    pairs and joins."""
    out = np.full(pairs.n_pairs, np.inf)
    n_src = pairs.source.shape[0]
    for s0 in range(0, n_src, SOURCES_AT_ONCE):
        s1 = min(s0 + SOURCES_AT_ONCE, n_src)
        a, b = int(pairs.start[s0]), int(pairs.start[s1])
        part = PairSet(
            source=pairs.source[s0:s1],
            region=pairs.region[s0:s1],
            start=pairs.start[s0 : s1 + 1] - a,
            target=pairs.target[a:b],
        )
        out[a:b] = _part_lengths_px(net, part, snap_px, feasible, best_entry)
    return out


def _part_lengths_px(net, pairs: PairSet, snap_px, feasible, best_entry) -> np.ndarray:
    """:func:`route_lengths_px` of a few sources' pairs."""
    out = np.full(pairs.n_pairs, np.inf)
    if pairs.n_pairs == 0:
        return out
    s_q, s_pt, s_d = _joins(net, pairs.source, snap_px, feasible, best_entry)
    t_q, t_pt, t_d = _joins(net, pairs.target, snap_px, feasible, best_entry)
    table = _JoinTable.of(pairs, s_q, t_q)
    for lo in range(0, table.total, COMBOS_AT_ONCE):
        pair, ja, jb = table.combos(lo, min(lo + COMBOS_AT_ONCE, table.total))
        best = _along_network_px(net, s_pt[ja], t_pt[jb])
        np.minimum.at(out, pair, s_d[ja] + best + t_d[jb])
    return out


def _along_network_px(net: RouteNetwork, ga: np.ndarray, gb: np.ndarray) -> np.ndarray:
    """Shortest length (pixels, float64 (C,)) along the network from each network point
    ``ga`` (int64 (C,)) to the point ``gb`` of the same row: along their run where they
    share one, else out through an end of one run and in through an end of the other."""
    ra, rb = net.pt_run[ga], net.pt_run[gb]
    ends_a = np.stack([net.run_a[ra], net.run_b[ra]], axis=1)
    off_a = np.stack([net.pt_t[ga], net.run_len[ra] - net.pt_t[ga]], axis=1)
    ends_b = np.stack([net.run_a[rb], net.run_b[rb]], axis=1)
    off_b = np.stack([net.pt_t[gb], net.run_len[rb] - net.pt_t[gb]], axis=1)
    sources, inv = np.unique(ends_a, return_inverse=True)
    inv = inv.reshape(ends_a.shape)
    best = np.where(ra == rb, np.abs(net.pt_t[ga] - net.pt_t[gb]), np.inf)
    rows = max(1, _DIJKSTRA_CELLS // max(1, net.n_nodes))
    for c0 in range(0, sources.size, rows):
        block = dijkstra(net.matrix, directed=False, indices=sources[c0 : c0 + rows])
        for i in range(2):
            r = inv[:, i] - c0
            here = (r >= 0) & (r < block.shape[0])
            for j in range(2):
                d = np.full(ga.size, np.inf)
                d[here] = block[r[here], ends_b[here, j]]
                best = np.minimum(best, off_a[:, i] + d + off_b[:, j])
    return best
