"""Small constants that the command line needs to build its parser, the colours that
pictures and ROS markers share, the distance kernels' "no obstacle" value, and the most
scans a saved mapper state or replay may count, in a module that imports nothing (the
modules that use them import JAX, numba, matplotlib or the map readers).

:mod:`topojax.maps`, :mod:`topojax.incremental` and :mod:`topojax.fields` import them from
here and export them under the same names.
"""

from __future__ import annotations

__all__ = [
    "CARMEN_LASERS",
    "EDGE_COLOUR",
    "FAR_SQ",
    "MAX_LOG_SCANS",
    "MODES",
    "OTHER_VERTEX_COLOUR",
    "STRATEGIES",
    "VERSION",
    "VERTEX_KIND_COLOURS",
]

#: topojax's version, the same as ``version`` in pyproject.toml (``topojax.__version__``).
VERSION = "0.1.0"

#: Pixel conventions of :func:`topojax.load_map` (``mode``); :data:`topojax.maps.MODES`.
MODES = ("trinary", "scale", "raw", "ipa")
#: Skeleton update strategies of :class:`topojax.IncrementalMapper`;
#: :data:`topojax.incremental.STRATEGIES`.
STRATEGIES = ("exact", "paper")
#: The laser messages of a CARMEN log that :func:`topojax.scans.read_carmen` reads
#: (``laser``; ``topojax replay --laser``).
CARMEN_LASERS = (
    "FLASER",
    "RLASER",
    "ROBOTLASER1",
    "ROBOTLASER2",
    "RAWLASER1",
    "RAWLASER2",
    "RAWLASER3",
    "RAWLASER4",
)
#: Colour of each vertex kind in pictures and ROS markers (:mod:`topojax.plotting`,
#: :mod:`topojax.io.mcap`).
VERTEX_KIND_COLOURS = {
    "junction": "#d62728",
    "end": "#1f77b4",
    "ring": "#9467bd",
    "isolated": "#7f7f7f",
}
#: Colour of a vertex of any other kind, or none (a graph of another tool), in the viewer
#: and ROS markers.
OTHER_VERTEX_COLOUR = "#8c564b"
#: Colour of the graph's edges in pictures and ROS markers.
EDGE_COLOUR = "#ff7f0e"
#: Colour of a route graph's edges in ROS markers (``/route_graph`` beside ``/topology``;
#: the viewer's colour for a second graph).
ROUTE_EDGE_COLOUR = "#2ca02c"
#: Squared-distance value (px^2) of pixels with no obstacle inside their window
#: (:data:`topojax.fields.FAR_SQ`).
FAR_SQ = 1 << 30
#: The most scans a saved mapper state or replay may count (a mapper's ``n_scans``, the
#: scans a replay took from its log): 10**12 scans are 800 years of a laser at 40 scans/s,
#: so a larger count is a damaged state.
MAX_LOG_SCANS = 10**12
