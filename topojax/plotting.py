"""Matplotlib helpers: the map, distance map, ridges, skeleton, graph, route and room
overlays.

All images are drawn in pixel coordinates (``imshow`` with row 0 at the top), so the
graph's pixel paths overlay exactly.  Keyword arguments shared by the helpers: ``ax`` (a
matplotlib Axes to draw into; default: a new figure), ``title`` (a string, or None for
none / the helper's own), ``color`` / ``edge_color`` (any matplotlib colour) and
``linewidth`` (points).  Each returns the Axes it drew into (:func:`plot_stages`: the
figure).
"""

from __future__ import annotations

import sys

import numpy as np

__all__ = [
    "plot",
    "plot_map",
    "plot_distance",
    "plot_ridges",
    "plot_skeleton",
    "plot_graph",
    "plot_route",
    "plot_rooms",
    "plot_stages",
]

_KIND_COLOURS = {
    "junction": "#d62728",
    "end": "#1f77b4",
    "ring": "#9467bd",
    "isolated": "#7f7f7f",
}


def _axes(ax, figsize=(8, 8)):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize)
    return ax


def _as_result(result, needs: tuple[str, ...]):
    """``result`` itself when it has the attributes ``needs`` (a
    :class:`~topojax.TopologyResult` or alike), or an
    :class:`~topojax.IncrementalMapper`'s current state (graph brought up to date)."""
    # an IncrementalMapper exists only once its (large) module is loaded: do not load it
    incremental = sys.modules.get(f"{__package__}.incremental")
    if incremental is not None and isinstance(result, incremental.IncrementalMapper):
        return result.to_result()
    missing = [name for name in needs if not hasattr(result, name)]
    if missing:
        raise TypeError(
            "result: expected a TopologyResult (from build_graph) or an IncrementalMapper, "
            f"received {type(result).__name__} (no {', '.join(missing)})"
        )
    return result


def _map_image(occupancy) -> np.ndarray:
    img = np.full(occupancy.shape, 0.8, np.float32)  # unknown: light grey
    img[occupancy.free] = 1.0
    img[occupancy.occupied] = 0.0
    return img


def plot_map(occupancy, *, ax=None, title: str | None = None):
    """Occupancy map: occupied black, free white, unknown grey.  Returns the axes."""
    ax = _axes(ax)
    ax.imshow(_map_image(occupancy), cmap="gray", vmin=0, vmax=1, interpolation="nearest")
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def plot_distance(distance: np.ndarray, *, ax=None, title: str | None = "distance map H"):
    """Distance map ``H`` (float (H, W) in [0, 1]) as a colour image.  Returns the axes."""
    ax = _axes(ax)
    im = ax.imshow(distance, cmap="viridis", vmin=0, vmax=1, interpolation="nearest")
    ax.figure.colorbar(im, ax=ax, fraction=0.046, pad=0.02)
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def plot_ridges(ridges: np.ndarray, *, ax=None, title: str | None = "ridges"):
    """Binary ridge map (bool (H, W)).  Returns the axes."""
    ax = _axes(ax)
    ax.imshow(ridges, cmap="gray_r", interpolation="nearest")
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def plot_skeleton(skeleton: np.ndarray, *, ax=None, color="#2ca02c", title: str | None = None):
    """Skeleton pixels as an overlay (transparent elsewhere).  Returns the axes."""
    ax = _axes(ax)
    rgba = np.zeros(skeleton.shape + (4,), np.float32)
    rgba[skeleton] = (*_hex_rgb(color), 1.0)
    ax.imshow(rgba, interpolation="nearest")
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def plot_graph(
    graph,
    *,
    ax=None,
    edge_color="#ff7f0e",
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
        Vertex marker size, points^2 (junction red, end blue, ring purple, isolated grey).
    title : str, optional

    Returns
    -------
    matplotlib Axes
    """
    from matplotlib.collections import LineCollection

    ax = _axes(ax)
    segments = [np.asarray(data["path"], float)[:, ::-1] for _, _, data in graph.edges(data=True)]
    if segments:
        ax.add_collection(LineCollection(segments, colors=edge_color, linewidths=linewidth))
    for kind, colour in _KIND_COLOURS.items():
        pts = np.asarray(
            [d["pixel"] for _, d in graph.nodes(data=True) if d.get("kind") == kind], float
        )
        if len(pts):
            ax.scatter(pts[:, 1], pts[:, 0], s=node_size, c=colour, label=kind, zorder=3)
    if graph.number_of_nodes():
        ax.legend(loc="lower right", fontsize="small", markerscale=1.5)
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
    ax = _axes(ax)
    px = np.asarray(route.pixels, float)
    ax.plot(px[:, 1], px[:, 0], color=color, linewidth=linewidth, zorder=4, label="route")
    ax.scatter(px[:1, 1], px[:1, 0], s=60, c=color, marker="o", zorder=5, label="start")
    ax.scatter(px[-1:, 1], px[-1:, 0], s=120, c=color, marker="*", zorder=5, label="goal")
    ax.set_aspect("equal")
    if title:
        ax.set_title(title)
    return ax


def _room_segmentation(seg, name: str):
    from .rooms import RoomSegmentation

    if not isinstance(seg, RoomSegmentation):
        raise TypeError(f"{name}: expected a RoomSegmentation, received {type(seg).__name__}")
    return seg


def _draw_rooms(seg, ax, *, doors: bool, labels: bool, alpha: float) -> None:
    """Rooms as a translucent colour layer (:func:`topojax.io.rooms.room_colours`, as the
    label picture), doorways as white lines between their ends, room ids at their
    centroids."""
    from matplotlib.collections import LineCollection

    from .io.rooms import room_colours

    lab = np.asarray(seg.labels)
    rgba = np.zeros(lab.shape + (4,), np.float32)
    if seg.n_rooms:
        colours = room_colours(int(lab.max())).astype(np.float32) / 255.0
        inside = lab > 0
        rgba[inside, :3] = colours[lab[inside] - 1]
        rgba[inside, 3] = alpha
    ax.imshow(rgba, interpolation="nearest")
    if doors and seg.doors:
        from matplotlib import patheffects

        segments = [np.asarray(d.ends_px, float)[:, ::-1] for d in seg.doors]
        lines = LineCollection(segments, colors="white", linewidths=2.0, zorder=3, label="doors")
        lines.set_path_effects([patheffects.withStroke(linewidth=3.5, foreground="#111111")])
        ax.add_collection(lines)
    if labels:
        for room in seg.rooms:
            r, c = seg.occupancy.world_to_pixel(*room.centroid)
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
        Default: the room and door counts.
    doors : bool
        Draw each doorway as a line between its two obstacle ends.
    labels : bool
        Write each room's id at its centroid.

    Returns
    -------
    matplotlib Axes
        Each room in its colour of the label picture (:func:`topojax.save_room_labels`).
    """
    seg = _room_segmentation(seg, "seg")
    ax = _axes(ax, figsize=(9, 9))
    plot_map(seg.occupancy, ax=ax)
    _draw_rooms(seg, ax, doors=doors, labels=labels, alpha=0.6)
    if title is None:
        title = f"{seg.n_rooms} rooms, {len(seg.doors)} doors"
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
        Default: the vertex and edge counts (and the room count).

    Returns
    -------
    matplotlib Axes
        ``ax.figure.savefig(path)`` writes a picture.
    """
    result = _as_result(result, ("map", "skeleton", "graph"))
    if rooms is not None:
        rooms = _room_segmentation(rooms, "rooms")
        if rooms.labels.shape != tuple(result.map.shape):
            raise ValueError(
                f"rooms: expected the rooms of a map of shape {tuple(result.map.shape)} (the "
                f"result's), received rooms of shape {rooms.labels.shape}"
            )
    ax = _axes(ax, figsize=(9, 9))
    plot_map(result.map, ax=ax)
    if rooms is not None:
        _draw_rooms(rooms, ax, doors=True, labels=True, alpha=0.45)
    if skeleton:
        plot_skeleton(result.skeleton, ax=ax, color="#2ca02c")
    if graph:
        plot_graph(result.graph, ax=ax)
    if route is not None:
        plot_route(route, ax=ax)
    if title is None:
        g = result.graph
        title = f"{g.number_of_nodes()} vertices, {g.number_of_edges()} edges"
        if rooms is not None:
            title += f", {rooms.n_rooms} rooms"
    ax.set_title(title)
    return ax


def plot_stages(result, *, figsize=(15, 9)):
    """The paper's Fig. 1: map, distance map, Laplacian, ridges, skeleton, graph, for a
    :class:`~topojax.TopologyResult` or an :class:`~topojax.IncrementalMapper`.

    Parameters
    ----------
    result : TopologyResult or IncrementalMapper
    figsize : (float, float)
        Figure size in inches.

    Returns
    -------
    matplotlib Figure
    """
    import matplotlib.pyplot as plt

    result = _as_result(result, ("map", "distance", "lap_abs", "ridges", "skeleton", "graph"))

    fig, axes = plt.subplots(2, 3, figsize=figsize)
    plot_map(result.map, ax=axes[0, 0], title="occupancy map")
    plot_distance(result.distance, ax=axes[0, 1])
    axes[0, 2].imshow(result.lap_abs, cmap="magma", interpolation="nearest")
    axes[0, 2].set_title("|Laplacian| (x255)")
    axes[0, 2].set_axis_off()
    plot_ridges(result.ridges, ax=axes[1, 0], title="ridges (> threshold)")
    plot_ridges(result.skeleton, ax=axes[1, 1], title="skeleton")
    plot(result, ax=axes[1, 2])
    fig.tight_layout()
    return fig


def _hex_rgb(colour: str) -> tuple[float, float, float]:
    from matplotlib.colors import to_rgb

    return to_rgb(colour)
