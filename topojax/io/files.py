"""Saving and loading topology graphs as GraphML, JSON node-link or GeoJSON files.

Floats are written with Python's shortest round-trip representation, so they come back
bit-exact. Writes are atomic: a temporary file in the target folder is renamed over the
destination with :func:`os.replace`; the file is written a node and an edge at a time.
"""

from __future__ import annotations

import json
import math
import numbers
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any, BinaryIO

import networkx as nx

from .._fs import atomic_write, output_file_in_folder, refuse_suffix_only
from .._validate import existing_file, instance_of, one_of, path_like
from ._schema import _build_schema, _graph_attrs_to_save, as_multigraph
from ._stream import DuplicateKeyError, _NotJsonCompliant, _write_json, loads_unique
from .geojson import _from_geojson, _to_geojson
from .graphml import _read_graphml, _write_graphml
from .nodelink import _from_node_link, _to_node_link

#: Supported formats and their file suffixes.
GRAPH_FORMATS = {".graphml": "graphml", ".json": "json", ".geojson": "geojson"}


def _format_for(path: Path, format: str | None) -> str:
    supported = sorted(GRAPH_FORMATS)
    if format is not None:
        format = instance_of("format", format, str)
        return one_of("format", format.lower().lstrip("."), sorted(GRAPH_FORMATS.values()))
    refuse_suffix_only("path", path, GRAPH_FORMATS)
    suffix = path.suffix.lower()
    if suffix not in GRAPH_FORMATS:
        raise ValueError(
            f"path: expected a graph file suffix, one of {supported} (or pass format=), "
            f"received {str(path)!r}"
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
        dicts. The arrays of one attribute come back in their common dtype; integers it
        would change (uint64 beside int64, whose common dtype is float64) are refused.
    path : str or Path
        Output file; its folder must exist.
    format : {"graphml", "json", "geojson"}, optional
        Default: from the suffix (``.graphml``, ``.json``, ``.geojson``).

        * ``graphml``: arrays, tuples and lists are stored as JSON strings, and so
          are the str values of an attribute where one holds a control character
          (XML cannot hold most, and reads a carriage return back as a line feed) and
          the int values of one where an int is beyond 64 bits (GraphML's long);
          node ids, edge keys and attribute names with such a character other
          than tab, line feed or carriage return are refused. An attribute that holds
          both ints and floats is a column of doubles: its ints come back as floats
          (where a double does not hold one of them exactly, a column of JSON text
          instead, whose ints and floats come back as they were).
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
    p = path_like("path", path)
    fmt = _format_for(p, format)
    output_file_in_folder(p, name="path")  # before the work
    g = as_multigraph(graph)
    graph_attrs = _graph_attrs_to_save(g)
    schema = _build_schema(g, graph_attrs)
    write: Callable[[BinaryIO], None]
    if fmt == "graphml":
        write = partial(_write_graphml, g, graph_attrs, schema)
    elif fmt == "json":
        write = partial(_write_json, doc=_to_node_link(g, graph_attrs, schema), allow_nan=True)
    else:
        write = partial(_write_json, doc=_to_geojson(g, graph_attrs, schema), allow_nan=False)
    try:
        atomic_write(p, write)  # nodes and edges are made as they are written
    except _NotJsonCompliant:
        raise ValueError(
            f"cannot write {p} as GeoJSON: an attribute holds NaN or infinity, which "
            "strict JSON cannot represent (use .json or .graphml)"
        ) from None
    return p


def graph_file(name: str, path: Any) -> Path:
    """``path`` as an existing graph file (:func:`~topojax._validate.existing_file`); a
    saved graph store's folder is refused naming :func:`topojax.load_graph_store`, which
    reads it, rather than as a folder only."""
    p = path_like(name, path)
    from .store import STORE_FILE

    if p.is_dir() and (p / STORE_FILE).is_file():
        raise ValueError(
            f"{name}: expected a graph file (GraphML, JSON or GeoJSON), received the saved "
            f"graph store {p} (topojax.load_graph_store(folder).to_networkx() reads it)"
        )
    return existing_file(name, p)


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
        tuples for node ``pixel`` / ``world`` and graph ``origin`` / ``shape``. In a file
        of another tool (no type schema) node ids and edge keys are ints where all of
        them are ints or their decimal text (``"12"``, not ``"012"``), else all str.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If it is not a file (a saved graph store's folder is named as one), its format
        cannot be told from the suffix, or it cannot be parsed as that format, or it
        lists a node (or an edge with its key) twice.

    Notes
    -----
    A GeoJSON position may hold an altitude as a third element (``[x, y, z]``, RFC 7946
    3.1.1, as GIS tools write): it must be a finite number and is dropped.  A null
    property is an empty column of a GIS program's attribute table, and is dropped,
    unless the file's type schema records that attribute for nodes (or edges).
    """
    p = graph_file("path", path)
    fmt = _format_for(p, format)
    if fmt == "graphml":
        return _numbers_checked(_structure_checked(_read_graphml, p, fmt), p)
    try:
        doc = loads_unique(p.read_text(encoding="utf-8"))
    except DuplicateKeyError as exc:
        raise ValueError(f"graph file {p}: {exc}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"graph file {p} is not valid JSON: {exc}") from None
    reader: Callable[[Any, Path], nx.MultiGraph]
    reader = _from_node_link if fmt == "json" else _from_geojson
    return _numbers_checked(_structure_checked(lambda path: reader(doc, path), p, fmt), p)


def _numbers_checked(g: nx.MultiGraph, p: Path) -> nx.MultiGraph:
    """``g``, once its graph ``resolution_m`` (if any) is a finite number > 0 and every
    edge's ``length_m`` (if any) a finite number >= 0: a hand-edited file failed later,
    deep inside ``graph_summary`` or ``prune_graph``."""
    res = g.graph.get("resolution_m")
    if res is not None and not (_is_number(res) and math.isfinite(res) and res > 0):
        raise ValueError(
            f"graph file {p}: resolution_m: expected a finite number > 0, received {res!r}"
        )
    for u, v, k, length in g.edges(keys=True, data="length_m"):
        if length is not None and not (
            _is_number(length) and math.isfinite(length) and length >= 0
        ):
            raise ValueError(
                f"graph file {p}: edge ({u!r}, {v!r}, {k!r}) length_m: expected a finite "
                f"number >= 0, received {length!r}"
            )
    return g


def _is_number(x) -> bool:
    return isinstance(x, numbers.Real) and not isinstance(x, bool)


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
