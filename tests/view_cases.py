"""Inputs shared by the viewer's tests (built once per test session)."""

from __future__ import annotations

import json
import re
import zlib
from base64 import b64decode
from functools import lru_cache
from pathlib import Path

import numpy as np

import topojax as tj

INTEL_EXCERPT = Path(__file__).parent / "data" / "intel_first40.log.gz"


@lru_cache(maxsize=1)
def intel_result():
    """The full pipeline on the bundled Intel map."""
    return tj.build_graph(tj.sample_map("intel"))


@lru_cache(maxsize=1)
def office_route_graph():
    """The bundled office map and its route graph (straight shortcuts included)."""
    occupancy = tj.sample_map("office")
    return occupancy, tj.route_graph(occupancy)


@lru_cache(maxsize=1)
def intel_replay():
    """The first 40 scans of the Intel log through a mapper that updates its graph (and
    rooms) every 10 scans, recorded by a Timeline; with the set of edge keys of the
    mapper's graph after each update."""
    mapper = tj.IncrementalMapper(skeleton_every=5, graph_every=10, rooms_every=10)
    timeline = tj.Timeline()
    keys = []
    for scan in tj.read_scans(INTEL_EXCERPT):
        report = mapper.add_scan(scan)
        if timeline.record(mapper, report, scan):
            keys.append({k for *_, k in mapper.graph.edges(keys=True)})
    return mapper, timeline, keys


def payload_of(html: str) -> dict:
    """The data a view page carries."""
    match = re.search(r'<script type="application/json" id="tj-data">(.*?)</script>', html, re.S)
    assert match is not None, "the page has no data element"
    return json.loads(match.group(1))


def unpacked(packed: dict) -> np.ndarray:
    """A packed array of the page's data, back as numpy."""
    types = {"i1": "<i1", "u1": "u1", "i2": "<i2", "i4": "<i4", "u4": "<u4", "f4": "<f4"}
    dtype = np.dtype(types.get(packed["t"], "<f8"))
    return np.frombuffer(zlib.decompress(b64decode(packed["z"])), dtype=dtype)


def crossing_graph():
    """Two straight edges that cross at pixel (5, 5), which is no vertex of either:
    a-b along row 5, c-d along column 5, and b-d round the corner (10, 10); on a free
    11 x 11 map of 1 m pixels.  A query at the crossing may leave along either edge."""
    import networkx as nx

    free = np.ones((11, 11), bool)
    occupancy = tj.OccupancyMap(~free, free, np.zeros_like(free), resolution_m=1.0)
    g = nx.MultiGraph(resolution_m=1.0)
    corners = {"a": (5, 0), "b": (5, 10), "c": (0, 5), "d": (10, 5)}
    for name, pixel in corners.items():
        g.add_node(name, pixel=pixel, world=tuple(occupancy.pixel_to_world(*pixel)))
    lines = {
        ("a", "b"): [(5, c) for c in range(11)],
        ("c", "d"): [(r, 5) for r in range(11)],
        ("b", "d"): [(r, 10) for r in range(5, 11)] + [(10, c) for c in range(9, 4, -1)],
    }
    for (u, v), path in lines.items():
        path = np.array(path, np.int64)
        world = np.array([occupancy.pixel_to_world(r, c) for r, c in path], np.float64)
        g.add_edge(u, v, path=path, world=world, length_m=float(len(path) - 1))
    return occupancy, g


def wall_between(closet: bool = False):
    """A free 40 x 40 map of 0.1 m pixels (walls all round) split by a wall down column 20
    from the top to row 30; a graph (robot radius 0.25 m) of two edges down its sides,
    "l" along column 10 and "r" along column 22, each from row 2 to row 35, joined along
    row 35; with ``closet``, a closet of 5 x 4 free pixels walled off from the graph at
    rows 4-8, columns 14-17, 0.3 m right of the left edge."""
    import networkx as nx

    occupied = np.ones((40, 40), bool)
    occupied[1:-1, 1:-1] = False
    occupied[1:31, 20] = True
    if closet:
        occupied[3:10, 13:19] = True
        occupied[4:9, 14:18] = False
    m = tj.OccupancyMap.from_array(occupied, resolution_m=0.1)
    g = nx.MultiGraph(resolution_m=0.1, shape=(40, 40), robot_radius_m=0.25, snap_m=1.0)
    g.graph["origin"] = tuple(m.origin)
    corners = {"l0": (2, 10), "l1": (35, 10), "r0": (2, 22), "r1": (35, 22)}
    for name, pixel in corners.items():
        g.add_node(name, pixel=pixel, world=tuple(float(x) for x in m.pixel_to_world(*pixel)))
    for u, v in (("l0", "l1"), ("l1", "r1"), ("r1", "r0")):
        (r0, c0), (r1, c1) = corners[u], corners[v]
        n = max(abs(r1 - r0), abs(c1 - c0)) + 1
        path = np.stack([np.linspace(r0, r1, n), np.linspace(c0, c1, n)], 1).astype(np.int64)
        x, y = m.pixel_to_world(path[:, 0], path[:, 1])
        g.add_edge(u, v, path=path, world=np.stack([x, y], 1), length_m=0.1 * (n - 1))
    return m, g
