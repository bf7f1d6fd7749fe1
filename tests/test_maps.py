"""Tests for topojax.maps: OccupancyMap, from_array, load_map, save_map."""

from __future__ import annotations

import math
import os
import re
import struct
import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from conftest import SHARED_DATA
from PIL import Image

import topojax as tj
from topojax.maps import OccupancyMap, load_map, save_map

MAP_SUFFIXES = {".yaml", ".png", ".pgm"}
_MAPS_DIR = SHARED_DATA / "maps"
MAP_FILES = (
    sorted(p for p in _MAPS_DIR.rglob("*") if p.suffix.lower() in MAP_SUFFIXES)
    if _MAPS_DIR.is_dir()
    else []
)


# ---------------------------------------------------------------------- reference helpers


def _png_bit_depth(path: Path) -> int | None:
    """Bit depth from a PNG's IHDR chunk (byte 24 of the file), None if not a PNG."""
    head = path.read_bytes()[:25]
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    return head[24]


def reference_grey(path: Path) -> tuple[np.ndarray, int]:
    """Mean of the colour channels as float64, decoded independently of topojax.

    8-bit files are decoded with PIL (palette/LA/RGBA converted to RGB); 16-bit PNGs with
    OpenCV (PIL cannot give 16-bit RGBA), returning the full scale (255 or 65535).
    """
    if _png_bit_depth(path) == 16:
        raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        assert raw.dtype == np.uint16
        colour = raw if raw.ndim == 2 else raw[..., :3]
        grey = colour.astype(np.float64) if raw.ndim == 2 else colour.mean(axis=2)
        return grey, 65535
    with Image.open(path) as im:
        if im.mode == "L":
            return np.asarray(im, dtype=np.float64), 255
        rgb = np.asarray(im.convert("RGB"), dtype=np.float64)
    return rgb.mean(axis=2), 255


def reference_classes(
    grey: np.ndarray, full: int, occ: float, free: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """map_server rule written out in float64: p = (full - v) / full."""
    p = (full - grey) / full
    occupied = p > occ
    free_m = p < free
    unknown = ~occupied & ~free_m
    return occupied, free_m, unknown


def yaml_doc(path: Path) -> dict:
    with open(path, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def yaml_image_path(path: Path) -> Path:
    """Image of a map YAML, resolved independently (by basename next to the YAML)."""
    return path.parent / Path(yaml_doc(path)["image"]).name


def assert_partition(m: OccupancyMap) -> None:
    for mask in (m.occupied, m.free, m.unknown):
        assert mask.dtype == np.bool_
        assert mask.shape == m.shape
        assert not mask.flags.writeable
    total = m.occupied.astype(int) + m.free.astype(int) + m.unknown.astype(int)
    assert np.all(total == 1)
    h, w = m.shape
    assert int(m.occupied.sum() + m.free.sum() + m.unknown.sum()) == h * w


# ---------------------------------------------------------------------- every real map


@pytest.mark.parametrize(
    "map_path", MAP_FILES, ids=[str(p.relative_to(_MAPS_DIR)) for p in MAP_FILES]
)
def test_every_shared_map_loads_and_matches_reference(shared_data: Path, map_path: Path):
    m = load_map(map_path)
    assert_partition(m)
    assert m.source == str(map_path)
    if map_path.suffix == ".yaml":
        doc = yaml_doc(map_path)
        grey, full = reference_grey(yaml_image_path(map_path))
        occ_t = float(doc.get("occupied_thresh", 0.65))
        free_t = float(doc.get("free_thresh", 0.196))
        assert int(doc.get("negate", 0)) == 0
        assert doc.get("mode", "trinary") == "trinary"
        assert m.resolution_m == float(doc["resolution"])
        assert m.origin == tuple(float(v) for v in doc["origin"])
    else:
        grey, full = reference_grey(map_path)
        occ_t, free_t = 0.65, 0.196
        assert m.origin == (0.0, 0.0, 0.0)
        head = map_path.read_bytes()[:200]
        if b"m/pix" in head:
            expected = float(head.split(b"m/pix")[0].split()[-1])
            assert m.resolution_m == pytest.approx(expected, rel=0, abs=1e-12)
        else:
            assert m.resolution_m == 0.05
    assert m.shape == grey.shape
    occupied, free, unknown = reference_classes(grey, full, occ_t, free_t)
    assert np.array_equal(m.occupied, occupied)
    assert np.array_equal(m.free, free)
    assert np.array_equal(m.unknown, unknown)
    counts = (int(m.occupied.sum()), int(m.free.sum()), int(m.unknown.sum()))
    assert counts == (int(occupied.sum()), int(free.sum()), int(unknown.sum()))
    if full == 255 and (occ_t, free_t) == (0.65, 0.196):
        # README: with 0.65 / 0.196, v <= 89 is occupied, v >= 206 is free (integer means).
        integral = grey == np.round(grey)
        assert np.array_equal(m.occupied[integral], grey[integral] <= 89)
        assert np.array_equal(m.free[integral], grey[integral] >= 206)


# ---------------------------------------------------------------------- specific real maps


def _grey_of(shared_data: Path, rel: str) -> np.ndarray:
    grey, full = reference_grey(shared_data / "maps" / rel)
    assert full == 255
    return grey


def test_trinary_slam_pgms_are_exactly_0_205_254(shared_data: Path):
    for p in sorted((shared_data / "maps" / "slam_pgm").glob("*.pgm")):
        v = _grey_of(shared_data, str(p.relative_to(shared_data / "maps")))
        assert set(np.unique(v).tolist()) <= {0.0, 205.0, 254.0}
        m = load_map(p)
        assert np.array_equal(m.occupied, v == 0)
        assert np.array_equal(m.unknown, v == 205)
        assert np.array_equal(m.free, v == 254)


def test_pal_office_127_is_unknown(shared_data: Path):
    m = load_map(shared_data / "maps/ros/pal_office_7th_floor/map.yaml")
    v = _grey_of(shared_data, "ros/pal_office_7th_floor/map.pgm")
    assert set(np.unique(v).tolist()) == {0.0, 127.0, 255.0}
    assert np.count_nonzero(v == 127) > 0
    assert np.array_equal(m.unknown, v == 127)
    assert np.array_equal(m.occupied, v == 0)
    assert np.array_equal(m.free, v == 255)
    assert m.resolution_m == 0.025
    assert m.origin == (-15.010291, -29.007413, 0.0)


def test_depot_205_is_free_with_free_thresh_025(shared_data: Path):
    yaml_path = shared_data / "maps/simulated/nav2/depot.yaml"
    m = load_map(yaml_path)
    v = _grey_of(shared_data, "simulated/nav2/depot.pgm")
    assert np.count_nonzero(v == 205) > 0
    assert np.all(m.free[v == 205])
    assert int(m.unknown.sum()) == 0
    # With the usual 0.196 (keyword overrides the YAML) 205 becomes unknown again.
    m2 = load_map(yaml_path, free_thresh=0.196)
    assert np.array_equal(m2.unknown, v == 205)
    # The PGM alone uses the default thresholds.
    m3 = load_map(shared_data / "maps/simulated/nav2/depot.pgm")
    assert np.array_equal(m3.unknown, m2.unknown)


def test_warehouse_free_thresh_01(shared_data: Path):
    m = load_map(shared_data / "maps/simulated/nav2/warehouse.yaml")
    v = _grey_of(shared_data, "simulated/nav2/warehouse.pgm")
    # free iff (255 - v) / 255 < 0.1  <=>  v >= 230 for integer v.
    assert np.array_equal(m.free, v >= 230)
    assert np.all(m.unknown[v == 205])
    assert np.all(m.free[(v == 254) | (v == 255)])


def test_turtlebot3_absolute_image_path_falls_back_to_basename(shared_data: Path):
    yaml_path = shared_data / "maps/ros/turtlebot3_office/map_office_raw.yaml"
    image = yaml_doc(yaml_path)["image"]
    assert Path(image).is_absolute() and not Path(image).exists()
    m = load_map(yaml_path)
    direct = load_map(yaml_path.with_suffix(".pgm"))
    assert np.array_equal(m.occupied, direct.occupied)
    assert np.array_equal(m.free, direct.free)
    assert m.origin == (-10.0, -10.0, 0.0)
    assert m.resolution_m == 0.05
    # Centre of the lower-left pixel is half a pixel inside the origin.
    x, y = m.pixel_to_world(m.shape[0] - 1, 0)
    assert x == pytest.approx(-10.0 + 0.025, abs=1e-12)
    assert y == pytest.approx(-10.0 + 0.025, abs=1e-12)
    # Centre of the top-right pixel.
    x, y = m.pixel_to_world(0, m.shape[1] - 1)
    assert x == pytest.approx(-10.0 + (384 - 0.5) * 0.05, abs=1e-12)
    assert y == pytest.approx(-10.0 + (384 - 0.5) * 0.05, abs=1e-12)


def test_pgm_header_resolution_is_used(shared_data: Path):
    assert load_map(shared_data / "maps/slam_pgm/DM_0.11.pgm").resolution_m == 0.11
    assert load_map(shared_data / "maps/slam_pgm/aces_0.10.pgm").resolution_m == 0.1
    # GIMP re-saved file: no header, default 0.05 (the file name says 0.06).
    assert load_map(shared_data / "maps/slam_pgm/edmonton_0.06.pgm").resolution_m == 0.05
    assert (
        load_map(shared_data / "maps/slam_pgm/edmonton_0.06.pgm", resolution_m=0.06).resolution_m
        == 0.06
    )


def test_paper_maps_have_no_unknown(shared_data: Path):
    for name in ("intel", "office", "a_scan"):
        v = _grey_of(shared_data, f"paper/{name}.png")
        m = load_map(shared_data / "maps/paper" / f"{name}.png")
        assert set(np.unique(v).tolist()) == {0.0, 255.0}
        assert int(m.unknown.sum()) == 0
        assert np.array_equal(m.occupied, v == 0)


def test_ipa_mode_and_default_mode_on_ipa_map(shared_data: Path):
    path = shared_data / "maps/ipa/freiburg_building79.png"
    v = _grey_of(shared_data, "ipa/freiburg_building79.png")
    assert set(np.unique(v).tolist()) == {0.0, 153.0, 255.0}
    default = load_map(path)
    assert np.array_equal(default.unknown, v == 153)  # grey outside is unknown by default
    ipa = load_map(path, mode="ipa")
    assert np.array_equal(ipa.free, v >= 250)
    assert np.array_equal(ipa.occupied, v < 250)
    assert int(ipa.unknown.sum()) == 0


def test_ipa_mode_reads_16_bit_images_as_the_ipa_tools_do(tmp_path: Path):
    """The IPA tools read a 16-bit map as 8-bit by keeping the high byte
    (``cv::imread(path, 0)``), so 64000 .. 64249 is their 250, free; mode="ipa" scaled
    250 / 255 to 64250 instead and made those pixels obstacles."""
    img = np.array([[63999, 64000, 64249], [64250, 65535, 0]], dtype=np.uint16)
    assert cv2.imwrite(str(tmp_path / "m.png"), img)
    as_ipa = cv2.imread(str(tmp_path / "m.png"), cv2.IMREAD_GRAYSCALE) >= 250
    assert as_ipa.tolist() == [[False, True, True], [True, True, False]]
    for path in (tmp_path / "m.png", SHARED_DATA / "maps/ipa/lab_b.png"):
        if not path.is_file():
            continue
        m = load_map(path, mode="ipa")
        expected = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE) >= 250
        assert np.array_equal(m.free, expected) and np.array_equal(m.occupied, ~expected)


def test_palette_png_from_data(shared_data: Path):
    path = shared_data / "maps/ipa/lab_e.png"
    with Image.open(path) as im:
        assert im.mode == "P"
    v = _grey_of(shared_data, "ipa/lab_e.png")
    m = load_map(path)
    assert np.array_equal(m.occupied, v == 0)
    assert np.array_equal(m.free, v == 255)


def test_16bit_rgba_png_from_data(shared_data: Path):
    path = shared_data / "maps/ipa/lab_b.png"
    assert _png_bit_depth(path) == 16
    raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    grey = raw[..., :3].astype(np.float64).mean(axis=2)
    m = load_map(path)
    occ, free, unk = reference_classes(grey, 65535, 0.65, 0.196)
    assert np.array_equal(m.occupied, occ)
    assert np.array_equal(m.free, free)
    # The 8-bit view (high byte) agrees except possibly right at the thresholds.
    hi = (raw[..., :3] >> 8).astype(np.float64).mean(axis=2)
    occ8, free8, _ = reference_classes(hi, 255, 0.65, 0.196)
    assert np.count_nonzero(occ8 != occ) + np.count_nonzero(free8 != free) < 0.001 * grey.size


# ---------------------------------------------------------------------- coordinates


def _small_map(h: int = 5, w: int = 7, **kw) -> OccupancyMap:
    arr = np.zeros((h, w), dtype=bool)
    arr[0, :] = True
    return OccupancyMap.from_array(arr, **kw)


def test_pixel_to_world_without_yaw_matches_map_server_formula():
    m = _small_map(resolution_m=0.1, origin=(2.0, -3.0, 0.0))
    rows = np.array([0, 4, 2])
    cols = np.array([0, 6, 3])
    x, y = m.pixel_to_world(rows, cols)
    assert x.dtype == np.float64 and y.dtype == np.float64
    np.testing.assert_allclose(x, 2.0 + (cols + 0.5) * 0.1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(y, -3.0 + (5 - rows - 0.5) * 0.1, rtol=0, atol=1e-12)


def test_coordinate_conversions_name_arguments_of_mismatched_shapes():
    """Coordinates of mismatched shapes are refused naming both arguments, not left to
    NumPy's "operands could not be broadcast together", which names neither."""
    m = _small_map()
    tiled = tj.TiledMap.from_occupancy(m)
    for convert, names in (
        (m.pixel_to_world, "rows, cols"),
        (tiled.pixel_to_world, "rows, cols"),
        (m.world_to_pixel, "x, y"),
        (tiled.world_to_pixel, "x, y"),
    ):
        with pytest.raises(ValueError, match=rf"^{names}: .* received shapes \(2,\) and \(3,\)"):
            convert([1, 2], [1, 2, 3])
        assert convert([[1], [2]], [1, 2, 3])[0].shape == (2, 3)  # broadcasting still works


@pytest.mark.parametrize(
    ("attr", "value", "words"),
    [
        ("shape", 5, r"recorded shape to be 2 integers \(rows, cols\), received 5"),
        ("shape", (4.5, 6.0), r"recorded shape to be 2 integers .* received \(4.5, 6.0\)"),
        ("shape", (4, np.nan), r"recorded shape to be 2 integers .* received \(4, nan\)"),
        ("origin", ["a", "b", "c"], r"recorded origin to be 3 numbers .* \['a', 'b', 'c'\]"),
        ("origin", 0.0, "recorded origin to be 3 numbers .* received 0.0"),
        ("resolution_m", "0.1", "recorded resolution_m to be a number, received str '0.1'"),
    ],
)
def test_a_graphs_malformed_map_attributes_are_named_not_crashed_on(attr, value, words):
    """A graph whose recorded shape or origin was edited into a non-sequence or into
    strings is refused naming the attribute wherever it meets a map, not left to fail
    inside NumPy or tuple() ("'int' object is not iterable"); nor is a str resolution
    taken for no resolution."""
    m = _small_map()
    graph = tj.build_graph(m).graph
    graph.graph[attr] = value
    with pytest.raises(ValueError, match=rf"^occupancy: expected the graph's {words}"):
        tj.RoutePlanner(graph, occupancy=m, robot_radius_m=0.0)


def test_coordinate_conversions_refuse_non_numbers():
    """None and strings are refused naming the argument: None would become NaN
    coordinates without a word, and a string would fail inside NumPy ("could not convert
    string to float")."""
    m = _small_map()
    tiled = tj.TiledMap.from_occupancy(m)
    for convert, names in (
        (m.pixel_to_world, ("rows", "cols")),
        (tiled.pixel_to_world, ("rows", "cols")),
        (m.world_to_pixel, ("x", "y")),
    ):
        for bad in (None, "a", [True, False]):
            with pytest.raises(TypeError, match=f"^{names[0]}: expected a number or an array"):
                convert(bad, 0)
            with pytest.raises(TypeError, match=f"^{names[1]}: expected a number or an array"):
                convert(0, bad)
    assert np.isnan(m.pixel_to_world(np.nan, 0)[0])  # NaN stays a float: it propagates


@pytest.mark.parametrize("yaw", [0.0, 0.3, -1.2, math.pi / 2, math.pi, 2.5])
def test_pixel_to_world_with_yaw_and_round_trip(yaw: float):
    res, ox, oy = 0.05, 1.5, -2.25
    m = _small_map(h=40, w=30, resolution_m=res, origin=(ox, oy, yaw))
    rng = np.random.default_rng(0)
    rows = rng.uniform(-5, 45, size=200)
    cols = rng.uniform(-5, 35, size=200)
    x, y = m.pixel_to_world(rows, cols)
    # Reference: rotation matrix applied to the unrotated map-frame point.
    local = np.stack([(cols + 0.5) * res, (40 - rows - 0.5) * res])
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    ref = rot @ local + np.array([[ox], [oy]])
    np.testing.assert_allclose(x, ref[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(y, ref[1], rtol=0, atol=1e-12)
    r2, c2 = m.world_to_pixel(x, y)
    np.testing.assert_allclose(r2, rows, rtol=0, atol=1e-9)
    np.testing.assert_allclose(c2, cols, rtol=0, atol=1e-9)
    # Integer pixel centres round-trip to integers.
    rr, cc = np.meshgrid(np.arange(40), np.arange(30), indexing="ij")
    r3, c3 = m.world_to_pixel(*m.pixel_to_world(rr, cc))
    assert np.array_equal(np.rint(r3).astype(int), rr)
    assert np.array_equal(np.rint(c3).astype(int), cc)
    # Scalars and broadcasting.
    xs, ys = m.pixel_to_world(3, np.arange(4))
    assert xs.shape == (4,) and ys.shape == (4,)


def test_yaml_yaw_is_honoured(tmp_path: Path):
    img = np.full((10, 20), 254, dtype=np.uint8)
    img[2:4, 5:9] = 0
    cv2.imwrite(str(tmp_path / "m.pgm"), img)
    (tmp_path / "m.yaml").write_text(
        "image: m.pgm\nresolution: 0.2\norigin: [1.0, 2.0, 0.7]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    m = load_map(tmp_path / "m.yaml")
    assert m.origin == (1.0, 2.0, 0.7)
    # Lower-left pixel centre is (0.1, 0.1) in the map frame, rotated by 0.7 rad.
    x, y = m.pixel_to_world(9, 0)
    c, s = math.cos(0.7), math.sin(0.7)
    assert x == pytest.approx(1.0 + c * 0.1 - s * 0.1, abs=1e-12)
    assert y == pytest.approx(2.0 + s * 0.1 + c * 0.1, abs=1e-12)
    assert np.array_equal(m.occupied, img == 0)


# ---------------------------------------------------------------------- from_array


def test_from_array_bool():
    arr = np.array([[True, False, False], [False, True, True]])
    m = OccupancyMap.from_array(arr, resolution_m=0.1)
    assert np.array_equal(m.occupied, arr)
    assert np.array_equal(m.free, ~arr)
    assert not m.unknown.any()
    assert m.shape == (2, 3)
    # The caller's array stays writeable and is not aliased.
    arr[0, 0] = False
    assert m.occupied[0, 0]


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int32, np.int64, np.uint16])
def test_from_array_occupancy_grid(dtype):
    values = np.array([-1, 0, 19, 20, 50, 65, 66, 100], dtype=np.int64)
    if dtype == np.uint16:
        values = values[1:]
    arr = np.stack([values, values[::-1]]).astype(dtype)
    m = OccupancyMap.from_array(arr)
    v = arr.astype(np.int64)
    assert np.array_equal(m.unknown, (v == -1) | ((v >= 20) & (v <= 65)))
    assert np.array_equal(m.free, (v >= 0) & (v <= 19))
    assert np.array_equal(m.occupied, v >= 66)
    m2 = OccupancyMap.from_array(arr, occupied_thresh=0.5, free_thresh=0.25)
    assert np.array_equal(m2.free, (v >= 0) & (v < 25))
    assert np.array_equal(m2.occupied, v > 50)


def test_from_array_float_probability():
    arr = np.array([[0.0, 0.1, 0.195, 0.196, 0.5], [0.65, 0.651, 0.9, 1.0, 0.3]])
    for dtype in (np.float16, np.float32, np.float64):
        a = arr.astype(dtype)
        m = OccupancyMap.from_array(a)
        assert np.array_equal(m.free, a < dtype(0.196))
        assert np.array_equal(m.occupied, a > dtype(0.65))
        assert np.array_equal(m.unknown, ~m.free & ~m.occupied)


@pytest.mark.parametrize("dtype", [np.float16, np.float32, "bfloat16"])
def test_from_array_float_threshold_values_compare_in_the_array_precision(dtype):
    # A probability written as the threshold itself is the threshold in the array's own
    # precision: float32(0.196) is a little below the float64 0.196, yet it is no more
    # free than the 0.196 of a float64 map.
    if dtype == "bfloat16":
        dtype = pytest.importorskip("ml_dtypes").bfloat16
    arr = np.array([[0.196, 0.65], [0.0, 1.0]]).astype(dtype)
    m = OccupancyMap.from_array(arr)
    assert m.unknown[0].all()
    assert m.free[1, 0] and m.occupied[1, 1]
    custom = OccupancyMap.from_array(
        np.array([[0.3, 0.7], [0.0, 1.0]]).astype(dtype), free_thresh=0.3, occupied_thresh=0.7
    )
    assert custom.unknown[0].all()


@pytest.mark.parametrize("dtype", [np.float16, np.float32, "bfloat16"])
def test_from_array_unknown_values_match_in_the_array_precision(dtype):
    # unknown_values=(0.1, 1.1) names the values as written; float32(0.1) is not the
    # float64 0.1, yet it is the value the user marked unknown.
    if dtype == "bfloat16":
        dtype = pytest.importorskip("ml_dtypes").bfloat16
    arr = np.array([[0.1, 1.1], [0.0, 1.0]]).astype(dtype)
    m = OccupancyMap.from_array(arr, unknown_values=(0.1, 1.1))
    assert m.unknown[0].all()
    assert m.free[1, 0] and m.occupied[1, 1]


def test_from_array_uint8_grey_threshold_boundaries():
    v = np.arange(256, dtype=np.uint8).reshape(16, 16)
    m = OccupancyMap.from_array(v)
    assert np.array_equal(m.occupied, v <= 89)
    assert np.array_equal(m.free, v >= 206)
    assert np.array_equal(m.unknown, (v >= 90) & (v <= 205))
    n = OccupancyMap.from_array(v, negate=True)
    # negate: p = v / 255, occupied if v > 165.75, free if v < 49.98.
    assert np.array_equal(n.occupied, v >= 166)
    assert np.array_equal(n.free, v <= 49)
    s = OccupancyMap.from_array(v, mode="scale")
    assert np.array_equal(s.occupied, m.occupied) and np.array_equal(s.free, m.free)


def test_from_array_colour_channels_use_mean():
    rng = np.random.default_rng(1)
    rgb = rng.integers(0, 256, size=(30, 40, 3), dtype=np.uint8)
    m = OccupancyMap.from_array(rgb)
    occ, free, unk = reference_classes(rgb.astype(np.float64).mean(axis=2), 255, 0.65, 0.196)
    assert np.array_equal(m.occupied, occ)
    assert np.array_equal(m.free, free)
    assert np.array_equal(m.unknown, unk)
    # Channel order does not matter (RGB vs BGR) and alpha is ignored.
    assert np.array_equal(OccupancyMap.from_array(rgb[..., ::-1]).occupied, occ)
    alpha = rng.integers(0, 256, size=(30, 40, 1), dtype=np.uint8)
    rgba = np.concatenate([rgb, alpha], axis=2)
    assert np.array_equal(OccupancyMap.from_array(rgba).free, free)
    grey = rgb[..., :1]
    la = np.concatenate([grey, alpha], axis=2)
    ref = OccupancyMap.from_array(grey[..., 0])
    assert np.array_equal(OccupancyMap.from_array(la).occupied, ref.occupied)
    assert np.array_equal(OccupancyMap.from_array(grey).unknown, ref.unknown)


def test_yaml_maps_average_alpha_in_trinary_mode_as_map_server(tmp_path: Path):
    # map_server (ROS 1 image_loader, Nav2 map_io) averages alpha in with the colour
    # channels in trinary mode; plain images and other modes ignore it
    rng = np.random.default_rng(7)
    grey = rng.integers(0, 256, size=(20, 30), dtype=np.uint8)
    grey[0, :3] = [205, 180, 100]
    alpha = rng.integers(0, 256, size=(20, 30), dtype=np.uint8)
    alpha[0, :3] = 255
    rgba = np.stack([grey, grey, grey, alpha], axis=2)
    assert cv2.imwrite(str(tmp_path / "m.png"), rgba)  # BGRA, same values
    assert cv2.imwrite(str(tmp_path / "g.png"), grey)
    (tmp_path / "m.yaml").write_text("image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\n")
    (tmp_path / "s.yaml").write_text(
        "image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\nmode: scale\n"
    )
    mean = (3.0 * grey + alpha) / 4.0
    occ, free, unk = reference_classes(mean, 255, 0.65, 0.196)
    m = load_map(tmp_path / "m.yaml")
    assert np.array_equal(m.occupied, occ) and np.array_equal(m.free, free)
    assert m.free[0, 0] and m.unknown[0, 1]  # opaque 205 is free in map_server, 180 not
    plain = load_map(tmp_path / "g.png")
    for ignored in (load_map(tmp_path / "m.png"), load_map(tmp_path / "s.yaml")):
        assert np.array_equal(ignored.occupied, plain.occupied)
        assert np.array_equal(ignored.free, plain.free)
    assert load_map(tmp_path / "m.png").unknown[0, 0]


def test_from_array_raw_mode():
    v = np.array([[0, 10, 19, 20, 65], [66, 100, 101, 200, 255]], dtype=np.uint8)
    m = OccupancyMap.from_array(v, mode="raw")
    vi = v.astype(int)
    assert np.array_equal(m.free, vi <= 19)
    assert np.array_equal(m.occupied, (vi >= 66) & (vi <= 100))
    assert np.array_equal(m.unknown, ((vi >= 20) & (vi <= 65)) | (vi > 100))
    # negate (ROS 1 behaviour): value 255 - v.
    n = OccupancyMap.from_array(255 - v, mode="raw", negate=True)
    assert np.array_equal(n.free, m.free) and np.array_equal(n.occupied, m.occupied)


def test_from_array_unknown_values():
    v = np.array([[0, 230, 255], [230, 127, 254]], dtype=np.uint8)
    base = OccupancyMap.from_array(v)
    assert base.free[0, 1]  # 230 is free under map_server rules
    m = OccupancyMap.from_array(v, unknown_values=[230])
    assert np.array_equal(m.unknown, (v == 230) | (v == 127))
    rgb = np.repeat(v[..., None], 3, axis=2)
    assert np.array_equal(OccupancyMap.from_array(rgb, unknown_values=(230,)).unknown, m.unknown)
    grid = np.array([[0, 255], [100, -1]], dtype=np.int16)
    g = OccupancyMap.from_array(grid, unknown_values=[255])
    assert np.array_equal(g.unknown, np.array([[False, True], [False, True]]))
    prob = np.array([[0.0, -1.0], [1.0, 0.5]])
    pm = OccupancyMap.from_array(prob, unknown_values=[-1.0])
    assert np.array_equal(pm.unknown, np.array([[False, True], [False, True]]))


def test_from_array_metadata():
    m = _small_map(resolution_m=0.25, origin=[1, 2, 3])
    assert m.resolution_m == 0.25
    assert m.origin == (1.0, 2.0, 3.0)
    assert all(isinstance(v, float) for v in m.origin)
    assert "shape=(5, 7)" in repr(m)


# ---------------------------------------------------------------------- from_array errors


@pytest.mark.parametrize(
    "arr",
    [
        np.zeros((0, 0), dtype=bool),
        np.zeros((1, 1), dtype=bool),
        np.zeros((1, 5), dtype=np.uint8),
        np.zeros((5, 1), dtype=np.float64),
    ],
    ids=["0x0", "1x1", "1x5", "5x1"],
)
def test_too_small_maps_raise(arr):
    with pytest.raises(ValueError, match=r"2x2.*" + re.escape(str(arr.shape))):
        OccupancyMap.from_array(arr)


def test_an_occupancy_grid_read_as_uint8_is_refused_not_read_as_an_inverted_image():
    # ROS OccupancyGrid cells (int8: 0 free, 100 occupied, -1 unknown) seen as uint8
    # (-1 as 255): as intensities 0 is black (occupied), 100 grey, 255 white (free)
    grid = np.zeros((6, 6), np.int8)
    grid[0, :] = 100
    grid[5, :] = -1
    cells = grid.view(np.uint8)
    with pytest.raises(ValueError, match=r"^array: uint8 image holds only the values 0, 100 "):
        OccupancyMap.from_array(cells)
    with pytest.raises(ValueError, match=r"OccupancyGrid.*view\(np\.int8\) or mode='raw'"):
        tj.build_graph(cells)
    expected = OccupancyMap.from_array(grid)
    assert expected.occupied[0].all() and expected.free[1:5].all() and expected.unknown[5].all()
    for same in (cells.view(np.int8), cells):
        got = OccupancyMap.from_array(same, mode="raw" if same.dtype == np.uint8 else "trinary")
        assert np.array_equal(got.occupied, expected.occupied)
        assert np.array_equal(got.unknown, expected.unknown)
    # an image whose grey 100 is meant as unknown, said so; other images are unaffected
    image = OccupancyMap.from_array(cells, unknown_values=(100,))
    assert image.occupied[1:5].all() and image.unknown[0].all() and image.free[5].all()
    for values in ((0, 255), (0, 100, 254), (0, 205, 254), (100, 255, 1)):
        img = np.resize(np.array(values, np.uint8), (6, 6))
        OccupancyMap.from_array(img)


def test_an_image_file_of_0_100_and_255_is_read_as_map_server_reads_it(tmp_path):
    """A file is an image: its 0 / 100 / 255 pixels are black, grey and white (occupied,
    unknown at (255 - 100) / 255 = 0.61, free), not refused as OccupancyGrid cells."""
    cells = np.zeros((6, 6), np.uint8)
    cells[0], cells[1:5], cells[5] = 0, 255, 100
    png = tmp_path / "grey.png"
    cv2.imwrite(str(png), cells)
    yaml = _yaml_map(tmp_path, GOOD, cells)  # the same pixels as m.pgm beside a YAML
    for m in (load_map(png, resolution_m=0.1), load_map(yaml)):
        assert m.occupied[0].all() and m.free[1:5].all() and m.unknown[5].all()
        assert m.occupied.sum() + m.free.sum() + m.unknown.sum() == 36


@pytest.mark.parametrize("dtype", [np.int8, np.int32, np.int64, np.uint16, np.uint8])
def test_zero_one_integer_array_is_refused_not_read_as_a_degenerate_map(dtype):
    # As OccupancyGrid percentages 0 and 1 are both free (no obstacle at all), as uint8
    # intensities both are black (occupied everywhere); distance_map reads the same array
    # as an obstacle mask.
    arr = np.zeros((6, 6), dtype)
    arr[2, :] = 1
    match = "only the values 0 and 1" if dtype == np.uint8 else "no value above 1"
    with pytest.raises(ValueError, match=rf"{match}.*astype\(bool\)"):
        OccupancyMap.from_array(arr)
    with pytest.raises(ValueError, match=match):
        tj.build_graph(arr)
    assert tj.distance_map(arr).max() == 1.0  # read as obstacles there
    if dtype == np.uint8:  # the same mask saved as an image: the error names the file
        import tempfile

        with tempfile.TemporaryDirectory() as folder:
            png = Path(folder) / "mask.png"
            cv2.imwrite(str(png), arr)
            with pytest.raises(ValueError, match=r"mask\.png: uint8 image holds only"):
                load_map(png)
    # the same array as a mask works
    assert OccupancyMap.from_array(arr.astype(bool)).occupied[2].all()
    if dtype == np.uint8:
        # real images are unaffected, and raw mode reads values as given
        img = arr * 254
        assert OccupancyMap.from_array(img).free[2].all()
        assert OccupancyMap.from_array(arr, mode="raw").free.all()
        return
    grid = arr.astype(np.int8) * 100
    assert OccupancyMap.from_array(grid).occupied[2].all()
    # all free is a valid grid; so is a grid with higher values
    assert OccupancyMap.from_array(np.zeros((6, 6), dtype)).free.all()
    grid = arr.astype(np.int16)
    grid[0, 0] = 40
    assert not OccupancyMap.from_array(grid).occupied.any()
    # -1 (unknown) does not make 0/1 cells a grid
    if np.issubdtype(dtype, np.signedinteger):
        mixed = arr.copy()
        mixed[0, 0] = -1
        with pytest.raises(ValueError, match="no value above 1"):
            OccupancyMap.from_array(mixed)
        # ... unless declared unknown on purpose
        m = OccupancyMap.from_array(mixed, unknown_values=[-1])
        assert m.unknown[0, 0]
    # thresholds under which 1 % counts as occupied make the array a valid grid again
    m = OccupancyMap.from_array(arr, occupied_thresh=0.005, free_thresh=0.001)
    assert m.occupied[2].all() and m.free.sum() == 30


def test_from_array_errors():
    nan = np.array([[np.nan, 0.1], [np.nan, np.nan]])
    with pytest.raises(ValueError, match=r"^array: expected .*3 NaN values .*masked_invalid"):
        OccupancyMap.from_array(nan)
    assert OccupancyMap.from_array(np.ma.masked_invalid(nan)).unknown.sum() == 3  # the hint
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        OccupancyMap.from_array(np.array([[1.5, 0.1], [0.0, 0.0]]))
    with pytest.raises(ValueError, match="-1..100"):
        OccupancyMap.from_array(np.array([[101, 0], [0, 0]], dtype=np.int32))
    with pytest.raises(ValueError, match="-1..100"):
        OccupancyMap.from_array(np.array([[-2, 0], [0, 0]], dtype=np.int8))
    with pytest.raises(TypeError, match="complex"):
        OccupancyMap.from_array(np.zeros((3, 3), dtype=np.complex128))
    for not_an_array in ("abc", None):
        with pytest.raises(TypeError, match="array: expected dtype bool"):
            OccupancyMap.from_array(not_an_array)
    with pytest.raises(TypeError, match="object"):
        OccupancyMap.from_array(np.array([[None, None], [None, None]], dtype=object))
    for ragged in ([[0, 100], [0]], [[0.1, 0.2], [0.3, [0.4]]]):  # rows of other lengths
        with pytest.raises(
            ValueError, match=r"^array: expected rows of one length \(an \(H, W\) array\)"
        ):
            OccupancyMap.from_array(ragged)
    with pytest.raises(ValueError, match="shape"):
        OccupancyMap.from_array(np.zeros((3, 3, 5), dtype=np.uint8))
    with pytest.raises(ValueError, match="shape"):
        OccupancyMap.from_array(np.zeros((3, 3, 3), dtype=np.float64))
    with pytest.raises(ValueError, match=r"free_thresh=0\.7.*occupied_thresh=0\.6"):
        OccupancyMap.from_array(np.zeros((3, 3), bool), occupied_thresh=0.6, free_thresh=0.7)
    with pytest.raises(ValueError, match=r"free_thresh=-0\.1"):
        OccupancyMap.from_array(np.zeros((3, 3), bool), free_thresh=-0.1)
    with pytest.raises(ValueError, match=r"occupied_thresh=1\.5"):
        OccupancyMap.from_array(np.zeros((3, 3), bool), occupied_thresh=1.5)
    with pytest.raises(ValueError, match="resolution_m"):
        OccupancyMap.from_array(np.zeros((3, 3), bool), resolution_m=0.0)
    with pytest.raises(ValueError, match="resolution_m"):
        OccupancyMap.from_array(np.zeros((3, 3), bool), resolution_m=float("inf"))
    with pytest.raises(ValueError, match="origin"):
        OccupancyMap.from_array(np.zeros((3, 3), bool), origin=(0.0, 0.0))
    with pytest.raises(ValueError, match="origin"):
        OccupancyMap.from_array(np.zeros((3, 3), bool), origin=(0.0, float("nan"), 0.0))
    with pytest.raises(ValueError, match="mode"):
        OccupancyMap.from_array(np.zeros((3, 3), np.uint8), mode="binary")
    with pytest.raises(ValueError, match="negate"):
        OccupancyMap.from_array(np.zeros((3, 3), bool), negate=True)
    with pytest.raises(ValueError, match="raw"):
        OccupancyMap.from_array(np.zeros((3, 3), np.int8), mode="raw")
    with pytest.raises(ValueError, match="unknown_values"):
        OccupancyMap.from_array(np.zeros((3, 3), bool), unknown_values=[1])
    with pytest.raises(ValueError, match="unknown_values"):
        OccupancyMap.from_array(np.zeros((3, 3), np.uint8), unknown_values=[300])


def test_occupancy_map_validation():
    a = np.zeros((3, 3), dtype=bool)
    t = np.ones((3, 3), dtype=bool)
    m = OccupancyMap(a, t, a.copy())
    assert m.free.all()
    assert not m.free.flags.writeable
    with pytest.raises(ValueError):
        m.free[0, 0] = False
    with pytest.raises(ValueError, match="partition"):
        OccupancyMap(t, t, a)
    with pytest.raises(ValueError, match="partition"):
        OccupancyMap(a, a, a)
    with pytest.raises(TypeError, match="dtype bool"):
        OccupancyMap(a.astype(np.uint8), t, a)
    with pytest.raises(ValueError, match="same shape"):
        OccupancyMap(np.zeros((3, 4), bool), t, a)
    with pytest.raises(ValueError, match="2-D"):
        OccupancyMap(np.zeros((3, 3, 1), bool), t[..., None], a[..., None])
    with pytest.raises(ValueError, match="resolution_m"):
        OccupancyMap(a, t, a, resolution_m=-1.0)
    with pytest.raises(ValueError, match="origin"):
        OccupancyMap(a, t, a, origin=(1.0, 2.0, 3.0, 4.0))
    with pytest.raises(TypeError, match="numpy"):
        OccupancyMap([[False]], t, a)  # type: ignore[arg-type]
    # a source that is no path or name is refused, not kept as its str(): "True",
    # "<object ...>"
    assert OccupancyMap(a, t, a, source=Path("maps/m.pgm")).source == str(Path("maps/m.pgm"))
    for bad in (True, 3, object()):
        with pytest.raises(TypeError, match=r"^source: expected a str, an os.PathLike or None"):
            OccupancyMap(a, t, a, source=bad)
        with pytest.raises(TypeError, match=r"^source: expected a str, an os.PathLike or None"):
            OccupancyMap.from_array(t, source=bad)


# ---------------------------------------------------------------------- image files


def _write_pgm(path: Path, img: np.ndarray, *, comment: str | None = None, maxval=255) -> None:
    h, w = img.shape
    header = "P5\n" + (f"# {comment}\n" if comment else "") + f"{w} {h}\n{maxval}\n"
    if maxval < 256:
        body = img.astype(np.uint8).tobytes()
    else:
        body = img.astype(">u2").tobytes()
    path.write_bytes(header.encode("ascii") + body)


def test_pgm_comment_resolution_and_override(tmp_path: Path):
    img = np.array([[0, 205, 254], [254, 254, 0]], dtype=np.uint8)
    _write_pgm(tmp_path / "a.pgm", img, comment="CREATOR: map_saver.cpp 0.070 m/pix")
    m = load_map(tmp_path / "a.pgm")
    assert m.resolution_m == 0.07
    assert np.array_equal(m.unknown, img == 205)
    assert load_map(tmp_path / "a.pgm", resolution_m=0.5).resolution_m == 0.5
    _write_pgm(tmp_path / "b.pgm", img)
    with pytest.warns(UserWarning, match="states no resolution"):
        assert load_map(tmp_path / "b.pgm").resolution_m == 0.05


def test_a_map_that_states_no_resolution_is_loaded_at_an_assumed_one_with_a_warning(
    tmp_path: Path,
):
    """A plain image without a resolution is loaded at 0.05 m/px with a warning: every
    length in metres then rests on a scale nobody gave."""
    img = np.array([[0, 205, 254], [254, 254, 0]], dtype=np.uint8)
    png = tmp_path / "plain.png"
    cv2.imwrite(str(png), img)
    with pytest.warns(UserWarning) as info:
        assert load_map(png).resolution_m == 0.05
    assert [str(w.message) for w in info] == [
        f"map {png} states no resolution: assumed 0.05 m/px, on which every length and "
        "world point rests; give the map's own with load_map(..., resolution_m=...)"
    ]
    assert info[0].filename == __file__  # it points at the call
    # a resolution given, in a PGM's comment or a YAML: nothing assumed, nothing said
    _write_pgm(tmp_path / "a.pgm", img, comment="CREATOR: map_saver.cpp 0.070 m/pix")
    (tmp_path / "a.yaml").write_text("image: a.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_map(png, resolution_m=0.2).resolution_m == 0.2
        assert load_map(tmp_path / "a.pgm").resolution_m == 0.07
        assert load_map(tmp_path / "a.yaml").resolution_m == 0.1


def test_a_plain_pgms_resolution_comment_is_not_reported_assumed(tmp_path: Path):
    """load_map takes the resolution from a plain (P2) PGM's comment, but the check
    behind the command line's "assumed" note read binary headers only."""
    from topojax.maps.files import default_resolution_used

    (tmp_path / "a.pgm").write_text("P2\n# CREATOR: map_saver.cpp 0.100 m/pix\n2 2\n255\n0 0 0 0\n")
    (tmp_path / "b.pgm").write_text("P2\n2 2\n255\n0 0 0 0\n")
    assert load_map(tmp_path / "a.pgm").resolution_m == 0.1
    assert not default_resolution_used(tmp_path / "a.pgm")
    assert default_resolution_used(tmp_path / "b.pgm")


def test_pgm_comment_resolution_is_read_whole_or_refused(tmp_path: Path):
    img = np.array([[0, 205, 254], [254, 254, 0]], dtype=np.uint8)
    good = {"1e-2 m/pix": 0.01, "CREATOR: x 0.5 m/pix": 0.5, "res .25m/pix": 0.25}
    for comment, value in good.items():
        _write_pgm(tmp_path / "g.pgm", img, comment=comment)
        assert load_map(tmp_path / "g.pgm").resolution_m == value, comment
    # the number may be glued to a word; a comment without a number is not a resolution
    for comment, value in (("res=0.25 m/pix", 0.25), ("(0.5 m/pix)", 0.5)):
        _write_pgm(tmp_path / "g.pgm", img, comment=comment)
        assert load_map(tmp_path / "g.pgm").resolution_m == value, comment
    for comment in ("units: m/pix", "Resolution in m/pix: 0.05", "by Hannan m/pix"):
        _write_pgm(tmp_path / "g.pgm", img, comment=comment)
        with pytest.warns(UserWarning, match="states no resolution: assumed 0.05 m/px"):
            assert load_map(tmp_path / "g.pgm").resolution_m == 0.05, comment  # the default
    # a decimal comma, a sign or a zero must not be read as some other number
    # nor a resolution written as NaN or infinity (as a C printf writes them)
    bad = ("CREATOR: x 0,05 m/pix", "-0.05 m/pix", "x=0,05 m/pix", "0 m/pix", "nan m/pix")
    for comment in (*bad, "CREATOR: map_saver.cpp -nan m/pix", "res=inf m/pix"):
        _write_pgm(tmp_path / "b.pgm", img, comment=comment)
        with pytest.raises(ValueError, match=r"b\.pgm.*not a positive number.*resolution_m"):
            load_map(tmp_path / "b.pgm")
        # ... unless the resolution comes from elsewhere
        assert load_map(tmp_path / "b.pgm", resolution_m=0.1).resolution_m == 0.1
    (tmp_path / "b.yaml").write_text("image: b.pgm\nresolution: 0.2\norigin: [0, 0, 0]\n")
    assert load_map(tmp_path / "b.yaml").resolution_m == 0.2


@pytest.mark.parametrize("word", ["1e9", "1e-7"])
def test_a_pgm_comments_resolution_out_of_range_is_named_as_the_comments(tmp_path, word):
    """A comment's resolution outside the range a map may have is the comment's error,
    named as such: it was reported as the caller's resolution_m, which nobody gave."""
    img = np.array([[0, 205, 254], [254, 254, 0]], dtype=np.uint8)
    _write_pgm(tmp_path / "b.pgm", img, comment=f"CREATOR: map_saver.cpp {word} m/pix")
    with pytest.raises(
        ValueError, match=rf"^map image .*b\.pgm: its comment .* gives the resolution as '{word}'"
    ):
        load_map(tmp_path / "b.pgm")
    assert load_map(tmp_path / "b.pgm", resolution_m=0.1).resolution_m == 0.1


def test_pgm_with_other_maxval(tmp_path: Path):
    img = np.array([[0, 30, 40], [80, 90, 100]], dtype=np.uint8)
    _write_pgm(tmp_path / "m.pgm", img, maxval=100)
    m = load_map(tmp_path / "m.pgm")
    p = (100 - img.astype(float)) / 100
    assert np.array_equal(m.occupied, p > 0.65)
    assert np.array_equal(m.free, p < 0.196)
    img16 = np.array([[0, 20000], [40000, 65535]], dtype=np.uint16)
    _write_pgm(tmp_path / "w.pgm", img16, maxval=65535)
    m16 = load_map(tmp_path / "w.pgm")
    p16 = (65535 - img16.astype(float)) / 65535
    assert np.array_equal(m16.occupied, p16 > 0.65)
    assert np.array_equal(m16.free, p16 < 0.196)


@pytest.mark.parametrize("maxval", [100, 200, 255, 1000])
def test_plain_ascii_pgm_classified_like_binary(tmp_path: Path, maxval):
    # OpenCV and PIL rescale plain (P2) files to 0..255 when maxval != 255, binary (P5)
    # files not: the two must still give the same map, against the file's own maxval.
    rng = np.random.default_rng(maxval)
    img = rng.integers(0, maxval + 1, size=(5, 7))
    img[0, :4] = [0, maxval, round(0.35 * maxval), round(0.804 * maxval)]  # near thresholds
    dtype = np.uint8 if maxval < 256 else np.uint16
    _write_pgm(tmp_path / "b.pgm", img.astype(dtype), maxval=maxval)
    rows = "\n".join(" ".join(str(v) for v in row) for row in img)
    (tmp_path / "a.pgm").write_text(f"P2\n# a comment\n7 5\n{maxval}\n{rows}\n")
    a, b = load_map(tmp_path / "a.pgm"), load_map(tmp_path / "b.pgm")
    p = (maxval - img.astype(float)) / maxval
    for m in (a, b):
        assert np.array_equal(m.occupied, p > 0.65)
        assert np.array_equal(m.free, p < 0.196)
    # plain PPM data (P3, here in a .pgm file): the mean of the three channels
    rgb = np.stack([img, img, img], axis=2)
    vals = " ".join(str(v) for v in rgb.ravel())
    (tmp_path / "c.pgm").write_text(f"P3\n7 5\n{maxval}\n{vals}\n")
    c = load_map(tmp_path / "c.pgm")
    assert np.array_equal(c.occupied, a.occupied) and np.array_equal(c.free, a.free)


def test_plain_pgm_faults_are_named(tmp_path: Path):
    bad = {
        "short.pgm": "P2\n3 2\n255\n0 1 2 3 4\n",
        "word.pgm": "P2\n2 1\n255\n0 x\n",
        "over.pgm": "P2\n2 1\n100\n0 101\n",
        "zero.pgm": "P2\n0 1\n255\n",
    }
    expect = {
        "short.pgm": "must hold 6 values, found 5",
        "word.pgm": "non-numeric",
        "over.pgm": "above its PGM maxval 100",
        "zero.pgm": "width, height >= 1",
    }
    for name, text in bad.items():
        (tmp_path / name).write_text(text)
        with pytest.raises(ValueError, match=expect[name]) as err:
            load_map(tmp_path / name)
        assert name in str(err.value)


def test_binary_pgm_shorter_than_its_header_is_named(tmp_path: Path):
    # a header claiming 100000 x 100000 pixels over a few bytes must say so, not
    # "could not decode", and must not allocate the claimed size
    cases = {
        "huge.pgm": (b"P5\n100000 100000\n255\n" + b"\xfe" * 1000, "10000000000 bytes"),
        "huge16.pgm": (b"P5\n100000 100000\n65535\n" + b"\xfe" * 1000, "20000000000 bytes"),
        "cut.pgm": (b"P5\n4 3\n255\n" + b"\xfe" * 11, "12 bytes"),
    }
    for name, (data, need) in cases.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(ValueError, match="header gives") as err:
            load_map(tmp_path / name)
        assert name in str(err.value) and need in str(err.value)
        assert "received" in str(err.value)


def test_binary_pgm_with_a_bad_header_is_named(tmp_path: Path):
    """A P5 header that does not parse is refused naming the map image and what its
    header holds, by both readers: not passed on to OpenCV, which reads "3x" as 3 (a map
    without a word) and refuses a zero size or maxval as "could not decode", nor left to
    fail inside int() in the tiled reader."""
    cases = {
        "word.pgm": (b"P5\n3x 2\n255\n" + bytes(6), "decimal integers, received '3x 2 255'"),
        "zero.pgm": (b"P5\n0 0\n255\n", "received 0 x 0, maxval 255"),
        "max0.pgm": (b"P5\n3 2\n0\n" + bytes(6), "received 3 x 2, maxval 0"),
        "cut.pgm": (b"P5\n3 2", "incomplete PGM header: expected width, height and maxval"),
    }
    for name, (data, needle) in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        for read in (load_map, tj.open_tiled_map):
            with pytest.raises(ValueError, match=f"^map image {re.escape(str(path))}: ") as err:
                read(path)
            assert needle in str(err.value)


def test_16bit_png_full_precision(tmp_path: Path):
    # Values straddling the occupied threshold in 16-bit precision.
    edge = 65535 * (1 - 0.65)
    img = np.array([[0, int(edge) - 1, int(edge) + 1], [65535, 52000, 30000]], dtype=np.uint16)
    assert cv2.imwrite(str(tmp_path / "m.png"), img)
    m = load_map(tmp_path / "m.png")
    p = (65535 - img.astype(float)) / 65535
    assert np.array_equal(m.occupied, p > 0.65)
    assert np.array_equal(m.free, p < 0.196)
    assert m.occupied[0, 1] and not m.occupied[0, 2]


def test_other_image_formats(tmp_path: Path):
    img = np.full((40, 60), 255, dtype=np.uint8)
    img[10:30, 20:40] = 0
    img[:, :5] = 205
    for suffix in (".png", ".bmp", ".tif", ".pgm"):
        path = tmp_path / f"m{suffix}"
        assert cv2.imwrite(str(path), img)
        m = load_map(path)
        assert np.array_equal(m.occupied, img == 0), suffix
        assert np.array_equal(m.unknown, img == 205), suffix
    # JPEG is lossy: check block interiors only.
    assert cv2.imwrite(str(tmp_path / "m.jpg"), img, [cv2.IMWRITE_JPEG_QUALITY, 95])
    m = load_map(tmp_path / "m.jpg")
    assert m.occupied[14:26, 24:36].all()
    assert m.free[5:35, 45:55].all()
    # Colour PNG written by PIL (RGB, palette, LA, RGBA).
    for mode in ("RGB", "P", "LA", "RGBA"):
        path = tmp_path / f"pil_{mode}.png"
        Image.fromarray(img, mode="L").convert(mode).save(path)
        m = load_map(path)
        assert np.array_equal(m.occupied, img == 0), mode
        assert np.array_equal(m.unknown, img == 205), mode


def test_image_errors(tmp_path: Path):
    missing = tmp_path / "nope.png"
    with pytest.raises(FileNotFoundError, match="nope.png"):
        load_map(missing)
    with pytest.raises(FileNotFoundError, match="nope.yaml"):
        load_map(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\nthis is not an image at all" * 3)
    with pytest.raises(ValueError, match="bad.png"):
        load_map(bad)
    empty = tmp_path / "empty.pgm"
    empty.write_bytes(b"")
    with pytest.raises(ValueError, match="empty.pgm"):
        load_map(empty)
    junk = tmp_path / "junk.jpg"
    junk.write_bytes(np.random.default_rng(0).integers(0, 256, 500, dtype=np.uint8).tobytes())
    with pytest.raises(ValueError, match="junk.jpg"):
        load_map(junk)
    other = tmp_path / "map.txt"
    other.write_text("hello")
    with pytest.raises(ValueError, match="suffix"):
        load_map(other)
    tiny = tmp_path / "tiny.png"
    cv2.imwrite(str(tiny), np.zeros((1, 1), np.uint8))
    with pytest.raises(ValueError, match=r"\(1, 1\)"):
        load_map(tiny)
    fl = tmp_path / "float.tif"
    Image.fromarray(np.zeros((4, 4), np.float32), mode="F").save(fl)
    with pytest.raises(ValueError, match="float.tif"):
        load_map(fl)
    folder = tmp_path / "folder.png"
    folder.mkdir()
    with pytest.raises(ValueError, match="path is not a file: .*folder.png"):
        load_map(folder)
    above = tmp_path / "above.pgm"
    above.write_bytes(b"P5\n4 4\n100\n" + bytes([200] * 16))
    with pytest.raises(ValueError, match="above.pgm has pixel values above its PGM maxval 100"):
        load_map(above)
    for maxval in (b"0", b"70000"):
        odd = tmp_path / f"maxval{maxval.decode()}.pgm"
        odd.write_bytes(b"P5\n4 4\n" + maxval + b"\n" + bytes(32))
        with pytest.raises(ValueError, match=f"maxval{maxval.decode()}.pgm"):
            load_map(odd)


def test_load_map_of_a_stored_tiled_map_points_at_the_tiled_readers(tmp_path):
    # a tile folder or Zarr array is a map, but one read a window at a time: the refusal
    # names what reads it, not the batch's folder search (which finds no map file there)
    tiles = tmp_path / "floor.v2"
    tj.save_tiled_map(OccupancyMap.from_array(np.zeros((8, 8), bool)), tiles)
    zarr_folder = tmp_path / "floor.zarr"
    zarr_folder.mkdir()
    (zarr_folder / "zarr.json").write_text("{}")
    for path, kind in ((tiles, "tile folder"), (zarr_folder, "Zarr array")):
        with pytest.raises(ValueError) as info:
            load_map(path)
        message = str(info.value)
        assert f"{path} is a {kind}" in message
        assert "open_tiled_map" in message and "topojax graph --tiled" in message
        assert "topojax batch" not in message


def test_unreadable_image_leaves_no_opencv_log_line(tmp_path: Path, capfd):
    bad = tmp_path / "bad.pgm"
    bad.write_bytes(b"P6\nnot a header at all")  # not P5: decoded by OpenCV
    with pytest.raises(ValueError, match="could not decode map image"):
        load_map(bad)
    assert "imdecode" not in capfd.readouterr().err


# ---------------------------------------------------------------------- YAML files


def _yaml_map(tmp_path: Path, text: str, img: np.ndarray | None = None) -> Path:
    if img is None:
        img = np.array([[0, 205, 254], [254, 100, 0]], dtype=np.uint8)
    _write_pgm(tmp_path / "m.pgm", img)
    path = tmp_path / "m.yaml"
    path.write_text(text)
    return path


GOOD = "image: m.pgm\nresolution: 0.1\norigin: [0.0, 0.0, 0.0]\n"


def test_yaml_defaults_and_overrides(tmp_path: Path):
    path = _yaml_map(tmp_path, GOOD)
    m = load_map(path)
    assert m.resolution_m == 0.1
    assert np.array_equal(m.unknown, np.array([[0, 1, 0], [0, 1, 0]], bool))
    m2 = load_map(path, resolution_m=0.3, origin=(1, 2, 0.5), free_thresh=0.25)
    assert m2.resolution_m == 0.3 and m2.origin == (1.0, 2.0, 0.5)
    assert m2.free[0, 1]  # 205 free with free_thresh 0.25
    sub = tmp_path / "sub"
    sub.mkdir()
    _write_pgm(sub / "x.pgm", np.zeros((2, 2), np.uint8))
    (tmp_path / "rel.yml").write_text("image: sub/x.pgm\nresolution: 1\norigin: [0, 0, 0]\n")
    assert load_map(tmp_path / "rel.yml").occupied.all()


def test_a_given_resolution_stands_in_for_a_yamls_missing_one(tmp_path):
    """resolution_m (--resolution) replaces a YAML's resolution, so it also stands in for
    a missing one, as origin= does for a missing origin; without it the error says how
    to give one."""
    path = _yaml_map(tmp_path, "image: m.pgm\norigin: [0, 0, 0]\n")
    assert load_map(path, resolution_m=0.2).resolution_m == 0.2
    with pytest.raises(ValueError, match=r"missing the required key 'resolution'.*resolution_m="):
        load_map(path)


@pytest.mark.parametrize("suffix", [".yaml", ".pgm"])
@pytest.mark.parametrize(
    ("key", "value"),
    [("origin", (1.0, 2.0)), ("negate", 2), ("mode", "TRINARY"), ("resolution_m", -1.0)],
)
def test_a_bad_override_is_named_as_the_callers_not_the_files(tmp_path, suffix, key, value):
    """load_map's own arguments are the caller's: a bad one is named alone, not as a
    field of the map file, which holds a good value (the message sent the user to fix a
    file that needed no fixing)."""
    path = _yaml_map(tmp_path, GOOD)
    if suffix == ".pgm":
        path = tmp_path / "m.pgm"
    with pytest.raises(ValueError, match=rf"^{key}: expected") as info:
        load_map(path, **{key: value})
    assert str(path) not in str(info.value)


@pytest.mark.parametrize(
    ("given", "message"),
    [
        (
            {"free_thresh": 0.7},
            r"^free_thresh: expected less than occupied_thresh \(0\.65, map_server's default: "
            r"map YAML .*m\.yaml sets none\), received 0\.7$",
        ),
        (
            {"occupied_thresh": 0.1},
            r"^occupied_thresh: expected more than free_thresh \(0\.196, map_server's default: "
            r"map YAML .*m\.yaml sets none\), received 0\.1$",
        ),
        ({"free_thresh": 1.5}, r"^free_thresh: expected a number from 0 to 1, received 1\.5$"),
        (
            {"free_thresh": 0.7, "occupied_thresh": 0.6},
            r"^free_thresh, occupied_thresh: expected 0 <= free_thresh < occupied_thresh",
        ),
    ],
)
def test_a_threshold_given_against_the_yaml_s_other_is_blamed_on_the_caller(
    tmp_path: Path, given, message
):
    # a threshold given beside a YAML that sets the other one: the refusal names the one
    # given and where the other came from, not the file alone (whose fields are fine)
    path = _yaml_map(tmp_path, GOOD)
    with pytest.raises(ValueError, match=message):
        load_map(path, **given)
    from topojax.maps.tiled import open_tiled_map

    with pytest.raises(ValueError, match=message):
        open_tiled_map(path, **given)


@pytest.mark.parametrize(
    ("given", "message"),
    [
        (
            {"free_thresh": 0.7},
            r"^free_thresh: expected less than occupied_thresh \(0\.65, map_server's default: "
            r"map .*x\.pgm has no YAML\), received 0\.7$",
        ),
        (
            {"occupied_thresh": 0.1},
            r"^occupied_thresh: expected more than free_thresh \(0\.196, map_server's default: "
            r"map .*x\.pgm has no YAML\), received 0\.1$",
        ),
        (
            {"free_thresh": 0.7, "occupied_thresh": 0.6},
            r"^free_thresh, occupied_thresh: expected 0 <= free_thresh < occupied_thresh",
        ),
    ],
)
def test_a_threshold_given_for_an_image_names_the_default_it_meets(tmp_path: Path, given, message):
    # an image has no YAML: the threshold given meets map_server's default other one,
    # and the refusal says so, as it does beside a YAML
    _write_pgm(tmp_path / "x.pgm", np.full((3, 3), 254, np.uint8))
    with pytest.raises(ValueError, match=message):
        load_map(tmp_path / "x.pgm", resolution_m=0.05, **given)
    from topojax.maps.tiled import open_tiled_map

    with pytest.raises(ValueError, match=message):
        open_tiled_map(tmp_path / "x.pgm", resolution_m=0.05, **given)


def test_a_threshold_given_against_the_yaml_s_own_other_names_the_file(tmp_path: Path):
    # the other threshold set in the file: the refusal says it came from there
    path = _yaml_map(tmp_path, GOOD + "occupied_thresh: 0.6\nfree_thresh: 0.3\n")
    less = r"^free_thresh: expected less than occupied_thresh \(0\.6, from map YAML .*m\.yaml\)"
    with pytest.raises(ValueError, match=less + r", received 0\.7$"):
        load_map(path, free_thresh=0.7)
    more = r"^occupied_thresh: expected more than free_thresh \(0\.3, from map YAML .*m\.yaml\)"
    with pytest.raises(ValueError, match=more + r", received 0\.2$"):
        load_map(path, occupied_thresh=0.2)


def test_yaml_numbers_as_map_server_reads_them(tmp_path: Path):
    # PyYAML (YAML 1.1) reads 5e-2 and quoted numbers as strings; yaml-cpp, which
    # map_server uses, reads them as numbers
    _write_pgm(tmp_path / "x.pgm", np.array([[0, 205], [254, 254]], np.uint8))
    text = (
        "image: x.pgm\nresolution: 5e-2\norigin: [-1.5E+1, '2', 0]\n"
        "occupied_thresh: '0.65'\nfree_thresh: 1.96e-1\n"
    )
    (tmp_path / "n.yaml").write_text(text)
    m = load_map(tmp_path / "n.yaml")
    assert m.resolution_m == 0.05 and m.origin == (-15.0, 2.0, 0.0)
    assert m.unknown[0, 1] and m.free[1].all()
    (tmp_path / "w.yaml").write_text("image: x.pgm\nresolution: 'five'\norigin: [0, 0, 0]\n")
    with pytest.raises(
        ValueError,
        match="'resolution': expected a number from 1e-06 to 10000, received 'five'",
    ):
        load_map(tmp_path / "w.yaml")
    # a resolution above the largest accepted one is refused with that bound, not with
    # "a finite number > 0", which 1e300 is
    (tmp_path / "h.yaml").write_text("image: x.pgm\nresolution: 1e300\norigin: [0, 0, 0]\n")
    with pytest.raises(ValueError, match=r"'resolution': expected .* to 10000.*1e\+300"):
        load_map(tmp_path / "h.yaml")


def test_a_quoted_negate_is_read_as_map_server_reads_it(tmp_path: Path):
    # yaml-cpp reads negate: "1" as the integer 1, as it reads the other quoted numbers
    img = np.array([[0, 50, 100], [150, 255, 10]], dtype=np.uint8)
    for text, negated in (("'1'", True), ('"0"', False), ("' 1 '", True)):
        m = load_map(_yaml_map(tmp_path, GOOD + f"negate: {text}\n", img))
        assert np.array_equal(m.occupied, img >= 166 if negated else img <= 89)
    path = _yaml_map(tmp_path, GOOD + "negate: '2'\n", img)
    with pytest.raises(ValueError, match="field 'negate': expected 0, 1, true or false"):
        load_map(path)


def test_yaml_negate_and_raw_mode(tmp_path: Path):
    img = np.array([[0, 50, 100], [150, 255, 10]], dtype=np.uint8)
    path = _yaml_map(tmp_path, GOOD + "negate: 1\n", img)
    m = load_map(path)
    assert np.array_equal(m.occupied, img >= 166)
    assert np.array_equal(m.free, img <= 49)
    path = _yaml_map(tmp_path, GOOD + "mode: raw\n", img)
    r = load_map(path)
    assert np.array_equal(r.free, img <= 19)
    assert np.array_equal(r.occupied, (img >= 66) & (img <= 100))
    assert np.array_equal(r.unknown, ((img > 19) & (img < 66)) | (img > 100))
    path = _yaml_map(tmp_path, GOOD + "mode: scale\n", img)
    s = load_map(path)
    t = load_map(_yaml_map(tmp_path, GOOD, img))
    assert np.array_equal(s.unknown, t.unknown)


def test_yaml_absolute_image_path(tmp_path: Path):
    _write_pgm(tmp_path / "m.pgm", np.zeros((3, 3), np.uint8))
    (tmp_path / "abs.yaml").write_text(
        f"image: {tmp_path / 'm.pgm'}\nresolution: 0.1\norigin: [0, 0, 0]\n"
    )
    assert load_map(tmp_path / "abs.yaml").occupied.all()
    (tmp_path / "gone.yaml").write_text(
        "image: /definitely/not/here/m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n"
    )
    assert load_map(tmp_path / "gone.yaml").occupied.all()
    (tmp_path / "gone2.yaml").write_text(
        "image: /definitely/not/here/q.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n"
    )
    with pytest.raises(FileNotFoundError, match="q.pgm"):
        load_map(tmp_path / "gone2.yaml")


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("- a\n- b\n", "mapping"),
        ("image: [unclosed\n", "parsed"),
        ("resolution: 0.1\norigin: [0, 0, 0]\n", "'image'"),
        ("image: m.pgm\norigin: [0, 0, 0]\n", "'resolution'"),
        ("image: m.pgm\nresolution: 0.1\n", "'origin'"),
        ("image: m.pgm\nresolution: 0\norigin: [0, 0, 0]\n", "'resolution'.*0"),
        ("image: m.pgm\nresolution: -0.5\norigin: [0, 0, 0]\n", r"'resolution'.*-0\.5"),
        ("image: m.pgm\nresolution: .nan\norigin: [0, 0, 0]\n", "'resolution'.*nan"),
        ("image: m.pgm\nresolution: fast\norigin: [0, 0, 0]\n", "'resolution'.*fast"),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0]\n", "'origin'"),
        ("image: m.pgm\nresolution: 0.1\norigin: zero\n", "'origin'.*zero"),
        (
            GOOD + "occupied_thresh: 0.1\nfree_thresh: 0.5\n",
            r"free_thresh=0\.5.*occupied_thresh=0\.1",
        ),
        (GOOD + "occupied_thresh: 1.5\n", r"'occupied_thresh'.*1\.5"),
        (GOOD + "free_thresh: high\n", "'free_thresh'.*high"),
        (GOOD + "mode: fancy\n", "'mode'.*fancy"),
        (GOOD + "negate: 7\n", "'negate'.*7"),
        (GOOD + "negate: 0.5\n", r"'negate'.*0\.5"),  # a wrong type in a file: ValueError
        ("image: m.pgm\nresolution: 0.1\norigin: [0, zero, 0]\n", "'origin'.*zero"),
        ("image: 12\nresolution: 0.1\norigin: [0, 0, 0]\n", "'image'"),
    ],
)
def test_yaml_errors(tmp_path: Path, text: str, pattern: str):
    path = _yaml_map(tmp_path, text)
    with pytest.raises(ValueError, match=pattern) as info:
        load_map(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("image: m.pgm\nresolution: 0.1\n foo: : bar\n", "line 3, column 5: mapping values"),
        ("image: [unclosed\nresolution: 0.1\n", "line 2, column 11: expected ',' or ']'"),
        ("image: m.pgm\nresolution: \x01\n", "line 2, column 13: character #x0001"),
    ],
)
def test_a_broken_yaml_names_its_line_and_column_not_pyyaml_s_stream(
    tmp_path: Path, text: str, where: str
):
    path = _yaml_map(tmp_path, text)
    with pytest.raises(ValueError) as info:
        load_map(path)
    assert str(info.value).startswith(f"map YAML {path} could not be parsed: {where}")
    assert "<unicode string>" not in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("text", "received"),
    [
        ("", "an empty document"),
        ("# only a comment\n", "an empty document"),
        ("- image: m.pgm\n- resolution: 0.1\n", "a list"),
        ("m.pgm 0.1\n", "the text 'm.pgm 0.1'"),
    ],
)
def test_a_yaml_that_is_no_mapping_says_what_it_holds(tmp_path: Path, text: str, received):
    path = _yaml_map(tmp_path, text)
    with pytest.raises(ValueError) as info:
        load_map(path)
    assert str(info.value) == (
        f"map YAML {path}: expected a mapping of keys to values (image: ..., resolution: "
        f"...), received {received}"
    )


@pytest.mark.parametrize(
    ("text", "key", "lines"),
    [
        (
            "image: m.pgm\nresolution: 0.05\nresolution: 0.1\norigin: [0, 0, 0]\n",
            "resolution",
            "2 and 3",
        ),
        ("image: a.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nimage: m.pgm\n", "image", "1 and 4"),
    ],
)
def test_a_key_given_twice_in_a_yaml_is_refused_naming_it(tmp_path: Path, text, key, lines):
    path = _yaml_map(tmp_path, text)
    with pytest.raises(ValueError) as info:
        load_map(path)
    assert str(info.value) == (
        f"map YAML {path}: key {key!r} is given twice (lines {lines}); expected each key once"
    )


def test_yaml_missing_image_file(tmp_path: Path):
    (tmp_path / "m.yaml").write_text("image: nothere.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(FileNotFoundError, match="nothere.pgm"):
        load_map(tmp_path / "m.yaml")


# ---------------------------------------------------------------------- saving


def test_to_image_values():
    occ = np.array([[True, False], [False, False]])
    free = np.array([[False, True], [False, True]])
    unk = ~occ & ~free
    img = OccupancyMap(occ, free, unk).to_image()
    assert img.dtype == np.uint8
    assert img.tolist() == [[0, 254], [205, 254]]


def test_save_map_round_trip(tmp_path: Path):
    rng = np.random.default_rng(3)
    codes = rng.integers(0, 3, size=(37, 53))
    m = OccupancyMap(
        codes == 0, codes == 1, codes == 2, resolution_m=0.011611161, origin=(-1.25, 3.5, 0.4)
    )
    image_path = save_map(m, tmp_path / "out.yaml")
    assert image_path == tmp_path / "out.pgm"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.pgm", "out.yaml"]
    back = load_map(tmp_path / "out.yaml")
    assert np.array_equal(back.occupied, m.occupied)
    assert np.array_equal(back.free, m.free)
    assert np.array_equal(back.unknown, m.unknown)
    assert back.resolution_m == m.resolution_m
    assert back.origin == m.origin
    # The PGM is a plain map_saver image readable by other decoders, header resolution kept.
    with Image.open(image_path) as im:
        assert im.mode == "L"
        assert np.array_equal(np.asarray(im), m.to_image())
    assert load_map(image_path).resolution_m == m.resolution_m
    doc = yaml_doc(tmp_path / "out.yaml")
    assert doc["image"] == "out.pgm" and doc["mode"] == "trinary"
    # Overwrite in place works and leaves no temporary files.
    save_map(back, tmp_path / "out.yaml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.pgm", "out.yaml"]


def test_save_map_real_map_round_trip(shared_data: Path, tmp_path: Path):
    m = load_map(shared_data / "maps/ros/pal_office_7th_floor/map.yaml")
    save_map(m, tmp_path / "pal.yaml", image_name="pal_image.pgm")
    back = load_map(tmp_path / "pal.yaml")
    assert np.array_equal(back.unknown, m.unknown)
    assert np.array_equal(back.occupied, m.occupied)
    assert back.origin == m.origin and back.resolution_m == m.resolution_m


def test_save_map_errors(tmp_path: Path):
    m = _small_map()
    with pytest.raises(ValueError, match="yaml"):
        save_map(m, tmp_path / "out.txt")
    with pytest.raises(ValueError, match="image_name"):
        save_map(m, tmp_path / "out.yaml", image_name="../x.pgm")
    # not a str: named, not pathlib's "expected str, bytes or os.PathLike object"
    with pytest.raises(TypeError, match=r"^image_name: expected a bare file name .*received int"):
        save_map(m, tmp_path / "out.yaml", image_name=3)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="OccupancyMap"):
        save_map(np.zeros((3, 3)), tmp_path / "out.yaml")  # type: ignore[arg-type]
    with pytest.raises(FileNotFoundError):
        save_map(m, tmp_path / "no_such_dir" / "out.yaml")
    # a folder where a file would go: refused before anything is written
    (tmp_path / "d.yaml").mkdir()
    with pytest.raises(IsADirectoryError, match=r"yaml_path: .*d\.yaml is a folder"):
        save_map(m, tmp_path / "d.yaml")
    (tmp_path / "e.pgm").mkdir()
    with pytest.raises(IsADirectoryError, match=r"image_name: .*e\.pgm is a folder"):
        save_map(m, tmp_path / "e.yaml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.yaml", "e.pgm"]
    # a YAML whose image is a folder says so
    (tmp_path / "f.yaml").write_text("image: e.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(ValueError, match="'image': expected an image file, received the folder"):
        load_map(tmp_path / "f.yaml")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
@pytest.mark.parametrize("absolute", [False, True])
def test_load_map_yaml_image_that_is_a_fifo_is_named_a_fifo(tmp_path: Path, absolute):
    # The image exists but is no regular file: reading it would wait for a writer for ever,
    # and "not found" would send the user looking for a file that is there.
    os.mkfifo(tmp_path / "pipe.pgm")
    image = tmp_path / "pipe.pgm" if absolute else "pipe.pgm"
    (tmp_path / "m.yaml").write_text(f"image: {image}\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(
        ValueError, match=r"'image': expected an image file, received the FIFO .*pipe\.pgm"
    ):
        load_map(tmp_path / "m.yaml")
    with pytest.raises(ValueError, match=r"not a regular file: .*pipe\.pgm is a FIFO"):
        load_map(tmp_path / "pipe.pgm")


@pytest.mark.parametrize("absolute", [False, True])
def test_load_map_yaml_image_that_is_a_symlink_loop_or_has_a_nul_says_so(tmp_path: Path, absolute):
    (tmp_path / "loop.pgm").symlink_to("loop.pgm")
    image = tmp_path / "loop.pgm" if absolute else "loop.pgm"
    (tmp_path / "m.yaml").write_text(f"image: {image}\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(ValueError) as info:
        load_map(tmp_path / "m.yaml")
    assert str(info.value) == (
        f"map YAML {tmp_path / 'm.yaml'}: field 'image': expected an image file, received "
        f"{tmp_path / 'loop.pgm'}, a loop of symbolic links"
    )
    (tmp_path / "n.yaml").write_text('image: "a\\0.pgm"\nresolution: 0.1\norigin: [0, 0, 0]\n')
    with pytest.raises(ValueError) as info:
        load_map(tmp_path / "n.yaml")
    assert str(info.value) == (
        f"map YAML {tmp_path / 'n.yaml'}: field 'image': expected a file name without a NUL "
        "character, received 'a\\x00.pgm'"
    )


def test_load_map_yaml_absolute_image_that_is_a_folder_is_named_a_folder(tmp_path: Path):
    (tmp_path / "img").mkdir()
    (tmp_path / "m.yaml").write_text(
        f"image: {tmp_path / 'img'}\nresolution: 0.1\norigin: [0, 0, 0]\n"
    )
    with pytest.raises(ValueError, match="'image': expected an image file, received the folder"):
        load_map(tmp_path / "m.yaml")


def test_pgm_writer_header_is_standard(tmp_path: Path):
    m = _small_map(h=3, w=4, resolution_m=0.05)
    save_map(m, tmp_path / "s.yaml")
    data = (tmp_path / "s.pgm").read_bytes()
    assert data.startswith(b"P5\n# CREATOR: ")
    lines = data.split(b"\n", 4)
    assert lines[2] == b"4 3" and lines[3] == b"255"
    assert len(lines[4]) == 12
    assert struct.unpack("12B", lines[4])[:4] == (0, 0, 0, 0)


def test_opencv_log_level_is_restored_after_overlapping_reads(tmp_path):
    """Unreadable images read from several threads at once: OpenCV's log level, silenced
    while they decode, is the caller's again afterwards."""
    from concurrent.futures import ThreadPoolExecutor

    bad = tmp_path / "bad.pgm"
    bad.write_bytes(b"P6\nnot a header at all")  # not P5: decoded by OpenCV
    before = cv2.utils.logging.getLogLevel()

    def read(_):
        with pytest.raises(ValueError, match="could not decode map image"):
            load_map(bad)

    with ThreadPoolExecutor(4) as pool:
        list(pool.map(read, range(40)))
    assert cv2.utils.logging.getLogLevel() == before != cv2.utils.logging.LOG_LEVEL_SILENT


def test_a_symlink_loop_or_a_dangling_link_says_what_it_is(tmp_path: Path):
    loop = tmp_path / "loop.yaml"
    loop.symlink_to("loop.yaml")
    with pytest.raises(ValueError) as info:
        load_map(loop)
    assert str(info.value) == f"map path is not a file: {loop}, a loop of symbolic links"
    dangling = tmp_path / "dangling.pgm"
    dangling.symlink_to("gone.pgm")
    with pytest.raises(FileNotFoundError) as info:
        load_map(dangling)
    assert str(info.value) == (
        f"map file not found: {dangling} (a symbolic link to gone.pgm, which does not exist)"
    )


@pytest.mark.parametrize("name", [".yaml", ".PGM"])
def test_a_map_file_named_only_by_its_suffix_is_said_to_have_no_stem(tmp_path: Path, name):
    path = tmp_path / name
    path.write_text("image: m.pgm\n")
    with pytest.raises(ValueError) as info:
        load_map(path)
    assert str(info.value) == (
        f"path: a file named only {name!r} has no stem (the part before the suffix); "
        f"expected a name such as 'map{name}', received {str(path)!r}"
    )
