"""Argument checks shared by the whole package.

Each check returns the value in its canonical Python type, or raises a ``TypeError`` for a
wrong type / a ``ValueError`` for a wrong value (:func:`existing_file`: also
``FileNotFoundError``) whose message reads ``"<name>: expected <what>, received <what was
given>"``.
NumPy scalars are accepted wherever the matching Python type is, and a 0-d array (NumPy's,
JAX's) wherever its item is: a 0-d numeric array where a number is, a 0-d bool array where
a bool is.  A bool (of any of these forms) is never a number, a number is never a bool
(a flag refuses 1 and 0; :func:`binary_flag` alone takes them), and a float (whole or not)
is never an int.  JAX's bfloat16 is a float wherever real numbers are, and ``ml_dtypes``'
int4 an integer wherever integers are (:func:`real_values`).
"""

from __future__ import annotations

import math
import numbers
import os
import reprlib
from collections.abc import Iterable, Mapping, Set
from pathlib import Path
from typing import Any

import numpy as np

from ._filekind import missing_file_error, the_non_file

__all__ = [
    "binary_flag",
    "binary_image",
    "existing_file",
    "finite_numbers",
    "finite_pair",
    "finite_positive",
    "flag",
    "float32_finite",
    "instance_of",
    "instance_or_default",
    "int_at_least",
    "integer",
    "is_real_number",
    "kernel_tile_px",
    "kernel_tiles_per_call",
    "masked_entries",
    "metres",
    "metres_per_pixel",
    "names_subset",
    "nonnegative_metres",
    "nonnegative_quantity",
    "nx_graph",
    "occupancy_thresholds",
    "one_of",
    "path_like",
    "pixel_rows",
    "plain_int_pair",
    "point_rows",
    "plain_length_m",
    "pose",
    "positive_int",
    "positive_metres",
    "quantity",
    "real_array",
    "real_number",
    "real_values",
    "robot_radius",
    "text_or_none",
    "unmasked",
    "xy_points",
]


def finite_positive(name: str, value: object) -> float:
    """:func:`quantity` without a unit, ``> 0``."""
    return quantity(name, value, unit="", allow_zero=False)


def _item(value: Any) -> Any:
    """The item inside ``value`` if it is a 0-d array (NumPy's or any other with
    ``__array__`` such as a JAX scalar; float32 for a bfloat16, :func:`real_values`),
    else ``value`` itself (a masked one too: no number, where ``np.asarray`` would give
    the value under the mask)."""
    if masked_entries(value) is not None:
        return value
    if (
        not isinstance(value, (numbers.Number, np.bool_))
        and hasattr(value, "__array__")
        and getattr(value, "shape", None) == ()
    ):
        return real_values(np.asarray(value))[()]
    return value


def _number(value: Any, kind: type) -> Any:
    """``value``, or the item inside it if it is a 0-d array (:func:`_item`), if that is a
    ``kind`` (``numbers.Integral``, ``numbers.Real``) and not a bool; None otherwise."""
    value = _item(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, kind):
        return None
    return value


def _boolean(value: Any) -> bool | None:
    """``value`` as a bool if it is one: a Python or NumPy bool, or a 0-d array of one
    (:func:`_item`); None for anything else, numbers included. The one test behind
    :func:`flag` and :func:`binary_flag`."""
    if type(value) is bool:
        return value
    value = _item(value)
    return bool(value) if isinstance(value, (bool, np.bool_)) else None


def _integral(value: Any) -> int | None:
    """``value`` as an int if it is an integer: a Python or NumPy int, not a bool, or a
    0-d array of one; None for anything else, floats with a whole value included. The one
    test behind every int check here."""
    if type(value) is int:
        return value
    number = _number(value, numbers.Integral)
    return None if number is None else int(number)


def integer(name: str, value: object) -> int:
    """``value`` as an int after checking it is an integer (see :func:`_integral`)."""
    number = _integral(value)
    if number is None:
        raise TypeError(f"{name}: expected an int, received {type(value).__name__} {value!r}")
    return number


def int_at_least(name: str, value: Any, minimum: int) -> int:
    """``value`` as an int after checking it is an integer (see :func:`_integral`), a
    ``TypeError`` otherwise, and ``>= minimum``, a ``ValueError`` otherwise."""
    number = _integral(value)
    if number is None:
        raise TypeError(
            f"{name}: expected an int >= {minimum}, received {type(value).__name__} {value!r}"
        )
    if number < minimum:
        raise ValueError(f"{name}: expected an int >= {minimum}, received {number}")
    return number


def _real(value: Any) -> Any:
    """``value`` if it is a real number: a Python or NumPy int or float, not a bool (the
    number inside a 0-d array, NumPy's or any other with ``__array__`` such as a JAX
    scalar); None for anything else. The one test behind :func:`is_real_number`,
    :func:`real_number` and :func:`quantity`."""
    if type(value) is float or type(value) is int:
        return value
    return _number(value, numbers.Real)


def real_number(name: str, value: Any, *, allow_inf: bool = False) -> float:
    """``value`` as a float after checking it is a real number (see :func:`is_real_number`),
    not NaN, and finite unless ``allow_inf``; a ``TypeError`` for a non-number, a
    ``ValueError`` for NaN or an infinity not allowed."""
    number = _real(value)
    if number is None:
        raise TypeError(
            f"{name}: expected a real number, received {type(value).__name__} {value!r}"
        )
    out = float(number)
    if math.isnan(out) or (math.isinf(out) and not allow_inf):
        expected = "a number, not NaN" if allow_inf else "a finite number"
        raise ValueError(f"{name}: expected {expected}, received {out!r}")
    return out


def real_values(arr: np.ndarray) -> np.ndarray:
    """``arr`` itself, or in the NumPy dtype that holds its values exactly if its dtype is
    an ``ml_dtypes`` one that NumPy knows as kind ``"V"``: float32 for a float (JAX's
    ``bfloat16``, the float8s), int8 / uint8 for a signed / unsigned integer (``int4``,
    ``uint4``); the checks of real numbers and integers (dtype kind ``"iuf"``) then take
    it, and arithmetic on it runs in float32 or wider, not in the narrow dtype."""
    if arr.dtype.kind != "V" or arr.dtype.fields is not None:
        return arr
    import ml_dtypes  # a dependency of JAX

    try:
        ml_dtypes.finfo(arr.dtype)
    except (TypeError, ValueError):  # not a float: an integer, a plain void
        pass
    else:
        return arr.astype(np.float32)
    try:
        signed = ml_dtypes.iinfo(arr.dtype).min < 0
    except (TypeError, ValueError):  # a plain void
        return arr
    return arr.astype(np.int8 if signed else np.uint8)


def real_array(name: str, value: Any, *, finite: bool = False) -> np.ndarray:
    """``value`` as a float64 array (any shape; 0-d for a number) after checking it holds
    real numbers: a ``TypeError`` naming ``name`` for None, strings, bools or objects
    (NumPy would turn None into NaN or fail on a string without naming the argument); a
    ``ValueError`` for NaN or an infinity when ``finite``; a masked array is refused
    (:func:`unmasked`)."""
    arr = real_values(np.asarray(unmasked(name, value)))
    if arr.dtype.kind not in "iuf":
        raise TypeError(
            f"{name}: expected a number or an array of real numbers, received "
            f"{type(value).__name__} of dtype {arr.dtype}"
        )
    arr = arr.astype(np.float64, copy=False)
    if finite and not np.isfinite(arr).all():
        bad = arr[~np.isfinite(arr)].flat[0]
        raise ValueError(f"{name}: expected finite numbers, received {float(bad)!r} among them")
    return arr


def flag(name: str, value: object) -> bool:
    """``value`` as a bool after checking it is one (see :func:`_boolean`): a Python or
    NumPy bool or a 0-d array of one, not a number (1, 0)."""
    out = _boolean(value)
    if out is None:
        raise TypeError(f"{name}: expected a bool, received {type(value).__name__} {value!r}")
    return out


#: The largest finite float32 (about 3.4e38): a larger number becomes inf in a float32
#: kernel.
MAX_FLOAT32 = float(np.finfo(np.float32).max)


def float32_finite(name: str, value: float) -> float:
    """``value``, a finite float already checked, after checking it stays finite in
    float32 (at most :data:`MAX_FLOAT32` from 0), for a number a float32 kernel takes; a
    ``ValueError`` otherwise."""
    if abs(value) > MAX_FLOAT32:
        raise ValueError(
            f"{name}: expected a number at most {MAX_FLOAT32:g} in magnitude (float32's "
            f"largest finite value: the kernels compute in float32), received {value!r}"
        )
    return value


def quantity(name: str, value: object, *, unit: str, allow_zero: bool) -> float:
    """``value`` as a float after checking it is a finite number (of ``unit``, e.g.
    ``"metres"``, ``"m2"``; ``""`` for a ratio), ``>= 0`` or ``> 0``; a TypeError for a
    non-number (see :func:`is_real_number`), a ValueError otherwise, naming ``name``, what
    was expected and what was received."""
    bound = ">= 0" if allow_zero else "> 0"
    of = f" of {unit}" if unit else ""
    number = _real(value)
    if number is None:
        raise TypeError(
            f"{name}: expected a real number{of} {bound}, received {type(value).__name__} {value!r}"
        )
    out = float(number)
    if not math.isfinite(out) or out < 0 or (out == 0 and not allow_zero):
        raise ValueError(f"{name}: expected a finite number{of} {bound}, received {out!r}")
    return out


def metres(name: str, value: object, *, allow_zero: bool) -> float:
    """:func:`quantity` in metres."""
    return quantity(name, value, unit="metres", allow_zero=allow_zero)


def nonnegative_metres(name: str, value: object) -> float:
    """:func:`metres` ``>= 0`` (the pruning thresholds of :class:`GraphConfig` and
    :func:`topojax.prune_graph`)."""
    return metres(name, value, allow_zero=True)


#: The largest robot radius accepted (metres): a larger one is a unit error (millimetres
#: given as metres), and its pixel counts overflow the float32 clearance.
MAX_ROBOT_RADIUS_M = 1000.0


def robot_radius(name: str, value: object, *, allow_zero: bool = True) -> float:
    """:func:`metres` from 0 (excluded unless ``allow_zero``) to
    :data:`MAX_ROBOT_RADIUS_M` (a round robot's radius)."""
    radius = metres(name, value, allow_zero=allow_zero)
    if radius > MAX_ROBOT_RADIUS_M:
        raise ValueError(
            f"{name}: expected a robot radius of at most {MAX_ROBOT_RADIUS_M:g} m, received "
            f"{radius!r} m"
        )
    return radius


def positive_metres(name: str, value: object) -> float:
    """:func:`metres` ``> 0`` (the tolerances of the Nav2 export and of
    :meth:`topojax.Route.waypoints`, the batch's ``sigma_m``)."""
    return metres(name, value, allow_zero=False)


def nonnegative_quantity(name: str, value: Any, unit: str) -> float:
    """:func:`quantity` of ``unit``, ``>= 0``."""
    return quantity(name, value, unit=unit, allow_zero=True)


def is_real_number(value: Any) -> bool:
    """True for a real number: a Python or NumPy int or float (NaN and infinities included)
    or a 0-d array of one; False for anything else, bools included."""
    return _real(value) is not None


#: The coarsest map resolution (metres per pixel): a map's extent and its square stay
#: finite in float64 far beyond any map's size.
MAX_RESOLUTION_M = 1e4


#: The finest map resolution (metres per pixel, a micrometre): options in metres (a
#: robot's radius, a kernel's sigma) stay a pixel count the kernels can hold.
MIN_RESOLUTION_M = 1e-6


def metres_per_pixel(name: str, value: Any) -> float:
    """:func:`quantity` in metres per pixel, from :data:`MIN_RESOLUTION_M` to
    :data:`MAX_RESOLUTION_M` (a map resolution)."""
    res = quantity(name, value, unit="metres per pixel", allow_zero=False)
    if not MIN_RESOLUTION_M <= res <= MAX_RESOLUTION_M:
        raise ValueError(
            f"{name}: expected {MIN_RESOLUTION_M:g} to {MAX_RESOLUTION_M:g} metres per "
            f"pixel, received {res!r}"
        )
    return res


#: The tile sides (pixels) the JAX kernels run on, smallest and largest.
MIN_KERNEL_TILE_PX = 8
MAX_KERNEL_TILE_PX = 4096

#: The most tile pixels one kernel call may carry (``tiles_per_call * tile_px**2``; e.g.
#: 4096 tiles of 256 px): the call's stacked inputs and outputs take about 10 bytes per
#: pixel, so a larger bucket asks for tens of GB before the first kernel runs.
MAX_CALL_PX = 2**28


def kernel_tile_px(name: str, value: Any) -> int:
    """``value`` as an int after checking it is an integer from
    :data:`MIN_KERNEL_TILE_PX` to :data:`MAX_KERNEL_TILE_PX` (a kernel tile side in
    pixels); a ``TypeError`` for a non-integer, a ``ValueError`` otherwise."""
    expected = f"{name}: expected an int in [{MIN_KERNEL_TILE_PX}, {MAX_KERNEL_TILE_PX}]"
    number = _integral(value)
    if number is None:
        raise TypeError(f"{expected}, received {type(value).__name__} {value!r}")
    if not MIN_KERNEL_TILE_PX <= number <= MAX_KERNEL_TILE_PX:
        raise ValueError(f"{expected}, received {number}")
    return number


def kernel_tiles_per_call(name: str, value: Any, tile_px: int) -> int:
    """``value`` as an int after checking it is an integer >= 1 (:func:`int_at_least`)
    whose kernel calls of ``tile_px``-pixel tiles carry at most :data:`MAX_CALL_PX`
    pixels; a ``ValueError`` naming the largest allowed count otherwise."""
    n = int_at_least(name, value, 1)
    most = max(1, MAX_CALL_PX // (tile_px * tile_px))
    if n > most:
        raise ValueError(
            f"{name}: expected an int from 1 to {most} (at most {MAX_CALL_PX} pixels per "
            f"kernel call of {tile_px} x {tile_px} px tiles), received {n}"
        )
    return n


#: The largest map origin coordinate (metres): beyond it a float64 world coordinate no
#: longer resolves a millimetre.
MAX_ORIGIN_M = 1e9

#: The largest yaw (radians) of a pose: beyond it a float64 angle no longer resolves a
#: microradian, and at 1e16 not even a turn (a garbled field, not a heading).
MAX_YAW_RAD = 1e9


def masked_entries(value: Any) -> np.ndarray | None:
    """Which entries of ``value`` are masked (a bool array of its shape) if it is a NumPy
    masked array with a masked entry; None for anything else (``np.asarray`` would drop
    the mask and keep the values under it)."""
    if not isinstance(value, np.ma.MaskedArray):
        return None
    mask = np.ma.getmaskarray(value)
    return mask if mask.any() else None


def unmasked(name: str, value: Any, *, fill: Any = None) -> Any:
    """``value`` itself unless it is a NumPy masked array: then its data if no entry is
    masked, else a copy with the masked entries set to ``fill`` (integers and bools as
    float64 for a NaN ``fill``); without ``fill`` (where a masked entry has no meaning) a
    ``TypeError`` naming ``name`` that says to call ``.filled``."""
    if not isinstance(value, np.ma.MaskedArray):
        return value
    data = np.asarray(value.data)
    mask = masked_entries(value)
    if mask is None:
        return data
    if fill is None:
        raise TypeError(
            f"{name}: expected an array without masked entries, received a masked array "
            f"with {int(mask.sum())} of {mask.size} entries masked (the values under the "
            "mask would be used); call .filled(value) with the value they stand for"
        )
    if data.dtype.kind in "biu" and isinstance(fill, float) and math.isnan(fill):
        data = data.astype(np.float64)
    out = np.array(data, copy=True)
    out[mask] = fill
    return out


def _real_items(value: Any) -> list[float] | None:
    """The items of ``value`` as floats if it is an iterable of real numbers (see
    :func:`is_real_number`; not a str or bytes, not a 0-d array, not a set or mapping,
    whose order says nothing about which item is which), else None. NumPy and JAX
    arrays are iterated along their first axis, so a 2-D one holds arrays, not numbers."""
    if isinstance(value, (str, bytes, Set, Mapping)):  # a set's order is its hashes'
        return None
    if (
        not isinstance(value, np.ndarray)
        and hasattr(value, "__array__")
        and hasattr(value, "shape")
    ):
        value = np.asarray(value)  # a JAX array: iterate NumPy numbers
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return None
    try:
        items = list(value)
    except TypeError:
        return None
    reals = [_real(v) for v in items]
    if any(n is None for n in reals):
        return None
    return [float(n) for n in reals]


def _finite_items(value: Any, n: int, expected: str) -> list[float]:
    """The ``n`` items of ``value`` as floats (see :func:`_real_items`): a ``TypeError``
    unless it is an iterable of numbers, a ``ValueError`` for another count or a
    non-finite item, each message ``expected`` followed by what was received."""
    mask = masked_entries(value)
    if mask is not None:
        raise TypeError(
            f"{expected}, received a masked array with {int(mask.sum())} of {mask.size} "
            "entries masked; call .filled(value) with the value they stand for"
        )
    items = _real_items(value)
    if items is None:
        raise TypeError(f"{expected}, received {type(value).__name__} {value!r}")
    if len(items) != n or not all(math.isfinite(v) for v in items):
        raise ValueError(f"{expected}, received {value!r}")
    return items


def pose(name: str, value: Any, *, bounded: bool = True) -> tuple[float, float, float]:
    """``value`` as ``(x_m, y_m, yaw_rad)`` floats after checking it is a sequence of 3
    finite numbers (a map origin), ``x`` and ``y`` at most :data:`MAX_ORIGIN_M` from 0
    unless not ``bounded`` (a robot or sensor pose), ``yaw`` at most
    :data:`MAX_YAW_RAD`; a ``TypeError`` unless it is an iterable of numbers (bools are
    not), a ``ValueError`` otherwise."""
    expected = f"{name}: expected a sequence of 3 finite numbers (x_m, y_m, yaw_rad)"
    x, y, yaw = _finite_items(value, 3, expected)
    if abs(yaw) > MAX_YAW_RAD:
        raise ValueError(
            f"{expected} with yaw within {MAX_YAW_RAD:g} rad of 0 (where a float64 angle "
            f"still resolves a microradian), received {value!r}"
        )
    if bounded and max(abs(x), abs(y)) > MAX_ORIGIN_M:
        raise ValueError(
            f"{expected} with x and y within {MAX_ORIGIN_M:g} m of 0 (where a world "
            f"coordinate still resolves a millimetre), received {value!r}"
        )
    return (x, y, yaw)


def threshold(name: str, value: Any) -> float:
    """``value`` as a float after checking it is a number (a ``TypeError`` otherwise) from
    0 to 1 (a ``ValueError`` otherwise): an occupancy threshold, alone."""
    number = _real(value)
    if number is None:
        raise TypeError(
            f"{name}: expected a number from 0 to 1, received {type(value).__name__} {value!r}"
        )
    if not 0.0 <= float(number) <= 1.0:  # also NaN
        raise ValueError(f"{name}: expected a number from 0 to 1, received {value!r}")
    return float(number)


def occupancy_thresholds(
    occupied_thresh: Any, free_thresh: Any, *, where: str = ""
) -> tuple[float, float]:
    """``(occupied_thresh, free_thresh)`` as floats after checking they are numbers (a
    ``TypeError`` otherwise) with ``0 <= free_thresh < occupied_thresh <= 1`` (a
    ``ValueError`` otherwise); the errors start with ``where: `` when ``where`` is given."""
    prefix = f"{where}: " if where else ""
    checked = []
    for name, v in (("occupied_thresh", occupied_thresh), ("free_thresh", free_thresh)):
        number = _real(v)
        if number is None:
            raise TypeError(
                f"{prefix}{name}: expected a finite number in [0, 1], received "
                f"{type(v).__name__} {v!r}"
            )
        if not math.isfinite(float(number)):
            raise ValueError(f"{prefix}{name}: expected a finite number in [0, 1], received {v!r}")
        checked.append(float(number))
    occ, free = checked
    if not (0.0 <= free < occ <= 1.0):
        raise ValueError(
            f"{prefix}free_thresh, occupied_thresh: expected 0 <= free_thresh < "
            f"occupied_thresh <= 1, received free_thresh={free!r}, occupied_thresh={occ!r}"
        )
    return occ, free


def names_subset(name: str, value: Any, choices: tuple[str, ...]) -> tuple[str, ...]:
    """``value``, an iterable of strings among ``choices`` (not a bare string), as a tuple
    in the order of ``choices`` without repeats."""
    expected = f"{name}: expected an iterable of names from {choices}, received {value!r}"
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        raise TypeError(expected)
    try:
        items = list(value)
    except TypeError:  # iterable by its type but not this one: a 0-d array
        raise TypeError(expected) from None
    unknown = [v for v in items if not isinstance(v, str) or v not in choices]
    if unknown:
        raise ValueError(f"{name}: expected names from {choices}, received {unknown[0]!r}")
    return tuple(c for c in choices if c in items)


def binary_flag(name: str, value: Any) -> bool:
    """``value`` as a bool after checking it is a bool (see :func:`flag`) or the integer
    0 or 1 (Python or NumPy, or a 0-d array of one), as ``map_server`` YAML files write
    ``negate``: a ``TypeError`` for another type (a float, a str), a ``ValueError`` for
    another integer."""
    out = _boolean(value)
    if out is not None:
        return out
    expected = f"{name}: expected a bool or 0/1, received"
    number = _integral(value)
    if number is None:
        raise TypeError(f"{expected} {type(value).__name__} {value!r}")
    if number not in (0, 1):
        raise ValueError(f"{expected} {value!r}")
    return bool(number)


def positive_int(name: str, value: Any) -> int:
    """:func:`int_at_least` 1."""
    return int_at_least(name, value, 1)


def one_of(name: str, value: Any, choices: Any) -> Any:
    """``value`` after checking it is among ``choices`` (shown as given in the error)."""
    try:
        known = not isinstance(value, np.ndarray) and value in choices
    except TypeError:  # an unhashable value against a set or dict of choices
        known = False
    if not known:
        raise ValueError(f"{name}: expected one of {choices}, received {value!r}")
    return value


def finite_pair(name: str, value: Any, what: str) -> np.ndarray:
    """``value`` as a float64 array of shape (2,) after checking it holds two finite
    numbers: a ``TypeError`` unless it is an iterable of numbers (bools are not), a
    ``ValueError`` for another count or a non-finite one; ``what`` describes them in the
    error (e.g. ``"(x, y) in metres"``)."""
    expected = f"{name}: expected two finite numbers {what}"
    return np.array(_finite_items(value, 2, expected), dtype=np.float64)


def finite_numbers(name: str, value: Any, n: int, what: str) -> tuple[float, ...]:
    """``value`` as a tuple of ``n`` floats after checking it holds ``n`` finite numbers:
    a ``TypeError`` unless it is an iterable of numbers (bools are not), a ``ValueError``
    for another count or a non-finite one; ``what`` describes them in the error (e.g.
    ``"(row0, row1, col0, col1) in pixels"``)."""
    return tuple(_finite_items(value, n, f"{name}: expected {n} finite numbers {what}"))


def path_like(name: str, value: Any) -> Path:
    """``value`` as a :class:`~pathlib.Path` after checking it is a ``str`` or
    ``os.PathLike``, not empty (``Path("")`` is the current folder) and without a NUL; a
    ``TypeError`` or ``ValueError`` naming ``name`` otherwise."""
    if not isinstance(value, str | os.PathLike):
        raise TypeError(
            f"{name}: expected a path (str or os.PathLike), received {type(value).__name__}"
        )
    if not (text := os.fsdecode(value)) or "\0" in text:  # no file is named with a NUL
        what = "one with a NUL character" if text else "an empty one"
        raise ValueError(f"{name}: expected a path, received {what} ({value!r})")
    return Path(value)


def text_or_none(name: str, value: Any, *, paths: bool = False) -> str | None:
    """``value`` (None stays None) after checking it is a ``str`` or, with ``paths``, an
    ``os.PathLike`` (returned as its ``str``, not normalised as a :class:`~pathlib.Path`:
    where a map came from); a ``TypeError`` naming ``name`` otherwise (``str()`` and
    matplotlib would take any object: a title or a source of ``True``)."""
    if value is None or isinstance(value, str):
        return value
    if paths and isinstance(value, os.PathLike):
        return str(value)
    what = "a str, an os.PathLike or None" if paths else "a str or None"
    raise TypeError(f"{name}: expected {what}, received {type(value).__name__} {value!r}")


def no_file_above(name: str, path: Path) -> Path:
    """``path`` after checking that no folder above it is an existing file (it could
    not be written; ``mkdir`` would only say "File exists"); a ``NotADirectoryError``
    naming ``name`` otherwise."""
    for parent in path.parents:
        if parent.exists() and not parent.is_dir():
            raise NotADirectoryError(f"{name}: {parent} in {str(path)!r} is a file, not a folder")
    return path


def existing_file(name: str, path: Any) -> Path:
    """``path`` as a :class:`~pathlib.Path` after checking it is one (:func:`path_like`,
    a ``TypeError`` or, for an empty one, a ``ValueError`` otherwise) naming an existing
    regular file: a ``FileNotFoundError`` if nothing is there, a ``ValueError`` naming
    what is there instead (a folder, a FIFO, ...)."""
    p = path_like(name, path)
    if not p.exists():
        raise missing_file_error(name, p)
    if not p.is_file():
        raise ValueError(f"{name}: expected a file, received {the_non_file(p)} {p}")
    return p


def _a(noun: str) -> str:
    """``noun`` after its indefinite article."""
    return f"{'an' if noun[:1].lower() in 'aeiou' else 'a'} {noun}"


def instance_of(name: str, value: Any, kind: type | tuple[type, ...], what: str | None = None):
    """``value`` after checking it is a ``kind`` (a class or a tuple of classes); otherwise a
    ``TypeError`` naming ``name``, ``what`` was expected (default: the class name, e.g.
    ``"RoomSegmentation"``) and the type received, instead of an ``AttributeError`` deep
    inside."""
    if not isinstance(value, kind):
        if what is None:
            kinds = kind if isinstance(kind, tuple) else (kind,)
            what = " or ".join(k.__name__ for k in kinds)
        raise TypeError(f"{name}: expected {_a(what)}, received {type(value).__name__}")
    return value


def instance_or_default(name: str, value: Any, kind: type) -> Any:
    """``value``, or ``kind()`` for None, after checking it is a ``kind``
    (:func:`instance_of`)."""
    return kind() if value is None else instance_of(name, value, kind)


def nx_graph(name: str, graph: Any, *, undirected: bool = True, multigraph: bool = False):
    """``graph`` after checking it is a networkx graph: a ``TypeError`` naming ``name``
    otherwise. A directed graph where an ``undirected`` one is needed is a wrong type too,
    and so is a simple graph where a ``multigraph`` (an undirected ``nx.MultiGraph``, as
    :func:`topojax.skeleton_to_graph` builds) is needed."""
    import networkx as nx

    if multigraph:
        ok = isinstance(graph, nx.MultiGraph) and not graph.is_directed()
        what = "undirected networkx.MultiGraph"
    else:
        ok = isinstance(graph, nx.Graph) and not (undirected and graph.is_directed())
        what = "undirected networkx graph" if undirected else "networkx graph"
    if not ok:
        hint = ""
        if callable(getattr(graph, "to_networkx", None)):  # a GraphStore, say
            hint = " (its to_networkx() gives the networkx graph)"
        elif isinstance(getattr(graph, "graph", None), nx.Graph):  # build_graph's result
            hint = " (its .graph is the networkx graph)"
        raise TypeError(f"{name}: expected {_a(what)}, received {type(graph).__name__}{hint}")
    return graph


def plain_length_m(value: Any) -> bool:
    """Is ``value`` a plain Python float or int, finite and ``>= 0``?  The common case of
    a graph's ``length_m``, told apart without building an error's name (per edge of a
    large graph); anything else goes through :func:`nonnegative_metres`."""
    return (type(value) is float or type(value) is int) and 0 <= value < math.inf


#: The largest sum (metres) of a graph's edge ``length_m`` that routes are planned on: a
#: quarter of the largest float, so that a route's sums (part of an edge, a path through
#: the graph, part of another edge) stay finite.
MAX_TOTAL_LENGTH_M = float(np.finfo(np.float64).max) / 4


def summable_lengths_m(name: str, lengths: Any) -> float:
    """The sum of ``lengths`` (each a finite number of metres >= 0), at most
    :data:`MAX_TOTAL_LENGTH_M`; a ValueError naming ``name`` above it."""
    with np.errstate(over="ignore"):
        total = float(np.sum(np.asarray(lengths, np.float64)))
    if not total <= MAX_TOTAL_LENGTH_M:
        raise ValueError(
            f"{name}: expected lengths that add up to at most {MAX_TOTAL_LENGTH_M:.6g} m, so "
            f"that sums along a route stay finite, received a sum of {total:.6g} m (to keep "
            "routes off an edge, remove it)"
        )
    return total


def plain_int_pair(value: Any) -> bool:
    """Is ``value`` a tuple of two plain Python ints (a vertex's ``pixel`` as the builders
    write it)?  Anything else goes through :func:`pixel_rows`."""
    return (
        type(value) is tuple and len(value) == 2 and type(value[0]) is int and type(value[1]) is int
    )


def pixel_rows(name: str, value: Any, *, one: bool = False) -> np.ndarray:
    """``value`` as int64 ``(row, col)`` pixels after checking it holds integers (whole
    floats pass, as a JSON or GraphML file may give them): shape (2,) when ``one`` (a
    vertex's ``pixel``), else (M, 2) from one pair or ``M >= 1`` of them (a vertex's
    ``pixels``, an edge's ``path``); a ``TypeError`` for a non-number, a ``ValueError`` for
    another shape or a fractional or non-finite value; a masked array is refused
    (:func:`unmasked`)."""
    try:
        arr = real_values(np.asarray(unmasked(name, value)))
    except ValueError:  # ragged nested lists
        arr = np.array(None)
    shape = "(2,)" if one else "(2,) or (M, 2)"
    expected = f"{name}: expected (row, col) pixels as integers, shape {shape}"
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{expected}, received {type(value).__name__} of dtype {arr.dtype}")
    if arr.shape != (2,) and (one or arr.ndim != 2 or arr.shape[1] != 2 or not len(arr)):
        raise ValueError(f"{expected}, received shape {arr.shape}")
    if arr.dtype.kind == "f":
        bad = ~(np.isfinite(arr) & (arr == np.round(arr)))
        if bad.any():
            raise ValueError(f"{expected}, received {float(arr[bad].flat[0])!r} among them")
    out = arr.astype(np.int64)
    return out if one else out.reshape(-1, 2)


def point_rows(name: str, value: Any) -> np.ndarray:
    """``value`` as float64 (N, 2) ``(x, y)`` points in metres (non-finite ones kept)
    after checking it is an array of real numbers: a ``TypeError`` naming ``name`` for
    None, strings, bools, complex numbers, objects or rows of different lengths (NumPy
    would take None as NaN and complex as its real part), a ``ValueError`` for another
    shape; an empty sequence is no points.  Masked entries of a masked array are NaN."""
    expected = f"{name}: expected an (N, 2) array of (x, y) in metres"
    try:
        arr = real_values(np.asarray(unmasked(name, value, fill=math.nan)))
    except (TypeError, ValueError):
        raise TypeError(
            f"{expected}, received {type(value).__name__} that makes no array "
            "(rows of different lengths?)"
        ) from None
    if arr.dtype.kind not in "iuf":
        mask = " (a mask? for a finished map use add_map)" if arr.dtype.kind == "b" else ""
        raise TypeError(
            f"{expected} (real numbers), received {type(value).__name__} of dtype {arr.dtype}{mask}"
        )
    if arr.shape == (0,):
        return np.zeros((0, 2), np.float64)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{expected}, received {type(value).__name__} of shape {arr.shape}")
    return arr.astype(np.float64, copy=False)


def binary_image(name: str, image: Any) -> np.ndarray:
    """``image`` as a C-contiguous bool (H, W) array (nonzero = True) after checking it is a
    2-D array of bool or real numbers without NaN, not masked (:func:`unmasked`)."""
    arr = real_values(np.asarray(unmasked(name, image)))
    if arr.dtype.kind not in "biuf":
        raise TypeError(
            f"{name}: expected a 2-D array of bool or real numbers, received dtype "
            f"{arr.dtype} (type {type(image).__name__})"
        )
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D array (H, W), received shape {arr.shape}")
    if arr.dtype.kind == "f" and np.isnan(arr).any():
        raise ValueError(
            f"{name} contains NaN ({int(np.isnan(arr).sum())} of {arr.size} values); "
            "cannot convert it to a binary image"
        )
    if arr.dtype == np.bool_:
        return np.ascontiguousarray(arr)
    return np.ascontiguousarray(arr != 0)


def xy_points(value: Any, where: str, *, min_points: int = 1) -> np.ndarray:
    """``value`` as float64 (K, 2) ``(x, y)`` points, ``K >= min_points`` (a vertex's
    position, an edge's ``world`` polyline or ``waypoints``); a ValueError naming
    ``where`` unless it is that shape and every number is finite (a ``TypeError`` for a
    masked array, :func:`unmasked`)."""
    plain = unmasked(where, value)
    try:
        xy = np.asarray(plain, dtype=np.float64)
    except (TypeError, ValueError):
        xy = None
    if xy is None or xy.ndim != 2 or xy.shape[1:] != (2,) or len(xy) < max(min_points, 1):
        shape = "" if xy is None else f" of shape {xy.shape}"
        raise ValueError(
            f"{where}: expected finite (x, y) points of shape (K, 2), K >= {max(min_points, 1)}, "
            f"received "
            f"{reprlib.repr(value)}{shape}"
        )
    bad = int(np.count_nonzero(~np.isfinite(xy)))
    if bad:
        raise ValueError(
            f"{where}: expected finite (x, y) points, received {bad} value(s) that are not finite"
        )
    return xy
