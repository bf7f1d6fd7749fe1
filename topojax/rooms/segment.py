"""Rooms and doorways of a map: :func:`segment_rooms` and :class:`RoomConfig`.  The method,
its parameters and what was tried are in ``docs/rooms.md``."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, fields

import cv2
import numpy as np

from .._stage_memory import SEGMENT_ROOMS_BYTES_PER_PX, SMALLER_MAP, check_stage_fits
from .._validate import (
    instance_of,
    instance_or_default,
    nonnegative_metres,
    positive_metres,
    quantity,
)
from ..fields.clearance import free_clearance_px
from ..skeleton import thin
from ._cuts import door_candidates, make_cuts
from ._grid import coarse_free, grid_factor
from ._kernels import enclosed_owner, fill_parts, first_pixels, room_pixels
from ._merge import DoorCut, merge_regions
from .model import RoomSegmentation, build_segmentation

__all__ = ["RoomConfig", "segment_rooms", "segment_window"]


@dataclass(frozen=True, kw_only=True)
class RoomConfig:
    """Options of :func:`segment_rooms`, in metres (they scale with the map's resolution).

    Attributes
    ----------
    min_door_width_m : float, default 0.5
        Narrower gaps are not doors (gaps between furniture, noise).
    max_door_width_m : float, default 2.2
        Wider gaps are not doors (open plan, corridor crossings).
    door_context_m : float, default 1.0
        A doorway is the narrowest point of the skeleton within this distance.
    door_ratio : float, default 0.7
        A door is kept only when its width is at most this times the width (twice the
        largest clearance) of each room it joins; otherwise the two rooms merge.
    min_room_m2 : float, default 2.0
        Smaller regions merge into the neighbour they share the most doorway with; an
        area of unknown space this large that a room surrounds stays no room.
    min_isolated_room_m2 : float, default 0.5
        A region without doorways (a free area of its own) is a room from this size on.
    max_border_share : float, default 0.25
        Two regions merge when the doors between them make up more than this share of the
        smaller one's boundary (a niche, not a room).
    """

    min_door_width_m: float = 0.5
    max_door_width_m: float = 2.2
    door_context_m: float = 1.0
    door_ratio: float = 0.7
    min_room_m2: float = 2.0
    min_isolated_room_m2: float = 0.5
    max_border_share: float = 0.25

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in ("door_ratio", "max_border_share"):
                value = quantity(f.name, value, unit="", allow_zero=False)
            elif f.name in ("max_door_width_m", "door_context_m"):
                value = positive_metres(f.name, value)
            elif f.name.endswith("_m2"):
                value = quantity(f.name, value, unit="m2", allow_zero=True)
            else:
                value = nonnegative_metres(f.name, value)
            object.__setattr__(self, f.name, value)
        if self.max_border_share > 1:
            raise ValueError(
                "max_border_share: expected a share of the boundary in (0, 1], received "
                f"{self.max_border_share!r}"
            )
        if self.max_door_width_m < self.min_door_width_m:
            raise ValueError(
                "min_door_width_m, max_door_width_m: expected min_door_width_m <= "
                f"max_door_width_m, received {self.min_door_width_m!r} and "
                f"{self.max_door_width_m!r} m"
            )


def _occupancy_of(source):
    """The OccupancyMap of ``source`` (an OccupancyMap or a TopologyResult)."""
    from ..maps.occupancy import OccupancyMap

    if isinstance(source, OccupancyMap):
        return source
    occ = getattr(source, "map", None)
    if isinstance(occ, OccupancyMap):
        return occ
    raise TypeError(
        f"source: expected an OccupancyMap or a TopologyResult, received {type(source).__name__}"
    )


def segment_rooms(source, *, config: RoomConfig | None = None) -> RoomSegmentation:
    """Split a map's known free space into rooms joined by doorways.

    Parameters
    ----------
    source : OccupancyMap or TopologyResult
        The map (a TopologyResult's ``map`` is used).
    config : RoomConfig, optional
        Options (metres).

    Returns
    -------
    RoomSegmentation
        ``labels`` int32 (H, W) (0 = no room), ``rooms``, ``doors``, ``graph`` and
        :meth:`RoomSegmentation.room_at`.

    Raises
    ------
    TypeError, ValueError
        For a source or option of the wrong type or out of range (the message names it).
    """
    cfg = instance_or_default("config", config, RoomConfig)
    occ = _occupancy_of(source)
    check_stage_fits("segment_rooms", "source", occ.shape, SEGMENT_ROOMS_BYTES_PER_PX, SMALLER_MAP)
    return _segment(occ, cfg, (0, 0, *occ.shape))


def segment_window(occupancy, config: RoomConfig, *, map_box) -> RoomSegmentation:
    """:func:`segment_rooms` of a window of a larger map (an OccupancyMap cut from it).

    The window's sides inside the larger map are cut through its space, not its edge: a
    doorway may end beyond them (on the side, standing for a wall of the larger map the
    window does not hold), but not beyond the larger map's own edge.  A window is held to
    the memory floor of :func:`segment_rooms` (a local room update's window may cover
    half the map).

    Parameters
    ----------
    occupancy : OccupancyMap
        The window.
    config : RoomConfig
    map_box : tuple of 4 int
        ``(row0, col0, row1, col1)``, end-exclusive: the larger map's extent in the
        window's pixels (``(0, 0, *occupancy.shape)`` for the whole map).

    Returns
    -------
    RoomSegmentation
    """
    r0, c0, r1, c1 = (int(v) for v in map_box)
    h, w = occupancy.shape
    if not (r0 <= 0 and c0 <= 0 and r1 >= h and c1 >= w):
        raise ValueError(
            f"map_box: expected a box holding the window's {h} x {w} pixels, received "
            f"{tuple(map_box)}"
        )
    cfg = instance_of("config", config, RoomConfig)
    check_stage_fits("segment_rooms", "window", (h, w), SEGMENT_ROOMS_BYTES_PER_PX, SMALLER_MAP)
    return _segment(occupancy, cfg, (r0, c0, r1, c1))


def _segment(occ, cfg: RoomConfig, map_box) -> RoomSegmentation:
    """:func:`segment_rooms` of an OccupancyMap whose map extends over ``map_box`` (its
    pixels, end exclusive)."""
    t0 = time.perf_counter()
    full = np.asarray(occ.free, bool)
    res = float(occ.resolution_m)
    # everything happens in the free space's bounding box with a one-pixel margin (the
    # margin is not free, so clearances and skeleton are those of the whole map)
    box, pad = _free_box(full)
    if box[0].stop == box[0].start:
        return build_segmentation(occ, np.zeros(full.shape, np.int32), [])
    # The doorways are searched on cells of f x f pixels, and where they fall decides
    # which doorways are found.  They fall on the map frame's lattice of f-pixel cells,
    # whatever the map's extent: a part of a map (a window of a local update, the map of
    # a robot still exploring) gets the cells, and so the rooms, of the whole map.  The
    # margin (not free) is there even where the map's edge cuts it off, and grows on the
    # top and left to put the cells' corners on the lattice.
    # No cell wider than the free space's box is wholly free, so none finds a doorway:
    # on maps so fine that a cell is (0.1 m at 1e-6 m per pixel: 100,000 pixels a side),
    # a cell just wider than the box finds the same (none) without the padding and the
    # cell pixels of the larger one, which grow with its square.
    f = min(grid_factor(res), min(box[0].stop - box[0].start, box[1].stop - box[1].start) + 1)
    anchor = _lattice_anchor(occ, f)
    if f > 1:
        pad = (
            pad[0] + (box[0].start - pad[0] - int(anchor[0])) % f,
            pad[1],
            pad[2] + (box[1].start - pad[2] - int(anchor[1])) % f,
            pad[3],
        )
    free = np.zeros(
        (
            box[0].stop - box[0].start + pad[0] + pad[1],
            box[1].stop - box[1].start + pad[2] + pad[3],
        ),
        bool,
    )
    inner = (slice(pad[0], free.shape[0] - pad[1]), slice(pad[2], free.shape[1] - pad[3]))
    free[inner] = full[box]
    # the doorways are searched on the cells, the regions made on the pixels
    cells = coarse_free(free, f) if f > 1 else free
    clearance = free_clearance_px(cells)
    skeleton = thin(cells)
    t1 = time.perf_counter()
    offset = np.array([box[0].start - pad[0], box[1].start - pad[2]], np.int64)
    in_free = np.asarray(map_box, np.int64) - np.tile(offset, 2)  # in ``free``'s pixels
    candidates = door_candidates(free, cells, clearance, skeleton, f, cfg, res, in_free)
    cuts = make_cuts(*candidates, free)
    t2 = time.perf_counter()
    open_ = free.copy()
    for cut in cuts:
        open_[cut.pixels[:, 0], cut.pixels[:, 1]] = False
    n, regions = cv2.connectedComponents(open_.view(np.uint8), connectivity=4, ltype=cv2.CV_32S)
    t3 = time.perf_counter()
    room_of, doors = merge_regions(regions, n, clearance, f, cuts, cfg, res)
    t4 = time.perf_counter()
    local = np.zeros(free.shape, np.int32)
    empty = np.empty(free.shape, np.uint8)
    room_pixels(regions, room_of, free, 2, local, empty)
    unknown = np.zeros(free.shape, bool)
    unknown[inner] = np.asarray(occ.unknown, bool)[box]
    _fill_enclosed(local, empty, unknown, max_unknown_px=cfg.min_room_m2 / res**2)
    doors = _in_raster_order(local, int(room_of.max(initial=0)), doors)
    labels = np.zeros(full.shape, np.int32)
    labels[box] = local[inner]
    doors = [d.shifted(offset) for d in doors]
    t5 = time.perf_counter()
    seg = build_segmentation(occ, labels, doors, box)
    seg.timings_s.update(
        {
            "fields": t1 - t0,
            "doors": t2 - t1,
            "regions": t3 - t2,
            "merge": t4 - t3,
            "fill": t5 - t4,
            "output": time.perf_counter() - t5,
        }
    )
    return seg


def _lattice_anchor(occ, f: int) -> tuple[int, int]:
    """The row and column of ``occ`` (modulo ``f``) whose pixels are multiples of ``f``
    in the map frame's pixel lattice (the frame of ``origin``, rotated by its yaw; row
    indices run down from the top)."""
    res = float(occ.resolution_m)
    x0, y0, yaw = (float(v) for v in occ.origin)
    cos, sin = math.cos(yaw), math.sin(yaw)
    col0 = _lattice_index((cos * x0 + sin * y0) / res)  # lattice column of column 0
    row0 = _lattice_index(-(-sin * x0 + cos * y0) / res) - occ.shape[0]  # and row of row 0
    return (-row0) % f, (-col0) % f


def _lattice_index(v: float) -> int:
    """The lattice index nearest to ``v`` (pixels), halves rounded up: an index that
    moves by one with ``v`` also for an origin half a pixel off the lattice, which
    ``round`` (halves to even) and the rounding errors of an origin moved by whole
    pixels would otherwise step by 0 or 2."""
    return math.floor(v + 0.5 + _LATTICE_SLACK)


#: Offsets of an origin from the lattice within this many pixels of a half count as the
#: half (an origin moved by whole pixels carries rounding errors of about 1e-12 pixels).
_LATTICE_SLACK = 1e-6


def _free_box(free: np.ndarray) -> tuple[tuple[slice, slice], tuple[int, int, int, int]]:
    """The bounding box of ``free`` grown by one pixel, clipped to the map, and the
    margin the map's edges cut off: ``(top, bottom, left, right)``, each 0 or 1."""
    rows = np.flatnonzero(free.any(axis=1))
    if rows.size == 0:
        return (slice(0, 0), slice(0, 0)), (0, 0, 0, 0)
    cols = np.flatnonzero(free.any(axis=0))
    h, w = free.shape
    r0, r1, c0, c1 = rows[0] - 1, rows[-1] + 2, cols[0] - 1, cols[-1] + 2
    box = (slice(max(r0, 0), min(r1, h)), slice(max(c0, 0), min(c1, w)))
    return box, (int(r0 < 0), int(r1 > h), int(c0 < 0), int(c1 > w))


def _in_raster_order(labels: np.ndarray, n: int, doors: list) -> list:
    """Rooms ``1..n`` of ``labels`` (int32, renamed in place) numbered in raster order of
    their first pixel, and ``doors`` (:class:`DoorCut`) with their rooms renamed.  The
    regions gave the order of their free space off the doorway lines; the cut pixels and
    the clutter a room took since may come first."""
    first = first_pixels(labels, n)[1:]
    if n < 2 or bool((np.diff(first) > 0).all()):
        return doors
    lut = np.zeros(n + 1, np.int32)
    lut[1 + np.argsort(first, kind="stable")] = np.arange(1, n + 1, dtype=np.int32)
    labels[...] = lut[labels]
    out = []
    for d in doors:
        a, b = int(lut[d.rooms[0]]), int(lut[d.rooms[1]])
        out.append(DoorCut(cut=d.cut, rooms=(min(a, b), max(a, b))))
    return out


def _fill_enclosed(
    labels: np.ndarray, empty: np.ndarray, unknown: np.ndarray, *, max_unknown_px: float
) -> None:
    """In place: every part of the pixels without a room (``empty``, uint8) that touches
    one room only and not the map's edge (furniture, clutter, pillars, small unknown
    patches inside a room) takes that room's id in ``labels``, unless it holds
    ``max_unknown_px`` or more pixels of ``unknown`` (bool): unexplored space the room
    surrounds, such as a building's inner block mapped from the corridors round it."""
    n, parts = cv2.connectedComponents(empty, connectivity=4, ltype=cv2.CV_32S)
    if n > 1:
        owner = enclosed_owner(parts, labels, n)
        # at least one pixel: a part with no unknown pixel (furniture) is always filled
        owner[np.bincount(parts[unknown], minlength=n) >= max(max_unknown_px, 1.0)] = 0
        fill_parts(labels, parts, owner)
