"""Independent brute-force references shared by the test modules."""

from __future__ import annotations

import numpy as np


def brute_sq_distance(obstacles: np.ndarray, r: int) -> np.ndarray:
    """Float64 windowed squared distance by brute force (independent of all kernels):
    ``min (dr^2 + dc^2)`` over obstacles with ``|dr| <= r`` and ``|dc| <= r``, ``inf``
    where there is none."""
    h, w = obstacles.shape
    out = np.full((h, w), np.inf)
    rr, cc = np.mgrid[0:h, 0:w]
    for y, x in zip(*np.nonzero(obstacles), strict=True):
        inside = (np.abs(rr - y) <= r) & (np.abs(cc - x) <= r)
        out = np.where(inside, np.minimum(out, (rr - y) ** 2 + (cc - x) ** 2), out)
    return out


def distance_to_polyline(points: np.ndarray, chain: np.ndarray) -> np.ndarray:
    """Euclidean distance from each point (n, 2) to the polyline ``chain`` (m, 2), by
    brute force over its segments."""
    best = np.full(len(points), np.inf)
    for a, b in zip(chain[:-1], chain[1:], strict=True):
        ab = b - a
        span = float(ab @ ab)
        t = np.zeros(len(points)) if span == 0 else np.clip((points - a) @ ab / span, 0, 1)
        best = np.minimum(best, np.hypot(*(points - (a + t[:, None] * ab)).T))
    return best
