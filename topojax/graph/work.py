"""An editable graph for the graph-shaping stages (route graphs, rooms): vertices with pixel positions, edges with
8-connected pixel paths, and the edits the builder makes (remove, split, add a straight
edge, contract degree-2 vertices), plus the two sparsifying passes: collapsing loops
around small obstacles and dropping medial-axis spurs."""

from __future__ import annotations

import heapq
import math

import cv2
import numpy as np

from .._jit import cached_njit
from .geodesic import nearest_path

__all__ = [
    "SQRT2",
    "WorkGraph",
    "collapse_loops",
    "drop_spurs",
    "face_labels",
    "line_in_mask",
    "line_step",
    "line_into",
    "line_pixels",
    "lines_pixels",
    "merge_close_vertices",
]

SQRT2 = math.sqrt(2.0)


@cached_njit(nogil=True, inline="always")
def line_step(r0, c0, dr, dc, n, i):
    """Pixel ``i`` (0..``n``) of the digital line from ``(r0, c0)`` by ``(dr, dc)``,
    ``n = max(|dr|, |dc|) > 0``: the major axis steps by one pixel, the minor coordinate
    is the exact line's, rounded (halves away from the start)."""
    major_r = abs(dr) >= abs(dc)
    num = (dc if major_r else dr) * i
    q = (2 * abs(num) + n) // (2 * n)
    off = q if num >= 0 else -q
    along = i if (dr if major_r else dc) > 0 else -i
    if major_r:
        return r0 + along, c0 + off
    return r0 + off, c0 + along


@cached_njit(nogil=True)
def line_into(r0, c0, r1, c1, out):
    """Write the 8-connected digital line from ``(r0, c0)`` to ``(r1, c1)`` (both
    included) into ``out`` (at least ``max(|dr|, |dc|) + 1`` rows); returns its length.

    The major axis steps by one pixel; the minor coordinate is the exact line's, rounded
    (halves away from the start)."""
    dr, dc = r1 - r0, c1 - c0
    n = max(abs(dr), abs(dc))
    out[0, 0], out[0, 1] = r0, c0
    for i in range(1, n + 1):
        out[i, 0], out[i, 1] = line_step(r0, c0, dr, dc, n, i)
    return n + 1


@cached_njit(nogil=True)
def line_in_mask(r0, c0, r1, c1, mask, out):
    """:func:`line_into`, returning 0 instead of the length when a pixel of the line is
    not set in ``mask`` (bool (H, W)); then ``out`` holds the line up to that pixel."""
    dr, dc = r1 - r0, c1 - c0
    n = max(abs(dr), abs(dc))
    out[0, 0], out[0, 1] = r0, c0
    if not mask[r0, c0]:
        return 0
    for i in range(1, n + 1):
        r, c = line_step(r0, c0, dr, dc, n, i)
        if not mask[r, c]:
            return 0
        out[i, 0], out[i, 1] = r, c
    return n + 1


def line_pixels(a, b) -> np.ndarray:
    """8-connected pixels (K, 2) int32 of the digital straight line from ``a`` to ``b``
    (``(row, col)``, both included)."""
    r0, c0, r1, c1 = int(a[0]), int(a[1]), int(b[0]), int(b[1])
    out = np.empty((max(abs(r1 - r0), abs(c1 - c0)) + 1, 2), np.int32)
    line_into(r0, c0, r1, c1, out)
    return out


@cached_njit(nogil=True)
def lines_pixels(ends):
    """The digital lines of :func:`line_pixels` between the pixels ``ends[k, 0:2]`` and
    ``ends[k, 2:4]`` (int64 (K, 4)), all at once: ``(pixels int32 (N, 2), starts int64
    (K + 1,), lengths float64 (K,))``, line ``k`` being ``pixels[starts[k]:starts[k +
    1]]`` and ``lengths[k]`` its :func:`path_length_px`."""
    k_lines = ends.shape[0]
    starts = np.zeros(k_lines + 1, np.int64)
    for k in range(k_lines):
        n = max(abs(ends[k, 2] - ends[k, 0]), abs(ends[k, 3] - ends[k, 1]))
        starts[k + 1] = starts[k] + n + 1
    pixels = np.empty((starts[k_lines], 2), np.int32)
    lengths = np.empty(k_lines, np.float64)
    for k in range(k_lines):
        out = pixels[starts[k] : starts[k + 1]]
        line_into(ends[k, 0], ends[k, 1], ends[k, 2], ends[k, 3], out)
        lengths[k] = _path_length(out) if out.shape[0] >= 2 else 0.0
    return pixels, starts, lengths


@cached_njit(nogil=True)
def _path_length(path):
    diagonal = 0
    for i in range(path.shape[0] - 1):
        if path[i + 1, 0] != path[i, 0] and path[i + 1, 1] != path[i, 1]:
            diagonal += 1
    return (path.shape[0] - 1 - diagonal) + diagonal * SQRT2


def path_length_px(path: np.ndarray) -> float:
    """Length of an 8-connected pixel path in pixels (straight 1, diagonal sqrt 2)."""
    if len(path) < 2:
        return 0.0
    return float(_path_length(np.asarray(path)))


def member_bridge(start, end, members: np.ndarray) -> np.ndarray | None:
    """The shortest 8-connected path (K, 2) int32 from pixel ``start`` to pixel ``end``
    through the pixels of ``members`` (both ends included; :func:`nearest_path`), or None
    where there is none.  A merged junction cluster's members may ring a pixel that is not
    free: a straight line between two of them could cross it, a path through them cannot."""
    rc = np.asarray(members, np.int64).reshape(-1, 2)
    lo = rc.min(axis=0)
    mask = np.zeros(tuple(rc.max(axis=0) - lo + 1), bool)
    mask[rc[:, 0] - lo[0], rc[:, 1] - lo[1]] = True
    a, b = np.asarray(start, np.int64) - lo, np.asarray(end, np.int64) - lo
    if not all(0 <= x[k] < mask.shape[k] for x in (a, b) for k in (0, 1)) or not mask[b[0], b[1]]:
        return None
    target = np.zeros_like(mask)
    target[b[0], b[1]] = True
    path = nearest_path(mask, a, target)
    return None if path is None else (path + lo).astype(np.int32)


def join_paths(a: np.ndarray, b: np.ndarray, members: np.ndarray | None = None) -> np.ndarray:
    """``a`` followed by ``b``, bridging a gap between ``a``'s last and ``b``'s first pixel
    (two pixels of one vertex) through the vertex's ``members`` where they join them,
    else with a straight line."""
    if a[-1, 0] == b[0, 0] and a[-1, 1] == b[0, 1]:
        return np.concatenate([a, b[1:]])
    bridge = None if members is None else member_bridge(a[-1], b[0], members)
    if bridge is None:
        bridge = line_pixels(a[-1], b[0])
    return np.concatenate([a, bridge[1:-1], b])


class WorkGraph:
    """Vertices ``0..`` (``pixel`` (row, col), ``members`` (M, 2) int32) and edges (ids in
    ``edges``: ``[u, v, path]`` with ``path`` (K, 2) int32 from a pixel of ``u`` to a pixel
    of ``v``) with incidence sets ``adj``."""

    def __init__(self) -> None:
        self.pixel: list[tuple[int, int]] = []
        self.members: list[np.ndarray] = []
        self.edges: dict[int, list] = {}
        self.length: dict[int, float] = {}
        self.adj: list[set] = []
        self.dead: set[int] = set()
        self._next_edge = 0

    @classmethod
    def from_networkx(cls, graph) -> WorkGraph:
        """The vertices and edges of a :func:`topojax.skeleton_to_graph` graph (nodes
        ``0..N-1``)."""
        work = cls()
        for n in range(graph.number_of_nodes()):
            data = graph.nodes[n]
            work.add_vertex(data["pixel"], data["pixels"])
        for u, v, data in graph.edges(data=True):
            work.add_edge(u, v, np.asarray(data["path"], np.int32))
        return work

    @classmethod
    def from_store(cls, store) -> WorkGraph:
        """:meth:`from_networkx` of ``store.to_networkx()`` (a
        :func:`topojax.graph.skeleton_graph_store` store), without the networkx graph:
        the same vertices and edges, with the same ids."""
        n = store.n_nodes
        if not np.array_equal(store.node_ids, np.arange(n)) or not store.has_metrics:
            return cls.from_networkx(store.to_networkx())
        work = cls()
        if store.member_pixels is None:
            members, bounds = store.node_pixel.astype(np.int32), list(range(n + 1))
        else:
            members = store.member_pixels.astype(np.int32)
            bounds = store.member_offsets.tolist()
        for p, i, j in zip(store.node_pixel.tolist(), bounds[:-1], bounds[1:], strict=True):
            work.add_vertex(p, members[i:j])
        # networkx lists a multigraph's edges under their smaller node, by the order that
        # node met each neighbour (the first edge of the pair), then in the order added
        a, b = store.edge_u.astype(np.int64), store.edge_v.astype(np.int64)
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        _, first, pair = np.unique(lo * max(n, 1) + hi, return_index=True, return_inverse=True)
        order = np.lexsort((np.arange(a.size), first[pair.reshape(-1)], lo))
        paths = store.path_pixels.astype(np.int32)
        offsets = store.path_offsets.tolist()
        for k, u, v in zip(order.tolist(), lo[order].tolist(), hi[order].tolist(), strict=True):
            work.add_edge(u, v, paths[offsets[k] : offsets[k + 1]])
        return work

    def add_vertex(self, pixel, members=None) -> int:
        """A new vertex at ``pixel``; returns its id."""
        self.pixel.append((int(pixel[0]), int(pixel[1])))
        if members is None:
            members = np.array([self.pixel[-1]], np.int32)
        self.members.append(np.asarray(members, np.int32).reshape(-1, 2))
        self.adj.append(set())
        return len(self.pixel) - 1

    def add_edge(self, u: int, v: int, path: np.ndarray, length: float | None = None) -> int:
        """A new edge ``u``-``v`` along ``path`` (of :func:`path_length_px` ``length``,
        found when not given); returns its id."""
        e = self._next_edge
        self._next_edge += 1
        self.edges[e] = [u, v, path]
        self.length[e] = path_length_px(path) if length is None else length
        self.adj[u].add(e)
        self.adj[v].add(e)
        return e

    @property
    def next_edge_id(self) -> int:
        """The id the next edge will get: edges made earlier have smaller ones, and
        :attr:`edges` holds them in the order they were made."""
        return self._next_edge

    def remove_edge(self, e: int) -> None:
        u, v, _ = self.edges.pop(e)
        del self.length[e]
        self.adj[u].discard(e)
        self.adj[v].discard(e)

    def degree(self, v: int) -> int:
        """Edge ends at ``v`` (a self-loop counts twice)."""
        return sum(2 if self.edges[e][0] == self.edges[e][1] else 1 for e in self.adj[v])

    def degrees(self) -> list[int]:
        """:meth:`degree` of every vertex, by id."""
        ends = [x for u, v, _ in self.edges.values() for x in (u, v)]
        return np.bincount(np.array(ends, np.int64), minlength=len(self.pixel)).tolist()

    def other(self, e: int, v: int) -> int:
        u, w, _ = self.edges[e]
        return w if u == v else u

    def oriented_path(self, e: int, start: int) -> np.ndarray:
        """Edge ``e``'s path starting at vertex ``start``."""
        u, _, path = self.edges[e]
        return path if u == start else path[::-1]

    def contract(self, v: int) -> bool:
        """Replace the two edges of a degree-2 vertex ``v`` (not a self-loop) by one."""
        if len(self.adj[v]) != 2:
            return False
        e1, e2 = self.adj[v]
        a, b = self.other(e1, v), self.other(e2, v)
        if a == v or b == v:
            return False
        path = join_paths(self.oriented_path(e1, a), self.oriented_path(e2, v), self.members[v])
        self.remove_edge(e1)
        self.remove_edge(e2)
        self.add_edge(a, b, path)
        self.dead.add(v)
        return True

    def contract_all(self, vertices=None) -> None:
        """Contract every degree-2 vertex (of ``vertices``, default all)."""
        todo = range(len(self.pixel)) if vertices is None else list(vertices)
        for v in todo:
            if len(self.adj[v]) == 2:
                self.contract(v)


# ---------------------------------------------------------------------------------------
# loops around small obstacles
# ---------------------------------------------------------------------------------------


def face_labels(skeleton: np.ndarray) -> np.ndarray:
    """Faces of the skeleton's plane graph: 4-connected components of the pixels off the
    skeleton (int32 (H, W), 0 on the skeleton).  The map's outside is face 1."""
    h, w = skeleton.shape
    off = np.ones((h + 2, w + 2), np.uint8)
    off[1:-1, 1:-1] = ~skeleton
    _, labels = cv2.connectedComponents(off, connectivity=4, ltype=cv2.CV_32S)
    return labels[1:-1, 1:-1]


def edge_sides(work: WorkGraph, faces: np.ndarray) -> dict[int, tuple[int, int]]:
    """The faces on the two sides of each edge (``(a, b)``, ``a == b`` for an edge with one
    face on both sides, i.e. a bridge); edges without interior pixels are left out."""
    h, w = faces.shape
    ids = list(work.edges)
    inner = [work.edges[e][2][1:-1] for e in ids]
    sizes = np.array([len(p) for p in inner], np.int64)
    if sizes.sum() == 0:
        return {}
    every = np.concatenate(inner).astype(np.int64)
    owner = np.repeat(np.arange(len(ids)), sizes)
    # the 4-neighbours of every interior pixel, with the edge they belong to
    rr = np.concatenate([every[:, 0] - 1, every[:, 0] + 1, every[:, 0], every[:, 0]])
    cc = np.concatenate([every[:, 1], every[:, 1], every[:, 1] - 1, every[:, 1] + 1])
    owner = np.tile(owner, 4)
    ok = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
    lab = faces[rr[ok], cc[ok]].astype(np.int64)
    owner = owner[ok]
    pos = lab > 0
    n_faces = int(faces.max()) + 1
    key = np.unique(owner[pos] * n_faces + lab[pos])
    edge, face = np.divmod(key, n_faces)
    count = np.bincount(edge, minlength=len(ids))
    first = np.searchsorted(edge, np.arange(len(ids)))
    sides = {}
    for k in np.flatnonzero((count == 1) | (count == 2)).tolist():
        a = int(face[first[k]])
        sides[ids[k]] = (a, a) if count[k] == 1 else (a, int(face[first[k] + 1]))
    return sides


@cached_njit(nogil=True)
def _obstacle_boxes(faces, free, n_faces):
    box = np.empty((n_faces, 4), np.int64)  # row min, col min, row max, col max
    box[:, :2] = np.iinfo(np.int64).max
    box[:, 2:] = -1
    for r in range(free.shape[0]):
        for c in range(free.shape[1]):
            if not free[r, c]:
                f = faces[r, c]
                box[f, 0] = min(box[f, 0], r)
                box[f, 1] = min(box[f, 1], c)
                box[f, 2] = max(box[f, 2], r)
                box[f, 3] = max(box[f, 3], c)
    return box


def obstacle_extent_px(faces: np.ndarray, free: np.ndarray, n_faces: int) -> np.ndarray:
    """Diagonal (pixels) of the bounding box of the pixels that are not free in each face
    (0 for a face holding none): the size of the obstacle a face's loop goes around."""
    box = _obstacle_boxes(faces, free, n_faces)
    has = box[:, 2] >= 0
    out = np.zeros(n_faces)
    out[has] = np.hypot(box[has, 2] - box[has, 0] + 1, box[has, 3] - box[has, 1] + 1)
    return out


class _FaceEdges:
    """The edges between each face (a root of merged faces) and the others, as a heap per
    face of ``(narrowness, -length, rank, edge)``: ``rank`` orders a face's edges as a list
    would (each face's edges by id, a merged face's list the absorbing face's followed by
    the absorbed one's), so the heap's top is the first of the narrowest, longest edges of
    that list.  A merge pushes the smaller heap into the larger one, ranked before or after
    it: each edge moves O(log E) times, also on chains of faces that absorb each other (a
    row of pillars)."""

    def __init__(self, work: WorkGraph, lists: dict[int, list], narrow: dict) -> None:
        self.heaps: dict[int, list] = {}
        self.span: dict[int, tuple[int, int]] = {}
        for f, edges in lists.items():
            heap = [(narrow[e], -work.length[e], i, e) for i, e in enumerate(edges)]
            heapq.heapify(heap)
            self.heaps[f] = heap
            self.span[f] = (0, len(edges) - 1)

    def best(self, f: int, alive) -> int | None:
        """The top edge of face ``f`` for which ``alive(edge)`` holds; the others above it
        are dropped (a removed edge, or one inside a face, stays so)."""
        heap = self.heaps.get(f)
        while heap:
            if alive(heap[0][3]):
                return heap[0][3]
            heapq.heappop(heap)
        return None

    def absorb(self, other: int, f: int) -> None:
        """Face ``f``'s edges after ``other``'s, as ``other``'s."""
        hf = self.heaps.pop(f, None)
        if hf is None:
            return
        lo_f, hi_f = self.span.pop(f)
        ho = self.heaps.get(other)
        if ho is None:
            self.heaps[other], self.span[other] = hf, (lo_f, hi_f)
            return
        lo_o, hi_o = self.span[other]
        if len(hf) <= len(ho):  # rank f's after other's
            shift = hi_o + 1 - lo_f
            for a, b, rank, e in hf:
                heapq.heappush(ho, (a, b, rank + shift, e))
            self.span[other] = (lo_o, hi_f + shift)
        else:  # rank other's before f's
            shift = lo_f - 1 - hi_o
            for a, b, rank, e in ho:
                heapq.heappush(hf, (a, b, rank + shift, e))
            self.heaps[other], self.span[other] = hf, (lo_o + shift, hi_f)


def collapse_loops(
    work: WorkGraph,
    faces: np.ndarray,
    free: np.ndarray,
    clearance_px: np.ndarray,
    loop_px: float,
    loop_factor: float,
    obstacle_px: float,
) -> int:
    """Open the loops around small obstacles: for each face whose obstacle is at most
    ``obstacle_px`` across or whose boundary is shorter than
    ``max(loop_px, loop_factor * clearance)``, remove the narrowest edge between it and
    another face and merge the two faces.  An edge between two distinct faces lies on a
    cycle, so no removal disconnects the graph.  Returns the number of edges removed."""
    n_faces = int(faces.max()) + 1
    sides = edge_sides(work, faces)
    extent = obstacle_extent_px(faces, free, n_faces)
    loop_len = np.zeros(n_faces)
    clear_sum = np.zeros(n_faces)
    edges_of: dict[int, list] = {}
    narrow = {}
    for e, (a, b) in sides.items():
        if a == b:
            continue
        path = work.edges[e][2]
        c = clearance_px[path[:, 0], path[:, 1]]
        narrow[e] = float(c.min())
        length = work.length[e]
        weighted = length * float(c.mean())
        for f in (a, b):
            loop_len[f] += length
            clear_sum[f] += weighted
            edges_of.setdefault(f, []).append(e)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_clear = np.where(loop_len > 0, clear_sum / loop_len, 0.0)
    small = (extent <= obstacle_px) | (loop_len < np.maximum(loop_px, loop_factor * mean_clear))
    small[1] = False  # the map's outside
    parent = list(range(n_faces))

    def find(f: int) -> int:
        while parent[f] != f:
            parent[f] = parent[parent[f]]
            f = parent[f]
        return f

    def between_faces(e: int) -> bool:
        if e not in work.edges:
            return False
        a, b = sides[e]
        return find(a) != find(b)

    heaps = _FaceEdges(work, edges_of, narrow)
    del edges_of
    removed = 0
    todo = np.flatnonzero(small & (loop_len > 0))
    # equal lengths in face order: the default sort's order of ties varies between CPUs
    for f in todo[np.argsort(loop_len[todo], kind="stable")]:
        f = int(f)
        if find(f) != f:
            continue
        best = heaps.best(f, between_faces)
        if best is None:
            continue
        a, b = sides[best]
        other = find(b) if find(a) == f else find(a)
        work.remove_edge(best)
        removed += 1
        parent[f] = other
        heaps.absorb(other, f)
    return removed


def drop_spurs(
    work: WorkGraph, feasible_clearance_px: np.ndarray, spur_px: float, spur_factor: float
) -> int:
    """Remove, round after round, every dead-end edge hanging off a junction (degree >= 3)
    that is shorter than ``max(spur_px, spur_factor * c)``, ``c`` the feasible clearance at
    the junction (medial-axis branches into corners).  Returns the number removed."""
    removed = 0
    changed = True
    while changed:
        changed = False
        drop = []
        for v in range(len(work.pixel)):
            if len(work.adj[v]) != 1:
                continue
            (e,) = work.adj[v]
            j = work.other(e, v)
            if j == v or work.degree(j) < 3:
                continue
            r, c = work.pixel[j]
            limit = max(spur_px, spur_factor * float(feasible_clearance_px[r, c]))
            if work.length[e] < limit:
                drop.append((e, j))
        touched = set()
        for e, j in drop:
            if e in work.edges and work.degree(j) >= 3:
                work.dead.add(work.other(e, j))
                work.remove_edge(e)
                touched.add(j)
                removed += 1
                changed = True
        work.contract_all(touched)
    return removed


# ---------------------------------------------------------------------------------------
# close vertices
# ---------------------------------------------------------------------------------------


def _rerouted(work: WorkGraph, gone: int, keep: int, skip: int, feasible: np.ndarray):
    """The edges of ``gone`` but ``skip`` as ``(edge, other end, path from keep's pixel)``,
    each path joined to ``keep``'s pixel by a straight connector from where it met
    ``gone``; None where a connector leaves ``feasible`` or ``gone`` has a self-loop."""
    out = []
    for f in work.adj[gone]:
        if f == skip:
            continue
        a, b, _ = work.edges[f]
        if a == b:
            return None
        path = work.oriented_path(f, gone)
        connector = line_pixels(work.pixel[keep], path[0])
        if not feasible[connector[:, 0], connector[:, 1]].all():
            return None
        out.append((f, work.other(f, gone), np.concatenate([connector[:-1], path])))
    return out


def merge_close_vertices(
    work: WorkGraph, feasible: np.ndarray, max_px: float, dead_end_px: float, min_loop_px: float
) -> int:
    """Merge the two ends of every edge shorter than ``max_px`` (``dead_end_px`` for an edge
    to a dead end), shortest first and round after round until none merges: the end with
    more edges stays (a vertex with a self-loop, a ring's, always does), the other's edges
    are joined to it by straight feasible connectors (no merge where one would leave
    ``feasible``) and its pixels become its member pixels.  A loop that the merge leaves
    shorter than ``min_loop_px`` at the vertex is dropped.  Returns the number of vertices
    merged."""
    merged, before = 0, -1
    reach = max(max_px, dead_end_px)
    while merged > before:  # a merge's connectors may make new short edges: another round
        before = merged
        short = [e for e, length in work.length.items() if length <= reach]
        for e in sorted(short, key=work.length.__getitem__):
            merged += _merge_ends(work, e, feasible, max_px, dead_end_px, min_loop_px)
        work.contract_all()
    return merged


def _has_self_loop(work: WorkGraph, vertex: int) -> bool:
    return any(work.edges[f][0] == work.edges[f][1] for f in work.adj[vertex])


def _merge_ends(
    work: WorkGraph, e: int, feasible: np.ndarray, max_px: float, dead_end_px: float, min_loop_px
) -> int:
    """Merge the two ends of edge ``e`` as :func:`merge_close_vertices` says (the end
    with more edges, or with a self-loop, stays); 1 if merged, else 0."""
    if e not in work.edges:
        return 0
    u, v, _ = work.edges[e]
    if u == v:
        return 0
    keep, gone = (u, v) if len(work.adj[u]) >= len(work.adj[v]) else (v, u)
    if _has_self_loop(work, gone) and not _has_self_loop(work, keep):
        keep, gone = gone, keep  # a ring's vertex stays where its ring is
    limit = dead_end_px if len(work.adj[gone]) == 1 else max_px
    if work.length[e] > limit:
        return 0
    moved = _rerouted(work, gone, keep, e, feasible)
    if moved is None:
        return 0
    work.remove_edge(e)
    for f, other, path in moved:
        work.remove_edge(f)
        end = keep if other == gone else other
        if end == keep and path_length_px(path) < min_loop_px:
            continue
        work.add_edge(keep, end, path)
    work.members[keep] = np.concatenate([work.members[keep], work.members[gone]])
    work.dead.add(gone)
    return 1
