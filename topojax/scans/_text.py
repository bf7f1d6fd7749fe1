"""Opening the text logs (CARMEN, Octave): plain or gzip-compressed, decompression faults
reported as ValueError naming the file."""

from __future__ import annotations

import gzip
import io
import warnings
import zlib
from pathlib import Path
from typing import IO

_GZIP_MAGIC = b"\x1f\x8b"


def _open_text(path: Path, *, warn_cut: bool = True) -> IO[str]:
    """Open a text file that may be gzip-compressed (detected by its magic bytes).

    Compressed data cut off (a logger that stopped while writing) reads up to the cut,
    with a warning (``warn_cut``; a first pass over a log that is read again passes
    False, for the warning to come once), as a plain file cut off does; damaged
    compressed data raises ValueError naming the file (gzip's own errors name neither)."""
    with open(path, "rb") as fh:
        magic = fh.read(2)
    if magic == _GZIP_MAGIC:
        raw = io.BufferedReader(_CheckedGzip(path, warn_cut))
        return io.TextIOWrapper(raw, encoding="latin-1", newline=None)
    return open(path, encoding="latin-1", newline=None)


class _CheckedGzip(io.RawIOBase):
    """A gzip file's decompressed bytes: up to the cut where it is cut off, and
    decompression faults as ValueError."""

    def __init__(self, path: Path, warn_cut: bool = True) -> None:
        self._path = path
        self._warn_cut = warn_cut  # whether the cut is yet to be warned of (once)
        self._file = gzip.open(path, "rb")

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        try:
            return self._file.readinto(buffer)
        except EOFError:
            if not self._warn_cut:
                return 0
            self._warn_cut = False
            warnings.warn(
                f"{self._path}: the gzip-compressed data is cut off; read up to the cut",
                RuntimeWarning,
                stacklevel=2,
            )
            return 0
        except (zlib.error, gzip.BadGzipFile) as exc:
            raise ValueError(
                f"{self._path}: the gzip-compressed data is damaged ({exc}); the file "
                "cannot be read to its end"
            ) from None

    def close(self) -> None:
        self._file.close()
        super().close()


def _cut_off(line: str) -> bool:
    """Is ``line`` the last, unfinished line of a file (no line end: a logger that
    stopped while writing it)?  Only such a line is skipped; a malformed line with a line
    end is an error."""
    return not line.endswith(("\n", "\r"))
