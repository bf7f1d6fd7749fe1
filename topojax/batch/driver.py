"""The batch driver: :func:`build_graphs` and the calling-process side of a batch
(loading, batched JAX kernels, handing maps to the CPU stage, records, manifests)."""

from __future__ import annotations

import concurrent.futures as cf
import os
import sys
import threading
import time
from collections import Counter, deque
from collections.abc import Iterable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from .._lock import one_writer
from ..config import DistanceConfig, PipelineConfig
from ..maps import OccupancyMap
from ..rooms import RoomConfig
from ..routegraph import RouteGraphConfig
from .arguments import (
    batch_items,
    checked_options,
    map_inputs,
    warn_unlisted_outputs,
    warn_unused_workers,
    workers_for_memory,
)
from .failures import _error_record, _lost_text
from .inputs import _Item
from .interrupts import HeldInterrupts
from .manifest import _drop_outputs, _forget_outputs, _resume_record, _write_manifest
from .outcome import counted_record, noted_record
from .pool import WorkerPool, terminate_workers
from .records import MapRecord, drop_summary, totalled, write_summary
from .worker import (
    InlineExecutor,
    _cpu_stage,
    _CpuJob,
    _CpuResult,
    _error_text,
    _load_here,
    _load_in_worker,
    _Loaded,
    _loaded_from_bits,
    _LoadedBits,
    _warm_worker,
    worker_context,
)

__all__ = ["build_graphs"]

# Kernel buckets (tile_px, tiles_per_call, half_width_px, ksize) already traced in this
# process, and the lock that makes the first call of a bucket run alone.
_COMPILED_BUCKETS: set[tuple[int, ...]] = set()
_COMPILE_LOCK = threading.Lock()
# Times an own process pool that broke (its worker processes kept dying) is replaced.
_POOL_RESTARTS = 3


def _ridge_clearance(
    ridges: np.ndarray, ridge_sq: np.ndarray, obstacles: np.ndarray, half_width_px: int
) -> np.ndarray:
    """Exact clearance (px, float32) at the ridge pixels, in raster order, from the
    windowed squared distance there (as :func:`topojax.build_graph` computes it)."""
    from ..fields import clearance_of_values

    return clearance_of_values(ridge_sq, obstacles, half_width_px, np.flatnonzero(ridges))


class _BatchRun:
    def __init__(
        self,
        items: list[_Item],
        *,
        executor: cf.Executor | None,
        workers: int,
        workers_given: bool = True,
        config: PipelineConfig,
        out_dir: Path | None,
        formats: tuple[str, ...],
        plot: bool,
        keep_graphs: bool,
        tiles_per_call: int,
        kernel_threads: int,
        batch_tiles: int,
        progress: bool,
        resume: bool,
        request: dict[str, Any],
        fingerprints: dict[int, dict[str, Any] | None],
        map_options: dict[str, Any] | None = None,
        sigma_m: float | None = None,
        route_config: RouteGraphConfig | None = None,
        room_config: RoomConfig | None = None,
    ) -> None:
        self.items = items
        self.map_options = map_options  # load_map's keyword arguments
        self.sigma_m = sigma_m
        self._configs: dict[float, PipelineConfig] = {}
        self.executor = executor
        self.owns_executor = executor is None
        self.workers = workers
        self.workers_given = workers_given
        self.config = config
        self.out_dir = out_dir
        self.formats = formats
        self.plot = plot
        self.keep_graphs = keep_graphs
        self.tiles_per_call = tiles_per_call
        self.kernel_threads = kernel_threads
        self.batch_tiles = batch_tiles
        self.progress = progress
        self.resume = resume
        self.request = request
        self.fingerprints = fingerprints
        self.prefetch = max(8, 4 * kernel_threads)
        # CPU jobs queued at most: small for the own pool, whose FIFO also carries the map
        # reads the kernels wait for; an outside executor's size is unknown.
        self.cpu_backlog = max(4, 3 * workers) if executor is None else 64
        self._restarts = 0
        self._started = False  # a worker task has run (see _note_started)
        self._pool_size = workers  # no more processes than maps to run (set by run())
        self._retried: set[int] = set()  # maps whose task a broken pool lost once
        # the rooms format segments each map in its CPU stage, which rebuilds the map (as
        # it does for the picture; a RoomConfig, else None)
        self._rooms = room_config if out_dir is not None else None
        # so does a route format, for the route graph (a RouteGraphConfig, else None)
        self._route = route_config if out_dir is not None else None
        self._needs_map = out_dir is not None and (plot or bool(self._rooms or self._route))

    # ---------------------------------------------------------------- executor handling
    def _new_executor(self) -> cf.Executor:
        if self.workers == 0:
            return InlineExecutor()
        # each process holds a few hundred MB: a count the memory cannot hold is refused
        # when the user asked for it before any map runs, and trimmed otherwise
        first = self.executor is None  # a replacement is made while the broken one is set
        asked = self.workers if self.workers_given and first else None
        self._pool_size = workers_for_memory(self._pool_size, asked=asked)
        ex = WorkerPool(self._pool_size, mp_context=worker_context())
        try:
            for _ in range(self._pool_size):  # import + numba cache load while kernels compile
                ex.submit(_warm_worker).add_done_callback(self._note_started)
        except BaseException:  # Ctrl-C: a pool no one holds would live on in a notebook
            terminate_workers(ex)
            raise
        return ex

    def _note_started(self, fut: cf.Future) -> None:
        """A worker task ended: one that ran means the processes can start (a pool that
        breaks later lost a process, e.g. killed for memory)."""
        if not fut.cancelled() and fut.exception() is None:
            self._started = True

    def _lost(self, exc: BaseException) -> str:
        """:func:`_lost_text` of ``exc``, for this batch's pool."""
        return _lost_text(exc, started=self._started or not self.owns_executor)

    def _submit(self, fn: Any, *args: Any) -> cf.Future:
        """Submit to the executor; an own process pool that broke is replaced (3 times in
        a row, with no task done in between), then RuntimeError: the maps left become
        error rows, not an end of the batch."""
        if self.executor is None:
            self.executor = self._new_executor()
        try:
            if isinstance(self.executor, InlineExecutor):  # the task runs here and now
                with self._held.at_once():
                    return self.executor.submit(fn, *args)
            return self.executor.submit(fn, *args)
        except cf.BrokenExecutor as exc:
            if not self.owns_executor:
                raise
            if self._restarts >= _POOL_RESTARTS:
                raise RuntimeError(
                    f"workers: a worker process died or could not start, and broke the pool "
                    f"{self._restarts + 1} times in a row (the last time: {exc}); no new "
                    "pool is started for the maps left (resume=True runs them again; fewer "
                    "workers need less memory)"
                ) from exc
            self._restarts += 1
            terminate_workers(self.executor)  # its live workers hold memory too
            self.executor.shutdown(wait=False, cancel_futures=True)
            self.executor = self._new_executor()
            return self.executor.submit(fn, *args)

    # ---------------------------------------------------------------- kernel stage
    def _config_for(self, g: _Loaded) -> PipelineConfig:
        """The settings of map ``g``: ``config``, with the Gaussian of ``sigma_m`` metres
        at the map's resolution when that is given."""
        if self.sigma_m is None:
            return self.config
        cfg = self._configs.get(g.resolution_m)
        if cfg is None:
            distance = DistanceConfig.from_metres(sigma_m=self.sigma_m, resolution_m=g.resolution_m)
            cfg = self._configs[g.resolution_m] = replace(self.config, distance=distance)
        return cfg

    def _dense_fields(self, group: list[_Loaded]) -> tuple[list[Any], float]:
        """``ridge_fields_many`` over the maps of a group (one distance setting): per map
        the ridges and the squared distance at the ridge pixels; (those, wall seconds)."""
        from ..fields import ridge_fields_many

        cfg = self._config_for(group[0])

        def call() -> list[Any]:
            return ridge_fields_many(
                [g.occupied for g in group],
                distance=cfg.distance,
                ridge=cfg.ridge,
                tile_px=cfg.tile_px,
                tiles_per_call=self.tiles_per_call,
            )

        t0 = time.perf_counter()
        if self._compiled(cfg):
            out = call()
        else:
            with _COMPILE_LOCK:  # the first call of a bucket traces it, alone
                out = call()
                _COMPILED_BUCKETS.add(self._bucket(cfg))
        return out, time.perf_counter() - t0

    def _bucket(self, cfg: PipelineConfig) -> tuple[int, ...]:
        return (cfg.tile_px, self.tiles_per_call, cfg.distance.half_width_px, cfg.ridge.ksize)

    def _compiled(self, cfg: PipelineConfig) -> bool:
        return self._bucket(cfg) in _COMPILED_BUCKETS

    def _kernels(self, group: list[_Loaded]) -> list[tuple[_Loaded, _CpuJob | None, float, str]]:
        """Run the JAX stage for a group of maps and build their CPU jobs.

        Returns ``(loaded map, job or None, t_distance_s, error message)`` per map.  If the
        group's kernel call fails, each map is retried alone, so one bad map cannot fail
        the others of its group.
        """
        from ..pipeline import travel_ridges

        with_obstacles = [g for g in group if g.occupied.any()]
        empty = {id(g) for g in group} - {id(g) for g in with_obstacles}
        fields: dict[int, tuple[Any, float]] = {}
        errors: dict[int, str] = {}
        if with_obstacles:
            try:
                out, wall = self._dense_fields(with_obstacles)
                tiles = sum(g.n_tiles for g in with_obstacles)
                for g, f in zip(with_obstacles, out, strict=True):
                    fields[id(g)] = (f, wall * g.n_tiles / tiles)
            except Exception as exc:
                if len(with_obstacles) == 1:
                    errors[id(with_obstacles[0])] = _error_text(exc)
                for g in with_obstacles if len(with_obstacles) > 1 else []:
                    try:
                        (f,), wall = self._dense_fields([g])
                        fields[id(g)] = (f, wall)
                    except Exception as exc_one:
                        errors[id(g)] = _error_text(exc_one)
        jobs: list[tuple[_Loaded, _CpuJob | None, float, str]] = []
        for g in group:
            cfg = self._config_for(g)
            if id(g) in errors:
                jobs.append((g, None, 0.0, errors[id(g)]))
                continue
            t0 = time.perf_counter()
            occ = g
            if id(g) in empty:  # no obstacle: H = 0, no ridges (as build_graph)
                share = 0.0
                ridges, ridge_sq = np.zeros(occ.shape, bool), np.zeros(0, np.int32)
            else:
                (f, ridge_sq), share = fields[id(g)]
                ridges = f.ridges
            # as build_graph: nothing to thin on a map that is all obstacle
            ridges = travel_ridges(ridges, occ.occupied)
            if not ridges.any():
                ridge_sq = np.zeros(0, np.int32)
            # Skeleton pixels are a subset of the ridge pixels, so the clearances of the
            # ridge pixels (computed exactly as build_graph does) are all the graph reads.
            clearance = _ridge_clearance(ridges, ridge_sq, occ.occupied, cfg.distance.half_width_px)
            masks = None
            if self._needs_map:
                masks = np.packbits(np.stack([occ.occupied, occ.free]))
            job = _CpuJob(
                name=g.item.name,
                shape=tuple(occ.shape),
                resolution_m=occ.resolution_m,
                origin=tuple(occ.origin),
                source=occ.source,
                ridges_bits=np.packbits(ridges),
                clearance_values=clearance,
                config=cfg,
                # absolute: a worker (on a Dask cluster, say) may run in another folder
                out_dir=None if self.out_dir is None else os.path.abspath(self.out_dir),
                formats=self.formats,
                masks_bits=masks,
                keep_graph=self.keep_graphs,
                free_bits=np.packbits(occ.free) if cfg.graph.free_space_only else None,
                plot=self.plot and self.out_dir is not None,
                rooms=self._rooms,
                route=self._route,
            )
            jobs.append((g, job, share + time.perf_counter() - t0, ""))
        return jobs

    def _take_group(self, ready: deque[_Loaded], limit: int) -> list[_Loaded]:
        """The next maps in order, up to ``limit`` tiles (at least one map), all with the
        first one's distance setting (one kernel call serves one setting)."""
        group = [ready.popleft()]
        tiles = group[0].n_tiles
        distance = self._config_for(group[0]).distance
        while (
            ready
            and tiles + ready[0].n_tiles <= limit
            and self._config_for(ready[0]).distance == distance
        ):
            tiles += ready[0].n_tiles
            group.append(ready.popleft())
        return group

    # ---------------------------------------------------------------- manifests
    def _resume_record(self, item: _Item) -> MapRecord | None:
        """The recorded result of ``item`` if its outputs are complete and valid."""
        return _resume_record(
            item,
            out_dir=self.out_dir,
            fingerprint=self.fingerprints.get(item.index),
            request=self.request,
            formats=self.formats,
            plot=self.plot,
        )

    def _write_manifest(self, item: _Item, rec: MapRecord, files: dict[str, Any]) -> str:
        assert self.out_dir is not None
        return _write_manifest(
            item,
            rec,
            files,
            out_dir=self.out_dir,
            fingerprint=self.fingerprints.get(item.index),
            request=self.request,
        )

    def _forget_outputs(self, item: _Item) -> None:
        """Before redoing a map: drop its manifest, outputs it will not write again and
        stale temporary files."""
        _forget_outputs(item, out_dir=self.out_dir, formats=self.formats, plot=self.plot)

    # ---------------------------------------------------------------- main loop
    def run(self) -> list[MapRecord]:
        """Run every map through loading, kernels and the CPU stage; one record per map,
        in input order."""
        from tqdm.auto import tqdm

        self._records: dict[int, MapRecord] = {}
        self._counts: Counter[str] = Counter()
        self._classes: dict[int, tuple[int, int | None]] = {}  # occupied, free pixels
        self._walls: dict[int, float | None] = {}  # wall share (maps.classify.wall_share)
        self._bar = tqdm(
            total=len(self.items),
            unit="map",
            desc="topojax batch",
            disable=not self.progress,
            file=sys.stderr,
            dynamic_ncols=True,
        )
        self._pending: deque[_Item] = deque()
        for item in self.items:
            rec = self._resume_record(item) if self.resume else None
            if rec is not None:
                self._finish(item.index, rec)
            else:
                self._pending.append(item)
        # each process costs a few hundred MB: none for a map that is not there
        self._pool_size = max(1, min(self.workers, len(self._pending)))

        # the free mask: for the picture and the rooms, and for free_space_only's thinning
        self._want_free = self._needs_map or self.config.graph.free_space_only
        # Map files are read by our own worker processes (same file system, and it keeps
        # decoding off this process's GIL); with a given executor (a cluster may not see
        # the files) or workers=0 they are read by threads here.
        self._load_in_workers = self.owns_executor and self.workers > 0
        self._load_pool = cf.ThreadPoolExecutor(2, thread_name_prefix="topojax-load")
        self._kernel_pool = cf.ThreadPoolExecutor(
            self.kernel_threads, thread_name_prefix="topojax-jax"
        )
        self._loads: dict[cf.Future, _Item] = {}
        self._in_kernels: dict[cf.Future, list[_Loaded]] = {}
        self._cpu: dict[cf.Future, tuple[_Item, MapRecord, _CpuJob]] = {}
        self._ready: deque[_Loaded] = deque()
        stopped = False
        self._held = HeldInterrupts()  # Ctrl-C, SIGTERM: taken between steps
        try:
            with self._held:
                if self._pending and self.executor is None:
                    self.executor = self._new_executor()
                while waiting := self._start_work():
                    for fut in self._held.wait(waiting):
                        if fut in self._loads:
                            self._on_loaded(fut)
                        elif fut in self._in_kernels:
                            self._on_kernels_done(fut)
                        else:
                            self._on_cpu_done(fut)
        except BaseException:  # Ctrl-C, SIGTERM: results no manifest would record
            stopped = True
            raise
        finally:
            self._close(stopped)
        return [self._records[item.index] for item in self.items]

    def _close(self, stopped: bool) -> None:
        """Shut the pools down; a ``stopped`` batch's own processes are terminated and
        the files of the maps they were running removed (temporary or whole).  A Ctrl-C
        or SIGTERM meanwhile waits until that is done: raised part way it left those
        files behind (for a stopped batch it is the same stop, and not raised again)."""
        try:
            with HeldInterrupts():
                if stopped and self.owns_executor:
                    terminate_workers(self.executor)
                self._bar.close()
                self._load_pool.shutdown(wait=True, cancel_futures=True)
                self._kernel_pool.shutdown(wait=True, cancel_futures=True)
                if self.owns_executor and self.executor is not None:
                    self.executor.shutdown(wait=True, cancel_futures=True)
                if stopped and self.owns_executor:
                    # (a given executor's tasks may still be writing theirs); the files a
                    # map wrote whole go too, as a failed map's: no manifest vouches for them
                    for item, _, _ in self._cpu.values():
                        self._forget_outputs(item)
                        if self.out_dir is not None:
                            _drop_outputs(
                                item, out_dir=self.out_dir, formats=self.formats, plot=self.plot
                            )
        except KeyboardInterrupt:
            if not stopped:
                raise

    def _finish(self, index: int, rec: MapRecord) -> None:
        """Record the final ``rec`` of map ``index`` and advance the progress bar; a map
        that failed loses the manifest and files of an earlier run (their input or
        settings are not this run's) and the files it wrote before it failed."""
        self._records[index] = rec = totalled(rec)
        if rec.status == "error" and self.out_dir is not None:
            item = self.items[index]
            _forget_outputs(item, out_dir=self.out_dir, formats=(), plot=False)
            _drop_outputs(item, out_dir=self.out_dir, formats=self.formats, plot=self.plot)
        counts = self._counts
        counts[rec.status] += 1
        self._bar.update(1)
        self._bar.set_postfix(
            {k: counts[k] for k in ("ok", "empty", "skipped", "error") if counts[k]}
        )

    def _start_work(self) -> list[cf.Future]:
        """Start the loads and kernels that may start; the futures of all work under way."""
        self._start_loads()
        self._start_kernels()
        return [*self._loads, *self._in_kernels, *self._cpu]

    def _start_loads(self) -> None:
        """Start loading pending maps until ``prefetch`` are loading or loaded."""
        tile_px = self.config.tile_px
        while self._pending and len(self._loads) + len(self._ready) < self.prefetch:
            item = self._pending.popleft()
            if item.occupancy is not None:  # nothing to load
                loaded = _load_here(item, tile_px, self._want_free)
                try:
                    self._config_for(loaded)  # e.g. a sigma_m too large here
                except ValueError as exc:
                    self._finish(item.index, self._base_record(loaded, "error", _error_text(exc)))
                    continue
                self._ready.append(loaded)
            elif self._load_in_workers:
                try:
                    fut = self._submit(
                        _load_in_worker, os.fspath(item.path), self._want_free, self.map_options
                    )
                except Exception as exc:  # the pool broke once too often
                    self._finish(item.index, _error_record(item, self._lost(exc)))
                    continue
                self._loads[fut] = item
            else:
                fut = self._load_pool.submit(
                    _load_here, item, tile_px, self._want_free, self.map_options
                )
                self._loads[fut] = item

    def _start_kernels(self) -> None:
        """Send groups of loaded maps to the kernel threads while threads and CPU backlog
        allow."""
        ready = self._ready
        while (
            ready
            and len(self._in_kernels) < self.kernel_threads
            and len(self._cpu) < self.cpu_backlog
        ):
            # Until the kernel is compiled, send one map at a time: the first call
            # (tracing + XLA compilation) runs alone, and a small first group lets
            # the pipeline fill as soon as it is done.
            limit = self.batch_tiles if self._compiled(self._config_for(ready[0])) else 0
            group = self._take_group(ready, limit)
            self._in_kernels[self._kernel_pool.submit(self._kernels, group)] = group

    def _on_loaded(self, fut: cf.Future) -> None:
        """A map finished loading: queue it for the kernels, or record its error."""
        item = self._loads.pop(fut)
        if self._retry(item, fut):
            self._pending.appendleft(item)
            return
        try:
            loaded = fut.result()
            if isinstance(loaded, _LoadedBits):
                loaded = _loaded_from_bits(item, loaded, self.config.tile_px)
            self._config_for(loaded)  # e.g. a sigma_m too large here
            self._ready.append(loaded)
        except Exception as exc:
            self._finish(item.index, _error_record(item, self._lost(exc)))

    def _on_kernels_done(self, fut: cf.Future) -> None:
        """A group's kernels finished: submit each map's CPU job, or record its error."""
        group = self._in_kernels.pop(fut)
        try:
            jobs = fut.result()
        except Exception as exc:
            for g in group:
                self._finish(g.item.index, self._base_record(g, "error", _error_text(exc)))
            return
        for g, job, t_distance, error in jobs:
            rec = replace(
                self._base_record(g, "error" if error else "ok", error), t_distance_s=t_distance
            )
            self._classes[g.item.index] = _class_counts(g)
            self._walls[g.item.index] = g.wall_share
            if job is None:
                self._finish(g.item.index, rec)
                continue
            try:
                self._forget_outputs(g.item)  # its outputs are about to change
                self._cpu[self._submit(_cpu_stage, job)] = (g.item, rec, job)
            except Exception as exc:
                self._finish(g.item.index, replace(rec, status="error", message=_error_text(exc)))

    def _on_cpu_done(self, fut: cf.Future) -> None:
        """A map's CPU stage ended: record it, or run it again on a new pool."""
        # left in place until recorded: a Ctrl-C its future holds (the stage ran here,
        # workers=0) stops the batch with the map still in flight, so its files go
        item, rec, job = self._cpu[fut]
        if self._retry(item, fut):
            del self._cpu[fut]
            try:
                self._cpu[self._submit(_cpu_stage, job)] = (item, rec, job)
                return
            except Exception as exc:
                rec = replace(rec, status="error", message=_error_text(exc))
                self._finish(item.index, rec)
                return
        rec = self._complete(item, rec, fut)
        del self._cpu[fut]
        self._finish(item.index, rec)

    def _retry(self, item: _Item, fut: cf.Future) -> bool:
        """Whether ``item``'s task, lost when a process of the own pool died (e.g. killed
        for memory) while it ran the task, or when the pool broke, runs once more."""
        if not self.owns_executor:
            return False
        if not fut.cancelled() and fut.exception() is None:
            # a worker ran a task: only breaks with no task done in between add up to
            # the pool's last replacement, not those of a long batch
            self._restarts = 0
            self._started = True
            return False
        # a lost task fails with WorkerDied (a BrokenExecutor), or is cancelled when the
        # pool is shut down before it could fail it
        if not (fut.cancelled() or isinstance(fut.exception(), cf.BrokenExecutor)):
            return False
        if item.index in self._retried:
            return False
        self._retried.add(item.index)
        return True

    def _base_record(self, g: _Loaded, status: str, message: str) -> MapRecord:
        return MapRecord(
            map=g.item.name,
            path=g.item.label,
            height=int(g.shape[0]),
            width=int(g.shape[1]),
            resolution_m=float(g.resolution_m),
            t_load_s=g.t_load_s,
            status=status,
            message=message,
        )

    def _complete(self, item: _Item, rec: MapRecord, fut: cf.Future) -> MapRecord:
        try:
            res: _CpuResult = fut.result()
        except Exception as exc:  # the worker died or the task could not be run
            return replace(rec, status="error", message=f"CPU stage failed: {self._lost(exc)}")
        rec = counted_record(rec, res)
        if res.error is not None:
            return replace(rec, status="error", message=res.error)
        rec = noted_record(
            rec,
            res,
            path=item.path,
            classes=self._classes.pop(item.index, (None, None)),
            wall=self._walls.pop(item.index, None),
            formats=self.formats,
            written=self.out_dir is not None,
            map_options=self.map_options,
        )
        if self.out_dir is not None:
            rec = totalled(rec)
            try:
                manifest = self._write_manifest(item, rec, res.files)
            except Exception as exc:
                return replace(rec, status="error", message=f"manifest: {_error_text(exc)}")
            rec = replace(rec, outputs=(*rec.outputs, manifest))
        return rec


def _class_counts(g) -> tuple[int, int | None]:
    """Occupied and free pixels of a loaded map (free counted as it was loaded)."""
    return int(g.occupied.sum()), g.n_free


def build_graphs(
    maps: Iterable[str | os.PathLike[str] | OccupancyMap] | str | os.PathLike[str] | OccupancyMap,
    *,
    executor: Any = None,
    workers: int | None = None,
    config: PipelineConfig | None = None,
    out_dir: str | os.PathLike[str] | None = None,
    formats: Sequence[str] | str = ("graphml", "json", "geojson"),
    plot: bool = False,
    resume: bool = False,
    progress: bool = True,
    tiles_per_call: int | None = None,
    kernel_threads: int | None = None,
    batch_tiles: int | None = None,
    keep_graphs: bool | None = None,
    map_mode: str | None = None,
    sigma_m: float | None = None,
    route_config: RouteGraphConfig | None = None,
    room_config: RoomConfig | None = None,
) -> list[MapRecord]:
    """Build the topology graphs of many maps (design: docs/batch-internals.md).

    Parameters
    ----------
    maps : iterable of (str, path or OccupancyMap)
        Map files :func:`topojax.load_map` reads (expand globs and folders first, e.g.
        with :func:`expand_map_inputs`) and/or loaded maps; or a single path or map.
    executor : concurrent.futures.Executor or dask.distributed.Client, optional
        Runs the CPU stages (thinning, T removal, graph, output files).  Default: a pool
        of ``workers`` processes (``forkserver`` start method where available, else
        ``spawn``), each with its own pipe, which also reads the map files, shut down at
        the end; a process that dies (killed for memory, say) loses only the map it ran.
        A Dask ``Client`` is used through ``client.get_executor(pure=False)``.  A given
        executor is not shut down, and map files are then read in the calling process.
    workers : int, optional
        Worker processes of the default executor, at most one per map to run; default
        the CPUs this process may run on (its affinity, which ``taskset``, a container or
        a job scheduler narrows), as many as the memory available holds (a larger count
        given is refused; ``docs/batch-and-dask.md``).  ``0`` runs the CPU stage in the
        calling thread (:class:`InlineExecutor`).  Unused (warned of) with ``executor``.
    config : PipelineConfig, optional
        Stage settings, as for :func:`topojax.build_graph`.
    out_dir : str or path, optional
        Output folder (created; locked while the batch runs: a second batch or replay into
        it is refused, BlockingIOError; a file there of a map's output name that no manifest
        lists is replaced, warned of by name); without it nothing is written.
    formats : sequence of str, or a comma-separated str
        Files per map, from ``graphml``, ``json``, ``geojson``, ``nav2`` (the graph for
        the Nav2 Route Server), ``rooms`` (:func:`topojax.segment_rooms` with
        ``room_config``; the graph files then carry the rooms), ``route`` and
        ``route_nav2`` (the route graph of ``route_config``, as graph files and for
        Nav2); these three need ``out_dir``.  A map without a room, or whose route graph
        is empty, gets ``status="empty"``.  File names: ``docs/batch-and-dask.md``.
    plot : bool
        Also write ``<name>_graph.png`` (map, skeleton and graph; needs ``out_dir``).
    resume : bool
        Skip maps whose manifest shows complete, valid outputs for the same input and
        settings (needs ``out_dir``).
    progress : bool
        Show a tqdm progress bar (maps, rate, ETA) on stderr.
    tiles_per_call : int, optional
        Tiles per kernel call (the bucket size; one compiled kernel per value).  Default
        ``max(config.tiles_per_call, 16)``; larger values may suit GPUs.
    kernel_threads : int, optional
        Threads dispatching kernel calls concurrently.  Default: the CPUs this process
        may run on (at most 8) on the CPU backend, 2 on an accelerator.
    batch_tiles : int, optional
        Most tiles per group of maps sent to the kernels together (a larger map forms
        a group of its own).  Default ``16 * tiles_per_call``.
    keep_graphs : bool, optional
        Return each graph in ``MapRecord.graph`` (and ``.route_graph``); default: only
        without ``out_dir``.  A map skipped by ``resume`` holds none (:func:`topojax.load_graph`).
    map_mode : {"trinary", "scale", "raw", "ipa"}, optional
        Pixel convention for every map file, as ``mode`` of :func:`topojax.load_map`
        (``"ipa"`` for the IPA benchmark maps: every pixel below 250 inaccessible).
        Default: each file's own (its YAML's, else trinary); maps given as
        :class:`OccupancyMap` objects are already classified.
    sigma_m : float, optional
        The distance map's Gaussian σ in metres for every map, converted with each map's
        own resolution (:meth:`DistanceConfig.from_metres`), in place of
        ``config.distance`` (default: the paper's 64.19 px for every map).
    route_config : RouteGraphConfig, optional
        Options of the route graph of the ``route`` formats (default: its defaults, a
        robot radius of 0.3 m).
    room_config : RoomConfig, optional
        Options of the ``rooms`` format's segmentation (default: its defaults; refused
        without that format).

    Returns
    -------
    list of MapRecord
        One per input, in input order; with ``out_dir``, also ``out_dir/summary.csv`` (and
        ``.parquet`` with pyarrow), replacing an earlier run's (manifests keep each row).

    Raises
    ------
    TypeError, ValueError
        For invalid arguments (a bad map never raises; it becomes an error record).
    """
    items_raw, sources = map_inputs(maps)
    options = checked_options(
        executor=executor,
        workers=workers,
        config=config,
        formats=formats,
        flags={"plot": plot, "resume": resume, "progress": progress, "keep_graphs": keep_graphs},
        out_dir=out_dir,
        tiles_per_call=tiles_per_call,
        kernel_threads=kernel_threads,
        batch_tiles=batch_tiles,
        map_mode=map_mode,
        sigma_m=sigma_m,
        route_config=route_config,
        room_config=room_config,
    )
    warn_unused_workers(executor, workers)
    if out_dir is None:
        return run_batch(items_raw, sources, None, options)
    with one_writer(out_dir, name="out_dir", command="batch") as out:  # one run per folder
        return run_batch(items_raw, sources, out, options)


def run_batch(
    items_raw: list[tuple[Path | None, OccupancyMap | None]],
    sources: list[Path | None],
    out: Path | None,
    options: dict[str, Any],
    *,
    out_name: str = "out_dir",
) -> list[MapRecord]:
    """Run :func:`build_graphs` on its checked inputs (:func:`map_inputs`) and options
    (:func:`checked_options`, whose ``map_options`` ``topojax batch`` gives too); with an
    output folder ``out`` (``out_name``: as its warnings name it), this run's summary
    table replaces the one there."""
    formats, plot = options["formats"], options["plot"]
    items, fingerprints = batch_items(items_raw, sources, out=out, formats=formats, plot=plot)
    if out is not None:
        warn_unlisted_outputs(items, out, formats, plot, name=out_name)
    runner = _BatchRun(items, out_dir=out, fingerprints=fingerprints, **options)
    if out is not None:
        drop_summary(out)
    records = runner.run()
    if out is not None:
        write_summary(records, out)
    return records
