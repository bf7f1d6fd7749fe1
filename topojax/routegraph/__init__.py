"""Route graphs for a round robot: sparse, safe and covering graphs built on topojax's
fields, and the metrics that score any route graph on a map."""

from __future__ import annotations

from .feasible import FeasibleSpace, feasible_space

__all__ = ["FeasibleSpace", "feasible_space"]
