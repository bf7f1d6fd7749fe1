"""Skeleton -> topology graph: the checks of :func:`skeleton_to_graph`'s arguments, world
coordinates, vertex kinds, the optional junction-cluster merge, and the assembly of the
networkx graph.  The definitions (pixel graph, vertices, edges, rings) are in
:mod:`topojax.graph`.

How the graph compares with the original implementation and with skan:
``docs/graph-semantics.md``.
"""

from __future__ import annotations

from collections.abc import Callable

import networkx as nx
import numpy as np

from .._validate import (
    flag,
    metres_per_pixel,
    nonnegative_metres,
    nx_graph,
    plain_length_m,
    real_values,
    unmasked,
)
from .geometry import _edge_pixel_index, orient, path_lengths_m
from .store import KIND_JUNCTION, GraphStore
from .trace import (
    _DC,
    _DR,
    _POPCOUNT,
    _dense_keys,
    _link_table,
    raw_graph,
)

PixelToWorld = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]

# --------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------


def _as_skeleton(skeleton: object) -> np.ndarray:
    arr = real_values(np.asarray(unmasked("skeleton", skeleton)))
    if arr.dtype.kind not in "biuf":
        raise TypeError(
            f"skeleton: expected a bool-like array (bool, or integers/floats in {{0, 1}}), "
            f"received dtype {arr.dtype} (type {type(skeleton).__name__})"
        )
    if arr.ndim != 2:
        raise ValueError(
            f"skeleton: expected a 2-D array (H, W), received an array with shape {arr.shape}"
        )
    if arr.dtype == np.bool_:
        return arr
    bad = (arr != 0) & (arr != 1)
    if bad.any():
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"skeleton: expected only the values 0 and 1, received {arr[first]!r} at "
            f"(row, col) = {first}"
        )
    return arr != 0


def _check_clearance(clearance_px: object, skel: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """Validate ``clearance_px`` at the skeleton's pixels ``flat`` (flat indices, raster
    order) and return its values there as float64 (n,): only those are read, so only those
    are checked, not the whole map."""
    arr = _real_clearances(clearance_px)
    if arr.shape != skel.shape:
        raise ValueError(
            f"clearance_px: expected shape {skel.shape} (the skeleton's shape), "
            f"received shape {arr.shape}"
        )
    return _check_clearance_values(arr.ravel()[flat], skel.shape, flat)


def _real_clearances(values: object) -> np.ndarray:
    """``values`` as an array of real numbers (bfloat16 as float32, :func:`real_values`);
    a TypeError naming ``clearance_px`` for another dtype."""
    arr = real_values(np.asarray(unmasked("clearance_px", values)))
    if arr.dtype.kind not in "iuf":
        raise TypeError(
            f"clearance_px: expected a real numeric array (pixels), received dtype {arr.dtype}"
        )
    return arr


def _check_clearance_values(
    values: np.ndarray, shape: tuple[int, ...], flat: np.ndarray
) -> np.ndarray:
    """Clearances at the pixels ``flat`` as float64 (n,), checked real, non-negative, not
    NaN."""
    vals = _real_clearances(values).astype(np.float64, copy=False)
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
    x, y = real_values(np.asarray(x)), real_values(np.asarray(y))
    if x.dtype.kind not in "iuf" or y.dtype.kind not in "iuf":
        raise TypeError(
            f"pixel_to_world: expected a callable returning real (x, y) arrays, received "
            f"dtypes {x.dtype} and {y.dtype}"
        )
    n = rows.shape[0]
    if x.shape != (n,) or y.shape != (n,):
        raise ValueError(
            f"pixel_to_world: expected x and y of shape ({n},) for {n} input pixels, "
            f"received shapes {x.shape} and {y.shape}"
        )
    xy = np.stack([x, y], axis=1).astype(np.float64, copy=False)
    bad = ~np.isfinite(xy).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"pixel_to_world: expected finite x and y, received ({float(xy[i, 0])!r}, "
            f"{float(xy[i, 1])!r}) at (row, col) = ({rows[i]:g}, {cols[i]:g})"
        )
    return xy


#: Pixels converted to world coordinates per call of the conversion (bounds its
#: temporaries; each pixel's coordinates do not depend on the others).  A graph of fewer
#: path and vertex pixels takes one call.
_WORLD_CHUNK_PX = 1 << 13


def _world_of(
    path_rc: np.ndarray,
    vr: np.ndarray,
    vc: np.ndarray,
    shape: tuple[int, int],
    res: float,
    pixel_to_world: PixelToWorld | None,
) -> np.ndarray:
    """World (x, y) of the path pixels ``path_rc`` (P, 2) and then of the vertex pixels
    ``(vr, vc)``: float64 (P + V, 2), converted a chunk of pixels at a time."""
    n_path = path_rc.shape[0]
    n = n_path + vr.shape[0]
    out = np.empty((n, 2), np.float64)
    for a in range(0, n, _WORLD_CHUNK_PX):
        b = min(a + _WORLD_CHUNK_PX, n)
        pa, pb = min(a, n_path), min(b, n_path)  # the chunk's path pixels, then vertices
        va, vb = max(a, n_path) - n_path, max(b, n_path) - n_path
        r = np.concatenate([path_rc[pa:pb, 0], vr[va:vb]]).astype(np.float64)
        c = np.concatenate([path_rc[pa:pb, 1], vc[va:vb]]).astype(np.float64)
        out[a:b] = _world_coords(r, c, shape, res, pixel_to_world)
    return out


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
    return skeleton_graph_store(
        skeleton,
        clearance_px=clearance_px,
        resolution_m=resolution_m,
        pixel_to_world=pixel_to_world,
        merge_junction_clusters=merge_junction_clusters,
    ).to_networkx()


def skeleton_graph_store(
    skeleton: np.ndarray,
    *,
    clearance_px: np.ndarray | None = None,
    resolution_m: float = 1.0,
    pixel_to_world: PixelToWorld | None = None,
    merge_junction_clusters: bool = False,
) -> GraphStore:
    """:func:`skeleton_to_graph` as arrays: the graph's vertices, edges and paths in one
    :class:`GraphStore`, without networkx's per-vertex and per-edge objects.

    Parameters
    ----------
    skeleton, clearance_px, resolution_m, pixel_to_world, merge_junction_clusters
        As for :func:`skeleton_to_graph`.

    Returns
    -------
    GraphStore
        Its :meth:`~GraphStore.to_networkx` is :func:`skeleton_to_graph`'s graph.

    Raises
    ------
    TypeError, ValueError
        As :func:`skeleton_to_graph`.
    """
    skel = _as_skeleton(skeleton)
    res = metres_per_pixel("resolution_m", resolution_m)
    if pixel_to_world is not None and not callable(pixel_to_world):
        raise TypeError(
            f"pixel_to_world: expected a callable (rows, cols) -> (x, y) or None, "
            f"received {type(pixel_to_world).__name__}"
        )
    merge = flag("merge_junction_clusters", merge_junction_clusters)
    flat = np.flatnonzero(skel.ravel())  # skeleton pixels, raster order
    if clearance_px is None:
        clear = None
    elif callable(clearance_px):
        clear = _check_clearance_values(clearance_px(flat), skel.shape, flat)
    else:
        clear = _check_clearance(clearance_px, skel, flat)
    # pixel keys row * (W + 1) + col (see _dense_keys), in place of the flat indices
    keys = flat // skel.shape[1]
    keys += flat
    del flat
    return _store_of_keys(skel.shape, keys, clear, res, pixel_to_world, merge)


def pixels_graph_store(
    shape: tuple[int, int],
    flat: np.ndarray,
    *,
    clearance_px: np.ndarray | None = None,
    resolution_m: float = 1.0,
    pixel_to_world: PixelToWorld | None = None,
    merge_junction_clusters: bool = False,
) -> GraphStore:
    """:func:`skeleton_graph_store` of a skeleton given by its pixels instead of an image.

    Parameters
    ----------
    shape : (H, W)
        The skeleton image's shape.
    flat : int (n,)
        Flat indices ``row * W + col`` of the skeleton's pixels, strictly increasing
        (raster order); the graph needs no image-sized array.
    clearance_px : real (n,), optional
        Clearance in pixels at those pixels (>= 0, not NaN).
    resolution_m, pixel_to_world, merge_junction_clusters
        As for :func:`skeleton_to_graph`.

    Returns
    -------
    GraphStore
        The store :func:`skeleton_graph_store` gives for the image holding these pixels.
    """
    if len(shape) != 2 or min(int(v) for v in shape) < 1:
        raise ValueError(f"shape: expected (H, W) with H, W >= 1, received {shape!r}")
    shape = (int(shape[0]), int(shape[1]))
    given = np.asarray(flat)
    idx = real_values(given)
    if idx.ndim != 1 or (idx.size and idx.dtype.kind not in "iu"):
        raise TypeError(
            f"flat: expected a 1-D integer array, received dtype {given.dtype} shape {idx.shape}"
        )
    idx = idx.astype(np.int64, copy=False)
    if idx.size and (idx[0] < 0 or idx[-1] >= shape[0] * shape[1] or np.any(np.diff(idx) <= 0)):
        raise ValueError(
            f"flat: expected strictly increasing indices in [0, {shape[0] * shape[1]}), "
            f"received {idx.size} indices from {idx.min()} to {idx.max()}"
        )
    res = metres_per_pixel("resolution_m", resolution_m)
    if pixel_to_world is not None and not callable(pixel_to_world):
        raise TypeError(
            f"pixel_to_world: expected a callable (rows, cols) -> (x, y) or None, "
            f"received {type(pixel_to_world).__name__}"
        )
    merge = flag("merge_junction_clusters", merge_junction_clusters)
    clear = None if clearance_px is None else _check_clearance_values(clearance_px, shape, idx)
    return _skeleton_store(shape, idx, clear, res, pixel_to_world, merge)


def _skeleton_store(
    shape: tuple[int, ...],
    flat: np.ndarray,
    clear: np.ndarray | None,
    res: float,
    pixel_to_world: PixelToWorld | None,
    merge: bool,
) -> GraphStore:
    """The :class:`GraphStore` of :func:`skeleton_to_graph` on checked input: the
    skeleton's pixels as flat indices ``flat`` (raster order) of an image of ``shape``,
    and their clearances in pixels (float64 (n,), aligned with ``flat``) or None."""
    keys, _ = _dense_keys(shape, flat)
    return _store_of_keys(shape, keys, clear, res, pixel_to_world, merge)


def _store_of_keys(
    shape: tuple[int, ...],
    keys: np.ndarray,
    clear: np.ndarray | None,
    res: float,
    pixel_to_world: PixelToWorld | None,
    merge: bool,
) -> GraphStore:
    """:func:`_skeleton_store` of the skeleton's pixels given as their keys
    ``row * (W + 1) + col`` (:func:`_dense_keys`, raster order) of an image of
    ``shape``, with their clearances in pixels (float64 (n,), aligned with ``keys``) or
    None."""
    shape = (int(shape[0]), int(shape[1]))
    attrs = {"resolution_m": res, "shape": shape, "merge_junction_clusters": merge}
    if keys.size == 0:
        return GraphStore.empty(attrs)

    # Pixels are numbered 0..n-1 in raster order (their index in ``flat`` and ``keys``);
    # vertices and paths refer to them by that number until the end.  Arrays are dropped
    # as soon as they are used.
    stride = shape[1] + 1
    v_idx, v_kind, e_u, e_v, e_off, path = raw_graph(keys, stride)
    u_id = np.searchsorted(v_idx, e_u)
    v_id = np.searchsorted(v_idx, e_v)
    del e_u, e_v
    lens = np.diff(e_off)
    u_id, v_id, path = orient(u_id, v_id, e_off, lens, path)  # paths from u to v, u <= v
    vr = keys[v_idx] // stride
    vc = keys[v_idx] % stride
    members = None
    if merge:
        junction = v_kind == KIND_JUNCTION
        tiny = (lens == 2) & junction[u_id] & junction[v_id]
        if tiny.any():
            v_idx, v_kind, vr, vc, members, new_id = _merged_vertices(
                v_idx, v_kind, vr, vc, u_id[tiny], v_id[tiny]
            )
            # Drop the intra-cluster 2-pixel edges, remap and re-orient the others.
            keep = np.flatnonzero(~tiny)
            path = path[_edge_pixel_index(e_off, keep)]
            lens = lens[keep]
            e_off = np.concatenate([[0], np.cumsum(lens)])
            u_id, v_id = new_id[u_id[keep]], new_id[v_id[keep]]
            u_id, v_id, path = orient(u_id, v_id, e_off, lens, path)
    path_rc = np.empty((path.shape[0], 2), np.int64)
    np.floor_divide(keys[path], stride, out=path_rc[:, 0])
    np.remainder(keys[path], stride, out=path_rc[:, 1])
    del keys
    length_m, min_c, mean_c = _edge_values(path_rc, path, e_off, lens, clear, res)
    node_clear = np.full(v_idx.shape[0], np.nan) if clear is None else clear[v_idx] * res
    del path, clear
    # Edges sorted by (u, v), then in tracing order; their paths one after another.
    order = np.lexsort((np.arange(u_id.shape[0]), v_id, u_id))
    path_rc = np.take(path_rc, _edge_pixel_index(e_off, order), axis=0)  # a row gather
    n_path = path_rc.shape[0]
    world = _world_of(path_rc, vr, vc, shape, res, pixel_to_world)
    return GraphStore(
        node_pixel=np.stack([vr, vc], axis=1),
        node_kind=v_kind,
        node_world=world[n_path:],
        node_clearance_m=node_clear,
        edge_u=u_id[order],
        edge_v=v_id[order],
        path_offsets=np.concatenate([[0], np.cumsum(lens[order])]),
        path_pixels=path_rc,
        path_world=world[:n_path],
        edge_length_m=length_m[order],
        edge_min_clearance_m=min_c[order],
        edge_mean_clearance_m=mean_c[order],
        attrs=attrs,
        member_offsets=None if members is None else members[0],
        member_pixels=None if members is None else members[1],
    )


def _merged_vertices(
    v_idx: np.ndarray,
    v_kind: np.ndarray,
    vr: np.ndarray,
    vc: np.ndarray,
    tiny_u: np.ndarray,
    tiny_v: np.ndarray,
) -> tuple:
    """Vertices after merging the junction clusters joined by the 2-pixel edges
    ``tiny_u``-``tiny_v`` (vertex numbers).

    Returns the new vertices' ``v_idx``, ``v_kind``, ``vr`` and ``vc`` (each cluster's
    member nearest to its centroid, then first in raster order; new vertices in raster
    order), their members as ``(offsets (N + 1,), pixels (M, 2) int64)`` in raster order,
    and the new vertex number of every old vertex.
    """
    # imported here: scipy.sparse is slow to import and only merging needs it
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n_v = v_idx.shape[0]
    adj = coo_matrix((np.ones(tiny_u.shape[0], dtype=np.int8), (tiny_u, tiny_v)), shape=(n_v, n_v))
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
    members = (
        np.searchsorted(new_id[member_order], np.arange(n_lab + 1)),
        np.stack([vr, vc], axis=1)[member_order],
    )
    kind = np.where(size[label[rep_sorted]] > 1, KIND_JUNCTION, v_kind[rep_sorted])
    return v_idx[rep_sorted], kind, vr[rep_sorted], vc[rep_sorted], members, new_id


def _edge_values(
    path_rc: np.ndarray,
    path: np.ndarray,
    e_off: np.ndarray,
    lens: np.ndarray,
    clear: np.ndarray | None,
    res: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Length, min and mean clearance in metres of each edge (float64 (E,) each; NaN
    clearances without ``clear``), from the paths' pixels ``path_rc`` (P, 2) and pixel
    numbers ``path`` (P,) in CSR layout ``e_off`` / ``lens``."""
    n_e = lens.shape[0]
    if n_e == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    starts = e_off[:-1]
    length_m = path_lengths_m(path_rc, starts, lens, res)
    if clear is None:
        return length_m, np.full(n_e, np.nan), np.full(n_e, np.nan)
    cval = clear[path] * res
    return length_m, np.minimum.reduceat(cval, starts), np.add.reduceat(cval, starts) / lens


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
        ``total_length_m`` (sum of ``length_m`` over the edges, metres; an edge without
        one counts 0).

    Raises
    ------
    TypeError
        If ``graph`` is not an undirected networkx graph, or an edge's ``length_m`` is
        not a number.
    ValueError
        If a node has no ``kind``, or an edge's ``length_m`` is negative or not finite.
    """
    nx_graph("graph", graph)  # undirected: its components are counted
    kinds = [k for _, k in graph.nodes(data="kind")]
    if any(k is None for k in kinds):
        raise ValueError("graph: expected every node to have a 'kind' attribute, some have none")
    total_m = 0.0
    for u, v, length in graph.edges(data="length_m", default=0.0):
        if plain_length_m(length):
            total_m += length
        else:
            total_m += nonnegative_metres(f"graph: edge {u!r}-{v!r}: 'length_m'", length)
    return {
        "n_vertices": graph.number_of_nodes(),
        "n_edges": graph.number_of_edges(),
        "n_junctions": kinds.count("junction"),
        "n_ends": kinds.count("end"),
        "n_rings": kinds.count("ring"),
        "n_isolated": kinds.count("isolated"),
        "n_self_loops": nx.number_of_selfloops(graph),
        "n_components": nx.number_connected_components(graph) if kinds else 0,
        "total_length_m": total_m,
    }
