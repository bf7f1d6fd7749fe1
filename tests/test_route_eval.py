"""evaluate_route_graph against hand-computed cases on small synthetic maps."""

from __future__ import annotations

import dataclasses
import json
import math

import networkx as nx
import numpy as np
import pytest

from topojax import OccupancyMap
from topojax.routegraph.evaluate import RouteGraphReport, evaluate_route_graph

RES = 0.1
RADIUS = 0.25  # 2.5 px: feasible pixels lie >= 3 px from anything not free


def _map(occupied: np.ndarray, origin=(0.0, 0.0, 0.0)) -> OccupancyMap:
    return OccupancyMap.from_array(occupied, resolution_m=RES, origin=origin)


def _corridor(free_rows: int, length: int = 200, origin=(0.0, 0.0, 0.0)) -> OccupancyMap:
    """A horizontal corridor ``free_rows`` pixels wide, walls all round."""
    occ = np.ones((free_rows + 2, length + 2), bool)
    occ[1:-1, 1:-1] = False
    return _map(occ, origin)


def _graph(m: OccupancyMap, polylines, multi: bool = True) -> nx.Graph:
    """A build_graph-like graph: one edge per pixel polyline [(row, col), ...], vertices at
    the polyline ends keyed by their pixel."""
    g = nx.MultiGraph() if multi else nx.Graph()
    for poly in polylines:
        path = np.asarray(poly, np.int64)
        x, y = m.pixel_to_world(path[:, 0], path[:, 1])
        world = np.stack([x, y], axis=1)
        for end, w in ((path[0], world[0]), (path[-1], world[-1])):
            g.add_node(tuple(end.tolist()), pixel=tuple(end.tolist()), world=tuple(w))
        g.add_edge(tuple(path[0].tolist()), tuple(path[-1].tolist()), path=path, world=world)
    return g


def _row(r: int, c0: int, c1: int):
    return [(r, c) for c in range(c0, c1 + 1)]


def _square(m: OccupancyMap, r0: int, c0: int, side: int, multi: bool = True) -> nx.Graph:
    corners = [(r0, c0), (r0, c0 + side), (r0 + side, c0 + side), (r0 + side, c0)]
    return _graph(m, [[corners[i], corners[(i + 1) % 4]] for i in range(4)], multi)


def test_single_row_corridor_routes_exactly_along_the_graph():
    # 5 free rows (1..5): only row 3 is >= 2.5 px from the walls; cols 3..198 feasible.
    m = _corridor(5)
    g = _graph(m, [_row(3, 3, 198)])
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=50)
    assert r.pairs == 50
    assert r.success_rate == 1.0 and r.success_safe_rate == 1.0
    assert r.stretch_median == pytest.approx(1.0, abs=1e-9)
    assert r.stretch_p90 == pytest.approx(1.0, abs=1e-9)
    assert r.unsafe_share == 0.0
    assert r.uncovered_share == 0.0
    assert (r.vertices, r.edges, r.components) == (2, 1, 1)
    assert (r.feasible_regions, r.regions_missed, r.regions_split) == (1, 0, 0)
    assert (r.short_loops, r.short_dead_ends) == (0, 0)
    assert r.graph_length_m == pytest.approx(19.5)


def test_wide_corridor_centre_graph_covers_and_routes_everything():
    # 18 free rows: feasible rows 3..16, at most 7 px (0.7 m < snap 1 m) from row 9.
    m = _corridor(18, origin=(2.0, -1.0, 0.3))
    g = _graph(m, [_row(9, 3, 198)])
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=100, seed=3)
    assert r.success_rate == 1.0 and r.success_safe_rate == 1.0
    assert r.uncovered_share == 0.0 and r.unsafe_share == 0.0
    # snap segments across the corridor: a detour of at most 2 x 0.7 m on top of the route
    assert 1.0 <= r.stretch_median <= r.stretch_p90 < 1.3


def test_graph_in_the_wall_is_all_unsafe_and_routes_nothing():
    m = _corridor(18)
    g = _graph(m, [_row(0, 0, 201)])
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=20)
    assert r.unsafe_share == 1.0
    assert r.success_rate == 0.0 and r.success_safe_rate == 0.0
    assert math.isnan(r.stretch_median)
    assert r.regions_missed == 1
    assert r.as_dict()["stretch_median"] is None


def test_graph_partly_in_the_wall_safe_routes_avoid_it():
    # 5 free rows, feasible row 3; the graph dips into the wall for cols 90..110.
    m = _corridor(5)
    poly = _row(3, 3, 89) + [(0, c) for c in range(90, 111)] + _row(3, 111, 198)
    r = evaluate_route_graph(_graph(m, [poly]), m, RADIUS, n_pairs=200)
    assert 0.0 < r.unsafe_share < 1.0
    assert r.success_rate > r.success_safe_rate > 0.0


@pytest.mark.parametrize("row", [2.5, 3.5])
def test_graph_on_the_border_of_a_region_lies_on_it(row):
    # 5 free rows, feasible row 3 only; the graph runs along the border between row 3 and
    # the infeasible row above or below it: its points lie on row 3 too, on either side
    m = _corridor(5)
    g = nx.Graph()
    g.add_node(0, pixel=(row, 3.0))
    g.add_node(1, pixel=(row, 198.0))
    g.add_edge(0, 1)
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=20, coordinates="pixel")
    assert r.unsafe_share == 0.0
    assert (r.feasible_regions, r.regions_missed, r.regions_split) == (1, 0, 0)
    assert r.uncovered_share == 0.0


def _two_rooms() -> OccupancyMap:
    occ = np.ones((22, 44), bool)
    occ[1:21, 1:21] = False  # room A: cols 1..20
    occ[1:21, 23:43] = False  # room B: cols 23..42 (wall cols 21, 22)
    return _map(occ)


def test_room_without_graph_is_missed():
    m = _two_rooms()
    g = _graph(m, [_row(10, 4, 10), _row(10, 10, 14), [(4, 10), (10, 10)], [(10, 10), (17, 10)]])
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=60)
    assert r.feasible_regions == 2
    assert (r.regions_missed, r.regions_split) == (1, 0)
    # about half of the pairs lie in the room without a graph
    assert 0.2 < r.success_rate < 0.8
    # room A is covered (every feasible pixel within 10 px of the cross), room B is not (its
    # nearest feasible pixels lie 11 px from the cross, through the wall)
    assert r.uncovered_share == pytest.approx(0.5)


def test_tiny_regions_are_ignored():
    m = _two_rooms()
    g = _graph(m, [_row(10, 4, 17)])
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=10, min_region_m2=5.0)
    assert r.feasible_regions == 0 and r.pairs == 0
    assert math.isnan(r.success_rate) and math.isnan(r.uncovered_share)


@pytest.mark.parametrize("resolution_m", [1e-6, 0.05])
def test_a_one_pixel_region_draws_no_pair_at_any_resolution(resolution_m):
    """A region of one pixel has no two distinct pixels to pair, at any resolution: at
    the finest a map may have (1e-6 m per pixel) its area would pass a two-pixel test,
    and the draw would fail inside numpy ("high <= 0")."""
    occ = np.ones((5, 5), bool)
    occ[2, 2] = False
    m = OccupancyMap.from_array(occ, resolution_m=resolution_m)
    r = evaluate_route_graph(nx.Graph(), m, 0.0, n_pairs=10, min_region_m2=0.0)
    assert r.feasible_regions == 1 and r.pairs == 0


def test_graph_in_two_pieces_splits_its_region():
    m = _corridor(5)
    g = _graph(m, [_row(3, 3, 95), _row(3, 105, 198)])
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=100)
    assert r.components == 2
    assert (r.regions_missed, r.regions_split) == (0, 1)
    assert 0.0 < r.success_rate < 1.0


@pytest.mark.parametrize(
    ("side_px", "expected"),
    [(9, 1), (20, 0), (100, 0)],  # perimeters 3.6 m (short), 8 m and 40 m (not)
)
def test_square_loop_is_short_when_its_perimeter_is_under_4m(side_px, expected):
    m = _map(np.zeros((110, 110), bool))
    for multi in (True, False):
        r = evaluate_route_graph(_square(m, 2, 2, side_px, multi), m, RADIUS, n_pairs=5)
        assert r.short_loops == expected
        assert r.short_dead_ends == 0


def test_parallel_edges_and_self_loops_are_loops():
    m = _map(np.zeros((60, 60), bool))
    g = _graph(m, [[(5, 5), (5, 20)], [(5, 5), (8, 12), (5, 20)]])  # 1.5 m + ~1.6 m
    g.add_edge(
        (5, 20), (5, 20), world=np.stack(m.pixel_to_world([5, 5, 15, 5], [20, 30, 25, 20]), 1)
    )
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=5)
    assert r.short_loops == 2


def test_spur_of_half_a_metre_is_a_short_dead_end():
    m = _map(np.zeros((80, 80), bool))
    g = _graph(m, [_row(40, 10, 40), _row(40, 40, 70), [(40, 40), (45, 40)]])
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=5)
    assert r.short_dead_ends == 1
    assert r.short_loops == 0


def _swagger_like(m: OccupancyMap, pixels) -> nx.Graph:
    """Straight edges with only a ``weight``; vertices with ``world`` (x, y, z)."""
    g = nx.Graph()
    for i, (r, c) in enumerate(pixels):
        x, y = m.pixel_to_world(r, c)
        g.add_node(i, world=(float(x), float(y), 0.0), pixel=(r, c))
    for i in range(len(pixels) - 1):
        (r0, c0), (r1, c1) = pixels[i], pixels[i + 1]
        g.add_edge(i, i + 1, weight=math.hypot(r1 - r0, c1 - c0) * RES)
    return g


@pytest.mark.parametrize("coordinates", ["auto", "world", "pixel"])
def test_straight_edge_graph_without_polylines(coordinates):
    m = _corridor(5)
    g = _swagger_like(m, [(3, 3), (3, 30), (3, 70), (3, 198)])
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=50, coordinates=coordinates)
    ref = evaluate_route_graph(_graph(m, [_row(3, 3, 198)]), m, RADIUS, n_pairs=50)
    assert r.success_rate == 1.0 and r.uncovered_share == 0.0
    assert r.stretch_median == pytest.approx(ref.stretch_median)
    assert r.graph_length_m == pytest.approx(19.5)
    assert (r.vertices, r.edges) == (4, 3)


def test_pixel_only_vertices_are_converted_with_the_map():
    m = _corridor(5, origin=(-3.0, 4.0, 0.0))
    g = nx.Graph()
    g.add_node("a", pixel=(3, 3))
    g.add_node("b", pixel=(3, 198))
    g.add_edge("a", "b")
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=30)
    assert r.success_rate == 1.0 and r.graph_length_m == pytest.approx(19.5)


def test_a_pixel_only_graph_is_read_whole_without_coordinates():
    """A graph in pixels only (vertex ``pixel``, edge ``path``) is read whole by "auto",
    the edges' ``path`` included, and scores as with ``coordinates="pixel"``: the
    vertices' ``pixel`` without the edges' ``path`` would score each bent edge as the
    straight line between its ends (through the wall here: an unsafe share, failed
    routes)."""
    occ = np.ones((40, 40), bool)
    occ[5:10, 5:35] = False  # an L: along row 7, then down column 32
    occ[5:35, 30:35] = False
    m = _map(occ)
    g = _graph(m, [_row(7, 7, 32) + [(r, 32) for r in range(8, 33)]])
    for _, data in g.nodes(data=True):
        del data["world"]
    for *_, data in g.edges(data=True):
        del data["world"]
    auto = evaluate_route_graph(g, m, RADIUS, n_pairs=50, min_region_m2=0.0)
    pixel = evaluate_route_graph(g, m, RADIUS, n_pairs=50, min_region_m2=0.0, coordinates="pixel")
    assert auto == dataclasses.replace(pixel, evaluation_s=auto.evaluation_s)
    assert auto.unsafe_share == 0.0 and auto.success_rate == 1.0
    assert auto.graph_length_m == pytest.approx(50 * RES)


def test_same_seed_same_report_and_json_friendly():
    m = _two_rooms()
    g = _graph(m, [_row(10, 4, 17), _row(10, 26, 39)])
    a = evaluate_route_graph(g, m, RADIUS, n_pairs=40, seed=7, generation_s=1.5).as_dict()
    b = evaluate_route_graph(g, m, RADIUS, n_pairs=40, seed=7, generation_s=1.5).as_dict()
    a.pop("evaluation_s"), b.pop("evaluation_s")
    assert a == b
    assert a["generation_s"] == 1.5 and a["seed"] == 7
    json.dumps(a, allow_nan=False)


def test_geodesic_searches_in_threads_give_the_one_thread_report(monkeypatch):
    """The geodesic searches run in threads, each into its own slice of the lengths."""
    import topojax.routegraph._eval_routes as routes

    m = _two_rooms()
    g = _graph(m, [_row(10, 4, 17), _row(10, 26, 39)])
    monkeypatch.setattr(routes, "usable_cpus", lambda: 4)  # threads on a 1-CPU runner too
    reports = []
    for threads in (1, 4):
        monkeypatch.setattr(routes, "GEODESIC_THREADS", threads)
        r = evaluate_route_graph(g, m, RADIUS, n_pairs=120, seed=3).as_dict()
        r.pop("evaluation_s")
        reports.append(r)
    assert reports[0] == reports[1]
    assert reports[0]["pairs"] == 120 and reports[0]["feasible_regions"] == 2


def test_empty_graph():
    m = _corridor(5)
    r = evaluate_route_graph(nx.MultiGraph(), m, RADIUS, n_pairs=10)
    assert isinstance(r, RouteGraphReport)
    assert (r.vertices, r.edges, r.components) == (0, 0, 0)
    assert r.success_rate == 0.0 and r.regions_missed == 1 and r.uncovered_share == 1.0
    assert r.as_dict()["unsafe_share"] is None


def test_isolated_vertex_is_a_graph_point():
    m = _corridor(5)
    g = nx.Graph()
    x, y = m.pixel_to_world(3, 50)
    g.add_node(0, world=(float(x), float(y)))
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=10)
    assert (r.vertices, r.edges, r.components, r.regions_missed) == (1, 0, 1, 0)


def test_a_point_robot_is_scored_on_the_free_space():
    """Radius 0, as route_graph accepts it: every free pixel is feasible, a graph along
    the wall is safe."""
    m = _corridor(5)
    g = _graph(m, [_row(1, 1, 200)])
    point = evaluate_route_graph(g, m, 0.0, n_pairs=30)
    assert point.unsafe_share == 0.0 and point.success_rate == 1.0
    assert evaluate_route_graph(g, m, RADIUS, n_pairs=30).unsafe_share == 1.0


@pytest.mark.parametrize(
    ("kwargs", "exc", "words"),
    [
        ({"robot_radius_m": -0.1}, ValueError, "robot_radius_m"),
        ({"robot_radius_m": "0.3"}, TypeError, "robot_radius_m"),
        ({"snap_m": -1.0}, ValueError, "snap_m"),
        ({"n_pairs": 0}, ValueError, "n_pairs"),
        ({"n_pairs": 2.5}, TypeError, "n_pairs: expected an int >= 1, received float"),
        ({"seed": 1.5}, TypeError, "seed"),
        ({"seed": -1}, ValueError, "seed: expected an int >= 0, received -1"),
        ({"min_region_m2": -1.0}, ValueError, "min_region_m2"),
        (
            {"min_region_m2": True},
            TypeError,
            "min_region_m2: expected a real number of square metres",
        ),
        ({"generation_s": -2.0}, ValueError, "generation_s"),
        ({"generation_s": float("nan")}, ValueError, "generation_s"),
        ({"coordinates": "polar"}, ValueError, "coordinates"),
        ({"entry": "any"}, ValueError, "entry"),
        ({"snap_m": 1e9}, ValueError, "snap_m: expected at most 5 m"),
        (
            {"robot_radius_m": 1e300},
            ValueError,
            "robot_radius_m: expected a robot radius of at most",
        ),
        ({"n_pairs": 10**9}, ValueError, "n_pairs: expected at most 100,000"),
    ],
)
def test_bad_arguments_name_the_parameter(kwargs, exc, words):
    m = _corridor(5)
    args = {"robot_radius_m": RADIUS, **kwargs}
    with pytest.raises(exc, match=words):
        evaluate_route_graph(_graph(m, [_row(3, 3, 198)]), m, **args)


def test_bad_graphs_are_refused():
    m = _corridor(5)
    with pytest.raises(TypeError, match="graph"):
        evaluate_route_graph([(0, 1)], m, RADIUS)
    with pytest.raises(
        TypeError, match="^graph: expected an undirected networkx graph, received DiGraph$"
    ):  # a directed graph is a wrong type, as everywhere a graph is read
        evaluate_route_graph(nx.DiGraph([(0, 1)]), m, RADIUS)
    with pytest.raises(ValueError, match="vertex 0"):
        evaluate_route_graph(nx.Graph([(0, 1)]), m, RADIUS)
    g = _graph(m, [_row(3, 3, 198)])
    next(iter(g.edges(data=True)))[2]["world"] = np.zeros((3, 1))
    with pytest.raises(ValueError, match="'world'"):
        evaluate_route_graph(g, m, RADIUS)
    with pytest.raises(TypeError, match="occupancy"):
        evaluate_route_graph(g, np.zeros((5, 5)), RADIUS)


def test_a_non_finite_polyline_point_is_named():
    """A NaN in a well-shaped polyline is reported as such, not as a wrong shape."""
    m = _corridor(5)
    g = _graph(m, [_row(3, 3, 198)])
    data = next(iter(g.edges(data=True)))[2]
    data["world"] = np.array(data["world"], np.float64)
    data["world"][1, 0] = np.nan
    with pytest.raises(ValueError, match=r"received shape \(\d+, 2\) with a non-finite point"):
        evaluate_route_graph(g, m, RADIUS)


@pytest.mark.parametrize("value", ["abc", [[1.0, 2.0], [3.0]]])
def test_a_polyline_that_is_not_numbers_is_named_as_received(value):
    m = _corridor(5)
    g = _graph(m, [_row(3, 3, 198)])
    next(iter(g.edges(data=True)))[2]["waypoints"] = value
    with pytest.raises(ValueError, match=rf"'waypoints': .* received {type(value).__name__} "):
        evaluate_route_graph(g, m, RADIUS)


def test_geodesic_matches_skimage_mcp_geometric():
    from skimage.graph import MCP_Geometric

    from topojax.graph.geodesic import geodesic_from

    rng = np.random.default_rng(1)
    for _ in range(5):
        mask = rng.random((40, 50)) > 0.3
        src = (int(rng.integers(40)), int(rng.integers(50)))
        mask[src] = True
        targets = np.stack([rng.integers(40, size=30), rng.integers(50, size=30)], axis=1)
        got = geodesic_from(mask, src, targets)
        costs, _ = MCP_Geometric(np.where(mask, 1.0, np.inf)).find_costs([src])
        want = costs[targets[:, 0], targets[:, 1]]
        want[~mask[targets[:, 0], targets[:, 1]]] = np.inf
        assert np.array_equal(np.isfinite(got), np.isfinite(want))
        np.testing.assert_allclose(got[np.isfinite(got)], want[np.isfinite(want)], rtol=1e-12)


def test_nearest_path_is_a_shortest_path_to_the_nearest_target():
    """Against skimage's MCP_Geometric: the same length, to a nearest target (the first
    in raster order among equally near ones), along feasible 8-connected steps."""
    from skimage.graph import MCP_Geometric

    from topojax.graph.geodesic import nearest_path

    rng = np.random.default_rng(2)
    for _ in range(60):
        h, w = (int(x) for x in rng.integers(5, 50, 2))
        mask = rng.random((h, w)) > rng.uniform(0.0, 0.4)
        targets = rng.random((h, w)) < rng.uniform(0.002, 0.05)
        start = (int(rng.integers(h)), int(rng.integers(w)))
        mask[start] = True
        got = nearest_path(mask, start, targets)
        costs, _ = MCP_Geometric(np.where(mask, 1.0, np.inf), fully_connected=True).find_costs(
            [start]
        )
        reached = np.isfinite(costs) & targets & mask
        if not reached.any():
            assert got is None
            continue
        steps = np.abs(np.diff(got, axis=0))
        assert got.dtype == np.int32 and tuple(got[0]) == start
        assert (steps.max(axis=1) == 1).all() and mask[got[:, 0], got[:, 1]].all()
        length = np.where(steps.sum(axis=1) == 2, np.sqrt(2.0), 1.0).sum()
        assert length == pytest.approx(costs[reached].min(), rel=1e-12)
        first = np.argwhere(reached)[np.argmin(costs[reached])]
        assert tuple(got[-1]) == tuple(first)
    assert nearest_path(np.zeros((4, 4), bool), (1, 1), np.ones((4, 4), bool)) is None


def test_waypoints_are_the_edge_geometry_when_present():
    """A robot follows an edge's ``waypoints``: they set its length, not ``world``."""
    m = _map(np.zeros((60, 60), bool))
    g = _graph(m, [[(30, 10), (10, 30), (30, 50)]])  # a detour through row 10
    plain = evaluate_route_graph(g, m, RADIUS, n_pairs=5)
    data = next(iter(g.edges(data=True)))[2]
    data["waypoints"] = np.stack(m.pixel_to_world([30, 30], [10, 50]), axis=1)
    straight = evaluate_route_graph(g, m, RADIUS, n_pairs=5)
    assert plain.graph_length_m == pytest.approx(2 * np.hypot(20, 20) * RES, rel=1e-6)
    assert straight.graph_length_m == pytest.approx(40 * RES, rel=1e-6)


def test_an_attribute_set_to_none_is_a_missing_one():
    """A graph from another tool may hold None for a geometry it lacks (as
    save_nav2_graph reads it): the next geometry is used, as if the key were absent."""
    m = _map(np.zeros((60, 60), bool))
    g = _graph(m, [[(30, 10), (10, 30), (30, 50)]])
    ref = evaluate_route_graph(g, m, RADIUS, n_pairs=5)
    next(iter(g.edges(data=True)))[2]["waypoints"] = None
    for n in g:
        g.nodes[n]["world"] = None  # the vertices' pixel instead
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=5)
    assert r.graph_length_m == pytest.approx(ref.graph_length_m)
    assert r.success_rate == ref.success_rate


def test_a_vertex_whose_wanted_attribute_is_none_is_refused_saying_so():
    # the refusal lists the attributes the vertex has; one set to None is named as such,
    # not listed as if it held a position
    m = _map(np.zeros((60, 60), bool))
    g = _graph(m, [[(30, 10), (10, 30), (30, 50)]])
    node = next(iter(g))
    g.nodes[node]["world"] = None
    with pytest.raises(ValueError, match=r"'world' attribute .*\('world' set to None\)$"):
        evaluate_route_graph(g, m, RADIUS, n_pairs=5, coordinates="world")


@pytest.mark.parametrize("reverse", [False, True])
def test_polylines_are_joined_to_their_vertices_either_way_round(reverse):
    """An edge's polyline that stops short of its vertices is joined to them by straight
    pieces, whichever way round it is stored; a one-point polyline too."""
    m = _corridor(5)
    g = nx.MultiGraph()
    ends = {"a": (3, 3), "b": (3, 198), "c": (3, 100)}
    for name, (r, c) in ends.items():
        g.add_node(name, world=tuple(np.ravel(m.pixel_to_world(r, c))))
    poly = np.stack(m.pixel_to_world([3, 3], [20, 90]), axis=1)
    g.add_edge("a", "c", world=poly[::-1] if reverse else poly)
    g.add_edge("c", "b", world=np.stack(m.pixel_to_world([3], [150]), axis=1))
    r = evaluate_route_graph(g, m, RADIUS, n_pairs=40)
    assert r.graph_length_m == pytest.approx(19.5, rel=1e-9)
    assert r.success_rate == 1.0 and r.uncovered_share == 0.0
    assert r.stretch_median == pytest.approx(1.0, abs=0.05)


def _fork():
    """A free 32 x 34 room (walls all round) with a fork from vertex (10, 3): one edge along
    row 10 to (10, 28), one down column 3 and along row 20 to (20, 28)."""
    occ = np.ones((32, 34), bool)
    occ[1:-1, 1:-1] = False
    m = _map(occ)
    return m, _graph(m, [[(10, 3), (10, 28)], [(10, 3), (20, 3), (20, 28)]])


@pytest.mark.parametrize(
    ("best_entry", "expected_px"),
    [
        # nearest: 3 px up to row 10, 17 along it to the fork, 10 + 23 along the other
        # edge to (20, 26), 3 px up to the goal
        (False, 3 + 17 + 33 + 3),
        # best entry: 7 px down to row 20, 6 along it, 3 px up (or the mirror of it)
        (True, 7 + 6 + 3),
    ],
)
def test_a_route_joins_the_graph_at_the_nearest_or_the_best_point(best_entry, expected_px):
    from topojax.routegraph._eval_geometry import graph_geometry
    from topojax.routegraph._eval_routes import PairSet, route_lengths_px, route_network
    from topojax.routegraph.feasible import feasible_space

    m, g = _fork()
    geo = graph_geometry(g, m, "auto")
    n = geo.pt_edge.size
    net = route_network(geo, np.ones(n - 1, bool), np.ones(n, bool))
    pairs = PairSet(
        source=np.array([[13, 20]]),
        region=np.array([1]),
        start=np.array([0, 1]),
        target=np.array([[17, 26]]),
    )
    feasible = feasible_space(m, RADIUS).feasible
    got = route_lengths_px(net, pairs, 1.0 / RES, feasible, best_entry)
    assert got[0] == pytest.approx(expected_px, abs=1e-9)


def test_best_entry_routes_are_never_longer_and_shorter_here():
    from topojax.routegraph._eval_geometry import graph_geometry
    from topojax.routegraph._eval_routes import route_lengths_px, route_network, sample_pairs
    from topojax.routegraph.feasible import feasible_space

    m, g = _fork()
    fs = feasible_space(m, RADIUS)
    geo = graph_geometry(g, m, "auto")
    n = geo.pt_edge.size
    net = route_network(geo, np.ones(n - 1, bool), np.ones(n, bool))
    pairs = sample_pairs(fs, fs.regions_at_least(0.0), 300, seed=2)
    near = route_lengths_px(net, pairs, 1.0 / RES, fs.feasible)
    best = route_lengths_px(net, pairs, 1.0 / RES, fs.feasible, best_entry=True)
    assert np.isfinite(near).all() and np.isfinite(best).all()
    assert (best <= near + 1e-9).all() and (best < near - 1.0).any()
    near = evaluate_route_graph(g, m, RADIUS, n_pairs=200, seed=5)
    best = evaluate_route_graph(g, m, RADIUS, n_pairs=200, seed=5, entry="best")
    assert (near.entry, best.entry) == ("nearest", "best")
    assert best.success_rate == near.success_rate == 1.0
    assert best.stretch_median < near.stretch_median
    assert best.stretch_p90 < near.stretch_p90
    # a corridor with one run: its nearest point is the only entry
    m = _corridor(18)
    g = _graph(m, [_row(9, 3, 198)])
    a = evaluate_route_graph(g, m, RADIUS, n_pairs=100, seed=3)
    b = evaluate_route_graph(g, m, RADIUS, n_pairs=100, seed=3, entry="best")
    assert (a.stretch_median, a.stretch_p90) == (b.stretch_median, b.stretch_p90)


def test_a_route_graph_is_scored_only_on_its_own_map(tmp_path):
    """A graph that records its map (shape, resolution, origin) scored on another map
    would give a silent nonsense report: refused, naming what differs.  A map file is
    read as route_graph reads one."""
    import topojax as tj

    m = tj.load_map(tj.datasets.sample_map_path("office"))
    rg = tj.route_graph(m, robot_radius_m=0.3)
    coarse = tj.OccupancyMap(
        occupied=m.occupied, free=m.free, unknown=m.unknown, resolution_m=0.1, origin=m.origin
    )
    moved = tj.OccupancyMap(
        occupied=m.occupied,
        free=m.free,
        unknown=m.unknown,
        resolution_m=m.resolution_m,
        origin=(10.0, 10.0, 0.0),
    )
    cropped = tj.OccupancyMap(
        occupied=m.occupied[1:],
        free=m.free[1:],
        unknown=m.unknown[1:],
        resolution_m=m.resolution_m,
        origin=m.origin,
    )
    for other, words in ((coarse, "m/px"), (moved, "origin"), (cropped, "shape")):
        with pytest.raises(ValueError, match=f"^occupancy: expected the graph's map .*{words}"):
            tj.evaluate_route_graph(rg, other, robot_radius_m=0.3, n_pairs=20)
    path = tj.datasets.sample_map_path("office")
    by_file = tj.evaluate_route_graph(rg, path, robot_radius_m=0.3, n_pairs=20)
    by_map = tj.evaluate_route_graph(rg, m, robot_radius_m=0.3, n_pairs=20)
    same = ("success_rate", "stretch_median", "stretch_p90", "unsafe_share", "uncovered_share")
    assert [getattr(by_file, k) for k in same] == [getattr(by_map, k) for k in same]


def test_a_route_graph_is_scored_at_the_snap_distance_it_was_built_for(tmp_path):
    """Without ``snap_m`` a route graph is scored at its own ``snap_m``, saved and loaded
    too, as ``route-graph --evaluate`` scores it: at the default 1 m a graph built to cover
    2 m read as missing a tenth of its hall, against its own ``uncovered_share`` of 0."""
    import topojax as tj

    free = np.zeros((242, 362), bool)  # a 12 x 18 m hall at 0.05 m per pixel
    free[1:-1, 1:-1] = True
    hall = OccupancyMap.from_array(~free, resolution_m=0.05)
    rg = tj.route_graph(hall, config=tj.RouteGraphConfig(snap_m=2.0))
    assert rg.graph["uncovered_share"] == 0.0
    tj.save_graph(rg, tmp_path / "hall_route.json")
    loaded = tj.load_graph(tmp_path / "hall_route.json")
    own = evaluate_route_graph(rg, hall, 0.3, snap_m=2.0, n_pairs=100)
    for graph in (rg, loaded):
        report = evaluate_route_graph(graph, hall, 0.3, n_pairs=100)
        assert report.snap_m == 2.0
        assert report.uncovered_share == 0.0 and report.success_rate == 1.0
        assert report.stretch_median == own.stretch_median
    at_one = evaluate_route_graph(rg, hall, 0.3, snap_m=1.0, n_pairs=100)
    assert at_one.uncovered_share > 0.05  # an explicit snap_m still wins
    bare = nx.MultiGraph(rg)
    bare.graph.pop("snap_m")  # a graph that records none: 1 m, as before
    assert evaluate_route_graph(bare, hall, 0.3, n_pairs=100).snap_m == 1.0
    bad = nx.MultiGraph(rg)
    bad.graph["snap_m"] = -1.0
    with pytest.raises(ValueError, match="^snap_m \\(the graph's 'snap_m' attribute\\): "):
        evaluate_route_graph(bad, hall, 0.3, n_pairs=100)


def test_a_route_graph_is_scored_at_the_robot_radius_it_was_built_for():
    """Without ``robot_radius_m`` a route graph is scored for the robot it was built for,
    as docs/route-graphs.md promises of all the options it records; a graph that records
    none (another generator's) is refused with the parameter named."""
    m = _corridor(18)
    rg = _graph(m, [_row(9, 3, 198)])
    rg.graph["robot_radius_m"] = RADIUS
    own = evaluate_route_graph(rg, m, n_pairs=50)
    assert own.robot_radius_m == RADIUS
    assert own == dataclasses.replace(
        evaluate_route_graph(rg, m, RADIUS, n_pairs=50), evaluation_s=own.evaluation_s
    )
    assert evaluate_route_graph(rg, m, 0.0, n_pairs=50).robot_radius_m == 0.0  # given wins
    bare = nx.MultiGraph(rg)
    bare.graph.pop("robot_radius_m")
    with pytest.raises(ValueError, match="^robot_radius_m: expected the robot radius"):
        evaluate_route_graph(bare, m, n_pairs=50)
    bad = nx.MultiGraph(rg)
    bad.graph["robot_radius_m"] = -1.0
    match = "^robot_radius_m \\(the graph's 'robot_radius_m' attribute\\): "
    with pytest.raises(ValueError, match=match):
        evaluate_route_graph(bad, m, n_pairs=50)


def _room_and_closet() -> OccupancyMap:
    """A 5 x 5 m room beside a closed 2 x 2 m closet (about 2 m2 feasible at 0.3 m),
    at 0.05 m per pixel."""
    free = np.zeros((104, 164), bool)
    free[2:102, 2:102] = True  # the room
    free[20:60, 120:160] = True  # the closet, no door
    return OccupancyMap.from_array(~free, resolution_m=0.05)


def test_a_route_graph_is_scored_on_the_regions_it_was_built_for(tmp_path):
    """Without ``min_region_m2`` a route graph is scored on the regions of its own
    ``min_region_m2``, saved and loaded in every format too: a graph that skips a closet
    under 4 m2 on purpose read as missing a region at the default 1 m2."""
    import topojax as tj
    from topojax.graph import GraphStore

    occ = _room_and_closet()
    rg = tj.route_graph(occ, config=tj.RouteGraphConfig(min_region_m2=4.0))
    assert rg.graph["min_region_m2"] == 4.0 and nx.number_connected_components(rg) == 1
    at_one = evaluate_route_graph(rg, occ, 0.3, min_region_m2=1.0, n_pairs=50)
    assert at_one.feasible_regions == 2 and at_one.regions_missed == 1  # explicit still wins
    assert at_one.min_region_m2 == 1.0 and at_one.as_dict()["min_region_m2"] == 1.0
    copies = [rg, GraphStore.from_networkx(rg).to_networkx()]
    for name in ("rg.json", "rg.graphml", "rg.geojson"):
        tj.save_graph(rg, tmp_path / name)
        copies.append(tj.load_graph(tmp_path / name))
    tj.save_graph_store(GraphStore.from_networkx(rg), tmp_path / "store")
    copies.append(tj.load_graph_store(tmp_path / "store").to_networkx())
    for graph in copies:
        assert graph.graph["min_region_m2"] == 4.0
        assert graph.graph["snap_m"] == rg.graph["snap_m"]
        report = evaluate_route_graph(graph, occ, 0.3, n_pairs=50)
        assert report.feasible_regions == 1 and report.regions_missed == 0
        assert report.min_region_m2 == 4.0  # the report says what it counted
    bare = nx.MultiGraph(rg)
    bare.graph.pop("min_region_m2")  # a graph that records none: 1 m2, as before
    assert evaluate_route_graph(bare, occ, 0.3, n_pairs=50).regions_missed == 1
    bad = nx.MultiGraph(rg)
    bad.graph["min_region_m2"] = -1.0
    match = "^min_region_m2 \\(the graph's 'min_region_m2' attribute\\): "
    with pytest.raises(ValueError, match=match):
        evaluate_route_graph(bad, occ, 0.3, n_pairs=50)


def test_a_graph_far_outside_its_map_is_refused_by_name():
    """A vertex or waypoint in another frame or unit (kilometres off) would be densified
    pixel by pixel; it is named instead."""
    m = _map(np.zeros((40, 40), bool))
    far = nx.Graph()
    far.add_node("a", world=(1.0, 1.0))
    far.add_node("b", world=(1e12, 1.0))
    far.add_edge("a", "b")
    with pytest.raises(
        ValueError,
        match=r"^graph: vertex 'b' lies at pixel .*at most the map's own size \(40 x 40 pixels\) outside the map",
    ):
        evaluate_route_graph(far, m, RADIUS)
    bent = nx.Graph()
    bent.add_node(0, world=(0.5, 0.5))
    bent.add_node(1, world=(1.5, 0.5))
    bent.add_edge(0, 1, waypoints=np.array([[0.5, 0.5], [1e6, 1e6], [1.5, 0.5]]))
    with pytest.raises(ValueError, match=r"^graph: edge \(0, 1\) runs to pixel"):
        evaluate_route_graph(bent, m, RADIUS)
    near = nx.Graph()  # up to the map's size beyond its border is fine
    near.add_node(0, world=(0.5, 0.5))
    near.add_node(1, world=(1.5, 0.5))
    near.add_edge(0, 1, waypoints=np.array([[0.5, 0.5], [-1.0, 0.5], [1.5, 0.5]]))
    assert evaluate_route_graph(near, m, RADIUS, n_pairs=5).vertices == 2


def test_snap_legs_follow_the_planners_sight_rule():
    # a snap leg from (0, 0.7) to (3, 5) clips obstacle pixel (1, 3) at its corner for
    # 0.43 px: collision, as for RoutePlanner's entry legs (points sampled half a pixel
    # apart step over it); the evaluator snaps with the planner's own test
    from topojax import _sight
    from topojax.routegraph import _eval_routes

    assert _eval_routes.sees is _sight.sees
    feasible = np.ones((4, 6), bool)
    feasible[1, 3] = False
    q = np.array([0.0, 0.7])
    cand = np.array([[3.0, 5.0], [3.0, 0.7], [0.0, 5.0]])
    assert _sight.sees(feasible, q, cand).tolist() == [False, True, True]


def test_best_entry_memory_does_not_grow_with_the_pairs(monkeypatch):
    """With ``entry="best"`` each pair has a (start join, goal join) combination per
    pair of runs its ends see: thousands on a dense graph within a large ``snap_m``.
    Held for all pairs at once they would take about 200 bytes each, some 100 GB for the
    most pairs allowed; scored a few sources and a bounded number of combinations at a
    time, the traced peak stays put as the pairs grow tenfold, and the report is the
    same."""
    import tracemalloc

    from topojax.routegraph import _eval_routes

    occ = np.zeros((140, 140), bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    m = _map(occ)
    g = nx.grid_2d_graph(13, 13)  # a mesh of straight edges 1 m apart
    nx.set_node_attributes(g, {n: (10 + 10 * n[0], 10 + 10 * n[1]) for n in g}, "pixel")

    def report(n_pairs):
        r = evaluate_route_graph(g, m, RADIUS, n_pairs=n_pairs, snap_m=3.0, entry="best")
        return dataclasses.replace(r, evaluation_s=0.0)

    whole = report(100)
    monkeypatch.setattr(_eval_routes, "SOURCES_AT_ONCE", 1, raising=False)
    monkeypatch.setattr(_eval_routes, "COMBOS_AT_ONCE", 2000, raising=False)
    peaks = []
    for n_pairs in (10, 100):
        tracemalloc.start()
        try:
            base = tracemalloc.get_traced_memory()[0]
            got = report(n_pairs)
            peaks.append(tracemalloc.get_traced_memory()[1] - base)
        finally:
            tracemalloc.stop()
    assert got == whole
    assert peaks[1] < 1.3 * peaks[0]


def _listed_pairs(fs, regions, n_pairs, seed):
    """Pairs drawn as ``sample_pairs`` draws them, from each region's listed pixels."""
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    slices = ndimage.find_objects(fs.labels)
    n_src = -(-n_pairs // 10)
    regions = np.asarray(regions, np.int64)
    src_region = np.sort(
        rng.choice(regions, size=n_src, p=fs.area_m2[regions] / fs.area_m2[regions].sum())
    )
    counts = np.full(n_src, 10)
    counts[-1] = n_pairs - 10 * (n_src - 1)
    sources, targets = [], []
    for rid, k in zip(src_region.tolist(), counts.tolist(), strict=True):
        sl = slices[rid - 1]
        rr, cc = np.nonzero(fs.labels[sl] == rid)
        px = np.stack([rr + sl[0].start, cc + sl[1].start], axis=1)
        i = int(rng.integers(px.shape[0]))
        j = rng.integers(px.shape[0] - 1, size=k)
        sources.append(px[i])
        targets.append(px[j + (j >= i)])
    return np.array(sources), np.concatenate(targets)


def test_pair_sampling_reads_rows_instead_of_listing_the_region():
    import tracemalloc

    from topojax.routegraph._eval_routes import sample_pairs
    from topojax.routegraph.feasible import feasible_space

    rng = np.random.default_rng(4)
    occ = rng.random((120, 150)) < 0.1  # many regions of odd shapes at this radius
    occ[[0, -1]] = True
    occ[:, [0, -1]] = True
    fs = feasible_space(_map(occ), 0.15)
    regions = np.array([r for r in fs.regions_at_least(0.0) if fs.area_m2[r] >= 1.5 * RES**2])
    assert regions.size > 5
    for n_pairs, seed in ((300, 0), (57, 9)):
        pairs = sample_pairs(fs, fs.regions_at_least(0.0), n_pairs, seed)
        src, tgt = _listed_pairs(fs, regions, n_pairs, seed)
        np.testing.assert_array_equal(pairs.source, src)
        np.testing.assert_array_equal(pairs.target, tgt)
    # one hall of 4 Mpx: listing its pixels would take 16 bytes each (64 MB and more)
    hall = np.zeros((2000, 2000), bool)
    hall[[0, -1]] = True
    hall[:, [0, -1]] = True
    fs = feasible_space(_map(hall), RADIUS)
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        pairs = sample_pairs(fs, fs.regions_at_least(0.0), 300, seed=0)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    assert pairs.n_pairs == 300
    assert peak < 2 * hall.size  # the bounding box compared with the region, one byte a pixel


def test_string_positions_as_networkx_reads_graphml_point_at_load_graph(tmp_path):
    """GraphML holds lists as text: a graph read with networkx.read_graphml carries
    '[x, y]' strings, which read as two numbers in the message; the error says they are
    text and names topojax.load_graph, which decodes them (its graph then scores)."""
    from topojax import load_graph

    m = _corridor(7)
    ends = [[float(v) for v in m.pixel_to_world(4, c)] for c in (5, 90)]
    g = nx.Graph()
    g.add_node("a", world=json.dumps(ends[0]))
    g.add_node("b", world=json.dumps(ends[1]))
    g.add_edge("a", "b", world=json.dumps(ends))
    nx.write_graphml(g, tmp_path / "peer.graphml")
    raw = nx.read_graphml(tmp_path / "peer.graphml")
    words = r"received str '\[.*text.*topojax\.load_graph"
    with pytest.raises(ValueError, match=rf"vertex 'a' attribute 'world': .*{words}"):
        evaluate_route_graph(raw, m, RADIUS, n_pairs=10)
    for n in ("a", "b"):
        raw.nodes[n]["world"] = json.loads(raw.nodes[n]["world"])
    with pytest.raises(ValueError, match=rf"edge \('a', 'b'\) attribute 'world': .*{words}"):
        evaluate_route_graph(raw, m, RADIUS, n_pairs=10)
    report = evaluate_route_graph(load_graph(tmp_path / "peer.graphml"), m, RADIUS, n_pairs=10)
    assert report.graph_length_m == pytest.approx(85 * RES)


def test_a_route_graph_file_read_with_networkx_points_at_load_graph(tmp_path):
    """A route graph saved as GraphML records its map's ``shape`` and ``origin`` as text
    that networkx.read_graphml leaves as it is: the map check refused it as a graph whose
    shape is not 2 integers, without saying why; it now says that it is text and names
    topojax.load_graph, as the positions' errors do."""
    import warnings

    import topojax as tj

    m = _corridor(7)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rg = tj.route_graph(m, robot_radius_m=RADIUS)
    tj.save_graph(rg, tmp_path / "rg.graphml")
    raw = nx.read_graphml(tmp_path / "rg.graphml")
    with pytest.raises(
        ValueError, match=r"recorded shape .*received '\[.*text.*topojax\.load_graph"
    ):
        evaluate_route_graph(raw, m, RADIUS, n_pairs=10)
