"""A sequential reader for ROS 1 bag v2.0 files that ``rosbags`` refuses."""

from __future__ import annotations

import bz2
import struct
import warnings
from collections import Counter
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

from .._words import counted

_ROS1_MAGIC = b"#ROSBAG V2.0\n"


def _normalize_msgtype(name: str) -> str:
    """``pkg/Name`` (ROS 1) -> ``pkg/msg/Name``."""
    parts = name.split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return name


class _Ros1Connection(NamedTuple):
    topic: str
    msgtype: str
    msgdef: str
    md5sum: str
    callerid: str | None


class _Ros1Sequential:
    """Minimal sequential reader for ROS 1 bag v2.0 files.

    Used when ``rosbags`` cannot open a bag whose index records are inconsistent (for
    example the CCNY demo bag, written in 2010, whose INDEX_DATA records declare 20 bytes
    per entry but hold 12). It walks the chunk records in file order and never uses the
    index; message definitions are taken from the bag's connection records.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.connections: dict[int, _Ros1Connection] = {}
        self._typestore: Any = None
        self._cut_told = False  # whether the cut (if any) has been warned of
        if not self._connections_from_index():
            # no index (a recording cut off, say): the connections are among the chunks;
            # the walk counts the messages up to a cut, for the one warning of it
            self._cut_told = True
            per_conn = Counter(conn for conn, _, _ in self._records(want_messages=True))
            self._cut_told = False
            self._warn_cut(f"read up to the cut: {self._per_topic(per_conn)}")

    def _connections_from_index(self) -> bool:
        """Read the connection records at the bag header's ``index_pos``; False if absent."""
        with open(self.path, "rb") as fh:
            if fh.read(len(_ROS1_MAGIC)) != _ROS1_MAGIC:
                raise ValueError(f"{self.path}: not a ROS 1 bag v2.0 file")
            head = fh.read(4096 + 64)
            try:
                hdr, _, _, _ = self._read_record(head, 0)
                index_pos = struct.unpack("<Q", hdr["index_pos"])[0]
                conn_count = struct.unpack("<I", hdr["conn_count"])[0]
            except (KeyError, ValueError, struct.error):
                return False
            if index_pos == 0 or conn_count == 0:
                return False
            fh.seek(index_pos)
            tail = fh.read()
        pos = 0
        found = 0
        try:
            while pos < len(tail) and found < conn_count:
                hdr, start, dlen, _ = self._read_record(tail, pos)
                if hdr.get("op", b"\xff")[0] == 0x07:
                    self._add_connection(hdr, tail[start : start + dlen])
                    found += 1
                pos = start + dlen
        except (KeyError, ValueError, struct.error):
            self.connections.clear()
            return False
        return found == conn_count

    def _per_topic(self, per_conn: Counter) -> str:
        """The messages counted per connection in ``per_conn``, summed per topic:
        ``"40 messages (/scan 10, /tf 30)"``."""
        per_topic: Counter = Counter()
        for conn, n in per_conn.items():
            conn_info = self.connections.get(conn)
            per_topic[conn_info.topic if conn_info else f"connection {conn}"] += n
        each = ", ".join(f"{topic} {n}" for topic, n in sorted(per_topic.items()))
        total = counted(sum(per_topic.values()), "message")
        return f"{total} ({each})" if each else total

    @property
    def topics(self) -> dict[str, str]:
        return {c.topic: c.msgtype for c in self.connections.values()}

    @staticmethod
    def _header(buf: bytes, what: str) -> dict[str, bytes]:
        fields: dict[str, bytes] = {}
        i = 0
        while i < len(buf):
            if i + 4 > len(buf):
                raise ValueError(f"truncated {what} header")
            (n,) = struct.unpack_from("<I", buf, i)
            item = buf[i + 4 : i + 4 + n]
            if len(item) != n or b"=" not in item:
                raise ValueError(f"malformed {what} header field")
            key, val = item.split(b"=", 1)
            fields[key.decode("latin-1")] = val
            i += 4 + n
        return fields

    @staticmethod
    def _read_record(buf: bytes, pos: int) -> tuple[dict[str, bytes], int, int, int]:
        """Header fields, data start, stored data length, position after the header+len."""
        if pos + 4 > len(buf):
            raise ValueError("truncated record")
        (hlen,) = struct.unpack_from("<I", buf, pos)
        hdr = _Ros1Sequential._header(buf[pos + 4 : pos + 4 + hlen], "record")
        if pos + 8 + hlen > len(buf):
            raise ValueError("truncated record")
        (dlen,) = struct.unpack_from("<I", buf, pos + 4 + hlen)
        start = pos + 8 + hlen
        return hdr, start, dlen, start

    def _add_connection(self, hdr: dict[str, bytes], data: bytes) -> None:
        conn = struct.unpack("<I", hdr["conn"])[0]
        topic = hdr["topic"].decode("utf-8", "replace")
        info = self._header(data, "connection")
        self.connections[conn] = _Ros1Connection(
            topic,
            _normalize_msgtype(info.get("type", b"").decode("utf-8", "replace")),
            info.get("message_definition", b"").decode("utf-8", "replace"),
            info.get("md5sum", b"").decode("ascii", "replace"),
            info.get("callerid", b"").decode("utf-8", "replace") or None,
        )

    _cut_at: int | None = None  # the byte of the record the bag ends inside, if any

    def _cut_off(self, pos: int) -> None:
        """Note that the bag ends inside the record at byte ``pos`` (a recording that
        stopped while writing: its messages up to the cut are read); warned of once,
        however many passes read the bag."""
        self._cut_at = pos
        self._warn_cut("read up to the cut")

    def _warn_cut(self, what: str) -> None:
        if self._cut_told or self._cut_at is None:
            return
        self._cut_told = True
        warnings.warn(
            f"{self.path}: the bag ends in the middle of the record at byte {self._cut_at} "
            f"(a recording cut off); {what}",
            RuntimeWarning,
            stacklevel=4,
        )

    def _records(self, want_messages: bool) -> Iterator[tuple[int, int, bytes]]:
        with open(self.path, "rb") as fh:
            if fh.read(len(_ROS1_MAGIC)) != _ROS1_MAGIC:
                raise ValueError(f"{self.path}: not a ROS 1 bag v2.0 file")
            while True:
                pos = fh.tell()
                head = fh.read(4)
                if not head:
                    return
                (hlen,) = struct.unpack("<I", head.ljust(4, b"\0"))
                hbuf = fh.read(hlen)
                dbuf = fh.read(4)
                if len(head) < 4 or len(hbuf) != hlen or len(dbuf) != 4:
                    self._cut_off(pos)
                    return
                hdr = self._header(hbuf, f"record at byte {pos} of {self.path}")
                (dlen,) = struct.unpack("<I", dbuf)
                op = hdr.get("op", b"\xff")[0]
                if op == 0x04:  # INDEX_DATA: trust the entry count, not the data length
                    ver = struct.unpack("<I", hdr["ver"])[0] if "ver" in hdr else 1
                    count = struct.unpack("<I", hdr["count"])[0] if "count" in hdr else 0
                    if ver == 1:
                        dlen = 12 * count
                    fh.seek(dlen, 1)
                    continue
                data = fh.read(dlen)
                cut = len(data) < dlen
                if op == 0x07 and not cut:
                    self._add_connection(hdr, data)
                elif op == 0x05:  # a CHUNK (BAG_HEADER, CHUNK_INFO, ...: skipped)
                    data = self._decompress(data, hdr, cut)
                    yield from self._chunk_records(data, want_messages, cut)
                if cut:
                    self._cut_off(pos)
                    return

    def _decompress(self, data: bytes, hdr: dict[str, bytes], cut: bool = False) -> bytes:
        """A CHUNK record's data, decompressed as its header's ``compression`` says (of
        a chunk ``cut`` off, as much as its data hold)."""
        comp = hdr.get("compression", b"none").decode()
        if comp == "bz2":
            return bz2.BZ2Decompressor().decompress(data) if cut else bz2.decompress(data)
        if comp == "lz4":
            import lz4.frame  # type: ignore[import-untyped]

            return (
                lz4.frame.LZ4FrameDecompressor().decompress(data)
                if cut
                else (lz4.frame.decompress(data))
            )
        if comp != "none":
            raise ValueError(f"{self.path}: unsupported chunk compression {comp!r}")
        return data

    def _chunk_records(
        self, data: bytes, want_messages: bool, cut: bool = False
    ) -> Iterator[tuple[int, int, bytes]]:
        """The records of a chunk's (decompressed) ``data``; of a chunk ``cut`` off, those
        before the cut."""
        pos = 0
        while pos < len(data):
            try:
                hdr, start, dlen, _ = self._read_record(data, pos)
                if start + dlen > len(data):
                    raise ValueError("truncated record")
            except ValueError as err:
                if cut:
                    return
                raise ValueError(f"{self.path}: corrupt chunk: {err}") from None
            op = hdr.get("op", b"\xff")[0]
            payload = data[start : start + dlen]
            if op == 0x07:
                self._add_connection(hdr, payload)
            elif op == 0x02 and want_messages:
                conn = struct.unpack("<I", hdr["conn"])[0]
                sec, nsec = struct.unpack("<II", hdr["time"])
                yield conn, sec * 1_000_000_000 + nsec, payload
            pos = start + dlen

    def _store(self) -> Any:
        if self._typestore is None:
            from rosbags.typesys import Stores, get_types_from_msg, get_typestore

            store = get_typestore(Stores.EMPTY)
            # Start from the ROS 1 Noetic definitions: bags from early ROS releases define
            # ``roslib/Header`` but refer to it as ``Header`` (= std_msgs/Header today).
            typs: dict[str, Any] = dict(get_typestore(Stores.ROS1_NOETIC).fielddefs)
            for c in self.connections.values():
                if c.msgdef:
                    typs.update(get_types_from_msg(c.msgdef, c.msgtype))
            store.register(typs)
            self._typestore = store
        return self._typestore

    def messages(self, topics: Iterable[str]) -> Iterator[tuple[str, str, int, Any]]:
        wanted = set(topics)
        store = self._store()
        for conn, t_ns, raw in self._records(want_messages=True):
            c = self.connections.get(conn)
            if c is None:
                raise ValueError(f"{self.path}: message for unknown connection {conn}")
            if c.topic in wanted:
                yield c.topic, c.msgtype, t_ns, store.deserialize_ros1(raw, c.msgtype)
