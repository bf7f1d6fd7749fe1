"""Short loops and short dead ends of a graph given as an edge table."""

from __future__ import annotations

import heapq

import numpy as np

__all__ = ["short_dead_ends", "short_loops"]


def _adjacency(n: int, u: np.ndarray, v: np.ndarray, length: np.ndarray) -> list[list]:
    adj: list[list] = [[] for _ in range(n)]
    for e, (a, b, w) in enumerate(zip(u.tolist(), v.tolist(), length.tolist(), strict=True)):
        adj[a].append((b, w, e))
        if a != b:
            adj[b].append((a, w, e))
    return adj


def _bounded_path(adj: list[list], src: int, dst: int, skip: int, limit: float):
    """Edge ids of a shortest ``src``-``dst`` path avoiding edge ``skip`` and shorter than
    ``limit``, or None."""
    dist = {src: 0.0}
    via: dict[int, tuple[int, int]] = {}
    heap = [(0.0, src)]
    done = set()
    while heap:
        d, x = heapq.heappop(heap)
        if x in done:
            continue
        if x == dst:
            path, y = [], dst
            while y != src:
                y, e = via[y]
                path.append(e)
            return path
        done.add(x)
        for y, w, e in adj[x]:
            nd = d + w
            if e == skip or nd >= limit or nd >= dist.get(y, np.inf):
                continue
            dist[y], via[y] = nd, (x, e)
            heapq.heappush(heap, (nd, y))
    return None


def short_loops(n: int, u: np.ndarray, v: np.ndarray, length: np.ndarray, limit: float) -> int:
    """Number of distinct minimal cycles shorter than ``limit``.

    For every edge ``e = (a, b)`` the minimal cycle through it is ``e`` plus a shortest
    ``a``-``b`` path without ``e`` (a self-loop is a cycle by itself).  Cycles shorter than
    ``limit`` are counted once each, as sets of edges.

    Parameters
    ----------
    n : int
        Number of vertices.
    u, v : int64 (E,)
        End vertices of the edges.
    length : float64 (E,)
        Edge lengths, in the unit of ``limit``.
    limit : float

    Returns
    -------
    int
    """
    adj = _adjacency(n, u, v, length)
    deg = np.bincount(np.r_[u, v], minlength=n)
    cycles: set[frozenset] = set()
    for e in np.flatnonzero(length < limit).tolist():
        a, b = int(u[e]), int(v[e])
        if a == b:
            cycles.add(frozenset((e,)))
            continue
        if deg[a] < 2 or deg[b] < 2:
            continue
        path = _bounded_path(adj, a, b, e, limit - float(length[e]))
        if path is not None:
            cycles.add(frozenset([e, *path]))
    return len(cycles)


def short_dead_ends(n: int, u: np.ndarray, v: np.ndarray, length: np.ndarray, limit: float) -> int:
    """Number of degree-1 vertices whose one edge is shorter than ``limit`` (a self-loop
    adds 2 to its vertex's degree)."""
    deg = np.bincount(np.r_[u, v], minlength=n)
    ends = np.r_[u, v]
    lens = np.r_[length, length]
    return int(np.count_nonzero((deg[ends] == 1) & (lens < limit)))
