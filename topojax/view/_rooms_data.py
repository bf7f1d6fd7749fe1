"""The rooms and doors of a segmentation as the page draws them."""

from __future__ import annotations

import numpy as np

__all__ = ["is_room_pair", "pair_mismatch", "rooms_payload", "rounded"]


def is_room_pair(value) -> bool:
    """Whether ``value`` is a ``(rooms, doors)`` pair of :class:`topojax.rooms.Room` and
    :class:`topojax.rooms.Door` lists."""
    if not (isinstance(value, tuple) and len(value) == 2):
        return False
    from ..rooms import Door, Room

    return (
        isinstance(value, tuple)
        and len(value) == 2
        and all(isinstance(r, Room) for r in value[0])
        and all(isinstance(d, Door) for d in value[1])
    )


#: How far (pixels) a door's world end, or a room's outline, may lie from its pixels on the
#: map it was segmented on (a file's rounding; its own map's are exact).
_PIXEL_SLACK = 0.01


def pair_mismatch(pair, occupancy) -> str | None:
    """Why a ``(rooms, doors)`` pair, whatever map it records, was not segmented on
    ``occupancy``: a door whose world ends are not its pixel ends there, or a room whose
    outline leaves its pixel box there; None when every door and room fits."""
    rooms, doors = pair
    with np.errstate(over="ignore", invalid="ignore"):
        for door in doors:
            px = np.asarray(door.ends_px, np.float64).reshape(-1, 2)
            xy = np.asarray(door.ends_world, np.float64).reshape(-1, 2)
            at = np.stack(occupancy.world_to_pixel(xy[:, 0], xy[:, 1]), axis=1)
            if not np.allclose(at, px, rtol=0.0, atol=_PIXEL_SLACK):
                return (
                    f"door {door.id} ends on pixels {px.astype(np.int64).tolist()} of their "
                    f"map, which lie at pixels {rounded(at, 1)} of the map shown"
                )
        for room in rooms:
            ring = np.asarray(room.polygon, np.float64).reshape(-1, 2)
            rows, cols = occupancy.world_to_pixel(ring[:, 0], ring[:, 1])
            r0, c0, r1, c1 = room.bbox
            s = 0.5 + _PIXEL_SLACK
            inside = (rows >= r0 - s) & (rows <= r1 + s) & (cols >= c0 - s) & (cols <= c1 + s)
            if not inside.all():
                return (
                    f"room {room.id}'s outline leaves its pixels (rows {r0} to {r1}, columns "
                    f"{c0} to {c1} of their map) on the map shown"
                )
    return None


def rounded(values, digits: int = 4) -> list:
    """``values`` as a flat-or-nested list of floats rounded to ``digits`` decimals (values
    too large for that, near the float64 limit, as they are rather than infinite)."""
    a = np.asarray(values, np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        r = np.round(a, digits)
    return np.where(np.isfinite(r), r, a).tolist()


def rooms_payload(rooms) -> dict:
    """Rooms (id, area, centroid, ``label``: where its id is written, outline, the rings
    round its holes) and doors (rooms, ends, width) for the page; rings are flat
    ``[x, y, x, y, ...]`` lists."""
    if is_room_pair(rooms):
        room_list, door_list = rooms
    else:
        room_list, door_list = rooms.rooms, rooms.doors
    return {
        "rooms": [
            {
                "id": int(r.id),
                "area_m2": float(r.area_m2),
                "centroid": rounded(r.centroid),
                "label": rounded(r.label_point),
                "polygon": rounded(np.asarray(r.polygon, np.float64).reshape(-1, 2).ravel()),
                "holes": [
                    rounded(np.asarray(h, np.float64).reshape(-1, 2).ravel()) for h in r.holes
                ],
            }
            for r in room_list
        ],
        "doors": [
            {
                "id": int(d.id),
                "rooms": [int(v) for v in d.rooms],
                "ends": rounded(np.asarray(d.ends_world, np.float64).ravel()),
                "width_m": float(d.width_m),
            }
            for d in door_list
        ],
    }
