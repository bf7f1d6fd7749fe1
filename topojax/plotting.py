"""Matplotlib helpers: the map, distance map, ridges, skeleton, graph, route and room
overlays, for papers and READMEs.

All images are drawn in pixel coordinates (``imshow`` with row 0 at the top), so the
graph's pixel paths overlay exactly.  Keyword arguments shared by the helpers: ``ax`` (a
matplotlib Axes to draw into; default: a new figure), ``title`` (a string, or None for
none / the helper's own), ``color`` / ``edge_color`` (any matplotlib colour) and
``linewidth`` (points).  Each returns the Axes it drew into (:func:`plot_stages`: the
figure).

Every picture, and the animation of ``topojax replay --animate``, shares one style: the
map's name in the title (from the map's ``source``, when known), a scale bar in metres
(:func:`add_scale_bar`) and the legend (:func:`add_legend`) below the map, where they
cover nothing, and thin pixel layers (ridges, skeleton, walls) max-pooled
(:func:`max_pool`) when the axes show fewer screen pixels than the layer has, so that a
one-pixel line stays one unbroken line.
"""

from __future__ import annotations

import io
import math
import sys
from pathlib import Path

import numpy as np

from ._constants import EDGE_COLOUR, VERTEX_KIND_COLOURS
from ._validate import instance_of, nx_graph

__all__ = [
    "plot",
    "plot_map",
    "plot_distance",
    "plot_ridges",
    "plot_skeleton",
    "plot_graph",
    "plot_route",
    "plot_route_graph",
    "plot_rooms",
    "route_graph_lines",
    "plot_stages",
    "add_legend",
    "add_scale_bar",
    "draw_graph_lines",
    "figure_png",
    "map_image",
    "map_name",
    "max_pool",
    "pool_factor",
    "result_png",
    "room_layer",
    "rooms_png",
    "route_graph_png",
    "stages_png",
]

_KIND_COLOURS = VERTEX_KIND_COLOURS
#: Grey levels of the map classes (0 black .. 1 white).
_OCCUPIED_GREY, _UNKNOWN_GREY, _FREE_GREY = 0.0, 0.8, 1.0
#: The most map pixels :func:`plot_map` hands to matplotlib, which resamples a shown
#: image through several full-size float copies: a larger map is shrunk first (each
#: block's darkest class), still finer than any figure shows it.
MAX_SHOWN_PX = 8_000_000
#: Free pixels closer to an obstacle than the robot's radius, in route-graph pictures.
_MARGIN_COLOUR = "#e6d3b8"
#: The scale bar's length is the longest 1, 2 or 5 x 10^k metres up to this share of the
#: axes' width.
_SCALE_SHARE = 0.25


# ---------------------------------------------------------------------- shared style


def map_name(source) -> str | None:
    """A map's name for titles: the file stem of ``source`` (a map's ``source`` path), its
    folder's name for a file called ``map`` (``pal_office/map.yaml``); None without one."""
    if not source:
        return None
    p = Path(str(source))
    if p.stem.lower() == "map" and p.parent.name:
        return p.parent.name
    return p.stem or None


def _titled(name: str | None, text: str) -> str:
    return f"{name}: {text}" if name else text


def max_pool(image: np.ndarray, factor: int) -> np.ndarray:
    """``image`` (bool or numbers, (H, W)) shrunk ``factor`` times by max-pooling: a pixel
    of the result is the largest of its ``factor`` x ``factor`` block (for bool: True when
    any is), the last blocks padded with the image's smallest value.  Shape
    ``(ceil(H / factor), ceil(W / factor))``; ``factor`` 1 returns ``image``.  True pixels
    connected in a bool image stay connected."""
    factor = int(factor)
    image = np.asarray(image)
    if factor <= 1 or image.size == 0:
        return image
    h, w = image.shape
    hp, wp = -(-h // factor), -(-w // factor)
    padded = np.full((hp * factor, wp * factor), image.min(), image.dtype)
    padded[:h, :w] = image
    return padded.reshape(hp, factor, wp, factor).max(axis=(1, 3))


def pool_factor(shape: tuple[int, int], ax) -> int:
    """How many layer pixels of an image of ``shape`` (H, W) share one screen pixel of
    ``ax`` at the figure's dpi (rounded up; 1 when the image is not shrunk)."""
    box = ax.get_window_extent()
    if box.width <= 0 or box.height <= 0:
        return 1
    ratio = max(shape[0] / box.height, shape[1] / box.width)
    return max(1, math.ceil(ratio - 1e-9))


def _imshow_pooled(ax, image: np.ndarray, shape: tuple[int, int], factor: int, **kwargs):
    """Show ``image``, an (H, W) layer pooled ``factor`` times, over the pixels of the
    (H, W) = ``shape`` layer in pixel coordinates; the axes keep the layer's limits."""
    h, w = shape
    hp, wp = image.shape[:2]
    extent = (-0.5, wp * factor - 0.5, hp * factor - 0.5, -0.5)
    shown = ax.imshow(image, interpolation="nearest", extent=extent, **kwargs)
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    return shown


def _show_mask(ax, mask: np.ndarray, colour, *, alpha: float = 1.0):
    """``mask`` as a colour layer (transparent elsewhere) in pixel coordinates,
    max-pooled for the axes."""
    k = pool_factor(mask.shape, ax)
    small = max_pool(mask.astype(bool), k)
    rgba = np.zeros(small.shape + (4,), np.float32)
    rgba[small] = (*_hex_rgb(colour), alpha)
    _imshow_pooled(ax, rgba, mask.shape, k)


def map_image(occupancy, factor: int = 1) -> np.ndarray:
    """Grey image of an occupancy map, float32: occupied 0 (black), unknown 0.8, free 1
    (white); with ``factor`` > 1 shrunk by taking each block's darkest class, so that thin
    walls stay visible.  Shape ``(ceil(H / factor), ceil(W / factor))``."""
    img = np.full(occupancy.shape, _UNKNOWN_GREY, np.float32)
    img[occupancy.free] = _FREE_GREY
    img[occupancy.occupied] = _OCCUPIED_GREY
    factor = int(factor)
    if factor <= 1:
        return img
    h, w = img.shape
    hp, wp = -(-h // factor), -(-w // factor)
    padded = np.full((hp * factor, wp * factor), _UNKNOWN_GREY, np.float32)
    padded[:h, :w] = img
    return padded.reshape(hp, factor, wp, factor).min(axis=(1, 3))


def _nice_length(limit: float) -> float:
    """The longest 1, 2 or 5 x 10^k not above ``limit`` (> 0)."""
    exp = math.floor(math.log10(limit))
    for mult in (5.0, 2.0, 1.0):
        if mult * 10.0**exp <= limit:
            return mult * 10.0**exp
    return 10.0 ** (exp - 1) * 5.0


def add_scale_bar(ax, metres_per_unit: float, *, length_m: float | None = None):
    """A scale bar under the lower-left corner of ``ax`` (outside the map), labelled in
    metres.

    Parameters
    ----------
    ax : matplotlib Axes
        With its final x limits.
    metres_per_unit : float
        Metres per data unit: the resolution for axes in pixels, 1 for axes in metres.
    length_m : float, optional
        Length of the bar; default the longest 1, 2 or 5 x 10^k metres up to a quarter of
        the axes' width.

    Returns
    -------
    AnchoredSizeBar or None
        The artist (in ``ax.artists``); None when the axes have no width.
    """
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    width_m = abs(x1 - x0) * float(metres_per_unit)
    if not width_m > 0 or not math.isfinite(width_m):
        return None
    if length_m is None:
        length_m = _nice_length(_SCALE_SHARE * width_m)
    bar = AnchoredSizeBar(
        ax.transData,
        length_m / metres_per_unit,
        f"{length_m:g} m",
        loc="upper left",
        bbox_to_anchor=(0.0, -0.01),
        bbox_transform=ax.transAxes,
        borderpad=0.0,
        pad=0.1,
        sep=3,
        frameon=False,
        size_vertical=0.012 * abs(y1 - y0),
        fontproperties={"size": "small"},
    )
    bar.set_gid("scale-bar")
    ax.add_artist(bar)
    return bar


def add_legend(ax, **kwargs):
    """The legend of ``ax``'s labelled artists under its lower-right corner (outside the
    map, two columns, no frame); None when nothing is labelled.  ``kwargs`` go to
    :meth:`matplotlib.axes.Axes.legend`."""
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    options = {
        "loc": "upper right",
        "bbox_to_anchor": (1.0, -0.01),
        "borderaxespad": 0.0,
        "ncol": 2,
        "frameon": False,
        "fontsize": "small",
        "markerscale": 1.5,
        "handlelength": 1.2,
        "columnspacing": 1.0,
    }
    options.update(kwargs)
    return ax.legend(handles, labels, **options)


def draw_graph_lines(
    ax,
    segments,
    points_by_kind: dict,
    *,
    edge_color=EDGE_COLOUR,
    linewidth: float = 1.5,
    node_size: float = 12.0,
) -> None:
    """Edges and vertices in any coordinates: ``segments`` a list of (K, 2) (x, y) arrays,
    ``points_by_kind`` vertex kind -> (N, 2) (x, y), drawn in the kind colours (junction
    red, end blue, ring purple, isolated grey) and labelled for :func:`add_legend`."""
    from matplotlib.collections import LineCollection

    if len(segments):
        ax.add_collection(
            LineCollection(segments, colors=edge_color, linewidths=linewidth, label="edges")
        )
    for kind, colour in _KIND_COLOURS.items():
        pts = np.asarray(points_by_kind.get(kind, ()), float).reshape(-1, 2)
        if len(pts):
            ax.scatter(pts[:, 0], pts[:, 1], s=node_size, c=colour, label=kind, zorder=3)


def room_layer(labels: np.ndarray, alpha: float) -> np.ndarray:
    """RGBA float32 (H, W, 4) of room labels (int (H, W), 0 = no room): each room in its
    colour of the label picture at opacity ``alpha``, transparent elsewhere."""
    from .io.rooms import room_colours

    lab = np.asarray(labels)
    rgba = np.zeros(lab.shape + (4,), np.float32)
    top = int(lab.max()) if lab.size else 0
    if top > 0:
        colours = room_colours(top).astype(np.float32) / 255.0
        inside = lab > 0
        rgba[inside, :3] = colours[lab[inside] - 1]
        rgba[inside, 3] = alpha
    return rgba


def _axes(ax, figsize=(8, 8)):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize)
    elif not hasattr(ax, "imshow"):
        raise TypeError(f"ax: expected matplotlib Axes or None, received {type(ax).__name__}")
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


def _shown_factor(shape: tuple[int, int]) -> int:
    """The smallest whole factor that shrinks a layer of ``shape`` (H, W), a block of
    ``factor`` x ``factor`` pixels to one, to at most :data:`MAX_SHOWN_PX` pixels."""
    h, w = shape
    k = max(1, math.ceil(math.sqrt(h * w / MAX_SHOWN_PX)))
    while -(-h // k) * -(-w // k) > MAX_SHOWN_PX:
        k += 1
    return k


def plot_map(
    occupancy, *, ax=None, title: str | None = None, scale_bar: bool = True, pool: bool = False
):
    """Occupancy map: occupied black, free white, unknown grey, with a scale bar in metres
    under it (:func:`add_scale_bar`).  With ``pool``, shrunk to the axes' screen pixels by
    keeping each block's darkest class (:func:`map_image`), so thin walls stay unbroken;
    without, shrunk the same way only as far as :data:`MAX_SHOWN_PX` asks.
    Returns the axes."""
    ax = _axes(ax)
    k = _shown_factor(occupancy.shape)
    if pool:
        k = max(k, pool_factor(occupancy.shape, ax))
    _imshow_pooled(ax, map_image(occupancy, k), occupancy.shape, k, cmap="gray", vmin=0, vmax=1)
    ax.set_axis_off()
    if scale_bar:
        add_scale_bar(ax, occupancy.resolution_m)
    if title:
        ax.set_title(title)
    return ax


def plot_distance(distance: np.ndarray, *, ax=None, title: str | None = "distance map H"):
    """Distance map ``H`` (float (H, W) in [0, 1]) as a colour image; above
    :data:`MAX_SHOWN_PX` pixels, every k-th row and column of it.  Returns the axes."""
    ax = _axes(ax)
    distance = np.asarray(distance)
    k = _shown_factor(distance.shape)
    shown = distance[::k, ::k]
    im = _imshow_pooled(ax, shown, distance.shape, k, cmap="viridis", vmin=0, vmax=1)
    ax.figure.colorbar(im, ax=ax, fraction=0.046, pad=0.02)
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def plot_ridges(ridges: np.ndarray, *, ax=None, title: str | None = "ridges"):
    """Binary ridge map (bool (H, W)), black on white; max-pooled when the axes show it
    smaller than its pixels (:func:`max_pool`), so one-pixel lines stay unbroken.
    Returns the axes."""
    ax = _axes(ax)
    ridges = np.asarray(ridges, bool)
    h, w = ridges.shape
    white = np.ones((1, 1), np.float32)
    ax.imshow(white, cmap="gray", vmin=0, vmax=1, extent=(-0.5, w - 0.5, h - 0.5, -0.5))
    _show_mask(ax, ridges, "#000000")
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def plot_skeleton(skeleton: np.ndarray, *, ax=None, color="#2ca02c", title: str | None = None):
    """Skeleton pixels as an overlay (transparent elsewhere), max-pooled when the axes
    show it smaller than its pixels (:func:`max_pool`).  Returns the axes."""
    ax = _axes(ax)
    _show_mask(ax, np.asarray(skeleton, bool), color)
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return ax


def _vertices_by_kind(graph) -> dict[str, list]:
    """Vertex kind -> list of the vertices' ``(col, row)`` pixels."""
    points: dict[str, list] = {}
    for _, d in graph.nodes(data=True):
        points.setdefault(d.get("kind"), []).append(d["pixel"][::-1])
    return points


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
        Vertex marker size, points^2 (junction red, end blue, ring purple, isolated grey).
    title : str, optional

    Returns
    -------
    matplotlib Axes
        With the legend of edges and vertex kinds under the graph (:func:`add_legend`).
    """
    ax = _axes(ax)
    segments = [np.asarray(data["path"], float)[:, ::-1] for _, _, data in graph.edges(data=True)]
    points = _vertices_by_kind(graph)
    draw_graph_lines(
        ax, segments, points, edge_color=edge_color, linewidth=linewidth, node_size=node_size
    )
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
    ax = _axes(ax)
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
    from .routegraph import vertex_pixels

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
        xy = np.asarray(pts, np.float64).reshape(-1, 2)
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

    from .maps import map_argument
    from .maps.occupancy import map_mismatch
    from .routegraph import vertex_pixels
    from .routegraph.feasible import feasible_space

    nx_graph("graph", graph, undirected=False)
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
    ax = _axes(ax, figsize=(9, 9))
    plot_map(occupancy, ax=ax)
    margin = space.free & ~space.feasible
    # not pooled to the axes, so a feasible band stays visible; past MAX_SHOWN_PX a
    # block shows the margin only where all of it is margin, for the same reason
    k = _shown_factor(margin.shape)
    shown = margin if k == 1 else ~max_pool(~margin, k)
    rgba = np.zeros(shown.shape + (4,), np.uint8)
    rgba[shown] = (*(round(255 * c) for c in _hex_rgb(_MARGIN_COLOUR)), 255)
    _imshow_pooled(ax, rgba, margin.shape, k)
    nodes = list(graph.nodes)
    points: dict[str, list] = {}
    for node, rc in zip(nodes, vertex_pixels(graph, nodes, occupancy, "auto"), strict=True):
        points.setdefault(graph.nodes[node].get("kind"), []).append((rc[1], rc[0]))
    draw_graph_lines(
        ax,
        route_graph_lines(graph, occupancy),
        points,
        edge_color=edge_color,
        linewidth=linewidth,
        node_size=node_size,
    )
    if graph.number_of_nodes():
        add_legend(ax)
    ax.set_aspect("equal")
    if title is None:
        title = _titled(
            map_name(occupancy.source),
            f"r = {float(robot_radius_m):g} m: {graph.number_of_nodes()} vertices, "
            f"{graph.number_of_edges()} edges",
        )
    ax.set_title(title)
    return ax


def figure_png(fig, *, dpi: int = 150) -> bytes:
    """``fig`` as PNG bytes, cropped to what is drawn; a pyplot figure is closed."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    if fig.canvas.manager is not None:  # made by pyplot, which keeps it until closed
        import matplotlib.pyplot as plt

        plt.close(fig)
    return buf.getvalue()


def _map_figure(shape: tuple[int, int], side_in: float):
    """A figure (no pyplot state: safe in worker processes and threads) with one axes,
    ``side_in`` inches wide and as tall as the map's aspect ratio asks."""
    from matplotlib.figure import Figure

    h, w = shape
    fig = Figure(figsize=(side_in, side_in * h / max(w, 1)))
    return fig, fig.add_subplot()


def result_png(result, *, title: str | None = None, rooms=None, dpi: int = 150) -> bytes:
    """The picture of :func:`plot` as PNG bytes (no pyplot state)."""
    fig, ax = _map_figure(result.map.shape, 9.0)
    plot(result, ax=ax, title=title, rooms=rooms)
    return figure_png(fig, dpi=dpi)


def stages_png(result, *, title: str | None = None, dpi: int = 110) -> bytes:
    """The picture of :func:`plot_stages` as PNG bytes."""
    return figure_png(plot_stages(result, title=title), dpi=dpi)


def rooms_png(seg, *, dpi: int = 150) -> bytes:
    """The picture of :func:`plot_rooms` as PNG bytes (no pyplot state)."""
    fig, ax = _map_figure(seg.labels.shape, 9.0)
    plot_rooms(seg, ax=ax)
    return figure_png(fig, dpi=dpi)


def route_graph_png(graph, occupancy, *, title: str | None = None, dpi: int = 150) -> bytes:
    """The picture of :func:`plot_route_graph` as PNG bytes (no pyplot state: safe in
    worker processes and threads)."""
    from .maps import map_argument

    occupancy = map_argument("occupancy", occupancy, files=True)
    fig, ax = _map_figure(occupancy.shape, 8.0)
    plot_route_graph(graph, occupancy, ax=ax, title=title)
    return figure_png(fig, dpi=dpi)


def _room_segmentation(seg, name: str):
    from .rooms import RoomSegmentation

    return instance_of(name, seg, RoomSegmentation)


def _draw_rooms(seg, ax, *, doors: bool, labels: bool, alpha: float) -> None:
    """Rooms as a translucent colour layer (:func:`topojax.io.rooms.room_colours`, as the
    label picture), doorways as white lines between their ends, room ids at their
    centroids."""
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
        Default: the map's name and the room and door counts.
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
    if doors and seg.doors:
        add_legend(ax)
    if title is None:
        title = _titled(
            map_name(getattr(seg.occupancy, "source", None)),
            f"{seg.n_rooms} rooms, {len(seg.doors)} doors",
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
        add_legend(ax)
    if title is None:
        g = result.graph
        title = f"{g.number_of_nodes()} vertices, {g.number_of_edges()} edges"
        if rooms is not None:
            title += f", {rooms.n_rooms} rooms"
        title = _titled(map_name(result.map.source), title)
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
    import matplotlib.pyplot as plt

    result = _as_result(result, ("map", "distance", "lap_abs", "ridges", "skeleton", "graph"))

    fig, axes = plt.subplots(2, 3, figsize=figsize)
    title = title if title is not None else map_name(result.map.source)
    if title:
        fig.suptitle(title)
    plot_map(result.map, ax=axes[0, 0], title="occupancy map", pool=True)
    plot_distance(result.distance, ax=axes[0, 1])
    k = pool_factor(result.lap_abs.shape, axes[0, 2])
    _imshow_pooled(axes[0, 2], max_pool(result.lap_abs, k), result.lap_abs.shape, k, cmap="magma")
    axes[0, 2].set_title("|Laplacian| (x255)")
    axes[0, 2].set_axis_off()
    plot_ridges(result.ridges, ax=axes[1, 0], title="ridges (> threshold)")
    plot_ridges(result.skeleton, ax=axes[1, 1], title="skeleton")
    g = result.graph
    plot(
        result,
        ax=axes[1, 2],
        title=f"graph ({g.number_of_nodes()} vertices, {g.number_of_edges()} edges)",
    )
    fig.tight_layout()
    return fig


def _hex_rgb(colour: str) -> tuple[float, float, float]:
    from matplotlib.colors import to_rgb

    return to_rgb(colour)
