"""Exact Euclidean clearance (distance to the nearest obstacle) from the windowed squared
distance, everywhere or at a few pixels."""

from __future__ import annotations

import numpy as np

from .._constants import FAR_SQ
from .._jit import cached_njit

__all__ = [
    "CLEARANCE_RTOL",
    "SPARSE_CLEARANCE_MAX_PX",
    "clearance_at",
    "clearance_at_least",
    "clearance_from_sq_distance",
    "clearance_of_values",
    "distance_transform_px",
    "free_clearance_px",
    "nearest_sq_distance",
]

#: Needed pixels beyond the window that :func:`clearance_from_sq_distance` searches one
#: by one (a square crop each) before it takes the whole map's distance transform instead.
SPARSE_CLEARANCE_MAX_PX = 64

#: Relative slack of a clearance compared with a limit: a clearance is a pixel distance
#: times the resolution, in float32 or float64, and one that equals a limit exactly can
#: round up to 1.5 float32 units in the last place (2**-23 each) below it.  Below the
#: relative gap between neighbouring pixel distances (about 1 / (2 d^2) at d pixels) up
#: to d = 1448 px, so it admits no pixel nearer than the limit short of that.
CLEARANCE_RTOL = 2.0**-22


def clearance_at_least(clearance, limit_m: float):
    """``clearance >= limit_m`` (metres; array or scalar) up to its rounding
    (:data:`CLEARANCE_RTOL`): a robot of radius ``limit_m`` fits at a clearance that
    equals it, whatever the resolution's binary expansion."""
    return clearance >= limit_m * (1.0 - CLEARANCE_RTOL)


def nearest_sq_distance(obstacles, rows, cols, upper_sq, start_px, budget_px):
    """Exact squared distance (px^2, int64) from pixels ``(rows, cols)`` to the nearest
    obstacle, searching squares around each pixel.

    ``upper_sq`` bounds each answer from above (the windowed value: the nearest obstacle
    inside the window is a real one); where it is ``FAR_SQ`` the search starts with a
    square of half-side ``start_px``.  A square of half-side ``s`` holding an obstacle at
    squared distance ``<= s^2`` holds the nearest one (every pixel outside it is farther
    than ``s``).  All first squares are searched together (their bounding box, read
    once); a pixel not settled there doubles its own square.  ``obstacles`` must hold an
    obstacle.  Returns None (gives up) once the squares read hold more than ``budget_px``
    pixels.
    """
    h, w = obstacles.shape
    rows = np.asarray(rows, np.int64)
    cols = np.asarray(cols, np.int64)
    upper = np.asarray(upper_sq, np.int64)
    far = upper >= FAR_SQ
    side = np.where(far, max(1, start_px), np.sqrt(np.where(far, 0, upper)).astype(np.int64) + 2)
    r0, r1 = max(0, int((rows - side).min())), min(h, int((rows + side).max()) + 1)
    c0, c1 = max(0, int((cols - side).min())), min(w, int((cols + side).max()) + 1)
    budget = budget_px - (r1 - r0) * (c1 - c0)
    if budget < 0:
        return None
    ys, xs = np.nonzero(obstacles[r0:r1, c0:c1])
    ys += r0
    xs += c0
    out = np.empty(rows.shape[0], np.int64)
    for i, (r, c, s) in enumerate(zip(rows.tolist(), cols.tolist(), side.tolist(), strict=True)):
        best = int(((ys - r) ** 2 + (xs - c) ** 2).min()) if ys.size else FAR_SQ
        while best > s * s:  # not settled: search a doubled square around this pixel
            s *= 2
            q0, q1 = max(0, r - s), min(h, r + s + 1)
            p0, p1 = max(0, c - s), min(w, c + s + 1)
            budget -= (q1 - q0) * (p1 - p0)
            if budget < 0:
                return None
            qy, qx = np.nonzero(obstacles[q0:q1, p0:p1])
            if qy.size:
                best = int(((qy + (q0 - r)) ** 2 + (qx + (p0 - c)) ** 2).min())
            if q0 == 0 and p0 == 0 and q1 == h and p1 == w:
                if not qy.size:
                    raise ValueError("obstacles holds no obstacle")
                break
        out[i] = best
    return out


def clearance_from_sq_distance(
    sq_distance_px: np.ndarray,
    obstacles: np.ndarray,
    half_width_px: int,
    need: np.ndarray | None = None,
) -> np.ndarray:
    """True Euclidean clearance in pixels from the windowed squared distance.

    The windowed distance equals the Euclidean distance transform wherever it is at most
    the window half-width ``R`` (an obstacle nearer than ``R`` is inside the window).
    Pixels beyond that (only in open maps) are filled in from an exact unwindowed
    transform.

    Parameters
    ----------
    sq_distance_px : int32 (H, W)
        Windowed squared distance, px^2 (``FAR_SQ`` where the window has no obstacle).
    obstacles : bool (H, W)
    half_width_px : int
        Window half-width ``R``.
    need : bool (H, W), optional
        If given, only these pixels must be exact (other pixels beyond ``R`` then keep the
        windowed value).  A few of them beyond ``R`` are searched one by one; more take
        the unwindowed transform of the whole map.  Default: every pixel is exact.

    Returns
    -------
    float32 (H, W): clearance in pixels, ``inf`` everywhere when there are no obstacles.
    Within ``R`` it is the square root of the exact integer distance; beyond ``R`` it is
    that too at a few needed pixels, otherwise OpenCV's exact transform in float32
    (which can differ by one ulp between calls).
    """
    d2 = sq_distance_px
    clearance = d2.astype(np.float32)
    np.sqrt(clearance, out=clearance)
    r2 = half_width_px * half_width_px
    if d2.size == 0 or d2.max() <= r2:
        return clearance
    if not obstacles.any():
        clearance.fill(np.inf)
        return clearance
    if need is not None:
        flat = np.flatnonzero(need)  # sparse (ridge pixels): test d2 there only
        flat = flat[d2.ravel()[flat] > r2]
        if flat.size:
            clearance.ravel()[flat] = clearance_at(d2, obstacles, half_width_px, flat)
        return clearance
    np.copyto(clearance, _unwindowed_clearance(obstacles), where=d2 > r2)
    return clearance


def clearance_at(
    sq_distance_px: np.ndarray, obstacles: np.ndarray, half_width_px: int, flat: np.ndarray
) -> np.ndarray:
    """True Euclidean clearance in pixels at some pixels only.

    Same values as :func:`clearance_from_sq_distance` at those pixels, without touching
    the rest of the map (the graph step needs the skeleton's pixels only).

    Parameters
    ----------
    sq_distance_px, obstacles, half_width_px : see :func:`clearance_from_sq_distance`
    flat : int array (n,)
        Flat (raster) indices of the pixels, ``row * W + col``.

    Returns
    -------
    float32 (n,): clearance in pixels (``inf`` where the map has no obstacle at all).
    """
    flat = np.asarray(flat, np.intp)
    return clearance_of_values(sq_distance_px.ravel()[flat], obstacles, half_width_px, flat)


def clearance_of_values(
    sq_values: np.ndarray, obstacles: np.ndarray, half_width_px: int, flat: np.ndarray
) -> np.ndarray:
    """:func:`clearance_at` from the windowed squared distance at those pixels only.

    Parameters
    ----------
    sq_values : int (n,)
        Windowed squared distance at the pixels ``flat``, px^2 (``FAR_SQ``: no obstacle
        in the window), e.g. kept at the ridge pixels only
        (:func:`topojax.fields.dense.ridge_fields`).
    obstacles, half_width_px : see :func:`clearance_from_sq_distance`
    flat : int array (n,)
        Flat (raster) indices of the pixels, ``row * W + col``.

    Returns
    -------
    float32 (n,): as :func:`clearance_at`.
    """
    flat = np.asarray(flat, np.intp)
    d2 = np.asarray(sq_values)
    out = np.sqrt(d2.astype(np.float32))
    far = np.flatnonzero(d2 > half_width_px * half_width_px)
    if far.size == 0:
        return out
    if not obstacles.any():
        out[far] = np.inf
        return out
    rows, cols = np.divmod(flat[far], obstacles.shape[1])
    exact = None
    if far.size <= SPARSE_CLEARANCE_MAX_PX:
        # searching more than twice the map would cost more than its transform
        exact = nearest_sq_distance(
            obstacles, rows, cols, d2[far], 2 * half_width_px, 2 * obstacles.size
        )
    if exact is not None:
        out[far] = np.sqrt(exact.astype(np.float32))
    else:
        out[far] = _unwindowed_clearance(obstacles)[rows, cols]
    return out


def _unwindowed_clearance(obstacles: np.ndarray) -> np.ndarray:
    """OpenCV's exact Euclidean distance transform (float32, px) of a map with obstacles."""
    return distance_transform_px((~obstacles).view(np.uint8))


def free_clearance_px(free: np.ndarray) -> np.ndarray:
    """Distance (pixels, float32 (H, W)) from each pixel centre to the nearest pixel
    centre that is not ``free``, the map's outside counting as not free; 0 off ``free``
    (OpenCV's exact Euclidean transform)."""
    padded = np.zeros((free.shape[0] + 2, free.shape[1] + 2), np.uint8)
    padded[1:-1, 1:-1] = free
    return distance_transform_px(padded)[1:-1, 1:-1]


def distance_transform_px(mask: np.ndarray) -> np.ndarray:
    """OpenCV's exact Euclidean distance transform of ``mask`` (uint8 or bool (H, W)):
    the distance (pixels, float32 (H, W)) from each pixel centre to the nearest zero
    pixel, the same bits on every call, machine and thread count.

    OpenCV rounds some distances a unit in the last place apart with the output's
    address modulo 32 bytes (its vectorised pass) and with the number of threads it runs
    on (one thread against several).  Every distance is the square root of a whole
    number of squared pixels, so each is rounded to that number and its root taken again:
    the float32 nearest the exact distance, up to about 2000 pixels (beyond that a float32
    distance no longer tells neighbouring whole numbers apart).  The output starts on a
    64-byte boundary.
    """
    import cv2

    mask = mask.view(np.uint8) if mask.dtype == bool else mask
    h, w = mask.shape
    raw = np.empty(h * w * 4 + _ALIGN_BYTES, np.uint8)
    skip = -raw.ctypes.data % _ALIGN_BYTES
    out = raw[skip : skip + h * w * 4].view(np.float32).reshape(h, w)
    cv2.distanceTransform(mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE, dst=out)
    _round_to_roots(out.reshape(-1))
    return out


_ALIGN_BYTES = 64


@cached_njit(nogil=True)
def _round_to_roots(flat):
    """Each distance (float32, in place) replaced by the root of the whole number nearest
    its square, in float64."""
    for i in range(flat.size):
        d = np.float64(flat[i])
        flat[i] = np.float32(np.sqrt(np.floor(d * d + 0.5)))
