"""Per-region sums in one pass over the pixels (compiled)."""

from __future__ import annotations

import numpy as np

from .._jit import cached_njit

__all__ = ["basis_points", "disc_offsets", "label_moments", "region_stats", "sides_widen"]


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


def disc_offsets(radius: float) -> np.ndarray:
    """Offsets (dr, dc) int64 (K, 2) of the disc of ``radius`` pixels, nearest first (ties
    in raster order)."""
    r = int(np.ceil(radius))
    dr, dc = np.mgrid[-r : r + 1, -r : r + 1]
    d2 = dr * dr + dc * dc
    keep = d2 <= radius * radius
    order = np.lexsort((dc[keep], dr[keep], d2[keep]))
    return np.stack([dr[keep][order], dc[keep][order]], axis=1).astype(np.int64)


@cached_njit(nogil=True)
def basis_points(free, pts, radius, offsets):
    """For each point (row, col) of ``pts`` (N, 2) int64, the nearest pixel that is not
    free (the map's outside included) within ``radius[i]`` pixels, and the nearest one on
    the opposite side (negative dot product, seen from the point); ``offsets``: the disc
    of at least the largest radius, nearest first (:func:`disc_offsets`).

    Returns int64 (N, 2, 2) (row, col) and bool (N,): whether both were found."""
    h, w = free.shape
    n = pts.shape[0]
    out = np.zeros((n, 2, 2), np.int64)
    found = np.zeros(n, np.bool_)
    for i in range(n):
        pr, pc = pts[i, 0], pts[i, 1]
        lim = radius[i] * radius[i]
        first = -1
        for k in range(offsets.shape[0]):
            dr, dc = offsets[k, 0], offsets[k, 1]
            if dr * dr + dc * dc > lim:
                break
            r, c = pr + dr, pc + dc
            if 0 <= r < h and 0 <= c < w and free[r, c]:
                continue
            if first < 0:
                first = k
                out[i, 0, 0], out[i, 0, 1] = r, c
            elif dr * offsets[first, 0] + dc * offsets[first, 1] < 0:
                out[i, 1, 0], out[i, 1, 1] = r, c
                found[i] = True
                break
    return out, found


@cached_njit(nogil=True)
def sides_widen(clearance, pts, normal, c, reach, rise):
    """Whether, seen from each point ``pts[i]`` (float64 (N, 2)), the clearance reaches
    ``rise * c[i]`` on both sides of the line through it across ``normal[i]``: along a fan
    of rays (+-30 deg about ``+normal`` and ``-normal``) out to ``reach`` pixels, each ray
    stopped at the first pixel of clearance below 1 (or off the map)."""
    h, w = clearance.shape
    n = pts.shape[0]
    out = np.zeros(n, np.bool_)
    cos30, sin30 = 0.8660254037844387, 0.5
    steps = int(np.ceil(reach))
    for i in range(n):
        need = rise * c[i]
        both = True
        for sign in (1.0, -1.0):
            seen = False
            for a in range(3):
                sa = (-sin30, 0.0, sin30)[a]
                ca = (cos30, 1.0, cos30)[a]
                dr = sign * (normal[i, 0] * ca - normal[i, 1] * sa)
                dc = sign * (normal[i, 0] * sa + normal[i, 1] * ca)
                for s in range(1, steps + 1):
                    r = int(np.floor(pts[i, 0] + s * dr + 0.5))
                    cc = int(np.floor(pts[i, 1] + s * dc + 0.5))
                    if r < 0 or r >= h or cc < 0 or cc >= w:
                        break
                    v = clearance[r, cc]
                    if v < 1.0:
                        break
                    if v >= need:
                        seen = True
                        break
                if seen:
                    break
            if not seen:
                both = False
                break
        out[i] = both
    return out


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
