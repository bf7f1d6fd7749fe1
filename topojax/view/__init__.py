"""An interactive viewer: one self-contained HTML file (no server, no network) with the
map, its layers, the graphs, rooms and routes, and a replay's timeline.

:func:`write_view` writes the file; :func:`show` displays the same page inline in a
notebook (Jupyter, VS Code) without extensions; :class:`Timeline` records an incremental
mapper's graph at every update for the page's timeline.  ``topojax view OUT_DIR`` writes
the view of a folder of results.  The page's script and style are part of the package
(``topojax/view/static``, MIT like the rest).
"""

from __future__ import annotations

import html
import inspect
from pathlib import Path

from .._validate import instance_of, positive_int
from ._data import DEFAULT_MAX_PIXELS, build_payload, inputs_of
from ._html import page
from .timeline import Timeline
from .window import apply_window

__all__ = ["DEFAULT_MAX_PIXELS", "Timeline", "View", "show", "view_html", "write_view"]


def view_html(
    obj,
    *,
    title: str | None = None,
    map=None,
    rooms=None,
    graphs: dict | None = None,
    route=None,
    timeline: Timeline | None = None,
    window=None,
    max_pixels: int = DEFAULT_MAX_PIXELS,
) -> str:
    """The viewer page of ``obj`` as HTML text (see :func:`write_view` for the
    arguments)."""
    max_pixels = positive_int("max_pixels", max_pixels)
    inputs = inputs_of(
        obj,
        map=map,
        rooms=rooms,
        graphs=graphs,
        route=route,
        timeline=timeline,
        title=title,
        max_pixels=max_pixels if window is None else None,
    )
    if window is not None:
        apply_window(inputs, window, max_pixels=max_pixels)
    return page(build_payload(inputs, max_pixels=max_pixels))


def write_view(
    obj,
    path,
    *,
    title: str | None = None,
    map=None,
    rooms=None,
    graphs: dict | None = None,
    route=None,
    timeline: Timeline | None = None,
    window=None,
    max_pixels: int = DEFAULT_MAX_PIXELS,
) -> Path:
    """Write an interactive view of a map and its graphs to one HTML file.

    The file opens from disk in any current browser, with no server and no network.  It
    shows the map with layers that can be switched on and off (distance map, ridges,
    skeleton, each graph with its vertices coloured by kind, rooms and doors, a route,
    the robot's path); drag to pan, wheel to zoom; hovering a vertex shows its id, kind,
    clearance and world position, an edge its length and clearances, a room its id and
    area; clicking a start and a goal plans a route along the graph exactly as
    :func:`topojax.plan_route` does (same snapping and length) and shows its length.
    The world position under the cursor and a scale bar are always shown.

    Parameters
    ----------
    obj : TopologyResult, TiledResult, IncrementalMapper, RoomSegmentation, networkx graph,
          OccupancyMap or TiledMap
        What to show: a result (map, distance map, ridges, skeleton, graph; of
        :func:`topojax.build_graph_tiled`, its map and graph), a mapper
        (its map and graph as of the last update, with its rooms when it keeps them), a
        room segmentation (with its map), a graph (e.g. :func:`topojax.route_graph`'s;
        pass its ``map``) or a map alone.
    path : str or Path
        The HTML file to write (its folder must exist).
    title : str, optional
        Shown on the page (default: from the map's file name).
    map : OccupancyMap or TiledMap, optional
        The map under a graph given alone (or another map to draw; the page notes a
        graph whose recorded shape, resolution or origin is not this map's, and leaves
        out a result's distance map, ridges and skeleton, which lie on its own map).  A
        :class:`topojax.TiledMap` (a map on disk) is read only where shown: the window,
        or the whole map once it is known to fit ``max_pixels``.
    rooms : RoomSegmentation, (rooms, doors), bool or None
        Rooms to draw: a segmentation, the pair :func:`topojax.load_rooms` returns, True
        (segment the map now; a mapper's own rooms), False (none, not even those a
        ``timeline`` recorded).  Default: a mapper's
        rooms when it keeps them (``rooms_every`` > 0, or None once its rooms are in
        use), else none.  The page notes a segmentation, or :func:`topojax.load_rooms`'
        pair, made on another map than the one shown, and a pair that records no map
        whose doors' pixel ends or rooms' pixel boxes do not fall where their world
        coordinates lie on it.
    graphs : dict of str to networkx graph, optional
        More graphs to draw, each a layer under its name (e.g. ``{"pruned":
        tj.prune_graph(res.graph, ...)}``); routes can be planned on each.  The page
        notes one whose recorded shape, resolution or origin is not the shown map's.
    route : Route, optional
        A route to draw (e.g. from :func:`topojax.plan_route`); the page notes one whose
        pixels do not lie where its world points fall on the map shown.
    timeline : Timeline, optional
        The mapper's graph at every update: the page gets a timeline to play or scrub
        (and a note when its last map reaches beyond the map shown).  ``obj`` must have
        a graph of its own (the mapper, or its graph), which the updates' graphs stand
        in for.
    window : (x_min, y_min, x_max, y_max), optional
        Show only this world box (metres): the map and its layers inside it, the edges
        that pass through it (whole, with their vertices; routes run on those), the
        rooms that meet it.  For maps larger than ``max_pixels``.
    max_pixels : int
        Refuse a map (or window) of more pixels than this (default
        :data:`DEFAULT_MAX_PIXELS`, 64 Mpx).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    TypeError
        ``obj`` or an argument of the wrong type.
    FileNotFoundError, NotADirectoryError, IsADirectoryError
        ``path`` cannot be written (its folder is missing or a file, or it is a folder):
        checked before any work.
    ValueError
        A map larger than ``max_pixels`` (the message names the limit and how to view a
        part), nothing to show (no map and an empty graph), a malformed graph, rooms
        or timeline, or a timeline beside an ``obj`` without a graph of its own.

    Examples
    --------
    >>> res = tj.build_graph(tj.sample_map("intel"))              # doctest: +SKIP
    >>> tj.write_view(res, "intel.html")                           # doctest: +SKIP
    """
    from .._fs import atomic_write_bytes, output_file_in_folder

    output_file_in_folder(path, name="path")  # before the work
    text = view_html(
        obj,
        title=title,
        map=map,
        rooms=rooms,
        graphs=graphs,
        route=route,
        timeline=timeline,
        window=window,
        max_pixels=max_pixels,
    )
    atomic_write_bytes(path, text.encode("utf-8"))
    return Path(path)


class View:
    """A viewer page that notebooks display inline (:func:`show`).

    Attributes
    ----------
    html : str
        The complete page, as :func:`write_view` writes it.
    height_px : int
        Height of the frame it is shown in, CSS pixels.
    """

    def __init__(self, text: str, *, height_px: int = 600) -> None:
        self.html = instance_of("text", text, str, "str (the page's HTML)")
        self.height_px = positive_int("height_px", height_px)

    def _repr_html_(self) -> str:
        # an iframe keeps the page's script and style apart from the notebook's; srcdoc
        # needs no file and no server (Jupyter, JupyterLab, VS Code)
        return (
            f'<iframe srcdoc="{html.escape(self.html, quote=True)}" '
            f'style="width: 100%; height: {self.height_px}px; border: 1px solid #cfd8dc;" '
            'title="topojax view"></iframe>'
        )

    def save(self, path) -> Path:
        """Write the page to ``path`` (an HTML file)."""
        from .._fs import atomic_write_bytes, output_file_in_folder

        p = output_file_in_folder(path, name="path")
        atomic_write_bytes(p, self.html.encode("utf-8"))
        return p

    def __repr__(self) -> str:
        return f"View({len(self.html) / 1e6:.2f} MB of HTML)"


def show(obj, *, height_px: int = 600, **kwargs) -> View:
    """The interactive view of ``obj`` inline in a notebook.

    Parameters
    ----------
    obj
        As for :func:`write_view` (a result, a mapper, a room segmentation, a graph, a
        map).
    height_px : int
        Height of the frame, CSS pixels (default 600).
    **kwargs
        ``title``, ``map``, ``rooms``, ``graphs``, ``route``, ``timeline``,
        ``window``, ``max_pixels`` (:func:`write_view`'s).

    Returns
    -------
    View
        Jupyter and VS Code display it as the page of :func:`write_view` in a frame (no
        extension needed).

    Examples
    --------
    >>> tj.show(tj.build_graph(tj.sample_map("intel")))           # doctest: +SKIP
    """
    height_px = positive_int("height_px", height_px)
    options = [
        p.name for p in inspect.signature(view_html).parameters.values() if p.kind == p.KEYWORD_ONLY
    ]
    for name in kwargs:
        if name not in options:
            raise TypeError(
                f"{name}: expected one of write_view's options ({', '.join(options)}) "
                "or height_px, received an unknown keyword argument"
            )
    return View(view_html(obj, **kwargs), height_px=height_px)
