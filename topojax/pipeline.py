"""Full-map pipeline: occupancy map -> distance map -> ridges -> skeleton -> graph.

The JAX stages (:mod:`topojax.fields`) turn the obstacle mask into the distance map and
its ridges tile by tile; the CPU stages (thinning, T removal, graph) then run on the whole
assembled ridge map.  The stages' functions are importable from here as well.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from functools import cached_property

import networkx as nx
import numpy as np

from .config import PipelineConfig
from .fields import (
    FAR_SQ,
    SPARSE_CLEARANCE_MAX_PX,
    DenseFields,
    clearance_at,
    clearance_from_sq_distance,
    dense_fields,
    dense_fields_many,
    distance_map,
    forward_tile,
    ridge_map,
    trace_counts,
)

__all__ = [
    "SPARSE_CLEARANCE_MAX_PX",
    "TopologyResult",
    "DenseFields",
    "build_graph",
    "clearance_at",
    "clearance_from_sq_distance",
    "dense_fields",
    "dense_fields_many",
    "distance_map",
    "ridge_map",
    "forward_tile",
    "graph_from_ridges",
    "graph_of_map",
    "trace_counts",
    "travel_ridges",
]


@dataclass(frozen=True)
class TopologyResult:
    """Everything :func:`build_graph` produced.

    Attributes
    ----------
    map : OccupancyMap
        The input map.
    distance : float32 (H, W)
        Gaussian distance map in [0, 1].
    lap_abs : uint8 (H, W)
        Absolute Laplacian response (scaled, rounded, saturated).
    ridges : bool (H, W)
        Thresholded ridge map.
    skeleton : bool (H, W)
        Thinned ridges after T-centre removal (of the ridges in free space only with
        ``GraphConfig.free_space_only``).
    graph : networkx.MultiGraph
        The topology graph (see :func:`topojax.graph.skeleton_to_graph`); it covers the
        whole skeleton unless ``GraphConfig``'s ``min_clearance_m``, ``min_spur_m`` or
        ``min_component_m`` pruned it (:func:`topojax.prune_graph`).
    config : PipelineConfig
    timings_s : dict[str, float]
        Wall time of each stage in seconds.
    sq_distance_px : int32 (H, W)
        Windowed squared distance to the nearest obstacle in px^2 (``FAR_SQ`` where the
        window holds none); the distance map is ``exp(-sq_distance_px / (2 sigma^2))``.
    clearance_px : float32 (H, W)
        Euclidean distance to the nearest obstacle in pixels (``inf`` with no obstacle),
        on the whole map.  Computed on first access (beyond the window it needs an
        unwindowed transform); the graph's clearances do not wait for it.
    """

    map: object
    distance: np.ndarray
    lap_abs: np.ndarray
    ridges: np.ndarray
    skeleton: np.ndarray
    graph: nx.MultiGraph
    config: PipelineConfig
    timings_s: dict[str, float] = field(default_factory=dict)
    sq_distance_px: np.ndarray | None = None

    @cached_property
    def clearance_px(self) -> np.ndarray:
        if self.sq_distance_px is None:
            raise ValueError("clearance_px needs sq_distance_px, which this result lacks")
        return clearance_from_sq_distance(
            self.sq_distance_px, self.map.occupied, self.config.distance.half_width_px
        )


def graph_from_ridges(
    ridges: np.ndarray,
    *,
    clearance_px: np.ndarray | None,
    resolution_m: float,
    origin: tuple[float, float, float],
    pixel_to_world,
    config: PipelineConfig,
    source: object = None,
    free: np.ndarray | None = None,
):
    """The CPU stages: thinning, T-centre removal, the skeleton-to-graph step and what
    ``config.graph`` keeps of the graph.

    Parameters
    ----------
    ridges : bool (H, W)
        Ridge map.
    clearance_px : float32 (H, W), callable or None
        Euclidean clearance in pixels, as ``clearance_px`` of
        :func:`topojax.graph.skeleton_to_graph` (a callable gets the skeleton's flat
        indices once the skeleton is known, so it need only be computed there).
    resolution_m : float
        Metres per pixel.
    origin : (x, y, yaw)
        Map origin, stored as a graph attribute.
    pixel_to_world : callable
        ``(rows, cols) -> (x, y)``, e.g. :meth:`OccupancyMap.pixel_to_world`.
    config : PipelineConfig
    source : optional
        Where the map came from; stored as the graph attribute ``source``.
    free : bool (H, W), optional
        Known free space (``OccupancyMap.free``); needed with
        ``config.graph.free_space_only``, which thins ``ridges & free`` only.

    Returns
    -------
    skeleton : bool (H, W)
        The thinned ridges after T removal; when ``config.graph`` prunes, the graph covers
        part of it.
    graph : networkx.MultiGraph
    timings_s : dict with ``thinning``, ``t_removal`` and ``graph`` wall times (the
        graph's includes the pruning).
    """
    from .graph import prune_graph, skeleton_to_graph
    from .skeleton import skeletonize_ridges

    if config.graph.free_space_only:
        free = np.asarray(free) if free is not None else None
        if free is None or free.shape != ridges.shape or free.dtype != bool:
            raise ValueError(
                "free: config.graph.free_space_only needs the map's known-free mask, a bool "
                f"array of shape {ridges.shape}, got "
                + ("None" if free is None else f"{free.dtype} {free.shape}")
            )
        ridges = ridges & free
    steps: dict[str, float] = {}
    skeleton = skeletonize_ridges(
        ridges,
        method=config.skeleton.thinning,
        remove_t=config.skeleton.remove_t,
        timings_s=steps,
    )
    t2 = time.perf_counter()
    graph = skeleton_to_graph(
        skeleton,
        clearance_px=clearance_px,
        resolution_m=resolution_m,
        pixel_to_world=pixel_to_world,
        merge_junction_clusters=config.graph.merge_junction_clusters,
    )
    if config.graph.prunes:
        graph = prune_graph(
            graph,
            min_clearance_m=config.graph.min_clearance_m,
            min_spur_m=config.graph.min_spur_m,
            min_component_m=config.graph.min_component_m,
        )
    graph.graph["origin"] = tuple(float(v) for v in origin)
    graph.graph["thinning"] = config.skeleton.thinning
    if source is not None:
        graph.graph["source"] = str(source)
    t3 = time.perf_counter()
    return skeleton, graph, {**steps, "graph": t3 - t2}


def travel_ridges(ridges: np.ndarray, occupied: np.ndarray) -> np.ndarray:
    """The ridges the CPU stages thin: all of them, or none on a map whose every pixel is
    occupied (no space to travel: an empty graph, as for a map without obstacles; a tiny
    such map would otherwise keep ridges from the Laplacian's border rule)."""
    return np.zeros_like(ridges) if occupied.all() else ridges


def graph_of_map(occupancy, ridges: np.ndarray, sq_distance_px: np.ndarray, config):
    """:func:`graph_from_ridges` for a map's ridges, with the clearance read from its
    windowed squared distances (exact, and only at the skeleton's pixels: the only ones
    the graph reads; a result's whole-map clearance is computed on first access)."""

    def skeleton_clearance(flat: np.ndarray) -> np.ndarray:
        return clearance_at(sq_distance_px, occupancy.occupied, config.distance.half_width_px, flat)

    return graph_from_ridges(
        travel_ridges(ridges, occupancy.occupied),
        clearance_px=skeleton_clearance,
        resolution_m=occupancy.resolution_m,
        origin=occupancy.origin,
        pixel_to_world=occupancy.pixel_to_world,
        config=config,
        source=occupancy.source,
        free=occupancy.free,
    )


def build_graph(occupancy, *, config: PipelineConfig | None = None) -> TopologyResult:
    """Build the topology graph of a finished occupancy map (paper §II).

    Parameters
    ----------
    occupancy : OccupancyMap, array or path
        The map.  Arrays are converted with :meth:`OccupancyMap.from_array` (bool: True =
        occupied; uint8 image; int8 occupancy grid); a path (``str`` or
        :class:`os.PathLike`) is read with :func:`topojax.load_map` and its defaults.
    config : PipelineConfig, optional
        All stage settings; default reproduces the paper with Guo–Hall thinning.

    Returns
    -------
    TopologyResult
        ``.graph`` is a :class:`networkx.MultiGraph`: junctions and dead ends as vertices,
        corridors as edges carrying their pixel paths and world polylines.  A map with no
        obstacle, or with nothing but obstacles, gives an empty skeleton and graph.  A map
        of obstacles and unknown space (no free pixel) keeps the paper's graph, which runs
        through unknown space; ``GraphConfig(free_space_only=True)`` keeps free space only.
    """
    from .maps import OccupancyMap, load_map

    config = config or PipelineConfig()
    if not isinstance(config, PipelineConfig):
        raise TypeError(f"config must be a PipelineConfig, got {type(config).__name__}")
    if isinstance(occupancy, (str, os.PathLike)):
        occupancy = load_map(occupancy)
    elif occupancy is None or isinstance(occupancy, (bytes, bytearray)):
        raise TypeError(
            "occupancy: expected an OccupancyMap, a 2-D array or a map file path (str or "
            f"Path), got {type(occupancy).__name__}"
        )
    elif not isinstance(occupancy, OccupancyMap):
        occupancy = OccupancyMap.from_array(occupancy)
    timings: dict[str, float] = {}
    obstacles = occupancy.occupied

    t0 = time.perf_counter()
    if obstacles.any():
        fields = dense_fields(
            obstacles,
            distance=config.distance,
            ridge=config.ridge,
            tile_px=config.tile_px,
            tiles_per_call=config.tiles_per_call,
        )
    else:  # nothing to measure distances from: H = 0 everywhere, no ridges
        shape = obstacles.shape
        fields = DenseFields(
            np.full(shape, FAR_SQ, np.int32),
            np.zeros(shape, np.float32),
            np.zeros(shape, np.uint8),
            np.zeros(shape, bool),
        )
    t1 = time.perf_counter()
    timings["distance_ridges"] = t1 - t0

    skeleton, graph, cpu_timings = graph_of_map(
        occupancy, fields.ridges, fields.sq_distance_px, config
    )
    timings.update(cpu_timings)
    timings["total"] = time.perf_counter() - t0
    result = TopologyResult(
        map=occupancy,
        distance=fields.distance,
        lap_abs=fields.lap_abs,
        ridges=fields.ridges,
        skeleton=skeleton,
        graph=graph,
        config=config,
        timings_s=timings,
        sq_distance_px=fields.sq_distance_px,
    )
    return result
