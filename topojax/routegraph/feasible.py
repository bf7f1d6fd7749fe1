"""Where a round robot of a given radius can be: the feasible space of a map.

A pixel is *feasible* for a robot of radius ``r`` when it is known free and the nearest
pixel that is not known free (occupied, unknown, or outside the map: the map's border is
a wall) lies at least ``r`` from it, measured between pixel centres.  Feasible pixels
split into 8-connected *regions*: the robot can drive between two feasible pixels exactly
when they lie in one region.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .._validate import is_real_number, robot_radius
from ..fields.clearance import CLEARANCE_RTOL, clearance_at_least, free_clearance_px
from ..maps import map_argument

__all__ = ["FeasibleSpace", "check_radius_within_graphs", "feasible_space"]


@dataclass(frozen=True, eq=False)
class FeasibleSpace:
    """The feasible space of one map for one robot radius.

    Attributes
    ----------
    free : bool (H, W)
        Known free pixels.
    clearance_m : float32 (H, W)
        Distance from each pixel centre to the nearest centre of a pixel that is not known
        free, with the map surrounded by such pixels; metres, 0 off the free space (a
        view, not contiguous: :func:`clearance_map_m`).
    feasible : bool (H, W)
        ``free & (clearance_m >= robot_radius_m)``, up to the clearance's rounding (one
        exactly ``robot_radius_m`` is feasible at any resolution).
    labels : int32 (H, W)
        Region of each feasible pixel, ``1..n_regions`` (8-connected); 0 elsewhere.
    area_m2 : float64 (n_regions + 1,)
        Area of each region in square metres (``area_m2[0]`` is 0).
    robot_radius_m, resolution_m : float
    """

    free: np.ndarray
    clearance_m: np.ndarray
    feasible: np.ndarray
    labels: np.ndarray
    area_m2: np.ndarray
    robot_radius_m: float
    resolution_m: float

    @property
    def n_regions(self) -> int:
        """Number of feasible regions."""
        return int(self.area_m2.size - 1)

    def regions_at_least(self, min_area_m2: float) -> np.ndarray:
        """Ids (int array, ascending, from 1) of the regions of at least ``min_area_m2``."""
        return (np.flatnonzero(self.area_m2[1:] >= min_area_m2) + 1).astype(np.int32)


def clearance_map_m(free: np.ndarray, resolution_m: float) -> np.ndarray:
    """Distance (metres, float32 (H, W)) from each pixel centre to the nearest pixel centre
    that is not ``free``, the map's outside counting as not free; 0 off ``free``.  A view
    (not contiguous) of the distance transform's framed output, scaled in place: no
    second image-sized array."""
    px = free_clearance_px(free)
    return np.multiply(px, np.float32(resolution_m), out=px)


def feasible_space(occupancy, robot_radius_m: float) -> FeasibleSpace:
    """The feasible space of ``occupancy`` for a round robot of radius ``robot_radius_m``.

    Parameters
    ----------
    occupancy : OccupancyMap or str or Path
        The map, or its file (read by :func:`topojax.load_map`); only its known-free
        pixels can be feasible.
    robot_radius_m : float
        Robot radius in metres (>= 0).

    Returns
    -------
    FeasibleSpace
    """
    occupancy = map_argument("occupancy", occupancy, files=True)
    radius = robot_radius("robot_radius_m", robot_radius_m)
    return feasible_space_of_free(
        np.asarray(occupancy.free, bool), float(occupancy.resolution_m), radius
    )


def feasible_space_of_free(free: np.ndarray, res: float, radius: float) -> FeasibleSpace:
    """:func:`feasible_space` of the known-free pixels ``free`` (bool (H, W), a map's or a
    window's whose outside is not free) at ``res`` metres per pixel, for a checked robot
    radius ``radius`` (metres)."""
    clearance = clearance_map_m(free, res)
    feasible = free & clearance_at_least(clearance, radius)  # radius <= MAX_ROBOT_RADIUS_M
    n, labels, stats, _ = cv2.connectedComponentsWithStats(
        feasible.view(np.uint8), connectivity=8, ltype=cv2.CV_32S
    )
    area = stats[:, cv2.CC_STAT_AREA].astype(np.float64) * res * res
    area[0] = 0.0
    return FeasibleSpace(
        free=free,
        clearance_m=clearance,
        feasible=feasible,
        labels=labels.astype(np.int32, copy=False),
        area_m2=area,
        robot_radius_m=radius,
        resolution_m=res,
    )


def route_graph_note(graph, occupancy, *, robot_radius_m: float, min_region_m2: float):
    """Why a route graph of ``occupancy`` has no vertex or no edge, as one line; None for
    a graph with edges.

    Parameters
    ----------
    graph : networkx.MultiGraph
        The route graph.
    occupancy : OccupancyMap
        Its map.
    robot_radius_m, min_region_m2 : float
        The options it was built with (m, m²).
    """
    n = graph.number_of_nodes()
    if graph.number_of_edges():
        return None
    if n:
        return f"warning: the route graph has {n} vert{'ex' if n == 1 else 'ices'}, no edge"
    free = np.asarray(occupancy.free, bool)
    if not free.any():
        why = "the map has no free pixel as classified"
    else:
        space = feasible_space_of_free(free, occupancy.resolution_m, robot_radius_m)
        most = float(space.clearance_m.max())
        why = (
            f"no known-free region of at least {min_region_m2:g} m2 where a robot of "
            f"radius {robot_radius_m:g} m fits (the most clearance from anything not "
            f"known free is {most:.3g} m"  # significant digits: maps of 1e-6 m/px too
        )
        largest = float(space.area_m2.max())
        if largest > 0:  # the robot fits: the regions are too small, not the clearance
            why += f"; the largest feasible region is {largest:.3g} m2, below min_region_m2"
        why += ")"
    return f"empty route graph: {why}"


def check_radius_within_graphs(attrs, radius_m: float) -> None:
    """A ValueError where ``radius_m`` (a planner's ``robot_radius_m``) is larger than
    the radius a route graph records it was built for (``attrs``' ``robot_radius_m``):
    its edges keep that far from obstacles only, so a route on it is no safe route for
    the larger robot.  A radius larger by no more than the clearances' rounding
    (:data:`~topojax.fields.clearance.CLEARANCE_RTOL`: the built one as a float32) is
    the built one.  Nothing for a graph that records none (a topology graph)."""
    built = attrs.get("robot_radius_m")
    if is_real_number(built) and radius_m > float(built) * (1 + CLEARANCE_RTOL):
        raise ValueError(
            f"robot_radius_m: expected at most the {float(built):.9g} m the route graph was "
            f"built for (its edges keep that far from obstacles, no farther), received "
            f"{radius_m:.9g} m; build the route graph for a robot of {radius_m:.9g} m"
        )
