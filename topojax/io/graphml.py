"""GraphML files: scalars as GraphML values, everything else as JSON strings."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import networkx as nx

from ._schema import (
    _SCHEMA_KEY,
    _check_ends,
    _decode_id,
    _decode_value,
    _schema_or_default,
    _to_python_scalar,
    jsonable,
)


def _graphml_value(value: Any, spec: dict[str, Any], where: str) -> Any:
    """GraphML holds only scalars: encode everything else as a JSON string."""
    value = _to_python_scalar(value)
    kind = spec["kind"]
    if kind == "float" and isinstance(value, (int, float)):
        return float(value)
    if kind in ("bool", "int", "str", "float"):
        return value
    return json.dumps(jsonable(value, where), allow_nan=True)


def _graphml_decode(value: Any, spec: dict[str, Any] | None) -> Any:
    if spec is None:
        return value
    if spec["kind"] in ("bool", "int", "str", "float"):
        return _decode_value(value, spec)
    if isinstance(value, str):
        value = json.loads(value)
    return _decode_value(value, spec)


def _write_graphml(g: nx.MultiGraph, graph_attrs: dict[str, Any], schema: dict) -> bytes:
    h = nx.MultiGraph()
    for name, val in graph_attrs.items():
        h.graph[name] = _graphml_value(val, schema["graph"][name], f"graph attribute {name!r}")
    h.graph[_SCHEMA_KEY] = json.dumps(schema)
    for n, d in g.nodes(data=True):
        h.add_node(
            _to_python_scalar(n),
            **{
                k: _graphml_value(v, schema["node"][k], f"node {n!r} attribute {k!r}")
                for k, v in d.items()
            },
        )
    for u, v, k, d in g.edges(keys=True, data=True):
        h.add_edge(
            _to_python_scalar(u),
            _to_python_scalar(v),
            key=_to_python_scalar(k),
            **{
                name: _graphml_value(
                    val, schema["edge"][name], f"edge ({u!r}, {v!r}, {k!r}) attribute {name!r}"
                )
                for name, val in d.items()
            },
        )
    text = "\n".join(nx.generate_graphml(h, encoding="utf-8", prettyprint=True))
    return text.encode("utf-8")


def _read_graphml(path: Path) -> nx.MultiGraph:
    try:
        raw = nx.read_graphml(path, node_type=str, edge_key_type=str, force_multigraph=True)
    except Exception as exc:  # ElementTree / networkx raise various types on bad files
        raise ValueError(f"graph file {path} is not valid GraphML: {exc}") from None
    if raw.is_directed():
        raise ValueError(f"graph file {path} holds a directed graph; expected undirected")
    graph_attrs = dict(raw.graph)
    graph_attrs.pop("node_default", None)
    graph_attrs.pop("edge_default", None)
    schema_text = graph_attrs.pop(_SCHEMA_KEY, None)
    try:
        schema = _schema_or_default(json.loads(schema_text) if schema_text else None)
    except json.JSONDecodeError:
        raise ValueError(f"graph file {path}: unreadable {_SCHEMA_KEY!r} attribute") from None
    has_schema = schema_text is not None
    # networkx adds a node that only an edge names, bare; JSON and GeoJSON refuse it
    listed = _graphml_node_ids(path)  # a second parse of the file: only its node ids
    for u, v in raw.edges():
        _check_ends(listed, u, v, path, "an edge")
    g = nx.MultiGraph()
    g.graph.update({k: _graphml_decode(v, schema["graph"].get(k)) for k, v in graph_attrs.items()})
    for n, d in raw.nodes(data=True):
        node = _decode_id(n, schema["node_id"], "node id", path)
        g.add_node(node, **{k: _graphml_decode(v, schema["node"].get(k)) for k, v in d.items()})
    for u, v, k, d in raw.edges(keys=True, data=True):
        attrs = dict(d)
        # networkx's reader copies the GraphML edge id into an 'id' attribute.
        if "id" in attrs and (not has_schema or "id" not in schema["edge"]):
            attrs.pop("id")
        g.add_edge(
            _decode_id(u, schema["node_id"], "node id", path),
            _decode_id(v, schema["node_id"], "node id", path),
            key=_decode_id(k, schema["edge_key"], "edge key", path),
            **{name: _graphml_decode(val, schema["edge"].get(name)) for name, val in attrs.items()},
        )
    return g


def _graphml_node_ids(path: Path) -> set[str]:
    """The ids of the ``<node>`` elements of a GraphML file."""
    import xml.etree.ElementTree as ET

    ids = set()
    for _, elem in ET.iterparse(path):
        if elem.tag.rsplit("}", 1)[-1] == "node":
            ids.add(elem.get("id"))
        elem.clear()
    return ids
