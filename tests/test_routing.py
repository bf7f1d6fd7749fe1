"""Routes on topology graphs (topojax.routing).

Reference: the skeleton's own pixel graph, built here independently (8-neighbour links,
without the diagonal of an L, straight steps 1 and diagonal steps sqrt(2) pixels), with
networkx's Dijkstra between the snapped pixels, and snapping checked against a brute-force
nearest skeleton pixel.  A route on the contracted graph must be exactly as long as that.
"""

from __future__ import annotations

import math
import warnings

import networkx as nx
import numpy as np
import pytest
from brute_force import distance_to_polyline, segment_pixels_exact
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage.morphology import skeletonize
from view_cases import crossing_graph, wall_between

import topojax as tj
from topojax._sight import sees, segment_pixels
from topojax.graph import prune_graph, skeleton_to_graph
from topojax.routing import NoRouteError, RoutePlanner, plan_route

SQRT2 = math.sqrt(2.0)


def art(text: str) -> np.ndarray:
    """'#' = skeleton pixel, '.' = background."""
    rows = [line.strip() for line in text.strip().splitlines()]
    return np.array([[ch == "#" for ch in r] for r in rows], dtype=bool)


def pixel_graph(skeleton: np.ndarray, res: float) -> nx.Graph:
    """The skeleton's pixel graph: 8-neighbours, a diagonal dropped where a pixel
    4-adjacent to both of its ends is set; weights in metres."""
    pts = {tuple(p) for p in np.argwhere(skeleton).tolist()}
    g = nx.Graph()
    g.add_nodes_from(pts)
    for r, c in pts:
        for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
            q = (r + dr, c + dc)
            if q not in pts:
                continue
            diagonal = dr != 0 and dc != 0
            if diagonal and ((r + dr, c) in pts or (r, c + dc) in pts):
                continue
            g.add_edge((r, c), q, w=(SQRT2 if diagonal else 1.0) * res)
    return g


def snap_targets(skeleton: np.ndarray, ref: nx.Graph) -> np.ndarray:
    """The skeleton pixels a query may snap to: those with a link (lone pixels lead
    nowhere), or every pixel of a skeleton without links."""
    pts = np.argwhere(skeleton)
    linked = np.array([ref.degree(tuple(p)) > 0 for p in pts.tolist()], bool)
    return pts[linked] if linked.any() else pts


def check_route(route, query_start, query_goal, skeleton, ref: nx.Graph, res: float) -> None:
    """The route snaps to nearest skeleton pixels, follows the pixel graph's links and is
    as long as the pixel graph's shortest path between its ends."""
    pts = snap_targets(skeleton, ref).astype(float)
    for q, pixel, snap in (
        (query_start, route.pixels[0], route.start_snap_m),
        (query_goal, route.pixels[-1], route.goal_snap_m),
    ):
        d = np.hypot(*(pts - np.asarray(q, float)).T)
        assert skeleton[tuple(pixel)]
        assert math.hypot(*(pixel - np.asarray(q, float))) == pytest.approx(d.min(), abs=1e-9)
        assert snap == pytest.approx(d.min() * res, abs=1e-9)
    nodes = [tuple(p) for p in route.pixels.tolist()]
    steps = 0.0
    for a, b in zip(nodes[:-1], nodes[1:], strict=True):
        assert ref.has_edge(a, b), (a, b)
        steps += ref.edges[a, b]["w"]
    want = nx.dijkstra_path_length(ref, nodes[0], nodes[-1], weight="w")
    assert route.length_m == pytest.approx(want, rel=1e-12, abs=1e-9)
    assert steps == pytest.approx(want, rel=1e-12, abs=1e-9)


def random_queries(skeleton: np.ndarray, n: int, seed: int, spread: float = 4.0):
    rng = np.random.default_rng(seed)
    pts = np.argwhere(skeleton)
    picks = pts[rng.integers(len(pts), size=(n, 2))]
    return picks + rng.uniform(-spread, spread, size=picks.shape)


# ------------------------------------------------------------------ literal fixtures

U_WITH_SHORTCUT = """
..............
##############
..#.........#.
..#.........#.
..#.........#.
..#.........#.
..##########..
"""


def test_route_takes_the_shortcut_not_the_long_edge_between_the_same_junctions():
    skel = art(U_WITH_SHORTCUT)
    g = skeleton_to_graph(skel, resolution_m=1.0)
    # the goal's and the start's edge is the U; the short way leaves it at both ends
    r = plan_route(g, (3.0, 2.0), (3.0, 12.0), frame="pixel")
    assert r.length_m == pytest.approx(2 + 10 + 2)
    assert len(r.vertices) == 2
    check_route(r, (3.0, 2.0), (3.0, 12.0), skel, pixel_graph(skel, 1.0), 1.0)
    # along the top line, the direct way along one edge
    r = plan_route(g, (0.6, 4.0), (1.0, 9.0), frame="pixel")
    assert r.length_m == pytest.approx(5.0) and r.vertices == ()
    assert len(r.edges) == 1


@pytest.mark.parametrize("end", [(0, 5), (5, 0), (10, 5), (5, 10), (2, 5), (5, 8)])
def test_a_point_where_edges_cross_may_leave_along_either(end):
    # (5, 5) lies on edge a-b and on edge c-d, as near to a query there as can be: the
    # route takes whichever is shorter, from the crossing and to it
    _, g = crossing_graph()
    planner = RoutePlanner(g)
    want = abs(end[0] - 5) + abs(end[1] - 5)
    for a, b in (((5, 5), end), (end, (5, 5))):
        r = planner.route(a, b, frame="pixel")
        assert r.length_m == pytest.approx(want)
        assert r.vertices == () and len(r.edges) == 1
        assert r.pixels[0].tolist() == list(a) and r.pixels[-1].tolist() == list(b)
        assert r.start_snap_m == r.goal_snap_m == 0.0


RING = """
.#######.
#.......#
#.......#
#.......#
.#######.
"""


@pytest.mark.parametrize("start, goal", [((1, 0), (3, 8)), ((0, 2), (0, 6)), ((4, 1), (0, 1))])
def test_ring_is_left_in_the_shorter_direction(start, goal):
    skel = art(RING)
    g = skeleton_to_graph(skel, resolution_m=0.1)
    assert [d["kind"] for _, d in g.nodes(data=True)] == ["ring"]
    for a, b in ((start, goal), (goal, start)):
        r = plan_route(g, a, b, frame="pixel")
        check_route(r, a, b, skel, pixel_graph(skel, 0.1), 0.1)
        assert r.length_m <= g.edges[0, 0, 0]["length_m"] / 2 + 1e-12


LOOP_ON_A_LINE = """
...###...
..#...#..
..#...#..
...#.#...
....#....
#########
"""


def test_routes_through_a_self_loop_at_a_junction():
    skel = art(LOOP_ON_A_LINE)
    g = skeleton_to_graph(skel, resolution_m=1.0)
    assert any(u == v for u, v in g.edges())
    ref = pixel_graph(skel, 1.0)
    for a, b in (((0, 4), (5, 0)), ((5, 8), (1, 2)), ((0, 3), (2, 6)), ((5, 1), (5, 7))):
        check_route(plan_route(g, a, b, frame="pixel"), a, b, skel, ref, 1.0)


def test_disconnected_pieces_and_isolated_pixels():
    skel = art(
        """
        #####....
        .........
        ....#....
        .........
        ..#######
        """
    )
    g = skeleton_to_graph(skel, resolution_m=0.5)
    with pytest.raises(NoRouteError, match="different components") as info:
        plan_route(g, (0, 1), (4, 7), frame="pixel")
    assert isinstance(info.value, nx.NetworkXNoPath)
    # a vertex without edges leads nowhere (pruning leaves them where a corridor was too
    # narrow): a point beside one snaps to the nearest corridor
    r = plan_route(g, (2.6, 4), (4, 7), frame="pixel")
    assert r.pixels.tolist() == [[4, 4], [4, 5], [4, 6], [4, 7]] and r.length_m == 1.5
    r = plan_route(g, (0, 2.2), (0, 2.4), frame="pixel")  # one pixel of an edge
    assert r.length_m == 0.0 and r.pixels.tolist() == [[0, 2]]
    # in a graph without edges, its vertices are all there is to snap to
    specks = skeleton_to_graph(art("#...#"), resolution_m=0.5)
    r = plan_route(specks, (0.2, 0.1), (-0.1, -0.2), frame="pixel")  # both snap to one
    assert r.length_m == 0.0 and r.pixels.tolist() == [[0, 0]] and r.edges == ()
    with pytest.raises(NoRouteError, match="different components"):
        plan_route(specks, (0, 0), (0, 4), frame="pixel")


def test_world_frame_equals_pixel_frame_through_the_map_transform():
    skel = np.pad(art(U_WITH_SHORTCUT), 3)
    m = tj.OccupancyMap.from_array(~skel, resolution_m=0.25, origin=(1.0, -2.0, 0.3))
    g = skeleton_to_graph(skel, resolution_m=0.25, pixel_to_world=m.pixel_to_world)
    planner = RoutePlanner(g)
    for a, b in (((6.2, 5.1), (6.4, 15.3)), ((4.0, 3.0), (9.0, 12.0))):
        rp = planner.route(a, b, frame="pixel")
        wa, wb = (np.array(m.pixel_to_world(*p), float) for p in (a, b))
        rw = planner.route(wa, wb)  # world frame is the default
        np.testing.assert_array_equal(rw.pixels, rp.pixels)
        assert rw.length_m == rp.length_m
        assert rw.start_snap_m == pytest.approx(rp.start_snap_m)
        x, y = m.pixel_to_world(rw.pixels[:, 0], rw.pixels[:, 1])
        np.testing.assert_allclose(rw.world, np.stack([x, y], axis=1))


# ------------------------------------------------------------------ real maps


@pytest.mark.parametrize("name", ["intel", "office", "a_scan"])
def test_routes_on_the_paper_maps_equal_the_pixel_graph(name):
    res = tj.build_graph(tj.sample_map(name), config=tj.PipelineConfig())
    skel, g = res.skeleton, res.graph
    ref = pixel_graph(skel, g.graph["resolution_m"])
    planner = RoutePlanner(g)
    found = missing = 0
    for a, b in random_queries(skel, 60, seed=len(name)):
        try:
            route = planner.route(a, b, frame="pixel")
        except NoRouteError:
            missing += 1
            # the reference agrees that the snapped pixels are not connected
            pts = snap_targets(skel, ref)
            sa = tuple(pts[np.argmin(np.hypot(*(pts - a).T))])
            sb = tuple(pts[np.argmin(np.hypot(*(pts - b).T))])
            assert not nx.has_path(ref, sa, sb)
            continue
        found += 1
        check_route(route, a, b, skel, ref, g.graph["resolution_m"])
        assert route.vertices == tuple(v for v in route.vertices if v in g)
        for u, v, k in route.edges:
            assert g.has_edge(u, v, k)
    assert found > 20


def test_pruned_and_reloaded_graphs_route_the_same(tmp_path):
    res = tj.build_graph(tj.sample_map("intel"))
    g = prune_graph(res.graph, min_spur_m=0.5, min_component_m=2.0)
    planner = RoutePlanner(g)
    queries = [((10.0, 20.0), (30.0, 15.0)), ((5.0, 5.0), (33.0, 30.0)), ((20, 4), (12, 30))]
    routes = []
    for a, b in queries:
        try:
            routes.append(planner.route(a, b))
        except NoRouteError:
            routes.append(None)
    assert any(r is not None for r in routes)
    for ext in ("json", "graphml", "geojson"):
        path = tmp_path / f"g.{ext}"
        tj.save_graph(g, path)
        loaded = RoutePlanner(tj.load_graph(path))
        for (a, b), want in zip(queries, routes, strict=True):
            if want is None:
                with pytest.raises(NoRouteError):
                    loaded.route(a, b)
                continue
            got = loaded.route(a, b)
            np.testing.assert_array_equal(got.pixels, want.pixels)
            np.testing.assert_allclose(got.world, want.world)
            assert got.length_m == pytest.approx(want.length_m, rel=1e-12)


def test_merged_junction_clusters_route_through_the_cluster():
    res = tj.build_graph(
        tj.sample_map("a_scan"),
        config=tj.PipelineConfig(graph=tj.GraphConfig(merge_junction_clusters=True)),
    )
    g = res.graph
    planner = RoutePlanner(g)
    n = 0
    for a, b in random_queries(res.skeleton, 40, seed=3):
        try:
            r = planner.route(a, b, frame="pixel")
        except NoRouteError:
            continue
        n += 1
        # every jump in the pixel path is inside one vertex's cluster
        steps = np.abs(np.diff(r.pixels.astype(int), axis=0)).max(axis=1)
        for i in np.flatnonzero(steps > 1):
            owners = [
                v
                for v in r.vertices
                if {tuple(r.pixels[i]), tuple(r.pixels[i + 1])}
                <= {tuple(p) for p in np.asarray(g.nodes[v]["pixels"]).tolist()}
            ]
            assert owners
        assert r.length_m >= 0
    assert n > 10


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_routes_on_random_skeletons_equal_the_pixel_graph(seed):
    rng = np.random.default_rng(seed)
    skel = skeletonize(rng.random((24, 30)) < 0.55)
    if not skel.any():
        return
    g = skeleton_to_graph(skel, resolution_m=0.5)
    ref = pixel_graph(skel, 0.5)
    planner = RoutePlanner(g)
    for a, b in random_queries(skel, 8, seed=seed, spread=2.0):
        try:
            route = planner.route(a, b, frame="pixel")
        except NoRouteError:
            pts = snap_targets(skel, ref)
            sa = tuple(pts[np.argmin(np.hypot(*(pts - a).T))])
            sb = tuple(pts[np.argmin(np.hypot(*(pts - b).T))])
            assert not nx.has_path(ref, sa, sb)
            continue
        check_route(route, a, b, skel, ref, 0.5)


def test_routes_on_the_incremental_mappers_graph():
    from pathlib import Path

    from topojax.scans import read_carmen

    mapper = tj.IncrementalMapper(resolution_m=0.05)
    for scan in read_carmen(Path(__file__).parent / "data" / "intel_first40.log.gz"):
        mapper.add_scan(scan)
    mapper.update_graph()
    g = mapper.graph
    skel = mapper.skeleton  # the graph's skeleton, over the mapper's bounding box
    ref = pixel_graph(skel, 0.05)
    planner = RoutePlanner(g)
    n = 0
    for a, b in random_queries(skel, 20, seed=1):
        try:
            route = planner.route(a, b, frame="pixel")
        except NoRouteError:
            continue
        n += 1
        check_route(route, a, b, skel, ref, 0.05)
    assert n >= 5


def test_waypoints_keep_the_route_within_the_tolerance():
    g = tj.build_graph(tj.sample_map("intel")).graph
    route = plan_route(g, (10.0, 20.0), (30.0, 15.0))
    counts = []
    for tol in (0.5, 0.1, 0.02):
        w = route.waypoints(tolerance_m=tol)
        np.testing.assert_array_equal(w[0], route.world[0])
        np.testing.assert_array_equal(w[-1], route.world[-1])
        # waypoints are route points, in order, and the route stays near them
        idx = [int(np.flatnonzero((route.world == p).all(axis=1))[0]) for p in w]
        assert idx == sorted(idx)
        assert distance_to_polyline(route.world, w).max() <= tol + 1e-12
        counts.append(len(w))
        feature = route.to_geojson(tolerance_m=tol)
        np.testing.assert_array_equal(feature["geometry"]["coordinates"], np.round(w, 9))
    assert counts[0] < counts[1] < counts[2] <= len(route.world)
    for bad, exc in (
        (0.0, ValueError),
        (-1.0, ValueError),
        (float("nan"), ValueError),
        ("1", TypeError),
    ):
        with pytest.raises(exc, match="tolerance_m"):
            route.waypoints(tolerance_m=bad)
    with pytest.raises(TypeError):
        route.waypoints(0.1)  # an option, named like to_geojson's


def test_reweighted_edges_charge_partial_traversals_in_proportion():
    """A user may re-weight an edge's length_m (a slow or preferred corridor): partial
    traversals then cost their share of it, never a negative or unchanged amount."""
    g = tj.build_graph(tj.sample_map("intel")).graph
    u, v, k, d = max(
        ((a, b, c, e) for a, b, c, e in g.edges(keys=True, data=True) if a != b),
        key=lambda e: e[3]["length_m"],
    )
    w = np.asarray(d["world"])
    start, goal = w[len(w) // 2], w[-1]
    before = plan_route(g, start, goal)
    for factor in (0.5, 3.0):
        h = g.copy()
        h.edges[u, v, k]["length_m"] = d["length_m"] * factor
        after = plan_route(h, start, goal)
        assert after.length_m >= 0
        if after.edges == before.edges:  # the same way, along the re-weighted edge
            assert after.length_m == pytest.approx(before.length_m * factor)
    ring = next((a, b, c) for a, b, c in g.edges(keys=True) if a == b)
    h = g.copy()
    h.edges[ring]["length_m"] *= 0.1
    rw = np.asarray(h.edges[ring]["world"])
    r = plan_route(h, rw[len(rw) // 3], rw[2 * len(rw) // 3])
    assert 0 <= r.length_m <= h.edges[ring]["length_m"]


def test_route_of_one_pixel_is_valid_geojson():
    g = tj.build_graph(tj.sample_map("intel")).graph
    p = next(iter(g.nodes(data=True)))[1]["world"]
    route = plan_route(g, p, p)
    assert route.length_m == 0 and len(route.world) == 1
    for tol in (None, 0.1):
        line = route.to_geojson(tolerance_m=tol)["geometry"]["coordinates"]
        xy = [round(v, 9) for v in p]
        assert line == [xy, xy]  # a LineString needs two positions


def test_route_geojson_writes_no_float_noise():
    """World points carry the noise of origin + (col + 0.5) * resolution (5.675000000000001);
    the GeoJSON coordinates are rounded to 1e-9 m and keep the pixels' metres."""
    import json

    from topojax.routing import Route

    world = np.array([[5.675000000000001, 0.42500000000000004], [42.175000000000004, 1e-7]])
    route = Route(1.0, np.array([[0, 0], [0, 1]], np.int32), world, (), (), 0.0, 0.0)
    text = json.dumps(route.to_geojson())
    assert '"coordinates": [[5.675, 0.425], [42.175, 1e-07]]' in text
    np.testing.assert_array_equal(route.world, world)  # the route itself keeps its floats


def test_a_route_without_world_coordinates_is_refused_as_geojson_not_written_as_nan():
    """A route on a graph's lone vertex that records only its pixel has no world
    coordinates (NaN): its GeoJSON would hold NaN, which is not JSON, so it is refused,
    saying why; with the vertex's ``world`` it is written."""
    g = nx.MultiGraph(resolution_m=0.1)
    g.add_node(0, pixel=(3, 4))
    route = plan_route(g, (3, 4), (3, 4), frame="pixel")
    for kwargs in ({}, {"tolerance_m": 0.1}):
        with pytest.raises(ValueError, match=r"^route: .*world coordinates.*vertex"):
            route.to_geojson(**kwargs)
    g.nodes[0]["world"] = (0.4, 0.3)
    feature = plan_route(g, (3, 4), (3, 4), frame="pixel").to_geojson()
    assert feature["geometry"]["coordinates"] == [[0.4, 0.3], [0.4, 0.3]]


def test_route_repr_summarises_its_arrays_and_ids():
    """A notebook shows a route by its repr: a line with its length, sizes and what it
    says of the robot, not its pixel and world arrays or every vertex and edge id."""
    from topojax.routing import Route

    n = 400
    pixels = np.stack([np.zeros(n, np.int32), np.arange(n, dtype=np.int32)], axis=1)
    world = pixels[:, ::-1] * 0.05
    route = Route(
        20.0,
        pixels,
        world,
        tuple(range(100)),
        tuple((i, i + 1, 0) for i in range(99)),
        0.125,
        0.25,
        start_leg_feasible=True,
        min_clearance_m=0.4,
        robot_radius_m=0.3,
    )
    text = repr(route)
    assert text == (
        "Route(length_m=20.0, pixels=400, vertices=100, edges=99, start_snap_m=0.125, "
        "goal_snap_m=0.25, start_leg_feasible=True, goal_leg_feasible=None, "
        "min_clearance_m=0.4, robot_radius_m=0.3)"
    )


# ------------------------------------------------------------------ bad input


def test_bad_input_gets_clear_errors():
    g = skeleton_to_graph(art(U_WITH_SHORTCUT), resolution_m=1.0)
    planner = RoutePlanner(g)
    with pytest.raises(ValueError, match=r"frame: expected one of .*'grid'"):
        planner.route((1, 1), (2, 2), frame="grid")
    with pytest.raises(ValueError, match=r"start: expected two finite numbers \(x, y\)"):
        planner.route((1.0, float("nan")), (2, 2))
    with pytest.raises(ValueError, match=r"goal: expected two finite numbers \(row, col\)"):
        planner.route((1, 1), (1, 2, 3), frame="pixel")
    with pytest.raises(TypeError, match=r"start: expected two finite numbers .* str 'here'"):
        planner.route("here", (1, 2))
    with pytest.raises(ValueError, match=r"goal: the nearest point of the graph is 3 m away"):
        planner.route((1, 4), (9, 7), frame="pixel", max_snap_m=2.5)
    with pytest.raises(ValueError, match="max_snap_m: expected a finite number"):
        planner.route((1, 4), (2, 7), frame="pixel", max_snap_m=-1.0)
    with pytest.raises(TypeError, match="max_snap_m"):
        planner.route((1, 4), (2, 7), frame="pixel", max_snap_m="1")
    with pytest.raises(
        TypeError, match="graph: expected an undirected networkx graph, received dict"
    ):
        RoutePlanner({})
    with pytest.raises(TypeError, match="undirected networkx graph, received MultiDiGraph"):
        RoutePlanner(nx.MultiDiGraph(g))
    tee = skeleton_to_graph(art("#####\n..#..\n..#.."), resolution_m=1.0)  # no parallel edges
    want = RoutePlanner(tee).route((0, 0), (2, 2), frame="pixel")
    got = RoutePlanner(nx.Graph(tee)).route((0, 0), (2, 2), frame="pixel")  # a plain Graph
    assert got.length_m == want.length_m and got.edges == want.edges
    with pytest.raises(ValueError, match="no vertices or edges"):
        plan_route(nx.MultiGraph(), (0, 0), (1, 1))
    bare = nx.MultiGraph()
    bare.add_edge(0, 1, length_m=1.0)
    with pytest.raises(ValueError, match=r"edge \(0, 1, 0\) has no 'path' attribute"):
        RoutePlanner(bare)
    wrong = g.copy()
    u, v, k = next(iter(wrong.edges(keys=True)))
    wrong.edges[u, v, k]["path"] = wrong.edges[u, v, k]["path"][1:]
    wrong.edges[u, v, k]["world"] = wrong.edges[u, v, k]["world"][1:]
    with pytest.raises(ValueError, match="not the pixels of its vertices"):
        RoutePlanner(wrong)
    for length, exc, words in (
        ("12", TypeError, "real number of metres >= 0, received str '12'"),
        (-1.0, ValueError, "finite number of metres >= 0, received -1.0"),
        (math.nan, ValueError, "finite number of metres >= 0, received nan"),
    ):
        edited = g.copy()
        edited.edges[u, v, k]["length_m"] = length
        with pytest.raises(exc, match=rf"^graph: edge \({u}, {v}, {k}\): 'length_m': .*{words}"):
            RoutePlanner(edited)
    for pixel, exc in (("here", TypeError), ((1.5, 2.0), ValueError), ((1,), ValueError)):
        edited = g.copy()
        edited.nodes[u]["pixel"] = pixel
        with pytest.raises(exc, match=rf"^graph: vertex {u!r}: 'pixel': expected \(row, col\)"):
            RoutePlanner(edited)
    edited = g.copy()
    edited.edges[u, v, k]["world"] = edited.edges[u, v, k]["world"].astype(object)
    edited.edges[u, v, k]["world"][0, 0] = None
    with pytest.raises(
        TypeError,
        match=r"'world': expected a number or an array of real numbers, received ndarray of dtype object",
    ):
        RoutePlanner(edited)
    # the planner read the graph without changing it
    fresh = skeleton_to_graph(art(U_WITH_SHORTCUT), resolution_m=1.0)
    assert list(g.edges(keys=True)) == list(fresh.edges(keys=True))
    for u, v, k, d in g.edges(keys=True, data=True):
        np.testing.assert_array_equal(d["path"], fresh.edges[u, v, k]["path"])


# ------------------------------------------------------------------ command line


def test_route_command_refuses_simplify_without_a_file_to_write(tmp_path, capsys):
    """``--simplify-m`` thins the route written with ``-o``; without ``-o`` it would do
    nothing, so it is refused as the options that need ``--map`` are, not dropped."""
    from topojax.cli import main

    free = np.zeros((40, 60), bool)
    free[5:35, 5:55] = True
    free[15:25, 20:40] = False
    graph = tj.build_graph(tj.OccupancyMap.from_array(free)).graph
    graph_file = tj.save_graph(graph, tmp_path / "g.json")
    a, b = (d["world"] for _, d in list(graph.nodes(data=True))[:2])
    argv = ["route", str(graph_file), "--start", *map(str, a), "--goal", *map(str, b)]
    assert main([*argv, "--simplify-m", "0.1"]) == 2
    captured = capsys.readouterr()
    assert "--simplify-m: only used with -o, which was not given" in captured.err
    assert captured.out == ""
    assert main([*argv, "--simplify-m", "0.1", "-o", str(tmp_path / "r.geojson")]) == 0


def test_a_point_beyond_the_snap_limit_is_refused_in_the_callers_words(tmp_path, capsys):
    """The planner names its parameter, ``max_snap_m`` and ``None``; ``topojax route``
    names its option, ``--max-snap-m`` and ``none``, and not the parameter as well."""
    from topojax.cli import main

    free = np.zeros((40, 60), bool)
    free[5:35, 5:55] = True
    free[15:25, 20:40] = False
    graph = tj.build_graph(tj.OccupancyMap.from_array(free)).graph
    a, b = (d["world"] for _, d in list(graph.nodes(data=True))[:2])
    off = (a[0] + 0.3, a[1] + 0.3)
    with pytest.raises(ValueError) as err:
        plan_route(graph, off, b, max_snap_m=0.01)
    text = str(err.value)
    assert text.startswith("start: the nearest point of the graph is ")
    assert text.endswith(
        "m away, more than max_snap_m=0.01 (pass a larger max_snap_m, or None for no limit)"
    )
    assert "--max-snap-m" not in text
    graph_file = tj.save_graph(graph, tmp_path / "g.json")
    argv = ["route", str(graph_file), "--start", *map(str, off), "--goal", *map(str, b)]
    assert main([*argv, "--max-snap-m", "0.01"]) == 2
    err = capsys.readouterr().err
    assert "error: --start: the nearest point of the graph is " in err
    assert "more than --max-snap-m 0.01 (pass a larger --max-snap-m, or none for no limit)" in err
    assert "max_snap_m" not in err and "None" not in err


def test_route_command_prints_and_writes_the_route(tmp_path, capsys):
    import json

    from topojax.cli import main

    g = prune_graph(tj.build_graph(tj.sample_map("intel")).graph, min_spur_m=0.5)
    graph_file = tj.save_graph(g, tmp_path / "intel.json")
    out = tmp_path / "r" / "route.geojson"
    argv = ["route", str(graph_file), "--start", "5", "30", "--goal", "33", "5"]
    assert main([*argv, "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    want = plan_route(tj.load_graph(graph_file), (5.0, 30.0), (33.0, 5.0))
    assert f"{want.length_m:.2f} m along the graph" in printed
    feature = json.loads(out.read_text())
    assert feature["geometry"]["type"] == "LineString"
    np.testing.assert_allclose(feature["geometry"]["coordinates"], want.world)
    assert feature["properties"]["length_m"] == want.length_m
    assert feature["properties"]["vertices"] == list(want.vertices)
    assert main([*argv, "-o", str(out), "--simplify-m", "0.2"]) == 0
    thin = json.loads(out.read_text())["geometry"]["coordinates"]
    np.testing.assert_allclose(thin, want.waypoints(tolerance_m=0.2))
    assert "warning" not in capsys.readouterr().err
    # wider than the corridors: its straight segments may cross walls, which is said
    assert main([*argv, "-o", str(out), "--simplify-m", "50"]) == 0
    err = capsys.readouterr().err
    words = (
        f"--simplify-m 50 m is more than the route's least clearance, "
        f"{want.min_clearance_m:.3f} m: the written route's straight segments may cross "
        "obstacles"
    )
    assert words in err
    assert main([*argv, "-o", str(out), "--simplify-m", "-1"]) == 2
    assert "--simplify-m: expected a finite number of metres > 0" in capsys.readouterr().err
    # the route is GeoJSON: another suffix is refused before any work, nothing written
    assert main([*argv, "-o", str(tmp_path / "route.txt")]) == 2
    err = capsys.readouterr().err
    assert "-o: expected a .geojson or .json file (the route is written as GeoJSON)" in err
    assert not (tmp_path / "route.txt").exists()
    # too far from the graph: a clear error and exit status 2
    assert main([*argv, "--max-snap-m", "0.01"]) == 2
    err = capsys.readouterr().err
    assert "error: --start: the nearest point of the graph is" in err and "--max-snap-m 0.01" in err
    # a point the planner refuses is named by its option
    assert main([*argv[:6], "nan", "5"]) == 2
    err = capsys.readouterr().err
    assert "error: --goal: expected two finite numbers (x, y) in metres, received (nan, 5.0)" in err
    assert main([*argv, "--max-snap-m", "-1"]) == 2
    assert (
        "--max-snap-m: expected a number of metres >= 0, or none or inf" in capsys.readouterr().err
    )
    assert main([*argv, "--max-snap-m", "none"]) == 0  # no limit (the start is 0.55 m off)
    capsys.readouterr()
    assert main([*argv, "--max-snap-m", "inf"]) == 0  # no limit either
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:  # argparse's own exit
        main([*argv, "--max-snap-m", "x"])
    assert info.value.code == 2
    assert "--max-snap-m: expected a number of metres or none" in capsys.readouterr().err
    assert main([*argv, "--map", "x.yaml", "--robot-radius", "-1"]) == 2
    assert "--robot-radius: expected" in capsys.readouterr().err
    assert main([*argv, "--map", "x.yaml", "--robot-radius", "2000"]) == 2
    err = capsys.readouterr().err
    assert "--robot-radius: expected a robot radius of at most 1000 m" in err
    # pixel frame, and no route between two components: exit status 1
    skel = art("###....###")
    two = tj.save_graph(skeleton_to_graph(skel, resolution_m=1.0), tmp_path / "two.graphml")
    argv = ["route", str(two), "--pixel", "--start", "0", "0", "--goal", "0", "9"]
    assert main(argv) == 1
    assert "different components" in capsys.readouterr().err


def test_route_command_names_its_graph_argument_for_a_missing_or_foreign_file(tmp_path, capsys):
    """A graph file that is missing or not a graph file is named ``graph``, as the command
    calls it, not by the library's ``path`` or its Python-only ``format=``."""
    from topojax.cli import main

    picture = tmp_path / "map.png"
    picture.write_bytes(b"not read")
    points = ["--start", "1", "1", "--goal", "2", "2"]
    assert main(["route", str(tmp_path / "none.json"), *points]) == 2
    assert f"graph: file not found: {tmp_path / 'none.json'}" in capsys.readouterr().err
    assert main(["route", str(picture), *points]) == 2
    err = capsys.readouterr().err
    assert f"graph: expected a .graphml, .json or .geojson file, received {picture}" in err
    assert "format=" not in err


def test_a_room_graph_is_refused_as_one_naming_the_graphs_routes_run_on(tmp_path, capsys):
    """A room graph (``topojax rooms``) is refused as a room graph, naming the graphs
    that routes run on, not failing on its first edge's missing 'path'."""
    from room_maps import three_rooms

    from topojax.cli import main

    seg = tj.segment_rooms(three_rooms())
    assert seg.n_rooms == 3
    expected = "graph: expected a topology graph (build_graph, topojax graph) or a route graph"
    received = "received a room graph (rooms as nodes, doors as edges"
    for suffix in (".json", ".graphml"):
        path = tj.save_room_graph(seg, tmp_path / f"rooms{suffix}")
        with pytest.raises(ValueError, match="received a room graph") as info:
            RoutePlanner(tj.load_graph(path))
        assert str(info.value).startswith(expected)
        assert main(["route", str(path), "--start", "0", "0", "--goal", "1", "1"]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"topojax route: error: {expected}") and received in err
    # one without the graph attributes (RoomSegmentation.graph) is told by its doors
    with pytest.raises(ValueError, match="received a room graph"):
        RoutePlanner(seg.graph)


def test_route_command_with_the_map_joins_the_graph_where_the_route_is_shortest(tmp_path, capsys):
    from topojax.cli import main

    m = tj.sample_map("intel")
    graph_file = tj.save_graph(tj.route_graph(m), tmp_path / "rg.json")
    start, goal = (150, 300), (170, 330)
    argv = ["route", str(graph_file), "--pixel", "--start", "150", "300", "--goal", "170", "330"]
    from topojax.datasets import sample_map_path

    map_file = str(sample_map_path("intel"))
    assert main([*argv, "--map", map_file, "--resolution", "0.05"]) == 0
    printed = capsys.readouterr().out
    want = RoutePlanner(tj.load_graph(graph_file), occupancy=m).route(start, goal, frame="pixel")
    assert f"{want.length_m:.2f} m along the graph" in printed
    assert f"start {want.start_snap_m:.3f} m" in printed
    # a map of another size is refused, naming the option
    small = tmp_path / "small.png"
    import cv2

    cv2.imwrite(str(small), np.full((20, 20), 255, np.uint8))
    assert main([*argv, "--map", str(small)]) == 2
    assert "--map: expected the graph's map of shape" in capsys.readouterr().err
    # options that only matter with the map are refused without it
    assert main([*argv, "--resolution", "0.05", "--entry-m", "2"]) == 2
    err = capsys.readouterr().err
    assert "--resolution, --entry-m: only used with --map, which was not given" in err
    # a topology graph records no robot radius: the option is named, not the parameter
    paper = tj.save_graph(tj.build_graph(m).graph, tmp_path / "paper.json")
    assert main(["route", str(paper), *argv[2:], "--map", map_file]) == 2
    assert "--robot-radius: expected the robot radius in metres with --map" in (
        capsys.readouterr().err
    )


def test_route_command_names_the_map_option_when_the_map_cannot_be_loaded(tmp_path, capsys):
    """A map that is missing or does not load is named by ``--map`` (the option that gave
    it), as a map of another size is, not by its file name alone."""
    from topojax.cli import main

    graph = tj.save_graph(skeleton_to_graph(art("#####"), resolution_m=1.0), tmp_path / "g.json")
    undecodable = tmp_path / "bad.png"
    undecodable.write_bytes(b"not an image")
    no_origin = tmp_path / "map.yaml"
    no_origin.write_text("image: map.pgm\nresolution: 0.05\n")
    argv = ["route", str(graph), "--pixel", "--start", "0", "0", "--goal", "0", "4"]
    for map_file, message in (
        (tmp_path / "none.png", f"map file not found: {tmp_path / 'none.png'}"),
        (undecodable, f"could not decode map image {undecodable}"),
        (no_origin, f"map YAML {no_origin} is missing the required key 'origin'"),
    ):
        assert main([*argv, "--map", str(map_file), "--robot-radius", "0.1"]) == 2
        assert f"topojax route: error: --map: {message}" in capsys.readouterr().err


def test_default_snap_limit_refuses_far_points_and_none_lifts_it():
    import topojax as tj
    from topojax.routing import DEFAULT_MAX_SNAP_M

    g = tj.build_graph(tj.sample_map("intel")).graph
    u, v = max(
        (e for e in g.edges(keys=True) if e[0] != e[1]), key=lambda e: g.edges[e]["length_m"]
    )[:2]
    start, goal = g.nodes[u]["world"], g.nodes[v]["world"]
    assert tj.plan_route(g, start, goal).length_m > 0
    far = (start[0] + 1000.0, start[1])  # a kilometre off: a frame mix-up, not a goal
    with pytest.raises(ValueError, match="max_snap_m=5.0 .*None for no limit"):
        tj.plan_route(g, start, far)
    assert DEFAULT_MAX_SNAP_M == 5.0
    for no_limit in (None, float("inf"), np.inf):  # snapped however far, to a piece
        try:  # that may be out of reach
            tj.plan_route(g, start, far, max_snap_m=no_limit)
        except tj.NoRouteError:
            pass


@pytest.mark.parametrize("max_snap_m", [5.0, None])
@pytest.mark.parametrize("far", [(1e200, 0.0), (-1e300, 5.0), (1e160, 1e160)])
def test_a_point_too_far_for_any_distance_gets_the_planners_error(far, max_snap_m):
    """A finite point so far off that its squared distance overflows (a unit or frame
    mix-up) is refused as far off, not left to fail inside SciPy's k-d tree ("The value
    of p too large for this dataset"), which names neither the point nor the graph."""
    g = tj.build_graph(tj.sample_map("intel")).graph
    start = g.nodes[0]["world"]
    with pytest.raises(ValueError, match=r"^goal: the nearest point of the graph is more than"):
        tj.plan_route(g, start, far, max_snap_m=max_snap_m)
    with pytest.raises(ValueError, match=r"^start: the nearest point of the graph is more than"):
        tj.plan_route(g, far, start, frame="pixel", max_snap_m=max_snap_m)


@pytest.mark.parametrize("frame", ["world", "pixel"])
def test_a_point_too_far_to_tell_the_graphs_points_apart_is_refused_without_a_snap_limit(frame):
    """Beyond 1e5 m (pixels in the pixel frame) the rounding of a distance outgrows the
    tolerance within which corridor points count as equally near, so a far start and goal
    would tie with every point and meet on one: a route of length 0.  With no snap limit
    such a point is refused, naming it and max_snap_m; one just within is routed as a
    nearer one along the same line is."""
    g = prune_graph(tj.build_graph(tj.sample_map("intel")).graph)
    planner = RoutePlanner(g)
    key = "world" if frame == "world" else "path"
    pts = np.concatenate([d[key] for *_, d in g.edges(data=True)]).astype(float)
    edge = pts[:, 0].max()
    top = pts[pts[:, 0] == edge]  # the points farthest along the first axis
    a, b = (float(top[:, 1].min()), float(top[:, 1].max()))
    assert b - a > 1.0
    for far in (1e9, 1e12):
        with pytest.raises(ValueError, match=r"^start: .*max_snap_m=None.* frame"):
            planner.route((edge + far, a), (edge + 10.0, b), frame=frame, max_snap_m=None)
        with pytest.raises(ValueError, match=r"^goal: .*max_snap_m=None"):
            plan_route(g, (edge + 10.0, a), (edge + far, b), frame=frame, max_snap_m=None)
    near = planner.route((edge + 10.0, a), (edge + 10.0, b), frame=frame, max_snap_m=None)
    within = planner.route((edge + 9e4, a), (edge + 9e4, b), frame=frame, max_snap_m=None)
    assert near.length_m > 0 and within.length_m == pytest.approx(near.length_m)


def _fork(wall: bool = False, radius: float | None = 0.25):
    """A free 32 x 34 map of 0.1 m pixels (walls all round) with a fork from vertex "j" at
    (10, 3): edge j-a along row 10 to (10, 28), edge j-b down column 3 and along row 20 to
    (20, 28); with ``wall``, a wall along row 16 from column 15 on."""
    occupied = np.ones((32, 34), bool)
    occupied[1:-1, 1:-1] = False
    if wall:
        occupied[16, 15:] = True
    m = tj.OccupancyMap.from_array(occupied, resolution_m=0.1)
    attrs = {"resolution_m": 0.1, "shape": (32, 34), "origin": tuple(m.origin)}
    if radius is not None:
        attrs["robot_radius_m"] = radius
    g = nx.MultiGraph(**attrs)
    for name, pixel in {"j": (10, 3), "a": (10, 28), "b": (20, 28)}.items():
        g.add_node(name, pixel=pixel, world=tuple(float(x) for x in m.pixel_to_world(*pixel)))
    paths = {
        "a": [(10, c) for c in range(3, 29)],
        "b": [(r, 3) for r in range(10, 21)] + [(20, c) for c in range(4, 29)],
    }
    for end, path in paths.items():
        path = np.array(path, np.int64)
        x, y = m.pixel_to_world(path[:, 0], path[:, 1])
        g.add_edge("j", end, path=path, world=np.stack([x, y], 1), length_m=0.1 * (len(path) - 1))
    return m, g


def test_no_sight_line_is_drawn_past_max_snap_m(monkeypatch):
    """Joins farther than ``max_snap_m`` are dropped, so none is tested: with a long
    ``entry_m``, drawing the sight line of every corridor point of the map first would
    take 38.7 s a query on the DM_0.11 route graph with entry_m=1e6, for the route of
    entry_m=5."""
    import topojax.routing as routing

    m, g = _fork()
    start, goal = (13, 20), (18, 26)
    want = RoutePlanner(g, occupancy=m, entry_m=0.5).route(start, goal, frame="pixel")
    drawn = []

    def counting(feasible, q, points):
        drawn.append(float(np.hypot(*(points - q).T).max()))
        return sees(feasible, q, points)

    monkeypatch.setattr(routing, "_sees", counting)
    got = RoutePlanner(g, occupancy=m, entry_m=1e6).route(
        start, goal, frame="pixel", max_snap_m=0.5
    )
    assert drawn and max(drawn) <= 5.0 + 1e-9  # 0.5 m: 5 pixels
    assert got.length_m == want.length_m and got.start_snap_m == want.start_snap_m
    assert np.array_equal(got.pixels, want.pixels)


def test_with_a_long_reach_sight_lines_are_drawn_only_as_far_as_a_join_can_shorten_the_route(
    monkeypatch,
):
    """A join d metres off costs at least d less the nearest join's distance, so joins
    are looked for in growing rings until one beyond could not give a shorter route: with
    entry_m=15 and no snap limit, a short route on the Intel route graph draws no sight
    line to the corridors 15 m off (every one of them within the reach, before: 35 s a
    query on the nav2 warehouse map at entry_m=100), and routes are the same as with one
    pass over the whole reach."""
    import topojax.routing as routing

    m = tj.sample_map("intel")
    rg = tj.route_graph(m, robot_radius_m=0.3)
    planner = RoutePlanner(rg, occupancy=m, entry_m=15.0)
    feasible = tj.routegraph.feasible.feasible_space(m, 0.3).feasible
    part = rg.subgraph(max(nx.connected_components(rg), key=len))
    near = np.concatenate([d["path"] for *_, d in part.edges(data=True)])
    rng = np.random.default_rng(5)
    near = near[rng.choice(len(near), 60)] + rng.integers(-10, 11, (60, 2))
    near = [tuple(p) for p in near.tolist() if feasible[tuple(p)]]
    queries = list(zip(near[0:10:2], near[1:10:2], strict=True))
    drawn = []

    def counting(feasible, q, points):
        drawn.append(float(np.hypot(*(points - q).T).max()))
        return sees(feasible, q, points)

    monkeypatch.setattr(routing, "_sees", counting)
    path = max((d["path"] for *_, d in rg.edges(data=True)), key=len)
    a, b = (tuple(int(v) for v in path[i]) for i in (len(path) // 2, len(path) // 2 + 10))
    short = planner.route(a, b, frame="pixel", max_snap_m=None)
    assert short.length_m < 1.0 and max(drawn) * 0.05 < 5.0

    def answer(a, b):
        try:
            r = planner.route(a, b, frame="pixel", max_snap_m=None)
        except NoRouteError:
            return None
        return r.pixels.tolist(), r.edges, r.length_m, r.start_snap_m, r.goal_snap_m

    got = [answer(a, b) for a, b in queries]
    monkeypatch.setattr(routing, "_FIRST_RING_M", math.inf)  # the whole reach at once
    assert got == [answer(a, b) for a, b in queries]
    assert all(x is not None for x in got)


def test_with_the_map_a_route_joins_the_edge_that_gives_the_shortest_route():
    m, g = _fork()
    start, goal = (13, 20), (18, 26)
    # nearest points (10, 20) and (20, 26): 17 px to the fork, 10 + 23 px to the goal's
    near = RoutePlanner(g).route(start, goal, frame="pixel")
    assert near.length_m == pytest.approx(5.0)
    assert (near.start_snap_m, near.goal_snap_m) == pytest.approx((0.3, 0.2))
    # with the map: 0.7 m straight down to (20, 20), 0.6 m along row 20, 0.2 m to the goal
    # (the mirror, along row 10, costs 0.3 + 0.6 + 0.8)
    best = RoutePlanner(g, occupancy=m).route(start, goal, frame="pixel")
    assert best.length_m == pytest.approx(0.6)
    assert (best.start_snap_m, best.goal_snap_m) == pytest.approx((0.7, 0.2))
    assert best.pixels[0].tolist() == [20, 20] and best.pixels[-1].tolist() == [20, 26]
    assert best.edges == (("j", "b", 0),) and best.vertices == ()
    # the same in the world frame, and through plan_route
    ws, wg = (m.pixel_to_world(*start), m.pixel_to_world(*goal))
    for r in (RoutePlanner(g, occupancy=m).route(ws, wg), plan_route(g, ws, wg, occupancy=m)):
        assert r.length_m == pytest.approx(0.6)
        np.testing.assert_array_equal(r.pixels, best.pixels)
    # a graph without a robot radius needs one; max_snap_m bounds the legs taken too
    m, g = _fork(radius=None)
    r = plan_route(g, start, goal, frame="pixel", occupancy=m, robot_radius_m=0.25)
    assert r.length_m == pytest.approx(0.6)
    r = plan_route(g, start, goal, frame="pixel", occupancy=m, robot_radius_m=0.25, max_snap_m=0.5)
    assert r.start_snap_m == pytest.approx(0.3) and r.length_m == pytest.approx(5.0)


def test_with_the_map_a_route_does_not_join_through_a_wall_or_beyond_reach():
    m, g = _fork(wall=True)
    start, goal = (12, 20), (19, 26)  # row 20 lies 0.8 m below the start, behind the wall
    r = RoutePlanner(g, occupancy=m).route(start, goal, frame="pixel")
    assert r.pixels[0].tolist() == [10, 20] and r.length_m == pytest.approx(5.0)
    m, g = _fork()
    r = RoutePlanner(g, occupancy=m).route(start, goal, frame="pixel")
    assert r.pixels[0].tolist() == [20, 20] and r.length_m == pytest.approx(0.6)
    r = RoutePlanner(g, occupancy=m, entry_m=0.5).route(start, goal, frame="pixel")
    assert r.pixels[0].tolist() == [10, 20] and r.length_m == pytest.approx(5.0)


def test_with_the_map_a_route_does_not_join_a_nearer_point_behind_a_wall():
    """The start (5, 17), left of the wall, is 0.5 m from the right edge's (5, 22)
    behind the wall and 0.7 m from the left edge's (5, 10) in sight.  With the map, the
    route joins only points in sight, and goes round the wall, even where joining the
    nearer point through the wall would make it shortest (here: the goal is right of the
    wall, 0.3 m from (5, 22))."""
    m, g = wall_between()
    start, goal = (5, 17), (5, 25)
    plain = RoutePlanner(g).route(start, goal, frame="pixel")
    assert plain.pixels[0].tolist() == [5, 22] and plain.length_m == pytest.approx(0.0)
    r = RoutePlanner(g, occupancy=m).route(start, goal, frame="pixel")
    assert r.pixels[0].tolist() == [5, 10] and r.pixels[-1].tolist() == [5, 22]
    assert (r.start_snap_m, r.goal_snap_m) == pytest.approx((0.7, 0.3))
    assert r.length_m == pytest.approx(3.0 + 1.2 + 3.0)
    # an end that sees no graph point within reach joins the nearest in sight, up to
    # entry_m farther than the nearest point, not the nearest through the wall
    r = RoutePlanner(g, occupancy=m, entry_m=0.6).route(start, goal, frame="pixel")
    assert r.pixels[0].tolist() == [5, 10] and r.length_m == pytest.approx(3.0 + 1.2 + 3.0)
    assert r.start_snap_m == pytest.approx(0.7)


def test_with_the_map_a_point_the_robot_does_not_fit_at_joins_the_graph_in_sight():
    """A robot closer to a wall than its radius sees no graph point over feasible pixels:
    it leaves along a straight line off the obstacles, as the page's router does, not to
    the nearest point through the wall."""
    m, g = wall_between()
    start, goal = (5, 19), (5, 25)  # 0.1 m from the wall: the robot (0.25 m) does not fit
    assert RoutePlanner(g).route(start, goal, frame="pixel").pixels[0].tolist() == [5, 22]
    r = RoutePlanner(g, occupancy=m).route(start, goal, frame="pixel")
    assert r.pixels[0].tolist() == [5, 10] and r.start_snap_m == pytest.approx(0.9)
    assert r.length_m == pytest.approx(3.0 + 1.2 + 3.0)
    assert sees(~m.occupied, np.array(start, float), r.pixels[:1].astype(float)).all()


def test_with_the_map_a_point_in_a_pocket_the_graph_does_not_reach_is_refused():
    """A point in a closet walled off from the graph, where every leg to the graph
    crosses a wall, is an error, not a route from the nearest point through the wall."""
    m, g = wall_between(closet=True)
    planner = RoutePlanner(g, occupancy=m)
    with pytest.raises(
        ValueError,
        match=r"^start: expected a point that sees the graph along a straight line off the "
        r"map's obstacles, received \(6\.0, 15\.0\) \(pixel frame\), whose nearest point of "
        r"the graph, 0\.5 m away, is behind an obstacle or off the map, as is every other "
        r"within 1\.5 m",
    ):
        planner.route((6, 15), (5, 25), frame="pixel")
    # beyond max_snap_m, the distance is what is refused
    with pytest.raises(ValueError, match=r"^goal: the nearest point of the graph is 0\.5 m"):
        planner.route((5, 25), (6, 15), frame="pixel", max_snap_m=0.4)
    RoutePlanner(g).route((6, 15), (5, 25), frame="pixel")  # without the map: nearest


def test_with_the_map_an_end_joins_its_nearest_point_in_sight_even_with_no_reach():
    # with entry_m=0 the reach beyond the nearest point is that point itself, whatever
    # the rounding of its distance (in metres, the frame routes are asked in)
    m, g = wall_between()
    planner = RoutePlanner(g, occupancy=m, entry_m=0)
    tree, _ = planner._tree("world")
    goal = tuple(map(float, m.pixel_to_world(5, 25)))
    rng = np.random.default_rng(0)
    tried = 0
    for rc in rng.uniform(1.0, 38.0, (400, 2)):
        start = tuple(map(float, m.pixel_to_world(*rc)))
        nearest = np.array(m.world_to_pixel(*tree.data[tree.query(start)[1]]), float)
        if m.occupied[tuple(np.floor(rc + 0.5).astype(int))]:
            continue
        if not sees(~m.occupied, rc, nearest[None])[0]:
            continue
        r = planner.route(start, goal)
        assert r.start_snap_m == pytest.approx(tree.query(start)[0])
        tried += 1
    assert tried > 300


def test_with_the_map_no_sight_line_is_drawn_from_off_the_map(monkeypatch):
    """A point off the map sees nothing: its lines are not drawn (with max_snap_m=None,
    one to every corridor point within reach of a point 100 km off takes gigabytes)."""
    import topojax.routing as routing

    m, g = wall_between()
    drawn = []
    monkeypatch.setattr(routing, "_sees", lambda *a: drawn.append(a) or sees(*a))
    planner = RoutePlanner(g, occupancy=m, entry_m=1e6)
    with pytest.raises(ValueError, match="is behind an obstacle or off the map"):
        planner.route((1e5, 0.0), (1.0, 1.0), max_snap_m=None)
    with pytest.raises(ValueError, match="is behind an obstacle or off the map"):
        planner.route((-0.5, 2.0), (1.0, 1.0))  # just off the map's left side
    assert drawn == []


def test_with_the_map_a_point_on_an_obstacle_is_refused():
    """A robot inside a wall (a localisation fault) or a goal picked on one: with the map
    given, an error naming the point, not a route from the nearest corridor."""
    m, g = _fork(wall=True)
    wall = tuple(int(v) for v in np.argwhere(m.occupied)[0])
    planner = RoutePlanner(g, occupancy=m)
    with pytest.raises(
        ValueError,
        match=rf"start: expected a point off the map's obstacles.*\({wall[0]}, {wall[1]}\)",
    ):
        planner.route(wall, (18, 26), frame="pixel")
    with pytest.raises(ValueError, match="goal: expected a point off the map's obstacles"):
        planner.route((18, 26), m.pixel_to_world(*wall))
    RoutePlanner(g).route(wall, (18, 26), frame="pixel")  # without the map: nearest corridor


@pytest.mark.parametrize("far", [(-1e308, 0.0), (1.7e308, 1.7e308)])
def test_with_the_map_a_point_too_far_for_the_maps_grid_gets_the_planners_error(far):
    """With the map, a finite point so far off that its pixel overflows to infinity is
    refused as far off, as without the map, not left to fail in the obstacle check
    ("cannot convert float infinity to integer"), which names neither the point nor the
    map."""
    m, g = _fork()
    planner = RoutePlanner(g, occupancy=m)
    near = m.pixel_to_world(18, 26)
    with pytest.raises(ValueError, match=r"^start: the nearest point of the graph is more than"):
        planner.route(far, near)
    with pytest.raises(ValueError, match=r"^goal: the nearest point of the graph is more than"):
        planner.route(near, far, max_snap_m=None)


def test_a_map_given_for_a_graph_that_records_no_grid_is_warned_of_by_name():
    """The planner checks the map against the graph's ``shape``, ``resolution_m`` and
    ``origin``; for a graph that lacks some (made by another tool, or its attributes
    dropped), that check is partial or none, and a wrong map would plan legs over the
    wrong pixels without a word: a warning names the attributes missing."""
    m, g = _fork()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a graph that records all three: no warning
        RoutePlanner(g, occupancy=m)
        RoutePlanner(g)  # and none without the map
    for dropped, words in (
        (("origin",), "'origin'"),
        (("shape", "resolution_m", "origin"), "'shape', 'resolution_m' or 'origin'"),
    ):
        bare = g.copy()
        for name in dropped:
            del bare.graph[name]
        with pytest.warns(UserWarning, match=f"^occupancy: the graph records no {words}") as w:
            plan_route(bare, (13, 20), (18, 26), frame="pixel", occupancy=m)
        assert [x.filename for x in w] == [__file__]  # the caller's line, however deep


def test_a_robot_larger_than_the_route_graph_was_built_for_is_refused(tmp_path, capsys):
    """A route graph's edges keep its own robot_radius_m from obstacles and no more: a
    planner asked for a larger robot is refused (its routes would not be safe for it),
    naming both radii, in the API and on the command line; the graph's own radius or a
    smaller one plans, and a topology graph (no radius of its own) takes any."""
    m = tj.sample_map("intel")
    rg = tj.route_graph(m, robot_radius_m=0.3)
    for radius in (0.3, 0.2, None):
        RoutePlanner(rg, occupancy=m, robot_radius_m=radius)
    for radius in (0.31, 2.0):
        with pytest.raises(ValueError, match=r"^robot_radius_m: expected at most the 0.3 m"):
            RoutePlanner(rg, occupancy=m, robot_radius_m=radius)
    RoutePlanner(tj.build_graph(m).graph, occupancy=m, robot_radius_m=2.0)
    from topojax.cli import main

    tj.save_graph(rg, tmp_path / "rg.json")
    argv = ["route", str(tmp_path / "rg.json"), "--map", "topojax/data/intel.png"]
    argv += ["--resolution", "0.05", "--start", "5", "30", "--goal", "33", "5"]
    assert main([*argv, "--robot-radius", "0.25"]) == 0
    capsys.readouterr()
    assert main([*argv, "--robot-radius", "2"]) == 2
    assert "route: error: --robot-radius: expected at most the 0.3 m" in capsys.readouterr().err


def test_the_route_graphs_own_radius_as_a_float32_plans():
    """A radius equal to the one the route graph was built for, up to float32 rounding (a
    radius read from a float32 array or message: 0.3 becomes 0.30000001), is that radius,
    as the graph's float32 clearances hold it: it plans, with the map and without, rather
    than being refused as larger with a message that gives both radii as 0.3 m."""
    m, g = _fork(radius=0.3)
    for occupancy in (None, m):
        planner = RoutePlanner(g, occupancy=occupancy, robot_radius_m=np.float32(0.3))
        assert planner.route((0.45, 2.15), (2.85, 1.15)).length_m > 0
    with pytest.raises(ValueError, match=r"at most the 0\.3 m .* received 0\.300001 m"):
        RoutePlanner(g, robot_radius_m=0.300001)


def test_with_the_map_routes_on_a_route_graph_join_in_sight_and_are_never_longer():
    from topojax.routegraph.feasible import feasible_space

    m = tj.sample_map("intel")
    rg = tj.route_graph(m, robot_radius_m=0.3)
    feasible = feasible_space(m, 0.3).feasible
    plain, planner = RoutePlanner(rg), RoutePlanner(rg, occupancy=m)
    pts = np.argwhere(feasible)
    rng = np.random.default_rng(3)
    shorter = 0
    for _ in range(40):
        a, b = (tuple(int(x) for x in pts[i]) for i in rng.choice(len(pts), 2, replace=False))
        try:
            r0 = plain.route(a, b, frame="pixel")
        except NoRouteError:
            continue
        r1 = planner.route(a, b, frame="pixel")
        total0 = r0.start_snap_m + r0.length_m + r0.goal_snap_m
        total1 = r1.start_snap_m + r1.length_m + r1.goal_snap_m
        plain_in_sight = all(
            feasible[tuple(np.array(sorted(segment_pixels_exact(q, end))).T)].all()
            for q, end in ((a, r0.pixels[0]), (b, r0.pixels[-1]))
        )
        if plain_in_sight:  # the nearest points are among the joins in sight
            assert total1 <= total0 + 1e-9
        shorter += total1 < total0 - 1e-9
        ends = (
            (a, r1.pixels[0], r1.start_snap_m, r0.start_snap_m),
            (b, r1.pixels[-1], r1.goal_snap_m, r0.goal_snap_m),
        )
        for q, end, leg, nearest in ends:  # every point sees the graph within snap_m
            assert leg == pytest.approx(0.05 * math.dist(q, end))
            assert nearest - 1e-9 <= leg <= rg.graph["snap_m"] + 1e-9
            line = np.array(sorted(segment_pixels_exact(q, end)))
            assert feasible[line[:, 0], line[:, 1]].all()
    assert shorter > 0


def test_with_the_map_an_end_as_near_to_two_points_of_an_edge_may_join_at_either():
    """A point as near to two pixels of one edge (here between two pixels of a straight
    corridor, the goal at its far end) may join at either, as without the map: the route
    joins at the one nearer the goal, not at whichever comes first along the edge (or, in
    the world frame, whichever the coordinates' rounding puts a hair nearer), which made
    the route with the map longer than the one without."""
    m, g = _fork()
    start_px, goal_px = (11.0, 15.5), (10, 28)  # as near to (10, 15) as to (10, 16)
    start_xy = tuple(float(v) for v in m.pixel_to_world(*start_px))
    goal_xy = tuple(float(v) for v in m.pixel_to_world(*goal_px))
    for occupancy in (None, m):
        planner = RoutePlanner(g, occupancy=occupancy)
        for route in (
            planner.route(start_px, goal_px, frame="pixel"),
            planner.route(start_xy, goal_xy),
        ):
            assert route.pixels[0].tolist() == [10, 16]
            assert route.length_m == pytest.approx(1.2)


def test_with_the_map_a_join_exactly_the_reach_away_is_in_reach_in_either_frame():
    """A point exactly ``entry_m`` (here the graph's snap_m, 1 m: 20 pixels) from the graph
    joins it along a leg the robot fits on, in the world frame as in the pixel frame,
    though its world coordinates put the join 1.0000000000000002 m away: the reach allows
    for the coordinates' rounding, as the fallback's does, rather than calling the leg
    one the robot does not fit on (which ``topojax route`` warns of)."""
    occupied = np.ones((60, 60), bool)
    occupied[1:-1, 1:-1] = False
    m = tj.OccupancyMap.from_array(occupied, resolution_m=0.05)
    g = nx.MultiGraph(resolution_m=0.05, shape=(60, 60), robot_radius_m=0.25, snap_m=1.0)
    g.graph["origin"] = tuple(m.origin)
    for name, pixel in {"a": (8, 6), "b": (51, 6)}.items():
        g.add_node(name, pixel=pixel, world=tuple(float(x) for x in m.pixel_to_world(*pixel)))
    path = np.array([(r, 6) for r in range(8, 52)], np.int64)
    x, y = m.pixel_to_world(path[:, 0], path[:, 1])
    g.add_edge("a", "b", path=path, world=np.stack([x, y], 1), length_m=0.05 * 43)
    planner = RoutePlanner(g, occupancy=m)
    q = tuple(float(v) for v in m.pixel_to_world(30, 26))
    assert planner.route(q, q).start_snap_m > 1.0  # the rounding of the world frame
    for route in (planner.route(q, q), planner.route((30, 26), (30, 26), frame="pixel")):
        assert route.start_leg_feasible and route.goal_leg_feasible
        assert route.pixels[0].tolist() == [30, 6]


def _half_pixel_samples(q, p) -> set[tuple[int, int]]:
    """The pixels of ``n = ceil(2 d) + 2`` points evenly spaced along ``q``-``p``, rounded
    half up: the sight test that sampled lines every half pixel."""
    q, p = np.asarray(q, float), np.asarray(p, float)
    n = math.ceil(2 * math.dist(q, p)) + 2
    t = np.arange(n)[:, None] / (n - 1)
    return {tuple(x) for x in np.floor(q + t * (p - q) + 0.5).astype(int).tolist()}


def test_a_line_that_clips_an_obstacle_pixel_at_its_corner_is_not_in_sight():
    feasible = ~art(
        """
        ......
        ...#..
        ......
        ......
        """
    )
    q, p = np.array([0.0, 0.7]), np.array([3.0, 5.0])
    # the line crosses pixel (1, 3) from (1.26, 2.5) to (1.5, 2.85), 0.43 px; samples
    # half a pixel apart step over it
    assert (1, 3) in segment_pixels_exact(q, p)
    assert (1, 3) not in _half_pixel_samples(q, p)
    assert not sees(feasible, q, p[None])[0]
    feasible[1, 3] = True
    assert sees(feasible, q, p[None])[0]


def test_a_line_through_a_pixel_corner_passes_between_the_pixels_beside_it():
    # (0, 0)-(2, 2) meets the corners (0.5, 0.5) and (1.5, 1.5), as 8-connected diagonal
    # steps do: it passes through (0, 0), (1, 1), (2, 2) only, either way round
    feasible = ~art(
        """
        .##
        #.#
        ##.
        """
    )
    for q, p in (((0, 0), (2, 2)), ((2, 2), (0, 0))):
        assert segment_pixels_exact(q, p) == {(0, 0), (1, 1), (2, 2)}
        assert sees(feasible, np.array(q, float), np.array([p], float)).tolist() == [True]
    # the other diagonal, (0, 2)-(2, 0), likewise
    feasible = np.fliplr(feasible).copy()
    for q, p in (((0, 2), (2, 0)), ((2, 0), (0, 2))):
        assert segment_pixels_exact(q, p) == {(0, 2), (1, 1), (2, 0)}
        assert sees(feasible, np.array(q, float), np.array([p], float)).tolist() == [True]
    # a line just off the corner cuts the pixel beside it
    assert not sees(feasible, np.array([0.0, 2.0]), np.array([[2.0, 0.1]]))[0]
    # an end on a corner is on the pixel it rounds to
    assert segment_pixels_exact((0.5, 0.5), (0.5, 0.5)) == {(1, 1)}
    assert not sees(~feasible, np.array([0.5, 0.5]), np.array([[0.5, 0.5]]))[0]


@settings(max_examples=120, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), quarters=st.booleans())
def test_in_sight_exactly_when_every_pixel_the_line_passes_through_is_feasible(seed, quarters):
    rng = np.random.default_rng(seed)
    feasible = rng.random((9, 11)) < 0.85
    q, ends = rng.uniform(-1.0, 11.0, 2), rng.uniform(-1.0, 11.0, (8, 2))
    if quarters:  # ends on pixel borders and corners
        q, ends = np.round(q * 4) / 4, np.round(ends * 4) / 4
    ends[:4] = np.round(ends[:4])  # graph pixels
    seen = sees(feasible, q, ends)
    for p, ok in zip(ends, seen.tolist(), strict=True):
        cells = segment_pixels_exact(q, p)
        want = all(0 <= r < 9 and 0 <= c < 11 and feasible[r, c] for r, c in cells)
        assert ok == want, (q.tolist(), p.tolist(), sorted(cells))


@pytest.mark.parametrize("blocked", [(40, 103), (40, 3996)])
def test_a_sight_line_blocked_near_either_end_is_not_walked_to_the_other(monkeypatch, blocked):
    """A line is checked near its two ends first: one blocked there (a wall beside the
    query point or beside the corridor point) is refused without walking the thousands of
    pixels between, the same answer as the whole walk."""
    from topojax import _sight

    feasible = np.ones((80, 4000), bool)
    feasible[blocked] = False
    q, far = np.array([40.0, 100.0]), np.array([[40.0, 3998.0], [40.0, 2.0]])
    walked = []

    def counting(*args, **kwargs):
        out = segment_pixels(*args, **kwargs)
        walked.append(out[0].size)
        return out

    monkeypatch.setattr(_sight, "segment_pixels", counting)
    assert sees(feasible, q, far).tolist() == [False, True]
    assert sum(walked) < 1000  # the clear line (98 pixels) whole, the blocked one in part


def test_short_sight_lines_are_walked_whole_in_one_pass(monkeypatch):
    """Lines of at most 64 pixels (every one at a route graph's default reach of 1 m, at
    0.05 m a pixel) cost less whole than checked near their ends first."""
    from topojax import _sight

    feasible = np.ones((80, 80), bool)
    feasible[40, 50] = False
    q = np.array([40.0, 10.0])
    ends = np.array([[40.0, 60.0], [10.0, 30.0], [70.0, 70.0]])
    passes = []

    def counting(*args, **kwargs):
        passes.append(args)
        return segment_pixels(*args, **kwargs)

    monkeypatch.setattr(_sight, "segment_pixels", counting)
    assert sees(feasible, q, ends).tolist() == [False, True, True]
    assert len(passes) == 1


@pytest.mark.parametrize(
    ("kwargs", "graph_radius", "exc", "words"),
    [
        ({"robot_radius_m": 0.3}, 0.25, ValueError, "^robot_radius_m: expected at most the 0.25"),
        ({"robot_radius_m": -1.0}, None, ValueError, "^robot_radius_m: expected"),
        ({"entry_m": 1.0}, 0.25, ValueError, "entry_m: only used with occupancy"),
        ({"occupancy": "map"}, 0.25, TypeError, "occupancy: expected an OccupancyMap"),
        ({"occupancy": "small"}, 0.25, ValueError, "occupancy: expected the graph's map"),
        ({"occupancy": "moved"}, 0.25, ValueError, "occupancy: expected the graph's map with"),
        ({"occupancy": "coarse"}, 0.25, ValueError, "occupancy: expected the graph's map at"),
        ({"occupancy": "fork"}, None, ValueError, "robot_radius_m: expected the robot radius"),
        (
            {"occupancy": "fork"},
            float("nan"),
            ValueError,
            r"^robot_radius_m \(the graph's 'robot_radius_m' attribute\): expected a finite",
        ),
        ({"occupancy": "fork", "entry_m": -1.0}, 0.25, ValueError, "entry_m"),
    ],
)
def test_planner_map_options_are_checked(kwargs, graph_radius, exc, words):
    m, g = _fork(radius=graph_radius)
    small = tj.OccupancyMap.from_array(np.zeros((5, 5), bool), resolution_m=0.1)
    moved = tj.OccupancyMap.from_array(m.occupied, resolution_m=0.1, origin=(1.0, 0.0, 0.0))
    g.graph["origin"] = tuple(m.origin)
    kwargs = {**kwargs}
    if "occupancy" in kwargs:
        coarse = tj.OccupancyMap.from_array(m.occupied, resolution_m=0.2)
        maps = {"fork": m, "small": small, "moved": moved, "coarse": coarse}
        kwargs["occupancy"] = maps.get(kwargs["occupancy"], "map")
    with pytest.raises(exc, match=words):
        RoutePlanner(g, **kwargs)


def test_the_route_graphs_straight_line_test_walks_the_planners_pixels():
    # between pixel centres the build's own test (its coverage and simplified waypoints)
    # and the planner's sight lines pass through the same pixels
    from topojax.routegraph._spanner import straight_is_feasible

    rng = np.random.default_rng(5)
    feasible = rng.random((15, 17)) < 0.8
    for _ in range(400):
        q, p = rng.integers(0, (15, 17)), rng.integers(0, (15, 17))
        want = bool(sees(feasible, q.astype(float), p[None].astype(float))[0])
        assert straight_is_feasible(*q.tolist(), *p.tolist(), feasible) == want, (q, p)


def test_routing_on_an_empty_route_graph_says_why_it_is_empty():
    """A route graph without edges records why (its ``note``); routing on it said only
    ``no vertices or edges`` (``topojax route`` on such a file too), not that the robot
    fits nowhere on the map."""
    import warnings

    m = tj.OccupancyMap.from_array(np.full((40, 40), 205, np.uint8), resolution_m=0.05)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rg = tj.route_graph(m, robot_radius_m=0.3)
    note = rg.graph["note"]
    with pytest.raises(ValueError, match="no vertices or edges to route on") as err:
        tj.plan_route(rg, (0.5, 0.5), (1.0, 1.0))
    assert f"({note})" in str(err.value)


def test_a_graph_file_read_with_networkx_points_at_load_graph(tmp_path):
    """networkx.read_graphml leaves a topojax GraphML file's lists as text: the planner
    said ``'world': expected a number or an array of real numbers, received str``; it
    now says that the paths are text and names topojax.load_graph, which decodes them."""
    g = skeleton_to_graph(art("#####\n..#..\n..#.."), resolution_m=1.0)
    tj.save_graph(g, tmp_path / "g.graphml")
    raw = nx.read_graphml(tmp_path / "g.graphml")
    with pytest.raises(ValueError, match=r"'path' .*text.*topojax\.load_graph") as err:
        RoutePlanner(raw)
    assert str(err.value).startswith("graph: ")
    with pytest.raises(ValueError, match=r"'world': .*received '\[.*text.*topojax\.load_graph"):
        tj.save_nav2_graph(raw, tmp_path / "g.geojson")
    assert RoutePlanner(tj.load_graph(tmp_path / "g.graphml")).route((0, 0), (2, 2), frame="pixel")


def test_a_tiled_map_as_the_planners_map_says_how_to_get_its_occupancy_map():
    """evaluate_route_graph and route_graph name a TiledMap's .occupancy(); the planner
    said only ``expected an OccupancyMap, received TiledMap``."""
    from topojax.maps.tiled import TiledMap

    m = tj.OccupancyMap.from_array(np.full((20, 20), 254, np.uint8), resolution_m=0.05)
    g = skeleton_to_graph(art("#####\n..#..\n..#.."), resolution_m=0.05)
    with pytest.raises(TypeError, match=r"^occupancy: expected an OccupancyMap, .*\.occupancy\(\)"):
        RoutePlanner(g, occupancy=TiledMap.from_occupancy(m))
    with pytest.raises(TypeError, match=r"^occupancy: .*received ndarray \(an array has no res"):
        plan_route(g, (0, 0), (2, 2), frame="pixel", occupancy=np.zeros((20, 20), bool))


def test_a_planner_repr_says_what_it_plans_on():
    m = tj.sample_map("intel")
    g = tj.build_graph(m).graph
    assert repr(RoutePlanner(g)) == (
        f"RoutePlanner(vertices={g.number_of_nodes()}, edges={g.number_of_edges()}, "
        "with_map=False, robot_radius_m=None)"
    )
    rg = tj.route_graph(m, robot_radius_m=0.3)
    assert repr(RoutePlanner(rg, occupancy=m)) == (
        f"RoutePlanner(vertices={rg.number_of_nodes()}, edges={rg.number_of_edges()}, "
        "with_map=True, robot_radius_m=0.3, entry_m=1.0)"
    )
