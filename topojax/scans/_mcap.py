"""A sequential reader for ROS 2 MCAP files that ``rosbags`` refuses because they were
cut off while recording (no summary, no end magic)."""

from __future__ import annotations

import struct
import warnings
import zlib
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

from .._mcap_records import (
    CHANNEL,
    CHUNK,
    FOOTER,
    MCAP_MAGIC,
    MESSAGE,
    RECORD_HEAD,
    SCHEMA,
    chunk_parts,
    decompress,
    string_at,
)


class _McapChannel(NamedTuple):
    """A channel's topic, message type and message definition (its schema's text and
    encoding, ``ros2msg`` or ``ros2idl``)."""

    topic: str
    msgtype: str
    msgdef: str
    encoding: str


class _Cut(Exception):
    """A record of the file, or of a chunk, runs past its end."""


class _McapSequential:
    """Message source reading an MCAP file record by record, chunks included, up to the
    end of its last whole record; messages are CDR-decoded with ``rosbags`` types built
    from the file's schemas.  Messages come in file order, each chunk's in log-time
    order (the order of ``rosbags``' reader where chunks do not overlap in time).

    Raises
    ------
    ValueError
        If the file is not MCAP or holds no whole message (cut before the first one).
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.channels: dict[int, _McapChannel] = {}
        self._schemas: dict[int, tuple[str, str, str]] = {}
        self._typestore: Any = None
        self.cut_at: int | None = None
        n_messages = sum(1 for _ in self._records())
        if n_messages == 0:
            where = f" (cut off at byte {self.cut_at})" if self.cut_at is not None else ""
            raise ValueError(
                f"{path}: the MCAP file holds no whole message{where}: nothing to read"
            )
        if self.cut_at is not None:
            warnings.warn(
                f"{path}: the MCAP file is cut off at the record at byte {self.cut_at} (no "
                "footer: a recording that stopped while writing); read "
                f"{n_messages} messages up to the cut",
                RuntimeWarning,
                stacklevel=4,
            )

    @property
    def topics(self) -> dict[str, str]:
        return {c.topic: c.msgtype for c in self.channels.values()}

    def _records(self) -> Iterator[tuple[int, int, bytes]]:
        """``(channel id, log time ns, CDR data)`` of every whole message; sets
        ``cut_at`` to the byte where the file is cut (None: it ends with a footer)."""
        size = self.path.stat().st_size
        with open(self.path, "rb") as fh:
            if fh.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                raise ValueError(
                    f"{self.path}: not an MCAP file (it does not begin with the MCAP magic "
                    f"{MCAP_MAGIC!r})"
                )
            pos = len(MCAP_MAGIC)
            while True:
                head = fh.read(RECORD_HEAD)
                if len(head) < RECORD_HEAD:  # ends between records, or in a record head
                    self.cut_at = pos
                    return
                op, length = head[0], struct.unpack_from("<Q", head, 1)[0]
                # a length past the file's end (cut, or garbage) reads only what is there
                body = fh.read(min(length, size - pos - RECORD_HEAD))
                cut = len(body) < length
                if op == FOOTER and not cut:
                    return
                try:
                    yield from self._record(op, body, cut, pos)
                except _Cut:
                    cut = True
                if cut:
                    self.cut_at = pos
                    return
                pos += RECORD_HEAD + length

    def _record(
        self, op: int, body: bytes, cut: bool, pos: int
    ) -> Iterator[tuple[int, int, bytes]]:
        """The messages of one record (a message, or a chunk's), at byte ``pos``; schemas
        and channels are kept.  Raises :class:`_Cut` for a record ``cut`` short (a chunk's
        whole records before the cut are read first)."""
        if op == CHUNK:
            yield from self._chunk(body, cut, pos)
            return
        if cut:
            raise _Cut
        if op == SCHEMA:
            self._add_schema(body)
        elif op == CHANNEL:
            self._add_channel(body)
        elif op == MESSAGE:
            yield self._message(body)

    def _chunk(self, body: bytes, cut: bool, where: int) -> Iterator[tuple[int, int, bytes]]:
        """The messages of the chunk record at byte ``where``, in log-time order (of one
        ``cut`` short, those before the cut, then :class:`_Cut`); a ValueError for a
        whole chunk whose records do not match its CRC."""
        try:
            crc, compression, start, n = chunk_parts(body)
        except ValueError:  # its head runs past the cut
            raise _Cut from None
        data = body[start : start + n]
        inner_cut = cut or len(data) < n
        records = decompress(data, compression, inner_cut)
        if crc and not inner_cut and zlib.crc32(records) != crc:
            raise ValueError(
                f"{self.path}: the chunk at byte {where} is damaged: its records do not "
                f"match its CRC ({zlib.crc32(records):#010x}, recorded {crc:#010x})"
            )
        messages: list[tuple[int, int, bytes]] = []
        at = 0
        while at + RECORD_HEAD <= len(records):
            op, length = records[at], struct.unpack_from("<Q", records, at + 1)[0]
            inner = records[at + RECORD_HEAD : at + RECORD_HEAD + length]
            if len(inner) < length:
                break
            if op == SCHEMA:
                self._add_schema(inner)
            elif op == CHANNEL:
                self._add_channel(inner)
            elif op == MESSAGE:
                messages.append(self._message(inner))
            at += RECORD_HEAD + length
        messages.sort(key=lambda m: m[1])  # stable: file order among equal times
        yield from messages
        if inner_cut or at != len(records):
            raise _Cut

    def _add_schema(self, body: bytes) -> None:
        (sid,) = struct.unpack_from("<H", body, 0)
        name, pos = string_at(body, 2)
        encoding, pos = string_at(body, pos)
        text, _ = string_at(body, pos)
        self._schemas[sid] = (name, encoding, text)

    def _add_channel(self, body: bytes) -> None:
        cid, sid = struct.unpack_from("<HH", body, 0)
        topic, _ = string_at(body, 4)
        if sid == 0:  # no schema: the messages cannot be decoded, the topic is listed
            self.channels[cid] = _McapChannel(topic, "", "", "")
            return
        if sid not in self._schemas:
            raise ValueError(f"{self.path}: channel {topic!r} refers to unknown schema {sid}")
        name, encoding, text = self._schemas[sid]
        self.channels[cid] = _McapChannel(topic, name, text, encoding)

    def _message(self, body: bytes) -> tuple[int, int, bytes]:
        if len(body) < 22:
            raise ValueError(f"{self.path}: a message record shorter than its fields")
        cid, _seq, log_time = struct.unpack_from("<HIQ", body, 0)
        if cid not in self.channels:
            raise ValueError(f"{self.path}: message for unknown channel {cid}")
        return cid, log_time, body[22:]

    def _store(self) -> Any:
        """A ``rosbags`` typestore with the file's message types (as ``AnyReader``
        builds one from the schemas)."""
        if self._typestore is None:
            from rosbags.typesys import (
                Stores,
                get_types_from_idl,
                get_types_from_msg,
                get_typestore,
            )

            typs: dict[str, Any] = {}
            sep = "=" * 80 + "\n"
            for c in self.channels.values():
                if c.encoding == "ros2idl":  # one IDL, or several each under an IDL: line
                    parts = c.msgdef.split(sep)[1:] if c.msgdef.startswith(sep) else []
                    for idl in [p.split("\n", 1)[1] for p in parts] or [c.msgdef]:
                        typs.update(get_types_from_idl(idl))
                elif c.msgdef:
                    typs.update(get_types_from_msg(c.msgdef, c.msgtype))
            store = get_typestore(Stores.EMPTY)
            store.register(typs)
            self._typestore = store
        return self._typestore

    def messages(self, topics: Iterable[str]) -> Iterator[tuple[str, str, int, Any]]:
        wanted = set(topics)
        store = self._store()
        for cid, t_ns, raw in self._records():  # the cut was reported once, on opening
            c = self.channels[cid]
            if c.topic in wanted:
                yield c.topic, c.msgtype, t_ns, store.deserialize_cdr(raw, c.msgtype)
