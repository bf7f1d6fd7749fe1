"""The map resolutions a route graph can be built at: the least robot radius and coverage
reach in pixels, and the checks that name what is too small or too coarse."""

from __future__ import annotations

from .._validate import MAX_ROBOT_RADIUS_M

__all__ = ["MAX_SNAP_M", "MIN_RADIUS_PX", "MIN_REACH_PX", "check_scale", "reach_in_px"]

#: The largest ``snap_m`` (metres), of the route graphs and of their scores
#: (:func:`topojax.evaluate_route_graph`): the coverage test of a pixel scans the graph
#: pixels within the snap distance, work that grows with its square, and routes join a
#: graph within 5 m by default (:data:`topojax.routing.DEFAULT_MAX_SNAP_M`).
MAX_SNAP_M = 5.0

#: The least coverage reach, ``snap_m - waypoint_tolerance_m``, in pixels of the map: a
#: reach of about a pixel covers the free space with a mesh of edges a pixel apart.
MIN_REACH_PX = 1.5

#: The least robot radius in pixels of the map: a smaller robot's paths squeeze between
#: the corners of single obstacle pixels, which a waypoint polyline cannot follow safely.
MIN_RADIUS_PX = 1.5

# A length in metres that is one of the limits above to rounding (0.075 m / 0.05 m is
# 1.4999999999999998) is at the limit: the comparisons in pixels allow this much.
_ROUNDING_PX = 1e-9


def check_scale(
    cfg,
    res: float,
    radius_name: str = "robot_radius_m",
    snap_name: str | None = "snap_m",
    resolution_name: str = "resolution_m",
) -> None:
    """Refuse a robot radius, a ``snap_m`` or a ``shortcut_spacing_m`` of ``cfg`` (a
    :class:`~topojax.routegraph.RouteGraphConfig`) too small for a map of ``res`` metres
    per pixel (see MIN_RADIUS_PX and MIN_REACH_PX; a spacing between 0
    and one pixel), and a map so coarse that no radius or no snap_m fits
    (:func:`_too_coarse`); the errors name ``radius_name``, ``snap_name`` and
    ``resolution_name`` (``snap_name`` None: a caller that cannot set ``snap_m``)."""
    _too_coarse(cfg, res, snap_name, resolution_name)
    if cfg.robot_radius_m / res < MIN_RADIUS_PX - _ROUNDING_PX:
        raise ValueError(
            f"{radius_name}: expected at least {MIN_RADIUS_PX:g} pixels of the map "
            f"({MIN_RADIUS_PX * res:g} m at {res:g} m per pixel), received "
            f"{cfg.robot_radius_m!r}; below that the graph's paths would squeeze between "
            "single obstacle pixels"
        )
    if reach_in_px(cfg, res) < MIN_REACH_PX - _ROUNDING_PX:
        least = _least_snap_m(cfg, res)
        raise ValueError(
            f"{snap_name}: expected at least the waypoint tolerance "
            f"({cfg.waypoint_tolerance_m:g} m) plus {MIN_REACH_PX:g} pixels of the map "
            f"({least:g} m at {res:g} m per pixel), received {cfg.snap_m!r}"
        )
    if 0 < cfg.shortcut_spacing_m < res:
        raise ValueError(
            f"shortcut_spacing_m: expected 0 (shortcuts from vertices only) or at least one "
            f"pixel of the map ({res:g} m), received {cfg.shortcut_spacing_m!r}; anchors "
            "closer than a pixel are the same anchors, at many times the time and memory"
        )


def _least_snap_m(cfg, res: float) -> float:
    """The least ``snap_m`` on a map of ``res`` metres per pixel: the waypoint tolerance of
    ``cfg`` plus MIN_REACH_PX pixels."""
    return cfg.waypoint_tolerance_m + MIN_REACH_PX * res


def _too_coarse(cfg, res: float, snap_name: str | None, resolution_name: str):
    """Refuse a map of ``res`` metres per pixel on which the least robot radius or the
    least ``snap_m`` (for the waypoint tolerance of ``cfg``) is above its largest value
    (``cfg``'s own where ``snap_name`` is None): asked for one of them, the user would be
    refused it as too large."""
    least_radius = MIN_RADIUS_PX * res
    least_snap = _least_snap_m(cfg, res)
    most_snap = MAX_SNAP_M if snap_name is not None else cfg.snap_m
    reasons = []
    if least_radius > MAX_ROBOT_RADIUS_M * (1 + _ROUNDING_PX):
        reasons.append(
            f"its least robot radius, {MIN_RADIUS_PX:g} pixels ({least_radius:g} m), is above "
            f"the largest accepted, {MAX_ROBOT_RADIUS_M:g} m"
        )
    if snap_name is None and least_snap > most_snap * (1 + _ROUNDING_PX):
        reasons.append(
            f"its route graph's coverage distance, {most_snap:g} m, is below the waypoint "
            f"tolerance ({cfg.waypoint_tolerance_m:g} m) plus {MIN_REACH_PX:g} pixels "
            f"({least_snap:g} m)"
        )
    elif least_snap > MAX_SNAP_M * (1 + _ROUNDING_PX):
        reasons.append(
            f"its least {snap_name}, the waypoint tolerance ({cfg.waypoint_tolerance_m:g} m) "
            f"plus {MIN_REACH_PX:g} pixels ({least_snap:g} m), is above the largest accepted, "
            f"{MAX_SNAP_M:g} m"
        )
    if reasons:
        coarsest = min(
            MAX_ROBOT_RADIUS_M / MIN_RADIUS_PX,
            (most_snap - cfg.waypoint_tolerance_m) / MIN_REACH_PX,
        )
        raise ValueError(
            f"{resolution_name}: expected at most {coarsest:g} m per pixel for a route graph, "
            f"received {res:g}: {'; '.join(reasons)}"
        )


def reach_in_px(cfg, res: float) -> float:
    """The coverage reach in pixels: the robot follows the simplified waypoints, up to
    the tolerance off the pixel paths."""
    return (cfg.snap_m - cfg.waypoint_tolerance_m) / res
