"""The geometry of an arbitrary route graph as the evaluator sees it.

Every vertex gets a position and every edge a polyline in continuous pixel coordinates of
the map (pixel centres at integer ``(row, col)``); polylines are densified to points at
most one pixel apart.  Lengths are in pixels here (a rotation of the map frame keeps
them); the caller converts to metres.
"""

from __future__ import annotations

import reprlib
from dataclasses import dataclass

import networkx as nx
import numpy as np

from .._words import graphml_text

__all__ = ["GraphGeometry", "graph_geometry", "pixel_lookup", "touched_pixels", "vertex_pixels"]

# Polyline ends closer than this (pixels) to their vertex count as lying on it.
_END_TOL_PX = 1e-6


@dataclass(frozen=True, eq=False)
class GraphGeometry:
    """Vertices, edges and densified points of a graph in pixel coordinates.

    Attributes
    ----------
    n_vertices, n_edges : int
        Vertices and (real) edges of the graph.
    edge_u, edge_v : int64 (n_edges + n_isolated,)
        End vertices of each edge; rows ``n_edges..`` are zero-length pseudo edges, one per
        isolated vertex, so that such a vertex is a graph point too.
    edge_len_px : float64 (n_edges,)
        Length of each real edge's polyline.
    pt_rc : float64 (N, 2)
        Densified points ``(row, col)``, edge after edge, each edge from ``u`` to ``v``.
    pt_edge : int64 (N,)
        Edge (or pseudo edge) of each point.
    pt_s : float64 (N,)
        Arc length of each point from the start of its edge.
    pt_vertex : int64 (N,)
        Vertex at the point for the first and last point of an edge, else -1.
    """

    n_vertices: int
    n_edges: int
    edge_u: np.ndarray
    edge_v: np.ndarray
    edge_len_px: np.ndarray
    pt_rc: np.ndarray
    pt_edge: np.ndarray
    pt_s: np.ndarray
    pt_vertex: np.ndarray


# A coordinate this close to halfway between two pixel centres lies on their border.
_TIE = 1e-9


def _has(data: dict, key: str) -> bool:
    """Whether ``data`` holds ``key`` with a value other than None."""
    return data.get(key) is not None


def _received(value) -> str:
    """``value`` as an error message shows it: text (GraphML keeps lists as text, which
    networkx's reader leaves as it is) said to be text, with the reader that decodes it."""
    return f"{type(value).__name__} {reprlib.repr(value)}{graphml_text(value)}"


def _vertex_point(node, data: dict, coordinates: str) -> tuple[np.ndarray, bool]:
    """One vertex's ``world`` (x, y) or ``pixel`` (row, col) attribute, checked, and
    whether it is ``world``."""
    # an attribute set to None is a missing one (as save_nav2_graph reads it)
    use_world = coordinates == "world" or (coordinates == "auto" and _has(data, "world"))
    key = "world" if use_world else "pixel"
    if not _has(data, key):
        wanted = {
            "world": "a 'world' attribute ((x, y) metres)",
            "pixel": "a 'pixel' attribute ((row, col) pixels)",
            "auto": "a 'world' ((x, y) metres) or 'pixel' ((row, col) pixels) attribute",
        }[coordinates]
        unset = [str(k) for k in ("world", "pixel") if k in data and data[k] is None]
        none = f" ({' and '.join(map(repr, unset))} set to None)" if unset else ""
        raise ValueError(
            f"graph: expected every vertex to carry {wanted}, vertex {node!r} has "
            f"attributes {sorted(map(str, data))}{none}"
        )
    try:
        q = np.asarray(data[key], dtype=np.float64).ravel()
    except (TypeError, ValueError):
        q = np.empty(0)
    if q.size < 2 or not np.isfinite(q[:2]).all():
        raise ValueError(
            f"graph: vertex {node!r} attribute {key!r}: expected two finite numbers, "
            f"received {_received(data[key])}"
        )
    return q[:2], use_world


def vertex_pixels(graph: nx.Graph, nodes: list, occupancy, coordinates: str) -> np.ndarray:
    """Pixel ``(row, col)`` (float64 (V, 2)) of each of ``nodes``; world positions are
    converted with the map, all at once."""
    pos = np.empty((len(nodes), 2), np.float64)
    world_at, world = [], []
    for i, n in enumerate(nodes):
        q, use_world = _vertex_point(n, graph.nodes[n], coordinates)
        if use_world:
            world_at.append(i)
            world.append(q)
        else:
            pos[i] = q
    if world_at:
        xy = np.array(world, np.float64)
        r, c = occupancy.world_to_pixel(xy[:, 0], xy[:, 1])
        pos[world_at, 0], pos[world_at, 1] = r, c
    return pos


def _edge_points(edge, data: dict, coordinates: str) -> tuple[np.ndarray | None, bool]:
    """The edge's own polyline (float64 (K, 2)), checked, and whether it is in world
    coordinates: ``path`` with pixel coordinates, else ``waypoints`` (the polyline a
    robot follows) if present, else ``world``, else (with ``"auto"``) ``path``; None for
    a straight edge."""
    if coordinates == "pixel":
        key = "path"
    else:
        key = next((k for k in ("waypoints", "world") if _has(data, k)), "world")
        if not _has(data, key) and coordinates == "auto" and _has(data, "path"):
            key = "path"  # a graph in pixels: its vertices' pixel, its edges' path
    if not _has(data, key):
        return None, False
    try:
        if isinstance(data[key], (str, bytes)):  # numpy would read "1.5" as a number
            raise TypeError
        arr = np.asarray(data[key], dtype=np.float64)
    except (TypeError, ValueError):  # not numbers, or rows of different lengths
        raise ValueError(
            f"graph: edge {edge!r} attribute {key!r}: expected a (K, 2) array of finite "
            f"numbers, received {_received(data[key])}"
        ) from None
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 2 or not np.isfinite(arr[:, :2]).all():
        got = f"shape {arr.shape}"
        if arr.ndim == 2 and arr.shape[0] >= 1 and arr.shape[1] >= 2:  # the shape is right
            row = int(np.flatnonzero(~np.isfinite(arr[:, :2]).all(axis=1))[0])
            got += f" with a non-finite point {arr[row, :2].tolist()} at row {row}"
        raise ValueError(
            f"graph: edge {edge!r} attribute {key!r}: expected a (K, 2) array of finite "
            f"numbers, received {got}"
        )
    return arr[:, :2], key != "path"


def _edge_polylines(items: list, occupancy, coordinates: str) -> list:
    """Each edge's own polyline (float64 (K, 2)) in pixels, or None for a straight edge;
    world polylines are converted with the map, all at once."""
    polys, world_at = [], []
    for edge, _, _, data in items:
        arr, is_world = _edge_points(edge, data, coordinates)
        if is_world:
            world_at.append(len(polys))
        polys.append(arr)
    if world_at:
        sizes = [polys[i].shape[0] for i in world_at]
        xy = np.concatenate([polys[i] for i in world_at])
        r, c = occupancy.world_to_pixel(xy[:, 0], xy[:, 1])
        rc = np.split(np.stack([r, c], axis=1), np.cumsum(sizes)[:-1])
        for i, p in zip(world_at, rc, strict=True):
            polys[i] = p
    return polys


def _oriented(polys: list, pu: np.ndarray, pv: np.ndarray) -> list[np.ndarray]:
    """Each of ``polys`` running from its ``pu`` to its ``pv`` (float64 (E, 2)): reversed
    if stored the other way, the vertex positions added where an end does not lie on its
    vertex, a straight segment for None, a one-point polyline doubled."""
    straight = np.array([p is None for p in polys], bool)
    first = np.array([pu[i] if p is None else p[0] for i, p in enumerate(polys)]).reshape(-1, 2)
    last = np.array([pv[i] if p is None else p[-1] for i, p in enumerate(polys)]).reshape(-1, 2)
    flip = np.hypot(*(last - pu).T) < np.hypot(*(first - pu).T)
    start, end = np.where(flip[:, None], last, first), np.where(flip[:, None], first, last)
    add_u = (np.hypot(*(start - pu).T) > _END_TOL_PX).tolist()
    add_v = (np.hypot(*(end - pv).T) > _END_TOL_PX).tolist()
    straight, flip = straight.tolist(), flip.tolist()
    out = []
    for i, p in enumerate(polys):
        if straight[i]:
            out.append(np.stack([pu[i], pv[i]]))
            continue
        if flip[i]:
            p = p[::-1]
        if add_u[i] or add_v[i]:
            p = np.vstack([pu[i][None]] * add_u[i] + [p] + [pv[i][None]] * add_v[i])
        out.append(p if p.shape[0] > 1 else np.vstack([p, p]))
    return out


def _lengths(polys: list[np.ndarray]) -> np.ndarray:
    """Length (float64 (len(polys),)) of each polyline (K >= 1, 2)."""
    if not polys:
        return np.zeros(0, np.float64)
    sizes = np.array([p.shape[0] for p in polys], np.int64)
    allp = np.concatenate(polys)
    owner = np.repeat(np.arange(len(polys)), sizes)
    same = owner[1:] == owner[:-1]
    step = np.hypot(*np.diff(allp, axis=0).T)
    return np.bincount(owner[1:][same], weights=step[same], minlength=len(polys))


def _densify(polys: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Points at most 1 px apart along each polyline, its own vertices kept.

    Returns ``(rc (N, 2), edge (N,), s (N,), is_end (N,) int8: 1 first, 2 last, 3 both)``.
    """
    n_poly = len(polys)
    sizes = np.array([p.shape[0] for p in polys], np.int64)
    allp = np.concatenate(polys) if polys else np.empty((0, 2))
    last = np.cumsum(sizes) - 1
    edge_of_pt = np.repeat(np.arange(n_poly), sizes)
    seg_start = np.setdiff1d(np.arange(allp.shape[0]), last, assume_unique=True)
    d = allp[seg_start + 1] - allp[seg_start]
    n_sub = np.maximum(1, np.ceil(np.hypot(d[:, 0], d[:, 1]) - 1e-9)).astype(np.int64)
    rep = np.repeat(np.arange(seg_start.size), n_sub)
    k = np.arange(rep.size) - np.repeat(np.cumsum(n_sub) - n_sub, n_sub)
    sub_rc = allp[seg_start[rep]] + (k / n_sub[rep])[:, None] * d[rep]
    sub_edge = edge_of_pt[seg_start[rep]]
    n_sub_edge = np.bincount(sub_edge, minlength=n_poly).astype(np.int64)
    out_size = n_sub_edge + 1
    out_start = np.cumsum(out_size) - out_size
    sub_first = np.cumsum(n_sub_edge) - n_sub_edge
    n = int(out_size.sum())
    rc = np.empty((n, 2))
    pos = out_start[sub_edge] + np.arange(rep.size) - sub_first[sub_edge]
    rc[pos] = sub_rc
    rc[out_start + out_size - 1] = allp[last]
    edge = np.repeat(np.arange(n_poly, dtype=np.int64), out_size)
    step = np.zeros(n)
    if n > 1:
        step[1:] = np.hypot(*(rc[1:] - rc[:-1]).T)
    step[out_start] = 0.0
    cs = np.cumsum(step)
    s = cs - np.repeat(cs[out_start], out_size) if n else cs
    is_end = np.zeros(n, np.int8)
    is_end[out_start] |= 1
    is_end[out_start + out_size - 1] |= 2
    return rc, edge, s, is_end


def _rc(point: np.ndarray) -> str:
    return f"({float(point[0]):.6g}, {float(point[1]):.6g})"


def _check_near_map(polys, pos, nodes, keys, shape) -> None:
    """Refuse a vertex or polyline point farther outside the map than the map's own size
    (a graph in another frame or unit; it would be densified pixel by pixel)."""
    h, w = shape
    lo, hi = np.array([-h, -w], float), np.array([2 * h, 2 * w], float)

    def far(rc: np.ndarray) -> np.ndarray:
        return ~np.all((rc >= lo) & (rc <= hi), axis=-1)

    where = None
    bad = np.flatnonzero(far(pos))
    if bad.size:
        where = f"vertex {nodes[bad[0]]!r} lies at pixel {_rc(pos[bad[0]])}"
    else:
        for key, poly in zip(keys, polys, strict=True):
            if far(poly).any():
                where = f"edge {key!r} runs to pixel {_rc(poly[far(poly)][0])}"
                break
    if where is not None:
        raise ValueError(
            f"graph: {where}, expected at most the map's own size ({h} x {w} pixels) "
            "outside the map: is the graph in the map's frame and in metres?"
        )


def graph_geometry(graph: nx.Graph, occupancy, coordinates: str) -> GraphGeometry:
    """The :class:`GraphGeometry` of ``graph`` on ``occupancy``.

    Parameters
    ----------
    graph : networkx.Graph or MultiGraph
        Undirected; vertices carry ``world`` (x, y) metres or ``pixel`` (row, col); edges
        carry a ``world`` (K, 2) polyline in metres (``path`` in pixels with
        ``coordinates="pixel"``, or with ``"auto"`` where there is no ``world``) or are
        straight segments between their vertices.
    occupancy : OccupancyMap
        Supplies the world <-> pixel transform.
    coordinates : {"auto", "world", "pixel"}
        ``"auto"``: each vertex's ``world`` if present, else its ``pixel``; each edge's
        ``world`` if present, else its ``path``.

    Returns
    -------
    GraphGeometry
    """
    nodes = list(graph.nodes)
    index = {n: i for i, n in enumerate(nodes)}
    pos = vertex_pixels(graph, nodes, occupancy, coordinates)
    if graph.is_multigraph():
        items = [((u, v, k), u, v, d) for u, v, k, d in graph.edges(keys=True, data=True)]
    else:
        items = [((u, v), u, v, d) for u, v, d in graph.edges(data=True)]
    us = [index[u] for _, u, _, _ in items]
    vs = [index[v] for _, _, v, _ in items]
    polys = _oriented(
        _edge_polylines(items, occupancy, coordinates),
        pos[np.array(us, np.int64)].reshape(-1, 2),
        pos[np.array(vs, np.int64)].reshape(-1, 2),
    )
    _check_near_map(polys, pos, nodes, [key for key, *_ in items], occupancy.shape)
    n_edges = len(polys)
    edge_len = _lengths(polys)
    isolated = [index[n] for n in nodes if graph.degree(n) == 0]
    for i in isolated:
        polys.append(pos[i][None, :])
        us.append(i)
        vs.append(i)
    rc, edge, s, is_end = _densify(polys)
    eu, ev = np.array(us, np.int64), np.array(vs, np.int64)
    vertex = np.full(edge.size, -1, np.int64)
    first, final = (is_end & 1) > 0, (is_end & 2) > 0
    vertex[final] = ev[edge[final]]
    vertex[first] = eu[edge[first]]  # a one-point pseudo edge is its vertex
    return GraphGeometry(
        n_vertices=len(nodes),
        n_edges=n_edges,
        edge_u=eu,
        edge_v=ev,
        edge_len_px=edge_len,
        pt_rc=rc,
        pt_edge=edge,
        pt_s=s,
        pt_vertex=vertex,
    )


def _touched_ranges(rc: np.ndarray):
    """The lowest and highest row and column of the pixels each point ``rc`` (..., 2)
    touches: its own, or both pixels of a border it lies on (a coordinate exactly
    halfway between two centres)."""
    r_lo = np.ceil(rc[..., 0] - 0.5 - _TIE)
    r_hi = np.floor(rc[..., 0] + 0.5 + _TIE)
    c_lo = np.ceil(rc[..., 1] - 0.5 - _TIE)
    c_hi = np.floor(rc[..., 1] + 0.5 + _TIE)
    return (r_lo, r_hi), (c_lo, c_hi)


def pixel_lookup(mask: np.ndarray, rc: np.ndarray) -> np.ndarray:
    """Whether each point ``rc`` (..., 2) lies on a pixel of ``mask``: the pixel it is
    inside, or, for a point on a border or corner shared by pixels (a coordinate exactly
    halfway between two centres), any of the pixels it touches; False off the map."""
    rc = np.asarray(rc, np.float64)
    h, w = mask.shape
    out = np.zeros(rc.shape[:-1], bool)
    rows, cols = _touched_ranges(rc)
    for r in rows:
        for c in cols:
            inside = (r >= 0) & (r < h) & (c >= 0) & (c < w) & ~out
            out[inside] = mask[r[inside].astype(np.int64), c[inside].astype(np.int64)]
    return out


def touched_pixels(rc: np.ndarray, shape) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every map pixel each point ``rc`` (N, 2) lies on, as ``pixel_lookup`` reads them
    (the pixel it is inside, or each pixel of a border or corner it lies on; none off
    the map): ``(point, row, col)``, int64, one entry per point and pixel."""
    rc = np.asarray(rc, np.float64).reshape(-1, 2)
    h, w = shape
    rows, cols = _touched_ranges(rc)
    point = np.arange(rc.shape[0])
    parts = []
    for i, r in enumerate(rows):
        for j, c in enumerate(cols):
            new = (r >= 0) & (r < h) & (c >= 0) & (c < w)
            if i:  # the second row only where it differs from the first: once each
                new &= rows[1] != rows[0]
            if j:
                new &= cols[1] != cols[0]
            parts.append((point[new], r[new].astype(np.int64), c[new].astype(np.int64)))
    return tuple(np.concatenate([p[k] for p in parts]) for k in range(3))
