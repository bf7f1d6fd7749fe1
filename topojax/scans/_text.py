"""Opening the text logs (CARMEN, Octave): plain or gzip-compressed, decompression faults
reported as ValueError naming the file."""

from __future__ import annotations

import io
import warnings
import zlib
from pathlib import Path
from typing import IO

_GZIP_MAGIC = b"\x1f\x8b"
#: The UTF-8 byte order mark some editors write at the start of a text file: not text of
#: the log (read as latin-1 it would join the first line's message name).
_UTF8_BOM = b"\xef\xbb\xbf"


def _open_text(path: Path, *, warn_cut: bool = True) -> IO[str]:
    """Open a text file that may be gzip-compressed (detected by its magic bytes), past a
    UTF-8 byte order mark at its start.

    Compressed data cut off (a logger that stopped while writing) reads up to the cut,
    with a warning (``warn_cut``; a first pass over a log that is read again passes
    False, for the warning to come once), as a plain file cut off does; damaged
    compressed data raises ValueError naming the file (gzip's own errors name neither)."""
    with open(path, "rb") as fh:
        magic = fh.read(2)
    if magic == _GZIP_MAGIC:
        raw = io.BufferedReader(_CheckedGzip(path, warn_cut))
    else:
        raw = open(path, "rb")  # noqa: SIM115 - the text wrapper owns and closes it
    if raw.peek(len(_UTF8_BOM))[: len(_UTF8_BOM)] == _UTF8_BOM:
        raw.read(len(_UTF8_BOM))
    return io.TextIOWrapper(raw, encoding="latin-1", newline=None)


class _CheckedGzip(io.RawIOBase):
    """A gzip file's decompressed bytes: every byte before the cut where it is cut off,
    and decompression faults as ValueError.

    It decompresses with :mod:`zlib` itself: :mod:`gzip` raises EOFError at a cut and
    drops what it had decompressed of its last block (the last scans of the log)."""

    _CHUNK = 1 << 16  # compressed bytes read at a time
    _MAX_OUT = 1 << 20  # decompressed bytes made at a time

    def __init__(self, path: Path, warn_cut: bool = True) -> None:
        self._path = path
        self._warn_cut = warn_cut  # whether the cut is yet to be warned of (once)
        self.cut = False  # the cut has been reached
        self._file = open(path, "rb")
        self._inflate = zlib.decompressobj(31)  # a gzip member, header and trailer checked
        self._fed = False  # the member has had bytes
        self._out = b""  # decompressed, read up to _pos
        self._pos = 0
        self._ended = False

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        while self._pos == len(self._out) and not self._ended:
            self._out, self._pos = b"", 0
            self._more()
        n = min(len(buffer), len(self._out) - self._pos)
        buffer[:n] = memoryview(self._out)[self._pos : self._pos + n]
        self._pos += n
        return n

    def _more(self) -> None:
        """Decompress more into ``_out``, or end (at the cut, where the file ends within a
        member)."""
        if self._inflate.eof:  # a member ended: another may follow (concatenated gzip)
            data = self._inflate.unused_data
            self._inflate, self._fed = zlib.decompressobj(31), False
        else:
            data = self._inflate.unconsumed_tail
        at_end = False
        if not data:
            data = self._file.read(self._CHUNK)
            at_end = not data
        if not self._fed:
            data = data.lstrip(b"\x00")  # zero padding after a member, as gzip allows
            if not data and not at_end:
                return
        if not data:  # the end of the file
            self._out = self._inflate.flush() if self._fed else b""  # what zlib still holds
            if not self._out:
                self._ended = True
                if self._fed:
                    self._cut()
            return
        self._fed = True
        try:
            self._out = self._inflate.decompress(data, self._MAX_OUT)
        except zlib.error as exc:
            raise ValueError(
                f"{self._path}: the gzip-compressed data is damaged ({exc}); the file "
                "cannot be read to its end"
            ) from None

    def _cut(self) -> None:
        self.cut = True
        if self._warn_cut:
            self._warn_cut = False
            warnings.warn(
                f"{self._path}: the gzip-compressed data is cut off; read up to the cut",
                RuntimeWarning,
                stacklevel=4,
            )

    def close(self) -> None:
        self._file.close()
        super().close()


def gzip_cut(fh: IO[str]) -> bool:
    """Whether ``fh``, opened by :func:`_open_text`, is compressed data read up to a cut."""
    raw = getattr(getattr(fh, "buffer", None), "raw", None)
    return isinstance(raw, _CheckedGzip) and raw.cut


def _cut_off(line: str) -> bool:
    """Is ``line`` the last, unfinished line of a file (no line end: a logger that
    stopped while writing it)?  Only such a line is skipped; a malformed line with a line
    end is an error."""
    return not line.endswith(("\n", "\r"))
