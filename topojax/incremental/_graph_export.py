"""Exports of the mapper's graph: a :class:`~topojax.graph.GraphStore` of its vertex and
edge tables (in the exported map's frame with the full-map schema, or in global lattice
pixels with pixels and kinds only), and the networkx graph built from it.
"""

from __future__ import annotations

import networkx as nx
import numpy as np

from ..graph import GraphStore, path_lengths_m
from ..maps.occupancy import grid_to_world
from ._clearance import pixel_clearance_m
from ._dense_export import lattice_origin
from ._graph_store import edge_ids, edge_paths, vertex_ids
from ._tiles import _unpack


def export_store(mapper) -> GraphStore:
    """The store of :attr:`IncrementalMapper.graph`: pixels relative to the exported
    bounding box, world coordinates, kinds, lengths and clearances as
    :func:`topojax.build_graph` gives them; node ids and edge keys are the mapper's ids,
    in increasing order.

    Reads the tiles at the vertex and path pixels only (memory in proportion to the graph
    and the tiles, not to the bounding box); equal, bit for bit, to the export computed
    from :attr:`~IncrementalMapper.occupancy`, :attr:`~IncrementalMapper.sq_distance_px`
    and :attr:`~IncrementalMapper.obstacles` with :func:`topojax.pipeline.clearance_at`
    (clearances up to about 2000 pixels; see :func:`pixel_clearance_m`).
    """
    res = mapper.resolution_m
    bbox = mapper._tiles.pixel_bbox
    if bbox is None:
        attrs = {"resolution_m": res, "shape": (0, 0), "merge_junction_clusters": False}
        return GraphStore.empty(attrs)
    mapper._flush_splat()  # clearances from the current distance map
    r0, c0, r1, c1 = bbox
    origin = lattice_origin(res, r1, c0)

    def world(pix: np.ndarray) -> np.ndarray:
        wx, wy = grid_to_world(
            pix[:, 0], pix[:, 1], height=r1 - r0, resolution_m=res, origin=origin
        )
        return np.stack([wx, wy], axis=1)

    nodes, edges = vertex_ids(mapper), edge_ids(mapper)
    node_pixel = np.stack(_unpack(mapper._v_key[nodes]), axis=1) - [r0, c0]
    paths, lens = edge_paths(mapper, edges)
    paths = paths.astype(np.int64) - [r0, c0]
    offsets = np.concatenate([[0], np.cumsum(lens)]).astype(np.int64)
    clearance = pixel_clearance_m(mapper, np.concatenate([node_pixel, paths]) + [r0, c0])
    node_clearance, path_clearance = np.split(clearance, [node_pixel.shape[0]])
    ends = np.searchsorted(nodes, mapper._e_uv[edges])
    return GraphStore(
        node_pixel=node_pixel,
        node_kind=mapper._v_code[nodes],
        node_world=world(node_pixel),
        node_clearance_m=node_clearance,
        edge_u=ends[:, 0],
        edge_v=ends[:, 1],
        path_offsets=offsets,
        path_pixels=paths,
        path_world=world(paths),
        # as the full-map graph counts them (integer steps), bit for bit
        edge_length_m=path_lengths_m(paths, offsets[:-1], lens, res),
        edge_min_clearance_m=_run_min(path_clearance, offsets),
        edge_mean_clearance_m=_run_means(path_clearance, offsets),
        attrs={
            "resolution_m": res,
            "shape": (r1 - r0, c1 - c0),
            "merge_junction_clusters": False,
            "origin": origin,
            "thinning": mapper.config.skeleton.thinning,
        },
        node_ids=nodes,
        edge_keys=edges,
    )


def export_graph(mapper) -> nx.MultiGraph:
    """The graph of :attr:`IncrementalMapper.graph` (see :func:`export_store`)."""
    return export_store(mapper).to_networkx()


def global_store(mapper) -> GraphStore:
    """The store of :attr:`IncrementalMapper.graph_global`: global lattice pixels and
    kinds only; node ids and edge keys are the mapper's ids, in increasing order."""
    nodes, edges = vertex_ids(mapper), edge_ids(mapper)
    paths, lens = edge_paths(mapper, edges)
    ends = np.searchsorted(nodes, mapper._e_uv[edges])
    return GraphStore(
        node_pixel=np.stack(_unpack(mapper._v_key[nodes]), axis=1),
        node_kind=mapper._v_code[nodes],
        edge_u=ends[:, 0],
        edge_v=ends[:, 1],
        path_offsets=np.concatenate([[0], np.cumsum(lens)]).astype(np.int64),
        path_pixels=paths,
        node_ids=nodes,
        edge_keys=edges,
    )


def global_graph(mapper) -> nx.MultiGraph:
    """The body of :attr:`IncrementalMapper.graph_global` (global pixels, kinds)."""
    return global_store(mapper).to_networkx()


def _run_min(values: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Minimum of ``values`` over each run ``offsets[i]:offsets[i + 1]`` (all non-empty)."""
    if offsets.shape[0] == 1:
        return np.zeros(0)
    return np.minimum.reduceat(values, offsets[:-1])


def _run_means(values: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Mean of ``values`` (float64) over each run ``offsets[i]:offsets[i + 1]`` (all
    non-empty), bit for bit as ``values[a:b].mean()`` gives it.

    Runs of one length are averaged as the rows of one C-contiguous array: numpy sums
    along the fast axis with the same pairwise summation as for one run alone
    (``np.add.reduceat`` sums sequentially and can differ in the last bits).
    """
    lens = np.diff(offsets)
    out = np.empty(lens.shape[0])
    order = np.argsort(lens, kind="stable")
    for runs in np.split(order, np.flatnonzero(np.diff(lens[order])) + 1):
        if runs.size:
            rows = offsets[runs, None] + np.arange(lens[runs[0]])
            out[runs] = values[rows].mean(axis=1)
    return out


def topology_result(mapper, update: bool):
    """The body of :meth:`IncrementalMapper.to_result`."""
    from ..pipeline import TopologyResult

    mapper._bbox_or_raise("to_result")
    if update:
        mapper.update_graph()
    return TopologyResult(
        map=mapper.occupancy,
        distance=mapper.distance,
        lap_abs=mapper.lap_abs,
        ridges=mapper.ridges,
        skeleton=mapper.skeleton,
        graph=mapper.graph,
        config=mapper.config,
        timings_s={},
        sq_distance_px=mapper.sq_distance_px,
    )
