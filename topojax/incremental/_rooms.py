"""Rooms of the mapper's map, kept up to date with stable ids.

A *whole* update segments the current map (:func:`topojax.segment_rooms` of the mapper's
occupancy) and carries ids over from the previous rooms: a new room takes the id of the
old room it overlaps most when that old room also overlaps it most and their
intersection over union is at least :data:`SAME_ROOM_IOU`; other rooms get new ids
(never reused).  Its labels are exactly those of segmenting the current map from
scratch, with the ids renamed; a room whose pixels did not change keeps its id.

A *local* update (``IncrementalMapper(rooms_local=True)``) segments only windows around
the pixels whose free state changed since the last update (``_rooms_local``); rooms the
changes do not reach keep their ids and pixels exactly, doors away from the changes stay."""

from __future__ import annotations

import time
import warnings
from collections import Counter
from dataclasses import dataclass

import numpy as np

from .._caller import outside_stacklevel
from .._cpus import MemoryRefusal
from ._room_ids import SAME_ROOM_IOU, match_ids, pasted
from ._tiles import ExportBudgetError
from .reports import report_repr

__all__ = [
    "SAME_ROOM_IOU",
    "RoomKeeper",
    "due_rooms_update",
    "RoomsUpdate",
    "match_ids",
    "rooms_due",
]


@dataclass(frozen=True, repr=False)
class RoomsUpdate:
    """What one room update changed.

    Attributes
    ----------
    added, removed : tuple of int
        Room ids.
    changed : tuple of int
        Rooms that stay (same id) but whose pixels changed.
    doors_added, doors_removed : tuple of (int, int)
        Doors as the pair of room ids they join (one entry per door).
    n_rooms : int
        Rooms after the update.
    time_s : float
        Wall time of the update in seconds.
    segmented_px : int
        Pixels segmented: the whole map, or the windows of a local update (0 when the
        free space did not change).
    """

    added: tuple[int, ...] = ()
    removed: tuple[int, ...] = ()
    changed: tuple[int, ...] = ()
    doors_added: tuple[tuple[int, int], ...] = ()
    doors_removed: tuple[tuple[int, int], ...] = ()
    n_rooms: int = 0
    time_s: float = 0.0
    segmented_px: int = 0

    def __repr__(self) -> str:
        return report_repr(self)


class RoomKeeper:
    """The rooms of one mapper: the last segmentation (stable ids), its labels and the
    free and unknown space it was made from over the global pixel box, the bounding box of that free
    space (global pixels, None if none), and the next unused id."""

    def __init__(self) -> None:
        self.seg = None
        self.labels: np.ndarray | None = None
        self.box: tuple[int, int, int, int] | None = None
        self.free: np.ndarray | None = None
        self.unknown: np.ndarray | None = None
        self.free_box: tuple[int, int, int, int] | None = None
        self.next_id = 1
        self.active = False
        self.over_budget = False  # the last due update found the map too large to export
        # the last segmentation or its labels left the keeper: a local update copies them
        self.handed_out = False

    def update(self, occupancy, box, config=None, *, local: bool = False) -> RoomsUpdate:
        """Segment ``occupancy`` (the mapper's map over global box ``box``), whole or, with
        ``local``, around what changed since the last update, and carry the ids over;
        returns what changed."""
        from ..rooms import RoomConfig, segment_rooms
        from ..rooms.model import relabel
        from ._rooms_local import free_box_near, local_update, undo_writes

        t0 = time.perf_counter()
        cfg = RoomConfig() if config is None else config
        self.active = True
        free = np.asarray(occupancy.free, bool)
        seg = changes = None
        if local and self.seg is not None and self.free is not None and _within(self.box, box):
            seg, segmented, self.next_id, changes = local_update(self, occupancy, box, cfg)
        if seg is None:
            fresh = segment_rooms(occupancy, config=cfg)
            lut, self.next_id = match_ids(self.labels, self.box, fresh.labels, box, self.next_id)
            seg = relabel(fresh, lut)
            segmented = free.size
        try:
            if changes is None:
                near = free_box_near(free, None)
                free_box = None if near is None else _moved(near, box)
            else:
                free_box = changes.free_box
            if changes is None or changes.written is None:
                report = self._changes(seg, box)
            else:
                report = self._local_changes(seg, box, changes)
        except BaseException:  # the kept labels, updated in place, as they were
            if changes is not None and changes.written is not None and not self.handed_out:
                undo_writes(self.labels, changes.written, self.box[:2])
            raise
        self.seg, self.labels, self.box, self.free = seg, seg.labels, tuple(box), free
        self.unknown = np.asarray(occupancy.unknown, bool)
        self.handed_out = False
        self.free_box = free_box
        return RoomsUpdate(
            **report,
            n_rooms=seg.n_rooms,
            time_s=time.perf_counter() - t0,
            segmented_px=int(segmented),
        )

    def _changes(self, seg, box) -> dict:
        """Added, removed and changed rooms and doors between the kept rooms and ``seg``."""
        old_ids = {r.id for r in self.seg.rooms} if self.seg is not None else set()
        new_ids = {r.id for r in seg.rooms}
        changed = []
        if old_ids & new_ids:
            # both label images over the union of their boxes: a kept room changed where
            # the two differ
            union = (
                min(self.box[0], box[0]),
                min(self.box[1], box[1]),
                max(self.box[2], box[2]),
                max(self.box[3], box[3]),
            )
            a = pasted(self.labels, self.box, union)
            b = pasted(seg.labels, box, union)
            differ = a != b
            touched = set(np.unique(a[differ]).tolist()) | set(np.unique(b[differ]).tolist())
            changed = sorted(touched & old_ids & new_ids)
        old_doors = _door_keys(self.seg, self.box) if self.seg is not None else []
        new_doors = _door_keys(seg, box)
        return {
            "added": tuple(sorted(new_ids - old_ids)),
            "removed": tuple(sorted(old_ids - new_ids)),
            "changed": tuple(changed),
            "doors_added": tuple(k[0] for k in _minus(new_doors, old_doors)),
            "doors_removed": tuple(k[0] for k in _minus(old_doors, new_doors)),
        }

    def _local_changes(self, seg, box, changes) -> dict:
        """As :meth:`_changes` for a local update over the same box as the kept rooms,
        reading the labels only in the boxes it wrote: each pixel's labels before the
        update are those of the first box written that holds it (the kept labels may
        have been updated in place)."""
        old_ids = {r.id for r in self.seg.rooms}
        new_ids = {r.id for r in seg.rooms}
        touched: set = set()
        done: list = []
        for wbox, prev in changes.written:
            r0, c0, r1, c1 = wbox
            now = seg.labels[r0 - box[0] : r1 - box[0], c0 - box[1] : c1 - box[1]]
            differ = prev != now
            for d in done:  # pixels an earlier box holds were compared there
                i = (max(d[0], r0), max(d[1], c0), min(d[2], r1), min(d[3], c1))
                if i[0] < i[2] and i[1] < i[3]:
                    differ[i[0] - r0 : i[2] - r0, i[1] - c0 : i[3] - c0] = False
            done.append(wbox)
            touched |= set(np.unique(prev[differ]).tolist()) | set(np.unique(now[differ]).tolist())
        gone, new = Counter(changes.doors_gone), Counter(changes.doors_new)
        return {
            "added": tuple(sorted(new_ids - old_ids)),
            "removed": tuple(sorted(old_ids - new_ids)),
            "changed": tuple(sorted(touched & old_ids & new_ids)),
            "doors_added": tuple(sorted(k[0] for k in (new - gone).elements())),
            "doors_removed": tuple(sorted(k[0] for k in (gone - new).elements())),
        }


def _moved(b, box) -> tuple[int, int, int, int]:
    """Box ``b`` (coordinates of the map box ``box``) in global pixels."""
    return (b[0] + box[0], b[1] + box[1], b[2] + box[0], b[3] + box[1])


def _within(inner, outer) -> bool:
    """Whether global box ``inner`` lies inside ``outer``."""
    return (
        inner[0] >= outer[0]
        and inner[1] >= outer[1]
        and inner[2] <= outer[2]
        and inner[3] <= outer[3]
    )


def _door_keys(seg, box) -> list:
    """Each door as ``((a, b), (r0, c0, r1, c1))``: its rooms and its ends in global
    pixels."""
    out = []
    for d in seg.doors:
        e = d.ends_px + np.array([box[0], box[1]])
        out.append((d.rooms, tuple(int(v) for v in e.ravel())))
    return out


def _minus(a: list, b: list) -> list:
    """Entries of ``a`` not in ``b`` (as multisets)."""
    rest = list(b)
    out = []
    for k in a:
        if k in rest:
            rest.remove(k)
        else:
            out.append(k)
    return out


def keeps_rooms(mapper) -> bool:
    """Whether the mapper updates its rooms by itself: every ``rooms_every`` scans, or
    (``rooms_every`` None) with each graph update once rooms are in use; with 0 (updates
    asked for only) they may be older than the map."""
    return bool(mapper.rooms_every) or (mapper.rooms_every is None and mapper._rooms.active)


def rooms_due(mapper, *, graph_ran: bool) -> bool:
    """Whether the mapper's rooms are due for an update after this scan: every
    ``rooms_every`` scans, or (``rooms_every`` None) with each graph update once rooms are
    in use."""
    if mapper.pixel_bbox is None:
        return False
    if mapper.rooms_every is None:
        return graph_ran and mapper._rooms.active
    return bool(mapper.rooms_every) and mapper._since_rooms >= mapper.rooms_every


def due_rooms_update(mapper) -> RoomsUpdate | None:
    """The room update a scan made due, or None where the map has outgrown
    ``mapper.max_export_bytes`` for rooms (a relocalisation far off, a large site) or
    the memory available (:func:`topojax.segment_rooms` refuses it).

    The scan is in the map by then: raising would tell its caller it was refused.  The
    rooms stay as of their last update instead and a ``RuntimeWarning`` says why (once,
    until an update succeeds again); reading :attr:`IncrementalMapper.rooms` afresh
    (:meth:`~IncrementalMapper.update_rooms`) raises the error itself.  The warning names
    the line outside topojax that led to it (an ``add_scan``, an ``update_graph``)."""
    keeper = mapper._rooms
    try:
        update = mapper._update_rooms()
    except (ExportBudgetError, MemoryRefusal) as exc:
        if not keeper.over_budget:  # once while the map stays too large, not every update
            warnings.warn(
                f"scan {mapper._n_scans - 1}: rooms not updated, they stay as of their last "
                f"update until the map fits again ({exc})",
                RuntimeWarning,
                stacklevel=outside_stacklevel(),
            )
        keeper.over_budget = True
        return None
    keeper.over_budget = False
    return update


def current_room_labels(mapper) -> np.ndarray | None:
    """The room labels of ``mapper`` (int32 (H, W), the frame of its current map) when its
    last room update covers the map as it is now, else None; segments nothing."""
    keeper = mapper._rooms
    if keeper.seg is None or keeper.box != mapper.pixel_bbox:
        return None
    keeper.handed_out = True
    return keeper.labels
