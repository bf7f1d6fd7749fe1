"""The arrays of a topology graph (:class:`GraphStore`), the vertex kind codes, and the
construction of networkx graphs through networkx's public API."""

from __future__ import annotations

import gc
import numbers
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field

import networkx as nx
import numpy as np

from .._cpus import check_fits_memory
from .._validate import nx_graph, real_values

__all__ = [
    "KIND_CODES",
    "KIND_END",
    "KIND_ISOLATED",
    "KIND_JUNCTION",
    "KIND_NAMES",
    "KIND_RING",
    "GraphStore",
    "check_networkx_fits",
    "fill_multigraph",
    "paused_gc",
]

#: Bytes a vertex or an edge takes at least in the networkx graph of a store: about 0.8
#: times the 1.07 to 1.2 kB measured on large skeleton graphs (their dicts, tuples and
#: small arrays); :meth:`GraphStore.to_networkx` checks the memory available for it.
NX_BYTES_PER_ELEMENT = 850
#: Bytes an edge's ``waypoints`` adds at least to the networkx graph of a store, besides
#: its 16 bytes a point: about 0.8 times the 215 bytes measured (the array view and the
#: edge's attribute dict grown to six entries).
NX_WAYPOINT_BYTES_PER_EDGE = 170

# Vertex kind codes.  The codes of "isolated" and "end" are their pixel-graph degrees and
# every degree >= 3 is a junction, so ``min(degree, KIND_JUNCTION)`` is the kind of a
# vertex that is not on a ring.
KIND_ISOLATED = 0
KIND_END = 1
KIND_RING = 2
KIND_JUNCTION = 3
KIND_NAMES = {
    KIND_ISOLATED: "isolated",
    KIND_END: "end",
    KIND_RING: "ring",
    KIND_JUNCTION: "junction",
}
KIND_CODES = {name: code for code, name in KIND_NAMES.items()}

_NODE_ATTRS = ("pixel", "pixels", "world", "kind", "clearance_m")
_EDGE_ATTRS = ("path", "world", "length_m", "min_clearance_m", "mean_clearance_m")
# Given all together or not at all (a store of pixels and kinds only).
_METRIC_FIELDS = (
    "node_world",
    "node_clearance_m",
    "path_world",
    "edge_length_m",
    "edge_min_clearance_m",
    "edge_mean_clearance_m",
)


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


def check_networkx_fits(store: GraphStore, context: str, advice: str) -> None:
    """A :class:`~topojax._cpus.MemoryRefusal` where the networkx graph of ``store``
    (:data:`NX_BYTES_PER_ELEMENT` a vertex and an edge; with waypoints,
    :data:`NX_WAYPOINT_BYTES_PER_EDGE` more an edge and 16 a waypoint) exceeds the memory
    available, checked before any of it is built: ``context`` (e.g. ``"graph:"``) begins
    the message, ``advice`` ends it; nothing when it fits or the memory available is not
    known."""
    n, m = store.n_nodes, store.n_edges
    need = NX_BYTES_PER_ELEMENT * (n + m)
    sizes = f"{NX_BYTES_PER_ELEMENT} bytes a vertex and an edge or more"
    if store.waypoints is not None:
        need += NX_WAYPOINT_BYTES_PER_EDGE * m + store.waypoints.nbytes
        sizes += (
            f", and {NX_WAYPOINT_BYTES_PER_EDGE} an edge and 16 a point for its "
            f"{store.waypoints.shape[0]:,} waypoints"
        )
    check_fits_memory(
        need,
        f"{context} the networkx graph of {n:,} vertices and {m:,} edges ({sizes}) takes at least",
        advice,
    )


def fill_multigraph(
    attrs: Mapping, nodes: Iterable, node_attrs: Iterable[dict], edges: Iterable[tuple]
) -> nx.MultiGraph:
    """A new :class:`networkx.MultiGraph` of the given nodes and edges.

    Parameters
    ----------
    attrs : mapping
        Graph attributes.
    nodes : iterable of hashable
        Nodes, in order (new, distinct).
    node_attrs : iterable of dict
        Attributes of each node of ``nodes``, in the same order; the dicts are used as
        given (not copied).
    edges : iterable of tuple
        ``(u, v, key, attrs)`` or ``(u, v, attrs)`` (keys numbered as networkx numbers
        them: the smallest unused int of the node pair), added in order; ``u`` and ``v``
        are nodes of ``nodes``; the attrs dicts are used as given.

    Returns
    -------
    networkx.MultiGraph
        Its nodes, edges, keys and attribute dicts in the order given: the graph that
        ``add_node(n, **a)`` / ``add_edge(u, v, key, **a)`` calls in this order build.

    Notes
    -----
    This is the one place that fills networkx's documented adjacency structure (a dict of
    node -> neighbour -> key -> attribute dict, one key dict shared by both ends) instead
    of calling ``add_edge`` per edge, which costs several times the whole graph stage;
    ``tests/test_graph.py`` checks that both give identical graphs.
    """
    g = nx.MultiGraph()
    g.graph.update(attrs)
    node, adj = g._node, g._adj
    for n, data in zip(nodes, node_attrs, strict=True):
        node[n] = data
        adj[n] = {}
    for edge in edges:
        if len(edge) == 4:
            u, v, key, data = edge
        else:
            u, v, data = edge
            key = None
        keys = adj[u].get(v)
        if keys is None:
            keys = adj[u][v] = {}
            adj[v][u] = keys
        if key is None:
            key = len(keys)
            while key in keys:
                key += 1
        keys[key] = data
    return g


def _array(name: str, value, dtype, kinds: str, shape: tuple) -> np.ndarray:
    """``value`` as a read-only array of ``dtype`` after checking its dtype kind and
    shape (``None`` in ``shape``: any length); ``ml_dtypes`` ones as :func:`real_values`
    takes them."""
    given = np.asarray(value)
    arr = real_values(given)
    if arr.dtype.kind not in kinds:
        expected = "an integer" if kinds == "iu" else "a real"
        raise TypeError(f"{name}: expected {expected} array, received dtype {given.dtype}")
    if arr.ndim != len(shape) or any(
        s is not None and s != a for s, a in zip(shape, arr.shape, strict=True)
    ):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape)
        want += ",)" if len(shape) == 1 else ")"
        raise ValueError(f"{name}: expected shape {want}, received shape {arr.shape}")
    return _readonly(arr.astype(dtype, copy=False))


def _readonly(arr: np.ndarray) -> np.ndarray:
    """A read-only view of ``arr`` (the flags of ``arr`` itself stay as they are)."""
    out = arr.view()
    out.flags.writeable = False
    return out


def _offsets(name: str, value, n: int, total: int) -> np.ndarray:
    """CSR offsets of ``n`` runs over ``total`` rows: int64 (n + 1,), from 0 to ``total``,
    non-decreasing."""
    off = _array(name, value, np.int64, "iu", (n + 1,))
    if off[0] != 0 or off[-1] != total or np.any(np.diff(off) < 0):
        raise ValueError(
            f"{name}: expected non-decreasing offsets from 0 to {total}, received "
            f"{off[0]} .. {off[-1]}" + (" (decreasing)" if np.any(np.diff(off) < 0) else "")
        )
    return off


def _pair_keys(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """networkx's own edge keys for edges added in order: 0, 1, ... per node pair."""
    n = u.shape[0]
    a, b = np.minimum(u, v), np.maximum(u, v)
    order = np.lexsort((np.arange(n), b, a))
    new_pair = np.ones(n, dtype=bool)
    new_pair[1:] = (a[order][1:] != a[order][:-1]) | (b[order][1:] != b[order][:-1])
    start = np.maximum.accumulate(np.where(new_pair, np.arange(n), 0))
    keys = np.empty(n, dtype=np.int64)
    keys[order] = np.arange(n) - start
    return keys


@dataclass(frozen=True, eq=False, repr=False, kw_only=True)
class GraphStore:
    """The topology graph as arrays: vertices, edges with their pixel paths, attributes.

    One row per vertex in the node arrays and one per edge in the edge arrays; edge
    ``i``'s pixels are the rows ``path_offsets[i]:path_offsets[i + 1]`` of the flat
    path arrays.  The arrays are converted to the dtypes below and kept read-only;
    :meth:`to_networkx` gives the networkx graph of :func:`skeleton_to_graph`.
    Without the metric arrays (world coordinates, clearances, lengths: all of them or
    none) the store holds pixels and kinds only, and its networkx graph has only the
    node attributes ``pixel`` and ``kind`` and the edge attribute ``path``.  A route
    graph's store (:func:`topojax.route_graph`) also holds each edge's ``waypoints``,
    the rows ``waypoint_offsets[i]:waypoint_offsets[i + 1]`` of ``waypoints``.

    Parameters
    ----------
    node_pixel : int (N, 2)
        ``(row, col)`` of each vertex's pixel; stored as int64.
    node_kind : int (N,)
        Vertex kind codes (:data:`KIND_NAMES`: 0 isolated, 1 end, 2 ring, 3 junction);
        stored as int8.
    node_world : real (N, 2), optional
        ``(x, y)`` in metres of each vertex pixel's centre; stored as float64.
    node_clearance_m : real (N,), optional
        Clearance at each vertex pixel in metres (NaN: unknown); stored as float64.
    edge_u, edge_v : int (E,)
        Ends of each edge as node *indices* (rows of the node arrays, 0..N-1), not node
        ids; stored as int64.
    path_offsets : int (E + 1,)
        CSR offsets of the edge paths: 0, non-decreasing, ending at P; stored as int64.
    path_pixels : int (P, 2)
        ``(row, col)`` of the pixels of all edge paths, one path after another, each
        from a pixel of its ``u`` to a pixel of its ``v``; stored as int64.
    path_world : real (P, 2), optional
        ``(x, y)`` in metres of each path pixel's centre; stored as float64.
    edge_length_m, edge_min_clearance_m, edge_mean_clearance_m : real (E,), optional
        Length of each path in metres and the min / mean clearance over its pixels in
        metres (NaN: unknown); stored as float64.
    attrs : mapping, default {}
        Graph attributes (``resolution_m``, ``shape``, ``merge_junction_clusters``,
        ``origin``, ...), copied.
    node_ids : int (N,), optional
        Node of each vertex in the networkx graph, distinct; default ``0..N-1``.
    edge_keys : int (E,), optional
        Key of each edge in the networkx graph, distinct per node pair; default 0, 1,
        ... per node pair in edge order (the keys networkx assigns).
    member_offsets : int (N + 1,), optional
        CSR offsets of each vertex's member pixels in ``member_pixels`` (merged
        junction clusters).  Given with ``member_pixels`` or not at all; default: each
        vertex's only member is its own pixel.
    member_pixels : int (M, 2), optional
        ``(row, col)`` of the member pixels, vertex after vertex, each in raster order.
        Only with the metric arrays.
    waypoint_offsets : int (E + 1,), optional
        CSR offsets of each edge's waypoints in ``waypoints``: 0, non-decreasing, ending
        at W; stored as int64.  Given with ``waypoints`` or not at all.
    waypoints : real (W, 2), optional
        ``(x, y)`` in metres of the waypoints of all edges (a route graph's simplified
        polylines, each from its ``u``'s ``world`` to its ``v``'s), one edge after
        another; stored as float64.  Only with the metric arrays.

    Raises
    ------
    TypeError
        If an array has a non-numeric (or bool) dtype, or a float dtype where integers
        are expected.
    ValueError
        If shapes disagree, offsets do not run from 0 to the row count, an edge end is
        not a node index, a kind code is unknown, node ids repeat, two edges of one node
        pair share a key, only some metric arrays are given, member pixels or waypoints
        are given without them, or one array of a CSR pair without the other.
    """

    node_pixel: np.ndarray
    node_kind: np.ndarray
    node_world: np.ndarray | None = None
    node_clearance_m: np.ndarray | None = None
    edge_u: np.ndarray
    edge_v: np.ndarray
    path_offsets: np.ndarray
    path_pixels: np.ndarray
    path_world: np.ndarray | None = None
    edge_length_m: np.ndarray | None = None
    edge_min_clearance_m: np.ndarray | None = None
    edge_mean_clearance_m: np.ndarray | None = None
    attrs: Mapping = field(default_factory=dict)
    node_ids: np.ndarray | None = None
    edge_keys: np.ndarray | None = None
    member_offsets: np.ndarray | None = None
    member_pixels: np.ndarray | None = None
    waypoint_offsets: np.ndarray | None = None
    waypoints: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = np.shape(self.node_pixel)[0] if np.ndim(self.node_pixel) else -1
        self._put("node_pixel", _array("node_pixel", self.node_pixel, np.int64, "iu", (None, 2)))
        kind = _array("node_kind", self.node_kind, np.int64, "iu", (n,))
        known = np.isin(kind, list(KIND_NAMES))
        if not known.all():
            raise ValueError(
                f"node_kind: expected codes in {KIND_NAMES}, received {kind[~known][0]}"
            )
        self._put("node_kind", _readonly(kind.astype(np.int8)))
        given = [name for name in _METRIC_FIELDS if getattr(self, name) is not None]
        if given and len(given) < len(_METRIC_FIELDS):
            missing = [name for name in _METRIC_FIELDS if name not in given]
            raise ValueError(
                f"{', '.join(_METRIC_FIELDS)}: expected all or none, received none for {missing}"
            )
        if given:
            world = _array("node_world", self.node_world, np.float64, "iuf", (n, 2))
            self._put("node_world", world)
            clear = _array("node_clearance_m", self.node_clearance_m, np.float64, "iuf", (n,))
            self._put("node_clearance_m", clear)
        given_ids = self.node_ids is not None  # the default 0..n-1 is distinct
        ids = self.node_ids if given_ids else np.arange(n)
        self._put("node_ids", _array("node_ids", ids, np.int64, "iu", (n,)))
        if given_ids and np.unique(self.node_ids).shape[0] != n:
            raise ValueError("node_ids: expected distinct ids, received repeated ones")
        self._check_edges(n)
        self._check_runs("member_offsets", "member_pixels", n, np.int64, "iu")
        self._check_runs("waypoint_offsets", "waypoints", self.n_edges, np.float64, "iuf")
        self._put("attrs", dict(self.attrs))

    def _put(self, name: str, value) -> None:
        object.__setattr__(self, name, value)  # frozen: only the checks set fields

    def _check_edges(self, n: int) -> None:
        e = np.shape(self.edge_u)[0] if np.ndim(self.edge_u) else -1
        for name in ("edge_u", "edge_v"):
            ends = _array(name, getattr(self, name), np.int64, "iu", (e,))
            outside = (ends < 0) | (ends >= n)
            if outside.any():
                raise ValueError(
                    f"{name}: expected node indices in [0, {n}), received {ends[outside][0]}"
                )
            self._put(name, ends)
        p = np.shape(self.path_pixels)[0] if np.ndim(self.path_pixels) else -1
        self._put("path_pixels", _array("path_pixels", self.path_pixels, np.int64, "iu", (p, 2)))
        self._put("path_offsets", _offsets("path_offsets", self.path_offsets, e, p))
        if self.has_metrics:
            world = _array("path_world", self.path_world, np.float64, "iuf", (p, 2))
            self._put("path_world", world)
            for name in ("edge_length_m", "edge_min_clearance_m", "edge_mean_clearance_m"):
                self._put(name, _array(name, getattr(self, name), np.float64, "iuf", (e,)))
        if self.edge_keys is None:  # numbered as networkx numbers them: distinct per pair
            self._put("edge_keys", _readonly(_pair_keys(self.edge_u, self.edge_v)))
            return
        self._put("edge_keys", _array("edge_keys", self.edge_keys, np.int64, "iu", (e,)))
        a = np.minimum(self.edge_u, self.edge_v)
        b = np.maximum(self.edge_u, self.edge_v)
        order = np.lexsort((self.edge_keys, b, a))
        same = np.diff(a[order]) == 0
        same &= np.diff(b[order]) == 0
        same &= np.diff(self.edge_keys[order]) == 0
        if same.any():
            raise ValueError("edge_keys: expected distinct keys per node pair, received repeats")

    def _check_runs(self, offsets: str, rows: str, n: int, dtype, kinds: str) -> None:
        """The optional CSR pair ``offsets`` (n + 1,) over the (M, 2) array ``rows``: both
        or neither, only with the metric arrays."""
        given_offsets, given_rows = getattr(self, offsets), getattr(self, rows)
        if (given_offsets is None) != (given_rows is None):
            raise ValueError(f"{offsets}, {rows}: expected both or neither, received one")
        if given_rows is None:
            return
        if not self.has_metrics:
            raise ValueError(
                f"{offsets}, {rows}: expected only with the metric arrays "
                f"({', '.join(_METRIC_FIELDS)}), received them without"
            )
        m = np.shape(given_rows)[0] if np.ndim(given_rows) else -1
        self._put(rows, _array(rows, given_rows, dtype, kinds, (m, 2)))
        self._put(offsets, _offsets(offsets, given_offsets, n, m))

    # ---- views --------------------------------------------------------------------------

    @property
    def has_metrics(self) -> bool:
        """Whether the store holds the metric arrays (world coordinates, clearances,
        lengths); without them it holds pixels and kinds only."""
        return self.node_world is not None

    @property
    def n_nodes(self) -> int:
        """Number of vertices N."""
        return int(self.node_pixel.shape[0])

    @property
    def n_edges(self) -> int:
        """Number of edges E (self-loops and parallel edges counted individually)."""
        return int(self.edge_u.shape[0])

    def path(self, i: int) -> np.ndarray:
        """Edge ``i``'s pixels: a read-only int64 (K, 2) view of ``path_pixels``."""
        return self.path_pixels[self.path_offsets[i] : self.path_offsets[i + 1]]

    def members(self, i: int) -> np.ndarray:
        """Vertex ``i``'s member pixels: a read-only int64 (M, 2) view, raster order."""
        if self.member_pixels is None:
            return self.node_pixel[i : i + 1]
        return self.member_pixels[self.member_offsets[i] : self.member_offsets[i + 1]]

    def __repr__(self) -> str:
        return f"GraphStore(n_nodes={self.n_nodes}, n_edges={self.n_edges}, attrs={self.attrs!r})"

    # ---- networkx -----------------------------------------------------------------------

    def to_networkx(self) -> nx.MultiGraph:
        """The networkx graph of these arrays, as :func:`skeleton_to_graph` returns it.

        Returns
        -------
        networkx.MultiGraph
            Nodes ``node_ids`` in store order with ``pixel`` ((row, col) tuple of int),
            ``pixels`` (int32 (M, 2)), ``world`` ((x, y) tuple of float), ``kind`` (name)
            and ``clearance_m`` (float); edges ``(node_ids[u], node_ids[v], key)`` in store
            order with ``path`` (int32 (K, 2)), ``world`` (float64 (K, 2)), ``length_m``,
            ``min_clearance_m`` and ``mean_clearance_m`` (float), and, where the store
            holds them, ``waypoints`` (float64 (K, 2)); graph attributes ``attrs``.
            Without the metric arrays (:attr:`has_metrics`), nodes have only
            ``pixel`` and ``kind`` and edges only ``path``.  Its arrays are views of new
            arrays: it shares no memory with the store.

        Raises
        ------
        MemoryError
            A ``topojax`` ``MemoryRefusal``, before any of it is built, where it would
            take more than the memory available (:data:`NX_BYTES_PER_ELEMENT` a vertex
            and an edge, with waypoints :data:`NX_WAYPOINT_BYTES_PER_EDGE` more an edge
            and 16 a waypoint).
        """
        check_networkx_fits(
            self,
            "graph:",
            "; the graph store holds them as arrays (save_graph_store writes it, "
            "load_graph_store reads it memory-mapped)",
        )
        ids = self.node_ids.tolist()
        pixel = self.node_pixel.tolist()
        kinds = [KIND_NAMES[k] for k in self.node_kind.tolist()]
        # Thousands of small dicts and tuples: a cyclic-GC pass triggered in the middle
        # would scan every live object of the process.
        with paused_gc():
            if self.has_metrics:
                node_attrs = self._node_attrs(pixel, kinds)
            else:
                node_attrs = [
                    {"pixel": (p[0], p[1]), "kind": k} for p, k in zip(pixel, kinds, strict=True)
                ]
            return fill_multigraph(self.attrs, ids, node_attrs, self._edge_tuples())

    def _node_attrs(self, pixel: list, kinds: list) -> list[dict]:
        """The attribute dicts of the vertices of a store with metric arrays, in order."""
        world = self.node_world.tolist()
        clear = self.node_clearance_m.tolist()
        if self.member_pixels is None:
            members, bounds = self.node_pixel.astype(np.int32), range(self.n_nodes + 1)
        else:
            members, bounds = self.member_pixels.astype(np.int32), self.member_offsets.tolist()
        return [
            {
                "pixel": (pixel[i][0], pixel[i][1]),
                "pixels": members[bounds[i] : bounds[i + 1]],
                "world": (world[i][0], world[i][1]),
                "kind": kinds[i],
                "clearance_m": clear[i],
            }
            for i in range(len(pixel))
        ]

    def _edge_tuples(self) -> Iterator[tuple]:
        """``(u, v, key, attrs)`` of every edge for networkx, in store order."""
        ids = self.node_ids
        u = ids[self.edge_u].tolist()
        v = ids[self.edge_v].tolist()
        keys = self.edge_keys.tolist()
        bounds = self.path_offsets.tolist()
        path = self.path_pixels.astype(np.int32)
        if not self.has_metrics:
            for i in range(len(u)):
                yield u[i], v[i], keys[i], {"path": path[bounds[i] : bounds[i + 1]]}
            return
        world = self.path_world.copy()
        length = self.edge_length_m.tolist()
        low = self.edge_min_clearance_m.tolist()
        mean = self.edge_mean_clearance_m.tolist()
        if self.waypoints is not None:
            waypoints, wp_bounds = self.waypoints.copy(), self.waypoint_offsets.tolist()
        for i in range(len(u)):
            a, b = bounds[i], bounds[i + 1]
            attrs = {
                "path": path[a:b],
                "world": world[a:b],
                "length_m": length[i],
                "min_clearance_m": low[i],
                "mean_clearance_m": mean[i],
            }
            if self.waypoints is not None:
                attrs["waypoints"] = waypoints[wp_bounds[i] : wp_bounds[i + 1]]
            yield u[i], v[i], keys[i], attrs

    @classmethod
    def empty(cls, attrs: Mapping | None = None) -> GraphStore:
        """A store without vertices or edges (with the metric arrays, all empty).

        Parameters
        ----------
        attrs : mapping, optional
            Graph attributes, copied; default none.
        """
        none2, none = np.zeros((0, 2)), np.zeros(0)
        return cls(
            node_pixel=none2.astype(np.int64),
            node_kind=none.astype(np.int64),
            node_world=none2,
            node_clearance_m=none,
            edge_u=none.astype(np.int64),
            edge_v=none.astype(np.int64),
            path_offsets=np.zeros(1, np.int64),
            path_pixels=none2.astype(np.int64),
            path_world=none2,
            edge_length_m=none,
            edge_min_clearance_m=none,
            edge_mean_clearance_m=none,
            attrs={} if attrs is None else attrs,
        )

    @classmethod
    def from_networkx(cls, graph: nx.MultiGraph) -> GraphStore:
        """The store of a topology graph (:func:`skeleton_to_graph`, :func:`prune_graph`,
        the incremental mapper, :func:`topojax.route_graph`, :func:`topojax.load_graph`).

        Parameters
        ----------
        graph : networkx.MultiGraph
            Undirected; integer nodes with exactly the attributes ``pixel``, ``pixels``,
            ``world``, ``kind`` and ``clearance_m``; integer edge keys; edges with exactly
            ``path``, ``world``, ``length_m``, ``min_clearance_m`` and
            ``mean_clearance_m``, and either every edge or none with ``waypoints``
            ((K, 2) real: a route graph's).  Nodes and edges are read in the graph's
            order.

        Returns
        -------
        GraphStore
            ``to_networkx()`` of it equals ``graph``: the same nodes, edges, keys and
            attributes in the same order, with paths and member pixels as int32.
            ``member_pixels`` is None when every vertex's only member is its own pixel,
            ``waypoints`` and ``waypoint_offsets`` when no edge has waypoints.

        Raises
        ------
        TypeError
            If ``graph`` is not an undirected MultiGraph or a node or key is not an int.
        ValueError
            If a vertex or edge lacks one of those attributes or has others, a kind is
            unknown, only some edges have ``waypoints`` or an edge's are not (K, 2).
        """
        nx_graph("graph", graph, multigraph=True)
        ids, index = _node_ids(graph)
        nodes = [_exact(graph.nodes[n], _NODE_ATTRS, f"vertex {n}") for n in ids]
        try:
            kinds = [KIND_CODES[d["kind"]] for d in nodes]
        except (KeyError, TypeError) as exc:
            raise ValueError(
                f"graph: expected vertex kinds in {tuple(KIND_CODES)}, received {exc}"
            ) from None
        vertices = [f"vertex {n}" for n in ids]
        members = _pair_runs([d["pixels"] for d in nodes], np.int64, vertices, "pixels")
        pixel = _pair_rows([d["pixel"] for d in nodes], np.int64, vertices, "pixel")
        node_world = _pair_rows([d["world"] for d in nodes], np.float64, vertices, "world")
        own = all(m.shape[0] == 1 for m in members) and (
            not members or np.array_equal(np.concatenate(members), pixel)
        )
        edges = list(graph.edges(keys=True, data=True))
        waypoints = _edge_waypoints(edges)
        names = _EDGE_ATTRS if waypoints is None else (*_EDGE_ATTRS, "waypoints")
        for u, v, k, d in edges:
            _exact(d, names, f"edge {u}-{v} (key {k!r})")
            if isinstance(k, bool) or not isinstance(k, numbers.Integral):
                raise TypeError(f"graph: expected integer edge keys, received {k!r}")
        names = [f"edge {u}-{v} (key {k!r})" for u, v, k, _ in edges]
        paths = _pair_runs([d["path"] for *_, d in edges], np.int64, names, "path")
        worlds = _pair_runs([d["world"] for *_, d in edges], np.float64, names, "world")
        lens = [p.shape[0] for p in paths]
        return cls(
            node_pixel=pixel,
            node_kind=np.array(kinds, dtype=np.int8),
            node_world=node_world,
            node_clearance_m=np.array([d["clearance_m"] for d in nodes], dtype=np.float64),
            edge_u=np.array([index[u] for u, _, _, _ in edges], dtype=np.int64),
            edge_v=np.array([index[v] for _, v, _, _ in edges], dtype=np.int64),
            path_offsets=np.concatenate([[0], np.cumsum(lens, dtype=np.int64)]),
            path_pixels=_stacked(paths, np.int64),
            path_world=_stacked(worlds, np.float64),
            edge_length_m=_floats(edges, "length_m"),
            edge_min_clearance_m=_floats(edges, "min_clearance_m"),
            edge_mean_clearance_m=_floats(edges, "mean_clearance_m"),
            attrs=dict(graph.graph),
            node_ids=np.array(ids, dtype=np.int64),
            edge_keys=np.array([k for _, _, k, _ in edges], dtype=np.int64),
            member_offsets=None if own else np.cumsum([0] + [m.shape[0] for m in members]),
            member_pixels=None if own else _stacked(members, np.int64),
            waypoint_offsets=None if waypoints is None else _run_offsets(waypoints),
            waypoints=None if waypoints is None else _stacked(waypoints, np.float64),
        )


def _node_ids(graph: nx.MultiGraph) -> tuple[list, dict]:
    """The graph's nodes in order (checked to be ints) and each node's index."""
    ids = list(graph.nodes)
    for n in ids:
        if isinstance(n, bool) or not isinstance(n, numbers.Integral):
            raise TypeError(f"graph: expected integer nodes, received {n!r}")
    return ids, {n: i for i, n in enumerate(ids)}


def _exact(data: dict, names: tuple, where: str) -> dict:
    """``data`` after checking that it has exactly the attributes ``names``."""
    if set(data) != set(names):
        missing = [k for k in names if k not in data]
        extra = sorted(str(k) for k in data if k not in names)
        raise ValueError(
            f"graph: expected {where} to have exactly the attributes {names}; "
            f"missing {missing}, others {extra}"
        )
    return data


def _edge_waypoints(edges: list) -> list[np.ndarray] | None:
    """Each edge's ``waypoints`` as float64 (K, 2), in order; None where no edge has any
    (a graph of :func:`skeleton_to_graph`'s schema)."""
    have = sum("waypoints" in d for _, _, _, d in edges)
    if not have:
        return None
    if have < len(edges):
        u, v, k, _ = next(e for e in edges if "waypoints" not in e[3])
        raise ValueError(
            f"graph: expected 'waypoints' on every edge or on none, received {have} of "
            f"{len(edges)} edges with them (not edge {u}-{v} (key {k!r}))"
        )
    names = [f"edge {u}-{v} (key {k!r})" for u, v, k, _ in edges]
    return _pair_runs([d["waypoints"] for *_, d in edges], np.float64, names, "waypoints")


def _pair_rows(values: list, dtype, wheres: list, name: str) -> np.ndarray:
    """``values`` (one pair each) as a ``dtype`` array (n, 2); ValueError naming
    ``wheres[i]``'s ``name`` for the first that is not a pair of numbers."""
    if not values:
        return np.zeros((0, 2), dtype=dtype)
    try:
        rows = np.array(values, dtype=dtype)
    except (TypeError, ValueError, OverflowError):
        rows = None
    if rows is not None and rows.ndim == 2 and rows.shape[1] == 2:
        return rows
    for value, where in zip(values, wheres, strict=True):
        _pairs([value], dtype, where, name)
    raise AssertionError("unreachable: a row that is no pair was found above")


def _pair_runs(values: list, dtype, wheres: list, name: str) -> list[np.ndarray]:
    """Each of ``values`` as a ``dtype`` array (K, 2), checked as :func:`_pairs` checks
    one (``wheres[i]`` names the owner of ``values[i]``), in one pass where all are."""
    try:
        runs = [np.asarray(v, dtype=dtype) for v in values]
    except (TypeError, ValueError, OverflowError):
        runs = None
    if runs is not None and all(r.ndim == 2 and r.shape[1] == 2 for r in runs):
        return runs
    return [_pairs(v, dtype, w, name) for v, w in zip(values, wheres, strict=True)]


def _pairs(value, dtype, where: str, name: str) -> np.ndarray:
    """``value`` as a ``dtype`` array (K, 2) (an empty one as (0, 2)); ValueError naming
    ``where``'s ``name`` when it is not one: a (K, 3) array is not taken apart into pairs."""
    try:
        points = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError, OverflowError) as exc:
        points, why = None, f"{type(value).__name__} ({exc})"
    else:
        why = f"shape {points.shape}"
        if points.size == 0:
            return points.reshape(0, 2)
    if points is None or points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(
            f"graph: expected {where} to have {name!r} of shape (K, 2) of real numbers, "
            f"received {why}"
        )
    return points


def _run_offsets(runs: list[np.ndarray]) -> np.ndarray:
    """CSR offsets of the row counts of ``runs``: int64 (len(runs) + 1,)."""
    return np.concatenate([[0], np.cumsum([r.shape[0] for r in runs], dtype=np.int64)])


def _stacked(arrays: list, dtype) -> np.ndarray:
    """Row-wise concatenation of (K, 2) arrays as ``dtype`` (0, 2) when there are none."""
    if not arrays:
        return np.zeros((0, 2), dtype=dtype)
    return np.concatenate([np.asarray(a, dtype=dtype) for a in arrays])


def _floats(edges: list, name: str) -> np.ndarray:
    return np.array([d[name] for _, _, _, d in edges], dtype=np.float64)
