"""The pictures' shared style: map grey levels, pooled layers, the scale bar, the legend,
graph lines and room colours."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .._constants import EDGE_COLOUR, OTHER_VERTEX_COLOUR, VERTEX_KIND_COLOURS

_KIND_COLOURS = VERTEX_KIND_COLOURS
#: Grey levels of the map classes (0 black .. 1 white).
_OCCUPIED_GREY, _UNKNOWN_GREY, _FREE_GREY = 0.0, 0.8, 1.0
#: The most map pixels :func:`plot_map` hands to matplotlib, which resamples a shown
#: image through several full-size float copies: a larger map is shrunk first (each
#: block's darkest class), still finer than any figure shows it.
MAX_SHOWN_PX = 8_000_000
#: Free pixels closer to an obstacle than the robot's radius, in route-graph pictures.
MARGIN_COLOUR = "#e6d3b8"
#: The scale bar's length is the longest 1, 2 or 5 x 10^k metres up to this share of the
#: axes' width.
_SCALE_SHARE = 0.25


def map_name(source) -> str | None:
    """A map's name for titles: the file stem of ``source`` (a map's ``source`` path), its
    folder's name for a file called ``map`` (``pal_office/map.yaml``); None without one."""
    if not source:
        return None
    p = Path(str(source))
    if p.stem.lower() == "map" and p.parent.name:
        return p.parent.name
    return p.stem or None


def titled(name: str | None, text: str) -> str:
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


def imshow_pooled(ax, image: np.ndarray, shape: tuple[int, int], factor: int, **kwargs):
    """Show ``image``, an (H, W) layer pooled ``factor`` times, over the pixels of the
    (H, W) = ``shape`` layer in pixel coordinates; the axes keep the layer's limits."""
    h, w = shape
    hp, wp = image.shape[:2]
    extent = (-0.5, wp * factor - 0.5, hp * factor - 0.5, -0.5)
    shown = ax.imshow(image, interpolation="nearest", extent=extent, **kwargs)
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    return shown


def show_mask(ax, mask: np.ndarray, colour, *, alpha: float = 1.0):
    """``mask`` as a colour layer (transparent elsewhere) in pixel coordinates,
    max-pooled for the axes."""
    k = pool_factor(mask.shape, ax)
    small = max_pool(mask.astype(bool), k)
    rgba = np.zeros(small.shape + (4,), np.float32)
    rgba[small] = (*hex_rgb(colour), alpha)
    imshow_pooled(ax, rgba, mask.shape, k)


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
    from matplotlib.collections import LineCollection
    from matplotlib.legend_handler import HandlerLineCollection

    if any(isinstance(h, LineCollection) and h.get_path_effects() for h in handles):
        # a white line drawn with a dark outline (the doors) keeps the outline in the legend
        outlined = HandlerLineCollection(update_func=_outlined_line)
        options.setdefault("handler_map", {LineCollection: outlined})
    return ax.legend(handles, labels, **options)


def _outlined_line(legend_handle, orig_handle) -> None:
    """Draw a LineCollection's legend line in its first colour and width, with its outline."""
    legend_handle.set_color(orig_handle.get_colors()[0])
    legend_handle.set_linewidth(orig_handle.get_linewidths()[0])
    legend_handle.set_path_effects(orig_handle.get_path_effects())


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
    red, end blue, ring purple, isolated grey; any other kind, or None, brown as "other")
    and labelled for :func:`add_legend`."""
    from matplotlib.collections import LineCollection

    if len(segments):
        ax.add_collection(
            LineCollection(segments, colors=edge_color, linewidths=linewidth, label="edges")
        )
    others = [p for kind, pts in points_by_kind.items() if kind not in _KIND_COLOURS for p in pts]
    layers = [*_KIND_COLOURS.items(), ("other", OTHER_VERTEX_COLOUR)]
    for kind, colour in layers:
        pts = points_by_kind.get(kind, ()) if kind != "other" else others
        pts = np.asarray(pts, float).reshape(-1, 2)
        if len(pts):
            ax.scatter(pts[:, 0], pts[:, 1], s=node_size, c=colour, label=kind, zorder=3)


def room_layer(labels: np.ndarray, alpha: float) -> np.ndarray:
    """RGBA float32 (H, W, 4) of room labels (int (H, W), 0 = no room): each room in its
    colour of the label picture at opacity ``alpha``, transparent elsewhere."""
    from ..io.rooms import room_colours

    lab = np.asarray(labels)
    rgba = np.zeros(lab.shape + (4,), np.float32)
    top = int(lab.max()) if lab.size else 0
    if top > 0:
        colours = room_colours(top).astype(np.float32) / 255.0
        inside = lab > 0
        rgba[inside, :3] = colours[lab[inside] - 1]
        rgba[inside, 3] = alpha
    return rgba


def axes_or_new(ax, figsize=(8, 8)):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize)
    elif not hasattr(ax, "imshow"):
        raise TypeError(f"ax: expected matplotlib Axes or None, received {type(ax).__name__}")
    return ax


def shown_factor(shape: tuple[int, int]) -> int:
    """The smallest whole factor that shrinks a layer of ``shape`` (H, W), a block of
    ``factor`` x ``factor`` pixels to one, to at most :data:`MAX_SHOWN_PX` pixels."""
    h, w = shape
    k = max(1, math.ceil(math.sqrt(h * w / MAX_SHOWN_PX)))
    while -(-h // k) * -(-w // k) > MAX_SHOWN_PX:
        k += 1
    return k


def hex_rgb(colour: str) -> tuple[float, float, float]:
    from matplotlib.colors import to_rgb

    return to_rgb(colour)
