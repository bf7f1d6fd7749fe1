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
