"""Pruning of a built topology graph: narrow edges, short spurs, small components; edges
of a vertex left with two are joined, and the result is renumbered as
:func:`~topojax.graph.skeleton_to_graph` numbers its graphs."""

from __future__ import annotations

import itertools
import math

import networkx as nx
import numpy as np

from .._validate import (
    is_real_number,
    nonnegative_metres,
    nx_graph,
    pixel_rows,
    plain_int_pair,
    plain_length_m,
)
from ..config import PRUNING_SETTINGS
from ..fields.clearance import clearance_at_least
from .geometry import _ends_at, _path_length_m, graph_resolution_m, holds
from .store import fill_multigraph, paused_gc


def pruned_by(graph_config) -> str:
    """The pruning settings of ``graph_config`` (a :class:`topojax.config.GraphConfig`)
    that remove parts of a graph, as ``name=value`` (``"min_component_m=1000"``)."""
    values = ((n, getattr(graph_config, n)) for n in PRUNING_SETTINGS)
    return ", ".join(f"{n}={v:g}" for n, v in values if v)


#: The setting that leaves out the corridors in unknown space (``GraphConfig``'s).
FREE_ONLY = "free_space_only"


def what_emptied(graph_config, skeleton: np.ndarray, ridges: np.ndarray) -> str:
    """What removed every corridor of a map whose graph (of ``graph_config``) is empty:
    :func:`pruned_by`'s settings where its ``skeleton`` has pixels, :data:`FREE_ONLY`
    where only its ``ridges`` have (all in unknown space), "" where it gave none."""
    if skeleton.any():
        return pruned_by(graph_config)
    return FREE_ONLY if graph_config.free_space_only and ridges.any() else ""


def emptied_reason(emptied: str) -> str:
    """Why a graph is empty whose map gave corridors: ``emptied`` (:func:`what_emptied`,
    or the options that set its pruning) removed them all."""
    if emptied == FREE_ONLY:
        return (
            f"every corridor the map gave runs through unknown space, which {FREE_ONLY} leaves out"
        )
    return f"{emptied} removed every corridor the map gave; give a smaller value to keep some"


def prune_graph(
    graph: nx.MultiGraph,
    *,
    min_clearance_m: float = 0.0,
    min_spur_m: float = 0.0,
    min_component_m: float = 0.0,
) -> nx.MultiGraph:
    """Trim a topology graph for routing: narrow corridors, short spurs, small pieces.

    Route graphs of real maps carry corridors too narrow for the robot, many short
    *spurs* (a junction to a dead end, from ridges of corners and clutter) and small
    disconnected pieces (around furniture, in unknown space); the paper keeps them all,
    which is this function's default.  In this order:

    1. **Narrow edges**: every edge whose ``min_clearance_m`` is below ``min_clearance_m``
       (say, the robot's radius plus a margin) is removed; edges without clearances (NaN)
       stay.
    2. **Spurs**: every edge between an ``"end"`` vertex and a ``"junction"`` that is
       shorter than ``min_spur_m`` is removed with its end vertex.  This repeats until no
       such spur is left, so a tree of short branches is eaten from its tips (a component
       made only of short spurs shrinks to one isolated vertex).
    3. **Components**: every connected component whose edges total less than
       ``min_component_m`` (isolated vertices: 0 m; an exactly rounded sum, so the order
       of the edges does not matter) is removed.

    After steps 1 and 2 a vertex left with two edge ends is contracted: its two edges
    become one (paths joined at its pixel), as in :func:`skeleton_to_graph`; one left with
    only a self-loop becomes a ``"ring"`` vertex where it is.  The result has no edge
    narrower than ``min_clearance_m``, no spur shorter than ``min_spur_m`` and no
    component shorter than ``min_component_m``.  Vertex and edge attributes keep their
    meaning: joined edges get the joined ``path`` and ``world``, its ``length_m``, and the
    min / mean clearance over its pixels (other edge attributes where both edges agree);
    ``kind`` is updated.  Nodes are renumbered ``0..N-1`` in raster order of ``pixel``
    with edges ``(u, v)``, ``u <= v``, their paths running from ``u`` to ``v``.

    Parameters
    ----------
    graph : networkx.MultiGraph
        A topology graph from :func:`skeleton_to_graph` (or :func:`topojax.build_graph`,
        :class:`topojax.IncrementalMapper`, :func:`topojax.load_graph`); to remove edges
        (``min_clearance_m`` or ``min_spur_m`` > 0) it must have been built with
        ``merge_junction_clusters=False`` (the edges of a merged cluster end at different
        member pixels and cannot be joined).  Not modified.
    min_clearance_m : float, default 0.0
        Edges whose narrowest point (``min_clearance_m``, metres) is below this are
        removed; 0 keeps all.
    min_spur_m : float, default 0.0
        Spurs shorter than this (``length_m``, metres) are removed; 0 keeps all.
    min_component_m : float, default 0.0
        Components whose total edge length is shorter than this are removed; 0 keeps all.

    Returns
    -------
    networkx.MultiGraph
        A new graph; its graph attributes are the input's plus ``pruned_min_clearance_m``,
        ``pruned_min_spur_m`` and ``pruned_min_component_m``.

    Raises
    ------
    TypeError
        If ``graph`` is not an undirected networkx MultiGraph, a threshold is not a
        number, or an edge's ``length_m`` (or, with ``min_clearance_m`` > 0, its
        ``min_clearance_m``) is not a number.
    ValueError
        If a threshold is negative or not finite, ``min_spur_m`` or ``min_clearance_m``
        is above 0 for a graph with merged junction clusters (whether or not an edge
        would go), a vertex lacks ``pixel`` / an edge lacks ``path`` or
        ``length_m``, or an edge's ``length_m`` is negative or not finite.
    """
    nx_graph("graph", graph, multigraph=True)
    clearance = nonnegative_metres("min_clearance_m", min_clearance_m)
    spur = nonnegative_metres("min_spur_m", min_spur_m)
    component = nonnegative_metres("min_component_m", min_component_m)
    if (spur > 0 or clearance > 0) and graph.graph.get("merge_junction_clusters"):
        raise ValueError(
            "graph: min_clearance_m or min_spur_m > 0 expects a graph built with "
            "merge_junction_clusters=False, received one with merged junction clusters "
            "(their edges end at different member pixels, so they cannot be joined)"
        )
    with paused_gc():  # many small containers, no reference cycles
        return _prune(graph, clearance, spur, component)


def _prune(graph: nx.MultiGraph, clearance: float, spur: float, component: float) -> nx.MultiGraph:
    """:func:`prune_graph` on checked input."""
    # A light copy: vertex attributes, edges by id, each vertex's edge ids, and degrees (a
    # self-loop counts 2).  The arrays of what survives are copied at the end, so the
    # result shares nothing with ``graph``.
    nodes: dict = {}
    for v, data in graph.nodes(data=True):
        if "pixel" not in data:
            raise ValueError(f"graph: expected every vertex to have a 'pixel', vertex {v} has none")
        if not plain_int_pair(data["pixel"]):
            pixel_rows(f"graph: vertex {v}: 'pixel'", data["pixel"], one=True)
        nodes[v] = dict(data)
    edges: dict[int, tuple] = {}
    incident: dict = {v: set() for v in nodes}
    degree = dict.fromkeys(nodes, 0)
    for eid, (u, v, data) in enumerate(graph.edges(data=True)):
        for name in ("path", "length_m"):
            if name not in data:
                raise ValueError(
                    f"graph: expected every edge to have a {name!r}, edge {u}-{v} has none"
                )
        if not plain_length_m(data["length_m"]):
            nonnegative_metres(f"graph: edge {u}-{v}: 'length_m'", data["length_m"])
        edges[eid] = (u, v, dict(data))
        incident[u].add(eid)
        incident[v].add(eid)
        degree[u] += 1
        degree[v] += 1
    res = graph_resolution_m(graph)
    new_ids = itertools.count(len(edges))

    def contract(vertices) -> set:
        """Join the edges of those of ``vertices`` left with two (no loop); returns the
        vertices whose edges changed."""
        changed = set()
        for n in sorted(vertices):  # such vertices are never removed by another's join
            if degree[n] == 2 and len(incident[n]) == 2:  # two edges, no loop
                changed.update(_join(n, nodes, edges, incident, degree, res, new_ids))
            else:
                changed.add(n)
        return {n for n in changed if n in nodes}  # joined ends may be joined away later

    if clearance > 0:
        narrow = [eid for eid, (u, v, d) in edges.items() if _below(d, clearance, f"edge {u}-{v}")]
        ends = set()
        for eid in narrow:
            u, v, _ = edges.pop(eid)
            incident[u].discard(eid)
            incident[v].discard(eid)
            degree[u] -= 1
            degree[v] -= 1  # a self-loop loses 2
            ends.update((u, v))
        contract(ends)

    if spur > 0:
        candidates = list(edges)  # edges that may be spurs; later only changed ones
        while True:
            spurs = []  # (end, hub, edge id), from the degrees before this round's removals
            for eid in candidates:
                u, v, data = edges[eid]
                du, dv = degree[u], degree[v]
                if u != v and data["length_m"] < spur and min(du, dv) == 1 and max(du, dv) >= 3:
                    spurs.append((u, v, eid) if du == 1 else (v, u, eid))
            if not spurs:
                break
            hubs = set()
            for end, hub, eid in spurs:
                del edges[eid], nodes[end], incident[end], degree[end]
                incident[hub].discard(eid)
                degree[hub] -= 1
                hubs.add(hub)
            # only the hubs' degrees changed, and joined edges are new: next round's spurs
            # touch a hub or a joined edge's ends
            changed = contract(hubs)
            candidates = sorted({eid for n in changed for eid in incident[n]})
    if component > 0:
        drop = []
        seen: set = set()
        for start in nodes:
            if start in seen:
                continue
            seen.add(start)
            members, stack, lengths = [start], [start], []
            while stack:
                n = stack.pop()
                for eid in incident[n]:
                    u, v, data = edges[eid]
                    if n == u:  # count each edge once (from its first end)
                        lengths.append(data["length_m"])
                    for m in (u, v):
                        if m not in seen:
                            seen.add(m)
                            members.append(m)
                            stack.append(m)
            if math.fsum(lengths) < component:  # exactly rounded: no order dependence
                drop.extend(members)
        for n in drop:
            for eid in incident.pop(n):
                edges.pop(eid, None)
            del nodes[n], degree[n]
    thresholds = {
        "pruned_min_clearance_m": clearance,
        "pruned_min_spur_m": spur,
        "pruned_min_component_m": component,
    }
    return _renumbered(graph.graph, nodes, edges, degree, thresholds)


def _below(data: dict, clearance: float, edge: str) -> bool:
    """Is the edge's narrowest clearance known and below ``clearance`` (metres)?"""
    value = data.get("min_clearance_m")
    if value is None:
        return False
    if not is_real_number(value):
        raise TypeError(
            f"graph: {edge}: 'min_clearance_m': expected a real number of metres (NaN: "
            f"unknown), received {type(value).__name__} {value!r}"
        )
    value = float(value)
    return not math.isnan(value) and not clearance_at_least(value, clearance)  # NaN: unknown


def _copied(data: dict) -> dict:
    return {k: v.copy() if isinstance(v, np.ndarray) else v for k, v in data.items()}


def _same(a: object, b: object) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b))
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # no truth value
        return a is b


_JOINED = ("path", "world", "length_m", "min_clearance_m", "mean_clearance_m")


def _join(v, nodes: dict, edges: dict, incident: dict, degree: dict, res, new_ids) -> tuple:
    """Join the two edges of vertex ``v`` (degree 2, no self-loop) into one and drop
    ``v``; returns the joined edge's ends.  ``new_ids`` yields unused edge ids.

    The joined path runs through ``v``'s pixel once; its length is recomputed from it
    (``res`` = metres per pixel; None: the two lengths are added up), and its mean
    clearance is the mean over its pixels, from the two edges' means, pixel counts and
    ``v``'s clearance."""
    e1, e2 = sorted(incident[v])
    (u1, v1, ea), (u2, v2, eb) = edges.pop(e1), edges.pop(e2)
    a = u1 if v1 == v else v1
    b = u2 if v2 == v else v2
    pixel = nodes[v]["pixel"]
    p1, w1 = ea["path"], ea.get("world")
    if not _ends_at(p1, pixel):  # first edge: from a to v
        p1, w1 = p1[::-1], None if w1 is None else w1[::-1]
    p2, w2 = eb["path"], eb.get("world")
    if _ends_at(p2, pixel):  # second edge: from v to b
        p2, w2 = p2[::-1], None if w2 is None else w2[::-1]
    n1, n2 = len(p1), len(p2)
    # other attributes (not skeleton_to_graph's) survive where both edges agree
    joined = {
        key: val
        for key, val in ea.items()
        if key not in _JOINED and key in eb and _same(val, eb[key])
    }
    joined["path"] = np.concatenate([p1, p2[1:]])
    if w1 is not None and w2 is not None:
        joined["world"] = np.concatenate([w1, w2[1:]])
    if res is not None:
        joined["length_m"] = _path_length_m(joined["path"], res)
    else:  # not from skeleton_to_graph: add up
        joined["length_m"] = float(ea["length_m"]) + float(eb["length_m"])
    m1, m2 = float(ea.get("min_clearance_m", math.nan)), float(eb.get("min_clearance_m", math.nan))
    joined["min_clearance_m"] = math.nan if math.isnan(m1) or math.isnan(m2) else min(m1, m2)
    c = float(nodes[v].get("clearance_m", math.nan))
    mean1 = float(ea.get("mean_clearance_m", math.nan))
    mean2 = float(eb.get("mean_clearance_m", math.nan))
    joined["mean_clearance_m"] = (mean1 * n1 + mean2 * n2 - c) / (n1 + n2 - 1)
    del nodes[v], incident[v], degree[v]
    incident[a].discard(e1)
    incident[b].discard(e2)
    eid = next(new_ids)
    edges[eid] = (a, b, joined)
    incident[a].add(eid)
    incident[b].add(eid)
    return a, b


def _renumbered(
    attrs: dict, nodes: dict, edges: dict, degree: dict, thresholds: dict
) -> nx.MultiGraph:
    """The pruned graph: nodes ``0..N-1`` in raster order of ``pixel``, kinds from the
    degrees, edges ``(u, v)`` with ``u <= v`` and paths from ``u`` to ``v``."""
    order = sorted(nodes, key=lambda n: (int(nodes[n]["pixel"][0]), int(nodes[n]["pixel"][1])))
    new = {old: i for i, old in enumerate(order)}
    loops = {u for u, v, _ in edges.values() if u == v}
    node_attrs = []
    for old in order:
        data = _copied(nodes[old])
        if degree[old] == 2 and old in loops:
            data["kind"] = "ring"
        else:
            data["kind"] = {0: "isolated", 1: "end"}.get(degree[old], "junction")
        node_attrs.append(data)
    out = []
    for u, v, data in edges.values():
        u, v = sorted((new[u], new[v]))
        if u != v and not holds(node_attrs[v], data["path"][-1]):
            data["path"] = data["path"][::-1]
            if data.get("world") is not None:
                data["world"] = data["world"][::-1]
        out.append((u, v, _copied(data)))
    out.sort(key=lambda e: (e[0], e[1], e[2]["path"][:2].tolist()))
    return fill_multigraph({**attrs, **thresholds}, range(len(node_attrs)), node_attrs, out)
