"""Synthetic floor plans with known rooms and doors, for the room segmentation tests.

A building is a rectangle split recursively by straight walls; every split wall gets one
door somewhere along it, so the rooms form a tree joined by the doors.  Rooms may hold
clutter (boxes standing free inside them).  The ground truth is each room's interior
(free pixels plus its clutter)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from topojax.maps.occupancy import OccupancyMap

RES = 0.05


@dataclass
class FloorPlan:
    occupancy: OccupancyMap
    rooms: np.ndarray  # int32 (H, W): ground-truth room of each interior pixel, 0 elsewhere
    doors: list  # (room a, room b, width_m) per door
    n_rooms: int


def _px(m: float) -> int:
    return int(round(m / RES))


def floor_plan(
    seed: int,
    *,
    size_m=(16.0, 24.0),
    min_room_m=3.5,
    wall_m=0.15,
    door_widths_m=(0.8, 0.9, 1.0, 1.2),
    clutter=0,
    margin_m=1.0,
) -> FloorPlan:
    """A random plan of rooms at least ``min_room_m`` on each side, surrounded by
    ``margin_m`` of unknown space; ``clutter`` free-standing boxes per room."""
    rng = np.random.default_rng(seed)
    h, w = _px(size_m[0]), _px(size_m[1])
    m = _px(margin_m)
    wall = max(1, _px(wall_m))
    occupied = np.zeros((h + 2 * m, w + 2 * m), bool)
    unknown = np.ones_like(occupied)
    unknown[m : m + h, m : m + w] = False
    occupied[m : m + h, m : m + w] = True
    occupied[m + wall : m + h - wall, m + wall : m + w - wall] = False
    boxes = []  # interior rectangles (r0, c0, r1, c1), end exclusive
    walls = []  # (orientation, position, start, end, box index a, box index b)

    def split(r0, c0, r1, c1):
        tall, wide = r1 - r0, c1 - c0
        can_r = tall >= 2 * _px(min_room_m) + wall
        can_c = wide >= 2 * _px(min_room_m) + wall
        if not (can_r or can_c) or (len(boxes) > 0 and rng.random() < 0.15):
            boxes.append((r0, c0, r1, c1))
            return len(boxes) - 1
        along_rows = can_r and (not can_c or tall >= wide)
        lo, hi = (r0, r1) if along_rows else (c0, c1)
        cut = int(rng.integers(lo + _px(min_room_m), hi - _px(min_room_m) - wall + 1))
        first = len(boxes)
        if along_rows:
            occupied[cut : cut + wall, c0:c1] = True
            split(r0, c0, cut, c1)
            mid = len(boxes)
            split(cut + wall, c0, r1, c1)
            walls.append(("row", cut, c0, c1, first, mid))
        else:
            occupied[r0:r1, cut : cut + wall] = True
            split(r0, c0, r1, cut)
            mid = len(boxes)
            split(r0, cut + wall, r1, c1)
            walls.append(("col", cut, r0, r1, first, mid))
        return first

    split(m + wall, m + wall, m + h - wall, m + w - wall)
    rooms = np.zeros(occupied.shape, np.int32)
    for k, (r0, c0, r1, c1) in enumerate(boxes, start=1):
        rooms[r0:r1, c0:c1] = k
    doors = []
    for orient, pos, start, end, _, _ in walls:
        width = float(rng.choice(door_widths_m))
        span = _px(width)
        # a door where the rooms on both sides of this wall meet it
        if orient == "row":
            above, below = rooms[pos - 1, start:end], rooms[pos + 1 + wall - 1, start:end]
            ok = np.flatnonzero((above > 0) & (below > 0))
        else:
            above, below = rooms[start:end, pos - 1], rooms[start:end, pos + wall]
            ok = np.flatnonzero((above > 0) & (below > 0))
        # keep the door inside one stretch where the same two rooms face each other
        pairs = above[ok].astype(np.int64) * 10_000 + below[ok]
        choice = pairs[int(rng.integers(pairs.size))]
        run = ok[pairs == choice]
        run = run[(run >= run.min() + _px(0.3)) & (run <= run.max() - _px(0.3) - span)]
        if run.size == 0:
            continue
        s = int(run[int(rng.integers(run.size))]) + start
        a, b = int(choice // 10_000), int(choice % 10_000)
        if orient == "row":
            occupied[pos : pos + wall, s : s + span] = False
            rooms[pos : pos + wall, s : s + span] = 0
        else:
            occupied[s : s + span, pos : pos + wall] = False
        doors.append((min(a, b), max(a, b), width))
    for r0, c0, r1, c1 in boxes:
        for _ in range(clutter):
            bh, bw = _px(rng.uniform(0.4, 1.0)), _px(rng.uniform(0.4, 1.0))
            gap = _px(1.0)
            if r1 - r0 - 2 * gap - bh <= 0 or c1 - c0 - 2 * gap - bw <= 0:
                continue
            br = int(rng.integers(r0 + gap, r1 - gap - bh))
            bc = int(rng.integers(c0 + gap, c1 - gap - bw))
            occupied[br : br + bh, bc : bc + bw] = True
    free = ~occupied & ~unknown
    occ = OccupancyMap(occupied=occupied, free=free, unknown=unknown, resolution_m=RES)
    return FloorPlan(occupancy=occ, rooms=rooms, doors=doors, n_rooms=len(boxes))
