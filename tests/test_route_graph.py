"""Route graphs on synthetic maps with known answers, and properties on random plans."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import cv2
import networkx as nx
import numpy as np
import pytest

import topojax as tj
from topojax.maps.occupancy import OccupancyMap
from topojax.routegraph.build import RouteGraphConfig, route_graph
from topojax.routegraph.feasible import feasible_space

RES = 0.05
R = 0.3


def _map(free: np.ndarray) -> OccupancyMap:
    free = np.asarray(free, bool)
    return OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=RES)


def _px(m: float) -> int:
    return int(round(m / RES))


def _room(h_m: float, w_m: float) -> np.ndarray:
    """A free rectangle with a one-pixel wall all round."""
    free = np.zeros((_px(h_m), _px(w_m)), bool)
    free[1:-1, 1:-1] = True
    return free


def _cycle_rank(g: nx.MultiGraph) -> int:
    return g.number_of_edges() - g.number_of_nodes() + nx.number_connected_components(g)


def _graph_pixels(g: nx.MultiGraph) -> np.ndarray:
    pix = [np.asarray(d["path"]) for _, _, d in g.edges(data=True)]
    pix += [np.asarray(d["pixels"]).reshape(-1, 2) for _, d in g.nodes(data=True)]
    return np.concatenate(pix)


def _assert_safe(g: nx.MultiGraph, occ: OccupancyMap, radius_m: float = R) -> None:
    space = feasible_space(occ, radius_m)
    for _, _, d in g.edges(data=True):
        path = np.asarray(d["path"])
        assert space.clearance_m[path[:, 0], path[:, 1]].min() >= radius_m - 1e-6
        assert d["min_clearance_m"] >= radius_m - 1e-6
        step = np.abs(np.diff(path.astype(int), axis=0))
        assert step.max() <= 1 and (step.sum(axis=1) > 0).all()  # 8-connected
        # the waypoints a robot follows keep the radius too, between the pixels as well:
        # every point lies on a feasible pixel (a point on a pixel border or corner on any
        # of the pixels it touches, as a diagonal step of a pixel path does)
        wr, wc = occ.world_to_pixel(d["waypoints"][:, 0], d["waypoints"][:, 1])
        way = np.stack([wr, wc], axis=1)
        for a, b in zip(way[:-1], way[1:], strict=True):
            t = np.linspace(0, 1, int(np.ceil(4 * np.hypot(*(b - a)))) + 2)[:, None]
            pts = a + t * (b - a)
            lo = np.ceil(pts - 0.5 - 1e-9).astype(int)
            hi = np.floor(pts + 0.5 + 1e-9).astype(int)
            on = np.zeros(len(pts), bool)
            for r in (lo[:, 0], hi[:, 0]):
                for c in (lo[:, 1], hi[:, 1]):
                    on |= space.feasible[r, c]
            assert on.all()


def _assert_one_component_per_region(g: nx.MultiGraph, occ: OccupancyMap) -> None:
    space = feasible_space(occ, R)
    wanted = set(space.regions_at_least(1.0).tolist())
    seen = []
    for comp in nx.connected_components(g):
        pix = np.concatenate([np.asarray(g.nodes[n]["pixels"]).reshape(-1, 2) for n in comp])
        regions = set(space.labels[pix[:, 0], pix[:, 1]].tolist())
        assert len(regions) == 1 and 0 not in regions
        seen.append(regions.pop())
    assert sorted(seen) == sorted(wanted)


def test_corridor_ring_keeps_its_one_loop():
    free = _room(10, 10)
    free[_px(2) : _px(8), _px(2) : _px(8)] = False  # a 6 m block, 2 m corridors round it
    occ = _map(free)
    g = route_graph(occ, robot_radius_m=R)
    assert nx.number_connected_components(g) == 1
    assert _cycle_rank(g) == 1
    _assert_safe(g, occ)


def test_pillars_make_no_micro_loops():
    free = _room(12, 12)
    for r in np.arange(2.0, 11.0, 2.0):
        for c in np.arange(2.0, 11.0, 2.0):
            free[_px(r) - 2 : _px(r) + 2, _px(c) - 2 : _px(c) + 2] = False  # 0.2 m pillars
    occ = _map(free)
    g = route_graph(occ, config=RouteGraphConfig(shortcut_radius_m=0.0))
    assert _cycle_rank(g) == 0
    assert nx.number_connected_components(g) == 1
    _assert_safe(g, occ)
    with_shortcuts = route_graph(occ)
    _assert_safe(with_shortcuts, occ)
    assert nx.number_connected_components(with_shortcuts) == 1


def test_open_hall_is_covered_within_the_snap_distance():
    free = _room(20, 20)
    occ = _map(free)
    g = route_graph(occ, robot_radius_m=R)
    space = feasible_space(occ, R)
    off = np.ones(free.shape, np.uint8)
    pix = _graph_pixels(g)
    off[pix[:, 0], pix[:, 1]] = 0
    dist_m = cv2.distanceTransform(off, cv2.DIST_L2, 5) * RES
    assert dist_m[space.feasible].max() <= g.graph["snap_m"] + 2 * RES
    assert g.graph["uncovered_share"] == 0.0
    _assert_safe(g, occ)


@pytest.mark.parametrize("radius_m", [1.5, 2.5])
def test_a_large_robot_keeps_the_hall_mesh_without_hubs(radius_m):
    """Vertices closer than the robot's radius merge only up to half the snap distance:
    a large robot's hall keeps its net of edges (merging at the radius folded it into a
    few hubs joined by hundreds of parallel edges and self-loops)."""
    free = _room(30, 30)
    occ = _map(free)
    g = route_graph(occ, robot_radius_m=radius_m)
    pairs = [tuple(sorted((u, v))) for u, v in g.edges()]
    assert sum(u == v for u, v in pairs) == 0
    assert len(pairs) - len(set(pairs)) <= 0.01 * len(pairs)
    assert g.graph["uncovered_share"] == 0.0
    assert g.number_of_nodes() > g.number_of_edges() / 5
    report = tj.evaluate_route_graph(g, occ, robot_radius_m=radius_m, n_pairs=100)
    assert report.success_rate == 1.0 and report.stretch_p90 < 1.25


@pytest.mark.parametrize("width_m", [2.6, 3.0, 3.6])
def test_wide_corridor_is_crossed_where_it_is_not_walked_round(width_m):
    """A corridor too wide for its centre line to cover gets lanes along both walls;
    they join the rest at rungs every few metres, not only at the corridor's ends (a
    route across the middle would otherwise run about 20 m round: p90 stretch 4.5-7 on
    these corridors; with rungs 1.6-2.5)."""
    occ = _map(_room(width_m, 20))
    g = route_graph(occ, robot_radius_m=R)
    report = tj.evaluate_route_graph(g, occ, robot_radius_m=R)
    assert report.success_rate == 1.0
    assert report.stretch_median < 1.2
    assert report.stretch_p90 < 3.0
    _assert_safe(g, occ)


def _two_rooms(gap_m: float) -> np.ndarray:
    free = _room(6, 12)
    wall = slice(_px(6) - 2, _px(6) + 2)
    free[:, wall] = False
    mid = _px(3)
    free[mid - _px(gap_m) // 2 : mid + _px(gap_m) // 2, wall] = True
    return free


def test_door_narrower_than_the_robot_splits_the_graph():
    occ = _map(_two_rooms(0.4))
    g = route_graph(occ, robot_radius_m=R)
    assert nx.number_connected_components(g) == 2
    cols = _graph_pixels(g)[:, 1]
    assert not ((cols >= _px(6) - 2) & (cols < _px(6) + 2)).any()  # nothing in the wall
    _assert_one_component_per_region(g, occ)


def test_wide_door_joins_the_rooms():
    occ = _map(_two_rooms(1.0))
    g = route_graph(occ, robot_radius_m=R)
    assert nx.number_connected_components(g) == 1
    _assert_safe(g, occ)


def test_narrow_passage_leaves_two_components():
    free = _room(6, 14)
    free[:, _px(5) : _px(9)] = False
    free[_px(3) - 5 : _px(3) + 5, _px(5) : _px(9)] = True  # 0.5 m x 4 m passage
    occ = _map(free)
    g = route_graph(occ, robot_radius_m=R)
    assert nx.number_connected_components(g) == 2
    _assert_one_component_per_region(g, occ)


def _random_plan(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    free = _room(15, 15)
    n = free.shape[0]
    for _ in range(rng.integers(4, 14)):
        r, c = rng.integers(0, n, 2)
        h, w = rng.integers(2, n // 3, 2)
        if rng.random() < 0.5:
            h = rng.integers(2, 6)  # a wall
        else:
            w = w if rng.random() < 0.5 else rng.integers(2, 6)
        free[r : r + h, c : c + w] = False
    return free


@pytest.mark.parametrize("seed", range(8))
def test_random_plans_are_safe_and_reach_each_region_once(seed):
    occ = _map(_random_plan(seed))
    g = route_graph(occ, robot_radius_m=R)
    _assert_safe(g, occ)
    _assert_one_component_per_region(g, occ)
    for u, v, d in g.edges(data=True):
        assert u <= v and d["length_m"] > 0
        assert u == v or len(d["path"]) > 2  # no one-pixel edges
        wp = d["waypoints"]
        assert np.array_equal(wp[0], g.nodes[u]["world"]) and np.array_equal(
            wp[-1], g.nodes[v]["world"]
        )


def test_waypoints_run_from_vertex_to_vertex_at_merged_clusters():
    # a_scan's route graph has paths that end on another pixel of a merged junction
    # cluster than the vertex's: the waypoints still start and end on the vertices
    occ = tj.sample_map("a_scan")
    g = route_graph(occ, robot_radius_m=R)
    off = 0
    for u, v, d in g.edges(data=True):
        path, wp = np.asarray(d["path"]), d["waypoints"]
        off += tuple(path[0]) != g.nodes[u]["pixel"]
        off += tuple(path[-1]) != g.nodes[v]["pixel"]
        assert np.array_equal(wp[0], g.nodes[u]["world"])
        assert np.array_equal(wp[-1], g.nodes[v]["world"])
    assert off > 0  # the case is there
    _assert_safe(g, occ)


def test_schema_is_build_graphs_plus_waypoints():
    occ = tj.sample_map("intel")
    rg = route_graph(occ)
    ref_graph = tj.build_graph(occ).graph
    _, ref_node = next(iter(ref_graph.nodes(data=True)))
    _, node = next(iter(rg.nodes(data=True)))
    assert set(node) == set(ref_node)
    ref_edge = next(iter(ref_graph.edges(data=True)))[2]
    edge = next(iter(rg.edges(data=True)))[2]
    assert set(edge) == set(ref_edge) | {"waypoints"}
    for name in ("path", "world"):
        assert edge[name].dtype == ref_edge[name].dtype
    assert edge["waypoints"].dtype == np.float64 and edge["waypoints"].shape[1] == 2
    assert set(ref_graph.graph) - set(rg.graph) <= {"thinning", "source"}
    assert rg.graph["kind"] == "route_graph" and rg.graph["robot_radius_m"] == 0.3
    nodes = sorted(rg.nodes)
    assert nodes == list(range(rg.number_of_nodes()))
    assert not any(rg.degree(n) == 2 and rg.nodes[n]["kind"] != "ring" for n in nodes)


def test_options_are_checked():
    with pytest.raises(ValueError, match="snap_m"):
        RouteGraphConfig(snap_m=-1.0)
    with pytest.raises(TypeError, match="robot_radius_m"):
        RouteGraphConfig(robot_radius_m="big")
    with pytest.raises(ValueError, match="shortcut_stretch"):
        RouteGraphConfig(shortcut_stretch=0.5)
    with pytest.raises(TypeError, match="shortcuts_round_corners"):
        RouteGraphConfig(shortcuts_round_corners="yes")
    with pytest.raises(TypeError, match="config"):
        route_graph(_map(_room(3, 3)), config="fast")
    with pytest.raises(TypeError):
        RouteGraphConfig(0.3)  # keyword-only


@pytest.mark.parametrize("snap_m", [5.01, 50.0, 1e9])
def test_a_snap_distance_past_the_evaluators_limit_is_refused(snap_m):
    """The coverage test's work grows with the square of the snap distance: 1e9 m would
    run out of memory deep inside the coverage pass, and a graph built past 5 m could
    not be scored (``evaluate_route_graph``) or routed to by default (``max_snap_m``) at
    its own snap distance."""
    from topojax.routegraph.evaluate import MAX_SNAP_M

    assert MAX_SNAP_M == 5.0
    RouteGraphConfig(snap_m=MAX_SNAP_M)  # the limit itself is fine
    with pytest.raises(ValueError, match=r"^snap_m: expected at most 5 m .* received "):
        RouteGraphConfig(snap_m=snap_m)


@pytest.mark.parametrize("radius_m", [1000.001, 1e300])
def test_a_robot_radius_past_a_kilometre_is_refused(radius_m):
    """A radius past 1000 m is a unit error, refused by the config, the feasible space
    and so the evaluator and the planner: 1e300 m would overflow the float32 clearance
    with a warning and build an empty graph on which the evaluator scores no pair."""
    occ = _map(_room(3, 3))
    RouteGraphConfig(robot_radius_m=1000.0)  # the limit itself is fine
    match = r"^robot_radius_m: expected a robot radius of at most 1000 m, received "
    with pytest.raises(ValueError, match=match):
        RouteGraphConfig(robot_radius_m=radius_m)
    with pytest.raises(ValueError, match=match):
        route_graph(occ, robot_radius_m=radius_m)
    with pytest.raises(ValueError, match=match):
        feasible_space(occ, radius_m)


@pytest.mark.parametrize("value", [np.zeros((8, 8), bool), None, 3.0])
def test_feasible_space_names_a_map_that_is_not_one(value):
    """``feasible_space`` is public: a non-map got an AttributeError ('no attribute
    free') from inside it, as ``route_graph`` and the evaluator do not."""
    with pytest.raises(TypeError, match=r"^occupancy: expected an OccupancyMap or a map file"):
        feasible_space(value, R)


def test_feasible_space_reads_a_map_file(tmp_path):
    occ = _map(_room(3, 3))
    tj.save_map(occ, tmp_path / "room.yaml")
    from_file = feasible_space(tmp_path / "room.yaml", R)
    assert np.array_equal(from_file.feasible, feasible_space(occ, R).feasible)


def test_map_is_a_map_or_its_file(tmp_path):
    occ = _map(_room(3, 3))
    with pytest.raises(TypeError, match=r"occupancy: .* received ndarray .*from_array"):
        route_graph(np.asarray(occ.free), robot_radius_m=R)
    with pytest.raises(TypeError, match="occupancy: .* received NoneType"):
        route_graph(None, robot_radius_m=R)
    tj.save_map(occ, tmp_path / "room.yaml")
    from_file = route_graph(tmp_path / "room.yaml", robot_radius_m=R)
    direct = route_graph(occ, robot_radius_m=R)
    assert sorted(from_file.edges(keys=True)) == sorted(direct.edges(keys=True)) != []
    for u, v, k, path in direct.edges(keys=True, data="path"):
        np.testing.assert_array_equal(from_file.edges[u, v, k]["path"], path)


def test_a_tiled_map_is_refused_naming_its_occupancy_method():
    """A TiledMap given where an OccupancyMap is expected is refused pointing at
    TiledMap.occupancy(), which gives it, not at load_map, which has nothing to do
    with a map already loaded."""
    tiled = tj.TiledMap.from_occupancy(_map(_room(2, 2)))
    with pytest.raises(TypeError, match=r"^occupancy: .* received TiledMap .*\.occupancy\(\)"):
        route_graph(tiled, robot_radius_m=R)
    with pytest.raises(TypeError, match=r"^occupancy: .* received TiledMap .*\.occupancy\(\)"):
        tj.evaluate_route_graph(nx.MultiGraph(), tiled, R)


def test_map_without_feasible_space_gives_an_empty_graph_that_says_why():
    occ = _map(_room(0.5, 0.5))
    # the note is a warning too, for a notebook, where nobody reads the graph's attributes
    with pytest.warns(UserWarning, match="^empty route graph: no known-free region") as info:
        g = route_graph(occ, robot_radius_m=R)
    assert [str(w.message) for w in info] == [g.graph["note"]]
    assert info[0].filename == __file__  # it points at the call
    assert g.number_of_nodes() == 0 and g.number_of_edges() == 0
    assert g.graph["note"].startswith("empty route graph: no known-free region of at least")
    assert f"radius {R:g} m" in g.graph["note"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert "note" not in route_graph(_map(_room(4, 4)), robot_radius_m=R).graph
    # a map of 0.1 mm pixels: its 3 mm of clearance is not rounded away
    fine = np.zeros((60, 60), bool)
    fine[[0, -1], :] = fine[:, [0, -1]] = True
    fine = tj.OccupancyMap.from_array(fine, resolution_m=1e-4)
    with pytest.warns(UserWarning, match="^empty route graph"):
        note = route_graph(fine, robot_radius_m=R).graph["note"]
    assert note.endswith("the most clearance from anything not known free is 0.0029 m)")


def test_empty_graph_note_names_the_area_when_the_robot_fits_but_the_regions_are_small():
    """Where the robot fits but every feasible region is below min_region_m2, the note
    says how large the largest is, not only the clearance (which exceeds the radius and
    would point at the radius)."""
    occ = _map(_room(1.0, 1.0))  # 0.9 m inside: the robot fits, in 8 x 8 pixels
    with pytest.warns(UserWarning, match="^empty route graph"):
        note = route_graph(occ, robot_radius_m=R).graph["note"]
    assert "the largest feasible region is 0.16 m2" in note, note
    assert "min_region_m2" in note


def test_route_graph_command_writes_the_graph_and_its_report(tmp_path, capsys):
    import json

    from topojax.cli import main
    from topojax.io import load_graph

    obstacles = np.zeros((60, 100), bool)
    obstacles[[0, -1], :] = True
    obstacles[:, [0, -1]] = True
    obstacles[20:40, 30:70] = True  # a block: a corridor ring around it
    path = tmp_path / "ring.png"
    cv2.imwrite(str(path), np.where(obstacles, 0, 254).astype(np.uint8))
    out = tmp_path / "out"
    code = main(["route-graph", str(path), "-o", str(out), "--robot-radius", "0.2", "--evaluate"])
    assert code == 0
    graph = load_graph(out / "ring_route.json")
    assert graph.number_of_edges() > 0 and graph.graph["robot_radius_m"] == 0.2
    files = {s: (out / f"ring_route{s}").read_bytes() for s in (".graphml", ".json", ".geojson")}
    report = json.loads((out / "ring_route_report.json").read_text())
    assert report["success_rate"] == 1.0 and report["unsafe_share"] == 0.0
    text = capsys.readouterr().out
    assert "route graph" in text
    # a PNG states no resolution: the line says the 0.05 m/px is assumed, until it is given
    assert "0.05 m/px, assumed: the file states none; --resolution sets it" in text
    argv = ["route-graph", str(path), "-o", str(out), "--robot-radius", "0.2"]
    assert main([*argv, "--resolution", "0.05"]) == 0
    for s, before in files.items():  # no build times in the files: a rerun writes the same
        assert (out / f"ring_route{s}").read_bytes() == before
    assert "assumed" not in capsys.readouterr().out
    assert main(["route-graph", str(path), "-o", str(out), "--robot-radius", "-1"]) == 2


def test_route_graph_command_counts_one_in_the_singular_and_names_an_undefined_share(
    tmp_path, capsys
):
    """A route graph of one vertex and no edge: its line counts "1 vertex" and "1
    component", and the evaluation says in words that the unsafe share has no edges to
    measure, where the report holds NaN."""
    from topojax.cli import main

    image = np.zeros((60, 60), np.uint8)
    image[10:50, 10:50] = 254  # a 2 m square room: one spot for a robot of radius 0.5 m
    path = tmp_path / "box.png"
    cv2.imwrite(str(path), image)
    argv = ["route-graph", str(path), "-o", str(tmp_path / "out"), "--robot-radius", "0.5"]
    assert main([*argv, "--evaluate"]) == 0
    lines = capsys.readouterr().out.splitlines()
    graph_line = next(line for line in lines if line.startswith("route graph "))
    assert graph_line.startswith("route graph 1 vertex, 0 edges, 1 component, robot radius")
    evaluation = next(line for line in lines if line.startswith("evaluation "))
    assert "unsafe share: no edges" in evaluation
    assert "nan" not in evaluation


def test_replay_says_it_writes_no_nav2_file_for_an_empty_route_graph(tmp_path):
    """A replay asked for the route graph's Nav2 file whose final route graph has no
    edge writes the other route graph files and says, with why it is empty, that the
    Nav2 file is missing (the Route Server needs an edge), as ``topojax route-graph`` does."""
    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    out = tmp_path / "out"
    summary = tj.replay(
        log,
        out_dir=out,
        progress=False,
        max_scans=10,
        route_graph_radius_m=50.0,
        nav2_tolerance_m=0.1,
    )
    assert (out / "route_graph.json").is_file() and (out / "graph_nav2.geojson").is_file()
    assert not (out / "route_graph_nav2.geojson").exists()
    (note,) = [m for m in summary["messages"] if m.startswith("empty route graph")]
    assert note.endswith("; no route_graph_nav2.geojson (the Route Server needs an edge)")


@pytest.mark.parametrize("radius_m", [0.0, -0.0, -1.0])
def test_a_robot_radius_of_zero_or_less_is_refused_as_not_positive(tmp_path, radius_m):
    """A route graph needs a robot of some size: zero or less is refused as not positive
    (not as "expected >= 0" for -1, which made 0 look allowed until the map refused it)."""
    match = r"^robot_radius_m: expected a finite number of metres > 0, received "
    with pytest.raises(ValueError, match=match):
        RouteGraphConfig(robot_radius_m=radius_m)
    with pytest.raises(ValueError, match=match):
        route_graph(_map(_room(3, 3)), robot_radius_m=radius_m)
    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    match = r"^route_graph_radius_m: expected a finite number of metres > 0"
    with pytest.raises(ValueError, match=match):
        tj.replay(log, out_dir=tmp_path / "out", route_graph_radius_m=radius_m)


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (["--robot-radius", "-1"], "--robot-radius: expected a finite number of metres > 0"),
        (["--robot-radius", "0"], "--robot-radius: expected a finite number of metres > 0"),
        (["--robot-radius", "0.01"], "--robot-radius: expected at least 1.5 pixels of the map"),
        (["--robot-radius", "2000"], "--robot-radius: expected a robot radius of at most 1000 m"),
        (["--snap-m", "6"], "--snap-m: expected 0.2 to 5 m"),
        (["--snap-m", "0.15"], "--snap-m: expected 0.2 to 5 m"),
        (
            ["--resolution", "10000"],
            "map resolution (--resolution or the map's own): expected at most 3.26667 m per "
            "pixel for a route graph, received 10000",
        ),
    ],
)
def test_route_graph_command_names_its_own_options_before_any_file(
    tmp_path, capsys, option, message
):
    """A value out of range is refused under the command's option name (not the Python
    option's) before anything is written: ``--snap-m 6 --evaluate`` must not write the
    graph and then fail in the evaluation, nor ``--snap-m 0.15`` blame
    ``waypoint_tolerance_m``, which the command does not take."""
    from topojax.cli import main

    path = tmp_path / "room.png"
    cv2.imwrite(str(path), np.where(_room(3, 4), 254, 0).astype(np.uint8))
    out = tmp_path / "out"
    assert main(["route-graph", str(path), "-o", str(out), "--evaluate", *option]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    ("command", "option"),
    [
        (["route-graph", "{map}"], "--robot-radius"),
        (["batch", "{map}", "--formats", "route", "--workers", "0"], "--robot-radius"),
        (
            ["route", "{graph}", "--start", "1", "1", "--goal", "2", "2", "--map", "{map}"],
            "--robot-radius",
        ),
        (["replay", "{log}"], "--route-graph"),
    ],
)
def test_a_robot_radius_too_large_is_refused_under_the_commands_option(
    tmp_path, capsys, command, option
):
    """A radius over 1000 m (a unit error) is named by the command's option, as one
    below zero or below 1.5 pixels is, not by the library's ``robot_radius_m``."""
    from pathlib import Path

    from topojax.cli import main

    path = tmp_path / "room.png"
    cv2.imwrite(str(path), np.where(_room(3, 4), 254, 0).astype(np.uint8))
    names = {
        "map": str(path),
        "graph": str(tmp_path / "room.json"),
        "log": str(Path(__file__).parent / "data" / "intel_first40.log.gz"),
    }
    argv = [part.format(**names) for part in command]
    out = tmp_path / "out"
    assert main([*argv, "-o", str(out / "x.geojson"), option, "5000"]) == 2
    assert f"{option}: expected a robot radius of at most 1000 m" in capsys.readouterr().err
    assert not out.exists()


def test_which_map_files_state_their_resolution(tmp_path):
    from topojax.maps.files import default_resolution_used

    m = tj.OccupancyMap.from_array(np.zeros((8, 8), bool), resolution_m=0.1)
    tj.save_map(m, tmp_path / "m.yaml")  # a YAML and a PGM whose comment gives 0.1
    assert not default_resolution_used(tmp_path / "m.yaml")
    assert not default_resolution_used(tmp_path / "m.pgm")
    cv2.imwrite(str(tmp_path / "bare.pgm"), np.full((8, 8), 254, np.uint8))
    assert default_resolution_used(tmp_path / "bare.pgm")
    assert default_resolution_used(tmp_path / "bare.png")


def test_route_graph_command_explains_an_empty_graph_and_writes_no_nav2_file(tmp_path, capsys):
    """A robot that fits nowhere gets an empty graph, a note saying why, the other files
    and no Nav2 file (the Route Server needs an edge), not an error after half the files."""
    from topojax.cli import main

    obstacles = np.zeros((40, 40), bool)
    obstacles[[0, -1], :] = True
    obstacles[:, [0, -1]] = True
    path = tmp_path / "closet.png"
    cv2.imwrite(str(path), np.where(obstacles, 0, 254).astype(np.uint8))
    out = tmp_path / "out"
    argv = ["route-graph", str(path), "-o", str(out), "--nav2", "--evaluate"]
    assert main([*argv, "--robot-radius", "0.2"]) == 0
    assert (out / "closet_route_nav2.geojson").is_file()
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert main([*argv, "--robot-radius", "5"]) == 0
    text, err = capsys.readouterr()
    assert "empty route graph" not in err
    assert text.count("empty route graph") == 1  # the note line, not a warning as well
    assert "note       empty route graph: no known-free region" in text
    assert "robot of radius 5 m fits" in text and "no Nav2 file" in text
    assert "evaluation no route to score: no feasible region of at least 1 m2" in text
    assert "nan" not in text
    assert not (out / "closet_route_nav2.geojson").exists()  # nor the earlier run's
    assert (out / "closet_route.json").is_file() and (out / "closet_route_report.json").is_file()
    # an .mcap path under a file is refused before any work
    assert main([*argv, "--mcap", str(path / "x.mcap")]) == 2
    assert "is a file, not a folder" in capsys.readouterr().err


def test_mapper_route_graph_is_the_route_graph_of_its_map():
    from topojax.scans import read_scans

    mapper = tj.IncrementalMapper(resolution_m=0.05)
    for scan in read_scans("tests/data/intel_first40.log.gz"):
        mapper.add_scan(scan)
    got = mapper.route_graph(robot_radius_m=0.25)
    want = route_graph(mapper.occupancy, robot_radius_m=0.25)
    assert got.number_of_nodes() == want.number_of_nodes() > 0
    assert sorted(map(tuple, (d["pixel"] for _, d in got.nodes(data=True)))) == sorted(
        map(tuple, (d["pixel"] for _, d in want.nodes(data=True)))
    )
    assert got.graph["robot_radius_m"] == 0.25
    assert got.graph["min_region_m2"] == want.graph["min_region_m2"] == 1.0


def test_the_mapper_takes_scans_while_its_route_graph_is_built(monkeypatch):
    """mapper.route_graph holds the mapper's lock only to export the map: a scan callback
    on another thread maps its scan while the route graph is built (up to tenths of a
    second a map), and the graph is that of the map as the call found it."""
    import threading

    import topojax.routegraph as routegraph
    from topojax.scans import read_scans

    scans = list(read_scans("tests/data/intel_first40.log.gz"))
    mapper = tj.IncrementalMapper(resolution_m=RES)
    for scan in scans[:30]:
        mapper.add_scan(scan)
    before = mapper.occupancy
    build = routegraph.route_graph
    taken = []

    def scan_callback():  # a scan arriving now: mapped if the lock is free
        if mapper._lock.acquire(blocking=False):
            try:
                taken.append(mapper.add_scan(scans[30]).index)
            finally:
                mapper._lock.release()

    def building(occupancy, **kw):
        thread = threading.Thread(target=scan_callback)
        thread.start()
        thread.join()
        return build(occupancy, **kw)

    monkeypatch.setattr(routegraph, "route_graph", building)
    got = mapper.route_graph(robot_radius_m=R)
    assert taken == [30] and mapper.n_scans == 31
    want = build(before, robot_radius_m=R)
    assert list(got.edges(keys=True)) == list(want.edges(keys=True)) != []
    assert got.graph["shape"] == want.graph["shape"]


def test_an_empty_route_graph_of_the_mapper_warns_at_the_caller_s_line():
    """The warning that the mapper's route graph is empty names the user's line, as
    ``tj.route_graph``'s does, not the mapper's module (where the default filter would
    show it once for every caller in the process)."""
    from topojax.scans import Scan

    mapper = tj.IncrementalMapper(resolution_m=RES)
    closet = Scan.from_arrays(np.full(360, 0.4), (0, 0, 0), angle_min=0, angle_increment=0.0175)
    mapper.add_scan(closet)  # 0.8 m across: no room for a robot of radius 0.3 m
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        graph = mapper.route_graph(robot_radius_m=R)
    assert graph.number_of_nodes() == 0
    notes = [w for w in caught if "empty route graph" in str(w.message)]
    assert [w.filename for w in notes] == [__file__]


def test_replay_writes_the_route_graph_of_its_final_map(tmp_path, capsys):
    from topojax._words import counted
    from topojax.cli import main
    from topojax.io import load_graph
    from topojax.plotting import route_graph_png

    argv = ["replay", "tests/data/intel_first40.log.gz", "-o", str(tmp_path), "--no-progress"]
    assert main([*argv, "--route-graph", "0.25"]) == 0
    g = load_graph(tmp_path / "route_graph.json")
    assert g.graph["robot_radius_m"] == 0.25 and g.number_of_edges() > 0
    text = capsys.readouterr().out
    assert "route_graph.geojson" in text and "empty route graph" not in text
    counts = {"vertices": g.number_of_nodes(), "edges": g.number_of_edges()}
    counts["components"] = nx.number_connected_components(g)
    assert (
        f"route graph {counted(counts['vertices'], 'vertex', 'vertices')}, "
        f"{counted(counts['edges'], 'edge')}, {counted(counts['components'], 'component')}, "
        "robot radius 0.25 m\n" in text
    )
    timings = json.loads((tmp_path / "timings.json").read_text())
    assert timings["route_graph"] == {**counts, "robot_radius_m": 0.25}
    assert not (tmp_path / "route_graph_nav2.geojson").exists()
    # with --nav2 the route graph, not only the topology graph, goes to the Route Server
    assert main([*argv, "--route-graph", "0.25", "--nav2"]) == 0
    doc = json.loads((tmp_path / "route_graph_nav2.geojson").read_text())
    edges = [f for f in doc["features"] if f["geometry"]["type"] == "MultiLineString"]
    assert len(edges) >= 2 * g.number_of_edges()  # both directions of every waypoint run
    assert not (tmp_path / "route_graph.png").exists()  # a picture with --plot
    # with --plot the picture topojax route-graph --plot draws, titled with the log
    assert main([*argv, "--route-graph", "0.25", "--plot"]) == 0
    title = f"intel_first40: r = 0.25 m: {counts['vertices']} vertices, {counts['edges']} edges"
    drawn = route_graph_png(load_graph(tmp_path / "route_graph.json"), tmp_path / "map.yaml")
    assert (tmp_path / "route_graph.png").read_bytes() != drawn  # the title
    drawn = route_graph_png(
        load_graph(tmp_path / "route_graph.json"), tmp_path / "map.yaml", title=title
    )
    assert (tmp_path / "route_graph.png").read_bytes() == drawn
    assert main([*argv, "--route-graph", "-1"]) == 2  # refused before the replay
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert main([*argv, "--route-graph", "100", "--nav2"]) == 0  # a robot too large
    text, err = capsys.readouterr()
    assert "empty route graph" not in err
    assert text.count("empty route graph: no known-free region") == 1  # said once
    assert "route graph 0 vertices, 0 edges, 0 components, robot radius 100 m\n" in text
    assert not (tmp_path / "route_graph_nav2.geojson").exists()  # the earlier run's went
    assert not (tmp_path / "route_graph.png").exists()


def test_replay_route_graph_files_hold_no_build_times(tmp_path):
    """The route graph a replay writes carries what the log and options determine, as the
    route-graph command's: no stage timings, so a rerun writes the same bytes."""
    from topojax.cli import main
    from topojax.io import load_graph

    argv = ["replay", "tests/data/intel_first40.log.gz", "--no-progress", "--max-scans", "20"]
    names = [f"route_graph{s}" for s in (".graphml", ".json", ".geojson")]
    files = []
    for run in ("a", "b"):
        assert main([*argv, "-o", str(tmp_path / run), "--route-graph", "0.3"]) == 0
        files.append([(tmp_path / run / name).read_bytes() for name in names])
    assert "timings_s" not in load_graph(tmp_path / "a" / "route_graph.json").graph
    assert files[0] == files[1]


def test_replay_refuses_a_route_graph_radius_too_small_for_its_grid_before_mapping(
    tmp_path, monkeypatch
):
    from topojax.cli import main

    def no_scan(self, scan):
        raise AssertionError("a scan was mapped before the radius was checked")

    monkeypatch.setattr(tj.IncrementalMapper, "add_scan", no_scan)

    log = "tests/data/intel_first40.log.gz"
    argv = ["replay", log, "-o", str(tmp_path / "cli"), "--no-progress"]
    assert main([*argv, "--route-graph", "0.3", "--resolution", "0.25"]) == 2
    assert not (tmp_path / "cli").exists()  # checked before the folder and the scans
    with pytest.raises(ValueError, match=r"^route_graph_radius_m: expected at least 1.5 pix"):
        tj.replay(log, out_dir=tmp_path / "api", route_graph_radius_m=0.3, resolution_m=0.25)
    with pytest.raises(ValueError, match=r"^route_graph_radius_m: expected a robot radius of"):
        tj.replay(log, out_dir=tmp_path / "api", route_graph_radius_m=2000.0)


def test_replay_blames_a_map_too_coarse_for_its_route_graph_on_the_resolution(
    tmp_path, monkeypatch, capsys
):
    """A replay builds its route graph with the default snap_m, which neither the API nor
    the command sets: a map too coarse for it is refused under the resolution, with the
    coarsest it takes, never as a snap_m the caller did not give."""
    from topojax.cli import main

    def no_scan(self, scan):
        raise AssertionError("a scan was mapped before the map's scale was checked")

    monkeypatch.setattr(tj.IncrementalMapper, "add_scan", no_scan)
    log = "tests/data/intel_first40.log.gz"
    expected = r"^resolution_m: expected at most 0\.6 m per pixel for a route graph, received 1:"
    with pytest.raises(ValueError, match=expected) as info:
        tj.replay(log, out_dir=tmp_path / "api", route_graph_radius_m=2.0, resolution_m=1.0)
    assert "snap_m" not in str(info.value)
    argv = ["replay", log, "-o", str(tmp_path / "cli"), "--no-progress", "--resolution", "1"]
    assert main([*argv, "--route-graph", "2"]) == 2
    said = capsys.readouterr().err
    assert "--resolution: expected at most 0.6 m per pixel for a route graph" in said
    assert "snap_m" not in said and "resolution_m" not in said


def _crossings(g: nx.MultiGraph, near_px: float = R / RES) -> int:
    """Pixels on two different edges' paths farther than ``near_px`` (the robot radius)
    from every vertex."""
    seen: dict[tuple[int, int], int] = {}
    shared = set()
    for k, (_, _, path) in enumerate(g.edges(data="path")):
        for p in map(tuple, np.asarray(path).tolist()):
            if seen.setdefault(p, k) != k:
                shared.add(p)
    vertices = np.concatenate([np.asarray(d, np.int64) for _, d in g.nodes(data="pixels")])
    return sum(int(np.abs(vertices - np.array(p)).max(axis=1).min() > near_px) for p in shared)


@pytest.mark.parametrize("size_m", [(12, 20), (20, 20)])
def test_shortcuts_cross_no_edge_and_close_no_short_loop_in_an_open_hall(size_m):
    occ = _map(_room(*size_m))
    g = route_graph(occ, robot_radius_m=R)
    assert _crossings(g) == 0
    assert tj.evaluate_route_graph(g, occ, robot_radius_m=R, n_pairs=20).short_loops == 0
    _assert_safe(g, occ)
    assert nx.number_connected_components(g) == 1


def _hall_with_pillars() -> OccupancyMap:
    """A 20 x 20 m hall with four 1 m pillars 3 m off its walls."""
    free = _room(20, 20)
    for r, c in [(3, 3), (3, 15), (16, 4), (15, 15)]:
        free[_px(r) : _px(r + 1), _px(c) : _px(c + 1)] = False
    return _map(free)


@pytest.mark.parametrize("radius_m", [2.0, 4.0])
def test_a_large_robot_gets_shortcuts_that_cross_no_edge(radius_m):
    """A shortcut may touch other edges only near its ends, where close vertices merge
    (the robot's radius, up to half the snap distance): a zone of the full radius of a
    robot of 2-4 m would span whole shortcuts, which would cross the edges of the hall."""
    occ = _hall_with_pillars()
    cfg = RouteGraphConfig(robot_radius_m=radius_m, shortcuts_round_corners=False)
    g = route_graph(occ, config=cfg)
    merge_px = min(radius_m, 0.5 * cfg.snap_m) / RES
    assert g.number_of_edges() > g.number_of_nodes()  # shortcuts were taken
    assert _crossings(g, merge_px) == 0
    _assert_safe(g, occ, radius_m)
    assert g.graph["uncovered_share"] == 0.0
    assert nx.number_connected_components(g) == 1


def test_a_large_robot_with_a_small_snap_searches_few_routes(monkeypatch):
    """With a snap distance of 0.2 m the hall has a dense net of vertices, and a robot of
    5 m the whole shortcut radius: still most candidate shortcuts end at the line test
    (they cross an edge, and are dropped before the greedy pass), and only a few per node
    get a route search."""
    import topojax.routegraph._cover as cover

    calls, lines = [], []
    original, original_lines = cover.greedy_shortcuts, cover.clear_lines

    def counted(pos, *args):
        taken, searched = original(pos, *args)
        calls.append((pos.shape[0], searched, int(taken.sum())))
        return taken, searched

    def counted_lines(a, *args):
        lines.append(a.size)
        return original_lines(a, *args)

    monkeypatch.setattr(cover, "greedy_shortcuts", counted)
    monkeypatch.setattr(cover, "clear_lines", counted_lines)
    cfg = RouteGraphConfig(robot_radius_m=5.0, snap_m=0.2)
    g = route_graph(_hall_with_pillars(), config=cfg)
    ((nodes, searched, taken),) = calls
    assert sum(lines) > 100 * nodes  # the radius holds many candidates per node
    assert 0 < taken <= searched <= 10 * nodes
    assert g.graph["uncovered_share"] == 0.0


@pytest.mark.parametrize("snap_px", [4.0, 7.5, 20.0, 21.0])
def test_coverage_never_reaches_past_the_snap_distance(snap_px):
    from topojax.routegraph._cover import covered

    raster = np.zeros((101, 101), bool)
    raster[50, 50] = True
    feasible = np.ones_like(raster)
    reach = covered(raster, feasible, snap_px)
    rows, cols = np.nonzero(reach)
    assert np.hypot(rows - 50, cols - 50).max() <= snap_px + 1e-9
    assert reach[50, 50 + int(snap_px) - 1]  # and it does reach most of the way


def test_coverage_counts_a_pixel_only_where_a_straight_snap_reaches_the_graph():
    """A robot snaps to the graph along a straight line: a pixel around the end of a wall,
    near the graph through the free space but hidden from it, is not covered."""
    from topojax.routegraph._cover import covered

    raster = np.zeros((101, 101), bool)
    raster[50, 50] = True
    feasible = np.ones_like(raster)
    feasible[45:56, 53] = False  # a wall 11 px long, 3 px to the right of the graph
    reach = covered(raster, feasible, 20.0)
    assert not reach[50, 56]  # 6 px away in a straight line, 13.4 px round the wall's end
    assert reach[50, 31] and reach[38, 53]  # in plain sight
    rows, cols = np.nonzero(reach)
    for r, c in zip(rows.tolist(), cols.tolist(), strict=True):  # every one in sight
        n = max(abs(r - 50), abs(c - 50)) * 4 + 2
        t = np.linspace(0.0, 1.0, n)
        pr, pc = np.rint(50 + t * (r - 50)).astype(int), np.rint(50 + t * (c - 50)).astype(int)
        assert feasible[pr, pc].all()


def test_shortcuts_from_points_along_edges_shorten_routes_around_pillars():
    """Between pillars the medial axis leaves long bending edges with few vertices;
    shortcuts that may start part-way along them (``shortcut_spacing_m``) give more direct
    routes, and every such shortcut is safe and splits its edge at a vertex."""
    free = _room(12, 12)
    for r in np.arange(3.0, 10.0, 3.0):
        for c in np.arange(3.0, 10.0, 3.0):
            free[_px(r) - 10 : _px(r) + 10, _px(c) - 10 : _px(c) + 10] = False  # 1 m blocks
    occ = _map(free)
    only_vertices = route_graph(occ, config=RouteGraphConfig(shortcut_spacing_m=0.0))
    along = route_graph(occ)
    _assert_safe(along, occ)
    _assert_one_component_per_region(along, occ)
    a = tj.evaluate_route_graph(only_vertices, occ, robot_radius_m=R, n_pairs=200)
    b = tj.evaluate_route_graph(along, occ, robot_radius_m=R, n_pairs=200)
    assert b.success_rate == a.success_rate == 1.0
    assert b.stretch_p90 < a.stretch_p90
    assert b.stretch_median <= a.stretch_median


def _centre_segment_graph(shape, r, c0, c1):
    from topojax.graph.work import WorkGraph, line_pixels

    work = WorkGraph()
    a, b = work.add_vertex((r, c0)), work.add_vertex((r, c1))
    work.add_edge(a, b, line_pixels((r, c0), (r, c1)))
    return work


def test_first_lanes_run_along_the_walls_at_the_inset_and_join_the_graph():
    """Round the walls of an open room, one lane on the level curve LANE_INSET snap
    distances from the pixels that are not feasible, joined to the graph in one piece."""
    from topojax.routegraph._cover import covered, graph_raster, wall_distance
    from topojax.routegraph._lanes import LANE_INSET, add_lanes

    feasible = np.zeros((120, 240), bool)
    feasible[10:110, 10:230] = True  # a 5 x 11 m room at 0.05 m
    snap = 20.0
    work = _centre_segment_graph(feasible.shape, 60, 60, 180)
    raster = graph_raster(work, feasible.shape)
    uncovered = feasible & ~covered(raster, feasible, snap)
    assert add_lanes(
        work, uncovered, raster, feasible, wall_distance(feasible), snap, 0.0, along_walls=True
    )
    wall = cv2.distanceTransform(feasible.view(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    new = [e for e in work.edges if e != 0 and work.length[e] > 5 * snap]
    assert len(new) >= 1
    for e in new:  # long lane edges: on the level curve (within a pixel and a half)
        path = work.edges[e][2]
        assert np.abs(wall[path[:, 0], path[:, 1]] - LANE_INSET * snap).max() <= 1.5
    g = nx.MultiGraph()
    g.add_edges_from((u, v) for u, v, _ in work.edges.values())
    assert nx.number_connected_components(g) == 1
    raster = graph_raster(work, feasible.shape)
    # corners included, the lanes and the centre line leave only specks uncovered
    assert np.count_nonzero(feasible & ~covered(raster, feasible, snap)) < 0.01 * feasible.sum()


def test_no_lanes_for_uncovered_pieces_smaller_than_the_minimum():
    from topojax.routegraph._cover import covered, graph_raster, wall_distance
    from topojax.routegraph._lanes import LANE_MIN_AREA, add_lanes

    feasible = np.zeros((60, 120), bool)
    feasible[10:50, 10:110] = True  # 2 x 5 m: a centre line leaves slivers only
    snap = 20.0
    work = _centre_segment_graph(feasible.shape, 30, 20, 100)
    raster = graph_raster(work, feasible.shape)
    uncovered = feasible & ~covered(raster, feasible, snap)
    _, _, stats, _ = cv2.connectedComponentsWithStats(uncovered.view(np.uint8), connectivity=8)
    assert (stats[1:, cv2.CC_STAT_AREA] < LANE_MIN_AREA * snap**2).all()
    n_edges = len(work.edges)
    assert not add_lanes(
        work, uncovered, raster, feasible, wall_distance(feasible), snap, 0.0, along_walls=True
    )
    assert len(work.edges) == n_edges


def _brute_covered(raster, feasible, snap_px):
    """Reference: every feasible pixel against every graph pixel within ``snap_px``, the
    straight segment's pixels (its supercover, sampled densely) all feasible."""
    out = np.zeros_like(feasible)
    graph = np.argwhere(raster)
    for r, c in np.argwhere(feasible):
        d = np.hypot(graph[:, 0] - r, graph[:, 1] - c)
        for gr, gc in graph[d <= snap_px]:
            n = int(max(abs(gr - r), abs(gc - c))) * 8 + 2
            t = np.linspace(0.0, 1.0, n)
            pr, pc = r + t * (gr - r), c + t * (gc - c)
            # a point on a pixel border lies on both pixels: all must be feasible
            lo_r, hi_r = np.floor(pr + 0.5 - 1e-9), np.ceil(pr - 0.5 + 1e-9)
            lo_c, hi_c = np.floor(pc + 0.5 - 1e-9), np.ceil(pc - 0.5 + 1e-9)
            ok = True
            for rr in (lo_r, hi_r):
                for cc in (lo_c, hi_c):
                    ok &= bool(feasible[rr.astype(int), cc.astype(int)].all())
            if ok:
                out[r, c] = True
                break
    return out


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("few", [True, False])
def test_coverage_equals_a_brute_force_reference(seed, few, monkeypatch):
    """Both ways of naming a near graph pixel (the nearest, searched row by row, for few
    pixels; the labelled distance transform's for many, then the row search where that
    one is hidden or out of reach) give the reference's answer."""
    from topojax.routegraph import _cover

    monkeypatch.setattr(_cover, "_ROWS_PER_PIXEL", 10**9 if few else 0)
    rng = np.random.default_rng(seed)
    feasible = np.ones((48, 56), bool)
    for _ in range(14):  # walls and pillars
        r, c = rng.integers(0, 44), rng.integers(0, 52)
        feasible[r : r + rng.integers(1, 4), c : c + rng.integers(1, 12)] = False
    raster = np.zeros_like(feasible)
    raster[rng.integers(0, 48, 6), rng.integers(0, 56, 6)] = True
    raster[24, 5:50] = True
    raster &= feasible
    snap = 7.5
    got = _cover.covered(raster, feasible, snap)
    want = _brute_covered(raster, feasible, snap)
    assert np.array_equal(got, want)
    # only some pixels tested (later rounds): the same answer there, False elsewhere
    among = np.zeros_like(feasible)
    among[30:, :20] = True
    among[rng.integers(0, 48, 40), rng.integers(0, 56, 40)] = True
    assert np.array_equal(_cover.covered(raster, feasible, snap, among=among), want & among)
    # a graph grown in two steps: testing what the first left uncovered against only the
    # pixels added gives the whole graph's answer (what add_coverage relies on)
    first = raster.copy()
    first[24, 30:] = False
    seen = _cover.covered(first, feasible, snap)
    added = raster & ~first
    rest = _cover.covered(added, feasible, snap, among=feasible & ~seen)
    assert np.array_equal(seen | rest, want)


@pytest.mark.parametrize("few", [True, False])
def test_coverage_of_a_strip_narrower_than_the_reach(few, monkeypatch):
    """A strip a few pixels wide with one graph pixel and a reach several times its width:
    rows without a graph pixel count as having none in reach, whatever the width."""
    from topojax.routegraph import _cover

    monkeypatch.setattr(_cover, "_ROWS_PER_PIXEL", 10**9 if few else 0)
    feasible = np.ones((200, 8), bool)
    raster = np.zeros_like(feasible)
    raster[0, 4] = True
    got = _cover.covered(raster, feasible, 40.0)
    assert np.array_equal(got, _brute_covered(raster, feasible, 40.0))
    assert got[:30].all() and not got[45:].any()


def test_straight_segments_are_tested_pixel_by_pixel():
    from topojax.graph.work import line_pixels
    from topojax.routegraph._joins import feasible_segments

    rng = np.random.default_rng(5)
    feasible = rng.random((30, 40)) > 0.08
    a = np.stack([rng.integers(0, 30, 200), rng.integers(0, 40, 200)], axis=1)
    b = np.stack([rng.integers(0, 30, 200), rng.integers(0, 40, 200)], axis=1)
    want = np.array([feasible[tuple(line_pixels(p, q).T)].all() for p, q in zip(a, b, strict=True)])
    assert 0 < want.sum() < len(want)
    assert np.array_equal(feasible_segments(a, b, feasible, False), want)
    first = np.zeros_like(want)
    first[np.argmax(want)] = True
    assert np.array_equal(feasible_segments(a, b, feasible, True), first)


@pytest.mark.parametrize("plan", ["random", "hall"])
def test_route_graph_moves_with_the_map(plan):
    """Unknown space added round a map (by odd and even numbers of pixels) moves the
    graph by as many pixels and changes nothing else (the hall's mesh included)."""
    free = _random_plan(3) if plan == "random" else _room(12, 14)
    g0 = route_graph(_map(free), robot_radius_m=R)
    for top, left in ((3, 0), (0, 5), (7, 2)):
        padded = np.pad(free, ((top, 4), (left, 1)))
        occ = OccupancyMap(
            occupied=np.zeros_like(padded),
            free=padded,
            unknown=~padded,
            resolution_m=RES,
        )
        g = route_graph(occ, robot_radius_m=R)
        assert g.number_of_nodes() == g0.number_of_nodes()
        assert g.number_of_edges() == g0.number_of_edges()
        shift = np.array([top, left])
        for n in g0.nodes:
            assert tuple(np.add(g0.nodes[n]["pixel"], shift)) == g.nodes[n]["pixel"]
        e0 = sorted((u, v, np.asarray(d["path"]).tobytes()) for u, v, d in g0.edges(data=True))
        e1 = sorted(
            (u, v, (np.asarray(d["path"]) - shift).astype(np.int32).tobytes())
            for u, v, d in g.edges(data=True)
        )
        assert e0 == e1


def _wall_end_room() -> np.ndarray:
    """A 10 m x 10 m room split by a wall from its top edge down to 6 m: the free space
    is a U round the wall's end."""
    free = _room(10, 10)
    free[: _px(6), _px(4.9) : _px(5.1)] = False
    return free


def test_reflex_corners_are_where_the_free_space_turns_round_an_obstacle():
    from topojax.routegraph._corners import reflex_corners

    occ = _map(_wall_end_room())
    feasible = feasible_space(occ, R).feasible
    corners = reflex_corners(feasible, 0.15 / RES)
    assert len(corners) >= 1 and feasible[corners[:, 0], corners[:, 1]].all()
    # the wall's end (row 6 m, col 5 m) has corners near it; the room's own corners
    # (where the free space is convex) have none
    end = np.array([_px(6), _px(5)])
    d = np.hypot(*(corners - end).T)
    assert (d < _px(0.6)).any()
    for corner in ([0, 0], [0, _px(10)], [_px(10), 0], [_px(10), _px(10)]):
        assert np.hypot(*(corners - np.array(corner)).T).min() > _px(1.0)


def test_shortcuts_bend_round_a_wall_end():
    """Routes from one side of the wall to the other hug its end: with
    ``shortcuts_round_corners`` an edge passes close by it and routes are shorter."""
    occ = _map(_wall_end_room())
    on = route_graph(occ, robot_radius_m=R)
    off = route_graph(occ, config=RouteGraphConfig(shortcuts_round_corners=False))
    end = np.array([_px(6), _px(5)])

    def nearest_px(g):
        return min(np.hypot(*(np.asarray(d["path"]) - end).T).min() for *_, d in g.edges(data=True))

    assert nearest_px(on) < _px(R + 0.25) < nearest_px(off)
    _assert_safe(on, occ)
    _assert_one_component_per_region(on, occ)
    e_on = tj.evaluate_route_graph(on, occ, robot_radius_m=R, n_pairs=200)
    e_off = tj.evaluate_route_graph(off, occ, robot_radius_m=R, n_pairs=200)
    assert e_on.stretch_median < e_off.stretch_median
    assert e_on.short_loops == 0


def test_bent_shortcuts_close_no_short_loop_through_a_shared_corner():
    """Pillars in a hall: many routes bend round each pillar's corners; no loop shorter
    than twice ``loop_m`` appears, through a corner used twice or otherwise."""
    free = _room(12, 12)
    for r in (3, 6, 9):
        for c in (3, 6, 9):
            free[_px(r) - 6 : _px(r) + 6, _px(c) - 6 : _px(c) + 6] = False
    occ = _map(free)
    g = route_graph(occ, robot_radius_m=R)
    assert tj.evaluate_route_graph(g, occ, robot_radius_m=R, n_pairs=50).short_loops == 0
    _assert_safe(g, occ)


@pytest.mark.parametrize("name", ["office", "intel"])
def test_shortcuts_bent_at_one_corner_share_their_legs(name):
    """Two shortcuts bent at the same corner from the same vertex add that leg once: no
    two edges join the same vertices along the same pixels (each such pair would be a
    loop of no length for a planner, and a doubled edge in the Nav2 file)."""
    g = route_graph(tj.sample_map(name), robot_radius_m=R)
    seen = set()
    for u, v, d in g.edges(data=True):
        path = np.asarray(d["path"])
        key = (u, v, path.tobytes()) if u <= v else (v, u, path[::-1].tobytes())
        assert key not in seen, f"edge {u}-{v} twice"
        seen.add(key)


def test_compiled_helpers_match_plain_numpy():
    """The compiled helpers of the builder against plain NumPy references: pixels of a
    mask, simplification of many paths at once, and anchors along edges."""
    from topojax.graph.work import SQRT2
    from topojax.routegraph._joins import mask_pixels
    from topojax.routegraph._spanner import anchor_pieces, simplify_path, simplify_paths

    rng = np.random.default_rng(5)
    for density in (0.0, 0.01, 0.5):
        mask = rng.random((37, 53)) < density
        assert np.array_equal(mask_pixels(mask), np.argwhere(mask))

    # random 8-connected walks as edge paths
    paths = []
    for n in (1, 2, 9, 40, 75):
        steps = rng.integers(-1, 2, size=(n - 1, 2))
        steps[(steps == 0).all(axis=1)] = (0, 1)
        paths.append(np.cumsum(np.r_[[[50, 50]], steps], axis=0).astype(np.int64))
    feasible = np.ones((200, 200), bool)
    every = np.concatenate(paths)
    sizes = np.array([len(p) for p in paths], np.int64)
    starts = np.r_[0, np.cumsum(sizes)[:-1]].astype(np.int64)
    kept = simplify_paths(every, starts, sizes, feasible, 1.5)
    for p, s0 in zip(paths, starts, strict=True):
        assert np.array_equal(kept[s0 : s0 + len(p)], simplify_path(p, feasible, 1.5))

    long = [p for p in paths if len(p) >= 2]
    every = np.concatenate(long)
    sizes = np.array([len(p) for p in long], np.int64)
    starts = np.r_[0, np.cumsum(sizes)[:-1]].astype(np.int64)
    ia = np.arange(len(long), dtype=np.int64)
    ib = ia + 1
    spacing, keep = 3.0, 2.0
    at, first, owner, pu, pv, pw = anchor_pieces(every, starts, sizes, ia, ib, 10, spacing, keep)
    ref_at, ref_pieces, n = [], [], 10
    for e, p in enumerate(long):  # reference: equal parts, the first pixel at or past each
        step = np.abs(np.diff(p, axis=0))
        arc = np.r_[0.0, np.cumsum(np.where(step.min(axis=1) > 0, SQRT2, 1.0))]
        k = int(arc[-1] // spacing)
        cut = np.searchsorted(arc, arc[-1] * np.arange(1, k) / k) if k > 1 else np.zeros(0, int)
        cut = np.unique(cut[(arc[cut] >= keep) & (arc[-1] - arc[cut] >= keep)])
        ids = np.r_[ia[e], n + np.arange(cut.size), ib[e]]
        marks = np.r_[0.0, arc[cut], arc[-1]]
        ref_at += (starts[e] + cut).tolist()
        ref_pieces += list(
            zip(ids[:-1].tolist(), ids[1:].tolist(), np.diff(marks).tolist(), strict=True)
        )
        n += cut.size
    assert at.tolist() == ref_at and len(ref_at) > 0
    assert list(zip(pu.tolist(), pv.tolist(), pw.tolist(), strict=True)) == ref_pieces
    assert np.array_equal(every[at], every[np.array(ref_at)])
    assert (owner >= 0).all() and (first <= np.arange(10, 10 + at.size)).all()


def test_a_spacing_below_a_pixel_anchors_every_pixel_however_small():
    """Cuts less than a pixel apart put an anchor on every pixel of an edge (but its
    ends); a spacing of 1e-300 pixels does the same, promptly, rather than ask for more
    cuts than an int holds (which would make none) or loop over billions of them."""
    from topojax.routegraph._spanner import anchor_pieces

    every = np.array([[5, c] for c in range(12)] + [[5 + r, 11 + r] for r in range(1, 9)])
    starts, sizes = np.array([0], np.int64), np.array([len(every)], np.int64)
    ends = (np.array([0], np.int64), np.array([1], np.int64))
    want = anchor_pieces(every, starts, sizes, *ends, 2, 0.5, 1.0)
    assert want[0].tolist() == list(range(1, len(every) - 1))
    for spacing in (1e-6, 1e-300):
        got = anchor_pieces(every, starts, sizes, *ends, 2, spacing, 1.0)
        assert all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))


def _without_mesh(monkeypatch):
    """Route graphs as if open pieces were too small for a mesh (skeleton lanes)."""
    from topojax.routegraph import _cover, _joins

    def no_mesh(uncovered, min_area_px, split_px):
        return _joins.large_pieces(uncovered, min_area_px), np.zeros_like(uncovered)

    monkeypatch.setattr(_cover, "pieces_by_area", no_mesh)


def test_open_hall_gets_a_mesh_with_fewer_vertices_and_shorter_routes(monkeypatch):
    occ = _map(_room(20, 24))
    g = route_graph(occ, robot_radius_m=R)
    report = tj.evaluate_route_graph(g, occ, robot_radius_m=R, n_pairs=150)
    _without_mesh(monkeypatch)
    lanes = route_graph(occ, robot_radius_m=R)
    lanes_report = tj.evaluate_route_graph(lanes, occ, robot_radius_m=R, n_pairs=150)
    assert g.number_of_nodes() < 0.75 * lanes.number_of_nodes()
    assert report.stretch_median < lanes_report.stretch_median - 0.03
    assert report.stretch_p90 < lanes_report.stretch_p90
    assert report.success_rate == 1.0 and report.uncovered_share == 0.0
    assert report.short_loops == 0 and _crossings(g) == 0
    _assert_safe(g, occ)


def test_mesh_sites_edges_and_joins():
    """Through an open piece round which a lane runs: sites on the jittered lattice inside
    the piece, straight feasible edges that touch the lane only at their ends, one piece
    with the lane, and no loop shorter than the limit."""
    from topojax.graph.work import WorkGraph, line_pixels
    from topojax.routegraph._cover import covered, graph_raster
    from topojax.routegraph._eval_loops import short_loops
    from topojax.routegraph._mesh import MESH_JITTER, MESH_SPACING, add_mesh, mesh_pieces

    feasible = np.zeros((300, 360), bool)
    feasible[10:290, 10:350] = True
    snap, min_loop = 18.0, 84.0
    work = WorkGraph()  # a rectangular lane 12 pixels inside the feasible space
    corners = [(22, 22), (22, 337), (277, 337), (277, 22)]
    ids = [work.add_vertex(p) for p in corners]
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        work.add_edge(ids[k], ids[(k + 1) % 4], line_pixels(a, b))
    lane = graph_raster(work, feasible.shape)
    uncovered = feasible & ~covered(lane, feasible, snap)
    pieces = mesh_pieces(uncovered, snap)
    assert pieces.any() and not (pieces & ~uncovered).any()
    n_old = len(work.pixel)
    assert add_mesh(work, pieces, lane, feasible, snap, min_loop)
    spacing = MESH_SPACING * snap
    rows = {int(round(spacing * np.sqrt(3) / 2 * (k + 0.5))) for k in range(40)}
    new = [v for v in range(n_old, len(work.pixel)) if v not in work.dead]
    inside = [work.pixel[v] for v in new if pieces[work.pixel[v]]]
    assert len(inside) > 20
    for r, _ in inside:  # within the jitter of a lattice row
        assert min(abs(r - q) for q in rows) <= MESH_JITTER * spacing + 1
    pos = np.array(inside)
    d = np.hypot(*(pos[:, None] - pos[None]).transpose(2, 0, 1))
    assert d[np.triu_indices(len(pos), 1)].min() >= (1 - 2 * np.sqrt(2) * MESH_JITTER) * spacing - 2
    g = nx.MultiGraph()
    n_mesh = 0
    for u, v, path in work.edges.values():
        g.add_edge(u, v)
        assert feasible[path[:, 0], path[:, 1]].all()
        if lane[path[:, 0], path[:, 1]].all():
            continue  # a piece of the lane, split where mesh edges start
        n_mesh += 1
        assert np.array_equal(path, line_pixels(work.pixel[u], work.pixel[v]))
        far = np.hypot(*(path - path[0]).T) > 3
        far &= np.hypot(*(path - path[-1]).T) > 3
        assert not lane[path[far, 0], path[far, 1]].any()  # the lane at its ends only
    assert n_mesh > 2 * len(inside)
    assert nx.number_connected_components(g) == 1
    u = np.array([work.edges[e][0] for e in work.edges])
    v = np.array([work.edges[e][1] for e in work.edges])
    length = np.array([work.length[e] for e in work.edges])
    assert short_loops(len(work.pixel), u, v, length, min_loop) == 0


@pytest.mark.parametrize(
    ("limits", "dropped"),
    [
        # the square's other three sides are 30 px: a limit over that drops the side, and
        # then the next side has no other way round
        ((35.0, 35.0), (True, False)),
        ((30.0, 35.0), (False, True)),  # exactly 30 is no shorter loop
        ((0.0, -1.0), (False, False)),  # no limit: kept
    ],
)
def test_drop_short_loops_on_a_square(limits, dropped):
    from topojax.routegraph._spanner import drop_short_loops

    u = np.array([0, 1, 2, 3], np.int64)
    v = np.array([1, 2, 3, 0], np.int64)
    w = np.full(4, 10.0)
    got = drop_short_loops(4, u, v, w, np.array([0, 1], np.int64), np.array(limits))
    assert tuple(got.tolist()) == dropped


def test_greedy_shortcuts_take_many_disjoint_lines_and_then_route_along_them():
    """More accepted shortcuts than the pass first has room for: its adjacency grows, and
    every accepted line is then a route (the same candidates again are useless)."""
    from topojax.routegraph._spanner import greedy_shortcuts

    feasible = np.ones((210, 100), bool)
    # 50 rows x 12 columns of short horizontal segments, 4 rows and 8 columns apart: no
    # two touch, none joined by a route
    rc = np.array([(r, c) for r in range(4, 204, 4) for c in range(2, 98, 8)], np.int64)
    n = len(rc)
    pos = np.concatenate([rc, rc + [0, 3]])
    mem = pos.copy()
    mem_start = np.arange(2 * n + 1, dtype=np.int64)
    a = np.r_[np.arange(n), np.arange(n)].astype(np.int64)
    b = a + n
    taken, searched = greedy_shortcuts(
        pos,
        mem,
        mem_start,
        np.zeros(0, np.int64),
        np.zeros(0, np.int64),
        np.zeros(0, np.float64),
        a,
        b,
        np.full(2 * n, -1, np.int64),
        np.full(2 * n, 3.5),
        np.zeros(2 * n),
        feasible,
        np.zeros_like(feasible),
        1.0,
        0.0,
    )
    assert taken[:n].all()
    assert not taken[n:].any()
    assert searched == 2 * n  # every line is clear: each candidate's route is searched


def test_open_short_loops_removes_the_longest_edge_of_each_short_loop():
    """A ring round one pixel, two parallel edges of 4 and 5 pixels and a square of 40
    pixels: under a 12-pixel limit the ring and the longer parallel edge go, the square
    stays."""
    from topojax.graph.work import WorkGraph, line_pixels
    from topojax.routegraph._spanner import open_short_loops

    work = WorkGraph()
    a, b, c = (work.add_vertex(p) for p in ((10, 10), (10, 14), (30, 30)))
    work.add_edge(a, a, np.array([(10, 10), (9, 11), (10, 12), (11, 11), (10, 10)], np.int32))
    straight = work.add_edge(a, b, line_pixels((10, 10), (10, 14)))
    work.add_edge(a, b, np.array([(10, 10), (11, 11), (11, 12), (11, 13), (10, 14)], np.int32))
    tail = work.add_edge(b, c, line_pixels((10, 14), (30, 30)))
    corners = [(40, 10), (40, 20), (50, 20), (50, 10)]
    ids = [work.add_vertex(p) for p in corners]
    square = [
        work.add_edge(ids[k], ids[(k + 1) % 4], line_pixels(corners[k], corners[(k + 1) % 4]))
        for k in range(4)
    ]
    removed = open_short_loops(work, 12.0)
    assert sorted((u == v, len(path)) for u, v, path in removed) == [(False, 5), (True, 5)]
    # b is left between two edges and contracted: a runs straight on to c, the bent edge
    # (through (11, 12)) gone
    (rest,) = set(work.edges) - set(square)
    assert sorted(work.edges[rest][:2]) == [a, c] and straight not in work.edges
    assert tail not in work.edges and b in work.dead
    path = work.edges[rest][2]
    assert (path == (10, 12)).all(axis=1).any() and not (path == (11, 12)).all(axis=1).any()
    assert open_short_loops(work, 12.0) == []
    assert len(open_short_loops(work, 41.0)) == 1  # the square is shorter than that


def test_last_loop_pass_keeps_an_edge_that_coverage_needs():
    """Two 16-pixel loops on a line, each of a straight edge and one that bulges 4 pixels
    off it: with a 2-pixel snap distance the bulge over feasible pixels stays (they depend
    on it), the bulge over pixels that are not feasible goes."""
    from topojax.graph.work import WorkGraph, line_pixels
    from topojax.routegraph.build import _open_short_loops

    work = WorkGraph()
    ids = [work.add_vertex((10, c)) for c in (2, 10, 16, 30, 36, 45)]
    for k, (c0, c1) in enumerate([(2, 10), (10, 16), (16, 30), (30, 36), (36, 45)]):
        work.add_edge(ids[k], ids[k + 1], line_pixels((10, c0), (10, c1)))
    for k, (c0, r_mid) in ((1, (10, 14)), (3, (30, 6))):
        mid = (r_mid, c0 + 3)
        bulge = np.concatenate([line_pixels((10, c0), mid), line_pixels(mid, (10, c0 + 6))[1:]])
        work.add_edge(ids[k], ids[k + 1], bulge)
    feasible = np.zeros((30, 50), bool)
    feasible[9:20, :] = True  # the first bulge runs over feasible pixels, the second not
    _open_short_loops(work, feasible, 2.0, 20.0)

    def through(pixel) -> bool:
        return any((p == pixel).all(axis=1).any() for *_, p in work.edges.values())

    assert through((14, 13)) and not through((6, 33))
    assert all(through((10, c)) for c in range(2, 46))
    assert work.degrees()[ids[3]] == 0 and work.degrees()[ids[1]] == 3


@pytest.mark.parametrize(("seed", "snap_m"), [(55, 2.0), (3, 1.0)])
def test_no_loop_shorter_than_loop_m(seed, snap_m):
    """Random plans, including one whose lanes could close a ring round one pixel."""
    occ = _map(_random_plan(seed))
    config = RouteGraphConfig(snap_m=snap_m)
    g = route_graph(occ, config=config)
    assert g.graph["uncovered_share"] == 0.0
    # the shortest loop through each edge: back along a parallel edge, or round by others
    lengths: dict = {}
    for u, v, k, d in g.edges(keys=True, data=True):
        assert u != v or d["length_m"] >= config.loop_m
        if u != v:
            lengths.setdefault(frozenset((u, v)), []).append((d["length_m"], k))
    simple = nx.Graph()
    simple.add_weighted_edges_from((*pair, min(ls)[0]) for pair, ls in lengths.items())
    for pair, ls in lengths.items():
        u, v = pair
        simple.remove_edge(u, v)
        around = nx.single_source_dijkstra_path_length(simple, u).get(v, np.inf)
        simple.add_edge(u, v, weight=min(ls)[0])
        for length, k in ls:
            back = min([x for x, j in ls if j != k], default=np.inf)
            assert min(back, around) + length >= config.loop_m


@pytest.mark.parametrize("in_boxes", [True, False])
def test_large_pieces_keeps_the_8_connected_pieces_of_at_least_the_area(in_boxes, monkeypatch):
    """Small pieces cleared in their bounding boxes or by a lookup over the whole mask:
    both give scikit-image's labelling filtered by area, as a new array."""
    from skimage.measure import label

    from topojax.routegraph import _joins

    monkeypatch.setattr(_joins, "_PIECE_COST_PX", 0 if in_boxes else 10**9)
    rng = np.random.default_rng(3)
    for _ in range(40):
        mask = rng.random((int(rng.integers(1, 60)), int(rng.integers(1, 60)))) < rng.random()
        area = int(rng.integers(0, 25))
        labels = label(mask, connectivity=2)
        sizes = np.bincount(labels.ravel())
        want = mask & (sizes[labels] >= area)
        got = _joins.large_pieces(mask, area)
        assert got is not mask and np.array_equal(got, want)
        split = area + int(rng.integers(0, 25))
        small, large = _joins.pieces_by_area(mask, area, split)
        assert np.array_equal(large, mask & (sizes[labels] >= split))
        assert np.array_equal(small, want & (sizes[labels] < split))


def test_route_graphs_and_rooms_load_without_jax():
    """Neither needs the JAX kernels: a robot or a command line that builds them does
    not pay JAX's import."""
    import subprocess
    import sys

    code = "import sys, topojax.routegraph, topojax.rooms; print('jax' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_snap_and_tolerance_that_leave_no_reach_are_refused():
    """The pixel paths are covered to ``snap_m - waypoint_tolerance_m``: a tolerance over
    half the snap distance, or a reach under 1.5 pixels of the map, is refused before any
    work (it would mesh the free space a pixel apart)."""
    with pytest.raises(
        ValueError,
        match=r"^waypoint_tolerance_m: expected at most half of snap_m \(0.5 m\), received 2.0",
    ):
        tj.RouteGraphConfig(waypoint_tolerance_m=2.0)
    tj.RouteGraphConfig(snap_m=0.2, waypoint_tolerance_m=0.1)  # exactly half: fine
    # a tolerance over half the largest snap_m: no snap_m fits it, none is suggested
    with pytest.raises(ValueError, match=r"received 3.0 \(at most 2.5 m for the largest snap_m"):
        tj.RouteGraphConfig(waypoint_tolerance_m=3.0)
    with pytest.raises(ValueError, match=r"received 2.0 \(or snap_m: at least 4 m\)$"):
        tj.RouteGraphConfig(waypoint_tolerance_m=2.0)
    m = tj.load_map(tj.datasets.sample_map_path("office"))
    res = m.resolution_m
    tight = tj.RouteGraphConfig(snap_m=0.05 + res, waypoint_tolerance_m=0.05)  # 1 px
    with pytest.raises(
        ValueError,
        match=r"^snap_m: expected at least the waypoint tolerance \(0.05 m\) plus 1.5 pixels",
    ):
        tj.route_graph(m, config=tight)


def test_a_shortcut_spacing_under_a_pixel_is_refused():
    """Anchors closer than a pixel are the anchors of a one-pixel spacing at many times
    the cost (1e-6 m: 42 s and 2.9 GB on the nav2 warehouse): refused before any work,
    while 0 (shortcuts from vertices only) stays."""
    m = tj.load_map(tj.datasets.sample_map_path("intel"), resolution_m=0.05)
    with pytest.raises(
        ValueError,
        match=r"^shortcut_spacing_m: expected 0 \(shortcuts from vertices only\) or at "
        r"least one pixel of the map \(0.05 m\), received 1e-06",
    ):
        tj.route_graph(m, config=tj.RouteGraphConfig(shortcut_spacing_m=1e-6))


def test_a_radius_under_one_and_a_half_pixels_is_refused():
    """Closer to the obstacles than 1.5 pixels a path squeezes between the corners of
    single obstacle pixels (a map's speckle), where no waypoint segment is safe."""
    m = tj.load_map(tj.datasets.sample_map_path("office"))
    res = m.resolution_m
    for radius in (res, 1.4 * res):
        with pytest.raises(
            ValueError, match=r"^robot_radius_m: expected at least 1.5 pixels of the map"
        ):
            route_graph(m, robot_radius_m=radius)
    g = route_graph(m, robot_radius_m=1.5 * res)
    assert tj.evaluate_route_graph(g, m, 1.5 * res, n_pairs=50).unsafe_share == 0.0


def test_a_map_too_coarse_for_any_radius_or_snap_says_so():
    """The least robot radius and the least ``snap_m`` grow with the pixel (1.5 pixels;
    the waypoint tolerance plus 1.5 pixels) and have largest values (1000 m, 5 m): on a
    coarser map no value can do, and the error says the resolution is what is wrong
    rather than ask for a radius or a snap_m that the next call refuses as too large."""
    free = np.zeros((40, 60), bool)
    free[1:-1, 1:-1] = True
    radius = (
        r"its least robot radius, 1\.5 pixels \(15000 m\), is above the largest accepted, "
        r"1000 m; "
    )
    snap = (
        r"its least snap_m, the waypoint tolerance \(0\.1 m\) plus 1\.5 pixels \({} m\), "
        r"is above the largest accepted, 5 m$"
    )
    for res, reasons in ((1e4, radius + snap.format("15000\\.1")), (10.0, snap.format("15\\.1"))):
        m = OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=res)
        expected = (
            rf"^resolution_m: expected at most 3\.26667 m per pixel for a route graph, "
            rf"received {res:g}: {reasons}"
        )
        for radius_m in (0.3, 1000.0):
            with pytest.raises(ValueError, match=expected):
                route_graph(m, config=RouteGraphConfig(robot_radius_m=radius_m, snap_m=5.0))


@pytest.mark.parametrize(
    ("res", "radius", "snap", "tolerance"), [(0.05, 0.075, 0.125, 0.05), (0.1, 0.15, 0.25, 0.1)]
)
def test_exactly_one_and_a_half_pixels_is_enough(res, radius, snap, tolerance):
    """The limits are "at least 1.5 pixels": a radius or a reach of exactly that, as
    typed in metres, is enough, although 0.075 / 0.05 is 1.4999999999999998 in floating
    point (not refused by an error that says it expected 0.075 m and received 0.075)."""
    free = np.zeros((60, 60), bool)
    free[1:-1, 1:-1] = True
    m = OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=res)
    only_radius = RouteGraphConfig(robot_radius_m=radius)
    assert route_graph(m, config=only_radius).number_of_nodes() > 0
    reach = RouteGraphConfig(robot_radius_m=2 * res, snap_m=snap, waypoint_tolerance_m=tolerance)
    assert route_graph(m, config=reach).number_of_nodes() > 0


def test_too_many_shortcut_candidates_are_refused_before_they_fill_memory(monkeypatch):
    """A small ``snap_m`` on a large map makes a dense graph whose node pairs within the
    shortcut radius would take gigabytes: counted first, and refused over the limit."""
    import topojax.routegraph._cover as cover

    m = tj.load_map(tj.datasets.sample_map_path("office"))
    monkeypatch.setattr(cover, "MAX_SHORTCUT_PAIRS", 1000)
    with pytest.raises(ValueError, match=r"^shortcut_radius_m: [\d,]+ pairs of the graph's"):
        route_graph(m, robot_radius_m=0.3)
    assert route_graph(m, robot_radius_m=0.3, config=RouteGraphConfig(shortcut_radius_m=0.0))


def test_a_small_snap_on_a_large_open_map_is_refused_before_the_coverage(monkeypatch):
    """The shortcut pairs of a small ``snap_m`` in a large open space are estimated from
    the feasible space, and a map over the limit is refused before its coverage is built
    (the graph's own count comes only after minutes of coverage on a 200 m hall); the
    limit is lowered here to keep the hall small."""
    import topojax.routegraph.build as build

    m = _map(_room(20, 20))
    assert route_graph(m, robot_radius_m=R, config=RouteGraphConfig(snap_m=0.5)).number_of_edges()
    monkeypatch.setattr(build, "MAX_ESTIMATED_PAIRS", 1_000_000)
    cover_of = build.add_coverage
    shapes = []

    # the estimate's own hall, of PROBE_MIN_PX pixels and the robot's diameter a side
    probe = build.PROBE_MIN_PX + 2 * _px(R)

    def only_small_halls(work, feasible, *args, **kwargs):
        shapes.append(feasible.shape)
        assert max(feasible.shape) <= probe, "the map's coverage was built"
        return cover_of(work, feasible, *args, **kwargs)

    monkeypatch.setattr(build, "add_coverage", only_small_halls)
    with pytest.raises(
        ValueError,
        match=r"^snap_m: 0\.2 leaves an estimated [\d,]+ pairs of vertices and anchors within "
        r"shortcut_radius_m \(5 m\) on the map's [\d,]+ m2 of open feasible space, expected "
        r"at most 1,000,000 .*; use a larger snap_m or a smaller window of the map",
    ):
        route_graph(m, robot_radius_m=R, config=RouteGraphConfig(snap_m=0.2))
    assert shapes == [(probe, probe)]


def test_the_route_graph_command_names_snap_m_when_the_estimate_refuses_it(
    tmp_path, monkeypatch, capsys
):
    import topojax.routegraph.build as build
    from topojax.cli import main

    path = tmp_path / "hall.png"
    cv2.imwrite(str(path), np.where(_room(20, 20), 254, 0).astype(np.uint8))
    monkeypatch.setattr(build, "MAX_ESTIMATED_PAIRS", 1_000_000)
    out = tmp_path / "out"
    assert main(["route-graph", str(path), "-o", str(out), "--snap-m", "0.2"]) == 2
    assert "--snap-m: 0.2 leaves an estimated" in capsys.readouterr().err
    assert not any(out.glob("*_route.json"))


def _pairs_counted(config: RouteGraphConfig, m: OccupancyMap, monkeypatch) -> int:
    """The graph's shortcut candidate pairs, as its count's error gives them."""
    import topojax.routegraph._cover as cover

    monkeypatch.setattr(cover, "MAX_SHORTCUT_PAIRS", 0)
    with pytest.raises(ValueError, match=r"^shortcut_radius_m: [\d,]+ pairs") as err:
        route_graph(m, config=config)
    return int(str(err.value).split()[1].replace(",", ""))


@pytest.mark.parametrize(
    ("snap", "tolerance"),
    [(0.15, 0.075), (0.2, 0.1), (0.2125, 0.1), (0.2, 0.05), (0.3, 0.1), (0.5, 0.1)],
)
def test_the_estimate_of_the_pairs_stays_under_the_graph_s_count(monkeypatch, snap, tolerance):
    """The estimate never refuses a graph whose count passes: at a limit of the graph's
    own count the count's check speaks, not the estimate's, also at reaches where the
    graph's density jumps with the pixels (1.5, 2.25, just under 3 pixels); and it is
    no trivial bound: at a quarter of the count the estimate refuses."""
    import topojax.routegraph._cover as cover
    import topojax.routegraph.build as build

    m = _map(_room(12, 12))
    config = RouteGraphConfig(robot_radius_m=0.2, snap_m=snap, waypoint_tolerance_m=tolerance)
    count = _pairs_counted(config, m, monkeypatch)
    monkeypatch.setattr(cover, "MAX_SHORTCUT_PAIRS", count - 1)
    monkeypatch.setattr(build, "MAX_ESTIMATED_PAIRS", count)
    with pytest.raises(ValueError, match=r"^shortcut_radius_m: "):
        route_graph(m, config=config)
    monkeypatch.setattr(build, "MAX_ESTIMATED_PAIRS", count // 4)
    with pytest.raises(ValueError, match=r"^snap_m: "):
        route_graph(m, config=config)


def test_a_shortcut_radius_beyond_the_map_counts_as_the_whole_map():
    """A shortcut radius beyond the map counts as the whole map:
    ``shortcut_radius_m=1e300`` gives no OverflowError in the bound of the pairs, and
    where the estimate runs (a large map) no OpenCV box filter of the radius's side is
    made (1e7 px would take 2.7 GB, 1e8 px fail with OpenCV's ``bad_alloc`` and 1e9 px
    exhaust the memory).  A box of twice the map's size holds the whole map already."""
    from topojax.routegraph._cover import estimated_pairs

    m = _map(_room(12, 12))
    whole = route_graph(m, config=RouteGraphConfig(shortcut_radius_m=100.0))
    far = route_graph(m, config=RouteGraphConfig(shortcut_radius_m=1e300))
    assert sorted(far.edges()) == sorted(whole.edges())
    open_ = np.zeros((40, 50), bool)
    open_[5:30, 3:45] = True
    assert estimated_pairs(open_, 0.1, 1e300) == estimated_pairs(open_, 0.1, 60.0)
    # a radius in pixels can be infinite (1e306 m at 1e-3 m per pixel)
    assert estimated_pairs(open_, 0.1, math.inf) == estimated_pairs(open_, 0.1, 60.0)


@pytest.mark.parametrize("hold_max_px", [0, 1 << 22])
def test_clearances_are_the_feasible_space_s_at_the_graph_s_pixels(monkeypatch, hold_max_px):
    """The graph is built in a window of the map (here off its corner, beside a region
    too small to keep): its clearance attributes are the map's, at the map's pixels,
    whether the window's clearance is held for the assembly or computed again there."""
    import topojax.routegraph.build as build

    monkeypatch.setattr(build, "HOLD_CLEARANCE_MAX_PX", hold_max_px)
    free = np.zeros((300, 260), bool)
    free[60:200, 90:230] = True  # the room, in the middle of the map
    free[100:150, 150:160] = False  # a pillar
    free[230:250, 20:40] = True  # a region of under 1 m2 for the robot
    occ = _map(free)
    g = route_graph(occ, robot_radius_m=R)
    space = feasible_space(occ, R)
    assert g.number_of_edges() > 0
    for _, d in g.nodes(data=True):
        assert d["clearance_m"] == float(space.clearance_m[d["pixel"]])
    for _, _, d in g.edges(data=True):
        along = space.clearance_m[d["path"][:, 0], d["path"][:, 1]].astype(np.float64)
        assert d["min_clearance_m"] == along.min()
        assert d["mean_clearance_m"] == pytest.approx(along.mean(), rel=1e-12)
    _assert_safe(g, occ)


def _traced_peak_growth(call):
    """``call()``'s result and the growth (bytes) of traced memory at its peak."""
    import tracemalloc

    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        out = call()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return out, peak - base


def test_traced_peak_per_pixel_is_bounded(monkeypatch):
    """route_graph keeps few image-sized arrays at once: the map-sized arrays of the
    feasible space are dropped once the window is cut out, and a large window's
    clearance is not held through the coverage stage (this plan's window is made to
    count as large).  NumPy's buffers are traced (not OpenCV's work space or numba's)."""
    from floorplans import floor_plan

    import topojax.routegraph.build as build

    monkeypatch.setattr(build, "HOLD_CLEARANCE_MAX_PX", 0)
    plan = floor_plan(7, size_m=(48.0, 48.0), clutter=1).occupancy  # about 1000 x 1000 px
    route_graph(plan, robot_radius_m=R)  # compiled kernels
    g, growth = _traced_peak_growth(lambda: route_graph(plan, robot_radius_m=R))
    assert g.number_of_edges() > 0
    per_pixel = growth / plan.free.size
    assert per_pixel <= 26.0, f"{per_pixel:.1f} bytes per pixel"


def test_shortcut_candidates_take_memory_by_the_block_not_by_their_number(monkeypatch):
    """A small ``snap_m`` makes a dense graph whose node pairs within the shortcut
    radius run to tens of millions on a large map: past ``PAIRS_AT_ONCE`` they are
    listed a block at a time, and only those with a clear line kept, so the traced peak
    stays far below the pairs' own size (here the limits are lowered to fit a small
    plan).  Without blocks it would be over 100 bytes a pair.  NumPy's buffers are
    traced."""
    from floorplans import floor_plan
    from scipy.spatial import cKDTree

    import topojax.routegraph._cover as cover

    monkeypatch.setattr(cover, "PAIRS_AT_ONCE", 10_000, raising=False)
    monkeypatch.setattr(cover, "PAIRS_PER_BLOCK", 10_000, raising=False)
    seen = []

    class Counted(cKDTree):
        def count_neighbors(self, other, r, *args, **kwargs):
            n = super().count_neighbors(other, r, *args, **kwargs)
            seen.append((int(n) - self.n) // 2)
            return n

    monkeypatch.setattr(cover, "cKDTree", Counted)
    plan = floor_plan(7, size_m=(12.0, 12.0), clutter=1).occupancy
    cfg = RouteGraphConfig(snap_m=0.2)
    route_graph(plan, config=cfg)  # compiled kernels
    seen.clear()
    g, growth = _traced_peak_growth(lambda: route_graph(plan, config=cfg))
    n_pairs = max(seen)
    assert n_pairs > 50 * 10_000  # many blocks
    assert g.number_of_edges() > 0
    per_pair = growth / n_pairs
    assert per_pair <= 30.0, f"{per_pair:.1f} bytes per candidate pair ({n_pairs:,} pairs)"


def test_shortcut_candidates_in_blocks_give_the_graph_listed_at_once(monkeypatch):
    """The candidates are sorted by their ends however they were listed, so the greedy
    pass meets those of equal length in the same order and the graph is the same."""
    from floorplans import floor_plan

    import topojax.routegraph._cover as cover

    plan = floor_plan(5, size_m=(10.0, 8.0), clutter=1).occupancy
    cfg = RouteGraphConfig(snap_m=0.3)  # ties among thousands of candidates
    at_once = route_graph(plan, config=cfg)
    monkeypatch.setattr(cover, "PAIRS_AT_ONCE", 1_000)
    monkeypatch.setattr(cover, "PAIRS_PER_BLOCK", 1_000)
    in_blocks = route_graph(plan, config=cfg)
    assert at_once.number_of_edges() > 50
    assert sorted(at_once.nodes(data="pixel")) == sorted(in_blocks.nodes(data="pixel"))
    paths = [
        sorted(np.asarray(p).tobytes() for *_, p in g.edges(data="path"))
        for g in (at_once, in_blocks)
    ]
    assert paths[0] == paths[1]


@pytest.mark.parametrize(
    ("res", "radius_m", "side"), [(0.03, 0.33, 21), (0.02, 0.2, 19), (RES, R, 11)]
)
def test_a_robot_as_wide_as_the_clearance_fits_at_any_resolution(res, radius_m, side):
    # the centre of a free square with the map's border round it is side // 2 + 1 pixels
    # from the nearest pixel that is not free, exactly radius_m; 11 x 0.03 m rounds below
    # 0.33 m in float32 and in float64, 10 x 0.02 m below 0.2 m in float32
    free = np.ones((side, side), bool)
    occ = OccupancyMap(occupied=~free, free=free, unknown=~free, resolution_m=res)
    space = feasible_space(occ, radius_m)
    c = side // 2
    assert (side // 2 + 1) * res == pytest.approx(radius_m)
    assert space.feasible[c, c] and space.feasible.sum() == 1


@pytest.mark.parametrize("name", ["lab_c_scan", "lab_f_scan_furnitures"])
def test_merged_vertices_leave_every_pixel_covered_to_the_reach(shared_data, name):
    """Merging close vertices drops the short edge between them, and contracting a merged
    vertex drops its member pixels: on these maps a corner pixel or a few were then seen
    only at 0.92 m, past ``snap_m - waypoint_tolerance_m`` (0.9 m), until covered again."""
    from topojax.routegraph._cover import covered

    occ = tj.load_map(shared_data / "maps" / "ipa" / f"{name}.png", mode="ipa")
    g = route_graph(occ, robot_radius_m=R)
    space = feasible_space(occ, R)
    kept = np.isin(space.labels, space.regions_at_least(1.0))
    raster = np.zeros(occ.shape, bool)
    pix = _graph_pixels(g)
    raster[pix[:, 0], pix[:, 1]] = True
    reach_px = (g.graph["snap_m"] - 0.1) / occ.resolution_m
    seen = covered(raster, space.feasible, reach_px)
    assert not np.argwhere(kept & ~seen).tolist()
