"""Route graphs for the ROS 2 Nav2 Route Server (topojax.save_nav2_graph).

Checked against what nav2_route reads (GeoJSON Point nodes with ``id`` and ``frame``,
directed MultiLineString edges with ``id``, ``startid``, ``endid``; ids unique over nodes
and edges) and against the topojax graph it came from: the same vertices and degrees once
the waypoint chains are contracted, every corridor pixel within the tolerance of its
chain, and the chains' ``length_m`` adding up to the corridor's.
"""

from __future__ import annotations

import json
from collections import Counter, defaultdict

import networkx as nx
import numpy as np
import pytest
from brute_force import distance_to_polyline

import topojax as tj
from topojax.graph import skeleton_to_graph


def art(text: str) -> np.ndarray:
    rows = [line.strip() for line in text.strip().splitlines()]
    return np.array([[ch == "#" for ch in r] for r in rows], dtype=bool)


def no_nulls(value, where="") -> None:
    """nav2_route's loader converts numbers, bools, strings, arrays and objects only."""
    assert value is not None, f"null at {where}"
    if isinstance(value, dict):
        for k, v in value.items():
            no_nulls(v, f"{where}.{k}")
    elif isinstance(value, list):
        for i, v in enumerate(value):
            no_nulls(v, f"{where}[{i}]")


def read_nav2(path):
    doc = json.loads(path.read_text())
    no_nulls(doc)
    assert doc["type"] == "FeatureCollection"
    nodes, edges = {}, []
    for f in doc["features"]:
        assert f["type"] == "Feature"
        props, geom = f["properties"], f["geometry"]
        if geom["type"] == "Point":
            assert isinstance(props["id"], int) and props["frame"] == "map"
            nodes[props["id"]] = (tuple(geom["coordinates"]), props["metadata"])
        else:
            assert geom["type"] == "MultiLineString"
            edges.append(props | {"coordinates": geom["coordinates"]})
    ids = list(nodes) + [e["id"] for e in edges]
    assert len(ids) == len(set(ids)), "ids must be unique over nodes and edges"
    return nodes, edges


def check_against_graph(g: nx.MultiGraph, path, tol: float) -> None:
    nodes, edges = read_nav2(path)
    # every edge has its reverse, and its geometry joins its two nodes
    directed = Counter((e["startid"], e["endid"]) for e in edges)
    for (a, b), n in directed.items():
        assert directed[(b, a)] == n
    for e in edges:
        (p0, p1) = e["coordinates"][0]
        assert tuple(p0) == nodes[e["startid"]][0] and tuple(p1) == nodes[e["endid"]][0]
        assert e["startid"] != e["endid"]
    # vertices with edges: ids 0..V-1 in node order, same positions and degrees once the
    # waypoint chains are contracted (one undirected edge per pair of directed ones);
    # vertices without edges lead nowhere and are left out
    order = [n for n in g.nodes if g.degree(n)]
    und = nx.MultiGraph()
    und.add_nodes_from(nodes)
    for e in edges:
        if e["startid"] < e["endid"]:
            und.add_edge(e["startid"], e["endid"])
    for i, n in enumerate(order):
        assert nodes[i][1]["vertex"] == n and nodes[i][1]["kind"] == g.nodes[n]["kind"]
        assert nodes[i][0] == pytest.approx(g.nodes[n]["world"])
        assert und.degree(i) == g.degree(n)
    for i in range(len(order), len(nodes)):
        assert nodes[i][1]["kind"] == "waypoint" and und.degree(i) == 2
    # each corridor: a chain within tol of every pixel, with its whole length
    chains = defaultdict(list)
    for e in edges:
        if e["startid"] < e["endid"]:
            chains[tuple(e["metadata"]["corridor"])].append(e)
    assert len(chains) == g.number_of_edges()
    for (u, v, k), segs in chains.items():
        d = g.edges[u, v, k]
        assert sum(s["metadata"]["length_m"] for s in segs) == pytest.approx(d["length_m"])
        pts = np.array(
            [nodes[s["startid"]][0] for s in segs] + [nodes[s["endid"]][0] for s in segs]
        )
        world = np.asarray(d["world"], float)
        # the chain's points lie on the corridor, and the corridor lies near the chain
        on = np.hypot(*(pts[:, None, :] - world[None, :, :]).transpose(2, 0, 1)).min(axis=1)
        assert on.max() < 1e-9
        assert distance_to_polyline(world, chain_of(segs, nodes)).max() <= tol + 1e-12


def chain_of(segs, nodes) -> np.ndarray:
    """The waypoints of one corridor in order (its segments joined end to end)."""
    nxt = {}
    for s in segs:
        nxt.setdefault(s["startid"], []).append(s["endid"])
        nxt.setdefault(s["endid"], []).append(s["startid"])
    ends = [n for n, m in nxt.items() if len(m) == 1]
    start = ends[0] if ends else segs[0]["startid"]  # a loop: any point
    order, prev, cur = [start], None, start
    for _ in range(len(segs)):
        step = [m for m in nxt[cur] if m != prev] or nxt[cur]
        prev, cur = cur, step[0]
        order.append(cur)
    return np.array([nodes[i][0] for i in order], float)


@pytest.mark.parametrize("tol", [0.05, 0.1, 0.5])
def test_intel_route_graph_matches_the_topology_graph(tmp_path, tol):
    g = tj.prune_graph(tj.build_graph(tj.sample_map("intel")).graph, min_spur_m=0.5)
    path = tj.save_nav2_graph(g, tmp_path / "intel_nav2.geojson", tolerance_m=tol)
    check_against_graph(g, path, tol)


def test_full_paper_graph_with_rings_and_loops(tmp_path):
    g = tj.build_graph(tj.sample_map("intel")).graph  # the paper's graph: a ring, specks
    assert any(u == v for u, v in g.edges())
    assert any(g.degree(n) == 0 for n in g.nodes)  # lone pixels: no node of the file
    path = tj.save_nav2_graph(g, tmp_path / "intel.geojson")
    check_against_graph(g, path, 0.1)


def test_fixture_ring_and_loop_get_two_waypoints_at_least(tmp_path):
    skel = art(
        """
        .#####..........
        #.....#.........
        #.....#.........
        .#####..###.....
        ..........#.....
        .......####.....
        """
    )
    g = skeleton_to_graph(skel, resolution_m=1.0)
    assert {d["kind"] for _, d in g.nodes(data=True)} >= {"ring"}
    path = tj.save_nav2_graph(g, tmp_path / "ring.geojson", tolerance_m=50.0)
    check_against_graph(g, path, 50.0)
    nodes, edges = read_nav2(path)
    ring = next(i for i, (_, m) in nodes.items() if m.get("kind") == "ring")
    loop = [e for e in edges if ring in (e["startid"], e["endid"])]
    assert len(loop) == 4  # two segments of the loop, both ways


@pytest.mark.parametrize("seed", range(8))
def test_merged_clusters_keep_the_tolerance_and_write_no_degenerate_edges(tmp_path, seed):
    """With merged junction clusters a path may end at another pixel of its vertex than
    the vertex's own: the chain runs node to node, so that hop is part of it (else
    corridor pixels would lie outside the tolerance), and a small loop still gets two
    distinct waypoints or, if it has none to give, is left out (not written as a
    node-to-itself edge)."""
    from skimage.morphology import skeletonize

    rng = np.random.default_rng(seed)
    skel = skeletonize(rng.random((40, 40)) < 0.45)
    if seed == 0:  # the two shapes found by fuzzing
        skel = np.zeros((5, 5), bool)
        skel[1:4, 1:4] = True
        skel[0, 2] = skel[4, 2] = True
    elif seed == 1:
        skel = art("..##..\n..##..\n..##..\n.#....")
    g = skeleton_to_graph(skel, resolution_m=1.0, merge_junction_clusters=True)
    if g.number_of_edges() == 0:
        pytest.skip("no edges")
    for tol in (0.5, 1.0):
        nodes, edges = read_nav2(tj.save_nav2_graph(g, tmp_path / "m.geojson", tolerance_m=tol))
        chains = defaultdict(list)
        for e in edges:
            assert e["startid"] != e["endid"]
            (p0, p1) = e["coordinates"][0]
            assert tuple(p0) == nodes[e["startid"]][0] and tuple(p1) == nodes[e["endid"]][0]
            if e["startid"] < e["endid"]:
                chains[tuple(e["metadata"]["corridor"])].append(e)
        # the loops of a merged cluster may share a hop: it is written once, under one
        pairs = Counter((e["startid"], e["endid"]) for e in edges)
        assert max(pairs.values()) == 1
        hops = [np.array([nodes[e["startid"]][0], nodes[e["endid"]][0]], float) for e in edges]
        for u, v, k, d in g.edges(keys=True, data=True):
            world = np.asarray(d["world"], float)
            if (u, v, k) not in chains and u == v and len(d["path"]) <= 3:
                continue  # a loop with no pixel to place two waypoints on
            # its own hops, or a shared one written under a corridor of the same vertex
            own = [
                h
                for e, h in zip(edges, hops, strict=True)
                if {u, v} & {*e["metadata"]["corridor"][:2]}
            ]
            near = np.min([distance_to_polyline(world, hop) for hop in own], axis=0)
            assert near.max() <= tol + 1e-12


def test_a_graph_of_point_loops_only_is_refused(tmp_path):
    g = nx.MultiGraph()
    g.add_node(0, world=(0.0, 0.0), pixel=(0, 0), kind="ring")
    g.add_edge(0, 0, world=np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0]]), length_m=2.0)
    with pytest.raises(ValueError, match="rejects a graph without edges"):
        tj.save_nav2_graph(g, tmp_path / "loop.geojson")
    assert not (tmp_path / "loop.geojson").exists()


def test_smaller_tolerance_means_more_waypoints(tmp_path):
    g = tj.build_graph(tj.sample_map("intel")).graph
    counts = []
    for tol in (1.0, 0.2, 0.05):
        nodes, _ = read_nav2(tj.save_nav2_graph(g, tmp_path / f"{tol}.geojson", tolerance_m=tol))
        counts.append(len(nodes))
    assert counts[0] < counts[1] < counts[2]


def test_graphs_without_clearances_write_strict_json(tmp_path):
    g = skeleton_to_graph(art("#####\n..#..\n..#.."), resolution_m=0.5)
    del g.nodes[0]["kind"]  # missing attributes are left out, not written as null
    # as are those no nav2_route metadata value holds: None, NaN, infinity
    g.nodes[1].update(kind=None, clearance_m=float("nan"))
    g.nodes[2].update(clearance_m=float("inf"))
    path = tj.save_nav2_graph(g, tmp_path / "g.geojson", frame="odom")
    text = path.read_text()
    assert "NaN" not in text and "Infinity" not in text
    doc = json.loads(text)
    no_nulls(doc)
    metadata = [f["properties"]["metadata"] for f in doc["features"][:3]]
    assert "kind" not in metadata[0] and "kind" not in metadata[1]
    assert "clearance_m" not in metadata[1] and "clearance_m" not in metadata[2]
    assert {
        f["properties"].get("frame") for f in doc["features"] if "frame" in f["properties"]
    } == {"odom"}


def test_command_writes_the_nav2_graph(tmp_path):
    from topojax.cli import main

    png = tj.datasets.sample_map_path("intel")
    argv = ["graph", str(png), "--resolution", "0.05", "-o", str(tmp_path), "--nav2"]
    assert main([*argv, "--min-spur-m", "0.5", "--nav2-tolerance-m", "0.2"]) == 0
    out = tmp_path / "intel_nav2.geojson"
    nodes, edges = read_nav2(out)
    assert nodes and edges


def test_command_checks_the_tolerance_first_and_notes_a_graph_without_edges(tmp_path, capsys):
    import cv2

    from topojax.cli import main

    png = tj.datasets.sample_map_path("intel")
    bad = ["graph", str(png), "-o", str(tmp_path / "bad"), "--nav2", "--nav2-tolerance-m", "0"]
    assert main(bad) == 2
    assert "--nav2-tolerance-m: expected" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()  # nothing written before the check
    # a tolerance without --nav2 would be ignored: refused
    assert main([*bad[:-3], "--nav2-tolerance-m", "0.5"]) == 2
    assert "--nav2-tolerance-m: only used with --nav2" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()
    empty = tmp_path / "empty.png"
    cv2.imwrite(str(empty), np.full((40, 50), 254, np.uint8))  # free, no obstacle
    assert main(["graph", str(empty), "-o", str(tmp_path / "e"), "--nav2"]) == 0
    out = capsys.readouterr().out
    assert "empty_nav2.geojson not written" in out and "no edges" in out
    assert (tmp_path / "e" / "empty.json").is_file()
    assert not (tmp_path / "e" / "empty_nav2.geojson").exists()


def test_a_rerun_whose_graph_has_no_edges_leaves_no_nav2_file_of_the_run_before(tmp_path, capsys):
    """``graph --nav2`` run again on the same map with options that leave no edge says
    the Nav2 file is not written: the one of the run before goes too, or it would stand
    beside a graph it no longer matches (as ``route-graph --nav2`` and the batch do)."""
    import cv2

    from topojax.cli import main

    free = np.full((40, 60), 254, np.uint8)
    free[[0, -1], :] = free[:, [0, -1]] = 0
    free[15:25, 20:40] = 0
    png = tmp_path / "room.png"
    cv2.imwrite(str(png), free)
    argv = ["graph", str(png), "-o", str(tmp_path / "out"), "--nav2"]
    assert main(argv) == 0
    nav2 = tmp_path / "out" / "room_nav2.geojson"
    assert nav2.is_file()
    capsys.readouterr()
    assert main([*argv, "--min-component-m", "1000"]) == 0  # every piece removed
    assert "room_nav2.geojson not written" in capsys.readouterr().out
    assert tj.load_graph(tmp_path / "out" / "room.json").number_of_edges() == 0
    assert not nav2.exists()


@pytest.mark.parametrize(
    "kwargs, exc, words",
    [
        ({"tolerance_m": 0.0}, ValueError, ["tolerance_m", "> 0", "0.0"]),
        ({"tolerance_m": float("nan")}, ValueError, ["tolerance_m", "nan"]),
        ({"tolerance_m": True}, TypeError, ["tolerance_m", "True"]),
        ({"tolerance_m": "0.1"}, TypeError, ["tolerance_m", "'0.1'"]),
        ({"frame": ""}, ValueError, ["frame", "non-empty"]),
        ({"frame": 3}, TypeError, ["frame", "non-empty string", "int"]),
        ({"frame": "ma\x00p"}, ValueError, ["frame: ", "no control character", r"'ma\x00p'"]),
        ({"frame": "map\n"}, ValueError, ["frame: ", "no control character", r"'map\n'"]),
    ],
)
def test_bad_input(tmp_path, kwargs, exc, words):
    g = skeleton_to_graph(art("###"), resolution_m=1.0)
    with pytest.raises(exc) as info:
        tj.save_nav2_graph(g, tmp_path / "x.geojson", **kwargs)
    for word in words:
        assert word in str(info.value)
    bare = nx.MultiGraph()
    bare.add_edge(0, 1, world=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="node 0 has no 'world'"):
        tj.save_nav2_graph(bare, tmp_path / "y.geojson")
    for path in ("here", np.array([[np.nan, 1.0]])):  # named, not left to fail in int()
        marked = skeleton_to_graph(art("###"), resolution_m=1.0)
        marked.edges[0, 1, 0]["path"] = path
        with pytest.raises((TypeError, ValueError), match=r"^graph: edge \(0, 1\): 'path'"):
            tj.save_nav2_graph(marked, tmp_path / "p.geojson")
    for waypoints in ("here", [[0.0, 0.0], [1.0]], [[0.0, 0.0]], [[0.0, 0.0], [np.nan, 1.0]]):
        marked = skeleton_to_graph(art("###"), resolution_m=1.0)
        marked.edges[0, 1, 0]["waypoints"] = waypoints
        words = r"^graph: edge \(0, 1, 0\) 'waypoints': expected finite \(x, y\) points"
        with pytest.raises(ValueError, match=words):
            tj.save_nav2_graph(marked, tmp_path / "w.geojson")
    lonely = skeleton_to_graph(art("#.#"), resolution_m=1.0)  # two isolated pixels
    with pytest.raises(ValueError, match="2 vertices and no edges"):
        tj.save_nav2_graph(lonely, tmp_path / "z.geojson")
    assert not (tmp_path / "x.geojson").exists()


def test_a_route_graph_is_written_along_its_waypoints_and_stays_safe(tmp_path):
    """A route graph's edges go out as their ``waypoints`` (not re-simplified pixel
    paths), so every straight hop a robot drives keeps the radius from the walls."""
    m = tj.load_map(tj.datasets.sample_map_path("office"))
    rg = tj.route_graph(m, robot_radius_m=0.3)
    path = tj.save_nav2_graph(rg, tmp_path / "route.geojson", tolerance_m=0.5)
    nodes, edges = read_nav2(path)
    n_inner = sum(len(d["waypoints"]) - 2 for _, _, d in rg.edges(data=True))
    # a waypoint where an edge crosses another or passes a vertex without meeting it is
    # the node already there: no two nodes at one point, which the Route Server would
    # hold unconnected
    points = {tuple(map(float, rg.nodes[n]["world"])) for n in rg}
    points |= {tuple(p) for *_, d in rg.edges(data=True) for p in d["waypoints"][1:-1].tolist()}
    assert len({xy for xy, _ in nodes.values()}) == len(nodes) == len(points)
    assert len(nodes) < rg.number_of_nodes() + n_inner  # there are such waypoints here
    written = {tuple(sorted((e["startid"], e["endid"]))) for e in edges}
    assert len(edges) == 2 * len(written)  # one hop each way between two nodes
    assert len(written) < sum(len(d["waypoints"]) - 1 for _, _, d in rg.edges(data=True))
    hops = nx.Graph()
    for e in edges:
        a, b = e["startid"], e["endid"]
        hops.add_node(a, world=nodes[a][0][:2])
        hops.add_node(b, world=nodes[b][0][:2])
        hops.add_edge(a, b)
    report = tj.evaluate_route_graph(hops, m, robot_radius_m=0.3)
    assert report.unsafe_share == 0.0 and report.success_rate == 1.0


def test_waypoints_that_do_not_run_between_their_vertices_are_refused(tmp_path):
    """The vertices are written in place of an edge's first and last waypoint: hand-edited
    waypoints ending elsewhere were written as a chain they do not describe, without a
    word.  Waypoints stored from ``v`` to ``u`` go out in the edge's own order."""
    free = np.zeros((84, 124), bool)  # a 4 x 6 m room with a 1 m pillar, 0.05 m a pixel
    free[2:82, 2:122] = True
    free[32:52, 52:72] = False
    m = tj.OccupancyMap.from_array(~free, resolution_m=0.05)
    rg = tj.route_graph(m, robot_radius_m=0.3)
    want = tj.save_nav2_graph(rg, tmp_path / "want.geojson").read_text()
    _, (u, v, k) = max(  # the edge with the most waypoints between its ends
        (len(d["waypoints"]), (u, v, k)) for u, v, k, d in rg.edges(keys=True, data=True) if u != v
    )
    d = rg.edges[u, v, k]
    assert len(d["waypoints"]) > 3
    # a polyline stored the other way round is the same corridor
    d["waypoints"] = d["waypoints"][::-1].copy()
    assert tj.save_nav2_graph(rg, tmp_path / "back.geojson").read_text() == want
    # an end off its vertex by less than tolerance_m (0.1 m) is the vertex
    d["waypoints"] = d["waypoints"][::-1].copy()
    d["waypoints"][0] += [0.03, 0.0]
    assert tj.save_nav2_graph(rg, tmp_path / "near.geojson").read_text() == want
    d["waypoints"] = np.array([[0.0, 0.0], [1.0, 1.0]])
    words = (
        rf"^graph: edge \({u!r}, {v!r}, {k!r}\) 'waypoints': expected a polyline from "
        rf"vertex ({u!r}|{v!r})'s 'world' \[.+\] to vertex ({u!r}|{v!r})'s \[.+\] \(or "
        r"back\), each end "
        r"within tolerance_m=0.1 m, received one from \[0.0, 0.0\] to \[1.0, 1.0\]$"
    )
    with pytest.raises(ValueError, match=words) as err:
        tj.save_nav2_graph(rg, tmp_path / "bad.geojson")
    for n in (u, v):  # where the ends were expected
        assert str(list(map(float, rg.nodes[n]["world"]))) in str(err.value)
    assert not (tmp_path / "bad.geojson").exists()


def test_waypoints_at_one_point_are_one_node_that_keeps_all_their_edges(tmp_path):
    """Route-graph edges may cross, or pass a vertex, without meeting it: a waypoint of one
    edge then lies where a waypoint or vertex of another lies.  Written as two nodes, the
    Route Server would hold two unconnected nodes at one point; they are one node, with
    every edge of both, and no edge from a node to itself."""
    g = nx.MultiGraph()
    for n, xy in enumerate([(0, 0), (4, 0), (2, -2), (2, 3), (2, 2), (4, 2)]):
        g.add_node(n, world=(float(xy[0]), float(xy[1])), kind="end")
    ways = {
        (0, 1): [(0, 0), (2, 0), (4, 0)],
        (2, 3): [(2, -2), (2, 0), (2, 2), (2, 3)],  # crosses (0, 1) at (2, 0), passes 4
        (4, 5): [(2, 2), (2, 2), (4, 2)],  # a waypoint on its own vertex
    }
    for (u, v), w in ways.items():
        w = np.array(w, float)
        g.add_edge(u, v, world=w, waypoints=w, length_m=float(np.hypot(*np.diff(w.T)).sum()))
    nodes, edges = read_nav2(tj.save_nav2_graph(g, tmp_path / "x.geojson"))
    assert sorted(nodes) == list(range(7))  # the six vertices and one waypoint, (2, 0)
    assert [nodes[i][1]["vertex"] for i in range(6)] == list(range(6))
    assert len({xy for xy, _ in nodes.values()}) == len(nodes)
    assert sorted(e["id"] for e in edges) == list(range(7, 7 + len(edges)))
    hops = Counter((e["startid"], e["endid"]) for e in edges)
    both = {(a, b) for a, b in [(0, 6), (6, 1), (2, 6), (6, 4), (4, 3), (4, 5)]}
    assert hops == Counter(both | {(b, a) for a, b in both})
    for e in edges:
        (p0, p1) = e["coordinates"][0]
        assert tuple(p0) == nodes[e["startid"]][0] and tuple(p1) == nodes[e["endid"]][0]
        assert p0 != p1
    # a vertex at another's place is that one's node
    g.add_node(6, world=(4.0, 0.0), kind="end")
    w = np.array([(4.0, 0.0), (2.0, 3.0)])
    g.add_edge(6, 3, world=w, waypoints=w, length_m=float(np.hypot(*np.diff(w.T)).sum()))
    nodes, edges = read_nav2(tj.save_nav2_graph(g, tmp_path / "x.geojson"))
    assert sorted(nodes) == list(range(7)) and nodes[1][1]["vertex"] == 1
    assert Counter((e["startid"], e["endid"]) for e in edges)[(1, 3)] == 1


def test_a_hop_two_corridors_share_is_written_once_with_the_shorter_corridor(tmp_path):
    """Two corridors whose chains run between the same two nodes (parallel edges that
    simplify to one straight hop, or corridors that share a stretch) would give the Route
    Server two edges with one start and end: it drives the same straight line along
    either.  The hop is written once each way, with the shorter corridor's metadata."""
    g = nx.MultiGraph()
    g.add_node("a", world=(0.0, 0.0), kind="junction")
    g.add_node("b", world=(2.0, 0.0), kind="junction")
    bent = np.array([(0.0, 0.0), (1.0, 0.05), (2.0, 0.0)])  # within 0.1 m of the straight
    straight = np.array([(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)])
    for w in (bent, straight):
        g.add_edge("a", "b", world=w, length_m=float(np.hypot(*np.diff(w.T)).sum()))
    nodes, edges = read_nav2(tj.save_nav2_graph(g, tmp_path / "x.geojson", tolerance_m=0.1))
    assert sorted(nodes) == [0, 1]
    assert sorted((e["startid"], e["endid"]) for e in edges) == [(0, 1), (1, 0)]
    assert [e["metadata"]["corridor"] for e in edges] == [["a", "b", 1]] * 2
    assert [e["metadata"]["length_m"] for e in edges] == [2.0, 2.0]
    assert sorted(e["id"] for e in edges) == [2, 3]


def test_a_real_route_graph_has_one_edge_per_directed_pair_of_nodes(tmp_path, shared_data):
    """The PAL office's route graph has corridors that share a stretch (four hops)."""
    m = tj.load_map(shared_data / "maps" / "ros" / "pal_office_7th_floor" / "map.yaml")
    nodes, edges = read_nav2(
        tj.save_nav2_graph(tj.route_graph(m, robot_radius_m=0.3), tmp_path / "pal.geojson")
    )
    pairs = Counter((e["startid"], e["endid"]) for e in edges)
    assert max(pairs.values()) == 1


def nav2_loadable_metadata(value, where="metadata") -> None:
    """What nav2_route's GeoJSON loader converts: objects (recursively), numbers, bools,
    strings and arrays of those three; an array holding an array or object fails it."""
    if isinstance(value, dict):
        for k, v in value.items():
            nav2_loadable_metadata(v, f"{where}.{k}")
    elif isinstance(value, list):
        for i, v in enumerate(value):
            assert isinstance(v, (bool, int, float, str)), f"{where}[{i}] is {v!r}"
    else:
        assert isinstance(value, (bool, int, float, str)), f"{where} is {value!r}"


def test_node_ids_that_are_tuples_are_written_as_text_the_loader_reads(tmp_path):
    """Node ids of other tools' graphs may be tuples (networkx's grid graphs use
    ``(row, col)``).  A node id or edge key that is not a number or string is written as
    its JSON text, not as an array (``corridor`` as ``[[0, 0], [0, 2], 0]``, an array of
    arrays), which nav2_route's loader refuses ("Failed to convert"), so that the whole
    graph fails to load."""
    g = skeleton_to_graph(art("#####\n..#..\n..#.."), resolution_m=0.5)
    pixel_ids = {n: tuple(int(v) for v in d["pixel"]) for n, d in g.nodes(data=True)}
    g = nx.relabel_nodes(g, pixel_ids)
    nodes, edges = read_nav2(tj.save_nav2_graph(g, tmp_path / "g.geojson"))
    for _, meta in nodes.values():
        nav2_loadable_metadata(meta)
    for e in edges:
        nav2_loadable_metadata(e["metadata"])
    vertices = {meta["vertex"] for _, meta in nodes.values() if "vertex" in meta}
    assert vertices == {json.dumps(list(p)) for p in pixel_ids.values()}
    u, v, k = edges[0]["metadata"]["corridor"]
    assert g.has_edge(tuple(json.loads(u)), tuple(json.loads(v)), k)


@pytest.mark.parametrize(
    "ids, words",
    [
        ({0: float("nan")}, r"^graph: node id: expected .* without NaN or infinity .*nan"),
        ({0: (0, float("inf"))}, r"^graph: node id: expected .* received \(0, inf\)"),
        ({0: object()}, r"^graph: node id: values of type object cannot be saved"),
    ],
)
def test_node_ids_strict_json_cannot_hold_are_refused_by_name(tmp_path, ids, words):
    """A NaN or an infinity in a node id is refused naming the node, not by the JSON
    writer's own message ("Out of range float values are not JSON compliant")."""
    g = nx.relabel_nodes(skeleton_to_graph(art("###"), resolution_m=1.0), ids)
    with pytest.raises((TypeError, ValueError), match=words):
        tj.save_nav2_graph(g, tmp_path / "x.geojson")
    assert not (tmp_path / "x.geojson").exists()


def test_a_vertex_position_that_is_not_a_pair_names_the_graph(tmp_path):
    g = skeleton_to_graph(art("###"), resolution_m=1.0)
    g.nodes[0]["world"] = (1.0, 2.0, 3.0)
    with pytest.raises(ValueError, match=r"^graph: node 0 'world': expected 2 finite numbers"):
        tj.save_nav2_graph(g, tmp_path / "x.geojson")


def test_an_empty_route_graph_is_refused_with_why_it_is_empty(tmp_path):
    import warnings

    m = tj.OccupancyMap.from_array(np.full((40, 40), 205, np.uint8), resolution_m=0.05)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rg = tj.route_graph(m, robot_radius_m=0.3)
    with pytest.raises(ValueError, match="rejects a graph without edges") as err:
        tj.save_nav2_graph(rg, tmp_path / "empty.geojson")
    assert f"({rg.graph['note']})" in str(err.value)
    assert not (tmp_path / "empty.geojson").exists()


def test_a_vertex_whose_only_edge_is_a_loop_left_out_is_left_out_too(tmp_path):
    """A loop with no room for two waypoints is left out; its vertex, with no other edge,
    was still written, a node that leads nowhere, where a route server that joins a pose
    at the nearest node finds no route."""
    g = nx.MultiGraph()
    g.add_node(0, world=(0.0, 0.0), pixel=(10, 0), kind="end")
    g.add_node(1, world=(1.0, 0.0), pixel=(10, 20), kind="end")
    g.add_node(2, world=(5.0, 5.0), pixel=(0, 100), kind="ring")
    g.add_edge(0, 1, world=np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]), length_m=1.0)
    g.add_edge(2, 2, world=np.array([[5.0, 5.0], [5.05, 5.0], [5.0, 5.0]]), length_m=0.1)
    path = tj.save_nav2_graph(g, tmp_path / "g.geojson")
    features = json.loads(path.read_text())["features"]
    nodes = [f["properties"] for f in features if f["geometry"]["type"] == "Point"]
    assert [p["metadata"]["vertex"] for p in nodes] == [0, 1]
    assert [p["id"] for p in nodes] == [0, 1]
    ends = {
        p[k]
        for f in features
        if (p := f["properties"]).get("startid") is not None
        for k in ("startid", "endid")
    }
    assert ends == {0, 1}
    # the same with a route graph's waypoints: a loop of one waypoint
    g.edges[2, 2, 0]["waypoints"] = np.array([[5.0, 5.0], [5.05, 5.0], [5.0, 5.0]])
    g.edges[0, 1, 0]["waypoints"] = np.array([[0.0, 0.0], [1.0, 0.0]])
    features = json.loads(tj.save_nav2_graph(g, path).read_text())["features"]
    assert [f["properties"]["metadata"]["vertex"] for f in features[:2]] == [0, 1]
    assert features[2]["geometry"]["type"] == "MultiLineString"


def test_a_bend_is_kept_where_the_coordinates_are_too_large_to_square(tmp_path):
    # the chord's squared length overflows to infinity: the bend's distance from it cannot
    # be computed, and a point whose distance is unknown must not be dropped
    scale = 1e300
    g = nx.MultiGraph()
    g.add_node(0, world=(0.0, 0.0))
    g.add_node(1, world=(scale, 0.0))
    world = np.array([[0.0, 0.0], [scale / 2, scale / 3], [scale, 0.0]])
    g.add_edge(0, 1, world=world, path=np.array([[0, 0], [0, 1], [0, 2]]))
    doc = json.loads(tj.save_nav2_graph(g, tmp_path / "huge.geojson").read_text())
    points = [f["geometry"]["coordinates"] for f in doc["features"]]
    assert [scale / 2, scale / 3] in points
