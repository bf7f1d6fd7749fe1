"""Tests for topojax.graph (skeleton -> topology MultiGraph, paper §II-C).

The independent reference used throughout is a brute-force pixel graph built here with plain
Python sets (8-neighbours minus the redundant diagonal of every ``L``), plus the original
implementation's outputs (``shared/data/reference``) and ``skan``.
"""

from __future__ import annotations

import math
from collections import Counter

import networkx as nx
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from topojax.graph import graph_summary, pixel_graph_degree, skeleton_to_graph

MAPS = ("intel", "office", "a_scan")
SQRT2 = math.sqrt(2.0)


# ----------------------------------------------------------------------------------------
# helpers: ASCII art and a brute-force pixel graph
# ----------------------------------------------------------------------------------------


def art(text: str) -> np.ndarray:
    """'#' = skeleton pixel, '.' = background; surrounding blank lines / indentation ignored."""
    rows = [line.strip() for line in text.strip().splitlines()]
    assert len({len(r) for r in rows}) == 1, "ragged ASCII art"
    return np.array([[ch == "#" for ch in r] for r in rows], dtype=bool)


def brute_links(skel: np.ndarray) -> set[frozenset]:
    """Pixel-graph links: 8-neighbours, minus diagonals whose common 4-neighbour is set."""
    h, w = skel.shape
    on = {(int(r), int(c)) for r, c in np.argwhere(skel)}
    links = set()
    for r, c in on:
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                q = (r + dr, c + dc)
                if (dr, dc) == (0, 0) or q not in on:
                    continue
                if dr != 0 and dc != 0 and ((r + dr, c) in on or (r, c + dc) in on):
                    continue  # redundant diagonal of an L
                links.add(frozenset(((r, c), q)))
    return links


def brute_degree(skel: np.ndarray, links: set[frozenset]) -> dict[tuple[int, int], int]:
    deg = {(int(r), int(c)): 0 for r, c in np.argwhere(skel)}
    for link in links:
        for p in link:
            deg[p] += 1
    return deg


def node_pixels(g: nx.MultiGraph, n: int) -> set[tuple[int, int]]:
    return {tuple(map(int, p)) for p in g.nodes[n]["pixels"]}


def paths(g: nx.MultiGraph) -> list[list[tuple[int, int]]]:
    return [[tuple(map(int, p)) for p in d["path"]] for _, _, d in g.edges(data=True)]


def check_invariants(g: nx.MultiGraph, skel: np.ndarray, *, resolution_m: float = 1.0) -> None:
    """Every structural property the graph must have, checked against the brute-force graph."""
    skel = np.asarray(skel, dtype=bool)
    h, w = skel.shape
    links = brute_links(skel)
    deg = brute_degree(skel, links)
    merged = g.graph["merge_junction_clusters"]
    assert g.graph["shape"] == (h, w)
    assert g.graph["resolution_m"] == resolution_m

    # nodes: ids 0..N-1 in raster order of `pixel`; pixel is one of the member pixels
    n_v = g.number_of_nodes()
    assert list(g.nodes) == list(range(n_v))
    rasters = [g.nodes[n]["pixel"][0] * w + g.nodes[n]["pixel"][1] for n in g]
    assert rasters == sorted(rasters) and len(set(rasters)) == n_v
    owner: dict[tuple[int, int], object] = {}
    for n, d in g.nodes(data=True):
        assert isinstance(d["pixel"][0], int) and isinstance(d["pixel"][1], int)
        assert d["pixels"].dtype == np.int32 and d["pixels"].ndim == 2
        members = node_pixels(g, n)
        assert d["pixel"] in members
        for p in members:
            assert p not in owner, f"pixel {p} in two vertices"
            owner[p] = ("v", n)
        x, y = d["world"]
        r, c = d["pixel"]
        assert x == pytest.approx((c + 0.5) * resolution_m)
        assert y == pytest.approx((h - r - 0.5) * resolution_m)
        if len(members) == 1:
            dp = deg[d["pixel"]]
            expected = {0: "isolated", 1: "end", 2: "ring"}.get(dp, "junction")
            assert d["kind"] == expected
        else:
            assert merged and d["kind"] == "junction"
            assert all(deg[p] >= 3 for p in members)

    # edges: orientation, connectivity, ends at vertex pixels, interior of degree 2
    used = Counter()
    for k, (u, v, d) in enumerate(g.edges(data=True)):
        assert u <= v
        path = d["path"]
        assert path.dtype == np.int32 and path.ndim == 2 and path.shape[1] == 2
        assert path.shape[0] >= 2
        pts = [tuple(map(int, p)) for p in path]
        assert pts[0] in node_pixels(g, u) and pts[-1] in node_pixels(g, v)
        steps = np.abs(np.diff(path.astype(np.int64), axis=0))
        assert np.all(steps.max(axis=1) == 1), "path not 8-connected"
        for a, b in zip(pts[:-1], pts[1:], strict=True):
            link = frozenset((a, b))
            assert link in links, f"step {a}->{b} is not a pixel-graph link"
            used[link] += 1
        for p in pts[1:-1]:
            assert deg[p] == 2 and p not in owner, f"interior pixel {p} reused or not degree 2"
            owner[p] = ("e", k)
        if u == v and len(node_pixels(g, u)) == 1:
            assert pts[0] == pts[-1]
        expected_len = float(np.sum(np.where(steps.sum(axis=1) == 2, SQRT2, 1.0))) * resolution_m
        assert d["length_m"] == pytest.approx(expected_len, rel=1e-12, abs=1e-12)
        assert d["world"].shape == (len(pts), 2) and d["world"].dtype == np.float64
        np.testing.assert_allclose(d["world"][:, 0], (path[:, 1] + 0.5) * resolution_m)
        np.testing.assert_allclose(d["world"][:, 1], (h - path[:, 0] - 0.5) * resolution_m)

    # partition of the skeleton pixels
    assert set(owner) == set(deg), "skeleton pixels not covered exactly"

    if not merged:
        # each pixel-graph link is traversed by exactly one edge
        assert set(used) == links and all(c == 1 for c in used.values())
        for n, dn in g.nodes(data=True):
            if dn["kind"] == "ring":
                assert g.degree(n) == 2 and g.number_of_edges(n, n) == 1
            else:
                assert g.degree(n) == deg[dn["pixel"]]
    else:
        # inside-cluster links dropped, all others kept exactly once
        junction = {p for p, dp in deg.items() if dp >= 3}
        inner = {lk for lk in links if all(p in junction for p in lk)}
        assert set(used) == links - inner and all(c == 1 for c in used.values())
        # clusters = connected components of junction-junction links
        jg = nx.Graph()
        jg.add_nodes_from(junction)
        jg.add_edges_from(tuple(lk) for lk in inner)
        clusters = {frozenset(c) for c in nx.connected_components(jg)}
        got = {frozenset(node_pixels(g, n)) for n, k in g.nodes(data="kind") if k == "junction"}
        assert got == clusters
        for n in g:
            mem = np.array(sorted(node_pixels(g, n)), dtype=float)
            dist2 = ((mem - mem.mean(axis=0)) ** 2).sum(axis=1)
            rep = np.array(g.nodes[n]["pixel"], dtype=float)
            assert ((rep - mem.mean(axis=0)) ** 2).sum() == pytest.approx(dist2.min())


# ----------------------------------------------------------------------------------------
# small literal skeletons
# ----------------------------------------------------------------------------------------


def vertices(g):
    return [(d["pixel"], d["kind"]) for _, d in g.nodes(data=True)]


def edge_list(g):
    return sorted((u, v, tuple(map(tuple, d["path"].tolist()))) for u, v, d in g.edges(data=True))


def test_single_pixel_is_isolated_vertex():
    skel = art("""
        ...
        .#.
        ...
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [((1, 1), "isolated")]
    assert g.number_of_edges() == 0
    check_invariants(g, skel)


def test_two_pixel_segment():
    g = skeleton_to_graph(art("##"))
    assert vertices(g) == [((0, 0), "end"), ((0, 1), "end")]
    assert edge_list(g) == [(0, 1, ((0, 0), (0, 1)))]
    assert g.edges[0, 1, 0]["length_m"] == 1.0


def test_straight_line_and_resolution():
    skel = art("#####")
    g = skeleton_to_graph(skel, resolution_m=0.05)
    assert vertices(g) == [((0, 0), "end"), ((0, 4), "end")]
    assert edge_list(g) == [(0, 1, tuple((0, c) for c in range(5)))]
    assert g.edges[0, 1, 0]["length_m"] == pytest.approx(4 * 0.05)
    check_invariants(g, skel, resolution_m=0.05)


def test_l_shape_drops_the_redundant_diagonal():
    skel = art("""
        #..
        #..
        ###
    """)
    g = skeleton_to_graph(skel)
    # Without the triangle rule (1,0) and (2,1) would be degree-3 junctions.
    assert vertices(g) == [((0, 0), "end"), ((2, 2), "end")]
    assert edge_list(g) == [(0, 1, ((0, 0), (1, 0), (2, 0), (2, 1), (2, 2)))]
    assert g.edges[0, 1, 0]["length_m"] == pytest.approx(4.0)
    deg = pixel_graph_degree(skel)
    assert deg.tolist() == [[1, 0, 0], [2, 0, 0], [2, 2, 1]]


def test_diagonal_staircase_keeps_diagonals():
    skel = art("""
        #...
        .#..
        ..#.
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [((0, 0), "end"), ((2, 2), "end")]
    assert g.edges[0, 1, 0]["length_m"] == pytest.approx(2 * SQRT2)


def test_ring_without_junction_is_one_ring_vertex_with_a_self_loop():
    skel = art("""
        .##.
        #..#
        #..#
        .##.
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [((3, 2), "ring")]  # last ring pixel in raster order
    assert g.number_of_edges() == 1 and nx.number_of_selfloops(g) == 1
    ((u, v, d),) = g.edges(data=True)
    pts = [tuple(p) for p in d["path"].tolist()]
    assert pts[0] == pts[-1] == (3, 2) and len(pts) == 9
    assert set(pts) == {tuple(p) for p in np.argwhere(skel).tolist()}
    assert d["length_m"] == pytest.approx(4 + 4 * SQRT2)
    check_invariants(g, skel)
    assert graph_summary(g)["n_rings"] == 1


def test_ring_along_the_image_border():
    skel = art("""
        ###
        #.#
        ###
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [((2, 2), "ring")]
    ((_, _, d),) = g.edges(data=True)
    assert len(d["path"]) == 9 and d["length_m"] == pytest.approx(8.0)
    check_invariants(g, skel)


def test_figure_eight_two_self_loops_on_one_junction():
    skel = art("""
        .#.#.
        #.#.#
        .#.#.
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [((1, 2), "junction")]
    assert g.number_of_edges(0, 0) == 2
    loops = sorted(frozenset(p[1:-1]) for p in paths(g))
    assert sorted(loops) == sorted(
        [frozenset({(0, 1), (1, 0), (2, 1)}), frozenset({(0, 3), (1, 4), (2, 3)})]
    )
    assert all(p[0] == p[-1] == (1, 2) for p in paths(g))
    assert g.degree(0) == 4
    check_invariants(g, skel)


def test_t_shape():
    skel = art("""
        #####
        ..#..
        ..#..
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [((0, 0), "end"), ((0, 2), "junction"), ((0, 4), "end"), ((2, 2), "end")]
    assert edge_list(g) == [
        (0, 1, ((0, 0), (0, 1), (0, 2))),
        (1, 2, ((0, 2), (0, 3), (0, 4))),
        (1, 3, ((0, 2), (1, 2), (2, 2))),
    ]
    check_invariants(g, skel)


def test_plus_shape():
    skel = art("""
        ..#..
        ..#..
        #####
        ..#..
        ..#..
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [
        ((0, 2), "end"),
        ((2, 0), "end"),
        ((2, 2), "junction"),
        ((2, 4), "end"),
        ((4, 2), "end"),
    ]
    assert edge_list(g) == [
        (0, 2, ((0, 2), (1, 2), (2, 2))),
        (1, 2, ((2, 0), (2, 1), (2, 2))),
        (2, 3, ((2, 2), (2, 3), (2, 4))),
        (2, 4, ((2, 2), (3, 2), (4, 2))),
    ]
    check_invariants(g, skel)


def test_one_pixel_spur_gives_two_pixel_edge():
    skel = art("""
        ...#...
        #######
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [((0, 3), "end"), ((1, 0), "end"), ((1, 3), "junction"), ((1, 6), "end")]
    assert (0, 2, ((0, 3), (1, 3))) in edge_list(g)
    assert g.number_of_edges() == 3
    check_invariants(g, skel)


def test_two_pixel_spur():
    skel = art("""
        ...#...
        ...#...
        #######
    """)
    g = skeleton_to_graph(skel)
    assert [k for _, k in vertices(g)].count("junction") == 1
    assert (0, 2, ((0, 3), (1, 3), (2, 3))) in edge_list(g)
    check_invariants(g, skel)


def test_parallel_corridors_are_kept_by_the_multigraph():
    skel = art("""
        ...###...
        ..#...#..
        ###...###
        ..#...#..
        ...###...
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [
        ((2, 0), "end"),
        ((2, 2), "junction"),
        ((2, 6), "junction"),
        ((2, 8), "end"),
    ]
    assert g.number_of_edges(1, 2) == 2
    corridors = sorted(tuple(p) for (u, v, p) in edge_list(g) if (u, v) == (1, 2))
    assert corridors == [
        ((2, 2), (1, 2), (0, 3), (0, 4), (0, 5), (1, 6), (2, 6)),
        ((2, 2), (3, 2), (4, 3), (4, 4), (4, 5), (3, 6), (2, 6)),
    ]
    check_invariants(g, skel)


def test_skeleton_touching_the_border():
    skel = art("""
        ####
        #...
        #...
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [((0, 3), "end"), ((2, 0), "end")]
    assert edge_list(g) == [(0, 1, ((0, 3), (0, 2), (0, 1), (0, 0), (1, 0), (2, 0)))]
    check_invariants(g, skel)


THICK_CROSSING = """
    #....#
    .#..#.
    ..##..
    ..##..
    .#..#.
    #....#
"""


def test_junction_cluster_unmerged_and_merged():
    skel = art(THICK_CROSSING)
    g = skeleton_to_graph(skel)
    block = [(2, 2), (2, 3), (3, 2), (3, 3)]
    assert [p for p, k in vertices(g) if k == "junction"] == block
    assert g.number_of_edges() == 8  # 4 arms + the 4-cycle of 2-pixel edges in the block
    check_invariants(g, skel)

    m = skeleton_to_graph(skel, merge_junction_clusters=True)
    assert vertices(m) == [
        ((0, 0), "end"),
        ((0, 5), "end"),
        ((2, 2), "junction"),  # all members tie for the centroid: first in raster order
        ((5, 0), "end"),
        ((5, 5), "end"),
    ]
    assert m.nodes[2]["pixels"].tolist() == [list(p) for p in block]
    assert edge_list(m) == [
        (0, 2, ((0, 0), (1, 1), (2, 2))),
        (1, 2, ((0, 5), (1, 4), (2, 3))),
        (2, 3, ((3, 2), (4, 1), (5, 0))),
        (2, 4, ((3, 3), (4, 4), (5, 5))),
    ]
    check_invariants(m, skel)


DIAMOND_HOLE = """
    ...#...
    ...#...
    ...#...
    ###.###
    ...#...
    ...#...
    ...#...
"""


def test_four_pixels_around_an_empty_diagonal_hole():
    # The a_scan pattern: N, E, S, W of an empty pixel are linked diagonally (their common
    # 4-neighbours are unset), so each has degree 3, as in the original implementation.
    skel = art(DIAMOND_HOLE)
    g = skeleton_to_graph(skel)
    diamond = [(2, 3), (3, 2), (3, 4), (4, 3)]
    assert [p for p, k in vertices(g) if k == "junction"] == diamond
    assert [p for p, k in vertices(g) if k == "end"] == [(0, 3), (3, 0), (3, 6), (6, 3)]
    tiny = sorted(p for (_, _, p) in edge_list(g) if len(p) == 2)
    assert tiny == [
        ((2, 3), (3, 2)),
        ((2, 3), (3, 4)),
        ((3, 2), (4, 3)),
        ((3, 4), (4, 3)),
    ]
    assert g.number_of_edges() == 8
    check_invariants(g, skel)

    m = skeleton_to_graph(skel, merge_junction_clusters=True)
    assert [k for _, k in vertices(m)].count("junction") == 1
    assert m.number_of_edges() == 4 and all(len(p) == 3 for p in paths(m))
    check_invariants(m, skel)


def test_loop_between_two_merged_junctions_becomes_a_self_loop():
    # Two adjacent junctions joined directly and by a longer loop: after merging, the loop
    # is a self-loop of the merged vertex whose ends are the two member pixels.
    skel = art("""
        ...##...
        ..#..#..
        ..#..#..
        ...##...
        ..#..#..
        .#....#.
    """)
    g = skeleton_to_graph(skel)
    assert vertices(g) == [
        ((3, 3), "junction"),
        ((3, 4), "junction"),
        ((5, 1), "end"),
        ((5, 6), "end"),
    ]
    assert g.number_of_edges(0, 1) == 2  # the 2-pixel link and the loop
    check_invariants(g, skel)
    m = skeleton_to_graph(skel, merge_junction_clusters=True)
    assert vertices(m) == [((3, 3), "junction"), ((5, 1), "end"), ((5, 6), "end")]
    assert m.nodes[0]["pixels"].tolist() == [[3, 3], [3, 4]]
    loop = [p for (u, v, p) in edge_list(m) if u == v == 0]
    assert loop == [((3, 3), (2, 2), (1, 2), (0, 3), (0, 4), (1, 5), (2, 5), (3, 4))]
    assert edge_list(m)[1:] == [
        (0, 1, ((3, 3), (4, 2), (5, 1))),
        (0, 2, ((3, 4), (4, 5), (5, 6))),
    ]
    check_invariants(m, skel)


# ----------------------------------------------------------------------------------------
# attributes, options, summary
# ----------------------------------------------------------------------------------------


def test_clearance_attributes():
    skel = art(THICK_CROSSING)
    rng = np.random.default_rng(3)
    clear = rng.uniform(0.0, 9.0, size=skel.shape)
    g = skeleton_to_graph(skel, clearance_px=clear, resolution_m=0.1)
    for _, d in g.nodes(data=True):
        assert d["clearance_m"] == pytest.approx(clear[d["pixel"]] * 0.1)
    for _, _, d in g.edges(data=True):
        vals = clear[d["path"][:, 0], d["path"][:, 1]] * 0.1
        assert d["min_clearance_m"] == pytest.approx(vals.min())
        assert d["mean_clearance_m"] == pytest.approx(vals.mean())
    g0 = skeleton_to_graph(skel)
    assert all(math.isnan(c) for _, c in g0.nodes(data="clearance_m"))
    assert all(math.isnan(c) for _, _, c in g0.edges(data="min_clearance_m"))
    assert all(math.isnan(c) for _, _, c in g0.edges(data="mean_clearance_m"))


def test_pixel_to_world_callable():
    skel = art(THICK_CROSSING)
    calls = []

    def p2w(rows, cols):
        calls.append(rows.shape)
        return 10.0 + 2.0 * cols, -3.0 * rows

    g = skeleton_to_graph(skel, pixel_to_world=p2w, resolution_m=0.5)
    assert len(calls) == 1  # one vectorised call
    for _, d in g.nodes(data=True):
        r, c = d["pixel"]
        assert d["world"] == (10.0 + 2.0 * c, -3.0 * r)
    for _, _, d in g.edges(data=True):
        np.testing.assert_array_equal(d["world"][:, 0], 10.0 + 2.0 * d["path"][:, 1])
        np.testing.assert_array_equal(d["world"][:, 1], -3.0 * d["path"][:, 0])
        # length_m stays pixel steps x resolution_m
        expected = 2 * SQRT2 if len(d["path"]) == 3 else 1.0  # arm / edge inside the block
        assert d["length_m"] == pytest.approx(0.5 * expected)


def test_graph_summary_values():
    skel = art("""
        #####..
        ..#....
        ..#...#
        .......
        .##....
        #..#...
        .##....
    """)
    g = skeleton_to_graph(skel, resolution_m=2.0)
    s = graph_summary(g)
    assert s == {
        "n_vertices": 6,
        "n_edges": 4,
        "n_junctions": 1,
        "n_ends": 3,
        "n_rings": 1,
        "n_isolated": 1,
        "n_self_loops": 1,
        "n_components": 3,
        "total_length_m": pytest.approx(2.0 * (2 + 2 + 2 + (2 + 4 * SQRT2))),
    }
    empty = graph_summary(skeleton_to_graph(np.zeros((3, 4), bool)))
    assert empty["n_vertices"] == 0 and empty["n_components"] == 0
    with pytest.raises(TypeError, match="graph"):
        graph_summary({"not": "a graph"})
    u, v, k = next(iter(g.edges(keys=True)))
    for length, exc, words in (
        ("2", TypeError, "expected a real number of metres >= 0, received str '2'"),
        (-2.0, ValueError, "expected a finite number of metres >= 0, received -2.0"),
        (float("nan"), ValueError, "expected a finite number of metres >= 0, received nan"),
    ):
        edited = g.copy()
        edited.edges[u, v, k]["length_m"] = length
        with pytest.raises(exc, match=rf"^graph: edge {u}-{v}: 'length_m': {words}"):
            graph_summary(edited)


def test_empty_skeleton_keeps_graph_attributes():
    g = skeleton_to_graph(np.zeros((5, 7), dtype=np.uint8), resolution_m=0.05)
    assert g.number_of_nodes() == 0 and g.number_of_edges() == 0
    assert g.graph["shape"] == (5, 7) and g.graph["resolution_m"] == 0.05
    assert isinstance(g, nx.MultiGraph)
    g = skeleton_to_graph(np.zeros((0, 0), dtype=bool))
    assert g.graph["shape"] == (0, 0)


def test_integer_and_float_input_equal_bool_input():
    skel = art(THICK_CROSSING)
    a = edge_list(skeleton_to_graph(skel))
    assert edge_list(skeleton_to_graph(skel.astype(np.uint8))) == a
    assert edge_list(skeleton_to_graph(skel.astype(np.float32))) == a
    assert edge_list(skeleton_to_graph(skel.tolist())) == a


def test_input_not_modified_and_deterministic():
    skel = art(DIAMOND_HOLE)
    before = skel.copy()
    a = skeleton_to_graph(skel)
    b = skeleton_to_graph(skel)
    np.testing.assert_array_equal(skel, before)
    assert vertices(a) == vertices(b) and edge_list(a) == edge_list(b)


@pytest.mark.parametrize(
    ("kwargs", "exc", "words"),
    [
        ({"skeleton": np.zeros((2, 2, 2), bool)}, ValueError, ["skeleton", "2-D", "(2, 2, 2)"]),
        ({"skeleton": np.array([["a", "b"]])}, TypeError, ["skeleton", "bool-like", "<U1"]),
        ({"skeleton": np.array([[0, 2]])}, ValueError, ["skeleton", "0 and 1", "2"]),
        ({"resolution_m": 0.0}, ValueError, ["resolution_m", "> 0", "0.0"]),
        ({"resolution_m": -1}, ValueError, ["resolution_m", "> 0", "-1"]),
        ({"resolution_m": float("nan")}, ValueError, ["resolution_m", "finite", "nan"]),
        ({"resolution_m": float("inf")}, ValueError, ["resolution_m", "finite", "inf"]),
        ({"resolution_m": "0.05"}, TypeError, ["resolution_m", "real number", "str"]),
        ({"resolution_m": True}, TypeError, ["resolution_m", "real number", "bool"]),
        ({"clearance_px": np.ones((3, 3))}, ValueError, ["clearance_px", "(4, 4)", "(3, 3)"]),
        ({"clearance_px": np.full((4, 4), np.nan)}, ValueError, ["clearance_px", "NaN", "nan"]),
        ({"clearance_px": -np.ones((4, 4))}, ValueError, ["clearance_px", "non-negative", "-1"]),
        ({"clearance_px": np.ones((4, 4), bool)}, TypeError, ["clearance_px", "numeric", "bool"]),
        ({"pixel_to_world": 3}, TypeError, ["pixel_to_world", "callable", "int"]),
        (
            {"pixel_to_world": lambda r, c: (r, c[:1])},
            ValueError,
            ["pixel_to_world", "shape", "(1,)"],
        ),
        ({"pixel_to_world": lambda r, c: r}, TypeError, ["pixel_to_world", "(x, y)"]),
        (
            {"pixel_to_world": lambda r, c: (c * np.nan, r)},
            ValueError,
            ["pixel_to_world", "finite", "nan", "(0, 0)"],
        ),
        (
            {"pixel_to_world": lambda r, c: (c + np.inf, r)},
            ValueError,
            ["pixel_to_world", "finite", "inf"],
        ),
        (
            {"pixel_to_world": lambda r, c: (c + 0j, r + 0j)},
            TypeError,
            ["pixel_to_world", "real", "complex128"],
        ),
        (
            {"pixel_to_world": lambda r, c: (["a"] * len(r), r)},
            TypeError,
            ["pixel_to_world", "real", "<U1"],
        ),
        ({"skeleton": None}, TypeError, ["skeleton", "bool-like", "NoneType"]),
        ({"skeleton": np.ones((2, 2), complex)}, TypeError, ["skeleton", "complex128"]),
        ({"merge_junction_clusters": "yes"}, TypeError, ["merge_junction_clusters", "bool"]),
    ],
)
def test_bad_input_raises_clear_errors(kwargs, exc, words):
    small = art("""
        ##..
        .#..
        .##.
        ....
    """)
    args = {"skeleton": small}
    args.update(kwargs)
    skel = args.pop("skeleton")
    with pytest.raises(exc) as info:
        skeleton_to_graph(skel, **args)
    for word in words:
        assert word in str(info.value), (word, str(info.value))


def test_pixel_graph_degree_matches_brute_force():
    rng = np.random.default_rng(11)
    skel = rng.random((40, 50)) < 0.35
    deg = pixel_graph_degree(skel)
    assert deg.shape == skel.shape and deg.dtype == np.uint8
    ref = np.zeros(skel.shape, dtype=int)
    for p, d in brute_degree(skel, brute_links(skel)).items():
        ref[p] = d
    np.testing.assert_array_equal(deg, ref)


@settings(max_examples=100, deadline=None)
@given(
    arrays(np.bool_, st.tuples(st.integers(1, 12), st.integers(1, 12)), elements=st.booleans()),
    st.integers(-5000, 5000),
    st.integers(-(2**31), 2**31 - 13),
)
def test_pixel_graph_does_not_depend_on_the_key_layout(skel, row0, col0):
    # The incremental mapper traces scattered pixels by key (row << 32) + col + 2^31 at any
    # origin; the full-map path uses row * (W + 1) + col.  Same pixels, same raw graph.
    from topojax.graph.trace import _dense_keys, raw_graph

    keys, stride = _dense_keys(skel.shape, np.flatnonzero(skel))
    rows, cols = keys // stride, keys % stride
    packed = ((rows + row0) << 32) + (cols + col0 + (1 << 31))
    assert np.all(np.diff(packed) > 0)
    dense = raw_graph(keys, stride)
    sparse = raw_graph(packed, 1 << 32)
    for a, b in zip(dense, sparse, strict=True):
        np.testing.assert_array_equal(a, b)


# ----------------------------------------------------------------------------------------
# property tests on random skeletons
# ----------------------------------------------------------------------------------------


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    arrays(
        np.bool_,
        st.tuples(st.integers(1, 11), st.integers(1, 11)),
        elements=st.booleans(),
    ),
    st.booleans(),
)
def test_invariants_on_arbitrary_masks(skel, merge):
    g = skeleton_to_graph(skel, merge_junction_clusters=merge)
    check_invariants(g, skel)


def _random_blob_skeleton(seed: int, h: int, w: int, density: float) -> np.ndarray:
    from scipy import ndimage as ndi
    from skimage.morphology import skeletonize

    rng = np.random.default_rng(seed)
    field = ndi.gaussian_filter(rng.standard_normal((h, w)), sigma=2.0)
    blobs = field > np.quantile(field, 1.0 - density)
    return skeletonize(blobs)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.integers(0, 2**32 - 1),
    st.integers(8, 64),
    st.integers(8, 64),
    st.floats(0.2, 0.8),
    st.booleans(),
)
def test_invariants_on_skeletonized_random_blobs(seed, h, w, density, merge):
    skel = _random_blob_skeleton(seed, h, w, density)
    g = skeleton_to_graph(skel, merge_junction_clusters=merge, resolution_m=0.25)
    check_invariants(g, skel, resolution_m=0.25)


# ----------------------------------------------------------------------------------------
# reference skeletons: the original implementation and skan
# ----------------------------------------------------------------------------------------


def _pix(points) -> list[tuple[int, int]]:
    return [tuple(map(int, p)) for p in points]


@pytest.mark.parametrize("name", MAPS)
def test_matches_original_implementation(paper_reference, name):
    ref = paper_reference(name)
    skel = ref["skeleton"]
    g = skeleton_to_graph(skel)
    check_invariants(g, skel)

    ref_v = _pix(ref["vertices"])
    ours = {d["pixel"] for _, d in g.nodes(data=True) if d["kind"] != "isolated"}
    # Required tolerance: >= 99 % of the original's vertices have one of ours within 1 px.
    all_ours = np.array([d["pixel"] for _, d in g.nodes(data=True)])
    cheb = np.abs(np.asarray(ref_v)[:, None, :] - all_ours[None, :, :]).max(axis=2).min(axis=1)
    assert np.mean(cheb <= 1) >= 0.99
    # Measured: exact equality once lone pixels (no edge in the original) are left out.
    assert ours == set(ref_v)
    assert len(ref_v) == {"intel": 258, "office": 305, "a_scan": 344}[name]
    isolated = [d["pixel"] for _, d in g.nodes(data=True) if d["kind"] == "isolated"]
    assert all(pixel_graph_degree(skel)[p] == 0 and skel[p] for p in isolated)

    # Same edges, as multisets of end-pixel pairs.
    ref_e = Counter(frozenset((ref_v[a], ref_v[b])) for a, b in ref["edges"].tolist())
    our_e = Counter(frozenset((g.nodes[u]["pixel"], g.nodes[v]["pixel"])) for u, v in g.edges())
    assert our_e == ref_e
    assert g.number_of_edges() == {"intel": 235, "office": 328, "a_scan": 350}[name]

    # Same pixel count per edge, except for rings: the original lists a ring twice
    # (2 n + 1 pixels) where our self-loop has n + 1.
    ours_np = Counter(len(d["path"]) for u, v, d in g.edges(data=True))
    ref_np = Counter(ref["edge_npix"].tolist())
    ring_np = [len(d["path"]) for u, v, d in g.edges(data=True) if g.nodes[u]["kind"] == "ring"]
    for n in ring_np:
        ours_np[n] -= 1
        ref_np[2 * n - 1] -= 1
    assert +ours_np == +ref_np
    assert len(ring_np) == (1 if name == "intel" else 0)


@pytest.mark.parametrize("name", MAPS)
def test_cross_check_with_skan(paper_reference, name):
    csr = pytest.importorskip("skan.csr")
    skel = paper_reference(name)["skeleton"]
    sk = csr.Skeleton(skel)
    skan_ends = set()
    skan_np = Counter()
    for i in range(sk.n_paths):
        c = _pix(sk.path_coordinates(i))
        skan_ends.update((c[0], c[-1]))
        skan_np[len(c)] += 1
    g = skeleton_to_graph(skel)
    rings = {d["pixel"] for _, d in g.nodes(data=True) if d["kind"] == "ring"}
    ours = {d["pixel"] for _, d in g.nodes(data=True) if d["kind"] not in ("isolated", "ring")}
    ours_np = Counter(len(d["path"]) for _, _, d in g.edges(data=True))
    if name in ("intel", "office"):
        # skan starts a ring at another pixel; everything else agrees exactly.
        assert len(skan_ends - ours) == len(rings)
        assert ours <= skan_ends
        assert sk.n_paths == g.number_of_edges()
        assert skan_np == ours_np
    else:
        # a_scan: skan keeps a spanning tree of each junction cluster, so at the 4 "diamond"
        # crossings (N, E, S, W around an empty pixel) two of our four junctions are path
        # pixels for skan.  Every difference must be such a diamond pixel.
        assert skan_ends <= ours
        extra = ours - skan_ends
        assert len(extra) == 8
        holes = ~skel[1:-1, 1:-1] & skel[:-2, 1:-1] & skel[2:, 1:-1]
        holes &= skel[1:-1, :-2] & skel[1:-1, 2:]
        centres = {(int(r) + 1, int(c) + 1) for r, c in np.argwhere(holes)}
        assert len(centres) == 4
        for r, c in extra:
            assert any(abs(r - cr) + abs(c - cc) == 1 for cr, cc in centres)
        assert g.number_of_edges() - sk.n_paths == 12


@pytest.mark.parametrize("name", MAPS)
def test_merged_clusters_on_reference_skeletons(paper_reference, name):
    skel = paper_reference(name)["skeleton"]
    g = skeleton_to_graph(skel)
    m = skeleton_to_graph(skel, merge_junction_clusters=True)
    check_invariants(m, skel)
    tiny = sum(
        1
        for u, v, d in g.edges(data=True)
        if len(d["path"]) == 2 and g.nodes[u]["kind"] == g.nodes[v]["kind"] == "junction"
    )
    assert m.number_of_edges() == g.number_of_edges() - tiny
    assert graph_summary(m)["n_ends"] == graph_summary(g)["n_ends"]
    assert graph_summary(m)["n_components"] == graph_summary(g)["n_components"]


def test_direct_graph_fill_equals_the_public_networkx_calls():
    """skeleton_to_graph fills its graph from a GraphStore with bulk networkx calls; one
    add_node / add_edge call per node and edge must give the same graph: nodes, edge keys
    and their order, attributes, and one key dict shared by both ends of every node pair
    (self-loops, parallel corridors, an isolated pixel and a ring included)."""
    skel = np.zeros((12, 30), bool)
    skel[:5, :5] = art("""
        .#.#.
        #.#.#
        .#.#.
        .....
        ..#..
    """)  # figure eight (two self-loops on a junction) and an isolated pixel
    skel[:5, 10:19] = art("""
        ...###...
        ..#...#..
        ###...###
        ..#...#..
        ...###...
    """)  # parallel corridors
    skel[6:10, 22:26] = art("""
        .##.
        #..#
        #..#
        .##.
    """)  # a ring
    direct = skeleton_to_graph(skel, clearance_px=np.ones(skel.shape))
    public = nx.MultiGraph()
    public.graph.update(direct.graph)
    for n, d in direct.nodes(data=True):
        public.add_node(n, **d)
    for u, v, d in direct.edges(data=True):
        public.add_edge(u, v, **d)
    assert type(direct) is nx.MultiGraph
    assert nx.number_of_selfloops(direct) == 3 and direct.number_of_edges(2, 3) == 2
    assert list(direct.nodes(data=True)) == list(public.nodes(data=True))
    assert list(direct.edges(keys=True, data=True)) == list(public.edges(keys=True, data=True))
    assert {u: {v: dict(k) for v, k in nb.items()} for u, nb in direct.adj.items()} == {
        u: {v: dict(k) for v, k in nb.items()} for u, nb in public.adj.items()
    }
    for graph in (direct, public):
        for u, v in graph.edges():
            assert graph._adj[u][v] is graph._adj[v][u]
    assert direct.degree(0) == public.degree(0) == 4
    assert nx.utils.graphs_equal(direct, public)


def test_clearance_as_a_function_of_the_skeleton_pixels():
    """clearance_px may be a function of the skeleton's flat indices: it is called once,
    with those indices in raster order, and gives what the whole-map array gives; a
    function returning the wrong number of values is refused."""
    skel = art("""
        #####
        ..#..
        ..#..
    """)
    clear = np.arange(15, dtype=np.float64).reshape(3, 5)
    calls = []

    def at(flat):
        calls.append(flat)
        return clear.ravel()[flat]

    a = skeleton_to_graph(skel, clearance_px=clear, resolution_m=0.5)
    b = skeleton_to_graph(skel, clearance_px=at, resolution_m=0.5)
    assert len(calls) == 1
    np.testing.assert_array_equal(calls[0], np.flatnonzero(skel))
    assert list(a.nodes(data="clearance_m")) == list(b.nodes(data="clearance_m"))
    assert [d["mean_clearance_m"] for *_, d in a.edges(data=True)] == [
        d["mean_clearance_m"] for *_, d in b.edges(data=True)
    ]
    with pytest.raises(ValueError, match=r"clearance_px: expected 7 values"):
        skeleton_to_graph(skel, clearance_px=lambda flat: flat[:-1])
