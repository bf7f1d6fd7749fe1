"""Batch processing of many maps: batched JAX kernels, parallel CPU stages, Dask, GPU.

:func:`build_graphs` turns a collection of maps (files and/or
:class:`~topojax.maps.OccupancyMap` objects) into topology graphs, writes the graph files
of every map and one summary table, and returns one :class:`MapRecord` per map.  The JAX
kernels run batched in the calling process; thinning, graph building and file writing run
in worker processes (or any :class:`concurrent.futures.Executor`, e.g. a Dask cluster).
Results equal :func:`topojax.build_graph` on each map alone.  ``topojax batch`` is the
command-line front end.  Design, outputs, resume, names, clusters and GPU use:
``docs/batch-internals.md``.

Modules: ``records`` (:class:`MapRecord`, the summary table), ``inputs`` (input expansion
and map names), ``manifest`` (fingerprints, ``resume``), ``worker`` (the CPU stage and map
loading), ``arguments`` (checks and defaults of the arguments of :func:`build_graphs`),
``pool`` (the worker processes, one pipe each), ``driver`` (:func:`build_graphs`).
"""

from __future__ import annotations

from .driver import build_graphs
from .inputs import expand_braces, expand_map_inputs
from .records import SUMMARY_COLUMNS, MapRecord, write_summary
from .worker import InlineExecutor, worker_context

__all__ = [
    "SUMMARY_COLUMNS",
    "InlineExecutor",
    "MapRecord",
    "build_graphs",
    "expand_braces",
    "expand_map_inputs",
    "worker_context",
    "write_summary",
]
