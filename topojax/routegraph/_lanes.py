"""Coverage lanes: long edges through the feasible space the medial axis leaves farther
than the snap distance from the graph.

The first round lays a lane along the walls of every such space, on the level curve at
:data:`LANE_INSET` snap distances from the pixels that are not feasible (close enough that
a room's corners are within the snap distance); later rounds lay the skeleton of what is
still uncovered.  Each lane is joined to the graph by the shortest straight feasible
segment (a feasible shortest path where none exists).  A lane is one edge however long,
so open rooms get a few long edges instead of a grid of waypoints."""

from __future__ import annotations

import cv2
import numpy as np

from ..graph import skeleton_graph_store
from ..graph.work import WorkGraph, drop_spurs
from ..skeleton import thin
from ._joins import GraphPixels, join_groups, large_pieces
from ._spanner import open_short_loops

__all__ = ["LANE_INSET", "LANE_MIN_AREA", "add_lanes"]

#: The first lanes run this many snap distances from the pixels that are not feasible: a
#: corner of the feasible space is then sqrt 2 times that, just within one snap distance.
LANE_INSET = 0.68
#: Uncovered pieces smaller than this many squared snap distances get waypoints, not lanes.
LANE_MIN_AREA = 0.5


def _lane_pixels(uncovered, feasible, wall, snap_px: float, along_walls: bool, sized: bool):
    """The one-pixel-wide lanes (bool (H, W)) through the large pieces of ``uncovered``
    (``sized``: it holds only such pieces), or None when no piece is large enough."""
    mask = uncovered if sized else large_pieces(uncovered, LANE_MIN_AREA * snap_px**2)
    if not mask.any():
        return None
    if not along_walls:
        return thin(mask)
    inner = (wall >= LANE_INSET * snap_px).view(np.uint8)
    curve = inner.view(bool) & ~cv2.erode(inner, np.ones((3, 3), np.uint8)).view(bool)
    near = cv2.dilate(mask.view(np.uint8), np.ones((5, 5), np.uint8)).view(bool)
    return thin(curve & near & feasible)


def _merged(
    work: WorkGraph, lanes: np.ndarray, snap_px: float, min_loop_px: float
) -> list[list[int]]:
    """Add the graph of ``lanes`` (spurs shorter than ``snap_px`` and loops shorter than
    ``min_loop_px`` dropped) to ``work``; returns the new vertices grouped by connected
    piece."""
    piece = WorkGraph.from_store(skeleton_graph_store(lanes, merge_junction_clusters=True))
    drop_spurs(piece, np.zeros(lanes.shape, np.float32), snap_px, 0.0)
    piece.contract_all()
    open_short_loops(piece, min_loop_px)
    new_id = {}
    parent: dict[int, int] = {}

    def find(x: int) -> int:
        while parent.setdefault(x, x) != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for v in range(len(piece.pixel)):
        if v not in piece.dead:
            new_id[v] = work.add_vertex(piece.pixel[v], piece.members[v])
            find(v)
    for u, v, path in piece.edges.values():
        work.add_edge(new_id[u], new_id[v], path)
        a, b = find(u), find(v)
        if a != b:
            parent[a] = b
    groups: dict[int, list[int]] = {}
    for v, w in new_id.items():
        groups.setdefault(find(v), []).append(w)
    return list(groups.values())


def add_lanes(
    work: WorkGraph,
    uncovered: np.ndarray,
    raster: np.ndarray,
    feasible: np.ndarray,
    wall: np.ndarray,
    snap_px: float,
    min_loop_px: float,
    along_walls: bool,
    *,
    sized: bool = False,
    pixels: GraphPixels | None = None,
) -> bool:
    """Add lanes through the large pieces of ``uncovered`` (bool (H, W)) and join each to
    the graph (pixels ``raster``); ``wall``: each pixel's distance to the nearest pixel
    that is not feasible (float32 (H, W)); ``along_walls``: the level-curve lanes of the
    first round, else the skeleton; lanes close no loop shorter than ``min_loop_px``;
    ``sized``: ``uncovered`` holds only pieces of at least :data:`LANE_MIN_AREA` squared
    snap distances (:func:`._joins.pieces_by_area`); ``pixels``: the
    :class:`GraphPixels` of ``raster``, where the caller keeps them.  Returns whether any
    lane was added."""
    lanes = _lane_pixels(uncovered, feasible, wall, snap_px, along_walls, sized)
    if lanes is None or not lanes.any():
        return False
    groups = _merged(work, lanes, snap_px, min_loop_px)
    join_groups(work, groups, raster, feasible, pixels=pixels)
    return True
