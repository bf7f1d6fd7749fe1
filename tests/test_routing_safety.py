"""What a route says about its robot's safety: whether each end's leg to the graph is one
the robot fits along, and the narrowest clearance of the corridors it runs along."""

from __future__ import annotations

import json
import math

import networkx as nx
import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt
from skimage.morphology import skeletonize
from view_cases import wall_between

import topojax as tj
from topojax.graph import skeleton_to_graph
from topojax.routing import NoRouteError, RoutePlanner, plan_route

# 0.1 m pixels.  Room A (rows 3-13, columns 1-12) has a closet one pixel wide in the wall
# above it (rows 1-2, column 7), a door two pixels wide (rows 5-6) along a corridor to
# room B (columns 18-29) and a wide way down (columns 3-12) to room C.
ROOMS = """
##############################
#######.######################
#######.######################
#............#################
#............#####...........#
#............................#
#............................#
#............#####...........#
#............#####...........#
#............#####...........#
#............#####...........#
#............#####...........#
#............#####...........#
#............#####...........#
###..........#################
###..........#################
###..........#################
#..............###############
#..............###############
#..............###############
#..............###############
#..............###############
#..............###############
#..............###############
#..............###############
##############################
"""
ROBOT_M = 0.25  # wider than the door (0.1 m from its walls), narrower than the rest
ROOM_A, ROOM_B, ROOM_C, CLOSET, DOOR = (8, 6), (8, 24), (22, 8), (2, 7), (5, 15)


def rooms():
    """The map of :data:`ROOMS` and its topology graph: the skeleton of its free space,
    whose edges carry the clearance (distance to the nearest obstacle) of their pixels."""
    occupied = np.array([[ch == "#" for ch in line] for line in ROOMS.strip().splitlines()])
    m = tj.OccupancyMap.from_array(occupied, resolution_m=0.1)
    free = ~occupied
    g = skeleton_to_graph(
        skeletonize(free),
        clearance_px=distance_transform_edt(free),
        resolution_m=0.1,
        pixel_to_world=m.pixel_to_world,
    )
    g.graph["origin"] = tuple(m.origin)  # the map recorded, as build_graph does
    return m, g


def narrowest(g, route) -> float:
    return min(g.edges[e]["min_clearance_m"] for e in route.edges)


def test_a_route_through_a_door_narrower_than_the_robot_says_how_narrow():
    m, g = rooms()
    planner = RoutePlanner(g, occupancy=m, robot_radius_m=ROBOT_M)
    through = planner.route(ROOM_C, ROOM_B, frame="pixel")
    assert through.min_clearance_m == pytest.approx(0.1)  # the door: 1 pixel either side
    assert through.min_clearance_m == narrowest(g, through) < ROBOT_M
    assert through.robot_radius_m == ROBOT_M
    assert through.start_leg_feasible is True and through.goal_leg_feasible is True
    wide = planner.route(ROOM_C, ROOM_A, frame="pixel")
    assert wide.min_clearance_m == narrowest(g, wide) >= ROBOT_M
    # without the map (other joins), the clearance is still the graph's
    plain = RoutePlanner(g).route(ROOM_C, ROOM_B, frame="pixel")
    assert plain.min_clearance_m == narrowest(g, plain) == through.min_clearance_m


def test_a_point_in_a_closet_only_the_fallback_reaches_says_the_robot_does_not_fit():
    m, g = rooms()
    planner = RoutePlanner(g, occupancy=m, robot_radius_m=ROBOT_M)
    for inside in (CLOSET, DOOR):  # no pixel of either fits the robot
        r = planner.route(inside, ROOM_A, frame="pixel")
        assert r.start_leg_feasible is False and r.goal_leg_feasible is True
        r = planner.route(ROOM_A, inside, frame="pixel")
        assert r.start_leg_feasible is True and r.goal_leg_feasible is False
    # as the documented fallback of a robot closer to a wall than its radius
    m, g = wall_between()
    r = RoutePlanner(g, occupancy=m).route((5, 19), (5, 25), frame="pixel")
    assert r.start_snap_m == pytest.approx(0.9)
    assert r.start_leg_feasible is False
    assert r.robot_radius_m == 0.25  # the graph's


def test_a_route_planned_without_the_map_knows_no_leg_and_no_robot():
    m, g = rooms()
    r = plan_route(g, CLOSET, ROOM_B, frame="pixel")
    assert r.start_leg_feasible is None and r.goal_leg_feasible is None
    assert r.robot_radius_m is None
    assert r.min_clearance_m == narrowest(g, r)
    # edges built without clearances (NaN), or recording none: unknown
    bare = skeleton_to_graph(skeletonize(~m.occupied), resolution_m=0.1)
    assert math.isnan(plan_route(bare, ROOM_C, ROOM_B, frame="pixel").min_clearance_m)
    for *_, d in bare.edges(data=True):
        del d["min_clearance_m"]
    assert math.isnan(plan_route(bare, ROOM_C, ROOM_B, frame="pixel").min_clearance_m)
    # one edge known, one not: the narrowest is not known
    known = plan_route(g, ROOM_C, ROOM_B, frame="pixel")
    g.edges[known.edges[0]]["min_clearance_m"] = math.nan
    assert math.isnan(plan_route(g, ROOM_C, ROOM_B, frame="pixel").min_clearance_m)
    # a value that is not a number is refused, naming the edge
    g.edges[known.edges[0]]["min_clearance_m"] = "narrow"
    with pytest.raises(TypeError, match=r"^graph: edge .*: 'min_clearance_m': expected a real"):
        RoutePlanner(g)


def test_a_route_along_no_edge_takes_the_clearance_where_it_stands():
    m, g = rooms()
    e, d = next((e, d) for e, d in g.edges.items() if len(d["path"]) > 2)
    inner = tuple(int(v) for v in d["path"][1])
    r = plan_route(g, inner, inner, frame="pixel")
    assert r.edges == () and r.min_clearance_m == d["min_clearance_m"]
    n, nd = next(iter(g.nodes(data=True)))
    r = plan_route(g, nd["pixel"], nd["pixel"], frame="pixel")
    assert r.edges == () and r.min_clearance_m == nd["clearance_m"]
    lone = nx.MultiGraph(resolution_m=0.1)
    lone.add_node(0, pixel=(1, 1), world=(0.15, 0.15), clearance_m=0.3)
    assert plan_route(lone, (0.15, 0.15), (0.15, 0.15)).min_clearance_m == 0.3
    lone.nodes[0].pop("clearance_m")
    assert math.isnan(plan_route(lone, (0.15, 0.15), (0.15, 0.15)).min_clearance_m)


def test_the_geojson_of_a_route_carries_what_it_says_about_the_robot():
    m, g = rooms()
    r = plan_route(g, CLOSET, ROOM_B, frame="pixel", occupancy=m, robot_radius_m=ROBOT_M)
    props = json.loads(json.dumps(r.to_geojson()))["properties"]
    assert props["start_leg_feasible"] is False and props["goal_leg_feasible"] is True
    assert props["min_clearance_m"] == r.min_clearance_m and props["robot_radius_m"] == ROBOT_M
    bare = skeleton_to_graph(skeletonize(~m.occupied), resolution_m=0.1)
    props = plan_route(bare, ROOM_C, ROOM_B, frame="pixel").to_geojson()["properties"]
    assert props["start_leg_feasible"] is None and props["goal_leg_feasible"] is None
    assert props["min_clearance_m"] is None and props["robot_radius_m"] is None
    json.dumps(props, allow_nan=False)  # valid JSON: no NaN


def test_route_command_warns_of_a_fallback_leg_and_a_corridor_narrower_than_the_robot(
    tmp_path, capsys
):
    import cv2

    from topojax.cli import main

    m, g = rooms()
    graph_file = tj.save_graph(g, tmp_path / "rooms.json")
    map_file = tmp_path / "rooms.png"
    cv2.imwrite(str(map_file), np.where(m.occupied, 0, 255).astype(np.uint8))
    out = tmp_path / "route.geojson"
    given = ["--map", str(map_file), "--resolution", "0.1", "--robot-radius", str(ROBOT_M)]

    def route(start, goal, *extra):
        points = ["--pixel", "--start", *map(str, start), "--goal", *map(str, goal)]
        assert main(["route", str(graph_file), *points, *extra]) == 0
        return capsys.readouterr()

    calm = route(ROOM_C, ROOM_A, *given)
    assert "warning" not in calm.err and "warning" not in calm.out
    told = route(ROOM_C, ROOM_B, *given, "-o", str(out))
    (line,) = told.err.splitlines()
    assert line == (
        "topojax route: warning: the route runs along a corridor 0.100 m from the nearest "
        "obstacle at its narrowest, less than the robot radius 0.25 m"
    )
    props = json.loads(out.read_text())["properties"]
    assert props["min_clearance_m"] == pytest.approx(0.1) and props["robot_radius_m"] == ROBOT_M
    assert props["start_leg_feasible"] is True and props["goal_leg_feasible"] is True
    told = route(DOOR, ROOM_A, *given)
    want = plan_route(g, DOOR, ROOM_A, frame="pixel", occupancy=m, robot_radius_m=ROBOT_M)
    assert told.err.splitlines() == [
        "topojax route: warning: start: no straight line from it to the graph within reach "
        "fits the robot (radius 0.25 m): it joins the graph "
        f"{want.start_snap_m:.3f} m away over pixels that are only not occupied (free or "
        "unknown)"
    ]
    told = route(ROOM_A, CLOSET, *given)  # along the closet's own edge, 0.1 m wide
    (leg, narrow) = told.err.splitlines()
    assert leg.startswith("topojax route: warning: goal: no straight line from it")
    assert narrow.startswith("topojax route: warning: the route runs along a corridor 0.100 m")
    # without the map nothing is known of the robot: no warning
    assert route(CLOSET, ROOM_B).err == ""


# 0.1 m pixels, a map free but for two walls (rows 0 and 20) and a pinch of two obstacle
# pixels 3 pixels above and below row 10 at column 6.  The graph: a line along row 10 from
# column 2 to column 48 with a branch down column 30 to row 17, so three edges: the left
# one, narrow at the pinch (3 pixels), the right one and the branch, each 10 pixels from
# the walls along row 10.
def pinched():
    """The map above and its graph, whose clearances are those of the graph builders (the
    float32 Euclidean distance in pixels to the nearest occupied pixel)."""
    occupied = np.zeros((21, 51), bool)
    occupied[[0, 20]] = True
    occupied[[7, 13], 6] = True
    skeleton = np.zeros_like(occupied)
    skeleton[10, 2:49] = True
    skeleton[11:18, 30] = True
    m = tj.OccupancyMap.from_array(occupied, resolution_m=0.1)
    g = skeleton_to_graph(
        skeleton,
        clearance_px=distance_transform_edt(~occupied).astype(np.float32),
        resolution_m=0.1,
        pixel_to_world=m.pixel_to_world,
    )
    g.graph["origin"] = tuple(m.origin)  # the map recorded, as build_graph does
    return m, g


def test_with_the_map_a_route_measures_the_part_of_its_end_edges_it_runs_along():
    m, g = pinched()
    left = next(e for e in g.edges if tuple(g.nodes[e[0]]["pixel"]) == (10, 2))
    assert g.edges[left]["min_clearance_m"] == 3 * 0.1  # the pinch, beyond the start
    planner = RoutePlanner(g, occupancy=m, robot_radius_m=ROBOT_M)
    for start, goal in (((10, 18), (10, 41)), ((10, 41), (10, 18))):
        r = planner.route(start, goal, frame="pixel")
        assert r.start_snap_m == 0 and r.goal_snap_m == 0 and left in r.edges
        # every pixel from column 18 to 41 on row 10 is 10 pixels from the walls, and the
        # pinch is farther (12.4 pixels from (10, 18))
        assert sorted(r.pixels[:, 1].tolist()) == list(range(18, 42))
        assert r.min_clearance_m == 10 * 0.1
        # without the map, the left edge counts whole: its pinch
        plain = RoutePlanner(g).route(start, goal, frame="pixel")
        assert plain.edges == r.edges
        assert plain.min_clearance_m == 3 * 0.1 == narrowest(g, plain)


def test_a_route_along_whole_edges_has_the_recorded_clearance_with_and_without_the_map():
    rooms_map, _ = rooms()
    m, g = pinched()
    cases = [
        (m, g, 0.25),  # the graph builders' clearance, recorded by skeleton_to_graph
        (rooms_map, tj.build_graph(rooms_map).graph, 0.1),
        (rooms_map, tj.route_graph(rooms_map, robot_radius_m=0.15), None),
    ]
    for occupancy, graph, radius in cases:
        with_map = RoutePlanner(graph, occupancy=occupancy, robot_radius_m=radius)
        plain = RoutePlanner(graph)
        ends = [tuple(d["pixel"]) for _, d in graph.nodes(data=True) if graph.degree(_) > 0]
        checked = 0
        for a in ends:
            for b in ends:
                try:
                    r = with_map.route(a, b, frame="pixel")
                except NoRouteError:  # pieces of the graph apart
                    continue
                if r.start_snap_m or r.goal_snap_m or not r.edges:
                    continue  # a leg to a point part way along an edge, or no edge
                want = narrowest(graph, r)
                assert r.min_clearance_m == want, (a, b)
                assert plain.route(a, b, frame="pixel").min_clearance_m == want
                checked += 1
        assert checked >= len(ends)


def test_a_robot_radius_without_the_map_is_recorded_and_checked_against_the_edges():
    m, g = pinched()
    r = RoutePlanner(g, robot_radius_m=0.35).route((10, 18), (10, 41), frame="pixel")
    assert r.robot_radius_m == 0.35 and r.min_clearance_m == 3 * 0.1  # the left edge whole
    assert r.start_leg_feasible is None and r.goal_leg_feasible is None  # no map: no legs
    assert plan_route(g, (10, 18), (10, 41), frame="pixel", robot_radius_m=0.2).robot_radius_m
    assert RoutePlanner(g).route((10, 18), (10, 41), frame="pixel").robot_radius_m is None
    with pytest.raises(ValueError, match="^entry_m: only used with occupancy="):
        RoutePlanner(g, robot_radius_m=0.35, entry_m=1.0)


def test_route_command_checks_a_robot_radius_without_the_map_against_the_edges(tmp_path, capsys):
    import cv2

    from topojax.cli import main

    m, g = pinched()
    graph_file = tj.save_graph(g, tmp_path / "pinched.json")
    map_file = tmp_path / "pinched.png"
    cv2.imwrite(str(map_file), np.where(m.occupied, 0, 255).astype(np.uint8))
    points = ["--pixel", "--start", "10", "18", "--goal", "10", "41"]

    def route(*extra):
        assert main(["route", str(graph_file), *points, *extra]) == 0
        return capsys.readouterr()

    told = route("--robot-radius", "0.35")
    assert (
        "note       without --map the legs from the start and goal to the graph are not "
        "checked for the robot, and the first and last edge count whole"
    ) in told.out
    (line,) = told.err.splitlines()
    assert line == (
        "topojax route: warning: the route runs along edges 0.300 m from the nearest "
        "obstacle at their narrowest, less than the robot radius 0.35 m (without --map the "
        "first and last edge count whole, though the route may run along part of them only)"
    )
    calm = route("--robot-radius", "0.25")
    assert calm.err == "" and "note       without --map the legs" in calm.out
    # with the map, the part of the left edge run along is measured: 1 m, no warning
    mapped = route("--robot-radius", "0.35", "--map", str(map_file), "--resolution", "0.1")
    assert mapped.err == "" and "without --map" not in mapped.out
    # an edge recording no clearance: the radius cannot be checked, which is said
    for *_, d in g.edges(data=True):
        d["min_clearance_m"] = math.nan
    tj.save_graph(g, graph_file)
    bare = route("--robot-radius", "0.35")
    assert bare.err == ""
    assert "the graph records no clearance along the route: the robot radius" in bare.out
    # nor a bad radius without the map, named as the option
    assert main(["route", str(graph_file), *points, "--robot-radius", "-1"]) == 2
    assert "--robot-radius: expected" in capsys.readouterr().err


def test_a_route_graph_planner_measures_clearance_on_the_transform_it_already_made(monkeypatch):
    import cv2

    rooms_map, _ = rooms()
    graph = tj.route_graph(rooms_map, robot_radius_m=0.15)
    planner = RoutePlanner(graph, occupancy=rooms_map)
    calls = []
    real = cv2.distanceTransform
    monkeypatch.setattr(cv2, "distanceTransform", lambda *a, **k: calls.append(1) or real(*a, **k))
    r = planner.route(ROOM_A, ROOM_C, frame="pixel")
    assert calls == []  # the feasible space's clearance serves the route's
    fresh = RoutePlanner(graph, occupancy=rooms_map)  # one transform, for the feasible space
    assert calls == [1]
    assert fresh.route(ROOM_A, ROOM_C, frame="pixel").min_clearance_m == r.min_clearance_m
    assert calls == [1]
