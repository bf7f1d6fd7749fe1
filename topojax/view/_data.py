"""The viewer's data: what :func:`topojax.write_view` puts into the page, as one
JSON-able dict (rasters as PNG tile pyramids, graphs and rooms as flat arrays)."""

from __future__ import annotations

import math
import sys

import cv2
import networkx as nx
import numpy as np

from .._validate import instance_of, nonnegative_metres, nx_graph
from .._words import counted
from ..graph import graph_resolution_m
from ..maps.occupancy import grid_mismatch, map_mismatch
from ..maps.tiled import TiledMap
from ..routing import DEFAULT_ENTRY_M, DEFAULT_MAX_SNAP_M
from ._encode import packed, pyramid
from ._graphs import Frame, graph_frame, graph_payload, world_points
from ._rooms_data import is_room_pair, pair_mismatch, rooms_payload, rounded

__all__ = ["DEFAULT_MAX_PIXELS", "FORMAT_VERSION", "Inputs", "build_payload", "inputs_of"]

#: The most map pixels a view ships to a browser (64 Mpx).  The page itself stays smooth
#: far beyond it (only the tiles in sight are decoded); the limit keeps the file, and
#: the memory a browser needs to open it, reasonable.
DEFAULT_MAX_PIXELS = 64_000_000
#: Version of the page's data layout.
FORMAT_VERSION = 1
#: The finest level of the distance map's pyramid is at most this many pixels across
#: (a smooth field: finer adds bytes, not detail).
DISTANCE_MAX_SIDE_PX = 2048


class Inputs:
    """What one view shows, gathered from the object given to :func:`write_view`:
    ``map`` (an OccupancyMap or None), ``rasters`` (name -> array), ``graphs`` (list of
    ``(name, label, graph)``), ``rooms`` (RoomSegmentation, ``(rooms, doors)`` or None),
    ``route``, ``timeline``, ``title`` and ``window``."""

    def __init__(self) -> None:
        self.map = None
        self.rasters: dict[str, np.ndarray] = {}
        self.graphs: list[tuple[str, str, nx.Graph]] = []
        self.rooms = None
        self.route = None
        self.timeline = None
        self.no_rooms = False  # rooms=False: none, not even a timeline's
        self.title = "topojax view"
        self.window = None  # the world box a window cut the inputs to
        self.notes: list[str] = []


def _result_inputs(result, out: Inputs, *, pruned: bool) -> None:
    out.map = result.map
    out.rasters = {
        "distance": result.distance,
        "ridges": result.ridges,
        "skeleton": result.skeleton,
    }
    label = "pruned graph" if pruned else "graph"
    out.graphs.append(("graph", label, result.graph))


def _instance(obj, module: str, name: str) -> bool:
    """``isinstance(obj, module.name)`` without importing ``module`` (JAX, numba) when it
    is not loaded yet: then ``obj`` cannot be one of its classes."""
    mod = sys.modules.get(module)
    return mod is not None and isinstance(obj, getattr(mod, name))


def inputs_of(
    obj,
    *,
    map=None,
    rooms=None,
    graphs=None,
    route=None,
    timeline=None,
    title=None,
    max_pixels: int | None = None,
):
    """Sort ``obj`` and the keyword arguments of :func:`write_view` into :class:`Inputs`.

    ``max_pixels``, where given, is checked against a ``TiledResult``'s map before its
    graph is read (pass None when a window will be applied).

    Raises
    ------
    TypeError
        ``obj`` or an argument of a type the viewer does not show.
    ValueError
        A ``TiledResult`` whose map is larger than ``max_pixels``.
    """
    from ..maps import OccupancyMap

    out = Inputs()
    tiled_result = _instance(obj, "topojax.outofcore.build", "TiledResult")
    shown = obj.map if tiled_result and map is None else map
    if tiled_result and max_pixels is not None and isinstance(shown, (OccupancyMap, TiledMap)):
        # refused before the result's graph is turned into networkx, which on a map this
        # large takes seconds and gigabytes
        _check_size(_map_frame(shown), max_pixels)
    if _instance(obj, "topojax.pipeline", "TopologyResult"):
        _result_inputs(obj, out, pruned=obj.config.graph.prunes)
        out.title = _title_of(obj.map, "topology graph")
    elif _instance(obj, "topojax.incremental.mapper", "IncrementalMapper"):
        if obj.pixel_bbox is None:
            raise ValueError("obj: the mapper has no map yet (add scans or points first)")
        from ..incremental import keeps_rooms  # only for a mapper: no import otherwise

        if rooms is None and keeps_rooms(obj):
            rooms = True
        if rooms is True:
            rooms = obj.rooms  # its first read updates the graph: the graph is taken after
        _result_inputs(obj.to_result(update=False), out, pruned=False)
        out.title = f"incremental mapper, {counted(obj.n_scans, 'scan')}"
    elif _instance(obj, "topojax.rooms.model", "RoomSegmentation"):
        out.map = obj.occupancy
        out.rooms = obj
        out.title = _title_of(obj.occupancy, "rooms")
    elif tiled_result:
        out.map = obj.map  # a TiledMap: read when shown (a window of it, at most)
        out.graphs.append(
            ("graph", "pruned graph" if obj.config.graph.prunes else "graph", obj.graph)
        )
        out.title = _title_of(obj.map, "topology graph")
    elif isinstance(obj, nx.Graph):
        out.graphs.append(("graph", _graph_label(obj), obj))
        out.title = _graph_label(obj)
    elif isinstance(obj, (OccupancyMap, TiledMap)):
        out.map = obj
        out.title = _title_of(obj, "map")
    else:
        raise TypeError(
            "obj: expected a TopologyResult, a TiledResult, an IncrementalMapper, a "
            "RoomSegmentation, a networkx graph, an OccupancyMap or a TiledMap, received "
            f"{type(obj).__name__}"
        )
    if map is not None:
        own = out.map
        out.map = instance_of("map", map, (OccupancyMap, TiledMap), "OccupancyMap or a TiledMap")
        _fields_on_the_map(out, own)
    if rooms is True:
        from ..rooms import segment_rooms

        if out.map is None:
            raise ValueError("rooms=True needs a map to segment; pass map=...")
        if isinstance(out.map, TiledMap):
            raise ValueError(
                "rooms=True: the map is a TiledMap, read a window at a time; pass the rooms "
                "segmented beforehand (rooms=tj.segment_rooms(...))"
            )
        rooms = segment_rooms(out.map)
    if rooms is not None and rooms is not False:
        if not (_instance(rooms, "topojax.rooms.model", "RoomSegmentation") or is_room_pair(rooms)):
            raise TypeError(
                "rooms: expected a RoomSegmentation, the (rooms, doors) pair of "
                f"topojax.load_rooms, True or False, received {type(rooms).__name__}"
            )
        out.rooms = rooms
    own_graphs = len(out.graphs)
    if timeline is not None and not own_graphs:  # the page steps through obj's own graph
        article = "an" if type(obj).__name__[0] in "AEIOU" else "a"
        raise ValueError(
            "timeline: expected obj to be the mapper (or its graph) whose graph the timeline "
            f"steps through, received {article} {type(obj).__name__} with no graph of its own"
        )
    for name, graph in _extra_graphs(graphs, [label for _, label, _ in out.graphs]):
        out.graphs.append((f"g{len(out.graphs)}", name, graph))
    out.route = _checked_route(route)
    out.timeline = _checked_timeline(timeline)
    out.no_rooms = rooms is False
    if title is not None:
        out.title = instance_of("title", title, str)
    # a graph beside a map of another (one given in map=, or any in graphs= beside the
    # object's own map): drawn, but said so
    if out.map is not None:
        _note_other_maps(out, out.graphs if map is not None else out.graphs[own_graphs:])
    return out


def _note_other_maps(out: Inputs, checked) -> None:
    """Note each of the ``checked`` graphs, the rooms, the route and the timeline that
    was not made on ``out.map``: drawn, but said so."""
    for _, label, graph in checked:
        why = map_mismatch(graph, out.map)
        if why is not None:
            out.notes.append(f"the {label} was not built on the map shown: {why}")
    if _instance(out.rooms, "topojax.rooms.model", "RoomSegmentation"):
        own = out.rooms.occupancy
        why = grid_mismatch(own.shape, own.resolution_m, own.origin, out.map, owner="their")
        if why is not None:
            out.notes.append(f"the rooms were not segmented on the map shown: {why}")
    elif out.rooms is not None:  # a pair: load_rooms' records the file's map, if stated
        frame = [getattr(out.rooms, k, None) for k in ("shape", "resolution_m", "origin")]
        why = grid_mismatch(*frame, out.map, owner="their")
        if why is None:  # as far as it is stated, their map: their pixels must fit it
            why = pair_mismatch(out.rooms, out.map)
        if why is not None:
            out.notes.append(f"the rooms were not segmented on the map shown: {why}")
    if out.route is not None:
        why = _route_mismatch(out.route, out.map)
        if why is not None:
            out.notes.append(f"the route was not planned on the map shown: {why}")
    if out.timeline is not None:
        why = _timeline_beyond(out.timeline, out.map)
        if why is not None:
            out.notes.append(f"the timeline was not recorded on the map shown: {why}")


def _route_mismatch(route, occupancy) -> str | None:
    """Why ``route`` was not planned on ``occupancy``: a pixel of its path whose world
    point lies on another pixel there (the page draws the world points); None when every
    one fits."""
    px = np.asarray(route.pixels, np.float64).reshape(-1, 2)
    xy = np.asarray(route.world, np.float64).reshape(-1, 2)
    if not len(px) or len(px) != len(xy):
        return None
    with np.errstate(over="ignore", invalid="ignore"):
        at = np.stack(occupancy.world_to_pixel(xy[:, 0], xy[:, 1]), axis=1)
        off = ~np.isclose(at, px, rtol=0.0, atol=0.01).all(axis=1)
    if not off.any():
        return None
    i = int(np.argmax(off))
    return (
        f"its pixel {px[i].astype(np.int64).tolist()} of its map lies at pixel "
        f"{rounded(at[i], 1)} of the map shown"
    )


def _timeline_beyond(timeline, occupancy) -> str | None:
    """Why ``timeline`` does not belong under ``occupancy``: its last map picture reaches
    beyond the map (by more than a pixel), as another run's or another map's would; None
    when it lies inside (the mapper's own map, or a larger one holding it)."""
    box = timeline._last_map_box()
    if box is None:
        return None
    h, w = occupancy.shape
    xs, ys = occupancy.pixel_to_world(
        [-0.5, -0.5, h - 0.5, h - 0.5], [-0.5, w - 0.5, -0.5, w - 0.5]
    )
    x0, x1, y0, y1 = (float(f(v)) for v in (xs, ys) for f in (np.min, np.max))
    tol = occupancy.resolution_m
    if box[0] >= x0 - tol and box[1] >= y0 - tol and box[2] <= x1 + tol and box[3] <= y1 + tol:
        return None
    return (
        f"its last map spans x {box[0]:.2f} to {box[2]:.2f} m, y {box[1]:.2f} to {box[3]:.2f} "
        f"m, beyond the map shown (x {x0:.2f} to {x1:.2f} m, y {y0:.2f} to {y1:.2f} m)"
    )


def _fields_on_the_map(out: Inputs, own) -> None:
    """Leave out a result's per-pixel fields (on ``own``, its map's grid) when the map
    shown is on another grid, with a note: drawn there they would stand in the wrong
    place, or not fit it."""
    if not out.rasters or own is None or own is out.map:
        return
    why = grid_mismatch(own.shape, own.resolution_m, own.origin, out.map, owner="their")
    if why is not None:
        out.rasters = {}
        out.notes.append(
            "the distance map, ridges and skeleton were left out: they were not computed "
            f"on the map shown: {why}"
        )


def _title_of(occupancy, what: str) -> str:
    source = getattr(occupancy, "source", None)
    if source:
        from pathlib import Path

        return f"{Path(str(source)).name}: {what}"
    return what


def _graph_label(graph: nx.Graph) -> str:
    return "route graph" if graph.graph.get("kind") == "route_graph" else "graph"


def _extra_graphs(graphs, taken: list[str]):
    """The (name, graph) pairs of ``graphs``, checked; ``taken`` lists the layer names
    already shown, which a name may not repeat (the layer list would not tell them apart)."""
    if graphs is None:
        return []
    instance_of("graphs", graphs, dict, "dict of name -> networkx graph")
    for name, graph in graphs.items():
        if not isinstance(name, str):
            raise TypeError(
                f"graphs: expected a dict of name (str) -> networkx graph, received a key "
                f"{name!r} ({type(name).__name__})"
            )
        if not name.strip() or name in taken:
            raise ValueError(
                f"graphs: expected a name for each layer, none blank or already a layer's "
                f"(here {', '.join(repr(t) for t in taken) or 'none'}), received {name!r}"
            )
        nx_graph(f"graphs[{name!r}]", graph)
    return list(graphs.items())


def _checked_route(route):
    if route is None:
        return None
    from ..routing import Route

    return instance_of("route", route, Route, "topojax.Route")


def _checked_timeline(timeline):
    if timeline is None:
        return None
    from .timeline import Timeline

    instance_of("timeline", timeline, Timeline, "topojax.Timeline")
    if timeline.n_frames == 0:
        raise ValueError(
            "timeline: it holds no graph update (record() keeps one at each report whose "
            "graph_update is set)"
        )
    return timeline


# ---------------------------------------------------------------------------- payload
def _map_frame(occupancy) -> Frame:
    h, w = occupancy.shape
    return Frame(int(h), int(w), float(occupancy.resolution_m), tuple(map(float, occupancy.origin)))


def _check_size(frame: Frame, max_pixels: int, *, has_map: bool = True) -> None:
    n = frame.height * frame.width
    if n > max_pixels:
        how = (
            ""
            if has_map
            else (
                " with the graph's map (map=: an OccupancyMap, or tj.open_tiled_map(...) of a "
                "map on disk, read a window at a time)"
            )
        )
        h, w = frame.height, frame.width
        x, y = frame.pixel_to_world([-0.5, -0.5, h - 0.5, h - 0.5], [-0.5, w - 0.5, -0.5, w - 0.5])
        raise ValueError(
            f"map: {h} x {w} pixels ({n / 1e6:.1f} Mpx) is more than max_pixels={max_pixels} "
            f"({max_pixels / 1e6:g} Mpx), the most a view ships to a browser; view a window "
            f"of it{how} (window=(x_min, y_min, x_max, y_max) in metres; the map spans x "
            f"{np.min(x):.2f} to {np.max(x):.2f} m, y {np.min(y):.2f} to {np.max(y):.2f} m) "
            "or pass a larger max_pixels"
        )


def _rasters(inputs: Inputs) -> list[dict]:
    out = []
    img = inputs.map.to_image()
    if not inputs.map.occupied.any() and not inputs.map.free.any():
        inputs.notes.append("the map is all unknown: no free or occupied pixel")
    out.append(
        {"name": "map", "label": "map", "kind": "grey", "on": True, **pyramid(img, reduce="map")}
    )
    shape = img.shape
    specs = (
        ("distance", "distance map", "scale", "mean", DISTANCE_MAX_SIDE_PX, None, False),
        ("ridges", "ridges", "mask", "max", None, 0, False),
        ("skeleton", "skeleton", "mask", "max", None, 0, False),
    )
    for name, label, kind, reduce, side, blank, on in specs:
        layer = inputs.rasters.get(name)
        if layer is None:
            continue
        layer = np.asarray(layer)
        if layer.shape != shape:
            raise ValueError(f"{name}: shape {layer.shape} is not the map's {shape}")
        if layer.dtype == bool:
            img8 = layer.view(np.uint8) * np.uint8(255)
        else:  # a field in [0, 1]: rounded and saturated to 0..255 (NaN: 0)
            img8 = cv2.convertScaleAbs(np.asarray(layer, np.float32), alpha=255.0)
        out.append(
            {
                "name": name,
                "label": label,
                "kind": kind,
                "on": on,
                **pyramid(img8, reduce=reduce, max_side_px=side, blank=blank),
            }
        )
    return out


def _route_payload(route) -> dict:
    return {
        "length_m": float(route.length_m),
        "xy": rounded(route.world.ravel(), 6),
        "start_snap_m": float(route.start_snap_m),
        "goal_snap_m": float(route.goal_snap_m),
    }


def _graph_bounds_frame(graphs) -> Frame:
    """A frame around the graphs' vertices when there is no map (for the page's
    coordinates only: nothing is drawn on it)."""
    xy = []
    for _, _, g in graphs:
        for d in [d for *_, d in g.edges(data="world")] + [d for _, d in g.nodes(data="world")]:
            try:
                xy.append(world_points(d, "world", one=False))
            except ValueError:  # the graph's own checks name it
                continue
    pts = np.concatenate(xy) if xy else np.zeros((0, 2))
    pts = pts[np.isfinite(pts).all(axis=1)]
    if not len(pts):
        return Frame(100, 100, 0.05, (0.0, 0.0, 0.0))
    known = [r for _, _, g in graphs if (r := graph_resolution_m(g)) is not None]
    res = known[0] if known else 0.05
    lo, hi = pts.min(axis=0) - 10 * res, pts.max(axis=0) + 10 * res
    w, h = (max(1, math.ceil((hi[i] - lo[i]) / res)) for i in (0, 1))
    return Frame(int(h), int(w), res, (float(lo[0]), float(lo[1]), 0.0))


def _entry_payload(graph: nx.Graph, shown: dict, inputs: Inputs) -> dict | None:
    """For a route graph (one with a ``robot_radius_m``) shown whole with its own map: the
    robot's feasible pixels and the map's occupied ones (bits, row-major, big-endian
    within each byte) and the reach
    (the graph's ``snap_m``), so that the page joins routes to it in sight as
    ``RoutePlanner(graph, occupancy=map)`` does.  None otherwise, with a note saying why
    where a route graph has a map but cannot get them."""
    radius = graph.graph.get("robot_radius_m")
    occupancy = inputs.map
    if occupancy is None or radius is None or not shown["routable"]:
        return None
    reach = graph.graph.get("snap_m")
    reach = DEFAULT_ENTRY_M if reach is None else reach  # as RoutePlanner reads it
    why = None
    if inputs.window is not None:
        why = "a window shows part of the map only"
    elif "rc" not in shown["edges"]:
        why = "its paths are not on the map's grid"
    else:
        try:
            nonnegative_metres("robot_radius_m", radius)
            nonnegative_metres("snap_m", reach)
            why = map_mismatch(graph, occupancy)
        except (TypeError, ValueError) as exc:
            why = f"its {exc}"
    if why is not None:
        inputs.notes.append(f"routes on the {shown['label']} join it at the nearest point: {why}")
        return None
    from ..routegraph.feasible import feasible_space

    feasible = feasible_space(occupancy, float(radius)).feasible
    return {
        "reach_m": float(reach),
        "feasible": packed(np.packbits(feasible.ravel()), np.uint8),
        # a route from an occupied pixel is refused, as the planner given the map does
        "occupied": packed(np.packbits(np.asarray(occupancy.occupied, bool).ravel()), np.uint8),
    }


def build_payload(inputs: Inputs, *, max_pixels: int = DEFAULT_MAX_PIXELS) -> dict:
    """The page's data for ``inputs`` (see :func:`topojax.write_view`).

    Raises
    ------
    ValueError
        The map is larger than ``max_pixels``, or a graph, layer or room is malformed
        (the message names it).
    """
    frame = _map_frame(inputs.map) if inputs.map is not None else None
    if frame is None:
        for _, _, g in inputs.graphs:
            frame = graph_frame(g)
            if frame is not None:
                break
    if frame is not None:
        _check_size(frame, max_pixels, has_map=inputs.map is not None)
    if isinstance(inputs.map, TiledMap):  # read now that it is known to fit
        inputs.map = inputs.map.occupancy()
    rasters = _rasters(inputs) if inputs.map is not None else []
    if inputs.map is None:
        inputs.notes.append("no map: the graphs are drawn on an empty background")
    if frame is None:
        frame = _graph_bounds_frame(inputs.graphs)
    graphs = [
        graph_payload(g, frame, name=n, label=lab, raster=bool(rasters))
        for n, lab, g in inputs.graphs
    ]
    for (_, _, g), shown in zip(inputs.graphs, graphs, strict=True):
        shown["entry"] = _entry_payload(g, shown, inputs)
    if not rasters and not any(g["n_vertices"] for g in graphs) and inputs.rooms is None:
        raise ValueError(
            "nothing to show: no map, and the graphs have no vertices (an empty graph "
            "without its map)"
        )
    for (_, _, graph), g in zip(inputs.graphs, graphs, strict=True):
        if g["n_vertices"] == 0:
            note = graph.graph.get("note")  # a route graph's reason (topojax.route_graph)
            why = f"; its note: {note}" if isinstance(note, str) and note else ""
            inputs.notes.append(f"the {g['label']} is empty: no vertex, no edge{why}")
    rooms = rooms_payload(inputs.rooms) if inputs.rooms is not None else None
    if rooms is not None and not rooms["rooms"]:
        inputs.notes.append("the rooms are empty: no room, no door")
    payload = {
        "version": FORMAT_VERSION,
        "title": inputs.title,
        "frame": frame.to_json(),
        "rasters": rasters,
        "graphs": graphs,
        "rooms": rooms,
        "route": _route_payload(inputs.route) if inputs.route is not None else None,
        "timeline": _timeline_payload(inputs),
        "max_snap_m": DEFAULT_MAX_SNAP_M,
        "notes": list(inputs.notes),
    }
    return payload


def _timeline_payload(inputs: Inputs) -> dict | None:
    """The timeline's page data; without its rooms for ``rooms=False``."""
    if inputs.timeline is None:
        return None
    data = inputs.timeline.payload()
    if inputs.no_rooms:
        data = {**data, "rooms": [], "frames": [{**f, "rooms": -1} for f in data["frames"]]}
    return data
