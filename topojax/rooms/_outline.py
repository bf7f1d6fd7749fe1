"""A room's outline: the pixel-edge (crack) boundary of its pixels as one simple outer
ring and one simple ring round each hole (compiled tracer)."""

from __future__ import annotations

import cv2
import numpy as np

from .._jit import cached_njit

__all__ = ["PINCH_PX", "outline"]

PINCH_PX = 1.0 / 64.0
"""Size of the corner cut at a pinch, pixels: where the ring passes a pixel corner twice
(two pixels of the room meet there only diagonally), each pass cuts that corner off the
empty pixel it turns round by this much along both edges, so the passes stay apart and
the diagonal contact becomes a neck ``PINCH_PX * sqrt(2)`` wide (each cut adds
``PINCH_PX**2 / 2`` square pixels)."""

# headings: east, south, west, north in (row, col) steps; the room is on the right
_DR = np.array([0, 1, 0, -1], np.int64)
_DC = np.array([1, 0, -1, 0], np.int64)
# the pixel ahead-left and ahead-right of a pixel corner (row, col) for each heading,
# as offsets from the corner to the pixel's index (corner (i, j) is the top-left corner
# of pixel (i, j))
_AHEAD = np.array(
    [
        [[-1, 0], [0, 0]],  # east: above-right, below-right
        [[0, 0], [0, -1]],  # south: below-right, below-left
        [[0, -1], [-1, -1]],  # west: below-left, above-left
        [[-1, -1], [-1, 0]],  # north: above-left, above-right
    ],
    np.int64,
)


@cached_njit(nogil=True)
def _inside(mask, r, c):
    return 0 <= r < mask.shape[0] and 0 <= c < mask.shape[1] and mask[r, c]


@cached_njit(nogil=True)
def _trace(mask, r0, c0, d0, cut):
    """Walk one closed crack boundary of ``mask`` with ``mask`` on the right, from pixel
    corner ``(r0, c0)`` leaving it with heading ``d0`` (0 east, 1 south, 2 west, 3 north)
    along an edge with a pixel of ``mask`` on its right and none on its left: east from
    the top-left corner of the first pixel of a part in raster order gives the part's
    outer ring, west from the top-right corner of the first pixel of a hole gives the
    hole's ring.  A corner where the heading changes is a vertex; a corner whose
    ahead-left pixel is in ``mask`` and ahead-right pixel is not (a diagonal contact) is
    passed by turning left and gives two points ``cut`` either side of it.  Returns the
    vertices float64 (K, 2) (pixel-corner coordinates, corner (i, j) at (i, j)) and the
    ring's length in pixel edges."""
    out = np.empty((64, 2))
    r, c, d = r0, c0, d0
    k = 0
    steps = 0
    while True:
        steps += 1
        r += _DR[d]
        c += _DC[d]
        left = _inside(mask, r + _AHEAD[d, 0, 0], c + _AHEAD[d, 0, 1])
        right = _inside(mask, r + _AHEAD[d, 1, 0], c + _AHEAD[d, 1, 1])
        if left:
            nd = (d + 3) % 4
        elif right:
            nd = d
        else:
            nd = (d + 1) % 4
        if k + 2 > out.shape[0]:
            grown = np.empty((2 * out.shape[0], 2))
            grown[:k] = out[:k]
            out = grown
        if left and not right:
            out[k, 0] = r - cut * _DR[d]
            out[k, 1] = c - cut * _DC[d]
            out[k + 1, 0] = r + cut * _DR[nd]
            out[k + 1, 1] = c + cut * _DC[nd]
            k += 2
        elif nd != d:
            out[k, 0] = r
            out[k, 1] = c
            k += 1
        d = nd
        if r == r0 and c == c0 and d == d0:
            return out[:k], steps


@cached_njit(nogil=True)
def _crack_length(mask):
    """Number of pixel edges between ``mask`` (uint8 0/1) and the rest, the space off it
    included: changes along rows and columns, and its pixels on the four borders."""
    h, w = mask.shape
    n = 0
    for c in range(w):
        n += mask[0, c] + mask[h - 1, c]
    for r in range(h):
        n += mask[r, 0] + mask[r, w - 1]
        for c in range(1, w):
            n += mask[r, c] != mask[r, c - 1]
    for r in range(1, h):
        for c in range(w):
            n += mask[r, c] != mask[r - 1, c]
    return n


def outline(mask: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
    """The outline of the largest 8-connected part of ``mask`` as one simple ring, and the
    rings round its holes.

    Parameters
    ----------
    mask : bool (H, W)

    Returns
    -------
    ring : float64 (K, 2)
        Vertices (row, col) in pixel coordinates of ``mask`` (pixel centres at integers,
        so pixel corners at half-integers), first point not repeated, collinear points
        left out, clockwise on the screen (rows down); empty (0, 2) for an empty mask.
        The ring runs along the pixel edges between the part and the space outside it
        and encloses the part's holes; a diagonal contact between two pixels of the part
        is a neck of width ``PINCH_PX * sqrt(2)``.
    holes : tuple of float64 (K, 2)
        One ring per hole (a 4-connected part of the pixels off the outlined part that
        does not reach the edge of ``mask``: other rooms, pixels of no room, the room's
        smaller parts), along the pixel edges between it and the part,
        counter-clockwise on the screen, in raster order of the holes' first pixels.  A
        diagonal contact is cut as on the outer ring, off the empty pixel the ring turns
        round, so holes that meet each other or the outside at a corner stay
        ``PINCH_PX * sqrt(2)`` apart there.
    """
    if mask.dtype == np.bool_ and mask.flags.c_contiguous:
        m = mask.view(np.uint8)
    else:
        m = np.ascontiguousarray(mask, dtype=np.uint8)
    flat = int(np.argmax(m))
    if not m.flat[flat]:
        return np.empty((0, 2)), ()
    r0, c0 = divmod(flat, m.shape[1])
    ring, length = _trace(m, r0, c0, 0, PINCH_PX)
    if length == _crack_length(m):  # one part, no holes
        return ring - 0.5, ()
    # holes or other parts: trace the largest part, the first in raster order among equals
    n, parts = cv2.connectedComponents(m, connectivity=8)
    size = np.bincount(parts.ravel(), minlength=n)
    size[0] = 0
    firsts = [int(np.argmax(parts == k)) for k in np.flatnonzero(size == size.max())]
    flat = min(firsts)
    m = (parts == parts.flat[flat]).view(np.uint8)
    r0, c0 = divmod(flat, m.shape[1])
    ring, length = _trace(m, r0, c0, 0, PINCH_PX)
    if length == _crack_length(m):
        return ring - 0.5, ()
    return ring - 0.5, _hole_rings(m)


def _hole_rings(part: np.ndarray) -> tuple[np.ndarray, ...]:
    """The rings round the holes of ``part`` (uint8 (H, W), one 8-connected part): the
    4-connected parts of the rest that do not reach its edge, in raster order of their
    first pixels, each traced west from its first pixel's top-right corner (the pixel
    above and the pixel left of a hole's first pixel are in ``part``)."""
    h, w = part.shape
    rest = np.ones((h + 2, w + 2), np.uint8)
    rest[1:-1, 1:-1] = 1 - part
    n, comp, stats, _ = cv2.connectedComponentsWithStats(rest, connectivity=4)
    outside = comp[0, 0]
    firsts = []
    for k in range(1, n):
        if k != outside:
            r = int(stats[k, cv2.CC_STAT_TOP]) - 1  # the hole's top row in ``part``
            firsts.append((r, int(np.argmax(comp[r + 1, 1:-1] == k))))
    rings = []
    for r, c in sorted(firsts):
        ring, _ = _trace(part, r, c + 1, 2, PINCH_PX)
        rings.append(ring - 0.5)
    return tuple(rings)
