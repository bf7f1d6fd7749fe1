"""Tests for topojax.io: save_graph / load_graph round trips (GraphML, JSON, GeoJSON)."""

from __future__ import annotations

import errno
import json
import math
import os
import re
from pathlib import Path

import ml_dtypes
import networkx as nx
import numpy as np
import pytest

import topojax as tj
from topojax._fs import atomic_write, atomic_write_bytes
from topojax.io import load_graph, save_graph

FORMATS = (".graphml", ".json", ".geojson")


# ---------------------------------------------------------------------- graph builders


def _edge_attrs(path: np.ndarray, rng: np.random.Generator) -> dict:
    world = np.stack([path[:, 1] * 0.05 / 3.0 + 1e-13, 123456.789 - path[:, 0] / 7.0], axis=1)
    clear = rng.random(len(path)) / 3.0
    seg = np.diff(world, axis=0)
    return {
        "path": path.astype(np.int64),
        "world": world.astype(np.float64),
        "length_m": float(np.hypot(seg[:, 0], seg[:, 1]).sum()),
        "min_clearance_m": float(clear.min()),
        "mean_clearance_m": float(clear.mean()),
    }


def make_graph() -> nx.MultiGraph:
    """Hand-made topology graph: parallel edges, a self-loop, isolated node, odd ids/keys."""
    rng = np.random.default_rng(42)
    g = nx.MultiGraph(resolution_m=0.05, origin=(1.5, -2.0, 0.1), shape=(100, 200))
    g.graph["name"] = "hand-made"
    g.graph["n_tiles"] = 4
    g.graph["thin_method"] = "guo_hall"
    g.graph["float_exact"] = 1.0 / 3.0
    nodes = {
        10: ((5, 7), "junction"),
        3: ((40, 60), "junction"),
        42: ((80, 20), "end"),
        7: ((50, 150), "isolated"),
        0: ((20, 100), "ring"),
    }
    for n, (pix, kind) in nodes.items():
        g.add_node(
            n,
            pixel=pix,
            world=(1.5 + (pix[1] + 0.5) * 0.05 / 3.0, -2.0 + (100 - pix[0] - 0.5) / 7.0),
            kind=kind,
            clearance_m=float(rng.random() / 7.0),
        )
    # Two parallel edges between 10 and 3 with different paths, keys 0 and 5.
    p1 = np.array([[5, 7], [6, 8], [7, 9], [20, 30], [40, 60]])
    p2 = np.array([[5, 7], [4, 8], [30, 50], [40, 60]])
    g.add_edge(10, 3, key=0, **_edge_attrs(p1, rng))
    g.add_edge(10, 3, key=5, **_edge_attrs(p2, rng))
    g.add_edge(3, 42, **_edge_attrs(np.array([[40, 60], [60, 40], [80, 20]]), rng))
    # Self-loop: closed ring, ends included.
    ring = np.array([[20, 100], [20, 101], [21, 102], [22, 101], [21, 100], [20, 100]])
    g.add_edge(0, 0, key=2, **_edge_attrs(ring, rng))
    return g


def make_edgeless() -> nx.MultiGraph:
    g = nx.MultiGraph(resolution_m=0.1, origin=(0.0, 0.0, 0.0), shape=(3, 4))
    g.add_node(1, pixel=(1, 2), world=(0.25, 0.15), kind="isolated", clearance_m=0.1)
    g.add_node(0, pixel=(0, 0), world=(0.05, 0.25), kind="isolated", clearance_m=0.05)
    return g


# ---------------------------------------------------------------------- comparison


def _assert_value_equal(a, b, where: str) -> None:
    if isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray), where
        assert a.dtype == b.dtype, where
        assert a.shape == b.shape, where
        if np.issubdtype(a.dtype, np.integer):
            assert np.array_equal(a, b), where
        else:
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-12, err_msg=where)
            assert np.array_equal(a, b), where  # shortest-repr floats are exact
        return
    assert type(a) is type(b), f"{where}: {type(a)} vs {type(b)}"
    if isinstance(a, tuple):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_value_equal(x, y, f"{where}[{i}]")
    elif isinstance(a, float):
        assert abs(a - b) <= 1e-12 and a == b, where
    else:
        assert a == b, where


def assert_graphs_equal(a: nx.MultiGraph, b: nx.MultiGraph, *, skip_edge=()) -> None:
    assert isinstance(b, nx.MultiGraph) and not b.is_directed()
    assert list(a.nodes) == list(b.nodes)
    assert all(type(n) is int for n in b.nodes)
    for n in a.nodes:
        assert set(a.nodes[n]) == set(b.nodes[n]), n
        for k, v in a.nodes[n].items():
            _assert_value_equal(v, b.nodes[n][k], f"node {n} {k}")
    ea = list(a.edges(keys=True))
    eb = list(b.edges(keys=True))
    assert ea == eb
    for u, v, k in ea:
        da, db = a.edges[u, v, k], b.edges[u, v, k]
        assert set(da) - set(skip_edge) == set(db) - set(skip_edge), (u, v, k)
        for name, val in da.items():
            if name not in skip_edge:
                _assert_value_equal(val, db[name], f"edge {(u, v, k)} {name}")
    assert set(a.graph) == set(b.graph)
    for name, val in a.graph.items():
        _assert_value_equal(val, b.graph[name], f"graph {name}")


# ---------------------------------------------------------------------- round trips


@pytest.mark.parametrize("suffix", FORMATS)
def test_round_trip_hand_made(tmp_path: Path, suffix: str):
    g = make_graph()
    out = save_graph(g, tmp_path / f"g{suffix}")
    assert out == tmp_path / f"g{suffix}"
    back = load_graph(out)
    assert_graphs_equal(g, back)
    # Types required by the schema.
    for _, d in back.nodes(data=True):
        assert all(type(x) is int for x in d["pixel"])
        assert all(type(x) is float for x in d["world"])
        assert type(d["clearance_m"]) is float and type(d["kind"]) is str
    for _, _, d in back.edges(data=True):
        assert d["path"].dtype == np.int64 and d["path"].shape[1] == 2
        assert d["world"].dtype == np.float64 and d["world"].shape == d["path"].shape
    assert back.graph["origin"] == (1.5, -2.0, 0.1)
    assert back.graph["shape"] == (100, 200)
    # Multi-edge structure.
    assert back.number_of_edges(10, 3) == 2
    assert set(back[10][3]) == {0, 5}
    assert back.has_edge(0, 0, key=2)
    assert back.degree(7) == 0
    # Only the target file exists (atomic write leaves no temporary files).
    assert [p.name for p in tmp_path.iterdir()] == [f"g{suffix}"]


@pytest.mark.parametrize("suffix", FORMATS)
def test_a_loaded_graph_saves_to_the_same_bytes(tmp_path: Path, suffix: str):
    """save, load, save gives the first file byte for byte, also in GeoJSON, whose
    ``world`` comes from the geometry apart from the other attributes: the attributes keep
    their written order, so a graph passed through a file does not churn in a diff."""
    g = make_graph()
    first = save_graph(g, tmp_path / f"a{suffix}")
    again = save_graph(load_graph(first), tmp_path / f"b{suffix}")
    assert again.read_bytes() == first.read_bytes()
    back = load_graph(again)
    assert [list(d) for _, d in back.nodes(data=True)] == [list(d) for _, d in g.nodes(data=True)]


@pytest.mark.parametrize("suffix", FORMATS)
def test_round_trip_edgeless_and_empty(tmp_path: Path, suffix: str):
    g = make_edgeless()
    back = load_graph(save_graph(g, tmp_path / f"e{suffix}"))
    assert_graphs_equal(g, back)
    assert back.number_of_edges() == 0
    empty = nx.MultiGraph()
    back = load_graph(save_graph(empty, tmp_path / f"empty{suffix}"))
    assert back.number_of_nodes() == 0 and back.number_of_edges() == 0
    assert dict(back.graph) == {}


@pytest.mark.parametrize("suffix", FORMATS)
def test_round_trip_extra_attribute_types(tmp_path: Path, suffix: str):
    g = make_graph()
    g.graph["flag"] = True
    g.graph["maybe"] = None
    g.graph["params"] = {"sigma_px": 2.5, "method": "zhang", "sizes": [1, 2]}
    g.graph["big_int"] = 2**40
    g.graph["np_scalar"] = np.float32(0.5)
    for n in g.nodes:
        g.nodes[n]["degree_hint"] = np.int64(3)
        g.nodes[n]["tags"] = ["a", "b"]
    for u, v, k in g.edges(keys=True):
        g.edges[u, v, k]["clearance_px"] = np.linspace(0.5, 2.0, len(g.edges[u, v, k]["path"]))
        g.edges[u, v, k]["mask"] = np.ones(3, dtype=bool)
        g.edges[u, v, k]["pixels32"] = g.edges[u, v, k]["path"].astype(np.int32)
    back = load_graph(save_graph(g, tmp_path / f"x{suffix}"))
    expected = g.copy()
    expected.graph["np_scalar"] = 0.5  # numpy scalars come back as Python scalars
    for n in expected.nodes:
        expected.nodes[n]["degree_hint"] = 3
    assert_graphs_equal(expected, back)


@pytest.mark.parametrize("suffix", FORMATS)
def test_arrays_of_mixed_dtypes_come_back_with_their_values(tmp_path: Path, suffix: str):
    # Arrays of several dtypes in one attribute are saved in NumPy's common dtype; where
    # that holds every value (int32 beside int64, small uint64 beside int64) they come back
    # in it, equal.
    g = make_graph()
    edges = list(g.edges(keys=True))
    for i, e in enumerate(edges):
        g.edges[e]["ids"] = np.array([i, 7], np.int32 if i % 2 else np.int64)
        g.edges[e]["counts"] = np.array([i, 2**40], np.uint64 if i % 2 else np.int64)
    back = load_graph(save_graph(g, tmp_path / f"m{suffix}"))
    for i, e in enumerate(edges):
        assert back.edges[e]["ids"].dtype == np.int64
        assert back.edges[e]["ids"].tolist() == [i, 7]
        assert back.edges[e]["counts"].tolist() == [i, 2**40]


@pytest.mark.parametrize("suffix", FORMATS)
def test_arrays_whose_common_dtype_would_change_a_value_are_refused(tmp_path: Path, suffix):
    # uint64 beside int64 is float64 to NumPy, which rounds 2**64 - 1 and 2**53 + 1: the
    # file would give back other numbers than were saved.
    g = make_graph()
    (a, b, *_) = list(g.edges(keys=True))
    g.edges[a]["counts"] = np.array([2**64 - 1], np.uint64)
    g.edges[b]["counts"] = np.array([-1], np.int64)
    target = tmp_path / f"m{suffix}"
    with pytest.raises(ValueError, match=r"edge attribute 'counts'.*int64, uint64.*float64"):
        save_graph(g, target)
    assert not target.exists()
    g.edges[a]["counts"] = np.array([2**53 + 1], np.int64)
    g.edges[b]["counts"] = np.array([0.5])
    with pytest.raises(ValueError, match=r"edge attribute 'counts'.*9007199254740993"):
        save_graph(g, target)


@pytest.mark.parametrize("suffix", FORMATS)
def test_plain_graph_and_str_ids(tmp_path: Path, suffix: str):
    g = nx.Graph()
    g.add_node(1, world=(0.0, 1.0))
    g.add_node(2, world=(1.0, 1.0))
    g.add_edge(1, 2, world=np.array([[0.0, 1.0], [1.0, 1.0]]), length_m=1.0)
    back = load_graph(save_graph(g, tmp_path / f"p{suffix}"))
    assert isinstance(back, nx.MultiGraph)
    assert list(back.edges(keys=True)) == [(1, 2, 0)]
    s = nx.MultiGraph()
    s.add_node("a", world=(0.0, 0.0))
    s.add_node("b", world=(2.0, 0.0))
    s.add_edge("a", "b", key="main", world=np.array([[0.0, 0.0], [2.0, 0.0]]))
    back = load_graph(save_graph(s, tmp_path / f"s{suffix}"))
    assert list(back.edges(keys=True)) == [("a", "b", "main")]


def test_format_argument_overrides_suffix(tmp_path: Path):
    g = make_graph()
    path = save_graph(g, tmp_path / "graph.txt", format="json")
    assert json.loads(path.read_text())["multigraph"] is True
    assert_graphs_equal(g, load_graph(path, format="json"))
    with pytest.raises(ValueError, match="format"):
        save_graph(g, tmp_path / "g.json", format="yaml")
    for wrong in (3, True, ["json"]):  # read as the text '3', 'true', "['json']"
        with pytest.raises(TypeError, match=r"^format: expected a str, received"):
            save_graph(g, tmp_path / "g.json", format=wrong)
        with pytest.raises(TypeError, match=r"^format: expected a str, received"):
            load_graph(path, format=wrong)
    with pytest.raises(ValueError, match=r"^path: expected a graph file suffix, one of .*\.json"):
        save_graph(g, tmp_path / "graph.txt")


# ---------------------------------------------------------------------- format validity


def test_json_is_node_link_readable_by_networkx(tmp_path: Path):
    g = make_graph()
    path = save_graph(g, tmp_path / "g.json")
    doc = json.loads(path.read_text())
    assert doc["directed"] is False and doc["multigraph"] is True
    h = nx.node_link_graph(doc, edges="edges")
    assert isinstance(h, nx.MultiGraph)
    assert sorted(h.nodes) == sorted(g.nodes)
    assert sorted(h.edges(keys=True)) == sorted(g.edges(keys=True))
    # Arrays are nested lists in the file.
    e = h.edges[10, 3, 5]
    assert e["path"] == g.edges[10, 3, 5]["path"].tolist()


def test_graphml_is_readable_by_networkx(tmp_path: Path):
    g = make_graph()
    path = save_graph(g, tmp_path / "g.graphml")
    h = nx.read_graphml(path, node_type=int, force_multigraph=True)
    assert sorted(h.nodes) == sorted(g.nodes)
    assert h.number_of_edges() == g.number_of_edges()
    assert isinstance(h.nodes[42]["clearance_m"], float)
    lengths = sorted(d["length_m"] for _, _, d in h.edges(data=True))
    assert lengths == sorted(d["length_m"] for _, _, d in g.edges(data=True))
    # path is a JSON string in GraphML.
    paths = sorted(json.dumps(d["path"].tolist()) for _, _, d in g.edges(data=True))
    assert sorted(json.dumps(json.loads(d["path"])) for _, _, d in h.edges(data=True)) == paths


def test_graphml_spells_booleans_and_special_doubles_as_xml_schema(tmp_path: Path):
    # GraphML types its values with XML Schema, whose boolean is true / false and whose
    # double spells NaN, INF and -INF; Python's True and nan are no such values (a Java
    # reader refuses them). networkx and topojax read the XML Schema spellings back.
    g = make_graph()
    g.graph["flag"] = True
    for n, value in zip(g.nodes, [math.nan, math.inf, -math.inf, 0.5, 1e300], strict=False):
        g.nodes[n]["score"] = value
        g.nodes[n]["seen"] = value == 0.5
    path = save_graph(g, tmp_path / "g.graphml")
    texts = re.findall(r">([^<]*)</data>", path.read_text())
    for spelling in ("true", "false", "NaN", "INF", "-INF"):
        assert spelling in texts
    assert not {"True", "False", "nan", "inf", "-inf"} & set(texts)
    back = load_graph(path)
    assert back.graph["flag"] is True
    theirs = nx.read_graphml(path, node_type=int, force_multigraph=True)
    for n, d in g.nodes(data=True):
        for h in (back, theirs):
            assert h.nodes[n]["seen"] is d["seen"]
            assert h.nodes[n]["score"] == d["score"] or math.isnan(h.nodes[n]["score"])


def test_graphml_long_values_are_those_xml_schema_long_holds(tmp_path: Path):
    # GraphML's long is XML Schema's, 64 bits: an int beyond it in a long column is no
    # long value (Java's readers refuse it). Such an attribute is written as JSON text
    # and read back as the same ints.
    import xml.etree.ElementTree as ET

    g = make_graph()
    g.graph["big"] = 2**70
    g.graph["small"] = -(2**63)
    for i, n in enumerate(g.nodes):
        g.nodes[n]["count"] = 2**64 - 1 if i == 0 else i
    path = save_graph(g, tmp_path / "g.graphml")
    ns = "{http://graphml.graphdrawing.org/xmlns}"
    root = ET.parse(path).getroot()
    long_keys = {k.get("id") for k in root.iter(f"{ns}key") if k.get("attr.type") == "long"}
    for data in root.iter(f"{ns}data"):
        if data.get("key") in long_keys:
            assert -(2**63) <= int(data.text) < 2**63
    back = load_graph(path)
    assert back.graph["big"] == 2**70 and back.graph["small"] == -(2**63)
    assert [d["count"] for _, d in back.nodes(data=True)] == [
        d["count"] for _, d in g.nodes(data=True)
    ]
    assert all(type(d["count"]) is int for _, d in back.nodes(data=True))


def test_graphml_double_columns_keep_ints_a_double_cannot_hold(tmp_path: Path):
    # An attribute of ints and floats is a GraphML double column; an int a double does
    # not hold exactly (2**53 + 1, rounded) or at all (2**1100, an OverflowError) makes
    # it a column of JSON text instead, whose numbers come back as they were.
    g = make_graph()
    values = [0.5, 2**53 + 1, 2**1100, -3, 1e300]
    assert g.number_of_nodes() >= len(values)
    for n, value in zip(g.nodes, values, strict=False):
        g.nodes[n]["score"] = value
    back = load_graph(save_graph(g, tmp_path / "g.graphml"))
    for n, d in g.nodes(data=True):
        assert back.nodes[n]["score"] == d["score"]
        assert type(back.nodes[n]["score"]) is type(d["score"])


def _strict_json(text: str):
    def bad_constant(name):
        raise AssertionError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=bad_constant)


def test_geojson_structure(tmp_path: Path):
    g = make_graph()
    path = save_graph(g, tmp_path / "g.geojson")
    doc = _strict_json(path.read_text())
    assert doc["type"] == "FeatureCollection"
    feats = doc["features"]
    points = [f for f in feats if f["geometry"]["type"] == "Point"]
    lines = [f for f in feats if f["geometry"]["type"] == "LineString"]
    assert len(points) == g.number_of_nodes()
    assert len(lines) == g.number_of_edges()
    assert len(points) + len(lines) == len(feats)
    for f in feats:
        assert f["type"] == "Feature"
        assert isinstance(f["properties"], dict)
    for f in points:
        props = f["properties"]
        n = props["id"]
        # Coordinate order is (x, y).
        assert f["geometry"]["coordinates"] == list(g.nodes[n]["world"])
        assert props["kind"] == g.nodes[n]["kind"]
        assert props["clearance_m"] == g.nodes[n]["clearance_m"]
        assert props["pixel"] == list(g.nodes[n]["pixel"])
    for f in lines:
        props = f["properties"]
        u, v, k = props["u"], props["v"], props["key"]
        d = g.edges[u, v, k]
        coords = np.asarray(f["geometry"]["coordinates"])
        assert coords.shape[1] == 2 and coords.shape[0] >= 2
        assert np.array_equal(coords, d["world"])
        assert props["length_m"] == d["length_m"]
        assert props["min_clearance_m"] == d["min_clearance_m"]
        assert props["mean_clearance_m"] == d["mean_clearance_m"]
        assert props["path"] == d["path"].tolist()
        if u == v:
            assert coords[0].tolist() == coords[-1].tolist()  # closed ring
    # x really is the first coordinate: node 42 is at column 20 -> small x, row 80 -> small y.
    p42 = next(f for f in points if f["properties"]["id"] == 42)["geometry"]["coordinates"]
    p7 = next(f for f in points if f["properties"]["id"] == 7)["geometry"]["coordinates"]
    assert p42[0] < p7[0]  # col 20 < col 150
    assert p42[1] < p7[1]  # row 80 is lower than row 50


def test_geojson_closes_open_self_loop_and_restores_it(tmp_path: Path):
    g = nx.MultiGraph()
    g.add_node(0, world=(0.0, 0.0))
    open_ring = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    g.add_edge(0, 0, world=open_ring, path=np.array([[0, 0], [0, 1], [1, 1], [1, 0]]))
    path = save_graph(g, tmp_path / "ring.geojson")
    doc = _strict_json(path.read_text())
    line = next(f for f in doc["features"] if f["geometry"]["type"] == "LineString")
    coords = line["geometry"]["coordinates"]
    assert coords[0] == coords[-1] and len(coords) == 5
    back = load_graph(path)
    assert np.array_equal(back.edges[0, 0, 0]["world"], open_ring)
    assert "closed_by_writer" not in back.edges[0, 0, 0]


def test_load_foreign_node_link_without_schema(tmp_path: Path):
    g = nx.MultiGraph(origin=[0.0, 1.0, 0.0])
    g.add_node(0, pixel=[1, 2], world=[0.5, 0.25], kind="end")
    g.add_node(1, pixel=[3, 4], world=[1.5, 0.75], kind="end")
    g.add_edge(0, 1, path=[[1, 2], [2, 3], [3, 4]], world=[[0.5, 0.25], [1.0, 0.5], [1.5, 0.75]])
    data = nx.node_link_data(g, edges="edges")
    path = tmp_path / "foreign.json"
    path.write_text(json.dumps(data))
    back = load_graph(path)
    assert back.nodes[0]["pixel"] == (1, 2)
    assert back.nodes[1]["world"] == (1.5, 0.75)
    assert back.graph["origin"] == (0.0, 1.0, 0.0)
    e = back.edges[0, 1, 0]
    assert e["path"].dtype == np.int64 and e["path"].shape == (3, 2)
    assert e["world"].dtype == np.float64


# ---------------------------------------------------------------------- errors


def test_unknown_suffix_lists_supported(tmp_path: Path):
    with pytest.raises(ValueError, match=r"\.geojson.*\.graphml.*\.json"):
        save_graph(make_graph(), tmp_path / "g.csv")
    (tmp_path / "g.xml").write_text("<graph/>")
    with pytest.raises(ValueError, match=r"\.xml"):
        load_graph(tmp_path / "g.xml")
    with pytest.raises(FileNotFoundError, match="h.xml"):  # missing, whatever the suffix
        load_graph(tmp_path / "h.xml")
    with pytest.raises(ValueError, match="^path: expected a file, received the folder"):
        load_graph(tmp_path)


def test_load_graph_says_a_symlink_loop_is_one(tmp_path: Path):
    loop = tmp_path / "loop.json"
    loop.symlink_to("loop.json")
    with pytest.raises(ValueError) as info:
        load_graph(loop)
    assert str(info.value) == f"path: expected a file, received {loop}, a loop of symbolic links"
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to("gone.json")
    with pytest.raises(FileNotFoundError) as info:
        load_graph(dangling)
    assert str(info.value) == (
        f"path: file not found: {dangling} (a symbolic link to gone.json, which does not exist)"
    )


@pytest.mark.parametrize("suffix", [".json", ".geojson"])
def test_a_key_given_twice_in_a_json_graph_is_refused_naming_it(tmp_path: Path, suffix: str):
    path = save_graph(make_graph(), tmp_path / f"g{suffix}")
    text = path.read_text()
    key = "type" if suffix == ".geojson" else "nodes"
    path.write_text(text.rstrip()[:-1] + f', "{key}": []}}')
    with pytest.raises(ValueError) as info:
        load_graph(path)
    assert str(info.value) == (
        f"graph file {path}: key {key!r} is given twice in one object; expected each key once"
    )


def test_load_errors(tmp_path: Path):
    with pytest.raises(FileNotFoundError, match="missing.json"):
        load_graph(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="bad.json"):
        load_graph(bad)
    bad_gml = tmp_path / "bad.graphml"
    bad_gml.write_text("<graphml><graph><node")
    with pytest.raises(ValueError, match="bad.graphml"):
        load_graph(bad_gml)
    not_fc = tmp_path / "nofc.geojson"
    not_fc.write_text(json.dumps({"type": "Feature"}))
    with pytest.raises(ValueError, match="FeatureCollection"):
        load_graph(not_fc)
    poly = tmp_path / "poly.geojson"
    poly.write_text(
        json.dumps(
            {
                "type": "FeatureCollection",
                "features": [
                    {
                        "type": "Feature",
                        "geometry": {"type": "Polygon", "coordinates": []},
                        "properties": {},
                    }
                ],
            }
        )
    )
    with pytest.raises(ValueError, match="Polygon"):
        load_graph(poly)
    no_nodes = tmp_path / "nonodes.json"
    no_nodes.write_text(json.dumps({"edges": []}))
    with pytest.raises(ValueError, match="nodes"):
        load_graph(no_nodes)


def _point(node, xy):
    props = {"feature": "node", "id": node}
    return {
        "type": "Feature",
        "geometry": {"type": "Point", "coordinates": xy},
        "properties": props,
    }


def _line(u, v, key):
    geometry = {"type": "LineString", "coordinates": [[0, 0], [1, 1]]}
    props = {"feature": "edge", "u": u, "v": v, "key": key}
    return {"type": "Feature", "geometry": geometry, "properties": props}


_GRAPHML_NODES = '<node id="1"><data key="d0">1.0</data></node><node id="2" />'
_GRAPHML = (
    '<graphml xmlns="http://graphml.graphdrawing.org/xmlns">'
    '<key id="d0" for="node" attr.name="x" attr.type="double" />'
    '<graph edgedefault="undirected">{}</graph></graphml>'
)

#: Files that list a node, or an edge with its key, twice: read one entry at a time, the
#: second would silently overwrite the first's attributes.
_LISTED_TWICE = {
    "node.json": (
        {"nodes": [{"id": 1, "x": 1.0}, {"id": 1, "x": 2.0}], "edges": []},
        "node 1",
    ),
    "edge.json": (
        {
            "nodes": [{"id": 1}, {"id": 2}],
            "edges": [{"source": 1, "target": 2, "key": 0}, {"source": 2, "target": 1, "key": 0}],
        },
        "edge (2, 1, 0)",
    ),
    "node.geojson": (
        {"type": "FeatureCollection", "features": [_point(1, [0, 0]), _point(1, [5, 5])]},
        "node 1",
    ),
    "edge.geojson": (
        {
            "type": "FeatureCollection",
            "features": [_point(1, [0, 0]), _point(2, [1, 1]), _line(1, 2, 0), _line(1, 2, 0)],
        },
        "edge (1, 2, 0)",
    ),
    "node.graphml": (
        _GRAPHML.format(_GRAPHML_NODES + '<node id="1"><data key="d0">2.0</data></node>'),
        "node '1'",
    ),
    "edge.graphml": (
        _GRAPHML.format(
            _GRAPHML_NODES
            + '<edge source="1" target="2" id="0" /><edge source="2" target="1" id="0" />'
        ),
        "edge ('2', '1', '0')",
    ),
}


@pytest.mark.parametrize("name", list(_LISTED_TWICE))
def test_a_node_or_edge_listed_twice_is_refused(tmp_path: Path, name: str):
    doc, what = _LISTED_TWICE[name]
    path = tmp_path / name
    path.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    with pytest.raises(ValueError, match=rf"{re.escape(str(path))}: .*{re.escape(what)}.* twice"):
        load_graph(path)


@pytest.mark.parametrize("suffix", FORMATS)
def test_a_schema_with_an_unknown_id_kind_is_refused_as_the_schema_s_fault(tmp_path, suffix):
    # node id 1 is an int; the file's type schema, edited to "float", is what is wrong
    g = make_graph()
    path = save_graph(g, tmp_path / f"g{suffix}")
    text = path.read_text()
    edited = text.replace('"node_id": "int"', '"node_id": "float"')
    edited = edited.replace(
        "&quot;node_id&quot;: &quot;int&quot;", "&quot;node_id&quot;: &quot;float&quot;"
    )
    assert edited != text
    path.write_text(edited)
    with pytest.raises(
        ValueError, match=r"topojax_schema: node_id: expected 'int' or 'str', received 'float'"
    ):
        load_graph(path)


def test_save_errors(tmp_path: Path):
    with pytest.raises(TypeError, match="^graph: expected an undirected networkx graph, rec"):
        save_graph(nx.MultiDiGraph(), tmp_path / "g.json")
    with pytest.raises(TypeError, match="networkx"):
        save_graph({"nodes": []}, tmp_path / "g.json")  # type: ignore[arg-type]
    g = make_graph()
    g.nodes[3]["obj"] = object()
    with pytest.raises(TypeError, match="obj"):
        save_graph(g, tmp_path / "g.json")
    h = nx.MultiGraph()
    h.add_node((1, 2))
    with pytest.raises(TypeError, match="node id"):
        save_graph(h, tmp_path / "h.graphml")
    no_world = make_graph()
    del no_world.nodes[42]["world"]
    with pytest.raises(ValueError, match="world"):
        save_graph(no_world, tmp_path / "w.geojson")
    nan = make_graph()
    nan.nodes[3]["clearance_m"] = float("nan")
    with pytest.raises(ValueError, match="NaN"):
        save_graph(nan, tmp_path / "n.geojson")
    # NaN is fine in .json / .graphml (Python round-trips it).
    for suffix in (".json", ".graphml"):
        back = load_graph(save_graph(nan, tmp_path / f"n{suffix}"))
        assert np.isnan(back.nodes[3]["clearance_m"])
    assert not (tmp_path / "g.json").exists()
    assert not (tmp_path / "w.geojson").exists()


@pytest.mark.parametrize("suffix", FORMATS)
@pytest.mark.parametrize(
    "array",
    [
        np.array([1 + 2j]),
        np.array(["2020-01-01"], "datetime64[D]"),
        np.array([b"raw"]),
        np.zeros(2, [("a", np.int64)]),
        np.array([object()], object),
        np.array([0.5], ml_dtypes.bfloat16),
        np.array([1 / 3], np.longdouble),
    ],
    ids=["complex", "datetime", "bytes", "structured", "object", "bfloat16", "longdouble"],
)
def test_an_array_of_values_no_file_holds_is_refused_naming_the_attribute(
    tmp_path: Path, suffix: str, array: np.ndarray
):
    # Arrays are saved as JSON lists: a dtype that JSON holds no value of, or one that
    # load_graph cannot read back (structured, bfloat16), is refused naming the attribute.
    g = make_graph()
    g.nodes[3]["odd"] = array
    with pytest.raises(TypeError, match=r"^node 3 attribute 'odd': .*cannot be saved"):
        save_graph(g, tmp_path / f"g{suffix}")
    assert not (tmp_path / f"g{suffix}").exists()


def test_unsupported_graph_attribute_is_skipped_with_warning(tmp_path: Path):
    g = make_graph()
    g.graph["callback"] = print
    with pytest.warns(UserWarning, match="callback"):
        path = save_graph(g, tmp_path / "g.json")
    back = load_graph(path)
    assert "callback" not in back.graph
    assert back.graph["name"] == "hand-made"


def test_atomic_write_keeps_old_file_on_failure(tmp_path: Path, monkeypatch):
    target = tmp_path / "g.json"
    save_graph(make_edgeless(), target)
    before = target.read_bytes()

    def boom(src, dst):
        raise OSError("simulated failure")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError, match="simulated"):
        save_graph(make_graph(), target)
    monkeypatch.undo()
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["g.json"]
    with pytest.raises(FileNotFoundError, match="no_dir"):
        atomic_write_bytes(tmp_path / "no_dir" / "x.bin", b"x")


def test_a_full_disk_names_the_file_it_could_not_write(tmp_path: Path):
    target = tmp_path / "g.json"
    target.write_bytes(b"old")

    def full(fh):
        fh.write(b"part")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(OSError) as info:
        atomic_write(target, full)
    assert info.value.errno == errno.ENOSPC and type(info.value) is OSError
    assert (
        str(info.value) == f"[Errno {errno.ENOSPC}] cannot write {target} (No space left on device)"
    )
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["g.json"]
    # an error that names its file already, or is no OSError, stays as it is
    with pytest.raises(PermissionError) as info:
        atomic_write(target, lambda fh: (_ for _ in ()).throw(PermissionError(13, "no", "x")))
    assert info.value.filename == "x"


def test_atomic_write_under_a_file_says_the_file_is_no_folder(tmp_path: Path):
    (tmp_path / "afile").write_text("x")
    for target in (tmp_path / "afile" / "g.json", tmp_path / "afile" / "sub" / "g.json"):
        with pytest.raises(NotADirectoryError, match=r"afile in .* is a file, not a folder"):
            save_graph(make_graph(), target)
    assert [p.name for p in tmp_path.iterdir()] == ["afile"]


def test_output_folder_on_a_file_names_the_option(tmp_path: Path, capsys):
    from topojax._fs import output_folder
    from topojax.cli import main

    (tmp_path / "afile").write_text("x")
    assert output_folder(tmp_path / "new" / "sub") == tmp_path / "new" / "sub"
    for bad in (tmp_path / "afile", tmp_path / "afile" / "sub"):
        with pytest.raises(NotADirectoryError, match="out_dir: expected a folder to write"):
            output_folder(bad)
    png = str(tj.datasets.sample_map_path("intel"))
    assert main(["graph", png, "-o", str(tmp_path / "afile")]) != 0
    assert "--out: expected a folder to write into" in capsys.readouterr().err
    argv = ["batch", png, "-o", str(tmp_path / "afile"), "--workers", "0", "--no-progress"]
    assert main(argv) != 0
    assert "--out: expected a folder to write into" in capsys.readouterr().err


def test_atomic_write_to_a_folder_says_so_and_leaves_nothing(tmp_path: Path):
    folder = tmp_path / "out"
    folder.mkdir()
    with pytest.raises(IsADirectoryError, match=r"out is a folder: expected a file path"):
        atomic_write_bytes(folder, b"x")
    with pytest.raises(IsADirectoryError, match="^path: expected a file name, received the folder"):
        save_graph(make_graph(), folder, format="json")
    # no temporary file left beside it, and the folder is untouched
    assert [p.name for p in tmp_path.iterdir()] == ["out"]
    assert list(folder.iterdir()) == []


def test_atomic_write_gives_ordinary_file_permissions(tmp_path):
    import os
    import stat

    from topojax._fs import atomic_write_bytes

    mask = os.umask(0o022)
    try:
        target = tmp_path / "out.bin"
        atomic_write_bytes(target, b"abc")
        assert stat.S_IMODE(target.stat().st_mode) == 0o644
        assert target.read_bytes() == b"abc"
    finally:
        os.umask(mask)


def _feature(geometry_type: str, coordinates, **properties) -> dict:
    return {
        "type": "Feature",
        "geometry": {"type": geometry_type, "coordinates": coordinates},
        "properties": properties,
    }


_POINT_A = _feature("Point", [0.0, 0.0], id=1)
_POINT_B = _feature("Point", [1.0, 0.0], id=2)


@pytest.mark.parametrize(
    ("suffix", "doc", "message"),
    [
        (".json", {"directed": True, "nodes": []}, "directed graph"),
        (".json", {"nodes": [{"x": 1}]}, "node entry without 'id'"),
        (".json", {"nodes": [{"id": 1}], "edges": [{"source": 1}]}, "without source/target"),
        (".json", {"nodes": [{"id": 1}], "edges": [{"source": 1, "target": 7}]}, "node 7"),
        (".json", {"nodes": [{"id": True}]}, "node id: expected an int or a str, received True"),
        (".json", {"nodes": [{"id": 1.5}]}, "node id: expected an int or a str, received 1.5"),
        (".json", {"nodes": [{"id": [1, 2]}]}, r"node id: expected an int or a str, received \["),
        (
            ".json",
            {"nodes": [{"id": 1}], "edges": [{"source": 1, "target": 1, "key": 0.5}]},
            "edge key: expected an int or a str, received 0.5",
        ),
        (".geojson", {"type": "FeatureCollection", "features": [42]}, r"features\[0\] is not"),
        (
            ".geojson",
            {"type": "FeatureCollection", "features": [_feature("Point", [0, 0])]},
            "has no 'id'",
        ),
        (
            ".geojson",
            {"type": "FeatureCollection", "features": [_feature("Point", ["a", "b"], id=1)]},
            "2 finite numbers",
        ),
        (
            ".geojson",
            {"type": "FeatureCollection", "features": [_feature("LineString", [[0, 0]], u=1)]},
            "lacks 'u'/'v'",
        ),
        (
            ".geojson",
            {
                "type": "FeatureCollection",
                "features": [_POINT_A, _feature("LineString", [[0, 0], [1, 0]], u=1, v=9)],
            },
            "joins node 9",
        ),
        (
            ".geojson",
            {
                "type": "FeatureCollection",
                "features": [_POINT_A, _POINT_B, _feature("LineString", "xy", u=1, v=2)],
            },
            r"features\[2\] coordinates: expected a list of \[x, y\], received 'xy'",
        ),
        # hand edits the readers do not look for: still a ValueError naming the file
        (".json", {"nodes": 5}, "'nodes': expected a list, received 5"),
        (".json", {"graph": [1, 2], "nodes": []}, r"'graph': expected an object, received \["),
        (
            ".json",
            {
                "nodes": [{"id": 0}, {"id": 1}],
                "edges": [{"source": 0, "target": 1, "path": [[1, 1], [1]]}],
            },
            "not a topojax json graph",
        ),
        (
            ".geojson",
            {"type": "FeatureCollection", "features": [{"type": "Feature", "geometry": [1]}]},
            r"features\[0\] 'geometry': expected an object or null, received \[1\]",
        ),
        # numbers a graph's users compute with: refused here, not deep in prune_graph
        (
            ".json",
            {
                "nodes": [{"id": 0}, {"id": 1}],
                "edges": [{"source": 0, "target": 1, "length_m": "abc"}],
            },
            r"edge \(0, 1, 0\) length_m: expected a finite number >= 0, received 'abc'",
        ),
        (
            ".json",
            {"graph": {"resolution_m": -0.05}, "nodes": [{"id": 0}], "edges": []},
            r"resolution_m: expected a finite number > 0, received -0.05",
        ),
    ],
)
def test_load_rejects_damaged_files_naming_the_file_and_the_fault(
    tmp_path: Path, suffix: str, doc: dict, message: str
):
    path = tmp_path / f"damaged{suffix}"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=message) as info:
        load_graph(path)
    assert "damaged" in str(info.value)


def test_graphml_edges_to_unlisted_nodes_and_foreign_pixels(tmp_path: Path):
    import re

    g = tj.build_graph(tj.sample_map("intel")).graph
    path = save_graph(g, tmp_path / "g.graphml")
    text = path.read_text()
    node = re.search(r'<node id="14">.*?</node>', text, flags=re.S)
    (tmp_path / "edited.graphml").write_text(text.replace(node.group(0), ""))
    with pytest.raises(ValueError, match=r"edited\.graphml: an edge joins node '14', which"):
        load_graph(tmp_path / "edited.graphml")
    # a GraphML written by networkx from a topojax graph (arrays as JSON text, no schema):
    # merged clusters' 'pixels' decode as arrays, as 'path' and 'world' do
    import json

    h = nx.MultiGraph()
    for n, d in g.nodes(data=True):
        h.add_node(
            n,
            pixel=json.dumps(list(d["pixel"])),
            world=json.dumps(list(d["world"])),
            pixels=json.dumps(np.asarray(d["pixels"]).tolist()),
            kind=d["kind"],
        )
    for u, v, k, d in g.edges(keys=True, data=True):
        h.add_edge(
            u,
            v,
            key=k,
            path=json.dumps(d["path"].tolist()),
            world=json.dumps(d["world"].tolist()),
            length_m=d["length_m"],
        )
    nx.write_graphml(h, tmp_path / "foreign.graphml")
    back = load_graph(tmp_path / "foreign.graphml")
    first = next(iter(back.nodes(data=True)))[1]
    assert isinstance(first["pixels"], np.ndarray) and first["pixels"].shape[1] == 2
    tj.prune_graph(back, min_spur_m=0.5)  # reads 'pixels'


def test_load_rejects_a_directed_graphml_file(tmp_path: Path):
    path = tmp_path / "directed.graphml"
    nx.write_graphml(nx.DiGraph([(1, 2)]), path)
    with pytest.raises(ValueError, match="directed.graphml holds a directed graph"):
        load_graph(path)


def test_output_folder_that_cannot_be_made_names_the_option(tmp_path, monkeypatch):
    from topojax._fs import output_folder

    def refuse(self, *args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(Path, "mkdir", refuse)
    with pytest.raises(PermissionError, match=r"^\[Errno 13\] --out: cannot make the folder"):
        output_folder(tmp_path / "x", name="--out")


def test_an_existing_folder_that_cannot_be_written_into_is_refused_up_front(tmp_path, monkeypatch):
    """An output folder that exists but takes no file (no permission, read-only) is
    tried when it is checked and refused naming the option, before a replay maps its
    whole log only to fail at the first write (and at saving its state)."""
    import tempfile

    from topojax._fs import output_folder

    folder = tmp_path / "read_only"
    folder.mkdir()
    real = tempfile.mkstemp

    def refuse(*args, dir=None, **kwargs):
        if dir is not None and Path(dir) == folder:
            raise PermissionError(13, "Permission denied")
        return real(*args, dir=dir, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    with pytest.raises(PermissionError, match=r"--out: cannot write into the folder .*read_only"):
        output_folder(folder, name="--out")
    monkeypatch.undo()
    assert output_folder(folder) == folder and not list(folder.iterdir())  # nothing left


def test_output_file_is_refused_up_front_where_it_cannot_be_written(tmp_path, read_only_folder):
    """An output file (``--mcap``, ``--animate``, ``route -o``) in a folder that takes
    no file is tried first and refused naming the option, not found out when it is
    written, after the work, with the system's message about a temporary file."""
    from topojax._fs import output_file

    with pytest.raises(
        OSError, match=r"--mcap: cannot write .*x\.mcap: no file can be made in the"
    ):
        output_file(read_only_folder / "x.mcap", name="--mcap")
    with pytest.raises(OSError, match=r"-o: cannot write .*r\.geojson: its folder .*sub cannot"):
        output_file(read_only_folder / "sub" / "r.geojson", name="-o")
    with pytest.raises(IsADirectoryError, match="-o: expected a file name, received the folder"):
        output_file(tmp_path, name="-o")
    (tmp_path / "afile").write_text("x")
    with pytest.raises(NotADirectoryError, match="--animate: .*afile in .* is a file, not a"):
        output_file(tmp_path / "afile" / "a.gif", name="--animate")
    assert output_file(tmp_path / "new" / "x.mcap") == tmp_path / "new" / "x.mcap"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "read_only"]  # nothing made
    assert list(read_only_folder.iterdir()) == []


def _writers():
    """Every public function that writes a file, called with the path given."""
    from skimage.draw import rectangle

    img = np.zeros((40, 50), np.uint8)
    rr, cc = rectangle((5, 5), end=(34, 44))
    img[rr, cc] = 254
    occupancy = tj.OccupancyMap.from_array(img, resolution_m=0.1)
    seg = tj.segment_rooms(occupancy)
    graph = nx.MultiGraph()
    graph.add_edge(0, 1, world=np.array([[0.0, 0.0], [1.0, 0.0]]))
    graph.nodes[0]["world"], graph.nodes[1]["world"] = (0.0, 0.0), (1.0, 0.0)
    return {
        "save_graph": lambda p: tj.save_graph(graph, p),
        "save_nav2_graph": lambda p: tj.save_nav2_graph(graph, p),
        "save_rooms": lambda p: tj.save_rooms(seg, p),
        "save_room_graph": lambda p: tj.save_room_graph(seg, p),
        "save_room_labels": lambda p: tj.save_room_labels(seg, p),
        "save_map": lambda p: tj.save_map(occupancy, p),
        "save_tiled_map": lambda p: tj.save_tiled_map(occupancy, p),
        "open_tiled_map": lambda p: tj.open_tiled_map(p),
        "View.save": lambda p: tj.View("<html></html>").save(p),
        "Timeline.save": lambda p: tj.Timeline().save(p),
        "write_view": lambda p: tj.write_view(occupancy, p),
    }


def test_a_path_that_is_not_one_is_named_in_the_error():
    # the same message everywhere, not Python's "expected str, bytes or os.PathLike object"
    for call in _writers().values():
        with pytest.raises(TypeError, match=r"path: expected a path \(str or os\.PathLike\)"):
            call(3)
        with pytest.raises(TypeError, match="received NoneType"):
            call(None)
    # a NUL is in no path: named, not os's bare "embedded null byte" or "not found"
    for call in [*_writers().values(), tj.load_map, tj.load_graph, tj.load_rooms]:
        with pytest.raises(ValueError, match=r"path: expected a path, received one with a NUL"):
            call("g\x00.json")


def test_loading_a_nav2_or_rooms_geojson_as_a_graph_says_what_it_is(tmp_path):
    g = nx.MultiGraph()
    g.add_edge(0, 1, world=np.array([[0.0, 0.0], [1.0, 0.0]]))
    g.nodes[0]["world"], g.nodes[1]["world"] = (0.0, 0.0), (1.0, 0.0)
    nav2 = tj.save_nav2_graph(g, tmp_path / "nav2.geojson")
    with pytest.raises(ValueError, match="a Nav2 route graph .save_nav2_graph."):
        load_graph(nav2)
    img = np.zeros((40, 50), np.uint8)
    img[5:35, 5:45] = 254
    seg = tj.segment_rooms(tj.OccupancyMap.from_array(img, resolution_m=0.1))
    rooms = tj.save_rooms(seg, tmp_path / "rooms.geojson")
    with pytest.raises(ValueError, match="a rooms GeoJSON; read it with load_rooms"):
        load_graph(rooms)


@pytest.mark.parametrize("suffix", [".json", ".graphml", ".geojson"])
def test_saved_files_leave_build_timings_out(tmp_path: Path, suffix: str):
    """How long a build took is not the graph's: two builds of one map save the same
    bytes (route graphs carry ``timings_s``, which a file would make differ)."""
    occ = tj.OccupancyMap.from_array(np.pad(np.ones((40, 60), bool), 1), resolution_m=0.05)
    with pytest.warns(UserWarning, match="empty route graph"):  # no room for the robot
        graphs = [tj.route_graph(occ, robot_radius_m=0.2) for _ in range(2)]
    assert all("timings_s" in g.graph for g in graphs)
    a, b = (save_graph(g, tmp_path / f"{k}{suffix}") for k, g in enumerate(graphs))
    assert a.read_bytes() == b.read_bytes()
    assert "timings_s" not in load_graph(a).graph


# what GraphML text loses ("\r" read back as "\n") or cannot hold (control characters)
LOST_IN_XML = "a\rb\r\nc\x0bd\x0ce\x1cf\x01g\x00h\x1fi\ud800j\ufffe"


@pytest.mark.parametrize("suffix", FORMATS)
def test_strings_with_control_characters_read_back_as_they_were(tmp_path: Path, suffix: str):
    g = nx.MultiGraph(note=LOST_IN_XML)
    g.add_node(0, world=(0.0, 0.0), kind=LOST_IN_XML)
    g.add_node(1, world=(1.0, 0.0), kind="end")
    g.add_edge(0, 1, world=np.array([[0.0, 0.0], [1.0, 0.0]]), label=LOST_IN_XML)
    back = load_graph(save_graph(g, tmp_path / f"g{suffix}"))
    assert back.graph["note"] == LOST_IN_XML
    assert [k for _, k in back.nodes(data="kind")] == [LOST_IN_XML, "end"]
    assert back.edges[0, 1, 0]["label"] == LOST_IN_XML


@pytest.mark.parametrize(
    ("what", "change"),
    [
        ("node id", lambda g: nx.relabel_nodes(g, {0: "a\x01", 1: "b"})),
        ("edge key", lambda g: nx.MultiGraph([(0, 1, "k\x0b")])),
        ("attribute name", lambda g: g.add_node(0, **{"x\x02": 1}) or g),
    ],
)
def test_graphml_refuses_names_xml_cannot_hold(tmp_path: Path, what: str, change):
    g = change(nx.MultiGraph([(0, 1)]))
    with pytest.raises(ValueError, match=rf"^{what} .*: expected text that GraphML can hold"):
        save_graph(g, tmp_path / "g.graphml")
    assert list(tmp_path.iterdir()) == []
    back = load_graph(save_graph(g, tmp_path / "g.json"))  # JSON holds them
    assert list(back.nodes) == list(g.nodes)
