"""``topojax graph`` and ``topojax demo``: the full-map pipeline on one map."""

from __future__ import annotations

import json
import time
from pathlib import Path

from .._fs import refuse_non_files
from ._graph_out import (
    emptied_text,
    graph_files,
    map_notes,
    summary_lines,
    write_graph_files,
    write_nav2,
)
from ._options import (
    add_map_options,
    add_nav2_options,
    add_pipeline_options,
    add_room_options,
    add_sigma_options,
    assumed_resolution_note,
    load_option_map,
    map_options,
    nav2_tolerance,
    pipeline_config,
    room_config,
)
from ._outputs import (
    OUT_OPTION,
    check_outputs,
    output_stem,
    planned,
    record_outputs,
    remove_earlier_outputs,
)
from .rooms import room_lines
from .tiled import add_tiled_options, check_tiled_options, cmd_graph_tiled


def add_commands(subparsers) -> None:
    """Register the ``graph`` and ``demo`` subcommands on an ``argparse`` subparsers
    object."""
    p = subparsers.add_parser(
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
    add_tiled_options(p)
    p.set_defaults(handler=_cmd_graph)

    p = subparsers.add_parser(
        "demo",
        help="run the pipeline on a bundled real map",
        description="Run the full pipeline on a map bundled with topojax (the paper's maps), "
        "write the graph and pictures, and print a summary.",
    )
    p.add_argument(
        "--map",
        choices=("intel", "office", "a_scan"),
        default="intel",
        help="bundled map to run on (default: intel)",
    )
    p.add_argument("-o", "--out", default="out", help="output folder (default: out)")
    add_pipeline_options(p)
    p.set_defaults(handler=_cmd_demo)


def _write_outputs(
    result, out_dir: Path, stem: str, *, plot: bool, stages: bool, rooms=None
) -> list[Path]:
    written = write_graph_files(result.graph, out_dir, stem)
    if plot or stages:
        import matplotlib

        matplotlib.use("Agg")
        from .._fs import atomic_write_bytes
        from ..plotting import result_png, stages_png

        if plot:
            atomic_write_bytes(out_dir / f"{stem}.png", result_png(result, rooms=rooms))
            written.append(out_dir / f"{stem}.png")
        if stages:
            atomic_write_bytes(out_dir / f"{stem}_stages.png", stages_png(result))
            written.append(out_dir / f"{stem}_stages.png")
    return written


def _classes_hint(occupancy, result) -> list[str]:
    """A note when the map, as classified, cannot give a graph (no obstacle or no free
    pixel), gave none, or its walls look unknown (grey walls): usually thresholds or a
    pixel convention that do not fit the file; or when the pruning options or
    ``--free-only`` removed every corridor it gave."""
    from ..graph.prune import what_emptied
    from ..maps.classify import wall_share

    counts = tuple(int(m.sum()) for m in (occupancy.occupied, occupancy.free, occupancy.unknown))
    share = wall_share(occupancy.occupied, occupancy.free) if all(counts[:2]) else None
    empty = result.graph.number_of_nodes() == 0
    emptied = what_emptied(result.config.graph, result.skeleton, result.ridges) if empty else ""
    return map_notes(counts, share, empty, emptied=emptied_text(result.config.graph, emptied))


def _cmd_graph(args) -> int:
    from ..pipeline import build_graph

    check_tiled_options(args)
    if args.tiled:
        return cmd_graph_tiled(args)
    tolerance = nav2_tolerance(args)  # checked before the pipeline runs and writes anything
    rooms_config = room_config(args, only_with="--rooms", given=args.rooms)
    stem = output_stem(args.map)
    targets = [Path(args.out) / name for name in _graph_files(stem, args)]
    _check_outputs_spare_inputs(Path(args.map), targets)
    check_outputs(planned(targets, args.map), command="graph", option=OUT_OPTION)
    refuse_non_files(targets, name=OUT_OPTION)
    if args.mcap is not None:
        from ..io.mcap import mcap_path

        mcap_path(args.mcap, name="--mcap")  # an .mcap file name, not a folder
        check_outputs(
            planned([args.mcap], args.map), command="graph", option="--mcap", names_file=True
        )
    occupancy = load_option_map(args.map, map_options(args))
    config = pipeline_config(args, resolution_m=occupancy.resolution_m)
    result = build_graph(occupancy, config=config)
    for line in _classes_hint(occupancy, result):
        print(line)
    seg, notes = None, []
    if rooms_config is not None:
        from ..rooms import assign_rooms, segment_rooms

        t0 = time.perf_counter()
        seg = segment_rooms(result, config=rooms_config)
        assign_rooms(result.graph, seg)  # before any graph file is written
        seconds = time.perf_counter() - t0
        notes += room_lines(seg, occupancy, seconds=seconds, time_label="rooms (ms)")
    written = _write_outputs(
        result, Path(args.out), stem, plot=args.plot, stages=args.stages, rooms=seg
    )
    if seg is not None:
        from ..io import save_room_files

        written += save_room_files(seg, Path(args.out) / stem)
    if args.nav2:
        nav2, nav2_notes = write_nav2(
            result.graph, Path(args.out) / f"{stem}_nav2.geojson", tolerance
        )
        written, notes = written + nav2, notes + nav2_notes
    if args.mcap is not None:
        from ..io.mcap import save_mcap

        written.append(save_mcap(result, args.mcap, rooms=seg))
    if args.view:
        from ..view import write_view

        written.append(write_view(result, Path(args.out) / f"{stem}_view.html", rooms=seg))
    first = "the process's first call: it includes loading or compiling the kernels"
    for line in [
        *summary_lines(
            str(args.map), result, timing_note=first, assumed=assumed_resolution_note(args)
        ),
        *notes,
    ]:
        print(line)
    out = Path(args.out)
    for line in remove_earlier_outputs(
        [out / name for name in graph_files(stem)], written, args.map, command="graph"
    ):
        print(line)
    record_outputs(planned(written, args.map), command="graph", map_options=map_options(args))
    print("wrote      " + ", ".join(str(p) for p in written))
    return 0


def _graph_files(stem: str, args) -> list[str]:
    """The names of the files ``topojax graph`` writes for a map called ``stem``."""
    return graph_files(
        stem,
        plot=args.plot,
        stages=args.stages,
        nav2=args.nav2,
        rooms=bool(args.rooms),
        view=bool(getattr(args, "view", False)),
    )


def _check_outputs_spare_inputs(map_path: Path, targets: list[Path]) -> None:
    """Refuse, before any work, an output folder where a file written would replace the
    input map or the image its YAML refers to (``-o`` being the map's own folder, with
    ``--plot`` writing ``<stem>.png``)."""
    from .._fs import refuse_overwriting_inputs

    refuse_overwriting_inputs([map_path], targets, option="--out")


def _cmd_demo(args) -> int:
    from ..datasets import sample_map, sample_map_path
    from ..pipeline import build_graph

    out = Path(args.out)
    source = sample_map_path(args.map)
    names = [f"{args.map}{s}" for s in (".graphml", ".json", ".geojson", ".png", "_stages.png")]
    summary_path = out / f"{args.map}_summary.json"
    targets = [*(out / name for name in names), summary_path]
    check_outputs(planned(targets, source), command="demo", option=OUT_OPTION)
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
    written = _write_outputs(result, out, f"{args.map}", plot=True, stages=True)
    print(
        f"topojax demo: bundled map '{args.map}' ({sample_map_path(args.map).name}, MIT, "
        "from the IncrementalTopo paper)"
    )
    for line in summary_lines(args.map, result, timing_note="the last warm call"):
        print(line)
    print(
        f"end-to-end first call {1e3 * cold:.0f} ms (includes compilation), "
        f"warm {1e3 * sorted(warm)[1]:.1f} ms (median of 3)"
    )
    summary = {
        "map": args.map,
        "vertices": result.graph.number_of_nodes(),
        "edges": result.graph.number_of_edges(),
        "cold_s": cold,
        "warm_s": sorted(warm)[1],
        "timings_s": result.timings_s,
    }
    from .._fs import atomic_write_bytes

    atomic_write_bytes(summary_path, json.dumps(summary, indent=2).encode("utf-8"))
    print("wrote      " + ", ".join(str(p) for p in [*written, summary_path]))
    record_outputs(planned(targets, source), command="demo")
    return 0
