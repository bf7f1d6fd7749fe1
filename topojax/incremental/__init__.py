"""Incremental topology mapping from laser scans (paper §III, made exact).

A robot streams laser scans with poses; :class:`IncrementalMapper` keeps the obstacle map,
the distance map, the ridges, the skeleton and the topology graph up to date while touching
only what changed.  Three loops run on their own schedules (paper defaults 1 / 20 / 80
scans) or on explicit calls:

1. **Distance loop** (every scan, :meth:`IncrementalMapper.add_scan`).  Beam end points
   become obstacle pixels of an unbounded pixel lattice stored in tiles
   (:class:`~topojax.tiling.TileManager`, allocated on demand in every direction); free
   cells along each beam (Bresenham) are counted for the occupancy output, in batches: at
   each skeleton update on a worker thread (while the update runs), or when the
   occupancy, the tiles or the state are read (the counts saturate, so the order does
   not matter).  Pixels hit for
   the first time are *new obstacles* (obstacles are monotone, like the paper's max-merge);
   they are Gaussian max-splatted into the blocks they can affect.  Because the Gaussian
   decreases with distance, the splat is kept as the integer windowed squared distance
   ``d2(x) = min (dr^2 + dc^2)`` over obstacles ``p`` with ``|x - p|_inf <= R``: the max of
   kernels becomes a min of squared distances, and ``H = exp(-d2 / (2 sigma^2))`` is
   computed from it on demand.
2. **Skeleton loop** (every ``skeleton_every`` scans, :meth:`IncrementalMapper.update_skeleton`).
   Ridges are recomputed on the blocks whose 2-pixel neighbourhood changed, then the
   skeleton is updated with one of two strategies (``"exact"``, ``"paper"``).
3. **Graph loop** (every ``graph_every`` scans, :meth:`IncrementalMapper.update_graph`).
   The graph is patched around the changed skeleton pixels only (paper §III-C); vertices
   and edges elsewhere keep their ids.  Each update returns a :class:`GraphUpdate`.

World grid
----------
Pixel ``(row, col)`` of the lattice (any integers) has its centre at
``x = (col + 0.5) * resolution_m``, ``y = -(row + 0.5) * resolution_m`` in the map frame
(rows grow downwards, i.e. towards -y, as in images).  Exported dense arrays
(:attr:`IncrementalMapper.distance`, :attr:`~IncrementalMapper.occupancy`, ...) cover the
bounding box of the allocated tiles; the exported :class:`~topojax.maps.OccupancyMap` has
the ``origin`` that makes its ``pixel_to_world`` agree with the formula above, so
:func:`topojax.build_graph` on it gives the same world coordinates.  Tiles are allocated
for every pixel within ``R + 2`` (Chebyshev) of an obstacle and for every beam cell, so a
tile that is not allocated has ``H = 0`` on it and on its 2-pixel halo (no ridges).

Splat kernel
------------
Tiles are cut into blocks of ``block_px`` (default 16).  A JAX kernel
(:func:`splat_block`, vmapped over a fixed batch of (block, 8 points) rows: two compiled
batch sizes, no recompilation) computes the windowed squared distance from a block's
pixels to up to 8 points; a numba step merges the rows into the tiles with a minimum.
Pairs (block, point) that cannot change a block are never formed, exactly: (a) the
squared distance from the point to the block is not below the block's maximum ``d2``;
(b) another obstacle within 2 pixels of the point is at least as near to all four block
corners (a half-plane test; see :func:`_splat_pairs` for why chains of such dominations
are safe); (c) the point is no nearer to the block than another new point of the same
batch is to the block's farthest corner (on intel this drops 58 % of the pairs left by
(a) and (b)).  Everything is integer, so the incremental ``d2`` equals the full-map one bit
for bit.

Exactness
---------
* Distance: ``sq_distance_px`` equals ``dense_fields(occupancy.occupied).sq_distance_px``
  exactly and ``distance`` equals the full-map ``H`` (the same float32 function).
* Ridges: the full pipeline's maths (:func:`~topojax.distance.gaussian_from_sq_distance`,
  :func:`~topojax.filters.laplacian_valid`, :func:`~topojax.filters.ridge_from_laplacian`)
  runs in JAX on haloed blocks; the gather applies ``BORDER_REFLECT_101`` at the border of
  the bounding box (index reflection commutes with the elementwise Gaussian).  When the
  box grows, the blocks along its old border are recomputed.
* ``"exact"`` skeleton, re-thinned locally.  Parallel thinning (Guo–Hall or Zhang–Suen)
  decides a pixel at sub-iteration ``s`` from its 8 neighbours' states at ``s``.  The
  mapper keeps, per pixel, the sub-iteration at which the thinning of the whole current
  ridge map deletes it (layer ``thin_time``: 0 off the ridge, ``s + 1``, or 65535 for a
  skeleton pixel).  After a ridge change it re-thins only the ridge pixels of the blocks
  around the changed pixels (:func:`_rethin`), reading the pixels just outside (the
  *ring*) from their stored history.  That is exact as long as every ring pixel sees the
  same neighbour states as before at every sub-iteration while it is alive (then, by
  induction over sub-iterations, nothing outside changes); the blocks of ring pixels for
  which this fails join the region and the round is repeated (it ends at the latest when
  the region covers whole ridge components, which have no ring).  T-centre removal
  examines pixels one at a time in raster order, interior first, then the border rows and
  columns (:func:`topojax.skeleton.remove_t_centres`), so a pixel reads the result of the
  4-neighbours examined before it and the thinned value of the others; the mapper
  re-examines, in that order, the pixels whose thinned value changed (or whose border rule
  changed when the bounding box grew), their 4-neighbours, and every later 4-neighbour of
  a pixel whose result changed (:func:`_t_update`).  The skeleton, and the stored
  history, equal those of the full-map pipeline on the exported map (tested after real
  and random replays, and against a whole-image reference on thick blobs, where the
  region has to grow).  :func:`thin_components` (whole components on a crop of their
  own) is the simpler exact alternative the mapper used before; it is kept as a utility.
* Graph: link masks and degrees of the pixel graph depend on 3x3 neighbourhoods, so only
  pixels within one pixel of a changed skeleton pixel (the region ``Z``) change.  Old
  edges that do not touch ``Z`` are edges of the new graph; every new edge that touches
  ``Z`` lies in ``A`` = the pixels of the old edges touching ``Z`` plus the new skeleton
  pixels in ``Z``.  The mapper traces the skeleton pixels within one pixel of ``A``
  (gathered from the tiles, so the cost follows the number of changed pixels, not their
  spread) with the kernels of :mod:`topojax.graph`, keeps the traced edges that lie in
  ``A`` and touch ``Z``, and replaces the old edges by them; an old edge whose path comes
  back unchanged keeps its key, and a vertex keeps its id while a vertex exists at its
  pixel.  Vertices and edges live in arrays indexed by id (the ``graph_id`` tile layer
  maps pixels back to ids), so an update costs no per-object Python containers.  Only
  net changes count: a pixel that changed and changed back since the last graph update is
  no change.  With the ``"exact"`` skeleton the graph equals ``build_graph`` on the
  exported map up to ids (same vertex pixels and kinds, same edge paths).  The tests check
  all of this after replays of real logs, and that every :class:`GraphUpdate` equals the
  difference of the graphs before and after it.

Laziness
--------
The splat of new obstacles is batched: pending points are flushed when
``max_pending_points`` are waiting, and before anything reads the distance map (the
skeleton loop, :attr:`~IncrementalMapper.distance`, :attr:`~IncrementalMapper.sq_distance_px`,
exports).  Results are identical to an eager splat (a minimum does not depend on the
order); ``max_pending_points=0`` splats at every scan.  :meth:`~IncrementalMapper.save`
stores pending points as they are.

Tiles and blocks have power-of-two sides (``tile_px``, ``block_px``), so the per-pixel
loops find a pixel's tile and its place in it with shifts and masks.

Memory: 18 bytes per pixel of an allocated tile (hit / miss counters, squared distance,
ridge, Laplacian, skeleton, thinning history, graph ids, scratch), about 288 KiB per
128 x 128 tile.
"""

from ._rethin import thin_components
from ._tiles import trace_counts
from .mapper import STRATEGIES, IncrementalMapper
from .replay import replay, summary_text
from .reports import GraphUpdate, ScanReport, timing_summary, vertex_error_metrics
from .state import STATE_FORMAT, STATE_VERSION

__all__ = [
    "STATE_FORMAT",
    "STATE_VERSION",
    "STRATEGIES",
    "GraphUpdate",
    "IncrementalMapper",
    "ScanReport",
    "replay",
    "summary_text",
    "thin_components",
    "timing_summary",
    "trace_counts",
    "vertex_error_metrics",
]
