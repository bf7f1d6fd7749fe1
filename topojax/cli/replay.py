"""``topojax replay``: a laser log through the incremental mapper."""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
import warnings
from pathlib import Path

from .._constants import CARMEN_LASERS, STRATEGIES
from ..config import PRUNING_SETTINGS
from ._options import (
    _OPTION_OF as _PIPELINE_OPTION_OF,
)
from ._options import (
    _ROOM_OPTIONS,
    _as_options,
    add_graph_options,
    add_nav2_options,
    add_room_options,
    add_sigma_options,
    distance_config,
    graph_config,
    graph_filters,
    named_as_options,
    nav2_tolerance,
    room_config,
)
from ._outputs import OUT_OPTION, check_outputs, planned, record_outputs


def _check_numbers(args) -> None:
    """The numeric options, checked under their own names before the replay (the
    library's messages name its parameters)."""
    from .._validate import (
        int_at_least,
        metres_per_pixel,
        nonnegative_quantity,
        positive_int,
        positive_metres,
        quantity,
        robot_radius,
    )

    positive_metres("--resolution", args.resolution)
    metres_per_pixel("--resolution", args.resolution)  # and a map's range
    nonnegative_quantity("--checkpoint-every", args.checkpoint_every, "seconds")
    for option, value in (
        ("--skeleton-every", args.skeleton_every),
        ("--graph-every", args.graph_every),
    ):
        if value is not None:
            int_at_least(option, value, 0)
    if args.max_scans is not None:
        positive_int("--max-scans", args.max_scans)
    if args.max_extent_m is not None:
        positive_metres("--max-extent-m", args.max_extent_m)
    if args.max_export_mb is not None:
        mb = quantity("--max-export-mb", args.max_export_mb, unit="MB", allow_zero=False)
        if _export_bytes(mb) < 1:
            raise ValueError(f"--max-export-mb: expected at least one byte, received {mb!r} MB")
    if args.max_range is not None and not args.max_range > 0:  # inf: every reading a hit
        raise ValueError(
            f"--max-range: expected a number of metres > 0 (inf: no no-return value), "
            f"received {args.max_range}"
        )
    if args.sensor_offset is not None:  # as the readers check it, under the option's name
        from ..scans.scan import mounting

        mounting("--sensor-offset", tuple(args.sensor_offset))
    if args.route_graph is not None:
        from ..routegraph.build import RouteGraphConfig
        from ..routegraph.scale import check_scale

        radius = robot_radius("--route-graph", args.route_graph, allow_zero=False)
        check_scale(
            RouteGraphConfig(robot_radius_m=radius),
            args.resolution,
            "--route-graph",
            snap_name=None,  # the default snap_m, which the command has no option for
            resolution_name="--resolution",
        )


def _cmd_replay(args) -> int:
    from ..playback import replay, summary_printed, summary_text
    from ..scans import ReaderOptionError

    _check_numbers(args)
    if not Path(args.source).exists():  # named as the command names it; a bag may be a folder
        raise FileNotFoundError(f"source: no log file or bag there: {args.source}")
    kw = {
        "resolution_m": args.resolution,
        "skeleton_every": args.skeleton_every,
        "graph_every": args.graph_every,
        "strategy": args.strategy,
    }
    if args.max_extent_m is not None:
        kw["max_extent_m"] = args.max_extent_m
    advice = _ADVICE
    if args.max_export_mb is not None:
        kw["max_export_bytes"] = limit = _export_bytes(args.max_export_mb)
        advice = {
            f"max_export_bytes={limit}": f"--max-export-mb {args.max_export_mb:g} "
            f"({limit:,} bytes)",
            **_ADVICE,
        }
    distance = distance_config(args, resolution_m=args.resolution)  # before the replay
    if distance is not None:
        kw["distance"] = distance
    config = room_config(args, only_with="--rooms", given=args.rooms)  # before the replay
    if config is not None:
        kw["room_config"] = config
    reader_kwargs = {}
    for name, key in (
        ("laser", "laser"),
        ("max_range", "max_range_m"),
        ("scan_topic", "scan_topic"),
        ("pose_topic", "pose_topic"),
    ):
        if getattr(args, name) is not None:
            reader_kwargs[key] = getattr(args, name)
    for name in ("tf_parent", "base_frame"):
        if getattr(args, name) is not None:
            reader_kwargs[name] = getattr(args, name)
    if args.sensor_offset is not None:
        reader_kwargs["sensor_offset"] = tuple(args.sensor_offset)
    if args.allow_missing_pose:
        reader_kwargs["allow_missing_pose"] = True
    if args.skip_bad_lines:
        reader_kwargs["bad_lines"] = "skip"
    check_outputs(_replay_claims(args), command="replay", option=OUT_OPTION)
    if args.mcap is not None:
        from ..io.mcap import mcap_path

        mcap_path(args.mcap, name="--mcap")  # an .mcap file name, not a folder
    for option, path in (("--animate", args.animate), ("--mcap", args.mcap)):
        if path is not None:
            check_outputs(
                planned([path], args.source), command="replay", option=option, names_file=True
            )
    summary = None
    printed_here = summary_printed.set(False)  # below, in the command's words
    try:
        with (
            _stops_on_signals() as stopped,
            named_as_options(_OPTION_OF, _RESUME_OPTION_OF, advice=advice),
            _warnings_in_words(),
        ):
            summary = replay(
                args.source,
                out_dir=args.out,
                plot=args.plot,
                animate=args.animate,
                progress=not args.no_progress,
                max_scans=args.max_scans,
                reader_kwargs=reader_kwargs or None,
                nav2_tolerance_m=nav2_tolerance(args),
                graph_config=graph_config(args),
                route_graph_radius_m=args.route_graph,
                rooms=args.rooms,
                mcap=args.mcap,
                view=args.view,
                resume=args.resume,
                checkpoint_every_s=args.checkpoint_every,
                **kw,
            )
    except ReaderOptionError as exc:  # options of another reader than the log's
        raise _reader_refused(exc) from None
    finally:
        summary_printed.reset(printed_here)
    if summary is None:  # stopped part way, its state saved for --resume
        print(f"topojax replay: stopped by {stopped[0].name}", file=sys.stderr)
        return 128 + stopped[0]
    filters = graph_filters(graph_config(args))  # the timeline keeps the graph unfiltered
    record_outputs(
        planned(summary["written"], args.source), command="replay", graph_options=filters
    )
    # not "resume", a word of the messages; the pruning settings of an emptied graph
    words = {"max_extent_m": "--max-extent-m", **_PRUNING_OPTIONS}
    messages = [_in_options(m, words) for m in summary["messages"]]  # e.g. a skipped scan's
    print(summary_text({**summary, "messages": messages}))
    print("wrote      " + ", ".join(summary["written"]))
    if stopped:  # a signal the replay could not act on (e.g. lost in a callback)
        print(
            f"topojax replay: {stopped[0].name} arrived but the replay finished; its files "
            "are complete",
            file=sys.stderr,
        )
        return 128 + stopped[0]
    return 0


@contextlib.contextmanager
def _warnings_in_words():
    """Within ``with``, the warnings of :func:`topojax.replay` shown in this command's
    words: how to continue a stopped replay names ``--resume``, not ``resume=True``, and
    the readers' advice its options as :data:`_ADVICE` words them."""
    from .._replay_state import RESUME_ADVICE

    shown = warnings.showwarning
    resume = "(the same command with --resume continues from it)"
    words = {f"(replay again with {RESUME_ADVICE})": resume, **_ADVICE}

    def show(message, category, filename, lineno, file=None, line=None):
        text = str(message)
        for phrase, instead in words.items():
            text = text.replace(phrase, instead)
        shown(text, category, filename, lineno, file, line)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield


def _export_bytes(mb: float) -> int:
    """``--max-export-mb`` in bytes (a MB is 2**20 bytes)."""
    return int(mb * 2**20)


def _reader_refused(exc) -> ValueError:
    """The error of reader options the log's reader does not take
    (:class:`topojax.scans.ReaderOptionError`), in the command's options."""
    option_of = {**_RESUME_OPTION_OF, "bad_lines": "--skip-bad-lines"}
    given = ", ".join(option_of.get(name, name) for name in exc.unknown)
    takes = [option_of[name] for name in exc.accepted if name in option_of]
    return ValueError(
        f"{given}: expected options of the log's reader, received a log read by "
        f"{exc.reader} ({exc.path}), which takes {', '.join(takes) or 'none of them'}"
    )


#: The pruning settings a note of a graph they emptied names, and their options.
_PRUNING_OPTIONS = {name: _PIPELINE_OPTION_OF[name] for name in PRUNING_SETTINGS}
#: The parameters of :func:`topojax.replay` that errors name, and the options that set
#: them (``mcap`` is checked as ``--mcap`` before; ``.mcap`` ends its messages' names).
_OPTION_OF = {
    "out_dir": "--out",
    "animate": "--animate",
    "resume": "--resume",
    "max_extent_m": "--max-extent-m",
    "checkpoint_every_s": "--checkpoint-every",
    # the readers' options (``laser`` is also a word of their messages)
    "max_range_m": "--max-range",
    "scan_topic": "--scan-topic",
    "pose_topic": "--pose-topic",
    "allow_missing_pose": "--allow-missing-pose",
    "tf_parent": "--tf-parent",
    "base_frame": "--base-frame",
    "sensor_offset": "--sensor-offset",
}
#: The advice of the mapper's refusals of a scan beyond ``max_extent_m`` that names
#: settings this command has no option for (the mapper's tiles) or that it sets with an
#: option (the Gaussian, ``max_extent_m``), and what the command says instead.
_ADVICE = {
    "make the mapper with a smaller tile_px or sigma, or a larger max_extent_m": (
        "give a smaller --sigma-m or --sigma-px, or a larger max_extent_m"
    ),
    "set the scan's range_max or the mapper's max_range_m, or make the mapper with a "
    "larger max_extent_m": "give a smaller --max-range, or a larger max_extent_m",
    "make the mapper with a larger max_extent_m": "give a larger max_extent_m",
    "make the mapper with a larger max_export_bytes": "give a larger --max-export-mb",
    "replay again with resume=True and a larger max_export_bytes": (
        "replay again with --resume and a larger --max-export-mb"
    ),
    "the kind laser=": "the kind --laser ",  # a CARMEN log without the lines asked for
    # the readers' advice, keyword values as the options take them
    "allow_missing_pose=True": "--allow-missing-pose",
    "sensor_offset=(x_m, y_m, yaw_rad)": "--sensor-offset X Y YAW",
    "base_frame= (": "--base-frame (",
    "tf_parent='odom' or 'map', or pose_topic=)": "--tf-parent odom or map, or --pose-topic)",
    "choose one with pose_topic=": "choose one with --pose-topic",
    "pass max_range_m": "give --max-range",
    "(pass laser=... to read another)": "(give --laser KIND to read another)",
    "bad_lines='skip'": "--skip-bad-lines",
    "(load_map reads maps)": "(topojax graph, rooms and route-graph read maps)",
}


def _in_options(text: str, option_of: dict[str, str] = _OPTION_OF) -> str:
    """``text`` (a message of :func:`topojax.replay`) in the words of this command: the
    mapper's advice as :data:`_ADVICE` words it, each parameter of ``option_of`` as the
    option that sets it."""
    return _as_options(text, option_of, advice=_ADVICE)


#: With them, the mapper settings, reader options and ``max_scans`` that a refused
#: resume names (``resume: ...``), as the options that set them.
_RESUME_OPTION_OF = {
    **_OPTION_OF,
    "max_scans": "--max-scans",
    "resolution_m": "--resolution",
    "skeleton_every": "--skeleton-every",
    "graph_every": "--graph-every",
    "rooms_every": "--rooms",
    "strategy": "--strategy",
    "route_graph_radius_m": "--route-graph",
    "laser": "--laser",
    "config.distance.sigma_px": "--sigma-px or --sigma-m (sigma in px)",
    "config.distance.half_width_px": "the Gaussian's half-width in px (--sigma-px or --sigma-m)",
    **{f"room_config.{field}": option for option, field, *_ in _ROOM_OPTIONS},
}


@contextlib.contextmanager
def _stops_on_signals():
    """Within ``with``, Ctrl-C (SIGINT) and SIGTERM (``kill``, ``timeout``, a service
    manager's stop) stop the replay as Ctrl-C stops :func:`topojax.replay`, which keeps
    the mapped scans for ``--resume``; the list it yields then holds the signal.  SIGTERM
    goes through the SIGINT handler in force when it arrives, the replay's, which lets
    the scan being mapped finish; where SIGINT is ignored (a background job of a
    script), through the replay's holding all the same.  Outside the main thread, or
    where SIGINT has another handler, SIGTERM is left as it is."""
    from .._replay_state import interrupt

    stopped: list[signal.Signals] = []

    def terminate(signum, frame):
        stopped[:] = [signal.SIGTERM]
        handler = signal.getsignal(signal.SIGINT)
        if not callable(handler):  # ignored: the replay holds the stop all the same
            interrupt(signal.SIGINT, frame)
        else:
            handler(signal.SIGINT, frame)

    previous = None
    if threading.current_thread() is threading.main_thread() and signal.getsignal(
        signal.SIGINT
    ) in (signal.default_int_handler, signal.SIG_IGN):
        previous = signal.signal(signal.SIGTERM, terminate)
    try:
        yield stopped
    except KeyboardInterrupt:
        stopped[:] = stopped or [signal.SIGINT]
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _replay_claims(args) -> dict:
    """The files :func:`topojax.replay` writes into ``--out`` (the names it uses)."""
    from ..playback import output_names

    names = output_names(
        nav2=bool(args.nav2),
        plot=bool(args.plot),
        route_graph=args.route_graph is not None,
        rooms=bool(args.rooms),
        view=bool(args.view),
    )
    return planned([Path(args.out) / name for name in names], args.source)


def add_command(subparsers) -> None:
    """Register the ``replay`` subcommand on an ``argparse`` subparsers object."""
    p = subparsers.add_parser(
        "replay",
        help="build the topology graph incrementally from a laser log",
        description="Replay a laser log (CARMEN .log/.gz, ROS 1/2 bag, Octave laser file) "
        "through the incremental mapper; write the final graph (GraphML, JSON, GeoJSON), "
        "the occupancy map, per-loop timings and optionally pictures and an animation.",
    )
    p.add_argument("source", help="log file or bag")
    p.add_argument("-o", "--out", default="out", help="output folder (default: out)")
    p.add_argument("--plot", action="store_true", help="also write PNG pictures")
    p.add_argument("--animate", metavar="PATH", help="write an animated GIF of the graph")
    p.add_argument(
        "--mcap",
        metavar="FILE",
        help="write a ROS 2 MCAP recording (FILE.mcap, for Foxglove, RViz and ros2 bag "
        "play): /scan and /tf per scan, /map and /topology at every graph update, "
        "/route_graph with --route-graph, /rooms with --rooms, stamped with the log's "
        "times (needs rosbags: pip install 'topojax[bags]')",
    )
    p.add_argument(
        "--skeleton-every",
        type=int,
        default=20,
        help="scans per skeleton update (default 20; 0: only with the graph updates)",
    )
    p.add_argument(
        "--graph-every",
        type=int,
        default=80,
        help="scans per graph update (default 80; 0: only after the last scan)",
    )
    p.add_argument(
        "--strategy",
        choices=STRATEGIES,
        default="exact",
        help="skeleton update: exact (equals the full-map result; default) or paper",
    )
    p.add_argument("--resolution", type=float, default=0.05, help="m/px (default 0.05)")
    add_sigma_options(p, each_map=" (converted to pixels at --resolution)")
    p.add_argument(
        "--max-scans",
        type=int,
        help="stop after this many scans of the log, those skipped included (the summary "
        "counts the scans mapped)",
    )
    p.add_argument(
        "--max-extent-m",
        type=float,
        metavar="M",
        help="the longest side the mapped area may grow to (default 2000); a scan that "
        "would grow it further (a pose far off) is skipped, and the summary counts the "
        "skipped scans per bound met with the first refusal",
    )
    p.add_argument(
        "--max-export-mb",
        type=float,
        metavar="MB",
        help="the most memory (MB of 2**20 bytes) one export of the whole map may take: "
        "the map, graph and route graph written at graph updates and at the end (default "
        "2048); a map past it stops the replay with its scans saved, and --resume with a "
        "larger one writes them",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue a replay of this log into --out that stopped part way (an error, "
        "Ctrl-C or SIGTERM) from the mapper_state.npz it saved there, skipping the scans it "
        "took and continuing its animation, view timeline and MCAP recording; the same "
        "mapper and reader options are needed (refused otherwise); also after a replay "
        "killed outright (kill -9, out of memory, a power cut), from its last checkpoint",
    )
    p.add_argument(
        "--checkpoint-every",
        type=float,
        default=60.0,
        metavar="SECONDS",
        help="while mapping, save the mapper's state into --out for --resume after a scan "
        "once this many seconds have passed since the last save (default 60; 0: never)",
    )
    _add_reader_options(p)
    add_graph_options(p)
    add_nav2_options(
        p,
        "graph_nav2.geojson (and route_graph_nav2.geojson with --route-graph, where the "
        "route graph has an edge)",
    )
    p.add_argument(
        "--route-graph",
        type=float,
        metavar="RADIUS_M",
        help="also write route_graph.{graphml,json,geojson}: the route graph of the final "
        "map for a round robot of this radius in metres (see topojax route-graph); with "
        "--mcap, also the route graph of the map at every graph update",
    )
    p.add_argument(
        "--rooms",
        action="store_true",
        help="also keep rooms as the map grows (with every graph update), give the graph "
        "files their rooms and write map_rooms.{geojson,png,graphml,json}; --animate "
        "colours the rooms and with --plot graph.png draws the final ones",
    )
    add_room_options(p, only_with="--rooms")
    p.add_argument(
        "--view",
        action="store_true",
        help="also write view.html: the interactive view of the final map and graph with a "
        "timeline of every graph update, and timeline.json.gz, from which topojax view makes "
        "the page again",
    )
    p.set_defaults(handler=_cmd_replay)
    return p


def _add_reader_options(p) -> None:
    """The options passed to the log's reader (CARMEN logs, bags)."""
    p.add_argument(
        "--max-range",
        type=float,
        metavar="M",
        help="CARMEN logs: readings of M metres or more are no-returns (default: from the "
        "log's no-return value, or each line's own maximum)",
    )
    p.add_argument(
        "--laser",
        choices=CARMEN_LASERS,
        metavar="KIND",
        help="CARMEN logs: the laser lines to read, one of "
        + ", ".join(CARMEN_LASERS)
        + " (default: the kind of the log's first laser line)",
    )
    p.add_argument(
        "--skip-bad-lines",
        action="store_true",
        help="CARMEN logs: skip malformed laser lines with a warning instead of stopping "
        "(also when resuming a replay that stopped at one)",
    )
    p.add_argument("--scan-topic", help="bags: the LaserScan topic (default: the only one)")
    p.add_argument("--pose-topic", help="bags: an Odometry / pose topic (default: tf)")
    p.add_argument(
        "--allow-missing-pose",
        action="store_true",
        help="bags: without any pose source, map every scan at the origin (scan-only bags)",
    )
    p.add_argument(
        "--tf-parent",
        metavar="FRAME",
        help="bags: the map frame of poses from tf (default: map if in tf, else odom)",
    )
    p.add_argument(
        "--base-frame",
        metavar="FRAME",
        help="bags: the robot frame (default: base_footprint or base_link on the tf chain, "
        "or the Odometry child frame)",
    )
    p.add_argument(
        "--sensor-offset",
        type=float,
        nargs=3,
        metavar=("X", "Y", "YAW"),
        help="the laser's pose on the robot in metres and radians, overriding tf (bags) "
        "or the log (CARMEN); needed where neither gives it",
    )
