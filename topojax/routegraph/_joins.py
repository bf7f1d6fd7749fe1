"""Joining new pieces to a route graph under construction: straight feasible segments,
feasible shortest paths, and vertices at given graph pixels (edges split there)."""

from __future__ import annotations

import cv2
import numpy as np
from skimage.graph import MCP_Geometric

from .._jit import cached_njit
from ..graph.work import WorkGraph, line_into

__all__ = ["attach_points", "geodesic_path", "mask_pixels", "segment_ok"]


def mask_pixels(mask: np.ndarray) -> np.ndarray:
    """``(row, col)`` of the set pixels of ``mask`` (bool (H, W)) in raster order, int64
    (N, 2): ``np.argwhere(mask)``, faster."""
    found = cv2.findNonZero(mask.view(np.uint8))
    if found is None:
        return np.zeros((0, 2), np.int64)
    return found.reshape(-1, 2)[:, ::-1].astype(np.int64)


@cached_njit(nogil=True)
def _line_if_feasible(r0, c0, r1, c1, feasible, out):
    n = line_into(r0, c0, r1, c1, out)
    for i in range(n):
        if not feasible[out[i, 0], out[i, 1]]:
            return False
    return True


def segment_ok(a, b, feasible: np.ndarray) -> np.ndarray | None:
    """The straight pixel line from ``a`` to ``b`` if all its pixels are feasible."""
    r0, c0, r1, c1 = int(a[0]), int(a[1]), int(b[0]), int(b[1])
    out = np.empty((max(abs(r1 - r0), abs(c1 - c0)) + 1, 2), np.int32)
    return out if _line_if_feasible(r0, c0, r1, c1, feasible, out) else None


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
        sel = np.flatnonzero(np.isin(keys, np.fromiter(want, np.int64)))
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
            hit = np.flatnonzero(np.isin(flat, np.fromiter(want, np.int64)))
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
