"""The incremental mapper."""

from __future__ import annotations

import functools
import math
import threading
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import networkx as nx
import numpy as np

from .._validate import flag, instance_of, path_like, real_array
from ..config import DistanceConfig, PipelineConfig, RidgeConfig, SkeletonConfig
from ..fields.distance import FAR_SQ
from ..fields.filters import HALO_PX
from ..fields.tiling import MAX_GRID_CELLS, TileManager
from ..scans import Scan
from ..scans.scan import reading_limits
from ._dense_export import dense_layer, distance_map, export_bbox, occupancy_over
from ._graph_export import export_graph, global_graph, topology_result
from ._graph_patch import patch_graph
from ._graph_store import empty_graph_tables
from ._rays import (
    _scan_geometry,
    add_occupancy,
    cast_pending_rays,
    changing,
    check_whole,
    join_rays,
    point_pixels,
    sensor_pixel,
)
from ._ridges import (
    RIDGE_BLOCKS,
    TABLE_MAX_HALF_PX,
    gaussian_table,
    ridge_kernel,
    update_ridges,
)
from ._rooms import RoomKeeper, due_rooms_update, rooms_due
from ._scan_loops import add_each, map_end_pixels, scan_subject
from ._settings import (
    DEFAULT_MAX_EXPORT_BYTES,
    DEFAULT_MAX_EXTENT_M,
    DEFAULT_MAX_TILE_BYTES,
    checked_guard_settings,
    checked_loop_settings,
    checked_resolution,
    checked_room_settings,
    checked_sizes,
    merged_config,
)
from ._skeleton import skeleton_exact, skeleton_paper
from ._splat import SPLAT_POINTS, SPLAT_ROWS, _splat_blocks, flush_splat
from ._tiles import check_export_budget, new_tile_storage, pixel_indices, window_box
from .reports import GraphUpdate, ScanReport
from .state import load_state, save_state


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
    rooms_every : int or None
        Update :attr:`rooms` once this many scans have come since the last room update;
        None (default): with every graph update, once rooms are in use (after the first
        read of :attr:`rooms` or call of :meth:`update_rooms`); 0: explicit calls only.
    room_config : RoomConfig, optional
        Options of the room segmentation.
    rooms_local : bool
        Default True: re-segment only around the free space changed since the last room
        update (rooms the changes do not reach keep ids and pixels; a few pixels differ
        from segmenting the map from scratch); False: the whole map each time, exactly as
        from scratch up to ids (``docs/rooms.md``).
    strategy : {"exact", "paper"}
        Skeleton update: ``"exact"`` re-thins the changed ridge components and equals the
        full-map pipeline; ``"paper"`` thins the new ridges inside the changed blocks plus a
        ``paper_layer_px`` wide layer of the old skeleton around them and writes back inside
        the changed blocks only (paper §III-B).
    config : PipelineConfig, optional
        Distance, ridge and skeleton settings (default: the paper's).  Its ``tile_px`` and
        ``tiles_per_call`` are the full-map pipeline's and are not used here.
        ``config.graph.merge_junction_clusters`` must be False.
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
        :class:`~topojax.fields.tiling.TileManager`); a scan that would exceed it is rejected
        with :class:`ExtentError` before anything changes.
    max_extent_m : float
        The longest side, in metres, the bounding box of the allocated tiles may reach
        (default 2000).  A scan, points or map that would grow it further (a pose far
        off: a localisation glitch) is refused with :class:`ExtentError` (a ValueError)
        before anything changes, naming the scan's index, timestamp and pose.
    max_export_bytes : int
        The most memory, in bytes, a dense export (:attr:`occupancy`, the fields,
        :meth:`to_result`, :meth:`route_graph`, :meth:`occupancy_window`) may allocate,
        estimated from its pixels before anything is allocated (default 2 GiB); a larger
        one raises ValueError that says how to export a window.
    max_tile_bytes : int
        The most memory, in bytes, the mapper's tiles may hold (default 2 GiB: about
        7,000 tiles of 128 px, each about 0.3 MB).  A scan, points or map that would
        allocate more is refused with :class:`ExtentError` before anything changes
        (readings far beyond the sensor's range: set ``range_max`` or ``max_range_m``).
        Either byte limit given above the memory available warns (it guards nothing).

    Notes
    -----
    Obstacles are monotone: a pixel hit once stays an obstacle (like the paper's max-merge
    of distance maps).  The exported occupancy map marks hit pixels occupied, pixels crossed
    by a beam but never hit free, and the rest unknown.

    A mapper may be shared between threads (a scan callback, a timer that publishes the
    graph or saves the state): scans, updates, exports and :meth:`save` hold its lock, so
    they run one at a time and each sees a whole scan.  Arrays and graphs it returns are
    copies or new objects, except :attr:`tiles`.

    With the ``"exact"`` strategy the distance map, ridges, skeleton and graph equal the
    full-map pipeline's on the exported map (the graph up to ids); the argument is in
    ``docs/incremental-exactness.md``.
    """

    def __init__(
        self,
        *,
        resolution_m: float = 0.05,
        skeleton_every: int | None = 20,
        graph_every: int | None = 80,
        rooms_every: int | None = None,
        room_config=None,
        rooms_local: bool = True,
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
        max_extent_m: float = DEFAULT_MAX_EXTENT_M,
        max_export_bytes: int = DEFAULT_MAX_EXPORT_BYTES,
        max_tile_bytes: int = DEFAULT_MAX_TILE_BYTES,
    ) -> None:
        resolution_m = checked_resolution(resolution_m, strategy)
        self.max_extent_m, self.max_export_bytes, self.max_tile_bytes = checked_guard_settings(
            max_extent_m, max_export_bytes, max_tile_bytes
        )
        config = merged_config(config, distance, ridge, skeleton)
        tile_px, block_px, paper_layer_px = checked_sizes(tile_px, block_px, paper_layer_px)
        (
            self.max_pending_points,
            self.free_space,
            self.max_range_m,
            self.skeleton_every,
            self.graph_every,
        ) = checked_loop_settings(
            max_pending_points, free_space, max_range_m, skeleton_every, graph_every
        )
        self.rooms_every, self.room_config, self.rooms_local = checked_room_settings(
            rooms_every, room_config, rooms_local
        )
        self._rooms = RoomKeeper()
        self._since_rooms = 0
        self.resolution_m = resolution_m
        self.strategy = strategy
        self.config = config
        self.tile_px = tile_px
        self.block_px = block_px
        self.paper_layer_px = paper_layer_px
        self._half = config.distance.half_width_px
        self._tiles = new_tile_storage(tile_px, block_px, max_grid_cells)
        self._n_scans = 0
        self._n_ridge = 0
        self._compiled = False
        self._pending: list[np.ndarray] = []
        # beams whose free cells are not counted yet: (sensor row, col, end rows, cols)
        self._rays: list[tuple[int, int, np.ndarray, np.ndarray]] = []
        self._n_rays = 0
        self._lock = threading.RLock()
        self._torn: str | None = None  # what stopped an update part way (see changing)
        self._ray_job = None
        self._n_pending = 0
        self._skel_changed: list[np.ndarray] = []
        self._ridge_bbox: tuple[int, int, int, int] | None = None
        self._since_skeleton = 0
        self._since_graph = 0
        empty_graph_tables(self)
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
    @_synchronized
    def tiles(self) -> TileManager:
        """The tile storage (read-only use: do not modify layers); its free-cell counts
        (``misses``) are brought up to date first."""
        cast_pending_rays(self)
        return self._tiles

    @property
    @_synchronized
    def pixel_bbox(self) -> tuple[int, int, int, int] | None:
        """``(row0, col0, row1, col1)`` of the exported arrays (end exclusive), global
        pixels, or None before anything was allocated."""
        return self._tiles.pixel_bbox

    def __repr__(self) -> str:
        return (
            f"IncrementalMapper(n_scans={self.n_scans}, resolution_m={self.resolution_m!r}, "
            f"strategy={self.strategy!r}, n_tiles={self.n_tiles}, pixel_bbox={self.pixel_bbox})"
        )

    def world_to_pixel(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Global lattice pixel containing world points ``(x, y)``.

        Parameters
        ----------
        x, y : array_like of float
            Finite world coordinates in metres, map frame (broadcast together).

        Returns
        -------
        rows, cols : np.ndarray of int64
            Global pixel indices (the square ``col r <= x < (col + 1) r``,
            ``-(row + 1) r < y <= -row r`` for resolution ``r``), with the broadcast shape.

        Raises
        ------
        TypeError, ValueError
            If ``x`` or ``y`` is not real numbers, or one is not finite or so far from 0
            that its pixel index does not fit an int64.
        """
        res = self.resolution_m
        rows = pixel_indices("y", real_array("y", y, finite=True), -1.0, res)
        cols = pixel_indices("x", real_array("x", x, finite=True), 1.0, res)
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
            Its timestamp only names it in errors: scans are mapped in the order given,
            timestamps that repeat or go backwards (as in some CARMEN logs) included.

        Returns
        -------
        ScanReport

        Raises
        ------
        TypeError
            If ``scan`` is not a :class:`~topojax.scans.Scan`.
        ValueError
            If the scan's pixels or its sensor's are absurdly far (beyond 2^30 pixels) or
            the map would exceed ``max_grid_cells``, ``max_extent_m`` or
            ``max_tile_bytes`` (:class:`ExtentError`).  Nothing is changed in that case.
        RuntimeError
            If an exception or interrupt (Ctrl-C) stopped an update of the mapper part
            way: its state holds part of that update (so do every other change and
            :meth:`save`).
        """
        instance_of("scan", scan, Scan, "topojax.Scan (see Scan.from_arrays)")
        t0 = time.perf_counter()
        sx, sy, syaw = scan.sensor_pose_world()
        sensor = sensor_pixel(self, sx, sy, lambda: scan_subject(self, scan))
        rmax = scan.range_max if self.max_range_m is None else min(scan.range_max, self.max_range_m)
        rmin, rmax = reading_limits(scan.ranges.dtype, scan.range_min, rmax)
        res = self.resolution_m
        er, ec, ext = _scan_geometry(
            scan.ranges.astype(np.float32) if scan.ranges.dtype == np.float16 else scan.ranges,
            scan.angle_min,
            scan.angle_increment,
            rmin,
            rmax,
            sx,
            sy,
            syaw,
            res,
        )
        return self._add_end_pixels(
            er,
            ec,
            ext,
            sensor,
            n_beams=scan.n_beams,
            t0=t0,
            where=lambda: scan_subject(self, scan),
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
            World ``(x, y)`` in metres, map frame.  Rows that are not finite (NaN, inf) or
            hold a masked entry (a NumPy masked array) are dropped and counted in the
            report.  The pixel of a point is the one whose square holds it.
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
        TypeError
            If ``points_xy`` is not real numbers (None, text, complex) or ``origin_xy``
            not two numbers.
        ValueError
            If ``points_xy`` is not of shape (N, 2) (``[]``: no points), ``origin_xy`` not
            finite, or the points or origin lie beyond 2^30 pixels or would make the map
            exceed ``max_grid_cells``, ``max_extent_m`` or ``max_tile_bytes``
            (:class:`ExtentError`).  Nothing is changed in that case.
        """
        t0 = time.perf_counter()
        er, ec, ext, sensor, n_points, where = point_pixels(self, points_xy, origin_xy)
        return self._add_end_pixels(er, ec, ext, sensor, n_beams=n_points, t0=t0, where=where)

    @_synchronized
    def add_map(self, occupancy) -> int:
        """Add a finished occupancy map, e.g. one from another SLAM system to keep mapping
        on: its occupied pixels become obstacles (as if hit by a beam) and its free pixels
        free space for the exported occupancy map; unknown pixels add nothing.

        The map must have the mapper's resolution and no yaw; its pixels then fall one to
        one on the mapper's pixels (each goes to the one that holds its centre,
        :meth:`world_to_pixel`), so a map whose origin is not on the mapper's lattice
        (a multiple of the resolution) moves as a whole by under half a pixel.  It does
        not count as a scan and runs no loop: call :meth:`update_graph` (or keep adding
        scans) to bring skeleton and graph up to date.

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
            make the map exceed ``max_grid_cells``, ``max_extent_m`` or ``max_tile_bytes``
            (:class:`ExtentError`).  Nothing is changed in that case.
        """
        return add_occupancy(self, occupancy)

    def _add_end_pixels(self, er, ec, ext, sensor, *, n_beams: int, t0: float, where):
        """The distance loop for one scan's end pixels ``(er, ec)`` (int64, extent
        ``ext`` = (min row, max row, min col, max col)), free space along the rays from the
        ``sensor`` pixel (row, col) when given, then the loops that are due."""
        check_whole(self, "add a scan")
        with changing(self, f"adding scan {self._n_scans}"):
            return map_end_pixels(self, er, ec, ext, sensor, n_beams=n_beams, t0=t0, where=where)

    @_synchronized
    def compile(self) -> None:
        """Compile every JAX kernel variant the mapper uses (two batch sizes each of the
        splat and ridge kernels) and build the ridge kernel's Gaussian table, so that no JAX
        compilation happens later.  Runs automatically before the first splat; calling it
        again does nothing.  The CPU kernels (numba) are compiled once per installation
        and loaded from numba's on-disk cache at their first use in a process."""
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
            jax.block_until_ready(ridge_kernel(self, patches))
        self._compiled = True

    @_synchronized
    def add_scans(self, scans) -> list[ScanReport]:
        """:meth:`add_scan` for every scan of an iterable; returns the reports (an item
        that is no Scan raises TypeError naming its index; the scans before it stay)."""
        if (
            isinstance(scans, (Scan, str, bytes))  # a path: read_scans(path) reads it
            or not hasattr(scans, "__iter__")
            or (isinstance(scans, np.ndarray) and scans.ndim == 0)
        ):
            raise TypeError(
                f"scans: expected an iterable of Scan (e.g. read_scans(path)), received "
                f"{type(scans).__name__}; add one scan with add_scan"
            )
        return add_each(self, scans)

    # ------------------------------------------------------------------ distance loop
    def _flush_splat(self) -> int:
        """Splat all pending new obstacle pixels; returns the number of changed blocks."""
        if not self._pending:
            return 0
        with changing(self, "a splat"):
            return flush_splat(self)

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
        check_whole(self, "update the skeleton")
        with changing(self, "a skeleton update"):
            return self._update_skeleton()

    def _update_skeleton(self) -> int:
        """The body of :meth:`update_skeleton`."""
        self._flush_splat()
        added, removed, border, blocks = update_ridges(self)
        # The free cells of the scans since the last update are counted on the worker
        # thread meanwhile (nothing below touches them or allocates tiles).  Not earlier:
        # next to the ridge kernel's XLA thread it slows that kernel down.
        cast_pending_rays(self, background=True)
        try:
            self._since_skeleton = 0
            self._export_cache.clear()
            if self.strategy == "exact":
                return skeleton_exact(self, added, removed, border)
            return skeleton_paper(self, blocks)
        finally:
            join_rays(self)

    # ------------------------------------------------------------------ graph loop
    @_synchronized
    def update_graph(self) -> GraphUpdate:
        """Bring everything up to date: splat, skeleton loop, then the graph loop.

        With ``rooms_every=None`` and rooms in use, the rooms are updated too, as with
        every graph update (a map past ``max_export_bytes`` for them warns and leaves
        them as they were, as a scan's update does).

        Returns
        -------
        GraphUpdate
            What the graph loop changed (``time_s`` covers the graph loop only).
        """
        self.update_skeleton()
        update = self._update_graph()
        if self.rooms_every is None and rooms_due(self, graph_ran=True):
            due_rooms_update(self)
        return update

    def _update_graph(self) -> GraphUpdate:
        from ..graph import paused_gc

        with paused_gc(), changing(self, "a graph update"):
            return patch_graph(self)

    # ------------------------------------------------------------------ exports
    def _bbox_or_raise(self, what: str | None = None) -> tuple[int, int, int, int]:
        """The exported bounding box; with ``what``, the export's memory budget checked
        (:func:`check_export_budget`) first."""
        return export_bbox(self, what)

    def _dense(self, name: str, what: str | None = None) -> np.ndarray:
        return dense_layer(self, name, what)

    def _occupancy_over(self, r0: int, c0: int, r1: int, c1: int):
        """The occupancy map of the global pixel box ``[r0, r1) x [c0, c1)``."""
        return occupancy_over(self, r0, c0, r1, c1)

    @property
    @_synchronized
    def sq_distance_px(self) -> np.ndarray:
        """Windowed squared distance to the nearest obstacle, int32 (H, W) px^2 over the
        bounding box (``FAR_SQ`` where no obstacle is within the window).  Always current
        (pending splats are applied first)."""
        self._bbox_or_raise("sq_distance_px")
        self._flush_splat()
        return self._dense("sq_distance")

    @property
    @_synchronized
    def distance(self) -> np.ndarray:
        """Gaussian distance map ``H``, float32 (H, W) in [0, 1], over the bounding box of
        the allocated tiles (``[row, col]``, row 0 = top = largest y).  Always current."""
        self._bbox_or_raise("distance")
        self._flush_splat()
        if "distance" not in self._export_cache:
            self._export_cache["distance"] = distance_map(self)
        return self._export_cache["distance"].copy()

    @property
    @_synchronized
    def occupancy(self):
        """The map as an :class:`~topojax.maps.OccupancyMap` over the bounding box of the
        allocated tiles: hit pixels occupied, pixels crossed by a beam and never hit free,
        the rest unknown.  Its origin puts pixel centres at the lattice world coordinates,
        so ``build_graph(mapper.occupancy)`` is in the mapper's world frame.  Raises
        ValueError if it would exceed ``max_export_bytes`` (see :meth:`occupancy_window`)."""
        return self._occupancy_over(*self._bbox_or_raise("occupancy"))

    @_synchronized
    def occupancy_window(self, bbox):
        """The occupancy map of the pixels whose squares meet ``bbox`` (those outside the
        allocated tiles unknown), e.g. of a map too large to export whole: on the pixels
        it shares with :attr:`occupancy` it equals it, and ``pixel_to_world`` gives the
        same points to within float rounding (about 1e-15 m: the two origins differ).

        Parameters
        ----------
        bbox : (x_min, y_min, x_max, y_max)
            The window in the mapper's world frame, metres.

        Returns
        -------
        OccupancyMap

        Raises
        ------
        ValueError
            If ``bbox`` is not four finite numbers with ``x_min < x_max`` and
            ``y_min < y_max``, covers less than 2 x 2 pixels, or the window would exceed
            ``max_export_bytes``.
        """
        box = window_box(self, bbox)
        check_export_budget(self, "occupancy_window", box)
        return self._occupancy_over(*box)

    @property
    @_synchronized
    def obstacles(self) -> np.ndarray:
        """Obstacle mask (pixels ever hit), bool (H, W) over the bounding box."""
        return self._dense("hits", "obstacles") > 0

    @property
    @_synchronized
    def ridges(self) -> np.ndarray:
        """Ridge map as of the last skeleton update, bool (H, W) over the bounding box."""
        return self._dense("ridge", "ridges")

    @property
    @_synchronized
    def lap_abs(self) -> np.ndarray:
        """``convertScaleAbs(Laplacian(255 H))`` as of the last skeleton update, uint8."""
        return self._dense("lap_abs", "lap_abs")

    @property
    @_synchronized
    def skeleton(self) -> np.ndarray:
        """Skeleton as of the last skeleton update, bool (H, W) over the bounding box."""
        return self._dense("skeleton", "skeleton")

    @property
    @_synchronized
    def graph(self) -> nx.MultiGraph:
        """Topology graph as of the last graph update, in the exported map's frame.

        Same attribute schema as :func:`topojax.build_graph`'s graph (node ``pixel``,
        ``pixels``, ``world``, ``kind``, ``clearance_m``; edge ``path``, ``world``,
        ``length_m``, ``min_clearance_m``, ``mean_clearance_m``), with pixel coordinates
        relative to the exported bounding box.  Node ids and edge keys are the mapper's
        stable ids (see :class:`GraphUpdate`); each edge is stored with ``u <= v`` and its
        path runs from ``u`` to ``v``.  Clearances use the current distance map.  Read
        from the tiles at the graph's pixels: its memory grows with the graph, not with
        the bounding box, and ``max_export_bytes`` does not apply.
        """
        if "graph" not in self._export_cache:
            self._export_cache["graph"] = export_graph(self)
        return self._export_cache["graph"].copy()

    @property
    @_synchronized
    def graph_global(self) -> nx.MultiGraph:
        """The internal graph: node ``pixel`` and edge ``path`` in global lattice pixels,
        node ``kind``; no other attributes (a new graph)."""
        return global_graph(self)

    def route_graph(self, *, robot_radius_m: float | None = None, config=None) -> nx.MultiGraph:
        """The route graph of the current map for a round robot (:func:`topojax.route_graph`
        of :attr:`occupancy`, recomputed whole), in the exported map's frame.  The lock is
        held only while the map is exported: scans from other threads go on while the
        graph is built, and it is the graph of the map as of the call.

        Parameters
        ----------
        robot_radius_m : float, optional
            Robot radius in metres (default ``config.robot_radius_m``, 0.3).
        config : RouteGraphConfig, optional
            The other options.

        Returns
        -------
        networkx.MultiGraph
            As :func:`topojax.route_graph`; pixel coordinates relative to the exported
            bounding box.
        """
        from ..routegraph import route_graph

        with self._lock:
            self._bbox_or_raise("route_graph")
            occupancy = self.occupancy
        return route_graph(occupancy, robot_radius_m=robot_radius_m, config=config)

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
        return topology_result(self, flag("update", update))

    # ------------------------------------------------------------------ rooms
    @property
    @_synchronized
    def rooms(self):
        """The rooms of the current map (:class:`topojax.RoomSegmentation` in the frame of
        :attr:`occupancy`, ids stable across updates); segmented on first read, then kept
        up to date at ``rooms_every``.  Its labels are those of
        ``segment_rooms(mapper.occupancy)`` with the ids renamed (with ``rooms_local``:
        re-segmented around the changes only, see ``docs/rooms.md``).  Read on an empty
        mapper, it raises ValueError, and rooms are kept from the first scan on."""
        if self._rooms.seg is None:
            self.update_rooms()
        self._rooms.handed_out = True  # kept as it is: the next update works on a copy
        return self._rooms.seg

    @_synchronized
    def update_rooms(self):
        """Bring the graph and the rooms up to date; returns a ``RoomsUpdate`` (rooms and
        doors added, removed, changed)."""
        check_whole(self, "update the rooms")
        self._rooms.active = True  # in use from now on, even if the mapper is empty yet
        self.update_skeleton()
        self._update_graph()
        return self._update_rooms()

    def _update_rooms(self):
        self._since_rooms = 0
        if self._tiles.pixel_bbox is None:
            raise ValueError(
                "rooms: the mapper is empty; they are kept up to date from the first scan "
                "with valid readings, or map with a known pixel, on"
            )
        box = self._bbox_or_raise("rooms")
        return self._rooms.update(
            self._occupancy_over(*box), box, self.room_config, local=self.rooms_local
        )

    # ------------------------------------------------------------------ state
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
        return save_state(self, path_like("path", path))

    @classmethod
    def load(cls, path) -> IncrementalMapper:
        """Load a state written by :meth:`save`.

        Raises
        ------
        FileNotFoundError
            If ``path`` does not exist.
        ValueError
            If it is not a file (a folder), the file is not a mapper state, has another
            format version, or is corrupt (the message names the file and the problem),
            e.g. a counter beyond what its tiles, int32 ids or the memory available allow,
            a scan count (``n_scans``) above 10**12, or a pixel off its tiles (the message
            names the field).
        """
        return load_state(cls, path)
