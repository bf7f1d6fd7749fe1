"""Occupancy-grid maps: the :class:`OccupancyMap` container and map file I/O.

Conventions
-----------
* Arrays are indexed ``grid[row, col]``; row 0 is the **top** row of the image.
* World coordinates follow ROS ``map_server``: ``origin = (x, y, yaw)`` is the world pose
  of the lower-left corner of the lower-left pixel. The centre of pixel ``(row, col)`` in
  the unrotated map frame is ``x' = (col + 0.5) * res``, ``y' = (H - row - 0.5) * res``;
  this point is rotated by ``yaw`` about the origin and translated by ``(x, y)``.
* Grey images are classified with the ``map_server`` rule. For a pixel intensity ``v``
  on a scale ``0 .. full`` (``full`` = 255 for 8-bit images), ``p = (full - v) / full``
  (``p = v / full`` when ``negate``); the pixel is *occupied* if ``p > occupied_thresh``,
  *free* if ``p < free_thresh`` and *unknown* otherwise. With the usual thresholds
  0.65 / 0.196, ``v <= 89`` is occupied, ``v >= 206`` is free and ``90 .. 205`` is unknown,
  so the ``map_saver`` values 0 / 205 / 254 map to occupied / unknown / free.
* Colour images are reduced to one intensity per pixel with the **mean of the colour
  channels** (the ROS 1 ``map_server`` rule; it does not depend on the channel order, so
  RGB and OpenCV's BGR give the same result). An alpha channel is ignored. All colour maps
  in the project data are grey (R = G = B), for which mean and luma weights agree.

Known data-set conventions this module does *not* reproduce by default: the IPA
room-segmentation maps treat only grey values >= 250 as free and everything else as
obstacle; with the ``map_server`` thresholds their grey outside area (153 .. 205) is
*unknown* instead. Use ``mode="ipa"`` to get the IPA interpretation.
"""

from __future__ import annotations

import contextlib
import math
import re
import threading
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "DEFAULT_FREE_THRESH",
    "DEFAULT_OCCUPIED_THRESH",
    "DEFAULT_RESOLUTION_M",
    "IMAGE_SUFFIXES",
    "MODES",
    "YAML_SUFFIXES",
    "OccupancyMap",
    "load_map",
    "save_map",
]

#: Default resolution for plain images (the IPA benchmark and paper maps use 0.05 m/px).
DEFAULT_RESOLUTION_M = 0.05
#: ``map_server`` default occupied threshold.
DEFAULT_OCCUPIED_THRESH = 0.65
#: ``map_server`` default free threshold.
DEFAULT_FREE_THRESH = 0.196
#: Interpretation modes accepted by :meth:`OccupancyMap.from_array` and :func:`load_map`.
MODES = ("trinary", "scale", "raw", "ipa")
#: File suffixes read as plain images by :func:`load_map`.
IMAGE_SUFFIXES = (".pgm", ".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
#: File suffixes read as ``map_server`` YAML by :func:`load_map`.
YAML_SUFFIXES = (".yaml", ".yml")

# Class codes used internally by the classification look-up tables.
_FREE, _OCC, _UNK = np.uint8(0), np.uint8(1), np.uint8(2)

# Pixel value written by ``to_image`` / ``save_map`` for each class (map_saver convention).
_IMAGE_OCCUPIED, _IMAGE_UNKNOWN, _IMAGE_FREE = 0, 205, 254

# IPA convention: grey >= 250 (of 255) is free.
_IPA_FREE_MIN = 250


def _is_real_number(value: Any) -> bool:
    """True for int/float (including numpy scalars) but not bool."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def _check_resolution(value: Any, *, where: str = "resolution_m") -> float:
    if not _is_real_number(value) or not math.isfinite(float(value)) or float(value) <= 0.0:
        raise ValueError(f"{where} must be a finite number > 0 (metres per pixel), got {value!r}")
    return float(value)


def _check_origin(value: Any, *, where: str = "origin") -> tuple[float, float, float]:
    try:
        items = list(value)
    except TypeError:
        raise ValueError(
            f"{where} must be a sequence of 3 finite numbers (x_m, y_m, yaw_rad), got {value!r}"
        ) from None
    if len(items) != 3 or not all(_is_real_number(v) and math.isfinite(float(v)) for v in items):
        raise ValueError(
            f"{where} must be a sequence of 3 finite numbers (x_m, y_m, yaw_rad), got {value!r}"
        )
    return (float(items[0]), float(items[1]), float(items[2]))


def _check_thresholds(
    occupied_thresh: Any, free_thresh: Any, *, where: str = ""
) -> tuple[float, float]:
    prefix = f"{where}: " if where else ""
    for name, v in (("occupied_thresh", occupied_thresh), ("free_thresh", free_thresh)):
        if not _is_real_number(v) or not math.isfinite(float(v)):
            raise ValueError(f"{prefix}{name} must be a finite number in [0, 1], got {v!r}")
    occ, free = float(occupied_thresh), float(free_thresh)
    if not (0.0 <= free < occ <= 1.0):
        raise ValueError(
            f"{prefix}thresholds must satisfy 0 <= free_thresh < occupied_thresh <= 1, "
            f"got free_thresh={free!r}, occupied_thresh={occ!r}"
        )
    return occ, free


def _check_mode(mode: Any, *, where: str = "mode") -> str:
    if not isinstance(mode, str) or mode not in MODES:
        raise ValueError(f"{where} must be one of {MODES}, got {mode!r}")
    return mode


def _check_negate(value: Any, *, where: str = "negate") -> bool:
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)) and int(value) in (0, 1):
        return bool(value)
    raise ValueError(f"{where} must be a bool or 0/1, got {value!r}")


@dataclass(frozen=True, eq=False, repr=False)
class OccupancyMap:
    """A 2-D occupancy grid split into three disjoint boolean masks.

    Parameters
    ----------
    occupied, free, unknown : np.ndarray of bool, shape (H, W)
        Class masks indexed ``[row, col]`` with row 0 at the top of the image. Exactly one
        of the three is True at every pixel. ``H`` and ``W`` must both be >= 2. The masks
        are stored read-only (writeable inputs are copied first).
    resolution_m : float
        Edge length of one pixel in metres (> 0).
    origin : tuple of 3 float
        ``(x_m, y_m, yaw_rad)``: world pose of the lower-left corner of the lower-left
        pixel (ROS ``map_server`` convention).
    source : str or None
        Where the map came from (a path), used in messages.
    """

    occupied: np.ndarray
    free: np.ndarray
    unknown: np.ndarray
    resolution_m: float = DEFAULT_RESOLUTION_M
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    source: str | None = None

    def __post_init__(self) -> None:
        masks = {}
        for name in ("occupied", "free", "unknown"):
            arr = getattr(self, name)
            if not isinstance(arr, np.ndarray):
                raise TypeError(
                    f"OccupancyMap.{name} must be a numpy bool array, got {type(arr).__name__}"
                )
            if arr.dtype != np.bool_:
                raise TypeError(f"OccupancyMap.{name} must have dtype bool, got {arr.dtype}")
            if arr.ndim != 2:
                raise ValueError(f"OccupancyMap.{name} must be 2-D (H, W), got shape {arr.shape}")
            masks[name] = arr
        shapes = {name: arr.shape for name, arr in masks.items()}
        if len(set(shapes.values())) != 1:
            raise ValueError(f"OccupancyMap masks must have the same shape, got {shapes}")
        shape = masks["occupied"].shape
        if shape[0] < 2 or shape[1] < 2:
            raise ValueError(f"OccupancyMap must be at least 2x2 pixels, got shape {shape}")
        total = (
            masks["occupied"].astype(np.uint8)
            + masks["free"].astype(np.uint8)
            + masks["unknown"].astype(np.uint8)
        )
        bad = int(np.count_nonzero(total != 1))
        if bad:
            raise ValueError(
                "OccupancyMap masks must partition the grid (exactly one of occupied/free/"
                f"unknown per pixel); {bad} of {total.size} pixels violate this"
            )
        for name, arr in masks.items():
            if arr.flags.writeable:
                arr = arr.copy()
                arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "resolution_m", _check_resolution(self.resolution_m))
        object.__setattr__(self, "origin", _check_origin(self.origin))
        if self.source is not None and not isinstance(self.source, str):
            object.__setattr__(self, "source", str(self.source))

    # ------------------------------------------------------------------ basic properties
    @property
    def shape(self) -> tuple[int, int]:
        """Grid shape ``(H, W)`` in pixels."""
        return self.occupied.shape  # type: ignore[return-value]

    def __repr__(self) -> str:
        h, w = self.shape
        return (
            f"OccupancyMap(shape=({h}, {w}), resolution_m={self.resolution_m!r}, "
            f"origin={self.origin!r}, occupied={int(self.occupied.sum())}, "
            f"free={int(self.free.sum())}, unknown={int(self.unknown.sum())}, "
            f"source={self.source!r})"
        )

    # ------------------------------------------------------------------ coordinates
    def pixel_to_world(self, rows: Any, cols: Any) -> tuple[np.ndarray, np.ndarray]:
        """Convert pixel coordinates to world coordinates.

        Parameters
        ----------
        rows, cols : array_like of float or int
            Pixel coordinates (broadcast together); integer values are pixel centres.

        Returns
        -------
        x, y : np.ndarray of float64
            World coordinates in metres, map frame, with the shape of the broadcast inputs
            (numpy scalars for scalar inputs).
        """
        r = np.asarray(rows, dtype=np.float64)
        c = np.asarray(cols, dtype=np.float64)
        res = self.resolution_m
        ox, oy, yaw = self.origin
        xm = (c + 0.5) * res
        ym = (self.shape[0] - r - 0.5) * res
        cos_t, sin_t = math.cos(yaw), math.sin(yaw)
        x = ox + cos_t * xm - sin_t * ym
        y = oy + sin_t * xm + cos_t * ym
        return x, y

    def world_to_pixel(self, x: Any, y: Any) -> tuple[np.ndarray, np.ndarray]:
        """Convert world coordinates to continuous pixel coordinates.

        Inverse of :meth:`pixel_to_world`.

        Parameters
        ----------
        x, y : array_like of float
            World coordinates in metres (broadcast together).

        Returns
        -------
        rows, cols : np.ndarray of float64
            Continuous pixel coordinates; pixel centres are at integer values. Points
            outside the grid give values outside ``[-0.5, H - 0.5)`` / ``[-0.5, W - 0.5)``.
        """
        dx = np.asarray(x, dtype=np.float64) - self.origin[0]
        dy = np.asarray(y, dtype=np.float64) - self.origin[1]
        yaw = self.origin[2]
        cos_t, sin_t = math.cos(yaw), math.sin(yaw)
        xm = cos_t * dx + sin_t * dy
        ym = -sin_t * dx + cos_t * dy
        res = self.resolution_m
        cols = xm / res - 0.5
        rows = self.shape[0] - 0.5 - ym / res
        return rows, cols

    # ------------------------------------------------------------------ conversions
    def to_image(self) -> np.ndarray:
        """Render the map as a ``map_saver``-style grey image.

        Returns
        -------
        np.ndarray of uint8, shape (H, W)
            0 = occupied, 205 = unknown, 254 = free. With the default thresholds
            (0.65 / 0.196) :meth:`from_array` maps this image back to the same masks.
        """
        img = np.full(self.shape, _IMAGE_UNKNOWN, dtype=np.uint8)
        img[self.occupied] = _IMAGE_OCCUPIED
        img[self.free] = _IMAGE_FREE
        return img

    @classmethod
    def from_array(
        cls,
        array: Any,
        *,
        resolution_m: float = DEFAULT_RESOLUTION_M,
        origin: Iterable[float] = (0.0, 0.0, 0.0),
        occupied_thresh: float = DEFAULT_OCCUPIED_THRESH,
        free_thresh: float = DEFAULT_FREE_THRESH,
        negate: bool = False,
        mode: str = "trinary",
        unknown_values: Iterable[float] | None = None,
        source: str | None = None,
    ) -> OccupancyMap:
        """Classify an array into an :class:`OccupancyMap`.

        The interpretation depends on the dtype of ``array``:

        * **bool** (H, W): True = occupied, False = free; no unknown pixels.
        * **uint8** (H, W) grey image, or (H, W, C) with C = 1 (grey), 2 (grey + alpha),
          3 (RGB or BGR) or 4 (RGBA/BGRA): an image with ``map_server`` semantics. The
          intensity ``v`` is the mean of the colour channels (alpha ignored; a map read
          from a ROS YAML by :func:`load_map` follows ``map_server`` there too), then
          ``mode`` decides:

          - ``"trinary"``: ``p = (255 - v) / 255`` (``v / 255`` if ``negate``); occupied if
            ``p > occupied_thresh``, free if ``p < free_thresh``, unknown otherwise.
          - ``"scale"``: identical classification. In ``map_server`` this mode only changes
            the *values* of the in-between pixels (scaled 1..99 instead of -1); all of them
            are neither free nor occupied, so they are unknown here as well.
          - ``"raw"``: the intensity (after ``negate``, as in ROS 1 ``map_server``) is the
            occupancy in percent: ``v > 100`` is unknown, otherwise occupied if
            ``v / 100 > occupied_thresh``, free if ``v / 100 < free_thresh``, else unknown.
          - ``"ipa"``: IPA room-segmentation convention: free if ``v >= 250`` (after
            ``negate``), occupied otherwise, never unknown; thresholds are not used.

        * **int8 or other integer dtypes** (H, W) (not uint8): ROS ``nav_msgs/OccupancyGrid``
          values, -1 = unknown, 0..100 = occupancy percent; occupied if
          ``v / 100 > occupied_thresh``, free if ``v / 100 < free_thresh``, else unknown.
          Values outside -1..100 raise ValueError.
        * **float** (H, W): occupancy probabilities in [0, 1]; occupied if
          ``p > occupied_thresh``, free if ``p < free_thresh``, else unknown. NaN or values
          outside [0, 1] raise ValueError.

        Parameters
        ----------
        array : array_like
            The map, indexed ``[row, col]`` with row 0 at the top (image order).
        resolution_m : float
            Metres per pixel (> 0).
        origin : sequence of 3 float
            ``(x_m, y_m, yaw_rad)`` pose of the lower-left corner of the lower-left pixel.
        occupied_thresh, free_thresh : float
            Thresholds, ``0 <= free_thresh < occupied_thresh <= 1``.
        negate : bool
            Swap the black/white meaning of image intensities (images only).
        mode : {"trinary", "scale", "raw", "ipa"}
            Image interpretation (see above). For non-image inputs only "trinary" and
            "scale" (which classify identically) are accepted.
        unknown_values : iterable of numbers, optional
            Input values that are classified unknown whatever the thresholds say, e.g.
            ``(230,)`` for maps that mark unexplored space with a light grey. For images
            the values are compared with the intensity before ``negate``. Values listed
            here are exempt from the range checks of integer and float inputs. Not
            allowed for bool input.
        source : str, optional
            Stored in :attr:`OccupancyMap.source`.

        Returns
        -------
        OccupancyMap

        Raises
        ------
        TypeError
            For unsupported dtypes or non-array input.
        ValueError
            For bad shapes, out-of-range values, NaN, or invalid parameters.
        """
        resolution_m = _check_resolution(resolution_m)
        origin_t = _check_origin(origin)
        occ_t, free_t = _check_thresholds(occupied_thresh, free_thresh)
        mode = _check_mode(mode)
        negate = _check_negate(negate)
        arr = np.asarray(array)
        if arr.dtype == np.uint8:
            if arr.ndim == 2 and mode != "raw" and unknown_values is None and _only_0_and_1(arr):
                # As image intensities 0 and 1 are both black: every pixel would be occupied
                # (all free with negate).  Such an array is an obstacle mask in uint8, as
                # OpenCV makes them, and distance_map reads it as one.
                raise ValueError(
                    "uint8 image holds only the values 0 and 1: as intensities that is a map "
                    "occupied everywhere (free everywhere with negate; 0 = black = occupied, "
                    "254 = free); for an obstacle mask pass a bool array "
                    "(array.astype(bool), True = occupied), or save a mask image as 0 / 255"
                )
            codes = _classify_image(
                arr,
                full_scale=255,
                occupied_thresh=occ_t,
                free_thresh=free_t,
                negate=negate,
                mode=mode,
                unknown_values=unknown_values,
            )
        else:
            numeric = np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)
            if arr.dtype != np.bool_ and not numeric:  # None, a string, complex numbers...
                raise TypeError(
                    "array must have dtype bool, uint8 (image), another integer type "
                    f"(OccupancyGrid -1..100) or float (probability 0..1), got {arr.dtype} "
                    f"(from {type(array).__name__})"
                )
            if arr.ndim != 2:
                raise ValueError(
                    f"array must be 2-D (H, W) for dtype {arr.dtype} (only uint8 images may "
                    f"have a channel axis), got shape {arr.shape}"
                )
            if negate:
                raise ValueError(
                    f"negate=True applies only to uint8 images, got an array of dtype {arr.dtype}"
                )
            if mode not in ("trinary", "scale"):
                raise ValueError(
                    f"mode={mode!r} applies only to uint8 images; arrays of dtype "
                    f"{arr.dtype} accept mode 'trinary' or 'scale'"
                )
            if arr.dtype == np.bool_:
                if unknown_values is not None:
                    raise ValueError("unknown_values cannot be used with a bool array")
                codes = np.where(arr, _OCC, _FREE)
            elif np.issubdtype(arr.dtype, np.integer):
                codes = _classify_occupancy_grid(arr, occ_t, free_t, unknown_values)
            else:  # floating (other dtypes were refused above)
                codes = _classify_probability(arr, occ_t, free_t, unknown_values)
        return cls._from_codes(codes, resolution_m, origin_t, source)

    @classmethod
    def _from_codes(
        cls,
        codes: np.ndarray,
        resolution_m: float,
        origin: tuple[float, float, float],
        source: str | None,
    ) -> OccupancyMap:
        if codes.ndim != 2 or codes.shape[0] < 2 or codes.shape[1] < 2:
            raise ValueError(f"map must be at least 2x2 pixels, got shape {codes.shape}")
        occupied = codes == _OCC
        free = codes == _FREE
        unknown = codes == _UNK
        for m in (occupied, free, unknown):
            m.setflags(write=False)
        return cls(
            occupied=occupied,
            free=free,
            unknown=unknown,
            resolution_m=resolution_m,
            origin=origin,
            source=source,
        )


# ---------------------------------------------------------------------- classification


def _unknown_value_list(unknown_values: Iterable[float] | None) -> list[float]:
    if unknown_values is None:
        return []
    if isinstance(unknown_values, (str, bytes)):
        raise TypeError(f"unknown_values must be an iterable of numbers, got {unknown_values!r}")
    try:
        values = list(np.asarray(list(unknown_values), dtype=object).ravel())
    except TypeError:
        raise TypeError(
            f"unknown_values must be an iterable of numbers, got {unknown_values!r}"
        ) from None
    for v in values:
        if not _is_real_number(v):
            raise TypeError(f"unknown_values must contain only numbers, got {v!r}")
    return [float(v) for v in values]


def _classify_image(
    arr: np.ndarray,
    *,
    full_scale: int,
    occupied_thresh: float,
    free_thresh: float,
    negate: bool,
    mode: str,
    unknown_values: Iterable[float] | None,
    average_alpha: bool = False,
) -> np.ndarray:
    """Classify an unsigned-integer image into class codes with a look-up table.

    ``arr`` is (H, W) or (H, W, C) with C in 1..4; ``full_scale`` is the intensity of white
    (255 for 8-bit, 65535 for 16-bit, a PGM's maxval otherwise).  Alpha is ignored unless
    ``average_alpha`` (map_server's rule for YAML maps in trinary mode).
    """
    if arr.ndim == 2:
        colour, n = arr, 1
    elif arr.ndim == 3 and arr.shape[2] in (1, 2, 3, 4):
        channels = arr.shape[2]
        n = 1 if channels <= 2 else 3  # grey(+alpha) or colour(+alpha)
        colour = arr[..., 0] if n == 1 else arr[..., :3].sum(axis=2, dtype=np.uint32)
        if average_alpha:  # load_map's decision: trinary mode, 2 or 4 channels
            # map_server (ROS 1 and Nav2) averages alpha in with the colour channels in
            # trinary mode; a grey + alpha pixel is read as R = G = B = grey, plus alpha
            grey3 = colour.astype(np.uint32) * (3 if n == 1 else 1)
            colour = grey3 + arr[..., channels - 1]
            n = 4
    else:
        raise ValueError(
            "image array must be (H, W) or (H, W, C) with C in 1..4 channels, "
            f"got shape {arr.shape}"
        )
    if mode == "raw" and full_scale != 255:
        raise ValueError(f"mode='raw' needs an 8-bit image, got full scale {full_scale}")
    # Mean intensity for every possible channel sum.
    sums = np.arange(n * full_scale + 1, dtype=np.float64)
    mean = sums / n
    v = (full_scale - mean) if negate else mean
    lut = np.full(sums.shape, _UNK, dtype=np.uint8)
    if mode in ("trinary", "scale"):
        p = (full_scale - v) / full_scale
        lut[p < free_thresh] = _FREE
        lut[p > occupied_thresh] = _OCC
    elif mode == "raw":
        pct = v / 100.0
        valid = v <= 100.0
        lut[valid & (pct < free_thresh)] = _FREE
        lut[valid & (pct > occupied_thresh)] = _OCC
    else:  # ipa
        lut[:] = _OCC
        lut[v * 255.0 >= _IPA_FREE_MIN * full_scale] = _FREE
    for u in _unknown_value_list(unknown_values):
        if not 0.0 <= u <= full_scale:
            raise ValueError(
                f"unknown_values entries must be intensities in [0, {full_scale}], got {u!r}"
            )
        idx = u * n
        if idx == int(idx):  # a mean of integer channels can only equal k / n
            lut[int(idx)] = _UNK
    return lut[colour]


def _only_0_and_1(arr: np.ndarray) -> bool:
    """Does a uint8 array hold the value 1 and nothing but 0 and 1?"""
    return arr.size > 0 and int(arr.max()) == 1


def _classify_occupancy_grid(
    arr: np.ndarray,
    occupied_thresh: float,
    free_thresh: float,
    unknown_values: Iterable[float] | None,
) -> np.ndarray:
    """Classify an integer ROS OccupancyGrid array (-1 unknown, 0..100 percent)."""
    extra = _unknown_value_list(unknown_values)
    forced = np.isin(arr, extra) if extra else None
    bad = (arr < -1) | (arr > 100)
    if forced is not None:
        bad &= ~forced
    n_bad = int(np.count_nonzero(bad))
    if n_bad:
        bad_vals = np.unique(arr[bad])[:5].tolist()
        raise ValueError(
            f"integer array (dtype {arr.dtype}) must hold OccupancyGrid values -1..100; "
            f"{n_bad} pixels are outside, e.g. {bad_vals} (use uint8 for grey images)"
        )
    one_is_free = not 0.01 > occupied_thresh
    if forced is None and one_is_free and arr.size and arr.max() == 1:
        # Read as OccupancyGrid percentages, 0 and 1 are both free: a map without a single
        # obstacle.  Real grids mark occupied cells 100; an array of 0 and 1 (and perhaps
        # -1) is nearly always an obstacle mask with the wrong dtype (distance_map reads it
        # as one).
        raise ValueError(
            f"integer array (dtype {arr.dtype}) holds no value above 1: as OccupancyGrid "
            "values (-1 unknown, 0..100 percent) that is a map with no obstacle at all, "
            "though it has cells at 1; for an obstacle mask pass a bool array "
            "(array.astype(bool), True = occupied), for OccupancyGrid data mark occupied "
            "cells 100"
        )
    pct = np.arange(-1, 101, dtype=np.float64)
    lut = np.full(pct.shape, _UNK, dtype=np.uint8)
    known = pct >= 0
    lut[known & (pct / 100.0 < free_thresh)] = _FREE
    lut[known & (pct / 100.0 > occupied_thresh)] = _OCC
    idx = np.clip(arr, -1, 100).astype(np.intp) + 1
    codes = lut[idx]
    if forced is not None:
        codes[forced] = _UNK
    return codes


def _classify_probability(
    arr: np.ndarray,
    occupied_thresh: float,
    free_thresh: float,
    unknown_values: Iterable[float] | None,
) -> np.ndarray:
    """Classify a float array of occupancy probabilities in [0, 1]."""
    n_nan = int(np.count_nonzero(np.isnan(arr)))
    if n_nan:
        raise ValueError(
            f"float array must hold occupancy probabilities in [0, 1]; it has {n_nan} NaN values"
        )
    extra = _unknown_value_list(unknown_values)
    forced = np.isin(arr, extra) if extra else None
    bad = (arr < 0.0) | (arr > 1.0)
    if forced is not None:
        bad &= ~forced
    n_bad = int(np.count_nonzero(bad))
    if n_bad:
        raise ValueError(
            f"float array must hold occupancy probabilities in [0, 1]; {n_bad} values are "
            f"outside (min {float(arr.min())!r}, max {float(arr.max())!r})"
        )
    # np.float64 thresholds make float32 input compare at float64 precision (exact values).
    codes = np.full(arr.shape, _UNK, dtype=np.uint8)
    codes[arr < np.float64(free_thresh)] = _FREE
    codes[arr > np.float64(occupied_thresh)] = _OCC
    if forced is not None:
        codes[forced] = _UNK
    return codes


# ---------------------------------------------------------------------- image reading

# the whitespace-delimited word before "m/pix" (map_saver writes "0.050 m/pix")
_PGM_RES_RE = re.compile(r"(?:^|\s)(\S+)\s*m/pix")
# the number-like end of that word: digits with dots, commas, a sign or an exponent
_PGM_NUMBER_RE = re.compile(r"[-+]?[0-9.,]*[0-9][0-9.,]*(?:[eE][-+]?[0-9]+)?$")


def _parse_pnm_header(data: bytes) -> tuple[int | None, list[str]]:
    """Return (maxval, comment lines) of a binary/ASCII PGM/PPM header, or (None, [])."""
    if len(data) < 2 or data[:1] != b"P" or data[1:2] not in b"2356":
        return None, []
    comments: list[str] = []
    tokens: list[bytes] = []
    pos = 2
    needed = 3  # width, height, maxval
    n = len(data)
    while len(tokens) < needed and pos < n:
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
    if len(tokens) < needed:
        return None, comments
    try:
        maxval = int(tokens[2])
    except ValueError:
        return None, comments
    return maxval, comments


def _resolution_from_pgm_comments(comments: list[str], path: Path) -> float | None:
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
            f"map image {path}: plain PNM header must give width, height >= 1 and maxval "
            f"1..65535, got {width} x {height}, maxval {maxval}"
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


def _read_image(path: Path) -> tuple[np.ndarray, int, list[str]]:
    """Read an image file.

    Returns
    -------
    pixels : np.ndarray of uint8 or uint16, (H, W) or (H, W, C)
    full_scale : int
        Intensity of white (255, 65535 or a PGM maxval).
    comments : list of str
        The PGM/PPM header's comment lines (see :func:`_resolution_from_pgm_comments`).
    """
    import cv2

    if not path.exists():
        raise FileNotFoundError(f"map image not found: {path}")
    if not path.is_file():
        raise ValueError(f"map image path is not a file: {path}")
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


# ---------------------------------------------------------------------- public loaders


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


def _yaml_error(path: Path, field: str, expected: str, value: Any) -> ValueError:
    return ValueError(f"map YAML {path}: field {field!r} must be {expected}, got {value!r}")


def _load_yaml(path: Path) -> dict[str, Any]:
    import yaml

    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"map YAML {path} is not valid UTF-8 text: {exc}") from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"map YAML {path} could not be parsed: {exc}") from None
    if not isinstance(doc, dict):
        raise ValueError(
            f"map YAML {path} must contain a mapping (key: value), got {type(doc).__name__}"
        )
    # map_server reads these with yaml-cpp, which converts 5e-2 and quoted numbers too;
    # PyYAML (YAML 1.1) leaves them strings
    for key in ("resolution", "occupied_thresh", "free_thresh"):
        if key in doc:
            doc[key] = _number_text(doc[key])
    if isinstance(doc.get("origin"), list):
        doc["origin"] = [_number_text(v) for v in doc["origin"]]
    return doc


_NUMBER_RE = re.compile(r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?")


def _number_text(value: Any) -> Any:
    """A string that spells a decimal number as that float; anything else unchanged."""
    if isinstance(value, str) and _NUMBER_RE.fullmatch(value.strip()):
        return float(value)
    return value


def _resolve_image_path(yaml_path: Path, image: Any) -> Path:
    if not isinstance(image, str) or not image.strip():
        raise _yaml_error(yaml_path, "image", "a non-empty file name", image)
    img = Path(image.strip())
    folder = yaml_path.parent
    if img.is_absolute():
        if img.is_file():
            return img
        fallback = folder / img.name
        if fallback.is_file():
            return fallback
        raise FileNotFoundError(
            f"map YAML {yaml_path}: image {str(img)!r} not found, nor {str(fallback)!r} "
            "next to the YAML"
        )
    resolved = folder / img
    if resolved.is_dir():
        raise ValueError(
            f"map YAML {yaml_path}: field 'image' must name an image file, got the folder "
            f"{resolved}"
        )
    if not resolved.is_file():
        raise FileNotFoundError(
            f"map YAML {yaml_path}: image {image!r} not found (looked for {resolved})"
        )
    return resolved


def load_map(
    path: str | Path,
    *,
    resolution_m: float | None = None,
    origin: Iterable[float] | None = None,
    occupied_thresh: float | None = None,
    free_thresh: float | None = None,
    negate: bool | None = None,
    mode: str | None = None,
) -> OccupancyMap:
    """Load an occupancy map from a ``map_server`` YAML file or a plain image.

    Parameters
    ----------
    path : str or Path
        ``.yaml`` / ``.yml``: ROS ``map_server`` map description with the keys ``image``
        (required; relative to the YAML's folder; an absolute path that does not exist
        falls back to the file of the same name next to the YAML), ``resolution``
        (required, m/px), ``origin`` ``[x, y, yaw]`` (required, as in ``map_server``,
        unless given here), ``negate`` (default 0), ``occupied_thresh`` (default 0.65),
        ``free_thresh`` (default 0.196) and ``mode`` (default ``trinary``).
        ``.pgm``, ``.png``, ``.jpg``, ``.jpeg``, ``.bmp``, ``.tif``, ``.tiff``: a plain
        image (8-bit or 16-bit; grey, grey + alpha, RGB, RGBA or palette). Defaults:
        resolution from a PGM ``# CREATOR: map_saver.cpp 0.050 m/pix`` style comment if
        present, else 0.05 m/px (the IPA benchmark / paper value); origin (0, 0, 0);
        thresholds 0.65 / 0.196; trinary mode.
    resolution_m, origin, occupied_thresh, free_thresh, negate, mode
        Override the values from the YAML file or the defaults (see
        :meth:`OccupancyMap.from_array` for their meaning).

    Returns
    -------
    OccupancyMap
        With ``source`` set to ``str(path)``.

    Raises
    ------
    FileNotFoundError
        If the file (or the YAML's image) does not exist.
    ValueError
        For undecodable images, malformed YAML, missing or invalid fields, or invalid
        parameters; the message names the file and the field.

    Notes
    -----
    16-bit images are classified at full precision, ``p = (65535 - v) / 65535``. PGM files
    with a maxval other than 255 / 65535 use ``v / maxval``.  An image with an alpha
    channel behind a YAML in trinary mode is read as ``map_server`` reads it, with alpha
    averaged in with the colour channels (so an opaque RGBA grey of 205 is free there, p =
    0.147); plain images ignore alpha, as the IPA maps' own tools do.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if p.is_dir():
        raise ValueError(
            f"map path is not a file: {p} is a folder; give a map file (topojax batch, "
            "and topojax.batch.expand_map_inputs, search folders for maps)"
        )
    if suffix not in YAML_SUFFIXES + IMAGE_SUFFIXES:
        if not p.exists():
            raise FileNotFoundError(f"map file not found: {p}")
        raise ValueError(
            f"map file {p} has unsupported suffix {p.suffix!r}; expected one of "
            f"{YAML_SUFFIXES + IMAGE_SUFFIXES}"
        )
    if not p.exists():
        raise FileNotFoundError(f"map file not found: {p}")

    if suffix in YAML_SUFFIXES:
        doc = _load_yaml(p)
        for key in ("image", "resolution"):
            if key not in doc:
                raise ValueError(f"map YAML {p} is missing the required key {key!r}")
        if origin is None and "origin" not in doc:
            raise ValueError(
                f"map YAML {p} is missing the required key 'origin' (pass origin= to override)"
            )
        image_path = _resolve_image_path(p, doc["image"])
        if resolution_m is None:
            res = doc["resolution"]
            if not _is_real_number(res) or not math.isfinite(float(res)) or float(res) <= 0:
                raise _yaml_error(p, "resolution", "a finite number > 0", res)
            resolution_m = float(res)
        if origin is None:
            raw_origin = doc["origin"]
            try:
                origin = _check_origin(raw_origin)
            except ValueError:
                raise _yaml_error(
                    p, "origin", "a list of 3 finite numbers [x, y, yaw]", raw_origin
                ) from None
        if negate is None:
            raw_neg = doc.get("negate", 0)
            try:
                negate = _check_negate(raw_neg)
            except ValueError:
                raise _yaml_error(p, "negate", "0, 1, true or false", raw_neg) from None
        thresholds = {}
        for key, given, default in (
            ("occupied_thresh", occupied_thresh, DEFAULT_OCCUPIED_THRESH),
            ("free_thresh", free_thresh, DEFAULT_FREE_THRESH),
        ):
            if given is not None:
                thresholds[key] = given
                continue
            val = doc.get(key, default)
            if not _is_real_number(val) or not 0.0 <= float(val) <= 1.0:
                raise _yaml_error(p, key, "a number in [0, 1]", val)
            thresholds[key] = float(val)
        occupied_thresh = thresholds["occupied_thresh"]
        free_thresh = thresholds["free_thresh"]
        if mode is None:
            raw_mode = doc.get("mode", "trinary")
            if not isinstance(raw_mode, str) or raw_mode not in ("trinary", "scale", "raw"):
                raise _yaml_error(p, "mode", "'trinary', 'scale' or 'raw'", raw_mode)
            mode = raw_mode
        where = f"map YAML {p}"
        _check_thresholds(occupied_thresh, free_thresh, where=where)
        pixels, full, _ = _read_image(image_path)
    else:
        pixels, full, comments = _read_image(p)
        if resolution_m is None:
            header_res = _resolution_from_pgm_comments(comments, p)
            resolution_m = header_res if header_res is not None else DEFAULT_RESOLUTION_M
        if origin is None:
            origin = (0.0, 0.0, 0.0)
        negate = False if negate is None else negate
        occupied_thresh = DEFAULT_OCCUPIED_THRESH if occupied_thresh is None else occupied_thresh
        free_thresh = DEFAULT_FREE_THRESH if free_thresh is None else free_thresh
        mode = "trinary" if mode is None else mode
        where = f"map {p}"

    # map_server averages an alpha channel in with the colour in trinary mode; a YAML map
    # is read as map_server reads it (plain images and arrays ignore alpha)
    average_alpha = (
        suffix in YAML_SUFFIXES
        and mode == "trinary"
        and pixels.ndim == 3
        and pixels.shape[2] in (2, 4)
    )
    if full == 255 and pixels.dtype == np.uint8 and not average_alpha:
        try:
            return OccupancyMap.from_array(
                pixels,
                resolution_m=resolution_m,
                origin=origin,
                occupied_thresh=occupied_thresh,
                free_thresh=free_thresh,
                negate=negate,
                mode=mode,
                source=str(p),
            )
        except ValueError as exc:  # name the file (e.g. a 0/1 mask saved as an image)
            if str(p) in str(exc):
                raise
            raise ValueError(f"{where}: {exc}") from None
    # 16-bit, non-standard maxval or map_server's alpha rule: classify directly.
    resolution_m = _check_resolution(resolution_m)
    origin_t = _check_origin(origin)
    occ_t, free_t = _check_thresholds(occupied_thresh, free_thresh, where=where)
    try:
        codes = _classify_image(
            pixels,
            full_scale=full,
            occupied_thresh=occ_t,
            free_thresh=free_t,
            negate=_check_negate(negate),
            mode=_check_mode(mode),
            unknown_values=None,
            average_alpha=average_alpha,
        )
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    return OccupancyMap._from_codes(codes, resolution_m, origin_t, str(p))


def save_map(
    occupancy_map: OccupancyMap, yaml_path: str | Path, *, image_name: str | None = None
) -> Path:
    """Write a ``map_server`` YAML + PGM pair.

    The PGM (binary P5, maxval 255) holds 0 = occupied, 205 = unknown, 254 = free; the
    YAML stores the resolution, origin, ``negate: 0``, thresholds 0.65 / 0.196 and
    ``mode: trinary``, so :func:`load_map` restores the same masks. Both files are written
    atomically (temporary file in the same folder, then ``os.replace``); the image first.

    Parameters
    ----------
    occupancy_map : OccupancyMap
        Map to save.
    yaml_path : str or Path
        Output ``.yaml`` / ``.yml`` path.
    image_name : str, optional
        File name of the PGM, written next to the YAML; default ``<yaml stem>.pgm``.

    Returns
    -------
    Path
        The path of the written PGM.
    """
    import yaml

    from ._fs import atomic_write_bytes

    if not isinstance(occupancy_map, OccupancyMap):
        raise TypeError(
            f"occupancy_map must be an OccupancyMap, got {type(occupancy_map).__name__}"
        )
    yp = Path(yaml_path)
    if yp.suffix.lower() not in YAML_SUFFIXES:
        raise ValueError(f"yaml_path must end in .yaml or .yml, got {str(yp)!r}")
    if image_name is None:
        image_name = yp.stem + ".pgm"
    if Path(image_name).name != image_name or not image_name.lower().endswith(".pgm"):
        raise ValueError(f"image_name must be a bare file name ending in .pgm, got {image_name!r}")
    for name, target in (("yaml_path", yp), ("image_name", yp.with_name(image_name))):
        if target.is_dir():  # before writing either file
            raise IsADirectoryError(
                f"{name}: {target} is a folder; expected a file name to write there"
            )
    img = occupancy_map.to_image()
    h, w = img.shape
    header = (
        f"P5\n# CREATOR: topojax save_map {occupancy_map.resolution_m!r} m/pix\n{w} {h}\n255\n"
    ).encode("ascii")
    image_path = yp.parent / image_name
    atomic_write_bytes(image_path, header + img.tobytes())
    doc = {
        "image": image_name,
        "mode": "trinary",
        "resolution": occupancy_map.resolution_m,
        "origin": list(occupancy_map.origin),
        "negate": 0,
        "occupied_thresh": DEFAULT_OCCUPIED_THRESH,
        "free_thresh": DEFAULT_FREE_THRESH,
    }
    text = yaml.safe_dump(doc, sort_keys=False, default_flow_style=None)
    atomic_write_bytes(yp, text.encode("utf-8"))
    return image_path
