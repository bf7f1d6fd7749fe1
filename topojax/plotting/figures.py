"""Matplotlib pictures of maps, fields, graphs, routes, route graphs and rooms."""

from __future__ import annotations

import sys

import numpy as np

from .._constants import EDGE_COLOUR
from .._validate import (
    finite_pair,
    flag,
    instance_of,
    nonnegative_quantity,
    nx_graph,
    pixel_rows,
    text_or_none,
    xy_points,
)
from .._words import counted
from .style import (
    MARGIN_COLOUR,
    add_legend,
    add_scale_bar,
    axes_or_new,
    draw_graph_lines,
    hex_rgb,
    imshow_pooled,
    map_image,
    map_name,
    max_pool,
    pool_factor,
    room_layer,
    show_mask,
    shown_factor,
    titled,
)


def _as_result(result, needs: tuple[str, ...]):
    """``result`` itself when it has the attributes ``needs`` (a
    :class:`~topojax.TopologyResult` or alike), or an
    :class:`~topojax.IncrementalMapper`'s current state (graph brought up to date)."""
    # an IncrementalMapper exists only once its (large) module is loaded: do not load it
    incremental = sys.modules.get("topojax.incremental")
    if incremental is not None and isinstance(result, incremental.IncrementalMapper):
        if result.pixel_bbox is None:
            raise ValueError("result: the mapper has no map yet (add scans or points first)")
        return result.to_result()
    missing = [name for name in needs if not hasattr(result, name)]
    if missing:
        raise TypeError(
            "result: expected a TopologyResult (from build_graph) or an IncrementalMapper, "
            f"received {type(result).__name__} (no {', '.join(missing)})"
        )
    return result


def plot_map(
    occupancy, *, ax=None, title: str | None = None, scale_bar: bool = True, pool: bool = False
):
    """Occupancy map: occupied black, free white, unknown grey, with a scale bar in metres
    under it (:func:`add_scale_bar`).  With ``pool``, shrunk to the axes' screen pixels by
    keeping each block's darkest class (:func:`map_image`), so thin walls stay unbroken;
    without, shrunk the same way only as far as :data:`MAX_SHOWN_PX` asks.
    Returns the axes."""
    title = text_or_none("title", title)
    ax = axes_or_new(ax)
    k = shown_factor(occupancy.shape)
    if pool:
        k = max(k, pool_factor(occupancy.shape, ax))
    imshow_pooled(ax, map_image(occupancy, k), occupancy.shape, k, cmap="gray", vmin=0, vmax=1)
    ax.set_axis_off()
    if scale_bar:
        add_scale_bar(ax, occupancy.resolution_m)
    if title:
        ax.set_title(title)
    return ax


def plot_distance(distance: np.ndarray, *, ax=None, title: str | None = "distance map H"):
    """Distance map ``H`` (float (H, W) in [0, 1]) as a colour image; above
    :data:`MAX_SHOWN_PX` pixels, every k-th row and column of it.  Returns the axes."""
    title = text_or_none("title", title)
    ax = axes_or_new(ax)
    distance = np.asarray(distance)
    k = shown_factor(distance.shape)
    shown = distance[::k, ::k]
    im = imshow_pooled(ax, shown, distance.shape, k, cmap="viridis", vmin=0, vmax=1)
    ax.figure.colorbar(im, ax=ax, fraction=0.046, pad=0.02)
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def plot_ridges(ridges: np.ndarray, *, ax=None, title: str | None = "ridges"):
    """Binary ridge map (bool (H, W)), black on white; max-pooled when the axes show it
    smaller than its pixels (:func:`max_pool`), so one-pixel lines stay unbroken.
    Returns the axes."""
    title = text_or_none("title", title)
    ax = axes_or_new(ax)
    ridges = np.asarray(ridges, bool)
    h, w = ridges.shape
    white = np.ones((1, 1), np.float32)
    ax.imshow(white, cmap="gray", vmin=0, vmax=1, extent=(-0.5, w - 0.5, h - 0.5, -0.5))
    show_mask(ax, ridges, "#000000")
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def plot_skeleton(skeleton: np.ndarray, *, ax=None, color="#2ca02c", title: str | None = None):
    """Skeleton pixels as an overlay (transparent elsewhere), max-pooled when the axes
    show it smaller than its pixels (:func:`max_pool`).  Returns the axes."""
    title = text_or_none("title", title)
    ax = axes_or_new(ax)
    show_mask(ax, np.asarray(skeleton, bool), color)
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def _vertices_edges(graph) -> str:
    """``"268 vertices, 235 edges"`` for a graph (``"1 vertex"``, ``"1 edge"`` for one)."""
    n = graph.number_of_nodes()
    return f"{n} {'vertex' if n == 1 else 'vertices'}, {counted(graph.number_of_edges(), 'edge')}"


def _graph_pixels(graph) -> tuple[list, dict[str, list]]:
    """Each edge's ``path`` as float ``(col, row)`` points, and vertex kind -> list of the
    vertices' ``(col, row)`` pixels; a ValueError or TypeError naming an edge without an
    integer pixel ``path`` or a vertex without a ``pixel``."""
    segments = []
    for u, v, d in graph.edges(data=True):
        if d.get("path") is None:
            raise ValueError(f"graph: edge {u!r}-{v!r} has no pixel 'path' to draw")
        path = pixel_rows(f"graph: edge {u!r}-{v!r}: 'path'", d["path"])
        segments.append(path[:, ::-1].astype(float))
    points: dict[str, list] = {}
    for n, d in graph.nodes(data=True):
        if d.get("pixel") is None:
            raise ValueError(f"graph: vertex {n!r} has no 'pixel' (row, col) to draw")
        pixel = pixel_rows(f"graph: vertex {n!r}: 'pixel'", d["pixel"], one=True)
        points.setdefault(d.get("kind"), []).append(tuple(pixel[::-1].tolist()))
    return segments, points


def _graph_style(edge_color, linewidth, node_size) -> dict:
    """The checked drawing options of :func:`plot_graph` and :func:`plot_route_graph`:
    a matplotlib colour and two finite sizes ``>= 0`` (points, points^2)."""
    from matplotlib.colors import is_color_like

    if not is_color_like(edge_color):
        raise ValueError(f"edge_color: expected a matplotlib colour, received {edge_color!r}")
    return {
        "edge_color": edge_color,
        "linewidth": nonnegative_quantity("linewidth", linewidth, "points"),
        "node_size": nonnegative_quantity("node_size", node_size, "points^2"),
    }


def plot_graph(
    graph,
    *,
    ax=None,
    edge_color=EDGE_COLOUR,
    linewidth: float = 1.5,
    node_size: float = 12.0,
    title: str | None = None,
):
    """Topology graph in pixel coordinates: edges along their pixel paths, vertices by kind.

    Parameters
    ----------
    graph : networkx.MultiGraph
        As returned by :func:`topojax.build_graph` (edges need ``path``, vertices ``pixel``).
    ax : matplotlib Axes, optional
        Where to draw; default a new figure.
    edge_color : matplotlib colour
        Colour of the edges.
    linewidth : float
        Edge line width, points.
    node_size : float
        Vertex marker size, points^2 (junction red, end blue, ring purple, isolated grey,
        any other kind brown).
    title : str, optional

    Returns
    -------
    matplotlib Axes
        With the legend of edges and vertex kinds under the graph (:func:`add_legend`).
    """
    title = text_or_none("title", title)
    style = _graph_style(edge_color, linewidth, node_size)
    segments, points = _graph_pixels(graph)
    ax = axes_or_new(ax)
    draw_graph_lines(ax, segments, points, **style)
    if graph.number_of_nodes():
        add_legend(ax)
    shape = graph.graph.get("shape")
    if shape is not None:
        ax.set_xlim(-0.5, shape[1] - 0.5)
        ax.set_ylim(shape[0] - 0.5, -0.5)
    else:  # no map size: fit the data, still with row 0 at the top (image order)
        ax.autoscale_view()
        if not ax.yaxis_inverted():
            ax.invert_yaxis()
    ax.set_aspect("equal")
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def plot_route(route, *, ax=None, color="#d62728", linewidth: float = 3.0, title=None):
    """A route (:class:`topojax.Route`) in pixel coordinates: its pixels as a line, the
    snapped start as a circle and the snapped goal as a star.

    Returns
    -------
    matplotlib Axes
    """
    title = text_or_none("title", title)
    ax = axes_or_new(ax)
    px = np.asarray(route.pixels, float)
    ax.plot(px[:, 1], px[:, 0], color=color, linewidth=linewidth, zorder=4, label="route")
    ax.scatter(px[:1, 1], px[:1, 0], s=60, c=color, marker="o", zorder=5, label="start")
    ax.scatter(px[-1:, 1], px[-1:, 0], s=120, c=color, marker="*", zorder=5, label="goal")
    ax.set_aspect("equal")
    if title:
        ax.set_title(title)
    return ax


def route_graph_lines(graph, occupancy) -> list[np.ndarray]:
    """Each edge of ``graph`` as a (K, 2) float array of ``(col, row)`` pixel coordinates of
    ``occupancy``: its ``waypoints`` (world, metres) where it has them, else its ``path``
    (pixels), else its ``world`` polyline, else the segment between its vertices."""
    from ..routegraph import vertex_pixels

    lines = []
    for u, v, d in graph.edges(data=True):
        if d.get("waypoints") is None and d.get("world") is None and d.get("path") is not None:
            lines.append(np.asarray(d["path"], float).reshape(-1, 2)[:, ::-1])
            continue
        pts = d.get("waypoints") if d.get("waypoints") is not None else d.get("world")
        if pts is None:
            rows_cols = vertex_pixels(graph, [u, v], occupancy, "auto")
            lines.append(rows_cols[:, ::-1])
            continue
        key = "waypoints" if d.get("waypoints") is not None else "world"
        xy = xy_points(pts, f"graph: edge {u!r}-{v!r}: {key!r}")
        rows, cols = occupancy.world_to_pixel(xy[:, 0], xy[:, 1])
        lines.append(np.stack([cols, rows], axis=1))
    return lines


def plot_route_graph(
    graph,
    occupancy,
    *,
    ax=None,
    robot_radius_m: float | None = None,
    edge_color=EDGE_COLOUR,
    linewidth: float = 1.5,
    node_size: float = 12.0,
    title: str | None = None,
):
    """A route graph over its map: the feasible space white, free pixels closer than the
    robot's radius to an obstacle tan, unknown grey, occupied black; edges along their
    simplified ``waypoints`` (the line a robot follows), vertices by kind.

    Parameters
    ----------
    graph : networkx.MultiGraph
        From :func:`topojax.route_graph`, or any graph :func:`topojax.evaluate_route_graph`
        scores: vertex ``pixel`` or ``world``; edge ``waypoints`` or ``world`` in metres,
        ``path`` in pixels, or none (a straight segment).
    occupancy : OccupancyMap, str or Path
        The map the graph was built on (or its file): the one whose shape, resolution and
        origin the graph records.
    ax : matplotlib Axes, optional
        Where to draw; default a new 9 x 9 inch figure.
    robot_radius_m : float, optional
        Radius that sets the feasible space; default the graph's ``robot_radius_m``.
    edge_color, linewidth, node_size
        As :func:`plot_graph`.
    title : str, optional
        Default: the map's name, the radius and the vertex and edge counts.

    Returns
    -------
    matplotlib Axes
    """
    from ..maps import map_argument
    from ..maps.occupancy import map_mismatch
    from ..routegraph import vertex_pixels
    from ..routegraph.feasible import feasible_space

    title = text_or_none("title", title)
    nx_graph("graph", graph, undirected=False)
    style = _graph_style(edge_color, linewidth, node_size)
    occupancy = map_argument("occupancy", occupancy, files=True)
    why = map_mismatch(graph, occupancy)
    if why is not None:
        raise ValueError(f"occupancy: {why}")
    if robot_radius_m is None:
        robot_radius_m = graph.graph.get("robot_radius_m")
        if robot_radius_m is None:
            raise ValueError(
                "robot_radius_m: expected a radius in metres (the graph has no "
                "'robot_radius_m' attribute), received None"
            )
    space = feasible_space(occupancy, robot_radius_m)
    ax = axes_or_new(ax, figsize=(9, 9))
    plot_map(occupancy, ax=ax)
    margin = space.free & ~space.feasible
    # not pooled to the axes, so a feasible band stays visible; past MAX_SHOWN_PX a
    # block shows the margin only where all of it is margin, for the same reason
    k = shown_factor(margin.shape)
    shown = margin if k == 1 else ~max_pool(~margin, k)
    rgba = np.zeros(shown.shape + (4,), np.uint8)
    rgba[shown] = (*(round(255 * c) for c in hex_rgb(MARGIN_COLOUR)), 255)
    imshow_pooled(ax, rgba, margin.shape, k)
    nodes = list(graph.nodes)
    points: dict[str, list] = {}
    for node, rc in zip(nodes, vertex_pixels(graph, nodes, occupancy, "auto"), strict=True):
        points.setdefault(graph.nodes[node].get("kind"), []).append((rc[1], rc[0]))
    draw_graph_lines(ax, route_graph_lines(graph, occupancy), points, **style)
    if graph.number_of_nodes():
        add_legend(ax)
    ax.set_aspect("equal")
    if title is None:
        title = titled(
            map_name(occupancy.source),
            f"r = {float(robot_radius_m):g} m: {_vertices_edges(graph)}",
        )
    ax.set_title(title)
    return ax


def _room_segmentation(seg, name: str):
    from ..rooms import RoomSegmentation

    return instance_of(name, seg, RoomSegmentation)


def _draw_rooms(seg, ax, *, doors: bool, labels: bool, alpha: float) -> None:
    """Rooms as a translucent colour layer (:func:`topojax.io.rooms.room_colours`, as the
    label picture), doorways as white lines between their ends, room ids at their
    :attr:`~topojax.Room.label_point`."""
    from matplotlib.collections import LineCollection

    lab = np.asarray(seg.labels)
    ax.imshow(room_layer(lab, alpha), interpolation="nearest")
    if doors and seg.doors:
        from matplotlib import patheffects

        segments = [np.asarray(d.ends_px, float)[:, ::-1] for d in seg.doors]
        lines = LineCollection(segments, colors="white", linewidths=2.0, zorder=3, label="doors")
        lines.set_path_effects([patheffects.withStroke(linewidth=3.5, foreground="#111111")])
        ax.add_collection(lines)
    if labels:
        for room in seg.rooms:
            r, c = seg.occupancy.world_to_pixel(*room.label_point)
            ax.text(
                float(c),
                float(r),
                str(room.id),
                ha="center",
                va="center",
                fontsize="small",
                fontweight="bold",
                zorder=4,
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8},
            )
    h, w = lab.shape
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_aspect("equal")


def plot_rooms(seg, *, ax=None, title: str | None = None, doors: bool = True, labels: bool = True):
    """Rooms of a :class:`~topojax.RoomSegmentation` over its map, in pixel coordinates.

    Parameters
    ----------
    seg : RoomSegmentation
        From :func:`topojax.segment_rooms`.
    ax : matplotlib Axes, optional
        Where to draw; default a new 9 x 9 inch figure.
    title : str, optional
        Default: the map's name and the room and door counts.
    doors : bool
        Draw each doorway as a line between its two obstacle ends.
    labels : bool
        Write each room's id at its :attr:`~topojax.Room.label_point` (inside the room).

    Returns
    -------
    matplotlib Axes
        Each room in its colour of the label picture (:func:`topojax.save_room_labels`).
    """
    title = text_or_none("title", title)
    seg = _room_segmentation(seg, "seg")
    doors, labels = flag("doors", doors), flag("labels", labels)
    ax = axes_or_new(ax, figsize=(9, 9))
    plot_map(seg.occupancy, ax=ax)
    _draw_rooms(seg, ax, doors=doors, labels=labels, alpha=0.6)
    if doors and seg.doors:
        add_legend(ax)
    if title is None:
        title = titled(
            map_name(getattr(seg.occupancy, "source", None)),
            f"{counted(seg.n_rooms, 'room')}, {counted(len(seg.doors), 'door')}",
        )
    ax.set_title(title)
    return ax


def plot(
    result,
    *,
    ax=None,
    skeleton: bool = True,
    graph: bool = True,
    route=None,
    rooms=None,
    title: str | None = None,
):
    """Overlay of map, skeleton and graph for a :class:`~topojax.TopologyResult` (or an
    :class:`~topojax.IncrementalMapper`'s current state), and a :class:`~topojax.Route` on
    top if given.

    Parameters
    ----------
    result : TopologyResult or IncrementalMapper
    ax : matplotlib Axes, optional
        Where to draw; default a new 9 x 9 inch figure.
    skeleton, graph : bool
        Draw the skeleton pixels (green) and the graph (edges orange, vertices by kind).
    route : Route, optional
        Drawn on top (:func:`plot_route`).
    rooms : RoomSegmentation, optional
        Rooms of the same map, drawn under the skeleton and graph as :func:`plot_rooms`
        draws them.
    title : str, optional
        Default: the map's name (:func:`map_name` of its ``source``) and the vertex and
        edge counts (and the room count).

    Returns
    -------
    matplotlib Axes
        ``ax.figure.savefig(path)`` writes a picture.
    """
    title = text_or_none("title", title)
    result = _as_result(result, ("map", "skeleton", "graph"))
    skeleton, graph = flag("skeleton", skeleton), flag("graph", graph)
    if graph:
        _graph_pixels(result.graph)  # checked before anything is drawn
    if route is not None:
        from ..routing import Route

        instance_of("route", route, Route)
    if rooms is not None:
        from ..maps.occupancy import grid_mismatch

        rooms = _room_segmentation(rooms, "rooms")
        why = grid_mismatch(
            rooms.labels.shape,
            rooms.resolution_m,
            rooms.origin,
            result.map,
            owner="the rooms'",
            owner_blamed=True,
        )
        if why is not None:  # rooms of another map would be drawn at the wrong places
            raise ValueError(f"rooms: not of the result's map: {why}")
    ax = axes_or_new(ax, figsize=(9, 9))
    plot_map(result.map, ax=ax)
    if rooms is not None:
        _draw_rooms(rooms, ax, doors=True, labels=True, alpha=0.45)
    if skeleton:
        plot_skeleton(result.skeleton, ax=ax, color="#2ca02c")
    if graph:
        plot_graph(result.graph, ax=ax)
    if route is not None:
        plot_route(route, ax=ax)
        add_legend(ax)
    if title is None:
        g = result.graph
        title = _vertices_edges(g)
        if rooms is not None:
            title += f", {counted(rooms.n_rooms, 'room')}"
        title = titled(map_name(result.map.source), title)
    ax.set_title(title)
    return ax


def plot_stages(result, *, figsize=(15, 9), title: str | None = None):
    """The paper's Fig. 1: map, distance map, Laplacian, ridges, skeleton, graph, for a
    :class:`~topojax.TopologyResult` or an :class:`~topojax.IncrementalMapper`, under the
    map's name; the ridge and skeleton panels are max-pooled to the panel size (one-pixel
    lines stay unbroken), the map and graph panels carry scale bars.

    Parameters
    ----------
    result : TopologyResult or IncrementalMapper
    figsize : (float, float)
        Figure size in inches.
    title : str, optional
        The figure's title; default the map's name (:func:`map_name`), if known.

    Returns
    -------
    matplotlib Figure
    """
    title = text_or_none("title", title)
    import matplotlib.pyplot as plt

    result = _as_result(result, ("map", "distance", "lap_abs", "ridges", "skeleton", "graph"))
    figsize = finite_pair("figsize", figsize, "(width, height) in inches")
    if not (figsize > 0).all():
        raise ValueError(
            f"figsize: expected (width, height) in inches > 0, received {tuple(figsize)}"
        )
    _graph_pixels(result.graph)  # checked before anything is drawn

    fig, axes = plt.subplots(2, 3, figsize=tuple(figsize))
    title = title if title is not None else map_name(result.map.source)
    if title:
        fig.suptitle(title)
    plot_map(result.map, ax=axes[0, 0], title="occupancy map", pool=True)
    plot_distance(result.distance, ax=axes[0, 1])
    k = pool_factor(result.lap_abs.shape, axes[0, 2])
    imshow_pooled(axes[0, 2], max_pool(result.lap_abs, k), result.lap_abs.shape, k, cmap="magma")
    axes[0, 2].set_title("|Laplacian| (x255)")
    axes[0, 2].set_axis_off()
    plot_ridges(result.ridges, ax=axes[1, 0], title="ridges (> threshold)")
    plot_ridges(result.skeleton, ax=axes[1, 1], title="skeleton")
    g = result.graph
    plot(
        result,
        ax=axes[1, 2],
        title=f"graph ({_vertices_edges(g)})",
    )
    fig.tight_layout()
    return fig
