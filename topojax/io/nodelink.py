"""JSON node-link files (networkx's ``"nodes"`` / ``"edges"`` layout with edge ``"key"``)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import networkx as nx

from ._schema import (
    _SCHEMA_KEY,
    _check_ends,
    _decode_attrs,
    _decode_id,
    _schema_or_default,
    add_edge,
    add_node,
    decided_id_kinds,
    jsonable,
    member,
)


def _to_node_link(g: nx.MultiGraph, graph_attrs: dict[str, Any], schema: dict) -> dict:
    """The node-link document of ``g``; its ``"nodes"`` and ``"edges"`` are iterators
    that make each entry as it is taken (:func:`~topojax.io._stream._write_json`)."""
    graph_json = {
        name: jsonable(val, f"graph attribute {name!r}") for name, val in graph_attrs.items()
    }
    graph_json[_SCHEMA_KEY] = schema
    return {
        "directed": False,
        "multigraph": True,
        "graph": graph_json,
        "nodes": _node_entries(g),
        "edges": _edge_entries(g),
    }


def _node_entries(g: nx.MultiGraph) -> Iterator[dict]:
    for n, d in g.nodes(data=True):
        entry = {k: jsonable(v, f"node {n!r} attribute {k!r}") for k, v in d.items()}
        if "id" in entry:
            raise ValueError(f"node {n!r} has an attribute named 'id', reserved by node-link")
        entry["id"] = jsonable(n, "node id")
        yield entry


def _edge_entries(g: nx.MultiGraph) -> Iterator[dict]:
    for u, v, k, d in g.edges(keys=True, data=True):
        entry = {
            name: jsonable(val, f"edge ({u!r}, {v!r}, {k!r}) attribute {name!r}")
            for name, val in d.items()
        }
        for reserved in ("source", "target", "key"):
            if reserved in entry:
                raise ValueError(
                    f"edge ({u!r}, {v!r}, {k!r}) has an attribute named {reserved!r}, "
                    "reserved by node-link"
                )
        entry["source"] = jsonable(u, "node id")
        entry["target"] = jsonable(v, "node id")
        entry["key"] = jsonable(k, "edge key")
        yield entry


def _from_node_link(doc: Any, path: Path) -> nx.MultiGraph:
    if not isinstance(doc, dict) or "nodes" not in doc:
        raise ValueError(f"graph file {path} is not a node-link JSON object with 'nodes'")
    if doc.get("directed", False):
        raise ValueError(f"graph file {path} holds a directed graph; expected undirected")
    if "edges" in doc and "links" in doc:  # networkx writes one or the other, by version
        raise ValueError(
            f"graph file {path}: expected one edge list, 'edges' or 'links', received both "
            "'edges' and 'links'"
        )
    edge_list_name = "edges" if "edges" in doc else "links"
    where = f"graph file {path}:"
    graph_attrs = dict(member(doc, "graph", dict, where))
    schema = _schema_or_default(graph_attrs.pop(_SCHEMA_KEY, None))
    node_entries = member(doc, "nodes", list, where)
    edge_entries = member(doc, edge_list_name, list, where)
    entries = [e for e in edge_entries if isinstance(e, dict)]
    nodes = [e.get("id") for e in node_entries if isinstance(e, dict)]
    keys = [e["key"] for e in entries if e.get("key") is not None]
    schema = decided_id_kinds(schema, {"node_id": nodes, "edge_key": keys})
    g = nx.MultiGraph()
    g.graph.update(_decode_attrs(graph_attrs, schema["graph"]))
    for entry in node_entries:
        if not isinstance(entry, dict) or "id" not in entry:
            raise ValueError(f"graph file {path}: node entry without 'id': {entry!r}")
        attrs = {k: v for k, v in entry.items() if k != "id"}
        node = _decode_id(entry["id"], schema["node_id"], "node id", path)
        add_node(g, node, _decode_attrs(attrs, schema["node"]), path)
    for entry in edge_entries:
        if not isinstance(entry, dict) or "source" not in entry or "target" not in entry:
            raise ValueError(f"graph file {path}: edge entry without source/target: {entry!r}")
        u = _decode_id(entry["source"], schema["node_id"], "node id", path)
        v = _decode_id(entry["target"], schema["node_id"], "node id", path)
        _check_ends(g, u, v, path, "edge entry")
        attrs = {k: val for k, val in entry.items() if k not in ("source", "target", "key")}
        key = entry.get("key")
        if key is not None:
            key = _decode_id(key, schema["edge_key"], "edge key", path)
        add_edge(g, u, v, key, _decode_attrs(attrs, schema["edge"]), path)
    return g
