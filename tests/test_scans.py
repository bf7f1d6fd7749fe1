"""Tests for topojax.scans: the Scan type and the CARMEN / Octave / ROS bag readers."""

from __future__ import annotations

import gzip
import math
import pickle
import re
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest

from topojax.scans import (
    Scan,
    read_bag,
    read_carmen,
    read_octave_laser,
    read_scans,
    scans_from_arrays,
)

DATA = Path(__file__).resolve().parent / "data"
INTEL_EXCERPT = DATA / "intel_first40.log.gz"
OCTAVE_EXCERPT = DATA / "csail_laser_octave_first20.txt"
CCNY_EXCERPT = DATA / "ccny_demo_first25.bag"

# Scans (FLASER lines) per shared CARMEN log, from the shared data README.
CARMEN_COUNTS = {
    "intel": (910, 180),
    "freiburg-079": (4791, 360),
    "aces": (440, 180),
    "csail": (406, 361),
    "infinite-corridor": (1941, 180),
    "freiburg-101": (292, 360),
    "freiburg-campus": (2008, 360),
    "seattle": (241, 361),
    "orebro": (237, 181),
    "belgioioso": (395, 361),
    "fhw": (488, 180),
    "edmonton": (340, 180),
    "acapulco": (861, 181),
}


def _se2(x: float, y: float, yaw: float) -> np.ndarray:
    """3x3 homogeneous matrix of a planar pose (float64)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def _reference_endpoints(ranges, angles, pose, offset, mask) -> np.ndarray:
    """World end points via homogeneous matrices, independent of topojax."""
    t = _se2(*pose) @ _se2(*offset)
    r = np.asarray(ranges, dtype=np.float64)[mask]
    a = np.asarray(angles, dtype=np.float64)[mask]
    pts = np.stack([r * np.cos(a), r * np.sin(a), np.ones_like(r)])
    return (t @ pts)[:2].T


# ------------------------------------------------------------------------------------------
# Scan
# ------------------------------------------------------------------------------------------


def test_scan_fields_validated_and_read_only():
    src = np.array([1.0, 2.0, 3.0])
    s = Scan(src, -0.5, 0.5, 0.1, 10.0, (1, 2, 0.3), timestamp=5)
    assert s.pose == (1.0, 2.0, 0.3) and all(isinstance(v, float) for v in s.pose)
    assert s.sensor_offset == (0.0, 0.0, 0.0)
    assert s.timestamp == 5.0
    assert not s.ranges.flags.writeable
    src[0] = 99.0  # the scan holds a copy
    assert s.ranges[0] == 1.0
    with pytest.raises(ValueError):
        s.ranges[1] = 0.0
    assert Scan(np.array([1, 2], dtype=np.int32), 0, 1, 0, 5, (0, 0, 0)).ranges.dtype == np.float64
    assert Scan(np.ones(2, np.float32), 0, 1, 0, 5, (0, 0, 0)).ranges.dtype == np.float32
    far = Scan(np.ones(2), 0, 1, 0, 5, np.array([2e9, -3e9, 0.5]))  # no map-origin bound
    assert far.pose == (2e9, -3e9, 0.5)


@pytest.mark.parametrize(
    ("kwargs", "exc", "word"),
    [
        ({"ranges": np.ones((2, 3))}, ValueError, "ranges"),
        ({"ranges": np.array(["a", "b"])}, TypeError, "ranges"),
        ({"angle_increment": 0.0}, ValueError, "angle_increment"),
        ({"angle_increment": math.nan}, ValueError, "angle_increment"),
        ({"angle_min": math.inf}, ValueError, "angle_min"),
        ({"angle_increment": 1e300}, ValueError, r"angle_increment: .*within one turn"),
        ({"angle_increment": -0.25 * 180}, ValueError, "angle_increment"),  # degrees
        ({"angle_min": -135.0}, ValueError, r"angle_min: .*within one turn"),
        ({"range_min": -0.1}, ValueError, "range_min"),
        ({"range_max": 0.05}, ValueError, "range_max"),
        ({"range_max": math.nan}, ValueError, "range_max"),
        ({"pose": (0.0, math.nan, 0.0)}, ValueError, "pose"),
        ({"pose": (0.0, 0.0, math.inf)}, ValueError, "pose"),
        # a garbled yaw: 1e20 rad is no heading (float64 spacing there is 16384 rad)
        ({"pose": (0.0, 0.0, 1e20)}, ValueError, r"^pose: .* yaw within 1e\+09 rad of 0"),
        ({"sensor_offset": (0.0, 0.0, -3e38)}, ValueError, r"^sensor_offset: .* yaw within"),
        ({"pose": (0.0, 0.0)}, ValueError, "pose"),
        ({"sensor_offset": (0.0, 0.0, 0.0, 0.0)}, ValueError, "sensor_offset"),
        ({"sensor_offset": (math.nan, 0.0, 0.0)}, ValueError, "sensor_offset"),
        ({"timestamp": math.nan}, ValueError, "timestamp"),
        ({"angle_min": "0"}, TypeError, "angle_min"),
        ({"pose": None}, TypeError, "pose"),
        ({"pose": ("1", "2", "0")}, TypeError, "pose"),
        ({"sensor_offset": (True, 0.0, 0.0)}, TypeError, "sensor_offset"),
        # 100 km: no laser's mounting on its robot (millimetres given as metres?)
        (
            {"sensor_offset": (1e5, 0.0, 0.0)},
            ValueError,
            r"^sensor_offset: expected a sensor's mounting on its robot, \(x_m, y_m\) within "
            r"100 m of the robot's frame, received \(100000\.0, 0\.0, 0\.0\) \(100000 m off",
        ),
        ({"sensor_offset": (80.0, -80.0, 0.0)}, ValueError, r"sensor_offset: .*113\.137 m off"),
    ],
)
def test_scan_rejects_bad_fields(kwargs, exc, word):
    base = {
        "ranges": np.ones(4),
        "angle_min": 0.0,
        "angle_increment": 0.1,
        "range_min": 0.1,
        "range_max": 10.0,
        "pose": (0.0, 0.0, 0.0),
    }
    base.update(kwargs)
    with pytest.raises(exc, match=word):
        Scan(**base)


def test_scan_beams_sweeping_more_than_one_turn_are_refused():
    # 360 beams 1 degree apart, the increment given in degrees: the beams would sweep
    # 359 rad, 57 turns, and land scrambled around the robot
    with pytest.raises(ValueError, match=r"angle_increment: .*one turn.* 360 beams"):
        Scan.from_arrays(np.full(360, 3.0), (0, 0, 0), angle_min=0.0, angle_increment=1.0)
    with pytest.raises(ValueError, match=r"angle_increment: .*received -0\.5 rad"):
        Scan.from_arrays(np.full(100, 3.0), (0, 0, 0), angle_min=0.0, angle_increment=-0.5)
    # a full turn, the last beam repeating the first, is a real 360 degree sensor
    n = 721
    full = Scan.from_arrays(
        np.full(n, 3.0), (0, 0, 0), angle_min=-math.pi, angle_increment=2 * math.pi / (n - 1)
    )
    assert full.angle_max == pytest.approx(math.pi)
    one = Scan.from_arrays([3.0], (0, 0, 0), angle_min=0.0, angle_increment=6.0)
    assert one.n_beams == 1
    with pytest.raises(ValueError, match="angle_increment: .*one turn"):  # when called
        scans_from_arrays(np.ones((2, 360)), np.zeros((2, 3)), angle_min=0, angle_increment=1)


def test_valid_mask_drops_no_returns():
    r = np.array([1.0, np.nan, np.inf, -np.inf, -1.0, 0.0, 0.05, 0.1, 4.999, 5.0, 7.0])
    s = Scan(r, 0.0, 0.1, 0.1, 5.0, (0, 0, 0))
    expected = [True, False, False, False, False, False, False, True, True, False, False]
    np.testing.assert_array_equal(s.valid_mask(), expected)
    # range_min = 0 still drops zero and negative readings.
    s0 = Scan(r, 0.0, 0.1, 0.0, 5.0, (0, 0, 0))
    assert s0.valid_mask()[6] and not s0.valid_mask()[5] and not s0.valid_mask()[4]
    assert s.endpoints_world().shape == (3, 2)
    assert np.all(np.isfinite(s.endpoints_world()))


def test_float32_max_range_reading_is_no_return():
    # A ROS LaserScan stores range_max and ranges as float32: a reading equal to it is dropped.
    r = np.array([5.6, 5.5, 0.02, 0.019], dtype=np.float32)
    s = Scan(r, 0.0, 0.1, float(np.float32(0.02)), float(np.float32(5.6)), (0, 0, 0))
    np.testing.assert_array_equal(s.valid_mask(), [False, True, True, False])


def test_float32_reading_at_a_decimal_range_max_is_no_return():
    # The limits typed as decimals (a driver's 5.6 m from a config file) have no exact
    # float32: float32(5.6) < 5.6, so compared in float64 a stored max-range reading would
    # be a hit, a ring of phantom obstacles at the sensor's range.
    r = np.array([5.6, 5.5, 0.02, 0.019], dtype=np.float32)
    s = Scan(r, 0.0, 0.1, 0.02, 5.6, (0, 0, 0))
    np.testing.assert_array_equal(s.valid_mask(), [False, True, True, False])
    # float64 readings keep the exact comparison
    s64 = Scan(r.astype(np.float64), 0.0, 0.1, 0.02, 5.6, (0, 0, 0))
    np.testing.assert_array_equal(s64.valid_mask(), [True, True, False, False])
    # float16 readings are kept as such (not float64) and compared in float16: float16(4.2)
    # and float16(0.03) lie below 4.2 and 0.03
    h = np.array([4.2, 4.1, 0.03, 0.0299], dtype=np.float16)
    s16 = Scan(h, 0.0, 0.1, 0.03, 4.2, (0, 0, 0))
    assert s16.ranges.dtype == np.float16
    np.testing.assert_array_equal(s16.valid_mask(), [False, True, True, False])


@pytest.mark.parametrize("order", [">", "<"])
def test_readings_of_either_byte_order_keep_their_precision(order):
    # big-endian float32 readings (from a file or the network) are float32 readings: the
    # limits compare them as stored, so a reading at range_max is still no return
    for dtype, limit in (("f4", 5.6), ("f2", 4.2)):
        r = np.array([limit, 1.0], dtype=order + dtype)
        s = Scan(r, 0.0, 0.1, 0.0, limit, (0, 0, 0))
        assert s.ranges.dtype == np.dtype(dtype) and s.ranges.dtype.isnative
        np.testing.assert_array_equal(s.valid_mask(), [False, True])
        assert s.ranges.tolist() == r.tolist()
    wide = Scan(np.array([2.0, 3.0], order + "u2"), 0.0, 0.1, 0.0, 10.0, (0, 0, 0))
    assert wide.ranges.dtype == np.float64 and wide.ranges.tolist() == [2.0, 3.0]


def test_angles_and_properties():
    s = Scan(np.ones(5), -1.0, 0.25, 0.0, 2.0, (0, 0, 0))
    np.testing.assert_allclose(s.angles(), [-1.0, -0.75, -0.5, -0.25, 0.0], rtol=0, atol=1e-15)
    assert s.n_beams == 5 and s.angle_max == 0.0
    assert s.angles().dtype == np.float64


def test_endpoints_world_hand_computed():
    # Robot at (1, 2) facing +y; sensor 0.5 m ahead of the robot centre and turned by +90°.
    # Sensor pose in the world: (1, 2.5), yaw = pi.
    s = Scan(
        np.array([2.0, 3.0, 1.0]),
        0.0,
        math.pi / 2,
        0.0,
        10.0,
        (1.0, 2.0, math.pi / 2),
        (0.5, 0.0, math.pi / 2),
    )
    sx, sy, syaw = s.sensor_pose_world()
    assert (sx, sy) == pytest.approx((1.0, 2.5), abs=1e-12)
    assert abs(abs(syaw) - math.pi) < 1e-12
    # beam 0 (angle pi in the world): 2 m towards -x; beam 1 (3pi/2): 3 m towards -y;
    # beam 2 (2pi): 1 m towards +x.
    expected = np.array([[-1.0, 2.5], [1.0, -0.5], [2.0, 2.5]])
    np.testing.assert_allclose(s.endpoints_world(), expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_endpoints_world_random_vs_matrices(seed):
    rng = np.random.default_rng(seed)
    n = 97
    ranges = rng.uniform(0.0, 12.0, n)
    ranges[rng.integers(0, n, 10)] = np.nan
    ranges[rng.integers(0, n, 5)] = 10.0  # == range_max -> no return
    pose = tuple(rng.uniform(-20, 20, 2)) + (float(rng.uniform(-4, 4)),)
    offset = (float(rng.normal()), float(rng.normal()), float(rng.uniform(-4, 4)))
    inc = float(rng.choice([-1, 1]) * rng.uniform(0.001, 0.05))
    s = Scan(ranges, float(rng.uniform(-3, 3)), inc, 0.3, 10.0, pose, offset)
    mask = np.isfinite(ranges) & (ranges >= 0.3) & (ranges < 10.0)
    np.testing.assert_array_equal(s.valid_mask(), mask)
    angles = s.angle_min + inc * np.arange(n)
    ref = _reference_endpoints(ranges, angles, pose, offset, mask)
    np.testing.assert_allclose(s.endpoints_world(), ref, rtol=0, atol=1e-9)
    # The sensor pose must match the matrix product as well.
    t = _se2(*pose) @ _se2(*offset)
    sx, sy, syaw = s.sensor_pose_world()
    np.testing.assert_allclose([sx, sy], t[:2, 2], atol=1e-12)
    assert math.isclose(math.cos(syaw), t[0, 0], abs_tol=1e-12)
    assert math.isclose(math.sin(syaw), t[1, 0], abs_tol=1e-12)
    # Sensor-frame end points rotate/translate into the world ones.
    es = s.endpoints_sensor()
    np.testing.assert_allclose(
        (t @ np.vstack([es.T, np.ones(len(es))]))[:2].T, ref, rtol=0, atol=1e-9
    )


def test_from_arrays_and_scans_from_arrays():
    s = Scan.from_arrays([1.0, 2.0], np.array([1.0, 2.0, 3.0]), angle_min=0.0, angle_increment=0.1)
    assert s.pose == (1.0, 2.0, 3.0) and s.range_max == math.inf and s.range_min == 0.0
    ranges = np.arange(12.0).reshape(3, 4) + 1
    poses = np.array([[0, 0, 0], [1, 0, 0.5], [2, 1, 1.0]])
    scans = list(
        scans_from_arrays(
            ranges,
            poses,
            angle_min=-0.3,
            angle_increment=0.2,
            range_min=0.0,
            range_max=10.0,
            timestamps=[1.0, 2.0, 3.0],
        )
    )
    assert len(scans) == 3
    for i, sc in enumerate(scans):
        np.testing.assert_array_equal(sc.ranges, ranges[i])
        assert sc.pose == tuple(poses[i]) and sc.timestamp == i + 1.0
    assert scans[1].valid_mask().all()
    assert scans[2].valid_mask().tolist() == [True, False, False, False]  # 9, 10, 11, 12
    with pytest.raises(ValueError, match="poses"):
        scans_from_arrays(ranges, poses[:2], angle_min=0, angle_increment=0.1)
    with pytest.raises(ValueError, match="timestamps"):
        scans_from_arrays(ranges, poses, angle_min=0, angle_increment=0.1, timestamps=[1, 2])
    with pytest.raises(ValueError, match="ranges"):
        scans_from_arrays(ranges[0], poses, angle_min=0, angle_increment=0.1)
    with pytest.raises(ValueError, match="angle_increment"):
        scans_from_arrays(ranges, poses, angle_min=0, angle_increment=0.0)


@pytest.mark.parametrize(
    ("name", "bad"),
    [
        ("poses", np.zeros((3, 3)) + 1j),  # NumPy keeps the real part, with a warning
        ("poses", [["a", "b", "c"]] * 3),
        ("poses", [[0.0, 0.0, None]] * 3),  # NumPy reads None as NaN
        ("timestamps", np.zeros(3) + 1j),
        ("timestamps", ["a", "b", "c"]),
    ],
)
def test_scans_from_arrays_refuses_poses_and_times_that_are_no_real_numbers(name, bad):
    args = {"poses": np.zeros((3, 3)), "timestamps": None, name: bad}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning: a refusal
        with pytest.raises(TypeError, match=rf"^{name}: expected .*real numbers"):
            scans_from_arrays(
                np.ones((3, 4)),
                args["poses"],
                angle_min=0.0,
                angle_increment=0.1,
                timestamps=args["timestamps"],
            )


# ------------------------------------------------------------------------------------------
# CARMEN
# ------------------------------------------------------------------------------------------


def _flaser(ranges, pose, ts=1.5) -> str:
    x, y, th = pose
    vals = " ".join(f"{r:.2f}" for r in ranges)
    return f"FLASER {len(ranges)} {vals} {x} {y} {th} {x} {y} {th} {ts} host {ts}\n"


@pytest.mark.parametrize(
    ("n", "inc"),
    [
        (180, math.pi / 180),
        (360, math.pi / 360),
        (181, math.pi / 180),
        (361, math.pi / 360),
        (7, math.pi / 6),
        (8, math.pi / 8),
    ],
)
def test_carmen_beam_angle_convention(tmp_path, n, inc):
    path = tmp_path / "scan.log"
    path.write_text("# comment\nPARAM robot_frontlaser_offset 0.0 nohost 0\n")
    with open(path, "a") as fh:
        fh.write(_flaser(np.full(n, 2.0), (1.0, 2.0, 0.25)))
        fh.write("NEFF 12.5\nODOM 0 0 0 0 0 0 0 host 0\n")
    (scan,) = list(read_carmen(path, max_range_m=50.0))
    assert scan.n_beams == n
    assert scan.angle_min == -math.pi / 2
    assert scan.angle_increment == pytest.approx(inc, rel=1e-15)
    # Odd counts span exactly [-90°, +90°]; even counts stop one step short of +90°.
    last = math.pi / 2 if n % 2 else math.pi / 2 - math.pi / n
    assert scan.angles()[-1] == pytest.approx(last, abs=1e-12)
    # World beam angles are theta - pi/2 + i * inc, from the line's x, y.
    a = 0.25 - math.pi / 2 + inc * np.arange(n)
    ref = np.stack([1.0 + 2.0 * np.cos(a), 2.0 + 2.0 * np.sin(a)], axis=1)
    np.testing.assert_allclose(scan.endpoints_world(), ref, rtol=0, atol=1e-12)


def test_carmen_max_range_sentinel(tmp_path):
    path = tmp_path / "sentinel.log"
    lines = [
        _flaser([1.0, 81.83, 2.0, 81.7, 50.0], (0, 0, 0)),
        _flaser([81.83, 3.0, 81.83, 81.83, 0.0], (1, 0, 0)),
    ]
    path.write_text("".join(lines))
    a, b = list(read_carmen(path))
    assert a.range_max == pytest.approx(81.83 - 0.2)
    np.testing.assert_array_equal(a.valid_mask(), [True, False, True, False, True])
    np.testing.assert_array_equal(b.valid_mask(), [False, True, False, False, False])
    # An explicit max range replaces the file maximum (and keeps 81.7).
    a2, _ = list(read_carmen(path, max_range_m=81.8))
    assert a2.range_max == 81.8
    np.testing.assert_array_equal(a2.valid_mask(), [True, False, True, True, True])
    a3, _ = list(read_carmen(path, no_return_margin_m=0.0))
    np.testing.assert_array_equal(a3.valid_mask(), [True, False, True, True, True])
    with pytest.raises(ValueError, match="max_range_m"):
        read_carmen(path, max_range_m=-1.0)


def test_a_log_of_only_zero_readings_says_which_option_sets_the_max_range(tmp_path, capsys):
    """Readings all 0 leave no no-return value above the margin: the refusal says how to
    give the range, in the API and on the command line."""
    path = tmp_path / "zeros.log"
    path.write_text("".join(_flaser([0.0] * 5, (i, 0, 0)) for i in range(3)))
    with (
        pytest.warns(UserWarning, match="taken as the FLASER no-return value"),
        pytest.raises(ValueError, match=r"is not positive; pass max_range_m$"),
    ):
        list(read_carmen(path))
    assert len(list(read_carmen(path, max_range_m=10.0))) == 3
    from topojax.cli import main

    assert main(["replay", str(path), "-o", str(tmp_path / "o"), "--no-progress"]) != 0
    said = capsys.readouterr().err
    assert said.count("give --max-range") == 2  # the warning and the error
    assert "max_range_m" not in said


def test_one_faulty_reading_does_not_set_the_no_return_value(tmp_path):
    """A reading far above the no-return value in one scan (a corrupt line) is dropped
    with a warning; it does not lift the range limit, which would turn every real
    no-return beam into a wall."""
    rng = np.random.default_rng(5)
    ranges = [np.r_[rng.uniform(1, 5, 170), np.full(10, 81.83)] for _ in range(20)]
    clean = tmp_path / "clean.log"
    clean.write_text("".join(_flaser(r, (0, 0, 0)) for r in ranges))
    ranges[7] = ranges[7].copy()
    ranges[7][3] = 1000.0
    faulty = tmp_path / "faulty.log"
    faulty.write_text("".join(_flaser(r, (0, 0, 0)) for r in ranges))
    with pytest.warns(
        UserWarning, match=r"above the log's no-return value 81.83 m \(up to 1000 m\)"
    ):
        got = list(read_carmen(faulty))
    want = list(read_carmen(clean))
    assert [s.range_max for s in got] == [s.range_max for s in want] == [81.83 - 0.2] * 20
    for k, (a, b) in enumerate(zip(got, want, strict=True)):
        expect = b.valid_mask().copy()
        if k == 7:
            expect[3] = False
        np.testing.assert_array_equal(a.valid_mask(), expect)
    # the same reading in three scans out of 20 is no longer a fault: it sets the value
    for k in (12, 15):
        ranges[k] = ranges[k].copy()
        ranges[k][5] = 1000.0
    faulty.write_text("".join(_flaser(r, (0, 0, 0)) for r in ranges))
    assert {s.range_max for s in read_carmen(faulty)} == {1000.0 - 0.2}


def test_a_log_without_a_no_return_value_keeps_its_long_readings(tmp_path):
    """Scan maxima that form no cluster (no no-return value) leave the largest reading
    the limit: two scans whose maxima happen to agree do not make one."""
    path = tmp_path / "plain.log"
    ranges = [np.r_[np.full(5, 3.0), m] for m in (30.1, 12.0, 12.05)]
    path.write_text("".join(_flaser(r, (0, 0, 0)) for r in ranges))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # most readings are near no maximum: no warning due
        scans = list(read_carmen(path))
    assert {s.range_max for s in scans} == {30.1 - 0.2}
    assert int(scans[0].valid_mask().sum()) == 5  # 30.1 itself is taken as no-return


def test_carmen_gzip_detected_by_magic_not_suffix(tmp_path):
    text = _flaser([1.0, 2.0, 3.0, 4.0], (0.5, 0.25, 1.0)) + _flaser([2.0] * 4, (1, 1, 1))
    gz_named_txt = tmp_path / "log.txt"
    with gzip.open(gz_named_txt, "wt") as fh:
        fh.write(text)
    plain_named_gz = tmp_path / "log.gz"
    plain_named_gz.write_text(text)
    a = list(read_carmen(gz_named_txt, max_range_m=10.0))
    b = list(read_carmen(plain_named_gz, max_range_m=10.0))
    assert len(a) == len(b) == 2
    np.testing.assert_array_equal(a[0].ranges, b[0].ranges)
    assert a[0].pose == b[0].pose == (0.5, 0.25, 1.0)


@pytest.mark.parametrize(
    ("line", "needle"),
    [
        ("FLASER x 1 2 3\n", "integer"),
        ("FLASER 5 1 2 3\n", "at least"),
        ("FLASER 4 1 2 abc 4 0 0 0 0 0 0 1 h 1\n", "not a number"),
        ("FLASER 4 1 2 3 4 0 0 0 0 0 1 h 1\n", "fields after the 4 ranges"),
        # a beam count one short: the fifth range would be read as x, every field shifted
        ("FLASER 4 1 2 3 4 5 0 0 0 0 0 0 1 h 1\n", "ranges: expected 9 .* received 10"),
        ("FLASER 1 1 0 0 0 0 0 0 1 h 1\n", ">= 2"),
    ],
)
def test_carmen_malformed_lines_raise_with_line_number(tmp_path, line, needle):
    path = tmp_path / "bad.log"
    path.write_text(
        "# header\n" + _flaser([1, 2, 3, 4], (0, 0, 0)) + "ODOM 0 0 0 0 0 0 0 h 0\n" + line
    )
    with pytest.raises(ValueError, match=needle) as info:
        list(read_carmen(path))
    assert f"{path}:4:" in str(info.value)
    assert "FLASER" in str(info.value)
    assert "bad_lines='skip'" in str(info.value)  # the way past it
    # skipped on request, with a warning naming the count and the first line (also the
    # first pass that finds the no-return value)
    for kw in ({}, {"max_range_m": 10.0}):
        with pytest.warns(UserWarning, match=r"skipped 1 malformed FLASER .* line 4: "):
            scans = list(read_carmen(path, bad_lines="skip", **kw))
        assert len(scans) == 1 and scans[0].ranges.size == 4


@pytest.mark.parametrize(
    ("line", "counted"),
    [
        ("FLASER\n", "the beam count: expected at least 1 field after FLASER, received 0"),
        (
            "FLASER 3 1.0 2.0\n",
            "3 ranges: expected at least 3 fields after the beam count, received 2",
        ),
        (
            "ROBOTLASER1 0 -1 2 0.5 30\n",
            "the laser configuration: expected at least 8 fields after ROBOTLASER1, received 5",
        ),
        (
            "ROBOTLASER1 0 -1 2 0.5 30 0.01 0 3 1 2\n",
            "3 ranges and num_remissions: expected at least 4 fields after num_readings, "
            "received 2",
        ),
    ],
)
def test_a_short_carmen_line_counts_the_fields_its_message_names(tmp_path, line, counted):
    """A cut-short laser line's message counts the fields it names, not the keyword and
    the fields before them."""
    path = tmp_path / "short.log"
    path.write_text(line)
    with pytest.raises(ValueError, match=re.escape(counted)):
        list(read_carmen(path, max_range_m=10.0))


def test_carmen_bad_lines_is_checked(tmp_path):
    path = tmp_path / "ok.log"
    path.write_text(_flaser([1, 2, 3, 4], (0, 0, 0)))
    with pytest.raises(ValueError, match=r"^bad_lines: expected one of"):
        read_carmen(path, bad_lines="ignore")


def test_carmen_scans_whose_pose_is_not_finite_are_skipped(tmp_path):
    """A NaN or infinite pose (a localisation glitch) does not refuse the whole log
    before any scan is mapped: such scans are skipped with a warning naming the first
    line, as are pose-less scans posed from such an ODOM line."""
    path = tmp_path / "glitch.log"
    path.write_text(
        _flaser([1, 2, 3, 4], (0, 0, 0))
        + "FLASER 4 1 2 3 4 0 nan 0 0 0 0 1 h 1\n"
        + _flaser([1, 2, 3, 4], (1, 0, 0))
        + "FLASER 4 1 2 3 4 inf 0 0 0 0 0 1 h 1\n"
    )
    for kw in ({}, {"max_range_m": 10.0}):  # the log's range survey skips them too
        with pytest.warns(
            UserWarning, match=r"skipped 2 FLASER scan\(s\) whose pose is not finite .* line 2$"
        ):
            scans = list(read_carmen(path, **kw))
        assert [s.pose for s in scans] == [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)]
    raw = "RAWLASER1 0 -1.5 3.0 0.75 20.0 0.01 0 5 1 2 3 4 20 0 {ts} host {ts}\n"
    path.write_text(
        "ODOM 1.0 2.0 0.5 0 0 0 1.0 host 1.0\n"
        + raw.format(ts=1.1)
        + "ODOM nan 2.5 0.6 0 0 0 1.2 host 1.2\n"
        + raw.format(ts=1.3)
        + "ODOM 2.0 3.0 0.7 0 0 0 1.4 host 1.4\n"
        + raw.format(ts=1.5)
    )
    with pytest.warns(UserWarning, match=r"skipped 1 RAWLASER1 scan\(s\) whose pose .* line 4$"):
        scans = list(read_carmen(path))
    assert [s.pose for s in scans] == [(1.0, 2.0, 0.5), (2.0, 3.0, 0.7)]


def test_carmen_scans_whose_timestamp_is_not_finite_are_skipped(tmp_path):
    """A scan with a NaN or infinite timestamp (a logging glitch) is skipped with a
    warning naming the first line, as one whose pose is not finite is, in every message
    kind: not a malformed line that refuses the whole log."""
    path = tmp_path / "glitch.log"
    path.write_text(
        _flaser([1, 2, 3, 4], (0, 0, 0))
        + _flaser([1, 2, 3, 4], (0.5, 0, 0), ts="nan")
        + _flaser([1, 2, 3, 4], (1, 0, 0))
        + _flaser([1, 2, 3, 4], (1.5, 0, 0), ts="-inf")
    )
    for kw in ({}, {"max_range_m": 10.0}, {"bad_lines": "skip"}):
        with pytest.warns(UserWarning) as caught:
            scans = list(read_carmen(path, **kw))
        assert [str(w.message) for w in caught] == [
            f"{path}: skipped 2 FLASER scan(s) whose timestamp is not finite (NaN or infinite: "
            "a logging glitch), the first on line 2"
        ]
        assert [s.pose for s in scans] == [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)]
    robot = "ROBOTLASER1 0 -1 2 0.5 30 0.01 0 5 1 2 3 4 5 0 0 0 0 0 0 0 0 0 0 0 0 {ts} h 1\n"
    raw = "RAWLASER1 0 -1.5 3.0 0.75 20.0 0.01 0 5 1 2 3 4 20 0 {ts} host 1\n"
    poseless = "FLASER 4 1 2 3 4 {ts} host 1\n"
    for line in (robot, raw, poseless):
        path.write_text(
            "ODOM 1 2 0.5 0 0 0 1 host 1\n" + line.format(ts="nan") + line.format(ts="1.5")
        )
        kind = line.split()[0]
        with pytest.warns(
            UserWarning, match=rf"skipped 1 {kind} scan\(s\) whose timestamp is not .* line 2$"
        ):
            (scan,) = list(read_carmen(path, max_range_m=10.0))
        assert scan.timestamp == 1.5


def test_a_carmen_log_whose_every_pose_is_not_finite_is_refused_for_its_poses(tmp_path):
    """Every scan skipped for its pose is no log without a finite range reading (nor, with
    max_range_m, an empty log): the refusal names the poses and the first line, as the
    bag and Octave readers name the first record of a log none of whose records makes a
    scan."""
    path = tmp_path / "lost.log"
    path.write_text(
        "PARAM robot_front_laser_max 50\n"
        + "FLASER 4 1 2 3 4 0 nan 0 0 0 0 1 h 1\n"
        + "FLASER 4 1 2 3 4 inf 0 0 0 0 0 1 h 1\n"
    )
    pose_fault = (
        rf"^{re.escape(str(path))}: no scan to read: 2 FLASER line\(s\) skipped for a pose "
        r"that is not finite \(NaN or infinite\), the first on line 2: pose: expected finite "
        r"x y theta, received \[0\.0, nan, 0\.0\]; expected at least one well-formed FLASER "
        r"line with a finite pose and timestamp$"
    )
    for kw in ({}, {"max_range_m": 10.0}):
        with pytest.raises(ValueError, match=pose_fault):
            list(read_carmen(path, **kw))
    path.write_text(_flaser([1, 2, 3, 4], (0, 0, 0), ts="nan") + _flaser([1, 2], (0, "nan", 0)))
    with pytest.raises(
        ValueError, match=r"2 FLASER line\(s\) skipped for a timestamp or pose .* line 1: time"
    ):
        list(read_carmen(path, max_range_m=10.0))


def test_a_carmen_log_whose_every_laser_line_is_skipped_as_malformed_is_refused(tmp_path):
    # bad_lines="skip" passes over damage; a log of nothing but damage is no empty log
    path = tmp_path / "damaged.log"
    robot = "ROBOTLASER1 0 -1.5 3 0.1 10 0.1 0 3 1 2 x 0\n"
    expected = r"; expected at least one well-formed {} line with a finite pose and timestamp$"
    for text, kind in (
        (_flaser([1, 2, 3, 4], (0, 0, 0)).replace("2.00", "x") + "FLASER 4 1 2\n", "FLASER"),
        (robot, "ROBOTLASER1"),
    ):
        path.write_text(text)
        for kw in ({}, {"max_range_m": 10.0}):
            with pytest.raises(
                ValueError,
                match=rf"^{re.escape(str(path))}: no scan to read: \d malformed {kind} line\(s\) "
                r"skipped \(bad_lines='skip'\), the first on line 1: range reading: not a "
                r"number .*" + expected.format(kind),
            ):
                list(read_carmen(path, bad_lines="skip", **kw))
    # with lines skipped for a pose not finite, the refusal counts both
    path.write_text(_flaser([1, 2, 3, 4], (0, "nan", 0)) + "FLASER 4 1 2\n")
    for kw in ({}, {"max_range_m": 10.0}):
        with pytest.raises(
            ValueError,
            match=r"no scan to read: 1 FLASER line\(s\) skipped for a pose that is not finite "
            r".* on line 1: .*; 1 malformed FLASER line\(s\) skipped .* on line 2: .*"
            + expected.format("FLASER"),
        ):
            list(read_carmen(path, bad_lines="skip", **kw))


def test_replay_names_its_option_for_skipping_malformed_carmen_lines(tmp_path, capsys):
    """A malformed laser line stops ``topojax replay`` with the option that skips it,
    and a log of nothing else says the option skipped them: no API keyword either time."""
    from topojax.cli import main

    path = tmp_path / "bad.log"
    path.write_text(_flaser([1, 2, 3, 4], (0, 0, 0)) + "FLASER 4 1 2 abc 4 0 0 0 0 0 0 1 h 1\n")
    argv = ["replay", str(path), "-o", str(tmp_path / "o"), "--no-progress", "--max-range", "9"]
    assert main(argv) != 0
    said = capsys.readouterr().err
    assert "(--skip-bad-lines skips such lines with a warning)" in said
    assert "bad_lines" not in said
    path.write_text("FLASER 4 1 2 abc 4 0 0 0 0 0 0 1 h 1\n")
    assert main([*argv, "--skip-bad-lines"]) != 0
    said = capsys.readouterr().err
    assert "malformed FLASER line(s) skipped (--skip-bad-lines)" in said
    assert "bad_lines" not in said


def test_a_carmen_log_without_a_line_of_the_kind_asked_for_is_refused(tmp_path):
    path = tmp_path / "front.log"
    path.write_text(_flaser([1, 2, 3, 4], (0, 0, 0)))
    for kind in ("ROBOTLASER1", "RLASER"):
        with pytest.raises(
            ValueError,
            match=rf"^{re.escape(str(path))}: no scan to read: no {kind} line found; expected "
            rf"at least one, the kind laser='{kind}' asks for$",
        ):
            list(read_carmen(path, laser=kind))


def test_a_carmen_log_whose_every_scan_comes_before_the_first_odom_line_is_refused(tmp_path):
    path = tmp_path / "raw.log"
    path.write_text("RAWLASER1 0 -1.5 3.0 0.75 20.0 0.01 0 3 1 2 3 0 0.5 host 0.5\n")
    with pytest.raises(
        ValueError,
        match=r"no scan to read: 1 RAWLASER1 line\(s\) skipped before the first ODOM line "
        r"\(they have no pose\); expected",
    ):
        list(read_carmen(path))


def test_damaged_gzip_logs_raise_value_errors_naming_the_file(tmp_path):
    good = (DATA / "intel_first40.log.gz").read_bytes()
    flipped = bytearray(good)
    for i in range(len(good) // 3, len(good) // 3 + 200):
        flipped[i] ^= 0x5A
    bad = tmp_path / "flipped.log.gz"
    bad.write_bytes(bytes(flipped))
    header = bytearray(good)
    header[2] = 7  # unknown compression method
    odd = tmp_path / "header.log.gz"
    odd.write_bytes(bytes(header))
    for path in (bad, odd):
        with pytest.raises(ValueError, match="gzip-compressed data is damaged") as e:
            list(read_carmen(path))
        assert str(path) in str(e.value)
    assert len(list(read_carmen(DATA / "intel_first40.log.gz"))) == 40


def test_a_gzip_log_cut_off_reads_its_scans_up_to_the_cut(tmp_path):
    """A logger that stopped while writing a compressed log leaves its scans readable,
    as it does a plain one (the last, unfinished line is dropped), with a warning."""
    good = (DATA / "intel_first40.log.gz").read_bytes()
    whole = list(read_carmen(DATA / "intel_first40.log.gz"))
    cut = tmp_path / "cut.log.gz"
    cut.write_bytes(good[: len(good) * 9 // 10])
    with pytest.warns(RuntimeWarning, match=f"{cut}: the gzip-compressed data is cut off") as w:
        scans = list(read_carmen(cut))
    assert sum("cut off" in str(x.message) for x in w) == 1  # read twice, said once
    assert 20 < len(scans) < len(whole)
    for a, b in zip(scans, whole, strict=False):
        np.testing.assert_array_equal(a.ranges, b.ranges)
        assert a.pose == b.pose


def test_log_without_a_no_return_value_warns_when_most_readings_go(tmp_path):
    rng = np.random.default_rng(3)
    path = tmp_path / "short.log"
    path.write_text("".join(_flaser(rng.uniform(3.0, 3.1, 180), (i, 0, 0)) for i in range(3)))
    with pytest.warns(UserWarning, match=r"dropped: 5\d\d of 540.*pass max_range"):
        scans = list(read_carmen(path))
    assert sum(int(s.valid_mask().sum()) for s in scans) < 540 // 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scans = list(read_carmen(path, max_range_m=10.0))  # no guess: no warning
        assert all(s.valid_mask().all() for s in scans)
        # a log with a no-return value (81.91) on a few beams: no warning
        mixed = tmp_path / "mixed.log"
        ranges = [np.r_[rng.uniform(1, 5, 170), np.full(10, 81.91)] for _ in range(3)]
        mixed.write_text("".join(_flaser(r, (0, 0, 0)) for r in ranges))
        assert all(s.valid_mask().sum() == 170 for s in read_carmen(mixed))


def test_reading_a_long_log_holds_no_share_of_its_readings(tmp_path):
    """The pass that finds a log's no-return value streams: what it keeps does not grow
    with the readings near each scan's largest (a quarter of an outdoor log's readings
    are no-returns), so a log six times longer peaks at about the same memory."""
    import tracemalloc

    rng = np.random.default_rng(3)
    ranges = np.r_[np.full(170, 81.91), np.zeros(10)]

    def peak(n_scans: int) -> int:
        path = tmp_path / f"long{n_scans}.log"
        with open(path, "w") as fh:
            for _ in range(n_scans):
                ranges[170:] = rng.uniform(1, 5, 10)
                fh.write(_flaser(ranges, (0, 0, 0)))
        tracemalloc.start()
        try:
            with warnings.catch_warnings():  # most readings are no-returns: a warning
                warnings.simplefilter("ignore")
                assert sum(1 for _ in read_carmen(path)) == n_scans
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    assert peak(3000) - peak(500) < 1_500_000  # the no-returns alone are 3.4 MB


def test_a_line_that_is_no_carmen_message_is_counted_when_skipped(tmp_path):
    """A line whose first field is no message name (a scan whose name was garbled, bytes
    of another file) is skipped with a warning that counts such lines and names the
    first, rather than silently as a message of another kind."""
    lines = gzip.decompress(INTEL_EXCERPT.read_bytes()).decode("latin-1").splitlines()
    flaser = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    lines[flaser[3]] = "F\x00ASER" + lines[flaser[3]][6:]
    lines.insert(flaser[7], "\x13\x9c garbage\x00 bytes")
    path = tmp_path / "garbled.log"
    path.write_text("\n".join(lines) + "\n", encoding="latin-1")
    with pytest.warns(UserWarning) as caught:
        scans = list(read_carmen(path))
    assert len(scans) == 39
    said = [str(x.message) for x in caught]
    assert said == [
        f"{path}: skipped 2 line(s) that are no CARMEN message (their first field is no "
        f"message name), the first on line {flaser[3] + 1}: 'F\\x00ASER'"
    ]


def test_log_cut_off_mid_line_keeps_the_scans_before(tmp_path):
    text = (DATA / "intel_first40.log.gz").read_bytes()
    full = gzip.decompress(text).decode("latin-1")
    lines = full.splitlines(keepends=True)
    last = max(i for i, line in enumerate(lines) if line.startswith("FLASER"))
    cut = "".join(lines[:last]) + lines[last][: len(lines[last]) // 3]  # no line end
    path = tmp_path / "cut.log"
    path.write_text(cut)
    with pytest.warns(UserWarning, match=r"cut\.log:\d+: the log ends in the middle"):
        scans = list(read_carmen(path))
    assert len(scans) == 39
    want = list(read_carmen(DATA / "intel_first40.log.gz"))[:39]
    for a, b in zip(scans, want, strict=True):
        np.testing.assert_array_equal(a.ranges, b.ranges)
    # the same damage with a line end is a malformed line, not a cut-off file
    path.write_text(cut + "\n")
    with pytest.raises(ValueError, match="malformed FLASER line"):
        list(read_carmen(path))


def test_a_gzip_log_of_several_members_with_zero_padding_reads_whole(tmp_path):
    """Concatenated gzip members (``cat a.gz b.gz``) read as one log, zero padding after
    the last is no damage, and any other bytes after it are."""
    text = gzip.decompress((DATA / "intel_first40.log.gz").read_bytes())
    half = text.index(b"\nFLASER", len(text) // 2) + 1
    joined = tmp_path / "joined.log.gz"
    joined.write_bytes(gzip.compress(text[:half]) + gzip.compress(text[half:]) + bytes(100))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scans = list(read_carmen(joined))
    whole = list(read_carmen(DATA / "intel_first40.log.gz"))
    assert len(scans) == len(whole) == 40
    for a, b in zip(scans, whole, strict=True):
        np.testing.assert_array_equal(a.ranges, b.ranges)
    joined.write_bytes(gzip.compress(text) + b"trailing words")
    with pytest.raises(ValueError, match=r"joined\.log\.gz: the gzip-compressed data is damaged"):
        list(read_carmen(joined))


@pytest.mark.parametrize("packed", [False, True])
def test_a_log_saved_with_a_byte_order_mark_keeps_its_first_scan(tmp_path, packed):
    """A log saved by an editor that writes a UTF-8 byte order mark (and CRLF line ends)
    reads every scan: the mark is not part of the first line's message name, which would
    make its scan a line of no known kind, dropped without a word."""
    text = gzip.decompress(INTEL_EXCERPT.read_bytes()).decode("latin-1")
    lasers = "".join(line + "\r\n" for line in text.splitlines() if line.startswith("FLASER"))
    data = b"\xef\xbb\xbf" + lasers.encode("latin-1")
    path = tmp_path / ("bom.log.gz" if packed else "bom.log")
    path.write_bytes(gzip.compress(data) if packed else data)
    scans = list(read_scans(path))
    whole = list(read_carmen(INTEL_EXCERPT))
    assert len(scans) == len(whole) == 40
    for a, b in zip(scans, whole, strict=True):
        np.testing.assert_array_equal(a.ranges, b.ranges)
        assert a.pose == b.pose
    octave = tmp_path / "bom.txt"  # an Octave file is told by its first line
    octave.write_bytes(b"\xef\xbb\xbf" + OCTAVE_EXCERPT.read_bytes())
    assert len(list(read_scans(octave))) == len(list(read_octave_laser(OCTAVE_EXCERPT)))


def test_a_gzip_log_cut_mid_line_gives_one_warning_for_the_cut_and_its_line(tmp_path):
    """Compressed data cut off in the middle of a laser line: one warning says both
    (the data is cut off, that line is skipped), not one for each."""
    import zlib

    good = (DATA / "intel_first40.log.gz").read_bytes()
    size = len(good) // 2
    while True:  # a cut that ends the readable text a third of the way into a FLASER line
        text = zlib.decompressobj(31).decompress(good[:size]).decode("latin-1")
        last = text.rsplit("\n", 1)[1]
        if last.startswith("FLASER") and 10 < len(last.split()) < 100:
            break
        size += 7
    cut = tmp_path / "cut.log.gz"
    cut.write_bytes(good[:size])
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        scans = list(read_carmen(cut))
    lineno = text.count("\n") + 1
    assert [str(x.message) for x in w] == [
        f"{cut}: the gzip-compressed data is cut off; read up to the cut, where line "
        f"{lineno}, a FLASER line, ends mid-way and is skipped"
    ]
    assert w[0].category is RuntimeWarning
    assert len(scans) == text.count("\nFLASER") + text.startswith("FLASER") - 1


def test_carmen_errors_for_bad_arguments(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.log"):
        read_carmen(tmp_path / "nope.log")
    path = tmp_path / "empty.log"
    path.write_text("# nothing\nODOM 0 0 0 0 0 0 0 h 0\n")
    with pytest.raises(ValueError, match="no laser lines"):
        list(read_carmen(path))
    with pytest.raises(ValueError, match="laser"):
        read_carmen(path, laser="LASER9")


def test_carmen_robotlaser_line(tmp_path):
    n = 5
    start, res = -1.0, 0.5
    ranges = [1.0, 2.0, 30.0, 4.0, 5.0]
    laser_pose = (3.2, -1.1, 0.9)
    robot_pose = (3.0, -1.0, 0.7)
    line = (
        f"ROBOTLASER1 0 {start} 2.0 {res} 30.0 0.01 0 {n} "
        + " ".join(map(str, ranges))
        + " 2 0.5 0.6 "
        + " ".join(map(str, laser_pose + robot_pose))
        + " 0.1 0.0 0.5 0.3 0.0 12.25 host 12.3\n"
    )
    path = tmp_path / "new.log"
    path.write_text("ODOM 0 0 0 0 0 0 0 h 0\n" + line)
    (scan,) = list(read_carmen(path))
    assert scan.pose == robot_pose
    assert scan.range_max == 30.0 and scan.timestamp == 12.25
    assert scan.angle_min == start and scan.angle_increment == res
    # Offset = laser pose in the robot frame.
    off = np.linalg.inv(_se2(*robot_pose)) @ _se2(*laser_pose)
    np.testing.assert_allclose(scan.sensor_offset[:2], off[:2, 2], atol=1e-12)
    assert scan.sensor_offset[2] == pytest.approx(0.2, abs=1e-12)
    # End points are cast from the laser pose.
    mask = np.array([True, True, False, True, True])
    a = start + res * np.arange(n)
    ref = _reference_endpoints(ranges, a, laser_pose, (0, 0, 0), mask)
    np.testing.assert_allclose(scan.endpoints_world(), ref, rtol=0, atol=1e-12)
    # Truncated line -> error with line number.
    path.write_text(line.rsplit(" ", 8)[0] + "\n")
    with pytest.raises(ValueError, match=r"new\.log:1: malformed ROBOTLASER1"):
        list(read_carmen(path))


def test_a_sensor_offset_beyond_a_mounting_is_refused_by_every_reader(tmp_path):
    """A sensor offset of 100 km was taken, and put every beam 100 km off the robot; an
    offset farther than 100 m from the robot's frame is refused, naming the parameter,
    the bound and the value, and one of 100 m is taken."""
    far = (0.0, 150.0, 0.0)
    message = r"sensor_offset: expected a sensor's mounting .* within 100 m .* \(150 m off"
    for make in (
        lambda o: Scan.from_arrays(
            [1.0], (0, 0, 0), angle_min=0, angle_increment=1, sensor_offset=o
        ),
        lambda o: next(
            scans_from_arrays([[1.0]], [[0, 0, 0]], angle_min=0, angle_increment=1, sensor_offset=o)
        ),
        lambda o: list(read_carmen(INTEL_EXCERPT, sensor_offset=o)),
        lambda o: list(read_bag(CCNY_EXCERPT, sensor_offset=o, allow_missing_pose=True)),
    ):
        with pytest.raises(ValueError, match=message):
            make(far)
    edge = Scan.from_arrays(
        [1.0], (0, 0, 0), angle_min=0, angle_increment=1, sensor_offset=(0, 100, 0)
    )
    assert edge.sensor_offset == (0.0, 100.0, 0.0)
    # the log's own mounting (a PARAM in millimetres) is checked as well
    path = tmp_path / "raw.log"
    path.write_text(
        "PARAM robot_frontlaser_offset 250 nohost 0\n"
        "ODOM 1.0 2.0 0.5 0 0 0 1.0 host 1.0\n"
        "RAWLASER1 0 -1.5 3.0 0.75 20.0 0.01 0 5 1 2 3 4 20 0 1.2 host 1.2\n"
    )
    with pytest.raises(ValueError, match=r"PARAM robot_frontlaser_\*: expected a sensor's mou"):
        list(read_carmen(path))


def test_carmen_rawlaser_uses_latest_odom(tmp_path):
    raw = "RAWLASER1 0 -1.5 3.0 0.75 20.0 0.01 0 5 1 2 3 4 20 0 {ts} host {ts}\n"
    text = (
        "PARAM robot_frontlaser_offset 0.25 nohost 0\n"
        + raw.format(ts=0.5)  # before any ODOM: skipped with a warning
        + "ODOM 1.0 2.0 0.5 0 0 0 1.0 host 1.0\n"
        + "ODOM 1.5 2.5 0.6 0 0 0 1.1 host 1.1\n"
        + raw.format(ts=1.2)
        + "ODOM 2.0 3.0 0.7 0 0 0 1.3 host 1.3\n"
        + raw.format(ts=1.4)
    )
    path = tmp_path / "raw.log"
    path.write_text(text)
    with pytest.warns(UserWarning, match="skipped 1 RAWLASER1"):
        scans = list(read_carmen(path))
    assert [s.pose for s in scans] == [(1.5, 2.5, 0.6), (2.0, 3.0, 0.7)]
    assert scans[0].sensor_offset == (0.25, 0.0, 0.0)
    assert scans[0].range_max == 20.0
    assert scans[0].valid_mask().tolist() == [True, True, True, True, False]
    # A laser whose mounting is not in the log needs sensor_offset.
    path.write_text(text.replace("RAWLASER1", "RAWLASER3"))
    with pytest.raises(ValueError, match="sensor_offset"):
        list(read_carmen(path))
    with pytest.warns(UserWarning, match="skipped 1 RAWLASER3"):
        scans3 = list(read_carmen(path, sensor_offset=(0.0, 0.0, math.pi)))
    assert scans3[-1].sensor_offset == (0.0, 0.0, math.pi)
    # A broken ODOM line is reported (with its line number) when a scan needs it.
    path.write_text(text.replace("ODOM 1.5 2.5 0.6", "ODOM 1.5 x 0.6"))
    with pytest.raises(ValueError, match=r"raw\.log:4: malformed ODOM"):
        list(read_carmen(path))


def test_carmen_laser_selection(tmp_path):
    text = (
        _flaser([1, 2, 3, 4], (0, 0, 0))
        + "RLASER 4 5 5 5 5 1 1 3.1 1 1 3.1 1 h 1\n"
        + _flaser([1, 2, 3, 4], (1, 0, 0))
    )
    path = tmp_path / "two.log"
    path.write_text(text)
    # auto = kind of the first laser line, with a word on the lines of the others
    with pytest.warns(UserWarning) as caught:
        assert len(list(read_carmen(path))) == 2
    assert [str(w.message) for w in caught] == [
        f"{path}: read the FLASER lines, the first laser kind in the log; it also holds "
        "lines of other kinds, not read: 1 RLASER (pass laser=... to read another)"
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # asked for by name: the other kinds are not wanted
        assert len(list(read_carmen(path, laser="FLASER", max_range_m=10.0))) == 2
        (rear,) = list(read_carmen(path, laser="RLASER", max_range_m=10.0))
    assert rear.pose == (1.0, 1.0, 3.1) and rear.ranges.tolist() == [5.0] * 4


def test_replay_reads_the_carmen_laser_it_is_asked_for(tmp_path, capsys):
    """``topojax replay --laser`` reads another laser of a CARMEN log than the first."""
    from topojax.cli import main

    text = "".join(
        _flaser([1.0, 2.0, 3.0, 4.0], (0.1 * k, 0, 0), ts=k)
        + f"RLASER 4 5 5 5 5 {0.1 * k} 1 3.1 {0.1 * k} 1 3.1 {k} h {k}\n"
        for k in range(4)
    )
    path = tmp_path / "two.log"
    path.write_text(text)
    argv = ["replay", str(path), "--no-progress", "--max-range", "10"]
    assert main([*argv, "-o", str(tmp_path / "rear"), "--laser", "RLASER"]) == 0
    captured = capsys.readouterr()
    assert "4 scans" in captured.out and "warning" not in captured.err
    assert main([*argv, "-o", str(tmp_path / "front")]) == 0
    captured = capsys.readouterr()
    assert "4 scans" in captured.out and "not read: 4 RLASER" in captured.err
    assert "(give --laser KIND to read another)" in captured.err
    assert "laser=" not in captured.err
    rear, front = ((tmp_path / d / "map.pgm").read_bytes() for d in ("rear", "front"))
    assert rear != front
    # a kind the log does not hold is refused under the option's name
    path.write_text("".join(_flaser([1.0, 2.0], (0, 0, 0), ts=k) for k in range(2)))
    assert main([*argv, "-o", str(tmp_path / "none"), "--laser", "RLASER"]) == 2
    assert "at least one, the kind --laser 'RLASER' asks for" in capsys.readouterr().err


def _first_flaser_tokens(path: Path) -> list[str]:
    with gzip.open(path, "rt") as fh:
        for line in fh:
            if line.startswith("FLASER"):
                return line.split()
    raise AssertionError("no FLASER line")


def test_intel_excerpt():
    scans = list(read_carmen(INTEL_EXCERPT))
    assert len(scans) == 40
    first = scans[0]
    assert first.n_beams == 180
    tok = _first_flaser_tokens(INTEL_EXCERPT)
    n = int(tok[1])
    assert n == 180
    assert first.pose == (float(tok[2 + n]), float(tok[3 + n]), float(tok[4 + n]))
    np.testing.assert_array_equal(first.ranges, np.array(tok[2 : 2 + n], dtype=float))
    assert first.timestamp == float(tok[8 + n])
    assert first.angle_increment == pytest.approx(math.pi / 180)
    # 81.83 is this log's no-return value: never a valid reading.
    all_r = np.concatenate([s.ranges for s in scans])
    assert all_r.max() == 81.83
    assert all(s.range_max == pytest.approx(81.83 - 0.2) for s in scans)
    assert not any(np.any(s.ranges[s.valid_mask()] >= 81.0) for s in scans)
    assert sum(int((~s.valid_mask()).sum()) for s in scans) == int((all_r >= 81.83).sum())
    pts = np.concatenate([s.endpoints_world() for s in scans])
    assert np.all(np.isfinite(pts)) and np.abs(pts).max() < 30.0


def _check_carmen_file(path: Path, count: int, beams: int) -> None:
    n = 0
    file_max = -math.inf
    for s in read_carmen(path):
        n += 1
        assert s.n_beams == beams
        file_max = max(file_max, float(s.ranges.max()))
        valid = s.ranges[s.valid_mask()]
        assert np.all(valid < s.range_max)
    assert n == count
    assert s.range_max == pytest.approx(file_max - 0.2)


@pytest.mark.parametrize("name", ["orebro", "seattle", "freiburg-101", "edmonton"])
def test_small_shared_carmen_logs(shared_data, name):
    path = shared_data / "logs" / "carmen_corrected" / f"{name}-corrected.log.gz"
    _check_carmen_file(path, *CARMEN_COUNTS[name])


@pytest.mark.slow
def test_all_shared_carmen_logs(shared_data):
    folder = shared_data / "logs" / "carmen_corrected"
    found = sorted(p.name for p in folder.glob("*.log.gz"))
    assert found == sorted(f"{k}-corrected.log.gz" for k in CARMEN_COUNTS)
    for name, (count, beams) in CARMEN_COUNTS.items():
        _check_carmen_file(folder / f"{name}-corrected.log.gz", count, beams)


# ------------------------------------------------------------------------------------------
# Octave
# ------------------------------------------------------------------------------------------


def _octave_first_matrix_line(path: Path, field: str) -> list[float]:
    """First data line of the first element of ``field`` (independent text scan)."""
    lines = path.read_text().splitlines()
    i = lines.index(f"# name: {field}")
    while lines[i].startswith("#"):
        i += 1
    return [float(v) for v in lines[i].split()]


def test_octave_excerpt():
    scans = list(read_octave_laser(OCTAVE_EXCERPT))
    assert len(scans) == 20
    s0, s1 = scans[0], scans[1]
    assert s0.n_beams == 361
    np.testing.assert_array_equal(s0.ranges, _octave_first_matrix_line(OCTAVE_EXCERPT, "ranges"))
    assert s0.angle_min == -1.570796 and s0.angle_increment == 0.008727
    assert s0.range_max == 80.0 and s0.range_min == 0.0
    assert s0.timestamp == 1134864642.914187
    assert s1.pose == (0.319678, 0.110037, 0.99433)
    assert s1.sensor_offset == (6.288372600415926e-18, 1.843143693225358e-17, 0.0)
    # 81.91 means "no return".
    assert np.any(s1.ranges == 81.91) and not np.any(s1.ranges[s1.valid_mask()] > 80.0)


def test_octave_shared_file(shared_data):
    path = shared_data / "logs" / "robot_mapping_course" / "csail_laser_octave.txt"
    scans = list(read_octave_laser(path))
    assert len(scans) == 686
    assert {s.n_beams for s in scans} == {361}
    poses = np.array([s.pose for s in scans])
    assert poses[:, 0].min() == pytest.approx(-8.2, abs=0.05)
    assert poses[:, 0].max() == pytest.approx(32.0, abs=0.05)
    assert poses[:, 1].min() == pytest.approx(-29.4, abs=0.05)
    assert poses[:, 1].max() == pytest.approx(32.3, abs=0.05)
    excerpt = list(read_octave_laser(OCTAVE_EXCERPT))
    for a, b in zip(excerpt, scans[:20], strict=True):
        np.testing.assert_array_equal(a.ranges, b.ranges)
        assert a.pose == b.pose and a.timestamp == b.timestamp


_OCTAVE_NDIMS = """# Created by Octave 8.4.0
# name: other
# type: scalar
3

# name: scans
# type: struct
# ndims: 2
 1 2
# length: 5
# name: start_angle
# type: cell
# ndims: 2
 1 2
# name: <cell-element>
# type: scalar
-1


# name: <cell-element>
# type: scalar
-0.5


# name: angular_resolution
# type: cell
# ndims: 2
 1 2
# name: <cell-element>
# type: scalar
0.5


# name: <cell-element>
# type: scalar
0.25


# name: maximum_range
# type: cell
# ndims: 2
 1 2
# name: <cell-element>
# type: scalar
10


# name: <cell-element>
# type: scalar
10


# name: ranges
# type: cell
# ndims: 2
 1 2
# name: <cell-element>
# type: matrix
# rows: 1
# columns: 3
 1 2 Inf


# name: <cell-element>
# type: matrix
# ndims: 2
 3 1
 4
 NaN
 6


# name: pose
# type: cell
# ndims: 2
 1 2
# name: <cell-element>
# type: matrix
# rows: 3
# columns: 1
 1
 2
 0.5


# name: <cell-element>
# type: matrix
# rows: 1
# columns: 3
 -1 -2 -0.5

"""


def test_octave_parser_newer_headers(tmp_path):
    path = tmp_path / "scans.txt"
    path.write_text(_OCTAVE_NDIMS)
    a, b = list(read_octave_laser(path))
    assert a.ranges.tolist()[:2] == [1.0, 2.0] and math.isinf(a.ranges[2])
    assert a.pose == (1.0, 2.0, 0.5) and a.sensor_offset == (0.0, 0.0, 0.0)
    assert a.timestamp is None and a.angle_min == -1.0 and a.angle_increment == 0.5
    assert b.ranges[0] == 4.0 and math.isnan(b.ranges[1]) and b.ranges[2] == 6.0
    assert b.pose == (-1.0, -2.0, -0.5) and b.angle_increment == 0.25
    assert b.valid_mask().tolist() == [True, False, True]
    # Found through read_scans too (content sniffing).
    assert len(list(read_scans(path))) == 2


def test_octave_scans_whose_pose_is_not_finite_are_skipped(tmp_path):
    path = tmp_path / "scans.txt"
    path.write_text(_OCTAVE_NDIMS.replace(" 1\n 2\n 0.5\n", " nan\n 2\n 0.5\n", 1))
    with pytest.warns(UserWarning, match=r"skipped 1 scan\(s\) whose pose is not finite"):
        (b,) = list(read_octave_laser(path))
    assert b.pose == (-1.0, -2.0, -0.5)


@pytest.mark.parametrize(
    ("field", "old", "new", "why"),
    [
        ("angular_resolution", "0.5", "0", "angle_increment: expected a non-zero angle"),
        ("angular_resolution", "0.5", "NaN", "angle_increment: expected a finite number"),
        ("maximum_range", "10", "0", r"range_max: expected a value > range_min \(0\.0 m\)"),
        ("start_angle", "-1", "NA", "angle_min: expected a finite number"),
    ],
)
def test_octave_scans_whose_fields_make_no_scan_are_skipped(tmp_path, field, old, new, why):
    """An element with an impossible geometry (a sensor glitch) is skipped, as the bag
    reader skips such a message, with the bag reader's warning naming the first and why,
    rather than stopping the reading part way."""
    path = tmp_path / "scans.txt"
    head, tail = _OCTAVE_NDIMS.split(f"# name: {field}\n")
    first = f"# type: scalar\n{old}\n"
    assert first in tail  # its first occurrence: the field's first element
    tail = tail.replace(first, f"# type: scalar\n{new}\n", 1)
    path.write_text(head + f"# name: {field}\n" + tail)
    with pytest.warns(UserWarning) as caught:
        (b,) = list(read_octave_laser(path))
    (message,) = [str(w.message) for w in caught]
    assert re.fullmatch(
        rf"{re.escape(str(path))}: skipped 1 element\(s\) of scans whose fields make no scan "
        rf"\(a sensor glitch\), the first scans\(1\): {why}.*",
        message,
    ), message
    assert b.pose == (-1.0, -2.0, -0.5) and b.angle_increment == 0.25


def _octave_refused(path, text: str, match: str) -> None:
    """An Octave log of ``text`` written at ``path`` is refused with ``match``."""
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        list(read_octave_laser(path))


def test_an_octave_log_whose_every_pose_is_not_finite_is_refused(tmp_path):
    # each skipped alone, but together no empty log behind a warning
    text = _OCTAVE_NDIMS.replace(" 1\n 2\n 0.5\n", " nan\n 2\n 0.5\n", 1)
    _octave_refused(
        tmp_path / "scans.txt",
        text.replace(" -1 -2 -0.5\n", " -1 inf -0.5\n", 1),
        r": no scan to read: 2 element\(s\) of scans skipped for a pose that is not finite "
        r"\(NaN or infinite\), the first scans\(1\); expected at least one element of scans "
        r"with a finite pose$",
    )


def test_an_octave_log_none_of_whose_elements_makes_a_scan_is_refused(tmp_path):
    # angles in degrees are no glitch: skipping every element would read as an empty log
    text = OCTAVE_EXCERPT.read_text()
    assert "-1.570796" in text
    _octave_refused(
        tmp_path / "degrees.txt",
        text.replace("-1.570796", "-90"),
        r": no scan to read: 20 element\(s\) of laser skipped, the first whose fields "
        r"make none is laser\(1\): .*; expected at least one whose fields make a scan$",
    )


def test_an_octave_log_refused_counts_every_element_skipped(tmp_path):
    # one pose not finite, the other element's fields make no scan: both count
    text = _OCTAVE_NDIMS.replace(" 1\n 2\n 0.5\n", " nan\n 2\n 0.5\n", 1)
    head, tail = text.split("# name: angular_resolution\n")
    tail = tail.replace("# type: scalar\n0.25\n", "# type: scalar\n0\n", 1)
    with pytest.warns(UserWarning, match="whose pose is not finite"):
        _octave_refused(
            tmp_path / "scans.txt",
            head + "# name: angular_resolution\n" + tail,
            r": no scan to read: 2 element\(s\) of scans skipped, the first whose fields "
            r"make none is scans\(2\): angle_increment",
        )


def test_octave_errors(tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text(_OCTAVE_NDIMS.replace(" 1 2 Inf", " 1 2"))
    with pytest.raises(ValueError, match=r"bad\.txt:\d+: expected 3 numbers"):
        list(read_octave_laser(bad))
    missing = tmp_path / "missing.txt"
    missing.write_text(_OCTAVE_NDIMS.replace("# length: 5", "# length: 4").split("# name: pose")[0])
    with pytest.raises(ValueError, match="pose"):
        list(read_octave_laser(missing))
    with pytest.raises(ValueError, match="variable"):
        list(read_octave_laser(OCTAVE_EXCERPT, variable="nope"))
    # a variable name that is no str is refused on the call, before the file is parsed
    with pytest.raises(TypeError, match="variable: expected a str or None, received int 5"):
        read_octave_laser(OCTAVE_EXCERPT, variable=5)
    with pytest.raises(FileNotFoundError):
        read_octave_laser(tmp_path / "none.txt")


@pytest.mark.parametrize("packed", [False, True])
def test_an_octave_file_cut_off_is_refused_as_cut_off(tmp_path, packed):
    """An Octave file stores each field of every scan together (the poses after all the
    ranges), so one cut off while written has no scan to read: it is refused saying it
    is cut off, where it was cut and why nothing is read; a compressed one is not first
    said to be read up to the cut."""
    text = OCTAVE_EXCERPT.read_bytes()
    half = text[: len(text) // 2]
    path = tmp_path / ("cut.txt.gz" if packed else "cut.txt")
    path.write_bytes(gzip.compress(text)[: len(gzip.compress(half))] if packed else half)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(ValueError) as info:
            list(read_scans(path))
    assert not [str(x.message) for x in caught]
    said = str(info.value)
    assert said.startswith(f"{path}: the file is cut off at line ")
    assert "no scan can be read" in said


# ------------------------------------------------------------------------------------------
# ROS bags
# ------------------------------------------------------------------------------------------

T0_NS = 1_700_000_000 * 1_000_000_000
MAP_ODOM = (2.0, 1.0, 0.5)
BASE_LASER = (0.2, -0.1, 0.3)  # x, y, yaw of the laser on the robot (z = 0.3 m)
N_BEAMS = 40


def _odom_base(t: float) -> tuple[float, float, float]:
    """Robot pose in the odom frame, linear in time (so linear interpolation is exact)."""
    return (1.0 + 0.5 * t, -2.0 + 0.2 * t, 0.3 + 0.4 * t)


def _scan_ranges(k: int) -> np.ndarray:
    rng = np.random.default_rng(k)
    r = rng.uniform(0.5, 7.5, N_BEAMS).astype(np.float32)
    r[3] = np.nan
    r[5] = 8.0  # == range_max -> no return
    r[7] = np.inf
    return r


def _quat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_euler("xyz", [roll, pitch, yaw]).as_quat()  # x, y, z, w


def _matrix(x: float, y: float, z: float, quat) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(quat).as_matrix()
    m[:3, 3] = (x, y, z)
    return m


class _BagWriter:
    """Write LaserScan / TF / Odometry messages into a ROS 1 or ROS 2 bag with rosbags."""

    def __init__(self, path: Path, ros: int) -> None:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        self.ros = ros
        if ros == 1:
            from rosbags.rosbag1 import Writer

            self.ts = get_typestore(Stores.ROS1_NOETIC)
            if "tf2_msgs/msg/TFMessage" not in self.ts.fielddefs:
                self.ts.register(
                    get_types_from_msg(
                        "geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"
                    )
                )
            self.writer = Writer(path)
        else:
            from rosbags.rosbag2 import Writer

            self.ts = get_typestore(Stores.ROS2_HUMBLE)
            self.writer = Writer(path, version=9)
        self.writer.open()
        self.conns: dict[str, object] = {}

    def _header(self, t_ns: int, frame: str):
        t = self.ts.types
        stamp = t["builtin_interfaces/msg/Time"](sec=t_ns // 10**9, nanosec=t_ns % 10**9)
        if self.ros == 1:
            return t["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame)
        return t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def write(self, topic: str, msgtype: str, t_ns: int, msg) -> None:
        if topic not in self.conns:
            self.conns[topic] = self.writer.add_connection(topic, msgtype, typestore=self.ts)
        data = (
            self.ts.serialize_ros1(msg, msgtype)
            if self.ros == 1
            else self.ts.serialize_cdr(msg, msgtype)
        )
        self.writer.write(self.conns[topic], t_ns, data)

    def scan(self, topic: str, t_ns: int, frame: str, ranges: np.ndarray, **fields) -> None:
        """A LaserScan message; ``fields`` replace its beam geometry and limits."""
        t = self.ts.types
        geometry = {
            "angle_min": -1.2,
            "angle_max": -1.2 + 0.06 * (N_BEAMS - 1),
            "angle_increment": 0.06,
            "range_min": 0.1,
            "range_max": 8.0,
        }
        msg = t["sensor_msgs/msg/LaserScan"](
            header=self._header(t_ns, frame),
            time_increment=0.0,
            scan_time=0.1,
            ranges=ranges,
            intensities=np.zeros(0, dtype=np.float32),
            **{**geometry, **fields},
        )
        self.write(topic, "sensor_msgs/msg/LaserScan", t_ns, msg)

    def transform(self, parent, child, t_ns, x, y, z, quat):
        t = self.ts.types
        return t["geometry_msgs/msg/TransformStamped"](
            header=self._header(t_ns, parent),
            child_frame_id=child,
            transform=t["geometry_msgs/msg/Transform"](
                translation=t["geometry_msgs/msg/Vector3"](x=x, y=y, z=z),
                rotation=t["geometry_msgs/msg/Quaternion"](
                    x=quat[0], y=quat[1], z=quat[2], w=quat[3]
                ),
            ),
        )

    def tf(self, topic: str, t_ns: int, transforms: list) -> None:
        msg = self.ts.types["tf2_msgs/msg/TFMessage"](transforms=transforms)
        self.write(topic, "tf2_msgs/msg/TFMessage", t_ns, msg)

    def odometry(self, topic: str, t_ns: int, parent: str, child: str, pose) -> None:
        t = self.ts.types
        q = _quat(0, 0, pose[2])
        msg = t["nav_msgs/msg/Odometry"](
            header=self._header(t_ns, parent),
            child_frame_id=child,
            pose=t["geometry_msgs/msg/PoseWithCovariance"](
                pose=t["geometry_msgs/msg/Pose"](
                    position=t["geometry_msgs/msg/Point"](x=pose[0], y=pose[1], z=0.0),
                    orientation=t["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
                ),
                covariance=np.zeros(36),
            ),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](
                twist=t["geometry_msgs/msg/Twist"](
                    linear=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                    angular=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                ),
                covariance=np.zeros(36),
            ),
        )
        self.write(topic, "nav_msgs/msg/Odometry", t_ns, msg)

    def close(self) -> None:
        self.writer.close()


SCAN_TIMES = [0.05 + 0.29 * k for k in range(10)]  # seconds after T0, inside the tf data


def _write_robot_bag(
    path: Path,
    ros: int,
    *,
    laser_rpy=(0.0, 0.0, BASE_LASER[2]),
    with_tf: bool = True,
    with_odom: bool = False,
    early_scan: bool = False,
    second_scan_topic: bool = False,
    glitch: range | set | None = None,
    bad_scans: dict | None = None,
) -> None:
    """A recording of SCAN_TIMES scans with 10 Hz odometry (tf and/or /odom); with
    ``glitch``, those odometry samples' positions are NaN (a localisation glitch); with
    ``bad_scans`` ({scan index: (ranges, LaserScan fields)}), those scans' messages."""
    w = _BagWriter(path, ros)
    if with_tf:
        w.tf(
            "/tf_static",
            T0_NS,
            [
                w.transform(
                    "base_link",
                    "laser",
                    T0_NS,
                    BASE_LASER[0],
                    BASE_LASER[1],
                    0.3,
                    _quat(*laser_rpy),
                )
            ],
        )
    events = []
    for k in range(31):  # 10 Hz odom -> base_link, 0 ... 3 s
        t = 0.1 * k
        events.append((t, "odom", k))
    for k in range(4):  # 1 Hz map -> odom (constant)
        events.append((float(k), "map", k))
    for k, t in enumerate(SCAN_TIMES):
        events.append((t, "scan", k))
    if early_scan:
        events.append((-0.5, "scan", 99))
    for t, kind, k in sorted(events):
        t_ns = T0_NS + int(round(t * 1e9))
        if kind == "odom":
            x, y, yaw = _odom_base(t)
            x = math.nan if glitch is not None and k in glitch else x
            if with_tf:
                w.tf(
                    "/tf",
                    t_ns,
                    [w.transform("odom", "base_link", t_ns, x, y, 0.0, _quat(0, 0, yaw))],
                )
            if with_odom:
                w.odometry("/odom", t_ns, "odom", "base_link", (x, y, yaw))
        elif kind == "map" and with_tf:
            mx, my, myaw = MAP_ODOM
            w.tf("/tf", t_ns, [w.transform("map", "odom", t_ns, mx, my, 0.0, _quat(0, 0, myaw))])
        elif kind == "scan":
            ranges, fields = (bad_scans or {}).get(k, (_scan_ranges(k), {}))
            w.scan("/scan", t_ns, "laser", ranges, **fields)
            if second_scan_topic:
                w.scan("/scan2", t_ns, "laser", _scan_ranges(k))
    w.close()


def _expected_world_points(t: float, ranges: np.ndarray, parent: str, laser_rpy) -> np.ndarray:
    """End points from full 3-D homogeneous transforms (scipy rotations), then x, y."""
    x, y, yaw = _odom_base(t)
    m = _matrix(x, y, 0.0, _quat(0, 0, yaw))
    if parent == "map":
        m = _matrix(MAP_ODOM[0], MAP_ODOM[1], 0.0, _quat(0, 0, MAP_ODOM[2])) @ m
    m = m @ _matrix(BASE_LASER[0], BASE_LASER[1], 0.3, _quat(*laser_rpy))
    r = ranges.astype(np.float64)
    a = float(np.float32(-1.2)) + float(np.float32(0.06)) * np.arange(N_BEAMS)
    ok = np.isfinite(r) & (r >= np.float32(0.1)) & (r < np.float32(8.0))
    pts = np.stack([r * np.cos(a), r * np.sin(a), np.zeros_like(r), np.ones_like(r)])[:, ok]
    return (m @ pts)[:2].T


@pytest.mark.parametrize("ros", [1, 2])
@pytest.mark.parametrize("parent", ["map", "odom"])
def test_bag_round_trip_with_tf(tmp_path, ros, parent):
    pytest.importorskip("rosbags")
    path = tmp_path / ("robot.bag" if ros == 1 else "robot_bag")
    _write_robot_bag(path, ros)
    scans = list(read_bag(path, tf_parent=parent))
    assert len(scans) == len(SCAN_TIMES)
    for k, (t, s) in enumerate(zip(SCAN_TIMES, scans, strict=True)):
        assert s.timestamp == pytest.approx((T0_NS + round(t * 1e9)) / 1e9, abs=1e-6)
        assert s.ranges.dtype == np.float32 and s.n_beams == N_BEAMS
        np.testing.assert_array_equal(s.ranges, _scan_ranges(k))
        # Robot pose = parent -> base_link; sensor offset = base_link -> laser.
        ref = _se2(*_odom_base(t))
        if parent == "map":
            ref = _se2(*MAP_ODOM) @ ref
        got = _se2(*s.pose)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
        np.testing.assert_allclose(s.sensor_offset, BASE_LASER, rtol=0, atol=1e-9)
        np.testing.assert_allclose(
            s.endpoints_world(),
            _expected_world_points(t, s.ranges, parent, (0.0, 0.0, BASE_LASER[2])),
            rtol=0,
            atol=1e-6,
        )
    # Default tf_parent is "map" when the tree has it.
    if parent == "map":
        default = list(read_bag(path))
        assert [s.pose for s in default] == [s.pose for s in scans]
        # Without a base frame split, the whole chain becomes the pose.
        whole = list(read_bag(path, base_frame="laser"))
        for s, w in zip(scans, whole, strict=True):
            np.testing.assert_allclose(
                _se2(*w.pose), _se2(*s.pose) @ _se2(*s.sensor_offset), atol=1e-9
            )
            assert w.sensor_offset == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("source", ["tf", "odom"])
def test_bag_poses_that_are_not_finite_are_skipped(tmp_path, source):
    """A NaN pose in the odometry (a localisation glitch) refused the whole recording;
    it is left out with a warning, and the scans are posed from the samples around it."""
    pytest.importorskip("rosbags")
    kw = {"with_tf": True, "with_odom": source == "odom"}  # odom: the glitch in /tf and /odom
    read = {"pose_topic": "/odom"} if source == "odom" else {"tf_parent": "odom"}
    _write_robot_bag(tmp_path / "good", 2, **kw)
    _write_robot_bag(tmp_path / "glitch", 2, glitch={9}, **kw)  # at 0.9 s, between two scans
    with pytest.warns(
        UserWarning,
        match=rf"skipped {1 + (source == 'odom')} pose\(s\) or transform\(s\) that are not ",
    ):
        scans = list(read_bag(tmp_path / "glitch", **read))
    good = list(read_bag(tmp_path / "good", **read))
    assert len(scans) == len(good) == len(SCAN_TIMES)
    for a, b in zip(scans, good, strict=True):
        np.testing.assert_allclose(a.pose, b.pose, atol=1e-9)  # linear: exact either way


@pytest.mark.parametrize("ros", [1, 2])
def test_bag_scans_whose_fields_make_no_scan_are_skipped(tmp_path, ros):
    """One LaserScan message with an impossible geometry (a driver's glitch, or its
    all-zero message at start-up) refused the whole recording, part way through, and
    a replay could not get past it; it is skipped with a warning naming the first."""
    pytest.importorskip("rosbags")
    zeros = dict(angle_min=0.0, angle_max=0.0, angle_increment=0.0, range_min=0.0, range_max=0.0)
    bad = {
        0: (np.zeros(0, np.float32), zeros),
        4: (_scan_ranges(4), {"angle_increment": 0.0}),
        6: (_scan_ranges(6), {"range_max": math.nan}),
        7: (_scan_ranges(7), {"range_max": 0.05}),  # below range_min
    }
    suffix = ".bag" if ros == 1 else ""
    _write_robot_bag(tmp_path / f"good{suffix}", ros)
    _write_robot_bag(tmp_path / f"glitch{suffix}", ros, bad_scans=bad)
    with pytest.warns(UserWarning) as caught:
        scans = list(read_bag(tmp_path / f"glitch{suffix}"))
    (message,) = [str(w.message) for w in caught]
    stamp = (T0_NS + round(SCAN_TIMES[0] * 1e9)) / 1e9
    assert re.search(
        rf"skipped 4 sensor_msgs/msg/LaserScan message\(s\) on /scan whose fields make no "
        rf"scan \(a sensor glitch\), the first at t={stamp:.9f} s: angle_increment: "
        "expected a non-zero angle",
        message,
    ), message
    good = [s for k, s in enumerate(read_bag(tmp_path / f"good{suffix}")) if k not in bad]
    assert len(scans) == len(good) == len(SCAN_TIMES) - len(bad)
    for a, b in zip(scans, good, strict=True):
        assert (a.pose, a.timestamp) == (b.pose, b.timestamp)
        np.testing.assert_array_equal(a.ranges, b.ranges)


def test_a_bag_none_of_whose_laser_scans_makes_a_scan_is_refused(tmp_path):
    pytest.importorskip("rosbags")
    bad = {k: (_scan_ranges(k), {"angle_increment": 0.0}) for k in range(len(SCAN_TIMES))}
    _write_robot_bag(tmp_path / "glitch", 2, bad_scans=bad)
    with pytest.raises(
        ValueError, match=r"no scan to read: \d+ sensor_msgs/msg/LaserScan message\(s\) on "
    ):
        list(read_bag(tmp_path / "glitch"))


def test_bag_pose_topic_takes_base_frame_as_the_posed_frame(tmp_path):
    """With a pose topic, ``base_frame`` names the frame its poses are of (the sensor
    offset is the tf from there to the scan's frame)."""
    pytest.importorskip("rosbags")
    _write_robot_bag(tmp_path / "bag", 2, with_odom=True)
    plain = list(read_bag(tmp_path / "bag", pose_topic="/odom"))
    of_laser = list(read_bag(tmp_path / "bag", pose_topic="/odom", base_frame="laser"))
    np.testing.assert_allclose(plain[0].sensor_offset, BASE_LASER, atol=1e-9)
    assert [s.sensor_offset for s in of_laser] == [(0.0, 0.0, 0.0)] * len(SCAN_TIMES)
    assert [s.pose for s in of_laser] == [s.pose for s in plain]


def test_bag_pose_topic_odometry(tmp_path):
    pytest.importorskip("rosbags")
    path = tmp_path / "odom_bag"
    _write_robot_bag(path, 2, with_odom=True)
    scans = list(read_bag(path, pose_topic="/odom"))
    assert len(scans) == len(SCAN_TIMES)
    for t, s in zip(SCAN_TIMES, scans, strict=True):
        np.testing.assert_allclose(_se2(*s.pose), _se2(*_odom_base(t)), atol=1e-9)
        np.testing.assert_allclose(s.sensor_offset, BASE_LASER, atol=1e-9)
        np.testing.assert_allclose(
            s.endpoints_world(),
            _expected_world_points(t, s.ranges, "odom", (0.0, 0.0, BASE_LASER[2])),
            atol=1e-6,
        )
    # Odometry only (no tf at all): chosen automatically; the laser mounting must be given.
    path2 = tmp_path / "odom_only"
    _write_robot_bag(path2, 2, with_tf=False, with_odom=True)
    with pytest.raises(ValueError, match="sensor_offset"):
        list(read_bag(path2))
    scans2 = list(read_bag(path2, sensor_offset=BASE_LASER))
    for a, b in zip(scans, scans2, strict=True):
        np.testing.assert_allclose(a.endpoints_world(), b.endpoints_world(), atol=1e-9)


@pytest.mark.parametrize("rpy", [(math.pi, 0.0, 0.3), (0.0, math.pi, -0.4)])
def test_bag_upside_down_laser_mirrors_scan(tmp_path, rpy):
    pytest.importorskip("rosbags")
    path = tmp_path / "flipped_bag"
    _write_robot_bag(path, 2, laser_rpy=rpy)
    scans = list(read_bag(path))
    for t, s in zip(SCAN_TIMES, scans, strict=True):
        assert s.angle_increment < 0
        np.testing.assert_allclose(
            s.endpoints_world(), _expected_world_points(t, s.ranges, "map", rpy), atol=1e-6
        )


def test_bag_missing_pose_skip_or_error(tmp_path):
    pytest.importorskip("rosbags")
    path = tmp_path / "early.bag"
    _write_robot_bag(path, 1, early_scan=True)
    with pytest.warns(UserWarning, match="skipped 1 scan"):
        scans = list(read_bag(path))
    assert len(scans) == len(SCAN_TIMES)
    with pytest.raises(ValueError, match="no pose"):
        list(read_bag(path, missing_pose="error"))
    # A large tolerance holds the first tf sample for the early scan.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(list(read_bag(path, pose_tolerance_s=1.0))) == len(SCAN_TIMES) + 1


def test_a_bag_none_of_whose_scans_has_a_pose_is_refused(tmp_path):
    # the odometry lost after its first sample: every scan skipped is no empty recording
    pytest.importorskip("rosbags")
    path = tmp_path / "lost.bag"
    _write_robot_bag(path, 1, glitch=range(1, 31))  # odometry at 0 s only
    with pytest.warns(UserWarning, match=r"skipped 30 pose\(s\) or transform\(s\)"):
        with pytest.raises(
            ValueError,
            match=rf"no scan to read: {len(SCAN_TIMES)} sensor_msgs/msg/LaserScan message\(s\) "
            r"on /scan skipped for no pose within pose_tolerance_s of the pose data, the first "
            r"at t=.*; expected at least one scan within pose_tolerance_s of the pose data$",
        ):
            list(read_bag(path, pose_tolerance_s=0.01))


def test_a_pose_topic_whose_every_pose_is_not_finite_is_refused_as_such(tmp_path):
    # it has messages, none of them usable
    pytest.importorskip("rosbags")
    path = tmp_path / "lost.bag"
    _write_robot_bag(path, 1, with_tf=False, with_odom=True, glitch=range(31))
    with pytest.raises(
        ValueError,
        match=r"^pose_topic: '/odom' in .*lost.bag has no pose that is finite and a rotation "
        r"\(the first left out: /odom at t=",
    ):
        list(read_bag(path, pose_topic="/odom"))


def test_bag_topics_named_without_the_root_slash_are_the_root_s(tmp_path):
    # "scan" and "odom" resolve to /scan and /odom, as ROS resolves a relative name in
    # the root namespace; the same scans and poses as with the full names
    pytest.importorskip("rosbags")
    path = tmp_path / "odom_bag"
    _write_robot_bag(path, 2, with_odom=True)
    full = list(read_bag(path, scan_topic="/scan", pose_topic="/odom"))
    short = list(read_bag(path, scan_topic="scan", pose_topic="odom"))
    assert len(short) == len(full) == len(SCAN_TIMES)
    for a, b in zip(full, short, strict=True):
        assert a.pose == b.pose and np.array_equal(a.ranges, b.ranges, equal_nan=True)
    with pytest.raises(ValueError, match=r"scan_topic: 'odom' is not a .*LaserScan"):
        read_bag(path, scan_topic="odom")


def test_bag_topic_and_frame_errors(tmp_path):
    pytest.importorskip("rosbags")
    path = tmp_path / "two_scans"
    _write_robot_bag(path, 2, second_scan_topic=True)
    with pytest.raises(ValueError, match=r"scan_topic.*/scan2"):
        read_bag(path)
    assert len(list(read_bag(path, scan_topic="/scan2"))) == len(SCAN_TIMES)
    with pytest.raises(ValueError, match="scan_topic"):
        read_bag(path, scan_topic="/tf")
    with pytest.raises(ValueError, match="pose_topic"):
        read_bag(path, scan_topic="/scan", pose_topic="/scan2")
    with pytest.raises(ValueError, match="tf_parent"):
        list(read_bag(path, scan_topic="/scan", tf_parent="world"))
    with pytest.raises(ValueError, match="base_frame"):
        list(read_bag(path, scan_topic="/scan", base_frame="nowhere"))
    with pytest.raises(FileNotFoundError):
        read_bag(tmp_path / "missing.bag")
    with pytest.raises(ValueError, match="missing_pose"):
        read_bag(path, missing_pose="ignore")
    # a list is refused, not failing as an unhashable dict key, and so is a frame that is
    # no name
    for name in ("scan_topic", "pose_topic", "tf_parent", "base_frame"):
        for bad in (["/scan"], True, np.array("/scan")):
            with pytest.raises(TypeError, match=rf"^{name}: expected a str or None, received "):
                read_bag(path, **{name: bad})


def test_replay_takes_the_bag_options_the_reader_errors_advise(tmp_path, capsys):
    """A bag of odometry and scans without the laser's mounting in tf (a common
    recording) needs a sensor offset, and one whose tf does not reach the default map
    frame a tf parent: topojax replay has the options, and the errors name them."""
    pytest.importorskip("rosbags")
    from topojax.cli import main

    bag = tmp_path / "odom.bag"
    _write_robot_bag(bag, 1, with_tf=False, with_odom=True)
    base = ["replay", str(bag), "--max-scans", "2", "--no-progress"]
    assert main([*base, "-o", str(tmp_path / "a")]) != 0
    said = capsys.readouterr().err
    assert "pass --sensor-offset X Y YAW" in said and "sensor_offset" not in said
    offset = [str(v) for v in BASE_LASER]
    assert main([*base, "-o", str(tmp_path / "b"), "--sensor-offset", *offset]) == 0
    tf_bag = tmp_path / "tf.bag"
    _write_robot_bag(tf_bag, 1)
    base = ["replay", str(tf_bag), "--max-scans", "2", "--no-progress"]
    assert main([*base, "-o", str(tmp_path / "c"), "--tf-parent", "world"]) != 0
    err = capsys.readouterr().err
    assert "no tf chain from 'world'" in err and "--tf-parent odom or map" in err
    assert "tf_parent" not in err and "pose_topic" not in err
    more = ["--tf-parent", "odom", "--base-frame", "base_link"]
    assert main([*base, "-o", str(tmp_path / "d"), *more]) == 0


def test_a_bag_folder_of_one_sqlite_file_without_metadata_reads_it(tmp_path):
    """ROS 2 writes a bag folder's metadata.yaml when the recording ends, so one stopped
    by a power cut holds only its .db3 file: the folder reads as that file, as one
    holding only its .mcap file does, with a warning naming the file read (SQLite keeps
    every message written, so nothing else tells that the recording was cut off)."""
    pytest.importorskip("rosbags")
    whole = tmp_path / "whole"
    _write_robot_bag(whole, 2)
    (whole / "metadata.yaml").unlink()
    (db3,) = whole.glob("*.db3")
    with pytest.warns(RuntimeWarning) as caught:
        scans = list(read_bag(whole))
    assert len(scans) == len(SCAN_TIMES)
    assert [str(x.message) for x in caught] == [
        f"{whole}: the bag folder has no metadata.yaml (written when a recording ends: "
        f"one cut off, say); read its one .db3 file, {db3.name}"
    ]
    (whole / "copy.db3").write_bytes(next(whole.glob("*.db3")).read_bytes())
    with pytest.raises(ValueError, match=r"not a ROS 2 bag: .*found 2 \.db3 files; pass"):
        list(read_bag(whole))


def test_bag_without_poses(tmp_path):
    pytest.importorskip("rosbags")
    path = tmp_path / "scans_only.bag"
    _write_robot_bag(path, 1, with_tf=False)
    with pytest.raises(ValueError, match="allow_missing_pose=True") as info:
        read_bag(path)
    assert "--" not in str(info.value)  # the API's keywords, no command's options
    with pytest.raises(TypeError, match="^allow_missing_pose: expected a bool, received str"):
        read_bag(path, allow_missing_pose="no")  # a non-empty str is not taken as True
    scans = list(read_bag(path, allow_missing_pose=True))
    assert len(scans) == len(SCAN_TIMES)
    assert all(s.pose == (0.0, 0.0, 0.0) and s.sensor_offset == (0.0, 0.0, 0.0) for s in scans)


def _break_index_lengths(path: Path) -> int:
    """Rewrite every INDEX_DATA record's data length as count * 20, as the 2010 rosbag did."""
    data = bytearray(path.read_bytes())
    pos = 13
    patched = 0
    while pos < len(data):
        (hlen,) = struct.unpack_from("<I", data, pos)
        hdr = bytes(data[pos + 4 : pos + 4 + hlen])
        fields = {}
        i = 0
        while i < len(hdr):
            (n,) = struct.unpack_from("<I", hdr, i)
            k, v = hdr[i + 4 : i + 4 + n].split(b"=", 1)
            fields[k] = v
            i += 4 + n
        (dlen,) = struct.unpack_from("<I", data, pos + 4 + hlen)
        if fields[b"op"] == b"\x04":
            (count,) = struct.unpack("<I", fields[b"count"])
            assert dlen == 12 * count
            struct.pack_into("<I", data, pos + 4 + hlen, 20 * count)
            patched += 1
        pos += 8 + hlen + dlen
    path.write_bytes(bytes(data))
    return patched


def test_ros1_fallback_reader_matches_rosbags(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.highlevel import AnyReader

    path = tmp_path / "robot.bag"
    _write_robot_bag(path, 1)
    good = list(read_bag(path))
    assert _break_index_lengths(path) > 0
    with pytest.raises(Exception):  # noqa: B017 - rosbags refuses the file (assertion)
        with AnyReader([path]) as reader:
            list(reader.messages())
    fallback = list(read_bag(path))
    assert len(fallback) == len(good)
    for a, b in zip(good, fallback, strict=True):
        np.testing.assert_array_equal(a.ranges, b.ranges)
        assert a.pose == pytest.approx(b.pose, abs=1e-12)
        assert a.sensor_offset == pytest.approx(b.sensor_offset, abs=1e-12)
        assert a.timestamp == b.timestamp


def _check_ccny(scans: list[Scan], count: int) -> None:
    assert len(scans) == count
    for s in scans:
        assert s.n_beams == 681
        assert s.angle_min == pytest.approx(-2.0862, abs=1e-4)
        assert s.angle_increment == pytest.approx(0.0061359, abs=1e-7)
        assert s.range_min == pytest.approx(0.02, abs=1e-6)
        assert s.range_max == pytest.approx(5.6, abs=1e-6)
        assert s.pose == (0.0, 0.0, 0.0)
        assert s.ranges.dtype == np.float32
    stamps = [s.timestamp for s in scans]
    assert stamps == sorted(stamps)


def test_ccny_excerpt_bag():
    pytest.importorskip("rosbags")
    with pytest.raises(ValueError, match="allow_missing_pose"):
        read_bag(CCNY_EXCERPT)
    scans = list(read_bag(CCNY_EXCERPT, allow_missing_pose=True))
    _check_ccny(scans, 25)
    assert scans[0].timestamp == pytest.approx(1282836370.9708765, abs=1e-6)


def test_a_ros1_bag_cut_off_reads_its_scans_up_to_the_cut(tmp_path):
    """A recording that stopped while writing (no index, its last chunk cut short) reads
    the scans before the cut with a warning, as a cut-off log does, rather than failing
    with the deserializer's 'Invalid sequence length', which names no file."""
    pytest.importorskip("rosbags")
    whole = list(read_bag(CCNY_EXCERPT, allow_missing_pose=True))
    cut = tmp_path / "cut.bag"
    cut.write_bytes(CCNY_EXCERPT.read_bytes()[:60000])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scans = list(read_bag(cut, allow_missing_pose=True))
    assert 0 < len(scans) < len(whole)
    # one warning, for a bag read in several passes, counting the messages read
    said = [str(x.message) for x in caught if "cut" in str(x.message)]
    assert len(said) == 1 and said[0].startswith(f"{cut}: the bag ends in the middle of")
    n = len(scans)  # the excerpt's messages before the cut are all scans
    assert said[0].endswith(f"(a recording cut off); read up to the cut: {n} messages (/scan {n})")
    for a, b in zip(scans, whole, strict=False):
        assert np.array_equal(a.ranges, b.ranges) and a.timestamp == b.timestamp


def test_a_cut_ros1_bag_counts_what_it_read_per_topic(tmp_path):
    """The warning of a cut-off bag counts the messages read per topic, so that scans
    are not confused with the tf and odometry messages beside them."""
    pytest.importorskip("rosbags")
    whole = tmp_path / "whole.bag"
    _write_robot_bag(whole, 1, with_odom=True)
    cut = tmp_path / "cut.bag"
    data = whole.read_bytes()
    cut.write_bytes(data[: len(data) * 2 // 3])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scans = list(read_bag(cut))
    (said,) = [str(x.message) for x in caught if "cut off" in str(x.message)]
    counts = dict(re.findall(r"(/\w+) (\d+)", said.rpartition("(")[2]))
    assert {"/odom", "/scan", "/tf", "/tf_static"} <= set(counts)
    assert 0 < len(scans) <= int(counts["/scan"]) < len(SCAN_TIMES)
    total = int(re.search(r"read up to the cut: (\d+) messages", said)[1])
    assert total == sum(int(n) for n in counts.values()) > int(counts["/scan"])


def test_ccny_shared_bag(shared_data):
    pytest.importorskip("rosbags")
    path = shared_data / "logs" / "rosbag" / "ccny_laser_scan_matcher_demo.bag"
    with pytest.raises(ValueError, match="no pose source") as info:
        read_bag(path)
    assert "/scan" in str(info.value) and "allow_missing_pose" in str(info.value)
    scans = list(read_bag(path, allow_missing_pose=True))
    _check_ccny(scans, 360)
    assert scans[-1].timestamp - scans[0].timestamp == pytest.approx(35.8, abs=0.1)
    excerpt = list(read_bag(CCNY_EXCERPT, allow_missing_pose=True))
    for a, b in zip(excerpt, scans[:25], strict=True):
        np.testing.assert_array_equal(a.ranges, b.ranges)
        assert a.timestamp == b.timestamp


# ------------------------------------------------------------------------------------------
# Dispatch
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".bag", ".db3"])
def test_a_bag_file_that_is_no_bag_is_refused_by_its_start(tmp_path, suffix):
    """A file named as a bag whose bytes are not one (a download that failed, a file of
    another kind renamed) is refused saying what its start should be, not with the
    repr of the decoder's error, which prints the file's garbage."""
    pytest.importorskip("rosbags")
    path = tmp_path / f"data{suffix}"
    path.write_bytes(np.random.default_rng(5).bytes(20000))
    with pytest.raises(ValueError) as info:
        list(read_scans(path))
    text = str(info.value)
    want = "#ROSBAG V2.0" if suffix == ".bag" else "SQLite format 3"
    assert text.startswith(f"path: {path} is not a ") and f"does not begin with b'{want}" in text
    assert len(text) < 300


def test_read_scans_dispatch(tmp_path):
    a = list(read_scans(INTEL_EXCERPT))
    assert len(a) == 40 and a[0].n_beams == 180
    b = list(read_scans(OCTAVE_EXCERPT))
    assert len(b) == 20 and b[0].n_beams == 361
    pytest.importorskip("rosbags")
    c = list(read_scans(CCNY_EXCERPT, allow_missing_pose=True))
    assert len(c) == 25
    # A ROS 2 bag: its folder or the storage file inside it.
    _write_robot_bag(tmp_path / "ros2", 2)
    db3 = next((tmp_path / "ros2").glob("*.db3"))
    for target in (tmp_path / "ros2", db3):
        assert len(list(read_scans(target))) == len(SCAN_TIMES)
    # A ROS 1 bag without the .bag suffix is recognised by its magic bytes.
    renamed = tmp_path / "ccny.dat"
    renamed.write_bytes(CCNY_EXCERPT.read_bytes())
    assert len(list(read_scans(renamed, allow_missing_pose=True))) == 25
    with pytest.raises(FileNotFoundError):
        read_scans(tmp_path / "missing.log")


@pytest.mark.parametrize("name", ["map.png", "map.pgm", "photo.jpg"])
def test_read_scans_refuses_a_map_image_by_name(tmp_path, name, capsys):
    """A map image handed to the scan readers is named as one, not read as a CARMEN log
    without laser lines; ``replay`` names it as its ``source``.  What reads maps is
    said in the caller's words: load_map to the API, the commands to topojax replay."""
    import cv2

    import topojax as tj
    from topojax.cli import main

    path = tmp_path / name
    cv2.imwrite(str(path), np.full((4, 4), 254, np.uint8))
    with pytest.raises(ValueError, match=r"^path: expected a laser log .* received the map image"):
        read_scans(path)
    with pytest.raises(ValueError, match=r"^source: expected a laser log") as info:
        tj.replay(path, out_dir=tmp_path / "out", progress=False)
    assert str(info.value).endswith("(load_map reads maps)")
    assert main(["replay", str(path), "-o", str(tmp_path / "cli"), "--no-progress"]) == 2
    said = capsys.readouterr().err
    assert said.rstrip().endswith("(topojax graph, rooms and route-graph read maps)")
    assert "load_map" not in said


@pytest.mark.parametrize(
    ("content", "opens"),
    [
        # raw Hokuyo scans and wheel ticks, one record a line (BreezySLAM's exp1.dat)
        (b"212387282 14710 29221 25178 0 0 0 170.1 9941 12750\n", "opens with '212387282'"),
        (b"\x7fELF\x02\x01\x01\x00 binary\n", "is binary data"),
    ],
)
def test_a_file_of_no_format_read_is_refused_as_such_with_the_formats_read(
    tmp_path, content, opens
):
    """A file that is no format topojax reads is refused as such, with the formats read
    and their suffixes, not as a CARMEN log with no laser lines."""
    path = tmp_path / "exp1.dat"
    path.write_bytes(content)
    for read in (read_scans, read_carmen):
        with pytest.raises(ValueError) as info:
            list(read(path))
        text = str(info.value)
        assert text.startswith(f"{path}: not a laser log or bag that topojax reads: ")
        assert f"its first line {opens}, where a CARMEN line opens with a message name" in text
        for name in ("CARMEN logs (.log, .clf", "Octave", "ROS 1 bags (.bag)", "(.mcap)"):
            assert name in text
        assert "no laser lines" not in text
    # a CARMEN log without laser lines keeps its own message
    for text in ("PARAM robot_front_laser_max 50.0 h 0\n", "# nothing\n", "\n"):
        path.write_text(text)
        with pytest.raises(ValueError, match="no scan to read: no laser lines found"):
            list(read_scans(path))


def test_options_another_reader_takes_are_refused_with_what_the_reader_takes():
    from topojax.scans import ReaderOptionError

    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    with pytest.raises(ReaderOptionError) as refused:
        read_scans(log, tf_parent="odom", scan_topic="/scan")
    exc = refused.value
    assert isinstance(exc, ValueError) and exc.reader == "read_carmen"
    assert exc.unknown == ("scan_topic", "tf_parent") and "max_range_m" in exc.accepted
    assert str(exc).startswith(
        f"{log} is read by read_carmen, which takes no scan_topic, tf_parent"
    )
    assert pickle.loads(pickle.dumps(exc)).unknown == exc.unknown


def test_tf_samples_are_kept_compactly():
    """A bag's tf series keeps its samples in typed arrays: an hour of 100 Hz tf is about
    12 MB per transform, not the 70 MB of tuples in lists, and reads back the same."""
    import tracemalloc

    from topojax.scans._tf import _TfSeries

    n = 100_000
    tracemalloc.start()
    try:
        series = _TfSeries()
        for k in range(n):
            series.add(k * 10_000_000, (0.1 * k, -0.2 * k, 0.001 * k, 1), False)
        held = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert held < 40 * n  # bytes per sample
    assert series.at(15_000_000, 0) == pytest.approx((0.15, -0.3, 0.0015, 1))
    series.add(7, (1.0, 2.0, 3.0, -1), True)  # a static transform replaces the series
    assert len(series) == 1 and series.at(10**12, 0) == (1.0, 2.0, 3.0, -1)
