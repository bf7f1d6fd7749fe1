"""Route graphs for a round robot: sparse, safe and covering graphs built on the feasible
space of a map (:func:`route_graph`), and the metrics that score any route graph on a map
(:func:`evaluate_route_graph`)."""

from __future__ import annotations

from ._eval_geometry import vertex_pixels
from .build import RouteGraphConfig, route_graph
from .evaluate import RouteGraphReport, evaluate_route_graph
from .feasible import FeasibleSpace, feasible_space

__all__ = [
    "FeasibleSpace",
    "RouteGraphConfig",
    "RouteGraphReport",
    "evaluate_route_graph",
    "feasible_space",
    "route_graph",
    "vertex_pixels",
]
