"""A coarser grid for the doorway search: the free space at a few map pixels per cell,
and the doorways found there moved back onto the map's pixels."""

from __future__ import annotations

import numpy as np

from ._cuts import make_cuts

__all__ = ["GRID_M", "coarse_free", "fine_cuts", "grid_factor"]

#: Doorways are searched on cells of at most this size (metres): a whole number of map
#: pixels per cell side, one on maps this coarse or coarser.  A door (0.5 m or wider) is
#: still five cells across.
GRID_M = 0.1


def grid_factor(resolution_m: float) -> int:
    """Map pixels per cell side for a map of ``resolution_m`` metres per pixel (>= 1)."""
    return max(1, int(np.floor(GRID_M / resolution_m + 1e-6)))


def coarse_free(free: np.ndarray, f: int) -> np.ndarray:
    """Cells of ``f`` x ``f`` pixels that are free as a whole: bool (ceil(H / f),
    ceil(W / f)); pixels beyond the map count as not free (walls stay closed)."""
    h, w = free.shape
    hf, wf = h // f, w // f
    out = np.zeros((-(-h // f), -(-w // f)), bool)
    whole = out[:hf, :wf]
    whole[:] = free[0 : hf * f : f, 0 : wf * f : f]
    for i in range(f):
        for j in range(f):
            if i or j:
                whole &= free[i : hf * f : f, j : wf * f : f]
    return out


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


def fine_cuts(centres, ends, free: np.ndarray, f: int, widths_px: tuple[float, float]) -> list:
    """Doorway candidates found on cells of ``f`` x ``f`` pixels (centres int64 (N, 2),
    ends int64 (N, 2, 2), in cells), as cuts on the map's pixels: each end the pixel of
    its end cell that is not free nearest to the candidate's centre, the width between the
    two ends, the free pixels of the line joining them.  Cuts whose width falls outside
    ``widths_px`` (pixels, inclusive) or without a free pixel are dropped."""
    if len(centres) == 0:
        return []
    centre = centres * f + (f - 1) / 2.0
    a = _end_pixels(ends[:, 0], free, f, centre)
    b = _end_pixels(ends[:, 1], free, f, centre)
    width = np.hypot(*(b - a).T) - 1.0
    ok = (widths_px[0] <= width) & (width <= widths_px[1])
    centre = np.floor(centre[ok] + 0.5).astype(np.int64)
    return make_cuts(centre, np.stack([a[ok], b[ok]], axis=1), width[ok], free)
