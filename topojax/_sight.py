"""Sight lines over a pixel grid: every pixel a straight segment passes through.

Pixel ``(r, c)`` is the square ``[r - 1/2, r + 1/2) x [c - 1/2, c + 1/2)``.  A segment
*passes through* a pixel when a piece of it of positive length lies inside the square,
or, for a piece along a pixel border, on the pixel its points round to (halves up); its
two ends pass through the pixels they round to (as a query point's pixel is found).  A
segment through a pixel corner thus passes through the two pixels it runs between, not
the two beside the corner: the rule of an 8-connected diagonal step, symmetric in the
segment's direction.  The viewer's router (``view/static/route.js``) walks the same
pixels with the same arithmetic.
"""

from __future__ import annotations

import numpy as np

__all__ = ["segment_pixels", "sees"]


def segment_pixels(
    q: np.ndarray, pts: np.ndarray, window: int | None = None, *, at_end: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pixels each segment from ``q`` to a point of ``pts`` passes through.

    Parameters
    ----------
    q : float (2,)
        The common end, ``(row, col)`` in pixels.
    pts : float (K, 2)
        The other ends.
    window : int, optional
        Only the pixels at most this many rows and columns from ``q``'s pixel (the same
        ones the whole segment passes through there); default all.
    at_end : bool
        With ``window``: from each segment's other end's pixel instead.

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
    j0 = np.zeros_like(n_rows)  # the rows kept: j0 .. j0 + n_keep - 1 of each segment
    n_keep = n_rows
    if window is not None:  # the rows within the window of the centre's row
        q_row = np.floor(v0 if at_end else u0)
        j0 = np.maximum(q_row - window - r_lo, 0).astype(np.int64)
        n_keep = np.maximum(np.minimum(n_rows - 1, q_row + window - r_lo) - j0 + 1, 0)
        n_keep = n_keep.astype(np.int64)
    # the column where each segment starts, crosses into each next row, and ends
    n_x = n_keep + 1
    first = np.cumsum(n_x) - n_x
    seg_x = np.repeat(np.arange(pts.shape[0]), n_x)
    local = np.arange(seg_x.size) - first[seg_x]
    j = local + j0[seg_x]
    # divided last: a crossing on a pixel corner, with ends in binary fractions, is exact
    x = a1[seg_x] + ((r_lo[seg_x] + j - a0[seg_x]) * d1[seg_x]) / d0[seg_x]
    x = np.where(j == 0, a1[seg_x], np.where(j == n_rows[seg_x], b1[seg_x], x))
    at = np.flatnonzero(local < n_keep[seg_x])
    seg, row = seg_x[at], j[at]
    # row j of a segment runs from x[j] to x[j + 1]: the pixels whose open column range
    # it meets, or the one its column rounds to where it runs along a border
    lo_x, hi_x = np.minimum(x[at], x[at + 1]), np.maximum(x[at], x[at + 1])
    lo = np.floor(lo_x)
    hi = np.where(hi_x > lo_x, np.ceil(hi_x) - 1, np.floor(hi_x))
    for here, end in ((row == 0, a1), (row == n_rows[seg] - 1, b1)):  # the ends' pixels
        fe = np.floor(end[seg])
        lo, hi = np.where(here, np.minimum(lo, fe), lo), np.where(here, np.maximum(hi, fe), hi)
    if window is not None:  # the columns within the window of the centre's column
        q_col = np.floor(v1[seg] if at_end else u1)
        lo, hi = np.maximum(lo, q_col - window), np.minimum(hi, q_col + window)
    lo = lo.astype(np.int64)
    n_cols = np.maximum(hi.astype(np.int64) - lo + 1, 0)
    k = np.repeat(np.arange(at.size), n_cols)
    cols = lo[k] + np.arange(k.size) - np.repeat(np.cumsum(n_cols) - n_cols, n_cols)
    return seg[k], (r_lo[seg] + row).astype(np.int64)[k], cols


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
    q = np.asarray(q, np.float64)
    length = np.abs(pts - q).max(axis=1)
    seen = np.ones(pts.shape[0], bool)
    todo = np.arange(pts.shape[0])
    # the pixels near either end first: a long line blocked there (most, in a cluttered
    # map) is not walked whole
    for window, at_end in _WINDOWS:
        long = todo[length[todo] > max(2 * window, _SHORT)]
        if long.size == 0:  # the windows grow: no line is long for the next either
            break
        seen[long[~_clear(feasible, q, pts[long], window, at_end)]] = False
        todo = todo[seen[todo]]
    seen[todo[~_clear(feasible, q, pts[todo], None, False)]] = False
    return seen


#: The windows (pixels from the query's pixel, or from the line's other end) a sight
#: line is checked within before it is walked whole.
_WINDOWS = tuple((w, at_end) for w in (4, 16, 64, 256) for at_end in (False, True))

#: Lines at most this many pixels long are walked whole at once.
_SHORT = 64


def _clear(feasible: np.ndarray, q: np.ndarray, pts: np.ndarray, window, at_end: bool):
    """Whether each segment's pixels within ``window`` of ``q``'s (or, ``at_end``, its
    other end's) are set in ``feasible`` (bool (K,); off the grid counts as unset)."""
    seg, rr, cc = segment_pixels(q, pts, window, at_end=at_end)
    h, w = feasible.shape
    inside = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
    ok = inside & feasible[np.clip(rr, 0, h - 1), np.clip(cc, 0, w - 1)]
    return np.bincount(seg[~ok], minlength=pts.shape[0]) == 0
