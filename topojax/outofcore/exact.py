"""Thinning and T-centre removal of one window of a larger ridge map, and which of its
pixels provably come out as in the whole map's skeleton (the set ``U`` of pixels that may
differ is tracked; the argument is in ``docs/large-maps.md``).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .._jit import cached_njit
from ..skeleton import TABLES_U8

__all__ = ["exact_after_t_removal", "remove_t_in_map_order", "thin_window", "uniform_tables"]


@lru_cache(maxsize=4)
def uniform_tables(method: str) -> np.ndarray:
    """uint8 (2, 256, 256): entry ``[s, known, free]`` is 1 when the deletion table of
    sub-iteration ``s`` gives one decision for every neighbourhood code that agrees with
    ``known`` outside the bits of ``free`` (``known & free == 0``)."""
    lut = TABLES_U8[method]
    out = np.zeros((2, 256, 256), np.uint8)
    codes = np.arange(256)
    for free in range(256):
        bits = [1 << k for k in range(8) if free >> k & 1]
        subsets = np.zeros(1, np.int64)
        for b in bits:
            subsets = np.concatenate([subsets, subsets | b])
        known = codes[(codes & free) == 0]
        for s in range(2):
            values = lut[s][known[:, None] | subsets[None, :]]
            out[s, known, free] = (values == values[:, :1]).all(axis=1)
    return out


@cached_njit(nogil=True)
def _thin_tracked(img, unk, n_cols, tables, uniform):
    """Thin the framed uint8 image ``img`` (raveled, rows of ``n_cols``) in place while
    growing the uint8 mask ``unk`` of pixels that may differ from the whole map's; return
    the number of sub-iterations run.  The frame rows and columns of ``img`` are 0; those
    of ``unk`` are 1 where the map goes on beyond the window."""
    offs = np.array(
        [1, 1 - n_cols, -n_cols, -n_cols - 1, -1, n_cols - 1, n_cols, n_cols + 1], np.int64
    )
    n = img.shape[0]
    alive = np.empty(n, np.int64)
    n_alive = 0
    for p in range(n):
        if img[p]:
            alive[n_alive] = p
            n_alive += 1
    dels = np.empty(n_alive + 1, np.int64)
    grow = np.empty(n_alive + 1, np.int64)
    t = 0
    quiet = 0
    while True:
        lut = tables[t & 1]
        uni = uniform[t & 1]
        n_del = 0
        n_grow = 0
        for i in range(n_alive):
            p = alive[i]
            code = 0
            mask = 0
            for k in range(8):
                q = p + offs[k]
                code |= img[q] << k
                mask |= unk[q] << k
            if lut[code]:
                dels[n_del] = p
                n_del += 1
            if unk[p] == 0 and mask != 0 and uni[code & ~mask & 255, mask] == 0:
                grow[n_grow] = p
                n_grow += 1
        for i in range(n_del):
            img[dels[i]] = 0
        for i in range(n_grow):
            unk[grow[i]] = 1
        quiet = quiet + 1 if n_del == 0 and n_grow == 0 else 0
        t += 1
        if quiet >= 2:
            return t
        m = 0
        for i in range(n_alive):
            p = alive[i]
            alive[m] = p
            m += 1 if img[p] else 0
        n_alive = m


def thin_window(ridges: np.ndarray, beyond: tuple[bool, bool, bool, bool], method: str):
    """Thin a window of a ridge map and find the pixels whose result is the whole map's.

    Parameters
    ----------
    ridges : bool (h, w)
        The window's ridges, exact (those the whole map's thinning starts from).
    beyond : (top, bottom, left, right) of bool
        Whether the map goes on beyond each side of the window.
    method : {"guo_hall", "zhang"}

    Returns
    -------
    skeleton : uint8 (h, w)
        The window's thinning (0 / 1).
    unsure : bool (h + 2, w + 2)
        The pixels that may differ from the whole map's thinning, with a one-pixel frame
        around the window (True on the sides where the map goes on).
    sub_iterations : int
    """
    h, w = ridges.shape
    img = np.zeros((h + 2, w + 2), np.uint8)
    img[1:-1, 1:-1] = ridges
    unk = np.zeros((h + 2, w + 2), np.uint8)
    top, bottom, left, right = beyond
    unk[0, :] = top
    unk[-1, :] = bottom
    unk[:, 0] |= left
    unk[:, -1] |= right
    n = _thin_tracked(
        img.reshape(-1), unk.reshape(-1), w + 2, TABLES_U8[method], uniform_tables(method)
    )
    return img[1:-1, 1:-1].copy(), unk.astype(bool), n


@cached_njit(nogil=True)
def remove_t_in_map_order(img, r0, c0, map_h, map_w):
    """T-centre removal on the window ``img`` (uint8 (h, w), in place) of a map of shape
    ``(map_h, map_w)`` whose first pixel is map pixel ``(r0, c0)``, visiting the window's
    pixels in the order the whole map's removal visits them (map-interior pixels in raster
    order, then map row 0, row H-1, column 0, column W-1); pixels outside the window read
    as unset.  Returns the number of cleared pixels."""
    h, w = img.shape
    cleared = 0
    for phase in range(5):
        for r in range(h):
            gr = r0 + r
            for c in range(w):
                gc = c0 + c
                row_edge = gr == 0 or gr == map_h - 1
                col_edge = gc == 0 or gc == map_w - 1
                if phase == 0:
                    ok = not row_edge and not col_edge
                elif phase == 1:
                    ok = gr == 0 and not col_edge
                elif phase == 2:
                    ok = gr == map_h - 1 and gr != 0 and not col_edge
                elif phase == 3:
                    ok = gc == 0 and not row_edge
                else:
                    ok = gc == map_w - 1 and gc != 0 and not row_edge
                if not ok or not img[r, c]:
                    continue
                n = 0
                if r > 0 and img[r - 1, c]:
                    n += 1
                if r + 1 < h and img[r + 1, c]:
                    n += 1
                if c > 0 and img[r, c - 1]:
                    n += 1
                if c + 1 < w and img[r, c + 1]:
                    n += 1
                if n >= 3:
                    img[r, c] = 0
                    cleared += 1
    return cleared


def _four_sum(framed: np.ndarray) -> np.ndarray:
    """Sum of the 4-neighbours of the interior of a framed array (int8 (h, w))."""
    f = framed.astype(np.int8)
    return f[:-2, 1:-1] + f[2:, 1:-1] + f[1:-1, :-2] + f[1:-1, 2:]


def exact_after_t_removal(skeleton: np.ndarray, unsure: np.ndarray, core) -> bool:
    """Whether T-centre removal settles every pixel of the ``core`` box of a thinned window.

    Parameters
    ----------
    skeleton : uint8 (h, w)
        The window's thinning (before T removal).
    unsure : bool (h + 2, w + 2)
        From :func:`thin_window`.
    core : (r0, r1, c0, c1)
        The box, in window coordinates.
    """
    from scipy import ndimage

    r0, r1, c0, c1 = core
    u_in = unsure[1:-1, 1:-1]
    if u_in[r0:r1, c0:c1].any():
        return False
    framed = np.zeros(unsure.shape, bool)
    framed[1:-1, 1:-1] = skeleton
    s = skeleton.astype(bool)
    unsure_near = (_four_sum(unsure) > 0) | u_in
    candidate = s & ~unsure_near & (_four_sum(framed) >= 3)
    unknown = s & unsure_near
    labels, _ = ndimage.label(candidate | unknown)  # 4-connected groups
    tainted = np.unique(labels[unknown])
    core_labels = labels[r0:r1, c0:c1]
    return not np.isin(core_labels[core_labels > 0], tainted).any()
