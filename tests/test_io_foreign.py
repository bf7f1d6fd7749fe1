"""Graph files written by other tools (networkx, GIS programs): loaded as the graph they
hold, or refused naming what is wrong."""

from __future__ import annotations

import json
from pathlib import Path

import networkx as nx
import pytest

from topojax.io import load_graph, save_graph


@pytest.mark.parametrize("suffix", [".graphml", ".json"])
def test_string_ids_that_only_look_like_numbers_stay_distinct_strings(tmp_path: Path, suffix: str):
    # "01" and "1" are two nodes, "1_0" is not the number 10
    g = nx.Graph([("01", "1"), ("1", "a"), ("1_0", "x")])
    path = tmp_path / f"ids{suffix}"
    if suffix == ".graphml":
        nx.write_graphml(g, path)
    else:
        path.write_text(json.dumps(nx.node_link_data(g, edges="edges")))
    back = load_graph(path)
    assert list(back.nodes) == ["01", "1", "a", "1_0", "x"]
    assert list(back.edges()) == [("01", "1"), ("1", "a"), ("1_0", "x")]
    save_graph(back, tmp_path / f"again{suffix}")  # one kind of id: it saves again


@pytest.mark.parametrize("suffix", [".graphml", ".json"])
def test_numeric_string_ids_of_another_tool_load_as_ints(tmp_path: Path, suffix: str):
    g = nx.Graph([(0, 1), (1, 12)])
    path = tmp_path / f"ints{suffix}"
    if suffix == ".graphml":
        nx.write_graphml(g, path)  # GraphML ids are text: "0", "1", "12"
    else:
        path.write_text(json.dumps(nx.node_link_data(nx.relabel_nodes(g, str), edges="edges")))
    assert list(load_graph(path).nodes) == [0, 1, 12]


def _gis_file(tmp_path: Path, point, line) -> Path:
    """A graph GeoJSON as a GIS program saves it: a ``crs`` member, extra properties."""
    doc = {
        "type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::3857"}},
        "features": [
            {"type": "Feature", "geometry": {"type": "Point", "coordinates": point},
             "properties": {"id": 0, "fid": 7}},
            {"type": "Feature", "geometry": {"type": "Point", "coordinates": [3.0, 4.0]},
             "properties": {"id": 1}},
            {"type": "Feature", "geometry": {"type": "LineString", "coordinates": line},
             "properties": {"u": 0, "v": 1, "key": 0}},
        ],
    }  # fmt: skip
    path = tmp_path / "gis.geojson"
    path.write_text(json.dumps(doc))
    return path


def test_geojson_positions_with_an_altitude_load_without_it(tmp_path: Path):
    # RFC 7946 3.1.1: a position may hold an altitude as its third element
    path = _gis_file(tmp_path, [1.0, 2.0, 0.0], [[1.0, 2.0, 0.0], [3.0, 4.0, 5.5]])
    back = load_graph(path)
    assert back.nodes[0] == {"fid": 7, "world": (1.0, 2.0)}
    assert back.edges[0, 1, 0]["world"].tolist() == [[1.0, 2.0], [3.0, 4.0]]


@pytest.mark.parametrize(
    ("point", "line", "message"),
    [
        ([1.0, 2.0, 0.0, 1.0], [[1.0, 2.0], [3.0, 4.0]], r"features\[0\].*\[x, y\] or \[x, y, z\]"),
        ([1.0, 2.0, "up"], [[1.0, 2.0], [3.0, 4.0]], r"features\[0\].*altitude.*'up'"),
        ([1.0, 2.0, 10**400], [[1.0, 2.0], [3.0, 4.0]], r"features\[0\].*altitude.*1000"),
        ([1.0, 2.0], [[1.0, 2.0], [3.0, 4.0, 0.0, 0.0]], r"features\[2\].*position 1"),
        ([1.0, 2.0], [[1.0, 2.0], [3.0]], r"features\[2\].*position 1.*\[3.0\]"),
    ],
)
def test_geojson_positions_that_are_no_position_are_named(tmp_path, point, line, message):
    with pytest.raises(ValueError, match=message):
        load_graph(_gis_file(tmp_path, point, line))


_NODE = {"type": "Feature", "geometry": {"type": "Point", "coordinates": [0, 0]}}


@pytest.mark.parametrize(
    ("suffix", "doc", "message"),
    [
        (".json", {"graph": [1], "nodes": []}, r"'graph': expected an object, received \[1\]"),
        (".json", {"nodes": 5}, r"'nodes': expected a list, received 5"),
        (".json", {"nodes": [], "links": {}}, r"'links': expected a list, received \{\}"),
        (
            ".geojson",
            {"type": "FeatureCollection", "features": [], "graph": "g"},
            r"'graph': expected an object, received 'g'",
        ),
        (
            ".geojson",
            {"type": "FeatureCollection", "features": {"a": 1}},
            r"'features': expected a list, received \{'a': 1\}",
        ),
        (
            ".geojson",
            {"type": "FeatureCollection", "features": [{**_NODE, "properties": [1]}]},
            r"features\[0\] 'properties': expected an object or null, received \[1\]",
        ),
        (
            ".geojson",
            {"type": "FeatureCollection", "features": [{**_NODE, "geometry": [1]}]},
            r"features\[0\] 'geometry': expected an object or null, received \[1\]",
        ),
    ],
)
def test_members_of_the_wrong_json_type_are_named(tmp_path, suffix, doc, message):
    path = tmp_path / f"odd{suffix}"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=message):
        load_graph(path)


@pytest.mark.parametrize("keep_members", [True, False])
def test_geojson_rewritten_by_a_gis_program_with_null_columns_loads_as_saved(
    tmp_path: Path, keep_members: bool
):
    import numpy as np

    # a GIS program gives every feature every column of its attribute table: a Point gets
    # u, v, key, path ... as null, a LineString id, pixel ...; and it may drop the file's
    # foreign members (the graph attributes and the type schema)
    g = nx.MultiGraph()
    g.add_node(0, pixel=(0, 0), world=(0.0, 0.0), kind="end")
    g.add_node(1, pixel=(0, 2), world=(0.1, 0.0), kind="junction")
    for u, v, path in ((0, 1, [[0, 0], [0, 1], [0, 2]]), (1, 1, [[0, 2], [1, 2], [1, 3]])):
        world = np.array(path) * 0.05  # the loop's polyline is open
        g.add_edge(u, v, path=np.array(path), world=world[:, ::-1], length_m=0.1)
    doc = json.loads(save_graph(g, tmp_path / "g.geojson").read_text())
    columns = list(dict.fromkeys(k for f in doc["features"] for k in f["properties"]))
    assert "closed_by_writer" in columns  # the open self-loop was closed
    for f in doc["features"]:
        f["properties"] = {k: f["properties"].get(k) for k in columns}
    if not keep_members:
        doc = {"type": "FeatureCollection", "name": "g", "features": doc["features"]}
    path = tmp_path / "qgis.geojson"
    path.write_text(json.dumps(doc))
    back = load_graph(path)
    assert [dict(d).keys() for _, d in back.nodes(data=True)] == [
        d.keys() for _, d in g.nodes(data=True)
    ]
    pairs = zip(back.edges(keys=True, data=True), g.edges(keys=True, data=True), strict=True)
    for (*_, d), (*_, e) in pairs:
        assert d.keys() == e.keys()
        assert np.array_equal(d["world"], e["world"]) and np.array_equal(d["path"], e["path"])


def test_graphml_default_values_of_another_tool_fill_the_elements_without_data(tmp_path):
    # GraphML: a key's <default> is the value of every element that holds no data for it
    path = tmp_path / "defaults.graphml"
    path.write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<graphml xmlns="http://graphml.graphdrawing.org/xmlns">\n'
        '<key id="d0" for="edge" attr.name="length_m" attr.type="double">'
        "<default>1.5</default></key>\n"
        '<key id="d1" for="node" attr.name="kind" attr.type="string">'
        "<default>end</default></key>\n"
        '<graph edgedefault="undirected">\n'
        '<node id="0"/><node id="1"><data key="d1">junction</data></node>\n'
        '<edge source="0" target="1"/>\n'
        '<edge source="0" target="1"><data key="d0">2.0</data></edge>\n'
        "</graph></graphml>\n"
    )
    back = load_graph(path)
    assert dict(back.nodes(data="kind")) == {0: "end", 1: "junction"}
    assert [d for *_, d in back.edges(keys=True, data="length_m")] == [1.5, 2.0]
    assert back.graph == {}


@pytest.mark.parametrize("suffix", [".json", ".geojson"])
def test_an_attribute_of_ints_and_floats_keeps_each_values_type_in_json(tmp_path, suffix):
    # JSON tells 3 from 3.0: each value comes back as the type it was saved as
    g = nx.MultiGraph(resolution_m=0.05)
    g.add_node(0, world=(0.0, 0.0), weight=3)
    g.add_node(1, world=(1.0, 0.0), weight=2.5)
    back = load_graph(save_graph(g, tmp_path / f"g{suffix}"))
    assert [type(w) for _, w in back.nodes(data="weight")] == [int, float]


def test_an_attribute_of_ints_and_floats_is_a_double_column_in_graphml(tmp_path):
    g = nx.MultiGraph()
    g.add_node(0, weight=3)
    g.add_node(1, weight=2.5)
    back = load_graph(save_graph(g, tmp_path / "g.graphml"))
    assert list(back.nodes(data="weight")) == [(0, 3.0), (1, 2.5)]
    assert [type(w) for _, w in back.nodes(data="weight")] == [float, float]


def test_a_node_link_file_with_both_edge_lists_is_refused(tmp_path: Path):
    """networkx writes ``edges`` or, in older versions, ``links``: a file holding both is
    ambiguous, and reading one would drop the other's edges without a word."""
    doc = {"nodes": [{"id": 0}, {"id": 1}], "edges": [], "links": [{"source": 0, "target": 1}]}
    path = tmp_path / "both.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(ValueError, match=r"both\.json.* both 'edges' and 'links'"):
        load_graph(path)
    for name in ("edges", "links"):  # either alone is read
        one = {"nodes": doc["nodes"], name: [{"source": 0, "target": 1}]}
        path.write_text(json.dumps(one), encoding="utf-8")
        assert load_graph(path).number_of_edges() == 1
