"""``topojax batch``: the graphs of many maps."""

from __future__ import annotations

import signal
import sys
import time
import warnings
from collections import Counter
from pathlib import Path

from ._options import (
    _OPTION_OF,
    _ROOM_OPTIONS,
    _THRESHOLD_OPTIONS,
    MAP_ADVICE,
    _as_options,
    _option_named,
    add_map_options,
    add_pipeline_options,
    add_room_options,
    add_sigma_options,
    add_snap_option,
    given_threshold_refused,
    map_options,
    pipeline_config,
    room_config,
    snap_option,
)
from ._outputs import OUT_OPTION, check_outputs
from ._signals import sigterm_stops

#: What a batch map's manifest appends to its name (``docs/batch-internals.md``).
_MANIFEST = ".manifest.json"
#: The parameters that the message of a map may name (a radius too small for the map's
#: resolution, ``robot_radius_m: expected at least 1.5 pixels ...``), and their options.
_MAP_OPTION_OF = {**_OPTION_OF, "robot_radius_m": "--robot-radius", "snap_m": "--snap-m"}
#: With them, the map and room settings a note of an empty or warned map names (an error
#: row's message, e.g. a YAML field's, names them as the file does).
_NOTE_OPTION_OF = {
    **_MAP_OPTION_OF,
    **{field: option for option, field, *_ in _ROOM_OPTIONS},
    "occupied_thresh": "--occupied-thresh",
    "free_thresh": "--free-thresh",
    "negate": "--negate",
    "map_mode": "--mode",
    "free_space_only": "--free-only",
}


#: The advice of a map's message that names build_graphs' keywords, as the command says it.
_ADVICE = {
    "resume=True runs": "--resume runs",  # a map lost with its worker process
    "fewer workers need": "fewer --workers need",
}


def _cmd_batch(args) -> int:
    stopped: list[signal.Signals] = []
    manifests: dict[Path, tuple[int, int] | None] = {}
    try:
        with sigterm_stops(stopped):
            return _batch(args, manifests)
    except KeyboardInterrupt:  # Ctrl-C, or SIGTERM through sigterm_stops
        signum = stopped[0] if stopped else signal.SIGINT
        print(_stopped_text(signum, args.out, manifests), file=sys.stderr)
        return 128 + signum


def _batch(args, manifests: dict[Path, tuple[int, int] | None]) -> int:
    """Run the batch of ``args``; ``manifests`` receives the manifest of each of its
    maps and its :func:`_stamp` before the run, for the line of a stopped run."""
    from .._fs import output_folder
    from .._lock import one_writer
    from .._words import counted
    from ..batch import expand_map_inputs
    from ..batch.arguments import checked_options, map_inputs
    from ..batch.driver import run_batch
    from ..batch.inputs import planned_outputs

    _check_numbers(args)
    reading = map_options(args)  # checked under the options' names
    route_config = _route_config(args)
    rooms_config = _room_config(args)
    paths = expand_map_inputs(args.inputs, exclude=args.out)
    planned = planned_outputs(paths, formats=args.formats, plot=args.plot)
    claims = {Path(args.out) / rel: source for rel, source in planned.items()}
    check_outputs(claims, command="batch", option=OUT_OPTION)
    config = pipeline_config(args)  # --sigma-m goes to build_graphs: per map
    client = None
    executor = None
    if args.scheduler:
        try:
            from distributed import Client
        except ImportError as exc:  # pragma: no cover - optional dependency
            raise ValueError(
                "--scheduler needs dask.distributed (pip install 'topojax[dask]')"
            ) from exc
        try:
            timeout = 30.0 if args.connect_timeout is None else args.connect_timeout
            client = Client(args.scheduler, timeout=timeout)
        except (OSError, TypeError, ValueError) as exc:  # no scheduler there, a bad address
            raise ValueError(
                f"--scheduler: expected the address of a running Dask scheduler (e.g. "
                f"tcp://host:8786), received {args.scheduler!r}: {exc}"
            ) from None
        executor = client.get_executor(pure=False)
        if args.workers is not None:
            warnings.warn(
                f"--workers: not used with --scheduler (received {args.workers}): the "
                "cluster's own workers run the maps",
                UserWarning,
                stacklevel=2,
            )
    t0 = time.perf_counter()
    for rel in planned:
        if rel.endswith(_MANIFEST):
            manifests[Path(args.out) / rel] = _stamp(Path(args.out) / rel)
    try:
        # made once the scheduler is reached: a failed connection leaves no folder
        out = output_folder(args.out, name="--out")  # named as the command names it
        # build_graphs, with load_map's options besides its map_mode for every map file
        options = checked_options(
            executor=executor,
            workers=args.workers,
            config=config,
            formats=args.formats,
            flags={
                "plot": args.plot,
                "resume": args.resume,
                "progress": not args.no_progress,
                "keep_graphs": None,
            },
            out_dir=out,
            tiles_per_call=args.tiles_per_call,
            kernel_threads=args.kernel_threads,
            batch_tiles=None,
            map_mode=reading.pop("mode", None),
            sigma_m=args.sigma_m,
            route_config=route_config,
            room_config=rooms_config,
            map_options=reading,
        )
        with one_writer(out, name="--out", command="batch"):  # one batch per folder
            records = run_batch(*map_inputs(paths), out, options, out_name="--out")
    except ValueError as exc:  # e.g. more --workers than the memory holds, or an output
        # that would replace an input map: named as the options the user typed
        exc = _option_named(exc, "workers", "--workers")
        raise _option_named(exc, "out_dir", OUT_OPTION) from None
    finally:
        if client is not None:
            client.close()
    wall = time.perf_counter() - t0
    records = _as_printed(records, args)
    counts = Counter(r.status for r in records)
    warned = [r for r in records if _warned(r)]
    done = ("ok", "empty")
    megapixels = sum((r.height or 0) * (r.width or 0) for r in records if r.status in done) / 1e6
    print(
        f"topojax batch: {counted(len(records), 'map')} in {wall:.1f} s "
        f"({counts['ok']} ok, {counts['empty']} empty, {counts['skipped']} skipped, "
        f"{counted(counts['error'], 'error')}, {len(warned)} with a warning; "
        f"{megapixels:.1f} Mpx processed); table: {Path(args.out) / 'summary.csv'}"
    )
    from ..batch.manifest import RESUMED

    for r in records:  # a skipped map with more to say: its earlier warning, or why empty
        if r.status in ("error", "empty") or r in warned or r.message not in ("", RESUMED):
            print(f"  {r.status:7s}  {r.map}: {r.message}", file=sys.stderr)
    return 1 if counts["error"] else 0


def _warned(record) -> bool:
    """Whether ``record`` carries a warning: an ok map's note, or the warning a skipped
    map's earlier run recorded (repeated after ``outputs complete (resume); ``)."""
    from ..batch.manifest import RESUMED

    if record.status == "skipped":
        return record.message.startswith(f"{RESUMED}; ")
    return record.status == "ok" and bool(record.message)


def _as_printed(records: list, args) -> list:
    """``records`` with the parameters their messages name written as the options that
    set them (``--robot-radius: expected at least 1.5 pixels ...``, ``--resolution sets
    it``); the summary table in ``--out`` written again with them where one changed."""
    from dataclasses import replace

    from ..batch import write_summary
    from ..batch.worker import GIVEN_RESOLUTION, RESOLUTION_HINT

    def message(r) -> str:
        names = _MAP_OPTION_OF if r.status == "error" else _NOTE_OPTION_OF
        error = r.message.removeprefix("ValueError: ")
        if r.status == "error" and given_threshold_refused(error, map_options(args)):
            names = {**names, **dict(_THRESHOLD_OPTIONS)}  # the one given, the map's other
        text = r.message.replace(RESOLUTION_HINT, "--resolution sets it")
        text = text.replace(GIVEN_RESOLUTION, "--resolution")
        return _as_options(text, names, advice={**MAP_ADVICE, **_ADVICE})

    named = [replace(r, message=message(r)) for r in records]
    if any(a.message != b.message for a, b in zip(records, named, strict=True)):
        write_summary(named, args.out)
    return named


def _stopped_text(signum: int, out, manifests: dict[Path, tuple[int, int] | None]) -> str:
    """The line of a batch stopped by the signal ``signum``: how many of its maps this
    run finished (their manifests, ``manifests`` with their stamps before the run, now
    new) and how to do the others."""
    how = "stopped by SIGTERM" if signum == signal.SIGTERM else "interrupted (Ctrl-C)"
    if not manifests:
        return f"topojax batch: {how} before any map was started"
    from .._words import counted

    done = sum(1 for path, was in manifests.items() if _stamp(path) not in (None, was))
    if done == len(manifests):  # stopped while the table was written
        return (
            f"topojax batch: {how} after it finished all {counted(done, 'map')} (their "
            f"files and manifests are in {out}), before it wrote summary.csv; the same "
            "command with --resume writes it"
        )
    return (
        f"topojax batch: {how}; this run finished {done} of {counted(len(manifests), 'map')} "
        f"(their files and manifests are in {out}; summary.csv is written only by a run "
        "that ends); the same command with --resume does the others"
    )


def _stamp(path: Path) -> tuple[int, int] | None:
    """The inode and modification time of ``path``, or None where there is no file: a
    manifest written again (renamed into place) gets another."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns


def _check_numbers(args) -> None:
    """The numeric options of the batch runner, checked under their own names before any
    work (the library's messages name its parameters)."""
    from .._validate import int_at_least, kernel_tiles_per_call, positive_int, quantity
    from ..batch.inputs import check_formats

    try:
        check_formats(args.formats)
    except ValueError as exc:
        raise _option_named(exc, "formats", "--formats") from None
    if args.connect_timeout is not None:
        quantity("--connect-timeout", args.connect_timeout, unit="seconds", allow_zero=False)
        if args.scheduler is None:
            raise ValueError(
                "--connect-timeout: only used with --scheduler; expected --scheduler ADDRESS "
                "beside it, received none"
            )
    if args.scheduler is not None and not args.scheduler.strip():  # an unset $SCHEDULER
        raise ValueError(
            "--scheduler: expected the address of a running Dask scheduler (e.g. "
            f"tcp://host:8786), received {args.scheduler!r}"
        )
    if args.workers is not None:
        int_at_least("--workers", args.workers, 0)
    if args.tiles_per_call is not None:
        kernel_tiles_per_call("--tiles-per-call", args.tiles_per_call, args.tile_px)
    if args.kernel_threads is not None:
        positive_int("--kernel-threads", args.kernel_threads)


def _route_config(args):
    """The route graph options of ``--robot-radius`` and ``--snap-m``, or None without
    either (the route formats then use :class:`RouteGraphConfig`'s defaults)."""
    from .._validate import robot_radius
    from ..batch.inputs import ROUTE_FORMATS, check_formats
    from ..routegraph import RouteGraphConfig

    given = {"robot_radius_m": args.robot_radius_m, "snap_m": args.snap_m}
    given = {k: v for k, v in given.items() if v is not None}
    if not given:
        return None
    if not set(check_formats(args.formats)) & set(ROUTE_FORMATS):
        raise ValueError(
            f"{_MAP_OPTION_OF[next(iter(given))]}: only used with the formats "
            f"{', '.join(ROUTE_FORMATS)}; expected --formats to name one, received "
            f"{args.formats!r}"
        )
    if "robot_radius_m" in given:
        given["robot_radius_m"] = robot_radius(
            "--robot-radius", given["robot_radius_m"], allow_zero=False
        )
    if "snap_m" in given:
        given["snap_m"] = snap_option(given["snap_m"])
    return RouteGraphConfig(**given)


def _room_config(args):
    """The room options of the ``rooms`` format (those of ``topojax rooms``), or None
    without any (the format then uses :class:`RoomConfig`'s defaults); an error names the
    option."""
    from ..batch.inputs import check_formats

    given = [option for option, field, *_ in _ROOM_OPTIONS if getattr(args, field) is not None]
    if not given:
        return None
    if "rooms" not in check_formats(args.formats):
        raise ValueError(
            f"{', '.join(given)}: only used with the format rooms; expected --formats to "
            f"name it, received {args.formats!r}"
        )
    return room_config(args)


def add_command(subparsers) -> None:
    """Register the ``batch`` subcommand on an ``argparse`` subparsers object."""
    p = subparsers.add_parser(
        "batch",
        help="build the graphs of many maps (batched kernels, parallel CPU stages)",
        description="Build the topology graphs of many maps: JAX kernels batched in this "
        "process, thinning and graph building in parallel worker processes (or on a Dask "
        "cluster with --scheduler). Writes per map GraphML/JSON/GeoJSON (+ picture with "
        "--plot) and a manifest, and OUT/summary.csv. Exit status 1 if any map failed.",
    )
    p.add_argument(
        "inputs",
        nargs="+",
        help="map files, folders (searched recursively) or glob patterns with ** and "
        "braces, e.g. 'maps/**/*.{yaml,png,pgm}' (quote it)",
    )
    p.add_argument("-o", "--out", default="out", help="output folder (default: out)")
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        help="worker processes for the CPU stages, at most one per map and as many as the "
        "memory holds (default: the cores this process may use, e.g. under taskset or a "
        "job scheduler; 0 = in-process)",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run the CPU stages on a Dask distributed cluster, e.g. tcp://host:8786",
    )
    p.add_argument(
        "--connect-timeout",
        type=float,
        default=None,
        help="seconds to reach the --scheduler (default 30)",
    )
    add_map_options(p, each_map=", the same for every map file")
    add_sigma_options(p, each_map=" (each map through its own resolution)")
    add_pipeline_options(p)
    p.add_argument(
        "--tiles-per-call",
        type=int,
        default=None,
        help="tiles per kernel call (bucket size; default 16)",
    )
    p.add_argument(
        "--kernel-threads",
        type=int,
        default=None,
        help="threads dispatching kernel calls (default: the cores this process may use, at "
        "most 8; 2 on an accelerator)",
    )
    p.add_argument(
        "--plot",
        action="store_true",
        help="also write <name>_graph.png per map (and <name>_route.png with a route format)",
    )
    p.add_argument(
        "--resume", action="store_true", help="skip maps whose outputs are complete and valid"
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument(
        "--formats",
        default="graphml,json,geojson",
        help="comma-separated graph formats: graphml, json, geojson, nav2 (a Nav2 Route "
        "Server graph, NAME_nav2.geojson), rooms (the map's rooms and doorways, "
        "NAME_rooms.{geojson,png,graphml,json}, with the room options below; the graph "
        "files then carry each vertex's room), route (the route graph for a round robot of "
        "--robot-radius, covering the feasible space within --snap-m, "
        "NAME_route.{graphml,json,geojson}), route_nav2 (that graph for the Nav2 Route "
        "Server, NAME_route_nav2.geojson) (default: graphml,json,geojson)",
    )
    p.add_argument(
        "--robot-radius",
        dest="robot_radius_m",
        type=float,
        metavar="M",
        help="robot radius in metres of the route formats (default 0.3)",
    )
    add_snap_option(p, default=None)
    add_room_options(p, only_with="--formats rooms")
    p.set_defaults(handler=_cmd_batch)
