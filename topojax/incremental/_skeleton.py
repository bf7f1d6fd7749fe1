"""The skeleton loop's strategies: ``"exact"`` (local re-thinning, then the ordered
T-removal update) and ``"paper"`` (paper §III-B), writing into the tile layers.
"""

from __future__ import annotations

import numpy as np

from ._rethin import _THIN_DC, _THIN_DR, RETHIN_BLOCK_PX, SEED_MARGIN_PX, _rethin, _seed_blocks
from ._tiles import _gather_px, _scatter_px
from ._tremoval import _t_seeds, _t_update


def write_skeleton(mapper, rows, cols, values) -> int:
    """Write skeleton values, record the changed pixels for the graph loop."""
    tiles = mapper._tiles
    grid, (g0r, g0c) = tiles.slot_grid
    old = np.empty(rows.shape[0], bool)
    layer = tiles.layer("skeleton")
    _gather_px(layer, grid, g0r, g0c, mapper.tile_px, rows, cols, False, old)
    ch = old != values
    if ch.any():
        r, c = rows[ch], cols[ch]
        _scatter_px(layer, grid, g0r, g0c, mapper.tile_px, r, c, values[ch])
        mapper._skel_changed.append(np.stack([r, c], axis=1))
    return int(ch.sum())


def thin(mapper, image: np.ndarray) -> np.ndarray:
    """The full pipeline's thinning and T removal of a bool ``image`` with the mapper's
    skeleton settings."""
    from ..skeleton import skeletonize_ridges

    return skeletonize_ridges(
        image, method=mapper.config.skeleton.thinning, remove_t=mapper.config.skeleton.remove_t
    )


def skeleton_exact(mapper, added, removed, border) -> int:
    """Exact local update of the skeleton (docs/incremental-exactness.md): re-thin around the
    changed ridge pixels (:func:`_rethin`), then redo T-centre removal where its inputs
    changed (:func:`_t_update`)."""
    if added.shape[0] == 0 and removed.shape[0] == 0 and border.shape[0] == 0:
        return 0
    from ..skeleton import TABLES_U8

    tiles = mapper._tiles
    t = mapper.tile_px
    b = min(RETHIN_BLOCK_PX, mapper.block_px)
    nb = t // b
    keys = tiles.keys
    tau = tiles.layer("thin_time")
    grid, (g0r, g0c) = tiles.slot_grid
    seeds = [border]
    changed = np.concatenate([added, removed])
    if changed.shape[0]:
        bid = np.full((tiles.n_tiles, nb, nb), -1, np.int32)
        blk = np.empty((tiles.n_tiles * nb * nb, 3), np.int64)
        n_blk = _seed_blocks(
            changed[:, 0].astype(np.int64),
            changed[:, 1].astype(np.int64),
            grid,
            g0r,
            g0c,
            nb,
            b,
            bid,
            blk,
            SEED_MARGIN_PX,
        )
        flat, _rounds, _n = _rethin(
            tiles.layer("ridge").reshape(-1),
            tau,
            tiles.neighbour_slots(),
            t,
            b,
            bid,
            blk,
            n_blk,
            TABLES_U8[mapper.config.skeleton.thinning],
            _THIN_DR,
            _THIN_DC,
        )
        slot, rem = np.divmod(flat, t * t)
        lr, lc = np.divmod(rem, t)
        seeds.append(np.stack([keys[slot, 0] * t + lr, keys[slot, 1] * t + lc], axis=1))
    seeds = np.concatenate(seeds)
    if seeds.shape[0] == 0:
        return 0
    bbox = np.asarray(tiles.pixel_bbox, np.int64)
    skel = tiles.layer("skeleton")
    n_seed = seeds.shape[0]
    ch_r = np.empty(n_seed + 16, np.int64)
    ch_c = np.empty(n_seed + 16, np.int64)
    args = (skel, tau, grid, g0r, g0c)
    todo, n_ch = _t_seeds(
        *args,
        t,
        bbox,
        seeds[:, 0].astype(np.int64),
        seeds[:, 1].astype(np.int64),
        border.shape[0],
        mapper.config.skeleton.remove_t,
        ch_r,
        ch_c,
    )
    ch_r, ch_c, n_ch = _t_update(
        *args, tiles.neighbour_slots(), t, bbox, np.sort(todo), ch_r, ch_c, n_ch
    )
    ch_r, ch_c = ch_r[:n_ch], ch_c[:n_ch]
    if ch_r.shape[0]:
        mapper._skel_changed.append(np.stack([ch_r, ch_c], axis=1))
    return int(ch_r.shape[0])


def skeleton_paper(mapper, blocks) -> int:
    """Paper §III-B: thin the new ridges of the changed blocks together with a layer of
    the old skeleton around them; write back inside the changed blocks only."""
    if blocks.shape[0] == 0:
        return 0
    from scipy import ndimage

    tiles = mapper._tiles
    b, lay = mapper.block_px, mapper.paper_layer_px
    bbox = tiles.pixel_bbox
    br0, bc0 = blocks.min(axis=0)
    br1, bc1 = blocks.max(axis=0) + 1
    grid_blocks = np.zeros((br1 - br0, bc1 - bc0), bool)
    grid_blocks[blocks[:, 0] - br0, blocks[:, 1] - bc0] = True
    mask_full = np.repeat(np.repeat(grid_blocks, b, axis=0), b, axis=1)
    mr0, mc0 = int(br0) * b, int(bc0) * b
    r0 = max(mr0 - lay, bbox[0])
    c0 = max(mc0 - lay, bbox[1])
    r1 = min(int(br1) * b + lay, bbox[2])
    c1 = min(int(bc1) * b + lay, bbox[3])
    mask = np.zeros((r1 - r0, c1 - c0), bool)
    sub = mask_full[r0 - mr0 : r1 - mr0, c0 - mc0 : c1 - mc0]
    oy, ox = max(0, mr0 - r0), max(0, mc0 - c0)
    sub = mask_full[max(0, r0 - mr0) : r1 - mr0, max(0, c0 - mc0) : c1 - mc0]
    mask[oy : oy + sub.shape[0], ox : ox + sub.shape[1]] = sub
    h, w = mask.shape
    # the square dilation as a separable maximum filter, whose cost does not grow with the
    # layer; a layer wider than the window reaches all of it
    side = 2 * min(lay, max(h, w)) + 1
    layer = ndimage.maximum_filter(mask, size=side, mode="constant", cval=False) & ~mask
    ridge = tiles.read("ridge", r0, c0, h, w)
    old = tiles.read("skeleton", r0, c0, h, w)
    sk = thin(mapper, (ridge & mask) | (old & layer))
    rr, cc = np.nonzero(mask)
    return write_skeleton(mapper, rr + r0, cc + c0, sk[rr, cc])
