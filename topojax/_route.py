"""The route :class:`topojax.routing.RoutePlanner` returns, and what it says of the robot's
safety: whether each end's straight leg fits the robot, and the narrowest clearance of
the graph's corridors it runs along."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ._validate import is_real_number, positive_metres
from .graph import polyline_keep
from .io import jsonable


@dataclass(frozen=True, repr=False)
class Route:
    """A route along a topology graph.

    Attributes
    ----------
    length_m : float
        Length along the graph from the snapped start to the snapped goal, metres: the
        sum of the ``length_m`` of the edges (and edge parts) it runs along.  Inside a
        merged junction cluster (a vertex of several pixels) the step from one edge's
        end pixel to the next edge's start pixel costs nothing, as the graph's vertex is
        one point, so there the polyline of ``world`` is a little longer (at most the
        cluster's extent per cluster passed).
    pixels : int32 array, shape (n, 2)
        The skeleton pixels of the route in order, ``[row, col]``; ``pixels[0]`` is the
        snapped start, ``pixels[-1]`` the snapped goal.  Consecutive pixels are
        8-neighbours, except inside a junction cluster merged into one vertex
        (``merge_junction_clusters=True``), where the route goes from the pixel one
        edge ends at to the pixel the next starts at.
    world : float64 array, shape (n, 2)
        ``x, y`` of those pixels in metres.
    vertices : tuple
        Ids of the graph vertices the route passes through, in order (empty when it stays
        on one edge or at one vertex).
    edges : tuple of (u, v, key)
        Graph edges the route runs along, in order, the first and last possibly in part;
        ``u`` is the vertex the edge's ``path`` starts at, whichever way the route runs.
    start_snap_m, goal_snap_m : float
        Distance from the start (goal) query point to ``pixels[0]`` (``pixels[-1]``),
        metres.
    start_leg_feasible, goal_leg_feasible : bool or None
        Planned with the map: True when the straight leg from the start (goal) query
        point to ``pixels[0]`` (``pixels[-1]``) runs over pixels where a robot of
        ``robot_radius_m`` fits; False when no such leg reached the graph and the route
        took the fallback, a leg over pixels that are only not occupied (free or
        unknown), along which the robot may touch an obstacle (a point closer to a wall
        than the radius, or in a pocket narrower than the robot).  None when planned
        without the map: nothing is known of the legs.
    min_clearance_m : float
        Narrowest clearance (distance to the nearest obstacle) along the route's graph
        part, metres.  Planned with the map: the least over the route's ``pixels`` of the
        map's distance to the nearest wall, measured as the graph's clearances are (a
        route graph's: to the nearest pixel that is not known free, the map's outside
        counting as such; any other graph's: to the nearest occupied pixel), so the first
        and last edge count only where the route runs along them, and a route along
        whole edges gets the least ``min_clearance_m`` they record (on a graph without
        edges, or with a route pixel off the map, the recorded values below).  Without
        the map: the least ``min_clearance_m`` of its ``edges``; the graph records one
        value per edge, so the first and last edge count whole, a lower bound (the
        route's own pixels there may be wider), and a route along no edge (one pixel)
        takes the ``clearance_m`` of the vertex it stands at, else the
        ``min_clearance_m`` of the edge it lies on; NaN when any of those is not
        recorded (a graph built without clearances).  Below ``robot_radius_m``, the
        route runs through a corridor narrower than the robot (a topology graph's
        corridors are not chosen for a robot; a route graph's keep its radius).
    robot_radius_m : float or None
        Robot radius the route was planned for, metres (with the map, the legs' too);
        None when planned without the map and without a ``robot_radius_m``.
    """

    length_m: float
    pixels: np.ndarray
    world: np.ndarray
    vertices: tuple
    edges: tuple
    start_snap_m: float
    goal_snap_m: float
    start_leg_feasible: bool | None = field(default=None, kw_only=True)
    goal_leg_feasible: bool | None = field(default=None, kw_only=True)
    min_clearance_m: float = field(default=math.nan, kw_only=True)
    robot_radius_m: float | None = field(default=None, kw_only=True)

    def __repr__(self) -> str:
        # the arrays and id tuples grow with the route: their sizes stand in for them
        return (
            f"Route(length_m={self.length_m!r}, pixels={len(self.pixels)}, "
            f"vertices={len(self.vertices)}, edges={len(self.edges)}, "
            f"start_snap_m={self.start_snap_m!r}, goal_snap_m={self.goal_snap_m!r}, "
            f"start_leg_feasible={self.start_leg_feasible!r}, "
            f"goal_leg_feasible={self.goal_leg_feasible!r}, "
            f"min_clearance_m={self.min_clearance_m!r}, robot_radius_m={self.robot_radius_m!r})"
        )

    def waypoints(self, *, tolerance_m: float = 0.1) -> np.ndarray:
        """The route's world polyline thinned to waypoints (Douglas–Peucker): every pixel
        of the route lies within ``tolerance_m`` of the straight segments between them, so
        a segment may pass up to ``tolerance_m`` closer to a wall than the route's pixels.

        Parameters
        ----------
        tolerance_m : float
            Largest distance from a route pixel to the waypoint polyline, metres (> 0).

        Returns
        -------
        float64 array, shape (m, 2)
            ``x, y`` in metres; the first and last are the route's ends.

        Raises
        ------
        TypeError
            If ``tolerance_m`` is not a number.
        ValueError
            If it is not finite and > 0.
        """
        tol = positive_metres("tolerance_m", tolerance_m)
        return self.world[polyline_keep(self.world, tol)]

    def to_geojson(self, *, tolerance_m: float | None = None) -> dict:
        """The route as a GeoJSON ``Feature``: a ``LineString`` of its world coordinates
        (``x, y`` in metres, the map's frame, as :func:`topojax.save_graph` writes
        graphs) with ``length_m``, the snap distances, the vertices and what the route
        says of the robot (whether each leg is feasible, ``min_clearance_m``, null when
        unknown, and ``robot_radius_m``) as properties.
        With ``tolerance_m``, the line holds the :meth:`waypoints` instead of every
        pixel.  A route of one pixel (start and goal snapped together) repeats it: a GeoJSON
        ``LineString`` needs two positions.  Coordinates are rounded to 1e-9 m, a
        thousandth of the finest pixel a map may have (1e-6 m), so that ``5.675`` is
        written, not the float noise ``5.675000000000001``.  A route without world
        coordinates (NaN: on a lone vertex that records no ``world``) raises
        ``ValueError``."""
        if not np.isfinite(self.world).all():  # NaN is not JSON: no line to write
            raise ValueError(
                "route: its world coordinates are not known (NaN: planned on a vertex that "
                "records no 'world'); expected a route on a graph with world coordinates"
            )
        line = self.world if tolerance_m is None else self.waypoints(tolerance_m=tolerance_m)
        if len(line) == 1:  # start and goal on one pixel: RFC 7946 wants two positions
            line = np.concatenate([line, line])
        xy = [[round(x, 9), round(y, 9)] for x, y in line.tolist()]  # correctly rounded
        clear = None if math.isnan(self.min_clearance_m) else self.min_clearance_m  # JSON
        return {
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": xy},
            "properties": {
                "length_m": self.length_m,
                "start_snap_m": self.start_snap_m,
                "goal_snap_m": self.goal_snap_m,
                "vertices": [jsonable(v, "vertex id") for v in self.vertices],
                "start_leg_feasible": self.start_leg_feasible,
                "goal_leg_feasible": self.goal_leg_feasible,
                "min_clearance_m": clear,
                "robot_radius_m": self.robot_radius_m,
            },
        }


def recorded_clearance_m(data: dict, name: str, where: str) -> float:
    """The clearance (metres) an edge's or vertex's attributes ``data`` record under
    ``name`` (``min_clearance_m``, ``clearance_m``), NaN when none is (or it is NaN).

    Raises
    ------
    TypeError
        If the value is not a real number; ``where`` names the edge or vertex.
    """
    value = data.get(name)
    if value is None:
        return math.nan
    if not is_real_number(value):
        raise TypeError(
            f"graph: {where}: {name!r}: expected a real number of metres (NaN: unknown), "
            f"received {type(value).__name__} {value!r}"
        )
    return float(value)


def narrowest_m(clearances) -> float:
    """The least of the clearances (metres), NaN when any is NaN (the narrowest is then
    not known) or there are none."""
    values = list(clearances)
    if not values or any(math.isnan(v) for v in values):
        return math.nan
    return min(values)


@dataclass(frozen=True, eq=False)
class WallDistance:
    """Per pixel of a map, the distance to its nearest wall as a graph's clearances
    measure it: for a route graph (graph attribute ``kind`` ``"route_graph"``) the
    distance to the nearest pixel that is not known free, the map's outside counting as
    such (:func:`topojax.routegraph.feasible.clearance_map_m`); for any other graph, as
    :func:`topojax.build_graph` records it, the distance to the nearest occupied pixel.
    The least of it over the pixels of whole edges is their recorded ``min_clearance_m``,
    to the bit.

    Attributes
    ----------
    px : float32 (H, W)
        Distance from each pixel centre to the nearest wall's centre, in units of
        ``unit_m`` (inf on a map without an occupied pixel, for a graph other than a
        route graph).
    unit_m : float
        Metres per unit of ``px``: the map's resolution, or 1 for a route graph's
        clearance already in float32 metres (:meth:`of_clearance_m`).
    route_graph : bool
        Whether the distance is a route graph's (rounded to float32 metres, as it records
        them).
    """

    px: np.ndarray
    unit_m: float
    route_graph: bool

    @classmethod
    def of_clearance_m(cls, clearance_m: np.ndarray) -> WallDistance:
        """A route graph's distance from its map's clearance (float32 (H, W), metres, as
        :func:`topojax.routegraph.feasible.clearance_map_m` gives it at the graph's
        resolution): float32 scaling keeps the order, so its least is the same bits."""
        return cls(clearance_m, 1.0, True)

    @classmethod
    def of_map(cls, occupancy, attrs: dict, resolution_m: float) -> WallDistance:
        """The distance on ``occupancy`` for the graph of attributes ``attrs``, at
        ``resolution_m`` metres per pixel (the graph's, which its clearances use)."""
        from .fields.clearance import distance_transform_px, free_clearance_px

        route_graph = attrs.get("kind") == "route_graph"
        if route_graph:
            px = free_clearance_px(np.asarray(occupancy.free, bool))
        else:
            occupied = np.asarray(occupancy.occupied, bool)
            if occupied.any():
                px = distance_transform_px(~occupied)
            else:  # nothing to measure from, as the graph builders' clearance
                px = np.full(occupied.shape, np.inf, np.float32)
        return cls(px, float(resolution_m), route_graph)

    def least_m(self, pixels: np.ndarray) -> float:
        """The least distance (metres) at ``pixels`` (int (n, 2), ``[row, col]``, n >= 1),
        NaN when one lies off the map."""
        h, w = self.px.shape
        rows, cols = pixels[:, 0], pixels[:, 1]
        if rows.min() < 0 or cols.min() < 0 or rows.max() >= h or cols.max() >= w:
            return math.nan
        least = self.px[rows, cols].min()  # the metres grow with the pixels: the least
        if self.route_graph:  # float32 metres, as clearance_map_m scales them
            return float(np.float32(least) * np.float32(self.unit_m))
        return float(least) * self.unit_m  # as the graph builders scale them
