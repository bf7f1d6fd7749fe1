"""Graph patch kernels: the region ``Z`` around changed skeleton pixels, the skeleton
pixels near the old edges, and path signatures.
"""

from __future__ import annotations

import numpy as np

from .._jit import cached_njit
from ._tiles import _U64, _around, _clear_region, _flat, _locate, _log2


@cached_njit(nogil=True, inline="always")
def _add_to_z(g, r, c, m, mk, gi, sk, zr, zc, gid, skz):
    """Append the pixel at flat storage offset ``g`` (global ``(r, c)``) to Z unless it is
    there already (``mk`` bit 4); returns the new length."""
    if mk[g] & 4:
        return m
    mk[g] |= 4
    gid[m] = gi[g]
    skz[m] = sk[g]
    zr[m] = r
    zc[m] = c
    return m + 1


@cached_njit(nogil=True)
def _region_z(sr, sc, grid, g0r, g0c, nbr9, t, mark, graph_id, skeleton):
    """The region Z: the *net* changed pixels dilated by one (3 x 3), without repeats,
    with the ``graph_id`` and ``skeleton`` values there.

    The graph covers every pixel of the skeleton it was built from (``graph_id != -1``
    exactly there), so a listed pixel whose skeleton value changed and changed back since
    the last graph update is no change and is skipped.  Pixels of missing tiles read -1 /
    False.  Returns ``zr, zc, gid, skz``.  One tile lookup per changed pixel; its
    neighbours are reached through ``nbr9`` (:meth:`TileManager.neighbour_slots`).

    ``mark`` (scratch uint8 layer) is zero on entry; on exit bit 4 is set on Z, for
    :func:`_near_skeleton`, which clears it (or :func:`_clear_region` on an error in
    between).
    """
    tsh = _log2(t)
    n = sr.shape[0]
    zr = np.empty(9 * n, np.int64)
    zc = np.empty(9 * n, np.int64)
    gid = np.empty(9 * n, np.int32)
    skz = np.empty(9 * n, np.bool_)
    mk = _flat(mark)
    gi = _flat(graph_id)
    sk = _flat(skeleton)
    m = 0
    for i in range(n):
        s0, lr0, lc0 = _locate(grid, g0r, g0c, tsh, sr[i], sc[i])
        if s0 >= 0 and skeleton[s0, lr0, lc0] == (graph_id[s0, lr0, lc0] != -1):
            continue
        if s0 >= 0 and 0 < lr0 < t - 1 and 0 < lc0 < t - 1:
            # the 3 x 3 neighbourhood lies in this tile: flat offsets
            f = _U64((s0 * t + lr0 - 1) * t + lc0 - 1)
            for dr in range(3):
                for dc in range(3):
                    g = f + _U64(dc)
                    r, c = sr[i] + dr - 1, sc[i] + dc - 1
                    m = _add_to_z(g, r, c, m, mk, gi, sk, zr, zc, gid, skz)
                f += _U64(t)
            continue
        for k in range(9):
            s, nr, nc = _around(nbr9, s0, lr0, lc0, k, t)
            if s >= 0:
                g = _U64((s * t + nr) * t + nc)
                r, c = sr[i] + k // 3 - 1, sc[i] + k % 3 - 1
                m = _add_to_z(g, r, c, m, mk, gi, sk, zr, zc, gid, skz)
            else:
                # outside the allocated tiles: only possible one pixel off the bbox;
                # repeats there are harmless
                gid[m] = -1
                skz[m] = False
                zr[m] = sr[i] + k // 3 - 1
                zc[m] = sc[i] + k % 3 - 1
                m += 1
    return zr[:m], zc[:m], gid[:m], skz[:m]


def _interior(off: np.ndarray) -> np.ndarray:
    """Mask of the interior pixels (not first, not last) of CSR paths with offsets ``off``."""
    inner = np.ones(int(off[-1]), bool)
    inner[off[:-1]] = False
    inner[off[1:] - 1] = False
    return inner


def _signatures(paths: np.ndarray, off: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Orientation-free signatures of CSR pixel paths (length, hashed ends, hashed pixel
    sum); equal paths have equal signatures (matches are verified by comparison)."""
    u = paths.astype(np.uint64)
    h = (u[:, 0] * np.uint64(0x9E3779B97F4A7C15)) ^ (u[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F))
    total = np.add.reduceat(h, off[:-1])
    e0 = h[off[:-1]]
    e1 = h[off[1:] - 1]
    return list(
        zip(
            np.diff(off).tolist(),
            np.minimum(e0, e1).tolist(),
            np.maximum(e0, e1).tolist(),
            total.tolist(),
            strict=True,
        )
    )


@cached_njit(nogil=True)
def _near_skeleton(ar, ac, zr, zc, qr, qc, grid, g0r, g0c, nbr9, t, mark, skeleton):
    """The skeleton pixels within one pixel (3 x 3) of the pixels A = ``(ar, ac)``.

    Returns their keys (:func:`_pack`, unsorted, without repeats), whether each lies in A
    and whether it lies in the region Z = ``(zr, zc)``, and whether each query pixel
    ``(qr, qc)`` lies in Z.  Work is proportional to the number of pixels, not to their
    bounding box.  ``mark`` (scratch uint8 layer) holds bit 4 on Z on entry (as
    :func:`_region_z` leaves it) and is zero on exit; bits: 1 collected, 2 in A, 4 in Z.
    """
    tsh = _log2(t)
    n = ar.shape[0]
    for i in range(n):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, ar[i], ac[i])
        if s >= 0:
            mark[s, lr, lc] |= 2
    keys = np.empty(9 * n, np.int64)
    in_a = np.empty(9 * n, np.bool_)
    in_z = np.empty(9 * n, np.bool_)
    m = 0
    for i in range(n):
        s0, lr0, lc0 = _locate(grid, g0r, g0c, tsh, ar[i], ac[i])
        if s0 < 0:
            continue
        for k in range(9):
            s, nr, nc = _around(nbr9, s0, lr0, lc0, k, t)
            if s < 0 or not skeleton[s, nr, nc] or mark[s, nr, nc] & 1:
                continue
            f = mark[s, nr, nc]
            mark[s, nr, nc] = f | 1
            keys[m] = ((ar[i] + k // 3 - 1) << 32) + ac[i] + k % 3 - 1 + (1 << 31)
            in_a[m] = (f & 2) != 0
            in_z[m] = (f & 4) != 0
            m += 1
    q_in_z = np.zeros(qr.shape[0], np.bool_)
    for i in range(qr.shape[0]):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, qr[i], qc[i])
        if s >= 0:
            q_in_z[i] = (mark[s, lr, lc] & 4) != 0
    kr = keys[:m] >> 32  # the collected pixels, from their keys
    _clear_region(kr, keys[:m] - (kr << 32) - (1 << 31), grid, g0r, g0c, t, mark)
    _clear_region(ar, ac, grid, g0r, g0c, t, mark)
    _clear_region(zr, zc, grid, g0r, g0c, t, mark)
    return keys[:m], in_a[:m], in_z[:m], q_in_z


_KIND_CODE = {"isolated": 0, "end": 1, "ring": 2, "junction": 3}


_KIND_NAME = {v: k for k, v in _KIND_CODE.items()}
