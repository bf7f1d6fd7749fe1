"""ROS 1 / ROS 2 bag reader: ``sensor_msgs/LaserScan`` messages posed from tf or a pose
topic."""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from .._mcap_records import MCAP_MAGIC
from .._validate import flag, one_of, path_like, real_number, text_or_none
from ._mcap import _McapSequential
from ._ros1 import _ROS1_MAGIC, _Ros1Sequential
from ._tf import _IDENTITY_TF, BadTransform, _Tf, _tf_from_msg, _TfSeries, _TfTree
from .scan import PoseLike, Scan, _SkippedScans, mounting, no_scan_error

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


def _messages(path: Path, source, topics) -> Iterator[tuple[str, str, int, Any]]:
    """``source.messages(topics)``, with an error of the reader on a message (a damaged
    chunk or message: rosbags and its decompressors raise their own types) as a
    ValueError naming ``path``."""
    it = iter(source.messages(topics))
    while True:
        try:
            item = next(it)
        except StopIteration:
            return
        except Exception as exc:  # noqa: BLE001 - any reader error is a damaged file
            raise ValueError(
                f"path: {path} is damaged: a message after its start cannot be read "
                f"({type(exc).__name__}: {exc})"
            ) from None
        yield item


def _open_bag(path: Path) -> _AnyReaderSource | _Ros1Sequential | _McapSequential:
    if not path.exists():
        raise FileNotFoundError(f"path: bag not found: {path}")
    magic = b""
    if path.is_file():
        with open(path, "rb") as fh:
            magic = fh.read(len(_SQLITE_MAGIC))
    ros1 = magic[: len(_ROS1_MAGIC)] == _ROS1_MAGIC
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
        mcap = _lone_mcap(path) if path.is_dir() else path
        if magic.startswith(MCAP_MAGIC[:5]) or (mcap is not None and mcap.suffix == ".mcap"):
            return _mcap_fallback(mcap, err)
        _refuse_a_file_of_another_kind(path, magic)
        if path.is_dir() and not (path / "metadata.yaml").is_file():
            db3 = sorted(path.glob("*.db3"))
            if len(db3) == 1 and not list(path.glob("*.mcap")):
                source = _open_bag(db3[0])  # a recording cut off: metadata.yaml comes last
                warnings.warn(
                    f"{path}: the bag folder has no metadata.yaml (written when a recording "
                    f"ends: one cut off, say); read its one .db3 file, {db3[0].name}",
                    RuntimeWarning,
                    stacklevel=3,
                )
                return source
            counts = ((len(list(path.glob("*.mcap"))), ".mcap"), (len(db3), ".db3"))
            found = " and ".join(f"{n} {ext} file{'s' if n > 1 else ''}" for n, ext in counts if n)
            found = found or "neither"
            raise ValueError(
                f"path: {path} is a folder but not a ROS 2 bag: expected its metadata.yaml "
                f"(or, for a recording cut off, one .mcap or .db3 file), found {found}; pass "
                "the bag folder, one .mcap or .db3 file or a log file"
            ) from None
        raise ValueError(f"path: cannot read bag {target} with rosbags: {err!r}") from None


_SQLITE_MAGIC = b"SQLite format 3\x00"
#: The first bytes of a bag file by its suffix, and what it is.
_BAG_MAGIC = {".bag": (_ROS1_MAGIC, "ROS 1 bag"), ".db3": (_SQLITE_MAGIC, "ROS 2 SQLite bag")}


def _refuse_a_file_of_another_kind(path: Path, magic: bytes) -> None:
    """A ValueError for a ``.bag`` / ``.db3`` file that does not begin as one (a failed
    download, a renamed file), rather than the decoder's error, which prints its bytes."""
    want = _BAG_MAGIC.get(path.suffix.lower()) if path.is_file() else None
    if want is not None and not magic.startswith(want[0]):
        got = f"it begins with {magic[:8]!r}" if magic else "it is empty"
        raise ValueError(
            f"path: {path} is not a {want[1]}: it does not begin with {want[0]!r} ({got})"
        )


def _lone_mcap(folder: Path) -> Path | None:
    """The only ``.mcap`` file of a bag folder (one cut off while recording has no
    ``metadata.yaml``), else None."""
    files = sorted(folder.glob("*.mcap"))
    return files[0] if len(files) == 1 else None


def _mcap_fallback(path: Path, err: Exception) -> _McapSequential:
    """Read an MCAP file that ``rosbags`` refused (``err``) record by record: one cut off
    while recording (no summary, no end magic) is read up to the cut, with a warning."""
    with open(path, "rb") as fh:
        if fh.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
            raise ValueError(
                f"path: {path} is not an MCAP file: it does not begin with the MCAP magic "
                f"{MCAP_MAGIC!r} (rosbags: {err})"
            ) from None
    try:
        return _McapSequential(path)
    except ValueError as err2:
        raise ValueError(f"path: cannot read MCAP file {path}: {err2} (rosbags: {err})") from None


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
    ``.bag`` file, or a ROS 2 bag folder (or a ``.db3`` / ``.mcap`` file inside one).  A
    ROS 1 bag ``rosbags`` refuses (inconsistent index records; no index: cut off while
    recording) is read by a small sequential reader, up to any cut with a warning; an MCAP
    file cut off (no summary or end magic) up to its last whole message, with a warning
    giving the count; a bag folder without its ``metadata.yaml`` (written when the
    recording ends) as its one ``.mcap`` or ``.db3`` file, with a warning.

    Poses are planar: for each transform only ``x``, ``y`` and the heading of the rotated
    ``x`` axis are used; a frame whose ``z`` axis points down (an upside-down laser) mirrors
    the scan, which is represented by negating ``angle_min`` and ``angle_increment``.
    Transforms are linearly interpolated at the scan's ``header.stamp`` (the bag time when
    the stamp is zero); a ``/tf_static`` transform holds from its stamp until the next
    one of its frames (a scan before the first takes the first).

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
        LaserScan topic (a relative name, ``scan``, is ``/scan`` where the bag holds only
        that); default: the only LaserScan topic (ValueError listing the topics if there
        is none or more than one).
    pose_topic : str, optional
        Pose topic (see above).
    tf_parent : str, optional
        Map frame for tf poses.
    base_frame : str, optional
        Robot frame (see above).
    sensor_offset : array_like, shape (3,), optional
        Sensor pose in the robot frame, overriding tf; ``(x, y)`` within 100 m of its
        origin (as every sensor offset, tf's too).
    allow_missing_pose : bool, optional
        Use the identity pose when the bag has no pose source at all.
    pose_tolerance_s : float, optional
        A scan up to this many seconds before the first (after the last) sample of a
        transform takes that first (last) sample; default 0.1 s.
    missing_pose : {"skip", "error"}, optional
        What to do with scans whose time is outside the pose data: skip them (a warning
        gives the count at the end; none left: ValueError) or raise ValueError.  Pose and
        transform messages that are not finite or whose quaternion is zero (a
        localisation glitch) are left out of the pose data, with a warning.  So are
        LaserScan messages whose fields make no :class:`Scan` (an ``angle_increment``
        of 0 or NaN, a ``range_max`` not above ``range_min``, say: a sensor glitch):
        skipped, a warning gives the count and the first once the iterator is exhausted.

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
        Unreadable bag, topic selection problems, missing pose source or tf frames, no
        LaserScan that makes a scan (one among others, a glitch, is skipped: a warning).
    """
    p = _checked_path(path, scan_topic, pose_topic, tf_parent, base_frame)
    one_of("missing_pose", missing_pose, ("skip", "error"))
    allow_missing_pose = flag("allow_missing_pose", allow_missing_pose)
    tol = real_number("pose_tolerance_s", pose_tolerance_s)
    if tol < 0:
        raise ValueError(f"pose_tolerance_s: expected a value >= 0 s, received {tol!r}")
    offset = sensor_offset
    offset = None if offset is None else mounting("sensor_offset", offset)
    source = _open_bag(p)
    topics = source.topics
    listing = ", ".join(f"{t} [{m}]" for t, m in sorted(topics.items())) or "(none)"
    scan_topic = _choose_scan_topic(p, topics, scan_topic, listing)
    tf_topics = [t for t, m in topics.items() if m in _TF_TYPES]
    mode, pose_topic = _choose_pose_source(
        p, topics, tf_topics, pose_topic, allow_missing_pose, listing
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
        offset,
        int(round(tol * 1e9)),
        missing_pose,
    )


def _checked_path(path, *names) -> Path:
    """``path`` as a Path (:func:`path_like`) after checking it, and the topic and frame
    ``names`` of :func:`read_bag` (a str or None each)."""
    p = path_like("path", path)
    for name, value in zip(_NAMED, names, strict=True):
        text_or_none(name, value)
    return p


#: The arguments of :func:`read_bag` that name a topic or a frame.
_NAMED = ("scan_topic", "pose_topic", "tf_parent", "base_frame")


def _choose_scan_topic(
    p: Path, topics: dict[str, str], scan_topic: str | None, listing: str
) -> str:
    """``scan_topic`` after checking it is a LaserScan topic of the bag; by default the
    only one."""
    scan_topics = [t for t, m in topics.items() if m == _LASERSCAN]
    if scan_topic is None:
        if len(scan_topics) != 1:
            raise ValueError(
                f"scan_topic: expected exactly one {_LASERSCAN} topic in {p} to choose by "
                f"default, found {len(scan_topics)}; topics: {listing}"
            )
        return scan_topics[0]
    if topics.get(_in_root(scan_topic, topics)) != _LASERSCAN:
        raise ValueError(
            f"scan_topic: {scan_topic!r} is not a {_LASERSCAN} topic in {p}; topics: {listing}"
        )
    return _in_root(scan_topic, topics)


def _in_root(topic: str, topics: dict[str, str]) -> str:
    """``topic`` as the bag names it: a relative name (``scan``) that the bag holds only
    in the root namespace (``/scan``) is that topic, as ROS resolves it."""
    if topic in topics or topic.startswith("/") or "/" + topic not in topics:
        return topic
    return "/" + topic


def _choose_pose_source(
    p: Path,
    topics: dict[str, str],
    tf_topics: list[str],
    pose_topic: str | None,
    allow_missing_pose: bool,
    listing: str,
) -> tuple[str, str | None]:
    """Where the scans' poses come from (see :func:`read_bag`): ``("topic", pose_topic)``,
    ``("tf", None)`` or ``("none", None)``."""
    pose_topics = [t for t, m in topics.items() if m in _POSE_TYPES]
    if pose_topic is not None:
        if topics.get(_in_root(pose_topic, topics)) not in _POSE_TYPES:
            raise ValueError(
                f"pose_topic: {pose_topic!r} is not one of {', '.join(_POSE_TYPES)} in {p}; "
                f"topics: {listing}"
            )
        return "topic", _in_root(pose_topic, topics)
    if tf_topics:
        return "tf", None
    if len(pose_topics) == 1:
        return "topic", pose_topics[0]
    if pose_topics:
        raise ValueError(
            f"pose_topic: {p} has no tf and several pose topics {sorted(pose_topics)}; "
            f"choose one with pose_topic="
        )
    if allow_missing_pose:
        return "none", None
    raise ValueError(
        f"{p} has no pose source (no tf topic and no {', '.join(_POSE_TYPES)} topic); "
        f"topics: {listing}. Pass allow_missing_pose=True to read the scans with the identity "
        "pose (0, 0, 0), or pose_topic."
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
    tree, body_pose, pose_body = _collect_poses(
        path, source, mode, pose_topic, tf_topics, base_frame
    )
    poses = _ScanPoses(
        path,
        mode,
        tree,
        body_pose,
        pose_body,
        pose_topic,
        tf_parent,
        base_frame,
        offset_override,
        tol_ns,
    )
    skipped, first_skipped = 0, 0
    unusable = _SkippedScans()
    for _topic, _typ, t_ns, msg in _messages(path, source, [scan_topic]):
        stamp = _stamp_ns(msg.header.stamp) or t_ns
        frame = _frame(msg.header.frame_id)
        robot, offset = poses.at(frame, stamp)
        if robot is None or offset is None:
            if missing_pose == "error":
                raise ValueError(
                    f"{path}: no pose for the scan at t={stamp / 1e9:.9f} s (frame {frame!r}) "
                    f"within pose_tolerance_s of the pose data"
                )
            first_skipped = first_skipped or stamp
            skipped += 1
            continue
        scan = _bag_scan(path, msg, stamp, robot, offset, offset_override, unusable)
        if scan is not None:
            yield scan
    records = f"{_LASERSCAN} message(s) on {scan_topic}"
    if skipped and not unusable.made and not unusable.count:
        raise no_scan_error(
            path,
            f"{skipped} {records} skipped for no pose within pose_tolerance_s of the pose "
            f"data, the first at t={first_skipped / 1e9:.9f} s",
            "at least one scan within pose_tolerance_s of the pose data",
        )
    if skipped:
        warnings.warn(
            f"{path}: skipped {skipped} scan(s) on {scan_topic} with no pose within "
            f"pose_tolerance_s of the pose data",
            stacklevel=2,
        )
    unusable.finish(path, records, others=skipped)


def _collect_poses(
    path: Path,
    source: _AnyReaderSource | _Ros1Sequential,
    mode: str,
    pose_topic: str | None,
    tf_topics: list[str],
    base_frame: str | None,
) -> tuple[_TfTree, _TfSeries, str | None]:
    """First pass over the bag: the (small) pose data. The tf tree, the pose topic's
    series and the robot frame it poses (``base_frame`` if given, else its first
    message's Odometry child frame, else None)."""
    tree = _TfTree()
    body_pose = _TfSeries()
    pose_parent: str | None = None
    pose_body: str | None = None
    wanted = list(tf_topics)
    if mode == "topic" and pose_topic is not None:
        wanted.append(pose_topic)
    bad: list[str] = []  # the poses and transforms skipped (a localisation glitch)
    if mode != "none" and wanted:
        for topic, typ, t_ns, msg in _messages(path, source, wanted):
            if typ in _TF_TYPES:
                _add_transforms(path, tree, topic, t_ns, msg, bad)
                continue
            try:
                parent, body, stamp, tf = _pose_from_msg(typ, msg)
            except BadTransform as err:
                bad.append(f"{topic} at t={t_ns / 1e9:.9f} s: {err}")
                continue
            except ValueError as err:
                raise ValueError(f"{path}: topic {topic}: {err}") from None
            if pose_parent is None:
                pose_parent, pose_body = parent, body
            body_pose.add(stamp or t_ns, tf, False)
        if mode == "topic" and not body_pose.t:
            got = "no messages"
            if bad:
                got = f"no pose that is finite and a rotation (the first left out: {bad[0]})"
            raise ValueError(f"pose_topic: {pose_topic!r} in {path} has {got}")
        if mode == "topic" and base_frame is not None:
            pose_body = base_frame
    if bad:
        warnings.warn(
            f"{path}: skipped {len(bad)} pose(s) or transform(s) that are not finite or "
            f"not a rotation (a localisation glitch; scans use the poses around them), the "
            f"first on {bad[0]}",
            stacklevel=3,
        )
    return tree, body_pose, pose_body


def _add_transforms(
    path: Path, tree: _TfTree, topic: str, t_ns: int, msg: Any, bad: list[str]
) -> None:
    """Add the transforms of one tf message (received at bag time ``t_ns``) to ``tree``;
    one not finite or not a rotation is left out and described in ``bad`` (on a static
    topic, a mounting that is wrong throughout: ValueError)."""
    static = topic.rstrip("/").endswith("tf_static")
    for tr in msg.transforms:
        stamp = _stamp_ns(tr.header.stamp) or t_ns
        try:
            tf = _tf_from_msg(tr.transform.translation, tr.transform.rotation)
        except BadTransform as err:
            if static:
                raise ValueError(f"{path}: topic {topic}: {err}") from None
            bad.append(f"{topic} at t={stamp / 1e9:.9f} s: {err}")
            continue
        tree.add(_frame(tr.header.frame_id), _frame(tr.child_frame_id), stamp, tf, static)


class _ScanPoses:
    """The robot pose and sensor offset of each scan, by the pose source ``mode``:
    ``"none"`` (identity), ``"tf"`` (the tf chain from the map frame to the scan frame,
    split at the base frame) or ``"topic"`` (the pose topic, plus tf from its robot frame
    to the scan frame)."""

    def __init__(
        self,
        path: Path,
        mode: str,
        tree: _TfTree,
        body_pose: _TfSeries,
        pose_body: str | None,
        pose_topic: str | None,
        tf_parent: str | None,
        base_frame: str | None,
        offset_override: tuple[float, float, float] | None,
        tol_ns: int,
    ) -> None:
        self.path = path
        self.mode = mode
        self.tree = tree
        self.body_pose = body_pose
        self.pose_body = pose_body
        self.pose_topic = pose_topic
        self.base_frame = base_frame
        self.offset_override = offset_override
        self.tol_ns = tol_ns
        self.frames = tree.frames
        self.parent_frame = tf_parent
        if mode == "tf" and self.parent_frame is None:
            self.parent_frame = "map" if "map" in self.frames else "odom"
        self._resolved: dict[str, str | None] = {}

    def at(self, frame: str, stamp: int) -> tuple[_Tf | None, _Tf | None]:
        """Robot pose and sensor offset of a scan in ``frame`` at ``stamp`` (ns); None
        where the pose data do not reach that time."""
        if self.mode == "none":
            return _IDENTITY_TF, _IDENTITY_TF
        if self.mode == "tf":
            return self._from_tf(frame, stamp)
        return self._from_topic(frame, stamp)

    def _from_tf(self, frame: str, stamp: int) -> tuple[_Tf | None, _Tf | None]:
        tree, tol_ns = self.tree, self.tol_ns
        base = self._base(frame)
        assert self.parent_frame is not None
        if base is None:
            return tree.lookup(self.parent_frame, frame, stamp, tol_ns), _IDENTITY_TF
        robot = tree.lookup(self.parent_frame, base, stamp, tol_ns)
        offset = (
            _IDENTITY_TF
            if self.offset_override is not None or base == frame
            else tree.lookup(base, frame, stamp, tol_ns)
        )
        return robot, offset

    def _from_topic(self, frame: str, stamp: int) -> tuple[_Tf | None, _Tf | None]:
        pose_body, pose_topic, path = self.pose_body, self.pose_topic, self.path
        robot = self.body_pose.at(stamp, self.tol_ns)
        if self.offset_override is not None or pose_body == frame:
            offset = _IDENTITY_TF
        elif pose_body is None:
            raise ValueError(
                f"pose_topic: {pose_topic!r} in {path} does not name the robot frame; pass "
                "base_frame= (to look the laser mounting up in tf) or sensor_offset=(x_m, y_m, "
                "yaw_rad)"
            )
        elif (
            pose_body in self.frames
            and frame in self.frames
            and self.tree.connected(pose_body, frame)
        ):
            offset = self.tree.lookup(pose_body, frame, stamp, self.tol_ns)
        else:
            raise ValueError(
                f"sensor_offset: the pose topic {pose_topic!r} gives the pose of frame "
                f"{pose_body!r} but tf in {path} does not connect it to the scan frame "
                f"{frame!r}; pass sensor_offset=(x_m, y_m, yaw_rad)"
            )
        return robot, offset

    def _base(self, frame: str) -> str | None:
        """For tf mode: the base frame on the chain to split at (None: no split)."""
        if frame in self._resolved:
            return self._resolved[frame]
        parent_frame, base_frame = self.parent_frame, self.base_frame
        frames, path = self.frames, self.path
        if (
            parent_frame not in frames
            or frame not in frames
            or not self.tree.connected(parent_frame, frame)
        ):
            raise ValueError(
                f"tf_parent: no tf chain from {parent_frame!r} to the scan frame {frame!r} in "
                f"{path}; tf frames: {sorted(frames)} (try tf_parent='odom' or 'map', or "
                "pose_topic=)"
            )
        chain = self.tree.ancestors(frame)
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
        self._resolved[frame] = out
        return out


def _bag_scan(
    path: Path,
    msg: Any,
    stamp: int,
    robot: _Tf,
    offset: _Tf,
    offset_override: tuple[float, float, float] | None,
    unusable: _SkippedScans,
) -> Scan | None:
    """The :class:`Scan` of a LaserScan message at ``stamp`` (ns) with its poses; a mirrored
    sensor negates the beam angles.  None (counted in ``unusable``) where the message's
    fields make no scan."""
    angle_min = float(msg.angle_min)
    inc = float(msg.angle_increment)
    if robot[3] < 0:
        raise ValueError(
            f"{path}: the robot frame is mirrored (upside down) in tf at t={stamp / 1e9} s"
        )
    if offset[3] < 0:
        angle_min, inc = -angle_min, -inc
    final_offset = offset_override if offset_override is not None else offset[:3]
    return unusable.scan(
        f"at t={stamp / 1e9:.9f} s",
        np.asarray(msg.ranges),
        angle_min,
        inc,
        float(msg.range_min),
        float(msg.range_max),
        robot[:3],
        final_offset,
        stamp / 1e9,
    )
