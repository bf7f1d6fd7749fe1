"""Coverage meshes: a triangulated net of straight edges through the open space the lanes
along the walls leave uncovered.

Sites lie on a triangular lattice, each moved by a fixed pseudo-random offset (an
irregular net offers routes in more directions than a regular one), inside the
uncovered pieces; the graph's own pixels near a piece, spaced along its edges, are sites
too, so the net starts on the lanes round it.  The Delaunay triangulation of all sites
gives the candidate edges; those that leave the feasible space, touch the graph away
from their ends, or run far along the outside of the net are dropped, and so is, longest
first, each edge that would close a short loop; groups of sites that reach no graph pixel
are joined to it like lanes."""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import Delaunay, QhullError, cKDTree

from .._jit import cached_njit
from ..graph.work import WorkGraph, line_in_mask, line_pixels
from ._joins import GraphPixels, attach_points, grow, join_groups, large_pieces
from ._spanner import drop_short_loops

__all__ = ["MESH_JITTER", "MESH_MIN_AREA", "MESH_SPACING", "add_mesh", "mesh_pieces"]

#: Mesh sites lie about this many snap distances apart.
MESH_SPACING = 2.0
#: Each site moves up to this share of the spacing from its lattice point, along each
#: axis (neighbouring sites stay at least 0.77 spacings apart).
MESH_JITTER = 0.08
#: Uncovered pieces of at least this many squared snap distances get a mesh (smaller ones
#: a lane along their skeleton, which needs fewer vertices there).
MESH_MIN_AREA = 10.0
#: Graph pixels next to a piece are sites at least this many spacings apart.
BORDER_STEP = 1.0
# Triangulation edges longer than this many spacings (along the net's outside) are dropped.
_LONGEST = 1.8
_SEED = 7


def _lattice(mask: np.ndarray, spacing: float) -> np.ndarray:
    """Sites (int64 (n, 2), ``(row, col)``) of the jittered triangular lattice of
    ``spacing`` pixels laid from the corner of ``mask`` that fall on its set pixels."""
    h, w = mask.shape
    dy = spacing * math.sqrt(3.0) / 2.0
    rows = np.arange(dy / 2.0, h, dy)
    cols = np.arange(0.0, w + spacing, spacing)
    r = np.repeat(rows[:, None], cols.size, axis=1)
    c = cols[None, :] + np.where(np.arange(rows.size) % 2 == 1, spacing / 2.0, 0.0)[:, None]
    shake = np.random.default_rng(_SEED).uniform(-MESH_JITTER, MESH_JITTER, (*r.shape, 2))
    rr = np.rint(r + shake[..., 0] * spacing).astype(np.int64).ravel()
    cc = np.rint(c + shake[..., 1] * spacing).astype(np.int64).ravel()
    inside = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
    rr, cc = rr[inside], cc[inside]
    on = mask[rr, cc]
    return np.stack([rr[on], cc[on]], axis=1)


def _border_sites(work: WorkGraph, near: np.ndarray, step: float) -> np.ndarray:
    """Graph pixels inside ``near`` (bool (H, W)) at least ``step`` pixels apart: the
    live vertices first, then points along the edges (greedily, in order)."""
    pts = [np.array([work.pixel[v] for v in range(len(work.pixel)) if v not in work.dead])]
    k = max(1, int(step // 4))
    pts += [np.asarray(path[k:-1:k]) for _, _, path in work.edges.values()]
    every = np.concatenate([p.reshape(-1, 2) for p in pts]).astype(np.int64)
    every = every[near[every[:, 0], every[:, 1]]]
    if len(every) == 0:
        return every
    keep = np.ones(len(every), bool)
    tree = cKDTree(every)
    for i in range(len(every)):
        if keep[i]:
            close = np.asarray(tree.query_ball_point(every[i], step), np.int64)
            keep[close[close > i]] = False
    return every[keep]


@cached_njit(nogil=True)
def _clear_lines(pos, ea, eb, inner, feasible, occupied, end_px):
    """Per candidate edge ``ea[k]``-``eb[k]``: whether its straight line stays on feasible
    pixels and away from ``occupied`` ones, except within ``end_px`` of an end that is a
    graph pixel (``inner`` False)."""
    n_max = 1
    for k in range(ea.size):
        a, b = ea[k], eb[k]
        n_max = max(n_max, abs(pos[a, 0] - pos[b, 0]) + 1, abs(pos[a, 1] - pos[b, 1]) + 1)
    seg = np.empty((n_max, 2), np.int64)
    ok = np.zeros(ea.size, np.bool_)
    lim = end_px * end_px
    for k in range(ea.size):
        a, b = ea[k], eb[k]
        n = line_in_mask(pos[a, 0], pos[a, 1], pos[b, 0], pos[b, 1], feasible, seg)
        good = n > 0
        for j in range(n):
            r, c = seg[j, 0], seg[j, 1]
            if occupied[r, c]:
                da = (r - pos[a, 0]) ** 2 + (c - pos[a, 1]) ** 2
                db = (r - pos[b, 0]) ** 2 + (c - pos[b, 1]) ** 2
                if not ((not inner[a] and da <= lim) or (not inner[b] and db <= lim)):
                    good = False
                    break
        ok[k] = good
    return ok


def _triangulated_pairs(pts: np.ndarray) -> np.ndarray:
    """The edges (int64 (m, 2), i < j) of the Delaunay triangulation of ``pts``."""
    try:
        tri = Delaunay(pts.astype(np.float64))
    except (QhullError, ValueError):  # fewer than three sites, or all on one line
        return np.zeros((0, 2), np.int64)
    s = tri.simplices
    pairs = np.concatenate([s[:, [0, 1]], s[:, [1, 2]], s[:, [0, 2]]])
    pairs.sort(axis=1)
    return np.unique(pairs, axis=0).astype(np.int64)


def mesh_pieces(uncovered: np.ndarray, snap_px: float) -> np.ndarray:
    """The pieces of ``uncovered`` (bool (H, W), 8-connected) of at least
    :data:`MESH_MIN_AREA` squared snap distances, as a mask."""
    return large_pieces(uncovered, MESH_MIN_AREA * snap_px**2)


def add_mesh(
    work: WorkGraph,
    pieces: np.ndarray,
    raster: np.ndarray,
    feasible: np.ndarray,
    snap_px: float,
    min_loop_px: float,
    *,
    pixels: GraphPixels | None = None,
) -> bool:
    """Add a triangulated net through ``pieces`` (bool (H, W)), joined to the graph
    (pixels ``raster``; ``pixels``: their :class:`GraphPixels`, where the caller keeps
    them), without loops shorter than ``min_loop_px`` (the longer edges of such loops are
    left out).  Returns whether any site was added."""
    spacing = MESH_SPACING * snap_px
    inner = _lattice(pieces, spacing)
    if len(inner) == 0:
        return False
    reach = int(math.ceil(spacing))
    near = cv2.dilate(pieces.view(np.uint8), np.ones((2 * reach + 1,) * 2, np.uint8)).view(bool)
    border = _border_sites(work, near, BORDER_STEP * spacing) if raster.any() else np.zeros((0, 2))
    pos = np.concatenate([inner, border.reshape(-1, 2)]).astype(np.int64)
    is_inner = np.arange(len(pos)) < len(inner)
    pairs = _triangulated_pairs(pos)
    pairs = pairs[is_inner[pairs[:, 0]] | is_inner[pairs[:, 1]]]
    length = np.hypot(*(pos[pairs[:, 0]] - pos[pairs[:, 1]]).T)
    pairs = pairs[length <= _LONGEST * spacing]
    ok = _clear_lines(pos, pairs[:, 0], pairs[:, 1], is_inner, feasible, grow(raster), 3.0)
    pairs = pairs[ok]
    # vertices: every site with an edge; graph pixels become vertices where edges start
    used = np.unique(pairs)
    ids = np.full(len(pos), -1, np.int64)
    on_graph = used[~is_inner[used]]
    ids[on_graph] = attach_points(work, [tuple(p) for p in pos[on_graph]], feasible.shape)
    for i in used[is_inner[used]].tolist():
        ids[i] = work.add_vertex(pos[i])
    added = []
    for i, j in pairs.tolist():
        if ids[i] >= 0 and ids[j] >= 0 and ids[i] != ids[j]:
            added.append(
                (work.add_edge(int(ids[i]), int(ids[j]), line_pixels(pos[i], pos[j])), i, j)
            )
    # longest first: the edge closing a short loop goes, unless the loop is already open
    order = sorted(added, key=lambda t: -work.length[t[0]])
    live = list(work.edges)
    slot = {e: k for k, e in enumerate(live)}
    dropped = drop_short_loops(
        len(work.pixel),
        np.array([work.edges[e][0] for e in live], np.int64),
        np.array([work.edges[e][1] for e in live], np.int64),
        np.array([work.length[e] for e in live], np.float64),
        np.array([slot[e] for e, _, _ in order], np.int64),
        np.array([min_loop_px - work.length[e] for e, _, _ in order], np.float64),
    )
    kept = []
    for (e, i, j), drop in zip(order, dropped.tolist(), strict=True):
        if drop:
            work.remove_edge(e)
        else:
            kept.append((i, j))
    for i in np.flatnonzero(is_inner & (ids >= 0)).tolist():
        if not work.adj[ids[i]]:
            work.dead.add(int(ids[i]))
            ids[i] = -1
    pairs = np.array(kept, np.int64).reshape(-1, 2)
    join_groups(work, _unjoined(pairs, ids, is_inner), raster, feasible, pixels=pixels)
    return bool(used.size)


def _unjoined(pairs: np.ndarray, ids: np.ndarray, is_inner: np.ndarray) -> list[list[int]]:
    """The vertex ids of the inner sites, grouped by piece of the mesh (site pairs
    ``pairs``), for the pieces that reach no graph site."""
    n = len(ids)
    ends = np.where(is_inner[pairs], pairs, n)  # every graph site is node n
    links = coo_matrix((np.ones(len(ends)), (ends[:, 0], ends[:, 1])), shape=(n + 1, n + 1))
    _, label = connected_components(links, directed=False)
    groups: dict[int, list[int]] = {}
    for i in np.flatnonzero(is_inner & (ids >= 0) & (label[:n] != label[n])).tolist():
        groups.setdefault(int(label[i]), []).append(int(ids[i]))
    return list(groups.values())
