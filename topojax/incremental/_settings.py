"""The mapper's settings: checked and normalised constructor arguments, and the
JSON-ready dictionary a saved state stores."""

from __future__ import annotations

import warnings
from dataclasses import asdict

from .._caller import outside_stacklevel
from .._constants import STRATEGIES
from .._cpus import available_memory_bytes, byte_size
from .._validate import (
    flag,
    instance_or_default,
    int_at_least,
    is_real_number,
    metres_per_pixel,
    one_of,
    positive_int,
    positive_metres,
)
from ..config import DistanceConfig, PipelineConfig, RidgeConfig, SkeletonConfig
from ..fields.filters import HALO_PX


def _check_rate(name: str, value) -> int:
    """A loop's rate: None (explicit calls only) as 0, else an int >= 0."""
    return 0 if value is None else int_at_least(name, value, 0)


def merged_config(config, distance, ridge, skeleton) -> PipelineConfig:
    """``config`` (default: the paper's) with the given parts replaced, checked for what
    the mapper supports.

    Raises
    ------
    TypeError
        If an argument is not the config class it names.
    ValueError
        If the ridge threshold is negative, or the graph config asks for junction-cluster
        merging, free-space filtering or pruning.
    """
    config = instance_or_default("config", config, PipelineConfig)
    for name, value, cls in (
        ("distance", distance, DistanceConfig),
        ("ridge", ridge, RidgeConfig),
        ("skeleton", skeleton, SkeletonConfig),
    ):
        if value is not None:  # None: the part of ``config``
            instance_or_default(name, value, cls)
    config = PipelineConfig(
        distance=distance or config.distance,
        ridge=ridge or config.ridge,
        skeleton=skeleton or config.skeleton,
        graph=config.graph,
        tile_px=config.tile_px,
        tiles_per_call=config.tiles_per_call,
    )
    if config.graph.merge_junction_clusters:
        raise ValueError(
            "config.graph.merge_junction_clusters=True is not supported incrementally; "
            "expected False (merge clusters on the exported graph instead)"
        )
    if config.graph.free_space_only or config.graph.prunes:
        raise ValueError(
            "config.graph: free_space_only, min_clearance_m, min_spur_m and "
            "min_component_m are not supported incrementally; expected their defaults "
            f"(False, 0, 0, 0), received {config.graph.free_space_only}, "
            f"{config.graph.min_clearance_m}, {config.graph.min_spur_m}, "
            f"{config.graph.min_component_m} (prune the exported graph with "
            "topojax.prune_graph instead)"
        )
    return config


def checked_sizes(tile_px, block_px, paper_layer_px) -> tuple[int, int, int]:
    """``tile_px``, ``block_px`` and ``paper_layer_px`` as ints, checked.

    Raises
    ------
    ValueError
        If one is not an int of at least its minimum (8, 4, 1), a side is not a power of
        two, the tile is larger than 4096 px or smaller than the block, or the block
        smaller than two ridge halos.
    """
    tile_px = int_at_least("tile_px", tile_px, 8)
    block_px = int_at_least("block_px", block_px, 4)
    paper_layer_px = int_at_least("paper_layer_px", paper_layer_px, 1)
    for name, value in (("tile_px", tile_px), ("block_px", block_px)):
        if value & (value - 1):
            raise ValueError(
                f"{name}: expected a power of two (tile and block coordinates are bit "
                f"shifts), received {value}"
            )
    if tile_px > 4096:  # as the full-map pipeline's tiles; one tile is tile_px**2 pixels
        raise ValueError(f"tile_px: expected a value <= 4096, received {tile_px}")
    if tile_px < block_px:
        raise ValueError(
            "tile_px, block_px: expected tile_px >= block_px (a block within a tile), "
            f"received tile_px={tile_px}, block_px={block_px}"
        )
    if block_px < 2 * HALO_PX:
        raise ValueError(f"block_px: expected a value >= {2 * HALO_PX}, received {block_px}")
    return tile_px, block_px, paper_layer_px


def checked_resolution(resolution_m, strategy) -> float:
    """``resolution_m`` as a float, checked, and ``strategy`` checked.

    Raises
    ------
    TypeError, ValueError
        If the resolution is not a finite number > 0 or the strategy is unknown.
    """
    # NumPy numbers are numbers too (stored as Python ones)
    resolution_m = metres_per_pixel("resolution_m", resolution_m)
    one_of("strategy", strategy, STRATEGIES)
    return resolution_m


def checked_loop_settings(
    max_pending_points, free_space, max_range_m, skeleton_every, graph_every
) -> tuple[int, bool, float | None, int, int]:
    """The loop settings of :class:`IncrementalMapper`, checked and converted to Python
    numbers (NumPy numbers are accepted; a rate of None becomes 0).

    Raises
    ------
    TypeError, ValueError
        If an argument has the wrong type or range.
    """
    max_pending_points = int_at_least("max_pending_points", max_pending_points, 0)
    if max_range_m is not None:
        if not is_real_number(max_range_m):
            raise TypeError(f"max_range_m: expected a number or None, received {max_range_m!r}")
        max_range_m = float(max_range_m)
        if not max_range_m > 0:
            raise ValueError(f"max_range_m: expected a value > 0 (metres), received {max_range_m}")
    return (
        max_pending_points,
        flag("free_space", free_space),
        max_range_m,
        _check_rate("skeleton_every", skeleton_every),
        _check_rate("graph_every", graph_every),
    )


def checked_room_settings(rooms_every, room_config, rooms_local=True):
    """``rooms_every`` (None, or an int >= 0), ``room_config`` (a RoomConfig or None,
    then the default) and ``rooms_local`` (a bool), checked."""
    from ..rooms import RoomConfig

    if rooms_every is not None:
        rooms_every = _check_rate("rooms_every", rooms_every)
    return (
        rooms_every,
        instance_or_default("room_config", room_config, RoomConfig),
        flag("rooms_local", rooms_local),
    )


#: Default ``max_extent_m`` of :class:`IncrementalMapper`: the largest side, in metres, of
#: the mapped area's bounding box (a large building or a campus; a pose kilometres off
#: is a localisation glitch, not a place).
DEFAULT_MAX_EXTENT_M = 2000.0


#: Default ``max_export_bytes`` of :class:`IncrementalMapper` (2 GiB): the most memory
#: a dense export (occupancy, fields, result, route graph) may allocate.
DEFAULT_MAX_EXPORT_BYTES = 1 << 31

#: Default ``max_tile_bytes`` of :class:`IncrementalMapper` (2 GiB): the most memory the
#: mapper's tiles may hold.
DEFAULT_MAX_TILE_BYTES = 1 << 31


def checked_guard_settings(
    max_extent_m, max_export_bytes, max_tile_bytes
) -> tuple[float, int, int]:
    """``max_extent_m`` (finite metres > 0), ``max_export_bytes`` and ``max_tile_bytes``
    (ints >= 1) as Python numbers.

    Raises
    ------
    TypeError, ValueError
        If one has the wrong type or range (the message names it, what was expected and
        what was received).
    """
    limits = (
        positive_metres("max_extent_m", max_extent_m),
        positive_int("max_export_bytes", max_export_bytes),
        positive_int("max_tile_bytes", max_tile_bytes),
    )
    available = available_memory_bytes()
    guards = (
        ("max_tile_bytes", limits[2], DEFAULT_MAX_TILE_BYTES, "the mapper", "refuses a scan"),
        ("max_export_bytes", limits[1], DEFAULT_MAX_EXPORT_BYTES, "an export", "is refused"),
    )
    for name, limit, default, who, refusal in guards:
        # a limit given, not the default: on a small computer every mapper would warn of
        # a limit its user did not choose
        if available is not None and limit > available and limit != default:
            warnings.warn(
                f"{name}: {byte_size(limit)} is more than the {byte_size(available)} of "
                f"memory available; {who} may be killed for memory before it {refusal} (a "
                f"smaller {name} refuses first)",
                UserWarning,
                stacklevel=outside_stacklevel(),  # IncrementalMapper(...) or .load(...)
            )
    return limits


def settings_of(mapper) -> dict:
    """The settings a mapper was made with, JSON-ready (``config`` as a dict)."""
    return {
        "resolution_m": mapper.resolution_m,
        "skeleton_every": mapper.skeleton_every,
        "graph_every": mapper.graph_every,
        "rooms_every": mapper.rooms_every,
        "room_config": asdict(mapper.room_config),
        "rooms_local": mapper.rooms_local,
        "strategy": mapper.strategy,
        "config": asdict(mapper.config),
        "tile_px": mapper.tile_px,
        "block_px": mapper.block_px,
        "max_pending_points": mapper.max_pending_points,
        "free_space": mapper.free_space,
        "max_range_m": mapper.max_range_m,
        "paper_layer_px": mapper.paper_layer_px,
        "max_grid_cells": mapper._tiles.max_grid_cells,
        "max_extent_m": mapper.max_extent_m,
        "max_export_bytes": mapper.max_export_bytes,
        "max_tile_bytes": mapper.max_tile_bytes,
    }
