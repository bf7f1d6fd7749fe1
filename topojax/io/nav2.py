"""Topology graphs as route graphs for the ROS 2 Nav2 Route Server."""

from __future__ import annotations

import json
import math
from array import array
from collections.abc import Iterator
from functools import partial
from pathlib import Path

import networkx as nx
import numpy as np

from .._fs import atomic_write, output_file_in_folder
from .._validate import instance_of, path_like, pixel_rows, positive_metres, xy_points
from ..graph import holds, polyline_keep
from ..graph.geometry import why_empty
from ._schema import _xy, as_multigraph, jsonable
from ._stream import _write_json


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
    ``tolerance_m`` from the walls.  An edge with ``waypoints`` (a route graph's, whose
    straight pieces keep the robot's radius from the walls) is written along them
    instead, as they are: they must run from one of its vertices' ``world`` to the
    other's, each end within ``tolerance_m``, as the vertices are written in their place.
    Every segment is written in both directions, once: where two corridors' chains hop
    between the same two nodes (corridors that share a stretch), the Route Server would
    drive the same straight line along either, so only the hop of the shorter corridor
    (``length_m``; the first of equals) is written.

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
        The nodes' ``frame`` property: the TF frame of the map (``"map"``); printable
        text.

    Returns
    -------
    Path
        The written path.

    Raises
    ------
    TypeError
        A ``tolerance_m`` that is not a number, a ``frame`` that is not a string.
    ValueError
        A bad ``tolerance_m``, an empty ``frame`` or one with a control character, a
        node or edge without ``world``, an edge whose ``waypoints`` do not run from one
        of its vertices to the other (the message names the edge, the vertices'
        positions and the waypoints' ends), or a graph without edges (nav2_route
        refuses to load one).

    Notes
    -----
    Metadata values are numbers, strings and lists of them only (nav2_route's loader
    accepts no ``null``, strict JSON no NaN): a vertex's ``kind`` is written where it is
    a string, its ``clearance_m`` where it is a finite number and its ``room`` where it
    is an int; one of another value (None, NaN, infinity) is left out, as a missing one
    is, and so are an edge's clearances.  Node ids: the graph's vertices with edges
    (vertices without edges lead nowhere and are left out) are ``0 .. V-1`` in node
    order (``metadata``: ``vertex``, the topojax node id (an id that is not a number or
    string, such as a tuple, as its JSON text), ``kind``, ``clearance_m`` and, after
    :func:`topojax.assign_rooms`, ``room``), then the waypoints (``kind: "waypoint"``);
    edge ids follow.  Points with equal coordinates, as written
    (the floats as they are, unrounded), are one node with the edges of all: a waypoint
    where a route graph's edge crosses another or passes a vertex without meeting it (a
    few per map) is the node already there, and a vertex at an earlier vertex's place is
    that one's node; a hop between two such points is left out, as an edge from a node
    to itself would be.  Edge ``metadata``: ``corridor`` (the
    topojax edge as ``[u, v, key]``, each written as ``vertex`` is), ``length_m`` (along
    the corridor between the two waypoints; the straight hop along a route graph's
    ``waypoints``) and the corridor's ``min_clearance_m`` / ``mean_clearance_m``.  topojax
    writes this format but does not read it back (use :func:`save_graph` for that).
    Where a path ends at another pixel of its vertex than the vertex's own (merged
    junction clusters), the chain includes the step to the vertex.  A loop with fewer
    than two points of its own to place waypoints on leads nowhere and is left out, as
    is a vertex with no other edge.
    """
    p = path_like("path", path)
    tol = positive_metres("tolerance_m", tolerance_m)
    instance_of("frame", frame, str, "non-empty string")
    if not frame or not frame.isprintable():  # a NUL or line feed is no TF frame name
        raise ValueError(
            f"frame: expected a non-empty string with no control character, received {frame!r}"
        )
    output_file_in_folder(p, name="path")  # before the work
    g = as_multigraph(graph)
    if g.number_of_edges() == 0:
        raise ValueError(
            f"graph: it has {g.number_of_nodes()} vertices and no edges{why_empty(g)}; the Nav2 "
            "Route Server rejects a graph without edges"
        )
    # a vertex without edges leads nowhere; a server that joins a pose at the nearest
    # node would get no route from it
    at: dict[tuple[float, float], int] = {}  # the node id written at each [x, y]
    node_id = {
        n: at.setdefault(tuple(_node_xy(n, g.nodes[n])), len(at))
        for n in g.nodes
        if _leads_somewhere(g, n, tol)
    }
    features = _features(g, node_id, at, tol, frame)  # made one at a time as they are written
    doc = {"type": "FeatureCollection", "name": "topojax route graph", "features": features}
    atomic_write(p, partial(_write_json, doc=doc, allow_nan=False))
    return p


def _features(g: nx.MultiGraph, node_id: dict, at: dict, tol: float, frame: str) -> Iterator[dict]:
    """The route graph's features: the vertices (ids ``node_id``), the waypoints of each
    corridor's chain in edge order, then every hop of the chains, both ways.

    ``at`` holds the id of the node written at each ``(x, y)``: a waypoint where a node
    already is (an edge crossing another, or passing a vertex, without a junction) is
    that node, so the written graph is joined where the geometry is."""
    node_xy: dict = {}
    yield from _vertex_features(g, node_id, frame, node_xy)
    chains = _Chains()
    for u, v, k, d in g.edges(keys=True, data=True):
        if u not in node_id:  # a loop left out, and its vertex with it
            continue
        chain = _corridor_chain(g, (u, v, k), d, node_xy, tol)
        if chain is None:
            continue
        a, b, inner, lengths, corridor = chain
        ids = [node_id[a]]
        for point in inner:
            new = len(at)
            ids.append(at.setdefault(tuple(point), new))
            if ids[-1] == new:
                yield _nav2_node(new, frame, point, {"kind": "waypoint"})
        ids.append(node_id[b])
        chains.add(ids, [node_xy[a], *inner, node_xy[b]], lengths, corridor)
    if not len(chains):  # every edge was a loop with no room for waypoints
        raise ValueError(
            f"graph: none of its {g.number_of_edges()} edges leads anywhere (loops around a "
            "single point); the Nav2 Route Server rejects a graph without edges"
        )
    yield from chains.features(len(at))


def _vertex_features(g: nx.MultiGraph, node_id: dict, frame: str, node_xy: dict) -> Iterator[dict]:
    """The graph's vertices as Point features (ids ``node_id``; a vertex with the id of
    one before it, at the same ``[x, y]``, is that one's node); each vertex's ``[x, y]``
    goes into ``node_xy``."""
    written = -1
    for n, d in g.nodes(data=True):
        if n not in node_id:
            continue
        node_xy[n] = _node_xy(n, d)
        if node_id[n] <= written:  # at an earlier vertex's [x, y]: that one's node
            continue
        written = node_id[n]
        meta = {"vertex": _id_value(n, "node id")}
        if isinstance(d.get("kind"), str):
            meta["kind"] = d["kind"]
        meta.update(_finite_metres(d, ("clearance_m",)))
        room = d.get("room")
        if isinstance(room, (int, np.integer)) and not isinstance(room, bool):
            meta["room"] = int(room)
        yield _nav2_node(node_id[n], frame, node_xy[n], meta)


def _node_xy(n, d: dict) -> list[float]:
    """Vertex ``n``'s ``[x, y]`` from its attributes ``d``."""
    if "world" not in d:
        raise ValueError(f"graph: node {n!r} has no 'world' (x, y) attribute")
    return _xy(d["world"], f"graph: node {n!r} 'world'")


def _leads_somewhere(g: nx.MultiGraph, n, tol: float) -> bool:
    """Whether vertex ``n`` keeps an edge in the file: one to another vertex, or a loop
    with room for two waypoints (a loop without is left out, and a vertex with no other
    edge with it)."""
    loops = []
    for _, m, k, d in g.edges(n, keys=True, data=True):
        if m != n:
            return True
        loops.append((k, d))
    xy = {n: _node_xy(n, g.nodes[n])} if loops else {}
    return any(_corridor_chain(g, (n, n, k), d, xy, tol) is not None for k, d in loops)


def _corridor_chain(
    g: nx.MultiGraph, edge: tuple, d: dict, node_xy: dict, tol: float
) -> tuple[object, object, list, list, dict] | None:
    """One corridor's waypoint chain, its polyline simplified within ``tol`` metres:
    the vertex it starts at, the one it ends at, the waypoints between (``[x, y]``
    each), the length of each hop (metres) and the corridor's metadata.  None for a
    loop around no pixel but its vertex's or a path on one point."""
    u, v, k = edge
    where = f"edge ({u!r}, {v!r}, {k!r})"
    if "world" not in d:
        raise ValueError(f"graph: {where} needs a finite 'world' polyline of shape (K, 2)")
    xy = xy_points(d["world"], f"graph: {where} 'world'")
    corridor = {"corridor": [_id_value(x, "edge id") for x in (u, v, k)]}
    corridor.update(_finite_metres(d, ("min_clearance_m", "mean_clearance_m")))
    planned = _waypoints(d, where)
    # the polyline runs from u (topojax's paths do; be tolerant of other graphs)
    if u != v and not _starts_at(g, u, v, d, xy if planned is None else planned, node_xy):
        u, v = v, u
    if planned is not None:  # a route graph's own chain, safe as it stands: straight hops
        planned = _from_u_to_v(planned, (u, node_xy[u]), (v, node_xy[v]), where, tol)
        inner = planned[1:-1].tolist()
        if u == v and len(inner) < 2:
            return None  # a loop needs two distinct waypoints
        points = [node_xy[u], *inner, node_xy[v]]
        lengths = [math.dist(a, b) for a, b in zip(points[:-1], points[1:], strict=True)]
        return u, v, inner, lengths, corridor
    # The chain runs from node to node: where a path ends at another pixel than its
    # vertex's (a merged junction cluster), the hop to the vertex is part of it, so the
    # simplification keeps every corridor pixel within the tolerance of what is written.
    xy = np.concatenate([[node_xy[u]], xy, [node_xy[v]]])
    xy = xy[np.r_[True, (np.diff(xy, axis=0) != 0).any(axis=1)]]  # no repeated points
    if len(xy) < (4 if u == v else 2):
        return None  # a loop around no pixel but its vertex's, or a path on one point
    keep = polyline_keep(xy, tol)
    if u == v and len(keep) < 4:  # a loop needs two distinct waypoints
        keep = np.unique(np.concatenate([keep, [len(xy) // 3, 2 * len(xy) // 3]]))
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    lengths = np.diff(along[keep]).tolist()  # along the corridor between the waypoints
    inner = xy[keep[1:-1]].tolist()
    return u, v, inner, lengths, corridor


def _waypoints(d: dict, where: str) -> np.ndarray | None:
    """An edge's ``waypoints`` (a route graph's simplified polyline), float64 (K, 2),
    or None when it has none."""
    w = d.get("waypoints")
    return None if w is None else xy_points(w, f"graph: {where} 'waypoints'", min_points=2)


def _from_u_to_v(planned: np.ndarray, u: tuple, v: tuple, where: str, tol: float) -> np.ndarray:
    """An edge's ``waypoints`` from vertex ``u`` to ``v`` (each ``(id, [x, y])``): as they
    are, or reversed where they run from ``v`` to ``u``; a ValueError naming the edge where
    they do not end at its vertices within ``tol`` metres.  The vertices are written in
    place of the first and last waypoint, so that farther off, the written chain would
    leave the polyline without a word (``tolerance_m`` bounds how far any chain may)."""
    first, last = planned[0], planned[-1]
    if math.dist(first, u[1]) <= tol and math.dist(last, v[1]) <= tol:
        return planned
    if math.dist(first, v[1]) <= tol and math.dist(last, u[1]) <= tol:
        return planned[::-1]
    raise ValueError(
        f"graph: {where} 'waypoints': expected a polyline from vertex {u[0]!r}'s 'world' "
        f"{list(u[1])} to vertex {v[0]!r}'s {list(v[1])} (or back), each end within "
        f"tolerance_m={tol:g} m, received one from {first.tolist()} to {last.tolist()}"
    )


class _Chains:
    """The hops of the corridors' waypoint chains, kept until every waypoint is written:
    their numbers in arrays and one metadata dict per corridor, a few dozen bytes a hop
    against the hundreds of its two features."""

    def __init__(self) -> None:
        self._ends = array("q")  # start id, end id per hop
        self._xy = array("d")  # start x, y, end x, y per hop
        self._lengths = array("d")
        self._corridor = array("q")  # index in _corridors per hop
        self._corridors: list[dict] = []

    def __len__(self) -> int:
        return len(self._lengths)

    def add(self, ids: list[int], points: list, lengths: list[float], corridor: dict) -> None:
        """The chain through the features ``ids`` at ``points``, hop ``j`` of
        ``lengths[j]`` metres, with the metadata ``corridor``; a hop between two points
        written as one node is left out (no edge from a node to itself)."""
        for j, length in enumerate(lengths):
            if ids[j] == ids[j + 1]:
                continue
            self._ends.extend((ids[j], ids[j + 1]))
            self._xy.extend((*points[j], *points[j + 1]))
            self._lengths.append(length)
            self._corridor.append(len(self._corridors))
        self._corridors.append(corridor)

    def _kept(self) -> np.ndarray:
        """Per hop, whether it is written: of the hops between one pair of nodes (chains
        of corridors that share a stretch), the shortest, the first added of equals."""
        ends = np.frombuffer(self._ends, np.int64).reshape(-1, 2)
        lo, hi = ends.min(axis=1), ends.max(axis=1)
        lengths = np.frombuffer(self._lengths, np.float64)
        order = np.lexsort((np.arange(len(lengths)), lengths, hi, lo))
        first = np.ones(len(order), bool)
        first[1:] = (np.diff(lo[order]) != 0) | (np.diff(hi[order]) != 0)
        kept = np.zeros(len(order), bool)
        kept[order[first]] = True
        return kept

    def features(self, first_id: int) -> Iterator[dict]:
        """Every hop kept (one per pair of nodes) as two MultiLineString features, one per
        direction, with ids from ``first_id`` on."""
        next_id = first_id
        kept = self._kept()
        for h, length in enumerate(self._lengths):
            if not kept[h]:
                continue
            a, b = self._ends[2 * h], self._ends[2 * h + 1]
            pa, pb = self._xy[4 * h : 4 * h + 2].tolist(), self._xy[4 * h + 2 : 4 * h + 4].tolist()
            meta = dict(self._corridors[self._corridor[h]], length_m=length)
            for start, end, p0, p1 in ((a, b, pa, pb), (b, a, pb, pa)):
                yield {
                    "type": "Feature",
                    "properties": {"id": next_id, "startid": start, "endid": end, "metadata": meta},
                    "geometry": {"type": "MultiLineString", "coordinates": [[p0, p1]]},
                }
                next_id += 1


def _starts_at(g, u, v, d: dict, xy: np.ndarray, node_xy: dict) -> bool:
    """Does edge ``(u, v)``'s polyline ``xy`` start at ``u``?  By the path's first pixel
    among the vertices' pixels (a merged cluster's path may start at any of them), else by
    which vertex is nearer."""
    path = d.get("path")
    if path is not None and (not isinstance(path, (list, tuple, np.ndarray)) or len(path)):
        path = pixel_rows(f"graph: edge ({u!r}, {v!r}): 'path'", path)
        at_u = holds(g.nodes[u], path[0], f"graph: vertex {u!r}")
        at_v = holds(g.nodes[v], path[0], f"graph: vertex {v!r}")
        if at_u != at_v:
            return at_u
    return math.dist(xy[0], node_xy[u]) <= math.dist(xy[0], node_xy[v])


def _id_value(value, where: str):
    """A node id or edge key as a metadata value: a number or string as it is, anything
    else (a tuple) as its JSON text; nav2_route's loader fails on an array of arrays."""
    plain = jsonable(value, f"graph: {where}")
    try:
        text = json.dumps(plain, allow_nan=False)
    except ValueError:  # a NaN or an infinity, which strict JSON cannot hold
        raise ValueError(
            f"graph: {where}: expected a number, string or tuple of them without NaN or "
            f"infinity (strict JSON), received {value!r}"
        ) from None
    return plain if isinstance(plain, (bool, int, float, str)) else text


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
