"""The shared argument checks of ``topojax._validate``: good values (Python and NumPy),
bools refused as numbers, NaN / inf, wrong types, and messages that name the parameter."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from topojax import _validate as v

NAN, INF = float("nan"), float("inf")


# --------------------------------------------------------------------------------------
# real numbers
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("value", [0.5, 2, np.float32(0.5), np.float64(3.0), np.int64(4)])
def test_finite_positive_accepts_python_and_numpy_numbers(value):
    out = v.finite_positive("size", value)
    assert type(out) is float and out == float(value)


@pytest.mark.parametrize(
    ("value", "exc", "words"),
    [
        (True, TypeError, ["size", "real number", "bool"]),
        (np.bool_(True), TypeError, ["size", "real number"]),
        ("1", TypeError, ["size", "real number", "str"]),
        (None, TypeError, ["size", "real number", "NoneType"]),
        (0, ValueError, ["size", "> 0", "0"]),
        (-1.5, ValueError, ["size", "> 0", "-1.5"]),
        (NAN, ValueError, ["size", "finite", "nan"]),
        (INF, ValueError, ["size", "finite", "inf"]),
        (np.float64(-INF), ValueError, ["size", "finite", "inf"]),
    ],
)
def test_finite_positive_rejects(value, exc, words):
    with pytest.raises(exc) as info:
        v.finite_positive("size", value)
    for word in words:
        assert word in str(info.value), (word, str(info.value))


@pytest.mark.parametrize("value", [1.5, -3, np.float64(0.0), np.int8(2), np.array(2.5)])
def test_real_number_accepts_numbers_and_0d_arrays(value):
    out = v.real_number("angle", value)
    assert type(out) is float and out == float(value)


def test_real_number_infinity_only_when_allowed():
    assert v.real_number("range_max", INF, allow_inf=True) == INF
    assert v.real_number("range_max", np.float32(-INF), allow_inf=True) == -INF
    with pytest.raises(ValueError, match="range_max: expected a finite number, received inf"):
        v.real_number("range_max", INF)
    for allow_inf in (False, True):
        with pytest.raises(ValueError, match="range_max: expected .*received nan"):
            v.real_number("range_max", NAN, allow_inf=allow_inf)


@pytest.mark.parametrize("value", [True, np.bool_(True), "0", None, [1.0], np.array([1.0])])
def test_real_number_rejects_non_numbers_with_type_error(value):
    with pytest.raises(TypeError, match="^angle: expected a real number, received "):
        v.real_number("angle", value)


def test_is_real_number():
    for value in (1, 1.5, np.int32(1), np.float32(1.5), NAN, INF, np.array(2.5), np.array(3)):
        assert v.is_real_number(value), value
    for value in (True, np.bool_(True), np.array(True), "1", None, 1j, [1], np.array([1.0])):
        assert not v.is_real_number(value), value


@pytest.mark.parametrize("value", [2, 1.5, np.float32(1.5), np.int64(2), np.array(1.5)])
def test_the_three_real_number_checks_agree_on_numbers(value):
    assert v.is_real_number(value)
    assert v.real_number("size", value) == float(value)
    assert v.quantity("size", value, unit="", allow_zero=False) == float(value)


def test_a_jax_scalar_is_a_real_number():
    jnp = pytest.importorskip("jax.numpy")
    assert v.is_real_number(jnp.float32(1.5)) and v.real_number("x", jnp.float32(1.5)) == 1.5
    assert not v.is_real_number(jnp.array([1.5])) and not v.is_real_number(jnp.bool_(True))


@pytest.mark.parametrize("value", [True, np.bool_(False), np.array(True), "1", None, [1.0], 1j])
def test_the_three_real_number_checks_agree_on_non_numbers(value):
    assert not v.is_real_number(value)
    with pytest.raises(TypeError, match="^size: expected a real number, received "):
        v.real_number("size", value)
    with pytest.raises(TypeError, match="^size: expected a real number > 0, received "):
        v.quantity("size", value, unit="", allow_zero=False)


# --------------------------------------------------------------------------------------
# metres
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("value", [0.0, 0, 2.5, np.float32(0.25), np.int64(3)])
def test_nonnegative_metres_accepts_zero_and_more(value):
    out = v.nonnegative_metres("min_spur_m", value)
    assert type(out) is float and out == float(value)


def test_positive_metres_refuses_zero():
    assert v.positive_metres("tolerance_m", np.float64(0.1)) == 0.1
    with pytest.raises(ValueError, match=r"tolerance_m: expected a finite number of metres > 0"):
        v.positive_metres("tolerance_m", 0)


@pytest.mark.parametrize(
    ("value", "exc"),
    [(True, TypeError), ("1", TypeError), (None, TypeError), (-0.5, ValueError)]
    + [(NAN, ValueError), (INF, ValueError)],
)
def test_metres_rejects(value, exc):
    for check in (v.nonnegative_metres, v.positive_metres):
        with pytest.raises(exc, match=r"^d_m: expected a .*number of metres .*received"):
            check("d_m", value)


@pytest.mark.parametrize("value", [0.05, 1, np.float32(0.5), np.int64(2)])
def test_metres_per_pixel_accepts(value):
    assert v.metres_per_pixel("resolution", value) == float(value)


@pytest.mark.parametrize(
    ("value", "exc"),
    [
        (0, ValueError),
        (-0.1, ValueError),
        (NAN, ValueError),
        (INF, ValueError),
        (True, TypeError),
        (np.bool_(True), TypeError),
        ("0.05", TypeError),
        (None, TypeError),
    ],
)
def test_metres_per_pixel_rejects(value, exc):
    with pytest.raises(exc, match=r"^resolution: expected a (finite|real) number of metres per"):
        v.metres_per_pixel("resolution", value)


@pytest.mark.parametrize("value", [1e-300, 1e-7, 1e5])
def test_metres_per_pixel_keeps_to_the_range_of_map_resolutions(value):
    """A resolution below 1e-6 m/px is refused: at 1e-300 m/px a 0.3 m robot radius
    would be 3e299 pixels, which overflows float32 and gives an empty route graph with
    numpy warnings."""
    with pytest.raises(ValueError, match=r"^resolution: expected 1e-06 to 10000 metres per pixel"):
        v.metres_per_pixel("resolution", value)
    assert v.metres_per_pixel("resolution", 1e-6) == 1e-6


# --------------------------------------------------------------------------------------
# integers
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("value", [0, -4, 7, np.int8(3), np.uint64(5)])
def test_integer_accepts_python_and_numpy_ints(value):
    out = v.integer("count", value)
    assert type(out) is int and out == int(value)


@pytest.mark.parametrize("value", [True, np.bool_(False), 1.0, np.float64(2.0), "3", None])
def test_integer_rejects_non_ints_with_type_error(value):
    with pytest.raises(TypeError, match="^count: expected an int, received "):
        v.integer("count", value)


@pytest.mark.parametrize("value", [1, 9, np.int32(1), np.uint8(200)])
def test_positive_int_accepts(value):
    out = v.positive_int("workers", value)
    assert type(out) is int and out == int(value)


@pytest.mark.parametrize(
    ("value", "exc"),
    [
        (0, ValueError),
        (-1, ValueError),
        (np.int64(0), ValueError),
        (True, TypeError),
        (1.0, TypeError),
        ("2", TypeError),
        (None, TypeError),
        (NAN, TypeError),
    ],
)
def test_positive_int_rejects(value, exc):
    with pytest.raises(exc, match="^workers: expected an int >= 1, received "):
        v.positive_int("workers", value)


def test_int_at_least():
    assert v.int_at_least("tile_px", 8, 8) == 8
    assert v.int_at_least("workers", np.int64(0), 0) == 0
    assert type(v.int_at_least("workers", np.int64(3), 0)) is int
    for bad in (7, np.int16(-1)):
        with pytest.raises(ValueError, match=r"^tile_px: expected an int >= 8, received -?\d"):
            v.int_at_least("tile_px", bad, 8)
    for bad in (True, 8.0, "8", None):
        with pytest.raises(TypeError, match=r"^tile_px: expected an int >= 8, received [a-zA-Z]"):
            v.int_at_least("tile_px", bad, 8)


def test_the_int_checks_take_a_0d_integer_array_as_numpy_scalars_are_taken():
    jnp = pytest.importorskip("jax.numpy")
    for value in (np.array(3), np.array(3, dtype=np.uint8), jnp.array(3)):
        assert type(v.integer("count", value)) is int and v.integer("count", value) == 3
        assert v.int_at_least("workers", value, 1) == 3 and v.positive_int("n", value) == 3
    assert v.kernel_tile_px("tile_px", np.array(16)) == 16
    assert v.binary_flag("negate", np.array(1)) is True
    with pytest.raises(ValueError, match=r"^workers: expected an int >= 1, received 0$"):
        v.positive_int("workers", np.array(0))


@pytest.mark.parametrize("value", [np.array(True), np.array(3.0), np.array([3]), 3.0])
def test_the_int_checks_refuse_a_0d_bool_or_float_array_as_they_refuse_a_bool_or_float(value):
    for check in (v.integer, v.positive_int, v.kernel_tile_px):
        with pytest.raises(TypeError, match=r"^n: expected an int.*, received "):
            check("n", value)


@pytest.mark.parametrize("value", [np.array(3.0), np.array([3]), np.array([True]), 3.0])
def test_binary_flag_refuses_a_float_or_a_1d_array(value):
    with pytest.raises(TypeError, match=r"^negate: expected a bool or 0/1, received "):
        v.binary_flag("negate", value)


# --------------------------------------------------------------------------------------
# flags and choices
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "value", [True, False, np.bool_(True), np.bool_(False), np.array(True), np.array(False)]
)
def test_flag_accepts_python_and_numpy_bools_and_0d_bool_arrays(value):
    out = v.flag("plot", value)
    assert type(out) is bool and out == bool(value)


def test_flag_takes_a_0d_jax_bool_array_as_the_number_checks_take_a_0d_jax_number():
    jnp = pytest.importorskip("jax.numpy")
    assert v.flag("plot", jnp.array(True)) is True and v.flag("plot", jnp.array(False)) is False
    assert v.binary_flag("negate", jnp.array(True)) is True


@pytest.mark.parametrize(
    "value",
    [1, 0, np.int64(1), np.array(1), "yes", None, 1.0, np.array([True]), np.array("True")]
    + [type("bool_", (), {})()],
)
def test_flag_rejects_non_bools(value):
    with pytest.raises(TypeError, match="^plot: expected a bool, received "):
        v.flag("plot", value)


@pytest.mark.parametrize(
    "value", [True, False, 0, 1, np.int8(1), np.bool_(False), np.array(True), np.array(0)]
)
def test_binary_flag_accepts_bools_and_0_1(value):
    out = v.binary_flag("negate", value)
    assert type(out) is bool and out == bool(value)


@pytest.mark.parametrize(
    ("value", "exc"),
    [(2, ValueError), (-1, ValueError), (np.uint8(2), ValueError), (1.0, TypeError)]
    + [(np.float64(0.0), TypeError), ("1", TypeError), (None, TypeError)],
)
def test_binary_flag_rejects(value, exc):
    with pytest.raises(exc, match="^negate: expected a bool or 0/1, received "):
        v.binary_flag("negate", value)


def test_one_of_needs_a_listed_value():
    assert v.one_of("method", "zhang", ("zhang", "guo_hall")) == "zhang"
    assert v.one_of("method", np.str_("zhang"), ["zhang"]) == "zhang"
    for bad in ("Zhang", 1, None, b"zhang", ["zhang"], np.array(["zhang"])):
        with pytest.raises(ValueError, match=r"^method: expected one of \('zhang',.*received "):
            v.one_of("method", bad, ("zhang", "guo_hall"))
    with pytest.raises(ValueError, match=r"^method: expected one of \{'zhang'\}, received \["):
        v.one_of("method", ["zhang"], {"zhang"})


def test_one_of_allows_any_listed_value():
    assert v.one_of("map_mode", None, ("raw", None)) is None
    assert v.one_of("frame", "grid", ("world", "grid")) == "grid"
    with pytest.raises(ValueError, match=r"^frame: expected one of \('world', 'grid'\), received"):
        v.one_of("frame", "map", ("world", "grid"))


# --------------------------------------------------------------------------------------
# pairs, poses, thresholds
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("value", [(1, 2), [0.5, -1.5], np.array([1.0, 2.0]), (np.int8(1), 2.0)])
def test_finite_pair_accepts(value):
    out = v.finite_pair("start", value, "(x, y) in metres")
    assert out.dtype == np.float64 and out.shape == (2,)
    np.testing.assert_array_equal(out, np.asarray(value, dtype=np.float64))


@pytest.mark.parametrize(
    ("value", "exc"),
    [((1.0,), ValueError), ((1, 2, 3), ValueError), ((NAN, 0.0), ValueError)]
    + [((0.0, INF), ValueError), (np.zeros(3), ValueError)]
    + [("ab", TypeError), (None, TypeError), (5, TypeError), (np.array(5.0), TypeError)]
    + [((True, 1.0), TypeError), (("1", 2), TypeError), ([[1, 2]], TypeError)]
    + [(np.zeros((1, 2)), TypeError), (np.array([True, False]), TypeError)],
)
def test_finite_pair_rejects(value, exc):
    with pytest.raises(exc, match=r"^start: expected two finite numbers \(x, y\) in metres"):
        v.finite_pair("start", value, "(x, y) in metres")


@pytest.mark.parametrize("value", [{30.0, 5.0}, frozenset((30.0, 5.0)), {30.0: 0, 5.0: 1}])
def test_finite_pair_refuses_a_collection_without_order(value):
    """A set iterates in hash order: ``{30.0, 5.0}`` gave the start (5, 30), a route
    from the wrong point; a dict iterates its keys.  Neither says which number is x."""
    with pytest.raises(TypeError, match=r"^start: expected two finite numbers .*received"):
        v.finite_pair("start", value, "(x, y) in metres")
    with pytest.raises(TypeError, match=r"^origin: expected a sequence of 3 finite numbers"):
        v.pose("origin", {*value, 1.0}, bounded=False)


@pytest.mark.parametrize(
    "value",
    [(1, 2, 0.5), [0.0, 0.0, 0.0], np.array([1.0, 2.0, 3.0]), (np.float32(1), np.int8(2), 3)]
    + [np.arange(3)],
)
def test_pose_accepts_three_finite_numbers(value):
    out = v.pose("origin", value)
    assert out == tuple(float(x) for x in value)
    assert all(type(x) is float for x in out)


@pytest.mark.parametrize(
    ("value", "exc"),
    [((1, 2), ValueError), ((1, 2, 3, 4), ValueError), ((0, NAN, 0), ValueError)]
    + [((0, 0, INF), ValueError), ((True, 0, 0), TypeError), ((np.bool_(True), 0, 0), TypeError)]
    + [(("1", 0, 0), TypeError), ("123", TypeError), (5, TypeError), (None, TypeError)]
    + [(np.array(1.0), TypeError), (np.zeros((3, 1)), TypeError)],
)
def test_pose_rejects(value, exc):
    with pytest.raises(exc, match=r"^origin: expected a sequence of 3 finite numbers"):
        v.pose("origin", value)


def test_pose_refuses_an_origin_where_metres_no_longer_resolve():
    assert v.pose("origin", (-1e9, 6.1e6, 0.5)) == (-1e9, 6.1e6, 0.5)  # UTM-like: fine
    for value in ((1e300, 0, 0), (0, -2e9, 0)):
        with pytest.raises(ValueError, match=r"^origin: expected .* within 1e\+09 m of 0"):
            v.pose("origin", value)
        assert v.pose("pose", value, bounded=False) == tuple(float(x) for x in value)
    with pytest.raises(ValueError, match=r"^pose: expected a sequence of 3 finite numbers"):
        v.pose("pose", (0, 0, INF), bounded=False)
    # an unwrapped yaw is a heading; one where float64 no longer resolves angles is not
    assert v.pose("pose", (0, 0, -1e6), bounded=False) == (0.0, 0.0, -1e6)
    for bounded in (True, False):
        with pytest.raises(ValueError, match=r"^pose: .* yaw within 1e\+09 rad of 0.*1e\+20"):
            v.pose("pose", (0, 0, 1e20), bounded=bounded)
    with pytest.raises(TypeError, match=r"^pose: expected a sequence of 3 finite numbers"):
        v.pose("pose", (0, 0, "1"), bounded=False)


def test_occupancy_thresholds():
    assert v.occupancy_thresholds(0.65, np.float32(0.25)) == (0.65, 0.25)
    assert v.occupancy_thresholds(1, 0) == (1.0, 0.0)
    with pytest.raises(
        ValueError, match=r"^m\.yaml: free_thresh, occupied_thresh: expected 0 <= free_thresh"
    ):
        v.occupancy_thresholds(0.2, 0.3, where="m.yaml")
    with pytest.raises(ValueError, match=r"^occupied_thresh: expected a finite number"):
        v.occupancy_thresholds(NAN, 0.1)
    with pytest.raises(TypeError, match=r"^free_thresh: expected a finite number .*bool True"):
        v.occupancy_thresholds(0.6, True)
    with pytest.raises(TypeError, match=r"^m\.yaml: occupied_thresh: expected .*str '0\.6'"):
        v.occupancy_thresholds("0.6", 0.2, where="m.yaml")
    assert v.occupancy_thresholds(np.array(0.5), np.int64(0)) == (0.5, 0.0)


# --------------------------------------------------------------------------------------
# objects, images, files
# --------------------------------------------------------------------------------------


def test_names_subset():
    choices = ("a", "b", "c")
    assert v.names_subset("keep", ["c", "a", "c"], choices) == ("a", "c")
    assert v.names_subset("keep", (), choices) == ()
    for bad in ("ab", None, 3, np.array("a")):
        with pytest.raises(TypeError, match=r"^keep: expected an iterable of names from \('a'"):
            v.names_subset("keep", bad, choices)
    for bad in (["a", "d"], [1]):
        with pytest.raises(ValueError, match=r"^keep: expected names from \('a'.*received"):
            v.names_subset("keep", bad, choices)


def test_instance_of():
    class Settings:
        pass

    given = Settings()
    assert v.instance_of("config", given, Settings) is given
    assert v.instance_of("n", np.int64(3), (int, np.integer)) == 3
    with pytest.raises(TypeError, match="^config: expected a Settings, received str$"):
        v.instance_of("config", "paper", Settings)
    with pytest.raises(TypeError, match="^n: expected an int or integer, received float$"):
        v.instance_of("n", 1.5, (int, np.integer))
    with pytest.raises(TypeError, match="^map: expected an occupancy map, received NoneType$"):
        v.instance_of("map", None, Settings, "occupancy map")


def test_nx_graph():
    import networkx as nx

    for g in (nx.Graph(), nx.MultiGraph()):
        assert v.nx_graph("graph", g) is g
    for g in (nx.DiGraph(), nx.MultiDiGraph()):
        assert v.nx_graph("graph", g, undirected=False) is g
        message = f"^graph: expected an undirected networkx graph, received {type(g).__name__}$"
        with pytest.raises(TypeError, match=message):
            v.nx_graph("graph", g)
    for bad in (None, {}, [(0, 1)]):
        with pytest.raises(TypeError, match="^g: expected a networkx graph, received "):
            v.nx_graph("g", bad, undirected=False)
    assert isinstance(v.nx_graph("graph", nx.MultiGraph(), multigraph=True), nx.MultiGraph)
    for bad in (nx.Graph(), nx.MultiDiGraph(), "g"):
        with pytest.raises(TypeError, match="^graph: expected an undirected networkx.MultiGraph"):
            v.nx_graph("graph", bad, multigraph=True)


def test_instance_or_default():
    class Settings:
        pass

    assert isinstance(v.instance_or_default("config", None, Settings), Settings)
    given = Settings()
    assert v.instance_or_default("config", given, Settings) is given
    with pytest.raises(TypeError, match="^config: expected a Settings, received str"):
        v.instance_or_default("config", "paper", Settings)


def test_binary_image():
    out = v.binary_image("mask", [[0, 2], [0.5, 0]])
    assert out.dtype == np.bool_ and out.flags.c_contiguous
    assert out.tolist() == [[False, True], [True, False]]
    src = np.zeros((3, 4), bool)[:, ::2]
    assert v.binary_image("mask", src).flags.c_contiguous
    with pytest.raises(TypeError, match="^mask: expected a 2-D array of bool or real numbers"):
        v.binary_image("mask", np.array([["a"]]))
    with pytest.raises(TypeError, match="^mask: .* received dtype complex128"):
        v.binary_image("mask", np.ones((2, 2), complex))
    with pytest.raises(
        ValueError, match=r"^mask: expected a 2-D array \(H, W\), received shape \(3,\)"
    ):
        v.binary_image("mask", np.zeros(3))
    with pytest.raises(ValueError, match="^mask contains NaN"):
        v.binary_image("mask", np.array([[math.nan, 0.0]]))


def test_non_file_kind_names_what_is_there_when_it_is_no_regular_file(tmp_path):
    (tmp_path / "f").write_text("x")
    from topojax._filekind import non_file_kind, the_non_file

    assert non_file_kind(tmp_path / "f") is None
    assert non_file_kind(tmp_path / "missing") is None
    assert non_file_kind(tmp_path) == "a folder"
    assert the_non_file(tmp_path) == "the folder"
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "pipe")
        assert non_file_kind(tmp_path / "pipe") == "a FIFO"
        assert the_non_file(tmp_path / "pipe") == "the FIFO"


def test_existing_file(tmp_path):
    f = tmp_path / "log.txt"
    f.write_text("x")
    assert v.existing_file("path", str(f)) == f
    with pytest.raises(FileNotFoundError, match="^path: file not found: .*nope"):
        v.existing_file("path", tmp_path / "nope")
    with pytest.raises(ValueError, match=r"^path: expected a file, received the folder .*"):
        v.existing_file("path", tmp_path)
    if hasattr(os, "mkfifo"):  # a named pipe is named as one, not "a directory or ..."
        os.mkfifo(tmp_path / "pipe")
        with pytest.raises(ValueError, match=r"^path: expected a file, received the FIFO .*pipe"):
            v.existing_file("path", tmp_path / "pipe")
    for bad in (None, 5, b"log.txt"):
        with pytest.raises(TypeError, match=r"^path: expected a path \(str or os.PathLike\)"):
            v.existing_file("path", bad)


@pytest.mark.parametrize("value", [0, 0.0, 2.5, np.float32(1.5), np.int64(3)])
def test_nonnegative_quantity_accepts(value):
    got = v.nonnegative_quantity("area_m2", value, "square metres")
    assert got == float(value) and type(got) is float


@pytest.mark.parametrize(
    ("value", "exc"),
    [
        (-1.0, ValueError),
        (float("nan"), ValueError),
        (float("inf"), ValueError),
        (True, TypeError),
        ("1", TypeError),
        (None, TypeError),
    ],
)
def test_nonnegative_quantity_refuses_naming_the_unit(value, exc):
    with pytest.raises(exc, match=r"^area_m2: expected a (finite|real) number of square metres"):
        v.nonnegative_quantity("area_m2", value, "square metres")


@pytest.mark.parametrize(
    ("unit", "allow_zero", "value", "exc", "message"),
    [
        (
            "m2",
            True,
            -1.0,
            ValueError,
            r"^area_m2: expected a finite number of m2 >= 0, received -1.0$",
        ),
        ("", False, 0.0, ValueError, r"^area_m2: expected a finite number > 0, received 0.0$"),
        ("", False, float("inf"), ValueError, r"^area_m2: expected a finite number > 0"),
        (
            "m2",
            True,
            "1",
            TypeError,
            r"^area_m2: expected a real number of m2 >= 0, received str '1'$",
        ),
        ("", True, True, TypeError, r"^area_m2: expected a real number >= 0, received bool True$"),
    ],
)
def test_quantity_names_the_unit_or_none(unit, allow_zero, value, exc, message):
    assert v.quantity("area_m2", np.float32(2.5), unit=unit, allow_zero=allow_zero) == 2.5
    assert v.quantity("area_m2", 0, unit=unit, allow_zero=True) == 0.0
    with pytest.raises(exc, match=message):
        v.quantity("area_m2", value, unit=unit, allow_zero=allow_zero)


def test_path_like(tmp_path):
    assert v.path_like("out_dir", str(tmp_path)) == tmp_path
    assert v.path_like("out_dir", tmp_path / "x") == tmp_path / "x"
    for bad in (None, 5, ["a"]):
        with pytest.raises(
            TypeError, match=r"^out_dir: expected a path \(str or os.PathLike\), received"
        ):
            v.path_like("out_dir", bad)
    # an empty path is the current folder to pathlib: a store, graph or picture would
    # land there unasked
    for empty in ("", type("P", (), {"__fspath__": lambda self: ""})()):
        with pytest.raises(ValueError, match=r"^out_dir: expected a path, received an empty"):
            v.path_like("out_dir", empty)


def test_text_or_none(tmp_path):
    assert v.text_or_none("title", None) is None
    assert v.text_or_none("title", "intel") == "intel"
    assert v.text_or_none("title", np.str_("intel")) == "intel"
    assert v.text_or_none("source", tmp_path / "m.pgm", paths=True) == str(tmp_path / "m.pgm")
    assert v.text_or_none("source", "s3://maps//a.pgm", paths=True) == "s3://maps//a.pgm"
    for bad in (True, 3, math.nan, ["a"], object(), b"m.pgm", tmp_path):
        with pytest.raises(TypeError, match=r"^title: expected a str or None, received "):
            v.text_or_none("title", bad)
    for bad in (True, 3, ["a"], b"m.pgm"):
        with pytest.raises(
            TypeError, match=r"^source: expected a str, an os.PathLike or None, received "
        ):
            v.text_or_none("source", bad, paths=True)


def test_pixel_rows():
    assert v.pixel_rows("p", (3, 4), one=True).tolist() == [3, 4]
    assert v.pixel_rows("p", (3.0, 4.0), one=True).dtype == np.int64  # whole floats
    assert v.pixel_rows("p", (3, 4)).tolist() == [[3, 4]]
    assert v.pixel_rows("p", [[1, 2], [3, 4]]).shape == (2, 2)
    with pytest.raises(TypeError, match=r"^p: expected \(row, col\) pixels as integers, .* str"):
        v.pixel_rows("p", "ab")
    with pytest.raises(TypeError, match=r"^p: .* received list of dtype object"):
        v.pixel_rows("p", [[1, 2], [3]])  # ragged
    with pytest.raises(ValueError, match=r"^p: .* shape \(2,\), received shape \(2, 2\)"):
        v.pixel_rows("p", [[1, 2], [3, 4]], one=True)
    with pytest.raises(ValueError, match=r"^p: .* received shape \(0, 2\)"):
        v.pixel_rows("p", np.zeros((0, 2), int))
    for bad, shown in ((1.5, "1.5"), (math.nan, "nan"), (math.inf, "inf")):
        with pytest.raises(ValueError, match=rf"^p: .* received {shown} among them"):
            v.pixel_rows("p", (bad, 2.0), one=True)


def test_point_rows():
    out = v.point_rows("xy", [[1, 2], [3.5, np.nan]])
    assert out.dtype == np.float64 and out.shape == (2, 2) and np.isnan(out[1, 1])
    assert v.point_rows("xy", []).shape == (0, 2)  # no points
    assert v.point_rows("xy", np.zeros((0, 2), np.float32)).shape == (0, 2)
    for bad, shown in [(None, "NoneType of dtype object"), ("ab", "str of dtype <U2")] + [
        ([[1j, 0]], "list of dtype complex128"),
        ([[True, False]], r"list of dtype bool \(a mask\?"),
        ([[1, 2], [3]], r"list that makes no array \(rows of different lengths\?\)"),
    ]:
        with pytest.raises(TypeError, match=r"^xy: expected an \(N, 2\) array .*received " + shown):
            v.point_rows("xy", bad)
    for bad, shown in ((np.ones((3, 3)), r"\(3, 3\)"), (5.0, r"\(\)"), ([1.0, 2.0], r"\(2,\)")):
        with pytest.raises(
            ValueError, match=r"^xy: expected an \(N, 2\) array .* of shape " + shown
        ):
            v.point_rows("xy", bad)


def test_float32_finite_refuses_what_float32_turns_into_an_infinity():
    top = float(np.finfo(np.float32).max)
    for ok in (0.0, -top, top, 1e38):
        assert v.float32_finite("scale", ok) == ok
    for bad in (1e39, -1e39, np.nextafter(top, math.inf)):
        with pytest.raises(
            ValueError, match=r"^scale: expected a number at most 3\.40282e\+38 in magnitude "
        ):
            v.float32_finite("scale", bad)


def test_every_exported_check_is_tested():
    tested = {
        "binary_flag", "binary_image", "existing_file", "finite_numbers", "finite_pair",
        "finite_positive", "flag", "float32_finite", "instance_of", "instance_or_default", "int_at_least",
        "integer", "is_real_number", "kernel_tile_px", "kernel_tiles_per_call", "masked_entries", "real_array", "metres", "metres_per_pixel", "names_subset", "nonnegative_metres", "nx_graph",
        "nonnegative_quantity", "occupancy_thresholds", "one_of", "path_like", "pixel_rows", "plain_int_pair", "point_rows", "plain_length_m", "pose", "positive_int", "positive_metres",
        "quantity", "real_number", "real_values", "robot_radius", "text_or_none", "unmasked", "xy_points",
    }  # fmt: skip
    assert set(v.__all__) == tested


@pytest.mark.parametrize("value", [0, 0.0, 2, 1.5, 1e300])
def test_a_plain_length_is_a_python_number_finite_and_not_negative(value):
    assert v.plain_length_m(value)


@pytest.mark.parametrize(
    "value", [-0.5, -1, math.nan, math.inf, True, "1.0", None, np.float64(1.0), [1.0]]
)
def test_anything_else_is_not_a_plain_length_and_goes_to_the_full_check(value):
    """NumPy numbers are lengths too, but checked (and converted) by nonnegative_metres."""
    assert not v.plain_length_m(value)


def test_a_plain_int_pair_is_a_tuple_of_two_python_ints():
    assert v.plain_int_pair((3, 4))
    for value in ([3, 4], (3,), (3, 4, 5), (3.0, 4), (np.int64(3), 4), (True, 4), "34", None):
        assert not v.plain_int_pair(value)


def test_xy_points_are_finite_pairs_at_least_min_points_of_them():
    np.testing.assert_array_equal(v.xy_points([[1, 2], [3, 4]], "w"), [[1.0, 2.0], [3.0, 4.0]])
    assert v.xy_points([[1, 2]], "w").dtype == np.float64
    cases = [
        ("abc", r"^w: expected finite \(x, y\) points of shape \(K, 2\), K >= 1, received 'abc'$"),
        ([[1, 2], [3]], r"^w: expected finite .* K >= 1, received \[\[1, 2\], \[3\]\]$"),
        ([1, 2], r"^w: expected finite .* received \[1, 2\] of shape \(2,\)$"),
        (np.zeros((0, 2)), r"^w: expected finite .* of shape \(0, 2\)$"),
        ([[1, np.inf]], r"^w: expected finite \(x, y\) points, received 1 value\(s\) that are not"),
    ]
    for value, words in cases:
        with pytest.raises(ValueError, match=words):
            v.xy_points(value, "w")
    with pytest.raises(ValueError, match=r"^w: expected finite .* K >= 2, received"):
        v.xy_points([[1, 2]], "w", min_points=2)


def test_robot_radius_is_metres_up_to_a_kilometre():
    assert v.robot_radius("r", 0) == 0.0
    assert v.robot_radius("r", v.MAX_ROBOT_RADIUS_M) == 1000.0
    with pytest.raises(ValueError, match=r"^r: expected a robot radius of at most 1000 m"):
        v.robot_radius("r", 1000.5)
    with pytest.raises(ValueError, match="^r: "):
        v.robot_radius("r", -0.1)
    with pytest.raises(TypeError, match="^r: "):
        v.robot_radius("r", "0.3")


def test_metres_per_pixel_refuses_resolutions_whose_squares_overflow():
    assert v.metres_per_pixel("resolution", v.MAX_RESOLUTION_M) == v.MAX_RESOLUTION_M
    with pytest.raises(ValueError, match="resolution: expected 1e-06 to 10000 metres per pixel"):
        v.metres_per_pixel("resolution", 1e308)


@pytest.mark.parametrize(
    ("call", "exc", "message"),
    [
        (lambda tj: tj.load_map(5), TypeError, "path: expected a path"),
        (lambda tj: list(tj.read_scans(None)), TypeError, "path: expected a path"),
        (
            lambda tj: tj.assign_rooms(None, None),
            TypeError,
            "graph: expected a networkx graph, received NoneType",
        ),
        (
            lambda tj: tj.Timeline().record(None, None),
            TypeError,
            "mapper: expected an IncrementalMapper, received NoneType",
        ),
        # a tile of 2^20 px a side would ask for a terabyte before anything is mapped
        (
            lambda tj: tj.IncrementalMapper(tile_px=2**20),
            ValueError,
            "tile_px: expected a value <= 4096",
        ),
        (
            lambda tj: tj.OccupancyMap.from_array(np.zeros((4, 4), bool), resolution_m=1e308),
            ValueError,
            "resolution_m: expected 1e-06 to 10000",
        ),
    ],
)
def test_public_functions_name_a_bad_argument(call, exc, message):
    import topojax as tj

    with pytest.raises(exc, match=message):
        call(tj)


# --------------------------------------------------------------------------------------
# kernel tiles
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "exc", "received"),
    [(7, ValueError, "7"), (4097, ValueError, "4097"), (True, TypeError, "bool True")],
)
def test_kernel_tile_px_range(value, exc, received):
    assert v.kernel_tile_px("tile_px", np.int16(8)) == 8
    with pytest.raises(
        exc, match=rf"^tile_px: expected an int in \[8, 4096\], received {received}"
    ):
        v.kernel_tile_px("tile_px", value)


def test_kernel_tiles_per_call_caps_the_pixels_of_a_call():
    assert v.kernel_tiles_per_call("tiles_per_call", 4096, 256) == 4096
    with pytest.raises(ValueError, match=r"^tiles_per_call: expected an int from 1 to 4096 "):
        v.kernel_tiles_per_call("tiles_per_call", 4097, 256)
    with pytest.raises(ValueError, match=r"^tiles_per_call: expected an int >= 1, received 0"):
        v.kernel_tiles_per_call("tiles_per_call", 0, 256)


def test_real_values_turns_ml_dtypes_floats_into_float32():
    ml_dtypes = pytest.importorskip("ml_dtypes")
    for dtype in (ml_dtypes.bfloat16, ml_dtypes.float8_e4m3fn):
        out = v.real_values(np.array([1.5, -2.0, 0.25], dtype))
        assert out.dtype == np.float32 and out.tolist() == [1.5, -2.0, 0.25]
    assert np.isinf(v.real_values(np.array([np.inf], ml_dtypes.bfloat16))).all()
    for kept in (
        np.ones(2, np.float16),
        np.ones(2, np.int8),
        np.zeros(2, "V4"),
        np.zeros(2, [("a", "f4")]),
    ):
        assert v.real_values(kept) is kept


def test_real_values_turns_ml_dtypes_integers_into_8_bit_ones():
    ml_dtypes = pytest.importorskip("ml_dtypes")
    for dtype, eight, values in (
        (ml_dtypes.int4, np.int8, [-8, 0, 7]),
        (ml_dtypes.uint4, np.uint8, [0, 1, 15]),
    ):
        out = v.real_values(np.array(values, dtype))
        assert out.dtype == eight and out.tolist() == values
    four = np.asarray(3, ml_dtypes.int4)
    assert v.integer("n", four) == 3 and v.real_number("x", four) == 3.0
    assert v.real_array("x", np.array([-8, 7], ml_dtypes.int4)).tolist() == [-8.0, 7.0]
    assert v.binary_image("image", np.array([[0, 1]], ml_dtypes.uint4)).tolist() == [[False, True]]
    with pytest.raises(TypeError, match="^f: expected a bool, received"):
        v.flag("f", np.asarray(1, ml_dtypes.uint4))


def test_the_real_number_checks_take_jax_bfloat16_arrays():
    jnp = pytest.importorskip("jax.numpy")
    bf = jnp.asarray([[1.0, 2.5], [3.0, -4.0]], jnp.bfloat16)
    assert v.real_array("x", bf).tolist() == [[1.0, 2.5], [3.0, -4.0]]
    assert v.real_array("x", bf).dtype == np.float64
    assert v.point_rows("xy", bf).dtype == np.float64
    assert v.pixel_rows("p", bf[0, :1].repeat(2)).tolist() == [[1, 1]]
    assert v.binary_image("image", bf).all()
    with pytest.raises(ValueError, match=r"^p: expected .* received 2\.5 among them"):
        v.pixel_rows("p", bf[0])


def test_a_jax_bfloat16_scalar_is_a_real_number_and_not_a_bool():
    jnp = pytest.importorskip("jax.numpy")
    for scalar in (jnp.asarray(0.5, jnp.bfloat16), jnp.bfloat16(0.5)):
        assert v.is_real_number(scalar) and v.real_number("angle_min", scalar) == 0.5
    assert v.pose("pose", jnp.asarray([1.0, 2.0, 0.5], jnp.bfloat16)) == (1.0, 2.0, 0.5)
    with pytest.raises(TypeError, match="^f: expected a bool, received"):
        v.flag("f", jnp.asarray(1.0, jnp.bfloat16))


def test_real_array_refuses_what_numpy_would_turn_into_nan_or_fail_on():
    out = v.real_array("rows", [1, 2.5])
    assert out.dtype == np.float64 and out.tolist() == [1.0, 2.5]
    assert v.real_array("rows", np.int32(3)).shape == ()
    assert math.isnan(v.real_array("rows", NAN))  # NaN is a float unless finite=True
    for bad in (None, "1", [True], [object()]):
        with pytest.raises(TypeError, match="^rows: expected a number or an array of real"):
            v.real_array("rows", bad)
    with pytest.raises(ValueError, match=r"^x: expected finite numbers, received inf among"):
        v.real_array("x", [0.0, INF], finite=True)


def test_finite_numbers():
    assert v.finite_numbers("region", (0, np.int8(1), 2.5, np.float32(3)), 4, "(a, b, c, d)") == (
        0.0,
        1.0,
        2.5,
        3.0,
    )
    with pytest.raises(ValueError, match=r"^region: expected 4 finite numbers \(a\), received"):
        v.finite_numbers("region", (0, 1, 2), 4, "(a)")
    with pytest.raises(TypeError, match=r"^region: expected 4 finite numbers \(a\), received str"):
        v.finite_numbers("region", "0123", 4, "(a)")


MASKED = np.ma.masked_array([1.0, 2.0, 3.0], mask=[False, True, False])


def test_masked_entries_are_those_of_a_masked_array_with_one():
    assert v.masked_entries(MASKED).tolist() == [False, True, False]
    assert v.masked_entries(np.ma.masked).tolist() is True  # the masked constant, 0-d
    for plain in ([1.0, 2.0], np.ones(3), np.ma.masked_array([1.0, 2.0]), 1.0, None):
        assert v.masked_entries(plain) is None


def test_unmasked_fills_the_masked_entries_or_refuses_naming_the_argument():
    out = v.unmasked("ranges", MASKED, fill=math.nan)
    assert type(out) is np.ndarray and out[[0, 2]].tolist() == [1.0, 3.0] and np.isnan(out[1])
    as_int = np.ma.masked_array([4, 5], mask=[True, False], dtype=np.uint16)
    filled = v.unmasked("ranges", as_int, fill=math.nan)
    assert filled.dtype == np.float64 and np.isnan(filled[0]) and filled[1] == 5.0
    assert v.unmasked("grid", as_int, fill=0).tolist() == [0, 5]
    assert MASKED.mask.tolist() == [False, True, False]  # the argument is not changed
    whole = np.ma.masked_array([1.0, 2.0], mask=False)
    assert type(v.unmasked("x", whole)) is np.ndarray
    plain = [1.0, 2.0]
    assert v.unmasked("x", plain) is plain
    with pytest.raises(
        TypeError,
        match=r"^x: expected an array without masked entries, received a masked array "
        r"with 1 of 3 entries masked .*call \.filled\(value\)",
    ):
        v.unmasked("x", MASKED)


def test_the_array_and_number_checks_refuse_masked_values_numpy_would_read_through():
    for check in (
        lambda: v.real_array("x", MASKED),
        lambda: v.pixel_rows("p", np.ma.masked_array([[1, 2]], mask=[[0, 1]])),
        lambda: v.binary_image("mask", np.ma.masked_array(np.ones((2, 2)), mask=np.eye(2))),
    ):
        with pytest.raises(TypeError, match=r"^(x|p|mask): expected an array without masked"):
            check()
    with pytest.raises(TypeError, match=r"^graph: edge 'world': expected an array without"):
        v.xy_points(np.ma.masked_array([[1.0, 2.0]], mask=[[1, 0]]), "graph: edge 'world'")
    with pytest.raises(TypeError, match=r"^origin_xy: expected two finite .*1 of 2 entries"):
        v.finite_pair("origin_xy", np.ma.masked_array([0.0, 5.0], mask=[0, 1]), "(x, y)")
    with pytest.raises(TypeError, match=r"^pose: expected a sequence of 3 finite numbers"):
        v.pose("pose", np.ma.masked_array([0.0, 1.0, 2.0], mask=[0, 0, 1]))
    with pytest.raises(TypeError, match=r"^timestamp: expected a real number"):
        v.real_number("timestamp", np.ma.masked)
    assert v.real_number("t", np.ma.masked_array(2.5, mask=False)) == 2.5
    rows = v.point_rows("xy", np.ma.masked_array([[1.0, 2.0], [3.0, 4.0]], mask=[[0, 0], [0, 1]]))
    assert rows[0].tolist() == [1.0, 2.0] and rows[1, 0] == 3.0 and np.isnan(rows[1, 1])
