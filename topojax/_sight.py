"""Sight lines over a pixel grid: every pixel a straight segment passes through.

Pixel ``(r, c)`` is the square ``[r - 1/2, r + 1/2) x [c - 1/2, c + 1/2)``: a point
belongs to the pixel its coordinates round to, halves rounded up (as a query point's
pixel is found).  A segment *passes through* a pixel when one of its points, ends
included, belongs to it.  A segment that only touches a pixel's corner or border passes
through it exactly when the touching point rounds to it: of the four pixels around the
corner ``(r + 1/2, c + 1/2)``, a segment through it counts ``(r + 1, c + 1)``, so one
from ``(r, c)`` to ``(r + 1, c + 1)`` passes through those two pixels only, one from
``(r, c + 1)`` to ``(r + 1, c)`` through ``(r + 1, c + 1)`` as well.  Every point of the
segment thus lies on a pixel passed (points sampled along it can step over a pixel it
clips at a corner).  The viewer's router (``view/static/route.js``) walks the same
pixels with the same arithmetic.
"""

from __future__ import annotations

import numpy as np

__all__ = ["segment_pixels", "sees"]


def segment_pixels(q: np.ndarray, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pixels each segment from ``q`` to a point of ``pts`` passes through.

    Parameters
    ----------
    q : float (2,)
        The common end, ``(row, col)`` in pixels.
    pts : float (K, 2)
        The other ends.

    Returns
    -------
    segment, rows, cols : int64 (N,)
        One entry per pixel passed: the segment's index in ``pts`` and the pixel, by
        segment; each segment's pixels row by row (rows in increasing order).
    """
    q = np.asarray(q, np.float64)
    pts = np.asarray(pts, np.float64).reshape(-1, 2)
    u0, u1 = q[0] + 0.5, q[1] + 0.5  # shifted by half: a point's pixel is its floor
    v0, v1 = pts[:, 0] + 0.5, pts[:, 1] + 0.5
    flip = v0 < u0  # walk each segment with the row increasing, from a to b
    a0, a1 = np.where(flip, v0, u0), np.where(flip, v1, u1)
    b0, b1 = np.where(flip, u0, v0), np.where(flip, u1, v1)
    d0, d1 = b0 - a0, b1 - a1
    d0 = np.where(d0 > 0, d0, 1.0)  # d0 is 0 only within one row: no crossing
    r_lo = np.floor(a0)
    n_rows = (np.floor(b0) - r_lo).astype(np.int64) + 1
    # the column where each segment starts, crosses into each next row, and ends
    n_x = n_rows + 1
    first = np.cumsum(n_x) - n_x
    seg_x = np.repeat(np.arange(pts.shape[0]), n_x)
    j = np.arange(seg_x.size) - first[seg_x]
    # divided last: a crossing on a pixel corner, with ends in binary fractions, is exact
    x = a1[seg_x] + ((r_lo[seg_x] + j - a0[seg_x]) * d1[seg_x]) / d0[seg_x]
    x[first] = a1
    x[first + n_rows] = b1
    fx = np.floor(x)
    # row j of a segment runs from x[j] to x[j + 1]; the point at x[j + 1] belongs to the
    # next row, except at the end
    at = np.flatnonzero(j < n_rows[seg_x])
    seg = seg_x[at]
    up_inner = (d1[seg] >= 0) & (j[at] + 1 < n_rows[seg])
    lo = np.minimum(fx[at], fx[at + 1]).astype(np.int64)
    hi = np.maximum(fx[at], np.where(up_inner, np.ceil(x[at + 1]) - 1, fx[at + 1]))
    n_cols = hi.astype(np.int64) - lo + 1
    k = np.repeat(np.arange(at.size), n_cols)
    cols = lo[k] + np.arange(k.size) - np.repeat(np.cumsum(n_cols) - n_cols, n_cols)
    return seg[k], (r_lo[seg] + j[at]).astype(np.int64)[k], cols


def sees(feasible: np.ndarray, q: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Whether each straight segment from ``q`` to a point of ``pts`` passes through set
    pixels of ``feasible`` only (:func:`segment_pixels`; off the grid counts as unset).

    Parameters
    ----------
    feasible : bool (H, W)
    q : float (2,)
        ``(row, col)`` in pixels.
    pts : float (K, 2)

    Returns
    -------
    bool (K,)
    """
    pts = np.asarray(pts, np.float64).reshape(-1, 2)
    seg, rr, cc = segment_pixels(q, pts)
    h, w = feasible.shape
    inside = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
    ok = inside & feasible[np.clip(rr, 0, h - 1), np.clip(cc, 0, w - 1)]
    return np.bincount(seg[~ok], minlength=pts.shape[0]) == 0
