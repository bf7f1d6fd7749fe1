"""2-D laser scans with poses, and readers for CARMEN logs, Octave text files and ROS bags.

A :class:`Scan` is one planar laser scan together with the pose of the robot in the map frame
and the mounting pose of the sensor on the robot. The readers in this module are generators:
they yield one :class:`Scan` at a time and never hold a whole log's ranges in memory (except
:func:`read_octave_laser`, whose file format stores every scan's ranges in one block).

Conventions
-----------
* Poses are ``(x_m, y_m, yaw_rad)``; yaw is counter-clockwise from the map ``x`` axis.
* Beam ``i`` of a scan points at ``angle_min + i * angle_increment`` (radians) in the sensor
  frame, counter-clockwise from the sensor's ``x`` axis.
* A reading is a *hit* (see :meth:`Scan.valid_mask`) when it is finite, positive,
  ``>= range_min`` and strictly ``< range_max``. Readings at or beyond ``range_max`` are
  "no return" (max-range) readings; NaN, +-inf, zero and negative values are no-returns too.
"""

from __future__ import annotations

import bz2
import gzip
import inspect
import io
import math
import numbers
import struct
import warnings
import zlib
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, NamedTuple

import numpy as np

__all__ = [
    "Scan",
    "read_bag",
    "read_carmen",
    "read_octave_laser",
    "read_scans",
    "scans_from_arrays",
]

PoseLike = Sequence[float] | np.ndarray

_TWO_PI = 2.0 * math.pi


def _wrap_angle(a: float) -> float:
    """Wrap an angle in radians to ``[-pi, pi)``."""
    return (a + math.pi) % _TWO_PI - math.pi


def _real_scalar(name: str, value: Any, *, allow_inf: bool = False) -> float:
    """Return ``value`` as a Python float, rejecting booleans, non-numbers and NaN (a
    0-d NumPy array of a real number counts as that number)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a real number, got {type(value).__name__} {value!r}")
    out = float(value)
    if math.isnan(out) or (math.isinf(out) and not allow_inf):
        raise ValueError(f"{name}: expected a finite number, got {out!r}")
    return out


def _pose3(name: str, value: Any) -> tuple[float, float, float]:
    """Validate a planar pose ``(x_m, y_m, yaw_rad)`` and return it as a tuple of floats."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(
            f"{name}: expected 3 numbers (x_m, y_m, yaw_rad), got {value!r} ({err})"
        ) from None
    if arr.shape != (3,):
        raise ValueError(
            f"{name}: expected 3 numbers (x_m, y_m, yaw_rad), got shape {arr.shape}: {value!r}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected 3 finite numbers, got {tuple(arr.tolist())}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def _compose(
    a: tuple[float, float, float], b: tuple[float, float, float]
) -> tuple[float, float, float]:
    """Planar pose composition ``a ∘ b`` (``b`` expressed in the frame of ``a``)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (
        a[0] + c * b[0] - s * b[1],
        a[1] + s * b[0] + c * b[1],
        _wrap_angle(a[2] + b[2]),
    )


def _relative(
    a: tuple[float, float, float], b: tuple[float, float, float]
) -> tuple[float, float, float]:
    """Planar pose of ``b`` in the frame of ``a`` (``a⁻¹ ∘ b``)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, _wrap_angle(b[2] - a[2]))


# --------------------------------------------------------------------------------------------
# Scan
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False, repr=False)
class Scan:
    """One planar laser scan with the robot's pose in the map frame.

    Parameters
    ----------
    ranges : numpy.ndarray, shape (N,), float32 or float64
        Measured ranges in metres, beam order. Integer input is converted to float64.
        NaN / inf / non-positive values are allowed and are treated as "no return".
        The array is copied and made read-only.
    angle_min : float
        Angle of beam 0 in radians, counter-clockwise from the sensor's ``x`` axis.
    angle_increment : float
        Angle between consecutive beams in radians; finite and non-zero (negative for
        sensors that sweep clockwise).
    range_min, range_max : float
        Readings ``r`` with ``range_min <= r < range_max`` are hits, everything else is
        "no return". ``range_min >= 0``; ``range_max > range_min`` (``inf`` allowed).
    pose : tuple of 3 floats
        ``(x_m, y_m, yaw_rad)`` of the ROBOT in the map frame. Must be finite.
    sensor_offset : tuple of 3 floats, optional
        ``(x_m, y_m, yaw_rad)`` of the sensor in the robot frame; default ``(0, 0, 0)``.
    timestamp : float or None, optional
        Acquisition time in seconds (as stored in the source), or None.

    Raises
    ------
    TypeError, ValueError
        If a field has the wrong type, shape or value (the message names the field).
    """

    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    pose: tuple[float, float, float]
    sensor_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    timestamp: float | None = None

    def __post_init__(self) -> None:
        raw = self.ranges
        try:
            arr = np.asarray(raw)
        except (TypeError, ValueError) as err:
            raise TypeError(f"ranges: expected a 1-D numeric array, got {raw!r} ({err})") from None
        if arr.dtype.kind not in "iuf":
            raise TypeError(f"ranges: expected a real numeric array, got dtype {arr.dtype}")
        if arr.ndim != 1:
            raise ValueError(f"ranges: expected a 1-D array (N,), got shape {arr.shape}")
        dtype = arr.dtype if arr.dtype in (np.float32, np.float64) else np.float64
        arr = np.array(arr, dtype=dtype, copy=True)
        arr.flags.writeable = False
        object.__setattr__(self, "ranges", arr)

        object.__setattr__(self, "angle_min", _real_scalar("angle_min", self.angle_min))
        inc = _real_scalar("angle_increment", self.angle_increment)
        if inc == 0.0:
            raise ValueError("angle_increment: expected a non-zero angle in radians, got 0.0")
        object.__setattr__(self, "angle_increment", inc)
        rmin = _real_scalar("range_min", self.range_min)
        if rmin < 0.0:
            raise ValueError(f"range_min: expected a value >= 0 m, got {rmin!r}")
        rmax = _real_scalar("range_max", self.range_max, allow_inf=True)
        if not rmax > rmin:
            raise ValueError(
                f"range_max: expected a value > range_min ({rmin!r} m), got {rmax!r} m"
            )
        object.__setattr__(self, "range_min", rmin)
        object.__setattr__(self, "range_max", rmax)
        object.__setattr__(self, "pose", _pose3("pose", self.pose))
        object.__setattr__(self, "sensor_offset", _pose3("sensor_offset", self.sensor_offset))
        if self.timestamp is not None:
            object.__setattr__(self, "timestamp", _real_scalar("timestamp", self.timestamp))

    def __repr__(self) -> str:
        return (
            f"Scan(n_beams={self.n_beams}, ranges.dtype={self.ranges.dtype}, "
            f"angle_min={self.angle_min!r}, angle_increment={self.angle_increment!r}, "
            f"range_min={self.range_min!r}, range_max={self.range_max!r}, pose={self.pose!r}, "
            f"sensor_offset={self.sensor_offset!r}, timestamp={self.timestamp!r})"
        )

    @classmethod
    def from_arrays(
        cls,
        ranges: Any,
        pose: PoseLike,
        *,
        angle_min: float,
        angle_increment: float,
        range_min: float = 0.0,
        range_max: float = math.inf,
        sensor_offset: PoseLike = (0.0, 0.0, 0.0),
        timestamp: float | None = None,
    ) -> Scan:
        """Build a scan from array-likes, with keyword-only beam geometry.

        Parameters
        ----------
        ranges : array_like, shape (N,)
            Ranges in metres.
        pose : array_like, shape (3,)
            Robot pose ``(x_m, y_m, yaw_rad)`` in the map frame.
        angle_min, angle_increment : float
            Beam geometry in radians (see :class:`Scan`).
        range_min, range_max : float, optional
            Valid range interval ``[range_min, range_max)`` in metres; default ``[0, inf)``.
        sensor_offset : array_like, shape (3,), optional
            Sensor pose in the robot frame.
        timestamp : float, optional
            Time in seconds.

        Returns
        -------
        Scan
        """
        return cls(
            np.asarray(ranges),
            angle_min,
            angle_increment,
            range_min,
            range_max,
            _pose3("pose", pose),
            _pose3("sensor_offset", sensor_offset),
            timestamp,
        )

    @property
    def n_beams(self) -> int:
        """Number of beams ``N``."""
        return int(self.ranges.shape[0])

    @property
    def angle_max(self) -> float:
        """Angle of the last beam in radians (sensor frame); ``angle_min`` when ``N <= 1``."""
        return self.angle_min + max(self.n_beams - 1, 0) * self.angle_increment

    def angles(self) -> np.ndarray:
        """Beam angles in the sensor frame.

        Returns
        -------
        numpy.ndarray, shape (N,), float64
            ``angle_min + i * angle_increment`` in radians.
        """
        return self.angle_min + np.arange(self.n_beams, dtype=np.float64) * self.angle_increment

    def valid_mask(self) -> np.ndarray:
        """Which beams hit something.

        Returns
        -------
        numpy.ndarray, shape (N,), bool
            True where the range is finite, ``> 0``, ``>= range_min`` and ``< range_max``
            (strictly: a reading equal to ``range_max`` is a max-range "no return").
        """
        r = self.ranges.astype(np.float64)
        with np.errstate(invalid="ignore"):
            return np.isfinite(r) & (r > 0.0) & (r >= self.range_min) & (r < self.range_max)

    def sensor_pose_world(self) -> tuple[float, float, float]:
        """Pose of the sensor in the map frame, ``pose ∘ sensor_offset``.

        Returns
        -------
        tuple of 3 floats
            ``(x_m, y_m, yaw_rad)``, yaw wrapped to ``[-pi, pi)``.
        """
        return _compose(self.pose, self.sensor_offset)

    def endpoints_sensor(self) -> np.ndarray:
        """End points of the valid beams in the sensor frame.

        Returns
        -------
        numpy.ndarray, shape (M, 2), float64
            ``(x, y)`` in metres, sensor frame, for the ``M`` beams of :meth:`valid_mask`
            in beam order.
        """
        mask = self.valid_mask()
        r = self.ranges[mask].astype(np.float64)
        a = self.angles()[mask]
        return np.stack([r * np.cos(a), r * np.sin(a)], axis=1)

    def endpoints_world(self) -> np.ndarray:
        """End points of the valid beams in the map frame.

        Returns
        -------
        numpy.ndarray, shape (M, 2), float64
            World ``(x, y)`` in metres of the ``M`` beams of :meth:`valid_mask`, in beam
            order. The sensor pose is ``pose ∘ sensor_offset``.
        """
        sx, sy, syaw = self.sensor_pose_world()
        mask = self.valid_mask()
        r = self.ranges[mask].astype(np.float64)
        a = self.angles()[mask] + syaw
        return np.stack([sx + r * np.cos(a), sy + r * np.sin(a)], axis=1)


# --------------------------------------------------------------------------------------------
# Plain arrays
# --------------------------------------------------------------------------------------------


def scans_from_arrays(
    ranges: Any,
    poses: Any,
    *,
    angle_min: float,
    angle_increment: float,
    range_min: float = 0.0,
    range_max: float = math.inf,
    timestamps: Any = None,
    sensor_offset: PoseLike = (0.0, 0.0, 0.0),
) -> Iterator[Scan]:
    """Scans from a ranges matrix and a pose array.

    Parameters
    ----------
    ranges : array_like, shape (S, N)
        Ranges in metres, one row per scan.
    poses : array_like, shape (S, 3)
        Robot poses ``(x_m, y_m, yaw_rad)`` in the map frame, one row per scan.
    angle_min, angle_increment : float
        Beam geometry in radians, shared by all scans.
    range_min, range_max : float, optional
        Valid range interval ``[range_min, range_max)`` in metres.
    timestamps : array_like, shape (S,), optional
        Times in seconds.
    sensor_offset : array_like, shape (3,), optional
        Sensor pose in the robot frame, shared by all scans.

    Returns
    -------
    iterator of Scan
        The shapes are checked when this function is called; scans are built lazily.

    Raises
    ------
    ValueError
        If the shapes do not match.
    """
    r = np.asarray(ranges)
    p = np.asarray(poses, dtype=np.float64)
    if r.ndim != 2:
        raise ValueError(f"ranges: expected a 2-D array (S, N), got shape {r.shape}")
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"poses: expected an array of shape (S, 3), got shape {p.shape}")
    if p.shape[0] != r.shape[0]:
        raise ValueError(
            f"poses: expected {r.shape[0]} rows (one per row of ranges), got {p.shape[0]}"
        )
    t: np.ndarray | None = None
    if timestamps is not None:
        t = np.asarray(timestamps, dtype=np.float64)
        if t.shape != (r.shape[0],):
            raise ValueError(f"timestamps: expected shape ({r.shape[0]},), got shape {t.shape}")
    offset = _pose3("sensor_offset", sensor_offset)
    # Validate the shared geometry once, eagerly, on an empty scan.
    Scan(np.zeros(0), angle_min, angle_increment, range_min, range_max, (0, 0, 0), offset)

    def generate() -> Iterator[Scan]:
        for i in range(r.shape[0]):
            yield Scan(
                r[i],
                angle_min,
                angle_increment,
                range_min,
                range_max,
                (p[i, 0], p[i, 1], p[i, 2]),
                offset,
                None if t is None else float(t[i]),
            )

    return generate()


# --------------------------------------------------------------------------------------------
# CARMEN logs
# --------------------------------------------------------------------------------------------

_GZIP_MAGIC = b"\x1f\x8b"
_OLD_LASERS = ("FLASER", "RLASER")
_ROBOT_LASERS = ("ROBOTLASER1", "ROBOTLASER2")
_RAW_LASERS = ("RAWLASER1", "RAWLASER2", "RAWLASER3", "RAWLASER4")
_CARMEN_LASERS = _OLD_LASERS + _ROBOT_LASERS + _RAW_LASERS

#: Default width (m) of the band below a CARMEN file's largest reading that counts as
#: "no return". In the 13 corrected logs the no-return values form a cluster up to 0.15 m
#: wide (acapulco: 51.14-51.25; infinite-corridor: 51.06-51.16; freiburg-campus:
#: 81.83/81.91; seattle: 81.87/81.91) with at most a handful of readings between 0.2 m and
#: 1 m below it.
CARMEN_NO_RETURN_MARGIN_M = 0.2


def _check_file(path: str | Path, what: str) -> Path:
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{what}: file not found: {p}")
    if not p.is_file():
        raise ValueError(f"{what}: expected a file, got a directory or special file: {p}")
    return p


def _open_text(path: Path) -> IO[str]:
    """Open a text file that may be gzip-compressed (detected by its magic bytes).

    Damaged or truncated compressed data raises ValueError naming the file (gzip's own
    EOFError / zlib.error say neither which file nor that it is the file's fault)."""
    with open(path, "rb") as fh:
        magic = fh.read(2)
    if magic == _GZIP_MAGIC:
        raw = io.BufferedReader(_CheckedGzip(path))
        return io.TextIOWrapper(raw, encoding="latin-1", newline=None)
    return open(path, encoding="latin-1", newline=None)


class _CheckedGzip(io.RawIOBase):
    """A gzip file's decompressed bytes, with decompression faults as ValueError."""

    def __init__(self, path: Path) -> None:
        self._path = path
        self._file = gzip.open(path, "rb")

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        try:
            return self._file.readinto(buffer)
        except (EOFError, zlib.error, gzip.BadGzipFile) as exc:
            raise ValueError(
                f"{self._path}: the gzip-compressed data is damaged or cut off ({exc}); "
                "the file cannot be read to its end"
            ) from None

    def close(self) -> None:
        self._file.close()
        super().close()


def _cut_off(line: str) -> bool:
    """Is ``line`` the last, unfinished line of a file (no line end: a logger that
    stopped while writing it)?  Only such a line is skipped; a malformed line with a line
    end is an error."""
    return not line.endswith(("\n", "\r"))


def _carmen_beam_increment(n: int) -> float:
    """Beam spacing (rad) of an old-format CARMEN scan of ``n`` beams over a 180° fan."""
    return math.pi / (n - 1) if n % 2 else math.pi / n


class _CarmenLineError(ValueError):
    pass


def _floats(tokens: Sequence[str], what: str) -> np.ndarray:
    try:
        return np.array([float(v) for v in tokens], dtype=np.float64)
    except ValueError as err:
        raise _CarmenLineError(f"{what}: not a number ({err})") from None


def _count(token: str, what: str) -> int:
    try:
        n = int(token)
    except ValueError:
        raise _CarmenLineError(f"{what}: expected an integer, got {token!r}") from None
    if n < 0:
        raise _CarmenLineError(f"{what}: expected a count >= 0, got {n}")
    return n


def _need(tokens: Sequence[str], k: int, what: str) -> None:
    if len(tokens) < k:
        raise _CarmenLineError(f"expected at least {k} fields for {what}, got {len(tokens)}")


def _parse_old_laser(tokens: list[str]) -> tuple[np.ndarray, np.ndarray | None, float | None]:
    """Parse FLASER/RLASER: ``n r_1..r_n [x y theta odom_x odom_y odom_theta] ts host lts``.

    Returns ranges, the pose (x, y, theta) or None for pose-less lines, and the timestamp.
    """
    _need(tokens, 2, "the beam count")
    n = _count(tokens[1], "number of readings")
    if n < 2:
        raise _CarmenLineError(f"number of readings: expected >= 2, got {n}")
    _need(tokens, 2 + n, f"{n} ranges")
    ranges = _floats(tokens[2 : 2 + n], "range reading")
    rest = len(tokens) - 2 - n
    if rest >= 9:
        nums = _floats(tokens[2 + n : 9 + n], "pose / odometry / timestamp")
        if not np.all(np.isfinite(nums[:3])):
            raise _CarmenLineError(f"pose: expected finite x y theta, got {nums[:3].tolist()}")
        return ranges, nums[:3], float(nums[6])
    if rest == 3:  # very old raw format: n ranges ipc_timestamp hostname logger_timestamp
        return ranges, None, float(_floats(tokens[2 + n : 3 + n], "timestamp")[0])
    raise _CarmenLineError(
        f"expected {n} ranges followed by 9 fields (x y theta odom_x odom_y odom_theta "
        f"timestamp host logger_timestamp) or 3 fields (timestamp host logger_timestamp), "
        f"got {rest} fields after the ranges"
    )


def _parse_new_laser_head(tokens: list[str]) -> tuple[np.ndarray, np.ndarray, int]:
    """Parse the common head of ROBOTLASERk / RAWLASERk lines.

    ``laser_type start_angle field_of_view angular_resolution maximum_range accuracy
    remission_mode num_readings r_1..r_n num_remissions rem_1..rem_m``.
    Returns ``[start_angle, fov, angular_resolution, maximum_range]``, the ranges and the
    index of the first token after the remissions.
    """
    _need(tokens, 9, "the laser configuration")
    cfg = _floats(tokens[2:6], "laser configuration")
    n = _count(tokens[8], "num_readings")
    _need(tokens, 10 + n, f"{n} ranges and num_remissions")
    ranges = _floats(tokens[9 : 9 + n], "range reading")
    m = _count(tokens[9 + n], "num_remissions")
    return cfg, ranges, 10 + n + m


def _survey_carmen(
    path: Path, laser: str, need_max: bool
) -> tuple[str | None, float | None, dict[str, str], np.ndarray, int]:
    """First pass: the laser message to use, its largest finite range, the PARAM values,
    and (with ``need_max``) the readings within ``_TOP_BAND_M`` of the largest and how
    many finite readings there were (for :func:`_warn_if_no_sentinel`)."""
    chosen = None if laser == "auto" else laser
    best = -math.inf
    tops: list[np.ndarray] = []
    n_readings = 0
    params: dict[str, str] = {}
    with _open_text(path) as fh:
        for lineno, line in enumerate(fh, 1):
            tokens = line.split()
            if not tokens:
                continue
            key = tokens[0]
            if key == "PARAM" and len(tokens) >= 3:
                params[tokens[1]] = tokens[2]
                continue
            if key not in _CARMEN_LASERS:
                continue
            if chosen is None:
                chosen = key
            if key != chosen:
                continue
            if not need_max:
                # Keep reading PARAM lines only until the first scan of the chosen kind.
                break
            try:
                if key in _OLD_LASERS:
                    ranges = _parse_old_laser(tokens)[0]
                else:
                    ranges = _parse_new_laser_head(tokens)[1]
            except _CarmenLineError as err:
                if _cut_off(line):  # the logger stopped mid-line: the scans before count
                    break
                raise ValueError(f"{path}:{lineno}: malformed {key} line: {err}") from None
            finite = ranges[np.isfinite(ranges)]
            if finite.size:
                best = max(best, float(finite.max()))
                tops.append(finite[finite >= best - _TOP_BAND_M])
                n_readings += finite.size
    if best == -math.inf:
        return chosen, None, params, np.empty(0), 0
    top = np.concatenate(tops)
    return chosen, best, params, top[top >= best - _TOP_BAND_M], n_readings


# The survey keeps the readings this close to the running maximum (the no-return margin is
# 0.2 m by default; a larger margin is checked within this band only).
_TOP_BAND_M = 1.0


def _warn_if_no_sentinel(
    path: Path, laser: str, near: np.ndarray, total: int, best: float, margin: float
) -> None:
    """Warn when the range limit inferred from the largest reading drops most readings: a
    log with a no-return value drops its no-return beams (at most a quarter of the
    readings in the shared logs, the open campus), one without drops its longest real
    readings, all of them when the readings lie within the margin of each other."""
    dropped = int(np.count_nonzero(near >= best - margin))
    if total and dropped > total // 2:
        warnings.warn(
            f"{path}: the largest {laser} reading, {best} m, is taken as the no-return value, "
            f"so readings from {best - margin:.4g} m up are dropped: {dropped} of {total}; "
            "if the log has no no-return value, pass max_range (topojax replay --max-range)",
            stacklevel=3,
        )


def read_carmen(
    path: str | Path,
    *,
    max_range: float | None = None,
    laser: str = "auto",
    no_return_margin_m: float = CARMEN_NO_RETURN_MARGIN_M,
    sensor_offset: PoseLike | None = None,
) -> Iterator[Scan]:
    """Read laser scans from a CARMEN log (plain text or gzip, detected by magic bytes).

    Supported laser messages (one kind is read per call, see ``laser``):

    ``FLASER`` / ``RLASER`` (old format)
        ``n r_1 … r_n x y theta odom_x odom_y odom_theta ipc_timestamp host logger_ts``.
        ``x y theta`` is the pose the beams are cast from (CARMEN writes the *laser* pose
        there; in the GMapping "corrected" logs it is the corrected robot pose). It becomes
        :attr:`Scan.pose` with a zero ``sensor_offset``. Beam angles are not stored: the
        convention is a 180° fan centred on ``theta``, ``angle_min = -pi/2``, increment
        ``pi/n`` for even ``n`` (180, 360) and ``pi/(n-1)`` for odd ``n`` (181, 361), so
        odd fans include both ±90° beams. Very old pose-less lines
        (``n ranges ipc_timestamp host logger_ts``) take their pose from the last ODOM.
    ``ROBOTLASER1`` / ``ROBOTLASER2``
        ``laser_type start_angle fov angular_resolution maximum_range accuracy
        remission_mode n r_1..r_n m rem_1..rem_m laser_x laser_y laser_theta robot_x
        robot_y robot_theta tv rv forward_safety_dist side_safety_dist turn_axis
        ipc_timestamp host logger_ts``. ``pose`` is the robot pose; ``sensor_offset`` is the
        laser pose expressed in the robot frame.
    ``RAWLASER1`` … ``RAWLASER4``
        The same head as ROBOTLASER (no poses): ``… n ranges m remissions ipc_timestamp
        host logger_ts``. The robot pose is the ``x y theta`` of the latest ``ODOM`` line
        before the scan (scans before the first ODOM are skipped with a warning).

    Other lines (``ODOM``, ``PARAM``, ``NEFF``, ``TRUEPOS``, comments, other messages) are
    skipped.

    Parameters
    ----------
    path : str or Path
        The log file.
    max_range : float, optional
        Readings ``>= max_range`` (m) are "no return". By default: for FLASER/RLASER, a
        first pass over the file finds the largest reading ``R`` and
        ``range_max = R - no_return_margin_m`` (the no-return sentinel, 81.83 / 81.91 / 50.0 /
        51.x / 32.767 in the shared logs, is not stored in the message; ``PARAM
        robot_front_laser_max`` is not used because it does not match the data: csail says
        50 m while its sentinel is 81.91 m, edmonton says 10 m with real readings to 50 m).
        For ROBOTLASER/RAWLASER lines, the line's ``maximum_range`` field.
    laser : str, optional
        Which message to read: ``"auto"`` (default: the kind of the first laser line in
        the file) or one of ``FLASER``, ``RLASER``, ``ROBOTLASER1``, ``ROBOTLASER2``,
        ``RAWLASER1`` … ``RAWLASER4``.
    no_return_margin_m : float, optional
        Width of the no-return band below the file's largest reading (default 0.2 m; the
        no-return readings of one log are not all identical, see
        :data:`CARMEN_NO_RETURN_MARGIN_M`). Ignored when ``max_range`` is given.
    sensor_offset : array_like, shape (3,), optional
        Override of the sensor pose in the robot frame. Default: zero for FLASER/RLASER with a
        pose; computed from the line for ROBOTLASER; for scans posed from ODOM, the
        ``PARAM robot_frontlaser_offset`` / ``_side_offset`` / ``_angular_offset`` values for
        the front laser (RAWLASER1 and pose-less FLASER, 0 when absent); other lasers posed
        from ODOM need it (ValueError otherwise).

    Returns
    -------
    iterator of Scan
        Scans in line order; ``ranges`` are float64; ``range_min = 0``; ``timestamp`` is the
        line's ``ipc_timestamp`` (unreliable in several logs: use the order).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        For a malformed laser (or needed ODOM) line, with the file name and line number;
        for bad arguments; if the file has no scan of the requested kind.
    """
    p = _check_file(path, "path")
    if laser != "auto" and laser not in _CARMEN_LASERS:
        raise ValueError(
            f"laser: expected 'auto' or one of {', '.join(_CARMEN_LASERS)}, got {laser!r}"
        )
    if max_range is not None:
        max_range = _real_scalar("max_range", max_range, allow_inf=True)
        if max_range <= 0:
            raise ValueError(f"max_range: expected a value > 0 m, got {max_range!r}")
    margin = _real_scalar("no_return_margin_m", no_return_margin_m)
    if margin < 0:
        raise ValueError(f"no_return_margin_m: expected a value >= 0 m, got {margin!r}")
    offset_override = None if sensor_offset is None else _pose3("sensor_offset", sensor_offset)
    return _iter_carmen(p, max_range, laser, margin, offset_override)


def _iter_carmen(
    path: Path,
    max_range: float | None,
    laser: str,
    margin: float,
    offset_override: tuple[float, float, float] | None,
) -> Iterator[Scan]:
    need_max = max_range is None and laser in ("auto", *_OLD_LASERS)
    chosen, file_max, params, near_max, n_readings = _survey_carmen(path, laser, need_max)
    if chosen is None:
        raise ValueError(f"{path}: no laser lines found (looked for {', '.join(_CARMEN_LASERS)})")
    old = chosen in _OLD_LASERS
    range_max_old: float | None = max_range
    if old and range_max_old is None:
        if file_max is None:
            raise ValueError(f"{path}: no finite {chosen} range readings to find the max range")
        range_max_old = file_max - margin
        _warn_if_no_sentinel(path, chosen, near_max, n_readings, file_max, margin)
        if range_max_old <= 0:
            raise ValueError(
                f"{path}: largest {chosen} reading {file_max} m minus no_return_margin_m "
                f"{margin} m is not positive; pass max_range"
            )

    def odom_offset() -> tuple[float, float, float]:
        if offset_override is not None:
            return offset_override
        if chosen in ("FLASER", "RAWLASER1"):
            vals = []
            for name in ("offset", "side_offset", "angular_offset"):
                txt = params.get(f"robot_frontlaser_{name}", "0")
                try:
                    vals.append(float(txt))
                except ValueError:
                    raise ValueError(
                        f"{path}: PARAM robot_frontlaser_{name}: expected a number, got {txt!r}"
                    ) from None
            return _pose3("PARAM robot_frontlaser_*", vals)
        raise ValueError(
            f"{path}: {chosen} lines carry no pose and the log does not say where this laser "
            f"is mounted; pass sensor_offset=(x_m, y_m, yaw_rad)"
        )

    # The latest ODOM line, parsed only when a scan needs it: (line number, tokens).
    odom_line: tuple[int, list[str]] | None = None

    def odom_pose() -> tuple[float, float, float]:
        assert odom_line is not None
        num, toks = odom_line
        try:
            _need(toks, 4, "ODOM x y theta")
            xyz = _floats(toks[1:4], "ODOM pose")
            if not np.all(np.isfinite(xyz)):
                raise _CarmenLineError(f"ODOM pose is not finite: {xyz.tolist()}")
        except _CarmenLineError as err:
            raise ValueError(f"{path}:{num}: malformed ODOM line: {err}") from None
        return (float(xyz[0]), float(xyz[1]), float(xyz[2]))

    skipped = 0
    zero = (0.0, 0.0, 0.0)
    with _open_text(path) as fh:
        for lineno, line in enumerate(fh, 1):
            tokens = line.split()
            if not tokens:
                continue
            key = tokens[0]
            try:
                if key == "ODOM":
                    odom_line = (lineno, tokens)
                    continue
                if key != chosen:
                    continue
                if old:
                    ranges, pose, stamp = _parse_old_laser(tokens)
                    n = ranges.shape[0]
                    angle_min, inc = -math.pi / 2.0, _carmen_beam_increment(n)
                    rmax = range_max_old
                    if pose is None:
                        if odom_line is None:
                            skipped += 1
                            continue
                        robot, offset = odom_pose(), odom_offset()
                    else:
                        robot = (float(pose[0]), float(pose[1]), float(pose[2]))
                        offset = zero if offset_override is None else offset_override
                else:
                    cfg, ranges, k = _parse_new_laser_head(tokens)
                    angle_min, inc = float(cfg[0]), float(cfg[2])
                    rmax = float(cfg[3]) if max_range is None else max_range
                    if chosen in _ROBOT_LASERS:
                        _need(tokens, k + 12, "laser pose, robot pose, 5 fields and timestamp")
                        nums = _floats(tokens[k : k + 12], "poses / timestamp")
                        if not np.all(np.isfinite(nums[:6])):
                            raise _CarmenLineError(f"poses are not finite: {nums[:6].tolist()}")
                        laser_pose = (float(nums[0]), float(nums[1]), float(nums[2]))
                        robot = (float(nums[3]), float(nums[4]), float(nums[5]))
                        offset = (
                            _relative(robot, laser_pose)
                            if offset_override is None
                            else offset_override
                        )
                        stamp = float(nums[11])
                    else:
                        _need(tokens, k + 1, "the timestamp")
                        stamp = float(_floats(tokens[k : k + 1], "timestamp")[0])
                        if odom_line is None:
                            skipped += 1
                            continue
                        robot, offset = odom_pose(), odom_offset()
                try:
                    scan = Scan(ranges, angle_min, inc, 0.0, rmax, robot, offset, stamp)
                except (TypeError, ValueError) as err:
                    raise _CarmenLineError(str(err)) from None
            except _CarmenLineError as err:
                if _cut_off(line):
                    warnings.warn(
                        f"{path}:{lineno}: the log ends in the middle of a {key} line (no "
                        f"line end; {err}); that line is skipped",
                        stacklevel=2,
                    )
                    break
                raise ValueError(f"{path}:{lineno}: malformed {key} line: {err}") from None
            yield scan
    if skipped:
        warnings.warn(
            f"{path}: skipped {skipped} {chosen} scan(s) before the first ODOM line "
            f"(they have no pose)",
            stacklevel=2,
        )


# --------------------------------------------------------------------------------------------
# Octave text format (robot-mapping course data)
# --------------------------------------------------------------------------------------------


class _OctaveStruct:
    """A parsed Octave struct (array): field name -> value (a cell for struct arrays)."""

    def __init__(self, dims: tuple[int, ...], fields: dict[str, Any], scalar: bool) -> None:
        self.dims = dims
        self.fields = fields
        self.scalar = scalar


def _octave_number(text: str) -> float:
    t = text.strip()
    if t in ("NA", "-NA"):
        return math.nan
    return float(t)


class _OctaveReader:
    """Recursive-descent reader for Octave's ``save -text`` format."""

    def __init__(self, lines: list[str], path: Path) -> None:
        self.lines = lines
        self.path = path
        self.i = 0

    def error(self, msg: str) -> ValueError:
        return ValueError(f"{self.path}:{min(self.i + 1, len(self.lines))}: {msg}")

    def _skip_blank(self) -> None:
        while self.i < len(self.lines) and not self.lines[self.i].strip():
            self.i += 1

    def header(self, key: str) -> str:
        self._skip_blank()
        if self.i >= len(self.lines):
            raise self.error(f"unexpected end of file, expected '# {key}:'")
        line = self.lines[self.i].strip()
        prefix = f"# {key}:"
        if not line.startswith(prefix):
            raise self.error(f"expected '# {key}:' header, found {line[:60]!r}")
        self.i += 1
        return line[len(prefix) :].strip()

    def peek_header(self) -> str | None:
        self._skip_blank()
        if self.i >= len(self.lines):
            return None
        line = self.lines[self.i].strip()
        if line.startswith("# ") and ":" in line:
            return line[2 : line.index(":")]
        return None

    def int_header(self, key: str) -> int:
        txt = self.header(key)
        try:
            v = int(txt)
        except ValueError:
            raise self.error(f"'# {key}:' expected an integer, got {txt!r}") from None
        if v < 0:
            raise self.error(f"'# {key}:' expected a value >= 0, got {v}")
        return v

    def data_line(self) -> list[str]:
        self._skip_blank()
        if self.i >= len(self.lines):
            raise self.error("unexpected end of file, expected a line of numbers")
        line = self.lines[self.i]
        if line.lstrip().startswith("#"):
            raise self.error(f"expected a line of numbers, found {line.strip()[:60]!r}")
        self.i += 1
        return line.split()

    def numbers(self, line: list[str], expected: int) -> list[float]:
        if len(line) != expected:
            raise ValueError(
                f"{self.path}:{self.i}: expected {expected} numbers on this line, got {len(line)}"
            )
        try:
            return [_octave_number(v) for v in line]
        except ValueError as err:
            raise ValueError(f"{self.path}:{self.i}: not a number: {err}") from None

    def dims(self) -> tuple[int, ...]:
        if self.peek_header() == "ndims":
            nd = self.int_header("ndims")
            vals = self.numbers(self.data_line(), nd)
            if any(v < 0 or v != int(v) for v in vals):
                raise self.error(f"invalid dimensions {vals}")
            return tuple(int(v) for v in vals)
        return (self.int_header("rows"), self.int_header("columns"))

    def variable(self) -> tuple[str, Any]:
        name = self.header("name")
        typ = self.header("type")
        return name, self.value(typ)

    def value(self, typ: str) -> Any:
        words = typ.split()
        if "complex" in words:
            raise self.error(f"unsupported Octave type {typ!r}")
        if typ == "bool" or (words and words[-1] == "scalar"):  # scalar, int32 scalar, ...
            return self.numbers(self.data_line(), 1)[0]
        if words and words[-1] == "matrix":  # matrix, bool matrix, int32 matrix, ...
            return self.matrix()
        if typ == "cell":
            return self.cell()
        if typ == "struct":
            return self.struct(scalar=False)
        if typ == "scalar struct":
            return self.struct(scalar=True)
        if typ in ("string", "sq_string"):
            return self.string()
        raise self.error(f"unsupported Octave type {typ!r}")

    def matrix(self) -> np.ndarray:
        if self.peek_header() == "ndims":
            shape = self.dims()
            count = int(np.prod(shape))
            flat = [self.numbers(self.data_line(), 1)[0] for _ in range(count)]
            return np.array(flat, dtype=np.float64).reshape(shape, order="F")
        rows, cols = self.int_header("rows"), self.int_header("columns")
        out = np.empty((rows, cols), dtype=np.float64)
        for r in range(rows):
            out[r] = self.numbers(self.data_line(), cols)
        return out

    def cell(self) -> np.ndarray:
        shape = self.dims()
        count = int(np.prod(shape))
        flat = np.empty(count, dtype=object)
        for k in range(count):
            name, val = self.variable()
            if name != "<cell-element>":
                raise self.error(f"expected a '<cell-element>', found name {name!r}")
            flat[k] = val
        return flat.reshape(shape, order="F")

    def struct(self, *, scalar: bool) -> _OctaveStruct:
        shape: tuple[int, ...] = (1, 1)
        if self.peek_header() == "ndims":
            shape = self.dims()
        nfields = self.int_header("length")
        fields: dict[str, Any] = {}
        for _ in range(nfields):
            name, val = self.variable()
            fields[name] = val
        return _OctaveStruct(shape, fields, scalar)

    def string(self) -> list[str]:
        n = self.int_header("elements")
        out = []
        for _ in range(n):
            length = self.int_header("length")
            if self.i >= len(self.lines):
                raise self.error("unexpected end of file in a string")
            out.append(self.lines[self.i].rstrip("\n")[:length])
            self.i += 1
        return out

    def variables(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        while True:
            self._skip_blank()
            # Skip top-level comments such as "# Created by Octave ...".
            while self.i < len(self.lines) and (
                self.lines[self.i].startswith("#") and not self.lines[self.i].startswith("# name:")
            ):
                self.i += 1
                self._skip_blank()
            if self.i >= len(self.lines):
                return out
            name, val = self.variable()
            out[name] = val


def _read_octave_text(path: Path) -> dict[str, Any]:
    with _open_text(path) as fh:
        lines = fh.read().splitlines()
    return _OctaveReader(lines, path).variables()


def read_octave_laser(path: str | Path, *, variable: str | None = None) -> Iterator[Scan]:
    """Read scans from an Octave text file holding a ``laser`` struct (robot-mapping course).

    The struct (array) has the fields ``start_angle``, ``angular_resolution``,
    ``maximum_range``, ``ranges`` (1 x N), ``pose`` ([x y theta], robot pose in the map
    frame), and optionally ``laser_offset`` (3 values, laser pose in the robot frame; zero
    when absent) and ``timestamp``. In a struct array saved by Octave each field is a cell
    with one element per scan. Readings ``>= maximum_range`` are "no return" (the file stores
    81.91 for no return with ``maximum_range = 80``).

    The format stores each field for all scans together, so the whole file is parsed before
    the first scan is yielded (1.6 MB for the 686-scan CSAIL file).

    Parameters
    ----------
    path : str or Path
        Octave text file (``save -text``), optionally gzip-compressed.
    variable : str, optional
        Name of the struct variable; default: ``laser`` if present, else the only struct.

    Returns
    -------
    iterator of Scan
        Float64 ranges, ``range_min = 0``, ``range_max = maximum_range``.

    Raises
    ------
    FileNotFoundError, ValueError
        Missing file; syntax errors (with line number); missing fields or inconsistent cell
        lengths.
    """
    p = _check_file(path, "path")
    return _iter_octave(p, variable)


def _iter_octave(path: Path, variable: str | None) -> Iterator[Scan]:
    data = _read_octave_text(path)
    structs = {k: v for k, v in data.items() if isinstance(v, _OctaveStruct)}
    if variable is None:
        if "laser" in structs:
            variable = "laser"
        elif len(structs) == 1:
            variable = next(iter(structs))
        else:
            raise ValueError(
                f"{path}: expected one struct variable (or one named 'laser'), found structs "
                f"{sorted(structs)}; pass variable="
            )
    if variable not in structs:
        raise ValueError(
            f"variable: {variable!r} is not a struct in {path}; structs: {sorted(structs)}"
        )
    st = structs[variable]
    required = ("start_angle", "angular_resolution", "maximum_range", "ranges", "pose")
    missing = [f for f in required if f not in st.fields]
    if missing:
        raise ValueError(
            f"{path}: struct {variable!r} lacks field(s) {missing}; has {sorted(st.fields)}"
        )

    def as_list(name: str) -> list[Any]:
        val = st.fields[name]
        if not st.scalar and isinstance(val, np.ndarray) and val.dtype == object:
            return list(val.ravel(order="F"))
        return [val]

    columns = {name: as_list(name) for name in st.fields}
    count = len(columns["ranges"])
    bad = {k: len(v) for k, v in columns.items() if len(v) != count}
    if bad:
        raise ValueError(
            f"{path}: struct {variable!r} fields have different lengths: ranges has {count}, {bad}"
        )

    def scalar(name: str, i: int) -> float:
        v = np.asarray(columns[name][i], dtype=np.float64)
        if v.size != 1:
            raise ValueError(f"{path}: {variable}({i + 1}).{name}: expected a scalar, got {v!r}")
        return float(v.reshape(()))

    def triple(name: str, i: int) -> np.ndarray:
        v = np.asarray(columns[name][i], dtype=np.float64).ravel()
        if v.size != 3:
            raise ValueError(
                f"{path}: {variable}({i + 1}).{name}: expected 3 values, got shape "
                f"{np.shape(columns[name][i])}"
            )
        return v

    for i in range(count):
        ranges = np.asarray(columns["ranges"][i], dtype=np.float64)
        if ranges.ndim == 2 and 1 in ranges.shape:
            ranges = ranges.ravel()
        offset = triple("laser_offset", i) if "laser_offset" in columns else np.zeros(3)
        stamp = scalar("timestamp", i) if "timestamp" in columns else None
        try:
            scan = Scan(
                ranges,
                scalar("start_angle", i),
                scalar("angular_resolution", i),
                0.0,
                scalar("maximum_range", i),
                triple("pose", i),
                offset,
                stamp,
            )
        except (TypeError, ValueError) as err:
            raise ValueError(f"{path}: {variable}({i + 1}): {err}") from None
        yield scan


# --------------------------------------------------------------------------------------------
# ROS bags
# --------------------------------------------------------------------------------------------

_LASERSCAN = "sensor_msgs/msg/LaserScan"
_TF_TYPES = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")
_POSE_TYPES = (
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
)
_BASE_FRAME_CANDIDATES = ("base_footprint", "base_link")
_ROS1_MAGIC = b"#ROSBAG V2.0\n"


def _normalize_msgtype(name: str) -> str:
    """``pkg/Name`` (ROS 1) -> ``pkg/msg/Name``."""
    parts = name.split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return name


def _frame(name: str) -> str:
    """Frame id without the ROS 1 leading slash."""
    return name.strip().lstrip("/")


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


# A planar transform that may mirror: p -> R(yaw) @ diag(1, s) @ p + (x, y), s in {+1, -1}.
_Tf = tuple[float, float, float, int]
_IDENTITY_TF: _Tf = (0.0, 0.0, 0.0, 1)


def _tf_from_msg(translation: Any, rotation: Any) -> _Tf:
    """Planar part of a 3-D transform: translation x, y; heading of the rotated x axis;
    ``s = -1`` when the rotated z axis points down (sensor mounted upside down)."""
    qx, qy, qz, qw = (float(rotation.x), float(rotation.y), float(rotation.z), float(rotation.w))
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not math.isfinite(norm) or norm == 0.0:
        raise ValueError(f"invalid quaternion ({qx}, {qy}, {qz}, {qw})")
    qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
    r00 = 1.0 - 2.0 * (qy * qy + qz * qz)
    r10 = 2.0 * (qx * qy + qw * qz)
    r22 = 1.0 - 2.0 * (qx * qx + qy * qy)
    x, y = float(translation.x), float(translation.y)
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"invalid translation ({x}, {y})")
    return (x, y, math.atan2(r10, r00), -1 if r22 < 0.0 else 1)


def _tf_compose(a: _Tf, b: _Tf) -> _Tf:
    c, s = math.cos(a[2]), math.sin(a[2])
    bx, by = b[0], a[3] * b[1]
    return (
        a[0] + c * bx - s * by,
        a[1] + s * bx + c * by,
        _wrap_angle(a[2] + a[3] * b[2]),
        a[3] * b[3],
    )


def _tf_inverse(a: _Tf) -> _Tf:
    yaw = -a[3] * a[2]
    c, s = math.cos(yaw), math.sin(yaw)
    tx, ty = a[0], a[3] * a[1]
    return (-(c * tx - s * ty), -(s * tx + c * ty), _wrap_angle(yaw), a[3])


class _TfSeries:
    """Time series of one transform (parent -> child), linearly interpolated."""

    def __init__(self) -> None:
        self.t: list[int] = []
        self.v: list[_Tf] = []
        self.static = False
        self._arr: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    def add(self, t_ns: int, tf: _Tf, static: bool) -> None:
        if static:
            self.static = True
            self.t, self.v = [t_ns], [tf]
        elif not self.static:
            self.t.append(t_ns)
            self.v.append(tf)
        self._arr = None

    def _arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if self._arr is None:
            order = np.argsort(np.asarray(self.t, dtype=np.int64), kind="stable")
            t = np.asarray(self.t, dtype=np.int64)[order]
            v = np.asarray(self.v, dtype=np.float64)[order]
            self._arr = (t, v[:, 0], v[:, 1], np.unwrap(v[:, 2]), v[:, 3])
        return self._arr

    def at(self, t_ns: int, tol_ns: int) -> _Tf | None:
        if self.static:
            return self.v[-1]
        t, x, y, yaw, s = self._arrays()
        if t_ns < t[0] - tol_ns or t_ns > t[-1] + tol_ns:
            return None
        k = int(np.searchsorted(t, t_ns, side="right"))
        if k == 0:
            return (float(x[0]), float(y[0]), _wrap_angle(float(yaw[0])), int(s[0]))
        if k == len(t) or t[k - 1] == t_ns:
            j = k - 1
            return (float(x[j]), float(y[j]), _wrap_angle(float(yaw[j])), int(s[j]))
        w = float(t_ns - t[k - 1]) / float(t[k] - t[k - 1])
        return (
            float(x[k - 1] + w * (x[k] - x[k - 1])),
            float(y[k - 1] + w * (y[k] - y[k - 1])),
            _wrap_angle(float(yaw[k - 1] + w * (yaw[k] - yaw[k - 1]))),
            int(s[k - 1]),
        )


class _TfTree:
    """The tf tree of a bag: child frame -> (parent frame, series)."""

    def __init__(self) -> None:
        self.edges: dict[str, tuple[str, _TfSeries]] = {}

    def add(self, parent: str, child: str, t_ns: int, tf: _Tf, static: bool) -> None:
        if not parent or not child or parent == child:
            return
        cur = self.edges.get(child)
        if cur is None:
            cur = (parent, _TfSeries())
            self.edges[child] = cur
        elif cur[0] != parent:
            raise ValueError(
                f"tf: frame {child!r} has two parents ({cur[0]!r} and {parent!r}); "
                f"a tf tree must be a tree"
            )
        cur[1].add(t_ns, tf, static)

    @property
    def frames(self) -> set[str]:
        out = set(self.edges)
        out.update(p for p, _ in self.edges.values())
        return out

    def ancestors(self, frame: str) -> list[str]:
        """``frame`` followed by its parents up to the root."""
        chain = [frame]
        seen = {frame}
        while chain[-1] in self.edges:
            parent = self.edges[chain[-1]][0]
            if parent in seen:
                raise ValueError(f"tf: cycle through frame {parent!r}")
            chain.append(parent)
            seen.add(parent)
        return chain

    def connected(self, a: str, b: str) -> bool:
        return self.ancestors(a)[-1] == self.ancestors(b)[-1]

    def _to_root(self, frame: str, t_ns: int, tol_ns: int) -> tuple[str, _Tf] | None:
        tf = _IDENTITY_TF
        cur = frame
        for parent in self.ancestors(frame)[1:]:
            edge = self.edges[cur][1].at(t_ns, tol_ns)
            if edge is None:
                return None
            tf = _tf_compose(edge, tf)
            cur = parent
        return cur, tf

    def lookup(self, target: str, source: str, t_ns: int, tol_ns: int) -> _Tf | None:
        """Transform taking ``source`` coordinates to ``target`` coordinates (pose of
        ``source`` in ``target``), or None if not available at ``t_ns``."""
        a = self._to_root(target, t_ns, tol_ns)
        b = self._to_root(source, t_ns, tol_ns)
        if a is None or b is None:
            return None
        if a[0] != b[0]:
            raise ValueError(f"tf: frames {target!r} and {source!r} are not connected")
        return _tf_compose(_tf_inverse(a[1]), b[1])


class _Ros1Connection(NamedTuple):
    topic: str
    msgtype: str
    msgdef: str
    md5sum: str
    callerid: str | None


class _Ros1Sequential:
    """Minimal sequential reader for ROS 1 bag v2.0 files.

    Used when ``rosbags`` cannot open a bag whose index records are inconsistent (for
    example the CCNY demo bag, written in 2010, whose INDEX_DATA records declare 20 bytes
    per entry but hold 12). It walks the chunk records in file order and never uses the
    index; message definitions are taken from the bag's connection records.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.connections: dict[int, _Ros1Connection] = {}
        self._typestore: Any = None
        if not self._connections_from_index():
            for _ in self._records(want_messages=False):
                pass

    def _connections_from_index(self) -> bool:
        """Read the connection records at the bag header's ``index_pos``; False if absent."""
        with open(self.path, "rb") as fh:
            if fh.read(len(_ROS1_MAGIC)) != _ROS1_MAGIC:
                raise ValueError(f"{self.path}: not a ROS 1 bag v2.0 file")
            head = fh.read(4096 + 64)
            try:
                hdr, _, _, _ = self._read_record(head, 0)
                index_pos = struct.unpack("<Q", hdr["index_pos"])[0]
                conn_count = struct.unpack("<I", hdr["conn_count"])[0]
            except (KeyError, ValueError, struct.error):
                return False
            if index_pos == 0 or conn_count == 0:
                return False
            fh.seek(index_pos)
            tail = fh.read()
        pos = 0
        found = 0
        try:
            while pos < len(tail) and found < conn_count:
                hdr, start, dlen, _ = self._read_record(tail, pos)
                if hdr.get("op", b"\xff")[0] == 0x07:
                    self._add_connection(hdr, tail[start : start + dlen])
                    found += 1
                pos = start + dlen
        except (KeyError, ValueError, struct.error):
            self.connections.clear()
            return False
        return found == conn_count

    @property
    def topics(self) -> dict[str, str]:
        return {c.topic: c.msgtype for c in self.connections.values()}

    @staticmethod
    def _header(buf: bytes, what: str) -> dict[str, bytes]:
        fields: dict[str, bytes] = {}
        i = 0
        while i < len(buf):
            if i + 4 > len(buf):
                raise ValueError(f"truncated {what} header")
            (n,) = struct.unpack_from("<I", buf, i)
            item = buf[i + 4 : i + 4 + n]
            if len(item) != n or b"=" not in item:
                raise ValueError(f"malformed {what} header field")
            key, val = item.split(b"=", 1)
            fields[key.decode("latin-1")] = val
            i += 4 + n
        return fields

    @staticmethod
    def _read_record(buf: bytes, pos: int) -> tuple[dict[str, bytes], int, int, int]:
        """Header fields, data start, stored data length, position after the header+len."""
        if pos + 4 > len(buf):
            raise ValueError("truncated record")
        (hlen,) = struct.unpack_from("<I", buf, pos)
        hdr = _Ros1Sequential._header(buf[pos + 4 : pos + 4 + hlen], "record")
        if pos + 8 + hlen > len(buf):
            raise ValueError("truncated record")
        (dlen,) = struct.unpack_from("<I", buf, pos + 4 + hlen)
        start = pos + 8 + hlen
        return hdr, start, dlen, start

    def _add_connection(self, hdr: dict[str, bytes], data: bytes) -> None:
        conn = struct.unpack("<I", hdr["conn"])[0]
        topic = hdr["topic"].decode("utf-8", "replace")
        info = self._header(data, "connection")
        self.connections[conn] = _Ros1Connection(
            topic,
            _normalize_msgtype(info.get("type", b"").decode("utf-8", "replace")),
            info.get("message_definition", b"").decode("utf-8", "replace"),
            info.get("md5sum", b"").decode("ascii", "replace"),
            info.get("callerid", b"").decode("utf-8", "replace") or None,
        )

    def _records(self, want_messages: bool) -> Iterator[tuple[int, int, bytes]]:
        with open(self.path, "rb") as fh:
            if fh.read(len(_ROS1_MAGIC)) != _ROS1_MAGIC:
                raise ValueError(f"{self.path}: not a ROS 1 bag v2.0 file")
            while True:
                pos = fh.tell()
                head = fh.read(4)
                if not head:
                    return
                if len(head) < 4:
                    raise ValueError(f"{self.path}: truncated record at byte {pos}")
                (hlen,) = struct.unpack("<I", head)
                hbuf = fh.read(hlen)
                dbuf = fh.read(4)
                if len(hbuf) != hlen or len(dbuf) != 4:
                    raise ValueError(f"{self.path}: truncated record at byte {pos}")
                hdr = self._header(hbuf, f"record at byte {pos} of {self.path}")
                (dlen,) = struct.unpack("<I", dbuf)
                op = hdr.get("op", b"\xff")[0]
                if op == 0x04:  # INDEX_DATA: trust the entry count, not the data length
                    ver = struct.unpack("<I", hdr["ver"])[0] if "ver" in hdr else 1
                    count = struct.unpack("<I", hdr["count"])[0] if "count" in hdr else 0
                    if ver == 1:
                        dlen = 12 * count
                    fh.seek(dlen, 1)
                    continue
                if op != 0x05:  # BAG_HEADER, CONNECTION, CHUNK_INFO, ...: skip or record
                    data = fh.read(dlen)
                    if op == 0x07:
                        self._add_connection(hdr, data)
                    continue
                data = fh.read(dlen)
                comp = hdr.get("compression", b"none").decode()
                if comp == "bz2":
                    data = bz2.decompress(data)
                elif comp == "lz4":
                    import lz4.frame  # type: ignore[import-untyped]

                    data = lz4.frame.decompress(data)
                elif comp != "none":
                    raise ValueError(f"{self.path}: unsupported chunk compression {comp!r}")
                yield from self._chunk_records(data, want_messages)

    def _chunk_records(self, data: bytes, want_messages: bool) -> Iterator[tuple[int, int, bytes]]:
        pos = 0
        while pos < len(data):
            try:
                hdr, start, dlen, _ = self._read_record(data, pos)
            except ValueError as err:
                raise ValueError(f"{self.path}: corrupt chunk: {err}") from None
            op = hdr.get("op", b"\xff")[0]
            payload = data[start : start + dlen]
            if op == 0x07:
                self._add_connection(hdr, payload)
            elif op == 0x02 and want_messages:
                conn = struct.unpack("<I", hdr["conn"])[0]
                sec, nsec = struct.unpack("<II", hdr["time"])
                yield conn, sec * 1_000_000_000 + nsec, payload
            pos = start + dlen

    def _store(self) -> Any:
        if self._typestore is None:
            from rosbags.typesys import Stores, get_types_from_msg, get_typestore

            store = get_typestore(Stores.EMPTY)
            # Start from the ROS 1 Noetic definitions: bags from early ROS releases define
            # ``roslib/Header`` but refer to it as ``Header`` (= std_msgs/Header today).
            typs: dict[str, Any] = dict(get_typestore(Stores.ROS1_NOETIC).fielddefs)
            for c in self.connections.values():
                if c.msgdef:
                    typs.update(get_types_from_msg(c.msgdef, c.msgtype))
            store.register(typs)
            self._typestore = store
        return self._typestore

    def messages(self, topics: Iterable[str]) -> Iterator[tuple[str, str, int, Any]]:
        wanted = set(topics)
        store = self._store()
        for conn, t_ns, raw in self._records(want_messages=True):
            c = self.connections.get(conn)
            if c is None:
                raise ValueError(f"{self.path}: message for unknown connection {conn}")
            if c.topic in wanted:
                yield c.topic, c.msgtype, t_ns, store.deserialize_ros1(raw, c.msgtype)


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


# --------------------------------------------------------------------------------------------
# Dispatch
# --------------------------------------------------------------------------------------------

_BAG_SUFFIXES = (".bag", ".db3", ".mcap")
_CARMEN_SUFFIXES = (".log", ".clf", ".gz", ".carmen")


def _looks_octave(path: Path) -> bool:
    with _open_text(path) as fh:
        for _ in range(20):
            line = fh.readline()
            if not line:
                return False
            s = line.strip()
            if s.startswith("# Created by Octave") or s.startswith("# name:"):
                return True
            if s and not s.startswith("#"):
                return False
    return False


def read_scans(path: str | Path, **kwargs: Any) -> Iterator[Scan]:
    """Read scans from any supported file, choosing the reader by content and suffix.

    * a folder, a ROS 1 bag (``#ROSBAG V2.0`` magic), an SQLite or MCAP file, or the
      suffixes ``.bag`` / ``.db3`` / ``.mcap`` -> :func:`read_bag`;
    * an Octave text file (``# Created by Octave`` or ``# name:`` in its first lines, plain
      or gzip) -> :func:`read_octave_laser`;
    * anything else (``.log``, ``.clf``, ``.gz``, ...) -> :func:`read_carmen`.

    Parameters
    ----------
    path : str or Path
        The file or bag folder.
    **kwargs
        Passed to the chosen reader.

    Returns
    -------
    iterator of Scan

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"path: file not found: {p}")
    reader = _reader_for(p)
    accepted = inspect.signature(reader).parameters
    unknown = sorted(set(kwargs) - set(accepted))
    if unknown:
        options = sorted(k for k, v in accepted.items() if v.kind is v.KEYWORD_ONLY)
        raise ValueError(
            f"{p} is read by {reader.__name__}, which takes no {', '.join(unknown)} "
            f"(its options: {', '.join(options)})"
        )
    return reader(p, **kwargs)


def _reader_for(p: Path):
    """The reader of :func:`read_scans` for an existing path."""
    if p.is_dir():
        return read_bag
    with open(p, "rb") as fh:
        magic = fh.read(16)
    if (
        magic.startswith(_ROS1_MAGIC[:9])
        or magic.startswith(b"SQLite format 3")
        or magic.startswith(b"\x89MCAP")
        or p.suffix.lower() in _BAG_SUFFIXES
    ):
        return read_bag
    if _looks_octave(p):
        return read_octave_laser
    return read_carmen
