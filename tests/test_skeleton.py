"""Tests for topojax.skeleton: thinning (bit-exact with scikit-image) and T-centre removal.

References: ``skimage.morphology.thin`` (Guo-Hall) and ``skimage.morphology.skeletonize``
(Zhang-Suen, 2-D default) of scikit-image 0.26, the original implementation's reference
outputs in ``shared/data/reference`` and a slow pure-Python transcription of the documented
T-removal rules below. All comparisons are exact (tolerance 0 pixels).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy import ndimage as ndi
from skimage.morphology import skeletonize as sk_skeletonize
from skimage.morphology import thin as sk_thin

from topojax.skeleton import (
    _SKIMAGE_ZHANG_DEVIATIONS,
    THIN_METHODS,
    _pattern_code,
    _zhang_suen_paper_tables,
    remove_t_centres,
    skeletonize_ridges,
    thin,
    thinning_lookup_tables,
)

MAPS = ("intel", "office", "a_scan")
EIGHT = np.ones((3, 3), dtype=bool)
SKIMAGE = {"guo_hall": sk_thin, "zhang": sk_skeletonize}


def _img(text: str) -> np.ndarray:
    """Bool image from rows of '#' (set) and '.' (unset), separated by whitespace."""
    return np.array([[ch == "#" for ch in row] for row in text.split()], dtype=bool)


def _assert_same(actual: np.ndarray, expected: np.ndarray) -> None:
    assert actual.dtype == np.bool_
    assert actual.shape == expected.shape
    diff = np.argwhere(actual != expected)
    assert diff.size == 0, f"{len(diff)} pixels differ, first (row, col): {diff[:5].tolist()}"


def _random_image(shape: tuple[int, int], density: float, seed: int, kind: str) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = rng.random(shape) < density
    if kind == "dilated":
        img = ndi.binary_dilation(img, structure=EIGHT, iterations=2)
    elif kind == "border":
        img[0, :] = img[-1, :] = img[:, 0] = img[:, -1] = True
    elif kind == "full":
        img[:] = True
    elif kind == "empty":
        img[:] = False
    return img


# ---------------------------------------------------------------- lookup tables


def test_guo_hall_tables_equal_skimage_tables() -> None:
    sk = pytest.importorskip("skimage.morphology._skeletonize")
    if not hasattr(sk, "G123_LUT"):
        pytest.skip("scikit-image no longer exposes G123_LUT")
    tables = thinning_lookup_tables("guo_hall")
    assert tables.shape == (2, 256) and tables.dtype == np.bool_
    # Same neighbour-bit order as skimage's correlation mask [[8, 4, 2], [16, 0, 1], [32, 64, 128]].
    np.testing.assert_array_equal(tables[0], sk.G123_LUT)
    np.testing.assert_array_equal(tables[1], sk.G123P_LUT)


def test_tables_are_read_only() -> None:
    for method in THIN_METHODS:
        with pytest.raises(ValueError):
            thinning_lookup_tables(method)[0, 0] = True


def test_zhang_deviations_really_deviate_from_paper() -> None:
    paper = _zhang_suen_paper_tables()
    skimage_table = thinning_lookup_tables("zhang")
    codes = [_pattern_code(p) for p, _ in _SKIMAGE_ZHANG_DEVIATIONS]
    assert len(set(codes)) == len(codes)
    for (pattern, passes), code in zip(_SKIMAGE_ZHANG_DEVIATIONS, codes, strict=True):
        paper_passes = int(paper[0, code]) + 2 * int(paper[1, code])
        assert paper_passes != passes, pattern
        assert int(skimage_table[0, code]) + 2 * int(skimage_table[1, code]) == passes
    others = np.setdiff1d(np.arange(256), codes)
    np.testing.assert_array_equal(skimage_table[:, others], paper[:, others])


def _thin_numpy(img: np.ndarray, tables: np.ndarray) -> np.ndarray:
    """Plain full-image parallel thinning with ``tables`` (independent of the numba kernel)."""
    # Weights 2**k at the neighbour offsets E, NE, N, NW, W, SW, S, SE of the table convention.
    weights = np.array([[8, 4, 2], [16, 0, 1], [32, 64, 128]])
    skel = img.astype(np.int64)
    while True:
        before = skel.copy()
        for table in tables:
            code = ndi.correlate(skel, weights, mode="constant", cval=0)
            skel[table[code] & (skel == 1)] = 0
        if np.array_equal(before, skel):
            return skel.astype(bool)


def test_zhang_deviations_matter() -> None:
    """skimage keeps the top row of a 2x2 square; the published conditions delete all four."""
    img = np.zeros((6, 6), dtype=bool)
    img[2:4, 2:4] = True
    expected = np.zeros_like(img)
    expected[2, 2:4] = True
    _assert_same(sk_skeletonize(img), expected)
    assert _thin_numpy(img, _zhang_suen_paper_tables()).sum() == 0
    _assert_same(_thin_numpy(img, thinning_lookup_tables("zhang")), sk_skeletonize(img))
    _assert_same(thin(img, method="zhang"), sk_skeletonize(img))


@settings(max_examples=60, deadline=None)
@given(
    shape=st.tuples(st.integers(1, 30), st.integers(1, 30)),
    density=st.floats(0.05, 0.95),
    seed=st.integers(0, 2**32 - 1),
)
def test_tables_with_plain_iteration_match_skimage(shape, density, seed) -> None:
    img = _random_image(shape, density, seed, "random")
    for method in THIN_METHODS:
        _assert_same(_thin_numpy(img, thinning_lookup_tables(method)), SKIMAGE[method](img))


# ---------------------------------------------------------------- paper maps


@pytest.mark.parametrize("name", MAPS)
def test_reference_maps_match_skimage_and_original(paper_reference, name: str) -> None:
    ref = paper_reference(name)
    ridge = ref["ridge"]
    _assert_same(thin(ridge), sk_thin(ridge))
    zhang = thin(ridge, method="zhang")
    _assert_same(zhang, sk_skeletonize(ridge))
    _assert_same(zhang, ref["skeleton_pre_T"])
    _assert_same(remove_t_centres(ref["skeleton_pre_T"]), ref["skeleton"])
    _assert_same(skeletonize_ridges(ridge, method="zhang"), ref["skeleton"])
    _assert_same(skeletonize_ridges(ridge, method="zhang", remove_t=False), zhang)
    _assert_same(skeletonize_ridges(ridge), remove_t_centres(sk_thin(ridge)))


# ---------------------------------------------------------------- random images


@settings(max_examples=400, deadline=None)
@given(
    shape=st.tuples(st.integers(1, 48), st.integers(1, 48)),
    density=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**32 - 1),
    kind=st.sampled_from(["random", "dilated", "border", "full", "empty"]),
)
def test_thin_matches_skimage_on_random_images(shape, density, seed, kind) -> None:
    img = _random_image(shape, density, seed, kind)
    for method in THIN_METHODS:
        _assert_same(thin(img, method=method), SKIMAGE[method](img))


@settings(max_examples=400, deadline=None)
@given(hnp.arrays(np.bool_, st.tuples(st.integers(1, 12), st.integers(1, 12))))
def test_thin_matches_skimage_on_small_arrays(img) -> None:
    for method in THIN_METHODS:
        _assert_same(thin(img, method=method), SKIMAGE[method](img))


def test_reused_work_space_across_calls_sizes_and_threads() -> None:
    """The kernel's work space (image buffer, pixel lists; a queued pixel is marked in
    the image itself) is kept per thread between calls: every call, whatever came before
    it (other sizes, both methods, other threads), equals scikit-image."""
    import threading

    from topojax import skeleton

    rng = np.random.default_rng(5)
    images = [
        ndi.binary_dilation(rng.random(shape) < 0.02, iterations=3)
        for shape in [(90, 120), (30, 40), (90, 120), (200, 170), (31, 41)]
    ]

    def check(results: list) -> None:
        for img in images:
            for method, ref in (("guo_hall", sk_thin), ("zhang", sk_skeletonize)):
                results.append(np.array_equal(thin(img, method=method), ref(img)))

    ok: list = []
    check(ok)
    check(ok)
    workers = [threading.Thread(target=check, args=(ok,)) for _ in range(3)]
    for t in workers:
        t.start()
    for t in workers:
        t.join()
    assert len(ok) == 5 * 2 * 5 and all(ok)
    # images above the kept size get a work space of their own, not kept
    skeleton._THIN_SCRATCH_MAX_PX, keep = 1000, skeleton._THIN_SCRATCH_MAX_PX
    try:
        kept = skeleton._THIN_SCRATCH.space.flat
        img = images[3]  # 202 x 172 framed pixels
        assert np.array_equal(thin(img), sk_thin(img))
        assert skeleton._THIN_SCRATCH.space.flat is kept
    finally:
        skeleton._THIN_SCRATCH_MAX_PX = keep


@settings(max_examples=80, deadline=None)
@given(
    shape=st.tuples(st.integers(1, 40), st.integers(1, 40)),
    density=st.floats(0.05, 0.95),
    seed=st.integers(0, 2**32 - 1),
    kind=st.sampled_from(["random", "dilated", "border"]),
)
def test_thinning_properties(shape, density, seed, kind) -> None:
    img = _random_image(shape, density, seed, kind)
    n_components = ndi.label(img, structure=EIGHT)[1]
    for method in THIN_METHODS:
        out = thin(img, method=method)
        assert not (out & ~img).any(), "thinning must only delete pixels"
        _assert_same(thin(out, method=method), out)  # result is a fixed point
    # Guo & Hall (1989) prove that algorithm A1 preserves 8-connected components.
    assert ndi.label(thin(img), structure=EIGHT)[1] == n_components


@pytest.mark.parametrize(
    "shape", [(1, 1), (1, 7), (7, 1), (2, 2), (2, 9), (9, 2), (3, 3), (1, 64), (64, 1)]
)
@pytest.mark.parametrize("fill", ["full", "empty", "border", "random"])
def test_degenerate_shapes(shape, fill) -> None:
    img = _random_image(shape, 0.6, 7, fill)
    for method in THIN_METHODS:
        _assert_same(thin(img, method=method), SKIMAGE[method](img))


def _shapes() -> dict[str, np.ndarray]:
    rr, cc = np.mgrid[0:61, 0:67]
    d = np.hypot(rr - 30, cc - 33)
    ellipse = ((rr - 30) / 25.0) ** 2 + ((cc - 33) / 12.0) ** 2 <= 1
    bars = np.zeros((40, 50), dtype=bool)
    bars[5:12, 2:48] = True
    bars[5:38, 20:27] = True
    bars[30:34, :] = True  # touches both side borders
    return {
        "disk": d <= 20,
        "ring": (d >= 12) & (d <= 20),
        "thick_ring_at_border": (d >= 20) & (d <= 40),
        "ellipse": ellipse,
        "bars": bars,
        "square": np.pad(np.ones((15, 15), dtype=bool), 3),
        "full_square": np.ones((15, 15), dtype=bool),
        "checkerboard": (rr + cc) % 2 == 0,
    }


@pytest.mark.parametrize("name", list(_shapes()))
def test_thick_shapes_match_skimage(name: str) -> None:
    img = _shapes()[name]
    for method in THIN_METHODS:
        _assert_same(thin(img, method=method), SKIMAGE[method](img))


def test_thin_on_views_and_other_dtypes() -> None:
    img = _shapes()["ring"]
    for view in (img.T, img[::2, 1::3], np.asfortranarray(img)):
        for method in THIN_METHODS:
            _assert_same(thin(view, method=method), SKIMAGE[method](view))
    expected = sk_thin(img)
    _assert_same(thin(img.astype(np.uint8) * 255), expected)
    _assert_same(thin(np.where(img, -2.5, 0.0)), expected)
    _assert_same(thin(img.astype(np.int64).tolist()), expected)
    copy = img.copy()
    thin(copy)
    _assert_same(copy, img)  # input untouched


def test_empty_image_shape_is_kept() -> None:
    out = thin(np.zeros((0, 5), dtype=bool))
    assert out.shape == (0, 5) and out.dtype == np.bool_
    assert remove_t_centres(np.zeros((3, 0))).shape == (3, 0)


# ---------------------------------------------------------------- errors


def test_thin_rejects_bad_input() -> None:
    img = np.zeros((4, 4), dtype=bool)
    with pytest.raises(
        ValueError, match=r"method: expected one of \['guo_hall', 'zhang'\], received 'lee'"
    ):
        thin(img, method="lee")
    with pytest.raises(ValueError, match="method"):
        thin(img, method=None)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"ridge: expected a 2-D array.*\(2, 2, 2\)"):
        thin(np.zeros((2, 2, 2)))
    with pytest.raises(ValueError, match="ridge: expected a 2-D array"):
        thin(np.zeros(5))
    bad = np.zeros((3, 3))
    bad[1, 1] = np.nan
    with pytest.raises(ValueError, match="ridge contains NaN"):
        thin(bad)
    with pytest.raises(TypeError, match="ridge: expected a 2-D array of bool or real numbers"):
        thin(np.array([["a", "b"], ["c", "d"]]))
    with pytest.raises(TypeError, match="dtype object"):
        thin(np.array([[None, 1], [1, 1]], dtype=object))


def test_remove_t_and_pipeline_reject_bad_input() -> None:
    with pytest.raises(ValueError, match="skeleton: expected a 2-D array"):
        remove_t_centres(np.zeros((2, 2, 2), dtype=bool))
    with pytest.raises(ValueError, match="skeleton contains NaN"):
        remove_t_centres(np.full((3, 3), np.nan))
    with pytest.raises(TypeError, match="remove_t: expected a bool"):
        skeletonize_ridges(np.zeros((3, 3), dtype=bool), remove_t="yes")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="method: expected one of"):
        skeletonize_ridges(np.zeros((3, 3), dtype=bool), method="zhang_suen")


# ---------------------------------------------------------------- T-centre removal


def _remove_t_reference(skel: np.ndarray) -> np.ndarray:
    """Slow transcription of the documented rules of the original ``remove_Tcenter``."""
    s = skel.copy()
    h, w = s.shape

    def is_set(r: int, c: int) -> bool:
        return 0 <= r < h and 0 <= c < w and bool(s[r, c])

    def t_centre(r: int, c: int) -> bool:
        up, down = is_set(r - 1, c), is_set(r + 1, c)
        left, right = is_set(r, c - 1), is_set(r, c + 1)
        # A T: the pixel plus three of its four 4-neighbours; the missing arm may be any one.
        return (
            (up and left and right)
            or (down and left and right)
            or (up and down and left)
            or (up and down and right)
        )

    order = [(r, c) for r in range(1, h - 1) for c in range(1, w - 1)]
    if h >= 2:
        order += [(0, c) for c in range(1, w - 1)] + [(h - 1, c) for c in range(1, w - 1)]
    if w >= 2:
        order += [(r, 0) for r in range(1, h - 1)] + [(r, w - 1) for r in range(1, h - 1)]
    for r, c in order:
        if s[r, c] and t_centre(r, c):
            s[r, c] = False
    return s


def test_remove_t_plus_sign() -> None:
    plus = _img(
        """
        ..#..
        ..#..
        #####
        ..#..
        ..#..
        """
    )
    expected = plus.copy()
    expected[2, 2] = False
    _assert_same(remove_t_centres(plus), expected)


def test_remove_t_interior_t() -> None:
    t_shape = _img(
        """
        .....
        #####
        ..#..
        ..#..
        """
    )
    expected = t_shape.copy()
    expected[1, 2] = False
    _assert_same(remove_t_centres(t_shape), expected)


def test_remove_t_on_each_border_uses_1d_rule() -> None:
    t_top = _img(
        """
        #####
        ..#..
        ..#..
        """
    )
    expected = t_top.copy()
    expected[0, 2] = False  # left, right and below set; the corners (0, 0), (0, 4) stay
    _assert_same(remove_t_centres(t_top), expected)
    # The same T rotated onto every other border.
    for k in (1, 2, 3):
        _assert_same(remove_t_centres(np.rot90(t_top, k)), np.rot90(expected, k))
    # A full border row alone is not a T (no inward neighbour).
    line = np.zeros((3, 6), dtype=bool)
    line[0] = True
    _assert_same(remove_t_centres(line), line)


def test_remove_t_corners_never_cleared() -> None:
    img = np.ones((2, 2), dtype=bool)
    _assert_same(remove_t_centres(img), img)
    img = np.ones((4, 4), dtype=bool)
    out = remove_t_centres(img)
    assert out[0, 0] and out[0, -1] and out[-1, 0] and out[-1, -1]


def test_remove_t_raster_order_matters() -> None:
    two_ts = _img(
        """
        ......
        ######
        ..##..
        ..##..
        ......
        """
    )
    # In raster order (1, 2) is cleared first; (1, 3) then has only two set 4-neighbours,
    # and (2, 2) loses its upper neighbour, so the next T centre is (2, 3). A decision from a
    # snapshot would clear all four of (1, 2), (1, 3), (2, 2), (2, 3).
    expected = two_ts.copy()
    expected[1, 2] = expected[2, 3] = False
    _assert_same(remove_t_centres(two_ts), expected)


def test_remove_t_interior_before_border() -> None:
    img = _img(
        """
        .###.
        .##..
        ..#..
        ..#..
        """
    )
    # The interior pixel (1, 2) (up, down and left set) is examined before the border pixel
    # (0, 2) and cleared, so (0, 2) no longer has a set neighbour below and is kept.
    expected = img.copy()
    expected[1, 2] = False
    _assert_same(remove_t_centres(img), expected)


def test_remove_t_does_not_modify_input_and_accepts_numbers() -> None:
    plus = np.zeros((3, 3), dtype=np.uint8)
    plus[1, :] = plus[:, 1] = 7
    before = plus.copy()
    out = remove_t_centres(plus)
    np.testing.assert_array_equal(plus, before)
    assert out.dtype == np.bool_ and not out[1, 1] and out.sum() == 4


@settings(max_examples=400, deadline=None)
@given(hnp.arrays(np.bool_, st.tuples(st.integers(1, 10), st.integers(1, 10))))
def test_remove_t_matches_reference_rules(img) -> None:
    _assert_same(remove_t_centres(img), _remove_t_reference(img))


@settings(max_examples=60, deadline=None)
@given(
    shape=st.tuples(st.integers(1, 40), st.integers(1, 40)),
    density=st.floats(0.05, 0.95),
    seed=st.integers(0, 2**32 - 1),
    method=st.sampled_from(THIN_METHODS),
)
def test_remove_t_on_thinned_images(shape, density, seed, method) -> None:
    img = _random_image(shape, density, seed, "dilated")
    skel = SKIMAGE[method](img)
    _assert_same(remove_t_centres(skel), _remove_t_reference(skel))
    _assert_same(skeletonize_ridges(img, method=method), _remove_t_reference(skel))


def test_same_results_with_numba_switched_off(tmp_path) -> None:
    """With ``NUMBA_DISABLE_JIT=1`` the kernels run as plain Python on NumPy scalars:
    counts summed from uint8 pixels must not wrap at 256 (wrapped, they give wrong
    skeletons)."""
    import json
    import os
    import subprocess
    import sys

    script = """
import json, sys
import numpy as np
from skimage.morphology import skeletonize, thin as sk_thin
from topojax.skeleton import thin, remove_t_centres
from topojax.graph import skeleton_to_graph
rng = np.random.default_rng(4)
img = rng.random((60, 70)) < 0.6
img[5:50, 5:65] |= True
out = {}
for method, ref in (("zhang", skeletonize), ("guo_hall", sk_thin)):
    sk = thin(img, method=method)
    out[method] = bool((sk == ref(img)).all()) and int(sk.sum()) > 256
    g = skeleton_to_graph(remove_t_centres(sk))
    out[method + "_graph"] = [g.number_of_nodes(), g.number_of_edges()]
json.dump(out, sys.stdout)
"""
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    run = subprocess.run(
        [sys.executable, "-W", "error::RuntimeWarning", "-c", script],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    got = json.loads(run.stdout)
    assert got["zhang"] and got["guo_hall"]
    # the graphs equal the compiled kernels' graphs
    from topojax.graph import skeleton_to_graph
    from topojax.skeleton import remove_t_centres, thin

    rng = np.random.default_rng(4)
    img = rng.random((60, 70)) < 0.6
    img[5:50, 5:65] |= True
    for method in ("zhang", "guo_hall"):
        g = skeleton_to_graph(remove_t_centres(thin(img, method=method)))
        assert got[method + "_graph"] == [g.number_of_nodes(), g.number_of_edges()]


def test_kernels_compile_without_numba_cache_where_none_can_be_written(monkeypatch) -> None:
    """In a read-only install with no writable cache folder numba's ``cache=True`` raises
    at decoration (import) time; the kernels must then compile uncached, with a warning."""
    import numba

    from topojax import _jit

    real = numba.njit

    def njit(*args, cache=False, **kwargs):
        if cache:
            raise RuntimeError("cannot cache function 'f': no locator available for file 'x'")
        return real(*args, **kwargs)

    monkeypatch.setattr(_jit.numba, "njit", njit)
    monkeypatch.setattr(_jit, "_warned", False)

    def add(a, b):
        return a + b

    with pytest.warns(RuntimeWarning, match="NUMBA_CACHE_DIR"):
        fast = _jit.cached_njit(nogil=True)(add)
    assert fast(2, 3) == 5
    # other errors are not swallowed
    monkeypatch.setattr(_jit.numba, "njit", lambda **kw: (_ for _ in ()).throw(RuntimeError("x")))
    with pytest.raises(RuntimeError, match="x"):
        _jit.cached_njit()(add)
