"""``topojax route-graph``: the route graph of one map for a round robot."""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from .._fs import refuse_non_files
from ._options import (
    _option_named,
    add_map_options,
    add_snap_option,
    assumed_resolution_note,
    load_option_map,
    map_line,
    map_options,
    snap_option,
)
from ._outputs import (
    OUT_OPTION,
    check_outputs,
    output_stem,
    planned,
    record_outputs,
    remove_earlier_outputs,
)


def add_command(subparsers) -> None:
    """Register the ``route-graph`` subcommand on an ``argparse`` subparsers object."""
    p = subparsers.add_parser(
        "route-graph",
        help="a sparse, safe, covering route graph of one map for a round robot",
        description="Build the route graph of a map (ROS map_server YAML, or a PGM/PNG/JPG "
        "image) for a round robot: every edge keeps the robot's radius from anything not "
        "known free, every feasible point lies within --snap-m of the graph, one piece per "
        "region the robot can reach. Writes STEM_route.{graphml,json,geojson}; no other "
        "option is needed on a real map.",
    )
    p.add_argument("map", help="map file: .yaml/.yml (map_server), .pgm, .png, .jpg, ...")
    p.add_argument("-o", "--out", default="out", help="output folder (default: out)")
    p.add_argument(
        "--robot-radius",
        dest="robot_radius_m",
        type=float,
        default=0.3,
        metavar="M",
        help="robot radius in metres (default 0.3)",
    )
    add_snap_option(p)
    add_map_options(p)
    p.add_argument("--plot", action="store_true", help="also write STEM_route.png")
    p.add_argument(
        "--nav2", action="store_true", help="also write STEM_route_nav2.geojson (Nav2 Route Server)"
    )
    p.add_argument(
        "--mcap",
        metavar="FILE",
        help="also write a ROS 2 MCAP recording (FILE.mcap, for Foxglove, RViz and ros2 bag "
        "play): the map on /map, the route graph on /route_graph (needs rosbags: pip "
        "install 'topojax[bags]')",
    )
    p.add_argument(
        "--evaluate",
        action="store_true",
        help="also score the graph (success, stretch, coverage; see docs) into "
        "STEM_route_report.json",
    )
    p.set_defaults(handler=_cmd_route_graph, runs_kernels=False)


def _files(stem: str, args) -> list[str]:
    names = [f"{stem}_route{s}" for s in (".graphml", ".json", ".geojson")]
    names += [f"{stem}_route.png"] * bool(args.plot)
    names += [f"{stem}_route_nav2.geojson"] * bool(args.nav2)
    names += [f"{stem}_route_report.json"] * bool(args.evaluate)
    return names


def _cmd_route_graph(args) -> int:
    from .._fs import output_folder, refuse_overwriting_inputs
    from .._validate import robot_radius
    from .._words import counted
    from ..io import save_graph
    from ..routegraph import RouteGraphConfig
    from ..routegraph.build import unwarned_route_graph
    from ..routegraph.scale import check_scale

    radius = robot_radius("--robot-radius", args.robot_radius_m, allow_zero=False)
    snap_m = snap_option(args.snap_m)
    config = RouteGraphConfig(robot_radius_m=radius, snap_m=snap_m)
    out = Path(args.out)
    stem = output_stem(args.map)
    targets = [out / name for name in _files(stem, args)]
    refuse_overwriting_inputs([Path(args.map)], targets, option="--out")
    check_outputs(planned(targets, args.map), command="route-graph", option=OUT_OPTION)
    refuse_non_files(targets, name=OUT_OPTION)
    if args.mcap is not None:
        from ..io.mcap import mcap_path

        mcap_path(args.mcap, name="--mcap")  # an .mcap file name, not a folder
        check_outputs(
            planned([args.mcap], args.map), command="route-graph", option="--mcap", names_file=True
        )
    kw = map_options(args)  # its errors name their options
    occupancy = load_option_map(args.map, kw)
    check_scale(
        config,
        occupancy.resolution_m,
        "--robot-radius",
        "--snap-m",
        resolution_name="map resolution (--resolution or the map's own)",
    )
    t0 = time.perf_counter()
    try:
        graph = unwarned_route_graph(occupancy, config=config)  # its note: printed below
    except ValueError as exc:  # e.g. a --snap-m too small for the map's open space
        raise _option_named(exc, "snap_m", "--snap-m") from None
    seconds = time.perf_counter() - t0
    output_folder(out, name="--out")
    written = [
        save_graph(graph, out / f"{stem}_route{s}") for s in (".graphml", ".json", ".geojson")
    ]
    if args.plot:
        written.append(_picture(occupancy, graph, out / f"{stem}_route.png"))
    note = graph.graph.get("note")
    if args.nav2 and graph.number_of_edges():
        from ..io import save_nav2_graph

        written.append(save_nav2_graph(graph, out / f"{stem}_route_nav2.geojson"))
    elif args.nav2:  # no file of an earlier run either
        (out / f"{stem}_route_nav2.geojson").unlink(missing_ok=True)
        note += "; no Nav2 file (the Route Server needs an edge)"
    if args.mcap is not None:
        written.append(_recording(occupancy, graph, args.mcap))
    components = _components(graph)
    print(map_line(args.map, occupancy, assumed_resolution_note(args)))
    print(
        f"route graph {counted(graph.number_of_nodes(), 'vertex', 'vertices')}, "
        f"{counted(graph.number_of_edges(), 'edge')}, {counted(components, 'component')}, "
        f"robot radius {radius:g} m; {seconds:.2f} s"
    )
    if note:
        print(f"note       {note}")
    if args.evaluate:
        from ..routegraph import evaluate_route_graph

        report = evaluate_route_graph(
            graph,
            occupancy,
            radius,
            snap_m=config.snap_m,
            min_region_m2=config.min_region_m2,
            generation_s=seconds,
        )
        path = out / f"{stem}_route_report.json"
        from .._fs import atomic_write_bytes

        atomic_write_bytes(path, json.dumps(report.as_dict(), indent=1).encode("utf-8"))
        written.append(path)
        print(_evaluation_line(report, config.min_region_m2))
    every = argparse.Namespace(plot=True, nav2=True, evaluate=True)
    possible = [out / name for name in _files(stem, every)]
    for line in remove_earlier_outputs(possible, written, args.map, command="route-graph"):
        print(line)
    record_outputs(planned(written, args.map), command="route-graph", map_options=kw)
    print("wrote      " + ", ".join(str(p) for p in written))
    return 0


def _evaluation_line(report, min_region_m2: float) -> str:
    """The printed line of the route graph's ``report``; a measure the graph leaves
    undefined (NaN in the report) says why in words."""
    if not report.pairs:  # its rates are NaN: say why rather than print them
        return (
            "evaluation no route to score: no feasible region of at least "
            f"{min_region_m2:g} m2 and 2 pixels for a robot of radius "
            f"{report.robot_radius_m:g} m"
        )

    def measure(name: str, text: str, value: float, why: str) -> str:
        return f"{name} {text}" if math.isfinite(value) else f"{name}: {why}"

    stretch = f"{report.stretch_median:.3f} (p90 {report.stretch_p90:.3f})"
    no_length = "no edges" if not report.edges else "no edge length"
    parts = [
        f"success {100 * report.success_rate:.1f} %",
        measure("stretch median", stretch, report.stretch_median, "no route found"),
        measure("unsafe share", f"{report.unsafe_share:.3f}", report.unsafe_share, no_length),
        measure(
            "uncovered share",
            f"{report.uncovered_share:.4f}",
            report.uncovered_share,
            "no feasible region",
        ),
    ]
    return "evaluation " + ", ".join(parts)


def _components(graph) -> int:
    import networkx as nx

    return nx.number_connected_components(graph) if graph.number_of_nodes() else 0


def _picture(occupancy, graph, path: Path) -> Path:
    from .._fs import atomic_write_bytes
    from ..plotting import route_graph_png

    atomic_write_bytes(path, route_graph_png(graph, occupancy))
    return path


def _recording(occupancy, graph, path) -> Path:
    """Write the MCAP recording of the map and its route graph; returns its path."""
    from ..io.mcap import McapRecorder

    with McapRecorder(path) as rec:
        rec.add_map(occupancy)
        rec.add_route_graph(graph)
    return rec.path
