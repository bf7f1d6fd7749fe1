"""The CPU stage of a batch (thinning, T removal, graph, rooms, output files), run in the
executor's workers, and the loading of map files (in a worker or in the calling process);
nothing here runs a JAX kernel."""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._fs import atomic_write_bytes, refuse_folder
from ..config import PipelineConfig
from ..graph.prune import what_emptied
from ..maps import OccupancyMap, load_map
from ..maps.classify import wall_share
from ..maps.files import default_resolution_used, replaced_resolution, said_resolution
from .inputs import (
    _FORMAT_FILES,
    _FORMAT_SUFFIX,
    _PICTURE_SUFFIX,
    _ROUTE_PICTURE_SUFFIX,
    _format_suffixes,
    _Item,
    picture_suffixes,
)
from .manifest import _sha256_file

__all__ = ["InlineExecutor"]

#: Modules the fork server imports once for every worker: the CPU stage and what it runs.
_PRELOAD = (
    "topojax.batch.worker",
    "topojax.pipeline",
    "topojax.graph",
    "topojax.skeleton",
    "topojax.io",
)


@dataclass(frozen=True)
class _MapFrame:
    """Shape, resolution and origin of a map: all that ``pixel_to_world`` reads."""

    shape: tuple[int, int]
    resolution_m: float
    origin: tuple[float, float, float]

    # The very same function as the OccupancyMap method, so world coordinates are
    # bit-identical to build_graph's without shipping the masks.
    pixel_to_world = OccupancyMap.pixel_to_world


@dataclass(frozen=True)
class _CpuJob:
    name: str
    shape: tuple[int, int]
    resolution_m: float
    origin: tuple[float, float, float]
    source: str | None
    ridges_bits: np.ndarray  # uint8, np.packbits of the (H, W) ridge map
    clearance_values: np.ndarray  # float32 (n_ridge,): clearance (px) at the ridge pixels
    config: PipelineConfig
    out_dir: str | None
    formats: tuple[str, ...]
    masks_bits: np.ndarray | None  # packbits of (occupied, free): for the picture, rooms
    keep_graph: bool
    free_bits: np.ndarray | None = None  # packbits of free, only for free_space_only
    plot: bool = False  # write the picture
    rooms: Any = None  # RoomConfig of the rooms format (the room files, rooms on the graph)
    route: Any = None  # RouteGraphConfig of the route formats, else None


@dataclass
class _CpuResult:
    name: str
    vertices: int | None = None
    edges: int | None = None
    total_length_m: float | None = None
    components: int | None = None
    route_vertices: int | None = None
    route_edges: int | None = None
    route_components: int | None = None
    rooms: int | None = None
    doors: int | None = None
    route_note: str = ""  # why the route graph is empty or has no edge, where it is
    nav2_note: str = ""  # the warning of a graph (nav2 format) with vertices and no edge
    no_nav2: list[str] = field(default_factory=list)  # Nav2 files not written: no edge
    pruned: str = ""  # what removed every corridor (graph.prune.what_emptied)
    t_thinning_s: float = 0.0
    t_graph_s: float = 0.0
    t_write_s: float = 0.0
    files: dict[str, dict[str, Any]] = field(default_factory=dict)
    graph: Any = None
    route_graph: Any = None
    error: str | None = None


def _error_text(exc: BaseException) -> str:
    text = str(exc).strip().replace("\n", " ")
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _occupancy(job: _CpuJob) -> OccupancyMap:
    """The map of ``job`` (its occupied and free masks, frame and source)."""
    assert job.masks_bits is not None
    h, w = job.shape
    masks = np.unpackbits(job.masks_bits, count=2 * h * w).reshape(2, h, w).astype(bool)
    return OccupancyMap(
        occupied=masks[0],
        free=masks[1],
        unknown=~(masks[0] | masks[1]),
        resolution_m=job.resolution_m,
        origin=job.origin,
        source=job.source,
    )


def _picture_bytes(
    job: _CpuJob, occupancy: OccupancyMap, skeleton: np.ndarray, graph: Any, rooms: Any
) -> bytes:
    from types import SimpleNamespace

    from ..plotting import result_png

    result = SimpleNamespace(map=occupancy, skeleton=skeleton, graph=graph)
    return result_png(result, title=job.name, rooms=rooms, dpi=110)


def _cpu_stage(job: _CpuJob) -> _CpuResult:
    """Thinning, T removal, graph, summary and output files of one map (worker side)."""
    from ..graph import graph_summary
    from ..io import save_graph, save_room_files
    from ..pipeline import graph_from_ridges
    from ..plotting import route_graph_png

    res = _CpuResult(name=job.name)
    try:
        h, w = job.shape
        ridges = np.unpackbits(job.ridges_bits, count=h * w).reshape(h, w).astype(bool)
        ridge_flat = np.flatnonzero(ridges.ravel())  # the clearance values' pixels

        def clearance(flat: np.ndarray) -> np.ndarray:
            # the skeleton's pixels are ridge pixels
            return job.clearance_values[np.searchsorted(ridge_flat, flat)]

        frame = _MapFrame(job.shape, job.resolution_m, job.origin)
        free = None
        if job.free_bits is not None:
            free = np.unpackbits(job.free_bits, count=h * w).reshape(h, w).astype(bool)
        skeleton, graph, cpu_t = graph_from_ridges(
            ridges,
            clearance_px=clearance,
            resolution_m=job.resolution_m,
            origin=job.origin,
            pixel_to_world=frame.pixel_to_world,
            config=job.config,
            source=job.source,
            free=free,
        )
        res.t_thinning_s = cpu_t["thinning"] + cpu_t["t_removal"]
        t1 = time.perf_counter()
        t0_graph = t1 - cpu_t["graph"]  # the graph step ran just before t1
        summary = graph_summary(graph)
        res.vertices = int(summary["n_vertices"])
        res.edges = int(summary["n_edges"])
        res.components = int(summary["n_components"])
        res.total_length_m = float(summary["total_length_m"])
        if not res.vertices:  # did the map give corridors, all pruned or in unknown space?
            res.pruned = what_emptied(job.config.graph, skeleton, ridges)
        t2 = time.perf_counter()
        res.t_graph_s = t2 - t0_graph

        routes = None  # the route formats write files: only with out_dir
        if job.out_dir is not None:
            out = Path(job.out_dir)
            stem = out / job.name
            stem.parent.mkdir(parents=True, exist_ok=True)
            occupancy = _occupancy(job) if job.masks_bits is not None else None
            rooms = _rooms(occupancy, graph, job.rooms) if job.rooms is not None else None
            if rooms is not None:
                res.rooms, res.doors = rooms.n_rooms, len(rooms.doors)
            routes = _route_graph(job, occupancy, res) if job.route is not None else None
            # files the batch names: a folder there is named as its output, not as a writer's
            for suffix in _format_suffixes(job.formats) + picture_suffixes(job.formats, job.plot):
                refuse_folder(Path(f"{stem}{suffix}"))
            written = []
            for fmt in job.formats:
                if fmt == "rooms":
                    written += save_room_files(rooms, stem)
                elif fmt == "route":
                    written += [save_graph(routes, f"{stem}{s}") for s in _FORMAT_FILES[fmt]]
                elif fmt == "route_nav2":
                    nav2 = Path(f"{stem}{_FORMAT_FILES[fmt][0]}")
                    written += _nav2_file(routes, res.route_edges, nav2)
                    res.no_nav2 += [] if res.route_edges else [nav2.relative_to(out).as_posix()]
                elif fmt == "nav2":
                    nav2 = Path(f"{stem}{_FORMAT_SUFFIX[fmt]}")
                    written += _nav2_file(graph, res.edges, nav2)
                    res.nav2_note = "" if res.edges else _nav2_note(res.vertices)
                    res.no_nav2 += [] if res.edges else [nav2.relative_to(out).as_posix()]
                else:
                    written.append(save_graph(graph, f"{stem}{_FORMAT_SUFFIX[fmt]}", format=fmt))
            if job.plot:
                pic = Path(f"{stem}{_PICTURE_SUFFIX}")
                atomic_write_bytes(pic, _picture_bytes(job, occupancy, skeleton, graph, rooms))
                written.append(pic)
            if job.plot and routes is not None:
                pic = Path(f"{stem}{_ROUTE_PICTURE_SUFFIX}")
                atomic_write_bytes(pic, route_graph_png(routes, occupancy, title=job.name))
                written.append(pic)
            for p in written:
                res.files[Path(p).relative_to(out).as_posix()] = {
                    "bytes": p.stat().st_size,
                    "sha256": _sha256_file(p),
                }
        res.t_write_s = time.perf_counter() - t2
        if job.keep_graph:
            res.graph = graph
            res.route_graph = routes
    except Exception as exc:
        res.error = _error_text(exc)
    return res


def _nav2_file(graph, n_edges: int | None, path: Path) -> list[Path]:
    """Write ``graph``'s Nav2 file to ``path``; a graph without an edge gets none (the
    Route Server needs one), and a file of an earlier run goes.  Returns what was written."""
    from ..io import save_nav2_graph

    if n_edges:
        return [save_nav2_graph(graph, path)]
    path.unlink(missing_ok=True)
    return []


def _nav2_note(vertices: int | None) -> str:
    """The warning of a graph of ``vertices`` vertices and no edge, which gets no Nav2
    file; none where it has no vertex (its emptiness is reported by itself)."""
    if not vertices:
        return ""
    return f"warning: the graph has {vertices} vert{'ex' if vertices == 1 else 'ices'}, no edge"


def no_nav2_note(names: list[str]) -> list[str]:
    """The note of the Nav2 files ``names`` not written (their graph has no edge)."""
    if not names:
        return []
    return [f"no Nav2 file {' or '.join(names)} (the Route Server needs an edge)"]


def _route_graph(job: _CpuJob, occupancy: OccupancyMap | None, res: _CpuResult) -> Any:
    """The route graph of ``occupancy`` for ``job.route``; its counts, and why it is
    empty where it is, go into ``res``."""
    import networkx as nx

    from ..routegraph.build import unwarned_route_graph

    assert occupancy is not None
    routes = unwarned_route_graph(occupancy, config=job.route)  # its note: in the record
    res.route_vertices = routes.number_of_nodes()
    res.route_edges = routes.number_of_edges()
    res.route_components = nx.number_connected_components(routes)
    res.route_note = routes.graph.get("note", "")
    return routes


def _rooms(occupancy: OccupancyMap | None, graph: Any, config: Any) -> Any:
    """The rooms of ``occupancy`` (the :class:`topojax.RoomConfig` ``config``), written
    onto ``graph``."""
    from ..rooms import assign_rooms, segment_rooms

    assert occupancy is not None
    seg = segment_rooms(occupancy, config=config)
    assign_rooms(graph, seg)
    return seg


def _warm_worker() -> int:
    """Import the CPU-stage modules and load their numba kernels (one tiny map)."""
    from ..graph import skeleton_to_graph
    from ..skeleton import skeletonize_ridges

    img = np.zeros((8, 8), bool)
    img[2:6, 3] = True
    img[4, 2:6] = True
    skeleton_to_graph(skeletonize_ridges(img), clearance_px=np.ones((8, 8), np.float32))
    return os.getpid()


def worker_context() -> Any:
    """Start method for the default worker processes.

    ``forkserver`` where available: a fresh, single-threaded server process (never the
    JAX-threaded caller) imports the CPU-stage modules once, and each worker is a cheap
    fork of it, so workers neither pay the imports again nor inherit JAX's threads.
    Elsewhere ``spawn`` (each worker imports everything itself).
    """
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        # the last takes Ctrl-C again (see topojax.batch.preloaded)
        ctx.set_forkserver_preload([*_PRELOAD, "topojax.batch.preloaded"])
        return ctx
    return multiprocessing.get_context("spawn")


class InlineExecutor(cf.Executor):
    """An executor that runs each task at once in the calling thread (``workers=0``)."""

    def submit(self, fn, /, *args, **kwargs):  # noqa: D102 - Executor API
        future: cf.Future = cf.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:
            future.set_exception(exc)
        return future


@dataclass(frozen=True)
class _LoadedBits:
    """A map loaded by a worker process, packed to 1 bit per pixel for the trip back."""

    shape: tuple[int, int]
    resolution_m: float
    origin: tuple[float, float, float]
    source: str | None
    occupied_bits: np.ndarray
    free_bits: np.ndarray | None
    t_load_s: float
    wall_share: float | None = None
    n_free: int | None = None  # free pixels, counted where the mask itself is not kept


def _load_in_worker(path: str, want_free: bool, options: dict | None = None) -> _LoadedBits:
    """Worker side: read and classify a map file (PNG/PGM decoding, YAML, thresholds),
    with the keyword arguments ``options`` of ``load_map``."""
    t0 = time.perf_counter()
    occ = load_map(path, **said_resolution(path, options or {}))
    return _LoadedBits(
        shape=(int(occ.shape[0]), int(occ.shape[1])),
        resolution_m=occ.resolution_m,
        origin=tuple(occ.origin),
        source=occ.source,
        occupied_bits=np.packbits(occ.occupied),
        free_bits=np.packbits(occ.free) if want_free else None,
        t_load_s=time.perf_counter() - t0,
        wall_share=wall_share(occ.occupied, occ.free),
        n_free=int(np.count_nonzero(occ.free)),
    )


@dataclass
class _Loaded:
    """A map ready for the kernel stage (in the calling process)."""

    item: _Item
    occupied: np.ndarray  # bool (H, W)
    free: np.ndarray | None  # bool (H, W); kept for a picture or free_space_only
    resolution_m: float
    origin: tuple[float, float, float]
    source: str | None
    t_load_s: float
    n_tiles: int
    wall_share: float | None = None
    n_free: int | None = None  # free pixels (also where ``free`` is not kept)

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.occupied.shape[0]), int(self.occupied.shape[1]))


def _n_tiles(shape: tuple[int, int], tile_px: int) -> int:
    return -(-shape[0] // tile_px) * -(-shape[1] // tile_px)


def _loaded_from_bits(item: _Item, bits: _LoadedBits, tile_px: int) -> _Loaded:
    h, w = bits.shape
    free = None
    if bits.free_bits is not None:
        free = np.unpackbits(bits.free_bits, count=h * w).reshape(h, w).astype(bool)
    return _Loaded(
        item=item,
        occupied=np.unpackbits(bits.occupied_bits, count=h * w).reshape(h, w).astype(bool),
        free=free,
        resolution_m=bits.resolution_m,
        origin=bits.origin,
        source=bits.source,
        t_load_s=bits.t_load_s,
        n_tiles=_n_tiles(bits.shape, tile_px),
        wall_share=bits.wall_share,
        n_free=bits.n_free,
    )


def _load_here(item: _Item, tile_px: int, want_free: bool, options: dict | None = None) -> _Loaded:
    """Calling-process side: use the given map object, or load the file in this thread
    (with the keyword arguments ``options`` of ``load_map``)."""
    t0 = time.perf_counter()
    occ = item.occupancy
    if occ is None:
        occ = load_map(item.path, **said_resolution(item.path, options or {}))
    return _Loaded(
        item=item,
        occupied=occ.occupied,
        free=occ.free if want_free else None,
        resolution_m=occ.resolution_m,
        origin=tuple(occ.origin),
        source=occ.source,
        t_load_s=time.perf_counter() - t0,
        n_tiles=_n_tiles(occ.shape, tile_px),
        wall_share=wall_share(occ.occupied, occ.free),
        n_free=int(np.count_nonzero(occ.free)),
    )


#: How a map of :func:`resolution_note` gets its resolution (the command line names its
#: option instead).
RESOLUTION_HINT = "a map given as load_map(path, resolution_m=...) sets it"
#: Where a resolution that replaces a map file's own comes from (the command line names
#: its option instead).
GIVEN_RESOLUTION = "map_options' resolution_m"


def resolution_note(path, options: dict | None, resolution_m: float) -> list[str]:
    """The note of a map file read at ``resolution_m`` because it states none and
    ``options`` (``load_map``'s keyword arguments) give none, or because they give one
    that replaces another the file states (every length and area then scales); no note
    otherwise."""
    if path is None:
        return []
    given = (options or {}).get("resolution_m")
    if given is not None:
        own = replaced_resolution(path, given)
        if own is None:
            return []
        return [f"{given:g} m/px from {GIVEN_RESOLUTION}: the file states {own:g}"]
    if not default_resolution_used(path):
        return []
    return [f"{resolution_m:g} m/px assumed: the file states none; {RESOLUTION_HINT}"]
