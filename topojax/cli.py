"""Command line: ``topojax graph``, ``topojax demo``, ``topojax route``, ``topojax replay``,
``topojax batch``."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

__all__ = ["main"]


def pipeline_config(args, *, resolution_m: float | None = None):
    """The :class:`PipelineConfig` of the options of :func:`add_pipeline_options`, with
    the Gaussian of :func:`add_sigma_options` where the command has them: ``--sigma-px``
    as given, ``--sigma-m`` through ``resolution_m`` (a command that runs many maps
    passes none and converts per map)."""
    from .config import DistanceConfig, PipelineConfig, SkeletonConfig

    distance = DistanceConfig()
    if getattr(args, "sigma_px", None) is not None:
        distance = DistanceConfig.from_pixels(sigma_px=args.sigma_px)
    elif getattr(args, "sigma_m", None) is not None and resolution_m is not None:
        distance = DistanceConfig.from_metres(sigma_m=args.sigma_m, resolution_m=resolution_m)
    return PipelineConfig(
        distance=distance,
        skeleton=SkeletonConfig(thinning=args.thinning, remove_t=not args.keep_t),
        graph=graph_config(args),
        tile_px=args.tile_px,
    )


def graph_config(args):
    """The :class:`GraphConfig` of the options of :func:`add_graph_options`."""
    from .config import GraphConfig

    return GraphConfig(
        free_space_only=args.free_only,
        min_clearance_m=args.min_clearance_m,
        min_spur_m=args.min_spur_m,
        min_component_m=args.min_component_m,
    )


def add_pipeline_options(p: argparse.ArgumentParser) -> None:
    """Options shared by every command that runs the full-map pipeline (thinning, T
    removal, what to keep of the graph, tiles)."""
    p.add_argument(
        "--thinning",
        choices=("guo_hall", "zhang"),
        default="guo_hall",
        help="thinning algorithm (default: guo_hall, the paper's; zhang = the original code's)",
    )
    p.add_argument("--keep-t", action="store_true", help="do not remove T-junction centres")
    add_graph_options(p)
    p.add_argument("--tile-px", type=int, default=256, help="JAX tile side in pixels")


def add_graph_options(p: argparse.ArgumentParser) -> None:
    """What to keep of the graph: ``--free-only`` and the ``--min-*-m`` pruning options."""
    p.add_argument(
        "--free-only",
        action="store_true",
        help="thin only the ridges in known free space (none in unknown space)",
    )
    p.add_argument(
        "--min-clearance-m",
        type=float,
        default=0.0,
        metavar="M",
        help="remove corridors narrower than M metres from wall to centre, e.g. the robot's "
        "radius (default 0: keep all)",
    )
    p.add_argument(
        "--min-spur-m",
        type=float,
        default=0.0,
        metavar="M",
        help="remove dead-end branches shorter than M metres (default 0: keep all)",
    )
    p.add_argument(
        "--min-component-m",
        type=float,
        default=0.0,
        metavar="M",
        help="remove pieces of graph shorter than M metres in all (default 0: keep all)",
    )


def add_sigma_options(p: argparse.ArgumentParser, *, each_map: str = "") -> None:
    """``--sigma-m`` / ``--sigma-px`` (mutually exclusive): the distance map's Gaussian."""
    scale = p.add_mutually_exclusive_group()
    scale.add_argument(
        "--sigma-m",
        type=float,
        metavar="M",
        help=f"Gaussian sigma of the distance map in metres{each_map}, the support scaled "
        "with it (default: the paper's 64.19 px, 3.2 m at 0.05 m/px; a finer map needs "
        "more pixels)",
    )
    scale.add_argument(
        "--sigma-px", type=float, metavar="P", help="the same in pixels (default 64.19)"
    )


def add_nav2_options(p: argparse.ArgumentParser, name: str) -> None:
    """``--nav2`` (also write the file ``name``: a Nav2 Route Server graph) and its
    ``--nav2-tolerance-m``."""
    p.add_argument(
        "--nav2",
        action="store_true",
        help=f"also write {name}, a route graph for the ROS 2 Nav2 Route Server",
    )
    p.add_argument(
        "--nav2-tolerance-m",
        type=float,
        default=0.1,
        metavar="M",
        help="Nav2 waypoints keep every corridor pixel within M metres (default 0.1)",
    )


def nav2_tolerance(args) -> float | None:
    """The checked ``--nav2-tolerance-m`` when ``--nav2`` is given (else None); the error
    names the option (checked before any work)."""
    if not args.nav2:
        return None
    from .config import _positive_metres

    return _positive_metres("--nav2-tolerance-m", args.nav2_tolerance_m)


def _write_outputs(result, out_dir: Path, stem: str, *, plot: bool, stages: bool) -> list[Path]:
    from .io import output_folder, save_graph

    output_folder(out_dir, name="--out")
    written = []
    for suffix in (".graphml", ".json", ".geojson"):
        written.append(save_graph(result.graph, out_dir / f"{stem}{suffix}"))
    if plot or stages:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from .plotting import plot as plot_result
        from .plotting import plot_stages

        if plot:
            ax = plot_result(result)
            path = out_dir / f"{stem}.png"
            ax.figure.savefig(path, dpi=150, bbox_inches="tight")
            plt.close(ax.figure)
            written.append(path)
        if stages:
            fig = plot_stages(result)
            path = out_dir / f"{stem}_stages.png"
            fig.savefig(path, dpi=110, bbox_inches="tight")
            plt.close(fig)
            written.append(path)
    return written


def _classes_hint(occupancy) -> list[str]:
    """A note when the map, as classified, cannot give a graph (no obstacle or no free
    pixel): usually thresholds or a pixel convention that do not fit the file."""
    n_occ, n_free = int(occupancy.occupied.sum()), int(occupancy.free.sum())
    if n_occ and n_free:
        return []
    n_unknown = int(occupancy.unknown.sum())
    if not n_occ:
        what = "no occupied pixel"
        outcome = "so the graph is empty"
    elif not n_unknown:
        what = "nothing but occupied pixels"
        outcome = "so the graph is empty"
    else:
        what = "no free pixel"
        outcome = "so the graph runs through unknown space only (--free-only: none)"
    return [
        f"note       the map has {what} as classified ({n_occ} occupied, {n_free} free, "
        f"{n_unknown} unknown), {outcome}; check the "
        "thresholds, --negate, or --mode (e.g. --mode ipa for IPA benchmark maps, where "
        "every pixel below 250 is inaccessible)"
    ]


def _summary_lines(name: str, result, *, timing_note: str = "") -> list[str]:
    from .graph import graph_summary

    s = graph_summary(result.graph)
    h, w = result.map.shape
    t = result.timings_s
    return [
        f"map        {name}  ({h} x {w} px, {result.map.resolution_m:g} m/px)",
        f"graph      {s['n_vertices']} vertices ({s['n_junctions']} junctions, "
        f"{s['n_ends']} ends), {s['n_edges']} edges, "
        f"{s['total_length_m']:.1f} m of corridors, {s['n_components']} components",
        "time (ms)  "
        + ", ".join(f"{k} {1e3 * v:.1f}" for k, v in t.items() if k != "total")
        + f"; total {1e3 * t['total']:.1f}"
        + (f" ({timing_note})" if timing_note else ""),
    ]


def _cmd_graph(args) -> int:
    from .maps import load_map
    from .pipeline import build_graph

    kw = {}
    for name in ("resolution_m", "occupied_thresh", "free_thresh", "mode"):
        if getattr(args, name) is not None:
            kw[name] = getattr(args, name)
    if args.negate:
        kw["negate"] = True
    tolerance = nav2_tolerance(args)  # checked before the pipeline runs and writes anything
    stem = Path(args.map).stem
    _check_outputs_spare_inputs(Path(args.map), Path(args.out), stem, args)
    occupancy = load_map(args.map, **kw)
    config = pipeline_config(args, resolution_m=occupancy.resolution_m)
    result = build_graph(occupancy, config=config)
    for line in _classes_hint(occupancy):
        print(line)
    written = _write_outputs(result, Path(args.out), stem, plot=args.plot, stages=args.stages)
    notes = []
    if args.nav2:
        from .io import save_nav2_graph

        try:
            written.append(
                save_nav2_graph(
                    result.graph,
                    Path(args.out) / f"{stem}_nav2.geojson",
                    tolerance_m=tolerance,
                )
            )
        except ValueError as exc:  # a graph without edges, which Nav2 refuses (as replay)
            notes.append(f"note       {stem}_nav2.geojson not written: {exc}")
    first = "the process's first call: it includes loading or compiling the kernels"
    for line in [*_summary_lines(str(args.map), result, timing_note=first), *notes]:
        print(line)
    print("wrote      " + ", ".join(str(p) for p in written))
    return 0


def _check_outputs_spare_inputs(map_path: Path, out: Path, stem: str, args) -> None:
    """Refuse, before any work, an output folder where a file written would replace the
    input map or the image its YAML refers to (``-o`` being the map's own folder, with
    ``--plot`` writing ``<stem>.png``)."""
    from .batch import refuse_overwriting_inputs

    names = [f"{stem}{s}" for s in (".graphml", ".json", ".geojson")]
    names += [f"{stem}.png"] * bool(args.plot) + [f"{stem}_stages.png"] * bool(args.stages)
    names += [f"{stem}_nav2.geojson"] * bool(args.nav2)
    refuse_overwriting_inputs([map_path], [out / n for n in names], option="--out")


def _cmd_demo(args) -> int:
    from .datasets import sample_map, sample_map_path
    from .pipeline import build_graph

    occupancy = sample_map(args.map)
    config = pipeline_config(args)
    t0 = time.perf_counter()
    result = build_graph(occupancy, config=config)  # first call: compiles kernels
    cold = time.perf_counter() - t0
    warm = []
    for _ in range(3):
        t0 = time.perf_counter()
        result = build_graph(occupancy, config=config)
        warm.append(time.perf_counter() - t0)
    out = Path(args.out)
    written = _write_outputs(result, out, f"{args.map}", plot=True, stages=True)
    print(
        f"topojax demo: bundled map '{args.map}' ({sample_map_path(args.map).name}, MIT, "
        "from the IncrementalTopo paper)"
    )
    for line in _summary_lines(args.map, result, timing_note="the last warm call"):
        print(line)
    print(
        f"end-to-end first call {1e3 * cold:.0f} ms (includes compilation), "
        f"warm {1e3 * sorted(warm)[1]:.1f} ms (median of 3)"
    )
    print("wrote      " + ", ".join(str(p) for p in written))
    summary = {
        "map": args.map,
        "vertices": result.graph.number_of_nodes(),
        "edges": result.graph.number_of_edges(),
        "cold_s": cold,
        "warm_s": sorted(warm)[1],
        "timings_s": result.timings_s,
    }
    (out / f"{args.map}_summary.json").write_text(json.dumps(summary, indent=2))
    return 0


def _cmd_route(args) -> int:
    from .io import load_graph
    from .routing import NoRouteError, RoutePlanner

    if args.simplify_m is not None:  # checked before the work, with the option's name
        from .config import _positive_metres

        _positive_metres("--simplify-m", args.simplify_m)
    if args.out and os.path.realpath(args.out) == os.path.realpath(args.graph):
        raise ValueError(f"-o: writing the route to {args.out} would overwrite the graph file")
    graph = load_graph(args.graph)
    frame = "pixel" if args.pixel else "world"
    try:
        route = RoutePlanner(graph).route(
            tuple(args.start), tuple(args.goal), frame=frame, max_snap_m=args.max_snap_m
        )
    except NoRouteError as exc:
        print(f"topojax route: {exc}", file=sys.stderr)
        return 1
    print(
        f"route      {route.length_m:.2f} m along the graph, {len(route.pixels)} pixels, "
        f"{len(route.vertices)} vertices, {len(route.edges)} edges"
    )
    print(f"snapped    start {route.start_snap_m:.3f} m, goal {route.goal_snap_m:.3f} m away")
    if args.out:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(route.to_geojson(tolerance_m=args.simplify_m)))
        print(f"wrote      {out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from .maps import MODES

    parser = argparse.ArgumentParser(
        prog="topojax",
        description="Topology (route) graphs from 2-D robot maps via Gaussian distance maps.",
        epilog="Compiled JAX kernels are kept in $XDG_CACHE_HOME/topojax/jax (default "
        "~/.cache/topojax/jax) unless JAX_COMPILATION_CACHE_DIR is set; "
        "TOPOJAX_NO_JAX_CACHE=1 turns that off.",
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
    p.add_argument(
        "--resolution",
        dest="resolution_m",
        type=float,
        help="m/px for images (default: a PGM's 'm/pix' comment, else 0.05; YAML: its own)",
    )
    p.add_argument("--occupied-thresh", type=float, help="override occupied_thresh")
    p.add_argument("--free-thresh", type=float, help="override free_thresh")
    p.add_argument("--negate", action="store_true", help="image values are occupancy")
    p.add_argument(
        "--mode",
        choices=MODES,
        help="pixel convention (default: the YAML's, else trinary; ipa: free if >= 250, "
        "everything else occupied)",
    )
    add_sigma_options(p)
    add_nav2_options(p, "STEM_nav2.geojson")
    add_pipeline_options(p)
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
        metavar="M",
        help="fail if a point is more than M metres from the graph (default: no limit)",
    )
    p.add_argument("-o", "--out", help="write the route here as GeoJSON")
    p.add_argument(
        "--simplify-m",
        type=float,
        metavar="M",
        help="write waypoints that keep every route pixel within M metres instead of every "
        "pixel (default: every pixel)",
    )
    p.set_defaults(handler=_cmd_route)

    for module in ("incremental", "batch"):
        try:
            mod = __import__(f"topojax.{module}", fromlist=["_add_cli"])
        except ImportError:  # pragma: no cover - optional extras missing
            continue
        if hasattr(mod, "_add_cli"):
            mod._add_cli(sub)
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
    _use_compilation_cache()
    try:
        return int(args.handler(args) or 0)
    except (ValueError, TypeError, FileNotFoundError, OSError) as exc:
        print(f"topojax {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
