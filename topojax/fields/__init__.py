"""Dense per-pixel fields of a map on fixed-size JAX tiles: the windowed distance, the
Gaussian distance map, the Laplacian and its ridges, and the exact clearance.

See ``docs/design-fields.md`` for the distance algorithm and the tiling.
"""

from __future__ import annotations

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
