"""Skeleton → topology graph (paper §II-C).

Every skeleton pixel is a node of a *pixel graph* and is linked to each of its up to eight
set neighbours, except for the redundant diagonal of an ``L``: two diagonal neighbours
``p`` and ``q`` are **not** linked when a pixel that is 4-adjacent to both of them is set
(the two 4-links through that pixel already connect them, and the diagonal would close a
triangle).  The topology graph is the pixel graph with its degree-2 pixels contracted:

* **vertices** are the pixels whose pixel-graph degree is not 2: ``"end"`` (degree 1),
  ``"junction"`` (degree >= 3) and ``"isolated"`` (degree 0, a lone pixel);
* **edges** are the maximal chains of degree-2 pixels between two vertices, stored with
  their full ordered pixel path;
* a closed ring made only of degree-2 pixels has no vertex of its own; it becomes a single
  vertex of kind ``"ring"`` (at the **last** pixel of the ring in raster order, which is
  where the original implementation puts it on the intel map) carrying one self-loop edge.

Partition invariant: every skeleton pixel is either a vertex pixel (a member of exactly one
vertex's ``pixels``) or an interior pixel of exactly one edge path.  Paths are 8-connected,
their first and last pixels are vertex pixels, and each pixel-graph link is traversed by
exactly one edge.

Comparison with the original implementation (STAR-Center/IncrementalTopo, reference arrays in
``shared/data/reference``), with ``merge_junction_clusters=False``:

* Its vertices are the end pixels of its edges, so a lone skeleton pixel (pixel-graph degree
  0) never appears there; here it is a vertex of kind ``"isolated"`` with no edge (intel 10,
  office 9, a_scan 4 such pixels).  Ignoring those, the vertex sets are identical on all
  three reference maps (258 / 305 / 344) and so are the edge counts (235 / 328 / 350).
* Its ring handling merges the last two parallel edges of a ring into a self-loop and then
  merges that self-loop with itself, so its single ring edge on intel lists the ring twice
  (``edge_npix`` = 2 n + 1 = 5863 for the 2931-pixel ring); here the ring's path has
  n + 1 = 2932 pixels (it starts and ends at the ring vertex).  Every other edge has the
  same pixel count as in the original.
* At a four-way crossing with a one-pixel hole (four skeleton pixels N, E, S, W around an
  empty pixel, found four times on a_scan), the four pixels are linked diagonally to each
  other (no common 4-neighbour is set), so each has degree 3: four junction vertices joined
  in a 4-cycle of 2-pixel edges plus the four arms.  This is what the original does.
  ``skan`` (0.13) links all 8 neighbours and then keeps only a minimum spanning tree of
  each cluster of junction pixels; on the diamond that drops one of the four equal-weight
  diagonal links, leaving two junctions and two path pixels (8 fewer vertices and 12 fewer
  edges on a_scan).  Elsewhere on the three paper maps skan finds the same vertices and
  per-edge pixel counts as this module (it only starts the intel ring at another pixel);
  on arbitrary skeletons its spanning trees also differ at L corners, 2 x 2 blocks and
  other small holes (about a third of random thinned blobs).
  ``merge_junction_clusters=True`` collapses each such diamond into one vertex.
* Its pixel-link construction has a border quirk: on the last image column it adds the
  down-left diagonal without the triangle test.  That quirk is not reproduced (the
  triangle rule is applied everywhere); none of the reference skeletons is affected.

:func:`prune_graph` trims a built graph for routing: edges narrower than the robot, short
dead-end branches (round after round, joining the edges of a vertex left with two) and
small components.  It works on the graph alone; for spurs it gives the vertices and edges
that pruning the skeleton's pixels and building the graph again would give, except that a
vertex left on a ring stays where it was (a rebuilt graph puts it at the ring's last pixel
in raster order).

Implementation: the link bit-masks, the tracing of ordered edge paths and the ring search are
numba kernels (one pass over the skeleton pixels each); attribute arrays (world coordinates,
lengths, clearances) are computed with vectorised numpy over all paths at once.
"""

from __future__ import annotations

import gc
import itertools
import math
import numbers
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import networkx as nx
import numpy as np

from ._jit import cached_njit
from ._validate import nonnegative_metres

__all__ = ["graph_summary", "pixel_graph_degree", "prune_graph", "skeleton_to_graph"]

PixelToWorld = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]

# Neighbour directions (drow, dcol) in a fixed order; bit ``k`` of a link mask refers to
# direction ``k``.  4-neighbours first, then diagonals.
_DR = np.array([-1, 0, 0, 1, -1, -1, 1, 1], dtype=np.int64)
_DC = np.array([0, -1, 1, 0, -1, 1, -1, 1], dtype=np.int64)

_KIND_ISOLATED = 0
_KIND_END = 1
_KIND_JUNCTION = 3
_KIND_RING = 2
_KIND_NAMES = {
    _KIND_ISOLATED: "isolated",
    _KIND_END: "end",
    _KIND_RING: "ring",
    _KIND_JUNCTION: "junction",
}


# --------------------------------------------------------------------------------------
# numba kernels (work on the skeleton padded by one zero pixel, flattened row-major)
# --------------------------------------------------------------------------------------


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
        up = nbr[i, 0] >= 0
        left = nbr[i, 1] >= 0
        right = nbr[i, 2] >= 0
        down = nbr[i, 3] >= 0
        m = 0
        if up:
            m |= 1
        if left:
            m |= 2
        if right:
            m |= 4
        if down:
            m |= 8
        # A diagonal is linked only if neither pixel 4-adjacent to both ends is set.
        if nbr[i, 4] >= 0 and not up and not left:
            m |= 16
        if nbr[i, 5] >= 0 and not up and not right:
            m |= 32
        if nbr[i, 6] >= 0 and not down and not left:
            m |= 64
        if nbr[i, 7] >= 0 and not down and not right:
            m |= 128
        masks[i] = m
    return nbr, masks


@cached_njit(nogil=True)
def _trace(
    links: np.ndarray,
    is_vertex: np.ndarray,
    vertex_idx: np.ndarray,
    deg2_idx: np.ndarray,
    nbr: np.ndarray,
    n_links: int,
):
    """Trace all edge paths.

    Pixels are numbered ``0..n-1`` in raster order; ``links`` (uint8 masks),
    ``is_vertex`` (bool) and ``nbr`` (:func:`_link_table`) are indexed by that number.
    Returns the ring-vertex numbers, and per edge the start / end pixel number and the
    concatenated paths with CSR offsets.  ``is_vertex`` is updated in place with the ring
    vertices.
    """
    visited = np.zeros(links.shape[0], dtype=np.bool_)
    max_edges = n_links + 1
    e_u = np.empty(max_edges, dtype=np.int64)
    e_v = np.empty(max_edges, dtype=np.int64)
    e_off = np.empty(max_edges + 1, dtype=np.int64)
    path = np.empty(2 * n_links + 2, dtype=np.int64)
    n_e = 0
    n_p = 0
    e_off[0] = 0
    rings = np.empty(deg2_idx.shape[0], dtype=np.int64)
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
                rings[n_r] = v
                n_r += 1
            m = links[v]
            for k in range(8):
                if not (m >> k) & 1:
                    continue
                nb = nbr[v, k]
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
    return rings[:n_r], e_u[:n_e], e_v[:n_e], e_off[: n_e + 1], path[:n_p]


# --------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------


def _as_skeleton(skeleton: object) -> np.ndarray:
    arr = np.asarray(skeleton)
    if arr.ndim != 2:
        raise ValueError(
            f"skeleton: expected a 2-D array (H, W), received an array with shape {arr.shape}"
        )
    if arr.dtype == np.bool_:
        return arr
    if arr.dtype.kind not in "iuf":
        raise TypeError(
            f"skeleton: expected a bool-like array (bool, or integers/floats in {{0, 1}}), "
            f"received dtype {arr.dtype}"
        )
    bad = (arr != 0) & (arr != 1)
    if bad.any():
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"skeleton: expected only the values 0 and 1, received {arr[first]!r} at "
            f"(row, col) = {first}"
        )
    return arr != 0


def _check_resolution(resolution_m: object) -> float:
    if isinstance(resolution_m, bool) or not isinstance(resolution_m, numbers.Real):
        raise TypeError(
            f"resolution_m: expected a finite real number > 0 (metres per pixel), "
            f"received {resolution_m!r} of type {type(resolution_m).__name__}"
        )
    res = float(resolution_m)
    if not (math.isfinite(res) and res > 0.0):
        raise ValueError(
            f"resolution_m: expected a finite real number > 0 (metres per pixel), "
            f"received {resolution_m!r}"
        )
    return res


def _check_clearance(clearance_px: object, skel: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """Validate ``clearance_px`` at the skeleton's pixels ``flat`` (flat indices, raster
    order) and return its values there as float64 (n,): only those are read, so only those
    are checked, not the whole map."""
    arr = np.asarray(clearance_px)
    if arr.dtype.kind not in "iuf" or arr.dtype == np.bool_:
        raise TypeError(
            f"clearance_px: expected a real numeric array (pixels), received dtype {arr.dtype}"
        )
    if arr.shape != skel.shape:
        raise ValueError(
            f"clearance_px: expected shape {skel.shape} (the skeleton's shape), "
            f"received shape {arr.shape}"
        )
    return _check_clearance_values(arr.ravel()[flat], skel.shape, flat)


def _check_clearance_values(
    values: np.ndarray, shape: tuple[int, ...], flat: np.ndarray
) -> np.ndarray:
    """Clearances at the pixels ``flat`` as float64 (n,), checked non-negative, not NaN."""
    vals = np.asarray(values).astype(np.float64, copy=False)
    if vals.shape != flat.shape:
        raise ValueError(
            f"clearance_px: expected {flat.shape[0]} values (one per skeleton pixel), "
            f"received an array of shape {vals.shape}"
        )
    bad = np.isnan(vals) | (vals < 0)
    if bad.any():
        r, c = divmod(int(flat[np.flatnonzero(bad)[0]]), shape[1])
        raise ValueError(
            f"clearance_px: expected non-negative, non-NaN values on skeleton pixels, "
            f"received {vals[bad][0]!r} at (row, col) = ({r}, {c})"
        )
    return vals


def _world_coords(
    rows: np.ndarray,
    cols: np.ndarray,
    shape: tuple[int, int],
    res: float,
    pixel_to_world: PixelToWorld | None,
) -> np.ndarray:
    """World (x, y) of pixel centres, shape (n, 2) float64."""
    if pixel_to_world is None:
        x = (cols + 0.5) * res
        y = (shape[0] - rows - 0.5) * res
        return np.stack([x, y], axis=1).astype(np.float64, copy=False)
    out = pixel_to_world(rows, cols)
    try:
        x, y = out
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"pixel_to_world: expected a callable returning (x, y) arrays, received "
            f"{type(out).__name__}"
        ) from exc
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n = rows.shape[0]
    if x.shape != (n,) or y.shape != (n,):
        raise ValueError(
            f"pixel_to_world: expected x and y of shape ({n},) for {n} input pixels, "
            f"received shapes {x.shape} and {y.shape}"
        )
    return np.stack([x, y], axis=1)


# --------------------------------------------------------------------------------------
# core
# --------------------------------------------------------------------------------------


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
    n_links = int(deg.sum(dtype=np.int64)) // 2
    rings, e_u, e_v, e_off, path = _trace(
        masks, vmask.copy(), vertex_idx, np.flatnonzero(~vmask), nbr, n_links
    )
    v_idx = np.concatenate([vertex_idx, rings])
    v_kind = np.concatenate(
        [np.minimum(deg[vmask], _KIND_JUNCTION), np.full(rings.shape[0], _KIND_RING, np.uint8)]
    ).astype(np.int8)
    order = np.argsort(v_idx, kind="stable")
    return v_idx[order], v_kind[order], e_u, e_v, e_off.astype(np.int64), path


def orient(
    u: np.ndarray, v: np.ndarray, off: np.ndarray, lens: np.ndarray, paths: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Swap ``u``/``v`` where ``u > v`` and reverse those edges' paths (CSR ``off``)."""
    flip = u > v
    if not flip.any():
        return u, v, paths
    edge_of = np.repeat(np.arange(u.shape[0]), lens)
    pos = np.arange(paths.shape[0])
    rev = np.where(flip[edge_of], 2 * off[edge_of] + lens[edge_of] - 1 - pos, pos)
    return np.where(flip, v, u), np.where(flip, u, v), paths[rev]


def _edge_pixel_index(off: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Indices into the concatenated paths of the pixels of the edges ``keep``."""
    lens = off[keep + 1] - off[keep]
    base = np.concatenate([[0], np.cumsum(lens)[:-1]])
    return np.repeat(off[keep] - base, lens) + np.arange(int(lens.sum()))


_POPCOUNT = np.array([bin(i).count("1") for i in range(256)], dtype=np.uint8)


def pixel_graph_degree(skeleton: np.ndarray) -> np.ndarray:
    """Degree of every pixel in the skeleton's pixel graph.

    Parameters
    ----------
    skeleton : np.ndarray, shape (H, W), bool-like
        Skeleton mask, indexed ``[row, col]``.

    Returns
    -------
    np.ndarray, shape (H, W), uint8
        Number of pixel-graph links of each skeleton pixel (8-neighbours minus redundant
        ``L`` diagonals, so 0..8); 0 on background pixels (and on isolated skeleton pixels).
    """
    skel = _as_skeleton(skeleton)
    keys, stride = _dense_keys(skel.shape, np.flatnonzero(skel.ravel()))
    _, masks = _link_table(keys, _DR * stride + _DC)
    deg = np.zeros(skel.size, dtype=np.uint8)
    deg[keys - keys // stride] = _POPCOUNT[masks]
    return deg.reshape(skel.shape)


def _empty_graph(shape: tuple[int, int], res: float, merge: bool) -> nx.MultiGraph:
    g = nx.MultiGraph()
    g.graph.update(resolution_m=res, shape=shape, merge_junction_clusters=merge)
    return g


@contextmanager
def paused_gc() -> Iterator[None]:
    """Pause Python's cyclic garbage collector (restored on exit, also on error).

    Building a networkx graph allocates many small containers, which triggers collections
    that scan every live object; the objects built here hold no reference cycles.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def skeleton_to_graph(
    skeleton: np.ndarray,
    *,
    clearance_px: np.ndarray | None = None,
    resolution_m: float = 1.0,
    pixel_to_world: PixelToWorld | None = None,
    merge_junction_clusters: bool = False,
) -> nx.MultiGraph:
    """Build the topology graph of a one-pixel-wide skeleton (paper §II-C).

    Parameters
    ----------
    skeleton : np.ndarray, shape (H, W), bool-like
        Skeleton mask indexed ``[row, col]``, row 0 at the top.  bool, or integers / floats
        holding only 0 and 1.  Any mask is accepted (thick parts simply give many junctions).
    clearance_px : np.ndarray, shape (H, W), real, or callable, optional
        Clearance (distance to the nearest obstacle) in pixels, e.g. a Euclidean distance
        transform.  Only the values on skeleton pixels are read; they must be >= 0 and not
        NaN.  A callable ``f(flat) -> (n,) array`` gives them at the skeleton's pixels
        only, ``flat`` being their flat (raster) indices ``row * W + col``, increasing
        (so the clearance need only be computed there).  If omitted, every clearance
        attribute is NaN.
    resolution_m : float, default 1.0
        Metres per pixel (finite, > 0).  Scales ``length_m`` and the clearances.
    pixel_to_world : callable, optional
        ``pixel_to_world(rows, cols) -> (x, y)``: maps float64 arrays of shape (n,) of pixel
        rows / columns to world coordinates in metres (e.g. ``OccupancyMap.pixel_to_world``).
        If omitted, the ROS map frame with origin (0, 0, 0) is used: the centre of pixel
        ``(row, col)`` is ``x = (col + 0.5) * resolution_m``,
        ``y = (H - row - 0.5) * resolution_m`` (x to the right, y up).
    merge_junction_clusters : bool, default False
        If False (the paper's and the original implementation's semantics) every pixel of
        degree != 2 is its own vertex.  If True, each cluster of junction pixels joined by
        direct pixel links (2-pixel junction-junction edges) becomes one vertex: the
        2-pixel edges inside the cluster are dropped, and every other edge that ended at a
        member now ends at the merged vertex.  Edge paths are *not* extended: their end
        pixel is the member they touched, which belongs to the vertex (its ``pixels``).  An
        edge longer than 2 pixels between two members of the same cluster becomes a
        self-loop of the merged vertex.

    Returns
    -------
    networkx.MultiGraph
        Nodes ``0..N-1`` in raster order of their ``pixel``, with attributes

        - ``pixel``: ``(row, col)`` tuple of int, the vertex pixel (for a merged cluster the
          member nearest the cluster centroid, ties broken by raster order);
        - ``pixels``: np.ndarray (M, 2) int32 ``(row, col)`` of all member pixels in raster
          order (M = 1 unless clusters are merged);
        - ``world``: ``(x, y)`` tuple of float, metres, of ``pixel``'s centre;
        - ``kind``: ``"junction"`` (degree >= 3), ``"end"`` (degree 1), ``"isolated"``
          (degree 0) or ``"ring"`` (a closed loop of degree-2 pixels; its vertex is the
          ring's last pixel in raster order and it carries one self-loop);
        - ``clearance_m``: clearance at ``pixel`` times ``resolution_m`` (NaN without
          ``clearance_px``).

        Edges ``(u, v, key)`` with ``u <= v`` and attributes

        - ``path``: np.ndarray (K, 2) int32 ``(row, col)``, 8-connected, ordered from a
          pixel of ``u`` to a pixel of ``v``, both end pixels included (K >= 2; K = 2 for two
          adjacent vertex pixels; a self-loop starts and ends at the same pixel);
        - ``world``: np.ndarray (K, 2) float64 ``(x, y)`` metres of the path pixel centres;
        - ``length_m``: sum of the path's step lengths (1 or sqrt(2) pixels) times
          ``resolution_m``;
        - ``min_clearance_m`` / ``mean_clearance_m``: min / mean over the K path pixels of
          the clearance in metres (NaN without ``clearance_px``).

        Graph attributes: ``resolution_m`` (float), ``shape`` ((H, W) tuple of int),
        ``merge_junction_clusters`` (bool).

    Raises
    ------
    TypeError
        If an argument has the wrong type (non-numeric skeleton, non-callable
        ``pixel_to_world``, ...).
    ValueError
        If ``skeleton`` is not 2-D or holds values other than 0/1, ``clearance_px`` has
        another shape or invalid values, ``resolution_m`` is not finite and > 0, or
        ``pixel_to_world`` returns arrays of the wrong shape.
    """
    skel = _as_skeleton(skeleton)
    res = _check_resolution(resolution_m)
    if pixel_to_world is not None and not callable(pixel_to_world):
        raise TypeError(
            f"pixel_to_world: expected a callable (rows, cols) -> (x, y) or None, "
            f"received {type(pixel_to_world).__name__}"
        )
    if not isinstance(merge_junction_clusters, (bool, np.bool_)):
        raise TypeError(
            f"merge_junction_clusters: expected a bool, received "
            f"{type(merge_junction_clusters).__name__}"
        )
    merge = bool(merge_junction_clusters)
    flat = np.flatnonzero(skel.ravel())  # skeleton pixels, raster order
    if clearance_px is None:
        clear = None
    elif callable(clearance_px):
        clear = _check_clearance_values(clearance_px(flat), skel.shape, flat)
    else:
        clear = _check_clearance(clearance_px, skel, flat)
    return _graph_from_skeleton(skel.shape, flat, clear, res, pixel_to_world, merge)


def _graph_from_skeleton(
    shape: tuple[int, ...],
    flat: np.ndarray,
    clear: np.ndarray | None,
    res: float,
    pixel_to_world: PixelToWorld | None,
    merge: bool,
) -> nx.MultiGraph:
    """:func:`skeleton_to_graph` on checked input: the skeleton's pixels as flat indices
    ``flat`` (raster order) of an image of ``shape``, and their clearances in pixels
    (float64 (n,), aligned with ``flat``) or None."""
    shape = (int(shape[0]), int(shape[1]))
    if flat.size == 0:
        return _empty_graph(shape, res, merge)

    # --- pixel graph and edge tracing (numba) -----------------------------------------
    # Pixels are numbered 0..n-1 in raster order (their index in ``flat`` and ``keys``);
    # vertices and paths refer to them by that number until the end.
    keys, stride = _dense_keys(shape, flat)
    v_idx, v_kind, e_u, e_v, e_off, path = raw_graph(keys, stride)
    n_v = v_idx.shape[0]
    u_id = np.searchsorted(v_idx, e_u)
    v_id = np.searchsorted(v_idx, e_v)

    # --- paths oriented so that u <= v ------------------------------------------------
    lens = np.diff(e_off)
    u_id, v_id, path = orient(u_id, v_id, e_off, lens, path)
    v_key = keys[v_idx]
    vr = v_key // stride
    vc = v_key % stride
    pixels_rc = np.stack([vr, vc], axis=1).astype(np.int32)
    member_bounds = np.arange(n_v + 1)

    # --- optional junction-cluster merge ---------------------------------------------
    if merge:
        junction = v_kind == _KIND_JUNCTION
        tiny = (lens == 2) & junction[u_id] & junction[v_id]
        if tiny.any():
            # imported here: scipy.sparse is a tenth of a second of `import topojax`
            from scipy.sparse import coo_matrix
            from scipy.sparse.csgraph import connected_components

            adj = coo_matrix(
                (np.ones(int(tiny.sum()), dtype=np.int8), (u_id[tiny], v_id[tiny])),
                shape=(n_v, n_v),
            )
            n_lab, label = connected_components(adj, directed=False)
            size = np.bincount(label, minlength=n_lab)
            cy = np.bincount(label, weights=vr, minlength=n_lab) / size
            cx = np.bincount(label, weights=vc, minlength=n_lab) / size
            d2 = (vr - cy[label]) ** 2 + (vc - cx[label]) ** 2
            # Representative per cluster: nearest to the centroid, then first in raster order.
            pick = np.lexsort((np.arange(n_v), d2, label))
            first = np.ones(n_v, dtype=bool)
            first[1:] = label[pick[1:]] != label[pick[:-1]]
            rep_of_label = pick[first]  # labels ascending
            rep_sorted = np.sort(rep_of_label)  # new vertices in raster order
            new_of_label = np.searchsorted(rep_sorted, rep_of_label)
            new_id = new_of_label[label]
            # Members of each new vertex, in raster order.
            member_order = np.lexsort((np.arange(n_v), new_id))
            pixels_rc = pixels_rc[member_order]
            member_bounds = np.searchsorted(new_id[member_order], np.arange(n_lab + 1))
            v_kind = np.where(size[label[rep_sorted]] > 1, _KIND_JUNCTION, v_kind[rep_sorted])
            v_idx = v_idx[rep_sorted]
            vr = vr[rep_sorted]
            vc = vc[rep_sorted]
            n_v = n_lab
            # Drop the intra-cluster 2-pixel edges, remap and re-orient the others.
            keep = np.flatnonzero(~tiny)
            path = path[_edge_pixel_index(e_off, keep)]
            lens = lens[keep]
            e_off = np.concatenate([[0], np.cumsum(lens)])
            u_id, v_id = new_id[u_id[keep]], new_id[v_id[keep]]
            u_id, v_id, path = orient(u_id, v_id, e_off, lens, path)
    n_e = u_id.shape[0]
    path_key = keys[path]
    pr = path_key // stride
    pc = path_key % stride

    # --- attributes (vectorised) ------------------------------------------------------
    n_path = pr.shape[0]
    world_all = _world_coords(
        np.concatenate([pr, vr]).astype(np.float64),
        np.concatenate([pc, vc]).astype(np.float64),
        shape,
        res,
        pixel_to_world,
    )
    path_world = world_all[:n_path]
    node_world = world_all[n_path:]
    path_rc = np.stack([pr, pc], axis=1).astype(np.int32)

    if n_e:
        starts = e_off[:-1]
        length_m = path_lengths_m(path_rc, starts, lens, res)
        if clear is not None:
            cval = clear[path] * res
            min_c = np.minimum.reduceat(cval, starts)
            mean_c = np.add.reduceat(cval, starts) / lens
        else:
            min_c = np.full(n_e, np.nan)
            mean_c = np.full(n_e, np.nan)
    if clear is not None:
        node_clear = clear[v_idx] * res
    else:
        node_clear = np.full(n_v, np.nan)

    # --- assemble the networkx graph --------------------------------------------------
    # Thousands of small dicts and tuples: a cyclic-GC pass triggered in the middle
    # would scan every live object of the process (milliseconds, at random calls).
    with paused_gc():
        vr_l = vr.tolist()
        vc_l = vc.tolist()
        kinds = [_KIND_NAMES[int(k)] for k in v_kind]
        nw = node_world.tolist()
        ncl = node_clear.tolist()
        mb = member_bounds.tolist()
        node_attrs = [
            {
                "pixel": (vr_l[i], vc_l[i]),
                "pixels": pixels_rc[mb[i] : mb[i + 1]],
                "world": (nw[i][0], nw[i][1]),
                "kind": kinds[i],
                "clearance_m": ncl[i],
            }
            for i in range(n_v)
        ]
        edges = []
        if n_e:
            order = np.lexsort((np.arange(n_e), v_id, u_id))
            bnd = e_off.tolist()
            u_l = u_id.tolist()
            v_l = v_id.tolist()
            ln = length_m.tolist()
            mn = min_c.tolist()
            me = mean_c.tolist()
            for i in order.tolist():
                a, b = bnd[i], bnd[i + 1]
                attrs = {
                    "path": path_rc[a:b],
                    "world": path_world[a:b],
                    "length_m": ln[i],
                    "min_clearance_m": mn[i],
                    "mean_clearance_m": me[i],
                }
                edges.append((u_l[i], v_l[i], attrs))
        return _fill_multigraph(_empty_graph(shape, res, merge), node_attrs, edges)


def _fill_multigraph(g: nx.MultiGraph, node_attrs: list[dict], edges: list[tuple]) -> nx.MultiGraph:
    """Add nodes ``0..n-1`` with the attribute dicts ``node_attrs`` and the edges
    ``(u, v, attrs)`` in order (keys 0, 1, ... per node pair) to an empty, plain
    :class:`networkx.MultiGraph` (from :func:`_empty_graph`).

    Writes networkx's documented dict-of-dict-of-dict structure directly, as
    ``add_node`` / ``add_edge`` would leave it: 4x faster than those calls, which was a
    third of the graph step on the paper maps.  A test checks it against those calls.
    """
    node, adj = g._node, g._adj
    for i, attrs in enumerate(node_attrs):
        node[i] = attrs
        adj[i] = {}
    for u, v, attrs in edges:
        keys = adj[u].get(v)
        if keys is None:
            keys = adj[u][v] = adj[v][u] = {}  # one key dict, seen from both ends
        keys[len(keys)] = attrs
    return g


def graph_summary(graph: nx.MultiGraph) -> dict[str, float | int]:
    """Counts and total length of a topology graph from :func:`skeleton_to_graph`.

    Parameters
    ----------
    graph : networkx.MultiGraph
        Graph whose nodes carry ``kind`` and whose edges carry ``length_m``.

    Returns
    -------
    dict
        ``n_vertices``, ``n_edges`` (self-loops and parallel edges counted individually),
        ``n_junctions``, ``n_ends``, ``n_rings``, ``n_isolated``, ``n_self_loops``,
        ``n_components`` (connected components, isolated vertices included) and
        ``total_length_m`` (sum of ``length_m`` over the edges, metres).
    """
    if not isinstance(graph, nx.Graph):
        raise TypeError(
            f"graph: expected a networkx graph from skeleton_to_graph, "
            f"received {type(graph).__name__}"
        )
    kinds = [k for _, k in graph.nodes(data="kind")]
    if any(k is None for k in kinds):
        raise ValueError("graph: expected every node to have a 'kind' attribute, some have none")
    return {
        "n_vertices": graph.number_of_nodes(),
        "n_edges": graph.number_of_edges(),
        "n_junctions": kinds.count("junction"),
        "n_ends": kinds.count("end"),
        "n_rings": kinds.count("ring"),
        "n_isolated": kinds.count("isolated"),
        "n_self_loops": nx.number_of_selfloops(graph),
        "n_components": nx.number_connected_components(graph) if kinds else 0,
        "total_length_m": float(sum(d for _, _, d in graph.edges(data="length_m", default=0.0))),
    }


def prune_graph(
    graph: nx.MultiGraph,
    *,
    min_clearance_m: float = 0.0,
    min_spur_m: float = 0.0,
    min_component_m: float = 0.0,
) -> nx.MultiGraph:
    """Trim a topology graph for routing: narrow corridors, short spurs, small pieces.

    Route graphs of real maps carry corridors too narrow for the robot, many short
    *spurs* (a junction to a dead end, from ridges of corners and clutter) and small
    disconnected pieces (around furniture, in unknown space); the paper keeps them all,
    which is this function's default.  In this order:

    1. **Narrow edges**: every edge whose ``min_clearance_m`` is below ``min_clearance_m``
       (say, the robot's radius plus a margin) is removed; edges without clearances (NaN)
       stay.
    2. **Spurs**: every edge between an ``"end"`` vertex and a ``"junction"`` that is
       shorter than ``min_spur_m`` is removed with its end vertex.  This repeats until no
       such spur is left, so a tree of short branches is eaten from its tips (a component
       made only of short spurs shrinks to one isolated vertex).
    3. **Components**: every connected component whose edges total less than
       ``min_component_m`` (isolated vertices: 0 m; an exactly rounded sum, so the order
       of the edges does not matter) is removed.

    After steps 1 and 2 a vertex left with two edge ends is contracted: its two edges
    become one (paths joined at its pixel), as in :func:`skeleton_to_graph`; one left with
    only a self-loop becomes a ``"ring"`` vertex where it is.  The result has no edge
    narrower than ``min_clearance_m``, no spur shorter than ``min_spur_m`` and no
    component shorter than ``min_component_m``.  Vertex and edge attributes keep their
    meaning: joined edges get the joined ``path`` and ``world``, its ``length_m``, and the
    min / mean clearance over its pixels (other edge attributes where both edges agree);
    ``kind`` is updated.  Nodes are renumbered ``0..N-1`` in raster order of ``pixel``
    with edges ``(u, v)``, ``u <= v``, their paths running from ``u`` to ``v``.

    Parameters
    ----------
    graph : networkx.MultiGraph
        A topology graph from :func:`skeleton_to_graph` (or :func:`topojax.build_graph`,
        :class:`topojax.IncrementalMapper`, :func:`topojax.load_graph`); to remove edges
        (``min_clearance_m`` or ``min_spur_m`` > 0) it must have been built with
        ``merge_junction_clusters=False`` (the edges of a merged cluster end at different
        member pixels and cannot be joined).  Not modified.
    min_clearance_m : float, default 0.0
        Edges whose narrowest point (``min_clearance_m``, metres) is below this are
        removed; 0 keeps all.
    min_spur_m : float, default 0.0
        Spurs shorter than this (``length_m``, metres) are removed; 0 keeps all.
    min_component_m : float, default 0.0
        Components whose total edge length is shorter than this are removed; 0 keeps all.

    Returns
    -------
    networkx.MultiGraph
        A new graph; its graph attributes are the input's plus ``pruned_min_clearance_m``,
        ``pruned_min_spur_m`` and ``pruned_min_component_m``.

    Raises
    ------
    TypeError
        If ``graph`` is not an undirected networkx MultiGraph, or a threshold is not a
        number.
    ValueError
        If a threshold is negative or not finite, ``min_spur_m`` or ``min_clearance_m``
        is above 0 for a graph with merged junction clusters (whether or not an edge
        would go), or a vertex lacks ``pixel`` / an edge lacks ``path`` or
        ``length_m``.
    """
    if not isinstance(graph, nx.MultiGraph) or graph.is_directed():
        raise TypeError(
            f"graph: expected an undirected networkx.MultiGraph from skeleton_to_graph, "
            f"received {type(graph).__name__}"
        )
    clearance = nonnegative_metres("min_clearance_m", min_clearance_m)
    spur = nonnegative_metres("min_spur_m", min_spur_m)
    component = nonnegative_metres("min_component_m", min_component_m)
    if (spur > 0 or clearance > 0) and graph.graph.get("merge_junction_clusters"):
        raise ValueError(
            "graph: min_clearance_m or min_spur_m > 0 expects a graph built with "
            "merge_junction_clusters=False, received one with merged junction clusters "
            "(their edges end at different member pixels, so they cannot be joined)"
        )
    with paused_gc():  # many small containers, no reference cycles
        return _prune(graph, clearance, spur, component)


def _prune(graph: nx.MultiGraph, clearance: float, spur: float, component: float) -> nx.MultiGraph:
    """:func:`prune_graph` on checked input."""
    # A light copy: vertex attributes, edges by id, each vertex's edge ids, and degrees (a
    # self-loop counts 2).  The arrays of what survives are copied at the end, so the
    # result shares nothing with ``graph``.
    nodes: dict = {}
    for v, data in graph.nodes(data=True):
        if "pixel" not in data:
            raise ValueError(f"graph: expected every vertex to have a 'pixel', vertex {v} has none")
        nodes[v] = dict(data)
    edges: dict[int, tuple] = {}
    incident: dict = {v: set() for v in nodes}
    degree = dict.fromkeys(nodes, 0)
    for eid, (u, v, data) in enumerate(graph.edges(data=True)):
        for name in ("path", "length_m"):
            if name not in data:
                raise ValueError(
                    f"graph: expected every edge to have a {name!r}, edge {u}-{v} has none"
                )
        edges[eid] = (u, v, dict(data))
        incident[u].add(eid)
        incident[v].add(eid)
        degree[u] += 1
        degree[v] += 1
    res = graph.graph.get("resolution_m")
    res = float(res) if isinstance(res, numbers.Real) and res > 0 else None
    new_ids = itertools.count(len(edges))

    def contract(vertices) -> set:
        """Join the edges of those of ``vertices`` left with two (no loop); returns the
        vertices whose edges changed."""
        changed = set()
        for n in sorted(vertices):  # such vertices are never removed by another's join
            if degree[n] == 2 and len(incident[n]) == 2:  # two edges, no loop
                changed.update(_join(n, nodes, edges, incident, degree, res, new_ids))
            else:
                changed.add(n)
        return {n for n in changed if n in nodes}  # joined ends may be joined away later

    if clearance > 0:
        narrow = [eid for eid, (_, _, d) in edges.items() if _below(d, clearance)]
        ends = set()
        for eid in narrow:
            u, v, _ = edges.pop(eid)
            incident[u].discard(eid)
            incident[v].discard(eid)
            degree[u] -= 1
            degree[v] -= 1  # a self-loop loses 2
            ends.update((u, v))
        contract(ends)

    if spur > 0:
        candidates = list(edges)  # edges that may be spurs; later only changed ones
        while True:
            spurs = []  # (end, hub, edge id), from the degrees before this round's removals
            for eid in candidates:
                u, v, data = edges[eid]
                du, dv = degree[u], degree[v]
                if u != v and data["length_m"] < spur and min(du, dv) == 1 and max(du, dv) >= 3:
                    spurs.append((u, v, eid) if du == 1 else (v, u, eid))
            if not spurs:
                break
            hubs = set()
            for end, hub, eid in spurs:
                del edges[eid], nodes[end], incident[end], degree[end]
                incident[hub].discard(eid)
                degree[hub] -= 1
                hubs.add(hub)
            # only the hubs' degrees changed, and joined edges are new: next round's spurs
            # touch a hub or a joined edge's ends
            changed = contract(hubs)
            candidates = sorted({eid for n in changed for eid in incident[n]})
    if component > 0:
        drop = []
        seen: set = set()
        for start in nodes:
            if start in seen:
                continue
            seen.add(start)
            members, stack, lengths = [start], [start], []
            while stack:
                n = stack.pop()
                for eid in incident[n]:
                    u, v, data = edges[eid]
                    if n == u:  # count each edge once (from its first end)
                        lengths.append(data["length_m"])
                    for m in (u, v):
                        if m not in seen:
                            seen.add(m)
                            members.append(m)
                            stack.append(m)
            if math.fsum(lengths) < component:  # exactly rounded: no order dependence
                drop.extend(members)
        for n in drop:
            for eid in incident.pop(n):
                edges.pop(eid, None)
            del nodes[n], degree[n]
    thresholds = {
        "pruned_min_clearance_m": clearance,
        "pruned_min_spur_m": spur,
        "pruned_min_component_m": component,
    }
    return _renumbered(graph.graph, nodes, edges, degree, thresholds)


def _below(data: dict, clearance: float) -> bool:
    """Is the edge's narrowest clearance known and below ``clearance`` (metres)?"""
    value = data.get("min_clearance_m")
    return value is not None and float(value) < clearance  # NaN compares False


def _copied(data: dict) -> dict:
    return {k: v.copy() if isinstance(v, np.ndarray) else v for k, v in data.items()}


def _same(a: object, b: object) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b))
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # no truth value
        return a is b


def _steps_length(n_straight, n_diagonal, res: float):
    """Length in metres of a path with these numbers of straight and diagonal steps."""
    return (n_straight + n_diagonal * math.sqrt(2.0)) * res


def _running_diagonals(pixels: np.ndarray) -> np.ndarray:
    """Diagonal steps before each pixel of ``pixels`` (K, 2), an integer running count
    (length K).  Paths stored one after another subtract the count at their own first
    pixel, so the step from one path's last pixel to the next one's first is never
    counted and a path's length is a function of the path alone, not of where it sits
    among the others."""
    step = np.abs(np.diff(np.asarray(pixels, np.int64), axis=0))
    return np.concatenate([[0], np.cumsum((step[:, 0] != 0) & (step[:, 1] != 0))])


def path_lengths_m(pixels: np.ndarray, starts, sizes, res: float) -> np.ndarray:
    """``length_m`` of each path stored in ``pixels`` (path ``i``: ``sizes[i]`` rows from
    ``starts[i]``): its straight and diagonal steps, counted as integers."""
    starts = np.asarray(starts, np.int64)
    sizes = np.asarray(sizes, np.int64)
    n_diag = _running_diagonals(pixels)
    diagonal = n_diag[starts + sizes - 1] - n_diag[starts]
    return _steps_length(sizes - 1 - diagonal, diagonal, res)


def cumulative_length_m(pixels: np.ndarray, starts, sizes, res: float) -> np.ndarray:
    """Length in metres from its own path's first pixel to every pixel, counted as
    :func:`path_lengths_m` does (the last pixel of a path has the path's length)."""
    n_diag = _running_diagonals(pixels)
    first = np.repeat(np.asarray(starts, np.int64), sizes)
    steps = np.arange(len(first)) - first
    diagonal = n_diag - n_diag[first]
    return _steps_length(steps - diagonal, diagonal, res)


def _path_length_m(path: np.ndarray, res: float) -> float:
    """``length_m`` of a ``(K, 2)`` pixel path, exactly as :func:`skeleton_to_graph`."""
    return float(path_lengths_m(path, [0], [len(path)], res)[0])


def holds(node: dict, pixel) -> bool:
    """Is ``pixel`` one of the vertex's pixels (its ``pixel``, or any of a merged junction
    cluster's ``pixels``)?  False for a vertex with neither."""
    r, c = int(pixel[0]), int(pixel[1])
    own = node.get("pixel")
    if own is not None and int(own[0]) == r and int(own[1]) == c:
        return True
    members = node.get("pixels")
    if members is None or len(members) == 0:
        return False
    members = np.asarray(members).reshape(-1, 2)
    return bool(np.any((members[:, 0] == r) & (members[:, 1] == c)))


def _ends_at(path: np.ndarray, pixel) -> bool:
    """Is ``pixel`` the last pixel of ``path``?"""
    return int(path[-1, 0]) == int(pixel[0]) and int(path[-1, 1]) == int(pixel[1])


_JOINED = ("path", "world", "length_m", "min_clearance_m", "mean_clearance_m")


def _join(v, nodes: dict, edges: dict, incident: dict, degree: dict, res, new_ids) -> tuple:
    """Join the two edges of vertex ``v`` (degree 2, no self-loop) into one and drop
    ``v``; returns the joined edge's ends.  ``new_ids`` yields unused edge ids.

    The joined path runs through ``v``'s pixel once; its length is recomputed from it
    (``res`` = metres per pixel; None: the two lengths are added up), and its mean
    clearance is the mean over its pixels, from the two edges' means, pixel counts and
    ``v``'s clearance."""
    e1, e2 = sorted(incident[v])
    (u1, v1, ea), (u2, v2, eb) = edges.pop(e1), edges.pop(e2)
    a = u1 if v1 == v else v1
    b = u2 if v2 == v else v2
    pixel = nodes[v]["pixel"]
    p1, w1 = ea["path"], ea.get("world")
    if not _ends_at(p1, pixel):  # first edge: from a to v
        p1, w1 = p1[::-1], None if w1 is None else w1[::-1]
    p2, w2 = eb["path"], eb.get("world")
    if _ends_at(p2, pixel):  # second edge: from v to b
        p2, w2 = p2[::-1], None if w2 is None else w2[::-1]
    n1, n2 = len(p1), len(p2)
    # other attributes (not skeleton_to_graph's) survive where both edges agree
    joined = {
        key: val
        for key, val in ea.items()
        if key not in _JOINED and key in eb and _same(val, eb[key])
    }
    joined["path"] = np.concatenate([p1, p2[1:]])
    if w1 is not None and w2 is not None:
        joined["world"] = np.concatenate([w1, w2[1:]])
    if res is not None:
        joined["length_m"] = _path_length_m(joined["path"], res)
    else:  # not from skeleton_to_graph: add up
        joined["length_m"] = float(ea["length_m"]) + float(eb["length_m"])
    m1, m2 = float(ea.get("min_clearance_m", math.nan)), float(eb.get("min_clearance_m", math.nan))
    joined["min_clearance_m"] = math.nan if math.isnan(m1) or math.isnan(m2) else min(m1, m2)
    c = float(nodes[v].get("clearance_m", math.nan))
    mean1 = float(ea.get("mean_clearance_m", math.nan))
    mean2 = float(eb.get("mean_clearance_m", math.nan))
    joined["mean_clearance_m"] = (mean1 * n1 + mean2 * n2 - c) / (n1 + n2 - 1)
    del nodes[v], incident[v], degree[v]
    incident[a].discard(e1)
    incident[b].discard(e2)
    eid = next(new_ids)
    edges[eid] = (a, b, joined)
    incident[a].add(eid)
    incident[b].add(eid)
    return a, b


def _renumbered(
    attrs: dict, nodes: dict, edges: dict, degree: dict, thresholds: dict
) -> nx.MultiGraph:
    """The pruned graph: nodes ``0..N-1`` in raster order of ``pixel``, kinds from the
    degrees, edges ``(u, v)`` with ``u <= v`` and paths from ``u`` to ``v``."""
    order = sorted(nodes, key=lambda n: (int(nodes[n]["pixel"][0]), int(nodes[n]["pixel"][1])))
    new = {old: i for i, old in enumerate(order)}
    loops = {u for u, v, _ in edges.values() if u == v}
    node_attrs = []
    for old in order:
        data = _copied(nodes[old])
        if degree[old] == 2 and old in loops:
            data["kind"] = "ring"
        else:
            data["kind"] = {0: "isolated", 1: "end"}.get(degree[old], "junction")
        node_attrs.append(data)
    out = []
    for u, v, data in edges.values():
        u, v = sorted((new[u], new[v]))
        if u != v and not holds(node_attrs[v], data["path"][-1]):
            data["path"] = data["path"][::-1]
            if data.get("world") is not None:
                data["world"] = data["world"][::-1]
        out.append((u, v, _copied(data)))
    out.sort(key=lambda e: (e[0], e[1], e[2]["path"][:2].tolist()))
    g = nx.MultiGraph()
    g.graph.update(attrs)
    g.graph.update(thresholds)
    return _fill_multigraph(g, node_attrs, out)


def polyline_keep(xy: np.ndarray, tol: float) -> np.ndarray:
    """Douglas–Peucker: indices of the points of polyline ``xy`` (K, 2) to keep (first and
    last included) so that every point lies within ``tol`` of the kept chain's segment
    between its neighbours."""
    n = len(xy)
    keep = np.zeros(n, dtype=bool)
    keep[[0, n - 1]] = True
    stack = [(0, n - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        a, b = xy[i], xy[j]
        pts = xy[i + 1 : j]
        ab = b - a
        span = float(ab @ ab)
        t = np.zeros(len(pts)) if span == 0 else np.clip((pts - a) @ ab / span, 0.0, 1.0)
        dist = np.hypot(*(pts - (a + t[:, None] * ab)).T)
        m = int(np.argmax(dist))
        if dist[m] > tol:
            m += i + 1
            keep[m] = True
            stack += [(i, m), (m, j)]
    return np.flatnonzero(keep)
