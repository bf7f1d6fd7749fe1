"""Values kept at the ridge pixels of a map only (raster order), instead of an image-sized
array: their assembly from the kernel's tiles and their lookup at chosen ridge pixels.

The CPU stages read the windowed squared distance only at skeleton pixels, a subset of
the ridge pixels, so the full-map pipeline keeps it at ridge pixels only
(:func:`topojax.fields.dense.ridge_fields`): 4 bytes per ridge pixel instead of 4 bytes
per pixel.
"""

from __future__ import annotations

import numpy as np

from .._jit import cached_njit

__all__ = ["at_ridge_pixels", "ridge_ranks", "tiles_to_raster"]


@cached_njit(nogil=True)
def tiles_to_raster(ridges, tile_px, values, offsets):
    """Reorder values given tile by tile into the raster order of the ridge pixels.

    Parameters
    ----------
    ridges : bool (H, W)
        Ridge map.
    tile_px : int
        Tile side; tiles are numbered row by row (``tile row * tile cols + tile col``).
    values : (n,) array
        The values of tile 0's ridge pixels (raster order inside the tile), then tile 1's,
        ...; ``n`` is the number of ridge pixels.
    offsets : int64 (n_tiles + 1,)
        Where each tile's values start in ``values``.

    Returns
    -------
    (n,) array of ``values``' dtype: the values in the order of ``np.flatnonzero(ridges)``.
    """
    h, w = ridges.shape
    tile_cols = (w + tile_px - 1) // tile_px
    out = np.empty(values.shape[0], values.dtype)
    read = np.empty(tile_cols, np.int64)
    k = 0
    for r in range(h):
        if r % tile_px == 0:
            first = (r // tile_px) * tile_cols
            for tc in range(tile_cols):
                read[tc] = offsets[first + tc]
        for tc in range(tile_cols):
            p = read[tc]
            for c in range(tc * tile_px, min(w, (tc + 1) * tile_px)):
                if ridges[r, c]:
                    out[k] = values[p]
                    p += 1
                    k += 1
            read[tc] = p
    return out


@cached_njit(nogil=True)
def ridge_ranks(ridges_flat, flat):
    """Rank of each pixel among the ridge pixels: the number of ridge pixels before it.

    Parameters
    ----------
    ridges_flat : uint8 or bool (H * W,)
        The ridge map, raveled.
    flat : int (m,)
        Flat indices, increasing.

    Returns
    -------
    int64 (m,)
    """
    out = np.empty(flat.shape[0], np.int64)
    count = 0
    p = 0
    for i in range(flat.shape[0]):
        f = flat[i]
        while p < f:
            count += 1 if ridges_flat[p] else 0
            p += 1
        out[i] = count
    return out


def at_ridge_pixels(ridges: np.ndarray, values: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """Values kept at the ridge pixels, read at some of them.

    Parameters
    ----------
    ridges : bool (H, W)
        Ridge map.
    values : (n,) array
        One value per ridge pixel, in the order of ``np.flatnonzero(ridges)``.
    flat : int (m,)
        Flat indices of ridge pixels, increasing.

    Returns
    -------
    (m,) array of ``values``' dtype.
    """
    flat = np.asarray(flat)
    if flat.size == 0:
        return values[:0].copy()
    if not ridges.flags.c_contiguous:
        ridges = np.ascontiguousarray(ridges)
    return values[ridge_ranks(ridges.reshape(-1), flat)]
