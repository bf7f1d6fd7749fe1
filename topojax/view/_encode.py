"""Compact encodings of the viewer's data: numeric arrays as zlib-compressed little-endian
bytes in base64, and 8-bit rasters as pyramids of PNG tiles.

The page decodes arrays with the browser's ``DecompressionStream("deflate")`` (zlib
format) and tiles with its PNG decoder, and colours the one-channel tiles itself (a grey
map, a colour scale for the distance map, one colour for a mask), so every raster is
shipped as a single 8-bit channel, which PNG compresses best.
"""

from __future__ import annotations

import base64
import zlib
from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np

from .._cpus import usable_cpus

__all__ = ["TILE_PX", "packed", "pyramid", "unpacked"]

#: Side of the PNG tiles, pixels of their pyramid level.
TILE_PX = 512

# numpy dtype -> the typed-array name the page reads
_TYPES = {
    np.dtype(np.int8): "i1",
    np.dtype(np.uint8): "u1",
    np.dtype(np.int16): "i2",
    np.dtype(np.int32): "i4",
    np.dtype(np.uint32): "u4",
    np.dtype(np.float32): "f4",
    np.dtype(np.float64): "f8",
}


def packed(values, dtype) -> dict:
    """``values`` as ``{"t": type, "n": count, "z": base64 of zlib of the raw bytes}``.

    Parameters
    ----------
    values : array_like
        Flattened in C order.
    dtype : numpy dtype
        One of int8, uint8, int16, int32, uint32, float32, float64; stored little-endian.
    """
    dt = np.dtype(dtype)
    a = np.ascontiguousarray(np.asarray(values).ravel(), dtype=dt.newbyteorder("<"))
    raw = zlib.compress(a.tobytes(), 6)
    return {"t": _TYPES[dt], "n": int(a.size), "z": base64.b64encode(raw).decode("ascii")}


def unpacked(doc: dict) -> np.ndarray:
    """The flat array (native byte order) of a :func:`packed` ``doc``.

    Raises
    ------
    ValueError
        If ``doc`` is not such a dict or its bytes do not decode to its count.
    """
    names = {name: dt for dt, name in _TYPES.items()}
    try:
        dt = names[doc["t"]]
        raw = zlib.decompress(base64.b64decode(doc["z"], validate=True))
        a = np.frombuffer(raw, dt.newbyteorder("<")).astype(dt)
        ok = a.size == int(doc["n"])
    except (KeyError, TypeError, ValueError, zlib.error) as exc:
        raise ValueError(f"not a packed array ({exc!r})") from None
    if not ok:
        raise ValueError(f"packed array: expected {doc['n']} values, decoded {a.size}")
    return a


def _png(image: np.ndarray) -> str:
    ok, buf = cv2.imencode(".png", image, [cv2.IMWRITE_PNG_COMPRESSION, 6])
    if not ok:  # pragma: no cover - cv2 encodes any uint8 2-D array
        raise RuntimeError("PNG encoding failed")
    return base64.b64encode(buf.tobytes()).decode("ascii")


def _halve(image: np.ndarray, how: str) -> np.ndarray:
    """``image`` at half size (odd sides rounded up), each pixel from its 2 x 2 block:
    ``"min"``, ``"max"`` or ``"mean"`` of the pixels the block has, or ``"map"``: 0 when
    the block has a 0 (an obstacle of a map image), else its maximum."""
    h, w = image.shape
    ph, pw = h + h % 2, w + w % 2
    if (ph, pw) != (h, w):
        # repeat the last row / column: the block's statistic is that of its own pixels
        image = np.pad(image, ((0, ph - h), (0, pw - w)), mode="edge")
    a, b = image[0::2, 0::2], image[0::2, 1::2]
    c, d = image[1::2, 0::2], image[1::2, 1::2]
    if how == "mean":
        total = a.astype(np.uint16) + b + c + d
        return ((total + 2) >> 2).astype(np.uint8)
    low = np.minimum(np.minimum(a, b), np.minimum(c, d))
    if how == "min":
        return low
    high = np.maximum(np.maximum(a, b), np.maximum(c, d))
    if how == "max":
        return high
    return np.where(low == 0, low, high)  # "map": an obstacle wins, else the lightest


def pyramid(
    image: np.ndarray,
    *,
    reduce: str,
    max_side_px: int | None = None,
    blank: int | None = None,
    min_step: int = 1,
) -> dict:
    """An 8-bit raster as PNG tiles at full size and halved again and again.

    Parameters
    ----------
    image : uint8 (H, W)
        The raster, row 0 at the top.
    reduce : {"map", "min", "max", "mean"}
        How a level's pixel comes from its 2 x 2 block of the level below: ``"map"`` keeps
        the obstacles (0) of a map image and shows free (lighter) over unknown, ``"min"``
        keeps dark pixels, ``"max"`` keeps thin lines of a mask, ``"mean"`` suits smooth
        fields.
    blank : int, optional
        Tiles of this value only are left out (the page draws nothing there), e.g. 0 for a
        mask; default: every tile is kept.
    max_side_px : int, optional
        The finest level shipped is the first whose longer side is at most this (a smooth
        field needs no full resolution; below a tile, it is the only level); default: full
        size.
    min_step : int
        Nor any level finer than this many map pixels per level pixel (a power of two;
        for layers the page draws otherwise when zoomed in).

    Returns
    -------
    dict
        ``{"width", "height", "tile", "levels": [{"step", "width", "height", "tiles":
        [[row, col, png_base64], ...]}, ...]}`` where level ``k`` has ``step`` map pixels
        per level pixel (a power of two), finest first.  The coarsest level fits in one
        tile.
    """
    image = np.ascontiguousarray(image, dtype=np.uint8)
    h, w = image.shape
    levels = []
    step, level = 1, image
    while True:
        fits = max_side_px is None or max(level.shape) <= max_side_px
        if fits and step >= min_step:
            levels.append(_level_tiles(level, step, blank))
        if max(level.shape) <= TILE_PX and fits:  # a level of one tile, and one shipped
            break
        level = _halve(level, reduce)
        step *= 2
    return {"width": w, "height": h, "tile": TILE_PX, "levels": levels}


def _level_tiles(level: np.ndarray, step: int, blank: int | None) -> dict:
    lh, lw = level.shape
    keep = []
    for r0 in range(0, lh, TILE_PX):
        for c0 in range(0, lw, TILE_PX):
            tile = level[r0 : r0 + TILE_PX, c0 : c0 + TILE_PX]
            if blank is None or (tile != blank).any():
                keep.append((r0 // TILE_PX, c0 // TILE_PX, tile))
    if len(keep) > 4:  # OpenCV's encoder releases the GIL: tiles encode side by side
        with ThreadPoolExecutor(max_workers=min(4, usable_cpus())) as pool:
            pngs = list(pool.map(_png, [t for *_, t in keep]))
    else:
        pngs = [_png(t) for *_, t in keep]
    tiles = [[r, c, png] for (r, c, _), png in zip(keep, pngs, strict=True)]
    return {"step": step, "width": lw, "height": lh, "tiles": tiles}
