"""Doorway candidates: local minima of the clearance along the skeleton, each cut along
the line between its two nearest obstacles."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._kernels import basis_points, disc_offsets, draw_lines, sides_widen, spaced_out

__all__ = ["Cut", "clearance_range_px", "door_candidates", "make_cuts"]

#: Along the skeleton, the clearance on both sides of a doorway rises to at least this
#: many times the doorway's (a branch into a corner only falls).
DOOR_RISE = 1.1
#: The two nearest obstacles of a doorway lie on opposite sides of it: the angle between
#: them, seen from the doorway, is above 120 deg (a room corner's is about 90).
OPPOSITE_COS = -0.5
#: On cells, a clearance is known to within about half a cell: doorway candidates are
#: looked for in a clearance range this many cells wider on both sides than
#: ``RoomConfig``'s (their width on the pixels must lie in it), and the clearance beyond
#: them need only rise to ``DOOR_RISE`` times theirs less this many cells.
CELL_SLACK = 0.5


@dataclass(frozen=True, eq=False)
class Cut:
    """One doorway candidate.

    Attributes
    ----------
    centre : int64 (2,)
        Skeleton pixel (row, col) where the clearance is locally smallest (found on
        cells: the pixel nearest to that cell's centre).
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


def _candidates(free, clearance, skeleton, lo, hi, w: int, rise: float, slack: float = 0.0):
    """Doorway candidates: skeleton pixels with clearance in [lo - slack, hi + slack]
    whose two nearest obstacles lie on opposite sides and beyond which the clearance rises
    to ``rise`` times theirs, less ``slack``, on both sides (looked for out to ``w``
    pixels).  Returns the pixels int64
    (N, 2), their clearances float64 (N,) and their two obstacle pixels int64 (N, 2, 2)."""
    rr, cc = np.nonzero(skeleton & (clearance >= lo - slack) & (clearance <= hi + slack))
    p = np.stack([rr, cc], axis=1).astype(np.int64)
    c = clearance[rr, cc].astype(np.float64)
    if rr.size == 0:
        return p, c, np.empty((0, 2, 2), np.int64)
    radius = 1.3 * c + 1.5
    offsets = disc_offsets(float(radius.max()))
    # every pixel nearer than a point's clearance is free: the search starts beyond
    d2 = (offsets * offsets).sum(axis=1)
    start = np.searchsorted(d2, c * c - 0.5)
    basis, ok = basis_points(free, p, radius, offsets, start)
    pf = p.astype(np.float64)
    q1, q2 = basis[:, 0].astype(np.float64), basis[:, 1].astype(np.float64)
    v1, v2 = q1 - pf, q2 - pf
    n1, n2 = np.hypot(*v1.T), np.hypot(*v2.T)
    cos = np.einsum("ij,ij->i", v1, v2) / np.maximum(n1 * n2, 1e-9)
    ok &= (cos < OPPOSITE_COS) & (n2 <= 1.3 * c + 1.5)
    along = q2 - q1
    normal = np.stack([-along[:, 1], along[:, 0]], axis=1)
    normal /= np.maximum(np.hypot(*normal.T), 1e-9)[:, None]
    ok &= sides_widen(clearance, pf, normal, rise * c - slack, float(w))
    return p[ok], c[ok], basis[ok]


def clearance_range_px(cfg, resolution_m: float) -> tuple[float, float]:
    """The clearances (pixels) of a doorway of ``cfg``'s smallest and largest width: a gap
    of width ``d`` has clearance ``(d + 1) / 2`` at its middle."""
    lo = max(cfg.min_door_width_m / resolution_m + 1.0, 1.0) / 2.0
    hi = (cfg.max_door_width_m / resolution_m + 1.0) / 2.0
    return lo, hi


def _end_pixels(cells: np.ndarray, free: np.ndarray, f: int, towards: np.ndarray) -> np.ndarray:
    """For each cell (row, col) of ``cells`` int64 (N, 2), its pixel that is not free (or
    beyond the map) nearest to ``towards[i]`` (row, col, float64 (N, 2)); int64 (N, 2)."""
    h, w = free.shape
    dr, dc = np.divmod(np.arange(f * f), f)
    rr = cells[:, :1] * f + dr[None, :]
    cc = cells[:, 1:] * f + dc[None, :]
    inside = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
    blocked = ~inside
    blocked[inside] = ~free[rr[inside], cc[inside]]
    blocked[~blocked.any(axis=1)] = True  # cannot happen for a cell that is not free
    d2 = (rr - towards[:, :1]) ** 2 + (cc - towards[:, 1:]) ** 2
    k = np.argmin(np.where(blocked, d2, np.inf), axis=1)
    pick = np.arange(len(cells))
    return np.stack([rr[pick, k], cc[pick, k]], axis=1)


def door_candidates(free, cells, clearance, skeleton, f: int, cfg, resolution_m: float, map_box):
    """Doorway candidates of a map, one per ``door_context_m`` neighbourhood, narrowest
    first: centres int64 (N, 2), ends int64 (N, 2, 2) (see :class:`Cut`) and widths
    float64 (N,) (pixels) within ``cfg``'s range, both ends on the map's pixels
    ``map_box`` ``(row0, col0, row1, col1)``, end-exclusive, in ``free``'s pixels (a gap
    between a wall and the map's edge is no doorway).

    ``cells``, ``clearance`` and ``skeleton`` are those of the free space on cells of
    ``f`` x ``f`` pixels (``cells`` is ``free`` when ``f`` is 1).  On cells, a gap's width
    is the pixels' to within a cell or so: candidates are looked for in a range widened by
    :data:`CELL_SLACK` cells, with the rise on both sides lowered by as much, then moved to
    the pixels (each end the pixel of its end cell that is not free nearest to the centre)
    and held to the width range there.
    """
    # lengths beyond the map's extent (pixels) mean the whole map; capped, they stay
    # within the integers and floats the kernels take
    extent = float(sum(free.shape))
    lo, hi = (min(v, extent) for v in clearance_range_px(cfg, resolution_m))
    w = max(1, int(round(min(cfg.door_context_m / resolution_m, extent))))
    if f == 1:
        # a gap of an even number d of pixels has clearance d / 2 at its middle, half a
        # pixel less than ``(d + 1) / 2``: its width is held to the range below
        p, c, ends = _candidates(free, clearance, skeleton, lo - 0.5, hi, w, DOOR_RISE)
    else:
        clo, chi = (min(v, extent) for v in clearance_range_px(cfg, resolution_m * f))
        wc = max(1, int(round(min(cfg.door_context_m / (resolution_m * f), extent))))
        p, c, ends = _candidates(cells, clearance, skeleton, clo, chi, wc, DOOR_RISE, CELL_SLACK)
        centre = p * f + (f - 1) / 2.0
        a = _end_pixels(ends[:, 0], free, f, centre)
        b = _end_pixels(ends[:, 1], free, f, centre)
        p = np.floor(centre + 0.5).astype(np.int64)
        ends = np.stack([a, b], axis=1)
    width = np.hypot(*(ends[:, 1] - ends[:, 0]).T) - 1.0
    ok = (2 * lo - 1.0 <= width) & (width <= 2 * hi - 1.0)
    # a gap between a wall and the map's edge is where the map stops, not a doorway
    lo_px, hi_px = np.asarray(map_box[:2]), np.asarray(map_box[2:])
    ok &= ((ends >= lo_px) & (ends < hi_px)).all(axis=(1, 2))
    p, c, ends, width = p[ok], c[ok], ends[ok], width[ok]
    # narrowest first: the clearance at the centre, on cells the half-width on the pixels
    key = c if f == 1 else (width + 1.0) / 2.0
    order = np.lexsort((p[:, 1], p[:, 0], key))
    keep = order[spaced_out(p[order], w, free.shape)]
    return p[keep], ends[keep], width[keep]


def make_cuts(centres, ends, widths, free) -> list[Cut]:
    """The cuts of doorway candidates: the free pixels of the line between the two ends
    of each; those without a free pixel are dropped."""
    pixels, starts = draw_lines(ends[:, 0].copy(), ends[:, 1].copy(), free)
    out = []
    for i in range(len(centres)):
        if starts[i + 1] > starts[i]:
            out.append(
                Cut(
                    centre=centres[i],
                    ends=ends[i],
                    pixels=pixels[starts[i] : starts[i + 1]],
                    width_px=float(widths[i]),
                )
            )
    return out
