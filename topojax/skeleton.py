"""Thinning of binary ridge maps into 1-pixel skeletons, and T-junction-centre removal.

Two parallel two-sub-iteration thinning algorithms are provided, each bit-exact with the
scikit-image 0.26 function that the original IncrementalTopo code used:

* ``method="guo_hall"``: Guo & Hall (1989), algorithm A1, identical to
  :func:`skimage.morphology.thin`.
* ``method="zhang"``: Zhang & Suen (1984) as implemented by
  :func:`skimage.morphology.skeletonize` for 2-D input (its default method), including the
  places where scikit-image's lookup table departs from the published conditions.

Both are run by a numba kernel that only re-examines pixels whose 3x3 neighbourhood changed
since they were last examined by the same kind of sub-iteration (see :func:`thin`), with
output identical to scikit-image's.

:func:`remove_t_centres` reproduces step 5 of the original pipeline (``remove_Tcenter``) and
:func:`skeletonize_ridges` chains the two.

Arrays are indexed ``[row, col]`` with row 0 at the top of the image.
"""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace
from typing import Any

import numpy as np

from ._jit import cached_njit
from ._validate import binary_image, flag, one_of

__all__ = [
    "THIN_METHODS",
    "remove_t_centres",
    "skeletonize_ridges",
    "thin",
    "thinning_lookup_tables",
]

#: Thinning methods accepted by :func:`thin` and :func:`skeletonize_ridges`.
THIN_METHODS: tuple[str, ...] = ("guo_hall", "zhang")

# Neighbour k of a pixel contributes bit k (value 2**k) to its 8-bit neighbourhood code.
# The order is counter-clockwise starting east, i.e. x1..x8 of Guo & Hall (1989):
#   bit 0: E, 1: NE, 2: N, 3: NW, 4: W, 5: SW, 6: S, 7: SE.
# The same (d_row, d_col) offsets are used by the numba kernel.
_NEIGHBOUR_OFFSETS: tuple[tuple[int, int], ...] = (
    (0, 1),
    (-1, 1),
    (-1, 0),
    (-1, -1),
    (0, -1),
    (1, -1),
    (1, 0),
    (1, 1),
)


def _neighbour_bits(code: int) -> tuple[int, ...]:
    """Return the 8 neighbour values (0/1) of ``code`` in the order E, NE, N, NW, W, SW, S, SE."""
    return tuple((code >> k) & 1 for k in range(8))


def _guo_hall_tables() -> np.ndarray:
    """Deletion tables of Guo & Hall (1989), algorithm A1, from the published conditions.

    With x1..x8 the neighbours E, NE, N, NW, W, SW, S, SE (indices wrap, x9 = x1), a
    foreground pixel is deleted in a sub-iteration when

    * G1: the crossing number X_H = #{i in 1..4 : x_{2i-1} = 0 and (x_{2i} = 1 or
      x_{2i+1} = 1)} equals 1;
    * G2: 2 <= min(N1, N2) <= 3, with N1 = sum_k (x_{2k-1} or x_{2k}) and
      N2 = sum_k (x_{2k} or x_{2k+1}), k = 1..4;
    * G3 (first sub-iteration): (x2 or x3 or not x8) and x1 is false;
      G3' (second sub-iteration): (x6 or x7 or not x4) and x5 is false.
    """
    tables = np.zeros((2, 256), dtype=bool)
    for code in range(256):
        x = (0,) + _neighbour_bits(code)  # 1-based: x[1] .. x[8]

        def xi(i: int, x: tuple[int, ...] = x) -> int:
            return x[(i - 1) % 8 + 1]

        crossing = sum(1 for i in range(1, 5) if not xi(2 * i - 1) and (xi(2 * i) or xi(2 * i + 1)))
        n1 = sum(1 for k in range(1, 5) if xi(2 * k - 1) or xi(2 * k))
        n2 = sum(1 for k in range(1, 5) if xi(2 * k) or xi(2 * k + 1))
        g12 = crossing == 1 and 2 <= min(n1, n2) <= 3
        g3 = not ((xi(2) or xi(3) or not xi(8)) and xi(1))
        g3p = not ((xi(6) or xi(7) or not xi(4)) and xi(5))
        tables[0, code] = g12 and g3
        tables[1, code] = g12 and g3p
    return tables


# Neighbourhoods at which scikit-image's Zhang-Suen lookup table (used unchanged by
# ``skimage.morphology.skeletonize`` since v0.12, still in 0.26) differs from the
# published conditions. Each pattern is the 3x3 window "NW N NE/W C E/SW S SE" ('#' set,
# '.' unset, the centre C is always set); the number says in which sub-iterations
# scikit-image deletes the centre: 0 never, 1 first only, 2 second only, 3 both. These
# entries were established by comparing the published rule with scikit-image's behaviour and
# are verified by the test-suite against ``skimage.morphology.skeletonize`` on random images.
_SKIMAGE_ZHANG_DEVIATIONS: tuple[tuple[str, int], ...] = (
    ("##./.#./...", 1),
    (".##/.#./...", 1),
    (".#./.##/...", 3),
    ("##./.##/...", 1),
    ("..#/.##/...", 1),
    (".##/.##/...", 1),
    (".../.##/..#", 2),
    (".#./.##/..#", 2),
    (".../.##/.#.", 3),
    (".../.#./.##", 0),
    (".../.##/.##", 2),
    (".../.#./##.", 2),
    (".../.##/##.", 2),
    ("..#/.##/##.", 2),
    ("#../##./...", 0),
    (".#./##./...", 3),
    ("##./##./...", 1),
    (".##/##./...", 1),
    (".../##./.#.", 3),
    ("#../##./.#.", 1),
    (".../##./.##", 2),
    (".../##./#..", 2),
    (".#./##./#..", 1),
    (".##/##./#..", 1),
    (".../##./##.", 2),
)


def _pattern_code(pattern: str) -> int:
    """8-bit neighbourhood code of a ``"abc/def/ghi"`` 3x3 pattern ('#' set, '.' unset)."""
    rows = pattern.split("/")
    if len(rows) != 3 or any(len(r) != 3 for r in rows) or rows[1][1] != "#":
        raise ValueError(f"malformed 3x3 pattern {pattern!r}")
    code = 0
    for k, (dr, dc) in enumerate(_NEIGHBOUR_OFFSETS):
        if rows[1 + dr][1 + dc] == "#":
            code |= 1 << k
    return code


def _zhang_suen_paper_tables() -> np.ndarray:
    """Deletion tables of Zhang & Suen (1984) from the published conditions.

    With P2..P9 the neighbours N, NE, E, SE, S, SW, W, NW, B the number of set neighbours and
    A the number of 0 -> 1 transitions in the cyclic sequence P2, P3, ..., P9, P2, a
    foreground pixel is deleted when 2 <= B <= 6, A = 1 and, in the first sub-iteration,
    P2*P4*P6 = 0 and P4*P6*P8 = 0; in the second, P2*P4*P8 = 0 and P2*P6*P8 = 0.
    """
    tables = np.zeros((2, 256), dtype=bool)
    for code in range(256):
        e, ne, n, nw, w, sw, s, se = _neighbour_bits(code)
        p = (n, ne, e, se, s, sw, w, nw)  # P2 .. P9
        b = sum(p)
        a = sum(1 for i in range(8) if p[i] == 0 and p[(i + 1) % 8] == 1)
        base = 2 <= b <= 6 and a == 1
        tables[0, code] = base and n * e * s == 0 and e * s * w == 0
        tables[1, code] = base and n * e * w == 0 and n * s * w == 0
    return tables


def _zhang_skimage_tables() -> np.ndarray:
    """Zhang-Suen deletion tables exactly as ``skimage.morphology.skeletonize`` applies them."""
    tables = _zhang_suen_paper_tables()
    for pattern, passes in _SKIMAGE_ZHANG_DEVIATIONS:
        code = _pattern_code(pattern)
        tables[0, code] = bool(passes & 1)
        tables[1, code] = bool(passes & 2)
    return tables


_TABLES: dict[str, np.ndarray] = {
    "guo_hall": _guo_hall_tables(),
    "zhang": _zhang_skimage_tables(),
}
TABLES_U8: dict[str, np.ndarray] = {k: v.astype(np.uint8) for k, v in _TABLES.items()}
for _table in _TABLES.values():
    _table.flags.writeable = False


def thinning_lookup_tables(method: str = "guo_hall") -> np.ndarray:
    """Return the deletion lookup tables used by :func:`thin`.

    Parameters
    ----------
    method : {"guo_hall", "zhang"}
        Thinning method.

    Returns
    -------
    numpy.ndarray
        Read-only bool array of shape (2, 256). Entry ``[s, code]`` is True when a foreground
        pixel whose 8 neighbours have the code ``code`` is deleted in sub-iteration ``s``
        (0 = first, 1 = second). Neighbour k contributes ``2**k`` to the code, in the order
        E, NE, N, NW, W, SW, S, SE (k = 0..7), where N is the row above (row - 1) and E the
        column to the right (col + 1).
    """
    return _TABLES[one_of("method", method, list(THIN_METHODS))]


@cached_njit(nogil=True, inline="always")
def compact(idx, n, keep):
    """Keep, in order and in place, the entries ``i`` of ``idx[:n]`` with ``keep[i]``
    non-zero; return how many there are."""
    m = 0
    for ii in range(n):
        i = idx[ii]
        idx[m] = i
        m += int(keep[i])  # int: a uint8 sum would wrap when numba is off
    return m


@cached_njit(nogil=True)
def _thin_flat(
    flat: np.ndarray,
    n_cols: int,
    tables: np.ndarray,
    n_fg: int,
    lists: np.ndarray,
) -> tuple[int, int]:
    """Thin a zero-framed image in place; return the number of deleted pixels and of
    sub-iterations run.

    ``flat`` is the raveled uint8 (0/1) image of ``n_cols`` columns whose first and last rows
    and columns are 0 (the frame stands for the background outside the image, and lets every
    foreground pixel read its 8 neighbours without bounds checks), followed by zero padding up
    to a multiple of 8 bytes. ``n_fg`` is its number of foreground pixels and ``tables`` the
    uint8 (2, 256) deletion table of the two sub-iterations.

    Sub-iteration t (kind t % 2) decides every deletion from the image as it was at the start
    of t and then applies them all. A pixel's decision depends only on its 8 neighbours, so it
    can change between two sub-iterations of the same kind (t - 2 and t) only if a neighbour
    was deleted in t - 2 or t - 1. Sub-iterations 0 and 1 examine every foreground pixel. A
    later one examines either every remaining foreground pixel (while many pixels are being
    deleted, this is cheaper) or only the foreground 8-neighbours of the pixels deleted in the
    previous two; examining an unchanged pixel again is harmless, it gives the same decision.
    The loop ends when two consecutive sub-iterations deleted nothing: the image is then a
    fixed point of both, as at the end of the scikit-image loops.

    While the candidates of a sub-iteration are gathered, a queued pixel is marked by bit 1
    of its byte (1 -> 3), so that it is queued once; the marks are cleared before the next
    sub-iteration reads the image.  ``lists`` (int32 or int64, (4, at least ``n_fg + 8``),
    holding indices into ``flat``) is the work space of the pixel lists (reused between
    calls).
    """
    o0 = 1
    o1 = 1 - n_cols
    o2 = -n_cols
    o3 = -n_cols - 1
    o4 = -1
    o5 = n_cols - 1
    o6 = n_cols
    o7 = n_cols + 1
    # Work lists with room for the unconditional (branch-free) stores below
    alive = lists[0]
    cand = lists[1]
    dels = lists[2]
    prev = lists[3]

    # Foreground pixels in raster order; skip all-zero 8-byte words.
    words = flat.view(np.uint64)
    n_alive = 0
    for w in range(words.size):
        if words[w]:
            base = w * 8
            for j in range(8):
                alive[n_alive] = base + j
                n_alive += int(flat[base + j])

    n_prev = 0
    deleted = 0
    use_alive = True
    n_cand = n_alive
    t = 0
    while n_cand > 0:
        lut = tables[t & 1]
        src = alive if use_alive else cand
        # Decide from the snapshot, then delete (parallel semantics).
        n_del = 0
        for i in range(n_cand):
            p = src[i]
            code = (
                flat[p + o0]
                | (flat[p + o1] << 1)
                | (flat[p + o2] << 2)
                | (flat[p + o3] << 3)
                | (flat[p + o4] << 4)
                | (flat[p + o5] << 5)
                | (flat[p + o6] << 6)
                | (flat[p + o7] << 7)
            )
            dels[n_del] = p
            n_del += int(lut[code])
        for i in range(n_del):
            flat[dels[i]] = 0
        deleted += n_del

        # Candidates of sub-iteration t + 1.
        changed = n_del + n_prev
        if t == 0 or 4 * changed > n_fg - deleted:
            n_alive = compact(alive, n_alive, flat)
            use_alive = True
            n_cand = n_alive if (changed > 0 or t == 0) else 0
        else:
            use_alive = False
            m = 0
            for i in range(changed):
                p = dels[i] if i < n_del else prev[i - n_del]
                for q in (p + o0, p + o1, p + o2, p + o3, p + o4, p + o5, p + o6, p + o7):
                    v = flat[q]
                    cand[m] = q
                    m += int(v == 1)  # set and not queued yet
                    flat[q] = v | (v << 1)  # 1 -> 3: queued; 0 stays 0
            for i in range(m):
                flat[cand[i]] = 1
            n_cand = m
        tmp = prev
        prev = dels
        dels = tmp
        n_prev = n_del
        t += 1
    return deleted, t


def _framed_buffer(image: np.ndarray, out: np.ndarray | None = None):
    """Copy a bool (H, W) image into a zero frame; return (flat buffer, (H+2, W+2) view).

    The flat uint8 buffer is zero-padded to a multiple of 8 bytes so that the kernels can scan
    it as 64-bit words.  ``out``: a uint8 buffer to use (its first bytes; at least that
    many), e.g. one reused between calls; default a new one.
    """
    n_rows, n_cols = image.shape
    n_total = (n_rows + 2) * (n_cols + 2)
    size = -(-n_total // 8) * 8
    if out is None:
        buf = np.zeros(size, dtype=np.uint8)
    else:
        buf = out[:size]
        buf[:] = 0
    framed = buf[:n_total].reshape(n_rows + 2, n_cols + 2)
    framed[1:-1, 1:-1] = image
    return buf, framed


def thin(ridge: Any, *, method: str = "guo_hall") -> np.ndarray:
    """Thin a binary image to a (nominally) 1-pixel-wide skeleton.

    Parameters
    ----------
    ridge : array_like, shape (H, W)
        Binary image (e.g. the ridge map), indexed ``[row, col]``. Any array convertible to
        bool is accepted: bool as is, numbers with nonzero = foreground (True). Float or
        complex input containing NaN is rejected. Pixels outside the image count as background.
    method : {"guo_hall", "zhang"}, keyword-only
        ``"guo_hall"``: Guo & Hall (1989) two-sub-iteration parallel thinning (algorithm A1),
        identical to ``skimage.morphology.thin(ridge)``. ``"zhang"``: Zhang & Suen (1984)
        parallel thinning with scikit-image's lookup table, identical to
        ``skimage.morphology.skeletonize(ridge)`` for 2-D input (scikit-image 0.26); that table
        differs from the published conditions at 25 of the 256 neighbourhoods (see
        ``_SKIMAGE_ZHANG_DEVIATIONS``).

    Returns
    -------
    numpy.ndarray
        New bool array of shape (H, W): the thinned image (a subset of the input foreground).

    Raises
    ------
    ValueError
        If ``method`` is unknown, ``ridge`` is not 2-D or contains NaN.
    TypeError
        If ``ridge`` has a non-numeric dtype (object, string, datetime).

    Notes
    -----
    Both algorithms repeat two sub-iterations until neither deletes a pixel. In each
    sub-iteration every deletion is decided from the image as it was at the start of that
    sub-iteration (parallel semantics): a foreground pixel is deleted when the lookup table of
    that sub-iteration (:func:`thinning_lookup_tables`) is True for the code of its 8
    neighbours. Like scikit-image's, the result can still contain 2x2 blocks of set pixels.

    Because a decision depends only on the 3x3 neighbourhood, after the first two
    sub-iterations only the foreground neighbours of the pixels deleted in the previous two
    sub-iterations need re-examining (while deletions are numerous, all remaining foreground
    pixels are re-examined instead, which is cheaper); the result is identical to re-examining
    every pixel. The cost is one linear scan of the image plus work proportional to the
    number of pixels examined. The first call in a fresh environment compiles the numba kernel
    (cached on disk afterwards). The work space is 1 byte per pixel plus 16 per foreground
    pixel; each thread keeps it for its next call for images up to 4 megapixels, and
    larger images get their skeleton in the work space's own image buffer.
    """
    method = one_of("method", method, list(THIN_METHODS))
    image = binary_image("ridge", ridge)
    if image.size == 0:
        return image.copy()
    n_fg = int(np.count_nonzero(image))
    h, w = image.shape
    size = -(-((h + 2) * (w + 2)) // 8) * 8
    kept = size <= _THIN_SCRATCH_MAX_PX
    scratch = _thin_scratch(size, n_fg + 8) if kept else _new_thin_scratch(size, n_fg + 8)
    buf, framed = _framed_buffer(image, out=scratch.flat)
    del image  # a copy of ``ridge`` where it was not bool: not needed any more
    _thin_flat(buf, framed.shape[1], TABLES_U8[method], n_fg, scratch.lists)
    if kept:  # the buffer is this thread's, for its next call
        return framed[1:-1, 1:-1].astype(bool)
    scratch.lists = None
    return _unframe(buf, h, w).view(bool)


@cached_njit(nogil=True)
def _unframe(buf: np.ndarray, h: int, w: int) -> np.ndarray:
    """The (h, w) image framed in ``buf`` (rows of ``w + 2`` after one frame row), moved
    to the start of ``buf`` row by row (each row moves towards the start, past no row
    not yet moved); returns that (h, w) view of ``buf``."""
    for r in range(h):
        src = (r + 1) * (w + 2) + 1
        dst = r * w
        for c in range(w):
            buf[dst + c] = buf[src + c]
    return buf[: h * w].reshape(h, w)


#: Per-thread work space of the thinning kernel, kept between calls: fresh map-sized
#: arrays would cost their page faults at every call, more than the thinning itself.
_THIN_SCRATCH = threading.local()
#: Largest image (framed pixels) whose work space is kept: 4 Mpx, 4 MB plus the lists.
_THIN_SCRATCH_MAX_PX = 1 << 22


def _thin_scratch(size: int, n_list: int):
    """This thread's work space for an image of ``size`` framed pixels (padding
    included, at most _THIN_SCRATCH_MAX_PX) and ``n_list`` list entries: ``flat`` (uint8
    image buffer) and ``lists`` (int32 (4, n))."""
    space = getattr(_THIN_SCRATCH, "space", None)
    if space is None or space.flat.size < size:
        space = _THIN_SCRATCH.space = _new_thin_scratch(size, n_list)
    elif space.lists.shape[1] < n_list:
        space.lists = np.empty((4, n_list), space.lists.dtype)
    return space


def _new_thin_scratch(size: int, n_list: int) -> SimpleNamespace:
    # int32 pixel indices where every index of the framed image fits (half the memory)
    index = np.int32 if size < _INT32_MAX - 16 else np.int64
    return SimpleNamespace(flat=np.empty(size, np.uint8), lists=np.empty((4, n_list), index))


_INT32_MAX = int(np.iinfo(np.int32).max)


@cached_njit(nogil=True)
def _n4_set(img: np.ndarray, r: int, c: int) -> int:
    """Number of set 4-neighbours of (r, c); pixels outside the image count as unset."""
    n_rows, n_cols = img.shape
    count = 0
    if r > 0 and img[r - 1, c]:
        count += 1
    if r < n_rows - 1 and img[r + 1, c]:
        count += 1
    if c > 0 and img[r, c - 1]:
        count += 1
    if c < n_cols - 1 and img[r, c + 1]:
        count += 1
    return count


@cached_njit(nogil=True)
def remove_t_centres_inplace(img: np.ndarray) -> int:
    """In-place T-centre removal on a uint8 (0/1) image; return the number of cleared pixels."""
    n_rows, n_cols = img.shape
    cleared = 0
    # Interior pixels, raster order (row by row, left to right).
    for r in range(1, n_rows - 1):
        for c in range(1, n_cols - 1):
            if img[r, c]:
                n = 0
                if img[r - 1, c]:
                    n += 1
                if img[r + 1, c]:
                    n += 1
                if img[r, c - 1]:
                    n += 1
                if img[r, c + 1]:
                    n += 1
                if n >= 3:
                    img[r, c] = 0
                    cleared += 1
    # Border rows then border columns (corners excluded: they have only 2 in-image
    # 4-neighbours and are never cleared).
    if n_rows >= 2:
        for r in (0, n_rows - 1):
            for c in range(1, n_cols - 1):
                if img[r, c] and _n4_set(img, r, c) >= 3:
                    img[r, c] = 0
                    cleared += 1
    if n_cols >= 2:
        for c in (0, n_cols - 1):
            for r in range(1, n_rows - 1):
                if img[r, c] and _n4_set(img, r, c) >= 3:
                    img[r, c] = 0
                    cleared += 1
    return cleared


def remove_t_centres(skeleton: Any) -> np.ndarray:
    """Clear the centre pixel of every T (and +) junction, as the original pipeline does.

    Parameters
    ----------
    skeleton : array_like, shape (H, W)
        Binary skeleton indexed ``[row, col]``; converted to bool like ``ridge`` in
        :func:`thin` (nonzero = set, NaN rejected).

    Returns
    -------
    numpy.ndarray
        New bool array of shape (H, W); the input is not modified.

    Raises
    ------
    ValueError
        If ``skeleton`` is not 2-D or contains NaN.
    TypeError
        If ``skeleton`` has a non-numeric dtype.

    Notes
    -----
    Reproduces ``remove_Tcenter`` of the original IncrementalTopo implementation exactly
    (verified on its reference outputs). A set pixel is a *T centre* when at least three of
    its four 4-neighbours (up, down, left, right) are set at the moment it is examined; pixels
    outside the image count as unset. T centres are cleared in place, one at a time, so a
    clearing can stop a later pixel from being a T centre. The examination order is:

    1. interior pixels (rows 1..H-2, columns 1..W-2) in raster order, row by row, left to
       right;
    2. the top row (row 0), then the bottom row (row H-1), each left to right over columns
       1..W-2;
    3. the left column (column 0), then the right column (column W-1), each top to bottom over
       rows 1..H-2.

    For a border (non-corner) pixel this is the original's "1-D" check: it is cleared only
    when all three of its in-image 4-neighbours are set (e.g. on the top row: left, right and
    below). The four corner pixels are never cleared (they have only two in-image
    4-neighbours; the original's corner checks cannot fire either, because numpy bool ``+``
    acts as OR). For H == 1 or W == 1 nothing is cleared (the original raises IndexError there
    when a pixel is set).
    """
    image = binary_image("skeleton", skeleton)
    out = image.astype(np.uint8)
    if out.size:
        remove_t_centres_inplace(out)
    return out.view(bool)


def skeletonize_ridges(
    ridge: Any,
    *,
    method: str = "guo_hall",
    remove_t: bool = True,
    timings_s: dict[str, float] | None = None,
) -> np.ndarray:
    """Thin a ridge map and (optionally) remove T-junction centres.

    Parameters
    ----------
    ridge : array_like, shape (H, W)
        Binary ridge map indexed ``[row, col]`` (see :func:`thin` for accepted dtypes).
    method : {"guo_hall", "zhang"}, keyword-only
        Thinning method passed to :func:`thin`.
    remove_t : bool, keyword-only
        If True (default), apply :func:`remove_t_centres` to the thinned image.
    timings_s : dict, keyword-only, optional
        If given, receives the wall times of the two steps in seconds under
        ``"thinning"`` and ``"t_removal"``.

    Returns
    -------
    numpy.ndarray
        New bool array of shape (H, W): the skeleton.

    Raises
    ------
    ValueError, TypeError
        As :func:`thin`; also TypeError if ``remove_t`` is not a bool.
    """
    flag("remove_t", remove_t)
    t0 = time.perf_counter()
    skeleton = thin(ridge, method=method)
    t1 = time.perf_counter()
    if remove_t and skeleton.size:
        remove_t_centres_inplace(skeleton.view(np.uint8))  # thin's output is our own
    if timings_s is not None:
        timings_s["thinning"] = t1 - t0
        timings_s["t_removal"] = time.perf_counter() - t1
    return skeleton
