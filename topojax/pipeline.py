"""Full-map pipeline: occupancy map -> distance map -> ridges -> skeleton -> graph.

The JAX stages (:mod:`topojax.fields`) turn the obstacle mask into the distance map and
its ridges tile by tile; the CPU stages (thinning, T removal, graph) then run on the whole
assembled ridge map.  The stages' functions are importable from here as well.
"""

from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass, field
from functools import cached_property

import networkx as nx
import numpy as np

from ._stage_memory import BUILD_GRAPH_BYTES_PER_PX, check_stage_fits
from ._validate import instance_or_default, names_subset
from .config import PipelineConfig
from .fields import (
    FAR_SQ,
    SPARSE_CLEARANCE_MAX_PX,
    DenseFields,
    clearance_at,
    clearance_from_sq_distance,
    clearance_of_values,
    dense_fields,
    dense_fields_many,
    distance_map,
    forward_tile,
    ridge_fields,
    ridge_map,
    trace_counts,
)
from .fields.ridge_values import at_ridge_pixels

__all__ = [
    "DEFAULT_KEEP",
    "RESULT_FIELDS",
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


#: The per-pixel fields of a :class:`TopologyResult`, from which ``keep`` of
#: :func:`build_graph` chooses those computed and held from the start.
RESULT_FIELDS = ("distance", "lap_abs", "ridges", "skeleton", "sq_distance_px")
#: What :func:`build_graph` holds unless told otherwise: the CPU stages' own fields (1
#: byte per pixel each); the others are computed on first access.
DEFAULT_KEEP = ("ridges", "skeleton")


class _NotKept:
    """Stands in a :class:`TopologyResult` field that is computed on first access."""

    def __repr__(self) -> str:
        return "<computed on first access>"


_NOT_KEPT = _NotKept()
#: Held while a field is computed on first access: threads asking for the same field of
#: one result get the same object.
_FIRST_ACCESS = threading.RLock()


class _OnFirstAccess:
    """A :class:`TopologyResult` field that :func:`build_graph` may leave out: on first
    access it is computed again from the map (identical to what build_graph would have
    held) and from then on held like the others."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        value = obj.__dict__[self.name]
        if value is _NOT_KEPT:
            with _FIRST_ACCESS:
                value = obj.__dict__[self.name]
                if value is _NOT_KEPT:
                    value = obj.__dict__[self.name] = _recompute(obj, self.name)
        return value

    def __set__(self, obj, value) -> None:  # the dataclass's __init__ only (frozen)
        obj.__dict__[self.name] = value


@dataclass(frozen=True, eq=False, repr=False)
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
    graph_store : GraphStore or None
        The graph as arrays (:class:`topojax.graph.GraphStore`), when :func:`build_graph`
        made it without pruning: ``graph`` is then built from it on first access.

    Notes
    -----
    A result of :func:`build_graph` holds only the per-pixel fields named in its ``keep``
    (by default ``ridges`` and ``skeleton``) and the graph as arrays.  Any other field is
    computed on first access, from the map and the config, identical to the one
    ``build_graph`` would have held, and is held from then on; the networkx graph is
    built from :attr:`graph_store` on first access.  ``dataclasses.replace`` reads every
    field, so it computes those too.
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

    @property
    def graph_store(self):
        """The graph as arrays (:class:`topojax.graph.GraphStore`), or None."""
        return self.__dict__.get("_graph_store")

    def __repr__(self) -> str:
        held = [n for n in (*RESULT_FIELDS, "graph") if self.__dict__[n] is not _NOT_KEPT]
        shape = getattr(self.map, "shape", None)
        return f"TopologyResult(map shape={shape}, held={held}, timings_s={self.timings_s})"


for _name in (*RESULT_FIELDS, "graph"):
    setattr(TopologyResult, _name, _OnFirstAccess(_name))
del _name


def _recompute(result: TopologyResult, name: str):
    """Field ``name`` of a :func:`build_graph` result that was not kept, computed again."""
    if name == "graph":
        return result.graph_store.to_networkx()
    occupancy, config = result.map, result.config
    if name == "skeleton":
        held = result.__dict__["ridges"]
        ridges = _dense(occupancy, config, "ridges") if held is _NOT_KEPT else held
        return _skeleton_of(occupancy, travel_ridges(ridges, occupancy.occupied), config)
    return _dense(occupancy, config, name)


def _dense(occupancy, config: PipelineConfig, name: str) -> np.ndarray:
    """One field of :func:`dense_fields` of a map, as :func:`build_graph` makes it."""
    if not occupancy.occupied.any():  # no obstacle: H = 0 everywhere, no ridges
        return getattr(_empty_fields(occupancy.shape, (name,)), name)
    fields = dense_fields(
        occupancy.occupied,
        distance=config.distance,
        ridge=config.ridge,
        tile_px=config.tile_px,
        tiles_per_call=config.tiles_per_call,
        outputs=(name,),
    )
    return getattr(fields, name)


def _empty_fields(shape: tuple[int, int], outputs) -> DenseFields:
    """The dense fields of a map without obstacles (those of ``outputs``; ridges always)."""
    return DenseFields(
        np.full(shape, FAR_SQ, np.int32) if "sq_distance_px" in outputs else None,
        np.zeros(shape, np.float32) if "distance" in outputs else None,
        np.zeros(shape, np.uint8) if "lap_abs" in outputs else None,
        np.zeros(shape, bool),
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
    skeleton, _, graph, timings = _cpu_stages(
        ridges,
        clearance_px=clearance_px,
        resolution_m=resolution_m,
        origin=origin,
        pixel_to_world=pixel_to_world,
        config=config,
        source=source,
        free=free,
        lazy=False,
    )
    return skeleton, graph, timings


def _cpu_stages(
    ridges, *, clearance_px, resolution_m, origin, pixel_to_world, config, source, free, lazy
):
    """:func:`graph_from_ridges`, returning ``(skeleton, store, graph, timings_s)``.  With
    ``lazy`` and no pruning the graph is left as its :class:`GraphStore` (graph None, the
    graph attributes in the store's); otherwise it is the networkx graph (store None)."""
    from .graph import prune_graph, skeleton_graph_store

    steps: dict[str, float] = {}
    skeleton = _thinned(ridges, free, config, steps)
    t2 = time.perf_counter()
    store = skeleton_graph_store(
        skeleton,
        clearance_px=clearance_px,
        resolution_m=resolution_m,
        pixel_to_world=pixel_to_world,
        merge_junction_clusters=config.graph.merge_junction_clusters,
    )
    attrs = {"origin": tuple(float(v) for v in origin), "thinning": config.skeleton.thinning}
    if source is not None:
        attrs["source"] = str(source)
    graph = None
    if lazy and not config.graph.prunes:
        store.attrs.update(attrs)
    else:
        graph = store.to_networkx()
        store = None
        if config.graph.prunes:
            graph = prune_graph(
                graph,
                min_clearance_m=config.graph.min_clearance_m,
                min_spur_m=config.graph.min_spur_m,
                min_component_m=config.graph.min_component_m,
            )
        graph.graph.update(attrs)
    t3 = time.perf_counter()
    return skeleton, store, graph, {**steps, "graph": t3 - t2}


def _thinned(ridges: np.ndarray, free, config: PipelineConfig, steps=None) -> np.ndarray:
    """The skeleton of the ridges (of those in ``free`` with ``free_space_only``)."""
    from .skeleton import skeletonize_ridges

    if config.graph.free_space_only:
        free = np.asarray(free) if free is not None else None
        if free is None or free.shape != ridges.shape or free.dtype != bool:
            raise ValueError(
                "free: expected the map's known-free mask (config.graph.free_space_only needs "
                f"it), a bool array of shape {ridges.shape}, received "
                + ("None" if free is None else f"{free.dtype} {free.shape}")
            )
        ridges = ridges & free
    return skeletonize_ridges(
        ridges,
        method=config.skeleton.thinning,
        remove_t=config.skeleton.remove_t,
        timings_s=steps,
    )


def _skeleton_of(occupancy, ridges: np.ndarray, config: PipelineConfig) -> np.ndarray:
    return _thinned(ridges, occupancy.free, config)


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


def build_graph(
    occupancy, *, config: PipelineConfig | None = None, keep=DEFAULT_KEEP
) -> TopologyResult:
    """Build the topology graph of a finished occupancy map (paper §II).

    Parameters
    ----------
    occupancy : OccupancyMap, array or path
        The map.  Arrays are converted with :meth:`OccupancyMap.from_array` (bool: True =
        occupied; uint8 image; int8 occupancy grid); a path (``str`` or
        :class:`os.PathLike`) is read with :func:`topojax.load_map` and its defaults.
    config : PipelineConfig, optional
        All stage settings; default reproduces the paper with Guo–Hall thinning.
    keep : iterable of str or "all", default ``("ridges", "skeleton")``
        The per-pixel fields of :data:`RESULT_FIELDS` (``"distance"``, ``"lap_abs"``,
        ``"ridges"``, ``"skeleton"``, ``"sq_distance_px"``) the result holds from the
        start; ``"all"`` for every one.  Any other is computed on first access,
        identical.  Each costs memory for as long as the result lives: 4 bytes per pixel
        for ``distance`` and ``sq_distance_px``, 1 for the others.

    Returns
    -------
    TopologyResult
        ``.graph`` is a :class:`networkx.MultiGraph`: junctions and dead ends as vertices,
        corridors as edges carrying their pixel paths and world polylines.  A map with no
        obstacle, or with nothing but obstacles, gives an empty skeleton and graph.  A map
        of obstacles and unknown space (no free pixel) keeps the paper's graph, which runs
        through unknown space; ``GraphConfig(free_space_only=True)`` keeps free space only.
        Without pruning, the graph is held as arrays (``.graph_store``) and the networkx
        graph is built on first access of ``.graph``.

    Notes
    -----
    The distance stage keeps the windowed squared distance at the ridge pixels only, which
    is all the graph's clearances read; with the default ``keep`` the call's peak memory
    is a few bytes per map pixel beyond the map (``bench/bench_memory.py``).
    """
    from .maps import OccupancyMap, load_map

    config = instance_or_default("config", config, PipelineConfig)
    keep = _keep_names(keep)
    if isinstance(occupancy, (str, os.PathLike)):
        occupancy = load_map(occupancy)
    elif occupancy is None or isinstance(occupancy, (bytes, bytearray)):
        raise TypeError(
            "occupancy: expected an OccupancyMap, a 2-D array or a map file path (str or "
            f"Path), received {type(occupancy).__name__}"
        )
    elif not isinstance(occupancy, OccupancyMap):
        try:
            occupancy = OccupancyMap.from_array(occupancy)
        except (TypeError, ValueError) as exc:  # its messages name its own argument
            raise type(exc)(f"occupancy (read by OccupancyMap.from_array): {exc}") from None
    check_stage_fits(
        "build_graph",
        "occupancy",
        occupancy.shape,
        BUILD_GRAPH_BYTES_PER_PX,
        "; build it block by block with build_graph_tiled (topojax graph --tiled), which "
        "gives the same graph (docs/large-maps.md)",
    )
    timings: dict[str, float] = {}
    obstacles = occupancy.occupied
    dense_kept = tuple(n for n in ("sq_distance_px", "distance", "lap_abs") if n in keep)

    t0 = time.perf_counter()
    if obstacles.any():
        fields, ridge_sq = ridge_fields(
            obstacles,
            distance=config.distance,
            ridge=config.ridge,
            tile_px=config.tile_px,
            tiles_per_call=config.tiles_per_call,
            outputs=dense_kept,
        )
    else:  # nothing to measure distances from: H = 0 everywhere, no ridges
        fields, ridge_sq = _empty_fields(obstacles.shape, dense_kept), np.zeros(0, np.int32)
    t1 = time.perf_counter()
    timings["distance_ridges"] = t1 - t0
    ridges = fields.ridges
    half_width = config.distance.half_width_px

    def skeleton_clearance(flat: np.ndarray) -> np.ndarray:
        # exact, and only at the skeleton's pixels (a subset of the ridge pixels)
        sq = at_ridge_pixels(ridges, ridge_sq, flat)
        return clearance_of_values(sq, obstacles, half_width, flat)

    skeleton, store, graph, cpu_timings = _cpu_stages(
        travel_ridges(ridges, obstacles),
        clearance_px=skeleton_clearance,
        resolution_m=occupancy.resolution_m,
        origin=occupancy.origin,
        pixel_to_world=occupancy.pixel_to_world,
        config=config,
        source=occupancy.source,
        free=occupancy.free,
        lazy=True,
    )
    timings.update(cpu_timings)
    timings["total"] = time.perf_counter() - t0

    def held(name: str, value):
        return value if name in keep else _NOT_KEPT

    result = TopologyResult(
        map=occupancy,
        distance=held("distance", fields.distance),
        lap_abs=held("lap_abs", fields.lap_abs),
        ridges=held("ridges", ridges),
        skeleton=held("skeleton", skeleton),
        graph=_NOT_KEPT if graph is None else graph,
        config=config,
        timings_s=timings,
        sq_distance_px=held("sq_distance_px", fields.sq_distance_px),
    )
    result.__dict__["_graph_store"] = store
    return result


def _keep_names(keep) -> tuple[str, ...]:
    if isinstance(keep, str):
        if keep == "all":
            return RESULT_FIELDS
        raise ValueError(
            f'keep: expected "all" or an iterable of names from {RESULT_FIELDS}, received {keep!r}'
        )
    return names_subset("keep", keep, RESULT_FIELDS)
