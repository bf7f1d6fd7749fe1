"""The viewer page as written (without a browser): what it carries, what it refuses, the
timeline file and ``topojax view`` on folders of results.  ``test_view_browser.py``
opens the pages in a real browser."""

from __future__ import annotations

import copy
import gzip
import inspect
import json
import re
import shutil
import subprocess
from pathlib import Path

import cv2
import networkx as nx
import numpy as np
import pytest
from view_cases import intel_replay, intel_result, office_route_graph, payload_of, unpacked

import topojax as tj
from topojax.cli import main
from topojax.view import View, view_html
from topojax.view._encode import packed


@pytest.fixture(scope="module")
def res():
    return intel_result()


def test_page_is_self_contained(res, tmp_path):
    path = tj.write_view(res, tmp_path / "v.html")
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>")
    # nothing is fetched: no external script, style, image or font
    assert not re.search(r"""(src|href)\s*=\s*["']?(https?:)?//""", text)
    assert "@import" not in text and "url(http" not in text
    assert text.count("<script") == 2  # the data and the viewer's own script
    assert "TJ.Router" in text and "DecompressionStream" in text


def test_payload_has_the_layers_and_the_graph(res):
    data = payload_of(view_html(res))
    assert [r["name"] for r in data["rasters"]] == ["map", "distance", "ridges", "skeleton"]
    h, w = res.map.shape
    assert data["frame"] == {
        "height": h,
        "width": w,
        "res": res.map.resolution_m,
        "origin": list(res.map.origin),
    }
    (g,) = data["graphs"]
    assert (g["n_vertices"], g["n_edges"]) == (
        res.graph.number_of_nodes(),
        res.graph.number_of_edges(),
    )
    assert g["routable"] and g["label"] == "graph"
    nodes = list(res.graph.nodes(data=True))
    assert np.array_equal(unpacked(g["vx"]), [d["world"][0] for _, d in nodes])
    clear = unpacked(g["clear"])
    assert np.allclose(clear, [d["clearance_m"] for _, d in nodes], rtol=1e-6)
    # the paths as pixel steps: their running sums are the edges' paths
    steps = unpacked(g["edges"]["rc"]).reshape(-1, 2)
    pixels = np.cumsum(steps, axis=0)
    want = np.concatenate([np.asarray(p) for *_, p in res.graph.edges(data="path")])
    assert np.array_equal(pixels, want)
    assert "xy" not in g["edges"]  # world = the map's pixel_to_world of the paths


def test_map_pyramid_ends_in_one_tile(res):
    data = payload_of(view_html(res))
    levels = data["rasters"][0]["levels"]
    assert levels[0]["step"] == 1 and (levels[0]["width"], levels[0]["height"]) == (
        res.map.shape[1],
        res.map.shape[0],
    )
    assert [lv["step"] for lv in levels] == [2**k for k in range(len(levels))]
    assert len(levels[-1]["tiles"]) == 1 and max(levels[-1]["width"], levels[-1]["height"]) <= 512


def test_extra_graphs_rooms_and_route(res):
    pruned = tj.prune_graph(res.graph, min_clearance_m=0.3, min_spur_m=0.5)
    route = tj.plan_route(pruned, (5.0, 30.0), (33.0, 5.0), max_snap_m=2.0)
    seg = tj.segment_rooms(res)
    data = payload_of(view_html(res, graphs={"pruned": pruned}, rooms=seg, route=route))
    assert [g["label"] for g in data["graphs"]] == ["graph", "pruned"]
    assert len(data["rooms"]["rooms"]) == seg.n_rooms and len(data["rooms"]["doors"]) == len(
        seg.doors
    )
    assert data["route"]["length_m"] == route.length_m


@pytest.mark.parametrize("name", ["graph", "", "  "])
def test_an_extra_graph_needs_a_layer_name_of_its_own(res, name):
    # two layers named "graph" (or one blank) could not be told apart in the layer list
    with pytest.raises(ValueError, match=rf"^graphs: expected a name .* received {name!r}$"):
        view_html(res, graphs={name: res.graph})


def test_a_pruning_result_labels_its_graph(res):
    cfg = tj.PipelineConfig(graph=tj.GraphConfig(min_spur_m=0.5))
    pruned = tj.build_graph(res.map, config=cfg)
    assert payload_of(view_html(pruned))["graphs"][0]["label"] == "pruned graph"


def test_rooms_alone_and_a_route_graph_with_its_map():
    occupancy, routes = office_route_graph()
    data = payload_of(view_html(routes, map=occupancy))
    (g,) = data["graphs"]
    assert g["label"] == "route graph" and g["routable"]
    assert g["n_edges"] == routes.number_of_edges()
    assert [r["name"] for r in data["rasters"]] == ["map"]
    seg = tj.segment_rooms(occupancy)
    data = payload_of(view_html(seg))
    assert data["graphs"] == [] and len(data["rooms"]["rooms"]) == seg.n_rooms
    room = data["rooms"]["rooms"][0]
    assert room["area_m2"] == seg.rooms[0].area_m2
    assert np.allclose(np.reshape(room["polygon"], (-1, 2)), seg.rooms[0].polygon, atol=1e-4)
    assert len(room["holes"]) == len(seg.rooms[0].holes)
    for ring, hole in zip(room["holes"], seg.rooms[0].holes, strict=True):
        assert np.allclose(np.reshape(ring, (-1, 2)), hole, atol=1e-4)


def test_rooms_carry_the_rings_round_their_holes():
    from topojax.view._rooms_data import rooms_payload

    hole = np.array([[1.0, 1.0], [1.0, 2.0], [2.0, 2.0], [2.0, 1.0]])
    outer = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0], [0.0, 3.0]])
    loop = tj.rooms.Room(1, 8.0, (1.5, 1.5), outer, (0, 0, 5, 5), holes=(hole, hole + 0.25))
    (room,) = rooms_payload(((loop,), ()))["rooms"]
    assert room["holes"] == [hole.ravel().tolist(), (hole + 0.25).ravel().tolist()]


def test_rooms_carry_the_point_their_id_is_written_at():
    from room_maps import ring_round_a_room

    from topojax.view._rooms_data import rooms_payload

    seg = ring_round_a_room()
    rooms = rooms_payload(seg)["rooms"]
    for room, sent in zip(seg.rooms, rooms, strict=True):
        assert sent["label"] == pytest.approx(room.label_point, abs=1e-4)
        assert seg.room_at(sent["label"]) == room.id


_DRAW_ROOMS = """
const fs = require("fs");
global.window = {};
eval(fs.readFileSync(process.argv[1], "utf8"));
const texts = [];
const noop = () => {};
const ctx = {
  beginPath: noop, moveTo: noop, lineTo: noop, closePath: noop, fill: noop, stroke: noop,
  fillRect: noop, measureText: (t) => ({ width: 7 * t.length }),
  fillText: (t, x, y) => texts.push([t, x, y]),
};
const frame = { worldToView: (x, y) => [10 * x, -10 * y] };
const view = { z: 2, tx: 5, ty: 300 };
window.TJ.roomColour = () => "#000";
window.TJ.drawRooms(ctx, view, frame, JSON.parse(process.argv[2]));
process.stdout.write(JSON.stringify(texts));
"""


@pytest.mark.skipif(shutil.which("node") is None, reason="no node on the PATH")
def test_the_page_writes_each_room_id_at_its_label_point():
    from room_maps import ring_round_a_room

    from topojax.view._rooms_data import rooms_payload

    rooms = rooms_payload(ring_round_a_room())["rooms"]
    old = {**rooms[1], "centroid": [1.0, 2.0]}  # a timeline saved before: no label
    del old["label"]
    draw = Path(tj.view.__file__).parent / "static" / "draw.js"
    out = subprocess.run(
        ["node", "-e", _DRAW_ROOMS, str(draw), json.dumps([rooms[0], old])],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    (t1, x1, y1), (t2, x2, y2) = json.loads(out)
    lx, ly = rooms[0]["label"]
    assert t1 == "1" and (x1, y1) == pytest.approx((20 * lx + 5, -20 * ly + 300.5))
    assert t2 == "2" and (x2, y2) == pytest.approx((25.0, 260.5))


def test_a_route_graph_with_its_map_carries_the_robots_feasible_pixels():
    from topojax.routegraph.feasible import feasible_space

    occupancy, routes = office_route_graph()
    (g,) = payload_of(view_html(routes, map=occupancy))["graphs"]
    assert g["entry"]["reach_m"] == routes.graph["snap_m"] == 1.0
    bits = np.unpackbits(unpacked(g["entry"]["feasible"]))[: occupancy.free.size]
    want = feasible_space(occupancy, 0.3).feasible
    np.testing.assert_array_equal(bits.reshape(occupancy.free.shape), want)
    # without its map, with another map, or for a graph without a robot radius: none
    assert payload_of(view_html(routes))["graphs"][0]["entry"] is None
    other = tj.sample_map("intel")
    assert payload_of(view_html(routes, map=other))["graphs"][0]["entry"] is None
    paper = tj.build_graph(occupancy).graph
    assert payload_of(view_html(paper, map=occupancy))["graphs"][0]["entry"] is None
    # a window of the map, or a robot radius that is no number of metres: none, and the
    # page's notes say why (the view is still written)
    x, y = occupancy.pixel_to_world(300, 300)
    data = payload_of(view_html(routes, map=occupancy, window=(x - 5, y - 5, x + 5, y + 5)))
    assert data["graphs"][0]["entry"] is None
    assert any("join it at the nearest point: a window" in n for n in data["notes"])
    bad = routes.copy()
    bad.graph["robot_radius_m"] = float("nan")
    data = payload_of(view_html(bad, map=occupancy))
    assert data["graphs"][0]["entry"] is None
    assert any("its robot_radius_m: expected a finite number of metres" in n for n in data["notes"])


def test_a_graph_without_paths_is_drawn_but_not_routed():
    g = nx.MultiGraph()
    g.add_node(0, world=(0.0, 0.0), kind="end")
    g.add_node(1, world=(1.0, 0.0), kind="end")
    g.add_edge(0, 1, world=np.array([[0.0, 0.0], [1.0, 0.0]]))
    (payload,) = payload_of(view_html(g))["graphs"]
    assert not payload["routable"] and "path" in payload["why_not_routable"]
    assert "no map" in " ".join(payload_of(view_html(g))["notes"])


def test_a_graph_with_an_infinite_edge_length_says_so():
    """An edge whose ``length_m`` is not a finite number is named with its length, not
    said to lack a path it has."""
    g = tj.skeleton_to_graph(np.array([[1, 1, 1], [0, 1, 0], [0, 1, 0]]), resolution_m=0.5)
    u, v, k = next(iter(g.edges(keys=True)))
    g.edges[u, v, k]["length_m"] = float("inf")
    (payload,) = payload_of(view_html(g))["graphs"]
    assert not payload["routable"]
    assert payload["why_not_routable"] == (
        f"edge ({u!r}, {v!r}, {k!r}): expected a finite 'length_m' >= 0, received inf"
    )


def _edited_tee(**graph_attrs):
    g = tj.skeleton_to_graph(np.array([[1, 1, 1], [0, 1, 0], [0, 1, 0]]), resolution_m=0.5)
    g.graph.update(graph_attrs)
    return g


@pytest.mark.parametrize("frame", [True, False])
@pytest.mark.parametrize(
    ("where", "value", "words"),
    [
        ("vertex", "here", r"vertex 0: expected a world position \(x, y\), received 'here'"),
        ("vertex", (1.0, 2.0, 3.0), r"vertex 0: expected a world position .* \(1.0, 2.0, 3.0\)"),
        ("edge", "here", r"edge \(0, 1, 0\): expected finite \(x, y\) points of shape"),
        (
            "vertex",
            (np.nan, 0.0),
            r"vertex 0: expected a finite world position \(x, y\), received \(nan, 0.0\)",
        ),
    ],
)
def test_a_graph_with_edited_world_coordinates_is_refused_naming_them(frame, where, value, words):
    """A vertex's or edge's ``world`` edited into a str or a triple, or (without the
    graph's map attributes) into NaN, is refused naming it, not left to fail inside
    NumPy ("could not convert string to float", "cannot reshape") or in converting NaN
    to an integer."""
    g = _edited_tee() if frame else nx.MultiGraph(_edited_tee())
    if not frame:
        g.graph.clear()
    if where == "vertex":
        g.nodes[0]["world"] = value
    else:
        g.edges[0, 1, 0]["world"] = value
    with pytest.raises(ValueError, match=rf"^graph: {words}"):
        view_html(g)


def test_a_graph_with_a_non_finite_origin_is_drawn_by_its_world_coordinates():
    """A recorded origin with NaN or infinity put NaN into the page's JSON (refused there
    as out of range); it is no frame, as a missing origin is not."""
    for origin in ((np.nan, 0.0, 0.0), (0.0, 0.0, np.inf)):
        (payload,) = payload_of(view_html(_edited_tee(origin=origin)))["graphs"]
        assert payload["routable"]


def test_an_empty_route_graph_is_noted_with_its_reason():
    occupancy = tj.sample_map("office")
    with pytest.warns(UserWarning, match="empty route graph: no known-free region"):
        routes = tj.route_graph(occupancy, robot_radius_m=50.0)
    assert routes.number_of_nodes() == 0
    notes = payload_of(view_html(routes, map=occupancy))["notes"]
    assert (
        f"the route graph is empty: no vertex, no edge; its note: {routes.graph['note']}" in notes
    )


def test_a_map_given_beside_a_graph_of_another_map_is_noted(res):
    """``map=`` may draw another map under a graph, but the page says when the graph was
    not built on it (shape, resolution or origin differ), instead of nothing."""
    own = payload_of(view_html(res.graph, map=res.map))["notes"]
    assert not any("not built on the map shown" in n for n in own)
    other = tj.sample_map("office")
    notes = payload_of(view_html(res.graph, map=other))["notes"]
    assert any(
        "graph was not built on the map shown: expected the graph's map of shape" in n
        for n in notes
    )


def test_rooms_of_another_map_are_noted(res):
    """Rooms segmented on another map are drawn where they lie, over the wrong walls: the
    page says so (as for a graph), instead of nothing."""
    own = payload_of(view_html(res, rooms=tj.segment_rooms(res.map)))["notes"]
    assert not any("rooms were not segmented" in n for n in own)
    office = tj.sample_map("office")
    notes = payload_of(view_html(res, rooms=tj.segment_rooms(office)))["notes"]
    assert any(
        "the rooms were not segmented on the map shown: expected their map of shape "
        "(727, 1234), received a map of shape (708, 763)" in n
        for n in notes
    )
    moved = tj.OccupancyMap(
        occupied=res.map.occupied,
        free=res.map.free,
        unknown=res.map.unknown,
        resolution_m=res.map.resolution_m,
        origin=(1.0, 0.0, 0.0),
    )
    notes = payload_of(view_html(res, rooms=tj.segment_rooms(moved)))["notes"]
    assert any(
        "rooms were not segmented on the map shown: expected their map with origin" in n
        for n in notes
    )


def test_rooms_read_from_a_file_that_records_another_map_are_noted(res, tmp_path):
    """A rooms file records its map: rooms of a map that was cropped on the right (their
    pixels lie where they were, the map shown has more columns) are noted as not
    segmented on the map shown, as a segmentation of it would be."""
    m = res.map
    cut = tj.OccupancyMap(
        m.occupied[:, :-40], m.free[:, :-40], m.unknown[:, :-40],
        resolution_m=m.resolution_m, origin=m.origin,
    )  # fmt: skip
    pair = tj.load_rooms(tj.save_rooms(tj.segment_rooms(cut), tmp_path / "cut.geojson"))
    notes = payload_of(view_html(res, rooms=pair))["notes"]
    h, w = m.shape
    assert (
        "the rooms were not segmented on the map shown: expected their map of shape "
        f"({h}, {w - 40}), received a map of shape ({h}, {w})"
    ) in notes, notes


def test_rooms_read_from_a_file_of_another_map_are_noted(res, tmp_path):
    """A (rooms, doors) pair that records no map (load_rooms' of another tool's file, or
    one put together): its doors' pixel ends and its rooms' pixel boxes, put on the map
    shown, say whether they were made on it."""
    own = tj.load_rooms(tj.save_rooms(tj.segment_rooms(res.map), tmp_path / "own.geojson"))
    assert own[1], "doors to check"
    for pair in (own, tuple(own)):
        notes = payload_of(view_html(res, rooms=pair))["notes"]
        assert not any("rooms were not segmented" in n for n in notes)
    office = tj.segment_rooms(tj.sample_map("office"))
    other = tj.load_rooms(tj.save_rooms(office, tmp_path / "office.geojson"))
    notes = payload_of(view_html(res, rooms=other))["notes"]  # the file's map is named
    assert any(n.endswith(f"expected their map of shape {office.labels.shape}, received a map "
                          f"of shape {res.map.shape}") for n in notes), notes  # fmt: skip
    other = tuple(other)  # no map recorded
    notes = payload_of(view_html(res, rooms=other))["notes"]
    assert any(
        re.fullmatch(
            r"the rooms were not segmented on the map shown: door 1 ends on pixels "
            r"\[\[\d+, \d+\], \[\d+, \d+\]\] of their map, which lie at pixels .* of "
            r"the map shown",
            n,
        )
        for n in notes
    ), notes
    doorless = (other[0], ())  # the rooms alone: their outlines leave their pixel boxes
    notes = payload_of(view_html(res, rooms=doorless))["notes"]
    assert any(
        n.startswith("the rooms were not segmented on the map shown: room 1's outline ")
        for n in notes
    ), notes


def test_bad_arguments_name_themselves(res, tmp_path):
    with pytest.raises(TypeError, match="obj: expected a TopologyResult"):
        tj.write_view(42, tmp_path / "v.html")
    with pytest.raises(TypeError, match="graphs: expected a dict"):
        tj.write_view(res, tmp_path / "v.html", graphs=[res.graph])
    with pytest.raises(TypeError, match=r"^graphs\['r'\]: expected an undirected networkx graph"):
        tj.write_view(res, tmp_path / "v.html", graphs={"r": res.graph.to_directed()})
    with pytest.raises(TypeError, match=r"^graphs: expected a dict of name \(str\) .* key 1 \(int"):
        tj.write_view(res, tmp_path / "v.html", graphs={1: res.graph})
    with pytest.raises(TypeError, match="route: expected a topojax.Route"):
        tj.write_view(res, tmp_path / "v.html", route="a")
    with pytest.raises(TypeError, match=r"path: expected a path \(str or os.PathLike\)"):
        tj.write_view(res, None)
    with pytest.raises(ValueError, match="nothing to show"):
        tj.write_view(nx.MultiGraph(), tmp_path / "v.html")
    assert not (tmp_path / "v.html").exists()


def test_a_value_the_page_cannot_hold_is_named():
    import dataclasses

    g = nx.MultiGraph()
    g.add_node(0, world=(0.0, 0.0), pixel=(1, 0))
    g.add_node(1, world=(0.1, 0.0), pixel=(1, 1))
    g.add_edge(0, 1, path=[(1, 0), (1, 1)], world=[(0.0, 0.0), (0.1, 0.0)], length_m=0.1)
    route = tj.plan_route(g, (0.0, 0.0), (0.1, 0.0))
    for field, value, where in [
        ("length_m", float("nan"), r"route\.length_m is nan"),
        ("goal_snap_m", float("inf"), r"route\.goal_snap_m is inf"),
    ]:
        bad = dataclasses.replace(route, **{field: value})
        with pytest.raises(ValueError, match=f"^the view's data: {where}, expected a finite"):
            view_html(g, route=bad)


def test_rooms_with_coordinates_near_the_float_limit_are_drawn(res):
    # rounding them to 0.1 mm would make them infinite, which the page cannot hold
    from topojax.rooms import Room

    ring = np.array([[0.0, 0.0], [1e308, 0.0], [1e308, 1e308], [0.0, 1e308]])
    room = Room(1, 1.0, (2.0, 3.0), ring, (0, 0, 0, 0))
    data = payload_of(view_html(res, rooms=([room], [])))
    assert data["rooms"]["rooms"][0]["polygon"][2:4] == [1e308, 0.0]


def test_a_page_that_cannot_be_written_is_refused_before_the_work(res, tmp_path, monkeypatch):
    import topojax.view as view

    def no_work(*args, **kwargs):
        raise AssertionError("the page was made for a path it cannot be written to")

    monkeypatch.setattr(view, "view_html", no_work)
    (tmp_path / "afile").write_text("x")
    (tmp_path / "d.html").mkdir()
    cases = [
        (tmp_path / "afile" / "v.html", NotADirectoryError, "afile in .* is a file, not a folder"),
        (tmp_path / "d.html", IsADirectoryError, "expected a file name, received the folder"),
        (tmp_path / "none" / "v.html", FileNotFoundError, "whose folder .*none does not exist"),
    ]
    for target, error, words in cases:
        with pytest.raises(error, match=f"^path: .*{words}"):
            tj.write_view(res, target)
        with pytest.raises(error, match=f"^path: .*{words}"):
            View("<html></html>").save(target)
        with pytest.raises(error, match=f"^path: .*{words}"):
            tj.Timeline().save(target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "d.html"]


def test_a_map_too_large_is_refused_with_the_limit_and_a_way_out(res, tmp_path):
    h, w = res.map.shape
    with pytest.raises(ValueError, match=rf"{h} x {w} pixels .* max_pixels=100000 .*window="):
        tj.write_view(res, tmp_path / "v.html", max_pixels=100_000)
    # a window of it fits
    x0, y0 = res.map.pixel_to_world(h - 1, 0)
    path = tj.write_view(
        res, tmp_path / "v.html", max_pixels=100_000, window=(x0, y0, x0 + 10.0, y0 + 8.0)
    )
    data = payload_of(path.read_text())
    assert (data["frame"]["height"], data["frame"]["width"]) == (161, 201)
    (g,) = data["graphs"]
    assert 0 < g["n_edges"] < res.graph.number_of_edges()
    assert g["routable"] and "xy" not in g["edges"]  # still on the (window's) grid
    assert any("window" in n for n in data["notes"])


class _CountingReader:
    """An array read through a TiledMap that records every window read."""

    def __init__(self, array):
        self.array, self.shape, self.dtype = array, array.shape, array.dtype
        self.reads = []

    def read(self, r0, r1, c0, c1):
        self.reads.append((r1 - r0) * (c1 - c0))
        return self.array[r0:r1, c0:c1]


def test_a_map_on_disk_is_viewed_reading_only_the_window(res, tmp_path):
    """A map larger than memory (a TiledMap, or build_graph_tiled's result) is shown as
    the same map in memory would be; a window reads only its pixels, and a map above
    max_pixels is refused before any is read."""
    reader = _CountingReader(res.map.to_image())
    tiled = tj.TiledMap(reader, resolution_m=res.map.resolution_m, origin=res.map.origin)
    h, w = res.map.shape
    x0, y0 = res.map.pixel_to_world(h - 1, 0)
    window = (x0 + 3.0, y0 + 2.0, x0 + 13.0, y0 + 10.0)
    with pytest.raises(ValueError, match=r"max_pixels=100000 .*window="):
        view_html(res.graph, map=tiled, max_pixels=100_000)
    assert reader.reads == []
    with pytest.raises(
        ValueError, match=r"window of it with the graph's map \(map=.*open_tiled_map"
    ):
        view_html(res.graph, max_pixels=100_000)  # a graph alone: window= needs its map
    got = payload_of(view_html(res.graph, map=tiled, window=window, max_pixels=100_000))
    assert 0 < sum(reader.reads) <= got["frame"]["height"] * got["frame"]["width"]
    want = payload_of(view_html(res.graph, map=res.map, window=window))
    for key in ("frame", "graphs", "notes"):
        assert got[key] == want[key], key
    assert got["rasters"][0] == want["rasters"][0]  # the map's pyramid
    whole = payload_of(view_html(res.graph, map=tiled))
    assert whole["rasters"][0] == payload_of(view_html(res.graph, map=res.map))["rasters"][0]
    # the result of build_graph_tiled shows its map and graph
    result = tj.build_graph_tiled(tj.save_tiled_map(res.map, tmp_path / "tiles", tile_px=128))
    with pytest.raises(ValueError, match=r"max_pixels=100000 .*window="):
        view_html(result, max_pixels=100_000)
    assert "graph" not in vars(result)  # refused before the networkx graph is built
    page = payload_of(view_html(result, window=window))
    assert page["frame"] == want["frame"] and page["graphs"][0]["n_edges"] > 0
    assert (
        page["graphs"]
        == payload_of(view_html(result.graph, map=result.map, window=window))["graphs"]
    )


@pytest.mark.parametrize(
    ("window", "error", "match"),
    [
        ((1, 2, 3), ValueError, "four finite numbers"),
        ((5, 0, 1, 1), ValueError, "x_min < x_max"),
        # rows and columns first (a region's order): the order expected is named
        (
            (0, 10, 0, 10),
            ValueError,
            r"\(x_min, y_min, x_max, y_max\) in metres with x_min < x_max",
        ),
        ("abcd", TypeError, "window: expected"),
        (("0", "0", "5", "5"), TypeError, r"window: expected .*received tuple \('0'"),
        ((False, 0, True, 1), TypeError, r"window: expected .*received tuple \(False"),
        ((-100, -100, -90, -90), ValueError, "less than 2 x 2 pixels"),
    ],
)
def test_bad_windows(res, window, error, match):
    with pytest.raises(error, match=match):
        view_html(res, window=window)


def test_show_is_an_inline_frame(res):
    view = tj.show(res, height_px=420)
    assert isinstance(view, View)
    out = view._repr_html_()
    assert out.startswith("<iframe srcdoc=") and "height: 420px" in out
    assert "<script" not in out  # the page sits escaped inside srcdoc
    assert view.html.startswith("<!DOCTYPE html>")


def test_show_names_an_option_it_does_not_take():
    # write_view's path is no option of show: named as such, not as an internal function's
    with pytest.raises(TypeError, match=r"path: expected one of write_view's options \(title,"):
        tj.show(tj.OccupancyMap.from_array(np.zeros((8, 8), np.uint8)), path="x.html")
    with pytest.raises(ValueError, match="height_px: expected an int >= 1"):
        tj.show(tj.OccupancyMap.from_array(np.zeros((8, 8), np.uint8)), height_px=0)
    # show takes view_html's options, which are write_view's but its path
    from topojax.view import view_html

    shown = set(inspect.signature(view_html).parameters) - {"obj"}
    assert shown == set(inspect.signature(tj.write_view).parameters) - {"obj", "path"}


@pytest.mark.parametrize("text", [None, 5, b"<html></html>"])
def test_a_view_of_no_page_is_refused(text):
    # not later, in the notebook's display or in save(), with an error about len() or encode
    with pytest.raises(TypeError, match=r"text: expected a str \(the page's HTML\), received"):
        View(text)


def test_timeline_keeps_every_update_and_round_trips(tmp_path):
    mapper, timeline, keys = intel_replay()
    assert timeline.n_frames == len(keys) == 4
    data = timeline.payload()
    frames = data["frames"]
    sizes = unpacked(data["pool"]["sizes"])
    assert len(sizes) == len(set().union(*keys))  # each edge once
    before: set = set()
    pool_keys = {}
    for frame, now in zip(frames, keys, strict=True):
        added, removed = unpacked(frame["added"]), unpacked(frame["removed"])
        assert len(unpacked(frame["edges"])) == len(now)
        assert len(added) == len(now - before) and len(removed) == len(before - now)
        for k, i in zip(sorted(now - before), sorted(added), strict=True):
            pool_keys[i] = k
        before = now
    assert [f["scan"] for f in frames] == [9, 19, 29, 39]
    assert len(unpacked(data["path"]["x"])) == 40
    assert frames[-1]["rooms"] >= 0 and data["rooms"][frames[-1]["rooms"]]
    path = timeline.save(tmp_path / "timeline.json.gz")
    back = tj.Timeline.load(path)
    assert back.n_frames == 4 and back.payload() == timeline.payload()
    # a timeline saved while recording records on as the one it was saved from
    going_on = copy.deepcopy(timeline)  # (intel_replay's is shared)
    for timeline_now in (going_on, back):  # the last step again (a final update): none
        timeline_now.snapshot(mapper, rooms=True)
    assert back.n_frames == 4 and back.payload() == going_on.payload()
    going_on.snapshot(mapper, scan_index=40, rooms=True)
    back.snapshot(mapper, scan_index=40, rooms=True)
    assert back.n_frames == 5 and back.payload() == going_on.payload()
    # one saved without what recording on needs (an older file) is to view only
    doc = json.loads(gzip.decompress(path.read_bytes()))
    del doc["continue"]
    path.write_bytes(gzip.compress(json.dumps(doc).encode()))
    with pytest.raises(ValueError, match="loaded from a file"):
        tj.Timeline.load(path).snapshot(mapper)


@pytest.mark.parametrize("max_map_px", [100, 300, 600, 2000])
def test_a_timeline_keeps_map_pictures_of_at_most_max_map_px(max_map_px):
    mapper, _, _ = intel_replay()
    timeline = tj.Timeline(max_map_px=max_map_px)
    timeline.snapshot(mapper)
    level = timeline.payload()["frames"][0]["map"]["level"]
    side = max(level["width"], level["height"])
    assert side <= max_map_px and (side > max_map_px // 2 or side == max(mapper.occupancy.shape))


def test_a_timeline_prints_what_it_recorded(tmp_path):
    """A timeline's repr says what it holds (updates, scans as the page numbers them,
    poses, the last graph), not its address."""
    assert repr(tj.Timeline()) == "Timeline(no update yet, 0 robot poses, max_map_px=1024)"
    mapper, timeline, _ = intel_replay()
    n, e = timeline.last_counts()
    want = (
        f"Timeline(4 updates at scans 10 to 40, 40 robot poses, last graph {n} vertices, "
        f"{e} edges, max_map_px=1024)"
    )
    assert repr(timeline) == want
    path = timeline.save(tmp_path / "timeline.json.gz")
    assert repr(tj.Timeline.load(path)) == want
    doc = json.loads(gzip.decompress(path.read_bytes()))
    del doc["continue"]  # one saved from a loaded timeline: to view only
    path.write_bytes(gzip.compress(json.dumps(doc).encode()))
    assert repr(tj.Timeline.load(path)) == (
        f"Timeline(4 updates at scans 10 to 40, 40 robot poses, last graph {n} vertices, "
        f"{e} edges; loaded from a file, to view only)"
    )


def test_a_timeline_file_that_unpacks_past_its_share_of_memory_is_refused(tmp_path, monkeypatch):
    """A small gzip file can unpack to gigabytes (and gzip records no size to trust): it
    is unpacked a megabyte at a time and refused once past a quarter of the memory
    available, before its JSON is parsed."""
    import topojax.view.timeline as timeline

    bomb = tmp_path / "timeline.json.gz"
    bomb.write_bytes(gzip.compress(b" " * (8 << 20)))  # 8 MiB of spaces in 8 kB
    monkeypatch.setattr(timeline, "available_memory_bytes", lambda: 16 << 20)
    from topojax._cpus import MemoryRefusal

    with pytest.raises(MemoryRefusal, match=rf"^timeline file {bomb}: unpacks to more than"):
        tj.Timeline.load(bomb)
    monkeypatch.setattr(timeline, "available_memory_bytes", lambda: 40 << 20)
    with pytest.raises(ValueError, match="not a gzip-compressed JSON file"):  # all spaces
        tj.Timeline.load(bomb)
    cut = tmp_path / "cut.json.gz"
    cut.write_bytes(gzip.compress(b'{"format": 1}')[:-6])
    with pytest.raises(ValueError, match="not a gzip-compressed JSON file: compressed file"):
        tj.Timeline.load(cut)


def test_a_corrupt_timeline_file_says_so(tmp_path):
    bad = tmp_path / "timeline.json.gz"
    bad.write_bytes(b"not gzip")
    with pytest.raises(ValueError, match="not a gzip-compressed JSON"):
        tj.Timeline.load(bad)
    with pytest.raises(FileNotFoundError, match="^path: file not found: .*missing.json.gz"):
        tj.Timeline.load(tmp_path / "missing.json.gz")
    with pytest.raises(ValueError, match="^path: expected a file, received the folder"):
        tj.Timeline.load(tmp_path)
    with pytest.raises(ValueError, match="holds no graph update"):
        view_html(intel_result(), timeline=tj.Timeline())


def _damaged(doc: dict, how: str) -> dict:
    doc = copy.deepcopy(doc)
    body = doc["timeline"]
    if how == "frame bytes":
        body["frames"][0]["ids"]["z"] = "AAAA"
    elif how == "frame bytes, view only":
        del doc["continue"]
        body["frames"][-1]["x"]["z"] = "AAAA"
    elif how == "frame not an object":
        body["frames"][0] = 5
    elif how == "no frames, view only":  # one saved while recording may have none yet
        del doc["continue"]
        body["frames"] = []
    elif how == "edge outside the pool":
        body["frames"][-1]["edges"] = packed([10**6], np.int32)
    elif how == "rooms outside the list":
        body["frames"][-1]["rooms"] = len(body["rooms"]) + 3
    elif how == "vertex arrays disagree":
        body["frames"][-1]["y"] = packed([1.0], np.float32)
    elif how == "vertex not finite":  # the page would draw it nowhere
        x = unpacked(body["frames"][-1]["x"])
        body["frames"][-1]["x"] = packed(np.where(np.arange(x.size) == 0, np.nan, x), np.float32)
    elif how == "edge point not finite, view only":
        del doc["continue"]
        xy = unpacked(body["pool"]["xy"])
        body["pool"]["xy"] = packed(np.where(np.arange(xy.size) == 3, np.inf, xy), np.float32)
    elif how == "path not finite":
        y = unpacked(body["path"]["y"])
        body["path"]["y"] = packed(np.where(np.arange(y.size) == 2, np.nan, y), np.float64)
    elif how == "edge sizes disagree with their points, view only":
        del doc["continue"]
        sizes = unpacked(body["pool"]["sizes"])
        body["pool"]["sizes"] = packed(sizes + np.arange(sizes.size) % 2, np.int32)
    elif how == "vertex kind unknown":
        kind = unpacked(body["frames"][0]["kind"])
        body["frames"][0]["kind"] = packed(np.full_like(kind, 200), np.uint8)
    elif how == "map box NaN":
        body["frames"][0]["map"]["box"][0] = float("nan")
    elif how == "map level damaged":
        body["frames"][0]["map"]["level"] = {"tiles": 5}
    elif how == "room without an outline":
        del body["rooms"][body["frames"][-1]["rooms"]][0]["polygon"]
    elif how == "room hole of odd length":
        body["rooms"][body["frames"][-1]["rooms"]][0]["holes"] = [[1.0, 2.0, 3.0]]
    return doc


@pytest.mark.parametrize(
    "how",
    [
        "frame bytes",
        "frame bytes, view only",
        "frame not an object",
        "no frames, view only",
        "edge outside the pool",
        "rooms outside the list",
        "vertex arrays disagree",
        "vertex not finite",
        "edge point not finite, view only",
        "path not finite",
        "edge sizes disagree with their points, view only",
        "vertex kind unknown",
        "map box NaN",
        "map level damaged",
        "room without an outline",
        "room hole of odd length",
    ],
)
def test_a_timeline_file_with_damaged_frames_is_refused_on_loading(tmp_path, how):
    # not written into a page that then fails in the browser ("Failed to fetch"), with
    # topojax view exiting 0
    _, timeline, _ = intel_replay()
    path = timeline.save(tmp_path / "timeline.json.gz")
    doc = _damaged(json.loads(gzip.decompress(path.read_bytes())), how)
    path.write_bytes(gzip.compress(json.dumps(doc).encode()))
    with pytest.raises(ValueError, match=f"^timeline file {re.escape(str(path))} "):
        tj.Timeline.load(path)


def test_mapper_view_has_its_rooms_and_timeline():
    mapper, timeline, _ = intel_replay()
    data = payload_of(view_html(mapper, timeline=timeline))
    assert data["rooms"] is not None  # the mapper keeps rooms (rooms_every)
    assert len(data["timeline"]["frames"]) == 4
    assert data["graphs"][0]["n_edges"] == mapper.graph.number_of_edges()


def test_rooms_false_leaves_the_timeline_s_rooms_out_too():
    """rooms=False shows no rooms: not the mapper's, nor those its timeline recorded."""
    mapper, timeline, _ = intel_replay()
    data = payload_of(view_html(mapper, timeline=timeline))
    assert any(f["rooms"] >= 0 for f in data["timeline"]["frames"])  # recorded ones
    data = payload_of(view_html(mapper, timeline=timeline, rooms=False))
    assert data["rooms"] is None
    assert [f["rooms"] for f in data["timeline"]["frames"]] == [-1] * 4
    assert data["timeline"]["rooms"] == []
    assert timeline.payload()["rooms"], "the timeline itself keeps them"


def test_a_timeline_needs_the_graph_it_steps_through():
    """The page shows a timeline's graph at each update in place of obj's own graph: a
    map or rooms given alone have none (the updates' graphs would not be drawn), and a
    graph of graphs= is not the mapper's (a route graph would be labelled with the
    mapper's graph at each update)."""
    mapper, timeline, _ = intel_replay()
    routes = mapper.route_graph(robot_radius_m=0.3)
    want = (
        "timeline: expected obj to be the mapper (or its graph) whose graph the timeline "
        "steps through, received {} with no graph of its own"
    )
    for obj, kwargs, name in (
        (mapper.occupancy, {}, "an OccupancyMap"),
        (mapper.occupancy, {"graphs": {"routes": routes}}, "an OccupancyMap"),
        (mapper.rooms, {}, "a RoomSegmentation"),
    ):
        with pytest.raises(ValueError, match=re.escape(want.format(name))):
            view_html(obj, timeline=timeline, **kwargs)
    data = payload_of(view_html(mapper.graph, map=mapper.occupancy, timeline=timeline))
    assert len(data["timeline"]["frames"]) == 4


def test_a_timeline_recorded_beyond_the_map_shown_is_noted(res):
    """A timeline whose maps reach beyond the map shown (another run's, another map's)
    is drawn with a note saying so, as a graph or rooms of another map are; the map its
    mapper made, or a larger one holding it, takes it without a word."""
    mapper, timeline, _ = intel_replay()
    assert not any(
        "timeline" in n for n in payload_of(view_html(mapper, timeline=timeline))["notes"]
    )
    final = mapper.to_result(update=False).map
    assert not any(
        "timeline" in n
        for n in payload_of(view_html(mapper.graph, map=final, timeline=timeline))["notes"]
    )
    notes = payload_of(view_html(res, timeline=timeline))["notes"]  # the Intel map at (0, 0)
    (note,) = [n for n in notes if "timeline" in n]
    assert note.startswith("the timeline was not recorded on the map shown: its last map spans x ")
    assert "beyond the map shown (x 0.00 to 38.15 m, y 0.00 to 35.40 m)" in note


def test_mapper_view_has_the_rooms_it_keeps_with_its_graph_updates():
    """``rooms_every=None`` (the default) keeps rooms with every graph update once they
    are in use, and the page shows them.  ``rooms_every=0`` (explicit updates only) may
    hold rooms older than the map: those are left out unless asked for."""
    from view_cases import INTEL_EXCERPT

    scans = list(tj.read_scans(INTEL_EXCERPT))
    pages, ids = {}, {}
    for every in (None, 0):
        mapper = tj.IncrementalMapper(graph_every=10, rooms_every=every)
        for scan in scans[:20]:
            mapper.add_scan(scan)
        assert mapper.rooms.rooms  # in use from here on
        for scan in scans[20:]:
            mapper.add_scan(scan)
        pages[every] = payload_of(view_html(mapper))["rooms"]
        ids[every] = [r.id for r in mapper.rooms.rooms]
        asked = payload_of(view_html(mapper, rooms=True))["rooms"]
        assert len(asked["rooms"]) == len(mapper.rooms.rooms)
    assert pages[None] is not None
    assert [r["id"] for r in pages[None]["rooms"]] == ids[None]
    assert pages[0] is None


def test_mapper_view_shows_the_graph_its_first_rooms_were_made_with():
    """Before a mapper's first rooms update, reading its rooms updates its graph first:
    the page shows that graph with those rooms, not the graph from before."""
    from view_cases import INTEL_EXCERPT

    mapper = tj.IncrementalMapper(graph_every=80, rooms_every=80)
    for scan in list(tj.read_scans(INTEL_EXCERPT))[:5]:
        mapper.add_scan(scan)
    assert mapper.graph.number_of_nodes() == 0  # no graph update yet
    data = payload_of(view_html(mapper))
    assert data["rooms"] is not None
    assert data["graphs"][0]["n_vertices"] == mapper.graph.number_of_nodes() > 0
    assert data["graphs"][0]["n_edges"] == mapper.graph.number_of_edges()


# ---------------------------------------------------------------------------- the command
def test_view_command_on_a_graph_folder(tmp_path, capsys):
    png = tj.datasets.sample_map_path("office")
    out = tmp_path / "out"
    assert main(["graph", str(png), "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    text = capsys.readouterr().out
    assert f"{out / 'view.html'}" in text and "map " in text and "office.json" in text
    data = payload_of((out / "view.html").read_text())
    assert data["rasters"][0]["name"] == "map"
    assert data["graphs"][0]["n_edges"] > 0
    assert main(["view", str(out)]) == 0  # again: its own file is replaced


def test_view_command_leaves_out_a_route_written_beside_the_graph(tmp_path, capsys):
    """The README's order: ``topojax route`` writes its route GeoJSON into the graph's
    folder, and ``topojax view`` still shows that folder's graph."""
    out = tmp_path / "out"
    assert main(["graph", str(tj.datasets.sample_map_path("office")), "-o", str(out)]) == 0
    g = tj.io.load_graph(out / "office.json")
    a, *_, b = sorted(max(nx.connected_components(g), key=len))
    (ra, ca), (rb, cb) = g.nodes[a]["pixel"], g.nodes[b]["pixel"]
    route = ["route", str(out / "office.json"), "-o", str(out / "route.geojson")]
    route += ["--start", str(ra), str(ca), "--goal", str(rb), str(cb), "--pixel"]
    assert main(route) == 0
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    text = capsys.readouterr().out
    assert "office.json" in text and "route" not in text.replace(str(tmp_path), "")
    assert not (out / "route_view.html").exists()
    # copied without the folder's hidden record (cp out/* elsewhere), the route file is
    # still told from a graph by what it holds: one GeoJSON Feature, not a collection
    copy = tmp_path / "copy"
    copy.mkdir()
    for name in ("office.json", "route.geojson"):
        (copy / name).write_bytes((out / name).read_bytes())
    assert main(["view", str(copy)]) == 0
    text = capsys.readouterr().out
    assert "office.json" in text and "route" not in text.replace(str(tmp_path), "")


def test_view_command_tells_the_graph_of_a_map_named_route_from_a_route_graph(tmp_path):
    """A map file named ``lab_route.png`` gives ``lab_route.json`` from ``topojax graph``:
    the folder's record says that command made it from that map, so it is a result of
    its own, not the route graph of ``lab.json``'s result (which left its page out)."""
    from topojax.cli.view import find_results

    occupancy = np.zeros((30, 40), bool)
    occupancy[[0, -1], :] = occupancy[:, [0, -1]] = True
    maps = tmp_path / "maps"
    maps.mkdir()
    for stem in ("lab", "lab_route"):
        cv2.imwrite(str(maps / f"{stem}.png"), np.where(occupancy, 0, 254).astype(np.uint8))
    out = tmp_path / "out"
    for stem in ("lab", "lab_route"):
        assert main(["graph", str(maps / f"{stem}.png"), "-o", str(out)]) == 0
    found = {r.stem: r for r in find_results(out)}
    assert sorted(found) == ["lab", "lab_route"]
    assert found["lab"].route_graph is None
    assert found["lab_route"].graph == out / "lab_route.json"
    assert found["lab_route"].map == maps / "lab_route.png"
    # a route graph that route-graph wrote beside its graph still goes with that graph
    assert main(["route-graph", str(maps / "lab.png"), "-o", str(tmp_path / "rg")]) == 0
    assert main(["graph", str(maps / "lab.png"), "-o", str(tmp_path / "rg")]) == 0
    (result,) = find_results(tmp_path / "rg")
    assert result.stem == "lab" and result.route_graph == tmp_path / "rg" / "lab_route.json"


@pytest.mark.parametrize("stem", ["meeting_rooms", "run_summary", "timings"])
def test_view_command_shows_the_graph_of_a_map_named_as_another_output(tmp_path, stem):
    """``topojax graph meeting_rooms.png`` writes the graph ``meeting_rooms.json`` (and
    ``.geojson``): the record says so, so the view shows it rather than taking it for
    rooms, a summary or timings (which made ``topojax view`` fail or find nothing)."""
    from topojax.cli.view import find_results

    occupancy = np.zeros((30, 40), bool)
    occupancy[[0, -1], :] = occupancy[:, [0, -1]] = True
    png = tmp_path / f"{stem}.png"
    cv2.imwrite(str(png), np.where(occupancy, 0, 254).astype(np.uint8))
    out = tmp_path / "out"
    assert main(["graph", str(png), "-o", str(out), "--rooms"]) == 0
    (result,) = find_results(out)
    assert result.stem == stem and result.graph == out / f"{stem}.json"
    assert result.rooms == out / f"{stem}_rooms.geojson" and result.map == png
    assert main(["view", str(out)]) == 0
    assert (out / "view.html").is_file()


def test_view_command_reads_the_map_as_the_graph_command_did(tmp_path, capsys):
    """A graph built from a map read with options (``--mode ipa``) is shown over the map
    read with the same options, which the folder's record keeps."""
    from topojax.cli.view import find_results

    png = tj.datasets.sample_map_path("office")
    out = tmp_path / "out"
    assert main(["graph", str(png), "--mode", "ipa", "-o", str(out)]) == 0
    (result,) = find_results(out)
    assert result.map == png.resolve() and result.map_kwargs == {"mode": "ipa"}
    plain = tmp_path / "plain"
    assert main(["graph", str(png), "-o", str(plain)]) == 0
    assert find_results(plain)[0].map_kwargs == {}
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    assert "graph only" not in capsys.readouterr().out


@pytest.mark.parametrize(
    "entry, note",
    [
        ({"input": 5}, "the map it was made from is not recorded: graph only"),
        ({"map_options": {"sigma": 2}}, "cannot be read (load_map() got an unexpected keyword"),
    ],
)
def test_view_command_shows_the_graph_alone_when_the_record_is_damaged(
    tmp_path, capsys, entry, note
):
    """A record (``.topojax-outputs.json``) edited by hand names its map by a value that
    is no path, or with options ``load_map`` does not take: the graph is shown alone
    with a note, as for a map that is gone."""
    from topojax.cli._outputs import RECORD_NAME

    out = tmp_path / "out"
    assert main(["graph", str(tj.datasets.sample_map_path("office")), "-o", str(out)]) == 0
    record = json.loads((out / RECORD_NAME).read_text())
    for files in record["files"].values():
        files.update(entry)
    (out / RECORD_NAME).write_text(json.dumps(record))
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    assert note in capsys.readouterr().out
    assert payload_of((out / "view.html").read_text())["graphs"][0]["n_edges"] > 0


def test_view_command_passes_over_a_folder_named_as_rooms(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["graph", str(tj.datasets.sample_map_path("office")), "-o", str(out)]) == 0
    (out / "office_rooms.geojson").mkdir()
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    assert "office_rooms.geojson" not in capsys.readouterr().out
    assert payload_of((out / "view.html").read_text())["rooms"] is None


def test_view_command_on_a_replay_folder_with_a_timeline(tmp_path, capsys):
    mapper, timeline, _ = intel_replay()
    out = tmp_path / "rep"
    out.mkdir()
    result = mapper.to_result(update=False)
    tj.save_graph(result.graph, out / "graph.json")
    tj.save_map(result.map, out / "map.yaml")
    tj.save_rooms(mapper.rooms, out / "map_rooms.geojson")
    timeline.save(out / "timeline.json.gz")
    assert main(["view", str(out)]) == 0
    text = capsys.readouterr().out
    assert "timeline.json.gz" in text and "another run" not in text
    data = payload_of((out / "view.html").read_text())
    assert len(data["timeline"]["frames"]) == 4
    assert data["rooms"]["rooms"] and data["rasters"][0]["name"] == "map"
    # a graph.json of another run beside the timeline is shown, with a note saying so
    other = result.graph.copy()
    other.remove_edge(*next(iter(other.edges(keys=True))))
    tj.save_graph(other, out / "graph.json")
    assert main(["view", str(out)]) == 0
    text = capsys.readouterr().out
    assert "timeline.json.gz: its last graph update (" in text and "another run" in text


def test_view_command_with_several_results_writes_an_index(tmp_path, capsys):
    res = intel_result()
    for stem in ("a", "b"):
        tj.save_graph(res.graph, tmp_path / f"{stem}.json")
    assert main(["view", str(tmp_path)]) == 0
    index = (tmp_path / "view.html").read_text()
    assert 'href="a_view.html"' in index and 'href="b_view.html"' in index
    data = payload_of((tmp_path / "a_view.html").read_text())
    assert data["rasters"] == [] and any("no map" in n for n in data["notes"])
    assert "not recorded" in capsys.readouterr().out


def test_a_folder_whose_results_are_in_subfolders_says_which_to_view(tmp_path, capsys):
    """A batch of maps from several folders writes each folder's results into a subfolder
    of its output folder: the view of the output folder itself, which holds no result,
    names the subfolders that do, instead of only listing what it found."""
    from topojax.batch import build_graphs

    for folder in ("ros", "sim"):
        (tmp_path / folder).mkdir()
        tj.save_map(tj.sample_map("a_scan"), tmp_path / folder / "m.yaml")
    out = tmp_path / "out"
    maps = [tmp_path / "ros" / "m.yaml", tmp_path / "sim" / "m.yaml"]
    build_graphs(maps, out_dir=out, workers=0, progress=False, formats="json")
    assert (out / "ros" / "m.json").is_file() and (out / "sim" / "m.json").is_file()
    assert main(["view", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"the results are in its subfolders {out / 'ros'}, {out / 'sim'}" in err
    assert f"topojax view {out / 'ros'}" in err
    assert main(["view", str(out / "ros")]) == 0


def test_view_command_errors(tmp_path, capsys):
    assert main(["view", str(tmp_path / "missing")]) == 2
    assert "OUT_DIR: expected a folder of results" in capsys.readouterr().err
    (tmp_path / "notes.txt").write_text("hello")
    assert main(["view", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "no results in" in err and "notes.txt" in err
    # a replay's map and timeline without its graph are no result: the message listed
    # map.yaml among what counts, beside "found ... map.yaml"
    tj.save_map(tj.sample_map("office"), tmp_path / "map.yaml")
    assert main(["view", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "(a graph STEM.json / .graphml / .geojson, or rooms STEM_rooms.geojson); " in err
    assert "found map.pgm, map.yaml, notes.txt" in err
    (tmp_path / "graph.json").write_text('{"directed": false, "nodes": [')
    assert main(["view", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "graph.json" in err
    assert not (tmp_path / "view.html").exists()


def test_view_command_leaves_no_page_of_a_result_it_cannot_show_any_more(tmp_path, capsys):
    """The one result of a folder, damaged after its page was written, is named in the
    error and its older page removed, as with several results: the page would show a
    graph that is gone."""
    tj.save_graph(intel_result().graph, tmp_path / "graph.json")
    assert main(["view", str(tmp_path)]) == 0
    assert (tmp_path / "view.html").is_file()
    (tmp_path / "graph.json").write_text('{"directed": false, "nodes": [')
    capsys.readouterr()
    assert main(["view", str(tmp_path)]) == 2
    assert "graph.json" in capsys.readouterr().err
    assert not (tmp_path / "view.html").exists()


def test_view_command_removes_its_pages_of_results_that_are_gone(tmp_path, capsys):
    """Pages an earlier ``topojax view`` wrote for results no longer in the folder are
    removed (they would show graphs that are gone, and the index no longer lists them);
    pages it did not write stay."""
    graph = intel_result().graph
    for stem in ("a", "b", "c"):
        tj.save_graph(graph, tmp_path / f"{stem}.json")
    assert main(["view", str(tmp_path)]) == 0
    (tmp_path / "mine_view.html").write_text("<p>mine</p>")
    (tmp_path / "c.json").unlink()
    capsys.readouterr()
    assert main(["view", str(tmp_path)]) == 0
    assert f"removed    {tmp_path / 'c_view.html'}" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.glob("*.html")) == [
        "a_view.html",
        "b_view.html",
        "mine_view.html",
        "view.html",
    ]
    (tmp_path / "b.json").unlink()  # one result: its page is view.html
    assert main(["view", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.glob("*.html")) == ["mine_view.html", "view.html"]


@pytest.mark.parametrize("stems", [["a"], ["a", "b"]])
def test_view_command_refuses_a_folder_named_as_its_page_before_any_work(tmp_path, capsys, stems):
    """A folder where a page goes (``view.html``, the index of several results too) is
    refused naming OUT_DIR before any page is written, not after the work as the page
    writer's ``path`` or a system error."""
    graph = intel_result().graph
    for stem in stems:
        tj.save_graph(graph, tmp_path / f"{stem}.json")
    (tmp_path / "view.html").mkdir()
    assert main(["view", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        f"topojax view: error: OUT_DIR: expected to write the page {tmp_path / 'view.html'}, "
        "received a folder of that name"
    )
    assert not list(tmp_path.glob("*_view.html"))


def test_view_command_names_a_folder_that_takes_no_page(tmp_path, read_only_folder, capsys):
    """A results folder that takes no file (read-only) is named as OUT_DIR, not left to
    the system's message about the page's temporary file, ``[Errno 30] Read-only file
    system: '.../.view.html.x.tmp'``, which names neither OUT_DIR nor the folder."""
    tj.save_graph(intel_result().graph, tmp_path / "a.json")
    shutil.copy(tmp_path / "a.json", read_only_folder / "a.json")  # a plain copy: no tempfile
    assert main(["view", str(read_only_folder)]) == 2
    assert capsys.readouterr().err.startswith(
        f"topojax view: error: OUT_DIR: cannot write into the folder {read_only_folder} "
        "(Read-only file system)"
    )


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--window", "nan", "0", "1", "1"], "--window: expected four finite numbers (metres)"),
        (
            ["--window", "5", "0", "1", "1"],
            "--window: expected (x_min, y_min, x_max, y_max) in metres with x_min < x_max",
        ),
        (["--max-pixels", "0"], "--max-pixels: expected an int >= 1, received 0"),
    ],
)
def test_view_command_option_errors_name_the_option(tmp_path, capsys, options, message):
    # the option is named, not write_view's argument (window, max_pixels) after the
    # first result's file, as if that file were at fault
    tj.save_graph(intel_result().graph, tmp_path / "intel.json")
    assert main(["view", str(tmp_path), *options]) == 2
    assert capsys.readouterr().err.startswith(f"topojax view: error: {message}")
    assert not (tmp_path / "view.html").exists()


def test_view_command_names_the_window_option_when_a_result_cannot_be_cut(tmp_path, capsys):
    """A ``--window`` that a result cannot use (a graph without its map, a box beside
    the map) is refused naming the option, not as ``window: ...``, write_view's
    argument."""
    tj.save_graph(intel_result().graph, tmp_path / "intel.json")
    window = ["--window", "0", "0", "9", "9"]
    assert main(["view", str(tmp_path), *window]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / 'intel.json'}: --window: needs a map to cut (the view has none)" in err
    tj.save_map(intel_result().map, tmp_path / "intel.yaml")
    assert main(["view", str(tmp_path), "--window", "1000", "1000", "1001", "1001"]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / 'intel.json'}: --window: (1000.0, 1000.0, 1001.0, 1001.0) covers" in err
    assert not (tmp_path / "view.html").exists()


def test_view_command_on_a_map_too_large(tmp_path, capsys):
    res = intel_result()
    tj.save_graph(res.graph, tmp_path / "intel.json")
    tj.save_map(res.map, tmp_path / "intel.yaml")
    assert main(["view", str(tmp_path), "--max-pixels", "1000"]) == 2
    err = capsys.readouterr().err
    assert "more than --max-pixels 1000 (" in err and "--window X_MIN Y_MIN X_MAX Y_MAX" in err
    assert "max_pixels" not in err and "window=" not in err  # the options, not parameters
    assert (
        main(["view", str(tmp_path), "--max-pixels", "1000000", "--window", "0", "0", "9", "9"])
        == 0
    )


def test_view_command_on_a_graph_too_large_without_its_map_names_options(tmp_path, capsys):
    """Without the graph's map in the folder the error says what to do on the command
    line, not which Python arguments (``map=``, ``tj.open_tiled_map``) to pass."""
    tj.save_graph(intel_result().graph, tmp_path / "intel.json")
    assert main(["view", str(tmp_path), "--max-pixels", "1000"]) == 2
    err = capsys.readouterr().err
    assert "more than --max-pixels 1000 (" in err
    assert "max_pixels" not in err and "map=" not in err and "tj." not in err


def test_view_command_leaves_out_a_map_not_on_the_graphs_grid(tmp_path, capsys):
    tj.save_graph(intel_result().graph, tmp_path / "intel.json")
    tj.save_map(tj.sample_map("office"), tmp_path / "intel.yaml")
    assert main(["view", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "(1234 x 727 px (w x h), 0.05 m/px) is not the graph's (763 x 708 px" in out
    data = payload_of((tmp_path / "view.html").read_text())
    assert data["rasters"] == [] and data["graphs"][0]["n_edges"] > 0


def test_view_command_notes_rooms_not_made_on_the_map_found(tmp_path, capsys):
    # the map the rooms were made from is replaced by another: a note says the rooms
    # were not segmented on it, not drawn over it without a word
    png = tmp_path / "plan.png"
    png.write_bytes(tj.datasets.sample_map_path("office").read_bytes())
    assert main(["rooms", str(png), "-o", str(tmp_path / "out")]) == 0
    assert main(["view", str(tmp_path / "out")]) == 0
    assert "not segmented on" not in capsys.readouterr().out
    png.write_bytes(tj.datasets.sample_map_path("intel").read_bytes())
    assert main(["view", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert (
        "note       plan_rooms.geojson: the rooms were not segmented on the map shown: "
        "expected their map of shape (727, 1234), received a map of shape (708, 763)"
    ) in out


def test_graph_and_replay_write_their_view(tmp_path, capsys):
    """``topojax graph --view`` and ``topojax replay --view`` write the page beside their
    other outputs; the replay's page carries a timeline of every graph update."""
    from pathlib import Path

    from topojax.cli import main

    data = Path(__file__).resolve().parents[1] / "topojax" / "data" / "intel.png"
    assert main(["graph", str(data), "-o", str(tmp_path / "g"), "--view"]) == 0
    page = (tmp_path / "g" / "intel_view.html").read_text()
    assert "<html" in page.lower() and "intel_view.html" in capsys.readouterr().out
    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    out = tmp_path / "r"
    code = main(
        ["replay", str(log), "-o", str(out), "--view", "--no-progress", "--graph-every", "10"]
    )
    assert code == 0
    assert (out / "view.html").stat().st_size > 0
    assert "timeline" in (out / "view.html").read_text().lower()


def test_view_command_on_a_replay_view_folder_keeps_the_timeline(tmp_path, capsys):
    """``replay --view`` leaves the timeline beside its page; ``topojax view`` on that
    folder makes the page again, timeline and all (a view page is no one's to guard)."""
    from view_cases import INTEL_EXCERPT

    out = tmp_path / "rep"
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress", "--view"]
    assert main([*args, "--graph-every", "10"]) == 0
    assert (out / "timeline.json.gz").is_file()
    frames = len(payload_of((out / "view.html").read_text())["timeline"]["frames"])
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    assert "timeline.json.gz" in capsys.readouterr().out
    assert len(payload_of((out / "view.html").read_text())["timeline"]["frames"]) == frames
    assert main([*args, "--graph-every", "10"]) == 0  # and the replay may write it again


@pytest.mark.parametrize("options", [["--free-only"], ["--min-spur-m", "0.5"]])
def test_view_command_on_a_filtered_replay_notes_no_other_run(tmp_path, capsys, options):
    """A replay's ``--free-only`` / ``--min-*-m`` apply to the graph files only, not to
    the timeline of the mapper's updates: their counts differ by design, and ``topojax
    view`` does not take the timeline for another run's."""
    from view_cases import INTEL_EXCERPT

    out = tmp_path / "rep"
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress", "--view"]
    assert main([*args, "--graph-every", "10", *options]) == 0
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    text = capsys.readouterr().out
    assert "timeline.json.gz" in text and "another run" not in text


@pytest.mark.parametrize(("every", "scans"), [(10, [9, 19, 29, 39]), (7, [6, 13, 20, 27, 34, 39])])
def test_replay_view_has_a_step_per_scan_that_updated_the_graph(tmp_path, every, scans):
    """The final graph update after the last scan is a step of the timeline only when
    scans came after the last update: right after one it changes nothing, and a second
    step of the same scan would show "+0 -0"."""
    from view_cases import INTEL_EXCERPT

    out = tmp_path / "rep"
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress", "--view"]
    assert main([*args, "--graph-every", str(every), "--rooms"]) == 0
    frames = payload_of((out / "view.html").read_text())["timeline"]["frames"]
    assert [f["scan"] for f in frames] == scans
    assert all(len(unpacked(f["added"])) + len(unpacked(f["removed"])) for f in frames)


def test_a_replay_removes_what_the_last_replay_wrote_and_it_does_not(tmp_path, capsys):
    """A replay without ``--view`` into the folder of one with it leaves no page or
    timeline of the other map for ``topojax view`` to show; files it did not write stay."""
    from view_cases import INTEL_EXCERPT

    out = tmp_path / "rep"
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress", "--graph-every", "10"]
    assert main([*args, "--view", "--max-scans", "30"]) == 0
    (out / "notes.txt").write_text("mine")
    assert main([*args, "--max-scans", "20"]) == 0
    assert not (out / "view.html").exists() and not (out / "timeline.json.gz").exists()
    assert (out / "notes.txt").read_text() == "mine" and (out / "graph.json").is_file()
    written = json.loads((out / "timings.json").read_text())["written"]
    assert {Path(p).name for p in written} >= {"graph.json", "map.yaml", "timings.json"}
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    assert "timeline" not in capsys.readouterr().out


def test_view_command_finds_a_batch_map_given_by_a_relative_path(tmp_path, capsys, monkeypatch):
    """A batch run on ``maps/office.png`` from one folder is viewed from another: the
    manifest names the map by its absolute path, so the view still draws it."""
    import shutil

    from topojax.cli.view import find_results

    (tmp_path / "maps").mkdir()
    shutil.copy(tj.datasets.sample_map_path("office"), tmp_path / "maps" / "office.png")
    monkeypatch.chdir(tmp_path)
    argv = ["batch", "maps/office.png", "-o", "out", "--workers", "0", "--no-progress"]
    assert main([*argv, "--formats", "json"]) == 0
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    (result,) = find_results(tmp_path / "out")
    assert result.map == tmp_path / "maps" / "office.png"
    capsys.readouterr()
    assert main(["view", str(tmp_path / "out")]) == 0
    assert "graph only" not in capsys.readouterr().out


def test_the_index_page_links_views_whose_names_hold_url_characters():
    # '#' starts a fragment and '%20' is read as a space: both are percent-encoded
    from urllib.parse import unquote

    from topojax.cli.view import _index_page

    names = ["r#1_view.html", "p%20q_view.html", "ä b?_view.html"]
    page = _index_page(Path("out"), [(n[: -len("_view.html")], Path("out") / n) for n in names])
    hrefs = re.findall(r'href="([^"]*)"', page)
    assert [unquote(h) for h in hrefs] == names
    assert not any(c in h for h in hrefs for c in "#? ")


def test_timeline_snapshot_names_a_wrong_mapper():
    """``snapshot``, as ``record`` does, names a wrong mapper rather than failing with
    an AttributeError on its ``pixel_bbox``."""
    with pytest.raises(TypeError, match="^mapper: expected an IncrementalMapper, received int"):
        tj.Timeline().snapshot(3)


@pytest.mark.parametrize(
    ("kwargs", "exc", "message"),
    [
        ({"scan_index": 2.5}, TypeError, r"^scan_index: expected an int >= 0, received float 2.5$"),
        ({"scan_index": True}, TypeError, r"^scan_index: expected an int >= 0, received bool"),
        ({"scan_index": "3"}, TypeError, r"^scan_index: expected an int >= 0, received str"),
        ({"scan_index": -1}, ValueError, r"^scan_index: expected an int >= 0, received -1$"),
        ({"rooms": "no"}, TypeError, r"^rooms: expected a bool, received str 'no'$"),
        ({"rooms": None}, TypeError, r"^rooms: expected a bool, received NoneType"),
    ],
)
def test_timeline_snapshot_checks_its_options(kwargs, exc, message):
    """A scan index is an int (a float not cut to one, True not kept as scan 1, a str or
    NaN not left to fail in ``int()`` naming nothing), and ``rooms`` a bool, not read by
    its truth value (where "no" would keep rooms)."""
    with pytest.raises(exc, match=message):
        tj.Timeline().snapshot(tj.IncrementalMapper(), **kwargs)


def test_view_command_shows_the_results_it_can_and_names_the_others(tmp_path, capsys):
    res = intel_result()
    for stem in ("a", "c"):
        tj.save_graph(res.graph, tmp_path / f"{stem}.json")
    assert main(["view", str(tmp_path)]) == 0
    (tmp_path / "b.json").write_text('{"directed": false, "nodes": [')
    (tmp_path / "b_view.html").write_text("an older page of b")
    assert main(["view", str(tmp_path)]) == 2
    out, err = capsys.readouterr()
    assert "a_view.html" in out and "c_view.html" in out
    assert "OUT_DIR: 1 of the 3 results" in err and "(the others were written)" in err
    assert "b.json" in err
    index = (tmp_path / "view.html").read_text()
    assert 'href="a_view.html"' in index and 'href="c_view.html"' in index
    assert "b_view.html" not in index and not (tmp_path / "b_view.html").exists()


def test_view_command_leaves_no_index_when_no_result_can_be_shown(tmp_path, capsys):
    for stem in ("a", "b"):
        (tmp_path / f"{stem}.json").write_text('{"directed": false, "nodes": [')
    (tmp_path / "view.html").write_text('an older index linking <a href="a_view.html">')
    assert main(["view", str(tmp_path)]) == 2
    assert "OUT_DIR: 2 of the 2 results" in capsys.readouterr().err
    assert not (tmp_path / "view.html").exists()


def test_the_page_colours_vertex_kinds_as_the_pictures_and_markers_do():
    """The page's vertex colours are those of the plots and the MCAP markers
    (``VERTEX_KIND_COLOURS``), kind for kind; kinds they do not know get a colour of
    their own."""
    import re
    from pathlib import Path

    from topojax._constants import VERTEX_KIND_COLOURS
    from topojax.view._graphs import KIND_NAMES

    script = (Path(tj.__file__).parent / "view" / "static" / "draw.js").read_text()
    page = re.search(r"TJ\.KIND_COLOURS = \[([^\]]*)\]", script)[1]
    colours = dict(zip(KIND_NAMES, re.findall(r'"(#[0-9a-f]{6})"', page), strict=True))
    assert {k: colours[k] for k in VERTEX_KIND_COLOURS} == VERTEX_KIND_COLOURS
    assert colours["other"] not in VERTEX_KIND_COLOURS.values()
