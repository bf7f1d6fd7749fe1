"""The JAX stages of the full-map pipeline over whole maps: distance map, Laplacian, ridges.

Two kernels run per tile: the column pass of the windowed distance
(:func:`~topojax.fields.distance.column_distance_tile`) on every tile's own columns, whose
small result is assembled into one map, then :func:`forward_tile` (row pass, Gaussian,
border reflection, Laplacian, threshold), which reads each tile's halo columns from its
neighbours.  Tiles go to the compiled kernels in chunks of a fixed size, so one
compilation of each serves every map size (see ``docs/design-fields.md``).
"""

from __future__ import annotations

import itertools
import os
import threading
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import lru_cache, partial

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._cpus import usable_cpus
from .._jit import TRACES, trace_counts
from .._validate import (
    instance_or_default,
    kernel_tile_px,
    kernel_tiles_per_call,
    names_subset,
    positive_int,
    real_values,
    unmasked,
)
from ..config import DistanceConfig, RidgeConfig
from .distance import (
    column_distance_tile,
    column_dtype,
    gaussian_from_sq_distance,
    row_sq_distance_tile,
)
from .filters import HALO_PX, laplacian_valid, reflect_101_halo, ridge_from_laplacian
from .tile_grid import TileGrid

__all__ = [
    "FIELD_NAMES",
    "DenseFields",
    "dense_fields",
    "dense_fields_many",
    "distance_map",
    "forward_tile",
    "ridge_fields",
    "ridge_fields_many",
    "ridge_map",
    "trace_counts",
]


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
        Column pass (:func:`topojax.fields.distance.column_distance_tile`) around the tile
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
    TRACES["column_tiles"] += 1
    # lax.map rather than vmap: the scans stay narrow; same results.
    return lax.map(partial(column_distance_tile, half_width=half_width), strips)


@partial(jax.jit, static_argnames=("tile_px", "half_width", "ksize"))
def _forward_tiles(
    columns, origins, map_shapes, sigma_px, scale, threshold, *, tile_px, half_width, ksize
):
    TRACES["forward_tiles"] += 1
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


#: Kernel calls each dispatch thread keeps launched ahead of the one it collects: with 0
#: (collect each call before launching the next) the kernels would wait for the host's
#: copies; the bound keeps the memory of a large batch small.
_IN_FLIGHT = 2

_POOLS: dict[int, ThreadPoolExecutor] = {}


def _dispatch_threads(threads: int | None, n_chunks: int) -> int:
    threads = usable_cpus() if threads is None else positive_int("threads", threads)
    return max(1, min(threads, n_chunks))


def _executor(n: int) -> ThreadPoolExecutor:
    pool = _POOLS.get(n)
    if pool is None:
        pool = _POOLS[n] = ThreadPoolExecutor(max_workers=n, thread_name_prefix="topojax")
    return pool


#: Bytes of scratch buffers (padded maps, the column pass) each thread keeps for its next
#: calls: fresh ones would cost their page faults and their unmapping at every call.
_SCRATCH_BYTES = 64 << 20
_SCRATCH_POOL = threading.local()


class _Scratch:
    """Scratch arrays of one call, carved out of byte buffers taken from (and given back
    to) this thread's pool.  A buffer given back during the call serves the call's next
    request that fits in it, so arrays used one after another share their memory."""

    def __init__(self) -> None:
        pool = getattr(_SCRATCH_POOL, "arrays", None)
        if pool is None:
            pool = _SCRATCH_POOL.arrays = []
        self._pool: list[np.ndarray] = pool  # uint8 (n,) buffers, oldest first
        self._taken: dict[int, np.ndarray] = {}  # id of the array handed out -> buffer

    def take(self, shape: tuple[int, ...], dtype, min_bytes: int = 0) -> np.ndarray:
        """An uninitialised array, unused by anything else until it is given back, in a
        buffer of at least ``min_bytes`` (to serve a larger array after it)."""
        dtype = np.dtype(dtype)
        need = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        size = max(need, int(min_bytes))
        fits = [i for i, b in enumerate(self._pool) if b.size >= size]
        if fits:  # the smallest buffer that holds it
            buf = self._pool.pop(min(fits, key=lambda i: self._pool[i].size))
        else:
            buf = np.empty(size, np.uint8)
        arr = buf[:need].view(dtype).reshape(shape)
        self._taken[id(arr)] = buf
        return arr

    def give_back(self, arr: np.ndarray) -> None:
        """Return the buffer of ``arr`` (from :meth:`take`) early; ``arr`` must not be
        used afterwards."""
        self._pool.append(self._taken.pop(id(arr)))

    def release(self) -> None:
        """Give every buffer back (most recent last), keeping at most _SCRATCH_BYTES.
        Not called when the call fails: a dispatch thread may still be using them."""
        self._pool.extend(self._taken.values())
        self._taken = {}
        total = sum(b.size for b in self._pool)
        while self._pool and total > _SCRATCH_BYTES:
            total -= self._pool.pop(0).size


@dataclass(frozen=True)
class DenseFields:
    """Per-pixel outputs of the JAX stages for a whole map (all ``(H, W)``, ``[row, col]``;
    None for a field not asked for, see ``outputs`` of :func:`dense_fields`).

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

    sq_distance_px: np.ndarray | None
    distance: np.ndarray | None
    lap_abs: np.ndarray | None
    ridges: np.ndarray | None

    def __repr__(self) -> str:
        held = {n: getattr(self, n) for n in FIELD_NAMES if getattr(self, n) is not None}
        shape = next(iter(held.values())).shape if held else None
        text = ", ".join(f"{n} {a.dtype}" for n, a in held.items())
        if shape is not None:
            text = f"{' x '.join(map(str, shape))} px (rows x cols): {text}"
        missing = [n for n in FIELD_NAMES if n not in held]
        if missing:
            text += f"{'; ' if held else ''}not computed: {', '.join(missing)}"
        return f"DenseFields({text})"


#: The fields of :class:`DenseFields`, in the order the kernel returns them.
FIELD_NAMES = ("sq_distance_px", "distance", "lap_abs", "ridges")


def _as_obstacles(obstacles) -> np.ndarray:
    given = np.asarray(unmasked("obstacles", obstacles))  # a masked cell: neither
    arr = real_values(given)  # bfloat16 as float32, int4 as int8
    if arr.dtype.kind not in "biuf":
        raise TypeError(
            f"obstacles: expected a boolean mask, received dtype {arr.dtype} "
            f"(type {type(obstacles).__name__})"
        )
    if arr.ndim != 2:
        raise ValueError(f"obstacles: expected a 2-D (rows, cols) mask, received shape {arr.shape}")
    if arr.dtype != bool:
        nonzero = arr != 0
        other = nonzero & (arr != 1)
        if other.any():  # NaN is neither 0 nor 1: only then is it looked for
            if np.issubdtype(arr.dtype, np.floating) and np.isnan(arr).any():
                raise ValueError(f"obstacles contains {int(np.isnan(arr).sum())} NaN values")
            # e.g. an image (0 = black = wall) or occupancy probabilities: reading them as
            # "nonzero = obstacle" would silently give the wrong map
            raise ValueError(
                "obstacles: expected a boolean mask (or 0 / 1 values), received "
                f"{given.dtype} values in [{arr.min()}, {arr.max()}] with "
                f"{int(other.sum())} pixels neither 0 nor 1; convert images and "
                "occupancy grids with OccupancyMap.from_array(...) and pass it (or its "
                ".occupied)"
            )
        arr = nonzero
    if min(arr.shape) < 2:
        raise ValueError(f"obstacles: expected at least 2 x 2 pixels, received shape {arr.shape}")
    return arr


def dense_fields(
    obstacles,
    *,
    distance: DistanceConfig | None = None,
    ridge: RidgeConfig | None = None,
    tile_px: int = 256,
    tiles_per_call: int = 1,
    threads: int | None = None,
    outputs=FIELD_NAMES,
) -> DenseFields:
    """Run the JAX stages (distance map, Laplacian, ridges) over a whole map, tile by tile.

    Parameters
    ----------
    obstacles : bool array, shape (H, W)
        Obstacle mask, ``obstacles[row, col]`` (numeric arrays must hold only 0 and 1).
    distance, ridge : configs, optional
    tile_px : int
        Tile side, 8 to 4096 (shape-setting; every map size uses the same compiled
        kernel).
    tiles_per_call : int
        Tiles per kernel call (fixed bucket; the last call is padded with empty tiles), at
        most ``2**28 // tile_px**2``.
    threads : int, optional
        Host threads dispatching kernel calls concurrently, each keeping a few calls in
        flight so that its host work (stacking patches, copying outputs) overlaps the
        kernels.  Default: the number of CPUs.  Results do not depend on it.
    outputs : iterable of str, default all of :data:`FIELD_NAMES`
        The fields to assemble (``"sq_distance_px"``, ``"distance"``, ``"lap_abs"``,
        ``"ridges"``); the others are None.  The kernels compute all four per tile
        either way, so the fields do not depend on it: only the memory does (4, 4, 1
        and 1 bytes per pixel).

    Returns
    -------
    DenseFields

    Notes
    -----
    Besides the outputs, the call needs the padded map and the column pass (about 2 to 3
    bytes per pixel, one after the other sharing memory); the calling thread keeps them
    (at most 64 MB in all) for its next calls.
    """
    return dense_fields_many(
        [obstacles],
        distance=distance,
        ridge=ridge,
        tile_px=tile_px,
        tiles_per_call=tiles_per_call,
        threads=threads,
        outputs=outputs,
    )[0]


def _obstacles_of(obstacles):
    """The obstacle mask of a mask, an OccupancyMap (its ``occupied``) or a map file."""
    if isinstance(obstacles, (str, os.PathLike)):
        from ..maps import load_map

        obstacles = load_map(obstacles)
    return getattr(obstacles, "occupied", obstacles)


def dense_fields_many(
    obstacle_maps,
    *,
    distance: DistanceConfig | None = None,
    ridge: RidgeConfig | None = None,
    tile_px: int = 256,
    tiles_per_call: int = 1,
    threads: int | None = None,
    outputs=FIELD_NAMES,
) -> list[DenseFields]:
    """:func:`dense_fields` for many maps at once, their tiles sharing kernel calls.

    The tiles of all maps are concatenated and cut into chunks of ``tiles_per_call``; each
    tile carries its own map's origin and shape, so a chunk may mix maps of different
    sizes.  One compiled kernel serves the whole batch, and the results are identical to
    processing each map alone.

    Parameters
    ----------
    obstacle_maps : sequence of bool arrays, each (H_i, W_i)
    distance, ridge, tile_px, tiles_per_call, threads, outputs : see :func:`dense_fields`

    Returns
    -------
    list of DenseFields, one per map, in input order.
    """
    outputs = names_subset("outputs", outputs, FIELD_NAMES)
    fields, _ = _run_kernels(
        obstacle_maps, distance, ridge, tile_px, tiles_per_call, threads, outputs, False
    )
    return fields


def ridge_fields(
    obstacles,
    *,
    distance: DistanceConfig | None = None,
    ridge: RidgeConfig | None = None,
    tile_px: int = 256,
    tiles_per_call: int = 1,
    threads: int | None = None,
    outputs=(),
) -> tuple[DenseFields, np.ndarray]:
    """The ridge map, the windowed squared distance at its pixels only, and other dense
    fields if asked for.

    What the CPU stages need of the JAX stages: 1 byte per pixel plus 4 per ridge pixel,
    where all of :func:`dense_fields` takes 10 bytes per pixel.

    Parameters
    ----------
    obstacles, distance, ridge, tile_px, tiles_per_call, threads
        As for :func:`dense_fields`.
    outputs : iterable of str, default none
        Dense fields to assemble besides the ridges, as for :func:`dense_fields`.

    Returns
    -------
    fields : DenseFields
        ``ridges`` and the fields of ``outputs``; the others None.
    ridge_sq_distance_px : int32 (n,)
        ``sq_distance_px`` at the ridge pixels in raster order (those of
        ``np.flatnonzero(fields.ridges)``); read it at chosen ridge pixels with
        :func:`topojax.fields.ridge_values.at_ridge_pixels`.
    """
    outputs = names_subset("outputs", outputs, FIELD_NAMES)
    (fields,), (values,) = _run_kernels(
        [obstacles], distance, ridge, tile_px, tiles_per_call, threads, outputs, True
    )
    return fields, values


def ridge_fields_many(
    obstacle_maps,
    *,
    distance: DistanceConfig | None = None,
    ridge: RidgeConfig | None = None,
    tile_px: int = 256,
    tiles_per_call: int = 1,
    threads: int | None = None,
) -> list[tuple[DenseFields, np.ndarray]]:
    """:func:`ridge_fields` for many maps at once, their tiles sharing kernel calls (as
    :func:`dense_fields_many`); one ``(fields, ridge_sq_distance_px)`` per map, in input
    order, identical to :func:`ridge_fields` of each map alone."""
    fields, values = _run_kernels(
        obstacle_maps, distance, ridge, tile_px, tiles_per_call, threads, (), True
    )
    return list(zip(fields, values, strict=True))


def _run_kernels(
    obstacle_maps, distance, ridge, tile_px, tiles_per_call, threads, outputs, ridge_values
):
    """Both kernel passes over the maps: their DenseFields with ``outputs`` and, with
    ``ridge_values``, the squared distance at each map's ridge pixels (raster order)."""
    maps = [_as_obstacles(o) for o in obstacle_maps]
    distance = instance_or_default("distance", distance, DistanceConfig)
    ridge = instance_or_default("ridge", ridge, RidgeConfig)
    tile_px = kernel_tile_px("tile_px", tile_px)
    tiles_per_call = kernel_tiles_per_call("tiles_per_call", tiles_per_call, tile_px)
    if not maps:
        return [], []
    batch = _TileBatch(maps, tile_px, tiles_per_call)
    scalars = _kernel_scalars(distance.sigma_px, ridge.scale, ridge.threshold)
    n_threads = _dispatch_threads(threads, len(batch.starts))
    scratch = _Scratch()
    r = distance.half_width_px
    columns = _column_pass(batch, r, scratch, n_threads)
    sinks = _Sinks(batch, outputs, ridge_values)
    _forward_pass(batch, columns, r, ridge.ksize, scalars, scratch, n_threads, sinks)
    scratch.release()  # only after every kernel call has been collected
    return sinks.fields, sinks.ridge_values(tile_px)


class _TileBatch:
    """The tiles of several maps as one sequence, cut into kernel calls of
    ``tiles_per_call`` tiles (chunks starting at :attr:`starts`)."""

    def __init__(self, maps: list[np.ndarray], tile_px: int, tiles_per_call: int) -> None:
        self.maps = maps
        self.tile_px = tile_px
        self.tiles_per_call = tiles_per_call
        self.grids = grids = [TileGrid(m.shape, tile_px) for m in maps]
        # (map index, tile row, tile col, map row, map col) of every tile, in order
        self.owners = owners = np.concatenate([np.full(g.n_tiles, i) for i, g in enumerate(grids)])
        local = np.concatenate([np.arange(g.n_tiles) for g in grids])
        self.cells = [
            divmod(int(k), grids[i].grid_shape[1]) for i, k in zip(owners, local, strict=True)
        ]
        self.origins = np.concatenate([g.origins() for g in grids])
        self.shapes = np.asarray([m.shape for m in maps], np.int32)
        self.total = len(owners)
        self.starts = range(0, self.total, tiles_per_call)

    def chunk(self, start: int) -> np.ndarray:
        """Indices of the tiles of the call starting at tile ``start``."""
        return np.arange(start, min(self.total, start + self.tiles_per_call))

    def stack(self, views, sel, fill):
        """The patches of tiles ``sel``, padded to a full chunk with ``fill``."""
        patches = np.stack([views[self.owners[j]][self.cells[j]] for j in sel])
        short = self.tiles_per_call - len(sel)
        if short:
            pad = np.full((short,) + patches.shape[1:], fill, patches.dtype)
            patches = np.concatenate([patches, pad])
        return patches

    def core_box(self, j):
        """``(row, col, rows, cols)`` of tile ``j``'s core inside its map."""
        r0, c0 = self.origins[j]
        h, w = self.maps[self.owners[j]].shape
        return r0, c0, min(self.tile_px, h - r0), min(self.tile_px, w - c0)


def _dispatch(starts: range, n_threads: int, launch, finish) -> None:
    """Run ``finish(start, launch(start))`` for every chunk.  Each thread keeps up to
    :data:`_IN_FLIGHT` chunks launched ahead of the one it collects: JAX dispatches
    asynchronously, so the host work of one chunk overlaps the kernels of the next, and
    the kernels run back to back.  Threads take the next chunk when they launch one
    (tiles differ in cost, so fixed shares would leave threads idle)."""
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


def _column_pass(batch: _TileBatch, r: int, scratch: _Scratch, n_threads: int) -> list[np.ndarray]:
    """Kernel 1, the column pass, on each tile's own columns with ``r`` halo rows: one
    array per map (:func:`~topojax.fields.distance.column_dtype`).  Each tile's core goes
    straight into its map's column array (tiles never overlap, so the dispatch threads
    write disjoint regions).  The padded maps go back to ``scratch`` at the end."""
    col_dtype = column_dtype(r)
    # Each padded map's buffer then holds its padded column pass (_forward_pass).
    padded = [
        scratch.take(
            g.padded_shape((r, 0)),
            bool,
            min_bytes=np.prod(g.padded_shape((HALO_PX, HALO_PX + r))) * col_dtype.itemsize,
        )
        for g in batch.grids
    ]
    strip_views = [
        g.patch_view(m, (r, 0), fill=False, out=out)
        for g, m, out in zip(batch.grids, batch.maps, padded, strict=True)
    ]
    columns = [scratch.take(m.shape, col_dtype) for m in batch.maps]

    def launch_columns(start: int):
        return _column_tiles(batch.stack(strip_views, batch.chunk(start), False), half_width=r)

    def finish_columns(start: int, handle) -> None:
        out = np.asarray(handle)
        for n, j in enumerate(batch.chunk(start)):
            r0, c0, h, w = batch.core_box(j)
            columns[batch.owners[j]][r0 : r0 + h, c0 : c0 + w] = out[n, :h, :w]

    _dispatch(batch.starts, n_threads, launch_columns, finish_columns)
    for arr in padded:  # the strip views are not read any more
        scratch.give_back(arr)
    return columns


class _Sinks:
    """Where the forward kernel's tiles go: the DenseFields asked for (``outputs``), and
    with ``ridge_values`` the squared distance at each tile's ridge pixels."""

    def __init__(self, batch: _TileBatch, outputs: tuple[str, ...], ridge_values: bool) -> None:
        dtypes = dict(zip(FIELD_NAMES, (np.int32, np.float32, np.uint8, bool), strict=True))
        if ridge_values and "ridges" not in outputs:
            outputs = (*outputs, "ridges")
        self.fields = [
            DenseFields(
                **{
                    name: np.empty(m.shape, dtypes[name]) if name in outputs else None
                    for name in FIELD_NAMES
                }
            )
            for m in batch.maps
        ]
        self.batch = batch
        self.slots = [i for i, name in enumerate(FIELD_NAMES) if name in outputs]
        self.tile_values = [None] * batch.total if ridge_values else None
        # the kernel outputs read back from the device: the kept fields, and the squared
        # distance and ridges (slots 0 and 3) when the ridge values are kept
        self.needed = frozenset(self.slots) | (frozenset((0, 3)) if ridge_values else frozenset())

    def put(self, j: int, n: int, tiles: list) -> None:
        """Tile ``j`` of the batch, slot ``n`` of the kernel call's outputs ``tiles``."""
        target = self.fields[self.batch.owners[j]]
        r0, c0, h, w = self.batch.core_box(j)
        for i in self.slots:
            getattr(target, FIELD_NAMES[i])[r0 : r0 + h, c0 : c0 + w] = tiles[i][n, :h, :w]
        if self.tile_values is not None:
            self.tile_values[j] = tiles[0][n, :h, :w][tiles[3][n, :h, :w]]

    def ridge_values(self, tile_px: int) -> list:
        """Per map, the squared distance at its ridge pixels in raster order."""
        if self.tile_values is None:
            return [None] * len(self.fields)
        from .ridge_values import tiles_to_raster

        out = []
        first = 0
        for f, g in zip(self.fields, self.batch.grids, strict=True):
            tiles = self.tile_values[first : first + g.n_tiles]
            first += g.n_tiles
            offsets = np.concatenate([[0], np.cumsum([t.size for t in tiles])])
            values = np.concatenate(tiles) if tiles else np.zeros(0, np.int32)
            del tiles
            out.append(tiles_to_raster(f.ridges, tile_px, values, offsets))
        self.tile_values = None
        return out


def _forward_pass(
    batch: _TileBatch,
    columns: list[np.ndarray],
    r: int,
    ksize: int,
    scalars,
    scratch: _Scratch,
    n_threads: int,
    sinks: _Sinks,
) -> None:
    """Kernel 2, everything after the column pass, on the column pass with the row halo
    of the Laplacian and the column halo of the Laplacian and the window; its tiles go
    to ``sinks``.  The column arrays go back to ``scratch`` once padded."""
    col_dtype = column_dtype(r)
    none = np.iinfo(col_dtype).max
    tiles_per_call = batch.tiles_per_call
    column_halo = (HALO_PX, HALO_PX + r)
    column_views = []
    for g, c in zip(batch.grids, columns, strict=True):
        out = scratch.take(g.padded_shape(column_halo), col_dtype)
        column_views.append(g.patch_view(c, column_halo, fill=none, out=out))
        scratch.give_back(c)
    del columns, c

    def launch_forward(start: int):
        sel = batch.chunk(start)
        org = batch.origins[sel]
        shp = batch.shapes[batch.owners[sel]]
        short = tiles_per_call - len(sel)
        if short:
            org = np.concatenate([org, np.zeros((short, 2), np.int32)])
            shp = np.concatenate([shp, np.full((short, 2), 2, np.int32)])
        return _forward_tiles(
            batch.stack(column_views, sel, none),
            org,
            shp,
            *scalars,
            tile_px=batch.tile_px,
            half_width=r,
            ksize=ksize,
        )

    def finish_forward(start: int, handle) -> None:
        tiles = [np.asarray(a) if i in sinks.needed else None for i, a in enumerate(handle)]
        for n, j in enumerate(batch.chunk(start)):
            sinks.put(j, n, tiles)

    _dispatch(batch.starts, n_threads, launch_forward, finish_forward)


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
    config = instance_or_default("config", config, DistanceConfig)
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
