"""A batch's status for the rooms format: judged by the rooms where only rooms are asked for."""

from __future__ import annotations

import numpy as np

import topojax as tj
from topojax.batch import build_graphs


def _hall(*, walls: bool) -> tj.OccupancyMap:
    """A 4.5 x 4.5 m free square, closed by walls or by unknown space only."""
    free = np.zeros((100, 100), bool)
    free[5:95, 5:95] = True
    other = ~free
    occupied = other if walls else np.zeros_like(free)
    unknown = np.zeros_like(free) if walls else other
    return tj.OccupancyMap(
        occupied=occupied, free=free, unknown=unknown, resolution_m=0.05, source="hall"
    )


def test_only_rooms_asked_for_ignore_the_papers_graph(tmp_path):
    kw = {"workers": 0, "progress": False, "out_dir": tmp_path}
    (rooms_only,) = build_graphs([_hall(walls=False)], formats="rooms", **kw)
    assert rooms_only.vertices == 0 and rooms_only.rooms == 1  # no obstacle: no graph
    assert rooms_only.status == "ok" and "empty graph" not in rooms_only.message
    (both,) = build_graphs([_hall(walls=False)], formats="json,rooms", **kw)
    assert both.status == "empty" and "no occupied pixel" in both.message


def test_a_map_without_rooms_is_empty_and_says_why(tmp_path):
    free = np.zeros((40, 40), bool)
    free[5:15, 5:15] = True  # 0.25 m2: below the smallest room without a doorway
    speck = tj.OccupancyMap(
        occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=0.05, source="speck"
    )
    kw = {"workers": 0, "progress": False, "out_dir": tmp_path}
    for formats in ("rooms", "json,rooms"):
        (rec,) = build_graphs([speck], formats=formats, **kw)
        assert rec.rooms == 0 and rec.status == "empty", formats
        assert "no room found: the map has 100 free pixels" in rec.message, formats
    (walled,) = build_graphs([_hall(walls=True)], formats="json,rooms", **kw)
    assert walled.rooms == 1 and walled.status == "ok"
