"""Local room updates: re-segment only windows around the free space that changed since
the last room update, and splice the result into the rooms kept from before (the steps
are in ``docs/rooms.md``, "Incremental")."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ._room_ids import match_ids, pasted

__all__ = [
    "LOCAL_MARGIN",
    "LOCAL_MAX_SHARE",
    "LocalChanges",
    "door_key",
    "free_box_near",
    "local_update",
]

#: A local update's window reaches this many times ``max_door_width_m + door_context_m``
#: (RoomConfig) past the changes and the rooms it re-segments.
LOCAL_MARGIN = 1.0
#: A local update whose windows would cover more than this share of the map segments the
#: whole map instead.
LOCAL_MAX_SHARE = 0.5
_CLUSTER_PX = 32  # changed pixels are grouped on a grid of this many pixels
#: A doorway's pixels lie within this many pixels of the bounding box of its ends.
_DOOR_SLACK = 2


@dataclass
class _Rooms:
    """Rooms being updated in place over the map box: labels int32 (H, W), rooms by id
    and doors (pixel coordinates in the box), the next unused id, the pixel size."""

    labels: np.ndarray
    rooms: dict
    doors: list
    next_id: int
    res_m: float
    origin: tuple = (0, 0)
    bounds: tuple = (0, 0, 0, 0)
    budget: float = 0.0
    written: list = field(default_factory=list)
    doors_gone: list = field(default_factory=list)
    doors_new: list = field(default_factory=list)


@dataclass
class _Relation:
    """How the rooms of a window's segmentation relate to the old ones: ``same`` (new id
    -> old id), ``replaced`` old ids, ``affected`` new ids, and the significant overlaps
    in the interior as arrays (new ids, old ids, pixels)."""

    same: dict
    replaced: set
    affected: set
    links: tuple


def local_update(keeper, occ, box, cfg):
    """The keeper's rooms brought up to ``occ`` (the map over global box ``box``, which
    holds the keeper's box) by re-segmenting windows around the changed free space.

    Returns the new :class:`~topojax.RoomSegmentation`, the pixels segmented, the next
    unused id and a :class:`LocalChanges` (None when the box grew); or ``(None, 0,
    keeper.next_id, None)`` when the windows would cover more than
    :data:`LOCAL_MAX_SHARE` of the bounding box of the free space (now and before: the
    part of the map a segmentation works on).

    With the box unchanged nothing here reads or writes the whole map but one comparison
    of the free and unknown space; the labels are updated in place unless they were handed out
    (:func:`_own_labels`)."""
    dr, dc = keeper.box[0] - box[0], keeper.box[1] - box[1]
    free = np.asarray(occ.free, bool)
    unknown = np.asarray(occ.unknown, bool)
    same_box = tuple(keeper.box) == tuple(box)
    before = keeper.free if same_box else pasted(keeper.free, keeper.box, box)
    # unknown space turned occupied can change a room's fill (segment_rooms leaves a
    # large unexplored part a room surrounds out of it), though no free pixel changed
    was_unknown = keeper.unknown if same_box else pasted(keeper.unknown, keeper.box, box, fill=True)
    rr, cc = _changed_pixels(before, free, was_unknown, unknown)
    st = _Rooms(
        labels=_own_labels(keeper) if same_box else pasted(keeper.labels, keeper.box, box),
        rooms={r.id: _shift_room(r, dr, dc) for r in keeper.seg.rooms},
        doors=[_shift_door(d, dr, dc) for d in keeper.seg.doors],
        next_id=keeper.next_id,
        res_m=float(occ.resolution_m),
        origin=(int(box[0]), int(box[1])),
    )
    try:  # an error or interrupt part way leaves the kept labels as they were
        return _local_steps(st, keeper, occ, box, free, rr, cc, cfg, same_box)
    except BaseException:
        _undo(st)
        raise


def _local_steps(st, keeper, occ, box, free, rr, cc, cfg, same_box):
    """:func:`local_update` from its work state ``st`` on: the windows re-segmented
    one after another, and the result assembled."""
    segmented = 0
    old_free = None if keeper.free_box is None else _shifted(keeper.free_box, box)
    if rr.size:
        st.bounds = _grow(_union_opt(old_free, _box_of_pixels(rr, cc)), 1, free.shape)
        st.budget = LOCAL_MAX_SHARE * _area(st.bounds)
        margin = _margin_px(cfg, st.res_m)
        groups = _groups(rr, cc, free.shape, margin)
        first = [_grow(_box_of_pixels(gr, gc), margin, st.bounds) for gr, gc in groups]
        if sum(_area(b) for b in first) > st.budget:  # the first windows alone
            return None, 0, keeper.next_id, None
        for gr, gc in groups:
            n = _local_step(st, occ, gr, gc, cfg)
            if n is None:
                _undo(st)  # the kept labels may be these: leave them as they were
                return None, 0, keeper.next_id, None
            segmented += n
    near = _union_opt(old_free, _box_of_pixels(rr, cc) if rr.size else None)
    changes = LocalChanges(
        written=tuple(st.written) if same_box else None,
        doors_gone=tuple(st.doors_gone),
        doors_new=tuple(st.doors_new),
        free_box=_global(free_box_near(free, near), box),
    )
    return _assembled(st, occ), segmented, st.next_id, changes


@dataclass(frozen=True)
class LocalChanges:
    """Where a local update wrote, for reporting it without reading the whole map.

    Attributes
    ----------
    written : tuple of ((int, int, int, int), ndarray), or None
        Boxes (global pixels, end exclusive) holding every label the update changed,
        each with the labels it held just before it was written (int32, the box's
        shape), in the order written; None when the map's box grew (then compare
        everything).
    doors_gone, doors_new : tuple
        Keys ``((a, b), ends)`` (:func:`door_key`) of the doors dropped and added, in
        the order it did so (one may be dropped and added again).
    free_box : tuple of int, or None
        Bounding box of the free pixels now (global, end exclusive); None if none.
    """

    written: tuple | None
    doors_gone: tuple
    doors_new: tuple
    free_box: tuple | None


def door_key(door, origin) -> tuple:
    """``((a, b), (r0, c0, r1, c1))``: the rooms of ``door`` and its ends in global pixels
    (``origin`` the global pixel of the labels' (0, 0))."""
    e = door.ends_px + np.array([origin[0], origin[1]])
    return (door.rooms, tuple(int(v) for v in e.ravel()))


def _undo(st: _Rooms) -> None:
    """Put back the labels of every box written, last first."""
    undo_writes(st.labels, st.written, st.origin)
    st.written.clear()


def undo_writes(labels: np.ndarray, written, origin) -> None:
    """Put back, last first, each ``(global box, labels before)`` of ``written`` into
    ``labels`` (whose pixel (0, 0) is global pixel ``origin``)."""
    for gbox, prev in reversed(written):
        r0, c0, r1, c1 = _shifted(gbox, (*origin, 0, 0))
        labels[r0:r1, c0:c1] = prev


def _own_labels(keeper) -> np.ndarray:
    """The keeper's labels to update in place, or a copy of them once its last
    segmentation or its labels were handed out (``mapper.rooms``): those must not
    change."""
    return keeper.labels.copy() if keeper.handed_out else keeper.labels


def _changed_pixels(
    before: np.ndarray, free: np.ndarray, was_unknown: np.ndarray, unknown: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns (int64) of the pixels whose free or unknown state differs,
    row-major; compared a block of rows at a time (no whole-map temporary)."""
    rows, cols = [], []
    for r0 in range(0, free.shape[0], _ROWS_AT_ONCE):
        rs = slice(r0, r0 + _ROWS_AT_ONCE)
        differ = np.not_equal(before[rs], free[rs])
        differ |= np.not_equal(was_unknown[rs], unknown[rs])
        r, c = np.nonzero(differ)
        rows.append(r.astype(np.int64) + r0)
        cols.append(c.astype(np.int64))
    if not rows:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(rows), np.concatenate(cols)


#: Rows compared at once by :func:`_changed_pixels`.
_ROWS_AT_ONCE = 256


def free_box_near(free: np.ndarray, near) -> tuple[int, int, int, int] | None:
    """The bounding box (end exclusive) of ``free``, given a box ``near`` that holds it
    (None: look everywhere): its sides move in while they hold no free pixel, so only
    the rows and columns between the two boxes are read."""
    r0, c0, r1, c1 = (0, 0, *free.shape) if near is None else near
    while r0 < r1 and not free[r0, c0:c1].any():
        r0 += 1
    while r1 > r0 and not free[r1 - 1, c0:c1].any():
        r1 -= 1
    if r0 == r1:
        return None
    while not free[r0:r1, c0].any():
        c0 += 1
    while not free[r0:r1, c1 - 1].any():
        c1 -= 1
    return (r0, c0, r1, c1)


def _shifted(gbox, box) -> tuple[int, int, int, int]:
    """Global box ``gbox`` in the coordinates of the map box ``box``."""
    return (gbox[0] - box[0], gbox[1] - box[1], gbox[2] - box[0], gbox[3] - box[1])


def _global(b, box):
    """Box ``b`` (coordinates of the map box ``box``) in global pixels; None stays."""
    return None if b is None else (b[0] + box[0], b[1] + box[1], b[2] + box[0], b[3] + box[1])


def _union_opt(a, b):
    """The union of boxes ``a`` and ``b``, either of which may be None."""
    if a is None or b is None:
        return b if a is None else a
    return _union(a, b)


def _box_of_pixels(rr, cc) -> tuple[int, int, int, int]:
    """The bounding box (end exclusive) of pixels ``rr, cc``."""
    return (int(rr.min()), int(cc.min()), int(rr.max()) + 1, int(cc.max()) + 1)


def _margin_px(cfg, res: float) -> int:
    return int(math.ceil(LOCAL_MARGIN * (cfg.max_door_width_m + cfg.door_context_m) / res))


def _groups(rr, cc, shape, reach_px: int) -> list:
    """The changed pixels ``rr, cc`` (row-major) as ``(rows, cols)`` int64 per group:
    cells of a coarse grid over ``shape`` with a changed pixel, joined when closer than
    ``reach_px``."""
    import cv2

    b = _CLUSTER_PX
    coarse = np.zeros((-(-shape[0] // b), -(-shape[1] // b)), np.uint8)
    coarse[rr // b, cc // b] = 1
    # a reach past the grid's far side joins no more cells (nor allocates a kernel the
    # size of the reach: the options are metres of any finite size)
    k = 2 * min(-(-reach_px // b), max(coarse.shape)) + 1
    grown = cv2.dilate(coarse, np.ones((k, k), np.uint8))
    _, comp = cv2.connectedComponents(grown, connectivity=8, ltype=cv2.CV_32S)
    which = comp[rr // b, cc // b]
    order = np.argsort(which, kind="stable")
    rr, cc, which = rr[order], cc[order], which[order]
    cuts = np.flatnonzero(np.diff(which)) + 1
    return list(zip(np.split(rr, cuts), np.split(cc, cuts), strict=True))


def _grow(need, pad: int, bounds) -> tuple[int, int, int, int]:
    """Box ``need`` (end exclusive) grown by ``pad`` pixels, clipped to ``bounds`` (a
    box, or a shape ``(h, w)``)."""
    b = (0, 0, *bounds) if len(bounds) == 2 else bounds
    return (
        int(max(need[0] - pad, b[0])),
        int(max(need[1] - pad, b[1])),
        int(min(need[2] + pad, b[2])),
        int(min(need[3] + pad, b[3])),
    )


def _intersection(a, b) -> tuple[int, int, int, int]:
    """The intersection of boxes ``a`` and ``b`` (may be empty)."""
    return (max(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), min(a[3], b[3]))


def _union(a, b) -> tuple[int, int, int, int]:
    return (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))


def _area(box) -> int:
    return (box[2] - box[0]) * (box[3] - box[1])


def _bbox_end(bbox) -> tuple[int, int, int, int]:
    """A Room's inclusive bbox as an end-exclusive box."""
    return (bbox[0], bbox[1], bbox[2] + 1, bbox[3] + 1)


def _local_step(st: _Rooms, occ, rr, cc, cfg) -> int | None:
    """Re-segment around the changed pixels ``rr, cc`` (box coordinates) and splice the
    result into ``st`` (steps 1-4 of the module's description); returns the pixels
    segmented, or None when the windows would exceed the budget (``st.budget`` pixels
    for all steps)."""
    from scipy import ndimage

    from ..rooms.segment import segment_window

    bounds = st.bounds
    margin = _margin_px(cfg, st.res_m)
    band = max(1, int(round(cfg.door_context_m / st.res_m)))
    link_px = 3.0 * (cfg.max_door_width_m / st.res_m + 1.0)
    need = _box_of_pixels(rr, cc)
    win, replaced, segmented = _grow(need, margin, bounds), set(), 0
    while True:
        st.budget -= _area(win)
        if st.budget < 0:
            return None
        sub = _crop(occ, win)
        h, w = occ.shape
        seg = segment_window(sub, cfg, map_box=(-win[0], -win[1], h - win[0], w - win[1]))
        segmented += _area(win)
        old = st.labels[win[0] : win[2], win[1] : win[3]]
        inner = _interior(win, band, bounds)
        rel = _relate(st, seg.labels, old, inner, rr - win[0], cc - win[1], replaced, link_px)
        replaced = rel.replaced
        spans = ndimage.find_objects(seg.labels)
        want, is_open = need, False
        for i in rel.replaced:
            want = _union(want, _bbox_end(st.rooms[i].bbox))
        for j in rel.affected:
            s = spans[j - 1]
            want = _union(want, _moved(s, win))
            is_open |= _reaches_band(s, win, band, bounds)
        pad = 2 * margin if is_open else margin
        bigger = _union(win, _grow(want, pad, bounds))
        if bigger == win:
            break
        need, win = want, bigger
    old_at = st.labels[rr, cc].copy()
    final_of = _splice(st, sub, win, seg, rel) if rel.replaced or rel.affected else {}
    touched = _patch(st, rr, cc, old_at, seg.labels[rr - win[0], cc - win[1]], rel)
    _rebuild(st, occ, touched - rel.replaced, (rr, cc))
    reach = int(math.ceil((cfg.max_door_width_m + cfg.door_context_m) / st.res_m))
    zone = _grow(_box_of_pixels(rr, cc), reach, win)
    zone = _intersection(zone, _moved(_interior(win, band, bounds), win))
    _refresh_doors(st, win, seg, rel, final_of, zone, (rr, cc))
    return segmented


def _moved(s, win) -> tuple[int, int, int, int]:
    """Window slices ``s`` as an end-exclusive box in the coordinates of the map box."""
    return (s[0].start + win[0], s[1].start + win[1], s[0].stop + win[0], s[1].stop + win[1])


def _interior(win, band: int, bounds) -> tuple[slice, slice]:
    """The window less ``band`` pixels along each side that is not a side of ``bounds``
    (window coordinates; nothing past those is free)."""
    hw, ww = win[2] - win[0], win[3] - win[1]
    return (
        slice(band if win[0] > bounds[0] else 0, hw - band if win[2] < bounds[2] else hw),
        slice(band if win[1] > bounds[1] else 0, ww - band if win[3] < bounds[3] else ww),
    )


def _reaches_band(s, win, band: int, bounds) -> bool:
    """Whether window slices ``s`` come within ``band`` pixels of a side of ``win`` that
    is not a side of ``bounds`` (space may continue past it)."""
    hw, ww = win[2] - win[0], win[3] - win[1]
    return (
        (win[0] > bounds[0] and s[0].start < band)
        or (win[1] > bounds[1] and s[1].start < band)
        or (win[2] < bounds[2] and s[0].stop > hw - band)
        or (win[3] < bounds[3] and s[1].stop > ww - band)
    )


def _crop(occ, win):
    """The OccupancyMap of the pixels ``win`` (end exclusive) of ``occ``, in the same
    world frame."""
    from ..maps import OccupancyMap

    r0, c0, r1, c1 = win
    res = occ.resolution_m
    x0, y0, yaw = occ.origin
    dx, dy = c0 * res, (occ.shape[0] - r1) * res
    cos, sin = math.cos(yaw), math.sin(yaw)
    sl = np.s_[r0:r1, c0:c1]
    return OccupancyMap(
        occupied=occ.occupied[sl],
        free=occ.free[sl],
        unknown=occ.unknown[sl],
        resolution_m=res,
        origin=(x0 + cos * dx - sin * dy, y0 + sin * dx + cos * dy, yaw),
    )


def _pair_counts(new: np.ndarray, old: np.ndarray, base: int):
    """Overlaps of the positive labels of ``new`` and ``old`` (same shape): new ids, old
    ids and pixel counts."""
    both = (new > 0) & (old > 0)
    keys, ov = np.unique(new[both].astype(np.int64) * base + old[both], return_counts=True)
    nb, na = np.divmod(keys, base)
    return nb, na, ov


def _relate(st: _Rooms, new, old, inner, cr, cc, replaced, link_px: float) -> _Relation:
    """Steps 2 and 3 of the module's description on the window labels ``new`` and the
    old labels ``old`` under it, ``inner`` its interior, ``cr, cc`` the changed pixels
    (window coordinates) and ``replaced`` old rooms already replaced."""
    ch = np.zeros(new.shape, bool)
    ch[cr, cc] = True
    ni, oi, chi = new[inner], old[inner], ch[inner]
    base = int(max(old.max(), 0)) + 1
    nb, na, ov = _pair_counts(ni, oi, base)
    area_new = np.bincount(new.ravel(), minlength=int(new.max()) + 1).astype(np.float64)
    area_old = np.array([st.rooms[i].area_m2 / st.res_m**2 for i in na.tolist()], np.float64)
    sig = ov > np.minimum(0.5 * np.minimum(area_new[nb], area_old), link_px)
    nb, na, ov = nb[sig], na[sig], ov[sig]
    of_new: dict[int, set] = {}
    of_old: dict[int, set] = {}
    for j, i in zip(nb.tolist(), na.tolist(), strict=True):
        of_new.setdefault(j, set()).add(i)
        of_old.setdefault(i, set()).add(j)
    # same rooms: one link each way, equal outside the changed pixels (up to a doorway)
    keep = ~chi
    cnt_new = np.bincount(ni[keep].ravel(), minlength=int(new.max()) + 1)
    cnt_old = np.bincount(oi[keep].ravel(), minlength=base)
    ub, ua, uo = _pair_counts(ni[keep], oi[keep], base)
    unchanged = dict(zip(zip(ub.tolist(), ua.tolist(), strict=True), uo.tolist(), strict=True))
    same = {}
    for j, olds in of_new.items():
        (i,) = olds if len(olds) == 1 else (None,)
        if i is None or of_old[i] != {j}:
            continue
        if cnt_new[j] + cnt_old[i] - 2 * unchanged.get((j, i), 0) <= link_px:
            same[j] = i
    same_old = set(same.values())
    y = set(np.unique(new[cr, cc]).tolist()) - {0} - set(same)
    x = set(replaced) | (set(np.unique(old[cr, cc]).tolist()) - {0} - same_old)
    links = list(zip(nb.tolist(), na.tolist(), strict=True))
    while True:
        ny = y | {j for j, i in links if i in x}
        nx_ = x | {i for j, i in links if j in ny}
        if ny == y and nx_ == x:
            break
        x, y = nx_, ny
    same = {j: i for j, i in same.items() if j not in y and i not in x}
    return _Relation(same=same, replaced=x, affected=y, links=(nb, na, ov))


def _splice(st: _Rooms, sub, win, seg, rel: _Relation) -> dict:
    """Put the affected rooms of the window segmentation ``seg`` (of ``sub``, the map
    over ``win``) in place of the replaced old rooms.

    Old rooms not replaced keep their pixels (a few pixels of a doorway line the window
    gave an affected room stay theirs); pixels of replaced or affected rooms take the
    affected room's id, or 0; pixels the window gave to a room that is not affected (a
    doorway line) go to an affected neighbour, as :func:`segment_rooms` fills its cut
    lines.  Ids by :func:`match_ids` against the replaced rooms.  Returns the final id
    of each affected room (window id -> id)."""
    import cv2

    from ..rooms.model import build_segmentation

    x, y = rel.replaced, rel.affected
    r0, c0 = win[0], win[1]
    old = st.labels[win[0] : win[2], win[1] : win[3]]
    new = seg.labels
    n_new = int(new.max()) if new.size else 0
    in_y = np.zeros(n_new + 1, bool)
    in_y[sorted(y)] = True
    old_x = np.isin(old, np.array(sorted(x), np.int64))
    kept = (old > 0) & ~old_x
    new_y = in_y[new] & ~kept
    take = (old_x | new_y) & ~kept
    yl = np.where(new_y, new, 0).astype(np.int32)
    gap = take & (new > 0) & ~in_y[new]
    for _ in range(2):
        if not (gap & (yl == 0)).any():
            break
        grown = cv2.dilate(yl.astype(np.float32), np.ones((3, 3), np.uint8)).astype(np.int32)
        yl = np.where(gap & (yl == 0), grown, yl)
    ys = sorted(y)
    compact = np.zeros(n_new + 1, np.int64)
    compact[ys] = np.arange(1, len(ys) + 1)
    yc = compact[yl]
    lut, st.next_id = match_ids(np.where(old_x, old, 0), win, yc, win, st.next_id)
    final = lut[yc].astype(np.int32)
    st.written.append((_global(win, (*st.origin, 0, 0)), old.copy()))
    old[take] = final[take]  # a view of st.labels
    for i in x:
        st.rooms.pop(i, None)
    for room in build_segmentation(sub, final, []).rooms:
        st.rooms[room.id] = _shift_room(room, r0, c0)
    return {j: int(lut[compact[j]]) for j in ys}


def _refresh_doors(st: _Rooms, win, seg, rel: _Relation, final_of: dict, zone, changed) -> None:
    """Doors after a local step: the old doors, less those of replaced rooms and those
    in ``zone`` (a box near the changes, inside the window's interior: a doorway there
    may have moved, appeared or gone); plus the window's doors of affected rooms and
    those in ``zone``, each side named by its final id (affected rooms), the old room it
    is the same as, or the old room it overlaps most.  An old door in ``zone`` stays
    when both its rooms stay, the window gives no door between them and no pixel of
    ``changed`` (rows, cols) comes near it: the window's side may cut off the space a
    doorway needs beyond it, and the rooms it separates still meet there."""
    x, y = rel.replaced, rel.affected
    owner = dict(rel.same)
    best: dict[int, int] = {}
    for j, i, o in zip(*(a.tolist() for a in rel.links), strict=True):
        if i not in x and j not in y and j not in rel.same and o > best.get(j, 0):
            owner[j], best[j] = i, o
    owner.update(final_of)

    def in_zone(pixels) -> bool:
        r, c = pixels[:, 0], pixels[:, 1]
        inside = (r >= zone[0]) & (r < zone[2]) & (c >= zone[1]) & (c < zone[3])
        return bool(inside.any())

    new = []
    for d in seg.doors:
        moved = _shift_door(d, win[0], win[1])
        a, b = d.rooms
        if a not in y and b not in y and not in_zone(moved.pixels):
            continue
        fa, fb = owner.get(a, 0), owner.get(b, 0)
        if fa and fb and fa != fb and fa in st.rooms and fb in st.rooms:
            new.append(_shift_door(moved, 0, 0, rooms=(min(fa, fb), max(fa, fb))))
    pairs = {d.rooms for d in new}
    cr, cc = changed

    def unjudged(door) -> bool:
        if door.rooms in pairs or not all(i in st.rooms for i in door.rooms):
            return False
        e, k = door.ends_px, _DOOR_SLACK + 1
        near = (cr >= e[:, 0].min() - k) & (cr <= e[:, 0].max() + k)
        near &= (cc >= e[:, 1].min() - k) & (cc <= e[:, 1].max() + k)
        return not bool(near.any())

    _drop_doors(st, x, zone, lambda d: in_zone(d.pixels) and not unjudged(d))
    for door in new:
        st.doors.append(door)
        st.doors_new.append(door_key(door, st.origin))


def _drop_doors(st: _Rooms, rooms: set, zone=None, in_zone=None) -> None:
    """Drop the doors of rooms ``rooms`` and, given ``zone`` (a box), those that
    ``in_zone(door)`` picks (a pixel in it), noting their keys.  Only doors whose ends
    come within :data:`_DOOR_SLACK` pixels of the zone are offered to ``in_zone`` (a
    doorway's pixels lie on the line between its ends)."""
    if not st.doors:
        return
    pair = np.array([d.rooms for d in st.doors], np.int64)
    drop = np.isin(pair, np.array(sorted(rooms), np.int64)).any(axis=1)
    if zone is not None:
        ends = np.array([d.ends_px.ravel() for d in st.doors], np.int64)
        r, c = ends[:, 0::2], ends[:, 1::2]
        k = _DOOR_SLACK
        near = (r.max(axis=1) + k >= zone[0]) & (r.min(axis=1) - k < zone[2])
        near &= (c.max(axis=1) + k >= zone[1]) & (c.min(axis=1) - k < zone[3])
        for i in np.flatnonzero(near & ~drop).tolist():
            drop[i] = in_zone(st.doors[i])
    st.doors_gone += [door_key(st.doors[i], st.origin) for i in np.flatnonzero(drop).tolist()]
    st.doors = [d for d, gone in zip(st.doors, drop.tolist(), strict=True) if not gone]


def _patch(st: _Rooms, rr, cc, old_at, new_at, rel: _Relation) -> set:
    """Changed pixels whose new room is the same as an old one take its id; changed
    pixels in no new room leave the old room they were in (unless it was replaced).
    Returns the ids of the rooms that gained or lost pixels."""
    n = int(max(new_at.max(), max(rel.same, default=0))) + 1
    lut = np.full(n, -1, np.int64)
    for j, i in rel.same.items():
        lut[j] = i
    target = lut[new_at]
    gone = (new_at == 0) & (old_at > 0) & ~np.isin(old_at, np.array(sorted(rel.replaced)))
    target[gone] = 0
    sel = (target >= 0) & (target != old_at)
    if sel.any():
        b = _box_of_pixels(rr[sel], cc[sel])
        prev = st.labels[b[0] : b[2], b[1] : b[3]].copy()
        st.written.append((_global(b, (*st.origin, 0, 0)), prev))
    st.labels[rr[sel], cc[sel]] = target[sel]
    return (set(target[sel].tolist()) | set(old_at[sel].tolist())) - {0}


def _rebuild(st: _Rooms, occ, ids: set, changed) -> None:
    """Recompute the outline, area and centroid of rooms ``ids`` (kept rooms whose pixels
    changed at ``changed`` = (rows, cols)); a room left without pixels goes, with its
    doors."""
    from ..rooms.model import build_segmentation

    ids = {i for i in ids if i in st.rooms}
    if not ids:
        return
    box = _box_of_pixels(*changed)
    for i in ids:
        box = _union(box, _bbox_end(st.rooms[i].bbox))
    lab = st.labels[box[0] : box[2], box[1] : box[3]]
    part = np.where(np.isin(lab, np.array(sorted(ids), np.int64)), lab, 0)
    for room in build_segmentation(_crop(occ, box), part, []).rooms:
        st.rooms[room.id] = _shift_room(room, box[0], box[1])
        ids.discard(room.id)
    for i in ids:  # no pixels left
        del st.rooms[i]
    _drop_doors(st, ids)


def _shift_room(room, dr: int, dc: int):
    """``room`` with its pixel bbox moved by ``(dr, dc)`` (its world geometry stays)."""
    from ..rooms.model import Room

    if dr == 0 and dc == 0:
        return room
    b = room.bbox
    return Room(
        id=room.id,
        area_m2=room.area_m2,
        centroid=room.centroid,
        polygon=room.polygon,
        bbox=(b[0] + dr, b[1] + dc, b[2] + dr, b[3] + dc),
        holes=room.holes,
    )


def _shift_door(door, dr: int, dc: int, *, rooms=None):
    """``door`` with its pixels moved by ``(dr, dc)`` (and joining ``rooms``, if given)."""
    from ..rooms.model import Door

    if dr == 0 and dc == 0 and rooms is None:
        return door
    off = np.array([dr, dc], np.int64)
    return Door(
        id=door.id,
        rooms=door.rooms if rooms is None else rooms,
        ends_px=door.ends_px + off,
        ends_world=door.ends_world,
        width_m=door.width_m,
        pixels=door.pixels + off,
    )


def _assembled(st: _Rooms, occ):
    """The RoomSegmentation of ``st`` over the map ``occ``: rooms in id order, doors in
    the order of the rooms they join (then their ends), numbered from 1."""
    from ..rooms.model import Door, RoomSegmentation

    doors = sorted(st.doors, key=lambda d: (d.rooms, tuple(d.ends_px.ravel().tolist())))
    return RoomSegmentation(
        labels=st.labels,
        rooms=tuple(st.rooms[k] for k in sorted(st.rooms)),
        doors=tuple(
            Door(
                id=k,
                rooms=d.rooms,
                ends_px=d.ends_px,
                ends_world=d.ends_world,
                width_m=d.width_m,
                pixels=d.pixels,
            )
            for k, d in enumerate(doors, start=1)
        ),
        resolution_m=float(occ.resolution_m),
        origin=tuple(float(o) for o in occ.origin),
        occupancy=occ,
    )
