"""Doorway candidates: local minima of the clearance along the skeleton, each cut along
the line between its two nearest obstacles."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..graph import skeleton_to_graph
from ..graph.work import WorkGraph, drop_spurs

__all__ = ["Cut", "door_cuts", "segment_pixels"]

#: Along the skeleton, the clearance on both sides of a doorway rises to at least this
#: many times the doorway's (a branch into a corner only falls).
DOOR_RISE = 1.1
#: Dead ends shorter than this many times the clearance at their junction are branches of
#: the medial axis into corners, not places a doorway can lead to.
SPUR_FACTOR = 2.0


@dataclass(frozen=True, eq=False)
class Cut:
    """One doorway candidate.

    Attributes
    ----------
    centre : int64 (2,)
        Skeleton pixel (row, col) where the clearance is locally smallest.
    ends : int64 (2, 2)
        The two obstacle pixels the cut runs between (row, col).
    pixels : int64 (K, 2)
        The free pixels of the cut (an 8-connected line: no 4-connected path crosses it).
    width_px : float
        Free width of the gap (distance between the two obstacle pixel centres, minus 1).
    """

    centre: np.ndarray
    ends: np.ndarray
    pixels: np.ndarray
    width_px: float


def segment_pixels(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """8-connected pixels (K, 2) int64 of the straight line from ``a`` to ``b`` (row, col),
    both included."""
    a = np.asarray(a, np.int64)
    b = np.asarray(b, np.int64)
    n = int(np.abs(b - a).max())
    if n == 0:
        return a[None].copy()
    t = np.arange(n + 1) / n
    pts = a[None, :] + t[:, None] * (b - a)[None, :]
    return np.floor(pts + 0.5).astype(np.int64)


def _edge_minima(c: np.ndarray, w: int, rise: float) -> np.ndarray:
    """Indices along one skeleton path (clearances ``c``) that are the smallest within
    ``w`` steps and beyond which the clearance rises to ``rise`` times theirs on both sides
    (the first index of a flat minimum)."""
    n = c.size
    if n < 3:
        return np.empty(0, np.int64)
    pad = np.pad(c, w, constant_values=np.inf)
    win = np.lib.stride_tricks.sliding_window_view(pad, 2 * w + 1).min(axis=1)
    left_max = np.maximum.accumulate(c)
    right_max = np.maximum.accumulate(c[::-1])[::-1]
    idx = np.arange(n)
    ok = (c <= win) & (idx > 0) & (idx < n - 1)
    ok &= np.r_[-np.inf, left_max[:-1]] >= rise * c
    ok &= np.r_[right_max[1:], -np.inf] >= rise * c
    ok &= np.r_[True, c[1:] != c[:-1]]  # the first pixel of a flat minimum
    return np.flatnonzero(ok)


def _candidates(clearance, skeleton, lo: float, hi: float, w: int, rise: float):
    """Skeleton pixels where the clearance along the skeleton has a local minimum in
    [lo, hi] with a rise on both sides, one per ``w`` neighbourhood (narrowest first)."""
    work = WorkGraph.from_networkx(skeleton_to_graph(skeleton))
    drop_spurs(work, clearance, float(w), SPUR_FACTOR)  # the medial axis's corner branches
    work.contract_all()
    found = []
    for _, _, path in work.edges.values():
        path = np.asarray(path, np.int64)
        c = clearance[path[:, 0], path[:, 1]]
        k = _edge_minima(c, w, rise)
        k = k[(c[k] >= lo) & (c[k] <= hi)]
        found.append(path[k])
    pts = np.concatenate(found) if found else np.empty((0, 2), np.int64)
    if pts.size == 0:
        return pts
    cv = clearance[pts[:, 0], pts[:, 1]]
    pts = pts[np.lexsort((pts[:, 1], pts[:, 0], cv))]
    tree = cKDTree(pts)
    taken = np.zeros(len(pts), bool)
    blocked = np.zeros(len(pts), bool)
    for i in range(len(pts)):
        if blocked[i]:
            continue
        taken[i] = True
        blocked[tree.query_ball_point(pts[i], w / 2, p=np.inf)] = True
    return pts[taken]


def _basis_points(free: np.ndarray, p: np.ndarray, radius: int):
    """The obstacle pixel (not free, the map's outside included) nearest to ``p`` and the
    nearest one on the opposite side of ``p`` (negative dot product), within ``radius``
    (Chebyshev window); None where either is missing."""
    h, w = free.shape
    r0, r1 = p[0] - radius, p[0] + radius + 1
    c0, c1 = p[1] - radius, p[1] + radius + 1
    win = np.zeros((r1 - r0, c1 - c0), bool)
    rs, re = max(r0, 0), min(r1, h)
    cs, ce = max(c0, 0), min(c1, w)
    win[rs - r0 : re - r0, cs - c0 : ce - c0] = free[rs:re, cs:ce]
    rr, cc = np.nonzero(~win)
    if rr.size == 0:
        return None
    dr, dc = rr + r0 - p[0], cc + c0 - p[1]
    d2 = dr * dr + dc * dc
    k = int(np.argmin(d2))
    opposite = np.flatnonzero(dr * dr[k] + dc * dc[k] < 0)
    if opposite.size == 0:
        return None
    j = opposite[int(np.argmin(d2[opposite]))]
    return (
        np.array([rr[k] + r0, cc[k] + c0], np.int64),
        np.array([rr[j] + r0, cc[j] + c0], np.int64),
    )


def door_cuts(free, clearance, skeleton, cfg, resolution_m: float) -> list[Cut]:
    """Doorway candidates of a map (see :class:`Cut`)."""
    lo = max(cfg.min_door_width_m / resolution_m + 1.0, 1.0) / 2.0
    hi = (cfg.max_door_width_m / resolution_m + 1.0) / 2.0
    w = max(1, int(round(cfg.door_context_m / resolution_m)))
    cuts = []
    for p in _candidates(clearance, skeleton, lo, hi, w, DOOR_RISE):
        c = float(clearance[p[0], p[1]])
        basis = _basis_points(free, p, int(np.ceil(1.6 * c)) + 2)
        if basis is None:
            continue
        q1, q2 = basis
        width = float(np.hypot(*(q2 - q1))) - 1.0
        if not (2 * lo - 1.0 <= width <= 2 * hi - 1.0):
            continue
        line = segment_pixels(q1, q2)
        inside = (line[:, 0] >= 0) & (line[:, 0] < free.shape[0])
        inside &= (line[:, 1] >= 0) & (line[:, 1] < free.shape[1])
        line = line[inside]
        line = line[free[line[:, 0], line[:, 1]]]
        if line.size == 0:
            continue
        cuts.append(Cut(centre=p, ends=np.stack([q1, q2]), pixels=line, width_px=width))
    return cuts
