"""Exports of the mapper's graph as networkx graphs: in the exported map's frame with
the full-map schema, or in global lattice pixels.
"""

from __future__ import annotations

import networkx as nx
import numpy as np

from ..graph import KIND_NAMES
from ._graph_store import edge_ids, edge_paths, vertex_ids
from ._tiles import _unpack


def export_graph(mapper) -> nx.MultiGraph:
    """The graph of :attr:`IncrementalMapper.graph`: pixels relative to the exported
    bounding box, world coordinates, kinds, lengths and clearances as
    :func:`topojax.build_graph` gives them."""
    from ..graph import path_lengths_m
    from ..pipeline import clearance_at

    res = mapper.resolution_m
    out = nx.MultiGraph()
    bbox = mapper._tiles.pixel_bbox
    if bbox is None:
        out.graph.update(resolution_m=res, shape=(0, 0), merge_junction_clusters=False)
        return out
    r0, c0, r1, c1 = bbox
    occ = mapper.occupancy
    d2, obstacles = mapper.sq_distance_px, mapper.obstacles

    def clearance_m(rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        # exact, read at these pixels only (vertex and path pixels)
        flat = rows.astype(np.intp) * d2.shape[1] + cols.astype(np.intp)
        return clearance_at(d2, obstacles, mapper._half, flat).astype(np.float64) * res

    out.graph.update(
        resolution_m=res,
        shape=(r1 - r0, c1 - c0),
        merge_junction_clusters=False,
        origin=tuple(float(v) for v in occ.origin),
        thinning=mapper.config.skeleton.thinning,
    )
    nodes = vertex_ids(mapper).tolist()
    if nodes:
        pix = np.stack(_unpack(mapper._v_key[nodes]), axis=1) - [r0, c0]
        kinds = [KIND_NAMES[code] for code in mapper._v_code[nodes].tolist()]
        wx, wy = occ.pixel_to_world(pix[:, 0], pix[:, 1])
        cl = clearance_m(pix[:, 0], pix[:, 1])
        for i, v in enumerate(nodes):
            rc = (int(pix[i, 0]), int(pix[i, 1]))
            out.add_node(
                v,
                pixel=rc,
                pixels=np.array([rc], np.int32),
                world=(float(wx[i]), float(wy[i])),
                kind=kinds[i],
                clearance_m=float(cl[i]),
            )
    edges = edge_ids(mapper).tolist()
    if edges:
        ends = mapper._e_uv[edges].tolist()
        allp, lens = edge_paths(mapper, np.asarray(edges, np.int64))
        allp = allp.astype(np.int64) - [r0, c0]
        wx, wy = occ.pixel_to_world(allp[:, 0], allp[:, 1])
        world = np.stack([wx, wy], axis=1)
        cl = clearance_m(allp[:, 0], allp[:, 1])
        bounds = np.concatenate([[0], np.cumsum(lens)])
        # as the full-map graph counts them (integer steps), bit for bit
        length_m = path_lengths_m(allp, bounds[:-1], lens, res)
        path32 = allp.astype(np.int32)
        for i, k in enumerate(edges):
            u, v = ends[i]
            a, b = bounds[i], bounds[i + 1]
            out.add_edge(
                u,
                v,
                key=k,
                path=path32[a:b],
                world=world[a:b],
                length_m=float(length_m[i]),
                min_clearance_m=float(cl[a:b].min()),
                mean_clearance_m=float(cl[a:b].mean()),
            )
    return out


def global_graph(mapper) -> nx.MultiGraph:
    """The body of :attr:`IncrementalMapper.graph_global` (global pixels, kinds)."""
    out = nx.MultiGraph()
    ids = vertex_ids(mapper)
    rows, cols = _unpack(mapper._v_key[ids])
    for v, r, c, code in zip(
        ids.tolist(), rows.tolist(), cols.tolist(), mapper._v_code[ids].tolist(), strict=True
    ):
        out.add_node(v, pixel=(r, c), kind=KIND_NAMES[code])
    edges = edge_ids(mapper)
    paths, lens = edge_paths(mapper, edges)
    bounds = np.concatenate([[0], np.cumsum(lens)]).tolist()
    for i, (k, (u, v)) in enumerate(zip(edges.tolist(), mapper._e_uv[edges].tolist(), strict=True)):
        out.add_edge(u, v, key=k, path=paths[bounds[i] : bounds[i + 1]].copy())
    return out
