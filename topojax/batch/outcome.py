"""The record of a map whose CPU stage ended: its counts, and why it is empty or what to
heed (the notes of :attr:`MapRecord.message`)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from ..maps.classify import wall_warning
from .inputs import ROUTE_FORMATS
from .records import MapRecord, empty_reason, no_room_reason
from .worker import _CpuResult, no_nav2_note, resolution_note


def counted_record(rec: MapRecord, res: _CpuResult) -> MapRecord:
    """``rec`` with the counts, times and files of the CPU stage's result ``res``."""
    return replace(
        rec,
        vertices=res.vertices,
        edges=res.edges,
        components=res.components,
        total_length_m=res.total_length_m,
        route_vertices=res.route_vertices,
        route_edges=res.route_edges,
        route_components=res.route_components,
        rooms=res.rooms,
        doors=res.doors,
        t_thinning_s=res.t_thinning_s,
        t_graph_s=res.t_graph_s,
        t_write_s=res.t_write_s,
        outputs=tuple(res.files),
    )


def noted_record(
    rec: MapRecord,
    res: _CpuResult,
    *,
    path: Path | None,
    classes: tuple[int, int | None],
    wall: float | None,
    formats: tuple[str, ...],
    written: bool,
    map_options: dict[str, Any] | None,
) -> MapRecord:
    """``rec`` (counted, of a map without error) with its status and notes: why its graph,
    route graph or rooms are empty, its warnings, and the graph itself.

    ``path`` is the map file (None for a loaded map), ``classes`` its occupied and free
    pixels, ``wall`` its wall share, ``formats`` the batch's, ``written`` whether it writes
    files, ``map_options`` ``load_map``'s keyword arguments."""
    warning = wall_warning(wall)
    # the paper's graph counts unless only route graphs or rooms were asked for
    paper = not written or not set(formats) <= {*ROUTE_FORMATS, "rooms"}
    mode = (map_options or {}).get("mode")
    notes = (
        [] if res.vertices or not paper else [empty_reason(*classes, mode=mode, pruned=res.pruned)]
    )
    notes += [no_room_reason(classes[1], mode=mode)] if res.rooms == 0 else []
    notes += [res.nav2_note] if res.nav2_note else []
    notes += [res.route_note] if res.route_note else []
    notes += no_nav2_note(res.no_nav2)
    notes += [warning] if warning else []
    notes += resolution_note(path, map_options, rec.resolution_m)
    empty = (paper and not res.vertices) or res.route_vertices == 0 or res.rooms == 0
    return replace(
        rec,
        status="empty" if empty else rec.status,
        message="; ".join(notes),  # why it is empty, and any warning
        graph=res.graph,
        route_graph=res.route_graph,
    )
