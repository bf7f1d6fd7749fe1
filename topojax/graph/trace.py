"""numba kernels of the pixel graph: the neighbour table with its link masks, the tracing
of ordered edge paths and the ring search, and :func:`raw_graph` on top of them.

The kernels work on pixel *keys* ``row * stride + col`` (sorted, unique) so that the same
code serves the full map (:func:`_dense_keys`, stride ``W + 1``) and the incremental
mapper's scattered pixels at any origin.
"""

from __future__ import annotations

import numpy as np

from .._jit import cached_njit
from .store import KIND_JUNCTION, KIND_RING

# Neighbour directions (drow, dcol) in a fixed order; bit ``k`` of a link mask refers to
# direction ``k``.  4-neighbours first, then diagonals.
_DR = np.array([-1, 0, 0, 1, -1, -1, 1, 1], dtype=np.int64)
_DC = np.array([0, -1, 1, 0, -1, 1, -1, 1], dtype=np.int64)


# --------------------------------------------------------------------------------------
# numba kernels (work on the skeleton padded by one zero pixel, flattened row-major)
# --------------------------------------------------------------------------------------


@cached_njit(nogil=True, inline="always")
def link_mask(up, left, right, down, up_left, up_right, down_left, down_right):
    """The link mask of a skeleton pixel (bit ``k`` set: linked in direction ``k``) from
    which of its 8 neighbours are set: every 4-neighbour, and a diagonal only if neither
    pixel 4-adjacent to both ends is set."""
    m = 0
    if up:
        m |= 1
    if left:
        m |= 2
    if right:
        m |= 4
    if down:
        m |= 8
    if up_left and not up and not left:
        m |= 16
    if up_right and not up and not right:
        m |= 32
    if down_left and not down and not left:
        m |= 64
    if down_right and not down and not right:
        m |= 128
    return m


@cached_njit(nogil=True)
def _link_table(keys: np.ndarray, offsets8: np.ndarray):
    """Neighbour table and link masks of a set of pixels given by their keys.

    ``keys`` (int64, strictly increasing: raster order) are pixel keys whose neighbour in
    direction ``k`` has the key ``keys[i] + offsets8[k]`` (``row * stride + col`` with a
    stride larger than every column, so no real pixel wraps onto another row).  Adding a
    constant keeps the keys sorted, so the row above and the row below are each found by
    one linear merge: no image-sized array is needed, and the cost is O(n) for n pixels
    wherever they lie.

    Returns ``nbr`` (int32, (n, 8): index of the neighbour in direction ``k``, or -1) and
    ``masks`` (uint8, (n,): bit ``k`` set when the pixel is linked to that neighbour).
    """
    n = keys.shape[0]
    nbr = np.full((n, 8), -1, dtype=np.int32)
    # Same row: the neighbours are adjacent in raster order.
    for i in range(n):
        if i > 0 and keys[i - 1] == keys[i] + offsets8[1]:
            nbr[i, 1] = i - 1
        if i + 1 < n and keys[i + 1] == keys[i] + offsets8[2]:
            nbr[i, 2] = i + 1
    # Rows above and below: one linear merge each finds the three candidates, which are
    # consecutive in raster order when present.
    for row_dirs in ((4, 0, 5), (6, 3, 7)):
        d0 = row_dirs[0]
        j = 0
        for i in range(n):
            base = keys[i] + offsets8[d0]
            while j < n and keys[j] < base:
                j += 1
            jj = j
            for d in row_dirs:
                target = keys[i] + offsets8[d]
                while jj < n and keys[jj] < target:
                    jj += 1
                if jj < n and keys[jj] == target:
                    nbr[i, d] = jj
    masks = np.zeros(n, dtype=np.uint8)
    for i in range(n):
        masks[i] = link_mask(
            nbr[i, 0] >= 0,
            nbr[i, 1] >= 0,
            nbr[i, 2] >= 0,
            nbr[i, 3] >= 0,
            nbr[i, 4] >= 0,
            nbr[i, 5] >= 0,
            nbr[i, 6] >= 0,
            nbr[i, 7] >= 0,
        )
    return nbr, masks


@cached_njit(nogil=True)
def _trace(
    links: np.ndarray,
    is_vertex: np.ndarray,
    vertex_idx: np.ndarray,
    deg2_idx: np.ndarray,
    nbr: np.ndarray,
    vertex_links: int,
):
    """Trace all edge paths.

    Pixels are numbered ``0..n-1`` in raster order; ``links`` (uint8 masks),
    ``is_vertex`` (bool) and ``nbr`` (:func:`_link_table`) are indexed by that number;
    ``vertex_links`` is the number of links of the vertex pixels (their degrees summed).
    Returns the ring-vertex numbers, and per edge the start / end pixel number and the
    concatenated paths with CSR offsets.  ``is_vertex`` is updated in place with the ring
    vertices.

    The output arrays are sized by bounds: every degree-2 pixel is on one path, once (a
    ring's first pixel twice); every other path entry is a vertex pixel at the end of one
    of its links, each link used by one edge at most; an edge other than a ring uses two
    such link ends; a ring holds at least 4 pixels (3 pixels cannot form one: the diagonal
    of a right triangle is not a link).  Writes past a bound raise instead.
    """
    visited = np.zeros(links.shape[0], dtype=np.bool_)
    n_deg2 = deg2_idx.shape[0]
    max_rings = n_deg2 // 4 + 1
    max_edges = vertex_links // 2 + max_rings + 1
    max_path = n_deg2 + vertex_links + max_rings + 1
    e_u = np.empty(max_edges, dtype=np.int64)
    e_v = np.empty(max_edges, dtype=np.int64)
    e_off = np.empty(max_edges + 1, dtype=np.int64)
    path = np.empty(max_path, dtype=np.int64)
    n_e = 0
    n_p = 0
    e_off[0] = 0
    rings = np.empty(max_rings, dtype=np.int64)
    n_r = 0

    for phase in range(2):
        if phase == 0:
            starts = vertex_idx
            count = starts.shape[0]
        else:
            starts = deg2_idx
            count = starts.shape[0]
        for s in range(count):
            if phase == 0:
                v = starts[s]
            else:
                # Reverse raster order: the first unvisited degree-2 pixel met is the last
                # pixel of its ring in raster order.
                v = starts[count - 1 - s]
                if visited[v]:
                    continue
                is_vertex[v] = True
                if n_r >= max_rings:
                    raise RuntimeError("_trace: more rings than its bound")
                rings[n_r] = v
                n_r += 1
            m = links[v]
            for k in range(8):
                if not (m >> k) & 1:
                    continue
                nb = nbr[v, k]
                if n_e >= max_edges or n_p + 2 > max_path:
                    raise RuntimeError("_trace: more edges or path pixels than its bound")
                if is_vertex[nb]:
                    # Two adjacent vertex pixels: one 2-pixel edge, emitted once.
                    if v < nb:
                        e_u[n_e] = v
                        e_v[n_e] = nb
                        path[n_p] = v
                        path[n_p + 1] = nb
                        n_p += 2
                        n_e += 1
                        e_off[n_e] = n_p
                    continue
                if visited[nb]:
                    continue
                path[n_p] = v
                n_p += 1
                prev = v
                cur = nb
                while True:
                    if n_p >= max_path:
                        raise RuntimeError("_trace: more path pixels than its bound")
                    path[n_p] = cur
                    n_p += 1
                    if is_vertex[cur]:
                        break
                    visited[cur] = True
                    mc = links[cur]
                    nxt = -1
                    for kk in range(8):
                        if (mc >> kk) & 1:
                            cand = nbr[cur, kk]
                            if cand != prev:
                                nxt = cand
                                break
                    prev = cur
                    cur = nxt
                e_u[n_e] = v
                e_v[n_e] = cur
                n_e += 1
                e_off[n_e] = n_p
            if phase == 1:
                visited[v] = True
    # copies: views would keep the arrays at their bounds alive
    rings = rings[:n_r].copy()
    e_u = e_u[:n_e].copy()
    e_v = e_v[:n_e].copy()
    return rings, e_u, e_v, e_off[: n_e + 1].copy(), path[:n_p].copy()


def _dense_keys(shape: tuple[int, ...], idx: np.ndarray) -> tuple[np.ndarray, int]:
    """Keys ``row * stride + col`` of the pixels with flat indices ``idx`` of an image of
    ``shape`` and the stride (``W + 1``: the neighbours of column 0 and W - 1 across the row
    ends fall on the unused column W)."""
    w = shape[1]
    return idx + idx // w, w + 1


def raw_graph(keys: np.ndarray, stride: int):
    """Pixel graph and traced edges of the pixels ``keys`` (sorted, unique).

    Parameters
    ----------
    keys : int64 (n,)
        Pixel keys ``row * stride + col`` (any origin), strictly increasing.
    stride : int
        Key step of one row; larger than every column index plus one.

    Returns
    -------
    v_idx : int64 (n_v,)
        Vertex pixels (indices into ``keys``), increasing.
    v_kind : int8 (n_v,)
        0 isolated, 1 end, 2 ring, 3 junction.
    e_u, e_v : int64 (n_e,)
        First and last pixel (indices into ``keys``) of each edge.
    e_off : int64 (n_e + 1,)
        CSR offsets of the edge paths in ``path``.
    path : int64 (L,)
        Concatenated edge paths (indices into ``keys``), each from one end to the other.
    """
    offsets8 = _DR * stride + _DC
    nbr, masks = _link_table(keys, offsets8)
    deg = _POPCOUNT[masks]
    vmask = deg != 2
    vertex_idx = np.flatnonzero(vmask)
    vertex_links = int(deg[vertex_idx].sum(dtype=np.int64))
    rings, e_u, e_v, e_off, path = _trace(
        masks, vmask.copy(), vertex_idx, np.flatnonzero(~vmask), nbr, vertex_links
    )
    del nbr, masks
    v_idx = np.concatenate([vertex_idx, rings])
    v_kind = np.concatenate(
        [np.minimum(deg[vmask], KIND_JUNCTION), np.full(rings.shape[0], KIND_RING, np.uint8)]
    ).astype(np.int8)
    order = np.argsort(v_idx, kind="stable")
    return v_idx[order], v_kind[order], e_u, e_v, e_off.astype(np.int64), path


_POPCOUNT = np.array([bin(i).count("1") for i in range(256)], dtype=np.uint8)
