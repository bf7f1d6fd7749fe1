"""Exact clearance at a few pixels read from the mapper's tiles: the windowed squared
distance at those pixels and, beyond the window, a search for the nearest obstacle pixel
in the tiles around each, as :func:`topojax.pipeline.clearance_at` gives it on the dense
maps of the bounding box.
"""

from __future__ import annotations

import numpy as np

from ..fields.distance import FAR_SQ
from ..fields.tiling import unique_pairs
from ._tiles import _gather_px


def pixel_clearance_m(mapper, pixels: np.ndarray) -> np.ndarray:
    """Exact clearance at global pixels of allocated tiles, read from the tiles.

    Parameters
    ----------
    mapper : IncrementalMapper
        Its squared distances are taken as they are (splat first for current ones).
    pixels : int (n, 2)
        Global ``(row, col)`` lattice pixels.

    Returns
    -------
    float64 (n,)
        Clearance in metres: :func:`topojax.pipeline.clearance_at` of the dense squared
        distance and obstacle mask over the bounding box at these pixels, bit for bit up
        to about 2000 pixels from the nearest obstacle (farther, the exact root, which
        ``clearance_at``'s rounded OpenCV transform may miss by a unit in the last
        place); ``inf`` where the map has no obstacle at all.
    """
    tiles = mapper._tiles
    grid, (g0r, g0c) = tiles.slot_grid
    rows = np.ascontiguousarray(pixels[:, 0], np.int64)
    cols = np.ascontiguousarray(pixels[:, 1], np.int64)
    d2 = np.empty(rows.shape[0], np.int32)
    layer = tiles.layer("sq_distance")
    _gather_px(layer, grid, g0r, g0c, mapper.tile_px, rows, cols, FAR_SQ, d2)
    out = np.sqrt(d2.astype(np.float32))
    # beyond the window half-width the windowed value is an upper bound only
    half = mapper._half
    far = np.flatnonzero(d2 > half * half)
    if far.size:
        sq = nearest_obstacle_sq(tiles, rows[far], cols[far], d2[far], 2 * half)
        root = np.sqrt(np.maximum(sq, 0).astype(np.float32))
        out[far] = np.where(sq < 0, np.float32(np.inf), root)
    return out.astype(np.float64) * mapper.resolution_m


def nearest_obstacle_sq(
    tiles, rows: np.ndarray, cols: np.ndarray, upper_sq: np.ndarray, start_px: int
) -> np.ndarray:
    """Exact squared distance (px^2, int64 (n,)) from global pixels ``(rows, cols)`` to
    the nearest obstacle pixel (hit) of the tiles; -1 where the tiles hold none.

    The square of half-side ``s`` around a pixel holds every pixel within ``s``: where
    ``upper_sq`` (int (n,), px^2) bounds the answer (below ``FAR_SQ``) the square of
    half-side ``sqrt(upper_sq)`` holds the nearest obstacle; elsewhere the search starts
    with half-side ``start_px`` and doubles it until the square holds an obstacle at
    most ``s`` away, or every tile.  Only the tiles meeting the squares are read.
    """
    n = rows.shape[0]
    out = np.full(n, -1, np.int64)
    bound = upper_sq < FAR_SQ
    side = np.where(bound, np.sqrt(np.where(bound, upper_sq, 0)).astype(np.int64) + 1, start_px)
    todo = np.arange(n)
    while todo.size:
        slots = slots_near(tiles, rows[todo], cols[todo], side[todo])
        every = slots.shape[0] == tiles.n_tiles
        sq = _nearest_sq_among(_obstacle_pixels(tiles, slots), rows[todo], cols[todo])
        settled = every | ((sq >= 0) & (sq <= side[todo] ** 2))
        out[todo[settled]] = sq[settled]
        todo = todo[~settled]
        side[todo] *= 2
    return out


def slots_near(
    tiles, rows: np.ndarray, cols: np.ndarray, side: np.ndarray, max_cells: int = 1 << 20
) -> np.ndarray:
    """Slots (int64, sorted) of the allocated tiles that meet the square of half-side
    ``side`` around some pixel ``(rows, cols)``; every slot where the squares span more
    than ``max_cells`` tile cells together (the tiles are then read whole)."""
    t = tiles.tile_px
    tr0, tr1 = (rows - side) // t, (rows + side) // t
    tc0, tc1 = (cols - side) // t, (cols + side) // t
    span_r, span_c = int((tr1 - tr0).max()) + 1, int((tc1 - tc0).max()) + 1
    if rows.shape[0] * span_r * span_c > max(max_cells, tiles.n_tiles):
        return np.arange(tiles.n_tiles)
    shape = (rows.shape[0], span_r, span_c)
    tr = np.broadcast_to((tr0[:, None] + np.arange(span_r))[:, :, None], shape)
    tc = np.broadcast_to((tc0[:, None] + np.arange(span_c))[:, None, :], shape)
    keep = (tr <= tr1[:, None, None]) & (tc <= tc1[:, None, None])
    pairs = unique_pairs(tr[keep], tc[keep])
    slots = tiles.lookup(pairs[:, 0], pairs[:, 1])
    return np.sort(slots[slots >= 0])


def _obstacle_pixels(tiles, slots: np.ndarray, chunk: int = 256) -> np.ndarray:
    """Global ``(row, col)`` of every obstacle pixel (hit count > 0) of the tiles in
    ``slots``, int64 (k, 2); read ``chunk`` tiles at a time."""
    hits = tiles.layer("hits")
    keys = tiles.keys
    t = tiles.tile_px
    parts = [np.zeros((0, 2), np.int64)]
    for s in range(0, slots.shape[0], chunk):
        some = slots[s : s + chunk]
        i, lr, lc = np.nonzero(hits[some] > 0)
        key = keys[some[i]]
        parts.append(np.stack([key[:, 0] * t + lr, key[:, 1] * t + lc], axis=1))
    return np.concatenate(parts)


def _nearest_sq_among(obstacles: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Squared distance (px^2, int64 (n,)) from each pixel to the nearest of the
    ``obstacles`` (int64 (k, 2)), exact; -1 everywhere when there are none."""
    if obstacles.shape[0] == 0:
        return np.full(rows.shape[0], -1, np.int64)
    from scipy.spatial import cKDTree  # imported here: slow to import, rarely needed

    # offsets from one obstacle: squared differences stay whole numbers exact in float64
    base = obstacles[0]
    tree = cKDTree((obstacles - base).astype(np.float64))
    query = np.stack([rows - base[0], cols - base[1]], axis=1).astype(np.float64)
    dist, _ = tree.query(query)
    return np.rint(dist * dist).astype(np.int64)
