"""The distance loop's CPU kernels: beam end points from a scan, Bresenham free-cell
counting, the tiles a scan needs and the integration of hits.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import cached_njit
from ._tiles import _UINT16_MAX, _locate, _log2, _slot

#: Beams whose free cells may wait for the next skeleton update (or an export); more
#: are counted at once.
RAY_BATCH_BEAMS = 1 << 16


@cached_njit(nogil=True)
def _scan_geometry(ranges, angle_min, angle_inc, range_min, range_max, sx, sy, syaw, res):
    """End pixels of the valid beams (same arithmetic as :meth:`Scan.endpoints_world`).

    A reading is valid when finite, > 0, >= ``range_min`` and < ``range_max``.  Returns
    rows, cols (int64) of the end pixels and their extent ``(min row, max row, min col,
    max col)`` (zeros without valid beams).
    """
    n = ranges.shape[0]
    er = np.empty(n, np.int64)
    ec = np.empty(n, np.int64)
    ext = np.zeros(4, np.int64)
    m = 0
    for i in range(n):
        r = np.float64(ranges[i])
        if not (math.isfinite(r) and r > 0.0 and r >= range_min and r < range_max):
            continue
        a = (angle_min + i * angle_inc) + syaw
        row = math.floor(-(sy + r * math.sin(a)) / res)
        col = math.floor((sx + r * math.cos(a)) / res)
        if m == 0 or row < ext[0]:
            ext[0] = row
        if m == 0 or row > ext[1]:
            ext[1] = row
        if m == 0 or col < ext[2]:
            ext[2] = col
        if m == 0 or col > ext[3]:
            ext[3] = col
        er[m] = row
        ec[m] = col
        m += 1
    return er[:m], ec[:m], ext


@cached_njit(nogil=True, inline="always")
def _bresenham_start(r, c, r1, c1):
    """Bresenham's line walk from (r, c) to (r1, c1): (dr, dc, stp_r, stp_c, err)."""
    dr = abs(r1 - r)
    dc = abs(c1 - c)
    return dr, dc, (1 if r1 > r else -1), (1 if c1 > c else -1), dc - dr


@cached_njit(nogil=True, inline="always")
def _bresenham_step(r, c, err, dr, dc, stp_r, stp_c):
    """One step of Bresenham's line walk; returns the next (row, col, error)."""
    e2 = 2 * err
    if e2 > -dr:
        err -= dr
        c += stp_c
    if e2 < dc:
        err += dc
        r += stp_r
    return r, c, err


@cached_njit(nogil=True)
def _missing_ray_tiles(sr, sc, er, ec, t, rays, grid, g0r, g0c):
    """Tiles touched by the beams (end cells; ray cells too if ``rays``) that are not
    allocated (with repeats).  Fast path: a ray whose tile rectangle is fully allocated
    needs no walk."""
    tsh = _log2(t)
    n = er.shape[0]
    out = np.empty((16, 2), np.int64)
    m = 0
    gh = grid.shape[0]
    gw = grid.shape[1]
    str_ = sr >> tsh
    stc = sc >> tsh
    for i in range(n):
        r1 = er[i]
        c1 = ec[i]
        if rays:
            tr0 = min(str_, r1 >> tsh)
            tr1 = max(str_, r1 >> tsh)
            tc0 = min(stc, c1 >> tsh)
            tc1 = max(stc, c1 >> tsh)
        else:
            tr0 = tr1 = r1 >> tsh
            tc0 = tc1 = c1 >> tsh
        full = True
        for tr in range(tr0, tr1 + 1):
            for tc in range(tc0, tc1 + 1):
                gi = tr - g0r
                gj = tc - g0c
                if gi < 0 or gj < 0 or gi >= gh or gj >= gw or grid[gi, gj] < 0:
                    full = False
        if full:
            continue
        if not rays:
            if m == out.shape[0]:
                out = np.concatenate((out, np.empty_like(out)))
            out[m, 0] = tr0
            out[m, 1] = tc0
            m += 1
            continue
        r = sr
        c = sc
        dr, dc, stp_r, stp_c, err = _bresenham_start(r, c, r1, c1)
        last_r = -(1 << 62)
        last_c = -(1 << 62)
        while True:
            tr = r >> tsh
            tc = c >> tsh
            if tr != last_r or tc != last_c:
                last_r = tr
                last_c = tc
                if _slot(grid, g0r, g0c, tsh, r, c) < 0:
                    if m == out.shape[0]:
                        out = np.concatenate((out, np.empty_like(out)))
                    out[m, 0] = tr
                    out[m, 1] = tc
                    m += 1
            if r == r1 and c == c1:
                break
            r, c, err = _bresenham_step(r, c, err, dr, dc, stp_r, stp_c)
    return out[:m]


@cached_njit(nogil=True)
def _missing_window_tiles(pr, pc, w, t, grid, g0r, g0c):
    """Tiles intersecting the squares ``[p - w, p + w]^2`` that are not allocated."""
    tsh = _log2(t)
    n = pr.shape[0]
    span = ((2 * w) >> tsh) + 2
    out = np.empty((n * span * span + 1, 2), np.int64)
    m = 0
    for i in range(n):
        tr0 = (pr[i] - w) >> tsh
        tr1 = (pr[i] + w) >> tsh
        tc0 = (pc[i] - w) >> tsh
        tc1 = (pc[i] + w) >> tsh
        for tr in range(tr0, tr1 + 1):
            for tc in range(tc0, tc1 + 1):
                gi = tr - g0r
                gj = tc - g0c
                ok = gi >= 0 and gj >= 0 and gi < grid.shape[0] and gj < grid.shape[1]
                if not ok or grid[gi, gj] < 0:
                    out[m, 0] = tr
                    out[m, 1] = tc
                    m += 1
    return out[:m]


@cached_njit(nogil=True)
def _integrate(er, ec, t, grid, g0r, g0c, hits, w):
    """Count hits (beam end cells); every end cell's tile must exist.

    Counters saturate at 65535.  Returns the pixels hit for the first time ever (new
    obstacles, (n, 2) int64, in beam order) and the unallocated tiles within ``w`` pixels
    (Chebyshev) of them (:func:`_missing_window_tiles`).
    """
    tsh = _log2(t)
    n = er.shape[0]
    new = np.empty((n, 2), np.int64)
    n_new = 0
    for i in range(n):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, er[i], ec[i])
        h = hits[s, lr, lc]
        if h == 0:
            new[n_new, 0] = er[i]
            new[n_new, 1] = ec[i]
            n_new += 1
        if h < _UINT16_MAX:
            hits[s, lr, lc] = h + 1
    new = new[:n_new]
    return new, _missing_window_tiles(new[:, 0], new[:, 1], w, t, grid, g0r, g0c)


@cached_njit(nogil=True)
def _count_cells(rows, cols, t, grid, g0r, g0c, counts):
    """Add one to ``counts`` (saturating at 65535) at every pixel; its tile must exist."""
    tsh = _log2(t)
    for i in range(rows.shape[0]):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, rows[i], cols[i])
        if counts[s, lr, lc] < _UINT16_MAX:
            counts[s, lr, lc] += 1


@cached_njit(nogil=True)
def _cast_rays(sr, sc, off, er, ec, t, grid, g0r, g0c, misses):
    """Count free cells (``misses``) along beams, end excluded (Bresenham): the beams of
    scan ``j`` run from ``(sr[j], sc[j])`` to ``(er[i], ec[i])`` for ``off[j] <= i <
    off[j + 1]``.  Every touched tile must exist; counters saturate at 65535 (so the
    order of the beams does not matter)."""
    tsh = _log2(t)
    for j in range(sr.shape[0]):
        for i in range(off[j], off[j + 1]):
            r1 = er[i]
            c1 = ec[i]
            r = sr[j]
            c = sc[j]
            if r == r1 and c == c1:
                continue
            dr, dc, stp_r, stp_c, err = _bresenham_start(r, c, r1, c1)
            # tile-local stepping: look the tile up only when the ray leaves it
            s, lr, lc = _locate(grid, g0r, g0c, tsh, r, c)
            while True:
                if misses[s, lr, lc] < _UINT16_MAX:
                    misses[s, lr, lc] += 1
                r2, c2, err = _bresenham_step(r, c, err, dr, dc, stp_r, stp_c)
                lr += r2 - r
                lc += c2 - c
                r, c = r2, c2
                if r == r1 and c == c1:
                    break
                if lr < 0 or lr >= t or lc < 0 or lc >= t:
                    s, lr, lc = _locate(grid, g0r, g0c, tsh, r, c)
