"""One block of a map larger than memory: its skeleton pixels and their windowed squared
distances, computed from a window around the block and proved equal to the whole map's.

The map is cut into square blocks of ``block_px`` (a multiple of the kernel tile side).
For one block the stages read a window of ``halo_px`` more on each side (clipped to the
map; ``halo_px`` a multiple of the tile side, so the kernels' tiles fall where they fall on
the whole map):

1. the distance and ridge kernels (:func:`topojax.fields.ridge_fields`) run on the window.
   The windowed distance at a pixel reads obstacles within ``R = half_width_px`` of it and
   the Laplacian two pixels more, so the ridges and squared distances are exact at least
   ``R + 2`` pixels inside the window (and up to the map's own edges);
2. the exact ridges around the block, ``halo_px - R - 2`` pixels on each side, are thinned
   and cleared of T centres by :mod:`topojax.outofcore.exact`, which proves that the
   block's pixels come out as in the whole map's skeleton, or says that they may not; the
   caller then asks again with a larger halo.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from ..config import PipelineConfig
from ..fields import HALO_PX, ridge_fields
from ..fields.ridge_values import at_ridge_pixels
from ..maps.tiled import TiledMap
from .exact import exact_after_t_removal, remove_t_in_map_order, thin_window

__all__ = ["BlockPiece", "block_piece", "fields_halo_px", "window_box", "window_digest"]


@dataclass(frozen=True)
class BlockPiece:
    """What one block contributes to the graph.

    Attributes
    ----------
    box : (r0, r1, c0, c1)
        The block, in map pixels.
    flat : int64 (n,)
        Flat indices ``row * W + col`` of the block's skeleton pixels, increasing.
    sq_distance_px : int32 (n,)
        Windowed squared distance at those pixels, px^2.
    occupied_px : int
        Occupied pixels in the block.
    halo_px : int
        The halo the proof needed (None when it failed: ``flat`` is then empty).
    sub_iterations : int
        Thinning sub-iterations the window ran.
    window_digest : bytes or None
        Digest of the map window read (:func:`window_digest`), when asked for.
    """

    box: tuple[int, int, int, int]
    flat: np.ndarray
    sq_distance_px: np.ndarray
    occupied_px: int
    halo_px: int | None
    sub_iterations: int
    window_digest: bytes | None = None


def fields_halo_px(config: PipelineConfig) -> int:
    """Pixels beyond a pixel that its ridge and squared distance read: ``R + 2``."""
    return config.distance.half_width_px + HALO_PX


def window_box(box, pad: int, shape) -> tuple[int, int, int, int]:
    """Block ``box`` ``(r0, r1, c0, c1)`` grown by ``pad`` pixels on each side, clipped to
    a map of ``shape``."""
    r0, r1, c0, c1 = box
    h, w = shape
    return max(0, r0 - pad), min(h, r1 + pad), max(0, c0 - pad), min(w, c1 + pad)


def window_digest(codes: np.ndarray) -> bytes:
    """A 16-byte digest of a map window (its class codes, uint8 (h, w)) and its shape."""
    data = np.ascontiguousarray(codes, dtype=np.uint8)
    shape = np.array(data.shape, np.int64).tobytes()
    return hashlib.blake2b(shape + data.tobytes(), digest_size=16).digest()


def block_piece(
    tiled: TiledMap,
    box,
    config: PipelineConfig,
    halo_px: int,
    threads: int | None = None,
    digest: bool = False,
) -> BlockPiece:
    """The skeleton pixels of block ``box`` with a halo of ``halo_px`` (see the module);
    with ``digest``, the piece carries the digest of the map window it read.

    ``halo_px - fields_halo_px(config)`` pixels of exact ridges are thinned around the
    block; when that is too few to prove the block's pixels exact, the piece has
    ``halo_px`` None and no pixels.
    """
    h, w = tiled.shape
    r0, r1, c0, c1 = box
    f0, f1, g0, g1 = window_box(box, halo_px, (h, w))  # the kernels' window
    codes = tiled.codes(f0, f1, g0, g1)
    seen = window_digest(codes) if digest else None
    occupied = codes == 1
    core_occ = int(np.count_nonzero(occupied[r0 - f0 : r1 - f0, c0 - g0 : c1 - g0]))
    thin_pad = halo_px - fields_halo_px(config)
    t0, t1, u0, u1 = window_box(box, thin_pad, (h, w))  # the thinned window
    empty = np.zeros(0, np.int64)
    if not occupied.any():  # H = 0 in the whole window: no ridge near the block
        return BlockPiece(box, empty, np.zeros(0, np.int32), core_occ, halo_px, 0, seen)
    fields, ridge_sq = ridge_fields(
        occupied,
        distance=config.distance,
        ridge=config.ridge,
        tile_px=config.tile_px,
        tiles_per_call=config.tiles_per_call,
        threads=threads,
    )
    del occupied
    ridges_all = fields.ridges
    ridges = ridges_all[t0 - f0 : t1 - f0, u0 - g0 : u1 - g0]
    if config.graph.free_space_only:
        ridges = ridges & (codes[t0 - f0 : t1 - f0, u0 - g0 : u1 - g0] == 0)
    del codes
    beyond = (t0 > 0, t1 < h, u0 > 0, u1 < w)
    skeleton, unsure, n_sub = thin_window(ridges, beyond, config.skeleton.thinning)
    core = (r0 - t0, r1 - t0, c0 - u0, c1 - u0)
    if config.skeleton.remove_t:
        if not exact_after_t_removal(skeleton, unsure, core):
            return BlockPiece(box, empty, np.zeros(0, np.int32), core_occ, None, n_sub, seen)
        remove_t_in_map_order(skeleton, t0, u0, h, w)
    elif unsure[1:-1, 1:-1][core[0] : core[1], core[2] : core[3]].any():
        return BlockPiece(box, empty, np.zeros(0, np.int32), core_occ, None, n_sub, seen)
    rows, cols = np.nonzero(skeleton[core[0] : core[1], core[2] : core[3]])
    rows += r0
    cols += c0
    in_fields = (rows - f0).astype(np.int64) * (g1 - g0) + (cols - g0)
    sq = at_ridge_pixels(ridges_all, ridge_sq, in_fields)
    flat = rows.astype(np.int64) * w + cols
    return BlockPiece(box, flat, sq.astype(np.int32), core_occ, halo_px, n_sub, seen)
