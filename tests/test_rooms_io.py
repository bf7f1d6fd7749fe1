"""Files of a room segmentation: the rooms GeoJSON (round trip, RFC 7946 structure, bad
files), the label picture and the room graph."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import cv2
import networkx as nx
import numpy as np
import pytest
from room_maps import three_rooms, three_rooms_occupied

import topojax as tj
from topojax.io import ROOM_FILE_SUFFIXES, save_room_files
from topojax.io.rooms import room_colours


@pytest.fixture(scope="module")
def seg():
    s = tj.segment_rooms(three_rooms())
    assert s.n_rooms == 3 and len(s.doors) == 2  # what the tests below rely on
    return s


def _strict(text: str):
    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def _area(ring) -> float:
    a = np.asarray(ring, float)
    return 0.5 * float(np.sum(a[:, 0] * np.roll(a[:, 1], -1) - np.roll(a[:, 0], -1) * a[:, 1]))


def assert_rooms_equal(got, want) -> None:
    assert len(got) == len(want)
    for a, b in zip(got, want, strict=True):
        assert (a.id, a.area_m2, a.centroid, a.bbox) == (b.id, b.area_m2, b.centroid, b.bbox)
        assert type(a.id) is int and all(type(v) is int for v in a.bbox)
        assert a.polygon.dtype == np.float64 and a.polygon.shape == b.polygon.shape
        np.testing.assert_allclose(a.polygon, b.polygon, rtol=0, atol=1e-9)
        assert isinstance(a.holes, tuple) and len(a.holes) == len(b.holes)
        for g, w in zip(a.holes, b.holes, strict=True):
            assert g.dtype == np.float64 and g.shape == w.shape
            np.testing.assert_allclose(g, w, rtol=0, atol=1e-9)


def assert_doors_equal(got, want) -> None:
    assert len(got) == len(want)
    for a, b in zip(got, want, strict=True):
        assert (a.id, a.rooms, a.width_m) == (b.id, b.rooms, b.width_m)
        assert a.ends_px.dtype == np.int64 and np.array_equal(a.ends_px, b.ends_px)
        assert a.pixels.dtype == np.int64 and np.array_equal(a.pixels, b.pixels)
        np.testing.assert_allclose(a.ends_world, b.ends_world, rtol=0, atol=1e-9)


# ---------------------------------------------------------------------- GeoJSON


def test_rooms_round_trip(seg, tmp_path: Path):
    path = tj.save_rooms(seg, tmp_path / "r.geojson")
    assert path == tmp_path / "r.geojson"
    rooms, doors = tj.load_rooms(path)
    assert isinstance(rooms, tuple) and isinstance(doors, tuple)
    assert_rooms_equal(rooms, seg.rooms)
    assert_doors_equal(doors, seg.doors)
    assert [p.name for p in tmp_path.iterdir()] == ["r.geojson"], "no temporary file left"


def test_load_rooms_gives_the_map_frame_the_file_records(seg, tmp_path: Path):
    """The pair load_rooms gives carries the map the file records (its shape,
    resolution and origin, where stated) and unpacks as before."""
    import pickle

    path = tj.save_rooms(seg, tmp_path / "r.geojson")
    pair = tj.load_rooms(path)
    rooms, doors = pair
    assert pair.shape == seg.labels.shape and pair.resolution_m == seg.resolution_m
    assert pair.origin == tuple(seg.origin)
    h, w = seg.labels.shape
    assert repr(pair) == (
        f"LoadedRooms({len(rooms)} rooms, {len(doors)} doors, {w} x {h} px (w x h) at "
        f"{seg.resolution_m:g} m/px, origin {tuple(seg.origin)})"
    )
    back = pickle.loads(pickle.dumps(pair))
    assert [r.id for r in back[0]] == [r.id for r in rooms] and len(back[1]) == len(doors)
    assert (back.shape, back.resolution_m, back.origin) == (
        pair.shape,
        pair.resolution_m,
        pair.origin,
    )
    with pytest.raises(AttributeError):
        pair.shape = (1, 1)
    doc = json.loads(path.read_text(encoding="utf-8"))
    del doc["topojax_rooms"]  # another tool's file: no frame
    path.write_text(json.dumps(doc), encoding="utf-8")
    bare = tj.load_rooms(path)
    assert (bare.shape, bare.resolution_m, bare.origin) == (None, None, None)
    assert repr(bare) == f"LoadedRooms({len(rooms)} rooms, {len(doors)} doors, no map recorded)"


def test_rooms_geojson_is_an_rfc7946_feature_collection(seg, tmp_path: Path):
    doc = _strict(tj.save_rooms(seg, tmp_path / "r.geojson").read_text(encoding="utf-8"))
    assert doc["type"] == "FeatureCollection"
    assert doc["topojax_rooms"] == {
        "version": 1,
        "resolution_m": 0.05,
        "origin": [-1.5, 2.0, 0.3],
        "shape": [60, 150],
    }
    rooms = [f for f in doc["features"] if f["properties"]["kind"] == "room"]
    doors = [f for f in doc["features"] if f["properties"]["kind"] == "door"]
    assert len(rooms) + len(doors) == len(doc["features"])
    assert [f["properties"]["id"] for f in rooms] == [1, 2, 3]
    assert [f["properties"]["id"] for f in doors] == [1, 2]
    for feat, room in zip(rooms, seg.rooms, strict=True):
        assert feat["type"] == "Feature" and feat["geometry"]["type"] == "Polygon"
        (ring,) = feat["geometry"]["coordinates"]
        assert len(ring) >= 4 and ring[0] == ring[-1], "closed linear ring"
        assert _area(ring[:-1]) > 0, "exterior ring counter-clockwise"
        # world metres of the map frame: the room's outline and centroid as they are
        np.testing.assert_array_equal(np.asarray(ring[:-1]), room.polygon)
        props = feat["properties"]
        assert set(props) == {"kind", "id", "area_m2", "centroid", "bbox_px"}
        assert props["centroid"] == list(room.centroid)
        assert props["bbox_px"] == list(room.bbox)
        assert props["area_m2"] == room.area_m2
    for feat, door in zip(doors, seg.doors, strict=True):
        assert feat["geometry"]["type"] == "LineString"
        assert feat["geometry"]["coordinates"] == door.ends_world.tolist()
        props = feat["properties"]
        assert props["rooms"] == list(door.rooms) and props["width_m"] == door.width_m
        assert props["ends_px"] == door.ends_px.tolist()
        assert props["pixels"] == door.pixels.tolist()


@pytest.fixture(scope="module")
def loop():
    """A corridor round two rooms (its holes), in a frame turned by 0.3 rad."""
    from room_maps import corridor_round_two_rooms

    s = corridor_round_two_rooms((8, 12), origin=(-1.5, 2.0, 0.3))
    assert [len(r.holes) for r in s.rooms] == [2, 0, 0]
    return s


def test_holes_are_interior_rings_and_come_back(loop, tmp_path: Path):
    path = tj.save_rooms(loop, tmp_path / "r.geojson")
    feats = _strict(path.read_text(encoding="utf-8"))["features"]
    for feat, room in zip(feats, loop.rooms, strict=True):
        exterior, *interior = feat["geometry"]["coordinates"]
        assert len(interior) == len(room.holes)
        assert _area(exterior[:-1]) > 0, "exterior ring counter-clockwise"
        for ring, hole in zip(interior, room.holes, strict=True):
            assert len(ring) >= 4 and ring[0] == ring[-1], "closed linear ring"
            assert _area(ring[:-1]) < 0, "interior ring clockwise (RFC 7946)"
            np.testing.assert_array_equal(np.asarray(ring[:-1]), hole)
        assert "holes" not in feat["properties"]
    corridor = feats[0]["geometry"]["coordinates"]
    area = sum(_area(r[:-1]) for r in corridor)
    assert area == pytest.approx(loop.rooms[0].area_m2, rel=1e-9)
    rooms, _ = tj.load_rooms(path)
    assert_rooms_equal(rooms, loop.rooms)


def test_a_hole_that_is_no_valid_interior_ring_is_kept_as_a_property(loop, tmp_path: Path):
    corridor = loop.rooms[0]
    turned = (corridor.holes[0][::-1].copy(), corridor.holes[1])  # counter-clockwise
    odd = dataclasses.replace(
        loop, rooms=(dataclasses.replace(corridor, holes=turned), *loop.rooms[1:])
    )
    path = tj.save_rooms(odd, tmp_path / "r.geojson")
    feat = _strict(path.read_text(encoding="utf-8"))["features"][0]
    (ring,) = feat["geometry"]["coordinates"]  # the pixel box
    assert len(ring) == 5 and _area(ring[:-1]) > 0
    assert feat["properties"]["outline"] == corridor.polygon.tolist()
    assert feat["properties"]["holes"] == [h.tolist() for h in turned]
    rooms, _ = tj.load_rooms(path)
    assert_rooms_equal(rooms, odd.rooms)


def test_an_outline_without_area_keeps_a_valid_ring(seg, tmp_path: Path):
    first = seg.rooms[0]
    line = first.polygon[:2].copy()  # a one-pixel-wide room: its outline is a line
    clockwise = seg.rooms[1].polygon[::-1].copy()
    odd = dataclasses.replace(
        seg,
        rooms=(
            dataclasses.replace(first, polygon=line),
            dataclasses.replace(seg.rooms[1], polygon=clockwise),
            seg.rooms[2],
        ),
    )
    path = tj.save_rooms(odd, tmp_path / "r.geojson")
    feats = _strict(path.read_text(encoding="utf-8"))["features"]
    for feat, polygon in zip(feats[:2], (line, clockwise), strict=True):
        (ring,) = feat["geometry"]["coordinates"]
        assert len(ring) == 5 and ring[0] == ring[-1] and _area(ring[:-1]) > 0
        assert feat["properties"]["outline"] == polygon.tolist()
    r0, c0, r1, c1 = first.bbox  # the geometry is the room's pixel box, map frame
    (ring,) = feats[0]["geometry"]["coordinates"]
    rows, cols = seg.occupancy.world_to_pixel(*np.asarray(ring[:-1]).T)
    got = {(round(r, 6), round(c, 6)) for r, c in zip(rows, cols, strict=True)}
    assert got == {(r, c) for r in (r0 - 0.5, r1 + 0.5) for c in (c0 - 0.5, c1 + 0.5)}
    rooms, _ = tj.load_rooms(path)
    assert_rooms_equal(rooms, odd.rooms)


def test_a_rooms_file_whose_gis_table_gives_every_feature_every_column_loads(seg, tmp_path: Path):
    # a room kept as a property outline (no valid ring) gives a GIS program's table the
    # columns outline and holes: every other feature gets them, and the doors' columns, null
    first = dataclasses.replace(seg.rooms[0], polygon=seg.rooms[0].polygon[:2].copy())
    odd = dataclasses.replace(seg, rooms=(first, *seg.rooms[1:]))
    doc = json.loads(tj.save_rooms(odd, tmp_path / "r.geojson").read_text(encoding="utf-8"))
    columns = list(dict.fromkeys(k for f in doc["features"] for k in f["properties"]))
    assert "outline" in columns
    for feat in doc["features"]:
        feat["properties"] = {k: feat["properties"].get(k) for k in columns}
    path = tmp_path / "gis.geojson"
    path.write_text(json.dumps(doc), encoding="utf-8")
    rooms, doors = tj.load_rooms(path)
    assert_rooms_equal(rooms, odd.rooms)
    assert_doors_equal(doors, odd.doors)


def test_save_rooms_refuses_what_geojson_cannot_hold(seg, tmp_path: Path):
    with pytest.raises(TypeError, match="seg: expected a RoomSegmentation, received dict"):
        tj.save_rooms({}, tmp_path / "r.geojson")
    nan = dataclasses.replace(seg, rooms=(dataclasses.replace(seg.rooms[0], area_m2=np.nan),))
    with pytest.raises(ValueError, match="NaN or infinite"):
        tj.save_rooms(nan, tmp_path / "r.geojson")
    bad = seg.rooms[0].polygon.copy()
    bad[0, 0] = np.inf
    inf = dataclasses.replace(seg, rooms=(dataclasses.replace(seg.rooms[0], polygon=bad),))
    with pytest.raises(ValueError, match="room 1 has a polygon with non-finite"):
        tj.save_rooms(inf, tmp_path / "r.geojson")
    assert not list(tmp_path.iterdir()), "nothing written"
    with pytest.raises(FileNotFoundError, match="does not exist"):
        tj.save_rooms(seg, tmp_path / "missing" / "r.geojson")


@pytest.mark.parametrize("name", ["r.json", "r.txt", "rooms", "r.geojson.tmp"])
def test_save_rooms_checks_its_suffix_as_the_other_room_writers_do(seg, tmp_path: Path, name):
    with pytest.raises(
        ValueError, match=rf"^path: expected a \.geojson file name, received '.*{name}'$"
    ):
        tj.save_rooms(seg, tmp_path / name)
    assert not list(tmp_path.iterdir()), "nothing written"
    assert tj.save_rooms(seg, tmp_path / "R.GeoJSON").is_file()


def _graph_geojson(path: Path) -> Path:
    g = nx.MultiGraph()
    g.add_node(0, world=(0.0, 0.0), pixel=(1, 1))
    g.add_node(1, world=(1.0, 0.0), pixel=(1, 21))
    g.add_edge(0, 1, world=np.array([[0.0, 0.0], [1.0, 0.0]]))
    return tj.save_graph(g, path)


def _rooms_doc(seg, tmp_path: Path) -> dict:
    return json.loads(tj.save_rooms(seg, tmp_path / "good.geojson").read_text(encoding="utf-8"))


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda d: d.update(type="Feature"), "is not a GeoJSON FeatureCollection"),
        (lambda d: d.update(features={}), "'features' must be a list"),
        (lambda d: d.update(features=[], topojax_rooms=None), "empty FeatureCollection"),
        (lambda d: d["topojax_rooms"].update(version=9), "is not version 1 rooms data"),
        (lambda d: d["features"][0].pop("geometry"), r"features\[0\] needs 'properties'"),
        (lambda d: d["features"][0]["properties"].pop("kind"), "kind None; expected 'room'"),
        (
            lambda d: d["features"][0]["geometry"]["coordinates"][0].pop(),
            r"features\[0\]: the exterior ring must be closed",
        ),
        (
            lambda d: d["features"][0]["geometry"]["coordinates"].append([[0, 0], [1, 0], [0, 1]]),
            r"features\[0\]: the interior ring 1 must be closed",
        ),
        (
            lambda d: d["features"][1]["properties"].update(area_m2="big"),
            "property 'area_m2': expected a finite number",
        ),
        (
            lambda d: d["features"][2]["properties"].update(bbox_px=[1, 2]),
            "'bbox_px': expected a list of 4 integers",
        ),
        (
            lambda d: d["features"][3]["properties"].update(pixels=[[1.5, 2]]),
            r"features\[3\] pixels: expected integer pixels",
        ),
        (  # not cast to int64 first (a warning, a wrapped negative pixel in the message)
            lambda d: d["features"][3]["properties"].update(pixels=[[10**30, 2]]),
            r"features\[3\] pixels: expected integer pixels of int64, received \[\[1000000000000000000000000000000, 2\]\]",
        ),
        # JSON integers beyond any float: refused, not an OverflowError
        (
            lambda d: d["features"][1]["properties"].update(area_m2=10**400),
            r"features\[1\]: property 'area_m2': expected a finite number, received 1000",
        ),
        (
            lambda d: d["features"][1]["properties"].update(centroid=[10**400, 0.0]),
            r"features\[1\]: property 'centroid': expected a finite number",
        ),
        (
            lambda d: d["features"][1]["geometry"]["coordinates"][0].insert(1, [10**400, 0]),
            r"features\[1\] exterior ring: expected finite numbers",
        ),
        (
            lambda d: d["features"][3]["properties"].update(pixels=[[10**400, 2]]),
            r"features\[3\] pixels: expected finite numbers",
        ),
        (
            lambda d: d["features"][3]["properties"].update(pixels=[["a", 2]]),
            r"features\[3\] pixels: expected a list of K \[a, b\] pairs",
        ),
        # true and false are no numbers (read as 1 and 0 they named other pixels)
        (
            lambda d: d["features"][3]["properties"].update(pixels=[[True, 2]]),
            r"features\[3\] pixels: expected a list of K \[a, b\] pairs, received \[\[True, 2\]\]",
        ),
        (
            lambda d: d["features"][3]["properties"].update(ends_px=[[21, 50], [38, False]]),
            r"features\[3\] ends_px: expected a list of 2 \[a, b\] pairs, received",
        ),
        (
            lambda d: d["features"][4]["geometry"].update(coordinates=[[True, 0.0], [1.0, 0.0]]),
            r"features\[4\] line: expected a list of 2 \[a, b\] pairs, received",
        ),
        (
            lambda d: d["features"][1]["geometry"]["coordinates"][0].insert(1, [False, 0.0]),
            r"features\[1\] exterior ring: expected a list of K \[a, b\] pairs, received",
        ),
        (
            lambda d: d["features"][4]["geometry"].update(type="Point"),
            "geometry: expected a LineString for a door, received 'Point'",
        ),
        (
            lambda d: d["features"][4]["properties"].update(id=0),
            "property 'id': expected an integer >= 1",
        ),
        (
            lambda d: d["features"][1]["properties"].update(id=1),
            r"features\[1\]: property 'id': room 1 appears twice",
        ),
        (
            lambda d: d["features"][4]["properties"].update(id=1),
            r"features\[4\]: property 'id': door 1 appears twice",
        ),
        (
            lambda d: d["features"][1]["properties"].update(area_m2=-2.0),
            r"features\[1\]: property 'area_m2': expected >= 0, received -2.0",
        ),
        (
            lambda d: d["features"][2]["properties"].update(bbox_px=[10, 10, 5, 5]),
            r"features\[2\]: property 'bbox_px': expected .*inclusive, >= 0\), inside the map",
        ),
        (
            lambda d: d["topojax_rooms"].update(shape=[1, 1]),
            r"'bbox_px': expected .* inside the map's 1 x 1 pixels",
        ),
        (
            lambda d: d["topojax_rooms"].update(shape="big"),
            r"topojax_rooms: 'shape': expected \[H, W\]",
        ),
        (
            lambda d: d["features"][3]["properties"].update(pixels=[[-1, 2]]),
            r"features\[3\]: property 'pixels': expected pixels \(row, col\) >= 0",
        ),
        # the map frame: a resolution no map has, an origin that is no pose
        *(
            (
                lambda d, v=v: d["topojax_rooms"].update(resolution_m=v),
                r"topojax_rooms: 'resolution_m': expected a number of metres per pixel from "
                rf"1e-06 to 10000, received {got}$",
            )
            for v, got in ((0, "0"), (-0.05, "-0.05"), (math.nan, "nan"), (math.inf, "inf"))
        ),
        (
            lambda d: d["topojax_rooms"].update(resolution_m="0.05"),
            r"topojax_rooms: 'resolution_m': expected a number .*, received '0.05'$",
        ),
        (
            lambda d: d["topojax_rooms"].update(origin=[0.0, 0.0]),
            r"topojax_rooms: 'origin': expected \[x, y, yaw\] .*, received \[0.0, 0.0\]$",
        ),
        (
            lambda d: d["topojax_rooms"].update(origin=[0.0, math.nan, 0.0]),
            r"topojax_rooms: 'origin': expected \[x, y, yaw\] .*, received \[0.0, nan, 0.0\]$",
        ),
        # door ends: on the map's pixels (its border ones included), never past its edge
        (
            lambda d: d["features"][3]["properties"].update(ends_px=[[21, 50], [500, 50]]),
            r"features\[3\]: property 'ends_px': expected two pixels \(row, col\) >= 0, "
            r"inside the map's 60 x 150 pixels, received \[\[21, 50\], \[500, 50\]\]$",
        ),
        (
            lambda d: d["features"][3]["properties"].update(ends_px=[[-1, 50], [38, 50]]),
            r"features\[3\]: property 'ends_px': expected two pixels \(row, col\) >= 0",
        ),
        (
            lambda d: d["features"][4]["geometry"].update(coordinates=[[0.0, 0.0], [1e6, 0.0]]),
            r"features\[4\]: geometry: expected a door's two ends \[x, y\] on the map's 60 x "
            r"150 pixels, received \[\[0.0, 0.0\], \[1000000.0, 0.0\]\]$",
        ),
        (
            lambda d: d["features"][4]["properties"].update(width_m=-0.5),
            r"features\[4\]: property 'width_m': expected >= 0",
        ),
        *(
            (
                lambda d, pair=pair: d["features"][3]["properties"].update(rooms=pair),
                r"features\[3\]: property 'rooms': expected two ascending ids of rooms in "
                rf"the file, received \[{pair[0]}, {pair[1]}\]",
            )
            for pair in ([1, 99], [2, 2], [2, 1])
        ),
    ],
)
def test_load_rooms_names_the_file_and_the_fault(seg, tmp_path: Path, damage, message):
    doc = _rooms_doc(seg, tmp_path)
    damage(doc)
    path = tmp_path / "bad.geojson"
    path.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(ValueError, match=message) as info:
        tj.load_rooms(path)
    assert str(path) in str(info.value)


def _with_altitudes(doc: dict, z) -> dict:
    """``doc`` with every geometry position given the third element ``z`` (an altitude)."""
    for feat in doc["features"]:
        geom = feat["geometry"]
        lines = geom["coordinates"] if geom["type"] == "Polygon" else [geom["coordinates"]]
        for line in lines:
            for pos in line:
                pos.append(z)
    return doc


def test_load_rooms_reads_positions_with_an_altitude(loop, tmp_path: Path):
    # RFC 7946 3.1.1: a position may hold an altitude as its third element; GIS tools
    # write one. The rooms are those of the file without it.
    for s in (loop, tj.segment_rooms(three_rooms())):
        doc = _with_altitudes(_rooms_doc(s, tmp_path), 12.5)
        doc["features"][0]["geometry"]["coordinates"][0][1].pop()  # positions may mix
        path = tmp_path / "z.geojson"
        path.write_text(json.dumps(doc), encoding="utf-8")
        rooms, doors = tj.load_rooms(path)
        assert_rooms_equal(rooms, s.rooms)
        assert_doors_equal(doors, s.doors)


def test_load_rooms_gives_rings_turned_the_other_way_the_rooms_orientation(loop, tmp_path: Path):
    # RFC 7946 3.1.6: a reader should not refuse rings against the right-hand rule; other
    # tools write clockwise exteriors (shapely's normalize, ESRI's convention). A Room's
    # polygon runs counter-clockwise and its holes clockwise, whatever the file's order.
    doc = _rooms_doc(loop, tmp_path)
    for feat in doc["features"]:
        if feat["geometry"]["type"] == "Polygon":
            feat["geometry"]["coordinates"] = [r[::-1] for r in feat["geometry"]["coordinates"]]
    path = tmp_path / "turned.geojson"
    path.write_text(json.dumps(doc), encoding="utf-8")
    rooms, _ = tj.load_rooms(path)
    assert_rooms_equal(rooms, loop.rooms)
    assert [_area(r.polygon) > 0 for r in rooms] == [True] * 3
    assert all(_area(h) < 0 for h in rooms[0].holes)


@pytest.mark.parametrize(
    ("z", "feature", "message"),
    [
        (True, 0, r"features\[0\] exterior ring: position 0: expected an altitude"),
        (math.nan, 4, r"features\[4\] line: position 0: expected an altitude .*, received nan"),
        ("high", 1, r"features\[1\] exterior ring: position 0: expected an altitude"),
        (
            [0.0, 1.0],  # an altitude and a fourth element
            3,
            r"features\[3\] line: position 0: expected \[x, y\] or \[x, y, z\], received "
            r"\[.*, .*, 0.0, 1.0\]$",
        ),
    ],
)
def test_load_rooms_refuses_a_bad_altitude_or_a_fourth_element(
    seg, tmp_path: Path, z, feature, message
):
    doc = _rooms_doc(seg, tmp_path)
    pos = doc["features"][feature]["geometry"]["coordinates"]
    pos = pos[0][0] if doc["features"][feature]["geometry"]["type"] == "Polygon" else pos[0]
    if isinstance(z, list):
        pos.extend(z)
    else:
        pos.append(z)
    path = tmp_path / "bad.geojson"
    path.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(ValueError, match=message) as info:
        tj.load_rooms(path)
    assert str(path) in str(info.value)


def test_load_rooms_takes_doors_that_end_on_the_maps_border(tmp_path: Path):
    # a doorway between a wall and the map's outer wall on its first row ends on row 0:
    # the rooms the package writes may end a door on the border, never past it
    occ = three_rooms_occupied()
    for c in (50, 100):
        occ[:, c] = True
        occ[1:17, c] = False
    m = tj.OccupancyMap(occupied=occ, free=~occ, unknown=np.zeros_like(occ), resolution_m=0.05)
    border = tj.segment_rooms(m)
    assert [d.ends_px.tolist() for d in border.doors] == [
        [[0, 50], [17, 50]],
        [[0, 100], [17, 100]],
    ]
    rooms, doors = tj.load_rooms(tj.save_rooms(border, tmp_path / "r.geojson"))
    assert_rooms_equal(rooms, border.rooms)
    assert_doors_equal(doors, border.doors)


def test_load_rooms_missing_unreadable_or_another_kind_of_file(tmp_path: Path):
    with pytest.raises(FileNotFoundError, match="^path: file not found: .*nothing.geojson"):
        tj.load_rooms(tmp_path / "nothing.geojson")
    with pytest.raises(ValueError, match="^path: expected a file, received the folder"):
        tj.load_rooms(tmp_path)
    broken = tmp_path / "broken.geojson"
    broken.write_text('{"type": "FeatureCollection", ', encoding="utf-8")
    with pytest.raises(ValueError, match=f"rooms file {broken} is not valid JSON"):
        tj.load_rooms(broken)
    graph = _graph_geojson(tmp_path / "graph.geojson")
    with pytest.raises(ValueError, match="not a rooms GeoJSON .*read it with load_graph"):
        tj.load_rooms(graph)


@pytest.mark.parametrize(
    ("save", "name"),
    [
        (tj.save_rooms, "r.geojson"),
        (tj.save_room_labels, "r.png"),
        (tj.save_room_graph, "r.graphml"),
        (tj.save_room_graph, "r.json"),
    ],
)
def test_room_writers_name_a_path_that_cannot_be_written(seg, tmp_path: Path, save, name):
    missing = tmp_path / "missing" / name
    with pytest.raises(
        FileNotFoundError,
        match=f"^path: expected a file in an existing folder, received {missing}, whose folder",
    ):
        save(seg, missing)
    (tmp_path / "a_file").write_text("x")
    with pytest.raises(NotADirectoryError, match="^path: "):
        save(seg, tmp_path / "a_file" / name)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


def test_an_empty_segmentation_round_trips(tmp_path: Path):
    occ = np.ones((20, 30), bool)  # all obstacle: no room
    m = tj.OccupancyMap(occupied=occ, free=~occ, unknown=np.zeros_like(occ))
    empty = tj.segment_rooms(m)
    assert empty.n_rooms == 0
    path = tj.save_rooms(empty, tmp_path / "r.geojson")
    assert tj.load_rooms(path) == ((), ())


# ---------------------------------------------------------------------- label picture


def test_label_picture(seg, tmp_path: Path):
    path = tj.save_room_labels(seg, tmp_path / "labels.png")
    bgr = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert bgr.shape == (*seg.labels.shape, 3) and bgr.dtype == np.uint8, "RGB, no alpha"
    rgb = bgr[..., ::-1]
    door_px = np.zeros(seg.labels.shape, bool)
    for door in seg.doors:
        door_px[door.pixels[:, 0], door.pixels[:, 1]] = True
    assert (rgb[door_px] == 255).all(), "doors white"
    colours = room_colours(seg.n_rooms)
    for room in seg.rooms:
        here = (seg.labels == room.id) & ~door_px
        assert (rgb[here] == colours[room.id - 1]).all(), f"room {room.id} in its colour"
    walls = (seg.labels == 0) & seg.occupancy.occupied & ~door_px
    assert walls.any() and (rgb[walls] == 0).all(), "walls black"
    assert len({tuple(c) for c in colours}) == seg.n_rooms
    again = tj.save_room_labels(seg, tmp_path / "again.png")
    assert again.read_bytes() == path.read_bytes(), "deterministic"
    for name in ("labels.jpg", "labels"):  # PNG bytes under another name would mislead
        with pytest.raises(
            ValueError, match=rf"^path: expected a \.png file name, received '.*/{name}'$"
        ):
            tj.save_room_labels(seg, tmp_path / name)
        assert not (tmp_path / name).exists()


def test_room_colours_are_distinct_and_stable():
    many = room_colours(300)
    assert many.shape == (300, 3) and many.dtype == np.uint8
    assert len({tuple(c) for c in many}) == 300
    assert not ({(0, 0, 0), (128, 128, 128), (255, 255, 255)} & {tuple(c) for c in many})
    np.testing.assert_array_equal(room_colours(7), many[:7])
    assert room_colours(0).shape == (0, 3)


def test_room_colours_for_more_rooms_than_the_hue_families_hold():
    # the golden-ratio hues at nine saturation/value pairs round to fewer than 8000
    # distinct colours; a map of 10,000 rooms (isolated specks on a coarse map) still
    # gets a distinct colour for each, and the first ones do not change
    n = 10_000
    many = room_colours(n)
    assert many.shape == (n, 3)
    as_int = many.astype(np.int64) @ np.array([1 << 16, 1 << 8, 1])
    assert np.unique(as_int).size == n
    assert not ((many[:, 0] == many[:, 1]) & (many[:, 1] == many[:, 2])).any()  # no grey
    np.testing.assert_array_equal(many[:300], room_colours(300))


# ---------------------------------------------------------------------- room graph


def test_room_graph_graphml_and_json_are_read_by_networkx(seg, tmp_path: Path):
    graphml = tj.save_room_graph(seg, tmp_path / "g.graphml")
    raw = nx.read_graphml(graphml)
    assert sorted(raw.nodes) == ["1", "2", "3"]
    assert json.loads(raw.nodes["2"]["centroid"]) == list(seg.rooms[1].centroid)
    assert raw.nodes["2"]["area_m2"] == seg.rooms[1].area_m2
    doors = sorted(json.loads(d["doors"]) for _, _, d in raw.edges(data=True))
    assert doors == [[1], [2]]

    nodelink = tj.save_room_graph(seg, tmp_path / "g.json")
    g = nx.node_link_graph(json.loads(nodelink.read_text(encoding="utf-8")), edges="edges")
    assert sorted(g.nodes) == [1, 2, 3]
    assert sorted(map(sorted, g.edges())) == [[1, 2], [2, 3]]
    assert g.graph["n_rooms"] == 3 and g.graph["shape"] == [60, 150]

    for path in (graphml, nodelink):
        back = tj.load_graph(path)
        assert back.nodes[1]["centroid"] == seg.rooms[0].centroid
        assert back.nodes[1]["bbox_px"] == seg.rooms[0].bbox
        assert back.edges[1, 2, 0]["doors"] == [1]
        assert back.edges[1, 2, 0]["width_m"] == seg.doors[0].width_m
        assert back.graph["origin"] == (-1.5, 2.0, 0.3)


def test_room_graph_format_from_the_suffix_only(seg, tmp_path: Path):
    with pytest.raises(ValueError, match=r"path: expected a room-graph file ending in .*g\.txt"):
        tj.save_room_graph(seg, tmp_path / "g.txt")
    with pytest.raises(TypeError, match="seg: expected a RoomSegmentation"):
        tj.save_room_graph(None, tmp_path / "g.json")


def test_save_room_files_writes_the_four_outputs(seg, tmp_path: Path):
    written = save_room_files(seg, tmp_path / "office")
    assert [p.name for p in written] == [f"office{s}" for s in ROOM_FILE_SUFFIXES]
    assert all(p.is_file() for p in written)
    rooms, doors = tj.load_rooms(written[0])
    assert_rooms_equal(rooms, seg.rooms)


@pytest.mark.parametrize(
    ("stem", "error", "words"),
    [
        (None, TypeError, "stem: expected a path (str or os.PathLike), received NoneType"),
        (3, TypeError, "stem: expected a path (str or os.PathLike), received int"),
        ("", ValueError, "stem: expected a path, received an empty one"),
        (".", ValueError, "stem: expected a path ending in a file name"),
        ("out/..", ValueError, "stem: expected a path ending in a file name"),
    ],
)
def test_save_room_files_names_a_stem_that_is_no_file_name(seg, stem, error, words):
    """A stem that is no path, or a folder with no name to put the suffixes on, is refused
    naming ``stem`` (a raw "expected str, bytes or os.PathLike" or "has an empty name")."""
    with pytest.raises(error) as info:
        save_room_files(seg, stem)
    assert words in str(info.value)


def test_a_key_given_twice_in_a_rooms_file_is_refused_naming_it(seg, tmp_path: Path):
    path = tj.save_rooms(seg, tmp_path / "r.geojson")
    path.write_text(path.read_text().rstrip()[:-1] + ', "features": []}')
    with pytest.raises(ValueError) as info:
        tj.load_rooms(path)
    assert str(info.value) == (
        f"rooms file {path}: key 'features' is given twice in one object; expected each key once"
    )


@pytest.mark.parametrize(
    ("save", "name"),
    [(tj.save_rooms, ".geojson"), (tj.save_room_labels, ".png"), (tj.save_room_graph, ".json")],
)
def test_room_writers_say_a_name_that_is_only_the_suffix_has_no_stem(seg, tmp_path, save, name):
    with pytest.raises(ValueError) as info:
        save(seg, tmp_path / name)
    assert str(info.value) == (
        f"path: a file named only {name!r} has no stem (the part before the suffix); "
        f"expected a name such as 'map{name}', received {str(tmp_path / name)!r}"
    )
    assert list(tmp_path.iterdir()) == []
