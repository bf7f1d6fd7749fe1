"""The work graph on literal graphs: the merge of close vertices, the faces beside edges."""

from __future__ import annotations

import numpy as np

from topojax.graph.build import skeleton_graph_store, skeleton_to_graph
from topojax.graph.work import (
    WorkGraph,
    collapse_loops,
    edge_sides,
    face_labels,
    line_in_mask,
    line_into,
    line_pixels,
    lines_pixels,
    merge_close_vertices,
    path_length_px,
)

FEASIBLE = np.ones((30, 30), bool)


def _graph(vertices, edges) -> WorkGraph:
    """``vertices``: (row, col) pixels; ``edges``: (u, v) joined by straight pixel lines."""
    work = WorkGraph()
    for p in vertices:
        work.add_vertex(p)
    for u, v in edges:
        work.add_edge(u, v, line_pixels(work.pixel[u], work.pixel[v]))
    return work


def _live(work: WorkGraph) -> list[int]:
    return [v for v in range(len(work.pixel)) if v not in work.dead and work.adj[v]]


def test_two_junctions_one_pixel_apart_become_one():
    # 0 and 1 are neighbours; each has two more edges
    work = _graph(
        [(10, 10), (10, 11), (2, 10), (18, 10), (2, 20), (18, 20)],
        [(0, 1), (0, 2), (0, 3), (1, 4), (1, 5)],
    )
    assert merge_close_vertices(work, FEASIBLE, 1.5, 1.5, 0.0) == 1
    assert _live(work) == [0, 2, 3, 4, 5]
    assert len(work.adj[0]) == 4 and len(work.edges) == 4
    assert {tuple(p) for p in work.members[0]} == {(10, 10), (10, 11)}
    for e in work.adj[0]:
        u, v, path = work.edges[e]
        end = work.oriented_path(e, 0)
        assert tuple(end[0]) == (10, 10)  # every edge starts at the kept pixel
        assert np.abs(np.diff(path, axis=0)).max() <= 1  # still 8-connected


def test_a_short_edge_that_a_merge_makes_is_merged_too():
    """Three junctions three pixels apart in a row: merging the first pair joins the third
    to the kept vertex by an edge of six pixels, still within the limit; it merges too."""
    work = _graph(
        [(10, 10), (10, 13), (10, 16), (2, 10), (18, 10), (2, 2), (2, 13), (18, 13)]
        + [(2, 16), (18, 16), (18, 25)],
        [(0, 1), (1, 2), (0, 3), (0, 4), (0, 5), (1, 6), (1, 7), (2, 8), (2, 9), (2, 10)],
    )
    assert merge_close_vertices(work, FEASIBLE, 6.5, 1.5, 0.0) == 2
    (hub,) = [v for v in _live(work) if len(work.adj[v]) > 1]
    assert len(work.adj[hub]) == 8
    assert {tuple(p) for p in work.members[hub]} == {(10, 10), (10, 13), (10, 16)}


def test_dead_end_one_pixel_off_a_junction_goes():
    work = _graph(
        [(10, 10), (10, 11), (2, 10), (18, 10), (10, 2)], [(0, 1), (0, 2), (0, 3), (0, 4)]
    )
    assert merge_close_vertices(work, FEASIBLE, 1.5, 1.5, 0.0) == 1
    assert 1 in work.dead and len(work.adj[0]) == 3
    assert (10, 11) in {tuple(p) for p in work.members[0]}


def test_dead_end_longer_than_its_limit_stays():
    work = _graph(
        [(10, 10), (10, 13), (2, 10), (18, 10), (10, 2)], [(0, 1), (0, 2), (0, 3), (0, 4)]
    )
    assert merge_close_vertices(work, FEASIBLE, 5.0, 1.5, 0.0) == 0
    assert len(work.edges) == 4


def test_no_merge_where_a_connector_would_leave_the_feasible_pixels():
    feasible = FEASIBLE.copy()
    # vertex 1's other edges meet it at (10, 12); the connector from vertex 0 to that pixel
    # is the line (10, 10)-(10, 12): its middle pixel is blocked, and the edge 0-1 runs
    # round it
    feasible[10, 11] = False
    work = WorkGraph()
    for p in [(10, 10), (10, 12), (2, 10), (18, 10), (18, 12), (2, 12)]:
        work.add_vertex(p)
    work.add_edge(0, 1, np.array([(10, 10), (9, 11), (10, 12)], np.int32))
    work.add_edge(0, 2, line_pixels((10, 10), (2, 10)))
    work.add_edge(0, 3, line_pixels((10, 10), (18, 10)))
    work.add_edge(1, 4, line_pixels((10, 12), (18, 12)))
    work.add_edge(1, 5, line_pixels((10, 12), (2, 12)))
    assert merge_close_vertices(work, feasible, 3.0, 1.5, 0.0) == 0
    assert merge_close_vertices(work, FEASIBLE, 3.0, 1.5, 0.0) == 1


def test_a_loop_left_short_by_a_merge_is_dropped_a_long_one_kept():
    # 0-1 directly (one pixel) and by a U of 9 pixels: after the merge a loop of 9 pixels
    u_path = np.array(
        [
            (10, 10),
            (9, 10),
            (8, 10),
            (7, 10),
            (6, 10),
            (6, 11),
            (7, 11),
            (8, 11),
            (9, 11),
            (10, 11),
        ],
        np.int32,
    )
    for loop_px, kept in ((20.0, False), (5.0, True)):
        work = _graph([(10, 10), (10, 11), (18, 10), (18, 11)], [(0, 1), (0, 2), (1, 3)])
        work.add_edge(0, 1, u_path)
        assert merge_close_vertices(work, FEASIBLE, 1.5, 1.5, loop_px) == 1
        loops = [e for e, (u, v, _) in work.edges.items() if u == v]
        assert bool(loops) == kept


def test_edge_sides_names_the_faces_each_side_of_an_edge():
    """A ring round a block and a spur into its outside: the ring's edge has the inside
    and the outside as its two faces, the spur the outside on both sides (a bridge), and
    an edge without interior pixels has none."""
    skeleton = np.zeros((9, 12), bool)
    skeleton[2, 2:9] = skeleton[6, 2:9] = True
    skeleton[2:7, 2] = skeleton[2:7, 8] = True
    faces = face_labels(skeleton)
    work = WorkGraph()
    a = work.add_vertex((2, 8))
    b = work.add_vertex((4, 11))
    c = work.add_vertex((4, 9))
    ring = np.array(
        [(2, x) for x in range(8, 1, -1)]
        + [(y, 2) for y in range(3, 7)]
        + [(6, x) for x in range(3, 9)]
        + [(y, 8) for y in range(5, 1, -1)],
        np.int32,
    )
    e_ring = work.add_edge(a, a, ring)
    e_spur = work.add_edge(c, b, np.array([(4, 9), (4, 10), (4, 11)], np.int32))
    e_short = work.add_edge(a, c, np.array([(2, 8), (3, 9)], np.int32))
    inside, outside = faces[4, 5], faces[0, 0]
    sides = edge_sides(work, faces)
    assert sides[e_ring] == tuple(sorted((int(inside), int(outside))))
    assert sides[e_spur] == (int(outside), int(outside))
    assert e_short not in sides


def test_line_in_mask_is_the_digital_line_where_every_pixel_is_set():
    """Against the line drawn whole and tested pixel by pixel: the same length where every
    pixel is set (and the same pixels), 0 where one is not."""
    rng = np.random.default_rng(7)
    for _ in range(3000):
        h, w = (int(x) for x in rng.integers(1, 30, 2))
        mask = rng.random((h, w)) < rng.choice([0.9, 0.99, 1.0])
        r0, r1 = (int(x) for x in rng.integers(0, h, 2))
        c0, c1 = (int(x) for x in rng.integers(0, w, 2))
        whole = np.zeros((h + w, 2), np.int64)
        n = line_into(r0, c0, r1, c1, whole)
        want = n if mask[whole[:n, 0], whole[:n, 1]].all() else 0
        out = np.zeros((h + w, 2), np.int64)
        assert line_in_mask(r0, c0, r1, c1, mask, out) == want
        if want:
            assert np.array_equal(out[:n], whole[:n])


def test_line_into_rounds_the_exact_line_halves_away_from_the_start():
    """Against exact rational arithmetic: one pixel per step along the major axis, the
    minor coordinate of the exact line rounded to the nearest pixel (halves away from the
    start), and a single pixel for a line of no length."""
    from fractions import Fraction

    rng = np.random.default_rng(11)
    for _ in range(2000):
        r0, c0, r1, c1 = (int(x) for x in rng.integers(-20, 20, 4))
        dr, dc = r1 - r0, c1 - c0
        n = max(abs(dr), abs(dc))
        want = []
        for i in range(n + 1):
            t = Fraction(i, n) if n else Fraction(0)
            exact_r, exact_c = dr * t, dc * t
            rounded = [
                int(x + Fraction(1, 2)) if x >= 0 else -int(-x + Fraction(1, 2))
                for x in (exact_r, exact_c)
            ]
            want.append((r0 + rounded[0], c0 + rounded[1]))
        out = np.zeros((n + 1, 2), np.int64)
        assert line_into(r0, c0, r1, c1, out) == n + 1
        assert [tuple(p) for p in out.tolist()] == want


def test_contracting_a_merged_cluster_goes_round_the_pixel_it_rings():
    """A junction cluster's members ring the obstacle pixel (5, 5); the two edges that
    met it at (5, 4) and (5, 6) join through the ring, never across (5, 5)."""
    ring = [(4, 4), (4, 5), (4, 6), (5, 6), (6, 6), (6, 5), (6, 4), (5, 4)]
    work = WorkGraph()
    work.add_vertex((5, 4), np.array(ring))
    work.add_vertex((5, 0))
    work.add_vertex((5, 10))
    work.add_edge(1, 0, line_pixels((5, 0), (5, 4)))
    work.add_edge(0, 2, line_pixels((5, 6), (5, 10)))
    work.contract(0)
    ((u, v, path),) = work.edges.values()
    assert {u, v} == {1, 2}
    cells = {tuple(p) for p in path}
    assert (5, 5) not in cells and cells <= {(5, c) for c in range(11)} | set(ring)
    assert np.abs(np.diff(path.astype(int), axis=0)).max() <= 1  # 8-connected
    assert len(path) == 11  # (5, 0)..(5, 4), (4, 5) or (6, 5), (5, 6)..(5, 10)


def test_member_bridge_stays_on_the_members_or_gives_none():
    from topojax.graph.work import member_bridge

    ring = np.array([(0, 0), (0, 1), (0, 2), (1, 2), (2, 2)])
    assert member_bridge((0, 0), (2, 2), ring).tolist() == [[0, 0], [0, 1], [1, 2], [2, 2]]
    assert member_bridge((0, 0), (5, 5), ring) is None  # the end is no member
    assert member_bridge((0, 0), (2, 2), ring[[0, 4]]) is None  # not joined


def test_route_graph_does_not_rest_on_how_a_sort_orders_equal_keys(monkeypatch, tmp_path):
    """Identical pillars give loops of equal length, and the loops collapse one after the
    other in length order: NumPy's default sort leaves the order of equal lengths to its
    algorithm, which differs between CPUs and releases, and another order opens other
    loops.  A sort that puts equal keys the other way round must give the same graph."""
    import topojax as tj
    from topojax.io import save_graph

    occupied = np.zeros((136, 136), bool)
    occupied[[0, -1], :] = occupied[:, [0, -1]] = True
    for r in range(20, 116, 12):
        for c in range(20, 116, 12):
            occupied[r : r + 3, c : c + 3] = True
    occ = tj.OccupancyMap(
        occupied=occupied, free=~occupied, unknown=np.zeros_like(occupied), resolution_m=0.05
    )
    real = np.argsort

    def ties_reversed(a, *args, kind=None, **kw):
        if kind == "stable":
            return real(a, *args, kind=kind, **kw)
        a = np.asarray(a)
        return a.size - 1 - real(a[::-1], kind="stable")

    def graph_bytes(name):
        graph = tj.route_graph(occ, robot_radius_m=0.1)
        return save_graph(graph, tmp_path / name).read_bytes()

    first = graph_bytes("a.json")  # compiles every kernel before the patch
    monkeypatch.setattr(np, "argsort", ties_reversed)
    assert graph_bytes("b.json") == first


class _CountedEdges(dict):
    """A work graph's edges that count the look-ups of an edge id."""

    lookups = 0

    def __contains__(self, e) -> bool:
        type(self).lookups += 1
        return super().__contains__(e)


def test_collapsing_a_row_of_loops_looks_at_each_edge_a_few_times():
    # a ladder of n loops, each rung narrower than the one before: each loop opens at its
    # right rung and joins the next, which thus gathers every rail edge so far; scanning
    # the gathered edges at each step would take 2 n^2 look-ups
    n = 200
    skeleton = np.zeros((12, 5 * n + 5), bool)
    skeleton[[1, 10], 2 : 5 * n + 3] = True
    clearance = np.full(skeleton.shape, 50.0, np.float32)
    for k in range(n + 1):
        skeleton[1:11, 2 + 5 * k] = True
        clearance[2:10, 2 + 5 * k] = 100.0 if k == 0 else 40.0 - 0.1 * k
    work = WorkGraph.from_networkx(skeleton_to_graph(skeleton, merge_junction_clusters=True))
    work.edges = _CountedEdges(work.edges)
    _CountedEdges.lookups = 0
    free = np.ones(skeleton.shape, bool)
    removed = collapse_loops(work, face_labels(skeleton), free, clearance, 1.0, 0.0, 1e9)
    assert removed == n
    rungs = {int(c) for _, _, path in work.edges.values() for r, c in path if 2 <= r <= 9}
    assert rungs == {2}  # the widest rung, at the left end, stays
    assert _CountedEdges.lookups <= 4 * n


def test_lines_drawn_at_once_are_those_drawn_one_by_one():
    """lines_pixels gives each line and length that line_pixels and path_length_px give,
    a line of one pixel (length 0) and lines in every octant among them."""
    rng = np.random.default_rng(7)
    ends = rng.integers(0, 40, size=(300, 4)).astype(np.int64)
    ends[:5, 2:] = ends[:5, :2]  # single pixels
    pixels, starts, lengths = lines_pixels(ends)
    assert pixels.dtype == np.int32
    for k, (r0, c0, r1, c1) in enumerate(ends.tolist()):
        line = line_pixels((r0, c0), (r1, c1))
        assert np.array_equal(pixels[starts[k] : starts[k + 1]], line)
        assert lengths[k] == path_length_px(line)
    empty = lines_pixels(np.zeros((0, 4), np.int64))
    assert empty[0].shape == (0, 2) and empty[1].tolist() == [0] and empty[2].size == 0


def test_an_edge_given_its_length_keeps_it():
    """add_edge takes a length given with the path instead of measuring the path."""
    work = _graph([(1, 1), (1, 5)], [])
    path = line_pixels((1, 1), (1, 5))
    assert work.length[work.add_edge(0, 1, path)] == 4.0
    assert work.length[work.add_edge(0, 1, path, 4.0)] == 4.0
    assert work.next_edge_id == 2


def _same_work(a: WorkGraph, b: WorkGraph) -> bool:
    if a.pixel != b.pixel or a.dead != b.dead or a.adj != b.adj or a.length != b.length:
        return False
    if any(not np.array_equal(x, y) for x, y in zip(a.members, b.members, strict=True)):
        return False
    return list(a.edges) == list(b.edges) and all(
        a.edges[e][:2] == b.edges[e][:2] and np.array_equal(a.edges[e][2], b.edges[e][2])
        for e in a.edges
    )


def test_work_graph_of_a_store_is_that_of_its_networkx_graph():
    """from_store gives the vertices, edges and ids that from_networkx gives for the
    store's networkx graph: parallel edges, self-loops (rings, a cluster's loop) and
    merged junction clusters included."""
    from topojax.skeleton import thin

    rng = np.random.default_rng(3)
    masks = []
    for _ in range(6):
        blob = rng.random((60, 70)) < 0.55
        masks.append(thin(blob))
    ring = np.zeros((20, 20), bool)
    ring[5, 5:15] = ring[14, 5:15] = ring[5:15, 5] = ring[5:15, 14] = True
    masks += [ring, np.zeros((5, 5), bool)]
    for mask in masks:
        for merge in (False, True):
            store = skeleton_graph_store(mask, merge_junction_clusters=merge)
            nx_work = WorkGraph.from_networkx(store.to_networkx())
            assert _same_work(WorkGraph.from_store(store), nx_work)
