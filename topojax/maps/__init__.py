"""Occupancy-grid maps: the :class:`OccupancyMap` container, the ``map_server``
classification rules and map file I/O."""

from __future__ import annotations

from .classify import DEFAULT_FREE_THRESH, DEFAULT_OCCUPIED_THRESH, MODES
from .files import IMAGE_SUFFIXES, YAML_SUFFIXES, load_map, map_argument, save_map
from .occupancy import DEFAULT_RESOLUTION_M, OccupancyMap

__all__ = [
    "DEFAULT_FREE_THRESH",
    "DEFAULT_OCCUPIED_THRESH",
    "DEFAULT_RESOLUTION_M",
    "IMAGE_SUFFIXES",
    "MODES",
    "YAML_SUFFIXES",
    "OccupancyMap",
    "load_map",
    "map_argument",
    "save_map",
]
