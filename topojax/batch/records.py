"""One record per map of a batch, and the summary table (CSV, Parquet) of the records."""

from __future__ import annotations

import csv
import io as _io
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .._fs import atomic_write_bytes

__all__ = ["ROOM_COLUMNS", "SUMMARY_COLUMNS", "MapRecord", "summary_columns", "write_summary"]

#: Columns of the summary table, in order.  Times are seconds of wall time spent on the map
#: in each stage; ``t_distance_s`` is the map's share (by tile count) of its group's kernel
#: wall time plus its own clearance/packing; ``t_write_s`` covers the graph files and picture
#: (and, with the ``rooms`` format, the room segmentation and its files, with the ``route``
#: formats, the route graph and its files); ``t_total_s`` is their sum (not the latency,
#: since stages of different maps overlap).
SUMMARY_COLUMNS = (
    "map",
    "path",
    "height",
    "width",
    "resolution_m",
    "vertices",
    "edges",
    "total_length_m",
    "components",
    "route_vertices",
    "route_edges",
    "route_components",
    "t_load_s",
    "t_distance_s",
    "t_thinning_s",
    "t_graph_s",
    "t_write_s",
    "t_total_s",
    "status",
    "message",
)

#: Columns of the room segmentation (the ``rooms`` format): counts of rooms and doorways.
#: The table has them, after ``route_components``, only where a map's rooms were made.
ROOM_COLUMNS = ("rooms", "doors")


@dataclass(frozen=True, kw_only=True)
class MapRecord:
    """What happened to one map of a batch (one row of the summary table).

    Attributes
    ----------
    map : str
        Unique name of the map in the batch; the stem of its output files.
    path : str or None
        Input file (or the ``source`` of an :class:`~topojax.maps.OccupancyMap`).
    height, width : int or None
        Map size in pixels (None when it could not be loaded).
    resolution_m : float or None
        Metres per pixel.
    vertices, edges, components : int or None
        Graph counts (:func:`topojax.graph.graph_summary`; isolated vertices count as
        components).
    total_length_m : float or None
        Sum of the edge lengths in metres.
    route_vertices, route_edges, route_components : int or None
        Counts of the route graph (:func:`topojax.route_graph`) with the ``route`` or
        ``route_nav2`` format, else None.
    rooms, doors : int or None
        Counts of rooms and doorways (:func:`topojax.segment_rooms`) with the ``rooms``
        format, else None (see :data:`ROOM_COLUMNS`).
    t_load_s, t_distance_s, t_thinning_s, t_graph_s, t_write_s, t_total_s : float
        Seconds per stage (see :data:`SUMMARY_COLUMNS`).
    status : {"ok", "empty", "error", "skipped"}
        ``"empty"``: the graph (unless only route graphs or rooms were asked for), or
        the route graph of a ``route`` format, has no vertex, or the ``rooms`` format
        found no room (outputs written; ``message`` says why);
        ``"skipped"``: complete outputs found by ``resume`` (``message`` then repeats
        what the run that wrote them said of an empty map or a warning).
    message : str
        Error message (``"ExceptionType: text"``) or a note; on an ok map empty, or a
        warning (``"warning: ..."``, e.g. walls that read as unknown:
        :func:`topojax.maps.classify.wall_share`).
    outputs : tuple of str
        Files written for this map, relative to ``out_dir`` (manifest last).
    graph : networkx.MultiGraph or None
        The graph itself when ``keep_graphs`` (not in the table).
    route_graph : networkx.MultiGraph or None
        The route graph itself when ``keep_graphs`` with a ``route`` or ``route_nav2``
        format (not in the table).
    """

    map: str
    path: str | None
    height: int | None = None
    width: int | None = None
    resolution_m: float | None = None
    vertices: int | None = None
    edges: int | None = None
    total_length_m: float | None = None
    components: int | None = None
    route_vertices: int | None = None
    route_edges: int | None = None
    route_components: int | None = None
    rooms: int | None = None
    doors: int | None = None
    t_load_s: float = 0.0
    t_distance_s: float = 0.0
    t_thinning_s: float = 0.0
    t_graph_s: float = 0.0
    t_write_s: float = 0.0
    t_total_s: float = 0.0
    status: str = "ok"
    message: str = ""
    outputs: tuple[str, ...] = ()
    graph: Any = field(default=None, repr=False, compare=False)
    route_graph: Any = field(default=None, repr=False, compare=False)

    def row(self) -> dict[str, Any]:
        """The record as a summary-table row (keys :data:`SUMMARY_COLUMNS`, and
        :data:`ROOM_COLUMNS` where its rooms were made)."""
        return {name: getattr(self, name) for name in summary_columns([self])}


def summary_columns(records: Sequence[MapRecord]) -> tuple[str, ...]:
    """The columns of the summary table of ``records``: :data:`SUMMARY_COLUMNS`, with
    :data:`ROOM_COLUMNS` after ``route_components`` where a record has rooms."""
    if all(rec.rooms is None for rec in records):
        return SUMMARY_COLUMNS
    at = SUMMARY_COLUMNS.index("route_components") + 1
    return (*SUMMARY_COLUMNS[:at], *ROOM_COLUMNS, *SUMMARY_COLUMNS[at:])


def totalled(rec: MapRecord) -> MapRecord:
    """A copy of ``rec`` whose ``t_total_s`` is the sum of its stage times."""
    stages = rec.t_load_s + rec.t_distance_s + rec.t_thinning_s + rec.t_graph_s
    return replace(rec, t_total_s=stages + rec.t_write_s)


def _csv_value(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    return str(value)


def drop_summary(out_dir: Path) -> None:
    """Remove the summary table an earlier run left in ``out_dir`` (wrong once a map is
    redone; a run cut short writes none).  ValueError naming ``out_dir`` if a folder is
    where a table goes (it could neither be removed nor replaced)."""
    targets = [out_dir / name for name in ("summary.csv", "summary.parquet")]
    for target in targets:
        if target.is_dir() and not target.is_symlink():
            raise ValueError(
                f"out_dir: {target} is a folder, expected the summary table's file or none "
                "there; remove or rename the folder, or write into another one"
            )
    for target in targets:
        target.unlink(missing_ok=True)


def write_summary(records: Sequence[MapRecord], out_dir: str | Path) -> list[Path]:
    """Write the summary table of a batch, atomically.

    Parameters
    ----------
    records : sequence of MapRecord
        One per map, in the order the rows should appear.
    out_dir : str or Path
        Existing folder; receives ``summary.csv`` and, when ``pyarrow`` is importable,
        ``summary.parquet``, with the columns of :func:`summary_columns` (room and door
        counts where a map's rooms were made; empty in the rows of the others).

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(out_dir)
    if not folder.is_dir():
        raise FileNotFoundError(f"out_dir: expected an existing folder, received {str(folder)!r}")
    buf = _io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    columns = summary_columns(records)
    rows = [{name: getattr(rec, name) for name in columns} for rec in records]
    writer.writerow(columns)
    for row in rows:
        writer.writerow([_csv_value(row[name]) for name in columns])
    written = [folder / "summary.csv"]
    atomic_write_bytes(written[0], buf.getvalue().encode("utf-8"))
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return written
    table = pa.Table.from_pylist(rows, schema=_arrow_schema(pa, columns))
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    written.append(folder / "summary.parquet")
    atomic_write_bytes(written[1], sink.getvalue().to_pybytes())
    return written


def _arrow_schema(pa: Any, columns: Sequence[str]) -> Any:
    types = {
        "map": pa.string(),
        "path": pa.string(),
        "height": pa.int64(),
        "width": pa.int64(),
        "vertices": pa.int64(),
        "edges": pa.int64(),
        "components": pa.int64(),
        "route_vertices": pa.int64(),
        "route_edges": pa.int64(),
        "route_components": pa.int64(),
        "rooms": pa.int64(),
        "doors": pa.int64(),
        "status": pa.string(),
        "message": pa.string(),
    }
    return pa.schema([(name, types.get(name, pa.float64())) for name in columns])


def empty_reason(
    n_occupied: int | None, n_free: int | None, *, mode: str | None = None, pruned: str = ""
) -> str:
    """Why a map's graph is empty, and what to check (the ``message`` of an empty map read
    in ``mode``, the ``map_mode`` given or None); ``pruned`` names what removed every
    corridor of a map that gave some (:func:`topojax.graph.prune.what_emptied`)."""
    if pruned:
        from ..graph.prune import emptied_reason

        return f"empty graph: {emptied_reason(pruned)}"
    if n_occupied == 0 and n_free == 0:
        why = "the map has no occupied and no free pixel as classified"
    elif n_occupied == 0:
        why = "the map has no occupied pixel as classified"
    elif n_free == 0:
        why = "the map has no free pixel as classified"
    else:
        why = "no corridor was found between the obstacles"
    return f"empty graph: {why}; {_check_map(mode)}"


def no_room_reason(n_free: int | None, *, mode: str | None = None) -> str:
    """Why a map has no room (the rooms format's :class:`topojax.RoomConfig`), and what to
    check (``n_free``: its free pixels, where counted)."""
    free = "" if n_free is None else f": the map has {n_free} free pixels as classified"
    smallest = "the smallest room without doorways (min_isolated_room_m2)"
    return f"no room found{free}; {_check_map(mode)}, or {smallest}"


def _check_map(mode: str | None) -> str:
    """What to check of a map read in ``mode`` that gave no graph or no room."""
    convention = (
        "map_mode"
        if mode == "ipa"
        else (
            "map_mode, e.g. 'ipa' for IPA benchmark maps, where every pixel below 250 is "
            "inaccessible"
        )
    )
    return (
        "check the map's thresholds (occupied_thresh, free_thresh, negate) or its pixel "
        f"convention ({convention})"
    )
