"""ROS 1 / ROS 2 bag reader: ``sensor_msgs/LaserScan`` messages posed from tf or a pose
topic."""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ._ros1 import _ROS1_MAGIC, _Ros1Sequential
from ._tf import _IDENTITY_TF, _Tf, _tf_from_msg, _TfSeries, _TfTree
from .scan import PoseLike, Scan, _pose3, _real_scalar

_LASERSCAN = "sensor_msgs/msg/LaserScan"
_TF_TYPES = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")
_POSE_TYPES = (
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
)
_BASE_FRAME_CANDIDATES = ("base_footprint", "base_link")


def _frame(name: str) -> str:
    """Frame id without the ROS 1 leading slash."""
    return name.strip().lstrip("/")


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


class _AnyReaderSource:
    """Message source backed by ``rosbags.highlevel.AnyReader`` (ROS 1 and ROS 2 bags)."""

    def __init__(self, path: Path) -> None:
        from rosbags.highlevel import AnyReader

        self._cls = AnyReader
        self.path = path
        with AnyReader([path]) as reader:
            self.topics = {c.topic: c.msgtype for c in reader.connections}
            for c in reader.connections:  # fail now, not mid-iteration, on unknown types
                reader.typestore.get_msgdef(c.msgtype)

    def messages(self, topics: Iterable[str]) -> Iterator[tuple[str, str, int, Any]]:
        wanted = set(topics)
        with self._cls([self.path]) as reader:
            conns = [c for c in reader.connections if c.topic in wanted]
            if not conns:
                return
            for conn, t_ns, raw in reader.messages(connections=conns):
                yield conn.topic, conn.msgtype, t_ns, reader.deserialize(raw, conn.msgtype)


def _open_bag(path: Path) -> _AnyReaderSource | _Ros1Sequential:
    if not path.exists():
        raise FileNotFoundError(f"path: bag not found: {path}")
    ros1 = False
    if path.is_file():
        with open(path, "rb") as fh:
            ros1 = fh.read(len(_ROS1_MAGIC)) == _ROS1_MAGIC
    if ros1 and path.suffix != ".bag":
        return _Ros1Sequential(path)
    target = path
    if path.is_file() and not ros1 and (path.parent / "metadata.yaml").is_file():
        target = path.parent  # a .db3/.mcap file inside a ROS 2 bag folder
    try:
        return _AnyReaderSource(target)
    except Exception as err:  # rosbags raises several types (and bare AssertionError)
        if ros1:
            try:
                return _Ros1Sequential(path)
            except ValueError as err2:
                raise ValueError(
                    f"path: cannot read ROS 1 bag {path}: rosbags: {err!r}; fallback: {err2}"
                ) from None
        raise ValueError(f"path: cannot read bag {target} with rosbags: {err!r}") from None


def _pose_from_msg(typ: str, msg: Any) -> tuple[str, str | None, int, _Tf]:
    """Parent frame, body frame (Odometry child frame or None), stamp, planar pose."""
    if typ == "nav_msgs/msg/Odometry":
        pose, body = msg.pose.pose, _frame(msg.child_frame_id) or None
    elif typ == "geometry_msgs/msg/PoseWithCovarianceStamped":
        pose, body = msg.pose.pose, None
    else:
        pose, body = msg.pose, None
    tf = _tf_from_msg(pose.position, pose.orientation)
    return _frame(msg.header.frame_id), body, _stamp_ns(msg.header.stamp), tf


def read_bag(
    path: str | Path,
    *,
    scan_topic: str | None = None,
    pose_topic: str | None = None,
    tf_parent: str | None = None,
    base_frame: str | None = None,
    sensor_offset: PoseLike | None = None,
    allow_missing_pose: bool = False,
    pose_tolerance_s: float = 0.1,
    missing_pose: str = "skip",
) -> Iterator[Scan]:
    """Read ``sensor_msgs/LaserScan`` messages with poses from a ROS 1 or ROS 2 bag.

    Bags are read with ``rosbags.highlevel.AnyReader`` (no ROS install needed): a ROS 1
    ``.bag`` file, or a ROS 2 bag folder (or a ``.db3`` / ``.mcap`` file inside one). ROS 1
    bags that ``rosbags`` refuses because of inconsistent index records are read by a small
    sequential reader instead (message definitions come from the bag itself).

    Poses are planar: for each transform only ``x``, ``y`` and the heading of the rotated
    ``x`` axis are used; a frame whose ``z`` axis points down (an upside-down laser) mirrors
    the scan, which is represented by negating ``angle_min`` and ``angle_increment``.
    Transforms are linearly interpolated at the scan's ``header.stamp`` (the bag time when
    the stamp is zero); ``/tf_static`` transforms are constant.

    Pose sources, in order:

    1. ``pose_topic`` (``nav_msgs/Odometry``, ``geometry_msgs/PoseStamped`` or
       ``PoseWithCovarianceStamped``): the robot pose in the message's ``header.frame_id``.
       The robot ("body") frame is ``base_frame`` if given, else the Odometry
       ``child_frame_id``. The sensor offset is ``sensor_offset`` if given, else looked up in
       tf from the body frame to the scan's frame (zero if they are the same frame).
    2. Otherwise, if the bag has tf topics (``tf2_msgs/TFMessage``): the chain from
       ``tf_parent`` (default ``"map"`` if that frame exists, else ``"odom"``) to the scan
       frame. It is split at ``base_frame`` (default: ``base_footprint`` or ``base_link``,
       whichever lies on the chain, else no split): ``pose`` = tf_parent -> base,
       ``sensor_offset`` = base -> scan frame.
    3. Otherwise, the only pose-type topic, if there is exactly one.
    4. No pose source: ValueError, unless ``allow_missing_pose=True``, in which case every
       scan gets the identity pose ``(0, 0, 0)`` (and ``sensor_offset`` or zero). The CCNY
       ``laser_scan_matcher`` demo bag, for example, holds only ``/scan``.

    Parameters
    ----------
    path : str or Path
        Bag file or ROS 2 bag folder.
    scan_topic : str, optional
        LaserScan topic; default: the only LaserScan topic (ValueError listing the topics
        if there is none or more than one).
    pose_topic : str, optional
        Pose topic (see above).
    tf_parent : str, optional
        Map frame for tf poses.
    base_frame : str, optional
        Robot frame (see above).
    sensor_offset : array_like, shape (3,), optional
        Sensor pose in the robot frame, overriding tf.
    allow_missing_pose : bool, optional
        Use the identity pose when the bag has no pose source at all.
    pose_tolerance_s : float, optional
        A scan up to this many seconds before the first (after the last) sample of a
        transform takes that first (last) sample; default 0.1 s.
    missing_pose : {"skip", "error"}, optional
        What to do with scans whose time is outside the pose data: skip them (a warning
        gives the count once the iterator is exhausted) or raise ValueError.

    Returns
    -------
    iterator of Scan
        Scans in bag order; ``ranges`` are the message's float32 array; ``timestamp`` in
        seconds (header stamp).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        Unreadable bag, topic selection problems, missing pose source or tf frames.
    """
    p = Path(path)
    if missing_pose not in ("skip", "error"):
        raise ValueError(f"missing_pose: expected 'skip' or 'error', got {missing_pose!r}")
    tol = _real_scalar("pose_tolerance_s", pose_tolerance_s)
    if tol < 0:
        raise ValueError(f"pose_tolerance_s: expected a value >= 0 s, got {tol!r}")
    offset_override = None if sensor_offset is None else _pose3("sensor_offset", sensor_offset)
    source = _open_bag(p)
    topics = source.topics
    listing = ", ".join(f"{t} [{m}]" for t, m in sorted(topics.items())) or "(none)"

    scan_topics = [t for t, m in topics.items() if m == _LASERSCAN]
    if scan_topic is None:
        if len(scan_topics) != 1:
            raise ValueError(
                f"scan_topic: expected exactly one {_LASERSCAN} topic in {p} to choose by "
                f"default, found {len(scan_topics)}; topics: {listing}"
            )
        scan_topic = scan_topics[0]
    elif topics.get(scan_topic) != _LASERSCAN:
        raise ValueError(
            f"scan_topic: {scan_topic!r} is not a {_LASERSCAN} topic in {p}; topics: {listing}"
        )

    tf_topics = [t for t, m in topics.items() if m in _TF_TYPES]
    pose_topics = [t for t, m in topics.items() if m in _POSE_TYPES]
    mode: str
    if pose_topic is not None:
        if topics.get(pose_topic) not in _POSE_TYPES:
            raise ValueError(
                f"pose_topic: {pose_topic!r} is not one of {', '.join(_POSE_TYPES)} in {p}; "
                f"topics: {listing}"
            )
        mode = "topic"
    elif tf_topics:
        mode = "tf"
    elif len(pose_topics) == 1:
        pose_topic, mode = pose_topics[0], "topic"
    elif pose_topics:
        raise ValueError(
            f"pose_topic: {p} has no tf and several pose topics {sorted(pose_topics)}; "
            f"choose one with pose_topic="
        )
    elif allow_missing_pose:
        mode = "none"
    else:
        raise ValueError(
            f"{p} has no pose source (no tf topic and no {', '.join(_POSE_TYPES)} topic); "
            f"topics: {listing}. Pass allow_missing_pose=True (topojax replay "
            "--allow-missing-pose) to read the scans with the identity pose (0, 0, 0), or "
            "pose_topic (--pose-topic)."
        )
    return _iter_bag(
        p,
        source,
        scan_topic,
        mode,
        pose_topic,
        tf_topics,
        tf_parent,
        base_frame,
        offset_override,
        int(round(tol * 1e9)),
        missing_pose,
    )


def _iter_bag(
    path: Path,
    source: _AnyReaderSource | _Ros1Sequential,
    scan_topic: str,
    mode: str,
    pose_topic: str | None,
    tf_topics: list[str],
    tf_parent: str | None,
    base_frame: str | None,
    offset_override: tuple[float, float, float] | None,
    tol_ns: int,
    missing_pose: str,
) -> Iterator[Scan]:
    # Pass 1: collect the (small) pose data.
    tree = _TfTree()
    body_pose = _TfSeries()
    pose_parent: str | None = None
    pose_body: str | None = None
    wanted = list(tf_topics)
    if mode == "topic" and pose_topic is not None:
        wanted.append(pose_topic)
    if mode != "none" and wanted:
        for topic, typ, t_ns, msg in source.messages(wanted):
            if typ in _TF_TYPES:
                static = topic.rstrip("/").endswith("tf_static")
                for tr in msg.transforms:
                    stamp = _stamp_ns(tr.header.stamp) or t_ns
                    try:
                        tf = _tf_from_msg(tr.transform.translation, tr.transform.rotation)
                    except ValueError as err:
                        raise ValueError(f"{path}: topic {topic}: {err}") from None
                    tree.add(
                        _frame(tr.header.frame_id), _frame(tr.child_frame_id), stamp, tf, static
                    )
            else:
                try:
                    parent, body, stamp, tf = _pose_from_msg(typ, msg)
                except ValueError as err:
                    raise ValueError(f"{path}: topic {topic}: {err}") from None
                if pose_parent is None:
                    pose_parent, pose_body = parent, body
                body_pose.add(stamp or t_ns, tf, False)
        if mode == "topic" and not body_pose.t:
            raise ValueError(f"pose_topic: {pose_topic!r} in {path} has no messages")
        if mode == "topic" and base_frame is not None:
            pose_body = base_frame

    frames = tree.frames
    parent_frame = tf_parent
    if mode == "tf" and parent_frame is None:
        parent_frame = "map" if "map" in frames else "odom"

    skipped = 0
    resolved: dict[str, str | None] = {}

    def resolve(frame: str) -> str | None:
        """For tf mode: the base frame on the chain to split at (None: no split)."""
        if frame in resolved:
            return resolved[frame]
        if (
            parent_frame not in frames
            or frame not in frames
            or not tree.connected(parent_frame, frame)
        ):
            raise ValueError(
                f"tf_parent: no tf chain from {parent_frame!r} to the scan frame {frame!r} in "
                f"{path}; tf frames: {sorted(frames)} (try tf_parent='odom' or 'map', or "
                f"pose_topic=)"
            )
        chain = tree.ancestors(frame)
        if base_frame is not None:
            if base_frame not in chain or parent_frame not in chain[chain.index(base_frame) :]:
                raise ValueError(
                    f"base_frame: {base_frame!r} is not between {parent_frame!r} and the scan "
                    f"frame {frame!r} in the tf tree of {path}; chain: {chain}"
                )
            out: str | None = base_frame
        else:
            upto = chain[: chain.index(parent_frame)] if parent_frame in chain else chain
            cands = [c for c in _BASE_FRAME_CANDIDATES if c in upto]
            out = cands[0] if cands else None
        resolved[frame] = out
        return out

    for _topic, _typ, t_ns, msg in source.messages([scan_topic]):
        stamp = _stamp_ns(msg.header.stamp) or t_ns
        frame = _frame(msg.header.frame_id)
        angle_min = float(msg.angle_min)
        inc = float(msg.angle_increment)
        robot: _Tf | None
        offset: _Tf | None
        if mode == "none":
            robot, offset = _IDENTITY_TF, _IDENTITY_TF
        elif mode == "tf":
            base = resolve(frame)
            assert parent_frame is not None
            if base is None:
                robot, offset = tree.lookup(parent_frame, frame, stamp, tol_ns), _IDENTITY_TF
            else:
                robot = tree.lookup(parent_frame, base, stamp, tol_ns)
                offset = (
                    _IDENTITY_TF
                    if offset_override is not None or base == frame
                    else tree.lookup(base, frame, stamp, tol_ns)
                )
        else:
            robot = body_pose.at(stamp, tol_ns)
            if offset_override is not None or pose_body == frame:
                offset = _IDENTITY_TF
            elif pose_body is None:
                raise ValueError(
                    f"pose_topic: {pose_topic!r} in {path} does not name the robot frame; pass "
                    f"base_frame= (to look the laser mounting up in tf) or sensor_offset="
                )
            elif pose_body in frames and frame in frames and tree.connected(pose_body, frame):
                offset = tree.lookup(pose_body, frame, stamp, tol_ns)
            else:
                raise ValueError(
                    f"sensor_offset: the pose topic {pose_topic!r} gives the pose of frame "
                    f"{pose_body!r} but tf in {path} does not connect it to the scan frame "
                    f"{frame!r}; pass sensor_offset=(x_m, y_m, yaw_rad)"
                )
        if robot is None or offset is None:
            if missing_pose == "error":
                raise ValueError(
                    f"{path}: no pose for the scan at t={stamp / 1e9:.9f} s (frame {frame!r}) "
                    f"within pose_tolerance_s of the pose data"
                )
            skipped += 1
            continue
        if robot[3] < 0:
            raise ValueError(
                f"{path}: the robot frame is mirrored (upside down) in tf at t={stamp / 1e9} s"
            )
        if offset[3] < 0:
            angle_min, inc = -angle_min, -inc
        final_offset = offset_override if offset_override is not None else offset[:3]
        try:
            scan = Scan(
                np.asarray(msg.ranges),
                angle_min,
                inc,
                float(msg.range_min),
                float(msg.range_max),
                robot[:3],
                final_offset,
                stamp / 1e9,
            )
        except (TypeError, ValueError) as err:
            raise ValueError(f"{path}: scan at t={stamp / 1e9:.9f} s: {err}") from None
        yield scan
    if skipped:
        warnings.warn(
            f"{path}: skipped {skipped} scan(s) on {scan_topic} with no pose within "
            f"pose_tolerance_s of the pose data",
            stacklevel=2,
        )
