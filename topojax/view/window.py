"""A window of a view: the part of a map (and of its layers, graphs and rooms) inside a
world box, for maps too large to ship whole."""

from __future__ import annotations

import math

import networkx as nx
import numpy as np

from .._validate import is_real_number

__all__ = ["checked_window", "apply_window"]


def checked_window(window, *, name: str = "window") -> tuple[float, float, float, float]:
    """``(x_min, y_min, x_max, y_max)`` as floats after checking them; errors name the
    argument ``name`` and the order expected."""
    expected = f"{name}: expected (x_min, y_min, x_max, y_max) in metres"
    try:
        items = list(window)
    except TypeError:
        items = None
    if items is None or not all(is_real_number(v) for v in items):  # not "1", not True
        raise TypeError(f"{expected}, received {type(window).__name__} {window!r}")
    box = tuple(float(v) for v in items)
    if len(box) != 4 or not all(math.isfinite(v) for v in box):
        raise ValueError(f"{name}: expected four finite numbers (metres), received {window!r}")
    if not (box[0] < box[2] and box[1] < box[3]):
        raise ValueError(f"{expected} with x_min < x_max and y_min < y_max, received {window!r}")
    return box


def _pixel_box(occupancy, box) -> tuple[int, int, int, int]:
    """Rows ``r0:r1`` and columns ``c0:c1`` of the pixels whose centres' squares meet
    the world box."""
    xs = [box[0], box[2], box[0], box[2]]
    ys = [box[1], box[1], box[3], box[3]]
    rows, cols = occupancy.world_to_pixel(xs, ys)
    h, w = occupancy.shape
    r0 = max(0, math.floor(float(np.min(rows)) + 0.5))
    r1 = min(h, math.floor(float(np.max(rows)) + 0.5) + 1)
    c0 = max(0, math.floor(float(np.min(cols)) + 0.5))
    c1 = min(w, math.floor(float(np.max(cols)) + 0.5) + 1)
    if r1 - r0 < 2 or c1 - c0 < 2:
        raise ValueError(
            f"window: {box} covers less than 2 x 2 pixels of the map (its world extent "
            f"is {_extent(occupancy)})"
        )
    return r0, r1, c0, c1


def _extent(occupancy) -> str:
    h, w = occupancy.shape
    x, y = occupancy.pixel_to_world([-0.5, -0.5, h - 0.5, h - 0.5], [-0.5, w - 0.5, -0.5, w - 0.5])
    return f"x {np.min(x):.2f} to {np.max(x):.2f} m, y {np.min(y):.2f} to {np.max(y):.2f} m"


def _cropped_map(occupancy, r0, r1, c0, c1):
    """The window's OccupancyMap, in the map's frame; of a TiledMap, only the window's
    pixels are read."""
    from ..maps import OccupancyMap
    from ..maps.tiled import TiledMap

    x, y = occupancy.pixel_to_world(r1 - 0.5, c0 - 0.5)  # the window's lower-left corner
    if isinstance(occupancy, TiledMap):
        masks = _masks(occupancy.occupancy(r0, r1, c0, c1), 0, None, 0, None)
    else:
        masks = _masks(occupancy, r0, r1, c0, c1)
    return OccupancyMap(
        **masks,
        resolution_m=occupancy.resolution_m,
        origin=(float(x), float(y), occupancy.origin[2]),
        source=occupancy.source,
    )


def _masks(occupancy, r0, r1, c0, c1) -> dict:
    return {
        name: np.ascontiguousarray(getattr(occupancy, name)[r0:r1, c0:c1])
        for name in ("occupied", "free", "unknown")
    }


def _inside(pixels: np.ndarray, r0, r1, c0, c1) -> np.ndarray:
    return (pixels[:, 0] >= r0) & (pixels[:, 0] < r1) & (pixels[:, 1] >= c0) & (pixels[:, 1] < c1)


def _cropped_graph(graph: nx.Graph, box, pixel_box) -> nx.MultiGraph:
    """The edges of ``graph`` that run through the window, whole, with their vertices
    (and the vertices inside it); pixels shifted to the window's grid."""
    from ..io import as_multigraph

    r0, r1, c0, c1 = pixel_box
    graph = as_multigraph(graph)
    out = nx.MultiGraph()
    out.graph.update(graph.graph)
    out.graph["shape"] = (r1 - r0, c1 - c0)
    shift = np.array([r0, c0])

    def inside_world(world) -> bool:
        xy = np.asarray(world, np.float64).reshape(-1, 2)
        return bool(
            np.any(
                (xy[:, 0] >= box[0])
                & (xy[:, 0] <= box[2])
                & (xy[:, 1] >= box[1])
                & (xy[:, 1] <= box[3])
            )
        )

    def vertex(n) -> None:
        if n in out:
            return
        data = dict(graph.nodes[n])
        for name in ("pixel", "pixels"):
            if data.get(name) is not None:
                value = np.asarray(data[name]) - shift
                data[name] = tuple(int(v) for v in value) if name == "pixel" else value
        out.add_node(n, **data)

    for n, data in graph.nodes(data=True):
        pixel = data.get("pixel")
        if pixel is not None:
            keep = bool(_inside(np.asarray(pixel).reshape(1, 2), *pixel_box)[0])
        else:
            keep = data.get("world") is not None and inside_world(data["world"])
        if keep:
            vertex(n)
    for a, b, key, data in graph.edges(keys=True, data=True):
        path = data.get("path")
        if path is not None:
            keep = bool(_inside(np.asarray(path).reshape(-1, 2), *pixel_box).any())
        else:
            keep = data.get("world") is not None and inside_world(data["world"])
        if not keep:
            continue
        vertex(a)
        vertex(b)
        data = dict(data)
        if path is not None:
            data["path"] = np.asarray(path) - shift
        out.add_edge(a, b, key=key, **data)
    return out


def _cropped_rooms(rooms, box):
    from ..rooms import RoomSegmentation

    if isinstance(rooms, RoomSegmentation):
        room_list, door_list = rooms.rooms, rooms.doors
    else:
        room_list, door_list = rooms

    def meets(xy) -> bool:
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        if not len(xy):
            return False
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        return bool(lo[0] <= box[2] and hi[0] >= box[0] and lo[1] <= box[3] and hi[1] >= box[1])

    return (
        tuple(r for r in room_list if meets(r.polygon)),
        tuple(d for d in door_list if meets(d.ends_world)),
    )


def apply_window(inputs, window, *, max_pixels: int) -> None:
    """Cut ``inputs`` (see :class:`topojax.view._data.Inputs`) down to ``window``, a world
    box (x_min, y_min, x_max, y_max) in metres: the map and its layers to the pixels in
    it, each graph to the edges that pass through it, the rooms to those that meet it.
    A window of more than ``max_pixels`` is refused before its pixels are read."""
    box = checked_window(window)
    if inputs.map is None:
        raise ValueError("window: needs a map to cut (the view has none)")
    pixel_box = _pixel_box(inputs.map, box)
    r0, r1, c0, c1 = pixel_box
    if (r1 - r0) * (c1 - c0) > max_pixels:
        raise ValueError(
            f"window: {box} covers {r1 - r0} x {c1 - c0} pixels of the map, more than "
            f"max_pixels={max_pixels}; view a smaller window or pass a larger max_pixels"
        )
    inputs.map = _cropped_map(inputs.map, r0, r1, c0, c1)
    inputs.window = box
    inputs.rasters = {k: np.asarray(v)[r0:r1, c0:c1] for k, v in inputs.rasters.items()}
    inputs.graphs = [(n, lab, _cropped_graph(g, box, pixel_box)) for n, lab, g in inputs.graphs]
    for _, _, g in inputs.graphs:  # the window's grid: its shape (set) and origin
        g.graph["origin"] = tuple(float(v) for v in inputs.map.origin)
    if inputs.rooms is not None:
        inputs.rooms = _cropped_rooms(inputs.rooms, box)
    inputs.notes.append(
        f"a window of the map: x {box[0]:g} to {box[2]:g} m, y {box[1]:g} to {box[3]:g} m "
        "(graphs keep the edges that pass through it, whole; routes run on those)"
    )
