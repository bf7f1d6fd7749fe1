"""Reader for Octave ``save -text`` files holding a ``laser`` struct (robot-mapping course
data)."""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from .._validate import existing_file, text_or_none
from ._text import _cut_off, _open_text, gzip_cut
from .scan import Scan, _SkippedScans, no_scan_error


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
            raise self.error(f"'# {key}:' expected an integer, received {txt!r}") from None
        if v < 0:
            raise self.error(f"'# {key}:' expected a value >= 0, received {v}")
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
                f"{self.path}:{self.i}: expected {expected} numbers on this line, "
                f"received {len(line)}"
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
    """The variables of an Octave text file; a file cut off while written (its last line
    unfinished, or its compressed data cut) that does not parse is refused as cut off."""
    with _open_text(path, warn_cut=False) as fh:
        text = fh.read()
        packed_cut = gzip_cut(fh)
    lines = text.splitlines()
    try:
        out = _OctaveReader(lines, path).variables()
    except ValueError as err:
        if not (packed_cut or (text and _cut_off(text))):
            raise
        how = "its compressed data end there" if packed_cut else "its last line has no line end"
        raise ValueError(
            f"{path}: the file is cut off at line {len(lines)} ({how}); an Octave file "
            f"stores each field of all its scans together, so no scan can be read ({err})"
        ) from None
    if packed_cut:
        warnings.warn(
            f"{path}: the gzip-compressed data is cut off; read up to the cut",
            RuntimeWarning,
            stacklevel=4,
        )
    return out


def read_octave_laser(path: str | Path, *, variable: str | None = None) -> Iterator[Scan]:
    """Read scans from an Octave text file holding a ``laser`` struct (robot-mapping course).

    The struct (array) has the fields ``start_angle``, ``angular_resolution``,
    ``maximum_range``, ``ranges`` (1 x N), ``pose`` ([x y theta], robot pose in the map
    frame), and optionally ``laser_offset`` (3 values, laser pose in the robot frame; zero
    when absent) and ``timestamp``. In a struct array saved by Octave each field is a cell
    with one element per scan. Readings ``>= maximum_range`` are "no return" (the file stores
    81.91 for no return with ``maximum_range = 80``).

    The format stores each field for all scans together, so the whole file is parsed before
    the first scan is yielded.  A scan whose pose is NaN or infinite (a localisation
    glitch) is skipped; a warning gives the count once the iterator is exhausted.  So is
    one whose fields make no :class:`Scan` (an ``angular_resolution`` of 0 or NaN, a
    ``maximum_range`` not above 0, a timestamp that is not finite: a sensor glitch), as
    :func:`read_bag` skips such messages; its warning names the first and why.

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
        Missing file; syntax errors (with line number); missing fields or inconsistent
        cell lengths; no element that makes a scan (every pose not finite, say).  An
        element whose fields make no scan (a sensor glitch) among others that do is
        skipped with a warning.
    """
    p = existing_file("path", path)
    return _iter_octave(p, text_or_none("variable", variable))


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
            raise ValueError(
                f"{path}: {variable}({i + 1}).{name}: expected a scalar, received {v!r}"
            )
        return float(v.reshape(()))

    def triple(name: str, i: int) -> np.ndarray:
        try:
            v = np.asarray(columns[name][i], dtype=np.float64).ravel()
        except (TypeError, ValueError) as err:
            raise ValueError(f"{path}: {variable}({i + 1}).{name}: {err}") from None
        if v.size != 3:
            raise ValueError(
                f"{path}: {variable}({i + 1}).{name}: expected 3 values, received shape "
                f"{np.shape(columns[name][i])}"
            )
        return v

    not_finite: list[int] = []  # scans whose pose is NaN or infinite (from 1)
    unusable = _SkippedScans()
    for i in range(count):
        ranges = np.asarray(columns["ranges"][i], dtype=np.float64)
        if ranges.ndim == 2 and 1 in ranges.shape:
            ranges = ranges.ravel()
        pose = triple("pose", i)
        if not np.isfinite(pose).all():  # a localisation glitch: the scan is skipped
            not_finite.append(i + 1)
            continue
        offset = triple("laser_offset", i) if "laser_offset" in columns else np.zeros(3)
        stamp = scalar("timestamp", i) if "timestamp" in columns else None
        scan = unusable.scan(
            f"{variable}({i + 1})",
            ranges,
            scalar("start_angle", i),
            scalar("angular_resolution", i),
            0.0,
            scalar("maximum_range", i),
            pose,
            offset,
            stamp,
        )
        if scan is not None:
            yield scan
    if not_finite and not unusable.made and not unusable.count:
        raise no_scan_error(
            path,
            f"{len(not_finite)} element(s) of {variable} skipped for a pose that is not "
            f"finite (NaN or infinite), the first {variable}({not_finite[0]})",
            f"at least one element of {variable} with a finite pose",
        )
    if not_finite:
        warnings.warn(
            f"{path}: skipped {len(not_finite)} scan(s) whose pose is not finite (NaN or "
            f"infinite: a localisation glitch), the first {variable}({not_finite[0]})",
            stacklevel=2,
        )
    unusable.finish(path, f"element(s) of {variable}", others=len(not_finite))
