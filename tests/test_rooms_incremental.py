"""Rooms kept by the incremental mapper: equal to segmenting its current map from
scratch up to the ids, ids stable where nothing changed, rates, saved state."""

from __future__ import annotations

import numpy as np
import pytest
from floorplans import RES, floor_plan

import topojax as tj
from topojax.incremental import ExportBudgetError
from topojax.maps.occupancy import OccupancyMap


def _part(occ: OccupancyMap, cols: slice) -> OccupancyMap:
    """The map with everything outside columns ``cols`` unknown."""
    keep = np.zeros(occ.free.shape, bool)
    keep[:, cols] = True
    return OccupancyMap(
        occupied=occ.occupied & keep,
        free=occ.free & keep,
        unknown=occ.unknown | ~keep,
        resolution_m=occ.resolution_m,
        origin=occ.origin,
    )


def _same_up_to_ids(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two label images are equal up to a one-to-one renaming of positive ids."""
    if a.shape != b.shape or not np.array_equal(a > 0, b > 0):
        return False
    pairs = np.unique(np.stack([a[a > 0], b[b > 0]], axis=1), axis=0)
    return len(np.unique(pairs[:, 0])) == len(pairs) == len(np.unique(pairs[:, 1]))


@pytest.fixture(scope="module")
def plan():
    return floor_plan(4)


def _mapper(**kw) -> tj.IncrementalMapper:
    """A mapper whose room updates segment the whole map (exactly as from scratch)."""
    kw.setdefault("rooms_local", False)
    return tj.IncrementalMapper(resolution_m=RES, graph_every=None, skeleton_every=None, **kw)


def test_mapper_rooms_equal_segmenting_its_map_from_scratch(plan):
    mapper = _mapper()
    mapper.add_map(plan.occupancy)
    seg = mapper.rooms
    scratch = tj.segment_rooms(mapper.occupancy)
    assert _same_up_to_ids(seg.labels, scratch.labels)
    assert seg.n_rooms == scratch.n_rooms == plan.n_rooms
    assert sorted(r.area_m2 for r in seg.rooms) == pytest.approx(
        sorted(r.area_m2 for r in scratch.rooms)
    )


def test_rooms_away_from_new_mapping_keep_their_ids_and_pixels(plan):
    occ = plan.occupancy
    w = occ.free.shape[1]
    mapper = _mapper()
    mapper.add_map(_part(occ, slice(0, w // 2)))
    first = mapper.update_rooms()
    assert first.added and not first.removed and not first.changed
    before = mapper.rooms
    box0 = mapper.pixel_bbox
    mapper.add_map(occ)
    update = mapper.update_rooms()
    after = mapper.rooms
    box1 = mapper.pixel_bbox
    assert _same_up_to_ids(after.labels, tj.segment_rooms(mapper.occupancy).labels)
    kept = set(r.id for r in before.rooms) - set(update.removed) - set(update.changed)
    assert kept, "rooms far from the newly mapped half stay as they were"
    for rid in kept:
        rr, cc = np.nonzero(before.labels == rid)
        r2, c2 = np.nonzero(after.labels == rid)
        np.testing.assert_array_equal(rr + box0[0], r2 + box1[0])
        np.testing.assert_array_equal(cc + box0[1], c2 + box1[1])
    new_ids = {r.id for r in after.rooms}
    assert set(update.added) == new_ids - {r.id for r in before.rooms}
    assert min(update.added) > max(r.id for r in before.rooms), "ids are never reused"
    assert update.n_rooms == after.n_rooms


def test_an_update_with_nothing_new_changes_nothing(plan):
    mapper = _mapper()
    mapper.add_map(plan.occupancy)
    ids = [r.id for r in mapper.rooms.rooms]
    again = mapper.update_rooms()
    assert (again.added, again.removed, again.changed) == ((), (), ())
    assert (again.doors_added, again.doors_removed) == ((), ())
    assert [r.id for r in mapper.rooms.rooms] == ids


def test_a_room_update_is_a_public_rooms_update(plan):
    """The report the rooms page names is importable from ``topojax``, as GraphUpdate and
    ScanReport are, and is what ``update_rooms`` returns."""
    assert "RoomsUpdate" in tj.__all__
    mapper = _mapper()
    mapper.add_map(plan.occupancy)
    update = mapper.update_rooms()
    assert isinstance(update, tj.RoomsUpdate)
    assert update.n_rooms == plan.n_rooms


def test_rooms_follow_the_graph_loop_once_in_use(plan):
    occ = plan.occupancy
    scans = []
    mapper = tj.IncrementalMapper(resolution_m=RES, graph_every=1, skeleton_every=None)
    mapper.add_map(_part(occ, slice(0, 200)))
    points = np.argwhere(occ.occupied)[:50]
    x, y = occ.pixel_to_world(points[:, 0], points[:, 1])
    report = mapper.add_points(np.stack([x, y], axis=1))
    assert "graph" in report.loops and "rooms" not in report.loops  # rooms not in use yet
    _ = mapper.rooms
    report = mapper.add_points(np.stack([x, y], axis=1))
    scans.append(report)
    assert "rooms" in report.loops and report.rooms_update is not None
    explicit = tj.IncrementalMapper(resolution_m=RES, rooms_every=0, graph_every=1)
    explicit.add_map(occ)
    _ = explicit.rooms
    report = explicit.add_points(np.stack([x, y], axis=1))
    assert "rooms" not in report.loops


def test_an_explicit_graph_update_brings_the_rooms_in_use(plan):
    """``rooms_every=None``: rooms follow every graph update, an explicit
    ``update_graph`` too (after ``add_map``, which runs no loop), in the frame of the
    updated map; ``rooms_every=0`` leaves them to explicit calls."""
    occ = plan.occupancy
    w = occ.free.shape[1]
    mapper = _mapper()
    mapper.add_map(_part(occ, slice(0, w // 2)))
    before = mapper.rooms
    mapper.add_map(occ)
    mapper.update_graph()
    after = mapper.rooms
    assert after is not before
    assert _same_up_to_ids(after.labels, tj.segment_rooms(mapper.occupancy).labels)
    tj.assign_rooms(mapper.graph, after)  # the graph's frame
    explicit = _mapper(rooms_every=0)
    explicit.add_map(_part(occ, slice(0, w // 2)))
    kept = explicit.rooms
    explicit.add_map(occ)
    explicit.update_graph()
    assert explicit.rooms is kept


def test_rooms_read_before_the_first_scan_are_kept_from_then_on(plan):
    """Reading rooms at start-up, before any scan, says the mapper is empty and puts
    rooms in use: the first graph update after scans brings them."""
    occ = plan.occupancy
    mapper = tj.IncrementalMapper(resolution_m=RES, graph_every=1, skeleton_every=None)
    words = "rooms: the mapper is empty; .* first scan with valid readings, or map with a"
    with pytest.raises(ValueError, match=words):
        _ = mapper.rooms
    unknown = np.zeros(occ.shape, bool)  # a map of unknown pixels only adds nothing
    mapper.add_map(tj.OccupancyMap(unknown, unknown, ~unknown, resolution_m=RES))
    with pytest.raises(ValueError, match=words):
        _ = mapper.rooms
    mapper.add_map(_part(occ, slice(0, 200)))
    points = np.argwhere(occ.occupied)[:50]
    x, y = occ.pixel_to_world(points[:, 0], points[:, 1])
    report = mapper.add_points(np.stack([x, y], axis=1))
    assert "rooms" in report.loops and mapper.rooms.n_rooms > 0


def test_rooms_survive_save_and_load(plan, tmp_path):
    mapper = _mapper(room_config=tj.RoomConfig(min_room_m2=3.0))
    mapper.add_map(plan.occupancy)
    ids = {r.id: r.area_m2 for r in mapper.rooms.rooms}
    path = mapper.save(tmp_path / "state.npz")
    loaded = tj.IncrementalMapper.load(path)
    assert loaded.room_config == tj.RoomConfig(min_room_m2=3.0)
    assert {r.id: r.area_m2 for r in loaded.rooms.rooms} == ids
    np.testing.assert_array_equal(loaded.rooms.labels, mapper.rooms.labels)


def test_bad_room_settings_are_refused():
    with pytest.raises(ValueError, match="rooms_every"):
        tj.IncrementalMapper(rooms_every=-1)
    with pytest.raises(TypeError, match="room_config"):
        tj.IncrementalMapper(room_config={"min_room_m2": 1.0})


def test_replay_keeps_rooms_and_writes_them(tmp_path):
    from pathlib import Path

    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    summary = tj.replay(
        log,
        out_dir=tmp_path,
        progress=False,
        graph_every=10,
        skeleton_every=None,
        rooms=True,
        animate=tmp_path / "rooms.gif",
    )
    assert summary["rooms"] >= 1
    assert "rooms" in summary["timings"]
    for name in ("map_rooms.geojson", "map_rooms.png", "map_rooms.graphml", "rooms.gif"):
        assert (tmp_path / name).stat().st_size > 0
    rooms, doors = tj.load_rooms(tmp_path / "map_rooms.geojson")
    assert (len(rooms), len(doors)) == (summary["rooms"], summary["doors"])
    graph = tj.load_graph(tmp_path / "graph.graphml")
    ids = {r.id for r in rooms} | {0}
    assert all(d["room"] in ids for _, d in graph.nodes(data=True))


def test_a_room_update_the_map_outgrew_warns_at_the_caller_s_line():
    """The warning that rooms stay as they were (map past ``max_export_bytes``) names the
    user's line, through add_scan, add_scans or update_graph alike."""
    import warnings

    from topojax.scans import Scan

    def scan():
        return Scan.from_arrays(np.full(90, 3.0), (0, 0, 0), angle_min=0, angle_increment=0.07)

    for call in ("add_scan", "add_scans", "update_graph"):
        mapper = tj.IncrementalMapper(rooms_every=1, max_export_bytes=2000, graph_every=0)
        if call == "update_graph":  # rooms in use, following each graph update
            mapper = tj.IncrementalMapper(max_export_bytes=2000, graph_every=0)
            mapper.add_scan(scan())
            with pytest.raises(ExportBudgetError):
                mapper.update_rooms()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if call == "add_scan":
                mapper.add_scan(scan())
            elif call == "add_scans":
                mapper.add_scans([scan()])
            else:
                mapper.update_graph()
        rooms = [w for w in caught if "rooms not updated" in str(w.message)]
        assert rooms and rooms[0].filename == __file__, (call, [w.filename for w in rooms])
