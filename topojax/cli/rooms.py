"""``topojax rooms``: the rooms and doorways of one map."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from .._fs import refuse_non_files
from ._options import (
    MAP_OPTIONS_TO_CHECK,
    add_map_options,
    add_room_options,
    assumed_resolution_note,
    load_option_map,
    map_line,
    map_options,
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


def add_command(subparsers) -> None:
    """Register the ``rooms`` subcommand on an ``argparse`` subparsers object."""
    p = subparsers.add_parser(
        "rooms",
        help="split one map into rooms joined by doorways",
        description="Split the known free space of a map (ROS map_server YAML, or a "
        "PGM/PNG/JPG image) into rooms joined by doorways. Writes STEM_rooms.geojson (room "
        "polygons and doorway lines in map-frame metres), STEM_rooms.png (the room labels "
        "in colour), STEM_rooms.graphml and STEM_rooms.json (the room graph), and prints a "
        "summary.",
    )
    p.add_argument("map", help="map file: .yaml/.yml (map_server), .pgm, .png, .jpg, ...")
    p.add_argument("-o", "--out", default="out", help="output folder (default: out)")
    p.add_argument(
        "--plot", action="store_true", help="also write STEM_rooms_plot.png (rooms over the map)"
    )
    add_map_options(p)
    add_room_options(p)
    p.set_defaults(handler=_cmd_rooms, runs_kernels=False)


def room_files(stem: str) -> list[str]:
    """The names of the room files (``topojax rooms``, ``topojax graph --rooms``) of a map
    called ``stem``."""
    from ..io import ROOM_FILE_SUFFIXES

    return [f"{stem}{suffix}" for suffix in ROOM_FILE_SUFFIXES]


def _files(stem: str, args) -> list[str]:
    """The names of the files ``topojax rooms`` writes for a map called ``stem``."""
    return room_files(stem) + [f"{stem}_rooms_plot.png"] * bool(args.plot)


def _cmd_rooms(args) -> int:
    from .._fs import output_folder, refuse_overwriting_inputs
    from ..io import save_room_files
    from ..rooms import segment_rooms

    config = room_config(args)  # checked before any work
    out = Path(args.out)
    stem = output_stem(args.map)
    targets = [out / name for name in _files(stem, args)]
    refuse_overwriting_inputs([Path(args.map)], targets, option="--out")
    check_outputs(planned(targets, args.map), command="rooms", option=OUT_OPTION)
    refuse_non_files(targets, name=OUT_OPTION)
    occupancy = load_option_map(args.map, map_options(args))
    t0 = time.perf_counter()
    seg = segment_rooms(occupancy, config=config)
    seconds = time.perf_counter() - t0
    output_folder(out, name="--out")
    written = save_room_files(seg, out / stem)
    if args.plot:
        written.append(_picture(seg, out / f"{stem}_rooms_plot.png"))
    # areas and widths are in metres: say when the resolution was not the file's own
    print(map_line(args.map, occupancy, assumed_resolution_note(args)))
    first = "the process's first call: it includes loading or compiling the kernels"
    for line in room_lines(seg, occupancy, seconds=seconds, timing_note=first):
        print(line)
    possible = [out / name for name in _files(stem, argparse.Namespace(plot=True))]
    for line in remove_earlier_outputs(possible, written, args.map, command="rooms"):
        print(line)
    record_outputs(planned(written, args.map), command="rooms", map_options=map_options(args))
    print("wrote      " + ", ".join(str(p) for p in written))
    return 0


def room_lines(
    seg, occupancy, *, seconds: float, time_label: str = "time (ms)", timing_note: str = ""
) -> list[str]:
    """The summary of a segmentation: rooms, doors and its stages' time (ms, the line
    ``time_label``, ending in ``timing_note`` in brackets where one is given and a stage
    ran), and a note when the map gave no room."""
    from .._words import counted

    rooms, doors = seg.rooms, seg.doors
    line = f"rooms      {counted(len(rooms), 'room')}"
    if rooms:
        areas = [r.area_m2 for r in rooms]
        spread = f"{min(areas):.1f}-{max(areas):.1f} m2 each"
        line += f" ({sum(areas):.1f} m2{f' in all, {spread}' if len(areas) > 1 else ''})"
    line += f", {counted(len(doors), 'door')}"
    if doors:
        widths = [d.width_m for d in doors]
        wide = f"{min(widths):.2f}" if len(widths) == 1 else f"{min(widths):.2f}-{max(widths):.2f}"
        line += f" ({wide} m wide)"
    stages = ", ".join(f"{k} {1e3 * v:.1f}" for k, v in seg.timings_s.items())
    timing = f"total {1e3 * seconds:.1f}"
    if stages:  # no stage ran (nothing loaded or compiled) on a map without free space
        timing = f"{stages}; {timing}" + (f" ({timing_note})" if timing_note else "")
    lines = [line, f"{time_label:<11}{timing}"]
    if not rooms:
        n_free = int(occupancy.free.sum())
        lines.append(
            f"note       no room found: the map has {n_free} free pixels as classified; "
            f"check {MAP_OPTIONS_TO_CHECK} or --min-isolated-room-m2"
        )
    return lines


def _picture(seg, path: Path) -> Path:
    from .._fs import atomic_write_bytes
    from ..plotting import rooms_png

    atomic_write_bytes(path, rooms_png(seg))
    return path
