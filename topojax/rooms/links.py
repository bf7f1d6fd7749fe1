"""Rooms on a topology graph: :func:`assign_rooms` gives every vertex its room and every
edge the rooms it passes and the doors it crosses."""

from __future__ import annotations

import networkx as nx
import numpy as np

from .._validate import instance_of, nx_graph, pixel_rows
from ..maps.occupancy import map_mismatch
from .model import RoomSegmentation

__all__ = ["assign_rooms"]


def _nearest_room(labels: np.ndarray, pixels: np.ndarray, reach: int = 2) -> int:
    """The room of the first of ``pixels`` (M, 2) that has one, else the most common room
    within ``reach`` pixels of them (vertices on a doorway line, or beside a wall); 0."""
    h, w = labels.shape
    pixels = np.asarray(pixels, np.int64).reshape(-1, 2)
    ok = (pixels[:, 0] >= 0) & (pixels[:, 0] < h) & (pixels[:, 1] >= 0) & (pixels[:, 1] < w)
    pixels = pixels[ok]
    if pixels.size == 0:
        return 0
    here = labels[pixels[:, 0], pixels[:, 1]]
    if (here > 0).any():
        return int(here[here > 0][0])
    found = []
    for p in pixels:
        r0, r1 = max(p[0] - reach, 0), min(p[0] + reach + 1, h)
        c0, c1 = max(p[1] - reach, 0), min(p[1] + reach + 1, w)
        win = labels[r0:r1, c0:c1]
        found.append(win[win > 0])
    near = np.concatenate(found)
    if near.size == 0:
        return 0
    ids, counts = np.unique(near, return_counts=True)
    return int(ids[np.argmax(counts)])


def _door_lookup(seg: RoomSegmentation) -> dict[tuple[int, int], list]:
    """Doors by the pair of rooms they join: ``{(a, b): [(door id, pixels), ...]}``."""
    out: dict[tuple[int, int], list] = {}
    for door in seg.doors:
        out.setdefault(door.rooms, []).append((door.id, np.asarray(door.pixels, np.float64)))
    return out


def _edge_links(labels: np.ndarray, path: np.ndarray, doors: dict) -> tuple[list, list]:
    """Rooms an edge path passes (in order, each once per visit) and doors it crosses."""
    h, w = labels.shape
    path = np.asarray(path, np.int64).reshape(-1, 2)
    ok = (path[:, 0] >= 0) & (path[:, 0] < h) & (path[:, 1] >= 0) & (path[:, 1] < w)
    lab = np.zeros(path.shape[0], np.int64)
    lab[ok] = labels[path[ok, 0], path[ok, 1]]
    idx = np.flatnonzero(lab > 0)
    rooms: list[int] = []
    crossed: list[int] = []
    for k, i in enumerate(idx):
        r = int(lab[i])
        if rooms and rooms[-1] == r:
            continue
        if rooms:
            pair = (min(rooms[-1], r), max(rooms[-1], r))
            where = path[idx[k - 1] : i + 1].astype(np.float64)
            best, best_d = None, np.inf
            for door_id, pix in doors.get(pair, ()):
                d = np.min(np.abs(where[:, None, :] - pix[None, :, :]).max(axis=2))
                if d < best_d:
                    best, best_d = door_id, d
            if best is not None:
                crossed.append(int(best))
        rooms.append(r)
    return rooms, crossed


def assign_rooms(graph: nx.Graph, seg: RoomSegmentation) -> nx.Graph:
    """Write the rooms of ``seg`` onto a topology graph of the same map, in place.

    Parameters
    ----------
    graph : networkx graph
        A :func:`topojax.build_graph` (or route) graph: vertices with ``pixels`` or
        ``pixel`` (row, col), edges with ``path`` (K, 2) pixels.
    seg : RoomSegmentation
        Rooms of the same map.

    Returns
    -------
    networkx graph
        ``graph``, whose vertices now carry ``room`` (int, 0 outside every room) and edges
        ``rooms`` (list of room ids in the order the path passes them) and ``doors`` (list
        of the door ids it crosses).  The graph attribute ``rooms`` holds the number of
        rooms.

    Raises
    ------
    TypeError, ValueError
        For a ``seg`` that is not a RoomSegmentation, or a graph of another map (its
        recorded shape, resolution or origin); nothing is written then.
    """
    nx_graph("graph", graph, undirected=False)
    instance_of("seg", seg, RoomSegmentation)
    why = map_mismatch(graph, seg.occupancy, graph_blamed=True)
    if why is not None:
        raise ValueError(f"graph: a graph of the segmentation's map is needed: {why}")
    labels = seg.labels
    vertex_pixels = {}  # checked whole before anything is written
    for n, d in graph.nodes(data=True):
        name = "pixels" if "pixels" in d else "pixel"
        if d.get(name) is None:
            raise ValueError(f"graph: node {n!r} has neither 'pixels' nor 'pixel'")
        vertex_pixels[n] = pixel_rows(f"graph: node {n!r}: {name!r}", d[name])
    paths = []
    for u, v, d in graph.edges(data=True):
        if "path" not in d:
            raise ValueError("graph: expected every edge to carry its pixel 'path'")
        paths.append(pixel_rows(f"graph: edge {u!r}-{v!r}: 'path'", d["path"]))
    for n, d in graph.nodes(data=True):
        d["room"] = _nearest_room(labels, vertex_pixels[n])
    doors = _door_lookup(seg)
    for (*_, d), path in zip(graph.edges(data=True), paths, strict=True):
        d["rooms"], d["doors"] = _edge_links(labels, path, doors)
    graph.graph["rooms"] = seg.n_rooms
    return graph
