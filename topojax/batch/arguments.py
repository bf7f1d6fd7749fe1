"""The arguments of :func:`~topojax.batch.build_graphs`: checks, defaults, the batch's
items and the settings its manifests record."""

from __future__ import annotations

import dataclasses
import os
import warnings
from pathlib import Path
from typing import Any

from .._caller import outside_stacklevel
from .._cpus import as_executor, available_memory_bytes, usable_cpus
from .._fs import refuse_overwriting_inputs
from .._validate import (
    flag,
    instance_or_default,
    int_at_least,
    kernel_tiles_per_call,
    one_of,
    path_like,
    positive_metres,
)
from ..config import PipelineConfig
from ..maps import MODES, OccupancyMap
from ..routegraph import RouteGraphConfig
from .inputs import (
    _MANIFEST_SUFFIX,
    ROUTE_FORMATS,
    _assign_names,
    _format_suffixes,
    _Item,
    batch_input,
    check_formats,
    picture_suffixes,
)
from .manifest import _fingerprint, _normalise

#: Default kernel bucket of a batch: several tiles per call mean fewer dispatches (empty
#: padding tiles are nearly free).
DEFAULT_TILES_PER_CALL = 16

#: Memory a batch's worker process holds before its first map (the interpreter, the
#: imported modules, numba's and OpenCV's runtimes; docs/performance.md), a lower bound.
WORKER_MEMORY_BYTES = 300 * 2**20


def workers_for_memory(wanted: int, *, asked: int | None) -> int:
    """How many of ``wanted`` (>= 1) worker processes to start: all of them where the
    memory available (:func:`~topojax._cpus.available_memory_bytes`) holds
    :data:`WORKER_MEMORY_BYTES` for each or cannot be read; else as many as it holds (at
    least one), or, where the user ``asked`` for a count (``workers``; None for the
    default), ValueError naming ``workers``."""
    free = available_memory_bytes()
    if free is None:
        return wanted
    fits = max(1, free // WORKER_MEMORY_BYTES)  # one worker whatever the memory
    if fits >= wanted:
        return wanted
    if asked is None:
        return fits
    raise ValueError(
        f"workers: expected at most {fits} worker processes for the "
        f"{free / 2**30:.1f} GiB of memory available (each holds about "
        f"{WORKER_MEMORY_BYTES // 2**20} MiB before its first map), received {asked} "
        f"({wanted} for the maps to run); use fewer workers, or 0 to run the maps in "
        "this process"
    )


def checked_options(
    *,
    executor: Any,
    workers: int | None,
    config: PipelineConfig | None,
    formats: Any,
    flags: dict[str, Any],
    out_dir: Any,
    tiles_per_call: int | None,
    kernel_threads: int | None,
    batch_tiles: int | None,
    map_mode: Any,
    sigma_m: Any,
    route_config: Any = None,
    map_options: dict[str, Any] | None = None,
    room_config: Any = None,
) -> dict[str, Any]:
    """Check the options of :func:`build_graphs` and fill in their defaults.

    ``flags`` holds ``plot``, ``resume``, ``progress`` and ``keep_graphs`` (bool;
    ``keep_graphs`` may be None); ``map_options`` are more keyword arguments of
    :func:`~topojax.load_map` for every map file (``resolution_m``, ``occupied_thresh``,
    ``free_thresh``, ``negate``; checked by ``load_map``), as ``topojax batch`` gives
    them.  Returns the keyword arguments of the batch run other than its items, output
    folder and fingerprints: ``config``, ``formats``, ``executor``, ``workers``, the
    flags as bools, the kernel settings, ``map_options`` (those and ``map_mode`` as
    ``mode``), ``sigma_m``, ``route_config`` (None without a route format),
    ``room_config`` (None without the rooms format) and the ``request`` its manifests
    record.  Raises TypeError or ValueError naming the
    argument.
    """
    config = instance_or_default("config", config, PipelineConfig)
    fmts = check_formats(formats)
    route_config = route_options(route_config, fmts, out_dir)
    room_config = room_options(room_config, fmts, out_dir)
    sigma_m = check_options(map_mode=map_mode, flags=flags, sigma_m=sigma_m, out_dir=out_dir)
    tpc, threads, group_tiles = kernel_settings(config, tiles_per_call, kernel_threads, batch_tiles)
    keep_graphs = flags["keep_graphs"]
    keep = out_dir is None if keep_graphs is None else bool(keep_graphs)
    executor = as_executor(executor)
    n_workers = usable_cpus() if workers is None else workers
    n_workers = int_at_least("workers", n_workers, 0)
    return {
        "executor": executor,
        "workers": n_workers,
        "workers_given": workers is not None,
        "config": config,
        "formats": fmts,
        "plot": bool(flags["plot"]),
        "keep_graphs": keep,
        "tiles_per_call": tpc,
        "kernel_threads": threads,
        "batch_tiles": group_tiles,
        "progress": bool(flags["progress"]),
        "resume": bool(flags["resume"]),
        "map_options": {**(map_options or {}), **({"mode": map_mode} if map_mode else {})},
        "sigma_m": sigma_m,
        "route_config": route_config,
        "room_config": room_config,
        "request": request_settings(
            config,
            fmts,
            plot=flags["plot"],
            map_mode=map_mode,
            sigma_m=sigma_m,
            route_config=route_config,
            room_config=room_config,
            map_options=map_options,
        ),
    }


def batch_items(
    items_raw: list[tuple[Path | None, OccupancyMap | None]],
    sources: list[Path | None],
    *,
    out: Path | None,
    formats: tuple[str, ...],
    plot: bool,
) -> tuple[list[_Item], dict[int, dict[str, Any] | None]]:
    """The named items of a batch and their input fingerprints.

    Parameters
    ----------
    items_raw, sources : list
        As returned by :func:`map_inputs`.
    out : Path, optional
        The output folder (created); with it, output names that would replace an input
        are refused (ValueError) and every item is fingerprinted for ``resume``.
    formats : tuple of str
        The checked output formats.
    plot : bool
        Whether the picture is written.

    Returns
    -------
    items : list of _Item
        One per input, in input order.
    fingerprints : dict
        Item index to its fingerprint (empty without ``out``).
    """
    names = _assign_names(sources)
    items = [
        _Item(index=i, name=names[i], path=p, occupancy=occ) for i, (p, occ) in enumerate(items_raw)
    ]
    if out is None:
        return items, {}
    check_no_overwrite(items, out, formats, plot)
    check_same_inputs(items, out)
    check_other_maps_files(items, out, formats, plot)
    return items, {item.index: _fingerprint(item) for item in items}


def default_kernel_threads() -> int:
    """Kernel threads of a batch: the CPUs this process may run on (at most 8) on the CPU
    backend, else 2."""
    import jax

    cores = usable_cpus()
    if jax.default_backend() == "cpu":
        return max(1, min(cores, 8))
    return 2  # an accelerator: one thread cuts tiles while the other's kernels run


def kernel_settings(
    config: PipelineConfig,
    tiles_per_call: int | None,
    kernel_threads: int | None,
    batch_tiles: int | None,
) -> tuple[int, int, int]:
    """The checked ``(tiles_per_call, kernel_threads, batch_tiles)`` of
    :func:`build_graphs`, defaults filled in."""
    tpc = kernel_tiles_per_call(
        "tiles_per_call",
        max(config.tiles_per_call, DEFAULT_TILES_PER_CALL)
        if tiles_per_call is None
        else tiles_per_call,
        config.tile_px,
    )
    threads = int_at_least(
        "kernel_threads",
        default_kernel_threads() if kernel_threads is None else kernel_threads,
        1,
    )
    group_tiles = int_at_least("batch_tiles", 16 * tpc if batch_tiles is None else batch_tiles, 1)
    return tpc, threads, group_tiles


def map_inputs(
    maps: Any,
) -> tuple[list[tuple[Path | None, OccupancyMap | None]], list[Path | None]]:
    """``(path, map object)`` per input of :func:`build_graphs`, and the path that names
    it (a map object's ``source``, if any)."""
    if isinstance(maps, (str, os.PathLike, OccupancyMap)):
        maps = [maps]
    try:
        inputs = list(maps)
    except TypeError:
        raise TypeError(
            f"maps: expected an iterable of paths or OccupancyMap objects, received "
            f"{type(maps).__name__}"
        ) from None
    sources: list[Path | None] = []
    items_raw: list[tuple[Path | None, OccupancyMap | None]] = []
    for i, m in enumerate(inputs):
        if isinstance(m, OccupancyMap):
            items_raw.append((None, m))
            sources.append(Path(m.source) if m.source else None)
        elif isinstance(m, (str, os.PathLike)):
            items_raw.append((Path(m), None))
            sources.append(Path(m))
        else:
            raise TypeError(
                f"maps[{i}]: expected a path (str / os.PathLike) or an OccupancyMap, received "
                f"{type(m).__name__}"
            )
    return items_raw, sources


def check_options(
    *, map_mode: Any, flags: dict[str, Any], sigma_m: Any, out_dir: Any
) -> float | None:
    """Check ``map_mode``, the bool ``flags`` (``keep_graphs`` may be None), ``sigma_m``,
    that ``out_dir`` is a path or None and that ``plot``/``resume`` have one; the checked
    ``sigma_m``."""
    one_of("map_mode", map_mode, (*MODES, None))
    for name, value in flags.items():
        if not (name == "keep_graphs" and value is None):
            flag(name, value)
    if sigma_m is not None:
        sigma_m = positive_metres("sigma_m", sigma_m)
    if out_dir is not None:
        path_like("out_dir", out_dir)
    if out_dir is None and (flags["plot"] or flags["resume"]):
        raise ValueError(
            "out_dir: expected a folder (plot=True and resume=True need one), received None"
        )
    return sigma_m


def route_options(route_config: Any, formats: tuple[str, ...], out_dir: Any):
    """The checked ``route_config`` (its default where None) when ``formats`` name a
    route format, else None; those formats need ``out_dir``."""
    config = instance_or_default("route_config", route_config, RouteGraphConfig)
    routes = sorted(set(formats) & set(ROUTE_FORMATS))
    if not routes:
        if route_config is not None:
            raise ValueError(
                f"route_config: only used with the formats {ROUTE_FORMATS}; expected formats "
                f"to name one, received {formats}"
            )
        return None
    if out_dir is None:
        raise ValueError(
            f"out_dir: expected a folder (the formats {routes} need one), received None"
        )
    return config


def room_options(room_config: Any, formats: tuple[str, ...], out_dir: Any):
    """The checked ``room_config`` (its default where None) when ``formats`` name the
    ``rooms`` format, else None; that format needs ``out_dir`` (rooms are not kept in
    the records)."""
    from ..rooms import RoomConfig

    config = instance_or_default("room_config", room_config, RoomConfig)
    if "rooms" not in formats:
        if room_config is not None:
            raise ValueError(
                "room_config: only used with the format rooms; expected formats to name "
                f"it, received {formats}"
            )
        return None
    if out_dir is None:
        raise ValueError(
            "out_dir: expected a folder (the format 'rooms' writes files and needs one), "
            "received None"
        )
    return config


def request_settings(
    config: PipelineConfig,
    formats: tuple[str, ...],
    *,
    plot: bool,
    map_mode: str | None,
    sigma_m: float | None,
    route_config: RouteGraphConfig | None = None,
    room_config: Any = None,
    map_options: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The result-relevant settings recorded in every manifest (``resume`` compares
    them; ``topojax view`` reads the maps with ``map_mode`` and ``map_options``):
    ``route_config`` and ``room_config`` (a :class:`topojax.RoomConfig`) are those of
    the route and rooms formats, None without them."""
    return _normalise(
        {
            "distance": dataclasses.asdict(config.distance),
            "ridge": dataclasses.asdict(config.ridge),
            "skeleton": dataclasses.asdict(config.skeleton),
            "graph": dataclasses.asdict(config.graph),
            "formats": sorted(formats),
            "plot": bool(plot),
            # only with the rooms format, so that manifests written without it still match
            **({"rooms": dataclasses.asdict(room_config)} if room_config is not None else {}),
            # likewise only with a route format
            **({"route": dataclasses.asdict(route_config)} if route_config else {}),
            # only when given, so that manifests written without them still match
            **({"map_mode": map_mode} if map_mode is not None else {}),
            **({"map_options": dict(sorted(map_options.items()))} if map_options else {}),
            **({"sigma_m": sigma_m} if sigma_m is not None else {}),
        }
    )


def check_no_overwrite(items: list[_Item], out: Path, formats: tuple[str, ...], plot: bool) -> None:
    """Refuse output names that would replace one of the input files (a map file, or the
    image a YAML refers to)."""
    suffixes = _format_suffixes(formats) + [_MANIFEST_SUFFIX] + picture_suffixes(formats, plot)
    refuse_overwriting_inputs(
        [it.path for it in items if it.path is not None],
        [out / f"{it.name}{suffix}" for it in items for suffix in suffixes],
        option="out_dir",
    )


def check_same_inputs(items: list[_Item], out: Path) -> None:
    """Refuse a map file (or a map object loaded from one) whose output name another map
    file's batch already used in ``out`` (its manifest names that file):
    ``maps_a/intel.png`` would silently replace the outputs of ``maps_b/intel.png``
    written there before."""
    for it in items:
        now = it.file  # a map object loaded from a file is checked as that file
        if now is None:
            continue
        manifest = out / f"{it.name}{_MANIFEST_SUFFIX}"
        before = batch_input(manifest)
        if before and os.path.isabs(before) and before != now:
            raise ValueError(
                f"out_dir: {manifest} and the files it lists were written from {before}; "
                f"{now} would replace them. Write into another folder, or remove them first"
            )


def check_other_maps_files(
    items: list[_Item], out: Path, formats: tuple[str, ...], plot: bool
) -> None:
    """Refuse a map whose output file another map's manifest in ``out`` lists: map
    ``x_nav2`` would replace ``x_nav2.geojson``, the Nav2 graph an earlier batch wrote for
    map ``x`` (and the other way round), leaving ``x``'s manifest vouching for another
    file."""
    suffixes = _format_suffixes(formats) + picture_suffixes(formats, plot)
    for it in items:
        own = out / f"{it.name}{_MANIFEST_SUFFIX}"
        for target in (out / f"{it.name}{suffix}" for suffix in suffixes):
            if not target.is_file():
                continue
            other = batch_input(target, other_than=own)
            if other is not None:
                source = other or "a map object"
                raise ValueError(
                    f"out_dir: {target} was written for another map ({source}), whose "
                    f"manifest lists it; map {it.name!r} would replace it. Write into "
                    "another folder, or remove that map's files first"
                )


def warn_unlisted_outputs(
    items: list[_Item], out: Path, formats: tuple[str, ...], plot: bool, *, name: str
) -> None:
    """Warn (``name``: the output folder's parameter or option) of the files in ``out``
    with a map's output name that no batch manifest lists (written by hand or by another
    program): the batch replaces them, or removes them where the map fails.  The files of
    a map whose manifest is there but damaged are a batch's: not warned of."""
    from .._words import counted

    suffixes = _format_suffixes(formats) + [_MANIFEST_SUFFIX] + picture_suffixes(formats, plot)
    found = [
        target
        for it in items
        if not _damaged_manifest(out / f"{it.name}{_MANIFEST_SUFFIX}")
        for target in (out / f"{it.name}{suffix}" for suffix in suffixes)
        if target.is_file() and batch_input(target) is None
    ]
    if not found:
        return
    shown = ", ".join(map(str, found[:5])) + (f" and {len(found) - 5} more" if found[5:] else "")
    them = "it" if len(found) == 1 else "them"
    warnings.warn(
        f"{name}: {shown}: {counted(len(found), 'file')} with a map's output name that no "
        "batch manifest lists (written by hand, by another program, or by a batch stopped "
        f"before that map's manifest); this batch replaces {them}, or removes {them} where "
        f"the map fails; move {them} away first to keep {them}",
        UserWarning,
        stacklevel=outside_stacklevel(),
    )


def _damaged_manifest(manifest: Path) -> bool:
    """Whether ``manifest`` is a file that lists no outputs (unreadable or cut short)."""
    return manifest.is_file() and batch_input(manifest) is None


def warn_unused_workers(executor: Any, workers: int | None) -> None:
    """Warn, at :func:`build_graphs`' caller, that ``workers`` given beside an
    ``executor`` is not used (the executor's own workers run the maps), as the command
    line warns of ``--workers`` beside ``--scheduler``."""
    if executor is not None and workers is not None:
        warnings.warn(
            f"workers: not used with executor= (received {workers}): the executor's own "
            "workers run the maps",
            UserWarning,
            stacklevel=outside_stacklevel(),
        )
