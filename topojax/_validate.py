"""Argument checks shared by the whole package.

Each check returns the value in its canonical Python type, or raises a ``TypeError`` /
``ValueError`` whose message names the parameter, what was expected and what was received.
NumPy scalars are accepted wherever the matching Python type is; ``bool`` is never a number.
"""

from __future__ import annotations

import math
import numbers

__all__ = [
    "finite_positive",
    "flag",
    "integer",
    "metres",
    "nonnegative_metres",
    "positive_metres",
]


def finite_positive(name: str, value: object) -> float:
    """``value`` as a float after checking it is a finite real number > 0 (Python or NumPy,
    not bool)."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return float(value)


def integer(name: str, value: object) -> int:
    """``value`` as an int after checking it is an integer (Python or NumPy, not bool)."""
    if not isinstance(value, numbers.Integral) or isinstance(value, bool):
        raise TypeError(f"{name} must be an int, got {type(value).__name__} {value!r}")
    return int(value)


def flag(name: str, value: object) -> bool:
    """``value`` as a bool after checking it is one (Python or NumPy)."""
    if type(value).__name__ not in ("bool", "bool_"):
        raise TypeError(f"{name} must be a bool, got {type(value).__name__} {value!r}")
    return bool(value)


def metres(name: str, value: object, *, allow_zero: bool) -> float:
    """``value`` as a float after checking it is a finite number of metres, ``>= 0`` or
    ``> 0``; the errors name ``name``, what was expected and what was received."""
    bound = ">= 0" if allow_zero else "> 0"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(
            f"{name}: expected a number of metres {bound}, received "
            f"{type(value).__name__} {value!r}"
        )
    value = float(value)
    if not math.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        raise ValueError(f"{name}: expected a finite number of metres {bound}, received {value!r}")
    return value


def nonnegative_metres(name: str, value: object) -> float:
    """:func:`metres` ``>= 0`` (the pruning thresholds of :class:`GraphConfig` and
    :func:`topojax.prune_graph`)."""
    return metres(name, value, allow_zero=True)


def positive_metres(name: str, value: object) -> float:
    """:func:`metres` ``> 0`` (the tolerances of the Nav2 export and of
    :meth:`topojax.Route.waypoints`, the batch's ``sigma_m``)."""
    return metres(name, value, allow_zero=False)
