"""The viewer with maps other than the graph's own: another map given to ``write_view``
beside a result."""

from __future__ import annotations

import numpy as np
from view_cases import payload_of

import topojax as tj
from topojax.view import view_html


def _room_map(shape=(60, 80), origin=(0.0, 0.0, 0.0)) -> tj.OccupancyMap:
    occupied = np.zeros(shape, bool)
    occupied[[0, -1], :] = True
    occupied[:, [0, -1]] = True
    occupied[shape[0] // 2, : shape[1] // 2] = True
    return tj.OccupancyMap(
        occupied=occupied,
        free=~occupied,
        unknown=np.zeros(shape, bool),
        resolution_m=0.05,
        origin=origin,
    )


def test_a_result_shown_over_another_map_leaves_its_fields_out_and_says_so():
    """The distance map, ridges and skeleton of a result lie on its own map's grid: over
    a map of another shape or origin they are left out with a note, and the graph is drawn
    with its own note, rather than a refusal that names a field the caller never gave."""
    res = tj.build_graph(_room_map())
    for other in (_room_map(shape=(50, 70)), _room_map(origin=(3.0, 0.0, 0.0))):
        data = payload_of(view_html(res, map=other))
        assert [r["name"] for r in data["rasters"]] == ["map"]
        assert any("distance map, ridges and skeleton" in n for n in data["notes"])
        assert any("graph was not built on the map shown" in n for n in data["notes"])
        assert data["graphs"][0]["n_edges"] == res.graph.number_of_edges()
    same = payload_of(view_html(res, map=_room_map()))  # its own map again: all layers
    assert [r["name"] for r in same["rasters"]] == ["map", "distance", "ridges", "skeleton"]
    assert same["notes"] == []
