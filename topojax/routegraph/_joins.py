"""Joining new pieces to a route graph under construction: straight feasible segments,
feasible shortest paths, and vertices at given graph pixels (edges split there); and the
masks the coverage steps share."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np
from scipy.spatial import cKDTree

from .._jit import cached_njit
from ..graph.geodesic import nearest_path
from ..graph.work import WorkGraph, line_in_mask, line_pixels

__all__ = [
    "GraphPixels",
    "attach_points",
    "feasible_segments",
    "geodesic_path",
    "grow",
    "join_groups",
    "large_pieces",
    "mask_pixels",
    "pieces_by_area",
]

# Joins tried per group: its pixels (every second one) to their nearest graph pixels.
_JOIN_TRIES = 400
_NEIGHBOURS = 4
# Clearing a small piece in its bounding box costs about as much as this many pixels of
# a whole-mask lookup, besides the box.
_PIECE_COST_PX = 1000


def mask_pixels(mask: np.ndarray) -> np.ndarray:
    """``(row, col)`` of the set pixels of ``mask`` (bool (H, W)) in raster order, int64
    (N, 2): ``np.argwhere(mask)``, faster."""
    found = cv2.findNonZero(mask.view(np.uint8))
    if found is None:
        return np.zeros((0, 2), np.int64)
    return found.reshape(-1, 2)[:, ::-1].astype(np.int64)


def grow(mask: np.ndarray) -> np.ndarray:
    """``mask`` (bool (H, W)) dilated by one pixel (3 x 3)."""
    return cv2.dilate(mask.view(np.uint8), np.ones((3, 3), np.uint8)).view(bool)


def large_pieces(mask: np.ndarray, min_area_px: float) -> np.ndarray:
    """The 8-connected pieces of ``mask`` (bool (H, W)) of at least ``min_area_px``
    pixels, as a new mask."""
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask.view(np.uint8), connectivity=8)
    area = stats[1:, cv2.CC_STAT_AREA]
    return _pieces(mask, labels, stats, area >= min_area_px)


def pieces_by_area(
    mask: np.ndarray, min_area_px: float, split_px: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(small, large)``: the 8-connected pieces of ``mask`` (bool (H, W)) of at least
    ``min_area_px`` pixels but fewer than ``split_px``, and those of at least
    ``split_px``, as new masks (from one labelling of ``mask``)."""
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask.view(np.uint8), connectivity=8)
    area = stats[1:, cv2.CC_STAT_AREA]
    large = area >= split_px
    small = (area >= min_area_px) & ~large
    return _pieces(mask, labels, stats, small), _pieces(mask, labels, stats, large)


def _pieces(mask: np.ndarray, labels: np.ndarray, stats: np.ndarray, keep: np.ndarray):
    """The pieces ``keep`` (bool (n,), piece ``k + 1`` of ``labels``) of ``mask`` as a new
    mask: the pieces cleared (or the kept ones set) in their bounding boxes where there are
    few such pieces, else a lookup over the whole mask."""
    ids = np.arange(1, len(stats))
    for drop, chosen in ((True, ids[~keep]), (False, ids[keep])):
        x, y, w, h = (stats[chosen, k] for k in range(4))
        if len(chosen) * _PIECE_COST_PX + int(np.dot(w.astype(np.int64), h)) > mask.size:
            continue
        # few pieces: each cleared (or set) in its bounding box
        out = mask.copy() if drop else np.zeros_like(mask)
        for i, x0, y0, x1, y1 in zip(chosen, x, y, x + w, y + h, strict=True):
            box = out[y0:y1, x0:x1]
            box[labels[y0:y1, x0:x1] == i] = not drop
        return out
    lookup = np.r_[False, keep]
    return lookup[labels]


@cached_njit(nogil=True)
def feasible_segments(a, b, feasible, stop_at_first):
    """For segments ``a[k]``-``b[k]`` (int64 (K, 2) pixels each): whether the straight pixel
    line is feasible (bool (K,)); with ``stop_at_first``, the segments after the first
    feasible one are not tested (False)."""
    n = a.shape[0]
    ok = np.zeros(n, np.bool_)
    longest = 1
    for k in range(n):
        longest = max(longest, abs(a[k, 0] - b[k, 0]) + 1, abs(a[k, 1] - b[k, 1]) + 1)
    out = np.empty((longest, 2), np.int32)
    for k in range(n):
        ok[k] = line_in_mask(a[k, 0], a[k, 1], b[k, 0], b[k, 1], feasible, out) > 0
        if ok[k] and stop_at_first:
            break
    return ok


def attach_points(work: WorkGraph, pixels: list, shape: tuple[int, int]) -> list[int]:
    """Vertices at the graph pixels ``pixels`` (each on a vertex or an edge): an edge is
    split at every requested interior pixel.  Returns one vertex id per pixel (-1 for a
    pixel that is on neither)."""
    width = shape[1]
    want = {int(r) * width + int(c): [] for r, c in pixels}
    for k, (r, c) in enumerate(pixels):
        want[int(r) * width + int(c)].append(k)
    out = [-1] * len(pixels)
    alive = [v for v in range(len(work.members)) if v not in work.dead]
    if alive and want:
        mem = np.concatenate([work.members[v] for v in alive]).astype(np.int64)
        owner = np.repeat(alive, [len(work.members[v]) for v in alive])
        keys = mem[:, 0] * width + mem[:, 1]
        sel = np.flatnonzero(np.isin(keys, np.fromiter(want, np.int64), kind="table"))
        # the vertex of lowest id holding a pixel takes it
        hit_keys, first = np.unique(keys[sel], return_index=True)
        for key, v in zip(hit_keys.tolist(), owner[sel[first]].tolist(), strict=True):
            for k in want.pop(key):
                out[k] = v
    splits: dict[int, dict[int, list]] = {}
    if want:
        # every interior edge pixel once, with its edge and index: one lookup for all
        ids = list(work.edges)
        inner = [work.edges[e][2][1:-1] for e in ids]
        sizes = np.array([len(p) for p in inner], np.int64)
        if sizes.sum():
            every = np.concatenate(inner).astype(np.int64)
            flat = every[:, 0] * width + every[:, 1]
            edge_of = np.repeat(np.arange(len(ids)), sizes)
            index = np.arange(flat.size) - np.repeat(np.cumsum(sizes) - sizes, sizes)
            hit = np.flatnonzero(np.isin(flat, np.fromiter(want, np.int64), kind="table"))
            for i in hit.tolist():  # in edge order, then along each path
                ks = want.pop(int(flat[i]), None)
                if ks:
                    splits.setdefault(ids[edge_of[i]], {})[int(index[i]) + 1] = ks
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


def geodesic_path(start, targets: np.ndarray, feasible: np.ndarray) -> np.ndarray | None:
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
            path = nearest_path(feasible[r0:r1, c0:c1], (start[0] - r0, start[1] - c0), sub)
            if path is not None:
                return path + np.array([r0, c0], np.int32)
        if r0 == 0 and c0 == 0 and r1 == h and c1 == w:
            return None
        half *= 2


@dataclass(frozen=True)
class GraphPixels:
    """The pixels of a graph (``raster``, bool (H, W)) and their k-d tree, each found when
    first needed and then kept: the joins of one coverage round share them."""

    raster: np.ndarray

    @cached_property
    def pixels(self) -> np.ndarray:
        """:func:`mask_pixels` of ``raster``."""
        return mask_pixels(self.raster)

    @cached_property
    def tree(self) -> cKDTree:
        """The k-d tree of :attr:`pixels`."""
        return cKDTree(self.pixels)


def _piece_pixels(work: WorkGraph, vertices: list[int]) -> np.ndarray:
    """Every second pixel of the piece ``vertices`` (their pixels and those of their
    edges), the pixels its joins start from."""
    pix = [work.members[v] for v in vertices]
    edges = set().union(*(work.adj[v] for v in vertices))
    pix += [work.edges[e][2] for e in edges]
    return np.concatenate(pix)[::2]


def _nearest_link(pix, dist, idx, graph_px, feasible):
    """The shortest straight feasible segment from a pixel of ``pix`` (a piece's, int
    (n, 2)) to a graph pixel, among each one's nearest graph pixels (``dist`` and ``idx``
    (n, k): the k-d tree's distances and indices into ``graph_px``), as ``(piece pixel,
    graph pixel)``, or None."""
    k = dist.shape[1]
    flat = np.argsort(dist, axis=None, kind="stable")[:_JOIN_TRIES]
    a = pix[flat // k].astype(np.int64)
    g = graph_px[idx.ravel()[flat]].astype(np.int64)
    hit = np.flatnonzero(feasible_segments(a, g, feasible, True))
    if hit.size == 0:
        return None
    j = flat[hit[0]]
    return tuple(pix[j // k]), tuple(graph_px[idx.ravel()[j]])


def join_groups(
    work: WorkGraph,
    groups: list[list[int]],
    raster: np.ndarray,
    feasible: np.ndarray,
    *,
    pixels: GraphPixels | None = None,
) -> None:
    """Join each group of new vertices (a piece of ``work`` not yet joined) to the graph
    pixels ``raster`` (bool (H, W)): by the shortest straight feasible segment from one of
    its pixels, else by a feasible shortest path from its first vertex (no join where
    neither exists).  ``pixels``: the :class:`GraphPixels` of ``raster`` where the caller
    keeps them for other joins."""
    if not groups:
        return
    pixels = GraphPixels(raster) if pixels is None else pixels
    graph_px = pixels.pixels
    if graph_px.size == 0:
        return
    # every piece's nearest graph pixels, in one query
    piece_px = [_piece_pixels(work, vertices) for vertices in groups]
    k = min(_NEIGHBOURS, len(graph_px))
    dist, idx = pixels.tree.query(np.concatenate(piece_px), k=k)
    dist, idx = dist.reshape(-1, k), idx.reshape(-1, k)
    bounds = np.cumsum([0] + [len(p) for p in piece_px]).tolist()
    piece_ends, graph_ends, paths = [], [], []
    for g, vertices in enumerate(groups):
        lo, hi = bounds[g], bounds[g + 1]
        pair = _nearest_link(piece_px[g], dist[lo:hi], idx[lo:hi], graph_px, feasible)
        if pair is not None:
            piece_ends.append(pair[0])
            graph_ends.append(pair[1])
            paths.append(line_pixels(*pair))
            continue
        start = work.pixel[vertices[0]]
        path = geodesic_path(start, raster, feasible)
        if path is not None:
            piece_ends.append(start)
            graph_ends.append(tuple(path[-1]))
            paths.append(path)
    ids = attach_points(work, piece_ends + graph_ends, feasible.shape)
    k = len(piece_ends)
    for j, path in enumerate(paths):
        a, b = ids[j], ids[k + j]
        if a >= 0 and b >= 0 and a != b:
            work.add_edge(a, b, path)
