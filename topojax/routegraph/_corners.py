"""Shortcuts that bend round a corner: where a wall or a piece of furniture juts into
the free space, the shortest route hugs its corner, and no straight line between two
points of the medial axis follows it.  The corners are the reflex vertices of the
feasible space's outline (simplified to a tolerance); a *bent* candidate joins two graph
nodes that see the corner but not each other by two straight lines through it."""

from __future__ import annotations

import cv2
import numpy as np
from scipy.spatial import cKDTree

from .._jit import cached_njit
from ._spanner import straight_is_feasible

__all__ = ["CORNER_TOLERANCE_M", "bent_candidates", "reflex_corners"]

#: The outline of the feasible space is simplified to this tolerance (metres) before its
#: corners are taken.
CORNER_TOLERANCE_M = 0.15
# A corner point sits this far (pixels) from the outline, inside the feasible space.
_INSET_PX = 2.0
# A vertex is a reflex corner when more than this share of the window round it is
# feasible (the free space wraps round it).
_REFLEX_SHARE = 0.6
_WINDOW = 3
# Each corner pairs up its nearest nodes, at most this many.
_PER_CORNER = 16


def reflex_corners(feasible: np.ndarray, tolerance_px: float) -> np.ndarray:
    """Points (int64 (K, 2), ``(row, col)``, feasible pixels) just inside the reflex
    corners of the outline of ``feasible`` (bool (H, W)), simplified to ``tolerance_px``:
    where the feasible space turns round an obstacle."""
    contours, _ = cv2.findContours(feasible.view(np.uint8), cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    h, w = feasible.shape
    polys = [
        cv2.approxPolyDP(contour, float(tolerance_px), True).reshape(-1, 2)
        for contour in contours
        if len(contour) >= 8
    ]
    polys = [poly for poly in polys if len(poly) >= 3]
    if not polys:
        return np.zeros((0, 2), np.int64)
    # every polygon's corners at once, each with its neighbours along its own polygon
    xy = np.concatenate(polys).astype(np.float64)
    sizes = np.array([len(poly) for poly in polys], np.int64)
    first = np.repeat(np.cumsum(sizes) - sizes, sizes)
    at = np.arange(len(xy)) - first
    prev = xy[first + (at - 1) % np.repeat(sizes, sizes)]
    nxt = xy[first + (at + 1) % np.repeat(sizes, sizes)]
    u = prev - xy
    v = nxt - xy
    u /= np.maximum(np.hypot(u[:, 0], u[:, 1]), 1e-9)[:, None]
    v /= np.maximum(np.hypot(v[:, 0], v[:, 1]), 1e-9)[:, None]
    bis = u + v
    norm = np.hypot(bis[:, 0], bis[:, 1])
    ok = norm > 1e-6
    # the bisector of the two sides points into the obstacle at a reflex corner
    q = xy[ok] - _INSET_PX * bis[ok] / norm[ok][:, None]
    cols, rows = np.rint(q[:, 0]).astype(np.int64), np.rint(q[:, 1]).astype(np.int64)
    corner = xy[ok].astype(np.int64)
    inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
    at = np.stack([rows[inside], cols[inside], *corner[inside].T[::-1]], axis=1)
    # (point row, point col, corner row, corner col)
    share = _feasible_around(feasible, at[:, 2], at[:, 3]) / (2 * _WINDOW + 1) ** 2
    keep = feasible[at[:, 0], at[:, 1]] & (share > _REFLEX_SHARE)
    return np.unique(at[keep, :2], axis=0).astype(np.int64)


@cached_njit(nogil=True)
def _feasible_around(feasible: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The number of feasible pixels (int64 (K,)) at most ``_WINDOW`` rows and columns
    from each pixel ``(rows[k], cols[k])`` (none past the image's edge): the box filter
    of the corner test, read at those pixels only."""
    h, w = feasible.shape
    count = np.zeros(rows.shape[0], np.int64)
    for k in range(rows.shape[0]):
        n = 0
        for r in range(max(0, rows[k] - _WINDOW), min(h, rows[k] + _WINDOW + 1)):
            for c in range(max(0, cols[k] - _WINDOW), min(w, cols[k] + _WINDOW + 1)):
                n += int(feasible[r, c])
        count[k] = n
    return count


@cached_njit(nogil=True)
def _visible_pairs(corner, near, pos, feasible, min_leg):
    """For each corner ``k`` and its candidate nodes ``near[k]`` (-1 padded), the pairs
    ``(a, b, k)`` of nodes that see the corner along straight feasible lines at least
    ``min_leg`` long but do not see each other."""
    n_k, width = near.shape
    cap = n_k * width * (width - 1) // 2
    out = np.empty((max(cap, 1), 3), np.int64)
    seen = np.empty(width, np.int64)
    n = 0
    for k in range(n_k):
        r, c = corner[k, 0], corner[k, 1]
        m = 0
        for j in range(width):
            a = near[k, j]
            if a < 0:
                break
            leg = ((pos[a, 0] - r) ** 2 + (pos[a, 1] - c) ** 2) ** 0.5
            if leg >= min_leg and straight_is_feasible(r, c, pos[a, 0], pos[a, 1], feasible):
                seen[m] = a
                m += 1
        for i in range(m):
            for j in range(i + 1, m):
                a, b = seen[i], seen[j]
                if not straight_is_feasible(pos[a, 0], pos[a, 1], pos[b, 0], pos[b, 1], feasible):
                    out[n, 0], out[n, 1], out[n, 2] = min(a, b), max(a, b), k
                    n += 1
    return out[:n]


def bent_candidates(
    corners: np.ndarray, pos: np.ndarray, usable: np.ndarray, feasible, radius_px, min_leg
) -> np.ndarray:
    """Bent candidates ``(a, b, k)`` (int64 (C, 3)): for each corner ``k``, pairs of the
    :data:`_PER_CORNER` nearest usable nodes (``pos`` (M, 2), ``usable`` bool (M,)) within
    ``radius_px`` of it that see it (legs of at least ``min_leg`` pixels) but not each
    other."""
    idx = np.flatnonzero(usable)
    if corners.shape[0] == 0 or idx.size < 2:
        return np.zeros((0, 3), np.int64)
    k = min(_PER_CORNER, idx.size)
    dist, j = cKDTree(pos[idx]).query(corners, k=k, distance_upper_bound=radius_px)
    dist, j = dist.reshape(len(corners), k), j.reshape(len(corners), k)
    near = np.where(np.isfinite(dist), idx[np.minimum(j, idx.size - 1)], -1).astype(np.int64)
    return _visible_pairs(corners, near, pos.astype(np.int64), feasible, float(min_leg))
