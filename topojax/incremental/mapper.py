"""The incremental mapper."""

from __future__ import annotations

import functools
import io as _io
import json
import math
import numbers
import threading
import time
import zipfile
from dataclasses import asdict
from pathlib import Path

import jax
import jax.numpy as jnp
import networkx as nx
import numpy as np

from ..config import DistanceConfig, GraphConfig, PipelineConfig, RidgeConfig, SkeletonConfig
from ..distance import FAR_SQ
from ..filters import HALO_PX
from ..scans import Scan
from ..tiling import MAX_GRID_CELLS, TileManager, unique_pairs
from ._graph_patch import _KIND_CODE, _KIND_NAME, _interior, _near_skeleton, _region_z, _signatures
from ._rays import (
    RAY_BATCH_BEAMS,
    _cast_rays,
    _count_cells,
    _integrate,
    _missing_ray_tiles,
    _scan_geometry,
)
from ._rethin import _THIN_DC, _THIN_DR, RETHIN_BLOCK_PX, SEED_MARGIN_PX, _rethin, _seed_blocks
from ._ridges import (
    RIDGE_BLOCKS,
    TABLE_MAX_HALF_PX,
    _gather_ridge_patches,
    _gaussian,
    _ridge_blocks,
    _write_ridges,
    gaussian_table,
)
from ._splat import (
    DOMINANCE_PX,
    PARALLEL_MIN_POINTS,
    SPLAT_POINTS,
    SPLAT_ROWS,
    _batch_bound,
    _finish_merge,
    _merge_rows,
    _splat_blocks,
    _splat_group,
    _splat_pairs,
)
from ._tiles import (
    _MAX_ABS_PIXEL,
    _aligned_empty,
    _batches,
    _clear_owned,
    _clear_region,
    _flags,
    _gather_px,
    _grown,
    _growth_pool,
    _log2,
    _max_padding,
    _pack,
    _scatter_px,
    _unpack,
    _worker_pool,
)
from ._tremoval import _t_seeds, _t_update
from .reports import GraphUpdate, ScanReport
from .state import STATE_FORMAT, STATE_VERSION

STRATEGIES = ("exact", "paper")


#: Tile storage reserved when a mapper starts: address space, whose pages are mapped on
#: first use (64 GiB: about 230,000 tiles of 128 px).  A map within it never grows its
#: storage, so no scan waits for a copy of every tile.  Where the system refuses the
#: reservation (strict overcommit, ``ulimit -v``) the storage starts small and grows.
INITIAL_STORAGE_BYTES = 1 << 36


def _check_rate(name: str, value) -> int:
    if value is None:
        return 0
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int >= 0 or None, got {type(value).__name__}")
    if value < 0:
        raise ValueError(f"{name} must be >= 0 (0 or None: explicit calls only), got {value}")
    return int(value)


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
        from ..maps import OccupancyMap

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
        from ..skeleton import skeletonize_ridges

        return skeletonize_ridges(
            image, method=self.config.skeleton.thinning, remove_t=self.config.skeleton.remove_t
        )

    def _skeleton_exact(self, added, removed, border) -> int:
        """Exact local update of the skeleton (see the module notes): re-thin around the
        changed ridge pixels (:func:`_rethin`), then redo T-centre removal where its inputs
        changed (:func:`_t_update`)."""
        if added.shape[0] == 0 and removed.shape[0] == 0 and border.shape[0] == 0:
            return 0
        from ..skeleton import TABLES_U8

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
        from ..graph import paused_gc

        with paused_gc():
            return self._patch_graph()

    def _patch_graph(self) -> GraphUpdate:
        from ..graph import orient, raw_graph

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
        from ..maps import OccupancyMap

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
        from ..graph import path_lengths_m
        from ..pipeline import clearance_at

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
        from ..pipeline import TopologyResult

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
        from .._fs import atomic_write_bytes

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
