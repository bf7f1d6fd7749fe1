"""``topojax route``: the shortest route between two points on a saved graph."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import warnings
from pathlib import Path

from ._options import (
    add_map_options,
    assumed_resolution_note,
    load_option_map,
    map_line,
    map_options,
)
from ._outputs import OUT_OPTION, check_outputs, planned, record_outputs


def _snap_limit(text: str) -> float | None:
    """``--max-snap-m``: a number of metres, or ``none`` (or ``inf``) for no limit."""
    if text.strip().lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a number of metres or none, received {text!r}"
        ) from None
    return None if value == float("inf") else value


def add_command(subparsers) -> None:
    """Register the ``route`` subcommand on an ``argparse`` subparsers object."""
    p = subparsers.add_parser(
        "route",
        help="shortest route between two points on a saved graph",
        description="Snap a start and a goal point to a saved topology graph (GraphML, "
        "JSON or GeoJSON from `topojax graph`) and print the shortest route between them "
        "along its corridors; optionally write it as a GeoJSON Feature (a LineString).",
    )
    p.add_argument("graph", help="graph file: .graphml, .json or .geojson")
    p.add_argument(
        "--start", nargs=2, type=float, required=True, metavar=("X", "Y"), help="start point"
    )
    p.add_argument(
        "--goal", nargs=2, type=float, required=True, metavar=("X", "Y"), help="goal point"
    )
    p.add_argument(
        "--pixel",
        action="store_true",
        help="points are (row, col) pixels of the map instead of world (x, y) metres",
    )
    p.add_argument(
        "--max-snap-m",
        type=_snap_limit,
        default=5.0,
        metavar="M",
        help="fail if a point is more than M metres from the graph (default 5; none: no limit)",
    )
    p.add_argument(
        "--map",
        metavar="MAP",
        help="the graph's map (as `topojax graph` reads it): each end may then join the "
        "graph at the nearest point of any edge it sees within the graph's snap distance "
        "(1 m if it has none), whichever gives the shortest route, and a point that sees "
        "no edge along a line off the map's obstacles (a closet the graph does not reach, a "
        "point off the map) is an error; the robot radius is the graph's (a route graph's) "
        "or --robot-radius; the map options below say how it is read",
    )
    p.add_argument(
        "--robot-radius",
        type=float,
        metavar="M",
        help="the robot radius in metres: a warning says when the route runs closer to an "
        "obstacle than that; with --map the legs to the graph keep it from the walls too "
        "(default: the graph's); without, only the edges' recorded min_clearance_m is "
        "checked, the first and last edge counted whole, and the legs are not",
    )
    p.add_argument(
        "--entry-m",
        type=float,
        metavar="M",
        help="with --map: how far a route may go to join the graph (default: the graph's "
        "snap distance, else 1)",
    )
    add_map_options(p)
    p.add_argument("-o", "--out", help="write the route here as GeoJSON")
    p.add_argument(
        "--simplify-m",
        type=float,
        metavar="M",
        help="with -o: write waypoints that keep every route pixel within M metres instead "
        "of every pixel (default: every pixel)",
    )
    p.set_defaults(handler=_cmd_route, runs_kernels=False)


def _map_options_given(args) -> list[str]:
    """The options that only matter with ``--map`` and were given."""
    given = [
        "--resolution" if k == "resolution_m" else "--" + k.replace("_", "-")
        for k in map_options(args)
    ]
    return given + (["--entry-m"] if args.entry_m is not None else [])


def _unsafe(route, mapped: bool) -> list[str]:
    """What makes ``route`` unsafe for the robot it was planned for: an end joined along
    the fallback leg (with ``--map``), a corridor narrower than the robot's radius
    (without ``--map``, by the edges' recorded clearances, the end edges whole)."""
    from ..fields.clearance import clearance_at_least

    radius = route.robot_radius_m
    if radius is None:  # no robot to compare with
        return []
    found = [
        f"{end}: no straight line from it to the graph within reach fits the robot (radius "
        f"{radius:g} m): it joins the graph {snap_m:.3f} m away over pixels that are only "
        "not occupied (free or unknown)"
        for end, fits, snap_m in (
            ("start", route.start_leg_feasible, route.start_snap_m),
            ("goal", route.goal_leg_feasible, route.goal_snap_m),
        )
        if fits is False
    ]
    clear = route.min_clearance_m
    if math.isnan(clear) or clearance_at_least(clear, radius):
        return found
    if mapped:
        found.append(
            f"the route runs along a corridor {clear:.3f} m from the nearest obstacle at its "
            f"narrowest, less than the robot radius {radius:g} m"
        )
    else:
        found.append(
            f"the route runs along edges {clear:.3f} m from the nearest obstacle at their "
            f"narrowest, less than the robot radius {radius:g} m (without --map the first "
            "and last edge count whole, though the route may run along part of them only)"
        )
    return found


def _unchecked(route, mapped: bool) -> list[str]:
    """What of ``route``'s robot cannot be checked without the map: the legs, and the
    corridors where the graph records no clearance."""
    if mapped or route.robot_radius_m is None:
        return []
    notes = [
        "without --map the legs from the start and goal to the graph are not checked for "
        "the robot, and the first and last edge count whole in its narrowest clearance"
    ]
    if math.isnan(route.min_clearance_m):
        notes.append(
            "the graph records no clearance along the route: the robot radius cannot be "
            "checked without --map"
        )
    return notes


def _cmd_route(args) -> int:
    from .._fs import output_file
    from .._snap import unrecorded_grid
    from .._validate import nonnegative_metres, positive_metres, robot_radius
    from .._words import counted
    from ..io import load_graph
    from ..io.files import GRAPH_FORMATS, graph_file
    from ..routing import NoRouteError, RoutePlanner, SnapLimitError

    # checked before the work, under the options' names
    for option, value, check in (
        ("--simplify-m", args.simplify_m, positive_metres),
        ("--robot-radius", args.robot_radius, robot_radius),
        ("--entry-m", args.entry_m, nonnegative_metres),
    ):
        if value is not None:
            check(option, value)
    if args.max_snap_m is not None and not args.max_snap_m >= 0:  # also NaN; inf is None
        raise ValueError(
            "--max-snap-m: expected a number of metres >= 0, or none or inf for no limit, "
            f"received {args.max_snap_m!r}"
        )
    if args.simplify_m is not None and not args.out:  # it thins the file written
        raise ValueError("--simplify-m: only used with -o, which was not given")
    if args.out and os.path.realpath(args.out) == os.path.realpath(args.graph):
        raise ValueError(f"-o: writing the route to {args.out} would overwrite the graph file")
    if args.out:
        suffix = Path(args.out).suffix.lower()
        if suffix not in (".geojson", ".json"):
            raise ValueError(
                f"-o: expected a .geojson or .json file (the route is written as GeoJSON), "
                f"received {args.out!r}"
            )
        check_outputs(
            planned([args.out], args.graph), command="route", option=OUT_OPTION, names_file=True
        )
        output_file(args.out, name="-o")  # can be written: checked before the route
    if not args.map and _map_options_given(args):
        raise ValueError(
            f"{', '.join(_map_options_given(args))}: only used with --map, which was not given"
        )
    graph_path = graph_file("graph", args.graph)  # named as the command names it
    if graph_path.suffix.lower() not in GRAPH_FORMATS:
        *most, last = GRAPH_FORMATS
        raise ValueError(
            f"graph: expected a {', '.join(most)} or {last} file, received {args.graph}"
        )
    graph = load_graph(graph_path)
    occupancy = None
    if args.map:
        kw = map_options(args)  # its errors name their options
        try:
            occupancy = load_option_map(args.map, kw)
        except (ValueError, OSError) as exc:  # they name the file; the user gave --map
            if type(exc).__module__ != "builtins":  # a subclass keeps its own arguments
                raise
            raise type(exc)(f"--map: {exc}") from None
        if args.robot_radius is None and graph.graph.get("robot_radius_m") is None:
            raise ValueError(
                "--robot-radius: expected the robot radius in metres with --map (the graph "
                "is not a route graph: it records none), received none"
            )
        # the snap and entry distances are in metres: say when the resolution was assumed
        print(map_line(args.map, occupancy, assumed_resolution_note(args)))
        missing = unrecorded_grid(graph.graph, quote="")
        if missing:  # a graph made elsewhere, or its attributes dropped: in --map's words
            print(
                f"note       the graph records no {missing}: --map cannot be checked to be "
                "its map by that"
            )
    frame = "pixel" if args.pixel else "world"
    try:
        with warnings.catch_warnings():  # the planner's own warning of it, noted above
            warnings.filterwarnings("ignore", "occupancy: the graph records no", UserWarning)
            planner = RoutePlanner(
                graph, occupancy=occupancy, robot_radius_m=args.robot_radius, entry_m=args.entry_m
            )
    except ValueError as exc:  # the planner names its parameter; the user gave the option
        text = str(exc)
        for name, option in (("occupancy", "--map"), ("robot_radius_m", "--robot-radius")):
            if text.startswith(f"{name}: "):
                raise ValueError(f"{option}: {text.removeprefix(f'{name}: ')}") from None
        raise
    try:
        route = planner.route(
            tuple(args.start), tuple(args.goal), frame=frame, max_snap_m=args.max_snap_m
        )
    except NoRouteError as exc:
        print(f"topojax route: {exc}", file=sys.stderr)
        return 1
    except SnapLimitError as exc:  # the planner names max_snap_m; the user gave the option
        limit = f"--max-snap-m {exc.limit_m:g}"
        raise ValueError(f"--{exc.worded(limit, 'a larger --max-snap-m, or none')}") from None
    except ValueError as exc:  # the planner names start and goal; the user gave --start
        text = str(exc)
        if not text.startswith(("start: ", "goal: ")):
            raise
        raise ValueError(f"--{text}") from None
    print(
        f"route      {route.length_m:.2f} m along the graph, "
        f"{counted(len(route.pixels), 'pixel')}, "
        f"{counted(len(route.vertices), 'vertex', 'vertices')}, "
        f"{counted(len(route.edges), 'edge')}"
    )
    print(f"snapped    start {route.start_snap_m:.3f} m, goal {route.goal_snap_m:.3f} m away")
    for text in _unchecked(route, occupancy is not None):
        print(f"note       {text}")
    for text in _unsafe(route, occupancy is not None):
        warnings.warn(text, UserWarning, stacklevel=2)
    if args.out:
        _write_route(route, args)
    return 0


def _write_route(route, args) -> None:
    """Write ``route`` to ``-o`` as GeoJSON, thinned by ``--simplify-m`` (warned of where
    wider than the route's least clearance), and record it in the folder's record."""
    from .._fs import atomic_write_bytes

    if args.simplify_m is not None and args.simplify_m > route.min_clearance_m:
        warnings.warn(  # a NaN clearance (none recorded) compares False: nothing to say
            f"--simplify-m {args.simplify_m:g} m is more than the route's least clearance, "
            f"{route.min_clearance_m:.3f} m: the written route's straight segments may "
            "cross obstacles",
            UserWarning,
            stacklevel=3,
        )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(route.to_geojson(tolerance_m=args.simplify_m))
    atomic_write_bytes(out, text.encode("utf-8"))
    record_outputs(planned([out], args.graph), command="route")
    print(f"wrote      {out}")
