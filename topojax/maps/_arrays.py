"""Windows of a map array held in memory or memory-mapped, for :class:`TiledMap`.

A block task of an executor pickles the map it reads.  An array in memory goes with its
pixels; one memory-mapped from a file (``numpy.memmap``, ``np.load(..., mmap_mode="r")``)
goes as its file name and layout and is mapped again where it is read, as a PGM is, so
that a map larger than memory can be sent at all, and each task costs a few hundred
bytes rather than the whole map.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["_ArrayReader"]


class _ArrayReader:
    """Windows of an array in memory or memory-mapped."""

    def __init__(self, array: np.ndarray) -> None:
        if array.ndim != 2:
            raise ValueError(f"array: expected a 2-D (H, W) array, received shape {array.shape}")
        self.array = array
        self.shape = array.shape
        self.dtype = array.dtype

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        return self.array[r0:r1, c0:c1]

    def __getstate__(self) -> dict[str, Any]:
        layout = _file_layout(self.array)
        return {"array": self.array} if layout is None else {"mapped": layout}

    def __setstate__(self, state: dict[str, Any]) -> None:
        if "array" in state:
            self.__init__(state["array"])
            return
        path, start, span, shape, strides, dtype = state["mapped"]
        raw = np.memmap(path, dtype=np.uint8, mode="r", offset=start, shape=(span,))
        self.__init__(np.ndarray(shape, np.dtype(dtype), buffer=raw, strides=strides))


def _file_layout(array: np.ndarray) -> tuple | None:
    """``(file, first byte, bytes spanned, shape, strides, dtype)`` of ``array`` where it
    is a view of a ``numpy.memmap`` of a file with non-negative strides; else None."""
    mapped = array  # the memmap that mapped the file: a slice of one keeps its offset
    while isinstance(getattr(mapped, "base", None), np.ndarray):
        mapped = mapped.base
    if not isinstance(mapped, np.memmap) or getattr(mapped, "filename", None) is None:
        return None
    if any(s < 0 for s in array.strides) or array.size == 0:
        return None
    start = array.__array_interface__["data"][0] - mapped.__array_interface__["data"][0]
    span = sum((n - 1) * s for n, s in zip(array.shape, array.strides, strict=True))
    span += array.itemsize
    return (
        mapped.filename,
        int(mapped.offset) + int(start),
        int(span),
        tuple(array.shape),
        tuple(array.strides),
        array.dtype.str,
    )
