"""Full-map pipeline: occupancy map -> distance map -> ridges -> skeleton -> graph.

The JAX stages run as two kernels per tile.  The column pass of the windowed distance
(:func:`topojax.distance.column_distance_tile`) runs on every tile's own columns; its small
result is assembled into one map, so that the second kernel (:func:`forward_tile`: row
pass, Gaussian, border reflection, Laplacian, threshold) can read each tile's halo columns
from its neighbours instead of recomputing them.  Tiles go to the compiled kernels in
chunks of a fixed size (``PipelineConfig.tiles_per_call``), so one compilation of each
serves every map size; the CPU stages (thinning, T removal, graph) then run on the whole
assembled ridge map.
"""

from __future__ import annotations

import itertools
import numbers
import os
import threading
import time
from collections import Counter, deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cached_property, lru_cache, partial

import jax
import jax.numpy as jnp
import networkx as nx
import numpy as np
from jax import lax

from .config import DistanceConfig, PipelineConfig, RidgeConfig
from .distance import (
    FAR_SQ,
    column_distance_tile,
    column_dtype,
    gaussian_from_sq_distance,
    row_sq_distance_tile,
)
from .filters import HALO_PX, laplacian_valid, reflect_101_halo, ridge_from_laplacian
from .tiling import TileGrid

__all__ = [
    "TopologyResult",
    "DenseFields",
    "build_graph",
    "dense_fields",
    "dense_fields_many",
    "distance_map",
    "ridge_map",
    "forward_tile",
    "graph_from_ridges",
    "trace_counts",
]

_TRACES: Counter[str] = Counter()


def trace_counts() -> dict[str, int]:
    """How many times each jitted kernel has been traced (compiled) in this process."""
    return dict(_TRACES)


def forward_tile(
    column: jax.Array,
    origin: jax.Array,
    map_shape: jax.Array,
    sigma_px: jax.Array,
    scale: jax.Array,
    threshold: jax.Array,
    *,
    tile_px: int,
    half_width: int,
    ksize: int,
):
    """All JAX stages after the column pass, for one tile.

    Parameters
    ----------
    column : uint8 or uint16 array, shape (T + 4, T + 4 + 2 R)
        Column pass (:func:`topojax.distance.column_distance_tile`) around the tile
        (``T = tile_px``, ``R = half_width``; the 2-pixel border on each side is the
        Laplacian's halo, the ``R`` extra columns the window's).  Outside the map: the
        dtype's maximum ("no obstacle").
    origin : int32 (2,)
        Map (row, col) of the tile's first core pixel.
    map_shape : int32 (2,)
        Map (rows, cols).
    sigma_px, scale, threshold : float32 scalars
        See :class:`~topojax.config.DistanceConfig` and :class:`~topojax.config.RidgeConfig`.
    tile_px, half_width, ksize : int
        Static, shape-setting.

    Returns
    -------
    All four are exact at the tile's pixels inside the map; pixels beyond the map edge
    (in the last row and column of tiles) hold unspecified values.

    sq_distance : int32 (T, T)
        Windowed squared distance to the nearest obstacle, px^2 (``FAR_SQ`` if none).
    distance : float32 (T, T)
        Distance map ``H`` in [0, 1].
    lap_abs : uint8 (T, T)
        Rounded, saturated absolute Laplacian of ``scale * H``.
    ridge : bool (T, T)
        ``lap_abs > threshold``.
    """
    # Only pixels inside the map are needed: the Laplacian's halo beyond the map edge is
    # replaced by reflected values, and the core beyond it is dropped.
    out = tile_px + 2 * HALO_PX
    first = origin - HALO_PX  # map (row, col) of the output's first pixel
    lo = jnp.maximum(-first, 0)
    hi = jnp.minimum(map_shape - first, out)
    d2 = row_sq_distance_tile(
        column, half_width=half_width, needed=jnp.stack([lo[0], hi[0], lo[1], hi[1]])
    )
    h = gaussian_from_sq_distance(d2, sigma_px)
    lap = laplacian_valid(reflect_101_halo(h, origin, map_shape, halo=HALO_PX), ksize=ksize)
    lap_abs, ridge = ridge_from_laplacian(lap, scale=scale, threshold=threshold)
    core = slice(HALO_PX, HALO_PX + tile_px)
    return d2[core, core], h[core, core], lap_abs, ridge


@partial(jax.jit, static_argnames=("half_width",))
def _column_tiles(strips, *, half_width):
    _TRACES["column_tiles"] += 1
    # lax.map: measured faster than vmap here (the scans stay narrow); same results.
    return lax.map(partial(column_distance_tile, half_width=half_width), strips)


@partial(jax.jit, static_argnames=("tile_px", "half_width", "ksize"))
def _forward_tiles(
    columns, origins, map_shapes, sigma_px, scale, threshold, *, tile_px, half_width, ksize
):
    _TRACES["forward_tiles"] += 1
    # lax.map, not vmap: each tile (and each band of rows inside it) runs its own exact
    # number of distance offsets; under vmap every tile would run the slowest one's count.
    fn = partial(forward_tile, tile_px=tile_px, half_width=half_width, ksize=ksize)
    return lax.map(
        lambda args: fn(args[0], args[1], args[2], sigma_px, scale, threshold),
        (columns, origins, map_shapes),
    )


@lru_cache(maxsize=16)
def _kernel_scalars(sigma_px: float, scale: float, threshold: float):
    """The kernel's float settings as device scalars, made once per setting (creating
    them costs a device transfer each)."""
    return jnp.float32(sigma_px), jnp.float32(scale), jnp.float32(threshold)


#: Kernel calls each dispatch thread keeps launched ahead of the one it collects.  With 0
#: (collect each call before launching the next) the kernels wait for the host's copies
#: and the pipeline took 10-30 % longer; 2 to 8 measured alike; the bound keeps the
#: memory of a large batch small.
_IN_FLIGHT = 2

_POOLS: dict[int, ThreadPoolExecutor] = {}


def _dispatch_threads(threads: int | None, n_chunks: int) -> int:
    if threads is None:
        threads = os.cpu_count() or 1
    if not isinstance(threads, int) or isinstance(threads, bool) or threads < 1:
        raise ValueError(f"threads must be a positive int or None, got {threads!r}")
    return max(1, min(threads, n_chunks))


def _executor(n: int) -> ThreadPoolExecutor:
    pool = _POOLS.get(n)
    if pool is None:
        pool = _POOLS[n] = ThreadPoolExecutor(max_workers=n, thread_name_prefix="topojax")
    return pool


#: Bytes of scratch buffers (padded maps, the column pass) each thread keeps for its next
#: calls.  Fresh ones cost their page faults and their unmapping at every call: 3-10 %
#: of dense_fields on the paper maps.
_SCRATCH_BYTES = 64 << 20
_SCRATCH_POOL = threading.local()


class _Scratch:
    """Scratch arrays of one call, taken from (and given back to) this thread's pool."""

    def __init__(self) -> None:
        pool = getattr(_SCRATCH_POOL, "arrays", None)
        if pool is None:
            pool = _SCRATCH_POOL.arrays = []
        self._pool: list[np.ndarray] = pool
        self._taken: list[np.ndarray] = []

    def take(self, shape: tuple[int, ...], dtype) -> np.ndarray:
        """An uninitialised array, unused by anything else until :meth:`release`."""
        dtype = np.dtype(dtype)
        for i, a in enumerate(self._pool):
            if a.shape == tuple(shape) and a.dtype == dtype:
                self._taken.append(self._pool.pop(i))
                return self._taken[-1]
        self._taken.append(np.empty(shape, dtype))
        return self._taken[-1]

    def release(self) -> None:
        """Give the arrays back (most recent last), keeping at most _SCRATCH_BYTES.
        Not called when the call fails: a dispatch thread may still be using them."""
        self._pool.extend(self._taken)
        self._taken = []
        total = sum(a.nbytes for a in self._pool)
        while self._pool and total > _SCRATCH_BYTES:
            total -= self._pool.pop(0).nbytes


@dataclass(frozen=True)
class DenseFields:
    """Per-pixel outputs of the JAX stages for a whole map (all ``(H, W)``, ``[row, col]``).

    Attributes
    ----------
    sq_distance_px : int32
        Windowed squared distance to the nearest obstacle in px^2 (``FAR_SQ`` if none in
        the window).
    distance : float32
        Gaussian distance map ``H`` in [0, 1].
    lap_abs : uint8
        ``convertScaleAbs(Laplacian(scale * H))``.
    ridges : bool
        ``lap_abs > threshold``.
    """

    sq_distance_px: np.ndarray
    distance: np.ndarray
    lap_abs: np.ndarray
    ridges: np.ndarray


def _as_obstacles(obstacles) -> np.ndarray:
    arr = np.asarray(obstacles)
    if arr.ndim != 2:
        raise ValueError(f"obstacles must be a 2-D (rows, cols) mask, got shape {arr.shape}")
    if arr.dtype != bool:
        if not np.issubdtype(arr.dtype, np.number):
            raise TypeError(f"obstacles must be a boolean mask, got dtype {arr.dtype}")
        nonzero = arr != 0
        other = nonzero & (arr != 1)
        if other.any():  # NaN is neither 0 nor 1: only then is it looked for
            if np.issubdtype(arr.dtype, np.floating) and np.isnan(arr).any():
                raise ValueError(f"obstacles contains {int(np.isnan(arr).sum())} NaN values")
            # e.g. an image (0 = black = wall) or occupancy probabilities: reading them as
            # "nonzero = obstacle" would silently give the wrong map
            raise ValueError(
                "obstacles: expected a boolean mask (or 0 / 1 values), received "
                f"{arr.dtype} values in [{arr.min()}, {arr.max()}] with "
                f"{int(other.sum())} pixels neither 0 nor 1; convert images and "
                "occupancy grids with OccupancyMap.from_array(...) and pass it (or its "
                ".occupied)"
            )
        arr = nonzero
    if min(arr.shape) < 2:
        raise ValueError(f"obstacles must be at least 2 x 2 pixels, got shape {arr.shape}")
    return arr


def dense_fields(
    obstacles,
    *,
    distance: DistanceConfig | None = None,
    ridge: RidgeConfig | None = None,
    tile_px: int = 256,
    tiles_per_call: int = 1,
    threads: int | None = None,
) -> DenseFields:
    """Run the JAX stages (distance map, Laplacian, ridges) over a whole map, tile by tile.

    Parameters
    ----------
    obstacles : bool array, shape (H, W)
        Obstacle mask, ``obstacles[row, col]`` (numeric arrays must hold only 0 and 1).
    distance, ridge : configs, optional
    tile_px : int
        Tile side (shape-setting; every map size uses the same compiled kernel).
    tiles_per_call : int
        Tiles per kernel call (fixed bucket; the last call is padded with empty tiles).
    threads : int, optional
        Host threads dispatching kernel calls concurrently, each keeping a few calls in
        flight so that its host work (stacking patches, copying outputs) overlaps the
        kernels.  Default: the number of CPUs.  Results do not depend on it.

    Returns
    -------
    DenseFields

    Notes
    -----
    The calling thread keeps the call's scratch arrays (the padded maps and the column
    pass, about 4 bytes per pixel; at most 64 MB in all) for its next calls.
    """
    return dense_fields_many(
        [obstacles],
        distance=distance,
        ridge=ridge,
        tile_px=tile_px,
        tiles_per_call=tiles_per_call,
        threads=threads,
    )[0]


def _obstacles_of(obstacles):
    """The obstacle mask of a mask, an OccupancyMap (its ``occupied``) or a map file."""
    if isinstance(obstacles, (str, os.PathLike)):
        from .maps import load_map

        obstacles = load_map(obstacles)
    return getattr(obstacles, "occupied", obstacles)


def _checked(value, kind: type, name: str):
    """``value``, or ``kind()`` for None, after checking its type (a TypeError naming
    ``name`` instead of an AttributeError deep inside)."""
    if value is None:
        return kind()
    if not isinstance(value, kind):
        raise TypeError(f"{name}: expected a {kind.__name__}, got {type(value).__name__} {value!r}")
    return value


def dense_fields_many(
    obstacle_maps,
    *,
    distance: DistanceConfig | None = None,
    ridge: RidgeConfig | None = None,
    tile_px: int = 256,
    tiles_per_call: int = 1,
    threads: int | None = None,
) -> list[DenseFields]:
    """:func:`dense_fields` for many maps at once, their tiles sharing kernel calls.

    The tiles of all maps are concatenated and cut into chunks of ``tiles_per_call``; each
    tile carries its own map's origin and shape, so a chunk may mix maps of different
    sizes.  One compiled kernel serves the whole batch, and the results are identical to
    processing each map alone.

    Parameters
    ----------
    obstacle_maps : sequence of bool arrays, each (H_i, W_i)
    distance, ridge, tile_px, tiles_per_call, threads : see :func:`dense_fields`

    Returns
    -------
    list of DenseFields, one per map, in input order.
    """
    maps = [_as_obstacles(o) for o in obstacle_maps]
    distance = _checked(distance, DistanceConfig, "distance")
    ridge = _checked(ridge, RidgeConfig, "ridge")
    for name, value in (("tile_px", tile_px), ("tiles_per_call", tiles_per_call)):
        if not isinstance(value, numbers.Integral) or isinstance(value, bool) or value < 1:
            raise ValueError(f"{name}: expected a positive int, got {value!r}")
    tile_px, tiles_per_call = int(tile_px), int(tiles_per_call)
    if not maps:
        return []
    r = distance.half_width_px
    col_dtype = column_dtype(r)
    none = np.iinfo(col_dtype).max
    grids = [TileGrid(m.shape, tile_px) for m in maps]
    # (map index, tile row, tile col, map row, map col) of every tile, in order
    owners = np.concatenate([np.full(g.n_tiles, i) for i, g in enumerate(grids)])
    local = np.concatenate([np.arange(g.n_tiles) for g in grids])
    cells = [divmod(int(k), grids[i].grid_shape[1]) for i, k in zip(owners, local, strict=True)]
    all_origins = np.concatenate([g.origins() for g in grids])
    shapes = np.asarray([m.shape for m in maps], np.int32)
    scalars = _kernel_scalars(distance.sigma_px, ridge.scale, ridge.threshold)
    total = len(owners)
    starts = range(0, total, tiles_per_call)
    n_threads = _dispatch_threads(threads, len(starts))

    def dispatch(launch, finish) -> None:
        """Run ``finish(start, launch(start))`` for every chunk.  Each thread keeps up to
        :data:`_IN_FLIGHT` chunks launched ahead of the one it collects: JAX dispatches
        asynchronously, so the host work of one chunk overlaps the kernels of the next,
        and the kernels run back to back.  Threads take the next chunk when they launch
        one (tiles differ up to 4x in cost; fixed shares left one thread idle up to a
        third of the time on intel)."""
        taken = itertools.count()
        lock = threading.Lock()

        def take() -> int:
            with lock:
                return next(taken)

        def share(_: int) -> None:
            pending: deque = deque()
            while (i := take()) < len(starts):
                pending.append((starts[i], launch(starts[i])))
                if len(pending) > _IN_FLIGHT:
                    finish(*pending.popleft())
            while pending:
                finish(*pending.popleft())

        if n_threads > 1:
            list(_executor(n_threads).map(share, range(n_threads)))
        else:
            share(0)

    def stack(views, sel, fill):
        """The patches of tiles ``sel``, padded to a full chunk with ``fill``."""
        patches = np.stack([views[owners[j]][cells[j]] for j in sel])
        short = tiles_per_call - len(sel)
        if short:
            pad = np.full((short,) + patches.shape[1:], fill, patches.dtype)
            patches = np.concatenate([patches, pad])
        return patches

    def core_box(j):
        r0, c0 = all_origins[j]
        h, w = maps[owners[j]].shape
        return r0, c0, min(tile_px, h - r0), min(tile_px, w - c0)

    scratch = _Scratch()

    # Kernel 1, the column pass, on each tile's own columns with R halo rows.  Each
    # tile's core goes straight into its map's column array (tiles never overlap, so the
    # dispatch threads write disjoint regions).
    strip_views = [
        g.patch_view(m, (r, 0), fill=False, out=scratch.take(g.padded_shape((r, 0)), bool))
        for g, m in zip(grids, maps, strict=True)
    ]
    columns = [scratch.take(m.shape, col_dtype) for m in maps]

    def chunk(start: int) -> np.ndarray:
        return np.arange(start, min(total, start + tiles_per_call))

    def launch_columns(start: int):
        return _column_tiles(stack(strip_views, chunk(start), False), half_width=r)

    def finish_columns(start: int, handle) -> None:
        out = np.asarray(handle)
        for n, j in enumerate(chunk(start)):
            r0, c0, h, w = core_box(j)
            columns[owners[j]][r0 : r0 + h, c0 : c0 + w] = out[n, :h, :w]

    dispatch(launch_columns, finish_columns)

    # Kernel 2, everything else, on the column pass with the row halo of the Laplacian
    # and the column halo of the Laplacian and the window.
    column_halo = (HALO_PX, HALO_PX + r)
    column_views = [
        g.patch_view(
            c, column_halo, fill=none, out=scratch.take(g.padded_shape(column_halo), col_dtype)
        )
        for g, c in zip(grids, columns, strict=True)
    ]
    fields = [
        DenseFields(
            np.empty(m.shape, np.int32),
            np.empty(m.shape, np.float32),
            np.empty(m.shape, np.uint8),
            np.empty(m.shape, bool),
        )
        for m in maps
    ]

    def launch_forward(start: int):
        sel = chunk(start)
        org = all_origins[sel]
        shp = shapes[owners[sel]]
        short = tiles_per_call - len(sel)
        if short:
            org = np.concatenate([org, np.zeros((short, 2), np.int32)])
            shp = np.concatenate([shp, np.full((short, 2), 2, np.int32)])
        return _forward_tiles(
            stack(column_views, sel, none),
            org,
            shp,
            *scalars,
            tile_px=tile_px,
            half_width=r,
            ksize=ridge.ksize,
        )

    def finish_forward(start: int, handle) -> None:
        tiles = [np.asarray(a) for a in handle]
        for n, j in enumerate(chunk(start)):
            target = fields[owners[j]]
            r0, c0, h, w = core_box(j)
            for dest, src in zip(
                (target.sq_distance_px, target.distance, target.lap_abs, target.ridges),
                tiles,
                strict=True,
            ):
                dest[r0 : r0 + h, c0 : c0 + w] = src[n, :h, :w]

    dispatch(launch_forward, finish_forward)
    scratch.release()  # only after every kernel call has been collected
    return fields


def distance_map(
    obstacles, *, config: DistanceConfig | None = None, tile_px: int = 256
) -> np.ndarray:
    """Gaussian max-splat distance map of an obstacle mask.

    Parameters
    ----------
    obstacles : bool array, shape (H, W)
        ``True`` where a pixel is an obstacle (``obstacles[row, col]``), or an
        :class:`~topojax.maps.OccupancyMap` (its ``occupied`` mask), or a map file (read
        with :func:`topojax.load_map`).
    config : DistanceConfig, optional
    tile_px : int

    Returns
    -------
    float32 array, shape (H, W), values in [0, 1]: ``max_p exp(-|x - p|^2 / (2 sigma^2))``
    over obstacles ``p`` in the square window.
    """
    obstacles = _obstacles_of(obstacles)
    config = _checked(config, DistanceConfig, "config")
    return dense_fields(obstacles, distance=config, tile_px=tile_px).distance


def ridge_map(
    obstacles,
    *,
    distance: DistanceConfig | None = None,
    ridge: RidgeConfig | None = None,
    tile_px: int = 256,
) -> np.ndarray:
    """Binary ridge map (paper Fig. 1d): ``round(|Laplacian(scale * H)|) > threshold``.

    Parameters
    ----------
    obstacles : bool array (H, W), OccupancyMap or map file
        As for :func:`distance_map`.
    distance : DistanceConfig, optional
    ridge : RidgeConfig, optional
    tile_px : int
        Tile side of the kernels (shape-setting).

    Returns
    -------
    bool array, shape (H, W)
    """
    obstacles = _obstacles_of(obstacles)
    return dense_fields(obstacles, distance=distance, ridge=ridge, tile_px=tile_px).ridges


@dataclass(frozen=True)
class TopologyResult:
    """Everything :func:`build_graph` produced.

    Attributes
    ----------
    map : OccupancyMap
        The input map.
    distance : float32 (H, W)
        Gaussian distance map in [0, 1].
    lap_abs : uint8 (H, W)
        Absolute Laplacian response (scaled, rounded, saturated).
    ridges : bool (H, W)
        Thresholded ridge map.
    skeleton : bool (H, W)
        Thinned ridges after T-centre removal (of the ridges in free space only with
        ``GraphConfig.free_space_only``).
    graph : networkx.MultiGraph
        The topology graph (see :func:`topojax.graph.skeleton_to_graph`); it covers the
        whole skeleton unless ``GraphConfig``'s ``min_clearance_m``, ``min_spur_m`` or
        ``min_component_m`` pruned it (:func:`topojax.prune_graph`).
    config : PipelineConfig
    timings_s : dict[str, float]
        Wall time of each stage in seconds.
    sq_distance_px : int32 (H, W)
        Windowed squared distance to the nearest obstacle in px^2 (``FAR_SQ`` where the
        window holds none); the distance map is ``exp(-sq_distance_px / (2 sigma^2))``.
    clearance_px : float32 (H, W)
        Euclidean distance to the nearest obstacle in pixels (``inf`` with no obstacle),
        on the whole map.  Computed on first access (beyond the window it needs an
        unwindowed transform); the graph's clearances do not wait for it.
    """

    map: object
    distance: np.ndarray
    lap_abs: np.ndarray
    ridges: np.ndarray
    skeleton: np.ndarray
    graph: nx.MultiGraph
    config: PipelineConfig
    timings_s: dict[str, float] = field(default_factory=dict)
    sq_distance_px: np.ndarray | None = None

    @cached_property
    def clearance_px(self) -> np.ndarray:
        if self.sq_distance_px is None:
            raise ValueError("clearance_px needs sq_distance_px, which this result lacks")
        return clearance_from_sq_distance(
            self.sq_distance_px, self.map.occupied, self.config.distance.half_width_px
        )


#: Needed pixels beyond the window that :func:`clearance_from_sq_distance` searches one
#: by one (a square crop each) before it takes the whole map's distance transform instead.
SPARSE_CLEARANCE_MAX_PX = 64


def _nearest_sq_distance(obstacles, rows, cols, upper_sq, start_px, budget_px):
    """Exact squared distance (px^2, int64) from pixels ``(rows, cols)`` to the nearest
    obstacle, searching squares around each pixel.

    ``upper_sq`` bounds each answer from above (the windowed value: the nearest obstacle
    inside the window is a real one); where it is ``FAR_SQ`` the search starts with a
    square of half-side ``start_px``.  A square of half-side ``s`` holding an obstacle at
    squared distance ``<= s^2`` holds the nearest one (every pixel outside it is farther
    than ``s``).  All first squares are searched together (their bounding box, read
    once); a pixel not settled there doubles its own square.  ``obstacles`` must hold an
    obstacle.  Returns None (gives up) once the squares read hold more than ``budget_px``
    pixels.
    """
    h, w = obstacles.shape
    rows = np.asarray(rows, np.int64)
    cols = np.asarray(cols, np.int64)
    upper = np.asarray(upper_sq, np.int64)
    far = upper >= FAR_SQ
    side = np.where(far, max(1, start_px), np.sqrt(np.where(far, 0, upper)).astype(np.int64) + 2)
    r0, r1 = max(0, int((rows - side).min())), min(h, int((rows + side).max()) + 1)
    c0, c1 = max(0, int((cols - side).min())), min(w, int((cols + side).max()) + 1)
    budget = budget_px - (r1 - r0) * (c1 - c0)
    if budget < 0:
        return None
    ys, xs = np.nonzero(obstacles[r0:r1, c0:c1])
    ys += r0
    xs += c0
    out = np.empty(rows.shape[0], np.int64)
    for i, (r, c, s) in enumerate(zip(rows.tolist(), cols.tolist(), side.tolist(), strict=True)):
        best = int(((ys - r) ** 2 + (xs - c) ** 2).min()) if ys.size else FAR_SQ
        while best > s * s:  # not settled: search a doubled square around this pixel
            s *= 2
            q0, q1 = max(0, r - s), min(h, r + s + 1)
            p0, p1 = max(0, c - s), min(w, c + s + 1)
            budget -= (q1 - q0) * (p1 - p0)
            if budget < 0:
                return None
            qy, qx = np.nonzero(obstacles[q0:q1, p0:p1])
            if qy.size:
                best = int(((qy + (q0 - r)) ** 2 + (qx + (p0 - c)) ** 2).min())
            if q0 == 0 and p0 == 0 and q1 == h and p1 == w:
                if not qy.size:
                    raise ValueError("obstacles holds no obstacle")
                break
        out[i] = best
    return out


def clearance_from_sq_distance(
    sq_distance_px: np.ndarray,
    obstacles: np.ndarray,
    half_width_px: int,
    need: np.ndarray | None = None,
) -> np.ndarray:
    """True Euclidean clearance in pixels from the windowed squared distance.

    The windowed distance equals the Euclidean distance transform wherever it is at most
    the window half-width ``R`` (an obstacle nearer than ``R`` is inside the window).
    Pixels beyond that (only in open maps) are filled in from an exact unwindowed
    transform.

    Parameters
    ----------
    sq_distance_px : int32 (H, W)
        Windowed squared distance, px^2 (``FAR_SQ`` where the window has no obstacle).
    obstacles : bool (H, W)
    half_width_px : int
        Window half-width ``R``.
    need : bool (H, W), optional
        If given, only these pixels must be exact (other pixels beyond ``R`` then keep the
        windowed value).  A few of them beyond ``R`` are searched one by one; more take
        the unwindowed transform of the whole map.  Default: every pixel is exact.

    Returns
    -------
    float32 (H, W): clearance in pixels, ``inf`` everywhere when there are no obstacles.
    Within ``R`` it is the square root of the exact integer distance; beyond ``R`` it is
    that too at a few needed pixels, otherwise OpenCV's exact transform in float32
    (which can differ by one ulp between calls).
    """
    d2 = sq_distance_px
    clearance = d2.astype(np.float32)
    np.sqrt(clearance, out=clearance)
    r2 = half_width_px * half_width_px
    if d2.size == 0 or d2.max() <= r2:
        return clearance
    if not obstacles.any():
        clearance.fill(np.inf)
        return clearance
    if need is not None:
        flat = np.flatnonzero(need)  # sparse (ridge pixels): test d2 there only
        flat = flat[d2.ravel()[flat] > r2]
        if flat.size:
            clearance.ravel()[flat] = clearance_at(d2, obstacles, half_width_px, flat)
        return clearance
    np.copyto(clearance, _unwindowed_clearance(obstacles), where=d2 > r2)
    return clearance


def clearance_at(
    sq_distance_px: np.ndarray, obstacles: np.ndarray, half_width_px: int, flat: np.ndarray
) -> np.ndarray:
    """True Euclidean clearance in pixels at some pixels only.

    Same values as :func:`clearance_from_sq_distance` at those pixels, without touching
    the rest of the map (the graph step needs the skeleton's pixels only).

    Parameters
    ----------
    sq_distance_px, obstacles, half_width_px : see :func:`clearance_from_sq_distance`
    flat : int array (n,)
        Flat (raster) indices of the pixels, ``row * W + col``.

    Returns
    -------
    float32 (n,): clearance in pixels (``inf`` where the map has no obstacle at all).
    """
    flat = np.asarray(flat, np.intp)
    d2 = sq_distance_px.ravel()[flat]
    out = np.sqrt(d2.astype(np.float32))
    far = np.flatnonzero(d2 > half_width_px * half_width_px)
    if far.size == 0:
        return out
    if not obstacles.any():
        out[far] = np.inf
        return out
    rows, cols = np.divmod(flat[far], sq_distance_px.shape[1])
    exact = None
    if far.size <= SPARSE_CLEARANCE_MAX_PX:
        # searching more than twice the map would cost more than its transform
        exact = _nearest_sq_distance(
            obstacles, rows, cols, d2[far], 2 * half_width_px, 2 * sq_distance_px.size
        )
    if exact is not None:
        out[far] = np.sqrt(exact.astype(np.float32))
    else:
        out[far] = _unwindowed_clearance(obstacles)[rows, cols]
    return out


def _unwindowed_clearance(obstacles: np.ndarray) -> np.ndarray:
    """OpenCV's exact Euclidean distance transform (float32, px) of a map with obstacles."""
    import cv2

    return cv2.distanceTransform((~obstacles).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)


def graph_from_ridges(
    ridges: np.ndarray,
    *,
    clearance_px: np.ndarray | None,
    resolution_m: float,
    origin: tuple[float, float, float],
    pixel_to_world,
    config: PipelineConfig,
    source: object = None,
    free: np.ndarray | None = None,
):
    """The CPU stages: thinning, T-centre removal, the skeleton-to-graph step and what
    ``config.graph`` keeps of the graph.

    Parameters
    ----------
    ridges : bool (H, W)
        Ridge map.
    clearance_px : float32 (H, W), callable or None
        Euclidean clearance in pixels, as ``clearance_px`` of
        :func:`topojax.graph.skeleton_to_graph` (a callable gets the skeleton's flat
        indices once the skeleton is known, so it need only be computed there).
    resolution_m : float
        Metres per pixel.
    origin : (x, y, yaw)
        Map origin, stored as a graph attribute.
    pixel_to_world : callable
        ``(rows, cols) -> (x, y)``, e.g. :meth:`OccupancyMap.pixel_to_world`.
    config : PipelineConfig
    source : optional
        Where the map came from; stored as the graph attribute ``source``.
    free : bool (H, W), optional
        Known free space (``OccupancyMap.free``); needed with
        ``config.graph.free_space_only``, which thins ``ridges & free`` only.

    Returns
    -------
    skeleton : bool (H, W)
        The thinned ridges after T removal; when ``config.graph`` prunes, the graph covers
        part of it.
    graph : networkx.MultiGraph
    timings_s : dict with ``thinning``, ``t_removal`` and ``graph`` wall times (the
        graph's includes the pruning).
    """
    from .graph import prune_graph, skeleton_to_graph
    from .skeleton import skeletonize_ridges

    if config.graph.free_space_only:
        free = np.asarray(free) if free is not None else None
        if free is None or free.shape != ridges.shape or free.dtype != bool:
            raise ValueError(
                "free: config.graph.free_space_only needs the map's known-free mask, a bool "
                f"array of shape {ridges.shape}, got "
                + ("None" if free is None else f"{free.dtype} {free.shape}")
            )
        ridges = ridges & free
    steps: dict[str, float] = {}
    skeleton = skeletonize_ridges(
        ridges,
        method=config.skeleton.thinning,
        remove_t=config.skeleton.remove_t,
        timings_s=steps,
    )
    t2 = time.perf_counter()
    graph = skeleton_to_graph(
        skeleton,
        clearance_px=clearance_px,
        resolution_m=resolution_m,
        pixel_to_world=pixel_to_world,
        merge_junction_clusters=config.graph.merge_junction_clusters,
    )
    if config.graph.prunes:
        graph = prune_graph(
            graph,
            min_clearance_m=config.graph.min_clearance_m,
            min_spur_m=config.graph.min_spur_m,
            min_component_m=config.graph.min_component_m,
        )
    graph.graph["origin"] = tuple(float(v) for v in origin)
    graph.graph["thinning"] = config.skeleton.thinning
    if source is not None:
        graph.graph["source"] = str(source)
    t3 = time.perf_counter()
    return skeleton, graph, {**steps, "graph": t3 - t2}


def travel_ridges(ridges: np.ndarray, occupied: np.ndarray) -> np.ndarray:
    """The ridges the CPU stages thin: all of them, or none on a map whose every pixel is
    occupied (no space to travel: an empty graph, as for a map without obstacles; a tiny
    such map would otherwise keep ridges from the Laplacian's border rule)."""
    return np.zeros_like(ridges) if occupied.all() else ridges


def graph_of_map(occupancy, ridges: np.ndarray, sq_distance_px: np.ndarray, config):
    """:func:`graph_from_ridges` for a map's ridges, with the clearance read from its
    windowed squared distances (exact, and only at the skeleton's pixels: the only ones
    the graph reads; a result's whole-map clearance is computed on first access)."""

    def skeleton_clearance(flat: np.ndarray) -> np.ndarray:
        return clearance_at(sq_distance_px, occupancy.occupied, config.distance.half_width_px, flat)

    return graph_from_ridges(
        travel_ridges(ridges, occupancy.occupied),
        clearance_px=skeleton_clearance,
        resolution_m=occupancy.resolution_m,
        origin=occupancy.origin,
        pixel_to_world=occupancy.pixel_to_world,
        config=config,
        source=occupancy.source,
        free=occupancy.free,
    )


def build_graph(occupancy, *, config: PipelineConfig | None = None) -> TopologyResult:
    """Build the topology graph of a finished occupancy map (paper §II).

    Parameters
    ----------
    occupancy : OccupancyMap, array or path
        The map.  Arrays are converted with :meth:`OccupancyMap.from_array` (bool: True =
        occupied; uint8 image; int8 occupancy grid); a path (``str`` or
        :class:`os.PathLike`) is read with :func:`topojax.load_map` and its defaults.
    config : PipelineConfig, optional
        All stage settings; default reproduces the paper with Guo–Hall thinning.

    Returns
    -------
    TopologyResult
        ``.graph`` is a :class:`networkx.MultiGraph`: junctions and dead ends as vertices,
        corridors as edges carrying their pixel paths and world polylines.  A map with no
        obstacle, or with nothing but obstacles, gives an empty skeleton and graph.  A map
        of obstacles and unknown space (no free pixel) keeps the paper's graph, which runs
        through unknown space; ``GraphConfig(free_space_only=True)`` keeps free space only.
    """
    from .maps import OccupancyMap, load_map

    config = config or PipelineConfig()
    if not isinstance(config, PipelineConfig):
        raise TypeError(f"config must be a PipelineConfig, got {type(config).__name__}")
    if isinstance(occupancy, (str, os.PathLike)):
        occupancy = load_map(occupancy)
    elif occupancy is None or isinstance(occupancy, (bytes, bytearray)):
        raise TypeError(
            "occupancy: expected an OccupancyMap, a 2-D array or a map file path (str or "
            f"Path), got {type(occupancy).__name__}"
        )
    elif not isinstance(occupancy, OccupancyMap):
        occupancy = OccupancyMap.from_array(occupancy)
    timings: dict[str, float] = {}
    obstacles = occupancy.occupied

    t0 = time.perf_counter()
    if obstacles.any():
        fields = dense_fields(
            obstacles,
            distance=config.distance,
            ridge=config.ridge,
            tile_px=config.tile_px,
            tiles_per_call=config.tiles_per_call,
        )
    else:  # nothing to measure distances from: H = 0 everywhere, no ridges
        shape = obstacles.shape
        fields = DenseFields(
            np.full(shape, FAR_SQ, np.int32),
            np.zeros(shape, np.float32),
            np.zeros(shape, np.uint8),
            np.zeros(shape, bool),
        )
    t1 = time.perf_counter()
    timings["distance_ridges"] = t1 - t0

    skeleton, graph, cpu_timings = graph_of_map(
        occupancy, fields.ridges, fields.sq_distance_px, config
    )
    timings.update(cpu_timings)
    timings["total"] = time.perf_counter() - t0
    result = TopologyResult(
        map=occupancy,
        distance=fields.distance,
        lap_abs=fields.lap_abs,
        ridges=fields.ridges,
        skeleton=skeleton,
        graph=graph,
        config=config,
        timings_s=timings,
        sq_distance_px=fields.sq_distance_px,
    )
    return result
