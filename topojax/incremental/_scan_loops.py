"""The loops one scan runs: the distance loop for its end pixels, then the skeleton,
graph and rooms loops that are due."""

from __future__ import annotations

import time

import numpy as np

from ..scans.scan import Scan
from ._extent import Subject
from ._rays import RAY_BATCH_BEAMS, cast_pending_rays, integrate_end_pixels
from ._rooms import due_rooms_update, rooms_due
from ._tiles import _growth_pool
from .reports import ScanReport


def map_end_pixels(mapper, er, ec, ext, sensor, *, n_beams: int, t0: float, where) -> ScanReport:
    """The body of :meth:`IncrementalMapper._add_end_pixels`: the distance loop for one
    scan's end pixels, then the skeleton, graph and rooms loops that are due."""
    n_valid = int(er.shape[0])
    tiles = mapper._tiles
    n_tiles = tiles.n_tiles
    n_new = integrate_end_pixels(mapper, er, ec, ext, sensor, where=where)
    if tiles.n_tiles != n_tiles and _growth_pool() is not None:
        # page in the storage of the next growth on another thread (see TileManager)
        tiles.prepare_growth(_growth_pool().submit)
    if mapper._n_rays >= RAY_BATCH_BEAMS:
        cast_pending_rays(mapper)
    loops = ["distance"]
    timings: dict[str, float] = {}
    if mapper._n_pending and mapper._n_pending >= mapper.max_pending_points:
        ts = time.perf_counter()
        mapper._flush_splat()
        timings["splat"] = time.perf_counter() - ts
        loops.append("splat")
    timings["distance"] = time.perf_counter() - t0
    mapper._n_scans += 1
    mapper._since_skeleton += 1
    mapper._since_graph += 1
    update = None
    if mapper.graph_every and mapper._since_graph >= mapper.graph_every:
        ts = time.perf_counter()
        mapper.update_skeleton()
        timings["skeleton"] = time.perf_counter() - ts
        ts = time.perf_counter()
        update = mapper._update_graph()
        timings["graph"] = time.perf_counter() - ts
        loops += ["skeleton", "graph"]
    elif mapper.skeleton_every and mapper._since_skeleton >= mapper.skeleton_every:
        ts = time.perf_counter()
        mapper.update_skeleton()
        timings["skeleton"] = time.perf_counter() - ts
        loops.append("skeleton")
    mapper._since_rooms += 1
    rooms = None
    if rooms_due(mapper, graph_ran=update is not None):
        rooms = due_rooms_update(mapper)
    if rooms is not None:
        timings["rooms"] = rooms.time_s
        loops.append("rooms")
    return ScanReport(
        index=mapper._n_scans - 1,
        n_beams=n_beams,
        n_valid=n_valid,
        n_dropped=n_beams - n_valid,
        n_new_obstacles=int(n_new),
        loops=tuple(loops),
        timings_s=timings,
        n_tiles=tiles.n_tiles,
        graph_update=update,
        rooms_update=rooms,
    )


def scan_subject(mapper, scan) -> Subject:
    """``scan <index>`` then `` (timestamp <t> s): the pose (x, y, yaw) with readings up
    to <r> m``, naming the scan in a refusal (:class:`ExtentError`)."""
    stamp = "" if scan.timestamp is None else f" (timestamp {scan.timestamp:.6f} s)"
    r = np.asarray(scan.ranges, np.float64)[scan.valid_mask()]
    r = r if mapper.max_range_m is None else r[r < mapper.max_range_m]
    far = f" with readings up to {r.max():.6g} m" if r.size else ""
    n = mapper._n_scans
    return Subject(f"scan {n}", f"{stamp}: the pose {scan.pose}{far}", n)


def add_each(mapper, scans) -> list[ScanReport]:
    """The body of :meth:`IncrementalMapper.add_scans`: ``mapper.add_scan`` for every
    item of the iterable ``scans``, in order.

    Returns
    -------
    list of ScanReport
        One per scan.

    Raises
    ------
    TypeError
        For an item that is no :class:`~topojax.Scan`, naming its index in ``scans``
        and how many scans before it were added (they stay in the map).
    """
    reports = []
    for i, scan in enumerate(scans):
        if not isinstance(scan, Scan):
            raise TypeError(
                f"scans[{i}]: expected a topojax.Scan (see Scan.from_arrays), received "
                f"{type(scan).__name__}; the {i} scan(s) before it were added"
            )
        reports.append(mapper.add_scan(scan))
    return reports
