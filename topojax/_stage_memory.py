"""The least memory the map-sized stages take, and their refusal of a map it cannot hold.

Each floor is a lower bound on a stage's peak memory growth per map pixel, beyond the
map itself and the process's fixed costs: about 0.8 times the lowest growth measured
over a spread of maps (``bench/bench_stage_floors.py``; the maps and figures are in
``docs/performance.md``).  A stage whose floor times the map's pixels exceeds the memory
available refuses the map before any map-sized work (:class:`~topojax._cpus.MemoryRefusal`),
rather than run until an allocation fails or the kernel's out-of-memory killer ends the
process; one under it may still run out, since a map can take more than its floor."""

from __future__ import annotations

from ._cpus import check_fits_memory

__all__ = [
    "BUILD_GRAPH_BYTES_PER_PX",
    "ROUTE_GRAPH_BYTES_PER_PX",
    "SEGMENT_ROOMS_BYTES_PER_PX",
    "SMALLER_MAP",
    "check_stage_fits",
]

#: :func:`topojax.build_graph`, with the default ``keep``.
BUILD_GRAPH_BYTES_PER_PX = 3.0
#: :func:`topojax.segment_rooms`.
SEGMENT_ROOMS_BYTES_PER_PX = 3.5
#: :func:`topojax.route_graph`.
ROUTE_GRAPH_BYTES_PER_PX = 8.0

#: What to do with a map too large for ``segment_rooms`` or ``route_graph``.
SMALLER_MAP = (
    "; crop the map to the part needed, or coarsen it (twice the resolution_m: a quarter "
    "of the pixels)"
)


def check_stage_fits(stage: str, argument: str, shape, bytes_per_px: float, advice: str) -> None:
    """A :class:`~topojax._cpus.MemoryRefusal` where ``stage`` (a function's name) of a
    map of ``shape`` (given as its parameter ``argument``), at ``bytes_per_px``, needs
    more than the memory available; ``advice`` ends the message."""
    h, w = (int(s) for s in shape)
    check_fits_memory(
        int(bytes_per_px * h * w),
        f"{stage}: {argument} of {h} x {w} pixels takes at least {bytes_per_px:g} bytes a "
        "pixel beyond the map,",
        advice,
    )
