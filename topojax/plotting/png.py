"""Pictures as PNG bytes, drawn without pyplot state where they can be (worker processes,
threads)."""

from __future__ import annotations

import io

from .figures import plot, plot_rooms, plot_route_graph, plot_stages


def figure_png(fig, *, dpi: int = 150) -> bytes:
    """``fig`` as PNG bytes, cropped to what is drawn; a pyplot figure is closed."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    if fig.canvas.manager is not None:  # made by pyplot, which keeps it until closed
        import matplotlib.pyplot as plt

        plt.close(fig)
    return buf.getvalue()


#: The tallest picture, in widths: a map taller than that (a strip a few pixels wide) is
#: drawn narrower within it, not on a figure whose canvas outgrows memory.
MAX_FIGURE_ASPECT = 8.0


def map_figure(shape: tuple[int, int], side_in: float):
    """A figure (no pyplot state: safe in worker processes and threads) with one axes,
    ``side_in`` inches wide and as tall as the map's aspect ratio asks, up to
    :data:`MAX_FIGURE_ASPECT` times its width."""
    from matplotlib.figure import Figure

    h, w = shape
    fig = Figure(figsize=(side_in, side_in * min(h / max(w, 1), MAX_FIGURE_ASPECT)))
    return fig, fig.add_subplot()


def result_png(result, *, title: str | None = None, rooms=None, dpi: int = 150) -> bytes:
    """The picture of :func:`plot` as PNG bytes (no pyplot state)."""
    fig, ax = map_figure(result.map.shape, 9.0)
    plot(result, ax=ax, title=title, rooms=rooms)
    return figure_png(fig, dpi=dpi)


def stages_png(result, *, title: str | None = None, dpi: int = 110) -> bytes:
    """The picture of :func:`plot_stages` as PNG bytes."""
    return figure_png(plot_stages(result, title=title), dpi=dpi)


def rooms_png(seg, *, dpi: int = 150) -> bytes:
    """The picture of :func:`plot_rooms` as PNG bytes (no pyplot state)."""
    fig, ax = map_figure(seg.labels.shape, 9.0)
    plot_rooms(seg, ax=ax)
    return figure_png(fig, dpi=dpi)


def route_graph_png(graph, occupancy, *, title: str | None = None, dpi: int = 150) -> bytes:
    """The picture of :func:`plot_route_graph` as PNG bytes (no pyplot state: safe in
    worker processes and threads)."""
    from ..maps import map_argument

    occupancy = map_argument("occupancy", occupancy, files=True)
    fig, ax = map_figure(occupancy.shape, 8.0)
    plot_route_graph(graph, occupancy, ax=ax, title=title)
    return figure_png(fig, dpi=dpi)
