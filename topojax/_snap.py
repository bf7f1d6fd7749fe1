"""Where a query point joins a topology graph, for :class:`topojax.routing.RoutePlanner`:
the snaps it may take and the refusals of a point too far off to snap."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ._caller import outside_stacklevel

__all__ = [
    "FAR",
    "GRID_ATTRIBUTES",
    "RESOLVED",
    "TIE",
    "Snap",
    "SnapLimitError",
    "check_box_gap",
    "check_resolved",
    "unrecorded_grid",
    "warn_unchecked_grid",
]

#: The graph attributes a planner's map is checked against.
GRID_ATTRIBUTES = ("shape", "resolution_m", "origin")

#: Corridor points at most this much farther from a query point than the nearest one
#: (metres, or pixels in the pixel frame) are as near: the same pixel on edges that cross.
TIE = 1e-9

#: A query point farther than this from the box round the graph's points (metres, or
#: pixels in the pixel frame) is refused before the k-d tree's search, whose squared
#: distances would overflow (a float's square root of its largest value is about 1.3e154).
FAR = 1e150

#: A query point farther than this from the graph (metres, or pixels in the pixel frame)
#: is refused: there a float64 distance's rounding (about 2.2e-16 of it, a few times
#: over) nears :data:`TIE`, so points far apart on the graph would tie as nearest and a
#: far start and goal could meet on one (a route of length 0).
RESOLVED = 1e5


class SnapLimitError(ValueError):
    """A start or goal farther from the graph than the snap limit.

    Its message names the planner's parameter, ``max_snap_m``; ``name`` (``"start"`` or
    ``"goal"``), ``distance_m`` and ``limit_m`` (metres) let a caller that took the limit
    under another name (a command-line option) word it with :meth:`worded`.
    """

    def __init__(self, name: str, distance_m: float, limit_m: float) -> None:
        self.name, self.distance_m, self.limit_m = name, distance_m, limit_m
        super().__init__(self.worded(f"max_snap_m={limit_m}", "a larger max_snap_m, or None"))

    def __reduce__(self):
        return type(self), (self.name, self.distance_m, self.limit_m)

    def worded(self, limit: str, lift: str) -> str:
        """The message with the limit written ``limit`` and how to lift it ``lift``."""
        return (
            f"{self.name}: the nearest point of the graph is {self.distance_m:.6g} m away, "
            f"more than {limit} (pass {lift} for no limit)"
        )


@dataclass(frozen=True)
class Snap:
    """A point where a route may join the graph."""

    edge: int  # index into the planner's edges, or -1 for a vertex without edges
    index: int  # position on the edge's path (or 0)
    vertex: object  # the vertex (node id) for edge == -1, else None
    distance_m: float
    feasible: bool | None = None  # the leg to it fits the robot (None: without the map)


def check_box_gap(name: str, q: np.ndarray, tree, scale: float, frame: str) -> None:
    """Refuse query ``q`` (a ``ValueError`` naming it as ``name``) when it lies more than
    :data:`FAR` from the box round the k-d ``tree``'s points, before a search whose squared
    distances would overflow; ``scale``: metres per unit of the ``frame``."""
    with np.errstate(over="ignore"):  # a gap beyond float range is inf: refused below
        box_gap = float(np.hypot(*np.maximum(np.maximum(tree.mins - q, q - tree.maxes), 0.0)))
    if box_gap > FAR:
        raise ValueError(
            f"{name}: the nearest point of the graph is more than {box_gap * scale:.6g} m "
            f"away; expected a point near the graph, received {tuple(q.tolist())} "
            f"({frame} frame): is it in the graph's frame and units?"
        )


def check_resolved(name: str, q: np.ndarray, distance: float, scale: float, frame: str) -> None:
    """Refuse query ``q`` (named ``name``) whose nearest point of the graph lies
    ``distance`` (units of the ``frame``, ``scale`` metres each) away, more than
    :data:`RESOLVED`: too far for its distances to the graph's points to be told apart."""
    if distance <= RESOLVED:
        return
    unit = "m" if frame == "world" else "pixels"
    raise ValueError(
        f"{name}: the nearest point of the graph is {distance * scale:.6g} m away, farther "
        f"than {RESOLVED:g} {unit}, where the distances to the graph's points can no longer "
        "be told apart in floating point (max_snap_m=None lifts the snap limit, not this); "
        f"expected a point near the graph, received {tuple(q.tolist())} ({frame} frame): "
        "is it in the graph's frame and units?"
    )


def unrecorded_grid(attrs: dict, *, quote: str = "'") -> str:
    """The attributes of :data:`GRID_ATTRIBUTES` that a graph's attributes ``attrs``
    lack, in words (``'shape' or 'origin'``, each in ``quote``); empty when none."""
    missing = [f"{quote}{name}{quote}" for name in GRID_ATTRIBUTES if attrs.get(name) is None]
    if len(missing) < 2:
        return "".join(missing)
    return f"{', '.join(missing[:-1])} or {missing[-1]}"


def warn_unchecked_grid(attrs: dict) -> None:
    """Warn (``UserWarning``) that a planner's ``occupancy`` cannot be fully checked to be
    the map of a graph whose attributes ``attrs`` lack some of :data:`GRID_ATTRIBUTES`,
    naming them."""
    missing = unrecorded_grid(attrs)
    if missing:
        warnings.warn(
            f"occupancy: the graph records no {missing}, so the map cannot be checked to be "
            "its map by that: legs to the graph are planned over the pixels of the map given "
            "(set the attributes from the graph's map to check it)",
            UserWarning,
            stacklevel=outside_stacklevel(),
        )
