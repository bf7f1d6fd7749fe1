"""The kept rooms in a saved mapper state: the last segmentation (rooms, doors) and the
free and unknown space it was made from, so that a loaded mapper's next local room
update starts where the saved mapper's would have (``docs/rooms.md``, "Incremental")."""

from __future__ import annotations

import numpy as np

from ._dense_export import lattice_origin

__all__ = ["rooms_seg_arrays", "restore_rooms_seg"]

_PREFIX = "rooms_seg/"


def _stacked(parts: list, width: int, dtype) -> np.ndarray:
    """``parts`` (arrays of ``width`` columns) one under the other; (0, width) if none."""
    if not parts:
        return np.zeros((0, width), dtype)
    return np.concatenate([np.asarray(p).reshape(-1, width) for p in parts])


def rooms_seg_arrays(keeper) -> dict[str, np.ndarray]:
    """The arrays that hold ``keeper``'s last segmentation and the free and unknown
    space it was made from (keys under ``rooms_seg/``); none before the first update."""
    seg = keeper.seg
    if seg is None or keeper.free is None or keeper.unknown is None:
        return {}
    rooms, doors = seg.rooms, seg.doors
    holes = [h for r in rooms for h in r.holes]
    fb = keeper.free_box
    arrays = {
        "free": np.packbits(np.asarray(keeper.free, bool), axis=None),
        "unknown": np.packbits(np.asarray(keeper.unknown, bool), axis=None),
        "free_box": np.asarray(fb if fb is not None else (0, 0, 0, 0), np.int64),
        "has_free_box": np.asarray(fb is not None),
        "room_id": np.asarray([r.id for r in rooms], np.int64),
        "room_area_m2": np.asarray([r.area_m2 for r in rooms], np.float64),
        "room_centroid": np.asarray([r.centroid for r in rooms], np.float64).reshape(-1, 2),
        "room_bbox": np.asarray([r.bbox for r in rooms], np.int64).reshape(-1, 4),
        "room_polygon_len": np.asarray([len(r.polygon) for r in rooms], np.int64),
        "room_polygon": _stacked([r.polygon for r in rooms], 2, np.float64),
        "room_n_holes": np.asarray([len(r.holes) for r in rooms], np.int64),
        "hole_len": np.asarray([len(h) for h in holes], np.int64),
        "hole": _stacked(holes, 2, np.float64),
        "door_id": np.asarray([d.id for d in doors], np.int64),
        "door_rooms": np.asarray([d.rooms for d in doors], np.int64).reshape(-1, 2),
        "door_ends_px": _stacked([d.ends_px for d in doors], 4, np.int64).reshape(-1, 2, 2),
        "door_ends_world": _stacked([d.ends_world for d in doors], 4, np.float64).reshape(-1, 2, 2),
        "door_width_m": np.asarray([d.width_m for d in doors], np.float64),
        "door_pixels_len": np.asarray([len(d.pixels) for d in doors], np.int64),
        "door_pixels": _stacked([d.pixels for d in doors], 2, np.int64),
    }
    return {_PREFIX + k: v for k, v in arrays.items()}


def _split(flat: np.ndarray, lengths: np.ndarray, what: str) -> list[np.ndarray]:
    """``flat`` cut into consecutive pieces of ``lengths`` rows; a ValueError naming
    ``what`` where they do not add up."""
    lengths = np.asarray(lengths, np.int64)
    if (lengths < 0).any() or int(lengths.sum()) != flat.shape[0]:
        raise ValueError(
            f"{_PREFIX}{what}: the lengths add up to {int(lengths.sum())} rows, "
            f"the stored array has {flat.shape[0]}"
        )
    return np.split(flat, np.cumsum(lengths)[:-1]) if lengths.size else []


def _mask(data, key: str, shape: tuple[int, int]) -> np.ndarray:
    bits = np.asarray(data[_PREFIX + key], np.uint8)
    n = shape[0] * shape[1]
    if bits.ndim != 1 or bits.shape[0] != (n + 7) // 8:
        raise ValueError(
            f"{_PREFIX}{key}: expected {(n + 7) // 8} bytes for the room box {shape}, "
            f"received shape {bits.shape}"
        )
    return np.unpackbits(bits, count=n).astype(bool).reshape(shape)


def restore_rooms_seg(keeper, data, resolution_m: float) -> None:
    """Give ``keeper`` (its labels, box and ids loaded) the segmentation and the free and
    unknown space stored by :func:`rooms_seg_arrays`; nothing where the state has none
    (older states: the next update segments the whole map).  A ValueError names the
    field that does not hold together."""
    from ..maps import OccupancyMap
    from ..rooms.model import Door, Room, RoomSegmentation

    if _PREFIX + "free" not in data or keeper.labels is None:
        return
    r0, c0, r1, c1 = keeper.box
    shape = (r1 - r0, c1 - c0)
    free, unknown = _mask(data, "free", shape), _mask(data, "unknown", shape)
    if (free & unknown).any():
        raise ValueError(f"{_PREFIX}free, {_PREFIX}unknown: pixels both free and unknown")

    def get(key):
        return np.asarray(data[_PREFIX + key])

    ids = get("room_id")
    polygons = _split(get("room_polygon").reshape(-1, 2), get("room_polygon_len"), "room_polygon")
    holes = _split(get("hole").reshape(-1, 2), get("hole_len"), "hole")
    n_holes = get("room_n_holes")
    per_room = [ids, get("room_area_m2"), get("room_centroid"), get("room_bbox"), n_holes]
    if any(len(a) != len(ids) for a in (*per_room, polygons)) or int(n_holes.sum()) != len(holes):
        raise ValueError(f"{_PREFIX}room_*: the rooms' fields differ in length")
    rooms, k = [], 0
    for i, rid in enumerate(ids):
        nh = int(n_holes[i])
        rooms.append(
            Room(
                id=int(rid),
                area_m2=float(per_room[1][i]),
                centroid=tuple(float(v) for v in per_room[2][i]),
                polygon=polygons[i],
                bbox=tuple(int(v) for v in per_room[3][i]),
                holes=tuple(holes[k : k + nh]),
            )
        )
        k += nh
    door_ids = get("door_id")
    pixels = _split(get("door_pixels").reshape(-1, 2), get("door_pixels_len"), "door_pixels")
    fields = [get("door_rooms"), get("door_ends_px"), get("door_ends_world"), get("door_width_m")]
    if any(len(a) != len(door_ids) for a in (*fields, pixels)):
        raise ValueError(f"{_PREFIX}door_*: the doors' fields differ in length")
    doors = tuple(
        Door(
            id=int(did),
            rooms=tuple(int(v) for v in fields[0][i]),
            ends_px=fields[1][i].copy(),
            ends_world=fields[2][i].copy(),
            width_m=float(fields[3][i]),
            pixels=pixels[i].copy(),
        )
        for i, did in enumerate(door_ids)
    )
    occ = OccupancyMap(
        occupied=~(free | unknown),
        free=free,
        unknown=unknown,
        resolution_m=resolution_m,
        origin=lattice_origin(resolution_m, r1, c0),
    )
    keeper.seg = RoomSegmentation(
        labels=keeper.labels,
        rooms=tuple(rooms),
        doors=doors,
        resolution_m=float(resolution_m),
        origin=tuple(float(o) for o in occ.origin),
        occupancy=occ,
    )
    keeper.free, keeper.unknown = free, unknown
    keeper.free_box = tuple(int(v) for v in get("free_box")) if bool(get("has_free_box")) else None
