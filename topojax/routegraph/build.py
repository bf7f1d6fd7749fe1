"""Route graphs for a round robot: :func:`route_graph` and its options,
:class:`RouteGraphConfig`.  The meaning of every option, with pictures, is in
``docs/route-graphs.md``, the method in ``docs/route-graph-design.md``."""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, fields, replace

import cv2
import networkx as nx
import numpy as np

from .._caller import outside_stacklevel
from .._stage_memory import ROUTE_GRAPH_BYTES_PER_PX, SMALLER_MAP, check_stage_fits
from .._validate import (
    flag,
    instance_or_default,
    nonnegative_metres,
    positive_metres,
    quantity,
    real_number,
    robot_radius,
)
from ..fields.clearance import clearance_at_least
from ..graph import skeleton_graph_store
from ..graph.store import fill_multigraph, paused_gc
from ..graph.work import (
    WorkGraph,
    collapse_loops,
    drop_spurs,
    face_labels,
    merge_close_vertices,
)
from ..maps import map_argument
from ..skeleton import thin
from ._corners import CORNER_TOLERANCE_M
from ._cover import (
    MAX_SHORTCUT_PAIRS,
    RUNG_GAIN_M,
    add_coverage,
    add_shortcuts,
    covered,
    estimated_pairs,
    graph_raster,
    open_pixels,
    pairs_bound,
    shortcut_nodes,
    wall_distance,
)
from ._spanner import open_short_loops, simplify_paths
from .feasible import (
    FeasibleSpace,
    clearance_map_m,
    feasible_space,
    feasible_space_of_free,
    route_graph_note,
)
from .scale import MAX_SNAP_M, check_scale, reach_in_px

__all__ = ["RouteGraphConfig", "route_graph"]

#: Edges at most this long (pixels) join two neighbouring pixels: one-pixel edges.
_ONE_PIXEL = 1.5

#: Vertices closer than the robot's radius, but at most this share of the snap distance,
#: merge into one.
MERGE_SNAP_SHARE = 0.5

#: An 8-connected pixel path is up to this much longer than the straight or simplified
#: line a robot follows (1 / cos 22.5 deg, rounded up): loop lengths measured on pixel
#: paths are scaled by it so that no loop is short along the waypoints.
PIXEL_PATH_EXCESS = 1.083


@dataclass(frozen=True, kw_only=True)
class RouteGraphConfig:
    """Options of :func:`route_graph`, in metres (they scale with the map's resolution).

    Attributes
    ----------
    robot_radius_m : float, default 0.3
        Robot radius: every edge keeps at least this clearance from anything not known free.
    snap_m : float, default 1.0
        Coverage: every feasible pixel lies within this distance of the graph (through the
        feasible space); waypoints are added where the medial axis does not reach.  At
        most :data:`MAX_SNAP_M` (5 m), at least twice ``waypoint_tolerance_m``.
    loop_m : float, default 2.0
        Loops shorter than this always collapse to one corridor, and no shortcut closes a
        loop shorter than twice this.
    loop_clearance_factor : float, default 8.0
        A loop shorter than this times its mean clearance also collapses.
    small_obstacle_m : float, default 1.0
        A loop around an obstacle at most this across (bounding-box diagonal) collapses.
    spur_m : float, default 1.0
        Dead ends hanging off a junction shorter than this are dropped.
    spur_clearance_factor : float, default 1.5
        Dead ends shorter than this times the feasible clearance at their junction (the
        medial axis's branches into room corners) are dropped too.
    shortcut_stretch : float, default 1.2
        A straight shortcut joins two vertices when the graph route between them is longer
        than this times their distance (and the straight line is feasible).
    shortcut_radius_m : float, default 5.0
        Only vertices at most this far apart are considered for shortcuts (0: none).
    shortcut_gain_m : float, default 0.3
        ... and only when the shortcut saves at least this much route length.  Straight
        shortcuts cross no edge: farther than the robot radius (at most half ``snap_m``)
        from its ends a shortcut touches no other edge.
    shortcut_spacing_m : float, default 1.0
        Shortcuts may also start at points about this far apart along the edges (the edge
        is split there); 0: only at vertices, else at least one pixel of the map.
    shortcuts_from_dead_ends : bool, default True
        Whether shortcuts may start at dead ends (coverage waypoints at the rim of open
        space); False gives markedly fewer edges in rooms and halls, and longer routes.
    shortcuts_round_corners : bool, default True
        Whether a shortcut may also bend once, round a corner the free space turns round
        (a wall's end, a door's frame, a piece of furniture): the shortest routes hug
        such corners, which no straight line between points of the medial axis follows.
        Bent shortcuts may cross other edges.
    waypoint_tolerance_m : float, default 0.1
        Each edge's ``waypoints`` polyline keeps every path pixel within this distance
        (at most half ``snap_m``; the pixel paths are covered to ``snap_m`` less this,
        which must be at least 1.5 pixels of the map).
    min_region_m2 : float, default 1.0
        Feasible regions smaller than this get no vertex.
    """

    robot_radius_m: float = 0.3
    snap_m: float = 1.0
    loop_m: float = 2.0
    loop_clearance_factor: float = 8.0
    small_obstacle_m: float = 1.0
    spur_m: float = 1.0
    spur_clearance_factor: float = 1.5
    shortcut_stretch: float = 1.2
    shortcut_radius_m: float = 5.0
    shortcut_gain_m: float = 0.3
    shortcut_spacing_m: float = 1.0
    shortcuts_from_dead_ends: bool = True
    shortcuts_round_corners: bool = True
    waypoint_tolerance_m: float = 0.1
    min_region_m2: float = 1.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "shortcut_stretch":
                value = real_number(f.name, value)  # >= 1, checked below
            elif f.name in ("shortcuts_from_dead_ends", "shortcuts_round_corners"):
                value = flag(f.name, value)
            elif f.name == "robot_radius_m":
                value = robot_radius(f.name, value, allow_zero=False)
            elif f.name in ("snap_m", "waypoint_tolerance_m"):
                value = positive_metres(f.name, value)
            elif f.name.endswith("_m"):
                value = nonnegative_metres(f.name, value)
            else:
                unit = "m2" if f.name.endswith("_m2") else ""
                value = quantity(f.name, value, unit=unit, allow_zero=True)
            object.__setattr__(self, f.name, value)
        if self.shortcut_stretch < 1.0:
            raise ValueError(
                f"shortcut_stretch: expected a finite number >= 1, received "
                f"{self.shortcut_stretch!r}"
            )
        if self.snap_m > MAX_SNAP_M:
            raise ValueError(
                f"snap_m: expected at most {MAX_SNAP_M:g} m (the coverage test's work grows "
                f"with its square; routes join within {MAX_SNAP_M:g} m), received "
                f"{self.snap_m!r}"
            )
        if self.waypoint_tolerance_m > 0.5 * self.snap_m:
            least = 2 * self.waypoint_tolerance_m
            fix = (  # no snap_m is suggested past its own limit
                f"or snap_m: at least {least:g} m"
                if least <= MAX_SNAP_M
                else f"at most {0.5 * MAX_SNAP_M:g} m for the largest snap_m, {MAX_SNAP_M:g} m"
            )
            raise ValueError(
                "waypoint_tolerance_m: expected at most half of snap_m "
                f"({0.5 * self.snap_m:g} m), received {self.waypoint_tolerance_m!r} ({fix})"
            )


def route_graph(occupancy, *, robot_radius_m: float | None = None, config=None) -> nx.MultiGraph:
    """The route graph of a map for a round robot: safe, covering, sparse and direct.

    Parameters
    ----------
    occupancy : OccupancyMap or str or Path
        The map, or its file (read by :func:`topojax.load_map`); only its known-free
        pixels are used, its border is a wall.
    robot_radius_m : float, optional
        Robot radius in metres; overrides ``config.robot_radius_m`` (default 0.3).
    config : RouteGraphConfig, optional
        The other options.

    Returns
    -------
    networkx.MultiGraph
        The schema of :func:`topojax.build_graph`'s graph (node ``pixel``, ``pixels``,
        ``world``, ``kind``, ``clearance_m``; edge ``path``, ``world``, ``length_m``,
        ``min_clearance_m``, ``mean_clearance_m``) plus, on each edge, ``waypoints``:
        float64 (K, 2) world polyline from ``u``'s ``world`` position to ``v``'s.  Graph
        attributes ``resolution_m``, ``shape``, ``origin``, ``merge_junction_clusters``
        (True), ``robot_radius_m``, ``snap_m`` and ``min_region_m2`` (the options it was
        built with, which :func:`topojax.evaluate_route_graph` scores it at by default),
        ``kind`` (``"route_graph"``), ``uncovered_share`` and ``timings_s``; for a graph
        without edges, ``note``: why (no feasible region, with the most clearance the map
        offers and, where the robot fits, the largest feasible region's area; or vertices
        without edges), also given as a ``UserWarning``.  One component per feasible
        region of at least ``min_region_m2``.

    Raises
    ------
    TypeError, ValueError
        For an option of the wrong type or out of range (the message names it); a
        ``snap_m`` too small for the map's open space is refused before the coverage is
        built, from an estimate of the shortcut candidates it would make.
    """
    graph = unwarned_route_graph(occupancy, robot_radius_m=robot_radius_m, config=config)
    if graph.graph.get("note"):  # an empty graph: in a notebook, where the note is unseen
        # at the user's line, also through the mapper's route_graph and its lock
        warnings.warn(graph.graph["note"], UserWarning, stacklevel=outside_stacklevel())
    return graph


def unwarned_route_graph(
    occupancy, *, robot_radius_m: float | None = None, config=None
) -> nx.MultiGraph:
    """:func:`route_graph` without its warning of an empty graph, for a caller that
    reports the graph's ``note`` itself (a command, a batch's record, a replay)."""
    occupancy = map_argument("occupancy", occupancy, files=True)
    cfg = instance_or_default("config", config, RouteGraphConfig)
    if robot_radius_m is not None:
        cfg = replace(cfg, robot_radius_m=robot_radius_m)
    with paused_gc():  # many small containers, no reference cycles
        return _route_graph(occupancy, cfg)


def _route_graph(occupancy, cfg: RouteGraphConfig) -> nx.MultiGraph:
    """:func:`route_graph` with its options checked."""
    check_scale(cfg, occupancy.resolution_m)
    check_stage_fits(
        "route_graph", "occupancy", occupancy.shape, ROUTE_GRAPH_BYTES_PER_PX, SMALLER_MAP
    )
    t0 = time.perf_counter()
    win, free, clearance_m = _windowed_space(occupancy, cfg)
    feasible = win.feasible
    _refuse_dense_graph(feasible, clearance_m, win.resolution_m, cfg)
    t1 = time.perf_counter()
    skeleton = thin(feasible)
    t2 = time.perf_counter()
    res = win.resolution_m
    # a large window's clearance is not held through the coverage stage (4 bytes per
    # pixel at its peak): the assembly computes it again
    held = clearance_m.copy() if clearance_m.size <= HOLD_CLEARANCE_MAX_PX else None
    work = _sparse_skeleton_graph(skeleton, free, clearance_m, res, cfg)
    del skeleton, free, clearance_m  # image-sized, not needed any more
    t3 = time.perf_counter()
    snap_px, min_loop_px = reach_in_px(cfg, res), _min_loop_px(cfg, res)
    wall = wall_distance(feasible)
    uncovered = add_coverage(work, feasible, snap_px, min_loop_px=min_loop_px, wall=wall)
    if wall.size > HOLD_CLEARANCE_MAX_PX:
        wall = None  # as the clearance: computed again where short loops are opened
    work.contract_all()
    merge_px = _merge_px(cfg, res)
    add_shortcuts(
        work,
        feasible,
        cfg.shortcut_radius_m / res,
        cfg.shortcut_stretch,
        cfg.shortcut_gain_m / res,
        cfg.shortcuts_from_dead_ends,
        _end_px(cfg, res),
        min_loop_px,
        cfg.shortcut_spacing_m / res,
        CORNER_TOLERANCE_M / res if cfg.shortcuts_round_corners else 0.0,
        RUNG_GAIN_M / res,
    )
    work.contract_all()
    before = graph_raster(work, feasible.shape)
    # close vertices merge; a dead end one pixel off its junction is a one-pixel edge
    merge_close_vertices(work, feasible, max(_ONE_PIXEL, merge_px), _ONE_PIXEL, min_loop_px)
    # loops shorter than loop_m collapse, wherever the passes left one
    _open_short_loops(work, feasible, snap_px, cfg.loop_m / res * PIXEL_PATH_EXCESS, wall)
    uncovered |= _cover_lost(work, feasible, snap_px, before, min_loop_px, wall)
    del wall, before
    t4 = time.perf_counter()
    graph = _assemble(work, occupancy, win, cfg, held)
    del held
    t5 = time.perf_counter()
    n_feasible = int(np.count_nonzero(feasible))
    graph.graph["uncovered_share"] = (
        float(np.count_nonzero(uncovered)) / n_feasible if n_feasible else 0.0
    )
    graph.graph["timings_s"] = {
        "feasible": t1 - t0,
        "thin": t2 - t1,
        "skeleton_graph": t3 - t2,
        "cover_and_shortcuts": t4 - t3,
        "assemble": t5 - t4,
    }
    if not graph.number_of_edges():
        graph.graph["note"] = route_graph_note(
            graph,
            occupancy,
            robot_radius_m=cfg.robot_radius_m,
            min_region_m2=cfg.min_region_m2,
        )
    return graph


def _min_loop_px(cfg: RouteGraphConfig, res: float) -> float:
    """The shortest loop the coverage and the shortcuts may close, in pixels of path."""
    return 2.0 * cfg.loop_m / res * PIXEL_PATH_EXCESS


def _merge_px(cfg: RouteGraphConfig, res: float) -> float:
    """The distance (pixels) at which vertices merge: closer than the robot's radius they
    are one place for it (up to a share of the snap distance: the coverage lanes and
    meshes are spaced by it, and a large robot's merges would fold them into hubs of
    parallel edges)."""
    return min(cfg.robot_radius_m, MERGE_SNAP_SHARE * cfg.snap_m) / res


def _end_px(cfg: RouteGraphConfig, res: float) -> float:
    """How close (pixels) to its ends a shortcut may touch other edges: where it would
    merge into them (a zone of the full radius of a large robot spans the whole
    shortcut)."""
    return max(2.0, _merge_px(cfg, res))


#: A map whose estimated shortcut candidate pairs (:func:`estimated_pairs`, a share of
#: those the graph will have) exceed this is refused before its coverage is built; the
#: graph's own count is checked against :data:`MAX_SHORTCUT_PAIRS` as well.
MAX_ESTIMATED_PAIRS = MAX_SHORTCUT_PAIRS

#: The node density of the estimate is measured in a square hall of this many coverage
#: reaches a side (clipped to ``PROBE_MIN_PX``, ``PROBE_MAX_PX`` pixels) ...
PROBE_REACHES = 100
PROBE_MIN_PX = 200
PROBE_MAX_PX = 2000
#: ... over its pixels farther than this many reaches from its walls.
PROBE_DEPTH = 4.0


def _refuse_dense_graph(feasible, clearance_m, res: float, cfg: RouteGraphConfig) -> None:
    """Refuse a ``snap_m`` whose graph would have more than :data:`MAX_ESTIMATED_PAIRS`
    shortcut candidate pairs, before its coverage is built: ``feasible`` (bool (H, W))
    and ``clearance_m`` (float32 (H, W), metres) of the window, ``res`` metres per
    pixel.  The estimate (:func:`estimated_pairs`) puts nodes on the open pixels at the
    density of an open hall built with ``cfg`` (:func:`_probe_density`), built only
    where the bound without it (:func:`pairs_bound`) exceeds the limit."""
    radius_px = cfg.shortcut_radius_m / res
    if radius_px <= 0:
        return
    reach_px = reach_in_px(cfg, res)
    open_ = open_pixels(feasible, clearance_m, cfg.robot_radius_m, reach_px * res)
    n_open = int(np.count_nonzero(open_))
    anchor_px = cfg.shortcut_spacing_m / res
    if pairs_bound(n_open, reach_px, radius_px, anchor_px) <= MAX_ESTIMATED_PAIRS:
        return
    pairs = estimated_pairs(open_, _probe_density(cfg, res), radius_px)
    if pairs > MAX_ESTIMATED_PAIRS:
        raise ValueError(
            f"snap_m: {cfg.snap_m!r} leaves an estimated {pairs:,.0f} pairs of vertices "
            f"and anchors within shortcut_radius_m ({cfg.shortcut_radius_m:g} m) on the "
            f"map's {n_open * res * res:,.0f} m2 of open feasible space, expected at most "
            f"{MAX_ESTIMATED_PAIRS:,} (each takes a line test, after the coverage that "
            "makes them); "
            "use a larger snap_m or a smaller window of the map (or a smaller "
            "shortcut_radius_m)"
        )


def _probe_density(cfg: RouteGraphConfig, res: float) -> float:
    """Nodes of the shortcuts (vertices and anchors, :func:`shortcut_nodes`) per pixel of
    the open middle of a square hall, free to its border, built with ``cfg`` at ``res``
    metres per pixel up to the shortcuts (:data:`PROBE_REACHES` reaches a side, plus the
    robot's diameter)."""
    reach_px = reach_in_px(cfg, res)
    side = int(np.clip(PROBE_REACHES * reach_px, PROBE_MIN_PX, PROBE_MAX_PX))
    side += 2 * math.ceil(cfg.robot_radius_m / res)
    free = np.ones((side, side), bool)
    clearance_m = clearance_map_m(free, res)
    feasible = free & clearance_at_least(clearance_m, cfg.robot_radius_m)
    middle = clearance_m >= cfg.robot_radius_m + PROBE_DEPTH * reach_px * res
    work = _sparse_skeleton_graph(thin(feasible), free, clearance_m, res, cfg)
    add_coverage(work, feasible, reach_px, min_loop_px=_min_loop_px(cfg, res))
    work.contract_all()
    _, anchored = shortcut_nodes(work, cfg.shortcut_spacing_m / res, _end_px(cfg, res))
    n_middle = int(np.count_nonzero(middle))
    if anchored is None or not n_middle:
        return 0.0
    pos = anchored[0]
    return int(np.count_nonzero(middle[pos[:, 0], pos[:, 1]])) / n_middle


#: Windows of at most this many pixels keep their clearance for the assembly of the graph,
#: and their distance to the nearest pixel that is not feasible for the last coverage test;
#: a larger one's are computed again there (one distance transform each, a small share of
#: such a map's build time) rather than held through the coverage and shortcut stages.
HOLD_CLEARANCE_MAX_PX = 1 << 22


def _open_short_loops(
    work: WorkGraph, feasible: np.ndarray, snap_px: float, loop_px: float, wall=None
) -> None:
    """Remove the edges that close loops shorter than ``loop_px`` (:func:`open_short_loops`;
    a shortcut's bend beside an edge, two splits of one edge), and put back each removed
    edge within reach of a feasible pixel that lost its last graph pixel within
    ``snap_px``; ``wall``: :func:`wall_distance` of ``feasible``, or None to compute it."""
    removed = open_short_loops(work, loop_px, contract=False)
    if not removed:
        return
    after = graph_raster(work, feasible.shape)
    before = after.copy()
    for _, _, path in removed:
        before[path[:, 0], path[:, 1]] = True
    reach = np.ones((2 * math.ceil(snap_px) + 1,) * 2, np.uint8)
    near = cv2.dilate((before & ~after).view(np.uint8), reach).view(bool)
    if wall is None:
        wall = wall_distance(feasible)
    had = covered(before, feasible, snap_px, wall, among=near)
    lost = had & ~covered(after, feasible, snap_px, wall, among=had)
    if lost.any():
        # a lost pixel saw a pixel of a removed edge within snap_px: within the square
        back = cv2.dilate(lost.view(np.uint8), reach).view(bool)
        for u, v, path in removed:
            if back[path[:, 0], path[:, 1]].any():
                work.add_edge(u, v, path)
    work.contract_all({x for u, v, _ in removed for x in (u, v)})


def _cover_lost(
    work: WorkGraph, feasible: np.ndarray, snap_px: float, before: np.ndarray, min_loop_px, wall
) -> np.ndarray:
    """Cover again (:func:`add_coverage`) the feasible pixels that saw a pixel of the graph
    ``before`` (its raster) within ``snap_px`` and see none now: a merge drops the short
    edge between the two vertices, and contracting a merged vertex drops its member
    pixels.  Returns the pixels still uncovered (bool (H, W))."""
    after = graph_raster(work, feasible.shape)
    gone = before & ~after
    if not gone.any():
        return gone
    reach = np.ones((2 * math.ceil(snap_px) + 1,) * 2, np.uint8)
    near = cv2.dilate(gone.view(np.uint8), reach).view(bool)
    had = covered(before, feasible, snap_px, wall, among=near)
    lost = had & ~covered(after, feasible, snap_px, wall, among=had)
    if not lost.any():
        return lost
    left = add_coverage(work, feasible, snap_px, min_loop_px=min_loop_px, wall=wall, among=lost)
    work.contract_all()
    return left


@dataclass(frozen=True, kw_only=True)
class _Window:
    """The feasible space in the window round the kept regions (see
    :func:`_windowed_space`); arrays (h, w) in the window's pixels.

    Attributes
    ----------
    origin : tuple of int
        The map pixel of the window's pixel ``(0, 0)`` (may lie past the map).
    map_shape : tuple of int
        The map's ``(H, W)``.
    resolution_m : float
        Metres per pixel.
    feasible : bool (h, w)
        Feasible pixels of the kept regions.
    any_feasible : bool (h, w)
        Feasible pixels of all regions (``feasible`` itself when every region is kept).
    """

    origin: tuple[int, int]
    map_shape: tuple[int, int]
    resolution_m: float
    feasible: np.ndarray
    any_feasible: np.ndarray


def _windowed_space(occupancy, cfg: RouteGraphConfig):
    """``(window, free, clearance_m)``: the feasible space of ``occupancy`` for the robot
    of ``cfg`` in the window round its regions of at least ``cfg.min_region_m2`` (a margin
    of 2 pixels that are not feasible, :class:`_Window`), and the known-free pixels (bool
    (h, w)) and :attr:`FeasibleSpace.clearance_m` (float32 (h, w), 0 past the map) of
    that window: the graph is built in the window's pixels, the same graph wherever the
    regions lie in the map.  The map-sized arrays of the feasible space are not made: it
    is found in the bounding box of the known-free pixels (the nearest pixel that is not
    free lies in that box or on its frame, which stands for the map's outside)."""
    free = np.asarray(occupancy.free, bool)
    (b0, b1), (bh, bw) = _window(free, margin=0)  # the whole map when none is free
    space = feasible_space_of_free(
        free[b0 : b0 + bh, b1 : b1 + bw], float(occupancy.resolution_m), cfg.robot_radius_m
    )
    kept = _kept_regions(space, cfg.min_region_m2)
    if not kept.any():  # the window of no region is the whole map
        space = feasible_space(occupancy, cfg.robot_radius_m)
        kept, (b0, b1) = _kept_regions(space, cfg.min_region_m2), (0, 0)
    (r0, c0), size = _window(kept, margin=2)
    feasible = _crop(kept, (r0, c0), size)
    every_region = kept is space.feasible
    del kept
    win = _Window(
        origin=(r0 + b0, c0 + b1),
        map_shape=tuple(int(s) for s in free.shape),
        resolution_m=space.resolution_m,
        feasible=feasible,
        any_feasible=feasible if every_region else _crop(space.feasible, (r0, c0), size),
    )
    free_win = _crop(space.free, (r0, c0), size)
    return win, free_win, _crop(space.clearance_m, (r0, c0), size)


def _kept_regions(space: FeasibleSpace, min_region_m2: float) -> np.ndarray:
    """Feasible pixels of the regions of at least ``min_region_m2``: ``space.feasible``
    itself when every region is kept."""
    kept = space.regions_at_least(min_region_m2)
    if kept.size == space.n_regions:
        return space.feasible
    keep = np.zeros(space.area_m2.size, bool)
    keep[kept] = True
    return keep[space.labels]


def _window(mask: np.ndarray, margin: int) -> tuple[tuple[int, int], tuple[int, int]]:
    """``(origin, size)``: the bounding box of ``mask``'s set pixels grown by ``margin``
    pixels (it may reach past the map); the whole map when none is set."""
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        return (0, 0), mask.shape
    r0, c0 = int(rows[0]) - margin, int(cols[0]) - margin
    return (r0, c0), (int(rows[-1]) + margin + 1 - r0, int(cols[-1]) + margin + 1 - c0)


def _crop(a: np.ndarray, origin: tuple[int, int], size: tuple[int, int]) -> np.ndarray:
    """The window ``size`` of ``a`` from pixel ``origin``, zero (False) past the map."""
    out = np.zeros(size, a.dtype)
    r0, c0 = origin
    h, w = a.shape
    rs, cs = max(r0, 0), max(c0, 0)
    re, ce = min(r0 + size[0], h), min(c0 + size[1], w)
    out[rs - r0 : re - r0, cs - c0 : ce - c0] = a[rs:re, cs:ce]
    return out


def _sparse_skeleton_graph(
    skeleton: np.ndarray,
    free: np.ndarray,
    clearance_m: np.ndarray,
    res: float,
    cfg: RouteGraphConfig,
) -> WorkGraph:
    """The graph of ``skeleton`` (junction clusters merged) without loops around small
    obstacles and without medial-axis spurs; ``free`` and ``clearance_m`` (metres;
    overwritten, the work space of the clearances in pixels) of the same pixels, ``res``
    metres per pixel."""
    clearance_px = np.divide(clearance_m, np.float32(res), out=clearance_m)
    work = WorkGraph.from_store(
        skeleton_graph_store(skeleton, resolution_m=res, merge_junction_clusters=True)
    )
    collapse_loops(
        work,
        face_labels(skeleton),
        free,
        clearance_px,
        cfg.loop_m / res,
        cfg.loop_clearance_factor,
        cfg.small_obstacle_m / res + 2.0 * cfg.robot_radius_m / res,
    )
    work.contract_all()
    # the clearance past the robot's radius, in place (image-sized)
    feasible_clear = np.subtract(
        clearance_px, np.float32(cfg.robot_radius_m / res), out=clearance_px
    )
    np.maximum(feasible_clear, 0, out=feasible_clear)
    drop_spurs(work, feasible_clear, cfg.spur_m / res, cfg.spur_clearance_factor)
    work.contract_all()
    return work


def _assemble(work: WorkGraph, occupancy, win: _Window, cfg: RouteGraphConfig, clearance_m):
    """The networkx graph of ``work`` (in the pixels of the window ``win``) with
    :func:`topojax.build_graph`'s schema, in the map's pixels; ``clearance_m``: the
    window's (float32 (h, w), metres), or None to compute the map's."""
    res = win.resolution_m
    shift = np.array(win.origin, np.int32)
    alive = [v for v in range(len(work.pixel)) if v not in work.dead]
    alive.sort(key=lambda v: work.pixel[v])
    new_id = {v: k for k, v in enumerate(alive)}
    pix = np.array([work.pixel[v] for v in alive], np.int64).reshape(-1, 2) + shift
    # the clearance at map pixel p is clearance_m[p - off]: the window's, or the map's
    off = shift.astype(np.int64)
    if clearance_m is None:
        clearance_m = clearance_map_m(np.asarray(occupancy.free, bool), res)
        off = np.zeros(2, np.int64)
    clear_at = clearance_m[pix[:, 0] - off[0], pix[:, 1] - off[1]].astype(np.float64).tolist()
    wx, wy = occupancy.pixel_to_world(pix[:, 0], pix[:, 1])
    degree = work.degrees()
    # each vertex's members are a consecutive piece of those of all, shifted at once
    members = [work.members[v] for v in alive]
    m_sizes = np.array([len(m) for m in members], np.int64)
    m_hi = np.cumsum(m_sizes)
    every_member = (np.concatenate(members) if members else np.zeros((0, 2), np.int32)) + shift
    pixels_of = [
        every_member[i:j] for i, j in zip((m_hi - m_sizes).tolist(), m_hi.tolist(), strict=True)
    ]
    node_attrs = []
    for v, p, x, y, c, px in zip(
        alive, pix.tolist(), wx.tolist(), wy.tolist(), clear_at, pixels_of, strict=True
    ):
        deg = degree[v]
        loop_only = deg == 2 and len(work.adj[v]) == 1
        kind = "ring" if loop_only else ("isolated", "end", "junction", "junction")[min(deg, 3)]
        node_attrs.append(
            {
                "pixel": (p[0], p[1]),
                "pixels": px,
                "world": (x, y),
                "kind": kind,
                "clearance_m": c,
            }
        )
    tol_px = cfg.waypoint_tolerance_m / res
    order, ends, paths = [], [], []
    for e, (u, v, path) in work.edges.items():
        a, b = new_id[u], new_id[v]
        if a > b:
            a, b, path = b, a, path[::-1]
        order.append((a, b, len(order)))
        ends.append(e)
        paths.append(path)
    ab = [(a, b) for a, b, _ in order]  # by edge, before the sort
    order.sort()
    sizes = np.array([len(p) for p in paths], np.int64)
    starts = np.cumsum(sizes) - sizes
    every = (np.concatenate(paths) if paths else np.zeros((0, 2), np.int32)).astype(np.int32)
    kept = simplify_paths(every.astype(np.int64), starts, sizes, win.any_feasible, tol_px)
    every += shift.astype(np.int32)
    x, y = occupancy.pixel_to_world(every[:, 0], every[:, 1])
    world_all = np.stack([x, y], axis=1)
    clear = clearance_m[every[:, 0] - off[0], every[:, 1] - off[1]].astype(np.float64)
    del clearance_m
    c_min = (np.minimum.reduceat(clear, starts) if paths else clear).tolist()
    c_mean = (np.add.reduceat(clear, starts) / sizes if paths else clear).tolist()
    # each edge's arrays are consecutive pieces of the arrays of all edges
    lo, hi = starts.tolist(), (starts + sizes).tolist()
    n_kept = np.add.reduceat(kept.astype(np.int64), starts) if paths else starts
    wp_hi = np.cumsum(n_kept)
    wp_lo, wp_hi = (wp_hi - n_kept).tolist(), wp_hi.tolist()
    waypoints_all = world_all[kept]
    path_of = [every[i:j] for i, j in zip(lo, hi, strict=True)]
    world_of = [world_all[i:j] for i, j in zip(lo, hi, strict=True)]
    waypoints_of = [waypoints_all[i:j] for i, j in zip(wp_lo, wp_hi, strict=True)]
    _from_vertex_to_vertex(waypoints_of, every, starts, sizes, ab, pix, np.stack([wx, wy], 1))
    length_of = [work.length[e] * res for e in ends]
    edges = [
        (
            a,
            b,
            {
                "path": path_of[k],
                "world": world_of[k],
                "length_m": length_of[k],
                "min_clearance_m": c_min[k],
                "mean_clearance_m": c_mean[k],
                "waypoints": waypoints_of[k],
            },
        )
        for a, b, k in order
    ]
    attrs = {
        "resolution_m": res,
        "shape": win.map_shape,
        "merge_junction_clusters": True,
        "origin": tuple(float(o) for o in occupancy.origin),
        "robot_radius_m": cfg.robot_radius_m,
        "snap_m": cfg.snap_m,
        "min_region_m2": cfg.min_region_m2,
        "kind": "route_graph",
    }
    return fill_multigraph(attrs, range(len(alive)), node_attrs, edges)


def _from_vertex_to_vertex(waypoints_of, every, starts, sizes, ab, pix, vertex_xy) -> None:
    """Make each edge's waypoints start at its ``u``'s world position and end at its
    ``v``'s, in place: a path ending at another pixel of a merged junction cluster than
    the vertex's gets the hop to the vertex (two pixels of one cluster, both feasible)."""
    if not waypoints_of:
        return
    ab = np.asarray(ab, np.int64).reshape(-1, 2)
    off_u = (every[starts] != pix[ab[:, 0]]).any(axis=1)
    off_v = (every[starts + sizes - 1] != pix[ab[:, 1]]).any(axis=1)
    for k in np.flatnonzero(off_u | off_v).tolist():
        head = [vertex_xy[ab[k, 0]][None]] if off_u[k] else []
        tail = [vertex_xy[ab[k, 1]][None]] if off_v[k] else []
        waypoints_of[k] = np.concatenate([*head, waypoints_of[k], *tail])
