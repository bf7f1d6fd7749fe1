"""The :class:`OccupancyMap` container: three disjoint class masks and the map frame.

Conventions
-----------
* Arrays are indexed ``grid[row, col]``; row 0 is the **top** row of the image.
* World coordinates follow ROS ``map_server``: ``origin = (x, y, yaw)`` is the world pose
  of the lower-left corner of the lower-left pixel. The centre of pixel ``(row, col)`` in
  the unrotated map frame is ``x' = (col + 0.5) * res``, ``y' = (H - row - 0.5) * res``;
  this point is rotated by ``yaw`` about the origin and translated by ``(x, y)``.
* Arrays and images are classified by :mod:`topojax.maps.classify`.
"""

from __future__ import annotations

import math
import numbers
import weakref
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import (
    binary_flag,
    instance_of,
    is_real_number,
    masked_entries,
    metres_per_pixel,
    occupancy_thresholds,
    one_of,
    pose,
    real_array,
    real_values,
    text_or_none,
    unmasked,
)
from .._words import graphml_text
from .classify import (
    _FREE,
    _OCC,
    _UNK,
    DEFAULT_FREE_THRESH,
    DEFAULT_OCCUPIED_THRESH,
    MODES,
    classify_array,
)

__all__ = [
    "DEFAULT_RESOLUTION_M",
    "OccupancyMap",
    "grid_mismatch",
    "grid_to_world",
    "map_mismatch",
    "window_origin",
    "world_to_grid",
]

#: Default resolution for plain images (the IPA benchmark and paper maps use 0.05 m/px).
DEFAULT_RESOLUTION_M = 0.05

# Pixel value written by ``to_image`` / ``save_map`` for each class (map_saver convention).
_IMAGE_OCCUPIED, _IMAGE_UNKNOWN, _IMAGE_FREE = 0, 205, 254

#: The mask arrays this module made read-only, by id (an entry goes with its array): no
#: caller holds a writeable array over their memory, so a map keeps them without a copy.
_FROZEN: weakref.WeakValueDictionary = weakref.WeakValueDictionary()


def _freeze(arr: np.ndarray) -> np.ndarray:
    """``arr``, a new array no caller has seen, made read-only and recorded as frozen."""
    arr.setflags(write=False)
    _FROZEN[id(arr)] = arr
    return arr


def _frozen_mask(arr: np.ndarray) -> np.ndarray:
    """``arr`` if it is a frozen mask or a read-only view of one, else a frozen copy: a
    read-only view of a caller's array (or a read-only array with a writeable view) would
    let the caller change the map."""
    owner = arr if arr.base is None else arr.base
    if not arr.flags.writeable and _FROZEN.get(id(owner)) is owner:
        return arr
    return _freeze(arr.copy())


def _broadcast(names: tuple[str, str], a: np.ndarray, b: np.ndarray):
    """``a`` and ``b`` after checking their shapes broadcast together; a ValueError
    naming both otherwise."""
    try:
        np.broadcast_shapes(a.shape, b.shape)
    except ValueError:
        raise ValueError(
            f"{names[0]}, {names[1]}: expected arrays of shapes that broadcast together, "
            f"received shapes {a.shape} and {b.shape}"
        ) from None
    return a, b


def world_to_grid(x, y, *, height: int, resolution_m: float, origin):
    """Continuous pixel coordinates ``rows, cols`` (float64) of world points ``x, y``
    (metres) on the grid of :func:`grid_to_world`, its inverse."""
    x, y = _broadcast(("x", "y"), real_array("x", x), real_array("y", y))
    dx = x - origin[0]
    dy = y - origin[1]
    cos_t, sin_t = math.cos(origin[2]), math.sin(origin[2])
    xm = cos_t * dx + sin_t * dy
    ym = -sin_t * dx + cos_t * dy
    return height - 0.5 - ym / resolution_m, xm / resolution_m - 0.5


def grid_to_world(rows, cols, *, height: int, resolution_m: float, origin):
    """World ``x, y`` (metres, float64) of continuous pixel coordinates of a grid of
    ``height`` rows with ``resolution_m`` metres per pixel whose lower-left corner is at
    ``origin`` (x, y, yaw); integer values are pixel centres (conventions above)."""
    r, c = _broadcast(("rows", "cols"), real_array("rows", rows), real_array("cols", cols))
    ox, oy, yaw = origin
    xm = (c + 0.5) * resolution_m
    ym = (height - r - 0.5) * resolution_m
    cos_t, sin_t = math.cos(yaw), math.sin(yaw)
    return ox + cos_t * xm - sin_t * ym, oy + sin_t * xm + cos_t * ym


def window_origin(origin, resolution_m: float, below: int, left: int):
    """The origin (x, y, yaw) of a window of a grid whose lower-left corner is at
    ``origin``: the window's lower-left corner, ``below`` rows above the grid's bottom and
    ``left`` columns right of its left edge, along the grid's own (rotated) axes, so that
    the window's pixels keep their world coordinates."""
    ox, oy, yaw = origin
    if below == 0 and left == 0:
        return origin
    dx, dy = left * resolution_m, below * resolution_m
    cos_t, sin_t = math.cos(yaw), math.sin(yaw)
    return (ox + cos_t * dx - sin_t * dy, oy + sin_t * dx + cos_t * dy, yaw)


@dataclass(frozen=True, eq=False, repr=False)
class OccupancyMap:
    """A 2-D occupancy grid split into three disjoint boolean masks.

    Parameters
    ----------
    occupied, free, unknown : np.ndarray of bool, shape (H, W)
        Class masks indexed ``[row, col]`` with row 0 at the top of the image. Exactly one
        of the three is True at every pixel. ``H`` and ``W`` must both be >= 2. The map
        stores read-only masks that no caller can write: an array given here is copied
        (a read-only view of a writeable array too), unless it is a mask of another
        map or a read-only view of one. :meth:`from_array` and :func:`load_map` make
        their masks without a copy.
    resolution_m : float
        Edge length of one pixel in metres (> 0).
    origin : tuple of 3 float
        ``(x_m, y_m, yaw_rad)``: world pose of the lower-left corner of the lower-left
        pixel (ROS ``map_server`` convention).
    source : str, os.PathLike or None
        Where the map came from (a path, kept as a str), used in messages.
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
            arr = unmasked(f"OccupancyMap.{name}", getattr(self, name))
            instance_of(f"OccupancyMap.{name}", arr, np.ndarray, "numpy bool array")
            if arr.dtype != np.bool_:
                raise TypeError(f"OccupancyMap.{name}: expected dtype bool, received {arr.dtype}")
            if arr.ndim != 2:
                raise ValueError(
                    f"OccupancyMap.{name}: expected a 2-D array (H, W), received shape {arr.shape}"
                )
            masks[name] = arr
        shapes = {name: arr.shape for name, arr in masks.items()}
        if len(set(shapes.values())) != 1:
            raise ValueError(f"OccupancyMap masks: expected the same shape, received {shapes}")
        shape = masks["occupied"].shape
        if shape[0] < 2 or shape[1] < 2:
            raise ValueError(f"OccupancyMap: expected at least 2x2 pixels, received shape {shape}")
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
            object.__setattr__(self, name, _frozen_mask(arr))
        object.__setattr__(
            self, "resolution_m", metres_per_pixel("resolution_m", self.resolution_m)
        )
        object.__setattr__(self, "origin", pose("origin", self.origin))
        object.__setattr__(self, "source", text_or_none("source", self.source, paths=True))

    def __setstate__(self, state: dict) -> None:
        """Restore a pickled or copied map: unpickled masks are new writeable arrays no
        caller holds yet, made read-only here (without a copy) as the map's own."""
        masks = {name: _freeze(np.asarray(state[name])) for name in ("occupied", "free", "unknown")}
        self.__dict__.update(state | masks)

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
        return grid_to_world(
            rows, cols, height=self.shape[0], resolution_m=self.resolution_m, origin=self.origin
        )

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
        return world_to_grid(
            x, y, height=self.shape[0], resolution_m=self.resolution_m, origin=self.origin
        )

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
        * **uint8** (H, W) grey image (``ml_dtypes``' uint4 too, as uint8), or (H, W, C)
          with C = 1 (grey), 2 (grey + alpha), 3 (RGB or BGR) or 4 (RGBA/BGRA): an image
          with ``map_server`` semantics. The intensity ``v`` is the mean of the colour
          channels (alpha ignored; a map read from a ROS YAML by :func:`load_map` follows
          ``map_server`` there too), then ``mode`` decides:

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
            (:func:`load_map` of a 16-bit image: free from 64000, the IPA tools' 250.)

          A 2-D image of nothing but 0 and 1 (an obstacle mask), or of 0, 100 and 255
          with 100 among them (ROS OccupancyGrid cells read as uint8, -1 as 255), is
          refused with a ValueError, unless ``mode="raw"`` (which reads the latter
          right) or ``unknown_values`` is given.

        * **int8 or other integer dtypes** (H, W) (not uint8 or uint4; int4 too): ROS
          ``nav_msgs/OccupancyGrid`` values, -1 = unknown, 0..100 = occupancy percent;
          occupied if ``v / 100 > occupied_thresh``, free if ``v / 100 < free_thresh``,
          else unknown.
          Values outside -1..100 raise ValueError.
        * **float** (H, W), JAX's ``bfloat16`` too: occupancy probabilities in [0, 1];
          occupied if ``p > occupied_thresh``, free if ``p < free_thresh``, else unknown,
          compared in the array's precision (the thresholds rounded to its dtype, so a
          float32 ``0.196`` is the free threshold 0.196, not below it). NaN
          or values outside [0, 1] raise ValueError (``np.ma.masked_invalid(array)`` makes
          NaN cells unknown).

        Whatever the dtype, the masked pixels of a NumPy masked array are unknown (a
        colour pixel with any channel masked); their values are not read.

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
            the values are compared with the intensity before ``negate``, for a float
            array in its precision (as the thresholds). Values listed here are exempt
            from the range checks of integer and float inputs. Not allowed for bool
            input.
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
        resolution_m = metres_per_pixel("resolution_m", resolution_m)
        origin_t = pose("origin", origin)
        occ_t, free_t = occupancy_thresholds(occupied_thresh, free_thresh)
        mode = one_of("mode", mode, MODES)
        negate = binary_flag("negate", negate)
        masked = masked_entries(array)
        given = unmasked("array", array, fill=0)  # 0: a value every dtype accepts
        try:
            values = np.asarray(given)
        except ValueError:  # nested lists whose rows differ in length
            raise ValueError(
                "array: expected rows of one length (an (H, W) array), received nested "
                f"sequences of different lengths ({type(array).__name__})"
            ) from None
        codes = classify_array(
            real_values(values),
            occupied_thresh=occ_t,
            free_thresh=free_t,
            negate=negate,
            mode=mode,
            unknown_values=unknown_values,
            given_type=type(array).__name__,
            precision=values.dtype,
        )
        if masked is not None:
            codes[masked if masked.ndim == codes.ndim else masked.any(axis=-1)] = _UNK
        return cls._from_codes(codes, resolution_m, origin_t, source, where="array")

    @classmethod
    def _from_codes(
        cls,
        codes: np.ndarray,
        resolution_m: float,
        origin: tuple[float, float, float],
        source: str | None,
        *,
        where: str,
    ) -> OccupancyMap:
        """The map of classified ``codes``; a refusal of their shape names ``where``."""
        if codes.ndim != 2 or codes.shape[0] < 2 or codes.shape[1] < 2:
            raise ValueError(f"{where}: expected at least 2x2 pixels, received shape {codes.shape}")
        occupied = codes == _OCC
        free = codes == _FREE
        unknown = codes == _UNK
        return cls(
            occupied=_freeze(occupied),
            free=_freeze(free),
            unknown=_freeze(unknown),
            resolution_m=resolution_m,
            origin=origin,
            source=source,
        )


# ---------------------------------------------------------------------- classification


def map_mismatch(graph, occupancy, *, graph_blamed: bool = False) -> str | None:
    """Why ``occupancy`` is not the map that ``graph`` records in its ``shape``,
    ``resolution_m`` and ``origin`` attributes (those it has), or None when it is: the
    same shape, the resolution to a relative 1e-9, the origin to 1e-9 m.  The reason
    expects the graph's map and receives ``occupancy``; with ``graph_blamed``, for an
    error that names the graph, it expects ``occupancy`` and receives the graph's."""
    attrs = graph.graph
    return grid_mismatch(
        attrs.get("shape"),
        attrs.get("resolution_m"),
        attrs.get("origin"),
        occupancy,
        owner="the graph's",
        owner_blamed=graph_blamed,
    )


def grid_mismatch(
    shape, resolution_m, origin, occupancy, *, owner: str, owner_blamed: bool = False
) -> str | None:
    """Why ``occupancy`` is not the map of ``shape`` (H, W), ``resolution_m`` and
    ``origin`` (each None when not known), or None when it is: the same shape, the
    resolution to a relative 1e-9, the origin to 1e-9 m.  ``owner`` (e.g. "the graph's")
    names whose map the message expects (with ``owner_blamed``, whose map it received);
    also why, when one of them is not what a map records (a graph's attributes edited by
    hand)."""
    malformed = _malformed_grid(shape, resolution_m, origin, owner)
    if malformed is not None:
        return malformed

    def why(kind: str, own, other) -> str:
        if owner_blamed:
            return f"expected a map {kind.format(other)}, received {owner} map {kind.format(own)}"
        return f"expected {owner} map {kind.format(own)}, received a map {kind.format(other)}"

    if shape is not None and tuple(shape) != tuple(occupancy.shape):
        return why("of shape {}", tuple(shape), tuple(occupancy.shape))
    res = resolution_m
    if isinstance(res, numbers.Real) and not math.isclose(res, occupancy.resolution_m):
        return why("at {} m/px", res, occupancy.resolution_m)
    if origin is not None and (
        np.shape(origin) != np.shape(occupancy.origin)
        or not np.allclose(origin, occupancy.origin, rtol=0.0, atol=1e-9)
    ):
        return why("with origin {}", tuple(origin), tuple(occupancy.origin))
    return None


def _numbers(value: Any, n: int, *, integral: bool = False) -> bool:
    """Is ``value`` a sequence (not a str) of ``n`` real numbers (whole and finite if
    ``integral``: ``4.0`` too, as a JSON or GraphML file may give them)?"""
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        return False
    items = list(value)
    if len(items) != n or not all(is_real_number(v) for v in items):
        return False
    return not integral or all(float(v).is_integer() for v in items)


def _malformed_grid(shape, resolution_m, origin, owner: str) -> str | None:
    """Why a recorded ``shape``, ``resolution_m`` or ``origin`` (None: not recorded) cannot
    be a map's, or None."""
    if shape is not None and not _numbers(shape, 2, integral=True):
        return (
            f"expected {owner} recorded shape to be 2 integers (rows, cols), received "
            f"{shape!r}{graphml_text(shape)}"
        )
    if resolution_m is not None and not is_real_number(resolution_m):
        return (
            f"expected {owner} recorded resolution_m to be a number, received "
            f"{type(resolution_m).__name__} {resolution_m!r}{graphml_text(resolution_m)}"
        )
    if origin is not None and not _numbers(origin, 3):
        return (
            f"expected {owner} recorded origin to be 3 numbers (x_m, y_m, yaw_rad), received "
            f"{origin!r}{graphml_text(origin)}"
        )
    return None
