"""The sensor's fixed offset on ``/tf_static`` (:mod:`topojax.io.mcap`), read back with the
``mcap`` package and its ROS 2 decoder, a reader that is not the writer: written at the
first scan and again only where the offset changes, latched as tf2's static broadcaster
offers it, and kept when a recording continues another."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import topojax as tj
from topojax.io.mcap import LASER_FRAME, MAP_FRAME, ROBOT_FRAME, McapRecorder

pytest.importorskip("rosbags")
pytest.importorskip("mcap_ros2")
yaml = pytest.importorskip("yaml")
from mcap.reader import make_reader  # noqa: E402
from mcap_ros2.decoder import DecoderFactory  # noqa: E402

A = (0.2, 0.0, 0.0)
B = (0.3, 0.1, 0.2)
SECOND = 1_000_000_000


def read(path: Path) -> list[tuple[str, int, object]]:
    """``(topic, log time ns, decoded message)`` of every message, in log time order."""
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [
            (channel.topic, message.log_time, ros)
            for _, channel, message, ros in reader.iter_decoded_messages(log_time_order=True)
        ]


def qos(path: Path, topic: str) -> list[dict]:
    """The offered QoS profiles recorded on ``topic``'s channel."""
    with open(path, "rb") as f:
        channels = make_reader(f).get_summary().channels.values()
    (channel,) = [c for c in channels if c.topic == topic]
    return yaml.safe_load(channel.metadata.get("offered_qos_profiles", "") or "[]") or []


def stamp_ns(header) -> int:
    return header.stamp.sec * SECOND + header.stamp.nanosec


def pose_of(transform) -> tuple[float, float, float]:
    t, q = transform.translation, transform.rotation
    return (t.x, t.y, math.atan2(2 * q.w * q.z, 1 - 2 * q.z * q.z))


def scan(i: int, offset, timestamp=None) -> tj.Scan:
    return tj.Scan.from_arrays(
        np.full(5, 2.0),
        (0.1 * i, 1.0, 0.5),
        angle_min=-0.2,
        angle_increment=0.1,
        range_max=10.0,
        sensor_offset=offset,
        timestamp=1.0 + i if timestamp is None else timestamp,
    )


def statics(messages) -> list[tuple[int, tuple[float, float, float]]]:
    """``(log time, offset)`` of each ``/tf_static`` message, checking that it holds the
    one static transform, base_link -> base_laser, stamped at its log time."""
    out = []
    for topic, t, msg in messages:
        if topic == "/tf_static":
            (tf,) = msg.transforms
            assert (tf.header.frame_id, tf.child_frame_id) == (ROBOT_FRAME, LASER_FRAME)
            assert stamp_ns(tf.header) == t
            out.append((t, pose_of(tf.transform)))
    return out


def assert_one_pose_per_scan(messages, scans) -> None:
    """``/tf`` holds the robot's pose alone at every scan, at the scan's stamp."""
    tfs = [(t, m) for tp, t, m in messages if tp == "/tf"]
    assert [t for t, _ in tfs] == [t for tp, t, _ in messages if tp == "/scan"]
    for (t, msg), s in zip(tfs, scans, strict=True):
        (tf,) = msg.transforms
        assert (tf.header.frame_id, tf.child_frame_id) == (MAP_FRAME, ROBOT_FRAME)
        assert stamp_ns(tf.header) == t
        assert pose_of(tf.transform) == pytest.approx(s.pose, abs=1e-12)


def record(path: Path, scans, continue_from=None) -> Path:
    with McapRecorder(path, continue_from=continue_from) as rec:
        for s in scans:
            rec.add_scan(s)
    return path


def test_the_offset_is_on_tf_static_at_the_first_scan_and_where_it_changes(tmp_path):
    offsets = [A, A, B, B, B, A]
    scans = [scan(i, o) for i, o in enumerate(offsets)]
    path = record(tmp_path / "r.mcap", scans)
    messages = read(path)
    assert statics(messages) == [
        (1 * SECOND, pytest.approx(A, abs=1e-12)),
        (3 * SECOND, pytest.approx(B, abs=1e-12)),
        (6 * SECOND, pytest.approx(A, abs=1e-12)),
    ]
    assert_one_pose_per_scan(messages, scans)
    # the static transform comes before the scan it belongs to
    order = [tp for tp, t, _ in messages if t == 1 * SECOND]
    assert order.index("/tf_static") < order.index("/scan")


def test_tf_static_is_latched_as_tf2_s_static_broadcaster_offers_it(tmp_path):
    path = record(tmp_path / "r.mcap", [scan(0, A), scan(1, A)])
    (profile,) = qos(path, "/tf_static")
    # rmw's numbers: history 1 keep last, reliability 1 reliable, durability 1 transient
    # local, as /map is offered
    assert (profile["history"], profile["depth"]) == (1, 1)
    assert (profile["reliability"], profile["durability"]) == (1, 1)
    assert qos(path, "/tf") == []  # a stream: the default, none recorded
    with McapRecorder(tmp_path / "m.mcap") as rec:
        rec.add_map(tj.sample_map("a_scan"))
    assert qos(tmp_path / "m.mcap", "/map") == [profile]


def test_an_offset_that_differs_only_by_rounding_is_not_written_again(tmp_path):
    """Logs that store the offset per scan carry rounding noise (1e-17 m in the
    robot-mapping course's Octave files): a mounting that did not move is one message."""
    scans = [scan(i, (1e-17 * i, -1e-15 * i, 1e-16 * i)) for i in range(5)]
    messages = read(record(tmp_path / "r.mcap", scans))
    assert statics(messages) == [(1 * SECOND, (0.0, 0.0, 0.0))]
    assert_one_pose_per_scan(messages, scans)


def test_a_yaw_that_differs_by_whole_turns_is_not_written_again(tmp_path):
    """A laser mounted backwards is at yaw pi or -pi (or 3 pi): one mounting, whose
    quaternions are opposite (z = 1 and z = -1); each counted as a change of offset and
    wrote /tf_static again.  A yaw a microradian off is still a change."""
    back = [(0.2, 0.0, math.pi), (0.2, 0.0, -math.pi), (0.2, 0.0, 3 * math.pi)]
    scans = [scan(i, o) for i, o in enumerate([*back, (0.2, 0.0, math.pi - 1e-6)])]
    messages = read(record(tmp_path / "r.mcap", scans))
    (first, _), (moved, offset) = statics(messages)
    assert (first, moved) == (1 * SECOND, 4 * SECOND)
    assert offset == pytest.approx((0.2, 0.0, math.pi - 1e-6), abs=1e-9)
    assert_one_pose_per_scan(messages, scans)


def test_a_recording_without_scans_has_no_tf(tmp_path):
    result = tj.build_graph(tj.sample_map("a_scan"))
    path = tj.save_mcap(result, tmp_path / "a.mcap")
    assert [tp for tp, *_ in read(path)] == ["/map", "/topology"]


@pytest.mark.parametrize(
    ("offsets", "split"),
    [([A, A, A, A], 2), ([A, A, B, B], 2), ([A, B, B, A], 2), ([A, B, B, B], 1)],
    ids=["same offset", "changed after the part", "changed in and after", "changed at"],
)
def test_a_continued_recording_has_the_static_transforms_of_the_whole(tmp_path, offsets, split):
    """The continued recording keeps the part's /tf_static and writes one only where the
    offset differs from the last one written, as the recording made at once does."""
    scans = [scan(i, o) for i, o in enumerate(offsets)]
    whole = record(tmp_path / "whole.mcap", scans)
    rec = McapRecorder(tmp_path / "r.mcap").open()
    for s in scans[:split]:
        rec.add_scan(s)
    part = rec.close(tmp_path / "part.mcap")
    with McapRecorder(tmp_path / "r.mcap", continue_from=part) as rec:
        assert rec.counts["/tf_static"] == len(statics(read(part)))
        for s in scans[split:]:
            rec.add_scan(s)
    messages = read(tmp_path / "r.mcap")
    assert statics(messages) == statics(read(whole))
    assert statics(messages)[0][0] == 1 * SECOND
    assert_one_pose_per_scan(messages, scans)


def test_a_continued_recording_without_a_static_transform_gets_one(tmp_path):
    """A part that holds no scan (stopped before the first) has no /tf_static: the first
    scan after it writes one."""
    with McapRecorder(tmp_path / "part.mcap") as rec:
        rec.add_map(tj.sample_map("a_scan"))
    path = record(tmp_path / "r.mcap", [scan(0, B), scan(1, B)], tmp_path / "part.mcap")
    assert statics(read(path)) == [(1 * SECOND, pytest.approx(B, abs=1e-12))]


def test_a_recording_reads_back_with_its_sensor_offset(tmp_path):
    """topojax's own bag reader finds the laser's mounting on /tf_static."""
    scans = [scan(i, B) for i in range(3)]
    back = list(tj.read_scans(record(tmp_path / "r.mcap", scans)))
    assert [s.sensor_offset for s in back] == [pytest.approx(B, abs=1e-9)] * 3
    assert [s.pose for s in back] == [pytest.approx(s.pose, abs=1e-9) for s in scans]


def test_a_recording_whose_offset_changes_reads_back_with_each_scan_s_offset(tmp_path):
    """Each /tf_static holds from its stamp on: a scan reads the latest one at or before
    its own time (the first, for scans before any), so the offsets written come back."""
    offsets = [A, A, B, B, B, A]
    scans = [scan(i, o) for i, o in enumerate(offsets)]
    back = list(tj.read_scans(record(tmp_path / "r.mcap", scans)))
    assert [s.sensor_offset for s in back] == [pytest.approx(o, abs=1e-9) for o in offsets]
