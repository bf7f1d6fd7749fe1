"""Rooms and doorways as files: GeoJSON (:func:`save_rooms` / :func:`load_rooms`), a
label picture (:func:`save_room_labels`) and the room graph (:func:`save_room_graph`);
:func:`save_room_files` writes all four beside each other, as the command line does."""

from __future__ import annotations

import colorsys
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._fs import atomic_write_bytes, output_file_in_folder, refuse_suffix_only
from .._validate import (
    MAX_RESOLUTION_M,
    MIN_RESOLUTION_M,
    existing_file,
    instance_of,
    metres_per_pixel,
    path_like,
    pose,
)
from ._schema import without_altitude
from ._stream import DuplicateKeyError, loads_unique

if TYPE_CHECKING:
    from ..rooms import LoadedRooms

__all__ = [
    "ROOM_FILE_SUFFIXES",
    "load_rooms",
    "room_colours",
    "room_graph",
    "room_picture",
    "save_room_files",
    "save_room_graph",
    "save_room_labels",
    "save_rooms",
]

#: What :func:`save_room_files` appends to a stem: GeoJSON, label picture, room graph
#: (GraphML, JSON node-link).
ROOM_FILE_SUFFIXES = ("_rooms.geojson", "_rooms.png", "_rooms.graphml", "_rooms.json")

#: The foreign member that marks a rooms GeoJSON and holds the map frame.
_MEMBER = "topojax_rooms"
_VERSION = 1
#: Label-picture colours: no room on an obstacle, no room elsewhere, doorways.
_BLACK, _GREY, _WHITE = (0, 0, 0), (128, 128, 128), (255, 255, 255)
_GOLDEN = 0.6180339887498949
#: Rooms coloured by golden-ratio hues (all distinct); later ones by :func:`_scrambled_colours`.
_HUE_COLOURS = 2048
#: An odd step through the 24-bit colours, so that neighbouring ids differ in every channel.
_SCRAMBLE = 0x3779B1
#: The RGB colours that are not grey (r = g = b).
_MAX_COLOURS = (1 << 24) - 256


def _check_seg(seg: Any):
    from ..rooms import RoomSegmentation

    return instance_of("seg", seg, RoomSegmentation)


# ---------------------------------------------------------------------- GeoJSON


def _signed_area(ring: np.ndarray) -> float:
    """Shoelace area of an open ring (K, 2): positive when counter-clockwise."""
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _box_ring(seg, bbox) -> np.ndarray:
    """The outer corners of the pixel squares of ``bbox`` (row0, col0, row1, col1), in
    world (x, y) metres, counter-clockwise."""
    r0, c0, r1, c1 = bbox
    rows = np.array([r0 - 0.5, r1 + 0.5, r1 + 0.5, r0 - 0.5])
    cols = np.array([c0 - 0.5, c0 - 0.5, c1 + 0.5, c1 + 0.5])
    x, y = seg.occupancy.pixel_to_world(rows, cols)
    ring = np.stack([np.asarray(x, np.float64), np.asarray(y, np.float64)], axis=1)
    return ring if _signed_area(ring) > 0 else ring[::-1].copy()


def _room_feature(seg, room) -> dict:
    where = f"room {room.id}"
    poly = np.asarray(room.polygon, np.float64).reshape(-1, 2)
    holes = [np.asarray(h, np.float64).reshape(-1, 2) for h in room.holes]
    if not all(np.isfinite(r).all() for r in (poly, *holes)):
        raise ValueError(f"seg: {where} has a polygon with non-finite coordinates")
    props: dict[str, Any] = {
        "kind": "room",
        "id": int(room.id),
        "area_m2": float(room.area_m2),
        "centroid": [float(v) for v in room.centroid],
        "bbox_px": [int(v) for v in room.bbox],
    }
    rings = [poly, *holes]
    if any(r.shape[0] < 3 or (_signed_area(r) > 0) != (i == 0) for i, r in enumerate(rings)):
        # a line, a point, a clockwise outline or a counter-clockwise hole is no valid
        # ring of RFC 7946: the geometry is the room's pixel box and the rings properties
        rings = [_box_ring(seg, room.bbox)]
        props["outline"] = poly.tolist()
        if holes:
            props["holes"] = [h.tolist() for h in holes]
    coords = [[*r.tolist(), r[0].tolist()] for r in rings]
    return {
        "type": "Feature",
        "geometry": {"type": "Polygon", "coordinates": coords},
        "properties": props,
    }


def _door_feature(door) -> dict:
    ends = np.asarray(door.ends_world, np.float64).reshape(-1, 2)
    if ends.shape != (2, 2) or not np.isfinite(ends).all():
        raise ValueError(
            f"seg: door {door.id}: expected two finite world ends, received {ends.tolist()}"
        )
    props = {
        "kind": "door",
        "id": int(door.id),
        "rooms": [int(r) for r in door.rooms],
        "width_m": float(door.width_m),
        "ends_px": np.asarray(door.ends_px, np.int64).reshape(2, 2).tolist(),
        "pixels": np.asarray(door.pixels, np.int64).reshape(-1, 2).tolist(),
    }
    return {
        "type": "Feature",
        "geometry": {"type": "LineString", "coordinates": ends.tolist()},
        "properties": props,
    }


def save_rooms(seg, path: str | Path) -> Path:
    """Write rooms and doorways as a GeoJSON FeatureCollection.

    Coordinates are ``[x, y]`` in metres in the map frame (the frame of the map's
    ``origin``), not WGS 84 longitude and latitude, as for graphs saved as GeoJSON; a
    GIS reads them as a local projected frame.

    Parameters
    ----------
    seg : RoomSegmentation
        From :func:`topojax.segment_rooms`.
    path : str or Path
        Output ``.geojson`` file; its folder must exist.  Written atomically (a temporary
        file renamed over it).

    Returns
    -------
    Path
        The written path.

    Raises
    ------
    ValueError
        If ``path`` does not end in ``.geojson`` (as :func:`save_room_labels` and
        :func:`save_room_graph` check theirs: a ``.json`` there is the room graph), or a
        number is NaN or infinite.

    Notes
    -----
    One ``Polygon`` feature per room, in id order: the exterior ring is the room's outline
    (:attr:`Room.polygon`), counter-clockwise and closed (first position repeated), and
    the interior rings are its holes (:attr:`Room.holes`: the rooms a corridor loop
    runs round), clockwise and closed, as RFC 7946 orders them; properties
    ``kind: "room"``, ``id``, ``area_m2``, ``centroid`` ``[x, y]`` (metres) and
    ``bbox_px`` ``[row_min, col_min, row_max, col_max]``.  An outline that encloses no
    area or runs clockwise, or a hole that runs counter-clockwise (not made by
    :func:`topojax.segment_rooms`), cannot be a ring: the geometry is then the room's
    pixel box and the outline and holes are kept in the properties ``outline`` and
    ``holes``.

    One ``LineString`` feature per door, in id order, from one obstacle end of the doorway
    to the other (:attr:`Door.ends_world`); properties ``kind: "door"``, ``id``, ``rooms``
    ``[a, b]``, ``width_m``, ``ends_px`` and ``pixels`` (``[row, col]`` lists).

    The foreign member ``"topojax_rooms"`` holds ``version``, ``resolution_m``,
    ``origin`` ``[x, y, yaw]`` and the map ``shape`` ``[H, W]``.  Floats are written with
    Python's shortest round-trip representation; NaN and infinity are refused.
    """
    seg = _check_seg(seg)
    p = path_like("path", path)
    refuse_suffix_only("path", p, (".geojson",))
    if p.suffix.lower() != ".geojson":
        raise ValueError(f"path: expected a .geojson file name, received {str(p)!r}")
    output_file_in_folder(p, name="path")  # before the work
    features = [_room_feature(seg, room) for room in seg.rooms]
    features += [_door_feature(door) for door in seg.doors]
    doc = {
        "type": "FeatureCollection",
        _MEMBER: {
            "version": _VERSION,
            "resolution_m": float(seg.resolution_m),
            "origin": [float(v) for v in seg.origin],
            "shape": [int(v) for v in seg.labels.shape],
        },
        "features": features,
    }
    try:
        data = json.dumps(doc, allow_nan=False).encode("utf-8")
    except ValueError:
        raise ValueError(
            f"cannot write {p}: an area, centroid or width is NaN or infinite, which "
            "GeoJSON cannot hold"
        ) from None
    atomic_write_bytes(p, data)
    return p


def _points(value: Any, dtype, what: str, *, count: int | None = None) -> np.ndarray:
    """``value`` as an array (K, 2) of ``dtype``; ValueError naming ``what``.  JSON's
    ``true`` and ``false`` are no numbers (NumPy would read them as 1 and 0)."""
    try:
        arr = np.empty(0) if _holds_bool(value) else np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = np.empty(0)
    except OverflowError:  # a JSON integer beyond any float
        raise ValueError(f"{what}: expected finite numbers") from None
    if isinstance(value, list) and not value and count is None:  # no pixels
        arr = arr.reshape(0, 2)
    if arr.ndim != 2 or arr.shape[1] != 2 or (count is not None and arr.shape[0] != count):
        size = "K" if count is None else str(count)
        raise ValueError(f"{what}: expected a list of {size} [a, b] pairs, received {value!r:.80}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{what}: expected finite numbers")
    if np.dtype(dtype).kind == "i":
        if not np.array_equal(arr, np.round(arr)):
            raise ValueError(f"{what}: expected integer pixels")
        if np.abs(arr).max(initial=0) > np.iinfo(dtype).max // 2:  # would wrap when cast
            raise ValueError(
                f"{what}: expected integer pixels of {np.dtype(dtype)}, received {value!r:.80}"
            )
    return arr.astype(dtype)


def _positions(value: Any, what: str, *, count: int | None = None) -> np.ndarray:
    """GeoJSON positions ``[x, y]`` or ``[x, y, z]`` as float64 (K, 2), as :func:`_points`
    reads pairs: RFC 7946 (3.1.1) allows an altitude as a third element, which other
    tools write; it must be a finite number and is dropped.  ValueError naming ``what``
    and the position for a fourth element or an altitude that is no finite number."""
    if not isinstance(value, list):
        return _points(value, np.float64, what, count=count)
    pairs = [without_altitude(pos, f"{what}: position {i}") for i, pos in enumerate(value)]
    return _points(pairs, np.float64, what, count=count)


def _holds_bool(value: Any) -> bool:
    """Whether ``value`` or a list item in it, to two levels (pairs in a list), is a bool."""
    if isinstance(value, bool):
        return True
    if not isinstance(value, list):
        return False
    return any(
        isinstance(v, bool) or (isinstance(v, list) and any(isinstance(u, bool) for u in v))
        for v in value
    )


def _number(props: dict, name: str, where: str) -> float:
    value = props.get(name)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not _finite(value):
        raise ValueError(
            f"{where}: property {name!r}: expected a finite number, received {value!r:.80}"
        )
    return float(value)


def _finite(value: int | float) -> bool:
    """Whether ``value`` is a finite float (a JSON integer beyond any float is not)."""
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def _integers(props: dict, name: str, where: str, count: int) -> tuple[int, ...]:
    value = props.get(name)
    if (
        not isinstance(value, list)
        or len(value) != count
        or not all(isinstance(v, int) and not isinstance(v, bool) for v in value)
    ):
        raise ValueError(
            f"{where}: property {name!r}: expected a list of {count} integers, "
            f"received {value!r:.80}"
        )
    return tuple(value)


def _read_room(props: dict, geometry: dict, where: str):
    from ..rooms import Room

    if geometry.get("type") != "Polygon":
        raise ValueError(
            f"{where}: geometry: expected a Polygon for a room, received {geometry.get('type')!r}"
        )
    if props.get("outline") is not None:  # null: a GIS table's empty column
        polygon = _points(props["outline"], np.float64, f"{where} outline")
        holes = [] if props.get("holes") is None else props["holes"]
        if not isinstance(holes, list):
            raise ValueError(
                f"{where}: property 'holes': expected a list of rings, received {holes!r:.80}"
            )
        holes = [_points(h, np.float64, f"{where} holes[{i}]") for i, h in enumerate(holes)]
    else:
        rings = geometry.get("coordinates")
        if not isinstance(rings, list) or not rings:
            raise ValueError(f"{where}: a Polygon needs at least one linear ring")
        polygon, *holes = (_linear_ring(r, where, i) for i, r in enumerate(rings))
        # RFC 7946 (3.1.6): rings against the right-hand rule are read, not refused; a
        # Room's outline runs counter-clockwise and its holes clockwise
        polygon = _turned(polygon, counter_clockwise=True)
        holes = [_turned(h, counter_clockwise=False) for h in holes]
    centroid = props.get("centroid")
    if not isinstance(centroid, list) or len(centroid) != 2:
        raise ValueError(
            f"{where}: property 'centroid': expected [x, y], received {centroid!r:.80}"
        )
    cx, cy = (_number({"centroid": v}, "centroid", where) for v in centroid)
    return Room(
        id=_identifier(props, where),
        area_m2=_number(props, "area_m2", where),
        centroid=(cx, cy),
        polygon=polygon,
        bbox=_integers(props, "bbox_px", where, 4),
        holes=tuple(holes),
    )


def _linear_ring(value: Any, where: str, index: int) -> np.ndarray:
    """Ring ``index`` of a Polygon's coordinates (0 the exterior) without its closing
    position, float64 (K, 2); ValueError unless closed with 4 or more positions."""
    what = "exterior ring" if index == 0 else f"interior ring {index}"
    ring = _positions(value, f"{where} {what}")
    if ring.shape[0] < 4 or not np.array_equal(ring[0], ring[-1]):
        raise ValueError(f"{where}: the {what} must be closed (4 or more positions)")
    return ring[:-1].copy()


def _turned(ring: np.ndarray, *, counter_clockwise: bool) -> np.ndarray:
    """``ring`` (K, 2) running the other way, from the same first position, where it
    encloses area and does not run as asked (``counter_clockwise`` or clockwise)."""
    area = _signed_area(ring)
    if area == 0 or (area > 0) == counter_clockwise:
        return ring
    return np.concatenate([ring[:1], ring[:0:-1]])


def _identifier(props: dict, where: str) -> int:
    value = props.get("id")
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{where}: property 'id': expected an integer >= 1, received {value!r}")
    return value


def _read_door(props: dict, geometry: dict, where: str):
    from ..rooms import Door

    if geometry.get("type") != "LineString":
        raise ValueError(
            f"{where}: geometry: expected a LineString for a door, received "
            f"{geometry.get('type')!r}"
        )
    return Door(
        id=_identifier(props, where),
        rooms=_integers(props, "rooms", where, 2),
        ends_px=_points(props.get("ends_px"), np.int64, f"{where} ends_px", count=2),
        ends_world=_positions(geometry.get("coordinates"), f"{where} line", count=2),
        width_m=_number(props, "width_m", where),
        pixels=_points(props.get("pixels"), np.int64, f"{where} pixels"),
    )


def load_rooms(path: str | Path) -> LoadedRooms:
    """Read a file written by :func:`save_rooms`.

    Parameters
    ----------
    path : str or Path
        A rooms GeoJSON file.

    Returns
    -------
    LoadedRooms
        The pair ``rooms, doors`` below, with the ``shape``, ``resolution_m`` and
        ``origin`` of the map the file records (each None where it states none).
    rooms : tuple of Room
        In file order (id order as written), with ``polygon`` float64 (K, 2) world
        metres (the exterior ring, the closing position dropped, counter-clockwise),
        ``holes`` (the interior rings, likewise, clockwise) and ``bbox`` from
        ``bbox_px``.  A ring that runs the other way (another tool's file; RFC 7946
        asks readers not to refuse it) is read turned round, from the same first
        position.
    doors : tuple of Door
        In file order, with ``ends_px`` int64 (2, 2), ``ends_world`` float64 (2, 2) (the
        line's coordinates) and ``pixels`` int64 (K, 2).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If it is not a file, not valid JSON, or not a rooms GeoJSON, or if room or door
        ids repeat, a door does not join two distinct rooms of the file, or a value is
        one no segmentation has (a ``resolution_m`` no map has, an ``origin`` that is no
        pose, a negative area or width, a room's bounding box or a door's ends or pixels
        off the map); the message names the file and the feature or field.

    Notes
    -----
    A position of a ring or a door's line may hold an altitude as a third element
    (``[x, y, z]``, RFC 7946 3.1.1, as other GIS tools write): it must be a finite number
    and is ignored; a fourth element is refused.

    A door's ends (``ends_px``, and its line where the file states the map's shape,
    resolution and origin) lie on the map's pixels, those on its border included:
    :func:`topojax.segment_rooms` never ends a doorway past the map's edge.
    """
    from ..rooms import LoadedRooms

    p = existing_file("path", path)
    try:
        doc = loads_unique(p.read_text(encoding="utf-8"))
    except DuplicateKeyError as exc:
        raise ValueError(f"rooms file {p}: {exc}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"rooms file {p} is not valid JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("type") != "FeatureCollection":
        raise ValueError(f"rooms file {p} is not a GeoJSON FeatureCollection")
    features = doc.get("features")
    if not isinstance(features, list):
        raise ValueError(f"rooms file {p}: 'features' must be a list")
    meta = doc.get(_MEMBER)
    if meta is None and not features:
        raise ValueError(f"rooms file {p}: an empty FeatureCollection without {_MEMBER!r}")
    if meta is not None and (not isinstance(meta, dict) or meta.get("version") != _VERSION):
        raise ValueError(f"rooms file {p}: {_MEMBER!r} is not version {_VERSION} rooms data")
    rooms, doors = [], []
    for i, feat in enumerate(features):
        where = f"rooms file {p}: features[{i}]"
        if not isinstance(feat, dict) or feat.get("type") != "Feature":
            raise ValueError(f"{where} is not a GeoJSON Feature")
        props = feat.get("properties")
        geometry = feat.get("geometry")
        if not isinstance(props, dict) or not isinstance(geometry, dict):
            raise ValueError(f"{where} needs 'properties' and a 'geometry' (objects)")
        kind = props.get("kind")
        if kind == "room":
            rooms.append((where, _read_room(props, geometry, where)))
        elif kind == "door":
            doors.append((where, _read_door(props, geometry, where)))
        else:
            hint = " (a topojax graph? read it with load_graph)" if "feature" in props else ""
            raise ValueError(
                f"{where} has kind {kind!r}; expected 'room' or 'door': not a rooms GeoJSON{hint}"
            )
    shape, resolution_m, origin = _map_frame(meta, f"rooms file {p}: {_MEMBER}")
    _check_pixels(rooms, doors, shape)
    if None not in (shape, resolution_m, origin):
        _check_lines(doors, shape, resolution_m, origin)
    _check_links(rooms, doors)
    return LoadedRooms(
        (r for _, r in rooms),
        (d for _, d in doors),
        shape=shape,
        resolution_m=resolution_m,
        origin=origin,
    )


def _map_frame(meta, where: str) -> tuple:
    """``shape`` [H, W], ``resolution_m`` and ``origin`` (x, y, yaw) of the foreign member
    ``meta``, each None where it states none; ValueError naming the field otherwise."""
    if not isinstance(meta, dict):
        return None, None, None
    shape, res, origin = (meta.get(k) for k in ("shape", "resolution_m", "origin"))
    if shape is not None and not (
        isinstance(shape, list)
        and len(shape) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in shape)
    ):
        raise ValueError(
            f"{where}: 'shape': expected [H, W] (two positive integers), received {shape!r:.80}"
        )
    try:  # a bad field is a bad file: ValueError, whatever its type
        res = None if res is None else metres_per_pixel("resolution_m", res)
    except (TypeError, ValueError):
        raise ValueError(
            f"{where}: 'resolution_m': expected a number of metres per pixel from "
            f"{MIN_RESOLUTION_M:g} to {MAX_RESOLUTION_M:g}, received {res!r:.80}"
        ) from None
    try:
        origin = None if origin is None else pose("origin", origin)
    except (TypeError, ValueError):
        raise ValueError(
            f"{where}: 'origin': expected [x, y, yaw] (three finite numbers: metres, metres, "
            f"radians), received {origin!r:.80}"
        ) from None
    return shape, res, origin


def _check_pixels(rooms: list, doors: list, shape) -> None:
    """Areas and widths >= 0, room bounding boxes, door ends and door pixels >= 0 and
    inside the map ``shape`` ([H, W], where the file states it)."""
    h, w = shape if shape is not None else (math.inf, math.inf)
    inside = "" if shape is None else f", inside the map's {h} x {w} pixels"
    for at, room in rooms:
        r0, c0, r1, c1 = room.bbox
        if room.area_m2 < 0:
            raise ValueError(f"{at}: property 'area_m2': expected >= 0, received {room.area_m2}")
        if not (0 <= r0 <= r1 < h and 0 <= c0 <= c1 < w):
            raise ValueError(
                f"{at}: property 'bbox_px': expected [row_min, col_min, row_max, col_max] "
                f"(inclusive, >= 0){inside}, received {list(room.bbox)}"
            )
    for at, door in doors:
        if door.width_m < 0:
            raise ValueError(f"{at}: property 'width_m': expected >= 0, received {door.width_m}")
        # segment_rooms ends a doorway on an obstacle pixel of the map, never past its
        # edge (a gap between a wall and the edge is no doorway): the ends may lie on the
        # border pixels, as the doorway's own pixels may
        for name, px, what in (
            ("ends_px", door.ends_px, "two pixels"),
            ("pixels", door.pixels, "pixels"),
        ):
            if px.size and not ((px >= 0).all() and (px[:, 0] < h).all() and (px[:, 1] < w).all()):
                raise ValueError(
                    f"{at}: property {name!r}: expected {what} (row, col) >= 0{inside}, "
                    f"received {px.tolist()!r:.80}"
                )


def _check_lines(doors: list, shape, resolution_m: float, origin) -> None:
    """Each door's line ends (world metres) on the map of ``shape``, ``resolution_m`` and
    ``origin``: within the outer edges of its pixels."""
    from ..maps.occupancy import world_to_grid

    h, w = shape
    for at, door in doors:
        xy = door.ends_world
        rows, cols = world_to_grid(
            xy[:, 0], xy[:, 1], height=h, resolution_m=resolution_m, origin=origin
        )
        if not ((rows >= -0.5) & (rows <= h - 0.5) & (cols >= -0.5) & (cols <= w - 0.5)).all():
            raise ValueError(
                f"{at}: geometry: expected a door's two ends [x, y] on the map's {h} x {w} "
                f"pixels, received {xy.tolist()!r:.80}"
            )


def _check_links(rooms: list, doors: list) -> None:
    """Room and door ids unique, and each door between two distinct rooms of the file,
    ascending (as :func:`save_rooms` writes them); ValueError naming the feature."""
    ids: set[int] = set()
    for where, room in rooms:
        if room.id in ids:
            raise ValueError(f"{where}: property 'id': room {room.id} appears twice")
        ids.add(room.id)
    door_ids: set[int] = set()
    for where, door in doors:
        if door.id in door_ids:
            raise ValueError(f"{where}: property 'id': door {door.id} appears twice")
        door_ids.add(door.id)
        a, b = door.rooms
        if not (a < b and a in ids and b in ids):
            raise ValueError(
                f"{where}: property 'rooms': expected two ascending ids of rooms in the "
                f"file, received {[a, b]}"
            )


# ---------------------------------------------------------------------- picture


def room_colours(n: int) -> np.ndarray:
    """Colours of rooms 1 .. ``n``: uint8 (n, 3) RGB, distinct, the same for every map.

    The first :data:`_HUE_COLOURS` step their hues by the golden ratio (neighbouring ids
    far apart on the colour wheel) at three saturations and values; those round to fewer
    than 8000 distinct colours, so the rooms after them (maps of specks) take the RGB
    cube in a scrambled order.  None is a grey, so none is black, grey or white.

    Raises
    ------
    ValueError
        For more rooms than there are colours that are not grey.
    """
    n = max(int(n), 0)
    if n > _MAX_COLOURS:
        raise ValueError(
            f"n: expected at most {_MAX_COLOURS} rooms (the RGB colours that are not grey), "
            f"received {n}"
        )
    out = np.empty((n, 3), np.uint8)
    for k in range(min(n, _HUE_COLOURS)):  # every one new (checked in the tests)
        hue = (k * _GOLDEN) % 1.0
        sat = (0.65, 0.9, 0.45)[k % 3]
        val = (0.95, 0.75, 0.85)[(k // 3) % 3]
        out[k] = [int(round(255 * c)) for c in colorsys.hsv_to_rgb(hue, sat, val)]
    if n > _HUE_COLOURS:
        out[_HUE_COLOURS:] = _scrambled_colours(n - _HUE_COLOURS, out[:_HUE_COLOURS])
    return out


def _scrambled_colours(n: int, taken: np.ndarray) -> np.ndarray:
    """``n`` RGB colours (uint8 (n, 3)), none grey nor in ``taken`` (uint8 (K, 3)): the
    24-bit colours ``j * _SCRAMBLE mod 2**24`` for j = 0, 1, ... (each once, the step
    being odd) less those."""
    codes = (np.arange(n + taken.shape[0] + 256, dtype=np.int64) * _SCRAMBLE) % (1 << 24)
    rgb = np.stack([codes >> 16, (codes >> 8) & 255, codes & 255], axis=1)
    grey = (rgb[:, 0] == rgb[:, 1]) & (rgb[:, 1] == rgb[:, 2])
    used = np.isin(codes, taken.astype(np.int64) @ np.array([1 << 16, 1 << 8, 1]))
    return rgb[~grey & ~used][:n].astype(np.uint8)


def room_picture(seg) -> np.ndarray:
    """The label picture of :func:`save_room_labels`: uint8 (H, W, 3) RGB."""
    seg = _check_seg(seg)
    labels = np.asarray(seg.labels)
    palette = np.empty((int(labels.max(initial=0)) + 1, 3), np.uint8)
    palette[0] = _GREY
    palette[1:] = room_colours(palette.shape[0] - 1)
    rgb = palette[labels]
    occupied = getattr(seg.occupancy, "occupied", None)
    if occupied is not None:
        rgb[(labels == 0) & np.asarray(occupied, bool)] = _BLACK
    for door in seg.doors:
        pix = np.asarray(door.pixels, np.int64).reshape(-1, 2)
        rgb[pix[:, 0], pix[:, 1]] = _WHITE
    return rgb


def save_room_labels(seg, path: str | Path) -> Path:
    """Write the room labels as a colour PNG, one picture pixel per map pixel.

    Parameters
    ----------
    seg : RoomSegmentation
    path : str or Path
        Output ``.png`` file; its folder must exist.  Written atomically.

    Returns
    -------
    Path
        The written path.

    Raises
    ------
    ValueError
        If ``path`` does not end in ``.png`` (the bytes are PNG whatever it is named).

    Notes
    -----
    RGB, no alpha, row 0 at the top (as the map image): room ``i`` in colour
    ``room_colours(n)[i - 1]`` (:func:`room_colours`: distinct, the same for every map),
    pixels of no room black on obstacles and grey (128, 128, 128) elsewhere, door pixels
    white.
    """
    import cv2

    p = path_like("path", path)
    refuse_suffix_only("path", p, (".png",))
    if p.suffix.lower() != ".png":
        raise ValueError(f"path: expected a .png file name, received {str(p)!r}")
    output_file_in_folder(p, name="path")  # before the work
    rgb = room_picture(seg)
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(rgb[..., ::-1]))
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
        raise ValueError(f"cannot encode the room labels of {path} as PNG")
    atomic_write_bytes(p, buf.tobytes())
    return p


# ---------------------------------------------------------------------- room graph

#: Room-graph formats and their suffixes.
_GRAPH_SUFFIXES = {".graphml": "graphml", ".json": "json"}


def room_graph(seg):
    """The room graph written by :func:`save_room_graph`: :attr:`RoomSegmentation.graph`
    with the nodes' ``bbox_px`` and the graph attributes ``resolution_m``, ``origin``,
    ``shape`` and ``n_rooms``."""
    seg = _check_seg(seg)
    g = seg.graph
    for room in seg.rooms:
        g.nodes[room.id]["bbox_px"] = tuple(int(v) for v in room.bbox)
    g.graph.update(
        resolution_m=float(seg.resolution_m),
        origin=tuple(float(v) for v in seg.origin),
        shape=tuple(int(v) for v in seg.labels.shape),
        n_rooms=seg.n_rooms,
    )
    return g


def save_room_graph(seg, path: str | Path) -> Path:
    """Write the room graph: rooms as nodes, doors as edges.

    Parameters
    ----------
    seg : RoomSegmentation
    path : str or Path
        ``.graphml`` (GraphML) or ``.json`` (networkx node-link, ``"edges"`` layout); its
        folder must exist.  Written atomically.

    Returns
    -------
    Path
        The written path.

    Notes
    -----
    Nodes are the room ids (int) with ``area_m2`` (m²), ``centroid`` ``(x, y)`` metres
    and ``bbox_px`` ``(row_min, col_min, row_max, col_max)``; one edge per pair of rooms
    with doors between them, with ``doors`` (their ids, a list) and ``width_m`` (the
    widest); graph attributes ``resolution_m``, ``origin``, ``shape``, ``n_rooms``.
    Written by :func:`topojax.save_graph` as a multigraph (edge keys 0): GraphML holds
    only scalars, so tuples and lists are JSON strings there (``"[1, 4]"``), in JSON
    they are lists; :func:`topojax.load_graph` gives back the tuples and lists.
    """
    from .files import save_graph

    p = path_like("path", path)
    refuse_suffix_only("path", p, _GRAPH_SUFFIXES)
    fmt = _GRAPH_SUFFIXES.get(p.suffix.lower())
    if fmt is None:
        raise ValueError(
            f"path: expected a room-graph file ending in {sorted(_GRAPH_SUFFIXES)}, "
            f"received {str(p)!r}"
        )
    output_file_in_folder(p, name="path")  # before the work
    return save_graph(room_graph(seg), p, format=fmt)


def save_room_files(seg, stem: str | Path) -> list[Path]:
    """Write every rooms output beside each other: ``STEM_rooms.geojson``
    (:func:`save_rooms`), ``STEM_rooms.png`` (:func:`save_room_labels`),
    ``STEM_rooms.graphml`` and ``STEM_rooms.json`` (:func:`save_room_graph`).

    Parameters
    ----------
    seg : RoomSegmentation
        The rooms to write.
    stem : str or os.PathLike
        Folder and file-name start of the four files (``out/intel`` writes
        ``out/intel_rooms.geojson`` ...).

    Returns
    -------
    list of Path
        The written files, in the order of :data:`ROOM_FILE_SUFFIXES`.
    """
    seg = _check_seg(seg)
    base = path_like("stem", stem)
    if base.name in ("", ".", ".."):  # a folder: no name to put the suffixes on
        raise ValueError(
            f"stem: expected a path ending in a file name (STEM of STEM_rooms.geojson), "
            f"received {stem!r}"
        )
    geojson, png, graphml, nodelink = (
        base.with_name(base.name + suffix) for suffix in ROOM_FILE_SUFFIXES
    )
    return [
        save_rooms(seg, geojson),
        save_room_labels(seg, png),
        save_room_graph(seg, graphml),
        save_room_graph(seg, nodelink),
    ]
