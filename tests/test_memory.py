"""What build_graph holds and how much memory it takes: fields left out of the result are
computed identical on first access, the graph is held as arrays until networkx is asked
for, and the call's traced peak per map pixel stays bounded."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from floorplans import floor_plan
from test_graph_store import assert_same_graph

import topojax as tj
from topojax.datasets import sample_map
from topojax.fields import dense_fields, ridge_fields
from topojax.fields.ridge_values import at_ridge_pixels, ridge_ranks
from topojax.graph import GraphStore, skeleton_graph_store, skeleton_to_graph
from topojax.pipeline import RESULT_FIELDS


def _noise(side: int, seed: int) -> tj.OccupancyMap:
    occ = np.random.default_rng(seed).random((side, side)) < 0.01
    return tj.OccupancyMap(occupied=occ, free=~occ, unknown=np.zeros_like(occ))


MAPS = {
    "intel": lambda: sample_map("intel"),
    "noise": lambda: _noise(420, 3),
    "plan": lambda: floor_plan(5, size_m=(20.0, 26.0), clutter=2).occupancy,
    "no obstacle": lambda: tj.OccupancyMap.from_array(np.zeros((40, 50), bool)),
    "all obstacle": lambda: tj.OccupancyMap.from_array(np.ones((40, 50), bool)),
}


@pytest.mark.parametrize("name", list(MAPS))
def test_fields_left_out_are_computed_identical_on_first_access(name):
    occupancy = MAPS[name]()
    config = tj.PipelineConfig(graph=tj.GraphConfig(merge_junction_clusters=True))
    full = tj.build_graph(occupancy, config=config, keep="all")
    lean = tj.build_graph(occupancy, config=config, keep=())
    assert lean.graph_store is not None and full.graph_store is not None
    for field in RESULT_FIELDS:
        a, b = getattr(full, field), getattr(lean, field)
        assert a.dtype == b.dtype and a.shape == b.shape, field
        np.testing.assert_array_equal(a, b, err_msg=field)
    assert_same_graph(lean.graph, full.graph)
    np.testing.assert_array_equal(lean.clearance_px, full.clearance_px)


def test_default_keeps_ridges_and_skeleton_and_builds_the_graph_once():
    res = tj.build_graph(sample_map("a_scan"))
    held = res.__dict__
    assert all(isinstance(held[f], np.ndarray) for f in ("ridges", "skeleton"))
    assert not any(isinstance(held[f], np.ndarray) for f in ("distance", "lap_abs"))
    assert not any(isinstance(held[f], np.ndarray) for f in ("sq_distance_px", "graph"))
    graph = res.graph
    assert res.graph is graph  # built on first access, then held
    assert isinstance(res.distance, np.ndarray) and res.distance is res.distance
    assert_same_graph(graph, res.graph_store.to_networkx())
    assert graph.number_of_nodes() == res.graph_store.n_nodes
    assert "held=" in repr(res)


def test_pruned_graph_is_held_as_networkx():
    config = tj.PipelineConfig(graph=tj.GraphConfig(min_spur_m=0.5))
    res = tj.build_graph(sample_map("intel"), config=config)
    assert res.graph_store is None
    assert res.graph.graph["thinning"] == "guo_hall"


def test_keep_names_are_checked():
    occ = sample_map("intel")
    with pytest.raises(ValueError, match="keep.*'graph'"):
        tj.build_graph(occ, keep=("graph",))
    with pytest.raises(ValueError, match='keep: expected "all"'):
        tj.build_graph(occ, keep="distance")
    with pytest.raises(TypeError, match="keep"):
        tj.build_graph(occ, keep=3)


def test_ridge_fields_hold_the_squared_distance_at_ridge_pixels():
    occ = MAPS["plan"]().occupied
    full = dense_fields(occ, tile_px=128, tiles_per_call=3)
    fields, values = ridge_fields(occ, tile_px=128, tiles_per_call=3, outputs=("distance",))
    flat = np.flatnonzero(full.ridges)
    np.testing.assert_array_equal(fields.ridges, full.ridges)
    np.testing.assert_array_equal(fields.distance, full.distance)
    assert fields.sq_distance_px is None and fields.lap_abs is None
    assert values.dtype == np.int32
    np.testing.assert_array_equal(values, full.sq_distance_px.ravel()[flat])
    some = flat[::5]
    np.testing.assert_array_equal(
        at_ridge_pixels(full.ridges, values, some), full.sq_distance_px.ravel()[some]
    )
    assert at_ridge_pixels(full.ridges, values, some[:0]).shape == (0,)


def test_dense_fields_assemble_the_fields_asked_for():
    occ = sample_map("office").occupied
    full = dense_fields(occ)
    some = dense_fields(occ, outputs=["lap_abs", "sq_distance_px"])
    assert some.distance is None and some.ridges is None
    np.testing.assert_array_equal(some.lap_abs, full.lap_abs)
    np.testing.assert_array_equal(some.sq_distance_px, full.sq_distance_px)
    with pytest.raises(ValueError, match="outputs"):
        dense_fields(occ, outputs=("clearance",))


def test_ridge_ranks_count_the_ridge_pixels_before_each_pixel():
    rng = np.random.default_rng(1)
    ridges = rng.random(5000) < 0.3
    flat = np.sort(rng.choice(5000, 200, replace=False))
    np.testing.assert_array_equal(ridge_ranks(ridges, flat), np.cumsum(np.r_[0, ridges])[flat])


def test_thinning_without_a_kept_work_space_is_the_same(monkeypatch):
    import topojax.skeleton as sk

    rng = np.random.default_rng(4)
    img = rng.random((300, 260)) < 0.55
    kept = sk.thin(img)
    monkeypatch.setattr(sk, "_THIN_SCRATCH_MAX_PX", 0)  # as for images over 4 Mpx
    fresh = sk.thin(img)
    assert fresh.dtype == bool and fresh.flags.c_contiguous and fresh.shape == img.shape
    np.testing.assert_array_equal(fresh, kept)
    np.testing.assert_array_equal(sk.thin(img, method="zhang"), sk.thin(img, method="zhang"))


def test_graph_store_of_a_skeleton_is_the_graph_as_arrays():
    res = tj.build_graph(sample_map("intel"), keep=("skeleton",))
    store = skeleton_graph_store(res.skeleton, resolution_m=0.05)
    assert isinstance(store, GraphStore)
    assert_same_graph(store.to_networkx(), skeleton_to_graph(res.skeleton, resolution_m=0.05))


def _traced_peak_per_pixel(occupancy, **kw) -> float:
    tj.build_graph(occupancy, **kw)  # compiled kernels, scratch of this size
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        result = tj.build_graph(occupancy, **kw)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert result.graph_store is not None
    return (peak - base) / occupancy.occupied.size


def test_traced_peak_per_pixel_of_a_floor_plan_is_bounded():
    # about 1000 x 1000 px; NumPy's buffers are traced (not numba's or XLA's).  The
    # fields of keep="all" alone are 10 bytes per pixel.
    plan = floor_plan(7, size_m=(48.0, 48.0), clutter=1).occupancy
    lean = _traced_peak_per_pixel(plan)
    full = _traced_peak_per_pixel(plan, keep="all")
    assert lean <= 6.0, f"{lean:.2f} bytes per pixel"
    assert full - lean >= 8.0, f"{full:.2f} and {lean:.2f} bytes per pixel"
