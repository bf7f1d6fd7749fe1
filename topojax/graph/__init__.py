"""Skeleton → topology graph (paper §II-C).

Every skeleton pixel is a node of a *pixel graph* and is linked to each of its up to eight
set neighbours, except for the redundant diagonal of an ``L``: two diagonal neighbours
``p`` and ``q`` are **not** linked when a pixel that is 4-adjacent to both of them is set
(the two 4-links through that pixel already connect them, and the diagonal would close a
triangle).  The topology graph is the pixel graph with its degree-2 pixels contracted:

* **vertices** are the pixels whose pixel-graph degree is not 2: ``"end"`` (degree 1),
  ``"junction"`` (degree >= 3) and ``"isolated"`` (degree 0, a lone pixel);
* **edges** are the maximal chains of degree-2 pixels between two vertices, stored with
  their full ordered pixel path;
* a closed ring made only of degree-2 pixels has no vertex of its own; it becomes a single
  vertex of kind ``"ring"`` (at the **last** pixel of the ring in raster order, which is
  where the original implementation puts it on the intel map) carrying one self-loop edge.

Partition invariant: every skeleton pixel is either a vertex pixel (a member of exactly one
vertex's ``pixels``) or an interior pixel of exactly one edge path.  Paths are 8-connected,
their first and last pixels are vertex pixels, and each pixel-graph link is traversed by
exactly one edge.

:func:`prune_graph` trims a built graph for routing: edges narrower than the robot, short
dead-end branches (round after round, joining the edges of a vertex left with two) and
small components.  It works on the graph alone; for spurs it gives the vertices and edges
that pruning the skeleton's pixels and building the graph again would give, except that a
vertex left on a ring stays where it was (a rebuilt graph puts it at the ring's last pixel
in raster order).

Modules: :mod:`~topojax.graph.trace` (numba kernels: links, tracing, rings),
:mod:`~topojax.graph.build` (:func:`skeleton_to_graph`: checks, world coordinates, kinds,
junction-cluster merge), :mod:`~topojax.graph.store` (:class:`GraphStore`, the graph as
arrays, and the vertex kind codes), :mod:`~topojax.graph.prune` (:func:`prune_graph`) and
:mod:`~topojax.graph.geometry` (path lengths, orientation, vertex pixels, simplification).
The link bit-masks, the tracing of ordered edge paths and the ring search are numba kernels
(one pass over the skeleton pixels each); attribute arrays (world coordinates, lengths,
clearances) are computed with vectorised numpy over all paths at once.
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
    polyline_keep,
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
    "pixel_graph_degree",
    "pixels_graph_store",
    "polyline_keep",
    "prune_graph",
    "raw_graph",
    "skeleton_graph_store",
    "skeleton_to_graph",
]
