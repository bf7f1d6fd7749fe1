"""The splat: JAX kernel for the windowed squared distance of a block to a few points, and
the numba steps that pair new obstacles with the blocks they can change and merge the
results into the tiles.
"""

from __future__ import annotations

import math
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from .._jit import TRACES, cached_njit
from ..fields.distance import FAR_SQ
from ..fields.filters import HALO_PX
from ._tiles import (
    _FAR_BOUND,
    _U64,
    _batches,
    _flat,
    _locate,
    _log2,
    _max_padding,
    _unflat,
    _worker_pool,
    _wrap_into_tile,
)

#: Points per row of the splat kernel (a row is one block and up to this many points).
SPLAT_POINTS = 8


#: Rows per splat kernel call: a small and a large fixed batch (two compilations serve a
#: whole replay; they are compiled on the first flush).
SPLAT_ROWS = (128, 1024)


#: Splat batches with at least this many new points share the pairing with a worker
#: thread (on machines with more than one CPU).
PARALLEL_MIN_POINTS = 64


#: Radius (Chebyshev, px) searched for obstacles that dominate a new point on a block
#: (at most 2: the pairing divides by twice a column offset with a shift).
DOMINANCE_PX = 2


def splat_block(points: jax.Array, *, size: int, half_width: int) -> jax.Array:
    """Squared distance from each pixel of one block to the nearest of up to ``P`` points.

    Pure function of one (block, point bucket) pair; batched with :func:`jax.vmap`.  The
    caller merges the result into the map with a minimum (a max-splat of Gaussians).

    Parameters
    ----------
    points : int32 array, shape (P, 2)
        Obstacle pixels ``(row, col)`` relative to the block's first pixel.  Padding
        points are placed more than ``half_width`` away (they change nothing).
    size : int
        Block side ``B`` (static).
    half_width : int
        Window half-width ``R`` (static): a point reaches pixels with ``|dr| <= R`` and
        ``|dc| <= R``.

    Returns
    -------
    int32 array, shape (B, B): ``min_p dr^2 + dc^2`` over the points whose window contains
    the pixel, :data:`~topojax.fields.distance.FAR_SQ` where there is none.
    """
    idx = jnp.arange(size, dtype=jnp.int32)
    dr = idx[None, :] - points[:, 0:1]  # (P, B)
    dc = idx[None, :] - points[:, 1:2]
    big = jnp.int32(FAR_SQ // 2)  # > any in-window dr^2 + dc^2; big + big fits in int32
    a = jnp.where(jnp.abs(dr) <= half_width, dr * dr, big)
    c = jnp.where(jnp.abs(dc) <= half_width, dc * dc, big)
    # one (B, B) minimum per point: XLA fuses the chain into a single vectorised loop,
    # where a reduction over a point axis vectorises poorly on a CPU
    best = a[0][:, None] + c[0][None, :]
    for p in range(1, points.shape[0]):
        best = jnp.minimum(best, a[p][:, None] + c[p][None, :])
    # A sum involving ``big`` means the pixel is outside that point's window.
    return jnp.where(best >= big, jnp.int32(FAR_SQ), best)


@partial(jax.jit, static_argnames=("size", "half_width"))
def _splat_blocks(points, *, size, half_width):
    TRACES["splat_blocks"] += 1
    return jax.vmap(partial(splat_block, size=size, half_width=half_width))(points)


@cached_njit(nogil=True, inline="always")
def _isqrt(n):
    """Largest integer ``e`` with ``e * e <= n`` (``n >= 0``), exact for any int64."""
    e = int(math.sqrt(float(n)))
    while e * e > n:
        e -= 1
    while (e + 1) * (e + 1) <= n:
        e += 1
    return e


@cached_njit(nogil=True, inline="always")
def _near_obstacles(p_r, p_c, rho, b, grid, g0r, g0c, tsh, hits, nbr, n_q):
    """Fill ``nbr`` and ``n_q`` with the obstacles ``q`` (old or new) at offsets ``(a, c)``
    ``!= (0, 0)`` with ``|a|, |c| <= rho`` from the point ``(p_r, p_c)``; returns whether
    there is any.

    They are grouped by the sign of ``c`` (group 0: ``c > 0``, 1: ``c < 0``, 2: ``c = 0``)
    so that the per-row loops of the pairing have no data-dependent branches.  For a
    block row ``[lo, hi]`` relative to ``p``, ``q`` is at least as near as ``p`` to the
    row's corners where ``dd = a^2 + c^2 - 2 a (lo if a > 0 else hi) <= 2 c dc_corner``;
    with ``hi = lo + b - 1`` that is ``dd = d0 - 2 a lo``.  Row ``j`` of group ``g`` is
    ``nbr[g, j] = (d0, 2 a, log2(2 |c|))``; ``n_q[g]`` counts the rows.
    """
    n_q[0] = 0
    n_q[1] = 0
    n_q[2] = 0
    for a in range(-rho, rho + 1):
        for c in range(-rho, rho + 1):
            if a == 0 and c == 0:
                continue
            s, lr, lc = _locate(grid, g0r, g0c, tsh, p_r + a, p_c + c)
            if s >= 0 and hits[s, lr, lc] > 0:
                g = 0 if c > 0 else (1 if c < 0 else 2)
                j = n_q[g]
                nbr[g, j, 0] = a * a + c * c - (2 * (b - 1) * a if a < 0 else 0)
                nbr[g, j, 1] = 2 * a
                nbr[g, j, 2] = 1 if abs(c) == 1 else 2  # log2(2 |c|), |c| <= rho <= 2
                n_q[g] = j + 1
    return n_q[0] + n_q[1] + n_q[2] > 0


@cached_njit(nogil=True, inline="always")
def _row_bound(grid, gi, gc0, gc1, lbr, rowmax):
    """Largest block maximum along block row ``lbr`` of the allocated tiles in columns
    ``gc0 .. gc1`` (clipped to the grid) of tile-grid row ``gi``; 0 if there is none."""
    rmax = 0
    for gj in range(max(gc0, 0), min(gc1, grid.shape[1] - 1) + 1):
        ss = grid[gi, gj]
        if ss >= 0 and rowmax[ss, lbr] > rmax:
            rmax = rowmax[ss, lbr]
    return rmax


@cached_njit(nogil=True, inline="always")
def _undominated_columns(nbr, n_q, lo, p_c, ib0, ib1, bsh):
    """The interval ``[al, ar]`` of the inner block columns ``ib0 .. ib1`` of a block row
    (first pixel row ``lo`` relative to the point) whose blocks no neighbour obstacle of
    :func:`_near_obstacles` dominates (empty as ``al > ar``); blocks of side
    ``2**bsh``."""
    b = 1 << bsh
    al = ib0
    ar = ib1
    for j in range(n_q[0]):  # c > 0: dominated iff lo_c >= ceil(dd / (2 c))
        dd = nbr[0, j, 0] - nbr[0, j, 1] * lo
        thr = -((-dd) >> nbr[0, j, 2]) + p_c  # 2 c is 2 or 4: a shift
        ar = min(ar, -((-thr) >> bsh) - 1)
    for j in range(n_q[1]):  # c < 0: iff hi_c <= floor(dd / (2 c))
        dd = nbr[1, j, 0] - nbr[1, j, 1] * lo
        thr = ((-dd) >> nbr[1, j, 2]) + p_c - b + 1
        al = max(al, (thr >> bsh) + 1)
    for j in range(n_q[2]):  # c = 0: iff dd <= 0, the whole row
        if nbr[2, j, 0] - nbr[2, j, 1] * lo <= 0:
            al = ib1 + 1
            ar = ib1
    return al, ar


@cached_njit(nogil=True, inline="always")
def _pair_columns(i, p_c, dr, e, rem, c_from, c_to, row, bsh, nsh, bmax, rowmax, pairs, n):
    """Append to ``pairs = (pair_k, pair_i)`` (from ``n``) the pairs of point ``i``
    (column ``p_c``) with the blocks of global block columns ``c_from .. c_to`` in one
    block row, ``dr`` pixel rows from the point, that pass the disk bound.

    ``row = (grid, gi, g0c, lbr)``: the tile grid, its row holding the block row and
    first column, and the block row in its tiles.  ``e`` is ``isqrt(rem - 1)`` for the
    row's bound ``rem``; blocks have side ``2**bsh``, tiles ``2**nsh`` blocks.  Returns
    the new number of pairs.
    """
    grid, gi, g0c, lbr = row
    pair_k, pair_i = pairs
    b = 1 << bsh
    nb = 1 << nsh
    gw = grid.shape[1]
    for tcc in range(c_from >> nsh, (c_to >> nsh) + 1):
        gj = tcc - g0c
        if gj < 0 or gj >= gw:
            continue
        s = grid[gi, gj]
        if s < 0:
            continue
        # this tile's own disk bound (the row's bound used the largest maximum)
        remt = rowmax[s, lbr] - dr * dr
        if remt <= 0:
            continue
        et = e if remt == rem else _isqrt(remt - 1)
        t_from = max(c_from, -((et + b - 1 - p_c) >> bsh))
        t_to = min(c_to, (p_c + et) >> bsh)
        l0 = max(t_from - tcc * nb, 0)
        l1 = min(t_to - tcc * nb, nb - 1)
        for lbc in range(l0, l1 + 1):
            lo_c = (tcc * nb + lbc) * b - p_c
            if lo_c > 0:
                dc = lo_c
            elif lo_c + b - 1 < 0:
                dc = -(lo_c + b - 1)
            else:
                dc = 0
            if dr * dr + dc * dc >= bmax[s, lbr, lbc]:
                continue
            pair_k[n] = (s * nb + lbr) * nb + lbc
            pair_i[n] = i
            n += 1
    return n


@cached_njit(nogil=True, inline="always")
def _point_pairs(i, p_r, p_c, near, grid, g0r, g0c, bsh, nsh, half, rho, bmax, rowmax, pairs, n):
    """Append the pairs of point ``i`` at ``(p_r, p_c)`` to ``pairs = (pair_k, pair_i)``
    (from ``n``; room for every block of its window), by block rows of its window.

    The disk bound limits each row's columns; on rows inside the inner square the
    columns that a neighbour obstacle dominates (``near = (nbr, n_q, any_q)``,
    :func:`_near_obstacles`) are left out.  Returns the new number of pairs.
    """
    nbr, n_q, any_q = near
    b = 1 << bsh
    nb = 1 << nsh
    inner = half - rho
    br0 = (p_r - half) >> bsh
    br1 = (p_r + half) >> bsh
    bc0 = (p_c - half) >> bsh
    bc1 = (p_c + half) >> bsh
    # block columns lying inside the inner square |x - p|_inf <= R - rho
    ib0 = -((inner - p_c) >> bsh)  # ceil((p_c - inner) / b)
    ib1 = (p_c + inner - b + 1) >> bsh
    for gbr in range(br0, br1 + 1):
        lo = gbr * b - p_r  # block rows relative to p
        hi = lo + b - 1
        if lo > 0:
            dr = lo
        elif hi < 0:
            dr = -hi
        else:
            dr = 0
        tr = gbr >> nsh
        gi = tr - g0r
        if gi < 0 or gi >= grid.shape[0]:
            continue
        lbr = gbr - tr * nb
        # Disk bound: no block of this row can gain if dc^2 >= max bmax - dr^2.
        rmax = _row_bound(grid, gi, (bc0 >> nsh) - g0c, (bc1 >> nsh) - g0c, lbr, rowmax)
        rem = rmax - dr * dr
        if rem <= 0:
            continue
        e = _isqrt(rem - 1)
        cb0 = max(bc0, -((e + b - 1 - p_c) >> bsh))
        cb1 = min(bc1, (p_c + e) >> bsh)
        if any_q and lo >= -inner and hi <= inner:
            jb0 = ib0
            al, ar = _undominated_columns(nbr, n_q, lo, p_c, ib0, ib1, bsh)
        else:  # no inner part in this row: every column is tested
            jb0 = ib1 + 1
            al = ib1 + 1
            ar = ib1
        row = (grid, gi, g0c, lbr)
        for part in range(3):
            if part == 0:  # the columns left of the inner ones
                c_from = cb0
                c_to = min(cb1, jb0 - 1)
            elif part == 1:  # the undominated inner ones
                c_from = max(al, jb0, cb0)
                c_to = min(ar, ib1, cb1)
            else:  # those right of the inner ones
                c_from = max(ib1 + 1, cb0, jb0)
                c_to = cb1
            if c_from <= c_to:
                n = _pair_columns(
                    i, p_c, dr, e, rem, c_from, c_to, row, bsh, nsh, bmax, rowmax, pairs, n
                )
    return n


@cached_njit(nogil=True)
def _splat_pairs(pr, pc, first, step, grid, g0r, g0c, t, b, half, bmax, rowmax, hits, rho):
    """The (block, point) pairs that can lower a block, for points ``first, first + step,
    ...`` (so that threads can share a batch).

    A pair is skipped when it provably changes nothing (exact; a third rule, among the
    batch's own points, is applied by :func:`_splat_group`):

    * ``dist^2(p, block) >= max_block d2``: every pixel already has a nearer obstacle;
    * the block lies in the square ``|x - p|_inf <= R - rho`` and another obstacle ``q``
      with ``|q - p|_inf <= rho`` (old, or new in this batch) is at least as near as ``p`` to
      all four block corners, hence (half-plane) to every block pixel, and ``q`` lies in
      every block pixel's window.  Following such dominations from ``p`` never cycles
      (two distinct points cannot be equally near all four corners) and ends at a point
      that is old, or splatted into the block, or skipped by the first or third rule
      (both of which only skip points that cannot lower any pixel), so the block's
      minimum is unaffected.  For one row of blocks each neighbour ``q`` dominates a
      half-line of block columns, so the allowed blocks form an interval.

    ``bmax`` (slot, block row, block col) holds the blocks' bounds (:func:`_batch_bound`)
    and ``rowmax`` (slot, block row) their maxima along block rows.  Per point: its
    neighbour obstacles (:func:`_near_obstacles`), then its window's block rows
    (:func:`_point_pairs`); the helpers are inlined (a numba call per block row would
    pass every array again).

    Returns ``pair_k`` (flat block id ``(slot * nb + block_row) * nb + block_col``),
    ``pair_i`` (point index) and the number of pairs (the arrays are longer).
    """
    if rho > 2:  # the domination thresholds divide by 2 |dc| with shifts
        raise ValueError("rho must be at most 2")
    tsh = _log2(t)
    bsh = _log2(b)
    nsh = _log2(t >> bsh)
    n = pr.shape[0]
    n_own = max(0, (n - first + step - 1) // step)
    side = 2 * rho + 1
    nbr = np.empty((3, side * side, 3), np.int64)  # see _near_obstacles
    n_q = np.zeros(3, np.int64)
    pair_k = np.empty(1024 + 64 * n_own, np.int64)
    pair_i = np.empty(pair_k.shape[0], np.int64)
    n_pairs = 0
    # every block of a point's window, at most: room for one more point's pairs is made
    # before the point (growing the arrays inside the per-block loop would make numba
    # count references at every step)
    per_point = ((2 * half) // b + 2) ** 2
    for i in range(first, n, step):
        if n_pairs + per_point > pair_k.shape[0]:
            cap = max(2 * pair_k.shape[0], n_pairs + per_point)
            nk = np.empty(cap, np.int64)
            ni = np.empty(cap, np.int64)
            nk[:n_pairs] = pair_k[:n_pairs]
            ni[:n_pairs] = pair_i[:n_pairs]
            pair_k = nk
            pair_i = ni
        any_q = _near_obstacles(pr[i], pc[i], rho, b, grid, g0r, g0c, tsh, hits, nbr, n_q)
        n_pairs = _point_pairs(
            i,
            pr[i],
            pc[i],
            (nbr, n_q, any_q),
            grid,
            g0r,
            g0c,
            bsh,
            nsh,
            half,
            rho,
            bmax,
            rowmax,
            (pair_k, pair_i),
            n_pairs,
        )
    return pair_k, pair_i, n_pairs


@cached_njit(nogil=True)
def _row_max(bm):
    """Maxima of ``bm`` (slot, block row, block col) along block rows: (slot, block row)."""
    out = np.empty(bm.shape[:2], bm.dtype)
    for s in range(bm.shape[0]):
        for r in range(bm.shape[1]):
            out[s, r] = bm[s, r].max()
    return out


@cached_njit(nogil=True)
def _batch_bound(pr, pc, grid, g0r, g0c, t, b, half, bmax, n_tiles):
    """Block maxima lowered by what the batch's own points guarantee.

    A new point ``q`` whose window covers a whole block brings every pixel of it to at
    most ``U(q)``, the squared distance from ``q`` to the block's farthest corner.  So
    after the batch a block's largest squared distance is at most ``min(bmax, min_q
    U(q))``, and :func:`_splat_pairs` may use that as its first rule's bound: a point at
    least that far from the block cannot lower a pixel below what the others give.
    (Exact: the point that sets the bound is nearer than that to the block, so it is
    paired, unless the old map or a dominating point already does as well.)  Computed on
    the block grid around the batch, with each block's points anywhere in it
    (``U <= (b |d_row| + b - 1)^2 + (b |d_col| + b - 1)^2`` for a block ``d`` blocks
    away), as two separable passes over at most ``K = (R - b + 1) // b`` blocks.

    Returns a copy of ``bmax[:n_tiles]`` with the bound applied, and its maxima along
    block rows (``(n_tiles, nb)``, the pairing's row bound).
    """
    bsh = _log2(b)
    nb = t >> bsh
    nsh = _log2(nb)
    out = bmax[:n_tiles].copy()
    n = pr.shape[0]
    k_max = (half - b + 1) >> bsh
    if n == 0 or k_max < 0:
        return out, _row_max(out)
    r0 = pr[0] >> bsh
    r1 = r0
    c0 = pc[0] >> bsh
    c1 = c0
    for i in range(n):
        r0 = min(r0, pr[i] >> bsh)
        r1 = max(r1, pr[i] >> bsh)
        c0 = min(c0, pc[i] >> bsh)
        c1 = max(c1, pc[i] >> bsh)
    r0 -= k_max
    c0 -= k_max
    h = r1 + k_max - r0 + 1
    w = c1 + k_max - c0 + 1
    occ = np.zeros((h, w), np.bool_)
    for i in range(n):
        occ[(pr[i] >> bsh) - r0, (pc[i] >> bsh) - c0] = True
    cost = np.empty(k_max + 1, np.int64)
    for d in range(k_max + 1):
        cost[d] = (b * d + b - 1) * (b * d + b - 1)
    far = _FAR_BOUND
    # column pass: nearest occupied block row within K (two running scans)
    col = np.full((h, w), far, np.int64)
    for j in range(w):
        last = -(1 << 30)
        for i in range(h):
            if occ[i, j]:
                last = i
            if i - last <= k_max:
                col[i, j] = cost[i - last]
        nxt = 1 << 30
        for i in range(h - 1, -1, -1):
            if occ[i, j]:
                nxt = i
            if nxt - i <= k_max and cost[nxt - i] < col[i, j]:
                col[i, j] = cost[nxt - i]
    # row pass and write-back into the allocated tiles' blocks
    gh = grid.shape[0]
    gw = grid.shape[1]
    for i in range(h):
        gbr = r0 + i
        gi = (gbr >> nsh) - g0r
        if gi < 0 or gi >= gh:
            continue
        for j in range(w):
            # outwards from j; every column value is at least cost[0], so the scan stops
            # once the offset's cost alone cannot improve u
            u = far
            for x in range(k_max + 1):
                cx = cost[x]
                if cx + cost[0] >= u:
                    break
                if j - x >= 0 and col[i, j - x] + cx < u:
                    u = col[i, j - x] + cx
                if j + x < w and col[i, j + x] + cx < u:
                    u = col[i, j + x] + cx
            if u >= far:
                continue
            gbc = c0 + j
            gj = (gbc >> nsh) - g0c
            if gj < 0 or gj >= gw:
                continue
            s = grid[gi, gj]
            if s < 0:
                continue
            lbr = gbr & (nb - 1)
            lbc = gbc & (nb - 1)
            if u < out[s, lbr, lbc]:
                out[s, lbr, lbc] = u
    return out, _row_max(out)


@cached_njit(nogil=True, inline="always")
def _block_origin(keys, k, t, b):
    """Global first pixel (row, col) of the block with flat id ``k``
    (``(slot * nb + block_row) * nb + block_col``, ``nb = t / b``)."""
    s, lbr, lbc = _unflat(k, _log2(t >> _log2(b)))
    return keys[s, 0] * t + lbr * b, keys[s, 1] * t + lbc * b


@cached_njit(nogil=True)
def _splat_group(pair_k, pair_i, pr, pc, keys, n_ids, t, b, half, n_points_row, slack):
    """Group the pairs of :func:`_splat_pairs` into kernel rows by block.

    Returns ``row_block`` (flat block id per row), ``row_pts`` (m, P, 2) int32 relative
    to the block's first pixel, ``row_bidx`` (index of the row's block in ``blocks``) and
    ``blocks`` (distinct flat block ids).  ``row_pts`` has at least ``slack`` rows more than
    there are rows, all padding (points far away), like the unused slots of a row.
    """
    n_pairs = pair_k.shape[0]
    # counting sort of the pairs by block id
    counts = np.zeros(n_ids + 1, np.int64)
    for j in range(n_pairs):
        counts[pair_k[j] + 1] += 1
    n_blocks = 0
    for k in range(n_ids):
        if counts[k + 1]:
            n_blocks += 1
        counts[k + 1] += counts[k]
    members = np.empty(n_pairs, np.int64)
    for j in range(n_pairs):
        k = pair_k[j]
        members[counts[k]] = pair_i[j]
        counts[k] += 1
    # counts[k] is now the end of block k's members (and the start of block k + 1's).
    # Third rule, among the batch's own points: the member q whose window covers the block
    # with the smallest squared distance U to its farthest block corner is kept (its
    # nearest pixel is nearer than that corner), so every pixel ends at most U; a member
    # whose squared distance to the block is >= U cannot lower any pixel.  Rows get the
    # survivors; every block keeps at least one, so the rows fit in this bound:
    cap = n_blocks + n_pairs // n_points_row + 1
    row_block = np.empty(cap, np.int64)
    row_bidx = np.empty(cap, np.int64)
    row_pts = np.full((cap + slack, n_points_row, 2), -(half + 2 * b + 1), np.int32)
    blocks = np.empty(n_blocks, np.int64)
    row = 0
    j = 0
    start = 0
    for k in range(n_ids):
        stop = counts[k]
        if stop == start:
            continue
        org_r, org_c = _block_origin(keys, k, t, b)
        u = _FAR_BOUND
        for m in range(start, stop):
            i = members[m]
            far_r = max(abs(pr[i] - org_r), abs(pr[i] - org_r - b + 1))
            far_c = max(abs(pc[i] - org_c), abs(pc[i] - org_c - b + 1))
            if far_r <= half and far_c <= half:
                u = min(u, far_r * far_r + far_c * far_c)
        blocks[j] = k
        q = 0
        for m in range(start, stop):
            i = members[m]
            dr = max(org_r - pr[i], 0, pr[i] - org_r - b + 1)
            dc = max(org_c - pc[i], 0, pc[i] - org_c - b + 1)
            if dr * dr + dc * dc >= u:
                continue
            row_pts[row, q, 0] = pr[i] - org_r
            row_pts[row, q, 1] = pc[i] - org_c
            row_block[row] = k
            row_bidx[row] = j
            q += 1
            if q == n_points_row:
                q = 0
                row += 1
        if q:
            row += 1
        j += 1
        start = stop
    return row_block[:row], row_pts, row_bidx[:row], blocks


@cached_njit(nogil=True)
def _merge_rows(d2, row_block, row_bidx, rows, n_rows, start, t, b, lo_a, hi_a, lo_c, hi_c):
    """``d2 = min(d2, rows)`` for kernel rows ``start .. start + n_rows`` (one batch, as
    the kernel returned it); widen each block's box of changed pixels (``lo_a`` .. ``hi_c``,
    indexed by the row's distinct block, empty as ``lo = b, hi = -1``)."""
    bsh = _log2(b)
    nb = t >> bsh
    nsh = _log2(nb)
    cols = np.empty(b, np.bool_)
    dst = _flat(d2)
    src = _flat(rows)
    for ii in range(n_rows):
        i = start + ii
        k = row_block[i]
        j = row_bidx[i]
        s, lbr, lbc = _unflat(k, nsh)
        p = _U64((s * t + lbr * b) * t + lbc * b)
        o = _U64(ii * b * b)
        # branch-free inner loop (vectorises): store the minimum, OR the "lowered" flags
        cols[:] = False
        for a in range(b):
            row_low = False
            for c in range(b):
                v = src[o + _U64(c)]
                w = dst[p + _U64(c)]
                low = v < w
                dst[p + _U64(c)] = min(v, w)
                cols[c] |= low
                row_low |= low
            if row_low:
                lo_a[j] = min(lo_a[j], a)
                hi_a[j] = max(hi_a[j], a)
            p += _U64(t)
            o += _U64(b)
        for c in range(b):
            if cols[c]:
                lo_c[j] = min(lo_c[j], c)
                hi_c[j] = max(hi_c[j], c)


@cached_njit(nogil=True)
def _finish_merge(d2, bmax, blocks, t, b, halo, lo_a, hi_a, lo_c, hi_c, nbr9, dirty, tile_dirty):
    """After :func:`_merge_rows`: update the maxima of the changed blocks and mark
    ridge-dirty (``dirty[slot, block_row, block_col]``, and ``tile_dirty[slot]``) every
    block whose ridges must be recomputed: a changed block itself, and each neighbouring
    block (in any tile) that lies within ``halo`` pixels of one of its changed pixels.
    Returns the number of changed blocks."""
    bsh = _log2(b)
    nb = t >> bsh
    nsh = _log2(nb)
    n_changed = 0
    flat = _flat(d2)
    for j in range(blocks.shape[0]):
        if hi_a[j] < 0:
            continue
        n_changed += 1
        s, lbr, lbc = _unflat(blocks[j], nsh)
        dy0 = -1 if lo_a[j] < halo else 0
        dy1 = 1 if hi_a[j] >= b - halo else 0
        dx0 = -1 if lo_c[j] < halo else 0
        dx1 = 1 if hi_c[j] >= b - halo else 0
        for dy in range(dy0, dy1 + 1):
            nbr_r, oy = _wrap_into_tile(lbr + dy, nb)
            for dx in range(dx0, dx1 + 1):
                nbr_c, ox = _wrap_into_tile(lbc + dx, nb)
                ns = nbr9[s, 3 * oy + ox]
                if ns >= 0:
                    dirty[ns, nbr_r, nbr_c] = True
                    tile_dirty[ns] = True
        mx = 0
        p = _U64((s * t + lbr * b) * t + lbc * b)
        for _ in range(b):
            for c in range(b):
                mx = max(mx, flat[p + _U64(c)])
            p += _U64(t)
        bmax[s, lbr, lbc] = mx
    return n_changed


def flush_splat(mapper) -> int:
    """Splat all pending new obstacle pixels; returns the number of changed blocks."""
    if not mapper._pending:
        return 0
    mapper.compile()
    pts = np.concatenate(mapper._pending)
    mapper._pending = []
    mapper._n_pending = 0
    tiles = mapper._tiles
    t, b, half = mapper.tile_px, mapper.block_px, mapper._half
    nb = t // b
    grid, (g0r, g0c) = tiles.slot_grid
    bmax = tiles.layer("block_max")
    pr, pc = np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1])
    bound, rowmax = _batch_bound(pr, pc, grid, g0r, g0c, t, b, half, bmax, tiles.n_tiles)
    args = (
        grid,
        g0r,
        g0c,
        t,
        b,
        half,
        bound,
        rowmax,
        tiles.layer("hits"),
        min(DOMINANCE_PX, half - 1),
    )
    pool = _worker_pool() if pts.shape[0] >= PARALLEL_MIN_POINTS else None
    if pool is None:
        pair_k, pair_i, n_pairs = _splat_pairs(pr, pc, 0, 1, *args)
        pair_k, pair_i = pair_k[:n_pairs], pair_i[:n_pairs]
    else:
        # every other point on the worker thread (numba releases the GIL)
        other = pool.submit(_splat_pairs, pr, pc, 1, 2, *args)
        ka, ia, na = _splat_pairs(pr, pc, 0, 2, *args)
        kb, ib, nb_ = other.result()
        pair_k = np.concatenate((ka[:na], kb[:nb_]))
        pair_i = np.concatenate((ia[:na], ib[:nb_]))
    row_block, row_pts, row_bidx, blocks = _splat_group(
        pair_k,
        pair_i,
        pr,
        pc,
        tiles.keys,
        tiles.n_tiles * nb * nb,
        t,
        b,
        half,
        SPLAT_POINTS,
        _max_padding(SPLAT_ROWS),  # so that every batch below is a view
    )
    n_rows = row_block.shape[0]
    if n_rows == 0:
        return 0
    d2 = tiles.layer("sq_distance")
    n_blocks = blocks.shape[0]
    lo_a = np.full(n_blocks, b, np.int64)
    hi_a = np.full(n_blocks, -1, np.int64)
    lo_c = np.full(n_blocks, b, np.int64)
    hi_c = np.full(n_blocks, -1, np.int64)
    # Dispatch every batch first (JAX runs them asynchronously), then merge each one
    # as it arrives: the merge of one batch overlaps the kernel of the next.
    batches = [
        (
            start,
            stop,
            _splat_blocks(row_pts[start : start + size], size=b, half_width=half),
        )
        for start, stop, size in _batches(n_rows, SPLAT_ROWS)
    ]
    for start, stop, res in batches:
        _merge_rows(
            d2,
            row_block,
            row_bidx,
            np.asarray(res),
            stop - start,
            start,
            t,
            b,
            lo_a,
            hi_a,
            lo_c,
            hi_c,
        )
    return _finish_merge(
        d2,
        bmax,
        blocks,
        t,
        b,
        HALO_PX,
        lo_a,
        hi_a,
        lo_c,
        hi_c,
        tiles.neighbour_slots(),
        tiles.layer("ridge_dirty"),
        tiles.dirty_flags("ridge"),
    )
