"""Incremental topology mapping from laser scans (paper §III, made exact).

:class:`IncrementalMapper` keeps the obstacle map, the distance map, the ridges, the
skeleton and the topology graph up to date from streamed scans while touching only what
changed; its results equal the full-map pipeline's on the exported map.  Why, stage by
stage: ``docs/incremental-exactness.md``.
"""

from .._jit import trace_counts
from ._extent import BOUNDS as EXTENT_BOUNDS
from ._extent import ExtentError
from ._rethin import thin_components
from ._rooms import RoomsUpdate, current_room_labels, keeps_rooms
from ._settings import STRATEGIES, settings_of
from ._tiles import ExportBudgetError
from .mapper import IncrementalMapper
from .reports import GraphUpdate, ScanReport, timing_summary, vertex_error_metrics
from .state import STATE_FORMAT, STATE_VERSION

__all__ = [
    "ExportBudgetError",
    "EXTENT_BOUNDS",
    "ExtentError",
    "STATE_FORMAT",
    "STATE_VERSION",
    "STRATEGIES",
    "GraphUpdate",
    "IncrementalMapper",
    "RoomsUpdate",
    "ScanReport",
    "current_room_labels",
    "keeps_rooms",
    "settings_of",
    "thin_components",
    "timing_summary",
    "trace_counts",
    "vertex_error_metrics",
]
