"""topojax: topology (route) graphs from 2-D robot maps via Gaussian distance maps.

Implements Yuan & Schwertfeger, *Incrementally Building Topology Graphs via Distance
Maps* (RCAR 2019): from a finished occupancy map (:func:`build_graph`) or scan by scan
(:class:`IncrementalMapper`), with the distance map, Laplacian and threshold as JAX kernels
on fixed-size tiles and the thinning and graph steps compiled for the CPU.

Notation
--------
Arrays
    2-D maps are indexed ``grid[row, col]``; row 0 is the *top* of the image.  Pixel
    coordinates are ``(row, col)`` pairs, integer at pixel centres.
World frame
    ``(x, y)`` in metres, the map frame of ROS ``map_server``: ``origin = (x, y, yaw)`` is
    the world pose of the lower-left corner of the lower-left pixel.  The centre of pixel
    ``(row, col)`` of an ``H``-row map lies at ``((col + 0.5) r, (H - row - 0.5) r)`` in
    the map's own axes (``r`` = ``resolution_m``), rotated by ``yaw`` and shifted by the
    origin.  :meth:`OccupancyMap.pixel_to_world` and :meth:`OccupancyMap.world_to_pixel`
    convert.
Incremental mapper
    Scan poses and :meth:`IncrementalMapper.add_points` use the map frame above; the
    mapper's global pixel ``(row, col)`` is the square ``col r <= x < (col + 1) r``,
    ``-(row + 1) r < y <= -row r`` (:meth:`IncrementalMapper.world_to_pixel`), and the
    origin of its exported :class:`OccupancyMap` puts those squares on its pixels.
Units
    Names carry their unit: ``_px`` pixels, ``_m`` metres, ``_s`` seconds; angles are
    radians.
Distance map
    ``H(x) = max_p exp(-|x - p|^2 / (2 sigma_px^2))`` over obstacle pixels ``p`` with
    ``|x - p|_inf <= half_width_px``; float32 in [0, 1], 1 on obstacles.
Graphs
    :class:`networkx.MultiGraph`; vertices carry ``pixel``, ``world``, ``kind``
    (junction / end / ring / isolated) and ``clearance_m``; edges carry the ordered pixel
    ``path`` (ends included), the ``world`` polyline, ``length_m`` and clearances.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ._constants import VERSION as _VERSION

#: The same as ``version`` in pyproject.toml.
__version__ = _VERSION

if TYPE_CHECKING:  # the names for type checkers; at run time they load on first use
    from .batch import MapRecord, build_graphs
    from .config import (
        DistanceConfig,
        GraphConfig,
        PipelineConfig,
        RidgeConfig,
        SkeletonConfig,
    )
    from .datasets import sample_map
    from .graph import graph_summary, prune_graph, skeleton_to_graph
    from .incremental import (
        GraphUpdate,
        IncrementalMapper,
        RoomsUpdate,
        ScanReport,
        vertex_error_metrics,
    )
    from .io import (
        McapRecorder,
        load_graph,
        load_graph_store,
        load_rooms,
        save_graph,
        save_graph_store,
        save_mcap,
        save_nav2_graph,
        save_room_graph,
        save_room_labels,
        save_rooms,
    )
    from .maps import OccupancyMap, load_map, save_map
    from .maps.tiled import TiledMap, open_tiled_map, save_tiled_map
    from .outofcore import TiledResult, build_graph_tiled
    from .pipeline import (
        TopologyResult,
        build_graph,
        dense_fields,
        distance_map,
        ridge_map,
    )
    from .playback import replay
    from .plotting import plot, plot_rooms, plot_route_graph, plot_stages
    from .rooms import (
        Door,
        Room,
        RoomConfig,
        RoomSegmentation,
        assign_rooms,
        segment_rooms,
    )
    from .routegraph import (
        RouteGraphConfig,
        RouteGraphReport,
        evaluate_route_graph,
        route_graph,
    )
    from .routing import NoRouteError, Route, RoutePlanner, plan_route
    from .scans import Scan, read_bag, read_carmen, read_scans
    from .skeleton import remove_t_centres, thin
    from .view import Timeline, View, show, write_view

__all__ = [
    "DistanceConfig",
    "Door",
    "GraphConfig",
    "GraphUpdate",
    "IncrementalMapper",
    "MapRecord",
    "McapRecorder",
    "NoRouteError",
    "OccupancyMap",
    "PipelineConfig",
    "RidgeConfig",
    "Room",
    "RoomConfig",
    "RoomSegmentation",
    "RoomsUpdate",
    "Route",
    "RouteGraphConfig",
    "RouteGraphReport",
    "RoutePlanner",
    "Scan",
    "ScanReport",
    "SkeletonConfig",
    "TiledMap",
    "TiledResult",
    "Timeline",
    "TopologyResult",
    "View",
    "assign_rooms",
    "build_graph",
    "build_graph_tiled",
    "build_graphs",
    "dense_fields",
    "distance_map",
    "evaluate_route_graph",
    "graph_summary",
    "load_graph",
    "load_graph_store",
    "load_map",
    "load_rooms",
    "open_tiled_map",
    "plan_route",
    "plot",
    "plot_rooms",
    "plot_route_graph",
    "plot_stages",
    "prune_graph",
    "read_bag",
    "read_carmen",
    "read_scans",
    "remove_t_centres",
    "replay",
    "ridge_map",
    "route_graph",
    "sample_map",
    "save_graph",
    "save_graph_store",
    "save_map",
    "save_mcap",
    "save_nav2_graph",
    "save_room_graph",
    "save_room_labels",
    "save_rooms",
    "save_tiled_map",
    "segment_rooms",
    "show",
    "skeleton_to_graph",
    "thin",
    "vertex_error_metrics",
    "write_view",
]

# Every public name and the module that defines it.  ``import topojax`` loads none of
# them (JAX, numba and the map readers take seconds to import); a name's module is
# imported on its first use, e.g. ``topojax.build_graph`` or ``from topojax import thin``.
_LAZY = {
    "DistanceConfig": "config",
    "GraphConfig": "config",
    "PipelineConfig": "config",
    "RidgeConfig": "config",
    "SkeletonConfig": "config",
    "sample_map": "datasets",
    "graph_summary": "graph",
    "prune_graph": "graph",
    "skeleton_to_graph": "graph",
    "load_graph": "io",
    "load_graph_store": "io",
    "save_graph": "io",
    "save_graph_store": "io",
    "save_nav2_graph": "io",
    "save_mcap": "io",
    "McapRecorder": "io",
    "load_rooms": "io",
    "save_room_graph": "io",
    "save_room_labels": "io",
    "save_rooms": "io",
    "OccupancyMap": "maps",
    "load_map": "maps",
    "save_map": "maps",
    "TopologyResult": "pipeline",
    "build_graph": "pipeline",
    "dense_fields": "pipeline",
    "distance_map": "pipeline",
    "ridge_map": "pipeline",
    "Door": "rooms",
    "Room": "rooms",
    "RoomConfig": "rooms",
    "RoomSegmentation": "rooms",
    "assign_rooms": "rooms",
    "segment_rooms": "rooms",
    "RouteGraphConfig": "routegraph",
    "RouteGraphReport": "routegraph",
    "evaluate_route_graph": "routegraph",
    "route_graph": "routegraph",
    "plot": "plotting",
    "plot_rooms": "plotting",
    "plot_route_graph": "plotting",
    "plot_stages": "plotting",
    "NoRouteError": "routing",
    "Route": "routing",
    "RoutePlanner": "routing",
    "plan_route": "routing",
    "Scan": "scans",
    "read_bag": "scans",
    "read_carmen": "scans",
    "read_scans": "scans",
    "remove_t_centres": "skeleton",
    "thin": "skeleton",
    "IncrementalMapper": "incremental",
    "ScanReport": "incremental",
    "RoomsUpdate": "incremental",
    "GraphUpdate": "incremental",
    "replay": "playback",
    "vertex_error_metrics": "incremental",
    "build_graphs": "batch",
    "MapRecord": "batch",
    "TiledMap": "maps.tiled",
    "open_tiled_map": "maps.tiled",
    "save_tiled_map": "maps.tiled",
    "TiledResult": "outofcore",
    "build_graph_tiled": "outofcore",
    "Timeline": "view",
    "View": "view",
    "show": "view",
    "write_view": "view",
}

#: Submodules reachable as attributes (``topojax.pipeline``) before they are imported,
#: as when ``import topojax`` loaded them.
_SUBMODULES = frozenset(
    (
        "batch",
        "cli",
        "config",
        "datasets",
        "fields",
        "graph",
        "incremental",
        "io",
        "maps",
        "outofcore",
        "pipeline",
        "plotting",
        "rooms",
        "routegraph",
        "routing",
        "scans",
        "skeleton",
        "view",
    )
)


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is not None:
        value = getattr(importlib.import_module(f".{module}", __name__), name)
    elif name in _SUBMODULES:
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'topojax' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__) | _SUBMODULES)
