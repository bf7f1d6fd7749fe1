"""Exact 8-connected geodesics inside a pixel mask (moves of 1 and sqrt 2 pixels): lengths
from one pixel to many (the route-graph evaluator) and the shortest path from one pixel to
the nearest of a set (joining coverage waypoints to the graph, and the edge ends of a
merged junction through its pixels).

The search is Dijkstra's with unit-width distance buckets: every move is at least 1 pixel
long, so once the pixels of bucket ``[k, k + 1)`` are reached, none of them can be improved
by another (any move from bucket ``k`` lands in bucket ``k + 1`` or later), and each
bucket is settled in one pass.  Moves are shorter than 2 pixels, so three buckets in
rotation suffice.  It gives the lengths of :class:`skimage.graph.MCP_Geometric` with cost 1
inside the mask (up to the rounding of the sums), in time linear in the pixels searched.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import cached_njit

__all__ = ["geodesic_from", "nearest_path"]


@cached_njit(nogil=True)
def _push(bufs, counts, b, p):
    """Append pixel ``p`` to bucket ``b`` (the buffer doubles when full)."""
    buf = bufs[b]
    if counts[b] == buf.size:
        bigger = np.empty(2 * buf.size, np.int64)
        bigger[: buf.size] = buf
        bufs[b] = bigger
        buf = bigger
    buf[counts[b]] = p
    counts[b] += 1


@cached_njit(nogil=True)
def _bucket_search(state, width, start, ends, nearest_only, dist, pred):
    """Settle pixels from flat pixel ``start`` in unit-width distance buckets until every
    open pixel of ``ends`` (flat pixels) is settled or, with ``nearest_only``, until the
    bucket holding the nearest of them is.  ``state`` (uint8, a padded mask raveled, its
    border 0) is 1 on open pixels and is consumed (settled pixels become 0); ``dist``
    (float64, the size of ``state``, inf) receives the lengths; ``pred`` (int64, the size
    of ``state``, or empty) each reached pixel's predecessor.  Returns the nearest open
    pixel of ``ends`` (the smallest flat index among equally near ones), or -1."""
    remaining = 0
    for e in ends:
        if state[e] == 1:
            state[e] = 2  # an open target
            remaining += 1
    paths = pred.size == state.size
    offs = np.array([-width - 1, -width, -width + 1, -1, 1, width - 1, width, width + 1], np.int64)
    s2 = math.sqrt(2.0)
    wts = np.array([s2, 1.0, s2, 1.0, 1.0, s2, 1.0, s2])
    bufs = [np.empty(1024, np.int64), np.empty(1024, np.int64), np.empty(1024, np.int64)]
    counts = np.zeros(3, np.int64)
    dist[start] = 0.0
    if paths:
        pred[start] = -1
    _push(bufs, counts, 0, start)
    k = 0
    best = -1
    while remaining > 0 and counts[0] + counts[1] + counts[2] > 0:
        b = k % 3
        buf = bufs[b]
        i = 0
        while i < counts[b]:
            p = buf[i]
            i += 1
            if state[p] == 0 or dist[p] >= k + 1:
                continue  # settled already, or a stale entry of a later bucket
            if state[p] == 2:
                remaining -= 1
                if best < 0 or dist[p] < dist[best] or (dist[p] == dist[best] and p < best):
                    best = p
            state[p] = 0
            d = dist[p]
            for j in range(8):
                q = p + offs[j]
                if state[q] != 0:
                    nd = d + wts[j]
                    if nd < dist[q]:
                        dist[q] = nd
                        if paths:
                            pred[q] = p
                        _push(bufs, counts, int(nd) % 3, q)
        counts[b] = 0
        if nearest_only and best >= 0:
            # every pixel less than k + 1 away is settled: no target is nearer
            break
        k += 1
    return best


def geodesic_from(mask: np.ndarray, source, targets: np.ndarray) -> np.ndarray:
    """Lengths (pixels, float64 (T,)) of the shortest 8-connected paths inside ``mask``
    from pixel ``source`` (row, col) to each of ``targets`` (T, 2) int; ``inf`` where
    unreachable (or where the source is outside the mask)."""
    h, w = mask.shape
    padded = np.zeros((h + 2, w + 2), np.uint8)
    padded[1:-1, 1:-1] = mask
    width = w + 2
    targets = np.asarray(targets, np.int64).reshape(-1, 2)
    out = np.full(targets.shape[0], np.inf)
    r, c = int(source[0]), int(source[1])
    if not mask[r, c] or targets.shape[0] == 0:
        return out
    ends = (targets[:, 0] + 1) * width + targets[:, 1] + 1
    dist = np.full(padded.size, np.inf)
    start = (r + 1) * width + c + 1
    _bucket_search(padded.ravel(), width, start, ends, False, dist, np.empty(0, np.int64))
    return dist[ends]


@cached_njit(nogil=True)
def _trace(pred, end):
    """The flat pixels from the search's start to ``end`` along ``pred``."""
    n = 1
    p = end
    while pred[p] >= 0:
        p = pred[p]
        n += 1
    out = np.empty(n, np.int64)
    p = end
    for i in range(n - 1, -1, -1):
        out[i] = p
        p = pred[p]
    return out


def nearest_path(mask: np.ndarray, start, targets: np.ndarray) -> np.ndarray | None:
    """Shortest 8-connected path inside ``mask`` (bool (H, W)) from pixel ``start`` (row,
    col) to the nearest pixel of ``targets`` (bool (H, W)) in ``mask``: int32 (K, 2) from
    ``start`` to that pixel, or None when none is reachable."""
    h, w = mask.shape
    r, c = int(start[0]), int(start[1])
    if not mask[r, c]:
        return None
    padded = np.zeros((h + 2, w + 2), np.uint8)
    padded[1:-1, 1:-1] = mask
    width = w + 2
    rows, cols = np.nonzero(mask & targets)
    ends = (rows.astype(np.int64) + 1) * width + cols + 1
    dist = np.full(padded.size, np.inf)
    pred = np.empty(padded.size, np.int64)
    start = (r + 1) * width + c + 1
    end = _bucket_search(padded.ravel(), width, start, ends, True, dist, pred)
    if end < 0:
        return None
    flat = _trace(pred, end)
    return np.stack([flat // width - 1, flat % width - 1], axis=1).astype(np.int32)
