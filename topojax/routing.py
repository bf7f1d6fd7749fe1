"""Routes on a topology graph from a start point to a goal point: each is snapped to the
nearest pixel of the graph's corridors (or, with the map, to the best point in sight),
then the route runs along the graph, shortest by ``length_m``.  Works on any graph with
edge ``path``, ``world`` and ``length_m`` (``docs/routing-and-nav2.md``).
"""

from __future__ import annotations

import heapq
import math

import networkx as nx
import numpy as np

from ._route import Route, WallDistance, narrowest_m, recorded_clearance_m
from ._sight import sees as _sees
from ._snap import TIE as _TIE
from ._snap import Snap as _Snap
from ._snap import SnapLimitError, check_box_gap, check_resolved, warn_unchecked_grid
from ._validate import (
    finite_pair,
    nonnegative_metres,
    one_of,
    plain_length_m,
    real_array,
    real_values,
    robot_radius,
    summable_lengths_m,
)
from .graph import (
    cumulative_length_m,
    graph_resolution_m,
    holds,
    pixel_less,
    scaled_cumulative,
)
from .graph.geometry import check_corridor_graph, why_empty
from .io import as_multigraph
from .maps import map_argument
from .maps.occupancy import map_mismatch

__all__ = [
    "DEFAULT_ENTRY_M",
    "DEFAULT_MAX_SNAP_M",
    "NoRouteError",
    "Route",
    "RoutePlanner",
    "plan_route",
]

_FRAMES = ("world", "pixel")

#: Default limit of :meth:`RoutePlanner.route` / :func:`plan_route` on the distance from a
#: query point to the graph, metres: a point farther off (a goal in a room the graph does
#: not reach, or coordinates in the wrong frame) is an error, not a silent long snap.
DEFAULT_MAX_SNAP_M = 5.0

#: Default reach (metres) of a route joining the graph away from the nearest point, for a
#: planner given the map and a graph without a ``snap_m`` attribute.
DEFAULT_ENTRY_M = 1.0

# Candidate entry points whose sight lines are drawn at once.
_ENTRY_BATCH = 256

# The first ring (metres) joins in sight are looked for within, and how much each next
# one is wider, up to the reach.
_FIRST_RING_M = 1.0
_RING_GROWTH = 4.0


class NoRouteError(nx.NetworkXNoPath):
    """The start and goal snap to parts of the graph that no corridor connects."""


class RoutePlanner:
    """Shortest routes between points on one topology graph.

    Builds the lookup structures once (a k-d tree of the corridor pixels per frame, the
    edges' cumulative lengths, the vertex adjacency); each :meth:`route` then costs a
    nearest-neighbour query per point (with the map, also range queries and the sight
    lines to the edges in rings that grow within reach until no join beyond could give
    a shorter route) and a Dijkstra search that stops once no unsettled vertex can beat
    the best route found.

    Parameters
    ----------
    graph : networkx.MultiGraph
        Topology graph (see the module docstring for what its edges must carry).  It is
        read, not modified; build a new planner after changing it.
    occupancy : OccupancyMap, optional
        The graph's map.  With it, each end of a route joins the graph at the nearest
        point of any edge it sees within ``entry_m`` (along a straight line over pixels
        where the robot fits), whichever gives the shortest route in all (the straight
        legs included); an end that sees no edge so within ``entry_m`` (a robot closer to
        a wall than its radius, a goal beyond the graph's reach) joins one it sees along a
        straight line over pixels that are not occupied, up to ``entry_m`` farther than
        the nearest point and within ``max_snap_m`` (the route's ``start_leg_feasible``
        or ``goal_leg_feasible`` is then False), and an end that sees none so is an
        error (:meth:`route`).  The route's ``min_clearance_m`` is then measured on the
        map along the pixels the route runs along (the map's distance to the nearest
        wall, kept from the feasible space for a route graph, else computed on the first
        route and kept: 4 bytes a pixel).  Without the map every end joins at the
        nearest corridor point, and ``min_clearance_m`` is the edges' recorded one, the
        first and last edge counted whole.
    robot_radius_m : float, optional
        Robot radius, metres, that each route records (its ``robot_radius_m``, for a
        comparison with its ``min_clearance_m``); with the map, also the radius of those
        straight legs, default the graph's ``robot_radius_m`` attribute (a route
        graph's).  Without the map nothing is known of the legs (``start_leg_feasible``
        and ``goal_leg_feasible`` stay None) and there is no default.
    entry_m : float, optional
        Reach of those legs, metres; default the graph's ``snap_m`` attribute, else
        :data:`DEFAULT_ENTRY_M`.

    Raises
    ------
    TypeError
        ``graph`` is not an undirected networkx graph (a plain ``networkx.Graph`` is read
        as a MultiGraph with edge keys 0), ``occupancy`` is not an OccupancyMap, or an
        edge's ``min_clearance_m`` is not a number.
    ValueError
        An edge lacks ``path``, ``world`` or ``length_m`` (a room graph is named as one),
        or its path does not start and end at its vertices; the lengths add up to over
        4.5e307 m; ``occupancy`` is not the graph's map (shape, resolution, origin); no
        robot radius is given or known with ``occupancy``; ``entry_m`` without
        ``occupancy``; a ``robot_radius_m`` larger than the route graph was built for.

    Warns
    -----
    UserWarning
        ``occupancy`` for a graph that lacks some of ``shape``, ``resolution_m`` and
        ``origin`` (named): the map is checked by those it records only.
    """

    def __init__(
        self,
        graph: nx.Graph,
        *,
        occupancy=None,
        robot_radius_m: float | None = None,
        entry_m: float | None = None,
    ) -> None:
        graph = as_multigraph(graph)  # a plain Graph: its edges get key 0
        check_corridor_graph(graph)  # a room graph, say, is named as one
        self._graph = graph
        self._res = graph_resolution_m(graph)
        self._occupancy = occupancy
        space, self._entry_m, self._radius = self._entry_space(occupancy, robot_radius_m, entry_m)
        self._feasible = None if space is None else space.feasible
        # with the map, the pixels a leg from a point the robot does not fit at may cross
        self._clear = None if occupancy is None else ~np.asarray(occupancy.occupied, bool)
        self._nodes = list(graph.nodes)
        # Per edge: node ids at the start and end of its path, key, path, world, the
        # cumulative length along the path from its start, its length and its narrowest
        # clearance (NaN: not recorded).
        self._u: list = []
        self._v: list = []
        self._key: list = []
        self._path: list[np.ndarray] = []
        self._world: list[np.ndarray] = []
        self._len: list[float] = []
        self._min_clear: list[float] = []
        for a, b, key, data in graph.edges(keys=True, data=True):
            path, world, length = self._edge_arrays(a, b, key, data)
            a, b = self._oriented(a, b, key, path)
            self._u.append(a)
            self._v.append(b)
            self._key.append(key)
            self._path.append(path)
            self._world.append(world)
            self._len.append(length)
            where = f"edge ({a!r}, {b!r}, {key!r})"
            self._min_clear.append(recorded_clearance_m(data, "min_clearance_m", where))
        summable_lengths_m("graph: the edges' 'length_m'", self._len)  # sums stay finite
        # where each edge's pixels start in the edges' paths (or polylines) one after another
        self._sizes = np.array([len(p) for p in self._path], np.int64)
        self._starts = np.concatenate([[0], np.cumsum(self._sizes)[:-1]]).astype(np.int64)
        self._cum = self._cumulative()
        # Adjacency by node: neighbour -> (length, edge index), the shortest of parallel
        # edges (self-loops never shorten a route between two vertices).
        self._adj: dict = {n: {} for n in self._nodes}
        for i, (a, b) in enumerate(zip(self._u, self._v, strict=True)):
            if a == b:
                continue
            for x, y in ((a, b), (b, a)):
                best = self._adj[x].get(y)
                if best is None or self._len[i] < best[0]:
                    self._adj[x][y] = (self._len[i], i)
        # Vertices without edges lead nowhere (pruning leaves them where a corridor was too
        # narrow): points snap to the corridors; only a graph without edges is snapped to
        # its vertices (a route of length 0 to itself).
        self._lonely = (
            []
            if self._path
            else [(i, n) for i, n in enumerate(self._nodes) if graph.degree(n) == 0]
        )
        self._trees: dict = {}
        self._tree_px: dict = {}  # per frame, the tree points' pixels (with the map)
        self._walls: WallDistance | None = None  # with the map: a route graph's, else lazy
        if space is not None and graph.graph.get("kind") == "route_graph":
            res = space.resolution_m if self._res is None else self._res
            if np.float32(res) == np.float32(space.resolution_m):  # the clearance's scale
                self._walls = WallDistance.of_clearance_m(space.clearance_m)

    def __repr__(self) -> str:
        entry = "" if self._occupancy is None else f", entry_m={self._entry_m!r}"
        return (
            f"RoutePlanner(vertices={len(self._nodes)}, edges={len(self._path)}, "
            f"with_map={bool(entry)}, robot_radius_m={self._radius!r}{entry})"
        )

    # ------------------------------------------------------------------ public
    def route(
        self, start, goal, *, frame: str = "world", max_snap_m: float | None = DEFAULT_MAX_SNAP_M
    ) -> Route:
        """The shortest route from ``start`` to ``goal`` along the graph.

        Parameters
        ----------
        start, goal : pair of float
            Query points: ``(x, y)`` in metres with ``frame="world"`` (the map's world
            frame, as the graph's ``world`` attributes), ``(row, col)`` in pixels with
            ``frame="pixel"``.
        frame : {"world", "pixel"}
        max_snap_m : float, optional
            Largest allowed distance from a query point to the graph, metres; a point
            farther away raises ``ValueError`` (e.g. a goal in a room the graph does not
            reach).  Default :data:`DEFAULT_MAX_SNAP_M` (5 m); ``None`` or inf: no limit,
            but a point over 1e5 m (pixels) off, where float distances no longer tell the
            graph's points apart, is refused all the same.

        Returns
        -------
        Route

        Raises
        ------
        NoRouteError
            The snapped start and goal lie in different components of the graph (a
            subclass of :class:`networkx.NetworkXNoPath`).
        ValueError
            Bad ``start``, ``goal``, ``frame`` or ``max_snap_m`` (``TypeError`` for a
            ``max_snap_m`` that is not a number, or a vertex's ``clearance_m`` that is not
            one on a route along no edge); a point beyond ``max_snap_m``; with the
            map, a point on an occupied pixel, or one that sees no point of the graph
            along a straight line off the obstacles (a closet the graph does not reach);
            a graph without vertices.
        """
        one_of("frame", frame, _FRAMES)
        if max_snap_m is not None and max_snap_m != math.inf:  # both: no limit
            max_snap_m = nonnegative_metres("max_snap_m", max_snap_m)
        # a join farther than max_snap_m would be dropped: none is looked for
        reach = self._entry_m if max_snap_m is None else min(self._entry_m, max_snap_m)
        # Joins in sight are looked for in growing rings: a join d metres off costs at
        # least d less the nearest join's distance, so once a route costs less than that
        # at the ring's edge, no join beyond it can give a shorter one.
        ring = min(reach, _FIRST_RING_M)
        while True:
            last = ring >= reach
            s = self._snaps(start, frame, "start", ring, max_snap_m, last=last)
            g = None if s is None else self._snaps(goal, frame, "goal", ring, max_snap_m, last=last)
            found, needed = (None, 0.0) if g is None else self._ring_route(s, g, max_snap_m, last)
            if found is not None and (last or needed < ring):
                return found
            ring = min(reach, max(_RING_GROWTH * ring, 1.25 * needed))

    def _ring_route(self, s: list[_Snap], g: list[_Snap], max_snap_m, last: bool):
        """The route between the joins ``s`` and ``g`` found within a ring (the whole
        reach when ``last``), and the ring beyond which no join can shorten it (metres);
        ``(None, 0.0)`` when they do not connect within a ring short of the reach."""
        # joins in sight lie within the reach; the nearest points are all as far as the first
        for name, snaps in (("start", s), ("goal", g)):
            if max_snap_m is not None and snaps[0].distance_m > max_snap_m:
                raise SnapLimitError(name, snaps[0].distance_m, max_snap_m)
        try:
            route = self._route(s, g)
        except NoRouteError:
            if last:  # no farther join to try
                raise
            return None, 0.0
        s0, g0 = s[0].distance_m, g[0].distance_m
        cost = (route.start_snap_m - s0) + route.length_m + (route.goal_snap_m - g0)
        return route, (cost + max(s0, g0)) * (1 + 1e-9) + _TIE

    # ------------------------------------------------------------------ internals
    def _entry_space(self, occupancy, radius, entry_m):
        """The feasible space (its pixels are those a route may cross to join the graph
        away from its nearest point), how far (metres) it may go to do so and the robot
        radius (metres); ``(None, 0.0, robot_radius_m)`` without a map (None when not
        given)."""
        if occupancy is None:
            if entry_m is not None:
                raise ValueError("entry_m: only used with occupancy=, which was not given")
            if radius is not None:  # the route's robot only: no leg can be checked
                from .routegraph.feasible import check_radius_within_graphs

                radius = robot_radius("robot_radius_m", radius)
                check_radius_within_graphs(self._graph.graph, radius)
            return None, 0.0, radius
        if not all(
            hasattr(occupancy, a) for a in ("free", "resolution_m", "origin", "world_to_pixel")
        ):
            map_argument("occupancy", occupancy)  # not one: its TypeError names what to pass
        attrs = self._graph.graph
        why = map_mismatch(self._graph, occupancy)
        if why is not None:
            raise ValueError(f"occupancy: {why}")
        warn_unchecked_grid(attrs)
        radius_name = "robot_radius_m"
        if radius is None:
            radius = attrs.get("robot_radius_m")
            if radius is None:
                raise ValueError(
                    "robot_radius_m: expected the robot radius in metres with occupancy= "
                    "(the graph has no 'robot_radius_m' attribute), received None"
                )
            radius_name = "robot_radius_m (the graph's 'robot_radius_m' attribute)"
        from .routegraph.feasible import check_radius_within_graphs, feasible_space

        radius = robot_radius(radius_name, radius)
        check_radius_within_graphs(attrs, radius)
        if entry_m is None:
            entry_m = attrs.get("snap_m")
            entry_m = DEFAULT_ENTRY_M if entry_m is None else entry_m
            entry_m = nonnegative_metres("entry_m (the graph's 'snap_m' attribute)", entry_m)
        entry_m = nonnegative_metres("entry_m", entry_m)
        return feasible_space(occupancy, radius), entry_m, radius

    def _snaps(
        self, point, frame: str, name: str, reach_m: float, max_snap_m, *, last: bool = True
    ) -> list[_Snap] | None:
        """The points where a route from ``point`` may join the graph, nearest first: with
        the map, each edge's nearest point that ``point`` sees within ``reach_m`` (metres;
        see :meth:`route` for the frames) over feasible pixels, else (a point the robot
        does not fit at, or beyond reach) over pixels off the obstacles up to ``entry_m``
        farther than the nearest point and within ``max_snap_m``, else a ValueError
        (without ``last``, a ring short of the reach: None instead of either); without
        the map, every corridor point as near as the nearest one (within
        :data:`_TIE`: one, or one per edge through the pixel where edges cross)."""
        what = "(x, y) in metres" if frame == "world" else "(row, col) in pixels"
        q = finite_pair(name, point, what)
        if self._occupancy is not None:
            self._check_off_obstacles(q, frame, name)
        tree, owners = self._tree(frame)
        scale = 1.0 if frame == "world" else self._pixel_size_m()
        check_box_gap(name, q, tree, scale, frame)
        dist, k = tree.query(q)
        nearest_m = float(dist) * scale
        cap = math.inf if max_snap_m is None else max_snap_m
        if nearest_m <= cap:  # else the snap limit refuses it
            check_resolved(name, q, float(dist), scale, frame)
        if self._feasible is not None and nearest_m <= cap:
            # a join exactly the reach away within it, and the nearest point itself within
            # the second reach, whatever the rounding of the query's coordinates
            near = reach_m * (1 + 1e-12) + _TIE
            wide = (nearest_m + self._entry_m) * (1 + 1e-12) + _TIE
            legs = ((True, self._feasible, near), (False, self._clear, min(wide, cap)))
            for fits, mask, reach in legs:  # the fallback's legs do not fit the robot
                entries = self._entries(q, frame, scale, reach, mask)
                seen = [self._snap(owners[i], d, fits) for i, d in entries]
                if seen:  # a clear leg exists: none through a wall to a nearer point
                    return seen
                if not last:  # farther rings first
                    return None
            raise ValueError(
                f"{name}: expected a point that sees the graph along a straight line off the "
                f"map's obstacles, received {tuple(float(v) for v in q)} ({frame} frame), "
                f"whose nearest point of the graph, {nearest_m:.6g} m away, is behind an "
                f"obstacle or off the map, as is every other within {reach:.6g} m (a point "
                "in a pocket the graph does not reach)"
            )
        near = sorted(set(tree.query_ball_point(q, float(dist) + _TIE)) | {int(k)})
        return [self._snap(owners[i], nearest_m) for i in near]

    def _check_off_obstacles(self, q: np.ndarray, frame: str, name: str) -> None:
        """With the map, a query point on an occupied pixel is an error (a robot inside a
        wall: a localisation fault, or a goal picked on a wall), not a route from the
        nearest corridor."""
        _, (r, c) = self._query_pixel(q, frame)
        occupied = self._occupancy.occupied
        if 0 <= r < occupied.shape[0] and 0 <= c < occupied.shape[1] and occupied[r, c]:
            raise ValueError(
                f"{name}: expected a point off the map's obstacles, received "
                f"{tuple(float(v) for v in q)} ({frame} frame), on the occupied pixel "
                f"({r}, {c})"
            )

    def _query_pixel(self, q: np.ndarray, frame: str) -> tuple[np.ndarray, tuple[int, int]]:
        """Query ``q`` in the map's pixel coordinates (float64 (2,)) and the pixel it
        rounds to (halves up), ``(-1, -1)`` for a point so far off the map that it has no
        pixel (the distance check refuses it)."""
        with np.errstate(over="ignore", invalid="ignore"):
            qp = q if frame == "pixel" else np.array(self._occupancy.world_to_pixel(*q), np.float64)
            own = np.floor(qp + 0.5)
        if not np.isfinite(own).all():
            return qp, (-1, -1)
        return qp, (int(own[0]), int(own[1]))

    def _snap(self, owner, distance_m: float, feasible: bool | None = None) -> _Snap:
        edge, index, vertex = (int(x) for x in owner)
        node = self._nodes[vertex] if edge < 0 else None
        return _Snap(edge, index, node, distance_m, feasible)

    def _entries(
        self, q: np.ndarray, frame: str, scale: float, reach_m: float, mask: np.ndarray
    ) -> list[tuple[int, float]]:
        """``(tree point, distance m)`` of each edge's (or edgeless vertex's) nearest
        corridor points within ``reach_m`` of query ``q`` that the robot reaches along
        a straight line over pixels set in ``mask`` (bool (H, W)): every pixel the line
        passes through (:func:`topojax._sight.sees`); every one as near as the edge's
        nearest (within :data:`_TIE`), as without the map, where the route may leave by
        either.  Candidates are tried nearest first, a batch at a time, skipping points
        farther than an edge's join (bounded memory for any reach)."""
        tree, owners = self._tree(frame)
        qp, (r, c) = self._query_pixel(q, frame)
        h, w = mask.shape
        if not (0 <= r < h and 0 <= c < w and mask[r, c]):
            return []  # every line would start off the map or on a pixel it may not cross
        cand = np.asarray(tree.query_ball_point(q, reach_m / scale), np.int64)
        if cand.size == 0:
            return []
        delta = tree.data[cand] - q
        dist = np.sqrt(delta[:, 0] * delta[:, 0] + delta[:, 1] * delta[:, 1]) * scale
        order = np.lexsort((cand, dist))
        cand, dist = cand[order], dist[order]
        key = np.where(owners[cand, 0] >= 0, owners[cand, 0], len(self._u) + owners[cand, 2])
        out: list[tuple[int, float]] = []
        # per edge (then edgeless vertex), the distance (m) it is joined at: inf until it is
        joined = np.full(len(self._u) + len(self._nodes), np.inf)
        for b in range(0, cand.size, _ENTRY_BATCH):
            sel = np.arange(b, min(b + _ENTRY_BATCH, cand.size))
            sel = sel[dist[sel] <= joined[key[sel]] + _TIE]  # no point farther than a join
            if sel.size == 0:
                continue
            seen = _sees(mask, qp, self._pixels_of(cand[sel], frame))
            for i in sel[seen].tolist():  # nearest first
                e = int(key[i])
                joined[e] = min(joined[e], dist[i])
                if dist[i] <= joined[e] + _TIE:
                    out.append((int(cand[i]), float(dist[i])))
        return out

    def _pixels_of(self, points: np.ndarray, frame: str) -> np.ndarray:
        """Pixel coordinates (float64 (K, 2)) of tree points: an edge's path pixel, or an
        edgeless vertex's position (in the world frame, its world position mapped onto
        the map's grid)."""
        if frame not in self._tree_px:
            parts = [np.concatenate(self._path).astype(np.float64)] if self._path else []
            for _, n in self._lonely:
                data = self._graph.nodes[n]
                if frame == "pixel":
                    parts.append(np.asarray(data["pixel"], np.float64).reshape(1, 2))
                else:
                    x, y = data["world"][:2]
                    parts.append(np.array(self._occupancy.world_to_pixel(x, y)).reshape(1, 2))
            self._tree_px[frame] = np.concatenate(parts) if parts else np.zeros((0, 2))
        return self._tree_px[frame][points]

    def _edge_arrays(self, a, b, key, data):
        where = f"edge ({a!r}, {b!r}, {key!r})"
        given = np.asarray(data["path"])  # each edge has the three: check_corridor_graph
        path = real_values(given)  # int4 as int8; bfloat16 as float32, refused below
        world = real_array(f"graph: {where}: 'world'", data["world"], finite=True)
        length = data["length_m"]
        length = (
            float(length)
            if plain_length_m(length)
            else nonnegative_metres(f"graph: {where}: 'length_m'", length)
        )
        if (
            path.ndim != 2
            or path.shape[1] != 2
            or len(path) < 1
            or world.shape != path.shape
            or not np.issubdtype(path.dtype, np.integer)
        ):
            raise ValueError(
                f"graph: {where}: expected an integer 'path' of shape (n, 2) and a 'world' of "
                f"the same shape, received {given.dtype} {path.shape} and {world.shape}"
            )
        return path.astype(np.int64), world, length

    def _oriented(self, a, b, key, path):
        """``(a, b)`` such that ``path`` runs from vertex ``a`` to vertex ``b``."""
        first, last = path[0], path[-1]
        if self._holds(a, first) and self._holds(b, last):
            return a, b
        if self._holds(b, first) and self._holds(a, last):
            return b, a
        raise ValueError(
            f"graph: the path of edge ({a!r}, {b!r}, {key!r}) runs from "
            f"{tuple(first.tolist())} to {tuple(last.tolist())}, which are not the pixels of "
            f"its vertices{pixel_less(self._graph, (a, b))}"
        )

    def _holds(self, node, pixel) -> bool:
        return holds(self._graph.nodes[node], pixel, f"graph: vertex {node!r}")

    def _cumulative(self) -> list[np.ndarray]:
        """Per edge, the length along its path from its start to each pixel, metres,
        counting straight and diagonal steps as ``length_m`` does (one pass over all
        paths); the last entry is the edge's own ``length_m``."""
        if not self._path:
            return []
        sizes, starts = self._sizes, self._starts
        pixels = np.concatenate(self._path)
        cum = cumulative_length_m(pixels, starts, sizes, self._pixel_size_m())
        # Along each edge, its pixel steps in proportion to its length_m: the same numbers
        # for a graph as built (length_m is the step sum), and for an edge whose length_m
        # a user re-weighted, partial traversals cost their share of it (never less than
        # zero, and the whole edge exactly length_m).
        return np.split(scaled_cumulative(cum, starts, sizes, self._len), starts[1:])

    def _pixel_size_m(self) -> float:
        if self._res is not None:
            return self._res
        for path, world in zip(self._path, self._world, strict=True):
            if len(path) > 1:
                return _step_size(path, world)
        raise ValueError(
            "graph: frame='pixel' needs the graph attribute 'resolution_m' (metres per "
            "pixel) to report distances in metres, and this graph has none"
        )

    def _tree(self, frame: str):
        if frame not in self._trees:
            from scipy.spatial import cKDTree

            points = list(self._world if frame == "world" else self._path)
            sizes, starts = self._sizes, self._starts  # polylines as long as the paths
            edge = np.repeat(np.arange(len(points)), sizes)
            owners = [np.stack([edge, np.arange(len(edge)) - starts[edge], -np.ones_like(edge)], 1)]
            for i, n in self._lonely:
                data = self._graph.nodes[n]
                where = data.get("world") if frame == "world" else data.get("pixel")
                if where is None:
                    raise ValueError(
                        f"graph: vertex {n!r} has no {'world' if frame == 'world' else 'pixel'} "
                        "attribute"
                    )
                points.append(np.asarray(where, np.float64).reshape(1, 2))
                owners.append(np.array([[-1, 0, i]]))
            if not points:
                raise ValueError(f"graph: no vertices or edges to route on{why_empty(self._graph)}")
            xy = np.concatenate([np.asarray(p, np.float64) for p in points])
            self._trees[frame] = (cKDTree(xy), np.concatenate(owners).astype(np.int64))
        return self._trees[frame]

    def _ends(self, snaps: list[_Snap]) -> dict:
        """Graph vertices a route can leave the snapped point through: vertex -> (cost,
        length along the snapped edge to it, the snap), the cheapest over ``snaps``; the
        cost is that length plus how much longer the straight leg to the snap is than the
        one to the nearest point (exactly 0 without the map: the same sums as routes on
        the graph alone)."""
        ends: dict = {}
        nearest = snaps[0].distance_m

        def offer(n, along: float, snap: _Snap) -> None:
            cost = (snap.distance_m - nearest) + along
            if n not in ends or cost < ends[n][0]:
                ends[n] = (cost, along, snap)

        for snap in snaps:
            if snap.edge < 0:
                offer(snap.vertex, 0.0, snap)
                continue
            e = snap.edge
            to_start = float(self._cum[e][snap.index])
            offer(self._u[e], to_start, snap)
            offer(self._v[e], self._len[e] - to_start, snap)
        return ends

    def _direct(self, ss: list[_Snap], gs: list[_Snap]):
        """The cheapest way between a start and a goal snap without passing a vertex:
        ``(cost, plan)`` or ``(inf, None)``; the cost counts both straight legs beyond the
        nearest ones (as :meth:`_ends`)."""
        best, plan = math.inf, None
        for s in ss:
            for g in gs:
                legs = (s.distance_m - ss[0].distance_m) + (g.distance_m - gs[0].distance_m)
                if s.edge >= 0 and s.edge == g.edge:
                    d = abs(float(self._cum[s.edge][g.index]) - float(self._cum[s.edge][s.index]))
                    if legs + d < best:
                        best, plan = legs + d, ("direct", s, g, d)
                elif s.edge < 0 and g.edge < 0 and s.vertex == g.vertex and legs < best:
                    best, plan = legs, ("vertex", s, g, 0.0)
        return best, plan

    def _route(self, ss: list[_Snap], gs: list[_Snap]) -> Route:
        # The direct way along one edge.
        best, plan = self._direct(ss, gs)
        # Through the graph: Dijkstra from the start's edge ends (with their offsets),
        # until no unsettled vertex can beat the best route found.  Heap entries carry
        # how they were reached, so each settled vertex knows its predecessor.
        sources, targets = self._ends(ss), self._ends(gs)
        parent: dict = {}
        heap = [(d, i, n, None, -1, a) for i, (n, (d, a, _)) in enumerate(sources.items())]
        heapq.heapify(heap)
        tie = len(heap)
        reached, length = None, 0.0
        while heap:
            d, _, n, via, e, along = heapq.heappop(heap)  # along: length on the graph
            if n in parent:
                continue
            if d >= best:
                break
            parent[n] = (via, e)
            if n in targets and d + targets[n][0] < best:
                best = d + targets[n][0]
                reached, length = n, along + targets[n][1]
                plan = ("graph",)
            for m, (w, e2) in self._adj[n].items():
                if m not in parent and d + w < best:
                    tie += 1
                    heapq.heappush(heap, (d + w, tie, m, n, e2, along + w))
        if plan is None:
            raise NoRouteError(
                f"no route from the start (snapped to {self._where(ss[0])}) to the goal "
                f"(snapped to {self._where(gs[0])}): they lie in different components of the "
                "graph"
            )
        if plan[0] == "vertex":
            return self._assemble([], [], 0.0, plan[1], plan[2])
        if plan[0] == "direct":
            s, g = plan[1], plan[2]
            return self._assemble([(s.edge, s.index, g.index)], [], plan[3], s, g)
        chain, hops = [reached], []
        while parent[chain[-1]][0] is not None:
            via, e = parent[chain[-1]]
            hops.append(e)
            chain.append(via)
        chain.reverse()
        hops.reverse()
        (_, d0, s), (_, d1, g) = sources[chain[0]], targets[chain[-1]]
        pieces = []
        if s.edge >= 0:
            pieces.append(self._partial(s.edge, s.index, chain[0], d0))
        for a, e in zip(chain[:-1], hops, strict=True):
            pieces.append((e, 0, -1) if self._u[e] == a else (e, -1, 0))
        if g.edge >= 0:
            e, index, end_ = self._partial(g.edge, g.index, chain[-1], d1)
            pieces.append((e, end_, index))  # from the vertex to the goal
        return self._assemble(pieces, chain, length, s, g)

    def _partial(self, e: int, index: int, vertex, along: float):
        """The piece of edge ``e`` from position ``index`` to its end at ``vertex`` (the
        end ``along`` metres away: the nearer one when both ends are that vertex)."""
        n = len(self._path[e])
        to_start = float(self._cum[e][index])
        if self._u[e] == vertex and (self._v[e] != vertex or to_start == along):
            return (e, index, 0)
        return (e, index, n - 1)

    def _assemble(self, pieces, vertices, length, s: _Snap, g: _Snap) -> Route:
        rows: list[np.ndarray] = []
        xys: list[np.ndarray] = []
        edges: list[tuple] = []
        along: list[int] = []  # the edges run along, by index
        last = None
        for e, i, j in pieces:
            n = len(self._path[e])
            i, j = i % n, j % n
            step = 1 if j >= i else -1
            sl = slice(i, j + step if j + step >= 0 else None, step)
            p, w = self._path[e][sl], self._world[e][sl]
            if last is not None and last[0] == p[0, 0] and last[1] == p[0, 1]:
                p, w = p[1:], w[1:]  # the shared vertex pixel once
            if len(p):
                last = p[-1]
            rows.append(p)
            xys.append(w)
            if i != j:  # the piece runs along the edge (not only its end pixel)
                edges.append((self._u[e], self._v[e], self._key[e]))
                along.append(e)
        if not rows:  # start and goal on the same vertex without edges
            data = self._graph.nodes[s.vertex]
            pixel = np.asarray(data.get("pixel", (0, 0)), np.int64).reshape(1, 2)
            world = np.asarray(data.get("world", (np.nan, np.nan)), np.float64).reshape(1, 2)
            rows, xys = [pixel], [world]
        pixels = np.concatenate(rows).astype(np.int32)
        world = np.concatenate(xys).astype(np.float64)
        clear = math.nan
        if self._occupancy is not None and pieces:  # the pixels it runs along, measured
            clear = self._wall_distance().least_m(pixels)
        if math.isnan(clear):  # without the map (or off it): the edges' recorded values
            clear = self._narrowest(along, vertices, s)
        return Route(
            length_m=float(length),
            pixels=pixels,
            world=world,
            vertices=tuple(vertices),
            edges=tuple(edges),
            start_snap_m=s.distance_m,
            goal_snap_m=g.distance_m,
            start_leg_feasible=s.feasible,
            goal_leg_feasible=g.feasible,
            min_clearance_m=clear,
            robot_radius_m=self._radius,
        )

    def _wall_distance(self) -> WallDistance:
        """The map's distance to the nearest wall, as the graph's clearances measure it
        (a route graph's kept from its feasible space, else computed on the first route)."""
        if self._walls is None:
            res = self._occupancy.resolution_m if self._res is None else self._res
            self._walls = WallDistance.of_map(self._occupancy, self._graph.graph, res)
        return self._walls

    def _narrowest(self, along: list[int], vertices, s: _Snap) -> float:
        """The narrowest clearance (metres) of the edges ``along`` (indices) a route runs
        along; for a route along none, that of the vertices it passes (or the start's
        edgeless vertex), else of the edge it stands on (NaN: not recorded)."""
        if along:
            return narrowest_m(self._min_clear[e] for e in along)
        nodes = list(vertices) if vertices else ([s.vertex] if s.edge < 0 else [])
        if not nodes:
            return self._min_clear[s.edge]
        return narrowest_m(
            recorded_clearance_m(self._graph.nodes[n], "clearance_m", f"vertex {n!r}")
            for n in nodes
        )

    def _where(self, snap: _Snap) -> str:
        if snap.edge < 0:
            return f"vertex {snap.vertex!r}"
        e = snap.edge
        return f"pixel {tuple(int(x) for x in self._path[e][snap.index])} of edge " + repr(
            (self._u[e], self._v[e], self._key[e])
        )


def plan_route(
    graph: nx.Graph,
    start,
    goal,
    *,
    frame: str = "world",
    max_snap_m: float | None = DEFAULT_MAX_SNAP_M,
    occupancy=None,
    robot_radius_m: float | None = None,
    entry_m: float | None = None,
) -> Route:
    """The shortest route from ``start`` to ``goal`` along a topology graph.

    One-off form of ``RoutePlanner(graph, occupancy=..., robot_radius_m=...,
    entry_m=...).route(start, goal, ...)``; build a :class:`RoutePlanner` to ask one graph
    for many routes.

    Parameters
    ----------
    graph : networkx.MultiGraph
        Topology graph (e.g. ``build_graph(m).graph``, pruned or not).
    start, goal : pair of float
        ``(x, y)`` in metres (``frame="world"``) or ``(row, col)`` in pixels
        (``frame="pixel"``).
    frame : {"world", "pixel"}
    max_snap_m : float or None, optional
        Largest allowed distance from a query point to the graph, metres (default
        :data:`DEFAULT_MAX_SNAP_M`, 5 m); ``None`` or inf: no limit.
    occupancy : OccupancyMap, optional
        The graph's map: each end may then join the graph at the nearest point of any
        edge it sees within reach, whichever gives the shortest route (see
        :class:`RoutePlanner`).
    robot_radius_m : float, optional
        The robot radius, metres, which the route records; with ``occupancy`` also that
        of the legs (default the graph's ``robot_radius_m``).
    entry_m : float, optional
        With ``occupancy``: the reach (default the graph's ``snap_m``, else 1 m), metres.

    Returns
    -------
    Route

    Raises
    ------
    NoRouteError, ValueError, TypeError
        As :class:`RoutePlanner` and :meth:`RoutePlanner.route`.

    Examples
    --------
    >>> import topojax as tj
    >>> g = tj.build_graph(tj.sample_map("intel")).graph
    >>> r = tj.plan_route(g, (10.0, 20.0), (30.0, 15.0))
    >>> r.length_m > 0, r.world.shape[1]
    (True, 2)
    """
    planner = RoutePlanner(
        graph, occupancy=occupancy, robot_radius_m=robot_radius_m, entry_m=entry_m
    )
    return planner.route(start, goal, frame=frame, max_snap_m=max_snap_m)


def _step_size(path: np.ndarray, world: np.ndarray) -> float:
    """Metres per pixel from the first step of a path and its world polyline."""
    d_px = math.hypot(*(np.asarray(path[1], float) - path[0]))
    d_m = math.hypot(*(world[1] - world[0]))
    return d_m / d_px
