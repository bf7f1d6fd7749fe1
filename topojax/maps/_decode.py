"""Decoding map image files with OpenCV, or PIL where OpenCV cannot: the messages the C
decoders print on standard error kept off it (and turned into the error where they say the
file is damaged), and files that hold several images refused."""

from __future__ import annotations

import contextlib
import io
import os
import re
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np

__all__ = ["decode_image", "decoder_limits", "refuse_several_images"]

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

#: The lines libpng and libjpeg (inside OpenCV) print on standard error.
_DECODER_LINE = re.compile(
    r"libpng (?:warning|error): |Corrupt JPEG data|Premature end of JPEG file|"
    r"Invalid SOS parameters|Inconsistent progression sequence|Warning: unknown JFIF"
)
#: libjpeg's words for compressed data it could not decode as written: it returns pixels
#: all the same, some of them made up.
_JPEG_DAMAGE = re.compile(
    r"Corrupt JPEG data|Premature end of JPEG file|Invalid SOS parameters|"
    r"Inconsistent progression sequence"
)
#: libjpeg's word for bytes it skipped to reach a marker: compressed data left over where
#: the decoder lost its place (damage), or padding before the end of the image (none).
_JPEG_SKIPPED = re.compile(r"Corrupt JPEG data: (\d+) extraneous bytes before marker 0xd9$")

_SILENCE_LOCK = threading.Lock()
_SILENCE = {"depth": 0, "level": None}
#: Held while standard error is taken from the process to hear a decoder.
_STDERR_LOCK = threading.Lock()


@contextlib.contextmanager
def _opencv_silenced(cv2):
    """OpenCV's (process-wide) log level set to silent while any thread is inside; the
    first to enter saves the level and the last to leave restores it, so overlapping
    readers (the batch loads maps on two threads) cannot leave it silent."""
    with _SILENCE_LOCK:
        if _SILENCE["depth"] == 0:
            _SILENCE["level"] = cv2.utils.logging.getLogLevel()
            cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
        _SILENCE["depth"] += 1
    try:
        yield
    finally:
        with _SILENCE_LOCK:
            _SILENCE["depth"] -= 1
            if _SILENCE["depth"] == 0:
                cv2.utils.logging.setLogLevel(_SILENCE["level"])


@contextlib.contextmanager
def _decoder_messages() -> Iterator[list[str]]:
    """Standard error (file descriptor 2) sent to a file while inside, one thread at a
    time: the list yielded then holds the lines libpng and libjpeg printed there, and the
    other bytes (another thread's) are written on to standard error as they came. Where
    there is no temporary file to send it to (no writable folder, a full disk) or no
    standard error, the list stays empty and the lines go where standard error goes."""
    lines: list[str] = []
    with _STDERR_LOCK:
        if sys.stderr is not None:
            with contextlib.suppress(OSError, ValueError):  # closed, or not a file
                sys.stderr.flush()
        try:
            sink = tempfile.TemporaryFile()
        except OSError:
            sink = None
        if sink is None:
            yield lines
            return
        with sink:
            try:
                saved = os.dup(2)
            except OSError:  # no standard error to keep them off
                saved = None
            if saved is None:
                yield lines
                return
            try:
                os.dup2(sink.fileno(), 2)
                yield lines
            finally:
                try:
                    os.dup2(saved, 2)
                finally:
                    os.close(saved)
                sink.seek(0)
                others = []
                for line in sink.read().splitlines(keepends=True):
                    text = line.decode("utf-8", "replace")
                    if _DECODER_LINE.match(text):
                        lines.append(text.rstrip("\r\n"))
                    else:
                        others.append(line)
                if others:  # as written, a carriage return (a progress line) included
                    os.write(2, b"".join(others))


def _is_jpeg_padding(message: str, data: bytes) -> bool:
    """Whether the bytes libjpeg's ``message`` says it skipped before an end-of-image
    marker of ``data`` are zeros: padding some writers add, skipped after the last pixel
    is decoded. Other bytes are refused: they are what most damage within the compressed
    data leaves, the decoder out of step and done before the data is, and that data ends
    in the encoder's last byte, which holds an end-of-block code or the one bits that
    pad it. Zeros before another marker are refused too: libjpeg prints its first
    warning only, so that one would hide the damage after it."""
    skipped = _JPEG_SKIPPED.match(message)
    if not skipped:
        return False
    count = int(skipped[1])
    at = data.find(b"\xff\xd9")
    while at >= 0:
        start = at  # the marker's first byte: libjpeg skips 0xFF fill without counting it
        while start > 0 and data[start - 1] == 0xFF:
            start -= 1
        if start >= count and data[start - count : start] == bytes(count):
            return True
        at = data.find(b"\xff\xd9", at + 2)
    return False


def _env_int(name: str, default: int) -> int:
    try:
        return int(os.environ.get(name, default))
    except ValueError:
        return default


def decoder_limits(width: int, height: int) -> str | None:
    """What OpenCV and PIL decode, in words, where an image of ``width`` x ``height``
    exceeds what both decode (OpenCV: at most ``OPENCV_IO_MAX_IMAGE_PIXELS``, 2^30 by
    default, and 2^20 a side; PIL: twice ``PIL.Image.MAX_IMAGE_PIXELS``, above which it
    refuses the image as a decompression bomb), else None."""
    from PIL import Image

    pixels = width * height
    opencv = _env_int("OPENCV_IO_MAX_IMAGE_PIXELS", 1 << 30)
    wide = _env_int("OPENCV_IO_MAX_IMAGE_WIDTH", 1 << 20)
    high = _env_int("OPENCV_IO_MAX_IMAGE_HEIGHT", 1 << 20)
    opencv_fits = pixels <= opencv and width <= wide and height <= high
    pil = Image.MAX_IMAGE_PIXELS
    if opencv_fits or pil is None or pixels <= 2 * pil:
        return None
    side = f"{wide:,} pixels a side" if wide == high else f"{wide:,} wide and {high:,} high"
    return (
        f"at most {2 * pil:,} pixels (what PIL decodes) or at most {opencv:,} pixels and "
        f"{side} (what OpenCV decodes)"
    )


def _decode_with_pil(data: bytes) -> tuple[np.ndarray | None, str]:
    """The pixels PIL decodes from ``data`` (CMYK and YCbCr converted to RGB), or None and
    PIL's reason (empty where PIL does not know the format)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(io.BytesIO(data)) as im:
            im.load()
            if im.mode in ("P", "PA"):
                im = im.convert("RGBA")
            elif im.mode == "1":
                im = im.convert("L")
            elif im.mode in ("CMYK", "YCbCr"):
                im = im.convert("RGB")
            return np.asarray(im), ""
    except UnidentifiedImageError:
        return None, ""
    except Exception as exc:  # PIL raises many exception types for undecodable input
        return None, str(exc) or type(exc).__name__


def decode_image(data: bytes, path: Path, *, cmyk_jpeg: bool = False) -> np.ndarray:
    """The pixels of image file bytes ``data`` (read from ``path``): OpenCV's (BGR order),
    PIL's where OpenCV decodes none (and for a CMYK JPEG, ``cmyk_jpeg``, which OpenCV
    converts a grey level too light: the ``map_saver`` unknown 205 becomes a free 206).

    A ValueError naming ``path`` where neither decodes the file, where libpng refuses it
    as damaged (PIL would read past a bad checksum or a missing end), or where libjpeg
    says its data is corrupt (it fills in what it cannot decode; zero bytes it skips
    before the end marker are padding, not damage)."""
    import cv2

    messages: list[str] = []
    pixels = None
    if not cmyk_jpeg:
        with _opencv_silenced(cv2), _decoder_messages() as messages:
            try:
                pixels = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
            except cv2.error:
                pixels = None
    damage = [m for m in messages if _JPEG_DAMAGE.match(m) and not _is_jpeg_padding(m, data)]
    if damage:
        raise ValueError(
            f"map image {path}: its JPEG data is damaged (the decoder reports "
            f"{'; '.join(damage)!r}), so some of its pixels would be made up; expected an "
            "undamaged file: export the map again (PNG or PGM keep its values exactly)"
        )
    failed = pixels is None or pixels.size == 0
    png_errors = [m[len("libpng error: ") :] for m in messages if m.startswith("libpng error: ")]
    if failed and data[:8] == _PNG_SIGNATURE and png_errors:
        raise ValueError(
            f"could not decode map image {path}: its PNG data is damaged (libpng: "
            f"{'; '.join(png_errors)}); expected a complete PNG file with valid checksums"
        )
    reason = ""
    if failed:
        pixels, reason = _decode_with_pil(data)
    if pixels is None or pixels.size == 0:
        received = (
            f"a file that is none (it starts with {data[:16]!r})"
            if not reason
            else f"one PIL does not decode: {reason}"
        )
        raise ValueError(
            f"could not decode map image {path}: expected a complete image file (PNG, "
            f"JPEG, BMP, TIFF, PGM or another format OpenCV or PIL reads), received {received}"
        )
    return pixels


def _png_frames(data: bytes) -> int:
    """The frames of an animated PNG (its ``acTL`` chunk's count); 1 for a still one."""
    pos = len(_PNG_SIGNATURE)
    while pos + 12 <= len(data):
        length, kind = int.from_bytes(data[pos : pos + 4], "big"), data[pos + 4 : pos + 8]
        if kind == b"acTL":
            return max(1, int.from_bytes(data[pos + 8 : pos + 12], "big"))
        if kind in (b"IDAT", b"IEND"):  # acTL comes before the image data
            return 1
        pos += 12 + length
    return 1


def _tiff_pages(data: bytes) -> int:
    """The full-resolution images of a classic TIFF: its image file directories less
    those of reduced-resolution copies (thumbnails, overviews) and transparency masks."""
    order = {b"II*\x00": "little", b"MM\x00*": "big"}[data[:4]]

    def number(at: int, size: int) -> int:
        return int.from_bytes(data[at : at + size], order)

    pages, at, seen = 0, number(4, 4), set()
    while 8 <= at and at + 2 <= len(data) and at not in seen:
        seen.add(at)
        count, subfile = number(at, 2), 0
        for entry in range(at + 2, at + 2 + 12 * count, 12):
            tag, kind = number(entry, 2), number(entry + 2, 2)
            value = number(entry + 8, 4 if kind == 4 else 2)
            if tag == 254:  # NewSubfileType: 1 reduced resolution, 4 transparency mask
                subfile = value
            elif tag == 255 and value == 2:  # SubfileType: reduced resolution
                subfile = 1
        pages += not subfile & 0b101
        at = number(at + 2 + 12 * count, 4)
    return max(pages, 1)


def _pil_frames(data: bytes) -> int:
    """The frames PIL counts in an image file (a GIF, a WebP); 1 where it opens none."""
    from PIL import Image

    try:
        with Image.open(io.BytesIO(data)) as im:
            return int(getattr(im, "n_frames", 1))
    except Exception:  # PIL raises many exception types for input it cannot read
        return 1


def refuse_several_images(data: bytes, path: Path) -> None:
    """A ValueError naming ``path`` where image file bytes ``data`` hold more than one
    image, of which a decoder would return the first without a word: the pages of a TIFF
    (not counting reduced-resolution copies), the frames of an animated PNG, GIF or
    WebP. A JPEG's extra images (MPO previews) and a PNM's are not counted."""
    if data[:8] == _PNG_SIGNATURE:
        count, what = _png_frames(data), "frames (an animated PNG)"
    elif data[:4] in (b"II*\x00", b"MM\x00*"):
        count, what = _tiff_pages(data), "pages (a multi-page TIFF)"
    elif data[:2] == b"\xff\xd8" or data[:1] == b"P" or data[:2] == b"BM":
        return
    else:
        count, what = _pil_frames(data), "frames (an animation)"
    if count > 1:
        raise ValueError(
            f"map image {path} holds {count} {what}; expected a single image: save the "
            "one that is the map as a file of its own"
        )
