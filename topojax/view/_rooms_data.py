"""The rooms and doors of a segmentation as the page draws them."""

from __future__ import annotations

import numpy as np

__all__ = ["is_room_pair", "rooms_payload", "rounded"]


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
