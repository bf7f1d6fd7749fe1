"""A sequential reader for ROS 2 MCAP files that ``rosbags`` refuses because they were
cut off while recording (no summary, no end magic)."""

from __future__ import annotations

import struct
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_SCHEMA, _CHANNEL, _MESSAGE, _CHUNK, _FOOTER = 0x03, 0x04, 0x05, 0x06, 0x02
_RECORD_HEAD = 9  # opcode u8 + body length u64


class _McapChannel(NamedTuple):
    """A channel's topic, message type and message definition (its schema's text and
    encoding, ``ros2msg`` or ``ros2idl``)."""

    topic: str
    msgtype: str
    msgdef: str
    encoding: str


class _Cut(Exception):
    """A record of the file, or of a chunk, runs past its end."""


def _string(body: bytes, pos: int) -> tuple[str, int]:
    """The u32-length-prefixed UTF-8 string at ``pos`` of a record body and the position
    after it."""
    (n,) = struct.unpack_from("<I", body, pos)
    end = pos + 4 + n
    if end > len(body):
        raise ValueError("a string runs past the end of its record")
    return body[pos + 4 : end].decode("utf-8", "replace"), end


def _decompress(data: bytes, compression: str, cut: bool) -> bytes:
    """A chunk's records: ``data`` decompressed (``""``, ``"zstd"`` or ``"lz4"``); of a
    chunk ``cut`` off, as much as its data hold.  A ValueError for data that do not
    decompress (a damaged chunk)."""
    try:
        return _decompressed(data, compression, cut)
    except (ValueError, ImportError):
        raise
    except Exception as exc:  # noqa: BLE001 - zstd and lz4 raise their own types
        raise ValueError(
            f"a {compression} chunk does not decompress ({type(exc).__name__}: {exc})"
        ) from None


def _decompressed(data: bytes, compression: str, cut: bool) -> bytes:
    if compression == "":
        return data
    if compression == "zstd":
        try:
            from compression import zstd  # Python >= 3.14
        except ImportError:
            from backports import zstd  # a dependency of rosbags
        return zstd.ZstdDecompressor().decompress(data) if cut else zstd.decompress(data)
    if compression == "lz4":
        import lz4.frame  # a dependency of rosbags

        if not cut:
            return lz4.frame.decompress(data)
        try:
            return lz4.frame.LZ4FrameDecompressor().decompress(data)
        except RuntimeError:  # cut inside the frame header
            return b""
    raise ValueError(f"chunk compression: expected '', 'zstd' or 'lz4', received {compression!r}")


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
            if fh.read(len(_MCAP_MAGIC)) != _MCAP_MAGIC:
                raise ValueError(
                    f"{self.path}: not an MCAP file (it does not begin with the MCAP magic "
                    f"{_MCAP_MAGIC!r})"
                )
            pos = len(_MCAP_MAGIC)
            while True:
                head = fh.read(_RECORD_HEAD)
                if len(head) < _RECORD_HEAD:  # ends between records, or in a record head
                    self.cut_at = pos
                    return
                op, length = head[0], struct.unpack_from("<Q", head, 1)[0]
                # a length past the file's end (cut, or garbage) reads only what is there
                body = fh.read(min(length, size - pos - _RECORD_HEAD))
                cut = len(body) < length
                if op == _FOOTER and not cut:
                    return
                try:
                    yield from self._record(op, body, cut)
                except _Cut:
                    cut = True
                if cut:
                    self.cut_at = pos
                    return
                pos += _RECORD_HEAD + length

    def _record(self, op: int, body: bytes, cut: bool) -> Iterator[tuple[int, int, bytes]]:
        """The messages of one record (a message, or a chunk's); schemas and channels
        are kept.  Raises :class:`_Cut` for a record ``cut`` short (a chunk's whole
        records before the cut are read first)."""
        if op == _CHUNK:
            yield from self._chunk(body, cut)
            return
        if cut:
            raise _Cut
        if op == _SCHEMA:
            self._add_schema(body)
        elif op == _CHANNEL:
            self._add_channel(body)
        elif op == _MESSAGE:
            yield self._message(body)

    def _chunk(self, body: bytes, cut: bool) -> Iterator[tuple[int, int, bytes]]:
        """The messages of a chunk record, in log-time order (of one ``cut`` short, those
        before the cut, then :class:`_Cut`)."""
        head = 8 + 8 + 8 + 4
        if len(body) < head + 4:
            raise _Cut
        try:
            compression, pos = _string(body, head)
        except ValueError:
            raise _Cut from None
        if len(body) < pos + 8:
            raise _Cut
        (n,) = struct.unpack_from("<Q", body, pos)
        data = body[pos + 8 : pos + 8 + n]
        inner_cut = cut or len(data) < n
        records = _decompress(data, compression, inner_cut)
        messages: list[tuple[int, int, bytes]] = []
        at = 0
        while at + _RECORD_HEAD <= len(records):
            op, length = records[at], struct.unpack_from("<Q", records, at + 1)[0]
            inner = records[at + _RECORD_HEAD : at + _RECORD_HEAD + length]
            if len(inner) < length:
                break
            if op == _SCHEMA:
                self._add_schema(inner)
            elif op == _CHANNEL:
                self._add_channel(inner)
            elif op == _MESSAGE:
                messages.append(self._message(inner))
            at += _RECORD_HEAD + length
        messages.sort(key=lambda m: m[1])  # stable: file order among equal times
        yield from messages
        if inner_cut or at != len(records):
            raise _Cut

    def _add_schema(self, body: bytes) -> None:
        (sid,) = struct.unpack_from("<H", body, 0)
        name, pos = _string(body, 2)
        encoding, pos = _string(body, pos)
        text, _ = _string(body, pos)
        self._schemas[sid] = (name, encoding, text)

    def _add_channel(self, body: bytes) -> None:
        cid, sid = struct.unpack_from("<HH", body, 0)
        topic, _ = _string(body, 4)
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
