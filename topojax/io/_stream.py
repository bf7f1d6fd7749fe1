"""Writing a file a piece at a time: text gathered and written a megabyte at a time, and
JSON documents whose long arrays are written an item at a time, so a writer holds one
item and one megabyte of text, not the whole file (and its parts as Python objects)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any, BinaryIO

#: Characters of text gathered before they are encoded and written.
_CHUNK_CHARS = 1 << 20


class _Chunks:
    """Text written to the binary file ``fh``, encoded with ``encoding`` / ``errors``
    (:meth:`str.encode`), :data:`_CHUNK_CHARS` characters at a time; :meth:`close` writes
    the rest."""

    def __init__(self, fh: BinaryIO, encoding: str = "utf-8", errors: str = "strict") -> None:
        self._fh = fh
        self._encoding = encoding
        self._errors = errors
        self._parts: list[str] = []
        self._chars = 0

    def write(self, text: str) -> None:
        self._parts.append(text)
        self._chars += len(text)
        if self._chars >= _CHUNK_CHARS:
            self._flush()

    def _flush(self) -> None:
        self._fh.write("".join(self._parts).encode(self._encoding, self._errors))
        self._parts.clear()
        self._chars = 0

    def close(self) -> None:
        self._flush()


class _NotJsonCompliant(ValueError):
    """A NaN or an infinity in a document written with ``allow_nan=False``."""


def _write_json(fh: BinaryIO, doc: dict[str, Any], *, allow_nan: bool) -> None:
    """Write ``json.dumps(doc, allow_nan=allow_nan)`` to ``fh`` (UTF-8), byte for byte,
    where a value of ``doc`` that is an iterator stands for the list of its items, made
    and written one at a time.

    A value that strict JSON cannot hold (``allow_nan=False``) raises
    :class:`_NotJsonCompliant`, once the items not yet made are made: an error of theirs
    comes first, as when the whole document was made before it was written."""
    encoder = json.JSONEncoder(allow_nan=allow_nan)

    def encode(value: Any) -> str:
        try:
            return encoder.encode(value)
        except ValueError as exc:
            if allow_nan:
                raise
            raise _NotJsonCompliant(str(exc)) from None

    out = _Chunks(fh)
    values = iter(doc.items())
    value: Any = None
    try:
        out.write("{")
        for i, (name, value) in enumerate(values):
            out.write(f"{', ' if i else ''}{encode(name)}: ")
            if not isinstance(value, Iterator):
                out.write(encode(value))
                continue
            out.write("[")
            for j, item in enumerate(value):
                out.write(f"{', ' if j else ''}{encode(item)}")
            out.write("]")
        out.write("}")
    except _NotJsonCompliant:
        for rest in (value, *(v for _, v in values)):  # their own errors first
            if isinstance(rest, Iterator):
                for _ in rest:
                    pass
        raise
    out.close()


class DuplicateKeyError(ValueError):
    """A JSON object of the document gives ``key`` twice."""

    def __init__(self, key: str) -> None:
        super().__init__(f"key {key!r} is given twice in one object; expected each key once")
        self.key = key


def _unique_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    doc = dict(pairs)
    if len(doc) < len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise DuplicateKeyError(key)
            seen.add(key)
    return doc


def loads_unique(text: str) -> Any:
    """``json.loads(text)``, raising :class:`DuplicateKeyError` where an object gives a
    key twice (``json`` keeps the last value silently)."""
    return json.loads(text, object_pairs_hook=_unique_pairs)
