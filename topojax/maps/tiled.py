"""Maps read a window at a time: a Zarr array, a folder of tiles or a binary PGM on disk.

A :class:`TiledMap` holds a map's metadata (shape, resolution, origin, classification
settings) and a reader of its raw values; :meth:`TiledMap.codes` classifies any window
``[r0:r1, c0:c1]`` with the rules :func:`topojax.load_map` and
:meth:`OccupancyMap.from_array` apply to the whole array, pixel by pixel, so a window's
classes are those of the same pixels in the loaded map.  Only the window is read.

Stored forms (:func:`open_tiled_map` opens each, :func:`save_tiled_map` writes the first
two):

* a **tile folder**: ``tiles.json`` (shape, tile side, dtype and the map metadata) and one
  ``.npy`` file per tile, ``r<tile row>_c<tile col>.npy``;
* a **Zarr array** (version 3, optional dependency: ``pip install topojax[zarr]``) whose
  attribute ``topojax`` holds the metadata;
* a **binary PGM** (``P5``, maxval up to 65535), or a ``map_server`` YAML naming one, read
  through ``numpy.memmap`` at its data offset.

The stored values are those of the map types :meth:`OccupancyMap.from_array` takes: a
grey image (uint8, or uint16 from a 16-bit PGM), an ``OccupancyGrid`` array (int8, -1
unknown, 0..100 percent) or an obstacle mask (bool, True = occupied).
"""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from .._filekind import non_file_kind
from .._fs import output_folder
from .._npy import load_npy
from .._validate import (
    binary_flag,
    instance_of,
    int_at_least,
    integer,
    metres_per_pixel,
    occupancy_thresholds,
    one_of,
    path_like,
    pose,
    positive_int,
    real_values,
    text_or_none,
    unmasked,
)
from ._arrays import _ArrayReader
from .classify import (
    _FREE,
    _OCC,
    _UNK,
    DEFAULT_FREE_THRESH,
    DEFAULT_OCCUPIED_THRESH,
    MODES,
    _classify_occupancy_grid,
    classify_image,
)
from .files import (
    YAML_SUFFIXES,
    _check_pgm_size,
    _NotMappable,
    _pgm_header,
    _yaml_settings,
    thresholds_without_yaml,
)
from .occupancy import (
    DEFAULT_RESOLUTION_M,
    OccupancyMap,
    _freeze,
    grid_to_world,
    window_origin,
    world_to_grid,
)
from .pnm import resolution_from_pgm_comments

__all__ = ["TILE_INDEX", "TiledMap", "open_tiled_map", "save_tiled_map"]

#: Name of a tile folder's index file.
TILE_INDEX = "tiles.json"
_FOLDER_FORMAT = "topojax-tiles"
_FOLDER_VERSION = 1
_KINDS = ("image", "grid", "mask")
_DTYPE_KIND = {"uint8": "image", "uint16": "image", "int8": "grid", "bool": "mask"}


#: The names of a window's bounds, as the reading methods take them.
_BOX = ("r0", "r1", "c0", "c1")


class TiledMap:
    """A 2-D map whose pixels are read a window at a time.

    Parameters
    ----------
    reader : object
        Has ``shape`` ((H, W)), ``dtype`` and ``read(r0, r1, c0, c1) -> (r1-r0, c1-c0)``
        array of the stored values; e.g. a NumPy array wrapper (:meth:`from_array`).
    resolution_m : float
        Metres per pixel.
    origin : (x, y, yaw)
        World pose of the lower-left corner (``map_server`` convention).
    occupied_thresh, free_thresh, negate, mode
        Classification, as for :meth:`OccupancyMap.from_array` (``negate`` and the modes
        other than ``"trinary"`` / ``"scale"`` apply to images only).
    full_scale : int, optional
        Intensity of white for images, at most the largest value of their dtype
        (default 255 for uint8, 65535 for uint16; a PGM's maxval).
    source : str or os.PathLike, optional
        Where the map is stored (kept as a str), the graph attribute ``source``.
    """

    def __init__(
        self,
        reader: Any,
        *,
        resolution_m: float = DEFAULT_RESOLUTION_M,
        origin=(0.0, 0.0, 0.0),
        occupied_thresh: float = DEFAULT_OCCUPIED_THRESH,
        free_thresh: float = DEFAULT_FREE_THRESH,
        negate: bool = False,
        mode: str = "trinary",
        full_scale: int | None = None,
        source: str | None = None,
    ) -> None:
        if not all(hasattr(reader, a) for a in ("shape", "dtype", "read")):
            raise TypeError(
                "reader: expected an object with shape, dtype and read(r0, r1, c0, c1) (see "
                f"TiledMap.from_array), received {type(reader).__name__}"
            )
        shape = tuple(int(v) for v in reader.shape)
        if len(shape) != 2 or min(shape) < 2:
            raise ValueError(
                f"reader: expected a 2-D map of at least 2 x 2 pixels, received {shape}"
            )
        dtype = np.dtype(reader.dtype)
        kind = _DTYPE_KIND.get(dtype.name)
        if kind is None:
            raise TypeError(
                "reader: expected stored values of dtype uint8 or uint16 (image), int8 "
                f"(OccupancyGrid) or bool (obstacle mask), received {dtype}"
            )
        self.reader = reader
        self.shape: tuple[int, int] = (shape[0], shape[1])
        self.kind = kind
        self.resolution_m = metres_per_pixel("resolution_m", resolution_m)
        self.origin = pose("origin", origin)
        self.occupied_thresh, self.free_thresh = occupancy_thresholds(occupied_thresh, free_thresh)
        self.negate = binary_flag("negate", negate)
        self.mode = one_of("mode", mode, MODES)
        if kind != "image" and (self.negate or self.mode not in ("trinary", "scale")):
            raise ValueError(
                f"negate, mode: expected negate=False and mode 'trinary' or 'scale' for a "
                f"{dtype} map (the others apply to images only), received negate={negate!r}, "
                f"mode={mode!r}"
            )
        if full_scale is None:
            full_scale = 65535 if dtype == np.uint16 else 255
        self.full_scale = positive_int("full_scale", full_scale)
        if kind == "image" and self.full_scale > np.iinfo(dtype).max:
            raise ValueError(  # white must be a value the image can hold
                f"full_scale: expected an int from 1 to {np.iinfo(dtype).max} for a {dtype} "
                f"image, received {self.full_scale}"
            )
        if kind == "image" and self.mode == "raw" and self.full_scale != 255:
            raise ValueError(  # found here, not when the first window is classified
                f"mode='raw': expected an 8-bit image (full scale 255), received full scale "
                f"{self.full_scale}"
            )
        self.source = text_or_none("source", source, paths=True)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_array(cls, array, **metadata) -> TiledMap:
        """A TiledMap of an array in memory (or a ``numpy.memmap``): the stored values of
        an image, an OccupancyGrid or an obstacle mask; ``metadata`` as for the class."""
        return array_map("array", array, **metadata)

    @classmethod
    def from_occupancy(cls, occupancy: OccupancyMap) -> TiledMap:
        """A TiledMap of an :class:`OccupancyMap`'s classes (read from its masks)."""
        instance_of("occupancy", occupancy, OccupancyMap)
        return cls(
            _MapReader(occupancy),
            resolution_m=occupancy.resolution_m,
            origin=occupancy.origin,
            source=occupancy.source,
        )

    # ------------------------------------------------------------------ reading
    @property
    def size(self) -> int:
        """Number of pixels, ``H * W``."""
        return self.shape[0] * self.shape[1]

    def _box(self, r0: int, r1: int, c0: int, c1: int) -> tuple[int, int, int, int]:
        h, w = self.shape
        r0, r1, c0, c1 = (integer(n, v) for n, v in zip(_BOX, (r0, r1, c0, c1), strict=True))
        if not (0 <= r0 <= r1 <= h and 0 <= c0 <= c1 <= w):
            raise ValueError(
                f"window: expected 0 <= r0 <= r1 <= {h} and 0 <= c0 <= c1 <= {w}, received "
                f"rows {r0}:{r1}, cols {c0}:{c1}"
            )
        return r0, r1, c0, c1

    def values(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """The stored values of the window ``[r0:r1, c0:c1]`` (a new array).

        Parameters
        ----------
        r0, r1, c0, c1 : int
            Rows ``r0:r1`` and columns ``c0:c1`` (end exclusive), with
            ``0 <= r0 <= r1 <= H`` and ``0 <= c0 <= c1 <= W``.

        Returns
        -------
        np.ndarray, shape (r1 - r0, c1 - c0)
            The reader's dtype (uint8 / uint16 image, int8 OccupancyGrid or bool mask).
        """
        box = self._box(r0, r1, c0, c1)
        return np.array(self.reader.read(*box))

    def codes(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """Class codes (uint8 (r1-r0, c1-c0)) of a window (bounds as :meth:`values`):
        those of the loaded map's pixels (:meth:`occupancy`)."""
        box = self._box(r0, r1, c0, c1)
        if isinstance(self.reader, _MapReader):
            return self.reader.codes(*box)
        raw = np.asarray(self.reader.read(*box))
        if self.kind == "mask":
            return np.where(raw, _OCC, _FREE)
        if self.kind == "grid":
            return _classify_occupancy_grid(raw, self.occupied_thresh, self.free_thresh, None)
        try:
            return classify_image(
                raw,
                full_scale=self.full_scale,
                occupied_thresh=self.occupied_thresh,
                free_thresh=self.free_thresh,
                negate=self.negate,
                mode=self.mode,
                unknown_values=None,
            )
        except ValueError as exc:  # name the map and the window
            r0, r1, c0, c1 = box
            raise ValueError(
                f"map {self.source or '(in memory)'}, rows {r0}:{r1}, cols {c0}:{c1}: {exc}"
            ) from None

    def occupied(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """Obstacle mask, bool (r1 - r0, c1 - c0), of a window (bounds as :meth:`values`)."""
        return self.codes(r0, r1, c0, c1) == _OCC

    def occupancy(self, r0: int = 0, r1: int | None = None, c0: int = 0, c1: int | None = None):
        """An :class:`OccupancyMap` of a window (by default the whole map, held in
        memory: for maps that fit).  A window's map keeps this map's resolution, and its
        origin is the pose of the window's lower-left corner, so that its pixels have the
        world coordinates they have in the whole map (a graph built from the window is in
        the whole map's frame)."""
        r1 = self.shape[0] if r1 is None else r1
        c1 = self.shape[1] if c1 is None else c1
        r0, r1, c0, c1 = self._box(r0, r1, c0, c1)
        if min(r1 - r0, c1 - c0) < 2:
            raise ValueError(
                f"window: expected at least 2 x 2 pixels for an OccupancyMap, received rows "
                f"{r0}:{r1}, cols {c0}:{c1}"
            )
        codes = self.codes(r0, r1, c0, c1)
        masks = {
            "occupied": _freeze(codes == _OCC),
            "free": _freeze(codes == _FREE),
            "unknown": _freeze(codes == _UNK),
        }
        del codes
        return OccupancyMap(
            **masks,
            resolution_m=self.resolution_m,
            origin=window_origin(self.origin, self.resolution_m, self.shape[0] - r1, c0),
            source=self.source,
        )

    def pixel_to_world(self, rows, cols) -> tuple[np.ndarray, np.ndarray]:
        """World ``(x, y)`` in metres of pixel ``(rows, cols)``, as
        :meth:`OccupancyMap.pixel_to_world` of the loaded map."""
        return grid_to_world(
            rows, cols, height=self.shape[0], resolution_m=self.resolution_m, origin=self.origin
        )

    def world_to_pixel(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Continuous pixel ``(rows, cols)`` of world ``(x, y)`` in metres, as
        :meth:`OccupancyMap.world_to_pixel` of the loaded map."""
        return world_to_grid(
            x, y, height=self.shape[0], resolution_m=self.resolution_m, origin=self.origin
        )

    def metadata(self) -> dict[str, Any]:
        """The map's metadata as JSON-ready values (what a tile folder's index and a Zarr
        array's ``topojax`` attribute hold)."""
        return {
            "resolution_m": self.resolution_m,
            "origin": list(self.origin),
            "occupied_thresh": self.occupied_thresh,
            "free_thresh": self.free_thresh,
            "negate": self.negate,
            "mode": self.mode,
            "full_scale": self.full_scale,
        }

    def __repr__(self) -> str:
        h, w = self.shape
        return (
            f"TiledMap(shape=({h}, {w}), kind={self.kind!r}, resolution_m="
            f"{self.resolution_m!r}, reader={type(self.reader).__name__}, "
            f"source={self.source!r})"
        )


def array_map(name: str, array, **metadata) -> TiledMap:
    """:meth:`TiledMap.from_array` whose errors name the argument ``name`` (the array
    as the caller gave it, not the map's reader).

    Shared with :mod:`topojax.outofcore`, which takes an array where a tiled map is
    expected.  ``array`` is (H, W), uint8, uint16, int8 or bool.
    """
    given = np.asarray(unmasked(name, array))  # no class for a masked value: refused
    array = real_values(given)  # int4 as int8 (an OccupancyGrid); bfloat16 refused below
    if array.ndim != 2 or min(array.shape) < 2:
        raise ValueError(
            f"{name}: expected a 2-D (H, W) array of at least 2 x 2 pixels, received shape "
            f"{array.shape}"
        )
    if array.dtype.name not in _DTYPE_KIND:
        raise TypeError(
            f"{name}: expected stored values of dtype uint8 or uint16 (image), int8 "
            f"(OccupancyGrid) or bool (obstacle mask), received {given.dtype}"
        )
    return TiledMap(_ArrayReader(array), **metadata)


# --------------------------------------------------------------------------- readers


class _MapReader:
    """Windows of an OccupancyMap's classes."""

    def __init__(self, occupancy: OccupancyMap) -> None:
        self.occupancy = occupancy
        self.shape = occupancy.shape
        self.dtype = np.dtype(bool)

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        return self.occupancy.occupied[r0:r1, c0:c1]

    def codes(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        m = self.occupancy
        out = np.full((r1 - r0, c1 - c0), _UNK, np.uint8)
        out[m.free[r0:r1, c0:c1]] = _FREE
        out[m.occupied[r0:r1, c0:c1]] = _OCC
        return out


class _PgmReader:
    """Windows of a binary PGM, memory-mapped at its data offset; the map is opened again
    after pickling (in a Dask or process-pool worker) instead of copying its pixels.  The
    file must stay the one opened: a header that gives another layout when it is mapped,
    or a file whose inode, size or modification time are no longer those it had when it
    was opened (its pixels would be read in the old layout, or mixed from two maps, or
    past its end), is refused, in every copy."""

    def __init__(self, path: Path, offset: int, shape: tuple[int, int], maxval: int) -> None:
        self.path, self.offset, self.maxval = path, offset, maxval
        # big-endian for 16-bit samples
        self.file_dtype = np.dtype(np.uint8) if maxval < 256 else np.dtype(">u2")
        self.shape, self.dtype = shape, self.file_dtype.newbyteorder("=")
        self._data: np.memmap | None = None
        self._state = _file_state(path)

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        if self._data is None:
            self._data = self._map()
        elif _file_state(self.path) != self._state:
            raise self._changed("it changed while it was read")
        return self._data[r0:r1, c0:c1].astype(self.dtype)

    def _map(self) -> np.memmap:
        """The file memory-mapped, after checking that its header still gives the
        layout it was opened with."""
        try:
            width, height, maxval, offset, _ = _pgm_header(self.path)
            _check_pgm_size(self.path, width, height, maxval, offset)
        except (OSError, ValueError) as exc:
            raise self._changed(f"it cannot be read as it was: {exc}") from None
        if (height, width) != self.shape or maxval != self.maxval or offset != self.offset:
            raise self._changed(
                f"its header now gives {width} x {height} pixels, maxval {maxval}, "
                f"{offset}-byte header"
            )
        data = np.memmap(
            self.path, dtype=self.file_dtype, mode="r", offset=self.offset, shape=self.shape
        )
        if _file_state(self.path) != self._state:
            raise self._changed("it changed after it was opened")
        return data

    def _changed(self, why: str) -> ValueError:
        h, w = self.shape
        return ValueError(
            f"map {self.path}: expected the PGM opened ({w} x {h} pixels, maxval "
            f"{self.maxval}, {self.offset}-byte header) unchanged, but {why}; open it "
            "again with open_tiled_map"
        )

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_data": None}


def _file_state(path: Path) -> tuple[int, int, int] | None:
    """``(inode, size, modification time in ns)`` of ``path``; None if it is gone."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_size, st.st_mtime_ns


class _FolderReader:
    """Windows of a folder of ``.npy`` tiles (each opened memory-mapped when read)."""

    def __init__(self, folder: Path, shape, tile_px: int, dtype) -> None:
        self.folder, self.tile_px = folder, tile_px
        self.shape, self.dtype = shape, np.dtype(dtype)

    def tile_path(self, tr: int, tc: int) -> Path:
        return self.folder / f"r{tr:05d}_c{tc:05d}.npy"

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        t = self.tile_px
        out = np.empty((r1 - r0, c1 - c0), self.dtype)
        for tr in range(r0 // t, -(-r1 // t)):
            for tc in range(c0 // t, -(-c1 // t)):
                tile = self._tile(tr, tc)
                a0, a1 = max(r0, tr * t), min(r1, tr * t + tile.shape[0])
                b0, b1 = max(c0, tc * t), min(c1, tc * t + tile.shape[1])
                out[a0 - r0 : a1 - r0, b0 - c0 : b1 - c0] = tile[
                    a0 - tr * t : a1 - tr * t, b0 - tc * t : b1 - tc * t
                ]
        return out

    def _tile(self, tr: int, tc: int) -> np.ndarray:
        """Tile ``(tr, tc)``, memory-mapped, after checking it has the shape and dtype
        that ``tiles.json`` gives it (a tile at the map's last row or column is cut)."""
        path = self.tile_path(tr, tc)
        t = self.tile_px
        want = (min(t, self.shape[0] - tr * t), min(t, self.shape[1] - tc * t))
        try:
            tile = load_npy(path, mmap_mode="r")
        except FileNotFoundError:
            raise FileNotFoundError(
                f"tile folder {self.folder}: tile {path.name} is missing"
            ) from None
        except (OSError, ValueError, EOFError) as exc:  # EOFError: an empty file
            raise ValueError(
                f"tile folder {self.folder}: {path.name} is not a .npy array ({exc})"
            ) from None
        if tile.shape != want or tile.dtype != self.dtype:
            raise ValueError(
                f"tile folder {self.folder}: {path.name}: expected a {self.dtype} array of "
                f"{want[0]} x {want[1]} pixels (from {TILE_INDEX}), received a {tile.dtype} "
                f"array of shape {tile.shape}"
            )
        return tile


class _ZarrReader:
    """Windows of a Zarr array (opened again after pickling)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        arr = self._open()
        self.shape, self.dtype = tuple(arr.shape), np.dtype(arr.dtype)
        self._array = arr

    def _open(self):
        zarr = _zarr()
        return zarr.open_array(str(self.path), mode="r")

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        if self._array is None:
            self._array = self._open()
        return np.asarray(self._array[r0:r1, c0:c1])

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_array": None}


def _zarr():
    try:
        import zarr
    except ImportError:
        raise ImportError(
            "Zarr maps need the optional dependency zarr (>= 3): pip install 'topojax[zarr]'"
        ) from None
    return zarr


# --------------------------------------------------------------------------- open / save


def open_tiled_map(path, **overrides) -> TiledMap:
    """Open a map stored on disk for reading a window at a time.

    Parameters
    ----------
    path : str or Path
        A tile folder (holding ``tiles.json``), a Zarr array (a folder holding
        ``zarr.json``), a binary PGM (``P5``) or a ``map_server`` YAML naming one.
    **overrides
        ``resolution_m``, ``origin``, ``occupied_thresh``, ``free_thresh``, ``negate``,
        ``mode``: replace the stored metadata (for a PGM or YAML, as :func:`load_map`'s
        arguments of the same names).

    Returns
    -------
    TiledMap
        Its windows classify as the map :func:`load_map` (or, for a tile folder or a Zarr
        array, :meth:`OccupancyMap.from_array` of the whole array) gives.

    Raises
    ------
    FileNotFoundError, ValueError
        For a missing path, an unknown form, or a PGM that is not binary single-channel.
    ImportError
        For a Zarr array without the ``zarr`` package.
    """
    p = path_like("path", path)
    unknown = set(overrides) - set(_OVERRIDABLE)
    if unknown:
        raise TypeError(
            f"open_tiled_map: expected keyword arguments from {_OVERRIDABLE}, received "
            f"{sorted(unknown)}"
        )
    if not p.exists():
        raise FileNotFoundError(f"path: map not found: {p}")
    kind = non_file_kind(p)
    if kind not in (None, "a folder"):  # reading a FIFO would wait for a writer for ever
        raise ValueError(
            f"path: {p} is {kind}; expected a tile folder, a Zarr array, a binary .pgm or a "
            "map YAML (a regular file)"
        )
    if p.is_dir() and (p / TILE_INDEX).is_file():
        return _open_folder(p, overrides)
    if p.is_dir() and (p / "zarr.json").is_file():
        reader = _ZarrReader(p)
        meta = dict(reader._array.attrs.get("topojax", {}))
        _refuse_missing_chunks(p, reader._array, meta)
        return _with_metadata(reader, p / "zarr.json", meta, overrides, source=str(p))
    suffix = p.suffix.lower()
    if p.is_dir():  # whatever its name ends with
        _refuse_unfinished(p)
    elif suffix in YAML_SUFFIXES:
        image, settings = _yaml_settings(p, **{k: overrides.get(k) for k in _OVERRIDABLE})
        return _open_pgm(image, settings, source=p)
    elif suffix == ".pgm":
        thresholds_without_yaml(p, overrides.get("occupied_thresh"), overrides.get("free_thresh"))
        return _open_pgm(p, dict(overrides), source=p)
    raise ValueError(
        f"path: expected a tile folder (with {TILE_INDEX}), a Zarr array, a binary .pgm or a "
        f"map YAML naming one, received {p}"
    )


def _refuse_missing_chunks(path: Path, array, meta: dict) -> None:
    """Zarr reads a missing chunk as its fill value (0, an obstacle in a grey image):
    an array that :func:`save_tiled_map` wrote with every chunk (``all_chunks``) must
    still hold them all, or its save did not finish or chunks were deleted."""
    if meta.get("all_chunks") is True and array.nchunks_initialized != array.nchunks:
        raise ValueError(
            f"path: {path} was saved with all its {array.nchunks} chunks but holds "
            f"{array.nchunks_initialized}: the save did not finish or chunks were deleted "
            "(Zarr would read them as the fill value); save the map again"
        )


def _refuse_unfinished(folder: Path) -> None:
    """A folder of tiles without its index: :func:`save_tiled_map` writes the index last,
    so its save did not finish."""
    tiles = sum(1 for _ in folder.glob("r*_c*.npy"))
    if tiles:
        raise ValueError(
            f"path: {folder} holds {tiles} tiles but no {TILE_INDEX}, which save_tiled_map "
            "writes last: the save did not finish; save the map again into an empty folder"
        )


@contextlib.contextmanager
def _named(index_path: Path):
    """Errors of the metadata stored in ``index_path`` name that file."""
    try:
        yield
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"path: {index_path}: {exc}") from None


_OVERRIDABLE = ("resolution_m", "origin", "occupied_thresh", "free_thresh", "negate", "mode")


def _metadata(stored: dict, overrides: dict) -> dict:
    out = {k: stored[k] for k in (*_OVERRIDABLE, "full_scale") if k in stored}
    out.update({k: v for k, v in overrides.items() if v is not None})
    return out


def _with_metadata(reader, index_path: Path, stored: dict, overrides: dict, source: str):
    """A TiledMap of ``reader``; errors of ``stored`` name ``index_path``, not those of the
    caller's ``overrides``."""
    with _named(index_path):
        as_stored = TiledMap(reader, **_metadata(stored, {}), source=source)
    if all(v is None for v in overrides.values()):  # nothing to replace: that map
        return as_stored
    return TiledMap(reader, **_metadata(stored, overrides), source=source)


def _open_folder(p: Path, overrides: dict) -> TiledMap:
    index_path = p / TILE_INDEX
    try:
        index = json.loads(index_path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"path: {index_path} is not JSON ({exc})") from None
    if not isinstance(index, dict) or index.get("format") != _FOLDER_FORMAT:
        found = index.get("format") if isinstance(index, dict) else type(index).__name__
        raise ValueError(
            f"path: {index_path} is not a tile index (format {found!r}, "
            f"expected {_FOLDER_FORMAT!r})"
        )
    if index.get("version") != _FOLDER_VERSION:
        raise ValueError(
            f"path: {index_path}: expected version {_FOLDER_VERSION} of the tile index, "
            f"received {index.get('version')!r} (written by another topojax release)"
        )
    shape, tile_px, dtype = _folder_layout(index, index_path)
    _check_tile_files(p, shape, tile_px)
    reader = _FolderReader(p, shape, tile_px, dtype)
    # its first tile holds what the index gives (its header and bytes): with the number
    # of tiles, that bounds the map's size by the folder's bytes, however large the shape
    # and tile side the index claims
    reader._tile(0, 0)
    return _with_metadata(reader, index_path, index, overrides, source=str(p))


def _folder_layout(index: dict, index_path: Path) -> tuple[tuple[int, int], int, np.dtype]:
    """``shape``, ``tile_px`` and ``dtype`` of a tile index, checked."""
    shape, tile_px, dtype = index.get("shape"), index.get("tile_px"), index.get("dtype")
    if (
        not isinstance(shape, list)
        or len(shape) != 2
        or not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in shape)
    ):
        raise ValueError(
            f"path: {index_path}: shape: expected two positive integers, received {shape!r}"
        )
    if not isinstance(tile_px, int) or isinstance(tile_px, bool) or tile_px < 1:
        raise ValueError(
            f"path: {index_path}: tile_px: expected a positive integer, received {tile_px!r}"
        )
    try:
        dt = np.dtype(dtype)
    except TypeError:
        dt = None
    if dt is None or dt.kind not in "biu":
        raise ValueError(
            f"path: {index_path}: dtype: expected an integer or bool type name, received {dtype!r}"
        )
    return (shape[0], shape[1]), tile_px, dt


def _check_tile_files(folder: Path, shape: tuple[int, int], tile_px: int) -> None:
    """The folder holds exactly the tiles its index's shape asks for (checked before any
    block is planned, so a wrong shape cannot make a map of absurd size)."""
    rows, cols = -(-shape[0] // tile_px), -(-shape[1] // tile_px)
    names = {f.name for f in folder.glob("r*_c*.npy")}
    if len(names) != rows * cols:
        raise ValueError(
            f"path: {folder / TILE_INDEX} gives a map of {shape[0]} x {shape[1]} pixels in "
            f"tiles of {tile_px}: expected {rows * cols} tile files, found {len(names)}"
        )
    for tr in range(rows):
        for tc in range(cols):
            if f"r{tr:05d}_c{tc:05d}.npy" not in names:
                raise ValueError(
                    f"path: {folder}: tile r{tr:05d}_c{tc:05d}.npy of the "
                    f"{rows} x {cols} tiles is missing"
                )


def _open_pgm(image: Path, settings: dict, *, source: Path) -> TiledMap:
    try:
        width, height, maxval, offset, comments = _pgm_header(image)
    except _NotMappable as exc:  # load_map decodes it whole; here it cannot be mapped
        raise ValueError(str(exc)) from None
    _check_pgm_size(image, width, height, maxval, offset)
    if settings.get("resolution_m") is None:
        res = resolution_from_pgm_comments(comments, image)
        settings["resolution_m"] = DEFAULT_RESOLUTION_M if res is None else res
    reader = _PgmReader(image, offset, (height, width), maxval)
    meta = {k: v for k, v in settings.items() if v is not None}
    try:
        return TiledMap(reader, **meta, full_scale=maxval, source=str(source))
    except ValueError as exc:  # name the file, as load_map does
        what = "map YAML" if source.suffix.lower() in YAML_SUFFIXES else "map"
        raise ValueError(f"{what} {source}: {exc}") from None


#: The smallest tile side :func:`save_tiled_map` writes: each tile is a file (a Zarr
#: chunk) with its own header, so one-pixel tiles would take thousands of times the map.
MIN_SAVED_TILE_PX = 16


def save_tiled_map(tiled, path, *, tile_px: int = 1024, format: str = "folder") -> Path:
    """Write a map as a tile folder or a Zarr array, a block of rows at a time.

    Parameters
    ----------
    tiled : TiledMap, OccupancyMap or array
        The map (an array: the stored values of an image, OccupancyGrid or mask, read by
        :meth:`TiledMap.from_array` with default metadata).  An OccupancyMap, or a
        TiledMap of one, is written as its grey image (0 occupied, 205 unknown, 254 free).
    path : str or Path
        The folder to create: empty or new (for Zarr, also an existing Zarr array,
        which is replaced).
    tile_px : int
        Tile (Zarr chunk) side in pixels, at least 16 (smaller tiles make a file or
        chunk for every few pixels).
    format : {"folder", "zarr"}

    Returns
    -------
    Path
        ``path``; :func:`open_tiled_map` reads it back.
    """
    tile_px = int_at_least("tile_px", tile_px, MIN_SAVED_TILE_PX)
    format = one_of("format", format, ("folder", "zarr"))
    if isinstance(tiled, TiledMap) and isinstance(tiled.reader, _MapReader):
        tiled = tiled.reader.occupancy  # its values are the obstacle mask only
    if isinstance(tiled, OccupancyMap):
        tiled = TiledMap.from_array(
            tiled.to_image(),
            resolution_m=tiled.resolution_m,
            origin=tiled.origin,
            source=tiled.source,
        )
    elif not isinstance(tiled, TiledMap):
        tiled = array_map("tiled", tiled)
    p = path_like("path", path)
    h, w = tiled.shape
    dtype = np.dtype(tiled.reader.dtype)
    meta = tiled.metadata()
    if format == "zarr":
        zarr = _zarr()
        output_folder(p, name="path")
        if not (p / "zarr.json").is_file() and any(p.iterdir()):
            raise ValueError(  # overwriting would delete the folder's files
                f"path: expected an empty or new folder or a Zarr array, received {p}"
            )
        arr = zarr.create_array(
            str(p),
            shape=(h, w),
            chunks=(tile_px, tile_px),
            dtype=dtype,
            overwrite=True,
            config={"write_empty_chunks": True},  # so a missing chunk is a damaged array
        )
        arr.attrs["topojax"] = {**meta, "all_chunks": True}
        for r0 in range(0, h, tile_px):
            arr[r0 : min(h, r0 + tile_px), :] = tiled.values(r0, min(h, r0 + tile_px), 0, w)
        return p
    folder = output_folder(p, name="path")
    if any(folder.iterdir()):
        if not (folder / TILE_INDEX).exists():
            _refuse_unfinished(folder)
        raise ValueError(f"path: expected an empty or new folder for the tiles, received {folder}")
    for tr, r0 in enumerate(range(0, h, tile_px)):
        band = tiled.values(r0, min(h, r0 + tile_px), 0, w)
        for tc, c0 in enumerate(range(0, w, tile_px)):
            np.save(folder / f"r{tr:05d}_c{tc:05d}.npy", band[:, c0 : c0 + tile_px])
    index = {
        "format": _FOLDER_FORMAT,
        "version": _FOLDER_VERSION,
        "shape": [h, w],
        "tile_px": tile_px,
    }
    index["dtype"] = dtype.name
    index.update(meta)
    (folder / TILE_INDEX).write_text(json.dumps(index, indent=1) + "\n")
    return p
