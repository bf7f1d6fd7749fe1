"""The incremental mapper's guard rails for a robot's bad moments: wrong input types
and hand-edited or corrupted saved states."""

from __future__ import annotations

import numpy as np
import pytest

from topojax.incremental import IncrementalMapper

KW = {"skeleton_every": 0, "graph_every": 0}
EXPECTED = r"^points_xy: expected an \(N, 2\) array of \(x, y\) in metres"


@pytest.mark.parametrize(
    ("points", "received"),
    [
        ([["a", "b"], ["c", "d"]], "list of dtype <U1"),
        ({"x": 1.0, "y": 2.0}, "dict of dtype object"),
        (None, "NoneType of dtype object"),  # NumPy would take it as NaN: a dropped point
        (np.array([[1.0 + 2.0j, 0.0]]), "ndarray of dtype complex128"),  # or the real part
        ([[1.0, None]], "list of dtype object"),
        (b"12", "bytes of dtype"),
        (np.ones((2, 2), bool), "ndarray of dtype bool .a mask\\? for a finished map use add_map"),
        ([[1.0, 2.0], [3.0]], "list that makes no array .rows of different lengths"),
    ],
)
def test_add_points_of_the_wrong_type_is_a_type_error(points, received):
    mapper = IncrementalMapper(**KW)
    with pytest.raises(TypeError, match=EXPECTED + ".*received " + received):
        mapper.add_points(points)
    assert mapper.n_scans == 0 and mapper.n_tiles == 0


@pytest.mark.parametrize(
    ("points", "shape"),
    [(np.ones((4, 3)), r"\(4, 3\)"), (np.ones(4), r"\(4,\)"), (np.ones((1, 2, 2)), r"\(1, 2, 2\)")],
)
def test_add_points_of_another_shape_is_a_value_error(points, shape):
    mapper = IncrementalMapper(**KW)
    with pytest.raises(ValueError, match=EXPECTED + ", received ndarray of shape " + shape):
        mapper.add_points(points)
    assert mapper.n_scans == 0


def test_add_points_of_an_empty_list_is_a_frame_without_points():
    """A depth camera that saw nothing gives ``[]``: a scan without valid readings, as
    ``np.zeros((0, 2))`` is, not an error that stops the robot's callback."""
    mapper = IncrementalMapper(**KW)
    report = mapper.add_points([], origin_xy=(0.0, 0.0))
    assert (report.n_beams, report.n_valid, mapper.n_scans, mapper.n_tiles) == (0, 0, 1, 0)


# --------------------------------------------------------------------------------------
# hand-edited or corrupted saved states
# --------------------------------------------------------------------------------------

HUGE = 10**15


def test_add_scans_names_the_item_that_is_no_scan_and_what_was_added():
    from topojax.scans import Scan

    scan = Scan.from_arrays([1.0, 2.0], (0, 0, 0), angle_min=0.0, angle_increment=0.1)
    mapper = IncrementalMapper(**KW)
    with pytest.raises(
        TypeError,
        match=r"^scans\[2\]: expected a topojax.Scan .*received str.* 2 scan.s. before it were added",
    ):
        mapper.add_scans(iter([scan, scan, "scan.log", scan]))
    assert mapper.n_scans == 2


@pytest.fixture(scope="module")
def saved_state(tmp_path_factory):
    """The arrays of a small mapper's state, mid-run: pending splats and skeleton changes
    not yet in the graph, rooms in use."""
    mapper = IncrementalMapper(**KW)
    origin = (0.5, 0.5)
    mapper.add_points([[0.0, 0.0], [1.0, 0.5], [2.0, 2.0], [3.0, 0.0]], origin_xy=origin)
    mapper.update_rooms()
    mapper.add_points([[1.0, 3.5], [-1.0, 2.0]], origin_xy=origin)
    mapper.update_skeleton()
    mapper.add_points([[0.25, -1.0]], origin_xy=origin)
    path = mapper.save(tmp_path_factory.mktemp("state") / "state.npz")
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def _edited(tmp_path, data, key, index, value):
    arrays = {k: v.copy() for k, v in data.items()}
    arrays[key][index] = value
    path = tmp_path / "edited.npz"
    np.savez_compressed(path, **arrays)
    return path


def test_the_state_used_for_edits_loads_and_keeps_its_parts(saved_state, tmp_path):
    assert saved_state["pending"].shape[0] and saved_state["skel_changed"].shape[0]
    assert saved_state["v_id"].size and "rooms_labels" in saved_state
    mapper = IncrementalMapper.load(_edited(tmp_path, saved_state, "version", (), 2))
    assert mapper.n_scans == 3


@pytest.mark.parametrize(
    ("key", "index", "field"),
    [
        ("counters", 0, r"counters \(n_scans\): expected an integer from 0 to 1000000000000 "),
        ("counters", 3, r"counters \(next_vertex\): expected an integer from 0 to 2147483647"),
        ("counters", 4, r"counters \(next_edge\): expected an integer from 0 to 2147483647"),
        ("counters", 1, r"counters \(since_skeleton\): expected an integer from 0 to 3 "),
        ("counters", 5, r"counters \(n_ridge\): expected an integer from 0 to \d+ .ridge"),
        ("rooms_counters", 0, r"rooms_counters \(next_room_id\): expected an integer from 1"),
        ("rooms_counters", 2, r"rooms_counters \(since_rooms\): expected an integer from 0 to 3"),
        ("pending", (0, 0), r"pending: expected \(row, col\) pixels on the state's tiles"),
        ("skel_changed", (0, 1), r"skel_changed: expected \(row, col\) pixels on the state's"),
        ("v_pixel", (0, 0), r"v_pixel: expected \(row, col\) pixels on the state's tiles"),
        ("e_path", (0, 1), r"e_path: expected \(row, col\) pixels on the state's tiles"),
        ("ridge_bbox", 2, r"ridge_bbox: expected a box within the tiles' pixel box"),
        ("tiles/bbox", 3, r"tile state: bbox \(.*\) is not the box of the tile keys"),
    ],
)
def test_a_huge_number_in_a_state_is_refused_naming_file_and_field(
    saved_state, tmp_path, key, index, field
):
    """A counter of 10**15 made tables of 10**15 ids (MemoryError); a pixel or box that far
    off loaded, and failed at a later update (or, for a vertex, stayed in the graph)."""
    path = _edited(tmp_path, saved_state, key, index, HUGE)
    with pytest.raises(ValueError, match=f"^{path}: corrupt or inconsistent mapper state: {field}"):
        IncrementalMapper.load(path)
    path = _edited(tmp_path, saved_state, key, index, -1 if key.endswith("counters") else 5000)
    with pytest.raises(ValueError, match=f"^{path}: corrupt .*: {field.split(':')[0]}"):
        IncrementalMapper.load(path)


@pytest.mark.parametrize("key", ["settings", "counters", "pending", "v_id", "e_path"])
def test_a_state_without_a_field_is_refused_naming_the_missing_field(saved_state, tmp_path, key):
    """The message was the bare key (``...mapper state: 'v_id'``), saying neither that a
    field was missing nor that it was a field."""
    arrays = {k: v for k, v in saved_state.items() if k != key}
    path = tmp_path / "cut.npz"
    np.savez_compressed(path, **arrays)
    with pytest.raises(ValueError, match=f"^{path}: corrupt .*: no field '{key}' .expected the "):
        IncrementalMapper.load(path)


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ("1", r"settings: expected a JSON object, received '1'"),  # was an AttributeError
        ('{"resolution_m": 0.05}', r"settings: expected the key 'config' in the saved"),
        ("{not json", r"settings: expected a JSON object, received '\{not json' \(Expecting"),
    ],
)
def test_a_state_whose_settings_are_damaged_is_refused_naming_them(
    saved_state, tmp_path, settings, message
):
    arrays = dict(saved_state, settings=np.array(settings))
    path = tmp_path / "settings.npz"
    np.savez_compressed(path, **arrays)
    with pytest.raises(
        ValueError, match=f"^{path}: corrupt or inconsistent mapper state: {message}"
    ):
        IncrementalMapper.load(path)


@pytest.mark.parametrize(
    ("key", "edit", "field"),
    [
        ("v_pixel", lambda a: a[:-1], r"v_pixel: expected one \(row, col\) per vertex id"),
        ("v_kind", lambda a: a[:-1], r"v_kind: expected one kind code per vertex id"),
        ("v_kind", lambda a: np.full_like(a, 99), r"v_kind: expected kind codes among"),
        ("e_uv", lambda a: a[:-1], r"e_uv: expected one \(u, v\) per edge id"),
        ("e_uv", lambda a: np.full_like(a, HUGE), r"e_uv: expected the ids of stored vertices"),
        ("e_uv", lambda a: np.full_like(a, -1), r"e_uv: expected the ids of stored vertices"),
        ("e_len", lambda a: a[:-1], r"e_len: expected one path length per edge id"),
        ("e_len", lambda a: a * 0, r"e_len: expected path lengths >= 1"),
        ("e_len", lambda a: a * 2, r"e_len: expected lengths adding up to the \d+ pixels"),
        ("v_id", lambda a: np.append(a[:-1], a[0]), r"v_id: expected distinct ids, received"),
        ("e_id", lambda a: np.append(a[:-1], a[0]), r"e_id: expected distinct ids, received"),
    ],
)
def test_a_state_whose_graph_tables_do_not_hold_together_is_refused_naming_the_field(
    saved_state, tmp_path, key, edit, field
):
    """An edge end off the vertex table raised a bare IndexError message (``index ... is
    out of bounds for axis 0``), and tables of different lengths NumPy's broadcasting
    error: neither named the field.  An edge id stored twice loaded, one edge's ends
    written over the other's."""
    assert saved_state["e_id"].size
    arrays = dict(saved_state, **{key: edit(saved_state[key])})
    path = tmp_path / "graph.npz"
    np.savez_compressed(path, **arrays)
    with pytest.raises(ValueError, match=f"^{path}: corrupt or inconsistent mapper state: {field}"):
        IncrementalMapper.load(path)


def test_id_tables_beyond_the_memory_available_are_refused(saved_state, tmp_path, monkeypatch):
    import topojax.incremental._state_checks as checks

    monkeypatch.setattr(checks, "available_memory_bytes", lambda: 10**6)
    path = _edited(tmp_path, saved_state, "counters", 4, 10**6)
    with pytest.raises(
        ValueError, match=r"counters \(next_edge\): 1000000 edge ids take .* more than the"
    ):
        IncrementalMapper.load(path)


@pytest.fixture(scope="module")
def rooms_state(tmp_path_factory):
    """The arrays of a state saved with rooms and doors kept, its map grown since."""
    from floorplans import RES, floor_plan

    plan = floor_plan(9, size_m=(16.0, 24.0))
    mapper = IncrementalMapper(resolution_m=RES, **KW)
    mapper.add_map(plan.occupancy)
    mapper.update_rooms()
    mapper.add_points([[40.0, 1.0]])
    assert mapper.rooms.labels.shape != mapper.occupancy.shape
    path = mapper.save(tmp_path_factory.mktemp("rooms") / "state.npz")
    with np.load(path) as z:
        return {k: z[k] for k in z.files}, mapper.rooms


def test_a_state_keeps_the_rooms_last_segmentation(rooms_state, tmp_path):
    """The rooms a loaded mapper returns are those it had when saved, not segmented
    again from its map (which has grown since)."""
    data, rooms = rooms_state
    assert len(rooms.rooms) > 1 and rooms.doors
    mapper = IncrementalMapper.load(_edited(tmp_path, data, "version", (), 2))
    np.testing.assert_array_equal(mapper.rooms.labels, rooms.labels)
    assert [(r.id, r.area_m2, r.bbox) for r in mapper.rooms.rooms] == [
        (r.id, r.area_m2, r.bbox) for r in rooms.rooms
    ]
    for a, b in zip(mapper.rooms.rooms, rooms.rooms, strict=True):
        np.testing.assert_array_equal(a.polygon, b.polygon)
    assert [(d.rooms, d.width_m) for d in mapper.rooms.doors] == [
        (d.rooms, d.width_m) for d in rooms.doors
    ]


@pytest.mark.parametrize(
    ("key", "edit", "field"),
    [
        ("rooms_seg/free", lambda a: a[:-1], r"rooms_seg/free: expected \d+ bytes"),
        ("rooms_seg/unknown", lambda a: a[:0], r"rooms_seg/unknown: expected \d+ bytes"),
        ("rooms_seg/room_polygon_len", lambda a: a + HUGE, r"rooms_seg/room_polygon: the len"),
        ("rooms_seg/room_polygon_len", lambda a: -a, r"rooms_seg/room_polygon: the len"),
        ("rooms_seg/room_area_m2", lambda a: a[1:], r"rooms_seg/room_\*: the rooms' fields"),
        ("rooms_seg/door_id", lambda a: np.append(a, 7), r"rooms_seg/door_\*: the doors' fie"),
    ],
)
def test_a_state_whose_rooms_do_not_hold_together_is_refused_naming_the_field(
    rooms_state, tmp_path, key, edit, field
):
    arrays = {k: v.copy() for k, v in rooms_state[0].items()}
    arrays[key] = edit(arrays[key])
    path = tmp_path / "edited.npz"
    np.savez_compressed(path, **arrays)
    with pytest.raises(ValueError, match=f"^{path}: corrupt or inconsistent mapper state: {field}"):
        IncrementalMapper.load(path)
