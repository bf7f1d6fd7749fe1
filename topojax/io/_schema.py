"""The type schema of saved graphs: how attribute values are encoded as JSON values and
decoded back to the same Python/numpy types.

Every file also stores a small *type schema* (``"topojax_schema"``) that records, per
attribute name, whether values were numpy arrays (with dtype and trailing shape), tuples,
lists or other JSON values, and the type of node ids and edge keys. :func:`load_graph` uses
it to give back the same Python/numpy types. Files without a schema (written by other
tools) are decoded with the topojax defaults (``_DEFAULT_*_KINDS``).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

from .._validate import nx_graph
from .._words import graphml_text

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
        return _array_values(value, where)
    if isinstance(value, (list, tuple)):
        return [jsonable(v, where) for v in value]
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise TypeError(f"{where}: dict keys: expected str (to be saved), received {k!r}")
            out[k] = jsonable(v, where)
        return out
    raise TypeError(
        f"{where}: values of type {type(value).__name__} cannot be saved "
        "(supported: numbers, str, bool, None, tuple, list, dict, numpy arrays)"
    )


def _array_values(value: np.ndarray, where: str) -> Any:
    """``value.tolist()`` where a file holds its values and reads back its dtype: bool,
    integer, float up to 64 bits, str, or objects that can be saved; a TypeError naming
    ``where`` otherwise (complex, datetime, bytes, structured, ``bfloat16``...)."""
    dtype = value.dtype
    if dtype.kind in "biuU" or (dtype.kind == "f" and dtype.itemsize <= 8):
        return value.tolist()
    if dtype.kind == "O":
        return jsonable(value.tolist(), where)
    hint = " (cast it, e.g. .astype(np.float64))" if dtype.kind in "fV" else ""
    raise TypeError(
        f"{where}: arrays of dtype {dtype} cannot be saved{hint} (supported: bool, "
        "integer, float up to 64 bits, str, and object arrays of values that can be)"
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
                raise TypeError(f"{where} attribute names: expected str, received {name!r}")
            kinds[name] = _merge_kinds(
                kinds.get(name), _value_kind(value), f"{where} attribute {name!r}"
            )
    for name, spec in kinds.items():
        if spec is not None and spec["kind"] == "ndarray":
            _check_common_dtype(items, name, np.dtype(spec["dtype"]), f"{where} attribute")
    return {k: v for k, v in kinds.items() if v is not None}


def _check_common_dtype(items: list[dict[str, Any]], name: str, common: np.dtype, where: str):
    """Refuse, naming the attribute, an integer array of ``items``' attribute ``name`` that
    the common dtype of its arrays (NumPy's, a float for uint64 beside int64) does not hold
    exactly: the file would give back other numbers than were saved."""
    if common.kind not in "fc":
        return
    for attrs in items:
        value = attrs.get(name)
        if not isinstance(value, np.ndarray) or value.dtype.kind not in "iu":
            continue
        ints = value.ravel().tolist()
        with np.errstate(all="ignore"):
            cast = value.ravel().astype(common).tolist()
        changed = next((i for i, c in zip(ints, cast, strict=True) if i != c), None)
        if changed is not None:
            dtypes = sorted(
                {str(a[name].dtype) for a in items if isinstance(a.get(name), np.ndarray)}
            )
            raise ValueError(
                f"{where} {name!r}: expected arrays whose values one dtype holds exactly, "
                f"received dtypes {', '.join(dtypes)}, saved as {common} (their common "
                f"dtype), which changes the value {changed}; cast them to one dtype that "
                "holds every value, or save them as lists"
            )


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
    # "float" (ints and floats): JSON tells 3 from 3.0, GraphML holds a double column
    return value


def _to_tuple(value: Any) -> Any:
    if isinstance(value, list):
        return tuple(_to_tuple(v) for v in value)
    return value


def _check_key_type(value: Any, what: str) -> str:
    value = _to_python_scalar(value)
    if isinstance(value, bool) or not isinstance(value, (int, str)):
        raise TypeError(f"{what}: expected int or str (to be saved), received {value!r}")
    return "int" if isinstance(value, int) else "str"


def _id_kind(values: list[Any], what: str) -> str:
    kinds = {_check_key_type(v, what) for v in values}
    if len(kinds) > 1:
        raise TypeError(f"{what}s: expected all int or all str, received a mix")
    return kinds.pop() if kinds else "int"


def as_multigraph(graph: Any) -> nx.MultiGraph:
    """``graph`` as an undirected MultiGraph (a plain Graph's edges get key 0)."""
    nx_graph("graph", graph)  # undirected: corridors run both ways
    if graph.is_multigraph():
        return graph
    return nx.MultiGraph(graph)


def _graph_attrs_to_save(graph: nx.MultiGraph) -> dict[str, Any]:
    """Graph attributes in a saveable form; unsupported values are skipped with a warning,
    and how long the build took (``timings_s``) is not the graph's: a file's bytes
    depend only on the graph."""
    out: dict[str, Any] = {}
    for name, value in graph.graph.items():
        if name in (_SCHEMA_KEY, "timings_s"):
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
    """A file's type schema, or the topojax defaults for a file without one (another
    tool's); a ValueError for a schema whose id kinds or attribute tables are no schema's
    (a hand-edited file), rather than a fault blamed on the ids or values it describes."""
    if isinstance(schema, dict) and schema.get("version") == _SCHEMA_VERSION:
        for name in ("node_id", "edge_key"):
            if schema.get(name) not in (None, "int", "str"):
                raise ValueError(
                    f"{_SCHEMA_KEY}: {name}: expected 'int' or 'str', received "
                    f"{schema.get(name)!r:.80}"
                )
        for scope in ("graph", "node", "edge"):
            if not isinstance(schema.get(scope), dict):
                raise ValueError(
                    f"{_SCHEMA_KEY}: {scope}: expected an object of attribute kinds, received "
                    f"{schema.get(scope)!r:.80}"
                )
        return schema
    return {
        "version": _SCHEMA_VERSION,
        "node_id": None,
        "edge_key": None,
        "graph": _DEFAULT_GRAPH_KINDS,
        "node": _DEFAULT_NODE_KINDS,
        "edge": _DEFAULT_EDGE_KINDS,
    }


def _canonical_int(value: Any) -> bool:
    """Whether ``value`` is an int, or a str that is one's decimal text as ``str`` gives
    it (not ``"01"``, ``"+1"``, ``"1_0"`` or ``" 1"``, which ``int`` also reads)."""
    if isinstance(value, bool):
        return False
    if isinstance(value, int):
        return True
    if not isinstance(value, str) or not value.isascii():
        return False
    try:
        return str(int(value)) == value
    except ValueError:
        return False


def decided_id_kinds(schema: dict[str, Any], ids: dict[str, list[Any]]) -> dict[str, Any]:
    """``schema`` with the kind of the node ids and edge keys that a file without a schema
    leaves open decided for the whole file (``ids``: each's values in the file): ``"int"``
    where every one is an int or its decimal text, else ``"str"``; ids read one at a time
    would make ``"01"`` and ``"1"`` one node, and a graph of mixed ids that cannot be saved.
    """
    out = dict(schema)
    for name, values in ids.items():
        if out[name] is None:
            out[name] = "int" if all(_canonical_int(v) for v in values) else "str"
    return out


def _decode_id(value: Any, kind: str | None, what: str, path: Path) -> Any:
    if kind == "str" and isinstance(value, (int, str)) and not isinstance(value, bool):
        return str(value)
    if kind == "int" or kind is None:
        if isinstance(value, bool):
            raise ValueError(
                f"graph file {path}: {what}: expected an int or a str, received {value!r:.80}"
            )
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
    raise ValueError(f"graph file {path}: {what}: expected an int or a str, received {value!r:.80}")


def _decode_attrs(attrs: dict[str, Any], specs: dict[str, Any]) -> dict[str, Any]:
    return {k: _decode_value(v, specs.get(k)) for k, v in attrs.items()}


def _xy(value: Any, where: str) -> list[float]:
    """``value`` as ``[x, y]`` floats; ValueError naming ``where`` unless it is 2 finite
    numbers."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = np.empty(0)
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ValueError(
            f"{where}: expected 2 finite numbers (x, y), received {value!r}{graphml_text(value)}"
        )
    return [float(arr[0]), float(arr[1])]


def without_altitude(pos: Any, where: str) -> Any:
    """A GeoJSON position ``pos`` without its altitude: RFC 7946 (3.1.1) allows one as a
    third element, which GIS tools write; it must be a finite number and is dropped.
    ValueError naming ``where`` for a fourth element or an altitude that is no finite
    number (a JSON integer beyond any float included); anything else is returned as it
    is, for the caller's own check."""
    if not isinstance(pos, list) or len(pos) < 3:
        return pos
    if len(pos) > 3:
        raise ValueError(f"{where}: expected [x, y] or [x, y, z], received {pos!r:.80}")
    z = pos[2]
    try:
        finite = not isinstance(z, bool) and isinstance(z, (int, float)) and math.isfinite(z)
    except OverflowError:  # an integer beyond any float
        finite = False
    if not finite:
        raise ValueError(
            f"{where}: expected an altitude (a finite number) as its third element, "
            f"received {z!r:.80}"
        )
    return pos[:2]


def member(obj: dict, name: str, kind: type, where: str, *, null: str = "") -> Any:
    """``obj[name]`` of a JSON document, ``kind()`` where absent or null; ValueError
    naming ``where`` and the member unless it is a ``kind`` (dict or list).  ``null``:
    text after the expectation, such as ``" or null"`` where a format allows null."""
    value = obj.get(name)
    if value is None:
        return kind()
    if not isinstance(value, kind):
        expected = "an object" if kind is dict else "a list"
        raise ValueError(f"{where} {name!r}: expected {expected}{null}, received {value!r:.80}")
    return value


def _check_ends(g, u: Any, v: Any, path: Path, where: str) -> None:
    """An edge must join two listed nodes (``g``: the graph, or the set of node ids;
    networkx would add bare ones silently)."""
    for end in (u, v):
        if end not in g:
            raise ValueError(f"graph file {path}: {where} joins node {end!r}, which is not listed")


def listed_twice(path: Path, what: str) -> ValueError:
    """The error of a file that lists ``what`` (a node, an edge with its key) twice: read
    an entry at a time, the second would silently replace the first's attributes."""
    return ValueError(f"graph file {path}: {what} is listed twice; expected each once")


def add_node(g: nx.MultiGraph, node: Any, attrs: dict[str, Any], path: Path | None = None) -> None:
    """Add ``node`` to ``g`` with ``attrs``, whatever their names (``add_node(node,
    **attrs)`` would take ``node_for_adding`` for its own argument); with the file's
    ``path``, a node already in ``g`` is refused (:func:`listed_twice`)."""
    if path is not None and node in g:
        raise listed_twice(path, f"node {node!r}")
    g.add_node(node)
    g.nodes[node].update(attrs)


def add_edge(
    g: nx.MultiGraph, u: Any, v: Any, key: Any, attrs: dict[str, Any], path: Path | None = None
) -> None:
    """Add the edge ``(u, v, key)`` (``key`` None: the next free one) to ``g`` with
    ``attrs``, whatever their names (``key``, ``u_for_edge`` and ``v_for_edge`` too); with
    the file's ``path``, an edge already in ``g`` is refused (:func:`listed_twice`)."""
    if path is not None and key is not None and g.has_edge(u, v, key):
        raise listed_twice(path, f"edge {(u, v, key)!r}")
    key = g.add_edge(u, v, key=key)
    g.edges[u, v, key].update(attrs)
