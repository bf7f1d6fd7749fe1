"""Skeleton → topology graph (paper §II-C): vertices at pixels whose pixel-graph degree is
not 2, edges along the chains between them with their ordered pixel paths, rings as one
vertex with a self-loop; :func:`prune_graph` trims a built graph for a robot.  What the
vertices and edges are, and the invariants the tests check, are in
``docs/graph-semantics.md``.
"""

from .build import (
    PixelToWorld,
    graph_summary,
    pixel_graph_degree,
    pixels_graph_store,
    skeleton_graph_store,
    skeleton_to_graph,
)
from .geometry import (
    cumulative_length_m,
    graph_resolution_m,
    holds,
    orient,
    path_lengths_m,
    pixel_less,
    polyline_keep,
    scaled_cumulative,
)
from .prune import prune_graph
from .store import KIND_CODES, KIND_NAMES, GraphStore, paused_gc
from .trace import raw_graph

__all__ = [
    "KIND_CODES",
    "KIND_NAMES",
    "GraphStore",
    "PixelToWorld",
    "cumulative_length_m",
    "graph_resolution_m",
    "graph_summary",
    "holds",
    "orient",
    "path_lengths_m",
    "paused_gc",
    "pixel_less",
    "pixel_graph_degree",
    "pixels_graph_store",
    "polyline_keep",
    "prune_graph",
    "raw_graph",
    "scaled_cumulative",
    "skeleton_graph_store",
    "skeleton_to_graph",
]
