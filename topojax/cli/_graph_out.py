"""What ``topojax graph`` writes and prints, with the whole map or ``--tiled``."""

from __future__ import annotations

from pathlib import Path

from ._options import _OPTION_OF, MAP_OPTIONS_TO_CHECK, graph_filters, map_line

#: The graph files of ``topojax graph``: ``STEM`` and each of these.
GRAPH_SUFFIXES = (".graphml", ".json", ".geojson")


def graph_files(
    stem: str,
    *,
    plot: bool = True,
    stages: bool = True,
    nav2: bool = True,
    rooms: bool = True,
    view: bool = True,
) -> list[str]:
    """The names of the files ``topojax graph`` writes into ``--out`` for a map called
    ``stem`` with those options (by default every one it may write)."""
    from .rooms import room_files

    names = [f"{stem}{s}" for s in GRAPH_SUFFIXES]
    names += [f"{stem}.png"] * plot + [f"{stem}_stages.png"] * stages
    names += [f"{stem}_nav2.geojson"] * nav2
    names += room_files(stem) if rooms else []
    names += [f"{stem}_view.html"] * view
    return names


def write_graph_files(graph, out_dir: Path, stem: str) -> list[Path]:
    """Write ``graph`` as ``STEM.graphml``, ``STEM.json`` and ``STEM.geojson`` into
    ``out_dir`` (created; an error names ``--out``)."""
    from .._fs import output_folder
    from ..io import save_graph

    output_folder(out_dir, name="--out")
    return [save_graph(graph, out_dir / f"{stem}{suffix}") for suffix in GRAPH_SUFFIXES]


def write_nav2(graph, path: Path, tolerance_m: float) -> tuple[list[Path], list[str]]:
    """Write ``graph`` for the Nav2 Route Server at ``path``: ``([path], [])``, or
    ``([], [note])`` for a graph Nav2 refuses (one without edges), whose ``path`` of an
    earlier run is removed (it would not match the graph written beside it)."""
    from ..io import save_nav2_graph

    try:
        return [save_nav2_graph(graph, path, tolerance_m=tolerance_m)], []
    except ValueError as exc:  # a graph without edges, which Nav2 refuses (as replay)
        path.unlink(missing_ok=True)
        return [], [f"note       {path.name} not written: {exc}"]


def summary_lines(name: str, result, *, timing_note: str = "", assumed: str = "") -> list[str]:
    """The map, graph and time lines ``topojax graph`` prints for ``result`` (a
    ``TopologyResult`` or a ``TiledResult``)."""
    from .._words import counted
    from ..graph import graph_summary

    s = graph_summary(result.graph)
    t = result.timings_s
    kinds = [counted(s["n_junctions"], "junction"), counted(s["n_ends"], "end")]
    kinds += [counted(s["n_rings"], "ring")] * bool(s["n_rings"])  # so that they add up
    kinds += [f"{s['n_isolated']} isolated"] * bool(s["n_isolated"])
    return [
        map_line(name, result.map, assumed),
        f"graph      {counted(s['n_vertices'], 'vertex', 'vertices')} ({', '.join(kinds)}), "
        f"{counted(s['n_edges'], 'edge')}, {s['total_length_m']:.1f} m of corridors, "
        f"{counted(s['n_components'], 'component')}",
        "time (ms)  "
        + ", ".join(f"{k} {1e3 * v:.1f}" for k, v in t.items() if k != "total")
        + f"; total {1e3 * t['total']:.1f}"
        + (f" ({timing_note})" if timing_note else ""),
    ]


def classes_note(n_occupied: int, n_free: int, n_unknown: int) -> str:
    """The note of a map whose graph is empty, or runs through unknown space only: its
    pixels as classified, and the options to check."""
    if n_occupied and n_free:
        return (
            f"note       the graph is empty: no corridor was found between the "
            f"obstacles ({n_occupied} occupied, {n_free} free pixels as classified); check "
            f"{MAP_OPTIONS_TO_CHECK}"
        )
    if not n_occupied:
        what = "no occupied pixel"
        outcome = "so the graph is empty"
    elif not n_unknown:
        what = "nothing but occupied pixels"
        outcome = "so the graph is empty"
    else:
        what = "no free pixel"
        outcome = "so the graph runs through unknown space only (--free-only: none)"
    return (
        f"note       the map has {what} as classified ({n_occupied} occupied, {n_free} "
        f"free, {n_unknown} unknown), {outcome}; check {MAP_OPTIONS_TO_CHECK}"
    )


def emptied_text(graph_config, emptied: str) -> str:
    """Why a graph (of ``graph_config``) is empty whose map gave corridors, in the
    command's options: ``emptied`` (:func:`topojax.graph.prune.what_emptied`) removed
    them all, the pruning options named without their values; "" for none."""
    from ..graph.prune import FREE_ONLY, emptied_reason

    if emptied and emptied != FREE_ONLY:
        pruned = graph_filters(graph_config)
        emptied = ", ".join(_OPTION_OF[name] for name in pruned if name in _OPTION_OF)
    return emptied_reason(emptied).replace(FREE_ONLY, "--free-only") if emptied else ""


def map_notes(
    counts: tuple[int, int, int], wall_share: float | None, empty: bool, *, emptied: str = ""
) -> list[str]:
    """The notes on a map's pixels as classified (``counts``: occupied, free, unknown) for
    a graph that is ``empty`` or not: :func:`classes_note` where the map cannot give a
    graph or gave none, and a warning where its walls look unknown (``wall_share``, of
    :func:`topojax.maps.classify.wall_share`, low: grey walls).  ``emptied`` says why
    a map that gave corridors has none (:func:`topojax.graph.prune.emptied_reason`, in
    the command's options; the note then says it instead of naming the map's options)."""
    from ..maps.classify import wall_warning

    n_occ, n_free, n_unknown = counts
    if not (n_occ and n_free):
        return [classes_note(n_occ, n_free, n_unknown)]
    warning = wall_warning(wall_share, to_check="--occupied-thresh, --free-thresh or --mode")
    notes = [f"note       {warning}"] if warning else []
    if empty and emptied:
        notes.append(f"note       the graph is empty: {emptied}")
    elif empty:
        notes.append(classes_note(n_occ, n_free, 0))
    return notes
