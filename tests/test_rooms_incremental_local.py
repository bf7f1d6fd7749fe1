"""Local room updates (``IncrementalMapper(rooms_local=True)``): only windows around the
changed free space are segmented again; rooms the changes do not reach keep their ids,
pixels and doors; the update reports what changed; saved state carries on."""

from __future__ import annotations

from collections import Counter

import cv2
import numpy as np
import pytest
from floorplans import RES, floor_plan

import topojax as tj
from topojax.maps.occupancy import OccupancyMap

#: Rooms whose pixels are all farther than this from every changed pixel must keep
#: their id, pixels and doors (metres).
FAR_M = 5.0


def _same_up_to_ids(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two label images are equal up to a one-to-one renaming of positive ids."""
    if a.shape != b.shape or not np.array_equal(a > 0, b > 0):
        return False
    pairs = np.unique(np.stack([a[a > 0], b[b > 0]], axis=1), axis=0)
    return len(np.unique(pairs[:, 0])) == len(pairs) == len(np.unique(pairs[:, 1]))


def _assert_same_geometry(a, b) -> None:
    """Each room of segmentation ``a`` has the outline and holes of the room of ``b`` on
    the same pixels (label images over the same map)."""
    by_pixel = {}
    for room in b.rooms:
        r, c = np.argwhere(b.labels == room.id)[0]
        by_pixel[(int(r), int(c))] = room
    for room in a.rooms:
        r, c = np.argwhere(a.labels == room.id)[0]
        other = by_pixel[(int(r), int(c))]
        np.testing.assert_allclose(room.polygon, other.polygon, rtol=0, atol=1e-9)
        assert len(room.holes) == len(other.holes)
        for g, w in zip(room.holes, other.holes, strict=True):
            np.testing.assert_allclose(g, w, rtol=0, atol=1e-9)


def _mapper(**kw) -> tj.IncrementalMapper:
    return tj.IncrementalMapper(resolution_m=RES, graph_every=None, skeleton_every=None, **kw)


def _shown(plan, rooms) -> OccupancyMap:
    """The plan with only the rooms ``rooms`` (ground-truth ids) and their walls known."""
    inside = np.isin(plan.rooms, list(rooms)).astype(np.uint8)
    keep = cv2.dilate(inside, np.ones((9, 9), np.uint8)).astype(bool)
    occ = plan.occupancy
    return OccupancyMap(
        occupied=occ.occupied & keep,
        free=occ.free & keep,
        unknown=occ.unknown | ~keep,
        resolution_m=occ.resolution_m,
        origin=occ.origin,
    )


def _exploration_order(plan) -> list[int]:
    """The plan's rooms in the order a robot walking through the doors meets them."""
    nbrs: dict[int, set] = {}
    for a, b, _ in plan.doors:
        nbrs.setdefault(a, set()).add(b)
        nbrs.setdefault(b, set()).add(a)
    order, todo = [], [1]
    while todo:
        r = todo.pop(0)
        if r not in order:
            order.append(r)
            todo += sorted(nbrs.get(r, ()))
    return order


def _on(array: np.ndarray, box, union) -> np.ndarray:
    """``array`` (over global pixel box ``box``) placed in a zero array over ``union``."""
    out = np.zeros((union[2] - union[0], union[3] - union[1]), array.dtype)
    r0, c0 = box[0] - union[0], box[1] - union[1]
    out[r0 : r0 + array.shape[0], c0 : c0 + array.shape[1]] = array
    return out


def _union(a, b) -> tuple:
    return (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))


def _same_pixels(seg0, box0, seg1, box1, rid) -> bool:
    """Whether room ``rid`` covers the same global pixels in both segmentations."""
    u = _union(box0, box1)
    return np.array_equal(_on(seg0.labels == rid, box0, u), _on(seg1.labels == rid, box1, u))


def _door_keys(seg, box) -> list:
    return [
        (d.rooms, tuple((d.ends_px + np.array([box[0], box[1]])).ravel().tolist()))
        for d in seg.doors
    ]


def _check_report(before, box0, after, box1, update) -> None:
    """The update names exactly the rooms and doors that differ between ``before`` and
    ``after`` (each over its global pixel box)."""
    old = {r.id for r in before.rooms}
    new = {r.id for r in after.rooms}
    assert set(update.added) == new - old
    assert set(update.removed) == old - new
    for rid in old & new:
        moved = not _same_pixels(before, box0, after, box1, rid)
        assert (rid in update.changed) == moved, rid
    k0, k1 = Counter(_door_keys(before, box0)), Counter(_door_keys(after, box1))
    assert Counter(update.doors_added) == Counter(k[0] for k in (k1 - k0).elements())
    assert Counter(update.doors_removed) == Counter(k[0] for k in (k0 - k1).elements())
    assert update.n_rooms == after.n_rooms


def _far_rooms(labels: np.ndarray, changed: np.ndarray, far_px: float) -> list[int]:
    """Rooms of ``labels`` whose pixels all lie farther than ``far_px`` from every pixel
    of ``changed`` (bool, same shape)."""
    dist = cv2.distanceTransform((~changed).view(np.uint8), cv2.DIST_L2, 5)
    low = np.full(int(labels.max()) + 1, np.inf)
    np.minimum.at(low, labels.ravel(), dist.ravel())
    return [int(i) for i in np.flatnonzero(np.isfinite(low) & (low > far_px)) if i > 0]


def test_rooms_found_room_by_room_keep_everything_away_from_the_new_room():
    plan = floor_plan(5, size_m=(16.0, 48.0))
    mapper = _mapper(rooms_local=True)
    shown, n_local = [], 0
    before = box0 = free0 = None
    for room in _exploration_order(plan):
        shown.append(room)
        mapper.add_map(_shown(plan, shown))
        free1 = mapper.occupancy.free
        update = mapper.update_rooms()
        after, box1 = mapper.rooms, mapper.pixel_bbox
        if before is not None:
            _check_report(before, box0, after, box1, update)
            assert update.added, "the newly explored room appears as a new room"
            if update.segmented_px < after.labels.size:  # a local update
                n_local += 1
                changed = _on(free0, box0, box1) != free1
                far = _far_rooms(_on(before.labels, box0, box1), changed, FAR_M / RES)
                for rid in far:
                    assert rid in {r.id for r in after.rooms}
                    assert _same_pixels(before, box0, after, box1, rid)
                doors = [k for k in _door_keys(before, box0) if set(k[0]) <= set(far)]
                assert Counter(doors) <= Counter(_door_keys(after, box1))
        before, box0, free0 = after, box1, free1
    assert n_local >= 3, "later updates segment only a window"
    scratch = tj.segment_rooms(mapper.occupancy)
    assert mapper.rooms.n_rooms == scratch.n_rooms == plan.n_rooms
    assert len(mapper.rooms.doors) == len(scratch.doors)
    a, b = mapper.rooms.labels, scratch.labels
    assert np.count_nonzero((a > 0) != (b > 0)) < 1e-3 * np.count_nonzero(b)


def _split_wall(plan) -> tuple[np.ndarray, int]:
    """A wall across the middle of the plan's largest room, with a 0.9 m doorway in its
    middle, as an obstacle mask; and that room's ground-truth id."""
    ids, area = np.unique(plan.rooms[plan.rooms > 0], return_counts=True)
    rid = int(ids[np.argmax(area)])
    rr, cc = np.nonzero(plan.rooms == rid)
    r0, r1, c0, c1 = rr.min(), rr.max() + 1, cc.min(), cc.max() + 1
    wall = np.zeros(plan.rooms.shape, bool)
    gap = int(round(0.9 / RES))
    if c1 - c0 >= r1 - r0:  # split the longer side
        mid, centre = (c0 + c1) // 2, (r0 + r1) // 2
        wall[r0:r1, mid : mid + 3] = True
        wall[centre - gap // 2 : centre - gap // 2 + gap, mid : mid + 3] = False
    else:
        mid, centre = (r0 + r1) // 2, (c0 + c1) // 2
        wall[mid : mid + 3, c0:c1] = True
        wall[mid : mid + 3, centre - gap // 2 : centre - gap // 2 + gap] = False
    return wall, rid


def _obstacles(plan, mask: np.ndarray) -> OccupancyMap:
    """A map of the plan's frame whose only known pixels are obstacles at ``mask``."""
    return _obstacles_of(plan.occupancy, mask)


def test_local_and_whole_agree_when_the_change_stays_in_one_room():
    plan = floor_plan(2, size_m=(16.0, 48.0))
    wall, _ = _split_wall(plan)
    occ, extra = plan.occupancy, _obstacles(plan, wall)
    local, whole = _mapper(rooms_local=True), _mapper(rooms_local=False)
    for m in (local, whole):
        m.add_map(occ)
        _ = m.rooms
    before = local.rooms
    for m in (local, whole):
        m.add_map(extra)
    update = local.update_rooms()
    whole.update_rooms()
    after = local.rooms
    assert update.segmented_px < after.labels.size, "only a window was segmented"
    assert _same_up_to_ids(after.labels, whole.rooms.labels)
    _assert_same_geometry(after, whole.rooms)
    assert after.n_rooms == before.n_rooms + 1 == whole.rooms.n_rooms
    assert len(after.doors) == len(before.doors) + 1 == len(whole.rooms.doors)
    # the split room: one id goes or changes, one or two come; every other room stays
    assert len(update.removed) + len(update.changed) == 1
    assert len(update.added) == 1 + len(update.removed)
    new_pair = tuple(sorted(update.added + update.changed))
    assert update.doors_added == (new_pair,) and not update.doors_removed
    box = local.pixel_bbox
    for room in before.rooms:
        if room.id not in update.removed + update.changed:
            assert _same_pixels(before, box, after, box, room.id)


def test_unknown_space_turned_occupied_is_a_change_a_local_update_sees():
    """A room round a large unexplored block leaves the block out; once the block is seen
    to be solid (unknown turned occupied: no free pixel changed) the room owns it, in a
    local update as from scratch."""
    from topojax.incremental._rooms import RoomKeeper

    free = np.zeros((160, 1000), bool)
    free[2:158, 2:158] = True
    free[22:138, 22:138] = False  # a corridor ring round a block
    free[2:158, 200:998] = True  # a hall of its own
    unknown = np.zeros_like(free)
    unknown[24:136, 24:136] = True  # 31 m² never seen
    keeper, box, cfg = RoomKeeper(), (0, 0, *free.shape), tj.RoomConfig()

    def seen(free, unknown):
        return OccupancyMap(occupied=~free & ~unknown, free=free, unknown=unknown, resolution_m=RES)

    keeper.update(seen(free, unknown), box, cfg, local=True)
    assert keeper.seg.labels[80, 80] == 0
    unknown[:] = False  # the block is solid
    free[100:110, 300:310] = False  # and a box stands in the other room
    update = keeper.update(seen(free, unknown), box, cfg, local=True)
    fresh = tj.segment_rooms(seen(free, unknown), config=cfg)
    assert update.segmented_px < free.size, "only windows were segmented"
    assert fresh.labels[80, 80] > 0
    assert _same_up_to_ids(keeper.seg.labels, fresh.labels)


def test_local_rooms_carry_on_after_save_and_load(tmp_path):
    plan = floor_plan(2, size_m=(16.0, 48.0))
    wall, _ = _split_wall(plan)
    mapper = _mapper(rooms_local=True)
    mapper.add_map(plan.occupancy)
    ids = [r.id for r in mapper.rooms.rooms]
    loaded = tj.IncrementalMapper.load(mapper.save(tmp_path / "state.npz"))
    assert loaded.rooms_local is True
    assert [r.id for r in loaded.rooms.rooms] == ids
    for m in (mapper, loaded):
        m.add_map(_obstacles(plan, wall))
    a, b = mapper.update_rooms(), loaded.update_rooms()
    assert b.segmented_px < loaded.rooms.labels.size, "the loaded mapper updates locally"
    assert (a.added, a.removed, a.changed) == (b.added, b.removed, b.changed)
    assert (a.doors_added, a.doors_removed) == (b.doors_added, b.doors_removed)
    np.testing.assert_array_equal(loaded.rooms.labels, mapper.rooms.labels)


def test_a_state_saved_between_room_updates_carries_on_as_if_never_saved(tmp_path):
    """Saved after the map changed and before the next room update, the loaded mapper
    updates locally from the rooms it kept, as the saved one does: the same labels,
    rooms and doors (a whole segmentation in their place differs by some pixels)."""
    plan = floor_plan(5, size_m=(16.0, 48.0))
    order = _exploration_order(plan)
    assert len(order) == 19

    def explored(save: bool):
        mapper = _mapper(rooms_local=True)
        for j in range(17, len(order) + 1):
            mapper.add_map(_shown(plan, order[:j]))
            if save and j == 18:
                mapper = tj.IncrementalMapper.load(mapper.save(tmp_path / "state.npz"))
            mapper.update_rooms()
        return mapper.rooms

    kept, loaded = explored(False), explored(True)
    np.testing.assert_array_equal(loaded.labels, kept.labels)
    assert [(r.id, r.area_m2, r.bbox) for r in loaded.rooms] == [
        (r.id, r.area_m2, r.bbox) for r in kept.rooms
    ]
    _assert_same_geometry(loaded, kept)
    assert [(d.rooms, d.ends_px.tolist()) for d in loaded.doors] == [
        (d.rooms, d.ends_px.tolist()) for d in kept.doors
    ]


def test_room_updates_are_local_by_default():
    assert tj.IncrementalMapper().rooms_local is True


def test_rooms_local_must_be_a_bool():
    with pytest.raises(TypeError, match="rooms_local"):
        tj.IncrementalMapper(rooms_local="yes")


def _two_buildings(gap_px: int) -> tuple[OccupancyMap, OccupancyMap]:
    """A small building without clutter and, ``gap_px`` pixels to its right, a larger one
    with clutter: the map of the first alone, and of both (same frame)."""
    a = floor_plan(109, size_m=(8.0, 8.0)).occupancy
    b = floor_plan(9, size_m=(12.0, 16.0), clutter=3).occupancy
    c = a.shape[1] + gap_px
    shape = (max(a.shape[0], b.shape[0]), c + b.shape[1])
    maps = []
    for parts in ([(a, 0)], [(a, 0), (b, c)]):
        occupied, free = np.zeros(shape, bool), np.zeros(shape, bool)
        for m, c0 in parts:
            occupied[: m.shape[0], c0 : c0 + m.shape[1]] = m.occupied
            free[: m.shape[0], c0 : c0 + m.shape[1]] = m.free
        maps.append(
            OccupancyMap(
                occupied=occupied,
                free=free,
                unknown=~(occupied | free),
                resolution_m=RES,
                origin=(0.0, 0.0, 0.0),
            )
        )
    return maps[0], maps[1]


def test_a_window_over_a_new_area_finds_the_doorways_the_whole_map_finds():
    # The doorway search works on cells of two pixels a side (at 5 cm) whose corners
    # are set by the free space's bounding box; a window segmented with its own corners
    # would find other doorways in this building than the whole map, which starts an
    # odd number of pixels further left, and merge two of its rooms.
    first, both = _two_buildings(gap_px=601)
    mapper = _mapper(rooms_local=True)
    mapper.add_map(first)
    _ = mapper.rooms
    mapper.add_map(both)
    update = mapper.update_rooms()
    assert update.segmented_px < mapper.rooms.labels.size, "only a window was segmented"
    assert _same_up_to_ids(mapper.rooms.labels, tj.segment_rooms(mapper.occupancy).labels)


def _far_corner(plan, far_m: float) -> OccupancyMap:
    """A small free square ``far_m`` metres right of and below the plan (same frame): it
    makes the mapper's box far larger than the plan."""
    free = np.ones((20, 20), bool)
    x0, y0, _ = plan.occupancy.origin
    return OccupancyMap(
        occupied=~free,
        free=free,
        unknown=~free,
        resolution_m=RES,
        origin=(x0 + far_m, y0 - far_m, 0.0),
    )


def test_a_local_update_works_in_windows_not_on_the_whole_map():
    """An update for a change in one room allocates far less than one label image of the
    map (no copy, paste or comparison of the whole labels), keeps the other rooms' Room
    objects, reports what changed, and leaves the rooms a caller holds as they were."""
    import tracemalloc

    plan = floor_plan(2, size_m=(16.0, 48.0))
    wall, _ = _split_wall(plan)
    mapper = _mapper(rooms_local=True)
    mapper.add_map(plan.occupancy)
    mapper.add_map(_far_corner(plan, 120.0))
    held = mapper.rooms
    held_labels = held.labels.copy()
    held_view = held.labels[: plan.occupancy.shape[0]]
    mapper.add_map(_obstacles(plan, wall))
    occ, box = mapper.occupancy, mapper.pixel_bbox
    keeper = mapper._rooms
    update = keeper.update(occ, box, mapper.room_config, local=True)
    np.testing.assert_array_equal(held.labels, held_labels)  # what the caller holds
    assert np.shares_memory(held_view, held.labels)
    assert update.segmented_px < occ.free.size / 50, "only a window was segmented"
    assert len(update.added) + len(update.changed) == 2
    del held, held_view
    mapper.update_rooms()  # rooms no caller has read: updated in place
    before = mapper._rooms.seg
    rooms_before = {r.id: r for r in before.rooms}
    mapper.add_map(_obstacles(plan, np.roll(wall, 3, axis=0)))  # the wall a bit thicker
    occ = mapper.occupancy
    labels_px = before.labels.nbytes
    del before
    tracemalloc.start()
    try:
        update = keeper.update(occ, box, mapper.room_config, local=True)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert 0 < update.segmented_px < occ.free.size / 50
    assert peak < labels_px / 2, (peak, labels_px)
    after = mapper.rooms
    assert _same_up_to_ids(after.labels, tj.segment_rooms(occ).labels)
    untouched = set(rooms_before) - set(update.changed) - set(update.removed)
    assert len(untouched) >= len(rooms_before) - 2
    for room in after.rooms:
        if room.id in untouched:
            assert room is rooms_before[room.id], room.id


def _room_and_corridors() -> OccupancyMap:
    """20 x 80 m: a 10 x 5 m room alone in the top left corner and, 6.5 m below it, two
    3 m corridors the length of the map joined by a door at the far end."""
    occ = np.zeros((400, 1600), bool)
    occ[0:3, 0:200] = occ[98:101, 0:200] = occ[0:100, 0:3] = occ[0:100, 197:200] = True
    for r in (230, 290, 350):
        occ[r : r + 3, :] = True
    occ[230:353, [0, 1, 2, -3, -2, -1]] = True
    occ[290:293, 1560:1578] = False
    known = np.zeros_like(occ)
    known[0:101, 0:200] = known[230:353, :] = True
    return OccupancyMap(
        occupied=occ, free=~occ & known, unknown=~known, resolution_m=RES, origin=(0, 0, 0)
    )


def test_a_local_update_given_up_half_way_leaves_the_kept_rooms_as_they_were():
    """The first window is spliced in, the second grows past the budget (the first
    corridor cut in two): the whole map is segmented and everything, ids and report included, is as
    for a mapper that updates whole, although the first window had been written."""
    occ = _room_and_corridors()
    change = np.zeros(occ.shape, bool)
    change[3:98, 100:103] = True  # a wall across the room (a door left)
    change[40:58, 100:103] = False
    change[233:290, 1300:1303] = True  # a wall across the first corridor
    local, whole = _mapper(rooms_local=True), _mapper(rooms_local=False)
    for m in (local, whole):
        m.add_map(occ)
        _ = m.rooms
        m.add_map(_obstacles_of(occ, change))
    a, b = local.update_rooms(), whole.update_rooms()
    assert a.segmented_px == local.rooms.labels.size, "the local update gave up"
    np.testing.assert_array_equal(local.rooms.labels, whole.rooms.labels)
    for k in ("added", "removed", "changed", "doors_added", "doors_removed", "n_rooms"):
        assert getattr(a, k) == getattr(b, k), k
    assert len(a.added) == 2, "a new room from the split room and one from the corridor"


def _obstacles_of(occ: OccupancyMap, mask: np.ndarray) -> OccupancyMap:
    """A map of ``occ``'s frame whose only known pixels are obstacles at ``mask``."""
    return OccupancyMap(
        occupied=mask,
        free=np.zeros_like(mask),
        unknown=~mask,
        resolution_m=occ.resolution_m,
        origin=occ.origin,
    )


def test_a_local_update_stopped_part_way_leaves_the_kept_labels_as_they_were(monkeypatch):
    """The kept labels are updated in place window by window; an error or interrupt
    between two windows puts back what the first wrote, so the next update starts from
    the rooms as they were and ends where an uninterrupted one does."""
    import topojax.incremental._rooms_local as rooms_local

    occ = _room_and_corridors()
    change = np.zeros(occ.shape, bool)
    change[3:98, 100:103] = True  # a wall across the room (a door left)
    change[40:58, 100:103] = False
    change[250:254, 700:704] = True  # a pillar in the first corridor, far from it
    m = _mapper(rooms_local=True)
    m.add_map(occ)
    m.update_rooms()  # not read: the update may write the kept labels in place
    kept = m._rooms.labels.copy()
    m.add_map(_obstacles_of(occ, change))
    real, written_before_stop = rooms_local._local_step, []

    def step(*args, **kwargs):
        if written_before_stop:
            raise KeyboardInterrupt
        n = real(*args, **kwargs)
        written_before_stop.append(not np.array_equal(m._rooms.labels, kept))
        return n

    monkeypatch.setattr(rooms_local, "_local_step", step)
    with pytest.raises(KeyboardInterrupt):
        m.update_rooms()
    assert written_before_stop == [True], "the first window wrote the kept labels"
    np.testing.assert_array_equal(m._rooms.labels, kept)
    monkeypatch.undo()
    again = _mapper(rooms_local=True)
    again.add_map(occ)
    again.update_rooms()
    again.add_map(_obstacles_of(occ, change))
    a, b = m.update_rooms(), again.update_rooms()
    np.testing.assert_array_equal(m.rooms.labels, again.rooms.labels)
    for k in ("added", "removed", "changed", "doors_added", "doors_removed", "n_rooms"):
        assert getattr(a, k) == getattr(b, k), k


def test_a_local_update_with_options_reaching_far_past_the_map_falls_back_to_whole():
    """Options of any finite size are valid: a margin (``max_door_width_m +
    door_context_m``) far wider than the map covers it all, so the update segments the
    whole map, as a mapper that updates whole does, and allocates nothing the size of
    the margin."""
    occ = _room_and_corridors()
    change = np.zeros(occ.shape, bool)
    change[250:254, 700:704] = True  # a pillar in the first corridor
    cfg = tj.RoomConfig(door_context_m=1e6)
    local, whole = _mapper(rooms_local=True, room_config=cfg), _mapper(room_config=cfg)
    for m in (local, whole):
        m.add_map(occ)
        m.update_rooms()
        m.add_map(_obstacles_of(occ, change))
    update = local.update_rooms()
    whole.update_rooms()
    assert update.segmented_px == local.rooms.labels.size
    np.testing.assert_array_equal(local.rooms.labels, whole.rooms.labels)


def _room_over_corridor() -> OccupancyMap:
    """A room (6 x 10 m) over a corridor 2.5 m wide running down from a 1.5 m doorway in
    the room's lower wall, at 0.05 m per pixel."""
    occ = np.zeros((224, 202), bool)
    occ[[0, -1]] = True
    occ[:, [0, -1]] = True
    occ[121, :86] = True  # the room's lower wall, the doorway at columns 86..115
    occ[121, 116:] = True
    occ[122:, :76] = True  # the corridor, columns 76..125
    occ[122:, 126:] = True
    return OccupancyMap(
        occupied=occ, free=~occ, unknown=np.zeros_like(occ), resolution_m=RES, origin=(0, 0, 0)
    )


def test_a_local_update_keeps_a_doorway_its_window_cuts_off_beyond():
    """A pillar placed 2.1 m from a doorway: the window (3.2 m round the pillar) ends
    just past the doorway, too near for the window to see the corridor widen beyond it,
    while the doorway lies in the zone whose doors are refreshed.  The two rooms stay as
    they were, so their door stays too (it went, leaving the room graph without the
    edge a segmentation from scratch has)."""
    occ = _room_over_corridor()
    pillar = np.zeros(occ.shape, bool)
    pillar[74:78, 99:103] = True
    local, whole = _mapper(rooms_local=True), _mapper(rooms_local=False)
    for m in (local, whole):
        m.add_map(occ)
        m.update_rooms()
        m.add_map(_obstacles_of(occ, pillar))
    update = local.update_rooms()
    whole.update_rooms()
    assert update.segmented_px < local.rooms.labels.size, "only a window was segmented"
    assert _same_up_to_ids(local.rooms.labels, whole.rooms.labels)
    assert [d.rooms for d in local.rooms.doors] == [(1, 2)]
    assert [d.ends_px.tolist() for d in local.rooms.doors] == [
        d.ends_px.tolist() for d in whole.rooms.doors
    ]
    assert not update.doors_removed and not update.doors_added
