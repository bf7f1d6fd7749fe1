""":func:`build_graph_tiled`: the topology graph of a map read block by block, identical to
:func:`topojax.build_graph`'s, with a working set bounded by the block size (plus the
sparse skeleton and the graph themselves)."""

from __future__ import annotations

import concurrent.futures as cf
import math
import os
import time
import warnings
from collections import deque
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from .._cpus import as_executor, available_memory_bytes, byte_size, check_fits_memory
from .._lock import one_writer
from .._validate import flag, instance_or_default, positive_int, quantity
from ..config import PipelineConfig
from ..maps import IMAGE_SUFFIXES, YAML_SUFFIXES, load_map
from ..maps.occupancy import OccupancyMap
from ..maps.tiled import TiledMap, array_map, open_tiled_map
from .blocks import BlockPiece, block_piece, fields_halo_px, window_box
from .checkpoint import BlockCheckpoints

__all__ = ["BYTES_PER_WINDOW_PX", "TiledResult", "block_px_for_budget", "build_graph_tiled"]

#: Bytes one block's stages take per pixel of its kernel window, an upper estimate (the
#: classified window, the kernels' padded map and column pass, the ridges, the thinning's
#: work space; measured in ``bench/bench_memory.py``).
BYTES_PER_WINDOW_PX = 24
#: Bytes the whole pixel graph takes per skeleton pixel while junction clusters are merged,
#: a lower estimate (0.8 times the least measured over sparse to cluttered maps).
MERGE_BYTES_PER_SKELETON_PX = 60
#: Largest halo tried for one block before giving up, in multiples of the tile side
#: beyond the first.
MAX_HALO_STEPS = 16


@dataclass(frozen=True, eq=False, repr=False)
class TiledResult:
    """What :func:`build_graph_tiled` produced.

    Attributes
    ----------
    map : TiledMap
        The input map.
    graph_store : GraphStore or None
        The graph as arrays (None when ``config.graph`` prunes: ``graph`` then holds it).
    config : PipelineConfig
    row_start : int64 (H + 1,)
        The skeleton row by row: row ``r``'s pixels are
        ``cols[row_start[r]:row_start[r + 1]]``.
    cols : int32 (n,)
        Columns of the skeleton's pixels (the pixels set in :func:`topojax.build_graph`'s
        ``skeleton``), increasing within each row.
    timings_s : dict[str, float]
        ``blocks`` (all block stages, with the clearances), ``graph`` and ``total``.
    blocks : int
        Number of blocks.
    blocks_reused : int
        Blocks read from a stopped build's ``out_dir`` (``resume=True``), not computed.
    halo_px : tuple of int
        The distinct halos the blocks needed, smallest first.
    pruned_graph : networkx.MultiGraph or None
        The graph when ``config.graph`` prunes (pruning works on networkx), else None.
    largest_window_px : (int, int)
        Rows and columns of the largest kernel window a block read (the block and the
        halo it needed on each side, clipped to the map); its stages took about
        :data:`BYTES_PER_WINDOW_PX` bytes per pixel of it.
    graph : networkx.MultiGraph
        ``pruned_graph``, or built from ``graph_store`` on first access.

    Notes
    -----
    The per-pixel fields of :class:`topojax.TopologyResult` (distance, ridges, skeleton
    image) are not held: they are map-sized.
    """

    map: TiledMap
    graph_store: Any
    config: PipelineConfig
    row_start: np.ndarray
    cols: np.ndarray
    timings_s: dict[str, float] = field(default_factory=dict)
    blocks: int = 0
    blocks_reused: int = 0
    halo_px: tuple[int, ...] = ()
    pruned_graph: Any = None
    largest_window_px: tuple[int, int] = (0, 0)

    def skeleton_flat(self) -> np.ndarray:
        """Flat indices ``row * W + col`` (int64, increasing) of the skeleton's pixels."""
        rows = np.repeat(np.arange(self.row_start.size - 1), np.diff(self.row_start))
        return rows * self.map.shape[1] + self.cols

    @cached_property
    def graph(self):
        if self.pruned_graph is not None:
            return self.pruned_graph
        return self.graph_store.to_networkx()

    def __repr__(self) -> str:
        return (
            f"TiledResult(map shape={self.map.shape}, blocks={self.blocks}, halo_px="
            f"{self.halo_px}, largest_window_px={self.largest_window_px}, skeleton_px="
            f"{self.cols.size}, timings_s={self.timings_s})"
        )


def block_px_for_budget(
    memory_budget_mb: float, config: PipelineConfig, *, shape: tuple[int, int] | None = None
) -> int:
    """The largest block side (a multiple of ``config.tile_px``, at least one tile) whose
    stages take about ``memory_budget_mb`` (:data:`BYTES_PER_WINDOW_PX` per pixel of the
    kernels' window, the block plus the first halo on each side); a budget below one
    tile's window (cut at the edges of a map of ``shape``, where given) is refused.  A
    budget above the memory available now (:func:`~topojax._cpus.available_memory_bytes`)
    guards nothing: a ``UserWarning`` says so (not a refusal: what is available changes
    while a build runs)."""
    budget = quantity("memory_budget_mb", memory_budget_mb, unit="megabytes", allow_zero=False)
    t = config.tile_px
    halo = _first_halo(config)
    side = t + 2 * halo
    window = (side, side) if shape is None else tuple(min(side, int(n)) for n in shape)
    least_mb = BYTES_PER_WINDOW_PX * window[0] * window[1] / 2**20
    if budget < least_mb:
        cut = (
            ""
            if window == (side, side)
            else (f", a window of {window[0]} x {window[1]} px cut at this map's edges")
        )
        raise ValueError(
            f"memory_budget_mb: expected at least {math.ceil(least_mb * 10) / 10:g} MB, what "
            f"the smallest block takes (one {t} px tile with a halo of {halo} px on each "
            f"side, the distance window's reach{cut}), received {budget:g}"
        )
    available = available_memory_bytes()
    if available is not None and budget * 2**20 > available:
        warnings.warn(
            f"memory_budget_mb: {budget:g} MB ({byte_size(budget * 2**20)}) is more than the "
            f"{byte_size(available)} of memory available; blocks sized to it may not fit (a "
            "smaller budget gives smaller blocks)",
            UserWarning,
            stacklevel=2,
        )
    # 2**20 bytes a megabyte: 2**10 pixels a side; the budget is not multiplied by 2**20,
    # which overflows to inf for a budget near the largest float
    side = math.sqrt(budget / BYTES_PER_WINDOW_PX) * 2**10 - 2 * halo
    return max(t, int(side // t) * t)


def _first_halo(config: PipelineConfig) -> int:
    """The smallest halo tried: the kernels' reach plus a few pixels to thin, rounded up
    to the tile side."""
    t = config.tile_px
    return -(-(fields_halo_px(config) + 8) // t) * t


def tiled_source(source, **overrides) -> TiledMap:
    """``source`` as :func:`build_graph_tiled` takes it, as a :class:`TiledMap`; a path
    is opened with ``overrides`` (``resolution_m``, ``mode``, ... as
    :func:`~topojax.maps.tiled.open_tiled_map` and :func:`topojax.load_map` take them),
    read a window at a time where it can be, else whole."""
    if isinstance(source, TiledMap):
        return source
    if isinstance(source, OccupancyMap):
        return TiledMap.from_occupancy(source)
    if isinstance(source, (str, os.PathLike)):
        if not Path(source).exists():  # named here, not as open_tiled_map's ``path``
            raise FileNotFoundError(f"source: map not found: {source}")
        try:
            return open_tiled_map(source, **overrides)
        except ValueError as exc:
            if Path(source).suffix.lower() not in IMAGE_SUFFIXES + YAML_SUFFIXES:
                # named as this function's ``source``, not as open_tiled_map's ``path``
                text = str(exc)
                if not text.startswith("path: "):
                    raise
                raise ValueError(f"source: {text[len('path: ') :]}") from None
            # an image that cannot be read a window at a time (PNG, ASCII PGM...): whole
            return TiledMap.from_occupancy(load_map(source, **overrides))
    if isinstance(source, np.ndarray):
        return array_map("source", source)
    raise TypeError(
        "source: expected a TiledMap, an OccupancyMap, a 2-D array or the path of a tile "
        f"folder, Zarr array or PGM, received {type(source).__name__}"
    )


def _block_task(
    tiled: TiledMap, box, config: PipelineConfig, halo: int, threads, digest: bool = False
) -> BlockPiece:
    """One block, its halo grown a tile at a time until its pixels are proved exact
    (with ``digest``, the piece carries its window's digest)."""
    t = config.tile_px
    for _ in range(MAX_HALO_STEPS + 1):
        piece = block_piece(tiled, box, config, halo, threads, digest)
        if piece.halo_px is not None:
            return piece
        halo += t
    raise RuntimeError(
        f"block {box}: thinning still reached the block from {halo - t} px away; "
        "the block's skeleton could not be proved equal to the whole map's"
    )


def build_graph_tiled(
    source,
    *,
    config: PipelineConfig | None = None,
    block_px: int | None = None,
    memory_budget_mb: float = 512.0,
    executor=None,
    threads: int | None = None,
    out_dir=None,
    resume: bool = False,
) -> TiledResult:
    """Build the topology graph of a map read block by block (maps larger than memory).

    Parameters
    ----------
    source : TiledMap, OccupancyMap, array or path
        The map: a :class:`TiledMap`, or what :func:`open_tiled_map` opens (a tile
        folder, a Zarr array, a binary PGM or a YAML naming one), or a map in memory.
        Another map file :func:`topojax.load_map` reads (PNG, ...) is read whole.
    config : PipelineConfig, optional
        As for :func:`topojax.build_graph`.
    block_px : int, optional
        Block side in pixels, a multiple of ``config.tile_px``; default: the largest
        whose stages fit ``memory_budget_mb``.  Given, the windows it makes are the
        caller's choice: ``TiledResult.largest_window_px`` records the largest, and
        nothing is warned of.
    memory_budget_mb : float, default 512
        Memory for one block's stages (per worker), used when ``block_px`` is None;
        not the kernels' compilers and runtimes, which a process's first call loads
        once (``docs/performance.md``).  A budget above the memory available is
        warned of (:func:`block_px_for_budget`).  A block whose proof needs a wider
        halo reads a larger window than its first; where that passes the budget (at
        :data:`BYTES_PER_WINDOW_PX` bytes a pixel), one ``UserWarning`` per build names
        the budget, the largest window and the halo it needed
        (``TiledResult.largest_window_px``).
    executor : concurrent.futures.Executor or dask.distributed.Client, optional
        Runs the blocks as tasks (a Dask ``Client``: on its workers, each reading its
        window from the source); default: one after another in this process.  A
        process pool must start its workers with ``forkserver`` or ``spawn``: one
        forked from a process that has run JAX can deadlock (a ValueError refuses a
        ``ProcessPoolExecutor`` whose start method is ``fork``).
    threads : int, optional
        Kernel dispatch threads per block (as for :func:`topojax.fields.dense_fields`).
    out_dir : str or Path, optional
        Folder (created) that receives the graph as :func:`topojax.save_graph_store`
        saves it (:func:`topojax.load_graph_store` opens it again).  The two
        skeleton-sized arrays, ``path_pixels.npy`` and ``path_world.npy``, are written
        a block of edges at a time and given to the store memory-mapped, so they need
        not fit in memory (with junction clusters merged the graph is built in memory
        and its arrays written there after; with pruning, the folder holds the pruned
        graph; a build that stops leaves it without ``graph_store.json``).  While the
        build runs, the folder's ``topojax_blocks/`` keeps each finished block (12 bytes
        per skeleton pixel), removed once the graph is written.  Default: in memory.
    resume : bool, default False
        Go on from the blocks a stopped build left in ``out_dir`` (the same map, options
        and block side; a block whose map window changed since is computed again);
        blocks of another build are refused.  False: an earlier build's blocks there
        are removed first.  One build at a time writes into a folder: a second one
        there is refused with a ``BlockingIOError``.

    Returns
    -------
    TiledResult
        Its graph equals :func:`topojax.build_graph`'s for the whole map: vertices,
        edges, paths and attributes.

    Notes
    -----
    Every field is local (the distance is windowed), so one block's ridges need a halo
    of ``half_width_px + 2`` pixels; its thinning is proved exact by tracking which
    pixels the unseen map could still change, the halo growing a tile at a time where
    the proof fails (:mod:`topojax.outofcore.exact`).  Clearances beyond the window are
    searched exactly in the map itself.  The working set is one block's window per
    worker, plus about 10 bytes per skeleton pixel (its column, clearance, link mask and
    state; :func:`topojax.graph.sparse.row_skeleton_graph_store`), the graph's vertex and
    edge arrays, and its paths (32 bytes per skeleton pixel; on disk with ``out_dir``).
    With ``merge_junction_clusters`` the graph is built from the whole pixel graph
    (:func:`topojax.graph.pixels_graph_store`, 75-170 bytes per skeleton pixel), and
    pruning works on the networkx graph: both are refused up front (a ``MemoryError``
    naming the option) where the memory available cannot hold them.
    """
    config = instance_or_default("config", config, PipelineConfig)
    tiled = tiled_source(source)
    given = block_px is not None
    block_px, threads, resume = _checked_options(
        config, tiled.shape, block_px, memory_budget_mb, threads, resume, out_dir
    )
    _refuse_forked_workers(executor)
    sized_for = _sized_window(block_px if given else None, memory_budget_mb)
    if out_dir is None:
        return _build(tiled, config, block_px, threads, executor, None, resume, sized_for)
    # one build per folder: two into it would overwrite each other's kept blocks
    with one_writer(out_dir, name="out_dir", command="build_graph_tiled") as out:
        return _build(tiled, config, block_px, threads, executor, out, resume, sized_for)


def _build(
    tiled: TiledMap,
    config: PipelineConfig,
    block_px: int,
    threads,
    executor,
    out_dir,
    resume,
    sized_for: tuple[float, str],
) -> TiledResult:
    """:func:`build_graph_tiled` of the checked options, into the folder ``out_dir``
    (made and locked; None: in memory); a window past ``sized_for`` (its pixels, what
    sized it, how) is warned of (:class:`_Windows`)."""
    pool = as_executor(executor)
    kept = None
    if out_dir is not None:
        kept = BlockCheckpoints(out_dir, tiled, config, block_px, resume=resume)
    h, w = tiled.shape
    boxes = [
        (r, min(h, r + block_px), c, min(w, c + block_px))
        for r in range(0, h, block_px)
        for c in range(0, w, block_px)
    ]
    halo = _first_halo(config)
    t0 = time.perf_counter()
    reused = {b for b in boxes if kept.usable(b)} if resume else set()
    todo = [b for b in boxes if b not in reused]
    computed = _computed(
        tiled, todo, config, halo, threads, pool, executor, digest=kept is not None
    )
    skeleton = _Skeleton(tiled, config.distance.half_width_px, config.tile_px)
    windows = _Windows(tiled.shape, sized_for[0])
    for piece in _in_block_order(boxes, reused, computed, kept):
        windows.add(piece)
        skeleton.add(piece)
    row_start, cols, clearance = skeleton.finish()
    windows.warn(sized_for, halo, len(boxes))
    t1 = time.perf_counter()
    store, pruned = _graph(tiled, row_start, cols, clearance, config, out_dir)
    if kept is not None:  # the graph is written: the blocks are not needed any more
        kept.remove()
    t2 = time.perf_counter()
    return TiledResult(
        map=tiled,
        graph_store=store,
        config=config,
        row_start=row_start,
        cols=cols,
        timings_s={"blocks": t1 - t0, "graph": t2 - t1, "total": t2 - t0},
        blocks=len(boxes),
        blocks_reused=len(reused),
        halo_px=tuple(sorted(skeleton.halos)),
        pruned_graph=pruned,
        largest_window_px=windows.largest,
    )


def _sized_window(block_px: int | None, memory_budget_mb: float) -> tuple[float, str]:
    """``(pixels, what)`` of the kernel window the budget holds where it sized the blocks
    (``block_px`` None); ``(inf, "")`` where ``block_px`` was given, which the budget does
    not size (the window is then the caller's choice, recorded but not warned of)."""
    if block_px is not None:
        return math.inf, ""
    limit_px = memory_budget_mb * 2**20 / BYTES_PER_WINDOW_PX
    return limit_px, f"memory_budget_mb={memory_budget_mb:g} holds ({limit_px:.0f} px)"


class _Windows:
    """The largest kernel window the blocks read, and how many read more than
    ``limit_px`` pixels."""

    def __init__(self, shape, limit_px: float) -> None:
        self.shape, self.limit_px = shape, limit_px
        self.largest: tuple[int, int] = (0, 0)
        self.box, self.halo, self.over = None, 0, 0

    def add(self, piece: BlockPiece) -> None:
        f0, f1, g0, g1 = window_box(piece.box, piece.halo_px, self.shape)
        size = (f1 - f0) * (g1 - g0)
        self.over += size > self.limit_px
        if size > self.largest[0] * self.largest[1]:
            self.largest, self.box, self.halo = (f1 - f0, g1 - g0), piece.box, piece.halo_px

    def warn(self, sized_for: tuple[float, str], first_halo: int, blocks: int) -> None:
        """One ``UserWarning`` when a window outgrew ``sized_for``: the halo that made it
        is the proof's, which no block side shrinks."""
        limit_px, how = sized_for
        if not self.over:
            return
        rows, cols = self.largest
        mb = BYTES_PER_WINDOW_PX * rows * cols / 2**20
        r0, r1, c0, c1 = self.box
        warnings.warn(
            f"memory_budget_mb: {self.over} of {blocks} blocks read a larger window than "
            f"{how}, the largest {rows} x {cols} px ({mb:.1f} MB at "
            f"{BYTES_PER_WINDOW_PX} bytes a pixel): block rows {r0}:{r1}, columns {c0}:{c1} "
            f"needed a halo of {self.halo} px, not the first ({first_halo} px), for its "
            "thinning to be proved equal to the whole map's (a smaller block does not "
            "shrink the halo; result.largest_window_px records the window)",
            UserWarning,
            stacklevel=4,
        )


def _checked_options(
    config: PipelineConfig, shape, block_px, memory_budget_mb, threads, resume, out_dir
):
    """``(block_px, threads, resume)`` of :func:`build_graph_tiled` for a map of
    ``shape``, checked (here, not in the first block or a worker's task)."""
    if block_px is None:
        block_px = block_px_for_budget(memory_budget_mb, config, shape=shape)
    else:  # it sizes nothing then, but a bad one is refused rather than ignored
        quantity("memory_budget_mb", memory_budget_mb, unit="megabytes", allow_zero=False)
    block_px = positive_int("block_px", block_px)
    if block_px % config.tile_px:
        raise ValueError(
            f"block_px: expected a multiple of config.tile_px ({config.tile_px}), "
            f"received {block_px}"
        )
    if threads is not None:
        threads = positive_int("threads", threads)
    resume = flag("resume", resume)
    if resume and out_dir is None:
        raise ValueError(
            "resume: expected out_dir, the folder whose blocks a stopped build left, "
            "received out_dir=None"
        )
    return block_px, threads, resume


def _refuse_forked_workers(executor) -> None:
    """Refuse a process pool that forks its workers: each block runs JAX in a worker,
    and one forked from this process (which runs JAX's threads) waited for ever on a lock
    one of them held at the fork, so the build never ended."""
    if not isinstance(executor, cf.ProcessPoolExecutor):
        return
    context = getattr(executor, "_mp_context", None)  # no public way to ask the pool
    if context is not None and context.get_start_method() == "fork":
        raise ValueError(
            "executor: expected a process pool whose workers start with 'forkserver' or "
            "'spawn' (ProcessPoolExecutor(mp_context=multiprocessing.get_context("
            "'forkserver'))), received one that forks them, which can wait for ever on a "
            "lock of JAX's threads"
        )


def _computed(
    tiled: TiledMap, boxes, config: PipelineConfig, halo: int, threads, pool, executor, *, digest
):
    """The pieces of ``boxes``, in order, computed here or by ``pool`` (the executor of
    ``executor``), each with its window's digest when ``digest``."""
    if pool is None:
        return (_block_task(tiled, b, config, halo, threads, digest) for b in boxes)
    shared = tiled
    if not isinstance(executor, cf.Executor) and hasattr(executor, "scatter"):
        shared = executor.scatter(tiled, broadcast=True)  # once, not once per block
    futures = deque(
        pool.submit(_block_task, shared, b, config, halo, threads, digest) for b in boxes
    )
    return _results(futures)


def _in_block_order(boxes, reused: set, computed, kept):
    """Every block's piece in the order of ``boxes``: the ``reused`` ones read from
    ``kept`` (:class:`BlockCheckpoints` or None), the others the next of ``computed``
    (in order), each kept there as it comes."""
    for box in boxes:
        if box in reused:
            yield kept.load(box)
            continue
        piece = next(computed)
        if kept is not None:
            kept.save(piece)
        yield piece


def _results(futures: deque):
    """The futures' results in order, each future dropped once read (a kept future keeps
    its block's pixels in memory, or on a Dask worker, to the end)."""
    while futures:
        yield futures.popleft().result()


class _Skeleton:
    """The skeleton's pixels row by row, gathered from the blocks (given in block order,
    a band of blocks at a time) with their clearances."""

    def __init__(self, tiled: TiledMap, half_width: int, group_px: int) -> None:
        self.tiled, self.half_width, self.group_px = tiled, half_width, group_px
        self.band: list[BlockPiece] = []
        self.counts: list[np.ndarray] = []  # pixels per row, band after band
        self.cols: list[np.ndarray] = []
        self.clearance: list[np.ndarray] = []
        self.occupied = 0
        self.halos: set[int] = set()

    def add(self, piece: BlockPiece) -> None:
        if self.band and piece.box[0] != self.band[0].box[0]:
            self._close_band()
        self.band.append(piece)
        self.occupied += piece.occupied_px
        self.halos.add(piece.halo_px)

    def _close_band(self) -> None:
        band, self.band = self.band, []
        r0, r1 = band[0].box[:2]
        w = self.tiled.shape[1]
        flat = np.concatenate([p.flat for p in band])
        sq = np.concatenate([p.sq_distance_px for p in band])
        del band
        order = np.argsort(flat, kind="stable")
        flat, sq = flat[order], sq[order]
        rows, cols = np.divmod(flat, w)
        self.counts.append(np.bincount(rows - r0, minlength=r1 - r0))
        self.cols.append(cols.astype(np.int32))
        self.clearance.append(
            _clearance(self.tiled, rows, cols, sq, self.half_width, self.group_px)
        )

    def finish(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.band:
            self._close_band()
        h = self.tiled.shape[0]
        if self.occupied == self.tiled.size:  # no space to travel (travel_ridges)
            return np.zeros(h + 1, np.int64), np.zeros(0, np.int32), np.zeros(0, np.float32)
        row_start = np.zeros(h + 1, np.int64)
        np.cumsum(np.concatenate(self.counts), out=row_start[1:])
        return row_start, _joined(self.cols, np.int32), _joined(self.clearance, np.float32)


def _joined(parts: list[np.ndarray], dtype) -> np.ndarray:
    """The parts one after another, each dropped from ``parts`` once copied (the peak is
    the result and one part, not twice the result)."""
    out = np.empty(sum(p.size for p in parts), dtype)
    at = 0
    parts.reverse()
    while parts:
        part = parts.pop()
        out[at : at + part.size] = part
        at += part.size
    return out


def _clearance(tiled: TiledMap, rows, cols, sq, half_width: int, group_px: int) -> np.ndarray:
    """Clearance in pixels (float32) at pixels ``(rows, cols)``: the square root of the
    windowed squared distance ``sq`` within ``R``, else of the exact one found in the map
    (``inf`` on a map without obstacles)."""
    out = np.sqrt(sq.astype(np.float32))
    far = np.flatnonzero(sq > half_width * half_width)
    if far.size == 0:
        return out
    rows, cols = rows[far], cols[far]
    # one search per square of `group_px`: a window of that square and its margin
    group = (rows // group_px) * (-(-tiled.shape[1] // group_px)) + cols // group_px
    exact = np.empty(far.size, np.int64)
    for g in np.unique(group):
        sel = np.flatnonzero(group == g)
        exact[sel] = _nearest_sq(tiled, rows[sel], cols[sel], 2 * half_width)
    out[far] = np.where(exact < 0, np.inf, np.sqrt(exact.astype(np.float32)))
    return out


def _nearest_sq(tiled: TiledMap, rows, cols, start_px: int) -> np.ndarray:
    """Exact squared distance (int64) from pixels ``(rows, cols)`` to the nearest
    obstacle (-1 where the map has none): the Euclidean distance transform of a window
    around them, read from the map, whose margin doubles until it holds every pixel's
    nearest obstacle (at distance ``d`` with ``d`` of window, or the map's edge, on every
    side)."""
    from scipy.ndimage import distance_transform_edt

    h, w = tiled.shape
    out = np.empty(rows.size, np.int64)
    todo = np.arange(rows.size)
    pad = max(1, start_px)
    while todo.size:
        r, c = rows[todo], cols[todo]
        q0, q1 = max(0, int(r.min()) - pad), min(h, int(r.max()) + pad + 1)
        p0, p1 = max(0, int(c.min()) - pad), min(w, int(c.max()) + pad + 1)
        whole = q0 == 0 and p0 == 0 and q1 == h and p1 == w
        free = ~tiled.occupied(q0, q1, p0, p1)
        if free.all():  # no obstacle in the window: look farther
            if whole:  # none in the map
                out[todo] = -1
                return out
            pad *= 2
            continue
        dist = distance_transform_edt(free)[r - q0, c - p0]
        del free
        d2 = np.rint(dist * dist).astype(np.int64)
        inf = np.iinfo(np.int64).max
        margin = np.minimum.reduce(
            [
                np.where(q0 > 0, r - q0, inf),
                np.where(q1 < h, q1 - 1 - r, inf),
                np.where(p0 > 0, c - p0, inf),
                np.where(p1 < w, p1 - 1 - c, inf),
            ]
        )
        settled = whole | (d2 <= margin.astype(np.float64) ** 2)
        out[todo[settled]] = d2[settled]
        todo = todo[~settled]
        pad *= 2
    return out


def _graph(tiled: TiledMap, row_start, cols, clearance, config: PipelineConfig, out_dir):
    """The graph store (no pruning) or the pruned networkx graph, with the attributes
    :func:`topojax.build_graph` gives them."""
    from ..graph import GraphStore, pixels_graph_store, prune_graph
    from ..graph.sparse import row_skeleton_graph_store, write_path_files
    from ..graph.store import check_networkx_fits
    from ..io.store import STORE_FILE, write_store

    if out_dir is not None:  # a build that stops leaves no complete-looking store there
        (out_dir / STORE_FILE).unlink(missing_ok=True)
    if config.graph.merge_junction_clusters:  # merging needs the whole pixel graph
        check_fits_memory(
            MERGE_BYTES_PER_SKELETON_PX * cols.size,
            f"build_graph_tiled: merging junction clusters (config.graph."
            f"merge_junction_clusters) builds the whole pixel graph of {cols.size:,} skeleton "
            f"pixels ({MERGE_BYTES_PER_SKELETON_PX} bytes a pixel or more), which takes at least",
            "; without merging, the graph is built a block of rows at a time",
        )
        rows = np.repeat(np.arange(row_start.size - 1), np.diff(row_start))
        store = pixels_graph_store(
            tiled.shape,
            rows * tiled.shape[1] + cols,
            clearance_px=clearance,
            resolution_m=tiled.resolution_m,
            pixel_to_world=tiled.pixel_to_world,
            merge_junction_clusters=True,
        )
        if out_dir is not None:  # built in memory; the folder holds its arrays all the same
            files = write_path_files(out_dir, store.path_pixels, store.path_world)
            store = replace(store, **files)
    else:
        store = row_skeleton_graph_store(
            tiled.shape,
            row_start,
            cols,
            clearance_px=clearance,
            resolution_m=tiled.resolution_m,
            pixel_to_world=tiled.pixel_to_world,
            out_dir=out_dir,
        )
    attrs = {"origin": tuple(float(v) for v in tiled.origin), "thinning": config.skeleton.thinning}
    if tiled.source is not None:
        attrs["source"] = str(tiled.source)
    if not config.graph.prunes:
        store.attrs.update(attrs)
        if out_dir is not None:  # its paths are there already: the rest of the store
            write_store(store, out_dir, written=("path_pixels", "path_world"))
        return store, None
    check_networkx_fits(  # pruning works on networkx: checked before any of it is built
        store,
        "build_graph_tiled: to prune (config.graph's min_clearance_m, min_spur_m, "
        "min_component_m),",
        "; without pruning, the graph is kept as a graph store of arrays (out_dir= writes "
        "it to disk)",
    )
    graph = prune_graph(
        store.to_networkx(),
        min_clearance_m=config.graph.min_clearance_m,
        min_spur_m=config.graph.min_spur_m,
        min_component_m=config.graph.min_component_m,
    )
    graph.graph.update(attrs)
    if out_dir is not None:  # the folder holds the graph of the result: the pruned one
        write_store(GraphStore.from_networkx(graph), out_dir)
    return None, graph
