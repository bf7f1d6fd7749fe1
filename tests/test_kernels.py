"""JAX kernels against independent float64 references (NumPy brute force, OpenCV, SciPy).

Tolerances: distance map 1e-5 absolute on the [0, 1] scale (the issue's bound; float32
exp gives ~6e-8); squared distances exact (integers); Laplacian equal to OpenCV's on the
same float32 map (0 differing pixels); ridges identical.
"""

from __future__ import annotations

from functools import partial

import cv2
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from brute_force import brute_sq_distance
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from topojax.config import ORIGINAL_HALF_WIDTH_PX, ORIGINAL_SIGMA_PX, DistanceConfig, RidgeConfig
from topojax.fields.distance import (
    FAR_SQ,
    brute_force_distance_map,
    column_distance_tile,
    column_dtype,
    window_sq_distance_tile,
)
from topojax.fields.filters import laplacian_valid, reflect_101_halo, ridge_from_laplacian
from topojax.fields.tiling import TileGrid
from topojax.pipeline import dense_fields, dense_fields_many, trace_counts


def test_original_sigma_matches_reference_value():
    assert ORIGINAL_SIGMA_PX == pytest.approx(64.19283, abs=1e-5)
    assert ORIGINAL_HALF_WIDTH_PX == 227


@settings(max_examples=25, deadline=None)
@given(
    h=st.integers(2, 40),
    w=st.integers(2, 40),
    density=st.floats(0.0, 0.3),
    r=st.integers(1, 12),
    tile=st.sampled_from([8, 16, 24]),
    seed=st.integers(0, 2**31 - 1),
)
def test_sq_distance_matches_brute_force(h, w, density, r, tile, seed):
    rng = np.random.default_rng(seed)
    obstacles = rng.random((h, w)) < density
    fields = dense_fields(
        obstacles, distance=DistanceConfig(sigma_px=min(3.0, r), half_width_px=r), tile_px=tile
    )
    ref = brute_sq_distance(obstacles, r)
    got = fields.sq_distance_px.astype(np.float64)
    got[fields.sq_distance_px >= FAR_SQ] = np.inf
    np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_distance_map_matches_float64_max_splat(seed):
    rng = np.random.default_rng(seed)
    obstacles = rng.random((70, 90)) < 0.01
    obstacles[rng.integers(0, 70), :40] = True  # a wall
    cfg = DistanceConfig(sigma_px=9.5, half_width_px=20)
    ref = brute_force_distance_map(obstacles, sigma_px=cfg.sigma_px, half_width_px=20)
    got = dense_fields(obstacles, distance=cfg, tile_px=32).distance
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-5)


def test_distance_map_paper_map_matches_reference(paper_reference):
    ref = paper_reference("intel")
    got = dense_fields(ref["obstacle"]).distance
    np.testing.assert_allclose(got, ref["dist_map"], rtol=0, atol=1e-5)


def test_distance_map_paper_map_matches_brute_force_splat_on_crop(paper_reference):
    """Float64 brute-force max-splat with the original window, on a crop of a paper map."""
    obstacles = paper_reference("a_scan")["obstacle"][200:330, 300:420]
    ref = brute_force_distance_map(obstacles, sigma_px=ORIGINAL_SIGMA_PX, half_width_px=227)
    got = dense_fields(obstacles).distance
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-5)


@pytest.mark.parametrize("ksize", [1, 3, 5])
@pytest.mark.parametrize(
    "shape", [(37, 53), (64, 64), (5, 129), (3, 40), (17, 4), (2, 2), (2, 9), (13, 2)]
)
def test_laplacian_matches_opencv_with_reflect_101_border(ksize, shape):
    rng = np.random.default_rng(ksize)
    values = rng.random(shape).astype(np.float32)
    grid = TileGrid(shape, 16)
    patches = grid.patches(values, 2, fill=np.float32(0))
    map_shape = jnp.asarray(shape, jnp.int32)

    @jax.jit
    def run(p, o):
        return jax.vmap(
            lambda a, b: laplacian_valid(reflect_101_halo(a, b, map_shape, halo=2), ksize=ksize)
        )(p, o)

    got = grid.assemble(np.asarray(run(patches, grid.origins())))
    ref = cv2.Laplacian(values.astype(np.float64), cv2.CV_64F, ksize=ksize)
    np.testing.assert_allclose(got, ref, rtol=0, atol=2e-5 * np.abs(ref).max() + 1e-5)


def _reflect_101_reference(values, origin, map_shape, halo):
    """Gather formulation of the border reflection, in NumPy (tiny maps included)."""
    out = np.asarray(values)
    for axis in (0, 1):
        n = out.shape[axis]
        start = origin[axis] - halo
        last = map_shape[axis] - 1
        glob = np.abs(start + np.arange(n)) % (2 * last)  # OpenCV reflects again
        glob = np.where(glob > last, 2 * last - glob, glob)
        out = np.take(out, np.clip(glob - start, 0, n - 1), axis=axis)
    return out


@pytest.mark.parametrize("map_shape", [(2, 2), (2, 9), (3, 3), (5, 30), (40, 41), (13, 2)])
@pytest.mark.parametrize("tile", [4, 8])
def test_reflect_101_halo_equals_gather_reference(map_shape, tile):
    """Every pixel that the Laplacian of a map pixel reads equals the gather reference."""
    rng = np.random.default_rng(map_shape[0] * 100 + tile)
    halo = 2
    fn = jax.jit(partial(reflect_101_halo, halo=halo))
    shape = jnp.asarray(map_shape, jnp.int32)
    for r0 in range(0, map_shape[0], tile):
        for c0 in range(0, map_shape[1], tile):
            values = rng.random((tile + 2 * halo, tile + 2 * halo)).astype(np.float32)
            origin = np.array([r0, c0], np.int32)
            got = np.asarray(fn(values, jnp.asarray(origin), shape))
            want = _reflect_101_reference(values, origin, map_shape, halo)
            # Only pixels within ``halo`` of the map are read by a map pixel's filter.
            rows = origin[0] - halo + np.arange(tile + 2 * halo)
            cols = origin[1] - halo + np.arange(tile + 2 * halo)
            keep = (rows <= map_shape[0] - 1 + halo)[:, None] & (cols <= map_shape[1] - 1 + halo)[
                None, :
            ]
            np.testing.assert_array_equal(got[keep], want[keep])


@pytest.mark.parametrize("r", [1, 5, 30])
def test_column_pass_matches_numpy(r):
    rng = np.random.default_rng(r)
    strip = rng.random((23 + 2 * r, 17)) < 0.04
    got = np.asarray(jax.jit(partial(column_distance_tile, half_width=r))(strip))
    assert got.dtype == np.uint8
    want = np.full((23, 17), 255, np.int64)
    for i in range(23):
        for j in range(17):
            hits = np.nonzero(strip[i : i + 2 * r + 1, j])[0]
            if hits.size:
                want[i, j] = np.abs(hits - r).min()
    np.testing.assert_array_equal(got, want)


def test_column_dtype_covers_large_windows():
    assert column_dtype(254) == np.uint8
    assert column_dtype(255) == np.uint16
    strip = np.zeros((2 * 300 + 4, 3), bool)
    strip[0, 1] = True  # exactly R rows above output row 0
    got = np.asarray(column_distance_tile(jnp.asarray(strip), half_width=300))
    assert got.dtype == np.uint16
    assert got[0, 1] == 300 and got[1, 1] == np.iinfo(np.uint16).max
    assert got[0, 0] == np.iinfo(np.uint16).max
    with pytest.raises(ValueError, match="half_width"):
        column_dtype(70000)


@pytest.mark.parametrize("r", [300, 4200])
def test_column_pass_with_tall_strips(r):
    """Row indices are int16 while the strip has fewer than 2^13 rows and int32 beyond;
    both give the brute-force column distances, obstacles at the window's edge included."""
    rng = np.random.default_rng(r)
    n = 5
    strip = rng.random((n + 2 * r, 4)) < 2e-3  # column 3: random obstacles
    strip[:, :3] = False
    strip[0, 0] = True  # exactly R rows above output row 0
    strip[n - 1 + 2 * r, 1] = True  # exactly R rows below the last output row
    got = np.asarray(column_distance_tile(jnp.asarray(strip), half_width=r))
    none = np.iinfo(column_dtype(r)).max
    want = np.full((n, 4), none, np.int64)
    for i in range(n):
        for j in range(4):
            hits = np.nonzero(strip[i : i + 2 * r + 1, j])[0]
            if hits.size:
                want[i, j] = np.abs(hits - r).min()
    np.testing.assert_array_equal(got, want)
    assert got[0, 0] == r and got[n - 1, 1] == r and (got[:, 2] == none).all()


def test_convert_scale_abs_semantics():
    # exactly representable half-way cases: OpenCV rounds half to even
    values = [10.49, 10.5, 10.51, -11.5, 12.5, 300.0, -0.2, 0.5, 1.5]
    lap = jnp.asarray(values, jnp.float32)
    lap_abs, ridge = ridge_from_laplacian(lap, scale=1.0, threshold=10)
    ref = cv2.convertScaleAbs(np.asarray(lap, np.float64)).ravel()
    np.testing.assert_array_equal(np.asarray(lap_abs), ref)
    np.testing.assert_array_equal(np.asarray(ridge), ref > 10)


@pytest.mark.parametrize("name", ["intel", "office", "a_scan"])
def test_ridges_identical_to_original(paper_reference, name):
    ref = paper_reference(name)
    fields = dense_fields(ref["obstacle"])
    np.testing.assert_array_equal(fields.ridges, ref["ridge"])
    # the Laplacian of our float32 map equals OpenCV's on that same map, bit for bit
    lap = cv2.convertScaleAbs(
        cv2.Laplacian(fields.distance.astype(np.float64) * 255.0, cv2.CV_64F, ksize=5)
    )
    assert int((lap != fields.lap_abs).sum()) == 0


@pytest.mark.parametrize("tile", [32, 48, 100, 256])
def test_tiled_equals_whole_map(tile):
    rng = np.random.default_rng(tile)
    obstacles = ndimage.binary_dilation(rng.random((150, 170)) < 0.003, iterations=2)
    cfg = DistanceConfig(sigma_px=12.0, half_width_px=40)
    whole = dense_fields(obstacles, distance=cfg, tile_px=512, tiles_per_call=1)
    tiled = dense_fields(obstacles, distance=cfg, tile_px=tile, tiles_per_call=3)
    np.testing.assert_array_equal(tiled.sq_distance_px, whole.sq_distance_px)
    np.testing.assert_array_equal(tiled.distance, whole.distance)
    np.testing.assert_array_equal(tiled.ridges, whole.ridges)


@pytest.mark.parametrize("threads", [2, 3, 16])
def test_dispatch_threads_do_not_change_results(threads):
    # 10 chunks of 3 tiles per map: each thread keeps several calls in flight
    rng = np.random.default_rng(threads)
    maps = [
        ndimage.binary_dilation(rng.random(shape) < 0.003, iterations=2)
        for shape in [(150, 170), (97, 260)]
    ]
    cfg = DistanceConfig(sigma_px=12.0, half_width_px=40)
    kw = {"distance": cfg, "tile_px": 32, "tiles_per_call": 3}
    one = dense_fields_many(maps, threads=1, **kw)
    many = dense_fields_many(maps, threads=threads, **kw)
    for a, b in zip(one, many, strict=True):
        for name in ("sq_distance_px", "distance", "lap_abs", "ridges"):
            np.testing.assert_array_equal(getattr(b, name), getattr(a, name))


def test_dispatch_threads_are_checked():
    obstacles = np.zeros((8, 8), bool)
    assert dense_fields(obstacles, threads=np.int64(2)).distance.shape == (8, 8)
    with pytest.raises(ValueError, match="^threads: expected an int >= 1, received 0"):
        dense_fields(obstacles, threads=0)
    for bad in (2.0, True, "2"):
        with pytest.raises(TypeError, match="^threads: expected an int >= 1, received "):
            dense_fields(obstacles, threads=bad)


def test_ridge_fields_many_equals_ridge_fields_of_each_map_alone():
    """Tiles of several maps of different sizes share kernel calls; each map still gets
    the ridges and the squared distance at its ridge pixels of a call on it alone."""
    from topojax.fields import ridge_fields, ridge_fields_many

    rng = np.random.default_rng(11)
    maps = [
        ndimage.binary_dilation(rng.random(shape) < 0.004, iterations=2)
        for shape in [(150, 170), (97, 260), (40, 33)]
    ]
    kw = {"distance": DistanceConfig(sigma_px=6.0, half_width_px=20), "tile_px": 32}
    many = ridge_fields_many(maps, tiles_per_call=4, **kw)
    assert len(many) == len(maps)
    for m, (fields, values) in zip(maps, many, strict=True):
        alone, alone_values = ridge_fields(m, **kw)
        np.testing.assert_array_equal(fields.ridges, alone.ridges)
        np.testing.assert_array_equal(values, alone_values)
        assert fields.sq_distance_px is None and fields.distance is None


def test_reused_scratch_buffers_do_not_leak_between_maps_or_calls():
    """Padded maps and the column pass live in per-thread scratch buffers reused between
    calls: maps of one shape in one batch each get their own, and a later call with
    other maps of the same shapes (obstacles where the earlier ones had none, at the
    borders too) gives what a fresh process would (brute force).  The pool stays
    bounded."""
    from topojax.fields import dense as pipeline

    pipeline._SCRATCH_POOL.arrays = []  # this thread's pool, as in a fresh thread
    rng = np.random.default_rng(3)
    cfg = DistanceConfig(sigma_px=5.0, half_width_px=10)
    kw = {"distance": cfg, "tile_px": 16}
    first = [rng.random((40, 50)) < 0.01 for _ in range(2)] + [rng.random((33, 21)) < 0.3]
    dense_fields_many(first, **kw)
    second = [~m for m in first[:2]] + [rng.random((33, 21)) < 0.01]
    second[0][:, 0] = second[0][0, :] = False  # borders differ from the buffers' last use
    for m, got in zip(second, dense_fields_many(second, **kw), strict=True):
        d2 = got.sq_distance_px.astype(np.float64)
        d2[d2 >= FAR_SQ] = np.inf
        np.testing.assert_array_equal(d2, brute_sq_distance(m, 10))
    pool = pipeline._SCRATCH_POOL.arrays
    assert 0 < sum(a.nbytes for a in pool) <= pipeline._SCRATCH_BYTES
    # two per map (the padded map, whose buffer then holds the padded column pass, and
    # the column pass), all reused by the second call
    assert len(pool) == 6 and len({id(a) for a in pool}) == 6


def test_eager_jit_vmap_agree():
    rng = np.random.default_rng(7)
    r, out = 6, 12
    patches = rng.random((3, out + 2 * r, out + 2 * r)) < 0.05
    eager = [
        np.asarray(window_sq_distance_tile(jnp.asarray(p), out_px=out, half_width=r))
        for p in patches
    ]
    jitted = jax.jit(lambda p: window_sq_distance_tile(p, out_px=out, half_width=r))
    vmapped = jax.jit(jax.vmap(lambda p: window_sq_distance_tile(p, out_px=out, half_width=r)))
    batch = np.asarray(vmapped(jnp.asarray(patches)))
    for i, p in enumerate(patches):
        np.testing.assert_array_equal(np.asarray(jitted(jnp.asarray(p))), eager[i])
        np.testing.assert_array_equal(batch[i], eager[i])


def test_one_trace_serves_every_map_size():
    cfg = DistanceConfig(sigma_px=5.0, half_width_px=9)
    rcfg = RidgeConfig()
    dense_fields(np.eye(20, 30, dtype=bool), distance=cfg, ridge=rcfg, tile_px=24)
    before = trace_counts().get("forward_tiles", 0)
    before_columns = trace_counts().get("column_tiles", 0)
    assert before >= 1 and before_columns >= 1
    for shape in [(21, 33), (70, 25), (2, 2), (100, 101)]:
        obstacles = np.zeros(shape, bool)
        obstacles[0, 0] = True
        dense_fields(obstacles, distance=cfg, ridge=rcfg, tile_px=24)
    dense_fields(
        np.eye(40, dtype=bool), distance=DistanceConfig(sigma_px=7.0, half_width_px=9), tile_px=24
    )
    assert trace_counts()["forward_tiles"] == before
    assert trace_counts()["column_tiles"] == before_columns


def test_bad_obstacle_input():
    with pytest.raises(ValueError, match="2-D"):
        dense_fields(np.zeros(5, bool))
    with pytest.raises(ValueError, match="NaN"):
        dense_fields(np.full((4, 4), np.nan))
    with pytest.raises(ValueError, match="at least 2 x 2"):
        dense_fields(np.zeros((1, 9), bool))
    for wrong in (None, {}, "map.png", np.ones((4, 4), complex)):
        with pytest.raises(TypeError, match="^obstacles: expected a boolean mask, received"):
            dense_fields(wrong)
    with pytest.raises(ValueError, match="half_width_px"):
        DistanceConfig(half_width_px=0)
    with pytest.raises(ValueError, match="sigma_px"):
        DistanceConfig(sigma_px=float("nan"))
    with pytest.raises(ValueError, match="ksize"):
        RidgeConfig(ksize=7)


@pytest.mark.parametrize("tile", [16, 20, 64])
def test_band_worst_pixel_reached_only_by_horizontal_site(tile):
    """Regression: a band whose worst pixel's nearest site lies exactly at its bound."""
    obstacles = np.zeros((40, 70), bool)
    obstacles[:, 0] = True  # every pixel's nearest obstacle is straight to the left
    obstacles[5, 33] = True
    r = 60
    got = dense_fields(
        obstacles, distance=DistanceConfig(sigma_px=10.0, half_width_px=r), tile_px=tile
    ).sq_distance_px.astype(np.float64)
    ref = brute_sq_distance(obstacles, r)
    got[got >= FAR_SQ] = np.inf
    np.testing.assert_array_equal(got, ref)


def test_distance_config_from_metres():
    cfg = DistanceConfig.from_metres(sigma_m=3.2096415, resolution_m=0.05)
    assert cfg.sigma_px == pytest.approx(64.19283, abs=1e-5)
    assert cfg.half_width_px == 227  # the original's support, scaled with sigma
    cfg = DistanceConfig.from_metres(sigma_m=1.0, resolution_m=0.1, half_width_m=2.0)
    assert (cfg.sigma_px, cfg.half_width_px) == (pytest.approx(10.0), 20)
    with pytest.raises(ValueError, match="resolution_m"):
        DistanceConfig.from_metres(sigma_m=1.0, resolution_m=0.0)
    with pytest.raises(ValueError, match="half_width_m: expected at least sigma_m"):
        DistanceConfig.from_metres(sigma_m=1.0, resolution_m=0.1, half_width_m=0.5)


def test_distance_config_window_follows_sigma_unless_given():
    """Given sigma alone, the window scales with it as in the original (the same as
    ``from_pixels``); a window narrower than one sigma (which flattens the ridges away:
    the Intel map's graph goes empty at sigma 1000 px in a 227 px window) is refused."""
    assert DistanceConfig().half_width_px == 227
    assert DistanceConfig(sigma_px=10.0) == DistanceConfig.from_pixels(sigma_px=10.0)
    assert DistanceConfig(sigma_px=10.0).half_width_px == 35
    assert DistanceConfig(sigma_px=10.0, half_width_px=10).half_width_px == 10
    with pytest.raises(ValueError, match=r"half_width_px: expected at least sigma_px"):
        DistanceConfig(sigma_px=1000.0, half_width_px=227)
    with pytest.raises(ValueError, match=r"sigma_px: 2000.0 px needs a support"):
        DistanceConfig(sigma_px=2000.0)


def test_wide_window_uses_uint16_column_pass_end_to_end():
    """R >= 255 switches the column pass to uint16; results stay exact on a real run."""
    rng = np.random.default_rng(5)
    obstacles = np.zeros((300, 40), bool)
    obstacles[rng.integers(0, 300, 6), rng.integers(0, 40, 6)] = True
    r = 270
    got = dense_fields(
        obstacles, distance=DistanceConfig(sigma_px=90.0, half_width_px=r), tile_px=32
    ).sq_distance_px.astype(np.float64)
    got[got >= FAR_SQ] = np.inf
    np.testing.assert_array_equal(got, brute_sq_distance(obstacles, r))


def test_row_pass_needed_region_is_exact_and_may_stop_early():
    """Pixels outside ``needed`` do not hold up a band's exit; needed ones stay exact."""
    from topojax.fields.distance import row_sq_distance_tile

    rng = np.random.default_rng(11)
    r, n, w = 20, 30, 24
    strip = rng.random((n + 2 * r, w + 2 * r)) < 0.01
    strip[:, : r + 6] = False  # an open area on the left: big distances there
    column = column_distance_tile(jnp.asarray(strip), half_width=r)
    full = np.asarray(row_sq_distance_tile(column, half_width=r))
    needed = np.array([3, 25, 8, 24], np.int32)
    part = np.asarray(
        jax.jit(partial(row_sq_distance_tile, half_width=r))(column, needed=jnp.asarray(needed))
    )
    np.testing.assert_array_equal(part[3:25, 8:24], full[3:25, 8:24])
    # elsewhere: never below the true value (an upper bound from real obstacles or FAR),
    # and here the open area's bands did stop early
    assert (part >= full).all()
    assert (part != full).any()
    ref = brute_sq_distance(strip, r)[r : r + n, r : r + w]
    ref[np.isinf(ref)] = FAR_SQ
    np.testing.assert_array_equal(full, ref)


@pytest.mark.parametrize("side", ["left", "right"])
def test_row_pass_keeps_pixels_reached_exactly_at_the_window_edge(side):
    """Pixels with an empty window leave a band's exit test; a pixel whose only obstacle
    lies exactly R columns away must stay in it (else the band stops at once)."""
    from topojax.fields.distance import row_sq_distance_tile

    r, n, w = 20, 26, 8
    column = np.full((n, w + 2 * r), np.iinfo(column_dtype(r)).max, column_dtype(r))
    edge = 0 if side == "left" else w + 2 * r - 1
    column[:, edge] = 3  # an obstacle 3 rows away in the window's outermost column
    got = np.asarray(row_sq_distance_tile(jnp.asarray(column), half_width=r))
    want = np.full((n, w), FAR_SQ, np.int64)
    want[:, 0 if side == "left" else w - 1] = r * r + 9
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("tile", [16, 40])
def test_empty_windows_next_to_far_obstacles_are_exact(tile):
    """Maps with unknown space around small clusters: bands that mix pixels with no
    obstacle in their window, pixels far from one and pixels next to one."""
    rng = np.random.default_rng(tile)
    r = 12
    for _ in range(4):
        obstacles = np.zeros((70, 90), bool)
        k = int(rng.integers(1, 5))
        obstacles[rng.integers(0, 70, k), rng.integers(0, 90, k)] = True
        got = dense_fields(
            obstacles, distance=DistanceConfig(sigma_px=5.0, half_width_px=r), tile_px=tile
        ).sq_distance_px.astype(np.float64)
        got[got >= FAR_SQ] = np.inf
        ref = brute_sq_distance(obstacles, r)
        assert np.isinf(ref).any() and np.isfinite(ref).any()
        np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("tile", [32, 64])
def test_sq_distances_above_16_bits_are_exact(tile):
    """Squared distances of 2^16 and more (nearest obstacle farther than 255 px: only in a
    window corner) are exact, and windows with no obstacle stay FAR."""
    r = 200
    obstacles = np.zeros((215, 240), bool)
    obstacles[5, 3] = True  # window corners reach 283 px away; beyond 200 px: no window
    got = dense_fields(
        obstacles, distance=DistanceConfig(sigma_px=60.0, half_width_px=r), tile_px=tile
    ).sq_distance_px.astype(np.float64)
    ref = brute_sq_distance(obstacles, r)
    assert (ref[np.isfinite(ref)] >= 65535).sum() > 500
    assert np.isinf(ref).any()
    got[got >= FAR_SQ] = np.inf
    np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("tile", [32, 128])
def test_row_pass_lane_width_choice_is_exact(tile):
    """Bands run in 16-bit lanes unless a needed pixel has no obstacle within R rows in
    the columns within h = isqrt(2^16 - 2 - R^2) of it (118 for R = 227): exact on both
    sides of that boundary (d^2 = R^2 + 118^2 stays below 2^16 - 1, R^2 + 119^2 does
    not), with random obstacles mixing both kinds of band in one map."""
    r = 227
    obstacles = np.zeros((260, 420), bool)
    obstacles[0, 0] = True
    got = dense_fields(
        obstacles, distance=DistanceConfig(sigma_px=64.0, half_width_px=r), tile_px=tile
    ).sq_distance_px
    assert got[r, 118] == r * r + 118**2 < 65535 <= got[r, 119] == r * r + 119**2
    rng = np.random.default_rng(tile)
    obstacles[rng.integers(0, 40, 3), rng.integers(380, 420, 3)] = True
    got = dense_fields(
        obstacles, distance=DistanceConfig(sigma_px=64.0, half_width_px=r), tile_px=tile
    ).sq_distance_px.astype(np.float64)
    ref = brute_sq_distance(obstacles, r)
    assert (ref[np.isfinite(ref)] >= 65535).any() and (ref < 65535).any()
    got[got >= FAR_SQ] = np.inf
    np.testing.assert_array_equal(got, ref)


def test_patch_view_into_a_reused_buffer_equals_a_fresh_one():
    grid = TileGrid((7, 11), 4)
    rng = np.random.default_rng(0)
    a, b = rng.random((7, 11)) < 0.5, rng.random((7, 11)) < 0.5
    halo = (3, 2)
    buf = np.ones(grid.padded_shape(halo), bool)  # stale content everywhere
    grid.patch_view(a, halo, fill=False, out=buf)
    np.testing.assert_array_equal(
        grid.patch_view(b, halo, fill=False, out=buf), grid.patch_view(b, halo, fill=False)
    )
    with pytest.raises(ValueError, match="out: expected shape"):
        grid.patch_view(b, halo, out=np.zeros((3, 3), bool))


def test_dense_fields_repr_is_one_short_line():
    """Printing the fields of a map says what they are (shape and dtypes), not their
    values: four arrays' worth of numbers is no summary."""
    obstacles = np.zeros((40, 30), bool)
    obstacles[0] = True
    text = repr(dense_fields(obstacles))
    assert text == (
        "DenseFields(40 x 30 px (rows x cols): sq_distance_px int32, distance float32, "
        "lap_abs uint8, ridges bool)"
    )
    only = repr(dense_fields(obstacles, outputs=("distance",)))
    assert only == (
        "DenseFields(40 x 30 px (rows x cols): distance float32; not computed: "
        "sq_distance_px, lap_abs, ridges)"
    )
