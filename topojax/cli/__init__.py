"""Command line: ``topojax graph``, ``topojax demo``, ``topojax route``,
``topojax route-graph``, ``topojax rooms``, ``topojax replay``, ``topojax batch``,
``topojax view``."""

from __future__ import annotations

import argparse
import os
import sys

from .. import __version__
from . import batch, replay, rooms, route_graph, view
from ._options import (
    add_map_options,
    add_nav2_options,
    add_pipeline_options,
    add_room_options,
    add_sigma_options,
)
from .graph import _cmd_demo, _cmd_graph
from .route import _cmd_route

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The ``topojax`` argument parser; building it imports no JAX, numba or readers."""
    parser = argparse.ArgumentParser(
        prog="topojax",
        description="Topology (route) graphs from 2-D robot maps via Gaussian distance maps.",
        epilog="Compiled JAX kernels are kept in $XDG_CACHE_HOME/topojax/jax (default "
        "~/.cache/topojax/jax) unless JAX_COMPILATION_CACHE_DIR is set; "
        "TOPOJAX_NO_JAX_CACHE=1 turns that off.",
    )
    parser.add_argument(
        "--version", action="version", version=f"%(prog)s {__version__}", help="print the version"
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser(
        "graph",
        help="build the topology graph of one map file",
        description="Build the topology graph of a map (ROS map_server YAML, or a "
        "PGM/PNG/JPG image) and write GraphML, JSON and GeoJSON.",
    )
    p.add_argument("map", help="map file: .yaml/.yml (map_server), .pgm, .png, .jpg, ...")
    p.add_argument("-o", "--out", default="out", help="output folder (default: out)")
    p.add_argument("--plot", action="store_true", help="also write a PNG overlay")
    p.add_argument("--stages", action="store_true", help="also write a PNG of every stage")
    add_map_options(p)
    add_sigma_options(p)
    add_nav2_options(p, "STEM_nav2.geojson")
    p.add_argument(
        "--rooms",
        action="store_true",
        help="also split the map into rooms: write STEM_rooms.{geojson,png,graphml,json} "
        "and give every vertex its room and every edge the rooms and doors it passes (in "
        "the graph files and the Nav2 graph); with --plot the rooms are drawn too",
    )
    p.add_argument(
        "--mcap",
        metavar="FILE",
        help="also write a ROS 2 MCAP recording (FILE.mcap, for Foxglove, RViz and "
        "ros2 bag play): the map on /map, the graph on /topology, with --rooms the rooms "
        "on /rooms (needs rosbags: pip install 'topojax[bags]')",
    )
    p.add_argument(
        "--view",
        action="store_true",
        help="also write STEM_view.html: the interactive view of the map, its stages and "
        "graph (with --rooms the rooms; see topojax view)",
    )
    add_pipeline_options(p)
    add_room_options(p, only_with="--rooms")
    p.set_defaults(handler=_cmd_graph)

    p = sub.add_parser(
        "demo",
        help="run the pipeline on a bundled real map",
        description="Run the full pipeline on a map bundled with topojax (the paper's maps), "
        "write the graph and pictures, and print a summary.",
    )
    p.add_argument("--map", choices=("intel", "office", "a_scan"), default="intel")
    p.add_argument("-o", "--out", default="out", help="output folder (default: out)")
    add_pipeline_options(p)
    p.set_defaults(handler=_cmd_demo)

    p = sub.add_parser(
        "route",
        help="shortest route between two points on a saved graph",
        description="Snap a start and a goal point to a saved topology graph (GraphML, "
        "JSON or GeoJSON from `topojax graph`) and print the shortest route between them "
        "along its corridors; optionally write it as a GeoJSON LineString.",
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
        type=float,
        default=5.0,
        metavar="M",
        help="fail if a point is more than M metres from the graph (default 5)",
    )
    p.add_argument(
        "--map",
        metavar="MAP",
        help="the graph's map (as `topojax graph` reads it): each end may then join the "
        "graph at the nearest point of any edge it sees within the graph's snap distance "
        "(1 m if it has none), whichever gives the shortest route; the robot radius is the "
        "graph's (a route graph's) or --robot-radius; the map options below say how it is "
        "read",
    )
    p.add_argument(
        "--robot-radius",
        type=float,
        metavar="M",
        help="with --map: the robot radius in metres (default: the graph's)",
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
        help="write waypoints that keep every route pixel within M metres instead of every "
        "pixel (default: every pixel)",
    )
    p.set_defaults(handler=_cmd_route, runs_kernels=False)

    route_graph.add_command(sub)
    rooms.add_command(sub)
    replay.add_command(sub)
    batch.add_command(sub)
    view.add_command(sub)
    return parser


def _use_compilation_cache() -> None:
    """Keep the compiled JAX kernels on disk between runs of the command.

    Each run of the command is a fresh process; without a persistent cache it compiles
    the kernels again (about half a second of a ``topojax graph`` run).  JAX's own
    settings win: ``JAX_COMPILATION_CACHE_DIR`` chooses the directory (default
    ``$XDG_CACHE_HOME/topojax/jax``, i.e. ``~/.cache/topojax/jax``) and
    ``JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS`` the threshold (default here 0: every
    kernel is kept); ``TOPOJAX_NO_JAX_CACHE=1`` turns the cache off.  Library calls never
    change JAX's settings; only the command does.
    """
    if os.environ.get("TOPOJAX_NO_JAX_CACHE", "") not in ("", "0"):
        return
    import jax

    if not os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        jax.config.update("jax_compilation_cache_dir", os.path.join(base, "topojax", "jax"))
    if not os.environ.get("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"):
        # the kernels compile in well under JAX's default threshold of one second, so
        # without this nothing would be cached
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``topojax`` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "runs_kernels", True):  # route only reads a graph: no JAX
        _use_compilation_cache()
    try:
        return int(args.handler(args) or 0)
    except (ValueError, TypeError, FileNotFoundError, OSError) as exc:
        print(f"topojax {args.command}: error: {exc}", file=sys.stderr)
        return 2
