"""CARMEN log reader (``FLASER`` / ``RLASER``, ``ROBOTLASERk``, ``RAWLASERk`` lines)."""

from __future__ import annotations

import math
import re
import warnings
from array import array
from collections import Counter
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .._constants import CARMEN_LASERS
from .._validate import existing_file, one_of, real_number
from ._text import _cut_off, _open_text, gzip_cut
from .scan import PoseLike, Scan, _relative, _unknown_format_error, mounting, no_scan_error

_OLD_LASERS = ("FLASER", "RLASER")
_ROBOT_LASERS = ("ROBOTLASER1", "ROBOTLASER2")
_RAW_LASERS = ("RAWLASER1", "RAWLASER2", "RAWLASER3", "RAWLASER4")

#: Default width (m) of the band below a CARMEN file's no-return value that counts as
#: "no return". In the 13 corrected logs the no-return values form a cluster up to 0.15 m
#: wide (acapulco: 51.14-51.25; infinite-corridor: 51.06-51.16; freiburg-campus:
#: 81.83/81.91; seattle: 81.87/81.91) with at most a handful of readings between 0.2 m and
#: 1 m below it.
CARMEN_NO_RETURN_MARGIN_M = 0.2


def _carmen_beam_increment(n: int) -> float:
    """Beam spacing (rad) of an old-format CARMEN scan of ``n`` beams over a 180° fan."""
    return math.pi / (n - 1) if n % 2 else math.pi / n


class _CarmenLineError(ValueError):
    pass


class _NotFinite(_CarmenLineError):
    """A well-formed line whose ``what`` is NaN or infinite (``why``: a glitch of the
    logger or the localisation): its scan is skipped, not the log refused."""

    what = ""
    why = ""


class _PoseNotFinite(_NotFinite):
    what, why = "pose", "a localisation glitch"


class _StampNotFinite(_NotFinite):
    what, why = "timestamp", "a logging glitch"


def _floats(tokens: Sequence[str], what: str) -> np.ndarray:
    try:
        return np.array([float(v) for v in tokens], dtype=np.float64)
    except ValueError as err:
        raise _CarmenLineError(f"{what}: not a number ({err})") from None


def _count(token: str, what: str) -> int:
    try:
        n = int(token)
    except ValueError:
        raise _CarmenLineError(f"{what}: expected an integer, received {token!r}") from None
    if n < 0:
        raise _CarmenLineError(f"{what}: expected a count >= 0, received {n}")
    return n


def _need(tokens: Sequence[str], start: int, k: int, what: str, after: str) -> None:
    """A :class:`_CarmenLineError` unless ``tokens`` hold at least ``k`` fields from
    index ``start`` on, those of ``what``; the message counts the fields after ``after``
    (the field before ``start``), as it names them."""
    have = max(0, len(tokens) - start)
    if have < k:
        fields = "field" if k == 1 else "fields"
        raise _CarmenLineError(
            f"{what}: expected at least {k} {fields} after {after}, received {have}"
        )


def _parse_old_laser(tokens: list[str]) -> tuple[np.ndarray, np.ndarray | None, float | None]:
    """Parse FLASER/RLASER: ``n r_1..r_n [x y theta odom_x odom_y odom_theta] ts host lts``.

    Returns ranges, the pose (x, y, theta) or None for pose-less lines, and the timestamp.
    """
    _need(tokens, 1, 1, "the beam count", tokens[0])
    n = _count(tokens[1], "number of readings")
    if n < 2:
        raise _CarmenLineError(f"number of readings: expected >= 2, received {n}")
    _need(tokens, 2, n, f"{n} ranges", "the beam count")
    ranges = _floats(tokens[2 : 2 + n], "range reading")
    rest = len(tokens) - 2 - n
    if rest == 9:  # more would shift every field: a wrong beam count
        nums = _floats(tokens[2 + n : 9 + n], "pose / odometry / timestamp")
        if not np.all(np.isfinite(nums[:3])):
            raise _PoseNotFinite(f"pose: expected finite x y theta, received {nums[:3].tolist()}")
        return ranges, nums[:3], float(nums[6])
    if rest == 3:  # very old raw format: n ranges ipc_timestamp hostname logger_timestamp
        return ranges, None, float(_floats(tokens[2 + n : 3 + n], "timestamp")[0])
    raise _CarmenLineError(
        f"fields after the {n} ranges: expected 9 (x y theta odom_x odom_y odom_theta "
        f"timestamp host logger_timestamp) or 3 (timestamp host logger_timestamp), "
        f"received {rest}"
    )


def _parse_new_laser_head(tokens: list[str]) -> tuple[np.ndarray, np.ndarray, int]:
    """Parse the common head of ROBOTLASERk / RAWLASERk lines.

    ``laser_type start_angle field_of_view angular_resolution maximum_range accuracy
    remission_mode num_readings r_1..r_n num_remissions rem_1..rem_m``.
    Returns ``[start_angle, fov, angular_resolution, maximum_range]``, the ranges and the
    index of the first token after the remissions.
    """
    _need(tokens, 1, 8, "the laser configuration", tokens[0])
    cfg = _floats(tokens[2:6], "laser configuration")
    n = _count(tokens[8], "num_readings")
    _need(tokens, 9, n + 1, f"{n} ranges and num_remissions", "num_readings")
    ranges = _floats(tokens[9 : 9 + n], "range reading")
    m = _count(tokens[9 + n], "num_remissions")
    return cfg, ranges, 10 + n + m


_MESSAGE_NAME = re.compile(r"[A-Z][A-Z0-9_]*")


def _opens_a_carmen_line(field: str) -> bool:
    """Whether a file whose first line opens with ``field`` may be a CARMEN log: the name
    of a message (``FLASER``, ``ODOM``, ``PARAM``) or a ``#`` comment."""
    return field.startswith("#") or bool(_MESSAGE_NAME.fullmatch(field))


class _ValueCounts:
    """A multiset of readings kept as distinct values and their counts, so that it does
    not grow with the readings of a long log (a log prints its ranges to a few decimals,
    and its no-returns share a few values)."""

    _BUFFER = 1 << 16  # readings taken before they are merged into the counts

    def __init__(self) -> None:
        self.values = np.empty(0)
        self.counts = np.empty(0, np.int64)
        self._pending: list[np.ndarray] = []
        self._n_pending = 0

    def add(self, readings: np.ndarray) -> None:
        self._pending.append(readings)
        self._n_pending += readings.size
        if self._n_pending >= self._BUFFER:
            self._merge()

    def _merge(self) -> None:
        if not self._pending:
            return
        values = np.concatenate([self.values, *self._pending])
        weights = np.concatenate([self.counts, np.ones(self._n_pending, np.int64)])
        self.values, where = np.unique(values, return_inverse=True)
        self.counts = np.bincount(where, weights=weights, minlength=self.values.size).astype(
            np.int64
        )
        self._pending, self._n_pending = [], 0

    def count_between(self, low: float, high: float) -> int:
        """How many readings lie in ``[low, high]``."""
        self._merge()
        inside = (self.values >= low) & (self.values <= high)
        return int(self.counts[inside].sum())


class _Survey(NamedTuple):
    """What the first pass over a log found: the laser message to use, the PARAM values,
    and (when the range limit is to be inferred) each scan's largest finite reading, the
    readings within ``_TOP_BAND_M`` of it (counted by value), how many finite readings
    there were, how many lines had a finite pose, how many had none and the first of
    them, whether a line of the kind was found, how many were malformed (skipped) and the
    first of them, and the first field of the first line that is not blank (None for a
    file of blank lines)."""

    chosen: str | None
    params: dict[str, str]
    scan_max: np.ndarray
    tops: _ValueCounts
    n_readings: int
    n_posed: int
    unposed: tuple[int, str]
    found: bool
    bad: tuple[int, str]
    first_field: str | None


def _survey_carmen(path: Path, laser: str, need_max: bool, skip_bad: bool = False) -> _Survey:
    """First pass over the log (see :class:`_Survey`); malformed laser lines raise, or
    with ``skip_bad`` are passed over (the reading pass warns)."""
    chosen = None if laser == "auto" else laser
    scan_max = array("d")
    tops = _ValueCounts()
    n_readings = n_posed = 0
    unposed, bad = _Tally(), _Tally()
    found = False
    params: dict[str, str] = {}
    first_field = None
    with _open_text(path, warn_cut=False) as fh:  # the reading pass warns
        for lineno, line in enumerate(fh, 1):
            tokens = line.split()
            if not tokens:
                continue
            key = tokens[0]
            if first_field is None:
                first_field = key
            if key == "PARAM" and len(tokens) >= 3:
                params[tokens[1]] = tokens[2]
                continue
            if key not in CARMEN_LASERS:
                continue
            if chosen is None:
                chosen = key
            if key != chosen:
                continue
            found = True
            if not need_max:
                # Keep reading PARAM lines only until the first scan of the chosen kind.
                break
            try:
                if key in _OLD_LASERS:
                    ranges = _parse_old_laser(tokens)[0]
                else:
                    ranges = _parse_new_laser_head(tokens)[1]
            except _PoseNotFinite as err:  # skipped when read
                unposed.add(lineno, err)
                continue
            except _CarmenLineError as err:
                if _cut_off(line):  # the logger stopped mid-line: the scans before count
                    break
                if not skip_bad:
                    raise _malformed(path, lineno, key, err) from None
                bad.add(lineno, err)
                continue
            n_posed += 1
            finite = ranges[np.isfinite(ranges)]
            if finite.size:
                top = float(finite.max())
                scan_max.append(top)
                tops.add(finite[finite >= top - _TOP_BAND_M])
                n_readings += finite.size
    return _Survey(
        chosen,
        params,
        np.frombuffer(scan_max, np.float64),
        tops,
        n_readings,
        n_posed,
        (unposed.count, unposed.first),
        found,
        (bad.count, bad.first),
        first_field,
    )


# The survey keeps the readings this close to each scan's maximum (the no-return margin is
# 0.2 m by default; a larger margin is checked within this band only).
_TOP_BAND_M = 1.0
# The no-return value is the largest of the scans' maxima shared (within the margin) by at
# least this percentage of the scans, and by at least three: a faulty reading far above
# the rest does not set the range limit.  In the 13 shared logs the no-return value is
# the maximum of 24-99 % of the scans; a log without one has no such cluster and keeps
# its largest reading.
_SENTINEL_SCAN_PERCENT = 5


def _no_return_value(scan_max: np.ndarray, margin: float) -> tuple[float, np.ndarray]:
    """The log's no-return value (see ``_SENTINEL_SCAN_PERCENT``) from each scan's largest
    reading, and the maxima of the scans above it (faulty readings); a log whose maxima
    form no such cluster gets its largest reading."""
    order = np.sort(scan_max)[::-1]
    need = max(3, -(-_SENTINEL_SCAN_PERCENT * order.size // 100))
    # scans whose maximum lies within the margin below each candidate, candidates down
    within = np.searchsorted(-order, -(order - margin), side="right") - np.arange(order.size)
    hits = np.flatnonzero(within >= need)
    k = int(hits[0]) if hits.size else 0
    return float(order[k]), order[:k]


def _warn_if_no_sentinel(
    path: Path, laser: str, near: _ValueCounts, total: int, best: float, margin: float
) -> None:
    """Warn when the range limit inferred from the no-return value drops most readings: a
    log with a no-return value drops its no-return beams (at most a quarter of the
    readings in the shared logs, the open campus), one without drops its longest real
    readings, all of them when the readings lie within the margin of each other."""
    dropped = near.count_between(best - margin, best)
    if total and dropped > total // 2:
        warnings.warn(
            f"{path}: {best} m is taken as the {laser} no-return value, "
            f"so readings from {best - margin:.4g} m up are dropped: {dropped} of {total}; "
            "if the log has no no-return value, pass max_range_m",
            stacklevel=3,
        )


def _warn_if_faulty(path: Path, laser: str, faulty: np.ndarray, sentinel: float) -> None:
    """Warn that the readings of the scans in ``faulty`` (their maxima) above the
    no-return value ``sentinel`` are dropped as faulty."""
    if faulty.size:
        warnings.warn(
            f"{path}: readings above the log's no-return value {sentinel} m (up to "
            f"{faulty.max():.6g} m) in {faulty.size} {laser} scan(s) are taken as faulty and "
            "dropped (pass max_range_m to keep them)",
            stacklevel=3,
        )


def read_carmen(
    path: str | Path,
    *,
    max_range_m: float | None = None,
    laser: str = "auto",
    no_return_margin_m: float = CARMEN_NO_RETURN_MARGIN_M,
    sensor_offset: PoseLike | None = None,
    bad_lines: str = "raise",
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

    A scan whose pose (or ODOM pose) is NaN or infinite, a localisation glitch, is skipped;
    a warning gives the count and the first line once the iterator is exhausted.  So is
    one whose timestamp is NaN or infinite (a logging glitch), as other readers skip a
    scan whose fields make none; a log in which no line makes a scan, those skipped so, is
    refused, naming the first.

    Other lines (``ODOM``, ``PARAM``, ``NEFF``, ``TRUEPOS``, comments, other messages) are
    skipped; so are lines whose first field is no message name (damage: a garbled name,
    bytes of another file), with a warning that counts them and names the first.

    Parameters
    ----------
    path : str or Path
        The log file.
    max_range_m : float, optional
        Readings ``>= max_range_m`` (m) are "no return". By default: for FLASER/RLASER, a
        first pass over the file finds the no-return value ``R``, the largest reading that
        is (within the margin) the largest of at least 5 % of the scans, and at least three
        (readings far above it in a few scans are faulty: dropped, with a warning; with no
        such value, the largest reading), and
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
        Width of the no-return band below the no-return value (default 0.2 m; the
        no-return readings of one log are not all identical, see
        :data:`CARMEN_NO_RETURN_MARGIN_M`). Ignored when ``max_range_m`` is given.
    sensor_offset : array_like, shape (3,), optional
        Override of the sensor pose in the robot frame. Default: zero for FLASER/RLASER
        with a pose; computed from the line for ROBOTLASER; for scans posed from ODOM, the
        ``PARAM robot_frontlaser_offset`` / ``_side_offset`` / ``_angular_offset`` values for
        the front laser (RAWLASER1 and pose-less FLASER, 0 when absent); other lasers posed
        from ODOM need it (ValueError otherwise).  Given or found, ``(x, y)`` lies within
        100 m of the robot's frame (a ROBOTLASER line farther is malformed).
    bad_lines : {"raise", "skip"}, optional
        A malformed laser line (a field that is not a number, a wrong count): an error
        naming the line (default), or ``"skip"``: the line is skipped, and a warning gives
        the count and the first line once the iterator is exhausted (a log damaged part
        way through can then be read, or a stopped replay resumed, past the damage; a
        log none of whose lines is well-formed is refused).

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
        For a malformed laser line (unless ``bad_lines="skip"``) or a malformed ODOM line
        a scan needs, with the file name and line number; for bad arguments; if the file
        has no line of the requested kind (where its first line is no CARMEN line either,
        the message says the file is no format topojax reads and lists those it reads),
        or none that makes a scan (each skipped for a pose or timestamp that is not
        finite, as malformed with ``bad_lines="skip"``, or before the first ODOM line).
    """
    p = existing_file("path", path)
    one_of("laser", laser, ("auto", *CARMEN_LASERS))
    if max_range_m is not None:
        max_range_m = real_number("max_range_m", max_range_m, allow_inf=True)
        if max_range_m <= 0:
            raise ValueError(f"max_range_m: expected a value > 0 m, received {max_range_m!r}")
    margin = real_number("no_return_margin_m", no_return_margin_m)
    if margin < 0:
        raise ValueError(f"no_return_margin_m: expected a value >= 0 m, received {margin!r}")
    offset_override = None if sensor_offset is None else mounting("sensor_offset", sensor_offset)
    skip_bad = one_of("bad_lines", bad_lines, ("raise", "skip")) == "skip"
    return _iter_carmen(p, max_range_m, laser, margin, offset_override, skip_bad)


def _iter_carmen(
    path: Path,
    max_range_m: float | None,
    laser: str,
    margin: float,
    offset_override: tuple[float, float, float] | None,
    skip_bad: bool = False,
) -> Iterator[Scan]:
    need_max = max_range_m is None and laser in ("auto", *_OLD_LASERS)
    survey = _survey_carmen(path, laser, need_max, skip_bad)
    chosen, params = survey.chosen, survey.params
    first = survey.first_field
    if not survey.found and first is not None and not _opens_a_carmen_line(first):
        opens = f"opens with {first[:24]!r}" if first.isprintable() else "is binary data"
        raise _unknown_format_error(
            path,
            f"its first line {opens}, where a CARMEN line opens with a message name "
            "(FLASER, ODOM, PARAM, ...) or # for a comment",
        )
    if chosen is None:
        kinds = ", ".join(CARMEN_LASERS)
        raise no_scan_error(path, "no laser lines found", f"a line of one of {kinds}")
    if not survey.found:
        raise no_scan_error(
            path, f"no {chosen} line found", f"at least one, the kind laser={laser!r} asks for"
        )
    old = chosen in _OLD_LASERS
    range_max_old: float | None = max_range_m
    if old and range_max_old is None:
        if not survey.n_posed and (survey.unposed[0] or survey.bad[0]):
            raise _no_scan(path, chosen, (*survey.unposed, "pose"), survey.bad)
        if not survey.scan_max.size:
            raise ValueError(f"{path}: no finite {chosen} range readings to find the max range")
        file_max, faulty = _no_return_value(survey.scan_max, margin)
        range_max_old = file_max - margin
        _warn_if_faulty(path, chosen, faulty, file_max)
        _warn_if_no_sentinel(path, chosen, survey.tops, survey.n_readings, file_max, margin)
        if range_max_old <= 0:
            raise ValueError(
                f"{path}: {chosen} no-return value {file_max} m minus no_return_margin_m "
                f"{margin} m is not positive; pass max_range_m"
            )
    odom = _OdomPoses(path, chosen, params, offset_override)
    skipped = 0
    not_finite: dict[type, list[int]] = {}  # lines of scans by what is not finite in them
    first_not_finite = ""
    made = 0
    bad = _Tally()  # malformed laser lines skipped
    garbled = _Tally()  # lines whose first field is no message name
    others: Counter = Counter()  # lines of the laser kinds not read
    half_line: tuple[int, str, Exception] | None = None  # the last line, cut off mid-way
    with _open_text(path, warn_cut=False) as fh:  # one warning of a cut, below
        for lineno, line in enumerate(fh, 1):
            tokens = line.split()
            if not tokens:
                continue
            key = tokens[0]
            try:
                if key == "ODOM":
                    odom.line = (lineno, tokens)
                    continue
                if key != chosen:
                    if key in CARMEN_LASERS:
                        others[key] += 1
                    elif not _opens_a_carmen_line(key):
                        garbled.add(lineno, repr(key[:24]))
                    continue
                if old:
                    scan = _old_laser_scan(tokens, range_max_old, offset_override, odom)
                else:
                    scan = _new_laser_scan(tokens, chosen, max_range_m, offset_override, odom)
                if scan is None:  # posed from ODOM, before the first ODOM line
                    skipped += 1
                    continue
            except _NotFinite as err:
                if not not_finite:
                    first_not_finite = f"line {lineno}: {err}"
                not_finite.setdefault(type(err), []).append(lineno)
                continue
            except _CarmenLineError as err:
                if _cut_off(line):
                    half_line = (lineno, key, err)
                    break
                if not skip_bad:
                    raise _malformed(path, lineno, key, err) from None
                bad.add(lineno, err)
                continue
            made += 1
            yield scan
        cut = gzip_cut(fh)
    _warn_of_a_cut(path, cut, half_line)
    if not made and (skipped or bad.count or not_finite):
        whats = " or ".join(kind.what for kind in not_finite)
        count = sum(map(len, not_finite.values()))
        raise _no_scan(
            path, chosen, (count, first_not_finite, whats), (bad.count, bad.first), skipped
        )
    if skipped:
        warnings.warn(
            f"{path}: skipped {skipped} {chosen} scan(s) before the first ODOM line "
            f"(they have no pose)",
            stacklevel=2,
        )
    if bad.count:
        warnings.warn(
            f"{path}: skipped {bad.count} malformed {chosen} line(s) (bad_lines='skip'), "
            f"the first on {bad.first}",
            stacklevel=2,
        )
    # a kind asked for by name: the lines of the others are not wanted
    _warn_unread(path, chosen, garbled, others if laser == "auto" else Counter())
    for kind, lines in not_finite.items():
        warnings.warn(
            f"{path}: skipped {len(lines)} {chosen} scan(s) whose {kind.what} is not finite "
            f"(NaN or infinite: {kind.why}), the first on line {lines[0]}",
            stacklevel=2,
        )


def _warn_unread(path: Path, chosen: str, garbled: _Tally, others: Counter) -> None:
    """Warn, from the reading generator, of the lines skipped as no CARMEN message
    (``garbled``) and of the lines of other laser kinds than ``chosen`` (``others``, a
    count per kind)."""
    if garbled.count:
        warnings.warn(
            f"{path}: skipped {garbled.count} line(s) that are no CARMEN message (their "
            f"first field is no message name), the first on {garbled.first}",
            stacklevel=3,
        )
    if others:
        each = ", ".join(f"{n} {kind}" for kind, n in sorted(others.items()))
        warnings.warn(
            f"{path}: read the {chosen} lines, the first laser kind in the log; it also "
            f"holds lines of other kinds, not read: {each} (pass laser=... to read "
            "another)",
            stacklevel=3,
        )


_ZERO_POSE = (0.0, 0.0, 0.0)


class _Tally:
    """Lines of a log skipped for one reason: how many, and the first (``"line N:
    why"``)."""

    def __init__(self) -> None:
        self.count = 0
        self.first = ""

    def add(self, lineno: int, err: object) -> None:
        if not self.count:
            self.first = f"line {lineno}: {err}"
        self.count += 1


def _no_scan(
    path: Path,
    chosen: str,
    not_finite: tuple[int, str, str],
    bad: tuple[int, str],
    before_odom: int = 0,
) -> ValueError:
    """The refusal of a log none of whose ``chosen`` lines makes a scan: ``not_finite``
    ``(count, first, whats)`` of them skipped for a ``whats`` (``pose``, ``timestamp``)
    not finite, the first of them ``line 3: ...``; ``bad`` ``(count, first)`` skipped as
    malformed (``bad_lines="skip"``); ``before_odom`` skipped before the first ODOM line."""
    reasons = []
    if not_finite[0]:
        reasons.append(
            f"{not_finite[0]} {chosen} line(s) skipped for a {not_finite[2]} that is not "
            f"finite (NaN or infinite), the first on {not_finite[1]}"
        )
    if bad[0]:
        reasons.append(
            f"{bad[0]} malformed {chosen} line(s) skipped (bad_lines='skip'), the first on {bad[1]}"
        )
    if before_odom:
        reasons.append(
            f"{before_odom} {chosen} line(s) skipped before the first ODOM line (they have no pose)"
        )
    return no_scan_error(
        path,
        "; ".join(reasons),
        f"at least one well-formed {chosen} line with a finite pose and timestamp",
    )


def _warn_of_a_cut(
    path: Path, gzip_cut: bool, half_line: tuple[int, str, Exception] | None
) -> None:
    """One warning for a log that ends cut off: its compressed data (``gzip_cut``), its
    last line (``half_line``: line number, key and fault), or both."""
    if gzip_cut:
        skipped = ""
        if half_line is not None:
            lineno, key, _ = half_line
            skipped = f", where line {lineno}, a {key} line, ends mid-way and is skipped"
        text = f"{path}: the gzip-compressed data is cut off; read up to the cut{skipped}"
        warnings.warn(text, RuntimeWarning, stacklevel=3)
    elif half_line is not None:
        lineno, key, err = half_line
        warnings.warn(
            f"{path}:{lineno}: the log ends in the middle of a {key} line (no line end; "
            f"{err}); that line is skipped",
            stacklevel=3,
        )


def _malformed(path: Path, lineno: int, key: str, err: Exception) -> ValueError:
    return ValueError(
        f"{path}:{lineno}: malformed {key} line: {err} (bad_lines='skip' skips such lines "
        "with a warning)"
    )


class _OdomPoses:
    """Robot pose and sensor offset for the scans of a log whose laser lines carry no
    pose: the latest ``ODOM`` line, and the front laser's ``PARAM`` mounting."""

    def __init__(
        self,
        path: Path,
        chosen: str,
        params: dict[str, str],
        offset_override: tuple[float, float, float] | None,
    ) -> None:
        self.path = path
        self.chosen = chosen
        self.params = params
        self.offset_override = offset_override
        # The latest ODOM line, parsed only when a scan needs it: (line number, tokens).
        self.line: tuple[int, list[str]] | None = None

    def offset(self) -> tuple[float, float, float]:
        """The sensor pose in the robot frame."""
        if self.offset_override is not None:
            return self.offset_override
        if self.chosen in ("FLASER", "RAWLASER1"):
            vals = []
            for name in ("offset", "side_offset", "angular_offset"):
                txt = self.params.get(f"robot_frontlaser_{name}", "0")
                try:
                    vals.append(float(txt))
                except ValueError:
                    raise ValueError(
                        f"{self.path}: PARAM robot_frontlaser_{name}: expected a number, "
                        f"received {txt!r}"
                    ) from None
            return mounting("PARAM robot_frontlaser_*", vals)
        raise ValueError(
            f"{self.path}: {self.chosen} lines carry no pose and the log does not say where "
            f"this laser is mounted; pass sensor_offset=(x_m, y_m, yaw_rad)"
        )

    def pose(self) -> tuple[float, float, float]:
        """The robot pose of the latest ODOM line."""
        assert self.line is not None
        num, toks = self.line
        try:
            _need(toks, 1, 3, "ODOM x y theta", "ODOM")
            xyz = _floats(toks[1:4], "ODOM pose")
        except _CarmenLineError as err:
            raise ValueError(f"{self.path}:{num}: malformed ODOM line: {err}") from None
        if not np.all(np.isfinite(xyz)):
            raise _PoseNotFinite(f"ODOM pose at line {num} is not finite: {xyz.tolist()}")
        return (float(xyz[0]), float(xyz[1]), float(xyz[2]))


def _old_laser_scan(
    tokens: list[str],
    range_max: float | None,
    offset_override: tuple[float, float, float] | None,
    odom: _OdomPoses,
) -> Scan | None:
    """The scan of a FLASER/RLASER line; None for a pose-less line before the first ODOM."""
    ranges, pose, stamp = _parse_old_laser(tokens)
    n = ranges.shape[0]
    angle_min, inc = -math.pi / 2.0, _carmen_beam_increment(n)
    if pose is None:
        if odom.line is None:
            return None
        robot, offset = odom.pose(), odom.offset()
    else:
        robot = (float(pose[0]), float(pose[1]), float(pose[2]))
        offset = _ZERO_POSE if offset_override is None else offset_override
    return _line_scan(ranges, angle_min, inc, range_max, robot, offset, stamp)


def _new_laser_scan(
    tokens: list[str],
    chosen: str,
    max_range_m: float | None,
    offset_override: tuple[float, float, float] | None,
    odom: _OdomPoses,
) -> Scan | None:
    """The scan of a ROBOTLASERk/RAWLASERk line; None for a RAWLASER line before the first
    ODOM."""
    cfg, ranges, k = _parse_new_laser_head(tokens)
    angle_min, inc = float(cfg[0]), float(cfg[2])
    rmax = float(cfg[3]) if max_range_m is None else max_range_m
    if chosen in _ROBOT_LASERS:
        _need(tokens, k, 12, "laser pose, robot pose, 5 fields and timestamp", "the remissions")
        nums = _floats(tokens[k : k + 12], "poses / timestamp")
        if not np.all(np.isfinite(nums[:6])):
            raise _PoseNotFinite(f"poses are not finite: {nums[:6].tolist()}")
        laser_pose = (float(nums[0]), float(nums[1]), float(nums[2]))
        robot = (float(nums[3]), float(nums[4]), float(nums[5]))
        offset = _relative(robot, laser_pose) if offset_override is None else offset_override
        stamp = float(nums[11])
    else:
        _need(tokens, k, 1, "the timestamp", "the remissions")
        stamp = float(_floats(tokens[k : k + 1], "timestamp")[0])
        if odom.line is None:
            return None
        robot, offset = odom.pose(), odom.offset()
    return _line_scan(ranges, angle_min, inc, rmax, robot, offset, stamp)


def _line_scan(ranges, angle_min, inc, rmax, robot, offset, stamp) -> Scan:
    """``Scan(...)`` with its complaints as :class:`_CarmenLineError` (they are the line's);
    a timestamp that is not finite is :class:`_StampNotFinite`."""
    if not math.isfinite(stamp):
        raise _StampNotFinite(f"timestamp: expected a finite number, received {stamp!r}")
    try:
        return Scan(ranges, angle_min, inc, 0.0, rmax, robot, offset, stamp)
    except (TypeError, ValueError) as err:
        raise _CarmenLineError(str(err)) from None
