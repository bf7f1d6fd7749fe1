"""Room segmentation: synthetic floor plans with known rooms and doors, properties, links
to the topology graph, bad input, and regressions on IPA maps."""

from __future__ import annotations

import warnings
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
from floorplans import RES, floor_plan
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import topojax as tj
from topojax.maps.occupancy import OccupancyMap

IPA = Path(__file__).resolve().parents[2] / "shared" / "data" / "maps" / "ipa"


def _map(
    free: np.ndarray, unknown: np.ndarray | None = None, origin=(0.0, 0.0, 0.0)
) -> OccupancyMap:
    free = np.asarray(free, bool)
    unknown = np.zeros_like(free) if unknown is None else np.asarray(unknown, bool)
    return OccupancyMap(
        occupied=~free & ~unknown, free=free, unknown=unknown, resolution_m=RES, origin=origin
    )


def _best_iou(seg_labels: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """For each ground-truth room, the IoU with the segment that overlaps it most."""
    out = []
    for k in range(1, int(truth.max()) + 1):
        t = truth == k
        ids, counts = np.unique(seg_labels[t], return_counts=True)
        s = seg_labels == ids[np.argmax(counts)]
        out.append((t & s).sum() / (t | s).sum())
    return np.array(out)


def _two_rooms(door_m: float, wall_px: int = 3) -> np.ndarray:
    """Two 5 m x 5 m rooms side by side, one door of ``door_m`` in the wall between."""
    free = np.zeros((104, 207), bool)
    free[2:102, 2:102] = True
    free[2:102, 102 + wall_px : 205] = True
    d = int(round(door_m / RES))
    free[52 - d // 2 : 52 - d // 2 + d, 102 : 102 + wall_px] = True
    return free


# --- known answers ---------------------------------------------------------------------


@pytest.mark.parametrize("door_m", [0.7, 0.9, 1.2, 1.6])
def test_two_rooms_and_one_door_of_any_usual_width(door_m):
    seg = tj.segment_rooms(_map(_two_rooms(door_m)))
    assert seg.n_rooms == 2
    assert len(seg.doors) == 1
    door = seg.doors[0]
    assert door.rooms == (1, 2)
    assert door.width_m == pytest.approx(door_m, abs=2.5 * RES)
    assert nx.is_connected(seg.graph)


def test_a_gap_between_a_wall_and_the_maps_edge_is_no_door():
    """Free space that runs off the map (a map cropped there, or drawn with a white
    outside) has no wall at the edge: a wall ending 0.9 m short of it leaves no doorway,
    where the same gap against a wall is one."""
    free = np.zeros((104, 207), bool)
    free[2:104, 2:102] = True
    free[2:104, 105:205] = True
    free[86:104, 102:105] = True  # the wall between stops 18 px short of the bottom edge
    seg = tj.segment_rooms(_map(free))
    assert seg.n_rooms == 1 and seg.doors == ()
    free[101:104] = False  # a bottom wall: the same gap now runs between two walls
    free[83:101, 102:105] = True
    seg = tj.segment_rooms(_map(free))
    assert seg.n_rooms == 2 and len(seg.doors) == 1
    assert seg.doors[0].width_m == pytest.approx(0.9, abs=2 * RES)


def test_a_window_keeps_doorways_across_its_cut_sides():
    """A window cut from a larger map (a local incremental update) ends in the map's
    space, not at its edge: a doorway whose wall lies beyond the window's side is kept,
    as the larger map's segmentation has it."""
    from topojax.rooms.segment import segment_window

    free = _two_rooms(0.9)  # the door runs down the wall between the rooms, rows 43-61
    occ = _map(free)
    whole = tj.segment_rooms(occ)
    assert len(whole.doors) == 1
    top = 50  # a window whose top side cuts through the doorway
    window = _map(free[top:])
    h, w = free.shape
    kept = segment_window(window, tj.RoomConfig(), map_box=(-top, 0, h - top, w))
    assert kept.n_rooms == 2 and len(kept.doors) == 1
    assert kept.doors[0].ends_px[:, 0].min() < 0  # the end beyond the window's side
    assert tj.segment_rooms(window).doors == ()  # as a map of its own: that is its edge
    with pytest.raises(ValueError, match=r"map_box: expected a box holding the window"):
        segment_window(window, tj.RoomConfig(), map_box=(0, 0, 10, 10))


def test_doors_end_on_the_map():
    for name in ("intel", "office", "a_scan"):
        occ = tj.sample_map(name)
        for door in tj.segment_rooms(occ).doors:
            assert (door.ends_px >= 0).all() and (door.ends_px < occ.shape).all(), name


def test_reprs_are_short_summaries():
    """A segmentation's repr is one line, not every pixel of every door and outline."""
    seg = tj.segment_rooms(_map(_two_rooms(0.9)))
    w = seg.labels.shape[1]
    assert repr(seg) == f"RoomSegmentation(2 rooms, 1 door, {w} x 104 px (w x h) at {RES:g} m/px)"
    assert "polygon" not in repr(seg.rooms[0]) and "pixels" not in repr(seg.doors[0])
    door = seg.doors[0]
    (r0, c0), (r1, c1) = door.ends_px.tolist()
    (x0, y0), (x1, y1) = door.ends_world.tolist()
    assert repr(door) == (  # one line: its ends as numbers, not two arrays over four lines
        f"Door(id=1, rooms=(1, 2), ends_px=(({r0}, {c0}), ({r1}, {c1})), "
        f"ends_world=(({x0:g}, {y0:g}), ({x1:g}, {y1:g})), width_m={door.width_m!r})"
    )


def test_rooms_are_numbered_in_raster_order_of_their_first_pixel():
    """The doorway line in the one-pixel wall at row 40 joins the lower room, so that
    room's first pixel (40, 40) comes before the first pixel (40, 102) of the room on the
    right, though its free space off the line starts a row lower."""
    free = np.zeros((120, 150), bool)
    free[2:40, 2:100] = True  # upper room
    free[40, 40:58] = True  # a door of 0.9 m in the wall between it and the lower room
    free[41:111, 2:100] = True  # lower room
    free[40:111, 102:148] = True  # a room of its own on the right
    seg = tj.segment_rooms(_map(free))
    assert [r.bbox[:2] for r in seg.rooms] == [(2, 2), (40, 2), (40, 102)]
    firsts = [np.flatnonzero(seg.labels.ravel() == r.id)[0] for r in seg.rooms]
    assert firsts == sorted(firsts) and firsts[1] == 40 * 150 + 40
    assert [d.rooms for d in seg.doors] == [(1, 2)]


def test_a_gap_wider_than_max_door_width_joins_one_room():
    seg = tj.segment_rooms(_map(_two_rooms(1.6)), config=tj.RoomConfig(max_door_width_m=1.2))
    assert seg.n_rooms == 1 and seg.doors == ()


def test_one_room_map_is_one_room_and_its_walls_are_no_room():
    free = np.zeros((80, 120), bool)
    free[3:77, 3:117] = True
    seg = tj.segment_rooms(_map(free))
    assert seg.n_rooms == 1
    assert seg.doors == ()
    assert (seg.labels[free] == 1).all()
    assert (seg.labels[:3] == 0).all() and (seg.labels[:, :3] == 0).all()
    room = seg.rooms[0]
    assert room.area_m2 == pytest.approx(free.sum() * RES**2)
    assert room.bbox == (3, 3, 76, 116)
    assert all(type(v) is int for v in room.bbox)  # as documented (json writes them)


@pytest.mark.parametrize("min_room_m2", [0.0, 2.0, 20.0])
def test_a_free_area_without_doorways_is_a_room_from_min_isolated_room_m2_on(min_room_m2):
    """A closed 6.25 m2 room is a room at min_isolated_room_m2 6 and none at 7, whatever
    min_room_m2 (which merges regions that have doorways) says."""
    free = np.zeros((60, 60), bool)
    free[5:55, 5:55] = True
    for iso, rooms in ((6.0, 1), (7.0, 0)):
        cfg = tj.RoomConfig(min_isolated_room_m2=iso, min_room_m2=min_room_m2)
        assert tj.segment_rooms(_map(free), config=cfg).n_rooms == rooms


def test_no_free_space_gives_no_rooms(monkeypatch):
    import topojax.rooms.model as model

    def refused(*args):  # nothing to measure: the command line's time says no stage ran
        raise AssertionError("a map without rooms loads the label kernel")

    monkeypatch.setattr(model, "label_stats", refused)
    seg = tj.segment_rooms(_map(np.zeros((40, 40), bool)))
    assert seg.n_rooms == 0 and seg.doors == () and not seg.labels.any()
    assert seg.graph.number_of_nodes() == 0


def test_unknown_space_outside_the_mapped_area_is_never_a_room():
    fp = floor_plan(3)
    seg = tj.segment_rooms(fp.occupancy)
    assert not seg.labels[fp.occupancy.unknown].any()


@pytest.mark.parametrize("min_room_m2", [0.0, 2.0])
def test_clutter_inside_a_room_belongs_to_it(min_room_m2):
    free = np.zeros((120, 120), bool)
    free[2:118, 2:118] = True
    free[50:60, 40:70] = False  # a table standing free in the room
    seg = tj.segment_rooms(_map(free), config=tj.RoomConfig(min_room_m2=min_room_m2))
    assert seg.n_rooms == 1
    assert (seg.labels[50:60, 40:70] == 1).all()
    assert seg.rooms[0].area_m2 == pytest.approx(116 * 116 * RES**2)


@pytest.mark.parametrize("min_room_m2", [1.0, 2.0, 4.0])
def test_unexplored_space_a_room_surrounds_is_no_room_from_min_room_m2_on(min_room_m2):
    # a corridor ring (1 m wide) mapped round a block whose inside was never seen: a
    # wall of known pixels, then unknown space; and an unseen table inside a 0.25 m² patch
    free = np.zeros((160, 160), bool)
    free[2:158, 2:158] = True
    free[22:138, 22:138] = False
    unknown = np.zeros_like(free)
    unknown[24:136, 24:136] = True
    unknown[5:10, 60:70] = True  # 0.125 m², inside the corridor
    free[5:10, 60:70] = False
    n_unknown_px = 112 * 112  # 31.4 m²
    seg = tj.segment_rooms(_map(free, unknown), config=tj.RoomConfig(min_room_m2=min_room_m2))
    assert seg.n_rooms == 1
    assert (seg.labels[5:10, 60:70] == 1).all()  # the small patch is the corridor's
    assert n_unknown_px * RES**2 >= min_room_m2
    assert not seg.labels[unknown & (np.arange(160)[:, None] > 20)].any()  # the block: none
    assert (seg.labels[22:138, 22:24] == 0).all()  # nor the block's known wall
    assert len(seg.rooms[0].holes) == 1
    # the same block with a smaller inside than min_room_m2 is the corridor's again
    small = np.zeros_like(free)
    small[60 : 60 + 10, 60 : 60 + 10] = True  # 0.25 m²
    seg = tj.segment_rooms(_map(free, small), config=tj.RoomConfig(min_room_m2=min_room_m2))
    assert (seg.labels[22:138, 22:138] == 1).all()


def test_a_gap_narrower_than_the_door_search_cells_still_joins_the_room():
    # a cupboard one pixel (0.05 m) off the wall: closed on the 0.1 m cells the doorways
    # are searched on, open on the map's pixels, where the regions are made
    free = np.zeros((120, 120), bool)
    free[2:118, 2:118] = True
    free[3:117, 60:64] = False  # the cupboard, a 0.05 m gap at both ends
    seg = tj.segment_rooms(_map(free))
    assert seg.n_rooms == 1 and seg.doors == ()
    assert (seg.labels[free] == 1).all()


@pytest.mark.parametrize(
    "res, min_door_m, door_px", [(0.25, 0.5, 2), (0.1, 0.6, 6), (0.1, 0.5, 5), (0.2, 0.6, 3)]
)
def test_a_door_of_exactly_min_door_width_is_a_door_on_coarse_maps(res, min_door_m, door_px):
    """On maps of 0.1 m or coarser the doorways are searched on the pixels; a gap of an
    even number of pixels has its clearance half a pixel below an odd one's and must not
    be missed at the smallest width."""
    n = int(round(6.0 / res))  # two rooms of 6 m x 6 m, a wall of one pixel between
    free = np.zeros((n + 2, 2 * n + 3), bool)
    free[1:-1, 1 : n + 1] = free[1:-1, n + 2 : -1] = True
    free[(n + 2 - door_px) // 2 : (n + 2 + door_px) // 2, n + 1] = True
    occ = OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=res)
    seg = tj.segment_rooms(occ, config=tj.RoomConfig(min_door_width_m=min_door_m))
    assert [(d.rooms, d.width_m) for d in seg.doors] == [((1, 2), pytest.approx(door_px * res))]
    narrower = tj.RoomConfig(min_door_width_m=min_door_m + res / 2)
    assert tj.segment_rooms(occ, config=narrower).doors == ()


@pytest.mark.parametrize("door_px", [13, 14, 15, 17])
def test_door_width_is_measured_on_the_map_pixels(door_px):
    seg = tj.segment_rooms(_map(_two_rooms(door_px * RES)))
    assert len(seg.doors) == 1
    assert seg.doors[0].width_m == pytest.approx(door_px * RES, abs=1.01 * RES)


@pytest.mark.parametrize("seed", range(3))
def test_a_finer_map_of_the_same_plan_gives_the_same_rooms_and_doors(seed):
    fp = floor_plan(seed)
    occ = fp.occupancy

    def up(a):
        return np.repeat(np.repeat(a, 2, axis=0), 2, axis=1)

    fine = OccupancyMap(
        occupied=up(occ.occupied),
        free=up(occ.free),
        unknown=up(occ.unknown),
        resolution_m=RES / 2,
    )
    seg = tj.segment_rooms(fine)
    assert seg.n_rooms == fp.n_rooms
    assert _best_iou(seg.labels, up(fp.rooms)).min() > 0.9
    assert sorted(d.rooms for d in seg.doors) == sorted(
        _matched_pairs(seg.labels, up(fp.rooms), fp.doors)
    )


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("offset", [(0.0, 0.0), (0.5, 0.5), (-0.5, 1.5)])
def test_padding_the_map_with_unknown_space_changes_no_room(seed, offset):
    """The doorway search runs on cells of 2 x 2 pixels here; they lie on the map frame's
    lattice, not on the map's edge, so a map cut tight round its free space and the same
    map padded in its frame by one to three pixels of unknown space give the same rooms
    and doors (as a mapper's growing map, or a window of it, must), also where the
    origin lies half a pixel (``offset``, pixels) off the lattice."""
    x0, y0 = (v * RES for v in offset)
    occ = floor_plan(seed).occupancy
    rows = np.flatnonzero(occ.free.any(axis=1))
    cols = np.flatnonzero(occ.free.any(axis=0))
    tight = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    free, unknown = occ.free[tight], occ.unknown[tight]
    base = tj.segment_rooms(_map(free, unknown, origin=(x0, y0, 0.0)))
    for top, left in ((1, 0), (0, 1), (1, 1), (2, 3)):
        padded = [
            np.pad(a, ((top, 1), (left, 2)), constant_values=v)
            for a, v in ((free, False), (unknown, True))
        ]
        # the origin is the lower left corner: one row below, ``left`` columns left
        seg = tj.segment_rooms(_map(*padded, origin=(x0 - left * RES, y0 - RES, 0.0)))
        inner = seg.labels[top : top + free.shape[0], left : left + free.shape[1]]
        np.testing.assert_array_equal(inner, base.labels)
        assert sorted(d.rooms for d in seg.doors) == sorted(d.rooms for d in base.doors)
        shift = np.array([top, left])
        for a, b in zip(seg.doors, base.doors, strict=True):
            np.testing.assert_array_equal(np.asarray(a.pixels) - shift, b.pixels)


def test_rooms_follow_the_map_frame_not_the_array():
    """The same pixels placed a pixel apart in the world may find other doorways (the
    cells fall elsewhere on them), but the same map moved by whole cells finds the same."""
    occ = floor_plan(1).occupancy
    base = tj.segment_rooms(occ)
    x0, y0, _ = occ.origin
    moved = tj.segment_rooms(
        OccupancyMap(
            occupied=occ.occupied,
            free=occ.free,
            unknown=occ.unknown,
            resolution_m=RES,
            origin=(x0 + 20 * RES, y0 - 6 * RES, 0.0),  # 10 and 3 cells of 2 x 2 pixels
        )
    )
    np.testing.assert_array_equal(moved.labels, base.labels)


@pytest.mark.parametrize("seed", range(6))
def test_synthetic_floor_plans_give_their_rooms_and_doors(seed):
    fp = floor_plan(seed)
    seg = tj.segment_rooms(fp.occupancy)
    assert seg.n_rooms == fp.n_rooms
    assert _best_iou(seg.labels, fp.rooms).min() > 0.9
    assert sorted(d.rooms for d in seg.doors) == sorted(
        _matched_pairs(seg.labels, fp.rooms, fp.doors)
    )


def _matched_pairs(labels: np.ndarray, truth: np.ndarray, doors) -> list:
    """The true doors' room pairs in the segmentation's ids."""
    to_seg = {}
    for k in range(1, int(truth.max()) + 1):
        ids, counts = np.unique(labels[truth == k], return_counts=True)
        to_seg[k] = int(ids[np.argmax(counts)])
    return [tuple(sorted((to_seg[a], to_seg[b]))) for a, b, _ in doors]


# --- properties ------------------------------------------------------------------------


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 10_000))
def test_properties_on_random_plans(seed):
    fp = floor_plan(seed, size_m=(12.0, 16.0))
    occ = fp.occupancy
    seg = tj.segment_rooms(occ)
    labels = seg.labels
    # ids are 1..n, each room's pixels as its record says
    assert set(np.unique(labels[labels > 0]).tolist()) == set(range(1, seg.n_rooms + 1))
    for room in seg.rooms:
        r0, c0, r1, c1 = room.bbox
        mine = labels == room.id
        assert mine[r0 : r1 + 1, c0 : c1 + 1].sum() == mine.sum()
        assert room.area_m2 == pytest.approx(mine.sum() * RES**2)
        assert seg.room_at(room.centroid) in (0, room.id) or not _convex(mine)
    # every door joins two distinct rooms that both touch it
    for door in seg.doors:
        a, b = door.rooms
        assert 0 < a < b <= seg.n_rooms
        near = _around(labels, door.pixels)
        assert a in near and b in near
    # the room graph is connected exactly where the free space is
    g = seg.graph
    free_parts = _free_components_with_rooms(occ.free, labels)
    assert nx.number_connected_components(g) == len(free_parts)


def _convex(mask: np.ndarray) -> bool:
    rows, cols = np.nonzero(mask)
    return mask.sum() == (rows.max() - rows.min() + 1) * (cols.max() - cols.min() + 1)


def _around(labels: np.ndarray, pixels: np.ndarray) -> set:
    h, w = labels.shape
    out = set()
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            r = np.clip(pixels[:, 0] + dr, 0, h - 1)
            c = np.clip(pixels[:, 1] + dc, 0, w - 1)
            out |= set(labels[r, c].tolist())
    return out - {0}


def _free_components_with_rooms(free: np.ndarray, labels: np.ndarray) -> list:
    """8-connected parts of the free space big enough to be a room (free specks inside
    clutter belong to the room around them)."""
    import cv2

    n, parts = cv2.connectedComponents(free.view(np.uint8), connectivity=8)
    size = np.bincount(parts.ravel(), minlength=n)
    small = tj.RoomConfig().min_room_m2 / RES**2
    return [k for k in range(1, n) if size[k] >= small and (labels[parts == k] > 0).any()]


# --- links to the topology graph -------------------------------------------------------


def test_every_vertex_gets_its_room_and_edges_their_rooms_and_doors():
    free = _two_rooms(0.9)
    occ = _map(free)
    res = tj.build_graph(occ)
    seg = tj.segment_rooms(res)
    g = tj.assign_rooms(res.graph, seg)
    assert g.graph["rooms"] == 2
    for _, d in g.nodes(data=True):
        r, c = d["pixel"]
        assert d["room"] == seg.labels[r, c] or seg.labels[r, c] == 0
    crossing = [d for *_, d in g.edges(data=True) if len(set(d["rooms"])) == 2]
    assert crossing, "some edge runs from one room into the other"
    for d in crossing:
        assert d["doors"] == [seg.doors[0].id]
    for *_, d in g.edges(data=True):
        assert len(d["doors"]) == max(0, len(d["rooms"]) - 1)


def test_assign_rooms_refuses_another_map():
    """A graph of another map (shape, or the same pixels at another origin) is refused
    before anything is written; so is a graph with an edge without its path."""
    seg = tj.segment_rooms(_map(_two_rooms(0.9)))
    other = tj.build_graph(_map(np.pad(_two_rooms(0.9), 5)))
    # the graph is refused: the map expected is the segmentation's, the one received
    # the graph's
    h, w = seg.labels.shape
    with pytest.raises(
        ValueError,
        match=rf"^graph: .*: expected a map of shape \({h}, {w}\), received the graph's "
        rf"map of shape \({h + 10}, {w + 10}\)$",
    ):
        tj.assign_rooms(other.graph, seg)
    with pytest.raises(TypeError, match="seg"):
        tj.assign_rooms(other.graph, "rooms")
    moved = tj.build_graph(_map(_two_rooms(0.9), origin=(3.0, -2.0, 0.7))).graph
    with pytest.raises(
        ValueError,
        match=r"graph: a graph of the segmentation's map .*received the graph's map with origin \(3\.0, -2\.0, 0\.7\)",
    ):
        tj.assign_rooms(moved, seg)
    own = tj.build_graph(_map(_two_rooms(0.9))).graph
    u, v, k = next(iter(own.edges(keys=True)))
    del own.edges[u, v, k]["path"]
    with pytest.raises(ValueError, match="every edge to carry its pixel 'path'"):
        tj.assign_rooms(own, seg)
    assert not any("room" in d for _, d in own.nodes(data=True)), "nothing written"


@pytest.mark.parametrize(
    ("where", "value", "exc", "words"),
    [
        ("node", np.array([[np.nan, 3.0]]), ValueError, "integers, .* received nan among them"),
        ("node", "here", TypeError, "integers, .* received str of dtype <U4"),
        ("node", [4, 5, 6], ValueError, r"integers, .* received shape \(3,\)"),
        ("edge", None, TypeError, "integers, .* received NoneType of dtype object"),
        ("edge", np.array([1, 2, 3]), ValueError, r"integers, .* received shape \(3,\)"),
        ("edge", np.array([[4.5, 6.0]]), ValueError, "integers, .* received 4.5 among them"),
    ],
)
def test_assign_rooms_refuses_edited_pixels_before_writing(where, value, exc, words):
    """A vertex's pixels or an edge's path that are not integer (row, col) pixels are
    refused, naming the vertex or edge, before any room is written."""
    seg = tj.segment_rooms(_map(_two_rooms(0.9)))
    own = tj.build_graph(_map(_two_rooms(0.9))).graph
    u, v, k = next(iter(own.edges(keys=True)))
    if where == "node":
        own.nodes[u]["pixels"] = value
        name = rf"node {u!r}: 'pixels'"
    else:
        own.edges[u, v, k]["path"] = value
        name = rf"edge {u!r}-{v!r}: 'path'"
    with pytest.raises(exc, match=rf"^graph: {name}: expected \(row, col\) pixels as {words}"):
        tj.assign_rooms(own, seg)
    assert not any("room" in d for _, d in own.nodes(data=True)), "nothing written"
    assert not any("rooms" in d for *_, d in own.edges(data=True)), "nothing written"


def test_room_at_world_points():
    seg = tj.segment_rooms(_map(_two_rooms(0.9)))
    for room in seg.rooms:
        assert seg.room_at(room.centroid) == room.id
    assert seg.room_at((-100.0, -100.0)) == 0
    # finite points so far off that their pixel overflows are off the map too
    assert seg.room_at((1e308, -1e308)) == 0
    assert seg.room_at((1e300, 0.0)) == 0
    with pytest.raises(TypeError, match=r"^point: expected two finite numbers \(x, y\)"):
        seg.room_at("here")
    with pytest.raises(ValueError, match=r"^point: expected two finite numbers .* received"):
        seg.room_at((np.nan, 0.0))
    with pytest.raises(TypeError, match=r"^point: expected two finite numbers"):
        seg.room_at((True, 3.0))  # a bool is not a coordinate


# --- bad input -------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"min_door_width_m": -1.0}, "min_door_width_m"),
        ({"max_door_width_m": 0.0}, "max_door_width_m"),
        (
            {"max_door_width_m": 0.4, "min_door_width_m": 0.6},
            r"^min_door_width_m, max_door_width_m: expected .* received 0.6 and 0.4 m",
        ),
        ({"door_ratio": 0.0}, r"^door_ratio: expected a finite number > 0, received 0.0"),
        ({"max_border_share": 2}, r"^max_border_share: expected a share .* in \(0, 1\]"),
        ({"min_room_m2": float("nan")}, r"^min_room_m2: expected a finite number of m2 >= 0"),
        ({"door_context_m": "1"}, "door_context_m"),
    ],
)
def test_bad_options_name_themselves(kwargs, match):
    with pytest.raises((TypeError, ValueError), match=match):
        tj.RoomConfig(**kwargs)


@pytest.mark.parametrize("res", [RES, 0.1])
@pytest.mark.parametrize("field", ["door_context_m", "max_door_width_m", "min_door_width_m"])
def test_lengths_beyond_the_map_act_as_the_whole_map(field, res):
    """A length of 1e300 m segments as one of 1e4 m (both past the map), with no
    overflow of the kernels' integers or of the float32 clearances."""
    free = _two_rooms(0.9)
    occ = OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=res)
    segs = []
    for value in (1e4, 1e300):
        extra = {"max_door_width_m": value} if field == "min_door_width_m" else {}
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            seg = tj.segment_rooms(occ, config=tj.RoomConfig(**{field: value}, **extra))
        segs.append(seg)
    assert np.array_equal(segs[0].labels, segs[1].labels)
    assert len(segs[0].doors) == len(segs[1].doors)


def test_bad_source_and_config_are_refused():
    with pytest.raises(TypeError, match="source"):
        tj.segment_rooms(np.zeros((10, 10), bool))
    with pytest.raises(TypeError, match="config"):
        tj.segment_rooms(_map(_two_rooms(0.9)), config={"min_room_m2": 1})


# --- regressions on the IPA benchmark maps ---------------------------------------------


@pytest.mark.skipif(not IPA.exists(), reason="shared IPA maps not present")
@pytest.mark.parametrize("name, rooms", [("lab_c_scan", (9, 17)), ("lab_intel", (15, 25))])
def test_ipa_maps_regression(name, rooms):
    occ = tj.load_map(IPA / f"{name}.png", mode="ipa", resolution_m=0.05)
    seg = tj.segment_rooms(occ)
    assert rooms[0] <= seg.n_rooms <= rooms[1]
    parts = _free_components_with_rooms(occ.free, seg.labels)
    assert nx.number_connected_components(seg.graph) == len(parts)
    assert all(0.5 <= d.width_m <= 2.3 for d in seg.doors)


@settings(max_examples=80, deadline=None)
@given(
    st.integers(1, 30),
    st.integers(1, 30),
    st.integers(1, 8),
    st.floats(0.5, 1.0),
    st.integers(0, 2**31),
)
def test_coarse_cells_are_free_only_when_every_pixel_is(h, w, f, p_free, seed):
    from topojax.rooms._grid import coarse_free

    free = np.random.default_rng(seed).random((h, w)) < p_free
    want = np.zeros((-(-h // f), -(-w // f)), bool)  # cells past the map stay closed
    for r in range(h // f):
        for c in range(w // f):
            want[r, c] = all(free[r * f + i, c * f + j] for i in range(f) for j in range(f))
    np.testing.assert_array_equal(coarse_free(free, f), want)


def test_a_cut_pixel_joins_the_room_it_shares_a_side_with():
    # the free pixel at (1, 1) lies on a cut (no region's room): room 1 is beside it,
    # room 2 only touches its corner, so it joins room 1 though 2 is the larger id
    from topojax.rooms._kernels import room_pixels

    regions = np.array([[1, 0, 0], [0, 0, 2], [0, 2, 2]], np.int32)
    free = np.array([[1, 0, 0], [0, 1, 1], [0, 1, 1]], bool)
    room_of = np.array([0, 2, 1], np.int32)  # region 1 is room 2, region 2 is room 1
    out = np.zeros((3, 3), np.int32)
    empty = np.zeros((3, 3), np.uint8)
    room_pixels(regions, room_of, free, 2, out, empty)
    assert out[1, 1] == 1
    assert out.tolist() == [[2, 0, 0], [0, 1, 1], [0, 1, 1]]
    # with no room beside it, the corner decides
    free[1, 2] = free[2, 1] = False
    regions[1, 2] = regions[2, 1] = 0
    out[:] = 0
    room_pixels(regions, room_of, free, 2, out, empty)
    assert out[1, 1] == 2
