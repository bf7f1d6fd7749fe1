"""Incremental topology mapping from laser scans (paper §III, made exact).

A robot streams laser scans with poses; :class:`IncrementalMapper` keeps the obstacle map,
the distance map, the ridges, the skeleton and the topology graph up to date while touching
only what changed.  Three loops run on their own schedules (paper defaults 1 / 20 / 80
scans) or on explicit calls:

1. **Distance loop** (every scan, :meth:`IncrementalMapper.add_scan`).  Beam end points
   become obstacle pixels of an unbounded pixel lattice stored in tiles
   (:class:`~topojax.tiling.TileManager`, allocated on demand in every direction); free
   cells along each beam (Bresenham) are counted for the occupancy output, in batches: at
   each skeleton update on a worker thread (while the update runs), or when the
   occupancy, the tiles or the state are read (the counts saturate, so the order does
   not matter).  Pixels hit for
   the first time are *new obstacles* (obstacles are monotone, like the paper's max-merge);
   they are Gaussian max-splatted into the blocks they can affect.  Because the Gaussian
   decreases with distance, the splat is kept as the integer windowed squared distance
   ``d2(x) = min (dr^2 + dc^2)`` over obstacles ``p`` with ``|x - p|_inf <= R``: the max of
   kernels becomes a min of squared distances, and ``H = exp(-d2 / (2 sigma^2))`` is
   computed from it on demand.
2. **Skeleton loop** (every ``skeleton_every`` scans, :meth:`IncrementalMapper.update_skeleton`).
   Ridges are recomputed on the blocks whose 2-pixel neighbourhood changed, then the
   skeleton is updated with one of two strategies (``"exact"``, ``"paper"``).
3. **Graph loop** (every ``graph_every`` scans, :meth:`IncrementalMapper.update_graph`).
   The graph is patched around the changed skeleton pixels only (paper §III-C); vertices
   and edges elsewhere keep their ids.  Each update returns a :class:`GraphUpdate`.

World grid
----------
Pixel ``(row, col)`` of the lattice (any integers) has its centre at
``x = (col + 0.5) * resolution_m``, ``y = -(row + 0.5) * resolution_m`` in the map frame
(rows grow downwards, i.e. towards -y, as in images).  Exported dense arrays
(:attr:`IncrementalMapper.distance`, :attr:`~IncrementalMapper.occupancy`, ...) cover the
bounding box of the allocated tiles; the exported :class:`~topojax.maps.OccupancyMap` has
the ``origin`` that makes its ``pixel_to_world`` agree with the formula above, so
:func:`topojax.build_graph` on it gives the same world coordinates.  Tiles are allocated
for every pixel within ``R + 2`` (Chebyshev) of an obstacle and for every beam cell, so a
tile that is not allocated has ``H = 0`` on it and on its 2-pixel halo (no ridges).

Splat kernel
------------
Tiles are cut into blocks of ``block_px`` (default 16).  A JAX kernel
(:func:`splat_block`, vmapped over a fixed batch of (block, 8 points) rows: two compiled
batch sizes, no recompilation) computes the windowed squared distance from a block's
pixels to up to 8 points; a numba step merges the rows into the tiles with a minimum.
Pairs (block, point) that cannot change a block are never formed, exactly: (a) the
squared distance from the point to the block is not below the block's maximum ``d2``;
(b) another obstacle within 2 pixels of the point is at least as near to all four block
corners (a half-plane test; see :func:`_splat_pairs` for why chains of such dominations
are safe); (c) the point is no nearer to the block than another new point of the same
batch is to the block's farthest corner (on intel this drops 58 % of the pairs left by
(a) and (b)).  Everything is integer, so the incremental ``d2`` equals the full-map one bit
for bit.

Exactness
---------
* Distance: ``sq_distance_px`` equals ``dense_fields(occupancy.occupied).sq_distance_px``
  exactly and ``distance`` equals the full-map ``H`` (the same float32 function).
* Ridges: the full pipeline's maths (:func:`~topojax.distance.gaussian_from_sq_distance`,
  :func:`~topojax.filters.laplacian_valid`, :func:`~topojax.filters.ridge_from_laplacian`)
  runs in JAX on haloed blocks; the gather applies ``BORDER_REFLECT_101`` at the border of
  the bounding box (index reflection commutes with the elementwise Gaussian).  When the
  box grows, the blocks along its old border are recomputed.
* ``"exact"`` skeleton, re-thinned locally.  Parallel thinning (Guo–Hall or Zhang–Suen)
  decides a pixel at sub-iteration ``s`` from its 8 neighbours' states at ``s``.  The
  mapper keeps, per pixel, the sub-iteration at which the thinning of the whole current
  ridge map deletes it (layer ``thin_time``: 0 off the ridge, ``s + 1``, or 65535 for a
  skeleton pixel).  After a ridge change it re-thins only the ridge pixels of the blocks
  around the changed pixels (:func:`_rethin`), reading the pixels just outside (the
  *ring*) from their stored history.  That is exact as long as every ring pixel sees the
  same neighbour states as before at every sub-iteration while it is alive (then, by
  induction over sub-iterations, nothing outside changes); the blocks of ring pixels for
  which this fails join the region and the round is repeated (it ends at the latest when
  the region covers whole ridge components, which have no ring).  T-centre removal
  examines pixels one at a time in raster order, interior first, then the border rows and
  columns (:func:`topojax.skeleton.remove_t_centres`), so a pixel reads the result of the
  4-neighbours examined before it and the thinned value of the others; the mapper
  re-examines, in that order, the pixels whose thinned value changed (or whose border rule
  changed when the bounding box grew), their 4-neighbours, and every later 4-neighbour of
  a pixel whose result changed (:func:`_t_update`).  The skeleton, and the stored
  history, equal those of the full-map pipeline on the exported map (tested after real
  and random replays, and against a whole-image reference on thick blobs, where the
  region has to grow).  :func:`thin_components` (whole components on a crop of their
  own) is the simpler exact alternative the mapper used before; it is kept as a utility.
* Graph: link masks and degrees of the pixel graph depend on 3x3 neighbourhoods, so only
  pixels within one pixel of a changed skeleton pixel (the region ``Z``) change.  Old
  edges that do not touch ``Z`` are edges of the new graph; every new edge that touches
  ``Z`` lies in ``A`` = the pixels of the old edges touching ``Z`` plus the new skeleton
  pixels in ``Z``.  The mapper traces the skeleton pixels within one pixel of ``A``
  (gathered from the tiles, so the cost follows the number of changed pixels, not their
  spread) with the kernels of :mod:`topojax.graph`, keeps the traced edges that lie in
  ``A`` and touch ``Z``, and replaces the old edges by them; an old edge whose path comes
  back unchanged keeps its key, and a vertex keeps its id while a vertex exists at its
  pixel.  Vertices and edges live in arrays indexed by id (the ``graph_id`` tile layer
  maps pixels back to ids), so an update costs no per-object Python containers.  Only
  net changes count: a pixel that changed and changed back since the last graph update is
  no change.  With the ``"exact"`` skeleton the graph equals ``build_graph`` on the
  exported map up to ids (same vertex pixels and kinds, same edge paths).  The tests check
  all of this after replays of real logs, and that every :class:`GraphUpdate` equals the
  difference of the graphs before and after it.

Laziness
--------
The splat of new obstacles is batched: pending points are flushed when
``max_pending_points`` are waiting, and before anything reads the distance map (the
skeleton loop, :attr:`~IncrementalMapper.distance`, :attr:`~IncrementalMapper.sq_distance_px`,
exports).  Results are identical to an eager splat (a minimum does not depend on the
order); ``max_pending_points=0`` splats at every scan.  :meth:`~IncrementalMapper.save`
stores pending points as they are.

Tiles and blocks have power-of-two sides (``tile_px``, ``block_px``), so the per-pixel
loops find a pixel's tile and its place in it with shifts and masks.

Memory: 18 bytes per pixel of an allocated tile (hit / miss counters, squared distance,
ridge, Laplacian, skeleton, thinning history, graph ids, scratch), about 288 KiB per
128 x 128 tile.
"""

from __future__ import annotations

import functools
import io as _io
import json
import math
import numbers
import os
import threading
import time
import zipfile
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path

import jax
import jax.numpy as jnp
import networkx as nx
import numba
import numpy as np

from ._jit import cached_njit
from .config import DistanceConfig, GraphConfig, PipelineConfig, RidgeConfig, SkeletonConfig
from .distance import FAR_SQ, gaussian_from_sq_distance
from .filters import HALO_PX, laplacian_valid, ridge_from_laplacian
from .scans import Scan
from .skeleton import compact
from .tiling import MAX_GRID_CELLS, TileManager, unique_pairs

__all__ = [
    "STATE_FORMAT",
    "STATE_VERSION",
    "GraphUpdate",
    "IncrementalMapper",
    "ScanReport",
    "replay",
    "thin_components",
    "timing_summary",
    "trace_counts",
    "vertex_error_metrics",
]

#: ``format`` field of saved mapper states.
STATE_FORMAT = "topojax.IncrementalMapper"
#: Version of the saved-state layout; :meth:`IncrementalMapper.load` accepts only this one.
STATE_VERSION = 2

STRATEGIES = ("exact", "paper")

#: Points per row of the splat kernel (a row is one block and up to this many points).
SPLAT_POINTS = 8
#: Rows per splat kernel call: a small and a large fixed batch (two compilations serve a
#: whole replay; they are compiled on the first flush).
SPLAT_ROWS = (128, 1024)
#: Splat batches with at least this many new points share the pairing with a worker
#: thread (on machines with more than one CPU).
PARALLEL_MIN_POINTS = 64
#: Beams whose free cells may wait for the next skeleton update (or an export); more
#: are counted at once.
RAY_BATCH_BEAMS = 1 << 16
#: Radius (Chebyshev, px) searched for obstacles that dominate a new point on a block
#: (at most 2: the pairing divides by twice a column offset with a shift).
DOMINANCE_PX = 2
#: Side (px, a power of two) of the blocks the exact re-thinning activates (at most
#: ``block_px``).
RETHIN_BLOCK_PX = 8
#: Largest window half-width (px) whose Gaussian the ridge kernel reads from a table
#: (2 R^2 + 2 float32 entries: 32 MiB at this bound) instead of computing it.
TABLE_MAX_HALF_PX = 2047
#: Blocks per ridge kernel call (small and large fixed batch).
RIDGE_BLOCKS = (64, 512)
#: The exact re-thinning activates the block of each changed ridge pixel, and the
#: neighbour block on each side where the pixel lies within this many pixels of the
#: border (at least 1: every 8-neighbour of a changed pixel must be active; a larger
#: margin costs pixels, a smaller one extra rounds of the leak check; 3 on intel, fhw and
#: acapulco: 10-15 % less re-thinning than whole 3 x 3 block neighbourhoods, one round).
SEED_MARGIN_PX = 3
#: Tile storage reserved when a mapper starts: address space, whose pages are mapped on
#: first use (64 GiB: about 230,000 tiles of 128 px).  A map within it never grows its
#: storage, so no scan waits for a copy of every tile (on freiburg-campus the growth at
#: 452 tiles, 133 MB, stalled one scan for 0.15-0.28 s).  Where the system refuses the
#: reservation (strict overcommit, ``ulimit -v``) the storage starts small and grows.
INITIAL_STORAGE_BYTES = 1 << 36

_FAR_BOUND = 1 << 62  # larger than any squared pixel distance in int64 arithmetic
_MAX_ABS_PIXEL = 1 << 30  # packed pixel keys shift rows by 32 bits
_UINT16_MAX = 65535
_U64 = numba.uint64  # unsigned flat offsets (see _gather_ridge_patches)

_TRACES: Counter[str] = Counter()


_POOLS: dict = {}  # thread name -> (process id, its executor in that process)


def _n_cpus() -> int:
    """CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _shared_thread(name: str):
    """A one-thread executor shared by all mappers of this process (None on a single-CPU
    machine).  Keyed by process id: a child forked after the thread started has the
    executor object but not its thread, so it makes its own."""
    pid = os.getpid()
    owner, pool = _POOLS.get(name, (None, None))
    if owner != pid:
        pool = ThreadPoolExecutor(1, thread_name_prefix=name) if _n_cpus() > 1 else None
        _POOLS[name] = (pid, pool)
    return pool


def _worker_pool():
    """The worker thread: splat pairing and free-cell counting."""
    return _shared_thread("topojax")


def _growth_pool():
    """A second thread that pages in the tile storage of the next growth
    (:meth:`TileManager.prepare_growth`) without holding up the worker's short jobs."""
    return _shared_thread("topojax-grow")


def trace_counts() -> dict[str, int]:
    """How many times each jitted kernel of this module has been traced (compiled)."""
    return dict(_TRACES)


# ======================================================================================
# JAX kernels
# ======================================================================================


def splat_block(points: jax.Array, *, size: int, half_width: int) -> jax.Array:
    """Squared distance from each pixel of one block to the nearest of up to ``P`` points.

    Pure function of one (block, point bucket) pair; batched with :func:`jax.vmap`.  The
    caller merges the result into the map with a minimum (a max-splat of Gaussians).

    Parameters
    ----------
    points : int32 array, shape (P, 2)
        Obstacle pixels ``(row, col)`` relative to the block's first pixel.  Padding
        points are placed more than ``half_width`` away (they change nothing).
    size : int
        Block side ``B`` (static).
    half_width : int
        Window half-width ``R`` (static): a point reaches pixels with ``|dr| <= R`` and
        ``|dc| <= R``.

    Returns
    -------
    int32 array, shape (B, B): ``min_p dr^2 + dc^2`` over the points whose window contains
    the pixel, :data:`~topojax.distance.FAR_SQ` where there is none.
    """
    idx = jnp.arange(size, dtype=jnp.int32)
    dr = idx[None, :] - points[:, 0:1]  # (P, B)
    dc = idx[None, :] - points[:, 1:2]
    big = jnp.int32(FAR_SQ // 2)  # > any in-window dr^2 + dc^2; big + big fits in int32
    a = jnp.where(jnp.abs(dr) <= half_width, dr * dr, big)
    c = jnp.where(jnp.abs(dc) <= half_width, dc * dc, big)
    # one (B, B) minimum per point: XLA fuses the chain into a single vectorised loop,
    # where a reduction over a point axis vectorises poorly (1.5x slower on a CPU)
    best = a[0][:, None] + c[0][None, :]
    for p in range(1, points.shape[0]):
        best = jnp.minimum(best, a[p][:, None] + c[p][None, :])
    # A sum involving ``big`` means the pixel is outside that point's window.
    return jnp.where(best >= big, jnp.int32(FAR_SQ), best)


@partial(jax.jit, static_argnames=("size", "half_width"))
def _splat_blocks(points, *, size, half_width):
    _TRACES["splat_blocks"] += 1
    return jax.vmap(partial(splat_block, size=size, half_width=half_width))(points)


def ridge_block(
    d2_patch: jax.Array,
    sigma_px: jax.Array,
    scale: jax.Array,
    threshold: jax.Array,
    *,
    ksize: int,
) -> tuple[jax.Array, jax.Array]:
    """Ridges of one block from its haloed squared distances.

    The same maths as :func:`topojax.pipeline.forward_tile` after its distance stage
    (:func:`~topojax.distance.gaussian_from_sq_distance`,
    :func:`~topojax.filters.laplacian_valid`, :func:`~topojax.filters.ridge_from_laplacian`).
    The halo must already hold the ``BORDER_REFLECT_101`` image of the map where it leaves
    the map (the gather does it: reflecting indices commutes with the elementwise Gaussian,
    so this equals :func:`~topojax.filters.reflect_101_halo` on ``H``).

    Parameters
    ----------
    d2_patch : int32 array, shape (B + 4, B + 4)
        Squared distances (px^2) of the block and a 2-pixel halo.
    sigma_px : float32 scalar or float32 array (n,)
        Gaussian standard deviation in pixels, or a table of ``H`` by squared distance
        (:func:`gaussian_table`): squared distances are integers, so a lookup gives the
        exponential's values (bit for bit) at a third less cost.
    scale, threshold : float32 scalars
    ksize : int
        Laplacian aperture (static).

    Returns
    -------
    lap_abs : uint8 (B, B)
    ridge : bool (B, B)
    """
    if sigma_px.ndim == 0:
        h = gaussian_from_sq_distance(d2_patch, sigma_px)
    else:
        h = sigma_px[jnp.minimum(d2_patch, sigma_px.shape[0] - 1)]
    lap = laplacian_valid(h, ksize=ksize)
    return ridge_from_laplacian(lap, scale=scale, threshold=threshold)


def gaussian_table(sigma_px: float, half_width: int) -> jax.Array:
    """``H`` for every squared distance a window of half-width ``R`` allows.

    Returns
    -------
    float32 array, shape (2 R^2 + 2,)
        ``table[d2]`` = :func:`~topojax.distance.gaussian_from_sq_distance` ``(d2)`` for
        ``d2 <= 2 R^2``; the last entry is 0 (:data:`~topojax.distance.FAR_SQ` is looked up
        there).
    """
    d2 = np.arange(2 * half_width * half_width + 2, dtype=np.int32)
    d2[-1] = FAR_SQ
    return _gaussian(d2, jnp.float32(sigma_px))


@partial(jax.jit, static_argnames=("ksize", "with_ridge"))
def _ridge_blocks(patches, sigma_px, scale, threshold, *, ksize, with_ridge=True):
    """:func:`ridge_block` over a batch; ``with_ridge=False`` returns ``lap_abs`` alone.

    The ridge map is ``lap_abs > threshold`` whenever ``threshold < 255`` (the caller's
    test), and XLA computes the fused filter once per output: one output halves the
    kernel (0.3 instead of 0.6 us per 16 x 16 block).
    """
    _TRACES["ridge_blocks"] += 1
    fn = partial(ridge_block, ksize=ksize)
    out = jax.vmap(fn, in_axes=(0, None, None, None))(patches, sigma_px, scale, threshold)
    return out if with_ridge else out[0]


@jax.jit
def _gaussian(d2, sigma_px):
    _TRACES["gaussian"] += 1
    return gaussian_from_sq_distance(d2, sigma_px)


# ======================================================================================
# numba kernels (tiles are found through the dense slot grid of the TileManager)
# ======================================================================================


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


@cached_njit(nogil=True, inline="always")
def _isqrt(n):
    """Largest integer ``e`` with ``e * e <= n`` (``n >= 0``), exact for any int64."""
    e = int(math.sqrt(float(n)))
    while e * e > n:
        e -= 1
    while (e + 1) * (e + 1) <= n:
        e += 1
    return e


@cached_njit(nogil=True)
def _splat_pairs(pr, pc, first, step, grid, g0r, g0c, t, b, half, bmax, rowmax, hits, rho):
    """The (block, point) pairs that can lower a block, for points ``first, first + step,
    ...`` (so that threads can share a batch).

    A pair is skipped when it provably changes nothing (exact; a third rule, among the
    batch's own points, is applied by :func:`_splat_group`):

    * ``dist^2(p, block) >= max_block d2``: every pixel already has a nearer obstacle;
    * the block lies in the square ``|x - p|_inf <= R - rho`` and another obstacle ``q``
      with ``|q - p|_inf <= rho`` (old, or new in this batch) is at least as near as ``p`` to
      all four block corners, hence (half-plane) to every block pixel, and ``q`` lies in
      every block pixel's window.  Following such dominations from ``p`` never cycles
      (two distinct points cannot be equally near all four corners) and ends at a point
      that is old, or splatted into the block, or skipped by the first or third rule
      (both of which only skip points that cannot lower any pixel), so the block's
      minimum is unaffected.  For one row of blocks each neighbour ``q`` dominates a
      half-line of block columns, so the allowed blocks form an interval.

    ``bmax`` (slot, block row, block col) holds the blocks' bounds (:func:`_batch_bound`)
    and ``rowmax`` (slot, block row) their maxima along block rows.

    Returns ``pair_k`` (flat block id ``(slot * nb + block_row) * nb + block_col``),
    ``pair_i`` (point index) and the number of pairs (the arrays are longer).
    """
    bsh = _log2(b)
    tsh = _log2(t)
    nb = t >> bsh
    nsh = _log2(nb)
    n = pr.shape[0]
    n_own = max(0, (n - first + step - 1) // step)
    if rho > 2:  # the domination thresholds below divide by 2 |dc| with shifts
        raise ValueError("rho must be at most 2")
    inner = half - rho
    side = 2 * rho + 1
    # neighbours by the sign of their column offset: (dd at lo = 0, 2 qa, log2(2 |qc|))
    nbr = np.empty((3, side * side, 3), np.int64)
    n_q = np.zeros(3, np.int64)
    cap = 1024 + 64 * n_own
    pair_k = np.empty(cap, np.int64)
    pair_i = np.empty(cap, np.int64)
    n_pairs = 0
    gh = grid.shape[0]
    gw = grid.shape[1]
    # every block of a point's window, at most: room for one more point's pairs is made
    # before the point (growing the arrays inside the per-block loop would make numba
    # count references at every step)
    per_point = ((2 * half) // b + 2) ** 2
    for i in range(first, n, step):
        if n_pairs + per_point > cap:
            cap = max(2 * cap, n_pairs + per_point)
            nk = np.empty(cap, np.int64)
            ni = np.empty(cap, np.int64)
            nk[:n_pairs] = pair_k[:n_pairs]
            ni[:n_pairs] = pair_i[:n_pairs]
            pair_k = nk
            pair_i = ni
        p_r = pr[i]
        p_c = pc[i]
        # Obstacles q near p (offset (a, c)), grouped by the sign of c (0: c > 0, 1: c < 0,
        # 2: c = 0) so that the per-row loops below have no data-dependent branches.  For
        # a block row [lo, hi] relative to p, q is at least as near as p to the row's
        # corners where dd = a^2 + c^2 - 2 a (lo if a > 0 else hi) <= 2 c dc_corner; with
        # hi = lo + b - 1 that is dd = d0 - 2 a lo, d0 stored per neighbour.
        n_q[0] = 0
        n_q[1] = 0
        n_q[2] = 0
        for a in range(-rho, rho + 1):
            for c in range(-rho, rho + 1):
                if a == 0 and c == 0:
                    continue
                qr = p_r + a
                qc = p_c + c
                s, lr, lc = _locate(grid, g0r, g0c, tsh, qr, qc)
                if s >= 0 and hits[s, lr, lc] > 0:
                    g = 0 if c > 0 else (1 if c < 0 else 2)
                    j = n_q[g]
                    nbr[g, j, 0] = a * a + c * c - (2 * (b - 1) * a if a < 0 else 0)
                    nbr[g, j, 1] = 2 * a
                    nbr[g, j, 2] = 1 if abs(c) == 1 else 2  # log2(2 |c|), |c| <= rho <= 2
                    n_q[g] = j + 1
        any_q = n_q[0] + n_q[1] + n_q[2] > 0
        br0 = (p_r - half) >> bsh
        br1 = (p_r + half) >> bsh
        bc0 = (p_c - half) >> bsh
        bc1 = (p_c + half) >> bsh
        # block columns lying inside the inner square |x - p|_inf <= R - rho
        ib0 = -((inner - p_c) >> bsh)  # ceil((p_c - inner) / b)
        ib1 = (p_c + inner - b + 1) >> bsh
        for gbr in range(br0, br1 + 1):
            lo = gbr * b - p_r  # block rows relative to p
            hi = lo + b - 1
            if lo > 0:
                dr = lo
            elif hi < 0:
                dr = -hi
            else:
                dr = 0
            tr = gbr >> nsh
            gi = tr - g0r
            if gi < 0 or gi >= gh:
                continue
            lbr = gbr - tr * nb
            # Disk bound: no block of this row can gain if dc^2 >= max bmax - dr^2.
            rmax = 0
            for tcc in range(bc0 >> nsh, (bc1 >> nsh) + 1):
                gj = tcc - g0c
                if 0 <= gj < gw:
                    ss = grid[gi, gj]
                    if ss >= 0 and rowmax[ss, lbr] > rmax:
                        rmax = rowmax[ss, lbr]
            rem = rmax - dr * dr
            if rem <= 0:
                continue
            e = _isqrt(rem - 1)
            cb0 = max(bc0, -((e + b - 1 - p_c) >> bsh))
            cb1 = min(bc1, (p_c + e) >> bsh)
            # Allowed interval [al, ar] of inner block columns.
            al = ib0
            ar = ib1
            if any_q and lo >= -inner and hi <= inner:
                for j in range(n_q[0]):  # c > 0: dominated iff lo_c >= ceil(dd / (2 c))
                    dd = nbr[0, j, 0] - nbr[0, j, 1] * lo
                    thr = -((-dd) >> nbr[0, j, 2]) + p_c  # 2 c is 2 or 4: a shift
                    ar = min(ar, -((-thr) >> bsh) - 1)
                for j in range(n_q[1]):  # c < 0: iff hi_c <= floor(dd / (2 c))
                    dd = nbr[1, j, 0] - nbr[1, j, 1] * lo
                    thr = ((-dd) >> nbr[1, j, 2]) + p_c - b + 1
                    al = max(al, (thr >> bsh) + 1)
                for j in range(n_q[2]):  # c = 0: iff dd <= 0, the whole row
                    if nbr[2, j, 0] - nbr[2, j, 1] * lo <= 0:
                        al = ib1 + 1
                        ar = ib1
            else:
                al = ib1 + 1  # no inner part in this row: every column is tested
                ar = ib1
                ib0 = ib1 + 1
            for part in range(3):
                if part == 0:
                    c_from = cb0
                    c_to = min(cb1, ib0 - 1)
                elif part == 1:
                    c_from = max(al, ib0, cb0)
                    c_to = min(ar, ib1, cb1)
                else:
                    c_from = max(ib1 + 1, cb0, ib0)
                    c_to = cb1
                if c_from > c_to:
                    continue
                for tcc in range(c_from >> nsh, (c_to >> nsh) + 1):
                    gj = tcc - g0c
                    if gj < 0 or gj >= gw:
                        continue
                    s = grid[gi, gj]
                    if s < 0:
                        continue
                    # this tile's own disk bound (the row's bound used the largest maximum)
                    remt = rowmax[s, lbr] - dr * dr
                    if remt <= 0:
                        continue
                    et = e if remt == rem else _isqrt(remt - 1)
                    t_from = max(c_from, -((et + b - 1 - p_c) >> bsh))
                    t_to = min(c_to, (p_c + et) >> bsh)
                    l0 = max(t_from - tcc * nb, 0)
                    l1 = min(t_to - tcc * nb, nb - 1)
                    for lbc in range(l0, l1 + 1):
                        lo_c = (tcc * nb + lbc) * b - p_c
                        if lo_c > 0:
                            dc = lo_c
                        elif lo_c + b - 1 < 0:
                            dc = -(lo_c + b - 1)
                        else:
                            dc = 0
                        if dr * dr + dc * dc >= bmax[s, lbr, lbc]:
                            continue
                        pair_k[n_pairs] = (s * nb + lbr) * nb + lbc
                        pair_i[n_pairs] = i
                        n_pairs += 1
            ib0 = -((inner - p_c) >> bsh)
    return pair_k, pair_i, n_pairs


@cached_njit(nogil=True)
def _row_max(bm):
    """Maxima of ``bm`` (slot, block row, block col) along block rows: (slot, block row)."""
    out = np.empty(bm.shape[:2], bm.dtype)
    for s in range(bm.shape[0]):
        for r in range(bm.shape[1]):
            out[s, r] = bm[s, r].max()
    return out


@cached_njit(nogil=True)
def _batch_bound(pr, pc, grid, g0r, g0c, t, b, half, bmax, n_tiles):
    """Block maxima lowered by what the batch's own points guarantee.

    A new point ``q`` whose window covers a whole block brings every pixel of it to at
    most ``U(q)``, the squared distance from ``q`` to the block's farthest corner.  So
    after the batch a block's largest squared distance is at most ``min(bmax, min_q
    U(q))``, and :func:`_splat_pairs` may use that as its first rule's bound: a point at
    least that far from the block cannot lower a pixel below what the others give.
    (Exact: the point that sets the bound is nearer than that to the block, so it is
    paired, unless the old map or a dominating point already does as well.)  Computed on
    the block grid around the batch, with each block's points anywhere in it
    (``U <= (b |d_row| + b - 1)^2 + (b |d_col| + b - 1)^2`` for a block ``d`` blocks
    away), as two separable passes over at most ``K = (R - b + 1) // b`` blocks.

    Returns a copy of ``bmax[:n_tiles]`` with the bound applied, and its maxima along
    block rows (``(n_tiles, nb)``, the pairing's row bound).
    """
    bsh = _log2(b)
    nb = t >> bsh
    nsh = _log2(nb)
    out = bmax[:n_tiles].copy()
    n = pr.shape[0]
    k_max = (half - b + 1) >> bsh
    if n == 0 or k_max < 0:
        return out, _row_max(out)
    r0 = pr[0] >> bsh
    r1 = r0
    c0 = pc[0] >> bsh
    c1 = c0
    for i in range(n):
        r0 = min(r0, pr[i] >> bsh)
        r1 = max(r1, pr[i] >> bsh)
        c0 = min(c0, pc[i] >> bsh)
        c1 = max(c1, pc[i] >> bsh)
    r0 -= k_max
    c0 -= k_max
    h = r1 + k_max - r0 + 1
    w = c1 + k_max - c0 + 1
    occ = np.zeros((h, w), np.bool_)
    for i in range(n):
        occ[(pr[i] >> bsh) - r0, (pc[i] >> bsh) - c0] = True
    cost = np.empty(k_max + 1, np.int64)
    for d in range(k_max + 1):
        cost[d] = (b * d + b - 1) * (b * d + b - 1)
    far = _FAR_BOUND
    # column pass: nearest occupied block row within K (two running scans)
    col = np.full((h, w), far, np.int64)
    for j in range(w):
        last = -(1 << 30)
        for i in range(h):
            if occ[i, j]:
                last = i
            if i - last <= k_max:
                col[i, j] = cost[i - last]
        nxt = 1 << 30
        for i in range(h - 1, -1, -1):
            if occ[i, j]:
                nxt = i
            if nxt - i <= k_max and cost[nxt - i] < col[i, j]:
                col[i, j] = cost[nxt - i]
    # row pass and write-back into the allocated tiles' blocks
    gh = grid.shape[0]
    gw = grid.shape[1]
    for i in range(h):
        gbr = r0 + i
        gi = (gbr >> nsh) - g0r
        if gi < 0 or gi >= gh:
            continue
        for j in range(w):
            # outwards from j; every column value is at least cost[0], so the scan stops
            # once the offset's cost alone cannot improve u
            u = far
            for x in range(k_max + 1):
                cx = cost[x]
                if cx + cost[0] >= u:
                    break
                if j - x >= 0 and col[i, j - x] + cx < u:
                    u = col[i, j - x] + cx
                if j + x < w and col[i, j + x] + cx < u:
                    u = col[i, j + x] + cx
            if u >= far:
                continue
            gbc = c0 + j
            gj = (gbc >> nsh) - g0c
            if gj < 0 or gj >= gw:
                continue
            s = grid[gi, gj]
            if s < 0:
                continue
            lbr = gbr & (nb - 1)
            lbc = gbc & (nb - 1)
            if u < out[s, lbr, lbc]:
                out[s, lbr, lbc] = u
    return out, _row_max(out)


@cached_njit(nogil=True, inline="always")
def _block_origin(keys, k, t, b):
    """Global first pixel (row, col) of the block with flat id ``k``
    (``(slot * nb + block_row) * nb + block_col``, ``nb = t / b``)."""
    s, lbr, lbc = _unflat(k, _log2(t >> _log2(b)))
    return keys[s, 0] * t + lbr * b, keys[s, 1] * t + lbc * b


@cached_njit(nogil=True)
def _splat_group(pair_k, pair_i, pr, pc, keys, n_ids, t, b, half, n_points_row, slack):
    """Group the pairs of :func:`_splat_pairs` into kernel rows by block.

    Returns ``row_block`` (flat block id per row), ``row_pts`` (m, P, 2) int32 relative
    to the block's first pixel, ``row_bidx`` (index of the row's block in ``blocks``) and
    ``blocks`` (distinct flat block ids).  ``row_pts`` has at least ``slack`` rows more than
    there are rows, all padding (points far away), like the unused slots of a row.
    """
    n_pairs = pair_k.shape[0]
    # counting sort of the pairs by block id
    counts = np.zeros(n_ids + 1, np.int64)
    for j in range(n_pairs):
        counts[pair_k[j] + 1] += 1
    n_blocks = 0
    for k in range(n_ids):
        if counts[k + 1]:
            n_blocks += 1
        counts[k + 1] += counts[k]
    members = np.empty(n_pairs, np.int64)
    for j in range(n_pairs):
        k = pair_k[j]
        members[counts[k]] = pair_i[j]
        counts[k] += 1
    # counts[k] is now the end of block k's members (and the start of block k + 1's).
    # Third rule, among the batch's own points: the member q whose window covers the block
    # with the smallest squared distance U to its farthest block corner is kept (its
    # nearest pixel is nearer than that corner), so every pixel ends at most U; a member
    # whose squared distance to the block is >= U cannot lower any pixel.  Rows get the
    # survivors; every block keeps at least one, so the rows fit in this bound:
    cap = n_blocks + n_pairs // n_points_row + 1
    row_block = np.empty(cap, np.int64)
    row_bidx = np.empty(cap, np.int64)
    row_pts = np.full((cap + slack, n_points_row, 2), -(half + 2 * b + 1), np.int32)
    blocks = np.empty(n_blocks, np.int64)
    row = 0
    j = 0
    start = 0
    for k in range(n_ids):
        stop = counts[k]
        if stop == start:
            continue
        org_r, org_c = _block_origin(keys, k, t, b)
        u = _FAR_BOUND
        for m in range(start, stop):
            i = members[m]
            far_r = max(abs(pr[i] - org_r), abs(pr[i] - org_r - b + 1))
            far_c = max(abs(pc[i] - org_c), abs(pc[i] - org_c - b + 1))
            if far_r <= half and far_c <= half:
                u = min(u, far_r * far_r + far_c * far_c)
        blocks[j] = k
        q = 0
        for m in range(start, stop):
            i = members[m]
            dr = max(org_r - pr[i], 0, pr[i] - org_r - b + 1)
            dc = max(org_c - pc[i], 0, pc[i] - org_c - b + 1)
            if dr * dr + dc * dc >= u:
                continue
            row_pts[row, q, 0] = pr[i] - org_r
            row_pts[row, q, 1] = pc[i] - org_c
            row_block[row] = k
            row_bidx[row] = j
            q += 1
            if q == n_points_row:
                q = 0
                row += 1
        if q:
            row += 1
        j += 1
        start = stop
    return row_block[:row], row_pts, row_bidx[:row], blocks


@cached_njit(nogil=True)
def _merge_rows(d2, row_block, row_bidx, rows, n_rows, start, t, b, lo_a, hi_a, lo_c, hi_c):
    """``d2 = min(d2, rows)`` for kernel rows ``start .. start + n_rows`` (one batch, as
    the kernel returned it); widen each block's box of changed pixels (``lo_a`` .. ``hi_c``,
    indexed by the row's distinct block, empty as ``lo = b, hi = -1``)."""
    bsh = _log2(b)
    nb = t >> bsh
    nsh = _log2(nb)
    cols = np.empty(b, np.bool_)
    dst = _flat(d2)
    src = _flat(rows)
    for ii in range(n_rows):
        i = start + ii
        k = row_block[i]
        j = row_bidx[i]
        s, lbr, lbc = _unflat(k, nsh)
        p = _U64((s * t + lbr * b) * t + lbc * b)
        o = _U64(ii * b * b)
        # branch-free inner loop (vectorises): store the minimum, OR the "lowered" flags
        cols[:] = False
        for a in range(b):
            row_low = False
            for c in range(b):
                v = src[o + _U64(c)]
                w = dst[p + _U64(c)]
                low = v < w
                dst[p + _U64(c)] = min(v, w)
                cols[c] |= low
                row_low |= low
            if row_low:
                lo_a[j] = min(lo_a[j], a)
                hi_a[j] = max(hi_a[j], a)
            p += _U64(t)
            o += _U64(b)
        for c in range(b):
            if cols[c]:
                lo_c[j] = min(lo_c[j], c)
                hi_c[j] = max(hi_c[j], c)


@cached_njit(nogil=True)
def _finish_merge(d2, bmax, blocks, t, b, halo, lo_a, hi_a, lo_c, hi_c, nbr9, dirty, tile_dirty):
    """After :func:`_merge_rows`: update the maxima of the changed blocks and mark
    ridge-dirty (``dirty[slot, block_row, block_col]``, and ``tile_dirty[slot]``) every
    block whose ridges must be recomputed: a changed block itself, and each neighbouring
    block (in any tile) that lies within ``halo`` pixels of one of its changed pixels.
    Returns the number of changed blocks."""
    bsh = _log2(b)
    nb = t >> bsh
    nsh = _log2(nb)
    n_changed = 0
    flat = _flat(d2)
    for j in range(blocks.shape[0]):
        if hi_a[j] < 0:
            continue
        n_changed += 1
        s, lbr, lbc = _unflat(blocks[j], nsh)
        dy0 = -1 if lo_a[j] < halo else 0
        dy1 = 1 if hi_a[j] >= b - halo else 0
        dx0 = -1 if lo_c[j] < halo else 0
        dx1 = 1 if hi_c[j] >= b - halo else 0
        for dy in range(dy0, dy1 + 1):
            nbr_r, oy = _wrap_into_tile(lbr + dy, nb)
            for dx in range(dx0, dx1 + 1):
                nbr_c, ox = _wrap_into_tile(lbc + dx, nb)
                ns = nbr9[s, 3 * oy + ox]
                if ns >= 0:
                    dirty[ns, nbr_r, nbr_c] = True
                    tile_dirty[ns] = True
        mx = 0
        p = _U64((s * t + lbr * b) * t + lbc * b)
        for _ in range(b):
            for c in range(b):
                mx = max(mx, flat[p + _U64(c)])
            p += _U64(t)
        bmax[s, lbr, lbc] = mx
    return n_changed


@cached_njit(nogil=True, inline="always")
def _reflect_into_tile(g, first, last, tile0, t):
    """Reflect global index ``g`` into ``[first, last]`` (BORDER_REFLECT_101), then
    express it relative to the tile starting at ``tile0``: (local index, neighbour 0/1/2
    for the previous / same / next tile along this axis)."""
    if g < first:
        g = 2 * first - g
    elif g > last:
        g = 2 * last - g
    return _wrap_into_tile(g - tile0, t)


@cached_njit(nogil=True, inline="always")
def _wrap_into_tile(local, t):
    """A tile-local index that may lie one tile before or after, as (index in that tile,
    neighbour 0/1/2 for the previous / same / next tile along this axis)."""
    if local < 0:
        return local + t, 0
    if local >= t:
        return local - t, 2
    return local, 1


@cached_njit(nogil=True)
def _gather_ridge_patches(d2, nbr9, t, b, halo, slots, lbr, lbc, keys, bbox, out):
    """Haloed squared-distance patches of blocks, reflected at the bounding box.

    ``out[i]`` is the ``(b + 2 halo)^2`` patch around block ``(lbr[i], lbc[i])`` of tile
    ``slots[i]``; rows/cols outside ``bbox = (row0, col0, row1, col1)`` read the
    ``BORDER_REFLECT_101`` mirror pixel (``-1 -> 1``), missing tiles read ``FAR_SQ``.

    The copies index flat views with unsigned offsets: numba wraps negative signed
    indices, and that test in every element keeps LLVM from vectorising the copy (3x
    slower on intel's patches).
    """
    r_first = bbox[0]
    c_first = bbox[1]
    r_last = bbox[2] - 1
    c_last = bbox[3] - 1
    size = b + 2 * halo
    src = _flat(d2)
    dst = _flat(out)
    lcs = np.empty(size, np.uint64)
    oxs = np.empty(size, np.int64)
    base = np.empty(3, np.int64)
    # columns of the patch per neighbour tile 0/1/2 along the row: (first, stop, first
    # tile-local column)
    seg = np.empty((3, 3), np.int64)
    for i in range(slots.shape[0]):
        s = slots[i]
        tile_r0 = keys[s, 0] * t
        tile_c0 = keys[s, 1] * t
        org_r = tile_r0 + lbr[i] * b - halo
        org_c = tile_c0 + lbc[i] * b - halo
        lr0 = org_r - tile_r0
        lc0 = org_c - tile_c0
        o = _U64(i * size * size)
        cols_inside = org_c >= c_first and org_c + size - 1 <= c_last
        if (
            cols_inside
            and lr0 >= 0
            and lc0 >= 0
            and lr0 + size <= t
            and lc0 + size <= t
            and org_r >= r_first
            and org_r + size - 1 <= r_last
        ):
            # the patch lies inside its own tile and inside the box: a plain copy
            p = _U64((s * t + lr0) * t + lc0)
            for _ in range(size):
                for cc in range(size):
                    dst[o + _U64(cc)] = src[p + _U64(cc)]
                p += _U64(t)
                o += _U64(size)
            continue
        if cols_inside:
            # patch column cc is tile-local column lc0 + cc: in the previous tile below 0,
            # in the next one from t
            e0 = min(max(-lc0, 0), size)
            e1 = min(max(t - lc0, 0), size)
            seg[0, 0] = 0
            seg[0, 1] = e0
            seg[0, 2] = lc0 + t
            seg[1, 0] = e0
            seg[1, 1] = e1
            seg[1, 2] = lc0 + e0
            seg[2, 0] = e1
            seg[2, 1] = size
            seg[2, 2] = lc0 + e1 - t
        else:
            for cc in range(size):  # reflected: the same column mapping for every row
                lc, ox = _reflect_into_tile(org_c + cc, c_first, c_last, tile_c0, t)
                lcs[cc] = _U64(lc)
                oxs[cc] = ox
        for a in range(size):
            lr, oy = _reflect_into_tile(org_r + a, r_first, r_last, tile_r0, t)
            if cols_inside:
                for k in range(3):
                    n = seg[k, 1] - seg[k, 0]
                    if n <= 0:
                        continue
                    d = o + _U64(seg[k, 0])
                    ss = nbr9[s, 3 * oy + k]
                    if ss < 0:
                        for cc in range(n):
                            dst[d + _U64(cc)] = FAR_SQ
                    else:
                        p = _U64((ss * t + lr) * t + seg[k, 2])
                        for cc in range(n):
                            dst[d + _U64(cc)] = src[p + _U64(cc)]
            else:
                for k in range(3):
                    ss = nbr9[s, 3 * oy + k]
                    base[k] = -1 if ss < 0 else (ss * t + lr) * t
                for cc in range(size):
                    bs = base[oxs[cc]]
                    dst[o + _U64(cc)] = FAR_SQ if bs < 0 else src[_U64(bs) + lcs[cc]]
            o += _U64(size)


@cached_njit(nogil=True, inline="always")
def _ridge_at(rs, ls, i, cut):
    """Ridge value of element ``i`` of a kernel batch: read from the kernel's ridge output
    ``rs`` when ``cut < 0``, else ``lap_abs > cut``."""
    return rs[i] if cut < 0 else np.int64(ls[i]) > cut


@cached_njit(nogil=True)
def _write_ridges(ridge_l, lap_l, slots, lbr, lbc, keys, t, b, lap_abs, ridge, cut):
    """Store recomputed blocks; return the global pixels that became ridge pixels and
    those that stopped being ones, (n, 2) int64 each.

    The ridge is read from ``ridge`` when ``cut < 0``, else it is ``lap_abs > cut``
    (``ridge`` is then not read)."""
    n = slots.shape[0]
    # room for the worst case (np.empty does not touch the memory it does not use)
    added = np.empty((n * b * b, 2), np.int64)
    removed = np.empty((n * b * b, 2), np.int64)
    na = 0
    nr = 0
    rl = _flat(ridge_l)
    ll = _flat(lap_l)
    rs = _flat(ridge)
    ls = _flat(lap_abs)
    for i in range(n):
        s = slots[i]
        r0 = lbr[i] * b
        c0 = lbc[i] * b
        gr = keys[s, 0] * t + r0
        gc = keys[s, 1] * t + c0
        o = _U64(i * b * b)
        p = _U64((s * t + r0) * t + c0)
        for a in range(b):
            # branch-free copy and compare (vectorises); most rows do not change
            diff = False
            for c in range(b):
                diff |= rl[p + _U64(c)] != _ridge_at(rs, ls, o + _U64(c), cut)
                ll[p + _U64(c)] = ls[o + _U64(c)]
            if diff:
                for c in range(b):
                    v = _ridge_at(rs, ls, o + _U64(c), cut)
                    if rl[p + _U64(c)] != v:
                        rl[p + _U64(c)] = v
                        if v:
                            added[na, 0] = gr + a
                            added[na, 1] = gc + c
                            na += 1
                        else:
                            removed[nr, 0] = gr + a
                            removed[nr, 1] = gc + c
                            nr += 1
            o += _U64(b)
            p += _U64(t)
    return added[:na].copy(), removed[:nr].copy()


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


_SURVIVOR = 65535  # ``thin_time`` of a pixel that thinning keeps
# (d_row, d_col) of neighbour bit k of the thinning code (E, NE, N, NW, W, SW, S, SE)
_THIN_DR = np.array([0, -1, -1, -1, 0, 1, 1, 1], np.int64)
_THIN_DC = np.array([1, 1, 0, -1, -1, -1, 0, 1], np.int64)
# a pixel and its 4 neighbours (up, down, left, right)
_T_DR5 = np.array([0, -1, 1, 0, 0], np.int64)
_T_DC5 = np.array([0, 0, 0, -1, 1], np.int64)


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
def _rethin(ridge, tau, nbr9, t, b, bid, blk, n_blk, tables, dr8, dc8):
    """Exact local re-thinning around changed ridge pixels (see ``_skeleton_exact``).

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

    Returns the flat indices (``slot * t^2 + row * t + col``) of the pixels whose thinned
    state (``tau == _SURVIVOR``) changed, the number of rounds and the size of ``I`` in the
    last round.  ``tau`` is updated in place.
    """
    tsh = _log2(t)
    bsh = _log2(b)
    tt = t * t
    tflat = tau.reshape(-1)
    zo = np.empty(0, np.int64)  # survivors cleared from the history (no longer ridge)
    n_zo = 0
    rounds = 0
    while True:
        rounds += 1
        # One pass over the active blocks: list I (their ridge pixels) with a local index
        # per active block, and clear the history of pixels that are no longer ridge
        # (recording the survivors among them as changed).  Nothing reads the history of
        # a non-ridge pixel inside the active blocks, so clearing it now is safe.
        if zo.shape[0] < n_zo + n_blk * b * b:  # room for every pixel of the blocks
            grown = np.empty(n_zo + n_blk * b * b, np.int64)
            grown[:n_zo] = zo[:n_zo]
            zo = grown
        lidx = np.empty((n_blk, b, b), np.int32)  # index in I, -1 off the ridge
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
        # Neighbour table, every neighbour as an index into the state array ``alive``:
        # 0..n-1 the pixels of I; n: always off (no ridge, or no tile); n + 1: always on
        # (a ring survivor); n + 2 + m: a ring pixel deleted at old time ``ring_tau[m]``
        # (one slot per reference, switched off at that sub-iteration).  The thinning
        # loop then reads eight states without a branch.
        nbt = np.empty((n, 8), np.int64)
        ring_tau = np.empty(8 * n, np.int64)
        n_ring = 0
        ring_max = 0
        # the 3 x 3 blocks around each active block: its row of blk (-1: not active) and
        # the flat index of its first pixel (-1: tile not allocated); a neighbour pixel is
        # then found with shifts and masks, in the order in which I was listed
        nact = np.empty((n_blk, 9), np.int64)
        nbase = np.empty((n_blk, 9), np.int64)
        n_side = t >> bsh  # blocks per tile side
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
        i = 0
        bm = b - 1
        for j in range(n_blk):
            for a in range(b):
                for c in range(b):
                    if lidx[j, a, c] < 0:
                        continue
                    for k in range(8):
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
        # thin I, sub-iteration by sub-iteration, the ring following its old history
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
        # check the ring; activate the blocks of ring pixels whose inputs changed
        grown = False
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
                            grown = True
        if not grown:
            break
    # write back; collect the pixels whose thinned state changed
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
    for j in range(n_blk):
        bid[blk[j, 0], blk[j, 1], blk[j, 2]] = -1
    return out[:m], rounds, n


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
def _heap_push(heap, n, key):
    """Push ``key`` on the binary min-heap ``heap[:n]`` (room for it is the caller's
    business); returns the new size."""
    i = n
    heap[i] = key
    while i > 0:
        p = (i - 1) >> 1
        if heap[p] <= heap[i]:
            break
        heap[p], heap[i] = heap[i], heap[p]
        i = p
    return n + 1


@cached_njit(nogil=True, inline="always")
def _heap_pop(heap, n):
    """Pop the smallest key of the binary min-heap ``heap[:n]``; returns it and the new size."""
    top = heap[0]
    n -= 1
    heap[0] = heap[n]
    i = 0
    while True:
        a = 2 * i + 1
        if a >= n:
            break
        if a + 1 < n and heap[a + 1] < heap[a]:
            a += 1
        if heap[i] <= heap[a]:
            break
        heap[a], heap[i] = heap[i], heap[a]
        i = a
    return top, n


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
    # every step: 2.5-3.5x slower).
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
            o, n_heap = _heap_pop(heap, n_heap)
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
                        n_heap = _heap_push(heap, n_heap, oq)
    state[0] = j
    state[1] = n_heap
    state[2] = last
    state[3] = n_ch
    return full


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
    from .skeleton import skeletonize_ridges

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


# ======================================================================================
# Reports
# ======================================================================================


@dataclass(frozen=True)
class GraphUpdate:
    """What one graph update changed.

    Vertex ids and edge keys are stable: a vertex keeps its id as long as a vertex exists at
    its pixel; an edge keeps its key as long as its path is unchanged (edges are never
    modified in place: a changed path is a removal plus an addition).

    Attributes
    ----------
    added_vertices, removed_vertices : tuple of int
        Vertex ids.
    changed_vertices : tuple of int
        Vertices that stay but whose kind or set of incident edges changed.
    added_edges, removed_edges : tuple of int
        Edge keys (unique over the whole graph).
    region_px : int
        Pixels in the patched region ``Z`` (changed skeleton pixels dilated by 1).
    time_s : float
        Wall time of the update in seconds.
    """

    added_vertices: tuple[int, ...] = ()
    removed_vertices: tuple[int, ...] = ()
    changed_vertices: tuple[int, ...] = ()
    added_edges: tuple[int, ...] = ()
    removed_edges: tuple[int, ...] = ()
    region_px: int = 0
    time_s: float = 0.0

    @property
    def empty(self) -> bool:
        """True when nothing changed."""
        return not (
            self.added_vertices
            or self.removed_vertices
            or self.changed_vertices
            or self.added_edges
            or self.removed_edges
        )


@dataclass(frozen=True)
class ScanReport:
    """What :meth:`IncrementalMapper.add_scan` (or :meth:`~IncrementalMapper.add_points`)
    did with one scan (or one frame of points).

    Attributes
    ----------
    index : int
        0-based number of the scan in this mapper (empty scans count).
    n_beams : int
        Beams in the scan (points in the frame).
    n_valid : int
        Beams used (hits): finite, ``range_min <= r < range_max`` (and ``< max_range_m``);
        points used: finite (and nearer than ``max_range_m`` to their origin).
    n_dropped : int
        ``n_beams - n_valid``: NaN, inf, non-positive, below ``range_min``, max-range.
    n_new_obstacles : int
        Obstacle pixels hit for the first time.
    loops : tuple of str
        Loops that ran: ``"distance"`` always; ``"splat"`` when this scan filled the
        pending-point buffer (``max_pending_points``) and the distance loop splatted it
        (otherwise pending points are splatted at the start of the skeleton loop, inside
        its time); ``"skeleton"``; ``"graph"``.
    timings_s : dict of str to float
        Wall time per loop in seconds (``"distance"`` includes ``"splat"``).
    n_tiles : int
        Tiles allocated after this scan.
    graph_update : GraphUpdate or None
        Result of the graph loop if it ran.
    """

    index: int
    n_beams: int
    n_valid: int
    n_dropped: int
    n_new_obstacles: int
    loops: tuple[str, ...]
    timings_s: dict[str, float]
    n_tiles: int
    graph_update: GraphUpdate | None = None


# ======================================================================================
# Helpers
# ======================================================================================


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
    the array in place as a kernel input instead of copying it (30-45 us less per 512
    ridge patches here), so it must not be written to while a kernel dispatched on it may
    still run."""
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


def _check_rate(name: str, value) -> int:
    if value is None:
        return 0
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int >= 0 or None, got {type(value).__name__}")
    if value < 0:
        raise ValueError(f"{name} must be >= 0 (0 or None: explicit calls only), got {value}")
    return int(value)


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


# ======================================================================================
# The mapper
# ======================================================================================


def _synchronized(method):
    """Run ``method`` holding the mapper's lock: one scan, update, export or save at a
    time, whichever threads call them (e.g. a scan callback and a timer that publishes
    the graph)."""

    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)

    return locked


class IncrementalMapper:
    """Keep distance map, skeleton and topology graph up to date from laser scans (or
    obstacle points, :meth:`add_points`).

    Parameters
    ----------
    resolution_m : float
        Pixel size in metres (default 0.05, the paper's).
    skeleton_every : int or None
        Run the skeleton loop once this many scans have come since the last skeleton
        update (default 20); the graph loop and explicit calls update the skeleton too
        and restart the count.  0 or None: only when :meth:`update_skeleton` (or
        :meth:`update_graph`) is called.
    graph_every : int or None
        Run the graph loop once this many scans have come since the last graph update
        (default 80); 0 or None: only when :meth:`update_graph` is called.
    strategy : {"exact", "paper"}
        Skeleton update: ``"exact"`` re-thins the changed ridge components and equals the
        full-map pipeline; ``"paper"`` thins the new ridges inside the changed blocks plus a
        ``paper_layer_px`` wide layer of the old skeleton around them and writes back inside
        the changed blocks only (paper §III-B).
    config : PipelineConfig, optional
        Distance, ridge and skeleton settings (default: the paper's).  Its ``tile_px`` and
        ``tiles_per_call`` are the full-map pipeline's and are not used here.
        ``config.graph.merge_junction_clusters`` must be False, and the ridge threshold
        at least 0 (a negative one makes every pixel of the unbounded map a ridge pixel).
    distance, ridge, skeleton : configs, optional
        Override the corresponding part of ``config``.
    tile_px : int
        Side of the storage tiles in pixels (default 128): a power of two, at least
        ``block_px``.
    block_px : int
        Side of the blocks the splat and ridge kernels work on (default 16): a power of two,
        at least 4.
    max_pending_points : int
        Splat pending new obstacle pixels once this many are waiting (default 4096; 0 splats
        at every scan).  Reads of the distance map always splat first.
    free_space : bool
        Count free cells along each beam (default True); they only feed the occupancy
        output (``free`` / ``unknown``), not the graph.
    max_range_m : float, optional
        Also drop readings at or beyond this range (in addition to the scan's
        ``range_max``).
    paper_layer_px : int
        Width of the old-skeleton layer of the ``"paper"`` strategy (default 2).
    max_grid_cells : int
        Bound on the bounding box of the map in tiles (see
        :class:`~topojax.tiling.TileManager`); a scan that would exceed it is rejected
        with ValueError before anything changes.

    Notes
    -----
    Obstacles are monotone: a pixel hit once stays an obstacle (like the paper's max-merge
    of distance maps).  The exported occupancy map marks hit pixels occupied, pixels crossed
    by a beam but never hit free, and the rest unknown.

    A mapper may be shared between threads (a scan callback, a timer that publishes the
    graph or saves the state): scans, updates, exports and :meth:`save` hold its lock, so
    they run one at a time and each sees a whole scan.  Arrays and graphs it returns are
    copies or new objects, except :attr:`tiles`.
    """

    def __init__(
        self,
        *,
        resolution_m: float = 0.05,
        skeleton_every: int | None = 20,
        graph_every: int | None = 80,
        strategy: str = "exact",
        config: PipelineConfig | None = None,
        distance: DistanceConfig | None = None,
        ridge: RidgeConfig | None = None,
        skeleton: SkeletonConfig | None = None,
        tile_px: int = 128,
        block_px: int = 16,
        max_pending_points: int = 4096,
        free_space: bool = True,
        max_range_m: float | None = None,
        paper_layer_px: int = 2,
        max_grid_cells: int = MAX_GRID_CELLS,
    ) -> None:
        # numbers.Real / Integral: NumPy numbers are numbers too (stored as Python ones)
        if isinstance(resolution_m, bool) or not isinstance(resolution_m, numbers.Real):
            raise TypeError(f"resolution_m must be a number, got {type(resolution_m).__name__}")
        resolution_m = float(resolution_m)
        if not math.isfinite(resolution_m) or resolution_m <= 0:
            raise ValueError(f"resolution_m must be finite and > 0 (metres), got {resolution_m}")
        if strategy not in STRATEGIES:
            raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
        config = config if config is not None else PipelineConfig()
        if not isinstance(config, PipelineConfig):
            raise TypeError(f"config must be a PipelineConfig, got {type(config).__name__}")
        for name, value, cls in (
            ("distance", distance, DistanceConfig),
            ("ridge", ridge, RidgeConfig),
            ("skeleton", skeleton, SkeletonConfig),
        ):
            if value is not None and not isinstance(value, cls):
                raise TypeError(f"{name} must be a {cls.__name__}, got {type(value).__name__}")
        config = PipelineConfig(
            distance=distance or config.distance,
            ridge=ridge or config.ridge,
            skeleton=skeleton or config.skeleton,
            graph=config.graph,
            tile_px=config.tile_px,
            tiles_per_call=config.tiles_per_call,
        )
        if config.ridge.threshold < 0:
            # then every pixel is a ridge pixel, also far from any obstacle where no tile
            # (and no ridge update) exists
            raise ValueError(
                "ridge.threshold must be >= 0 for incremental mapping (a negative threshold "
                f"makes every pixel of the unbounded map a ridge pixel), got "
                f"{config.ridge.threshold}"
            )
        if config.graph.merge_junction_clusters:
            raise ValueError(
                "config.graph.merge_junction_clusters=True is not supported incrementally; "
                "expected False (merge clusters on the exported graph instead)"
            )
        if config.graph.free_space_only or config.graph.prunes:
            raise ValueError(
                "config.graph: free_space_only, min_clearance_m, min_spur_m and "
                "min_component_m are not supported incrementally; expected their defaults "
                f"(False, 0, 0, 0), got {config.graph.free_space_only}, "
                f"{config.graph.min_clearance_m}, {config.graph.min_spur_m}, "
                f"{config.graph.min_component_m} (prune the exported graph with "
                "topojax.prune_graph instead)"
            )
        for name, value, lo in (
            ("tile_px", tile_px, 8),
            ("block_px", block_px, 4),
            ("paper_layer_px", paper_layer_px, 1),
        ):
            if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < lo:
                raise ValueError(f"{name} must be an int >= {lo}, got {value!r}")
        tile_px, block_px, paper_layer_px = int(tile_px), int(block_px), int(paper_layer_px)
        for name, value in (("tile_px", tile_px), ("block_px", block_px)):
            if value & (value - 1):
                raise ValueError(
                    f"{name} must be a power of two (tile and block coordinates are bit "
                    f"shifts), got {value}"
                )
        if tile_px < block_px:
            raise ValueError(f"tile_px ({tile_px}) must be >= block_px ({block_px})")
        if block_px < 2 * HALO_PX:
            raise ValueError(f"block_px must be >= {2 * HALO_PX}, got {block_px}")
        if (
            isinstance(max_pending_points, bool)
            or not isinstance(max_pending_points, numbers.Integral)
            or max_pending_points < 0
        ):
            raise ValueError(f"max_pending_points must be an int >= 0, got {max_pending_points!r}")
        max_pending_points = int(max_pending_points)
        if max_range_m is not None:
            if isinstance(max_range_m, bool) or not isinstance(max_range_m, numbers.Real):
                raise TypeError(f"max_range_m must be a number or None, got {max_range_m!r}")
            max_range_m = float(max_range_m)
            if not max_range_m > 0:
                raise ValueError(f"max_range_m must be > 0 (metres), got {max_range_m}")
        if not isinstance(free_space, bool):
            raise TypeError(f"free_space must be a bool, got {type(free_space).__name__}")
        self.resolution_m = float(resolution_m)
        self.skeleton_every = _check_rate("skeleton_every", skeleton_every)
        self.graph_every = _check_rate("graph_every", graph_every)
        self.strategy = strategy
        self.config = config
        self.tile_px = tile_px
        self.block_px = block_px
        self.max_pending_points = max_pending_points
        self.free_space = free_space
        self.max_range_m = None if max_range_m is None else float(max_range_m)
        self.paper_layer_px = paper_layer_px
        self._half = config.distance.half_width_px
        nb = tile_px // block_px
        self._tiles = TileManager(
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
        self._n_scans = 0
        self._n_ridge = 0
        self._compiled = False
        self._pending: list[np.ndarray] = []
        # beams whose free cells are not counted yet: (sensor row, col, end rows, cols)
        self._rays: list[tuple[int, int, np.ndarray, np.ndarray]] = []
        self._n_rays = 0
        self._lock = threading.RLock()
        self._ray_job = None
        self._n_pending = 0
        self._skel_changed: list[np.ndarray] = []
        self._ridge_bbox: tuple[int, int, int, int] | None = None
        self._since_skeleton = 0
        self._since_graph = 0
        # The graph, by stable id (ids are never reused): vertex pixel key (_pack), kind
        # code and liveness; edge ends (u <= v) and liveness; each live edge's pixel path
        # (from u to v) as rows [start, start + len) of one int32 (n, 2) pool (removed
        # paths leave holes until the pool is compacted).  The graph_id tile layer maps
        # pixels back to ids.
        self._v_key = np.zeros(0, np.int64)
        self._v_code = np.zeros(0, np.int8)
        self._v_alive = np.zeros(0, bool)
        self._e_uv = np.zeros((0, 2), np.int64)
        self._e_alive = np.zeros(0, bool)
        self._e_start = np.zeros(0, np.int64)
        self._e_len = np.zeros(0, np.int64)
        self._pool = np.zeros((0, 2), np.int32)
        self._pool_used = 0  # rows written (live paths and holes)
        self._next_vertex = 0
        self._next_edge = 0
        self._export_cache: dict[str, object] = {}
        self._scalars = (
            jnp.float32(config.distance.sigma_px),
            jnp.float32(config.ridge.scale),
            jnp.float32(config.ridge.threshold),
        )
        # the ridge kernel's Gaussian: a table (built by compile) up to TABLE_MAX_HALF_PX
        self._ridge_args = self._scalars
        # below 255 the ridge is lap_abs > floor(threshold) (integers, threshold >= 0) and
        # the ridge kernel returns lap_abs alone; else it returns the ridge too (cut -1)
        thr = config.ridge.threshold
        self._ridge_cut = math.floor(thr) if thr < 255 else -1

    # ------------------------------------------------------------------ properties
    @property
    @_synchronized
    def n_scans(self) -> int:
        """Scans added so far (empty ones included)."""
        return self._n_scans

    @property
    @_synchronized
    def n_tiles(self) -> int:
        """Allocated tiles."""
        return self._tiles.n_tiles

    @property
    def tiles(self) -> TileManager:
        """The tile storage (read-only use: do not modify layers); its free-cell counts
        (``misses``) are brought up to date first."""
        self._cast_pending_rays()
        return self._tiles

    @property
    @_synchronized
    def pixel_bbox(self) -> tuple[int, int, int, int] | None:
        """``(row0, col0, row1, col1)`` of the exported arrays (end exclusive), global
        pixels, or None before anything was allocated."""
        return self._tiles.pixel_bbox

    def world_to_pixel(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Global lattice pixel ``(row, col)`` (int64) containing world points ``(x, y)``."""
        res = self.resolution_m
        rows = np.floor(-np.asarray(y, np.float64) / res).astype(np.int64)
        cols = np.floor(np.asarray(x, np.float64) / res).astype(np.int64)
        return rows, cols

    # ------------------------------------------------------------------ scans
    @_synchronized
    def add_scan(self, scan: Scan) -> ScanReport:
        """Integrate one scan (distance loop), then run the loops that are due.

        Parameters
        ----------
        scan : Scan
            Ranges, beam geometry and the robot pose in the map frame.  Invalid readings
            (NaN, inf, non-positive, below ``range_min``, at or beyond ``range_max`` or
            ``max_range_m``) are dropped and counted in the report.  A scan without valid
            readings changes nothing but the scan counter (and may trigger due loops).

        Returns
        -------
        ScanReport

        Raises
        ------
        TypeError
            If ``scan`` is not a :class:`~topojax.scans.Scan`.
        ValueError
            If the scan's pixels are absurdly far (beyond 2^30 pixels) or the map would
            exceed ``max_grid_cells``.  Nothing is changed in that case.
        """
        if not isinstance(scan, Scan):
            raise TypeError(
                f"scan must be a topojax.Scan (see Scan.from_arrays), got {type(scan).__name__}"
            )
        t0 = time.perf_counter()
        sx, sy, syaw = scan.sensor_pose_world()
        rmax = scan.range_max if self.max_range_m is None else min(scan.range_max, self.max_range_m)
        res = self.resolution_m
        er, ec, ext = _scan_geometry(
            scan.ranges,
            scan.angle_min,
            scan.angle_increment,
            scan.range_min,
            rmax,
            sx,
            sy,
            syaw,
            res,
        )
        sensor = (math.floor(-sy / res), math.floor(sx / res))
        return self._add_end_pixels(
            er,
            ec,
            ext,
            sensor,
            n_beams=scan.n_beams,
            t0=t0,
            where=lambda: f"scan: the pose {scan.pose}",
        )

    @_synchronized
    def add_points(self, points_xy, *, origin_xy=None) -> ScanReport:
        """Integrate obstacle points in the map frame, e.g. one frame of a depth camera or a
        3-D lidar projected to the floor plane, then run the loops that are due.

        The points count as one scan: they go where a scan's beam ends go, and the
        skeleton and graph loops run at the same rates (``skeleton_every``,
        ``graph_every`` calls).

        Parameters
        ----------
        points_xy : array_like, shape (N, 2)
            World ``(x, y)`` in metres, map frame.  Rows that are not finite (NaN, inf)
            are dropped and counted in the report.  The pixel of a point is the one whose
            square holds it (:meth:`world_to_pixel`).
        origin_xy : (x, y), optional
            Position of the sensor in the map frame, metres.  With it, the ray from the
            origin to each point is free space for the exported occupancy map (as a scan's
            beams are, when ``free_space``), and points at ``max_range_m`` or farther from
            it are dropped (within a few rounding steps of it counts as at it: a scan's
            end points at its no-return range are dropped as the scan drops them).
            Without it the points mark obstacles only.

        Returns
        -------
        ScanReport
            ``n_beams`` is ``N``; ``n_valid`` the points used.

        Raises
        ------
        ValueError
            If ``points_xy`` is not (N, 2) numbers, ``origin_xy`` not two finite numbers,
            or the points lie absurdly far (beyond 2^30 pixels) or would make the map
            exceed ``max_grid_cells``.  Nothing is changed in that case.
        """
        t0 = time.perf_counter()
        if getattr(points_xy, "dtype", None) == np.bool_:  # a mask, not coordinates
            raise ValueError(
                "points_xy: expected an (N, 2) array of (x, y) in metres, received a bool "
                f"array of shape {np.shape(points_xy)} (for a finished map use add_map)"
            )
        try:
            pts = np.asarray(points_xy, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(
                "points_xy: expected an (N, 2) array of (x, y) in metres, received "
                f"{type(points_xy).__name__}"
            ) from None
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise ValueError(
                f"points_xy: expected an (N, 2) array of (x, y) in metres, received shape "
                f"{pts.shape}"
            )
        keep = np.isfinite(pts).all(axis=1)
        sensor = None
        if origin_xy is not None:
            try:
                origin = np.asarray(origin_xy, dtype=np.float64)
            except (TypeError, ValueError):
                origin = np.empty(0)
            if origin.shape != (2,) or not np.isfinite(origin).all():
                raise ValueError(
                    f"origin_xy: expected two finite numbers (x, y) in metres, received "
                    f"{origin_xy!r}"
                )
            if self.max_range_m is not None:
                # A scan's reading at exactly max_range_m is dropped; its end point, made
                # from the range and rounded, lies a rounding step either side of it.
                # Within a few steps (relative to the coordinates' size) a point counts
                # as at the limit, so a scan's end points are dropped as the scan is.
                slack = 16 * np.finfo(np.float64).eps
                scale = np.abs(pts).sum(axis=1) + np.abs(origin).sum() + self.max_range_m
                with np.errstate(invalid="ignore"):
                    keep &= np.hypot(*(pts - origin).T) < self.max_range_m - slack * scale
            res = self.resolution_m
            sensor = (math.floor(-origin[1] / res), math.floor(origin[0] / res))
        used = pts[keep]
        if used.shape[0] and np.abs(used).max() / self.resolution_m > _MAX_ABS_PIXEL:
            raise ValueError(
                f"points_xy: the points put pixels beyond {_MAX_ABS_PIXEL} px from the origin "
                f"at resolution {self.resolution_m} m (largest coordinate "
                f"{np.abs(used).max():g}); expected coordinates in metres"
            )
        er, ec = self.world_to_pixel(used[:, 0], used[:, 1])
        if er.shape[0]:
            ext = np.array([er.min(), er.max(), ec.min(), ec.max()], np.int64)
        else:
            ext = np.zeros(4, np.int64)
        return self._add_end_pixels(
            er, ec, ext, sensor, n_beams=pts.shape[0], t0=t0, where=lambda: "points_xy: the points"
        )

    @_synchronized
    def add_map(self, occupancy) -> int:
        """Add a finished occupancy map, e.g. one from another SLAM system to keep mapping
        on: its occupied pixels become obstacles (as if hit by a beam) and its free pixels
        free space for the exported occupancy map; unknown pixels add nothing.

        The map must have the mapper's resolution and no yaw; its pixels then fall one to
        one on the mapper's pixels (each goes to the one that holds its centre,
        :meth:`world_to_pixel`), so a map whose origin is not on the mapper's lattice
        (a multiple of the resolution) moves as a whole by under half a pixel.  It does not count as a scan and runs no loop: call
        :meth:`update_graph` (or keep adding scans) to bring skeleton and graph up to date.

        Parameters
        ----------
        occupancy : OccupancyMap
            In the map frame of the scans that follow.

        Returns
        -------
        int
            Obstacle pixels that are new to the mapper.

        Raises
        ------
        TypeError
            If ``occupancy`` is not an :class:`~topojax.OccupancyMap`.
        ValueError
            If its resolution differs from the mapper's, its yaw is not 0, or it would
            make the map exceed ``max_grid_cells``.  Nothing is changed in that case.
        """
        from .maps import OccupancyMap

        if not isinstance(occupancy, OccupancyMap):
            raise TypeError(
                f"occupancy: expected an OccupancyMap (see load_map), received "
                f"{type(occupancy).__name__}"
            )
        if not math.isclose(occupancy.resolution_m, self.resolution_m, rel_tol=1e-9):
            raise ValueError(
                f"occupancy: expected the mapper's resolution {self.resolution_m} m, "
                f"received a map of {occupancy.resolution_m} m per pixel; resample it first"
            )
        if occupancy.origin[2] != 0.0:
            raise ValueError(
                f"occupancy: expected a map without yaw (origin yaw 0), received yaw "
                f"{occupancy.origin[2]} rad"
            )
        # the map's pixel (0, 0) and the shift that takes its pixels onto the mapper's
        x0, y0 = occupancy.pixel_to_world(0, 0)
        r0, c0 = (int(v) for v in self.world_to_pixel(x0, y0))
        h, w = occupancy.shape
        t = self.tile_px
        half = self._half + HALO_PX
        rows, cols = np.nonzero(occupancy.occupied)
        free_rows, free_cols = np.nonzero(occupancy.free) if self.free_space else ((), ())
        if rows.shape[0] or len(free_rows):
            lo_r, hi_r, lo_c, hi_c = r0 - half, r0 + h + half, c0 - half, c0 + w + half
            if max(abs(lo_r), abs(hi_r), abs(lo_c), abs(hi_c)) > _MAX_ABS_PIXEL:
                raise ValueError(
                    f"occupancy: its origin {occupancy.origin} puts pixels beyond "
                    f"{_MAX_ABS_PIXEL} px from the mapper's origin; expected metres"
                )
            # the whole map and its splat windows, before anything changes
            self._tiles.check_extent_box(lo_r // t, lo_c // t, hi_r // t + 1, hi_c // t + 1)
        er = rows.astype(np.int64) + r0
        ec = cols.astype(np.int64) + c0
        ext = (
            np.array([er.min(), er.max(), ec.min(), ec.max()], np.int64)
            if er.shape[0]
            else np.zeros(4, np.int64)
        )
        n_new = self._integrate_end_pixels(er, ec, ext, None, where=lambda: "occupancy: the map")
        if len(free_rows):
            fr = free_rows.astype(np.int64) + r0
            fc = free_cols.astype(np.int64) + c0
            tsh = _log2(t)
            tiles_needed = unique_pairs(fr >> tsh, fc >> tsh)
            tiles = self._tiles
            tiles.ensure(tiles_needed[:, 0], tiles_needed[:, 1])
            grid, (g0r, g0c) = tiles.slot_grid
            _count_cells(fr, fc, t, grid, g0r, g0c, tiles.layer("misses"))
            self._export_cache.clear()
        return n_new

    def _add_end_pixels(self, er, ec, ext, sensor, *, n_beams: int, t0: float, where):
        """The distance loop for one scan's end pixels ``(er, ec)`` (int64, extent
        ``ext`` = (min row, max row, min col, max col)), free space along the rays from the
        ``sensor`` pixel (row, col) when given, then the loops that are due."""
        n_valid = int(er.shape[0])
        tiles = self._tiles
        n_tiles = tiles.n_tiles
        n_new = self._integrate_end_pixels(er, ec, ext, sensor, where=where)
        if tiles.n_tiles != n_tiles and _growth_pool() is not None:
            # page in the storage of the next growth on another thread (see TileManager)
            tiles.prepare_growth(_growth_pool().submit)
        if self._n_rays >= RAY_BATCH_BEAMS:
            self._cast_pending_rays()
        loops = ["distance"]
        timings: dict[str, float] = {}
        if self._n_pending and self._n_pending >= self.max_pending_points:
            ts = time.perf_counter()
            self._flush_splat()
            timings["splat"] = time.perf_counter() - ts
            loops.append("splat")
        timings["distance"] = time.perf_counter() - t0
        self._n_scans += 1
        self._since_skeleton += 1
        self._since_graph += 1
        update = None
        if self.graph_every and self._since_graph >= self.graph_every:
            ts = time.perf_counter()
            self.update_skeleton()
            timings["skeleton"] = time.perf_counter() - ts
            ts = time.perf_counter()
            update = self._update_graph()
            timings["graph"] = time.perf_counter() - ts
            loops += ["skeleton", "graph"]
        elif self.skeleton_every and self._since_skeleton >= self.skeleton_every:
            ts = time.perf_counter()
            self.update_skeleton()
            timings["skeleton"] = time.perf_counter() - ts
            loops.append("skeleton")
        return ScanReport(
            index=self._n_scans - 1,
            n_beams=n_beams,
            n_valid=n_valid,
            n_dropped=n_beams - n_valid,
            n_new_obstacles=int(n_new),
            loops=tuple(loops),
            timings_s=timings,
            n_tiles=tiles.n_tiles,
            graph_update=update,
        )

    def _integrate_end_pixels(self, er, ec, ext, sensor, *, where) -> int:
        """Hits at the end pixels ``(er, ec)`` (int64, extent ``ext`` = (min row, max row,
        min col, max col)): their tiles and those of their splat windows allocated, new
        obstacles queued for the splat, and the rays from the ``sensor`` pixel (row, col)
        queued for the free-cell count when given.  Raises before any change if the
        extent is too large, its message starting with ``where()`` (a callable: the scan
        path formats nothing unless it fails).  Returns the number of new obstacle
        pixels."""
        if self._ray_job is not None:  # only after an interrupted update
            self._join_rays()
        if not er.shape[0]:
            return 0
        t = self.tile_px
        res = self.resolution_m
        n_valid = int(er.shape[0])
        tiles = self._tiles
        w = self._half + HALO_PX
        e_r0, e_r1, e_c0, e_c1 = ext.tolist()
        sr, sc = sensor if sensor is not None else (e_r0, e_c0)
        lo_r = min(e_r0, sr) - w
        hi_r = max(e_r1, sr) + w
        lo_c = min(e_c0, sc) - w
        hi_c = max(e_c1, sc) + w
        if max(abs(lo_r), abs(hi_r), abs(lo_c), abs(hi_c)) > _MAX_ABS_PIXEL:
            raise ValueError(
                f"{where()} put pixels beyond {_MAX_ABS_PIXEL} px from the origin at "
                f"resolution {res} m; expected coordinates in metres"
            )
        # Validate the whole extent (beams and splat windows) before changing anything.
        tiles.check_extent_box(lo_r // t, lo_c // t, hi_r // t + 1, hi_c // t + 1)
        rays = self.free_space and sensor is not None
        grid, (g0r, g0c) = tiles.slot_grid
        need = _missing_ray_tiles(sr, sc, er, ec, t, rays, grid, g0r, g0c)
        if need.shape[0]:
            tiles.ensure(need[:, 0], need[:, 1])
            grid, (g0r, g0c) = tiles.slot_grid
        new, miss = _integrate(er, ec, t, grid, g0r, g0c, tiles.layer("hits"), w)
        if rays:
            # free cells are counted later, in batches (see _cast_pending_rays)
            self._rays.append((sr, sc, er, ec))
            self._n_rays += n_valid
        n_new = new.shape[0]
        if n_new:
            if miss.shape[0]:
                tiles.ensure(miss[:, 0], miss[:, 1])
            self._pending.append(new)
            self._n_pending += n_new
            self._export_cache.clear()
        return int(n_new)

    @_synchronized
    def compile(self) -> None:
        """Compile every JAX kernel variant the mapper uses (two batch sizes each of the
        splat and ridge kernels) and build the ridge kernel's Gaussian table, so that no JAX
        compilation happens later.  Runs
        automatically before the first splat; calling it again does nothing.  The CPU
        kernels (numba) are compiled once per installation and loaded from numba's
        on-disk cache at their first use in a process (milliseconds each)."""
        if self._compiled:
            return
        b, half = self.block_px, self._half
        size = b + 2 * HALO_PX
        if half <= TABLE_MAX_HALF_PX:
            table = gaussian_table(self.config.distance.sigma_px, half)
            self._ridge_args = (table, *self._scalars[1:])
        for n in SPLAT_ROWS:
            pts = np.full((n, SPLAT_POINTS, 2), -(half + 2 * b + 1), np.int32)
            _splat_blocks(pts, size=b, half_width=half).block_until_ready()
        for n in RIDGE_BLOCKS:
            patches = np.full((n, size, size), FAR_SQ, np.int32)
            jax.block_until_ready(self._ridge_kernel(patches))
        self._compiled = True

    def _ridge_kernel(self, patches):
        """Dispatch the ridge kernel on a batch of patches (asynchronous): ``lap_abs``, or
        ``(lap_abs, ridge)`` when the threshold is 255 or more (see ``_ridge_cut``)."""
        return _ridge_blocks(
            patches,
            *self._ridge_args,
            ksize=self.config.ridge.ksize,
            with_ridge=self._ridge_cut < 0,
        )

    @_synchronized
    def add_scans(self, scans) -> list[ScanReport]:
        """:meth:`add_scan` for every scan of an iterable; returns the reports."""
        return [self.add_scan(s) for s in scans]

    # ------------------------------------------------------------------ distance loop
    def _flush_splat(self) -> int:
        """Splat all pending new obstacle pixels; returns the number of changed blocks."""
        if not self._pending:
            return 0
        self.compile()
        pts = np.concatenate(self._pending)
        self._pending = []
        self._n_pending = 0
        tiles = self._tiles
        t, b, half = self.tile_px, self.block_px, self._half
        nb = t // b
        grid, (g0r, g0c) = tiles.slot_grid
        bmax = tiles.layer("block_max")
        pr, pc = np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1])
        bound, rowmax = _batch_bound(pr, pc, grid, g0r, g0c, t, b, half, bmax, tiles.n_tiles)
        args = (
            grid,
            g0r,
            g0c,
            t,
            b,
            half,
            bound,
            rowmax,
            tiles.layer("hits"),
            min(DOMINANCE_PX, half - 1),
        )
        pool = _worker_pool() if pts.shape[0] >= PARALLEL_MIN_POINTS else None
        if pool is None:
            pair_k, pair_i, n_pairs = _splat_pairs(pr, pc, 0, 1, *args)
            pair_k, pair_i = pair_k[:n_pairs], pair_i[:n_pairs]
        else:
            # every other point on the worker thread (numba releases the GIL)
            other = pool.submit(_splat_pairs, pr, pc, 1, 2, *args)
            ka, ia, na = _splat_pairs(pr, pc, 0, 2, *args)
            kb, ib, nb_ = other.result()
            pair_k = np.concatenate((ka[:na], kb[:nb_]))
            pair_i = np.concatenate((ia[:na], ib[:nb_]))
        row_block, row_pts, row_bidx, blocks = _splat_group(
            pair_k,
            pair_i,
            pr,
            pc,
            tiles.keys,
            tiles.n_tiles * nb * nb,
            t,
            b,
            half,
            SPLAT_POINTS,
            _max_padding(SPLAT_ROWS),  # so that every batch below is a view
        )
        n_rows = row_block.shape[0]
        if n_rows == 0:
            return 0
        d2 = tiles.layer("sq_distance")
        n_blocks = blocks.shape[0]
        lo_a = np.full(n_blocks, b, np.int64)
        hi_a = np.full(n_blocks, -1, np.int64)
        lo_c = np.full(n_blocks, b, np.int64)
        hi_c = np.full(n_blocks, -1, np.int64)
        # Dispatch every batch first (JAX runs them asynchronously), then merge each one
        # as it arrives: the merge of one batch overlaps the kernel of the next.
        batches = [
            (
                start,
                stop,
                _splat_blocks(row_pts[start : start + size], size=b, half_width=half),
            )
            for start, stop, size in _batches(n_rows, SPLAT_ROWS)
        ]
        for start, stop, res in batches:
            _merge_rows(
                d2,
                row_block,
                row_bidx,
                np.asarray(res),
                stop - start,
                start,
                t,
                b,
                lo_a,
                hi_a,
                lo_c,
                hi_c,
            )
        return _finish_merge(
            d2,
            bmax,
            blocks,
            t,
            b,
            HALO_PX,
            lo_a,
            hi_a,
            lo_c,
            hi_c,
            tiles.neighbour_slots(),
            tiles.layer("ridge_dirty"),
            tiles.dirty_flags("ridge"),
        )

    def _mark_blocks(self, gbr, gbc) -> None:
        """Mark global blocks ridge-dirty (blocks of unallocated tiles are skipped)."""
        tiles = self._tiles
        nb = self.tile_px // self.block_px
        tr, lbr = np.divmod(gbr, nb)
        tc, lbc = np.divmod(gbc, nb)
        sl = tiles.lookup(tr, tc)
        ok = sl >= 0
        tiles.layer("ridge_dirty")[sl[ok], lbr[ok], lbc[ok]] = True
        tiles.mark_dirty("ridge", sl[ok])

    # ------------------------------------------------------------------ ridges
    def _update_ridges(self):
        """Recompute the ridges of the dirty blocks.

        Returns
        -------
        added, removed : int64 arrays (n, 2)
            Global pixels that became / stopped being ridge pixels.
        border : int64 array (m, 2)
            Pixels on the lines of the previous bounding box border that is now interior
            (their T-removal rule changed).
        blocks : int64 array (k, 2)
            Global (block row, block col) of the recomputed blocks.
        """
        tiles = self._tiles
        t, b = self.tile_px, self.block_px
        nb = t // b
        bbox = tiles.pixel_bbox
        empty = np.zeros((0, 2), np.int64)
        if bbox is None:
            return empty, empty, empty, empty
        border = empty
        old = self._ridge_bbox
        if old is not None and old != bbox:
            border = self._old_border(old, bbox)
        self._ridge_bbox = bbox
        slots = tiles.dirty("ridge")
        flags = tiles.layer("ridge_dirty")
        # contiguous copies: np.nonzero's arrays are strided views (except when they hold
        # one element), and numba compiles a new variant for each memory layout
        sl, lbr, lbc = (np.ascontiguousarray(a) for a in np.nonzero(flags[slots]))
        sl = slots[sl]
        tiles.clear_dirty("ridge")
        flags[sl, lbr, lbc] = False
        if sl.size == 0:
            return empty, empty, border, empty
        self.compile()
        keys = tiles.keys
        gbr = keys[sl, 0] * nb + lbr
        gbc = keys[sl, 1] * nb + lbc
        size = b + 2 * HALO_PX
        n = sl.size
        plan = list(_batches(n, RIDGE_BLOCKS))
        # room for the last batch's padding: every batch is dispatched as a view
        patches = _aligned_empty((plan[-1][0] + plan[-1][2], size, size), np.int32)
        patches[n:] = FAR_SQ
        _gather_ridge_patches(
            tiles.layer("sq_distance"),
            tiles.neighbour_slots(),
            t,
            b,
            HALO_PX,
            sl,
            lbr,
            lbc,
            keys,
            np.asarray(bbox, np.int64),
            patches,
        )
        # All batches are dispatched first (asynchronous), then written as they arrive.
        batches = [
            (
                start,
                stop,
                self._ridge_kernel(patches[start : start + bsize]),
            )
            for start, stop, bsize in plan
        ]
        added, removed = [], []
        cut = self._ridge_cut
        no_ridge = np.zeros((0, b, b), bool)
        for start, stop, res in batches:
            m = stop - start
            la, ri = (res, no_ridge) if cut >= 0 else (res[0], np.asarray(res[1])[:m])
            a, r = _write_ridges(
                tiles.layer("ridge"),
                tiles.layer("lap_abs"),
                sl[start:stop],
                lbr[start:stop],
                lbc[start:stop],
                keys,
                t,
                b,
                np.asarray(la)[:m],
                ri,
                cut,
            )
            added.append(a)
            removed.append(r)
        added = np.concatenate(added)
        removed = np.concatenate(removed)
        self._n_ridge += added.shape[0] - removed.shape[0]
        blocks = np.stack([gbr, gbc], axis=1)
        return added, removed, border, blocks

    def _old_border(self, old, new) -> np.ndarray:
        """Dirty the blocks along the sides of the old bounding box that moved and return
        the pixels on those old border lines."""
        r0, c0, r1, c1 = old
        b = self.block_px
        lines = []
        if new[0] < r0:
            lines.append((r0, r0 + 1, c0, c1))
        if new[2] > r1:
            lines.append((r1 - 1, r1, c0, c1))
        if new[1] < c0:
            lines.append((r0, r1, c0, c0 + 1))
        if new[3] > c1:
            lines.append((r0, r1, c1 - 1, c1))
        pix = []
        for a0, a1, b0, b1 in lines:
            rr, cc = np.mgrid[a0:a1, b0:b1]
            rr = rr.ravel().astype(np.int64)
            cc = cc.ravel().astype(np.int64)
            pix.append(np.stack([rr, cc], axis=1))
            # blocks within the 2-pixel halo of the old border line
            brs = np.unique(np.concatenate([(rr - HALO_PX) // b, rr // b, (rr + HALO_PX) // b]))
            bcs = np.unique(np.concatenate([(cc - HALO_PX) // b, cc // b, (cc + HALO_PX) // b]))
            gbr, gbc = np.meshgrid(brs, bcs, indexing="ij")
            self._mark_blocks(gbr.ravel(), gbc.ravel())
        return np.concatenate(pix) if pix else np.zeros((0, 2), np.int64)

    # ------------------------------------------------------------------ skeleton loop
    @_synchronized
    def update_skeleton(self) -> int:
        """Run the skeleton loop now: splat pending points, recompute the dirty ridges and
        update the skeleton with the mapper's strategy.

        Returns
        -------
        int
            Number of skeleton pixels that changed.
        """
        self._flush_splat()
        added, removed, border, blocks = self._update_ridges()
        # The free cells of the scans since the last update are counted on the worker
        # thread meanwhile (nothing below touches them or allocates tiles).  Not earlier:
        # next to the ridge kernel's XLA thread it slowed that kernel by a third.
        self._cast_pending_rays(background=True)
        try:
            self._since_skeleton = 0
            self._export_cache.clear()
            if self.strategy == "exact":
                return self._skeleton_exact(added, removed, border)
            return self._skeleton_paper(blocks)
        finally:
            self._join_rays()

    def _cast_pending_rays(self, *, background: bool = False) -> None:
        """Count the free cells of the beams added since the last call (on the worker
        thread if ``background``; :meth:`_join_rays` waits for it)."""
        self._join_rays()
        if not self._rays:
            return
        rays, self._rays, self._n_rays = self._rays, [], 0
        sr = np.array([r[0] for r in rays], np.int64)
        sc = np.array([r[1] for r in rays], np.int64)
        off = np.zeros(len(rays) + 1, np.int64)
        np.cumsum([r[2].shape[0] for r in rays], out=off[1:])
        er = np.concatenate([r[2] for r in rays])
        ec = np.concatenate([r[3] for r in rays])
        tiles = self._tiles
        grid, (g0r, g0c) = tiles.slot_grid
        args = (sr, sc, off, er, ec, self.tile_px, grid, g0r, g0c, tiles.layer("misses"))
        pool = _worker_pool() if background else None
        if pool is None:
            _cast_rays(*args)
        else:
            self._ray_job = pool.submit(_cast_rays, *args)

    def _join_rays(self) -> None:
        """Wait for the free-cell counting started by :meth:`_cast_pending_rays`."""
        job = self._ray_job
        if job is not None:
            try:
                job.result()
            finally:
                # an interrupt while waiting leaves the job running: keep waiting for it
                # next time (nothing may grow the tiles under it)
                if job.done():
                    self._ray_job = None

    def _write_skeleton(self, rows, cols, values) -> int:
        """Write skeleton values, record the changed pixels for the graph loop."""
        tiles = self._tiles
        grid, (g0r, g0c) = tiles.slot_grid
        old = np.empty(rows.shape[0], bool)
        layer = tiles.layer("skeleton")
        _gather_px(layer, grid, g0r, g0c, self.tile_px, rows, cols, False, old)
        ch = old != values
        if ch.any():
            r, c = rows[ch], cols[ch]
            _scatter_px(layer, grid, g0r, g0c, self.tile_px, r, c, values[ch])
            self._skel_changed.append(np.stack([r, c], axis=1))
        return int(ch.sum())

    def _thin(self, image: np.ndarray) -> np.ndarray:
        from .skeleton import skeletonize_ridges

        return skeletonize_ridges(
            image, method=self.config.skeleton.thinning, remove_t=self.config.skeleton.remove_t
        )

    def _skeleton_exact(self, added, removed, border) -> int:
        """Exact local update of the skeleton (see the module notes): re-thin around the
        changed ridge pixels (:func:`_rethin`), then redo T-centre removal where its inputs
        changed (:func:`_t_update`)."""
        if added.shape[0] == 0 and removed.shape[0] == 0 and border.shape[0] == 0:
            return 0
        from .skeleton import TABLES_U8

        tiles = self._tiles
        t = self.tile_px
        b = min(RETHIN_BLOCK_PX, self.block_px)
        nb = t // b
        keys = tiles.keys
        tau = tiles.layer("thin_time")
        grid, (g0r, g0c) = tiles.slot_grid
        seeds = [border]
        changed = np.concatenate([added, removed])
        if changed.shape[0]:
            bid = np.full((tiles.n_tiles, nb, nb), -1, np.int32)
            blk = np.empty((tiles.n_tiles * nb * nb, 3), np.int64)
            n_blk = _seed_blocks(
                changed[:, 0].astype(np.int64),
                changed[:, 1].astype(np.int64),
                grid,
                g0r,
                g0c,
                nb,
                b,
                bid,
                blk,
                SEED_MARGIN_PX,
            )
            flat, _rounds, _n = _rethin(
                tiles.layer("ridge").reshape(-1),
                tau,
                tiles.neighbour_slots(),
                t,
                b,
                bid,
                blk,
                n_blk,
                TABLES_U8[self.config.skeleton.thinning],
                _THIN_DR,
                _THIN_DC,
            )
            slot, rem = np.divmod(flat, t * t)
            lr, lc = np.divmod(rem, t)
            seeds.append(np.stack([keys[slot, 0] * t + lr, keys[slot, 1] * t + lc], axis=1))
        seeds = np.concatenate(seeds)
        if seeds.shape[0] == 0:
            return 0
        bbox = np.asarray(tiles.pixel_bbox, np.int64)
        skel = tiles.layer("skeleton")
        n_seed = seeds.shape[0]
        ch_r = np.empty(n_seed + 16, np.int64)
        ch_c = np.empty(n_seed + 16, np.int64)
        args = (skel, tau, grid, g0r, g0c)
        todo, n_ch = _t_seeds(
            *args,
            t,
            bbox,
            seeds[:, 0].astype(np.int64),
            seeds[:, 1].astype(np.int64),
            border.shape[0],
            self.config.skeleton.remove_t,
            ch_r,
            ch_c,
        )
        ch_r, ch_c, n_ch = _t_update(
            *args, tiles.neighbour_slots(), t, bbox, np.sort(todo), ch_r, ch_c, n_ch
        )
        ch_r, ch_c = ch_r[:n_ch], ch_c[:n_ch]
        if ch_r.shape[0]:
            self._skel_changed.append(np.stack([ch_r, ch_c], axis=1))
        return int(ch_r.shape[0])

    def _skeleton_paper(self, blocks) -> int:
        """Paper §III-B: thin the new ridges of the changed blocks together with a layer of
        the old skeleton around them; write back inside the changed blocks only."""
        if blocks.shape[0] == 0:
            return 0
        from scipy import ndimage

        tiles = self._tiles
        b, lay = self.block_px, self.paper_layer_px
        bbox = tiles.pixel_bbox
        br0, bc0 = blocks.min(axis=0)
        br1, bc1 = blocks.max(axis=0) + 1
        grid_blocks = np.zeros((br1 - br0, bc1 - bc0), bool)
        grid_blocks[blocks[:, 0] - br0, blocks[:, 1] - bc0] = True
        mask_full = np.repeat(np.repeat(grid_blocks, b, axis=0), b, axis=1)
        mr0, mc0 = int(br0) * b, int(bc0) * b
        r0 = max(mr0 - lay, bbox[0])
        c0 = max(mc0 - lay, bbox[1])
        r1 = min(int(br1) * b + lay, bbox[2])
        c1 = min(int(bc1) * b + lay, bbox[3])
        mask = np.zeros((r1 - r0, c1 - c0), bool)
        sub = mask_full[r0 - mr0 : r1 - mr0, c0 - mc0 : c1 - mc0]
        oy, ox = max(0, mr0 - r0), max(0, mc0 - c0)
        sub = mask_full[max(0, r0 - mr0) : r1 - mr0, max(0, c0 - mc0) : c1 - mc0]
        mask[oy : oy + sub.shape[0], ox : ox + sub.shape[1]] = sub
        layer = ndimage.binary_dilation(mask, np.ones((2 * lay + 1, 2 * lay + 1), bool)) & ~mask
        h, w = mask.shape
        ridge = tiles.read("ridge", r0, c0, h, w)
        old = tiles.read("skeleton", r0, c0, h, w)
        sk = self._thin((ridge & mask) | (old & layer))
        rr, cc = np.nonzero(mask)
        return self._write_skeleton(rr + r0, cc + c0, sk[rr, cc])

    # ------------------------------------------------------------------ graph loop
    @_synchronized
    def update_graph(self) -> GraphUpdate:
        """Bring everything up to date: splat, skeleton loop, then the graph loop.

        Returns
        -------
        GraphUpdate
            What the graph loop changed (``time_s`` covers the graph loop only).
        """
        self.update_skeleton()
        return self._update_graph()

    def _update_graph(self) -> GraphUpdate:
        from .graph import paused_gc

        with paused_gc():
            return self._patch_graph()

    def _patch_graph(self) -> GraphUpdate:
        from .graph import orient, raw_graph

        t0 = time.perf_counter()
        self._since_graph = 0
        self._export_cache.clear()
        if not self._skel_changed:
            return GraphUpdate(time_s=time.perf_counter() - t0)
        tiles = self._tiles
        t = self.tile_px
        changed = np.concatenate(self._skel_changed).astype(np.int64, copy=False)
        self._skel_changed = []
        grid, (g0r, g0c) = tiles.slot_grid
        gl = tiles.layer("graph_id")
        mark = tiles.layer("mark")
        skel = tiles.layer("skeleton")
        nbr9 = tiles.neighbour_slots()
        # Z: the changed pixels dilated by one (where pixel-graph links can change); it
        # stays flagged in ``mark`` until _near_skeleton has read and cleared it
        where = (grid, g0r, g0c, nbr9, t, mark)  # tile lookup and the scratch marks
        zr, zc, gid, skz = _region_z(
            np.ascontiguousarray(changed[:, 0]),
            np.ascontiguousarray(changed[:, 1]),
            *where,
            gl,
            skel,
        )
        try:
            nv, ne = self._next_vertex, self._next_edge
            e_alive = self._e_alive[:ne]
            e_u, e_v = self._e_uv[:ne, 0], self._e_uv[:ne, 1]
            # R: edges with a pixel in Z or ending at a vertex in Z
            in_vz = np.zeros(nv, bool)
            in_vz[-(gid[gid <= -2].astype(np.int64) + 2)] = True
            rem_flag = e_alive & (in_vz[e_u] | in_vz[e_v])
            rem_flag[gid[gid >= 0]] = True
            rem = np.flatnonzero(rem_flag)
            touched = np.flatnonzero(in_vz | _flags(nv, e_u[rem]) | _flags(nv, e_v[rem]))
            all_r, lens_r = self._paths(rem)
            all_r = all_r.astype(np.int64)
            off_r = np.concatenate([[0], np.cumsum(lens_r)])
            # A: pixels of the edges of R and new skeleton pixels in Z.  Every new edge that
            # touches Z lies in A, so the local graph is traced on the skeleton pixels within
            # one pixel of A (their links to A are the same as in the whole map).  Pixels are
            # gathered sparsely: changes spread over a large map cost by their number, not by
            # their bounding box.
            a_px = np.concatenate([all_r, np.stack([zr[skz], zc[skz]], axis=1)])
            t_r, t_c = _unpack(self._v_key[touched])
            ar, ac = np.ascontiguousarray(a_px[:, 0]), np.ascontiguousarray(a_px[:, 1])
            keys, in_a, in_z, t_in_z = _near_skeleton(ar, ac, zr, zc, t_r, t_c, *where, skel)
        except BaseException:
            _clear_region(zr, zc, grid, g0r, g0c, t, mark)
            raise
        order = np.argsort(keys)
        keys, in_a, in_z = keys[order], in_a[order], in_z[order]
        if keys.size:
            v_idx, v_kind, _, _, e_off, path = raw_graph(keys, 1 << 32)
        else:
            v_idx, v_kind = np.zeros(0, np.int64), np.zeros(0, np.int8)
            e_off, path = np.zeros(1, np.int64), np.zeros(0, np.int64)
        # N: the local edges lying in A with a pixel in Z (the new edges around Z)
        kept = np.zeros(0, np.int64)
        is_end = np.zeros(keys.shape[0], bool)
        if e_off.shape[0] > 1:
            all_a = np.minimum.reduceat(in_a[path], e_off[:-1])
            any_z = np.maximum.reduceat(in_z[path], e_off[:-1])
            kept = np.flatnonzero(all_a & any_z)
            is_end[path[e_off[kept]]] = True
            is_end[path[e_off[kept + 1] - 1]] = True
        # vertices of the patch: local vertices in Z and the ends of N (sorted keys)
        sel = in_z[v_idx] | is_end[v_idx]
        nk_keys = keys[v_idx[sel]]
        nk_code = v_kind[sel].astype(np.int8)
        lens_k = e_off[kept + 1] - e_off[kept]
        off_k = np.concatenate([[0], np.cumsum(lens_k)])
        take = np.repeat(e_off[kept] - off_k[:-1], lens_k) + np.arange(int(off_k[-1]))
        kk = keys[path[take]]
        kp = np.stack(_unpack(kk), axis=1)
        # ---- edges of R whose path comes back unchanged keep their key (and are not
        # touched); match by orientation-free signature, then verify
        matched_old = np.zeros(rem.shape[0], bool)
        matched_new = np.zeros(kept.shape[0], bool)
        if rem.size and kept.size:
            by_sig: dict[tuple, list[int]] = {}
            for j, sig in enumerate(_signatures(all_r, off_r)):
                by_sig.setdefault(sig, []).append(j)
            kp32 = kp.astype(np.int32)
            for i, sig in enumerate(_signatures(kp, off_k)):
                cands = by_sig.get(sig)
                if not cands:
                    continue
                new = kp32[off_k[i] : off_k[i + 1]]
                for j in cands:
                    old = all_r[off_r[j] : off_r[j + 1]]
                    if not matched_old[j] and (
                        np.array_equal(old, new) or np.array_equal(old, new[::-1])
                    ):
                        matched_old[j] = matched_new[i] = True
                        break
        gone_e = rem[~matched_old]
        # ---- remove the edges that changed
        if gone_e.size:
            keep_px = np.repeat(~matched_old, lens_r)
            inner = _interior(off_r) & keep_px
            owner = np.repeat(rem.astype(np.int32), lens_r)
            _clear_owned(gl, grid, g0r, g0c, t, all_r[inner, 0], all_r[inner, 1], owner[inner])
            self._e_alive[gone_e] = False
            self._drop_paths(gone_e)
        # ---- vertices: a touched vertex whose pixel is no vertex of the patch goes (outside
        # Z a vertex keeps its degree; only a ring vertex can stop being one)
        t_keys = self._v_key[touched]
        stays = np.isin(t_keys, nk_keys, assume_unique=True)
        ring = self._v_code[touched] == _KIND_CODE["ring"]
        removed_v = touched[~stays & (t_in_z | ring)]
        if removed_v.size:
            vr, vc = _unpack(self._v_key[removed_v])
            _clear_owned(gl, grid, g0r, g0c, t, vr, vc, -(removed_v.astype(np.int32) + 2))
            self._v_alive[removed_v] = False
        # existing vertices keep their id (their pixel holds it), the others are new
        nr, nc = _unpack(nk_keys)
        at = np.empty(nk_keys.shape[0], np.int32)
        _gather_px(gl, grid, g0r, g0c, t, nr, nc, -1, at)
        old_v = at <= -2
        ids = np.where(old_v, -(at.astype(np.int64) + 2), 0)
        n_new = int((~old_v).sum())
        added_v = np.arange(nv, nv + n_new, dtype=np.int64)
        ids[~old_v] = added_v
        self._reserve(vertices=nv + n_new)
        self._next_vertex = nv + n_new
        self._v_key[added_v] = nk_keys[~old_v]
        self._v_alive[added_v] = True
        kind_changed = ids[old_v][self._v_code[ids[old_v]] != nk_code[old_v]]
        self._v_code[ids] = nk_code
        _scatter_px(gl, grid, g0r, g0c, t, nr, nc, -(ids.astype(np.int32) + 2))
        # ---- add the new edges, oriented from the smaller vertex id
        new_i = np.flatnonzero(~matched_new)
        added_e = np.arange(ne, ne + new_i.shape[0], dtype=np.int64)
        if new_i.size:
            ln = lens_k[new_i]
            off_n = np.concatenate([[0], np.cumsum(ln)])
            take = np.repeat(off_k[new_i] - off_n[:-1], ln) + np.arange(int(off_n[-1]))
            nkk = kk[take]
            a_ids = ids[np.searchsorted(nk_keys, nkk[off_n[:-1]])]
            b_ids = ids[np.searchsorted(nk_keys, nkk[off_n[1:] - 1])]
            a_ids, b_ids, npx = orient(a_ids, b_ids, off_n, ln, kp[take])
            npx32 = npx.astype(np.int32)
            self._reserve(edges=ne + new_i.shape[0])
            self._next_edge = ne + new_i.shape[0]
            self._e_uv[added_e, 0] = a_ids
            self._e_uv[added_e, 1] = b_ids
            self._e_alive[added_e] = True
            self._add_paths(added_e, npx32, ln)
            inner = _interior(off_n)
            owner = np.repeat(added_e.astype(np.int32), ln)
            _scatter_px(gl, grid, g0r, g0c, t, npx[inner, 0], npx[inner, 1], owner[inner])
        # a vertex changed when its kind or its set of edges did
        changed_v = np.concatenate(
            [kind_changed, self._e_uv[gone_e].ravel(), self._e_uv[added_e].ravel()]
        )
        changed_v = np.unique(changed_v)
        changed_v = changed_v[self._v_alive[changed_v] & (changed_v < nv)]
        return GraphUpdate(
            added_vertices=tuple(added_v.tolist()),
            removed_vertices=tuple(removed_v.tolist()),
            changed_vertices=tuple(changed_v.tolist()),
            added_edges=tuple(added_e.tolist()),
            removed_edges=tuple(gone_e.tolist()),
            region_px=int(zr.shape[0]),
            time_s=time.perf_counter() - t0,
        )

    def _vertex_ids(self) -> np.ndarray:
        """Ids of the live vertices, increasing."""
        return np.flatnonzero(self._v_alive[: self._next_vertex])

    def _edge_ids(self) -> np.ndarray:
        """Keys of the live edges, increasing."""
        return np.flatnonzero(self._e_alive[: self._next_edge])

    def _reserve(self, *, vertices: int = 0, edges: int = 0) -> None:
        """Grow the vertex / edge tables (doubling) to hold at least this many ids."""
        if vertices > self._v_key.shape[0]:
            cap = max(vertices, 2 * self._v_key.shape[0], 1024)
            self._v_key = _grown(self._v_key, cap)
            self._v_code = _grown(self._v_code, cap)
            self._v_alive = _grown(self._v_alive, cap)
        if edges > self._e_uv.shape[0]:
            cap = max(edges, 2 * self._e_uv.shape[0], 1024)
            self._e_uv = _grown(self._e_uv, cap)
            self._e_alive = _grown(self._e_alive, cap)
            self._e_start = _grown(self._e_start, cap)
            self._e_len = _grown(self._e_len, cap)

    def _paths(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The pixel paths of edges ``ids``: all of them concatenated (int32 (n, 2),
        global ``(row, col)``) and their lengths (int64)."""
        lens = self._e_len[ids]
        off = np.zeros(lens.shape[0] + 1, np.int64)
        np.cumsum(lens, out=off[1:])
        rows = np.repeat(self._e_start[ids] - off[:-1], lens) + np.arange(off[-1])
        return self._pool[rows], lens

    def _add_paths(self, ids: np.ndarray, paths: np.ndarray, lens: np.ndarray) -> None:
        """Store the paths of new edges ``ids`` (``paths``: concatenated, int (n, 2))."""
        n = paths.shape[0]
        if self._pool_used + n > self._pool.shape[0]:
            self._compact_paths(n)
        start = self._pool_used
        self._pool[start : start + n] = paths
        self._e_start[ids] = start + np.cumsum(lens) - lens
        self._e_len[ids] = lens
        self._pool_used += n

    def _drop_paths(self, ids: np.ndarray) -> None:
        """Forget the paths of edges ``ids`` (their rows become holes)."""
        self._e_len[ids] = 0

    def _compact_paths(self, extra: int) -> None:
        """Make room for ``extra`` more rows: drop the holes, and grow the pool (doubling)
        if the live paths would still fill more than half of it."""
        live = self._edge_ids()
        paths, lens = self._paths(live)
        need = paths.shape[0] + extra
        cap = self._pool.shape[0]
        if 2 * need > cap:
            cap = max(2 * need, 4096)
        self._pool = np.zeros((cap, 2), np.int32)
        self._pool[: paths.shape[0]] = paths
        self._e_start[live] = np.cumsum(lens) - lens
        self._pool_used = paths.shape[0]

    # ------------------------------------------------------------------ exports
    def _bbox_or_raise(self) -> tuple[int, int, int, int]:
        bbox = self._tiles.pixel_bbox
        if bbox is None:
            raise ValueError(
                "the mapper is empty: add scans with valid readings before exporting maps"
            )
        return bbox

    def _dense(self, name: str) -> np.ndarray:
        r0, c0, r1, c1 = self._bbox_or_raise()
        return self._tiles.read(name, r0, c0, r1 - r0, c1 - c0)

    @property
    @_synchronized
    def sq_distance_px(self) -> np.ndarray:
        """Windowed squared distance to the nearest obstacle, int32 (H, W) px^2 over the
        bounding box (``FAR_SQ`` where no obstacle is within the window).  Always current
        (pending splats are applied first)."""
        self._flush_splat()
        return self._dense("sq_distance")

    @property
    @_synchronized
    def distance(self) -> np.ndarray:
        """Gaussian distance map ``H``, float32 (H, W) in [0, 1], over the bounding box of
        the allocated tiles (``[row, col]``, row 0 = top = largest y).  Always current."""
        self._flush_splat()
        if "distance" not in self._export_cache:
            r0, c0, r1, c1 = self._bbox_or_raise()
            tiles = self._tiles
            n, t = tiles.n_tiles, self.tile_px
            d2 = tiles.layer("sq_distance")
            h = np.empty((n, t, t), np.float32)
            chunk = 16
            for s in range(0, n, chunk):
                block = d2[s : s + chunk]
                if block.shape[0] < chunk:
                    pad = np.full((chunk - block.shape[0], t, t), FAR_SQ, np.int32)
                    block = np.concatenate([block, pad])
                h[s : s + chunk] = np.asarray(_gaussian(block, self._scalars[0]))[: n - s]
            out = np.zeros((r1 - r0, c1 - c0), np.float32)
            for slot, (tr, tc) in enumerate(tiles.keys):
                out[tr * t - r0 : (tr + 1) * t - r0, tc * t - c0 : (tc + 1) * t - c0] = h[slot]
            self._export_cache["distance"] = out
        return self._export_cache["distance"].copy()

    @property
    @_synchronized
    def occupancy(self):
        """The map as an :class:`~topojax.maps.OccupancyMap` over the bounding box of the
        allocated tiles: hit pixels occupied, pixels crossed by a beam and never hit free,
        the rest unknown.  Its origin puts pixel centres at the lattice world coordinates,
        so ``build_graph(mapper.occupancy)`` is in the mapper's world frame."""
        from .maps import OccupancyMap

        r0, c0, r1, c1 = self._bbox_or_raise()
        self._cast_pending_rays()
        occupied = self._dense("hits") > 0
        free = (self._dense("misses") > 0) & ~occupied
        res = self.resolution_m
        return OccupancyMap(
            occupied=occupied,
            free=free,
            unknown=~(occupied | free),
            resolution_m=res,
            origin=(c0 * res, -r1 * res, 0.0),
        )

    @property
    @_synchronized
    def obstacles(self) -> np.ndarray:
        """Obstacle mask (pixels ever hit), bool (H, W) over the bounding box."""
        return self._dense("hits") > 0

    @property
    @_synchronized
    def ridges(self) -> np.ndarray:
        """Ridge map as of the last skeleton update, bool (H, W) over the bounding box."""
        return self._dense("ridge")

    @property
    @_synchronized
    def lap_abs(self) -> np.ndarray:
        """``convertScaleAbs(Laplacian(255 H))`` as of the last skeleton update, uint8."""
        return self._dense("lap_abs")

    @property
    @_synchronized
    def skeleton(self) -> np.ndarray:
        """Skeleton as of the last skeleton update, bool (H, W) over the bounding box."""
        return self._dense("skeleton")

    @property
    @_synchronized
    def graph(self) -> nx.MultiGraph:
        """Topology graph as of the last graph update, in the exported map's frame.

        Same attribute schema as :func:`topojax.build_graph`'s graph (node ``pixel``,
        ``pixels``, ``world``, ``kind``, ``clearance_m``; edge ``path``, ``world``,
        ``length_m``, ``min_clearance_m``, ``mean_clearance_m``), with pixel coordinates
        relative to the exported bounding box.  Node ids and edge keys are the mapper's
        stable ids (see :class:`GraphUpdate`); each edge is stored with ``u <= v`` and its
        path runs from ``u`` to ``v``.  Clearances use the current distance map.
        """
        if "graph" not in self._export_cache:
            self._export_cache["graph"] = self._export_graph()
        return self._export_cache["graph"].copy()

    @property
    @_synchronized
    def graph_global(self) -> nx.MultiGraph:
        """The internal graph: node ``pixel`` and edge ``path`` in global lattice pixels,
        node ``kind``; no other attributes (a new graph)."""
        out = nx.MultiGraph()
        ids = self._vertex_ids()
        rows, cols = _unpack(self._v_key[ids])
        for v, r, c, code in zip(
            ids.tolist(), rows.tolist(), cols.tolist(), self._v_code[ids].tolist(), strict=True
        ):
            out.add_node(v, pixel=(r, c), kind=_KIND_NAME[code])
        edges = self._edge_ids()
        paths, lens = self._paths(edges)
        bounds = np.concatenate([[0], np.cumsum(lens)]).tolist()
        for i, (k, (u, v)) in enumerate(
            zip(edges.tolist(), self._e_uv[edges].tolist(), strict=True)
        ):
            out.add_edge(u, v, key=k, path=paths[bounds[i] : bounds[i + 1]].copy())
        return out

    def _export_graph(self) -> nx.MultiGraph:
        from .graph import path_lengths_m
        from .pipeline import clearance_at

        res = self.resolution_m
        out = nx.MultiGraph()
        bbox = self._tiles.pixel_bbox
        if bbox is None:
            out.graph.update(resolution_m=res, shape=(0, 0), merge_junction_clusters=False)
            return out
        r0, c0, r1, c1 = bbox
        occ = self.occupancy
        d2, obstacles = self.sq_distance_px, self.obstacles

        def clearance_m(rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
            # exact, read at these pixels only (vertex and path pixels)
            flat = rows.astype(np.intp) * d2.shape[1] + cols.astype(np.intp)
            return clearance_at(d2, obstacles, self._half, flat).astype(np.float64) * res

        out.graph.update(
            resolution_m=res,
            shape=(r1 - r0, c1 - c0),
            merge_junction_clusters=False,
            origin=tuple(float(v) for v in occ.origin),
            thinning=self.config.skeleton.thinning,
        )
        nodes = self._vertex_ids().tolist()
        if nodes:
            pix = np.stack(_unpack(self._v_key[nodes]), axis=1) - [r0, c0]
            kinds = [_KIND_NAME[code] for code in self._v_code[nodes].tolist()]
            wx, wy = occ.pixel_to_world(pix[:, 0], pix[:, 1])
            cl = clearance_m(pix[:, 0], pix[:, 1])
            for i, v in enumerate(nodes):
                rc = (int(pix[i, 0]), int(pix[i, 1]))
                out.add_node(
                    v,
                    pixel=rc,
                    pixels=np.array([rc], np.int32),
                    world=(float(wx[i]), float(wy[i])),
                    kind=kinds[i],
                    clearance_m=float(cl[i]),
                )
        edges = self._edge_ids().tolist()
        if edges:
            ends = self._e_uv[edges].tolist()
            allp, lens = self._paths(np.asarray(edges, np.int64))
            allp = allp.astype(np.int64) - [r0, c0]
            wx, wy = occ.pixel_to_world(allp[:, 0], allp[:, 1])
            world = np.stack([wx, wy], axis=1)
            cl = clearance_m(allp[:, 0], allp[:, 1])
            bounds = np.concatenate([[0], np.cumsum(lens)])
            # as the full-map graph counts them (integer steps), bit for bit
            length_m = path_lengths_m(allp, bounds[:-1], lens, res)
            path32 = allp.astype(np.int32)
            for i, k in enumerate(edges):
                u, v = ends[i]
                a, b = bounds[i], bounds[i + 1]
                out.add_edge(
                    u,
                    v,
                    key=k,
                    path=path32[a:b],
                    world=world[a:b],
                    length_m=float(length_m[i]),
                    min_clearance_m=float(cl[a:b].min()),
                    mean_clearance_m=float(cl[a:b].mean()),
                )
        return out

    @_synchronized
    def to_result(self, *, update: bool = True):
        """Everything as a :class:`topojax.pipeline.TopologyResult` (for plotting and I/O).

        Parameters
        ----------
        update : bool
            Run :meth:`update_graph` first (default) so that ridges, skeleton and graph
            describe the current map.

        Returns
        -------
        TopologyResult
            ``map`` is :attr:`occupancy`; arrays cover its grid; ``timings_s`` is empty.
        """
        from .pipeline import TopologyResult

        if update:
            self.update_graph()
        return TopologyResult(
            map=self.occupancy,
            distance=self.distance,
            lap_abs=self.lap_abs,
            ridges=self.ridges,
            skeleton=self.skeleton,
            graph=self.graph,
            config=self.config,
            timings_s={},
            sq_distance_px=self.sq_distance_px,
        )

    # ------------------------------------------------------------------ state
    def _settings(self) -> dict:
        return {
            "resolution_m": self.resolution_m,
            "skeleton_every": self.skeleton_every,
            "graph_every": self.graph_every,
            "strategy": self.strategy,
            "config": asdict(self.config),
            "tile_px": self.tile_px,
            "block_px": self.block_px,
            "max_pending_points": self.max_pending_points,
            "free_space": self.free_space,
            "max_range_m": self.max_range_m,
            "paper_layer_px": self.paper_layer_px,
            "max_grid_cells": self._tiles.max_grid_cells,
        }

    @_synchronized
    def save(self, path) -> Path:
        """Save the complete state to an ``.npz`` file, atomically.

        The file holds a ``format`` and ``version`` field, the settings (JSON), the tiles
        (keys and every layer, stacked), pending splat points and skeleton changes, the
        graph (vertex ids, pixels, kinds; edge keys, ends, concatenated paths) and the
        counters.  It is written to a temporary file in the same folder and renamed over
        ``path`` (:func:`topojax.io.atomic_write_bytes`).

        Parameters
        ----------
        path : str or Path
            Output file; its folder must exist.

        Returns
        -------
        Path
        """
        from ._fs import atomic_write_bytes

        p = Path(path)
        self._cast_pending_rays()
        arrays: dict[str, np.ndarray] = {
            "format": np.asarray(STATE_FORMAT),
            "version": np.asarray(STATE_VERSION, np.int64),
            "settings": np.asarray(json.dumps(self._settings())),
        }
        for key, value in self._tiles.state().items():
            arrays[f"tiles/{key}"] = value
        pend = np.concatenate(self._pending) if self._pending else np.zeros((0, 2), np.int64)
        chg = (
            np.concatenate(self._skel_changed) if self._skel_changed else np.zeros((0, 2), np.int64)
        )
        arrays["pending"] = pend.astype(np.int64)
        arrays["skel_changed"] = chg.astype(np.int64)
        rb = self._ridge_bbox
        arrays["ridge_bbox"] = np.asarray(rb if rb is not None else (0, 0, 0, 0), np.int64)
        arrays["has_ridge_bbox"] = np.asarray(rb is not None)
        arrays["counters"] = np.asarray(
            [
                self._n_scans,
                self._since_skeleton,
                self._since_graph,
                self._next_vertex,
                self._next_edge,
                self._n_ridge,
            ],
            np.int64,
        )
        nodes = self._vertex_ids()
        arrays["v_id"] = nodes
        arrays["v_pixel"] = np.stack(_unpack(self._v_key[nodes]), axis=1)
        arrays["v_kind"] = self._v_code[nodes].copy()
        edges = self._edge_ids()
        arrays["e_id"] = edges
        arrays["e_uv"] = self._e_uv[edges]
        paths, lens = self._paths(edges)
        arrays["e_len"] = lens.astype(np.int64)
        arrays["e_path"] = paths.astype(np.int64)
        buf = _io.BytesIO()
        np.savez_compressed(buf, **arrays)
        atomic_write_bytes(p, buf.getvalue())
        return p

    @classmethod
    def load(cls, path) -> IncrementalMapper:
        """Load a state written by :meth:`save`.

        Raises
        ------
        FileNotFoundError
            If ``path`` does not exist.
        ValueError
            If the file is not a mapper state, has another format version, or is corrupt
            (the message names the file and the problem).
        """
        p = Path(path)
        if not p.is_file():
            raise FileNotFoundError(f"mapper state file not found: {p}")
        if not zipfile.is_zipfile(p):  # np.load would read a .npy or ask about pickles
            raise ValueError(
                f"{p}: not a mapper state: a state is an .npz (zip) archive written by "
                "IncrementalMapper.save"
            )
        try:
            with np.load(p, allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}
        except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
            raise ValueError(f"{p}: not a readable mapper state (.npz): {exc}") from None
        try:
            fmt = str(data["format"])
            version = int(data["version"])
        except KeyError:
            raise ValueError(f"{p}: not a mapper state (no format/version field)") from None
        except (TypeError, ValueError):
            raise ValueError(
                f"{p}: not a mapper state (format/version field of another kind: "
                f"{data['format']!r}, {data['version']!r})"
            ) from None
        if fmt != STATE_FORMAT:
            raise ValueError(f"{p}: expected format {STATE_FORMAT!r}, got {fmt!r}")
        if version != STATE_VERSION:
            raise ValueError(
                f"{p}: mapper state version {version} is not supported; expected "
                f"{STATE_VERSION} (saved by another topojax version)"
            )
        try:
            settings = json.loads(str(data["settings"]))
            cfg = settings.pop("config")
            config = PipelineConfig(
                distance=DistanceConfig(**cfg["distance"]),
                ridge=RidgeConfig(**cfg["ridge"]),
                skeleton=SkeletonConfig(**cfg["skeleton"]),
                graph=GraphConfig(**cfg["graph"]),
                tile_px=cfg["tile_px"],
                tiles_per_call=cfg["tiles_per_call"],
            )
            mapper = cls(config=config, **settings)
            tile_state = {k[6:]: v for k, v in data.items() if k.startswith("tiles/")}
            mapper._tiles.load_state(tile_state)
            pend = np.asarray(data["pending"], np.int64).reshape(-1, 2)
            mapper._pending = [pend] if pend.shape[0] else []
            mapper._n_pending = int(pend.shape[0])
            chg = np.asarray(data["skel_changed"], np.int64).reshape(-1, 2)
            mapper._skel_changed = [chg] if chg.shape[0] else []
            if bool(data["has_ridge_bbox"]):
                mapper._ridge_bbox = tuple(int(v) for v in data["ridge_bbox"])
            (
                mapper._n_scans,
                mapper._since_skeleton,
                mapper._since_graph,
                mapper._next_vertex,
                mapper._next_edge,
                mapper._n_ridge,
            ) = (int(v) for v in data["counters"])
            v_id = np.asarray(data["v_id"], np.int64)
            v_px = np.asarray(data["v_pixel"], np.int64).reshape(-1, 2)
            v_code = np.asarray(data["v_kind"], np.int8)
            e_id = np.asarray(data["e_id"], np.int64)
            e_uv = np.asarray(data["e_uv"], np.int64).reshape(-1, 2)
            nv, ne = mapper._next_vertex, mapper._next_edge
            for name, ids, n in (("vertex", v_id, nv), ("edge", e_id, ne)):
                if ids.size and (ids.min() < 0 or ids.max() >= n):
                    raise ValueError(
                        f"{name} ids must lie in [0, {n}), got {ids.min()}..{ids.max()}"
                    )
            if not set(v_code.tolist()) <= set(_KIND_NAME):
                raise ValueError(f"unknown vertex kind codes {sorted(set(v_code.tolist()))}")
            mapper._reserve(vertices=nv, edges=ne)
            mapper._v_key[v_id] = _pack(v_px[:, 0], v_px[:, 1])
            mapper._v_code[v_id] = v_code
            mapper._v_alive[v_id] = True
            if e_uv.size and not mapper._v_alive[e_uv.ravel()].all():
                raise ValueError("some edges end at unknown vertices")
            if (np.asarray(data["e_len"]) < 1).any():
                raise ValueError("edge path lengths must be positive")
            bounds = np.concatenate([[0], np.cumsum(data["e_len"])])
            paths = np.asarray(data["e_path"], np.int64).reshape(-1, 2)
            if bounds[-1] != paths.shape[0]:
                raise ValueError("edge path lengths do not add up to the stored paths")
            mapper._e_uv[e_id] = e_uv
            mapper._e_alive[e_id] = True
            mapper._add_paths(e_id, paths.astype(np.int32), np.asarray(data["e_len"], np.int64))
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise ValueError(f"{p}: corrupt or inconsistent mapper state: {exc}") from None
        return mapper


_KIND_CODE = {"isolated": 0, "end": 1, "ring": 2, "junction": 3}
_KIND_NAME = {v: k for k, v in _KIND_CODE.items()}


# ======================================================================================
# Paper metrics
# ======================================================================================


def vertex_error_metrics(
    graph_a: nx.Graph,
    graph_b: nx.Graph,
    *,
    outlier_px: float = 20.0,
    region: tuple[int, int, int, int] | None = None,
) -> dict[str, float | int]:
    """The paper's vertex error of ``graph_a`` against ``graph_b`` (paper §IV).

    For every vertex of ``graph_a`` the Euclidean distance (pixels) to the nearest vertex
    of ``graph_b`` is taken; distances above ``outlier_px`` are outliers.  The paper
    reports the mean over non-outliers, the number of outliers out of all vertices and the
    share of vertices within 1 px (2.28 px, 5 of 251, 63.0 % for its incremental intel
    run).

    Parameters
    ----------
    graph_a, graph_b : networkx graphs
        Nodes need a ``pixel`` attribute ``(row, col)`` in the same pixel frame (e.g.
        :attr:`IncrementalMapper.graph` and ``build_graph(mapper.occupancy).graph``).
    outlier_px : float
        Outlier threshold in pixels (paper: 20).
    region : (row0, row1, col0, col1), optional
        Only vertices with ``row0 <= row < row1`` and ``col0 <= col < col1`` (in both
        graphs) count, like the paper's "inside room region".

    Returns
    -------
    dict
        ``n_vertices`` (vertices of ``graph_a`` considered), ``n_outliers``,
        ``mean_px`` (mean distance of non-outliers; NaN if none), ``share_within_1px``
        (in [0, 1]; NaN without vertices), ``median_px``, ``max_px`` (over all).
    """
    from scipy.spatial import cKDTree

    if not (isinstance(graph_a, nx.Graph) and isinstance(graph_b, nx.Graph)):
        raise TypeError(
            "graph_a and graph_b must be networkx graphs, got "
            f"{type(graph_a).__name__} and {type(graph_b).__name__}"
        )
    if not (isinstance(outlier_px, (int, float)) and outlier_px > 0):
        raise ValueError(f"outlier_px must be a number > 0, got {outlier_px!r}")

    def pixels(g: nx.Graph, name: str) -> np.ndarray:
        pts = []
        for n, pix in g.nodes(data="pixel"):
            if pix is None:
                raise ValueError(f"{name}: node {n!r} has no 'pixel' attribute (row, col)")
            pts.append(pix)
        arr = np.asarray(pts, np.float64).reshape(-1, 2)
        if region is not None:
            r0, r1, c0, c1 = region
            keep = (arr[:, 0] >= r0) & (arr[:, 0] < r1) & (arr[:, 1] >= c0) & (arr[:, 1] < c1)
            arr = arr[keep]
        return arr

    a = pixels(graph_a, "graph_a")
    b = pixels(graph_b, "graph_b")
    if a.shape[0] == 0:
        nan = float("nan")
        return {
            "n_vertices": 0,
            "n_outliers": 0,
            "mean_px": nan,
            "share_within_1px": nan,
            "median_px": nan,
            "max_px": nan,
        }
    if b.shape[0] == 0:
        d = np.full(a.shape[0], np.inf)
    else:
        d, _ = cKDTree(b).query(a)
    inlier = d <= outlier_px
    return {
        "n_vertices": int(a.shape[0]),
        "n_outliers": int((~inlier).sum()),
        "mean_px": float(d[inlier].mean()) if inlier.any() else float("nan"),
        "share_within_1px": float((d <= 1.0).mean()),
        "median_px": float(np.median(d)),
        "max_px": float(d.max()),
    }


# ======================================================================================
# Replay (used by the ``topojax replay`` command)
# ======================================================================================


def timing_summary(reports: list[ScanReport]) -> dict[str, dict[str, float]]:
    """Per-loop timing statistics of a replay.

    Parameters
    ----------
    reports : list of ScanReport

    Returns
    -------
    dict
        For each loop (``distance``, ``splat``, ``skeleton``, ``graph``) and for
        ``add_scan`` (the sum of the loops of one call): ``count`` (calls that ran it),
        ``mean_ms``, ``p50_ms``, ``p99_ms``, ``max_ms`` (over those calls), ``total_s`` and
        ``per_scan_ms`` (total divided by all scans: the amortised cost).
    """
    n = max(len(reports), 1)
    series: dict[str, list[float]] = {}
    for r in reports:
        for k, v in r.timings_s.items():
            series.setdefault(k, []).append(v)
        series.setdefault("add_scan", []).append(
            sum(v for k, v in r.timings_s.items() if k != "splat")
        )
    out = {}
    for k, v in series.items():
        a = np.asarray(v) * 1e3
        out[k] = {
            "count": len(v),
            "mean_ms": float(a.mean()),
            "p50_ms": float(np.percentile(a, 50)),
            "p99_ms": float(np.percentile(a, 99)),
            "max_ms": float(a.max()),
            "total_s": float(a.sum() / 1e3),
            "per_scan_ms": float(a.sum() / n),
        }
    return out


def _frame(mapper: IncrementalMapper, max_px: int = 500) -> dict:
    """A small snapshot for the animation: downsampled map image, world extent, edges."""
    occ = mapper.occupancy
    img = occ.to_image()
    step = max(1, -(-max(img.shape) // max_px))
    h, w = occ.shape
    ox, oy, _ = occ.origin
    res = occ.resolution_m
    g = mapper.graph
    edges = [d for *_, d in g.edges(data="world")]
    verts = np.array([d for _, d in g.nodes(data="world")], np.float64).reshape(-1, 2)
    return {
        "image": img[::step, ::step],
        "extent": (ox, ox + w * res, oy, oy + h * res),
        "edges": edges,
        "vertices": verts,
        "scan": mapper.n_scans,
    }


def _write_animation(frames: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter

    last = frames[-1]["extent"]
    fig, ax = plt.subplots(figsize=(7, 7))

    def draw(i: int):
        f = frames[i]
        ax.clear()
        ax.imshow(f["image"], cmap="gray", vmin=0, vmax=255, extent=f["extent"])
        for wline in f["edges"]:
            ax.plot(wline[:, 0], wline[:, 1], color="#d62728", lw=1.0)
        if f["vertices"].size:
            ax.plot(f["vertices"][:, 0], f["vertices"][:, 1], ".", color="#1f77b4", ms=2)
        ax.set_xlim(last[0], last[1])
        ax.set_ylim(last[2], last[3])
        ax.set_title(f"scan {f['scan']}: {len(f['edges'])} edges")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        return []

    anim = FuncAnimation(fig, draw, frames=len(frames), blit=False)
    tmp = path.with_name(f".{path.name}.tmp.gif")
    try:
        anim.save(tmp, writer=PillowWriter(fps=3))
        tmp.replace(path)
    finally:
        plt.close(fig)
        tmp.unlink(missing_ok=True)


def replay(
    source,
    *,
    out_dir,
    plot: bool = False,
    animate=None,
    progress: bool = True,
    max_scans: int | None = None,
    reader_kwargs: dict | None = None,
    nav2_tolerance_m: float | None = None,
    graph_config: GraphConfig | None = None,
    **mapper_kw,
) -> dict:
    """Replay a scan log through an :class:`IncrementalMapper` and write the results.

    Parameters
    ----------
    source : str or Path
        A CARMEN log, ROS bag or Octave laser file (see :func:`topojax.scans.read_scans`).
    out_dir : str or Path
        Output folder (created).  Written: ``graph.graphml``, ``graph.json``,
        ``graph.geojson`` (skipped with a message when an attribute is not finite),
        ``map.yaml`` + ``map.pgm`` (the occupancy map), ``timings.json`` (per-loop
        statistics, see :func:`timing_summary`) and, with ``plot``, ``graph.png`` and
        ``stages.png``.
    plot : bool
        Write pictures.
    animate : str or Path, optional
        Write an animated GIF with one frame per graph update.
    progress : bool
        Show a tqdm progress bar.
    max_scans : int, optional
        Stop after this many scans.
    reader_kwargs : dict, optional
        Passed to the reader.
    nav2_tolerance_m : float, optional
        Also write ``graph_nav2.geojson``, a route graph for the ROS 2 Nav2 Route Server
        with this waypoint tolerance (:func:`topojax.save_nav2_graph`); with ``map.yaml``
        it is what Nav2 needs.  Skipped with a message when the graph has no edges.
    graph_config : GraphConfig, optional
        What the written graph (and Nav2 file and pictures) keep of the final graph:
        ``free_space_only`` and the ``min_*_m`` pruning, as :func:`topojax.build_graph`
        applies them (thinning, T removal and the graph step are re-run on the final
        ridge map, which equals the full-map pipeline's, so the written graph is
        ``build_graph(map, ...)``'s with this ``graph``).  Default: the mapper's whole
        graph, as the paper keeps it.  The animation shows the mapper's whole graph as
        it grew.
    **mapper_kw
        Passed to :class:`IncrementalMapper` (``resolution_m``, ``skeleton_every``,
        ``graph_every``, ``strategy``, ...).

    Returns
    -------
    dict
        ``n_scans``, ``n_tiles``, ``vertices``, ``edges``, ``timings`` (per loop),
        ``written`` (paths), ``messages``.
    """
    from tqdm import tqdm

    from ._fs import output_folder
    from .graph import graph_summary
    from .io import save_graph, save_nav2_graph
    from .maps import save_map
    from .scans import read_scans

    if max_scans is not None and (
        isinstance(max_scans, bool) or not isinstance(max_scans, int) or max_scans < 1
    ):
        raise ValueError(f"max_scans must be a positive int or None, got {max_scans!r}")
    if nav2_tolerance_m is not None:  # checked now, not after the whole replay
        from ._validate import positive_metres

        nav2_tolerance_m = positive_metres("nav2_tolerance_m", nav2_tolerance_m)
    if graph_config is not None and not isinstance(graph_config, GraphConfig):
        raise TypeError(
            f"graph_config: expected a GraphConfig, received {type(graph_config).__name__}"
        )
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(
            f"out_dir: expected a folder to write into, but {out} is an existing file"
        )
    if animate is not None and Path(animate).is_dir():  # checked now, not after the replay
        raise IsADirectoryError(
            f"animate: expected a GIF file name, got the folder {animate}; e.g. "
            f"{Path(animate) / 'graph.gif'}"
        )
    scans = read_scans(source, **(reader_kwargs or {}))
    mapper = IncrementalMapper(**mapper_kw)
    output_folder(out)
    reports: list[ScanReport] = []
    frames: list[dict] = []
    bar = tqdm(total=max_scans, unit="scan", disable=not progress, desc="replay")
    t0 = time.perf_counter()
    for i, scan in enumerate(scans):
        if max_scans is not None and i >= max_scans:
            break
        rep = mapper.add_scan(scan)
        reports.append(rep)
        if animate is not None and rep.graph_update is not None and mapper.pixel_bbox:
            frames.append(_frame(mapper))
        bar.update(1)
    bar.close()
    wall = time.perf_counter() - t0
    if not reports:
        raise ValueError(f"source {source}: no scans to replay")
    if mapper.pixel_bbox is None:
        raise ValueError(f"source {source}: no valid laser readings in {len(reports)} scans")
    t_final = time.perf_counter()
    update = mapper.update_graph()
    final_s = time.perf_counter() - t_final
    result = mapper.to_result(update=False)
    if graph_config is not None and (graph_config.free_space_only or graph_config.prunes):
        result = _with_graph_config(result, graph_config)
    written: list[Path] = []
    messages: list[str] = []
    for suffix in (".graphml", ".json", ".geojson"):
        try:
            written.append(save_graph(result.graph, out / f"graph{suffix}"))
        except ValueError as exc:
            messages.append(f"graph{suffix} not written: {exc}")
    if nav2_tolerance_m is not None:
        try:
            written.append(
                save_nav2_graph(
                    result.graph, out / "graph_nav2.geojson", tolerance_m=nav2_tolerance_m
                )
            )
        except ValueError as exc:  # e.g. a graph without edges, which Nav2 refuses
            messages.append(f"graph_nav2.geojson not written: {exc}")
    written.append(save_map(result.map, out / "map.yaml"))
    written.append(out / "map.yaml")
    timings = timing_summary(reports)
    summary_g = graph_summary(result.graph)
    summary = {
        "source": str(source),
        "n_scans": len(reports),
        "n_tiles": mapper.n_tiles,
        "map_shape": list(result.map.shape),
        "vertices": summary_g["n_vertices"],
        "edges": summary_g["n_edges"],
        "wall_s": wall,
        "final_update_s": final_s,
        "final_update": asdict(update),
        "timings": timings,
        "settings": mapper._settings(),
    }
    from ._fs import atomic_write_bytes

    atomic_write_bytes(out / "timings.json", json.dumps(summary, indent=2).encode("utf-8"))
    written.append(out / "timings.json")
    if plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from .plotting import plot as plot_result
        from .plotting import plot_stages

        ax = plot_result(result)
        ax.figure.savefig(out / "graph.png", dpi=150, bbox_inches="tight")
        plt.close(ax.figure)
        written.append(out / "graph.png")
        fig = plot_stages(result)
        fig.savefig(out / "stages.png", dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(out / "stages.png")
    if animate is not None:
        frames.append(_frame(mapper))
        apath = Path(animate)
        apath.parent.mkdir(parents=True, exist_ok=True)
        _write_animation(frames, apath)
        written.append(apath)
    summary["written"] = [str(p) for p in written]
    summary["messages"] = messages
    if progress:
        print(summary_text(summary))
    return summary


def summary_text(summary: dict) -> str:
    lines = [
        f"replayed   {summary['n_scans']} scans of {summary['source']} in "
        f"{summary['wall_s']:.2f} s; map {summary['map_shape'][0]} x "
        f"{summary['map_shape'][1]} px in {summary['n_tiles']} tiles",
        f"graph      {summary['vertices']} vertices, {summary['edges']} edges",
        "loop        calls    mean ms     p50 ms     p99 ms   amortised ms/scan",
    ]
    for k in ("distance", "splat", "skeleton", "graph", "add_scan"):
        s = summary["timings"].get(k)
        if s:
            lines.append(
                f"{k:10s} {s['count']:6d} {s['mean_ms']:10.3f} {s['p50_ms']:10.3f} "
                f"{s['p99_ms']:10.3f} {s['per_scan_ms']:12.4f}"
            )
    lines.extend(summary.get("messages", []))
    return "\n".join(lines)


def _with_graph_config(result, graph_config: GraphConfig):
    """``result`` with the skeleton and graph that ``graph_config`` keeps: the CPU stages
    of the full-map pipeline re-run on its ridge map (exact, so the graph is the one
    ``build_graph(result.map, ...)`` gives with that ``graph``)."""
    from dataclasses import replace

    from .pipeline import graph_of_map

    config = replace(result.config, graph=graph_config)
    skeleton, graph, _ = graph_of_map(result.map, result.ridges, result.sq_distance_px, config)
    return replace(result, skeleton=skeleton, graph=graph, config=config)
