"""ROS 2 recordings (MCAP) of maps, topology graphs, rooms and scans, for Foxglove, RViz
and ``ros2 bag play``, written with ``rosbags`` (no ROS install needed).

One self-contained ``.mcap`` file per recording, in the message types of ROS 2 Humble:
``/map`` (``OccupancyGrid``), ``/topology``, ``/route_graph`` and ``/rooms``
(``MarkerArray``, in :data:`MAP_FRAME`, metres), ``/scan`` (``LaserScan``, in
:data:`LASER_FRAME`), ``/tf`` (the robot's pose) and ``/tf_static`` (the sensor's
offset).  Stamps are nanoseconds: a scan's own where usable, else
:data:`SCAN_PERIOD_S` after the previous one.  Topics, frames, QoS and stamps:
``docs/command-line.md``, "ROS 2 recordings (MCAP)".
"""

from __future__ import annotations

import functools
import math
import os
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np

from .._caller import outside_stacklevel
from .._constants import (
    EDGE_COLOUR,
    OTHER_VERTEX_COLOUR,
    ROUTE_EDGE_COLOUR,
    VERTEX_KIND_COLOURS,
)
from .._fs import output_file, refuse_suffix_only
from .._mcap_records import fill_chunk_crcs
from .._validate import instance_of, no_file_above, nx_graph, xy_points
from ..scans.scan import reading_limits
from ._qos import offered_qos
from ._recording_lock import lock_as_owner, remove_abandoned
from ._schema import _xy

__all__ = [
    "LASER_FRAME",
    "LATE_WARN_S",
    "MAP_FRAME",
    "ROBOT_FRAME",
    "SCAN_PERIOD_S",
    "TOPICS",
    "McapRecorder",
    "graph_markers",
    "mcap_path",
    "occupancy_grid",
    "room_markers",
    "save_mcap",
    "scan_message",
    "tf_message",
    "tf_static_message",
]

#: The fixed frame of maps, graphs and rooms.
MAP_FRAME = "map"
#: The robot's frame: ``/tf`` gives its pose in :data:`MAP_FRAME`.
ROBOT_FRAME = "base_link"
#: The frame of ``/scan``: ``/tf_static`` gives the sensor's pose in :data:`ROBOT_FRAME`
#: (``Scan.sensor_offset``).
LASER_FRAME = "base_laser"
#: Seconds between a scan without a usable timestamp and the one before it.
SCAN_PERIOD_S = 0.1
#: Seconds a scan's own timestamp may lie behind its stamp before a warning says that
#: the log's times went back (a jitter of a scan or two is not said).
LATE_WARN_S = 10.0
#: Each topic and its message type.
TOPICS = {
    "/map": "nav_msgs/msg/OccupancyGrid",
    "/topology": "visualization_msgs/msg/MarkerArray",
    "/route_graph": "visualization_msgs/msg/MarkerArray",
    "/rooms": "visualization_msgs/msg/MarkerArray",
    "/scan": "sensor_msgs/msg/LaserScan",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/tf_static": "tf2_msgs/msg/TFMessage",
}
#: Topics offered as ``transient_local`` (late subscribers get the last message).
_LATCHED = ("/map", "/topology", "/route_graph", "/rooms", "/tf_static")
#: Metres (and radians of yaw) by which a static transform must move to be written
#: again: logs that store the offset per scan carry rounding noise.
_STATIC_TOLERANCE = 1e-9
_VERTEX_DIAMETER_M = 0.25
_EDGE_WIDTH_M = 0.05
_ROOM_LINE_WIDTH_M = 0.08
_ROOM_TEXT_M = 0.6
_DOOR_COLOUR = "#ffffff"
_MAX_STAMP_S = 2**31
_NS = 1_000_000_000


@functools.lru_cache(maxsize=1)
def _typestore():
    """The ROS 2 Humble message types of ``rosbags``."""
    try:
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise ImportError(
            "MCAP recordings need the rosbags package: pip install 'topojax[bags]'"
        ) from None
    return get_typestore(Stores.ROS2_HUMBLE)


def _rgba(colour: str, alpha: float = 1.0):
    t = _typestore().types["std_msgs/msg/ColorRGBA"]
    h = colour.lstrip("#")
    r, g, b = (int(h[i : i + 2], 16) / 255.0 for i in (0, 2, 4))
    return t(r=r, g=g, b=b, a=alpha)


def _time(ns: int):
    """``builtin_interfaces/msg/Time`` of ``ns`` nanoseconds."""
    return _typestore().types["builtin_interfaces/msg/Time"](sec=ns // _NS, nanosec=ns % _NS)


def _header(ns: int, frame: str = MAP_FRAME):
    return _typestore().types["std_msgs/msg/Header"](stamp=_time(ns), frame_id=frame)


def _quaternion(yaw: float):
    return _typestore().types["geometry_msgs/msg/Quaternion"](
        x=0.0, y=0.0, z=math.sin(0.5 * yaw), w=math.cos(0.5 * yaw)
    )


def _pose(x: float, y: float, yaw: float):
    t = _typestore().types
    point = t["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0)
    return t["geometry_msgs/msg/Pose"](position=point, orientation=_quaternion(yaw))


def _points(xy) -> list:
    point = _typestore().types["geometry_msgs/msg/Point"]
    return [point(x=x, y=y, z=0.0) for x, y in np.asarray(xy, np.float64).reshape(-1, 2).tolist()]


# ---------------------------------------------------------------------- messages


def occupancy_grid(occupancy, stamp_ns: int = 0):
    """``nav_msgs/msg/OccupancyGrid`` of an :class:`~topojax.OccupancyMap` (100 occupied,
    0 free, -1 unknown; ``data`` row-major from the map's bottom row)."""
    t = _typestore().types
    h, w = occupancy.shape
    grid = np.full((h, w), -1, np.int8)
    grid[occupancy.free] = 0
    grid[occupancy.occupied] = 100
    ox, oy, yaw = occupancy.origin
    info = t["nav_msgs/msg/MapMetaData"](
        map_load_time=_time(stamp_ns),
        resolution=float(occupancy.resolution_m),
        width=w,
        height=h,
        origin=_pose(ox, oy, yaw),
    )
    return t["nav_msgs/msg/OccupancyGrid"](
        header=_header(stamp_ns), info=info, data=np.ascontiguousarray(grid[::-1]).ravel()
    )


def _marker(stamp_ns: int, ns: str, mid: int, kind: str, *, points=(), colour=None, scale=0.0):
    """One marker in the map frame: ``kind`` a ``Marker`` type name (``"LINE_STRIP"``),
    or ``"DELETEALL"`` for the action that clears the topic's earlier markers."""
    t = _typestore().types
    marker = t["visualization_msgs/msg/Marker"]
    vec = t["geometry_msgs/msg/Vector3"]
    empty = np.zeros(0, np.uint8)
    return marker(
        header=_header(stamp_ns),
        ns=ns,
        id=int(mid),
        type=getattr(marker, kind) if kind != "DELETEALL" else marker.ARROW,
        action=marker.DELETEALL if kind == "DELETEALL" else marker.ADD,
        pose=_pose(0.0, 0.0, 0.0),
        scale=vec(x=scale, y=scale, z=scale),
        color=colour if colour is not None else _rgba("#000000", 0.0),
        lifetime=t["builtin_interfaces/msg/Duration"](sec=0, nanosec=0),
        frame_locked=False,
        points=list(points),
        colors=[],
        texture_resource="",
        texture=t["sensor_msgs/msg/CompressedImage"](
            header=_header(stamp_ns), format="", data=empty
        ),
        uv_coordinates=[],
        text="",
        mesh_resource="",
        mesh_file=t["visualization_msgs/msg/MeshFile"](filename="", data=empty),
        mesh_use_embedded_materials=False,
    )


def graph_markers(graph, stamp_ns: int = 0, *, edge_colour: str = EDGE_COLOUR):
    """``visualization_msgs/msg/MarkerArray`` of a topology or route graph: ``DELETEALL``,
    one ``SPHERE_LIST`` per vertex kind (namespace ``vertices``, id 0 junction, 1 end, 2
    ring, 3 isolated, 4 any other kind or none, as the viewer's "other"; vertices in node
    order) and one ``LINE_STRIP`` per edge (namespace ``edges``, id = its place in
    ``graph.edges``, in ``edge_colour``, ``#rrggbb``) through its ``waypoints`` where the
    edge has them (route graphs), else the ``world`` (x, y) of its pixel centres."""
    _check_graph("graph", graph)
    t = _typestore().types
    markers = [_marker(stamp_ns, "", 0, "DELETEALL")]
    kinds = [*VERTEX_KIND_COLOURS.items(), (None, OTHER_VERTEX_COLOUR)]
    for i, (kind, colour) in enumerate(kinds):
        xy = [d["world"] for _, d in graph.nodes(data=True) if _kind(d) == kind]
        if xy:
            markers.append(
                _marker(
                    stamp_ns,
                    "vertices",
                    i,
                    "SPHERE_LIST",
                    points=_points(xy),
                    colour=_rgba(colour),
                    scale=_VERTEX_DIAMETER_M,
                )
            )
    line_colour = _rgba(edge_colour)
    for i, (_, _, d) in enumerate(graph.edges(data=True)):
        markers.append(
            _marker(
                stamp_ns,
                "edges",
                i,
                "LINE_STRIP",
                points=_points(d["waypoints"] if "waypoints" in d else d["world"]),
                colour=line_colour,
                scale=_EDGE_WIDTH_M,
            )
        )
    return t["visualization_msgs/msg/MarkerArray"](markers=markers)


def _kind(data: dict):
    """A vertex's kind where it is one of :data:`VERTEX_KIND_COLOURS`, else None."""
    kind = data.get("kind")
    return kind if isinstance(kind, str) and kind in VERTEX_KIND_COLOURS else None


def _check_graph(name: str, graph, *, undirected: bool = False) -> None:
    """Raise a TypeError or ValueError naming ``name`` unless ``graph`` is a networkx
    graph (an undirected one where ``undirected``) whose vertices have ``world`` and
    whose edges ``waypoints`` or ``world``."""
    nx_graph(name, graph, undirected=undirected)
    if any("world" not in d for _, d in graph.nodes(data=True)):
        raise ValueError(f"{name}: expected a 'world' (x, y) on every vertex, one has none")
    if any("world" not in d and "waypoints" not in d for *_, d in graph.edges(data=True)):
        raise ValueError(
            f"{name}: expected 'waypoints' or 'world' points on every edge, one has neither"
        )
    # RViz drops a marker with a NaN point, with only a warning
    for n, d in graph.nodes(data=True):
        _xy(d["world"], f"{name}: node {n!r} 'world'")
    edges = graph.edges(keys=True, data=True) if graph.is_multigraph() else graph.edges(data=True)
    for *edge, d in edges:
        attr = "waypoints" if "waypoints" in d else "world"
        xy_points(d[attr], f"{name}: edge {tuple(edge)!r} {attr!r}")


def room_markers(seg, stamp_ns: int = 0):
    """``visualization_msgs/msg/MarkerArray`` of a :class:`~topojax.RoomSegmentation`:
    ``DELETEALL``, each room's closed outline (``LINE_STRIP``, namespace ``rooms``, id =
    room id, in its colour of the label picture), the rings round its holes where it has
    any (one ``LINE_LIST``, namespace ``room_holes``, id = room id, same colour, each
    ring's sides as point pairs), its id as text at its label point
    (:attr:`~topojax.Room.label_point`, ``TEXT_VIEW_FACING``, namespace ``room_ids``)
    and the doorways (one ``LINE_LIST``, namespace ``doors``, two points per door)."""
    from .rooms import room_colours

    t = _typestore().types
    markers = [_marker(stamp_ns, "", 0, "DELETEALL")]
    top = max((room.id for room in seg.rooms), default=0)
    colours = room_colours(top)
    for room in seg.rooms:
        ring = np.asarray(room.polygon, np.float64).reshape(-1, 2)
        closed = np.vstack([ring, ring[:1]])
        colour = "#" + "".join(f"{int(v):02x}" for v in colours[room.id - 1])
        markers.append(
            _marker(
                stamp_ns,
                "rooms",
                room.id,
                "LINE_STRIP",
                points=_points(closed),
                colour=_rgba(colour),
                scale=_ROOM_LINE_WIDTH_M,
            )
        )
        if room.holes:
            sides = []
            for hole in room.holes:
                h = np.asarray(hole, np.float64).reshape(-1, 2)
                sides.append(np.stack([h, np.roll(h, -1, axis=0)], axis=1).reshape(-1, 2))
            markers.append(
                _marker(
                    stamp_ns,
                    "room_holes",
                    room.id,
                    "LINE_LIST",
                    points=_points(np.concatenate(sides)),
                    colour=_rgba(colour),
                    scale=_ROOM_LINE_WIDTH_M,
                )
            )
        label = _marker(stamp_ns, "room_ids", room.id, "TEXT_VIEW_FACING", colour=_rgba("#000000"))
        label.pose = _pose(*room.label_point, 0.0)
        label.scale.z = _ROOM_TEXT_M
        label.text = str(room.id)
        markers.append(label)
    if seg.doors:
        ends = np.concatenate([np.asarray(d.ends_world, np.float64) for d in seg.doors])
        markers.append(
            _marker(
                stamp_ns,
                "doors",
                0,
                "LINE_LIST",
                points=_points(ends),
                colour=_rgba(_DOOR_COLOUR),
                scale=_ROOM_LINE_WIDTH_M,
            )
        )
    return t["visualization_msgs/msg/MarkerArray"](markers=markers)


def scan_message(scan, stamp_ns: int = 0):
    """``sensor_msgs/msg/LaserScan`` of a :class:`~topojax.Scan` in :data:`LASER_FRAME`
    (ranges in metres as float32, no intensities).  A reading the scan takes as no return
    (not in :meth:`~topojax.Scan.valid_mask`: 0, NaN, below ``range_min``, at or beyond
    ``range_max``) is +inf, REP 117's no return, which RViz and Foxglove do not draw (a 0
    would be a point on the laser).  A hit that float32 rounds onto a limit (just below
    ``range_max``, or a tiny reading with ``range_min`` 0) is the nearest float32 inside
    it, so it reads back as a hit."""
    t = _typestore().types
    n = scan.n_beams
    ranges = _float32_ranges(scan)
    return t["sensor_msgs/msg/LaserScan"](
        header=_header(stamp_ns, LASER_FRAME),
        angle_min=scan.angle_min,
        angle_max=scan.angle_min + max(n - 1, 0) * scan.angle_increment,
        angle_increment=scan.angle_increment,
        time_increment=0.0,
        scan_time=0.0,
        range_min=scan.range_min,
        range_max=scan.range_max,
        ranges=ranges,
        intensities=np.zeros(0, np.float32),
    )


def _float32_ranges(scan) -> np.ndarray:
    """``scan``'s readings as float32 (N,), +inf where it takes them as no return and its
    hits kept inside ``(0, range_max)`` in float32 (``valid_mask`` on read-back agrees)."""
    hit = scan.valid_mask()
    ranges = np.where(hit, scan.ranges, np.inf).astype(np.float32)
    _, top = reading_limits(np.float32, scan.range_min, scan.range_max)
    with np.errstate(over="ignore"):  # a limit beyond float32: inf, whose neighbour is max
        top = np.nextafter(np.float32(top), np.float32(0))
    least = np.nextafter(np.float32(0), np.float32(1))
    ranges[hit] = np.clip(ranges[hit], least, top)
    return ranges


def _transform(stamp_ns: int, parent: str, child: str, pose3):
    t = _typestore().types
    x, y, yaw = pose3
    return t["geometry_msgs/msg/TransformStamped"](
        header=_header(stamp_ns, parent),
        child_frame_id=child,
        transform=t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=0.0),
            rotation=_quaternion(yaw),
        ),
    )


def tf_message(scan, stamp_ns: int = 0):
    """``tf2_msgs/msg/TFMessage`` of ``/tf``: :data:`MAP_FRAME` -> :data:`ROBOT_FRAME`
    (the scan's ``pose``)."""
    return _typestore().types["tf2_msgs/msg/TFMessage"](
        transforms=[_transform(stamp_ns, MAP_FRAME, ROBOT_FRAME, scan.pose)]
    )


def tf_static_message(scan, stamp_ns: int = 0):
    """``tf2_msgs/msg/TFMessage`` of ``/tf_static``, the recording's whole set of static
    transforms: :data:`ROBOT_FRAME` -> :data:`LASER_FRAME` (the scan's ``sensor_offset``)."""
    return _typestore().types["tf2_msgs/msg/TFMessage"](
        transforms=[_transform(stamp_ns, ROBOT_FRAME, LASER_FRAME, scan.sensor_offset)]
    )


def _same_static(a, b) -> bool:
    """Whether two ``/tf_static`` messages hold the same transforms (stamps aside): the
    translations (m) within :data:`_STATIC_TOLERANCE`, and the yaws (rad) too, modulo a
    turn (a yaw of pi and one of -pi are one mounting, their quaternions opposite)."""

    def values(msg) -> list:
        out = []
        for tf in msg.transforms:
            q = tf.transform.rotation
            xyz = [getattr(tf.transform.translation, k) for k in "xyz"]
            # the recorder's rotations turn about z alone; x and y are compared as they are
            yaw = 2.0 * math.atan2(q.z, q.w)
            out.append(((tf.header.frame_id, tf.child_frame_id), [*xyz, q.x, q.y], yaw))
        return out

    va, vb = values(a), values(b)
    return len(va) == len(vb) and all(
        fa == fb
        and all(abs(x - y) <= _STATIC_TOLERANCE for x, y in zip(xa, xb, strict=True))
        and abs(math.remainder(ya - yb, 2.0 * math.pi)) <= _STATIC_TOLERANCE
        for (fa, xa, ya), (fb, xb, yb) in zip(va, vb, strict=True)
    )


# ---------------------------------------------------------------------- the writer


def mcap_path(path, *, name: str = "path", written: bool = True) -> Path:
    """``path`` as a Path, checked: a file name ending in ``.mcap`` that is not a folder
    and, when it is to be ``written``, one that can be written (its folder takes a new
    file: :func:`~topojax._fs.output_file`); errors name the parameter ``name``."""
    try:
        given = os.fspath(path)
        p = Path(given)
    except TypeError:
        raise TypeError(
            f"{name}: expected a file name ending in .mcap, received {type(path).__name__}"
        ) from None
    if p.suffix.lower() != ".mcap":  # the value as given: Path("") reads "."
        refuse_suffix_only(name, p, (".mcap",))
        shown = repr(given) if given else "an empty path"
        raise ValueError(f"{name}: expected a file name ending in .mcap, received {shown}")
    if p.is_dir():
        raise IsADirectoryError(f"{name}: expected an .mcap file name, received the folder {p}")
    return output_file(p, name=name) if written else no_file_above(name, p)


class McapRecorder:
    """Write a ROS 2 MCAP recording of a mapping run, message by message.

    Use it as a context manager: the file appears, complete, when the ``with`` block ends
    (an exception leaves no file and no temporary folder behind).  Messages are written as
    they come; the recording is built in a hidden folder beside ``path`` and moved to
    ``path`` at the end, replacing a file that was there.  A recorder writes one
    recording: once closed or aborted it takes no more messages and does not open again.
    Opening removes the hidden folders that recorders of ``path`` whose process was
    killed left behind (never one whose recorder still records).

    Parameters
    ----------
    path : str or Path
        The ``.mcap`` file to write; its folder is created.
    continue_from : str or Path, optional
        A recording this one continues (one written by :meth:`close` when a replay
        stopped part way): its messages are copied first, the next scan is stamped
        after its last one, and its last ``/tf_static`` stands until a scan's offset
        differs.  A file that is not a complete MCAP recording is refused with a
        ValueError naming it when the recording opens.

    Attributes
    ----------
    counts : dict of str to int
        Messages written per topic.
    stamp_ns : int
        Stamp of the last scan in nanoseconds (0 before the first); see the module's notes
        on time stamps.

    Examples
    --------
    >>> with McapRecorder("run.mcap") as rec:  # doctest: +SKIP
    ...     for scan in scans:
    ...         report = mapper.add_scan(scan)
    ...         rec.add_scan(scan)
    ...         if report.graph_update:
    ...             rec.add_map(mapper.occupancy, mapper.graph)
    ...             rec.add_route_graph(mapper.route_graph(robot_radius_m=0.3))
    """

    def __init__(self, path, *, continue_from=None) -> None:
        self.path = mcap_path(path)
        self.counts: dict[str, int] = {}
        self.stamp_ns = 0
        self._scanned = False
        self._static = None  # the last /tf_static written (or copied)
        self._last_time: float | None = None  # the last scan's own usable timestamp (s)
        self._late_warned = False  # a scan's own time going back: said once
        self._writer = None
        self._tmp: Path | None = None
        self._owner: int | None = None  # the locked descriptor of the temporary folder
        self._connections: dict[str, object] = {}
        self._finished = False  # closed or aborted: a recorder writes one recording
        self._earlier = (
            None
            if continue_from is None
            else mcap_path(continue_from, name="continue_from", written=False)
        )

    # ------------------------------------------------------------------ lifetime
    def open(self) -> McapRecorder:
        """Start the recording (the ``with`` statement calls it)."""
        from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

        if self._writer is not None:
            raise RuntimeError(f"McapRecorder: the recording {self.path} is already open")
        if self._finished:
            raise RuntimeError(
                f"McapRecorder: the recording {self.path} is finished (closed or aborted); "
                "make a new McapRecorder for another"
            )
        _typestore()  # a missing rosbags fails here, before anything is created
        self.path.parent.mkdir(parents=True, exist_ok=True)
        remove_abandoned(self.path)
        self._tmp = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", dir=self.path.parent))
        try:
            self._owner = lock_as_owner(self._tmp)
            writer = Writer(self._tmp / "recording", version=8, storage_plugin=StoragePlugin.MCAP)
            writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
            writer.open()
            self._writer = writer
            if self._earlier is not None:
                self._copy(self._earlier)
        except BaseException:
            self.abort()
            raise
        return self

    def _copy(self, earlier: Path) -> None:
        """Write the messages of the recording ``earlier``, in time order, and take its
        last scan's stamp as the latest."""
        from rosbags.highlevel import AnyReader

        if not earlier.is_file():
            raise FileNotFoundError(f"continue_from: no recording {earlier}")

        def messages():
            # rosbags raises several types (AssertionError among them) for a file that is
            # not MCAP, cut short or damaged; the writing's own errors pass as they are
            try:
                with AnyReader([earlier]) as reader:
                    yield from reader.messages()
            except Exception as exc:  # noqa: BLE001
                raise ValueError(
                    f"continue_from: expected a complete MCAP recording (one McapRecorder "
                    f"closed), {earlier} cannot be read: {type(exc).__name__}: {exc}"
                ) from None

        for conn, stamp_ns, raw in messages():
            if conn.topic not in TOPICS:
                raise ValueError(
                    f"continue_from: expected a recording of McapRecorder's topics "
                    f"{sorted(TOPICS)}, {earlier} has {conn.topic!r}"
                )
            self._write_raw(conn.topic, raw, stamp_ns)
            if conn.topic == "/tf_static":
                self._static = _typestore().deserialize_cdr(raw, TOPICS["/tf_static"])
            if conn.topic == "/scan":
                self.stamp_ns, self._scanned = max(self.stamp_ns, stamp_ns), True

    def close(self, path=None) -> Path:
        """Finish the file and move it to :attr:`path` (or to ``path``, e.g. a stopped
        replay's part, which a later recording continues); returns where it is."""
        if self._writer is None:
            raise RuntimeError("McapRecorder: the recording is not open")
        target = self.path if path is None else mcap_path(path)
        writer, self._writer = self._writer, None
        self._finished = True
        try:
            writer.close()
            done = self._tmp / "recording" / "recording.mcap"
            fill_chunk_crcs(done)  # rosbags records none: damage would read unseen
            if path is None:
                os.replace(done, target)
            else:  # its folder, maybe on another file system
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.move(done, target)
        finally:
            self._remove_tmp()
        return target

    def _remove_tmp(self) -> None:
        """Remove the temporary folder, then let go of its lock."""
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
        if self._owner is not None:
            os.close(self._owner)
            self._owner = None

    def abort(self) -> None:
        """Drop the recording: no file is written."""
        writer, self._writer = self._writer, None
        if writer is not None:
            self._finished = True
            writer.abort()
        self._remove_tmp()

    def __enter__(self) -> McapRecorder:
        return self.open()

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

    def __repr__(self) -> str:
        state = "recording" if self._writer else "finished" if self._finished else "not open"
        if self.counts:
            state += ": " + ", ".join(f"{t} {n}" for t, n in self.counts.items())
        if self._scanned:
            state += f"; last scan at {self.stamp_ns / _NS:.9f} s"
        if self._earlier is not None:
            state += f", continuing {str(self._earlier)!r}"
        return f"McapRecorder({str(self.path)!r}, {state})"

    # ------------------------------------------------------------------ messages
    def _write(self, topic: str, message, stamp_ns: int) -> None:
        self._write_raw(topic, _typestore().serialize_cdr(message, TOPICS[topic]), stamp_ns)

    def _write_raw(self, topic: str, raw, stamp_ns: int) -> None:
        """Write one CDR-serialised message of ``topic``."""
        if self._writer is None:
            if self._finished:
                raise RuntimeError(
                    f"McapRecorder: the recording {self.path} is finished (closed or aborted): "
                    "no more messages can be written"
                )
            raise RuntimeError("McapRecorder: open the recording first (use it in a with block)")
        conn = self._connections.get(topic)
        if conn is None:
            conn = self._writer.add_connection(
                topic,
                TOPICS[topic],
                typestore=_typestore(),
                offered_qos_profiles=offered_qos(topic in _LATCHED),
            )
            self._connections[topic] = conn
        self._writer.write(conn, stamp_ns, raw)
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def _next_stamp(self, timestamp) -> int:
        """The stamp of the next scan (ns): its timestamp when usable (after the previous
        stamp), else one :data:`SCAN_PERIOD_S` after the previous stamp."""
        if timestamp is not None and 0.0 <= timestamp < _MAX_STAMP_S:
            ns = int(round(timestamp * _NS))
            last, self._last_time = self._last_time, timestamp
            if not self._scanned or ns > self.stamp_ns:
                return ns
            behind_s = self.stamp_ns / _NS - timestamp
            late = last is not None and last != timestamp and behind_s > LATE_WARN_S
            if late and not self._late_warned:
                self._late_warned = True  # repeated times (all 0 in some logs) are not said
                warnings.warn(
                    f"{self.path}: the scans' times went back from {last:.9g} s to "
                    f"{timestamp:.9g} s; this scan and the ones after it are recorded "
                    f"{SCAN_PERIOD_S:g} s apart from {self.stamp_ns / _NS:.9g} s on, until "
                    "the log's times pass that (a recording's stamps only move forward: a "
                    "timestamp far ahead in the log shifts the scans after it)",
                    UserWarning,
                    stacklevel=outside_stacklevel(),
                )
        return self.stamp_ns + int(round(SCAN_PERIOD_S * _NS)) if self._scanned else 0

    def add_scan(self, scan) -> int:
        """Write ``/tf`` and ``/scan`` for a :class:`~topojax.Scan`, and ``/tf_static``
        at the first scan and where its ``sensor_offset`` differs from the last one
        written; returns its stamp (ns).  A scan whose sensor pose in the map frame
        (``pose`` then ``sensor_offset``) is not finite is refused with a ValueError, and
        nothing is written."""
        from ..scans import Scan

        instance_of("scan", scan, Scan, "topojax.Scan")
        sensor = scan.sensor_pose_world()
        if not all(math.isfinite(v) for v in sensor):  # tf would put the laser nowhere
            raise ValueError(
                "scan: expected a sensor pose in the map frame (pose then sensor_offset) of "
                f"finite numbers, received {sensor} from pose {scan.pose} and sensor_offset "
                f"{scan.sensor_offset}"
            )
        self.stamp_ns = self._next_stamp(scan.timestamp)
        self._scanned = True
        static = tf_static_message(scan, self.stamp_ns)
        if self._static is None or not _same_static(static, self._static):
            self._write("/tf_static", static, self.stamp_ns)
            self._static = static
        self._write("/tf", tf_message(scan, self.stamp_ns), self.stamp_ns)
        self._write("/scan", scan_message(scan, self.stamp_ns), self.stamp_ns)
        return self.stamp_ns

    def add_map(self, occupancy, graph=None) -> None:
        """Write ``/map`` (an :class:`~topojax.OccupancyMap`) and, given its topology
        ``graph`` (with ``world`` vertex and edge coordinates), ``/topology``, at
        :attr:`stamp_ns`."""
        from ..maps import map_argument

        occupancy = map_argument("occupancy", occupancy)
        topology = None if graph is None else graph_markers(graph, self.stamp_ns)
        self._write("/map", occupancy_grid(occupancy, self.stamp_ns), self.stamp_ns)
        if topology is not None:
            self._write("/topology", topology, self.stamp_ns)

    def add_route_graph(self, graph) -> None:
        """Write ``/route_graph`` (a :func:`topojax.route_graph`, edges drawn through their
        ``waypoints``, green where ``/topology``'s are orange) at :attr:`stamp_ns`."""
        nx_graph("graph", graph)  # undirected, as every route graph reader takes it
        markers = graph_markers(graph, self.stamp_ns, edge_colour=ROUTE_EDGE_COLOUR)
        self._write("/route_graph", markers, self.stamp_ns)

    def add_rooms(self, seg) -> None:
        """Write ``/rooms`` (a :class:`~topojax.RoomSegmentation`) at :attr:`stamp_ns`."""
        from .rooms import _check_seg

        self._write("/rooms", room_markers(_check_seg(seg), self.stamp_ns), self.stamp_ns)


def save_mcap(result, path, *, rooms=None, route_graph=None) -> Path:
    """Write a full-map result as a ROS 2 MCAP recording: one ``/map`` and one
    ``/topology`` message (and one ``/rooms`` with ``rooms``, one ``/route_graph`` with
    ``route_graph``), all at 0 s.

    Parameters
    ----------
    result : TopologyResult
        From :func:`topojax.build_graph` (its ``map`` and ``graph``).
    path : str or Path
        The ``.mcap`` file (replaced if it exists; its folder is created).
    rooms : RoomSegmentation, optional
        Rooms of the same map (:func:`topojax.segment_rooms`).
    route_graph : networkx.MultiGraph, optional
        A route graph of the same map (:func:`topojax.route_graph`).

    Raises
    ------
    TypeError
        ``route_graph`` is not an undirected networkx graph.
    ValueError
        ``rooms`` or ``route_graph`` made on another map (its recorded shape,
        resolution or origin is not the result's), which would be drawn off its place.

    Returns
    -------
    Path
        ``path``.  See :mod:`topojax.io.mcap` for topics, types and frames.
    """
    from ..maps import OccupancyMap

    for name in ("map", "graph"):
        if not hasattr(result, name):
            raise TypeError(
                f"result: expected a TopologyResult (from build_graph), received "
                f"{type(result).__name__} (no {name})"
            )
    if not isinstance(result.map, OccupancyMap):  # a TiledResult's map stays on disk
        raise TypeError(
            f"result: expected a TopologyResult (from build_graph), whose map is an "
            f"OccupancyMap in memory, received {type(result).__name__} with a "
            f"{type(result.map).__name__}"
        )
    from ..maps.occupancy import grid_mismatch, map_mismatch

    # every topic is drawn in the one map frame: rooms or a route graph of another map
    # would sit off their place over /map
    if rooms is not None:
        from ..rooms import RoomSegmentation

        instance_of("rooms", rooms, RoomSegmentation)
        own = rooms.occupancy
        why = grid_mismatch(own.shape, own.resolution_m, own.origin, result.map, owner="their")
        if why is not None:
            raise ValueError(f"rooms: not segmented on the result's map: {why}")
    if route_graph is not None:
        _check_graph("route_graph", route_graph, undirected=True)
        why = map_mismatch(route_graph, result.map)
        if why is not None:
            raise ValueError(f"route_graph: not built on the result's map: {why}")
    with McapRecorder(path) as rec:
        rec.add_map(result.map, result.graph)
        if rooms is not None:
            rec.add_rooms(rooms)
        if route_graph is not None:
            rec.add_route_graph(route_graph)
    return rec.path
