"""The viewer with maps other than the graph's own: another map given to ``write_view``
beside a result, and a stored map (a tile folder) found by ``topojax view``."""

from __future__ import annotations

import numpy as np
from view_cases import payload_of

import topojax as tj
from topojax.cli import main
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


def test_more_graphs_of_another_map_beside_a_result_are_noted():
    """A graph given in ``graphs=`` beside a result is drawn over the result's own map:
    one built on another map (shape or origin) is noted, as one under ``map=`` is, not
    drawn off its place without a word; one of the same map is not."""
    res = tj.build_graph(_room_map())
    for other in (_room_map(shape=(50, 70)), _room_map(origin=(3.0, 0.0, 0.0))):
        notes = payload_of(view_html(res, graphs={"other": tj.build_graph(other).graph}))["notes"]
        assert any("the other was not built on the map shown" in n for n in notes), notes
    own = tj.prune_graph(res.graph, min_spur_m=0.5)
    assert payload_of(view_html(res, graphs={"pruned": own}))["notes"] == []


def test_view_command_shows_the_tile_folder_a_tiled_graph_was_built_from(tmp_path, capsys):
    """``graph --tiled`` reads a tile folder; ``topojax view`` of its output opens that
    folder as the map (it is there, a folder, not a file)."""
    occupancy = _room_map(origin=(-1.0, 2.0, 0.4))
    tiles = tmp_path / "map tiles"
    tj.save_tiled_map(occupancy, tiles, tile_px=16)
    out = tmp_path / "out"
    assert main(["graph", str(tiles), "--tiled", "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    text = capsys.readouterr().out
    assert "not there" not in text and f"map {tiles}" in text
    data = payload_of((out / "view.html").read_text(encoding="utf-8"))
    assert data["rasters"][0]["name"] == "map"
    assert data["frame"]["origin"] == [-1.0, 2.0, 0.4]
    assert data["notes"] == []
    expected = tj.view.view_html(tj.build_graph(occupancy).graph, map=occupancy)
    assert data["rasters"][0]["levels"] == payload_of(expected)["rasters"][0]["levels"]


def test_a_route_planned_on_another_map_is_noted():
    """A route is drawn by its world points: one planned on another map (another
    origin, another grid) would lie elsewhere or off the map, drawn silently; its pixels,
    put on the map shown, say whether it was planned there, as for rooms read from a
    file."""
    res = tj.build_graph(_room_map())
    g = res.graph
    ends = [g.nodes[n]["world"] for n in g.nodes if g.degree(n)]
    route = tj.plan_route(g, tuple(ends[0]), tuple(ends[-1]))
    own = payload_of(view_html(res, route=route))["notes"]
    assert not any("route" in n for n in own)
    moved = tj.build_graph(_room_map(origin=(3.0, 0.0, 0.0)))
    notes = payload_of(view_html(moved, route=route))["notes"]
    assert any(
        n.startswith("the route was not planned on the map shown: its pixel ") for n in notes
    ), notes


def test_rooms_with_no_room_are_noted():
    """A segmentation that found no room (a map with no free pixel) draws nothing over
    its map: the page says so, as for an empty graph, instead of a bare map."""
    walls = np.ones((40, 50), bool)
    occupancy = tj.OccupancyMap(
        occupied=walls, free=~walls, unknown=np.zeros_like(walls), resolution_m=0.05
    )
    seg = tj.segment_rooms(occupancy)
    assert not seg.rooms
    notes = payload_of(view_html(seg))["notes"]
    assert "the rooms are empty: no room, no door" in notes, notes
    notes = payload_of(view_html(tj.segment_rooms(_room_map())))["notes"]
    assert not any("rooms are empty" in n for n in notes)
