"""Ridge kernels: the full-map pipeline's Gaussian, Laplacian and ridge cut on haloed
blocks (JAX), and the numba gather of the patches and write-back of the results.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from .._jit import TRACES, cached_njit
from ..fields.distance import FAR_SQ, gaussian_from_sq_distance
from ..fields.filters import HALO_PX, laplacian_valid, ridge_from_laplacian
from ._tiles import _U64, _aligned_empty, _batches, _flat, _wrap_into_tile

#: Largest window half-width (px) whose Gaussian the ridge kernel reads from a table
#: (2 R^2 + 2 float32 entries: 32 MiB at this bound) instead of computing it.
TABLE_MAX_HALF_PX = 2047


#: Blocks per ridge kernel call (small and large fixed batch).
RIDGE_BLOCKS = (64, 512)


def ridge_block(
    d2_patch: jax.Array,
    sigma_px: jax.Array,
    scale: jax.Array,
    threshold: jax.Array,
    *,
    ksize: int,
) -> tuple[jax.Array, jax.Array]:
    """Ridges of one block from its haloed squared distances.

    The same maths as :func:`topojax.pipeline.forward_tile` after its distance stage
    (:func:`~topojax.fields.distance.gaussian_from_sq_distance`,
    :func:`~topojax.fields.filters.laplacian_valid`, :func:`~topojax.fields.filters.ridge_from_laplacian`).
    The halo must already hold the ``BORDER_REFLECT_101`` image of the map where it leaves
    the map (the gather does it: reflecting indices commutes with the elementwise Gaussian,
    so this equals :func:`~topojax.fields.filters.reflect_101_halo` on ``H``).

    Parameters
    ----------
    d2_patch : int32 array, shape (B + 4, B + 4)
        Squared distances (px^2) of the block and a 2-pixel halo.
    sigma_px : float32 scalar or float32 array (n,)
        Gaussian standard deviation in pixels, or a table of ``H`` by squared distance
        (:func:`gaussian_table`): squared distances are integers, so a lookup gives the
        exponential's values (bit for bit) at a third less cost.
    scale, threshold : float32 scalars
    ksize : int
        Laplacian aperture (static).

    Returns
    -------
    lap_abs : uint8 (B, B)
    ridge : bool (B, B)
    """
    if sigma_px.ndim == 0:
        h = gaussian_from_sq_distance(d2_patch, sigma_px)
    else:
        h = sigma_px[jnp.minimum(d2_patch, sigma_px.shape[0] - 1)]
    lap = laplacian_valid(h, ksize=ksize)
    return ridge_from_laplacian(lap, scale=scale, threshold=threshold)


def gaussian_table(sigma_px: float, half_width: int) -> jax.Array:
    """``H`` for every squared distance a window of half-width ``R`` allows.

    Returns
    -------
    float32 array, shape (2 R^2 + 2,)
        ``table[d2]`` = :func:`~topojax.fields.distance.gaussian_from_sq_distance` ``(d2)`` for
        ``d2 <= 2 R^2``; the last entry is 0 (:data:`~topojax.fields.distance.FAR_SQ` is looked up
        there).
    """
    d2 = np.arange(2 * half_width * half_width + 2, dtype=np.int32)
    d2[-1] = FAR_SQ
    return _gaussian(d2, jnp.float32(sigma_px))


@partial(jax.jit, static_argnames=("ksize", "with_ridge"))
def _ridge_blocks(patches, sigma_px, scale, threshold, *, ksize, with_ridge=True):
    """:func:`ridge_block` over a batch; ``with_ridge=False`` returns ``lap_abs`` alone.

    The ridge map is ``lap_abs > threshold`` whenever ``threshold < 255`` (the caller's
    test), and XLA computes the fused filter once per output: one output halves the
    kernel's work.
    """
    TRACES["ridge_blocks"] += 1
    fn = partial(ridge_block, ksize=ksize)
    out = jax.vmap(fn, in_axes=(0, None, None, None))(patches, sigma_px, scale, threshold)
    return out if with_ridge else out[0]


@jax.jit
def _gaussian(d2, sigma_px):
    TRACES["gaussian"] += 1
    return gaussian_from_sq_distance(d2, sigma_px)


@cached_njit(nogil=True, inline="always")
def _reflect_into_tile(g, first, last, tile0, t):
    """Reflect global index ``g`` into ``[first, last]`` (BORDER_REFLECT_101), then
    express it relative to the tile starting at ``tile0``: (local index, neighbour 0/1/2
    for the previous / same / next tile along this axis)."""
    if g < first:
        g = 2 * first - g
    elif g > last:
        g = 2 * last - g
    return _wrap_into_tile(g - tile0, t)


@cached_njit(nogil=True)
def _gather_ridge_patches(d2, nbr9, t, b, halo, slots, lbr, lbc, keys, bbox, out):
    """Haloed squared-distance patches of blocks, reflected at the bounding box.

    ``out[i]`` is the ``(b + 2 halo)^2`` patch around block ``(lbr[i], lbc[i])`` of tile
    ``slots[i]``; rows/cols outside ``bbox = (row0, col0, row1, col1)`` read the
    ``BORDER_REFLECT_101`` mirror pixel (``-1 -> 1``), missing tiles read ``FAR_SQ``.

    The copies index flat views with unsigned offsets: numba wraps negative signed
    indices, and that test in every element keeps LLVM from vectorising the copy.
    """
    r_first = bbox[0]
    c_first = bbox[1]
    r_last = bbox[2] - 1
    c_last = bbox[3] - 1
    size = b + 2 * halo
    src = _flat(d2)
    dst = _flat(out)
    lcs = np.empty(size, np.uint64)
    oxs = np.empty(size, np.int64)
    base = np.empty(3, np.int64)
    # columns of the patch per neighbour tile 0/1/2 along the row: (first, stop, first
    # tile-local column)
    seg = np.empty((3, 3), np.int64)
    for i in range(slots.shape[0]):
        s = slots[i]
        tile_r0 = keys[s, 0] * t
        tile_c0 = keys[s, 1] * t
        org_r = tile_r0 + lbr[i] * b - halo
        org_c = tile_c0 + lbc[i] * b - halo
        lr0 = org_r - tile_r0
        lc0 = org_c - tile_c0
        o = _U64(i * size * size)
        cols_inside = org_c >= c_first and org_c + size - 1 <= c_last
        if (
            cols_inside
            and lr0 >= 0
            and lc0 >= 0
            and lr0 + size <= t
            and lc0 + size <= t
            and org_r >= r_first
            and org_r + size - 1 <= r_last
        ):
            # the patch lies inside its own tile and inside the box: a plain copy
            p = _U64((s * t + lr0) * t + lc0)
            for _ in range(size):
                for cc in range(size):
                    dst[o + _U64(cc)] = src[p + _U64(cc)]
                p += _U64(t)
                o += _U64(size)
            continue
        if cols_inside:
            # patch column cc is tile-local column lc0 + cc: in the previous tile below 0,
            # in the next one from t
            e0 = min(max(-lc0, 0), size)
            e1 = min(max(t - lc0, 0), size)
            seg[0, 0] = 0
            seg[0, 1] = e0
            seg[0, 2] = lc0 + t
            seg[1, 0] = e0
            seg[1, 1] = e1
            seg[1, 2] = lc0 + e0
            seg[2, 0] = e1
            seg[2, 1] = size
            seg[2, 2] = lc0 + e1 - t
        else:
            for cc in range(size):  # reflected: the same column mapping for every row
                lc, ox = _reflect_into_tile(org_c + cc, c_first, c_last, tile_c0, t)
                lcs[cc] = _U64(lc)
                oxs[cc] = ox
        for a in range(size):
            lr, oy = _reflect_into_tile(org_r + a, r_first, r_last, tile_r0, t)
            if cols_inside:
                for k in range(3):
                    n = seg[k, 1] - seg[k, 0]
                    if n <= 0:
                        continue
                    d = o + _U64(seg[k, 0])
                    ss = nbr9[s, 3 * oy + k]
                    if ss < 0:
                        for cc in range(n):
                            dst[d + _U64(cc)] = FAR_SQ
                    else:
                        p = _U64((ss * t + lr) * t + seg[k, 2])
                        for cc in range(n):
                            dst[d + _U64(cc)] = src[p + _U64(cc)]
            else:
                for k in range(3):
                    ss = nbr9[s, 3 * oy + k]
                    base[k] = -1 if ss < 0 else (ss * t + lr) * t
                for cc in range(size):
                    bs = base[oxs[cc]]
                    dst[o + _U64(cc)] = FAR_SQ if bs < 0 else src[_U64(bs) + lcs[cc]]
            o += _U64(size)


@cached_njit(nogil=True, inline="always")
def _ridge_at(rs, ls, i, cut):
    """Ridge value of element ``i`` of a kernel batch: read from the kernel's ridge output
    ``rs`` when ``cut < 0``, else ``lap_abs > cut``."""
    return rs[i] if cut < 0 else np.int64(ls[i]) > cut


@cached_njit(nogil=True)
def _write_ridges(ridge_l, lap_l, slots, lbr, lbc, keys, t, b, lap_abs, ridge, cut):
    """Store recomputed blocks; return the global pixels that became ridge pixels and
    those that stopped being ones, (n, 2) int64 each.

    The ridge is read from ``ridge`` when ``cut < 0``, else it is ``lap_abs > cut``
    (``ridge`` is then not read)."""
    n = slots.shape[0]
    # room for the worst case (np.empty does not touch the memory it does not use)
    added = np.empty((n * b * b, 2), np.int64)
    removed = np.empty((n * b * b, 2), np.int64)
    na = 0
    nr = 0
    rl = _flat(ridge_l)
    ll = _flat(lap_l)
    rs = _flat(ridge)
    ls = _flat(lap_abs)
    for i in range(n):
        s = slots[i]
        r0 = lbr[i] * b
        c0 = lbc[i] * b
        gr = keys[s, 0] * t + r0
        gc = keys[s, 1] * t + c0
        o = _U64(i * b * b)
        p = _U64((s * t + r0) * t + c0)
        for a in range(b):
            # branch-free copy and compare (vectorises); most rows do not change
            diff = False
            for c in range(b):
                diff |= rl[p + _U64(c)] != _ridge_at(rs, ls, o + _U64(c), cut)
                ll[p + _U64(c)] = ls[o + _U64(c)]
            if diff:
                for c in range(b):
                    v = _ridge_at(rs, ls, o + _U64(c), cut)
                    if rl[p + _U64(c)] != v:
                        rl[p + _U64(c)] = v
                        if v:
                            added[na, 0] = gr + a
                            added[na, 1] = gc + c
                            na += 1
                        else:
                            removed[nr, 0] = gr + a
                            removed[nr, 1] = gc + c
                            nr += 1
            o += _U64(b)
            p += _U64(t)
    return added[:na].copy(), removed[:nr].copy()


def ridge_kernel(mapper, patches):
    """Dispatch the ridge kernel on a batch of patches (asynchronous): ``lap_abs``, or
    ``(lap_abs, ridge)`` when the threshold is 255 or more (see ``_ridge_cut``)."""
    return _ridge_blocks(
        patches,
        *mapper._ridge_args,
        ksize=mapper.config.ridge.ksize,
        with_ridge=mapper._ridge_cut < 0,
    )


def mark_blocks(mapper, gbr, gbc) -> None:
    """Mark global blocks ridge-dirty (blocks of unallocated tiles are skipped)."""
    tiles = mapper._tiles
    nb = mapper.tile_px // mapper.block_px
    tr, lbr = np.divmod(gbr, nb)
    tc, lbc = np.divmod(gbc, nb)
    sl = tiles.lookup(tr, tc)
    ok = sl >= 0
    tiles.layer("ridge_dirty")[sl[ok], lbr[ok], lbc[ok]] = True
    tiles.mark_dirty("ridge", sl[ok])


def update_ridges(mapper):
    """Recompute the ridges of the dirty blocks.

    Returns
    -------
    added, removed : int64 arrays (n, 2)
        Global pixels that became / stopped being ridge pixels.
    border : int64 array (m, 2)
        Pixels on the lines of the previous bounding box border that is now interior
        (their T-removal rule changed).
    blocks : int64 array (k, 2)
        Global (block row, block col) of the recomputed blocks.
    """
    tiles = mapper._tiles
    t, b = mapper.tile_px, mapper.block_px
    nb = t // b
    bbox = tiles.pixel_bbox
    empty = np.zeros((0, 2), np.int64)
    if bbox is None:
        return empty, empty, empty, empty
    border = empty
    old = mapper._ridge_bbox
    if old is not None and old != bbox:
        border = old_border(mapper, old, bbox)
    mapper._ridge_bbox = bbox
    slots = tiles.dirty("ridge")
    flags = tiles.layer("ridge_dirty")
    # contiguous copies: np.nonzero's arrays are strided views (except when they hold
    # one element), and numba compiles a new variant for each memory layout
    sl, lbr, lbc = (np.ascontiguousarray(a) for a in np.nonzero(flags[slots]))
    sl = slots[sl]
    tiles.clear_dirty("ridge")
    flags[sl, lbr, lbc] = False
    if sl.size == 0:
        return empty, empty, border, empty
    mapper.compile()
    keys = tiles.keys
    gbr = keys[sl, 0] * nb + lbr
    gbc = keys[sl, 1] * nb + lbc
    size = b + 2 * HALO_PX
    n = sl.size
    plan = list(_batches(n, RIDGE_BLOCKS))
    # room for the last batch's padding: every batch is dispatched as a view
    patches = _aligned_empty((plan[-1][0] + plan[-1][2], size, size), np.int32)
    patches[n:] = FAR_SQ
    _gather_ridge_patches(
        tiles.layer("sq_distance"),
        tiles.neighbour_slots(),
        t,
        b,
        HALO_PX,
        sl,
        lbr,
        lbc,
        keys,
        np.asarray(bbox, np.int64),
        patches,
    )
    # All batches are dispatched first (asynchronous), then written as they arrive.
    batches = [
        (
            start,
            stop,
            ridge_kernel(mapper, patches[start : start + bsize]),
        )
        for start, stop, bsize in plan
    ]
    added, removed = [], []
    cut = mapper._ridge_cut
    no_ridge = np.zeros((0, b, b), bool)
    for start, stop, res in batches:
        m = stop - start
        la, ri = (res, no_ridge) if cut >= 0 else (res[0], np.asarray(res[1])[:m])
        a, r = _write_ridges(
            tiles.layer("ridge"),
            tiles.layer("lap_abs"),
            sl[start:stop],
            lbr[start:stop],
            lbc[start:stop],
            keys,
            t,
            b,
            np.asarray(la)[:m],
            ri,
            cut,
        )
        added.append(a)
        removed.append(r)
    added = np.concatenate(added)
    removed = np.concatenate(removed)
    mapper._n_ridge += added.shape[0] - removed.shape[0]
    blocks = np.stack([gbr, gbc], axis=1)
    return added, removed, border, blocks


def old_border(mapper, old, new) -> np.ndarray:
    """Dirty the blocks along the sides of the old bounding box that moved and return
    the pixels on those old border lines."""
    r0, c0, r1, c1 = old
    b = mapper.block_px
    lines = []
    if new[0] < r0:
        lines.append((r0, r0 + 1, c0, c1))
    if new[2] > r1:
        lines.append((r1 - 1, r1, c0, c1))
    if new[1] < c0:
        lines.append((r0, r1, c0, c0 + 1))
    if new[3] > c1:
        lines.append((r0, r1, c1 - 1, c1))
    pix = []
    for a0, a1, b0, b1 in lines:
        rr, cc = np.mgrid[a0:a1, b0:b1]
        rr = rr.ravel().astype(np.int64)
        cc = cc.ravel().astype(np.int64)
        pix.append(np.stack([rr, cc], axis=1))
        # blocks within the 2-pixel halo of the old border line
        brs = np.unique(np.concatenate([(rr - HALO_PX) // b, rr // b, (rr + HALO_PX) // b]))
        bcs = np.unique(np.concatenate([(cc - HALO_PX) // b, cc // b, (cc + HALO_PX) // b]))
        gbr, gbc = np.meshgrid(brs, bcs, indexing="ij")
        mark_blocks(mapper, gbr.ravel(), gbc.ravel())
    return np.concatenate(pix) if pix else np.zeros((0, 2), np.int64)
