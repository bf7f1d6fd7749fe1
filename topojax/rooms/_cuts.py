"""Doorway candidates: local minima of the clearance along the skeleton, each cut along
the line between its two nearest obstacles."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..graph.work import line_pixels
from ._kernels import basis_points, disc_offsets, sides_widen

__all__ = ["Cut", "door_cuts"]

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
    basis, ok = basis_points(free, p, radius, disc_offsets(float(radius.max())))
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
    p, q1, q2 = p[order], q1[order], q2[order]
    tree = cKDTree(p)
    taken = np.zeros(len(p), bool)
    blocked = np.zeros(len(p), bool)
    for i in range(len(p)):
        if blocked[i]:
            continue
        taken[i] = True
        blocked[tree.query_ball_point(p[i], w, p=np.inf)] = True
    ends = np.stack([q1[taken], q2[taken]], axis=1).astype(np.int64)
    return p[taken].astype(np.int64), ends


def door_cuts(free, clearance, skeleton, cfg, resolution_m: float) -> list[Cut]:
    """Doorway candidates of a map (see :class:`Cut`)."""
    lo = max(cfg.min_door_width_m / resolution_m + 1.0, 1.0) / 2.0
    hi = (cfg.max_door_width_m / resolution_m + 1.0) / 2.0
    w = max(1, int(round(cfg.door_context_m / resolution_m)))
    cuts = []
    centres, ends = _candidates(free, clearance, skeleton, lo, hi, w, DOOR_RISE)
    for p, (q1, q2) in zip(centres, ends, strict=True):
        width = float(np.hypot(*(q2 - q1))) - 1.0
        if not (2 * lo - 1.0 <= width <= 2 * hi - 1.0):
            continue
        line = line_pixels(q1, q2).astype(np.int64)
        inside = (line[:, 0] >= 0) & (line[:, 0] < free.shape[0])
        inside &= (line[:, 1] >= 0) & (line[:, 1] < free.shape[1])
        line = line[inside]
        line = line[free[line[:, 0], line[:, 1]]]
        if line.size == 0:
            continue
        cuts.append(Cut(centre=p, ends=np.stack([q1, q2]), pixels=line, width_px=width))
    return cuts
