"""Small maps with known rooms for the tests of the rooms outputs, plots and commands."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def three_rooms_occupied() -> np.ndarray:
    """bool (60, 150): walls round three rooms in a row with 16 px doorways between them
    (0.8 m at 0.05 m/px; each room about 7 m², over the default smallest room)."""
    occ = np.zeros((60, 150), bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    for c in (50, 100):
        occ[:, c] = True
        occ[22:38, c] = False
    return occ


def three_rooms(origin=(-1.5, 2.0, 0.3)):
    """:func:`three_rooms_occupied` as an OccupancyMap at 0.05 m/px, the map frame shifted
    and turned (yaw 0.3 rad)."""
    from topojax.maps import OccupancyMap

    occ = three_rooms_occupied()
    return OccupancyMap(
        occupied=occ, free=~occ, unknown=np.zeros_like(occ), resolution_m=0.05, origin=origin
    )


def three_rooms_png(path: Path) -> Path:
    """The map as an IPA-benchmark-style PNG (free 255, everything else 0)."""
    import cv2

    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), np.where(three_rooms_occupied(), 0, 255).astype(np.uint8))
    return path


def corridor_round_two_rooms(shape=(6, 10), origin=(0.0, 0.0, 0.0)):
    """The rooms (a RoomSegmentation at 0.05 m/px) of a corridor, room 1, round two rooms
    2 and 3 (its two holes) in a block of ``shape`` pixels framed by a wall pixel."""
    from topojax.maps.occupancy import OccupancyMap
    from topojax.rooms.model import build_segmentation

    h, w = shape
    labels = np.ones(shape, np.int32)
    labels[2 : h - 2, 2 : w // 2] = 2
    labels[2 : h - 2, w // 2 + 1 : w - 2] = 3
    labels = np.pad(labels, 1)
    free = labels > 0
    occ = OccupancyMap(
        occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=0.05, origin=origin
    )
    return build_segmentation(occ, labels, [])


def ring_round_a_room(size: int = 7, origin=(0.0, 0.0, 0.0)):
    """The rooms (a RoomSegmentation at 0.05 m/px) of a ring, room 1, two pixels wide
    round a square room 2 of ``size - 4`` pixels, framed by a wall pixel: the ring's
    centroid lies in room 2."""
    from topojax.maps.occupancy import OccupancyMap
    from topojax.rooms.model import build_segmentation

    labels = np.ones((size, size), np.int32)
    labels[2 : size - 2, 2 : size - 2] = 2
    labels = np.pad(labels, 1)
    free = labels > 0
    occ = OccupancyMap(
        occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=0.05, origin=origin
    )
    return build_segmentation(occ, labels, [])
