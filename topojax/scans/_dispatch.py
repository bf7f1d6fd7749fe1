"""Choosing the reader of :func:`read_scans` by a file's content and suffix."""

from __future__ import annotations

import inspect
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from .._validate import path_like
from ._ros1 import _ROS1_MAGIC
from ._text import _open_text
from .bag import read_bag
from .carmen import read_carmen
from .octave import read_octave_laser
from .scan import Scan

_BAG_SUFFIXES = (".bag", ".db3", ".mcap")


class ReaderOptionError(ValueError):
    """Options given to :func:`read_scans` that the reader of the file does not take.

    Attributes
    ----------
    path : Path
        The file.
    reader : str
        The name of its reader (``"read_carmen"``, ``"read_bag"``, ...).
    unknown : tuple of str
        The options it does not take, sorted.
    accepted : tuple of str
        The options it takes, sorted.
    """

    def __init__(self, path: Path, reader: str, unknown: tuple, accepted: tuple) -> None:
        super().__init__(
            f"{path} is read by {reader}, which takes no {', '.join(unknown)} "
            f"(its options: {', '.join(accepted)})"
        )
        self.path, self.reader, self.unknown, self.accepted = path, reader, unknown, accepted

    def __reduce__(self):
        return type(self), (self.path, self.reader, self.unknown, self.accepted)


def _looks_octave(path: Path) -> bool:
    """Does the file open with an Octave ``save -text`` header (``# Created by Octave`` or
    ``# name:`` among its first 20 lines, before any line that is not a comment)?"""
    with _open_text(path, warn_cut=False) as fh:  # the reader warns of a cut
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
    * anything else (``.log``, ``.clf``, ``.gz``, ...) -> :func:`read_carmen`, which
      refuses a file whose first line is no CARMEN line, listing the formats read here.

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
    ValueError
        For a map image, or a file of none of these formats (raised once the scans are
        iterated), the message listing the formats and their usual suffixes; a
        :class:`ReaderOptionError` for options the file's reader does not take.
    """
    p = path_like("path", path)
    if not p.exists():
        raise FileNotFoundError(f"path: file not found: {p}")
    reader = _reader_for(p)
    accepted = inspect.signature(reader).parameters
    unknown = sorted(set(kwargs) - set(accepted))
    if unknown:
        options = sorted(k for k, v in accepted.items() if v.kind is v.KEYWORD_ONLY)
        raise ReaderOptionError(p, reader.__name__, tuple(unknown), tuple(options))
    return reader(p, **kwargs)


#: Map images, not scans: refused by name instead of read as an empty CARMEN log.
_IMAGE_SUFFIXES = (".png", ".pgm", ".ppm", ".jpg", ".jpeg", ".tif", ".tiff")


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
    if (
        magic.startswith((b"\x89PNG", b"P2", b"P5", b"\xff\xd8"))
        or p.suffix.lower() in _IMAGE_SUFFIXES
    ):
        raise ValueError(
            f"path: expected a laser log (CARMEN, Octave) or a bag (ROS 1, ROS 2, MCAP), "
            f"received the map image {p} (load_map reads maps)"
        )
    return read_carmen
