"""Classification of map arrays into free / occupied / unknown pixels.

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
*unknown* instead. Use ``mode="ipa"`` to get the IPA interpretation (for a 16-bit image,
free from 64000, which the IPA tools read as 250: they keep the high byte).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from .._constants import MODES
from .._validate import is_real_number

__all__ = [
    "DEFAULT_FREE_THRESH",
    "DEFAULT_OCCUPIED_THRESH",
    "LOW_WALL_SHARE",
    "MODES",
    "classify_array",
    "classify_image",
    "rim_counts",
    "share_of_rim",
    "wall_share",
    "wall_warning",
]

#: ``map_server`` default occupied threshold.
DEFAULT_OCCUPIED_THRESH = 0.65
#: ``map_server`` default free threshold.
DEFAULT_FREE_THRESH = 0.196

# Class codes used internally by the classification look-up tables.
_FREE, _OCC, _UNK = np.uint8(0), np.uint8(1), np.uint8(2)

# IPA convention: grey >= 250 (of 255) is free.
_IPA_FREE_MIN = 250


def classify_array(
    array: np.ndarray,
    *,
    occupied_thresh: float,
    free_thresh: float,
    negate: bool,
    mode: str,
    unknown_values: Iterable[float] | None,
    given_type: str,
    precision: np.dtype,
) -> np.ndarray:
    """Class codes (uint8, ``_FREE`` / ``_OCC`` / ``_UNK``) of an array, with the rules of
    :meth:`OccupancyMap.from_array` for its dtype; the parameters are already checked
    there.  ``given_type`` names the type the caller passed, for the dtype error;
    ``precision``: the dtype the caller's array had (``bfloat16`` before it was read as
    float32), to which a float array's thresholds and ``unknown_values`` are rounded."""
    if array.dtype == np.uint8:
        return _classify_uint8(
            array,
            occupied_thresh=occupied_thresh,
            free_thresh=free_thresh,
            negate=negate,
            mode=mode,
            unknown_values=unknown_values,
        )
    return _classify_values(
        array,
        occupied_thresh=occupied_thresh,
        free_thresh=free_thresh,
        negate=negate,
        mode=mode,
        unknown_values=unknown_values,
        given_type=given_type,
        precision=precision,
    )


def _classify_uint8(
    arr: np.ndarray,
    *,
    occupied_thresh: float,
    free_thresh: float,
    negate: bool,
    mode: str,
    unknown_values: Iterable[float] | None,
) -> np.ndarray:
    """Class codes of an 8-bit image, after refusing an obstacle mask of 0 and 1."""
    plain = arr.ndim == 2 and mode != "raw" and unknown_values is None  # read as intensities
    if plain and _only_0_and_1(arr):
        # As image intensities 0 and 1 are both black: every pixel would be occupied
        # (all free with negate).  Such an array is an obstacle mask in uint8, as
        # OpenCV makes them, and distance_map reads it as one.
        raise ValueError(
            "uint8 image holds only the values 0 and 1: as intensities that is a map "
            "occupied everywhere (free everywhere with negate; 0 = black = occupied, "
            "254 = free); for an obstacle mask pass a bool array "
            "(array.astype(bool), True = occupied), or save a mask image as 0 / 255"
        )
    if plain and _grid_values(arr):
        # Intensities 0 / 100 / 255 are the cells of an OccupancyGrid (int8) read as uint8:
        # 0 free, 100 occupied, -1 unknown became 255.  As intensities they turn free
        # into occupied and unknown into free (map_saver writes 0 / 205 / 254).
        raise ValueError(
            "array: uint8 image holds only the values 0, 100 and 255, the cells of a ROS "
            "OccupancyGrid (0 free, 100 occupied, -1 unknown as 255) read as uint8; as "
            "intensities free cells would be occupied and unknown ones free; for "
            "OccupancyGrid data pass array.view(np.int8) or mode='raw', for an image "
            "whose grey 100 is unknown pass unknown_values=(100,)"
        )
    return classify_image(
        arr,
        full_scale=255,
        occupied_thresh=occupied_thresh,
        free_thresh=free_thresh,
        negate=negate,
        mode=mode,
        unknown_values=unknown_values,
    )


def _classify_values(
    arr: np.ndarray,
    *,
    occupied_thresh: float,
    free_thresh: float,
    negate: bool,
    mode: str,
    unknown_values: Iterable[float] | None,
    given_type: str,
    precision: np.dtype,
) -> np.ndarray:
    """Class codes of a bool mask, an OccupancyGrid integer array or a probability array
    (whose thresholds and ``unknown_values`` are rounded to ``precision``, the caller's
    float dtype)."""
    numeric = np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)
    if arr.dtype != np.bool_ and not numeric:  # None, a string, complex numbers...
        raise TypeError(
            "array: expected dtype bool, uint8 (image), another integer type "
            f"(OccupancyGrid -1..100) or float (probability 0..1), received {arr.dtype} "
            f"(from {given_type})"
        )
    if arr.ndim != 2:
        raise ValueError(
            f"array: expected a 2-D (H, W) array for dtype {arr.dtype} (only uint8 images "
            f"may have a channel axis), received shape {arr.shape}"
        )
    if negate:
        raise ValueError(
            "negate: expected False (negate=True applies only to uint8 images), received "
            f"{negate!r} for an array of dtype {arr.dtype}"
        )
    if mode not in ("trinary", "scale"):
        raise ValueError(
            f"mode: expected 'trinary' or 'scale' for an array of dtype {arr.dtype} (the "
            f"other modes apply only to uint8 images), received {mode!r}"
        )
    if arr.dtype == np.bool_:
        if unknown_values is not None:
            raise ValueError("unknown_values cannot be used with a bool array")
        return np.where(arr, _OCC, _FREE)
    if np.issubdtype(arr.dtype, np.integer):
        return _classify_occupancy_grid(arr, occupied_thresh, free_thresh, unknown_values)
    # floating (other dtypes were refused above)
    return _classify_probability(arr, occupied_thresh, free_thresh, unknown_values, precision)


def _unknown_value_list(unknown_values: Iterable[float] | None) -> list[float]:
    if unknown_values is None:
        return []
    if isinstance(unknown_values, (str, bytes)):
        raise TypeError(
            f"unknown_values: expected an iterable of numbers, received {unknown_values!r}"
        )
    try:
        values = list(np.asarray(list(unknown_values), dtype=object).ravel())
    except TypeError:
        raise TypeError(
            f"unknown_values: expected an iterable of numbers, received {unknown_values!r}"
        ) from None
    for v in values:
        if not is_real_number(v):
            raise TypeError(f"unknown_values: expected only numbers, received {v!r}")
    return [float(v) for v in values]


def classify_image(
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
    ``average_alpha`` (map_server's rule for YAML maps in trinary mode).  A pixel above
    ``full_scale`` is a ValueError.
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
            "image array: expected shape (H, W) or (H, W, C) with C in 1..4 channels, "
            f"received shape {arr.shape}"
        )
    if full_scale < np.iinfo(arr.dtype).max and arr.size:
        # the look-up table ends at full scale: a brighter pixel (a PGM sample above its
        # maxval, read a window at a time) would index past it
        top = int(arr.max())
        if top > full_scale:
            raise ValueError(
                f"image: expected intensities 0..{full_scale} (its full scale, a PGM's "
                f"maxval), received a pixel of {top}"
            )
    if mode == "raw" and full_scale != 255:
        raise ValueError(
            f"mode='raw': expected an 8-bit image (full scale 255), received full scale "
            f"{full_scale}"
        )
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
        lut[v >= _ipa_free_min(full_scale)] = _FREE
    for u in _unknown_value_list(unknown_values):
        if not 0.0 <= u <= full_scale:
            raise ValueError(
                f"unknown_values: expected intensities in [0, {full_scale}], received {u!r}"
            )
        idx = u * n
        if idx == int(idx):  # a mean of integer channels can only equal k / n
            lut[int(idx)] = _UNK
    return lut[colour]


def _ipa_free_min(full_scale: int) -> float:
    """The least intensity on ``0 .. full_scale`` that ``mode="ipa"`` reads as free: 250
    of 255, as the IPA tools read 8-bit images; for 16-bit ones 250 * 256, as they read
    them (``cv::imread(path, 0)`` keeps the high byte, so 64000 is their 250); on
    another scale (a PGM maxval) the same share, 250 / 255 of it."""
    if full_scale == 65535:
        return float(_IPA_FREE_MIN * 256)
    return _IPA_FREE_MIN * full_scale / 255.0


def _only_0_and_1(arr: np.ndarray) -> bool:
    """Does a uint8 array hold the value 1 and nothing but 0 and 1?"""
    return arr.size > 0 and int(arr.max()) == 1


def _grid_values(arr: np.ndarray) -> bool:
    """Does a uint8 array hold the value 100 and nothing but 0, 100 and 255?"""
    if not arr.size or int(arr.max()) not in (100, 255) or not (arr == 100).any():
        return False
    return not np.count_nonzero((arr != 0) & (arr != 100) & (arr != 255))


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


def _in_precision(dtype: np.dtype, values: list[float]) -> list[float]:
    """``values`` rounded to ``dtype`` where it is a float (``bfloat16`` too), else as
    given (an integer dtype, ``int4``)."""
    if not values:
        return values
    if dtype.kind == "V" and dtype.fields is None:  # an ml_dtypes type: a float or not?
        import ml_dtypes  # a dependency of JAX

        try:
            ml_dtypes.finfo(dtype)
        except (TypeError, ValueError):  # an integer (int4) or a plain void
            return values
    elif dtype.kind != "f":
        return values
    with np.errstate(over="ignore"):  # a value beyond the dtype matches none of its own
        return [float(v) for v in np.asarray(values).astype(dtype)]


def _classify_probability(
    arr: np.ndarray,
    occupied_thresh: float,
    free_thresh: float,
    unknown_values: Iterable[float] | None,
    precision: np.dtype,
) -> np.ndarray:
    """Classify a float array of occupancy probabilities in [0, 1]; the thresholds and
    ``unknown_values`` compare in ``precision`` (as written: a float32 ``0.196`` is the
    threshold 0.196, not the float just below it; 0.1 is float32(0.1))."""
    n_nan = int(np.count_nonzero(np.isnan(arr)))
    if n_nan:
        raise ValueError(
            f"array: expected occupancy probabilities in [0, 1], received a float array with "
            f"{n_nan} NaN values (cells of unknown occupancy? mask them, "
            "np.ma.masked_invalid(array): masked cells are unknown)"
        )
    extra = _in_precision(precision, _unknown_value_list(unknown_values))
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
    # the thresholds rounded to the array's dtype: float64 comparisons with them are exact
    occupied_thresh, free_thresh = _in_precision(precision, [occupied_thresh, free_thresh])
    codes = np.full(arr.shape, _UNK, dtype=np.uint8)
    codes[arr < np.float64(free_thresh)] = _FREE
    codes[arr > np.float64(occupied_thresh)] = _OCC
    if forced is not None:
        codes[forced] = _UNK
    return codes


# ---------------------------------------------------------------------- image reading


#: Below this share of occupied pixels around the free space, the walls are probably
#: classified unknown (drawn in grey) rather than occupied.
LOW_WALL_SHARE = 0.2


def wall_share(occupied: np.ndarray, free: np.ndarray) -> float | None:
    """Share of the pixels next to the free space (8-neighbours, not free themselves)
    that are occupied rather than unknown; None without free space.

    A SLAM map's free space is bounded mostly by walls (occupied) and partly by unexplored
    space; a share far below :data:`LOW_WALL_SHARE` means the walls were read as unknown
    (grey walls, a threshold that does not fit the image)."""
    free = np.asarray(free, bool)
    if not free.any():
        return None
    return share_of_rim(*rim_counts(occupied, free))


def rim_counts(occupied: np.ndarray, free: np.ndarray, rows: slice = slice(None)):
    """The pixels next to the free space (8-neighbours, not free themselves) among
    ``rows`` of the (H, W) masks, and how many of them are occupied; a map read in bands
    of rows gives its :func:`wall_share` from each band read with a row more on either
    side, counted over the band's own rows."""
    import cv2

    free = np.ascontiguousarray(free, bool)
    near = cv2.dilate(free.view(np.uint8), np.ones((3, 3), np.uint8)).view(bool)
    rim = (near & ~free)[rows]
    return int(np.count_nonzero(rim)), int(np.count_nonzero(rim & np.asarray(occupied, bool)[rows]))


def share_of_rim(n_rim: int, n_rim_occupied: int) -> float:
    """:func:`wall_share` from :func:`rim_counts` of a map with free space."""
    if n_rim == 0:
        return 1.0  # free up to the map's edge: nothing reads as a missing wall
    return n_rim_occupied / n_rim


def wall_warning(
    share: float | None, *, to_check: str = "occupied_thresh, free_thresh or map_mode"
) -> str | None:
    """The warning for a map whose :func:`wall_share` is low, else None; ``to_check``
    names the settings to check (as the caller's user gives them)."""
    if share is None or share >= LOW_WALL_SHARE:
        return None
    return (
        f"warning: only {100 * share:.0f}% of the pixels around the free space are occupied, "
        f"the rest unknown: are the walls drawn in grey? check {to_check}"
    )
