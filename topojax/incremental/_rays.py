"""The distance loop's CPU kernels: beam end points from a scan, Bresenham free-cell
counting, the tiles a scan needs and the integration of hits.
"""

from __future__ import annotations

import contextlib
import math

import numpy as np

from .._jit import cached_njit
from .._validate import finite_pair, point_rows
from .._words import memory_size
from ..fields.filters import HALO_PX
from ..fields.tiling import unique_pairs
from ._extent import ExtentError, Subject, refusal
from ._tiles import _MAX_ABS_PIXEL, _UINT16_MAX, _locate, _log2, _slot, _worker_pool

#: Beams whose free cells may wait for the next skeleton update (or an export); more
#: are counted at once.
RAY_BATCH_BEAMS = 1 << 16

#: Beams of a scan, spread over it, whose tiles are counted first where its extent holds
#: more tiles than the tile budget has left: a wide far scan far over the budget is then
#: refused after these, not after every beam (each costing work in its length).
_PROBE_BEAMS = 1024


@cached_njit(nogil=True)
def _scan_geometry(ranges, angle_min, angle_inc, range_min, range_max, sx, sy, syaw, res):
    """End pixels of the valid beams (same arithmetic as :meth:`Scan.endpoints_world`).

    A reading is valid when finite, > 0, >= ``range_min`` and < ``range_max``.  Returns
    rows, cols (int64) of the end pixels and their extent ``(min row, max row, min col,
    max col)`` (zeros without valid beams).
    """
    n = ranges.shape[0]
    er = np.empty(n, np.int64)
    ec = np.empty(n, np.int64)
    ext = np.zeros(4, np.int64)
    m = 0
    for i in range(n):
        r = np.float64(ranges[i])
        if not (math.isfinite(r) and r > 0.0 and r >= range_min and r < range_max):
            continue
        a = (angle_min + i * angle_inc) + syaw
        row = math.floor(-(sy + r * math.sin(a)) / res)
        col = math.floor((sx + r * math.cos(a)) / res)
        if m == 0 or row < ext[0]:
            ext[0] = row
        if m == 0 or row > ext[1]:
            ext[1] = row
        if m == 0 or col < ext[2]:
            ext[2] = col
        if m == 0 or col > ext[3]:
            ext[3] = col
        er[m] = row
        ec[m] = col
        m += 1
    return er[:m], ec[:m], ext


@cached_njit(nogil=True, inline="always")
def _bresenham_start(r, c, r1, c1):
    """Bresenham's line walk from (r, c) to (r1, c1): (dr, dc, stp_r, stp_c, err)."""
    dr = abs(r1 - r)
    dc = abs(c1 - c)
    return dr, dc, (1 if r1 > r else -1), (1 if c1 > c else -1), dc - dr


@cached_njit(nogil=True, inline="always")
def _bresenham_step(r, c, err, dr, dc, stp_r, stp_c):
    """One step of Bresenham's line walk; returns the next (row, col, error)."""
    e2 = 2 * err
    if e2 > -dr:
        err -= dr
        c += stp_c
    if e2 < dc:
        err += dc
        r += stp_r
    return r, c, err


@cached_njit(nogil=True, inline="always")
def _note_missing(out, m, tr, tc, seen, b0r, b0c):
    """Append tile ``(tr, tc)`` to ``out[:m]`` unless ``seen`` (the tiles of the box from
    tile ``(b0r, b0c)``) marks it already; returns ``(out, m)``, ``out`` grown when full."""
    if seen[tr - b0r, tc - b0c]:
        return out, m
    seen[tr - b0r, tc - b0c] = True
    if m == out.shape[0]:
        out = np.concatenate((out, np.empty_like(out)))
    out[m, 0] = tr
    out[m, 1] = tc
    return out, m + 1


@cached_njit(nogil=True)
def _missing_ray_tiles(sr, sc, er, ec, t, rays, grid, g0r, g0c, seen, b0r, b0c, limit):
    """Tiles touched by the beams (end cells; ray cells too if ``rays``) that are not
    allocated, each once (``seen`` covers the tiles of the box from tile ``(b0r, b0c)``
    that holds them all, and marks those found), the walk stopping once more than
    ``limit`` are found.  Fast path: a ray whose tile rectangle is allocated or found
    needs no walk."""
    tsh = _log2(t)
    n = er.shape[0]
    out = np.empty((16, 2), np.int64)
    m = 0
    gh = grid.shape[0]
    gw = grid.shape[1]
    str_ = sr >> tsh
    stc = sc >> tsh
    for i in range(n):
        if m > limit:
            break
        r1 = er[i]
        c1 = ec[i]
        if rays:
            tr0 = min(str_, r1 >> tsh)
            tr1 = max(str_, r1 >> tsh)
            tc0 = min(stc, c1 >> tsh)
            tc1 = max(stc, c1 >> tsh)
        else:
            tr0 = tr1 = r1 >> tsh
            tc0 = tc1 = c1 >> tsh
        full = True
        for tr in range(tr0, tr1 + 1):
            for tc in range(tc0, tc1 + 1):
                gi = tr - g0r
                gj = tc - g0c
                absent = gi < 0 or gj < 0 or gi >= gh or gj >= gw or grid[gi, gj] < 0
                if absent and not seen[tr - b0r, tc - b0c]:
                    full = False
        if full:
            continue
        if not rays:
            out, m = _note_missing(out, m, tr0, tc0, seen, b0r, b0c)
            continue
        r = sr
        c = sc
        dr, dc, stp_r, stp_c, err = _bresenham_start(r, c, r1, c1)
        last_r = -(1 << 62)
        last_c = -(1 << 62)
        while True:
            tr = r >> tsh
            tc = c >> tsh
            if tr != last_r or tc != last_c:
                last_r = tr
                last_c = tc
                if _slot(grid, g0r, g0c, tsh, r, c) < 0:
                    out, m = _note_missing(out, m, tr, tc, seen, b0r, b0c)
                    if m > limit:
                        return out[:m]
            if r == r1 and c == c1:
                break
            r, c, err = _bresenham_step(r, c, err, dr, dc, stp_r, stp_c)
    return out[:m]


@cached_njit(nogil=True)
def _missing_window_tiles(pr, pc, w, t, grid, g0r, g0c, seen, b0r, b0c, limit):
    """Tiles intersecting the squares ``[p - w, p + w]^2`` that are not allocated, each
    once and none that ``seen`` marks (as :func:`_missing_ray_tiles`), stopping once
    more than ``limit`` are found."""
    tsh = _log2(t)
    n = pr.shape[0]
    out = np.empty((16, 2), np.int64)
    m = 0
    for i in range(n):
        if m > limit:
            break
        tr0 = (pr[i] - w) >> tsh
        tr1 = (pr[i] + w) >> tsh
        tc0 = (pc[i] - w) >> tsh
        tc1 = (pc[i] + w) >> tsh
        for tr in range(tr0, tr1 + 1):
            for tc in range(tc0, tc1 + 1):
                gi = tr - g0r
                gj = tc - g0c
                ok = gi >= 0 and gj >= 0 and gi < grid.shape[0] and gj < grid.shape[1]
                if not ok or grid[gi, gj] < 0:
                    out, m = _note_missing(out, m, tr, tc, seen, b0r, b0c)
                    if m > limit:
                        return out[:m]
    return out[:m]


@cached_njit(nogil=True)
def _integrate(er, ec, t, grid, g0r, g0c, hits, w, seen, b0r, b0c):
    """Count hits (beam end cells); every end cell's tile must exist.

    Counters saturate at 65535.  Returns the pixels hit for the first time ever (new
    obstacles, (n, 2) int64, in beam order) and the unallocated tiles within ``w`` pixels
    (Chebyshev) of them (:func:`_missing_window_tiles`, each once: ``seen``, cleared,
    covers the tiles of the box from tile ``(b0r, b0c)`` that holds them).
    """
    tsh = _log2(t)
    n = er.shape[0]
    new = np.empty((n, 2), np.int64)
    n_new = 0
    for i in range(n):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, er[i], ec[i])
        h = hits[s, lr, lc]
        if h == 0:
            new[n_new, 0] = er[i]
            new[n_new, 1] = ec[i]
            n_new += 1
        if h < _UINT16_MAX:
            hits[s, lr, lc] = h + 1
    new = new[:n_new]
    return new, _missing_window_tiles(
        new[:, 0], new[:, 1], w, t, grid, g0r, g0c, seen, b0r, b0c, seen.size
    )


@cached_njit(nogil=True)
def _count_cells(rows, cols, t, grid, g0r, g0c, counts):
    """Add one to ``counts`` (saturating at 65535) at every pixel; its tile must exist."""
    tsh = _log2(t)
    for i in range(rows.shape[0]):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, rows[i], cols[i])
        if counts[s, lr, lc] < _UINT16_MAX:
            counts[s, lr, lc] += 1


@cached_njit(nogil=True)
def _cast_rays(sr, sc, off, er, ec, t, grid, g0r, g0c, misses):
    """Count free cells (``misses``) along beams, end excluded (Bresenham): the beams of
    scan ``j`` run from ``(sr[j], sc[j])`` to ``(er[i], ec[i])`` for ``off[j] <= i <
    off[j + 1]``.  Every touched tile must exist; counters saturate at 65535 (so the
    order of the beams does not matter)."""
    tsh = _log2(t)
    for j in range(sr.shape[0]):
        for i in range(off[j], off[j + 1]):
            r1 = er[i]
            c1 = ec[i]
            r = sr[j]
            c = sc[j]
            if r == r1 and c == c1:
                continue
            dr, dc, stp_r, stp_c, err = _bresenham_start(r, c, r1, c1)
            # tile-local stepping: look the tile up only when the ray leaves it
            s, lr, lc = _locate(grid, g0r, g0c, tsh, r, c)
            while True:
                if misses[s, lr, lc] < _UINT16_MAX:
                    misses[s, lr, lc] += 1
                r2, c2, err = _bresenham_step(r, c, err, dr, dc, stp_r, stp_c)
                lr += r2 - r
                lc += c2 - c
                r, c = r2, c2
                if r == r1 and c == c1:
                    break
                if lr < 0 or lr >= t or lc < 0 or lc >= t:
                    s, lr, lc = _locate(grid, g0r, g0c, tsh, r, c)


def integrate_end_pixels(mapper, er, ec, ext, sensor, *, where) -> int:
    """Hits at the end pixels ``(er, ec)`` (int64, extent ``ext`` = (min row, max row,
    min col, max col)): their tiles and those of their splat windows allocated, new
    obstacles queued for the splat, and the rays from the ``sensor`` pixel (row, col)
    queued for the free-cell count when given.  Raises before any change if the
    extent is too large (:class:`ExtentError`), its message starting with ``where()`` (a
    callable giving a :class:`Subject`: the scan path formats nothing unless it fails).  Returns the number of new obstacle
    pixels."""
    if mapper._ray_job is not None:  # only after an interrupted update
        join_rays(mapper)
    if not er.shape[0]:
        return 0
    t = mapper.tile_px
    n_valid = int(er.shape[0])
    tiles = mapper._tiles
    w = mapper._half + HALO_PX
    e_r0, e_r1, e_c0, e_c1 = ext.tolist()
    sr, sc = sensor if sensor is not None else (e_r0, e_c0)
    lo_r = min(e_r0, sr) - w
    hi_r = max(e_r1, sr) + w
    lo_c = min(e_c0, sc) - w
    hi_c = max(e_c1, sc) + w
    # Validate the whole extent (beams and splat windows) before changing anything.
    check_growth(mapper, lo_r, hi_r, lo_c, hi_c, where)
    rays = mapper.free_space and sensor is not None
    grid, (g0r, g0c) = tiles.slot_grid
    # each missing tile counted once (marked in `seen`, the tiles of the extent), and the
    # count stopped once over the budget: a far reading of a wide scan crosses many tiles
    b0r, b0c = lo_r // t, lo_c // t
    seen = np.zeros((hi_r // t - b0r + 1, hi_c // t - b0c + 1), np.bool_)
    # (at most the tiles of the extent: a budget of any size fits the compiled count)
    spare = min(max(mapper.max_tile_bytes // tiles.tile_nbytes - tiles.n_tiles, 0), seen.size)
    if rays and seen.size > spare and n_valid > _PROBE_BEAMS:  # see _PROBE_BEAMS
        step = -(-n_valid // _PROBE_BEAMS)
        pr, pc = np.ascontiguousarray(er[::step]), np.ascontiguousarray(ec[::step])
        probe = _missing_ray_tiles(
            sr, sc, pr, pc, t, rays, grid, g0r, g0c, seen.copy(), b0r, b0c, spare
        )
        if probe.shape[0] > spare:  # a subset of the beams' tiles: "at least"
            check_tile_budget(mapper, probe.shape[0], where, at_least=True)
    need = _missing_ray_tiles(sr, sc, er, ec, t, rays, grid, g0r, g0c, seen, b0r, b0c, spare)
    # the tiles of the beams, and of the splat windows round new obstacles (a subset of
    # the end pixels), counted exactly only where a rough bound could exceed the budget
    span = ((2 * w) // t) + 2
    more = 0
    if need.shape[0] <= spare and (
        (tiles.n_tiles + need.shape[0] + n_valid * span * span) * tiles.tile_nbytes
        > mapper.max_tile_bytes
    ):
        limit = spare - need.shape[0]
        more = _missing_window_tiles(er, ec, w, t, grid, g0r, g0c, seen, b0r, b0c, limit)
        more = more.shape[0]
    if need.shape[0] + more > spare:  # counted up to one over: "at least"
        check_tile_budget(mapper, need.shape[0] + more, where, at_least=True)
    if need.shape[0]:
        tiles.ensure(need[:, 0], need[:, 1])
        grid, (g0r, g0c) = tiles.slot_grid
    seen[:] = False  # the budget's count marked window tiles it did not allocate
    hits = tiles.layer("hits")
    new, miss = _integrate(er, ec, t, grid, g0r, g0c, hits, w, seen, b0r, b0c)
    if rays:
        # free cells are counted later, in batches (see cast_pending_rays)
        mapper._rays.append((sr, sc, er, ec))
        mapper._n_rays += n_valid
    n_new = new.shape[0]
    if n_new:
        if miss.shape[0]:
            tiles.ensure(miss[:, 0], miss[:, 1])
        mapper._pending.append(new)
        mapper._n_pending += n_new
        mapper._export_cache.clear()
    return int(n_new)


@contextlib.contextmanager
def changing(mapper, what: str):
    """Within ``with``, ``mapper`` changes its state (``what``: "a skeleton update", say):
    an exception or interrupt (Ctrl-C) that stops it part way, other than an
    :class:`ExtentError` (raised before any change), leaves the mapper marked as half
    updated (:func:`check_whole` then refuses to save or change it)."""
    try:
        yield
    except ExtentError:
        raise
    except BaseException as exc:
        if mapper._torn is None:
            mapper._torn = f"{type(exc).__name__} stopped {what} part way"
        raise


def check_whole(mapper, action: str) -> None:
    """Raise RuntimeError, saying why and what to do, if an exception or interrupt left
    ``mapper`` half updated (:func:`changing`): ``action`` ("save", say) would keep or
    build on a state that holds part of an update (a wrong map)."""
    if mapper._torn is not None:
        raise RuntimeError(
            f"mapper: cannot {action}: {mapper._torn}, so its state holds part of that "
            "update (its map and graph would be wrong); load the last saved state "
            "(IncrementalMapper.load) or add the scans to a new mapper"
        )


def check_growth(mapper, lo_r, hi_r, lo_c, hi_c, where) -> None:
    """Raise :class:`ExtentError` if the tiles of global pixels ``lo_r..hi_r`` x
    ``lo_c..hi_c`` (inclusive) lie beyond 2^30 pixels, or would make the allocated
    tiles' bounding box longer than ``max_extent_m`` or larger than ``max_grid_cells``;
    the message starts with ``where()``."""
    if max(abs(lo_r), abs(hi_r), abs(lo_c), abs(hi_c)) > _MAX_ABS_PIXEL:
        raise refusal(
            where,
            f" put pixels beyond {_MAX_ABS_PIXEL} px from the origin at "
            f"resolution {mapper.resolution_m} m; nothing was added (expected coordinates "
            "in metres; a localisation glitch?)",
            "max_abs_pixel",
        )
    check_max_extent(mapper, lo_r, hi_r, lo_c, hi_c, where)
    t = mapper.tile_px
    try:
        mapper._tiles.check_extent_box(lo_r // t, lo_c // t, hi_r // t + 1, hi_c // t + 1)
    except ValueError as exc:
        raise refusal(where, f": {exc}; nothing was added", "max_grid_cells") from None


def sensor_pixel(mapper, x: float, y: float, where) -> tuple[int, int]:
    """The global pixel ``(row, col)`` of a sensor at world ``(x, y)`` (metres), whose
    rays start there; :class:`ExtentError`, its message starting with ``where()``, if it
    lies beyond 2^30 pixels from the origin (where ``x / resolution`` may overflow)."""
    res = mapper.resolution_m
    row, col = -y / res, x / res
    if not (abs(row) <= _MAX_ABS_PIXEL and abs(col) <= _MAX_ABS_PIXEL):
        raise refusal(
            where,
            f" put the sensor at ({x:g}, {y:g}) m, beyond {_MAX_ABS_PIXEL} px from "
            f"the origin at resolution {res} m; nothing was added (expected coordinates in "
            "metres; a localisation glitch?)",
            "max_abs_pixel",
        )
    return math.floor(row), math.floor(col)


def check_tile_budget(mapper, new_tiles: int, where, *, at_least: bool = False) -> None:
    """Raise :class:`ExtentError` if ``new_tiles`` more tiles (``at_least`` that many: a
    count stopped once over the budget) would make the mapper's tiles hold more than
    ``mapper.max_tile_bytes``; the message starts with ``where()``."""
    tiles = mapper._tiles
    need = (tiles.n_tiles + int(new_tiles)) * tiles.tile_nbytes
    if need > mapper.max_tile_bytes:
        least = "at least " if at_least else ""
        raise refusal(
            where,
            f" would allocate {least}{new_tiles} more tiles, {least}"
            f"{memory_size(need)} in all, beyond max_tile_bytes={mapper.max_tile_bytes}; "
            "nothing was added (a reading far beyond the sensor's range? set the scan's "
            "range_max or the mapper's max_range_m, or make the mapper with a larger "
            "max_tile_bytes)",
            "max_tile_bytes",
        )


def check_max_extent(mapper, lo_r, hi_r, lo_c, hi_c, where) -> None:
    """Raise :class:`ExtentError` if allocating the tiles of global pixels ``lo_r..hi_r``
    x ``lo_c..hi_c`` (inclusive) would make a side of the allocated tiles' bounding box
    longer than ``mapper.max_extent_m``; the message starts with ``where()``."""
    t = mapper.tile_px
    r0, c0, r1, c1 = (lo_r // t) * t, (lo_c // t) * t, (hi_r // t + 1) * t, (hi_c // t + 1) * t
    bbox = mapper._tiles.pixel_bbox
    if bbox is not None:
        r0, c0 = min(r0, bbox[0]), min(c0, bbox[1])
        r1, c1 = max(r1, bbox[2]), max(c1, bbox[3])
    res = mapper.resolution_m
    height_m, width_m = (r1 - r0) * res, (c1 - c0) * res
    if max(height_m, width_m) > mapper.max_extent_m:
        w = mapper._half + HALO_PX  # the callers' splat window round each pixel
        spread = (max(hi_r - lo_r, hi_c - lo_c) + 1 - 2 * w) * res  # the pixels' own
        if spread > mapper.max_extent_m and where().scan is None:  # a map wider than that
            why = f"the map alone spans {spread:.6g} m: make the mapper with a larger max_extent_m"
        elif spread > mapper.max_extent_m:  # the pixels themselves lie too far apart
            why = (
                f"its pixels alone span {spread:.6g} m: a reading far beyond the sensor's "
                "range or a point far off? set the scan's range_max or the mapper's max_range_m, "
                "or make the mapper with a larger max_extent_m"
            )
        elif bbox is None:  # the first pixels alone: the tiles and window are too large
            why = (
                f"the first pixels' tiles of {t} px and distance window of "
                f"{mapper._half} px are {t * res:g} m and {mapper._half * res:g} m at "
                f"{res:g} m per pixel: make the mapper with a smaller tile_px or sigma, "
                "or a larger max_extent_m"
            )
        else:
            why = "a localisation glitch? check the pose, or make the mapper with a larger max_extent_m"
        raise refusal(
            where,
            f" would grow the mapped area to {width_m:.6g} m x {height_m:.6g} m "
            f"(x by y, tile-aligned), beyond max_extent_m={mapper.max_extent_m:g} m; "
            f"nothing was added ({why})",
            "max_extent_m",
        )


def cast_pending_rays(mapper, *, background: bool = False) -> None:
    """Count the free cells of the beams added since the last call (on the worker
    thread if ``background``; :func:`join_rays` waits for it)."""
    join_rays(mapper)
    if not mapper._rays:
        return
    with changing(mapper, "counting free cells"):
        _cast_batch(mapper, background)


def _cast_batch(mapper, background: bool) -> None:
    """The body of :func:`cast_pending_rays` once beams are waiting."""
    rays, mapper._rays, mapper._n_rays = mapper._rays, [], 0
    sr = np.array([r[0] for r in rays], np.int64)
    sc = np.array([r[1] for r in rays], np.int64)
    off = np.zeros(len(rays) + 1, np.int64)
    np.cumsum([r[2].shape[0] for r in rays], out=off[1:])
    er = np.concatenate([r[2] for r in rays])
    ec = np.concatenate([r[3] for r in rays])
    tiles = mapper._tiles
    grid, (g0r, g0c) = tiles.slot_grid
    args = (sr, sc, off, er, ec, mapper.tile_px, grid, g0r, g0c, tiles.layer("misses"))
    pool = _worker_pool() if background else None
    if pool is None:
        _cast_rays(*args)
    else:
        mapper._ray_job = pool.submit(_cast_rays, *args)


def join_rays(mapper) -> None:
    """Wait for the free-cell counting started by :func:`cast_pending_rays`."""
    job = mapper._ray_job
    if job is not None:
        try:
            job.result()
        finally:
            # an interrupt while waiting leaves the job running: keep waiting for it
            # next time (nothing may grow the tiles under it)
            if job.done():
                mapper._ray_job = None


def point_pixels(mapper, points_xy, origin_xy):
    """End pixels of the obstacle points ``points_xy`` (see
    :meth:`IncrementalMapper.add_points`): ``(er, ec, ext, sensor, n, where)`` with the
    pixels of the finite points (int64; those at ``max_range_m`` or farther from
    ``origin_xy`` dropped), their extent (min row, max row, min col, max col) and the
    pixel of ``origin_xy`` (None without it), the number of points given, and what a
    refusal of their extent names (a callable giving a :class:`Subject`, see
    :func:`_blamed`).

    Raises
    ------
    TypeError
        If ``points_xy`` is not an array of real numbers, ``origin_xy`` not two numbers.
    ValueError
        If ``points_xy`` is not of shape (N, 2), ``origin_xy`` not two finite numbers, or
        the points lie beyond 2^30 pixels.
    """
    pts = point_rows("points_xy", points_xy)
    keep = np.isfinite(pts).all(axis=1)
    sensor = None
    if origin_xy is not None:
        origin = finite_pair("origin_xy", origin_xy, "(x, y) in metres")
        x, y = (float(v) for v in origin)
        n = mapper._n_scans
        sensor = sensor_pixel(
            mapper, x, y, lambda: Subject(f"origin_xy: the points (scan {n})", scan=n)
        )
        if mapper.max_range_m is not None:
            # A scan's reading at exactly max_range_m is dropped; its end point, made
            # from the range and rounded, lies a rounding step either side of it.
            # Within a few steps (relative to the coordinates' size) a point counts
            # as at the limit, so a scan's end points are dropped as the scan is.
            slack = 16 * np.finfo(np.float64).eps
            scale = np.abs(pts).sum(axis=1) + np.abs(origin).sum() + mapper.max_range_m
            with np.errstate(invalid="ignore"):
                keep &= np.hypot(*(pts - origin).T) < mapper.max_range_m - slack * scale
    used = pts[keep]
    if used.shape[0] and np.abs(used).max() / mapper.resolution_m > _MAX_ABS_PIXEL:
        raise refusal(
            lambda: _points_subject("points_xy", mapper._n_scans),
            f" put pixels beyond {_MAX_ABS_PIXEL} px from the origin "
            f"at resolution {mapper.resolution_m} m (largest coordinate "
            f"{np.abs(used).max():g}); nothing was added (expected coordinates in metres)",
            "max_abs_pixel",
        )
    er, ec = mapper.world_to_pixel(used[:, 0], used[:, 1])
    name = "points_xy"
    if er.shape[0]:
        ext = np.array([er.min(), er.max(), ec.min(), ec.max()], np.int64)
        if sensor is not None:
            name = _blamed(mapper, ext, sensor)
    else:
        ext = np.zeros(4, np.int64)
    n = mapper._n_scans
    return er, ec, ext, sensor, pts.shape[0], lambda: _points_subject(name, n)


def _blamed(mapper, ext, sensor) -> str:
    """Which of ``points_xy`` and ``origin_xy`` a refusal of points of extent ``ext`` (min
    row, max row, min col, max col) with their origin's pixel ``sensor`` names:
    ``points_xy`` if the points alone grow the map beyond the mapper's limits (raised here,
    :func:`check_growth`), else whichever lies farther from the mapped area (pixel (0, 0)
    before any): an origin far out with points near names ``origin_xy``."""
    n = mapper._n_scans
    w = mapper._half + HALO_PX
    r0, r1, c0, c1 = ext.tolist()
    check_growth(mapper, r0 - w, r1 + w, c0 - w, c1 + w, lambda: _points_subject("points_xy", n))
    bbox = mapper._tiles.pixel_bbox
    mid_r, mid_c = (0, 0) if bbox is None else ((bbox[0] + bbox[2]) // 2, (bbox[1] + bbox[3]) // 2)
    points_far = max(abs(r0 - mid_r), abs(r1 - mid_r), abs(c0 - mid_c), abs(c1 - mid_c))
    sr, sc = sensor
    return "origin_xy" if max(abs(sr - mid_r), abs(sc - mid_c)) > points_far else "points_xy"


def _points_subject(name: str, n: int) -> Subject:
    """The subject of a refusal of the points of scan ``n`` that names ``name``."""
    return Subject(f"{name}: the points (scan {n})", scan=n)


def _mask_tiles(mask, r0: int, c0: int, t: int) -> np.ndarray:
    """The global tiles (int64 (n, 2)) holding a True pixel of ``mask``, whose pixel
    (0, 0) is global ``(r0, c0)``: reduced a tile row and column at a time, without the
    pixels' indices (16 bytes a pixel)."""
    h, w = mask.shape
    rows = np.unique(np.r_[0, np.arange((-r0) % t, h, t)])  # first map row of each tile row
    cols = np.unique(np.r_[0, np.arange((-c0) % t, w, t)])
    held = np.logical_or.reduceat(np.logical_or.reduceat(mask, rows, axis=0), cols, axis=1)
    i, j = np.nonzero(held)
    return np.stack([(r0 + rows[i]) // t, (c0 + cols[j]) // t], axis=1).astype(np.int64)


def _map_tiles(mapper, occupied, free, r0: int, c0: int) -> int:
    """How many tiles an imported map allocates: those of its known pixels (``occupied``,
    and ``free`` unless None, masks of the map whose pixel (0, 0) is global ``(r0, c0)``)
    and those the splat windows round its occupied pixels reach."""
    t = mapper.tile_px
    k = -(-(mapper._half + HALO_PX) // t)  # tiles a window reaches beyond its pixel's
    held = _mask_tiles(occupied, r0, c0, t)
    near = np.arange(-k, k + 1)
    dr, dc = np.repeat(near, near.size), np.tile(near, near.size)
    rows, cols = [(held[:, :1] + dr).ravel()], [(held[:, 1:] + dc).ravel()]
    if free is not None:
        held = _mask_tiles(free, r0, c0, t)
        rows.append(held[:, 0])
        cols.append(held[:, 1])
    known = unique_pairs(np.concatenate(rows), np.concatenate(cols))
    return int((mapper._tiles.lookup(known[:, 0], known[:, 1]) < 0).sum())


def add_occupancy(mapper, occupancy) -> int:
    """The body of :meth:`IncrementalMapper.add_map`: the occupied pixels of
    ``occupancy`` as hits, its free pixels as free cells; returns the number of new
    obstacle pixels.  Raises TypeError / ValueError (before any change) as that method
    says."""
    from ..maps import map_argument

    occupancy = map_argument("occupancy", occupancy)
    check_whole(mapper, "add a map")
    if not math.isclose(occupancy.resolution_m, mapper.resolution_m, rel_tol=1e-9):
        raise ValueError(
            f"occupancy: expected the mapper's resolution {mapper.resolution_m} m, "
            f"received a map of {occupancy.resolution_m} m per pixel; resample it first"
        )
    if occupancy.origin[2] != 0.0:
        raise ValueError(
            f"occupancy: expected a map without yaw (origin yaw 0), received yaw "
            f"{occupancy.origin[2]} rad"
        )
    # the map's pixel (0, 0) and the shift that takes its pixels onto the mapper's
    x0, y0 = occupancy.pixel_to_world(0, 0)
    r0, c0 = (int(v) for v in mapper.world_to_pixel(x0, y0))
    h, w = occupancy.shape
    half = mapper._half + HALO_PX
    free = occupancy.free if mapper.free_space else None
    if occupancy.occupied.any() or (free is not None and free.any()):
        lo_r, hi_r, lo_c, hi_c = r0 - half, r0 + h + half, c0 - half, c0 + w + half
        # the whole map and its splat windows, before anything changes (or the pixels'
        # indices, 16 bytes a pixel, are taken)
        where = lambda: Subject(f"occupancy: the map at {occupancy.origin}")  # noqa: E731
        check_growth(mapper, lo_r, hi_r, lo_c, hi_c, where)
        check_tile_budget(mapper, _map_tiles(mapper, occupancy.occupied, free, r0, c0), where)
    rows, cols = np.nonzero(occupancy.occupied)
    free_rows, free_cols = np.nonzero(free) if free is not None else ((), ())
    er = rows.astype(np.int64) + r0
    ec = cols.astype(np.int64) + c0
    ext = (
        np.array([er.min(), er.max(), ec.min(), ec.max()], np.int64)
        if er.shape[0]
        else np.zeros(4, np.int64)
    )
    with changing(mapper, "adding a map"):
        return _add_map_pixels(mapper, er, ec, ext, free_rows, free_cols, r0, c0)


def _add_map_pixels(mapper, er, ec, ext, free_rows, free_cols, r0: int, c0: int) -> int:
    """The changes of :func:`add_occupancy`: the map's occupied pixels ``(er, ec)``
    (global, extent ``ext``) as hits and its free pixels (``free_rows``, ``free_cols``
    of the map, whose pixel (0, 0) is global ``(r0, c0)``) as free cells."""
    t = mapper.tile_px
    where = lambda: Subject("occupancy: the map")  # noqa: E731
    n_new = integrate_end_pixels(mapper, er, ec, ext, None, where=where)
    if len(free_rows):
        fr = free_rows.astype(np.int64) + r0
        fc = free_cols.astype(np.int64) + c0
        tsh = _log2(t)
        tiles_needed = unique_pairs(fr >> tsh, fc >> tsh)
        tiles = mapper._tiles
        tiles.ensure(tiles_needed[:, 0], tiles_needed[:, 1])
        grid, (g0r, g0c) = tiles.slot_grid
        _count_cells(fr, fc, t, grid, g0r, g0c, tiles.layer("misses"))
        mapper._export_cache.clear()
    return n_new
