"""Tile bookkeeping shared by the mapper's kernels: slot lookup, flat offsets, pixel
gather/scatter, kernel batch plans, packed pixel keys and the worker threads.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from .._cpus import usable_cpus
from .._jit import cached_njit
from .._words import memory_size
from ..fields.distance import FAR_SQ
from ..fields.tiling import TileManager

_FAR_BOUND = 1 << 62  # larger than any squared pixel distance in int64 arithmetic


_MAX_ABS_PIXEL = 1 << 30  # packed pixel keys shift rows by 32 bits


_UINT16_MAX = 65535


_U64 = numba.uint64  # unsigned flat offsets (see _gather_ridge_patches)


_POOLS: dict = {}  # thread name -> (process id, its executor in that process)


def _shared_thread(name: str):
    """A one-thread executor shared by all mappers of this process (None on a single-CPU
    machine).  Keyed by process id: a child forked after the thread started has the
    executor object but not its thread, so it makes its own."""
    pid = os.getpid()
    owner, pool = _POOLS.get(name, (None, None))
    if owner != pid:
        pool = ThreadPoolExecutor(1, thread_name_prefix=name) if usable_cpus() > 1 else None
        _POOLS[name] = (pid, pool)
    return pool


def _worker_pool():
    """The worker thread: splat pairing and free-cell counting."""
    return _shared_thread("topojax")


def _growth_pool():
    """A second thread that pages in the tile storage of the next growth
    (:meth:`TileManager.prepare_growth`) without holding up the worker's short jobs."""
    return _shared_thread("topojax-grow")


@cached_njit(nogil=True, inline="always")
def _log2(n):
    """``log2(n)`` of a power of two: tile and block coordinates are then shifts and masks
    (an integer division costs 20-40 cycles, and the per-pixel loops do several)."""
    s = 0
    while (1 << s) < n:
        s += 1
    return s


@cached_njit(nogil=True)
def _slot(grid, g0r, g0c, sh, r, c):
    """Storage slot of the tile of pixel ``(r, c)`` (tiles of side ``2**sh``), or -1."""
    tr = r >> sh
    tc = c >> sh
    gi = tr - g0r
    gj = tc - g0c
    if gi < 0 or gj < 0 or gi >= grid.shape[0] or gj >= grid.shape[1]:
        return -1
    return grid[gi, gj]


@cached_njit(nogil=True, inline="always")
def _flat(a):
    """1-D view of a C-contiguous array (numba refuses ``reshape`` of any other layout at
    compile time, where ``ravel`` would silently return a copy and lose writes)."""
    return a.reshape(a.size)


@cached_njit(nogil=True, inline="always")
def _unflat(f, sh):
    """Flat index ``slot * t^2 + row * t + col`` (``t = 2**sh``) -> ``(slot, row, col)``;
    also a flat block id, with ``t`` blocks per tile side."""
    m = (1 << sh) - 1
    return f >> (2 * sh), (f >> sh) & m, f & m


@cached_njit(nogil=True, inline="always")
def _locate(grid, g0r, g0c, sh, r, c):
    """Pixel ``(r, c)`` in tile storage (tiles of side ``2**sh``): ``(slot, local row,
    local col)``, slot -1 if its tile is not allocated."""
    m = (1 << sh) - 1
    return _slot(grid, g0r, g0c, sh, r, c), r & m, c & m


@cached_njit(nogil=True, inline="always")
def _wrap_into_tile(local, t):
    """A tile-local index that may lie one tile before or after, as (index in that tile,
    neighbour 0/1/2 for the previous / same / next tile along this axis)."""
    if local < 0:
        return local + t, 0
    if local >= t:
        return local - t, 2
    return local, 1


@cached_njit(nogil=True, inline="always")
def _around(nbr9, s0, lr0, lc0, k, t):
    """Pixel ``k`` (0..8, row-major) of the 3 x 3 neighbourhood of the tile-local pixel
    ``(lr0, lc0)`` of slot ``s0``: ``(slot, local row, local col)``, slot -1 where that
    tile (or ``s0``) does not exist."""
    nr, oy = _wrap_into_tile(lr0 + k // 3 - 1, t)
    nc, ox = _wrap_into_tile(lc0 + k % 3 - 1, t)
    s = nbr9[s0, 3 * oy + ox] if s0 >= 0 else -1
    return s, nr, nc


@cached_njit(nogil=True)
def _gather_px(layer, grid, g0r, g0c, t, rows, cols, fill, out):
    tsh = _log2(t)
    for i in range(rows.shape[0]):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, rows[i], cols[i])
        out[i] = fill if s < 0 else layer[s, lr, lc]


@cached_njit(nogil=True)
def _scatter_px(layer, grid, g0r, g0c, t, rows, cols, values):
    """Write ``values`` at global pixels; returns how many pixels lie in missing tiles."""
    tsh = _log2(t)
    missing = 0
    for i in range(rows.shape[0]):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, rows[i], cols[i])
        if s < 0:
            missing += 1
        else:
            layer[s, lr, lc] = values[i]
    return missing


@cached_njit(nogil=True)
def _clear_region(zr, zc, grid, g0r, g0c, t, mark):
    """Zero ``mark`` at the pixels ``(zr, zc)``."""
    tsh = _log2(t)
    for i in range(zr.shape[0]):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, zr[i], zc[i])
        if s >= 0:
            mark[s, lr, lc] = 0


@cached_njit(nogil=True)
def _clear_owned(layer, grid, g0r, g0c, t, rows, cols, owner):
    """Set ``layer`` to -1 at the pixels whose value equals ``owner[i]``."""
    tsh = _log2(t)
    for i in range(rows.shape[0]):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, rows[i], cols[i])
        if s >= 0 and layer[s, lr, lc] == owner[i]:
            layer[s, lr, lc] = -1


def _batches(n: int, sizes: tuple[int, int]):
    """Cut ``n`` items into fixed-size kernel batches: ``(start, stop, size)`` with
    ``stop - start <= size``; the large size while at least half of it is left."""
    small, large = sizes
    start = 0
    while start < n:
        size = large if n - start >= large // 2 else small
        stop = min(n, start + size)
        yield start, stop, size
        start = stop


def _aligned_empty(shape, dtype, align: int = 64) -> np.ndarray:
    """``np.empty`` whose data starts on an ``align``-byte boundary: JAX on a CPU then uses
    the array in place as a kernel input instead of copying it, so it must not be written
    to while a kernel dispatched on it may still run."""
    dtype = np.dtype(dtype)
    nbytes = math.prod(shape) * dtype.itemsize
    buf = np.empty(nbytes + align, np.uint8)
    off = -buf.ctypes.data % align
    return buf[off : off + nbytes].view(dtype).reshape(shape)


def _max_padding(sizes: tuple[int, int]) -> int:
    """The most padding rows a batch of :func:`_batches` gets: a large batch starts with at
    least half of it left, a small one with at least one row."""
    small, large = sizes
    return max(large - large // 2, small - 1)


def _grown(a: np.ndarray, cap: int) -> np.ndarray:
    """``a`` zero-padded along axis 0 to ``cap`` rows."""
    out = np.zeros((cap,) + a.shape[1:], a.dtype)
    out[: a.shape[0]] = a
    return out


def _flags(n: int, idx: np.ndarray) -> np.ndarray:
    """Bool array of length ``n``, True at ``idx``."""
    out = np.zeros(n, bool)
    out[idx] = True
    return out


def _pack(rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Pixel coordinates -> one int64 key each (order-preserving within a row)."""
    return (np.asarray(rows, np.int64) << 32) + (np.asarray(cols, np.int64) + (1 << 31))


def _unpack(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    keys = np.asarray(keys, np.int64)
    rows = keys >> 32  # the column part lies in [0, 2^32)
    cols = keys - (rows << 32) - (1 << 31)
    return rows, cols


#: Tile storage reserved when a mapper starts: address space, whose pages are mapped on
#: first use (64 GiB: about 230,000 tiles of 128 px).  A map within it never grows its
#: storage, so no scan waits for a copy of every tile.  Where the system refuses the
#: reservation (strict overcommit, ``ulimit -v``) the storage starts small and grows.
INITIAL_STORAGE_BYTES = 1 << 36


def new_tile_storage(tile_px: int, block_px: int, max_grid_cells: int) -> TileManager:
    """The mapper's tile storage: one layer per per-pixel quantity (hit / miss counts,
    squared distance, Laplacian, ridge, skeleton, graph ids, scratch marks, thinning
    history) and two per block (largest squared distance, ridge-dirty flag)."""
    nb = tile_px // block_px
    return TileManager(
        tile_px=tile_px,
        layers={
            "hits": (np.uint16, 0),
            "misses": (np.uint16, 0),
            "sq_distance": (np.int32, FAR_SQ),
            "lap_abs": (np.uint8, 0),
            "ridge": (np.bool_, False),
            "skeleton": (np.bool_, False),
            "graph_id": (np.int32, -1),
            "mark": (np.uint8, 0),
            "thin_time": (np.uint16, 0),
            "block_max": (np.int32, FAR_SQ, (nb, nb)),
            "ridge_dirty": (np.bool_, False, (nb, nb)),
        },
        loops=("ridge",),
        max_grid_cells=max_grid_cells,
        reserve_bytes=INITIAL_STORAGE_BYTES,
    )


#: Bytes per bounding-box pixel each dense export may hold at its peak (its outputs,
#: the layers it reads and the temporaries between them), as traced on a replay's
#: exports with some margin (:func:`check_export_budget`).
EXPORT_BYTES_PER_PX = {
    "obstacles": 4,
    "ridges": 2,
    "lap_abs": 2,
    "skeleton": 2,
    "sq_distance_px": 8,
    "occupancy": 10,
    "occupancy_window": 10,
    "distance": 16,
    "to_result": 40,
    "route_graph": 64,
    "rooms": 48,
}


class ExportBudgetError(ValueError):
    """A dense export refused because it would allocate more than the mapper's
    ``max_export_bytes``."""


def check_export_budget(mapper, what: str, box: tuple[int, int, int, int]) -> None:
    """Raise :class:`ExportBudgetError` if the export ``what`` (a key of :data:`EXPORT_BYTES_PER_PX`) over
    the global pixel box ``(row0, col0, row1, col1)`` (end exclusive) would allocate more
    than ``mapper.max_export_bytes``; the message says how to export a window."""
    r0, c0, r1, c1 = box
    h, w = max(r1 - r0, 0), max(c1 - c0, 0)
    per_px = EXPORT_BYTES_PER_PX[what]
    need = h * w * per_px
    if need <= mapper.max_export_bytes:
        return
    res = mapper.resolution_m
    span = ""
    bbox = mapper._tiles.pixel_bbox
    if bbox is not None:
        span = (
            f" (the mapped area spans x {bbox[1] * res:g}..{bbox[3] * res:g} m, "
            f"y {-bbox[2] * res:g}..{-bbox[0] * res:g} m)"
        )
    amount = memory_size(need)
    if what == "occupancy_window":
        instead = "ask for a smaller window"
    else:
        instead = (
            "export a window instead with "
            "mapper.occupancy_window((x_min, y_min, x_max, y_max)) in metres"
        )
    raise ExportBudgetError(
        f"mapper.{what}: refused to allocate about {amount} for {h} x {w} "
        f"px ({w * res:g} m x {h * res:g} m, about {per_px} bytes per pixel), more than "
        f"max_export_bytes={mapper.max_export_bytes}; {instead}{span}, or make "
        "the mapper with a larger max_export_bytes"
    )


def window_box(mapper, bbox) -> tuple[int, int, int, int]:
    """Global pixel box ``(row0, col0, row1, col1)`` (end exclusive) of the pixels whose
    squares meet the world box ``bbox = (x_min, y_min, x_max, y_max)`` in metres.

    Raises
    ------
    ValueError
        If ``bbox`` is not four finite numbers with ``x_min < x_max`` and
        ``y_min < y_max``, covers less than 2 x 2 pixels or reaches beyond 2^30 pixels.
    """
    try:
        values = [float(v) for v in bbox]
        if len(values) != 4 or any(isinstance(v, (bool, np.bool_, str)) for v in bbox):
            raise TypeError
    except (TypeError, ValueError):
        raise ValueError(
            "bbox: expected (x_min, y_min, x_max, y_max), four numbers in metres, "
            f"received {bbox!r}"
        ) from None
    x0, y0, x1, y1 = values
    if not all(math.isfinite(v) for v in values) or not (x0 < x1 and y0 < y1):
        raise ValueError(
            "bbox: expected (x_min, y_min, x_max, y_max) finite metres with x_min < x_max "
            f"and y_min < y_max, received {tuple(values)}"
        )
    res = mapper.resolution_m
    box = (
        math.floor(-y1 / res),
        math.floor(x0 / res),
        math.ceil(-y0 / res),
        math.ceil(x1 / res),
    )
    if max(abs(v) for v in box) > _MAX_ABS_PIXEL:
        raise ValueError(
            f"bbox: {tuple(values)} reaches beyond {_MAX_ABS_PIXEL} px from the origin at "
            f"resolution {res} m; expected metres"
        )
    if box[2] - box[0] < 2 or box[3] - box[1] < 2:
        raise ValueError(
            f"bbox: expected a window of at least 2 x 2 pixels ({2 * res:g} m a side), "
            f"received {tuple(values)}: {box[2] - box[0]} x {box[3] - box[1]} px"
        )
    return box


def pixel_indices(name: str, value: np.ndarray, sign: float, res: float) -> np.ndarray:
    """The lattice pixel indices ``floor(sign * value / res)`` of the finite coordinates
    ``value`` (``name``: ``"x"`` or ``"y"``), int64, after checking each fits: a
    ValueError naming ``name`` otherwise (a cast would give int64's minimum)."""
    index = np.floor(sign * value / res)
    fits = np.abs(index) < 2.0**63
    if not fits.all():
        raise ValueError(
            f"{name}: expected coordinates within {2.0**63 * res:g} m of 0 (a pixel index "
            f"that fits an int64 at {res:g} m per pixel), received "
            f"{float(value[~fits].flat[0])!r} among them"
        )
    return index.astype(np.int64)
