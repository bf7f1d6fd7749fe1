"""The result of a room segmentation: :class:`RoomSegmentation`, :class:`Room`,
:class:`Door`."""

from __future__ import annotations

from dataclasses import dataclass, field

import networkx as nx
import numpy as np

from .._validate import finite_pair
from ._kernels import label_stats
from ._outline import outline

__all__ = ["Door", "LoadedRooms", "Room", "RoomSegmentation", "build_segmentation", "relabel"]


@dataclass(frozen=True, eq=False)
class Room:
    """One room.

    Attributes
    ----------
    id : int
        Its label in :attr:`RoomSegmentation.labels` (from 1).
    area_m2 : float
        Area of its pixels (free pixels and the clutter it encloses), square metres.
    centroid : tuple[float, float]
        Mean world position (x, y) of its pixels, metres.
    polygon : float64 (K, 2)
        Outer outline in world (x, y) metres: one simple ring (no sides cross or touch),
        counter-clockwise, first point not repeated, no collinear points, along the
        outer edges of its pixel squares: rooms that meet share the edges between them.
        Only the largest of the room's parts not touching even at a corner is outlined.
        Pixels meeting only at a corner are joined by a neck: each of the ring's two
        passes there cuts 1/64 pixel off the empty pixel it turns round (1/8192 square
        pixels more area).
    bbox : tuple[int, int, int, int]
        ``(row_min, col_min, row_max, col_max)`` of its pixels, inclusive.
    holes : tuple of float64 (K, 2), default ()
        The rings round what the outlined part encloses without owning (the rooms
        inside a corridor loop, free space of no room), world (x, y) metres, clockwise,
        first point not repeated, no collinear points, along the pixel edges as
        ``polygon``; empty for most rooms (a room owns the clutter it encloses).  Each is
        simple and no two of these rings and ``polygon`` meet: where a hole meets
        another or the outside at a corner, each ring cuts that corner as above.
        ``polygon`` less its holes is the area of the outlined part, ``area_m2`` where
        the room is one part, and the polygons with holes of a segmentation's rooms do
        not overlap.
    label_point : tuple[float, float]
        Where to write the room's id: a world point (x, y), metres, inside ``polygon``
        and outside its holes (see the property).
    """

    id: int
    area_m2: float
    centroid: tuple[float, float]
    polygon: np.ndarray = field(repr=False)
    bbox: tuple[int, int, int, int]
    holes: tuple[np.ndarray, ...] = field(default=(), repr=False, kw_only=True)

    @property
    def label_point(self) -> tuple[float, float]:
        """World point (x, y), metres, where the room's id is written.

        The point of the outlined part farthest from its outline and holes (to 1/1000
        of the outline's larger side; of points as far, the nearest to ``centroid``),
        so inside the room where ``centroid`` is not (a ring round a courtyard, an L).
        ``centroid`` for an outline that encloses no area.  Computed on first use.
        """
        point = self.__dict__.get("_label_point")
        if point is None:
            point = _pole(self.polygon, self.holes, self.centroid)
            object.__setattr__(self, "_label_point", point)
        return point


@dataclass(frozen=True, eq=False)
class Door:
    """One doorway between two rooms.

    Attributes
    ----------
    id : int
        From 1, in the order of the rooms it joins.
    rooms : tuple[int, int]
        The two room ids, ascending.
    ends_px : int64 (2, 2)
        The two obstacle pixels (row, col) the doorway runs between.
    ends_world : float64 (2, 2)
        The same points in world (x, y) metres.
    width_m : float
        Free width of the doorway, metres.
    pixels : int64 (K, 2)
        Free pixels (row, col) on the doorway line.
    """

    id: int
    rooms: tuple[int, int]
    ends_px: np.ndarray
    ends_world: np.ndarray
    width_m: float
    pixels: np.ndarray = field(repr=False)

    def __repr__(self) -> str:
        px = tuple(tuple(int(v) for v in p) for p in np.asarray(self.ends_px).reshape(-1, 2))
        xy = ", ".join(
            f"({x:g}, {y:g})" for x, y in np.asarray(self.ends_world, float).reshape(-1, 2)
        )
        return (
            f"Door(id={self.id!r}, rooms={self.rooms!r}, ends_px={px}, ends_world=({xy}), "
            f"width_m={self.width_m!r})"
        )


class LoadedRooms(tuple):
    """The ``(rooms, doors)`` pair :func:`topojax.load_rooms` reads, with the map the file
    records: it unpacks as ``rooms, doors = ...``.

    Attributes
    ----------
    shape : (int, int) or None
        The map's ``(H, W)``; None where the file states none (another tool's file).
    resolution_m : float or None
    origin : (float, float, float) or None
        As :attr:`RoomSegmentation.origin`.
    """

    def __new__(cls, rooms, doors, *, shape=None, resolution_m=None, origin=None):
        pair = super().__new__(cls, (tuple(rooms), tuple(doors)))
        frame = {
            "shape": None if shape is None else tuple(int(v) for v in shape),
            "resolution_m": None if resolution_m is None else float(resolution_m),
            "origin": None if origin is None else tuple(float(v) for v in origin),
        }
        for name, value in frame.items():
            object.__setattr__(pair, name, value)
        return pair

    def __setattr__(self, name, value):
        raise AttributeError(f"LoadedRooms is read-only: cannot set {name!r}")

    def __reduce__(self):
        frame = {"shape": self.shape, "resolution_m": self.resolution_m, "origin": self.origin}
        return (_loaded_rooms, (self[0], self[1], frame))

    def __repr__(self) -> str:
        from .._words import counted

        text = f"{counted(len(self[0]), 'room')}, {counted(len(self[1]), 'door')}"
        if self.shape is not None:
            text += f", {self.shape[1]} x {self.shape[0]} px (w x h)"
        if self.resolution_m is not None:
            text += f" at {self.resolution_m:g} m/px"
        if self.origin is not None:
            text += f", origin {self.origin}"
        if (self.shape, self.resolution_m, self.origin) == (None, None, None):
            text += ", no map recorded"
        return f"LoadedRooms({text})"


def _loaded_rooms(rooms, doors, frame: dict) -> LoadedRooms:
    return LoadedRooms(rooms, doors, **frame)


@dataclass(frozen=True, eq=False)
class RoomSegmentation:
    """Rooms and doorways of one map.

    Attributes
    ----------
    labels : int32 (H, W)
        Room id of each pixel (0 = no room).
    rooms : tuple[Room, ...]
        In id order.
    doors : tuple[Door, ...]
        In id order.
    resolution_m : float
    origin : tuple[float, float, float]
        The map's origin (x, y, yaw) of pixel (H - 1, 0)'s outer corner, as map_server.
    timings_s : dict[str, float]
    """

    labels: np.ndarray
    rooms: tuple[Room, ...]
    doors: tuple[Door, ...]
    resolution_m: float
    origin: tuple[float, float, float]
    occupancy: object = field(repr=False)
    timings_s: dict = field(default_factory=dict)

    @property
    def n_rooms(self) -> int:
        return len(self.rooms)

    def __repr__(self) -> str:
        h, w = self.labels.shape
        rooms, doors = self.n_rooms, len(self.doors)
        return (
            f"RoomSegmentation({rooms} room{'s' * (rooms != 1)}, {doors} door"
            f"{'s' * (doors != 1)}, {w} x {h} px (w x h) at {self.resolution_m:g} m/px)"
        )

    @property
    def graph(self) -> nx.Graph:
        """Rooms as nodes (``area_m2``, ``centroid``), doors as edges (``doors``: their ids,
        ``width_m``: the widest)."""
        g = nx.Graph()
        for room in self.rooms:
            g.add_node(room.id, area_m2=room.area_m2, centroid=room.centroid)
        for door in self.doors:
            a, b = door.rooms
            if g.has_edge(a, b):
                g.edges[a, b]["doors"].append(door.id)
                g.edges[a, b]["width_m"] = max(g.edges[a, b]["width_m"], door.width_m)
            else:
                g.add_edge(a, b, doors=[door.id], width_m=door.width_m)
        return g

    def room_at(self, point) -> int:
        """Room id at a world point (x, y) in metres (0 outside every room and the map)."""
        x, y = finite_pair("point", point, "(x, y) in metres")  # bools are no numbers
        with np.errstate(over="ignore", invalid="ignore"):  # a point far off: inf pixels
            r, c = self.occupancy.world_to_pixel(x, y)
        h, w = self.labels.shape
        # compared as floats: a point so far off that its pixel overflows is off the map
        r, c = float(np.floor(r + 0.5)), float(np.floor(c + 0.5))
        if 0 <= r < h and 0 <= c < w:
            return int(self.labels[int(r), int(c)])
        return 0


_SQRT2 = float(np.sqrt(2.0))
#: How near the farthest point a label point is, as a share of the outline's larger side.
_LABEL_TOLERANCE = 1e-3
#: Corner offsets of a square cell's four quarters, in half its half side.
_QUARTERS = np.array([[-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0], [1.0, 1.0]])


def _pole(polygon, holes, fallback) -> tuple[float, float]:
    """The point inside ``polygon`` (float (K, 2)) and outside ``holes`` farthest from
    them all, found by splitting square cells (polylabel); ``fallback`` when the rings
    enclose no area."""
    rings = [np.asarray(r, np.float64).reshape(-1, 2) for r in (polygon, *holes)]
    if rings[0].shape[0] < 3:  # no outline to be inside of
        return (float(fallback[0]), float(fallback[1]))
    rings = [r for r in rings if r.shape[0] >= 3]
    if not np.isfinite(np.concatenate(rings)).all():
        return (float(fallback[0]), float(fallback[1]))
    a = np.concatenate(rings)
    b = np.concatenate([np.roll(r, -1, axis=0) for r in rings])
    lo, hi = rings[0].min(axis=0), rings[0].max(axis=0)
    cell = float(np.min(hi - lo))
    if not cell > 0:
        return (float(fallback[0]), float(fallback[1]))
    tol = _LABEL_TOLERANCE * float(np.max(hi - lo))
    h = cell / 2
    xs = np.arange(lo[0], hi[0], cell) + h
    ys = np.arange(lo[1], hi[1], cell) + h
    centres = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    best_d = -np.inf
    while True:
        with np.errstate(over="ignore", invalid="ignore"):
            d = _signed_distance(centres, a, b)
        if not np.isfinite(d).all():  # coordinates whose squares overflow (a damaged file)
            return (float(fallback[0]), float(fallback[1]))
        best_d = max(best_d, float(d.max()))
        if h * _SQRT2 <= tol or centres.shape[0] == 0:
            break
        centres = centres[d + h * _SQRT2 >= best_d - tol]  # may hold a point as far
        h /= 2
        centres = (centres[:, None, :] + h * _QUARTERS).reshape(-1, 2)
    if not best_d > 0:
        return (float(fallback[0]), float(fallback[1]))
    near = centres[d >= best_d - tol]
    pick = np.argmin(np.hypot(near[:, 0] - fallback[0], near[:, 1] - fallback[1]))
    return (float(near[pick, 0]), float(near[pick, 1]))


def _signed_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance (N,) of ``points`` (N, 2) to the sides ``a[k]``-``b[k]`` (K, 2) of closed
    rings, positive inside (an odd number of rings round the point), else negative."""
    out = np.empty(points.shape[0])
    ab = b - a
    length2 = np.maximum(np.einsum("kd,kd->k", ab, ab), np.finfo(float).tiny)
    step = max(1, 2_000_000 // max(a.shape[0], 1))
    for i in range(0, points.shape[0], step):
        p = points[i : i + step, None, :]
        t = np.clip(np.einsum("nkd,kd->nk", p - a, ab) / length2, 0.0, 1.0)
        dist = np.hypot(*np.moveaxis(p - a - t[..., None] * ab, -1, 0)).min(axis=1)
        y = p[..., 1]
        cross = (a[:, 1] > y) != (b[:, 1] > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = a[:, 0] + (y - a[:, 1]) * ab[:, 0] / ab[:, 1]
        inside = np.count_nonzero(cross & (p[..., 0] < x_at), axis=1) % 2 == 1
        out[i : i + step] = np.where(inside, dist, -dist)
    return out


def build_segmentation(occ, labels: np.ndarray, doors, box=None) -> RoomSegmentation:
    """The :class:`RoomSegmentation` of final ``labels`` and door cuts; ``box`` (a pair of
    slices), when given, holds every labelled pixel."""
    res = float(occ.resolution_m)
    if box is None:
        box = (slice(0, labels.shape[0]), slice(0, labels.shape[1]))
    # one memory layout whatever the box (a crop is strided, the whole map is not)
    part = np.ascontiguousarray(labels[box])
    r_off, c_off = int(box[0].start), int(box[1].start)  # Python ints in ``Room.bbox``
    n = int(part.max()) if part.size else 0
    if n:  # no room, nothing to measure: the compiled kernel is not even loaded
        count, sum_r, sum_c, boxes = label_stats(part, n)
        with np.errstate(invalid="ignore", divide="ignore"):
            # the map frame is an affine image of the pixel grid: mean of world = world of mean
            cx, cy = occ.pixel_to_world(sum_r / count + r_off, sum_c / count + c_off)
    rooms = []
    for rid in range(1, n + 1):
        if count[rid] == 0:
            continue
        q0, p0, q1, p1 = (int(v) for v in boxes[rid])
        mask = part[q0 : q1 + 1, p0 : p1 + 1] == rid
        r0, c0 = q0 + r_off, p0 + c_off
        ring, holes = outline(mask)
        rooms.append(
            Room(
                id=rid,
                area_m2=float(count[rid]) * res * res,
                centroid=(float(cx[rid]), float(cy[rid])),
                polygon=_world_ring(occ, ring, r0, c0, counter_clockwise=True),
                bbox=(r0, c0, q1 + r_off, p1 + c_off),
                holes=tuple(_world_ring(occ, h, r0, c0, counter_clockwise=False) for h in holes),
            )
        )
    out = []
    for d in sorted(doors, key=lambda d: (d.rooms, tuple(d.cut.centre))):
        ex, ey = occ.pixel_to_world(d.cut.ends[:, 0], d.cut.ends[:, 1])
        out.append(
            Door(
                id=len(out) + 1,
                rooms=d.rooms,
                ends_px=d.cut.ends.copy(),
                ends_world=np.stack([ex, ey], axis=1),
                width_m=float(d.cut.width_px) * res,
                pixels=d.cut.pixels.copy(),
            )
        )
    return RoomSegmentation(
        labels=labels.astype(np.int32),
        rooms=tuple(rooms),
        doors=tuple(out),
        resolution_m=res,
        origin=tuple(float(o) for o in occ.origin),
        occupancy=occ,
    )


def _world_ring(occ, ring: np.ndarray, r0: int, c0: int, *, counter_clockwise: bool):
    """``ring`` (pixel (row, col) of a crop whose first pixel is ``(r0, c0)``) in world
    (x, y) metres, turned to run counter-clockwise or clockwise in the map frame."""
    px, py = occ.pixel_to_world(ring[:, 0] + r0, ring[:, 1] + c0)
    poly = np.stack([px, py], axis=1)
    if poly.shape[0] >= 3:
        x, y = poly[:, 0], poly[:, 1]
        twice_area = x[:-1] @ y[1:] - x[1:] @ y[:-1] + x[-1] * y[0] - x[0] * y[-1]
        if (twice_area < 0) == counter_clockwise:
            poly = poly[::-1].copy()
    return poly


def relabel(seg: RoomSegmentation, lut: np.ndarray) -> RoomSegmentation:
    """``seg`` with room ``k`` renamed ``lut[k]`` (``lut[0] == 0``, distinct positive ids
    otherwise): labels, rooms (sorted by their new id) and the doors' rooms; door ids are
    renumbered from 1 in the order of the rooms they join."""
    lut = np.asarray(lut, np.int64)
    rooms = sorted(
        (
            Room(
                id=int(lut[r.id]),
                area_m2=r.area_m2,
                centroid=r.centroid,
                polygon=r.polygon,
                bbox=r.bbox,
                holes=r.holes,
            )
            for r in seg.rooms
        ),
        key=lambda r: r.id,
    )
    doors = []
    for d in seg.doors:
        a, b = int(lut[d.rooms[0]]), int(lut[d.rooms[1]])
        doors.append((min(a, b), max(a, b), d))
    doors.sort(key=lambda t: (t[0], t[1], tuple(t[2].ends_px.ravel())))
    new_doors = tuple(
        Door(
            id=k,
            rooms=(a, b),
            ends_px=d.ends_px,
            ends_world=d.ends_world,
            width_m=d.width_m,
            pixels=d.pixels,
        )
        for k, (a, b, d) in enumerate(doors, start=1)
    )
    return RoomSegmentation(
        labels=lut.astype(np.int32)[seg.labels],
        rooms=tuple(rooms),
        doors=new_doors,
        resolution_m=seg.resolution_m,
        origin=seg.origin,
        occupancy=seg.occupancy,
        timings_s=dict(seg.timings_s),
    )
