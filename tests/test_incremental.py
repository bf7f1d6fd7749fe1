"""Incremental mapper: exact equivalence with the full-map pipeline, state, bad input.

References: :func:`topojax.pipeline.dense_fields` / :func:`topojax.build_graph` run on the
mapper's exported occupancy map (the full-map pipeline, itself tested against float64
NumPy, OpenCV and scikit-image), and a float64 NumPy brute-force windowed distance.
Tolerances: squared distances exact (integers), distance map 1e-6, ridges / skeleton /
graph identical (graph compared as multisets of vertex (pixel, kind) and of
orientation-normalised edge paths).
"""

from __future__ import annotations

import gzip
import json
import math
import os
import re
from collections import Counter

import networkx as nx
import numpy as np
import pytest
from brute_force import brute_sq_distance
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import topojax as tj
from topojax.config import DistanceConfig, GraphConfig, PipelineConfig
from topojax.datasets import sample_map
from topojax.fields.distance import FAR_SQ
from topojax.fields.tiling import TileManager
from topojax.graph import prune_graph
from topojax.incremental import (
    STATE_FORMAT,
    STATE_VERSION,
    ExtentError,
    GraphUpdate,
    IncrementalMapper,
    ScanReport,
    timing_summary,
    trace_counts,
    vertex_error_metrics,
)
from topojax.io import load_graph
from topojax.maps import OccupancyMap, load_map
from topojax.pipeline import build_graph, dense_fields
from topojax.playback import replay
from topojax.scans import Scan, read_carmen

DATA = __import__("pathlib").Path(__file__).parent / "data"
INTEL_EXCERPT = DATA / "intel_first40.log.gz"

# A small configuration for synthetic worlds: many tiles and blocks, short kernels.
SMALL = DistanceConfig(sigma_px=4.0, half_width_px=10)
SMALL_KW = {"resolution_m": 0.1, "distance": SMALL, "tile_px": 16, "block_px": 8}


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------


def path_key(path) -> bytes:
    """An edge path's key, the same in either direction."""
    p = np.ascontiguousarray(path, np.int64)
    return min(p.tobytes(), p[::-1].copy().tobytes())


def canon(graph: nx.MultiGraph):
    """Graph up to ids: multiset of (pixel, kind) and of orientation-free edge paths."""
    verts = Counter(
        (tuple(int(v) for v in d["pixel"]), d["kind"]) for _, d in graph.nodes(data=True)
    )
    edges = Counter()
    for *_, p in graph.edges(data="path"):
        edges[path_key(p)] += 1
    return verts, edges


def assert_matches_full_map(mapper: IncrementalMapper, config: PipelineConfig | None = None):
    """The mapper (brought up to date) equals the full-map pipeline on its exported map."""
    config = config or PipelineConfig(distance=mapper.config.distance)
    mapper.update_graph()
    occ = mapper.occupancy
    ref = build_graph(occ, config=config)
    fields = dense_fields(occ.occupied, distance=config.distance, ridge=config.ridge, tile_px=64)
    np.testing.assert_array_equal(mapper.sq_distance_px, fields.sq_distance_px)
    np.testing.assert_allclose(mapper.distance, ref.distance, atol=1e-6, rtol=0)
    np.testing.assert_array_equal(mapper.ridges, ref.ridges)
    np.testing.assert_array_equal(mapper.lap_abs, ref.lap_abs)
    np.testing.assert_array_equal(mapper.skeleton, ref.skeleton)
    if mapper.strategy == "exact":  # the state behind the local re-thinning
        times = thin_times_reference(ref.ridges, config.skeleton.thinning)
        np.testing.assert_array_equal(mapper._dense("thin_time"), times)
    assert_graph_is_the_dense_export(mapper)  # read from the tiles, bit for bit
    gv, ge = canon(mapper.graph)
    rv, re_ = canon(ref.graph)
    assert gv == rv
    assert ge == re_
    # ... with the same clearances (read at the vertex and path pixels only)
    ref_v = {tuple(d["pixel"]): d["clearance_m"] for _, d in ref.graph.nodes(data=True)}
    for _, d in mapper.graph.nodes(data=True):
        assert d["clearance_m"] == pytest.approx(ref_v[tuple(d["pixel"])], rel=1e-6)
    ref_e = {path_key(d["path"]): d for *_, d in ref.graph.edges(data=True)}
    for *_, d in mapper.graph.edges(data=True):
        r = ref_e[path_key(d["path"])]
        assert d["length_m"] == r["length_m"]  # the same integer step counts, bit for bit
        assert d["min_clearance_m"] == pytest.approx(r["min_clearance_m"], rel=1e-6)
        assert d["mean_clearance_m"] == pytest.approx(r["mean_clearance_m"], rel=1e-6)
    # The exported result's clearance map is the full-map one everywhere (pixels beyond R
    # come from OpenCV's float32 transform, which differs by 1 ulp from call to call).
    got = mapper.to_result(update=False).clearance_px
    np.testing.assert_allclose(got, ref.clearance_px, rtol=1e-6, atol=0)
    return ref


def room_world(rng: np.random.Generator, n_walls: int = 6) -> np.ndarray:
    """Segments (n, 4) = (x0, y0, x1, y1) metres: a 6 m x 4 m room around the origin with
    a few random inner walls (so the map extends into negative coordinates)."""
    segs = [(-3, -2, 3, -2), (3, -2, 3, 2), (3, 2, -3, 2), (-3, 2, -3, -2)]
    for _ in range(n_walls):
        x, y = rng.uniform(-2.6, 2.6), rng.uniform(-1.6, 1.6)
        if rng.random() < 0.5:
            segs.append((x, y, x + rng.uniform(0.3, 1.5), y))
        else:
            segs.append((x, y, x, y + rng.uniform(0.3, 1.2)))
    return np.asarray(segs, np.float64)


def cast(world: np.ndarray, pose, n_beams: int, fov: float, max_range: float) -> np.ndarray:
    """Exact ranges of a fan of beams against the segments (inf where nothing is hit)."""
    x, y, yaw = pose
    ang = yaw - fov / 2 + np.arange(n_beams) * fov / (n_beams - 1)
    dx, dy = np.cos(ang)[:, None], np.sin(ang)[:, None]
    x0, y0, x1, y1 = (world[:, k][None, :] for k in range(4))
    ex, ey = x1 - x0, y1 - y0
    den = dx * ey - dy * ex
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((x0 - x) * ey - (y0 - y) * ex) / den
        u = ((x0 - x) * dy - (y0 - y) * dx) / den
    ok = (np.abs(den) > 1e-12) & (t > 1e-9) & (u >= 0) & (u <= 1)
    r = np.where(ok, t, np.inf).min(axis=1)
    return np.where(r < max_range, r, max_range)


def synthetic_scans(seed: int, n: int, *, bad: bool = True) -> list[Scan]:
    rng = np.random.default_rng(seed)
    world = room_world(rng)
    scans = []
    fov = math.radians(270)
    for _ in range(n):
        pose = (rng.uniform(-2.5, 2.5), rng.uniform(-1.5, 1.5), rng.uniform(-np.pi, np.pi))
        r = cast(world, pose, 90, fov, 8.0) + rng.normal(0, 0.02, 90)
        if bad:
            k = rng.integers(0, 90, 6)
            r[k[0]] = np.nan
            r[k[1]] = np.inf
            r[k[2]] = -1.0
            r[k[3]] = 8.0  # max range
            r[k[4]] = 0.0
        scans.append(
            Scan.from_arrays(r, pose, angle_min=-fov / 2, angle_increment=fov / 89, range_max=8.0)
        )
    return scans


# --------------------------------------------------------------------------------------
# TileManager
# --------------------------------------------------------------------------------------


def test_tile_manager_allocates_in_every_direction_and_round_trips():
    tm = TileManager(
        tile_px=8, layers={"a": (np.int32, -1), "s": (np.uint8, 0, (2, 3))}, loops=("x",)
    )
    assert tm.n_tiles == 0 and tm.pixel_bbox is None
    slots, n_new = tm.ensure(np.array([0, -3, 0, 5]), np.array([0, 2, 0, -7]))
    assert n_new == 3 and slots[0] == slots[2]
    assert tm.tile_bbox == (-3, -7, 6, 3)
    assert tm.pixel_bbox == (-24, -56, 48, 24)
    assert (tm.lookup([-3, 1], [2, 1]) == [slots[1], -1]).all()
    assert set(tm.dirty("x").tolist()) == {0, 1, 2}
    tm.clear_dirty("x")
    win = np.arange(20 * 30, dtype=np.int32).reshape(20, 30)
    mask = np.zeros_like(win, bool)
    mask[:8, 2:10] = True  # pixels (-24..-17, -40..-33) lie in tile (-3, -5): not allocated
    with pytest.raises(ValueError, match="not allocated"):
        tm.write("a", -24, -42, win, mask)
    tm.write("a", -24, 16 - 30 + 8, win[:8], np.ones((8, 30), bool) & (np.arange(30) >= 22))
    back = tm.read("a", -24, 16 - 30 + 8, 8, 30)
    np.testing.assert_array_equal(back[:, 22:], win[:8, 22:])
    assert (back[:, :22] == -1).all()
    state = tm.state()
    tm2 = TileManager(
        tile_px=8, layers={"a": (np.int32, -1), "s": (np.uint8, 0, (2, 3))}, loops=("x",)
    )
    tm2.load_state(state)
    assert tm2.tile_bbox == tm.tile_bbox
    # a state of another layer or loop set is refused, naming the entry
    for layers, loops, word in (
        ({"a": (np.int32, -1)}, ("x",), "extra entry 'layer/s'"),
        ({"a": (np.int32, -1), "s": (np.uint8, 0, (2, 3)), "t": (bool, 0)}, ("x",), "'layer/t'"),
        ({"a": (np.int32, -1), "s": (np.uint8, 0, (2, 3))}, ("x", "y"), "lacks 'dirty/y'"),
    ):
        other = TileManager(tile_px=8, layers=layers, loops=loops)
        with pytest.raises(ValueError, match=word):
            other.load_state(state)
    for key in ("has_bbox", "bbox", "grid"):
        partial = {k: v for k, v in state.items() if k != key}
        with pytest.raises(ValueError, match=f"lacks '{key}'"):
            tm2.load_state(partial)
        assert tm2.tile_bbox == tm.tile_bbox  # unchanged
    np.testing.assert_array_equal(tm2.read("a", -30, -60, 90, 90), tm.read("a", -30, -60, 90, 90))
    nb = tm.neighbour_slots()
    assert nb.shape == (3, 9) and (nb[:, 4] == np.arange(3)).all()
    np.testing.assert_array_equal(tm2.neighbour_slots(), nb)
    # the cached table follows new tiles: tile (1, 0) is the south neighbour of (0, 0)
    (s_new,), _ = tm.ensure(np.array([1]), np.array([0]))
    nb = tm.neighbour_slots()
    assert nb.shape == (4, 9) and nb[slots[0], 7] == s_new and nb[s_new, 1] == slots[0]
    # new tiles hold each layer's fill, also across capacity growth and after a load
    for m in (tm, tm2):
        m.ensure(np.arange(40) // 8 + 10, np.arange(40) % 8)
        assert m.n_tiles >= 40
        new = m.lookup(np.arange(40) // 8 + 10, np.arange(40) % 8)
        assert (m.layer("a")[new] == -1).all() and (m.layer("s")[new] == 0).all()


def test_tile_storage_with_and_without_huge_pages(monkeypatch):
    """Mapped layers are zero and keep what is written, in huge pages or not, and where
    the kernel refuses huge pages (no transparent huge page support: OSError)."""
    import mmap

    from topojax.fields import tiling

    class Refusing(mmap.mmap):
        def madvise(self, *args):
            raise OSError(22, "Invalid argument")

    for huge, cls in ((True, mmap.mmap), (False, mmap.mmap), (True, Refusing)):
        monkeypatch.setattr(tiling, "HUGE_PAGES", huge)
        monkeypatch.setattr(tiling.mmap, "mmap", cls)
        a = tiling._storage(64, (128, 128), np.dtype(np.int32))  # 4 MiB: its own mapping
        assert a.shape == (64, 128, 128) and not a.any()
        a[10] = 5
        assert (a[10] == 5).all() and not a[11].any() and not a[:10].any()


@pytest.mark.parametrize("sizes", [(128, 1024), (64, 512), (3, 7)])
def test_batches_cover_the_rows_and_pad_at_most_max_padding(sizes):
    """Kernel batches are dispatched as views of arrays allocated with
    ``_max_padding`` spare rows: the bound must hold (and be reached)."""
    from topojax.incremental._tiles import _batches, _max_padding

    worst = 0
    for n in range(1, 3000):
        plan = list(_batches(n, sizes))
        assert plan[0][0] == 0 and all(
            a[1] == b[0] for a, b in zip(plan[:-1], plan[1:], strict=True)
        )
        assert plan[-1][1] == n and all(stop - start <= size for start, stop, size in plan)
        worst = max(worst, plan[-1][0] + plan[-1][2] - n)
    assert worst == _max_padding(sizes)


def test_tile_manager_growth_uses_storage_paged_in_ahead():
    from concurrent.futures import Future

    from topojax.fields.tiling import GROWTH_FACTOR

    jobs = []

    def submit(fn):  # runs the job at once, as a worker thread eventually would
        fut = Future()
        fn()
        fut.set_result(None)
        jobs.append(fut)
        return fut

    tm = TileManager(
        tile_px=128, layers={"d": (np.int32, 7), "h": (np.uint16, 0)}, initial_capacity=8
    )
    tm.ensure(np.arange(5), np.zeros(5))
    assert not tm.prepare_growth(submit) and not jobs  # 5 of 8: not yet
    tm.ensure(np.arange(6), np.zeros(6))
    tm.layer("h")[: tm.n_tiles] = np.arange(tm.n_tiles)[:, None, None]
    assert tm.prepare_growth(submit) and len(jobs) == 1
    assert not tm.prepare_growth(submit)  # one spare at a time
    tm.add_layer("late", np.int8, 3)  # added after the spare: allocated at the growth
    spare = tm._spare["d"]
    tm.ensure(np.arange(20), np.ones(20))  # past the capacity: grows into the spare
    assert tm.layer("d") is spare and tm.layer("d").shape[0] == 8 * GROWTH_FACTOR
    n = tm.n_tiles
    assert n == 26 and (tm.layer("d")[:n] == 7).all() and (tm.layer("late")[:n] == 3).all()
    np.testing.assert_array_equal(tm.layer("h")[:6, 0, 0], np.arange(6))
    assert (tm.layer("h")[6:n] == 0).all()
    assert tm.layer("d").flags.c_contiguous and tm.layer("d").flags.writeable


def test_tile_storage_reservation_and_its_fallback(monkeypatch):
    """A reserved capacity holds the tiles without growing; where the system refuses the
    reservation, the storage starts at ``initial_capacity`` and grows (also on load)."""
    import topojax.fields.tiling as tiling

    layers = {"d": (np.int32, 7), "h": (np.uint16, 0)}
    nbytes = 6 * 128 * 128  # one tile of both layers
    tm = TileManager(tile_px=128, layers=layers, initial_capacity=4, reserve_bytes=64 * nbytes)
    assert tm.tile_nbytes == nbytes
    d = tm.layer("d")
    assert d.shape[0] == 64
    tm.ensure(np.arange(40), np.zeros(40))
    assert tm.layer("d") is d and (d[:40] == 7).all()  # no growth, no copy

    real = tiling._storage
    refused = []

    def storage(capacity, shape, dt):
        if capacity > 16:
            refused.append(capacity)
            raise OSError(12, "Cannot allocate memory")
        return real(capacity, shape, dt)

    monkeypatch.setattr(tiling, "_storage", storage)
    tm2 = TileManager(tile_px=128, layers=layers, initial_capacity=4, reserve_bytes=64 * nbytes)
    assert refused == [64] and tm2.layer("d").shape[0] == 4
    tm2.ensure(np.arange(3), np.zeros(3))
    tm2.layer("h")[:3] = 5
    state = tm2.state()
    monkeypatch.setattr(tiling, "_storage", real)
    tm2.ensure(np.arange(10), np.ones(10))  # grows past 4
    assert tm2.n_tiles == 13 and (tm2.layer("d")[:13] == 7).all()
    np.testing.assert_array_equal(tm2.layer("h")[:3], 5)
    tm2.ensure(np.arange(20), np.full(20, 2))
    state20 = tm2.state()  # 33 tiles: more than a refused storage may hold
    # loading reserves too, and falls back the same way
    tm3 = TileManager(tile_px=128, layers=layers, initial_capacity=4, reserve_bytes=64 * nbytes)
    tm3.load_state(state)
    assert tm3.layer("d").shape[0] == 64 and tm3.n_tiles == 3
    monkeypatch.setattr(tiling, "_storage", storage)
    tm3.load_state(state)
    assert tm3.layer("d").shape[0] == 4 and tm3.n_tiles == 3
    np.testing.assert_array_equal(tm3.layer("h")[:3], 5)
    # a refusal of what is needed is an error, and leaves the tiles as they were
    with pytest.raises(OSError):
        tm3.load_state(state20)
    assert tm3.n_tiles == 3 and tm3.layer("d").shape[0] == 4


def test_mapper_storage_does_not_grow_in_a_replay():
    """The mapper reserves its tile storage (address space only): scans that allocate
    tiles far and wide never make it copy them into a larger storage."""
    m = IncrementalMapper()
    d = m.tiles.layer("sq_distance")
    if d.shape[0] * m.tiles.tile_nbytes < 1 << 33:
        pytest.skip("this system refused the storage reservation (strict overcommit?)")
    ranges = np.full(8, 5.0)
    for i in range(40):  # a robot jumping 30 m at a time: new tiles with every scan
        pose = (30.0 * (i % 7), 30.0 * (i // 7), 0.0)
        m.add_scan(Scan.from_arrays(ranges, angle_min=0.0, angle_increment=0.7, pose=pose))
    assert m.n_tiles > 100
    assert m.tiles.layer("sq_distance") is d


def test_tile_manager_late_layer_fills_existing_and_new_tiles():
    tm = TileManager(tile_px=8, layers={"a": (np.int32, 0)}, initial_capacity=4)
    tm.ensure(np.array([0, 1]), np.array([0, 0]))
    tm.add_layer("late", np.int16, 7)
    assert (tm.layer("late")[:2] == 7).all()
    tm.ensure(np.arange(10), np.full(10, 3))  # grows the capacity past 4
    assert (tm.layer("late")[: tm.n_tiles] == 7).all() and (tm.layer("a")[: tm.n_tiles] == 0).all()


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(-(1 << 20), 1 << 20), st.integers(-(1 << 20), 1 << 20)),
        min_size=1,
        max_size=40,
    )
)
def test_new_tiles_get_slots_in_row_major_order(pairs):
    from topojax.fields.tiling import unique_pairs

    rows = np.array([p[0] for p in pairs], np.int64)
    cols = np.array([p[1] for p in pairs], np.int64)
    want = np.unique(np.stack([rows, cols], axis=1), axis=0)
    got = unique_pairs(rows, cols)
    assert got.dtype == np.int64
    np.testing.assert_array_equal(got, want)


def test_tile_manager_extent_limit_changes_nothing():
    tm = TileManager(tile_px=8, layers={"a": (np.int32, 0)}, max_grid_cells=100)
    tm.ensure([0], [0])
    with pytest.raises(ValueError, match="max_grid_cells"):
        tm.ensure([0, 50], [0, 50])
    assert tm.n_tiles == 1 and tm.tile_bbox == (0, 0, 1, 1)
    with pytest.raises(ValueError, match="tile_px: expected an int >= 4, received 2"):
        TileManager(tile_px=2, layers={})
    for kwargs in ({"tile_px": 8.0}, {"tile_px": True}, {"tile_px": 8, "max_grid_cells": 1e6}):
        with pytest.raises(TypeError, match="^(tile_px|max_grid_cells): expected an int >= "):
            TileManager(layers={}, **kwargs)
    assert TileManager(tile_px=np.int64(8), layers={}, max_grid_cells=np.int32(9)).tile_px == 8


def test_max_grid_cells_is_refused_where_a_saved_state_cannot_hold_it(tmp_path):
    """The saved state stores ``max_grid_cells`` as an int64: a larger one is refused
    when the mapper is made, not by its first save once scans are mapped."""
    top = int(np.iinfo(np.int64).max)
    with pytest.raises(
        ValueError, match=f"max_grid_cells: expected .* <= {top}, received {top + 1}"
    ):
        IncrementalMapper(max_grid_cells=top + 1)
    path = IncrementalMapper(max_grid_cells=top).save(tmp_path / "state.npz")
    assert IncrementalMapper.load(path).tiles.max_grid_cells == top


# --------------------------------------------------------------------------------------
# Distance loop
# --------------------------------------------------------------------------------------


def test_gaussian_table_is_the_full_map_gaussian_bit_for_bit():
    """The ridge kernel reads H from a table by squared distance: every entry equals the
    full-map pipeline's H, and the ridges equal those computed with the exponential."""
    from topojax.incremental import _ridges as inc

    ref = build_graph(sample_map("intel"))
    dist = ref.config.distance
    table = np.asarray(inc.gaussian_table(dist.sigma_px, dist.half_width_px))
    assert table.shape == (2 * dist.half_width_px**2 + 2,) and table[-1] == 0.0
    d2 = np.asarray(ref.sq_distance_px)
    np.testing.assert_array_equal(table[np.minimum(d2, table.shape[0] - 1)], ref.distance)
    rng = np.random.default_rng(5)
    patches = rng.integers(0, 2 * dist.half_width_px**2 + 1, (64, 20, 20)).astype(np.int32)
    patches[:8] = rng.integers(0, 3000, (8, 20, 20))
    patches[rng.random(patches.shape) < 0.05] = FAR_SQ
    scalars = (np.float32(10.0), np.float32(10.0))
    by_exp = inc._ridge_blocks(patches, np.float32(dist.sigma_px), *scalars, ksize=5)
    by_table = inc._ridge_blocks(patches, table, *scalars, ksize=5)
    for a, b in zip(by_exp, by_table, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 12), eager=st.booleans())
def test_distance_equals_full_map_on_random_scans(seed, n, eager):
    mapper = IncrementalMapper(
        skeleton_every=0, graph_every=0, max_pending_points=0 if eager else 4096, **SMALL_KW
    )
    for scan in synthetic_scans(seed, n):
        mapper.add_scan(scan)
    occ = mapper.occupancy
    d2 = mapper.sq_distance_px
    ref = dense_fields(occ.occupied, distance=SMALL, tile_px=32)
    np.testing.assert_array_equal(d2, ref.sq_distance_px)
    np.testing.assert_allclose(mapper.distance, ref.distance, atol=1e-6, rtol=0)
    # independent float64 brute force on a crop around the obstacles
    rows, cols = np.nonzero(occ.occupied)
    r0, c0 = max(rows.min() - 12, 0), max(cols.min() - 12, 0)
    crop = occ.occupied[r0 : rows.max() + 13, c0 : cols.max() + 13]
    brute = brute_sq_distance(crop, SMALL.half_width_px)
    got = d2[r0 : r0 + crop.shape[0], c0 : c0 + crop.shape[1]].astype(np.float64)
    got[got >= FAR_SQ] = np.inf
    np.testing.assert_array_equal(got, brute)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_batch_bound_holds_after_the_splat(seed):
    """The bound the batch's own points put on each block's largest squared distance
    (used to prune the splat's pairs) is never below the block's true maximum after the
    splat, and it does lower some blocks."""
    from topojax.incremental import _splat as inc

    mapper = IncrementalMapper(
        skeleton_every=0,
        graph_every=0,
        max_pending_points=1 << 20,
        resolution_m=0.1,
        distance=DistanceConfig(sigma_px=12.0, half_width_px=40),
        tile_px=32,
        block_px=8,
    )
    lowered = 0
    for scan in synthetic_scans(seed, 6, bad=False):
        mapper.add_scan(scan)
        if not mapper._pending:
            continue
        pts = np.concatenate(mapper._pending)
        tiles = mapper._tiles
        grid, (g0r, g0c) = tiles.slot_grid
        bmax = tiles.layer("block_max")
        bound, rowmax = inc._batch_bound(
            np.ascontiguousarray(pts[:, 0]),
            np.ascontiguousarray(pts[:, 1]),
            grid,
            g0r,
            g0c,
            32,
            8,
            40,
            bmax,
            tiles.n_tiles,
        )
        np.testing.assert_array_equal(rowmax, bound.max(axis=2))
        lowered += int((bound < bmax[: tiles.n_tiles]).sum())
        mapper._flush_splat()
        after = tiles.layer("block_max")[: tiles.n_tiles]
        assert (after <= bound).all()
    assert lowered > 0


def test_bad_readings_are_dropped_and_counted():
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, **SMALL_KW)
    r = np.array([1.0, np.nan, np.inf, -np.inf, -1.0, 0.0, 0.05, 5.0, 7.0, 1.5])
    scan = Scan.from_arrays(
        r, (0.0, 0.0, 0.0), angle_min=0.0, angle_increment=0.1, range_min=0.1, range_max=5.0
    )
    rep = mapper.add_scan(scan)
    assert isinstance(rep, ScanReport)
    assert (rep.n_beams, rep.n_valid, rep.n_dropped) == (10, 2, 8)
    assert rep.n_new_obstacles == 2 and rep.index == 0
    assert mapper.obstacles.sum() == 2
    # the two hits, at 1.0 m and 1.5 m along beams 0 and 9
    occ = mapper.occupancy
    rows, cols = np.nonzero(occ.occupied)
    x, y = occ.pixel_to_world(rows, cols)
    expect = np.array([[1.0, 0.0], [1.5 * math.cos(0.9), 1.5 * math.sin(0.9)]])
    got = np.stack([x, y], axis=1)
    for e in expect:
        assert np.min(np.abs(got - e).max(axis=1)) <= 0.05 + 1e-9
    # max_range_m drops more
    m2 = IncrementalMapper(skeleton_every=0, graph_every=0, max_range_m=1.2, **SMALL_KW)
    assert m2.add_scan(scan).n_valid == 1


def test_free_cells_follow_each_beam_and_batching_changes_nothing():
    # one scan, three beams: every beam marks max(|dr|, |dc|) cells (Bresenham, end
    # excluded), all within half a pixel diagonal of the beam's centre line
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, **SMALL_KW)
    ranges = np.full(5, np.inf)
    ranges[[0, 2, 4]] = [2.3, 1.7, 3.1]
    scan = Scan.from_arrays(
        ranges,
        (0.02, -0.03, 0.0),
        angle_min=0.3,
        angle_increment=0.95,
        range_min=0.1,
        range_max=5.0,
    )
    angles = 0.3 + 0.95 * np.array([0, 2, 4])
    mapper.add_scan(scan)
    occ = mapper.occupancy
    counts = mapper._dense("misses")
    res = 0.1
    r0, c0, _, _ = mapper.pixel_bbox
    sr, sc = math.floor(0.03 / res) - r0, math.floor(0.02 / res) - c0
    ends = [
        (
            math.floor(-(-0.03 + r * math.sin(a)) / res) - r0,
            math.floor((0.02 + r * math.cos(a)) / res) - c0,
        )
        for r, a in zip([2.3, 1.7, 3.1], angles, strict=True)
    ]
    assert counts.sum() == sum(max(abs(er - sr), abs(ec - sc)) for er, ec in ends)
    assert counts[sr, sc] == 3
    for rr, cc in zip(*np.nonzero(counts), strict=True):
        near = []
        for er, ec in ends:
            d = np.array([er - sr, ec - sc], float)
            p = np.array([rr - sr, cc - sc], float)
            u = np.clip(p @ d / (d @ d), 0.0, 1.0)
            near.append(np.hypot(*(p - u * d)))
        assert min(near) <= math.sqrt(0.5) + 1e-9
    assert not (occ.free & occ.occupied).any()
    # counting the free cells at every scan or in batches (at skeleton updates, on the
    # worker thread, or when read) gives the same counts
    scans = list(read_carmen(INTEL_EXCERPT))[:33]
    every = IncrementalMapper(skeleton_every=1, graph_every=0)
    batched = IncrementalMapper(skeleton_every=20, graph_every=0)
    for s in scans:
        every.add_scan(s)
        batched.add_scan(s)
    assert batched._n_rays > 0  # 13 scans not counted yet
    np.testing.assert_array_equal(
        every._dense("misses"), batched.tiles.read("misses", *_box(batched))
    )
    np.testing.assert_array_equal(every.occupancy.free, batched.occupancy.free)
    assert batched._n_rays == 0


def _box(mapper):
    r0, c0, r1, c1 = mapper.pixel_bbox
    return r0, c0, r1 - r0, c1 - c0


def test_empty_scan_is_a_counted_no_op():
    mapper = IncrementalMapper(skeleton_every=2, graph_every=0, **SMALL_KW)
    empty = Scan.from_arrays(np.full(5, np.nan), (1.0, 2.0, 0.0), angle_min=0, angle_increment=0.1)
    rep = mapper.add_scan(empty)
    assert (rep.n_valid, rep.n_new_obstacles, rep.n_tiles) == (0, 0, 0)
    rep = mapper.add_scan(Scan.from_arrays(np.zeros(0), (0, 0, 0), angle_min=0, angle_increment=1))
    assert rep.index == 1 and "skeleton" in rep.loops and mapper.n_scans == 2
    with pytest.raises(ValueError, match="empty"):
        _ = mapper.occupancy
    assert mapper.graph.number_of_nodes() == 0


def test_bad_input_raises_before_any_change():
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, max_grid_cells=400, **SMALL_KW)
    scans = synthetic_scans(3, 4, bad=False)
    mapper.add_scan(scans[0])
    before = {k: v.copy() for k, v in mapper.tiles.state().items()}
    with pytest.raises(TypeError, match="Scan"):
        mapper.add_scan({"ranges": [1.0]})
    with pytest.raises(TypeError, match="Scan"):
        mapper.add_scan(np.ones(10))
    with pytest.raises(ValueError, match="finite"):
        Scan.from_arrays(np.ones(3), (np.nan, 0, 0), angle_min=0, angle_increment=0.1)
    with pytest.raises(ValueError, match="beyond"):
        mapper.add_scan(
            Scan.from_arrays(np.ones(3), (1e300, 0, 0), angle_min=0, angle_increment=0.1)
        )
    far = Scan.from_arrays(np.ones(3), (500.0, 0.0, 0.0), angle_min=0, angle_increment=0.1)
    with pytest.raises(ValueError, match="max_grid_cells"):
        mapper.add_scan(far)
    after = mapper.tiles.state()
    assert before.keys() == after.keys()
    for k in before:
        np.testing.assert_array_equal(before[k], after[k], err_msg=k)
    assert mapper.n_scans == 1
    for scan in scans[1:]:  # still works, still exact
        mapper.add_scan(scan)
    assert_matches_full_map(mapper)


def _state(mapper: IncrementalMapper) -> dict[str, np.ndarray]:
    mapper.update_graph()
    occ = mapper.occupancy
    return {
        "bbox": np.asarray(mapper.pixel_bbox),
        "occupied": occ.occupied,
        "free": occ.free,
        "sq_distance": mapper.sq_distance_px,
        "skeleton": mapper.skeleton,
    }


@pytest.mark.parametrize("max_range_m", [None, 3.0])
def test_points_with_their_origin_are_the_scan_they_came_from(max_range_m):
    """A scan's end points in the map frame, with the sensor position as origin, change
    the mapper exactly as the scan does: obstacles, free space, distances, skeleton,
    graph, reports and loop schedule."""
    scans = synthetic_scans(7, 9)
    kw = {"skeleton_every": 3, "graph_every": 6, "max_range_m": max_range_m, **SMALL_KW}
    a, b = IncrementalMapper(**kw), IncrementalMapper(**kw)
    for scan in scans:
        ra = a.add_scan(scan)
        if max_range_m is None:
            points = scan.endpoints_world()
        else:  # the scan's readings at max_range_m or beyond are dropped: keep them in
            # the points too, so the mapper must drop them by their distance to the origin
            r = np.where(np.isfinite(scan.ranges) & (scan.ranges > 0), scan.ranges, np.nan)
            sx, sy, syaw = scan.sensor_pose_world()
            ang = scan.angles() + syaw
            points = np.stack([sx + r * np.cos(ang), sy + r * np.sin(ang)], axis=1)
            points = points[np.isfinite(points).all(axis=1) & (r < scan.range_max)]
        origin = scan.sensor_pose_world()[:2]
        rb = b.add_points(points, origin_xy=origin)
        assert (rb.index, rb.n_new_obstacles, rb.loops, rb.n_tiles) == (
            ra.index,
            ra.n_new_obstacles,
            ra.loops,
            ra.n_tiles,
        )
        assert rb.n_valid == ra.n_valid
    sa, sb = _state(a), _state(b)
    assert sb["free"].sum() > 3 * sb["occupied"].sum()  # the rays cleared free space
    for k in sa:
        np.testing.assert_array_equal(sa[k], sb[k], err_msg=k)
    assert canon(a.graph) == canon(b.graph)
    assert_matches_full_map(b)


@pytest.mark.parametrize("seed", range(4))
def test_points_at_exactly_max_range_are_dropped_as_the_scan_drops_them(seed):
    """No-return readings sit exactly at the range limit; their end points, made from the
    range, come back a rounding step either side of it, and must be dropped as well."""
    rng = np.random.default_rng(seed)
    n = 360
    ranges = np.full(n, 3.0)
    ranges[rng.random(n) < 0.3] = rng.uniform(0.5, 2.9, size=1)[0]  # some real hits
    pose = (float(rng.uniform(-50, 50)), float(rng.uniform(-50, 50)), float(rng.uniform(-3, 3)))
    scan = Scan.from_arrays(
        ranges, pose, angle_min=-math.pi, angle_increment=2 * math.pi / n, range_max=30.0
    )
    kw = dict(resolution_m=0.05, max_range_m=3.0, skeleton_every=0, graph_every=0)
    a, b = IncrementalMapper(**kw), IncrementalMapper(**kw)
    ra = a.add_scan(scan)
    sx, sy, syaw = scan.sensor_pose_world()
    ang = scan.angles() + syaw
    points = np.stack([sx + ranges * np.cos(ang), sy + ranges * np.sin(ang)], axis=1)
    rb = b.add_points(points, origin_xy=(sx, sy))
    assert (rb.n_valid, rb.n_new_obstacles) == (ra.n_valid, ra.n_new_obstacles)
    np.testing.assert_array_equal(a.occupancy.occupied, b.occupancy.occupied)
    np.testing.assert_array_equal(a.occupancy.free, b.occupancy.free)


def test_points_without_origin_mark_obstacles_only():
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, **SMALL_KW)
    # two walls of a corridor, sampled every 5 cm, plus points that are not finite
    x = np.arange(-2.0, 2.0, 0.05)
    pts = np.concatenate([np.stack([x, np.full_like(x, y)], 1) for y in (0.5, -0.5)])
    bad = np.array([[np.nan, 0.0], [0.0, np.inf], [-np.inf, np.nan]])
    rep = mapper.add_points(np.concatenate([pts, bad]))
    assert (rep.n_beams, rep.n_valid, rep.n_dropped) == (len(pts) + 3, len(pts), 3)
    rows, cols = mapper.world_to_pixel(pts[:, 0], pts[:, 1])
    r0, c0, _, _ = mapper.pixel_bbox
    occ = mapper.occupancy
    want = np.zeros(occ.shape, bool)
    want[rows - r0, cols - c0] = True
    np.testing.assert_array_equal(occ.occupied, want)
    assert not occ.free.any()  # no rays without an origin
    ref = assert_matches_full_map(mapper)
    # the corridor's centre line is an edge of the graph, 0.5 m from both walls
    assert ref.graph.number_of_edges() > 0
    mid = max((d for *_, d in mapper.graph.edges(data=True)), key=lambda d: d["length_m"])
    assert mid["length_m"] > 2.5
    np.testing.assert_allclose(mid["world"][:, 1], -0.05, atol=1e-9)  # its pixels' centres
    # the same points again: nothing new, a counted scan
    rep = mapper.add_points(pts)
    assert rep.n_new_obstacles == 0 and rep.index == 1 and mapper.n_scans == 2


def test_numpy_numbers_are_numbers_for_the_mapper():
    kw = dict(skeleton_every=0, graph_every=0)
    a = IncrementalMapper(resolution_m=0.05, tile_px=64, block_px=16, max_range_m=20.0, **kw)
    b = IncrementalMapper(
        resolution_m=np.float64(0.05),
        tile_px=np.int64(64),
        block_px=np.int32(16),
        max_range_m=np.float32(20.0),
        max_pending_points=np.int64(4096),
        **kw,
    )
    scan = tj.Scan.from_arrays(
        np.full(31, 2.0),
        angle_min=np.array(-0.5),
        angle_increment=np.float32(1 / 30),
        pose=(0.0, 0.0, 0.0),
    )
    assert type(scan.angle_min) is float and scan.angle_min == -0.5
    for m in (a, b):
        m.add_scan(scan)
    np.testing.assert_array_equal(a.occupancy.occupied, b.occupancy.occupied)
    # a float32 resolution is taken as the Python float of its value (not refused)
    c = IncrementalMapper(resolution_m=np.float32(0.05), **kw)
    assert type(c.resolution_m) is float and c.resolution_m == float(np.float32(0.05))


def test_bad_points_raise_before_any_change():
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, max_grid_cells=400, **SMALL_KW)
    mapper.add_scan(synthetic_scans(3, 1, bad=False)[0])
    before = {k: v.copy() for k, v in mapper.tiles.state().items()}
    cases = [
        (np.ones((4, 3)), "points_xy: expected an .N, 2. array.*shape \\(4, 3\\)"),
        (np.ones(4), "points_xy: expected an .N, 2. array.*shape \\(4,\\)"),
        (np.array([[1e300, 0.0]]), r"points_xy: the points \(scan 1\) put pixels beyond"),
        (np.array([[500.0, 0.0]]), "max_grid_cells"),
    ]
    for points, message in cases:
        with pytest.raises(ValueError, match=message):
            mapper.add_points(points)
    for origin in ((0.0,), (np.nan, 0.0)):
        with pytest.raises(ValueError, match="origin_xy: expected two finite numbers"):
            mapper.add_points(np.zeros((1, 2)), origin_xy=origin)
    with pytest.raises(TypeError, match="origin_xy: expected two finite numbers"):
        mapper.add_points(np.zeros((1, 2)), origin_xy="here")
    after = mapper.tiles.state()
    for k in before:
        np.testing.assert_array_equal(before[k], after[k], err_msg=k)
    assert mapper.n_scans == 1


def test_scans_and_reads_from_two_threads(tmp_path):
    """A scan callback and a reader (graph, occupancy, result, saved state) on another
    thread, as in a ROS node: the mapper serialises them, the reader never fails, and
    the end state is the sequential one."""
    import threading

    scans = synthetic_scans(11, 40)
    kw = {"skeleton_every": 4, "graph_every": 8, **SMALL_KW}
    mapper, sequential = IncrementalMapper(**kw), IncrementalMapper(**kw)
    for scan in scans:
        sequential.add_scan(scan)
    done = threading.Event()
    errors: list[BaseException] = []
    reads = [0]

    def reader():
        try:
            while not done.is_set():
                if mapper.n_scans:
                    g = mapper.graph
                    assert all("path" in d for *_, d in g.edges(data=True))
                    occ = mapper.occupancy
                    assert occ.occupied.shape == occ.free.shape
                    res = mapper.to_result(update=False)
                    assert res.skeleton.shape == res.ridges.shape
                    mapper.save(tmp_path / "state.npz")
                    reads[0] += 1
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    thread = threading.Thread(target=reader)
    thread.start()
    try:
        for scan in scans:
            mapper.add_scan(scan)
            mapper.add_points(scan.endpoints_world()[:5])  # repeats: no new obstacles
    finally:
        done.set()
        thread.join()
    assert not errors, errors[0]
    assert reads[0] > 0
    loaded = IncrementalMapper.load(tmp_path / "state.npz")
    assert loaded.n_scans <= mapper.n_scans == 2 * len(scans)
    for name in ("obstacles", "sq_distance_px"):
        np.testing.assert_array_equal(getattr(mapper, name), getattr(sequential, name))
    sequential.update_graph()
    assert canon(mapper.graph) == canon(sequential.graph)


def test_a_finished_map_seeds_the_mapper_and_scans_continue_on_it():
    """add_map puts a map's occupied and free pixels one to one on the mapper's lattice
    (any origin, here not a multiple of the resolution); the mapper then equals the
    full-map pipeline on its map, before and after more scans."""
    rng = np.random.default_rng(4)
    occupied = np.zeros((70, 90), bool)
    occupied[[0, -1], :] = occupied[:, [0, -1]] = True
    occupied[20:50, 40] = True
    occupied[rng.random(occupied.shape) < 0.01] = True
    unknown = np.zeros_like(occupied)
    unknown[:, 70:] = True
    unknown &= ~occupied
    prior = OccupancyMap(
        occupied=occupied,
        free=~occupied & ~unknown,
        unknown=unknown,
        resolution_m=0.1,
        origin=(-3.03, -2.47, 0.0),
    )
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, **SMALL_KW)
    assert mapper.add_map(prior) == occupied.sum()
    assert mapper.n_scans == 0
    occ = mapper.occupancy
    r0, c0 = (int(v) for v in mapper.world_to_pixel(*prior.pixel_to_world(0, 0)))
    br0, bc0, _, _ = mapper.pixel_bbox
    inside = (slice(r0 - br0, r0 - br0 + 70), slice(c0 - bc0, c0 - bc0 + 90))
    np.testing.assert_array_equal(occ.occupied[inside], prior.occupied)
    np.testing.assert_array_equal(occ.free[inside], prior.free)
    assert occ.occupied.sum() == prior.occupied.sum() and occ.free.sum() == prior.free.sum()
    # each pixel went to the mapper pixel that holds its centre: one shift for all,
    # under half a pixel in each axis
    rows, cols = np.nonzero(prior.occupied)
    got = np.stack(occ.pixel_to_world(rows + r0 - br0, cols + c0 - bc0))
    shift = got - np.stack(prior.pixel_to_world(rows, cols))
    np.testing.assert_allclose(shift, shift[:, :1] * np.ones_like(shift), atol=1e-9)
    np.testing.assert_allclose(shift[:, 0], (0.03, -0.03), atol=1e-9)
    assert_matches_full_map(mapper)
    assert mapper.add_map(prior) == 0  # nothing new
    for scan in synthetic_scans(9, 6):
        mapper.add_scan(scan)
    assert_matches_full_map(mapper)
    no_free = IncrementalMapper(free_space=False, **SMALL_KW)
    no_free.add_map(prior)
    assert not no_free.occupancy.free.any()


def test_add_map_refuses_maps_it_cannot_place_and_changes_nothing():
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, max_grid_cells=400, **SMALL_KW)
    mapper.add_scan(synthetic_scans(3, 1, bad=False)[0])
    before = {k: v.copy() for k, v in mapper.tiles.state().items()}
    grid = np.zeros((20, 30), bool)
    grid[5, 5:25] = True
    base = OccupancyMap.from_array(grid, resolution_m=0.1)
    with pytest.raises(TypeError, match="occupancy: expected an OccupancyMap"):
        mapper.add_map(grid)
    with pytest.raises(ValueError, match="occupancy: expected the mapper's resolution 0.1 m"):
        mapper.add_map(OccupancyMap.from_array(grid, resolution_m=0.05))
    with pytest.raises(ValueError, match="without yaw"):
        mapper.add_map(OccupancyMap.from_array(grid, resolution_m=0.1, origin=(0, 0, 0.3)))
    with pytest.raises(ValueError, match="max_grid_cells"):
        mapper.add_map(OccupancyMap.from_array(grid, resolution_m=0.1, origin=(500.0, 0, 0)))
    after = mapper.tiles.state()
    for k in before:
        np.testing.assert_array_equal(before[k], after[k], err_msg=k)
    assert mapper.add_map(base) == 20


def test_constructor_validation():
    with pytest.raises(ValueError, match="strategy"):
        IncrementalMapper(strategy="fast")
    with pytest.raises(ValueError, match="resolution_m"):
        IncrementalMapper(resolution_m=0.0)
    with pytest.raises(ValueError, match="tile_px: expected a power of two.*received 24"):
        IncrementalMapper(tile_px=24, block_px=16)
    with pytest.raises(ValueError, match="block_px: expected a power of two.*received 12"):
        IncrementalMapper(tile_px=64, block_px=12)
    with pytest.raises(
        ValueError,
        match=r"tile_px, block_px: expected tile_px >= block_px .*, received tile_px=16, block_px=32",
    ):
        IncrementalMapper(tile_px=16, block_px=32)
    with pytest.raises(ValueError, match="skeleton_every"):
        IncrementalMapper(skeleton_every=-1)
    with pytest.raises(TypeError, match="graph_every"):
        IncrementalMapper(graph_every=2.5)
    with pytest.raises(TypeError, match="config"):
        IncrementalMapper(config="paper")
    with pytest.raises(ValueError, match="threshold: expected a finite number >= 0.*received -0.5"):
        from topojax.config import RidgeConfig

        IncrementalMapper(ridge=RidgeConfig(threshold=-0.5))
    with pytest.raises(ValueError, match="merge_junction_clusters"):
        IncrementalMapper(config=PipelineConfig(graph=GraphConfig(merge_junction_clusters=True)))
    m = IncrementalMapper(skeleton_every=None, graph_every=None)
    assert (m.skeleton_every, m.graph_every) == (0, 0)


def _resident_bytes() -> int:
    """Resident memory of this process (Linux ``/proc``; 0 elsewhere)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except OSError:
        return 0


def test_map_grows_in_negative_directions_and_far_jump_allocates_few_tiles():
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, **SMALL_KW)
    for scan in synthetic_scans(11, 6, bad=False):
        mapper.add_scan(scan)
    keys = mapper.tiles.keys
    assert (keys[:, 0] < 0).any() and (keys[:, 1] < 0).any()
    n_before = mapper.n_tiles
    # one scan 1 km away: only the tiles around it appear (no dense allocation in between)
    jump = Scan.from_arrays(
        np.full(20, 1.0), (1000.0, -1000.0, 0.3), angle_min=-1.0, angle_increment=0.1
    )
    rss_before = _resident_bytes()
    rep = mapper.add_scan(jump)
    assert rep.n_new_obstacles > 0
    new = mapper.n_tiles - n_before
    window_tiles = (2 * (SMALL.half_width_px + 2) // 16 + 2) ** 2
    assert 0 < new <= window_tiles + 40  # ~ the 2 m fan + splat windows, not 10^6 tiles
    r0, c0, r1, c1 = mapper.pixel_bbox
    assert (r1 - r0) * (c1 - c0) > 1e8  # the bounding box is huge, memory is not
    # memory: the tiles in use, and what the process really holds (the storage's
    # reserved capacity is address space only)
    assert mapper.n_tiles * mapper.tiles.tile_nbytes < 50e6
    assert _resident_bytes() - rss_before < 200e6
    # distances near the far scan equal a brute force on that neighbourhood
    mapper.update_skeleton()
    occ_rows, occ_cols = mapper.world_to_pixel(1000.0, -1000.0)
    w = 40
    t = mapper.tiles
    obst = t.read("hits", int(occ_rows) - w, int(occ_cols) - w, 2 * w, 2 * w) > 0
    d2 = t.read("sq_distance", int(occ_rows) - w, int(occ_cols) - w, 2 * w, 2 * w).astype(float)
    d2[d2 >= FAR_SQ] = np.inf
    np.testing.assert_array_equal(d2[12:-12, 12:-12], brute_sq_distance(obst, 10)[12:-12, 12:-12])


# --------------------------------------------------------------------------------------
# Skeleton and graph loops
# --------------------------------------------------------------------------------------


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(2, 14),
    every=st.tuples(st.integers(1, 4), st.integers(1, 6)),
    thinning=st.sampled_from(["guo_hall", "zhang"]),
    remove_t=st.booleans(),
)
def test_exact_strategy_equals_full_map_on_random_scans(seed, n, every, thinning, remove_t):
    from topojax.config import SkeletonConfig

    sk = SkeletonConfig(thinning=thinning, remove_t=remove_t)
    mapper = IncrementalMapper(
        skeleton_every=every[0], graph_every=every[1], skeleton=sk, **SMALL_KW
    )
    for scan in synthetic_scans(seed, n):
        mapper.add_scan(scan)
    assert_matches_full_map(mapper, PipelineConfig(distance=SMALL, skeleton=sk))


@pytest.mark.parametrize(
    "scale, threshold", [(255.0, 3.5), (255.0, 0.0), (8000.0, 254.5), (8000.0, 300.0)]
)
def test_ridge_thresholds_equal_full_map(scale, threshold):
    """Below 255 the ridge kernel returns only ``lap_abs`` and the ridge is derived from
    it (``lap_abs > floor(threshold)``); from 255 on it returns the ridge as well.  Both
    paths, fractional thresholds included, equal the full-map pipeline."""
    from topojax.config import RidgeConfig

    ridge = RidgeConfig(scale=scale, threshold=threshold)
    mapper = IncrementalMapper(skeleton_every=3, graph_every=5, ridge=ridge, **SMALL_KW)
    for scan in synthetic_scans(11, 8):
        mapper.add_scan(scan)
    ref = assert_matches_full_map(mapper, PipelineConfig(distance=SMALL, ridge=ridge))
    assert 0 < ref.ridges.sum() < ref.ridges.size
    if threshold >= 255:
        assert (ref.lap_abs[ref.ridges] == 255).all() and ((ref.lap_abs == 255) & ~ref.ridges).any()


@settings(max_examples=60, deadline=None)
@given(
    shape=st.tuples(st.integers(3, 40), st.integers(3, 40)),
    density=st.floats(0.2, 0.7),
    seed=st.integers(0, 2**31 - 1),
    method=st.sampled_from(["guo_hall", "zhang"]),
)
def test_thin_components_equals_whole_image(shape, density, seed, method):
    from scipy import ndimage

    from topojax.incremental import thin_components
    from topojax.skeleton import remove_t_centres, thin

    rng = np.random.default_rng(seed)
    image = rng.random(shape) < density
    full = remove_t_centres(thin(image, method=method))
    labels, n = ndimage.label(image, structure=np.ones((3, 3)))
    if n == 0:
        return
    pick = rng.random(n) < 0.5
    pick[rng.integers(n)] = True
    rows, cols = np.nonzero(pick[labels - 1] & image)
    off = rng.integers(-50, 50, 2)  # any global frame
    got = thin_components(
        rows + off[0],
        cols + off[1],
        (off[0], off[1], off[0] + shape[0], off[1] + shape[1]),
        method=method,
    )
    np.testing.assert_array_equal(got, full[rows, cols])


def thin_times_reference(image: np.ndarray, method: str) -> np.ndarray:
    """Deletion time of every pixel under parallel thinning, whole-image NumPy reference:
    0 off the image, ``s + 1`` when deleted by sub-iteration ``s``, 65535 when kept."""
    from topojax.skeleton import thinning_lookup_tables

    tables = thinning_lookup_tables(method)
    offsets = [(0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0), (1, 1)]
    h, w = image.shape
    alive = image.astype(bool).copy()
    times = np.where(alive, 65535, 0).astype(np.int64)
    s, quiet = 0, 0
    while quiet < 2:
        p = np.pad(alive, 1).astype(np.int64)
        code = sum(
            p[1 + dr : 1 + dr + h, 1 + dc : 1 + dc + w] << k for k, (dr, dc) in enumerate(offsets)
        )
        gone = alive & tables[s & 1][code]
        times[gone] = s + 1
        alive &= ~gone
        quiet = 0 if gone.any() else quiet + 1
        s += 1
    return times


def to_tiles(image: np.ndarray, t: int) -> np.ndarray:
    """(H, W) -> (n_tiles, t, t), tiles in raster order (slot = tile_row * n_cols + tile_col)."""
    h, w = image.shape
    return np.ascontiguousarray(
        image.reshape(h // t, t, w // t, t).transpose(0, 2, 1, 3).reshape(-1, t, t)
    )


def from_tiles(tiles: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    h, w = shape
    t = tiles.shape[1]
    return tiles.reshape(h // t, w // t, t, t).transpose(0, 2, 1, 3).reshape(h, w)


def blob_image(rng, shape, n_blobs, max_side):
    image = np.zeros(shape, bool)
    for _ in range(n_blobs):
        a, b = rng.integers(2, max_side, 2)
        r, c = rng.integers(0, shape[0] - a), rng.integers(0, shape[1] - b)
        image[r : r + a, c : c + b] = True
    return image


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    method=st.sampled_from(["guo_hall", "zhang"]),
    remove_t=st.booleans(),
    margin=st.integers(1, 4),
)
def test_local_rethinning_and_t_update_equal_whole_image(seed, method, remove_t, margin):
    """The exact skeleton loop's kernels on tile layers: re-thinning around changed
    pixels (growing its region where the change reaches the ring, as in thick blobs; any
    seed margin of at least one pixel) and the ordered T-removal update give the
    whole-image thinning times and skeleton."""
    from topojax.incremental import _skeleton as inc
    from topojax.skeleton import TABLES_U8, remove_t_centres

    rng = np.random.default_rng(seed)
    t, b = 16, 4
    shape = (64, 80)
    old = blob_image(rng, shape, 12, 30) ^ (rng.random(shape) < 0.05)
    new = old.copy()
    edits = rng.integers(0, [shape[0], shape[1]], (int(rng.integers(1, 12)), 2))
    new[edits[:, 0], edits[:, 1]] ^= True
    tau_old = thin_times_reference(old, method)
    tau_new = thin_times_reference(new, method)

    def skeleton(tau):
        sk = tau == 65535
        return remove_t_centres(sk) if remove_t else sk

    nr, nc = shape[0] // t, shape[1] // t
    grid = np.arange(nr * nc, dtype=np.int32).reshape(nr, nc)
    tr, tc = np.divmod(np.arange(nr * nc), nc)
    nbr9 = np.full((nr * nc, 9), -1, np.int64)
    for k, (dr, dc) in enumerate((dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1)):
        ok = (tr + dr >= 0) & (tr + dr < nr) & (tc + dc >= 0) & (tc + dc < nc)
        nbr9[ok, k] = grid[tr[ok] + dr, tc[ok] + dc]
    ridge = to_tiles(new, t)
    tau = to_tiles(tau_old.astype(np.uint16), t)
    bid = np.full((nr * nc, t // b, t // b), -1, np.int32)
    blk = np.empty((bid.size, 3), np.int64)
    n_blk = inc._seed_blocks(edits[:, 0], edits[:, 1], grid, 0, 0, t // b, b, bid, blk, margin)
    flat, rounds, _ = inc._rethin(
        ridge.reshape(-1),
        tau,
        nbr9,
        t,
        b,
        bid,
        blk,
        n_blk,
        TABLES_U8[method],
        inc._THIN_DR,
        inc._THIN_DC,
    )
    np.testing.assert_array_equal(from_tiles(tau, shape), tau_new)
    assert (bid == -1).all()  # left clean for the next update
    slot, rem = np.divmod(flat, t * t)
    rows = tr[slot] * t + rem // t
    cols = tc[slot] * t + rem % t
    expect = np.argwhere((tau_old == 65535) != (tau_new == 65535))
    assert sorted(zip(rows.tolist(), cols.tolist(), strict=True)) == sorted(
        map(tuple, expect.tolist())
    )

    skel = to_tiles(skeleton(tau_old), t)
    bbox = np.array([0, 0, shape[0], shape[1]], np.int64)
    ch_r = np.empty(rows.size + 16, np.int64)
    ch_c = np.empty(rows.size + 16, np.int64)
    args = (skel, tau, grid, 0, 0)
    todo, n_ch = inc._t_seeds(*args, t, bbox, rows, cols, 0, remove_t, ch_r, ch_c)
    # once with room for everything, once resuming from tiny arrays grown on the way
    skel0, seeds = skel.copy(), (ch_r.copy(), ch_c.copy(), n_ch)
    todo = np.sort(todo)
    ch_r, ch_c, n_ch = inc._t_update(*args, nbr9, t, bbox, todo, ch_r, ch_c, n_ch)
    tiny = inc._t_update(skel0, *args[1:], nbr9, t, bbox, todo, *seeds, room=1)
    assert tiny[2] == n_ch
    np.testing.assert_array_equal(skel0, skel)
    np.testing.assert_array_equal(tiny[0][:n_ch], ch_r[:n_ch])
    want = skeleton(tau_new)
    np.testing.assert_array_equal(from_tiles(skel, shape), want)
    got_changed = sorted(zip(ch_r[:n_ch].tolist(), ch_c[:n_ch].tolist(), strict=True))
    assert got_changed == sorted(map(tuple, np.argwhere(want != skeleton(tau_old)).tolist()))


def test_local_rethinning_grows_through_a_thick_blob():
    """A change at the centre of a thick blob moves the skeleton far beyond one block:
    the re-thinning region must grow (several rounds) and still be exact."""
    from topojax.incremental import _skeleton as inc
    from topojax.skeleton import TABLES_U8

    t, b = 16, 4
    old = np.zeros((96, 96), bool)
    old[8:88, 20:76] = True
    new = old.copy()
    new[47:49, 30:66] = False  # a slot through the middle splits the skeleton
    tau_old = thin_times_reference(old, "guo_hall")
    grid = np.arange(36, dtype=np.int32).reshape(6, 6)
    tr, tc = np.divmod(np.arange(36), 6)
    nbr9 = np.full((36, 9), -1, np.int64)
    for k, (dr, dc) in enumerate((dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1)):
        ok = (tr + dr >= 0) & (tr + dr < 6) & (tc + dc >= 0) & (tc + dc < 6)
        nbr9[ok, k] = grid[tr[ok] + dr, tc[ok] + dc]
    tau = to_tiles(tau_old.astype(np.uint16), t)
    bid = np.full((36, 4, 4), -1, np.int32)
    blk = np.empty((bid.size, 3), np.int64)
    rows, cols = np.nonzero(old != new)
    n_blk = inc._seed_blocks(rows, cols, grid, 0, 0, 4, b, bid, blk, inc.SEED_MARGIN_PX)
    _, rounds, _ = inc._rethin(
        to_tiles(new, t).reshape(-1),
        tau,
        nbr9,
        t,
        b,
        bid,
        blk,
        n_blk,
        TABLES_U8["guo_hall"],
        inc._THIN_DR,
        inc._THIN_DC,
    )
    assert rounds > 1
    np.testing.assert_array_equal(from_tiles(tau, (96, 96)), thin_times_reference(new, "guo_hall"))


def test_thin_times_reference_matches_skimage():
    from skimage.morphology import skeletonize, thin

    rng = np.random.default_rng(3)
    image = blob_image(rng, (50, 60), 10, 20) ^ (rng.random((50, 60)) < 0.1)
    np.testing.assert_array_equal(thin_times_reference(image, "guo_hall") == 65535, thin(image))
    np.testing.assert_array_equal(thin_times_reference(image, "zhang") == 65535, skeletonize(image))


@pytest.mark.parametrize("transpose", [False, True])
def test_bounding_box_growth_recomputes_the_reflected_border(transpose):
    """Ridges next to the bounding box use BORDER_REFLECT_101; when the box grows those
    rows become interior and must be recomputed.  With sigma 4 px and R = 6 px the
    reflected values near the old border flip ridge pixels."""
    cfg = DistanceConfig(sigma_px=4.0, half_width_px=6)

    def shot(row, col):  # one 7 m beam ending in pixel (row, col) at 1 m per pixel
        if transpose:
            row, col = col, row
        return Scan.from_arrays(
            np.array([7.0]),
            (col + 0.5 - 7.0, -(row + 0.5), 0.0),
            angle_min=0.0,
            angle_increment=1.0,
        )

    mapper = IncrementalMapper(
        resolution_m=1.0,
        distance=cfg,
        tile_px=16,
        block_px=8,
        skeleton_every=1,
        graph_every=1,
        free_space=False,
    )
    mapper.add_scan(shot(7, 7))
    mapper.add_scan(shot(8, 9))
    box = mapper.pixel_bbox
    mapper.add_scan(shot(100, 7))  # far away: the box grows, nothing near the old border
    assert mapper.pixel_bbox != box
    assert_matches_full_map(mapper, PipelineConfig(distance=cfg))


def test_intel_excerpt_matches_full_map():
    mapper = IncrementalMapper(skeleton_every=5, graph_every=15)
    reports = [mapper.add_scan(s) for s in read_carmen(INTEL_EXCERPT)]
    assert len(reports) == 40
    assert sum("graph" in r.loops for r in reports) == 2
    assert all(isinstance(r.graph_update, GraphUpdate) for r in reports if "graph" in r.loops)
    ref = assert_matches_full_map(mapper)
    # the exported graph prunes like build_graph's (the mapper itself keeps every piece)
    pruned = prune_graph(mapper.graph, min_spur_m=0.5, min_component_m=2.0)
    want = prune_graph(ref.graph, min_spur_m=0.5, min_component_m=2.0)
    assert canon(pruned) == canon(want)
    assert pruned.number_of_nodes() < mapper.graph.number_of_nodes()
    # world coordinates agree with build_graph on the exported map
    g = mapper.graph
    by_pixel = {d["pixel"]: d["world"] for _, d in ref.graph.nodes(data=True)}
    for _, d in g.nodes(data=True):
        assert d["world"] == by_pixel[d["pixel"]]
    # and the global lattice: pixel centre x = (col + 0.5) res, y = -(row + 0.5) res
    r0, c0, _, _ = mapper.pixel_bbox
    for _, d in list(g.nodes(data=True))[:20]:
        r, c = d["pixel"]
        assert d["world"][0] == pytest.approx((c + c0 + 0.5) * 0.05, abs=1e-9)
        assert d["world"][1] == pytest.approx(-(r + r0 + 0.5) * 0.05, abs=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("log_name", "n_scans", "min_edges"), [("intel", 300, 301), ("seattle", 120, 1)]
)
def test_log_replay_matches_full_map(shared_data, log_name, n_scans, min_edges):
    log = shared_data / "logs" / "carmen_corrected" / f"{log_name}-corrected.log.gz"
    mapper = IncrementalMapper(skeleton_every=20, graph_every=80)
    for i, scan in enumerate(read_carmen(log)):
        if i == n_scans:
            break
        mapper.add_scan(scan)
    assert_matches_full_map(mapper)
    assert mapper.graph.number_of_edges() >= min_edges


def test_edge_path_pool_survives_holes_and_compaction():
    from topojax.incremental._graph_store import (
        add_paths,
        drop_paths,
        edge_ids,
        edge_paths,
        reserve,
    )

    m = IncrementalMapper()
    rng = np.random.default_rng(3)
    want = {}

    def add(ids):
        reserve(m, edges=int(ids.max()) + 1)
        m._next_edge = max(m._next_edge, int(ids.max()) + 1)
        lens = rng.integers(1, 400, ids.shape[0])
        paths = rng.integers(-(1 << 20), 1 << 20, (int(lens.sum()), 2)).astype(np.int32)
        m._e_alive[ids] = True
        add_paths(m, ids, paths, lens)
        for k, a, b in zip(ids, np.cumsum(lens) - lens, np.cumsum(lens), strict=True):
            want[int(k)] = paths[a:b]

    add(np.arange(20))
    for _step in range(30):  # remove some, add more: holes, compactions and growth
        gone = rng.choice(sorted(want), size=min(8, len(want)), replace=False)
        m._e_alive[gone] = False
        drop_paths(m, gone)
        for k in gone.tolist():
            del want[k]
        add(np.arange(m._next_edge, m._next_edge + 10))
    live = edge_ids(m)
    assert sorted(want) == live.tolist()
    paths, lens = edge_paths(m, live)
    assert lens.tolist() == [want[k].shape[0] for k in live.tolist()]
    np.testing.assert_array_equal(paths, np.concatenate([want[k] for k in live.tolist()]))
    assert m._pool.shape[0] < 8 * (int(lens.sum()) + 4096)  # holes do not pile up


def test_graph_ids_are_stable_away_from_changes():
    """Vertices of a region that no later scan touches keep their ids and edges."""
    rng = np.random.default_rng(5)
    world = room_world(rng, n_walls=4)
    fov = math.radians(270)

    def scan_at(x, y, yaw):
        r = cast(world + np.array([x, y, x, y]), (x, y, yaw), 90, fov, 8.0)
        return Scan.from_arrays(
            r, (x, y, yaw), angle_min=-fov / 2, angle_increment=fov / 89, range_max=8.0
        )

    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, **SMALL_KW)
    for yaw in np.linspace(-3, 3, 6):
        mapper.add_scan(scan_at(0.0, 0.0, yaw))
    mapper.update_graph()
    g1 = mapper.graph_global
    assert g1.number_of_edges() > 3
    # a second room 40 m away: far beyond every window of the first
    for yaw in np.linspace(-3, 3, 6):
        mapper.add_scan(scan_at(40.0, 0.0, yaw))
    upd = mapper.update_graph()
    g2 = mapper.graph_global
    assert upd.added_vertices and upd.added_edges
    assert not upd.removed_vertices and not upd.removed_edges and not upd.changed_vertices
    for v, d in g1.nodes(data=True):
        assert g2.nodes[v]["pixel"] == d["pixel"] and g2.nodes[v]["kind"] == d["kind"]
    for u, v, k, p in g1.edges(keys=True, data="path"):
        np.testing.assert_array_equal(g2.edges[u, v, k]["path"], p)
    assert set(g1.nodes).isdisjoint(upd.added_vertices)
    # a new room changed nothing old; rescanning the first room only touches its region
    for yaw in np.linspace(-2.5, 2.5, 3):
        mapper.add_scan(scan_at(0.1, 0.05, yaw))
    upd = mapper.update_graph()
    g3 = mapper.graph_global
    far = [v for v, d in g2.nodes(data=True) if d["pixel"][1] > 300]
    assert far and all(v in g3 and g3.nodes[v]["pixel"] == g2.nodes[v]["pixel"] for v in far)
    assert not set(far) & set(upd.removed_vertices + upd.changed_vertices)
    assert_matches_full_map(mapper)


def test_mapper_repr_says_what_it_holds():
    """A notebook shows a mapper by its repr: its scans, resolution, strategy and
    storage, not an object address."""
    mapper = IncrementalMapper(resolution_m=0.1, skeleton_every=None, graph_every=None)
    assert repr(mapper) == (
        "IncrementalMapper(n_scans=0, resolution_m=0.1, strategy='exact', n_tiles=0, "
        "pixel_bbox=None)"
    )
    mapper.add_points(np.array([[0.05, -0.05]]), origin_xy=(0.05, -0.05))
    assert repr(mapper).startswith("IncrementalMapper(n_scans=1, resolution_m=0.1, ")
    assert f"pixel_bbox={mapper.pixel_bbox}" in repr(mapper) and mapper.pixel_bbox


def test_update_reprs_stay_short_for_a_whole_map_of_ids():
    """The first graph update of a large map adds every vertex and edge: a notebook showing
    the update (or the scan report holding it) gets the first and last ids and their
    count, not thousands of ids; a short tuple is shown whole."""
    from topojax.incremental import RoomsUpdate

    big = GraphUpdate(
        added_vertices=tuple(range(5000)),
        added_edges=tuple(range(7000)),
        removed_edges=(3, 4),
        region_px=12,
        time_s=0.5,
    )
    assert repr(big) == (
        "GraphUpdate(added_vertices=(0, 1, 2, ..., 4997, 4998, 4999; 5000 ids), "
        "removed_vertices=(), changed_vertices=(), "
        "added_edges=(0, 1, 2, ..., 6997, 6998, 6999; 7000 ids), removed_edges=(3, 4), "
        "region_px=12, time_s=0.5)"
    )
    report = ScanReport(0, 10, 10, 0, 10, ("distance", "graph"), {}, 4, graph_update=big)
    assert len(repr(report)) < 600 and repr(big) in repr(report)
    rooms = RoomsUpdate(added=tuple(range(1, 101)), doors_added=((1, 2),), n_rooms=100)
    assert "added=(1, 2, 3, ..., 98, 99, 100; 100 ids)" in repr(rooms)
    assert "doors_added=((1, 2),)" in repr(rooms)


def test_graph_update_reports_exactly_what_changed(shared_data):
    """Each GraphUpdate equals the difference of the graphs before and after it."""
    log = shared_data / "logs" / "carmen_corrected" / "intel-corrected.log.gz"
    mapper = IncrementalMapper(skeleton_every=10, graph_every=0)
    before = mapper.graph_global
    n_updates = 0
    for i, scan in enumerate(read_carmen(log)):
        if i == 240:
            break
        mapper.add_scan(scan)
        if (i + 1) % 40:
            continue
        upd = mapper.update_graph()
        after = mapper.graph_global
        n_updates += 1
        v1, v2 = set(before.nodes), set(after.nodes)
        e1, e2 = set(before.edges(keys=True)), set(after.edges(keys=True))
        k1, k2 = {k for *_, k in e1}, {k for *_, k in e2}
        assert set(upd.added_vertices) == v2 - v1
        assert set(upd.removed_vertices) == v1 - v2
        assert set(upd.added_edges) == k2 - k1
        assert set(upd.removed_edges) == k1 - k2
        for u, v, k in e1 & e2:  # a kept key keeps its ends and its path
            np.testing.assert_array_equal(
                before.edges[u, v, k]["path"], after.edges[u, v, k]["path"]
            )
        assert {k for *_, k in e1 if k in k2} == {k for *_, k in e2 if k in k1}

        def incident(g, v):
            return {k for *_, k in g.edges(v, keys=True)}

        changed = {
            v
            for v in v1 & v2
            if before.nodes[v]["kind"] != after.nodes[v]["kind"]
            or before.nodes[v]["pixel"] != after.nodes[v]["pixel"]
            or incident(before, v) != incident(after, v)
        }
        assert set(upd.changed_vertices) == changed
        assert all(before.nodes[v]["pixel"] == after.nodes[v]["pixel"] for v in v1 & v2)
        before = after
    assert n_updates == 6
    assert_matches_full_map(mapper)


def test_paper_strategy_reports_paper_metrics(shared_data):
    log = shared_data / "logs" / "carmen_corrected" / "intel-corrected.log.gz"
    mapper = IncrementalMapper(strategy="paper")
    for i, scan in enumerate(read_carmen(log)):
        if i == 200:
            break
        mapper.add_scan(scan)
    mapper.update_graph()
    ref = build_graph(mapper.occupancy)
    m = vertex_error_metrics(mapper.graph, ref.graph)
    print(f"paper strategy vs full map, intel first 200 scans: {m}")
    assert m["n_vertices"] == mapper.graph.number_of_nodes() > 100
    assert 0.0 <= m["share_within_1px"] <= 1.0
    assert 0 <= m["n_outliers"] <= m["n_vertices"]
    assert math.isfinite(m["mean_px"]) and 0.0 <= m["mean_px"] <= 20.0
    # the paper layer never writes outside the changed blocks: the skeleton stays thin
    assert mapper.skeleton.sum() < 1.2 * ref.skeleton.sum()


def test_a_paper_layer_wider_than_the_window_reaches_all_of_it():
    """A paper layer far wider than the window covers all of it without a dilation by a
    square of ``2 * paper_layer_px + 1`` pixels, which at 10**30 fails inside NumPy
    ("Maximum allowed dimension exceeded"), at 10**6 asks for a 3.6 TiB structuring
    element, and whose cost grows with the square's area."""
    scans = list(read_carmen(INTEL_EXCERPT))[:12]
    skeletons = []
    for layer in (10**30, 10**4, 2):
        mapper = IncrementalMapper(strategy="paper", paper_layer_px=layer, skeleton_every=4)
        mapper.add_scans(scans)
        mapper.update_skeleton()
        skeletons.append(mapper.skeleton)
    np.testing.assert_array_equal(skeletons[0], skeletons[1])
    assert skeletons[2].any()


def test_vertex_error_metrics_on_known_graphs():
    a, b = nx.Graph(), nx.Graph()
    for i, pix in enumerate([(0, 0), (10, 0), (50, 50), (7, 7)]):
        a.add_node(i, pixel=pix)
    for i, pix in enumerate([(0, 1), (13, 4), (7, 7)]):
        b.add_node(i, pixel=pix)
    m = vertex_error_metrics(a, b)
    # distances: 1, 5, ~50.2 (outlier), 0
    assert m["n_vertices"] == 4 and m["n_outliers"] == 1
    assert m["mean_px"] == pytest.approx(2.0)
    assert m["share_within_1px"] == pytest.approx(0.5)
    m = vertex_error_metrics(a, b, region=(0, 20, 0, 20))
    assert m["n_vertices"] == 3 and m["n_outliers"] == 0
    with pytest.raises(ValueError, match="pixel"):
        vertex_error_metrics(a, nx.Graph([(0, 1)]))
    assert vertex_error_metrics(a, nx.Graph())["n_outliers"] == 4
    assert vertex_error_metrics(a, b, outlier_px=np.float32(np.inf))["n_outliers"] == 0
    with pytest.raises(TypeError, match="^graph_b: expected a networkx graph, received dict"):
        vertex_error_metrics(a, {})
    assert vertex_error_metrics(a.to_directed(), b)["n_vertices"] == 4  # direction unread
    for pixel, exc, shown in (("ab", TypeError, "str 'ab'"), ((np.nan, 1.0), ValueError, "nan")):
        edited = b.copy()
        edited.nodes[1]["pixel"] = pixel  # named, not left to fail inside NumPy or SciPy
        with pytest.raises(exc, match=rf"^graph_b: node 1: 'pixel': expected two finite .*{shown}"):
            vertex_error_metrics(a, edited)
    with pytest.raises(TypeError, match="^outlier_px: expected a real number, received str"):
        vertex_error_metrics(a, b, outlier_px="20")
    for bad in (0, -1.0, np.nan):
        with pytest.raises(ValueError, match="^outlier_px: expected a"):
            vertex_error_metrics(a, b, outlier_px=bad)


def test_vertex_error_metrics_checks_the_region():
    """A region of the wrong length, a NaN one or an empty one (row0 >= row1) is refused
    naming ``region``, not left to Python's unpacking error, which names nothing, nor to
    n_vertices 0 and NaN metrics without a word."""
    a = nx.Graph()
    a.add_node(0, pixel=(5, 5))
    assert vertex_error_metrics(a, a, region=(0.0, 10, np.int64(0), 10))["n_vertices"] == 1
    for bad in ((0, 10), (0, 10, 0, 10, 0), (0, np.nan, 0, 10), (0, 10, -np.inf, 10)):
        with pytest.raises(ValueError, match=r"^region: expected 4 finite numbers \(row0, row1"):
            vertex_error_metrics(a, a, region=bad)
    for bad in ("abcd", (0, 10, True, 10), None.__class__):
        with pytest.raises(TypeError, match="^region: expected 4 finite numbers"):
            vertex_error_metrics(a, a, region=bad)
    for bad in ((10, 0, 0, 10), (0, 10, 5, 5)):
        with pytest.raises(ValueError, match="^region: expected row0 < row1 and col0 < col1"):
            vertex_error_metrics(a, a, region=bad)


# --------------------------------------------------------------------------------------
# Compilation, state, replay
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(("dtype", "limit"), [(np.float32, 5.6), (np.float16, 4.2)])
def test_low_precision_readings_at_a_decimal_range_max_add_no_obstacles(dtype, limit):
    """A float32 (float16) scan whose no-returns are stored at range_max (5.6 m, 4.2 m:
    rounded down in that precision) adds only its real hits, as its valid_mask says
    (float16 readings taken as float64 would make a ring of phantom obstacles)."""
    r = np.full(360, limit, dtype)
    r[:10] = 2.0
    scan = Scan.from_arrays(
        r, (0.0, 0.0, 0.0), angle_min=-math.pi, angle_increment=2 * math.pi / 360, range_max=limit
    )
    report = IncrementalMapper(free_space=False).add_scan(scan)
    assert report.n_valid == int(scan.valid_mask().sum()) == 10
    capped = IncrementalMapper(free_space=False, max_range_m=2.0).add_scan(scan)
    assert capped.n_valid == 0


def test_no_new_traces_during_a_replay():
    scans = list(read_carmen(INTEL_EXCERPT))
    mapper = IncrementalMapper(skeleton_every=4, graph_every=8)
    for s in scans[:6]:
        mapper.add_scan(s)
    assert "skeleton" in mapper.add_scans(scans[6:8])[-1].loops
    _ = mapper.distance  # the export's kernel compiles at its first use (in any mapper)
    before = trace_counts()
    assert before.get("splat_blocks", 0) >= 1 and before.get("ridge_blocks", 0) >= 1
    for s in scans[8:]:
        mapper.add_scan(s)
    mapper.update_graph()
    _ = mapper.distance
    other = IncrementalMapper(skeleton_every=3, graph_every=0, max_pending_points=0)
    other.add_scans(scans[:10])
    assert trace_counts() == before


_LAYOUT_CHECK = """
import sys
from collections import Counter
import numba
import numpy as np
from topojax import incremental as inc
from topojax.scans import read_carmen
mapper = inc.IncrementalMapper(skeleton_every=1, graph_every=2)
for s in list(read_carmen(sys.argv[1]))[:12]:
    mapper.add_scan(s)
# the smallest updates: one dirty block, one changed skeleton pixel (one-element arrays)
tiles = mapper._tiles
tiles.layer("ridge_dirty")[0, 1, 1] = True
tiles.mark_dirty("ridge", [0])
mapper.update_skeleton()
r0, c0 = tiles.keys[0] * mapper.tile_px
mapper._skel_changed.append(np.array([[r0 + 3, c0 + 5]], np.int64))
mapper.update_graph()
for name in dir(inc):
    f = getattr(inc, name)
    if isinstance(f, numba.core.registry.CPUDispatcher):
        key = Counter(
            tuple((a.dtype, a.ndim, a.mutable) if isinstance(a, numba.types.Array) else a
                  for a in sig)
            for sig in f.signatures
        )
        if max(key.values(), default=0) > 1:
            print(name, f.signatures)
"""


def test_compiled_kernels_see_one_memory_layout_per_argument():
    """numba compiles a new variant (0.3-0.9 s) for every new memory layout of an array
    argument: a strided view that happens to hold one element is contiguous, so a real-time
    loop must pass contiguous arrays (or always strided ones) to its compiled kernels.  Run
    in a fresh process (tests here call some kernels with other layouts on purpose)."""
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", _LAYOUT_CHECK, str(INTEL_EXCERPT)],
        capture_output=True,
        text=True,
        check=True,
    )
    assert out.stdout == "", out.stdout


def test_save_load_continue_equals_uninterrupted(tmp_path):
    scans = list(read_carmen(INTEL_EXCERPT))
    kw = {"skeleton_every": 4, "graph_every": 10}
    straight = IncrementalMapper(**kw)
    straight.add_scans(scans)
    first = IncrementalMapper(**kw)
    first.add_scans(scans[:17])  # pending points, dirty blocks and skeleton changes waiting
    path = first.save(tmp_path / "state.npz")
    resumed = IncrementalMapper.load(path)
    assert resumed.n_scans == 17
    resumed.add_scans(scans[17:])
    a, b = straight.tiles.state(), resumed.tiles.state()
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    ga, gb = straight.graph_global, resumed.graph_global
    assert sorted(ga.nodes(data="pixel")) == sorted(gb.nodes(data="pixel"))
    assert sorted(ga.edges(keys=True)) == sorted(gb.edges(keys=True))
    for u, v, k, p in ga.edges(keys=True, data="path"):
        np.testing.assert_array_equal(gb.edges[u, v, k]["path"], p)
    straight.update_graph()
    resumed.update_graph()
    assert canon(straight.graph) == canon(resumed.graph)
    # atomic: no temporary files left next to the state
    assert [p.name for p in tmp_path.iterdir()] == ["state.npz"]


def test_load_rejects_bad_files(tmp_path):
    with pytest.raises(FileNotFoundError, match="^path: file not found: .*missing.npz"):
        IncrementalMapper.load(tmp_path / "missing.npz")
    with pytest.raises(ValueError, match="^path: expected a file, received the folder"):
        IncrementalMapper.load(tmp_path)
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"this is not a zip file")
    with pytest.raises(ValueError, match="bad.npz"):
        IncrementalMapper.load(bad)
    other = tmp_path / "other.npz"
    np.savez(other, format=np.asarray("something else"), version=np.asarray(1))
    with pytest.raises(ValueError, match="format"):
        IncrementalMapper.load(other)
    npy = tmp_path / "array.npz"  # np.save writes a bare .npy whatever the name
    with open(npy, "wb") as fh:
        np.save(fh, np.arange(3))
    text = tmp_path / "text.npz"
    text.write_text("format: topojax\n")
    for path in (npy, text):
        with pytest.raises(ValueError, match=r"not a mapper state: a state is an \.npz"):
            IncrementalMapper.load(path)
    odd = tmp_path / "odd.npz"
    np.savez(odd, format=np.asarray(STATE_FORMAT), version=np.asarray("one"))
    with pytest.raises(ValueError, match=r"odd\.npz: not a mapper state \(format/version"):
        IncrementalMapper.load(odd)
    mapper = IncrementalMapper(**SMALL_KW)
    mapper.add_scans(synthetic_scans(1, 2))
    good = mapper.save(tmp_path / "good.npz")
    with np.load(good) as z:
        data = {k: z[k] for k in z.files}
    data["version"] = np.asarray(STATE_VERSION + 1)
    np.savez(tmp_path / "future.npz", **data)
    with pytest.raises(ValueError, match="version"):
        IncrementalMapper.load(tmp_path / "future.npz")
    data["version"] = np.asarray(STATE_VERSION)
    data["e_len"] = data["e_len"] + 1
    np.savez(tmp_path / "broken.npz", **data)
    if data["e_len"].size:
        with pytest.raises(ValueError, match="corrupt"):
            IncrementalMapper.load(tmp_path / "broken.npz")
    del data["tiles/keys"]
    np.savez(tmp_path / "nokeys.npz", **data)
    with pytest.raises(ValueError, match="corrupt"):
        IncrementalMapper.load(tmp_path / "nokeys.npz")


def test_replay_writes_graph_map_timings_and_pictures(tmp_path):
    summary = replay(
        INTEL_EXCERPT,
        out_dir=tmp_path / "out",
        plot=True,
        animate=tmp_path / "out" / "anim.gif",
        progress=False,
        skeleton_every=5,
        graph_every=10,
    )
    out = tmp_path / "out"
    for name in (
        "graph.graphml",
        "graph.json",
        "map.yaml",
        "map.pgm",
        "timings.json",
        "graph.png",
        "anim.gif",
    ):
        assert (out / name).is_file(), name
    g = load_graph(out / "graph.json")
    assert g.number_of_nodes() == summary["vertices"] and g.number_of_edges() == summary["edges"]
    occ = load_map(out / "map.yaml")
    assert occ.shape == tuple(summary["map_shape"])
    assert summary["n_scans"] == 40
    t = summary["timings"]
    assert t["distance"]["count"] == 40 and t["graph"]["count"] == 4
    assert t["add_scan"]["p99_ms"] >= t["add_scan"]["p50_ms"] > 0


def test_replay_cli_registers_and_runs(tmp_path, capsys):
    import argparse

    from topojax.cli.replay import add_command

    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    add_command(sub)
    args = parser.parse_args(
        [
            "replay",
            str(INTEL_EXCERPT),
            "-o",
            str(tmp_path),
            "--max-scans",
            "12",
            "--skeleton-every",
            "4",
            "--graph-every",
            "8",
            "--no-progress",
            "--nav2",
        ]
    )
    assert args.handler(args) == 0
    text = capsys.readouterr().out
    assert "replayed   12 scans" in text and "skeleton" in text
    # the Nav2 route graph: the final graph's vertices first, in node order
    doc = json.loads((tmp_path / "graph_nav2.geojson").read_text())
    g = load_graph(tmp_path / "graph.json")
    points = [f for f in doc["features"] if f["geometry"]["type"] == "Point"]
    linked = [n for n in g.nodes if g.degree(n)]  # vertices without edges are left out
    assert [p["properties"]["metadata"]["vertex"] for p in points[: len(linked)]] == linked
    assert "graph_nav2.geojson" in text
    with pytest.raises(ValueError, match="tolerance_m"):  # before any scan is replayed
        replay(INTEL_EXCERPT, out_dir=tmp_path / "bad", nav2_tolerance_m=-1.0, progress=False)
    assert not (tmp_path / "bad").exists()
    assert (tmp_path / "graph.geojson").is_file()
    with pytest.raises(ValueError, match="max_scans"):
        replay(INTEL_EXCERPT, out_dir=tmp_path, max_scans=0, progress=False)


def test_replay_cli_reader_options_and_early_path_checks(tmp_path, capsys):
    from topojax.cli import main

    bag = DATA / "ccny_demo_first25.bag"
    base = ["replay", "-o", str(tmp_path / "o"), "--max-scans", "3", "--no-progress"]
    # a scan-only bag: the error names the command-line option, which then works
    assert main([*base, str(bag)]) != 0
    said = capsys.readouterr().err
    assert "Pass --allow-missing-pose to read" in said and "--pose-topic" in said
    assert "allow_missing_pose" not in said and "pose_topic" not in said
    assert main([*base, str(bag), "--allow-missing-pose"]) == 0
    # options for another reader are named, not a TypeError
    assert main([*base, str(bag), "--max-range", "5"]) != 0
    assert (
        "--max-range: expected options of the log's reader, received a log read by read_bag "
        in capsys.readouterr().err
    )
    # and the options a bag takes, on a CARMEN log, in the command's words
    other = ["replay", "-o", str(tmp_path / "carmen"), "--no-progress"]
    assert main([*other, str(INTEL_EXCERPT), "--tf-parent", "odom"]) != 0
    err = capsys.readouterr().err
    assert "--tf-parent: expected options of the log's reader" in err and "tf_parent" not in err
    takes = "takes --skip-bad-lines, --laser, --max-range, --sensor-offset"
    assert "read_carmen" in err and takes in err
    assert main([*base, str(bag), "--laser", "RLASER"]) != 0  # a CARMEN option on a bag
    assert "--laser: expected options of the log's reader" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([*other, str(INTEL_EXCERPT), "--laser", "LASER9"])
    assert "--laser: invalid choice: 'LASER9' (choose from " in capsys.readouterr().err
    # --max-range reaches the CARMEN reader: with 1 m nearly every beam is a no-return
    short = replay(
        INTEL_EXCERPT,
        out_dir=tmp_path / "s",
        max_scans=3,
        progress=False,
        reader_kwargs={"max_range_m": 1.0},
        skeleton_every=1,
        graph_every=1,
    )
    full = replay(
        INTEL_EXCERPT,
        out_dir=tmp_path / "f",
        max_scans=3,
        progress=False,
        skeleton_every=1,
        graph_every=1,
    )
    assert short["n_tiles"] < full["n_tiles"] or short["vertices"] != full["vertices"]
    # paths that cannot be written are refused before the replay, leaving nothing behind
    folder = tmp_path / "gif"
    folder.mkdir()
    with pytest.raises(IsADirectoryError, match="animate: expected a GIF file name"):
        replay(INTEL_EXCERPT, out_dir=tmp_path / "a", animate=folder, progress=False)
    (tmp_path / "afile").write_text("x")
    with pytest.raises(NotADirectoryError, match="out_dir: expected a folder to write into"):
        replay(INTEL_EXCERPT, out_dir=tmp_path / "afile", progress=False)
    # a GIF below a file: refused before the replay, not with "File exists" after it
    with pytest.raises(NotADirectoryError, match=r"animate: .*afile in .* is a file, not a"):
        replay(INTEL_EXCERPT, out_dir=tmp_path / "b", animate=tmp_path / "afile" / "x.gif")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "f", "gif", "o", "s"]
    assert list(folder.iterdir()) == []


@pytest.mark.parametrize(
    "graph",
    [
        GraphConfig(free_space_only=True, min_spur_m=0.5, min_component_m=2.0),
        GraphConfig(min_clearance_m=0.3),
    ],
    ids=["free-only+spurs+components", "clearance"],
)
def test_replay_writes_the_graph_that_build_graph_keeps(tmp_path, graph):
    """With graph_config the written graph is build_graph's on the written map with the
    same GraphConfig (free-space thinning and pruning), smaller than the whole graph."""
    whole = replay(INTEL_EXCERPT, out_dir=tmp_path / "whole", progress=False)
    summary = replay(INTEL_EXCERPT, out_dir=tmp_path / "kept", progress=False, graph_config=graph)
    got = load_graph(tmp_path / "kept" / "graph.json")
    want = build_graph(load_map(tmp_path / "kept" / "map.yaml"), config=PipelineConfig(graph=graph))
    assert canon(got) == canon(want.graph)
    for _, d in want.graph.nodes(data=True):
        match = [e for e, f in got.nodes(data=True) if f["pixel"] == d["pixel"]]
        assert len(match) == 1
        assert got.nodes[match[0]]["world"] == pytest.approx(d["world"], abs=1e-9)
        assert got.nodes[match[0]]["clearance_m"] == pytest.approx(d["clearance_m"], rel=1e-6)
    assert 0 < summary["edges"] == got.number_of_edges() < whole["edges"]
    with pytest.raises(TypeError, match="graph_config: expected a GraphConfig"):
        replay(INTEL_EXCERPT, out_dir=tmp_path / "bad", graph_config={"min_spur_m": 1.0})


def test_replay_cli_prunes_like_graph(tmp_path, capsys):
    import argparse

    from topojax.cli.replay import add_command

    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    add_command(sub)
    options = ["--free-only", "--min-spur-m", "0.5", "--min-clearance-m", "0.2"]
    args = parser.parse_args(
        ["replay", str(INTEL_EXCERPT), "-o", str(tmp_path), "--no-progress", "--nav2", *options]
    )
    assert args.handler(args) == 0
    capsys.readouterr()
    cfg = GraphConfig(free_space_only=True, min_spur_m=0.5, min_clearance_m=0.2)
    want = build_graph(load_map(tmp_path / "map.yaml"), config=PipelineConfig(graph=cfg))
    assert canon(load_graph(tmp_path / "graph.json")) == canon(want.graph)
    assert (tmp_path / "graph_nav2.geojson").is_file()


def test_timing_summary_statistics():
    reps = [
        ScanReport(i, 1, 1, 0, 0, ("distance",), {"distance": 0.001 * (i + 1)}, 1)
        for i in range(100)
    ]
    s = timing_summary(reps)["distance"]
    assert s["count"] == 100
    assert s["mean_ms"] == pytest.approx(50.5)
    assert s["p50_ms"] == pytest.approx(50.5)
    assert s["per_scan_ms"] == pytest.approx(50.5)
    assert s["max_ms"] == pytest.approx(100.0)


# --------------------------------------------------------------------------------------
# graph exports: GraphStore-built graphs equal one networkx call per vertex and edge
# --------------------------------------------------------------------------------------


def _reference_graph(mapper: IncrementalMapper) -> nx.MultiGraph:
    """``mapper.graph`` as one add_node / add_edge call per vertex and edge gives it, each
    value computed on its own from the mapper's tables."""
    from topojax.graph import KIND_NAMES, path_lengths_m
    from topojax.incremental._graph_store import edge_ids, edge_paths, vertex_ids
    from topojax.incremental._tiles import _unpack
    from topojax.pipeline import clearance_at

    res = mapper.resolution_m
    out = nx.MultiGraph()
    if mapper.pixel_bbox is None:
        out.graph.update(resolution_m=res, shape=(0, 0), merge_junction_clusters=False)
        return out
    r0, c0, r1, c1 = mapper.pixel_bbox
    occ = mapper.occupancy
    d2, obstacles = mapper.sq_distance_px, mapper.obstacles

    def clearance_m(r: int, c: int) -> float:
        flat = np.array([r * d2.shape[1] + c], np.intp)
        return float(clearance_at(d2, obstacles, mapper._half, flat)[0]) * res

    def world(r: int, c: int) -> tuple[float, float]:
        x, y = occ.pixel_to_world(np.array([r]), np.array([c]))
        return float(x[0]), float(y[0])

    out.graph.update(
        resolution_m=res,
        shape=(r1 - r0, c1 - c0),
        merge_junction_clusters=False,
        origin=tuple(float(v) for v in occ.origin),
        thinning=mapper.config.skeleton.thinning,
    )
    for v in vertex_ids(mapper).tolist():
        r, c = (int(x[0]) for x in _unpack(mapper._v_key[[v]]))
        r, c = r - r0, c - c0
        out.add_node(
            v,
            pixel=(r, c),
            pixels=np.array([[r, c]], np.int32),
            world=world(r, c),
            kind=KIND_NAMES[int(mapper._v_code[v])],
            clearance_m=clearance_m(r, c),
        )
    for k in edge_ids(mapper).tolist():
        u, v = mapper._e_uv[k].tolist()
        path = edge_paths(mapper, np.array([k]))[0].astype(np.int64) - [r0, c0]
        cl = np.array([clearance_m(r, c) for r, c in path.tolist()])
        length = path_lengths_m(path, np.array([0]), np.array([len(path)]), res)[0]
        out.add_edge(
            u,
            v,
            key=k,
            path=path.astype(np.int32),
            world=np.array([world(r, c) for r, c in path.tolist()]),
            length_m=float(length),
            min_clearance_m=float(cl.min()),
            mean_clearance_m=float(cl.mean()),
        )
    return out


def _reference_global_graph(mapper: IncrementalMapper) -> nx.MultiGraph:
    """``mapper.graph_global`` as one add_node / add_edge call per vertex and edge gives it."""
    from topojax.graph import KIND_NAMES
    from topojax.incremental._graph_store import edge_ids, edge_paths, vertex_ids
    from topojax.incremental._tiles import _unpack

    out = nx.MultiGraph()
    for v in vertex_ids(mapper).tolist():
        r, c = (int(x[0]) for x in _unpack(mapper._v_key[[v]]))
        out.add_node(v, pixel=(r, c), kind=KIND_NAMES[int(mapper._v_code[v])])
    for k in edge_ids(mapper).tolist():
        u, v = mapper._e_uv[k].tolist()
        out.add_edge(u, v, key=k, path=edge_paths(mapper, np.array([k]))[0].copy())
    return out


def _assert_same_value(a, b, where: str) -> None:
    assert type(a) is type(b), f"{where}: {type(a).__name__} != {type(b).__name__}"
    if isinstance(a, np.ndarray):
        assert (a.dtype, a.shape) == (b.dtype, b.shape), f"{where}: {a.dtype}{a.shape}"
        assert a.tobytes() == b.tobytes(), where  # bit for bit
        assert a.flags.writeable and b.flags.writeable, where
        assert a.flags.c_contiguous == b.flags.c_contiguous, where
    elif isinstance(a, tuple):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_same_value(x, y, f"{where}[{i}]")
    elif isinstance(a, float):
        assert a == b or (math.isnan(a) and math.isnan(b)), f"{where}: {a!r} != {b!r}"
        assert math.copysign(1.0, a) == math.copysign(1.0, b), where
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


def _assert_same_dict(a: dict, b: dict, where: str) -> None:
    assert list(a) == list(b), f"{where}: keys {list(a)} != {list(b)}"
    for k in a:
        _assert_same_value(a[k], b[k], f"{where}.{k}")


def assert_identical_graphs(a: nx.MultiGraph, b: nx.MultiGraph) -> None:
    """Node for node and edge for edge: ids, order, neighbour and key order, attribute
    order, types, dtypes, values (bit for bit) and writability."""
    assert type(a) is type(b) is nx.MultiGraph
    _assert_same_dict(a.graph, b.graph, "graph")
    assert [type(n) for n in a] == [type(n) for n in b] and list(a) == list(b)
    for n in a:
        _assert_same_dict(a.nodes[n], b.nodes[n], f"node {n}")
        assert list(a.adj[n]) == list(b.adj[n]), f"neighbours of {n}"
        for m in a.adj[n]:
            assert list(a.adj[n][m]) == list(b.adj[n][m]), f"keys of {n}-{m}"
    ea = list(a.edges(keys=True, data=True))
    eb = list(b.edges(keys=True, data=True))
    assert [(u, v, k, type(k)) for u, v, k, _ in ea] == [(u, v, k, type(k)) for u, v, k, _ in eb]
    for (u, v, k, da), (_, _, _, db) in zip(ea, eb, strict=True):
        _assert_same_dict(da, db, f"edge {u}-{v}-{k}")


def _assert_exports_match_references(mapper: IncrementalMapper) -> None:
    from topojax.incremental._graph_export import export_graph

    ref = _reference_graph(mapper)
    assert_identical_graphs(export_graph(mapper), ref)
    assert_identical_graphs(mapper.graph, ref.copy())  # the property hands out copies
    assert_identical_graphs(mapper.graph_global, _reference_global_graph(mapper))


def test_graph_exports_equal_one_networkx_call_per_vertex_and_edge():
    """mapper.graph and graph_global are built from a GraphStore of the mapper's tables;
    they equal the graphs of one add_node / add_edge per vertex and edge (values computed
    one by one): on an empty mapper, at every graph update of the intel excerpt, and on
    the intel map added at once."""
    empty = IncrementalMapper()
    _assert_exports_match_references(empty)
    assert empty.graph.graph == {
        "resolution_m": 0.05,
        "shape": (0, 0),
        "merge_junction_clusters": False,
    }
    mapper = IncrementalMapper(skeleton_every=4, graph_every=8)
    updates = 0
    for s in read_carmen(INTEL_EXCERPT):
        if "graph" in mapper.add_scan(s).loops:
            updates += 1
            _assert_exports_match_references(mapper)
    assert updates == 5 and mapper.graph.number_of_edges() > 300
    whole = sample_map("intel")
    prior = IncrementalMapper(resolution_m=whole.resolution_m, graph_every=None)
    prior.add_map(whole)
    prior.update_graph()
    assert prior.graph.number_of_nodes() > 200
    _assert_exports_match_references(prior)


def test_run_means_are_ndarray_means_bit_for_bit():
    """The export's mean clearances: runs of one length averaged as the rows of one array
    give ``values[a:b].mean()`` bit for bit (np.add.reduceat would not)."""
    from topojax.incremental._graph_export import _run_means, _run_min

    rng = np.random.default_rng(7)
    lens = np.concatenate([rng.integers(1, 300, 400), np.full(300, 37), np.full(50, 1)])
    rng.shuffle(lens)
    offsets = np.concatenate([[0], np.cumsum(lens)])
    values = rng.uniform(0.0, 5.0, offsets[-1]) * 0.05
    values[5] = np.inf
    want = [values[a:b].mean() for a, b in zip(offsets[:-1], offsets[1:], strict=True)]
    assert _run_means(values, offsets).tobytes() == np.array(want).tobytes()
    reduceat = np.add.reduceat(values, offsets[:-1]) / lens
    assert (reduceat != np.array(want)).any()  # why the rows
    lows = [values[a:b].min() for a, b in zip(offsets[:-1], offsets[1:], strict=True)]
    assert _run_min(values, offsets).tolist() == lows
    none = np.zeros(1, np.int64)
    assert _run_means(values[:0], none).shape == _run_min(values[:0], none).shape == (0,)


def _dense_store(mapper: IncrementalMapper):
    """``mapper.graph``'s store computed from the dense exports over the bounding box
    (``occupancy``, ``sq_distance_px``, ``obstacles``) with ``clearance_at``."""
    from topojax.graph import GraphStore, path_lengths_m
    from topojax.incremental._graph_export import _run_means, _run_min
    from topojax.incremental._graph_store import edge_ids, edge_paths, vertex_ids
    from topojax.incremental._tiles import _unpack
    from topojax.pipeline import clearance_at

    res = mapper.resolution_m
    r0, c0, r1, c1 = mapper.pixel_bbox
    occ = mapper.occupancy
    d2, obstacles = mapper.sq_distance_px, mapper.obstacles

    def clearance_m(pix: np.ndarray) -> np.ndarray:
        flat = pix[:, 0].astype(np.intp) * d2.shape[1] + pix[:, 1].astype(np.intp)
        return clearance_at(d2, obstacles, mapper._half, flat).astype(np.float64) * res

    def world(pix: np.ndarray) -> np.ndarray:
        return np.stack(occ.pixel_to_world(pix[:, 0], pix[:, 1]), axis=1)

    nodes, edges = vertex_ids(mapper), edge_ids(mapper)
    node_pixel = np.stack(_unpack(mapper._v_key[nodes]), axis=1) - [r0, c0]
    paths, lens = edge_paths(mapper, edges)
    paths = paths.astype(np.int64) - [r0, c0]
    offsets = np.concatenate([[0], np.cumsum(lens)]).astype(np.int64)
    path_clearance = clearance_m(paths)
    ends = np.searchsorted(nodes, mapper._e_uv[edges])
    return GraphStore(
        node_pixel=node_pixel,
        node_kind=mapper._v_code[nodes],
        node_world=world(node_pixel),
        node_clearance_m=clearance_m(node_pixel),
        edge_u=ends[:, 0],
        edge_v=ends[:, 1],
        path_offsets=offsets,
        path_pixels=paths,
        path_world=world(paths),
        edge_length_m=path_lengths_m(paths, offsets[:-1], lens, res),
        edge_min_clearance_m=_run_min(path_clearance, offsets),
        edge_mean_clearance_m=_run_means(path_clearance, offsets),
        attrs={
            "resolution_m": res,
            "shape": (r1 - r0, c1 - c0),
            "merge_junction_clusters": False,
            "origin": tuple(float(v) for v in occ.origin),
            "thinning": mapper.config.skeleton.thinning,
        },
        node_ids=nodes,
        edge_keys=edges,
    )


def _far_pixels(mapper: IncrementalMapper) -> int:
    """Graph pixels (vertices and path pixels) beyond the window half-width, where the
    exact clearance needs a search for the nearest obstacle."""
    from topojax.incremental._graph_store import edge_ids, edge_paths, vertex_ids
    from topojax.incremental._tiles import _unpack

    r0, c0, _, _ = mapper.pixel_bbox
    paths, _ = edge_paths(mapper, edge_ids(mapper))
    nodes = np.stack(_unpack(mapper._v_key[vertex_ids(mapper)]), axis=1)
    pix = np.concatenate([nodes, paths]) - [r0, c0]
    return int((mapper.sq_distance_px[pix[:, 0], pix[:, 1]] > mapper._half**2).sum())


def assert_graph_is_the_dense_export(mapper: IncrementalMapper) -> None:
    """``mapper.graph`` (read from the tiles at its pixels) equals the export from the
    dense maps over the bounding box: every store field bit for bit, attributes too."""
    import dataclasses

    from topojax.graph import GraphStore
    from topojax.incremental._graph_export import export_store

    got, want = export_store(mapper), _dense_store(mapper)
    for f in dataclasses.fields(GraphStore):
        a, b = getattr(got, f.name), getattr(want, f.name)
        if isinstance(a, np.ndarray):
            assert (a.dtype, a.shape) == (b.dtype, b.shape), f.name
            assert a.tobytes() == b.tobytes(), f.name
        elif isinstance(a, dict):
            _assert_same_dict(a, b, f.name)
        else:
            assert a is b is None, f.name
    assert_identical_graphs(mapper.graph, want.to_networkx().copy())  # handed out as copies


#: Windows of 8 px (0.4 m): most of the graph of the intel excerpt lies beyond them.
NARROW_KW = {"distance": DistanceConfig(sigma_px=8.0, half_width_px=8)}


def test_graph_from_the_tiles_equals_the_dense_export():
    """The graph export reads the tiles at the graph's pixels; it equals the export from
    the dense maps bit for bit at every graph update of a replayed log: with the
    default window (no graph pixel beyond it), a window of 8 px (many beyond it: the
    dense clearance takes the whole map's transform) and a synthetic world of 1 m
    windows (a few beyond it: the dense clearance searches around each)."""
    cases = [
        ({}, read_carmen(INTEL_EXCERPT), (0, 0)),
        (NARROW_KW, read_carmen(INTEL_EXCERPT), (65, None)),
        (SMALL_KW, synthetic_scans(2, 12), (1, 64)),
    ]
    for kwargs, scans, (lo, hi) in cases:
        mapper = IncrementalMapper(skeleton_every=4, graph_every=8, **kwargs)
        far = []
        for s in scans:
            if "graph" in mapper.add_scan(s).loops:
                assert_graph_is_the_dense_export(mapper)
                far.append(_far_pixels(mapper))
        assert len(far) >= 1 and mapper.graph.number_of_edges() > 0
        assert lo <= max(far) and (hi is None or max(far) <= hi), far


def test_clearance_from_the_tiles_equals_the_dense_clearance_at_every_pixel():
    """The export's clearance, read from the tiles, equals ``clearance_at`` of the dense
    maps at every pixel of maps with open space far beyond the window (no obstacle in
    some windows: the search widens until it holds the nearest obstacle), at a few
    pixels beyond it (the tiles near them only) and on a map without obstacles (inf)."""
    from topojax.incremental._clearance import pixel_clearance_m
    from topojax.pipeline import clearance_at

    occupied = np.zeros((90, 120), bool)
    occupied[[0, -1], :40] = occupied[:, [0, 39]] = True
    occupied[40:45, 80:84] = True
    scattered = np.random.default_rng(5).random((150, 200)) < 0.001
    cases = {"open": occupied, "scattered": scattered, "empty": np.zeros_like(occupied)}
    for name, occ in cases.items():
        mapper = IncrementalMapper(skeleton_every=0, graph_every=0, **SMALL_KW)
        mapper.add_map(
            OccupancyMap(
                occupied=occ,
                free=~occ,
                unknown=np.zeros_like(occ),
                resolution_m=0.1,
                origin=(-4.0, -3.0, 0.0),
            )
        )
        r0, c0, r1, c1 = mapper.pixel_bbox
        d2, obstacles = mapper.sq_distance_px, mapper.obstacles
        rows, cols = (g.ravel() for g in np.mgrid[r0:r1, c0:c1])
        few = np.flatnonzero((d2.ravel() > 10**2) & (d2.ravel() < FAR_SQ))[::7][:40]
        unbounded = np.flatnonzero(d2.ravel() == FAR_SQ)[::97][:40]
        near = np.flatnonzero(d2.ravel() <= 10**2)
        for pick in (np.arange(rows.size), few, unbounded, near):
            want = clearance_at(d2, obstacles, mapper._half, pick).astype(np.float64) * 0.1
            got = pixel_clearance_m(mapper, np.stack([rows[pick], cols[pick]], axis=1))
            assert got.tobytes() == want.tobytes(), name
            if name == "empty":
                assert np.isinf(got).all() and not obstacles.any()
        assert unbounded.size >= 20
        if name == "empty":
            assert few.size == near.size == 0
        else:
            assert 20 <= few.size <= 64


def test_sparse_wide_map_exports_its_graph_within_a_small_budget():
    """Two patches 400 m apart (a bounding box of about 9,200 x 1,150 px, five times the
    tiles' area): the graph exports within a budget far below the bounding box's dense
    export, the same graph as the dense export; the dense maps stay refused."""
    import dataclasses

    from topojax.incremental import ExportBudgetError

    scans = list(read_carmen(INTEL_EXCERPT))
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, max_export_bytes=8 << 20)
    for s in scans[:20]:
        mapper.add_scan(s)
    for s in scans[20:]:
        x, y, yaw = s.pose
        mapper.add_scan(dataclasses.replace(s, pose=(x + 400.0, y, yaw)))
    mapper.update_graph()
    r0, c0, r1, c1 = mapper.pixel_bbox
    assert (r1 - r0) * (c1 - c0) * 24 > 16 * mapper.max_export_bytes
    assert mapper.n_tiles * mapper.tile_px**2 < (r1 - r0) * (c1 - c0) / 4
    for name in ("occupancy", "sq_distance_px", "obstacles"):
        with pytest.raises(ExportBudgetError, match=rf"mapper\.{name}: refused"):
            getattr(mapper, name)
    graph = mapper.graph
    xs = [d["world"][0] for _, d in graph.nodes(data=True)]
    assert min(xs) < 50.0 and max(xs) > 400.0  # both patches
    mapper.max_export_bytes = 2**31  # the dense export, for the comparison
    assert_graph_is_the_dense_export(mapper)


# --------------------------------------------------------------------------------------
# guard rails: max_extent_m, max_export_bytes, occupancy_window
# --------------------------------------------------------------------------------------

_FAR_JUMP = """
import dataclasses, resource, sys
import numpy as np
import topojax as tj
from topojax.incremental import IncrementalMapper
scans = list(tj.read_scans(sys.argv[1]))
mapper = IncrementalMapper(skeleton_every=0, graph_every=0)
mapper.add_scans(scans)
before = mapper.occupancy
last = scans[-1]
x, y, yaw = last.pose
far = dataclasses.replace(last, pose=(x + 100_000.0, y, yaw))
peak0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
try:
    mapper.add_scan(far)
    print("accepted")
except ValueError as exc:
    print("refused:", exc)
after = mapper.occupancy
peak1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
same = all(
    np.array_equal(getattr(before, k), getattr(after, k)) for k in ("occupied", "free", "unknown")
)
print("same:", same, before.origin == after.origin, mapper.n_scans)
print("growth_kib:", peak1 - peak0)
"""


def test_far_jump_is_refused_with_bounded_memory():
    """A scan whose pose is 100 km off (a localisation glitch) is refused before anything
    changes, naming its index, timestamp and pose; the attempt and the next export keep the
    process's peak resident memory where it was (a fresh process: a clean peak)."""
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", _FAR_JUMP, str(INTEL_EXCERPT)],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
    ).stdout
    lines = dict(line.split(": ", 1) for line in out.strip().splitlines())
    refused = lines["refused"]
    assert refused.startswith("scan 40 (timestamp ")
    assert "100012.7253" in refused and "max_extent_m=2000" in refused
    assert "nothing was added" in refused
    assert lines["same"] == "True True 40"
    assert int(lines["growth_kib"]) < 200 * 1024


def test_max_extent_refuses_points_and_maps_before_any_change():
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, max_extent_m=20.0, **SMALL_KW)
    mapper.add_scan(synthetic_scans(3, 1, bad=False)[0])
    before = {k: v.copy() for k, v in mapper.tiles.state().items()}
    with pytest.raises(ValueError, match=r"points_xy: the points \(scan 1\).*max_extent_m=20"):
        mapper.add_points(np.array([[40.0, 0.0]]))
    far = Scan.from_arrays(np.ones(3), (30.0, 0.0, 0.0), angle_min=0, angle_increment=0.1)
    with pytest.raises(ValueError, match=r"^scan 1: the pose \(30.0, 0.0, 0.0\).*max_extent_m"):
        mapper.add_scan(far)
    occupied = np.zeros((400, 20), bool)
    occupied[::50, 5] = True
    big = OccupancyMap(
        occupied=occupied,
        free=~occupied,
        unknown=np.zeros_like(occupied),
        resolution_m=0.1,
        origin=(0.0, 0.0, 0.0),
    )
    with pytest.raises(ValueError, match="occupancy: the map.*max_extent_m=20"):
        mapper.add_map(big)
    after = mapper.tiles.state()
    assert before.keys() == after.keys()
    for k in before:
        np.testing.assert_array_equal(before[k], after[k], err_msg=k)
    assert mapper.n_scans == 1
    # within the extent: accepted
    mapper.add_points(np.array([[3.0, 1.0]]))
    assert mapper.n_scans == 2


def test_export_budget_refuses_and_names_the_window():
    scans = list(read_carmen(INTEL_EXCERPT))[:10]
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, max_export_bytes=10_000)
    mapper.add_scans(scans)
    for name in ("occupancy", "distance", "sq_distance_px", "obstacles", "skeleton"):
        with pytest.raises(
            ValueError,
            match=rf"mapper.{name}:.*max_export_bytes=10000.*"
            r"occupancy_window\(\(x_min, y_min, x_max, y_max\)\)",
        ):
            getattr(mapper, name)
    with pytest.raises(ValueError, match="mapper.to_result:.*max_export_bytes"):
        mapper.to_result()
    with pytest.raises(ValueError, match="mapper.route_graph:.*max_export_bytes"):
        mapper.route_graph()
    with pytest.raises(ValueError, match="mapper.occupancy_window:.*max_export_bytes"):
        mapper.occupancy_window((-10.0, -10.0, 10.0, 10.0))
    small = mapper.occupancy_window((0.0, 0.0, 1.0, 1.0))  # 20 x 20 px: within the budget
    assert small.shape == (20, 20)
    # under a MiB the need is given in bytes, not as "about 0 MiB"; a window refused
    # points to a smaller window, not to occupancy_window as if it were another export
    with pytest.raises(ValueError, match=r"about 16,000 bytes for 40 x 40 px.*smaller window"):
        mapper.occupancy_window((0.0, 0.0, 2.0, 2.0))


def test_occupancy_window_equals_the_crop_of_the_full_export():
    scans = list(read_carmen(INTEL_EXCERPT))
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0)
    mapper.add_scans(scans)
    full = mapper.occupancy
    res = mapper.resolution_m
    for bbox in ((-3.02, -7.51, 9.0, 4.49), (-100.0, -3.0, -5.0, 80.0), (1.0, 1.0, 1.07, 1.07)):
        win = mapper.occupancy_window(bbox)
        # the pixel holding the window's top-left corner, in both maps
        r0, c0 = (int(v) for v in mapper.world_to_pixel(bbox[0], bbox[3]))
        fr0, fc0 = r0 - mapper.pixel_bbox[0], c0 - mapper.pixel_bbox[1]
        h, w = win.shape
        assert (h, w) == (
            math.ceil(-bbox[1] / res) - r0,
            math.ceil(bbox[2] / res) - c0,
        )
        np.testing.assert_allclose(win.pixel_to_world(0, 0), full.pixel_to_world(fr0, fc0))
        np.testing.assert_allclose(
            win.pixel_to_world(h - 1, w - 1), full.pixel_to_world(fr0 + h - 1, fc0 + w - 1)
        )
        # the overlap equals the crop; the rest is unknown
        a0, b0 = max(fr0, 0), max(fc0, 0)
        a1, b1 = min(fr0 + h, full.shape[0]), min(fc0 + w, full.shape[1])
        for k in ("occupied", "free", "unknown"):
            expect = np.zeros((h, w), bool) if k != "unknown" else np.ones((h, w), bool)
            if a1 > a0 and b1 > b0:
                expect[a0 - fr0 : a1 - fr0, b0 - fc0 : b1 - fc0] = getattr(full, k)[a0:a1, b0:b1]
            np.testing.assert_array_equal(getattr(win, k), expect, err_msg=k)
    assert mapper.occupancy_window((-100.0, -3.0, -5.0, 80.0)).occupied.any()


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"max_extent_m": 0.0}, ValueError, "max_extent_m: expected a finite number of metres"),
        ({"max_extent_m": -5}, ValueError, "max_extent_m:.*received -5"),
        ({"max_extent_m": float("inf")}, ValueError, "max_extent_m"),
        ({"max_extent_m": "2 km"}, TypeError, "max_extent_m:.*received str"),
        ({"max_export_bytes": 0}, ValueError, "max_export_bytes: expected an int >= 1"),
        ({"max_export_bytes": 1.5e9}, TypeError, "max_export_bytes: expected an int >= 1"),
        ({"max_export_bytes": True}, TypeError, "max_export_bytes"),
        ({"max_tile_bytes": 0}, ValueError, "max_tile_bytes: expected an int >= 1"),
        ({"max_tile_bytes": "2 GiB"}, TypeError, "max_tile_bytes"),
    ],
)
def test_guard_settings_are_checked(kwargs, error, message):
    with pytest.raises(error, match=message):
        IncrementalMapper(**kwargs)


def test_occupancy_window_bad_bbox_is_refused():
    mapper = IncrementalMapper(**SMALL_KW)
    mapper.add_scan(synthetic_scans(3, 1, bad=False)[0])
    for bbox in ((0, 0, 1), (0, 0, 1, "x"), "abcd", None, (1, 0, 0, 1), (0, 1, 1, 1)):
        with pytest.raises(ValueError, match="bbox: expected"):
            mapper.occupancy_window(bbox)
    with pytest.raises(ValueError, match="bbox: expected .* finite"):
        mapper.occupancy_window((0, 0, np.inf, 1))
    with pytest.raises(ValueError, match="bbox: .*beyond"):
        mapper.occupancy_window((0, 0, 1e300, 1))
    with pytest.raises(ValueError, match=r"bbox: expected a window of at least 2 x 2.*1 x 1 px"):
        mapper.occupancy_window((0.01, 0.01, 0.02, 0.02))
    # an empty mapper: a window is all unknown
    empty = IncrementalMapper(**SMALL_KW).occupancy_window((0.0, 0.0, 1.0, 2.0))
    assert empty.shape == (20, 10) and empty.unknown.all()


def test_guard_settings_are_saved_and_default_for_old_states(tmp_path):
    mapper = IncrementalMapper(
        max_extent_m=123.0, max_export_bytes=4567, max_tile_bytes=10**8, **SMALL_KW
    )
    mapper.add_scan(synthetic_scans(3, 1, bad=False)[0])
    path = mapper.save(tmp_path / "state.npz")
    loaded = IncrementalMapper.load(path)
    assert (loaded.max_extent_m, loaded.max_export_bytes) == (123.0, 4567)
    assert loaded.max_tile_bytes == 10**8
    # a state saved before these settings existed loads with the defaults
    with np.load(path, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    settings = json.loads(str(data["settings"]))
    del settings["max_extent_m"], settings["max_export_bytes"], settings["max_tile_bytes"]
    data["settings"] = np.asarray(json.dumps(settings))
    old = tmp_path / "old.npz"
    np.savez_compressed(old, **data)
    loaded = IncrementalMapper.load(old)
    assert (loaded.max_extent_m, loaded.max_export_bytes) == (2000.0, 2**31)
    assert loaded.max_tile_bytes == 2**31


def _state_of(mapper) -> dict:
    return {k: v.copy() for k, v in mapper.tiles.state().items()}


def _assert_same_state(before: dict, mapper) -> None:
    after = mapper.tiles.state()
    assert before.keys() == after.keys()
    for k in before:
        np.testing.assert_array_equal(before[k], after[k], err_msg=k)


def test_far_readings_and_poses_are_extent_errors_naming_the_scan():
    """Readings or poses so far off that the map could not hold them are refused as
    ExtentError (what a replay skips), naming the scan, its pose and its farthest reading;
    nothing changes."""
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, **SMALL_KW)
    mapper.add_scan(synthetic_scans(3, 1, bad=False)[0])
    before = _state_of(mapper)
    cases = [
        (np.full(5, 1e6), (0.0, 0.0, 0.0), r"readings up to 1e\+06 m.*max_extent_m=2000"),
        (np.ones(5), (1e8, 0.0, 0.0), r"\(100000000.0, 0.0, 0.0\).*max_extent_m"),
        (np.full(5, 1e30), (0.0, 0.0, 0.0), r"readings up to 1e\+30 m.*beyond 1073741824 px"),
        (np.ones(5), (1e300, 0.0, 0.0), r"beyond 1073741824 px"),
    ]
    for ranges, pose, message in cases:
        scan = Scan.from_arrays(ranges, pose, angle_min=0.0, angle_increment=0.3)
        with pytest.raises(ExtentError, match=r"^scan 1: the pose .*" + message):
            mapper.add_scan(scan)
    with pytest.raises(ExtentError, match=r"^points_xy: the points \(scan 1\) put pixels beyond"):
        mapper.add_points(np.array([[1e12, 0.0]]))
    # beyond max_grid_cells (a smaller bound than the extent here)
    tight = IncrementalMapper(skeleton_every=0, graph_every=0, max_grid_cells=50, **SMALL_KW)
    with pytest.raises(ExtentError, match=r"^scan 0: .*max_grid_cells.*nothing was added"):
        tight.add_scan(
            Scan.from_arrays(np.full(5, 50.0), (0, 0, 0), angle_min=0, angle_increment=1)
        )
    _assert_same_state(before, mapper)
    assert mapper.n_scans == 1 and tight.n_scans == 0


def test_a_sensor_beyond_the_pixel_range_is_an_extent_error():
    """A sensor pose whose pixel overflows (x / resolution beyond float64; an offset, at
    most 100 m, moves no finite pose beyond it) is an extent error, not an OverflowError
    from math.floor: the sensor's pixel is checked like the readings' (also without
    valid readings: the rays would start there); nothing changes and the next scan maps
    as if the refused ones never came."""
    ref = IncrementalMapper(skeleton_every=0, graph_every=0, **SMALL_KW)
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0, **SMALL_KW)
    first, second = synthetic_scans(3, 2, bad=False)
    ref.add_scan(first)
    mapper.add_scan(first)
    before = _state_of(mapper)
    beyond = r"put the sensor at \({}, 0\) m, beyond 1073741824 px.*nothing was added"
    cases = [
        (np.ones(5), (1.7e308, 0.0, 0.0), (100.0, 0.0, 0.0), beyond.format(r"1\.7e\+308")),
        (np.ones(5), (1e308, 0.0, 0.0), (0.0, 0.0, 0.0), beyond.format(r"1e\+308")),
        (np.full(5, np.nan), (1e308, 0.0, 0.0), (0.0, 0.0, 0.0), beyond.format(r"1e\+308")),
        (np.full(5, np.nan), (1e12, 0.0, 0.0), (0.0, 0.0, 0.0), beyond.format(r"1e\+12")),
    ]
    for ranges, pose, offset, message in cases:
        scan = Scan.from_arrays(
            ranges, pose, angle_min=0.0, angle_increment=0.3, sensor_offset=offset
        )
        with pytest.raises(ExtentError, match=r"^scan 1: the pose .*" + message):
            mapper.add_scan(scan)
    for origin in ((1.7e308, 0.0), (1e12, 0.0)):
        with pytest.raises(ExtentError, match=r"^origin_xy: the points \(scan 1\) put the sensor"):
            mapper.add_points(np.array([[1.0, 0.0]]), origin_xy=origin)
    _assert_same_state(before, mapper)
    assert mapper.n_scans == 1
    ref.add_scan(second)
    mapper.add_scan(second)
    ref.update_graph()
    mapper.update_graph()
    _assert_same_state(_state_of(ref), mapper)
    assert sorted(ref.graph.edges(keys=True)) == sorted(mapper.graph.edges(keys=True))


def test_rooms_over_the_export_budget_do_not_fail_the_scan_that_made_them_due():
    """Rooms in use, a relocalisation 300 m off grows the map past max_export_bytes: the
    scans are mapped and reported (with the graph loop), the rooms stay as they were with
    a warning (once while the map stays too large); asking for fresh rooms raises the
    budget error."""
    import warnings

    from topojax.incremental import ExportBudgetError

    scans = list(read_carmen(INTEL_EXCERPT))
    mapper = IncrementalMapper(skeleton_every=2, graph_every=2, max_export_bytes=64 << 20)
    for s in scans[:6]:
        mapper.add_scan(s)
    rooms = mapper.rooms
    far = [
        Scan.from_arrays(
            s.ranges,
            (s.pose[0] + 300.0, s.pose[1], s.pose[2]),
            angle_min=s.angle_min,
            angle_increment=s.angle_increment,
            range_max=s.range_max,
        )
        for s in scans[6:10]
    ]
    assert "graph" not in mapper.add_scan(far[0]).loops
    with pytest.warns(RuntimeWarning, match=r"^scan 7: rooms not updated.*max_export_bytes"):
        report = mapper.add_scan(far[1])
    assert mapper.n_scans == 8 and report.index == 7
    assert "graph" in report.loops and "rooms" not in report.loops
    assert report.rooms_update is None and report.n_valid > 0
    assert mapper.rooms is rooms
    with warnings.catch_warnings(record=True) as caught:  # the next due update: no repeat
        warnings.simplefilter("always")
        reports = [mapper.add_scan(s) for s in far[2:]]
    assert "graph" in reports[-1].loops and not caught
    with pytest.raises(ExportBudgetError, match=r"mapper\.rooms: refused to allocate"):
        mapper.update_rooms()


def test_tile_budget_refuses_scans_points_and_maps_before_any_change():
    """``max_tile_bytes`` bounds the memory the tiles may take: a scan whose beams would
    allocate more tiles (a reading far beyond the sensor's range) is refused before
    anything changes; scans within the budget go on being mapped."""
    probe = IncrementalMapper(**SMALL_KW)
    tile_bytes = probe.tiles.tile_nbytes
    mapper = IncrementalMapper(
        skeleton_every=0, graph_every=0, max_tile_bytes=60 * tile_bytes, **SMALL_KW
    )
    mapper.add_scan(synthetic_scans(3, 1, bad=False)[0])
    before = _state_of(mapper)
    n_tiles = mapper.tiles.n_tiles
    assert n_tiles < 60
    long = Scan.from_arrays(np.full(40, 80.0), (0, 0, 0), angle_min=0.0, angle_increment=0.15)
    with pytest.raises(ExtentError, match=r"^scan 1: .*readings up to 80 m.*max_tile_bytes="):
        mapper.add_scan(long)
    with pytest.raises(ExtentError, match=r"points_xy: .*max_tile_bytes"):
        mapper.add_points(np.stack([np.linspace(-60, 60, 200), np.full(200, 30.0)], 1))
    free = np.ones((600, 600), bool)
    big = OccupancyMap(
        occupied=np.zeros_like(free),
        free=free,
        unknown=~free,
        resolution_m=0.1,
        origin=(-30.0, -30.0, 0.0),
    )
    with pytest.raises(ExtentError, match=r"occupancy: the map .*max_tile_bytes"):
        mapper.add_map(big)
    _assert_same_state(before, mapper)
    assert mapper.n_scans == 1
    mapper.add_scan(
        Scan.from_arrays(np.full(40, 2.0), (0, 0, 0), angle_min=0, angle_increment=0.15)
    )
    assert mapper.n_scans == 2 and mapper.tiles.n_tiles * tile_bytes <= 60 * tile_bytes
    # the splat windows round new obstacles count too: a few points far apart each need
    # the tiles of a window, not one tile
    corners = np.array([[0.0, 0.0], [30.0, 0.0], [0.0, 30.0], [30.0, 30.0]])
    for budget in range(4, 400):
        fresh = IncrementalMapper(max_tile_bytes=budget * tile_bytes, **SMALL_KW)
        try:
            fresh.add_points(corners)
        except ExtentError:
            assert fresh.tiles.n_tiles == 0
            continue
        assert fresh.tiles.n_tiles <= budget
        break
    assert budget > 4 * 4  # every point's window spans several tiles


def test_a_tile_budget_of_any_size_is_taken():
    # the count of a scan's missing tiles is bounded by the budget: one past an int64
    with pytest.warns(UserWarning, match="max_tile_bytes: .* is more than the"):
        mapper = IncrementalMapper(max_tile_bytes=10**30, **SMALL_KW)
    scan = Scan.from_arrays(np.full(90, 3.0), (0, 0, 0), angle_min=-1.5, angle_increment=1 / 30)
    mapper.add_scan(scan)
    mapper.add_scan(scan)
    assert mapper.n_scans == 2 and mapper.tiles.n_tiles > 0


def test_limits_above_the_memory_available_warn_that_they_guard_nothing(monkeypatch):
    """A tile or export limit given above the memory available is taken, with a warning:
    the mapper would be killed for memory before it refused.  Limits that fit, and the
    defaults, say nothing."""
    import warnings

    from topojax.incremental import _settings

    monkeypatch.setattr(_settings, "available_memory_bytes", lambda: 1 << 30)
    with pytest.warns(UserWarning) as caught:
        mapper = IncrementalMapper(max_tile_bytes=3 << 30, max_export_bytes=3 << 30, **SMALL_KW)
    assert [str(w.message).split(":")[0] for w in caught] == ["max_tile_bytes", "max_export_bytes"]
    assert str(caught[0].message) == (
        "max_tile_bytes: 3.0 GiB is more than the 1.0 GiB of memory available; the mapper "
        "may be killed for memory before it refuses a scan (a smaller max_tile_bytes "
        "refuses first)"
    )
    assert mapper.max_tile_bytes == 3 << 30
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        IncrementalMapper(max_tile_bytes=1 << 29, max_export_bytes=1 << 29, **SMALL_KW)
        IncrementalMapper(**SMALL_KW)  # the defaults (2 GiB each)
        monkeypatch.setattr(_settings, "available_memory_bytes", lambda: None)  # not Linux
        IncrementalMapper(max_tile_bytes=3 << 30, **SMALL_KW)


def test_a_loaded_limit_above_the_memory_available_warns_at_the_caller_s_line(
    tmp_path, monkeypatch
):
    """The warning that a limit guards nothing names the line that made the mapper or
    loaded its state, not the package's own code."""
    import warnings

    from topojax.incremental import _settings

    monkeypatch.setattr(_settings, "available_memory_bytes", lambda: 1 << 30)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mapper = IncrementalMapper(max_export_bytes=3 << 30, **SMALL_KW)
        mapper.add_points(np.array([[1.0, 1.0]]))
        mapper.save(tmp_path / "state.npz")
        IncrementalMapper.load(tmp_path / "state.npz")
    limits = [w for w in caught if str(w.message).startswith("max_export_bytes: ")]
    assert [w.filename for w in limits] == [__file__, __file__]


def test_a_map_over_the_tile_budget_is_refused_before_its_pixels_are_indexed():
    """add_map weighs a map against max_tile_bytes from its masks, a tile row and column
    at a time, not from the indices of its pixels (16 bytes a pixel: 5 GB for a 14000 x
    14000 map before its refusal)."""
    import tracemalloc

    free = np.ones((2000, 2000), bool)
    big = OccupancyMap(
        occupied=np.zeros_like(free), free=free, unknown=~free, resolution_m=0.05, origin=(0, 0, 0)
    )
    probe = IncrementalMapper()
    mapper = IncrementalMapper(max_tile_bytes=100 * probe.tiles.tile_nbytes)
    tracemalloc.start()
    try:
        with pytest.raises(ExtentError, match=r"^occupancy: the map .* 256 more tiles"):
            mapper.add_map(big)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < free.size  # under a byte a pixel
    assert mapper.tiles.n_tiles == 0
    small = np.ones((600, 600), bool)
    mapper.add_map(
        OccupancyMap(
            occupied=~small, free=small, unknown=~small, resolution_m=0.05, origin=(0, 0, 0)
        )
    )
    assert 0 < mapper.tiles.n_tiles <= 100  # the mapper goes on


def test_the_tiles_of_a_wide_far_scan_are_counted_once_and_only_up_to_the_budget():
    """Every beam of a wide scan crosses the tiles its neighbours cross: each tile is
    counted once, and the count stops once it is over the budget (counted once per
    crossing, a scan of a million beams at 300 m needs gigabytes to be refused)."""
    probe = IncrementalMapper(**SMALL_KW)
    tile_bytes = probe.tiles.tile_nbytes
    mapper = IncrementalMapper(
        skeleton_every=0, graph_every=0, max_tile_bytes=30 * tile_bytes, **SMALL_KW
    )
    n = 20_000
    wide = Scan.from_arrays(
        np.full(n, 150.0), (0, 0, 0), angle_min=-math.pi, angle_increment=2 * math.pi / n
    )
    with pytest.raises(ExtentError, match=r"^scan 0: .* would allocate at least 31 more tiles"):
        mapper.add_scan(wide)
    assert mapper.tiles.n_tiles == 0
    near = Scan.from_arrays(
        np.full(n, 2.0), (0, 0, 0), angle_min=-math.pi, angle_increment=2 * math.pi / n
    )
    mapper.add_scan(near)  # the mapper goes on
    assert 0 < mapper.tiles.n_tiles <= 30 and mapper.n_scans == 1


def test_a_wide_far_scan_over_the_tile_budget_is_refused_from_a_spread_of_its_beams(
    monkeypatch,
):
    """A scan of many far beams over the tile budget is refused once the tiles of a spread
    of its beams are over it, without walking every beam (each walk costs work in its
    length); a scan within the budget has every beam's tiles counted and is mapped as
    with no budget."""
    from topojax.incremental import _rays

    walked = []
    real = _rays._missing_ray_tiles

    def counting(sr, sc, er, *args):
        walked.append(er.shape[0])
        return real(sr, sc, er, *args)

    monkeypatch.setattr(_rays, "_missing_ray_tiles", counting)
    tile_bytes = IncrementalMapper(**SMALL_KW).tiles.tile_nbytes
    kw = {"skeleton_every": 0, "graph_every": 0, **SMALL_KW}
    mapper = IncrementalMapper(max_tile_bytes=30 * tile_bytes, **kw)
    n = 20_000
    wide = Scan.from_arrays(
        np.full(n, 150.0), (0, 0, 0), angle_min=-math.pi, angle_increment=2 * math.pi / n
    )
    with pytest.raises(ExtentError, match=r"^scan 0: .* would allocate at least 31 more tiles"):
        mapper.add_scan(wide)
    assert walked and max(walked) < n
    assert mapper.tiles.n_tiles == 0
    narrow = Scan.from_arrays(np.full(n, 150.0), (0, 0, 0), angle_min=0.0, angle_increment=1e-5)
    unbounded = IncrementalMapper(**kw)
    unbounded.add_scan(narrow)
    need = unbounded.tiles.n_tiles
    walked.clear()
    bounded = IncrementalMapper(max_tile_bytes=need * tile_bytes, **kw)
    bounded.add_scan(narrow)
    assert max(walked) == n and min(walked) < n  # the spread first, then every beam
    _assert_same_state(_state_of(unbounded), bounded)


@pytest.mark.parametrize(
    ("glitch", "message"),
    [
        ("pose", "--max-extent-m=2000"),
        ("pose_1e8", "beyond 1073741824 px"),
        ("readings", "readings up to 1e+06 m"),
    ],
)
def test_replay_skips_a_scan_far_off_and_goes_on(tmp_path, capsys, glitch, message):
    """A localisation glitch in a log (one pose 100 km or 100,000 km off, or readings
    of 1000 km) does not end the replay: the scan is skipped with the refusal's message,
    the others are mapped."""
    import gzip

    from topojax.cli import main

    lines = gzip.open(INTEL_EXCERPT, "rt").read().splitlines()
    n = 0
    for k, line in enumerate(lines):
        if line.startswith("FLASER"):
            n += 1
            if n == 20:
                f = line.split()
                count = int(f[1])
                if glitch == "readings":
                    f[2 : 2 + count // 2] = ["1000000.0"] * (count // 2)
                else:  # x of the laser pose and of the odometry pose
                    shift = 100_000.0 if glitch == "pose" else 1e8
                    for j in (2 + count, 2 + count + 3):
                        f[j] = str(float(f[j]) + shift)
                lines[k] = " ".join(f)
    log = tmp_path / "glitch.log"
    log.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    # readings of 1000 km are kept (else the reader drops them as faulty, test_scans.py)
    keep = ["--max-range", "2e6"] if glitch == "readings" else []
    args = ["replay", str(log), "-o", str(out), "--no-progress", "--graph-every", "20", *keep]
    code = main(args)
    assert code == 0
    text = capsys.readouterr().out
    assert "skipped scan 19" in text and message in text
    summary = json.loads((out / "timings.json").read_text())
    assert summary["n_scans"] == 39
    assert len(summary["skipped_scans"]) == 1


def test_replay_says_the_scans_it_skipped_in_one_line(tmp_path, capsys):
    """With a --max-extent-m that the log outgrows, the scans refused are counted in
    one line with the first refusal; timings.json lists them all."""
    import re

    from topojax.cli import main

    out = tmp_path / "out"
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress"]
    assert main([*args, "--max-extent-m", "50"]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("skipped")]
    summary = json.loads((out / "timings.json").read_text())
    n = len(summary["skipped_scans"])
    assert n > 1 and summary["n_scans"] == 40 - n
    assert len(lines) == 1
    assert re.match(rf"skipped {n} of 40 scans, .*--max-extent-m.*; the first: scan \d+ ", lines[0])
    # the first refusal, in the command's words (timings.json keeps the mapper's)
    first = summary["skipped_scans"][0]
    assert first.split(": ")[0] in lines[0] and "max_extent_m" not in lines[0]


def test_replay_whose_every_scan_is_refused_says_why(tmp_path):
    """At 5 m per pixel the default tiles and distance window alone are wider than
    ``max_extent_m``: every scan is refused, and the error says so with the first
    refusal and what to change, not that the log holds no scans."""
    with pytest.raises(
        ValueError,
        match=r"all 40 scans were refused; the first: scan 0 .*tiles of 128 px .* "
        r"at 5 m per pixel: make the mapper with a smaller tile_px or sigma",
    ):
        replay(INTEL_EXCERPT, out_dir=tmp_path / "out", progress=False, resolution_m=5.0)


def test_replay_whose_only_scan_is_refused_says_so_in_the_singular(tmp_path):
    """One scan refused is said in the singular ("the only scan replayed was refused"),
    not as "all 1 scans were refused; the first: ..."."""
    with pytest.raises(
        ValueError, match=r"^source \S+: the only scan replayed was refused: scan 0 "
    ):
        replay(INTEL_EXCERPT, out_dir=tmp_path, progress=False, max_scans=1, resolution_m=5.0)


def test_replay_of_a_map_too_large_to_write_keeps_the_mapper_state(tmp_path):
    """A log whose final map is beyond ``max_export_bytes`` is not lost: the replay saves
    the mapper's state, and its error says where and how to skip the scans that grew
    the map."""
    out = tmp_path / "out"
    with pytest.raises(ValueError, match=r"max_export_bytes=20000\b.*saved to .*max_extent_m"):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, max_export_bytes=20_000)
    state = out / "mapper_state.npz"
    loaded = IncrementalMapper.load(state)
    assert loaded.n_scans == 40
    assert loaded.occupancy_window((0.0, 0.0, 1.0, 1.0)).shape == (20, 20)
    # the route graph's export (64 bytes per pixel) over the budget, the result's (40) not
    r0, c0, r1, c1 = loaded.pixel_bbox
    h, w = r1 - r0, c1 - c0
    state.unlink()
    with pytest.raises(ValueError, match=r"mapper.route_graph: .*saved to"):
        replay(
            INTEL_EXCERPT,
            out_dir=out,
            progress=False,
            route_graph_radius_m=0.3,
            max_export_bytes=50 * h * w,
        )
    assert IncrementalMapper.load(state).n_scans == 40


def _with_export_budget(max_export_bytes: int):
    """``IncrementalMapper`` with another default ``max_export_bytes``."""

    def make(**kw):
        return IncrementalMapper(**{"max_export_bytes": max_export_bytes, **kw})

    return make


def test_replay_of_a_map_too_large_to_write_names_the_scans_it_skipped(tmp_path, capsys):
    """A replay that skipped scans (refused as beyond the mapper's bounds) and then
    finds its map too large to write says so in its error, with the first refusal (no
    summary lists them: none is written); the command names its options once."""
    from topojax import playback
    from topojax.cli import main

    out = tmp_path / "out"
    kw = dict(out_dir=out, progress=False, max_extent_m=50, max_export_bytes=20_000)
    with pytest.raises(ValueError, match=r"saved to .*skipped (\d+) of the 40 scans") as err:
        replay(INTEL_EXCERPT, **kw)
    n = int(re.search(r"skipped (\d+) of the 40 scans", str(err.value))[1])
    assert 0 < n < 40 and IncrementalMapper.load(out / "mapper_state.npz").n_scans == 40 - n
    assert "; the first: scan " in str(err.value)
    assert "a smaller max_extent_m (now 50 m) to skip" in str(err.value)
    assert "--" not in str(err.value) and "topojax replay" not in str(err.value)
    (out / "mapper_state.npz").unlink()
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress"]
    with pytest.MonkeyPatch.context() as mp:
        # the export budget has no option: the command's mapper gets it here
        mp.setattr(playback, "IncrementalMapper", _with_export_budget(20_000))
        assert main([*args, "--max-extent-m", "50"]) != 0
    text = capsys.readouterr().err
    assert f"skipped {n} of the 40 scans" in text and "beyond --max-extent-m=50 m" in text
    assert "a smaller --max-extent-m (now 50 m) to skip" in text
    assert "max_extent_m" not in text and "topojax replay)" not in text


def test_replay_stopped_part_way_keeps_the_mapper_state(tmp_path):
    """A log with an unreadable line part way through raises the reader's error, and the
    scans mapped before it are not lost: their state is saved, with a warning saying
    where; a log unreadable from its first scan leaves no state."""
    lines = gzip.open(INTEL_EXCERPT, "rt").read().splitlines()
    laser = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    bad = lines[laser[35]].split()
    bad[5] = "abc"  # a range that is not a number
    lines[laser[35]] = " ".join(bad)
    log = tmp_path / "bad.log"
    log.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    given_range = {"max_range_m": 50.0}  # no survey of the whole log before the first scan
    with (
        pytest.warns(RuntimeWarning, match=r"stopped after 35 scans; .* saved to .*mapper_state"),
        pytest.raises(ValueError, match=r"bad.log:\d+: malformed FLASER line"),
    ):
        replay(log, out_dir=out, progress=False, reader_kwargs=given_range)
    assert IncrementalMapper.load(out / "mapper_state.npz").n_scans == 35
    lines[laser[0]] = lines[laser[35]]
    log.write_text("\n".join(lines) + "\n")
    (out / "mapper_state.npz").unlink()
    with pytest.raises(ValueError, match="malformed FLASER line"):
        replay(log, out_dir=out, progress=False, reader_kwargs=given_range)
    assert not (out / "mapper_state.npz").exists()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"rooms": "no"}, "rooms: expected a bool, received str 'no'"),
        ({"plot": 1}, "plot: expected a bool"),
        ({"view": None}, "view: expected a bool"),
        ({"out_dir": None}, r"out_dir: expected a path \(str or os.PathLike\), received NoneType"),
        ({"animate": 5}, r"animate: expected a path .*received int"),
        ({"reader_kwargs": [1]}, "reader_kwargs: expected a dict .*received list"),
        ({"animate": "a.png"}, r"animate: expected a GIF file name ending in .gif, .*a.png"),
        # named as the reader's ``path``
        ({"source": "missing.log"}, "^source: no log file or bag there: missing.log$"),
    ],
)
def test_replay_checks_its_options_before_mapping(tmp_path, kwargs, message):
    args = {"source": INTEL_EXCERPT, "out_dir": tmp_path / "out", "progress": False, **kwargs}
    with pytest.raises((TypeError, ValueError, FileNotFoundError), match=message):
        replay(**args)
    assert not (tmp_path / "out").exists()


def test_add_scans_and_save_name_a_bad_argument(tmp_path):
    mapper = IncrementalMapper(**SMALL_KW)
    scan = synthetic_scans(3, 1, bad=False)[0]
    with pytest.raises(TypeError, match=r"scans: expected an iterable of Scan .*received int"):
        mapper.add_scans(5)
    with pytest.raises(TypeError, match=r"scans: .*received Scan; add one scan with add_scan"):
        mapper.add_scans(scan)
    # a path is refused, not iterated character by character, and so is a 0-d array, not
    # left to fail inside NumPy
    for bad, shown in (("intel.log", "str"), (b"intel.log", "bytes"), (np.array(1), "ndarray")):
        with pytest.raises(TypeError, match=rf"^scans: expected an iterable of Scan .*{shown}"):
            mapper.add_scans(bad)
    with pytest.raises(TypeError, match=r"path: expected a path .*received int"):
        mapper.save(5)
    assert mapper.n_scans == 0 and not list(tmp_path.iterdir())


@pytest.mark.parametrize("update", ["no", None, 0, np.array([True])])
def test_to_result_update_is_a_bool(update):
    """``update`` is a bool, not read by its truth value (where "no" would update the
    graph and None would not)."""
    with pytest.raises(TypeError, match="^update: expected a bool, received "):
        IncrementalMapper(**SMALL_KW).to_result(update=update)


def test_world_to_pixel_refuses_what_has_no_pixel():
    """NaN, an infinity or None has no pixel and is refused, not turned into the pixel
    -9223372036854775808 (int64's minimum) with only a NumPy cast warning; a string is
    refused naming the argument, not left to fail inside NumPy."""
    m = IncrementalMapper(resolution_m=0.1)
    assert m.world_to_pixel(0.25, -0.25) == (2, 2)
    for bad, exc in ((math.nan, ValueError), (math.inf, ValueError), (None, TypeError)):
        with pytest.raises(exc, match="^x: expected"):
            m.world_to_pixel(bad, 0.0)
        with pytest.raises(exc, match="^y: expected"):
            m.world_to_pixel([0.0, 1.0], [0.0, bad])
    with pytest.raises(TypeError, match="^x: expected a number or an array of real numbers"):
        m.world_to_pixel("1", 0.0)
    # a finite coordinate whose pixel index does not fit an int64 is refused, not turned
    # into int64's minimum
    assert m.world_to_pixel(-2e17, 9e17) == (-9e18, -2e18)
    for x, y, name in ((1e300, 0.0, "x"), (0.0, [1.0, -1e21], "y"), (-1e19, 0.0, "x")):
        with pytest.raises(
            ValueError, match=rf"^{name}: expected coordinates within 9.2\d+e\+17 m"
        ):
            m.world_to_pixel(x, y)


def test_an_update_stopped_part_way_is_neither_saved_nor_built_on(tmp_path, monkeypatch):
    """A Ctrl-C part way through a skeleton update (the changed ridges taken, the
    skeleton not yet re-thinned) leaves a mapper that holds half an update: the state
    saved, or the map built on, would give a wrong graph.  Saving it, adding to it and
    updating it are refused, saying why."""
    import topojax.incremental.mapper as mapper_module

    scans = list(read_carmen(INTEL_EXCERPT))[:6]
    mapper = IncrementalMapper(skeleton_every=0, graph_every=0)
    for scan in scans[:5]:
        mapper.add_scan(scan)

    def interrupted(*args, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(mapper_module, "skeleton_exact", interrupted)
    with pytest.raises(KeyboardInterrupt):
        mapper.update_graph()
    monkeypatch.undo()
    message = "KeyboardInterrupt stopped a skeleton update part way"
    with pytest.raises(RuntimeError, match=f"cannot save: {message}.*IncrementalMapper.load"):
        mapper.save(tmp_path / "state.npz")
    assert not (tmp_path / "state.npz").exists()
    for call, action in (
        (lambda: mapper.add_scan(scans[5]), "add a scan"),
        (lambda: mapper.add_points([[1.0, 1.0]]), "add a scan"),
        (lambda: mapper.add_map(mapper.occupancy), "add a map"),
        (mapper.update_graph, "update the skeleton"),
        (mapper.update_rooms, "update the rooms"),
    ):
        with pytest.raises(RuntimeError, match=f"cannot {action}: {message}"):
            call()
    assert mapper.n_scans == 5
    # a scan refused before any change (ExtentError) leaves the mapper whole
    whole = IncrementalMapper(max_extent_m=50.0)
    whole.add_scan(scans[0])
    far = Scan.from_arrays(np.full(5, 2.0), (1000.0, 0.0, 0.0), angle_min=0, angle_increment=0.1)
    with pytest.raises(ExtentError):
        whole.add_scan(far)
    whole.add_scan(scans[1])
    whole.save(tmp_path / "whole.npz")
