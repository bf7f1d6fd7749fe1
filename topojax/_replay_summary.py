"""The record of a replay (``timings.json``) and the summary :func:`topojax.replay` and
``topojax replay`` print."""

from __future__ import annotations

from dataclasses import asdict

from ._replay_skips import ordered
from ._words import counted
from .graph import graph_summary
from .graph.prune import emptied_reason, pruned_by
from .incremental import settings_of, timing_summary

__all__ = ["empty_note", "replay_summary", "route_counts", "route_note", "summary_text"]


def replay_summary(source, mapper, done, progress_at) -> dict:
    """The record of a replay of ``source`` (``timings.json``, to which
    :func:`topojax.replay` adds ``written``): ``done`` is what mapping the log gave."""
    summary_g = graph_summary(done.result.graph)
    routes = done.routes
    return {
        "rooms": None if done.seg is None else done.seg.n_rooms,
        "doors": None if done.seg is None else len(done.seg.doors),
        "route_graph": None if routes is None else route_counts(routes),
        "source": str(source),
        "n_scans": mapper.n_scans,
        "n_skipped": done.skipped.count,
        "skipped_scans": done.skipped.texts,
        "skipped_bounds": done.skipped.bounds,
        "skipped_per_bound": ordered(done.skipped.per_bound),
        "skipped_left_out": done.skipped.left_out,
        "n_tiles": mapper.n_tiles,
        "map_shape": list(done.result.map.shape),
        "vertices": summary_g["n_vertices"],
        "edges": summary_g["n_edges"],
        "wall_s": done.wall_s,
        "final_update_s": done.final_s,
        "final_update": asdict(done.update),
        "timings": timing_summary(done.reports),
        "settings": settings_of(mapper),
        "resumed_after": progress_at.resumed_after,
        "checkpoints": progress_at.checkpoints,
    }


def route_counts(routes) -> dict:
    """The vertices, edges and components of a route graph, and its robot radius."""
    import networkx as nx

    n = routes.number_of_nodes()
    return {
        "vertices": n,
        "edges": routes.number_of_edges(),
        "components": nx.number_connected_components(routes) if n else 0,
        "robot_radius_m": routes.graph["robot_radius_m"],
    }


def empty_note(result) -> list[str]:
    """Why the graph of ``result`` (the final one, with the replay's graph settings) is
    empty where its pruning settings removed every corridor of the skeleton; else none."""
    if result.graph.number_of_nodes() or not result.skeleton.any():
        return []
    pruned = pruned_by(result.config.graph)
    return [f"the graph is empty: {emptied_reason(pruned)}"] if pruned else []


def route_note(done, nav2_tolerance_m) -> list[str]:
    """Why the final route graph (if any) has no edge, as a message naming the Nav2 file
    not written for it (with a ``nav2_tolerance_m``); else none."""
    routes = done.routes
    if routes is None or routes.number_of_edges():
        return []
    note = routes.graph.get("note") or "the route graph has no edge"
    if nav2_tolerance_m is not None:
        note += "; no route_graph_nav2.geojson (the Route Server needs an edge)"
    return [note]


def summary_text(summary: dict) -> str:
    """The printed summary of a replay (:func:`replay`'s record, with its messages)."""
    lines = [
        f"replayed   {counted(summary['n_scans'], 'scan')} of {summary['source']} in "
        f"{summary['wall_s']:.2f} s; map {summary['map_shape'][1]} x "
        f"{summary['map_shape'][0]} px (w x h) in {counted(summary['n_tiles'], 'tile')}",
        f"graph      {counted(summary['vertices'], 'vertex', 'vertices')}, "
        f"{counted(summary['edges'], 'edge')}",
        "loop        calls    mean ms     p50 ms     p99 ms   amortised ms/scan",
    ]
    routes = summary.get("route_graph")
    if routes is not None:
        lines.insert(
            2,
            f"route graph {counted(routes['vertices'], 'vertex', 'vertices')}, "
            f"{counted(routes['edges'], 'edge')}, {counted(routes['components'], 'component')}, "
            f"robot radius {routes['robot_radius_m']:g} m",
        )
    if summary.get("rooms") is not None:
        doors = summary.get("doors")  # a record of an older topojax may not have it
        line = f"rooms      {counted(summary['rooms'], 'room')}"
        lines.insert(2, line if doors is None else f"{line}, {counted(doors, 'door')}")
    if summary.get("resumed_after"):
        lines.insert(
            1,
            f"resumed    after {counted(summary['resumed_after'], 'scan')} of the log: the "
            "time and the loop timings are this run's, of the scans after them",
        )
    for k in ("distance", "splat", "skeleton", "graph", "rooms", "add_scan"):
        s = summary["timings"].get(k)
        if s:
            lines.append(
                f"{k:10s} {s['count']:6d} {s['mean_ms']:10.3f} {s['p50_ms']:10.3f} "
                f"{s['p99_ms']:10.3f} {s['per_scan_ms']:12.4f}"
            )
    for message in summary.get("messages", []):  # a removed file: in the labels' column
        word, _, rest = message.partition(" ")
        lines.append(f"{word:10s} {rest}" if word == "removed" else message)
    return "\n".join(lines)
