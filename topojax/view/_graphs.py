"""A topology graph as the viewer's flat arrays: vertices (world position, kind,
clearance), edges (ends, length, clearances) and every edge's pixel path, which the page
routes on exactly as :class:`topojax.RoutePlanner` does.

Edge paths go as pixels (``[row, col]``, each pixel the difference from the one before,
which compresses to a fraction of a byte per pixel) when their ``world`` polylines are the
map's :meth:`~topojax.OccupancyMap.pixel_to_world` of them, as for every graph topojax
builds; the page then computes the world coordinates with the same formula.  Otherwise
the world polylines themselves go, as float64.
"""

from __future__ import annotations

import math
import reprlib
from dataclasses import dataclass

import networkx as nx
import numpy as np

from .._validate import nx_graph, real_values, xy_points
from ..graph import holds
from ..io import as_multigraph, jsonable
from ..maps.occupancy import grid_to_world
from ._encode import packed, pyramid

__all__ = ["Frame", "KIND_NAMES", "graph_payload", "graph_frame", "world_points"]

#: Vertex kinds in the order of their codes on the page (anything else is "other").
KIND_NAMES = ("junction", "end", "ring", "isolated", "other")

# world polylines within this of the map's pixel_to_world of the paths go as pixels
_SAME_M = 1e-9


@dataclass(frozen=True)
class Frame:
    """The map's pixel grid in the world: ``H x W`` pixels of ``resolution_m`` metres, the
    lower-left corner of the lower-left pixel at ``origin`` (x, y, yaw), as
    :class:`topojax.OccupancyMap`."""

    height: int
    width: int
    resolution_m: float
    origin: tuple[float, float, float]

    def pixel_to_world(self, rows, cols) -> tuple[np.ndarray, np.ndarray]:
        """World ``x, y`` (metres) of pixel centres, the formula of
        :meth:`topojax.OccupancyMap.pixel_to_world`."""
        return grid_to_world(
            rows, cols, height=self.height, resolution_m=self.resolution_m, origin=self.origin
        )

    def to_json(self) -> dict:
        return {
            "height": self.height,
            "width": self.width,
            "res": self.resolution_m,
            "origin": list(self.origin),
        }


def graph_frame(graph: nx.Graph) -> Frame | None:
    """The frame a graph records in its attributes (``shape``, ``resolution_m``,
    ``origin``, as :func:`topojax.build_graph` stores them), or None."""
    attrs = graph.graph
    try:
        h, w = (int(v) for v in attrs["shape"])
        res = float(attrs["resolution_m"])
        origin = tuple(float(v) for v in attrs.get("origin", (0.0, 0.0, 0.0)))
    except (KeyError, TypeError, ValueError):
        return None
    if h <= 0 or w <= 0 or not (math.isfinite(res) and res > 0) or len(origin) != 3:
        return None
    if not all(math.isfinite(v) for v in origin):
        return None
    return Frame(h, w, res, origin)


def world_points(value, name: str, *, one: bool) -> np.ndarray:
    """``value``, a vertex's ``world`` (x, y) when ``one``, else an edge's polyline, as
    float64 (K, 2); a ValueError naming ``name`` when it is not numbers in pairs."""
    if not one:
        return xy_points(value, name)
    try:
        return np.asarray(value, np.float64).reshape(1, 2)
    except (TypeError, ValueError):
        raise ValueError(
            f"{name}: expected a world position (x, y), received {reprlib.repr(value)}"
        ) from None


def _vertex_world(graph, frame: Frame | None, where: str) -> np.ndarray:
    xy = np.full((graph.number_of_nodes(), 2), np.nan)
    for i, (n, data) in enumerate(graph.nodes(data=True)):
        world = data.get("world")
        if world is None and frame is not None and data.get("pixel") is not None:
            world = frame.pixel_to_world(*data["pixel"])
        if world is None:
            raise ValueError(
                f"{where}: vertex {n!r} has neither a 'world' position (x, y) nor a "
                "'pixel' (row, col) on the map"
            )
        xy[i] = world_points(world, f"{where}: vertex {n!r}", one=True)[0]
        if not np.isfinite(xy[i]).all():  # the page would draw it nowhere
            raise ValueError(
                f"{where}: vertex {n!r}: expected a finite world position (x, y), received "
                f"{tuple(xy[i].tolist())}"
            )
    return xy


def _number(data: dict, name: str) -> float:
    value = data.get(name)
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _routable_edges(graph, where: str):
    """Per edge ``(a, b, path, world, length)`` with ``path`` running from ``a`` to ``b``,
    or a reason why the graph cannot be routed on (then the edges' world polylines)."""
    rows, reason = [], None
    for a, b, key, data in graph.edges(keys=True, data=True):
        name = f"edge ({a!r}, {b!r}, {key!r})"
        world = data.get("world")
        if world is None:
            raise ValueError(f"{where}: {name} has no 'world' polyline to draw")
        world = world_points(world, f"{where}: {name}", one=False)
        if len(world) == 0 or not np.isfinite(world).all():
            raise ValueError(f"{where}: {name}: its 'world' polyline is empty or not finite")
        path, length = data.get("path"), _number(data, "length_m")
        if path is not None:
            path = real_values(np.asarray(path))  # int4 as int8; bfloat16 is no integer
        why = None
        if path is None or path.shape != world.shape or not np.issubdtype(path.dtype, np.integer):
            why = f"{name} lacks an integer 'path' like its 'world'"
        elif not (math.isfinite(length) and length >= 0):
            got = data.get("length_m")
            why = f"{name}: expected a finite 'length_m' >= 0, received {got!r}"
        if why is not None:
            reason = reason or why
            rows.append((a, b, None, world, length))
            continue
        na, nb = f"{where}: vertex {a!r}", f"{where}: vertex {b!r}"
        if not (holds(graph.nodes[a], path[0], na) and holds(graph.nodes[b], path[-1], nb)):
            if holds(graph.nodes[b], path[0], nb) and holds(graph.nodes[a], path[-1], na):
                a, b = b, a
            else:
                reason = reason or f"the path of {name} does not run between its vertices' pixels"
        rows.append((a, b, path.astype(np.int64), world, length))
    return rows, reason


def graph_payload(
    graph, frame: Frame | None, *, name: str, label: str, raster: bool = False
) -> dict:
    """The page's description of one graph.

    Parameters
    ----------
    graph : networkx.Graph
        A topology or route graph (vertices with ``world`` or ``pixel``, edges with a
        ``world`` polyline; routes need ``path`` and ``length_m`` too).
    frame : Frame or None
        The map's grid; without one, paths go as world polylines.
    name, label : str
        Short id and the text shown for it.
    raster : bool
        Also ship the edges as a mask pyramid from half size down (``"raster"``), which
        the page draws instead of the polylines when zoomed out: tens of thousands of
        edges then cost a few tiles.  Only for paths on ``frame``'s grid.

    Raises
    ------
    TypeError
        ``graph`` is not a networkx graph.
    ValueError
        A vertex without a position, an edge without a ``world`` polyline, or values that
        are not finite.
    """
    nx_graph(name, graph)
    graph = as_multigraph(graph)
    where = f"{label}"
    index = {n: i for i, n in enumerate(graph.nodes)}
    vxy = _vertex_world(graph, frame, where)
    kinds = [graph.nodes[n].get("kind") for n in graph.nodes]
    codes = [KIND_NAMES.index(k) if k in KIND_NAMES[:-1] else len(KIND_NAMES) - 1 for k in kinds]
    clearance = [_number(graph.nodes[n], "clearance_m") for n in graph.nodes]
    rows, reason = _routable_edges(graph, where)
    sizes = np.array([len(r[3]) for r in rows], np.int64)
    edges = {
        "u": packed([index[r[0]] for r in rows], np.int32),
        "v": packed([index[r[1]] for r in rows], np.int32),
        "len": packed([r[4] for r in rows], np.float64),
        "cmin": packed(
            [_number(d, "min_clearance_m") for *_, d in graph.edges(data=True)], np.float32
        ),
        "cmean": packed(
            [_number(d, "mean_clearance_m") for *_, d in graph.edges(data=True)], np.float32
        ),
        "sizes": packed(sizes, np.int32),
    }
    edges.update(_geometry(rows, frame))
    mask = None
    if raster and frame is not None and "xy" not in edges and rows:
        mask = _edge_mask(rows, frame)
    return {
        "name": name,
        "label": label,
        "n_vertices": graph.number_of_nodes(),
        "n_edges": graph.number_of_edges(),
        "ids": [_label(n) for n in graph.nodes],
        "vx": packed(vxy[:, 0], np.float64),
        "vy": packed(vxy[:, 1], np.float64),
        "kind": packed(codes, np.uint8),
        "kinds": list(KIND_NAMES),
        "clear": packed(clearance, np.float32),
        "edges": edges,
        "routable": reason is None,
        "why_not_routable": reason,
        "resolution_m": _finite_or_none(_number(graph.graph, "resolution_m")),
        "raster": mask,
    }


def _edge_mask(rows, frame: Frame) -> dict | None:
    """The edges' pixels on the map's grid as a mask pyramid (levels of 2 and more map
    pixels per level pixel; lines kept by the maximum)."""
    pixels = np.concatenate([r[2] for r in rows])
    inside = (
        (pixels[:, 0] >= 0)
        & (pixels[:, 0] < frame.height)
        & (pixels[:, 1] >= 0)
        & (pixels[:, 1] < frame.width)
    )
    mask = np.zeros((frame.height, frame.width), np.uint8)
    mask[pixels[inside, 0], pixels[inside, 1]] = 255
    levels = pyramid(mask, reduce="max", blank=0, min_step=2)
    return levels if levels["levels"] else None  # a small map: the lines are few


def _geometry(rows, frame: Frame | None) -> dict:
    """The edges' polylines: ``rc`` (pixel rows and columns, each the difference from the
    previous pixel of all paths in order) when every path is on ``frame``'s grid as its
    world polyline says; else ``xy`` (world, float64) and, for routing, ``rc`` as well."""
    if not rows:
        return {"rc": packed([], np.int32)}
    worlds = np.concatenate([r[3] for r in rows])
    if all(r[2] is not None for r in rows):
        pixels = np.concatenate([r[2] for r in rows])
        steps = np.diff(pixels, axis=0, prepend=np.zeros((1, 2), np.int64))
        out = {"rc": packed(steps, np.int32)}  # row, col, row, col, ...: differences
        if frame is not None:
            x, y = frame.pixel_to_world(pixels[:, 0], pixels[:, 1])
            if np.abs(np.stack([x, y], 1) - worlds).max() <= _SAME_M:
                return out
        out["xy"] = packed(worlds.ravel(), np.float64)
        return out
    return {"xy": packed(worlds.ravel(), np.float64)}


def _finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _label(node) -> str | int | float:
    """A vertex id as the page shows it (JSON numbers and strings as they are)."""
    try:
        value = jsonable(node, "vertex id")
    except (TypeError, ValueError):
        return repr(node)
    return value if isinstance(value, (str, int, float)) else repr(node)
