"""``topojax view``: the interactive HTML view of a folder of results.

The folder is one that ``topojax graph``, ``demo``, ``rooms``, ``route-graph``,
``replay`` or ``batch`` wrote into.  Each result is found by the names those commands
write: a graph ``STEM.json`` (or ``.graphml``, ``.geojson``), its map (the input the
folder's ``.topojax-outputs.json`` records, ``map.yaml`` of a replay, the map a batch
manifest names), rooms ``STEM_rooms.geojson`` (``map_rooms.geojson`` of a replay), a route
graph ``STEM_route.json`` (``route_graph.json`` of a replay; a batch's route graph
without its graph is drawn over the map of its manifest) and a replay's
``timeline.json.gz``; the routes ``topojax route`` wrote there are left out (told by
the folder's record, or by the one GeoJSON Feature they hold).  One result gives
``view.html``; several give one page each, ``STEM_view.html``, and ``view.html`` lists
them.
"""

from __future__ import annotations

import html
import json
import re
import urllib.parse
from dataclasses import dataclass, field
from pathlib import Path

from ._outputs import RECORD_NAME, check_outputs, planned, read_record, record_outputs

__all__ = ["add_command", "find_results"]

#: Graph file suffixes in the order a result's graph is read.
_GRAPH_SUFFIXES = (".json", ".graphml", ".geojson")
#: Names (endings) of files that are not topology graphs.
_NOT_GRAPHS = (
    ".manifest.json",
    "_rooms.json",
    "_rooms.graphml",
    "_rooms.geojson",
    "_nav2.geojson",
    "_summary.json",
    "_route_report.json",
    "timings.json",
    RECORD_NAME,
)
_TIMELINE = "timeline.json.gz"
#: The commands whose output folders ``topojax view`` reads.
_WRITERS = "graph, demo, rooms, route-graph, replay or batch"


@dataclass
class _Result:
    """One result of a folder: its graph file and what goes with it."""

    stem: str
    graph: Path | None = None
    map: Path | None = None
    map_kwargs: dict = field(default_factory=dict)
    rooms: Path | None = None
    route_graph: Path | None = None
    timeline: Path | None = None
    #: The options that filtered the graph file after the replay's last update (its
    #: record's ``graph_options``): then it is not the timeline's last graph.
    graph_filtered: bool = False
    notes: list[str] = field(default_factory=list)


def _graph_stems(folder: Path, record: dict) -> dict[str, Path]:
    """``{stem: graph file}`` for every graph file of the folder (JSON first; not the
    routes ``topojax route`` wrote)."""
    stems: dict[str, Path] = {}
    for suffix in reversed(_GRAPH_SUFFIXES):
        for path in sorted(folder.glob(f"*{suffix}")):
            entry = record.get(path.name)
            if isinstance(entry, dict) and entry.get("command") == "route":
                continue
            if entry is None and suffix == ".geojson" and _one_feature(path):
                continue  # a route, its record left behind (the files copied, say)
            if path.is_file() and (
                not path.name.endswith(_NOT_GRAPHS) or _recorded_graph(path, record)
            ):
                stems[path.name[: -len(suffix)]] = path
    return stems


#: How a GeoJSON file of one Feature begins (a route, as ``topojax route`` writes it; a
#: graph is a FeatureCollection).
_ONE_FEATURE = re.compile(rb'\s*\{\s*"type"\s*:\s*"Feature"\s*[,}]')


def _one_feature(path: Path) -> bool:
    """Whether the file ``path`` begins as a GeoJSON Feature does (its first bytes)."""
    try:
        with open(path, "rb") as fh:
            return _ONE_FEATURE.match(fh.read(256)) is not None
    except OSError:  # a folder, say: not a graph either way
        return False


def _recorded_graph(path: Path, record: dict) -> bool:
    """Whether the record says ``path`` is the graph file of the map it was made from
    (``STEM`` + a graph suffix, STEM the map's name): so is ``meeting_rooms.json`` of a
    map ``meeting_rooms.png``, whose name ends as a rooms file's does."""
    entry = record.get(path.name)
    if not isinstance(entry, dict) or entry.get("command") not in ("graph", "demo"):
        return False
    source = entry.get("input")
    if not isinstance(source, str) or not source:
        return False
    names = {Path(source).name, Path(source).stem}  # a tile folder's whole name, a file's stem
    return any(path.name == f"{n}{suffix}" for n in names for suffix in _GRAPH_SUFFIXES)


def _recorded_input(record: dict, folder: Path, stem: str) -> tuple[Path | None, dict]:
    """The input a result's files were made from, and the ``load_map`` options it was
    read with (none recorded: the file's own)."""
    for suffix in _GRAPH_SUFFIXES + ("_rooms.geojson",):
        entry = record.get(f"{stem}{suffix}")
        if isinstance(entry, dict) and isinstance(entry.get("input"), str) and entry["input"]:
            options = entry.get("map_options")
            return Path(entry["input"]), dict(options) if isinstance(options, dict) else {}
    return None, {}


def _manifest_map(folder: Path, stem: str) -> tuple[Path | None, dict]:
    """The map a batch manifest ``STEM.manifest.json`` names, and the ``load_map``
    options it was read with (its map mode, ``--resolution``, thresholds, ``--negate``)."""
    try:
        doc = json.loads((folder / f"{stem}.manifest.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None, {}
    path = doc.get("path") if isinstance(doc, dict) else None
    if not isinstance(path, str) or not path:
        return None, {}
    request = doc.get("request") if isinstance(doc.get("request"), dict) else {}
    mode = request.get("map_mode")
    options = request.get("map_options")
    options = dict(options) if isinstance(options, dict) else {}
    return Path(path), {**options, **({"mode": mode} if isinstance(mode, str) else {})}


def find_results(folder: Path) -> list[_Result]:
    """The results in ``folder`` (see the module docstring); empty when there are none."""
    record = read_record(folder)
    stems = _graph_stems(folder, record)
    results: dict[str, _Result] = {}
    replay = (folder / "map.yaml").is_file() and "graph" in stems
    for stem, path in stems.items():
        base = None
        if stem == "route_graph" and replay:
            base = "graph"
        elif stem.endswith("_route") and stem[: -len("_route")] in stems:
            # unless the record says another command made it: the graph of a map
            # named STEM_route is a result of its own
            entry = record.get(path.name)
            if not isinstance(entry, dict) or entry.get("command") in (None, "route-graph"):
                base = stem[: -len("_route")]
        if base is not None:
            results.setdefault(base, _Result(base)).route_graph = path
            continue
        results.setdefault(stem, _Result(stem)).graph = path
    for rooms in sorted(folder.glob("*_rooms.geojson")):
        # as for graphs: a folder or a pipe is no result; nor is a graph so named
        if not rooms.is_file() or _recorded_graph(rooms, record):
            continue
        stem = rooms.name[: -len("_rooms.geojson")]
        if stem == "map" and replay:
            stem = "graph"
        results.setdefault(stem, _Result(stem)).rooms = rooms
    for stem, res in results.items():
        if replay and stem == "graph":
            res.map = folder / "map.yaml"
            if (folder / _TIMELINE).is_file():
                res.timeline = folder / _TIMELINE
            entry = record.get(res.graph.name) if res.graph is not None else None
            res.graph_filtered = isinstance(entry, dict) and bool(entry.get("graph_options"))
            continue
        source, kwargs = _recorded_input(record, folder, stem)
        if source is None:
            source, kwargs = _manifest_map(folder, stem)
        if source is None and stem.endswith("_route"):  # a batch's route graph alone
            source, kwargs = _manifest_map(folder, stem[: -len("_route")])
        if source is None:
            for suffix in (".yaml", ".yml"):
                if (folder / f"{stem}{suffix}").is_file():
                    source = folder / f"{stem}{suffix}"
        res.map, res.map_kwargs = source, kwargs
    return [results[k] for k in sorted(results)]


def _load(result: _Result):
    """The arguments of :func:`topojax.write_view` for one result."""
    from ..io import load_graph, load_rooms

    graph = load_graph(result.graph) if result.graph is not None else None
    occupancy = _load_map(result, graph)
    kwargs: dict = {"title": result.stem}
    if result.rooms is not None:
        kwargs["rooms"] = load_rooms(result.rooms)
        if occupancy is not None:
            _note_rooms_grid(result, kwargs["rooms"], occupancy)
    if result.route_graph is not None:
        kwargs["graphs"] = {"route graph": load_graph(result.route_graph)}
    if result.timeline is not None:
        from ..view import Timeline

        kwargs["timeline"] = Timeline.load(result.timeline)
        if graph is not None:
            _note_timeline(result, kwargs["timeline"], graph)
    if graph is not None:
        return graph, occupancy, kwargs
    if occupancy is None:
        raise ValueError(
            f"{result.rooms}: rooms without their map (the map they were made from is not "
            "recorded or not found)"
        )
    return occupancy, None, kwargs


def _note_timeline(result: _Result, timeline, graph) -> None:
    """Note when the timeline's last graph is not the graph shown (a timeline of another
    run in the folder); the page still shows both.  The command prints the note.  A
    graph the replay filtered (``--free-only``, ``--min-*-m``) differs from its
    timeline's by design: no note."""
    from .._words import counted

    if result.graph_filtered:
        return
    last = timeline.last_counts()
    shown = (graph.number_of_nodes(), graph.number_of_edges())
    if last is not None and last != shown:
        sizes = [
            f"{counted(v, 'vertex', 'vertices')}, {counted(e, 'edge')}" for v, e in (last, shown)
        ]
        result.notes.append(
            f"{result.timeline.name}: its last graph update ({sizes[0]}) is not "
            f"{result.graph.name} ({sizes[1]}): the timeline may come from another run"
        )


def _note_rooms_grid(result: _Result, rooms, occupancy) -> None:
    """Note when the map found is not the one the rooms file records (its shape,
    resolution and origin, which ``load_rooms`` gives with the ``rooms``); the rooms are
    still drawn."""
    from ..maps.occupancy import grid_mismatch

    why = grid_mismatch(rooms.shape, rooms.resolution_m, rooms.origin, occupancy, owner="their")
    if why is not None:
        result.notes.append(
            f"{result.rooms.name}: the rooms were not segmented on the map shown: {why}"
        )


def _load_map(result: _Result, graph):
    """The result's map when it is there and on the graph's grid; else None (a note
    says why)."""
    from ..maps import load_map
    from ..maps.files import said_resolution
    from ..maps.tiled import open_tiled_map

    if result.map is None:
        result.notes.append("the map it was made from is not recorded: graph only")
        return None
    stored = result.map.is_dir()  # a tile folder or a Zarr array (graph --tiled)
    if not (stored or result.map.is_file()):
        result.notes.append(f"its map {result.map} is not there: graph only")
        return None
    try:
        if stored:  # read a window at a time, only where shown
            occupancy = open_tiled_map(result.map, **result.map_kwargs)
        else:  # the command that made the files said that a resolution was assumed
            occupancy = load_map(result.map, **said_resolution(result.map, result.map_kwargs))
    except (ValueError, OSError, TypeError, ImportError) as exc:  # TypeError: options edited
        result.notes.append(f"its map {result.map} cannot be read ({exc}): graph only")
        return None
    grid = _graph_grid(graph)
    if grid is not None and grid != (*occupancy.shape, occupancy.resolution_m):
        result.notes.append(
            f"its map {result.map} ({occupancy.shape[1]} x {occupancy.shape[0]} px (w x h), "
            f"{occupancy.resolution_m:g} m/px) is not the graph's ({grid[1]} x {grid[0]} px, "
            f"{grid[2]:g} m/px): graph only"
        )
        return None
    return occupancy


def _graph_grid(graph) -> tuple[int, int, float] | None:
    """``(H, W, resolution_m)`` a graph records (``shape``, ``resolution_m``), or None."""
    if graph is None:
        return None
    try:
        h, w = (int(v) for v in graph.graph["shape"])
        return h, w, float(graph.graph["resolution_m"])
    except (KeyError, TypeError, ValueError):
        return None


#: The words of write_view's refusal of a large map that name its arguments, and what
#: the command says instead (without its map in the folder, ``--window`` cannot cut one).
_AS_OPTIONS = (
    ("max_pixels=", "--max-pixels "),
    ("a larger max_pixels", "a larger --max-pixels"),
    ("window=(x_min, y_min, x_max, y_max)", "--window X_MIN Y_MIN X_MAX Y_MAX"),
    (
        " (map=: an OccupancyMap, or tj.open_tiled_map(...) of a map on disk, read a window "
        "at a time)",
        " (the map it was made from, in the folder or recorded in its .topojax-outputs.json)",
    ),
)


def _write_one(result: _Result, target: Path, args) -> str:
    from ..view import write_view

    obj, occupancy, kwargs = _load(result)
    if occupancy is not None:
        kwargs["map"] = occupancy
    try:
        write_view(obj, target, window=args.window, max_pixels=args.max_pixels, **kwargs)
    except ValueError as exc:
        text = str(exc)
        if text.startswith("window: "):  # write_view's argument, given as --window
            text = "--window: " + text.removeprefix("window: ")
        for words, option in _AS_OPTIONS:  # write_view's arguments, as the options give them
            text = text.replace(words, option)
        raise ValueError(f"{result.graph or result.rooms}: {text}") from None
    parts = [f"{target} ({target.stat().st_size / 1e6:.2f} MB)"]
    if result.graph is not None:
        parts.append(f"graph {result.graph.name}")
    if occupancy is not None:
        parts.append(f"map {result.map}")
    parts += [p.name for p in (result.rooms, result.route_graph, result.timeline) if p]
    return ": ".join([parts[0], ", ".join(parts[1:])]) + "".join(
        f"\nnote       {n}" for n in result.notes
    )


def _index_page(folder: Path, pages: list[tuple[str, Path]]) -> str:
    items = "\n".join(
        f'<li><a href="{html.escape(urllib.parse.quote(p.name))}">{html.escape(stem)}</a></li>'
        for stem, p in pages
    )
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>topojax views: {html.escape(folder.name)}</title></head>\n"
        f"<body><h1>topojax views of {html.escape(str(folder))}</h1>\n<ul>\n{items}\n</ul>"
        "</body></html>\n"
    )


def _remove_page(page: Path) -> None:
    """Remove an older page (a file; a folder of that name is not the command's)."""
    if page.is_file() or page.is_symlink():
        page.unlink(missing_ok=True)


def _remove_older_pages(folder: Path, record: dict, targets: list[Path]) -> None:
    """Remove the pages an earlier ``topojax view`` wrote into ``folder`` (as its
    ``record`` says) that are not among this run's ``targets``: pages of results that
    are gone, which the index no longer lists.  Prints a line per page removed."""
    kept = {t.name for t in targets}
    for name, entry in sorted(record.items()):
        page = name == "view.html" or name.endswith("_view.html")
        mine = isinstance(entry, dict) and entry.get("command") == "view"
        if page and mine and name not in kept and (folder / name).is_file():
            _remove_page(folder / name)
            print(f"removed    {folder / name}, the page of a result no longer there")


def _subfolders_hint(folder: Path) -> str:
    """Where a ``folder`` without results holds some in subfolders (a batch of maps from
    several folders writes each folder's maps into one), a sentence naming them (the
    first 3) and how to view one; else ""."""
    graphs = (p for p in folder.rglob("*") if p.name.endswith(_GRAPH_SUFFIXES))
    held = sorted({p.parent for p in graphs if p.parent != folder})
    held = [d for d in held if find_results(d)]
    if not held:
        return ""
    more = f" and {len(held) - 3} more" if held[3:] else ""
    return (
        f"; the results are in its subfolders {', '.join(map(str, held[:3]))}{more}: view "
        f"each, e.g. topojax view {held[0]}"
    )


def _cmd_view(args) -> int:
    from .._fs import atomic_write_bytes, output_folder
    from .._validate import int_at_least
    from .._words import counted
    from ..view.window import checked_window

    if args.window is not None:  # checked before any work, named as on the command line
        checked_window(args.window, name="--window")
    int_at_least("--max-pixels", args.max_pixels, 1)
    folder = Path(args.folder)
    if not folder.is_dir():
        raise NotADirectoryError(
            f"OUT_DIR: expected a folder of results (from topojax {_WRITERS}), received "
            f"{folder}, which is {'a file' if folder.exists() else 'not there'}"
        )
    results = find_results(folder)
    if not results:
        found = sorted(p.name for p in folder.iterdir())[:8]
        raise ValueError(
            f"OUT_DIR: no results in {folder}: expected what topojax {_WRITERS} write "
            "(a graph STEM.json / .graphml / .geojson, or rooms STEM_rooms.geojson); "
            f"found {', '.join(found) if found else 'nothing'}{_subfolders_hint(folder)}"
        )
    index = folder / "view.html"
    if len(results) == 1:
        pages = [(results[0].stem, index)]
    else:
        pages = [(r.stem, folder / f"{r.stem}_view.html") for r in results]
    targets = [p for _, p in pages] + ([index] if len(results) > 1 else [])
    check_outputs(planned(targets, folder), command="view", option="OUT_DIR")
    output_folder(folder, name="OUT_DIR")  # takes the pages: checked before any work
    earlier = read_record(folder)  # before this run's pages are recorded
    for target in targets:
        if target.is_dir():
            raise IsADirectoryError(
                f"OUT_DIR: expected to write the page {target}, received a folder of that "
                "name; move it away or remove it first"
            )
    if len(results) == 1:
        try:
            print("wrote      " + _write_one(results[0], index, args))
        except (ValueError, OSError):
            _remove_page(index)  # an older page of it would show what is gone
            raise
        _remove_older_pages(folder, earlier, targets)
        record_outputs(planned(targets, folder), command="view")
        return 0
    written, failed = [], []
    for result, (stem, target) in zip(results, pages, strict=True):
        try:  # one result that cannot be shown does not keep the others from the index
            print("wrote      " + _write_one(result, target, args))
            written.append((stem, target))
        except (ValueError, OSError) as exc:
            failed.append(str(exc))
            _remove_page(target)  # an older page of it would show what is gone
    if written:
        atomic_write_bytes(index, _index_page(folder, written).encode("utf-8"))
        print(f"wrote      {index} (links to {counted(len(written), 'view')})")
    else:
        index.unlink(missing_ok=True)  # an older index would link the pages just removed
    _remove_older_pages(folder, earlier, targets)
    record_outputs(planned(targets, folder), command="view")
    if failed:
        raise ValueError(
            f"OUT_DIR: {len(failed)} of the {counted(len(results), 'result')} in {folder} "
            f"could not be shown{' (the others were written)' if written else ''}:\n  "
            + "\n  ".join(failed)
        )
    return 0


def add_command(subparsers) -> None:
    """Register the ``view`` subcommand on an ``argparse`` subparsers object."""
    p = subparsers.add_parser(
        "view",
        help="write an interactive HTML view of a folder of results",
        description="Write OUT_DIR/view.html: the map, its graph, rooms, route graph and "
        "(for a replay with a timeline) the graph at every update, in one HTML file that "
        "opens in any browser without a server or network. Pan, zoom, switch layers, "
        "hover for attributes, click two points for a route. With several results in the "
        "folder, one STEM_view.html each and view.html listing them. Opens nothing.",
    )
    p.add_argument("folder", metavar="OUT_DIR", help=f"a folder written by {_WRITERS}")
    p.add_argument(
        "--window",
        nargs=4,
        type=float,
        metavar=("X_MIN", "Y_MIN", "X_MAX", "Y_MAX"),
        help="show only this world box (metres) of the map: for maps too large to view whole",
    )
    p.add_argument(
        "--max-pixels",
        type=int,
        default=64_000_000,
        metavar="N",
        help="refuse maps (or windows) of more than N pixels (default 64000000)",
    )
    p.set_defaults(handler=_cmd_view, runs_kernels=False)
