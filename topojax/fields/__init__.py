"""Dense per-pixel fields of a map on fixed-size JAX tiles: the windowed distance, the
Gaussian distance map, the Laplacian and its ridges, and the exact clearance.

See ``docs/design-fields.md`` for the distance algorithm and the tiling.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the names for type checkers; at run time each module loads on first use
    from .clearance import (
        SPARSE_CLEARANCE_MAX_PX,
        clearance_at,
        clearance_from_sq_distance,
        clearance_of_values,
        nearest_sq_distance,
    )
    from .dense import (
        FIELD_NAMES,
        DenseFields,
        dense_fields,
        dense_fields_many,
        distance_map,
        forward_tile,
        ridge_fields,
        ridge_fields_many,
        ridge_map,
        trace_counts,
    )
    from .distance import (
        FAR_SQ,
        brute_force_distance_map,
        column_distance_tile,
        column_dtype,
        gaussian_from_sq_distance,
        row_sq_distance_tile,
        window_sq_distance_tile,
    )
    from .filters import HALO_PX, laplacian_valid, reflect_101_halo, ridge_from_laplacian
    from .tile_grid import TileGrid
    from .tiling import GROWTH_FACTOR, MAX_GRID_CELLS, TileManager, unique_pairs

__all__ = [
    "FAR_SQ",
    "FIELD_NAMES",
    "GROWTH_FACTOR",
    "HALO_PX",
    "MAX_GRID_CELLS",
    "SPARSE_CLEARANCE_MAX_PX",
    "DenseFields",
    "TileGrid",
    "TileManager",
    "brute_force_distance_map",
    "clearance_at",
    "clearance_from_sq_distance",
    "clearance_of_values",
    "column_distance_tile",
    "column_dtype",
    "dense_fields",
    "dense_fields_many",
    "distance_map",
    "forward_tile",
    "gaussian_from_sq_distance",
    "laplacian_valid",
    "nearest_sq_distance",
    "reflect_101_halo",
    "ridge_fields",
    "ridge_fields_many",
    "ridge_from_laplacian",
    "ridge_map",
    "row_sq_distance_tile",
    "trace_counts",
    "unique_pairs",
    "window_sq_distance_tile",
]

#: Each public name and the module that defines it: the distance kernels import JAX, the
#: clearance helpers only NumPy and OpenCV, so a caller of the latter (the route graphs,
#: the rooms) does not pay for JAX.
_LAZY = {
    "DenseFields": "dense",
    "FAR_SQ": "distance",
    "FIELD_NAMES": "dense",
    "GROWTH_FACTOR": "tiling",
    "HALO_PX": "filters",
    "MAX_GRID_CELLS": "tiling",
    "SPARSE_CLEARANCE_MAX_PX": "clearance",
    "TileGrid": "tile_grid",
    "TileManager": "tiling",
    "brute_force_distance_map": "distance",
    "clearance_at": "clearance",
    "clearance_from_sq_distance": "clearance",
    "clearance_of_values": "clearance",
    "column_distance_tile": "distance",
    "column_dtype": "distance",
    "dense_fields": "dense",
    "dense_fields_many": "dense",
    "distance_map": "dense",
    "forward_tile": "dense",
    "gaussian_from_sq_distance": "distance",
    "laplacian_valid": "filters",
    "nearest_sq_distance": "clearance",
    "reflect_101_halo": "filters",
    "ridge_fields": "dense",
    "ridge_fields_many": "dense",
    "ridge_from_laplacian": "filters",
    "ridge_map": "dense",
    "row_sq_distance_tile": "distance",
    "trace_counts": "dense",
    "unique_pairs": "tiling",
    "window_sq_distance_tile": "distance",
}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
