"""Map image files: PGM/PPM headers and their resolution comments, plain (ASCII) PNM, the
image sizes headers give, and reading an image (decoded by OpenCV or PIL in
:mod:`topojax.maps._decode`)."""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from .._cpus import check_fits_memory
from .._validate import MAX_RESOLUTION_M, MIN_RESOLUTION_M, existing_file
from ._decode import decode_image, decoder_limits, refuse_several_images

__all__ = [
    "DECODE_BYTES_PER_PIXEL",
    "pnm_header_tokens",
    "read_image",
    "resolution_from_pgm_comments",
]

#: The fewest bytes a pixel of a decoded image takes in :func:`topojax.load_map`: 1 for
#: the decoded intensity (8-bit grey; up to 8 for 16-bit RGBA) and 4 for the map's
#: classes.  An image whose header gives more pixels than the memory available holds at
#: this rate is refused before it is decoded (a decompression bomb costs nothing).
DECODE_BYTES_PER_PIXEL = 5

# the whitespace-delimited word before "m/pix" (map_saver writes "0.050 m/pix")
_PGM_RES_RE = re.compile(r"(?:^|\s)(\S+)\s*m/pix")
# the number-like end of that word: digits with dots, commas, a sign or an exponent, or
# a NaN or an infinity as C's printf writes them
_PGM_NUMBER_RE = re.compile(
    r"[-+]?(?:[0-9.,]*[0-9][0-9.,]*(?:[eE][-+]?[0-9]+)?|(?<![a-z])(?:nan|inf|infinity))$",
    re.IGNORECASE,
)


_LINE_END = re.compile(rb"[\r\n]")


def pnm_header_tokens(data: bytes) -> tuple[list[bytes], list[str], int]:
    """The first three header words (width, height, maxval; fewer if ``data`` ends
    before them), the comment lines before them and the index just past the last word,
    of PGM/PPM bytes whose two-byte magic number is skipped."""
    comments: list[str] = []
    tokens: list[bytes] = []
    pos = 2
    n = len(data)
    while len(tokens) < 3 and pos < n:
        ch = data[pos : pos + 1]
        if ch == b"#":  # to the next line feed or carriage return (Netpbm's rule)
            found = _LINE_END.search(data, pos)
            end = n if found is None else found.start()
            comments.append(data[pos + 1 : end].decode("latin-1").strip())
            pos = end + 1
        elif ch.isspace():
            pos += 1
        else:
            start = pos
            while pos < n and not data[pos : pos + 1].isspace() and data[pos : pos + 1] != b"#":
                pos += 1
            tokens.append(data[start:pos])
    return tokens, comments, pos


def _parse_pnm_header(data: bytes) -> tuple[int | None, list[str]]:
    """Return (maxval, comment lines) of a binary/ASCII PGM/PPM header, or (None, [])."""
    if len(data) < 2 or data[:1] != b"P" or data[1:2] not in b"2356":
        return None, []
    tokens, comments, _ = pnm_header_tokens(data)
    if len(tokens) < 3:
        return None, comments
    try:
        maxval = int(tokens[2])
    except ValueError:
        return None, comments
    return maxval, comments


def resolution_from_pgm_comments(comments: list[str], path: Path) -> float | None:
    """Resolution from a ``# CREATOR: map_saver.cpp 0.050 m/pix`` style comment: the number
    at the end of the word before ``m/pix`` (``0.05``, ``res=0.05``, ``(0.05``).  None if
    no comment gives one.  A number that is not a positive one (``0,05``, ``-0.05``), or
    one outside the resolutions a map may have, is an error rather than a misread: the
    map would be scaled wrongly without notice."""
    for line in comments:
        m = _PGM_RES_RE.search(line)
        if not m:
            continue
        number = _PGM_NUMBER_RE.search(m.group(1))
        if number is None:  # no number there ("units: m/pix")
            continue
        word = number.group(0)
        try:
            value = float(word)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise ValueError(
                f"map image {path}: its comment {line!r} gives the resolution as "
                f"{word!r}, which is not a positive number of metres per pixel; pass "
                "resolution_m to set it"
            )
        if not MIN_RESOLUTION_M <= value <= MAX_RESOLUTION_M:
            raise ValueError(
                f"map image {path}: its comment {line!r} gives the resolution as "
                f"{word!r}, outside the {MIN_RESOLUTION_M:g} to {MAX_RESOLUTION_M:g} metres "
                "per pixel a map may have; pass resolution_m to set it"
            )
        return value
    return None


#: Bytes of a plain PNM file parsed at once: bounds the scratch memory of the parse.
_PLAIN_CHUNK = 1 << 18
#: Byte classes of plain PNM files: 0 for a separator (the bytes ``bytes.split`` splits
#: at), 1 for a digit, 2 for any other byte.
_PLAIN_CLASS = np.full(256, 2, dtype=np.uint8)
_PLAIN_CLASS[list(b" \t\n\r\x0b\x0c")] = 0
_PLAIN_CLASS[list(b"0123456789")] = 1
#: Digits of the largest maxval (65535): a sample with more significant digits is above it.
_SAMPLE_DIGITS = 5
#: Significant digits of the largest header number given whole in an error message.
_HEADER_DIGITS = 100


def _plain_comments(u: np.ndarray, in_comment: bool) -> np.ndarray | None:
    """Mask (bool, like ``u``) of the bytes of ``u`` (uint8) in comments, ``#`` up to
    (not including) the next line feed or carriage return; ``in_comment`` if ``u`` starts
    inside one.  None if there is none."""
    hashes = u == ord("#")
    if not in_comment and not hashes.any():
        return None
    index = np.arange(u.size, dtype=np.int32)
    last_hash = np.maximum.accumulate(np.where(hashes, index, -1 if in_comment else -2))
    line_end = (u == ord("\n")) | (u == ord("\r"))
    last_newline = np.maximum.accumulate(np.where(line_end, index, -2 if in_comment else -1))
    return last_hash > last_newline


def _plain_word_error(u: np.ndarray, start: int, end: int, offset: int, path: Path) -> str:
    """The error message for the word ``u[start:end]`` (at ``offset + start`` in the file),
    which is not an unsigned decimal integer."""
    word = u[start : min(end, start + 24)].tobytes().decode("latin-1")
    word += "..." if end - start > 24 else ""
    signed = word[:1] in "+-" and word[1:].isdigit() and word[1:].isascii()
    return (
        f"map image {path}: plain PNM file with non-numeric entries: {word!r} at byte "
        f"{offset + start}{' has a sign' if signed else ''}; expected unsigned decimal integers"
    )


def _plain_words(
    buf: np.ndarray, path: Path
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray, int]]:
    """Yield ``(chunk, starts, ends, offset)`` for consecutive chunks of ``buf`` (uint8,
    the file after its magic number), cut after a separator: each chunk's words as
    [start, end) offsets (int64, (K,)) into ``chunk``, which starts at byte ``offset`` of
    ``buf``.  A ValueError for a word that is not all digits or fills a whole chunk."""
    pos, in_comment = 0, False
    while pos < buf.size:
        u = buf[pos : pos + _PLAIN_CHUNK]
        byte_class = _PLAIN_CLASS.take(u)
        comment = _plain_comments(u, in_comment)
        if comment is not None:
            byte_class[comment] = 0
        space = byte_class == 0
        last = u.size - 1 - int(np.argmax(space[::-1]))
        if not space[last] and u.size == _PLAIN_CHUNK:
            raise ValueError(
                f"map image {path}: plain PNM file with an entry of {_PLAIN_CHUNK} "
                f"characters or more at byte {pos + 2}"
            )
        if pos + u.size < buf.size:  # cut after the last separator
            u, space, byte_class = u[: last + 1], space[: last + 1], byte_class[: last + 1]
            in_comment = comment is not None and bool(comment[last])
        # word edges alternate: start, end, start, ...
        edges = np.flatnonzero(np.diff(np.concatenate(([True], space, [True])).view(np.int8)))
        starts, ends = edges[0::2], edges[1::2]
        bad = byte_class == 2
        if bad.any():
            k = int(np.searchsorted(starts, np.argmax(bad), side="right")) - 1
            raise ValueError(_plain_word_error(u, starts[k], ends[k], pos + 2, path))
        yield u, starts, ends, pos
        pos += u.size


def _digits_value(u: np.ndarray, first: np.ndarray, n: int) -> np.ndarray:
    """Values (int32, (K,)) of the ``n`` digits of ``u`` (uint8) from each of ``first``."""
    value = u[first].astype(np.int32) - ord("0")
    for j in range(1, n):
        value *= 10
        value += u[first + j]
        value -= ord("0")
    return value


def _plain_values(u: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Values (int32, (K,)) of the digit words ``u[starts[k]:ends[k]]``, computed for
    the words of each length at once; one above 99999 is given as 100000 (above any
    maxval)."""
    length = ends - starts
    values = np.empty(starts.size, dtype=np.int32)
    for n in range(1, _SAMPLE_DIGITS + 1):
        words = np.flatnonzero(length == n)
        if words.size:
            values[words] = _digits_value(u, starts[words], n)
    long = np.flatnonzero(length > _SAMPLE_DIGITS)
    if long.size:  # the last digits, after leading zeros or with more before them
        values[long] = _digits_value(u, ends[long] - _SAMPLE_DIGITS, _SAMPLE_DIGITS)
        nonzero = np.concatenate(([0], np.cumsum(u != ord("0"), dtype=np.int32)))
        leading = nonzero[ends[long] - _SAMPLE_DIGITS] - nonzero[starts[long]]
        values[long[leading > 0]] = 10**_SAMPLE_DIGITS
    return values


def _plain_header(words: list[bytes], path: Path) -> tuple[tuple[int, int, int], str | None]:
    """``(width, height, maxval)`` of a plain PNM header's three digit words, and the
    error message where they are not a valid header (else None)."""
    names = ("width", "height", "maxval")
    for name, word in zip(names, words, strict=True):
        digits = len(word.lstrip(b"0"))
        if digits > _HEADER_DIGITS:
            return (0, 0, 0), (
                f"map image {path}: plain PNM header: expected width, height >= 1 and "
                f"maxval 1..65535, received a {name} of {digits} digits"
            )
    width, height, maxval = (int(w.lstrip(b"0") or b"0") for w in words)
    if width < 1 or height < 1 or not 0 < maxval < 65536:
        return (width, height, maxval), (
            f"map image {path}: plain PNM header: expected width, height >= 1 and maxval "
            f"1..65535, received {width} x {height}, maxval {maxval}"
        )
    return (width, height, maxval), None


def _read_plain_pnm(data: bytes, path: Path) -> np.ndarray:
    """Pixels of a plain (ASCII) PGM ``P2`` or PPM ``P3`` file, exactly as written: uint8
    if its maxval is below 256, else uint16; (H, W) or (H, W, 3) RGB.

    Parsed in chunks of ``_PLAIN_CHUNK`` bytes with array operations: the memory used
    is the pixels and a scratch space proportional to the chunk, whatever the file
    size.  Faults are reported in this order: a word that is not an unsigned decimal integer, the header, the
    number of samples, samples above maxval.
    """
    channels = 3 if data[:2] == b"P3" else 1
    buf = np.frombuffer(data, dtype=np.uint8)[2:]
    header: list[bytes] = []
    size, maxval, error = (0, 0, 0), 0, None
    out, count, above = None, 0, False
    for u, starts, ends, offset in _plain_words(buf, path):
        if len(header) < 3:
            take = min(3 - len(header), starts.size)
            header += [u[s:e].tobytes() for s, e in zip(starts[:take], ends[:take], strict=True)]
            starts, ends = starts[take:], ends[take:]
            if len(header) == 3:
                size, error = _plain_header(header, path)
                maxval, expected = size[2], size[0] * size[1] * channels
                # allocated only if the rest of the file can hold that many numbers
                if error is None and expected <= (buf.size - offset + 1) // 2:
                    out = np.empty(expected, dtype=np.uint8 if maxval < 256 else np.uint16)
        values = _plain_values(u, starts, ends)
        if out is not None and count < out.size:
            stop = min(count + values.size, out.size)
            out[count:stop] = values[: stop - count]
        above |= values.size > 0 and int(values.max()) > maxval
        count += values.size
    if len(header) < 3:
        words = " ".join(w.decode("latin-1") for w in header)
        raise ValueError(
            f"map image {path}: incomplete plain PNM header: expected width, height and "
            f"maxval, received {words!r}"
        )
    if error is not None:
        raise ValueError(error)
    width, height, _ = size
    if out is None or count != out.size:
        raise ValueError(
            f"map image {path}: plain PNM file of {width} x {height} pixels must hold "
            f"{width * height * channels} values, found {count}"
        )
    if above:
        raise ValueError(f"map image {path} has pixel values above its PGM maxval {maxval}")
    return out.reshape((height, width) if channels == 1 else (height, width, 3))


def _png_size(data: bytes) -> tuple[int, int] | None:
    if data[:8] != b"\x89PNG\r\n\x1a\n" or data[12:16] != b"IHDR" or len(data) < 24:
        return None
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def _jpeg_frame(data: bytes) -> tuple[int, int, int] | None:
    """Width, height and number of colour components of a JPEG's first frame header
    (SOF0..SOF15 but DHT, JPG, DAC)."""
    pos, n = 2, len(data)
    while pos + 4 <= n and data[pos] == 0xFF:
        marker = data[pos + 1]
        if marker == 0xFF:  # fill byte
            pos += 1
            continue
        if marker == 0x01 or 0xD0 <= marker <= 0xD8:  # no length
            pos += 2
            continue
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            if pos + 10 > n:
                return None
            height = int.from_bytes(data[pos + 5 : pos + 7], "big")
            return int.from_bytes(data[pos + 7 : pos + 9], "big"), height, data[pos + 9]
        if marker == 0xDA:  # the scan starts: no frame header before it
            return None
        pos += 2 + int.from_bytes(data[pos + 2 : pos + 4], "big")
    return None


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    """Width and height of a JPEG's first frame header."""
    frame = _jpeg_frame(data)
    return None if frame is None else frame[:2]


def _bmp_size(data: bytes) -> tuple[int, int] | None:
    if data[:2] != b"BM" or len(data) < 26:
        return None
    if int.from_bytes(data[14:18], "little") == 12:  # OS/2 core header: 16-bit sizes
        return int.from_bytes(data[18:20], "little"), int.from_bytes(data[20:22], "little")
    width = int.from_bytes(data[18:22], "little", signed=True)
    return abs(width), abs(int.from_bytes(data[22:26], "little", signed=True))


def _tiff_size(data: bytes) -> tuple[int, int] | None:
    """Width and height of a (classic, not Big) TIFF's first image."""
    order = {b"II*\x00": "little", b"MM\x00*": "big"}.get(data[:4])
    if order is None:
        return None
    at = int.from_bytes(data[4:8], order)
    if at + 2 > len(data):
        return None
    found = {}
    for i in range(int.from_bytes(data[at : at + 2], order)):
        entry = data[at + 2 + 12 * i : at + 14 + 12 * i]
        if len(entry) < 12:
            return None
        tag, kind = int.from_bytes(entry[:2], order), int.from_bytes(entry[2:4], order)
        if tag in (256, 257) and kind in (3, 4):  # ImageWidth, ImageLength: SHORT or LONG
            value = entry[8:10] if kind == 3 else entry[8:12]
            found[tag] = int.from_bytes(value, order)
    return (found[256], found[257]) if len(found) == 2 else None


def _pnm_size(data: bytes) -> tuple[int, int] | None:
    if len(data) < 2 or data[:1] != b"P" or data[1:2] not in b"2356":
        return None
    tokens = pnm_header_tokens(data[: 1 << 16])[0]
    if len(tokens) < 2 or not all(t.isdigit() and len(t) <= 20 for t in tokens[:2]):
        return None  # the readers report a header that is not two numbers
    width, height = int(tokens[0]), int(tokens[1])
    if data[1:2] in b"23" and len(data) < 2 * width * height:
        return None  # plain text too short for its samples: refused as such, unread
    return width, height


def _gif_size(data: bytes) -> tuple[int, int] | None:
    """Width and height of a GIF's logical screen (what the decoders return)."""
    if data[:6] not in (b"GIF87a", b"GIF89a") or len(data) < 10:
        return None
    return int.from_bytes(data[6:8], "little"), int.from_bytes(data[8:10], "little")


def _webp_size(data: bytes) -> tuple[int, int] | None:
    """Width and height of a WebP's canvas (VP8X) or its one frame (VP8L, VP8)."""
    if data[:4] != b"RIFF" or data[8:12] != b"WEBP" or len(data) < 30:
        return None
    kind = data[12:16]
    if kind == b"VP8X":  # 24-bit canvas width - 1 and height - 1
        return 1 + int.from_bytes(data[24:27], "little"), 1 + int.from_bytes(data[27:30], "little")
    if kind == b"VP8L" and data[20] == 0x2F:  # 14-bit width - 1 and height - 1
        bits = int.from_bytes(data[21:25], "little")
        return 1 + (bits & 0x3FFF), 1 + ((bits >> 14) & 0x3FFF)
    if kind == b"VP8 " and data[23:26] == b"\x9d\x01\x2a":  # a key frame: 14-bit sizes
        width = int.from_bytes(data[26:28], "little") & 0x3FFF
        return width, int.from_bytes(data[28:30], "little") & 0x3FFF
    return None


def _jpeg2000_size(data: bytes) -> tuple[int, int] | None:
    """Width and height of a JPEG 2000 image: a JP2 file's ``ihdr`` box, or a bare
    codestream's SIZ marker (the image area less its offset)."""
    if data[:4] == b"\xff\x4f\xff\x51":  # SOC, SIZ: Lsiz Rsiz Xsiz Ysiz XOsiz YOsiz
        if len(data) < 24:
            return None
        x, y, x0, y0 = (int.from_bytes(data[k : k + 4], "big") for k in range(8, 24, 4))
        return (x - x0, y - y0) if x >= x0 and y >= y0 else None
    if data[:12] != b"\x00\x00\x00\x0cjP  \r\n\x87\n":
        return None
    pos = 12
    while pos + 8 <= len(data):  # boxes: length, type[, 64-bit length]; ihdr is in jp2h
        length, kind, head = int.from_bytes(data[pos : pos + 4], "big"), data[pos + 4 : pos + 8], 8
        if length == 1:
            length, head = int.from_bytes(data[pos + 8 : pos + 16], "big"), 16
        if kind == b"ihdr":  # HEIGHT, WIDTH
            body = data[pos + head : pos + head + 8]
            if len(body) < 8:
                return None
            return int.from_bytes(body[4:], "big"), int.from_bytes(body[:4], "big")
        if kind == b"jp2h":  # a box of boxes: into it
            pos += head
        elif length < head:  # 0: the last box, to the end of the file
            return None
        else:
            pos += length
    return None


def _pil_size(data: bytes) -> tuple[int, int] | None:
    """Width and height of an image in a format PIL reads, from its header (PIL opens an
    image lazily); None where PIL reads none, or refuses to open the image as larger than
    twice its ``MAX_IMAGE_PIXELS`` (its own guard against decompression bombs)."""
    import io as _stdio

    from PIL import Image

    try:
        with Image.open(_stdio.BytesIO(data)) as im:
            return im.size
    except Exception:  # PIL raises many exception types for input it cannot read
        return None


def _declared_size(data: bytes) -> tuple[int, int] | None:
    """``(width, height)`` that the header of image file bytes ``data`` gives, read
    without decoding: here for PNG, JPEG, BMP, TIFF, PGM / PPM, GIF, WebP and JPEG 2000,
    by PIL for the other formats it reads; None where it gives none (a format neither
    reads, a header cut short)."""
    for read in (
        _png_size,
        _pnm_size,
        _jpeg_size,
        _bmp_size,
        _tiff_size,
        _gif_size,
        _webp_size,
        _jpeg2000_size,
    ):
        size = read(data)
        if size is not None:
            return size
    if data[:2] in (b"P2", b"P3", b"P5", b"P6"):  # the readers report what is not read here
        return None
    return _pil_size(data)


def _check_declared_size(data: bytes, path: Path) -> None:
    """A MemoryError where the header of ``data`` (read from ``path``) gives an image
    that decoding and classifying cannot fit in the memory available
    (:data:`DECODE_BYTES_PER_PIXEL`, :func:`~topojax._cpus.available_memory_bytes`),
    raised before any pixel is decoded; a ValueError where it gives no pixels, or more
    than the decoders decode."""
    size = _declared_size(data)
    if size is None:
        return
    width, height = size
    if not (width and height) and data[:2] not in (b"P2", b"P3"):  # those say it themselves
        raise ValueError(
            f"map image {path}: its header gives {width} x {height} pixels; expected an "
            "image of at least 2 x 2 pixels"
        )
    if data[:2] == b"P5":  # 16-bit or maxval not 255 (not memory-mapped): tiled reads it
        advice = (
            "; build its topology graph with build_graph_tiled (topojax graph --tiled), "
            "which reads this binary PGM a window at a time"
        )
    else:
        advice = (
            "; save a map this large as a binary 8-bit PGM, which load_map memory-maps "
            "instead of decoding (and build_graph_tiled, topojax graph --tiled, reads a "
            "window at a time)"
        )
    check_fits_memory(
        width * height * DECODE_BYTES_PER_PIXEL,
        f"map image {path}: its header gives {width} x {height} pixels, and decoding and "
        f"classifying them ({DECODE_BYTES_PER_PIXEL} bytes a pixel) takes at least",
        advice,
    )
    plain = data[:2] in (b"P2", b"P3")  # read here, not decoded
    limits = None if plain else decoder_limits(width, height)
    if limits is not None:
        raise ValueError(
            f"map image {path}: expected an image of {limits}, received one of {width} x "
            f"{height} pixels; save a map this large as a binary 8-bit PGM, which load_map "
            "memory-maps instead of decoding (and build_graph_tiled, topojax graph --tiled, "
            "reads a window at a time)"
        )


#: How much of an image file :func:`read_image` reads for its header before the rest: a
#: file larger than the memory available would otherwise end the process as it is read.
_HEAD_BYTES = 1 << 20


def read_image(path: Path) -> tuple[np.ndarray, int, list[str]]:
    """Read an image file.

    Returns
    -------
    pixels : np.ndarray of uint8 or uint16, (H, W) or (H, W, C)
    full_scale : int
        Intensity of white (255, 65535 or a PGM maxval).
    comments : list of str
        The PGM/PPM header's comment lines (see :func:`resolution_from_pgm_comments`).

    Raises
    ------
    ValueError
        An image that cannot be decoded, whose header gives no pixels, whose data the
        decoder reports damaged, or a file of several images (pages, frames).
    MemoryError
        An image whose header gives more pixels than the memory available can decode
        (checked before decoding).
    """
    path = existing_file("path", path)
    with open(path, "rb") as f:
        head = f.read(_HEAD_BYTES)
        if len(head) == _HEAD_BYTES:  # more to come: what the header gives must fit first
            _check_declared_size(head, path)
            f.seek(0)
        data = head if len(head) < _HEAD_BYTES else f.read()
    if not data:
        raise ValueError(f"map image {path} is empty (0 bytes)")
    _check_declared_size(data, path)
    refuse_several_images(data, path)
    maxval, comments = _parse_pnm_header(data)
    if data[:2] in (b"P2", b"P3"):
        # Plain (ASCII) PGM / PPM: OpenCV and PIL rescale these to 0..255 when the maxval
        # is not 255 (with rounding), while binary files keep their values; read them here
        # so that both are classified against their own maxval.
        pixels = _read_plain_pnm(data, path)
    else:
        frame = _jpeg_frame(data) if data[:2] == b"\xff\xd8" else None
        pixels = decode_image(data, path, cmyk_jpeg=frame is not None and frame[2] == 4)
    if pixels.dtype == np.uint8:
        full = 255
    elif pixels.dtype == np.uint16:
        full = 65535
    else:
        raise ValueError(
            f"map image {path} has unsupported sample type {pixels.dtype}; "
            "expected 8-bit or 16-bit unsigned integers"
        )
    if maxval is not None and maxval not in (255, 65535):
        if not 0 < maxval < 65536:
            raise ValueError(f"map image {path} has invalid PGM maxval {maxval}")
        if int(pixels.max()) > maxval:
            raise ValueError(f"map image {path} has pixel values above its PGM maxval {maxval}")
        full = maxval
    if pixels.ndim == 3 and pixels.shape[2] not in (1, 2, 3, 4):
        raise ValueError(f"map image {path} has {pixels.shape[2]} channels; expected 1 to 4")
    return pixels, full, comments
