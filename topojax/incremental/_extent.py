"""The mapper's refusal of a scan, points or map beyond its bounds (:class:`ExtentError`),
which says in fields what its message says in words: the bound met and what was refused."""

from __future__ import annotations

import functools
from typing import NamedTuple

#: The bounds a refusal may meet (:attr:`ExtentError.bound`): the mapper's settings
#: ``max_extent_m``, ``max_grid_cells`` and ``max_tile_bytes``, and ``max_abs_pixel``, the
#: fixed limit of 2^30 pixels from the origin (coordinates far off, not in metres).
BOUNDS = ("max_extent_m", "max_grid_cells", "max_tile_bytes", "max_abs_pixel")


class ExtentError(ValueError):
    """A scan, points or map refused because it would grow the mapped area beyond the
    mapper's ``max_extent_m``, ``max_grid_cells`` or ``max_tile_bytes``, or put pixels
    beyond 2^30 pixels from the origin (nothing was added).

    Attributes
    ----------
    bound : str
        The bound met, one of :data:`BOUNDS`: ``"max_extent_m"``, ``"max_grid_cells"``,
        ``"max_tile_bytes"`` or ``"max_abs_pixel"`` (beyond 2^30 pixels).
    subject : str
        What was refused, as the message names it first (``"scan 40"``,
        ``"points_xy: the points (scan 3)"``, ``"occupancy: the map at (0, 0, 0)"``).
    scan : int or None
        The refused scan's (or points') index, the scans the mapper had added; None for
        a map (``add_map``), which is no scan.
    """

    def __init__(self, message: str, *, bound: str, subject: str = "", scan=None) -> None:
        if bound not in BOUNDS:
            raise ValueError(f"bound: expected one of {BOUNDS}, received {bound!r}")
        if not message.startswith(subject):
            raise ValueError(
                f"subject: expected the start of the message, received {subject!r} for {message!r}"
            )
        super().__init__(message)
        self.bound = bound
        self.subject = subject
        self.scan = scan

    def __reduce__(self):
        # the keywords kept (the default would call the class with the message only)
        make = functools.partial(type(self), bound=self.bound, subject=self.subject, scan=self.scan)
        return make, self.args, self.__dict__ or None

    def renamed(self, name: str) -> str:
        """The message, naming what was refused ``name`` instead of :attr:`subject`."""
        return name + str(self)[len(self.subject) :]


class Subject(NamedTuple):
    """What a refusal names as its message opens: ``name`` (:attr:`ExtentError.subject`),
    the words that follow it (a scan's timestamp and pose, or none) and the scan's index
    (:attr:`ExtentError.scan`)."""

    name: str
    more: str = ""
    scan: int | None = None


def refusal(where, reason: str, bound: str) -> ExtentError:
    """The :class:`ExtentError` of meeting ``bound``, its message ``where()`` (a callable
    giving a :class:`Subject`, formatted only on a refusal) then ``reason``."""
    what = where()
    return ExtentError(
        f"{what.name}{what.more}{reason}", bound=bound, subject=what.name, scan=what.scan
    )
