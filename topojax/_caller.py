"""Where a warning names its cause: the first line outside the package."""

from __future__ import annotations

import os
import sys

__all__ = ["outside_stacklevel"]

_PACKAGE = os.path.dirname(os.path.abspath(__file__)) + os.sep


def outside_stacklevel() -> int:
    """The ``stacklevel`` with which a ``warnings.warn`` in the function that calls this
    names the first frame outside topojax: the line of the user's code that led to it,
    however deep the package's own calls (a method, its lock, its loops) run."""
    frame = sys._getframe(1)
    level = 1
    while frame.f_back is not None and frame.f_code.co_filename.startswith(_PACKAGE):
        frame = frame.f_back
        level += 1
    return level
