"""Batch processing of many maps: batched JAX kernels, parallel CPU stages, Dask, GPU.

:func:`build_graphs` turns a collection of maps (files and/or
:class:`~topojax.maps.OccupancyMap` objects) into topology graphs, writes the graph
files of every map and one summary table, and returns one :class:`MapRecord` per map.
``topojax batch`` (:func:`_add_cli`) is the command-line front end.

Design
------
The pipeline has two very different halves, and each runs where it is cheapest:

* **Kernel stage (JAX), in the calling process.**  Loaded maps are gathered into *groups*
  of up to ``batch_tiles`` tiles.  Each group goes through
  :func:`topojax.pipeline.dense_fields_many`: the fixed-size tiles of all maps of the group
  are concatenated and cut into chunks of exactly ``tiles_per_call`` tiles (the last chunk
  padded with empty tiles), so a chunk may mix tiles of maps of different sizes and **one
  compiled kernel serves every map** (one trace per ``(tile_px, tiles_per_call,
  half_width_px, ksize)`` bucket; :func:`topojax.pipeline.trace_counts` shows it).  Groups
  are dispatched from ``kernel_threads`` threads: JAX releases the GIL while a kernel runs,
  so on a multi-core CPU several groups execute at once, and on a GPU the host-side tile
  cutting of one group overlaps the device work of another.  The first call of a bucket
  runs alone and on a single map, so the kernel is traced exactly once and the pipeline
  fills as soon as it is compiled.
* **CPU stages (numba, networkx, file I/O), in the executor's workers.**  With the default
  process pool the workers also read the map files (decoding, YAML, thresholds) and send
  back the obstacle mask packed to 1 bit per pixel.  As soon as a group's kernels finish,
  each of its maps becomes a small, picklable job: the ridge map packed to 1 bit per pixel
  and the clearance (Euclidean distance to the nearest obstacle, px) of the ridge pixels
  only.  A worker thins the ridges, removes T centres, builds the graph, writes the graph
  files (and picture) and returns the counts.  Workers never run a JAX kernel and never
  touch an accelerator.  Submitting every map as soon as its group is done pipelines the
  two halves: while the workers thin and trace the maps of one group, the kernel threads
  already run the next groups.  The default workers are forked from a fork server (a
  fresh single-threaded process that imported topojax once), never from the JAX-threaded
  caller; where there is no fork server they are spawned.

Results are identical to calling :func:`topojax.build_graph` on each map alone: the
kernels are exact per tile, so chunk composition does not matter, and the worker runs the
same functions (:func:`~topojax.skeleton.thin`, :func:`~topojax.skeleton.remove_t_centres`,
:func:`~topojax.graph.skeleton_to_graph` with ``OccupancyMap.pixel_to_world``) on the
same arrays.  Only skeleton pixels, a subset of the ridge pixels, are ever read from the
clearance array, which is why shipping the ridge pixels' clearances suffices.

Trade-off
---------
Keeping JAX in one process means one compilation, one copy of the JAX runtime and of the
device memory, instead of one per worker, and it lets the kernels of many maps share calls
(16 tiles per call cost about 7 % less CPU time than the 4 of a single ``build_graph``).
The price is traffic between the processes, per map about ``H W / 4`` bytes of packed
masks plus 4 bytes per ridge pixel (1 % to 7 % of the pixels): 0.3 MB for a 708 x 763
map.  A second price is balance: in a sequential loop over the 100-map benchmark job
(``bench/bench_batch.py``) the JAX stage takes 66 % of the time, loading 16 %, thinning
2 % and graph building 17 %, so on a CPU the calling process keeps most of the work and
needs as many kernel threads as cores, while the workers fill the gaps; when the graph
files are written (the usual case) the workers' share grows to about 80 % and the parallel
speed-up with it.  The alternative, one whole ``build_graph`` per worker process, compiles
the kernel in every worker (about 1.5 s of CPU each) and lets the XLA runtimes of the
workers compete for the same cores; ``bench/BATCH.md`` has the measured numbers.

Outputs, faults and resume
--------------------------
With ``out_dir``, every map gets ``<name>.graphml`` / ``.json`` / ``.geojson`` /
``_nav2.geojson`` (as chosen by ``formats``), optionally ``<name>_graph.png``, and then,
**last**, a manifest ``<name>.manifest.json`` listing the input's SHA-256, the result-relevant settings and
the name, size and SHA-256 of every output file.  ``out_dir/summary.csv`` (and
``summary.parquet`` when pyarrow is installed) holds one row per map (columns
:data:`SUMMARY_COLUMNS`).  Every file is written to a temporary name in its folder and
renamed into place (:func:`topojax.io.atomic_write_bytes`), so a killed run leaves
complete files or hidden ``.*.tmp`` leftovers, never a truncated file under a final name;
a map counts as done only once its manifest exists.  A map that cannot be loaded or
processed becomes a row with ``status="error"`` and the message, and the other maps
finish.  With ``resume=True`` a map whose manifest matches its current input, the
settings, and output files of the recorded sizes and hashes is skipped
(``status="skipped"``, numbers taken from the manifest); any other map is redone.

Names
-----
A map's name (``map`` column, output file stem) is its path relative to the deepest folder
that holds all input files, without the suffix, e.g. ``ipa/office_a`` or
``ros/tuw_freihaus_eg/map``; outputs mirror that layout under ``out_dir``.  Names that
would clash get the suffix (``map_pgm``), then a counter (``_2``); so does a name whose
output files would be another map's (a map ``x_nav2`` next to a map ``x``, whose Nav2 graph
is ``x_nav2.geojson``).  Maps given as objects
without a ``source`` are called ``map_0000``, ``map_0001``, ... by position.

Clusters (Dask)
---------------
Any :class:`concurrent.futures.Executor` can run the CPU stages.  For a Dask cluster pass a
``dask.distributed.Client`` (its ``get_executor(pure=False)`` is used) or that executor
itself; ``topojax batch --scheduler tcp://host:8786`` does this.  With a given executor the
map files are read by threads of the calling process (the cluster need not see them), and
the executor is not shut down.  The workers need topojax installed and, when ``out_dir`` is
given, must see ``out_dir`` under the same path (a shared file system), because they write
the graph files themselves.

GPU
---
With a CUDA build of jax the kernel stage runs on the GPU with no code change (JAX picks
its default backend); the workers stay on the CPU.  Install it with::

    pip install -U "jax[cuda13]"      # NVIDIA driver for CUDA 13
    pip install -U "jax[cuda12]"      # or, with a CUDA 12 driver

(jax 0.10 provides both extras; ``python -c "import jax; print(jax.devices())"`` should
list a ``CudaDevice``).  On a GPU raise ``tiles_per_call`` (e.g. 64) so each call carries
enough tiles to fill the device; it stays one compiled kernel.
"""

from __future__ import annotations

import concurrent.futures as cf
import csv
import dataclasses
import glob as _glob
import hashlib
import io as _io
import json
import math
import multiprocessing
import os
import sys
import threading
import time
from collections import Counter, deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ._fs import atomic_write_bytes, output_folder, refuse_overwriting_inputs, yaml_image
from ._validate import positive_metres
from .config import DistanceConfig, PipelineConfig
from .io import GRAPH_FORMATS
from .maps import IMAGE_SUFFIXES, MODES, YAML_SUFFIXES, OccupancyMap, load_map

__all__ = [
    "SUMMARY_COLUMNS",
    "InlineExecutor",
    "MapRecord",
    "build_graphs",
    "expand_braces",
    "expand_map_inputs",
    "write_summary",
]

#: Columns of the summary table, in order.  Times are seconds of wall time spent on the map
#: in each stage; ``t_distance_s`` is the map's share (by tile count) of its group's kernel
#: wall time plus its own clearance/packing; ``t_write_s`` covers the graph files and picture;
#: ``t_total_s`` is their sum (not the latency, since stages of different maps overlap).
SUMMARY_COLUMNS = (
    "map",
    "path",
    "height",
    "width",
    "resolution_m",
    "vertices",
    "edges",
    "total_length_m",
    "components",
    "t_load_s",
    "t_distance_s",
    "t_thinning_s",
    "t_graph_s",
    "t_write_s",
    "t_total_s",
    "status",
    "message",
)

#: Default kernel bucket of a batch: 16 tiles per call costs about 7 % less CPU time than 4
#: on the CPU backend (fewer dispatches; empty padding tiles are nearly free).
_DEFAULT_TILES_PER_CALL = 16
_MANIFEST_VERSION = 1
_MANIFEST_SUFFIX = ".manifest.json"
_PICTURE_SUFFIX = "_graph.png"
_FORMAT_SUFFIX = {fmt: suffix for suffix, fmt in GRAPH_FORMATS.items()}
# a route graph for the ROS 2 Nav2 Route Server (topojax.save_nav2_graph, default tolerance)
_FORMAT_SUFFIX["nav2"] = "_nav2.geojson"
# Kernel buckets (tile_px, tiles_per_call, half_width_px, ksize) already traced in this
# process, and the lock that makes the first call of a bucket run alone.
_COMPILED_BUCKETS: set[tuple[int, ...]] = set()
_COMPILE_LOCK = threading.Lock()
_MAP_SUFFIXES = tuple(YAML_SUFFIXES) + tuple(IMAGE_SUFFIXES)


# ======================================================================================
# records
# ======================================================================================


@dataclass
class MapRecord:
    """What happened to one map of a batch (one row of the summary table).

    Attributes
    ----------
    map : str
        Unique name of the map in the batch; the stem of its output files.
    path : str or None
        Input file (or the ``source`` of an :class:`~topojax.maps.OccupancyMap`).
    height, width : int or None
        Map size in pixels (None when it could not be loaded).
    resolution_m : float or None
        Metres per pixel.
    vertices, edges, components : int or None
        Graph counts (:func:`topojax.graph.graph_summary`; isolated vertices count as
        components).
    total_length_m : float or None
        Sum of the edge lengths in metres.
    t_load_s, t_distance_s, t_thinning_s, t_graph_s, t_write_s, t_total_s : float
        Seconds per stage (see :data:`SUMMARY_COLUMNS`).
    status : {"ok", "error", "skipped"}
        ``"skipped"``: complete outputs found by ``resume``.
    message : str
        Error message (``"ExceptionType: text"``) or a note; empty when ok.
    outputs : tuple of str
        Files written for this map, relative to ``out_dir`` (manifest last).
    graph : networkx.MultiGraph or None
        The graph itself when ``keep_graphs`` (not in the table).
    """

    map: str
    path: str | None
    height: int | None = None
    width: int | None = None
    resolution_m: float | None = None
    vertices: int | None = None
    edges: int | None = None
    total_length_m: float | None = None
    components: int | None = None
    t_load_s: float = 0.0
    t_distance_s: float = 0.0
    t_thinning_s: float = 0.0
    t_graph_s: float = 0.0
    t_write_s: float = 0.0
    t_total_s: float = 0.0
    status: str = "ok"
    message: str = ""
    outputs: tuple[str, ...] = ()
    graph: Any = field(default=None, repr=False, compare=False)

    def row(self) -> dict[str, Any]:
        """The record as a summary-table row (keys :data:`SUMMARY_COLUMNS`)."""
        return {name: getattr(self, name) for name in SUMMARY_COLUMNS}

    def _finish(self) -> MapRecord:
        self.t_total_s = (
            self.t_load_s + self.t_distance_s + self.t_thinning_s + self.t_graph_s + self.t_write_s
        )
        return self


def _csv_value(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    return str(value)


def write_summary(records: Sequence[MapRecord], out_dir: str | Path) -> list[Path]:
    """Write the summary table of a batch, atomically.

    Parameters
    ----------
    records : sequence of MapRecord
        One per map, in the order the rows should appear.
    out_dir : str or Path
        Existing folder; receives ``summary.csv`` and, when ``pyarrow`` is importable,
        ``summary.parquet``.

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(out_dir)
    if not folder.is_dir():
        raise FileNotFoundError(f"out_dir: expected an existing folder, got {str(folder)!r}")
    buf = _io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(SUMMARY_COLUMNS)
    for rec in records:
        row = rec.row()
        writer.writerow([_csv_value(row[name]) for name in SUMMARY_COLUMNS])
    written = [folder / "summary.csv"]
    atomic_write_bytes(written[0], buf.getvalue().encode("utf-8"))
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return written
    table = pa.Table.from_pylist([rec.row() for rec in records], schema=_arrow_schema(pa))
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    written.append(folder / "summary.parquet")
    atomic_write_bytes(written[1], sink.getvalue().to_pybytes())
    return written


def _arrow_schema(pa: Any) -> Any:
    types = {
        "map": pa.string(),
        "path": pa.string(),
        "height": pa.int64(),
        "width": pa.int64(),
        "vertices": pa.int64(),
        "edges": pa.int64(),
        "components": pa.int64(),
        "status": pa.string(),
        "message": pa.string(),
    }
    return pa.schema([(name, types.get(name, pa.float64())) for name in SUMMARY_COLUMNS])


# ======================================================================================
# inputs: brace/glob expansion, names, fingerprints
# ======================================================================================


def _matching_brace(text: str, start: int) -> tuple[int, list[int]] | None:
    """Index of the ``}`` closing the ``{`` at ``start`` and the top-level comma indices."""
    depth = 0
    commas: list[int] = []
    for i in range(start, len(text)):
        ch = text[i]
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
            if depth == 0:
                return i, commas
        elif ch == "," and depth == 1:
            commas.append(i)
    return None


def expand_braces(pattern: str) -> list[str]:
    """Shell-style brace expansion: ``"a/*.{yaml,p{n,g}m}"`` -> ``["a/*.yaml", "a/*.pnm",
    "a/*.pgm"]``.

    Parameters
    ----------
    pattern : str
        Text with optional ``{x,y,...}`` groups (nestable).  As in bash, a group needs a
        matching ``}`` and at least one top-level comma; other braces stay literal
        (``"{a}"``, ``"a{"``).  Numeric ranges (``{1..3}``) and backslash escapes are not
        supported.

    Returns
    -------
    list of str
        The expansions, left to right in the order of the alternatives (duplicates kept).
    """
    if not isinstance(pattern, str):
        raise TypeError(f"pattern: expected a str, got {type(pattern).__name__}")
    pos = pattern.find("{")
    while pos != -1:
        found = _matching_brace(pattern, pos)
        if found is not None and found[1]:
            end, commas = found
            cuts = [pos, *commas, end]
            alternatives = [pattern[a + 1 : b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
            head, tail = pattern[:pos], pattern[end + 1 :]
            out: list[str] = []
            for alt in alternatives:
                out.extend(expand_braces(head + alt + tail))
            return out
        pos = pattern.find("{", pos + 1)
    return [pattern]


def _is_map_file(path: Path) -> bool:
    return path.suffix.lower() in _MAP_SUFFIXES


def _walk_maps(folder: Path) -> list[Path]:
    found = []
    for root, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for name in sorted(files):
            p = Path(root) / name
            if not name.startswith(".") and _is_map_file(p):
                found.append(p)
    return found


def _static_prefix(pattern: str) -> str:
    """The folder of a glob pattern before its first wildcard ("." if none)."""
    fixed = []
    for part in Path(pattern).parts:
        if _glob.has_magic(part):
            break
        fixed.append(part)
    return os.path.join(*fixed) if fixed else "."


def expand_map_inputs(
    inputs: Iterable[str | os.PathLike[str]], *, exclude: str | os.PathLike[str] | None = None
) -> list[Path]:
    """Turn command-line inputs into a list of map files.

    Parameters
    ----------
    inputs : iterable of str or path
        Each is brace-expanded (:func:`expand_braces`), then

        * an existing folder is searched recursively (hidden entries skipped) for files
          with a map suffix (``.yaml``, ``.yml``, ``.pgm``, ``.png``, ``.jpg``, ``.jpeg``,
          ``.bmp``, ``.tif``, ``.tiff``);
        * a pattern with ``*``, ``?`` or ``[`` is globbed (``**`` matches any depth);
          matched map files are kept, matched folders searched as above;
        * anything else is taken as a file name as is (a missing or unsupported file
          then becomes an error row of the batch, not an exception here).
    exclude : str or path, optional
        A folder that searches of a folder (or pattern) strictly above it skip, e.g. the
        batch's output folder inside an input folder (its pictures are PNG files).  An
        input that is that folder, or lies inside it, is searched as usual.

    Returns
    -------
    list of Path
        In order of the inputs (sorted within each folder/pattern), without duplicates.
        An image referenced by a YAML that is also in the list is dropped: the map is
        processed once, through its YAML.

    Raises
    ------
    ValueError
        If nothing at all was found.
    """
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    skip = None if exclude is None else os.path.join(os.path.realpath(exclude), "")

    def searched(root: str, files) -> list[Path]:
        # files found below ``root``, without those in ``exclude`` if it lies strictly
        # inside ``root`` (the batch's own outputs)
        top = os.path.join(os.path.realpath(root), "")
        if skip is None or not (skip.startswith(top) and skip != top):
            return list(files)
        return [f for f in files if not os.path.realpath(f).startswith(skip)]

    found: list[Path] = []
    for raw in inputs:
        for pattern in expand_braces(os.fspath(raw)):
            p = Path(pattern)
            if p.is_dir():
                found.extend(searched(pattern, _walk_maps(p)))
            elif _glob.has_magic(pattern):
                matches = []
                for match in sorted(_glob.glob(pattern, recursive=True)):
                    m = Path(match)
                    if m.is_dir():
                        matches.extend(_walk_maps(m))
                    elif _is_map_file(m):
                        matches.append(m)
                found.extend(searched(_static_prefix(pattern), matches))
            else:
                found.append(p)
    unique: list[Path] = []
    seen: set[str] = set()
    for p in found:
        key = os.path.realpath(p)
        if key not in seen:
            seen.add(key)
            unique.append(p)
    referenced = set()
    for p in unique:
        if p.suffix.lower() in YAML_SUFFIXES and p.is_file():
            img = yaml_image(p)
            if img is not None:
                referenced.add(os.path.realpath(img))
    result = [
        p
        for p in unique
        if p.suffix.lower() in YAML_SUFFIXES or os.path.realpath(p) not in referenced
    ]
    if not result:
        shown = ", ".join(repr(os.fspath(x)) for x in inputs) if inputs else "(none)"
        raise ValueError(f"inputs: expected map files, folders or patterns; none found in {shown}")
    return result


@dataclass
class _Item:
    index: int
    name: str
    path: Path | None
    occupancy: OccupancyMap | None

    @property
    def label(self) -> str | None:
        if self.path is not None:
            return os.fspath(self.path)
        return None if self.occupancy is None else self.occupancy.source


def _assign_names(sources: list[Path | None]) -> list[str]:
    """Unique output stems (see the module notes)."""
    given = [p for p in sources if p is not None]
    root = None
    if given:
        root = os.path.commonpath([os.path.dirname(os.path.abspath(p)) for p in given])
    names = []
    for i, p in enumerate(sources):
        if p is None or root is None:
            names.append(f"map_{i:04d}")
            continue
        rel = Path(os.path.relpath(os.path.abspath(p), root))
        names.append(rel.with_suffix("").as_posix() if rel.suffix else rel.as_posix())
    counts = Counter(names)
    for i, p in enumerate(sources):
        if counts[names[i]] > 1 and p is not None and p.suffix:
            names[i] = f"{names[i]}_{p.suffix[1:].lower()}"
    used: set[str] = set()
    files: set[str] = set()  # every output file name of the names given so far
    for i, name in enumerate(names):
        if name.endswith(".manifest"):  # would collide with another map's manifest file
            name = name[: -len(".manifest")] + "_manifest"
        candidate, k = name, 2
        # A name is taken if any of its possible output files is another name's (``x_nav2``
        # would write ``x_nav2.geojson``, the Nav2 file of ``x``), whatever the formats, so
        # that names do not depend on them.
        while candidate in used or not files.isdisjoint(_output_files(candidate)):
            candidate, k = f"{name}_{k}", k + 1
        used.add(candidate)
        files.update(_output_files(candidate))
        names[i] = candidate
    return names


def _output_files(name: str) -> list[str]:
    """Every file name a map called ``name`` may write (any formats, picture, manifest)."""
    suffixes = [*_FORMAT_SUFFIX.values(), _PICTURE_SUFFIX, _MANIFEST_SUFFIX]
    return [name + suffix for suffix in suffixes]


def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _fingerprint(item: _Item) -> dict[str, Any] | None:
    """Identity of a map's input for resume: file hashes, or a hash of the masks."""
    if item.occupancy is not None:
        occ = item.occupancy
        h = hashlib.sha256()
        h.update(np.asarray(occ.shape, np.int64).tobytes())
        h.update(np.packbits(occ.occupied).tobytes())
        h.update(np.packbits(occ.free).tobytes())
        h.update(repr((occ.resolution_m, occ.origin)).encode())
        return {"masks_sha256": h.hexdigest()}
    assert item.path is not None
    try:
        files = {item.path.name: _sha256_file(item.path)}
        if item.path.suffix.lower() in YAML_SUFFIXES:
            img = yaml_image(item.path)
            if img is not None and img.is_file():
                files["image:" + img.name] = _sha256_file(img)
    except OSError:
        return None
    return {"files_sha256": files}


def _normalise(value: Any) -> Any:
    return json.loads(json.dumps(value))


# ======================================================================================
# the CPU stage (runs in the executor's workers; no JAX)
# ======================================================================================


@dataclass(frozen=True)
class _MapFrame:
    """Shape, resolution and origin of a map: all that ``pixel_to_world`` reads."""

    shape: tuple[int, int]
    resolution_m: float
    origin: tuple[float, float, float]

    # The very same function as the OccupancyMap method, so world coordinates are
    # bit-identical to build_graph's without shipping the masks.
    pixel_to_world = OccupancyMap.pixel_to_world


@dataclass(frozen=True)
class _CpuJob:
    name: str
    shape: tuple[int, int]
    resolution_m: float
    origin: tuple[float, float, float]
    source: str | None
    ridges_bits: np.ndarray  # uint8, np.packbits of the (H, W) ridge map
    clearance_values: np.ndarray  # float32 (n_ridge,): clearance (px) at the ridge pixels
    config: PipelineConfig
    out_dir: str | None
    formats: tuple[str, ...]
    masks_bits: np.ndarray | None  # packbits of (occupied, free), only for the picture
    keep_graph: bool
    free_bits: np.ndarray | None = None  # packbits of free, only for free_space_only


@dataclass
class _CpuResult:
    name: str
    vertices: int | None = None
    edges: int | None = None
    total_length_m: float | None = None
    components: int | None = None
    t_thinning_s: float = 0.0
    t_graph_s: float = 0.0
    t_write_s: float = 0.0
    files: dict[str, dict[str, Any]] = field(default_factory=dict)
    graph: Any = None
    error: str | None = None


def _error_text(exc: BaseException) -> str:
    text = str(exc).strip().replace("\n", " ")
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _picture_bytes(job: _CpuJob, skeleton: np.ndarray, graph: Any) -> bytes:
    from types import SimpleNamespace

    from matplotlib.figure import Figure

    from .plotting import plot

    assert job.masks_bits is not None
    h, w = job.shape
    masks = np.unpackbits(job.masks_bits, count=2 * h * w).reshape(2, h, w).astype(bool)
    occupancy = OccupancyMap(
        occupied=masks[0],
        free=masks[1],
        unknown=~(masks[0] | masks[1]),
        resolution_m=job.resolution_m,
        origin=job.origin,
        source=job.source,
    )
    side = 9.0
    fig = Figure(figsize=(side, side * h / w if w else side))
    ax = fig.add_subplot()
    plot(SimpleNamespace(map=occupancy, skeleton=skeleton, graph=graph), ax=ax, title=job.name)
    buf = _io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    return buf.getvalue()


def _cpu_stage(job: _CpuJob) -> _CpuResult:
    """Thinning, T removal, graph, summary and output files of one map (worker side)."""
    from .graph import graph_summary
    from .io import save_graph, save_nav2_graph
    from .pipeline import graph_from_ridges

    res = _CpuResult(name=job.name)
    try:
        h, w = job.shape
        ridges = np.unpackbits(job.ridges_bits, count=h * w).reshape(h, w).astype(bool)
        ridge_flat = np.flatnonzero(ridges.ravel())  # the clearance values' pixels

        def clearance(flat: np.ndarray) -> np.ndarray:
            # the skeleton's pixels are ridge pixels
            return job.clearance_values[np.searchsorted(ridge_flat, flat)]

        frame = _MapFrame(job.shape, job.resolution_m, job.origin)
        free = None
        if job.free_bits is not None:
            free = np.unpackbits(job.free_bits, count=h * w).reshape(h, w).astype(bool)
        skeleton, graph, cpu_t = graph_from_ridges(
            ridges,
            clearance_px=clearance,
            resolution_m=job.resolution_m,
            origin=job.origin,
            pixel_to_world=frame.pixel_to_world,
            config=job.config,
            source=job.source,
            free=free,
        )
        res.t_thinning_s = cpu_t["thinning"] + cpu_t["t_removal"]
        t1 = time.perf_counter()
        t0_graph = t1 - cpu_t["graph"]  # the graph step ran just before t1
        summary = graph_summary(graph)
        res.vertices = int(summary["n_vertices"])
        res.edges = int(summary["n_edges"])
        res.components = int(summary["n_components"])
        res.total_length_m = float(summary["total_length_m"])
        t2 = time.perf_counter()
        res.t_graph_s = t2 - t0_graph

        if job.out_dir is not None:
            out = Path(job.out_dir)
            stem = out / job.name
            stem.parent.mkdir(parents=True, exist_ok=True)
            written = []
            for fmt in job.formats:
                target = f"{stem}{_FORMAT_SUFFIX[fmt]}"
                if fmt == "nav2":
                    written.append(save_nav2_graph(graph, target))
                else:
                    written.append(save_graph(graph, target, format=fmt))
            if job.masks_bits is not None:
                pic = Path(f"{stem}{_PICTURE_SUFFIX}")
                atomic_write_bytes(pic, _picture_bytes(job, skeleton, graph))
                written.append(pic)
            for p in written:
                res.files[Path(p).relative_to(out).as_posix()] = {
                    "bytes": p.stat().st_size,
                    "sha256": _sha256_file(p),
                }
        res.t_write_s = time.perf_counter() - t2
        if job.keep_graph:
            res.graph = graph
    except Exception as exc:
        res.error = _error_text(exc)
    return res


def _warm_worker() -> int:
    """Import the CPU-stage modules and load their numba kernels (one tiny map)."""
    from .graph import skeleton_to_graph
    from .skeleton import skeletonize_ridges

    img = np.zeros((8, 8), bool)
    img[2:6, 3] = True
    img[4, 2:6] = True
    skeleton_to_graph(skeletonize_ridges(img), clearance_px=np.ones((8, 8), np.float32))
    return os.getpid()


def _worker_context() -> Any:
    """Start method for the default worker processes.

    ``forkserver`` where available: a fresh, single-threaded server process (never the
    JAX-threaded caller) imports the CPU-stage modules once, and each worker is a cheap
    fork of it, so workers neither pay the imports again nor inherit JAX's threads.
    Elsewhere ``spawn`` (each worker imports everything itself).
    """
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["topojax.batch"])
        return ctx
    return multiprocessing.get_context("spawn")


class InlineExecutor(cf.Executor):
    """An executor that runs each task at once in the calling thread (``workers=0``)."""

    def submit(self, fn, /, *args, **kwargs):  # noqa: D102 - Executor API
        future: cf.Future = cf.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:
            future.set_exception(exc)
        return future


# ======================================================================================
# the driver (calling process)
# ======================================================================================


@dataclass
class _Loaded:
    """A map ready for the kernel stage (in the calling process)."""

    item: _Item
    occupied: np.ndarray  # bool (H, W)
    free: np.ndarray | None  # bool (H, W); kept for a picture or free_space_only
    resolution_m: float
    origin: tuple[float, float, float]
    source: str | None
    t_load_s: float
    n_tiles: int

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.occupied.shape[0]), int(self.occupied.shape[1]))


@dataclass(frozen=True)
class _LoadedBits:
    """A map loaded by a worker process, packed to 1 bit per pixel for the trip back."""

    shape: tuple[int, int]
    resolution_m: float
    origin: tuple[float, float, float]
    source: str | None
    occupied_bits: np.ndarray
    free_bits: np.ndarray | None
    t_load_s: float


def _load_in_worker(path: str, want_free: bool, mode: str | None = None) -> _LoadedBits:
    """Worker side: read and classify a map file (PNG/PGM decoding, YAML, thresholds)."""
    t0 = time.perf_counter()
    occ = load_map(path, mode=mode)
    return _LoadedBits(
        shape=(int(occ.shape[0]), int(occ.shape[1])),
        resolution_m=occ.resolution_m,
        origin=tuple(occ.origin),
        source=occ.source,
        occupied_bits=np.packbits(occ.occupied),
        free_bits=np.packbits(occ.free) if want_free else None,
        t_load_s=time.perf_counter() - t0,
    )


def _ridge_clearance(fields: Any, obstacles: np.ndarray, half_width_px: int) -> np.ndarray:
    """Exact clearance (px, float32) at the ridge pixels, in raster order."""
    from .pipeline import clearance_at

    return clearance_at(
        fields.sq_distance_px, obstacles, half_width_px, np.flatnonzero(fields.ridges)
    )


def _n_tiles(shape: tuple[int, int], tile_px: int) -> int:
    return -(-shape[0] // tile_px) * -(-shape[1] // tile_px)


def _loaded_from_bits(item: _Item, bits: _LoadedBits, tile_px: int) -> _Loaded:
    h, w = bits.shape
    free = None
    if bits.free_bits is not None:
        free = np.unpackbits(bits.free_bits, count=h * w).reshape(h, w).astype(bool)
    return _Loaded(
        item=item,
        occupied=np.unpackbits(bits.occupied_bits, count=h * w).reshape(h, w).astype(bool),
        free=free,
        resolution_m=bits.resolution_m,
        origin=bits.origin,
        source=bits.source,
        t_load_s=bits.t_load_s,
        n_tiles=_n_tiles(bits.shape, tile_px),
    )


def _load_here(item: _Item, tile_px: int, want_free: bool, mode: str | None = None) -> _Loaded:
    """Calling-process side: use the given map object, or load the file in this thread."""
    t0 = time.perf_counter()
    occ = item.occupancy if item.occupancy is not None else load_map(item.path, mode=mode)
    return _Loaded(
        item=item,
        occupied=occ.occupied,
        free=occ.free if want_free else None,
        resolution_m=occ.resolution_m,
        origin=tuple(occ.origin),
        source=occ.source,
        t_load_s=time.perf_counter() - t0,
        n_tiles=_n_tiles(occ.shape, tile_px),
    )


class _BatchRun:
    def __init__(
        self,
        items: list[_Item],
        *,
        executor: cf.Executor | None,
        workers: int,
        config: PipelineConfig,
        out_dir: Path | None,
        formats: tuple[str, ...],
        plot: bool,
        keep_graphs: bool,
        tiles_per_call: int,
        kernel_threads: int,
        batch_tiles: int,
        progress: bool,
        resume: bool,
        request: dict[str, Any],
        fingerprints: dict[int, dict[str, Any] | None],
        map_mode: str | None = None,
        sigma_m: float | None = None,
    ) -> None:
        self.items = items
        self.map_mode = map_mode
        self.sigma_m = sigma_m
        self._configs: dict[float, PipelineConfig] = {}
        self.executor = executor
        self.owns_executor = executor is None
        self.workers = workers
        self.config = config
        self.out_dir = out_dir
        self.formats = formats
        self.plot = plot
        self.keep_graphs = keep_graphs
        self.tiles_per_call = tiles_per_call
        self.kernel_threads = kernel_threads
        self.batch_tiles = batch_tiles
        self.progress = progress
        self.resume = resume
        self.request = request
        self.fingerprints = fingerprints
        self.prefetch = max(8, 4 * kernel_threads)
        # CPU jobs queued at most: small for the own pool, whose FIFO also carries the map
        # reads the kernels wait for; an outside executor's size is unknown.
        self.cpu_backlog = max(4, 3 * workers) if executor is None else 64
        self._restarts = 0

    # ---------------------------------------------------------------- executor handling
    def _new_executor(self) -> cf.Executor:
        if self.workers == 0:
            return InlineExecutor()
        ex = cf.ProcessPoolExecutor(max_workers=self.workers, mp_context=_worker_context())
        for _ in range(self.workers):  # import + numba cache load while the kernels compile
            ex.submit(_warm_worker)
        return ex

    def _submit(self, fn: Any, *args: Any) -> cf.Future:
        """Submit to the executor; an own process pool that broke is replaced (3 times)."""
        if self.executor is None:
            self.executor = self._new_executor()
        try:
            return self.executor.submit(fn, *args)
        except cf.BrokenExecutor:
            if not self.owns_executor or self._restarts >= 3:
                raise
            self._restarts += 1
            self.executor.shutdown(wait=False, cancel_futures=True)
            self.executor = self._new_executor()
            return self.executor.submit(fn, *args)

    # ---------------------------------------------------------------- kernel stage
    def _config_for(self, g: _Loaded) -> PipelineConfig:
        """The settings of map ``g``: ``config``, with the Gaussian of ``sigma_m`` metres
        at the map's resolution when that is given."""
        if self.sigma_m is None:
            return self.config
        cfg = self._configs.get(g.resolution_m)
        if cfg is None:
            distance = DistanceConfig.from_metres(sigma_m=self.sigma_m, resolution_m=g.resolution_m)
            cfg = self._configs[g.resolution_m] = dataclasses.replace(
                self.config, distance=distance
            )
        return cfg

    def _dense_fields(self, group: list[_Loaded]) -> tuple[list[Any], float]:
        """``dense_fields_many`` over the maps of a group (one distance setting); (fields,
        wall seconds)."""
        from .pipeline import dense_fields_many

        cfg = self._config_for(group[0])

        def call() -> list[Any]:
            return dense_fields_many(
                [g.occupied for g in group],
                distance=cfg.distance,
                ridge=cfg.ridge,
                tile_px=cfg.tile_px,
                tiles_per_call=self.tiles_per_call,
            )

        t0 = time.perf_counter()
        if self._compiled(cfg):
            out = call()
        else:
            with _COMPILE_LOCK:  # the first call of a bucket traces it, alone
                out = call()
                _COMPILED_BUCKETS.add(self._bucket(cfg))
        return out, time.perf_counter() - t0

    def _bucket(self, cfg: PipelineConfig) -> tuple[int, ...]:
        return (cfg.tile_px, self.tiles_per_call, cfg.distance.half_width_px, cfg.ridge.ksize)

    def _compiled(self, cfg: PipelineConfig) -> bool:
        return self._bucket(cfg) in _COMPILED_BUCKETS

    def _kernels(self, group: list[_Loaded]) -> list[tuple[_Loaded, _CpuJob | None, float, str]]:
        """Run the JAX stage for a group of maps and build their CPU jobs.

        Returns ``(loaded map, job or None, t_distance_s, error message)`` per map.  If the
        group's kernel call fails, each map is retried alone, so one bad map cannot fail
        the others of its group.
        """
        from .distance import FAR_SQ
        from .pipeline import DenseFields, travel_ridges

        with_obstacles = [g for g in group if g.occupied.any()]
        empty = {id(g) for g in group} - {id(g) for g in with_obstacles}
        fields: dict[int, tuple[Any, float]] = {}
        errors: dict[int, str] = {}
        if with_obstacles:
            try:
                out, wall = self._dense_fields(with_obstacles)
                tiles = sum(g.n_tiles for g in with_obstacles)
                for g, f in zip(with_obstacles, out, strict=True):
                    fields[id(g)] = (f, wall * g.n_tiles / tiles)
            except Exception as exc:
                if len(with_obstacles) == 1:
                    errors[id(with_obstacles[0])] = _error_text(exc)
                for g in with_obstacles if len(with_obstacles) > 1 else []:
                    try:
                        (f,), wall = self._dense_fields([g])
                        fields[id(g)] = (f, wall)
                    except Exception as exc_one:
                        errors[id(g)] = _error_text(exc_one)
        jobs: list[tuple[_Loaded, _CpuJob | None, float, str]] = []
        for g in group:
            cfg = self._config_for(g)
            if id(g) in errors:
                jobs.append((g, None, 0.0, errors[id(g)]))
                continue
            t0 = time.perf_counter()
            occ = g
            if id(g) in empty:  # no obstacle: H = 0, no ridges (as build_graph)
                share = 0.0
                f = DenseFields(
                    np.full(occ.shape, FAR_SQ, np.int32),
                    np.zeros(occ.shape, np.float32),
                    np.zeros(occ.shape, np.uint8),
                    np.zeros(occ.shape, bool),
                )
            else:
                f, share = fields[id(g)]
            # as build_graph: nothing to thin on a map that is all obstacle
            f = dataclasses.replace(f, ridges=travel_ridges(f.ridges, occ.occupied))
            # Skeleton pixels are a subset of the ridge pixels, so the clearances of the
            # ridge pixels (computed exactly as build_graph does) are all the graph reads.
            clearance = _ridge_clearance(f, occ.occupied, cfg.distance.half_width_px)
            masks = None
            if self.plot and self.out_dir is not None:
                masks = np.packbits(np.stack([occ.occupied, occ.free]))
            job = _CpuJob(
                name=g.item.name,
                shape=tuple(occ.shape),
                resolution_m=occ.resolution_m,
                origin=tuple(occ.origin),
                source=occ.source,
                ridges_bits=np.packbits(f.ridges),
                clearance_values=clearance,
                config=cfg,
                out_dir=None if self.out_dir is None else os.fspath(self.out_dir),
                formats=self.formats,
                masks_bits=masks,
                keep_graph=self.keep_graphs,
                free_bits=np.packbits(occ.free) if cfg.graph.free_space_only else None,
            )
            jobs.append((g, job, share + time.perf_counter() - t0, ""))
        return jobs

    def _take_group(self, ready: deque[_Loaded], limit: int) -> list[_Loaded]:
        """The next maps in order, up to ``limit`` tiles (at least one map), all with the
        first one's distance setting (one kernel call serves one setting)."""
        group = [ready.popleft()]
        tiles = group[0].n_tiles
        distance = self._config_for(group[0]).distance
        while (
            ready
            and tiles + ready[0].n_tiles <= limit
            and self._config_for(ready[0]).distance == distance
        ):
            tiles += ready[0].n_tiles
            group.append(ready.popleft())
        return group

    # ---------------------------------------------------------------- manifests
    def _manifest_path(self, name: str) -> Path:
        assert self.out_dir is not None
        return self.out_dir / f"{name}{_MANIFEST_SUFFIX}"

    def _resume_record(self, item: _Item) -> MapRecord | None:
        """The recorded result of ``item`` if its outputs are complete and valid."""
        fp = self.fingerprints.get(item.index)
        if self.out_dir is None or fp is None:
            return None
        path = self._manifest_path(item.name)
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(doc, dict) or doc.get("version") != _MANIFEST_VERSION:
            return None
        if doc.get("map") != item.name or doc.get("input") != _normalise(fp):
            return None
        if doc.get("request") != self.request:
            return None
        files = doc.get("files")
        if not isinstance(files, dict):
            return None
        expected = {f"{item.name}{_FORMAT_SUFFIX[f]}" for f in self.formats}
        if self.plot:
            expected.add(f"{item.name}{_PICTURE_SUFFIX}")
        if set(files) != expected:
            return None
        for rel, meta in files.items():
            p = self.out_dir / rel
            try:
                if p.stat().st_size != meta["bytes"] or _sha256_file(p) != meta["sha256"]:
                    return None
            except (OSError, KeyError, TypeError):
                return None
        row = doc.get("record")
        if not isinstance(row, dict):
            return None
        rec = MapRecord(map=item.name, path=item.label)
        for name in SUMMARY_COLUMNS:
            if name not in ("map", "path", "status", "message") and name in row:
                setattr(rec, name, row[name])
        rec.status = "skipped"
        rec.message = "outputs complete (resume)"
        rec.outputs = (*sorted(files), path.relative_to(self.out_dir).as_posix())
        return rec

    def _write_manifest(self, item: _Item, rec: MapRecord, files: dict[str, Any]) -> str:
        assert self.out_dir is not None
        doc = {
            "version": _MANIFEST_VERSION,
            "map": item.name,
            "path": item.label,
            "input": _normalise(self.fingerprints.get(item.index)),
            "request": self.request,
            "files": files,
            "record": {k: v for k, v in rec.row().items() if k not in ("status", "message")},
        }
        path = self._manifest_path(item.name)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, json.dumps(doc, indent=1).encode("utf-8"))
        return path.relative_to(self.out_dir).as_posix()

    def _forget_outputs(self, item: _Item) -> None:
        """Before redoing a map: drop its manifest and stale temporary files."""
        if self.out_dir is None:
            return
        manifest = self._manifest_path(item.name)
        manifest.unlink(missing_ok=True)
        folder = manifest.parent
        if folder.is_dir():
            base = Path(item.name).name
            suffixes = [_FORMAT_SUFFIX[f] for f in self.formats]
            suffixes += [_PICTURE_SUFFIX, _MANIFEST_SUFFIX]
            for suffix in suffixes:  # leftovers of atomic writes killed mid-way
                for tmp in folder.glob(f".{_glob.escape(base + suffix)}.*.tmp"):
                    tmp.unlink(missing_ok=True)

    # ---------------------------------------------------------------- main loop
    def run(self) -> list[MapRecord]:
        from tqdm.auto import tqdm

        records: dict[int, MapRecord] = {}
        bar = tqdm(
            total=len(self.items),
            unit="map",
            desc="topojax batch",
            disable=not self.progress,
            file=sys.stderr,
            dynamic_ncols=True,
        )
        counts: Counter[str] = Counter()

        def finish(index: int, rec: MapRecord) -> None:
            records[index] = rec._finish()
            counts[rec.status] += 1
            bar.update(1)
            bar.set_postfix({k: counts[k] for k in ("ok", "skipped", "error") if counts[k]})

        pending: deque[_Item] = deque()
        for item in self.items:
            rec = self._resume_record(item) if self.resume else None
            if rec is not None:
                finish(item.index, rec)
            else:
                pending.append(item)

        tile_px = self.config.tile_px
        # the free mask: for the picture, and for free_space_only's thinning
        want_free = (self.plot and self.out_dir is not None) or self.config.graph.free_space_only
        # Map files are read by our own worker processes (same file system, and it keeps
        # decoding off this process's GIL); with a given executor (a cluster may not see
        # the files) or workers=0 they are read by threads here.
        load_in_workers = self.owns_executor and self.workers > 0
        load_pool = cf.ThreadPoolExecutor(2, thread_name_prefix="topojax-load")
        kernel_pool = cf.ThreadPoolExecutor(self.kernel_threads, thread_name_prefix="topojax-jax")
        loads: dict[cf.Future, _Item] = {}
        kernels: dict[cf.Future, list[_Loaded]] = {}
        cpu: dict[cf.Future, tuple[_Item, MapRecord]] = {}
        ready: deque[_Loaded] = deque()
        try:
            if pending and self.executor is None:
                self.executor = self._new_executor()
            while True:
                while pending and len(loads) + len(ready) < self.prefetch:
                    item = pending.popleft()
                    if item.occupancy is not None:  # nothing to load
                        loaded = _load_here(item, tile_px, want_free)
                        try:
                            self._config_for(loaded)  # e.g. a sigma_m too large here
                        except ValueError as exc:
                            finish(item.index, self._base_record(loaded, "error", _error_text(exc)))
                            continue
                        ready.append(loaded)
                    elif load_in_workers:
                        fut = self._submit(
                            _load_in_worker, os.fspath(item.path), want_free, self.map_mode
                        )
                        loads[fut] = item
                    else:
                        fut = load_pool.submit(_load_here, item, tile_px, want_free, self.map_mode)
                        loads[fut] = item
                while ready and len(kernels) < self.kernel_threads and len(cpu) < self.cpu_backlog:
                    # Until the kernel is compiled, send one map at a time: the first call
                    # (tracing + XLA compilation) runs alone, and a small first group lets
                    # the pipeline fill as soon as it is done.
                    limit = self.batch_tiles if self._compiled(self._config_for(ready[0])) else 0
                    group = self._take_group(ready, limit)
                    kernels[kernel_pool.submit(self._kernels, group)] = group
                waiting = [*loads, *kernels, *cpu]
                if not waiting:
                    break
                done, _ = cf.wait(waiting, return_when=cf.FIRST_COMPLETED)
                for fut in done:
                    if fut in loads:
                        item = loads.pop(fut)
                        try:
                            loaded = fut.result()
                            if isinstance(loaded, _LoadedBits):
                                loaded = _loaded_from_bits(item, loaded, tile_px)
                            self._config_for(loaded)  # e.g. a sigma_m too large here
                            ready.append(loaded)
                        except Exception as exc:
                            finish(
                                item.index,
                                MapRecord(
                                    item.name, item.label, status="error", message=_error_text(exc)
                                ),
                            )
                    elif fut in kernels:
                        group = kernels.pop(fut)
                        try:
                            jobs = fut.result()
                        except Exception as exc:
                            for g in group:
                                finish(
                                    g.item.index, self._base_record(g, "error", _error_text(exc))
                                )
                            continue
                        for g, job, t_distance, error in jobs:
                            rec = self._base_record(g, "error" if error else "ok", error)
                            rec.t_distance_s = t_distance
                            if job is None:
                                finish(g.item.index, rec)
                                continue
                            try:
                                self._forget_outputs(g.item)  # its outputs are about to change
                                cpu[self._submit(_cpu_stage, job)] = (g.item, rec)
                            except Exception as exc:
                                rec.status, rec.message = "error", _error_text(exc)
                                finish(g.item.index, rec)
                    else:
                        item, rec = cpu.pop(fut)
                        finish(item.index, self._complete(item, rec, fut))
        finally:
            bar.close()
            load_pool.shutdown(wait=True, cancel_futures=True)
            kernel_pool.shutdown(wait=True, cancel_futures=True)
            if self.owns_executor and self.executor is not None:
                self.executor.shutdown(wait=True, cancel_futures=True)
        return [records[item.index] for item in self.items]

    def _base_record(self, g: _Loaded, status: str, message: str) -> MapRecord:
        occ = g
        rec = MapRecord(
            map=g.item.name,
            path=g.item.label,
            height=int(occ.shape[0]),
            width=int(occ.shape[1]),
            resolution_m=float(occ.resolution_m),
            t_load_s=g.t_load_s,
            status=status,
            message=message,
        )
        return rec

    def _complete(self, item: _Item, rec: MapRecord, fut: cf.Future) -> MapRecord:
        try:
            res: _CpuResult = fut.result()
        except Exception as exc:  # the worker died or the task could not be run
            rec.status, rec.message = "error", f"CPU stage failed: {_error_text(exc)}"
            return rec
        rec.vertices, rec.edges = res.vertices, res.edges
        rec.components, rec.total_length_m = res.components, res.total_length_m
        rec.t_thinning_s, rec.t_graph_s, rec.t_write_s = (
            res.t_thinning_s,
            res.t_graph_s,
            res.t_write_s,
        )
        rec.outputs = tuple(res.files)
        if res.error is not None:
            rec.status, rec.message = "error", res.error
            return rec
        rec.graph = res.graph
        if self.out_dir is not None:
            rec._finish()
            try:
                manifest = self._write_manifest(item, rec, res.files)
            except Exception as exc:
                rec.status, rec.message = "error", f"manifest: {_error_text(exc)}"
                return rec
            rec.outputs = (*rec.outputs, manifest)
        return rec


# ======================================================================================
# public entry point
# ======================================================================================


def _check_formats(formats: Any) -> tuple[str, ...]:
    if isinstance(formats, str):
        formats = [f for f in formats.split(",") if f.strip()]
    try:
        items = [str(f).strip().lower().lstrip(".") for f in formats]
    except TypeError:
        raise TypeError(
            f"formats: expected a sequence of format names, got {type(formats).__name__}"
        ) from None
    allowed = tuple(_FORMAT_SUFFIX)
    bad = [f for f in items if f not in allowed]
    if bad:
        raise ValueError(f"formats: expected names from {allowed}, got {bad!r}")
    if not items:
        raise ValueError(f"formats: expected at least one of {allowed}, got none")
    return tuple(dict.fromkeys(items))


def _positive_int(name: str, value: Any, *, minimum: int = 1) -> int:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < minimum:
        raise ValueError(f"{name}: expected an int >= {minimum}, got {value!r}")
    return int(value)


def _default_kernel_threads() -> int:
    import jax

    cores = os.cpu_count() or 1
    if jax.default_backend() == "cpu":
        return max(1, min(cores, 8))
    return 2  # an accelerator: one thread cuts tiles while the other's kernels run


def build_graphs(
    maps: Iterable[str | os.PathLike[str] | OccupancyMap] | str | os.PathLike[str] | OccupancyMap,
    *,
    executor: Any = None,
    workers: int | None = None,
    config: PipelineConfig | None = None,
    out_dir: str | os.PathLike[str] | None = None,
    formats: Sequence[str] | str = ("graphml", "json", "geojson"),
    plot: bool = False,
    resume: bool = False,
    progress: bool = True,
    tiles_per_call: int | None = None,
    kernel_threads: int | None = None,
    batch_tiles: int | None = None,
    keep_graphs: bool | None = None,
    map_mode: str | None = None,
    sigma_m: float | None = None,
) -> list[MapRecord]:
    """Build the topology graphs of many maps (see the module notes for the design).

    Parameters
    ----------
    maps : iterable of (str, path or OccupancyMap)
        Map files in any format :func:`topojax.load_map` reads (YAML, PGM, PNG, ...;
        expand globs/folders first, e.g. with :func:`expand_map_inputs`) and/or loaded
        maps.  A single path or map is accepted too.
    executor : concurrent.futures.Executor or dask.distributed.Client, optional
        Runs the CPU stages (thinning, T removal, graph, output files).  Default: a
        :class:`~concurrent.futures.ProcessPoolExecutor` of ``workers`` processes
        (``forkserver`` start method where available, else ``spawn``), which also reads
        the map files, shut down at the end.  A Dask ``Client`` is used through
        ``client.get_executor(pure=False)``.  A given executor is not shut down, and map
        files are then read in the calling process.
    workers : int, optional
        Worker processes of the default executor; default ``os.cpu_count()``.  ``0`` runs
        the CPU stage in the calling thread (:class:`InlineExecutor`).  Not used when
        ``executor`` is given (but still checked).
    config : PipelineConfig, optional
        Stage settings, as for :func:`topojax.build_graph`.
    out_dir : str or path, optional
        Output folder (created).  Without it nothing is written and the graphs are
        returned in the records.
    formats : sequence of {"graphml", "json", "geojson", "nav2"} or comma-separated str
        Graph files per map (``nav2``: ``<name>_nav2.geojson``, a route graph for the ROS 2
        Nav2 Route Server, :func:`topojax.save_nav2_graph` with its default tolerance).
    plot : bool
        Also write ``<name>_graph.png`` (map, skeleton and graph; needs ``out_dir``).
    resume : bool
        Skip maps whose manifest shows complete, valid outputs for the same input and
        settings (needs ``out_dir``).
    progress : bool
        Show a tqdm progress bar (maps, rate, ETA) on stderr.
    tiles_per_call : int, optional
        Tiles per kernel call (the bucket size; one compiled kernel per value).  Default
        ``max(config.tiles_per_call, 16)``; larger values may suit GPUs.
    kernel_threads : int, optional
        Threads dispatching kernel calls concurrently.  Default: the number of cores
        (at most 8) on the CPU backend, 2 on an accelerator.
    batch_tiles : int, optional
        Most tiles per group of maps sent to the kernels together (a larger map forms
        a group of its own).  Default ``16 * tiles_per_call``.
    keep_graphs : bool, optional
        Return each ``networkx.MultiGraph`` in ``MapRecord.graph``.  Default: True
        without ``out_dir``, False with it (graphs are then on disk).  Maps skipped by
        ``resume`` are not rebuilt, so their records hold no graph (read it from their
        files with :func:`topojax.load_graph`).
    map_mode : {"trinary", "scale", "raw", "ipa"}, optional
        Pixel convention for every map file, as ``mode`` of :func:`topojax.load_map`
        (e.g. ``"ipa"`` for the IPA benchmark maps, where every pixel below 250 is
        inaccessible).  Default: each file's own (its YAML's, else trinary).  Maps given
        as :class:`OccupancyMap` objects are already classified.
    sigma_m : float, optional
        The distance map's Gaussian σ in metres for every map, converted with each map's
        own resolution (:meth:`DistanceConfig.from_metres`; the support scales with it),
        in place of ``config.distance``.  Maps of different resolutions then get
        different pixel settings: each setting compiles its own kernel once and runs
        in kernel calls of its own.  Default: ``config.distance`` (the paper's 64.19 px)
        for every map.

    Returns
    -------
    list of MapRecord
        One per input, in input order.  With ``out_dir``, the table is also written to
        ``out_dir/summary.csv`` (and ``summary.parquet`` with pyarrow).

    Raises
    ------
    TypeError, ValueError
        For invalid arguments (a bad map never raises; it becomes an error record).
    """
    if isinstance(maps, (str, os.PathLike, OccupancyMap)):
        maps = [maps]
    try:
        inputs = list(maps)
    except TypeError:
        raise TypeError(
            f"maps: expected an iterable of paths or OccupancyMap objects, got "
            f"{type(maps).__name__}"
        ) from None
    sources: list[Path | None] = []
    items_raw: list[tuple[Path | None, OccupancyMap | None]] = []
    for i, m in enumerate(inputs):
        if isinstance(m, OccupancyMap):
            items_raw.append((None, m))
            sources.append(Path(m.source) if m.source else None)
        elif isinstance(m, (str, os.PathLike)):
            items_raw.append((Path(m), None))
            sources.append(Path(m))
        else:
            raise TypeError(
                f"maps[{i}]: expected a path (str / os.PathLike) or an OccupancyMap, got "
                f"{type(m).__name__}"
            )
    config = PipelineConfig() if config is None else config
    if not isinstance(config, PipelineConfig):
        raise TypeError(f"config: expected a PipelineConfig, got {type(config).__name__}")
    fmts = _check_formats(formats)
    if map_mode is not None and map_mode not in MODES:
        raise ValueError(f"map_mode: expected one of {MODES} or None, received {map_mode!r}")
    flags = [("plot", plot), ("resume", resume), ("progress", progress)]
    if keep_graphs is not None:
        flags.append(("keep_graphs", keep_graphs))
    for name, flag in flags:
        if not isinstance(flag, (bool, np.bool_)):
            raise TypeError(f"{name}: expected a bool, got {flag!r}")
    if sigma_m is not None:
        sigma_m = positive_metres("sigma_m", sigma_m)
    if out_dir is None and (plot or resume):
        raise ValueError("out_dir: needed for plot=True or resume=True, got None")
    tpc = _positive_int(
        "tiles_per_call",
        max(config.tiles_per_call, _DEFAULT_TILES_PER_CALL)
        if tiles_per_call is None
        else tiles_per_call,
    )
    threads = _positive_int(
        "kernel_threads", _default_kernel_threads() if kernel_threads is None else kernel_threads
    )
    group_tiles = _positive_int("batch_tiles", 16 * tpc if batch_tiles is None else batch_tiles)
    keep = out_dir is None if keep_graphs is None else bool(keep_graphs)
    if executor is not None and not isinstance(executor, cf.Executor):
        get_executor = getattr(executor, "get_executor", None)
        if get_executor is None:
            raise TypeError(
                "executor: expected a concurrent.futures.Executor or a dask.distributed "
                f"Client, got {type(executor).__name__}"
            )
        executor = get_executor(pure=False)
    n_workers = (os.cpu_count() or 1) if workers is None else workers
    n_workers = _positive_int("workers", n_workers, minimum=0)

    out: Path | None = None
    if out_dir is not None:
        out = output_folder(out_dir)
    names = _assign_names(sources)
    items = [
        _Item(index=i, name=names[i], path=p, occupancy=occ) for i, (p, occ) in enumerate(items_raw)
    ]
    if out is not None:
        _check_no_overwrite(items, out, fmts, plot)
    request = _normalise(
        {
            "distance": dataclasses.asdict(config.distance),
            "ridge": dataclasses.asdict(config.ridge),
            "skeleton": dataclasses.asdict(config.skeleton),
            "graph": dataclasses.asdict(config.graph),
            "formats": sorted(fmts),
            "plot": bool(plot),
            # only when given, so that manifests written without them still match
            **({"map_mode": map_mode} if map_mode is not None else {}),
            **({"sigma_m": sigma_m} if sigma_m is not None else {}),
        }
    )
    fingerprints = {item.index: _fingerprint(item) for item in items} if out is not None else {}
    runner = _BatchRun(
        items,
        executor=executor,
        workers=n_workers,
        config=config,
        out_dir=out,
        formats=fmts,
        plot=bool(plot),
        keep_graphs=keep,
        tiles_per_call=tpc,
        kernel_threads=threads,
        batch_tiles=group_tiles,
        progress=bool(progress),
        resume=bool(resume),
        request=request,
        fingerprints=fingerprints,
        map_mode=map_mode,
        sigma_m=sigma_m,
    )
    records = runner.run()
    if out is not None:
        write_summary(records, out)
    return records


def _check_no_overwrite(
    items: list[_Item], out: Path, formats: tuple[str, ...], plot: bool
) -> None:
    """Refuse output names that would replace one of the input files (a map file, or the
    image a YAML refers to)."""
    suffixes = [_FORMAT_SUFFIX[f] for f in formats] + [_MANIFEST_SUFFIX]
    if plot:
        suffixes.append(_PICTURE_SUFFIX)
    refuse_overwriting_inputs(
        [it.path for it in items if it.path is not None],
        [out / f"{it.name}{suffix}" for it in items for suffix in suffixes],
        option="out_dir",
    )
