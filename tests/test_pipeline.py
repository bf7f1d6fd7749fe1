"""End-to-end pipeline: build_graph on real maps, parity with the original, edge cases, CLI."""

from __future__ import annotations

import json
import math

import cv2
import networkx as nx
import numpy as np
import pytest
from brute_force import brute_sq_distance
from scipy.spatial import cKDTree

import topojax as tj
from topojax.cli import main as cli_main
from topojax.datasets import sample_map
from topojax.fields.distance import FAR_SQ


@pytest.fixture(scope="module")
def intel_zhang():
    return tj.build_graph(
        sample_map("intel"),
        config=tj.PipelineConfig(skeleton=tj.SkeletonConfig(thinning="zhang")),
    )


@pytest.mark.parametrize("name", ["intel", "office", "a_scan"])
def test_zhang_pipeline_reproduces_original(paper_reference, name):
    ref = paper_reference(name)
    occupancy = tj.OccupancyMap.from_array(ref["obstacle"])
    res = tj.build_graph(
        occupancy, config=tj.PipelineConfig(skeleton=tj.SkeletonConfig(thinning="zhang"))
    )
    np.testing.assert_array_equal(res.ridges, ref["ridge"])
    np.testing.assert_array_equal(res.skeleton, ref["skeleton"])
    ours = np.asarray([d["pixel"] for _, d in res.graph.nodes(data=True)], float)
    dist, _ = cKDTree(ours).query(ref["vertices"].astype(float))
    assert np.mean(dist <= 1.0) >= 0.99
    # every difference is an isolated skeleton pixel, which the original never reports
    # as a vertex (its vertices are edge ends)
    kinds = {d["pixel"]: d["kind"] for _, d in res.graph.nodes(data=True)}
    ref_set = {tuple(v) for v in ref["vertices"].tolist()}
    extra = set(kinds) - ref_set
    assert all(kinds[p] == "isolated" for p in extra)
    assert ref_set <= set(kinds)
    non_isolated = [e for e in res.graph.edges()]
    assert len(non_isolated) == len(ref["edges"])


def test_bundled_sample_equals_reference_obstacles(paper_reference):
    np.testing.assert_array_equal(
        sample_map("intel").occupied, paper_reference("intel")["obstacle"]
    )


def test_graph_invariants_on_real_map(intel_zhang):
    res = intel_zhang
    g = res.graph
    owner = np.zeros(res.skeleton.shape, np.int32)
    for _, d in g.nodes(data=True):
        owner[d["pixel"]] += 1
    for _, _, d in g.edges(data=True):
        path = d["path"]
        steps = np.abs(np.diff(path, axis=0))
        assert steps.max() <= 1 and (steps.sum(axis=1) > 0).all()  # 8-connected
        inner = path[1:-1]
        np.add.at(owner, (inner[:, 0], inner[:, 1]), 1)
        assert not res.map.occupied[path[:, 0], path[:, 1]].any()  # never crosses a wall
    # each skeleton pixel belongs to exactly one vertex or one edge interior
    assert np.array_equal(owner > 0, res.skeleton)
    assert owner.max() == 1
    # world coordinates agree with the map's transform
    for _, d in list(g.nodes(data=True))[:20]:
        x, y = res.map.pixel_to_world(*d["pixel"])
        assert d["world"] == pytest.approx((float(x), float(y)))
        assert d["clearance_m"] > 0


def test_clearance_is_euclidean_distance(intel_zhang):
    import cv2

    res = intel_zhang
    edt = cv2.distanceTransform(
        (~res.map.occupied).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE
    )
    # exact on the whole map, not only where the graph reads it
    np.testing.assert_allclose(res.clearance_px, edt, rtol=0, atol=1e-3)


def test_graph_from_ridges_takes_clearance_as_map_or_function(intel_zhang):
    """The CPU stages accept the clearance as a whole map or as a function of the
    skeleton's flat indices (what build_graph and the batch workers pass); both give
    build_graph's graph, and a function giving the wrong number of values is refused."""
    from topojax.pipeline import graph_from_ridges

    res = intel_zhang
    seen = []

    def at_pixels(flat):
        seen.append(flat)
        return res.clearance_px.ravel()[flat]

    common = dict(
        resolution_m=res.map.resolution_m,
        origin=res.map.origin,
        pixel_to_world=res.map.pixel_to_world,
        config=res.config,
    )
    expected = edge_table(res.graph)
    for clearance in (res.clearance_px, at_pixels):
        skeleton, graph, _ = graph_from_ridges(res.ridges, clearance_px=clearance, **common)
        np.testing.assert_array_equal(skeleton, res.skeleton)
        assert edge_table(graph) == expected
        assert [d["clearance_m"] for _, d in graph.nodes(data=True)] == [
            d["clearance_m"] for _, d in res.graph.nodes(data=True)
        ]
    np.testing.assert_array_equal(seen[0], np.flatnonzero(res.skeleton))
    with pytest.raises(ValueError, match=r"clearance_px: expected \d+ values"):
        graph_from_ridges(res.ridges, clearance_px=lambda flat: flat[:-1], **common)
    _, bare, _ = graph_from_ridges(res.ridges, clearance_px=None, **common)
    assert all(np.isnan(d["clearance_m"]) for _, d in bare.nodes(data=True))


def edge_table(graph):
    return [
        (u, v, k, d["path"].tolist(), d["length_m"], d["min_clearance_m"], d["mean_clearance_m"])
        for u, v, k, d in graph.edges(keys=True, data=True)
    ]


def test_default_is_guo_hall_and_equals_skimage_thin():
    from skimage.morphology import thin

    res = tj.build_graph(sample_map("a_scan"))
    np.testing.assert_array_equal(res.skeleton, tj.remove_t_centres(thin(res.ridges)))
    assert res.graph.graph["thinning"] == "guo_hall"


def test_office_beyond_window_clearance(paper_reference):
    """office has pixels farther than R = 227 px from any obstacle; clearance stays exact
    there, on the whole map (the windowed distance alone would be wrong beyond R).  The
    graph's clearances (computed at the skeleton's pixels only) equal it too."""
    import cv2

    obstacles = paper_reference("office")["obstacle"]
    res = tj.build_graph(obstacles)
    edt = cv2.distanceTransform((~obstacles).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    assert (res.clearance_px > 227).any()
    np.testing.assert_allclose(res.clearance_px, edt, rtol=0, atol=1e-3)
    res_m = res.graph.graph["resolution_m"]
    for _, d in res.graph.nodes(data=True):
        assert d["clearance_m"] == pytest.approx(edt[d["pixel"]] * res_m, rel=1e-6)
    for _, _, d in res.graph.edges(data=True):
        vals = edt[d["path"][:, 0], d["path"][:, 1]].astype(np.float64) * res_m
        assert d["min_clearance_m"] == pytest.approx(vals.min(), rel=1e-6)
        assert d["mean_clearance_m"] == pytest.approx(vals.mean(), rel=1e-6)


def _sparse_map(seed: int):
    """A 90 x 120 map with 6 obstacle pixels, R = 4: (rng, obstacles, R, exact windowed
    squared distance, OpenCV's exact unwindowed transform)."""
    import cv2

    rng = np.random.default_rng(seed)
    obstacles = np.zeros((90, 120), bool)
    obstacles[rng.integers(0, 90, 6), rng.integers(0, 120, 6)] = True
    r = 4
    d2 = brute_sq_distance(obstacles, r)
    d2 = np.where(np.isinf(d2), FAR_SQ, d2).astype(np.int32)
    edt = cv2.distanceTransform((~obstacles).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return rng, obstacles, r, d2, edt


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_clearance_beyond_window_at_few_needed_pixels(seed):
    """A few needed pixels beyond R (some with no obstacle in their window at all) are
    searched one by one; many take the whole map's transform: both exact."""
    from topojax.fields.clearance import clearance_from_sq_distance
    from topojax.fields.clearance import nearest_sq_distance as _nearest_sq_distance

    rng, obstacles, r, d2, edt = _sparse_map(seed)
    beyond = np.argwhere(d2 > r * r)
    for n in (5, 40, 500):  # 500 > SPARSE_CLEARANCE_MAX_PX: whole-map transform
        pick = beyond[rng.choice(len(beyond), size=min(n, len(beyond)), replace=False)]
        need = np.zeros_like(obstacles)
        need[pick[:, 0], pick[:, 1]] = True
        got = clearance_from_sq_distance(d2, obstacles, r, need)
        np.testing.assert_allclose(got[need], edt[need], rtol=1e-6, atol=0)
        within = (d2 <= r * r) & ~need
        np.testing.assert_array_equal(got[within], np.sqrt(d2[within].astype(np.float32)))
    # the search gives up (None) when its squares exceed the budget
    rows, cols = beyond[:3, 0], beyond[:3, 1]
    assert _nearest_sq_distance(obstacles, rows, cols, d2[rows, cols], 2 * r, 10) is None


@pytest.mark.parametrize("seed", [0, 1])
def test_clearance_at_selected_pixels_is_exact(seed):
    """clearance_at reads only the pixels asked for: exact within and beyond R (searched
    one by one when few, from the whole map's transform when many)."""
    from topojax.pipeline import clearance_at

    rng, obstacles, r, d2, edt = _sparse_map(seed)
    assert (d2 <= r * r).any() and (d2 > r * r).any()
    for n in (0, 7, 60, 3000):  # 3000 pixels hold more than 64 beyond R: whole-map path
        flat = np.sort(rng.choice(d2.size, size=n, replace=False))
        got = clearance_at(d2, obstacles, r, flat)
        assert got.dtype == np.float32 and got.shape == (n,)
        np.testing.assert_allclose(got, edt.ravel()[flat], rtol=1e-6, atol=0)
    empty = np.zeros_like(obstacles)
    got = clearance_at(np.full(d2.shape, FAR_SQ, np.int32), empty, r, np.arange(5))
    assert np.isinf(got).all()


def test_opencv_distance_transform_gives_the_same_bits_wherever_numpy_allocates():
    """OpenCV's vectorised exact transform rounds a few distances a unit in the last place
    apart with the output's address modulo 32 bytes: a route graph's mean clearances, and
    a pixel exactly at the robot's radius, changed from one run to the next."""
    from scipy import ndimage

    from topojax.fields.clearance import distance_transform_px, free_clearance_px

    free = np.ones((60, 100), bool)
    free[[0, -1], :] = free[:, [0, -1]] = False
    free[20:40, 30:70] = False
    first = free_clearance_px(free).copy()
    exact = ndimage.distance_transform_edt(np.pad(free, 1))[1:-1, 1:-1]
    np.testing.assert_allclose(first, exact, rtol=1e-6, atol=0)
    held = []
    for k in range(64):  # arrays of other sizes move where the next output lands
        held += [np.empty(25000 + 16 * k, np.uint8), np.ones(24000 + 24 * k, np.uint8)]
        got = free_clearance_px(free)
        assert np.array_equal(got, first), k
    assert distance_transform_px(free).ctypes.data % 64 == 0


def test_opencv_distance_transform_gives_the_same_bits_with_any_thread_count():
    """OpenCV's exact transform run on one thread (``cv2.setNumThreads(1)``, a one-core
    machine or container) rounds many distances a unit in the last place apart from the
    same transform run in parallel: the same map would give other clearances, and route
    graphs, on another machine.  Every distance is the float32 nearest the exact one."""
    import cv2
    from scipy import ndimage

    from topojax.fields.clearance import distance_transform_px

    free = np.ones((300, 400), bool)
    free[[0, -1], :] = free[:, [0, -1]] = False
    free[100:140, 50:330] = False
    free[200:260:7, 20:380:11] = False  # pillars: many distances, few of them integers
    exact = ndimage.distance_transform_edt(free).astype(np.float32)
    threads = cv2.getNumThreads()
    try:
        for n in (1, 2, 3):
            cv2.setNumThreads(n)
            assert np.array_equal(distance_transform_px(free), exact), n
    finally:
        cv2.setNumThreads(threads)


def test_world_coordinates_follow_map_origin_and_yaw():
    occ = sample_map("intel")
    moved = tj.OccupancyMap(
        occupied=occ.occupied,
        free=occ.free,
        unknown=occ.unknown,
        resolution_m=0.05,
        origin=(10.0, -5.0, np.pi / 2),
    )
    g = tj.build_graph(moved).graph
    for _, d in list(g.nodes(data=True))[:10]:
        r, c = d["pixel"]
        h = occ.shape[0]
        u, v = (c + 0.5) * 0.05, (h - r - 0.5) * 0.05
        assert d["world"] == pytest.approx((10.0 - v, -5.0 + u))


@pytest.mark.parametrize(
    "array",
    [np.zeros((30, 40), bool), np.ones((30, 40), bool), np.ones((2, 2), bool)]
    + [np.ones((2, 9), bool), np.ones((3, 3), bool), np.ones((5, 2), bool)],
    ids=["no-obstacles", "no-free-space", "all-occupied-2x2", "2x9", "3x3", "5x2"],
)
def test_degenerate_maps_give_empty_graphs(array):
    res = tj.build_graph(array)
    assert res.graph.number_of_nodes() == 0
    assert res.graph.number_of_edges() == 0
    assert res.skeleton.shape == array.shape
    assert not res.skeleton.any()


@pytest.mark.parametrize(
    "occupied",
    [[[0, 1], [1, 0]], [[0, 1, 0], [0, 0, 0]], [[0, 0], [1, 0], [0, 0]]],
    ids=["diagonal-2x2", "2x3", "3x2"],
)
def test_maps_two_pixels_across_reflect_their_border_as_opencv(occupied):
    """The Laplacian reads past a 2-pixel side by reflecting twice (OpenCV's
    BORDER_REFLECT_101), not from outside the map: no ridge, so no graph, on obstacles."""
    occupied = np.array(occupied, bool)
    res = tj.build_graph(occupied, keep="all")
    want = cv2.convertScaleAbs(cv2.Laplacian(res.distance.astype(np.float64) * 255, -1, ksize=5))
    np.testing.assert_array_equal(res.lap_abs, want)
    assert not (res.ridges & occupied).any()
    assert res.graph.number_of_edges() == 0


def test_obstacles_and_unknown_space_keep_the_papers_graph(capsys):
    """No free pixel but unknown space between walls: the paper's method only looks at
    obstacles, so the graph runs through the unknown space; free-space-only has none."""
    from types import SimpleNamespace

    from topojax.cli.graph import _classes_hint as hint_of

    def _classes_hint(occupancy, graph):  # a result of that graph and no skeleton
        skeleton = np.zeros(occupancy.shape, bool)
        result = SimpleNamespace(
            graph=graph, skeleton=skeleton, ridges=skeleton, config=tj.PipelineConfig()
        )
        return hint_of(occupancy, result)

    img = np.full((100, 120), 205, np.uint8)  # unknown
    img[20:80, 30] = img[20:80, 90] = img[20, 30:91] = 0  # three walls
    m = tj.OccupancyMap.from_array(img)
    assert not m.free.any()
    g = tj.build_graph(m).graph
    assert g.number_of_edges() > 0
    want = tj.build_graph(tj.OccupancyMap.from_array(m.occupied)).graph  # free elsewhere
    assert sorted(d["pixel"] for _, d in g.nodes(data=True)) == sorted(
        d["pixel"] for _, d in want.nodes(data=True)
    )
    cfg = tj.PipelineConfig(graph=tj.GraphConfig(free_space_only=True))
    assert tj.build_graph(m, config=cfg).graph.number_of_nodes() == 0
    # the command-line note says what happens in each case
    some = nx.MultiGraph([(0, 1)])
    assert "runs through unknown space" in _classes_hint(m, some)[0]
    full = tj.OccupancyMap.from_array(np.ones((4, 4), bool))
    assert "nothing but occupied pixels" in _classes_hint(full, nx.MultiGraph())[0]
    assert "graph is empty" in _classes_hint(full, nx.MultiGraph())[0]
    none = tj.OccupancyMap.from_array(np.zeros((4, 4), bool))
    assert "no occupied pixel" in _classes_hint(none, nx.MultiGraph())[0]
    walls = tj.OccupancyMap.from_array(m.occupied)
    assert _classes_hint(walls, some) == []
    # obstacles and free space, yet no corridor (e.g. a map read with its colours
    # swapped): the note says so, as the batch's status does
    (note,) = _classes_hint(walls, nx.MultiGraph())
    assert "the graph is empty: no corridor was found" in note and "--negate" in note


def test_configs_check_types_and_take_numpy_numbers():
    # NumPy numbers are numbers: stored as Python ones
    d = tj.DistanceConfig(sigma_px=np.float32(3.5), half_width_px=np.int64(12))
    assert (d.sigma_px, d.half_width_px) == (3.5, 12)
    assert type(d.sigma_px) is float and type(d.half_width_px) is int
    r = tj.RidgeConfig(scale=np.float64(255), ksize=np.int32(3), threshold=np.int8(7))
    assert (r.ksize, r.threshold) == (3, 7.0) and type(r.ksize) is int
    assert tj.SkeletonConfig(remove_t=np.bool_(False)).remove_t is False
    assert tj.PipelineConfig(tile_px=np.int64(128)).tile_px == 128
    bad = [
        (lambda: tj.RidgeConfig(ksize=True), TypeError, "ksize: expected an int"),
        (lambda: tj.RidgeConfig(threshold=True), TypeError, "threshold: expected a real number"),
        (lambda: tj.SkeletonConfig(remove_t="no"), TypeError, "remove_t: expected a bool"),
        (lambda: tj.SkeletonConfig(thinning=["zhang"]), ValueError, "thinning"),
        (lambda: tj.DistanceConfig(half_width_px=3.0), TypeError, "half_width_px"),
        (
            lambda: tj.PipelineConfig(distance=tj.RidgeConfig()),
            TypeError,
            "distance: expected a Di",
        ),
        (lambda: tj.PipelineConfig(graph=None), TypeError, "graph: expected a GraphConfig"),
        (
            lambda: tj.build_graph(np.zeros((4, 4), bool), config=0),  # falsy: not the default
            TypeError,
            "config: expected a PipelineConfig, received int",
        ),
        (lambda: tj.PipelineConfig(ridge={"threshold": 5}), TypeError, "ridge: expected a Ridge"),
        (
            lambda: tj.distance_map(np.eye(4, dtype=bool), config=tj.PipelineConfig()),
            TypeError,
            "config: expected a DistanceConfig",
        ),
        (
            lambda: tj.ridge_map(np.eye(4, dtype=bool), ridge={"threshold": 5}),
            TypeError,
            "ridge: expected a RidgeConfig",
        ),
        (
            lambda: tj.ridge_map(np.eye(4, dtype=bool), distance=tj.RidgeConfig()),
            TypeError,
            "distance: expected a DistanceConfig",
        ),
        (
            lambda: tj.distance_map(np.eye(4, dtype=bool), tile_px=2.5),
            TypeError,
            r"tile_px: expected an int in \[8, 4096\], received float 2.5",
        ),
        (
            lambda: tj.DistanceConfig.from_metres(sigma_m=1000, resolution_m=0.05),
            ValueError,
            "sigma_m: 1000.0 m at 0.05 m/px is 20000 px",
        ),
        (
            lambda: tj.DistanceConfig.from_metres(sigma_m=1, resolution_m=0.05, half_width_m=300),
            ValueError,
            "half_width_m: 300.0 m",
        ),
        (lambda: tj.DistanceConfig.from_pixels(sigma_px=5000), ValueError, "sigma_px: 5000.0"),
        (
            lambda: tj.DistanceConfig.from_metres(sigma_m=1e-300, resolution_m=0.05),
            ValueError,
            "sigma_m: 1e-300 m at 0.05 m/px is 2e-299 px, less than the narrowest sigma, 1e-06 px",
        ),
    ]
    for make, exc, words in bad:
        with pytest.raises(exc, match=words):
            make()


def test_a_sigma_narrower_than_a_micropixel_is_refused():
    """A sigma narrower than 1e-6 px is refused: at 1e-19 the distance map would be NaN
    on every obstacle (the kernels' float32 ``1 / (2 sigma^2)`` overflows), and every
    sigma up to about 0.07 px gives the same map, the obstacles alone, so none narrower
    than 1e-6 px is needed."""
    mask = np.eye(12, dtype=bool)
    got = tj.distance_map(mask, config=tj.DistanceConfig(sigma_px=1e-6))
    np.testing.assert_array_equal(got, mask.astype(np.float32))
    wider = tj.distance_map(mask, config=tj.DistanceConfig(sigma_px=0.05))
    np.testing.assert_array_equal(wider, got)
    for bad in (9e-7, 1e-19, 1e-300):
        with pytest.raises(ValueError, match=r"^sigma_px: expected at least 1e-06 px .*received"):
            tj.DistanceConfig(sigma_px=bad)


def test_distance_and_ridge_maps_read_map_files():
    png = tj.datasets.sample_map_path("intel")
    m = tj.load_map(png)
    np.testing.assert_array_equal(tj.distance_map(png), tj.distance_map(m))
    np.testing.assert_array_equal(tj.ridge_map(str(png)), tj.ridge_map(m.occupied))


def test_build_graph_reads_a_path_with_load_map(tmp_path):
    """A file name (str or Path) goes through load_map with its defaults."""
    png = tj.datasets.sample_map_path("a_scan")
    want = tj.build_graph(tj.load_map(png))
    for path in (png, str(png)):
        got = tj.build_graph(path)
        assert got.map.source == want.map.source
        np.testing.assert_array_equal(got.skeleton, want.skeleton)
        assert got.graph.number_of_edges() == want.graph.number_of_edges()
    with pytest.raises(FileNotFoundError, match="nope.yaml"):
        tj.build_graph(tmp_path / "nope.yaml")


def test_bad_inputs_raise_clear_errors():
    for bad in (None, b"map.png"):
        with pytest.raises(TypeError, match="occupancy: expected an OccupancyMap"):
            tj.build_graph(bad)
    with pytest.raises(ValueError, match="NaN"):
        tj.build_graph(np.full((10, 10), np.nan))
    with pytest.raises(ValueError):
        tj.build_graph(np.zeros((1, 1), bool))
    with pytest.raises(ValueError):
        tj.build_graph(np.zeros((0, 5), bool))
    with pytest.raises(TypeError, match="PipelineConfig"):
        tj.build_graph(np.zeros((10, 10), bool), config={"tile_px": 5})
    # the low-level functions take masks: an image or probabilities is not silently
    # read as "nonzero = obstacle"; 0 / 1 numbers are
    image = np.full((10, 10), 254, np.uint8)
    image[4, :] = 0
    for bad in (image, np.full((10, 10), 0.3)):
        with pytest.raises(ValueError, match="obstacles: expected a boolean mask"):
            tj.distance_map(bad)
        with pytest.raises(ValueError, match="OccupancyMap.from_array"):
            tj.ridge_map(bad)
    np.testing.assert_array_equal(
        tj.distance_map((image == 0).astype(np.uint8)), tj.distance_map(image == 0)
    )
    with pytest.raises(ValueError, match="thinning"):
        tj.SkeletonConfig(thinning="lee")
    with pytest.raises(ValueError, match="tile_px"):
        tj.PipelineConfig(tile_px=0)


_TILED = {
    "PipelineConfig": lambda **kw: tj.PipelineConfig(**kw),
    "dense_fields": lambda **kw: tj.dense_fields(np.eye(16, dtype=bool), **kw),
    "distance_map": lambda **kw: tj.distance_map(np.eye(16, dtype=bool), **kw),
    "ridge_map": lambda **kw: tj.ridge_map(np.eye(16, dtype=bool), **kw),
}


@pytest.mark.parametrize("name", list(_TILED))
def test_kernel_tile_sizes_are_bounded(name):
    """A tile side outside [8, 4096] is refused up front, naming the option: a huge one
    would otherwise ask for exabytes (a MemoryError from inside NumPy) for a 16 x 16 map."""
    call = _TILED[name]
    with pytest.raises(ValueError, match=r"tile_px: expected an int in \[8, 4096\], received 5"):
        call(tile_px=5)
    with pytest.raises(ValueError, match=r"tile_px: expected .*received 1000000000000"):
        call(tile_px=10**12)
    call(tile_px=8)  # the smallest tile is fine


@pytest.mark.parametrize("name", ["PipelineConfig", "dense_fields"])
def test_kernel_buckets_are_bounded(name):
    """More than 2**28 tile pixels per kernel call is refused up front: every call is
    padded to the full bucket, so 10**6 tiles per call would ask for 30 GB for a small
    map."""
    call = _TILED[name]
    with pytest.raises(
        ValueError, match=r"tiles_per_call: expected an int from 1 to 4096 .*received 1000000"
    ):
        call(tile_px=256, tiles_per_call=10**6)
    with pytest.raises(ValueError, match=r"tiles_per_call: expected an int from 1 to 16 "):
        call(tile_px=4096, tiles_per_call=17)
    call(tile_px=8, tiles_per_call=3)


def test_build_graph_names_its_occupancy_argument_for_a_bad_array():
    """The conversion's errors name build_graph's argument, not the conversion's own
    ("array: ...")."""
    with pytest.raises(ValueError, match=r"^occupancy \(read by OccupancyMap.from_array\): "):
        tj.build_graph(np.zeros(5))
    with pytest.raises(TypeError, match=r"^occupancy \(read by OccupancyMap.from_array\): "):
        tj.build_graph(np.array([[object()]]))


def test_negative_ridge_threshold_is_refused():
    """``round(|Laplacian|) > threshold`` holds for every pixel when the threshold is
    negative: the whole map, walls included, would come back as ridge pixels."""
    with pytest.raises(ValueError, match=r"threshold: expected a finite number >= 0 .*-1.0"):
        tj.RidgeConfig(threshold=-1)
    assert tj.RidgeConfig(threshold=0).threshold == 0.0


def test_a_ridge_scale_or_threshold_float32_cannot_hold_is_refused():
    """A ridge scale or threshold beyond float32's largest finite value is refused: in
    the float32 kernels it would be inf and no pixel a ridge (``threshold=1e39`` with
    ``scale=1e38``, both with ``scale=2.55e40``, the paper's ratio); that value itself
    is taken."""
    top = float(np.finfo(np.float32).max)
    with pytest.raises(ValueError, match=r"^threshold: expected a number at most 3\.40282e\+38 "):
        tj.RidgeConfig(threshold=1e39, scale=1e38)
    with pytest.raises(ValueError, match=r"^scale: .* float32.*received 1e\+39$"):
        tj.RidgeConfig(threshold=1e38, scale=1e39)
    edge = tj.RidgeConfig(threshold=top, scale=top)
    assert (edge.threshold, edge.scale) == (top, top)
    assert np.isfinite(np.float32(edge.threshold)) and np.isfinite(np.float32(edge.scale))


def test_a_ridge_scale_outside_the_range_the_test_can_resolve_is_refused():
    """``scale=1e30`` made every pixel with any curvature a ridge.  The ridge test is
    ``|Laplacian(H)| > (floor(threshold) + 0.5) / scale`` on a map in [0, 1]: refused are
    the scales at which no pixel can pass (the largest |Laplacian| is 4, 8 or 56 by
    aperture) and those at which the threshold falls below float32's rounding error of
    the Laplacian (2 * 56 * 2**-24 with aperture 5); the bounds are what the kernels do."""
    import jax.numpy as jnp

    from topojax.fields.filters import laplacian_valid, ridge_from_laplacian

    with pytest.raises(
        ValueError,
        match=r"^scale: expected 0\.1875 to 1\.57286e\+06 with ksize=5 and threshold=10 .*"
        r"received 1e\+30$",
    ):
        tj.RidgeConfig(scale=1e30)
    for ksize, peak in ((1, 4.0), (3, 8.0), (5, 56.0)):
        for threshold in (0.0, 10.0, 254.5):
            cut = math.floor(threshold) + 0.5
            low, high = cut / peak, cut / (2 * peak * 2.0**-24)
            for scale in (low, high):
                assert tj.RidgeConfig(scale=scale, ksize=ksize, threshold=threshold).scale == scale
            for scale in (low * (1 - 1e-6), high * (1 + 1e-6)):
                with pytest.raises(ValueError, match=f"^scale: expected .* ksize={ksize} "):
                    tj.RidgeConfig(scale=scale, ksize=ksize, threshold=threshold)
            # the largest Laplacian of a [0, 1] map: 1 under the positive weights, 0 under
            # the negative ones; it passes from the lowest scale on, not below
            kernel = np.asarray(laplacian_valid(jnp.pad(jnp.eye(1), 4), ksize=ksize))[::-1, ::-1]
            values = np.pad((kernel > 0).astype(np.float32), 2)
            lap = laplacian_valid(jnp.asarray(values), ksize=ksize)
            assert float(jnp.abs(lap).max()) == peak
            for scale, passes in ((low * (1 + 1e-6), True), (low * (1 - 1e-6), False)):
                ridge = ridge_from_laplacian(lap, scale=scale, threshold=threshold)[1]
                assert bool(ridge.any()) is passes
    assert tj.RidgeConfig() == tj.RidgeConfig(scale=255.0, ksize=5, threshold=10.0)


def test_tile_size_does_not_change_result():
    occ = sample_map("a_scan")
    a = tj.build_graph(occ, config=tj.PipelineConfig(tile_px=256))
    b = tj.build_graph(occ, config=tj.PipelineConfig(tile_px=160, tiles_per_call=3))
    np.testing.assert_array_equal(a.skeleton, b.skeleton)
    assert sorted(d["pixel"] for _, d in a.graph.nodes(data=True)) == sorted(
        d["pixel"] for _, d in b.graph.nodes(data=True)
    )
    assert sorted(d["path"].tobytes() for *_, d in a.graph.edges(data=True)) == sorted(
        d["path"].tobytes() for *_, d in b.graph.edges(data=True)
    )


def test_save_and_load_round_trip(tmp_path, intel_zhang):
    g = intel_zhang.graph
    for suffix in (".graphml", ".json"):
        back = tj.load_graph(tj.save_graph(g, tmp_path / f"g{suffix}"))
        assert back.number_of_nodes() == g.number_of_nodes()
        assert back.number_of_edges() == g.number_of_edges()
        for u, v, k, d in g.edges(keys=True, data=True):
            np.testing.assert_array_equal(back.edges[u, v, k]["path"], d["path"])
    gj = json.loads(tj.save_graph(g, tmp_path / "g.geojson").read_text())
    assert gj["type"] == "FeatureCollection"


def test_cli_graph_and_demo(tmp_path, capsys, shared_data):
    yaml = shared_data / "maps" / "simulated" / "nav2" / "tb3_sandbox.yaml"
    assert cli_main(["graph", str(yaml), "-o", str(tmp_path), "--plot"]) == 0
    out = capsys.readouterr().out
    assert "vertices" in out
    for suffix in (".graphml", ".json", ".geojson", ".png"):
        assert (tmp_path / f"tb3_sandbox{suffix}").stat().st_size > 0
    g = tj.load_graph(tmp_path / "tb3_sandbox.json")
    assert g.number_of_edges() > 0

    assert cli_main(["demo", "--map", "a_scan", "-o", str(tmp_path / "demo")]) == 0
    summary = json.loads((tmp_path / "demo" / "a_scan_summary.json").read_text())
    assert summary["vertices"] > 100
    (wrote,) = [line for line in capsys.readouterr().out.splitlines() if line.startswith("wrote")]
    assert "a_scan_summary.json" in wrote  # every file the demo writes is listed


def _ipa_style_png(path):
    """An IPA-benchmark-style image: grey 153 outside, white 255 rooms, no wall pixels."""
    img = np.full((60, 80), 153, np.uint8)
    img[10:50, 10:35] = 255
    img[10:50, 40:70] = 255
    img[28:32, 35:40] = 255  # a door between the rooms
    cv2.imwrite(str(path), img)
    return path


def test_cli_graph_mode_and_a_note_for_maps_without_obstacles(tmp_path, capsys):
    png = _ipa_style_png(tmp_path / "rooms.png")
    assert cli_main(["graph", str(png), "-o", str(tmp_path / "a")]) == 0
    out = capsys.readouterr().out
    assert "note       the map has no occupied pixel" in out and "--mode ipa" in out
    assert tj.load_graph(tmp_path / "a" / "rooms.json").number_of_edges() == 0
    assert cli_main(["graph", str(png), "-o", str(tmp_path / "b"), "--mode", "ipa"]) == 0
    out = capsys.readouterr().out
    assert "the map has no" not in out
    got = tj.load_graph(tmp_path / "b" / "rooms.json")
    want = tj.build_graph(tj.load_map(png, mode="ipa")).graph
    assert got.number_of_edges() == want.number_of_edges() > 0
    with pytest.raises(SystemExit):
        cli_main(["graph", str(png), "--mode", "grey"])
    assert "invalid choice: 'grey'" in capsys.readouterr().err


def test_cli_graph_sigma_in_metres_or_pixels(tmp_path, capsys):
    """``--sigma-m`` goes through the map's resolution (support scaled like the original's
    227 px for 64.19 px); ``--sigma-px`` is the same in pixels; they exclude each other."""
    png = tj.datasets.sample_map_path("intel")  # 0.05 m/px
    m = tj.load_map(png)
    cfg = tj.PipelineConfig(
        distance=tj.DistanceConfig.from_metres(sigma_m=1.0, resolution_m=m.resolution_m)
    )
    assert (cfg.distance.sigma_px, cfg.distance.half_width_px) == (pytest.approx(20.0), 71)
    assert tj.DistanceConfig.from_pixels(sigma_px=20.0) == cfg.distance
    assert (
        tj.DistanceConfig.from_pixels(sigma_px=tj.DistanceConfig().sigma_px) == tj.DistanceConfig()
    )
    want = tj.build_graph(m, config=cfg).graph
    for option, value in (("--sigma-m", "1.0"), ("--sigma-px", "20")):
        out = tmp_path / option.strip("-")
        assert cli_main(["graph", str(png), "-o", str(out), option, value]) == 0
        got = tj.load_graph(out / "intel.json")
        assert got.number_of_nodes() == want.number_of_nodes()
        assert got.number_of_edges() == want.number_of_edges()
    capsys.readouterr()
    with pytest.raises(SystemExit):
        cli_main(["graph", str(png), "--sigma-m", "1", "--sigma-px", "20"])
    assert "not allowed with argument" in capsys.readouterr().err
    assert cli_main(["graph", str(png), "-o", str(tmp_path / "x"), "--sigma-m", "-1"]) == 2
    assert "--sigma-m: expected a finite number of metres > 0" in capsys.readouterr().err


def test_cli_keeps_compiled_kernels_between_runs(tmp_path):
    """The command stores JAX's compiled kernels under $XDG_CACHE_HOME/topojax/jax and a
    second run, which loads them, writes the same graph.  (A small map: the command keeps
    the cache whatever the map, and the graph command on it takes less time than the
    demo.)"""
    import os
    import subprocess
    import sys

    png = tmp_path / "rooms.png"
    img = np.full((60, 80), 254, np.uint8)  # two rooms and a door, walls all round
    img[:2], img[-2:], img[:, :2], img[:, -2:] = 0, 0, 0, 0
    img[:, 38:42] = 0
    img[26:34, 38:42] = 254
    cv2.imwrite(str(png), img)
    env = {k: v for k, v in os.environ.items() if k not in ("TOPOJAX_NO_JAX_CACHE",)}
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")
    outputs = []
    for run in range(2):
        out = tmp_path / f"run{run}"
        # JAX logs each kernel it finds in the cache (a warning with log_compiles)
        run_env = {**env, "JAX_LOG_COMPILES": "1"} if run else env
        cmd = [sys.executable, "-m", "topojax.cli", "graph", str(png), "-o", str(out)]
        done = subprocess.run(cmd, env=run_env, check=True, capture_output=True, timeout=300)
        outputs.append((out / "rooms.json").read_bytes())
        kernels = sorted(p.name for p in (tmp_path / "cache" / "topojax" / "jax").iterdir())
        assert any(name.startswith("jit__forward_tiles") for name in kernels), kernels
    hits = [s for s in done.stderr.decode().splitlines() if "cache hit" in s.lower()]
    assert any("jit__forward_tiles" in line for line in hits), done.stderr
    assert outputs[0] == outputs[1]
    # JAX_COMPILATION_CACHE_DIR alone moves the cache, and kernels are still kept there
    env["JAX_COMPILATION_CACHE_DIR"] = str(tmp_path / "own")
    cmd = [sys.executable, "-m", "topojax.cli", "graph", str(png), "-o", str(out)]
    subprocess.run(cmd, env=env, check=True, capture_output=True, timeout=300)
    kernels = sorted(p.name for p in (tmp_path / "own").iterdir())
    assert any(name.startswith("jit__forward_tiles") for name in kernels), kernels


def test_cli_reports_bad_input(tmp_path, capsys):
    assert cli_main(["graph", str(tmp_path / "missing.yaml"), "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "missing.yaml" in err


def test_concurrent_calls_from_threads_equal_sequential_ones():
    """build_graph keeps per-thread scratch space (distance stage and thinning): calls from
    several threads at once, on different maps and thinnings, give the sequential
    results bit for bit."""
    from concurrent.futures import ThreadPoolExecutor

    intel = sample_map("intel")
    # two maps of one size (scratch space of the same shape) and one of another
    maps = [intel, tj.OccupancyMap.from_array(intel.occupied[::-1]), sample_map("a_scan")]
    configs = [tj.PipelineConfig(), tj.PipelineConfig(skeleton=tj.SkeletonConfig(thinning="zhang"))]
    keys = [(i, j) for i in range(3) for j in range(2)]
    want = {k: tj.build_graph(maps[k[0]], config=configs[k[1]]) for k in keys}

    def run(key):
        return key, tj.build_graph(maps[key[0]], config=configs[key[1]])

    with ThreadPoolExecutor(3) as pool:
        results = list(pool.map(run, keys * 4))
    for key, got in results:
        ref = want[key]
        for name in ("sq_distance_px", "distance", "lap_abs", "ridges", "skeleton"):
            np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), err_msg=name)
        assert sorted(d["path"].tobytes() for *_, d in got.graph.edges(data=True)) == sorted(
            d["path"].tobytes() for *_, d in ref.graph.edges(data=True)
        )
