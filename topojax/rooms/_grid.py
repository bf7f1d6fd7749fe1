"""A coarser grid for the doorway search: the free space at a few map pixels per cell."""

from __future__ import annotations

import numpy as np

__all__ = ["GRID_M", "coarse_free", "grid_factor"]

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
    out[:hf, :wf] = free[: hf * f, : wf * f].reshape(hf, f, wf, f).all(axis=(1, 3))
    return out
