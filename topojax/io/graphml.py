"""GraphML files: scalars as GraphML values, everything else as JSON strings."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any, BinaryIO

import networkx as nx

from ._schema import (
    _SCHEMA_KEY,
    _check_ends,
    _decode_id,
    _decode_value,
    _schema_or_default,
    _to_python_scalar,
    add_edge,
    add_node,
    decided_id_kinds,
    jsonable,
    listed_twice,
)
from ._stream import _Chunks


def _graphml_value(value: Any, spec: dict[str, Any], where: str) -> Any:
    """GraphML holds only scalars: encode everything else as a JSON string."""
    value = _to_python_scalar(value)
    kind = spec["kind"]
    if kind == "float" and isinstance(value, (int, float)):
        return float(value)
    if kind in ("bool", "int", "str", "float"):
        if type(value) not in (bool, int, float, str):  # an IntEnum, a str subclass
            raise TypeError(
                f"{where}: expected a bool, int, float or str (to be saved as GraphML), "
                f"received {type(value).__name__}"
            )
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


#: GraphML's types (networkx's names) of the values :func:`_graphml_value` gives for
#: each kind of the schema; "string" for the others.
_KIND_XML_TYPES = {"bool": "boolean", "int": "long", "float": "double"}
#: The range of GraphML's long (XML Schema's: 64-bit two's complement).
_LONG_MIN, _LONG_MAX = -(2**63), 2**63 - 1
#: The line breaks of :meth:`str.splitlines` left in ASCII text once escaped: networkx
#: writes a document's lines joined with "\n".
_LINE_BREAKS = re.compile("\r\n|[\r\n\x0b\x0c\x1c\x1d\x1e]")
#: Characters that XML 1.0 cannot hold, not even as character references.
_NOT_XML_CHAR = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
#: Those and "\r", which an XML reader gives back as "\n" in character data.
_NOT_XML_TEXT = re.compile("[\r\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
#: A node attribute name that networkx's GraphML reader cannot read back: it hands a
#: node's values to ``add_node`` as keywords, and ``add_node`` takes this one itself.
_UNREADABLE_NODE_NAME = "node_for_adding"
#: What ElementTree replaces in character data, and also in attribute values.
_ESCAPES = (("&", "&amp;"), ("<", "&lt;"), (">", "&gt;"))
_QUOTE_ESCAPES = (('"', "&quot;"), ("\r", "&#13;"), ("\n", "&#10;"), ("\t", "&#09;"))
_HEAD = (
    '<graphml xmlns="http://graphml.graphdrawing.org/xmlns" '
    'xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" '
    'xsi:schemaLocation="http://graphml.graphdrawing.org/xmlns '
    'http://graphml.graphdrawing.org/xmlns/1.0/graphml.xsd">'
)


def _escape(text: str, quote: bool) -> str:
    """``text`` escaped as ElementTree escapes character data (or, ``quote``, an
    attribute value), each line break that is left a newline."""
    for char, reference in _ESCAPES + (_QUOTE_ESCAPES if quote else ()):
        if char in text:  # "&" first: the references hold one
            text = text.replace(char, reference)
    return _LINE_BREAKS.sub("\n", text) if _LINE_BREAKS.search(text) else text


def _write_graphml(
    g: nx.MultiGraph, graph_attrs: dict[str, Any], schema: dict, fh: BinaryIO
) -> None:
    """Write ``g`` to ``fh`` as GraphML, an element at a time: the bytes of networkx's
    ``generate_graphml`` (pretty-printed, its lines joined with newlines) for the graph
    whose values are :func:`_graphml_value`'s, non-ASCII characters as references."""
    _check_names(g, schema)
    schema = _xml_schema(g, graph_attrs, schema)
    graph_data = {
        name: _graphml_value(val, schema["graph"][name], f"graph attribute {name!r}")
        for name, val in graph_attrs.items()
    }
    graph_data[_SCHEMA_KEY] = json.dumps(schema)
    keys: dict[tuple[str, str], str] = {}  # networkx numbers them in the order first used
    types = {}
    for scope, names in (("graph", graph_data), ("node", schema["node"]), ("edge", schema["edge"])):
        for name in names:
            keys[scope, name] = f"d{len(keys)}"
            kind = schema[scope][name]["kind"] if name in schema[scope] else "str"
            types[scope, name] = _KIND_XML_TYPES.get(kind, "string")
    out = _Chunks(fh, "ascii", "xmlcharrefreplace")
    out.write(_HEAD)
    for (scope, name), key in reversed(keys.items()):  # networkx puts each new one first
        out.write(
            f'\n  <key id="{key}" for="{scope}" attr.name="{_escape(name, True)}" '
            f'attr.type="{types[scope, name]}" />'
        )
    out.write('\n  <graph edgedefault="undirected">')  # an 'id' attribute is a <data> too
    for n, d in g.nodes(data=True):
        node = _escape(str(_to_python_scalar(n)), True)
        out.write(f'\n    <node id="{node}"')
        data = {
            k: _graphml_value(v, schema["node"][k], f"node {n!r} attribute {k!r}")
            for k, v in d.items()
        }
        out.write(_data_elements(data, keys, "node", "\n    ", "</node>"))
    for u, v, k, d in g.edges(keys=True, data=True):
        ends = (_escape(str(_to_python_scalar(x)), True) for x in (u, v, k))
        out.write('\n    <edge source="{}" target="{}" id="{}"'.format(*ends))
        data = {
            name: _graphml_value(
                val, schema["edge"][name], f"edge ({u!r}, {v!r}, {k!r}) attribute {name!r}"
            )
            for name, val in d.items()
        }
        out.write(_data_elements(data, keys, "edge", "\n    ", "</edge>"))
    # networkx adds the graph's data elements after its nodes and edges
    out.write(_data_elements(graph_data, keys, "graph", "\n  ", "</graph>")[1:])
    out.write("\n</graphml>")
    out.close()


def _data_elements(data: dict, keys: dict, scope: str, indent: str, end: str) -> str:
    """The ``<data>`` elements of an element (``data``: its values) indented one level
    below ``indent``, after the ``>`` that ends its start tag, and its end tag ``end``;
    ``" />"`` for an element without data."""
    if not data:
        return " />"
    parts = [">"]
    for name, value in data.items():
        text = _escape(_xml_text(value), False)
        key = keys[scope, name]
        parts.append(
            f'{indent}  <data key="{key}">{text}</data>'
            if text
            else f'{indent}  <data key="{key}" />'
        )
    parts.append(f"{indent}{end}")
    return "".join(parts)


def _xml_text(value: Any) -> str:
    """The text of a :func:`_graphml_value` in XML Schema's spelling of its GraphML type:
    ``true`` / ``false`` for a boolean, ``NaN`` / ``INF`` / ``-INF`` for such a double
    (Python's ``True`` and ``nan`` are no XML Schema values; networkx reads both)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("INF" if value > 0 else "-INF")
    return str(value)


def _not_graphml_text(value: Any, kind: str) -> bool:
    """Is ``value`` of an attribute of ``kind`` a str that GraphML text loses or cannot
    hold (:data:`_NOT_XML_TEXT`), an int beyond GraphML's long (XML Schema's, 64 bits),
    or, in a double column (ints and floats), an int that no double holds exactly?"""
    if isinstance(value, str):
        return _NOT_XML_TEXT.search(value) is not None
    value = _to_python_scalar(value)
    if not isinstance(value, int) or isinstance(value, bool):
        return False
    if kind == "float":
        try:
            return float(value) != value
        except OverflowError:  # beyond any double
            return True
    return not _LONG_MIN <= value <= _LONG_MAX


def _xml_schema(g: nx.MultiGraph, graph_attrs: dict[str, Any], schema: dict) -> dict:
    """``schema`` with the kind ``"json"`` for each str, int or float attribute one of
    whose values GraphML cannot hold as such (:func:`_not_graphml_text`): its values are
    written as JSON strings, which hold them, and read back as they were."""
    out = dict(schema)
    for scope, items in (
        ("graph", [graph_attrs]),
        ("node", (d for _, d in g.nodes(data=True))),
        ("edge", (d for *_, d in g.edges(data=True))),
    ):
        kinds = {
            name: spec["kind"]
            for name, spec in schema[scope].items()
            if spec["kind"] in ("str", "int", "float")
        }
        found = set()
        for d in items if kinds else ():
            for name in kinds.keys() - found:
                if _not_graphml_text(d.get(name), kinds[name]):
                    found.add(name)
        if found:
            out[scope] = {**schema[scope], **{name: {"kind": "json"} for name in found}}
    return out


def _check_names(g: nx.MultiGraph, schema: dict) -> None:
    """A ValueError when a node id, edge key or attribute name holds a character that
    XML cannot (:data:`_NOT_XML_CHAR`), or a node has an attribute networkx's GraphML
    reader cannot read back (:data:`_UNREADABLE_NODE_NAME`)."""
    texts = [("attribute name", n) for scope in ("graph", "node", "edge") for n in schema[scope]]
    if schema["node_id"] == "str":
        texts += [("node id", n) for n in g.nodes]
    if schema["edge_key"] == "str":
        texts += [("edge key", k) for *_, k in g.edges(keys=True)]
    for what, text in texts:
        if _NOT_XML_CHAR.search(str(text)):
            raise ValueError(
                f"{what} {text!r}: expected text that GraphML can hold (no control "
                "characters but tab, line feed and carriage return, no lone surrogates), "
                f"received one with {_NOT_XML_CHAR.search(str(text)).group()!r}; save as .json"
            )
    name = _UNREADABLE_NODE_NAME
    if name in schema["node"]:
        owner = next(n for n, d in g.nodes(data=True) if name in d)
        raise ValueError(
            f"node {owner!r} has an attribute named {name!r}, which networkx's GraphML "
            "reader takes for its own argument: load_graph could not read it back; rename "
            "it, or save as .json or .geojson"
        )


def _read_graphml(path: Path) -> nx.MultiGraph:
    try:
        raw = nx.read_graphml(path, node_type=str, edge_key_type=str, force_multigraph=True)
    except Exception as exc:  # ElementTree / networkx raise various types on bad files
        raise ValueError(f"graph file {path} is not valid GraphML: {exc}") from None
    if raw.is_directed():
        raise ValueError(f"graph file {path} holds a directed graph; expected undirected")
    graph_attrs = dict(raw.graph)
    schema_text = graph_attrs.pop(_SCHEMA_KEY, None)
    try:
        schema = _schema_or_default(json.loads(schema_text) if schema_text else None)
    except json.JSONDecodeError:
        raise ValueError(f"graph file {path}: unreadable {_SCHEMA_KEY!r} attribute") from None
    # networkx keeps the keys' <default> values here, unless the graph had such attributes;
    # GraphML gives them to every element that holds no data for the key
    defaults = {
        name: graph_attrs.pop(name, None) or {}
        for name in ("node_default", "edge_default")
        if name not in schema["graph"]
    }
    node_default, edge_default = (defaults.get(f"{s}_default", {}) for s in ("node", "edge"))
    has_schema = schema_text is not None
    keys = [k for *_, k in raw.edges(keys=True)]
    schema = decided_id_kinds(schema, {"node_id": list(raw.nodes), "edge_key": keys})
    # networkx adds a node that only an edge names, bare; JSON and GeoJSON refuse it
    listed = _graphml_node_ids(path)  # a second parse of the file: only its node ids
    for u, v in raw.edges():
        _check_ends(listed, u, v, path, "an edge")
    g = nx.MultiGraph()
    g.graph.update({k: _graphml_decode(v, schema["graph"].get(k)) for k, v in graph_attrs.items()})
    for n, d in raw.nodes(data=True):
        node = _decode_id(n, schema["node_id"], "node id", path)
        d = d | {name: val for name, val in node_default.items() if name not in d}
        add_node(g, node, {k: _graphml_decode(v, schema["node"].get(k)) for k, v in d.items()})
    for u, v, k, d in raw.edges(keys=True, data=True):
        attrs = d | {name: val for name, val in edge_default.items() if name not in d}
        # networkx's reader copies the GraphML edge id into an 'id' attribute.
        if "id" in attrs and (not has_schema or "id" not in schema["edge"]):
            attrs.pop("id")
        add_edge(
            g,
            _decode_id(u, schema["node_id"], "node id", path),
            _decode_id(v, schema["node_id"], "node id", path),
            _decode_id(k, schema["edge_key"], "edge key", path),
            {name: _graphml_decode(val, schema["edge"].get(name)) for name, val in attrs.items()},
        )
    return g


def _graphml_node_ids(path: Path) -> set[str]:
    """The ids of the ``<node>`` elements of a GraphML file; a ValueError for a node, or
    an edge with its id, listed twice (networkx merges them into one)."""
    import xml.etree.ElementTree as ET

    ids, edges = set(), set()
    for _, elem in ET.iterparse(path):
        tag = elem.tag.rsplit("}", 1)[-1]
        if tag == "node":
            if elem.get("id") in ids:  # networkx would merge the two
                raise listed_twice(path, f"node {elem.get('id')!r}")
            ids.add(elem.get("id"))
        elif tag == "edge" and elem.get("id") is not None:
            ends, key = (elem.get("source"), elem.get("target")), elem.get("id")
            if (frozenset(ends), key) in edges:
                raise listed_twice(path, f"edge {(*ends, key)!r}")
            edges.add((frozenset(ends), key))
        elem.clear()
    return ids
