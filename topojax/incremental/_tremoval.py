"""Ordered T-centre removal update: the pixels whose inputs changed are re-examined in
the order of :func:`topojax.skeleton.remove_t_centres`, with a heap.
"""

from __future__ import annotations

import numpy as np

from .._heap import heap_pop, heap_push
from .._jit import cached_njit
from ._rethin import _SURVIVOR
from ._tiles import _locate, _log2, _wrap_into_tile

# a pixel and its 4 neighbours (up, down, left, right)
_T_DR5 = np.array([0, -1, 1, 0, 0], np.int64)


_T_DC5 = np.array([0, 0, 0, -1, 1], np.int64)


@cached_njit(nogil=True, inline="always")
def _t_order(rr, cc, h, w, sh):
    """Key of bbox pixel ``(rr, cc)`` in T-centre removal's examination order
    (:func:`topojax.skeleton.remove_t_centres`); -1 for the corners (never examined).
    Interior pixels are keyed ``rr * 2**sh + cc`` (``2**sh >= w``: raster order, and the
    decoding is a shift)."""
    hw = h << sh
    if 0 < rr < h - 1 and 0 < cc < w - 1:
        return (rr << sh) + cc
    if rr == 0 or rr == h - 1:
        if cc == 0 or cc == w - 1:
            return -1
        return hw + cc if rr == 0 else hw + w + cc
    return hw + 2 * w + rr if cc == 0 else hw + 2 * w + h + rr


@cached_njit(nogil=True, inline="always")
def _t_decode(o, h, w, sh):
    """Inverse of :func:`_t_order` for ``o >= 0``: the bbox pixel ``(rr, cc)``."""
    hw = h << sh
    if o < hw:
        return o >> sh, o & ((1 << sh) - 1)
    if o < hw + w:
        return 0, o - hw
    if o < hw + 2 * w:
        return h - 1, o - hw - w
    if o < hw + 2 * w + h:
        return o - hw - 2 * w, 0
    return o - hw - 2 * w - h, w - 1


@cached_njit(nogil=True)
def _t_seeds(skel, tau, grid, g0r, g0c, t, bbox, seed_r, seed_c, n_rule, remove_t, ch_r, ch_c):
    """First step of :func:`_t_update`: the examination-order keys (:func:`_t_order`) of
    the pixels to re-examine, unsorted, with repeats.

    The seeds are pixels whose thinned value changed; the first ``n_rule`` of them are
    instead pixels whose examination rule changed (a moved bounding-box border).  A
    changed thinned value is read by the pixel itself and by the 4-neighbours examined
    *before* it (later ones read its result, and are reached if that changes), so those
    are listed; for a changed rule, the pixel and all its 4-neighbours.  Seeds that T
    removal never examines (corners, or everything when ``remove_t`` is False) get the
    thinned value directly; those changes go to ``ch_r``, ``ch_c`` (room for every seed)
    and their number is returned too."""
    tsh = _log2(t)
    r0, c0, r1, c1 = bbox[0], bbox[1], bbox[2], bbox[3]
    h = r1 - r0
    w = c1 - c0
    osh = _log2(w)
    keys = np.empty(5 * seed_r.shape[0], np.int64)
    n_keys = 0
    n_ch = 0
    for i in range(seed_r.shape[0]):
        rr0 = seed_r[i] - r0
        cc0 = seed_c[i] - c0
        if not (0 <= rr0 < h and 0 <= cc0 < w):
            continue
        o0 = _t_order(rr0, cc0, h, w, osh)
        if o0 < 0 or not remove_t:
            # never examined: the skeleton is the thinned image here
            r = seed_r[i]
            c = seed_c[i]
            s, lr, lc = _locate(grid, g0r, g0c, tsh, r, c)
            if s >= 0:
                new = tau[s, lr, lc] == _SURVIVOR
                if new != skel[s, lr, lc]:
                    skel[s, lr, lc] = new
                    ch_r[n_ch] = r
                    ch_c[n_ch] = c
                    n_ch += 1
            if not remove_t:
                continue
        else:
            keys[n_keys] = o0
            n_keys += 1
        for k in range(1, 5):
            rr = rr0 + _T_DR5[k]
            cc = cc0 + _T_DC5[k]
            if not (0 <= rr < h and 0 <= cc < w):
                continue
            o = _t_order(rr, cc, h, w, osh)
            # a corner seed (o0 < 0) is read as a thinned value by all its neighbours
            if o >= 0 and (i < n_rule or o0 < 0 or o < o0):
                keys[n_keys] = o
                n_keys += 1
    return keys[:n_keys], n_ch


def _t_update(skel, tau, grid, g0r, g0c, nbr9, t, bbox, todo, ch_r, ch_c, n_ch, *, room=None):
    """Bring the skeleton (T-centre removal of the thinned image ``tau == _SURVIVOR``) up
    to date after the thinned state changed at some pixels (or their examination rule
    did: pixels of a moved bounding-box border).

    T removal examines pixels one at a time in a fixed order (:func:`_t_order`), so pixel
    ``p`` reads the *result* at 4-neighbours examined before it and the *thinned* value at
    the others.  ``todo`` holds the sorted, distinct keys of the changed pixels and their
    4-neighbours (:func:`_t_seeds`); they are re-examined in order, merged (through a
    heap) with every later 4-neighbour of a pixel whose result changes.  All other results
    keep their inputs and so their values.  Changed pixels are appended to ``ch_r``,
    ``ch_c`` after the first ``n_ch``; returns the arrays (possibly reallocated) and the
    new count.
    """
    n_todo = todo.shape[0]
    room = 2 * n_todo + 64 if room is None else room  # (tests resume from tiny arrays)
    heap = np.empty(max(8, 2 * room), np.int64)
    cap = n_ch + max(1, room)
    out_r = np.empty(cap, np.int64)
    out_c = np.empty(cap, np.int64)
    out_r[:n_ch] = ch_r[:n_ch]
    out_c[:n_ch] = ch_c[:n_ch]
    state = np.array([0, 0, -1, n_ch], np.int64)  # next todo, heap size, last key, changes
    # The compiled loop stops when an array could overflow; it is grown here and the
    # loop resumes (growing arrays inside the loop would make numba count references at
    # every step).
    while _t_run(skel, tau, grid, g0r, g0c, nbr9, t, bbox, todo, heap, out_r, out_c, state):
        if state[1] + 4 > heap.shape[0]:
            heap = np.concatenate((heap, np.empty(heap.shape[0], np.int64)))
        if state[3] + 1 > out_r.shape[0]:
            out_r = np.concatenate((out_r, np.empty(out_r.shape[0], np.int64)))
            out_c = np.concatenate((out_c, np.empty(out_c.shape[0], np.int64)))
    return out_r, out_c, int(state[3])


@cached_njit(nogil=True)
def _t_run(skel, tau, grid, g0r, g0c, nbr9, t, bbox, todo, heap, out_r, out_c, state):
    """The loop of :func:`_t_update`, resumable: ``state`` = (next todo entry, heap size,
    last key examined, number of changes), updated in place.  Returns True when it
    stopped early because ``heap`` or ``out_r`` / ``out_c`` might overflow."""
    tsh = _log2(t)
    r0, c0, r1, c1 = bbox[0], bbox[1], bbox[2], bbox[3]
    h = r1 - r0
    w = c1 - c0
    osh = _log2(w)
    n_todo = todo.shape[0]
    j = state[0]
    n_heap = state[1]
    last = state[2]
    n_ch = state[3]
    full = False
    while j < n_todo or n_heap:
        if n_heap + 4 > heap.shape[0] or n_ch + 1 > out_r.shape[0]:
            full = True
            break
        if n_heap and (j == n_todo or heap[0] < todo[j]):
            o, n_heap = heap_pop(heap, None, n_heap)
        else:
            o = todo[j]
            j += 1
        if o == last:
            continue
        last = o
        rr, cc = _t_decode(o, h, w, osh)
        r = rr + r0
        c = cc + c0
        s, lr, lc = _locate(grid, g0r, g0c, tsh, r, c)
        if s < 0:
            continue
        new = tau[s, lr, lc] == _SURVIVOR
        if new:
            cnt = 0
            for k in range(1, 5):
                qr = rr + _T_DR5[k]
                qc = cc + _T_DC5[k]
                if not (0 <= qr < h and 0 <= qc < w):
                    continue
                nr, oy = _wrap_into_tile(lr + _T_DR5[k], t)
                nc, ox = _wrap_into_tile(lc + _T_DC5[k], t)
                qs = nbr9[s, 3 * oy + ox]
                if qs < 0:
                    continue
                oq = _t_order(qr, qc, h, w, osh)
                if 0 <= oq < o:
                    cnt += 1 if skel[qs, nr, nc] else 0
                else:
                    cnt += 1 if tau[qs, nr, nc] == _SURVIVOR else 0
            if cnt >= 3:
                new = False
        if new != skel[s, lr, lc]:
            skel[s, lr, lc] = new
            out_r[n_ch] = r
            out_c[n_ch] = c
            n_ch += 1
            for k in range(1, 5):
                qr = rr + _T_DR5[k]
                qc = cc + _T_DC5[k]
                if 0 <= qr < h and 0 <= qc < w:
                    oq = _t_order(qr, qc, h, w, osh)
                    if oq > o:
                        n_heap = heap_push(heap, None, n_heap, oq, 0)
    state[0] = j
    state[1] = n_heap
    state[2] = last
    state[3] = n_ch
    return full
