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

from .figures import (
    plot,
    plot_distance,
    plot_graph,
    plot_map,
    plot_ridges,
    plot_rooms,
    plot_route,
    plot_route_graph,
    plot_skeleton,
    plot_stages,
    route_graph_lines,
)
from .png import figure_png, result_png, rooms_png, route_graph_png, stages_png
from .style import (
    MAX_SHOWN_PX,
    add_legend,
    add_scale_bar,
    draw_graph_lines,
    map_image,
    map_name,
    max_pool,
    pool_factor,
    room_layer,
)

__all__ = [
    "MAX_SHOWN_PX",
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
