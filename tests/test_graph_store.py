"""Tests for topojax.graph.GraphStore (the topology graph as arrays).

Stores are written out by hand for small skeletons (a line, a T, a ring, an isolated
pixel, a junction cluster with and without merging, an empty skeleton) and their
``to_networkx()`` must equal ``skeleton_to_graph``'s graph: the same nodes, edges, keys,
attributes, dtypes and order.  ``from_networkx`` must give them back.
"""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from topojax.graph import KIND_CODES, KIND_NAMES, GraphStore, prune_graph, skeleton_to_graph

SQRT2 = math.sqrt(2.0)


def art(text: str) -> np.ndarray:
    """'#' = skeleton pixel, '.' = background; surrounding blank lines / indentation ignored."""
    rows = [line.strip() for line in text.strip().splitlines()]
    return np.array([[ch == "#" for ch in r] for r in rows], dtype=bool)


# ----------------------------------------------------------------------------------------
# exact comparison of two networkx graphs
# ----------------------------------------------------------------------------------------


def assert_same_value(a, b, where: str) -> None:
    assert type(a) is type(b), f"{where}: {type(a).__name__} != {type(b).__name__}"
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, f"{where}: {a.dtype}{a.shape}"
        np.testing.assert_array_equal(a, b, err_msg=where)
        assert a.flags.writeable == b.flags.writeable, where
    elif isinstance(a, float):
        assert a == b or (math.isnan(a) and math.isnan(b)), f"{where}: {a} != {b}"
    elif isinstance(a, tuple):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same_value(x, y, f"{where}[{i}]")
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


def assert_same_dict(a: dict, b: dict, where: str) -> None:
    assert list(a) == list(b), f"{where}: keys {list(a)} != {list(b)}"
    for k in a:
        assert_same_value(a[k], b[k], f"{where}.{k}")


def assert_same_graph(a: nx.MultiGraph, b: nx.MultiGraph) -> None:
    """Node for node and edge for edge: order, keys, attributes and their types/dtypes."""
    assert type(a) is type(b) is nx.MultiGraph
    assert_same_dict(a.graph, b.graph, "graph")
    assert list(a.nodes) == list(b.nodes)
    for n in a:
        assert_same_dict(a.nodes[n], b.nodes[n], f"node {n}")
        assert list(a.adj[n]) == list(b.adj[n]), f"neighbours of {n}"
        for m in a.adj[n]:
            assert list(a.adj[n][m]) == list(b.adj[n][m]), f"keys of {n}-{m}"
    ea = list(a.edges(keys=True, data=True))
    eb = list(b.edges(keys=True, data=True))
    assert [e[:3] for e in ea] == [e[:3] for e in eb]
    for (u, v, k, da), (_, _, _, db) in zip(ea, eb, strict=True):
        assert_same_dict(da, db, f"edge {u}-{v}-{k}")


def assert_same_store(a: GraphStore, b: GraphStore) -> None:
    for name in GraphStore.__dataclass_fields__:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            assert isinstance(x, np.ndarray) and isinstance(y, np.ndarray), name
            assert x.dtype == y.dtype and x.shape == y.shape, name
            np.testing.assert_array_equal(x, y, err_msg=name)
        else:
            assert x == y, name


# ----------------------------------------------------------------------------------------
# hand-written stores
# ----------------------------------------------------------------------------------------


def hand_store(
    shape,
    nodes,
    edges,
    *,
    clearance=None,
    res=1.0,
    merge=False,
    members=None,
) -> GraphStore:
    """A store from literal vertices ``[(row, col, kind name), ...]`` and edges
    ``[(u, v, [(row, col), ...]), ...]`` (paths from u to v), with the default map frame
    and integer clearances (exact in floating point), computed independently here."""
    h = shape[0]

    def world(rc):
        rc = np.asarray(rc, dtype=np.float64).reshape(-1, 2)
        return np.stack([(rc[:, 1] + 0.5) * res, (h - rc[:, 0] - 0.5) * res], axis=1)

    def clear_at(rc):
        if clearance is None:
            return np.full(len(rc), np.nan)
        return np.array([float(clearance[r, c]) for r, c in rc]) * res

    node_rc = [(r, c) for r, c, _ in nodes]
    paths = [p for _, _, p in edges]
    lengths, lows, means = [], [], []
    for p in paths:
        steps = np.abs(np.diff(np.asarray(p), axis=0))
        diagonal = int(np.sum((steps[:, 0] != 0) & (steps[:, 1] != 0)))
        lengths.append((len(p) - 1 - diagonal + diagonal * SQRT2) * res)
        c = clear_at(p)
        lows.append(c.min())
        means.append(c.sum() / len(p))
    flat = [rc for p in paths for rc in p]
    kw = {}
    if members is not None:
        kw["member_offsets"] = np.cumsum([0] + [len(m) for m in members])
        kw["member_pixels"] = np.array([rc for m in members for rc in m]).reshape(-1, 2)
    return GraphStore(
        node_pixel=np.array(node_rc, dtype=np.int64).reshape(-1, 2),
        node_kind=np.array([KIND_CODES[k] for _, _, k in nodes], dtype=np.int8),
        node_world=world(node_rc),
        node_clearance_m=clear_at(node_rc),
        edge_u=np.array([u for u, _, _ in edges], dtype=np.int64),
        edge_v=np.array([v for _, v, _ in edges], dtype=np.int64),
        path_offsets=np.cumsum([0] + [len(p) for p in paths]),
        path_pixels=np.array(flat, dtype=np.int64).reshape(-1, 2),
        path_world=world(flat),
        edge_length_m=np.array(lengths, dtype=np.float64),
        edge_min_clearance_m=np.array(lows, dtype=np.float64),
        edge_mean_clearance_m=np.array(means, dtype=np.float64),
        attrs={"resolution_m": res, "shape": shape, "merge_junction_clusters": merge},
        **kw,
    )


LINE = art("###")
T = art("""
    #####
    ..#..
    ..#..
""")
RING = art("""
    .##.
    #..#
    #..#
    .##.
""")
ISOLATED = art("""
    ...
    .#.
    ...
""")
CLUSTER = art("""
    #..#
    .##.
    #..#
""")


def fixtures():
    """(name, skeleton, skeleton_to_graph keywords, hand-written store)."""
    t_clear = np.arange(15).reshape(3, 5)
    ring_path = [(3, 2), (3, 1), (2, 0), (1, 0), (0, 1), (0, 2), (1, 3), (2, 3), (3, 2)]
    c_clear = np.array([[4, 0, 0, 5], [0, 2, 3, 0], [6, 0, 0, 7]])
    return [
        (
            "line",
            LINE,
            {},
            hand_store((1, 3), [(0, 0, "end"), (0, 2, "end")], [(0, 1, [(0, 0), (0, 1), (0, 2)])]),
        ),
        (
            "T with clearance, 0.5 m/px",
            T,
            {"clearance_px": t_clear, "resolution_m": 0.5},
            hand_store(
                (3, 5),
                [(0, 0, "end"), (0, 2, "junction"), (0, 4, "end"), (2, 2, "end")],
                [
                    (0, 1, [(0, 0), (0, 1), (0, 2)]),
                    (1, 2, [(0, 2), (0, 3), (0, 4)]),
                    (1, 3, [(0, 2), (1, 2), (2, 2)]),
                ],
                clearance=t_clear,
                res=0.5,
            ),
        ),
        (
            "ring",
            RING,
            {},
            hand_store((4, 4), [(3, 2, "ring")], [(0, 0, ring_path)]),
        ),
        (
            "isolated pixel",
            ISOLATED,
            {"clearance_px": np.full((3, 3), 2)},
            hand_store((3, 3), [(1, 1, "isolated")], [], clearance=np.full((3, 3), 2)),
        ),
        (
            "junction cluster, not merged",
            CLUSTER,
            {"clearance_px": c_clear},
            hand_store(
                (3, 4),
                [
                    (0, 0, "end"),
                    (0, 3, "end"),
                    (1, 1, "junction"),
                    (1, 2, "junction"),
                    (2, 0, "end"),
                    (2, 3, "end"),
                ],
                [
                    (0, 2, [(0, 0), (1, 1)]),
                    (1, 3, [(0, 3), (1, 2)]),
                    (2, 3, [(1, 1), (1, 2)]),
                    (2, 4, [(1, 1), (2, 0)]),
                    (3, 5, [(1, 2), (2, 3)]),
                ],
                clearance=c_clear,
            ),
        ),
        (
            "junction cluster, merged",
            CLUSTER,
            {"clearance_px": c_clear, "merge_junction_clusters": True},
            hand_store(
                (3, 4),
                [(0, 0, "end"), (0, 3, "end"), (1, 1, "junction"), (2, 0, "end"), (2, 3, "end")],
                [
                    (0, 2, [(0, 0), (1, 1)]),
                    (1, 2, [(0, 3), (1, 2)]),
                    (2, 3, [(1, 1), (2, 0)]),
                    (2, 4, [(1, 2), (2, 3)]),
                ],
                clearance=c_clear,
                merge=True,
                members=[[(0, 0)], [(0, 3)], [(1, 1), (1, 2)], [(2, 0)], [(2, 3)]],
            ),
        ),
        (
            "empty skeleton",
            np.zeros((3, 4), dtype=bool),
            {},
            hand_store((3, 4), [], []),
        ),
    ]


FIXTURES = fixtures()
IDS = [f[0] for f in FIXTURES]


@pytest.mark.parametrize(("name", "skel", "kw", "store"), FIXTURES, ids=IDS)
def test_hand_written_store_gives_skeleton_to_graphs_graph(name, skel, kw, store):
    assert_same_graph(store.to_networkx(), skeleton_to_graph(skel, **kw))


@pytest.mark.parametrize(("name", "skel", "kw", "store"), FIXTURES, ids=IDS)
def test_from_networkx_gives_the_hand_written_store_back(name, skel, kw, store):
    g = skeleton_to_graph(skel, **kw)
    back = GraphStore.from_networkx(g)
    # member pixels are kept only where a vertex has more than its own pixel
    assert (back.member_pixels is None) == (name != "junction cluster, merged")
    assert_same_store(back, store)
    assert_same_graph(back.to_networkx(), g)


def test_counts_and_views():
    store = FIXTURES[4][3]  # junction cluster, not merged
    assert (store.n_nodes, store.n_edges) == (6, 5)
    np.testing.assert_array_equal(store.path(2), [[1, 1], [1, 2]])
    assert store.path(2).dtype == np.int64 and not store.path(2).flags.writeable
    np.testing.assert_array_equal(store.members(3), [[1, 2]])
    merged = FIXTURES[5][3]
    np.testing.assert_array_equal(merged.members(2), [[1, 1], [1, 2]])
    assert merged.members(2).base is not None  # a view
    assert "n_nodes=5" in repr(merged) and "n_edges=4" in repr(merged)
    empty = FIXTURES[-1][3]
    assert (empty.n_nodes, empty.n_edges) == (0, 0)


def test_kind_codes_are_defined_once_and_match_the_graph():
    assert KIND_NAMES == {0: "isolated", 1: "end", 2: "ring", 3: "junction"}
    assert KIND_CODES == {name: code for code, name in KIND_NAMES.items()}


def test_arrays_are_read_only_and_the_graph_shares_no_memory():
    base = np.array([[0, 0], [0, 2]])
    store = FIXTURES[0][3]
    for name in GraphStore.__dataclass_fields__:
        value = getattr(store, name)
        if isinstance(value, np.ndarray):
            assert not value.flags.writeable, name
    with pytest.raises(ValueError):
        store.node_pixel[0, 0] = 5
    with pytest.raises(AttributeError):
        store.node_pixel = base
    # the caller's array stays writable; the store keeps a read-only view
    s = GraphStore(**{**_fields(store), "node_pixel": base})
    assert base.flags.writeable and not s.node_pixel.flags.writeable
    g = FIXTURES[5][3].to_networkx()
    merged = FIXTURES[5][3]
    for _, d in g.nodes(data=True):
        assert d["pixels"].flags.writeable
        assert not np.shares_memory(d["pixels"], merged.member_pixels)
    for _, _, d in g.edges(data=True):
        assert d["path"].flags.writeable and d["world"].flags.writeable
        assert not np.shares_memory(d["path"], merged.path_pixels)
        assert not np.shares_memory(d["world"], merged.path_world)


def _fields(store: GraphStore) -> dict:
    return {name: getattr(store, name) for name in GraphStore.__dataclass_fields__}


def test_default_keys_are_networkx_keys_and_ids_and_keys_can_be_given():
    # parallel edges and self-loops between vertices 0 and 1, in a mixed order
    pairs = [(0, 1), (1, 1), (1, 0), (0, 0), (0, 1), (1, 1)]
    n_e = len(pairs)
    paths = np.array([[0, 0], [0, 1]] * n_e)
    common = dict(
        node_pixel=[[0, 0], [0, 1]],
        node_kind=[3, 3],
        node_world=[[0.5, 0.5], [1.5, 0.5]],
        node_clearance_m=[np.nan, np.nan],
        edge_u=[u for u, _ in pairs],
        edge_v=[v for _, v in pairs],
        path_offsets=np.arange(0, 2 * n_e + 1, 2),
        path_pixels=paths,
        path_world=paths + 0.5,
        edge_length_m=np.arange(n_e, dtype=float),
        edge_min_clearance_m=np.full(n_e, np.nan),
        edge_mean_clearance_m=np.full(n_e, np.nan),
    )
    store = GraphStore(**common)
    reference = nx.MultiGraph()
    reference.add_nodes_from([0, 1])
    keys = [reference.add_edge(u, v) for u, v in pairs]
    assert store.edge_keys.tolist() == keys == [0, 0, 1, 0, 2, 1]
    g = store.to_networkx()
    assert list(g.edges(keys=True)) == list(reference.edges(keys=True))
    for i, (u, v) in enumerate(pairs):
        assert g.edges[u, v, keys[i]]["length_m"] == float(i)
    # a graph numbered as the incremental mapper numbers it: any distinct ids and keys
    named = GraphStore(**common, node_ids=[40, 7], edge_keys=[10, 11, 12, 13, 14, 15])
    h = named.to_networkx()
    assert list(h.nodes) == [40, 7]
    assert sorted(k for _, _, k in h.edges(keys=True)) == [10, 11, 12, 13, 14, 15]
    assert h.edges[7, 40, 12]["length_m"] == 2.0
    back = GraphStore.from_networkx(h)
    assert_same_graph(back.to_networkx(), h)
    assert back.node_ids.tolist() == [40, 7]


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        ({"node_pixel": [[0.0, 0.0], [0.0, 2.0]]}, TypeError, "node_pixel: expected an integer"),
        ({"node_pixel": [[0, 0, 0], [0, 2, 0]]}, ValueError, "node_pixel: expected shape"),
        ({"node_kind": [1]}, ValueError, r"node_kind: expected shape \(2,\), received"),
        ({"node_kind": [1, 4]}, ValueError, "node_kind: expected codes"),
        ({"node_kind": [1, 259]}, ValueError, "node_kind: expected codes"),
        ({"node_world": [[True, False], [True, True]]}, TypeError, "node_world"),
        ({"node_ids": [3, 3]}, ValueError, "node_ids: expected distinct"),
        ({"edge_v": [2]}, ValueError, r"edge_v: expected node indices in \[0, 2\)"),
        ({"edge_u": [-1]}, ValueError, "edge_u: expected node indices"),
        ({"path_offsets": [0, 2]}, ValueError, "path_offsets: expected non-decreasing"),
        ({"path_offsets": [1, 3]}, ValueError, "path_offsets"),
        ({"edge_length_m": [1.0, 2.0]}, ValueError, "edge_length_m: expected shape"),
        ({"edge_keys": [0.5]}, TypeError, "edge_keys"),
        ({"member_offsets": [0, 1, 2]}, ValueError, "both or neither"),
        (
            {"member_offsets": [0, 1, 3], "member_pixels": [[0, 0], [0, 2]]},
            ValueError,
            "member_offsets: expected non-decreasing offsets from 0 to 2",
        ),
    ],
)
def test_constructor_checks(change, error, match):
    fields = _fields(FIXTURES[0][3])
    fields.update(node_ids=None, edge_keys=None)
    fields.update(change)
    with pytest.raises(error, match=match):
        GraphStore(**fields)


def test_repeated_keys_of_a_node_pair_are_refused():
    fields = _fields(FIXTURES[0][3])
    two = dict(
        edge_u=[0, 1],
        edge_v=[1, 0],
        path_offsets=[0, 3, 6],
        path_pixels=np.concatenate([fields["path_pixels"], fields["path_pixels"][::-1]]),
        path_world=np.concatenate([fields["path_world"], fields["path_world"][::-1]]),
        edge_length_m=[2.0, 2.0],
        edge_min_clearance_m=[np.nan] * 2,
        edge_mean_clearance_m=[np.nan] * 2,
    )
    fields.update(two)
    assert GraphStore(**{**fields, "edge_keys": None}).edge_keys.tolist() == [0, 1]
    with pytest.raises(ValueError, match="distinct keys per node pair"):
        GraphStore(**{**fields, "edge_keys": [5, 5]})


def test_from_networkx_refuses_what_it_cannot_hold():
    g = skeleton_to_graph(T)
    with pytest.raises(TypeError, match="undirected networkx.MultiGraph"):
        GraphStore.from_networkx(nx.MultiDiGraph(g))
    with pytest.raises(TypeError, match="undirected networkx.MultiGraph"):
        GraphStore.from_networkx(nx.Graph(g))
    named = nx.relabel_nodes(g, {0: "a"})
    with pytest.raises(TypeError, match="integer nodes"):
        GraphStore.from_networkx(named)
    extra = g.copy()
    extra.nodes[1]["note"] = "x"
    with pytest.raises(ValueError, match=r"vertex 1 .*others \['note'\]"):
        GraphStore.from_networkx(extra)
    missing = g.copy()
    del missing.edges[0, 1, 0]["world"]
    with pytest.raises(ValueError, match=r"edge 0-1 \(key 0\) .*missing \['world'\]"):
        GraphStore.from_networkx(missing)
    odd = g.copy()
    odd.nodes[0]["kind"] = "corner"
    with pytest.raises(ValueError, match="vertex kinds"):
        GraphStore.from_networkx(odd)
    keyed = nx.MultiGraph()
    keyed.add_nodes_from(g.nodes(data=True))
    keyed.add_edge(0, 1, key="a", **g.edges[0, 1, 0])
    with pytest.raises(TypeError, match="integer edge keys"):
        GraphStore.from_networkx(keyed)


@pytest.mark.parametrize(
    "where, name, value",
    [
        ("edge", "path", np.array([[1, 1, 1], [1, 2, 1]])),  # six numbers: not three pixels
        ("edge", "world", np.zeros((2, 3))),
        ("vertex", "pixel", (1, 1, 0)),
        ("vertex", "world", (0.0, 0.0, 0.0)),
        ("vertex", "pixels", np.array([[1, 1, 0, 2]])),
    ],
)
def test_from_networkx_refuses_points_that_are_not_pairs(where, name, value):
    g = skeleton_to_graph(T)
    owner = g.edges[0, 1, 0] if where == "edge" else g.nodes[0]
    owner[name] = value
    at = r"edge 0-1 \(key 0\)" if where == "edge" else "vertex 0"
    with pytest.raises(
        ValueError, match=rf"graph: expected {at} to have '{name}' of shape \(K, 2\)"
    ):
        GraphStore.from_networkx(g)


def test_pruned_graphs_round_trip():
    skel = art("""
        ..........
        .########.
        .#......#.
        .#......##
        .########.
        ...#......
    """)
    g = skeleton_to_graph(skel, clearance_px=np.ones(skel.shape), resolution_m=0.1)
    pruned = prune_graph(g, min_spur_m=0.25)
    assert pruned.number_of_nodes() < g.number_of_nodes()
    assert_same_graph(GraphStore.from_networkx(pruned).to_networkx(), pruned)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    arrays(np.bool_, st.tuples(st.integers(1, 10), st.integers(1, 10)), elements=st.booleans()),
    st.booleans(),
    st.booleans(),
)
def test_round_trip_on_random_skeletons(skel, merge, with_clearance):
    from topojax.graph.build import _skeleton_store

    clearance = np.arange(skel.size, dtype=np.float64).reshape(skel.shape) % 5
    kw = {"merge_junction_clusters": merge, "resolution_m": 0.25}
    if with_clearance:
        kw["clearance_px"] = clearance
    g = skeleton_to_graph(skel, **kw)
    store = GraphStore.from_networkx(g)
    assert (store.n_nodes, store.n_edges) == (g.number_of_nodes(), g.number_of_edges())
    assert_same_graph(store.to_networkx(), g)
    flat = np.flatnonzero(skel.ravel())
    built = _skeleton_store(
        skel.shape, flat, clearance.ravel()[flat] if with_clearance else None, 0.25, None, merge
    )
    assert_same_store(built, store)


# ----------------------------------------------------------------------------------------
# stores of pixels and kinds only (the incremental mapper's global graph), empty stores
# ----------------------------------------------------------------------------------------

_METRICS = (
    "node_world",
    "node_clearance_m",
    "path_world",
    "edge_length_m",
    "edge_min_clearance_m",
    "edge_mean_clearance_m",
)


def test_store_without_metric_arrays_gives_pixels_kinds_and_paths_only():
    full = FIXTURES[1][3]  # the T
    fields = {k: v for k, v in _fields(full).items() if k not in _METRICS}
    fields.update(node_ids=[30, 10, 20, 40], edge_keys=[7, 5, 6])
    store = GraphStore(**fields)
    assert full.has_metrics and not store.has_metrics
    assert all(getattr(store, name) is None for name in _METRICS)
    np.testing.assert_array_equal(store.path(1), full.path(1))
    g = store.to_networkx()
    ids, reference = [30, 10, 20, 40], full.to_networkx()
    want = nx.MultiGraph(**full.attrs)
    for n, d in zip(ids, reference.nodes.values(), strict=True):
        want.add_node(n, pixel=d["pixel"], kind=d["kind"])
    for (u, v, d), key in zip(reference.edges(data=True), [7, 5, 6], strict=True):
        want.add_edge(ids[u], ids[v], key=key, path=d["path"])
    assert_same_graph(g, want)
    for _, _, path in g.edges(data="path"):
        assert path.dtype == np.int32 and path.flags.writeable
        assert not np.shares_memory(path, store.path_pixels)


@pytest.mark.parametrize("name", _METRICS)
def test_metric_arrays_come_all_together_or_not_at_all(name):
    fields = _fields(FIXTURES[1][3])
    with pytest.raises(ValueError, match=f"expected all or none, received none for \\['{name}'\\]"):
        GraphStore(**{**fields, name: None})


def test_member_pixels_need_the_metric_arrays():
    fields = {k: v for k, v in _fields(FIXTURES[5][3]).items() if k not in _METRICS}
    assert fields["member_pixels"] is not None
    with pytest.raises(ValueError, match="expected only with the metric arrays"):
        GraphStore(**fields)


def test_empty_store_is_the_empty_skeletons_store():
    g = skeleton_to_graph(np.zeros((3, 4), bool))
    empty = GraphStore.empty(g.graph)
    assert empty.has_metrics and (empty.n_nodes, empty.n_edges) == (0, 0)
    assert_same_store(empty, FIXTURES[-1][3])
    assert_same_graph(empty.to_networkx(), g)
    assert GraphStore.empty().attrs == {} and GraphStore.empty().to_networkx().graph == {}


# ----------------------------------------------------------------------------------------
# waypoints: the simplified world polyline on each edge of a route graph
# ----------------------------------------------------------------------------------------

#: A literal floor plan ('#' wall, '.' free), each character 8 x 8 pixels of 0.05 m: two
#: rooms with pillars, joined by a door, 8 m x 16 m.
PLAN = """
    ####################
    #........#.........#
    #........#.........#
    #..##....#....#....#
    #..##..............#
    #..................#
    #........#.........#
    #........#....##...#
    #........#.........#
    ####################
"""


def plan_map():
    from topojax.maps.occupancy import OccupancyMap

    free = np.kron(~art(PLAN), np.ones((8, 8), bool))
    return OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=0.05)


def with_waypoints(store: GraphStore) -> dict:
    """The fields of ``store`` plus waypoints: each edge's first and last world point."""
    fields = _fields(store)
    ends = np.stack([store.path_offsets[:-1], store.path_offsets[1:] - 1], axis=1).ravel()
    fields.update(
        waypoint_offsets=np.arange(0, 2 * store.n_edges + 1, 2),
        waypoints=store.path_world[ends],
    )
    return fields


def test_a_route_graph_round_trips_through_a_store():
    from topojax.routegraph import route_graph

    g = route_graph(plan_map(), robot_radius_m=0.3)
    assert g.graph["kind"] == "route_graph" and g.number_of_edges() > 10
    assert any(len(d["pixels"]) > 1 for _, d in g.nodes(data=True))  # merged members
    store = GraphStore.from_networkx(g)
    assert store.waypoints.dtype == np.float64 and store.waypoints.shape[1] == 2
    assert store.waypoint_offsets.shape == (store.n_edges + 1,)
    assert not store.waypoints.flags.writeable and not store.waypoint_offsets.flags.writeable
    back = store.to_networkx()
    assert_same_graph(back, g)
    for (_, _, a), (_, _, b) in zip(
        g.edges(data="waypoints"), back.edges(data="waypoints"), strict=True
    ):
        assert a.tobytes() == b.tobytes()  # bit for bit
        assert b.flags.writeable and not np.shares_memory(b, store.waypoints)
    assert_same_store(GraphStore.from_networkx(back), store)


def test_a_store_without_waypoints_has_none():
    store = GraphStore.from_networkx(skeleton_to_graph(T))
    assert store.waypoints is None and store.waypoint_offsets is None
    assert all("waypoints" not in d for _, _, d in store.to_networkx().edges(data=True))


def test_waypoints_of_a_hand_written_store():
    fields = with_waypoints(FIXTURES[1][3])  # the T
    store = GraphStore(**fields)
    np.testing.assert_array_equal(store.waypoint_offsets, [0, 2, 4, 6])
    g = store.to_networkx()
    for i, (_, _, d) in enumerate(g.edges(data=True)):
        assert list(d)[-1] == "waypoints"
        np.testing.assert_array_equal(d["waypoints"], fields["waypoints"][2 * i : 2 * i + 2])
    assert_same_graph(GraphStore.from_networkx(g).to_networkx(), g)


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        ({"waypoints": None}, ValueError, "waypoint_offsets, waypoints: expected both or neither"),
        ({"waypoint_offsets": None}, ValueError, "expected both or neither"),
        (
            {"waypoints": np.zeros((6, 3))},
            ValueError,
            r"waypoints: expected shape \(6, 2\), received shape \(6, 3\)",
        ),
        ({"waypoints": np.zeros((6, 2), bool)}, TypeError, "waypoints: expected a real array"),
        ({"waypoint_offsets": [0, 2, 4]}, ValueError, r"waypoint_offsets: expected shape \(4,\)"),
        (
            {"waypoint_offsets": [0, 2, 4, 7]},
            ValueError,
            "waypoint_offsets: expected non-decreasing offsets from 0 to 6",
        ),
        ({"waypoint_offsets": [0, 4, 2, 6]}, ValueError, r"waypoint_offsets: .*\(decreasing\)"),
        (
            {"waypoint_offsets": [0.0, 2.0, 4.0, 6.0]},
            TypeError,
            "waypoint_offsets: expected an integer",
        ),
    ],
)
def test_waypoint_checks(change, error, match):
    with pytest.raises(error, match=match):
        GraphStore(**{**with_waypoints(FIXTURES[1][3]), **change})


def test_waypoints_need_the_metric_arrays():
    fields = {k: v for k, v in with_waypoints(FIXTURES[1][3]).items() if k not in _METRICS}
    with pytest.raises(
        ValueError, match=r"waypoint_offsets, waypoints: expected only with the metric"
    ):
        GraphStore(**fields)


def test_from_networkx_refuses_waypoints_on_only_some_edges():
    g = skeleton_to_graph(T)
    first = next(iter(g.edges(keys=True, data=True)))
    first[3]["waypoints"] = np.asarray(first[3]["world"])[[0, -1]]
    with pytest.raises(
        ValueError, match=r"graph: expected 'waypoints' on every edge or on none, received 1 of 3"
    ):
        GraphStore.from_networkx(g)
    odd = skeleton_to_graph(T)
    for _, _, d in odd.edges(data=True):
        d["waypoints"] = np.zeros((2, 3))
    with pytest.raises(ValueError, match=r"graph: expected edge .* 'waypoints' of shape \(K, 2\)"):
        GraphStore.from_networkx(odd)


def test_the_networkx_memory_check_counts_the_waypoints(monkeypatch):
    import topojax.graph.store as store_module

    asked = []
    monkeypatch.setattr(
        store_module, "check_fits_memory", lambda n, what, advice: asked.append((n, what))
    )
    plain = FIXTURES[1][3]
    store = GraphStore(**with_waypoints(plain))
    plain.to_networkx()
    store.to_networkx()
    (without, what_without), (with_wp, what_with) = asked
    assert without == store_module.NX_BYTES_PER_ELEMENT * (plain.n_nodes + plain.n_edges)
    extra = store_module.NX_WAYPOINT_BYTES_PER_EDGE * store.n_edges + store.waypoints.nbytes
    assert with_wp == without + extra
    assert "waypoints" not in what_without and "waypoints" in what_with
