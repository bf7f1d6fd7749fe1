"""Independent brute-force references shared by the test modules."""

from __future__ import annotations

import math

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


def segment_pixels_exact(q, p) -> set[tuple[int, int]]:
    """The pixels ``(row, col)`` the segment ``q``-``p`` passes through, in exact rational
    arithmetic: the pixels its ends round to (halves up) and, between consecutive
    crossings of pixel borders, the pixel the piece's midpoint rounds to (inside a pixel,
    or on the border it runs along); a crossing point alone adds no pixel."""
    from fractions import Fraction

    half = Fraction(1, 2)
    q = [Fraction(float(x)) for x in q]
    p = [Fraction(float(x)) for x in p]
    ts = {Fraction(0), Fraction(1)}
    for k in range(2):
        d = p[k] - q[k]
        if d == 0:
            continue
        lo, hi = sorted((q[k], p[k]))
        for m in range(math.floor(lo) - 1, math.ceil(hi) + 1):
            t = (m + half - q[k]) / d  # where it crosses the border at m + 1/2
            if 0 <= t <= 1:
                ts.add(t)
    ts = sorted(ts)
    at = [ts[0], ts[-1]] + [(a + b) / 2 for a, b in zip(ts[:-1], ts[1:], strict=True)]
    return {tuple(math.floor(q[k] + t * (p[k] - q[k]) + half) for k in range(2)) for t in at}
