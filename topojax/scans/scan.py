"""The :class:`Scan` type, planar pose helpers, and scans from plain arrays."""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import pose as checked_pose
from .._validate import real_array, real_number, real_values, unmasked

PoseLike = Sequence[float] | np.ndarray

_TWO_PI = 2.0 * math.pi


def _wrap_angle(a: float) -> float:
    """Wrap an angle in radians to ``[-pi, pi)``."""
    return (a + math.pi) % _TWO_PI - math.pi


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


#: The farthest a sensor may sit from its robot's frame (metres): the largest vehicles
#: that carry a planar laser measure tens of metres, so an offset beyond is no mounting
#: but a unit or field error (millimetres read as metres, a pose given as the offset).
MAX_SENSOR_OFFSET_M = 100.0


def mounting(name: str, value: Any) -> tuple[float, float, float]:
    """``value`` as a sensor's offset ``(x_m, y_m, yaw_rad)`` in its robot's frame after
    checking it as a robot's pose is checked, and that ``(x, y)`` lies within
    :data:`MAX_SENSOR_OFFSET_M` of the frame's origin; a ``ValueError`` naming ``name``,
    the bound and the distance received otherwise."""
    x, y, yaw = checked_pose(name, value, bounded=False)
    off_m = math.hypot(x, y)
    if off_m > MAX_SENSOR_OFFSET_M:
        raise ValueError(
            f"{name}: expected a sensor's mounting on its robot, (x_m, y_m) within "
            f"{MAX_SENSOR_OFFSET_M:g} m of the robot's frame, received {value!r} "
            f"({off_m:.6g} m off: millimetres given as metres?)"
        )
    return (x, y, yaw)


#: The largest |angle_min| and |angle_increment| a scan may have (radians), with slack
#: for a float32 2 pi.
_FULL_TURN = 2.0 * math.pi + 1e-6


def reading_limits(dtype, range_min: float, range_max: float) -> tuple[float, float]:
    """``(range_min, range_max)`` in the precision of readings of ``dtype``.

    A float32 reading at a sensor's ``range_max`` of 5.6 m is ``float32(5.6)``, just
    below 5.6: compared with the float64 limit it would count as a hit (as would a
    float16 reading at 4.2 m).  Rounded to the nearest float32 (float16: no such number
    lies between a limit and its rounding), the limits compare the readings as they
    are stored.

    Parameters
    ----------
    dtype : numpy.dtype
        Dtype of the readings (float16, float32 or float64).
    range_min, range_max : float
        Limits in metres; ``range_max`` may be inf.

    Returns
    -------
    tuple of 2 floats
        The limits, rounded to the readings' precision for float16 and float32
        readings, else as given.
    """
    dtype = np.dtype(dtype)
    if dtype not in (np.float16, np.float32):
        return range_min, range_max
    top = float(np.finfo(dtype).max)
    return tuple(float(dtype.type(v)) if abs(v) <= top else v for v in (range_min, range_max))


# --------------------------------------------------------------------------------------------
# Scan
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False, repr=False)
class Scan:
    """One planar laser scan with the robot's pose in the map frame.

    Parameters
    ----------
    ranges : numpy.ndarray, shape (N,), float16, float32 or float64
        Measured ranges in metres, beam order (stored in native byte order). Integers are
        converted to float64, JAX's ``bfloat16`` (and other ``ml_dtypes`` floats) to
        float32.
        NaN / inf / non-positive values are allowed and are treated as "no return", as
        are the masked entries of a NumPy masked array (stored as NaN).
        The array is copied and made read-only.
    angle_min : float
        Angle of beam 0 in radians, counter-clockwise from the sensor's ``x`` axis.
    angle_increment : float
        Angle between consecutive beams in radians; finite and non-zero (negative for
        sensors that sweep clockwise); the beams sweep at most one turn, ``(N - 1) *
        |angle_increment| <= 2 pi`` (with one beam's slack for a last beam repeating the
        first).
    range_min, range_max : float
        Readings ``r`` with ``range_min <= r < range_max`` are hits, everything else is
        "no return". ``range_min >= 0``; ``range_max > range_min`` (``inf`` allowed).
    pose : tuple of 3 floats
        ``(x_m, y_m, yaw_rad)`` of the ROBOT in the map frame. Must be finite, ``|yaw|``
        at most 1e9 rad (beyond, a float64 angle resolves no heading).
    sensor_offset : tuple of 3 floats, optional
        ``(x_m, y_m, yaw_rad)`` of the sensor in the robot frame; default ``(0, 0, 0)``;
        finite, ``(x, y)`` within 100 m of the robot's frame's origin (a mounting on the
        robot: farther is a unit or field error), ``|yaw|`` at most 1e9 rad.
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
            arr = real_values(np.asarray(unmasked("ranges", raw, fill=math.nan)))
        except (TypeError, ValueError) as err:
            raise TypeError(
                f"ranges: expected a 1-D numeric array, received {raw!r} ({err})"
            ) from None
        if arr.dtype.kind not in "iuf":
            raise TypeError(f"ranges: expected a real numeric array, received dtype {arr.dtype}")
        if arr.ndim != 1:
            raise ValueError(f"ranges: expected a 1-D array (N,), received shape {arr.shape}")
        dtype = arr.dtype.newbyteorder("=")  # big-endian float32 readings stay float32
        dtype = dtype if dtype in (np.float16, np.float32, np.float64) else np.float64
        arr = np.array(arr, dtype=dtype, copy=True)
        arr.flags.writeable = False
        object.__setattr__(self, "ranges", arr)

        a0 = real_number("angle_min", self.angle_min)
        inc = real_number("angle_increment", self.angle_increment)
        if inc == 0.0:
            raise ValueError("angle_increment: expected a non-zero angle in radians, received 0.0")
        for name, value in (("angle_min", a0), ("angle_increment", inc)):
            if abs(value) > _FULL_TURN:  # degrees given as radians, or a garbled field
                raise ValueError(
                    f"{name}: expected an angle in radians within one turn (|a| <= 2 pi), "
                    f"received {value!r}"
                )
        sweep = max(arr.shape[0] - 1, 0) * abs(inc)
        if sweep > _FULL_TURN + abs(inc):  # the last beam may repeat the first, no more
            raise ValueError(
                "angle_increment: expected beams within one turn ((n_beams - 1) * "
                f"|angle_increment| <= 2 pi), received {inc!r} rad for {arr.shape[0]} beams, "
                f"a sweep of {sweep:.4g} rad (degrees given as radians?)"
            )
        object.__setattr__(self, "angle_min", a0)
        object.__setattr__(self, "angle_increment", inc)
        rmin = real_number("range_min", self.range_min)
        if rmin < 0.0:
            raise ValueError(f"range_min: expected a value >= 0 m, received {rmin!r}")
        rmax = real_number("range_max", self.range_max, allow_inf=True)
        if not rmax > rmin:
            raise ValueError(
                f"range_max: expected a value > range_min ({rmin!r} m), received {rmax!r} m"
            )
        object.__setattr__(self, "range_min", rmin)
        object.__setattr__(self, "range_max", rmax)
        object.__setattr__(self, "pose", checked_pose("pose", self.pose, bounded=False))
        object.__setattr__(self, "sensor_offset", mounting("sensor_offset", self.sensor_offset))
        if self.timestamp is not None:
            object.__setattr__(self, "timestamp", real_number("timestamp", self.timestamp))

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
            Ranges in metres; masked entries (a NumPy masked array) are "no return".
        pose : array_like, shape (3,)
            Robot pose ``(x_m, y_m, yaw_rad)`` in the map frame.
        angle_min, angle_increment : float
            Beam geometry in radians (see :class:`Scan`).
        range_min, range_max : float, optional
            Valid range interval ``[range_min, range_max)`` in metres; default ``[0, inf)``.
        sensor_offset : array_like, shape (3,), optional
            Sensor pose in the robot frame, ``(x, y)`` within 100 m of its origin.
        timestamp : float, optional
            Time in seconds.

        Returns
        -------
        Scan
        """
        return cls(
            ranges,
            angle_min,
            angle_increment,
            range_min,
            range_max,
            checked_pose("pose", pose, bounded=False),
            mounting("sensor_offset", sensor_offset),
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
            Float32 (float16) readings are compared with the limits rounded to float32
            (float16), so a reading stored at ``range_max`` is a no-return even where the
            limit (5.6 m, say) has no exact float32.
        """
        rmin, rmax = reading_limits(self.ranges.dtype, self.range_min, self.range_max)
        r = self.ranges.astype(np.float64)
        with np.errstate(invalid="ignore"):
            return np.isfinite(r) & (r > 0.0) & (r >= rmin) & (r < rmax)

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
        Ranges in metres, one row per scan; masked entries (a NumPy masked array) are
        "no return".
    poses : array_like, shape (S, 3)
        Robot poses ``(x_m, y_m, yaw_rad)`` in the map frame, one row per scan.
    angle_min, angle_increment : float
        Beam geometry in radians, shared by all scans.
    range_min, range_max : float, optional
        Valid range interval ``[range_min, range_max)`` in metres.
    timestamps : array_like, shape (S,), optional
        Times in seconds.
    sensor_offset : array_like, shape (3,), optional
        Sensor pose in the robot frame, shared by all scans, ``(x, y)`` within 100 m of
        its origin.

    Returns
    -------
    iterator of Scan
        The shapes are checked when this function is called; scans are built lazily.

    Raises
    ------
    TypeError
        If ``poses`` or ``timestamps`` hold no real numbers (None, text, complex).
    ValueError
        If the shapes do not match.
    """
    r = np.asarray(unmasked("ranges", ranges, fill=math.nan))
    p = real_array("poses", poses)  # None, text, complex: a TypeError naming poses
    if r.ndim != 2:
        raise ValueError(f"ranges: expected a 2-D array (S, N), received shape {r.shape}")
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"poses: expected an array of shape (S, 3), received shape {p.shape}")
    if p.shape[0] != r.shape[0]:
        raise ValueError(
            f"poses: expected {r.shape[0]} rows (one per row of ranges), received {p.shape[0]}"
        )
    t: np.ndarray | None = None
    if timestamps is not None:
        t = real_array("timestamps", timestamps)
        if t.shape != (r.shape[0],):
            raise ValueError(
                f"timestamps: expected shape ({r.shape[0]},), received shape {t.shape}"
            )
    offset = mounting("sensor_offset", sensor_offset)
    # Validate the shared geometry once, eagerly, on a scan of as many beams.
    Scan(np.zeros(r.shape[1]), angle_min, angle_increment, range_min, range_max, (0, 0, 0), offset)

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


def no_scan_error(path: Any, reason: str, expected: str) -> ValueError:
    """The refusal of a log that leaves no scan to read, the same for every reader:
    ``reason`` says what became of its records (``2 FLASER line(s) skipped for ...``),
    ``expected`` what a log needs to make a scan."""
    return ValueError(f"{path}: no scan to read: {reason}; expected {expected}")


#: The files :func:`topojax.read_scans` reads, and their usual suffixes.
_READ_FORMATS = (
    "CARMEN logs (.log, .clf; plain or gzip, .gz), Octave text files (save -text: .txt, "
    ".mat; plain or gzip), ROS 1 bags (.bag), ROS 2 bags (a folder with metadata.yaml, or "
    "its .db3 or .mcap file) and MCAP recordings (.mcap)"
)


def _unknown_format_error(path: Any, what: str) -> ValueError:
    """The refusal of a file that is no format topojax reads: ``what`` says what it
    holds instead; the message lists the formats read."""
    return ValueError(
        f"{path}: not a laser log or bag that topojax reads: {what}; topojax reads {_READ_FORMATS}"
    )


class _SkippedScans:
    """The records of a log whose fields make no :class:`Scan` (an ``angle_increment`` of
    0 or NaN, a ``range_max`` not above ``range_min``, say: a sensor glitch).  A reader
    skips them rather than refuse the log, and once its iterator is exhausted warns of
    how many there were and why the first made none; a log none of whose records makes a
    scan (angles in degrees, ranges of the wrong shape: no glitch) is refused."""

    def __init__(self) -> None:
        self.count = 0
        self.made = 0
        self.first = ""

    def scan(self, where: str, *fields: Any) -> Scan | None:
        """``Scan(*fields)``, or None (and counted) where the fields make none; ``where``
        names the record for the warning (``at t=1.5 s``, ``laser(3)``)."""
        try:
            scan = Scan(*fields)
        except (TypeError, ValueError) as err:
            if not self.count:
                self.first = f"{where}: {err}"
            self.count += 1
            return None
        self.made += 1
        return scan

    def finish(self, path: Any, records: str, *, others: int = 0) -> None:
        """From a reader's exhausted iterator: the warning, where any records were
        skipped, or a ValueError where all were (``records`` says what they are:
        ``sensor_msgs/msg/LaserScan message(s) on /scan``; ``others``: how many the reader
        skipped for another reason, a pose it has not, say, counted in the refusal)."""
        if self.count and not self.made:
            raise no_scan_error(
                path,
                f"{self.count + others} {records} skipped, the first whose fields make none "
                f"is {self.first}",
                "at least one whose fields make a scan",
            )
        if self.count:
            warnings.warn(
                f"{path}: skipped {self.count} {records} whose fields make no scan (a "
                f"sensor glitch), the first {self.first}",
                stacklevel=3,
            )
