"""save_graph and save_nav2_graph write their files a piece at a time: the bytes networkx's
GraphML writer and json.dumps give for the whole document, with a traced peak of memory
well below the file's size, and nothing in place of the file when the writing fails."""

from __future__ import annotations

import enum
import json
import re
import tracemalloc
from collections.abc import Iterator
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

import topojax as tj
from topojax.io._schema import (
    _SCHEMA_KEY,
    _build_schema,
    _graph_attrs_to_save,
    _to_python_scalar,
    as_multigraph,
)
from topojax.io._stream import _NotJsonCompliant, _write_json
from topojax.io.geojson import _to_geojson
from topojax.io.graphml import _graphml_value, _xml_schema
from topojax.io.nodelink import _to_node_link

ODD_TEXT = "a<b>&\"'é ü\u2028\x85 \U0001f600 \r\n\t\x0b\x0c\x1c end\r"


def _odd_graph() -> nx.MultiGraph:
    """Parallel edges, loops, an isolated node, values of every kind (NaN and infinities,
    unicode, XML's special characters and line breaks in strings)."""
    g = nx.MultiGraph(
        name=ODD_TEXT, resolution_m=0.05, origin=(0.0, 1.0, 0.0), ok=True, n=3, lst=[1, "x"]
    )
    g.add_node(
        0,
        world=(1.0, 2.0),
        kind="<end & \"'>",
        empty="",
        text=ODD_TEXT,
        flag=False,
        i=7,
        x=float("inf"),
        y=-float("inf"),
        z=float("nan"),
        mixed=[1, 2.5, None],
        nested={"a": [1, 2], "b": "c&d"},
        nothing=None,
    )
    g.add_node(1, world=(3.0, 4.0))
    g.add_node(2, world=(5.0, 6.0), kind="junction", i=np.int64(3), x=np.float32(0.5))
    g.add_node(3, world=(7.0, 8.0))
    two = np.array([[1.0, 2.0], [3.0, 4.0]])
    g.add_edge(0, 1, world=two, path=np.array([[1, 2], [3, 4]]), flag=True, length_m=2.5)
    g.add_edge(0, 1, world=two[::-1], path=np.zeros((2, 2), int), flag=False, length_m=3)
    g.add_edge(2, 2, world=np.array([[5.0, 6.0], [5.5, 6.5]]), note=ODD_TEXT)
    g.add_edge(2, 2, key=7, world=np.array([[5.0, 6.0], [np.nan, 6.5]]))
    g.add_edge(1, 2, world=np.array([[3.0, 4.0], [5.0, 6.0]]), path=np.zeros((0, 2), np.int32))
    return g


def _str_id_graph() -> nx.MultiGraph:
    g = nx.MultiGraph()
    for i, n in enumerate(("a&b", "c\"d'", "é<>", "\t")):
        g.add_node(n, world=(float(i), 0.0))
    g.add_edge("a&b", "c\"d'", key="k<1>", world=np.array([[0.0, 0.0], [1.0, 0.0]]))
    g.add_edge("a&b", "c\"d'", key="k2", world=np.array([[0.0, 0.0], [1.0, 0.0]]))
    g.add_edge("é<>", "é<>", key="loop", world=np.array([[2.0, 0.0]]))
    return g


def _plain_graph() -> nx.Graph:
    """A plain Graph (edge keys 0) with nodes out of order."""
    g = nx.Graph(name="graph & name")
    g.add_edge(3, 1, w=1.0)
    g.add_edge(1, 2, w=2)
    g.add_edge(0, 3, w=3)
    g.add_node(9)
    return g


GRAPHS = {
    "empty": nx.MultiGraph,
    "odd": _odd_graph,
    "str ids": _str_id_graph,
    "plain": _plain_graph,
    "floor plan": lambda: (
        tj.build_graph(
            tj.OccupancyMap.from_array(np.pad(np.zeros((60, 90), bool), 2, constant_values=True))
        ).graph
    ),
}


#: networkx's text of booleans and special doubles, and XML Schema's, which GraphML uses.
_XML_SCHEMA_SPELLINGS = {"True": "true", "False": "false", "nan": "NaN", "inf": "INF"}


def _networkx_graphml(graph: nx.Graph) -> bytes:
    """networkx's ``generate_graphml`` of the graph whose values are those ``save_graph``
    writes as GraphML, its lines joined with "\\n", booleans and special doubles spelled
    as XML Schema spells them (networkx writes Python's ``True`` and ``nan``)."""
    g = as_multigraph(graph)
    graph_attrs = _graph_attrs_to_save(g)
    schema = _xml_schema(g, graph_attrs, _build_schema(g, graph_attrs))
    h = nx.MultiGraph()
    for name, val in graph_attrs.items():
        h.graph[name] = _graphml_value(val, schema["graph"][name], name)
    h.graph[_SCHEMA_KEY] = json.dumps(schema)
    for n, d in g.nodes(data=True):
        values = {k: _graphml_value(v, schema["node"][k], k) for k, v in d.items()}
        h.add_node(_to_python_scalar(n), **values)
    for u, v, k, d in g.edges(keys=True, data=True):
        values = {name: _graphml_value(val, schema["edge"][name], name) for name, val in d.items()}
        u, v, k = (_to_python_scalar(x) for x in (u, v, k))
        h.add_edge(u, v, key=k, **values)
    text = "\n".join(nx.generate_graphml(h, encoding="utf-8", prettyprint=True))
    return re.sub(
        r">(-?)(True|False|nan|inf)</data>",
        lambda m: f">{m[1]}{_XML_SCHEMA_SPELLINGS[m[2]]}</data>",
        text,
    ).encode()


def _whole_json(doc: dict, *, allow_nan: bool) -> bytes:
    """``json.dumps`` of ``doc`` with its iterators made into lists."""
    whole = {k: list(v) if isinstance(v, Iterator) else v for k, v in doc.items()}
    return json.dumps(whole, allow_nan=allow_nan).encode()


@pytest.mark.parametrize("name", list(GRAPHS))
def test_graphml_is_networkx_generate_graphml_byte_for_byte(tmp_path: Path, name: str):
    graph = GRAPHS[name]()
    path = tj.save_graph(graph, tmp_path / "g.graphml")
    assert path.read_bytes() == _networkx_graphml(graph)
    back = tj.load_graph(path)
    assert list(back.nodes) == list(graph.nodes)
    assert list(back.edges) == list(as_multigraph(graph).edges)
    nx.read_graphml(path)  # networkx reads it


@pytest.mark.parametrize("name", list(GRAPHS))
def test_json_files_are_json_dumps_of_the_whole_document(tmp_path: Path, name: str):
    graph = GRAPHS[name]()
    g = as_multigraph(graph)
    graph_attrs = _graph_attrs_to_save(g)
    schema = _build_schema(g, graph_attrs)
    path = tj.save_graph(graph, tmp_path / "g.json")
    assert path.read_bytes() == _whole_json(_to_node_link(g, graph_attrs, schema), allow_nan=True)
    if name in ("odd", "plain"):  # NaN; nodes without "world"
        return
    path = tj.save_graph(graph, tmp_path / "g.geojson")
    doc = _to_geojson(g, graph_attrs, schema)
    assert path.read_bytes() == _whole_json(doc, allow_nan=False)
    if name != "empty":
        nav2 = tj.save_nav2_graph(graph, tmp_path / "nav2.geojson")
        text = nav2.read_bytes()
        assert text == json.dumps(json.loads(text), allow_nan=False).encode()


def test_write_json_writes_iterators_as_lists_and_checks_every_item(tmp_path: Path):
    def items(n: int, fail_at: int | None = None) -> Iterator:
        for i in range(n):
            if i == fail_at:
                raise ValueError("item fault")
            yield {"i": i, "x": [float(i), 0.5]}

    doc = {"a": 1, "empty": items(0), "xs": items(5), "b": {"c": "é"}}
    path = tmp_path / "d.json"
    with path.open("wb") as fh:
        _write_json(fh, doc, allow_nan=False)
    assert (
        path.read_bytes()
        == json.dumps({"a": 1, "empty": [], "xs": list(items(5)), "b": {"c": "é"}}).encode()
    )
    nan = {"xs": iter([{"x": float("nan")}]), "ys": items(5, fail_at=3)}
    with path.open("wb") as fh, pytest.raises(ValueError, match="item fault"):
        _write_json(fh, nan, allow_nan=False)  # an item's own fault comes first
    with path.open("wb") as fh, pytest.raises(_NotJsonCompliant):
        _write_json(fh, {"xs": iter([{"x": float("nan")}]), "ys": items(5)}, allow_nan=False)


def test_geojson_reports_a_later_missing_world_before_an_earlier_nan(tmp_path: Path):
    g = _str_id_graph()
    g.nodes["a&b"]["clearance_m"] = float("nan")
    del g.edges["é<>", "é<>", "loop"]["world"]
    with pytest.raises(ValueError, match="'world'.*loop"):
        tj.save_graph(g, tmp_path / "g.geojson")
    g.remove_edge("é<>", "é<>", "loop")
    with pytest.raises(ValueError, match="NaN"):
        tj.save_graph(g, tmp_path / "g.geojson")
    assert list(tmp_path.iterdir()) == []


def test_graphml_refuses_a_node_attribute_networkx_reads_as_its_own_argument(tmp_path: Path):
    g = _str_id_graph()
    g.nodes["é<>"]["node_for_adding"] = 1
    with pytest.raises(
        ValueError, match=re.escape("node 'é<>' has an attribute named 'node_for_adding'")
    ):
        tj.save_graph(g, tmp_path / "g.graphml")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("suffix", [".graphml", ".json", ".geojson"])
def test_attributes_named_as_networkx_arguments_or_graphml_fields_are_read_back(
    tmp_path: Path, suffix: str
):
    # a graph's 'id' is also GraphML's graph element id, and 'node_default' /
    # 'edge_default' networkx's defaults: all three are read back, and edge attributes
    # named as add_edge's arguments (and, outside GraphML, add_node's) make files that
    # load_graph reads
    g = _str_id_graph()
    g.graph.update(id="floor 3", node_default=[1, 2], edge_default="x")
    ends = ("a&b", "c\"d'", "k2")
    g.edges[ends].update(u_for_edge=1, v_for_edge="v")
    if suffix == ".graphml":
        g.edges[ends]["key"] = 2.5  # node-link and GeoJSON files keep "key" for the key
    else:
        g.nodes["é<>"]["node_for_adding"] = 1
    back = tj.load_graph(tj.save_graph(g, tmp_path / f"g{suffix}"))
    assert {k: back.graph[k] for k in ("id", "node_default", "edge_default")} == {
        "id": "floor 3",
        "node_default": [1, 2],
        "edge_default": "x",
    }
    kept = {k: v for k, v in back.edges[ends].items() if k != "world"}
    assert kept == {k: v for k, v in g.edges[ends].items() if k != "world"}
    assert dict(back.nodes["é<>"]).get("node_for_adding") == g.nodes["é<>"].get("node_for_adding")


def test_graphml_refuses_a_subclass_of_a_scalar_naming_the_attribute(tmp_path: Path):
    class Level(enum.IntEnum):
        GROUND = 0

    g = _str_id_graph()
    g.nodes["é<>"]["level"] = Level.GROUND
    with pytest.raises(TypeError, match=r"^node 'é<>' attribute 'level': expected a bool, int"):
        tj.save_graph(g, tmp_path / "g.graphml")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------- big graphs


def _grid_graph(rows: int, cols: int, step: int = 3) -> nx.MultiGraph:
    """A grid of corridors ``step`` pixels long: rows * cols junctions, about twice as
    many edges, with the attributes build_graph gives."""
    res = 0.05
    g = nx.MultiGraph(resolution_m=res, origin=(0.0, 0.0, 0.0), shape=(rows * step, cols * step))
    ramp = np.arange(step + 1)
    for r in range(rows):
        for c in range(cols):
            px = (r * step, c * step)
            world = ((px[1] + 0.5) * res, (rows * step - px[0] - 0.5) * res)
            g.add_node(r * cols + c, pixel=px, world=world, kind="junction", clearance_m=0.4)
    for r in range(rows):
        for c in range(cols):
            for dr, dc in ((0, 1), (1, 0)):
                if r + dr >= rows or c + dc >= cols:
                    continue
                path = np.stack([r * step + dr * ramp, c * step + dc * ramp], axis=1)
                world = np.stack(
                    [(path[:, 1] + 0.5) * res, (rows * step - path[:, 0] - 0.5) * res], axis=1
                )
                g.add_edge(
                    r * cols + c,
                    (r + dr) * cols + c + dc,
                    path=path,
                    world=world,
                    length_m=step * res,
                    min_clearance_m=0.3,
                    mean_clearance_m=0.35,
                )
    return g


@pytest.fixture(scope="module")
def grid() -> nx.MultiGraph:
    g = _grid_graph(100, 110)
    assert g.number_of_edges() > 20_000
    return g


@pytest.fixture(scope="module")
def nav2_grid() -> nx.MultiGraph:
    """A quarter of ``grid``, whose Nav2 route graph is still over 4 MB (about 700 bytes a
    corridor, twice save_graph's JSON): save_nav2_graph simplifies each corridor, which
    under tracemalloc made the whole of ``grid`` take three times the other formats."""
    g = _grid_graph(55, 60)
    assert g.number_of_edges() > 6_000
    return g


@pytest.mark.parametrize("suffix", [".graphml", ".json", ".geojson", "nav2"])
def test_saving_a_big_graph_holds_far_less_than_the_file(
    tmp_path: Path, grid, nav2_grid, suffix: str
):
    big = nav2_grid if suffix == "nav2" else grid
    small = big.subgraph(range(30)).copy()  # the first call's imports are not the file's
    save = tj.save_nav2_graph if suffix == "nav2" else tj.save_graph
    name = "g.geojson" if suffix == "nav2" else f"g{suffix}"
    save(small, tmp_path / name)
    tracemalloc.start()
    try:
        path = save(big, tmp_path / name)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    size = path.stat().st_size
    assert size > 4 << 20
    assert peak < 3 * size, f"peak {peak / size:.1f} times the file's {size} bytes"


@pytest.mark.parametrize("suffix", [".graphml", ".json"])
def test_a_write_that_fails_late_leaves_the_old_file(tmp_path: Path, grid, suffix: str):
    target = tj.save_graph(_str_id_graph(), tmp_path / f"g{suffix}")
    before = target.read_bytes()
    g = grid.copy()
    u, v, k = list(g.edges(keys=True))[-1]
    g.edges[u, v, k]["extra"] = object()  # found past the first megabytes written
    with pytest.raises(TypeError, match=rf"edge \({u}, {v}, {k}\) attribute 'extra'"):
        tj.save_graph(g, target)
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == [target.name]
