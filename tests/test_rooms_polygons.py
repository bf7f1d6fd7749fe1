"""Room outlines (:attr:`Room.polygon`): one simple counter-clockwise ring along the pixel
edges of the room, whose area is the room's pixel area, that neighbouring rooms share
edges of, on literal shapes, random masks and the IPA benchmark maps."""

from __future__ import annotations

import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import topojax as tj
from topojax.maps.occupancy import OccupancyMap
from topojax.rooms.model import build_segmentation

IPA = Path(__file__).resolve().parents[2] / "shared" / "data" / "maps" / "ipa"
RES = 0.5  # a power of two: pixel corners are exact in the map frame
ORIGIN = (1.0, -2.0, 0.0)
#: ring area may exceed the pixel area by this much per pinch (square pixels)
PINCH_AREA = 1e-3


def _seg(labels) -> tj.RoomSegmentation:
    """The rooms of ``labels``, framed by a pixel of no room so that pixel (H - 1, 0)
    of ``labels`` has its outer corner at :data:`ORIGIN`."""
    labels = np.pad(np.asarray(labels, np.int32), 1)
    free = labels > 0
    occ = OccupancyMap(
        occupied=~free,
        free=free,
        unknown=np.zeros_like(free),
        resolution_m=RES,
        origin=(ORIGIN[0] - RES, ORIGIN[1] - RES, ORIGIN[2]),
    )
    return build_segmentation(occ, labels, [])


def _mask(rows: list[str]) -> np.ndarray:
    return np.array([[ch == "#" for ch in row] for row in rows])


def _twice_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return float(x @ np.roll(y, -1) - np.roll(x, -1) @ y)


def _orient(p, q, r) -> np.ndarray:
    cross = (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1])
    return np.sign(cross - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0]))


def _within(p, q, r) -> np.ndarray:
    """Whether ``r`` lies in the box of segment ``p``-``q`` (for collinear points)."""
    lo, hi = np.minimum(p, q), np.maximum(p, q)
    return ((lo <= r) & (r <= hi)).all(axis=-1)


def _problems(ring: np.ndarray) -> list[str]:
    """What makes ``ring`` (K, 2) no simple ring: fewer than 3 points, a repeated point,
    three consecutive collinear points, or two sides that meet other than consecutive
    sides at their shared end (crossing, touching or overlapping)."""
    k = len(ring)
    if k < 3:
        return [f"{k} points"]
    out = []
    if len({tuple(p) for p in ring.tolist()}) < k:
        out.append("a repeated point")
    prev, nxt = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
    if (_orient(prev, ring, nxt) == 0).any():
        out.append("collinear consecutive points")
    a, b = ring, nxt
    idx = np.arange(k)
    for s in range(0, k, 256):  # rows of sides at a time: K x K pairs in all
        a1, b1, i = a[s : s + 256, None], b[s : s + 256, None], idx[s : s + 256, None]
        o1, o2 = _orient(a1, b1, a[None]), _orient(a1, b1, b[None])
        o3, o4 = _orient(a[None], b[None], a1), _orient(a[None], b[None], b1)
        meet = (o1 * o2 < 0) & (o3 * o4 < 0)
        meet |= (o1 == 0) & _within(a1, b1, a[None])
        meet |= (o2 == 0) & _within(a1, b1, b[None])
        meet |= (o3 == 0) & _within(a[None], b[None], a1)
        meet |= (o4 == 0) & _within(a[None], b[None], b1)
        # consecutive sides share an end (and do not overlap: no collinear points)
        same = (i == idx) | ((i + 1) % k == idx) | (i == (idx + 1) % k)
        if (meet & ~same).any():
            out.append("sides that meet")
            break
    return out


def _largest_part(mask: np.ndarray) -> np.ndarray:
    """The largest 8-connected part of ``mask`` (the first in raster order among equals),
    bool of its shape."""
    n, parts = cv2.connectedComponents(mask.astype(np.uint8), connectivity=8)
    if n < 2:
        return np.zeros(mask.shape, bool)
    size = np.bincount(parts.ravel())
    size[0] = 0
    first = min(int(np.argmax(parts == k)) for k in np.flatnonzero(size == size.max()))
    return parts == parts.flat[first]


def _filled_area(mask: np.ndarray) -> int:
    """Pixels of the largest 8-connected part of ``mask`` and of what it encloses."""
    part = _largest_part(mask)
    if not part.any():
        return 0
    outside = np.pad(~part, 1, constant_values=True).astype(np.uint8)
    cv2.floodFill(outside, None, (0, 0), 2, flags=4)
    return int((outside != 2).sum())


def _assert_ring(ring: np.ndarray, pixels: int) -> None:
    assert ring.dtype == np.float64 and ring.ndim == 2 and ring.shape[1] == 2
    assert _problems(ring) == []
    area_px = _twice_area(ring) / 2 / RES**2
    assert area_px > 0, "counter-clockwise in the map frame"
    assert area_px == pytest.approx(pixels, abs=PINCH_AREA * len(ring))


def test_the_check_finds_what_makes_a_ring_not_simple():
    square = np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float)
    assert _problems(square) == []
    assert _problems(square[:2]) == ["2 points"]
    bowtie = np.array([[0, 0], [2, 2], [2, 0], [0, 2]], float)
    assert _problems(bowtie) == ["sides that meet"]
    out_and_back = np.array([[0, 0], [2, 0], [1, 0]], float)
    assert "collinear consecutive points" in _problems(out_and_back)
    pinch = np.array([[0, 0], [1, 0], [1, 1], [2, 1], [2, 2], [1, 2], [1, 1], [0, 1]], float)
    assert _problems(pinch) == ["a repeated point", "sides that meet"]
    # vertex (2, 0) lies on the first side
    touch = np.array([[0, 0], [4, 0], [4, 2], [3, 2], [2, 0], [1, 2], [0, 2]], float)
    assert _problems(touch) == ["sides that meet"]


# --- literal shapes -------------------------------------------------------------------

#: name: (rows, pixels inside the ring)
SHAPES = {
    "line": (["######"], 6),
    "column": (["#", "#", "#"], 3),
    "one pixel": (["#"], 1),
    "thin L": (["#....", "#....", "#####"], 7),
    "thick L": (["##...", "##...", "#####", "#####"], 14),
    "corner contact": (["##..", "##..", "..##", "..##"], 8),
    "staircase": (["#...", ".#..", "..#.", "...#"], 4),
    # three of its empty pixels have the room on all four sides: they are enclosed
    "checkerboard": (["#.#.#", ".#.#.", "#.#.#", ".#.#."], 13),
    "comb": (["#.#.#", "#####", "#.#.#"], 11),
    "open C touching itself": ([".###", "#..#", "#...", ".###"], 9),
    # the three empty pixels reach the outside only diagonally: they are enclosed
    "C closed at a corner": (["####", "#..#", "#.#.", "###."], 14),
}


@pytest.mark.parametrize("name", SHAPES)
def test_literal_shapes_give_a_simple_ring_of_their_pixel_area(name):
    rows, inside = SHAPES[name]
    mask = _mask(rows)
    (room,) = _seg(mask).rooms
    _assert_ring(room.polygon, inside)
    assert inside == _filled_area(mask)
    assert room.area_m2 == pytest.approx(mask.sum() * RES**2)


def test_a_one_pixel_room_is_its_square():
    (room,) = _seg(_mask(["#"])).rooms
    x0, y0 = ORIGIN[0], ORIGIN[1]
    square = {(x0, y0), (x0 + RES, y0), (x0 + RES, y0 + RES), (x0, y0 + RES)}
    assert {tuple(p) for p in room.polygon.tolist()} == square


def test_a_straight_room_has_four_corners():
    for rows in (SHAPES["line"][0], SHAPES["column"][0], ["###", "###"]):
        (room,) = _seg(_mask(rows)).rooms
        assert room.polygon.shape == (4, 2)


def test_a_diagonal_contact_is_a_thin_neck_not_a_shared_point():
    (room,) = _seg(_mask(SHAPES["corner contact"][0])).rooms
    ring = room.polygon
    # both 2 x 2 blocks are inside the ring: 8 pixels (and two corner cuts)
    assert _twice_area(ring) / 2 / RES**2 == pytest.approx(8, abs=1e-3)
    # the corner where the blocks meet (pixel corner (1.5, 1.5)) is no vertex; four
    # points close to it are
    cx, cy = ORIGIN[0] + 2 * RES, ORIGIN[1] + 2 * RES
    d = np.hypot(ring[:, 0] - cx, ring[:, 1] - cy)
    assert d.min() > 0
    assert (d < 0.05 * RES).sum() == 4


def test_a_room_round_clutter_holds_the_clutter_and_its_ring_has_no_hole():
    free = np.zeros((120, 120), bool)
    free[2:118, 2:118] = True
    free[50:60, 40:70] = False  # a table standing free in the room
    occ = OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=0.05)
    (room,) = tj.segment_rooms(occ).rooms
    ring = room.polygon
    assert _problems(ring) == []
    assert _twice_area(ring) / 2 == pytest.approx(room.area_m2, rel=1e-12)
    assert room.area_m2 == pytest.approx(116 * 116 * 0.05**2)


def test_a_room_round_another_room_encloses_it():
    labels = np.ones((5, 5), np.int32)
    labels[1:4, 1:4] = 2
    labels[2, 2] = 0
    one, two = _seg(labels).rooms
    # room 1 is the ring of 16 pixels; its outline is its outer edge (25 pixels)
    _assert_ring(one.polygon, 25)
    assert one.area_m2 == pytest.approx(16 * RES**2)
    _assert_ring(two.polygon, 9)


def _unit_edges(ring: np.ndarray) -> set:
    """The pixel edges along the axis-parallel sides of ``ring`` between pixel corners,
    each a pair of corners (map-frame x, y in pixels from the origin), in any order."""
    corners = (ring - np.array(ORIGIN[:2])) / RES
    out = set()
    for p, q in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        if not (np.all(p == np.round(p)) and np.all(q == np.round(q))):
            continue  # a side that ends at a corner cut
        n = int(abs(q - p).sum())
        steps = [p + (q - p) * t / n for t in range(n + 1)]
        for a, b in zip(steps, steps[1:], strict=False):
            out.add(frozenset({tuple(a.tolist()), tuple(b.tolist())}))
    return out


def test_neighbouring_rooms_share_the_edges_between_them():
    labels = np.zeros((6, 9), np.int32)
    labels[1:5, 1:4] = 1
    labels[1:5, 4:8] = 2
    labels[0, 3:6] = 2  # room 2 reaches over room 1: they meet on a step
    labels[5, 2:4] = 1
    contacts = ((labels[:, :-1] == 1) & (labels[:, 1:] == 2)).sum()
    contacts += ((labels[:-1] == 2) & (labels[1:] == 1)).sum()
    contacts += ((labels[:-1] == 1) & (labels[1:] == 2)).sum()
    assert contacts == 5
    one, two = _seg(labels).rooms
    _assert_ring(one.polygon, 14)
    _assert_ring(two.polygon, 19)
    assert len(_unit_edges(one.polygon) & _unit_edges(two.polygon)) == contacts


def test_only_the_largest_of_unconnected_parts_is_outlined():
    labels = _mask(["###.", "###.", "....", "...#"]).astype(np.int32)
    (room,) = _seg(labels).rooms
    _assert_ring(room.polygon, 6)
    assert room.area_m2 == pytest.approx(7 * RES**2)


# --- random masks ---------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(arrays(np.bool_, st.tuples(st.integers(1, 9), st.integers(1, 9))))
def test_random_masks_give_a_simple_ring_round_their_largest_part(mask):
    if not mask.any():
        assert _seg(mask).rooms == ()
        return
    (room,) = _seg(mask).rooms
    _assert_ring(room.polygon, _filled_area(mask))


@settings(max_examples=100, deadline=None)
@given(
    arrays(np.int32, st.tuples(st.integers(2, 8), st.integers(2, 8)), elements=st.integers(0, 3))
)
def test_every_room_of_random_label_images_gets_a_simple_ring(labels):
    for room in _seg(labels).rooms:
        _assert_ring(room.polygon, _filled_area(labels == room.id))


# --- IPA benchmark maps ---------------------------------------------------------------


@pytest.mark.skipif(not IPA.exists(), reason="shared IPA maps not present")
@pytest.mark.parametrize("name", ["lab_intel", "office_e_furnitures", "Freiburg52_scan"])
def test_every_room_of_ipa_maps_is_a_simple_ring(name):
    occ = tj.load_map(IPA / f"{name}.png", mode="ipa", resolution_m=0.05)
    seg = tj.segment_rooms(occ)
    for room in seg.rooms:
        ring = room.polygon
        assert _problems(ring) == [], f"room {room.id}"
        r0, c0, r1, c1 = room.bbox
        filled = _filled_area(seg.labels[r0 : r1 + 1, c0 : c1 + 1] == room.id)
        area_px = _twice_area(ring) / 2 / 0.05**2
        assert area_px == pytest.approx(filled, abs=PINCH_AREA * len(ring)), f"room {room.id}"


# --- holes ----------------------------------------------------------------------------


def _sides_meet(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether a side of ring ``a`` meets (crosses, touches, overlaps) a side of ring
    ``b``, both (K, 2)."""
    a0, a1 = a[:, None], np.roll(a, -1, axis=0)[:, None]
    b0, b1 = b[None], np.roll(b, -1, axis=0)[None]
    o1, o2 = _orient(a0, a1, b0), _orient(a0, a1, b1)
    o3, o4 = _orient(b0, b1, a0), _orient(b0, b1, a1)
    meet = (o1 * o2 < 0) & (o3 * o4 < 0)
    meet |= (o1 == 0) & _within(a0, a1, b0)
    meet |= (o2 == 0) & _within(a0, a1, b1)
    meet |= (o3 == 0) & _within(b0, b1, a0)
    meet |= (o4 == 0) & _within(b0, b1, a1)
    return bool(meet.any())


def _covered(room, seg) -> np.ndarray:
    """Pixels of ``seg`` whose centre lies inside ``room``'s polygon and outside its
    holes (the even-odd rule on rays along the rows), bool (H, W)."""
    h, w = seg.labels.shape
    crossings = np.zeros((h, w + 1), np.int64)
    for ring in (room.polygon, *room.holes):
        r1, c1 = seg.occupancy.world_to_pixel(ring[:, 0], ring[:, 1])
        r2, c2 = np.roll(r1, -1), np.roll(c1, -1)
        for a, b, p, q in zip(r1, r2, c1, c2, strict=True):
            rows = np.arange(np.ceil(min(a, b)), np.floor(max(a, b)) + 1).astype(int)
            rows = rows[(rows > min(a, b)) & (rows <= max(a, b)) & (rows >= 0) & (rows < h)]
            at = p + (rows - a) * (q - p) / (b - a) if len(rows) else rows
            # the side crosses the rows' rays from pixel centres left of ``at``
            np.add.at(crossings, (rows, np.clip(np.ceil(at), 0, w).astype(int)), 1)
    # crossings right of column j: those whose count index is > j
    right = np.cumsum(crossings[:, ::-1], axis=1)[:, ::-1][:, 1:]
    return right % 2 == 1


def _assert_holes(room, seg, res: float = RES) -> None:
    """The room's holes are simple clockwise rings apart from each other and from its
    outline; outline less holes is the area of its outlined part, and a pixel's centre is
    inside the room's polygon (less holes) exactly where the pixel is in that part."""
    r0, c0, r1, c1 = room.bbox
    part = np.zeros(seg.labels.shape, bool)
    part[r0 : r1 + 1, c0 : c1 + 1] = _largest_part(seg.labels[r0 : r1 + 1, c0 : c1 + 1] == room.id)
    assert isinstance(room.holes, tuple)
    rings = [room.polygon, *room.holes]
    area = _twice_area(room.polygon) / 2
    for hole in room.holes:
        assert hole.dtype == np.float64 and hole.ndim == 2 and hole.shape[1] == 2
        assert _problems(hole) == []
        assert _twice_area(hole) < 0, "holes run clockwise in the map frame"
        area += _twice_area(hole) / 2
    for i in range(len(rings)):
        for j in range(i + 1, len(rings)):
            assert not _sides_meet(rings[i], rings[j]), f"rings {i} and {j} meet"
    n_points = sum(len(r) for r in rings)
    assert area / res**2 == pytest.approx(part.sum(), abs=PINCH_AREA * n_points)
    assert np.array_equal(_covered(room, seg), part)


def test_a_room_round_another_room_has_it_as_a_hole():
    labels = np.ones((5, 5), np.int32)
    labels[1:4, 1:4] = 2
    labels[2, 2] = 0
    seg = _seg(labels)
    one, two = seg.rooms
    (hole,) = one.holes
    (centre,) = two.holes  # the pixel of no room in the middle
    assert -_twice_area(centre) / 2 / RES**2 == 1
    # the hole is the inner room's outline run the other way round
    assert {tuple(p) for p in hole.tolist()} == {tuple(p) for p in two.polygon.tolist()}
    for room in seg.rooms:
        _assert_holes(room, seg)


def test_a_room_round_two_rooms_has_two_holes():
    labels = _mask(["#########", "#..#....#", "#..#....#", "#########"]).astype(np.int32)
    labels[1:3, 1:3] = 2
    labels[1:3, 4:8] = 3
    seg = _seg(labels)
    one = seg.rooms[0]
    assert sorted(round(-_twice_area(h) / 2 / RES**2) for h in one.holes) == [4, 8]
    for room in seg.rooms:
        _assert_holes(room, seg)


#: name: (rows, pixels of each hole)
HOLED = {
    # the hole meets the space outside at one corner (top right of pixel (1, 2))
    "hole touching the outside diagonally": (["###..", "#..#.", "#..#.", "####."], [4]),
    # two holes meeting at a corner
    "holes touching each other": (["#####", "#.###", "##.##", "#####"], [1, 1]),
    "larger holes touching each other": (
        ["######", "#..###", "#.#..#", "###..#", "######"],
        [3, 4],
    ),
    # the room's pixels (2, 2) and (3, 3) meet at a corner inside the hole, which passes
    # round that corner twice
    "hole pinched by the room": (["######", "#....#", "#.#..#", "#..#.#", "######"], [10]),
    "pixels of no room": (["#####", "#.#.#", "#####"], [1, 1]),
}


@pytest.mark.parametrize("name", HOLED)
def test_holes_are_simple_rings_apart_from_each_other_and_the_outline(name):
    rows, sizes = HOLED[name]
    seg = _seg(_mask(rows))
    (room,) = seg.rooms
    got = sorted(round(-_twice_area(h) / 2 / RES**2) for h in room.holes)
    assert got == sizes
    _assert_holes(room, seg)


def test_rooms_without_holes_have_an_empty_tuple():
    for rows, _ in SHAPES.values():
        (room,) = _seg(_mask(rows)).rooms
        assert room.holes == () or all(len(h) >= 4 for h in room.holes)
    (room,) = _seg(_mask(SHAPES["thick L"][0])).rooms
    assert room.holes == ()
    assert "holes" not in repr(room)


def test_a_room_built_without_holes_gets_none():
    from topojax.rooms import Room

    room = Room(1, 1.0, (0.0, 0.0), np.zeros((4, 2)), (0, 0, 1, 1))
    assert room.holes == ()


@settings(max_examples=150, deadline=None)
@given(
    arrays(np.int32, st.tuples(st.integers(2, 9), st.integers(2, 9)), elements=st.integers(0, 3))
)
def test_rooms_of_random_label_images_cover_their_own_pixels_only(labels):
    seg = _seg(labels)
    for room in seg.rooms:
        _assert_holes(room, seg)


@pytest.mark.skipif(not IPA.exists(), reason="shared IPA maps not present")
@pytest.mark.parametrize("name", ["lab_a_scan", "office_d_furnitures"])
def test_rooms_of_ipa_maps_do_not_overlap(name):
    occ = tj.load_map(IPA / f"{name}.png", mode="ipa", resolution_m=0.05)
    seg = tj.segment_rooms(occ)
    assert any(room.holes for room in seg.rooms), "a map with a room round others"
    covered = np.zeros(seg.labels.shape, np.int32)
    for room in seg.rooms:
        _assert_holes(room, seg, 0.05)
        covered += _covered(room, seg)
    assert covered.max() == 1


# --- label points ---------------------------------------------------------------------


def test_the_label_point_of_a_ring_round_a_room_is_on_the_ring_not_in_its_middle():
    labels = np.ones((7, 7), np.int32)
    labels[2:5, 2:5] = 2
    seg = _seg(labels)
    ring = seg.rooms[0]
    assert seg.room_at(ring.centroid) == 2, "the ring's centroid lies in the room it encloses"
    assert seg.room_at(ring.label_point) == 1
    assert seg.room_at(seg.rooms[1].label_point) == 2
    assert seg.rooms[1].label_point == pytest.approx(seg.rooms[1].centroid, abs=0.01 * RES)


def test_the_label_point_of_an_l_shaped_room_is_in_the_l():
    labels = np.full((5, 6), 2, np.int32)
    labels[0, :] = 1
    labels[:, 0] = 1
    seg = _seg(labels)
    corner = seg.rooms[0]
    assert seg.room_at(corner.centroid) == 2
    assert seg.room_at(corner.label_point) == 1


def test_the_label_point_of_a_rectangle_is_its_middle_and_is_kept():
    seg = _seg(np.ones((3, 9), np.int32))
    (room,) = seg.rooms
    assert room.label_point == pytest.approx(room.centroid, abs=0.01 * RES)
    assert room.label_point is room.label_point, "computed once"


def test_a_room_whose_outline_encloses_nothing_is_labelled_at_its_centroid():
    from topojax.rooms import Room

    room = Room(1, 0.0, (2.0, 3.0), np.array([[0.0, 0.0], [1.0, 1.0]]), (0, 0, 0, 0))
    assert room.label_point == (2.0, 3.0)
    hole = np.array([[5.0, 5.0], [6.0, 5.0], [6.0, 6.0]])  # a hole is no outline of its own
    room = Room(1, 0.0, (2.0, 3.0), np.zeros((2, 2)), (0, 0, 0, 0), holes=(hole,))
    assert room.label_point == (2.0, 3.0)


def test_a_room_whose_outline_overflows_in_squares_is_labelled_at_its_centroid():
    # finite coordinates (a rooms file edited or damaged) whose distances overflow
    from topojax.rooms import Room

    ring = np.array([[0.0, 0.0], [1e308, 0.0], [1e308, 1e308], [0.0, 1e308]])
    room = Room(1, 1.0, (2.0, 3.0), ring, (0, 0, 0, 0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warnings either
        assert room.label_point == (2.0, 3.0)


@settings(max_examples=150, deadline=None)
@given(
    arrays(np.int32, st.tuples(st.integers(1, 9), st.integers(1, 9)), elements=st.integers(0, 3))
)
def test_every_label_point_of_random_label_images_lies_in_its_own_room(labels):
    seg = _seg(labels)
    for room in seg.rooms:
        assert seg.room_at(room.label_point) == room.id


def test_every_label_point_of_the_bundled_intel_map_lies_in_its_own_room():
    seg = tj.segment_rooms(tj.sample_map("intel"))
    assert any(seg.room_at(room.centroid) not in (0, room.id) for room in seg.rooms)
    for room in seg.rooms:
        assert seg.room_at(room.label_point) == room.id, f"room {room.id}"
