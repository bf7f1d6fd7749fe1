""".npy arrays read only once their file holds what their header gives: a header is a
claim, and ``numpy.load`` allocates the array it claims before reading a byte of it; and
.npz archives written at a chosen zlib level."""

from __future__ import annotations

import math
import zipfile
from typing import BinaryIO

import numpy as np

from ._cpus import check_fits_memory

__all__ = [
    "check_npy_size",
    "check_npz_fits",
    "check_npz_sizes",
    "load_npy",
    "savez_deflated",
]

_HEADER_READERS = {
    (1, 0): np.lib.format.read_array_header_1_0,
    (2, 0): np.lib.format.read_array_header_2_0,
}


def load_npy(path, *, mmap_mode: str | None = None) -> np.ndarray:
    """``numpy.load`` of the ``.npy`` file ``path``, pickles refused.  A file that does not
    begin with the ``.npy`` magic string is a ValueError saying so (numpy takes it for a
    pickle and advises loading it unsafely); an empty one is numpy's EOFError."""
    magic = np.lib.format.MAGIC_PREFIX
    with open(path, "rb") as fh:
        head = fh.read(len(magic))
    if head and head != magic:
        raise ValueError(
            f"expected a file that begins with the .npy magic string {magic!r}, received "
            f"one that begins with {head!r}"
        )
    return np.load(path, mmap_mode=mmap_mode, allow_pickle=False)


def check_npy_size(fh: BinaryIO, size: int, where: str) -> None:
    """A ValueError naming ``where`` unless the ``.npy`` data of ``size`` bytes (its
    header included) read from ``fh`` (at its start) holds the whole array its header
    gives.  A header numpy cannot read (or of a version read here) is left to
    ``numpy.load``, which reports it."""
    try:
        version = np.lib.format.read_magic(fh)
        read_header = _HEADER_READERS.get(version)
        if read_header is None:
            return
        shape, _, dtype = read_header(fh)
    except ValueError:
        return
    need = math.prod(shape) * dtype.itemsize
    have = size - fh.tell()
    if need > have:
        raise ValueError(
            f"{where}: expected the {need:,} bytes of the {dtype.str} {tuple(shape)} array "
            f"its header gives, received {max(have, 0):,} bytes after the header (the file "
            "was cut short or its header altered)"
        )


def check_npz_sizes(npz) -> None:
    """:func:`check_npy_size` for every member of ``npz`` (an open ``numpy.load`` of an
    ``.npz`` archive), against its uncompressed size in the archive's directory; the
    error names the member."""
    for info in npz.zip.infolist():
        with npz.zip.open(info) as fh:
            check_npy_size(fh, info.file_size, f"member {info.filename}")


def check_npz_fits(npz, where: str) -> None:
    """A MemoryError naming ``where`` when the members of ``npz`` (an open ``numpy.load``
    of an ``.npz`` archive), unpacked at the sizes its directory gives, hold more bytes
    than the memory available (:func:`~topojax._cpus.available_memory_bytes`): a small
    archive that unpacks to gigabytes (a zip bomb, or a state of a far larger map) is
    refused before any member is read."""
    need = sum(info.file_size for info in npz.zip.infolist())
    check_fits_memory(need, f"{where}: its arrays unpack to")


def savez_deflated(fh: BinaryIO, arrays: dict[str, np.ndarray], level: int) -> None:
    """Write ``arrays`` into ``fh`` as :func:`numpy.savez_compressed` does (an .npz that
    :func:`numpy.load` reads), deflated at zlib ``level`` (1-9; numpy's is 6)."""
    with zipfile.ZipFile(fh, "w", zipfile.ZIP_DEFLATED, compresslevel=level) as zf:
        for name, value in arrays.items():
            with zf.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(value), allow_pickle=False)
