"""Snapshots of an incremental mapper at every graph update, for the viewer's timeline.

A :class:`Timeline` is fed every scan report of a replay (``record(mapper, report,
scan)``); at each report with a graph (or room) update it keeps the graph, the rooms and
a small picture of the map, and with each scan the robot's position.  The viewer plays
them back: the graph at every update, what the update added and removed, and the path
driven so far.  Edges are kept once each (the mapper's edge keys are stable and an edge
never changes in place), so a long replay costs little more than its final graph.
"""

from __future__ import annotations

import gzip
import json
import math
import zlib
from pathlib import Path

import numpy as np

from .._cpus import MemoryRefusal, available_memory_bytes, byte_size
from .._validate import existing_file, flag, instance_of, int_at_least
from ._encode import packed, pyramid, unpacked
from ._graphs import KIND_NAMES
from ._rooms_data import rooms_payload

__all__ = ["Timeline"]

_FORMAT = "topojax-timeline"
_VERSION = 1


class Timeline:
    """The graph of an :class:`~topojax.IncrementalMapper` at every graph update.

    Parameters
    ----------
    max_map_px : int
        Longest side, pixels, of the map picture kept with each update (the map
        downscaled, obstacles kept; default 1024); 0 keeps none (the view then shows the
        final map under every update).

    Examples
    --------
    >>> timeline = tj.Timeline()                                    # doctest: +SKIP
    >>> for scan in scans:                                          # doctest: +SKIP
    ...     timeline.record(mapper, mapper.add_scan(scan), scan)
    >>> tj.write_view(mapper, "view.html", timeline=timeline)       # doctest: +SKIP
    """

    def __init__(self, *, max_map_px: int = 1024) -> None:
        self.max_map_px = int_at_least("max_map_px", max_map_px, 0)
        self._frames: list[dict] = []
        self._pool_index: dict[int, int] = {}
        self._pool: list[tuple[np.ndarray, float, float, float]] = []
        self._path: list[tuple[int, float, float]] = []
        self._last_keys: set[int] = set()
        self._rooms: list[list[dict]] = []
        self._loaded: dict | None = None

    @property
    def n_frames(self) -> int:
        """Graph updates recorded."""
        if self._loaded is not None:
            return len(self._loaded["frames"])
        return len(self._frames)

    def last_counts(self) -> tuple[int, int] | None:
        """Vertices and edges of the last graph recorded, or None before the first."""
        frames = self._loaded["frames"] if self._loaded is not None else self._frames
        if not frames:
            return None
        return int(frames[-1]["ids"]["n"]), int(frames[-1]["edges"]["n"])

    def __repr__(self) -> str:
        from .._words import counted

        frames = self._loaded["frames"] if self._loaded is not None else self._frames
        if self._loaded is not None:
            poses = int(self._loaded["path"]["scan"]["n"])
        else:
            poses = len(self._path)
        if frames:  # scans counted from 1, as the page shows them
            first, last = frames[0]["scan"] + 1, frames[-1]["scan"] + 1
            n, e = self.last_counts()
            text = (
                f"{counted(len(frames), 'update')} at scan{'s' * (first != last)} {first}"
                f"{f' to {last}' if first != last else ''}, {counted(poses, 'robot pose')}, "
                f"last graph {counted(n, 'vertex', 'vertices')}, {counted(e, 'edge')}"
            )
        else:
            text = f"no update yet, {counted(poses, 'robot pose')}"
        if self._loaded is not None:
            return f"Timeline({text}; loaded from a file, to view only)"
        return f"Timeline({text}, max_map_px={self.max_map_px})"

    def _last_map_box(self) -> list[float] | None:
        """The world box ``[x_min, y_min, x_max, y_max]`` of the last map picture kept,
        or None when no frame has one (``max_map_px=0``)."""
        frames = self._loaded["frames"] if self._loaded is not None else self._frames
        for frame in reversed(frames):
            if frame.get("map") is not None:
                return [float(v) for v in frame["map"]["box"]]
        return None

    def _continuation(self) -> dict:
        """What :meth:`load` needs to extend a saved timeline: the mapper's edge key of
        each pooled edge, the keys of the last snapshot and ``max_map_px``."""
        return {
            "keys": list(self._pool_index),
            "last": sorted(self._last_keys),
            "max_map_px": self.max_map_px,
        }

    def _continue(self, body: dict, cont: dict) -> None:
        """Take up a saved ``body`` (:meth:`payload`) with its :meth:`_continuation`."""
        keys = [int(k) for k in cont["keys"]]
        pool = body["pool"]
        sizes = unpacked(pool["sizes"])
        xy = unpacked(pool["xy"]).reshape(-1, 2)
        if len(keys) != sizes.size or int(sizes.sum()) != xy.shape[0]:
            raise ValueError("the edge pool and its keys disagree")
        pieces = np.split(xy, np.cumsum(sizes)[:-1]) if sizes.size else []
        stats = zip(*(unpacked(pool[k]).tolist() for k in ("len", "cmin", "cmean")), strict=True)
        self._pool = [(xy_k, *st) for xy_k, st in zip(pieces, stats, strict=True)]
        self._pool_index = {k: i for i, k in enumerate(keys)}
        self._last_keys = {int(k) for k in cont["last"]}
        path = body["path"]
        scans, px, py = (unpacked(path[k]).tolist() for k in ("scan", "x", "y"))
        self._path = list(zip(scans, px, py, strict=True))
        self._frames = body["frames"]
        self._rooms = body["rooms"]

    def record(self, mapper, report, scan=None) -> bool:
        """Keep what one :meth:`~topojax.IncrementalMapper.add_scan` did.

        Parameters
        ----------
        mapper : IncrementalMapper
            The mapper the report comes from.
        report : ScanReport
            Its report; a snapshot is kept when it has a ``graph_update`` or a
            ``rooms_update``.
        scan : Scan, optional
            The scan; its pose extends the robot's path.

        Returns
        -------
        bool
            Whether a snapshot was kept.
        """
        from ..incremental import IncrementalMapper, ScanReport
        from ..scans import Scan

        instance_of("mapper", mapper, IncrementalMapper)
        instance_of("report", report, ScanReport)
        if scan is not None:
            instance_of("scan", scan, Scan)
        self._writable()
        if scan is not None:
            x, y, _ = scan.pose
            self._path.append((int(report.index), float(x), float(y)))
        if report.graph_update is None and getattr(report, "rooms_update", None) is None:
            return False
        rooms = report.rooms_update is not None
        before = len(self._frames)
        self.snapshot(mapper, scan_index=int(report.index), rooms=rooms)
        return len(self._frames) > before

    def snapshot(self, mapper, *, scan_index: int | None = None, rooms: bool = False) -> None:
        """Keep the mapper's graph as of its last graph update (e.g. after a final
        :meth:`~topojax.IncrementalMapper.update_graph`), unless the last snapshot is of
        the same scan with the same graph (and rooms): a final update with nothing left
        to change adds no step.

        Parameters
        ----------
        mapper : IncrementalMapper
        scan_index : int, optional
            The scan it belongs to, from 0 (default: the mapper's last).
        rooms : bool
            Also keep the mapper's rooms (otherwise those of the previous snapshot stay).
        """
        from ..incremental import IncrementalMapper

        instance_of("mapper", mapper, IncrementalMapper)
        if scan_index is not None:
            scan_index = int_at_least("scan_index", scan_index, 0)
        rooms = flag("rooms", rooms)
        self._writable()
        if mapper.pixel_bbox is None:
            return
        graph = mapper.graph
        keys, edges = [], graph.edges(keys=True, data=True)
        for _, _, key, data in edges:
            key = int(key)
            if key not in self._pool_index:
                self._pool_index[key] = len(self._pool)
                self._pool.append(
                    (
                        np.asarray(data["world"], np.float32).reshape(-1, 2),
                        float(data.get("length_m", np.nan)),
                        float(data.get("min_clearance_m", np.nan)),
                        float(data.get("mean_clearance_m", np.nan)),
                    )
                )
            keys.append(key)
        now = set(keys)
        added = sorted(self._pool_index[k] for k in now - self._last_keys)
        removed = sorted(self._pool_index[k] for k in self._last_keys - now)
        self._last_keys = now
        nodes = list(graph.nodes(data=True))
        xy = np.array([d["world"] for _, d in nodes], np.float64).reshape(-1, 2)
        kind = [
            KIND_NAMES.index(d.get("kind")) if d.get("kind") in KIND_NAMES[:-1] else 4
            for _, d in nodes
        ]
        frame = {
            "scan": mapper.n_scans - 1 if scan_index is None else int(scan_index),
            "ids": packed([int(n) for n, _ in nodes], np.int32),
            "x": packed(xy[:, 0], np.float32),
            "y": packed(xy[:, 1], np.float32),
            "kind": packed(kind, np.uint8),
            "clear": packed([float(d.get("clearance_m", np.nan)) for _, d in nodes], np.float32),
            "edges": packed([self._pool_index[k] for k in keys], np.int32),
        }
        room_list = rooms_payload(mapper.rooms)["rooms"] if rooms else None
        if self._repeats_last(frame, added or removed, room_list):
            return
        if rooms:
            self._rooms.append(room_list)
        frame["added"] = packed(added, np.int32)
        frame["removed"] = packed(removed, np.int32)
        frame["rooms"] = len(self._rooms) - 1
        frame["map"] = self._map_picture(mapper)
        self._frames.append(frame)

    def _repeats_last(self, frame: dict, changed, room_list) -> bool:
        """Whether ``frame`` (without its edge changes, rooms and map) is the last
        snapshot again: the same scan, no edge ``changed``, the same vertices and, with
        a ``room_list``, the same rooms."""
        if not self._frames or changed:
            return False
        last = self._frames[-1]
        if any(last[k] != v for k, v in frame.items()):
            return False
        if room_list is None:
            return True
        return last["rooms"] >= 0 and self._rooms[last["rooms"]] == room_list

    def _map_picture(self, mapper) -> dict | None:
        if self.max_map_px == 0:
            return None
        occ = mapper.occupancy
        image = occ.to_image()
        h, w = image.shape
        levels = pyramid(image, reduce="map", max_side_px=self.max_map_px)
        finest = levels["levels"][0]
        ox, oy, _ = occ.origin
        res = occ.resolution_m
        return {
            "box": [ox, oy, ox + w * res, oy + h * res],
            "level": finest,
        }

    def _writable(self) -> None:
        if self._loaded is not None:
            raise ValueError("this timeline was loaded from a file: it can be viewed, not extended")

    def payload(self) -> dict:
        """The timeline as the viewer's page reads it (JSON-able)."""
        if self._loaded is not None:
            return self._loaded
        pool = self._pool
        sizes = [len(p[0]) for p in pool]
        xy = np.concatenate([p[0] for p in pool]) if pool else np.zeros((0, 2), np.float32)
        path = np.array(self._path, np.float64).reshape(-1, 3)
        return {
            "frames": self._frames,
            "pool": {
                "sizes": packed(sizes, np.int32),
                "xy": packed(xy.ravel(), np.float32),
                "len": packed([p[1] for p in pool], np.float32),
                "cmin": packed([p[2] for p in pool], np.float32),
                "cmean": packed([p[3] for p in pool], np.float32),
            },
            "path": {
                "scan": packed(path[:, 0], np.int32),
                "x": packed(path[:, 1], np.float64),
                "y": packed(path[:, 2], np.float64),
            },
            "rooms": self._rooms,
            "kinds": list(KIND_NAMES),
        }

    def save(self, path) -> Path:
        """Write the timeline to a gzip-compressed JSON file (e.g. ``timeline.json.gz``
        next to a replay's outputs, where ``topojax view`` finds it)."""
        from .._fs import atomic_write_bytes, output_file_in_folder

        p = output_file_in_folder(path, name="path")
        doc = {"format": _FORMAT, "version": _VERSION, "timeline": self.payload()}
        if self._loaded is None:
            doc["continue"] = self._continuation()
        data = gzip.compress(json.dumps(doc, separators=(",", ":")).encode("utf-8"), mtime=0)
        atomic_write_bytes(p, data)
        return p

    @classmethod
    def load(cls, path) -> Timeline:
        """Read a file written by :meth:`save`.  A timeline saved while recording (not
        one loaded from a file) records on where it stopped: :meth:`record` extends it as
        if it had not been saved.

        Raises
        ------
        FileNotFoundError
            If ``path`` does not exist.
        ValueError
            If it is not a file (a folder), not a timeline file or is corrupt (the message
            names the file).
        MemoryError
            If its JSON text unpacks to more than a quarter of the memory available
            (parsed, it takes a few times its text), said once that much is unpacked.
        """
        p = existing_file("path", path)
        try:
            text = _gunzip(p.read_bytes(), p).decode("utf-8")
            doc = json.loads(text, parse_constant=_no_constant)
        except _NotFinite as exc:
            raise ValueError(f"timeline file {p} is corrupt: {exc}") from None
        except (OSError, EOFError, ValueError, UnicodeDecodeError, zlib.error) as exc:
            raise ValueError(
                f"timeline file {p} is not a gzip-compressed JSON file: {exc}"
            ) from None
        if not isinstance(doc, dict) or doc.get("format") != _FORMAT:
            raise ValueError(f"timeline file {p} is not a topojax timeline")
        if doc.get("version") != _VERSION:
            raise ValueError(
                f"timeline file {p} has version {doc.get('version')!r}; this topojax reads "
                f"version {_VERSION}"
            )
        body = doc.get("timeline")
        if not isinstance(body, dict) or not isinstance(body.get("frames"), list):
            raise ValueError(f"timeline file {p} has no frames")
        cont = doc.get("continue")
        if not body["frames"] and cont is None:  # one saved while recording records on
            raise ValueError(f"timeline file {p} has no frames (no graph update recorded)")
        try:
            _check_body(body)
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"timeline file {p} is corrupt: {exc}") from None
        if cont is None:  # saved from a loaded timeline: to view only
            out = cls()
            out._loaded = body
            return out
        try:
            out = cls(max_map_px=cont["max_map_px"])
            out._continue(body, cont)
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"timeline file {p} is corrupt: {exc}") from None
        return out


_FRAME_ARRAYS = ("ids", "x", "y", "kind", "clear", "edges", "added", "removed")


def _gunzip(data: bytes, path: Path) -> bytes:
    """The gzip-compressed ``data`` (read from ``path``; one or more members) unpacked a
    megabyte at a time, up to a quarter of the memory available: a MemoryError naming the
    file beyond that (a small file can unpack to gigabytes, and gzip records no size to
    trust); ``EOFError`` for a stream cut short, ``zlib.error`` for a damaged one."""
    available = available_memory_bytes()
    limit = None if available is None else available // 4
    parts, total, rest = [], 0, data
    while rest:
        stream = zlib.decompressobj(wbits=31)  # a gzip member
        pending = rest
        while not stream.eof:
            piece = stream.decompress(pending, 1 << 20)
            pending = stream.unconsumed_tail
            if not piece and not pending:  # all read, no end of stream: cut short
                break
            total += len(piece)
            if limit is not None and total > limit:
                raise MemoryRefusal(
                    f"timeline file {path}: unpacks to more than {byte_size(limit)}, a "
                    f"quarter of the {byte_size(available)} of memory available (its parsed "
                    "JSON takes a few times its text)"
                )
            parts.append(piece)
        if not stream.eof:
            raise EOFError("compressed file ended before the end-of-stream marker was reached")
        rest = stream.unused_data
    return b"".join(parts)


class _NotFinite(ValueError):
    """A NaN or Infinity in a timeline file."""


def _no_constant(name: str):
    """``json.loads``' ``parse_constant``: :meth:`Timeline.save` writes no NaN or
    Infinity, and the page's JSON cannot hold them."""
    raise _NotFinite(f"it holds {name}, expected finite numbers only")


def _finite(values: np.ndarray, what: str) -> np.ndarray:
    if not np.isfinite(values).all():
        raise ValueError(f"{what}: expected finite coordinates, received NaN or infinity")
    return values


def _numbers(value, what: str, *, count: int | None = None, pairs: bool = False) -> None:
    """Raise a ValueError naming ``what`` unless ``value`` is a list of numbers (of
    ``count`` of them, or of an even count when ``pairs``)."""
    if (
        not isinstance(value, list)
        or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            for v in value
        )
        or (count is not None and len(value) != count)
        or (pairs and len(value) % 2)
    ):
        size = f"{count} " if count is not None else ""
        kind = "x, y pairs of finite numbers" if pairs else "finite numbers"
        raise ValueError(f"{what}: expected a list of {size}{kind}, received {value!r:.80}")


def _check_rooms(rooms) -> None:
    """The rooms of each snapshot as :func:`rooms_payload` gives them (the page draws their
    rings and writes their ids)."""
    instance_of("'rooms'", rooms, list)
    for i, snapshot in enumerate(rooms):
        instance_of(f"rooms {i}", snapshot, list)
        for j, room in enumerate(snapshot):
            where = f"rooms {i}, room {j}"
            instance_of(where, room, dict, "object")
            if isinstance(room.get("id"), bool) or not isinstance(room.get("id"), int):
                raise ValueError(f"{where}: 'id': expected an int, received {room.get('id')!r}")
            area = room.get("area_m2")
            if not isinstance(area, (int, float)) or isinstance(area, bool) or not area >= 0:
                raise ValueError(f"{where}: 'area_m2': expected a number >= 0, received {area!r}")
            _numbers(room.get("label"), f"{where}: 'label'", count=2)
            _numbers(room.get("polygon"), f"{where}: 'polygon'", pairs=True)
            instance_of(f"{where}: 'holes'", room.get("holes"), list)
            for k, hole in enumerate(room["holes"]):
                _numbers(hole, f"{where}: hole {k}", pairs=True)


def _check_picture(picture, i: int) -> None:
    """A frame's map picture: its world ``box`` and one pyramid level of PNG tiles."""
    if picture is None:
        return
    expected = f"frame {i}: 'map': expected a map picture (box, level) or null"
    if not isinstance(picture, dict) or not isinstance(picture.get("level"), dict):
        raise ValueError(f"{expected}, received {picture!r:.80}")
    _numbers(picture.get("box"), f"frame {i}: 'map' 'box'", count=4)
    level = picture["level"]
    for key in ("step", "width", "height"):
        v = level.get(key)
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise ValueError(
                f"frame {i}: 'map' level {key!r}: expected an int >= 1, received {v!r}"
            )
    tiles = level.get("tiles")
    if not isinstance(tiles, list) or not all(
        isinstance(t, list)
        and len(t) == 3
        and all(isinstance(v, int) and not isinstance(v, bool) for v in t[:2])
        and isinstance(t[2], str)
        for t in tiles
    ):
        raise ValueError(
            f"frame {i}: 'map' level 'tiles': expected [row, col, PNG base64] lists, received "
            f"{tiles!r:.80}"
        )


def _check_body(body: dict) -> None:
    """Decode every packed array of a saved :meth:`Timeline.payload` and check that the
    frames agree with the edge pool, the rooms and each other, so that a damaged file is
    refused on loading rather than by the page in the browser.

    Raises
    ------
    KeyError, TypeError, ValueError
        Naming the frame and the part that is damaged.
    """
    pool = body["pool"]
    sizes = unpacked(pool["sizes"])
    n_pool = sizes.size
    for name in ("len", "cmin", "cmean"):
        if unpacked(pool[name]).size != n_pool:
            raise ValueError(f"pool {name!r}: expected {n_pool} values (one per edge)")
    xy = _finite(unpacked(pool["xy"]), "pool 'xy'")
    if (sizes < 0).any() or 2 * int(sizes.sum(dtype=np.int64)) != xy.size:
        raise ValueError(
            f"pool 'sizes': expected the point counts of the edges, {xy.size // 2} points in "
            f"all, received counts summing to {int(sizes.sum(dtype=np.int64))}"
            + (" (some negative)" if (sizes < 0).any() else "")
        )
    path = body["path"]
    if len({unpacked(path[k]).size for k in ("scan", "x", "y")}) != 1:
        raise ValueError("path: 'scan', 'x' and 'y' have different lengths")
    for k in ("x", "y"):
        _finite(unpacked(path[k]), f"path {k!r}")
    rooms = body["rooms"]
    _check_rooms(rooms)
    for i, frame in enumerate(body["frames"]):
        instance_of(f"frame {i}", frame, dict, "object")
        arrays = {}
        for k in _FRAME_ARRAYS:
            if k not in frame:
                raise ValueError(f"frame {i}: {k!r} is missing")
            try:
                arrays[k] = unpacked(frame[k])
            except ValueError as exc:
                raise ValueError(f"frame {i}: {k!r}: {exc}") from None
        if len({arrays[k].size for k in ("ids", "x", "y", "kind", "clear")}) != 1:
            raise ValueError(f"frame {i}: its vertex arrays have different lengths")
        for k in ("x", "y"):
            _finite(arrays[k], f"frame {i}: {k!r}")
        if arrays["kind"].size and not 0 <= arrays["kind"].min() <= arrays["kind"].max() < len(
            KIND_NAMES
        ):
            raise ValueError(
                f"frame {i}: 'kind': expected vertex kind codes 0 to {len(KIND_NAMES) - 1}"
            )
        for k in ("edges", "added", "removed"):
            if arrays[k].size and not 0 <= arrays[k].min() <= arrays[k].max() < n_pool:
                raise ValueError(f"frame {i}: {k!r} names edges outside the pool of {n_pool}")
        r = frame["rooms"]
        if isinstance(r, bool) or not isinstance(r, int) or not -1 <= r < len(rooms):
            raise ValueError(f"frame {i}: 'rooms': expected -1 to {len(rooms) - 1}, received {r!r}")
        if not isinstance(frame["scan"], int) or isinstance(frame["scan"], bool):
            raise TypeError(f"frame {i}: 'scan': expected an int, received {frame['scan']!r}")
        _check_picture(frame["map"], i)
