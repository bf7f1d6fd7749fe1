"""GeoJSON files: a FeatureCollection of Point nodes and LineString edges in map-frame
metres (not WGS 84), with the graph attributes and the type schema as foreign members."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

from ._schema import (
    _SCHEMA_KEY,
    _check_ends,
    _decode_attrs,
    _decode_id,
    _decode_value,
    _schema_or_default,
    _xy,
    add_edge,
    add_node,
    decided_id_kinds,
    jsonable,
    member,
    without_altitude,
)

_GEO_NODE_RESERVED = ("id", "feature")
_GEO_EDGE_RESERVED = ("u", "v", "key", "feature", "closed_by_writer")


def _to_geojson(g: nx.MultiGraph, graph_attrs: dict[str, Any], schema: dict) -> dict:
    """The GeoJSON document of ``g``; its ``"features"`` is an iterator that makes each
    feature as it is taken (:func:`~topojax.io._stream._write_json`)."""
    graph_json = {
        name: jsonable(val, f"graph attribute {name!r}") for name, val in graph_attrs.items()
    }
    # Foreign members (RFC 7946 section 6.1); coordinates are map-frame metres, not WGS 84.
    return {
        "type": "FeatureCollection",
        "features": _features(g),
        "graph": graph_json,
        _SCHEMA_KEY: schema,
    }


def _features(g: nx.MultiGraph) -> Iterator[dict]:
    """A Point feature per node, then a LineString feature per edge."""
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
        yield {"type": "Feature", "geometry": geometry, "properties": props}
    for u, v, k, d in g.edges(keys=True, data=True):
        where = f"edge ({u!r}, {v!r}, {k!r})"
        if "world" in d:
            coords = np.asarray(d["world"], dtype=np.float64)
            if coords.ndim != 2 or coords.shape[1] != 2 or coords.shape[0] < 1:
                raise ValueError(f"{where} 'world': expected shape (K, 2), received {coords.shape}")
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
        yield {"type": "Feature", "geometry": geometry, "properties": props}


def _hint(props: dict) -> str:
    """What a GeoJSON file that is not a graph is, when its feature says so."""
    if "startid" in props or "endid" in props:
        return ": a Nav2 route graph (save_nav2_graph), which topojax does not read back"
    if props.get("kind") in ("room", "door"):
        return ": a rooms GeoJSON; read it with load_rooms"
    return ""


def _from_geojson(doc: Any, path: Path) -> nx.MultiGraph:
    if not isinstance(doc, dict) or doc.get("type") != "FeatureCollection":
        raise ValueError(f"graph file {path} is not a GeoJSON FeatureCollection")
    schema = _schema_or_default(doc.get(_SCHEMA_KEY))
    foreign = schema["node_id"] is None  # no schema: every null is an empty column
    features = member(doc, "features", list, f"graph file {path}:")
    schema = decided_id_kinds(schema, _ids(features))
    g = nx.MultiGraph()
    graph_attrs = member(doc, "graph", dict, f"graph file {path}:")
    g.graph.update(_decode_attrs(dict(graph_attrs), schema["graph"]))
    edges = []
    for i, feat in enumerate(features):
        where = f"graph file {path}: features[{i}]"
        if not isinstance(feat, dict) or feat.get("type") != "Feature":
            raise ValueError(f"{where} is not a GeoJSON Feature")
        geom = member(feat, "geometry", dict, where, null=" or null")
        props = dict(member(feat, "properties", dict, where, null=" or null"))
        gtype = geom.get("type")
        coords = geom.get("coordinates")
        saved = {} if foreign else schema["node" if gtype == "Point" else "edge"]
        props = _columns_dropped(props, saved)
        if gtype == "Point":
            if "id" not in props:
                raise ValueError(f"graph file {path}: Point features[{i}] has no 'id' property")
            node = _decode_id(props.pop("id"), schema["node_id"], "node id", path)
            props.pop("feature", None)
            attrs = _decode_attrs(props, schema["node"])
            where = f"graph file {path}: features[{i}] coordinates"
            xy = _xy(without_altitude(coords, where), where)
            spec = schema["node"].get("world") or {"kind": "tuple"}
            attrs["world"] = _decode_value(xy, spec)
            add_node(g, node, _in_order(attrs, schema["node"]), path)
        elif gtype == "LineString":
            if "u" not in props or "v" not in props:
                raise ValueError(
                    f"graph file {path}: LineString features[{i}] lacks 'u'/'v'{_hint(props)}"
                )
            edges.append((i, props, coords))
        else:
            raise ValueError(
                f"graph file {path}: features[{i}] has geometry type {gtype!r}; "
                f"expected Point or LineString{_hint(props)}"
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
        world = _line(coords, f"graph file {path}: features[{i}] coordinates")
        if appended:
            world = world[:-appended]
        attrs = _decode_attrs(props, schema["edge"])
        spec = schema["edge"].get("world")
        if spec is not None and spec["kind"] == "ndarray":
            world = world.astype(np.dtype(spec["dtype"]), copy=False)
        attrs["world"] = world
        add_edge(g, u, v, key, _in_order(attrs, schema["edge"]), path)
    return g


def _columns_dropped(props: dict, saved: dict) -> dict:
    """``props`` without the nulls of attributes that ``saved`` (the file's schema for the
    feature's kind) does not record: the empty columns of a GIS program's attribute
    table, which gives every feature every column (a Point ``u`` and ``path``, a
    LineString ``id`` and ``pixel``)."""
    return {k: v for k, v in props.items() if v is not None or k in saved}


def _line(coords: Any, where: str) -> np.ndarray:
    """A LineString's ``coords`` as float64 (K, 2), altitudes dropped (:func:`_position`);
    ValueError naming ``where`` and the position that is none."""
    try:
        world = np.asarray(coords, dtype=np.float64)
    except (TypeError, ValueError):
        world = np.empty(0)
    if world.ndim == 2 and world.shape[1] == 2:
        return world
    if world.ndim == 2 and world.shape[1] == 3 and np.all(np.isfinite(world[:, 2])):
        return np.ascontiguousarray(world[:, :2])
    if not isinstance(coords, list) or not coords:
        raise ValueError(f"{where}: expected a list of [x, y], received {coords!r:.80}")
    at = [f"{where} position {j}" for j in range(len(coords))]  # positions one by one
    xy = [_xy(without_altitude(c, w), w) for c, w in zip(coords, at, strict=True)]
    return np.array(xy, dtype=np.float64)


def _ids(features: Any) -> dict[str, list]:
    """The node ids (of the Points) and edge keys (of the LineStrings) in ``features``."""
    ids: dict[str, list] = {"node_id": [], "edge_key": []}
    for feat in features:
        geom = feat.get("geometry") if isinstance(feat, dict) else None
        props = feat.get("properties") if isinstance(feat, dict) else None
        if not isinstance(geom, dict) or not isinstance(props, dict):
            continue
        if geom.get("type") == "Point" and "id" in props:
            ids["node_id"].append(props["id"])
        elif geom.get("type") == "LineString" and props.get("key") is not None:
            ids["edge_key"].append(props["key"])
    return ids


def _in_order(attrs: dict, spec: dict) -> dict:
    """``attrs`` in the order the file's schema lists them (the written graph's order; the
    geometry's ``world`` comes apart from the properties), others after."""
    first = {k: attrs[k] for k in spec if k in attrs}
    return first | {k: v for k, v in attrs.items() if k not in first}
