"""Dense exports of the mapper's tiles: the exported bounding box (with the export memory
budget), a layer read over it, the occupancy map of a pixel box and the Gaussian distance
map.
"""

from __future__ import annotations

import numpy as np

from .._validate import pose
from ..fields.distance import FAR_SQ
from ._rays import cast_pending_rays
from ._ridges import _gaussian
from ._tiles import check_export_budget


def export_bbox(mapper, what: str | None = None) -> tuple[int, int, int, int]:
    """The exported bounding box ``(row0, col0, row1, col1)`` (global pixels, end
    exclusive); with ``what``, the export's memory budget checked
    (:func:`check_export_budget`) first.  Raises ValueError while the mapper is empty."""
    bbox = mapper._tiles.pixel_bbox
    if bbox is None:
        raise ValueError("the mapper is empty: add scans with valid readings before exporting maps")
    if what is not None:
        check_export_budget(mapper, what, bbox)
    return bbox


def dense_layer(mapper, name: str, what: str | None = None) -> np.ndarray:
    """Tile layer ``name`` over the exported bounding box, shape (H, W) (the layer's
    dtype); ``what`` as in :func:`export_bbox`."""
    r0, c0, r1, c1 = export_bbox(mapper, what)
    return mapper._tiles.read(name, r0, c0, r1 - r0, c1 - c0)


def lattice_origin(resolution_m: float, row1: int, col0: int) -> tuple[float, float, float]:
    """Origin ``(x_m, y_m, yaw_rad)`` of the exported map of a global pixel box with bottom
    row ``row1 - 1`` and left column ``col0``: its pixel centres at the lattice's world
    coordinates (``x = (col + 0.5) r``, ``y = -(row + 0.5) r`` for resolution ``r``)."""
    return pose("origin", (col0 * resolution_m, -row1 * resolution_m, 0.0))


def occupancy_over(mapper, r0: int, c0: int, r1: int, c1: int):
    """The :class:`~topojax.maps.OccupancyMap` of the global pixel box ``[r0, r1) x
    [c0, c1)``: hit pixels occupied, pixels crossed by a beam and never hit free, the
    rest unknown; pending free cells are counted first."""
    from ..maps import OccupancyMap

    cast_pending_rays(mapper)
    tiles = mapper._tiles
    h, w = r1 - r0, c1 - c0
    occupied = tiles.read("hits", r0, c0, h, w) > 0
    free = (tiles.read("misses", r0, c0, h, w) > 0) & ~occupied
    res = mapper.resolution_m
    return OccupancyMap(
        occupied=occupied,
        free=free,
        unknown=~(occupied | free),
        resolution_m=res,
        origin=lattice_origin(res, r1, c0),
    )


def distance_map(mapper) -> np.ndarray:
    """Gaussian distance map ``H``, float32 (H, W) in [0, 1], over the exported bounding
    box, from the tiles' squared distances as they are (splat first)."""
    r0, c0, r1, c1 = export_bbox(mapper)
    tiles = mapper._tiles
    n, t = tiles.n_tiles, mapper.tile_px
    d2 = tiles.layer("sq_distance")
    h = np.empty((n, t, t), np.float32)
    chunk = 16  # tiles per kernel call: one fixed shape, one compilation
    for s in range(0, n, chunk):
        block = d2[s : s + chunk]
        if block.shape[0] < chunk:
            pad = np.full((chunk - block.shape[0], t, t), FAR_SQ, np.int32)
            block = np.concatenate([block, pad])
        h[s : s + chunk] = np.asarray(_gaussian(block, mapper._scalars[0]))[: n - s]
    out = np.zeros((r1 - r0, c1 - c0), np.float32)
    for slot, (tr, tc) in enumerate(tiles.keys):
        out[tr * t - r0 : (tr + 1) * t - r0, tc * t - c0 : (tc + 1) * t - c0] = h[slot]
    return out
