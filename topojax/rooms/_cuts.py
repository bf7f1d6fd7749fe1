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


def _candidates(free, clearance, skeleton, lo: float, hi: float, w: int, rise: float):
    """Doorway candidates: skeleton pixels with clearance in [lo, hi] whose two nearest
    obstacles lie on opposite sides and beyond which the clearance rises to ``rise`` times
    theirs on both sides; one per ``w`` neighbourhood (narrowest first).  Returns the
    pixels (N, 2) and their two obstacle pixels (N, 2, 2)."""
    rr, cc = np.nonzero(skeleton & (clearance >= lo) & (clearance <= hi))
    empty = np.empty((0, 2), np.int64), np.empty((0, 2, 2), np.int64)
    if rr.size == 0:
        return empty
    p = np.stack([rr, cc], axis=1).astype(np.int64)
    c = clearance[rr, cc].astype(np.float64)
    radius = 1.3 * c + 1.5
    offsets = disc_offsets(float(radius.max()))
    # every pixel nearer than a point's clearance is free: the search starts beyond
    d2 = (offsets * offsets).sum(axis=1)
    start = np.searchsorted(d2, c * c - 0.5)
    basis, ok = basis_points(free, p, radius, offsets, start)
    p = p.astype(np.float64)
    q1, q2 = basis[:, 0].astype(np.float64), basis[:, 1].astype(np.float64)
    v1, v2 = q1 - p, q2 - p
    n1, n2 = np.hypot(*v1.T), np.hypot(*v2.T)
    cos = np.einsum("ij,ij->i", v1, v2) / np.maximum(n1 * n2, 1e-9)
    ok &= (cos < OPPOSITE_COS) & (n2 <= 1.3 * c + 1.5)
    along = q2 - q1
    normal = np.stack([-along[:, 1], along[:, 0]], axis=1)
    normal /= np.maximum(np.hypot(*normal.T), 1e-9)[:, None]
    ok &= sides_widen(clearance, p, normal, c, float(w), rise)
    if not ok.any():
        return empty
    p, c, q1, q2 = p[ok], c[ok], q1[ok], q2[ok]
    order = np.lexsort((p[:, 1], p[:, 0], c))
    p = p[order].astype(np.int64)
    keep = spaced_out(p, w, free.shape)
    ends = np.stack([q1[order][keep], q2[order][keep]], axis=1).astype(np.int64)
    return p[keep], ends


def clearance_range_px(cfg, resolution_m: float) -> tuple[float, float]:
    """The clearances (pixels) of a doorway of ``cfg``'s smallest and largest width: a gap
    of width ``d`` has clearance ``(d + 1) / 2`` at its middle."""
    lo = max(cfg.min_door_width_m / resolution_m + 1.0, 1.0) / 2.0
    hi = (cfg.max_door_width_m / resolution_m + 1.0) / 2.0
    return lo, hi


def door_candidates(free, clearance, skeleton, cfg, resolution_m: float, slack_px=0.0):
    """Doorway candidates of a map: centres int64 (N, 2) and ends int64 (N, 2, 2) (see
    :class:`Cut`), widths float64 (N,) within ``cfg``'s range; ``slack_px`` widens the
    range by that many pixels of clearance on both sides."""
    lo, hi = clearance_range_px(cfg, resolution_m)
    lo, hi = lo - slack_px, hi + slack_px
    w = max(1, int(round(cfg.door_context_m / resolution_m)))
    centres, ends = _candidates(free, clearance, skeleton, lo, hi, w, DOOR_RISE)
    width = np.hypot(*(ends[:, 1] - ends[:, 0]).T) - 1.0
    ok = (2 * lo - 1.0 <= width) & (width <= 2 * hi - 1.0)
    return centres[ok], ends[ok], width[ok]


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
