"""Per-region sums in one pass over the pixels (compiled)."""

from __future__ import annotations

import numpy as np

from .._jit import cached_njit
from ..graph.work import line_into

__all__ = [
    "basis_points",
    "cut_sides",
    "disc_offsets",
    "enclosed_owner",
    "fill_parts",
    "first_pixels",
    "label_stats",
    "draw_lines",
    "region_stats",
    "room_pixels",
    "sides_widen",
    "spaced_out",
]


@cached_njit(nogil=True)
def region_stats(regions, clearance, f, n):
    """Area (pixels), largest clearance (pixels), boundary length (pixels with a
    4-neighbour of another label, the map's outside included) and first pixel (raster
    index) of regions ``1..n-1`` (region 0, the pixels off the free space, is skipped:
    zeros).

    Parameters
    ----------
    regions : int32 (H, W)
    clearance : float32 (ceil(H / f), ceil(W / f))
        Clearance of the cells of ``f`` x ``f`` pixels, in cells.
    f : int
    n : int

    Returns
    -------
    (float64 (n,), float64 (n,), float64 (n,), int64 (n,))
    """
    h, w = regions.shape
    area = np.zeros(n, np.float64)
    clear = np.zeros(n, np.float64)
    border = np.zeros(n, np.float64)
    first = np.full(n, h * w, np.int64)
    for r in range(h):
        row = regions[r]
        crow = clearance[r // f]
        c0 = 0
        while c0 < w:  # one run of equal labels at a time
            k = row[c0]
            c1 = c0 + 1
            while c1 < w and row[c1] == k:
                c1 += 1
            if k != 0:
                if area[k] == 0.0:
                    first[k] = r * w + c0
                area[k] += c1 - c0
                best = clear[k]
                for cc in range(c0 // f, (c1 - 1) // f + 1):
                    if crow[cc] > best:
                        best = crow[cc]
                clear[k] = best
                if r == 0 or r == h - 1:
                    edge = c1 - c0
                else:
                    up = regions[r - 1]
                    down = regions[r + 1]
                    edge = 2 if c1 - c0 > 1 else 1  # the run's two ends
                    for c in range(c0 + 1, c1 - 1):
                        edge += up[c] != k or down[c] != k
                border[k] += edge
            c0 = c1
    return area, clear * f, border, first


def disc_offsets(radius: float) -> np.ndarray:
    """Offsets (dr, dc) int64 (K, 2) of the disc of ``radius`` pixels, nearest first (ties
    in raster order)."""
    r = int(np.ceil(radius))
    dr, dc = np.mgrid[-r : r + 1, -r : r + 1]
    d2 = dr * dr + dc * dc
    keep = d2 <= radius * radius
    order = np.lexsort((dc[keep], dr[keep], d2[keep]))
    return np.stack([dr[keep][order], dc[keep][order]], axis=1).astype(np.int64)


@cached_njit(nogil=True)
def basis_points(free, pts, radius, offsets, start):
    """For each point (row, col) of ``pts`` (N, 2) int64, the nearest pixel that is not
    free (the map's outside included) within ``radius[i]`` pixels, and the nearest one on
    the opposite side (negative dot product, seen from the point); ``offsets``: the disc
    of at least the largest radius, nearest first (:func:`disc_offsets`); the search of
    point ``i`` starts at offset ``start[i]`` (every offset before it must be free: those
    nearer than the point's clearance).

    Returns int64 (N, 2, 2) (row, col) and bool (N,): whether both were found."""
    h, w = free.shape
    n = pts.shape[0]
    out = np.zeros((n, 2, 2), np.int64)
    found = np.zeros(n, np.bool_)
    for i in range(n):
        pr, pc = pts[i, 0], pts[i, 1]
        lim = radius[i] * radius[i]
        first = -1
        for k in range(start[i], offsets.shape[0]):
            dr, dc = offsets[k, 0], offsets[k, 1]
            if dr * dr + dc * dc > lim:
                break
            r, c = pr + dr, pc + dc
            if 0 <= r < h and 0 <= c < w and free[r, c]:
                continue
            if first < 0:
                first = k
                out[i, 0, 0], out[i, 0, 1] = r, c
            elif dr * offsets[first, 0] + dc * offsets[first, 1] < 0:
                out[i, 1, 0], out[i, 1, 1] = r, c
                found[i] = True
                break
    return out, found


@cached_njit(nogil=True)
def sides_widen(clearance, pts, normal, need, reach):
    """Whether, seen from each point ``pts[i]`` (float64 (N, 2)), the clearance reaches
    ``need[i]`` on both sides of the line through it across ``normal[i]``: along a fan
    of rays (+-30 deg about ``+normal`` and ``-normal``) out to ``reach`` pixels, each ray
    stopped at the first pixel of clearance below 1 (or off the map)."""
    h, w = clearance.shape
    n = pts.shape[0]
    out = np.zeros(n, np.bool_)
    cos30, sin30 = 0.8660254037844387, 0.5
    steps = int(np.ceil(reach))
    for i in range(n):
        both = True
        for sign in (1.0, -1.0):
            seen = False
            for a in range(3):
                sa = (-sin30, 0.0, sin30)[a]
                ca = (cos30, 1.0, cos30)[a]
                dr = sign * (normal[i, 0] * ca - normal[i, 1] * sa)
                dc = sign * (normal[i, 0] * sa + normal[i, 1] * ca)
                for s in range(1, steps + 1):
                    r = int(np.floor(pts[i, 0] + s * dr + 0.5))
                    cc = int(np.floor(pts[i, 1] + s * dc + 0.5))
                    if r < 0 or r >= h or cc < 0 or cc >= w:
                        break
                    v = clearance[r, cc]
                    if v < 1.0:
                        break
                    if v >= need[i]:
                        seen = True
                        break
                if seen:
                    break
            if not seen:
                both = False
                break
        out[i] = both
    return out


@cached_njit(nogil=True)
def label_stats(labels, n):
    """Pixel count, row sum, column sum and bounding box of labels ``0..n``.

    Returns float64 (n + 1,) three times and int64 (n + 1, 4) ``(row_min, col_min,
    row_max, col_max)`` inclusive (``row_min > row_max`` for a label without pixels)."""
    count = np.zeros(n + 1, np.float64)
    sum_r = np.zeros(n + 1, np.float64)
    sum_c = np.zeros(n + 1, np.float64)
    h, w = labels.shape
    box = np.empty((n + 1, 4), np.int64)
    box[:, 0] = h
    box[:, 1] = w
    box[:, 2] = -1
    box[:, 3] = -1
    for r in range(h):
        row = labels[r]
        c0 = 0
        while c0 < w:  # one run of equal labels at a time
            k = row[c0]
            c1 = c0 + 1
            while c1 < w and row[c1] == k:
                c1 += 1
            m = c1 - c0
            count[k] += m
            sum_r[k] += r * m
            sum_c[k] += (c0 + c1 - 1) * m / 2
            if r < box[k, 0]:
                box[k, 0] = r
            if c0 < box[k, 1]:
                box[k, 1] = c0
            box[k, 2] = r
            if c1 - 1 > box[k, 3]:
                box[k, 3] = c1 - 1
            c0 = c1
    return count, sum_r, sum_c, box


@cached_njit(nogil=True)
def first_pixels(labels, n):
    """Raster index ``row * W + col`` of the first pixel of labels ``1..n`` of ``labels``
    (int32 (H, W)): int64 (n + 1,), ``H * W`` for a label without pixels (and label 0).
    Stops once every label is found."""
    h, w = labels.shape
    first = np.full(n + 1, h * w, np.int64)
    left = n
    for r in range(h):
        row = labels[r]
        for c in range(w):
            k = row[c]
            if k > 0 and first[k] == h * w:
                first[k] = r * w + c
                left -= 1
        if left == 0:
            break
    return first


@cached_njit(nogil=True)
def cut_sides(regions, pixels, starts):
    """The two regions each cut separates: the two most frequent labels > 0 among the
    4-neighbours of its pixels (ties: the smaller label first), ascending; (-1, -1) for a
    cut next to fewer than two.  Cut ``i`` has the pixels (row, col)
    ``pixels[starts[i]:starts[i + 1]]``.  Returns int64 (m, 2)."""
    h, w = regions.shape
    m = starts.shape[0] - 1
    out = np.full((m, 2), -1, np.int64)
    for i in range(m):
        k0, k1 = starts[i], starts[i + 1]
        near = np.empty(4 * (k1 - k0), np.int64)
        j = 0
        for k in range(k0, k1):
            r, c = pixels[k, 0], pixels[k, 1]
            if r > 0 and regions[r - 1, c] > 0:
                near[j] = regions[r - 1, c]
                j += 1
            if r < h - 1 and regions[r + 1, c] > 0:
                near[j] = regions[r + 1, c]
                j += 1
            if c > 0 and regions[r, c - 1] > 0:
                near[j] = regions[r, c - 1]
                j += 1
            if c < w - 1 and regions[r, c + 1] > 0:
                near[j] = regions[r, c + 1]
                j += 1
        if j == 0:
            continue
        lab = np.sort(near[:j])
        best, best_n, second, second_n = -1, 0, -1, 0
        run = 1
        for k in range(1, j + 1):
            if k < j and lab[k] == lab[k - 1]:
                run += 1
                continue
            v = lab[k - 1]  # a run of ``run`` equal labels ends; ascending, so ties keep
            if run > best_n:  # the smaller label ahead
                second, second_n = best, best_n
                best, best_n = v, run
            elif run > second_n:
                second, second_n = v, run
            run = 1
        if second >= 0:
            out[i, 0] = min(best, second)
            out[i, 1] = max(best, second)
    return out


@cached_njit(nogil=True)
def enclosed_owner(parts, labels, n):
    """For the parts ``1..n-1`` of ``parts`` (int32 (H, W), 0 = none), the one label > 0
    of ``labels`` among their pixels' 4-neighbours, or 0 when they touch none, several,
    or the image's edge.  Returns int32 (n,)."""
    h, w = parts.shape
    owner = np.zeros(n, np.int32)
    bad = np.zeros(n, np.bool_)
    for r in range(h):
        for c in range(w):
            p = parts[r, c]
            if p == 0 or bad[p]:
                continue
            if r == 0 or r == h - 1 or c == 0 or c == w - 1:
                bad[p] = True
                continue
            for v in (labels[r - 1, c], labels[r + 1, c], labels[r, c - 1], labels[r, c + 1]):
                if v > 0:
                    if owner[p] == 0:
                        owner[p] = v
                    elif owner[p] != v:
                        bad[p] = True
    for p in range(n):
        if bad[p]:
            owner[p] = 0
    return owner


@cached_njit(nogil=True)
def room_pixels(regions, room_of, free, rounds, out, empty):
    """Room id of every pixel: ``out = room_of[regions]`` (int32, written in place), then
    ``rounds`` times every pixel of ``free`` without a room (0) next to a room (the cut
    lines) takes the largest id among its 4 neighbours, or, if they have none, among its
    diagonal ones (a pixel joins the room it shares a side with when it can), all decided
    from the ids of the round before; ``empty`` (uint8, in place) is 1 where ``out`` is 0
    at the end."""
    h, w = regions.shape
    n = 0
    for r in range(h):
        orow = out[r]
        erow = empty[r]
        for c in range(w):
            v = room_of[regions[r, c]]
            orow[c] = v
            erow[c] = v == 0
            n += v == 0 and free[r, c]
    todo = np.empty((n, 2), np.int64)
    n = 0
    for r in range(h):
        for c in range(w):
            if empty[r, c] and free[r, c]:
                todo[n, 0], todo[n, 1] = r, c
                n += 1
    got = np.zeros(n, np.int32)
    for _ in range(rounds):
        for i in range(n):
            r, c = todo[i, 0], todo[i, 1]
            best = 0  # the largest id of a 4-neighbour, else of a diagonal one
            for rr, cc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
                if 0 <= rr < h and 0 <= cc < w and out[rr, cc] > best:
                    best = out[rr, cc]
            if best == 0:
                for rr, cc in ((r - 1, c - 1), (r - 1, c + 1), (r + 1, c - 1), (r + 1, c + 1)):
                    if 0 <= rr < h and 0 <= cc < w and out[rr, cc] > best:
                        best = out[rr, cc]
            got[i] = best
        m = 0
        for i in range(n):
            if got[i] > 0:
                out[todo[i, 0], todo[i, 1]] = got[i]
                empty[todo[i, 0], todo[i, 1]] = 0
            else:
                todo[m] = todo[i]
                m += 1
        if m == 0 or m == n:
            break
        n = m


@cached_njit(nogil=True)
def fill_parts(labels, parts, owner):
    """In place: every pixel of a part ``k > 0`` of ``parts`` with ``owner[k] > 0`` takes
    that id in ``labels``."""
    h, w = labels.shape
    for r in range(h):
        for c in range(w):
            k = parts[r, c]
            if k > 0 and owner[k] > 0:
                labels[r, c] = owner[k]


@cached_njit(nogil=True)
def spaced_out(pts, w, shape):
    """Greedy spacing: point ``i`` of ``pts`` (int64 (N, 2), in order of preference) is
    kept unless a kept point lies within ``w`` (>= 1) pixels of it in both rows and
    columns.  ``shape``: (H, W) bounding every point.  Returns bool (N,)."""
    n = pts.shape[0]
    keep = np.zeros(n, np.bool_)
    bh, bw = shape[0] // w + 1, shape[1] // w + 1
    head = np.full((bh, bw), -1, np.int64)
    nxt = np.full(n, -1, np.int64)
    for i in range(n):
        r, c = pts[i, 0], pts[i, 1]
        br, bc = r // w, c // w
        near = False
        for qr in range(max(br - 1, 0), min(br + 2, bh)):
            for qc in range(max(bc - 1, 0), min(bc + 2, bw)):
                j = head[qr, qc]
                while j >= 0 and not near:
                    near = abs(pts[j, 0] - r) <= w and abs(pts[j, 1] - c) <= w
                    j = nxt[j]
        if not near:
            keep[i] = True
            nxt[i] = head[br, bc]
            head[br, bc] = i
    return keep


@cached_njit(nogil=True)
def draw_lines(a, b, free):
    """The pixels of ``free`` (bool (H, W)) on the digital lines from ``a[i]`` to ``b[i]``
    (int64 (N, 2) each, :func:`topojax.graph.work.line_into`): int64 (K, 2) (row, col),
    line ``i`` at ``[starts[i]:starts[i + 1]]``; returns (pixels, starts)."""
    h, w = free.shape
    n = a.shape[0]
    total = 0
    for i in range(n):
        total += max(abs(b[i, 0] - a[i, 0]), abs(b[i, 1] - a[i, 1])) + 1
    out = np.empty((total, 2), np.int64)
    starts = np.zeros(n + 1, np.int64)
    buf = np.empty((1, 2), np.int64)
    m = 0
    for i in range(n):
        k = max(abs(b[i, 0] - a[i, 0]), abs(b[i, 1] - a[i, 1])) + 1
        if buf.shape[0] < k:
            buf = np.empty((k, 2), np.int64)
        line_into(a[i, 0], a[i, 1], b[i, 0], b[i, 1], buf)
        for j in range(k):
            r, c = buf[j, 0], buf[j, 1]
            if 0 <= r < h and 0 <= c < w and free[r, c]:
                out[m, 0], out[m, 1] = r, c
                m += 1
        starts[i + 1] = m
    return out[:m], starts
