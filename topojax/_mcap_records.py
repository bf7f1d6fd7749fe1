"""MCAP files as records of bytes: the magic, record heads, chunk bodies, their
decompression and their CRCs (the MCAP specification, https://mcap.dev/spec)."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

MCAP_MAGIC = b"\x89MCAP0\r\n"
SCHEMA, CHANNEL, MESSAGE, CHUNK, FOOTER, DATA_END = 0x03, 0x04, 0x05, 0x06, 0x02, 0x0F
RECORD_HEAD = 9  # opcode u8 + body length u64
# a chunk's body opens with its message start and end times and uncompressed size (u64
# each) and the CRC-32 of its uncompressed records (u32; 0: none)
CHUNK_HEAD = 8 + 8 + 8 + 4
CRC_AT = 24


def string_at(body: bytes, pos: int) -> tuple[str, int]:
    """The u32-length-prefixed UTF-8 string at ``pos`` of a record body and the position
    after it."""
    (n,) = struct.unpack_from("<I", body, pos)
    end = pos + 4 + n
    if end > len(body):
        raise ValueError("a string runs past the end of its record")
    return body[pos + 4 : end].decode("utf-8", "replace"), end


def decompress(data: bytes, compression: str, cut: bool) -> bytes:
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


def chunk_parts(body: bytes) -> tuple[int, str, int, int]:
    """A chunk body's CRC, compression, where its compressed records start and their
    length in bytes; a ValueError where its head runs past ``body``."""
    if len(body) < CHUNK_HEAD + 4:
        raise ValueError("a chunk's head runs past the end of its record")
    (crc,) = struct.unpack_from("<I", body, CRC_AT)
    compression, pos = string_at(body, CHUNK_HEAD)
    if len(body) < pos + 8:
        raise ValueError("a chunk's head runs past the end of its record")
    (n,) = struct.unpack_from("<Q", body, pos)
    return crc, compression, pos + 8, n


def fill_chunk_crcs(path: Path) -> int:
    """Write the CRC-32 of its uncompressed records into each chunk of the MCAP file
    ``path`` that records none (0), in place; returns how many were written.  The records
    are read up to the data section's end (or the footer)."""
    n = 0
    with open(path, "r+b") as fh:
        if fh.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
            raise ValueError(f"{path}: not an MCAP file")
        pos = len(MCAP_MAGIC)
        while True:
            head = fh.read(RECORD_HEAD)
            if len(head) < RECORD_HEAD:
                return n
            op, length = head[0], struct.unpack_from("<Q", head, 1)[0]
            if op in (DATA_END, FOOTER):
                return n
            if op == CHUNK:
                body = fh.read(length)
                crc, compression, start, size = chunk_parts(body)
                if crc == 0:
                    records = decompress(body[start : start + size], compression, cut=False)
                    crc = zlib.crc32(records)
                    fh.seek(pos + RECORD_HEAD + CRC_AT)
                    fh.write(struct.pack("<I", crc))
                    n += 1
            pos += RECORD_HEAD + length
            fh.seek(pos)
