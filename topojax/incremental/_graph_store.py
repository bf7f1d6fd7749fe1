"""The mapper's graph tables: vertices and edges in arrays indexed by stable id, edge
paths as rows of one pixel pool (removed paths leave holes until it is compacted).
"""

from __future__ import annotations

import numpy as np

from ._tiles import _grown


def empty_graph_tables(mapper) -> None:
    """Give ``mapper`` an empty graph, by stable id (ids are never reused): vertex pixel
    key (``_tiles._pack``), kind code and liveness; edge ends (u <= v) and liveness; each live
    edge's pixel path (from u to v) as rows [start, start + len) of one int32 (n, 2)
    pool.  The graph_id tile layer maps pixels back to ids."""
    mapper._v_key = np.zeros(0, np.int64)
    mapper._v_code = np.zeros(0, np.int8)
    mapper._v_alive = np.zeros(0, bool)
    mapper._e_uv = np.zeros((0, 2), np.int64)
    mapper._e_alive = np.zeros(0, bool)
    mapper._e_start = np.zeros(0, np.int64)
    mapper._e_len = np.zeros(0, np.int64)
    mapper._pool = np.zeros((0, 2), np.int32)
    mapper._pool_used = 0  # rows written (live paths and holes)
    mapper._next_vertex = 0
    mapper._next_edge = 0


def vertex_ids(mapper) -> np.ndarray:
    """Ids of the live vertices, increasing."""
    return np.flatnonzero(mapper._v_alive[: mapper._next_vertex])


def edge_ids(mapper) -> np.ndarray:
    """Keys of the live edges, increasing."""
    return np.flatnonzero(mapper._e_alive[: mapper._next_edge])


def reserve(mapper, *, vertices: int = 0, edges: int = 0) -> None:
    """Grow the vertex / edge tables (doubling) to hold at least this many ids."""
    if vertices > mapper._v_key.shape[0]:
        cap = max(vertices, 2 * mapper._v_key.shape[0], 1024)
        mapper._v_key = _grown(mapper._v_key, cap)
        mapper._v_code = _grown(mapper._v_code, cap)
        mapper._v_alive = _grown(mapper._v_alive, cap)
    if edges > mapper._e_uv.shape[0]:
        cap = max(edges, 2 * mapper._e_uv.shape[0], 1024)
        mapper._e_uv = _grown(mapper._e_uv, cap)
        mapper._e_alive = _grown(mapper._e_alive, cap)
        mapper._e_start = _grown(mapper._e_start, cap)
        mapper._e_len = _grown(mapper._e_len, cap)


def edge_paths(mapper, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pixel paths of edges ``ids``: all of them concatenated (int32 (n, 2),
    global ``(row, col)``) and their lengths (int64)."""
    lens = mapper._e_len[ids]
    off = np.zeros(lens.shape[0] + 1, np.int64)
    np.cumsum(lens, out=off[1:])
    rows = np.repeat(mapper._e_start[ids] - off[:-1], lens) + np.arange(off[-1])
    return mapper._pool[rows], lens


def add_paths(mapper, ids: np.ndarray, paths: np.ndarray, lens: np.ndarray) -> None:
    """Store the paths of new edges ``ids`` (``paths``: concatenated, int (n, 2))."""
    n = paths.shape[0]
    if mapper._pool_used + n > mapper._pool.shape[0]:
        compact_paths(mapper, n)
    start = mapper._pool_used
    mapper._pool[start : start + n] = paths
    mapper._e_start[ids] = start + np.cumsum(lens) - lens
    mapper._e_len[ids] = lens
    mapper._pool_used += n


def drop_paths(mapper, ids: np.ndarray) -> None:
    """Forget the paths of edges ``ids`` (their rows become holes)."""
    mapper._e_len[ids] = 0


def compact_paths(mapper, extra: int) -> None:
    """Make room for ``extra`` more rows: drop the holes, and grow the pool (doubling)
    if the live paths would still fill more than half of it."""
    live = edge_ids(mapper)
    paths, lens = edge_paths(mapper, live)
    need = paths.shape[0] + extra
    cap = mapper._pool.shape[0]
    if 2 * need > cap:
        cap = max(2 * need, 4096)
    mapper._pool = np.zeros((cap, 2), np.int32)
    mapper._pool[: paths.shape[0]] = paths
    mapper._e_start[live] = np.cumsum(lens) - lens
    mapper._pool_used = paths.shape[0]
