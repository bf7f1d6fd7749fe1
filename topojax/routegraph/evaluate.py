"""Score any route graph on a map for a round robot (definitions:
``docs/route-graph-metrics.md``)."""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import networkx as nx
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .._validate import (
    int_at_least,
    nonnegative_metres,
    nonnegative_quantity,
    nx_graph,
    one_of,
    positive_int,
    positive_metres,
)
from ..fields.clearance import distance_transform_px
from ..maps import map_argument
from ..maps.occupancy import map_mismatch
from ._eval_geometry import GraphGeometry, graph_geometry, pixel_lookup, touched_pixels
from ._eval_loops import short_dead_ends, short_loops
from ._eval_routes import (
    PairSet,
    geodesic_lengths_px,
    route_lengths_px,
    route_network,
    sample_pairs,
)
from .feasible import FeasibleSpace, feasible_space
from .scale import MAX_SNAP_M  # every route end checks the graph points within it

__all__ = ["RouteGraphReport", "evaluate_route_graph"]

#: Loops shorter than this (metres) count as short.
SHORT_LOOP_M = 4.0
#: Dead ends whose edge is shorter than this (metres) count as short.
SHORT_DEAD_END_M = 1.0
#: The most pairs (each source's geodesic search covers its region).
MAX_PAIRS = 100_000
#: ``snap_m`` of a graph that records none (metres): a route graph's default.
DEFAULT_SNAP_M = 1.0
#: ``min_region_m2`` of a graph that records none (square metres): a route graph's default.
DEFAULT_MIN_REGION_M2 = 1.0


@dataclass(frozen=True)
class RouteGraphReport:
    """Metrics of one route graph on one map (see ``docs/route-graph-metrics.md``).

    Shares and rates are fractions in [0, 1]; NaN where undefined (no pair, no graph
    length); lengths in metres, times in seconds.
    """

    robot_radius_m: float
    snap_m: float
    seed: int
    pairs: int
    success_rate: float
    success_safe_rate: float
    stretch_median: float
    stretch_p90: float
    stretch_safe_median: float
    stretch_safe_p90: float
    unsafe_share: float
    graph_length_m: float
    vertices: int
    edges: int
    components: int
    feasible_regions: int
    regions_missed: int
    regions_split: int
    uncovered_share: float
    short_loops: int
    short_dead_ends: int
    generation_s: float | None
    evaluation_s: float
    entry: str = "nearest"
    min_region_m2: float = DEFAULT_MIN_REGION_M2

    def as_dict(self) -> dict:
        """The fields as a JSON-friendly dict (plain ints and floats, NaN as None)."""
        out = {}
        for k, v in asdict(self).items():
            if isinstance(v, float) and not math.isfinite(v):
                v = None
            out[k] = v
        return out


def _given_or_recorded(graph, name: str, value, default) -> tuple:
    """``value``, else the graph's attribute ``name`` (the option a route graph was built
    with), else ``default``; with the name its errors give."""
    if value is not None:
        return value, name
    recorded = graph.graph.get(name)
    if recorded is None:
        return default, name
    return recorded, f"{name} (the graph's '{name}' attribute)"


def _check_args(graph, occupancy, radius, snap_m, n_pairs, seed, min_region_m2, generation_s):
    nx_graph("graph", graph)
    why = map_mismatch(graph, occupancy)
    if why is not None:  # a graph that records its map (a route graph) scored on another
        raise ValueError(f"occupancy: {why}")
    radius, named = _given_or_recorded(graph, "robot_radius_m", radius, None)
    if radius is None:
        raise ValueError(
            "robot_radius_m: expected the robot radius in metres (>= 0; 0: a point robot), "
            "received none, and the graph records none (a route graph records the radius "
            "it was built for)"
        )
    radius = nonnegative_metres(named, radius)
    # a route graph is scored at the distance it was built to cover
    snap_m, named = _given_or_recorded(graph, "snap_m", snap_m, DEFAULT_SNAP_M)
    snap_m = positive_metres(named, snap_m)
    if snap_m > MAX_SNAP_M:
        raise ValueError(
            f"{named}: expected at most {MAX_SNAP_M:g} m (how far a route may run off the "
            f"graph to join it; the work grows with its square), received {snap_m!r}"
        )
    n_pairs = positive_int("n_pairs", n_pairs)
    if n_pairs > MAX_PAIRS:
        raise ValueError(f"n_pairs: expected at most {MAX_PAIRS:,}, received {n_pairs:,}")
    seed = int_at_least("seed", seed, 0)  # numpy's generators take no negative seed
    # and on the regions it was built to reach
    area, named = _given_or_recorded(graph, "min_region_m2", min_region_m2, DEFAULT_MIN_REGION_M2)
    min_region_m2 = nonnegative_quantity(named, area, "square metres")
    gen = (
        None
        if generation_s is None
        else nonnegative_quantity("generation_s", generation_s, "seconds")
    )
    return radius, snap_m, n_pairs, seed, min_region_m2, gen


def _stretch(route_px: np.ndarray, geo_px: np.ndarray) -> tuple[float, float, float]:
    """(success rate, median stretch, p90 stretch) of the pairs."""
    if route_px.size == 0:
        return math.nan, math.nan, math.nan
    ok = np.isfinite(route_px) & np.isfinite(geo_px)
    rate = float(np.count_nonzero(ok) / route_px.size)
    good = ok & (geo_px > 0)
    if not good.any():
        return rate, math.nan, math.nan
    s = route_px[good] / geo_px[good]
    return rate, float(np.median(s)), float(np.percentile(s, 90))


def _pieces(geo: GraphGeometry, feasible: np.ndarray):
    """Per densified piece (between points g and g + 1 of one edge): length (px), its
    midpoint feasible, and all three of its points feasible; and per point: feasible."""
    same = geo.pt_edge[1:] == geo.pt_edge[:-1]
    seg = geo.pt_rc[1:] - geo.pt_rc[:-1]
    length = np.where(same, np.hypot(seg[:, 0], seg[:, 1]), 0.0)
    point_ok = pixel_lookup(feasible, geo.pt_rc)
    mid_ok = pixel_lookup(feasible, 0.5 * (geo.pt_rc[1:] + geo.pt_rc[:-1]))
    piece_safe = mid_ok & point_ok[1:] & point_ok[:-1]
    return length, mid_ok, piece_safe, point_ok


def _components(geo: GraphGeometry) -> tuple[int, np.ndarray]:
    """Number of graph components and the component of each vertex."""
    n = geo.n_vertices
    m = coo_matrix((np.ones(geo.edge_u.size), (geo.edge_u, geo.edge_v)), shape=(n, n)).tocsr()
    return connected_components(m, directed=False)


def _region_metrics(fs: FeasibleSpace, geo: GraphGeometry, regions, snap_px: float):
    """(components, regions_missed, regions_split, uncovered_share)."""
    n_comp, comp = _components(geo)
    h, w = fs.labels.shape
    # every pixel a point lies on: a point on a pixel border lies on both pixels
    point, rows, cols = touched_pixels(geo.pt_rc, (h, w))
    label = fs.labels[rows, cols]
    pt_comp = comp[geo.edge_u[geo.pt_edge[point]]]
    big = np.zeros(fs.area_m2.size, bool)
    big[regions] = True
    sel = big[label]
    # each (region, component) pair once: one int64 key per point sorts faster than rows
    keys = np.unique(label[sel].astype(np.int64) * max(n_comp, 1) + pt_comp[sel])
    per_region = np.bincount(keys // max(n_comp, 1), minlength=fs.area_m2.size)[regions]
    missed = int(np.count_nonzero(per_region == 0))
    split = int(np.count_nonzero(per_region > 1))
    target = big[fs.labels] & fs.feasible
    n_target = int(np.count_nonzero(target))
    if n_target == 0:
        return n_comp, missed, split, math.nan
    not_graph = np.ones((h, w), np.uint8)
    not_graph[rows, cols] = 0
    if rows.size == 0:
        return n_comp, missed, split, 1.0
    dist = distance_transform_px(not_graph)
    far = np.count_nonzero(target & (dist > np.float32(snap_px)))
    return n_comp, missed, split, float(far / n_target)


def _routes(fs, geo, pairs: PairSet, pieces, snap_px: float, best_entry: bool):
    """(success, median, p90) over all graph points and over the safe ones only."""
    _, _, piece_safe, point_ok = pieces
    geod = geodesic_lengths_px(fs, pairs)
    n = geo.pt_edge.size
    full = route_network(geo, np.ones(max(n - 1, 0), bool), np.ones(n, bool))
    safe = route_network(geo, piece_safe, point_ok)
    all_stats = _stretch(route_lengths_px(full, pairs, snap_px, fs.feasible, best_entry), geod)
    safe_stats = _stretch(route_lengths_px(safe, pairs, snap_px, fs.feasible, best_entry), geod)
    return all_stats, safe_stats


def evaluate_route_graph(
    graph: nx.Graph,
    occupancy,
    robot_radius_m: float | None = None,
    *,
    snap_m: float | None = None,
    entry: str = "nearest",
    n_pairs: int = 300,
    seed: int = 0,
    min_region_m2: float | None = None,
    generation_s: float | None = None,
    coordinates: str = "auto",
) -> RouteGraphReport:
    """Score a route graph on a map for a round robot.

    Routes between seeded random pairs of feasible pixels (snapped onto the graph, then
    along it) are compared with the geodesic in the feasible space; coverage, safety and
    shape of the graph are measured as defined in ``docs/route-graph-metrics.md``.

    Parameters
    ----------
    graph : networkx.Graph or networkx.MultiGraph
        Undirected.  Vertices carry ``world`` ((x, y) metres; further entries ignored) or
        ``pixel`` ((row, col)); edges carry a ``waypoints`` or else a ``world`` (K, 2)
        polyline in metres, or are straight segments between their vertices.
    occupancy : OccupancyMap, str or Path
        The map the graph was made for (or its file).  A graph that records its map's
        ``shape``, ``resolution_m`` and ``origin`` (a route graph) must be scored on that
        map.
    robot_radius_m : float, optional
        Robot radius in metres (>= 0; 0: a point robot, the free space is feasible);
        default the graph's ``robot_radius_m`` attribute (a route graph's: the robot it
        was built for).  A graph that records none needs it.
    snap_m : float, optional
        Largest distance (metres, > 0, at most :data:`MAX_SNAP_M`) from a point to the
        graph point it snaps to, and the coverage distance; default the graph's
        ``snap_m`` attribute (a route graph's: the distance it was built to cover), else
        :data:`DEFAULT_SNAP_M`.
    entry : {"nearest", "best"}
        Where a route joins the graph: ``"nearest"``, at the nearest graph point each end
        sees within ``snap_m``; ``"best"``, at the nearest point it sees of whichever
        edge stretch within ``snap_m`` gives the shortest route (the rule of
        ``RoutePlanner(graph, occupancy=map)`` on a route graph, which also keeps the
        nearest point when it is out of sight).
    n_pairs : int
        Number of pairs (>= 1, at most :data:`MAX_PAIRS`).
    seed : int
        Seed of the pair sampling (>= 0).
    min_region_m2 : float, optional
        Feasible regions smaller than this (square metres, >= 0) are ignored; default the
        graph's ``min_region_m2`` attribute (a route graph's: the smallest region it was
        built to reach), else :data:`DEFAULT_MIN_REGION_M2`.
    generation_s : float or None
        Time taken to make the graph (seconds), echoed in the report.
    coordinates : {"auto", "world", "pixel"}
        Which vertex positions to use: ``"auto"`` each vertex's ``world`` if present, else
        its ``pixel``, and each edge's ``waypoints`` or ``world`` if present, else its
        ``path``; ``"pixel"`` uses ``pixel`` and edges' ``path`` ((K, 2) pixels)
        instead of ``world`` (for graphs whose ``world`` frame differs from the map's).

    Returns
    -------
    RouteGraphReport

    Raises
    ------
    TypeError, ValueError
        For a directed graph, a non-graph, a vertex without a position, a malformed edge
        polyline, a vertex or polyline point farther outside the map than the map's own
        size (a graph in another frame or unit), a map that is not the one the graph
        records, or an invalid parameter (the message names it).
    """
    t0 = time.perf_counter()
    occupancy = map_argument("occupancy", occupancy, files=True)
    radius, snap_m, n_pairs, seed, min_area, gen = _check_args(
        graph, occupancy, robot_radius_m, snap_m, n_pairs, seed, min_region_m2, generation_s
    )
    coordinates = one_of("coordinates", coordinates, ("auto", "world", "pixel"))
    entry = one_of("entry", entry, ("nearest", "best"))
    fs = feasible_space(occupancy, radius)
    res = fs.resolution_m
    snap_px = snap_m / res
    geo = graph_geometry(graph, occupancy, coordinates)
    regions = fs.regions_at_least(min_area)
    pieces = _pieces(geo, fs.feasible)
    length_px, mid_ok, _, _ = pieces
    total = float(length_px.sum())
    unsafe = float(length_px[~mid_ok].sum()) / total if total > 0 else math.nan
    pairs = sample_pairs(fs, regions, n_pairs, seed)
    (ok, med, p90), (ok_s, med_s, p90_s) = _routes(fs, geo, pairs, pieces, snap_px, entry == "best")
    n_comp, missed, split, uncovered = _region_metrics(fs, geo, regions, snap_px)
    u, v = geo.edge_u[: geo.n_edges], geo.edge_v[: geo.n_edges]
    length_m = geo.edge_len_px * res
    return RouteGraphReport(
        robot_radius_m=radius,
        snap_m=snap_m,
        entry=entry,
        min_region_m2=min_area,
        seed=seed,
        pairs=pairs.n_pairs,
        success_rate=ok,
        success_safe_rate=ok_s,
        stretch_median=med,
        stretch_p90=p90,
        stretch_safe_median=med_s,
        stretch_safe_p90=p90_s,
        unsafe_share=unsafe,
        graph_length_m=float(length_m.sum()),
        vertices=geo.n_vertices,
        edges=geo.n_edges,
        components=int(n_comp),
        feasible_regions=int(regions.size),
        regions_missed=missed,
        regions_split=split,
        uncovered_share=uncovered,
        short_loops=short_loops(geo.n_vertices, u, v, length_m, SHORT_LOOP_M),
        short_dead_ends=short_dead_ends(geo.n_vertices, u, v, length_m, SHORT_DEAD_END_M),
        generation_s=gen,
        evaluation_s=time.perf_counter() - t0,
    )
