"""JAX's bfloat16 arrays, where the library takes real numbers: scan ranges, points,
float grids."""

from __future__ import annotations

import math

import numpy as np
import pytest

import topojax as tj

jnp = pytest.importorskip("jax.numpy")


def _bf16(values):
    return jnp.asarray(np.asarray(values, np.float32), jnp.bfloat16)


def test_a_scan_keeps_bfloat16_ranges_as_float32():
    scan = tj.Scan(
        ranges=_bf16([1.0, 2.5, math.inf, math.nan]),
        angle_min=0.0,
        angle_increment=0.1,
        range_min=0.0,
        range_max=10.0,
        pose=(0.0, 0.0, 0.0),
    )
    assert scan.ranges.dtype == np.float32
    assert scan.ranges[:3].tolist() == [1.0, 2.5, math.inf] and math.isnan(scan.ranges[3])


def test_from_array_reads_a_bfloat16_grid_as_probabilities():
    grid = [[0.0, 1.0, 0.5], [0.0, 0.0, 1.0]]
    m = tj.OccupancyMap.from_array(_bf16(grid))
    expected = tj.OccupancyMap.from_array(np.array(grid))
    for name in ("occupied", "free", "unknown"):
        assert np.array_equal(getattr(m, name), getattr(expected, name))
    with pytest.raises(ValueError, match="array"):
        tj.OccupancyMap.from_array(_bf16([[0.0, 2.0], [0.0, 0.0]]))


def test_a_mapper_and_a_map_take_bfloat16_points():
    points = [[1.0, 0.0], [1.0, 0.5]]
    report = tj.IncrementalMapper().add_points(_bf16(points), origin_xy=(0.0, 0.0))
    expected = tj.IncrementalMapper().add_points(np.array(points), origin_xy=(0.0, 0.0))
    assert (report.n_valid, report.n_new_obstacles) == (expected.n_valid, expected.n_new_obstacles)
    assert report.n_valid == 2
    m = tj.OccupancyMap.from_array(np.zeros((3, 3)))
    x, y = m.pixel_to_world(_bf16([1.0]), _bf16([2.0]))
    expected_x, expected_y = m.pixel_to_world(np.array([1.0]), np.array([2.0]))
    assert np.array_equal(x, expected_x) and np.array_equal(y, expected_y)


# ------------------------------------------------------------------ ml_dtypes at the array checks

ml_dtypes = pytest.importorskip("ml_dtypes")

_SKELETON = np.zeros((7, 7), bool)
_SKELETON[3, 1:6] = True
_WALLS = np.ones((16, 16), bool)
_WALLS[1:-1, 1:-1] = False


def _same_graph(a, b) -> bool:
    return sorted(a.nodes(data="pixel")) == sorted(b.nodes(data="pixel")) and sorted(
        (u, v, d["length_m"]) for u, v, d in a.edges(data=True)
    ) == sorted((u, v, d["length_m"]) for u, v, d in b.edges(data=True))


@pytest.mark.parametrize("dtype", [jnp.bfloat16, ml_dtypes.int4, ml_dtypes.uint4])
def test_skeleton_to_graph_takes_ml_dtypes_skeletons_like_float32_and_int8(dtype):
    from topojax.graph import pixel_graph_degree

    expected = tj.skeleton_to_graph(_SKELETON)
    assert _same_graph(tj.skeleton_to_graph(_SKELETON.astype(dtype)), expected)
    assert _same_graph(tj.skeleton_to_graph(jnp.asarray(_SKELETON, dtype)), expected)
    assert np.array_equal(
        pixel_graph_degree(_SKELETON.astype(dtype)), pixel_graph_degree(_SKELETON)
    )
    two = _SKELETON.astype(np.float32) * 2
    with pytest.raises(ValueError, match=r"^skeleton: expected only the values 0 and 1"):
        tj.skeleton_to_graph(two.astype(dtype))


@pytest.mark.parametrize("dtype", [jnp.bfloat16, ml_dtypes.int4, ml_dtypes.uint4])
def test_skeleton_to_graph_takes_ml_dtypes_clearances_and_world_coordinates(dtype):
    clearance = np.full(_SKELETON.shape, 3.0)
    expected = tj.skeleton_to_graph(_SKELETON, clearance_px=clearance)
    for given in (clearance.astype(dtype), lambda flat: clearance.ravel()[flat].astype(dtype)):
        g = tj.skeleton_to_graph(_SKELETON, clearance_px=given)
        assert [d["clearance_m"] for _, d in g.nodes(data=True)] == [
            d["clearance_m"] for _, d in expected.nodes(data=True)
        ]
    g = tj.skeleton_to_graph(
        _SKELETON, pixel_to_world=lambda r, c: (c.astype(dtype), r.astype(dtype))
    )
    assert sorted(d["world"] for _, d in g.nodes(data=True)) == [(1.0, 3.0), (5.0, 3.0)]


def test_pixels_graph_store_takes_int4_indices_and_refuses_bfloat16_ones():
    from topojax.graph import pixels_graph_store

    flat = np.array([1, 2, 3])
    expected = pixels_graph_store((1, 5), flat).to_networkx()
    assert _same_graph(
        pixels_graph_store((1, 5), flat.astype(ml_dtypes.int4)).to_networkx(), expected
    )
    with pytest.raises(TypeError, match=r"^flat: expected a 1-D integer array, received dtype"):
        pixels_graph_store((1, 5), flat.astype(jnp.bfloat16))


@pytest.mark.parametrize("dtype", [jnp.bfloat16, ml_dtypes.int4, ml_dtypes.uint4])
def test_distance_map_takes_ml_dtypes_obstacle_masks_like_float32_and_int8(dtype):
    expected = tj.distance_map(_WALLS)
    assert np.array_equal(tj.distance_map(_WALLS.astype(dtype)), expected)
    assert np.array_equal(tj.distance_map(jnp.asarray(_WALLS, dtype)), expected)
    assert np.array_equal(tj.ridge_map(_WALLS.astype(dtype)), tj.ridge_map(_WALLS))
    with pytest.raises(ValueError, match=rf"^obstacles: expected .* received {np.dtype(dtype)} "):
        tj.distance_map((_WALLS * 3).astype(dtype))


@pytest.mark.parametrize("dtype", [ml_dtypes.int4, ml_dtypes.uint4])
def test_thin_and_from_array_take_4_bit_integers_like_8_bit_ones(dtype):
    eight = np.int8 if dtype == ml_dtypes.int4 else np.uint8
    assert np.array_equal(tj.thin(_SKELETON.astype(dtype)), tj.thin(_SKELETON.astype(eight)))
    grid = np.array([[0, 7], [-1, 7]] if dtype == ml_dtypes.int4 else [[0, 15], [9, 15]])
    m = tj.OccupancyMap.from_array(grid.astype(dtype))
    expected = tj.OccupancyMap.from_array(grid.astype(eight))
    for name in ("occupied", "free", "unknown"):
        assert np.array_equal(getattr(m, name), getattr(expected, name))


def _store_arrays():
    from topojax.graph import skeleton_graph_store

    store = skeleton_graph_store(_SKELETON)
    names = (
        "node_pixel node_kind node_world node_clearance_m edge_u edge_v path_offsets "
        "path_pixels path_world edge_length_m edge_min_clearance_m edge_mean_clearance_m"
    ).split()
    return store, {name: np.asarray(getattr(store, name)) for name in names}


def test_graph_store_takes_bfloat16_reals_and_int4_integers():
    from topojax.graph import GraphStore

    store, arrays = _store_arrays()
    given = {
        name: arr.astype(ml_dtypes.int4 if arr.dtype.kind in "iu" else jnp.bfloat16)
        for name, arr in arrays.items()
    }
    out = GraphStore(**given, attrs=dict(store.attrs))
    for name, arr in arrays.items():
        assert getattr(out, name).dtype == arr.dtype
        assert np.array_equal(getattr(out, name), arr, equal_nan=arr.dtype.kind == "f")
    with pytest.raises(TypeError, match=r"^edge_u: expected an integer array, received dtype bf"):
        GraphStore(**{**arrays, "edge_u": arrays["edge_u"].astype(jnp.bfloat16)})


@pytest.mark.parametrize("dtype", [np.complex64, object, str])
def test_the_array_checks_still_name_a_wrong_dtype(dtype):
    from topojax.graph import GraphStore

    _, arrays = _store_arrays()
    calls = {
        "skeleton": lambda: tj.skeleton_to_graph(_SKELETON.astype(dtype)),
        "clearance_px": lambda: tj.skeleton_to_graph(
            _SKELETON, clearance_px=lambda flat: np.ones(flat.shape, dtype)
        ),
        "obstacles": lambda: tj.distance_map(_WALLS.astype(dtype)),
        "node_world": lambda: GraphStore(
            **{**arrays, "node_world": arrays["node_world"].astype(dtype)}
        ),
    }
    for name, call in calls.items():
        with pytest.raises(TypeError, match=rf"^{name}: expected .* received .*dtype") as err:
            call()
        assert np.dtype(dtype).name.rstrip("0123456789") in str(err.value) or dtype is str


def _with_paths(dtype):
    g = tj.skeleton_to_graph(_SKELETON)
    for _, _, d in g.edges(data=True):
        d["path"] = np.asarray(d["path"]).astype(dtype)
    return g


def test_routes_take_int4_edge_paths_and_refuse_bfloat16_ones():
    start, goal = (1.0, 3.5), (5.0, 3.5)
    expected = tj.plan_route(tj.skeleton_to_graph(_SKELETON), start, goal)
    route = tj.plan_route(_with_paths(ml_dtypes.int4), start, goal)
    assert route.length_m == expected.length_m
    with pytest.raises(ValueError, match=r"expected an integer 'path' .* received bfloat16"):
        tj.plan_route(_with_paths(jnp.bfloat16), start, goal)


def test_the_view_routes_int4_edge_paths_and_not_bfloat16_ones():
    from topojax.view._graphs import graph_payload

    def payload(dtype):
        return graph_payload(_with_paths(dtype), None, name="g", label="graph")

    assert payload(ml_dtypes.int4)["routable"] and payload(np.int64)["routable"]
    assert not payload(jnp.bfloat16)["routable"] and not payload(np.float32)["routable"]


def test_a_tiled_map_takes_an_int4_grid_like_an_int8_one_and_refuses_bfloat16():
    grid = np.array([[0, 7, -1], [0, 0, 7]])
    m = tj.TiledMap.from_array(grid.astype(ml_dtypes.int4))
    expected = tj.TiledMap.from_array(grid.astype(np.int8))
    assert m.kind == expected.kind == "grid"
    assert np.array_equal(m.codes(0, 2, 0, 3), expected.codes(0, 2, 0, 3))
    with pytest.raises(TypeError, match=r"^array: expected .* received bfloat16$"):
        tj.TiledMap.from_array(grid.astype(jnp.bfloat16))
