"""The route graph builder's compiled loops.  The greedy spanner's inner loop: candidate
shortcuts, shortest first, each accepted when the graph (grown by the shortcuts accepted
so far) still has no route short enough between its ends, its straight pixel line (or,
for a shortcut bent at a corner, its two lines) is feasible, and a straight one crosses
no other edge.  The digital straight line used here is the one of every straight
route-graph edge (:func:`line_pixels`).  Also: the coverage tests (which pixels see the
graph), anchors along edges and the simplification of edge paths."""

from __future__ import annotations

import math

import numpy as np

from .._heap import heap_pop, heap_push
from .._jit import cached_njit
from ..graph.sparse import grown
from ..graph.work import WorkGraph, line_step

__all__ = [
    "anchor_pieces",
    "clear_lines",
    "drop_short_loops",
    "greedy_shortcuts",
    "open_short_loops",
    "see_named",
    "see_within",
    "simplify_path",
    "simplify_paths",
    "straight_is_feasible",
]

_SQRT2 = math.sqrt(2.0)


@cached_njit(nogil=True)
def _line_length(r0, c0, r1, c1):
    """8-connected length (pixels) of the digital line: one step per major-axis pixel, a
    diagonal step costing sqrt 2."""
    n = max(abs(r1 - r0), abs(c1 - c0))
    diagonal = min(abs(r1 - r0), abs(c1 - c0))
    # every minor-axis change is one diagonal step of the line
    return (n - diagonal) + diagonal * _SQRT2


@cached_njit(nogil=True)
def _within(head, nxt, to, wt, src, dst, cutoff, dist, stamp, run, hk, hv):
    """Whether the graph (linked adjacency ``head``/``nxt``/``to``/``wt``) has a route
    from ``src`` to ``dst`` of length at most ``cutoff`` (Dijkstra, stopped at it)."""
    if src == dst:
        return True
    size = heap_push(hk, hv, 0, 0.0, src)
    stamp[src], dist[src] = run, 0.0
    while size > 0:
        u = hv[0]
        d, size = heap_pop(hk, hv, size)
        if u == dst:
            return True
        if d > dist[u]:
            continue
        k = head[u]
        while k >= 0:
            v = to[k]
            nd = d + wt[k]
            if nd <= cutoff and (stamp[v] != run or nd < dist[v]):
                stamp[v], dist[v] = run, nd
                if size == hk.size:
                    return False  # never reached: the heap holds one entry per edge end
                size = heap_push(hk, hv, size, nd, v)
            k = nxt[k]
    return False


@cached_njit(nogil=True)
def _linked(n_nodes, edge_u, edge_v, edge_w, cap):
    """The edges as a linked adjacency with room for ``cap`` edge ends: ``(head, nxt, to,
    wt, k)``, ``head[v]`` the first slot of node ``v``, ``nxt``/``to``/``wt`` per slot,
    ``k`` the first free slot (two slots per edge, one per direction)."""
    head = np.full(n_nodes, -1, np.int64)
    nxt = np.empty(cap, np.int64)
    to = np.empty(cap, np.int64)
    wt = np.empty(cap, np.float64)
    k = 0
    for e in range(edge_u.size):
        for a, b in ((edge_u[e], edge_v[e]), (edge_v[e], edge_u[e])):
            to[k], wt[k], nxt[k] = b, edge_w[e], head[a]
            head[a] = k
            k += 1
    return head, nxt, to, wt, k


@cached_njit(nogil=True)
def drop_short_loops(n_nodes, edge_u, edge_v, edge_w, order, limit):
    """Visit the edges ``order`` in turn and drop each whose ends are joined, without it,
    by a route shorter than its ``limit`` (the edges dropped before gone too): the edge
    would close a loop that short.

    Parameters
    ----------
    n_nodes : int
    edge_u, edge_v, edge_w : int64 (E,), int64 (E,), float64 (E,)
        The graph's edges (no self-loops) and their lengths in pixels.
    order : int64 (K,)
        Indices of the edges to visit, in turn.
    limit : float64 (K,)
        Per visited edge, the route length it must not be joined by (<= 0: kept).

    Returns
    -------
    bool (K,)
        Which visited edges were dropped.
    """
    cap = 2 * edge_u.size + 1
    head, nxt, to, wt, _ = _linked(n_nodes, edge_u, edge_v, edge_w, cap)
    dist = np.zeros(n_nodes, np.float64)
    stamp = np.zeros(n_nodes, np.int64)
    hk = np.empty(cap, np.float64)
    hv = np.empty(cap, np.int64)
    dropped = np.zeros(order.size, np.bool_)
    for i in range(order.size):
        if limit[i] <= 0:
            continue
        e = order[i]
        wt[2 * e] = np.inf  # the route may not use the edge itself
        wt[2 * e + 1] = np.inf
        # strictly shorter than the limit
        cutoff = np.nextafter(limit[i], -np.inf)
        if _within(head, nxt, to, wt, edge_u[e], edge_v[e], cutoff, dist, stamp, i + 1, hk, hv):
            dropped[i] = True
        else:
            wt[2 * e] = edge_w[e]
            wt[2 * e + 1] = edge_w[e]
    return dropped


def open_short_loops(work: WorkGraph, min_loop_px: float, contract: bool = True) -> list:
    """Remove the loops of ``work`` shorter than ``min_loop_px``: such self-loops, then,
    longest first, each edge that closes such a loop (:func:`drop_short_loops`).

    Parameters
    ----------
    work : WorkGraph
        Changed in place.
    min_loop_px : float
        Loop length (pixels, along the edges' paths) below which a loop is opened.
    contract : bool
        Contract the vertices left with two edges.

    Returns
    -------
    list
        The removed edges, each ``(u, v, path)`` (path int32 (K, 2) from ``u`` to ``v``).
    """
    removed = []
    for e, (u, v, path) in list(work.edges.items()):
        if u == v and work.length[e] < min_loop_px:
            removed.append((u, v, path))
            work.remove_edge(e)
    live = [e for e, (u, v, _) in work.edges.items() if u != v]
    if live:
        length = np.array([work.length[e] for e in live], np.float64)
        order = np.argsort(-length, kind="stable").astype(np.int64)
        dropped = drop_short_loops(
            len(work.pixel),
            np.array([work.edges[e][0] for e in live], np.int64),
            np.array([work.edges[e][1] for e in live], np.int64),
            length,
            order,
            min_loop_px - length[order],
        )
        for k in order[dropped].tolist():
            u, v, path = work.edges[live[k]]
            removed.append((u, v, path))
            work.remove_edge(live[k])
    if removed and contract:
        work.contract_all({x for u, v, _ in removed for x in (u, v)})
    return removed


@cached_njit(nogil=True)
def _near_ends(r, c, r0, c0, r1, c1, mem, ms, end_px):
    """Whether pixel ``(r, c)`` lies within ``end_px`` (Chebyshev) of a segment's ends
    ``(r0, c0)``, ``(r1, c1)`` or of the member pixels ``mem[ms[0]:ms[1]]``,
    ``mem[ms[2]:ms[3]]`` of its end vertices."""
    if max(abs(r - r0), abs(c - c0)) <= end_px or max(abs(r - r1), abs(c - c1)) <= end_px:
        return True
    for part in range(2):
        for j in range(ms[2 * part], ms[2 * part + 1]):
            if max(abs(r - mem[j, 0]), abs(c - mem[j, 1])) <= end_px:
                return True
    return False


@cached_njit(nogil=True)
def _clear_line(a, b, pos, mem, mem_start, feasible, occupied, end_px, seg, ms, cross):
    """Draw the straight line between nodes ``a`` and ``b`` into ``seg``; its length in
    pixels, or 0 when it leaves the feasible pixels or (unless ``cross``) touches an edge
    away from its ends.  The line is given up at its first such pixel: in a dense graph
    most lines touch an edge a few pixels from their start."""
    r0, c0, r1, c1 = pos[a, 0], pos[a, 1], pos[b, 0], pos[b, 1]
    ms[0], ms[1], ms[2], ms[3] = mem_start[a], mem_start[a + 1], mem_start[b], mem_start[b + 1]
    dr, dc = r1 - r0, c1 - c0
    n = max(abs(dr), abs(dc))
    r, c = r0, c0
    for i in range(n + 1):
        if i > 0:
            r, c = line_step(r0, c0, dr, dc, n, i)
        if not feasible[r, c]:
            return 0
        if not cross and occupied[r, c] and not _near_ends(r, c, r0, c0, r1, c1, mem, ms, end_px):
            return 0
        seg[i, 0], seg[i, 1] = r, c
    return n + 1


@cached_njit(nogil=True)
def clear_lines(cand_a, cand_b, pos, mem, mem_start, feasible, occupied, end_px):
    """Whether each straight candidate ``cand_a[i]``-``cand_b[i]`` (int64 (C,) node ids)
    has a clear line now (:func:`_clear_line`, no crossing): bool (C,).  ``occupied``
    only grows in :func:`greedy_shortcuts`, so a line not clear here is never clear there;
    arguments as there."""
    h, w = feasible.shape
    seg = np.empty((h + w + 1, 2), np.int64)
    ms = np.empty(4, np.int64)
    out = np.zeros(cand_a.size, np.bool_)
    for i in range(cand_a.size):
        n = _clear_line(
            cand_a[i], cand_b[i], pos, mem, mem_start, feasible, occupied, end_px, seg, ms, False
        )
        out[i] = n > 0
    return out


@cached_njit(nogil=True)
def _link(a, b, pos, head, nxt, to, wt, k):
    """Add the straight edge ``a``-``b`` to the linked adjacency; returns the next free
    slot."""
    length = _line_length(pos[a, 0], pos[a, 1], pos[b, 0], pos[b, 1])
    for x, y in ((a, b), (b, a)):
        to[k], wt[k], nxt[k] = y, length, head[x]
        head[x] = k
        k += 1
    return k


@cached_njit(nogil=True)
def _occupy(seg, n, occupied):
    h, w = occupied.shape
    for j in range(n):
        for dr in range(-1, 2):
            for dc in range(-1, 2):
                r = min(max(seg[j, 0] + dr, 0), h - 1)
                c = min(max(seg[j, 1] + dc, 0), w - 1)
                occupied[r, c] = True


@cached_njit(nogil=True)
def greedy_shortcuts(
    pos,
    mem,
    mem_start,
    edge_u,
    edge_v,
    edge_w,
    cand_a,
    cand_b,
    cand_c,
    need,
    short,
    feasible,
    occupied,
    end_px,
    min_loop,
):
    """Accept candidate shortcuts in the given order (shortest first).

    Parameters
    ----------
    pos : int64 (M, 2)
        Node pixels (row, col).
    mem, mem_start : int64 (P, 2), int64 (M + 1,)
        Member pixels of each node: ``mem[mem_start[v]:mem_start[v + 1]]``.
    edge_u, edge_v, edge_w : int64 (E,), int64 (E,), float64 (E,)
        The current edges (no self-loops) and their lengths in pixels.
    cand_a, cand_b : int64 (C,)
        Candidate shortcut ends.
    cand_c : int64 (C,)
        -1 for a straight shortcut; else the node it bends at (two straight lines,
        ``a``-``c`` and ``c``-``b``).
    need : float64 (C,)
        A candidate is taken only if no route of at most this length joins its ends.
    short : float64 (C,)
        ... nor one of at most this length (the loop it would close would be too short;
        <= 0: no such check).
    feasible : bool (H, W)
        Pixels a shortcut may cross.
    occupied : bool (H, W)
        Pixels of (or next to) edges, updated in place with the accepted shortcuts.
    end_px : float
        Near its ends a shortcut may touch other edges.
    min_loop : float
        Through a corner already in the graph, neither leg of a bent shortcut may close
        a loop shorter than this (<= 0: no such check).

    Returns
    -------
    taken : bool (C,)
        Which candidates were accepted.
    searched : int
        How many candidates had clear lines and so got a route search (the pass's work).
    """
    m = pos.shape[0]
    n_c = cand_a.size
    # room for the edges and some shortcuts; grown (doubled) when the accepted ones fill it
    cap = 2 * edge_u.size + 4 * max(64, n_c // 16) + 1
    head, nxt, to, wt, k = _linked(m, edge_u, edge_v, edge_w, cap)
    dist = np.zeros(m, np.float64)
    stamp = np.zeros(m, np.int64)
    hk = np.empty(cap, np.float64)
    hv = np.empty(cap, np.int64)
    h, w = feasible.shape
    seg = np.empty((h + w + 1, 2), np.int64)
    seg2 = np.empty((h + w + 1, 2), np.int64)
    ms = np.empty(4, np.int64)
    out = np.zeros(n_c, np.bool_)
    run, searched = 0, 0
    for i in range(n_c):
        a, b, c = cand_a[i], cand_b[i], cand_c[i]
        mid = b if c < 0 else c
        # the lines first: most candidates leave the feasible space or touch an edge, and
        # a line is cheaper to draw than a route search
        n = _clear_line(a, mid, pos, mem, mem_start, feasible, occupied, end_px, seg, ms, c >= 0)
        if n == 0:
            continue
        n2 = 0
        if c >= 0:
            n2 = _clear_line(c, b, pos, mem, mem_start, feasible, occupied, end_px, seg2, ms, True)
            if n2 == 0:
                continue
        run += 1
        searched += 1
        # a route of at most ``need`` makes the shortcut useless, one of at most ``short``
        # makes its loop too short: one search to the longer of the two
        if _within(head, nxt, to, wt, a, b, max(need[i], short[i]), dist, stamp, run, hk, hv):
            continue
        if c >= 0 and head[c] >= 0 and min_loop > 0:
            # a corner already in the graph: neither leg may close a short loop through it
            run += 1
            leg = _line_length(pos[a, 0], pos[a, 1], pos[c, 0], pos[c, 1])
            if _within(head, nxt, to, wt, a, c, min_loop - leg, dist, stamp, run, hk, hv):
                continue
            run += 1
            leg = _line_length(pos[c, 0], pos[c, 1], pos[b, 0], pos[b, 1])
            if _within(head, nxt, to, wt, c, b, min_loop - leg, dist, stamp, run, hk, hv):
                continue
        if c >= 0:
            _occupy(seg2, n2, occupied)
        _occupy(seg, n, occupied)
        # room for four more edge ends (slots k..k+3)
        nxt, to, wt = grown(nxt, k + 3), grown(to, k + 3), grown(wt, k + 3)
        if hk.size < nxt.size:
            hk, hv = np.empty(nxt.size, np.float64), np.empty(nxt.size, np.int64)
        k = _link(a, mid, pos, head, nxt, to, wt, k)
        if c >= 0:
            k = _link(c, b, pos, head, nxt, to, wt, k)
        out[i] = True
    return out, searched


@cached_njit(nogil=True)
def straight_is_feasible(r0, c0, r1, c1, feasible):
    """Whether every pixel the straight segment between the centres of pixels
    ``(r0, c0)`` and ``(r1, c1)`` passes through (its supercover; at a pixel corner it
    steps diagonally) is feasible."""
    n_r, n_c = abs(r1 - r0), abs(c1 - c0)
    sr = 1 if r1 > r0 else -1
    sc = 1 if c1 > c0 else -1
    r, c, i, j = r0, c0, 0, 0
    if not feasible[r, c]:
        return False
    while i < n_r or j < n_c:
        # the next border crossings at t = (i + 1/2) / n_r and (j + 1/2) / n_c, compared
        # exactly in integers
        if j >= n_c or (i < n_r and (2 * i + 1) * n_c < (2 * j + 1) * n_r):
            r += sr
            i += 1
        elif i >= n_r or (2 * j + 1) * n_r < (2 * i + 1) * n_c:
            c += sc
            j += 1
        else:
            r += sr
            c += sc
            i += 1
            j += 1
        if not feasible[r, c]:
            return False
    return True


@cached_njit(nogil=True)
def simplify_path(path, feasible, tol):
    """Douglas-Peucker on an 8-connected pixel path (K, 2) int64 with tolerance ``tol``
    (pixels) whose straight pieces also stay on feasible pixels (a piece within the
    tolerance that leaves them is split at its middle, down to single steps).  Returns
    bool (K,): the kept pixels (both ends always)."""
    n = path.shape[0]
    keep = np.zeros(n, np.bool_)
    keep[0] = True
    keep[n - 1] = True
    stack = np.empty((2 * n + 2, 2), np.int64)
    stack[0, 0], stack[0, 1] = 0, n - 1
    top = 1
    while top > 0:
        top -= 1
        i, j = stack[top, 0], stack[top, 1]
        if j - i < 2:
            continue
        ar, ac = float(path[i, 0]), float(path[i, 1])
        br, bc = float(path[j, 0]) - ar, float(path[j, 1]) - ac
        span = br * br + bc * bc
        best, m = -1.0, i + 1
        for k in range(i + 1, j):
            pr, pc = path[k, 0] - ar, path[k, 1] - ac
            t = 0.0 if span == 0 else min(max((pr * br + pc * bc) / span, 0.0), 1.0)
            dr, dc = pr - t * br, pc - t * bc
            d = (dr * dr + dc * dc) ** 0.5
            if d > best:
                best, m = d, k
        if best <= tol:
            if straight_is_feasible(path[i, 0], path[i, 1], path[j, 0], path[j, 1], feasible):
                continue
            m = i + (j - i) // 2
        keep[m] = True
        stack[top, 0], stack[top, 1] = i, m
        stack[top + 1, 0], stack[top + 1, 1] = m, j
        top += 2
    return keep


@cached_njit(nogil=True)
def _fill_row(raster, r, c_lo, c_hi, none_left, none_right, side, slot):
    """Into ``side[:, slot]`` (int32 (2, S, c_hi - c_lo)): for row ``r`` of ``raster``
    within the columns ``c_lo``..``c_hi - 1``, the column of the nearest set pixel at or
    left of each pixel, and at or right of it (``none_left`` / ``none_right`` where the
    row has none on that side in those columns)."""
    last = none_left
    for c in range(c_lo, c_hi):
        if raster[r, c]:
            last = c
        side[0, slot, c - c_lo] = last
    last = none_right
    for c in range(c_hi - 1, c_lo - 1, -1):
        if raster[r, c]:
            last = c
        side[1, slot, c - c_lo] = last


@cached_njit(nogil=True)
def see_within(rows, cols, raster, wall, feasible, snap_px):
    """For pixels ``(rows[k], cols[k])``, whether a pixel of ``raster`` within
    ``snap_px`` is reached by a straight segment over feasible pixels only (bool (K,)).
    The nearest pixel (found row by row) is tried first, with no walk when the
    segment is shorter than the pixel's ``wall`` distance minus one; then every other
    one in reach."""
    h, w = raster.shape
    n = rows.shape[0]
    out = np.zeros(n, np.bool_)
    if n == 0:
        return out
    reach = int(math.floor(snap_px))
    snap2 = snap_px * snap_px
    # only the columns within reach of a pixel's can hold a graph pixel in reach; a
    # column past these bounds stands for none (it is farther than the reach)
    c_lo, c_hi = max(0, cols.min() - reach), min(w, cols.max() + reach + 1)
    none_left, none_right = c_lo - reach - 1, c_hi + reach
    # the nearest columns of the rows within reach, in a ring of 2 x reach + 1 rows
    # filled as the pixels are taken in row order
    span = 2 * reach + 1
    side = np.empty((2, span, c_hi - c_lo), np.int32)
    done = -1  # the last row filled
    for k in np.argsort(rows, kind="mergesort"):
        r0, c0 = rows[k], cols[k]
        for r in range(max(done + 1, r0 - reach), min(h, r0 + reach + 1)):
            _fill_row(raster, r, c_lo, c_hi, none_left, none_right, side, r % span)
            done = r
        # rows outward from the pixel's own, until a row's offset alone is too far
        best, nr, nc = snap2 + 1.0, -1, -1
        for dr in range(reach + 1):
            if dr * dr > best:
                break
            for r in (r0 - dr, r0 + dr):
                if r < 0 or r >= h:
                    continue
                for s in range(2):
                    c = side[s, r % span, c0 - c_lo]
                    d2 = float(dr * dr + (c - c0) * (c - c0))
                    if d2 < best:
                        best, nr, nc = d2, r, c
        if best > snap2:
            continue
        if math.sqrt(best) + 1.0 < wall[r0, c0] or straight_is_feasible(r0, c0, nr, nc, feasible):
            out[k] = True
            continue
        out[k] = _sees_any(r0, c0, raster, feasible, snap_px)
    return out


@cached_njit(nogil=True)
def _sees_any(r0, c0, raster, feasible, snap_px):
    """Whether any pixel of ``raster`` within ``snap_px`` of pixel ``(r0, c0)`` is
    reached by a straight segment over feasible pixels only."""
    h, w = raster.shape
    reach = int(math.floor(snap_px))
    lim = snap_px * snap_px
    for r in range(max(0, r0 - reach), min(h, r0 + reach + 1)):
        for c in range(max(0, c0 - reach), min(w, c0 + reach + 1)):
            if raster[r, c] and (r - r0) ** 2 + (c - c0) ** 2 <= lim:
                if straight_is_feasible(r0, c0, r, c, feasible):
                    return True
    return False


@cached_njit(nogil=True)
def anchor_pieces(every, starts, sizes, ia, ib, n0, spacing, keep):
    """Anchors along the edges (paths ``every[starts[e]:starts[e] + sizes[e]]``, each of
    at least two pixels, between nodes ``ia[e]`` and ``ib[e]``): ``k - 1`` cuts splitting
    an edge of arc length ``L`` into ``k = floor(L / spacing)`` equal parts, moved to the
    first pixel at or past each cut and kept at least ``keep`` from both ends.  Anchors
    are numbered from ``n0`` in edge order.

    Returns ``(at (A,), first (A,), edge (A,), u, v (P,), w (P,))``: each anchor's index
    into ``every``, the number of the first anchor of its edge, its edge, and the pieces
    between consecutive nodes along every edge (no self-loops) with their lengths."""
    total_px = every.shape[0]
    at = np.empty(total_px, np.int64)
    first = np.empty(total_px, np.int64)
    owner = np.empty(total_px, np.int64)
    pu = np.empty(total_px + sizes.shape[0], np.int64)
    pv = np.empty(total_px + sizes.shape[0], np.int64)
    pw = np.empty(total_px + sizes.shape[0], np.float64)
    arc = np.empty(sizes.max() if sizes.shape[0] else 1, np.float64)
    n_at, n_p, n = 0, 0, n0
    for e in range(sizes.shape[0]):
        s0, m = starts[e], sizes[e]
        arc[0] = 0.0
        for j in range(1, m):
            diagonal = every[s0 + j, 0] != every[s0 + j - 1, 0] and (
                every[s0 + j, 1] != every[s0 + j - 1, 1]
            )
            arc[j] = arc[j - 1] + (_SQRT2 if diagonal else 1.0)
        total = arc[m - 1]
        k = 0 if math.isinf(spacing) else int(min(total // spacing, total + 1.0))
        # (cuts less than a pixel apart put an anchor on every pixel: so do k = total + 1,
        # without the loop over ever more cuts of a tiny spacing)
        prev_node, prev_mark, first_here, last_cut = ia[e], 0.0, n, -1
        for i in range(1, k):
            x = total * i / k
            c = 0
            while arc[c] < x:
                c += 1
            if c == last_cut or arc[c] < keep or total - arc[c] < keep:
                continue
            last_cut = c
            at[n_at], first[n_at], owner[n_at] = s0 + c, first_here, e
            n_at += 1
            if prev_node != n:
                pu[n_p], pv[n_p], pw[n_p] = prev_node, n, arc[c] - prev_mark
                n_p += 1
            prev_node, prev_mark = n, arc[c]
            n += 1
        if prev_node != ib[e]:
            pu[n_p], pv[n_p], pw[n_p] = prev_node, ib[e], total - prev_mark
            n_p += 1
    return at[:n_at], first[:n_at], owner[:n_at], pu[:n_p], pv[:n_p], pw[:n_p]


@cached_njit(nogil=True)
def simplify_paths(every, starts, sizes, feasible, tol):
    """:func:`simplify_path` of each path ``every[starts[e]:starts[e] + sizes[e]]``;
    returns the kept pixels of all of them (bool, the length of ``every``)."""
    keep = np.zeros(every.shape[0], np.bool_)
    for e in range(sizes.shape[0]):
        s0 = starts[e]
        keep[s0 : s0 + sizes[e]] = simplify_path(every[s0 : s0 + sizes[e]], feasible, tol)
    return keep


@cached_njit(nogil=True)
def see_named(test, label, graph_px, wall, feasible, snap_px, reach_px):
    """One pass over the pixels ``test`` (bool (H, W)): a pixel is covered when the graph
    pixel its ``label`` names (``graph_px[label - 1]``) is within ``snap_px`` and seen
    along a straight feasible segment (no walk needed when the segment is shorter than
    the pixel's ``wall`` distance minus one).  Returns ``(covered bool (H, W), rows,
    cols)``: the pixels not covered so whose named pixel is within ``reach_px`` (another
    graph pixel may be seen)."""
    h, w = test.shape
    out = np.zeros((h, w), np.bool_)
    snap2 = snap_px * snap_px
    reach2 = reach_px * reach_px
    rows = np.empty(16, np.int64)
    cols = np.empty(16, np.int64)
    n = 0
    for r in range(h):
        for c in range(w):
            if not test[r, c]:
                continue
            k = label[r, c] - 1
            nr, nc = graph_px[k, 0], graph_px[k, 1]
            d2 = (nr - r) * (nr - r) + (nc - c) * (nc - c)
            if d2 <= snap2:
                d = math.sqrt(float(d2))
                if d + 1.0 < wall[r, c] or straight_is_feasible(r, c, nr, nc, feasible):
                    out[r, c] = True
                    continue
            if d2 <= reach2:
                if n == rows.shape[0]:
                    rows = np.concatenate((rows, np.empty(n, np.int64)))
                    cols = np.concatenate((cols, np.empty(n, np.int64)))
                rows[n], cols[n] = r, c
                n += 1
    return out, rows[:n], cols[:n]
