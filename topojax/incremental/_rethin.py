"""Local re-thinning: the thinning history (``thin_time``) of the changed region is
recomputed, growing the region until nothing outside it changes.
"""

from __future__ import annotations

import numpy as np

from .._jit import cached_njit
from ..skeleton import compact
from ._tiles import _log2, _slot, _unflat, _wrap_into_tile

#: Side (px, a power of two) of the blocks the exact re-thinning activates (at most
#: ``block_px``).
RETHIN_BLOCK_PX = 8


#: The exact re-thinning activates the block of each changed ridge pixel, and the
#: neighbour block on each side where the pixel lies within this many pixels of the
#: border (at least 1: every 8-neighbour of a changed pixel must be active; a larger
#: margin costs pixels, a smaller one extra rounds of the leak check).
SEED_MARGIN_PX = 3


_SURVIVOR = 65535  # ``thin_time`` of a pixel that thinning keeps


# (d_row, d_col) of neighbour bit k of the thinning code (E, NE, N, NW, W, SW, S, SE)
_THIN_DR = np.array([0, -1, -1, -1, 0, 1, 1, 1], np.int64)


_THIN_DC = np.array([1, 1, 0, -1, -1, -1, 0, 1], np.int64)


@cached_njit(nogil=True)
def _seed_blocks(rows, cols, grid, g0r, g0c, nb, b, bid, blk, margin):
    """List (``blk`` rows ``(slot, block_row, block_col)``) the allocated blocks containing
    the pixels, and the blocks next to them on the sides where a pixel lies within
    ``margin`` (``>= 1``) pixels of its block's border, and store each one's row of
    ``blk`` in ``bid[slot, block_row, block_col]`` (-1 elsewhere, as on entry); returns
    how many were listed."""
    bsh = _log2(b)
    nsh = _log2(nb)
    nm = nb - 1
    n = 0
    prev = (np.int64(0), np.int64(-1), np.int64(0), np.int64(-1))
    for i in range(rows.shape[0]):
        gbr = rows[i] >> bsh
        gbc = cols[i] >> bsh
        lr = rows[i] & (b - 1)
        lc = cols[i] & (b - 1)
        r0 = gbr - 1 if lr < margin else gbr
        r1 = gbr + 1 if lr >= b - margin else gbr
        c0 = gbc - 1 if lc < margin else gbc
        c1 = gbc + 1 if lc >= b - margin else gbc
        if (r0, r1, c0, c1) == prev:  # changed pixels come in runs: same blocks again
            continue
        prev = (r0, r1, c0, c1)
        for br in range(r0, r1 + 1):
            for bc in range(c0, c1 + 1):
                s = _slot(grid, g0r, g0c, nsh, br, bc)  # blocks are the "pixels" of a tile
                if s < 0:
                    continue
                lbr = br & nm
                lbc = bc & nm
                if bid[s, lbr, lbc] < 0:
                    bid[s, lbr, lbc] = n
                    blk[n, 0] = s
                    blk[n, 1] = lbr
                    blk[n, 2] = lbc
                    n += 1
    return n


@cached_njit(nogil=True)
def _list_active(ridge, tflat, blk, n_blk, t, b, zo, n_zo):
    """List ``I``, the ridge pixels of the active blocks, and clear the history of their
    pixels that are no longer ridge.

    Nothing reads the history of a non-ridge pixel inside the active blocks, so clearing
    it is safe; the survivors among them are appended to ``zo[:n_zo]`` (grown when it
    lacks room for every pixel of the blocks).

    Returns
    -------
    lidx : int32 array (n_blk, b, b)
        Index in ``I`` of each pixel of each active block, -1 off the ridge.
    pix : int64 array (>= n,)
        Flat index (``slot * t^2 + row * t + col``) of each pixel of ``I``.
    n : int
        Size of ``I``.
    zo, n_zo : int64 array, int
        The cleared survivors so far.
    """
    tt = t * t
    if zo.shape[0] < n_zo + n_blk * b * b:
        grown = np.empty(n_zo + n_blk * b * b, np.int64)
        grown[:n_zo] = zo[:n_zo]
        zo = grown
    lidx = np.empty((n_blk, b, b), np.int32)
    pix = np.empty(n_blk * b * b, np.int64)
    n = 0
    for j in range(n_blk):
        s, br, bc = blk[j, 0], blk[j, 1], blk[j, 2]
        for a in range(b):
            base = s * tt + (br * b + a) * t + bc * b
            for c in range(b):
                f = base + c
                if ridge[f]:
                    pix[n] = f
                    lidx[j, a, c] = n
                    n += 1
                    continue
                lidx[j, a, c] = -1
                if tflat[f] != 0:
                    if tflat[f] == _SURVIVOR:
                        zo[n_zo] = f
                        n_zo += 1
                    tflat[f] = 0
    return lidx, pix, n, zo, n_zo


@cached_njit(nogil=True)
def _block_neighbours(blk, n_blk, nbr9, bid, t, b):
    """The 3 x 3 blocks around each active block, in row-major order.

    Returns
    -------
    nact : int64 array (n_blk, 9)
        Row of ``blk`` of each neighbour block, -1 where it is not active.
    nbase : int64 array (n_blk, 9)
        Flat index of each neighbour block's first pixel, -1 where its tile is not
        allocated.
    """
    tt = t * t
    nact = np.empty((n_blk, 9), np.int64)
    nbase = np.empty((n_blk, 9), np.int64)
    n_side = t >> _log2(b)  # blocks per tile side
    for j in range(n_blk):
        s, br, bc = blk[j, 0], blk[j, 1], blk[j, 2]
        for oy in range(3):
            rr, ty = _wrap_into_tile(br + oy - 1, n_side)
            for ox in range(3):
                cc, tx = _wrap_into_tile(bc + ox - 1, n_side)
                ns = nbr9[s, 3 * ty + tx]
                if ns < 0:
                    nact[j, 3 * oy + ox] = -1
                    nbase[j, 3 * oy + ox] = -1
                else:
                    nact[j, 3 * oy + ox] = bid[ns, rr, cc]
                    nbase[j, 3 * oy + ox] = ns * tt + (rr * b) * t + cc * b
    return nact, nbase


@cached_njit(nogil=True)
def _neighbour_table(lidx, n, nact, nbase, tflat, t, b, dr8, dc8):
    """Every 8-neighbour of every pixel of ``I`` as an index into the thinning's state
    array: ``0 .. n-1`` the pixels of ``I``; ``n`` always off (no ridge, or no tile);
    ``n + 1`` always on (a ring survivor); ``n + 2 + m`` a ring pixel deleted at its old
    time ``ring_tau[m]`` (one slot per reference).  The thinning then reads eight states
    without a branch.

    Returns
    -------
    nbt : int64 array (n, 8)
        The table, neighbours in the order of ``dr8, dc8``.
    ring_tau : int64 array (>= n_ring,)
        Old deletion time of each ring reference.
    n_ring, ring_max : int
        Number of ring references and their latest deletion time (0 if none).
    """
    bsh = _log2(b)
    bm = b - 1
    nbt = np.empty((n, 8), np.int64)
    ring_tau = np.empty(8 * n, np.int64)
    n_ring = 0
    ring_max = 0
    i = 0
    for j in range(lidx.shape[0]):
        for a in range(b):
            for c in range(b):
                if lidx[j, a, c] < 0:
                    continue
                for k in range(8):
                    # neighbour by shifts and masks within the 3 x 3 blocks around j
                    ay = a + dr8[k] + b
                    ax = c + dc8[k] + b
                    o = 3 * (ay >> bsh) + (ax >> bsh)
                    la = ay & bm
                    lc = ax & bm
                    q = nact[j, o]
                    if q >= 0:
                        v = lidx[q, la, lc]
                        nbt[i, k] = v if v >= 0 else n  # -1: off the ridge
                    else:
                        base = nbase[j, o]
                        tq = 0 if base < 0 else np.int64(tflat[base + la * t + lc])
                        if tq == 0:
                            nbt[i, k] = n
                        elif tq == _SURVIVOR:
                            nbt[i, k] = n + 1
                        else:
                            nbt[i, k] = n + 2 + n_ring
                            ring_tau[n_ring] = tq
                            n_ring += 1
                            ring_max = max(ring_max, tq)
                i += 1
    return nbt, ring_tau, n_ring, ring_max


@cached_njit(nogil=True)
def _thin_active(nbt, n, ring_tau, n_ring, ring_max, tables):
    """Thin ``I`` sub-iteration by sub-iteration, the ring following its old history
    (:func:`_neighbour_table`), until two quiet sub-iterations after the ring's last
    deletion.

    Returns
    -------
    int64 array (n,): the new deletion time of each pixel of ``I``.
    """
    alive = np.ones(n + 2 + n_ring, np.uint8)
    alive[n] = 0
    tnew = np.full(n, _SURVIVOR, np.int64)
    live = np.arange(n)
    n_live = n
    dels = np.empty(n, np.int64)
    s_it = 0
    quiet = 0
    while not (quiet >= 2 and s_it - 2 >= ring_max):
        lut = tables[s_it & 1]
        for m in range(n_ring):  # ring pixels deleted at this sub-iteration
            if ring_tau[m] == s_it:
                alive[n + 2 + m] = 0
        nd = 0
        for ii in range(n_live):
            i = live[ii]
            code = 0
            for k in range(8):
                code |= np.int64(alive[nbt[i, k]]) << k
            if lut[code]:
                dels[nd] = i
                nd += 1
        for jj in range(nd):
            alive[dels[jj]] = 0
            tnew[dels[jj]] = s_it + 1
        if nd:
            n_live = compact(live, n_live, alive)
            quiet = 0
        else:
            quiet += 1
        s_it += 1
    return tnew


@cached_njit(nogil=True)
def _grow_active(pix, n, tnew, nbt, ring_tau, tflat, nbr9, bid, blk, n_blk, t, b, dr8, dc8):
    """Check the ring: activate (append to ``blk``, index in ``bid``) the block of every
    ring pixel that sees a neighbour in ``I`` change state while it is alive, i.e. with
    ``min(tau_new(p), tau(q)) != min(tau_old(p), tau(q))``.

    Returns
    -------
    int: the new number of active blocks (``n_blk`` when the ring is exact).
    """
    tsh = _log2(t)
    bsh = _log2(b)
    for i in range(n):
        f = pix[i]
        told = np.int64(tflat[f])
        for k in range(8):
            v = nbt[i, k]
            if v > n:  # a ring pixel on the ridge
                tq = _SURVIVOR if v == n + 1 else ring_tau[v - n - 2]
                if min(tnew[i], tq) != min(told, tq):
                    s, lr, lc = _unflat(f, tsh)
                    nr, oy = _wrap_into_tile(lr + dr8[k], t)
                    nc, ox = _wrap_into_tile(lc + dc8[k], t)
                    ns = nbr9[s, 3 * oy + ox]
                    if bid[ns, nr >> bsh, nc >> bsh] < 0:
                        # joins the active set from the next round on
                        bid[ns, nr >> bsh, nc >> bsh] = n_blk
                        blk[n_blk, 0] = ns
                        blk[n_blk, 1] = nr >> bsh
                        blk[n_blk, 2] = nc >> bsh
                        n_blk += 1
    return n_blk


@cached_njit(nogil=True)
def _write_back(pix, n, tnew, tflat, zo, n_zo):
    """Store the new deletion times of ``I``; returns the flat indices of the pixels whose
    thinned state changed (those of ``I`` first, then the cleared survivors ``zo``)."""
    out = np.empty(n + n_zo, np.int64)
    m = 0
    for i in range(n):
        f = pix[i]
        was = tflat[f] == _SURVIVOR
        if was != (tnew[i] == _SURVIVOR):
            out[m] = f
            m += 1
        tflat[f] = tnew[i]
    out[m : m + n_zo] = zo[:n_zo]
    m += n_zo
    return out[:m]


@cached_njit(nogil=True)
def _rethin(ridge, tau, nbr9, t, b, bid, blk, n_blk, tables, dr8, dc8):
    """Exact local re-thinning around changed ridge pixels (see ``skeleton_exact``).

    ``tau[slot, row, col]`` (uint16) holds every pixel's *deletion time* under the
    parallel thinning of the whole current ridge map: 0 off the ridge, ``s + 1`` for a
    ridge pixel deleted by sub-iteration ``s``, :data:`_SURVIVOR` for a skeleton pixel.  A
    pixel's state at the start of sub-iteration ``s`` is ``tau > s``.

    ``blk[:n_blk]`` (rows ``(slot, block_row, block_col)``; capacity for every block of
    the map) are the *active* blocks: at least every block containing a changed ridge
    pixel or one of its 8 neighbour pixels (:func:`_seed_blocks`; a removed ridge pixel
    is in no ``I``, so its neighbours must be).  Their ridge pixels ``I`` are thinned
    again, sub-iteration by sub-iteration, reading the pixels outside the active blocks
    (the *ring*) from their old ``tau``.  That is exact when every ring pixel ``q``
    sees, at every sub-iteration while it is alive, the same states of its neighbours in
    ``I`` as before (then, by induction over sub-iterations, nothing outside changes):
    ``min(tau_new(p), tau(q)) == min(tau_old(p), tau(q))``.  Blocks of ring pixels that
    fail this are activated and the round is repeated; the active set only grows, and
    once it covers whole components there is no ring, so this ends.  ``bid`` (int32,
    ``(n_slots, nb, nb)``) holds the row of ``blk`` of every active block and -1
    elsewhere (as :func:`_seed_blocks` leaves it); it is all -1 on exit.

    A round lists ``I`` (:func:`_list_active`), tabulates its neighbours
    (:func:`_block_neighbours`, :func:`_neighbour_table`), thins it
    (:func:`_thin_active`) and checks the ring (:func:`_grow_active`); the new history is
    written back once no ring pixel fails (:func:`_write_back`).

    Returns the flat indices (``slot * t^2 + row * t + col``) of the pixels whose thinned
    state (``tau == _SURVIVOR``) changed, the number of rounds and the size of ``I`` in the
    last round.  ``tau`` is updated in place.
    """
    tflat = tau.reshape(-1)
    zo = np.empty(0, np.int64)  # survivors cleared from the history (no longer ridge)
    n_zo = 0
    rounds = 0
    while True:
        rounds += 1
        lidx, pix, n, zo, n_zo = _list_active(ridge, tflat, blk, n_blk, t, b, zo, n_zo)
        nact, nbase = _block_neighbours(blk, n_blk, nbr9, bid, t, b)
        nbt, ring_tau, n_ring, ring_max = _neighbour_table(
            lidx, n, nact, nbase, tflat, t, b, dr8, dc8
        )
        tnew = _thin_active(nbt, n, ring_tau, n_ring, ring_max, tables)
        grown = _grow_active(
            pix, n, tnew, nbt, ring_tau, tflat, nbr9, bid, blk, n_blk, t, b, dr8, dc8
        )
        if grown == n_blk:
            break
        n_blk = grown
    out = _write_back(pix, n, tnew, tflat, zo, n_zo)
    for j in range(n_blk):
        bid[blk[j, 0], blk[j, 1], blk[j, 2]] = -1
    return out, rounds, n


def thin_components(
    rows: np.ndarray,
    cols: np.ndarray,
    bounds: tuple[int, int, int, int],
    *,
    method: str = "guo_hall",
    remove_t: bool = True,
) -> np.ndarray:
    """Skeleton of whole 8-connected components, thinned on a crop of their own.

    Thinning and T-centre removal decide every pixel from its 8 (4) neighbours, so they act
    on each 8-connected component independently.  T removal treats the image border
    specially (a 1-D rule, applied after the interior), so the crop's border must be the
    image border or lie at least one pixel from every component pixel; this function
    chooses it so.  The result then equals ``remove_t_centres(thin(image))`` at these
    pixels for any image of which these are whole components (tested).

    Parameters
    ----------
    rows, cols : int arrays (n,)
        The pixels of one or more whole components (any order).
    bounds : (row0, col0, row1, col1)
        The image the pixels live in (end exclusive): its border rows/columns get the
        border rule.
    method : {"guo_hall", "zhang"}
    remove_t : bool

    Returns
    -------
    bool array (n,): skeleton value of each pixel.
    """
    from ..skeleton import skeletonize_ridges

    if rows.size == 0:
        return np.zeros(0, bool)
    r_lo = max(int(rows.min()) - 1, bounds[0])
    r_hi = min(int(rows.max()) + 1, bounds[2] - 1)
    c_lo = max(int(cols.min()) - 1, bounds[1])
    c_hi = min(int(cols.max()) + 1, bounds[3] - 1)
    img = np.zeros((r_hi - r_lo + 1, c_hi - c_lo + 1), bool)
    img[rows - r_lo, cols - c_lo] = True
    sk = skeletonize_ridges(img, method=method, remove_t=remove_t)
    return sk[rows - r_lo, cols - c_lo]
