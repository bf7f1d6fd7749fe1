"""Per-region sums in one pass over the pixels (compiled)."""

from __future__ import annotations

import numpy as np

from .._jit import cached_njit

__all__ = ["basis_points", "label_moments", "region_stats"]


@cached_njit(nogil=True)
def region_stats(regions, clearance, n):
    """Area (pixels), largest clearance and boundary length (pixels with a 4-neighbour of
    another label, the map's outside included) of regions ``0..n-1``.

    Parameters
    ----------
    regions : int32 (H, W)
    clearance : float32 (H, W)
    n : int

    Returns
    -------
    (float64 (n,), float64 (n,), float64 (n,))
    """
    h, w = regions.shape
    area = np.zeros(n, np.float64)
    clear = np.zeros(n, np.float64)
    border = np.zeros(n, np.float64)
    for r in range(h):
        for c in range(w):
            k = regions[r, c]
            area[k] += 1.0
            v = clearance[r, c]
            if v > clear[k]:
                clear[k] = v
            edge = r == 0 or r == h - 1 or c == 0 or c == w - 1
            if not edge:
                edge = (
                    regions[r - 1, c] != k
                    or regions[r + 1, c] != k
                    or regions[r, c - 1] != k
                    or regions[r, c + 1] != k
                )
            if edge:
                border[k] += 1.0
    return area, clear, border


@cached_njit(nogil=True)
def basis_points(free, pts, radius):
    """For each point (row, col) of ``pts`` (N, 2) int64, the nearest pixel that is not
    free (the map's outside included) within ``radius[i]`` (Chebyshev), and the nearest
    one on the opposite side (negative dot product, seen from the point).

    Returns int64 (N, 2, 2) (row, col) and bool (N,): whether both were found."""
    h, w = free.shape
    n = pts.shape[0]
    out = np.zeros((n, 2, 2), np.int64)
    found = np.zeros(n, np.bool_)
    for i in range(n):
        pr, pc = pts[i, 0], pts[i, 1]
        rad = radius[i]
        best = 1 << 62
        br, bc = 0, 0
        for r in range(pr - rad, pr + rad + 1):
            for c in range(pc - rad, pc + rad + 1):
                if 0 <= r < h and 0 <= c < w and free[r, c]:
                    continue
                d = (r - pr) * (r - pr) + (c - pc) * (c - pc)
                if d < best:
                    best, br, bc = d, r, c
        if best == 1 << 62:
            continue
        ur, uc = br - pr, bc - pc
        best2 = 1 << 62
        sr, sc = 0, 0
        for r in range(pr - rad, pr + rad + 1):
            for c in range(pc - rad, pc + rad + 1):
                if 0 <= r < h and 0 <= c < w and free[r, c]:
                    continue
                if (r - pr) * ur + (c - pc) * uc >= 0:
                    continue
                d = (r - pr) * (r - pr) + (c - pc) * (c - pc)
                if d < best2:
                    best2, sr, sc = d, r, c
        if best2 == 1 << 62:
            continue
        out[i, 0, 0], out[i, 0, 1], out[i, 1, 0], out[i, 1, 1] = br, bc, sr, sc
        found[i] = True
    return out, found


@cached_njit(nogil=True)
def label_moments(labels, n):
    """Pixel count, row sum and column sum of labels ``0..n`` (float64 (n + 1,) each)."""
    count = np.zeros(n + 1, np.float64)
    sum_r = np.zeros(n + 1, np.float64)
    sum_c = np.zeros(n + 1, np.float64)
    h, w = labels.shape
    for r in range(h):
        for c in range(w):
            k = labels[r, c]
            count[k] += 1.0
            sum_r[k] += r
            sum_c[k] += c
    return count, sum_r, sum_c
