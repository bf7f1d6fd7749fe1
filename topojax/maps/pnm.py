"""Map image files: PGM/PPM headers and their resolution comments, plain (ASCII) PNM, and
decoding with OpenCV or PIL."""

from __future__ import annotations

import contextlib
import math
import re
import threading
from pathlib import Path

import numpy as np

from .._validate import existing_file

__all__ = ["pnm_header_tokens", "read_image", "resolution_from_pgm_comments"]

_SILENCE_LOCK = threading.Lock()
_SILENCE = {"depth": 0, "level": None}


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


# the whitespace-delimited word before "m/pix" (map_saver writes "0.050 m/pix")
_PGM_RES_RE = re.compile(r"(?:^|\s)(\S+)\s*m/pix")
# the number-like end of that word: digits with dots, commas, a sign or an exponent
_PGM_NUMBER_RE = re.compile(r"[-+]?[0-9.,]*[0-9][0-9.,]*(?:[eE][-+]?[0-9]+)?$")


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
        if ch == b"#":
            end = data.find(b"\n", pos)
            end = n if end < 0 else end
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
    no comment gives one.  A number that is not a positive one (``0,05``, ``-0.05``) is an
    error rather than a misread: the map would be scaled wrongly without notice."""
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
                "resolution_m (--resolution) to set it"
            )
        return value
    return None


def _read_plain_pnm(data: bytes, path: Path) -> np.ndarray:
    """Pixels of a plain (ASCII) PGM ``P2`` or PPM ``P3`` file, exactly as written: uint8
    if its maxval is below 256, else uint16; (H, W) or (H, W, 3) RGB."""
    tokens = re.sub(rb"#[^\n]*", b" ", data[2:]).split()
    channels = 3 if data[:2] == b"P3" else 1
    try:
        width, height, maxval = (int(t) for t in tokens[:3])
        values = np.array(tokens[3:], dtype=np.bytes_).astype(np.int64)
    except ValueError:
        raise ValueError(f"map image {path}: plain PNM file with non-numeric entries") from None
    if width < 1 or height < 1 or not 0 < maxval < 65536:
        raise ValueError(
            f"map image {path}: plain PNM header: expected width, height >= 1 and maxval "
            f"1..65535, received {width} x {height}, maxval {maxval}"
        )
    expected = width * height * channels
    if values.size != expected:
        raise ValueError(
            f"map image {path}: plain PNM file of {width} x {height} pixels must hold "
            f"{expected} values, found {values.size}"
        )
    if values.min() < 0 or values.max() > maxval:
        raise ValueError(f"map image {path} has pixel values above its PGM maxval {maxval}")
    dtype = np.uint8 if maxval < 256 else np.uint16
    shape = (height, width) if channels == 1 else (height, width, 3)
    return values.astype(dtype).reshape(shape)


def _decode_with_pil(data: bytes) -> np.ndarray | None:
    import io as _stdio

    from PIL import Image

    try:
        with Image.open(_stdio.BytesIO(data)) as im:
            im.load()
            if im.mode in ("P", "PA"):
                im = im.convert("RGBA")
            elif im.mode == "1":
                im = im.convert("L")
            return np.asarray(im)
    except Exception:  # PIL raises many exception types for undecodable input
        return None


def read_image(path: Path) -> tuple[np.ndarray, int, list[str]]:
    """Read an image file.

    Returns
    -------
    pixels : np.ndarray of uint8 or uint16, (H, W) or (H, W, C)
    full_scale : int
        Intensity of white (255, 65535 or a PGM maxval).
    comments : list of str
        The PGM/PPM header's comment lines (see :func:`resolution_from_pgm_comments`).
    """
    import cv2

    path = existing_file("path", path)
    data = path.read_bytes()
    if not data:
        raise ValueError(f"map image {path} is empty (0 bytes)")
    maxval, comments = _parse_pnm_header(data)
    pixels: np.ndarray | None = None
    if data[:2] in (b"P2", b"P3"):
        # Plain (ASCII) PGM / PPM: OpenCV and PIL rescale these to 0..255 when the maxval
        # is not 255 (with rounding), while binary files keep their values; read them here
        # so that both are classified against their own maxval.
        pixels = _read_plain_pnm(data, path)
    else:
        # a file OpenCV cannot read gets our error below (or PIL reads it): not also
        # OpenCV's own log line on stderr
        with _opencv_silenced(cv2):
            try:
                pixels = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
            except cv2.error:
                pixels = None
    if pixels is None or pixels.size == 0:
        pixels = _decode_with_pil(data)
    if pixels is None or pixels.size == 0:
        raise ValueError(f"could not decode map image {path} (corrupt or unsupported format)")
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
