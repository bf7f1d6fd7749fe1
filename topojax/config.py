"""Frozen configuration dataclasses for every pipeline stage.

Units are in the field names: ``_px`` is pixels, ``_m`` is metres.  All options are
keyword-only, so configurations read the same in code, notebooks and the CLI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ._validate import (
    finite_positive,
    flag,
    float32_finite,
    integer,
    kernel_tile_px,
    kernel_tiles_per_call,
    metres_per_pixel,
    nonnegative_metres,
    one_of,
    positive_metres,
    quantity,
    real_number,
)

__all__ = [
    "ORIGINAL_SIGMA_PX",
    "ORIGINAL_HALF_WIDTH_PX",
    "DistanceConfig",
    "RidgeConfig",
    "SkeletonConfig",
    "GraphConfig",
    "PipelineConfig",
]

#: Effective standard deviation (pixels) of the original implementation's 455-sample kernel
#: ``gkern(455, nsig=5)``: ``sqrt(2 / bw**2 + 1 / 6)`` with ``bw = (10 + 11/455) / 455``.
ORIGINAL_SIGMA_PX = math.sqrt(2.0 / ((10.0 + 11.0 / 455.0) / 455.0) ** 2 + 1.0 / 6.0)
#: Half-width of the original square kernel support (455 = 2 * 227 + 1 pixels).
ORIGINAL_HALF_WIDTH_PX = 227

#: The settings of :class:`GraphConfig` that prune a graph (:func:`topojax.prune_graph`).
PRUNING_SETTINGS = ("min_clearance_m", "min_spur_m", "min_component_m")

_THINNING = ("guo_hall", "zhang")
#: Largest window half-width the distance kernels take (pixels).
_MAX_HALF_WIDTH_PX = 4096
#: Smallest sigma (pixels): every sigma below about 0.07 px gives the same distance map,
#: the obstacles alone (the Gaussian is 0 in float32 one pixel away), and below about
#: 1e-19 px the kernels' float32 ``1 / (2 sigma^2)`` overflows and the map is NaN.
_MIN_SIGMA_PX = 1e-6
#: Per OpenCV aperture, the sum of the Laplacian kernel's positive weights (that of its
#: negative ones is the same): the largest |Laplacian| of a map with values in [0, 1].
_MAX_LAPLACIAN = {1: 4.0, 3: 8.0, 5: 56.0}


def _scale_range(ksize: int, threshold: float) -> tuple[float, float]:
    """``(low, high)``: the ``scale`` factors with which the ridge test
    ``round(|Laplacian(scale * H)|) > threshold`` on a distance map ``H`` in [0, 1] means
    something.  The test is ``|Laplacian(H)| > cut / scale`` with ``cut = floor(threshold)
    + 0.5``: below ``low = cut / max|Laplacian|`` no pixel can pass; above ``high``, ``cut
    / scale`` is under ``2 max|Laplacian| 2**-24``, the Laplacian of a one-step float32
    rounding (2**-24 below 1) of every pixel of H, the size of the float32 kernels'
    rounding error."""
    peak = _MAX_LAPLACIAN[ksize]
    cut = math.floor(threshold) + 0.5
    return cut / peak, cut / (2.0 * peak * 2.0**-24)


def _canonical(obj: object, name: str, value: object) -> None:
    object.__setattr__(obj, name, value)  # frozen dataclass: store the checked value


@dataclass(frozen=True, kw_only=True)
class DistanceConfig:
    """Gaussian max-splat distance map ``H(x) = max_p exp(-|x - p|^2 / (2 sigma^2))``.

    The maximum runs over obstacle pixels ``p`` inside the square window
    ``|row(x) - row(p)| <= half_width_px`` and ``|col(x) - col(p)| <= half_width_px``
    (the support of the original's 455 x 455 kernel).

    Parameters
    ----------
    sigma_px : float
        Gaussian standard deviation in pixels, at least 1e-6.  Default: the original's
        effective 64.19283 px.
    half_width_px : int, optional
        Half-width ``R`` of the square support in pixels (kernel size ``2R + 1``), at
        least ``sigma_px`` (a narrower window cuts the Gaussian off inside one sigma and
        flattens the map's ridges away).  Default: scaled with ``sigma_px`` as in the
        original, 227 px for 64.19 px (about 3.54 sigma each side), rounded.
        Shape-setting: a new value compiles a new kernel.
    """

    sigma_px: float = ORIGINAL_SIGMA_PX
    half_width_px: int | None = None

    def __post_init__(self) -> None:
        sigma_px = quantity("sigma_px", self.sigma_px, unit="pixels", allow_zero=False)
        if sigma_px < _MIN_SIGMA_PX:
            raise ValueError(
                f"sigma_px: expected at least {_MIN_SIGMA_PX:g} px (every narrower Gaussian "
                f"gives the same distance map, the obstacles alone), received {sigma_px!r}"
            )
        _canonical(self, "sigma_px", sigma_px)
        if self.half_width_px is None:
            half = _scaled_half_width(sigma_px)
            if half > _MAX_HALF_WIDTH_PX:
                raise ValueError(
                    f"sigma_px: {sigma_px!r} px needs a support of {half} px (about 3.54 "
                    f"sigma each side), more than the largest half-width, "
                    f"{_MAX_HALF_WIDTH_PX} px"
                )
            _canonical(self, "half_width_px", half)
            return
        half = integer("half_width_px", self.half_width_px)
        _canonical(self, "half_width_px", half)
        if not 1 <= half <= _MAX_HALF_WIDTH_PX:
            raise ValueError(
                f"half_width_px: expected an int in [1, {_MAX_HALF_WIDTH_PX}], received {half}"
            )
        if half < sigma_px:
            raise ValueError(
                f"half_width_px: expected at least sigma_px ({sigma_px:.6g} px), so that the "
                f"window holds the Gaussian out to one sigma; received {half} (leave it "
                "unset to scale it with sigma_px)"
            )

    @classmethod
    def from_metres(
        cls, *, sigma_m: float, resolution_m: float, half_width_m: float | None = None
    ) -> DistanceConfig:
        """Build a configuration from metric sizes.

        Parameters
        ----------
        sigma_m : float
            Gaussian standard deviation in metres.
        resolution_m : float
            Map resolution in metres per pixel.
        half_width_m : float, optional
            Support half-width in metres; default: the original's ratio, 227 px of
            support for 64.19 px of sigma (about 3.54 sigma on each side), rounded.
        """
        sigma_m = positive_metres("sigma_m", sigma_m)
        resolution_m = metres_per_pixel("resolution_m", resolution_m)
        sigma_px = sigma_m / resolution_m
        if sigma_px < _MIN_SIGMA_PX:
            raise ValueError(
                f"sigma_m: {sigma_m!r} m at {resolution_m!r} m/px is {sigma_px:.6g} px, less "
                f"than the narrowest sigma, {_MIN_SIGMA_PX:g} px (every narrower Gaussian "
                "gives the same distance map, the obstacles alone)"
            )
        if half_width_m is None:
            half = _scaled_half_width(sigma_px)
            if half > _MAX_HALF_WIDTH_PX:
                raise ValueError(
                    f"sigma_m: {sigma_m!r} m at {resolution_m!r} m/px is {sigma_px:.6g} px, "
                    f"whose support (about 3.54 sigma each side: {half} px) exceeds the "
                    f"largest half-width, {_MAX_HALF_WIDTH_PX} px"
                )
            return cls(sigma_px=sigma_px, half_width_px=half)
        half_width_m = positive_metres("half_width_m", half_width_m)
        half = max(1, round(half_width_m / resolution_m))
        if half > _MAX_HALF_WIDTH_PX:
            raise ValueError(
                f"half_width_m: {half_width_m!r} m at {resolution_m!r} m/px is {half} px, "
                f"more than the largest half-width, {_MAX_HALF_WIDTH_PX} px"
            )
        if half < sigma_px:
            raise ValueError(
                f"half_width_m: expected at least sigma_m ({sigma_m!r} m); received "
                f"{half_width_m!r} m ({half} px at {resolution_m!r} m/px)"
            )
        return cls(sigma_px=sigma_px, half_width_px=half)

    @classmethod
    def from_pixels(cls, *, sigma_px: float) -> DistanceConfig:
        """A configuration with this sigma (pixels) and the support scaled with it as in
        the original: the same as ``DistanceConfig(sigma_px=sigma_px)``."""
        return cls(sigma_px=sigma_px)


def _scaled_half_width(sigma_px: float) -> int:
    """The original's support for this sigma: 227 px for 64.19 px, rounded, >= 1."""
    return max(1, round(sigma_px * ORIGINAL_HALF_WIDTH_PX / ORIGINAL_SIGMA_PX))


@dataclass(frozen=True, kw_only=True)
class RidgeConfig:
    """Laplacian ridge detection on the scaled distance map.

    ``ridge = round(|Laplacian(scale * H)|) > threshold`` with OpenCV's ``Laplacian``
    kernels and its default ``BORDER_REFLECT_101`` border, and OpenCV's
    ``convertScaleAbs`` rounding (half to even) and saturation to 0..255.

    Parameters
    ----------
    scale : float
        Factor applied to the [0, 1] distance map before filtering (paper: 255).  The
        ridges depend on ``threshold / scale`` (and the rounding).  A scale at which no
        pixel can pass the threshold is refused: below ``(floor(threshold) + 0.5) / 56``,
        56 being the largest |Laplacian| of a [0, 1] map with aperture 5 (8 with 3, 4
        with 1).  So is one at which the threshold, on the unscaled Laplacian, falls
        below float32's rounding error of it (``2 * 56 * 2**-24`` with aperture 5): the
        test then asks for more than the float32 kernels compute, and every pixel with
        any curvature passes.  With the paper's aperture and threshold: 0.1875 to
        1572864.
    ksize : int
        OpenCV Laplacian aperture: 1, 3 or 5 (paper: 5).
    threshold : float
        Ridge threshold on the rounded absolute response, ``>= 0`` (paper: 10; strict
        ``>``).  Like ``scale``, at most float32's largest finite value (about 3.4e38):
        both reach the kernels as float32.
    """

    scale: float = 255.0
    ksize: int = 5
    threshold: float = 10.0

    def __post_init__(self) -> None:
        _canonical(self, "scale", float32_finite("scale", finite_positive("scale", self.scale)))
        _canonical(self, "ksize", integer("ksize", self.ksize))
        if self.ksize not in (1, 3, 5):
            raise ValueError(
                f"ksize: expected 1, 3 or 5 (OpenCV apertures), received {self.ksize!r}"
            )
        threshold = real_number("threshold", self.threshold)
        if threshold < 0:  # every pixel's rounded |response| is >= 0: all would be ridges
            raise ValueError(
                f"threshold: expected a finite number >= 0 (on the rounded absolute "
                f"Laplacian), received {threshold!r}"
            )
        _canonical(self, "threshold", float32_finite("threshold", threshold))
        low, high = _scale_range(self.ksize, threshold)
        if not low <= self.scale <= high:
            raise ValueError(
                f"scale: expected {low:.6g} to {high:.6g} with ksize={self.ksize} and "
                f"threshold={threshold:g} (below, no pixel of a [0, 1] map passes "
                "round(|Laplacian(scale * H)|) > threshold; above, the threshold on the "
                "unscaled Laplacian, about threshold / scale, lies under the float32 kernels' "
                "rounding error of it, and every pixel with any curvature passes), received "
                f"{self.scale!r}"
            )


@dataclass(frozen=True, kw_only=True)
class SkeletonConfig:
    """Thinning of the ridge map.

    Parameters
    ----------
    thinning : {"guo_hall", "zhang"}
        ``"guo_hall"`` (the paper's choice; equals ``skimage.morphology.thin``) or
        ``"zhang"`` (Zhang–Suen, what the original full-map code ran; equals
        ``skimage.morphology.skeletonize``).
    remove_t : bool
        Remove T-junction centre pixels after thinning (paper §II-B).
    """

    thinning: str = "guo_hall"
    remove_t: bool = True

    def __post_init__(self) -> None:
        one_of("thinning", self.thinning, _THINNING)
        _canonical(self, "remove_t", flag("remove_t", self.remove_t))


@dataclass(frozen=True, kw_only=True)
class GraphConfig:
    """Skeleton-to-graph conversion, and what to keep of the graph.

    The defaults are the paper's: every ridge is thinned and every piece of skeleton
    becomes part of the graph.  Route graphs of real maps usually want less.

    Parameters
    ----------
    merge_junction_clusters : bool
        Collapse 8-connected clusters of junction pixels into one vertex.  Default False,
        the paper's semantics (every pixel of degree != 2 is a vertex).
    free_space_only : bool
        Thin only the ridges in known free space (``OccupancyMap.free``): ridges in
        unknown space and on obstacles are dropped first, so the graph stays where the
        robot can go and ends where the map does.  Default False.
    min_clearance_m : float
        Remove edges whose narrowest clearance is below this, in metres, e.g. the robot's
        radius plus a margin (:func:`topojax.prune_graph`).  Default 0: keep all.
    min_spur_m : float
        Remove dead-end branches (end vertex to junction) shorter than this, in metres,
        round after round (:func:`topojax.prune_graph`).  Default 0: keep all.
    min_component_m : float
        Remove connected components whose edges total less than this, in metres
        (isolated vertices count 0 m).  Default 0: keep all.
    """

    merge_junction_clusters: bool = False
    free_space_only: bool = False
    min_clearance_m: float = 0.0
    min_spur_m: float = 0.0
    min_component_m: float = 0.0

    def __post_init__(self) -> None:
        for name in ("merge_junction_clusters", "free_space_only"):
            _canonical(self, name, flag(name, getattr(self, name)))
        for name in ("min_clearance_m", "min_spur_m", "min_component_m"):
            _canonical(self, name, nonnegative_metres(name, getattr(self, name)))
        if self.merge_junction_clusters and (self.min_spur_m > 0 or self.min_clearance_m > 0):
            raise ValueError(
                "min_spur_m and min_clearance_m > 0 need merge_junction_clusters=False (a "
                "vertex left with two edges is joined at its pixel; a merged cluster has "
                "several)"
            )

    @property
    def prunes(self) -> bool:
        """Whether :func:`topojax.prune_graph` has anything to do."""
        return any(getattr(self, name) > 0 for name in PRUNING_SETTINGS)


@dataclass(frozen=True, kw_only=True)
class PipelineConfig:
    """Everything :func:`topojax.build_graph` needs besides the map.

    Parameters
    ----------
    distance, ridge, skeleton, graph : stage configurations
    tile_px : int
        Side of the square tiles the JAX kernels run on, 8 to 4096.  Shape-setting: every
        map size is served by the kernels compiled for this tile size.
    tiles_per_call : int
        Number of tiles handed to one kernel call (a fixed bucket, so maps of any size
        reuse the compiled kernels; a short last call is padded with empty tiles), at
        most ``2**28 // tile_px**2``.  On a CPU, 1 wastes nothing on padding and the
        calls are spread over every core.
    """

    distance: DistanceConfig = field(default_factory=DistanceConfig)
    ridge: RidgeConfig = field(default_factory=RidgeConfig)
    skeleton: SkeletonConfig = field(default_factory=SkeletonConfig)
    graph: GraphConfig = field(default_factory=GraphConfig)
    tile_px: int = 256
    tiles_per_call: int = 1

    def __post_init__(self) -> None:
        for name, kind in (
            ("distance", DistanceConfig),
            ("ridge", RidgeConfig),
            ("skeleton", SkeletonConfig),
            ("graph", GraphConfig),
        ):
            value = getattr(self, name)
            if not isinstance(value, kind):
                raise TypeError(
                    f"{name}: expected a {kind.__name__}, received {type(value).__name__} {value!r}"
                )
        _canonical(self, "tile_px", kernel_tile_px("tile_px", self.tile_px))
        _canonical(
            self,
            "tiles_per_call",
            kernel_tiles_per_call("tiles_per_call", self.tiles_per_call, self.tile_px),
        )
