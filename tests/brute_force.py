"""Independent brute-force references shared by the test modules."""

from __future__ import annotations

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
