"""Saving and loading topology graphs (GraphML, JSON node-link, GeoJSON), and writing
them as route graphs for the ROS 2 Nav2 Route Server (:func:`save_nav2_graph`).

Graphs are :class:`networkx.MultiGraph` objects with integer node ids. The topojax
attribute schema is

* nodes: ``pixel`` (tuple (row, col) of int), ``world`` (tuple (x, y) of float, metres),
  ``kind`` (str), ``clearance_m`` (float);
* edges: ``path`` (np.ndarray of int, (K, 2), (row, col)), ``world`` (np.ndarray of float,
  (K, 2), (x, y) metres), ``length_m``, ``min_clearance_m``, ``mean_clearance_m`` (float);
* graph: ``resolution_m``, ``origin`` (3-tuple), ``shape`` ((H, W)) and any other
  attributes.

Every file also stores a small *type schema* (``"topojax_schema"``) that records, per
attribute name, whether values were numpy arrays (with dtype and trailing shape), tuples,
lists or other JSON values, and the type of node ids and edge keys. :func:`load_graph` uses
it to give back the same Python/numpy types. Files without a schema (written by other
tools) are decoded with the topojax defaults above.

Floats are written with Python's shortest round-trip representation, so they come back
bit-exact. Writes are atomic: a temporary file in the target folder is renamed over the
destination with :func:`os.replace`.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

from ._fs import atomic_write_bytes
from ._validate import positive_metres
from .graph import holds, polyline_keep

__all__ = ["GRAPH_FORMATS", "load_graph", "save_graph", "save_nav2_graph"]

#: Supported formats and their file suffixes.
GRAPH_FORMATS = {".graphml": "graphml", ".json": "json", ".geojson": "geojson"}

_SCHEMA_KEY = "topojax_schema"
_SCHEMA_VERSION = 1

# Decoding used for files without a schema (topojax defaults).
_DEFAULT_NODE_KINDS: dict[str, dict[str, Any]] = {
    "pixel": {"kind": "tuple"},
    "pixels": {"kind": "ndarray", "dtype": "int64", "trailing": [2]},
    "world": {"kind": "tuple"},
}
_DEFAULT_EDGE_KINDS: dict[str, dict[str, Any]] = {
    "path": {"kind": "ndarray", "dtype": "int64", "trailing": [2]},
    "world": {"kind": "ndarray", "dtype": "float64", "trailing": [2]},
}
_DEFAULT_GRAPH_KINDS: dict[str, dict[str, Any]] = {
    "origin": {"kind": "tuple"},
    "shape": {"kind": "tuple"},
}


# ---------------------------------------------------------------------- value encoding


def _to_python_scalar(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    return value


def jsonable(value: Any, where: str) -> Any:
    """Convert nested tuples/lists/dicts/numpy values into plain JSON values."""
    value = _to_python_scalar(value)
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [jsonable(v, where) for v in value]
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise TypeError(f"{where}: dict keys must be str to be saved, got {k!r}")
            out[k] = jsonable(v, where)
        return out
    raise TypeError(
        f"{where}: values of type {type(value).__name__} cannot be saved "
        "(supported: numbers, str, bool, None, tuple, list, dict, numpy arrays)"
    )


def _value_kind(value: Any) -> dict[str, Any]:
    """Describe the type of one attribute value for the schema."""
    if isinstance(value, np.ndarray):
        return {"kind": "ndarray", "dtype": value.dtype.str, "trailing": list(value.shape[1:])}
    value = _to_python_scalar(value)
    if isinstance(value, bool):
        return {"kind": "bool"}
    if isinstance(value, int):
        return {"kind": "int"}
    if isinstance(value, float):
        return {"kind": "float"}
    if isinstance(value, str):
        return {"kind": "str"}
    if isinstance(value, tuple):
        return {"kind": "tuple"}
    if value is None:
        return {"kind": "none"}
    return {"kind": "json"}


def _merge_kinds(a: dict[str, Any] | None, b: dict[str, Any], where: str) -> dict[str, Any]:
    """Combine the kinds of two values of the same attribute."""
    if a is None or a == b:
        return b
    ka, kb = a["kind"], b["kind"]
    if {ka, kb} == {"int", "float"}:
        return {"kind": "float"}
    if ka == kb == "ndarray":
        merged = dict(a)
        if a["dtype"] != b["dtype"]:
            merged["dtype"] = np.result_type(np.dtype(a["dtype"]), np.dtype(b["dtype"])).str
        if a["trailing"] != b["trailing"]:
            merged["trailing"] = None
        return merged
    # Mixed kinds: keep each value's own JSON form (tuples/arrays come back as lists).
    warnings.warn(
        f"{where} mixes values of kinds {ka!r} and {kb!r}; they are saved as plain JSON "
        "values and may come back as lists",
        UserWarning,
        stacklevel=4,
    )
    return {"kind": "json"}


def _collect_schema(items: list[dict[str, Any]], where: str) -> dict[str, dict[str, Any]]:
    kinds: dict[str, dict[str, Any] | None] = {}
    for attrs in items:
        for name, value in attrs.items():
            if not isinstance(name, str):
                raise TypeError(f"{where} attribute names must be str, got {name!r}")
            kinds[name] = _merge_kinds(
                kinds.get(name), _value_kind(value), f"{where} attribute {name!r}"
            )
    return {k: v for k, v in kinds.items() if v is not None}


def _decode_value(value: Any, spec: dict[str, Any] | None) -> Any:
    """Inverse of :func:`jsonable` for one attribute value, guided by ``spec``."""
    if spec is None:
        return value
    kind = spec["kind"]
    if kind == "ndarray":
        if value is None:
            return None
        arr = np.asarray(value, dtype=np.dtype(spec["dtype"]))
        trailing = spec.get("trailing")
        if trailing is not None and arr.size == 0:
            arr = arr.reshape((0, *trailing))
        return arr
    if kind == "tuple":
        return _to_tuple(value) if isinstance(value, list) else value
    if kind == "float" and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    return value


def _to_tuple(value: Any) -> Any:
    if isinstance(value, list):
        return tuple(_to_tuple(v) for v in value)
    return value


def _check_key_type(value: Any, what: str) -> str:
    value = _to_python_scalar(value)
    if isinstance(value, bool) or not isinstance(value, (int, str)):
        raise TypeError(f"{what} must be int or str to be saved, got {value!r}")
    return "int" if isinstance(value, int) else "str"


def _id_kind(values: list[Any], what: str) -> str:
    kinds = {_check_key_type(v, what) for v in values}
    if len(kinds) > 1:
        raise TypeError(f"{what}s must all be int or all be str, got a mix")
    return kinds.pop() if kinds else "int"


def as_multigraph(graph: Any) -> nx.MultiGraph:
    """``graph`` as an undirected MultiGraph (a plain Graph's edges get key 0)."""
    if not isinstance(graph, nx.Graph):
        raise TypeError(f"graph: expected a networkx graph, received {type(graph).__name__}")
    if graph.is_directed():
        raise TypeError(
            f"graph: expected an undirected graph (corridors run both ways), received "
            f"{type(graph).__name__}"
        )
    if graph.is_multigraph():
        return graph
    return nx.MultiGraph(graph)


def _graph_attrs_to_save(graph: nx.MultiGraph) -> dict[str, Any]:
    """Graph attributes in a saveable form; unsupported values are skipped with a warning."""
    out: dict[str, Any] = {}
    for name, value in graph.graph.items():
        if name == _SCHEMA_KEY:
            continue
        if not isinstance(name, str):
            warnings.warn(f"graph attribute {name!r} skipped: name is not a str", stacklevel=3)
            continue
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            value = dataclasses.asdict(value)
        try:
            jsonable(value, f"graph attribute {name!r}")
        except TypeError as exc:
            warnings.warn(f"graph attribute {name!r} not saved: {exc}", UserWarning, stacklevel=3)
            continue
        out[name] = value
    return out


def _build_schema(g: nx.MultiGraph, graph_attrs: dict[str, Any]) -> dict[str, Any]:
    return {
        "version": _SCHEMA_VERSION,
        "node_id": _id_kind(list(g.nodes), "node id"),
        "edge_key": _id_kind([k for _, _, k in g.edges(keys=True)], "edge key"),
        "graph": _collect_schema([graph_attrs], "graph"),
        "node": _collect_schema([d for _, d in g.nodes(data=True)], "node"),
        "edge": _collect_schema([d for _, _, d in g.edges(data=True)], "edge"),
    }


def _schema_or_default(schema: Any) -> dict[str, Any]:
    if isinstance(schema, dict) and schema.get("version") == _SCHEMA_VERSION:
        return schema
    return {
        "version": _SCHEMA_VERSION,
        "node_id": None,
        "edge_key": None,
        "graph": _DEFAULT_GRAPH_KINDS,
        "node": _DEFAULT_NODE_KINDS,
        "edge": _DEFAULT_EDGE_KINDS,
    }


def _decode_id(value: Any, kind: str | None, what: str, path: Path) -> Any:
    if kind == "str":
        return str(value)
    if kind == "int" or kind is None:
        if isinstance(value, bool):
            raise ValueError(f"graph file {path}: bad {what} {value!r}")
        if isinstance(value, int):
            return value
        if isinstance(value, str):
            try:
                return int(value)
            except ValueError:
                if kind == "int":
                    raise ValueError(
                        f"graph file {path}: {what} {value!r} is not an integer"
                    ) from None
                return value
    raise ValueError(f"graph file {path}: bad {what} {value!r}")


def _decode_attrs(attrs: dict[str, Any], specs: dict[str, Any]) -> dict[str, Any]:
    return {k: _decode_value(v, specs.get(k)) for k, v in attrs.items()}


# ---------------------------------------------------------------------- JSON node-link


def _to_node_link(g: nx.MultiGraph, graph_attrs: dict[str, Any], schema: dict) -> dict:
    nodes = []
    for n, d in g.nodes(data=True):
        entry = {k: jsonable(v, f"node {n!r} attribute {k!r}") for k, v in d.items()}
        if "id" in entry:
            raise ValueError(f"node {n!r} has an attribute named 'id', reserved by node-link")
        entry["id"] = jsonable(n, "node id")
        nodes.append(entry)
    edges = []
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
        edges.append(entry)
    graph_json = {
        name: jsonable(val, f"graph attribute {name!r}") for name, val in graph_attrs.items()
    }
    graph_json[_SCHEMA_KEY] = schema
    return {
        "directed": False,
        "multigraph": True,
        "graph": graph_json,
        "nodes": nodes,
        "edges": edges,
    }


def _from_node_link(doc: Any, path: Path) -> nx.MultiGraph:
    if not isinstance(doc, dict) or "nodes" not in doc:
        raise ValueError(f"graph file {path} is not a node-link JSON object with 'nodes'")
    if doc.get("directed", False):
        raise ValueError(f"graph file {path} holds a directed graph; expected undirected")
    edge_list_name = "edges" if "edges" in doc else "links"
    graph_attrs = dict(doc.get("graph") or {})
    schema = _schema_or_default(graph_attrs.pop(_SCHEMA_KEY, None))
    g = nx.MultiGraph()
    g.graph.update(_decode_attrs(graph_attrs, schema["graph"]))
    for entry in doc["nodes"]:
        if not isinstance(entry, dict) or "id" not in entry:
            raise ValueError(f"graph file {path}: node entry without 'id': {entry!r}")
        attrs = {k: v for k, v in entry.items() if k != "id"}
        node = _decode_id(entry["id"], schema["node_id"], "node id", path)
        g.add_node(node, **_decode_attrs(attrs, schema["node"]))
    for entry in doc.get(edge_list_name, []):
        if not isinstance(entry, dict) or "source" not in entry or "target" not in entry:
            raise ValueError(f"graph file {path}: edge entry without source/target: {entry!r}")
        u = _decode_id(entry["source"], schema["node_id"], "node id", path)
        v = _decode_id(entry["target"], schema["node_id"], "node id", path)
        _check_ends(g, u, v, path, "edge entry")
        attrs = {k: val for k, val in entry.items() if k not in ("source", "target", "key")}
        key = entry.get("key")
        if key is not None:
            key = _decode_id(key, schema["edge_key"], "edge key", path)
        g.add_edge(u, v, key=key, **_decode_attrs(attrs, schema["edge"]))
    return g


# ---------------------------------------------------------------------- GraphML


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


# ---------------------------------------------------------------------- GeoJSON

_GEO_NODE_RESERVED = ("id", "feature")
_GEO_EDGE_RESERVED = ("u", "v", "key", "feature", "closed_by_writer")


def _xy(value: Any, where: str) -> list[float]:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = np.empty(0)
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{where} must be 2 finite numbers (x, y), got {value!r}")
    return [float(arr[0]), float(arr[1])]


def _to_geojson(g: nx.MultiGraph, graph_attrs: dict[str, Any], schema: dict) -> dict:
    features = []
    for n, d in g.nodes(data=True):
        if "world" not in d:
            raise ValueError(f"GeoJSON needs a 'world' (x, y) attribute on every node; node {n!r}")
        props = {
            k: jsonable(v, f"node {n!r} attribute {k!r}") for k, v in d.items() if k != "world"
        }
        for reserved in _GEO_NODE_RESERVED:
            if reserved in props:
                raise ValueError(f"node {n!r} has an attribute named {reserved!r}, reserved")
        props["feature"] = "node"
        props["id"] = jsonable(n, "node id")
        geometry = {"type": "Point", "coordinates": _xy(d["world"], f"node {n!r} 'world'")}
        features.append({"type": "Feature", "geometry": geometry, "properties": props})
    for u, v, k, d in g.edges(keys=True, data=True):
        where = f"edge ({u!r}, {v!r}, {k!r})"
        if "world" in d:
            coords = np.asarray(d["world"], dtype=np.float64)
            if coords.ndim != 2 or coords.shape[1] != 2 or coords.shape[0] < 1:
                raise ValueError(f"{where} 'world' must have shape (K, 2), got {coords.shape}")
        else:
            raise ValueError(f"GeoJSON needs a 'world' (K, 2) polyline on every edge; {where}")
        if not np.all(np.isfinite(coords)):
            raise ValueError(f"{where} 'world' contains non-finite coordinates")
        line = coords.tolist()
        appended = 0
        # A self-loop is a closed ring; a LineString needs at least 2 positions.
        if (u == v and line[0] != line[-1]) or len(line) < 2:
            line.append(list(line[0]))
            appended = 1
        props = {
            name: jsonable(val, f"{where} attribute {name!r}")
            for name, val in d.items()
            if name != "world"
        }
        for reserved in _GEO_EDGE_RESERVED:
            if reserved in props:
                raise ValueError(f"{where} has an attribute named {reserved!r}, reserved")
        props["feature"] = "edge"
        props["u"] = jsonable(u, "node id")
        props["v"] = jsonable(v, "node id")
        props["key"] = jsonable(k, "edge key")
        if appended:
            props["closed_by_writer"] = appended
        geometry = {"type": "LineString", "coordinates": line}
        features.append({"type": "Feature", "geometry": geometry, "properties": props})
    graph_json = {
        name: jsonable(val, f"graph attribute {name!r}") for name, val in graph_attrs.items()
    }
    # Foreign members (RFC 7946 section 6.1); coordinates are map-frame metres, not WGS 84.
    return {
        "type": "FeatureCollection",
        "features": features,
        "graph": graph_json,
        _SCHEMA_KEY: schema,
    }


def _check_ends(g, u: Any, v: Any, path: Path, where: str) -> None:
    """An edge must join two listed nodes (``g``: the graph, or the set of node ids;
    networkx would add bare ones silently)."""
    for end in (u, v):
        if end not in g:
            raise ValueError(f"graph file {path}: {where} joins node {end!r}, which is not listed")


def _from_geojson(doc: Any, path: Path) -> nx.MultiGraph:
    if not isinstance(doc, dict) or doc.get("type") != "FeatureCollection":
        raise ValueError(f"graph file {path} is not a GeoJSON FeatureCollection")
    schema = _schema_or_default(doc.get(_SCHEMA_KEY))
    g = nx.MultiGraph()
    g.graph.update(_decode_attrs(dict(doc.get("graph") or {}), schema["graph"]))
    edges = []
    for i, feat in enumerate(doc.get("features", [])):
        if not isinstance(feat, dict) or feat.get("type") != "Feature":
            raise ValueError(f"graph file {path}: features[{i}] is not a GeoJSON Feature")
        geom = feat.get("geometry") or {}
        props = dict(feat.get("properties") or {})
        gtype = geom.get("type")
        coords = geom.get("coordinates")
        if gtype == "Point":
            if "id" not in props:
                raise ValueError(f"graph file {path}: Point features[{i}] has no 'id' property")
            node = _decode_id(props.pop("id"), schema["node_id"], "node id", path)
            props.pop("feature", None)
            attrs = _decode_attrs(props, schema["node"])
            xy = _xy(coords, f"graph file {path}: features[{i}] coordinates")
            spec = schema["node"].get("world") or {"kind": "tuple"}
            attrs["world"] = _decode_value(xy, spec)
            g.add_node(node, **attrs)
        elif gtype == "LineString":
            if "u" not in props or "v" not in props:
                raise ValueError(f"graph file {path}: LineString features[{i}] lacks 'u'/'v'")
            edges.append((i, props, coords))
        else:
            raise ValueError(
                f"graph file {path}: features[{i}] has geometry type {gtype!r}; "
                "expected Point or LineString"
            )
    for i, props, coords in edges:
        u = _decode_id(props.pop("u"), schema["node_id"], "node id", path)
        v = _decode_id(props.pop("v"), schema["node_id"], "node id", path)
        _check_ends(g, u, v, path, f"LineString features[{i}]")
        key = props.pop("key", None)
        if key is not None:
            key = _decode_id(key, schema["edge_key"], "edge key", path)
        appended = int(props.pop("closed_by_writer", 0))
        props.pop("feature", None)
        try:
            world = np.asarray(coords, dtype=np.float64)
        except (TypeError, ValueError):
            world = np.empty(0)
        if world.ndim != 2 or world.shape[1] != 2:
            raise ValueError(
                f"graph file {path}: features[{i}] coordinates must be a list of [x, y]"
            )
        if appended:
            world = world[:-appended]
        attrs = _decode_attrs(props, schema["edge"])
        spec = schema["edge"].get("world")
        if spec is not None and spec["kind"] == "ndarray":
            world = world.astype(np.dtype(spec["dtype"]), copy=False)
        attrs["world"] = world
        g.add_edge(u, v, key=key, **attrs)
    return g


# ---------------------------------------------------------------------- public API


def _format_for(path: Path, format: str | None) -> str:
    supported = sorted(GRAPH_FORMATS)
    if format is not None:
        fmt = str(format).lower().lstrip(".")
        if fmt not in GRAPH_FORMATS.values():
            raise ValueError(
                f"format must be one of {sorted(GRAPH_FORMATS.values())}, got {format!r}"
            )
        return fmt
    suffix = path.suffix.lower()
    if suffix not in GRAPH_FORMATS:
        raise ValueError(
            f"cannot infer the graph format of {str(path)!r} from suffix {path.suffix!r}; "
            f"supported suffixes: {supported} (or pass format=)"
        )
    return GRAPH_FORMATS[suffix]


def save_graph(graph: nx.MultiGraph, path: str | Path, *, format: str | None = None) -> Path:
    """Save a topology graph.

    Parameters
    ----------
    graph : networkx.MultiGraph
        Undirected graph (a plain ``networkx.Graph`` is saved with edge keys 0). Node ids
        and edge keys must be int (or all str). Attribute values may be numbers, str,
        bool, None, tuples, lists, dicts and numpy arrays. Graph attributes of other
        types (e.g. objects) are skipped with a warning; dataclass instances are saved as
        dicts.
    path : str or Path
        Output file; its folder must exist.
    format : {"graphml", "json", "geojson"}, optional
        Default: from the suffix (``.graphml``, ``.json``, ``.geojson``).

        * ``graphml``: arrays, tuples and lists are stored as JSON strings.
        * ``json``: networkx node-link data (``"nodes"`` / ``"edges"``, edge ``"key"``),
          arrays as nested lists.
        * ``geojson``: a FeatureCollection with one Point per node (properties ``id``,
          ``feature: "node"`` and the node attributes except ``world``, which is the
          geometry) and one LineString per edge (properties ``u``, ``v``, ``key``,
          ``feature: "edge"`` and the edge attributes except ``world``, which gives the
          coordinates ``[x, y]``). A self-loop whose polyline is not closed is closed by
          repeating its first point (recorded as ``closed_by_writer`` so that loading
          removes it). Needs ``world`` on every node and edge. Coordinates are map-frame
          metres, not WGS 84.

    Returns
    -------
    Path
        The written path.
    """
    p = Path(path)
    fmt = _format_for(p, format)
    g = as_multigraph(graph)
    graph_attrs = _graph_attrs_to_save(g)
    schema = _build_schema(g, graph_attrs)
    if fmt == "graphml":
        data = _write_graphml(g, graph_attrs, schema)
    elif fmt == "json":
        data = json.dumps(_to_node_link(g, graph_attrs, schema), allow_nan=True).encode("utf-8")
    else:
        doc = _to_geojson(g, graph_attrs, schema)
        try:
            data = json.dumps(doc, allow_nan=False).encode("utf-8")
        except ValueError:
            raise ValueError(
                f"cannot write {p} as GeoJSON: an attribute holds NaN or infinity, which "
                "strict JSON cannot represent (use .json or .graphml)"
            ) from None
    atomic_write_bytes(p, data)
    return p


def load_graph(path: str | Path, *, format: str | None = None) -> nx.MultiGraph:
    """Load a graph written by :func:`save_graph`.

    Parameters
    ----------
    path : str or Path
        ``.graphml``, ``.json`` or ``.geojson`` file.
    format : {"graphml", "json", "geojson"}, optional
        Default: from the suffix.

    Returns
    -------
    networkx.MultiGraph
        Same node ids, edge keys, node/edge order and attribute types as saved: numpy
        arrays (with their dtype) for array attributes such as edge ``path`` / ``world``,
        tuples for node ``pixel`` / ``world`` and graph ``origin`` / ``shape``.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If it is not a file, its format cannot be told from the suffix, or it cannot be
        parsed as that format.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"graph file not found: {p}")
    if not p.is_file():
        raise ValueError(f"graph file {p} is not a file (a folder?)")
    fmt = _format_for(p, format)
    if fmt == "graphml":
        return _structure_checked(_read_graphml, p, fmt)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"graph file {p} is not valid JSON: {exc}") from None
    reader: Callable[[Any, Path], nx.MultiGraph]
    reader = _from_node_link if fmt == "json" else _from_geojson
    return _structure_checked(lambda path: reader(doc, path), p, fmt)


def _structure_checked(read: Callable[[Path], nx.MultiGraph], p: Path, fmt: str):
    """``read(p)``, with what a hand-edited or foreign file trips over deep inside (a
    list where a mapping belongs, a ragged path, ...) reported as a ValueError naming the
    file; the readers' own errors already do."""
    try:
        return read(p)
    except ValueError as exc:
        if str(p) in str(exc):
            raise
        raise ValueError(f"graph file {p}: not a topojax {fmt} graph: {exc}") from None
    except (TypeError, AttributeError, KeyError, IndexError) as exc:
        raise ValueError(
            f"graph file {p}: not a topojax {fmt} graph ({type(exc).__name__}: {exc})"
        ) from None


# ---------------------------------------------------------------------- Nav2 route graph


def save_nav2_graph(
    graph: nx.MultiGraph,
    path: str | Path,
    *,
    tolerance_m: float = 0.1,
    frame: str = "map",
) -> Path:
    """Save a topology graph as a route graph for the ROS 2 Nav2 Route Server.

    Nav2's route server (``nav2_route``) reads a GeoJSON ``FeatureCollection`` of
    ``Point`` nodes (properties ``id`` and ``frame``) and directed ``MultiLineString``
    edges (properties ``id``, ``startid``, ``endid``), with ids unique over nodes and
    edges, and optional ``metadata``.  It drives straight from node to node, so each
    corridor is written as a chain of waypoints: its world polyline simplified
    (Douglas–Peucker) until every pixel of the corridor lies within ``tolerance_m`` of
    the chain.  A segment then stays at least the corridor's clearance minus
    ``tolerance_m`` from the walls.  Every segment is written in both directions.

    Parameters
    ----------
    graph : networkx.MultiGraph
        Topology graph (e.g. ``build_graph(m).graph``, best pruned first with
        :func:`topojax.prune_graph`); nodes need ``world``, edges ``world`` polylines.
    path : str or Path
        Output file (``.geojson`` by convention); its folder must exist.
    tolerance_m : float
        Largest distance, metres, from a corridor pixel to the waypoint chain (> 0).
    frame : str
        The nodes' ``frame`` property: the TF frame of the map (``"map"``).

    Returns
    -------
    Path
        The written path.

    Raises
    ------
    TypeError
        A ``tolerance_m`` that is not a number.
    ValueError
        A bad ``tolerance_m`` or ``frame``, a node or edge without ``world``, or a graph
        without edges (nav2_route refuses to load one).

    Notes
    -----
    Metadata values are numbers, strings and lists of them only (nav2_route's loader
    accepts no ``null``).  Node ids: the graph's vertices are ``0 .. V-1`` in node order (``metadata``:
    ``vertex``, the topojax node id, ``kind`` and ``clearance_m``), then the waypoints
    (``kind: "waypoint"``); edge ids follow.  Edge ``metadata``: ``corridor`` (the
    topojax edge as ``[u, v, key]``), ``length_m`` (along the corridor between the two
    waypoints) and the corridor's ``min_clearance_m`` / ``mean_clearance_m``.  topojax
    writes this format but does not read it back (use :func:`save_graph` for that).
    Where a path ends at another pixel of its vertex than the vertex's own (merged
    junction clusters), the chain includes the step to the vertex.  A loop with fewer
    than two points of its own to place waypoints on leads nowhere and is left out.
    """
    tol = positive_metres("tolerance_m", tolerance_m)
    if not isinstance(frame, str) or not frame:
        raise ValueError(f"frame: expected a non-empty string, received {frame!r}")
    g = as_multigraph(graph)
    if g.number_of_edges() == 0:
        raise ValueError(
            f"graph: it has {g.number_of_nodes()} vertices and no edges; the Nav2 Route Server "
            "rejects a graph without edges"
        )
    node_id = {n: i for i, n in enumerate(g.nodes)}
    node_xy = {}
    features: list[dict] = []
    for n, d in g.nodes(data=True):
        if "world" not in d:
            raise ValueError(f"graph: node {n!r} has no 'world' (x, y) attribute")
        node_xy[n] = _xy(d["world"], f"node {n!r} 'world'")
        meta = {"vertex": jsonable(n, "node id")}
        if isinstance(d.get("kind"), str):
            meta["kind"] = d["kind"]
        meta.update(_finite_metres(d, ("clearance_m",)))
        features.append(_nav2_node(node_id[n], frame, node_xy[n], meta))
    next_id = len(features)
    segments: list[tuple[int, int, list[float], list[float], dict]] = []
    for u, v, k, d in g.edges(keys=True, data=True):
        where = f"edge ({u!r}, {v!r}, {k!r})"
        xy = np.asarray(d.get("world", np.empty((0, 2))), dtype=np.float64)
        if xy.ndim != 2 or xy.shape[1:] != (2,) or len(xy) < 1 or not np.isfinite(xy).all():
            raise ValueError(f"graph: {where} needs a finite 'world' polyline of shape (K, 2)")
        corridor = {"corridor": [jsonable(x, "edge id") for x in (u, v, k)]}
        # the polyline runs from u (topojax's paths do; be tolerant of other graphs)
        if u != v and not _starts_at(g, u, v, d, xy, node_xy):
            u, v = v, u
        # The chain runs from node to node: where a path ends at another pixel than its
        # vertex's (a merged junction cluster), the hop to the vertex is part of it, so the
        # simplification keeps every corridor pixel within the tolerance of what is written.
        xy = np.concatenate([[node_xy[u]], xy, [node_xy[v]]])
        xy = xy[np.r_[True, (np.diff(xy, axis=0) != 0).any(axis=1)]]  # no repeated points
        if len(xy) < (4 if u == v else 2):
            continue  # a loop around no pixel but its vertex's, or a path on one point
        keep = polyline_keep(xy, tol)
        if u == v and len(keep) < 4:  # a loop needs two distinct waypoints
            keep = np.unique(np.concatenate([keep, [len(xy) // 3, 2 * len(xy) // 3]]))
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
        inner = xy[keep[1:-1]].tolist()
        chain = [node_id[u]]
        for point in inner:
            features.append(_nav2_node(next_id, frame, point, {"kind": "waypoint"}))
            chain.append(next_id)
            next_id += 1
        chain.append(node_id[v])
        points = [node_xy[u], *inner, node_xy[v]]
        corridor.update(_finite_metres(d, ("min_clearance_m", "mean_clearance_m")))
        for j in range(len(chain) - 1):
            meta = dict(corridor, length_m=float(along[keep[j + 1]] - along[keep[j]]))
            segments.append((chain[j], chain[j + 1], points[j], points[j + 1], meta))
    if not segments:  # every edge was a loop with no room for waypoints
        raise ValueError(
            f"graph: none of its {g.number_of_edges()} edges leads anywhere (loops around a "
            "single point); the Nav2 Route Server rejects a graph without edges"
        )
    for a, b, pa, pb, meta in segments:
        for start, end, p0, p1 in ((a, b, pa, pb), (b, a, pb, pa)):
            features.append(
                {
                    "type": "Feature",
                    "properties": {"id": next_id, "startid": start, "endid": end, "metadata": meta},
                    "geometry": {"type": "MultiLineString", "coordinates": [[p0, p1]]},
                }
            )
            next_id += 1
    doc = {"type": "FeatureCollection", "name": "topojax route graph", "features": features}
    data = json.dumps(doc, allow_nan=False).encode("utf-8")
    p = Path(path)
    atomic_write_bytes(p, data)
    return p


def _starts_at(g, u, v, d: dict, xy: np.ndarray, node_xy: dict) -> bool:
    """Does edge ``(u, v)``'s polyline ``xy`` start at ``u``?  By the path's first pixel
    among the vertices' pixels (a merged cluster's path may start at any of them), else by
    which vertex is nearer."""
    path = d.get("path")
    if path is not None and len(path):
        at_u, at_v = holds(g.nodes[u], path[0]), holds(g.nodes[v], path[0])
        if at_u != at_v:
            return at_u
    return math.dist(xy[0], node_xy[u]) <= math.dist(xy[0], node_xy[v])


def _nav2_node(i: int, frame: str, xy: list[float], meta: dict) -> dict:
    return {
        "type": "Feature",
        "properties": {"id": i, "frame": frame, "metadata": meta},
        "geometry": {"type": "Point", "coordinates": [float(xy[0]), float(xy[1])]},
    }


def _finite_metres(d: dict, names: tuple[str, ...]) -> dict:
    """The attributes ``names`` of ``d`` that are finite numbers (strict JSON has no NaN)."""
    out = {}
    for name in names:
        value = d.get(name)
        if isinstance(value, (int, float, np.number)) and np.isfinite(value):
            out[name] = float(value)
    return out
